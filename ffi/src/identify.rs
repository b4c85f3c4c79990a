//! Identification (Sections 3.2–4.1): the identifiability analysis and the paper's three
//! algorithms (OLS, OPT1, OPT2) over a caller-owned set of measurements, with caller-owned
//! working memory.
//!
//! Memory: the core needs a p×p workspace (p = requested parameters, rounded up to one of the
//! capacities 32 or `KINCAL_MAX_PARAMS`) and the measurements in its own form (about
//! 0.26 KB per pose). Both live in one caller buffer of `kincal_identify_workspace_size`
//! bytes: `malloc` on a host, a static array on a controller. Nothing is allocated here.

use core::ffi::c_void;

use kincal::identify::{
    Algorithm, Bounds, ComponentMask, Identifiability, Identification, IdentifyOptions,
    MAX_CORRELATED_PAIRS, Measurement, Prior, PriorSizes, Workspace, analyze, identify,
};
use kincal::params::num_params;
use kincal::{EffectSet, ParamSet, Robot, with_any_robot};

use crate::kinematics::{DATA_AUX, joint_state, kincal_joint_aux};
use crate::robot::{KINCAL_MAX_JOINTS, KINCAL_MAX_PARAMS, from_robot, kincal_robot, to_any};
use crate::status::{FfiResult, KINCAL_NO_INDEX, kincal_error, kincal_status};

/// Most strongly correlated parameter pairs a report lists (`kincal_identify_report`).
pub const KINCAL_MAX_CORRELATED_PAIRS: usize = 32;
const _: () = assert!(KINCAL_MAX_CORRELATED_PAIRS == MAX_CORRELATED_PAIRS);
const _: () = assert!(KINCAL_MAX_PARAMS == kincal::identify::MAX_MODEL_PARAMS);

/// Alignment `kincal_identify` needs of its workspace pointer (`malloc` provides it).
pub const KINCAL_WORKSPACE_ALIGN: usize = 16;

/// The identification algorithms of the paper (Section 4.1.3).
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_algorithm {
    /// Gauss–Newton with the minimum-norm least-squares step (Matlab `lsqminnorm`).
    Ols = 0,
    /// Bounded fit inside the prior intervals `lower`/`upper` of the options (`fmincon` in
    /// the paper): projected Levenberg–Marquardt; parameters ending on a bound are reported.
    Opt1 = 1,
    /// Levenberg–Marquardt with MINPACK's trust region (`lsqnonlin`).
    Opt2 = 2,
}

/// A set of measurements: caller-owned arrays, viewed (not copied into the library) for the
/// duration of one call. L = `n_poses`, N = the robot's joint count.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
#[allow(non_camel_case_types)]
pub struct kincal_measurements {
    /// Number of poses L (≥ 1).
    pub n_poses: usize,
    /// Joint readings [rad], L × N row-major (pose l at `q[l*N]`); `q_len` = L·N.
    pub q: *const f64,
    /// Length of `q`.
    pub q_len: usize,
    /// Measured tool poses `T_e^b` in the base frame: L 4×4 column-major rigid transforms;
    /// `poses_len` = 16·L.
    pub poses: *const f64,
    /// Length of `poses`.
    pub poses_len: usize,
    /// Measured components per pose (bit k = component k of `[x, y, z, φx, φy, φz]`: 0x3f a
    /// full pose, 0x07 position only), or NULL for full poses; `masks_len` = L.
    pub masks: *const u8,
    /// Length of `masks` (ignored when NULL).
    pub masks_len: usize,
    /// Approach directions / temperature per pose, or NULL; `aux_len` = L.
    pub aux: *const kincal_joint_aux,
    /// Length of `aux` (ignored when NULL).
    pub aux_len: usize,
    /// Weight of each pose in the fit (finite, ≥ 0; it multiplies the row weights): 1
    /// normally, 0 to hold a pose out (cross-validation), other values for robust
    /// reweighting; or NULL for all 1. `weights_len` = L. Validation ignores the weights.
    pub weights: *const f64,
    /// Length of `weights` (ignored when NULL).
    pub weights_len: usize,
}

/// Options of `kincal_identify` and `kincal_analyze_identifiability`; fill them with
/// `kincal_identify_options_default`, then edit. Plain data, no pointers.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_identify_options {
    /// A `kincal_algorithm`.
    pub algorithm: u32,
    /// Iteration limit (default 200); reaching it is `KINCAL_STATUS_NOT_CONVERGED`.
    pub max_iterations: u32,
    /// Non-zero: fit the identifiable subset even when the data leave some generically
    /// identifiable parameters undetermined, at the initial or at the fitted model
    /// (otherwise `KINCAL_STATUS_RANK_DEFICIENT`).
    pub allow_data_deficiency: u32,
    /// Orientation error of the cost, a `kincal_orientation_error` (default exact).
    pub orientation: u32,
    /// Relative step tolerance (default 1e-12).
    pub xtol: f64,
    /// Relative cost-reduction tolerance (default 1e-14).
    pub ftol: f64,
    /// Absolute cost below which the fit is exact (default 1e-28).
    pub abs_cost_tol: f64,
    /// Identifiability tolerance on unit-scaled Jacobian columns (default 1e-6).
    pub rank_tol: f64,
    /// Weight of each position row [1/m²] (default 1).
    pub weight_pos: f64,
    /// Weight of each rotation row [1/rad²] (default 1).
    pub weight_rot: f64,
    /// Parameters to identify: `requested[i]` non-zero for flat index i (first
    /// `kincal_num_params(N)` used); only their identifiable subset is fitted.
    pub requested: [u8; KINCAL_MAX_PARAMS],
    /// OPT1 prior intervals, absolute values per flat index (±infinity allowed, NaN not).
    pub lower: [f64; KINCAL_MAX_PARAMS],
    /// Upper ends of the OPT1 intervals.
    pub upper: [f64; KINCAL_MAX_PARAMS],
    /// Gaussian prior for weak directions, for every algorithm: per flat index, the σ of a
    /// prior centred on the robot's own value (the model the fit starts from), in the
    /// parameter's unit; `INFINITY` = no prior (the default everywhere). Each prior adds
    /// one row weighted 1/σ² on the scale of `weight_pos`/`weight_rot`, so it means what
    /// it says when those whiten the data (1/σ_instrument²). Counted in the standard
    /// errors (posterior). `kincal_identify_options_set_prior` fills the link entries.
    pub prior_sigma: [f64; KINCAL_MAX_PARAMS],
}

/// Residual statistics of a model on a set of measurements.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_residual_stats {
    /// Number of poses.
    pub poses: usize,
    /// Number of measured rows (components).
    pub rows: usize,
    /// Weighted sum of squares (the identification cost).
    pub cost: f64,
    /// RMS of |e_p| over poses with a measured position [m].
    pub rms_pos_m: f64,
    /// Largest |e_p| [m].
    pub max_pos_m: f64,
    /// RMS of the rotation angle over poses with a measured orientation [rad].
    pub rms_rot_rad: f64,
    /// Largest rotation angle [rad].
    pub max_rot_rad: f64,
}

/// What the data can determine. Masks are indexed by flat parameter index (1 = member).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_identifiability {
    /// Number of identifiable parameters.
    pub rank: usize,
    /// σ_max/σ_min of the unit-column-scaled Jacobian of the identifiable parameters
    /// (infinity when singular).
    pub condition_number: f64,
    /// What was asked for.
    pub requested: [u8; KINCAL_MAX_PARAMS],
    /// What the data determine (and is fitted).
    pub identifiable: [u8; KINCAL_MAX_PARAMS],
    /// Redundant in the model for the measured components, whatever the poses.
    pub structural: [u8; KINCAL_MAX_PARAMS],
    /// Identifiable in general but not from these poses.
    pub data_deficient: [u8; KINCAL_MAX_PARAMS],
    /// For each parameter not kept: the kept parameter its column aligns with most
    /// (`KINCAL_NO_INDEX` if none).
    pub partner: [usize; KINCAL_MAX_PARAMS],
    /// |cos| of the angle between the two columns (NaN if no partner).
    pub partner_cosine: [f64; KINCAL_MAX_PARAMS],
    /// Number of valid entries of `singular_values` (= `rank`).
    pub n_singular_values: usize,
    /// Singular values (descending) of the unit-column-scaled Jacobian of the identifiable
    /// parameters.
    pub singular_values: [f64; KINCAL_MAX_PARAMS],
}

/// A pair of strongly correlated parameter estimates.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_correlation {
    /// First parameter (flat index).
    pub a: usize,
    /// Second parameter (flat index).
    pub b: usize,
    /// Correlation coefficient.
    pub rho: f64,
}

/// Everything `kincal_identify` reports besides the identified model.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_identify_report {
    /// The `kincal_algorithm` used.
    pub algorithm: u32,
    /// Iterations used.
    pub iterations: u32,
    /// The identifiability analysis.
    pub analysis: kincal_identifiability,
    /// Residuals of the initial model.
    pub initial: kincal_residual_stats,
    /// Residuals of the identified model.
    pub fitted: kincal_residual_stats,
    /// Residual variance σ² = cost/(rows − fitted parameters) (0 without redundancy).
    pub sigma2: f64,
    /// Standard error of each fitted parameter (flat index; 0 for parameters not fitted).
    pub std_errors: [f64; KINCAL_MAX_PARAMS],
    /// OPT1: fitted parameters that ended on a bound (mask by flat index).
    pub at_bound: [u8; KINCAL_MAX_PARAMS],
    /// Number of pairs with |ρ| above 0.95 (only the first `KINCAL_MAX_CORRELATED_PAIRS`
    /// are listed).
    pub n_correlated: usize,
    /// The listed pairs.
    pub correlated: [kincal_correlation; KINCAL_MAX_CORRELATED_PAIRS],
    /// With a prior: Σ((x − centre)/σ)² over the fitted parameters that carry one; else 0.
    pub prior_chi2: f64,
    /// With a prior: its rows (fitted parameters with a finite σ); else 0.
    pub prior_rows: usize,
}

/// Workspace capacities (parameters fitted at once) the C ABI instantiates.
pub(crate) const CAPACITIES: [usize; 2] = [32, KINCAL_MAX_PARAMS];

/// The smallest capacity holding `n` parameters.
pub(crate) fn capacity_for(n: usize) -> Option<usize> {
    CAPACITIES.iter().copied().find(|&c| c >= n)
}

/// `x` rounded up to a multiple of `align`; `usize::MAX` on overflow (or `align == 0`), so
/// the callers' checked additions fail. No division that can trap: `div_ceil` by a run-time
/// `align` is a panic path where this is not inlined (opt-level z).
pub(crate) const fn round_up(x: usize, align: usize) -> usize {
    match x.checked_next_multiple_of(align) {
        Some(v) => v,
        None => usize::MAX,
    }
}

/// Bytes of the workspace of capacity `P` for `L` poses of an `N`-joint robot:
/// `Workspace<P>` then the measurements.
const fn bytes<const N: usize, const P: usize>(n_poses: usize) -> Option<usize> {
    let ws = round_up(core::mem::size_of::<Workspace<P>>(), KINCAL_WORKSPACE_ALIGN);
    match n_poses.checked_mul(core::mem::size_of::<Measurement<N>>()) {
        Some(m) => ws.checked_add(m),
        None => None,
    }
}

const _: () =
    assert!(core::mem::align_of::<Workspace<KINCAL_MAX_PARAMS>>() <= KINCAL_WORKSPACE_ALIGN);
const _: () =
    assert!(core::mem::align_of::<Measurement<KINCAL_MAX_JOINTS>>() <= KINCAL_WORKSPACE_ALIGN);

fn bytes_for<const N: usize>(capacity: usize, n_poses: usize) -> Option<usize> {
    match capacity {
        32 => bytes::<N, 32>(n_poses),
        KINCAL_MAX_PARAMS => bytes::<N, KINCAL_MAX_PARAMS>(n_poses),
        _ => None,
    }
}

fn workspace_size(n_joints: usize, n_poses: usize, n_requested: usize) -> Option<usize> {
    let cap = capacity_for(n_requested)?;
    match n_joints {
        1 => bytes_for::<1>(cap, n_poses),
        2 => bytes_for::<2>(cap, n_poses),
        3 => bytes_for::<3>(cap, n_poses),
        4 => bytes_for::<4>(cap, n_poses),
        5 => bytes_for::<5>(cap, n_poses),
        6 => bytes_for::<6>(cap, n_poses),
        7 => bytes_for::<7>(cap, n_poses),
        8 => bytes_for::<8>(cap, n_poses),
        9 => bytes_for::<9>(cap, n_poses),
        10 => bytes_for::<10>(cap, n_poses),
        11 => bytes_for::<11>(cap, n_poses),
        12 => bytes_for::<12>(cap, n_poses),
        _ => None,
    }
}

/// Bytes of caller memory `kincal_identify` and `kincal_analyze_identifiability` need for
/// `n_poses` measurements of an `n_joints` robot when `n_requested` parameters are
/// requested (the count of non-zero `requested` entries; the size is that of the smallest
/// capacity, 32 or `KINCAL_MAX_PARAMS`, that holds them: about 92 KB or 1.45 MB,
/// plus about 0.26 KB per pose). Returns 0 for an invalid joint count, more than
/// `KINCAL_MAX_PARAMS` parameters, or an overflowing size.
#[unsafe(no_mangle)]
pub extern "C" fn kincal_identify_workspace_size(
    n_joints: usize,
    n_poses: usize,
    n_requested: usize,
) -> usize {
    ffi_boundary!(on_panic = 0; { workspace_size(n_joints, n_poses, n_requested).unwrap_or(0) })
}

pub(crate) fn mask_of(set: &ParamSet) -> [u8; KINCAL_MAX_PARAMS] {
    let mut m = [0u8; KINCAL_MAX_PARAMS];
    for (i, v) in m.iter_mut().enumerate() {
        *v = u8::from(set.contains(i));
    }
    m
}

fn algorithm(v: u32) -> FfiResult<Algorithm> {
    match v {
        0 => Ok(Algorithm::Ols),
        1 => Ok(Algorithm::Opt1),
        2 => Ok(Algorithm::Opt2),
        _ => Err(kincal_error::new(kincal_status::InvalidArgument)
            .arg(c"opts->algorithm")
            .value(f64::from(v))),
    }
}

fn defaults<const N: usize>(
    r: &Robot<N>,
    alg: Algorithm,
    effects: EffectSet,
) -> kincal_identify_options {
    let set = r.param_set(effects);
    let o = IdentifyOptions::new(alg, set);
    let b = Bounds::paper_default(r);
    kincal_identify_options {
        algorithm: alg as u32,
        max_iterations: o.max_iterations,
        allow_data_deficiency: u32::from(o.allow_data_deficiency),
        orientation: match o.orientation {
            kincal::OrientationError::SmallAngle => 0,
            kincal::OrientationError::Exact => 1,
        },
        xtol: o.xtol,
        ftol: o.ftol,
        abs_cost_tol: o.abs_cost_tol,
        rank_tol: o.rank_tol,
        weight_pos: o.weight_pos,
        weight_rot: o.weight_rot,
        requested: mask_of(&set),
        lower: b.lower,
        upper: b.upper,
        prior_sigma: [f64::INFINITY; KINCAL_MAX_PARAMS],
    }
}

/// Default identification options for `robot`: `algorithm` (a `kincal_algorithm`), the
/// geometric parameters θ0, a, α and d-or-β of every link plus every parameter of the effects in
/// the mask `effects` requested, OPT1 intervals of the paper (±5 mm on lengths, ±5° on angles
/// around the current parameters; compliance in [0, 1e-2] rad/(N·m)), and the tolerances listed
/// in `kincal_identify_options`. Returns OK, NULL_POINTER, MISALIGNED_POINTER,
/// INVALID_ARGUMENT (`algorithm`, `effects`) or any status of `kincal_robot_validate`.
///
/// # Safety
/// `robot` must be NULL or point to a readable `kincal_robot`; `opts_out` NULL or writable;
/// `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_identify_options_default(
    robot: *const kincal_robot,
    algorithm: u32,
    effects: u32,
    opts_out: *mut kincal_identify_options,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let r = arg_ref!(robot);
        let out = arg_out1!(opts_out);
        let alg = self::algorithm(algorithm).map_err(|e| e.arg(c"algorithm"))?;
        let set = crate::effects::effect_set(effects)?;
        let any = to_any(r)?;
        let o = with_any_robot!(&any, r => defaults(r, alg, set));
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(o) };
        Ok(())
    })
}

/// Sets `opts->prior_sigma` for `robot`'s link parameters: `length_m` on every link length
/// (d, a) and `angle_rad` on every link angle (θ0, α, β); frames and effects get no prior
/// (`INFINITY`). The CLI's defaults are 5 mm and 1° (`kincal calibrate --prior`). Either
/// size may be `INFINITY` (no prior on that kind). Returns OK, NULL_POINTER,
/// MISALIGNED_POINTER, INVALID_ARGUMENT (a size NaN, zero or negative; a bad robot).
///
/// # Safety
/// `robot` points to a readable `kincal_robot`; `opts` to a writable
/// `kincal_identify_options` (typically filled by `kincal_identify_options_default`); `err`
/// is NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_identify_options_set_prior(
    robot: *const kincal_robot,
    length_m: f64,
    angle_rad: f64,
    opts: *mut kincal_identify_options,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let r = arg_ref!(robot);
        for (v, name) in [(length_m, c"length_m"), (angle_rad, c"angle_rad")] {
            if v.is_nan() || v <= 0.0 {
                return Err(kincal_error::new(kincal_status::InvalidArgument).arg(name).value(v));
            }
        }
        let any = to_any(r)?;
        let sigma = with_any_robot!(&any, r => {
            Prior::around(r, &PriorSizes::links(length_m, angle_rad)).sigma
        });
        let mut o: kincal_identify_options = *arg_ref!(opts);
        for (d, s) in o.prior_sigma.iter_mut().zip(sigma) {
            *d = s;
        }
        let out = arg_out1!(opts);
        // SAFETY: checked by `arg_out1!`; writable by contract.
        unsafe { out.put(o) };
        Ok(())
    })
}

/// The core options of checked C options for an `n`-joint robot; `bounds` receives OPT1's
/// intervals.
pub(crate) fn options<'a>(
    o: &kincal_identify_options,
    n: usize,
    bounds: &'a mut Bounds,
) -> FfiResult<IdentifyOptions<'a>> {
    let alg = algorithm(o.algorithm)?;
    let mut requested = ParamSet::new();
    for (i, &m) in o.requested.iter().enumerate().take(num_params(n)) {
        if m != 0 {
            requested.insert(i)?;
        }
    }
    for (v, name) in [
        (o.xtol, c"opts->xtol"),
        (o.ftol, c"opts->ftol"),
        (o.abs_cost_tol, c"opts->abs_cost_tol"),
        (o.rank_tol, c"opts->rank_tol"),
        (o.weight_pos, c"opts->weight_pos"),
        (o.weight_rot, c"opts->weight_rot"),
    ] {
        crate::args::finite(&[v], name)?;
        if v < 0.0 {
            return Err(kincal_error::new(kincal_status::InvalidArgument)
                .arg(name)
                .value(v));
        }
    }
    let orientation = match o.orientation {
        0 => kincal::OrientationError::SmallAngle,
        1 => kincal::OrientationError::Exact,
        v => {
            return Err(kincal_error::new(kincal_status::InvalidArgument)
                .arg(c"opts->orientation")
                .value(f64::from(v)));
        }
    };
    for (i, (&lo, &hi)) in o
        .lower
        .iter()
        .zip(o.upper.iter())
        .enumerate()
        .take(num_params(n))
    {
        if lo.is_nan() || hi.is_nan() || lo > hi {
            return Err(kincal_error::new(kincal_status::InvalidArgument)
                .arg(if lo.is_nan() || lo > hi {
                    c"opts->lower"
                } else {
                    c"opts->upper"
                })
                .at(i)
                .value(if lo.is_nan() { lo } else { hi }));
        }
    }
    bounds.lower = o.lower;
    bounds.upper = o.upper;
    let mut io = IdentifyOptions::new(alg, requested);
    io.max_iterations = o.max_iterations;
    io.allow_data_deficiency = o.allow_data_deficiency != 0;
    io.orientation = orientation;
    io.xtol = o.xtol;
    io.ftol = o.ftol;
    io.abs_cost_tol = o.abs_cost_tol;
    io.rank_tol = o.rank_tol;
    io.weight_pos = o.weight_pos;
    io.weight_rot = o.weight_rot;
    io.bounds = Some(bounds);
    Ok(io)
}

/// The prior of checked C options around `r` (the model the fit starts from), or `None`
/// when every σ is infinite. A σ that is NaN, zero or negative is refused.
pub(crate) fn prior_of<const N: usize>(
    o: &kincal_identify_options,
    r: &Robot<N>,
) -> FfiResult<Option<Prior>> {
    let n = num_params(N);
    if let Some((i, &s)) = o
        .prior_sigma
        .iter()
        .enumerate()
        .take(n)
        .find(|(_, s)| s.is_nan() || **s <= 0.0)
    {
        return Err(kincal_error::new(kincal_status::InvalidArgument)
            .arg(c"opts->prior_sigma")
            .at(i)
            .value(s));
    }
    if !o.prior_sigma.iter().take(n).any(|s| s.is_finite()) {
        return Ok(None);
    }
    let mut p = Prior::around(r, &PriorSizes::NONE);
    for (d, &s) in p.sigma.iter_mut().zip(o.prior_sigma.iter()).take(n) {
        *d = s;
    }
    Ok(Some(p))
}

/// The caller's measurement arrays, checked (NULL, alignment, lengths), not yet converted.
pub(crate) struct Data<'a> {
    n_poses: usize,
    q: &'a [f64],
    poses: &'a [f64],
    masks: Option<&'a [u8]>,
    aux: Option<&'a [kincal_joint_aux]>,
    weights: Option<&'a [f64]>,
}

/// Checks `data` for an `n`-joint robot.
///
/// # Safety
/// `data` is NULL or points to a `kincal_measurements` whose non-NULL arrays are readable for
/// their stated lengths.
pub(crate) unsafe fn data_view<'a>(
    data: *const kincal_measurements,
    n: usize,
) -> FfiResult<Data<'a>> {
    // SAFETY: forwarded contract.
    let d = unsafe { crate::args::req(data, c"data") }?;
    let l = d.n_poses;
    if l == 0 {
        return Err(kincal_error::new(kincal_status::TooFewData)
            .arg(c"data->n_poses")
            .counts(1, 0));
    }
    let len = |per: usize, name| {
        l.checked_mul(per)
            .ok_or_else(|| crate::args::bad_length(name, KINCAL_NO_INDEX, l))
    };
    // SAFETY (all four): forwarded contract; lengths checked against L before use.
    let q = unsafe { crate::args::slice(d.q, d.q_len, len(n, c"data->q")?, c"data->q") }?;
    let poses = unsafe {
        crate::args::slice(
            d.poses,
            d.poses_len,
            len(16, c"data->poses")?,
            c"data->poses",
        )
    }?;
    let masks = if d.masks.is_null() {
        None
    } else {
        Some(unsafe { crate::args::slice(d.masks, d.masks_len, l, c"data->masks") }?)
    };
    let aux = if d.aux.is_null() {
        None
    } else {
        Some(unsafe { crate::args::slice(d.aux, d.aux_len, l, c"data->aux") }?)
    };
    let weights = if d.weights.is_null() {
        None
    } else {
        Some(unsafe { crate::args::slice(d.weights, d.weights_len, l, c"data->weights") }?)
    };
    crate::args::finite(q, c"data->q")?;
    if let Some(w) = weights {
        crate::args::finite(w, c"data->weights")?;
        if let Some(l) = w.iter().position(|&v| v < 0.0) {
            return Err(kincal_error::new(kincal_status::InvalidArgument)
                .arg(c"data->weights")
                .at(l)
                .value(w.get(l).copied().unwrap_or(f64::NAN)));
        }
    }
    Ok(Data {
        n_poses: l,
        q,
        poses,
        masks,
        aux,
        weights,
    })
}

impl Data<'_> {
    /// Number of poses.
    pub(crate) fn n_poses(&self) -> usize {
        self.n_poses
    }

    /// Measurement `l` in the core's form; errors name the pose.
    pub(crate) fn measurement<const N: usize>(&self, l: usize) -> FfiResult<Measurement<N>> {
        let at_pose = |mut e: kincal_error| {
            e.pose = l;
            e
        };
        let q = self
            .q
            .get(l * N..(l + 1) * N)
            .ok_or(kincal_error::new(kincal_status::Internal))?;
        let aux = match self.aux {
            Some(a) => Some(a.get(l).ok_or(kincal_error::new(kincal_status::Internal))?),
            None => None,
        };
        let state = joint_state::<N>(q, aux, DATA_AUX).map_err(at_pose)?;
        let m = self
            .poses
            .get(16 * l..16 * (l + 1))
            .ok_or(kincal_error::new(kincal_status::Internal))?;
        let pose = crate::pose::from_matrix(m, c"data->poses").map_err(|mut e| {
            if e.index != KINCAL_NO_INDEX {
                e.index += 16 * l;
            }
            at_pose(e)
        })?;
        let mask = match self.masks {
            Some(ms) => {
                let v = ms.get(l).copied().unwrap_or(0);
                if v == 0 || v & !0x3f != 0 {
                    return Err(at_pose(
                        kincal_error::new(kincal_status::InvalidArgument)
                            .arg(c"data->masks")
                            .at(l)
                            .value(f64::from(v)),
                    ));
                }
                ComponentMask(v)
            }
            None => ComponentMask::ALL,
        };
        let weight = match self.weights {
            Some(w) => w.get(l).copied().unwrap_or(1.0),
            None => 1.0,
        };
        Ok(Measurement {
            state,
            pose,
            mask,
            weight,
            point: None,
        })
    }
}

/// The caller's workspace split into the core workspace and the measurement array, with the
/// measurements converted.
///
/// # Safety
/// `ws` is NULL or writable for `ws_len` bytes, and no reference into it is alive.
unsafe fn prepare<'w, const N: usize, const P: usize>(
    ws: *mut c_void,
    ws_len: usize,
    data: &Data<'_>,
) -> FfiResult<(&'w mut Workspace<P>, &'w [Measurement<N>])> {
    let l = data.n_poses;
    let needed = bytes::<N, P>(l).ok_or(kincal_error::new(kincal_status::CapacityExceeded))?;
    if ws.is_null() {
        return Err(crate::args::null(c"workspace"));
    }
    if !(ws as usize).is_multiple_of(KINCAL_WORKSPACE_ALIGN) {
        return Err(kincal_error::new(kincal_status::MisalignedPointer).arg(c"workspace"));
    }
    if ws_len < needed {
        return Err(crate::args::bad_length(c"workspace", needed, ws_len));
    }
    let base = ws.cast::<u8>();
    let offset = round_up(core::mem::size_of::<Workspace<P>>(), KINCAL_WORKSPACE_ALIGN);
    // SAFETY: `base` is aligned to KINCAL_WORKSPACE_ALIGN >= align_of Workspace<P>, and
    // writable for `needed >= size_of Workspace<P>` bytes. All-zero bytes are a valid
    // Workspace (documented by the core), so the zeroed memory may be referenced as one.
    let workspace = unsafe {
        core::ptr::write_bytes(base, 0, core::mem::size_of::<Workspace<P>>());
        &mut *base.cast::<Workspace<P>>()
    };
    // SAFETY: `offset` is a multiple of KINCAL_WORKSPACE_ALIGN >= align_of Measurement<N>;
    // `offset + L * size_of Measurement<N>` = `needed` <= `ws_len`; the two regions do not
    // overlap.
    let first = unsafe { base.add(offset).cast::<Measurement<N>>() };
    for l in 0..l {
        let m = data.measurement::<N>(l)?;
        // SAFETY: slot `l < L` lies within the region checked above.
        unsafe { first.add(l).write(m) };
    }
    // SAFETY: all L slots were initialised just above.
    let measurements = unsafe { core::slice::from_raw_parts(first, l) };
    Ok((workspace, measurements))
}

fn analysis_of<const P: usize>(a: &Identifiability, ws: &Workspace<P>) -> kincal_identifiability {
    let mut out = kincal_identifiability {
        rank: a.rank,
        condition_number: a.condition_number,
        requested: mask_of(&a.requested),
        identifiable: mask_of(&a.identifiable),
        structural: mask_of(&a.structural),
        data_deficient: mask_of(&a.data_deficient),
        partner: [KINCAL_NO_INDEX; KINCAL_MAX_PARAMS],
        partner_cosine: [f64::NAN; KINCAL_MAX_PARAMS],
        n_singular_values: 0,
        singular_values: [0.0; KINCAL_MAX_PARAMS],
    };
    for ((p, c), partner) in out
        .partner
        .iter_mut()
        .zip(out.partner_cosine.iter_mut())
        .zip(a.partner.iter())
    {
        if let Some(q) = partner {
            *p = q.param.0;
            *c = q.cosine;
        }
    }
    let sv = ws.singular_values();
    out.n_singular_values = sv.len();
    for (d, s) in out.singular_values.iter_mut().zip(sv) {
        *d = *s;
    }
    out
}

fn stats(s: &kincal::identify::ResidualStats) -> kincal_residual_stats {
    kincal_residual_stats {
        poses: s.poses,
        rows: s.rows,
        cost: s.cost,
        rms_pos_m: s.rms_pos_m,
        max_pos_m: s.max_pos_m,
        rms_rot_rad: s.rms_rot_rad,
        max_rot_rad: s.max_rot_rad,
    }
}

pub(crate) fn report_of<const N: usize, const P: usize>(
    r: &Identification<N>,
    ws: &Workspace<P>,
) -> kincal_identify_report {
    let mut out = kincal_identify_report {
        algorithm: r.algorithm as u32,
        iterations: r.iterations,
        analysis: analysis_of(&r.analysis, ws),
        initial: stats(&r.initial),
        fitted: stats(&r.fitted),
        sigma2: r.sigma2,
        std_errors: r.std_errors,
        at_bound: mask_of(&r.at_bound),
        n_correlated: r.n_correlated,
        correlated: [kincal_correlation::default(); KINCAL_MAX_CORRELATED_PAIRS],
        prior_chi2: r.prior_chi2,
        prior_rows: r.prior_rows,
    };
    for (d, c) in out.correlated.iter_mut().zip(r.correlations()) {
        *d = kincal_correlation {
            a: c.a.0,
            b: c.b.0,
            rho: c.rho,
        };
    }
    out
}

/// What a call computes with the prepared workspace and measurements.
#[derive(Clone, Copy)]
enum Task {
    Analyze,
    Identify,
}

// Returned once per call by value (nothing stores it), so the size difference is harmless.
#[allow(clippy::large_enum_variant)]
enum Outcome {
    Analysis(kincal_identifiability),
    Identified(kincal_robot, kincal_identify_report),
}

/// # Safety
/// As [`prepare`].
unsafe fn run_p<const N: usize, const P: usize>(
    r: &Robot<N>,
    data: &Data<'_>,
    opts: &IdentifyOptions<'_>,
    ws: *mut c_void,
    ws_len: usize,
    task: Task,
) -> FfiResult<Outcome> {
    // SAFETY: forwarded contract.
    let (workspace, measurements) = unsafe { prepare::<N, P>(ws, ws_len, data) }?;
    match task {
        Task::Analyze => {
            let a = analyze(r, measurements, opts, workspace)?;
            Ok(Outcome::Analysis(analysis_of(&a, workspace)))
        }
        Task::Identify => {
            let id = identify(r, measurements, opts, workspace)?;
            let report = report_of(&id, workspace);
            Ok(Outcome::Identified(from_robot(&id.robot)?, report))
        }
    }
}

/// # Safety
/// As [`prepare`].
unsafe fn run<const N: usize>(
    r: &Robot<N>,
    data: &Data<'_>,
    o: &kincal_identify_options,
    ws: *mut c_void,
    ws_len: usize,
    task: Task,
) -> FfiResult<Outcome> {
    let mut bounds = Bounds::paper_default(r);
    let prior = prior_of(o, r)?;
    let mut opts = options(o, N, &mut bounds)?;
    opts.prior = prior.as_ref();
    let n_requested = opts.requested.len();
    if n_requested == 0 {
        return Err(kincal_error::new(kincal_status::TooFewData)
            .arg(c"opts->requested")
            .counts(1, 0));
    }
    // SAFETY (all three): forwarded contract.
    match capacity_for(n_requested) {
        Some(32) => unsafe { run_p::<N, 32>(r, data, &opts, ws, ws_len, task) },
        Some(KINCAL_MAX_PARAMS) => unsafe {
            run_p::<N, KINCAL_MAX_PARAMS>(r, data, &opts, ws, ws_len, task)
        },
        _ => Err(kincal_error::new(kincal_status::CapacityExceeded)
            .arg(c"opts->requested")
            .counts(KINCAL_MAX_PARAMS, n_requested)),
    }
}

/// # Safety
/// Pointers as the exports document.
unsafe fn entry(
    robot: *const kincal_robot,
    data: *const kincal_measurements,
    opts: *const kincal_identify_options,
    workspace: *mut c_void,
    workspace_len: usize,
    task: Task,
) -> FfiResult<Outcome> {
    let r = arg_ref!(robot);
    let o = arg_ref!(opts);
    let any = to_any(r)?;
    // SAFETY: forwarded contract.
    let view = unsafe { data_view(data, any.n_joints()) }?;
    // SAFETY: forwarded contract.
    with_any_robot!(&any, r => unsafe { run(r, &view, o, workspace, workspace_len, task) })
}

/// Identification: fits the identifiable subset of `opts->requested` to the measurements,
/// starting from `robot`, with `opts->algorithm` (OLS, OPT1 or OPT2), and writes the identified
/// model to `robot_out` and the report (identifiability analysis, residuals before and after,
/// standard errors, correlations, parameters on a bound) to `report_out` (NULL if not wanted).
/// OLS and OPT2 give each fitted link angle (θ0, α, β) within half a turn of its initial value.
///
/// - `robot`: initial model (read only). `robot_out` may point to the same struct.
/// - `data`: the measurements (see `kincal_measurements`); their poses in metres.
/// - `opts`: from `kincal_identify_options_default`, possibly edited.
/// - `workspace`, `workspace_len`: caller memory of at least `kincal_identify_workspace_size(N,
///   L, requested count)` bytes, aligned to `KINCAL_WORKSPACE_ALIGN`; its contents are scratch.
///
/// Returns OK; argument errors (NULL_POINTER, MISALIGNED_POINTER, BAD_LENGTH with `expected` =
/// the bytes needed for a short workspace, NON_FINITE, INVALID_TRANSFORM or INVALID_ARGUMENT
/// with `pose` set for a bad measurement, INVALID_ARGUMENT for an option, MISSING_INPUT when a
/// requested effect's input is missing, TOO_FEW_DATA, CAPACITY_EXCEEDED, any status of
/// `kincal_robot_validate`); RANK_DEFICIENT (the data leave requested parameters undetermined;
/// see `kincal_analyze_identifiability`, or set `allow_data_deficiency`: a parameter found
/// undetermined only at the fitted model is then held and listed in the result's analysis),
/// NOT_CONVERGED (`iterations`),
/// INVALID_PARAMETER (OPT1 with an initial value outside its interval). Outputs are written on
/// success only.
///
/// # Safety
/// Non-NULL pointers must be valid for their stated lengths (`workspace` writable for
/// `workspace_len` bytes and not overlapping the other arguments); `err` NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_identify(
    robot: *const kincal_robot,
    data: *const kincal_measurements,
    opts: *const kincal_identify_options,
    workspace: *mut c_void,
    workspace_len: usize,
    robot_out: *mut kincal_robot,
    report_out: *mut kincal_identify_report,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let out = arg_out1!(robot_out);
        let report = arg_out_opt!(report_out, 1, 1);
        // SAFETY: forwarded contract.
        let outcome = unsafe { entry(robot, data, opts, workspace, workspace_len, Task::Identify) }?;
        if let Outcome::Identified(r, rep) = outcome {
            // SAFETY: checked by `arg_out1!`/`arg_out_opt!`; writable by contract.
            unsafe {
                out.put(r);
                if let Some(p) = report {
                    p.put(rep);
                }
            }
        }
        Ok(())
    })
}

/// The identifiability analysis alone: which of `opts->requested` the measurements determine
/// (rank, structural and data-deficient parameters with their aligned partners, condition
/// number and singular values of the unit-scaled Jacobian), written to `analysis_out`.
/// Arguments, memory and statuses as `kincal_identify` (no iterations, so never
/// NOT_CONVERGED or RANK_DEFICIENT: a deficiency is reported in `analysis_out`).
///
/// # Safety
/// As `kincal_identify`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_analyze_identifiability(
    robot: *const kincal_robot,
    data: *const kincal_measurements,
    opts: *const kincal_identify_options,
    workspace: *mut c_void,
    workspace_len: usize,
    analysis_out: *mut kincal_identifiability,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let out = arg_out1!(analysis_out);
        // SAFETY: forwarded contract.
        let outcome = unsafe { entry(robot, data, opts, workspace, workspace_len, Task::Analyze) }?;
        if let Outcome::Analysis(a) = outcome {
            // SAFETY: checked by `arg_out1!`; writable by contract.
            unsafe { out.put(a) };
        }
        Ok(())
    })
}
