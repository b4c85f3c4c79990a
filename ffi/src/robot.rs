//! The robot model as caller-owned plain data (`kincal_robot`), its conversion to the core's
//! [`AnyRobot`], and the exports that build and edit it.
//!
//! Why a plain struct and not an opaque handle: firmware has no heap, and a plain struct can be
//! kept in static memory, copied, stored in flash and sent over a wire. Every bit pattern of
//! it is a valid *input*: each call converts it to the core model and validates every field it
//! uses (joint count, finiteness, limit order, masses, d/β choice), so a struct edited by hand
//! or restored from storage can never cause undefined behaviour, only a status code. The price
//! is that conversion, which rebuilds the precomputed link constants: a few microseconds, about
//! the cost of ten forward kinematics evaluations. Batch APIs (identification) convert once
//! per call, and control loops convert once into a prepared handle ([`crate::prepared`]).

use kincal::any::{AnyRobot, MAX_JOINTS};
use kincal::params::{num_geometric_params, num_params};
use kincal::{
    JointKind, JointLimits, LengthParam, Link, MassModel, ParamIndex, Robot, with_any_robot,
};

use crate::status::{FfiResult, kincal_error, kincal_status};

/// Largest joint count of a `kincal_robot`.
pub const KINCAL_MAX_JOINTS: usize = 12;
/// Capacity of `kincal_robot.params`: `kincal_num_params(KINCAL_MAX_JOINTS)` = 12·12 + 13.
pub const KINCAL_MAX_PARAMS: usize = 157;
/// Capacity of `kincal_robot.nominal`: `kincal_num_geometric_params(KINCAL_MAX_JOINTS)` =
/// 5·12 + 12.
pub const KINCAL_MAX_GEOMETRIC_PARAMS: usize = 72;

const _: () = assert!(KINCAL_MAX_JOINTS == MAX_JOINTS);
const _: () = assert!(KINCAL_MAX_PARAMS == num_params(KINCAL_MAX_JOINTS));
const _: () = assert!(KINCAL_MAX_GEOMETRIC_PARAMS == num_geometric_params(KINCAL_MAX_JOINTS));

/// Which of d and β a link identifies (values of `kincal_robot.length_param`).
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_length_param {
    /// Identify d, keep β at its nominal value (non-parallel consecutive axes).
    D = 0,
    /// Identify β, keep d at its nominal value (parallel consecutive axes).
    Beta = 1,
}

/// What a joint's reading moves (values of `kincal_robot.joint_kind`).
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_joint_kind {
    /// Rotation about the joint axis: `Rz(q + θ0)·Tz(d)·…`, reading and limits in radians.
    Revolute = 0,
    /// Translation along the joint axis: `Rz(θ0)·Tz(d + q)·…`, reading and limits in metres;
    /// its cyclic effect parameters must be zero.
    Prismatic = 1,
    /// A passive revolute joint read by a sensor (inclinometer or accelerometer tilt),
    /// reading in radians: not commanded (IK holds it at the seed's reading); its gain is
    /// the joint_scale parameter; its cyclic and backlash parameters must be zero.
    Sensor = 2,
}

/// A robot model with 1..=`KINCAL_MAX_JOINTS` revolute or prismatic joints: Hayati/mDH geometry, base and
/// tool frames, joint limits, point-mass model and effect parameters. Caller-owned plain data:
/// declare it anywhere (stack, static, flash), fill it with `kincal_robot_init` or
/// `kincal_robot_aria`, edit it with the `kincal_robot_*` setters or directly, and pass it to
/// every call. The library keeps no pointer to it and allocates nothing.
///
/// Every call validates the fields it uses and ignores entries beyond the joint count.
/// `sizeof(kincal_robot)` must equal `kincal_robot_size()` (checks that header and library
/// agree).
///
/// Units: metres, radians, kilograms, seconds.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_robot {
    /// Number of joints N, 1..=`KINCAL_MAX_JOINTS`.
    pub n_joints: u32,
    /// Per link: `KINCAL_LENGTH_PARAM_D` (0) or `KINCAL_LENGTH_PARAM_BETA` (1).
    pub length_param: [u32; KINCAL_MAX_JOINTS],
    /// Per joint: `KINCAL_JOINT_KIND_REVOLUTE` (0, what a zeroed struct holds),
    /// `KINCAL_JOINT_KIND_PRISMATIC` (1) or `KINCAL_JOINT_KIND_SENSOR` (2).
    pub joint_kind: [u32; KINCAL_MAX_JOINTS],
    /// Current parameters, first `kincal_num_params(N)` = 12N + 13 entries, in the flat layout
    /// of the core: `5i..5i+5` link i+1 [θ0, d, a, α, β]; `5N..5N+6` base [px, py, pz, rx, ry,
    /// rz] (Trans(p)·Rot(r), r a rotation vector); `5N+6..5N+12` tool, same form; then
    /// compliance (N) [rad/(N·m)], scale (N), cyclic (4N: sin q, cos q, sin 2q, cos 2q per
    /// joint) [rad], backlash (N) [rad], thermal κ [1/K]. Labels: `kincal_robot_param_label`.
    pub params: [f64; KINCAL_MAX_PARAMS],
    /// Nominal geometry (the description's), first `kincal_num_geometric_params(N)` = 5N + 12
    /// entries in the same layout as `params` (links, base, tool). Gravity torques are
    /// evaluated with it, so calibrating `params` does not move the mass model.
    pub nominal: [f64; KINCAL_MAX_GEOMETRIC_PARAMS],
    /// Lower joint limits [rad] ([m] for a prismatic joint), inclusive.
    pub limits_lower: [f64; KINCAL_MAX_JOINTS],
    /// Upper joint limits [rad] ([m] for a prismatic joint), inclusive.
    pub limits_upper: [f64; KINCAL_MAX_JOINTS],
    /// Mass of each link [kg], at the midpoint between the origins of frames k−1 and k.
    pub link_masses_kg: [f64; KINCAL_MAX_JOINTS],
    /// Mass of the tool [kg], at the end-effector origin.
    pub tool_mass_kg: f64,
    /// Gravity in the base frame [m/s²].
    pub gravity: [f64; 3],
}

impl kincal_robot {
    pub(crate) const ZERO: kincal_robot = kincal_robot {
        n_joints: 0,
        length_param: [0; KINCAL_MAX_JOINTS],
        joint_kind: [0; KINCAL_MAX_JOINTS],
        params: [0.0; KINCAL_MAX_PARAMS],
        nominal: [0.0; KINCAL_MAX_GEOMETRIC_PARAMS],
        limits_lower: [0.0; KINCAL_MAX_JOINTS],
        limits_upper: [0.0; KINCAL_MAX_JOINTS],
        link_masses_kg: [0.0; KINCAL_MAX_JOINTS],
        tool_mass_kg: 0.0,
        gravity: [0.0; 3],
    };
}

fn internal() -> kincal_error {
    kincal_error::new(kincal_status::Internal)
}

fn field_error(e: kincal::Error, name: &'static core::ffi::CStr) -> kincal_error {
    kincal_error::from(e).arg(name)
}

/// The core model of a validated `kincal_robot` with `N` joints.
fn to_robot<const N: usize>(r: &kincal_robot) -> FfiResult<Robot<N>> {
    let nominal = r
        .nominal
        .get(..num_geometric_params(N))
        .ok_or_else(internal)?;
    crate::args::finite(nominal, c"robot->nominal")?;
    let params = r.params.get(..num_params(N)).ok_or_else(internal)?;
    crate::args::finite(params, c"robot->params")?;
    let lower = r.limits_lower.get(..N).ok_or_else(internal)?;
    let upper = r.limits_upper.get(..N).ok_or_else(internal)?;
    let masses = r.link_masses_kg.get(..N).ok_or_else(internal)?;
    crate::args::finite(masses, c"robot->link_masses_kg")?;
    crate::args::finite(&[r.tool_mass_kg], c"robot->tool_mass_kg")?;
    crate::args::finite(&r.gravity, c"robot->gravity")?;

    let mut links = [Link::default(); N];
    // `as_chunks` rather than `chunks_exact(5)`: the latter divides by a run-time chunk size,
    // a panic path where it is not inlined (opt-level z).
    for (l, &[theta0, d, a, alpha, beta]) in links.iter_mut().zip(nominal.as_chunks::<5>().0) {
        *l = Link {
            theta0,
            d,
            a,
            alpha,
            beta,
        };
    }
    let mut limits = [JointLimits::new(0.0, 0.0); N];
    for (l, (&lo, &hi)) in limits.iter_mut().zip(lower.iter().zip(upper)) {
        *l = JointLimits::new(lo, hi);
    }
    let frame = |k: usize| -> FfiResult<[f64; 6]> {
        nominal
            .get(5 * N + 6 * k..5 * N + 6 * k + 6)
            .and_then(|s| <[f64; 6]>::try_from(s).ok())
            .ok_or_else(internal)
    };
    let mass = MassModel {
        link_masses_kg: <[f64; N]>::try_from(masses).map_err(|_| internal())?,
        tool_mass_kg: r.tool_mass_kg,
        gravity: r.gravity,
    };
    // Conversion cost matters (it runs on every call): frames and parameters already equal to
    // what the constructor set (identity frames, nominal links, zero effects) are not set
    // again, since every setter rebuilds precomputed link constants.
    let mut robot = Robot::new(links, limits).map_err(|e| field_error(e, c"robot->nominal"))?;
    let (base, tool) = (frame(0)?, frame(1)?);
    if base != [0.0; 6] {
        robot = robot
            .with_base(base)
            .map_err(|e| field_error(e, c"robot->nominal"))?;
    }
    if tool != [0.0; 6] {
        robot = robot
            .with_tool(tool)
            .map_err(|e| field_error(e, c"robot->nominal"))?;
    }
    let mut robot = robot
        .with_mass(mass)
        .map_err(|e| field_error(e, c"robot->link_masses_kg"))?;
    for (i, &choice) in r.length_param.iter().take(N).enumerate() {
        let lp = match choice {
            0 => LengthParam::D,
            1 => LengthParam::Beta,
            v => {
                return Err(kincal_error::new(kincal_status::InvalidArgument)
                    .arg(c"robot->length_param")
                    .at(i)
                    .value(f64::from(v)));
            }
        };
        robot.set_length_param(i, lp)?;
    }
    for (i, &kind) in r.joint_kind.iter().take(N).enumerate() {
        let k = match kind {
            0 => JointKind::Revolute,
            1 => JointKind::Prismatic,
            2 => JointKind::Sensor,
            v => {
                return Err(kincal_error::new(kincal_status::InvalidArgument)
                    .arg(c"robot->joint_kind")
                    .at(i)
                    .value(f64::from(v)));
            }
        };
        if k != JointKind::Revolute {
            robot
                .set_joint_kind(i, k)
                .map_err(|e| field_error(e, c"robot->params"))?;
        }
    }
    for (i, &v) in params.iter().enumerate() {
        if robot.param(ParamIndex(i))? != v {
            robot
                .set_param(ParamIndex(i), v)
                .map_err(|e| field_error(e, c"robot->params"))?;
        }
    }
    Ok(robot)
}

/// The plain struct of a core model.
pub(crate) fn from_robot<const N: usize>(r: &Robot<N>) -> FfiResult<kincal_robot> {
    let mut out = kincal_robot::ZERO;
    out.n_joints = u32::try_from(N).map_err(|_| internal())?;
    r.read_params(out.params.get_mut(..num_params(N)).ok_or_else(internal)?)?;
    for (c, l) in out
        .nominal
        .as_chunks_mut::<5>()
        .0
        .iter_mut()
        .zip(r.nominal_links())
    {
        *c = [l.theta0, l.d, l.a, l.alpha, l.beta];
    }
    let (base, tool) = r.nominal_frames();
    let frames = out
        .nominal
        .get_mut(5 * N..5 * N + 12)
        .ok_or_else(internal)?;
    for (dst, src) in frames.iter_mut().zip(base.iter().chain(tool.iter())) {
        *dst = *src;
    }
    for (j, lim) in r.limits().iter().enumerate() {
        if let (Some(lo), Some(hi)) = (out.limits_lower.get_mut(j), out.limits_upper.get_mut(j)) {
            *lo = lim.lower;
            *hi = lim.upper;
        }
    }
    for (j, dst) in out.joint_kind.iter_mut().take(N).enumerate() {
        *dst = match r.joint_kind(j) {
            JointKind::Revolute => kincal_joint_kind::Revolute as u32,
            JointKind::Prismatic => kincal_joint_kind::Prismatic as u32,
            JointKind::Sensor => kincal_joint_kind::Sensor as u32,
        };
    }
    for (dst, lp) in out.length_param.iter_mut().zip(r.length_params()) {
        *dst = match lp {
            LengthParam::D => kincal_length_param::D as u32,
            LengthParam::Beta => kincal_length_param::Beta as u32,
        };
    }
    let m = r.mass();
    for (dst, src) in out.link_masses_kg.iter_mut().zip(m.link_masses_kg.iter()) {
        *dst = *src;
    }
    out.tool_mass_kg = m.tool_mass_kg;
    out.gravity = m.gravity;
    Ok(out)
}

/// The core model of a `kincal_robot`, validating every field it uses.
pub(crate) fn to_any(r: &kincal_robot) -> FfiResult<AnyRobot> {
    Ok(match r.n_joints {
        1 => to_robot::<1>(r)?.into(),
        2 => to_robot::<2>(r)?.into(),
        3 => to_robot::<3>(r)?.into(),
        4 => to_robot::<4>(r)?.into(),
        5 => to_robot::<5>(r)?.into(),
        6 => to_robot::<6>(r)?.into(),
        7 => to_robot::<7>(r)?.into(),
        8 => to_robot::<8>(r)?.into(),
        9 => to_robot::<9>(r)?.into(),
        10 => to_robot::<10>(r)?.into(),
        11 => to_robot::<11>(r)?.into(),
        12 => to_robot::<12>(r)?.into(),
        n => {
            return Err(bad_joint_count(n as usize));
        }
    })
}

pub(crate) fn bad_joint_count(n: usize) -> kincal_error {
    kincal_error::new(kincal_status::BadJointCount)
        .arg(c"robot->n_joints")
        .counts(KINCAL_MAX_JOINTS, n)
}

/// The plain struct of a core model.
pub(crate) fn from_any(a: &AnyRobot) -> FfiResult<kincal_robot> {
    with_any_robot!(a, r => from_robot(r))
}

/// Reads `*robot`, converts it, lets `edit` change the core model, and writes it back. On
/// failure `*robot` is unchanged.
///
/// # Safety
/// `robot` is NULL or points to a readable and writable `kincal_robot`.
pub(crate) unsafe fn edit(
    robot: *mut kincal_robot,
    edit: impl FnOnce(&mut AnyRobot) -> FfiResult,
) -> FfiResult {
    let out = crate::args::Out::new(robot, 1, 1, c"robot")?;
    // SAFETY: non-NULL and aligned (checked by `Out::new`); readable by contract.
    let current = unsafe { robot.read() };
    let mut any = to_any(&current)?;
    edit(&mut any)?;
    let updated = from_any(&any)?;
    // SAFETY: writable by contract; no reference into `*robot` is alive.
    unsafe { out.put(updated) };
    Ok(())
}

/// Number of parameters (`kincal_robot.params` entries used) of an `n_joints` model: 12N + 13.
/// Returns 0 when `n_joints` is not in 1..=`KINCAL_MAX_JOINTS`.
#[unsafe(no_mangle)]
pub extern "C" fn kincal_num_params(n_joints: usize) -> usize {
    ffi_boundary!(on_panic = 0; {
        if (1..=KINCAL_MAX_JOINTS).contains(&n_joints) { num_params(n_joints) } else { 0 }
    })
}

/// Number of geometric parameters (links, base, tool; `kincal_robot.nominal` entries used) of
/// an `n_joints` model: 5N + 12. Returns 0 when `n_joints` is not in 1..=`KINCAL_MAX_JOINTS`.
#[unsafe(no_mangle)]
pub extern "C" fn kincal_num_geometric_params(n_joints: usize) -> usize {
    ffi_boundary!(on_panic = 0; {
        if (1..=KINCAL_MAX_JOINTS).contains(&n_joints) { num_geometric_params(n_joints) } else { 0 }
    })
}

/// `sizeof(kincal_robot)` as the library was built: compare with the header's to detect a
/// header/library mismatch.
#[unsafe(no_mangle)]
pub extern "C" fn kincal_robot_size() -> usize {
    ffi_boundary!(on_panic = 0; { core::mem::size_of::<kincal_robot>() })
}

/// Builds a robot from a parameter table: `n_joints` links with identity base and tool, no
/// masses, no effects, and the d/β choice made from axis parallelism (β for links whose axis is
/// parallel to the next one within 1°, d otherwise). This geometry is also the nominal one.
///
/// - `robot_out`: written on success only; need not be initialised.
/// - `n_joints`: 1..=`KINCAL_MAX_JOINTS`, else `KINCAL_STATUS_BAD_JOINT_COUNT`.
/// - `links`, `links_len`: row-major table of `5 * n_joints` doubles, one row per link
///   `[θ0 rad, d m, a m, α rad, β rad]`.
/// - `limits`, `limits_len`: `2 * n_joints` doubles, `[lower, upper]` per joint [rad].
/// - `err`: detail on failure, or NULL.
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_JOINT_COUNT, BAD_LENGTH, NON_FINITE or
/// INVALID_LIMITS.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_init(
    robot_out: *mut kincal_robot,
    n_joints: usize,
    links: *const f64,
    links_len: usize,
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
        let links = arg_f64s!(links, links_len, 5 * n_joints);
        let limits = arg_f64s!(limits, limits_len, 2 * n_joints);
        let mut ls = [Link::default(); KINCAL_MAX_JOINTS];
        for (l, &[theta0, d, a, alpha, beta]) in ls.iter_mut().zip(links.as_chunks::<5>().0) {
            *l = Link { theta0, d, a, alpha, beta };
        }
        let mut lims = [JointLimits::new(0.0, 0.0); KINCAL_MAX_JOINTS];
        for (l, &[lo, hi]) in lims.iter_mut().zip(limits.as_chunks::<2>().0) {
            *l = JointLimits::new(lo, hi);
        }
        let (ls, lims) = (
            ls.get(..n_joints).ok_or_else(internal)?,
            lims.get(..n_joints).ok_or_else(internal)?,
        );
        let any = AnyRobot::new(ls, lims).map_err(|e| match e {
            kincal::Error::InvalidLimits { .. } => kincal_error::from(e).arg(c"limits"),
            _ => kincal_error::from(e).arg(c"links"),
        })?;
        let r = from_any(&any)?;
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(r) };
        Ok(())
    })
}

/// Checks a robot the caller filled or edited directly: returns the status any call would
/// return for it (OK when every used field is valid).
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_JOINT_COUNT, NON_FINITE, INVALID_LIMITS,
/// INVALID_PARAMETER or INVALID_ARGUMENT (a `length_param` entry not 0/1).
///
/// # Safety
/// `robot` must be NULL or point to a readable `kincal_robot`; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_validate(
    robot: *const kincal_robot,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let r = arg_ref!(robot);
        to_any(r)?;
        Ok(())
    })
}

/// Sets the base frame `T_0^b` = Trans(p)·Rot(r) as `[px, py, pz, rx, ry, rz]` (metres and a
/// rotation vector in radians), both current and nominal (use `kincal_robot_set_param` with
/// `base_*` labels to change only the current one). `base_len` must be 6.
///
/// On failure `*robot` is unchanged. Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH,
/// NON_FINITE or any status of `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable and writable `kincal_robot`; `base` NULL or
/// readable for `base_len` doubles; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_set_base(
    robot: *mut kincal_robot,
    base: *const f64,
    base_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let base: [f64; 6] = <[f64; 6]>::try_from(arg_f64s!(base, base_len, 6)).map_err(|_| internal())?;
        // SAFETY: forwarded contract.
        unsafe {
            edit(robot, |any| {
                with_any_robot!(any, r => *r = r.with_base(base)?);
                Ok(())
            })
        }
    })
}

/// Sets the tool frame `T_e^N` = Trans(p)·Rot(r) relative to the last link frame as
/// `[px, py, pz, rx, ry, rz]` (metres, rotation vector in radians), both current and nominal.
/// `tool_len` must be 6. On failure `*robot` is unchanged; statuses as
/// `kincal_robot_set_base`.
///
/// # Safety
/// As `kincal_robot_set_base`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_set_tool(
    robot: *mut kincal_robot,
    tool: *const f64,
    tool_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let tool: [f64; 6] = <[f64; 6]>::try_from(arg_f64s!(tool, tool_len, 6)).map_err(|_| internal())?;
        // SAFETY: forwarded contract.
        unsafe {
            edit(robot, |any| {
                with_any_robot!(any, r => *r = r.with_tool(tool)?);
                Ok(())
            })
        }
    })
}

/// Sets the joint limits: `limits_len` = 2N doubles `[lower, upper]` per joint [rad],
/// inclusive. On failure `*robot` is unchanged. Returns OK, NULL_POINTER, MISALIGNED_POINTER,
/// BAD_LENGTH, NON_FINITE, INVALID_LIMITS or any status of `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable and writable `kincal_robot`; `limits` NULL or
/// readable for `limits_len` doubles; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_set_limits(
    robot: *mut kincal_robot,
    limits: *const f64,
    limits_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let n = unsafe { n_joints_of(robot) }?;
        let limits = arg_f64s!(limits, limits_len, 2 * n);
        let mut lims = [JointLimits::new(0.0, 0.0); KINCAL_MAX_JOINTS];
        for (l, &[lo, hi]) in lims.iter_mut().zip(limits.as_chunks::<2>().0) {
            *l = JointLimits::new(lo, hi);
        }
        // SAFETY: forwarded contract.
        unsafe {
            edit(robot, |any| {
                with_any_robot!(any, r => {
                    let l = lims.get(..r.limits().len()).and_then(|s| s.try_into().ok()).ok_or_else(internal)?;
                    r.set_limits(l).map_err(|e| kincal_error::from(e).arg(c"limits"))?
                });
                Ok(())
            })
        }
    })
}

/// Sets the point-mass model: `link_masses_kg` (N values [kg], at the midpoint between the
/// origins of frames k−1 and k), `tool_mass_kg` [kg] at the end-effector origin, `gravity`
/// (3 values [m/s²] in the base frame, e.g. {0, 0, -9.81}). Masses must be ≥ 0. On failure
/// `*robot` is unchanged. Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE,
/// INVALID_PARAMETER (a negative mass; `index` = link, N = tool) or any status of
/// `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable and writable `kincal_robot`; arrays NULL or
/// readable for their lengths; `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_set_mass(
    robot: *mut kincal_robot,
    link_masses_kg: *const f64,
    link_masses_kg_len: usize,
    tool_mass_kg: f64,
    gravity: *const f64,
    gravity_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let n = unsafe { n_joints_of(robot) }?;
        let masses = arg_f64s!(link_masses_kg, link_masses_kg_len, n);
        crate::args::finite(&[tool_mass_kg], c"tool_mass_kg")?;
        let g = <[f64; 3]>::try_from(arg_f64s!(gravity, gravity_len, 3)).map_err(|_| internal())?;
        let mut m = [0.0; KINCAL_MAX_JOINTS];
        for (d, s) in m.iter_mut().zip(masses) {
            *d = *s;
        }
        // SAFETY: forwarded contract.
        unsafe {
            edit(robot, |any| {
                with_any_robot!(any, r => {
                    let link_masses_kg = m.get(..r.limits().len()).and_then(|s| s.try_into().ok()).ok_or_else(internal)?;
                    let mass = MassModel { link_masses_kg, tool_mass_kg, gravity: g };
                    *r = r.with_mass(mass).map_err(|e| kincal_error::from(e).arg(c"link_masses_kg"))?;
                });
                Ok(())
            })
        }
    })
}

/// Sets which of d/β link `link` (zero-based, < N) identifies: `choice` is
/// `KINCAL_LENGTH_PARAM_D` or `KINCAL_LENGTH_PARAM_BETA`. On failure `*robot` is unchanged.
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, INDEX_OUT_OF_RANGE (`link`), INVALID_ARGUMENT
/// (`choice`) or any status of `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable and writable `kincal_robot`; `err` NULL or
/// writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_set_length_param(
    robot: *mut kincal_robot,
    link: usize,
    choice: u32,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let n = unsafe { n_joints_of(robot) }?;
        if link >= n {
            return Err(kincal_error::new(kincal_status::IndexOutOfRange).arg(c"link").at(link).counts(n, link));
        }
        let lp = match choice {
            0 => LengthParam::D,
            1 => LengthParam::Beta,
            v => return Err(kincal_error::new(kincal_status::InvalidArgument).arg(c"choice").value(f64::from(v))),
        };
        // SAFETY: forwarded contract.
        unsafe {
            edit(robot, |any| {
                with_any_robot!(any, r => r.set_length_param(link, lp)?);
                Ok(())
            })
        }
    })
}

/// Sets what joint `joint` (zero-based, < N) moves: `kind` is `KINCAL_JOINT_KIND_REVOLUTE`,
/// `KINCAL_JOINT_KIND_PRISMATIC` (reading and limits then in metres) or
/// `KINCAL_JOINT_KIND_SENSOR` (a passive revolute joint read by a tilt sensor). The same
/// check as the core's: a prismatic or sensor joint's cyclic (and a sensor's backlash)
/// effect parameters must be zero. On failure
/// `*robot` is unchanged. Returns OK, NULL_POINTER, MISALIGNED_POINTER, INDEX_OUT_OF_RANGE
/// (`joint`), INVALID_ARGUMENT (`kind`, or nonzero cyclic parameters) or any status of
/// `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable and writable `kincal_robot`; `err` NULL or
/// writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_set_joint_kind(
    robot: *mut kincal_robot,
    joint: usize,
    kind: u32,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        let n = unsafe { n_joints_of(robot) }?;
        if joint >= n {
            return Err(kincal_error::new(kincal_status::IndexOutOfRange).arg(c"joint").at(joint).counts(n, joint));
        }
        let k = match kind {
            0 => JointKind::Revolute,
            1 => JointKind::Prismatic,
            2 => JointKind::Sensor,
            v => return Err(kincal_error::new(kincal_status::InvalidArgument).arg(c"kind").value(f64::from(v))),
        };
        // SAFETY: forwarded contract.
        unsafe {
            edit(robot, |any| {
                any.set_joint_kind(joint, k)?;
                Ok(())
            })
        }
    })
}

/// Makes the current geometry (links, base, tool of `params`) the nominal one, e.g. to use a
/// calibrated model as the description of a new calibration. On failure `*robot` is unchanged;
/// statuses as `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable and writable `kincal_robot`; `err` NULL or
/// writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_robot_adopt_geometry_as_nominal(
    robot: *mut kincal_robot,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        // SAFETY: forwarded contract.
        unsafe {
            edit(robot, |any| {
                with_any_robot!(any, r => r.adopt_geometry_as_nominal());
                Ok(())
            })
        }
    })
}

/// The joint count of `*robot` (1..=`KINCAL_MAX_JOINTS`), checking the pointer first.
///
/// # Safety
/// `robot` is NULL or points to a readable `kincal_robot`.
pub(crate) unsafe fn n_joints_of(robot: *const kincal_robot) -> FfiResult<usize> {
    // SAFETY: forwarded contract.
    let r = unsafe { crate::args::req(robot, c"robot") }?;
    let n = r.n_joints as usize;
    if (1..=KINCAL_MAX_JOINTS).contains(&n) {
        Ok(n)
    } else {
        Err(bad_joint_count(n))
    }
}
