//! Robust identification and the residual test: bad poses (a pose recorded with the wrong
//! joint row, a glitch of a few millimetres, a swapped axis) are found, named and kept from
//! pulling the model.
//!
//! **Residual test.** For each pose `l` the position and orientation residuals `e_p`, `e_φ`
//! (measured minus model, exact rotation vector) are standardised by robust scales:
//! `d_l² = |e_p|²/σ_p² + |e_φ|²/σ_φ²` over the measured components (k_l of them). σ_p and
//! σ_φ are per-axis standard deviations estimated from the median of the per-pose norms
//! (the MAD about zero of the norms, normalised by the median of the χ₃ distribution,
//! [`CHI3_MEDIAN`], and corrected for the degrees of freedom the fit uses up), so a minority
//! of bad poses does not inflate them; [`RobustOptions::scale`] can fix them instead (e.g.
//! the instrument's stated noise). For a good pose with Gaussian noise, `d_l²` follows χ²
//! with k_l degrees of freedom; a pose with `d_l²` above [`RobustOptions::suspect_chi2`]
//! (default: the 99.99 % quantile, [`CHI2_9999`]; `d_l` > 5.28 for a full pose, > 4.59 for
//! a position-only pose) is a **suspect**.
//!
//! **Robust fit.** Iteratively reweighted least squares over the per-pose
//! [`Measurement::weight`]: each pose gets `prior weight × w(d_l)` with the Huber weight
//! `w = min(1, c/d)` or the Cauchy weight `w = 1/(1 + d²/c²)`, `c² =`
//! [`RobustOptions::tuning_chi2`] (default the 95 % quantile of χ², [`CHI2_95`]); scales
//! and weights are recomputed after each weighted fit until no weight changes by more than
//! [`RobustOptions::weight_tol`]. Huber's loss is convex, so the iteration is started from
//! the plain least-squares fit; Cauchy's redescends (a gross outlier ends with a weight near
//! zero) but has local minima, so it starts from the converged Huber fit. A pose with prior
//! weight 0 stays out of the fit and out of the scales but is still tested.
//!
//! Memory: the per-pose results go into a caller slice (one [`PoseResidual`] per pose); the
//! weights are written into the caller's data during the iteration and restored before
//! returning, also on error. No heap; medians are exact order statistics found by bisection
//! on the bit patterns of the (non-negative) norms.

use super::constraints::{ConstraintData, Contact, Distance, Group};
use super::data::{Measurement, RowSource, residual_stats};
use super::identifiability::analyze_into;
use super::solvers::{check_identify_options, check_inputs, identify_into};
use super::{Identification, IdentifyOptions, Workspace};
use crate::error::{Error, Quantity, Result, check_finite};
use crate::math::sqrt;
use crate::model::Robot;
use crate::pose::{OrientationError, pose_error};

/// The loss of the robust fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Loss {
    /// Huber: quadratic up to `c`, linear beyond (weight `min(1, c/d)`); convex.
    Huber,
    /// Cauchy (Lorentzian): weight `1/(1 + d²/c²)`; redescending, started from Huber.
    Cauchy,
}

impl Loss {
    /// Both losses.
    pub const ALL: [Loss; 2] = [Loss::Huber, Loss::Cauchy];
    /// Lower-case name (`huber`, `cauchy`).
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Loss::Huber => "huber",
            Loss::Cauchy => "cauchy",
        }
    }
    /// Parses a lower-case name.
    #[must_use]
    pub fn parse(s: &str) -> Option<Self> {
        Loss::ALL.into_iter().find(|l| l.name() == s)
    }
    /// The weight of a pose at standardised residual `d` with threshold `c²`.
    #[must_use]
    pub fn weight(self, d: f64, c2: f64) -> f64 {
        match self {
            Loss::Huber => {
                if d * d <= c2 {
                    1.0
                } else {
                    sqrt(c2) / d
                }
            }
            Loss::Cauchy => 1.0 / (1.0 + d * d / c2),
        }
    }
}

/// Quantiles of χ² with k = 1..6 degrees of freedom at 95 % (index k − 1): the default
/// tuning of the robust weights.
pub const CHI2_95: [f64; 6] = [
    3.841_458_820_694_124,
    5.991_464_547_107_977,
    7.814_727_903_251_177,
    9.487_729_036_781_15,
    11.070_497_693_516_348,
    12.591_587_243_743_977,
];

/// Quantiles of χ² with k = 1..6 degrees of freedom at 99.99 % (index k − 1): the default
/// threshold of the residual test (a good pose is named a suspect once in 10 000).
pub const CHI2_9999: [f64; 6] = [
    15.136_705_226_622_556,
    18.420_680_743_951_472,
    21.107_513_466_159_283,
    23.512_742_444_989_875,
    25.744_831_959_054_878,
    27.856_341_236_012_888,
];

/// Median of the χ distribution with 3 degrees of freedom: the median norm of a 3-D
/// Gaussian vector with unit per-axis standard deviation.
pub const CHI3_MEDIAN: f64 = 1.538_172_254_455_052_2;

/// Options of [`identify_robust`] and [`residual_test`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobustOptions {
    /// The loss.
    pub loss: Loss,
    /// `c²` of the weight function per number of measured components k (index k − 1).
    pub tuning_chi2: [f64; 6],
    /// A pose with `d²` above this (per k, index k − 1) is a suspect.
    pub suspect_chi2: [f64; 6],
    /// Largest number of reweighted fits (per phase: Huber, then Cauchy).
    pub max_reweights: u32,
    /// Converged when no robust weight changes by more than this.
    pub weight_tol: f64,
    /// Fixed per-axis scales `(σ_p [m], σ_φ [rad])` instead of the robust estimate.
    pub scale: Option<(f64, f64)>,
    /// Lower bound of the estimated σ_p \[m\] (noise-free data fit to rounding).
    pub min_scale_pos_m: f64,
    /// Lower bound of the estimated σ_φ \[rad\].
    pub min_scale_rot_rad: f64,
}

impl RobustOptions {
    /// Defaults for `loss`: 95 % tuning, 99.99 % suspect threshold, at most 50 reweighted
    /// fits per phase, weights converged to 1e-6, estimated scales floored at 1 nm / 1 nrad.
    #[must_use]
    pub const fn new(loss: Loss) -> Self {
        RobustOptions {
            loss,
            tuning_chi2: CHI2_95,
            suspect_chi2: CHI2_9999,
            max_reweights: 50,
            weight_tol: 1e-6,
            scale: None,
            min_scale_pos_m: 1e-9,
            min_scale_rot_rad: 1e-9,
        }
    }
}

/// The residual test's view of one pose.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PoseResidual {
    /// The caller's weight of the pose (0: held out).
    pub prior_weight: f64,
    /// |e_p| over the measured position components \[m\] (0 if none).
    pub pos_m: f64,
    /// |e_φ| over the measured orientation components \[rad\] (0 if none).
    pub rot_rad: f64,
    /// Number of measured components k (1..=6).
    pub components: u8,
    /// Standardised residual `d` (see the module documentation).
    pub distance: f64,
    /// Robust weight factor in (0, 1] of the last reweighting (1 for a plain test).
    pub robust_weight: f64,
    /// `d²` above the suspect threshold.
    pub suspect: bool,
}

/// Outcome of [`residual_test`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResidualTest {
    /// Per-axis position scale σ_p used \[m\].
    pub scale_pos_m: f64,
    /// Per-axis orientation scale σ_φ used \[rad\].
    pub scale_rot_rad: f64,
    /// Number of suspects.
    pub n_suspect: usize,
    /// The suspect with the largest `d` (if any).
    pub worst: Option<crate::error::PoseIndex>,
}

/// The result of [`identify_robust`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobustIdentification<const N: usize> {
    /// The final weighted fit (its residual statistics and standard errors are those of the
    /// weighted problem).
    pub fit: Identification<N>,
    /// The residual test at the final model (scales, suspects).
    pub test: ResidualTest,
    /// Reweighted fits performed (both phases).
    pub reweights: u32,
}

/// Index of the order statistic of rank `rank` (0-based) among the non-negative finite
/// values `v(i)` for which `keep(i)`; exact, by bisection on the IEEE bit pattern (which
/// orders non-negative doubles).
fn order_statistic(
    n: usize,
    rank: usize,
    v: impl Fn(usize) -> f64,
    keep: impl Fn(usize) -> bool,
) -> f64 {
    let (mut lo, mut hi) = (0u64, f64::MAX.to_bits());
    // Smallest bit pattern t with count(v <= t) > rank.
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        let t = f64::from_bits(mid);
        let c = (0..n).filter(|&i| keep(i) && v(i) <= t).count();
        if c > rank {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    f64::from_bits(lo)
}

/// Median of the kept values (mean of the two middle ones for an even count); 0 if none.
fn median(n: usize, v: impl Fn(usize) -> f64 + Copy, keep: impl Fn(usize) -> bool + Copy) -> f64 {
    let m = (0..n).filter(|&i| keep(i)).count();
    if m == 0 {
        return 0.0;
    }
    let a = order_statistic(n, (m - 1) / 2, v, keep);
    let b = order_statistic(n, m / 2, v, keep);
    0.5 * (a + b)
}

/// Residual norms of every pose at `robot` into `report` (prior weights untouched).
fn residual_norms<const N: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    report: &mut [PoseResidual],
) -> Result<()> {
    for (m, r) in data.iter().zip(report.iter_mut()) {
        let t = m.model_pose(robot)?;
        let e = pose_error(&m.pose, &t, OrientationError::Exact);
        let (mut p2, mut r2, mut k) = (0.0, 0.0, 0u8);
        for (c, v) in e.iter().enumerate() {
            if m.mask.has(c) {
                k += 1;
                if c < 3 {
                    p2 += v * v;
                } else {
                    r2 += v * v;
                }
            }
        }
        r.pos_m = sqrt(p2);
        r.rot_rad = sqrt(r2);
        r.components = k;
    }
    Ok(())
}

/// The residual test of `robot` on `data`: per-pose standardised residuals and suspects in
/// `report` (`report.len() == data.len()`; `robust_weight` is left as found, set it to 1 for
/// a plain test), the scales in the result. `dof_used` is the number of fitted parameters
/// (for the degrees-of-freedom correction of the estimated scales; 0 for a model that was
/// not fitted to these data).
pub fn residual_test<const N: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    dof_used: usize,
    ropts: &RobustOptions,
    report: &mut [PoseResidual],
) -> Result<ResidualTest> {
    if report.len() != data.len() {
        return Err(Error::DimensionMismatch {
            expected: data.len(),
            found: report.len(),
        });
    }
    super::data::validate(data)?;
    check_options(ropts)?;
    for (m, r) in data.iter().zip(report.iter_mut()) {
        r.prior_weight = m.weight;
    }
    test_at(robot, data, dof_used, ropts, report)
}

fn check_options(ropts: &RobustOptions) -> Result<()> {
    check_finite(&ropts.tuning_chi2, Quantity::Setting)?;
    check_finite(&ropts.suspect_chi2, Quantity::Setting)?;
    let (sp, sr) = ropts.scale.unwrap_or((1.0, 1.0));
    check_finite(
        &[
            ropts.weight_tol,
            sp,
            sr,
            ropts.min_scale_pos_m,
            ropts.min_scale_rot_rad,
        ],
        Quantity::Setting,
    )?;
    let scales = [sp, sr, ropts.min_scale_pos_m, ropts.min_scale_rot_rad];
    let bad = ropts
        .tuning_chi2
        .iter()
        .chain(ropts.suspect_chi2.iter())
        .chain(scales.iter())
        .find(|&&v| v <= 0.0);
    if let Some(&value) = bad {
        return Err(Error::InvalidParameter { index: 0, value });
    }
    if ropts.weight_tol < 0.0 {
        return Err(Error::InvalidParameter {
            index: 0,
            value: ropts.weight_tol,
        });
    }
    Ok(())
}

/// What the scale estimate needs of a row: whether it is in the fit, and its measured
/// position and orientation components.
#[derive(Debug, Clone, Copy)]
struct RowShape {
    used: bool,
    pos: usize,
    rot: usize,
}

fn shape_of<const N: usize>(m: &Measurement<N>) -> RowShape {
    RowShape {
        used: m.weight > 0.0,
        pos: (0..3).filter(|&k| m.mask.has(k)).count(),
        rot: (3..6).filter(|&k| m.mask.has(k)).count(),
    }
}

/// Degrees-of-freedom factor `sqrt(rows/(rows − dof_used))` over the rows in the fit.
fn dof_factor(n: usize, shape: impl Fn(usize) -> RowShape, dof_used: usize) -> f64 {
    let rows: usize = (0..n)
        .map(&shape)
        .filter(|s| s.used)
        .map(|s| s.pos + s.rot)
        .sum();
    if rows > dof_used {
        sqrt(rows as f64 / (rows - dof_used) as f64)
    } else {
        1.0
    }
}

/// Marks `report[l].suspect` from `d²` at scales `(sp, sr)`; returns whether any flag
/// changed.
fn mark(report: &mut [PoseResidual], sp: f64, sr: f64, ropts: &RobustOptions) -> bool {
    let mut changed = false;
    for r in report.iter_mut() {
        let d2 = (r.pos_m / sp) * (r.pos_m / sp) + (r.rot_rad / sr) * (r.rot_rad / sr);
        r.distance = sqrt(d2);
        let k = usize::from(r.components.clamp(1, 6)) - 1;
        let s = d2 > ropts.suspect_chi2[k];
        changed |= s != r.suspect;
        r.suspect = s;
    }
    changed
}

/// Passes of the reweighted scale estimate (it stops earlier when the inliers settle).
const SCALE_PASSES: usize = 8;

/// The robust scales: first from the medians of the norms (MAD about zero, breakdown
/// 50 %), then — far more efficient — the root mean square per component over the poses
/// that the residual test accepts at the current scales, repeated until that set settles.
/// Both are corrected by [`dof_factor`] and floored by the options.
fn estimate_scales(
    shape: impl Fn(usize) -> RowShape + Copy,
    dof_used: usize,
    ropts: &RobustOptions,
    report: &mut [PoseResidual],
) -> (f64, f64) {
    let n = report.len();
    let dof = dof_factor(n, shape, dof_used);
    let floor = |s: f64, min: f64| if s.is_finite() { s.max(min) } else { min };
    let (mp, mr) = {
        let rep: &[PoseResidual] = report;
        (
            median(n, |i| rep[i].pos_m, |i| shape(i).used && shape(i).pos > 0),
            median(n, |i| rep[i].rot_rad, |i| shape(i).used && shape(i).rot > 0),
        )
    };
    let mut sp = floor(mp / CHI3_MEDIAN * dof, ropts.min_scale_pos_m);
    let mut sr = floor(mr / CHI3_MEDIAN * dof, ropts.min_scale_rot_rad);
    mark(report, sp, sr, ropts);
    for _ in 0..SCALE_PASSES {
        let (mut sum_p, mut n_p, mut sum_r, mut n_r) = (0.0, 0usize, 0.0, 0usize);
        for (i, r) in report.iter().enumerate() {
            let s = shape(i);
            if s.used && !r.suspect {
                sum_p += r.pos_m * r.pos_m;
                n_p += s.pos;
                sum_r += r.rot_rad * r.rot_rad;
                n_r += s.rot;
            }
        }
        let new_sp = if n_p > 0 {
            floor(sqrt(sum_p / n_p as f64) * dof, ropts.min_scale_pos_m)
        } else {
            sp
        };
        let new_sr = if n_r > 0 {
            floor(sqrt(sum_r / n_r as f64) * dof, ropts.min_scale_rot_rad)
        } else {
            sr
        };
        sp = new_sp;
        sr = new_sr;
        if !mark(report, sp, sr, ropts) {
            // The same inliers as the scales were computed from: settled.
            break;
        }
    }
    (sp, sr)
}

/// The residual test with `report[..].prior_weight` already set.
fn test_at<const N: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    dof_used: usize,
    ropts: &RobustOptions,
    report: &mut [PoseResidual],
) -> Result<ResidualTest> {
    residual_norms(robot, data, report)?;
    let shape = |i: usize| {
        data.get(i).map_or(
            RowShape {
                used: false,
                pos: 0,
                rot: 0,
            },
            shape_of,
        )
    };
    Ok(test_norms(shape, dof_used, ropts, report))
}

/// The residual test on the norms in `report` (scales, suspects).
fn test_norms(
    shape: impl Fn(usize) -> RowShape + Copy,
    dof_used: usize,
    ropts: &RobustOptions,
    report: &mut [PoseResidual],
) -> ResidualTest {
    let (sp, sr) = match ropts.scale {
        Some(s) => s,
        None => estimate_scales(shape, dof_used, ropts, report),
    };
    let mut out = ResidualTest {
        scale_pos_m: sp,
        scale_rot_rad: sr,
        n_suspect: 0,
        worst: None,
    };
    mark(report, sp, sr, ropts);
    let mut worst = 0.0;
    for (l, r) in report.iter().enumerate() {
        if r.suspect {
            out.n_suspect += 1;
            if r.distance > worst {
                worst = r.distance;
                out.worst = Some(crate::error::PoseIndex(l));
            }
        }
    }
    out
}

/// Robust identification: as [`identify`](super::identify) (same options, same errors for bad or
/// insufficient data), then iteratively reweighted fits with `ropts.loss`, then the residual
/// test at the final model. `report` (`report.len() == data.len()`) receives every pose's
/// residuals, standardised residual, final robust weight and suspect flag. The weights in
/// `data` are restored before returning. More than `ropts.max_reweights` reweighted fits in
/// a phase is [`Error::NotConverged`].
pub fn identify_robust<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &mut [Measurement<N>],
    opts: &IdentifyOptions<'_>,
    ropts: &RobustOptions,
    report: &mut [PoseResidual],
    ws: &mut Workspace<P>,
) -> Result<RobustIdentification<N>> {
    if report.len() != data.len() {
        return Err(Error::DimensionMismatch {
            expected: data.len(),
            found: report.len(),
        });
    }
    super::data::validate(data)?;
    check_options(ropts)?;
    for (m, r) in data.iter().zip(report.iter_mut()) {
        r.prior_weight = m.weight;
        r.robust_weight = 1.0;
    }
    let mut out = RobustIdentification {
        fit: Identification::start(robot, opts.algorithm, None),
        test: ResidualTest {
            scale_pos_m: 0.0,
            scale_rot_rad: 0.0,
            n_suspect: 0,
            worst: None,
        },
        reweights: 0,
    };
    let status = reweighted(robot, data, opts, ropts, report, ws, &mut out);
    for (m, r) in data.iter_mut().zip(report.iter()) {
        m.weight = r.prior_weight;
    }
    status.map(|()| out)
}

/// The iteration of [`identify_robust`], in `out` (the weights in `data` are left changed).
fn reweighted<const N: usize, const P: usize>(
    robot: &Robot<N>,
    data: &mut [Measurement<N>],
    opts: &IdentifyOptions<'_>,
    ropts: &RobustOptions,
    report: &mut [PoseResidual],
    ws: &mut Workspace<P>,
    out: &mut RobustIdentification<N>,
) -> Result<()> {
    // The plain least-squares fit, with its identifiability analysis kept for every
    // reweighted fit (the weights stay positive, so the poses in the fit do not change).
    check_identify_options(opts)?;
    check_inputs(data, opts)?;
    analyze_into(robot, data, opts, ws, &mut out.fit.analysis)?;
    identify_into(data, opts, ws, &mut out.fit)?;
    let rank = out.fit.analysis.rank;
    let phases: &[Loss] = match ropts.loss {
        Loss::Huber => &[Loss::Huber],
        Loss::Cauchy => &[Loss::Huber, Loss::Cauchy],
    };
    for &loss in phases {
        let mut converged = false;
        for _ in 0..ropts.max_reweights {
            test_at(&out.fit.robot, data, rank, ropts, report)?;
            let mut change: f64 = 0.0;
            for (m, r) in data.iter_mut().zip(report.iter_mut()) {
                let k = usize::from(r.components.clamp(1, 6)) - 1;
                let w = loss.weight(r.distance, ropts.tuning_chi2[k]);
                change = change.max((w - r.robust_weight).abs());
                r.robust_weight = w;
                m.weight = r.prior_weight * w;
            }
            if change <= ropts.weight_tol && out.reweights > 0 {
                converged = true;
                break;
            }
            // Warm start from the last fit.
            identify_into(data, opts, ws, &mut out.fit)?;
            out.reweights += 1;
        }
        if !converged {
            return Err(Error::NotConverged {
                iterations: out.reweights,
            });
        }
    }
    // Initial residuals of the reported fit: those of the caller's model, with the final
    // weights.
    out.fit.initial = residual_stats(robot, data, opts)?;
    out.test = test_at(&out.fit.robot, data, rank, ropts, report)?;
    Ok(())
}

/// Robust identification from constraint data: as
/// [`identify_constrained`](super::identify_constrained) (same options and errors), then
/// iteratively reweighted fits with `ropts.loss` over the rows, then the residual test at
/// the final model. Instrument rows are weighted as in [`identify_robust`]; each contact
/// is one row whose residual is its distance to its group's target or plane, estimated
/// from the group's weighted contacts as the fit eliminates it (3 position components for
/// a target, 1 for a plane); known distances keep their weight. The fitted degrees of
/// freedom include 3 per unknown target or plane. `report` (instrument rows, then
/// contacts) receives every row's residual, standardised residual, final robust weight
/// and suspect flag; the weights in `instrument` and `contacts` are restored before
/// returning. Errors: as [`identify_robust`], plus those of the constraint data.
#[allow(clippy::too_many_arguments)]
pub fn identify_constrained_robust<const N: usize, const P: usize>(
    robot: &Robot<N>,
    instrument: &mut [Measurement<N>],
    contacts: &mut [Contact<N>],
    groups: &[Group],
    distances: &[Distance],
    opts: &IdentifyOptions<'_>,
    ropts: &RobustOptions,
    report: &mut [PoseResidual],
    ws: &mut Workspace<P>,
) -> Result<RobustIdentification<N>> {
    let n_inst = instrument.len();
    if report.len() != n_inst + contacts.len() {
        return Err(Error::DimensionMismatch {
            expected: n_inst + contacts.len(),
            found: report.len(),
        });
    }
    check_options(ropts)?;
    let weights = instrument
        .iter()
        .map(|m| m.weight)
        .chain(contacts.iter().map(|c| c.weight));
    for (w, r) in weights.zip(report.iter_mut()) {
        r.prior_weight = w;
        r.robust_weight = 1.0;
    }
    let mut out = RobustIdentification {
        fit: Identification::start(robot, opts.algorithm, None),
        test: ResidualTest {
            scale_pos_m: 0.0,
            scale_rot_rad: 0.0,
            n_suspect: 0,
            worst: None,
        },
        reweights: 0,
    };
    let mut rows = ContactRows {
        instrument,
        contacts,
        groups,
        distances,
    };
    let status = reweighted_constrained(robot, &mut rows, opts, ropts, report, ws, &mut out);
    let (inst, cont) = report.split_at(n_inst);
    for (m, r) in rows.instrument.iter_mut().zip(inst) {
        m.weight = r.prior_weight;
    }
    for (c, r) in rows.contacts.iter_mut().zip(cont) {
        c.weight = r.prior_weight;
    }
    status.map(|()| out)
}

/// Constraint data whose row weights the iteration changes.
struct ContactRows<'a, const N: usize> {
    instrument: &'a mut [Measurement<N>],
    contacts: &'a mut [Contact<N>],
    groups: &'a [Group],
    distances: &'a [Distance],
}

impl<const N: usize> ContactRows<'_, N> {
    fn view(&self) -> ConstraintData<'_, N> {
        ConstraintData {
            instrument: self.instrument,
            contacts: self.contacts,
            groups: self.groups,
            distances: self.distances,
            sessions: &[],
        }
    }

    /// Row `i` (instrument rows, then contacts) for the scale estimate.
    fn shape(&self, i: usize) -> RowShape {
        let none = RowShape {
            used: false,
            pos: 0,
            rot: 0,
        };
        match i.checked_sub(self.instrument.len()) {
            None => self.instrument.get(i).map_or(none, shape_of),
            Some(c) => {
                let g = self.groups.partition_point(|g| g.start + g.len <= c);
                match (self.contacts.get(c), self.groups.get(g)) {
                    (Some(contact), Some(grp)) => RowShape {
                        used: contact.weight > 0.0,
                        pos: if grp.kind.is_target() { 3 } else { 1 },
                        rot: 0,
                    },
                    _ => none,
                }
            }
        }
    }

    /// Unknown targets and planes (3 eliminated coordinates each).
    fn nuisance_dof(&self) -> usize {
        3 * self.groups.iter().filter(|g| !g.kind.is_known()).count()
    }
}

/// The residual test of constraint data at `robot` (`report[..].prior_weight` set).
fn test_contacts<const N: usize>(
    robot: &Robot<N>,
    rows: &ContactRows<'_, N>,
    dof_used: usize,
    ropts: &RobustOptions,
    report: &mut [PoseResidual],
) -> Result<ResidualTest> {
    let n_inst = rows.instrument.len();
    let (inst, cont) = report.split_at_mut(n_inst);
    residual_norms(robot, rows.instrument, inst)?;
    let mut norms = [0.0; 64];
    // Contacts in chunks: their residual norms need no heap.
    let view = rows.view();
    let mut from = 0;
    while from < cont.len() {
        let to = (from + norms.len()).min(cont.len());
        contact_norms(
            robot,
            &view,
            from,
            norms.get_mut(..to - from).unwrap_or(&mut []),
        )?;
        for (r, (c, &e)) in cont
            .get_mut(from..to)
            .unwrap_or(&mut [])
            .iter_mut()
            .zip(norms.iter())
            .enumerate()
        {
            c.pos_m = e;
            c.rot_rad = 0.0;
            c.components = rows.shape(n_inst + from + r).pos as u8;
        }
        from = to;
    }
    Ok(test_norms(
        |i| rows.shape(i),
        dof_used + rows.nuisance_dof(),
        ropts,
        report,
    ))
}

/// The residual distances of contacts `from..from + out.len()`.
fn contact_norms<const N: usize>(
    robot: &Robot<N>,
    data: &ConstraintData<'_, N>,
    from: usize,
    out: &mut [f64],
) -> Result<()> {
    super::constraints::contact_residuals_range(robot, data, from, out)
}

/// The iteration of [`identify_constrained_robust`] (the weights in `rows` are left
/// changed).
fn reweighted_constrained<const N: usize, const P: usize>(
    robot: &Robot<N>,
    rows: &mut ContactRows<'_, N>,
    opts: &IdentifyOptions<'_>,
    ropts: &RobustOptions,
    report: &mut [PoseResidual],
    ws: &mut Workspace<P>,
    out: &mut RobustIdentification<N>,
) -> Result<()> {
    // The plain fit and its analysis (kept: the weights stay positive).
    out.fit = super::constraints::identify_constrained(robot, &rows.view(), opts, ws)?;
    let rank = out.fit.analysis.rank;
    let phases: &[Loss] = match ropts.loss {
        Loss::Huber => &[Loss::Huber],
        Loss::Cauchy => &[Loss::Huber, Loss::Cauchy],
    };
    let n_inst = rows.instrument.len();
    for &loss in phases {
        let mut converged = false;
        for _ in 0..ropts.max_reweights {
            test_contacts(&out.fit.robot, rows, rank, ropts, report)?;
            let mut change: f64 = 0.0;
            for (i, r) in report.iter_mut().enumerate() {
                let k = usize::from(r.components.clamp(1, 6)) - 1;
                let w = loss.weight(r.distance, ropts.tuning_chi2[k]);
                change = change.max((w - r.robust_weight).abs());
                r.robust_weight = w;
                let weight = r.prior_weight * w;
                match i.checked_sub(n_inst) {
                    None => {
                        if let Some(m) = rows.instrument.get_mut(i) {
                            m.weight = weight;
                        }
                    }
                    Some(c) => {
                        if let Some(c) = rows.contacts.get_mut(c) {
                            c.weight = weight;
                        }
                    }
                }
            }
            if change <= ropts.weight_tol && out.reweights > 0 {
                converged = true;
                break;
            }
            // Warm start from the last fit.
            identify_into(&rows.view(), opts, ws, &mut out.fit)?;
            out.reweights += 1;
        }
        if !converged {
            return Err(Error::NotConverged {
                iterations: out.reweights,
            });
        }
    }
    out.fit.initial = RowSource::stats(&rows.view(), robot, opts)?;
    out.test = test_contacts(&out.fit.robot, rows, rank, ropts, report)?;
    Ok(())
}
