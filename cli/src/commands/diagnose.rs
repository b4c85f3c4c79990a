//! `kincal diagnose DATA --robot ROBOT [--sigma-pos-mm S] [--sigma-rot-deg S] --json
//! REPORT.json --out MODEL`: the sim-to-real diagnosis of spec/effects.md. The core
//! (`kincal::diagnosis`) does every computation; this module reads the data, formats the
//! report (JSON per spec/cli.md and readable text), draws the plots and writes the model.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use kincal::diagnosis::{
    self, BeyondLibrary, Config, DiagWorkspace, Diagnosis, Method, ModelScore, Part, PoseDiagnosis,
    Reason, Status, Warning,
};
use kincal::identify::{Algorithm, Measurement};
use kincal::{Effect, EffectSet, ParamId, ParamIndex, ParamSet, Robot};
use serde::Serialize;

use crate::args::parse_effect;
use crate::error::{CliError, core_error};
use crate::plots::diagnosis::Outputs;
use crate::report::{self, Table, quantity_label, quantity_unit};
use kincal_io::calibration::{Calibration, Run, Settings, Weighting};
use kincal_io::data::{self, DataOptions};
use kincal_io::measurements::MeasurementSet;
use kincal_io::model_file::{DataJson, ModelFile};

pub const LONG_ABOUT: &str = "\
The sim-to-real gap diagnosis (spec/effects.md): after a geometric calibration, where does
the residual lie, which non-geometric effect causes it, and how far does it shrink when the
model is extended by that effect?

1. Noise floor: --sigma-pos-mm/--sigma-rot-deg (1σ per axis) when given; otherwise pooled
   from rows sharing a pose_id measured under the same conditions (same approach directions
   s1..sN, temperatures within 0.5 °C). Neither: exit 2.
2. Geometric calibration on all rows (OLS, rows weighted by 1/σ²).
3. Where: its residuals by axis, by octant of the data's bounding box, and their
   correlation with each joint angle, gravity torque, approach direction and temperature.
4. Which: every candidate effect (those whose input columns DATA has, or --candidates) alone
   and in pairs, fitted with the geometric parameters and judged on held-out poses (k-fold
   cross-validation, rows of one pose_id in the same fold). Structurally redundant effect
   parameters are removed, parameters these poses cannot separate from the geometry are
   reported (candidates with none left are 'confounded with the geometry').
5. Decision (rank tests over pose groups, thresholds z = 3): no_gap when the geometric
   model's held-out error is consistent with the noise floor (its expected value includes
   the parameter-estimation error on held-out poses); a candidate is significant when it
   beats the geometric model; the smallest significant candidate not significantly worse
   than the best wins; same-size candidates as good are listed as confounded_with.
   explained when it closes ≥ 80 % of the gap above the noise floor (whitened held-out RMS
   per row, position and rotation each by its noise, floor with the estimation error;
   gap_closed_fraction = (B − A)/(B − √3·σ_pos) on the position and the same on rotation
   are reported), its own remaining gap is not significant and it makes neither position
   nor rotation significantly worse; partially_explained from 25 % (or when the remaining
   gap is significant: the reason says where), else unexplained. A significant candidate
   is a gap even when the gap test says no_gap (σ stated too large: a warning says so).
   Gross outliers are screened first (suspect rows, named by CSV line, are left out); the
   stated σ is checked against the repeats and the residuals. With fewer than 5 pose
   groups per fold, in-sample nested tests replace cross-validation (method in the report).

Writes REPORT.json (spec/cli.md fields plus details), a readable report (--report, default
REPORT.txt next to it, also printed), three SVG plots next to REPORT.json (residual vectors
over the working region, residual against the most correlated quantity, held-out RMS per
candidate) and MODEL: geometric + the verdict's effects, fitted on all rows, which predict
and validate accept.

Exit status: 0 success (whatever the verdict), 2 usage (also: no noise floor), 3 bad input,
4 numerical failure.";

pub const EXAMPLE: &str = "\
Example:
  kincal diagnose session.csv --robot aria --json diag/REPORT.json --out diag/model.json
  kincal diagnose session.csv --robot aria --sigma-pos-mm 0.1 --sigma-rot-deg 0.02 \\
      --json REPORT.json --out model.json";

#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Measurement CSV (pose_id repeats give the noise floor; s1..sN and temp_c enable the
    /// backlash and thermal candidates)
    #[arg(value_name = "DATA")]
    pub data: PathBuf,
    /// Built-in robot name (aria) or robot description file (with its mass model)
    #[arg(long, value_name = "ROBOT")]
    pub robot: String,
    #[command(flatten)]
    pub chain: kincal_io::robot_arg::UrdfChainArgs,
    /// Instrument position noise, 1σ per axis [mm] (default: from repeats)
    #[arg(long, value_name = "S", value_parser = crate::args::sigma_mm)]
    pub sigma_pos_mm: Option<f64>,
    /// Instrument orientation noise, 1σ per axis [deg] (default: from repeats)
    #[arg(long, value_name = "S", value_parser = crate::args::sigma_deg)]
    pub sigma_rot_deg: Option<f64>,
    /// The diagnosis report (JSON)
    #[arg(long, value_name = "REPORT.json")]
    pub json: PathBuf,
    /// Model file to write: geometric + the verdict's effects
    #[arg(long, value_name = "MODEL")]
    pub out: PathBuf,
    /// Readable report (default: REPORT.json with the extension .txt)
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
    /// Candidate effects (comma-separated; default: every effect whose inputs DATA has)
    #[arg(long, value_name = "E1,E2", value_delimiter = ',', value_parser = parse_effect)]
    pub candidates: Vec<Effect>,
    /// Evaluate single effects only, not pairs
    #[arg(long)]
    pub no_pairs: bool,
    /// Cross-validation folds
    #[arg(long, value_name = "K", default_value_t = 5)]
    pub folds: usize,
    /// Seed of the fold assignment (as in crossval; the default keeps earlier reports)
    #[arg(long, value_name = "S", default_value_t = Config::default().fold_seed)]
    pub seed: u64,
    /// Accept joint readings outside the robot's joint limits
    #[arg(long)]
    pub allow_out_of_limits: bool,
    /// Known distances, targets and planes (TOML, docs/constraints.md) of data with
    /// target/plane rows
    #[arg(long, value_name = "FILE")]
    pub constraints: Option<PathBuf>,
    /// Fit the written MODEL (geometric + the verdict's effects) with Gaussian priors around
    /// the initial model, as `calibrate --prior`: one σ for link lengths [mm] and angles
    /// [deg] (`--prior` alone: 5,1), weighed against the noise floor. The candidates are
    /// judged without it.
    #[arg(long, value_name = "MM,DEG", value_parser = crate::args::prior, num_args = 0..=1, default_missing_value = "5,1")]
    pub prior: Option<crate::args::PriorArg>,
    #[command(flatten)]
    pub prior_kinds: crate::args::PriorKinds,
}

/// Capacity of the diagnosis workspace: the union of every model's columns of the largest
/// supported robot (15N + 7 ≤ 142 for 9 joints).
pub const DIAG_PARAMS: usize = 144;

/// A zeroed diagnosis workspace on the heap (about a megabyte).
pub fn new_workspace() -> Box<DiagWorkspace<DIAG_PARAMS>> {
    let b = Box::<DiagWorkspace<DIAG_PARAMS>>::new_zeroed();
    // SAFETY: the core documents all-zero as a valid `DiagWorkspace` (numbers, counters
    // and the identification workspace, itself valid when zeroed).
    unsafe { b.assume_init() }
}

/// What a diagnosis produced (for the demo, which validates the models further).
#[derive(Debug, Clone)]
pub struct Outcome<const N: usize> {
    pub diagnosis: Box<Diagnosis<N>>,
    /// The readable report, as written to its file.
    pub text: String,
    /// Run time [s] (for the screen, never written).
    pub seconds: f64,
}

pub fn run(args: &Args) -> Result<(), CliError> {
    let spec = kincal_io::robot_arg::resolve_robot(&args.robot, &args.chain)?;
    kincal::with_any_robot!(&spec.robot, r => {
        if let Some(text) = contact_diagnosis(r, args)? {
            report::emit(&text);
            return Ok(());
        }
        let out = execute(r, &spec.name, args)?;
        // The run time goes to the screen only: the report files are byte-for-byte
        // reproducible.
        report::emit(&format!("{}Diagnosis took {:.2} s.\n", out.text, out.seconds));
        Ok(())
    })
}

/// The diagnosis of data with target/plane rows ([`crate::commands::diagnose_contacts`]); `None`
/// for instrument data. Writes REPORT.json and the readable report; no model (contact data
/// are calibrated by `kincal calibrate`).
fn contact_diagnosis<const N: usize>(
    robot: &Robot<N>,
    args: &Args,
) -> Result<Option<String>, CliError> {
    let set = data::read(
        &args.data,
        robot,
        EffectSet::NONE,
        DataOptions {
            require_pose: true,
            allow_out_of_limits: args.allow_out_of_limits,
        },
    )?;
    if args.constraints.is_none() && !kincal_io::constraints::has_contacts(&set) {
        return Ok(None);
    }
    let options = crate::commands::diagnose_contacts::Options {
        candidates: &args.candidates,
        no_pairs: args.no_pairs,
        constraints: args.constraints.as_deref(),
        sigma_pos_mm: args.sigma_pos_mm,
        folds: args.folds,
    };
    let (mut text, json) = crate::commands::diagnose_contacts::run(robot, &set, &options)?;
    let _ = writeln!(
        text,
        "No model written to {}: calibrate contact data with `kincal calibrate DATA --robot R \
         --constraints C [--effects E]`.",
        args.out.display()
    );
    let outputs = Outputs::new(&args.json, args.report.as_deref(), &args.out);
    let mut inputs: Vec<&Path> = vec![&args.data];
    if let Some(c) = &args.constraints {
        inputs.push(c);
    }
    let body = serde_json::to_string_pretty(&json)
        .map_err(|e| CliError::io(format!("{}: {e}", outputs.json.display())))?;
    kincal_io::files::write_atomic(&outputs.json, &inputs, |w| w.write_all(body.as_bytes()))?;
    kincal_io::files::write_atomic(&outputs.report, &inputs, |w| w.write_all(text.as_bytes()))?;
    Ok(Some(text))
}

fn config(args: &Args) -> Result<Config, CliError> {
    if args.folds < 2 {
        return Err(CliError::usage(format!(
            "--folds {}: at least 2 folds are needed",
            args.folds
        )));
    }
    Ok(Config {
        sigma_pos_m: args.sigma_pos_mm.map(|s| s * 1e-3),
        sigma_rot_rad: args.sigma_rot_deg.map(f64::to_radians),
        folds: args.folds,
        candidates: (!args.candidates.is_empty()).then(|| {
            args.candidates
                .iter()
                .fold(EffectSet::NONE, |a, &e| a.with(e))
        }),
        pairs: !args.no_pairs,
        fold_seed: args.seed,
        ..Config::default()
    })
}

/// Group ids from the `pose_id` column: equal labels share an id; rows without one get
/// their own.
pub fn group_ids(set: &MeasurementSet) -> Vec<u32> {
    let mut ids: HashMap<&str, u32> = HashMap::new();
    let mut next = 0u32;
    set.rows
        .iter()
        .map(|row| {
            next += 1;
            match &row.pose_id {
                Some(label) => *ids.entry(label.as_str()).or_insert(next),
                None => next,
            }
        })
        .collect()
}

/// Why the repeats gave no noise floor: there are none, or those there are agree exactly.
fn why_no_repeat_scatter(groups: &[u32]) -> String {
    let mut sorted = groups.to_vec();
    sorted.sort_unstable();
    let repeated = sorted.windows(2).filter(|w| w[0] == w[1]).count();
    if repeated == 0 {
        "no pose_id was measured twice under the same conditions (same s1..sN, temperatures within 0.5 °C)".into()
    } else {
        format!(
            "{repeated} row(s) repeat an earlier pose_id, but the repeats under the same conditions \
             (same s1..sN, temperatures within 0.5 °C) agree exactly or differ in those conditions: \
             zero scatter estimates no noise"
        )
    }
}

/// Which stated noise the data still need: the sentence and the flags to name.
fn missing_sigma<const N: usize>(args: &Args, meas: &[Measurement<N>]) -> (String, String) {
    let has_rot = meas.iter().any(|m| m.mask.has_orientation());
    match (args.sigma_pos_mm, args.sigma_rot_deg, has_rot) {
        (Some(_), None, true) => (
            "--sigma-rot-deg is not given (the data measure orientation; --sigma-pos-mm covers positions only)".into(),
            "--sigma-rot-deg".into(),
        ),
        (None, Some(_), _) => (
            "--sigma-pos-mm is not given (--sigma-rot-deg covers orientations only)".into(),
            "--sigma-pos-mm".into(),
        ),
        (None, None, true) => (
            "neither --sigma-pos-mm nor --sigma-rot-deg is given".into(),
            "--sigma-pos-mm and --sigma-rot-deg".into(),
        ),
        _ => (
            "--sigma-pos-mm is not given".into(),
            "--sigma-pos-mm".into(),
        ),
    }
}

/// Reads DATA, runs the diagnosis and writes every output; returns the readable report.
pub fn execute<const N: usize>(
    robot: &Robot<N>,
    name: &str,
    args: &Args,
) -> Result<Outcome<N>, CliError> {
    let t0 = Instant::now();
    if args.prior == Some(crate::args::PriorArg::Auto) {
        return Err(CliError::usage(
            "--prior auto chooses the size by held-out error: run `kincal crossval --prior auto`, \
             then pass the size it reports (--prior MM,DEG)",
        ));
    }
    let cfg = config(args)?;
    let set = data::read(
        &args.data,
        robot,
        cfg.candidates.unwrap_or(EffectSet::NONE),
        DataOptions {
            require_pose: true,
            allow_out_of_limits: args.allow_out_of_limits,
        },
    )?;
    let meas = data::measurements::<N>(&set)?;
    let groups = group_ids(&set);
    let mut poses = vec![PoseDiagnosis::default(); meas.len()];
    let mut ws = new_workspace();
    let pb = crate::progress::spinner("diagnosing (cross-validating every candidate)");
    let result = diagnosis::diagnose(robot, &meas, &groups, &cfg, &mut poses, &mut ws);
    pb.finish_and_clear();
    let d = Box::new(result.map_err(|e| match e {
        kincal::Error::MissingInput {
            what: kincal::Quantity::NoiseFloor,
        } => CliError::usage(format!(
            "{}: no noise floor: {}, and {}\n\
             hint: state the instrument's noise (1σ per axis) with {}, or repeat some poses",
            set.source,
            why_no_repeat_scatter(&groups),
            missing_sigma(args, &meas).0,
            missing_sigma(args, &meas).1
        )),
        kincal::Error::TooFewData { found, needed } => CliError::input(format!(
            "{}: {found} distinct pose_id groups, {needed} folds need at least {needed}",
            set.source
        )),
        other => core_error(other, &set.source, |i| data::line_of(&set, i)),
    })?);
    let seconds = t0.elapsed().as_secs_f64();
    let outputs = Outputs::new(&args.json, args.report.as_deref(), &args.out);
    let mut inputs: Vec<&Path> = vec![&args.data];
    let robot_path = Path::new(&args.robot);
    if robot_path.is_file() {
        inputs.push(robot_path);
    }

    // Everything is rendered first, then the paths are checked (never an input, never the
    // same file twice), then each file is written atomically.
    let rows: usize = meas
        .iter()
        .map(|m| (0..6).filter(|&k| m.mask.has(k)).count())
        .sum();
    let cal = match args.prior_kinds.sizes(args.prior) {
        None => calibration_of(robot, &d),
        Some(sizes) => with_prior(robot, &d, &meas, sizes, &set.source)?,
    };
    let model_text = ModelFile::from_calibration(
        name,
        &cal,
        0,
        DataJson {
            path: args.data.display().to_string(),
            sha256: set.sha256.clone(),
            poses: meas.len(),
            rows,
        },
        args.allow_out_of_limits,
    )
    .to_json();
    let plots = crate::plots::diagnosis::render_all::<N>(&d, &meas, &poses, &outputs)?;
    let json = report_json::<N>(&d, &meas, &set, &poses, &args.data, &outputs);
    let json_text = serde_json::to_string_pretty(&json).unwrap_or_default() + "\n";
    let mut text = readable::<N>(name, &set, &d, &meas);
    let _ = writeln!(
        text,
        "\nFiles: {} (report), {} (readable), {} (model: geometric{}), plots {}",
        outputs.json.display(),
        outputs.report.display(),
        outputs.model.display(),
        d.verdict
            .effects
            .iter()
            .map(|e| format!(" + {}", e.name()))
            .collect::<String>(),
        plots
            .iter()
            .map(|(p, _)| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mut files: Vec<(&Path, &str)> = vec![
        (&outputs.model, &model_text),
        (&outputs.json, &json_text),
        (&outputs.report, &text),
    ];
    files.extend(plots.iter().map(|(p, svg)| (p.as_path(), svg.as_str())));
    for (k, (path, _)) in files.iter().enumerate() {
        if let Some(input) = inputs
            .iter()
            .find(|i| kincal_io::files::is_same_file(path, i))
        {
            return Err(CliError::usage(format!(
                "{}: refusing to write: this is the input file '{}' (an input is never overwritten; choose another output path)",
                path.display(),
                input.display()
            )));
        }
        if let Some((other, _)) = files[..k]
            .iter()
            .find(|(o, _)| kincal_io::files::is_same_file(path, o) || o == path)
        {
            return Err(CliError::usage(format!(
                "{}: two outputs name the same file ({}): give --json, --report and --out different paths",
                path.display(),
                other.display()
            )));
        }
    }
    for (path, content) in &files {
        kincal_io::files::write_atomic(path, &inputs, |w| w.write_all(content.as_bytes()))?;
    }
    Ok(Outcome {
        diagnosis: d,
        text,
        seconds,
    })
}

/// The verdict's fit as a one-run calibration (what `calibrate --effects …` would have
/// written for the same model), so predict and validate read it like any model file.
fn calibration_of<const N: usize>(start: &Robot<N>, d: &Diagnosis<N>) -> Calibration<N> {
    let mut settings = Settings::paper(vec![Algorithm::Ols]);
    settings.effects = d.verdict.effects;
    settings.weighting = Weighting::Sigma {
        pos_m: d.noise.sigma_pos_m,
        rot_rad: d.noise.sigma_rot_rad,
    };
    settings.allow_data_deficiency = true;
    Calibration {
        start: *start,
        settings,
        analysis: d.fit.analysis,
        singular_values: Vec::new(),
        runs: vec![Run {
            ident: d.fit,
            seconds: 0.0,
            robust: None,
        }],
        consensus: None,
    }
}

/// `--prior`: the verdict's model fitted again, as `calibrate --prior` would on the rows
/// the diagnosis kept (suspects left out), with the noise floor as the data's weights.
fn with_prior<const N: usize>(
    start: &Robot<N>,
    d: &Diagnosis<N>,
    meas: &[Measurement<N>],
    sizes: kincal::identify::PriorSizes,
    source: &str,
) -> Result<Calibration<N>, CliError> {
    let mut settings = calibration_of(start, d).settings;
    settings.prior = Some(sizes);
    let suspects = d.suspects.get(..d.n_suspects).unwrap_or_default();
    let kept: Vec<Measurement<N>> = meas
        .iter()
        .enumerate()
        .filter(|(i, _)| !suspects.iter().any(|&s| s as usize == *i))
        .map(|(_, m)| *m)
        .collect();
    kincal_io::calibration::calibrate(start, &kept, &settings).map_err(|f| {
        CliError::numeric(format!(
            "{source}: the verdict's model with the prior could not be fitted: {f:?}"
        ))
    })
}

// ---------------------------------------------------------------------------------------
// REPORT.json

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

fn names(set: EffectSet) -> Vec<String> {
    set.iter().map(|e| e.name().to_string()).collect()
}

fn label<const N: usize>(i: usize) -> String {
    ParamId::from_index(ParamIndex(i), N).map_or_else(|_| format!("#{i}"), |id| id.to_string())
}

fn labels<const N: usize>(set: &ParamSet) -> Vec<String> {
    set.iter().map(label::<N>).collect()
}

#[derive(Serialize)]
struct Report {
    /// `cross_validation` or `in_sample_nested` (too few pose groups for held-out poses).
    method: &'static str,
    /// Things to know about the data or the stated noise.
    warnings: Vec<WarningJson>,
    /// Gross outliers excluded from every fit and test.
    suspect_rows: Vec<SuspectJson>,
    noise_floor: NoiseJson,
    baseline: BaselineJson,
    candidates: Vec<CandidateJson>,
    verdict: VerdictJson,
    /// Library-free check: how much of the gap any smooth function of q explains.
    explainable: ExplainableJson,
    /// The same check on the verdict's held-out residuals (evaluated only when the
    /// verdict would otherwise be `explained`).
    remaining_structure: ExplainableJson,
    /// Leave-one-range-out check of the verdict's model (evaluated only when the verdict
    /// would otherwise be `explained` under cross-validation).
    extrapolation: ExtrapolationJson,
    /// Form check of a verdict with `joint_cyclic` (evaluated only when the verdict would
    /// otherwise be `explained` under cross-validation).
    form: FormJson,
    #[serde(rename = "where")]
    where_: WhereJson,
    data: DataInfoJson,
    settings: SettingsJson,
    files: FilesJson,
    // No run time here: it is shown on screen only, so that identical inputs give a
    // bit-identical report whatever the machine load or thread count.
}

#[derive(Serialize)]
struct NoiseJson {
    pos_mm: f64,
    rot_deg: f64,
    /// "stated" or "repeats", per component type.
    pos_source: &'static str,
    rot_source: &'static str,
    dof_pos: Option<f64>,
    dof_rot: Option<f64>,
    repeat_subgroups: usize,
    /// √3·σ_pos: RMS position error of pure noise [mm].
    rms_pos_mm: f64,
    rms_rot_deg: f64,
    /// σ per axis the repeats alone give (also when σ was stated) [mm], [°].
    repeats_pos_mm: Option<f64>,
    repeats_rot_deg: Option<f64>,
}

#[derive(Serialize)]
struct WarningJson {
    code: &'static str,
    message: String,
}

#[derive(Serialize)]
struct SuspectJson {
    /// Zero-based row of the data.
    index: usize,
    line: u64,
    pose_id: Option<String>,
}

#[derive(Serialize)]
struct BaselineJson {
    heldout_rms_pos_mm: f64,
    heldout_rms_rot_deg: f64,
    insample_rms_pos_mm: f64,
    insample_rms_rot_deg: f64,
    /// Held-out RMS expected at the noise floor (√3σ inflated by estimation error).
    expected_rms_pos_mm: f64,
    expected_rms_rot_deg: f64,
    /// Observed over expected whitened held-out total, and its z (the gap test).
    gap_ratio: f64,
    gap_z: Option<f64>,
    /// The gap test on the position rows alone and on the rotation rows alone.
    gap_z_pos: Option<f64>,
    gap_z_rot: Option<f64>,
    gap: bool,
    fitted_params: usize,
}

#[derive(Serialize)]
struct DroppedJson {
    label: String,
    aligned_with: Option<String>,
    cosine: f64,
}

#[derive(Serialize)]
struct CandidateJson {
    effects: Vec<String>,
    heldout_rms_pos_mm: f64,
    heldout_rms_rot_deg: f64,
    significant: bool,
    evaluated: bool,
    /// No effect parameter separable from the geometry on these poses.
    confounded_with_geometry: bool,
    improvement_z: Option<f64>,
    z_vs_best: Option<f64>,
    /// Paired z of the improvement in position alone and in rotation alone (negative:
    /// worse).
    z_pos: Option<f64>,
    z_rot: Option<f64>,
    gap_closed_fraction: f64,
    gap_closed_rot_fraction: f64,
    /// Whitened share (position and rotation by their noise): what the status is decided on.
    gap_closed_total_fraction: f64,
    fitted_params: usize,
    distinctness: f64,
    least_distinct: Option<String>,
    structurally_redundant: Vec<String>,
    data_deficient: Vec<DroppedJson>,
}

#[derive(Serialize)]
struct VerdictJson {
    effects: Vec<String>,
    status: &'static str,
    /// Effect names of every candidate confounded with the verdict (a pair as its names).
    confounded_with: Vec<String>,
    /// The same, one list per confounded candidate.
    confounded_candidates: Vec<Vec<String>>,
    gap_closed_fraction: f64,
    /// Share of the held-out RMS rotation angle's gap closed.
    gap_closed_rot_fraction: f64,
    /// Whitened share of the gap closed (position and rotation): the status's share.
    gap_closed_total_fraction: f64,
    /// Why the status: `closed`, `remaining_gap`, `worsens`, `small_share`,
    /// `no_significant_candidate`, `at_noise_floor`.
    reason: &'static str,
    reason_text: String,
    /// What lies beyond the library when the gap stays open (the smooth check):
    /// `smooth_effect`, `not_a_function_of_q` or `not_applicable`.
    beyond_library: &'static str,
    heldout_rms_pos_mm: f64,
    heldout_rms_rot_deg: f64,
    /// z of what remains against the noise floor.
    remaining_gap_z: Option<f64>,
    remaining_gap_z_pos: Option<f64>,
    remaining_gap_z_rot: Option<f64>,
    /// The remaining-gap test exceeds z_gap.
    remaining_gap_significant: bool,
    /// Held-out RMS of what remains per axis.
    remaining_rms_axis: AxisJson,
    /// Identified effect parameters of the model (SI units) with standard errors.
    parameters: Vec<ParamValueJson>,
}

/// The "explainable at all?" check (kincal::diagnosis::SmoothCheck).
#[derive(Serialize)]
struct ExplainableJson {
    evaluated: bool,
    /// Share of the held-out gap (whitened position and rotation) a cross-validated
    /// smooth function of the joint angles removes.
    share_of_gap: f64,
    share_pos: f64,
    share_rot: f64,
    heldout_rms_pos_mm: f64,
    heldout_rms_rot_deg: f64,
    /// Paired Wilcoxon z against the geometric model (positive: better).
    z: Option<f64>,
    significant: bool,
    method: &'static str,
}

#[derive(Serialize)]
struct FormJson {
    evaluated: bool,
    /// Paired z of the alternative (3rd and 4th harmonics in place of joint_cyclic's 1st
    /// and 2nd) against the verdict's model (positive: the alternative is worse).
    z: Option<f64>,
    heldout_rms_pos_mm: f64,
    heldout_rms_rot_deg: f64,
    /// The alternative explains the data as well: the form is not determined.
    equivalent: bool,
    method: &'static str,
}

#[derive(Serialize)]
struct ExtrapolationJson {
    evaluated: bool,
    /// Half-range splits evaluated (two per joint at most).
    splits: usize,
    /// Largest z over the splits (held-out total against its expectation under the model).
    z: Option<f64>,
    /// Held-out whitened total over its expectation, of that split.
    ratio: f64,
    /// Joint (1-based) whose range that split halves; null when not evaluated.
    joint: Option<usize>,
    /// `upper` or `lower`: the half held out.
    held_out_half: &'static str,
    /// Bonferroni-corrected threshold of the largest z.
    threshold: f64,
    /// The model does not predict the held-out half.
    significant: bool,
    method: &'static str,
}

#[derive(Serialize)]
struct ParamValueJson {
    label: String,
    value: f64,
    unit: &'static str,
    std_error: f64,
}

#[derive(Serialize)]
struct RegionJson {
    min_mm: [f64; 3],
    max_mm: [f64; 3],
    count: usize,
    rms_pos_mm: f64,
    rms_rot_deg: f64,
    mean_pos_mm: [f64; 3],
}

#[derive(Serialize)]
struct CorrelationJson {
    quantity: String,
    unit: &'static str,
    /// Pearson correlation with the residual components x, y, z, φx, φy, φz.
    corr: [f64; 6],
    corr_norm_pos: f64,
    explained_pos: f64,
    explained_rot: f64,
    /// Share of the whitened residual (all six components) explained: the ranking.
    explained: f64,
}

#[derive(Serialize)]
struct PoseJson {
    line: u64,
    pose_id: Option<String>,
    fold: u16,
    residual_mm: [f64; 3],
    residual_deg: [f64; 3],
    heldout_geometric_mm: [f64; 3],
    heldout_final_mm: [f64; 3],
    heldout_geometric_norm_mm: f64,
    heldout_final_norm_mm: f64,
    /// A gross outlier: excluded from every fit and test.
    suspect: bool,
}

#[derive(Serialize)]
struct WhereJson {
    /// Residuals of the geometric calibration (all rows).
    rms_axis: AxisJson,
    mean_axis: AxisJson,
    rms_pos_mm: f64,
    rms_rot_deg: f64,
    bbox_min_mm: [f64; 3],
    bbox_max_mm: [f64; 3],
    regions: Vec<RegionJson>,
    correlations: Vec<CorrelationJson>,
    most_correlated: Option<String>,
    per_pose: Vec<PoseJson>,
}

#[derive(Serialize)]
struct AxisJson {
    x_mm: f64,
    y_mm: f64,
    z_mm: f64,
    rx_deg: f64,
    ry_deg: f64,
    rz_deg: f64,
}

#[derive(Serialize)]
struct DataInfoJson {
    path: String,
    sha256: String,
    rows: usize,
    groups: usize,
    folds: usize,
    has_approach: bool,
    has_temperature: bool,
}

#[derive(Serialize)]
struct SettingsJson {
    z_gap: f64,
    z_significance: f64,
    z_equivalence: f64,
    explained_fraction: f64,
    partial_fraction: f64,
    pairs: bool,
    candidates: Vec<String>,
    paired_test: &'static str,
}

#[derive(Serialize)]
struct FilesJson {
    model: String,
    report: String,
    plots: Vec<String>,
}

fn axis(v: &[f64; 6]) -> AxisJson {
    AxisJson {
        x_mm: v[0] * 1e3,
        y_mm: v[1] * 1e3,
        z_mm: v[2] * 1e3,
        rx_deg: v[3].to_degrees(),
        ry_deg: v[4].to_degrees(),
        rz_deg: v[5].to_degrees(),
    }
}

fn mm3(v: &[f64]) -> [f64; 3] {
    [v[0] * 1e3, v[1] * 1e3, v[2] * 1e3]
}

fn norm3(v: &[f64]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn candidate_json<const N: usize>(c: &ModelScore) -> CandidateJson {
    CandidateJson {
        effects: names(c.effects),
        heldout_rms_pos_mm: c.heldout_rms_pos_m * 1e3,
        heldout_rms_rot_deg: c.heldout_rms_rot_rad.to_degrees(),
        significant: c.significant,
        evaluated: c.evaluated,
        confounded_with_geometry: !c.evaluated,
        improvement_z: c.evaluated.then_some(c.improvement_z).and_then(finite),
        z_vs_best: c.evaluated.then_some(c.z_vs_best).and_then(finite),
        z_pos: c.evaluated.then_some(c.z_pos).and_then(finite),
        z_rot: c.evaluated.then_some(c.z_rot).and_then(finite),
        gap_closed_fraction: c.gap_closed_fraction,
        gap_closed_rot_fraction: c.gap_closed_rot_fraction,
        gap_closed_total_fraction: c.gap_closed_total_fraction,
        fitted_params: c.fitted_params,
        distinctness: c.distinctness,
        least_distinct: c.least_distinct.map(|p| label::<N>(p.0)),
        structurally_redundant: labels::<N>(&c.structural),
        data_deficient: c
            .data_deficient
            .iter()
            .map(|i| {
                let d = c.dropped.iter().flatten().find(|d| d.param.0 == i);
                DroppedJson {
                    label: label::<N>(i),
                    aligned_with: d.and_then(|d| d.partner).map(|p| label::<N>(p.0)),
                    cosine: d.map_or(0.0, |d| d.cosine),
                }
            })
            .collect(),
    }
}

#[allow(clippy::too_many_arguments)]
fn report_json<const N: usize>(
    d: &Diagnosis<N>,
    meas: &[Measurement<N>],
    set: &MeasurementSet,
    poses: &[PoseDiagnosis],
    data_path: &Path,
    outputs: &Outputs,
) -> Report {
    let n = &d.noise;
    let loc = &d.location;
    let effect_params = d
        .verdict
        .effects
        .iter()
        .fold(ParamSet::new(), |acc, e| acc.union(&e.params(N)));
    let parameters = d
        .fit
        .analysis
        .identifiable
        .iter()
        .filter(|&i| effect_params.contains(i))
        .map(|i| ParamValueJson {
            label: label::<N>(i),
            value: d.model.param(ParamIndex(i)).unwrap_or(f64::NAN),
            unit: ParamId::from_index(ParamIndex(i), N).map_or("", kincal_io::units::si_unit),
            std_error: d.fit.std_errors[i],
        })
        .collect();
    let winner = d.verdict.candidate.and_then(|c| d.candidates().get(c));
    Report {
        method: d.method.name(),
        warnings: d
            .warnings()
            .map(|w| WarningJson {
                code: w.code(),
                message: warning_text(w),
            })
            .collect(),
        suspect_rows: suspect_rows(d, set),
        noise_floor: NoiseJson {
            pos_mm: n.sigma_pos_m * 1e3,
            rot_deg: n.sigma_rot_rad.to_degrees(),
            pos_source: if n.stated_pos { "stated" } else { "repeats" },
            rot_source: if n.stated_rot { "stated" } else { "repeats" },
            dof_pos: finite(n.dof_pos),
            dof_rot: finite(n.dof_rot),
            repeat_subgroups: n.repeat_subgroups,
            rms_pos_mm: n.rms_pos_m() * 1e3,
            rms_rot_deg: n.rms_rot_rad().to_degrees(),
            repeats_pos_mm: n.repeat_pos.map(|(s, _)| s * 1e3),
            repeats_rot_deg: n.repeat_rot.map(|(s, _)| s.to_degrees()),
        },
        baseline: BaselineJson {
            heldout_rms_pos_mm: d.baseline.heldout_rms_pos_m * 1e3,
            heldout_rms_rot_deg: d.baseline.heldout_rms_rot_rad.to_degrees(),
            insample_rms_pos_mm: d.geometric_residuals.rms_pos_m * 1e3,
            insample_rms_rot_deg: d.geometric_residuals.rms_rot_rad.to_degrees(),
            expected_rms_pos_mm: d.gap.expected_rms_pos_m * 1e3,
            expected_rms_rot_deg: d.gap.expected_rms_rot_rad.to_degrees(),
            gap_ratio: d.gap.ratio,
            gap_z: finite(d.gap.z),
            gap_z_pos: finite(d.gap.z_pos),
            gap_z_rot: finite(d.gap.z_rot),
            gap: d.verdict.status != Status::NoGap,
            fitted_params: d.baseline.fitted_params,
        },
        candidates: d.candidates().iter().map(candidate_json::<N>).collect(),
        verdict: VerdictJson {
            effects: names(d.verdict.effects),
            status: d.verdict.status.name(),
            confounded_with: names(d.verdict.confounded_effects()),
            confounded_candidates: d.verdict.confounded().iter().map(|s| names(*s)).collect(),
            gap_closed_fraction: d.verdict.gap_closed_fraction,
            gap_closed_rot_fraction: winner.map_or(0.0, |c| c.gap_closed_rot_fraction),
            gap_closed_total_fraction: winner.map_or(0.0, |c| c.gap_closed_total_fraction),
            reason: reason_code(&d.verdict.reason),
            reason_text: reason_text(d),
            beyond_library: d.beyond_library().name(),
            heldout_rms_pos_mm: d.final_heldout_rms_pos_m * 1e3,
            heldout_rms_rot_deg: d.final_heldout_rms_rot_rad.to_degrees(),
            remaining_gap_z: finite(d.remaining.z),
            remaining_gap_z_pos: finite(d.remaining.z_pos),
            remaining_gap_z_rot: finite(d.remaining.z_rot),
            remaining_gap_significant: d.remaining.z > Config::default().z_gap,
            remaining_rms_axis: axis(&d.final_rms_axis),
            parameters,
        },
        explainable: explainable_json(&d.explainable),
        remaining_structure: explainable_json(&d.remaining_structure),
        extrapolation: extrapolation_json(&d.extrapolation),
        form: FormJson {
            evaluated: d.form.evaluated,
            z: if d.form.evaluated {
                finite(d.form.z)
            } else {
                None
            },
            heldout_rms_pos_mm: d.form.heldout_rms_pos_m * 1e3,
            heldout_rms_rot_deg: d.form.heldout_rms_rot_rad.to_degrees(),
            equivalent: d.form.equivalent,
            method: "the verdict's model cross-validated with each joint's 3rd and 4th harmonics in place of joint_cyclic's 1st and 2nd; paired Wilcoxon z over pose groups against the verdict",
        },
        where_: WhereJson {
            rms_axis: axis(&loc.rms_axis),
            mean_axis: axis(&loc.mean_axis),
            rms_pos_mm: loc.rms_pos_m * 1e3,
            rms_rot_deg: loc.rms_rot_rad.to_degrees(),
            bbox_min_mm: mm3(&loc.bbox_min_m),
            bbox_max_mm: mm3(&loc.bbox_max_m),
            regions: loc
                .regions
                .iter()
                .map(|r| RegionJson {
                    min_mm: mm3(&r.min_m),
                    max_mm: mm3(&r.max_m),
                    count: r.count,
                    rms_pos_mm: r.rms_pos_m * 1e3,
                    rms_rot_deg: r.rms_rot_rad.to_degrees(),
                    mean_pos_mm: mm3(&r.mean_pos_m),
                })
                .collect(),
            correlations: loc
                .correlates()
                .iter()
                .map(|c| CorrelationJson {
                    quantity: quantity_label(c.quantity),
                    unit: quantity_unit(c.quantity),
                    corr: c.corr,
                    corr_norm_pos: c.corr_norm_pos,
                    explained_pos: c.explained_pos,
                    explained_rot: c.explained_rot,
                    explained: c.explained,
                })
                .collect(),
            most_correlated: loc
                .most_correlated
                .map(|k| quantity_label(loc.correlates()[k].quantity)),
            per_pose: poses
                .iter()
                .zip(&set.rows)
                .map(|(p, row)| PoseJson {
                    line: row.line,
                    pose_id: row.pose_id.clone(),
                    fold: p.fold,
                    residual_mm: mm3(&p.residual[..3]),
                    residual_deg: [
                        p.residual[3].to_degrees(),
                        p.residual[4].to_degrees(),
                        p.residual[5].to_degrees(),
                    ],
                    heldout_geometric_mm: mm3(&p.heldout_baseline[..3]),
                    heldout_final_mm: mm3(&p.heldout_final[..3]),
                    heldout_geometric_norm_mm: norm3(&p.heldout_baseline[..3]) * 1e3,
                    heldout_final_norm_mm: norm3(&p.heldout_final[..3]) * 1e3,
                    suspect: p.suspect,
                })
                .collect(),
        },
        data: DataInfoJson {
            path: data_path.display().to_string(),
            sha256: set.sha256.clone(),
            rows: meas.len(),
            groups: d.groups,
            folds: d.folds,
            has_approach: set.has_approach,
            has_temperature: set.has_temperature,
        },
        settings: {
            let c = Config::default();
            SettingsJson {
                z_gap: c.z_gap,
                z_significance: c.z_significance,
                z_equivalence: c.z_equivalence,
                explained_fraction: c.explained_fraction,
                partial_fraction: c.partial_fraction,
                pairs: d.candidates().iter().any(|c| c.effects.len() == 2),
                candidates: names(d.candidates().iter().fold(EffectSet::NONE, |acc, c| {
                    c.effects.iter().fold(acc, EffectSet::with)
                })),
                paired_test: match d.method {
                    Method::CrossValidation => {
                        "Wilcoxon signed-rank over pose_id groups of the whitened held-out squared errors"
                    }
                    Method::InSampleNested => {
                        "likelihood ratio against the geometric model (Wilson-Hilferty z); Vuong over pose_id groups between candidates"
                    }
                },
            }
        },
        files: FilesJson {
            model: outputs.model.display().to_string(),
            report: outputs.report.display().to_string(),
            plots: [
                &outputs.plot_residuals,
                &outputs.plot_correlate,
                &outputs.plot_candidates,
            ]
            .iter()
            .map(|p| p.display().to_string())
            .collect(),
        },
    }
}

fn suspect_rows<const N: usize>(d: &Diagnosis<N>, set: &MeasurementSet) -> Vec<SuspectJson> {
    d.suspects()
        .iter()
        .map(|&l| {
            let row = set.rows.get(l as usize);
            SuspectJson {
                index: l as usize,
                line: row.map_or(0, |r| r.line),
                pose_id: row.and_then(|r| r.pose_id.clone()),
            }
        })
        .collect()
}

fn part_text(p: Part) -> &'static str {
    p.name()
}

/// The readable text of a warning.
pub fn warning_text(w: &Warning) -> String {
    let noise = |part: Part| match part {
        Part::Rotation => "orientation",
        _ => "position",
    };
    let factor = |ratio: f64| {
        if ratio < 1.0 {
            format!("{:.1}x quieter", 1.0 / ratio)
        } else {
            format!("{ratio:.1}x noisier")
        }
    };
    match *w {
        Warning::NoiseVsRepeats { part, ratio, z } => format!(
            "the repeats are {} than the stated {} noise (z = {z:.1}): check --sigma-{}{}",
            factor(ratio),
            noise(part),
            if part == Part::Rotation {
                "rot-deg"
            } else {
                "pos-mm"
            },
            if ratio > 1.0 {
                "; the noise floor uses the repeats' sigma (repeatability bounds the noise from below)"
            } else {
                ""
            }
        ),
        Warning::NoiseVsResiduals { part, ratio, z } => format!(
            "data are {} than the stated {} noise: the geometric calibration's residuals are below it (sqrt(chi2/dof) = {ratio:.2}, z = {z:.1})",
            factor(ratio),
            noise(part)
        ),
        Warning::GapDespiteGapTest { z_gap, z_candidate } => format!(
            "the gap test finds no gap at the stated noise (z = {z_gap:.1}) but a candidate improves significantly (z = {z_candidate:.1}): there is a gap; the stated noise is probably too large"
        ),
        Warning::TooManySuspects { count } => format!(
            "{count} rows fail the outlier test: too many to be gross outliers (heavy-tailed residuals, or an effect outside the library); none excluded"
        ),
    }
}

/// The JSON form of a smooth check.
fn explainable_json(x: &diagnosis::SmoothCheck) -> ExplainableJson {
    ExplainableJson {
        evaluated: x.evaluated,
        share_of_gap: x.share_of_gap,
        share_pos: x.share_pos,
        share_rot: x.share_rot,
        heldout_rms_pos_mm: x.heldout_rms_pos_m * 1e3,
        heldout_rms_rot_deg: x.heldout_rms_rot_rad.to_degrees(),
        z: finite(x.z),
        significant: x.significant,
        method: "kernel ridge regression on (sin q, cos q): linear + random Fourier features of a squared-exponential kernel, nested cross-validation on the diagnosis folds",
    }
}

/// The JSON form of the extrapolation check.
fn extrapolation_json(x: &diagnosis::ExtrapolationCheck) -> ExtrapolationJson {
    ExtrapolationJson {
        evaluated: x.evaluated,
        splits: x.splits,
        z: if x.evaluated { finite(x.z) } else { None },
        ratio: x.ratio,
        joint: x.evaluated.then_some(x.joint + 1),
        held_out_half: if x.upper { "upper" } else { "lower" },
        threshold: x.threshold,
        significant: x.significant,
        method: "leave-one-range-out: the verdict's model fitted on one half of each joint's range (split at the median) and judged on the other; exact moments of the held-out total, Satterthwaite/Wilson-Hilferty z, Bonferroni over the splits",
    }
}

fn reason_code(r: &Reason) -> &'static str {
    match r {
        Reason::AtNoiseFloor => "at_noise_floor",
        Reason::Closed => "closed",
        Reason::RemainingGap { .. } => "remaining_gap",
        Reason::RemainingStructure { .. } => "remaining_structure",
        Reason::DoesNotExtrapolate { .. } => "does_not_extrapolate",
        Reason::FormNotDetermined { .. } => "form_not_determined",
        Reason::Worsens { .. } => "worsens",
        Reason::SmallShare => "small_share",
        Reason::NoSignificantCandidate => "no_significant_candidate",
    }
}

/// The axis (x, y, z, φx, φy, φz) whose remaining held-out RMS stands out most above its
/// noise (by σ).
fn worst_axis<const N: usize>(d: &Diagnosis<N>) -> &'static str {
    const AXES: [&str; 6] = ["x", "y", "z", "φx", "φy", "φz"];
    let sigma = |k: usize| {
        if k < 3 {
            d.noise.sigma_pos_m
        } else {
            d.noise.sigma_rot_rad
        }
    };
    (0..6)
        .max_by(|&a, &b| {
            (d.final_rms_axis[a] / sigma(a)).total_cmp(&(d.final_rms_axis[b] / sigma(b)))
        })
        .map_or("", |k| AXES[k])
}

/// Why the verdict's status, in words, with what lies beyond the library when a gap stays
/// open.
fn reason_text<const N: usize>(d: &Diagnosis<N>) -> String {
    let mut text = status_reason_text(d);
    match d.beyond_library() {
        BeyondLibrary::NotApplicable => {}
        BeyondLibrary::SmoothEffect { share } => {
            let _ = write!(
                text,
                "; a library-free smooth function of the joint angles closes {:.0} % of the gap held out: not explained by the library (an effect outside it)",
                100.0 * share
            );
        }
        BeyondLibrary::NotAFunctionOfQ => text.push_str(
            "; no smooth function of the joint angles explains what remains either (noise-like, drift or set-up changes, not a function of q)",
        ),
    }
    text
}

/// Why the verdict's status, in words.
fn status_reason_text<const N: usize>(d: &Diagnosis<N>) -> String {
    match d.verdict.reason {
        Reason::AtNoiseFloor => {
            "the geometric model's held-out error is consistent with the noise floor".into()
        }
        Reason::Closed => {
            "the chosen effects close the gap; what remains is consistent with the noise floor"
                .into()
        }
        Reason::RemainingGap { z, part } => format!(
            "remaining gap significant (z = {z:.1}), in {} (largest on axis {}): part of the gap is not explained by the chosen effects",
            part_text(part),
            worst_axis(d)
        ),
        Reason::RemainingStructure { z } => format!(
            "what the chosen effects leave is near the noise floor but not noise-like: a library-free smooth function of the joint angles still explains part of it held out (z = {z:.1}); part of the gap is not explained by the chosen effects"
        ),
        Reason::DoesNotExtrapolate { z, joint, upper } => format!(
            "what the chosen effects leave is near the noise floor where they were fitted, but fitted on the {} half of joint {}'s range they do not predict the {} half (z = {z:.1}): they absorb an effect of another form (outside the library) rather than explain it",
            if upper { "lower" } else { "upper" },
            joint + 1,
            if upper { "upper" } else { "lower" }
        ),
        Reason::FormNotDetermined { z } => format!(
            "the chosen effects fit, but a function of the same joints outside the library (3rd and 4th harmonics in place of joint_cyclic's 1st and 2nd) explains the data as well held out (paired z = {z:.1}): the data do not determine the effect's form, so part of the gap may come from an effect outside the library"
        ),
        Reason::Worsens { z, part } => format!(
            "the chosen effects make the {} significantly worse (z = {z:.1})",
            part_text(part)
        ),
        Reason::SmallShare => "the chosen effects close only part of the gap".into(),
        Reason::NoSignificantCandidate => {
            "no candidate improves significantly on the geometric model".into()
        }
    }
}

// ---------------------------------------------------------------------------------------
// Readable report

fn mm(v: f64) -> String {
    format!("{:.3}", v * 1e3)
}

fn deg(v: f64) -> String {
    format!("{:.4}", v.to_degrees())
}

fn zfmt(z: f64) -> String {
    if z.is_finite() {
        format!("{z:.1}")
    } else if z > 0.0 {
        "+inf".into()
    } else {
        "-inf".into()
    }
}

fn effects_text(s: EffectSet) -> String {
    if s.is_empty() {
        "geometric only".into()
    } else {
        s.iter().map(|e| e.name()).collect::<Vec<_>>().join(" + ")
    }
}

/// The readable report.
pub fn readable<const N: usize>(
    robot: &str,
    set: &MeasurementSet,
    d: &Diagnosis<N>,
    meas: &[Measurement<N>],
) -> String {
    let mut s = String::new();
    let n = &d.noise;
    let source = &set.source;
    let _ = writeln!(
        s,
        "Sim-to-real diagnosis of '{robot}' from {source}: {} rows in {} pose groups, {}\n",
        meas.len(),
        d.groups,
        match d.method {
            Method::CrossValidation => format!("{}-fold cross-validation by pose_id", d.folds),
            Method::InSampleNested => format!(
                "too few groups for {}-fold cross-validation: in-sample nested tests with the noise floor (likelihood ratio against the geometric model, Vuong between candidates)",
                d.folds
            ),
        }
    );
    let src = |stated: bool, dof: f64| {
        if stated {
            "stated".to_string()
        } else {
            format!("from repeats, {dof:.0} degrees of freedom")
        }
    };
    let _ = writeln!(
        s,
        "Noise floor: {} mm ({}) and {}° ({}) per axis; pure noise gives an RMS of √3σ = {} mm, {}°.",
        mm(n.sigma_pos_m),
        src(n.stated_pos, n.dof_pos),
        deg(n.sigma_rot_rad),
        src(n.stated_rot, n.dof_rot),
        mm(n.rms_pos_m()),
        deg(n.rms_rot_rad())
    );
    let _ = writeln!(
        s,
        "Geometric calibration ({} parameters): in-sample RMS {} mm, {}°; held-out RMS {} mm, {}°\n  (expected at the noise floor, estimation error included: {} mm, {}°): observed/expected {:.2}, gap z = {} → {}.\n",
        d.baseline.fitted_params,
        mm(d.geometric_residuals.rms_pos_m),
        deg(d.geometric_residuals.rms_rot_rad),
        mm(d.baseline.heldout_rms_pos_m),
        deg(d.baseline.heldout_rms_rot_rad),
        mm(d.gap.expected_rms_pos_m),
        deg(d.gap.expected_rms_rot_rad),
        d.gap.ratio,
        zfmt(d.gap.z),
        if d.verdict.status == Status::NoGap {
            "consistent with the noise floor (no gap)"
        } else {
            "a gap above the noise floor"
        }
    );

    if !d.suspects().is_empty() {
        let _ = writeln!(
            s,
            "Suspect rows (gross outliers, excluded from every fit and test): {}\n",
            suspect_rows(d, set)
                .iter()
                .map(|r| match &r.pose_id {
                    Some(id) => format!("line {} (pose_id {id})", r.line),
                    None => format!("line {}", r.line),
                })
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    for w in d.warnings() {
        let _ = writeln!(s, "WARNING: {}", warning_text(w));
    }
    if d.n_warnings > 0 {
        s.push('\n');
    }

    // Where.
    let loc = &d.location;
    let _ = writeln!(
        s,
        "WHERE — residuals of the geometric calibration (all rows):"
    );
    let _ = writeln!(
        s,
        "  by axis (RMS): x {} y {} z {} mm; φx {} φy {} φz {}°",
        mm(loc.rms_axis[0]),
        mm(loc.rms_axis[1]),
        mm(loc.rms_axis[2]),
        deg(loc.rms_axis[3]),
        deg(loc.rms_axis[4]),
        deg(loc.rms_axis[5])
    );
    let mut t = Table::new(&[
        "region (octant)",
        "poses",
        "RMS |Δp| mm",
        "RMS angle °",
        "mean Δp (x, y, z) mm",
    ]);
    for (k, r) in loc.regions.iter().enumerate() {
        if r.count == 0 {
            continue;
        }
        let half =
            |b: usize, axis: &str| format!("{axis}{}", if k & (1 << b) != 0 { "+" } else { "−" });
        t.row(vec![
            format!("{} {} {}", half(0, "x"), half(1, "y"), half(2, "z")),
            r.count.to_string(),
            mm(r.rms_pos_m),
            deg(r.rms_rot_rad),
            format!(
                "({}, {}, {})",
                mm(r.mean_pos_m[0]),
                mm(r.mean_pos_m[1]),
                mm(r.mean_pos_m[2])
            ),
        ]);
    }
    s.push_str(&t.render("  "));
    let mut cs: Vec<_> = loc.correlates().to_vec();
    cs.sort_by(|a, b| b.explained.total_cmp(&a.explained));
    let mut t = Table::new(&[
        "quantity",
        "whitened",
        "explains Δp var.",
        "explains Δφ var.",
        "corr x",
        "corr y",
        "corr z",
        "corr |Δp|",
    ]);
    for c in cs.iter().take(8) {
        t.row(vec![
            quantity_label(c.quantity),
            format!("{:.0} %", 100.0 * c.explained),
            format!("{:.0} %", 100.0 * c.explained_pos),
            format!("{:.0} %", 100.0 * c.explained_rot),
            format!("{:+.2}", c.corr[0]),
            format!("{:+.2}", c.corr[1]),
            format!("{:+.2}", c.corr[2]),
            format!("{:+.2}", c.corr_norm_pos),
        ]);
    }
    let _ = writeln!(
        s,
        "  correlation with the quantities the effects depend on, ranked by the share of the residual\n  variance a linear function of the quantity explains (whitened: every component weighted\n  by 1/σ²; then the position and the orientation components alone):"
    );
    s.push_str(&t.render("  "));

    // Which.
    let _ = writeln!(
        s,
        "\nWHICH — every candidate fitted with the geometry, judged on held-out poses\n  \
         (mm, deg: held-out RMS; z: improvement over geometric only; gap, rot. gap: share of\n  \
         the gap to the noise floor closed, position and orientation):"
    );
    let mut t = Table::new(&[
        "candidate",
        "params",
        "mm",
        "deg",
        "z",
        "signif.",
        "gap",
        "rot. gap",
        "note",
    ]);
    t.row(vec![
        "geometric only".into(),
        d.baseline.fitted_params.to_string(),
        mm(d.baseline.heldout_rms_pos_m),
        deg(d.baseline.heldout_rms_rot_rad),
        "".into(),
        "".into(),
        "".into(),
        "".into(),
        "baseline".into(),
    ]);
    let mut order: Vec<&ModelScore> = d.candidates().iter().collect();
    order.sort_by(|a, b| match (a.evaluated, b.evaluated) {
        (true, true) => a.heldout_chi2.total_cmp(&b.heldout_chi2),
        (a, b) => b.cmp(&a),
    });
    // Long notes go under the table as numbered footnotes, keeping it within ~100 columns.
    let mut footnotes: Vec<String> = Vec::new();
    // A share of the gap needs a gap: where geometric only is not above the floor (√3σ) the
    // share's denominator is zero or negative and the column shows a dash.
    let pos_gap = d.baseline.heldout_rms_pos_m > d.noise.rms_pos_m();
    let rot_gap = d.baseline.heldout_rms_rot_rad > d.noise.rms_rot_rad();
    let share = |open: bool, evaluated: bool, f: f64| {
        if open && evaluated {
            format!("{:.0} %", 100.0 * f)
        } else {
            "-".to_string()
        }
    };
    for c in order {
        let long_note = |text: String, footnotes: &mut Vec<String>| {
            footnotes.push(format!(
                "[{}] {}: {text}",
                footnotes.len() + 1,
                effects_text(c.effects)
            ));
            format!("see [{}]", footnotes.len())
        };
        let note = if !c.evaluated {
            let partner = c
                .dropped
                .iter()
                .flatten()
                .next()
                .and_then(|x| x.partner)
                .map(|p| label::<N>(p.0))
                .unwrap_or_default();
            long_note(
                format!("confounded with the geometry ({partner})"),
                &mut footnotes,
            )
        } else if c.effects == d.verdict.effects {
            "VERDICT".into()
        } else if d.verdict.confounded().contains(&c.effects) {
            "confounded with the verdict".into()
        } else if c.distinctness < 0.05 {
            long_note(
                format!(
                    "weakly determined: {} has {:.3} of its column outside the others'",
                    c.least_distinct
                        .map(|p| label::<N>(p.0))
                        .unwrap_or_default(),
                    c.distinctness
                ),
                &mut footnotes,
            )
        } else {
            String::new()
        };
        t.row(vec![
            effects_text(c.effects),
            c.fitted_params.to_string(),
            if c.evaluated {
                mm(c.heldout_rms_pos_m)
            } else {
                "-".into()
            },
            if c.evaluated {
                deg(c.heldout_rms_rot_rad)
            } else {
                "-".into()
            },
            if c.evaluated {
                zfmt(c.improvement_z)
            } else {
                "-".into()
            },
            if c.significant { "yes" } else { "no" }.into(),
            share(pos_gap, c.evaluated, c.gap_closed_fraction),
            share(rot_gap, c.evaluated, c.gap_closed_rot_fraction),
            note,
        ]);
    }
    s.push_str(&t.render("  "));
    // Position-only data have no orientation errors and no orientation floor: nothing to say.
    let rot_measured = d.baseline.heldout_rms_rot_rad > 0.0 || d.noise.rms_rot_rad() > 0.0;
    for (open, name, base, floor) in [
        (
            pos_gap,
            "gap",
            mm(d.baseline.heldout_rms_pos_m) + " mm",
            mm(d.noise.rms_pos_m()) + " mm",
        ),
        (
            rot_gap,
            "rot. gap",
            deg(d.baseline.heldout_rms_rot_rad) + "°",
            deg(d.noise.rms_rot_rad()) + "°",
        ),
    ] {
        if !open && (name == "gap" || rot_measured) {
            let _ = writeln!(
                s,
                "  {name} -: geometric only ({base} held out) is not above the noise floor √3σ = {floor}:\n    no gap to take a share of"
            );
        }
    }
    for f in &footnotes {
        let _ = writeln!(s, "  {f}");
    }

    // Verdict and how far.
    let v = &d.verdict;
    let _ = writeln!(
        s,
        "\nVERDICT: {} — {}",
        v.status.name(),
        match v.status {
            Status::NoGap => "the geometric model is already at the noise floor".to_string(),
            Status::Unexplained =>
                "a gap, but no candidate closes a significant share of it".to_string(),
            _ => effects_text(v.effects),
        }
    );
    let _ = writeln!(s, "  why: {}", reason_text(d));
    if !v.confounded().is_empty() {
        let _ = writeln!(
            s,
            "  confounded with: {} (they explain these data as well: add poses that separate them)",
            v.confounded()
                .iter()
                .map(|c| effects_text(*c))
                .collect::<Vec<_>>()
                .join("; ")
        );
    }
    if !v.effects.is_empty() {
        let _ = writeln!(
            s,
            "HOW FAR: held-out RMS {} → {} mm, {} → {}° (noise floor {} mm, {}°): {:.0} % of the position gap, {:.0} % of the rotation gap, {:.0} % of the whitened gap closed; what remains: z = {} (position {}, rotation {}).",
            mm(d.baseline.heldout_rms_pos_m),
            mm(d.final_heldout_rms_pos_m),
            deg(d.baseline.heldout_rms_rot_rad),
            deg(d.final_heldout_rms_rot_rad),
            mm(n.rms_pos_m()),
            deg(n.rms_rot_rad()),
            100.0 * v.gap_closed_fraction,
            100.0
                * v.candidate
                    .and_then(|c| d.candidates().get(c))
                    .map_or(0.0, |c| c.gap_closed_rot_fraction),
            100.0
                * v.candidate
                    .and_then(|c| d.candidates().get(c))
                    .map_or(0.0, |c| c.gap_closed_total_fraction),
            zfmt(d.remaining.z),
            zfmt(d.remaining.z_pos),
            zfmt(d.remaining.z_rot)
        );
        let mut t = Table::new(&["effect parameter", "value", "std error", "unit"]);
        let effect_params = v
            .effects
            .iter()
            .fold(ParamSet::new(), |acc, e| acc.union(&e.params(N)));
        for i in d
            .fit
            .analysis
            .identifiable
            .iter()
            .filter(|&i| effect_params.contains(i))
        {
            let id = ParamId::from_index(ParamIndex(i), N);
            t.row(vec![
                label::<N>(i),
                format!("{:.4e}", d.model.param(ParamIndex(i)).unwrap_or(f64::NAN)),
                format!("{:.2e}", d.fit.std_errors[i]),
                id.map_or("", kincal_io::units::si_unit).to_string(),
            ]);
        }
        let _ = writeln!(s, "  identified effect parameters (all rows):");
        s.push_str(&t.render("  "));
    }
    let x = &d.explainable;
    if x.evaluated && v.status != Status::NoGap {
        let verdict = if x.significant {
            "significant"
        } else {
            "not significant: what remains does not look like a function of q"
        };
        if d.gap.z <= 0.0 {
            // No excess over the stated floor to take a share of (the stated noise is an
            // upper bound, or too large): say what the smooth model does to the RMS.
            let _ = writeln!(
                s,
                "EXPLAINABLE AT ALL (library-free): the geometric model is not above the stated noise floor, yet a smooth function of the joint angles lowers the held-out RMS from {} mm, {}° to {} mm, {}° (z = {}, {}).",
                mm(d.baseline.heldout_rms_pos_m),
                deg(d.baseline.heldout_rms_rot_rad),
                mm(x.heldout_rms_pos_m),
                deg(x.heldout_rms_rot_rad),
                zfmt(x.z),
                verdict
            );
        } else {
            let _ = writeln!(
                s,
                "EXPLAINABLE AT ALL (library-free): a smooth function of the joint angles closes {:.0} % of the gap held out (position {:.0} %, rotation {:.0} %; held-out RMS {} mm, {}°; z = {}, {}).",
                100.0 * x.share_of_gap,
                100.0 * x.share_pos,
                100.0 * x.share_rot,
                mm(x.heldout_rms_pos_m),
                deg(x.heldout_rms_rot_rad),
                zfmt(x.z),
                verdict
            );
        }
    }
    s
}
