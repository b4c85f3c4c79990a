//! Poses at the boundary: 4×4 column-major matrices and position + quaternion arrays, the
//! kinematic error of eq. (16) in both orientation forms, and conversions.
//!
//! Conventions: a 4×4 pose `t` is column-major (`t[4*col + row]`), a homogeneous rigid
//! transform with bottom row (0, 0, 0, 1); "pq" is `[px, py, pz, qw, qx, qy, qz]` (metres,
//! unit quaternion with qw ≥ 0 on output; normalised on input); RPY is
//! `R = Rz(yaw)·Ry(pitch)·Rx(roll)` in radians.

use core::ffi::CStr;

use kincal::pose::{
    OrientationError, Transform, checked_transform, matrix_to_quaternion, matrix_to_rpy,
    pose_error, pose_from_xyz_rpy, quaternion_to_matrix, transform,
};
use nalgebra::{Matrix3, Vector3};

use crate::status::{FfiResult, kincal_error, kincal_status};

/// Tolerance of the rigid-transform check of input matrices: every entry of RᵀR − I within
/// this, and det R > 0.
pub const KINCAL_ROTATION_TOLERANCE: f64 = 1e-6;
// The header needs a literal; the check itself is the core's.
const _: () = assert!(KINCAL_ROTATION_TOLERANCE == kincal::pose::ROTATION_TOLERANCE);

/// Which orientation error `kincal_pose_error*` report.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_orientation_error {
    /// Eq. (16) of the ARIA paper: S(Δφ) = (R_meas − R_model)·R_modelᵀ, skew part taken.
    /// First-order accurate; what the paper uses for small calibration errors.
    SmallAngle = 0,
    /// The exact rotation vector log(R_meas·R_modelᵀ), right for any error size.
    Exact = 1,
}

fn invalid_transform(name: &'static CStr) -> kincal_error {
    kincal_error::new(kincal_status::InvalidTransform).arg(name)
}

/// A transform from 16 finite column-major values, checking that it is rigid.
pub(crate) fn from_matrix(m: &[f64], name: &'static CStr) -> FfiResult<Transform> {
    crate::args::finite(m, name)?;
    let [
        r00,
        r10,
        r20,
        b0,
        r01,
        r11,
        r21,
        b1,
        r02,
        r12,
        r22,
        b2,
        px,
        py,
        pz,
        b3,
    ]: [f64; 16] = m
        .try_into()
        .map_err(|_| crate::args::bad_length(name, 16, m.len()))?;
    if b0 != 0.0 || b1 != 0.0 || b2 != 0.0 || b3 != 1.0 {
        return Err(invalid_transform(name));
    }
    let r = Matrix3::new(r00, r01, r02, r10, r11, r12, r20, r21, r22);
    checked_transform(r, Vector3::new(px, py, pz)).ok_or_else(|| invalid_transform(name))
}

/// The 16 column-major values of a transform.
pub(crate) fn to_matrix(t: &Transform) -> [f64; 16] {
    // Not `to_homogeneous()`: its fixed views assert their ranges, a panic path at opt-level z.
    let [c0, c1, c2] = t.rotation.matrix().data.0;
    let [[px, py, pz]] = t.translation.vector.data.0;
    [
        c0[0], c0[1], c0[2], 0.0, c1[0], c1[1], c1[2], 0.0, c2[0], c2[1], c2[2], 0.0, px, py, pz,
        1.0,
    ]
}

/// `[px, py, pz, qw, qx, qy, qz]` of a transform.
pub(crate) fn to_pq(t: &Transform) -> [f64; 7] {
    let p = t.translation.vector;
    let [w, x, y, z] = matrix_to_quaternion(t.rotation.matrix());
    [p.x, p.y, p.z, w, x, y, z]
}

/// A transform from 7 finite values `[px, py, pz, qw, qx, qy, qz]` (quaternion normalised).
pub(crate) fn from_pq(v: &[f64], name: &'static CStr) -> FfiResult<Transform> {
    crate::args::finite(v, name)?;
    let [px, py, pz, w, x, y, z]: [f64; 7] = v
        .try_into()
        .map_err(|_| crate::args::bad_length(name, 7, v.len()))?;
    let r = quaternion_to_matrix(&[w, x, y, z]).map_err(|e| {
        // A zero quaternion: name the argument; index 3 = where the quaternion starts.
        let mut k = kincal_error::from(e).arg(name);
        k.index = 3;
        k
    })?;
    Ok(transform(r, Vector3::new(px, py, pz)))
}

fn form(v: u32) -> FfiResult<OrientationError> {
    match v {
        0 => Ok(OrientationError::SmallAngle),
        1 => Ok(OrientationError::Exact),
        _ => Err(kincal_error::new(kincal_status::InvalidArgument)
            .arg(c"form")
            .value(f64::from(v))),
    }
}

/// Kinematic error of `measured` relative to `model` (both 4×4 column-major rigid transforms,
/// 16 doubles each): `error_out` = `[Δp (m); Δφ (rad)]` (6 doubles), measured minus model, both
/// in the base frame; `form` is a `kincal_orientation_error`.
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE, INVALID_TRANSFORM or
/// INVALID_ARGUMENT (`form`). `error_out` is written on success only and may overlap the inputs.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_pose_error(
    measured: *const f64,
    measured_len: usize,
    model: *const f64,
    model_len: usize,
    form: u32,
    error_out: *mut f64,
    error_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let a = from_matrix(arg_slice!(measured, measured_len, 16), c"measured")?;
        let b = from_matrix(arg_slice!(model, model_len, 16), c"model")?;
        let f = self::form(form)?;
        let out = arg_out!(error_out, error_len, 6);
        let e = pose_error(&a, &b, f);
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&e) }?;
        Ok(())
    })
}

/// As `kincal_pose_error` with both poses as position + quaternion `[px, py, pz, qw, qx, qy,
/// qz]` (7 doubles each; quaternions normalised, a zero quaternion gives INVALID_PARAMETER).
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_pose_error_pq(
    measured: *const f64,
    measured_len: usize,
    model: *const f64,
    model_len: usize,
    form: u32,
    error_out: *mut f64,
    error_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let a = from_pq(arg_slice!(measured, measured_len, 7), c"measured")?;
        let b = from_pq(arg_slice!(model, model_len, 7), c"model")?;
        let f = self::form(form)?;
        let out = arg_out!(error_out, error_len, 6);
        let e = pose_error(&a, &b, f);
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&e) }?;
        Ok(())
    })
}

/// Converts position + quaternion `pq` (7 doubles `[px, py, pz, qw, qx, qy, qz]`, quaternion
/// normalised) to a 4×4 column-major pose `t_out` (16 doubles). Returns OK, NULL_POINTER,
/// MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE or INVALID_PARAMETER (zero quaternion).
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_pose_from_pq(
    pq: *const f64,
    pq_len: usize,
    t_out: *mut f64,
    t_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let t = from_pq(arg_slice!(pq, pq_len, 7), c"pq")?;
        let out = arg_out!(t_out, t_len, 16);
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&to_matrix(&t)) }?;
        Ok(())
    })
}

/// Converts a 4×4 column-major rigid transform `t` (16 doubles) to position + quaternion
/// `pq_out` (7 doubles, qw ≥ 0). Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH,
/// NON_FINITE or INVALID_TRANSFORM.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_pose_to_pq(
    t: *const f64,
    t_len: usize,
    pq_out: *mut f64,
    pq_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let t = from_matrix(arg_slice!(t, t_len, 16), c"t")?;
        let out = arg_out!(pq_out, pq_len, 7);
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&to_pq(&t)) }?;
        Ok(())
    })
}

/// Converts `xyz_rpy` (6 doubles: x, y, z [m], roll, pitch, yaw [rad] with
/// R = Rz(yaw)·Ry(pitch)·Rx(roll), the measurement-file convention) to a 4×4 column-major pose
/// `t_out` (16 doubles). Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH or NON_FINITE.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_pose_from_xyz_rpy(
    xyz_rpy: *const f64,
    xyz_rpy_len: usize,
    t_out: *mut f64,
    t_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let v = arg_f64s!(xyz_rpy, xyz_rpy_len, 6);
        let [x, y, z, roll, pitch, yaw]: [f64; 6] =
            v.try_into().map_err(|_| kincal_error::new(kincal_status::Internal))?;
        let out = arg_out!(t_out, t_len, 16);
        let t = pose_from_xyz_rpy([x, y, z], [roll, pitch, yaw]);
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&to_matrix(&t)) }?;
        Ok(())
    })
}

/// Converts a 4×4 column-major rigid transform `t` (16 doubles) to `xyz_rpy_out` (6 doubles:
/// x, y, z [m], roll, pitch, yaw [rad], pitch in [−π/2, π/2]; at gimbal lock roll = 0).
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE or INVALID_TRANSFORM.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_pose_to_xyz_rpy(
    t: *const f64,
    t_len: usize,
    xyz_rpy_out: *mut f64,
    xyz_rpy_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let t = from_matrix(arg_slice!(t, t_len, 16), c"t")?;
        let out = arg_out!(xyz_rpy_out, xyz_rpy_len, 6);
        let p = t.translation.vector;
        let [roll, pitch, yaw] = matrix_to_rpy(t.rotation.matrix());
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&[p.x, p.y, p.z, roll, pitch, yaw]) }?;
        Ok(())
    })
}
