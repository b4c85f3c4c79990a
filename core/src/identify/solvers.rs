//! The three identification algorithms on the identifiable parameter set, and the
//! parameter covariance of the result.

use super::at_fit::{all_kept_by_factor, dropped_at};
use super::data::{
    ResidualStats, RowSource, accumulate, accumulate_gram, accumulate_trial_gram, first_gram,
    fold_last_trial,
};
use super::identifiability::analyze_into;
use super::{
    Algorithm, CORRELATION_REPORT_THRESHOLD, Correlation, Identification, IdentifyOptions,
    MAX_CORRELATED_PAIRS, MAX_MODEL_PARAMS, Workspace,
};
use crate::effects::Effect;
use crate::error::{Error, ParamIndex, Quantity, Result, check_finite};
use crate::linalg::lm::lm_parameter;
use crate::linalg::minnorm::min_norm_solve;
use crate::linalg::tri::{solve_upper_transpose, upper_inverse_gram};
use crate::math::sqrt;
use crate::model::Robot;
use crate::params::{ParamId, ParamSet};

/// Identifies the identifiable subset of `opts.requested` from `data`, starting at `robot`.
/// OLS and OPT2 report each fitted link angle (θ0, α, β) within half a turn of its starting
/// value (whole turns removed: the same model); OPT1 keeps its intervals.
///
/// Errors: bad data ([`Error::NonFinite`] with the pose index, [`Error::BadPose`]), a
/// requested effect whose input is missing ([`Error::MissingInput`]), too few rows,
/// data-deficient parameters unless allowed ([`Error::RankDeficient`]), OPT1 without
/// bounds or with an initial value outside them ([`Error::InvalidParameter`]), and
/// [`Error::NotConverged`].
pub fn identify<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
) -> Result<Identification<N>> {
    let mut out = Identification::start(robot, opts.algorithm, None);
    identify_in_place(robot, data, opts, ws, &mut out)?;
    Ok(out)
}

/// [`identify`] into the caller's `out` (every field is overwritten), so that a caller
/// holding its result in its own memory does not get a second copy on the stack.
pub(crate) fn identify_in_place<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
    out: &mut Identification<N>,
) -> Result<()> {
    data.validate()?;
    check_identify_options(opts)?;
    check_inputs(data, opts)?;
    out.robot = *robot;
    // The analysis's pass over the data at `robot` also leaves the first iteration's
    // normal equations and the initial residuals (`fold_first_pass`); not with a prior,
    // whose rows the fit's passes add.
    ws.share_first_pass = opts.prior.is_none();
    let analysed = analyze_into(robot, data, opts, ws, &mut out.analysis);
    ws.share_first_pass = false;
    let fitted = analysed.and_then(|()| identify_into(data, opts, ws, out));
    ws.first_pass = false;
    fitted
}

/// Checks the numeric options of [`identify`].
pub(crate) fn check_identify_options(opts: &IdentifyOptions<'_>) -> Result<()> {
    check_finite(
        &[
            opts.xtol,
            opts.ftol,
            opts.abs_cost_tol,
            opts.rank_tol,
            opts.weight_pos,
            opts.weight_rot,
        ],
        Quantity::Setting,
    )?;
    if opts.weight_pos < 0.0 || opts.weight_rot < 0.0 {
        return Err(Error::InvalidParameter {
            index: 0,
            value: opts.weight_pos.min(opts.weight_rot),
        });
    }
    Ok(())
}

/// As [`identify`] with the identifiability analysis already done (by [`analyze`](super::analyze) on the
/// same kind of data: same requested parameters, components and auxiliary inputs), e.g.
/// once per design in a Monte-Carlo study. Only `analysis.identifiable` is fitted.
pub fn identify_with_analysis<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
    analysis: &super::Identifiability,
    ws: &mut Workspace<P>,
) -> Result<Identification<N>> {
    let mut out = Identification::start(robot, opts.algorithm, Some(analysis));
    identify_into(data, opts, ws, &mut out)?;
    Ok(out)
}

impl<const N: usize> Identification<N> {
    /// A result not yet fitted: `robot` as the starting model, `analysis` as the
    /// identifiable set (none yet: to be filled by the analysis).
    pub(crate) fn start(
        robot: &Robot<N>,
        algorithm: Algorithm,
        analysis: Option<&super::Identifiability>,
    ) -> Self {
        let mut out = Identification {
            robot: *robot,
            algorithm,
            analysis: super::Identifiability::empty(ParamSet::new()),
            iterations: 0,
            initial: ResidualStats::default(),
            fitted: ResidualStats::default(),
            sigma2: 0.0,
            std_errors: [0.0; MAX_MODEL_PARAMS],
            at_bound: ParamSet::new(),
            correlated: [Correlation {
                a: ParamIndex(0),
                b: ParamIndex(0),
                rho: 0.0,
            }; MAX_CORRELATED_PAIRS],
            n_correlated: 0,
            prior_chi2: 0.0,
            prior_rows: 0,
            prior_held: ParamSet::new(),
        };
        if let Some(a) = analysis {
            out.analysis = *a;
        }
        out
    }
}

/// [`identify_with_analysis`] in place: fits `out.analysis.identifiable` starting from
/// `out.robot` and fills the rest of `out`. Works in the caller's memory, so that a loop of
/// fits (robust reweighting, diagnosis) keeps one result, not one per call level, on the
/// stack.
pub(crate) fn identify_into<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    data: &D,
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
    out: &mut Identification<N>,
) -> Result<()> {
    data.validate()?;
    check_inputs(data, opts)?;
    out.prior_chi2 = 0.0;
    out.prior_rows = 0;
    out.prior_held = ParamSet::new();
    let Some(prior) = opts.prior else {
        let fitted = out.analysis.identifiable;
        return fit_set(data, opts, fitted, ws, out).map(|_| ());
    };
    prior.validate()?;
    // Data-deficient parameters with a prior are fitted: the prior holds them.
    let mut fitted = out.analysis.identifiable;
    for i in out.analysis.data_deficient.iter().filter(|&i| prior.has(i)) {
        fitted.insert(i)?;
        out.prior_held.insert(i)?;
    }
    let with = super::prior::WithPrior {
        data,
        prior,
        fitted,
    };
    let fitted = fit_set(&with, opts, fitted, ws, out)?;
    out.prior_rows = fitted.iter().filter(|&i| prior.has(i)).count();
    out.prior_chi2 = prior.chi2(&out.robot, &fitted)?;
    Ok(())
}

/// Fits the parameters `fitted` (the identifiable ones, and with a prior the data-deficient
/// ones it holds) on the rows of `data`.
fn fit_set<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    data: &D,
    opts: &IdentifyOptions<'_>,
    fitted: ParamSet,
    ws: &mut Workspace<P>,
    out: &mut Identification<N>,
) -> Result<ParamSet> {
    let analysis = &out.analysis;
    let n = fitted.len();
    if n > P || analysis.identifiable.len() != analysis.rank {
        return Err(Error::CapacityExceeded {
            needed: n,
            capacity: P,
        });
    }
    let rows = data.row_count(opts);
    let undetermined = analysis.data_deficient.iter().any(|i| !fitted.contains(i));
    if n == 0 || (undetermined && !opts.allow_data_deficiency) {
        return Err(Error::RankDeficient {
            rank: analysis.rank,
            required: analysis.requested.len() - analysis.structural.len(),
        });
    }
    if rows < n {
        return Err(Error::TooFewData {
            found: rows,
            needed: n,
        });
    }
    // What the analysis's pass left (`fold_first_pass`) is the fit's first pass when it
    // folded exactly these columns, in this order, at this model (`identify_in_place`).
    ws.first_pass = ws.first_pass
        && ws.gram.n() == n
        && fitted.iter().zip(ws.cols.iter()).all(|(i, &c)| i == c);
    for (k, i) in fitted.iter().enumerate() {
        ws.cols[k] = i;
    }
    out.algorithm = opts.algorithm;
    out.initial = if ws.first_pass {
        ws.pass_stats.finish()
    } else {
        data.stats_ws(&out.robot, opts, ws)?
    };
    let fit = solve_confirmed(data, opts, fitted, ws, out)?;
    let n = fit.fitted.len();
    out.iterations = fit.iterations;
    out.sigma2 = 0.0;
    out.std_errors = [0.0; MAX_MODEL_PARAMS];
    out.at_bound = ParamSet::new();
    out.n_correlated = 0;
    if let (Algorithm::Opt1, Some(b)) = (opts.algorithm, opts.bounds) {
        for k in 0..n {
            let i = ws.cols[k];
            let v = out.robot.param(ParamIndex(i))?;
            if v <= b.lower[i] || v >= b.upper[i] {
                out.at_bound.insert(i)?;
            }
        }
    } else {
        wrap_link_angles(&mut out.robot, &ws.cols[..n], &ws.start[..n])?;
    }
    if opts.covariance {
        covariance(data, opts, n, rows, fit.factor, ws, out)?;
    }
    if fit.refitted {
        // The conditioning reported is that of the parameters fitted, at the final model.
        super::identifiability::conditioning(
            &out.robot,
            data,
            opts,
            ws,
            &mut out.analysis,
            n,
            true,
        )?;
    }
    Ok(fit.fitted)
}

/// Brings each fitted link angle (θ0, α, β of `cols`) that ended more than half a turn
/// from its starting value in `start` back by whole turns. The kinematics see these angles
/// only through their sines and cosines, so the model is the same (to rounding); but an
/// unbounded fit of a weakly determined angle (a tool point 0.1 mm off the last axis) can
/// walk several turns, and "θ0_6 = −2,344°" reads as nonsense and compares wrongly with
/// another algorithm's 16°. Angles within half a turn of their start are left bit for bit.
fn wrap_link_angles<const N: usize>(
    robot: &mut Robot<N>,
    cols: &[usize],
    start: &[f64],
) -> Result<()> {
    for (&i, &s) in cols.iter().zip(start) {
        if !ParamId::from_index(ParamIndex(i), N).is_ok_and(ParamId::is_link_angle) {
            continue;
        }
        let v = robot.param(ParamIndex(i))?;
        let turns = libm::round((v - s) / core::f64::consts::TAU);
        if turns != 0.0 {
            robot.set_param(ParamIndex(i), v - turns * core::f64::consts::TAU)?;
        }
    }
    Ok(())
}

/// What [`solve_confirmed`] fitted.
struct ConfirmedFit {
    /// The parameters fitted (without those found data-deficient at the fit).
    fitted: ParamSet,
    /// The normal equations at the fitted model.
    factor: NormalFactor,
    /// Iterations, of both fits when a refit followed.
    iterations: u32,
    /// Whether a parameter was found data-deficient at the fit.
    refitted: bool,
}

/// Runs `opts.algorithm` on the columns `ws.cols[..]` of `fitted` from `out.robot`, and
/// confirms the data step of the analysis at the fitted model ([`super::at_fit`]): a
/// parameter data-deficient there is held at its starting value, reported in
/// `out.analysis`, and the others are refitted from the start (an error unless
/// `opts.allow_data_deficiency`). Sets `out.fitted`.
fn solve_confirmed<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    data: &D,
    opts: &IdentifyOptions<'_>,
    mut fitted: ParamSet,
    ws: &mut Workspace<P>,
    out: &mut Identification<N>,
) -> Result<ConfirmedFit> {
    let (mut refitted, mut iterations) = (false, 0u32);
    loop {
        let n = fitted.len();
        for k in 0..n {
            ws.start[k] = out.robot.param(ParamIndex(ws.cols[k]))?;
        }
        let finish = match opts.algorithm {
            Algorithm::Ols => gauss_newton(&mut out.robot, data, opts, n, ws)?,
            Algorithm::Opt2 => levenberg_marquardt(&mut out.robot, data, opts, n, ws)?,
            Algorithm::Opt1 => bounded(&mut out.robot, data, opts, n, ws)?,
        };
        iterations = iterations.saturating_add(finish.iterations);
        out.fitted = if core::mem::take(&mut ws.fitted_stats) {
            ws.pass_stats.finish()
        } else {
            data.stats_ws(&out.robot, opts, ws)?
        };
        let mut factor = normal_factor_at_fit(&out.robot, data, opts, n, finish.gram_current, ws)?;
        let screened = factor.factored && all_kept_by_factor(ws, n, opts.rank_tol);
        let mut dropped = ParamSet::new();
        if !screened {
            dropped = dropped_at(&out.robot, data, opts, n, ws, &mut out.analysis.partner)?;
        }
        if let Some(prior) = data.prior() {
            // A parameter with a prior stays fitted: its prior holds it (as
            // `identify_into` fits the data-deficient ones that carry one).
            for i in fitted.iter().filter(|&i| prior.has(i)) {
                dropped.remove(i);
            }
        }
        if dropped.is_empty() {
            if !screened {
                // The test overwrote `ws.mat`: the covariance needs the factor again.
                factor.factored = factor_gram(ws, n, GramSel::All).is_ok();
            }
            return Ok(ConfirmedFit {
                fitted,
                factor,
                iterations,
                refitted,
            });
        }
        for k in 0..n {
            out.robot.set_param(ParamIndex(ws.cols[k]), ws.start[k])?;
        }
        hold_data_deficient(&mut out.analysis, dropped, &mut fitted, opts)?;
        for (k, i) in fitted.iter().enumerate() {
            ws.cols[k] = i;
        }
        ws.first_pass = false;
        refitted = true;
    }
}

/// Moves `dropped` from the fitted and identifiable parameters to the data-deficient ones;
/// [`Error::RankDeficient`] unless `opts.allow_data_deficiency` and something is left.
fn hold_data_deficient(
    analysis: &mut super::Identifiability,
    dropped: ParamSet,
    fitted: &mut ParamSet,
    opts: &IdentifyOptions<'_>,
) -> Result<()> {
    for i in dropped.iter() {
        fitted.remove(i);
        analysis.identifiable.remove(i);
        analysis.data_deficient.insert(i)?;
    }
    analysis.rank = analysis.identifiable.len();
    if fitted.is_empty() || !opts.allow_data_deficiency {
        return Err(Error::RankDeficient {
            rank: analysis.rank,
            required: analysis.requested.len() - analysis.structural.len(),
        });
    }
    Ok(())
}

use super::data::Measurement;

/// Refuses effects whose inputs the data lack, and OPT1 without bounds.
pub(crate) fn check_inputs<const N: usize, D: RowSource<N> + ?Sized>(
    data: &D,
    opts: &IdentifyOptions<'_>,
) -> Result<()> {
    data.check_inputs(opts)?;
    if opts.algorithm == Algorithm::Opt1 && opts.bounds.is_none() {
        return Err(Error::InvalidParameter {
            index: 0,
            value: f64::NAN,
        });
    }
    Ok(())
}

/// Refuses effects whose inputs the joint states lack.
pub(crate) fn check_effect_inputs<'s, const N: usize>(
    states: impl Iterator<Item = &'s crate::model::JointState<N>> + Clone,
    opts: &IdentifyOptions<'_>,
) -> Result<()> {
    let has = |e: Effect| {
        opts.requested
            .iter()
            .any(|i| ParamId::from_index(ParamIndex(i), N).is_ok_and(|id| id.effect() == Some(e)))
    };
    if has(Effect::Backlash) && states.clone().any(|s| s.approach.is_none()) {
        return Err(Error::MissingInput {
            what: Quantity::ApproachDirection,
        });
    }
    if has(Effect::Thermal) && states.clone().any(|s| s.temp_c.is_none()) {
        return Err(Error::MissingInput {
            what: Quantity::Temperature,
        });
    }
    Ok(())
}

fn get_x<const N: usize, const P: usize>(
    robot: &Robot<N>,
    n: usize,
    ws: &mut Workspace<P>,
) -> Result<()> {
    for k in 0..n {
        ws.x[k] = robot.param(ParamIndex(ws.cols[k]))?;
    }
    Ok(())
}

/// Sets the fitted parameters of `trial` to `x + step` (clipped to `bounds` when given, so
/// a parameter moved onto a bound sits exactly on it). `trial` must otherwise equal the
/// current model (the solvers keep one trial model and overwrite only these parameters).
fn apply<const N: usize, const P: usize>(
    trial: &mut Robot<N>,
    n: usize,
    ws: &Workspace<P>,
    bounds: Option<&super::Bounds>,
) -> Result<()> {
    for k in 0..n {
        let i = ws.cols[k];
        let mut v = ws.x[k] + ws.step[k];
        if let Some(b) = bounds {
            v = v.clamp(b.lower[i], b.upper[i]);
        }
        trial.set_param(ParamIndex(i), v)?;
    }
    Ok(())
}

fn unit_scale<const P: usize>(ws: &mut Workspace<P>, n: usize) {
    for k in 0..n {
        ws.colscale[k] = 1.0;
    }
}

fn scaled_norm<const P: usize>(ws: &Workspace<P>, n: usize, v: &[f64; P]) -> f64 {
    sqrt(
        (0..n)
            .map(|k| (ws.diag[k] * v[k]) * (ws.diag[k] * v[k]))
            .sum::<f64>(),
    )
}

/// Which Gram columns [`factor_gram`] takes and how it scales them; every array is read
/// from the workspace, so nothing of size P is copied onto the stack.
#[derive(Clone, Copy)]
enum GramSel {
    /// Columns `0..m`, unscaled, undamped.
    All,
    /// Columns `ws.free[..m]`, damped by `λ·ws.row[f]²` (the scale of free column f).
    FreeDamped(f64),
}

/// Cholesky factor of the (optionally damped) Gram matrix of the
/// selected columns into `ws.mat` (`m` columns, see [`GramSel`]), zero below the diagonal.
/// The selected matrix is built in `ws.mat` and factored there: no second p×p copy.
fn factor_gram<const P: usize>(ws: &mut Workspace<P>, m: usize, how: GramSel) -> Result<()> {
    let Workspace {
        gram,
        free,
        row,
        mat,
        ..
    } = ws;
    let g = gram.gram();
    let col = |a: usize| match how {
        GramSel::FreeDamped(_) => free[a],
        _ => a,
    };
    for a in 0..m {
        mat[a][..a].fill(0.0);
        for b in a..m {
            let (i, j) = (col(a).min(col(b)), col(a).max(col(b)));
            let mut x = g[i][j];
            match how {
                GramSel::FreeDamped(lambda) if a == b => x += lambda * row[a] * row[a],
                _ => {}
            }
            mat[a][b] = x;
        }
    }
    crate::linalg::gram::cholesky_upper_in_place(mat, m, 1e-14)
}

/// Solves `RᵀR·x = rhs` with `R = mat` (from [`factor_gram`] or [`damped_step`]'s
/// factorisation, each just successful) in place in `x`.
fn solve_normal<const P: usize>(mat: &[[f64; P]; P], n: usize, x: &mut [f64]) -> Result<()> {
    crate::linalg::tri::solve_normal_factored(mat, n, x)
}

/// How a solver ended.
#[derive(Clone, Copy)]
struct Finish {
    /// Iterations used.
    iterations: u32,
    /// Whether `ws.gram` holds the unit-scaled normal equations (and in `btb` the cost) of
    /// the returned model: then the covariance needs no further pass over the data.
    gram_current: bool,
}

impl Finish {
    /// Ended at a model whose normal equations are in `ws.gram`.
    const fn current(iterations: u32) -> Self {
        Finish {
            iterations,
            gram_current: true,
        }
    }
}

/// OLS: Gauss–Newton with the minimum-norm least-squares step (as `lsqminnorm`) on
/// unit-scaled columns. The step comes from the Cholesky factor of the scaled normal
/// equations — for the full-rank identifiable set that is the unique, hence minimum-norm,
/// solution — and from the SVD of the Givens factor when the normal equations are
/// numerically singular at an iterate.
///
/// Step control: the full step, halved up to 29 times while it raises the cost. On
/// contact data ([`RowSource::damped_fallback`]) and with nonsingular normal equations, from
/// the 7th halving ([`DAMPED_AFTER`]) on, the damped (Marquardt) step of the same scaled
/// length ([`step_of_length`]) is tried as well and taken when it gains at least a quarter
/// of what the linearised model predicts for it; there a rejected full step predicted to
/// gain less than [`ROUNDING_GAIN`]·`ftol` of the cost ends the fit. On every data kind,
/// when all 30 cuts raise the cost although the full step is longer than the parameters'
/// scaled norm and predicts a gain above that rounding level, the fit is not at a minimum:
/// OPT2's trust region ([`levenberg_marquardt`]) continues from that iterate
/// ([`crawl_handover`]) instead of reporting convergence. Where no damped step is tried
/// (instrument data; contact data at a singular iterate) the same handover follows a cut
/// below [`CRAWL_SCALE`] of such a step that lowers the cost: a sliver of a direction gone
/// bad is no progress.
///
/// Why the handover: along some paths the normal equations become near singular and the
/// Gauss–Newton step stops being a usable direction while still predicting a large gain.
/// On a UR10e cross-validation fold (camera poses, 30 parameters) halving accepted 2⁻⁸ …
/// 2⁻³⁰ of a step that grew from 0.2 to 1857 times the parameters' norm, the model
/// predicting 54 % of the cost throughout, and then every cut failed: the fit stopped
/// "converged" at cost 135.66 where OPT2 reaches 62.54 (held-out camera position 4.974 mm
/// instead of 4.246). On ARIA with two exact tool poses (the Octave test `too_few_poses`)
/// the same crawl (step 17,700 times the norm, predicted gain the whole cost) stopped at
/// 0.0714 where OPT2 reaches 4.09e-3. Handed over, both end converged at OPT2's minimum
/// (15 and 71 trust-region iterations; `core/tests/ols_stop.rs`). The trigger cannot fire
/// at a minimum: there the step is short, and at the rounding floor of exact data tiny
/// (the reverted damped rescue, commit 387882d, had no step-length condition). Fits that
/// end any other way are unchanged bit for bit.
///
/// Why: far from the minimum the Gauss–Newton step can be dominated by a weakly determined
/// combination of parameters. On MUKCa's `panda_6` (three plate placements) the full step is
/// 5–350 in scaled length against a parameter norm of 25, almost all of it along link 6's
/// θ0, d, a, α and link 7's d; halving alone accepted 1/4096–1/16384 of it per iteration and
/// crawled 175 iterations before the quadratic phase (186 in all, each with some 13 Jacobian
/// passes). With the damped fallback: 11, at the minimum OPT2 finds.
///
/// Why only there: the first version (commit ebc842f, reverted) used the damped step on
/// every fit and broke instrument fits. Its persistent trust radius skipped the full step
/// and, once every step of the radius's length failed, never grew again (TALOS
/// position-only: 200 iterations without convergence); it kept the Gauss–Newton direction
/// in `ws.row`, which a prior's rows overwrite during a fold; and a damped step "gains"
/// rounding noise at the floor of noise-free data (200 iterations at a cost of 2.5e-21 in
/// `core/tests/structural_memo.rs`). Without those faults, the damped fallback still
/// changed instrument fits: a TALOS cross-validation fold did not converge in 200
/// iterations (a damped step reaches the valley floor fast and then crawls along it,
/// where halved Gauss–Newton steps follow the valley). Instrument fits therefore keep
/// plain halving in the loop; the UR10e fold that plain halving once ended early is the
/// handover's case above.
///
/// A trial full step is evaluated by accumulating its normal equations (Jacobian and
/// residual in one pass): an accepted trial's cost and normal equations are those the next
/// iteration needs. Where the data have a Jacobian-free pass giving the same cost bit for bit
/// (contact data), a trial is first costed by it and folded only if accepted
/// ([`accumulate_trial_gram`]): same steps, same iterates.
fn gauss_newton<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    robot: &mut Robot<N>,
    data: &D,
    opts: &IdentifyOptions<'_>,
    n: usize,
    ws: &mut Workspace<P>,
) -> Result<Finish> {
    // One trial model, equal to `robot` except for the fitted parameters being tried.
    let mut trial = *robot;
    unit_scale(ws, n);
    let mut c = first_gram(robot, data, opts, n, ws)?;
    for it in 0..opts.max_iterations {
        get_x(robot, n, ws)?;
        if c <= opts.abs_cost_tol {
            return Ok(Finish::current(it));
        }
        for k in 0..n {
            let d = sqrt(ws.gram.gram()[k][k]);
            ws.diag[k] = if d > 0.0 { d } else { 1.0 };
            ws.colscale[k] = 1.0 / ws.diag[k];
        }
        keep_scaled_normal_equations(ws, n);
        let xn = scaled_norm(ws, n, &ws.x);
        let singular = gauss_newton_step(robot, data, opts, n, ws)?;
        let damped = !singular && data.damped_fallback();
        let dx = scaled_norm(ws, n, &ws.step);
        // The cost reduction the linearised model predicts for the full step, `gᵀδ`.
        let predicted: f64 = (0..n).map(|k| ws.gram.atb()[k] * ws.step[k]).sum();
        unit_scale(ws, n);
        // A full step this small ends the iteration once accepted: its cost suffices, its
        // normal equations would never be used.
        let last = dx <= opts.xtol * (xn + opts.xtol);
        let mut gram_current = true;
        let mut accepted = None;
        let mut scale = 1.0;
        ws.fitted_stats = false;
        for halving in 0..30u32 {
            apply(&mut trial, n, ws, None)?;
            let c2 = if last {
                // The check at the fit and the covariance need the normal equations of the
                // model this step ends at: the full step's trial is folded (its cost is
                // `cost`'s bit for bit), which spares them their pass and the fitted
                // residuals theirs.
                let rows = data.instrument_rows().filter(|_| halving == 0);
                match rows.and_then(|rows| fold_last_trial(&trial, rows, opts, n, ws)) {
                    Some(c2) => {
                        gram_current = c2 <= c;
                        ws.fitted_stats = gram_current;
                        c2
                    }
                    None => data.cost_ws(&trial, opts, ws)?,
                }
            } else {
                gram_current = false;
                accumulate_trial_gram(&trial, data, opts, n, c, ws)?
            };
            if c2 <= c {
                accepted = Some(c2);
                break;
            }
            if damped && halving == 0 && predicted <= ROUNDING_GAIN * opts.ftol * c {
                // A step the model says gains nothing above rounding, and it does not.
                break;
            }
            scale *= 0.5;
            if damped && halving >= DAMPED_AFTER && step_of_length(ws, n, scale * dx) {
                // The Gauss–Newton direction is this far off: the damped step of the same
                // length instead, if it lowers the cost.
                apply(&mut trial, n, ws, None)?;
                let c_damped = data.cost_ws(&trial, opts, ws)?;
                // Taken only when it gains a fair part of what the model predicts: at the
                // rounding floor (noise-free data) a damped step "gains" rounding noise.
                if c_damped <= c && c - c_damped >= 0.25 * model_gain(ws, n) {
                    accepted = Some(if last {
                        c_damped
                    } else {
                        accumulate_gram(&trial, data, opts, n, ws)?
                    });
                    break;
                }
                gauss_newton_direction(ws, n, singular)?;
                for k in 0..n {
                    ws.step[k] *= scale;
                }
            } else {
                for k in 0..n {
                    ws.step[k] *= 0.5;
                }
            }
        }
        let gone_bad = dx > xn && predicted > ROUNDING_GAIN * opts.ftol * c;
        if accepted.is_none() && gone_bad {
            // Every cut of the step raised the cost although the step is longer than the
            // parameters themselves and the model predicts a gain far above the cost's
            // rounding: not a minimum (there the step is short, and at the rounding floor
            // of exact data tiny) but a Gauss–Newton direction gone bad, the normal
            // equations near singular along the path. MINPACK's trust region (OPT2)
            // takes over from this iterate.
            return crawl_handover(robot, data, opts, n, ws, it);
        }
        if accepted.is_some() && gone_bad && !damped && scale < CRAWL_SCALE {
            // The same direction gone bad, a sliver of it accepted: such slivers crawl.
            return crawl_handover(robot, data, opts, n, ws, it);
        }
        let Some(c2) = accepted else {
            // No decrease along the Gauss–Newton direction nor a short damped step: at a
            // minimum to rounding.
            return Ok(Finish {
                iterations: it,
                gram_current,
            });
        };
        *robot = trial;
        if dx <= opts.xtol * (xn + opts.xtol) || (c - c2) <= opts.ftol * c {
            // After a last step, current when its full step was folded and accepted.
            return Ok(Finish {
                iterations: it + 1,
                gram_current: !last || (gram_current && ws.fitted_stats),
            });
        }
        c = c2;
    }
    Err(Error::NotConverged {
        iterations: opts.max_iterations,
    })
}

/// [`levenberg_marquardt`] from `robot` for the iterations [`gauss_newton`] has left after
/// `used`; the iterations reported are both solvers' together.
fn crawl_handover<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    robot: &mut Robot<N>,
    data: &D,
    opts: &IdentifyOptions<'_>,
    n: usize,
    ws: &mut Workspace<P>,
    used: u32,
) -> Result<Finish> {
    let mut rest = *opts;
    rest.max_iterations = opts.max_iterations - used;
    match levenberg_marquardt(robot, data, &rest, n, ws) {
        Ok(f) => Ok(Finish {
            iterations: used + f.iterations,
            ..f
        }),
        Err(Error::NotConverged { iterations }) => Err(Error::NotConverged {
            iterations: used + iterations,
        }),
        Err(e) => Err(e),
    }
}

/// A Gauss–Newton step longer than the parameters' scaled norm, predicting a gain above
/// rounding, whose cost falls only once cut below this share, is handed over to the trust
/// region as if every cut had failed ([`gauss_newton`], where no damped step is tried). Why: with a tool
/// point 0.1 mm off the last axis (position rows, started at ARIA's Table 1, 46° from the
/// truth's θ0_4) the first step kept 1/64 and moved into a region where every later one
/// kept 1/1,024–1/65,536: 200 iterations without convergence on 6 of 12 simulated data
/// sets, where OPT2 from the start converged on 11. Handed over at the first such cut,
/// OLS ends at OPT2's minimum on those 11 (`cli/tests/cli.rs`, near-axis data). The
/// fingerprinted fits (ARIA's 94, MUKCa's eleven Pandas) never reach it (bit for bit the
/// same), and the real-data tests pass unchanged.
const CRAWL_SCALE: f64 = 1.0 / 16.0;

/// Halvings of a rejected Gauss–Newton step after which [`gauss_newton`] also tries the
/// damped step of each length: up to here it is plain step halving (the real fits that
/// converge well take at least 1/64 of the step: TALOS, UR10e), beyond it the direction is
/// dominated by a weakly determined combination (MUKCa's `panda_6`: 1/4096–1/16384).
const DAMPED_AFTER: u32 = 6;

/// The Gauss–Newton step (unscaled) into `ws.step`, from the scaled normal equations kept
/// in `ws.v`, `ws.tmp` (Cholesky), or, when they are numerically singular, from the SVD of
/// the Givens factor at `robot` (accumulated here into `ws.lsq`). Returns whether the
/// Givens factor was used (then [`gauss_newton_direction`] recomputes the step from it).
fn gauss_newton_step<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    robot: &Robot<N>,
    data: &D,
    opts: &IdentifyOptions<'_>,
    n: usize,
    ws: &mut Workspace<P>,
) -> Result<bool> {
    if damped_step(ws, n, 0.0).is_ok() {
        return Ok(false);
    }
    accumulate(robot, data, opts, n, ws)?;
    gauss_newton_direction(ws, n, true)?;
    Ok(true)
}

/// The Gauss–Newton step of the current iterate into `ws.step` again (a trial's fold has
/// overwritten `ws.gram`, not `ws.v`, `ws.tmp` or the Givens factor `ws.lsq`).
fn gauss_newton_direction<const P: usize>(
    ws: &mut Workspace<P>,
    n: usize,
    singular: bool,
) -> Result<()> {
    if !singular {
        return damped_step(ws, n, 0.0);
    }
    let Workspace {
        lsq,
        step,
        svd,
        colscale,
        ..
    } = ws;
    min_norm_solve(lsq.r(), n, &lsq.qtb()[..n], None, &mut step[..n], svd)?;
    for k in 0..n {
        step[k] *= colscale[k];
    }
    Ok(())
}

/// The cost reduction the linearised model predicts for the step in `ws.step`,
/// `2gᵀδ − δᵀGδ`, from the scaled normal equations [`keep_scaled_normal_equations`] kept
/// (`s = D·δ`: `2·tmpᵀs − sᵀ·v·s`); 0 or less for a step that does not descend.
fn model_gain<const P: usize>(ws: &Workspace<P>, n: usize) -> f64 {
    let mut gain = 0.0;
    for a in 0..n {
        let sa = ws.diag[a] * ws.step[a];
        gain += 2.0 * ws.tmp[a] * sa - ws.v[a][a] * sa * sa;
        for b in a + 1..n {
            gain -= 2.0 * ws.v[a][b] * sa * ws.diag[b] * ws.step[b];
        }
    }
    gain
}

/// A rejected full Gauss–Newton step whose predicted gain is below this many `ftol`
/// (relative to the cost) ends [`gauss_newton`]: the cost cannot be lowered above its own
/// rounding (sums of thousands of squares vary by some `1e-14` relative between
/// evaluations), and searching shorter steps would cost up to 60 evaluations for nothing.
const ROUNDING_GAIN: f64 = 100.0;

/// The damped step ([`damped_step`]) whose scaled length `|D·δ|` is within 10 % of `delta`
/// (bisection on `log λ`; the length falls as `λ` grows), or the nearest the bisection
/// finds, into `ws.step`. A `λ` too small to factor (singular normal equations) counts as
/// too long a step. Returns false when no damped matrix could be factored.
fn step_of_length<const P: usize>(ws: &mut Workspace<P>, n: usize, delta: f64) -> bool {
    let (mut lo, mut hi) = (-16.0f64, 16.0f64);
    // The exponent of the last λ that could be factored, and whether `ws.step` is its step.
    let (mut good, mut in_step) = (None, false);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if damped_step(ws, n, libm::pow(10.0, mid)).is_err() {
            lo = mid;
            in_step = false;
            continue;
        }
        (good, in_step) = (Some(mid), true);
        let len = scaled_norm(ws, n, &ws.step);
        if (len - delta).abs() <= 0.1 * delta {
            break;
        }
        if len > delta {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    match good {
        Some(e) if !in_step => damped_step(ws, n, libm::pow(10.0, e)).is_ok(),
        Some(_) => true,
        None => false,
    }
}

/// Copies the column-scaled normal equations `D⁻¹GD⁻¹` (upper triangle) into `ws.v` and
/// `D⁻¹Jᵀe` into `ws.tmp` (`D = ws.diag`): a rejected trial overwrites `ws.gram`, and the
/// damped steps that follow are solved from these.
fn keep_scaled_normal_equations<const P: usize>(ws: &mut Workspace<P>, n: usize) {
    let Workspace {
        gram,
        colscale,
        v,
        tmp,
        ..
    } = ws;
    let g = gram.gram();
    for a in 0..n {
        for b in a..n {
            v[a][b] = g[a][b] * colscale[a] * colscale[b];
        }
        tmp[a] = gram.atb()[a] * colscale[a];
    }
}

/// The damped step `(D⁻¹GD⁻¹ + λI)⁻¹D⁻¹Jᵀe`, unscaled (`D⁻¹·`), into `ws.step`, from the
/// matrices [`keep_scaled_normal_equations`] kept. Errors: the damped matrix is singular.
fn damped_step<const P: usize>(ws: &mut Workspace<P>, n: usize, lambda: f64) -> Result<()> {
    let Workspace {
        v,
        tmp,
        mat,
        step,
        diag,
        ..
    } = ws;
    for a in 0..n {
        mat[a][..a].fill(0.0);
        for b in a..n {
            mat[a][b] = v[a][b] + if a == b { lambda } else { 0.0 };
        }
    }
    crate::linalg::gram::cholesky_upper_in_place(mat, n, 1e-14)?;
    step[..n].copy_from_slice(&tmp[..n]);
    solve_normal(mat, n, &mut step[..n])?;
    // Times the reciprocal, not divided: the same rounding as the column scales `1/D`.
    for k in 0..n {
        step[k] *= 1.0 / diag[k];
    }
    Ok(())
}

/// OPT2: MINPACK `lmder` — trust region on the scaled step, λ from `lmpar` — on the
/// triangular factor of the normal equations (Givens factor if they are singular).
fn levenberg_marquardt<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    robot: &mut Robot<N>,
    data: &D,
    opts: &IdentifyOptions<'_>,
    n: usize,
    ws: &mut Workspace<P>,
) -> Result<Finish> {
    const FACTOR: f64 = 100.0;
    let mut delta = 0.0;
    let mut lambda = 0.0;
    for k in 0..n {
        ws.diag[k] = 0.0;
    }
    let mut trial = *robot;
    for it in 0..opts.max_iterations {
        get_x(robot, n, ws)?;
        unit_scale(ws, n);
        let fnorm2 = first_gram(robot, data, opts, n, ws)?;
        if fnorm2 <= opts.abs_cost_tol {
            return Ok(Finish::current(it));
        }
        if factor_gram(ws, n, GramSel::All).is_ok() {
            // qtb = R⁻ᵀ·Jᵀe, so that RᵀR x = Rᵀ qtb is the Gauss–Newton system.
            let Workspace { gram, tmp, mat, .. } = ws;
            tmp.copy_from_slice(gram.atb());
            solve_upper_transpose(mat, n, &mut tmp[..n])?;
        } else {
            accumulate(robot, data, opts, n, ws)?;
            // Row by row: a whole P×P copy would land on the stack.
            let Workspace { lsq, tmp, mat, .. } = ws;
            mat[..n].copy_from_slice(&lsq.r()[..n]);
            tmp.copy_from_slice(lsq.qtb());
        }
        // MINPACK scaling: D_k = max over iterations of the column norms.
        for k in 0..n {
            let cn = sqrt(ws.gram.gram()[k][k]);
            ws.diag[k] = ws.diag[k].max(if cn > 0.0 { cn } else { 1.0 });
        }
        let xnorm = scaled_norm(ws, n, &ws.x);
        if it == 0 {
            delta = if xnorm > 0.0 { FACTOR * xnorm } else { FACTOR };
        }
        let fnorm = sqrt(fnorm2);
        loop {
            let Workspace {
                mat,
                diag,
                step,
                tmp,
                damped,
                ..
            } = ws;
            lambda = lm_parameter(
                mat,
                n,
                &diag[..n],
                &tmp[..n],
                delta,
                lambda,
                &mut step[..n],
                damped,
            )?;
            let pnorm = scaled_norm(ws, n, &ws.step);
            if it == 0 {
                delta = delta.min(pnorm);
            }
            apply(&mut trial, n, ws, None)?;
            let fnorm1 = sqrt(data.cost_ws(&trial, opts, ws)?);
            let actred = if 0.1 * fnorm1 < fnorm {
                1.0 - (fnorm1 / fnorm) * (fnorm1 / fnorm)
            } else {
                -1.0
            };
            // |J p| = |R p|.
            let mut jp2 = 0.0;
            for i in 0..n {
                let s: f64 = (i..n).map(|j| ws.mat[i][j] * ws.step[j]).sum();
                jp2 += s * s;
            }
            let temp1 = sqrt(jp2) / fnorm;
            let temp2 = sqrt(lambda) * pnorm / fnorm;
            let prered = temp1 * temp1 + 2.0 * temp2 * temp2;
            let dirder = -(temp1 * temp1 + temp2 * temp2);
            let ratio = if prered != 0.0 { actred / prered } else { 0.0 };
            // A trial whose reduction cannot be measured (an overflowed step or cost makes
            // the ratio NaN) is a failed step: with a NaN ratio MINPACK's update keeps δ and
            // λ and tries the same step again, forever (a fuzzed OPT2 fit hung so). The
            // shrink factor is then 0.1, so δ falls below the stop tests in a bounded number
            // of trials. Finite ratios and factors are unchanged.
            let ratio = if ratio.is_nan() { 0.0 } else { ratio };
            if ratio <= 0.25 {
                let mut temp = if actred >= 0.0 {
                    0.5
                } else {
                    0.5 * dirder / (dirder + 0.5 * actred)
                };
                if 0.1 * fnorm1 >= fnorm || temp < 0.1 || temp.is_nan() {
                    temp = 0.1;
                }
                delta = temp * delta.min(pnorm / 0.1);
                lambda /= temp;
            } else if lambda == 0.0 || ratio >= 0.75 {
                delta = pnorm / 0.5;
                lambda *= 0.5;
            }
            let accepted = ratio >= 1e-4;
            if accepted {
                *robot = trial;
            }
            let xnorm_new = scaled_norm(ws, n, &ws.x);
            if (actred.abs() <= opts.ftol && prered <= opts.ftol && 0.5 * ratio <= 1.0)
                || delta <= opts.xtol * xnorm_new
                || fnorm1 * fnorm1 <= opts.abs_cost_tol
            {
                return Ok(Finish {
                    iterations: it + 1,
                    gram_current: !accepted,
                });
            }
            if accepted {
                break;
            }
            if !delta.is_finite() || delta < f64::MIN_POSITIVE {
                return Err(Error::NotConverged { iterations: it + 1 });
            }
        }
    }
    Err(Error::NotConverged {
        iterations: opts.max_iterations,
    })
}

/// OPT1: projected Levenberg–Marquardt with an active set. Parameters on a bound whose
/// descent direction points outwards are held; the damped step of the others is clipped to
/// the box; λ shrinks after a successful step and grows after a failed one.
fn bounded<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    robot: &mut Robot<N>,
    data: &D,
    opts: &IdentifyOptions<'_>,
    n: usize,
    ws: &mut Workspace<P>,
) -> Result<Finish> {
    let Some(b) = opts.bounds else {
        return Err(Error::InvalidParameter {
            index: 0,
            value: f64::NAN,
        });
    };
    get_x(robot, n, ws)?;
    for k in 0..n {
        let i = ws.cols[k];
        let (lo, hi) = (b.lower[i], b.upper[i]);
        if lo.is_nan() || hi.is_nan() || lo > hi || ws.x[k] < lo || ws.x[k] > hi {
            return Err(Error::InvalidParameter {
                index: i,
                value: ws.x[k],
            });
        }
    }
    let mut lambda = 1e-3;
    let mut trial = *robot;
    for it in 0..opts.max_iterations {
        get_x(robot, n, ws)?;
        unit_scale(ws, n);
        let c = first_gram(robot, data, opts, n, ws)?;
        if c <= opts.abs_cost_tol {
            return Ok(Finish::current(it));
        }
        // Descent direction of the cost along each parameter: Jᵀe.
        let mut nf = 0;
        for k in 0..n {
            let i = ws.cols[k];
            let gk = ws.gram.atb()[k];
            let held = (ws.x[k] <= b.lower[i] && gk < 0.0) || (ws.x[k] >= b.upper[i] && gk > 0.0);
            let d = sqrt(ws.gram.gram()[k][k]);
            ws.diag[k] = if d > 0.0 { d } else { 1.0 };
            if !held {
                ws.free[nf] = k;
                nf += 1;
            }
        }
        if nf == 0 {
            return Ok(Finish::current(it));
        }
        let mut improved = false;
        for _ in 0..40 {
            for f in 0..nf {
                ws.row[f] = ws.diag[ws.free[f]];
            }
            if factor_gram(ws, nf, GramSel::FreeDamped(lambda)).is_ok() {
                // The damped step of the free parameters, in `tmp`.
                let Workspace {
                    gram,
                    free,
                    tmp,
                    mat,
                    step,
                    x,
                    cols,
                    ..
                } = &mut *ws;
                for f in 0..nf {
                    tmp[f] = gram.atb()[free[f]];
                }
                solve_normal(mat, nf, &mut tmp[..nf])?;
                for k in 0..n {
                    step[k] = 0.0;
                }
                for f in 0..nf {
                    let k = free[f];
                    let i = cols[k];
                    let target = (x[k] + tmp[f]).clamp(b.lower[i], b.upper[i]);
                    step[k] = target - x[k];
                }
                apply(&mut trial, n, ws, Some(b))?;
                let c2 = data.cost_ws(&trial, opts, ws)?;
                if c2 < c {
                    let dx = scaled_norm(ws, n, &ws.step);
                    let xn = scaled_norm(ws, n, &ws.x);
                    *robot = trial;
                    lambda = (lambda / 3.0).max(1e-15);
                    improved = true;
                    if dx <= opts.xtol * (xn + opts.xtol) || (c - c2) <= opts.ftol * c {
                        return Ok(Finish {
                            iterations: it + 1,
                            gram_current: false,
                        });
                    }
                    break;
                }
            }
            lambda *= 4.0;
            if lambda > 1e16 {
                break;
            }
        }
        if !improved {
            // No descent inside the box: a constrained minimum to rounding.
            return Ok(Finish::current(it));
        }
    }
    Err(Error::NotConverged {
        iterations: opts.max_iterations,
    })
}

/// σ² of a fit with a prior, from the inverse `ws.v` of its normal equations (unit-scaled):
/// the data's cost over `rows − n_eff`, where `rows` are the data rows and
/// `n_eff = n − tr(A⁻¹·P)` (`A` the normal matrix with the prior, `P` its prior part) is the
/// number of parameters the data determine: `n` for a vanishing prior (today's σ²), 0 for
/// an infinitely strong one. Unbiased when the truth is drawn from the prior
/// (`E[data cost] = s²·(rows − n_eff)`, as for ridge regression). `c` is the total cost,
/// `rows_all` the data and prior rows.
fn posterior_sigma2<const N: usize, const P: usize>(
    prior: &super::Prior,
    robot: &Robot<N>,
    c: f64,
    rows_all: usize,
    n: usize,
    ws: &Workspace<P>,
) -> Result<f64> {
    let (mut prior_cost, mut trace, mut prior_rows) = (0.0, 0.0, 0usize);
    for k in 0..n.min(P) {
        let i = ws.cols[k];
        let w = prior.weight(i);
        if w == 0.0 {
            continue;
        }
        let e = prior.center.get(i).copied().unwrap_or(0.0) - robot.param(ParamIndex(i))?;
        prior_cost += w * e * e;
        trace += w * ws.v[k][k];
        prior_rows += 1;
    }
    let data_rows = rows_all.saturating_sub(prior_rows);
    if prior_rows == 0 {
        return Ok(if data_rows > n {
            c / (data_rows - n) as f64
        } else {
            0.0
        });
    }
    let dof = data_rows as f64 - (n as f64 - trace);
    Ok(if dof > 0.0 {
        (c - prior_cost).max(0.0) / dof
    } else {
        0.0
    })
}

/// The normal equations at the fitted model, factored by [`normal_factor_at_fit`].
#[derive(Clone, Copy)]
struct NormalFactor {
    /// The cost at the fitted model.
    cost: f64,
    /// Whether `ws.mat` holds their Cholesky factor (they are not numerically singular).
    factored: bool,
}

/// Factors the normal equations at the fitted model `robot` into `ws.mat`: for the check at
/// the fit ([`all_kept_by_factor`]) and the covariance. With `gram_current` (see
/// [`Finish`]) the normal equations the solver left are used as they are; otherwise they
/// are accumulated at the fitted model.
fn normal_factor_at_fit<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    robot: &Robot<N>,
    data: &D,
    opts: &IdentifyOptions<'_>,
    n: usize,
    gram_current: bool,
    ws: &mut Workspace<P>,
) -> Result<NormalFactor> {
    unit_scale(ws, n);
    // `btb` is the cost accumulated the same way, term for term, as `accumulate_gram`'s.
    let cost = if gram_current && ws.gram.n() == n {
        ws.gram.btb()
    } else {
        accumulate_gram(robot, data, opts, n, ws)?
    };
    Ok(NormalFactor {
        cost,
        factored: factor_gram(ws, n, GramSel::All).is_ok(),
    })
}

/// σ², standard errors and strong correlations at the fitted model `out.robot`, from the
/// factor [`normal_factor_at_fit`] left.
fn covariance<const N: usize, const P: usize, D: RowSource<N> + ?Sized>(
    data: &D,
    opts: &IdentifyOptions<'_>,
    n: usize,
    rows: usize,
    factor: NormalFactor,
    ws: &mut Workspace<P>,
    out: &mut Identification<N>,
) -> Result<()> {
    let robot = &out.robot;
    let c = factor.cost;
    out.sigma2 = if rows > n { c / (rows - n) as f64 } else { 0.0 };
    // Covariance (RᵀR)⁻¹ from the normal equations (2–3 digits suffice for standard
    // errors); the backward-stable Givens factor when they are numerically singular. The
    // inverse goes to `ws.v`, read straight from the factor.
    let inverted = if factor.factored {
        let Workspace { mat, v, .. } = ws;
        upper_inverse_gram(mat, n, v)
    } else {
        accumulate(robot, data, opts, n, ws)?;
        let Workspace { lsq, v, .. } = ws;
        upper_inverse_gram(lsq.r(), n, v)
    };
    if inverted.is_err() {
        // Identifiable at the start but singular at the optimum: report no errors.
        return Ok(());
    }
    if let Some(prior) = data.prior() {
        out.sigma2 = posterior_sigma2(prior, robot, c, rows, n, ws)?;
    }
    let cov = &ws.v;
    for k in 0..n {
        let var = (out.sigma2 * cov[k][k]).max(0.0);
        if let Some(s) = out.std_errors.get_mut(ws.cols[k]) {
            *s = sqrt(var);
        }
    }
    for a in 0..n {
        for b in (a + 1)..n {
            let d = sqrt(cov[a][a] * cov[b][b]);
            if d <= 0.0 {
                continue;
            }
            let rho = cov[a][b] / d;
            if rho.abs() > CORRELATION_REPORT_THRESHOLD {
                if let Some(slot) = out.correlated.get_mut(out.n_correlated) {
                    *slot = Correlation {
                        a: ParamIndex(ws.cols[a]),
                        b: ParamIndex(ws.cols[b]),
                        rho,
                    };
                }
                out.n_correlated += 1;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use core::f64::consts::TAU;

    /// Link angles a whole number of turns from their start come back within half a turn,
    /// the same model (FK equal to rounding); an angle within half a turn, a length and a
    /// frame angle are left bit for bit.
    #[test]
    #[allow(clippy::unwrap_used)]
    fn link_angles_come_back_by_whole_turns() {
        let start = crate::aria::nominal();
        let theta0_2 = 5; // link 1's θ0
        let beta_2 = 9; // link 1's β
        let alpha_3 = 13; // link 2's α
        let d_1 = 1;
        let base_rx = 5 * 6 + 3; // a base-frame rotation parameter
        let cols = [d_1, theta0_2, beta_2, alpha_3, base_rx];
        let starts: std::vec::Vec<f64> = cols
            .iter()
            .map(|&i| start.param(ParamIndex(i)).unwrap())
            .collect();
        let mut fitted = start;
        let moved = [10.0, TAU + 0.1, 3.0, -2.0 * TAU - 0.2, TAU + 0.3];
        for ((&i, &s), &m) in cols.iter().zip(&starts).zip(&moved) {
            fitted.set_param(ParamIndex(i), s + m).unwrap();
        }
        let before = fitted;
        wrap_link_angles(&mut fitted, &cols, &starts).unwrap();
        let got: std::vec::Vec<f64> = cols
            .iter()
            .map(|&i| fitted.param(ParamIndex(i)).unwrap())
            .collect();
        assert_eq!(got[0].to_bits(), (starts[0] + 10.0).to_bits());
        assert!((got[1] - (starts[1] + 0.1)).abs() < 1e-12, "{}", got[1]);
        assert_eq!(got[2].to_bits(), (starts[2] + 3.0).to_bits());
        assert!((got[3] - (starts[3] - 0.2)).abs() < 1e-12, "{}", got[3]);
        assert_eq!(got[4].to_bits(), (starts[4] + TAU + 0.3).to_bits());
        let mut rng = crate::rng::SplitMix64::new(3);
        for _ in 0..20 {
            let q: [f64; 6] = core::array::from_fn(|_| rng.range(-3.0, 3.0));
            let (a, b) = (before.fk_q(&q).unwrap(), fitted.fk_q(&q).unwrap());
            assert!((a.translation.vector - b.translation.vector).norm() < 1e-12);
            assert!((a.rotation.matrix() - b.rotation.matrix()).norm() < 1e-12);
        }
    }
}
