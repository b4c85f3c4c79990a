//! Non-geometric effects (spec/effects.md) on the model: names, masks, which are active, and
//! clearing them. Their parameters are ordinary parameters (`compliance_2`, `scale_1`,
//! `cyclic_sin1_4`, `backlash_6`, `thermal_kappa`, `base_*`, `tool_*`): set them with
//! `kincal_robot_set_param_by_label`; FK, IK and the Jacobian then compensate them.

use core::ffi::c_char;

use kincal::{Effect, EffectSet, with_any_robot};

use crate::robot::{edit, kincal_robot, to_any};
use crate::status::{FfiResult, kincal_error, kincal_status};

/// A non-geometric effect. In effect masks (`uint32_t effects`), bit k stands for effect k,
/// e.g. `(1u << KINCAL_EFFECT_JOINT_COMPLIANCE) | (1u << KINCAL_EFFECT_BACKLASH)`.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_effect {
    /// `base_frame`: measured poses are expressed in a base frame off by a small rigid
    /// transform (parameters `base_px` … `base_rz`).
    BaseFrame = 0,
    /// `tool_frame`: the probe/tool frame is off (`tool_px` … `tool_rz`).
    ToolFrame = 1,
    /// `joint_compliance`: Δθ_j = c_j·τ_j(q), τ_j the gravity torque (`compliance_j`,
    /// rad/(N·m)).
    JointCompliance = 2,
    /// `joint_scale`: Δθ_j = k_j·q_j (`scale_j`).
    JointScale = 3,
    /// `joint_cyclic`: Δθ_j = a·sin q + b·cos q + c·sin 2q + d·cos 2q (`cyclic_sin1_j`,
    /// `cyclic_cos1_j`, `cyclic_sin2_j`, `cyclic_cos2_j`, rad).
    JointCyclic = 4,
    /// `backlash`: Δθ_j = b_j·s_j, s_j the approach direction (`backlash_j`, rad); needs
    /// approach directions in `kincal_joint_aux`.
    Backlash = 5,
    /// `thermal`: every d and a times 1 + κ·(T − 20 °C) (`thermal_kappa`, 1/K); needs the
    /// temperature in `kincal_joint_aux`.
    Thermal = 6,
}

/// Mask of every effect.
pub const KINCAL_EFFECTS_ALL: u32 = 0x7f;

const _: () = {
    assert!(kincal_effect::BaseFrame as u32 == Effect::BaseFrame as u32);
    assert!(kincal_effect::ToolFrame as u32 == Effect::ToolFrame as u32);
    assert!(kincal_effect::JointCompliance as u32 == Effect::JointCompliance as u32);
    assert!(kincal_effect::JointScale as u32 == Effect::JointScale as u32);
    assert!(kincal_effect::JointCyclic as u32 == Effect::JointCyclic as u32);
    assert!(kincal_effect::Backlash as u32 == Effect::Backlash as u32);
    assert!(kincal_effect::Thermal as u32 == Effect::Thermal as u32);
};

/// The core effect set of a C mask, or INVALID_ARGUMENT for unknown bits.
pub(crate) fn effect_set(mask: u32) -> FfiResult<EffectSet> {
    u8::try_from(mask)
        .ok()
        .and_then(EffectSet::from_bits)
        .ok_or_else(|| {
            kincal_error::new(kincal_status::InvalidArgument)
                .arg(c"effects")
                .value(f64::from(mask))
        })
}

fn effect_cname(e: Effect) -> &'static core::ffi::CStr {
    match e {
        Effect::BaseFrame => c"base_frame",
        Effect::ToolFrame => c"tool_frame",
        Effect::JointCompliance => c"joint_compliance",
        Effect::JointScale => c"joint_scale",
        Effect::JointCyclic => c"joint_cyclic",
        Effect::Backlash => c"backlash",
        Effect::Thermal => c"thermal",
    }
}

/// The public name of effect `effect` (`"base_frame"`, `"joint_compliance"`, …): a static
/// NUL-terminated string (never free it), or NULL when `effect` is not a `kincal_effect`.
#[unsafe(no_mangle)]
pub extern "C" fn kincal_effect_name(effect: u32) -> *const c_char {
    ffi_boundary!(on_panic = core::ptr::null(); {
        Effect::ALL
            .iter()
            .find(|e| **e as u32 == effect)
            .map_or(core::ptr::null(), |e| effect_cname(*e).as_ptr())
    })
}

/// The `kincal_effect` named `name` (NUL-terminated, e.g. `"joint_compliance"`), written to
/// `effect_out`. Returns OK, NULL_POINTER, MISALIGNED_POINTER or UNKNOWN_LABEL.
///
/// # Safety
/// `name` must be NULL or a NUL-terminated string; `effect_out` NULL or writable; `err` NULL or
/// writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_effect_from_name(
    name: *const c_char,
    effect_out: *mut u32,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let name = arg_str!(name);
        let out = arg_out1!(effect_out);
        let e = Effect::parse(name)
            .ok_or_else(|| kincal_error::new(kincal_status::UnknownLabel).arg(c"name"))?;
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(e as u32) };
        Ok(())
    })
}

/// The mask of the joint effects with a non-zero parameter in the model (compliance, scale,
/// cyclic, backlash, thermal; base and tool frames are geometry and never reported), written
/// to `effects_out`. Returns OK, NULL_POINTER, MISALIGNED_POINTER or any status of
/// `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable `kincal_robot`; `effects_out` NULL or writable;
/// `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_active_effects(
    robot: *const kincal_robot,
    effects_out: *mut u32,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let r = arg_ref!(robot);
        let out = arg_out1!(effects_out);
        let any = to_any(r)?;
        let set = with_any_robot!(&any, r => r.active_effects());
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(u32::from(set.bits())) };
        Ok(())
    })
}

/// Sets every parameter of the effects in the mask `effects` to zero (for `base_frame` and
/// `tool_frame`: the current base/tool frame becomes identity). On failure `*robot` is
/// unchanged. Returns OK, NULL_POINTER, MISALIGNED_POINTER, INVALID_ARGUMENT (unknown bits) or
/// any status of `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable and writable `kincal_robot`; `err` NULL or
/// writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_clear_effects(
    robot: *mut kincal_robot,
    effects: u32,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let set = effect_set(effects)?;
        // SAFETY: forwarded contract.
        unsafe {
            edit(robot, |any| {
                with_any_robot!(any, r => r.clear_effects(set));
                Ok(())
            })
        }
    })
}
