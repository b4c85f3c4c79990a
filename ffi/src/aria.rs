//! The built-in ARIA arm (K. Arent et al., Bull. Pol. Acad. Sci. 72(6), 2024): Table 1
//! nominal model, Table 3 virtual truth, Table 4 real identification, Table 2 tool poses.

use kincal::any::AnyRobot;
use kincal::aria;

use crate::robot::{from_any, kincal_robot};
use crate::status::{kincal_error, kincal_status};

/// Joint count of ARIA.
pub const KINCAL_ARIA_NUM_JOINTS: usize = 6;
/// Number of Table 2 calibration-tool poses.
pub const KINCAL_ARIA_NUM_TOOL_POSES: usize = 10;
const _: () = assert!(KINCAL_ARIA_NUM_JOINTS == aria::N);
const _: () = assert!(KINCAL_ARIA_NUM_TOOL_POSES == aria::TOOL_POSES.len());

/// Which built-in ARIA model `kincal_robot_aria` writes.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_aria_model {
    /// Table 1 nominal geometry with joint limits (eq. 2; q3 lower limit assumed −π) and the
    /// assumed mass model.
    Nominal = 0,
    /// Table 3: the virtual "true" robot of the paper's simulation study (nominal geometry
    /// Table 1).
    VirtualTruth = 1,
    /// Table 4: the real robot identified from motion-capture data (nominal geometry Table 1).
    RealIdentified = 2,
}

/// Writes a built-in ARIA model (`model` is a `kincal_aria_model`) into `robot_out` (need not be
/// initialised; written on success only). Identity base and tool, no effects. Returns OK,
/// NULL_POINTER, MISALIGNED_POINTER or INVALID_ARGUMENT (`model`).
///
/// # Safety
/// `robot_out` must be NULL or writable; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_aria(
    robot_out: *mut kincal_robot,
    model: u32,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let out = arg_out1!(robot_out);
        let robot = match model {
            0 => aria::nominal(),
            1 => aria::virtual_truth(),
            2 => aria::real_identified(),
            v => {
                return Err(kincal_error::new(kincal_status::InvalidArgument)
                    .arg(c"model")
                    .value(f64::from(v)));
            }
        };
        let r = from_any(&AnyRobot::from(robot))?;
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(r) };
        Ok(())
    })
}

/// Table 2 calibration-tool pose `index` (zero-based, < `KINCAL_ARIA_NUM_TOOL_POSES`) as a 4×4
/// column-major pose in `t_out` (16 doubles). Returns OK, NULL_POINTER, MISALIGNED_POINTER,
/// BAD_LENGTH or INDEX_OUT_OF_RANGE.
///
/// # Safety
/// `t_out` must be NULL or writable for `t_len` doubles; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_aria_tool_pose(
    index: usize,
    t_out: *mut f64,
    t_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let out = arg_out!(t_out, t_len, 16);
        let t = aria::tool_pose(index).ok_or(
            kincal_error::new(kincal_status::IndexOutOfRange)
                .arg(c"index")
                .at(index)
                .counts(KINCAL_ARIA_NUM_TOOL_POSES, index),
        )?;
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&crate::pose::to_matrix(&t)) }?;
        Ok(())
    })
}

/// A configuration near the Table 2 tool poses [rad] (6 doubles in `q_out`), the IK seed that
/// solves every tool pose on the same branch. Returns OK, NULL_POINTER, MISALIGNED_POINTER or
/// BAD_LENGTH.
///
/// # Safety
/// `q_out` must be NULL or writable for `q_len` doubles; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_aria_tool_seed(
    q_out: *mut f64,
    q_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let out = arg_out!(q_out, q_len, KINCAL_ARIA_NUM_JOINTS);
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&aria::TOOL_SEED_Q) }?;
        Ok(())
    })
}
