//! Where a camera looks (`kincal::view_point`): the least-squares point where the viewing
//! axes of a set of camera poses converge, with the distances along the axes and how closely
//! the axes pass it, and a pose moved to a point given in its own frame (a measured pose
//! re-expressed at the point the camera looks at; see docs/real-data.md "Camera poses: where
//! the position is measured").

use kincal::pose::Transform;
use kincal::view_point::{Axis, moved_to_point, view_point_from};

use crate::status::{KINCAL_NO_INDEX, kincal_error, kincal_status};

/// A frame axis: the viewing direction of a camera frame (`KINCAL_AXIS_Z` for the optical
/// frame of OpenCV, ROS `*_optical_frame` and most calibration toolboxes). Passed as a
/// `uint32_t`.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_axis {
    /// The frame's x axis.
    X = 0,
    /// The frame's y axis.
    Y = 1,
    /// The frame's z axis.
    Z = 2,
}

/// The result of `kincal_view_point`: where the viewing axes of a set of poses converge (the
/// `_result` suffix: in C a type cannot share the function's name).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_view_point_result {
    /// The point nearest (least squares) to every viewing axis, in the frame the poses are
    /// given in [m].
    pub point_m: [f64; 3],
    /// Mean distance from the frame origins to the point, measured along each axis [m]: the
    /// re-expression distance `s` (the point `s·e_axis` of every frame).
    pub mean_distance_m: f64,
    /// Smallest distance along an axis [m] (negative: the point lies behind that frame).
    pub min_distance_m: f64,
    /// Largest distance along an axis [m].
    pub max_distance_m: f64,
    /// RMS over the poses of the point's distance from each viewing axis [m].
    pub miss_rms_m: f64,
    /// Largest distance of the point from a viewing axis [m].
    pub miss_max_m: f64,
    /// Index (zero-based) of the pose whose axis passes farthest from the point.
    pub miss_max_pose: usize,
}

fn axis_of(v: u32) -> Result<Axis, kincal_error> {
    match v {
        0 => Ok(Axis::X),
        1 => Ok(Axis::Y),
        2 => Ok(Axis::Z),
        _ => Err(kincal_error::new(kincal_status::InvalidArgument)
            .arg(c"axis")
            .value(f64::from(v))),
    }
}

/// Pose `l` of the column-major stack `poses` (validated: finite and rigid); errors name
/// the pose and give the element index within `poses`.
fn pose_at(poses: &[f64], l: usize) -> Result<Transform, kincal_error> {
    let m = poses
        .get(16 * l..16 * (l + 1))
        .ok_or(kincal_error::new(kincal_status::Internal))?;
    crate::pose::from_matrix(m, c"poses").map_err(|mut e| {
        if e.index != KINCAL_NO_INDEX {
            e.index += 16 * l;
        }
        e.pose = l;
        e
    })
}

/// The point where the `axis` directions of `n_poses` poses (lines through each frame
/// origin) converge, least squares: `min_c Σ |(I − dᵢ·dᵢᵀ)(c − pᵢ)|²` with `pᵢ` the origin
/// and `dᵢ` the unit `axis` of pose i; with the distances along the axes and how closely
/// the axes pass the point (a set whose camera did not look at one place shows a large
/// miss). Nothing is allocated: the poses are read twice.
///
/// - `poses`, `poses_len`: `n_poses` 4×4 column-major rigid transforms one after the other
///   (pose l at `poses[16*l]`), all in one frame; `poses_len` = 16·`n_poses`.
/// - `n_poses`: at least 2.
/// - `axis`: a `kincal_axis`, the viewing direction in each frame.
/// - `view_point_out`: written on success only.
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, TOO_FEW_DATA (fewer than 2
/// poses), NON_FINITE or INVALID_TRANSFORM (`pose`, and `index` within `poses` for a
/// non-finite value), INVALID_ARGUMENT (`axis`) or RANK_DEFICIENT (axes parallel within
/// 1e-9 of the eigenvalue ratio of `Σ (I − d·dᵀ)`: no point is determined; `found` = rank).
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_view_point(
    poses: *const f64,
    poses_len: usize,
    n_poses: usize,
    axis: u32,
    view_point_out: *mut kincal_view_point_result,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let out = arg_out1!(view_point_out);
        let a = axis_of(axis)?;
        if n_poses < 2 {
            return Err(kincal_error::new(kincal_status::TooFewData)
                .arg(c"n_poses")
                .counts(2, n_poses));
        }
        let expected = n_poses
            .checked_mul(16)
            .ok_or_else(|| crate::args::bad_length(c"poses", usize::MAX, poses_len))?;
        let p = arg_slice!(poses, poses_len, expected);
        for l in 0..n_poses {
            pose_at(p, l)?;
        }
        // Every pose validated above: the fallback is never taken.
        let v = view_point_from(
            n_poses,
            |l| pose_at(p, l).unwrap_or(kincal::fixed3::IDENTITY_TRANSFORM),
            a,
        )?;
        let r = kincal_view_point_result {
            point_m: v.point_m,
            mean_distance_m: v.mean_distance_m,
            min_distance_m: v.min_distance_m,
            max_distance_m: v.max_distance_m,
            miss_rms_m: v.miss_rms_m,
            miss_max_m: v.miss_max_m,
            miss_max_pose: v.miss_max_pose,
        };
        let [x, y, z] = r.point_m;
        crate::args::finite_result(
            &[x, y, z, r.mean_distance_m, r.min_distance_m, r.max_distance_m, r.miss_rms_m,
              r.miss_max_m],
            c"view_point_out",
        )?;
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(r) };
        Ok(())
    })
}

/// `t·Trans(point)`: the same rigid body's frame moved (not rotated) to `point`, given in
/// that frame [m]; the pose a measurement row with measured point `point` carries. With
/// `point` = `(0, 0, s)` and `s` = `kincal_view_point_result.mean_distance_m`, a camera pose moved to
/// the point it looks at.
///
/// - `t`, `t_len`: a 4×4 column-major rigid transform, 16 doubles.
/// - `point`, `point_len`: 3 doubles [m].
/// - `t_out`, `t_out_len`: the moved pose, 16 doubles; written on success only, may overlap
///   the inputs.
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE or
/// INVALID_TRANSFORM.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_moved_to_point(
    t: *const f64,
    t_len: usize,
    point: *const f64,
    point_len: usize,
    t_out: *mut f64,
    t_out_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let pose = crate::pose::from_matrix(arg_slice!(t, t_len, 16), c"t")?;
        let p = arg_f64s!(point, point_len, 3);
        let point3 = [
            p.first().copied().unwrap_or(0.0),
            p.get(1).copied().unwrap_or(0.0),
            p.get(2).copied().unwrap_or(0.0),
        ];
        let out = arg_out!(t_out, t_out_len, 16);
        let m = crate::pose::to_matrix(&moved_to_point(&pose, &point3));
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&m) }?;
        Ok(())
    })
}
