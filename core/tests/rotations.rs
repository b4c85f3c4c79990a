//! Pose algebra: RPY (zyx) and quaternion conventions of the measurement format, the
//! rotation-vector exponential and logarithm (including near gimbal lock and near π), the
//! SO(3) left Jacobian, and the small-angle orientation error of eq. (16) against the
//! exact one. Independent references: nalgebra's own `Rotation3`/`UnitQuaternion`
//! constructors and finite differences.

mod common;

use std::f64::consts::{FRAC_PI_2, PI};

use common::SplitMix64;
use kincal::pose::{
    OrientationError, matrix_to_quaternion, matrix_to_rpy, pose_error, pose_from_vector6,
    pose_to_vector6, quaternion_to_matrix, rotation_exp, rotation_log, rpy_to_matrix,
    so3_left_jacobian,
};
use kincal::{Error, Transform};
use nalgebra::{Matrix3, Rotation3, Translation3, Unit, UnitQuaternion, Vector3};

/// Agreement of rotation matrices built two ways (element-wise) [1].
const MAT_TOL: f64 = 1e-14;
/// Round trips through angles [rad].
const ANGLE_TOL: f64 = 1e-12;
/// Near gimbal lock roll and yaw are ill-conditioned; the matrix must still come back to
/// this accuracy [1] (measured: 7e-16).
const GIMBAL_MAT_TOL: f64 = 1e-14;
/// Log near π, rotation vector and angle [rad] (measured: 9e-16 up to π − 1e-8).
const LOG_NEAR_PI_TOL: f64 = 1e-13;
/// Random samples per test.
const SAMPLES: usize = 500;

fn max_diff(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    (a - b).abs().max()
}

fn random_vector(rng: &mut SplitMix64, angle: f64) -> Vector3<f64> {
    let u = rng.unit_vector();
    Vector3::new(u[0], u[1], u[2]) * angle
}

#[test]
fn rpy_matches_nalgebra_euler_angles() {
    // nalgebra's from_euler_angles(roll, pitch, yaw) is Rz(yaw)·Ry(pitch)·Rx(roll).
    let mut rng = SplitMix64::new(400);
    for _ in 0..SAMPLES {
        let (r, p, y) = (
            rng.uniform(-PI, PI),
            rng.uniform(-PI, PI),
            rng.uniform(-PI, PI),
        );
        let m = rpy_to_matrix(r, p, y);
        let reference = Rotation3::from_euler_angles(r, p, y);
        assert!(max_diff(&m, reference.matrix()) < MAT_TOL);
    }
    // The measurement-format convention, by hand: roll −150° about x only.
    let m = rpy_to_matrix((-150.0_f64).to_radians(), 0.0, 0.0);
    let (s, c) = (-150.0_f64).to_radians().sin_cos();
    let expected = Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c);
    assert!(max_diff(&m, &expected) < MAT_TOL);
}

#[test]
fn rpy_round_trip_away_from_gimbal_lock() {
    let mut rng = SplitMix64::new(401);
    for _ in 0..SAMPLES {
        let rpy = [
            rng.uniform(-PI + 1e-6, PI - 1e-6),
            rng.uniform(-FRAC_PI_2 + 1e-3, FRAC_PI_2 - 1e-3),
            rng.uniform(-PI + 1e-6, PI - 1e-6),
        ];
        let back = matrix_to_rpy(&rpy_to_matrix(rpy[0], rpy[1], rpy[2]));
        for k in 0..3 {
            assert!(
                (back[k] - rpy[k]).abs() < ANGLE_TOL,
                "{rpy:?} came back as {back:?}"
            );
        }
    }
}

/// At and within 1e-9 rad of pitch = ±π/2 roll and yaw are not separable: the angles need
/// not come back, but the rotation they describe must.
#[test]
fn rpy_round_trip_near_gimbal_lock() {
    let mut rng = SplitMix64::new(402);
    for &p0 in &[FRAC_PI_2, -FRAC_PI_2] {
        for &dp in &[0.0, 1e-9, -1e-9, 1e-12, -1e-12, 1e-7, -1e-7] {
            for _ in 0..50 {
                let (r, y) = (rng.uniform(-PI, PI), rng.uniform(-PI, PI));
                let m = rpy_to_matrix(r, p0 + dp, y);
                let back = matrix_to_rpy(&m);
                assert!(back.iter().all(|v| v.is_finite()));
                assert!(back[1].abs() <= FRAC_PI_2 + 1e-15);
                let m2 = rpy_to_matrix(back[0], back[1], back[2]);
                assert!(
                    max_diff(&m, &m2) < GIMBAL_MAT_TOL,
                    "pitch {p0}{dp:+e}: ({r}, {y}) -> {back:?}, diff {:.2e}",
                    max_diff(&m, &m2)
                );
            }
        }
    }
}

#[test]
fn quaternion_matches_nalgebra_and_round_trips() {
    let mut rng = SplitMix64::new(403);
    for _ in 0..SAMPLES {
        let q = [
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
        ];
        let m = quaternion_to_matrix(&q).expect("quaternion");
        let reference =
            UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]));
        assert!(max_diff(&m, reference.to_rotation_matrix().matrix()) < MAT_TOL);
        let back = matrix_to_quaternion(&m);
        assert!(back[0] >= 0.0, "w < 0: {back:?}");
        let n = (back.iter().map(|v| v * v).sum::<f64>()).sqrt();
        assert!((n - 1.0).abs() < 1e-15);
        // Same rotation, and the same quaternion up to the sign convention.
        let qn = (q.iter().map(|v| v * v).sum::<f64>()).sqrt();
        let sign = if q[0] < 0.0 { -1.0 } else { 1.0 };
        for k in 0..4 {
            assert!(
                (back[k] - sign * q[k] / qn).abs() < ANGLE_TOL,
                "{q:?} -> {back:?}"
            );
        }
    }
}

/// Near 180° (w ≈ 0) every branch of Shepperd's method is taken; the sign convention
/// w >= 0 holds and the matrix comes back.
#[test]
fn quaternion_near_half_turn() {
    let mut rng = SplitMix64::new(404);
    for &angle in &[PI, PI - 1e-9, PI - 1e-4, PI - 0.3, 3.0 * FRAC_PI_2 / 2.0] {
        for axis in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
            .into_iter()
            .chain((0..30).map(|_| rng.unit_vector()))
        {
            let v = Vector3::new(axis[0], axis[1], axis[2]) * angle;
            let m = *Rotation3::new(v).matrix();
            let q = matrix_to_quaternion(&m);
            assert!(q[0] >= 0.0);
            let m2 = quaternion_to_matrix(&q).expect("quaternion");
            assert!(max_diff(&m, &m2) < MAT_TOL, "angle {angle}, axis {axis:?}");
        }
    }
}

#[test]
fn zero_and_non_finite_quaternions_are_rejected() {
    assert!(matches!(
        quaternion_to_matrix(&[0.0; 4]),
        Err(Error::InvalidParameter { index: 0, .. })
    ));
    assert_eq!(
        quaternion_to_matrix(&[1.0, 0.0, f64::NAN, 0.0]),
        Err(Error::NonFinite {
            what: kincal::Quantity::Orientation,
            index: 2
        })
    );
}

#[test]
fn rotation_exp_matches_nalgebra() {
    let mut rng = SplitMix64::new(405);
    // Includes the series branch (|v| < 1e-4) and its boundary.
    for &angle in &[
        0.0,
        1e-12,
        1e-8,
        9.99e-5,
        1e-4,
        1.01e-4,
        1e-2,
        0.5,
        2.0,
        PI - 1e-6,
        PI,
    ] {
        for _ in 0..30 {
            let v = random_vector(&mut rng, angle);
            let m = rotation_exp(&v);
            assert!(
                max_diff(&m, Rotation3::new(v).matrix()) < MAT_TOL,
                "|v| = {angle}"
            );
        }
    }
}

#[test]
fn rotation_log_inverts_exp() {
    let mut rng = SplitMix64::new(406);
    for _ in 0..SAMPLES {
        let a = rng.uniform(0.0, PI - 1e-3);
        let v = random_vector(&mut rng, a);
        let back = rotation_log(&rotation_exp(&v));
        assert!((back - v).abs().max() < ANGLE_TOL, "{v:?} -> {back:?}");
    }
    for &angle in &[0.0, 1e-300, 1e-15, 1e-10, 1e-7, 1e-6, 1.01e-6, 1e-3] {
        for _ in 0..20 {
            let v = random_vector(&mut rng, angle);
            let back = rotation_log(&rotation_exp(&v));
            assert!(
                (back - v).abs().max() < 1e-16 + 1e-12 * angle,
                "|v| = {angle}"
            );
        }
    }
}

/// Across the switch to the symmetric part (cos θ = −0.7, θ ≈ 134°) and up to π: the
/// rotation comes back, the angle is right, and below π the vector itself comes back.
#[test]
fn rotation_log_near_pi() {
    let mut rng = SplitMix64::new(407);
    let switch = (-0.7_f64).acos();
    let angles = [
        switch - 1e-9,
        switch + 1e-9,
        2.5,
        3.0,
        PI - 1e-2,
        PI - 1e-4,
        PI - 1e-6,
        PI - 1e-8,
        PI,
    ];
    for &angle in &angles {
        for axis in [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]
            .into_iter()
            .chain((0..50).map(|_| rng.unit_vector()))
        {
            let v = Vector3::new(axis[0], axis[1], axis[2]) * angle;
            let m = rotation_exp(&v);
            let back = rotation_log(&m);
            assert!((back.norm() - angle).abs() < LOG_NEAR_PI_TOL);
            assert!(
                max_diff(&rotation_exp(&back), &m) < MAT_TOL,
                "angle {angle}"
            );
            if angle < PI {
                assert!(
                    (back - v).abs().max() < LOG_NEAR_PI_TOL,
                    "angle {angle}, axis {axis:?}: {back:?}"
                );
            }
        }
    }
}

/// `exp(v + δ) ≈ exp(J_l(v)·δ)·exp(v)`: J_l against central differences of the exact log.
#[test]
fn left_jacobian_matches_finite_differences() {
    const H: f64 = 1e-6;
    let mut rng = SplitMix64::new(408);
    for &angle in &[0.0, 5e-5, 0.3, 1.5, 3.0] {
        for _ in 0..20 {
            let v = random_vector(&mut rng, angle);
            let jl = so3_left_jacobian(&v);
            for k in 0..3 {
                let mut e = Vector3::zeros();
                e[k] = H;
                let d =
                    rotation_log(&(rotation_exp(&(v + e)) * rotation_exp(&(v - e)).transpose()))
                        / (2.0 * H);
                assert!(
                    (d - jl.column(k)).abs().max() < 1e-8,
                    "|v| = {angle}, column {k}"
                );
            }
        }
    }
}

#[test]
fn vector6_round_trip() {
    let mut rng = SplitMix64::new(409);
    for _ in 0..SAMPLES {
        let a = rng.uniform(0.0, 3.0);
        let r = random_vector(&mut rng, a);
        let v = [
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
            r.x,
            r.y,
            r.z,
        ];
        let t = pose_from_vector6(&v);
        // Trans(p)·Rot(r): translation first, untouched by the rotation.
        assert_eq!(t.translation.vector, Vector3::new(v[0], v[1], v[2]));
        let back = pose_to_vector6(&t);
        for k in 0..6 {
            assert!((back[k] - v[k]).abs() < ANGLE_TOL);
        }
    }
}

fn pose(r: Matrix3<f64>, p: Vector3<f64>) -> Transform {
    Transform::from_parts(Translation3::from(p), Rotation3::from_matrix_unchecked(r))
}

/// Eq. (16): the small-angle error agrees with the exact log to second order: for an error
/// rotation of angle ε the difference is ε − sin ε ≈ ε³/6. Signs: measured minus model, in
/// the base frame (measured = exp(δ)·model gives +δ).
#[test]
fn small_angle_error_agrees_with_exact_to_second_order() {
    let mut rng = SplitMix64::new(410);
    for &eps in &[1e-1, 1e-2, 1e-3, 1e-4] {
        for _ in 0..50 {
            let a = rng.uniform(0.0, 3.0);
            let model = pose(
                rotation_exp(&random_vector(&mut rng, a)),
                Vector3::new(0.3, -0.2, 0.5),
            );
            let delta = random_vector(&mut rng, eps);
            let dp = Vector3::new(1e-3, -2e-3, 5e-4);
            let measured = pose(
                rotation_exp(&delta) * model.rotation.matrix(),
                model.translation.vector + dp,
            );
            let exact = pose_error(&measured, &model, OrientationError::Exact);
            let small = pose_error(&measured, &model, OrientationError::SmallAngle);
            for k in 0..3 {
                assert!((exact[k] - dp[k]).abs() < 1e-15);
                assert_eq!(exact[k], small[k]);
                assert!((exact[3 + k] - delta[k]).abs() < 1e-12 * (1.0 + eps));
            }
            let diff = (3..6)
                .map(|k| (exact[k] - small[k]).abs())
                .fold(0.0, f64::max);
            // ε³/6 with a margin for rounding; and genuinely third order: not ε²-sized.
            assert!(
                diff <= eps.powi(3) / 6.0 * 1.01 + 1e-15,
                "ε = {eps}: |exact − small| = {diff:e}"
            );
            // The small-angle vector is sin ε along the same axis.
            let small_v = Vector3::new(small[3], small[4], small[5]);
            assert!((small_v.norm() - eps.sin()).abs() < 1e-14);
        }
    }
}

/// The rotation axis direction of a unit-quaternion rotation equals the log's direction
/// (cross-check of log against nalgebra for moderate angles).
#[test]
fn rotation_log_matches_nalgebra_scaled_axis() {
    let mut rng = SplitMix64::new(411);
    for _ in 0..SAMPLES {
        let u = rng.unit_vector();
        let angle = rng.uniform(0.0, 2.5);
        let r =
            Rotation3::from_axis_angle(&Unit::new_normalize(Vector3::new(u[0], u[1], u[2])), angle);
        let back = rotation_log(r.matrix());
        assert!((back - r.scaled_axis()).abs().max() < ANGLE_TOL);
    }
}

/// `checked_transform` (the input check the C ABI and Python share): a rotation within
/// `ROTATION_TOLERANCE` of orthonormal passes unchanged; a reflection, a scaled or sheared
/// matrix and non-finite entries are refused. The Gram residual is computed here by hand.
#[test]
fn checked_transform_accepts_rotations_only() {
    use kincal::pose::{ROTATION_TOLERANCE, checked_transform};
    let r = rpy_to_matrix(0.3, -1.1, 2.0);
    let p = Vector3::new(0.1, -0.2, 0.3);
    let t = checked_transform(r, p).expect("a rotation");
    assert_eq!(*t.rotation.matrix(), r);
    assert_eq!(t.translation.vector, p);
    // Scaled by 1 + ε: RᵀR − I = (2ε + ε²)·I, inside the tolerance below it, outside above.
    let gram_entry = |eps: f64| (1.0 + eps) * (1.0 + eps) - 1.0;
    let inside = 0.4 * ROTATION_TOLERANCE;
    let outside = 0.6 * ROTATION_TOLERANCE;
    assert!(gram_entry(inside) < ROTATION_TOLERANCE && gram_entry(outside) > ROTATION_TOLERANCE);
    assert!(checked_transform(r * (1.0 + inside), p).is_some());
    assert!(checked_transform(r * (1.0 + outside), p).is_none());
    // A reflection is orthonormal but left-handed.
    let flip = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
    assert!(checked_transform(r * flip, p).is_none());
    let mut shear = r;
    shear[(0, 1)] += 1e-3;
    assert!(checked_transform(shear, p).is_none());
    let mut nan = r;
    nan[(2, 2)] = f64::NAN;
    assert!(checked_transform(nan, p).is_none());
    assert!(checked_transform(r, Vector3::new(0.0, f64::INFINITY, 0.0)).is_none());
}
