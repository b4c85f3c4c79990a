//! Forward kinematics (pose, position + quaternion, every frame), the identification
//! Jacobian, gravity torques, and the effect-compensated joint angles.

use core::ffi::CStr;

use kincal::any::AnyRobot;
use kincal::kinematics::Frames;
use kincal::params::{num_geometric_params, num_params};
use kincal::pose::Transform;
use kincal::{JointState, Robot, with_any_robot};

use crate::robot::{KINCAL_MAX_JOINTS, kincal_robot, to_any};
use crate::status::{FfiResult, kincal_error, kincal_status};

/// Auxiliary inputs of a joint state that some effects need. Pass NULL where a function takes
/// `const kincal_joint_aux *aux` when the model has neither backlash nor thermal expansion.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_joint_aux {
    /// Non-zero: `approach` holds the approach directions (needed with backlash).
    pub has_approach: u32,
    /// Non-zero: `temp_c` holds the arm temperature (needed with thermal expansion).
    pub has_temp: u32,
    /// Direction from which each joint approached the pose: −1, 0 or +1 (first N used).
    pub approach: [f64; KINCAL_MAX_JOINTS],
    /// Arm temperature [°C].
    pub temp_c: f64,
}

/// The argument names reported for bad `kincal_joint_aux` fields.
#[derive(Debug, Clone, Copy)]
pub(crate) struct AuxNames {
    approach: &'static CStr,
    temp_c: &'static CStr,
}

/// Names of an `aux` argument of a call.
pub(crate) const CALL_AUX: AuxNames = AuxNames {
    approach: c"aux->approach",
    temp_c: c"aux->temp_c",
};

/// Names of the per-pose `aux` of a `kincal_measurements`.
pub(crate) const DATA_AUX: AuxNames = AuxNames {
    approach: c"data->aux->approach",
    temp_c: c"data->aux->temp_c",
};

/// The core joint state of checked readings `q` (length N) and optional aux data. Inlined:
/// returned through memory, the state's stores and the caller's wider loads stall the FK hot
/// path (store forwarding fails).
#[inline(always)]
pub(crate) fn joint_state<const N: usize>(
    q: &[f64],
    aux: Option<&kincal_joint_aux>,
    names: AuxNames,
) -> FfiResult<JointState<N>> {
    let q: [f64; N] = q
        .try_into()
        .map_err(|_| crate::args::bad_length(c"q", N, q.len()))?;
    let mut s = JointState::new(q);
    if let Some(a) = aux {
        if a.has_approach != 0 {
            let ap: [f64; N] = a
                .approach
                .get(..N)
                .and_then(|s| s.try_into().ok())
                .ok_or(kincal_error::new(kincal_status::Internal))?;
            if let Some(j) = ap.iter().position(|&v| v != -1.0 && v != 0.0 && v != 1.0) {
                let v = ap.get(j).copied().unwrap_or(f64::NAN);
                let status = if v.is_finite() {
                    kincal_status::InvalidArgument
                } else {
                    kincal_status::NonFinite
                };
                return Err(kincal_error::new(status).arg(names.approach).at(j).value(v));
            }
            s.approach = Some(ap);
        }
        if a.has_temp != 0 {
            crate::args::finite(&[a.temp_c], names.temp_c)?;
            s.temp_c = Some(a.temp_c);
        }
    }
    Ok(s)
}

/// The common prologue of the joint-space exports: robot converted, `q` checked (length N,
/// finite), `aux` checked. Returns the robot and a copy of `q`.
///
/// # Safety
/// `robot`, `q`, `aux` NULL or valid as the exports document.
pub(crate) unsafe fn robot_and_q(
    robot: *const kincal_robot,
    q: *const f64,
    q_len: usize,
    q_name: &'static CStr,
    aux: *const kincal_joint_aux,
) -> FfiResult<(AnyRobot, [f64; KINCAL_MAX_JOINTS], Option<kincal_joint_aux>)> {
    let r = arg_ref!(robot);
    let any = to_any(r)?;
    // SAFETY: forwarded contract.
    let (q, aux) = unsafe { joint_args(any.n_joints(), q, q_len, q_name, aux) }?;
    Ok((any, q, aux))
}

/// The joint arguments of an `n`-joint export: `q` checked (length `n`, finite) and copied,
/// `aux` copied (NULL: none).
///
/// # Safety
/// `q`, `aux` NULL or valid as the exports document.
pub(crate) unsafe fn joint_args(
    n: usize,
    q: *const f64,
    q_len: usize,
    q_name: &'static CStr,
    aux: *const kincal_joint_aux,
) -> FfiResult<([f64; KINCAL_MAX_JOINTS], Option<kincal_joint_aux>)> {
    // SAFETY: forwarded contract.
    let q = unsafe { crate::args::slice(q, q_len, n, q_name) }?;
    crate::args::finite(q, q_name)?;
    let aux = arg_opt!(aux).copied();
    let mut qq = [0.0; KINCAL_MAX_JOINTS];
    for (d, s) in qq.iter_mut().zip(q) {
        *d = *s;
    }
    Ok((qq, aux))
}

fn q_n(q: &[f64; KINCAL_MAX_JOINTS], n: usize) -> FfiResult<&[f64]> {
    q.get(..n).ok_or(kincal_error::new(kincal_status::Internal))
}

pub(crate) fn fk_of<const N: usize>(
    r: &Robot<N>,
    q: &[f64; KINCAL_MAX_JOINTS],
    aux: Option<&kincal_joint_aux>,
) -> FfiResult<Transform> {
    Ok(r.fk(&joint_state::<N>(q_n(q, N)?, aux, CALL_AUX)?)?)
}

/// Forward kinematics: the tool pose `T_e^b` (end effector in the base frame, effects
/// compensated) as a 4×4 column-major matrix.
///
/// - `robot`: the model (read only; the library keeps no pointer to it).
/// - `q`, `q_len`: joint readings [rad], `q_len` = `robot->n_joints` (else BAD_LENGTH).
/// - `aux`: approach directions / temperature, or NULL (then a model with backlash or thermal
///   expansion returns MISSING_INPUT).
/// - `t_base_tool_out`, `t_base_tool_len`: 16 doubles, written on success only.
/// - `err`: detail on failure, or NULL.
///
/// Joint limits are not checked (see `kincal_robot_check_limits`). Returns OK, NULL_POINTER,
/// MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE, INVALID_ARGUMENT (an approach direction not
/// −1/0/+1), MISSING_INPUT or any status of `kincal_robot_validate`.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_fk(
    robot: *const kincal_robot,
    q: *const f64,
    q_len: usize,
    aux: *const kincal_joint_aux,
    t_base_tool_out: *mut f64,
    t_base_tool_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let (any, q, aux) = unsafe { robot_and_q(robot, q, q_len, c"q", aux) }?;
        let out = arg_out!(t_base_tool_out, t_base_tool_len, 16);
        let t = with_any_robot!(&any, r => fk_of(r, &q, aux.as_ref()))?;
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&crate::pose::to_matrix(&t)) }?;
        Ok(())
    })
}

/// As `kincal_fk`, with the pose as position + quaternion `[px, py, pz, qw, qx, qy, qz]`
/// (metres; unit quaternion, qw ≥ 0) in `pq_out` (7 doubles).
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_fk_pq(
    robot: *const kincal_robot,
    q: *const f64,
    q_len: usize,
    aux: *const kincal_joint_aux,
    pq_out: *mut f64,
    pq_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let (any, q, aux) = unsafe { robot_and_q(robot, q, q_len, c"q", aux) }?;
        let out = arg_out!(pq_out, pq_len, 7);
        let t = with_any_robot!(&any, r => fk_of(r, &q, aux.as_ref()))?;
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&crate::pose::to_pq(&t)) }?;
        Ok(())
    })
}

/// Largest `frames_len` of `kincal_fk_frames`: 16·(`KINCAL_MAX_JOINTS` + 2).
pub const KINCAL_MAX_FRAMES_LEN: usize = 224;
const _: () = assert!(KINCAL_MAX_FRAMES_LEN == 16 * (KINCAL_MAX_JOINTS + 2));

fn frames_of<const N: usize>(
    r: &Robot<N>,
    q: &[f64; KINCAL_MAX_JOINTS],
    aux: Option<&kincal_joint_aux>,
    out: &mut [f64; KINCAL_MAX_FRAMES_LEN],
) -> FfiResult {
    let mut f = Frames::<N>::default();
    r.fk_frames(&joint_state::<N>(q_n(q, N)?, aux, CALL_AUX)?, &mut f)?;
    let all = core::iter::once(&f.t_base_0)
        .chain(f.t_base_link.iter())
        .chain(core::iter::once(&f.t_base_ee));
    // `as_chunks_mut` rather than `chunks_exact_mut(16)`: the latter's length division by a
    // run-time chunk size stays a panic path at opt-level z.
    for (dst, t) in out.as_chunks_mut::<16>().0.iter_mut().zip(all) {
        *dst = crate::pose::to_matrix(t);
    }
    Ok(())
}

/// Every frame of one FK evaluation, in the base frame, as N + 2 consecutive 4×4 column-major
/// matrices in `frames_out` (`frames_len` = 16·(N + 2) doubles): `T_0^b` (frame 0, before joint
/// 1), then frames 1..N (`T_0^b·A_1···A_i`), then the tool `T_e^b`. Arguments and statuses as
/// `kincal_fk`.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_fk_frames(
    robot: *const kincal_robot,
    q: *const f64,
    q_len: usize,
    aux: *const kincal_joint_aux,
    frames_out: *mut f64,
    frames_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let (any, q, aux) = unsafe { robot_and_q(robot, q, q_len, c"q", aux) }?;
        let out = arg_out!(frames_out, frames_len, 16 * (any.n_joints() + 2));
        let mut buf = [0.0; KINCAL_MAX_FRAMES_LEN];
        with_any_robot!(&any, r => frames_of(r, &q, aux.as_ref(), &mut buf))?;
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&buf) }?;
        Ok(())
    })
}

/// The identification Jacobian at `q`: a 6 × P column-major matrix in `jac_out`, column `i` =
/// ∂[p; φ]/∂param_i, rows `[Δp (m); Δφ (rad)]` in the base frame (the row order of
/// `kincal_pose_error`). P is chosen by `jac_len`:
/// `6 * kincal_num_geometric_params(N)` (links, base, tool: the first 5N + 12 parameters) or
/// `6 * kincal_num_params(N)` (also every effect column); anything else is BAD_LENGTH with
/// `expected` = the full size. Link columns follow eq. (13a–e) of the ARIA paper.
///
/// - `t_base_tool_out`, `t_base_tool_len`: the pose at `q` (16 doubles, column-major), or NULL.
///
/// Every column is written (the caller need not zero the buffer). On failure the contents of
/// `jac_out` are unspecified; NON_FINITE_RESULT when a column overflowed (finite parameters
/// too large for double precision). Other arguments and statuses as `kincal_fk`.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `jac_out` must not overlap the
/// other arguments; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_jacobian(
    robot: *const kincal_robot,
    q: *const f64,
    q_len: usize,
    aux: *const kincal_joint_aux,
    jac_out: *mut f64,
    jac_len: usize,
    t_base_tool_out: *mut f64,
    t_base_tool_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let (any, q, aux) = unsafe { robot_and_q(robot, q, q_len, c"q", aux) }?;
        let n = any.n_joints();
        let cols = if jac_len == 6 * num_geometric_params(n) {
            num_geometric_params(n)
        } else {
            num_params(n)
        };
        let mut jac = arg_out!(jac_out, jac_len, 6 * cols);
        let t_out = arg_out_opt!(t_base_tool_out, t_base_tool_len, 16);
        // SAFETY: checked by `arg_out!`; writable by contract, no other reference into it.
        let flat = unsafe { jac.as_mut_slice() };
        let (columns, _) = flat.as_chunks_mut::<6>();
        let t = with_any_robot!(&any, r => jacobian_of(r, &q, aux.as_ref(), columns))?;
        // Finite lengths near 1e308 overflow the columns: never OK with an infinity in them.
        crate::args::finite_result(flat, c"jac_out")?;
        if let Some(o) = t_out {
            // SAFETY: checked by `arg_out_opt!`; writable by contract.
            unsafe { o.write_finite(&crate::pose::to_matrix(&t)) }?;
        }
        Ok(())
    })
}

pub(crate) fn jacobian_of<const N: usize>(
    r: &Robot<N>,
    q: &[f64; KINCAL_MAX_JOINTS],
    aux: Option<&kincal_joint_aux>,
    columns: &mut [[f64; 6]],
) -> FfiResult<Transform> {
    Ok(r.jacobian(&joint_state::<N>(q_n(q, N)?, aux, CALL_AUX)?, columns)?)
}

fn per_joint<const N: usize>(v: &[f64; N]) -> [f64; KINCAL_MAX_JOINTS] {
    let mut out = [0.0; KINCAL_MAX_JOINTS];
    for (d, s) in out.iter_mut().zip(v) {
        *d = *s;
    }
    out
}

/// Gravity torque about each joint axis [N·m] at readings `q` (`tau_out`, N doubles), from the
/// mass model and the nominal geometry: τ_j = z_{j−1}·Σ_{k≥j}(c_k − p_{j−1}) × (m_k·g); a
/// positive compliance moves a joint the way gravity pulls. Returns OK, NULL_POINTER,
/// MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE or any status of `kincal_robot_validate`.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_gravity_torques(
    robot: *const kincal_robot,
    q: *const f64,
    q_len: usize,
    tau_out: *mut f64,
    tau_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let (any, q, _) = unsafe { robot_and_q(robot, q, q_len, c"q", core::ptr::null()) }?;
        let out = arg_out!(tau_out, tau_len, any.n_joints());
        let tau = with_any_robot!(&any, r => gravity_of(r, &q))?;
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&tau) }?;
        Ok(())
    })
}

/// The joint angles the geometry sees after the joint effects (compliance, scale, cyclic,
/// backlash), `q_j + Δθ_j` without θ0, in `angles_out` (N doubles) [rad]: what a controller
/// compensating the calibrated model works with. Arguments and statuses as `kincal_fk`.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_joint_angles(
    robot: *const kincal_robot,
    q: *const f64,
    q_len: usize,
    aux: *const kincal_joint_aux,
    angles_out: *mut f64,
    angles_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let (any, q, aux) = unsafe { robot_and_q(robot, q, q_len, c"q", aux) }?;
        let out = arg_out!(angles_out, angles_len, any.n_joints());
        let angles = with_any_robot!(&any, r => angles_of(r, &q, aux.as_ref()))?;
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&angles) }?;
        Ok(())
    })
}

fn gravity_of<const N: usize>(
    r: &Robot<N>,
    q: &[f64; KINCAL_MAX_JOINTS],
) -> FfiResult<[f64; KINCAL_MAX_JOINTS]> {
    let s = joint_state::<N>(q_n(q, N)?, None, CALL_AUX)?;
    let tau = r.gravity_torques(&s.q);
    // Finite but absurd lengths or masses can overflow to NaN: never return that as OK
    // (found by fuzzing, fuzz/seeds/c_abi/regression-gravity-overflow-nan).
    if let Some(index) = tau.iter().position(|t| !t.is_finite()) {
        return Err(kincal::Error::NonFinite {
            what: kincal::Quantity::Parameter,
            index,
        }
        .into());
    }
    Ok(per_joint(&tau))
}

pub(crate) fn angles_of<const N: usize>(
    r: &Robot<N>,
    q: &[f64; KINCAL_MAX_JOINTS],
    aux: Option<&kincal_joint_aux>,
) -> FfiResult<[f64; KINCAL_MAX_JOINTS]> {
    Ok(per_joint(&r.joint_angles(&joint_state::<N>(
        q_n(q, N)?,
        aux,
        CALL_AUX,
    )?)?))
}

/// Checks that every reading of `q` (N doubles [rad]) lies within the joint limits
/// (inclusive). Returns OK, OUT_OF_LIMITS (`joint`, `value`, `lower`, `upper`), NULL_POINTER,
/// MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE or any status of `kincal_robot_validate`.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_check_limits(
    robot: *const kincal_robot,
    q: *const f64,
    q_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let (any, q, _) = unsafe { robot_and_q(robot, q, q_len, c"q", core::ptr::null()) }?;
        with_any_robot!(&any, r => limits_of(r, &q))
    })
}

fn limits_of<const N: usize>(r: &Robot<N>, q: &[f64; KINCAL_MAX_JOINTS]) -> FfiResult {
    let s = joint_state::<N>(q_n(q, N)?, None, CALL_AUX)?;
    Ok(r.check_limits(&s.q)?)
}
