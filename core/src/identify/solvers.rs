//! The three identification algorithms on the identifiable parameter set, and the
//! parameter covariance of the result.

use super::data::{accumulate, accumulate_gram, cost, residual_stats, validate};
use super::{
    Algorithm, CORRELATION_REPORT_THRESHOLD, Correlation, Identification, IdentifyOptions,
    MAX_CORRELATED_PAIRS, MAX_MODEL_PARAMS, Workspace, analyze,
};
use crate::effects::Effect;
use crate::error::{Error, ParamIndex, Quantity, Result, check_finite};
use crate::linalg::lm::lm_parameter;
use crate::linalg::minnorm::min_norm_solve;
use crate::linalg::tri::{solve_upper, solve_upper_transpose, upper_inverse_gram};
use crate::math::sqrt;
use crate::model::Robot;
use crate::params::{ParamId, ParamSet};

/// Identifies the identifiable subset of `opts.requested` from `data`, starting at `robot`.
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
    validate(data)?;
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
    check_inputs(data, opts)?;
    let analysis = analyze(robot, data, opts, ws)?;
    identify_with_analysis(robot, data, opts, &analysis, ws)
}

/// As [`identify`] with the identifiability analysis already done (by [`analyze`] on the
/// same kind of data: same requested parameters, components and auxiliary inputs), e.g.
/// once per design in a Monte-Carlo study. Only `analysis.identifiable` is fitted.
pub fn identify_with_analysis<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
    analysis: &super::Identifiability,
    ws: &mut Workspace<P>,
) -> Result<Identification<N>> {
    validate(data)?;
    check_inputs(data, opts)?;
    let analysis = *analysis;
    let n = analysis.rank;
    if n > P || analysis.identifiable.len() != n {
        return Err(Error::CapacityExceeded {
            needed: analysis.identifiable.len(),
            capacity: P,
        });
    }
    let rows: usize = data
        .iter()
        .filter(|m| m.weight > 0.0)
        .map(|m| (0..6).filter(|&k| m.mask.has(k)).count())
        .sum();
    if n == 0 || (!analysis.data_deficient.is_empty() && !opts.allow_data_deficiency) {
        return Err(Error::RankDeficient {
            rank: n,
            required: analysis.requested.len() - analysis.structural.len(),
        });
    }
    if rows < n {
        return Err(Error::TooFewData {
            found: rows,
            needed: n,
        });
    }
    let initial = residual_stats(robot, data, opts)?;
    let mut fit = *robot;
    for (k, i) in analysis.identifiable.iter().enumerate() {
        ws.cols[k] = i;
    }
    let iterations = match opts.algorithm {
        Algorithm::Ols => gauss_newton(&mut fit, data, opts, n, ws)?,
        Algorithm::Opt2 => levenberg_marquardt(&mut fit, data, opts, n, ws)?,
        Algorithm::Opt1 => bounded(&mut fit, data, opts, n, ws)?,
    };
    let fitted = residual_stats(&fit, data, opts)?;
    let mut out = Identification {
        robot: fit,
        algorithm: opts.algorithm,
        analysis,
        iterations,
        initial,
        fitted,
        sigma2: 0.0,
        std_errors: [0.0; MAX_MODEL_PARAMS],
        at_bound: ParamSet::new(),
        correlated: [Correlation {
            a: ParamIndex(0),
            b: ParamIndex(0),
            rho: 0.0,
        }; MAX_CORRELATED_PAIRS],
        n_correlated: 0,
    };
    if let (Algorithm::Opt1, Some(b)) = (opts.algorithm, opts.bounds) {
        for k in 0..n {
            let i = ws.cols[k];
            let v = fit.param(ParamIndex(i))?;
            if v <= b.lower[i] || v >= b.upper[i] {
                out.at_bound.insert(i)?;
            }
        }
    }
    if opts.covariance {
        covariance(&fit, data, opts, n, rows, ws, &mut out)?;
    }
    Ok(out)
}

use super::data::Measurement;

/// Refuses effects whose inputs the data lack.
fn check_inputs<const N: usize>(data: &[Measurement<N>], opts: &IdentifyOptions<'_>) -> Result<()> {
    let has = |e: Effect| {
        opts.requested
            .iter()
            .any(|i| ParamId::from_index(ParamIndex(i), N).is_ok_and(|id| id.effect() == Some(e)))
    };
    if has(Effect::Backlash) && data.iter().any(|m| m.state.approach.is_none()) {
        return Err(Error::MissingInput {
            what: Quantity::ApproachDirection,
        });
    }
    if has(Effect::Thermal) && data.iter().any(|m| m.state.temp_c.is_none()) {
        return Err(Error::MissingInput {
            what: Quantity::Temperature,
        });
    }
    if opts.algorithm == Algorithm::Opt1 && opts.bounds.is_none() {
        return Err(Error::InvalidParameter {
            index: 0,
            value: f64::NAN,
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

/// `robot` with the fitted parameters set to `x + step` (clipped to `bounds` when given, so
/// a parameter moved onto a bound sits exactly on it).
fn apply<const N: usize, const P: usize>(
    robot: &Robot<N>,
    n: usize,
    ws: &Workspace<P>,
    bounds: Option<&super::Bounds>,
) -> Result<Robot<N>> {
    let mut r = *robot;
    for k in 0..n {
        let i = ws.cols[k];
        let mut v = ws.x[k] + ws.step[k];
        if let Some(b) = bounds {
            v = v.clamp(b.lower[i], b.upper[i]);
        }
        r.set_param(ParamIndex(i), v)?;
    }
    Ok(r)
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

/// Cholesky factor of the (optionally damped, optionally column-scaled) Gram matrix of the
/// columns `sel` into `ws.mat`: `A = D⁻¹·G[sel,sel]·D⁻¹ + λ·E²` with `D = scale`.
fn factor_gram<const P: usize>(
    ws: &mut Workspace<P>,
    sel: &[usize],
    inv_scale: Option<&[f64]>,
    damping: Option<(f64, &[f64])>,
) -> Result<()> {
    let m = sel.len();
    let g = ws.gram.gram();
    for a in 0..m {
        for b in a..m {
            let (i, j) = (sel[a].min(sel[b]), sel[a].max(sel[b]));
            let mut v = g[i][j];
            if let Some(s) = inv_scale {
                v *= s[a] * s[b];
            }
            if let (true, Some((lambda, d))) = (a == b, damping) {
                v += lambda * d[a] * d[a];
            }
            ws.v[a][b] = v;
        }
    }
    crate::linalg::gram::cholesky_upper(&ws.v, m, 1e-14, &mut ws.mat)
}

/// Solves `RᵀR·x = rhs` with `R = ws.mat` in place in `x`.
fn solve_normal<const P: usize>(ws: &Workspace<P>, n: usize, x: &mut [f64]) -> Result<()> {
    solve_upper_transpose(&ws.mat, n, x)?;
    solve_upper(&ws.mat, n, x)
}

/// OLS: Gauss–Newton with the minimum-norm least-squares step (as `lsqminnorm`) on
/// unit-scaled columns, halving the step up to 30 times when the cost rises. The step comes
/// from the Cholesky factor of the scaled normal equations — for the full-rank identifiable
/// set that is the unique, hence minimum-norm, solution — and from the SVD of the Givens
/// factor when the normal equations are numerically singular at an iterate.
///
/// A trial point is evaluated by accumulating its normal equations (Jacobian and residual
/// in one pass): an accepted trial's cost and normal equations are those the next
/// iteration needs, so each iteration costs one Jacobian pass instead of a Jacobian pass
/// plus a cost pass.
fn gauss_newton<const N: usize, const P: usize>(
    robot: &mut Robot<N>,
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
    n: usize,
    ws: &mut Workspace<P>,
) -> Result<u32> {
    unit_scale(ws, n);
    let mut c = accumulate_gram(robot, data, opts, n, ws)?;
    for it in 0..opts.max_iterations {
        get_x(robot, n, ws)?;
        if c <= opts.abs_cost_tol {
            return Ok(it);
        }
        for k in 0..n {
            let d = sqrt(ws.gram.gram()[k][k]);
            ws.diag[k] = if d > 0.0 { d } else { 1.0 };
            ws.colscale[k] = 1.0 / ws.diag[k];
            ws.free[k] = k;
        }
        let (sel, inv) = (ws.free, ws.colscale);
        if factor_gram(ws, &sel[..n], Some(&inv[..n]), None).is_ok() {
            for k in 0..n {
                ws.step[k] = ws.gram.atb()[k] * ws.colscale[k];
            }
            let mut z = ws.step;
            solve_normal(ws, n, &mut z[..n])?;
            ws.step = z;
        } else {
            accumulate(robot, data, opts, n, ws)?;
            let Workspace { lsq, step, svd, .. } = ws;
            min_norm_solve(lsq.r(), n, &lsq.qtb()[..n], None, &mut step[..n], svd)?;
        }
        for k in 0..n {
            ws.step[k] *= ws.colscale[k];
        }
        let dx = scaled_norm(ws, n, &ws.step);
        let xn = scaled_norm(ws, n, &ws.x);
        unit_scale(ws, n);
        // A full step this small ends the iteration once accepted: its cost suffices, its
        // normal equations would never be used.
        let last = dx <= opts.xtol * (xn + opts.xtol);
        let mut accepted = None;
        for _ in 0..30 {
            let trial = apply(robot, n, ws, None)?;
            let c2 = if last {
                cost(&trial, data, opts)?
            } else {
                accumulate_gram(&trial, data, opts, n, ws)?
            };
            if c2 <= c {
                accepted = Some((trial, c2));
                break;
            }
            for k in 0..n {
                ws.step[k] *= 0.5;
            }
        }
        let Some((trial, c2)) = accepted else {
            // No decrease along the Gauss–Newton direction: at a minimum to rounding.
            return Ok(it);
        };
        *robot = trial;
        if dx <= opts.xtol * (xn + opts.xtol) || (c - c2) <= opts.ftol * c {
            return Ok(it + 1);
        }
        c = c2;
    }
    Err(Error::NotConverged {
        iterations: opts.max_iterations,
    })
}

/// OPT2: MINPACK `lmder` — trust region on the scaled step, λ from `lmpar` — on the
/// triangular factor of the normal equations (Givens factor if they are singular).
fn levenberg_marquardt<const N: usize, const P: usize>(
    robot: &mut Robot<N>,
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
    n: usize,
    ws: &mut Workspace<P>,
) -> Result<u32> {
    const FACTOR: f64 = 100.0;
    let mut delta = 0.0;
    let mut lambda = 0.0;
    for k in 0..n {
        ws.diag[k] = 0.0;
        ws.free[k] = k;
    }
    for it in 0..opts.max_iterations {
        get_x(robot, n, ws)?;
        unit_scale(ws, n);
        let fnorm2 = accumulate_gram(robot, data, opts, n, ws)?;
        if fnorm2 <= opts.abs_cost_tol {
            return Ok(it);
        }
        let sel = ws.free;
        if factor_gram(ws, &sel[..n], None, None).is_ok() {
            // qtb = R⁻ᵀ·Jᵀe, so that RᵀR x = Rᵀ qtb is the Gauss–Newton system.
            let mut q = *ws.gram.atb();
            solve_upper_transpose(&ws.mat, n, &mut q[..n])?;
            ws.tmp = q;
        } else {
            accumulate(robot, data, opts, n, ws)?;
            // Row by row: a whole P×P copy would land on the stack.
            for i in 0..n {
                ws.mat[i] = ws.lsq.r()[i];
            }
            ws.tmp = *ws.lsq.qtb();
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
            let trial = apply(robot, n, ws, None)?;
            let fnorm1 = sqrt(cost(&trial, data, opts)?);
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
            if ratio <= 0.25 {
                let mut temp = if actred >= 0.0 {
                    0.5
                } else {
                    0.5 * dirder / (dirder + 0.5 * actred)
                };
                if 0.1 * fnorm1 >= fnorm || temp < 0.1 {
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
                return Ok(it + 1);
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
fn bounded<const N: usize, const P: usize>(
    robot: &mut Robot<N>,
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
    n: usize,
    ws: &mut Workspace<P>,
) -> Result<u32> {
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
    for it in 0..opts.max_iterations {
        get_x(robot, n, ws)?;
        unit_scale(ws, n);
        let c = accumulate_gram(robot, data, opts, n, ws)?;
        if c <= opts.abs_cost_tol {
            return Ok(it);
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
            return Ok(it);
        }
        let mut improved = false;
        for _ in 0..40 {
            let sel = ws.free;
            for f in 0..nf {
                ws.row[f] = ws.diag[sel[f]];
            }
            let d = ws.row;
            if factor_gram(ws, &sel[..nf], None, Some((lambda, &d[..nf]))).is_ok() {
                let mut z = [0.0; P];
                for f in 0..nf {
                    z[f] = ws.gram.atb()[sel[f]];
                }
                solve_normal(ws, nf, &mut z[..nf])?;
                for k in 0..n {
                    ws.step[k] = 0.0;
                }
                for f in 0..nf {
                    let k = sel[f];
                    let i = ws.cols[k];
                    let target = (ws.x[k] + z[f]).clamp(b.lower[i], b.upper[i]);
                    ws.step[k] = target - ws.x[k];
                }
                let trial = apply(robot, n, ws, Some(b))?;
                let c2 = cost(&trial, data, opts)?;
                if c2 < c {
                    let dx = scaled_norm(ws, n, &ws.step);
                    let xn = scaled_norm(ws, n, &ws.x);
                    *robot = trial;
                    lambda = (lambda / 3.0).max(1e-15);
                    improved = true;
                    if dx <= opts.xtol * (xn + opts.xtol) || (c - c2) <= opts.ftol * c {
                        return Ok(it + 1);
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
            return Ok(it);
        }
    }
    Err(Error::NotConverged {
        iterations: opts.max_iterations,
    })
}

/// σ², standard errors and strong correlations at the fitted model.
fn covariance<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    opts: &IdentifyOptions<'_>,
    n: usize,
    rows: usize,
    ws: &mut Workspace<P>,
    out: &mut Identification<N>,
) -> Result<()> {
    unit_scale(ws, n);
    let c = accumulate_gram(robot, data, opts, n, ws)?;
    out.sigma2 = if rows > n { c / (rows - n) as f64 } else { 0.0 };
    for k in 0..n {
        ws.free[k] = k;
    }
    let sel = ws.free;
    // Covariance (RᵀR)⁻¹ from the normal equations (2–3 digits suffice for standard
    // errors); the backward-stable Givens factor when they are numerically singular.
    if factor_gram(ws, &sel[..n], None, None).is_err() {
        accumulate(robot, data, opts, n, ws)?;
        for i in 0..n {
            ws.v[i] = ws.lsq.r()[i];
        }
    } else {
        for i in 0..n {
            ws.v[i] = ws.mat[i];
        }
    }
    let Workspace { v, mat, .. } = ws;
    if upper_inverse_gram(v, n, mat).is_err() {
        // Identifiable at the start but singular at the optimum: report no errors.
        return Ok(());
    }
    for k in 0..n {
        let var = (out.sigma2 * ws.mat[k][k]).max(0.0);
        if let Some(s) = out.std_errors.get_mut(ws.cols[k]) {
            *s = sqrt(var);
        }
    }
    for a in 0..n {
        for b in (a + 1)..n {
            let d = sqrt(ws.mat[a][a] * ws.mat[b][b]);
            if d <= 0.0 {
                continue;
            }
            let rho = ws.mat[a][b] / d;
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
