//! `kincal crossval DATA --robot ROBOT [--effects E1,E2] [--init-frames] [--folds K]`:
//! held-out residuals of the nominal geometry and of the calibrated model (k-fold
//! cross-validation by pose_id), the noise floor (repeats, or an upper bound from the
//! residuals), and the outliers a robust fit names. Every number comes from the core:
//! `frames::estimate_frames`, `identify::identify`, `identify::identify_robust`,
//! `validation::{PoseErrors, ErrorSummary}`, `noise::{pooled_repeat_scatter,
//! residual_sigma}` (the diagnosis's noise-floor estimator).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use kincal::identify::{
    Algorithm, Identifiability, IdentifyOptions, Loss, Measurement, PoseResidual, Prior,
    PriorSizes, RobustOptions, identify, identify_robust,
};
use kincal::noise::{pooled_repeat_scatter, repeat_leader, residual_sigma};
use kincal::validation::{ErrorSummary, PoseErrors};
use kincal::{Effect, EffectSet, ParamSet, Robot};
use rayon::prelude::*;
use serde_json::{Value, json};

use crate::args::parse_effect;
use crate::error::CliError;
use kincal_io::calibration::new_workspace;
use kincal_io::data::{self, DataOptions};
use kincal_io::measurements::MeasurementSet;
use kincal_io::robot_arg;

pub const LONG_ABOUT: &str = "\
Cross-validates a calibration on held-out poses. The poses are dealt to K folds (rows
sharing a pose_id stay together; seeded, so reruns give the same folds); each fold is
predicted by models fitted on the other folds:

  nominal     the ROBOT's geometry, with only the base/tool frame parameters among --effects
              fitted (base_frame, tool_frame; none: the ROBOT as it is),
  calibrated  the geometric parameters plus every effect of --effects (as `calibrate`).

With --init-frames both start, in every fold, from frames estimated on that fold's training
poses (kincal::frames: hand-eye equation for full poses, rigid fits for positions), so a set
whose base and tool frames are unknown needs no hand-made starting values. Fits use OLS
(Gauss-Newton), falling back to OPT2 (Levenberg-Marquardt) if OLS does not converge, and fit
the identifiable subset when a fold leaves parameters undetermined (reported per fold).

Weighting: Σ w_pos·|Δp|² + w_rot·|Δφ|². --sigma-pos-mm/--sigma-rot-deg state the noise
(w = 1/σ²); --unit-weights uses 1 and 1 (the paper's); by default the weights are 1/σ²
with σ the per-axis RMS residual of the calibrated model on all poses, iterated to a fixed
point and corrected for the fitted parameters (so neither kind of row dominates by its unit).

Priors: --prior [MM,DEG] fits the calibrated model with a Gaussian prior around the initial
model on the link parameters (one σ for lengths [mm] and angles [deg]; alone: 5 mm, 1°),
whitened by the weights (not with --unit-weights; one kind of rows is then weighted by its
residual σ too); the weights themselves come from fits without the prior. --prior auto
cross-validates without a prior and with each size of the grid 1.25 mm/0.25°, 2.5/0.5,
5/1, 10/2, 20/4, 40/8, and takes the tightest size whose held-out score (w_pos·RMS_p² +
w_rot·RMS_φ², square-rooted) is within 2 % of the best; the table is printed and in --json
(prior.grid). Printed either way: the largest change of a link length and angle from the
nominal model in the fit on all poses (--json largest_change), with and without the prior.

Also printed (and in --json): the noise floor — the pooled scatter of repeated pose_ids
when the data have them (the estimator of `kincal diagnose`: repeats count together when
they share approach directions and temperatures within 0.5 °C), else an upper bound: the
calibrated model's dof-corrected residual per axis, which contains whatever the model does
not explain; the robust fit (IRLS with --robust's loss, Cauchy by default, on
all poses, core identify_robust) and the poses its residual test names as outliers (d² above
the 99.99 % χ² quantile); the identifiability of the calibrated model on all poses.

--plot FILE.svg draws the held-out |e_p| (and |e_φ|) of every pose for both models on one
scale. --robot-out ROBOT.toml writes the ROBOT's nominal geometry with the base and tool
frames of the calibrated fit on all poses (a starting model for `kincal diagnose`, whose
baseline fits the geometry but not the frames).

Data with target/plane rows (docs/constraints.md; --constraints FILE): folds hold out whole
groups, --group-by target|session|pose_id (default: session when the data have sessions,
else target): training on one placement and testing on it overfits. A held-out row is
scored by the distance of its predicted tool point from its target (plane) re-estimated
from the held-out rows only; known distances whose targets are held out are scored too.
Printed and in --json: mean |e|, RMS and max [mm] and the mean distance error, nominal vs
calibrated (geometry kinds of --geometry, --effects, and the tool translation). With
--robust LOSS every fold's fit is the robust constrained fit of `calibrate --robust` (core
identify_constrained_robust, IRLS on the training rows); the held-out scores are not
reweighted.";

pub const EXAMPLE: &str = "\
Example:
  kincal crossval ur10e.csv --robot ur10e.toml --effects base_frame,tool_frame \\
      --init-frames --folds 5 --json ur10e-cv.json --plot ur10e-cv.svg";

#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Measurement CSV: joint readings and measured poses
    #[arg(value_name = "DATA")]
    pub data: PathBuf,
    /// Built-in robot name (aria) or robot description file: the nominal model
    #[arg(long, value_name = "ROBOT")]
    pub robot: String,
    #[command(flatten)]
    pub chain: kincal_io::robot_arg::UrdfChainArgs,
    /// Effects to identify with the geometry (comma-separated names of spec/effects.md)
    #[arg(long, value_name = "E1,E2", value_delimiter = ',', value_parser = parse_effect)]
    pub effects: Vec<Effect>,
    /// Estimate the base and tool frames from each fold's training poses first
    #[arg(long)]
    pub init_frames: bool,
    /// Number of folds (2 or more; at most the number of pose groups)
    #[arg(long, value_name = "K", default_value_t = 5)]
    pub folds: usize,
    /// Seed of the fold assignment
    #[arg(long, value_name = "S", default_value_t = 1)]
    pub seed: u64,
    /// Geometric parameter kinds to identify in the calibrated model (theta0, d, a, alpha;
    /// d stands for d or β, whichever the link identifies)
    #[arg(long, value_name = "K1,K2", value_delimiter = ',', default_value = "theta0,d,a,alpha", value_parser = ["theta0", "d", "a", "alpha"])]
    pub geometry: Vec<String>,
    /// Instrument position noise, 1σ per axis [mm]: weight 1/σ²
    #[arg(long, value_name = "S", value_parser = crate::args::sigma_mm, requires = "sigma_rot_deg", conflicts_with = "unit_weights")]
    pub sigma_pos_mm: Option<f64>,
    /// Instrument orientation noise, 1σ per axis [deg]: weight 1/σ²
    #[arg(long, value_name = "S", value_parser = crate::args::sigma_deg, requires = "sigma_pos_mm")]
    pub sigma_rot_deg: Option<f64>,
    /// Weights 1 per m² and 1 per rad² (the paper's) instead of residual-based ones
    #[arg(long)]
    pub unit_weights: bool,
    /// Fit every model robustly (IRLS with this loss, core identify_robust; `--robust`
    /// alone means cauchy, as before) instead of by least squares; held-out errors are
    /// still reported for every pose
    #[arg(long, value_enum, value_name = "LOSS", num_args = 0..=1, default_missing_value = "cauchy")]
    pub robust: Option<crate::args::LossArg>,
    /// Accept joint readings outside the robot's joint limits
    #[arg(long)]
    pub allow_out_of_limits: bool,
    /// Iteration limit of each fit
    #[arg(long, value_name = "N", default_value_t = 200)]
    pub max_iterations: u32,
    /// Write the numbers as JSON
    #[arg(long, value_name = "FILE.json")]
    pub json: Option<PathBuf>,
    /// Draw the held-out errors per pose (SVG)
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
    /// Write the nominal geometry with the calibrated frames as a robot description
    #[arg(long, value_name = "ROBOT.toml")]
    pub robot_out: Option<PathBuf>,
    /// Data with target/plane rows: what a fold holds out (default: session when the data
    /// have sessions, else target); see docs/constraints.md
    #[arg(long, value_enum, value_name = "BY")]
    pub group_by: Option<crate::commands::crossval_contacts::GroupBy>,
    /// Known geometry of the fixtures (TOML) for data with target/plane rows
    #[arg(long, value_name = "FILE")]
    pub constraints: Option<PathBuf>,
    /// Gaussian priors around the initial model on the calibrated link parameters: one σ
    /// for lengths [mm] and angles [deg] (`--prior` alone: 5,1), or `auto`: the tightest
    /// size of a fixed grid whose held-out error is within 2 % of the best
    #[arg(long, value_name = "MM,DEG|auto", value_parser = crate::args::prior, num_args = 0..=1, default_missing_value = "5,1", conflicts_with = "unit_weights")]
    pub prior: Option<crate::args::PriorArg>,
    #[command(flatten)]
    pub prior_kinds: crate::args::PriorKinds,
}

/// A fold's held-out errors (pose, nominal, calibrated), data-deficient parameter count and
/// the algorithm that fitted it.
type FoldResult = Result<(Vec<(usize, PoseErrors, PoseErrors)>, usize, &'static str), String>;

/// Residual-based weighting: rounds of the fixed point.
const WEIGHT_ROUNDS: usize = 4;

pub fn run(args: &Args) -> Result<(), CliError> {
    if args.folds < 2 {
        return Err(CliError::usage("--folds must be 2 or more"));
    }
    let outputs: Vec<&PathBuf> = [&args.json, &args.plot, &args.robot_out]
        .into_iter()
        .flatten()
        .collect();
    for (i, a) in outputs.iter().enumerate() {
        if outputs[i + 1..]
            .iter()
            .any(|b| kincal_io::files::is_same_file(a, b) || a == b)
        {
            return Err(CliError::usage(format!(
                "{} is named by two outputs",
                a.display()
            )));
        }
    }
    let spec = robot_arg::resolve_robot(&args.robot, &args.chain)?;
    kincal::with_any_robot!(&spec.robot, r => crossval(r, &spec.name, args))
}

/// How the rows are weighted.
#[derive(Debug, Clone, Copy)]
struct Weights {
    pos: f64,
    rot: f64,
    mode: &'static str,
}

/// One fitted model and how it was fitted.
struct Fit<const N: usize> {
    robot: Robot<N>,
    analysis: Option<Identifiability>,
    algorithm: &'static str,
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
fn geometry_subset<const N: usize>(robot: &Robot<N>, kinds: &[String]) -> ParamSet {
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

/// The loss of the outlier fit on all poses: `--robust`'s, Cauchy by default.
fn outlier_loss(args: &Args) -> Loss {
    args.robust.map_or(Loss::Cauchy, Loss::from)
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
    /// `--prior-frames`/`--prior-effects`, applied to every size `--prior auto` tries.
    prior_kinds: crate::args::PriorKinds,
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
fn summarize<const N: usize>(
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
fn summary_json(s: &ErrorSummary, orientation: bool) -> Value {
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
fn assign_folds(
    set: &MeasurementSet,
    k: usize,
    seed: u64,
) -> Result<(Vec<usize>, usize), CliError> {
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
        return Err(CliError::usage(format!(
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
type Repeats = Result<(f64, f64, usize, usize), &'static str>;

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
struct AutoRow {
    sizes: Option<(f64, f64)>,
    rms_pos_m: f64,
    rms_rot_rad: f64,
    score: f64,
}

/// `--prior auto`: cross-validates without a prior and with every size of
/// [`crate::args::PRIOR_AUTO_GRID`]; picks the tightest size whose held-out score's square
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
    let grid = std::iter::once(None).chain(crate::args::PRIOR_AUTO_GRID.iter().map(|&g| Some(g)));
    let mut rows = Vec::new();
    for sizes in grid {
        let prior = sizes.map(|(mm, deg)| {
            how.prior_kinds
                .apply(PriorSizes::links(mm * 1e-3, f64::to_radians(deg)))
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

/// Prints the prior (and `--prior auto`'s search) into `s`; its JSON (null without one).
fn prior_report(
    s: &mut String,
    prior: Option<PriorSizes>,
    auto: bool,
    table: &[AutoRow],
    orientation: bool,
) -> Value {
    let Some(p) = prior else {
        if auto {
            let _ = writeln!(
                s,
                "Prior (auto): none is within 2 % of the best held-out error"
            );
        }
        return if auto {
            json!({"auto": true, "length_mm": null, "angle_deg": null})
        } else {
            Value::Null
        };
    };
    let (mm, deg) = (p.length_m * 1e3, p.angle_rad.to_degrees());
    let _ = writeln!(
        s,
        "Prior{}: Gaussian around the initial model on the link parameters, σ {mm} mm (lengths), {deg}° (angles); rows whitened by the weights above",
        if auto {
            " (auto: the tightest size of the grid within 2 % of the best held-out error)"
        } else {
            ""
        }
    );
    let mut rows = Vec::new();
    for r in table {
        let _ = writeln!(
            s,
            "  prior {:>14}: held-out RMS {:.4} mm{}, score {:.4}",
            r.sizes
                .map_or("none".to_string(), |(a, b)| format!("{a} mm, {b}°")),
            r.rms_pos_m * 1e3,
            if orientation {
                format!(", {:.4}°", r.rms_rot_rad.to_degrees())
            } else {
                String::new()
            },
            r.score
        );
        rows.push(json!({
            "length_mm": r.sizes.map(|x| x.0), "angle_deg": r.sizes.map(|x| x.1),
            "heldout_rms_pos_mm": r.rms_pos_m * 1e3,
            "heldout_rms_rot_deg": if orientation { json!(r.rms_rot_rad.to_degrees()) } else { Value::Null },
            "score": r.score,
        }));
    }
    json!({"auto": auto, "length_mm": mm, "angle_deg": deg, "grid": rows})
}

/// `--prior auto` accepts a held-out RMS (in noise units) this much above the best.
const AUTO_TOLERANCE: f64 = 0.02;

/// The largest change of a link length [m] and a link angle [rad] of `fitted` from
/// `nominal` among `set`, with the parameters' labels.
fn largest_changes<const N: usize>(
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
            *slot = (d, crate::report::label::<N>(i));
        }
    }
    (len, ang)
}

fn crossval<const N: usize>(nominal: &Robot<N>, name: &str, args: &Args) -> Result<(), CliError> {
    let effects = args.effects.iter().fold(EffectSet::NONE, |a, &e| a.with(e));
    let set = data::read(
        &args.data,
        nominal,
        effects,
        DataOptions {
            require_pose: true,
            allow_out_of_limits: args.allow_out_of_limits,
        },
    )?;
    if args.constraints.is_some() || kincal_io::constraints::has_contacts(&set) {
        return crossval_contacts(nominal, args, &set, effects);
    }
    if args.group_by.is_some() {
        return Err(CliError::usage(
            "--group-by applies to data with target/plane rows (instrument data: folds by pose_id)",
        ));
    }
    let meas = data::measurements::<N>(&set)?;
    let orientation = meas.iter().any(|m| m.mask.has_orientation());
    let (fold_of, n_groups) = assign_folds(&set, args.folds, args.seed)?;
    let req_nom = frames_only(effects, N);
    let req_cal = geometry_subset(nominal, &args.geometry).union(&effects.params(N));
    let fail = |what: &str, e: String| CliError::numeric(format!("{}: {what}: {e}", set.source));

    // Weights.
    let mut w = match (args.sigma_pos_mm, args.sigma_rot_deg, args.unit_weights) {
        (Some(sp), Some(sr), _) => Weights {
            pos: 1.0 / (sp * 1e-3).powi(2),
            rot: 1.0 / sr.to_radians().powi(2),
            mode: "stated",
        },
        (_, _, true) => Weights {
            pos: 1.0,
            rot: 1.0,
            mode: "unit",
        },
        _ => Weights {
            pos: 1.0,
            rot: 1.0,
            mode: "residual",
        },
    };
    let how = |w: Weights| How {
        w,
        init_frames: args.init_frames,
        robust: args.robust.map(Loss::from),
        max_iterations: args.max_iterations,
        prior: None,
        prior_kinds: args.prior_kinds,
    };
    let mut all =
        fit(nominal, &meas, req_cal, how(w)).map_err(|e| fail("calibration on all poses", e))?;
    let p_fit = |f: &Fit<N>| f.analysis.as_ref().map_or(0, |a| a.identifiable.len());
    // Residual-based weights matter only when both kinds of rows are measured.
    let both = orientation && meas.iter().any(|m| m.mask.has_position());
    // A prior is weighed against the data's noise: then the weights whiten even one kind.
    if w.mode == "residual" && !both && args.prior.is_none() {
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
    let nom_all =
        fit(nominal, &meas, req_nom, how(w)).map_err(|e| fail("nominal fit on all poses", e))?;

    // The prior: as given, or chosen by held-out error (`auto`). The weights above come
    // from fits without it, so that a prior changes the model, not the weighting.
    let no_prior = all.robot;
    let (prior, auto_table) = match args.prior {
        None => (None, Vec::new()),
        Some(crate::args::PriorArg::Sizes { .. }) => {
            (args.prior_kinds.sizes(args.prior), Vec::new())
        }
        Some(crate::args::PriorArg::Auto) => choose_prior(
            nominal,
            &meas,
            &fold_of,
            args.folds,
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
    let pb = crate::progress::spinner(format!("cross-validating ({} folds)", args.folds));
    let folds = run_folds(
        nominal,
        &meas,
        &fold_of,
        args.folds,
        req_nom,
        req_cal,
        how(w),
    );
    pb.finish_and_clear();
    let (held_nom, held_cal, fold_info) = folds.map_err(|e| fail("cross-validation", e))?;
    let all_poses = |_: usize| true;
    let s_nom = summarize(&meas, &held_nom, all_poses);
    let s_cal = summarize(&meas, &held_cal, all_poses);
    let in_cal: Vec<PoseErrors> = meas
        .iter()
        .map(|m| errors(&all.robot, m))
        .collect::<Result<_, _>>()
        .map_err(|e| fail("residuals", e))?;
    let in_nom: Vec<PoseErrors> = meas
        .iter()
        .map(|m| errors(&nom_all.robot, m))
        .collect::<Result<_, _>>()
        .map_err(|e| fail("residuals", e))?;
    let s_in_cal = summarize(&meas, &in_cal, all_poses);
    let s_in_nom = summarize(&meas, &in_nom, all_poses);

    // Noise floor.
    let repeats = repeat_noise(&all.robot, &set, &meas).map_err(|e| fail("noise floor", e))?;

    // Robust fit and outliers (IRLS with --robust's loss, Cauchy by default, from the calibrated start).
    let robust_start = if args.init_frames {
        kincal::frames::estimate_frames(nominal, &meas)
            .map_err(|e| fail("frame estimate", e.to_string()))?
            .robot
    } else {
        *nominal
    };
    let mut rdata = meas.clone();
    let mut report = vec![PoseResidual::default(); meas.len()];
    let mut o = IdentifyOptions::new(Algorithm::Ols, req_cal);
    o.weight_pos = w.pos;
    o.weight_rot = w.rot;
    o.allow_data_deficiency = true;
    o.max_iterations = args.max_iterations;
    let mut ws = new_workspace();
    let robust = identify_robust(
        &robust_start,
        &mut rdata,
        &o,
        &RobustOptions::new(outlier_loss(args)),
        &mut report,
        &mut ws,
    );

    // Report.
    let analysis = all.analysis.as_ref();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Cross-validation of '{name}' on {}:\n  {n_groups} poses (pose_id groups, {} rows), {} folds (seed {}), {}",
        set.source,
        meas.len(),
        args.folds,
        args.seed,
        if orientation {
            "full poses"
        } else {
            "positions only"
        }
    );
    let eff_names: Vec<&str> = effects.iter().map(|e| e.name()).collect();
    let _ = writeln!(
        s,
        "Models: nominal = ROBOT geometry{}; calibrated = geometry ({}){}{}",
        if req_nom.is_empty() {
            String::new()
        } else {
            " with fitted frames".to_string()
        },
        args.geometry.join(", "),
        if eff_names.is_empty() {
            String::new()
        } else {
            format!(" + {}", eff_names.join(", "))
        },
        if args.init_frames {
            "; frames estimated from the training poses first (--init-frames)"
        } else {
            ""
        }
    );
    if args.robust.is_some() {
        let _ = writeln!(
            s,
            "Fits: robust ({} IRLS) in every fold and on all poses",
            outlier_loss(args).name()
        );
    }
    let _ = writeln!(
        s,
        "Weighting ({}): {:.4e} per m², {:.4e} per rad²{}",
        w.mode,
        w.pos,
        w.rot,
        match w.mode {
            "residual" if orientation => format!(
                " (σ = {:.4} mm, {:.4}° per axis)",
                1e3 / w.pos.sqrt(),
                (1.0 / w.rot.sqrt()).to_degrees()
            ),
            "residual" => format!(" (σ = {:.4} mm per axis)", 1e3 / w.pos.sqrt()),
            _ => String::new(),
        }
    );
    let prior_json = prior_report(
        &mut s,
        prior,
        args.prior == Some(crate::args::PriorArg::Auto),
        &auto_table,
        orientation,
    );
    let changes = |r: &Robot<N>| {
        let ((dl, pl), (da, pa)) = largest_changes(r, nominal, &req_cal);
        json!({"length_mm": dl * 1e3, "length_param": pl, "angle_deg": da.to_degrees(), "angle_param": pa})
    };
    let change_json =
        json!({"calibrated": changes(&all.robot), "without_prior": changes(&no_prior)});
    {
        let ((dl, pl), (da, pa)) = largest_changes(&all.robot, nominal, &req_cal);
        let _ = writeln!(
            s,
            "Largest change from nominal (calibrated on all poses): |Δ length| {:.3} mm ({pl}), |Δ angle| {:.3}° ({pa}){}",
            dl * 1e3,
            da.to_degrees(),
            if prior.is_some() {
                let ((dl, pl), (da, pa)) = largest_changes(&no_prior, nominal, &req_cal);
                format!(
                    "; without the prior {:.3} mm ({pl}), {:.3}° ({pa})",
                    dl * 1e3,
                    da.to_degrees()
                )
            } else {
                String::new()
            }
        );
    }
    if let Some(a) = analysis {
        let _ = writeln!(
            s,
            "Calibrated model on all poses: {} of {} requested parameters identified (rank {}, condition {:.3e}), {} structurally redundant, {} data-deficient",
            a.identifiable.len(),
            a.requested.len(),
            a.rank,
            a.condition_number,
            a.structural.len(),
            a.data_deficient.len()
        );
    }
    s.push('\n');
    let mut t = crate::report::Table::new(&[
        "model",
        "RMS e_p [mm]",
        "max e_p [mm]",
        "RMS e_φ [deg]",
        "max e_φ [deg]",
    ]);
    let line = |label: &str, x: &ErrorSummary| {
        vec![
            label.to_string(),
            format!("{:.4}", x.rms_pos_m() * 1e3),
            format!("{:.4}", x.max_pos_m * 1e3),
            if orientation {
                format!("{:.4}", x.rms_rot_rad().to_degrees())
            } else {
                "-".into()
            },
            if orientation {
                format!("{:.4}", x.max_rot_rad.to_degrees())
            } else {
                "-".into()
            },
        ]
    };
    t.row(line("nominal, held-out", &s_nom));
    t.row(line("calibrated, held-out", &s_cal));
    t.row(line("nominal, in-sample", &s_in_nom));
    t.row(line("calibrated, in-sample", &s_in_cal));
    s.push_str("Residuals (held-out: each pose predicted by the fit of the other folds):\n");
    s.push_str(&t.render("  "));
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { f64::INFINITY };
    let _ = writeln!(
        s,
        "  held-out RMS position: {:.3} mm -> {:.3} mm ({:.2}x lower){}",
        s_nom.rms_pos_m() * 1e3,
        s_cal.rms_pos_m() * 1e3,
        ratio(s_nom.rms_pos_m() * 1e3, s_cal.rms_pos_m() * 1e3),
        if orientation {
            format!(
                "; orientation {:.4}° -> {:.4}° ({:.2}x)",
                s_nom.rms_rot_rad().to_degrees(),
                s_cal.rms_rot_rad().to_degrees(),
                ratio(
                    s_nom.rms_rot_rad().to_degrees(),
                    s_cal.rms_rot_rad().to_degrees()
                )
            )
        } else {
            String::new()
        }
    );
    let mut ft = crate::report::Table::new(&[
        "fold",
        "poses",
        "nominal e_p [mm]",
        "calibrated e_p [mm]",
        "data-deficient",
        "algorithm",
    ]);
    let mut folds_json = Vec::new();
    for &(k, n, deficient, algorithm) in &fold_info {
        let keep = |i: usize| fold_of[i] == k;
        let (a, b) = (
            summarize(&meas, &held_nom, keep),
            summarize(&meas, &held_cal, keep),
        );
        ft.row(vec![
            format!("{}", k + 1),
            n.to_string(),
            format!("{:.4}", a.rms_pos_m() * 1e3),
            format!("{:.4}", b.rms_pos_m() * 1e3),
            deficient.to_string(),
            algorithm.to_uppercase(),
        ]);
        folds_json.push(json!({
            "fold": k + 1, "poses": n, "data_deficient": deficient, "algorithm": algorithm,
            "nominal": summary_json(&a, orientation), "calibrated": summary_json(&b, orientation),
        }));
    }
    s.push_str("Per fold (RMS):\n");
    s.push_str(&ft.render("  "));
    s.push('\n');
    let noise_json = match repeats {
        Ok((sp, sr, dp, dr)) => {
            let _ = writeln!(
                s,
                "Noise floor (repeated pose_ids, pooled scatter): σ_pos {:.4} mm ({dp} dof){}",
                sp * 1e3,
                if dr > 0 {
                    format!(", σ_rot {:.4}° ({dr} dof)", sr.to_degrees())
                } else {
                    String::new()
                }
            );
            json!({"source": "repeats", "sigma_pos_mm": sp * 1e3, "sigma_rot_deg": sr.to_degrees(), "dof_pos": dp, "dof_rot": dr})
        }
        Err(why) => {
            let _ = writeln!(
                s,
                "Noise floor: {why}; upper bound from the calibrated residual (dof-corrected): σ_pos {:.4} mm per axis (√3σ = {:.4} mm){}",
                sig_p * 1e3,
                3f64.sqrt() * sig_p * 1e3,
                if orientation {
                    format!(", σ_rot {:.4}° per axis", sig_r.to_degrees())
                } else {
                    String::new()
                }
            );
            json!({"source": "residual_upper_bound", "sigma_pos_mm": sig_p * 1e3, "sigma_rot_deg": if orientation { json!(sig_r.to_degrees()) } else { Value::Null }})
        }
    };
    let outliers_json = match &robust {
        Ok(r) => {
            let suspects: Vec<usize> = (0..meas.len()).filter(|&i| report[i].suspect).collect();
            let _ = writeln!(
                s,
                "Robust fit ({} IRLS, {} reweighted fits): robust scales σ_pos {:.4} mm{}; {} outlier(s) by the 99.99 % residual test{}",
                outlier_loss(args).name(),
                r.reweights,
                r.test.scale_pos_m * 1e3,
                if orientation {
                    format!(", σ_rot {:.4}°", r.test.scale_rot_rad.to_degrees())
                } else {
                    String::new()
                },
                suspects.len(),
                if suspects.is_empty() { "" } else { ":" }
            );
            for &i in &suspects {
                let row = &set.rows[i];
                let _ = writeln!(
                    s,
                    "  pose {} (line {}): d = {:.2}, |e_p| {:.3} mm{}, robust weight {:.3}",
                    row.pose_id.as_deref().unwrap_or("-"),
                    row.line,
                    report[i].distance,
                    report[i].pos_m * 1e3,
                    if orientation {
                        format!(", |e_φ| {:.4}°", report[i].rot_rad.to_degrees())
                    } else {
                        String::new()
                    },
                    report[i].robust_weight
                );
            }
            json!({
                "loss": "cauchy", "scale_pos_mm": r.test.scale_pos_m * 1e3,
                "scale_rot_deg": if orientation { json!(r.test.scale_rot_rad.to_degrees()) } else { Value::Null },
                "suspects": suspects.iter().map(|&i| json!({
                    "pose_id": set.rows[i].pose_id, "line": set.rows[i].line,
                    "distance": report[i].distance, "pos_mm": report[i].pos_m * 1e3,
                    "rot_deg": report[i].rot_rad.to_degrees(), "robust_weight": report[i].robust_weight,
                })).collect::<Vec<_>>(),
            })
        }
        Err(e) => {
            let _ = writeln!(s, "Robust fit failed: {e} (no outlier test)");
            json!({"error": e.to_string()})
        }
    };

    // Outputs.
    let mut inputs: Vec<&Path> = vec![&args.data];
    let robot_path = Path::new(&args.robot);
    if robot_path.is_file() {
        inputs.push(robot_path);
    }
    if let Some(p) = &args.json {
        let poses: Vec<Value> = (0..meas.len())
            .map(|i| {
                json!({
                    "pose_id": set.rows[i].pose_id, "line": set.rows[i].line, "fold": fold_of[i] + 1,
                    "nominal_pos_mm": held_nom[i].pos_norm_m * 1e3,
                    "calibrated_pos_mm": held_cal[i].pos_norm_m * 1e3,
                    "nominal_rot_deg": held_nom[i].rot_norm_rad.to_degrees(),
                    "calibrated_rot_deg": held_cal[i].rot_norm_rad.to_degrees(),
                })
            })
            .collect();
        let doc = json!({
            "format": "kincal-crossval", "schema_version": "1.0",
            "data": {"path": set.source, "sha256": set.sha256, "poses": meas.len(), "groups": n_groups, "orientation": orientation},
            "robot": name, "effects": eff_names, "geometry": args.geometry, "init_frames": args.init_frames, "robust": args.robust.is_some(), "robust_loss": args.robust.map(|l| Loss::from(l).name()),
            "folds": args.folds, "seed": args.seed,
            "weighting": {"mode": w.mode, "weight_pos": w.pos, "weight_rot": w.rot},
            "prior": prior_json, "largest_change": change_json,
            "identifiability": analysis.map(|a| json!({
                "requested": a.requested.len(), "identifiable": a.identifiable.len(),
                "structurally_redundant": a.structural.iter().map(crate::report::label::<N>).collect::<Vec<_>>(),
                "data_deficient": a.data_deficient.iter().map(crate::report::label::<N>).collect::<Vec<_>>(),
                "rank": a.rank,
                "condition_number": if a.condition_number.is_finite() { json!(a.condition_number) } else { Value::Null },
            })),
            "heldout": {"nominal": summary_json(&s_nom, orientation), "calibrated": summary_json(&s_cal, orientation)},
            "insample": {"nominal": summary_json(&s_in_nom, orientation), "calibrated": summary_json(&s_in_cal, orientation)},
            "per_fold": folds_json,
            "noise_floor": noise_json,
            "outliers": outliers_json,
            "poses": poses,
        });
        let text = serde_json::to_string_pretty(&doc).map_err(|e| CliError::io(e.to_string()))?;
        kincal_io::files::write_atomic(p, &inputs, |w| w.write_all(text.as_bytes()))?;
        let _ = writeln!(s, "JSON written to {}.", p.display());
    }
    if let Some(p) = &args.plot {
        let svg = crate::plots::pose_errors::heldout_svg(
            &format!("{name}: held-out errors per pose ({} folds)", args.folds),
            &held_nom,
            &held_cal,
            orientation,
        )
        .map_err(|e| CliError::io(format!("{}: cannot draw the figure: {e}", p.display())))?;
        kincal_io::files::write_atomic(p, &inputs, |w| w.write_all(svg.as_bytes()))?;
        let _ = writeln!(s, "Figure written to {}.", p.display());
    }
    if let Some(p) = &args.robot_out {
        let (base, tool) = (all.robot.base(), all.robot.tool());
        let start = if args.init_frames {
            kincal::frames::estimate_frames(nominal, &meas)
                .map_err(|e| fail("frame estimate", e.to_string()))?
                .robot
        } else {
            *nominal
        };
        let r = start
            .with_base(base)
            .and_then(|r| r.with_tool(tool))
            .map_err(|e| fail("frames", e.to_string()))?;
        let joint_names: Vec<String> = (1..=N).map(|k| format!("joint{k}")).collect();
        let text = format!(
            "# {name}: nominal geometry with the base and tool frames of the calibration on all\n\
             # poses of {} (written by kincal crossval --robot-out)\n{}",
            set.source,
            kincal_io::robot_file::write_generic(&format!("{name}-frames"), &joint_names, &r)
        );
        kincal_io::files::write_atomic(p, &inputs, |w| w.write_all(text.as_bytes()))?;
        let _ = writeln!(
            s,
            "Robot with the calibrated frames written to {}.",
            p.display()
        );
    }
    crate::report::emit(&s);
    Ok(())
}

/// Cross-validation of contact data by whole groups (see [`crate::commands::crossval_contacts`]).
fn crossval_contacts<const N: usize>(
    nominal: &Robot<N>,
    args: &Args,
    set: &MeasurementSet,
    effects: EffectSet,
) -> Result<(), CliError> {
    if args.init_frames || args.plot.is_some() || args.robot_out.is_some() {
        return Err(CliError::usage(
            "--init-frames, --plot and --robot-out are not implemented for data with \
             target/plane rows",
        ));
    }
    let cons = args
        .constraints
        .as_deref()
        .map(kincal_io::constraints::read_constraints)
        .transpose()?;
    let group_by = args.group_by.unwrap_or(if set.has_session {
        crate::commands::crossval_contacts::GroupBy::Session
    } else {
        crate::commands::crossval_contacts::GroupBy::Target
    });
    let mut requested = geometry_subset(nominal, &args.geometry).union(&effects.params(N));
    for k in 0..3 {
        // The contacted point (ball centre) as the tool translation.
        let _ = requested.insert(5 * N + 6 + k);
    }
    let weight_pos = args.sigma_pos_mm.map_or(1.0, |s| 1.0 / (s * 1e-3).powi(2));
    let plan = crate::commands::crossval_contacts::Plan {
        group_by,
        folds: args.folds,
        seed: args.seed,
        requested,
        weight_pos,
        max_iterations: args.max_iterations,
        constraints: cons.as_ref(),
        robust: args.robust.map(Loss::from),
    };
    let (text, json) = crate::commands::crossval_contacts::run(nominal, set, &plan)?;
    if let Some(path) = &args.json {
        let body = serde_json::to_string_pretty(&json)
            .map_err(|e| CliError::io(format!("{}: {e}", path.display())))?;
        let mut inputs: Vec<&Path> = vec![&args.data];
        if let Some(c) = &args.constraints {
            inputs.push(c);
        }
        kincal_io::files::write_atomic(path, &inputs, |w| w.write_all(body.as_bytes()))?;
    }
    crate::report::emit(&text);
    Ok(())
}
