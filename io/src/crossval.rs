//! K-fold cross-validation of a pose calibration (`kincal crossval`, Python's
//! `kincal.crossval`): held-out residuals of the nominal geometry and of the calibrated model
//! (folds by pose_id), the noise floor (repeats, or an upper bound from the residuals), and
//! the outliers a robust fit names. Every number comes from the core:
//! `frames::estimate_frames`, `identify::identify`, `identify::identify_robust`,
//! `validation::{PoseErrors, ErrorSummary}`, `noise::{pooled_repeat_scatter,
//! residual_sigma}` (the diagnosis's noise-floor estimator). [`run`] computes a [`Study`];
//! [`json`] is its report as data (`crossval --json`); front ends add only the text.
//!
//! Units: metres and radians in [`Study`]; the JSON's fields say theirs (`_mm`, `_deg`).

use kincal::identify::{
    Algorithm, Identifiability, IdentifyOptions, Loss, Measurement, PoseResidual, Prior,
    PriorSizes, RobustIdentification, RobustOptions, identify, identify_robust,
};
use kincal::noise::{pooled_repeat_scatter, repeat_leader, residual_sigma};
use kincal::validation::{ErrorSummary, PoseErrors};
use kincal::{Effect, EffectSet, ParamSet, Robot};
use rayon::prelude::*;
use serde_json::{Value, json};

use crate::calibration::new_workspace;
use crate::data;
use crate::effects_arg::EffectChoice;
use crate::error::Error;
use crate::measurements::MeasurementSet;
use crate::units::param_label;

/// The sizes `crossval --prior auto` tries (mm, deg), from tight to loose: the default
/// scaled by 1/4 … 8 (the last is practically no prior on well-excited data).
pub const PRIOR_AUTO_GRID: [(f64, f64); 6] = [
    (1.25, 0.25),
    (2.5, 0.5),
    (5.0, 1.0),
    (10.0, 2.0),
    (20.0, 4.0),
    (40.0, 8.0),
];

/// How the rows are weighted (Σ w_pos·|Δp|² + w_rot·|Δφ|²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Weighting {
    /// The instrument's noise, 1σ per axis [mm], [deg]: w = 1/σ².
    Stated { pos_mm: f64, rot_deg: f64 },
    /// 1 per m² and 1 per rad² (the paper's).
    Unit,
    /// 1/σ² with σ the calibrated model's dof-corrected RMS residual per axis on all poses,
    /// iterated to a fixed point.
    Residual,
}

/// The prior of the calibrated model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PriorChoice {
    None,
    /// These sizes around the initial model.
    Sizes(PriorSizes),
    /// The tightest size of [`PRIOR_AUTO_GRID`] within 2 % of the best held-out score;
    /// `template` gives the frame and effect sizes the search applies to every grid size.
    Auto {
        template: PriorSizes,
    },
}

/// What a front end asks of a cross-validation.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Effects identified with the geometry (base_frame/tool_frame also in the nominal model).
    pub effects: EffectSet,
    /// The joints (0-based) whose scale is identified when `effects` has joint_scale
    /// (`--effects joint_scale@JOINT`); `None`: every joint.
    pub scale_joints: Option<Vec<usize>>,
    /// Estimate the base and tool frames from each fold's training poses first.
    pub init_frames: bool,
    /// Folds (2 or more; at most the number of pose groups).
    pub folds: usize,
    /// Seed of the fold assignment.
    pub seed: u64,
    /// Geometric parameter kinds of the calibrated model (`theta0`, `d`, `a`, `alpha`).
    pub geometry: Vec<String>,
    pub weighting: Weighting,
    /// Fit every model robustly with this loss (the outlier fit uses it too; default Cauchy).
    pub robust: Option<Loss>,
    /// Iteration limit of each fit.
    pub max_iterations: u32,
    pub prior: PriorChoice,
}

impl Default for Options {
    /// The CLI's defaults: 5 folds, seed 1, every geometric kind, residual weights.
    fn default() -> Self {
        Options {
            effects: EffectSet::NONE,
            scale_joints: None,
            init_frames: false,
            folds: 5,
            seed: 1,
            geometry: ["theta0", "d", "a", "alpha"].map(String::from).to_vec(),
            weighting: Weighting::Residual,
            robust: None,
            max_iterations: 200,
            prior: PriorChoice::None,
        }
    }
}

impl Options {
    /// The effects with their joint selection.
    pub fn effect_choice(&self) -> EffectChoice {
        EffectChoice {
            effects: self.effects,
            scale_joints: self.scale_joints.clone(),
        }
    }

    /// The loss of the outlier fit on all poses: `robust`'s, Cauchy by default.
    pub fn outlier_loss(&self) -> Loss {
        self.robust.unwrap_or(Loss::Cauchy)
    }
}

/// A fold's held-out errors (pose, nominal, calibrated), data-deficient parameter count and
/// the algorithm that fitted it.
type FoldResult = Result<(Vec<(usize, PoseErrors, PoseErrors)>, usize, &'static str), String>;

/// Residual-based weighting: rounds of the fixed point.
const WEIGHT_ROUNDS: usize = 4;

/// The weights the rows got.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Weights {
    /// [1/m²]
    pub pos: f64,
    /// [1/rad²]
    pub rot: f64,
    /// `stated`, `unit`, `residual`, or `residual (one kind of rows: weights immaterial)`.
    pub mode: &'static str,
}

/// One fitted model and how it was fitted.
#[derive(Debug, Clone)]
pub struct Fit<const N: usize> {
    pub robot: Robot<N>,
    /// `None` when nothing was fitted.
    pub analysis: Option<Identifiability>,
    /// `ols`, `opt2` or `none`.
    pub algorithm: &'static str,
}

/// One fold: its index (0-based), held-out poses, data-deficient parameters of the
/// calibrated fit and the algorithm that fitted it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FoldInfo {
    pub fold: usize,
    pub poses: usize,
    pub data_deficient: usize,
    pub algorithm: &'static str,
}

/// A cross-validation's results (metres and radians).
#[derive(Debug, Clone)]
pub struct Study<const N: usize> {
    pub meas: Vec<Measurement<N>>,
    /// Some row measures orientation.
    pub orientation: bool,
    /// Per row: its fold (0-based).
    pub fold_of: Vec<usize>,
    /// Distinct pose groups.
    pub n_groups: usize,
    /// Parameters of the nominal model (frames among the effects) and the calibrated one.
    pub req_nom: ParamSet,
    pub req_cal: ParamSet,
    pub weights: Weights,
    /// The calibrated model on all poses (with the prior, if any) and without the prior.
    pub all: Fit<N>,
    pub no_prior: Robot<N>,
    /// The nominal model fitted on all poses (frames only).
    pub nominal_all: Fit<N>,
    /// The prior used (given or chosen) and `auto`'s search table.
    pub prior: Option<PriorSizes>,
    pub auto_table: Vec<AutoRow>,
    /// Per row: held-out errors of the nominal and the calibrated model.
    pub held_nom: Vec<PoseErrors>,
    pub held_cal: Vec<PoseErrors>,
    pub folds: Vec<FoldInfo>,
    /// Summaries: held-out and in-sample, nominal and calibrated.
    pub heldout_nominal: ErrorSummary,
    pub heldout_calibrated: ErrorSummary,
    pub insample_nominal: ErrorSummary,
    pub insample_calibrated: ErrorSummary,
    /// Noise from repeated pose_ids, or why there is none.
    pub repeats: Repeats,
    /// Upper bound of the noise: the calibrated model's dof-corrected residual σ per axis
    /// [m], [rad].
    pub residual_sigma_pos_m: f64,
    pub residual_sigma_rot_rad: f64,
    /// The outlier fit on all poses and its per-pose report.
    pub robust: Result<RobustIdentification<N>, kincal::Error>,
    pub robust_report: Vec<PoseResidual>,
}

impl<const N: usize> Study<N> {
    /// The rows the outlier fit names as suspects.
    pub fn suspects(&self) -> Vec<usize> {
        if self.robust.is_err() {
            return Vec::new();
        }
        (0..self.meas.len())
            .filter(|&i| self.robust_report.get(i).is_some_and(|r| r.suspect))
            .collect()
    }
}

fn frames_only(effects: EffectSet, n: usize) -> ParamSet {
    let mut frames = EffectSet::NONE;
    for e in [Effect::BaseFrame, Effect::ToolFrame] {
        if effects.contains(e) {
            frames = frames.with(e);
        }
    }
    frames.params(n)
}

/// The geometric parameters of the kinds named (`d` = the link's length parameter, d or β).
pub fn geometry_subset<const N: usize>(robot: &Robot<N>, kinds: &[String]) -> ParamSet {
    use kincal::params::LinkParam;
    let mut out = ParamSet::new();
    for i in robot.geometric_param_set().iter() {
        if let Ok(kincal::ParamId::Link { kind, .. }) =
            kincal::ParamId::from_index(kincal::ParamIndex(i), N)
        {
            let name = match kind {
                LinkParam::Theta0 => "theta0",
                LinkParam::D | LinkParam::Beta => "d",
                LinkParam::A => "a",
                LinkParam::Alpha => "alpha",
            };
            if kinds.iter().any(|k| k == name) {
                // Indices come from the robot's own set.
                let _ = out.insert(i);
            }
        }
    }
    out
}

/// How every model is fitted.
#[derive(Debug, Clone, Copy)]
struct How {
    w: Weights,
    init_frames: bool,
    robust: Option<Loss>,
    max_iterations: u32,
    /// Priors around each fit's starting model (rows whitened: the weights are 1/σ²).
    prior: Option<PriorSizes>,
    /// The frame and effect sizes `auto` applies to every grid size.
    auto_template: PriorSizes,
}

/// Fits `requested` on the poses of `data` with a positive weight.
fn fit<const N: usize>(
    start: &Robot<N>,
    data: &[Measurement<N>],
    requested: ParamSet,
    how: How,
) -> Result<Fit<N>, String> {
    let (w, init_frames, max_iterations) = (how.w, how.init_frames, how.max_iterations);
    let start = if init_frames {
        kincal::frames::estimate_frames(start, data)
            .map_err(|e| format!("frame estimate: {e}"))?
            .robot
    } else {
        *start
    };
    if requested.is_empty() {
        return Ok(Fit {
            robot: start,
            analysis: None,
            algorithm: "none",
        });
    }
    let mut ws = new_workspace();
    let mut last = String::new();
    let prior = how
        .prior
        .map(|sizes| Box::new(Prior::around(&start, &sizes)));
    for algorithm in [Algorithm::Ols, Algorithm::Opt2] {
        let mut o = IdentifyOptions::new(algorithm, requested);
        o.prior = prior.as_deref();
        o.weight_pos = w.pos;
        o.weight_rot = w.rot;
        o.allow_data_deficiency = true;
        o.max_iterations = max_iterations;
        let result = if let Some(loss) = how.robust {
            let mut d = data.to_vec();
            let mut report = vec![PoseResidual::default(); d.len()];
            identify_robust(
                &start,
                &mut d,
                &o,
                &RobustOptions::new(loss),
                &mut report,
                &mut ws,
            )
            .map(|r| r.fit)
        } else {
            identify(&start, data, &o, &mut ws)
        };
        match result {
            Ok(id) => {
                return Ok(Fit {
                    robot: id.robot,
                    analysis: Some(id.analysis),
                    algorithm: algorithm.name(),
                });
            }
            Err(e @ kincal::Error::NotConverged { .. }) => last = e.to_string(),
            Err(e) => return Err(e.to_string()),
        }
    }
    Err(last)
}

/// Errors of `robot` on pose `m` (components `m` does not measure zero).
fn errors<const N: usize>(robot: &Robot<N>, m: &Measurement<N>) -> Result<PoseErrors, String> {
    PoseErrors::of_measurement(robot, m).map_err(|e| e.to_string())
}

/// Core summary of the poses `keep` selects, each kind over the poses measuring it.
pub fn summarize<const N: usize>(
    meas: &[Measurement<N>],
    e: &[PoseErrors],
    keep: impl Fn(usize) -> bool,
) -> ErrorSummary {
    let mut s = ErrorSummary::default();
    for (i, (m, e)) in meas.iter().zip(e).enumerate() {
        if keep(i) {
            s.add_measured(e, m.mask);
        }
    }
    s
}

/// RMS and max of |e_p| [mm] and |e_φ| [deg].
pub fn summary_json(s: &ErrorSummary, orientation: bool) -> Value {
    let mut v = json!({"rms_pos_mm": s.rms_pos_m() * 1e3, "max_pos_mm": s.max_pos_m * 1e3});
    if orientation {
        v["rms_rot_deg"] = json!(s.rms_rot_rad().to_degrees());
        v["max_rot_deg"] = json!(s.max_rot_rad.to_degrees());
    }
    v
}

/// Per-axis residual σ of `robot` on `data` (core `noise::residual_sigma`, corrected for
/// `p` fitted parameters): (σ_pos [m], σ_rot [rad], position rows, rotation rows).
fn residual_sigma_of<const N: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    p: usize,
) -> Result<(f64, f64, usize, usize), String> {
    let poses: Vec<(PoseErrors, kincal::identify::ComponentMask)> = data
        .iter()
        .map(|m| Ok((errors(robot, m)?, m.mask)))
        .collect::<Result<_, String>>()?;
    let s = residual_sigma(poses, p);
    Ok((s.sigma_pos_m, s.sigma_rot_rad, s.rows_pos, s.rows_rot))
}

/// Folds by pose group: groups in order of first appearance, shuffled with `seed`, dealt
/// round-robin.
pub fn assign_folds(
    set: &MeasurementSet,
    k: usize,
    seed: u64,
) -> Result<(Vec<usize>, usize), Error> {
    let mut labels: Vec<String> = Vec::new();
    let mut group_of = Vec::with_capacity(set.rows.len());
    for (i, r) in set.rows.iter().enumerate() {
        let label = r.pose_id.clone().unwrap_or_else(|| format!("#row{i}"));
        let g = match labels.iter().position(|l| *l == label) {
            Some(g) => g,
            None => {
                labels.push(label);
                labels.len() - 1
            }
        };
        group_of.push(g);
    }
    let n_groups = labels.len();
    if n_groups < k {
        return Err(Error::usage(format!(
            "{}: {n_groups} pose groups, fewer than --folds {k}",
            set.source
        )));
    }
    let mut order: Vec<usize> = (0..n_groups).collect();
    kincal::rng::SplitMix64::new(seed).shuffle(&mut order);
    let mut fold_of_group = vec![0; n_groups];
    for (pos, &g) in order.iter().enumerate() {
        fold_of_group[g] = pos % k;
    }
    Ok((
        group_of.iter().map(|&g| fold_of_group[g]).collect(),
        n_groups,
    ))
}

/// Pooled repeat noise `(σ_pos [m], σ_rot [rad], dof_pos, dof_rot)`, or why there is none.
pub type Repeats = Result<(f64, f64, usize, usize), &'static str>;

/// Noise floor from repeated pose_ids: the diagnosis's estimator (core
/// `noise::pooled_repeat_scatter` over the repeat subgroups of `noise::repeat_leader`, with
/// the diagnosis's default temperature tolerance), residuals against `robot`;
/// `Ok((σ_pos [m], σ_rot [rad], dof_pos, dof_rot))`, or `Err(why there are no repeats)`.
fn repeat_noise<const N: usize>(
    robot: &Robot<N>,
    set: &MeasurementSet,
    meas: &[Measurement<N>],
) -> Result<Repeats, String> {
    const NO_IDS: &str = "no repeated pose_ids";
    // Group leader of each row: the first row with its pose_id (strings are the CLI's).
    let mut firsts: Vec<(&str, usize)> = Vec::new();
    let mut group_leader = Vec::with_capacity(set.rows.len());
    for (i, r) in set.rows.iter().enumerate() {
        let Some(id) = r.pose_id.as_deref() else {
            return Ok(Err(NO_IDS));
        };
        let g = match firsts.iter().find(|(g, _)| *g == id) {
            Some(&(_, g)) => g,
            None => {
                firsts.push((id, i));
                i
            }
        };
        group_leader.push(g);
    }
    let tol = kincal::diagnosis::Config::default().repeat_temp_tol_c;
    let sub_leader: Vec<usize> = (0..meas.len())
        .map(|l| repeat_leader(meas, l, |m| group_leader[m], tol))
        .collect();
    let r = pooled_repeat_scatter(
        meas.len(),
        |l| sub_leader[l],
        |l| meas[l].mask,
        |l| {
            let e = errors(robot, &meas[l])?;
            let (p, q) = (e.pos_m, e.rot_rad);
            Ok::<_, String>([p[0], p[1], p[2], q[0], q[1], q[2]])
        },
    )?;
    if r.dof_pos + r.dof_rot == 0 {
        return Ok(Err(if firsts.len() < meas.len() {
            "no repeated pose_ids under the same conditions (approach directions, temperature)"
        } else {
            NO_IDS
        }));
    }
    Ok(Ok((
        r.sigma_pos_m().unwrap_or(0.0),
        r.sigma_rot_rad().unwrap_or(0.0),
        r.dof_pos,
        r.dof_rot,
    )))
}

/// Every fold's held-out errors: (nominal, calibrated) per pose, and per fold (fold, poses,
/// data-deficient count, algorithm).
type Folds = (
    Vec<PoseErrors>,
    Vec<PoseErrors>,
    Vec<(usize, usize, usize, &'static str)>,
);

/// K-fold cross-validation: each fold's poses predicted by the nominal and the calibrated
/// fit of the other folds.
fn run_folds<const N: usize>(
    nominal: &Robot<N>,
    meas: &[Measurement<N>],
    fold_of: &[usize],
    k_folds: usize,
    req_nom: ParamSet,
    req_cal: ParamSet,
    how: How,
) -> Result<Folds, String> {
    let folds: Vec<FoldResult> = (0..k_folds)
        .into_par_iter()
        .map(|k| {
            let train: Vec<Measurement<N>> = meas
                .iter()
                .zip(fold_of)
                .map(|(m, &f)| Measurement {
                    weight: if f == k { 0.0 } else { m.weight },
                    ..*m
                })
                .collect();
            let a = fit(nominal, &train, req_nom, how)
                .map_err(|e| format!("fold {}: nominal: {e}", k + 1))?;
            let b = fit(nominal, &train, req_cal, how)
                .map_err(|e| format!("fold {}: calibrated: {e}", k + 1))?;
            let deficient = b.analysis.as_ref().map_or(0, |x| x.data_deficient.len());
            let mut out = Vec::new();
            for (i, m) in meas.iter().enumerate() {
                if fold_of[i] == k {
                    out.push((i, errors(&a.robot, m)?, errors(&b.robot, m)?));
                }
            }
            Ok((out, deficient, b.algorithm))
        })
        .collect();
    let mut held_nom = vec![PoseErrors::default(); meas.len()];
    let mut held_cal = vec![PoseErrors::default(); meas.len()];
    let mut fold_info = Vec::new();
    for (k, f) in folds.into_iter().enumerate() {
        let (rows, deficient, algorithm) = f?;
        for &(i, a, b) in &rows {
            held_nom[i] = a;
            held_cal[i] = b;
        }
        fold_info.push((k, rows.len(), deficient, algorithm));
    }
    Ok((held_nom, held_cal, fold_info))
}

/// One row of `--prior auto`'s search: the sizes (none: no prior), the held-out RMS of the
/// calibrated model [m, rad] and its weighted score (`w_pos·RMS_p² + w_rot·RMS_φ²`, the
/// fit's own cost per pose).
#[derive(Debug, Clone, Copy)]
pub struct AutoRow {
    pub sizes: Option<(f64, f64)>,
    pub rms_pos_m: f64,
    pub rms_rot_rad: f64,
    pub score: f64,
}

/// `--prior auto`: cross-validates without a prior and with every size of
/// [`PRIOR_AUTO_GRID`]; picks the tightest size whose held-out score's square
/// root (an RMS in noise units) is within [`AUTO_TOLERANCE`] of the best of all rows — the
/// most physical model the data cannot tell apart from the best-predicting one.
fn choose_prior<const N: usize>(
    nominal: &Robot<N>,
    meas: &[Measurement<N>],
    fold_of: &[usize],
    k_folds: usize,
    req_nom: ParamSet,
    req_cal: ParamSet,
    how: How,
) -> Result<(Option<PriorSizes>, Vec<AutoRow>), String> {
    let grid = std::iter::once(None).chain(PRIOR_AUTO_GRID.iter().map(|&g| Some(g)));
    let mut rows = Vec::new();
    for sizes in grid {
        let prior = sizes.map(|(mm, deg)| PriorSizes {
            length_m: mm * 1e-3,
            angle_rad: f64::to_radians(deg),
            ..how.auto_template
        });
        let (_, held, _) = run_folds(
            nominal,
            meas,
            fold_of,
            k_folds,
            req_nom,
            req_cal,
            How { prior, ..how },
        )?;
        let s = summarize(meas, &held, |_| true);
        let (p, r) = (s.rms_pos_m(), s.rms_rot_rad());
        rows.push(AutoRow {
            sizes,
            rms_pos_m: p,
            rms_rot_rad: r,
            score: how.w.pos * p * p + how.w.rot * r * r,
        });
    }
    let best = rows.iter().map(|r| r.score).fold(f64::INFINITY, f64::min);
    let limit = best * (1.0 + AUTO_TOLERANCE).powi(2);
    let chosen = rows
        .iter()
        .filter(|r| r.sizes.is_some() && r.score <= limit)
        .map(|r| r.sizes)
        .next()
        .flatten();
    Ok((
        chosen.map(|(mm, deg)| PriorSizes::links(mm * 1e-3, f64::to_radians(deg))),
        rows,
    ))
}

/// `--prior auto` accepts a held-out RMS (in noise units) this much above the best.
const AUTO_TOLERANCE: f64 = 0.02;

/// The largest change of a link length [m] and a link angle [rad] of `fitted` from
/// `nominal` among `set`, with the parameters' labels.
pub fn largest_changes<const N: usize>(
    fitted: &Robot<N>,
    nominal: &Robot<N>,
    set: &ParamSet,
) -> ((f64, String), (f64, String)) {
    let mut len = (0.0, String::from("-"));
    let mut ang = (0.0, String::from("-"));
    for i in set.iter() {
        let Ok(id) = kincal::ParamId::from_index(kincal::ParamIndex(i), N) else {
            continue;
        };
        if !matches!(id, kincal::ParamId::Link { .. }) {
            continue;
        }
        let d = (fitted.param(kincal::ParamIndex(i)).unwrap_or(f64::NAN)
            - nominal.param(kincal::ParamIndex(i)).unwrap_or(f64::NAN))
        .abs();
        let slot = if id.is_length() { &mut len } else { &mut ang };
        if d > slot.0 || d.is_nan() {
            *slot = (d, param_label::<N>(i));
        }
    }
    (len, ang)
}

/// The starting weights of `options` (residual weights start at 1 and 1).
fn initial_weights(weighting: Weighting) -> Weights {
    match weighting {
        Weighting::Stated { pos_mm, rot_deg } => Weights {
            pos: 1.0 / (pos_mm * 1e-3).powi(2),
            rot: 1.0 / rot_deg.to_radians().powi(2),
            mode: "stated",
        },
        Weighting::Unit => Weights {
            pos: 1.0,
            rot: 1.0,
            mode: "unit",
        },
        Weighting::Residual => Weights {
            pos: 1.0,
            rot: 1.0,
            mode: "residual",
        },
    }
}

/// Cross-validates a calibration of the pose rows of `set` starting from `nominal`.
/// Errors: fewer pose groups than folds (usage), a failed fit (numeric, naming the step).
pub fn run<const N: usize>(
    nominal: &Robot<N>,
    set: &MeasurementSet,
    options: &Options,
) -> Result<Study<N>, Error> {
    let meas = data::measurements::<N>(set)?;
    let orientation = meas.iter().any(|m| m.mask.has_orientation());
    let (fold_of, n_groups) = assign_folds(set, options.folds, options.seed)?;
    let req_nom = frames_only(options.effects, N);
    let req_cal = geometry_subset(nominal, &options.geometry)
        .union(&options.effect_choice().effect_params(N));
    let fail = |what: &str, e: String| Error::numeric(format!("{}: {what}: {e}", set.source));
    let how = |w: Weights| How {
        w,
        init_frames: options.init_frames,
        robust: options.robust,
        max_iterations: options.max_iterations,
        prior: None,
        auto_template: match options.prior {
            PriorChoice::Auto { template } => template,
            _ => PriorSizes::DEFAULT,
        },
    };

    // Weights.
    let mut w = initial_weights(options.weighting);
    let mut all =
        fit(nominal, &meas, req_cal, how(w)).map_err(|e| fail("calibration on all poses", e))?;
    let p_fit = |f: &Fit<N>| f.analysis.as_ref().map_or(0, |a| a.identifiable.len());
    // Residual-based weights matter only when both kinds of rows are measured.
    let both = orientation && meas.iter().any(|m| m.mask.has_position());
    // A prior is weighed against the data's noise: then the weights whiten even one kind.
    if w.mode == "residual" && !both && options.prior == PriorChoice::None {
        w.mode = "residual (one kind of rows: weights immaterial)";
    }
    if w.mode == "residual" {
        for _ in 0..WEIGHT_ROUNDS {
            let (sp, sr, _, nr) = residual_sigma_of(&all.robot, &meas, p_fit(&all))
                .map_err(|e| fail("residuals", e))?;
            if !(sp > 0.0 && sp.is_finite()) {
                break;
            }
            w.pos = 1.0 / (sp * sp);
            w.rot = if nr > 0 && sr > 0.0 && sr.is_finite() {
                1.0 / (sr * sr)
            } else {
                1.0
            };
            all = fit(nominal, &meas, req_cal, how(w))
                .map_err(|e| fail("calibration on all poses", e))?;
        }
    }
    let (sig_p, sig_r, _, _) =
        residual_sigma_of(&all.robot, &meas, p_fit(&all)).map_err(|e| fail("residuals", e))?;
    let nominal_all =
        fit(nominal, &meas, req_nom, how(w)).map_err(|e| fail("nominal fit on all poses", e))?;

    // The prior: as given, or chosen by held-out error (`auto`). The weights above come
    // from fits without it, so that a prior changes the model, not the weighting.
    let no_prior = all.robot;
    let (prior, auto_table) = match options.prior {
        PriorChoice::None => (None, Vec::new()),
        PriorChoice::Sizes(sizes) => (Some(sizes), Vec::new()),
        PriorChoice::Auto { .. } => choose_prior(
            nominal,
            &meas,
            &fold_of,
            options.folds,
            req_nom,
            req_cal,
            how(w),
        )
        .map_err(|e| fail("--prior auto", e))?,
    };
    let how = |w: Weights| How { prior, ..how(w) };
    if prior.is_some() {
        all = fit(nominal, &meas, req_cal, how(w))
            .map_err(|e| fail("calibration on all poses with the prior", e))?;
    }

    // Folds.
    let (held_nom, held_cal, fold_info) = run_folds(
        nominal,
        &meas,
        &fold_of,
        options.folds,
        req_nom,
        req_cal,
        how(w),
    )
    .map_err(|e| fail("cross-validation", e))?;
    let in_sample = |robot: &Robot<N>| -> Result<ErrorSummary, Error> {
        let e: Vec<PoseErrors> = meas
            .iter()
            .map(|m| errors(robot, m))
            .collect::<Result<_, _>>()
            .map_err(|e| fail("residuals", e))?;
        Ok(summarize(&meas, &e, |_| true))
    };
    let insample_calibrated = in_sample(&all.robot)?;
    let insample_nominal = in_sample(&nominal_all.robot)?;

    // Noise floor.
    let repeats = repeat_noise(&all.robot, set, &meas).map_err(|e| fail("noise floor", e))?;

    // Robust fit and outliers (IRLS with the robust loss, Cauchy by default, from the
    // calibrated start).
    let (robust, robust_report) =
        outlier_fit(nominal, &meas, req_cal, w, options).map_err(|e| fail("frame estimate", e))?;
    Ok(Study {
        heldout_nominal: summarize(&meas, &held_nom, |_| true),
        heldout_calibrated: summarize(&meas, &held_cal, |_| true),
        insample_nominal,
        insample_calibrated,
        orientation,
        fold_of,
        n_groups,
        req_nom,
        req_cal,
        weights: w,
        all,
        no_prior,
        nominal_all,
        prior,
        auto_table,
        held_nom,
        held_cal,
        folds: fold_info
            .into_iter()
            .map(|(fold, poses, data_deficient, algorithm)| FoldInfo {
                fold,
                poses,
                data_deficient,
                algorithm,
            })
            .collect(),
        repeats,
        residual_sigma_pos_m: sig_p,
        residual_sigma_rot_rad: sig_r,
        robust,
        robust_report,
        meas,
    })
}

/// The start of the fits on all poses: `nominal`, or with frames estimated from all poses.
fn start_on_all<const N: usize>(
    nominal: &Robot<N>,
    meas: &[Measurement<N>],
    init_frames: bool,
) -> Result<Robot<N>, String> {
    if init_frames {
        Ok(kincal::frames::estimate_frames(nominal, meas)
            .map_err(|e| e.to_string())?
            .robot)
    } else {
        Ok(*nominal)
    }
}

/// The outlier fit on all poses (IRLS with the outlier loss) and its per-pose report; `Err`
/// only when the frames cannot be estimated (a failed fit is part of the result).
#[allow(clippy::type_complexity)]
fn outlier_fit<const N: usize>(
    nominal: &Robot<N>,
    meas: &[Measurement<N>],
    req_cal: ParamSet,
    w: Weights,
    options: &Options,
) -> Result<
    (
        Result<RobustIdentification<N>, kincal::Error>,
        Vec<PoseResidual>,
    ),
    String,
> {
    let start = start_on_all(nominal, meas, options.init_frames)?;
    let mut rdata = meas.to_vec();
    let mut report = vec![PoseResidual::default(); meas.len()];
    let mut o = IdentifyOptions::new(Algorithm::Ols, req_cal);
    o.weight_pos = w.pos;
    o.weight_rot = w.rot;
    o.allow_data_deficiency = true;
    o.max_iterations = options.max_iterations;
    let mut ws = new_workspace();
    let robust = identify_robust(
        &start,
        &mut rdata,
        &o,
        &RobustOptions::new(options.outlier_loss()),
        &mut report,
        &mut ws,
    );
    Ok((robust, report))
}

/// The nominal geometry with the base and tool frames of the calibrated fit on all poses
/// (`crossval --robot-out`: a starting model for a diagnosis, whose baseline fits the
/// geometry but not the frames).
pub fn robot_with_frames<const N: usize>(
    nominal: &Robot<N>,
    study: &Study<N>,
    options: &Options,
    source: &str,
) -> Result<Robot<N>, Error> {
    let fail = |what: &str, e: String| Error::numeric(format!("{source}: {what}: {e}"));
    let (base, tool) = (study.all.robot.base(), study.all.robot.tool());
    let start = start_on_all(nominal, &study.meas, options.init_frames)
        .map_err(|e| fail("frame estimate", e))?;
    start
        .with_base(base)
        .and_then(|r| r.with_tool(tool))
        .map_err(|e| fail("frames", e.to_string()))
}

/// The prior's JSON (null without one; `auto`'s search table in `grid`).
fn prior_json(
    study_prior: Option<PriorSizes>,
    auto: bool,
    table: &[AutoRow],
    orientation: bool,
) -> Value {
    let Some(p) = study_prior else {
        return if auto {
            json!({"auto": true, "length_mm": null, "angle_deg": null})
        } else {
            Value::Null
        };
    };
    let rows: Vec<Value> = table
        .iter()
        .map(|r| {
            json!({
                "length_mm": r.sizes.map(|x| x.0), "angle_deg": r.sizes.map(|x| x.1),
                "heldout_rms_pos_mm": r.rms_pos_m * 1e3,
                "heldout_rms_rot_deg": if orientation { json!(r.rms_rot_rad.to_degrees()) } else { Value::Null },
                "score": r.score,
            })
        })
        .collect();
    json!({"auto": auto, "length_mm": p.length_m * 1e3, "angle_deg": p.angle_rad.to_degrees(), "grid": rows})
}

/// The noise floor's JSON: the repeats' scatter, or the residuals' upper bound.
fn noise_json<const N: usize>(study: &Study<N>) -> Value {
    match study.repeats {
        Ok((sp, sr, dp, dr)) => {
            json!({"source": "repeats", "sigma_pos_mm": sp * 1e3, "sigma_rot_deg": sr.to_degrees(), "dof_pos": dp, "dof_rot": dr})
        }
        Err(_) => {
            let (sig_p, sig_r) = (study.residual_sigma_pos_m, study.residual_sigma_rot_rad);
            json!({"source": "residual_upper_bound", "sigma_pos_mm": sig_p * 1e3, "sigma_rot_deg": if study.orientation { json!(sig_r.to_degrees()) } else { Value::Null }})
        }
    }
}

/// The outlier fit's JSON: scales and suspects, or its error.
fn outliers_json<const N: usize>(study: &Study<N>, set: &MeasurementSet) -> Value {
    let orientation = study.orientation;
    let report = &study.robust_report;
    match &study.robust {
        Ok(r) => json!({
            // The outlier loss's name was always written as "cauchy" (kept for readers of
            // earlier files; `robust_loss` at the top names the fits' loss).
            "loss": "cauchy", "scale_pos_mm": r.test.scale_pos_m * 1e3,
            "scale_rot_deg": if orientation { json!(r.test.scale_rot_rad.to_degrees()) } else { Value::Null },
            "suspects": study.suspects().iter().map(|&i| json!({
                "pose_id": set.rows[i].pose_id, "line": set.rows[i].line,
                "distance": report[i].distance, "pos_mm": report[i].pos_m * 1e3,
                "rot_deg": report[i].rot_rad.to_degrees(), "robust_weight": report[i].robust_weight,
            })).collect::<Vec<_>>(),
        }),
        Err(e) => json!({"error": e.to_string()}),
    }
}

/// The largest changes' JSON, with and without the prior.
fn change_json<const N: usize>(study: &Study<N>, nominal: &Robot<N>) -> Value {
    let changes = |r: &Robot<N>| {
        let ((dl, pl), (da, pa)) = largest_changes(r, nominal, &study.req_cal);
        json!({"length_mm": dl * 1e3, "length_param": pl, "angle_deg": da.to_degrees(), "angle_param": pa})
    };
    json!({"calibrated": changes(&study.all.robot), "without_prior": changes(&study.no_prior)})
}

/// Per fold: poses, data-deficient parameters, algorithm and both models' held-out
/// summaries.
fn folds_json<const N: usize>(study: &Study<N>) -> Vec<Value> {
    let orientation = study.orientation;
    study
        .folds
        .iter()
        .map(|f| {
            let keep = |i: usize| study.fold_of[i] == f.fold;
            let a = summarize(&study.meas, &study.held_nom, keep);
            let b = summarize(&study.meas, &study.held_cal, keep);
            json!({
                "fold": f.fold + 1, "poses": f.poses, "data_deficient": f.data_deficient, "algorithm": f.algorithm,
                "nominal": summary_json(&a, orientation), "calibrated": summary_json(&b, orientation),
            })
        })
        .collect()
}

/// Per pose: its file line, fold and held-out error norms.
fn poses_json<const N: usize>(study: &Study<N>, set: &MeasurementSet) -> Vec<Value> {
    (0..study.meas.len())
        .map(|i| {
            json!({
                "pose_id": set.rows[i].pose_id, "line": set.rows[i].line, "fold": study.fold_of[i] + 1,
                "nominal_pos_mm": study.held_nom[i].pos_norm_m * 1e3,
                "calibrated_pos_mm": study.held_cal[i].pos_norm_m * 1e3,
                "nominal_rot_deg": study.held_nom[i].rot_norm_rad.to_degrees(),
                "calibrated_rot_deg": study.held_cal[i].rot_norm_rad.to_degrees(),
            })
        })
        .collect()
}

/// The cross-validation `study` of `set` from `nominal` (named `robot_name`) as data: the
/// document `kincal crossval --json` writes (format `kincal-crossval` 1.0).
pub fn json<const N: usize>(
    study: &Study<N>,
    set: &MeasurementSet,
    nominal: &Robot<N>,
    robot_name: &str,
    options: &Options,
) -> Value {
    let orientation = study.orientation;
    let eff_names: Vec<&str> = options.effects.iter().map(|e| e.name()).collect();
    let auto = matches!(options.prior, PriorChoice::Auto { .. });
    let (w, a) = (study.weights, study.all.analysis.as_ref());
    json!({
        "format": "kincal-crossval", "schema_version": "1.0",
        "data": {"path": set.source, "sha256": set.sha256, "poses": study.meas.len(), "groups": study.n_groups, "orientation": orientation},
        "robot": robot_name, "effects": eff_names, "geometry": options.geometry, "init_frames": options.init_frames, "robust": options.robust.is_some(), "robust_loss": options.robust.map(Loss::name),
        "folds": options.folds, "seed": options.seed,
        "weighting": {"mode": w.mode, "weight_pos": w.pos, "weight_rot": w.rot},
        "prior": prior_json(study.prior, auto, &study.auto_table, orientation), "largest_change": change_json(study, nominal),
        "identifiability": a.map(|a| json!({
            "requested": a.requested.len(), "identifiable": a.identifiable.len(),
            "structurally_redundant": a.structural.iter().map(param_label::<N>).collect::<Vec<_>>(),
            "data_deficient": a.data_deficient.iter().map(param_label::<N>).collect::<Vec<_>>(),
            "rank": a.rank,
            "condition_number": if a.condition_number.is_finite() { json!(a.condition_number) } else { Value::Null },
        })),
        "heldout": {"nominal": summary_json(&study.heldout_nominal, orientation), "calibrated": summary_json(&study.heldout_calibrated, orientation)},
        "insample": {"nominal": summary_json(&study.insample_nominal, orientation), "calibrated": summary_json(&study.insample_calibrated, orientation)},
        "per_fold": folds_json(study),
        "noise_floor": noise_json(study),
        "outliers": outliers_json(study, set),
        "poses": poses_json(study, set),
    })
}
