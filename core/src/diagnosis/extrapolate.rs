//! "Does the verdict's model predict where it was not fitted?": the extrapolation check
//! that keeps a flexible candidate from being called `explained` when it only absorbs an
//! effect outside the library.
//!
//! # Why this check
//! Random cross-validation folds hold out poses *inside* the joint-space region the other
//! folds cover. A flexible candidate (`joint_cyclic`: four terms per joint, i.e. on the
//! narrow joint ranges of a working region nearly a quartic polynomial in every joint) can
//! then interpolate a smooth effect of another form — a third harmonic, a wobbling axis —
//! to within the noise: it closes 90–99 % of the held-out gap, its remaining gap is not
//! significant and no smooth function of q finds structure in what it leaves. The
//! difference between the right form and such a surrogate shows only outside the range
//! the parameters were fitted on: a model of the right form predicts there (up to its
//! larger estimation error), a surrogate's error grows with the distance from its
//! training range.
//!
//! # Method: leave-one-range-out, Chow's predictive test
//! For every joint `j` the clean rows are split at the median of `q_j` into a lower and an
//! upper half (repeats share their joint readings, so a pose group never straddles). The
//! verdict's model is fitted (linearised at the verdict's fit on all rows, as in the
//! cross-validation, `cv.rs`) on one half, and its prediction of the other half is tested,
//! both ways: `2N` splits. A split is skipped when either half has fewer than
//! [`super::Config::min_groups_per_fold`] distinct joint states or when the training half
//! does not determine every parameter of the model (it would predict with a smaller
//! model).
//!
//! The test is Chow's (1960) test of predictive failure: with `RSS_T` the whitened
//! residual sum of squares of the fit on the training half (`n_T` rows, `p` parameters)
//! and `RSS` that of the fit on all rows, the increase `ΔRSS = RSS − RSS_T` equals
//! `rᵀ(I + H)⁻¹r`, `r` the `m` held-out rows' prediction errors and `I + H` their
//! covariance under the model (`H = J_h·(J_TᵀJ_T)⁻¹·J_hᵀ`, the extrapolation leverage).
//! Under "the model is exact" it is χ² with `m` degrees of freedom whatever the leverage,
//! so predictions far outside the training range (large `H`, noisy) are weighed by their
//! own uncertainty, and the bias of a surrogate shows in every direction it is determined.
//! The statistic is scale-free, `F = (ΔRSS/m)/(RSS_T/(n_T − p))` with `F(m, n_T − p)`
//! degrees of freedom: a misstated σ cancels; its z by Paulson's (1942) normal
//! approximation, `z = ((1 − 2/(9d₂))·F^⅓ − (1 − 2/(9d₁))) / √(2/(9d₁) + F^⅔·2/(9d₂))`.
//! (Summing the raw held-out errors against their expectation `m + tr H` instead loses
//! almost all power: the few extrapolating directions dominate its variance.)
//!
//! The check is significant when the largest `z` over the splits exceeds the gap test's
//! threshold `z_gap`, Bonferroni-corrected for the number of splits (the one-sided tail
//! `Φ̄(z_gap)` divided by the splits evaluated): with the default `z_gap = 3` and twelve
//! splits, `z > 3.69`. The correction keeps the false-alarm rate of a correct model at
//! that of one gap test, whatever the number of joints.
//!
//! Only run when the verdict would be `explained` under cross-validation (the in-sample
//! regime has too few poses to fit on half of them). Cost: `2N + 1` factorisations of the
//! verdict's model and two Jacobians per row and split.

use super::{Config, DiagWorkspace, PoseDiagnosis, cv};
use crate::error::Result;
use crate::identify::Measurement;
use crate::math::{cbrt, sqrt};
use crate::model::Robot;

/// The extrapolation check of the verdict's model (module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ExtrapolationCheck {
    /// Whether the check ran (an `explained` verdict under cross-validation with at least
    /// one evaluable split).
    pub evaluated: bool,
    /// Splits evaluated (at most two per joint).
    pub splits: usize,
    /// Largest z over the splits (Paulson's z of Chow's F).
    pub z: f64,
    /// Chow's `F` of that split: the held-out rows' whitened prediction error per row
    /// (leverage-corrected) over the training fit's residual variance; 1 for a model of
    /// the right form.
    pub ratio: f64,
    /// Joint (zero-based) of that split.
    pub joint: usize,
    /// Whether that split held out the upper half of the joint's range (fitted on the
    /// lower).
    pub upper: bool,
    /// Bonferroni-corrected threshold the largest z is compared with.
    pub threshold: f64,
    /// Whether the model fails to extrapolate (`z > threshold`).
    pub significant: bool,
}

/// Upper tail of the standard normal, `Φ̄(z) = erfc(z/√2)/2`.
fn normal_tail(z: f64) -> f64 {
    0.5 * libm::erfc(z / core::f64::consts::SQRT_2)
}

/// The z whose upper tail is `p` (bisection on [`normal_tail`]; `p` in (0, 0.5]).
pub(crate) fn normal_upper_quantile(p: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 40.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if normal_tail(mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The Bonferroni threshold for `splits` one-sided tests at the level of one test at `z`.
pub(crate) fn bonferroni_threshold(z: f64, splits: usize) -> f64 {
    if splits <= 1 {
        z
    } else {
        normal_upper_quantile(normal_tail(z) / splits as f64)
    }
}

/// The lower median of `q_j` over the clean rows (`None` without clean rows): the
/// smallest value with at least half the rows at or below it. Sorted in place in the
/// first records' `scratch` (O(n log n), no memory).
fn median_q<const N: usize>(
    data: &[Measurement<N>],
    poses: &mut [PoseDiagnosis],
    j: usize,
) -> Option<f64> {
    let mut n = 0;
    for l in 0..poses.len().min(data.len()) {
        if poses[l].suspect {
            continue;
        }
        if let Some(&q) = data[l].state.q.get(j) {
            // Slot n ≤ l: every record at or before it has been read.
            poses[n].scratch = q;
            n += 1;
        }
    }
    let values = poses.get_mut(..n)?;
    super::rank::sort_by_value(values);
    values.get(n.div_ceil(2).checked_sub(1)?).map(|p| p.scratch)
}

/// Whether clean row `l` is held out by the split of joint `j` at `cut` (`upper`: the rows
/// above the cut are held out).
fn held_out<const N: usize>(
    m: &Measurement<N>,
    p: &PoseDiagnosis,
    j: usize,
    cut: f64,
    upper: bool,
) -> bool {
    !p.suspect && m.state.q.get(j).is_some_and(|&q| (q > cut) == upper)
}

/// Number of distinct joint states (pose groups) among the held-out rows.
fn held_groups<const N: usize>(
    data: &[Measurement<N>],
    poses: &[PoseDiagnosis],
    j: usize,
    cut: f64,
    upper: bool,
) -> usize {
    data.iter()
        .zip(poses)
        .enumerate()
        .filter(|&(l, (m, p))| held_out(m, p, j, cut, upper) && p.leader as usize == l)
        .count()
}

/// Paulson's normal approximation of an `F(d1, d2)` variate's z.
pub(crate) fn paulson_z(f: f64, d1: f64, d2: f64) -> f64 {
    if f.is_nan() || d1 <= 0.0 || d2 <= 0.0 {
        return 0.0;
    }
    let (a, b) = (2.0 / (9.0 * d1), 2.0 / (9.0 * d2));
    let c = cbrt(f.max(0.0));
    ((1.0 - b) * c - (1.0 - a)) / sqrt(a + c * c * b)
}

/// Residual sum of squares of model `mdl` fitted on all clean rows (`train = false`) or on
/// the training half (`train = true`: all minus `ws.g_fold`), from the Grams: `bᵀb −
/// |L⁻¹·D⁻¹·Aᵀb|²`. `None` when the rows do not determine every parameter.
fn rss<const P: usize>(
    ws: &mut DiagWorkspace<P>,
    mdl: usize,
    train: bool,
    tol: f64,
) -> Option<f64> {
    let p = ws.model_n.get(mdl).copied().unwrap_or(0);
    let n = cv::factor(ws, mdl, train, tol, None);
    if n < p {
        return None;
    }
    let mut fitted = 0.0;
    for r in 0..n {
        let c = ws.model_cols[mdl][ws.kept[r]] as usize;
        let atb = ws.g_all.atb()[c] - if train { ws.g_fold.atb()[c] } else { 0.0 };
        let mut v = atb / ws.scale[r];
        for k in 0..r {
            v -= ws.chol[r][k] * ws.tmp[k];
        }
        let v = v / ws.chol[r][r];
        ws.tmp[r] = v;
        fitted += v * v;
    }
    let btb = ws.g_all.btb() - if train { ws.g_fold.btb() } else { 0.0 };
    Some((btb - fitted).max(0.0))
}

/// Runs the check of model `mdl` (its columns in `ws.model_cols`) linearised at `lin`,
/// with `ws.g_all` the whitened Gram of the clean rows there (as left by the verdict's
/// final cross-validation pass). Uses `ws.g_fold` and the factor scratch.
///
/// The splits need the model's columns only: the union `U` is narrowed to them for the
/// run ([`cv::narrow_to_model`]) and `ws.g_all` with it ([`GramAccumulator::select`], bit
/// for bit; nothing to do when the final pass already folded it over them), so each
/// split's Gram costs `p²` instead of `|U|²` per row. `ws.u`, `ws.n_u` and the model's
/// column positions are restored afterwards; `ws.g_all` stays narrow (the form check, the
/// only later user, rebuilds it).
///
/// [`GramAccumulator::select`]: crate::linalg::gram::GramAccumulator::select
pub(crate) fn check<const N: usize, const P: usize>(
    lin: &Robot<N>,
    data: &[Measurement<N>],
    sw: &[f64; 6],
    poses: &mut [PoseDiagnosis],
    mdl: usize,
    cfg: &Config,
    ws: &mut DiagWorkspace<P>,
) -> Result<ExtrapolationCheck> {
    let p = ws.model_n.get(mdl).copied().unwrap_or(0).min(P);
    let mut sorted = [0usize; P];
    let saved = cv::narrow_to_model(ws, mdl, &mut sorted);
    // Identity when the final pass already folded `g_all` over the model's columns.
    if let Err(e) = ws.g_all.select(sorted.get(..p).unwrap_or(&[])) {
        cv::restore_union(ws, &saved);
        return Err(e);
    }
    let out = splits(lin, data, sw, poses, mdl, cfg, ws);
    cv::restore_union(ws, &saved);
    out
}

/// [`check`]'s splits on the narrowed workspace.
fn splits<const N: usize, const P: usize>(
    lin: &Robot<N>,
    data: &[Measurement<N>],
    sw: &[f64; 6],
    poses: &mut [PoseDiagnosis],
    mdl: usize,
    cfg: &Config,
    ws: &mut DiagWorkspace<P>,
) -> Result<ExtrapolationCheck> {
    let mut out = ExtrapolationCheck::default();
    let p = ws.model_n.get(mdl).copied().unwrap_or(0);
    let Some(rss_all) = rss(ws, mdl, false, cfg.rank_tol) else {
        return Ok(out);
    };
    let rows_all: usize = data
        .iter()
        .zip(poses.iter())
        .filter(|(_, pd)| !pd.suspect)
        .map(|(m, _)| (0..6).filter(|&k| m.mask.has(k)).count())
        .sum();
    let mut best = f64::NEG_INFINITY;
    let min_groups = cfg.min_groups_per_fold.max(2);
    let lin = cv::Lin::bind(lin, ws);
    for j in 0..N {
        let Some(cut) = median_q(data, poses, j) else {
            continue;
        };
        for upper in [false, true] {
            if held_groups(data, poses, j, cut, upper) < min_groups
                || held_groups(data, poses, j, cut, !upper) < min_groups
            {
                continue;
            }
            ws.g_fold.reset(ws.n_u)?;
            let mut m_rows = 0usize;
            for (l, (m, pd)) in data.iter().zip(poses.iter()).enumerate() {
                if held_out(m, pd, j, cut, upper) {
                    cv::pose_rows(&lin, l, m, sw, ws)?;
                    cv::fold_rows(ws, true)?;
                    m_rows += (0..6).filter(|&k| m.mask.has(k)).count();
                }
            }
            let Some(rss_train) = rss(ws, mdl, true, cfg.rank_tol) else {
                continue;
            };
            let d1 = m_rows as f64;
            let d2 = rows_all.saturating_sub(m_rows).saturating_sub(p) as f64;
            if d1 <= 0.0 || d2 <= 0.0 || rss_train <= 0.0 {
                continue;
            }
            let f = ((rss_all - rss_train).max(0.0) / d1) / (rss_train / d2);
            let z = paulson_z(f, d1, d2);
            out.splits += 1;
            if z > best {
                best = z;
                out.z = z;
                out.ratio = f;
                out.joint = j;
                out.upper = upper;
            }
        }
    }
    if out.splits > 0 {
        out.evaluated = true;
        out.threshold = bonferroni_threshold(cfg.z_gap, out.splits);
        out.significant = out.z > out.threshold;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;
    use nalgebra::{SMatrix, SVector};
    use std::boxed::Box;
    use std::vec::Vec;

    #[test]
    fn quantile_matches_table_values() {
        // Φ̄(3) = 1.3499e-3 and Φ̄(3.7190) = 1.0e-4 (standard normal tables).
        assert!((normal_upper_quantile(1.3499e-3) - 3.0).abs() < 1e-3);
        assert!((normal_upper_quantile(1.0e-4) - 3.7190).abs() < 1e-3);
        assert!((bonferroni_threshold(3.0, 1) - 3.0).abs() < 1e-12);
        // Twelve splits at the level of one z = 3 test: Φ̄⁻¹(1.3499e-3/12) = 3.69.
        assert!((bonferroni_threshold(3.0, 12) - 3.69).abs() < 0.01);
    }

    #[test]
    fn paulson_tends_to_wilson_hilferty_for_a_chi2() {
        // d2 → ∞: F·d1 is χ² with d1 degrees of freedom, as in the likelihood-ratio z.
        for (q, k) in [(10.0, 12usize), (40.0, 30), (3.0, 1), (90.0, 60)] {
            let a = paulson_z(q / k as f64, k as f64, 1e15);
            let b = super::super::lr_z(q, k);
            assert!((a - b).abs() < 1e-6, "{a} {b}");
        }
        // F(d1, d2) upper 0.1 % points from tables: F(10, 100) = 3.30 → z ≈ 3.09.
        assert!((paulson_z(3.30, 10.0, 100.0) - 3.09).abs() < 0.1);
    }

    /// A cubic in x as the model (4 columns), fitted where x < 0.2, predicting x ≥ 0.2 (far
    /// outside: large leverage): rows and the truth's values.
    fn rows(rng: &mut SplitMix64) -> (Vec<[f64; 4]>, Vec<[f64; 4]>) {
        let basis = |x: f64| [1.0, x, x * x, x * x * x];
        let train = (0..14).map(|_| basis(rng.range(-1.0, 0.2))).collect();
        let test = (0..6).map(|_| basis(rng.range(0.2, 1.0))).collect();
        (train, test)
    }

    /// ΔRSS of `rss` for right-hand sides `b_train`, `b_test` (whitened residuals).
    fn delta_rss(
        ws: &mut DiagWorkspace<8>,
        train: &[[f64; 4]],
        test: &[[f64; 4]],
        b_train: &[f64],
        b_test: &[f64],
    ) -> f64 {
        ws.g_all.reset(4).unwrap();
        ws.g_fold.reset(4).unwrap();
        for (r, &b) in train.iter().zip(b_train).chain(test.iter().zip(b_test)) {
            ws.g_all.add_row_weighted(r, b, 1.0).unwrap();
        }
        for (r, &b) in test.iter().zip(b_test) {
            ws.g_fold.add_row_weighted(r, b, 1.0).unwrap();
        }
        let all = rss(ws, 1, false, 1e-12).unwrap();
        let tr = rss(ws, 1, true, 1e-12).unwrap();
        all - tr
    }

    #[test]
    fn chow_increase_is_the_leverage_weighted_prediction_error_and_chi2() {
        let mut rng = SplitMix64::new(7);
        let (train, test) = rows(&mut rng);
        let mut ws: Box<DiagWorkspace<8>> = Box::default();
        ws.n_u = 4;
        ws.model_n[1] = 4;
        for c in 0..4 {
            ws.model_cols[1][c] = c as u8;
        }
        let v = |r: &[f64; 4]| SVector::<f64, 4>::from_row_slice(r);
        let mut a = SMatrix::<f64, 4, 4>::zeros();
        for r in &train {
            a += v(r) * v(r).transpose();
        }
        let c = a.try_inverse().unwrap();
        let tr_h: f64 = test
            .iter()
            .map(|r| (v(r).transpose() * c * v(r))[(0, 0)])
            .sum();
        assert!(tr_h > 6.0, "the held-out rows extrapolate: tr H = {tr_h}");
        // Direct: r = b_test − J_T·δ_train, ΔRSS = rᵀ(I + H)⁻¹r.
        let b_train: Vec<f64> = train.iter().map(|_| rng.normal()).collect();
        let b_test: Vec<f64> = test.iter().map(|_| rng.normal() + 0.5).collect();
        let mut atb = SVector::<f64, 4>::zeros();
        for (r, &b) in train.iter().zip(&b_train) {
            atb += v(r) * b;
        }
        let delta = c * atb;
        let m = test.len();
        let mut cov = nalgebra::DMatrix::<f64>::identity(m, m);
        let mut res = nalgebra::DVector::<f64>::zeros(m);
        for (i, ri) in test.iter().enumerate() {
            res[i] = b_test[i] - (v(ri).transpose() * delta)[(0, 0)];
            for (k, rk) in test.iter().enumerate() {
                cov[(i, k)] += (v(ri).transpose() * c * v(rk))[(0, 0)];
            }
        }
        let direct = (res.transpose() * cov.try_inverse().unwrap() * &res)[(0, 0)];
        let chow = delta_rss(&mut ws, &train, &test, &b_train, &b_test);
        assert!((chow - direct).abs() < 1e-8 * direct, "{chow} {direct}");
        // Monte Carlo under the model (unit noise): ΔRSS is χ² with m degrees of freedom,
        // whatever the leverage.
        let reps = 4000;
        let (mut s1, mut s2) = (0.0, 0.0);
        for _ in 0..reps {
            let bt: Vec<f64> = train.iter().map(|_| rng.normal()).collect();
            let bh: Vec<f64> = test.iter().map(|_| rng.normal()).collect();
            let q = delta_rss(&mut ws, &train, &test, &bt, &bh);
            s1 += q;
            s2 += q * q;
        }
        let mean = s1 / reps as f64;
        let var = s2 / reps as f64 - mean * mean;
        assert!((mean / m as f64 - 1.0).abs() < 0.06, "{mean}");
        assert!((var / (2.0 * m as f64) - 1.0).abs() < 0.15, "{var}");
    }
}
