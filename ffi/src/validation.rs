//! Validation metrics (Section 4.4): per-pose errors of a model on measurements, their
//! summary against the paper's targets, and the biopsy requirement of eq. (3).

use kincal::validation::{
    ErrorSummary, PoseErrors, TARGET_POS_M, TARGET_ROT_RAD, Verdict, biopsy_allowed_rotation_rad,
};
use kincal::{Robot, with_any_robot};

use crate::identify::{Data, data_view, kincal_measurements};
use crate::robot::{kincal_robot, to_any};
use crate::status::{FfiResult, kincal_error, kincal_status};

/// The paper's position target of Section 4.4: every pose error below 1 mm [m].
pub const KINCAL_TARGET_POS_M: f64 = 0.001;
/// The paper's orientation target: every pose error below 0.66° [rad].
pub const KINCAL_TARGET_ROT_RAD: f64 = 0.011519173063162576;
const _: () = assert!(KINCAL_TARGET_POS_M == TARGET_POS_M);
const _: () = assert!(KINCAL_TARGET_ROT_RAD == TARGET_ROT_RAD);

/// Doubles per pose in `kincal_validate`'s `errors_out`: `[e_x, e_y, e_z] (m)`,
/// `[e_φx, e_φy, e_φz] (rad, exact rotation vector)`, `|e_p| (m)`, `|e_φ| (rad)`.
pub const KINCAL_POSE_ERRORS_LEN: usize = 8;

/// Summary of a validation: RMS (sqrt(mean |e|²)) and maximum of the error norms, and whether
/// the worst pose meets the targets.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_validation_summary {
    /// Number of poses.
    pub count: usize,
    /// RMS of |e_p| [m].
    pub rms_pos_m: f64,
    /// Largest |e_p| [m].
    pub max_pos_m: f64,
    /// RMS of |e_φ| [rad].
    pub rms_rot_rad: f64,
    /// Largest |e_φ| [rad].
    pub max_rot_rad: f64,
    /// 1 when every |e_p| is below the position target.
    pub pos_ok: u32,
    /// 1 when every |e_φ| is below the orientation target.
    pub rot_ok: u32,
}

fn validate_robot<const N: usize>(
    r: &Robot<N>,
    data: &Data<'_>,
    errors: &mut [f64],
) -> FfiResult<ErrorSummary> {
    let mut summary = ErrorSummary::default();
    for l in 0..data.n_poses() {
        let m = data.measurement::<N>(l)?;
        if m.mask.0 != 0x3f {
            return Err(kincal_error::new(kincal_status::InvalidArgument)
                .arg(c"data->masks")
                .at(l)
                .value(f64::from(m.mask.0)));
        }
        let t = r.fk(&m.state).map_err(|e| {
            let mut k = kincal_error::from(e);
            k.pose = l;
            k
        })?;
        let e = PoseErrors::between(&m.pose, &t);
        summary.add(&e);
        let [x, y, z] = e.pos_m;
        let [a, b, c] = e.rot_rad;
        let row = [x, y, z, a, b, c, e.pos_norm_m, e.rot_norm_rad];
        // Finite but huge measurements or lengths overflow the error norms.
        crate::args::finite_result(&row, c"errors_out").map_err(|mut k| {
            k.pose = l;
            k
        })?;
        if let Some(dst) = errors
            .as_chunks_mut::<KINCAL_POSE_ERRORS_LEN>()
            .0
            .get_mut(l)
        {
            *dst = row;
        }
    }
    Ok(summary)
}

/// Validates `robot` on measurements with full poses (every mask 0x3f): the error of each
/// pose, measured minus model in the base frame with the exact rotation-vector orientation
/// error, and their summary judged against `target_pos_m` [m] and `target_rot_rad` [rad]
/// (the paper's: `KINCAL_TARGET_POS_M`, `KINCAL_TARGET_ROT_RAD`).
///
/// - `errors_out`, `errors_len`: `KINCAL_POSE_ERRORS_LEN`·L doubles (see there), or NULL.
/// - `summary_out`: required.
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE, INVALID_TRANSFORM,
/// INVALID_ARGUMENT (`pose` set for a partial mask or bad approach direction; a target not
/// positive), MISSING_INPUT, TOO_FEW_DATA, NON_FINITE_RESULT (an error or the summary
/// overflowed: `argument` names which, `pose` the pose) or any status of
/// `kincal_robot_validate`. `summary_out` is written on success only, `errors_out` row by row
/// (on failure it may hold the rows before the failing pose); it must not overlap the inputs.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_validate(
    robot: *const kincal_robot,
    data: *const kincal_measurements,
    target_pos_m: f64,
    target_rot_rad: f64,
    errors_out: *mut f64,
    errors_len: usize,
    summary_out: *mut kincal_validation_summary,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let r = arg_ref!(robot);
        let out = arg_out1!(summary_out);
        for (v, name) in [(target_pos_m, c"target_pos_m"), (target_rot_rad, c"target_rot_rad")] {
            crate::args::finite(&[v], name)?;
            if v <= 0.0 {
                return Err(kincal_error::new(kincal_status::InvalidArgument).arg(name).value(v));
            }
        }
        let any = to_any(r)?;
        // SAFETY: forwarded contract.
        let view = unsafe { data_view(data, any.n_joints()) }?;
        let n_err = view.n_poses() * KINCAL_POSE_ERRORS_LEN;
        let mut errors = arg_out_opt!(errors_out, errors_len, n_err);
        let mut empty: [f64; 0] = [];
        let buf: &mut [f64] = match errors.as_mut() {
            // SAFETY: checked by `arg_out_opt!`; writable by contract; no other reference
            // into it (inputs were read into `view`, which the contract keeps disjoint).
            Some(o) => unsafe { o.as_mut_slice() },
            None => &mut empty,
        };
        let summary = with_any_robot!(&any, r => validate_robot(r, &view, buf))?;
        let verdict = Verdict::judge(&summary, target_pos_m, target_rot_rad);
        let s = kincal_validation_summary {
            count: summary.count,
            rms_pos_m: summary.rms_pos_m(),
            max_pos_m: summary.max_pos_m,
            rms_rot_rad: summary.rms_rot_rad(),
            max_rot_rad: summary.max_rot_rad,
            pos_ok: u32::from(verdict.pos_ok),
            rot_ok: u32::from(verdict.rot_ok),
        };
        // The sums of squares can overflow even when every row is finite.
        crate::args::finite_result(
            &[s.rms_pos_m, s.max_pos_m, s.rms_rot_rad, s.max_rot_rad],
            c"summary_out",
        )?;
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(s) };
        Ok(())
    })
}

/// Eq. (3): the largest orientation error [rad] that keeps the needle tip inside a tumour of
/// radius `r_t_m` [m] when the puncture point is off by `d_m` [m] and the insertion is at most
/// `l_max_m` [m] long, `2·asin((r_t − d)/(2·√2·l_max))`, written to `rotation_out` (0.66° for
/// 5 mm, √3 mm, 0.2 m). Returns OK, NULL_POINTER, MISALIGNED_POINTER, NON_FINITE or
/// INVALID_PARAMETER (`index` 0: r_t ≤ 0; 1: d outside [0, r_t); 2: l_max ≤ 0).
///
/// # Safety
/// `rotation_out` must be NULL or writable; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_biopsy_allowed_rotation(
    r_t_m: f64,
    d_m: f64,
    l_max_m: f64,
    rotation_out: *mut f64,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let out = arg_out1!(rotation_out);
        let v = biopsy_allowed_rotation_rad(r_t_m, d_m, l_max_m)?;
        crate::args::finite_result(&[v], c"rotation_out")?;
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(v) };
        Ok(())
    })
}
