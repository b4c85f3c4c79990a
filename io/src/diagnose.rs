//! The sim-to-real diagnosis (spec/effects.md) as every front end runs it (`kincal
//! diagnose`, Python's `kincal.diagnose`): the rows and pose groups of a measurement set, the
//! core's `kincal::diagnosis::diagnose` on them, the model the verdict names, and the report
//! as data ([`Report`], REPORT.json's fields). Front ends add only their wording of the
//! arguments, the readable text, progress and plots.
//!
//! Units: the core works in metres and radians; the report's fields say theirs (`_mm`,
//! `_deg`), as REPORT.json does (spec/cli.md).

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use kincal::diagnosis::{
    self, BeyondLibrary, Config, DiagWorkspace, Diagnosis, Method, ModelScore, Part, PoseDiagnosis,
    Reason, Status, Warning,
};
use kincal::identify::{Algorithm, Measurement, PriorSizes};
use kincal::{Effect, EffectSet, ParamId, ParamIndex, ParamSet, Robot};
use serde::Serialize;

use crate::calibration::{Calibration, Run, Settings, Weighting};
use crate::data;
use crate::diagnose_sessions::{
    Sessions, SessionsJson, separate_by, session_confounded, session_frames,
};
use crate::diagnose_where::{Breakdown, BreakdownJson, breakdown};
use crate::error::{Error, core_error};
use crate::measurements::MeasurementSet;
use crate::model_file::{DataJson, ModelFile};
use crate::units::{param_label, param_labels};

/// Capacity of the diagnosis workspace: the union of every model's columns of the largest
/// supported robot (15N + 7 ≤ 187 for 12 joints), and the session test's geometric, frame
/// (6 per session) and effect columns.
pub const DIAG_PARAMS: usize = 192;

/// A zeroed diagnosis workspace on the heap (about a megabyte).
pub fn new_workspace() -> Box<DiagWorkspace<DIAG_PARAMS>> {
    let b = Box::<DiagWorkspace<DIAG_PARAMS>>::new_zeroed();
    // SAFETY: the core documents all-zero as a valid `DiagWorkspace` (numbers, counters
    // and the identification workspace, itself valid when zeroed).
    unsafe { b.assume_init() }
}

/// What a front end asks of a diagnosis (the CLI's flags, Python's keyword arguments).
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Instrument noise, 1σ per axis [mm] and [deg]; `None`: from repeated pose_ids.
    pub sigma_pos_mm: Option<f64>,
    pub sigma_rot_deg: Option<f64>,
    /// Candidate effects; empty: every effect whose inputs the data have.
    pub candidates: Vec<Effect>,
    /// The joints (0-based) whose scale the `joint_scale` candidate fits (the front end's
    /// `joint_scale@JOINT` selectors, resolved by [`crate::effects_arg::resolve`]); `None`:
    /// every joint.
    pub scale_joints: Option<Vec<usize>>,
    /// Also evaluate pairs of effects.
    pub pairs: bool,
    /// Cross-validation folds (2 or more: the front end checks, naming its argument).
    pub folds: usize,
    /// Seed of the fold assignment.
    pub seed: u64,
}

impl Default for Options {
    fn default() -> Self {
        let c = Config::default();
        Options {
            sigma_pos_mm: None,
            sigma_rot_deg: None,
            candidates: Vec::new(),
            scale_joints: None,
            pairs: c.pairs,
            folds: c.folds,
            seed: c.fold_seed,
        }
    }
}

impl Options {
    /// The core's configuration (SI units).
    pub fn config(&self) -> Config {
        Config {
            sigma_pos_m: self.sigma_pos_mm.map(|s| s * 1e-3),
            sigma_rot_rad: self.sigma_rot_deg.map(f64::to_radians),
            folds: self.folds,
            candidates: (!self.candidates.is_empty()).then(|| {
                self.candidates
                    .iter()
                    .fold(EffectSet::NONE, |a, &e| a.with(e))
            }),
            pairs: self.pairs,
            fold_seed: self.seed,
            ..Config::default()
        }
    }

    /// [`Options::config`] for an `n`-joint robot: with the `joint_scale` candidate
    /// restricted to the selected joints.
    pub fn config_for(&self, n: usize) -> Config {
        let mut cfg = self.config();
        if let Some(joints) = &self.scale_joints {
            let choice = crate::effects_arg::EffectChoice {
                effects: cfg.candidates.unwrap_or(EffectSet::NONE),
                scale_joints: Some(joints.clone()),
            };
            cfg.effect_params = Some(choice.effect_params(n));
        }
        cfg
    }

    /// The effect columns to read from the data: the candidates given, else none (the core
    /// finds those the data have).
    pub fn effects_to_read(&self) -> EffectSet {
        self.config().candidates.unwrap_or(EffectSet::NONE)
    }
}

/// How a front end names the two noise arguments in its messages (`--sigma-pos-mm`,
/// `sigma_pos_mm`).
#[derive(Debug, Clone, Copy)]
pub struct SigmaNames<'a> {
    pub pos: &'a str,
    pub rot: &'a str,
}

/// A diagnosis and what it ran on.
#[derive(Debug, Clone)]
pub struct Study<const N: usize> {
    pub diagnosis: Box<Diagnosis<N>>,
    /// The rows, in file order (with several sessions: registered into the robot's base
    /// frame).
    pub meas: Vec<Measurement<N>>,
    /// Per row: fold, residuals, held-out errors, suspect flag.
    pub poses: Vec<PoseDiagnosis>,
    /// Per row: its pose group ([`group_ids`]).
    pub groups: Vec<u32>,
    /// Several sessions, each in its own base frame (`None` for one session).
    pub sessions: Option<Sessions<N>>,
    /// Where the gap lies by session, `extra_` column and prismatic reading.
    pub breakdown: Vec<Breakdown>,
    /// The joints (0-based) the `joint_scale` candidate was restricted to (`None`: all).
    pub scale_joints: Option<Vec<usize>>,
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

/// Diagnoses the rows of `set` (read with [`Options::effects_to_read`]) on `robot`; rows
/// of several sessions are first registered each into the robot's base frame
/// ([`session_frames`]), and the candidates are tested for confounding with the sessions.
/// Errors: no noise floor (a usage error naming the arguments as `names` spells them), too
/// few pose groups for the folds, and the core's, with the file line of the row at fault.
pub fn run<const N: usize>(
    robot: &Robot<N>,
    set: &MeasurementSet,
    options: &Options,
    names: SigmaNames<'_>,
) -> Result<Study<N>, Error> {
    let cfg = options.config_for(N);
    let sessions = session_frames(robot, set, &cfg)?;
    let meas = match &sessions {
        Some(s) => s.data.clone(),
        None => data::measurements::<N>(set)?,
    };
    let groups = group_ids(set);
    let mut poses = vec![PoseDiagnosis::default(); meas.len()];
    let mut ws = new_workspace();
    let mut diagnosis = Box::new(Diagnosis::new(robot));
    let index: &[u16] = sessions.as_ref().map_or(&[], |s| &s.index);
    let result = diagnosis::diagnose_sessions_into(
        robot,
        &meas,
        &groups,
        index,
        &cfg,
        &mut poses,
        &mut ws,
        &mut diagnosis,
    );
    result.map_err(|e| match e {
        kincal::Error::MissingInput {
            what: kincal::Quantity::NoiseFloor,
        } => {
            let (sentence, flags) = missing_sigma(options, &meas, names);
            Error::usage(format!(
                "{}: no noise floor: {}, and {sentence}\n\
                 hint: state the instrument's noise (1σ per axis) with {flags}, or repeat some poses",
                set.source,
                why_no_repeat_scatter(&groups),
            ))
        }
        kincal::Error::TooFewData { found, needed } => Error::input(format!(
            "{}: {found} distinct pose_id groups, {needed} folds need at least {needed}",
            set.source
        )),
        other => core_error(other, &set.source, |i| data::line_of(set, i)),
    })?;
    let breakdown = breakdown(robot, set, &poses, sessions.as_ref());
    Ok(Study {
        diagnosis,
        meas,
        poses,
        groups,
        sessions,
        breakdown,
        scale_joints: options.scale_joints.clone(),
    })
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

/// Which stated noise the data still need: the sentence and the arguments to name.
fn missing_sigma<const N: usize>(
    options: &Options,
    meas: &[Measurement<N>],
    names: SigmaNames<'_>,
) -> (String, String) {
    let has_rot = meas.iter().any(|m| m.mask.has_orientation());
    let SigmaNames { pos, rot } = names;
    match (options.sigma_pos_mm, options.sigma_rot_deg, has_rot) {
        (Some(_), None, true) => (
            format!(
                "{rot} is not given (the data measure orientation; {pos} covers positions only)"
            ),
            rot.into(),
        ),
        (None, Some(_), _) => (
            format!("{pos} is not given ({rot} covers orientations only)"),
            pos.into(),
        ),
        (None, None, true) => (
            format!("neither {pos} nor {rot} is given"),
            format!("{pos} and {rot}"),
        ),
        _ => (format!("{pos} is not given"), pos.into()),
    }
}

/// The verdict's fit as a one-run calibration (what `calibrate --effects …` would have
/// written for the same model), so predict and validate read it like any model file.
pub fn calibration_of<const N: usize>(start: &Robot<N>, d: &Diagnosis<N>) -> Calibration<N> {
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
        found_at_fit: kincal::ParamSet::new(),
        runs: vec![Run {
            ident: d.fit,
            seconds: 0.0,
            robust: None,
        }],
        failed: Vec::new(),
        consensus: None,
    }
}

/// The verdict's model fitted again with Gaussian priors of `sizes` around `start`, as
/// `calibrate --prior` would on the rows the diagnosis kept (suspects left out), with the
/// noise floor as the data's weights.
pub fn with_prior<const N: usize>(
    start: &Robot<N>,
    study: &Study<N>,
    sizes: PriorSizes,
    source: &str,
) -> Result<Calibration<N>, Error> {
    let d = &study.diagnosis;
    let mut settings = calibration_of(start, d).settings;
    settings.prior = Some(sizes);
    let suspects = d.suspects.get(..d.n_suspects).unwrap_or_default();
    let kept: Vec<Measurement<N>> = study
        .meas
        .iter()
        .enumerate()
        .filter(|(i, _)| !suspects.iter().any(|&s| s as usize == *i))
        .map(|(_, m)| *m)
        .collect();
    crate::calibration::calibrate(start, &kept, &settings).map_err(|f| {
        Error::numeric(format!(
            "{source}: the verdict's model with the prior could not be fitted: {f:?}"
        ))
    })
}

/// The model file of the verdict's model (geometric + its effects; with `prior`, fitted
/// again with it), which predict and validate read like any model file.
pub fn model_file<const N: usize>(
    robot_name: &str,
    start: &Robot<N>,
    study: &Study<N>,
    prior: Option<PriorSizes>,
    set: &MeasurementSet,
    data_path: &Path,
    allow_out_of_limits: bool,
) -> Result<ModelFile, Error> {
    let cal = match prior {
        None => calibration_of(start, &study.diagnosis),
        Some(sizes) => with_prior(start, study, sizes, &set.source)?,
    };
    let rows: usize = study
        .meas
        .iter()
        .map(|m| (0..6).filter(|&k| m.mask.has(k)).count())
        .sum();
    Ok(ModelFile::from_calibration(
        robot_name,
        &cal,
        0,
        DataJson {
            path: data_path.display().to_string(),
            sha256: set.sha256.clone(),
            poses: study.meas.len(),
            rows,
        },
        allow_out_of_limits,
    ))
}

/// REPORT.json's text: the report pretty-printed, with a final newline.
pub fn report_text(report: &Report) -> String {
    serde_json::to_string_pretty(report).unwrap_or_default() + "\n"
}

// ---------------------------------------------------------------------------------------
// REPORT.json
// ---------------------------------------------------------------------------------------
// REPORT.json

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

fn names(set: EffectSet) -> Vec<String> {
    set.iter().map(|e| e.name().to_string()).collect()
}

/// Effect names joined by " + " (`geometric only` for none), as the reports word a model.
pub fn effects_text(s: EffectSet) -> String {
    if s.is_empty() {
        "geometric only".into()
    } else {
        s.iter().map(|e| e.name()).collect::<Vec<_>>().join(" + ")
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// `cross_validation` or `in_sample_nested` (too few pose groups for held-out poses).
    pub method: &'static str,
    /// Things to know about the data or the stated noise.
    pub warnings: Vec<WarningJson>,
    /// Gross outliers excluded from every fit and test.
    pub suspect_rows: Vec<SuspectJson>,
    pub outlier_screen: OutlierScreenJson,
    pub noise_floor: NoiseJson,
    pub baseline: BaselineJson,
    pub candidates: Vec<CandidateJson>,
    pub verdict: VerdictJson,
    /// Library-free check: how much of the gap any smooth function of q explains.
    pub explainable: ExplainableJson,
    /// The same check on the verdict's held-out residuals (evaluated only when the
    /// verdict would otherwise be `explained`).
    pub remaining_structure: ExplainableJson,
    /// Leave-one-range-out check of the verdict's model (evaluated only when the verdict
    /// would otherwise be `explained` under cross-validation).
    pub extrapolation: ExtrapolationJson,
    /// Form check of a verdict with `joint_cyclic` (evaluated only when the verdict would
    /// otherwise be `explained` under cross-validation).
    pub form: FormJson,
    #[serde(rename = "where")]
    pub where_: WhereJson,
    /// Several sessions: each registered in its own base frame (null for one session).
    pub sessions: Option<SessionsJson>,
    pub data: DataInfoJson,
    pub settings: SettingsJson,
    /// The other outputs (the CLI's; none when nothing was written).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub files: Option<FilesJson>,
    // No run time here: it is shown on screen only, so that identical inputs give a
    // bit-identical report whatever the machine load or thread count.
}

#[derive(Debug, Clone, Serialize)]
pub struct NoiseJson {
    /// σ per axis [mm], [°]; null for a component type no row measures (unless stated).
    pub pos_mm: Option<f64>,
    pub rot_deg: Option<f64>,
    /// "stated", "repeats" or "not_measured" (no row measures it and no σ was stated),
    /// per component type.
    pub pos_source: &'static str,
    pub rot_source: &'static str,
    pub dof_pos: Option<f64>,
    pub dof_rot: Option<f64>,
    pub repeat_subgroups: usize,
    /// √3·σ_pos: RMS position error of pure noise [mm] (null when not measured).
    pub rms_pos_mm: Option<f64>,
    pub rms_rot_deg: Option<f64>,
    /// σ per axis the repeats alone give (also when σ was stated) [mm], [°].
    pub repeats_pos_mm: Option<f64>,
    pub repeats_rot_deg: Option<f64>,
}

/// The outlier screen: how many rows it may exclude and how many were over its threshold.
#[derive(Debug, Clone, Serialize)]
pub struct OutlierScreenJson {
    /// Suspects it may exclude on these data: the core's capacity (`MAX_SUSPECTS`) or a
    /// tenth of the rows, whichever is less.
    pub cap: usize,
    /// Rows over the threshold (χ² 99.99 %) at its last pass.
    pub rows_over_threshold: usize,
    /// Rows excluded (`suspect_rows`): all of those over the threshold, or none when they
    /// exceed the cap (then `too_many_suspects` is among the warnings).
    pub excluded: usize,
    /// Rows over the threshold beyond the cap (0 when none was over it).
    pub over_cap: usize,
}

#[derive(Debug, Clone, Serialize)]
pub struct WarningJson {
    pub code: &'static str,
    pub message: String,
}

#[derive(Debug, Clone, Serialize)]
pub struct SuspectJson {
    /// Zero-based row of the data.
    pub index: usize,
    pub line: u64,
    pub pose_id: Option<String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct BaselineJson {
    pub heldout_rms_pos_mm: f64,
    pub heldout_rms_rot_deg: f64,
    pub insample_rms_pos_mm: f64,
    pub insample_rms_rot_deg: f64,
    /// Held-out RMS expected at the noise floor (√3σ inflated by estimation error).
    pub expected_rms_pos_mm: f64,
    pub expected_rms_rot_deg: f64,
    /// Observed over expected whitened held-out total, and its z (the gap test).
    pub gap_ratio: f64,
    pub gap_z: Option<f64>,
    /// The gap test on the position rows alone and on the rotation rows alone.
    pub gap_z_pos: Option<f64>,
    pub gap_z_rot: Option<f64>,
    pub gap: bool,
    pub fitted_params: usize,
}

#[derive(Debug, Clone, Serialize)]
pub struct DroppedJson {
    pub label: String,
    pub aligned_with: Option<String>,
    pub cosine: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct CandidateJson {
    pub effects: Vec<String>,
    pub heldout_rms_pos_mm: f64,
    pub heldout_rms_rot_deg: f64,
    pub significant: bool,
    pub evaluated: bool,
    /// No effect parameter separable from the geometry on these poses.
    pub confounded_with_geometry: bool,
    pub improvement_z: Option<f64>,
    pub z_vs_best: Option<f64>,
    /// Paired z of the improvement in position alone and in rotation alone (negative:
    /// worse).
    pub z_pos: Option<f64>,
    pub z_rot: Option<f64>,
    pub gap_closed_fraction: f64,
    pub gap_closed_rot_fraction: f64,
    /// Whitened share (position and rotation by their noise): what the status is decided on.
    pub gap_closed_total_fraction: f64,
    pub fitted_params: usize,
    pub distinctness: f64,
    pub least_distinct: Option<String>,
    pub structurally_redundant: Vec<String>,
    pub data_deficient: Vec<DroppedJson>,
    /// `["session_frame"]` when the candidate is confounded with the sessions (never
    /// chosen), else empty.
    pub confounded_with: Vec<String>,
    /// The session test (null for one session).
    pub session: Option<SessionTestJson>,
}

/// The confounding test of a candidate with the sessions (kincal::diagnosis::sessions).
#[derive(Debug, Clone, Serialize)]
pub struct SessionTestJson {
    /// Largest sin of the principal angle between an effect column and the span of the
    /// geometric and per-session base-frame columns.
    pub column_sin: f64,
    pub columns_in_span: bool,
    /// √(within-session share of the effect input's variance) (temp_c, s1..sN); null for
    /// effects of the joint readings alone.
    pub input_sin: Option<f64>,
    pub input_constant_within_sessions: bool,
    pub threshold: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct VerdictJson {
    pub effects: Vec<String>,
    pub status: &'static str,
    /// Effect names of every candidate confounded with the verdict (a pair as its names).
    pub confounded_with: Vec<String>,
    /// The same, one list per confounded candidate.
    pub confounded_candidates: Vec<Vec<String>>,
    pub gap_closed_fraction: f64,
    /// Share of the held-out RMS rotation angle's gap closed.
    pub gap_closed_rot_fraction: f64,
    /// Whitened share of the gap closed (position and rotation): the status's share.
    pub gap_closed_total_fraction: f64,
    /// Why the status: `closed`, `remaining_gap`, `remaining_structure`,
    /// `does_not_extrapolate`, `form_not_determined`, `worsens`, `small_share`,
    /// `no_significant_candidate`, `confounded_with_sessions`, `at_noise_floor`.
    pub reason: &'static str,
    pub reason_text: String,
    /// What lies beyond the library when the gap stays open (the smooth check):
    /// `smooth_effect`, `not_a_function_of_q` or `not_applicable`.
    pub beyond_library: &'static str,
    pub heldout_rms_pos_mm: f64,
    pub heldout_rms_rot_deg: f64,
    /// z of what remains against the noise floor.
    pub remaining_gap_z: Option<f64>,
    pub remaining_gap_z_pos: Option<f64>,
    pub remaining_gap_z_rot: Option<f64>,
    /// The remaining-gap test exceeds z_gap.
    pub remaining_gap_significant: bool,
    /// Held-out RMS of what remains per axis.
    pub remaining_rms_axis: AxisJson,
    /// Effects whose single candidate is confounded with the sessions (never chosen, nor
    /// any pair containing them).
    pub confounded_with_sessions: Vec<String>,
    /// What data would separate them from the sessions (null when none).
    pub separate_by: Option<String>,
    /// Identified effect parameters of the model (SI units) with standard errors.
    pub parameters: Vec<ParamValueJson>,
}

/// The "explainable at all?" check (kincal::diagnosis::SmoothCheck).
#[derive(Debug, Clone, Serialize)]
pub struct ExplainableJson {
    pub evaluated: bool,
    /// Share of the held-out gap (whitened position and rotation) a cross-validated
    /// smooth function of the joint angles removes.
    pub share_of_gap: f64,
    pub share_pos: f64,
    pub share_rot: f64,
    pub heldout_rms_pos_mm: f64,
    pub heldout_rms_rot_deg: f64,
    /// Paired Wilcoxon z against the geometric model (positive: better).
    pub z: Option<f64>,
    pub significant: bool,
    pub method: &'static str,
}

#[derive(Debug, Clone, Serialize)]
pub struct FormJson {
    pub evaluated: bool,
    /// The effect whose form was checked (`joint_cyclic` or `thermal`).
    pub effect: Option<&'static str>,
    /// Paired z of the alternative (module `kincal::diagnosis::form`) against the
    /// verdict's model (positive: the alternative is worse).
    pub z: Option<f64>,
    pub heldout_rms_pos_mm: f64,
    pub heldout_rms_rot_deg: f64,
    /// The alternative explains the data as well: the form is not determined.
    pub equivalent: bool,
    pub method: &'static str,
}

#[derive(Debug, Clone, Serialize)]
pub struct ExtrapolationJson {
    pub evaluated: bool,
    /// Half-range splits evaluated (two per joint at most).
    pub splits: usize,
    /// Largest z over the splits (held-out total against its expectation under the model).
    pub z: Option<f64>,
    /// Held-out whitened total over its expectation, of that split.
    pub ratio: f64,
    /// Joint (1-based) whose range that split halves; null when not evaluated.
    pub joint: Option<usize>,
    /// `upper` or `lower`: the half held out.
    pub held_out_half: &'static str,
    /// Bonferroni-corrected threshold of the largest z.
    pub threshold: f64,
    /// The model does not predict the held-out half.
    pub significant: bool,
    pub method: &'static str,
}

#[derive(Debug, Clone, Serialize)]
pub struct ParamValueJson {
    pub label: String,
    pub value: f64,
    pub unit: &'static str,
    pub std_error: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct RegionJson {
    pub min_mm: [f64; 3],
    pub max_mm: [f64; 3],
    pub count: usize,
    pub rms_pos_mm: f64,
    pub rms_rot_deg: f64,
    pub mean_pos_mm: [f64; 3],
}

#[derive(Debug, Clone, Serialize)]
pub struct CorrelationJson {
    pub quantity: String,
    pub unit: &'static str,
    /// Pearson correlation with the residual components x, y, z, φx, φy, φz.
    pub corr: [f64; 6],
    pub corr_norm_pos: f64,
    pub explained_pos: f64,
    pub explained_rot: f64,
    /// Share of the whitened residual (all six components) explained: the ranking.
    pub explained: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct PoseJson {
    pub line: u64,
    pub pose_id: Option<String>,
    pub fold: u16,
    pub residual_mm: [f64; 3],
    pub residual_deg: [f64; 3],
    pub heldout_geometric_mm: [f64; 3],
    pub heldout_final_mm: [f64; 3],
    pub heldout_geometric_norm_mm: f64,
    pub heldout_final_norm_mm: f64,
    /// A gross outlier: excluded from every fit and test.
    pub suspect: bool,
}

#[derive(Debug, Clone, Serialize)]
pub struct WhereJson {
    /// Residuals of the geometric calibration (all rows).
    pub rms_axis: AxisJson,
    pub mean_axis: AxisJson,
    pub rms_pos_mm: f64,
    pub rms_rot_deg: f64,
    pub bbox_min_mm: [f64; 3],
    pub bbox_max_mm: [f64; 3],
    pub regions: Vec<RegionJson>,
    pub correlations: Vec<CorrelationJson>,
    pub most_correlated: Option<String>,
    /// Held-out RMS |Δp| of the geometric model and of the verdict's by session, by each
    /// `extra_` column and by each prismatic joint's reading.
    pub by: Vec<BreakdownJson>,
    pub per_pose: Vec<PoseJson>,
}

#[derive(Debug, Clone, Serialize)]
pub struct AxisJson {
    pub x_mm: f64,
    pub y_mm: f64,
    pub z_mm: f64,
    pub rx_deg: f64,
    pub ry_deg: f64,
    pub rz_deg: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct DataInfoJson {
    pub path: String,
    sha256: String,
    pub rows: usize,
    pub groups: usize,
    pub folds: usize,
    pub has_approach: bool,
    pub has_temperature: bool,
}

#[derive(Debug, Clone, Serialize)]
pub struct SettingsJson {
    pub z_gap: f64,
    pub z_significance: f64,
    pub z_equivalence: f64,
    pub explained_fraction: f64,
    pub partial_fraction: f64,
    pub pairs: bool,
    pub candidates: Vec<String>,
    /// The joints whose scale the `joint_scale` candidate fits, as data columns (`q3`);
    /// null: every joint.
    pub scale_joints: Option<Vec<String>>,
    pub paired_test: &'static str,
}

#[derive(Debug, Clone, Serialize)]
pub struct FilesJson {
    pub model: String,
    pub report: String,
    pub plots: Vec<String>,
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
        least_distinct: c.least_distinct.map(|p| param_label::<N>(p.0)),
        structurally_redundant: param_labels::<N>(&c.structural),
        confounded_with: if c.session.confounded() {
            vec!["session_frame".into()]
        } else {
            Vec::new()
        },
        session: c.session.evaluated.then(|| SessionTestJson {
            column_sin: c.session.column_sin,
            columns_in_span: c.session.columns_in_span,
            input_sin: c.session.input_sin,
            input_constant_within_sessions: c.session.input_constant,
            threshold: Config::default().session_sin_max,
        }),
        data_deficient: c
            .data_deficient
            .iter()
            .map(|i| {
                let d = c.dropped.iter().flatten().find(|d| d.param.0 == i);
                DroppedJson {
                    label: param_label::<N>(i),
                    aligned_with: d.and_then(|d| d.partner).map(|p| param_label::<N>(p.0)),
                    cosine: d.map_or(0.0, |d| d.cosine),
                }
            })
            .collect(),
    }
}

/// The diagnosis `study` of `set` (read from `data_path`) as REPORT.json's data; `files`:
/// the other outputs written beside it, if any.
pub fn report<const N: usize>(
    study: &Study<N>,
    set: &MeasurementSet,
    data_path: &Path,
    files: Option<FilesJson>,
) -> Report {
    let d = &*study.diagnosis;
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
        outlier_screen: outlier_screen_json(d),
        noise_floor: noise_json(&d.noise),
        baseline: baseline_json(d),
        candidates: d.candidates().iter().map(candidate_json::<N>).collect(),
        verdict: verdict_json(d),
        explainable: explainable_json(&d.explainable),
        remaining_structure: explainable_json(&d.remaining_structure),
        extrapolation: extrapolation_json(&d.extrapolation),
        form: form_json(&d.form),
        where_: where_json(d, study, set),
        sessions: study.sessions.as_ref().map(Sessions::json),
        data: DataInfoJson {
            path: data_path.display().to_string(),
            sha256: set.sha256.clone(),
            rows: study.meas.len(),
            groups: d.groups,
            folds: d.folds,
            has_approach: set.has_approach,
            has_temperature: set.has_temperature,
        },
        settings: SettingsJson {
            scale_joints: study
                .scale_joints
                .as_ref()
                .map(|js| js.iter().map(|j| format!("q{}", j + 1)).collect()),
            ..settings_json(d)
        },
        files,
    }
}

/// The noise floor in mm and degrees, and where it came from; a component type no row
/// measures (and with no stated σ) is "not_measured", its σ null rather than the core's
/// placeholder.
fn noise_json(n: &diagnosis::NoiseFloor) -> NoiseJson {
    let known_pos = n.measured_pos || n.stated_pos;
    let known_rot = n.measured_rot || n.stated_rot;
    NoiseJson {
        pos_mm: known_pos.then_some(n.sigma_pos_m * 1e3),
        rot_deg: known_rot.then(|| n.sigma_rot_rad.to_degrees()),
        pos_source: noise_source(n.stated_pos, n.measured_pos),
        rot_source: noise_source(n.stated_rot, n.measured_rot),
        dof_pos: if known_pos { finite(n.dof_pos) } else { None },
        dof_rot: if known_rot { finite(n.dof_rot) } else { None },
        repeat_subgroups: n.repeat_subgroups,
        rms_pos_mm: known_pos.then_some(n.rms_pos_m() * 1e3),
        rms_rot_deg: known_rot.then(|| n.rms_rot_rad().to_degrees()),
        repeats_pos_mm: n.repeat_pos.map(|(s, _)| s * 1e3),
        repeats_rot_deg: n.repeat_rot.map(|(s, _)| s.to_degrees()),
    }
}

/// Where a noise σ came from: `stated`, `repeats` or `not_measured`.
pub fn noise_source(stated: bool, measured: bool) -> &'static str {
    match (stated, measured) {
        (true, _) => "stated",
        (false, true) => "repeats",
        (false, false) => "not_measured",
    }
}

/// The outlier screen's cap and count.
fn outlier_screen_json<const N: usize>(d: &Diagnosis<N>) -> OutlierScreenJson {
    OutlierScreenJson {
        cap: d.suspect_cap,
        rows_over_threshold: d.rows_over_threshold,
        excluded: d.suspects().len(),
        over_cap: d.rows_over_threshold.saturating_sub(d.suspect_cap),
    }
}

/// The geometric model's in-sample and held-out RMS and the gap test.
fn baseline_json<const N: usize>(d: &Diagnosis<N>) -> BaselineJson {
    BaselineJson {
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
    }
}

/// The verdict's identified effect parameters (SI units) with standard errors.
fn verdict_parameters<const N: usize>(d: &Diagnosis<N>) -> Vec<ParamValueJson> {
    let effect_params = d
        .verdict
        .effects
        .iter()
        .fold(ParamSet::new(), |acc, e| acc.union(&e.params(N)));
    d.fit
        .analysis
        .identifiable
        .iter()
        .filter(|&i| effect_params.contains(i))
        .map(|i| ParamValueJson {
            label: param_label::<N>(i),
            value: d.model.param(ParamIndex(i)).unwrap_or(f64::NAN),
            unit: ParamId::from_index(ParamIndex(i), N).map_or("", crate::units::si_unit),
            std_error: d.fit.std_errors[i],
        })
        .collect()
}

/// The verdict: status, why, what remains.
fn verdict_json<const N: usize>(d: &Diagnosis<N>) -> VerdictJson {
    let winner = d.verdict.candidate.and_then(|c| d.candidates().get(c));
    let parameters = verdict_parameters(d);
    VerdictJson {
        effects: names(d.verdict.effects),
        status: d.verdict.status.name(),
        confounded_with: names(d.verdict.confounded_effects()),
        confounded_candidates: d.verdict.confounded().iter().map(|s| names(*s)).collect(),
        gap_closed_fraction: d.verdict.gap_closed_fraction,
        gap_closed_rot_fraction: winner.map_or(0.0, |c| c.gap_closed_rot_fraction),
        gap_closed_total_fraction: winner.map_or(0.0, |c| c.gap_closed_total_fraction),
        reason: d.verdict.reason.name(),
        reason_text: reason_text(d),
        beyond_library: d.beyond_library().name(),
        heldout_rms_pos_mm: d.final_heldout_rms_pos_m * 1e3,
        heldout_rms_rot_deg: d.final_heldout_rms_rot_rad.to_degrees(),
        remaining_gap_z: finite(d.remaining.z),
        remaining_gap_z_pos: finite(d.remaining.z_pos),
        remaining_gap_z_rot: finite(d.remaining.z_rot),
        remaining_gap_significant: d.remaining.z > Config::default().z_gap,
        remaining_rms_axis: axis(&d.final_rms_axis),
        confounded_with_sessions: names(session_confounded(d)),
        separate_by: separate_by(d),
        parameters,
    }
}

/// The form check of a verdict with `joint_cyclic` or `thermal`.
fn form_json(f: &diagnosis::FormCheck) -> FormJson {
    FormJson {
        evaluated: f.evaluated,
        effect: f.effect.map(Effect::name),
        z: if f.evaluated { finite(f.z) } else { None },
        heldout_rms_pos_mm: f.heldout_rms_pos_m * 1e3,
        heldout_rms_rot_deg: f.heldout_rms_rot_rad.to_degrees(),
        equivalent: f.equivalent,
        method: "the verdict's model cross-validated with the effect's columns replaced by a model of another form outside the library with as many parameters (joint_cyclic: each joint's 3rd and 4th harmonics in place of its 1st and 2nd; thermal: a translation proportional to T - 20 °C, the part of thermal's column common to every pose); paired Wilcoxon z over pose groups against the verdict",
    }
}

/// The reason of a verdict whose form check found `effect`'s form not determined.
fn form_reason_text(z: f64, effect: Effect) -> String {
    format!(
        "the chosen effects fit, but {} explains the data as well held out (paired z = {z:.1}): the data do not determine {}'s form, so part of the gap may come from an effect outside the library",
        form_alternative_text(effect),
        effect.name()
    )
}

/// What the form check put in place of `effect`, for the verdict's reason.
fn form_alternative_text(effect: Effect) -> &'static str {
    match effect {
        Effect::Thermal => {
            "a translation that follows the temperature and not the arm's configuration (what a slow drift of the instrument or of the arm's mount does while the arm warms up)"
        }
        _ => {
            "a function of the same joints outside the library (3rd and 4th harmonics in place of joint_cyclic's 1st and 2nd)"
        }
    }
}

/// Where the geometric residuals lie: by axis, octant, correlated quantity and pose.
fn where_json<const N: usize>(
    d: &Diagnosis<N>,
    study: &Study<N>,
    set: &MeasurementSet,
) -> WhereJson {
    let loc = &d.location;
    WhereJson {
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
                quantity: crate::units::quantity_label(c.quantity),
                unit: crate::units::quantity_unit(c.quantity),
                corr: c.corr,
                corr_norm_pos: c.corr_norm_pos,
                explained_pos: c.explained_pos,
                explained_rot: c.explained_rot,
                explained: c.explained,
            })
            .collect(),
        most_correlated: loc
            .most_correlated
            .map(|k| crate::units::quantity_label(loc.correlates()[k].quantity)),
        by: study.breakdown.iter().map(Breakdown::json).collect(),
        per_pose: study
            .poses
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
    }
}

/// The decision's thresholds and what was evaluated.
fn settings_json<const N: usize>(d: &Diagnosis<N>) -> SettingsJson {
    {
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
            scale_joints: None,
            paired_test: match d.method {
                Method::CrossValidation => {
                    "Wilcoxon signed-rank over pose_id groups of the whitened held-out squared errors"
                }
                Method::InSampleNested => {
                    "likelihood ratio against the geometric model (Wilson-Hilferty z); Vuong over pose_id groups between candidates"
                }
            },
        }
    }
}

/// The rows the screening left out, by index, file line and pose_id.
pub fn suspect_rows<const N: usize>(d: &Diagnosis<N>, set: &MeasurementSet) -> Vec<SuspectJson> {
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
        Warning::RepeatsDrift { part, ratio, z } => format!(
            "the differences between repeats of the same pose follow the order of the rows ({} serial z = {z:.1}{}): something drifted during the session (the instrument or its mount, the base, or a temperature the file does not record), so the repeats measure the drift as well as the noise; {}",
            noise(part),
            if ratio.is_finite() {
                format!(", repeats {} than stated", factor(ratio))
            } else {
                String::new()
            },
            if ratio.is_finite() {
                "the stated sigma stays the noise floor"
            } else if part == Part::Rotation {
                "the noise floor taken from them is too high: state --sigma-rot-deg"
            } else {
                "the noise floor taken from them is too high: state --sigma-pos-mm"
            }
        ),
        Warning::TooManySuspects { count, cap } => format!(
            "{count} rows fail the outlier test, {} more than the {cap} the screen may exclude (at most {} or a tenth of the rows): too many to be gross outliers (heavy-tailed residuals, or an effect outside the library); none excluded",
            count.saturating_sub(cap),
            diagnosis::MAX_SUSPECTS
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
pub fn reason_text<const N: usize>(d: &Diagnosis<N>) -> String {
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
        Reason::FormNotDetermined { z, effect } => form_reason_text(z, effect),
        Reason::Worsens { z, part } => format!(
            "the chosen effects make the {} significantly worse (z = {z:.1})",
            part_text(part)
        ),
        Reason::SmallShare => "the chosen effects close only part of the gap".into(),
        Reason::NoSignificantCandidate => {
            "no candidate improves significantly on the geometric model".into()
        }
        Reason::ConfoundedWithSessions => format!(
            "the candidates that improve significantly are confounded with the sessions ({}): the data cannot attribute the gap to them rather than to what differs between the sessions",
            effects_text(session_confounded(d))
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The drift warning says what the floor became: the stated σ when there is one, else
    /// which flag to state.
    #[test]
    fn repeats_drift_text_names_the_floor_it_leaves() {
        let stated = warning_text(&Warning::RepeatsDrift {
            part: Part::Position,
            ratio: 3.9,
            z: 4.0,
        });
        assert!(stated.contains("position serial z = 4.0"), "{stated}");
        assert!(stated.contains("3.9x noisier than stated"), "{stated}");
        assert!(
            stated.contains("the stated sigma stays the noise floor"),
            "{stated}"
        );
        let unstated = warning_text(&Warning::RepeatsDrift {
            part: Part::Rotation,
            ratio: f64::NAN,
            z: 3.5,
        });
        assert!(unstated.contains("state --sigma-rot-deg"), "{unstated}");
        assert!(!unstated.contains("than stated"), "{unstated}");
    }

    /// `form_not_determined` says whose form and what explained the data as well.
    #[test]
    fn form_reason_names_the_effect_and_its_alternative() {
        let thermal = form_reason_text(1.24, Effect::Thermal);
        assert!(thermal.contains("determine thermal's form"), "{thermal}");
        assert!(thermal.contains("follows the temperature"), "{thermal}");
        assert!(thermal.contains("paired z = 1.2"), "{thermal}");
        let cyclic = form_reason_text(-0.5, Effect::JointCyclic);
        assert!(cyclic.contains("determine joint_cyclic's form"), "{cyclic}");
        assert!(cyclic.contains("3rd and 4th harmonics"), "{cyclic}");
        assert!(!cyclic.contains("temperature"), "{cyclic}");
    }
}
