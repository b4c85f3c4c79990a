//! A robot from its joint axes at the zero configuration (URDF, CAD, circle point analysis),
//! converted to the Hayati/mDH model by the core (`kincal::axis_chain`).

use kincal::JointLimits;
use kincal::axis_chain::{AxisChain, JointAxis};
use kincal::pose::Transform;

use crate::robot::{KINCAL_MAX_JOINTS, from_robot, kincal_robot};
use crate::status::{FfiResult, kincal_error, kincal_status};

fn build<const N: usize>(
    points: &[f64],
    directions: &[f64],
    t_ref_base: Transform,
    t_ref_tool: Transform,
    limits: &[f64],
) -> FfiResult<kincal_robot> {
    let mut axes = [JointAxis::new([0.0; 3], [0.0, 0.0, 1.0]); N];
    for ((a, p), u) in axes
        .iter_mut()
        .zip(points.as_chunks::<3>().0)
        .zip(directions.as_chunks::<3>().0)
    {
        *a = JointAxis::new(*p, *u);
    }
    let mut lims = [JointLimits::new(0.0, 0.0); N];
    for (l, &[lo, hi]) in lims.iter_mut().zip(limits.as_chunks::<2>().0) {
        *l = JointLimits::new(lo, hi);
    }
    let chain = AxisChain {
        t_ref_base,
        axes,
        t_ref_tool,
    };
    let robot = chain.to_robot(lims).map_err(|e| match e {
        kincal::Error::InvalidLimits { .. } => kincal_error::from(e).arg(c"limits"),
        kincal::Error::DegenerateAxis { .. } => kincal_error::from(e).arg(c"directions"),
        _ => kincal_error::from(e),
    })?;
    from_robot(&robot)
}

/// Builds a robot from its N revolute joint axes at q = 0, all given in one reference frame:
/// the mDH links, d/β choices (β for parallel consecutive axes), base and tool frames are
/// computed so that the model's FK equals the chain's product of exponentials
/// `T_base_tool(q) = T_ref_base⁻¹ · Rot(p_1, u_1, q_1) ··· Rot(p_N, u_N, q_N) · T_ref_tool`
/// to rounding. No masses, no effects; this geometry is also the nominal one.
///
/// - `robot_out`: written on success only; need not be initialised.
/// - `n_joints`: 1..=`KINCAL_MAX_JOINTS`.
/// - `points`, `points_len`: a point on each axis [m], N × 3 doubles.
/// - `directions`, `directions_len`: each axis direction, N × 3 doubles (positive rotation is
///   right-handed about it; normalised, must not be zero).
/// - `t_ref_base`, `t_ref_base_len`: the robot's base frame in the reference frame (16 doubles,
///   4×4 column-major), or NULL for identity.
/// - `t_ref_tool`, `t_ref_tool_len`: the tool (flange) frame in the reference frame at q = 0,
///   or NULL for identity.
/// - `limits`, `limits_len`: `[lower, upper]` per joint [rad], 2N doubles.
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_JOINT_COUNT, BAD_LENGTH, NON_FINITE,
/// INVALID_TRANSFORM, DEGENERATE_AXIS (`joint`) or INVALID_LIMITS.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_from_axes(
    robot_out: *mut kincal_robot,
    n_joints: usize,
    points: *const f64,
    points_len: usize,
    directions: *const f64,
    directions_len: usize,
    t_ref_base: *const f64,
    t_ref_base_len: usize,
    t_ref_tool: *const f64,
    t_ref_tool_len: usize,
    limits: *const f64,
    limits_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let out = arg_out1!(robot_out);
        if !(1..=KINCAL_MAX_JOINTS).contains(&n_joints) {
            return Err(kincal_error::new(kincal_status::BadJointCount)
                .arg(c"n_joints")
                .counts(KINCAL_MAX_JOINTS, n_joints));
        }
        let points = arg_f64s!(points, points_len, 3 * n_joints);
        let directions = arg_f64s!(directions, directions_len, 3 * n_joints);
        let limits = arg_f64s!(limits, limits_len, 2 * n_joints);
        let base = if t_ref_base.is_null() {
            Transform::identity()
        } else {
            crate::pose::from_matrix(arg_slice!(t_ref_base, t_ref_base_len, 16), c"t_ref_base")?
        };
        let tool = if t_ref_tool.is_null() {
            Transform::identity()
        } else {
            crate::pose::from_matrix(arg_slice!(t_ref_tool, t_ref_tool_len, 16), c"t_ref_tool")?
        };
        let r = match n_joints {
            1 => build::<1>(points, directions, base, tool, limits),
            2 => build::<2>(points, directions, base, tool, limits),
            3 => build::<3>(points, directions, base, tool, limits),
            4 => build::<4>(points, directions, base, tool, limits),
            5 => build::<5>(points, directions, base, tool, limits),
            6 => build::<6>(points, directions, base, tool, limits),
            7 => build::<7>(points, directions, base, tool, limits),
            8 => build::<8>(points, directions, base, tool, limits),
            9 => build::<9>(points, directions, base, tool, limits),
            10 => build::<10>(points, directions, base, tool, limits),
            11 => build::<11>(points, directions, base, tool, limits),
            _ => build::<12>(points, directions, base, tool, limits),
        }?;
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(r) };
        Ok(())
    })
}
