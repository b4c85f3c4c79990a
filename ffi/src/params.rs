//! Parameters by flat index and by label (`theta0_3`, `beta_2`, `base_px`, `compliance_2`,
//! `cyclic_sin1_4`, `thermal_kappa`, …), the whole vector at once, and the default
//! identification mask.

use core::ffi::c_char;
use core::fmt::Write as _;

use kincal::params::{ParamId, num_params};
use kincal::{ParamIndex, with_any_robot};

use crate::robot::{edit, kincal_robot, n_joints_of, to_any};
use crate::status::{FfiResult, kincal_error, kincal_status};

/// A buffer of this many bytes holds every parameter label with its terminating NUL.
pub const KINCAL_LABEL_CAPACITY: usize = 32;

fn index_error(index: usize, count: usize) -> kincal_error {
    kincal_error::new(kincal_status::IndexOutOfRange)
        .arg(c"index")
        .at(index)
        .counts(count, index)
}

/// The flat index of `label` in an `n`-joint model.
fn parse_label(label: &str, n: usize) -> FfiResult<usize> {
    ParamId::parse(label, n)
        .map(|id| id.index(n).0)
        .ok_or_else(|| kincal_error::new(kincal_status::UnknownLabel).arg(c"label"))
}

/// The value of parameter `index` (flat layout, see `kincal_robot.params`).
///
/// - `value_out`: one double, written on success only; unit by parameter (m, rad,
///   rad/(N·m), 1, 1/K).
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, INDEX_OUT_OF_RANGE (`index >=
/// kincal_num_params(N)`) or any status of `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable `kincal_robot`; `value_out` NULL or writable;
/// `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_get_param(
    robot: *const kincal_robot,
    index: usize,
    value_out: *mut f64,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let r = arg_ref!(robot);
        let out = arg_out1!(value_out);
        let any = to_any(r)?;
        let n = any.n_joints();
        if index >= num_params(n) {
            return Err(index_error(index, num_params(n)));
        }
        let v = with_any_robot!(&any, r => r.param(ParamIndex(index)))?;
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(v) };
        Ok(())
    })
}

/// Sets parameter `index` (flat layout) of the current model to `value` (finite). On failure
/// `*robot` is unchanged. Returns OK, NULL_POINTER, MISALIGNED_POINTER, INDEX_OUT_OF_RANGE,
/// NON_FINITE or any status of `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable and writable `kincal_robot`; `err` NULL or
/// writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_set_param(
    robot: *mut kincal_robot,
    index: usize,
    value: f64,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let n = unsafe { n_joints_of(robot) }?;
        if index >= num_params(n) {
            return Err(index_error(index, num_params(n)));
        }
        crate::args::finite(&[value], c"value")?;
        // SAFETY: forwarded contract.
        unsafe {
            edit(robot, |any| {
                with_any_robot!(any, r => r.set_param(ParamIndex(index), value)?);
                Ok(())
            })
        }
    })
}

/// The flat index of the parameter labelled `label` (NUL-terminated, e.g. `"theta0_3"`,
/// `"beta_2"`, `"base_px"`, `"tool_rz"`, `"compliance_2"`, `"scale_1"`, `"cyclic_sin1_4"`,
/// `"backlash_6"`, `"thermal_kappa"`; link and joint numbers are 1-based).
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, UNKNOWN_LABEL or any status of
/// `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable `kincal_robot`; `label` NULL or a NUL-terminated
/// string; `index_out` NULL or writable; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_param_index(
    robot: *const kincal_robot,
    label: *const c_char,
    index_out: *mut usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let n = unsafe { n_joints_of(robot) }?;
        let label = arg_str!(label);
        let out = arg_out1!(index_out);
        let i = parse_label(label, n)?;
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(i) };
        Ok(())
    })
}

/// The value of the parameter labelled `label` (see `kincal_robot_param_index`). Returns as
/// `kincal_robot_get_param`, plus UNKNOWN_LABEL.
///
/// # Safety
/// As `kincal_robot_param_index`, with `value_out` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_get_param_by_label(
    robot: *const kincal_robot,
    label: *const c_char,
    value_out: *mut f64,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let r = arg_ref!(robot);
        let label = arg_str!(label);
        let out = arg_out1!(value_out);
        let any = to_any(r)?;
        let i = parse_label(label, any.n_joints())?;
        let v = with_any_robot!(&any, r => r.param(ParamIndex(i)))?;
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(v) };
        Ok(())
    })
}

/// Sets the parameter labelled `label` (see `kincal_robot_param_index`) to `value` (finite).
/// On failure `*robot` is unchanged. Returns as `kincal_robot_set_param`, plus UNKNOWN_LABEL.
///
/// # Safety
/// `robot` must be NULL or point to a readable and writable `kincal_robot`; `label` NULL or a
/// NUL-terminated string; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_set_param_by_label(
    robot: *mut kincal_robot,
    label: *const c_char,
    value: f64,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let n = unsafe { n_joints_of(robot) }?;
        let label = arg_str!(label);
        let i = parse_label(label, n)?;
        crate::args::finite(&[value], c"value")?;
        // SAFETY: forwarded contract.
        unsafe {
            edit(robot, |any| {
                with_any_robot!(any, r => r.set_param(ParamIndex(i), value)?);
                Ok(())
            })
        }
    })
}

/// Writes fixed-capacity text (no allocation).
struct Label {
    buf: [u8; KINCAL_LABEL_CAPACITY],
    len: usize,
}

impl core::fmt::Write for Label {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        for &b in s.as_bytes() {
            let slot = self.buf.get_mut(self.len).ok_or(core::fmt::Error)?;
            *slot = b;
            self.len += 1;
        }
        Ok(())
    }
}

/// The label of parameter `index` of an `N`-joint robot. Generic over `N` so the layout
/// arithmetic is constant and the build stays panic-free.
fn label_of<const N: usize>(_: &kincal::Robot<N>, index: usize) -> FfiResult<Label> {
    if index >= num_params(N) {
        return Err(index_error(index, num_params(N)));
    }
    let id = ParamId::from_index(ParamIndex(index), N)?;
    let mut label = Label {
        buf: [0; KINCAL_LABEL_CAPACITY],
        len: 0,
    };
    write!(label, "{id}").map_err(|_| kincal_error::new(kincal_status::Internal))?;
    Ok(label)
}

/// Writes the label of parameter `index` (e.g. `"theta0_3"`) as a NUL-terminated string into
/// `label_out`, which holds `label_len` bytes; `KINCAL_LABEL_CAPACITY` bytes always suffice.
/// If the buffer is too small, returns BAD_LENGTH with `expected` = the bytes needed (NUL
/// included) and writes nothing.
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, INDEX_OUT_OF_RANGE, BAD_LENGTH or any status of
/// `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable `kincal_robot`; `label_out` NULL or writable for
/// `label_len` bytes; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_param_label(
    robot: *const kincal_robot,
    index: usize,
    label_out: *mut c_char,
    label_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let r = arg_ref!(robot);
        if label_out.is_null() {
            return Err(crate::args::null(c"label_out"));
        }
        let any = to_any(r)?;
        let label = with_any_robot!(&any, r => label_of(r, index))?;
        let needed = label.len + 1;
        if label_len < needed {
            return Err(crate::args::bad_length(c"label_out", needed, label_len));
        }
        let out = crate::args::Out::new(label_out, label_len, label_len, c"label_out")?;
        // The byte after the label is still 0 from initialisation: the NUL terminator.
        let bytes: [c_char; KINCAL_LABEL_CAPACITY] = label.buf.map(|b| b as c_char);
        let src = bytes.get(..needed).ok_or(kincal_error::new(kincal_status::Internal))?;
        // SAFETY: checked above; writable for `label_len >= needed` bytes by contract.
        unsafe { out.write(src) };
        Ok(())
    })
}

/// Copies every parameter (`params_len` = `kincal_num_params(N)` doubles, flat layout) into
/// `params_out`. Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH or any status of
/// `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable `kincal_robot`; `params_out` NULL or writable for
/// `params_len` doubles; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_get_params(
    robot: *const kincal_robot,
    params_out: *mut f64,
    params_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let n = unsafe { n_joints_of(robot) }?;
        let out = arg_out!(params_out, params_len, num_params(n));
        let r = arg_ref!(robot);
        let any = to_any(r)?;
        let mut p = [0.0; crate::robot::KINCAL_MAX_PARAMS];
        let dst = p.get_mut(..num_params(n)).ok_or(kincal_error::new(kincal_status::Internal))?;
        with_any_robot!(&any, r => r.read_params(dst))?;
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write_finite(&p) }?;
        Ok(())
    })
}

/// Sets every parameter from `params` (`params_len` = `kincal_num_params(N)` finite doubles,
/// flat layout). On failure `*robot` is unchanged. Returns OK, NULL_POINTER,
/// MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE or any status of `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable and writable `kincal_robot`; `params` NULL or
/// readable for `params_len` doubles; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_set_params(
    robot: *mut kincal_robot,
    params: *const f64,
    params_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let n = unsafe { n_joints_of(robot) }?;
        let src = arg_f64s!(params, params_len, num_params(n));
        let mut p = [0.0; crate::robot::KINCAL_MAX_PARAMS];
        for (d, s) in p.iter_mut().zip(src) {
            *d = *s;
        }
        let p = p.get(..num_params(n)).ok_or(kincal_error::new(kincal_status::Internal))?;
        // SAFETY: forwarded contract.
        unsafe {
            edit(robot, |any| {
                with_any_robot!(any, r => r.write_params(p)?);
                Ok(())
            })
        }
    })
}

/// The parameters identified by default, as a mask: `mask_out[i]` = 1 when parameter `i` is
/// identified, 0 when it is fixed (`mask_len` = `kincal_num_params(N)` bytes). By default θ0,
/// a, α and (d or β, see `kincal_robot.length_param`) of every link are identified, plus every
/// parameter of the effects in `effects` (a bit mask: bit k = effect k of `kincal_effect`).
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, INVALID_ARGUMENT (unknown effect
/// bits) or any status of `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable `kincal_robot`; `mask_out` NULL or writable for
/// `mask_len` bytes; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_param_mask(
    robot: *const kincal_robot,
    effects: u32,
    mask_out: *mut u8,
    mask_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let n = unsafe { n_joints_of(robot) }?;
        let out = arg_out!(mask_out, mask_len, num_params(n));
        let set = crate::effects::effect_set(effects)?;
        let r = arg_ref!(robot);
        let any = to_any(r)?;
        let ids = with_any_robot!(&any, r => r.param_set(set));
        let mut mask = [0u8; crate::robot::KINCAL_MAX_PARAMS];
        for (i, m) in mask.iter_mut().enumerate() {
            *m = u8::from(ids.contains(i));
        }
        // SAFETY: checked by `arg_out!`; writable by contract.
        unsafe { out.write(&mask) };
        Ok(())
    })
}
