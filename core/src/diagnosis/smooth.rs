//! "Explainable at all?": how much of the geometric calibration's held-out gap **any**
//! smooth function of the joint angles explains, independent of the effect library.
//!
//! # Why this check
//! The library's candidates can only explain what they model. When none closes the gap,
//! the honest answers differ: either a smooth, repeatable function of the posture is left
//! (an effect outside the library: link bending, a nonlinear compliance, a compliant
//! mount, a scale error of the instrument, a flexing tool; compensable by a lookup or a
//! new effect), or what is left is not a function of q at all (noise misstated, outliers,
//! hysteresis, temperature; not compensable from the joint readings). A model-free
//! regression on q, judged held out on the same folds as the candidates, separates the
//! two and also says how much a perfect library entry could gain.
//!
//! # Method: kernel ridge regression on a fixed feature basis
//! Gaussian-process regression (equivalently kernel ridge regression) is the standard
//! nonparametric model of an unknown smooth function with a noise level: its posterior
//! mean is the ridge solution in the kernel's feature space (Rasmussen & Williams 2006,
//! ch. 2 and 6). The inputs are `x = (sin q_1, cos q_1, …, sin q_N, cos q_N)`, so
//! revolute joints are periodic. The kernel is additive (Duvenaud et al. 2011): a linear
//! kernel in `x` (first harmonics of each joint, the dominant part of most joint-level
//! errors), a quadratic one in the task space of the nominal arm (tool position, its
//! pairwise products, tool axis: also smooth functions of q, and the natural coordinates
//! of errors that act in Cartesian space — instrument scale, a tilting mount, a flexing
//! tool), plus the squared exponential
//! `k(x, x') = exp(−|x − x'|²/(2ℓ²))`; since `|x − x'|² = Σ_i 4 sin²((q_i − q'_i)/2)`
//! the latter is the product of the standard periodic kernels of the joints (MacKay
//! 1998) and carries every interaction between joints. To keep memory fixed whatever the
//! number of poses, the squared exponential is approximated by random Fourier features
//! `φ_j(x) = √(2/M')·cos(ω_j·x/ℓ + b_j)`, `ω_j` standard normal, `b_j` uniform on
//! [0, 2π) (Rahimi & Recht 2007, "Random features for large-scale kernel machines"; a
//! fixed seed, so the check is deterministic). [`FEATURES`] = `M` features in all (the
//! `2N` linear and [`TASK`] task-space ones first) turn the regression into an `M×M`
//! ridge system:
//! memory `O(M²)`, time `O(n·M²)` per Gram and `O(M³)` per solve, no heap.
//!
//! The check is generic, so it needs more data than the right parametric candidate for
//! the same share: on 80 simulated poses it recovers 0.55–0.75 of the gap of a joint
//! compliance or cyclic error the right candidate closes to 0.9–1 (tests/explainable.rs),
//! and at high signal-to-noise (laser tracker, effects 10–100× the noise) its
//! approximation error, not the noise, limits the share (tests/diagnosis_families.rs).
//! Its share is therefore a conservative estimate of what a smooth function of q can
//! explain.
//!
//! Targets are the baseline's held-out residuals (`PoseDiagnosis::heldout_baseline`)
//! whitened by σ (each kernel part has `k(x, x) ≈ 1`, so the ridge strength `λ` is the
//! inverse prior variance of each part in noise units: the grid [`RIDGES`] spans prior
//! amplitudes from the noise level to ~30 σ). Position and rotation components each get their own
//! output; the three outputs of a component type share the features and the ridge.
//!
//! # Cross-validation (nested)
//! Outer folds are the diagnosis's folds (groups of `pose_id`, so repeats never straddle):
//! for each fold, the model is fitted on the other folds' targets and predicts this fold's.
//! The hyperparameters — the length scale `ℓ` from [`LENGTH_SCALES`] times the data's RMS
//! pairwise input distance (the usual "median heuristic", with the RMS so no sorting is
//! needed) and `λ` from [`RIDGES`] — are chosen per component type by an inner
//! cross-validation over the training folds only (each training fold held out in turn);
//! predicting zero (no smooth part) competes too, so pure noise mostly gives an exact zero
//! model. The test fold never influences its own prediction's hyperparameters or
//! coefficients. Its targets do enter the training targets indirectly, through the
//! geometric fits of the other folds (each excludes only its own fold); that coupling is
//! of the order of the geometric leverage (~p/rows, a few %) and, being a least-squares
//! projection, biases the held-out prediction *against* the test residual, i.e. the check
//! is slightly conservative.
//!
//! # Outputs ([`SmoothCheck`])
//! Held-out RMS position/rotation after the smooth correction; `share_of_gap`, the
//! fraction of the baseline's held-out excess over the noise floor that the correction
//! removes, on whitened totals (position and rotation rows by their noise):
//! `(√Q_B − √Q_S)/(√Q_B − √E)` clipped to [0, 1] with `Q_B`, `Q_S` the baseline's and the
//! smooth model's held-out whitened totals and `E` their expectation at the noise floor
//! (including the estimation inflation, as in the gap test); the same ratio per component
//! type on RMS values against `√3·σ` (as `gap_closed_fraction`); and the paired
//! Wilcoxon z over groups against the baseline (as the candidates' `improvement_z`).
//!
//! Poses that do not measure every component of the component types the data measure
//! (mixed position-only and full-pose rows) are neither fitted nor corrected (their
//! baseline residual counts unchanged, a conservative choice). The smooth model uses the
//! joint readings only: backlash (approach direction) and thermal drift (temperature) are
//! not functions of q and stay unexplained by design.

use super::{Config, ModelAcc, NoiseFloor, PoseDiagnosis};
use crate::any::MAX_JOINTS;
use crate::identify::Measurement;
use crate::math::{cos, sin_cos, sqrt};
use crate::model::{JointState, Robot};
use crate::rng::SplitMix64;

/// Number of features `M`: the `2N` linear terms `(sin q_i, cos q_i)/√N` first, the
/// [`TASK`] task-space terms, then `M − 2N − TASK` random Fourier features (24 for six
/// joints).
pub const FEATURES: usize = 48;
/// Task-space terms: nominal tool position (3), its products (6), tool axis (3).
pub const TASK: usize = 12;
/// Length scales, in units of the data's RMS pairwise distance in `(sin q, cos q)` space.
pub const LENGTH_SCALES: [f64; 2] = [1.0, 3.0];
/// Ridge strengths λ (inverse prior variance of the smooth function, in noise units²).
pub const RIDGES: [f64; 4] = [1.0, 0.1, 0.01, 1e-3];
/// Seed of the random features.
pub const FEATURE_SEED: u64 = 0x736d_6f6f_7468;

/// Folds up to which the nested cross-validation keeps every fold's Gram (one length scale
/// at a time) instead of rebuilding each about `2·folds` times ([`choose_all`]); more
/// folds take the rebuilding path ([`choose`]), with the same results bit for bit.
pub const STORED_FOLDS: usize = 8;

const M: usize = FEATURES;
const L: usize = LENGTH_SCALES.len();
const R: usize = RIDGES.len();
const X: usize = 2 * MAX_JOINTS;
/// Right-hand sides the workspace holds: six outputs per check, and the baseline's check
/// and the verdict's ([`check_both`]) share the features, Grams and factors.
const OUT: usize = 12;

/// The model-free "explainable at all?" check (module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SmoothCheck {
    /// Whether the check ran (false: fewer than 3 folds, fewer than two fitted poses per
    /// fold, no measured component with a positive σ, or joint readings that do not vary).
    pub evaluated: bool,
    /// Share of the baseline's held-out excess over the noise floor (whitened position and
    /// rotation together) that the smooth model removes, held out; in [0, 1].
    pub share_of_gap: f64,
    /// The same on the held-out RMS position error against `√3·σ_pos` (0 without a
    /// position gap).
    pub share_pos: f64,
    /// The same on the held-out RMS rotation angle against `√3·σ_rot` (0 without a
    /// rotation gap).
    pub share_rot: f64,
    /// Held-out RMS position error after the smooth correction \[m\].
    pub heldout_rms_pos_m: f64,
    /// Held-out RMS rotation angle after the smooth correction \[rad\].
    pub heldout_rms_rot_rad: f64,
    /// Held-out whitened total after the smooth correction.
    pub heldout_chi2: f64,
    /// Paired Wilcoxon z over groups against the baseline (positive: the smooth model has
    /// the smaller held-out errors).
    pub z: f64,
    /// Whether `z` exceeds the configuration's `z_significance`.
    pub significant: bool,
}

/// Working memory of the check (part of [`super::DiagWorkspace`]; about 321 KiB).
#[derive(Debug, Clone)]
pub struct SmoothWorkspace {
    omega: [[f64; X]; M],
    phase: [f64; M],
    g_all: [[[f64; M]; M]; L],
    r_all: [[[f64; OUT]; M]; L],
    g_out: [[f64; M]; M],
    r_out: [[f64; OUT]; M],
    g_in: [[f64; M]; M],
    r_in: [[f64; OUT]; M],
    chol: [[f64; M]; M],
    beta: [[f64; OUT]; M],
    /// One solution per ridge while the ridges are compared.
    beta_ridge: [[[f64; OUT]; M]; R],
    /// Every fold's Gram and right-hand side at one length scale ([`choose_all`]).
    g_folds: [[[f64; M]; M]; STORED_FOLDS],
    r_folds: [[[f64; OUT]; M]; STORED_FOLDS],
    /// Right-hand sides in use: 6 (one check) or [`OUT`] (both checks, [`check_both`]).
    n_out: usize,
    u: [f64; M],
    n_linear: usize,
    task_mean: [f64; 3],
    task_scale: f64,
    phi: [f64; M],
    /// Tests only: the inner training sets in the order before fits were shared by fold
    /// pairs (`G_all − G_out − G_in`, each outer fold's inner folds fitted on their own;
    /// [`training`]), the reference the shared fits are compared with.
    #[cfg(test)]
    legacy: bool,
}

impl SmoothWorkspace {
    /// A zeroed workspace.
    #[must_use]
    pub const fn new() -> Self {
        SmoothWorkspace {
            omega: [[0.0; X]; M],
            phase: [0.0; M],
            g_all: [[[0.0; M]; M]; L],
            r_all: [[[0.0; OUT]; M]; L],
            g_out: [[0.0; M]; M],
            r_out: [[0.0; OUT]; M],
            g_in: [[0.0; M]; M],
            r_in: [[0.0; OUT]; M],
            chol: [[0.0; M]; M],
            beta: [[0.0; OUT]; M],
            beta_ridge: [[[0.0; OUT]; M]; R],
            g_folds: [[[0.0; M]; M]; STORED_FOLDS],
            r_folds: [[[0.0; OUT]; M]; STORED_FOLDS],
            n_out: 6,
            u: [0.0; M],
            n_linear: 0,
            task_mean: [0.0; 3],
            task_scale: 0.0,
            phi: [0.0; M],
            #[cfg(test)]
            legacy: false,
        }
    }
}

impl Default for SmoothWorkspace {
    fn default() -> Self {
        Self::new()
    }
}

/// Component types: position (rows 0..3) and rotation (3..6).
const CLASSES: [core::ops::Range<usize>; 2] = [0..3, 3..6];

/// Whitened held-out baseline residual of a pose (zero where not measured).
fn target<const N: usize>(m: &Measurement<N>, p: &PoseDiagnosis, sw: &[f64; 6]) -> [f64; 6] {
    whitened(m, &p.heldout_baseline, sw)
}

/// Whitened residual `r` of a pose (zero where not measured).
fn whitened<const N: usize>(m: &Measurement<N>, r: &[f64; 6], sw: &[f64; 6]) -> [f64; 6] {
    let mut y = [0.0; 6];
    for (k, (yk, (&r, &w))) in y.iter_mut().zip(r.iter().zip(sw)).enumerate() {
        if m.mask.has(k) {
            *yk = r * w;
        }
    }
    y
}

/// The targets of every check in use (`n_out` outputs): the baseline's held-out residual
/// ([`target`]) and, for [`OUT`], the verdict's (`heldout_final`) after it.
fn targets<const N: usize>(
    m: &Measurement<N>,
    p: &PoseDiagnosis,
    sw: &[f64; 6],
    n_out: usize,
) -> [f64; OUT] {
    let mut y = [0.0; OUT];
    let (first, second) = y.split_at_mut(6);
    first.copy_from_slice(&target(m, p, sw));
    if n_out > 6 {
        second.copy_from_slice(&whitened(m, &p.heldout_final, sw));
    }
    y
}

/// Check `c`'s six outputs of `y`.
fn part(y: &[f64; OUT], c: usize) -> [f64; 6] {
    core::array::from_fn(|k| y.get(6 * c + k).copied().unwrap_or(0.0))
}

/// Whitened squared error of a pose with prediction `pred` (zero outside active classes),
/// summed over the measured components in a fixed order (a zero prediction reproduces the
/// baseline's value bit for bit).
fn sq<const N: usize>(m: &Measurement<N>, y: &[f64; 6], pred: &[f64; 6]) -> f64 {
    let mut s = 0.0;
    for (k, (&yk, &pk)) in y.iter().zip(pred).enumerate() {
        if m.mask.has(k) {
            let v = yk - pk;
            s += v * v;
        }
    }
    s
}

/// Which component types are fitted: those some pose measures completely.
fn active_classes<const N: usize>(data: &[Measurement<N>]) -> [bool; 2] {
    let mut act = [false; 2];
    for m in data {
        for (a, c) in act.iter_mut().zip(CLASSES) {
            *a |= c.clone().all(|k| m.mask.has(k));
        }
    }
    act
}

/// Whether a pose measures every component of the active types (it is fitted and
/// corrected).
fn fits<const N: usize>(m: &Measurement<N>, act: &[bool; 2]) -> bool {
    act.iter()
        .zip(CLASSES)
        .all(|(&a, c)| !a || c.clone().all(|k| m.mask.has(k)))
}

/// The ℓ-independent parts of a pose's features: the linear terms `x(q)/√N` into
/// `ws.phi[..2N]`, the task-space terms (nominal tool position, centred and scaled, its
/// pairwise products and the tool axis; [`TASK`] slots) after them, and the projections
/// `u_j = ω_j·x(q)` of the Fourier slots into `ws.u`.
fn project<const N: usize>(ws: &mut SmoothWorkspace, robot: &Robot<N>, state: &JointState<N>) {
    let mut x = [0.0; X];
    for (pair, &qi) in x.chunks_exact_mut(2).zip(state.q.iter()) {
        let (s, c) = sin_cos(qi);
        if let [a, b] = pair {
            *a = s;
            *b = c;
        }
    }
    let nl = ws.n_linear;
    for (u, w) in ws.u.iter_mut().zip(&ws.omega).skip(nl + TASK) {
        *u = w.iter().zip(&x).map(|(a, b)| a * b).sum();
    }
    let norm = 1.0 / sqrt(N.max(1) as f64);
    for (f, &v) in ws.phi.iter_mut().zip(&x).take(nl) {
        *f = v * norm;
    }
    let task = task_terms(robot, state, &ws.task_mean, ws.task_scale);
    for (f, &v) in ws.phi.iter_mut().skip(nl).zip(&task) {
        *f = v;
    }
}

/// Slots of a pose's stored features (`PoseDiagnosis::smooth`): the `2N + TASK` shared
/// ones and the Fourier ones of every length scale, at most `L·M − (L − 1)·TASK`.
pub(crate) const STORED: usize = L * M - (L - 1) * TASK;

/// Keeps the pose's features at every length scale in its record (`PoseDiagnosis::smooth`:
/// the linear and task-space slots, then the Fourier slots of each length scale in turn),
/// so the nested cross-validation, which needs them about 20 times per pose and check,
/// computes them (and their cosines) once. Needs [`project`]'s results in `ws`.
fn stash_features(ws: &mut SmoothWorkspace, p: &mut PoseDiagnosis, inv_l0: f64) {
    let nl = ws.n_linear + TASK;
    for (d, &v) in p.smooth.iter_mut().zip(&ws.phi).take(nl) {
        *d = v;
    }
    for (li, &scale) in LENGTH_SCALES.iter().enumerate() {
        features(ws, inv_l0 / scale);
        let at = nl + li * M.saturating_sub(nl);
        for (d, &v) in p.smooth.iter_mut().skip(at).zip(ws.phi.iter().skip(nl)) {
            *d = v;
        }
    }
}

/// The features of pose `p` at length scale `li` into `ws.phi` ([`stash_features`]):
/// the same values [`features`] computes, bit for bit.
fn load_features(ws: &mut SmoothWorkspace, p: &PoseDiagnosis, li: usize) {
    let nl = ws.n_linear + TASK;
    for (d, &v) in ws.phi.iter_mut().zip(&p.smooth).take(nl) {
        *d = v;
    }
    let at = nl + li * M.saturating_sub(nl);
    for (d, &v) in ws.phi.iter_mut().skip(nl).zip(p.smooth.iter().skip(at)) {
        *d = v;
    }
}

/// Task-space terms of a pose, each of unit mean square over the data (about): the
/// nominal tool position `s = (p − p̄)·scale`, the products `s_i·s_j` (i ≤ j) and the tool
/// axis `z`, every group divided by √(its size) so each group has unit norm. Zero when the
/// forward kinematics fails.
fn task_terms<const N: usize>(
    robot: &Robot<N>,
    state: &JointState<N>,
    mean: &[f64; 3],
    scale: f64,
) -> [f64; TASK] {
    let mut t = [0.0; TASK];
    let Ok(pose) = robot.fk(state) else {
        return t;
    };
    let p = pose.translation.vector;
    let r = pose.rotation.matrix();
    let s = [
        (p[0] - mean[0]) * scale,
        (p[1] - mean[1]) * scale,
        (p[2] - mean[2]) * scale,
    ];
    let (g1, g2) = (1.0 / sqrt(3.0), 1.0 / sqrt(6.0));
    let mut k = 0;
    for &v in &s {
        t[k] = v * g1;
        k += 1;
    }
    for i in 0..3 {
        for j in i..3 {
            t[k] = s[i] * s[j] * g2;
            k += 1;
        }
    }
    for i in 0..3 {
        t[k] = r[(i, 2)] * g1;
        k += 1;
    }
    t
}

/// The Fourier features at length-scale factor `inv_l = 1/ℓ` (slots from `2N` on) from
/// the projections in `ws.u`; the linear slots stay as [`project`] wrote them.
fn features(ws: &mut SmoothWorkspace, inv_l: f64) {
    let nl = ws.n_linear + TASK;
    let amp = sqrt(2.0 / (M - nl).max(1) as f64);
    for ((f, &u), &b) in ws.phi.iter_mut().zip(&ws.u).zip(&ws.phase).skip(nl) {
        *f = amp * cos(u * inv_l + b);
    }
}

/// Adds `φ·φᵀ` (lower triangle) and `φ·yᵀ` (the first `n_out` outputs) to a Gram/right-hand
/// side.
fn accumulate(
    g: &mut [[f64; M]; M],
    r: &mut [[f64; OUT]; M],
    phi: &[f64; M],
    y: &[f64; OUT],
    n_out: usize,
) {
    for (i, (gi, ri)) in g.iter_mut().zip(r.iter_mut()).enumerate() {
        let pi = phi[i % M];
        for (gij, &pj) in gi.iter_mut().zip(phi).take(i + 1) {
            *gij += pi * pj;
        }
        for (rik, &yk) in ri.iter_mut().zip(y).take(n_out) {
            *rik += pi * yk;
        }
    }
}

/// Gram and right-hand side over the fitted poses of fold `fold` at length scale `li`
/// into `ws.g_out`/`r_out` (`inner = false`) or `ws.g_in`/`r_in`.
#[allow(clippy::too_many_arguments)]
fn fold_gram<const N: usize>(
    ws: &mut SmoothWorkspace,
    data: &[Measurement<N>],
    poses: &[PoseDiagnosis],
    sw: &[f64; 6],
    act: &[bool; 2],
    fold: Option<usize>,
    li: usize,
    inner: bool,
) {
    {
        let (gm, rm) = if inner {
            (&mut ws.g_in, &mut ws.r_in)
        } else {
            (&mut ws.g_out, &mut ws.r_out)
        };
        for row in gm.iter_mut() {
            *row = [0.0; M];
        }
        for row in rm.iter_mut() {
            *row = [0.0; OUT];
        }
    }
    let n_out = ws.n_out;
    for (m, p) in data.iter().zip(poses) {
        if p.suspect || fold.is_some_and(|f| usize::from(p.fold) != f) || !fits(m, act) {
            continue;
        }
        let y = targets(m, p, sw, n_out);
        load_features(ws, p, li);
        let SmoothWorkspace {
            g_out,
            r_out,
            g_in,
            r_in,
            phi,
            ..
        } = ws;
        if inner {
            accumulate(g_in, r_in, phi, &y, n_out);
        } else {
            accumulate(g_out, r_out, phi, &y, n_out);
        }
    }
}

/// Entry of a training matrix or right-hand side: `all − out` (outer fit), or for an inner
/// fit `all − (out + in)`, the two held-out folds' sums added first: addition commutes
/// exactly, so the training set of the fold pair {f, g} is the same bits whichever of the
/// two is the outer fold, and one fit serves both ([`choose_all`]). (`legacy`, tests only:
/// `all − out − in`, the order before, where the pair's two fits differed in the last bits.)
#[inline]
fn training(all: f64, out: f64, inn: f64, inner: bool, legacy: bool) -> f64 {
    if !inner {
        all - out
    } else if legacy {
        all - out - inn
    } else {
        all - (out + inn)
    }
}

/// Whether the workspace computes the test-only reference order ([`training`]).
#[cfg(test)]
fn legacy(ws: &SmoothWorkspace) -> bool {
    ws.legacy
}

/// Whether the workspace computes the test-only reference order ([`training`]): never
/// outside the tests.
#[cfg(not(test))]
fn legacy(_: &SmoothWorkspace) -> bool {
    false
}

/// Whether the nested cross-validation keeps every fold's Gram ([`choose_all`]) rather than
/// rebuilding them per outer fold ([`choose`]; always in the tests' reference order).
fn stored_path(ws: &SmoothWorkspace, folds: usize) -> bool {
    folds <= STORED_FOLDS && !legacy(ws)
}

/// Rows the Cholesky factor computes together ([`factor`]).
const BLOCK: usize = 4;
const _: () = assert!(M.is_multiple_of(BLOCK));

/// Cholesky factor of `G_all[li] − G_out + λ·I`, or `G_all[li] − (G_out + G_in) + λ·I` if
/// `inner` ([`training`]), into `ws.chol`; false when not positive definite.
///
/// Row by row (Cholesky–Crout): `L[i][j] = (A[i][j] − Σ_{k<j} L[i][k]·L[j][k]) / L[j][j]`,
/// each sum in increasing `k` from the value an empty `f64` sum starts at. [`BLOCK`] rows
/// at a time: rows `i0..i0 + BLOCK` need the same earlier rows `j < i0`, so their sums
/// share the loads of row `j` and run as `BLOCK` independent chains (a single chain waits
/// on the latency of each addition); then the triangle inside the block, row by row.
/// Every entry is still the same expression evaluated in the same order, so the factor is
/// bit for bit the one-row-at-a-time factor's (unit test).
fn factor(ws: &mut SmoothWorkspace, li: usize, inner: bool, lambda: f64) -> bool {
    let legacy = legacy(ws);
    let SmoothWorkspace {
        g_all,
        g_out,
        g_in,
        chol,
        ..
    } = ws;
    let Some(ga) = g_all.get(li) else {
        return false;
    };
    // Entry (i, j) of the matrix being factored.
    let a = |i: usize, j: usize| {
        let mut s = training(ga[i][j], g_out[i][j], g_in[i][j], inner, legacy);
        if i == j {
            s += lambda;
        }
        s
    };
    let zero: f64 = core::iter::empty::<f64>().sum();
    for i0 in (0..M).step_by(BLOCK) {
        let (upper, lower) = chol.split_at_mut(i0);
        let Some((block, _)) = lower.split_first_chunk_mut::<BLOCK>() else {
            return false;
        };
        let [r0, r1, r2, r3] = &mut *block;
        // The columns of the complete rows above the block, four chains at a time.
        for (j, cj) in upper.iter().enumerate() {
            let mut d = [zero; BLOCK];
            let rows = r0[..j].iter().zip(&r1[..j]).zip(&r2[..j]).zip(&r3[..j]);
            for ((((&x0, &x1), &x2), &x3), &y) in rows.zip(&cj[..j]) {
                d[0] += x0 * y;
                d[1] += x1 * y;
                d[2] += x2 * y;
                d[3] += x3 * y;
            }
            let pivot = cj[j];
            r0[j] = (a(i0, j) - d[0]) / pivot;
            r1[j] = (a(i0 + 1, j) - d[1]) / pivot;
            r2[j] = (a(i0 + 2, j) - d[2]) / pivot;
            r3[j] = (a(i0 + 3, j) - d[3]) / pivot;
        }
        // The triangle inside the block, row by row.
        for r in 0..BLOCK {
            let i = i0 + r;
            let (done, rest) = block.split_at_mut(r);
            let Some(ci) = rest.first_mut() else {
                return false;
            };
            for (jj, cj) in done.iter().enumerate() {
                let j = i0 + jj;
                let d = ci[..j]
                    .iter()
                    .zip(&cj[..j])
                    .map(|(x, y)| x * y)
                    .sum::<f64>();
                ci[j] = (a(i, j) - d) / cj[j];
            }
            let s = a(i, i) - ci[..i].iter().map(|v| v * v).sum::<f64>();
            if !(s > 0.0 && s.is_finite()) {
                return false;
            }
            ci[i] = sqrt(s);
        }
    }
    true
}

/// The one-row-at-a-time factor [`factor`] must equal bit for bit (its test).
#[cfg(test)]
fn factor_by_rows(ws: &mut SmoothWorkspace, li: usize, inner: bool, lambda: f64) -> bool {
    let legacy = legacy(ws);
    let SmoothWorkspace {
        g_all,
        g_out,
        g_in,
        chol,
        ..
    } = ws;
    let Some(ga) = g_all.get(li) else {
        return false;
    };
    for i in 0..M {
        for j in 0..=i {
            let mut s = training(ga[i][j], g_out[i][j], g_in[i][j], inner, legacy);
            if i == j {
                s += lambda;
            }
            let (upper, lower) = chol.split_at_mut(i);
            let ci = &mut lower[0];
            if j < i {
                let cj = &upper[j];
                s -= ci[..j]
                    .iter()
                    .zip(&cj[..j])
                    .map(|(a, b)| a * b)
                    .sum::<f64>();
                ci[j] = s / cj[j];
            } else {
                s -= ci[..i].iter().map(|a| a * a).sum::<f64>();
                if !(s > 0.0 && s.is_finite()) {
                    return false;
                }
                ci[i] = sqrt(s);
            }
        }
    }
    true
}

/// Solves the factored system for the right-hand sides `r_all[li] − r_out` or
/// `r_all[li] − (r_out + r_in)` ([`training`]) into
/// `ws.beta` (the first `ws.n_out` outputs; each output's arithmetic does not depend on
/// how many are solved together).
fn solve(ws: &mut SmoothWorkspace, li: usize, inner: bool) {
    if ws.n_out > 6 {
        solve_k::<OUT>(ws, li, inner);
    } else {
        solve_k::<6>(ws, li, inner);
    }
}

/// [`solve`] for the first `K` outputs.
fn solve_k<const K: usize>(ws: &mut SmoothWorkspace, li: usize, inner: bool) {
    let legacy = legacy(ws);
    let SmoothWorkspace {
        r_all,
        r_out,
        r_in,
        chol,
        beta,
        ..
    } = ws;
    let Some(ra) = r_all.get(li) else {
        return;
    };
    // The right-hand sides together (innermost), each still summed over c in order.
    for i in 0..M {
        let mut v = [0.0; K];
        for (k, vk) in v.iter_mut().enumerate() {
            *vk = training(ra[i][k], r_out[i][k], r_in[i][k], inner, legacy);
        }
        for (&l, b) in chol[i].iter().zip(beta.iter()).take(i) {
            for (vk, &bk) in v.iter_mut().zip(b) {
                *vk -= l * bk;
            }
        }
        let d = chol[i][i];
        for (bk, vk) in beta[i].iter_mut().zip(v) {
            *bk = vk / d;
        }
    }
    for i in (0..M).rev() {
        let mut v: [f64; K] = core::array::from_fn(|k| beta[i][k]);
        for (row, b) in chol.iter().zip(beta.iter()).skip(i + 1) {
            let l = row[i];
            for (vk, &bk) in v.iter_mut().zip(b) {
                *vk -= l * bk;
            }
        }
        let d = chol[i][i];
        for (bk, vk) in beta[i].iter_mut().zip(v) {
            *bk = vk / d;
        }
    }
}

/// Prediction `φ·β` of check `c` with the workspace's features and solution (see
/// [`predict_with`]).
fn predict(ws: &SmoothWorkspace, act: &[bool; 2], use_class: &[bool; 2], c: usize) -> [f64; 6] {
    predict_with(&ws.phi, &ws.beta, act, use_class, c)
}

/// Prediction `φ·β` of check `c` (its six outputs of `β`) in the active component types
/// (zero elsewhere). One pass over the features with six sums, each in increasing feature
/// order from the value an empty `f64` sum starts at: every output the sum
/// `Σ_j φ_j·β_j[k]` an iterator's `sum` gives, bit for bit, for a sixth of the loads of
/// `φ`.
fn predict_with(
    phi: &[f64; M],
    beta: &[[f64; OUT]; M],
    act: &[bool; 2],
    use_class: &[bool; 2],
    c: usize,
) -> [f64; 6] {
    let zero: f64 = core::iter::empty::<f64>().sum();
    let mut acc = [zero; 6];
    let o = 6 * c.min(OUT / 6 - 1);
    for (&f, b) in phi.iter().zip(beta) {
        if let Some(bc) = b.get(o..o + 6) {
            for (a, &x) in acc.iter_mut().zip(bc) {
                *a += f * x;
            }
        }
    }
    let mut pred = [0.0; 6];
    for (t, range) in CLASSES.iter().enumerate() {
        if act[t] && use_class[t] {
            for k in range.clone() {
                pred[k] = acc[k];
            }
        }
    }
    pred
}

/// Squared whitened error per component type.
fn class_sq(y: &[f64; 6], pred: &[f64; 6]) -> [f64; 2] {
    let mut e = [0.0; 2];
    for (ec, range) in e.iter_mut().zip(CLASSES) {
        for k in range {
            let v = y[k] - pred[k];
            *ec += v * v;
        }
    }
    e
}

/// Hyperparameters chosen for one component type: (length-scale index, ridge) or none
/// (the zero model).
type Choice = Option<(usize, f64)>;

/// Zero-model errors per check and component type: the training targets' own squares
/// (every fold but `f`), as [`choose`] and [`choose_all`] start from.
fn zero_model<const N: usize>(
    data: &[Measurement<N>],
    poses: &[PoseDiagnosis],
    sw: &[f64; 6],
    act: &[bool; 2],
    n_out: usize,
    f: usize,
) -> [[(f64, Choice); 2]; 2] {
    let mut best = [[(0.0, None::<(usize, f64)>); 2]; 2];
    for (m, p) in data.iter().zip(poses) {
        if !p.suspect && usize::from(p.fold) != f && fits(m, act) {
            let y = targets(m, p, sw, n_out);
            for (c, b) in best.iter_mut().enumerate().take(n_out / 6) {
                let e = class_sq(&part(&y, c), &[0.0; 6]);
                b[0].0 += e[0];
                b[1].0 += e[1];
            }
        }
    }
    best
}

/// Inner cross-validation on the folds other than `f`: the best hyperparameters per
/// component type (or the zero model when no smooth model beats it); one check
/// (`ws.n_out = 6`).
#[allow(clippy::too_many_arguments)]
fn choose<const N: usize>(
    ws: &mut SmoothWorkspace,
    data: &[Measurement<N>],
    poses: &[PoseDiagnosis],
    sw: &[f64; 6],
    act: &[bool; 2],
    folds: usize,
    f: usize,
) -> [Choice; 2] {
    let [mut best, _] = zero_model(data, poses, sw, act, 6, f);
    for li in 0..L {
        fold_gram(ws, data, poses, sw, act, Some(f), li, false);
        let mut err = [[0.0f64; 4]; R];
        let mut ok = [true; R];
        for g in (0..folds).filter(|&g| g != f) {
            fold_gram(ws, data, poses, sw, act, Some(g), li, true);
            let side = Side {
                fold: g,
                err: &mut err,
                ok: &mut ok,
            };
            validate_ridges(ws, data, poses, sw, act, li, &mut [side]);
        }
        for (ri, &lambda) in RIDGES.iter().enumerate() {
            for c in 0..2 {
                if ok[ri] && err[ri][c] < best[c].0 {
                    best[c] = (err[ri][c], Some((li, lambda)));
                }
            }
        }
    }
    [best[0].1, best[1].1]
}

/// A fold validated by an inner fit and where its squared errors go: `err[ri][2·c + t]`
/// (ridge `ri`, check `c`, component type `t`) of the outer fold it is an inner fold of;
/// `ok[ri]` is cleared when ridge `ri`'s factorisation fails.
struct Side<'a> {
    fold: usize,
    err: &'a mut [[f64; 4]; R],
    ok: &'a mut [bool; R],
}

/// One inner fit of the nested cross-validation at length scale `li`, the training Gram
/// already in `ws` (`g_in`, `r_in`), validated on each side's fold: every ridge's solution
/// first, so each validation row's features are computed once for all ridges (the features
/// cost more than the predictions), then each ridge's squared validation errors per check
/// and class added to the side of the row's fold, row by row in row order. [`choose`]
/// passes one side (inner fold `g` of outer fold `f`); [`choose_all`] two (the pair's fit
/// validated on `g` for outer fold `f` and on `f` for outer fold `g`).
#[allow(clippy::too_many_arguments)]
fn validate_ridges<const N: usize>(
    ws: &mut SmoothWorkspace,
    data: &[Measurement<N>],
    poses: &[PoseDiagnosis],
    sw: &[f64; 6],
    act: &[bool; 2],
    li: usize,
    sides: &mut [Side<'_>],
) {
    let mut solved = [false; R];
    for (ri, &lambda) in RIDGES.iter().enumerate() {
        if !factor(ws, li, true, lambda) {
            for side in sides.iter_mut() {
                if let Some(o) = side.ok.get_mut(ri) {
                    *o = false;
                }
            }
            continue;
        }
        solve(ws, li, true);
        if let (Some(b), Some(s)) = (ws.beta_ridge.get_mut(ri), solved.get_mut(ri)) {
            *b = ws.beta;
            *s = true;
        }
    }
    let n_out = ws.n_out;
    for (m, p) in data.iter().zip(poses) {
        if p.suspect || !fits(m, act) {
            continue;
        }
        let Some(side) = sides.iter_mut().find(|s| s.fold == usize::from(p.fold)) else {
            continue;
        };
        let y = targets(m, p, sw, n_out);
        load_features(ws, p, li);
        for ((e_r, beta), _) in side
            .err
            .iter_mut()
            .zip(&ws.beta_ridge)
            .zip(solved)
            .filter(|&(_, s)| s)
        {
            for c in 0..n_out / 6 {
                let pred = predict_with(&ws.phi, beta, act, &[true; 2], c);
                let e = class_sq(&part(&y, c), &pred);
                if let Some([e0, e1]) = e_r.get_mut(2 * c..2 * c + 2) {
                    *e0 += e[0];
                    *e1 += e[1];
                }
            }
        }
    }
}

/// Choices of every check in use (`[check][component type]`) for one outer fold.
type Choices = [[Choice; 2]; 2];

/// [`choose`] for every outer fold at once (`folds ≤ STORED_FOLDS`) and every check in use
/// (`ws.n_out`), bit for bit: per length scale every fold's Gram is built once
/// ([`fold_grams`]) and copied where [`choose`] rebuilds it. Inner fold `g` of outer fold
/// `f` trains on every fold but `f` and `g`, the training set of inner fold `f` of outer
/// fold `g`, in the same bits ([`training`]): each pair `f < g` is factored and solved once
/// (at every ridge) and validated on `g` for `f` and on `f` for `g`. Pairs run in
/// lexicographic order, so each outer fold still receives its inner folds' errors in
/// increasing fold order, row by row, as [`choose`] sums them; the hyperparameters are
/// compared in the same order (length scale, then ridge) as [`choose`] compares them. The
/// checks share the Grams and factors (they depend on the features only), each has its own
/// right-hand sides and errors.
#[allow(clippy::too_many_arguments)]
fn choose_all<const N: usize>(
    ws: &mut SmoothWorkspace,
    data: &[Measurement<N>],
    poses: &[PoseDiagnosis],
    sw: &[f64; 6],
    act: &[bool; 2],
    folds: usize,
    choices: &mut [Choices; STORED_FOLDS],
) {
    let mut err = [[[[0.0f64; 4]; R]; L]; STORED_FOLDS];
    let mut ok = [[[true; R]; L]; STORED_FOLDS];
    let k = folds.min(STORED_FOLDS);
    for li in 0..L {
        fold_grams(ws, data, poses, sw, act, folds, li);
        for f in 0..k {
            ws.g_out = ws.g_folds[f];
            ws.r_out = ws.r_folds[f];
            for g in f + 1..k {
                ws.g_in = ws.g_folds[g];
                ws.r_in = ws.r_folds[g];
                // Outer fold f's errors (f < g) in the first part, outer fold g's first in
                // the second.
                let (err_f, err_g) = err.split_at_mut(g);
                let (ok_f, ok_g) = ok.split_at_mut(g);
                let (Some(ef), Some(eg), Some(of), Some(og)) = (
                    err_f.get_mut(f),
                    err_g.first_mut(),
                    ok_f.get_mut(f),
                    ok_g.first_mut(),
                ) else {
                    continue;
                };
                let mut sides = [
                    Side {
                        fold: g,
                        err: &mut ef[li],
                        ok: &mut of[li],
                    },
                    Side {
                        fold: f,
                        err: &mut eg[li],
                        ok: &mut og[li],
                    },
                ];
                validate_ridges(ws, data, poses, sw, act, li, &mut sides);
            }
        }
    }
    let n_out = ws.n_out;
    for (f, choice) in choices.iter_mut().enumerate().take(folds) {
        let mut best = zero_model(data, poses, sw, act, n_out, f);
        for (c, best) in best.iter_mut().enumerate().take(n_out / 6) {
            for li in 0..L {
                for (ri, &lambda) in RIDGES.iter().enumerate() {
                    for t in 0..2 {
                        let e = err[f][li][ri][2 * c + t];
                        if ok[f][li][ri] && e < best[t].0 {
                            best[t] = (e, Some((li, lambda)));
                        }
                    }
                }
            }
        }
        *choice = best.map(|b| [b[0].1, b[1].1]);
    }
}

/// Every fold's Gram and right-hand side at length scale `li` into `ws.g_folds`/`r_folds`
/// (`folds ≤ STORED_FOLDS`), each the sum over its fitted poses in row order, as
/// [`fold_gram`] builds one.
#[allow(clippy::too_many_arguments)]
fn fold_grams<const N: usize>(
    ws: &mut SmoothWorkspace,
    data: &[Measurement<N>],
    poses: &[PoseDiagnosis],
    sw: &[f64; 6],
    act: &[bool; 2],
    folds: usize,
    li: usize,
) {
    for (g, r) in ws.g_folds.iter_mut().zip(ws.r_folds.iter_mut()).take(folds) {
        *g = [[0.0; M]; M];
        *r = [[0.0; OUT]; M];
    }
    let n_out = ws.n_out;
    for (m, p) in data.iter().zip(poses) {
        let f = usize::from(p.fold);
        if p.suspect || f >= folds || !fits(m, act) {
            continue;
        }
        let y = targets(m, p, sw, n_out);
        load_features(ws, p, li);
        let SmoothWorkspace {
            g_folds,
            r_folds,
            phi,
            ..
        } = ws;
        if let (Some(g), Some(r)) = (g_folds.get_mut(f), r_folds.get_mut(f)) {
            accumulate(g, r, phi, &y, n_out);
        }
    }
}

/// The check on the diagnosis's held-out baseline residuals (`poses[l].heldout_baseline`,
/// folds in `poses[l].fold`), with the nominal arm `robot` for the task-space terms:
/// `base` is the baseline's accumulator (its expected totals at the noise floor); the
/// folds and the significance threshold are the configuration's. Uses `poses[l].scratch`.
/// Never fails: a check that cannot run is returned with `evaluated = false`. (The
/// diagnosis calls [`check_both`]; this is its one-check form, for the tests.)
#[cfg(test)]
pub(crate) fn check<const N: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    poses: &mut [PoseDiagnosis],
    noise: &NoiseFloor,
    base: &ModelAcc,
    cfg: &Config,
    ws: &mut SmoothWorkspace,
) -> SmoothCheck {
    check_both(robot, data, poses, noise, base, None, cfg, ws).0
}

/// Swaps every pose's `heldout_baseline` and `heldout_final`: the verdict's check run as
/// the baseline's, every helper reading one field.
fn swap_residuals(poses: &mut [PoseDiagnosis]) {
    for p in poses.iter_mut() {
        core::mem::swap(&mut p.heldout_baseline, &mut p.heldout_final);
    }
}

/// [`check`], and with `remaining` (the verdict's accumulator) the same check on the
/// verdict's held-out residuals (`heldout_final`): does a smooth function of q still
/// explain part of what the chosen effects leave? The two checks' outputs are each bit for
/// bit what the check run alone on its residuals gives: with up to [`STORED_FOLDS`] folds
/// they share the features, the Grams and the ridge factorisations of the nested
/// cross-validation (which depend on the poses' features only; each check has its own
/// right-hand sides, errors and choices), with more folds the verdict's check runs again
/// on swapped residual fields. `poses[l].scratch` is left as the last check leaves it.
#[allow(clippy::too_many_arguments)]
pub(crate) fn check_both<const N: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    poses: &mut [PoseDiagnosis],
    noise: &NoiseFloor,
    base: &ModelAcc,
    remaining: Option<&ModelAcc>,
    cfg: &Config,
    ws: &mut SmoothWorkspace,
) -> (SmoothCheck, Option<SmoothCheck>) {
    let stored_path = stored_path(ws, cfg.folds);
    let shared = remaining.is_some() && stored_path;
    ws.n_out = if shared { OUT } else { 6 };
    let first = match prepare(robot, data, poses, noise, cfg, ws) {
        None => SmoothCheck::default(),
        Some((sw, act)) => {
            let mut stored = [[[None; 2]; 2]; STORED_FOLDS];
            if stored_path {
                choose_all(ws, data, poses, &sw, &act, cfg.folds, &mut stored);
            }
            let first = outer_folds(ws, data, poses, noise, base, cfg, &sw, &act, &stored, 0);
            if let (true, Some(acc)) = (shared, remaining) {
                // The verdict's right-hand sides are the second six; its outputs from swapped
                // fields, so the summary reads its residuals.
                let second = outer_folds(ws, data, poses, noise, acc, cfg, &sw, &act, &stored, 1);
                ws.n_out = 6;
                return (first, Some(second));
            }
            first
        }
    };
    ws.n_out = 6;
    let second = remaining.map(|acc| {
        swap_residuals(poses);
        let out = check_both(robot, data, poses, noise, acc, None, cfg, ws).0;
        swap_residuals(poses);
        out
    });
    (first, second)
}

/// The check's data-dependent set-up shared by every check in use: whitening `sw`, active
/// component types `act`, the input and task-space scales, the random features, each
/// fitted pose's features (`PoseDiagnosis::smooth`) and the Grams over all fitted poses per
/// length scale (`ws.g_all`, `ws.r_all` with `ws.n_out` outputs). `None` when the check
/// cannot run.
// Long by design: the input scale, the task-space scale and the random features share the
// caller's workspace and the fitted-pose filter (no heap).
fn prepare<const N: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    poses: &mut [PoseDiagnosis],
    noise: &NoiseFloor,
    cfg: &Config,
    ws: &mut SmoothWorkspace,
) -> Option<([f64; 6], [bool; 2])> {
    let folds = cfg.folds;
    let out = None;
    let (sp, sr) = (noise.sigma_pos_m, noise.sigma_rot_rad);
    if folds < 3 || data.len() != poses.len() || N > MAX_JOINTS || 2 * N + TASK + 4 > M {
        return out;
    }
    ws.n_linear = 2 * N;
    let wp = if sp > 0.0 && sp.is_finite() {
        1.0 / sp
    } else {
        0.0
    };
    let wr = if sr > 0.0 && sr.is_finite() {
        1.0 / sr
    } else {
        0.0
    };
    let sw = [wp, wp, wp, wr, wr, wr];
    let mut act = active_classes(data);
    act[0] &= wp > 0.0;
    act[1] &= wr > 0.0;

    // Input scale: RMS pairwise distance of x(q) = √(2·Σ var(x_i)).
    let mut mean = [0.0; X];
    let mut n_fit = 0usize;
    for m in data.iter().filter(|m| fits(m, &act)) {
        for (pair, &qi) in mean.chunks_exact_mut(2).zip(m.state.q.iter()) {
            let (s, c) = sin_cos(qi);
            if let [a, b] = pair {
                *a += s;
                *b += c;
            }
        }
        n_fit += 1;
    }
    if n_fit < 2 * folds || !(act[0] || act[1]) {
        return out;
    }
    for v in &mut mean {
        *v /= n_fit as f64;
    }
    let mut var = 0.0;
    for m in data.iter().filter(|m| fits(m, &act)) {
        for (pair, &qi) in mean.chunks_exact(2).zip(m.state.q.iter()) {
            let (s, c) = sin_cos(qi);
            if let [a, b] = pair {
                var += (s - a) * (s - a) + (c - b) * (c - b);
            }
        }
    }
    let d0 = sqrt(2.0 * var / n_fit as f64);
    if !(d0 > 1e-9 && d0.is_finite()) {
        return out;
    }
    let inv_l0 = 1.0 / d0;
    // Task-space centring and scale: mean and RMS spread of the nominal tool position.
    let (mut pm, mut count) = ([0.0; 3], 0usize);
    for m in data.iter().filter(|m| fits(m, &act)) {
        if let Ok(t) = robot.fk(&m.state) {
            for (a, v) in pm.iter_mut().zip(t.translation.vector.iter()) {
                *a += v;
            }
            count += 1;
        }
    }
    let mut spread = 0.0;
    if count > 0 {
        for a in &mut pm {
            *a /= count as f64;
        }
        for m in data.iter().filter(|m| fits(m, &act)) {
            if let Ok(t) = robot.fk(&m.state) {
                spread += t
                    .translation
                    .vector
                    .iter()
                    .zip(&pm)
                    .map(|(v, a)| (v - a) * (v - a))
                    .sum::<f64>();
            }
        }
        spread = sqrt(spread / (3 * count) as f64);
    }
    ws.task_mean = pm;
    ws.task_scale = if spread > 0.0 && spread.is_finite() {
        1.0 / spread
    } else {
        0.0
    };

    // Random features (fixed seed).
    let mut rng = SplitMix64::new(FEATURE_SEED);
    for (w, b) in ws
        .omega
        .iter_mut()
        .zip(ws.phase.iter_mut())
        .skip(2 * N + TASK)
    {
        for (k, wk) in w.iter_mut().enumerate() {
            // Draw every coordinate so the features do not depend on N's padding.
            let z = rng.normal();
            *wk = if k < 2 * N { z } else { 0.0 };
        }
        *b = 2.0 * core::f64::consts::PI * rng.uniform();
    }

    // Each fitted pose's features at every length scale, once.
    for (m, p) in data.iter().zip(poses.iter_mut()) {
        if fits(m, &act) {
            project(ws, robot, &m.state);
            stash_features(ws, p, inv_l0);
        }
    }

    // Grams over all fitted poses, one per length scale.
    for li in 0..L {
        fold_gram(ws, data, poses, &sw, &act, None, li, false);
        if let (Some(g), Some(r)) = (ws.g_all.get_mut(li), ws.r_all.get_mut(li)) {
            *g = ws.g_out;
            *r = ws.r_out;
        }
    }

    Some((sw, act))
}

/// The outer folds of check `c` (0: the baseline's, 1: the verdict's right-hand sides):
/// choose (stored choices, or [`choose`] with more than [`STORED_FOLDS`] folds), fit on the
/// other folds, predict this one; then the outputs ([`summarise`]). `scratch` holds each
/// pose's corrected whitened total; `delta` the change of each type's total.
#[allow(clippy::too_many_arguments)]
fn outer_folds<const N: usize>(
    ws: &mut SmoothWorkspace,
    data: &[Measurement<N>],
    poses: &mut [PoseDiagnosis],
    noise: &NoiseFloor,
    base: &ModelAcc,
    cfg: &Config,
    sw: &[f64; 6],
    act: &[bool; 2],
    stored: &[Choices; STORED_FOLDS],
    c: usize,
) -> SmoothCheck {
    let (folds, z_significance) = (cfg.folds, cfg.z_significance);
    let n_out = ws.n_out;
    let stored_path = stored_path(ws, folds);
    for (m, p) in data.iter().zip(poses.iter_mut()) {
        p.scratch = sq(m, &part(&targets(m, p, sw, n_out), c), &[0.0; 6]);
    }
    let mut delta = [0.0; 2];
    for f in 0..folds {
        let choice = match stored.get(f) {
            Some(s) if stored_path => s.get(c).copied().unwrap_or([None; 2]),
            _ => choose(ws, data, poses, sw, act, folds, f),
        };
        // One fit per distinct choice (both types usually agree).
        for t in 0..2 {
            let Some((li, lambda)) = choice[t] else {
                continue;
            };
            let same = choice[0] == choice[1];
            if t == 1 && same {
                continue;
            }
            let use_class = [t == 0 || same, t == 1 || same];
            // The fold's Gram at the last length scale is still stored ([`choose_all`]
            // builds it the same way, over the same outputs): copied, not rebuilt.
            let SmoothWorkspace {
                g_folds,
                r_folds,
                g_out,
                r_out,
                ..
            } = ws;
            match (g_folds.get(f), r_folds.get(f)) {
                (Some(g), Some(r)) if stored_path && li + 1 == L => {
                    *g_out = *g;
                    *r_out = *r;
                }
                _ => fold_gram(ws, data, poses, sw, act, Some(f), li, false),
            }
            if !factor(ws, li, false, lambda) {
                continue;
            }
            solve(ws, li, false);
            for (m, p) in data.iter().zip(poses.iter_mut()) {
                if p.suspect || usize::from(p.fold) != f || !fits(m, act) {
                    continue;
                }
                let y = part(&targets(m, p, sw, n_out), c);
                load_features(ws, p, li);
                let pred = predict(ws, act, &use_class, c);
                let (before, after) = (class_sq(&y, &[0.0; 6]), class_sq(&y, &pred));
                for (cc, d) in delta.iter_mut().enumerate() {
                    if use_class[cc] && act[cc] {
                        p.scratch += after[cc] - before[cc];
                        *d += after[cc] - before[cc];
                    }
                }
            }
        }
    }
    if c == 1 {
        swap_residuals(poses);
    }
    let out = summarise(data, poses, noise, base, sw, delta, z_significance);
    if c == 1 {
        swap_residuals(poses);
    }
    out
}

/// The outputs from the per-pose corrected totals in `poses[l].scratch` and the change
/// `delta` of each component type's whitened total.
fn summarise<const N: usize>(
    data: &[Measurement<N>],
    poses: &mut [PoseDiagnosis],
    noise: &NoiseFloor,
    base: &ModelAcc,
    sw: &[f64; 6],
    delta: [f64; 2],
    z_significance: f64,
) -> SmoothCheck {
    // The baseline's whitened totals, per type over completely measured poses (as the
    // held-out RMS definitions), and overall.
    let (mut b_type, mut n_type) = ([0.0; 2], [0usize; 2]);
    let (mut q_base, mut q_smooth) = (0.0, 0.0);
    for (m, p) in data.iter().zip(poses.iter()).filter(|(_, p)| !p.suspect) {
        let y = target(m, p, sw);
        let b = class_sq(&y, &[0.0; 6]);
        for (c, range) in CLASSES.iter().enumerate() {
            if range.clone().all(|k| m.mask.has(k)) {
                b_type[c] += b[c];
                n_type[c] += 1;
            }
        }
        q_base += sq(m, &y, &[0.0; 6]);
        q_smooth += p.scratch;
    }
    let rms = |s: f64, n: usize, w: f64| {
        if n == 0 || w <= 0.0 {
            0.0
        } else {
            sqrt(s.max(0.0) / n as f64) / w
        }
    };
    let share = |b: f64, a: f64, floor: f64| {
        if b > floor && b.is_finite() {
            ((b - a) / (b - floor)).clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    let (bp, br) = (
        rms(b_type[0], n_type[0], sw[0]),
        rms(b_type[1], n_type[1], sw[3]),
    );
    let ap = rms(b_type[0] + delta[0], n_type[0], sw[0]);
    let ar = rms(b_type[1] + delta[1], n_type[1], sw[3]);
    let expected = base.expected_pos + base.expected_rot;
    let z = group_wilcoxon(data, poses, sw);
    SmoothCheck {
        evaluated: true,
        share_of_gap: share(
            sqrt(q_base),
            sqrt(q_smooth.max(0.0)),
            sqrt(expected.max(0.0)),
        ),
        share_pos: share(bp, ap, noise.rms_pos_m()),
        share_rot: share(br, ar, noise.rms_rot_rad()),
        heldout_rms_pos_m: ap,
        heldout_rms_rot_rad: ar,
        heldout_chi2: q_smooth,
        z,
        significant: z > z_significance,
    }
}

/// Paired Wilcoxon signed-rank z over groups of `D_g = S_g^baseline − S_g^smooth`
/// (normal approximation, zero differences dropped, mid-ranks, tie correction) by the
/// shared [`super::rank::signed_rank_z`], O(n + G log G). Overwrites `scratch`.
fn group_wilcoxon<const N: usize>(
    data: &[Measurement<N>],
    poses: &mut [PoseDiagnosis],
    sw: &[f64; 6],
) -> f64 {
    // Per pose D_l, then added into its leader in row order (a leader is the first row of
    // its group, so it precedes its members and still holds its own sum when they arrive).
    for (m, p) in data.iter().zip(poses.iter_mut()) {
        // Suspect rows (gross outliers) take no part, as in every other test.
        p.scratch = if p.suspect {
            0.0
        } else {
            sq(m, &target(m, p, sw), &[0.0; 6]) - p.scratch
        };
    }
    for l in 0..poses.len() {
        let (lead, d) = (poses[l].leader as usize, poses[l].scratch);
        if lead < l
            && let Some(p) = poses.get_mut(lead)
        {
            p.scratch += d;
        }
    }
    // Compact the non-zero group totals into the first records (slot g ≤ l: read first).
    let mut g = 0;
    for l in 0..poses.len() {
        let d = poses[l].scratch;
        if poses[l].leader as usize == l && d != 0.0 {
            poses[g].scratch = d;
            g += 1;
        }
    }
    poses.get_mut(..g).map_or(0.0, super::rank::signed_rank_z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::boxed::Box;
    use std::vec;
    use std::vec::Vec;

    /// The block factor equals the one-row-at-a-time one bit for bit, with and
    /// without the inner fold, at every ridge, and both refuse the same singular matrix.
    #[test]
    fn block_factor_is_the_row_factor_bit_for_bit() {
        let mut ws = Box::new(SmoothWorkspace::new());
        let mut rng = SplitMix64::new(11);
        let mut phi = [0.0; M];
        for r in 0..90 {
            for v in phi.iter_mut() {
                *v = rng.normal();
            }
            let mut y = [0.0; OUT];
            y[..6].copy_from_slice(&[rng.normal(), 0.0, 1.0, -0.5, rng.normal(), 0.25]);
            accumulate(&mut ws.g_all[0], &mut ws.r_all[0], &phi, &y, 6);
            match r % 3 {
                0 => accumulate(&mut ws.g_out, &mut ws.r_out, &phi, &y, 6),
                1 => accumulate(&mut ws.g_in, &mut ws.r_in, &phi, &y, 6),
                _ => {}
            }
        }
        for inner in [false, true] {
            for lambda in RIDGES {
                assert!(factor(&mut ws, 0, inner, lambda));
                let paired = ws.chol;
                ws.chol = [[0.0; M]; M];
                assert!(factor_by_rows(&mut ws, 0, inner, lambda));
                for (a, b) in paired.iter().zip(&ws.chol) {
                    for (x, y) in a.iter().zip(b) {
                        assert_eq!(x.to_bits(), y.to_bits(), "{inner} {lambda}");
                    }
                }
            }
        }
        // The training set of 30 rows only (all minus both folds) and no ridge: singular.
        ws.g_all[1] = ws.g_all[0];
        assert!(!factor(&mut ws, 1, true, 0.0));
        assert!(!factor_by_rows(&mut ws, 1, true, 0.0));
    }

    /// A diagnosis of a simulated ARIA session (90 poses, 30 repeated) and what it leaves.
    struct Simulated {
        data: Vec<Measurement<6>>,
        poses: Vec<PoseDiagnosis>,
        ws: Box<crate::diagnosis::DiagWorkspace<80>>,
        d: crate::diagnosis::Diagnosis<6>,
    }

    /// [`Simulated`] for a perturbed ARIA with `effect` (unit strength) from `seed`.
    #[allow(clippy::unwrap_used)]
    fn simulated_diagnosis(effect: Option<crate::Effect>, seed: u64, dc: &Config) -> Simulated {
        use crate::sim::{SessionConfig, add_effect, perturb_geometry, simulate_session};
        use crate::{Transform, aria};
        let nominal = aria::nominal();
        let mut rng = SplitMix64::new(seed);
        let mut truth = perturb_geometry(&nominal, 5e-3, 0.08, &mut rng).unwrap();
        if let Some(e) = effect {
            add_effect(&mut truth, e, 1.0, &mut rng).unwrap();
        }
        let cfg = SessionConfig {
            poses: 90,
            repeated: 30,
            ..SessionConfig::blind_training()
        };
        let n = cfg.measurements();
        let mut data = vec![Measurement::new([0.0; 6], Transform::identity()); n];
        let mut groups = vec![0u32; n];
        let q0 = aria::TOOL_SEED_Q;
        simulate_session(&truth, &q0, &cfg, &mut rng, &mut data, &mut groups).unwrap();
        let mut poses = vec![PoseDiagnosis::default(); n];
        // SAFETY: all-zero is a valid DiagWorkspace (documented).
        let mut ws: Box<crate::diagnosis::DiagWorkspace<80>> =
            unsafe { Box::new_zeroed().assume_init() };
        let d =
            crate::diagnosis::diagnose(&nominal, &data, &groups, dc, &mut poses, &mut ws).unwrap();
        Simulated { data, poses, ws, d }
    }

    /// The stored-Gram path ([`choose_all`]) chooses what the rebuilding path ([`choose`])
    /// chooses for every outer fold, on the features and Grams a real diagnosis leaves in
    /// the workspace (a simulated joint compliance, 5 folds), and some choice is a smooth
    /// model (the comparison is not between two zero models).
    #[test]
    #[allow(clippy::unwrap_used)]
    fn stored_fold_grams_choose_as_rebuilt_ones() {
        let nominal = crate::aria::nominal();
        let dc = Config::default();
        let Simulated {
            data,
            mut poses,
            mut ws,
            d,
        } = simulated_diagnosis(Some(crate::Effect::JointCompliance), 120, &dc);
        assert!(d.explainable.evaluated);
        // The baseline's check again, so the workspace holds its features and Grams.
        let base = ws.acc[0];
        let again = check(
            &nominal,
            &data,
            &mut poses,
            &d.noise,
            &base,
            &dc,
            &mut ws.smooth,
        );
        assert_eq!(again, d.explainable);
        let (wp, wr) = (1.0 / d.noise.sigma_pos_m, 1.0 / d.noise.sigma_rot_rad);
        let sw = [wp, wp, wp, wr, wr, wr];
        let act = active_classes(&data);
        let mut all = [[[None; 2]; 2]; STORED_FOLDS];
        choose_all(&mut ws.smooth, &data, &poses, &sw, &act, dc.folds, &mut all);
        let mut smooth_models = 0;
        for (f, stored) in all.iter().enumerate().take(dc.folds) {
            let rebuilt = choose(&mut ws.smooth, &data, &poses, &sw, &act, dc.folds, f);
            let bits = |c: &[Choice; 2]| c.map(|x| x.map(|(li, l)| (li, l.to_bits())));
            assert_eq!(bits(&stored[0]), bits(&rebuilt), "fold {f}");
            smooth_models += stored[0].iter().filter(|c| c.is_some()).count();
        }
        assert!(smooth_models > 0);

        // Both checks in one run (shared features, Grams and factors, two sets of
        // right-hand sides) against each run alone, the verdict's on swapped fields: the same
        // outputs bit for bit, and the same per-pose scratch (the last check's).
        let acc = ws.acc[1];
        let bits = |c: &SmoothCheck| {
            [
                c.share_of_gap,
                c.share_pos,
                c.share_rot,
                c.heldout_rms_pos_m,
                c.heldout_rms_rot_rad,
                c.heldout_chi2,
                c.z,
            ]
            .map(f64::to_bits)
        };
        for p in poses.iter_mut() {
            // A remainder unlike the baseline's, so the two checks differ.
            p.heldout_final = p.heldout_baseline.map(|v| 0.5 * v + 1e-5);
        }
        let (a, b) = check_both(
            &nominal,
            &data,
            &mut poses,
            &d.noise,
            &base,
            Some(&acc),
            &dc,
            &mut ws.smooth,
        );
        let b = b.unwrap();
        let scratch: std::vec::Vec<u64> = poses.iter().map(|p| p.scratch.to_bits()).collect();
        let alone_a = check(
            &nominal,
            &data,
            &mut poses,
            &d.noise,
            &base,
            &dc,
            &mut ws.smooth,
        );
        swap_residuals(&mut poses);
        let alone_b = check(
            &nominal,
            &data,
            &mut poses,
            &d.noise,
            &acc,
            &dc,
            &mut ws.smooth,
        );
        swap_residuals(&mut poses);
        assert!(a.evaluated && b.evaluated);
        assert_eq!(bits(&a), bits(&alone_a));
        assert_eq!(bits(&b), bits(&alone_b));
        assert_ne!(bits(&a), bits(&b));
        let alone: std::vec::Vec<u64> = poses.iter().map(|p| p.scratch.to_bits()).collect();
        assert_eq!(scratch, alone);
    }

    /// Fits shared by fold pairs ([`choose_all`], `G_all − (G_out + G_in)`) against the
    /// former computation (the tests-only reference order `G_all − G_out − G_in`, each outer
    /// fold's inner fits its own, [`choose`] per fold): on diagnoses of simulated sessions
    /// (a joint compliance, a cyclic error, no effect; 120 measurements, 5 folds) the same
    /// hyperparameters for every outer fold, and both checks' outputs bit for bit: the
    /// order changes the inner fits' last bits only, and those only choose the
    /// hyperparameters; the outputs come from the outer fits, whose arithmetic is unchanged.
    /// The choices include smooth models, so the comparison is not between zero models.
    #[test]
    #[allow(clippy::unwrap_used)]
    fn pair_fits_match_the_former_order() {
        use crate::Effect;
        let mut smooth_models = 0;
        for (effect, seed) in [
            (Some(Effect::JointCompliance), 120),
            (Some(Effect::JointCyclic), 7),
            (None, 3),
        ] {
            let nominal = crate::aria::nominal();
            let dc = Config::default();
            let Simulated {
                data,
                mut poses,
                mut ws,
                d,
            } = simulated_diagnosis(effect, seed, &dc);
            let (base, acc) = (ws.acc[0], ws.acc[1]);
            let what = std::format!("{effect:?}");
            let mut both = |ws: &mut SmoothWorkspace, legacy: bool| {
                ws.legacy = legacy;
                let (a, b) = check_both(
                    &nominal,
                    &data,
                    &mut poses,
                    &d.noise,
                    &base,
                    Some(&acc),
                    &dc,
                    ws,
                );
                (a, b.unwrap())
            };
            let (a, b) = both(&mut ws.smooth, false);
            // The diagnosis's own check is the shared one.
            assert_eq!(a, d.explainable, "{what}");
            let (a0, b0) = both(&mut ws.smooth, true);
            assert!(a.evaluated && b.evaluated, "{what}");
            assert_eq!(a, a0, "{what}");
            assert_eq!(b, b0, "{what}");

            // Every outer fold's choices of the baseline's check: shared pairs against the
            // reference, on the features and Grams the baseline's check alone leaves (the
            // reference ran the verdict's check last).
            ws.smooth.legacy = false;
            let alone = check(
                &nominal,
                &data,
                &mut poses,
                &d.noise,
                &base,
                &dc,
                &mut ws.smooth,
            );
            assert_eq!(alone, a, "{what}");
            let (wp, wr) = (1.0 / d.noise.sigma_pos_m, 1.0 / d.noise.sigma_rot_rad);
            let sw = [wp, wp, wp, wr, wr, wr];
            let act = active_classes(&data);
            let mut all = [[[None; 2]; 2]; STORED_FOLDS];
            choose_all(&mut ws.smooth, &data, &poses, &sw, &act, dc.folds, &mut all);
            ws.smooth.legacy = true;
            for (f, stored) in all.iter().enumerate().take(dc.folds) {
                let former = choose(&mut ws.smooth, &data, &poses, &sw, &act, dc.folds, f);
                let bits = |c: &[Choice; 2]| c.map(|x| x.map(|(li, l)| (li, l.to_bits())));
                assert_eq!(bits(&stored[0]), bits(&former), "{what} fold {f}");
                smooth_models += stored[0].iter().filter(|c| c.is_some()).count();
            }
        }
        assert!(smooth_models > 0);
    }

    /// The greedy-free Cholesky and the two triangular solves against the normal equations
    /// themselves: `(G_all − G_out + λ·I)·β = r_all − r_out` with a full symmetric `G`.
    #[test]
    fn ridge_solve_satisfies_its_normal_equations() {
        let mut ws = Box::new(SmoothWorkspace::new());
        let mut rng = SplitMix64::new(5);
        let mut full = [[0.0; M]; M];
        let (mut phi, mut y) = ([0.0; M], [0.0; OUT]);
        ws.n_out = OUT;
        for _ in 0..30 {
            for v in phi.iter_mut() {
                *v = rng.normal();
            }
            for v in y.iter_mut() {
                *v = rng.normal();
            }
            accumulate(&mut ws.g_all[1], &mut ws.r_all[1], &phi, &y, OUT);
            for i in 0..M {
                for j in 0..M {
                    full[i][j] += phi[i] * phi[j];
                }
            }
        }
        // One "fold" removed: the last row.
        let (mut g, mut r) = ([[0.0; M]; M], [[0.0; OUT]; M]);
        accumulate(&mut g, &mut r, &phi, &y, OUT);
        ws.g_out = g;
        ws.r_out = r;
        let lambda = 0.1;
        assert!(factor(&mut ws, 1, false, lambda));
        solve(&mut ws, 1, false);
        for i in 0..M {
            for k in 0..OUT {
                let mut lhs = lambda * ws.beta[i][k];
                for j in 0..M {
                    lhs += (full[i][j] - phi[i] * phi[j]) * ws.beta[j][k];
                }
                let rhs = ws.r_all[1][i][k] - ws.r_out[i][k];
                assert!((lhs - rhs).abs() < 1e-9 * (1.0 + rhs.abs()), "{i} {k}");
            }
        }
        // Six outputs solved alone: the first six of the twelve, bit for bit.
        let twelve = ws.beta;
        ws.n_out = 6;
        solve(&mut ws, 1, false);
        for (a, b) in twelve.iter().zip(&ws.beta) {
            assert_eq!(part(a, 0).map(f64::to_bits), part(b, 0).map(f64::to_bits));
        }
        // The documented size (about 321 KiB).
        let size = core::mem::size_of::<SmoothWorkspace>();
        assert!((315 * 1024..325 * 1024).contains(&size), "{size}");
        // Not positive definite (λ = 0 with fewer rows than features): refused.
        ws.g_all[1] = [[0.0; M]; M];
        ws.g_out = [[0.0; M]; M];
        assert!(!factor(&mut ws, 1, false, 0.0));
    }
}
