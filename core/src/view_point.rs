//! Where a camera looks: the point its viewing axes converge on, and the measured pose
//! re-expressed there.
//!
//! An eye-in-hand camera that measures its pose from a board seen at distance `s` gets the
//! pose about the board: the board's position in the camera frame is well determined, the
//! camera's orientation less so, and the camera's *position* (in the board frame, or in
//! any frame fixed to the board) then carries the orientation error times `s`. With
//! `s` = 0.47 m and 0.2° of orientation noise that is 1.6 mm per axis, strongly correlated
//! with the orientation error, and a least-squares fit that weights positions and
//! orientations independently reads it as geometry.
//!
//! Re-expressing each measured pose `T` at the point the camera looks at,
//! `T·Trans(s·e_axis)`, and declaring that point as the row's measured point
//! ([`crate::identify::Measurement::point`], `(0, 0, s)` in the tool frame for the optical
//! axis z) changes nothing about what was measured (same rigid body, same orientation)
//! but moves the reference point of the position rows to where the measurement is
//! precise. [`view_point`] finds `s` from the data: the least-squares point nearest to all
//! viewing axes, with how closely the axes pass it, so that a set whose camera did not
//! look at one place is recognised and not re-expressed blindly.

use nalgebra::Vector3;

use crate::error::{Error, Quantity, Result};
use crate::fixed3::{
    IDENTITY, IDENTITY_TRANSFORM, ZERO, ZERO33, at, cholesky_solve, dot, mat_vec, norm, outer,
};
use crate::pose::Transform;
use crate::registration::symmetric_eigen;

/// A frame axis (the viewing direction of a camera frame: z for the optical frame of
/// OpenCV, ROS `*_optical_frame` and most calibration toolboxes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// The frame's x axis.
    X,
    /// The frame's y axis.
    Y,
    /// The frame's z axis.
    Z,
}

impl Axis {
    /// Column index of the axis in a rotation matrix.
    #[must_use]
    pub const fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }

    /// The axis as a unit vector in its own frame.
    #[must_use]
    pub fn unit(self) -> [f64; 3] {
        let mut u = [0.0; 3];
        u[self.index()] = 1.0;
        u
    }
}

/// Below this ratio of the smallest to the largest eigenvalue of `Σ (I − d·dᵀ)` the
/// viewing axes are taken as parallel: the point they converge on is not determined (a
/// ratio of 1e-9 corresponds to axes spread by about 0.005°).
pub const PARALLEL_AXES_RATIO: f64 = 1e-9;

/// The result of [`view_point`]: where the viewing axes of a set of poses converge.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewPoint {
    /// The point nearest (least squares) to every viewing axis, in the frame the poses
    /// are given in \[m\].
    pub point_m: [f64; 3],
    /// Mean distance from the frame origins to the point, measured along each axis \[m\]:
    /// the re-expression distance `s` (the point `s·e_axis` of every frame).
    pub mean_distance_m: f64,
    /// Smallest and largest distance along an axis \[m\] (negative: the point lies behind
    /// that frame).
    pub min_distance_m: f64,
    /// See `min_distance_m`.
    pub max_distance_m: f64,
    /// RMS over the poses of the point's distance from each viewing axis \[m\].
    pub miss_rms_m: f64,
    /// Largest distance of the point from a viewing axis \[m\].
    pub miss_max_m: f64,
    /// Index of the pose whose axis passes farthest from the point.
    pub miss_max_pose: usize,
}

/// The point where the `axis` directions of `poses` (lines through each origin) converge.
///
/// Solves `min_c Σ |(I − dᵢ·dᵢᵀ)(c − pᵢ)|²`, i.e. `(Σ (I − dᵢdᵢᵀ))·c = Σ (I − dᵢdᵢᵀ)·pᵢ`,
/// with `pᵢ` the origin and `dᵢ` the unit `axis` of pose `i`. Errors: fewer than 2 poses
/// ([`Error::TooFewData`]), a non-finite pose ([`Error::NonFinite`]), axes (nearly) parallel
/// so that no point is determined ([`Error::RankDeficient`], see
/// [`PARALLEL_AXES_RATIO`]).
///
/// # Errors
/// As listed above.
pub fn view_point(poses: &[Transform], axis: Axis) -> Result<ViewPoint> {
    view_point_from(
        poses.len(),
        |i| poses.get(i).copied().unwrap_or(IDENTITY_TRANSFORM),
        axis,
    )
}

/// [`view_point`] of the `n` poses `pose(0)`, …, `pose(n − 1)`, without a slice: for
/// callers that hold the poses in another form (the C ABI's column-major matrices) and
/// must not allocate. `pose` is called twice for every index (two passes over the data)
/// and must return the same transform both times. The result equals [`view_point`] of the
/// same poses bit for bit (it is the same computation).
///
/// # Errors
/// As [`view_point`].
pub fn view_point_from(
    n: usize,
    pose: impl Fn(usize) -> Transform,
    axis: Axis,
) -> Result<ViewPoint> {
    if n < 2 {
        return Err(Error::TooFewData {
            found: n,
            needed: 2,
        });
    }
    // fixed3 rather than nalgebra's products, `Index` and Cholesky (same bits): theirs keep
    // panic paths at opt-level z.
    let mut a = ZERO33;
    let mut b = ZERO;
    for i in 0..n {
        let (p, d) = origin_and_axis(&pose(i), axis);
        if !(p.iter().all(|v| v.is_finite()) && d.iter().all(|v| v.is_finite())) {
            return Err(Error::NonFinite {
                what: Quantity::Position,
                index: i,
            });
        }
        let m = IDENTITY - outer(&d);
        a += m;
        b += mat_vec(&m, &p);
    }
    let rows: [[f64; 3]; 3] = core::array::from_fn(|i| core::array::from_fn(|j| at(&a, i, j)));
    let (values, _) = symmetric_eigen(rows)?;
    let (lo, hi) = values.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| {
        (lo.min(v), hi.max(v))
    });
    if lo.is_nan() || lo <= PARALLEL_AXES_RATIO * hi {
        let rank = values
            .iter()
            .filter(|&&v| v > PARALLEL_AXES_RATIO * hi)
            .count();
        return Err(Error::RankDeficient { rank, required: 3 });
    }
    let [b] = &b.data.0;
    let [cx, cy, cz] = cholesky_solve(&a.data.0, b).ok_or(Error::RankDeficient {
        rank: 2,
        required: 3,
    })?;
    let c = Vector3::new(cx, cy, cz);

    let mut sum_s = 0.0;
    let (mut min_s, mut max_s) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut sum_miss2, mut miss_max, mut miss_max_pose) = (0.0, 0.0f64, 0);
    for i in 0..n {
        let (p, d) = origin_and_axis(&pose(i), axis);
        let v = c - p;
        let s = dot(&v, &d);
        let miss = norm(&(v - d * s));
        sum_s += s;
        min_s = min_s.min(s);
        max_s = max_s.max(s);
        sum_miss2 += miss * miss;
        if miss > miss_max {
            miss_max = miss;
            miss_max_pose = i;
        }
    }
    let n = n as f64;
    Ok(ViewPoint {
        point_m: [c.x, c.y, c.z],
        mean_distance_m: sum_s / n,
        min_distance_m: min_s,
        max_distance_m: max_s,
        miss_rms_m: crate::math::sqrt(sum_miss2 / n),
        miss_max_m: miss_max,
        miss_max_pose,
    })
}

/// `pose·Trans(point_m)`: the same rigid body's frame moved (not rotated) to `point_m`,
/// given in that frame \[m\]: the pose a row with measured point `point_m` carries.
#[must_use]
pub fn moved_to_point(pose: &Transform, point_m: &[f64; 3]) -> Transform {
    let p = Vector3::new(point_m[0], point_m[1], point_m[2]);
    Transform::from_parts(
        (pose.translation.vector + mat_vec(pose.rotation.matrix(), &p)).into(),
        pose.rotation,
    )
}

fn origin_and_axis(t: &Transform, axis: Axis) -> (Vector3<f64>, Vector3<f64>) {
    let r = t.rotation.matrix();
    (t.translation.vector, crate::math::column3(r, axis.index()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::{rotation_exp, transform};
    use nalgebra::Matrix3;

    /// A camera at `eye` looking (z) at `target`, rolled by `roll` about its axis.
    fn look_at(eye: [f64; 3], target: [f64; 3], roll: f64) -> Transform {
        let e = Vector3::from(eye);
        let z = (Vector3::from(target) - e).normalize();
        let helper = if z.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let x = helper.cross(&z).normalize();
        let y = z.cross(&x);
        let r = Matrix3::from_columns(&[x, y, z]) * rotation_exp(&(Vector3::z() * roll));
        transform(r, e)
    }

    #[test]
    fn recovers_the_target_and_distances() {
        let target = [1.2, -0.3, 0.4];
        let eyes = [
            [1.0, 0.0, 0.8],
            [1.6, -0.2, 0.7],
            [1.1, -0.7, 0.9],
            [1.3, 0.1, 0.95],
        ];
        let poses: [Transform; 4] =
            core::array::from_fn(|i| look_at(eyes[i], target, 0.3 * i as f64));
        let v = view_point(&poses, Axis::Z).unwrap();
        for k in 0..3 {
            assert!((v.point_m[k] - target[k]).abs() < 1e-12, "{v:?}");
        }
        assert!(v.miss_max_m < 1e-12);
        let dists: [f64; 4] =
            core::array::from_fn(|i| (Vector3::from(eyes[i]) - Vector3::from(target)).norm());
        let mean = dists.iter().sum::<f64>() / 4.0;
        assert!((v.mean_distance_m - mean).abs() < 1e-12);
        assert!((v.min_distance_m - dists.iter().cloned().fold(9.0, f64::min)).abs() < 1e-12);
        // Every pose moved by its own distance lands on the target.
        for (t, d) in poses.iter().zip(dists) {
            let m = moved_to_point(t, &[0.0, 0.0, d]);
            assert!((m.translation.vector - Vector3::from(target)).norm() < 1e-12);
            assert_eq!(m.rotation, t.rotation);
        }
    }

    #[test]
    fn a_missing_axis_is_measured() {
        // Three axes through the origin, one offset by 5 cm sideways: the least-squares
        // point moves and the offset axis has the largest miss.
        let mut poses = [
            look_at([1.0, 0.0, 0.0], [0.0; 3], 0.0),
            look_at([0.0, 1.0, 0.0], [0.0; 3], 0.0),
            look_at([0.0, 0.0, 1.0], [0.0; 3], 0.0),
            look_at([0.7, 0.7, 0.0], [0.0; 3], 0.0),
        ];
        poses[3].translation.vector += Vector3::new(0.0, 0.0, 0.05);
        let v = view_point(&poses, Axis::Z).unwrap();
        assert_eq!(v.miss_max_pose, 3);
        assert!(v.miss_max_m > 0.02 && v.miss_rms_m > 0.01, "{v:?}");
    }

    #[test]
    fn parallel_axes_and_too_few_poses_are_errors() {
        let a = look_at([0.0, 0.0, 1.0], [0.0; 3], 0.0);
        let b = look_at([0.1, 0.0, 1.0], [0.1, 0.0, 0.0], 0.0);
        assert!(matches!(
            view_point(&[a, b], Axis::Z),
            Err(Error::RankDeficient { required: 3, .. })
        ));
        assert!(matches!(
            view_point(&[a], Axis::Z),
            Err(Error::TooFewData {
                found: 1,
                needed: 2
            })
        ));
        let mut c = a;
        c.translation.vector.x = f64::NAN;
        assert!(matches!(
            view_point(&[a, b, c], Axis::Z),
            Err(Error::NonFinite { index: 2, .. })
        ));
    }

    #[test]
    fn the_streaming_form_equals_the_slice_form() {
        let target = [0.4, 0.2, -0.1];
        let eyes = [
            [1.0, 0.1, 0.5],
            [0.2, 1.1, 0.4],
            [0.5, 0.4, 1.2],
            [1.1, 1.0, 0.3],
        ];
        let mut poses: [Transform; 4] =
            core::array::from_fn(|i| look_at(eyes[i], target, 0.2 * i as f64));
        // Not converging exactly: the statistics are not all zero.
        poses[1].translation.vector += Vector3::new(0.0, 0.0, 0.01);
        let v = view_point(&poses, Axis::Z).unwrap();
        let calls = core::cell::Cell::new(0usize);
        let w = view_point_from(
            poses.len(),
            |i| {
                calls.set(calls.get() + 1);
                poses[i]
            },
            Axis::Z,
        )
        .unwrap();
        assert_eq!(v, w);
        assert_eq!(calls.get(), 2 * poses.len());
        assert!(v.miss_rms_m > 0.0 && v.miss_max_pose == 1, "{v:?}");
        assert!(matches!(
            view_point_from(1, |i| poses[i], Axis::Z),
            Err(Error::TooFewData {
                found: 1,
                needed: 2
            })
        ));
    }

    #[test]
    fn other_axes() {
        // The same cameras with x as the viewing direction: rotate each frame so that its
        // x axis is the old z axis.
        let target = [0.2, 0.1, -0.3];
        let eyes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.2], [0.3, 0.2, 1.0]];
        let swap = rotation_exp(&(Vector3::y() * (-core::f64::consts::FRAC_PI_2)));
        let poses: [Transform; 3] = core::array::from_fn(|i| {
            let t = look_at(eyes[i], target, 0.0);
            transform(t.rotation.matrix() * swap, t.translation.vector)
        });
        let v = view_point(&poses, Axis::X).unwrap();
        for k in 0..3 {
            assert!((v.point_m[k] - target[k]).abs() < 1e-12, "{v:?}");
        }
        assert_eq!(Axis::X.unit(), [1.0, 0.0, 0.0]);
    }
}
