//! Observability indices (Section 3.3, eq. 17, O1–O5, A- and D-optimality) of a set of
//! configurations, the per-pose singular values, and pose selection (eq. 18): the m
//! configurations of a caller's candidate pool that maximise an index.
//!
//! Memory: as identification, one caller buffer aligned to `KINCAL_WORKSPACE_ALIGN` holds the
//! core's working memory (`kincal_observability_workspace_size`,
//! `kincal_select_workspace_size`); its contents are scratch and nothing is allocated here.
//! The capacity (parameters at once) is 32 or `KINCAL_MAX_PARAMS`, the smallest that holds the
//! parameter set.

use core::ffi::c_void;

use kincal::identify::Workspace;
use kincal::observability::{
    ColumnScaling, Index, Indices, ObservabilityOptions, PoseBlock, observability,
    pose_singular_values,
};
use kincal::params::num_params;
use kincal::selection::{
    Constraints, MAX_DESIGN, Objective, Pool, Region, SelectOptions, SelectScratch, Selection,
    fill_pool, select_poses,
};
use kincal::{ParamSet, Robot, with_any_robot};

use crate::identify::{CAPACITIES, KINCAL_WORKSPACE_ALIGN, capacity_for, round_up};
use crate::robot::{KINCAL_MAX_PARAMS, kincal_robot, to_any};
use crate::status::{FfiResult, kincal_error, kincal_status};

/// Largest design `kincal_select_poses` selects (`m`; the core's exchange needs 3 more slots).
pub const KINCAL_MAX_SELECT: usize = 61;
const _: () = assert!(KINCAL_MAX_SELECT + 3 == MAX_DESIGN);

/// How the Jacobian columns are scaled before the singular values are taken.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_scaling_kind {
    /// Raw columns (metres per metre, metres per radian): the indices depend on units.
    None = 0,
    /// Every column divided by its norm over the pose set (the default; the convention of
    /// the identifiability condition number).
    UnitColumns = 1,
    /// Columns times the expected error of their parameter: `length_m` for lengths,
    /// `angle_rad` for angles (effect parameters unscaled).
    Tolerance = 2,
}

/// Column scaling of the observability exports. Plain data.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_scaling {
    /// A `kincal_scaling_kind`.
    pub kind: u32,
    /// Tolerance of lengths [m] (finite, > 0; used by `KINCAL_SCALING_KIND_TOLERANCE` only).
    pub length_m: f64,
    /// Tolerance of angles [rad] (finite, > 0; used by `KINCAL_SCALING_KIND_TOLERANCE` only).
    pub angle_rad: f64,
}

/// The observability indices; all are "larger is better".
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_obs_index {
    /// Eq. (17): σ_min/σ_max.
    O = 0,
    /// Borm–Menq: (σ_1···σ_p)^(1/p)/√m.
    O1 = 1,
    /// Inverse condition number (equal to O).
    O2 = 2,
    /// σ_min.
    O3 = 3,
    /// Noise amplification σ_min²/σ_max.
    O4 = 4,
    /// 1/σ_max.
    O5 = 5,
    /// A-optimality 1/Σ σ⁻¹.
    AOpt = 6,
    /// D-optimality ln det(JᵀJ).
    DOpt = 7,
}

/// The observability indices of a pose set (singular values σ of the stacked, scaled
/// identification Jacobian: rows `[Δp (m); Δφ (rad)]` per pose, one column per parameter).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_observability_indices {
    /// Eq. (17), σ_min/σ_max.
    pub o: f64,
    /// Borm–Menq, (σ_1···σ_p)^(1/p)/√m.
    pub o1: f64,
    /// Inverse condition number.
    pub o2: f64,
    /// σ_min.
    pub o3: f64,
    /// σ_min²/σ_max.
    pub o4: f64,
    /// 1/σ_max.
    pub o5: f64,
    /// A-optimality, 1/Σ σ⁻¹.
    pub a_optimality: f64,
    /// D-optimality, ln det(JᵀJ) (−infinity when singular).
    pub d_optimality: f64,
    /// Smallest singular value.
    pub sigma_min: f64,
    /// Largest singular value.
    pub sigma_max: f64,
    /// Number of poses m.
    pub poses: usize,
    /// Number of parameters p (columns).
    pub params: usize,
}

/// An axis-aligned box in the base frame [m].
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_region {
    /// Lower corner `[x, y, z]` [m].
    pub min_m: [f64; 3],
    /// Upper corner `[x, y, z]` [m] (each ≥ the lower one).
    pub max_m: [f64; 3],
}

/// The outcome of `kincal_select_poses`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_selection {
    /// Objective (the chosen index, from the Gram matrix) of the selected set.
    pub value: f64,
    /// Objective after the greedy initial set.
    pub initial_value: f64,
    /// Objective after the exchange, before the joint-space refinement.
    pub exchange_value: f64,
    /// Objective evaluations.
    pub evaluations: u64,
    /// Accepted exchanges.
    pub exchanges: usize,
    /// Accepted refinement moves.
    pub refinements: usize,
    /// The start that gave the result.
    pub start: usize,
    /// The indices of the selected set (SVD route, as `kincal_observability`).
    pub indices: kincal_observability_indices,
}

pub(crate) fn indices_of(i: &Indices) -> kincal_observability_indices {
    kincal_observability_indices {
        o: i.o,
        o1: i.o1,
        o2: i.o2,
        o3: i.o3,
        o4: i.o4,
        o5: i.o5,
        a_optimality: i.a_opt,
        d_optimality: i.log_det,
        sigma_min: i.sigma_min,
        sigma_max: i.sigma_max,
        poses: i.poses,
        params: i.params,
    }
}

fn index_of(v: u32) -> FfiResult<Index> {
    Ok(match v {
        0 => Index::O,
        1 => Index::O1,
        2 => Index::O2,
        3 => Index::O3,
        4 => Index::O4,
        5 => Index::O5,
        6 => Index::AOpt,
        7 => Index::DOpt,
        _ => {
            return Err(kincal_error::new(kincal_status::InvalidArgument)
                .arg(c"objective")
                .value(f64::from(v)));
        }
    })
}

fn scaling_of(s: Option<&kincal_scaling>) -> FfiResult<ColumnScaling> {
    let Some(s) = s else {
        return Ok(ColumnScaling::UnitColumns);
    };
    match s.kind {
        0 => Ok(ColumnScaling::None),
        1 => Ok(ColumnScaling::UnitColumns),
        2 => {
            for (v, name) in [
                (s.length_m, c"scaling->length_m"),
                (s.angle_rad, c"scaling->angle_rad"),
            ] {
                crate::args::finite(&[v], name)?;
                if v <= 0.0 {
                    return Err(kincal_error::new(kincal_status::InvalidArgument)
                        .arg(name)
                        .value(v));
                }
            }
            Ok(ColumnScaling::Tolerance {
                length_m: s.length_m,
                angle_rad: s.angle_rad,
            })
        }
        k => Err(kincal_error::new(kincal_status::InvalidArgument)
            .arg(c"scaling->kind")
            .value(f64::from(k))),
    }
}

/// The parameter set of a mask (`None` = the robot's geometric set).
fn param_set<const N: usize>(r: &Robot<N>, mask: Option<&[u8]>) -> FfiResult<ParamSet> {
    let Some(mask) = mask else {
        return Ok(r.geometric_param_set());
    };
    let mut set = ParamSet::new();
    for (i, &m) in mask.iter().enumerate() {
        if m != 0 {
            set.insert(i)?;
        }
    }
    if set.is_empty() {
        return Err(kincal_error::new(kincal_status::TooFewData)
            .arg(c"params")
            .counts(1, 0));
    }
    Ok(set)
}

/// The caller's parameter mask (NULL allowed), checked against the robot's parameter count.
///
/// # Safety
/// `params` is NULL or readable for `params_len` bytes.
unsafe fn mask_view<'a>(
    params: *const u8,
    params_len: usize,
    n: usize,
) -> FfiResult<Option<&'a [u8]>> {
    if params.is_null() {
        return Ok(None);
    }
    // SAFETY: forwarded contract.
    Ok(Some(unsafe {
        crate::args::slice(params, params_len, num_params(n), c"params")
    }?))
}

/// Rows of `n`-element configurations from a flat, checked `f64` slice.
fn rows<const N: usize>(flat: &[f64]) -> &[[f64; N]] {
    let (rows, _) = flat.as_chunks::<N>();
    rows
}

fn capacity(n_params: usize) -> FfiResult<usize> {
    capacity_for(n_params).ok_or(
        kincal_error::new(kincal_status::CapacityExceeded)
            .arg(c"params")
            .counts(KINCAL_MAX_PARAMS, n_params),
    )
}

const fn ws_bytes<const P: usize>() -> usize {
    round_up(core::mem::size_of::<Workspace<P>>(), KINCAL_WORKSPACE_ALIGN)
}

/// Bytes of the selection workspace of capacity `P` for a pool of `k` configurations:
/// `Workspace<P>`, `SelectScratch<P>`, `k` blocks, `k` positions.
const fn select_bytes<const P: usize>(k: usize) -> Option<usize> {
    let fixed = ws_bytes::<P>()
        + round_up(
            core::mem::size_of::<SelectScratch<P>>(),
            KINCAL_WORKSPACE_ALIGN,
        );
    let per = core::mem::size_of::<PoseBlock<P>>() + core::mem::size_of::<[f64; 3]>();
    match k.checked_mul(per) {
        // Positions start on an aligned offset after the blocks.
        Some(v) => fixed.checked_add(v + KINCAL_WORKSPACE_ALIGN),
        None => None,
    }
}

const _: () =
    assert!(core::mem::align_of::<SelectScratch<KINCAL_MAX_PARAMS>>() <= KINCAL_WORKSPACE_ALIGN);
const _: () =
    assert!(core::mem::align_of::<PoseBlock<KINCAL_MAX_PARAMS>>() <= KINCAL_WORKSPACE_ALIGN);
const _: () = assert!(CAPACITIES.len() == 2);

/// Bytes of caller memory `kincal_observability` and `kincal_pose_singular_values` need for
/// `n_params` parameters (the mask's count, or `kincal_num_geometric_params`-sized default
/// set's count; the size is that of the smallest capacity, 32 or `KINCAL_MAX_PARAMS`, that
/// holds them). Returns 0 for 0 or more than `KINCAL_MAX_PARAMS` parameters.
#[unsafe(no_mangle)]
pub extern "C" fn kincal_observability_workspace_size(n_params: usize) -> usize {
    ffi_boundary!(on_panic = 0; {
        match (n_params, capacity_for(n_params)) {
            (0, _) => 0,
            (_, Some(32)) => ws_bytes::<32>(),
            (_, Some(KINCAL_MAX_PARAMS)) => ws_bytes::<KINCAL_MAX_PARAMS>(),
            _ => 0,
        }
    })
}

/// Bytes of caller memory `kincal_select_poses` needs for `n_params` parameters and a pool
/// of `pool_len` configurations (the core workspace and selection scratch, then one Jacobian
/// block and position per candidate: about 1.5 KB per candidate at capacity 32). Returns 0
/// for 0 or more than `KINCAL_MAX_PARAMS` parameters or an overflowing size.
#[unsafe(no_mangle)]
pub extern "C" fn kincal_select_workspace_size(n_params: usize, pool_len: usize) -> usize {
    ffi_boundary!(on_panic = 0; {
        match (n_params, capacity_for(n_params)) {
            (0, _) => 0,
            (_, Some(32)) => select_bytes::<32>(pool_len).unwrap_or(0),
            (_, Some(KINCAL_MAX_PARAMS)) => select_bytes::<KINCAL_MAX_PARAMS>(pool_len).unwrap_or(0),
            _ => 0,
        }
    })
}

/// Checks the workspace pointer, alignment and size.
fn check_ws(ws: *mut c_void, ws_len: usize, needed: usize) -> FfiResult<*mut u8> {
    if ws.is_null() {
        return Err(crate::args::null(c"workspace"));
    }
    if !(ws as usize).is_multiple_of(KINCAL_WORKSPACE_ALIGN) {
        return Err(kincal_error::new(kincal_status::MisalignedPointer).arg(c"workspace"));
    }
    if ws_len < needed {
        return Err(crate::args::bad_length(c"workspace", needed, ws_len));
    }
    Ok(ws.cast::<u8>())
}

/// Zeroes `size_of::<T>()` bytes at `base + offset` and references them as a `T`.
///
/// # Safety
/// `base + offset` is aligned for `T` and writable for `size_of::<T>()` bytes that no live
/// reference covers; all-zero bytes are a valid `T` (true of `Workspace`, `SelectScratch`,
/// `f64` arrays: floats and a `bool`).
unsafe fn zeroed_at<'w, T>(base: *mut u8, offset: usize) -> &'w mut T {
    // SAFETY: forwarded contract.
    unsafe {
        let p = base.add(offset);
        core::ptr::write_bytes(p, 0, core::mem::size_of::<T>());
        &mut *p.cast::<T>()
    }
}

/// # Safety
/// `ws` NULL or writable for `ws_len` bytes, no live reference into it.
unsafe fn workspace<'w, const P: usize>(
    ws: *mut c_void,
    ws_len: usize,
) -> FfiResult<&'w mut Workspace<P>> {
    let base = check_ws(ws, ws_len, ws_bytes::<P>())?;
    // SAFETY: aligned to KINCAL_WORKSPACE_ALIGN >= align of Workspace<P> (asserted in
    // identify), size checked; all-zero is a valid Workspace (core documentation).
    Ok(unsafe { zeroed_at::<Workspace<P>>(base, 0) })
}

enum Obs<'a> {
    Set(&'a [f64]),
    One(&'a [f64]),
}

// Returned once per call by value (nothing stores it), so the size difference is harmless.
#[allow(clippy::large_enum_variant)]
enum ObsOut {
    Set(Indices, [f64; KINCAL_MAX_PARAMS]),
    One([f64; 6]),
}

/// # Safety
/// As [`workspace`].
unsafe fn obs_p<const N: usize, const P: usize>(
    r: &Robot<N>,
    what: &Obs<'_>,
    opts: &ObservabilityOptions,
    ws: *mut c_void,
    ws_len: usize,
) -> FfiResult<ObsOut> {
    // SAFETY: forwarded contract.
    let w = unsafe { workspace::<P>(ws, ws_len) }?;
    match what {
        Obs::Set(q) => {
            let i = observability(r, rows::<N>(q), opts, w)?;
            let mut sv = [0.0; KINCAL_MAX_PARAMS];
            for (d, s) in sv.iter_mut().zip(w.singular_values()) {
                *d = *s;
            }
            Ok(ObsOut::Set(i, sv))
        }
        Obs::One(q) => {
            let q: [f64; N] = rows::<N>(q)
                .first()
                .copied()
                .ok_or(kincal_error::new(kincal_status::Internal))?;
            Ok(ObsOut::One(pose_singular_values(r, &q, opts, w)?))
        }
    }
}

/// # Safety
/// As [`workspace`]; `params` NULL or readable for `params_len` bytes.
#[allow(clippy::too_many_arguments)]
unsafe fn obs_run<const N: usize>(
    r: &Robot<N>,
    what: &Obs<'_>,
    params: *const u8,
    params_len: usize,
    scaling: Option<&kincal_scaling>,
    ws: *mut c_void,
    ws_len: usize,
) -> FfiResult<ObsOut> {
    // SAFETY: forwarded contract.
    let mask = unsafe { mask_view(params, params_len, N) }?;
    let mut opts = ObservabilityOptions::new(param_set(r, mask)?);
    opts.scaling = scaling_of(scaling)?;
    // SAFETY (both): forwarded contract.
    match capacity(opts.params.len())? {
        32 => unsafe { obs_p::<N, 32>(r, what, &opts, ws, ws_len) },
        _ => unsafe { obs_p::<N, KINCAL_MAX_PARAMS>(r, what, &opts, ws, ws_len) },
    }
}

/// Observability indices of `n_poses` configurations of `robot` (normally the nominal
/// model): the singular values σ_1 ≥ … ≥ σ_p of the stacked identification Jacobian
/// (6 rows `[Δp (m); Δφ (rad)]` per pose, one column per parameter, scaled as `scaling`
/// says) and the indices O (eq. 17), O1–O5, A- and D-optimality.
///
/// - `qs`, `qs_len`: joint values [rad], `n_poses` × N row-major (pose l at `qs[l*N]`);
///   `qs_len` = `n_poses`·N, `n_poses` ≥ 1.
/// - `params`, `params_len`: parameter mask by flat index (`params_len` =
///   `kincal_num_params(N)`, non-zero = a column), or NULL for the robot's geometric set
///   (θ0, a, α and d-or-β of every link; `params_len` ignored).
/// - `scaling`: column scaling, or NULL for unit columns.
/// - `workspace`, `workspace_len`: caller memory of at least
///   `kincal_observability_workspace_size(p)` bytes aligned to `KINCAL_WORKSPACE_ALIGN`;
///   scratch.
/// - `indices_out`: the indices. `sv_out`, `sv_len`: the p singular values (descending), or
///   NULL if not wanted; `sv_len` = p.
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH (`workspace`: `expected` = bytes
/// needed), NON_FINITE, INVALID_ARGUMENT (`scaling`), TOO_FEW_DATA (no pose, empty mask),
/// CAPACITY_EXCEEDED, NOT_CONVERGED (SVD), any status of `kincal_robot_validate`. Outputs are
/// written on success only.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths (`workspace` writable for
/// `workspace_len` bytes and not overlapping the other arguments); `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_observability(
    robot: *const kincal_robot,
    qs: *const f64,
    n_poses: usize,
    qs_len: usize,
    params: *const u8,
    params_len: usize,
    scaling: *const kincal_scaling,
    workspace: *mut c_void,
    workspace_len: usize,
    indices_out: *mut kincal_observability_indices,
    sv_out: *mut f64,
    sv_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let r = arg_ref!(robot);
        let s = arg_opt!(scaling);
        let out = arg_out1!(indices_out);
        let any = to_any(r)?;
        let n = any.n_joints();
        if n_poses == 0 {
            return Err(kincal_error::new(kincal_status::TooFewData)
                .arg(c"n_poses")
                .counts(1, 0));
        }
        let expected = n_poses
            .checked_mul(n)
            .ok_or_else(|| crate::args::bad_length(c"qs", usize::MAX, qs_len))?;
        let q = arg_f64s!(qs, qs_len, expected);
        let what = Obs::Set(q);
        // SAFETY: forwarded contract.
        let res = with_any_robot!(&any, r => unsafe {
            obs_run(r, &what, params, params_len, s, workspace, workspace_len)
        })?;
        if let ObsOut::Set(i, sv) = res {
            let sv_o = arg_out_opt!(sv_out, sv_len, i.params);
            // SAFETY: checked by `arg_out1!`/`arg_out_opt!`; writable by contract.
            unsafe {
                out.put(indices_of(&i));
                if let Some(o) = sv_o {
                    o.write(sv.get(..i.params).unwrap_or(&[]));
                }
            }
        }
        Ok(())
    })
}

/// The per-pose index: the six singular values (descending) of configuration `q`'s 6 × p
/// block of the identification Jacobian, columns scaled as `scaling` says (unit columns use
/// this pose's own column norms); what the workspace-clustering design compares.
///
/// - `q`, `q_len`: joint values [rad], `q_len` = N.
/// - `params`, `params_len`, `scaling`, `workspace`, `workspace_len`: as
///   `kincal_observability`.
/// - `sv_out`, `sv_len`: the six singular values; `sv_len` = 6.
///
/// Returns the statuses of `kincal_observability`.
///
/// # Safety
/// As `kincal_observability`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_pose_singular_values(
    robot: *const kincal_robot,
    q: *const f64,
    q_len: usize,
    params: *const u8,
    params_len: usize,
    scaling: *const kincal_scaling,
    workspace: *mut c_void,
    workspace_len: usize,
    sv_out: *mut f64,
    sv_len: usize,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let r = arg_ref!(robot);
        let s = arg_opt!(scaling);
        let out = arg_out!(sv_out, sv_len, 6);
        let any = to_any(r)?;
        let qv = arg_f64s!(q, q_len, any.n_joints());
        let what = Obs::One(qv);
        // SAFETY: forwarded contract.
        let res = with_any_robot!(&any, r => unsafe {
            obs_run(r, &what, params, params_len, s, workspace, workspace_len)
        })?;
        if let ObsOut::One(sv) = res {
            // SAFETY: checked by `arg_out!`; writable by contract.
            unsafe { out.write(&sv) };
        }
        Ok(())
    })
}

struct SelectIn<'a> {
    pool: &'a [f64],
    m: usize,
    objective: Index,
    seed: u64,
    region: Option<Region>,
    margin: f64,
}

/// # Safety
/// As [`workspace`].
unsafe fn select_p<const N: usize, const P: usize>(
    r: &Robot<N>,
    a: &SelectIn<'_>,
    obs: &ObservabilityOptions,
    ws: *mut c_void,
    ws_len: usize,
    out: &mut [[f64; N]; MAX_DESIGN],
) -> FfiResult<(Selection, Indices)> {
    let pool_q = rows::<N>(a.pool);
    let k = pool_q.len();
    let needed = select_bytes::<P>(k).ok_or(kincal_error::new(kincal_status::CapacityExceeded))?;
    let base = check_ws(ws, ws_len, needed)?;
    let off_s = ws_bytes::<P>();
    let off_b = off_s
        + round_up(
            core::mem::size_of::<SelectScratch<P>>(),
            KINCAL_WORKSPACE_ALIGN,
        );
    let off_p = round_up(
        off_b + k * core::mem::size_of::<PoseBlock<P>>(),
        KINCAL_WORKSPACE_ALIGN,
    );
    // SAFETY: the four regions are disjoint, aligned to KINCAL_WORKSPACE_ALIGN (>= their
    // alignments, asserted) and end at or before `needed` <= `ws_len`; all-zero bytes are
    // valid values of each type (floats, a `bool` false).
    let (w, s, blocks, pos) = unsafe {
        let w = zeroed_at::<Workspace<P>>(base, 0);
        let s = zeroed_at::<SelectScratch<P>>(base, off_s);
        let bp = base.add(off_b);
        core::ptr::write_bytes(bp, 0, k * core::mem::size_of::<PoseBlock<P>>());
        let blocks = core::slice::from_raw_parts_mut(bp.cast::<PoseBlock<P>>(), k);
        let pp = base.add(off_p);
        core::ptr::write_bytes(pp, 0, k * core::mem::size_of::<[f64; 3]>());
        let pos = core::slice::from_raw_parts_mut(pp.cast::<[f64; 3]>(), k);
        (w, s, blocks, pos)
    };
    fill_pool(r, pool_q, obs, w, blocks, pos)?;
    let pool = Pool {
        q: pool_q,
        blocks,
        pos,
    };
    let c = Constraints {
        region: a.region,
        joint_margin_rad: a.margin,
        ..Constraints::none()
    };
    let opts = SelectOptions::new(Objective::Index(a.objective), a.seed);
    let sel = select_poses(r, &pool, a.m, obs, &c, &opts, w, s, out)?;
    let chosen = out
        .get(..a.m)
        .ok_or(kincal_error::new(kincal_status::Internal))?;
    let ind = observability(r, chosen, obs, w)?;
    Ok((sel, ind))
}

/// # Safety
/// As [`obs_run`].
#[allow(clippy::too_many_arguments)]
unsafe fn select_run<const N: usize>(
    r: &Robot<N>,
    a: &SelectIn<'_>,
    params: *const u8,
    params_len: usize,
    scaling: Option<&kincal_scaling>,
    ws: *mut c_void,
    ws_len: usize,
    q_out: &mut [f64],
) -> FfiResult<(Selection, Indices)> {
    // SAFETY: forwarded contract.
    let mask = unsafe { mask_view(params, params_len, N) }?;
    let mut obs = ObservabilityOptions::new(param_set(r, mask)?);
    obs.scaling = scaling_of(scaling)?;
    let mut out = [[0.0; N]; MAX_DESIGN];
    // SAFETY (both): forwarded contract.
    let res = match capacity(obs.params.len())? {
        32 => unsafe { select_p::<N, 32>(r, a, &obs, ws, ws_len, &mut out) },
        _ => unsafe { select_p::<N, KINCAL_MAX_PARAMS>(r, a, &obs, ws, ws_len, &mut out) },
    }?;
    for (d, s) in q_out.iter_mut().zip(out.as_flattened()) {
        *d = *s;
    }
    Ok(res)
}

/// Pose selection (eq. 18): the `m` configurations that maximise the index `objective`, from
/// the caller's candidate pool (greedy start, DETMAX exchange, then joint-space refinement
/// within the joint limits minus `joint_margin_rad` and inside `region`; refined poses need
/// not be pool members). Deterministic for a given `seed` (the core's default of 4 starts).
///
/// - `pool_q`, `pool_q_len`: candidate joint values [rad], `pool_len` × N row-major;
///   `pool_q_len` = `pool_len`·N; `m` ≤ `pool_len`.
/// - `m`: poses to select, 1 ≤ `m` ≤ `KINCAL_MAX_SELECT`.
/// - `params`, `params_len`, `scaling`: as `kincal_observability`.
/// - `objective`: a `kincal_obs_index`. `seed`: random seed.
/// - `region`: the end effector's box [m], or NULL for none. `joint_margin_rad`: distance
///   kept from every joint limit [rad] (finite, ≥ 0).
/// - `workspace`, `workspace_len`: caller memory of at least
///   `kincal_select_workspace_size(p, pool_len)` bytes aligned to `KINCAL_WORKSPACE_ALIGN`;
///   scratch.
/// - `q_out`, `q_out_len`: the selected configurations, `m` × N row-major; `q_out_len` = m·N.
/// - `selection_out`: objective values, counts and the indices of the selected set (NULL if
///   not wanted).
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE, INVALID_ARGUMENT
/// (`objective`, `scaling`, `region`, `joint_margin_rad`), TOO_FEW_DATA (`m` = 0 or above the
/// pool), CAPACITY_EXCEEDED (`m` > `KINCAL_MAX_SELECT`), NOT_CONVERGED, any status of
/// `kincal_robot_validate`. Outputs are written on success only.
///
/// # Safety
/// As `kincal_observability`; `q_out` writable for `q_out_len` doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_select_poses(
    robot: *const kincal_robot,
    pool_q: *const f64,
    pool_len: usize,
    pool_q_len: usize,
    m: usize,
    params: *const u8,
    params_len: usize,
    scaling: *const kincal_scaling,
    objective: u32,
    seed: u64,
    region: *const kincal_region,
    joint_margin_rad: f64,
    workspace: *mut c_void,
    workspace_len: usize,
    q_out: *mut f64,
    q_out_len: usize,
    selection_out: *mut kincal_selection,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let r = arg_ref!(robot);
        let s = arg_opt!(scaling);
        let reg = arg_opt!(region);
        let any = to_any(r)?;
        let n = any.n_joints();
        let expected = pool_len
            .checked_mul(n)
            .ok_or_else(|| crate::args::bad_length(c"pool_q", usize::MAX, pool_q_len))?;
        let pool = arg_f64s!(pool_q, pool_q_len, expected);
        if m == 0 || m > pool_len {
            return Err(kincal_error::new(kincal_status::TooFewData)
                .arg(c"m")
                .counts(m.max(1), pool_len));
        }
        if m > KINCAL_MAX_SELECT {
            return Err(kincal_error::new(kincal_status::CapacityExceeded)
                .arg(c"m")
                .counts(KINCAL_MAX_SELECT, m));
        }
        let out = arg_out!(q_out, q_out_len, m * n);
        let sel_out = arg_out_opt!(selection_out, 1, 1);
        let objective = index_of(objective)?;
        crate::args::finite(&[joint_margin_rad], c"joint_margin_rad")?;
        if joint_margin_rad < 0.0 {
            return Err(kincal_error::new(kincal_status::InvalidArgument)
                .arg(c"joint_margin_rad")
                .value(joint_margin_rad));
        }
        let region = match reg {
            None => None,
            Some(g) => {
                crate::args::finite(&g.min_m, c"region->min_m")?;
                crate::args::finite(&g.max_m, c"region->max_m")?;
                Some(Region::new(g.min_m, g.max_m).map_err(|_| {
                    kincal_error::new(kincal_status::InvalidArgument).arg(c"region")
                })?)
            }
        };
        let a = SelectIn { pool, m, objective, seed, region, margin: joint_margin_rad };
        let mut q_sel = [0.0; MAX_DESIGN * crate::robot::KINCAL_MAX_JOINTS];
        let q_sel = q_sel.get_mut(..m * n).ok_or(kincal_error::new(kincal_status::Internal))?;
        // SAFETY: forwarded contract.
        let (sel, ind) = with_any_robot!(&any, r => unsafe {
            select_run(r, &a, params, params_len, s, workspace, workspace_len, q_sel)
        })?;
        // SAFETY: checked by `arg_out!`/`arg_out_opt!`; writable by contract; `q_sel` is a
        // Rust value.
        unsafe {
            out.write(q_sel);
            if let Some(o) = sel_out {
                o.put(kincal_selection {
                    value: sel.value,
                    initial_value: sel.initial_value,
                    exchange_value: sel.exchange_value,
                    evaluations: sel.evaluations,
                    exchanges: sel.exchanges,
                    refinements: sel.refinements,
                    start: sel.start,
                    indices: indices_of(&ind),
                });
            }
        }
        Ok(())
    })
}

/// The outcome of `kincal_cluster_select`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_cluster_selection {
    /// Spread of the per-pose indices of the chosen poses: `max_k |ln σ_k(q) − ln σ_k(q*)|`
    /// over the chosen `q` and the target `q*` (0.1 ≈ 10 %).
    pub spread: f64,
    /// Objective (the chosen index) of the chosen set.
    pub value: f64,
    /// Zero-based pool index of the target pose whose per-pose index the others match.
    pub target: usize,
    /// Non-zero when the spread is within the tolerance (else the smallest spread found).
    pub within_tolerance: u32,
    /// Cubes of the region that hold at least one pool member.
    pub occupied_cubes: usize,
}

/// Cubes of side `cube_m` in `region`, `None` when the count overflows.
fn cube_count(region: &Region, cube_m: f64) -> Option<usize> {
    let [a, b, c] = region.cube_counts(cube_m);
    a.checked_mul(b)?.checked_mul(c)
}

/// Bytes of the clustering workspace: the selection workspace, then `k` per-pose indices
/// and `cubes` cube slots.
fn cluster_bytes<const P: usize>(k: usize, cubes: usize) -> Option<usize> {
    let per = k.checked_mul(core::mem::size_of::<[f64; 6]>())?;
    let cube = cubes.checked_mul(core::mem::size_of::<(f64, usize)>())?;
    select_bytes::<P>(k)?
        .checked_add(KINCAL_WORKSPACE_ALIGN)?
        .checked_add(per)?
        .checked_add(KINCAL_WORKSPACE_ALIGN)?
        .checked_add(cube)
}

/// The region of a `kincal_region` and a cube side, checked.
fn cluster_geometry(g: &kincal_region, cube_m: f64) -> FfiResult<(Region, usize)> {
    crate::args::finite(&g.min_m, c"region->min_m")?;
    crate::args::finite(&g.max_m, c"region->max_m")?;
    let region = Region::new(g.min_m, g.max_m)
        .map_err(|_| kincal_error::new(kincal_status::InvalidArgument).arg(c"region"))?;
    crate::args::finite(&[cube_m], c"cube_m")?;
    if cube_m <= 0.0 {
        return Err(kincal_error::new(kincal_status::InvalidArgument)
            .arg(c"cube_m")
            .value(cube_m));
    }
    let cubes = cube_count(&region, cube_m).ok_or(
        kincal_error::new(kincal_status::CapacityExceeded)
            .arg(c"cube_m")
            .value(cube_m),
    )?;
    Ok((region, cubes))
}

/// Bytes of caller memory `kincal_cluster_select` needs for `n_params` parameters, a pool of
/// `pool_len` configurations and the cubes of side `cube_m` [m] of `region` (the selection
/// workspace of `kincal_select_workspace_size`, then six values per candidate and 16 bytes
/// per cube). Returns 0 for 0 or more than `KINCAL_MAX_PARAMS` parameters, a NULL or invalid
/// region, a cube side that is not finite and positive, or an overflowing size.
///
/// # Safety
/// `region` NULL or readable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_cluster_workspace_size(
    n_params: usize,
    pool_len: usize,
    region: *const kincal_region,
    cube_m: f64,
) -> usize {
    ffi_boundary!(on_panic = 0; {
        // SAFETY: forwarded contract.
        let Ok(Some(g)) = (unsafe { crate::args::opt(region, c"region") }) else {
            return 0;
        };
        let Ok((_, cubes)) = cluster_geometry(g, cube_m) else {
            return 0;
        };
        match (n_params, capacity_for(n_params)) {
            (0, _) => 0,
            (_, Some(32)) => cluster_bytes::<32>(pool_len, cubes).unwrap_or(0),
            (_, Some(KINCAL_MAX_PARAMS)) => {
                cluster_bytes::<KINCAL_MAX_PARAMS>(pool_len, cubes).unwrap_or(0)
            }
            _ => 0,
        }
    })
}

struct ClusterIn<'a> {
    pool: &'a [f64],
    m: usize,
    objective: Index,
    region: Region,
    cubes: usize,
    cube_m: f64,
    tolerance: f64,
}

/// # Safety
/// As [`workspace`].
unsafe fn cluster_p<const N: usize, const P: usize>(
    r: &Robot<N>,
    a: &ClusterIn<'_>,
    obs: &ObservabilityOptions,
    ws: *mut c_void,
    ws_len: usize,
    chosen: &mut [usize],
) -> FfiResult<kincal::selection::ClusterSelection> {
    let pool_q = rows::<N>(a.pool);
    let k = pool_q.len();
    let needed =
        cluster_bytes::<P>(k, a.cubes).ok_or(kincal_error::new(kincal_status::CapacityExceeded))?;
    let base = check_ws(ws, ws_len, needed)?;
    let off_s = ws_bytes::<P>();
    let off_b = off_s
        + round_up(
            core::mem::size_of::<SelectScratch<P>>(),
            KINCAL_WORKSPACE_ALIGN,
        );
    let off_p = round_up(
        off_b + k * core::mem::size_of::<PoseBlock<P>>(),
        KINCAL_WORKSPACE_ALIGN,
    );
    let off_v = round_up(
        off_p + k * core::mem::size_of::<[f64; 3]>(),
        KINCAL_WORKSPACE_ALIGN,
    );
    let off_c = round_up(
        off_v + k * core::mem::size_of::<[f64; 6]>(),
        KINCAL_WORKSPACE_ALIGN,
    );
    // SAFETY: the six regions are disjoint, aligned to KINCAL_WORKSPACE_ALIGN (>= their
    // alignments) and end at or before `needed` <= `ws_len` (`cluster_bytes` adds an
    // alignment's slack per region); all-zero bytes are valid values of each type.
    let (w, s, blocks, pos, per, cube_best) = unsafe {
        let w = zeroed_at::<Workspace<P>>(base, 0);
        let s = zeroed_at::<SelectScratch<P>>(base, off_s);
        let region = |off: usize, bytes: usize| {
            let p = base.add(off);
            core::ptr::write_bytes(p, 0, bytes);
            p
        };
        let bp = region(off_b, k * core::mem::size_of::<PoseBlock<P>>());
        let blocks = core::slice::from_raw_parts_mut(bp.cast::<PoseBlock<P>>(), k);
        let pp = region(off_p, k * core::mem::size_of::<[f64; 3]>());
        let pos = core::slice::from_raw_parts_mut(pp.cast::<[f64; 3]>(), k);
        let vp = region(off_v, k * core::mem::size_of::<[f64; 6]>());
        let per = core::slice::from_raw_parts_mut(vp.cast::<[f64; 6]>(), k);
        let cp = region(off_c, a.cubes * core::mem::size_of::<(f64, usize)>());
        let cubes = core::slice::from_raw_parts_mut(cp.cast::<(f64, usize)>(), a.cubes);
        (w, s, blocks, pos, per, cubes)
    };
    fill_pool(r, pool_q, obs, w, blocks, pos)?;
    for (d, q) in per.iter_mut().zip(pool_q) {
        *d = pose_singular_values(r, q, obs, w)?;
    }
    let pool = Pool {
        q: pool_q,
        blocks,
        pos,
    };
    let opts = kincal::selection::ClusterOptions {
        region: a.region,
        cube_m: a.cube_m,
        tolerance: a.tolerance,
        objective: Objective::Index(a.objective),
    };
    let unit = obs.scaling == ColumnScaling::UnitColumns;
    Ok(kincal::selection::cluster_select(
        &pool,
        per,
        a.m,
        obs.params.len(),
        unit,
        &opts,
        s,
        cube_best,
        chosen,
    )?)
}

/// # Safety
/// As [`obs_run`].
#[allow(clippy::too_many_arguments)]
unsafe fn cluster_run<const N: usize>(
    r: &Robot<N>,
    a: &ClusterIn<'_>,
    params: *const u8,
    params_len: usize,
    scaling: Option<&kincal_scaling>,
    ws: *mut c_void,
    ws_len: usize,
    chosen: &mut [usize],
) -> FfiResult<kincal::selection::ClusterSelection> {
    // SAFETY: forwarded contract.
    let mask = unsafe { mask_view(params, params_len, N) }?;
    let mut obs = ObservabilityOptions::new(param_set(r, mask)?);
    obs.scaling = scaling_of(scaling)?;
    // SAFETY (both): forwarded contract.
    match capacity(obs.params.len())? {
        32 => unsafe { cluster_p::<N, 32>(r, a, &obs, ws, ws_len, chosen) },
        _ => unsafe { cluster_p::<N, KINCAL_MAX_PARAMS>(r, a, &obs, ws, ws_len, chosen) },
    }
}

/// The workspace-clustering design of the paper (Section 4.2, what `kincal select-poses
/// --design clustering` and `design-tool` use): `m` members of the caller's pool whose
/// end-effector positions lie in mutually different cubes of side `cube_m` of `region`, and
/// whose per-pose indices (`kincal_pose_singular_values`) match a target pose's within
/// `tolerance` (`max_k |ln σ_k − ln σ_k*|`); among targets whose design is within the
/// tolerance the index `objective` decides, otherwise the smallest spread. Deterministic.
///
/// - `pool_q`, `pool_q_len`: candidate joint values [rad], `pool_len` × N row-major;
///   `pool_q_len` = `pool_len`·N. Members outside `region` are never chosen.
/// - `m`: poses to choose, 1 ≤ `m` ≤ `KINCAL_MAX_SELECT` and ≤ the occupied cubes.
/// - `params`, `params_len`, `scaling`: as `kincal_observability`.
/// - `objective`: a `kincal_obs_index`.
/// - `region`: the box split into cubes [m] (required). `cube_m`: cube side [m] (> 0).
///   `tolerance`: accepted spread (finite, ≥ 0; the CLI's default is 0.1).
/// - `workspace`, `workspace_len`: caller memory of at least `kincal_cluster_workspace_size(p,
///   pool_len, region, cube_m)` bytes aligned to `KINCAL_WORKSPACE_ALIGN`; scratch.
/// - `chosen_out`, `chosen_len`: the zero-based pool indices of the chosen poses; `chosen_len`
///   = m.
/// - `selection_out`: spread, objective, target, occupied cubes (NULL if not wanted).
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH, NON_FINITE, INVALID_ARGUMENT
/// (`objective`, `scaling`, `region`, `cube_m`, `tolerance`), TOO_FEW_DATA (`m` = 0, or more
/// than the occupied cubes), CAPACITY_EXCEEDED (`m` > `KINCAL_MAX_SELECT`, too many cubes),
/// NOT_CONVERGED, any status of `kincal_robot_validate`. Outputs are written on success only.
///
/// # Safety
/// As `kincal_select_poses`; `chosen_out` writable for `chosen_len` elements.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_cluster_select(
    robot: *const kincal_robot,
    pool_q: *const f64,
    pool_len: usize,
    pool_q_len: usize,
    m: usize,
    params: *const u8,
    params_len: usize,
    scaling: *const kincal_scaling,
    objective: u32,
    region: *const kincal_region,
    cube_m: f64,
    tolerance: f64,
    workspace: *mut c_void,
    workspace_len: usize,
    chosen_out: *mut usize,
    chosen_len: usize,
    selection_out: *mut kincal_cluster_selection,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let r = arg_ref!(robot);
        let s = arg_opt!(scaling);
        let g = arg_ref!(region);
        let any = to_any(r)?;
        let n = any.n_joints();
        let expected = pool_len
            .checked_mul(n)
            .ok_or_else(|| crate::args::bad_length(c"pool_q", usize::MAX, pool_q_len))?;
        let pool = arg_f64s!(pool_q, pool_q_len, expected);
        if m == 0 || m > pool_len {
            return Err(kincal_error::new(kincal_status::TooFewData)
                .arg(c"m")
                .counts(m.max(1), pool_len));
        }
        if m > KINCAL_MAX_SELECT {
            return Err(kincal_error::new(kincal_status::CapacityExceeded)
                .arg(c"m")
                .counts(KINCAL_MAX_SELECT, m));
        }
        let out = arg_out!(chosen_out, chosen_len, m);
        let sel_out = arg_out_opt!(selection_out, 1, 1);
        let objective = index_of(objective)?;
        let (region, cubes) = cluster_geometry(g, cube_m)?;
        crate::args::finite(&[tolerance], c"tolerance")?;
        if tolerance < 0.0 {
            return Err(kincal_error::new(kincal_status::InvalidArgument)
                .arg(c"tolerance")
                .value(tolerance));
        }
        let a = ClusterIn { pool, m, objective, region, cubes, cube_m, tolerance };
        let mut chosen = [0usize; KINCAL_MAX_SELECT];
        let chosen = chosen.get_mut(..m).ok_or(kincal_error::new(kincal_status::Internal))?;
        // SAFETY: forwarded contract.
        let cs = with_any_robot!(&any, r => unsafe {
            cluster_run(r, &a, params, params_len, s, workspace, workspace_len, chosen)
        })?;
        // SAFETY: checked by `arg_out!`/`arg_out_opt!`; writable by contract.
        unsafe {
            out.write(chosen);
            if let Some(o) = sel_out {
                o.put(kincal_cluster_selection {
                    spread: cs.spread,
                    value: cs.value,
                    target: cs.target,
                    within_tolerance: u32::from(cs.within_tolerance),
                    occupied_cubes: cs.occupied_cubes,
                });
            }
        }
        Ok(())
    })
}
