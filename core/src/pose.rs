//! Pose algebra: rigid transforms, RPY (zyx) and quaternion conventions of the measurement
//! format, the rotation-vector exponential/logarithm, and the kinematic error of eq. (16).
//!
//! Conventions (spec/measurements.md): `R = Rz(yaw)·Ry(pitch)·Rx(roll)`, quaternions are
//! `[w, x, y, z]` with `w >= 0` on output. A transform named `t_a_b` is frame `b`
//! expressed in frame `a`; composition is `t_a_c = t_a_b * t_b_c`.

use nalgebra::{IsometryMatrix3, Matrix3, Rotation3, Translation3, Vector3};

use crate::error::{Error, Quantity, Result};
use crate::fixed3::{IDENTITY, at, dot, mat_mul, norm, norm_squared};
use crate::math::{atan2, cos, hypot, sin, sin_cos, sqrt};

/// A rigid transform (rotation matrix + translation in metres).
pub type Transform = IsometryMatrix3<f64>;

/// A pose error `[Δp; Δφ]`: position \[m\] then orientation \[rad\], both in the base frame,
/// measured minus model. This is also the row order of every identification Jacobian.
pub type PoseError = [f64; 6];

/// Which orientation error is reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OrientationError {
    /// Eq. (16): `S(Δφ) = (R_meas − R_model)·R_modelᵀ`, the skew-symmetric part taken.
    /// First-order accurate; what the paper uses for small calibration errors.
    SmallAngle,
    /// The exact rotation vector `log(R_meas·R_modelᵀ)`: right for any error size.
    Exact,
}

/// The skew-symmetric cross-product matrix `S(v)` with `S(v)·w = v × w`.
#[must_use]
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Elementary rotation about x by `angle` \[rad\].
#[must_use]
pub fn rot_x(angle: f64) -> Matrix3<f64> {
    let (s, c) = sin_cos(angle);
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

/// Elementary rotation about y by `angle` \[rad\].
#[must_use]
pub fn rot_y(angle: f64) -> Matrix3<f64> {
    let (s, c) = sin_cos(angle);
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

/// How far from orthonormal a rotation given from outside may be: every entry of RᵀR − I
/// within this (the C ABI's `KINCAL_ROTATION_TOLERANCE`; Python's check too).
pub const ROTATION_TOLERANCE: f64 = 1e-6;

/// A transform from a rotation and a translation \[m\] given from outside (a file, a C
/// caller, a numpy array): `None` unless every entry is finite and `rotation` is orthonormal
/// within [`ROTATION_TOLERANCE`] and right-handed. Input checking only: the rotation is kept
/// as given, not re-orthonormalised.
#[must_use]
pub fn checked_transform(rotation: Matrix3<f64>, translation: Vector3<f64>) -> Option<Transform> {
    let finite = rotation
        .iter()
        .chain(translation.iter())
        .all(|v| v.is_finite());
    // (kincal::fixed3: nalgebra's product and identity, without their opt-level z panic paths)
    let gram = mat_mul(&rotation.transpose(), &rotation) - IDENTITY;
    let orthonormal = gram.iter().all(|v| v.abs() <= ROTATION_TOLERANCE);
    (finite && orthonormal && rotation.determinant() > 0.0)
        .then(|| transform(rotation, translation))
}

/// Elementary rotation about z by `angle` \[rad\].
#[must_use]
pub fn rot_z(angle: f64) -> Matrix3<f64> {
    let (s, c) = sin_cos(angle);
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// Builds a transform from a rotation matrix and a translation \[m\].
#[must_use]
pub fn transform(rotation: Matrix3<f64>, translation: Vector3<f64>) -> Transform {
    IsometryMatrix3::from_parts(
        Translation3::from(translation),
        Rotation3::from_matrix_unchecked(rotation),
    )
}

/// `R = Rz(yaw)·Ry(pitch)·Rx(roll)` (angles in radians).
#[must_use]
pub fn rpy_to_matrix(roll: f64, pitch: f64, yaw: f64) -> Matrix3<f64> {
    mat_mul(&mat_mul(&rot_z(yaw), &rot_y(pitch)), &rot_x(roll))
}

/// Inverse of [`rpy_to_matrix`]: `[roll, pitch, yaw]` with pitch in [−π/2, π/2].
///
/// At gimbal lock (|pitch| = π/2, detected when `cos(pitch) < 1e-15`) roll and yaw are
/// not separable; roll is set to ~0 and the whole rotation about z goes into yaw, so the
/// returned angles still reproduce the matrix (to ~cos(pitch) < 1e-15).
///
/// Yaw is taken first and roll and pitch are read from `Rz(−yaw)·R = Ry(pitch)·Rx(roll)`,
/// so the angles reproduce the matrix to rounding (a few 1e-16) also *near* gimbal lock,
/// where reading roll from `r21, r22` (both ~cos(pitch)) would lose digits.
#[must_use]
pub fn matrix_to_rpy(r: &Matrix3<f64>) -> [f64; 3] {
    let cp = hypot(at(r, 0, 0), at(r, 1, 0));
    let lock = cp < 1e-15;
    let yaw = if lock {
        atan2(-at(r, 0, 1), at(r, 1, 1))
    } else {
        atan2(at(r, 1, 0), at(r, 0, 0))
    };
    let (sy, cy) = sin_cos(yaw);
    // Rz(−yaw)·R: its rows 0 and 1 are cy·r0 + sy·r1 and −sy·r0 + cy·r1.
    let r00 = cy * at(r, 0, 0) + sy * at(r, 1, 0);
    let r11 = -sy * at(r, 0, 1) + cy * at(r, 1, 1);
    let r12 = -sy * at(r, 0, 2) + cy * at(r, 1, 2);
    let roll = atan2(-r12, r11);
    let pitch = atan2(-at(r, 2, 0), if lock { cp } else { r00 });
    [roll, pitch, yaw]
}

/// The quaternion `q` = `[w, x, y, z]` divided by its norm, and that norm (so that a
/// reader can refuse a norm far from 1 instead of silently normalising it).
///
/// Fails with [`Error::NonFinite`] on a non-finite element and [`Error::InvalidParameter`]
/// (index 0, value = norm) when the norm is zero.
pub fn normalized_quaternion(q: &[f64; 4]) -> Result<([f64; 4], f64)> {
    crate::error::check_finite(q, Quantity::Orientation)?;
    let n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if n < 1e-300 {
        return Err(Error::InvalidParameter { index: 0, value: n });
    }
    Ok(([q[0] / n, q[1] / n, q[2] / n, q[3] / n], n))
}

/// Rotation matrix of the quaternion `[w, x, y, z]`, normalised first.
///
/// Fails with [`Error::NonFinite`] on a non-finite element and [`Error::InvalidParameter`]
/// (index 0, value = norm) when the norm is zero.
pub fn quaternion_to_matrix(q: &[f64; 4]) -> Result<Matrix3<f64>> {
    let ([w, x, y, z], _) = normalized_quaternion(q)?;
    Ok(Matrix3::new(
        1.0 - 2.0 * (y * y + z * z),
        2.0 * (x * y - w * z),
        2.0 * (x * z + w * y),
        2.0 * (x * y + w * z),
        1.0 - 2.0 * (x * x + z * z),
        2.0 * (y * z - w * x),
        2.0 * (x * z - w * y),
        2.0 * (y * z + w * x),
        1.0 - 2.0 * (x * x + y * y),
    ))
}

/// Unit quaternion `[w, x, y, z]` (with `w >= 0`) of a rotation matrix (Shepperd's method,
/// accurate for every rotation).
#[must_use]
pub fn matrix_to_quaternion(r: &Matrix3<f64>) -> [f64; 4] {
    let (m00, m11, m22) = (at(r, 0, 0), at(r, 1, 1), at(r, 2, 2));
    let tr = m00 + m11 + m22;
    let q = if tr >= m00 && tr >= m11 && tr >= m22 {
        let s = 2.0 * sqrt(1.0 + tr);
        [
            0.25 * s,
            (at(r, 2, 1) - at(r, 1, 2)) / s,
            (at(r, 0, 2) - at(r, 2, 0)) / s,
            (at(r, 1, 0) - at(r, 0, 1)) / s,
        ]
    } else if m00 >= m11 && m00 >= m22 {
        let s = 2.0 * sqrt(1.0 + m00 - m11 - m22);
        [
            (at(r, 2, 1) - at(r, 1, 2)) / s,
            0.25 * s,
            (at(r, 0, 1) + at(r, 1, 0)) / s,
            (at(r, 0, 2) + at(r, 2, 0)) / s,
        ]
    } else if m11 >= m22 {
        let s = 2.0 * sqrt(1.0 - m00 + m11 - m22);
        [
            (at(r, 0, 2) - at(r, 2, 0)) / s,
            (at(r, 0, 1) + at(r, 1, 0)) / s,
            0.25 * s,
            (at(r, 1, 2) + at(r, 2, 1)) / s,
        ]
    } else {
        let s = 2.0 * sqrt(1.0 - m00 - m11 + m22);
        [
            (at(r, 1, 0) - at(r, 0, 1)) / s,
            (at(r, 0, 2) + at(r, 2, 0)) / s,
            (at(r, 1, 2) + at(r, 2, 1)) / s,
            0.25 * s,
        ]
    };
    let n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    let sign = if q[0] < 0.0 { -1.0 } else { 1.0 };
    [
        sign * q[0] / n,
        sign * q[1] / n,
        sign * q[2] / n,
        sign * q[3] / n,
    ]
}

/// Rotation matrix of the rotation vector `v` (axis times angle \[rad\]): Rodrigues' formula
/// with series expansions near zero.
#[must_use]
pub fn rotation_exp(v: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = norm_squared(v);
    let t = sqrt(t2);
    let (a, b) = if t < 1e-4 {
        (
            1.0 - t2 / 6.0 + t2 * t2 / 120.0,
            0.5 - t2 / 24.0 + t2 * t2 / 720.0,
        )
    } else {
        (sin(t) / t, (1.0 - cos(t)) / t2)
    };
    let k = skew(v);
    IDENTITY + k * a + mat_mul(&k, &k) * b
}

/// The exact rotation vector of `r` (its matrix logarithm), angle in [0, π].
///
/// Accurate everywhere: the skew part is used for angles below ~135°, the symmetric part
/// near π, where the skew part vanishes.
#[must_use]
pub fn rotation_log(r: &Matrix3<f64>) -> Vector3<f64> {
    let s = Vector3::new(
        at(r, 2, 1) - at(r, 1, 2),
        at(r, 0, 2) - at(r, 2, 0),
        at(r, 1, 0) - at(r, 0, 1),
    ) * 0.5;
    let sin_t = norm(&s);
    // (`f64::clamp` asserts its bounds: a panic path where it is not inlined; this is its body.)
    let c = (at(r, 0, 0) + at(r, 1, 1) + at(r, 2, 2) - 1.0) * 0.5;
    #[allow(clippy::manual_clamp)]
    let cos_t = if c < -1.0 {
        -1.0
    } else if c > 1.0 {
        1.0
    } else {
        c
    };
    let angle = atan2(sin_t, cos_t);
    if sin_t < 1e-300 && cos_t > 0.0 {
        return crate::fixed3::ZERO;
    }
    if cos_t > -0.7 {
        // angle < ~134°: sin is a good measure, θ/sinθ well conditioned.
        let f = if angle < 1e-6 {
            1.0 + angle * angle / 6.0
        } else {
            angle / sin_t
        };
        return s * f;
    }
    // Near π: R + Rᵀ = 2cosθ·I + 2(1 − cosθ)·a·aᵀ; take the largest diagonal entry.
    let omc = 1.0 - cos_t;
    let b =
        |i: usize, j: usize| 0.5 * (at(r, i, j) + at(r, j, i)) - if i == j { cos_t } else { 0.0 };
    let k = if b(0, 0) >= b(1, 1) && b(0, 0) >= b(2, 2) {
        0
    } else if b(1, 1) >= b(2, 2) {
        1
    } else {
        2
    };
    let ak = sqrt((b(k, k) / omc).max(0.0));
    let entry = |j: usize| if j == k { ak } else { b(j, k) / (omc * ak) };
    let axis = Vector3::new(entry(0), entry(1), entry(2));
    let axis = axis / norm(&axis);
    let axis = if dot(&axis, &s) < 0.0 { -axis } else { axis };
    axis * angle
}

/// Left Jacobian of SO(3): `exp(v + δ) ≈ exp(J_l(v)·δ)·exp(v)`, so a change `δ` of a
/// rotation-vector parameter rotates the frame by `J_l(v)·δ` in the outer (space) frame.
#[must_use]
pub fn so3_left_jacobian(v: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = norm_squared(v);
    let t = sqrt(t2);
    let (a, b) = if t < 1e-4 {
        (0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0)
    } else {
        ((1.0 - cos(t)) / t2, (t - sin(t)) / (t2 * t))
    };
    let k = skew(v);
    IDENTITY + k * a + mat_mul(&k, &k) * b
}

/// Kinematic error `[Δp; Δφ]` of `measured` relative to `model` (measured minus model),
/// position in metres, orientation in radians, both in the base frame.
#[must_use]
pub fn pose_error(measured: &Transform, model: &Transform, form: OrientationError) -> PoseError {
    let dp = measured.translation.vector - model.translation.vector;
    let rm = measured.rotation.matrix();
    let r0 = model.rotation.matrix();
    let dphi = match form {
        OrientationError::Exact => rotation_log(&mat_mul(rm, &r0.transpose())),
        OrientationError::SmallAngle => {
            let s = mat_mul(&(rm - r0), &r0.transpose());
            Vector3::new(
                at(&s, 2, 1) - at(&s, 1, 2),
                at(&s, 0, 2) - at(&s, 2, 0),
                at(&s, 1, 0) - at(&s, 0, 1),
            ) * 0.5
        }
    };
    [dp.x, dp.y, dp.z, dphi.x, dphi.y, dphi.z]
}

/// A pose from position \[m\] and RPY angles \[rad\] (`R = Rz(yaw)·Ry(pitch)·Rx(roll)`).
#[must_use]
pub fn pose_from_xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> Transform {
    transform(
        rpy_to_matrix(rpy[0], rpy[1], rpy[2]),
        Vector3::new(xyz[0], xyz[1], xyz[2]),
    )
}

/// A pose from the six parameters `[px, py, pz, rx, ry, rz]`: `Trans(p)·Rot(r)`, `r` a
/// rotation vector. This is how base and tool frames are parameterised.
#[must_use]
pub fn pose_from_vector6(v: &[f64; 6]) -> Transform {
    transform(
        rotation_exp(&Vector3::new(v[3], v[4], v[5])),
        Vector3::new(v[0], v[1], v[2]),
    )
}

/// Inverse of [`pose_from_vector6`].
#[must_use]
pub fn pose_to_vector6(t: &Transform) -> [f64; 6] {
    let r = rotation_log(t.rotation.matrix());
    let p = t.translation.vector;
    [p.x, p.y, p.z, r.x, r.y, r.z]
}
