//! `kincal validate MODEL DATA [--plot FILE.svg]`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use kincal::Robot;
use kincal::identify::{ComponentMask, Measurement};
use kincal::validation::{ErrorSummary, PoseErrors, Verdict, biopsy_allowed_rotation_rad};
use serde::Serialize;

use crate::args::{non_negative, positive};
use crate::error::{CliError, core_error};
use crate::plots::pose_errors::{self, Series};
use crate::report::{Table, Targets, fmt_err};
use kincal_io::data::{self, DataOptions, RowLabels};
use kincal_io::robot_arg;
use kincal_io::session_scores::{
    BaseSession, SessionScore, pose_errors, score_sessions, session_of_instrument_rows,
};

pub const LONG_ABOUT: &str = "\
Compares the model's poses with the measured poses of DATA (measured minus model, in the base
frame): per pose the position error e_p = (e_x, e_y, e_z) and its norm [mm], and the
orientation error e_φ (rotation vector of R_meas·R_modelᵀ, exact) and its angle [deg]; then
max and RMS (sqrt of the mean squared norm) over the poses, and the verdict against the
targets: every pose below --target-pos-mm (default 1 mm) and --target-rot-deg (default 0.66°),
the paper's Section 4.4. Also prints the paper's eq. (3): the orientation error a biopsy
allows, 2·asin((r_t − d)/(2·√2·l_max)), with r_t = --tumour-radius-mm (5), l_max =
--insertion-mm (200) and d = --biopsy-d-mm (default: the worst position error found).

For a model file from `calibrate --algorithm all` the summary covers NOM (the initial model),
OLS, OPT1 and OPT2; for a single-algorithm model NOM and that algorithm; for a ROBOT the
nominal model only.

--plot writes the paper's error figure (Fig. 7/11) as one SVG: two 4×4 panels, position
errors [mm] above and orientation errors [deg] below; columns NOM, OLS, OPT1, OPT2 (those
present), rows e_x, e_y, e_z and the norm, against the pose index. The dashed red line in the
norm rows is the target (drawn when the errors reach 5% of it). --json writes every
number (SI units, full precision).

Data with target/plane rows (docs/constraints.md; --constraints FILE for known distances,
targets, planes): reports instead the consistency per target and plane — the scatter of the
predicted tool points about the target (plane) each model estimates from them: mean RMS and
max [mm] — and the error of every known distance [mm], for the model and its variants.

Instrument rows in several sessions (a `session` column, docs/constraints.md): the rows of the
first session are in the robot's base frame and are judged there; every later session was
measured in a frame of its own that nothing in DATA fixes, so its rows are judged after
fitting that session's rigid frame only (6 parameters, no model parameter; as calibrate
eliminates it), per model. Its per-pose errors are measured − frame·model, in the session's
frame; a table (and `sessions` in --json) gives per session the fitted frame and the RMS and
max errors.";

pub const EXAMPLE: &str = "\
Example:
  kincal validate aria-model.json check.csv --plot errors.svg --json validation.json";

#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Model file, or ROBOT for the nominal model
    #[arg(value_name = "MODEL")]
    pub model: String,
    #[command(flatten)]
    pub chain: kincal_io::robot_arg::UrdfChainArgs,
    /// Measurement CSV with measured poses
    #[arg(value_name = "DATA")]
    pub data: PathBuf,
    /// Write the error figure (SVG)
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
    /// Write per-pose errors and summaries as JSON
    #[arg(long, value_name = "REPORT.json")]
    pub json: Option<PathBuf>,
    /// Position target per pose [mm]
    #[arg(long, value_name = "MM", default_value = "1", value_parser = positive)]
    pub target_pos_mm: f64,
    /// Orientation target per pose [deg]
    #[arg(long, value_name = "DEG", default_value = "0.66", value_parser = positive)]
    pub target_rot_deg: f64,
    /// Eq. (3): position error at the puncture point [mm] (default: worst e_p found)
    #[arg(long, value_name = "MM", value_parser = non_negative)]
    pub biopsy_d_mm: Option<f64>,
    /// Eq. (3): tumour radius r_t [mm]
    #[arg(long, value_name = "MM", default_value = "5", value_parser = positive)]
    pub tumour_radius_mm: f64,
    /// Eq. (3): maximum insertion length l_max [mm]
    #[arg(long, value_name = "MM", default_value = "200", value_parser = positive)]
    pub insertion_mm: f64,
    /// Accept joint readings outside the robot's joint limits
    #[arg(long)]
    pub allow_out_of_limits: bool,
    /// Print the summary only (no per-pose table)
    #[arg(long)]
    pub quiet: bool,
    /// Known geometry of the fixtures (TOML) for data with target/plane rows: validate
    /// then reports the consistency per target/plane and the error of every known distance
    #[arg(long, value_name = "FILE")]
    pub constraints: Option<PathBuf>,
}

/// Errors of one model on a data set.
#[derive(Debug, Clone)]
pub struct Evaluation {
    pub name: String,
    pub errors: Vec<PoseErrors>,
    pub summary: ErrorSummary,
}

/// Refuses errors that overflowed (no table, JSON or figure may carry them), naming the
/// first row.
fn refuse_non_finite<const N: usize>(
    e: &Scored<'_, N>,
    source: &str,
    labels: &RowLabels,
) -> Result<(), CliError> {
    match e.first_non_finite {
        None => Ok(()),
        Some(i) => Err(CliError::numeric(format!(
            "{}:{}: the error of model {} overflowed (not a finite number): the model or the data hold implausibly large numbers",
            source,
            labels.line(i).unwrap_or(0),
            e.name
        ))),
    }
}

/// Per-pose errors of `robot` on `meas` (orientation errors zero for position-only rows).
pub fn evaluate<const N: usize>(
    name: &str,
    robot: &Robot<N>,
    meas: &[Measurement<N>],
) -> Result<Evaluation, (usize, kincal::Error)> {
    let mut summary = ErrorSummary::default();
    let errors = meas
        .iter()
        .enumerate()
        .map(|(i, m)| {
            // Unmeasured components are zero; each kind's RMS and max run over the poses
            // that measure it (position-only rows do not dilute the orientation RMS).
            let e = PoseErrors::of_measurement(robot, m).map_err(|e| (i, e))?;
            summary.add_measured(&e, m.mask);
            Ok(e)
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Evaluation {
        name: name.to_string(),
        errors,
        summary,
    })
}

/// One model's summary on a data set, its per-pose errors not kept: they are computed again
/// when a table, report or figure needs them ([`Scored::errors`]), so a million-row file is
/// held once, as its measurements (issue #16 item 6).
#[derive(Debug)]
pub struct Scored<'r, const N: usize> {
    pub name: String,
    pub robot: &'r Robot<N>,
    pub summary: ErrorSummary,
    /// The first row whose errors are not finite (refused before any output).
    pub first_non_finite: Option<usize>,
    /// With instrument rows in several sessions: each session's fitted frame and errors.
    pub sessions: Option<Vec<SessionScore>>,
}

/// Instrument rows in several sessions, each later session in a frame of its own: the core
/// data (rows ordered by session) and, per row of DATA, its session (an index into
/// [`score_sessions`]'s result).
#[derive(Debug)]
pub struct SessionSplit<const N: usize> {
    pub cd: kincal_io::constraints::ContactData<N>,
    pub session_of_row: Vec<usize>,
}

impl<const N: usize> SessionSplit<N> {
    /// The split of `set` (instrument rows only) and its rows as measurements in file order.
    fn of(
        set: &kincal_io::measurements::MeasurementSet,
        robot: &Robot<N>,
    ) -> Result<(Self, Vec<Measurement<N>>), CliError> {
        let cd = kincal_io::constraints::build::<N>(set, None, robot, 1.0)?;
        let of_instrument = session_of_instrument_rows(&cd);
        let mut meas = vec![None; set.rows.len()];
        let mut session_of_row = vec![0; set.rows.len()];
        for (l, &r) in cd.instrument_rows.iter().enumerate() {
            meas[r] = Some(cd.instrument[l]);
            session_of_row[r] = of_instrument[l];
        }
        // Every row is an instrument row here (contact rows take validate_contacts).
        let meas = meas.into_iter().flatten().collect::<Vec<_>>();
        if meas.len() != set.rows.len() {
            return Err(CliError::input(format!(
                "{}: internal error: rows without a measured pose among instrument sessions",
                set.source
            )));
        }
        Ok((SessionSplit { cd, session_of_row }, meas))
    }
}

/// The summary of `robot` on `meas` ([`evaluate`] without keeping the errors); with
/// `split`, each later session's rows after fitting its frame ([`score_sessions`]).
/// Errors: a row index of `meas` with core's error, or a session's fault as [`CliError`].
pub fn score<'r, const N: usize>(
    name: &str,
    robot: &'r Robot<N>,
    meas: &[Measurement<N>],
    split: Option<&SessionSplit<N>>,
) -> Result<Scored<'r, N>, (usize, kincal::Error)> {
    let sessions = match split {
        None => None,
        Some(sp) => Some(
            score_sessions(robot, &sp.cd, BaseSession::InBaseFrame)
                .map_err(|(l, e)| (sp.cd.instrument_rows.get(l).copied().unwrap_or(0), e))?,
        ),
    };
    let mut summary = ErrorSummary::default();
    let mut first_non_finite = None;
    for (i, m) in meas.iter().enumerate() {
        let frame = frame_of(sessions.as_deref(), split, i);
        let e = pose_errors(robot, m, frame).map_err(|e| (i, e))?;
        summary.add_measured(&e, m.mask);
        if first_non_finite.is_none() && !errors_finite(&e) {
            first_non_finite = Some(i);
        }
    }
    Ok(Scored {
        name: name.to_string(),
        robot,
        summary,
        first_non_finite,
        sessions,
    })
}

/// The fitted frame row `i` is judged in (`None`: the robot's base frame).
fn frame_of<'a, const N: usize>(
    sessions: Option<&'a [SessionScore]>,
    split: Option<&SessionSplit<N>>,
    i: usize,
) -> Option<&'a kincal::Transform> {
    let s = split?.session_of_row.get(i)?;
    sessions?.get(*s)?.frame.as_ref()
}

fn errors_finite(p: &PoseErrors) -> bool {
    p.pos_m
        .iter()
        .chain(&p.rot_rad)
        .chain([&p.pos_norm_m, &p.rot_norm_rad])
        .all(|v| v.is_finite())
}

impl<const N: usize> Scored<'_, N> {
    /// The per-pose errors again, in row order. [`score`] computed each of them without
    /// error (the computation is deterministic: the same bits), so none is missing here.
    pub fn errors<'a>(
        &'a self,
        meas: &'a [Measurement<N>],
        split: Option<&'a SessionSplit<N>>,
    ) -> impl Iterator<Item = PoseErrors> + 'a {
        meas.iter().enumerate().map(move |(i, m)| {
            let frame = frame_of(self.sessions.as_deref(), split, i);
            pose_errors(self.robot, m, frame).unwrap_or_default()
        })
    }
}

fn verdict_text(v: &Verdict, has_rot: bool) -> String {
    match (v.pos_ok, v.rot_ok || !has_rot) {
        (true, true) => "PASS".into(),
        (false, true) => "FAIL (e_p)".into(),
        (true, false) => "FAIL (e_φ)".into(),
        (false, false) => "FAIL (e_p, e_φ)".into(),
    }
}

/// Summary table of several models' errors (name, summary) against the targets.
pub fn summary_table<'a>(
    models: impl IntoIterator<Item = (&'a str, &'a ErrorSummary)>,
    targets: Targets,
    has_rot: bool,
) -> String {
    let mut t = Table::new(&[
        "model",
        "max e_p [mm]",
        "RMS e_p [mm]",
        "max e_φ [deg]",
        "RMS e_φ [deg]",
        "verdict",
    ]);
    for (name, s) in models {
        let v = Verdict::judge(s, targets.pos_m, targets.rot_rad);
        let rot = |x: f64| {
            if has_rot {
                fmt_err(x.to_degrees())
            } else {
                "n/a".to_string()
            }
        };
        t.row(vec![
            name.to_string(),
            fmt_err(s.max_pos_m * 1e3),
            fmt_err(s.rms_pos_m() * 1e3),
            rot(s.max_rot_rad),
            rot(s.rms_rot_rad()),
            verdict_text(&v, has_rot),
        ]);
    }
    t.render("  ")
}

/// Header of the per-pose table.
pub fn pose_table_header(has_rot: bool) -> Vec<&'static str> {
    let mut header = vec!["pose", "e_x [mm]", "e_y [mm]", "e_z [mm]", "|e_p| [mm]"];
    if has_rot {
        header.extend(["e_φx [deg]", "e_φy [deg]", "e_φz [deg]", "|e_φ| [deg]"]);
    }
    header
}

/// Per-pose table rows of one model's `errors` (in row order), made on demand (a file of a
/// million rows is printed without holding its table): `id(i)` names pose `i`; a component
/// `mask(i)` does not measure prints a dash (a row giving only `x` has no e_y, e_z; a
/// position-only row no orientation error), not a zero one; |e_p| and |e_φ| run over the
/// measured components.
pub fn pose_table_rows<'a>(
    errors: impl Iterator<Item = PoseErrors> + 'a,
    id: impl Fn(usize) -> String + 'a,
    has_rot: bool,
    mask: impl Fn(usize) -> ComponentMask + 'a,
) -> impl Iterator<Item = Vec<String>> + 'a {
    errors.enumerate().map(move |(i, p)| {
        let mask = mask(i);
        let cell = |k: usize, v: String| if mask.has(k) { v } else { "-".to_string() };
        let any = |mut ks: core::ops::Range<usize>| ks.any(|k| mask.has(k));
        let mut row = vec![id(i)];
        row.extend((0..3).map(|k| cell(k, crate::report::fmt_signed6(p.pos_m[k] * 1e3))));
        row.push(if any(0..3) {
            format!("{:.6}", p.pos_norm_m * 1e3)
        } else {
            "-".to_string()
        });
        if has_rot {
            row.extend(
                (0..3).map(|k| cell(3 + k, crate::report::fmt_signed6(p.rot_rad[k].to_degrees()))),
            );
            row.push(if any(3..6) {
                format!("{:.6}", p.rot_norm_rad.to_degrees())
            } else {
                "-".to_string()
            });
        }
        row
    })
}

/// "10 poses (46 rows)" when rows share pose ids, else "46 poses".
pub fn poses_text(labels: &RowLabels) -> String {
    let poses = labels.pose_count();
    let rows = labels.len();
    if poses == rows {
        format!("{rows} poses")
    } else {
        format!("{poses} poses ({rows} rows)")
    }
}

/// The algorithm and the effects the model carries: "OLS + joint_compliance".
fn model_label(algorithm: String, effects: kincal::EffectSet) -> String {
    effects
        .iter()
        .fold(algorithm, |acc, e| format!("{acc} + {e}"))
}

/// True if the model was calibrated on exactly these bytes (same SHA-256).
fn calibrated_on(file: &kincal_io::model_file::ModelFile, sha256: &str) -> bool {
    file.calibration
        .as_ref()
        .is_some_and(|c| c.data.sha256.eq_ignore_ascii_case(sha256))
}

/// The ARIA biopsy robot the paper's targets (1 mm, 0.66°) and eq. (3) were set for.
fn is_aria(file: &kincal_io::model_file::ModelFile) -> bool {
    file.robot.name.eq_ignore_ascii_case("aria")
}

#[derive(Serialize)]
struct PoseJson<'a> {
    index: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pose_id: Option<&'a str>,
    line: u64,
    e_pos_m: [f64; 3],
    e_pos_norm_m: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    e_rot_rad: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    e_rot_norm_rad: Option<f64>,
}

#[derive(Serialize)]
struct SummaryJson {
    name: String,
    poses: usize,
    max_pos_m: f64,
    rms_pos_m: f64,
    max_rot_rad: Option<f64>,
    rms_rot_rad: Option<f64>,
    pos_ok: bool,
    rot_ok: Option<bool>,
    passed: bool,
}

#[derive(Serialize)]
struct ReportJson<'a, const N: usize> {
    model: &'a str,
    data: DataRef<'a>,
    targets: TargetsJson,
    eq3: Option<Eq3Json>,
    summary: SummaryJson,
    variants: Vec<SummaryJson>,
    /// Only with instrument rows in several sessions (one-session reports keep their bytes).
    #[serde(skip_serializing_if = "Option::is_none")]
    sessions: Option<Vec<SessionJson>>,
    poses: PosesJson<'a, N>,
}

/// One session's fitted frame and the main model's errors on it (SI units).
#[derive(Serialize)]
struct SessionJson {
    session: String,
    rows: usize,
    /// Robot base → the session's measuring frame, `[px, py, pz, rx, ry, rz]` (m, rotation
    /// vector in rad); `None` for the first session (the robot's base frame).
    frame: Option<[f64; 6]>,
    max_pos_m: f64,
    rms_pos_m: f64,
    max_rot_rad: Option<f64>,
    rms_rot_rad: Option<f64>,
}

fn sessions_json(scores: &[SessionScore], has_rot: bool) -> Vec<SessionJson> {
    scores
        .iter()
        .map(|x| SessionJson {
            session: x.session.clone(),
            rows: x.rows,
            frame: x.frame.as_ref().map(kincal::pose::pose_to_vector6),
            max_pos_m: x.summary.max_pos_m,
            rms_pos_m: x.summary.rms_pos_m(),
            max_rot_rad: (has_rot && x.summary.count_rot() > 0).then_some(x.summary.max_rot_rad),
            rms_rot_rad: (has_rot && x.summary.count_rot() > 0).then(|| x.summary.rms_rot_rad()),
        })
        .collect()
}

/// The per-session table of the main model (instrument rows in several sessions).
fn sessions_text(scores: &[SessionScore], name: &str, has_rot: bool) -> String {
    let mut t = Table::new(&[
        "session",
        "rows",
        "frame translation [mm]",
        "frame rotation vector [deg]",
        "RMS e_p [mm]",
        "max e_p [mm]",
        "RMS e_φ [deg]",
        "max e_φ [deg]",
    ]);
    for x in scores {
        let (tr, rot) = match &x.frame {
            None => ("base frame".to_string(), "base frame".to_string()),
            Some(f) => {
                let v = kincal::pose::pose_to_vector6(f);
                (
                    format!("{:.3} {:.3} {:.3}", v[0] * 1e3, v[1] * 1e3, v[2] * 1e3),
                    format!(
                        "{:.4} {:.4} {:.4}",
                        v[3].to_degrees(),
                        v[4].to_degrees(),
                        v[5].to_degrees()
                    ),
                )
            }
        };
        let rot_cell = |v: f64| {
            if has_rot && x.summary.count_rot() > 0 {
                fmt_err(v.to_degrees())
            } else {
                "n/a".to_string()
            }
        };
        t.row(vec![
            x.session.clone(),
            x.rows.to_string(),
            tr,
            rot,
            fmt_err(x.summary.rms_pos_m() * 1e3),
            fmt_err(x.summary.max_pos_m * 1e3),
            rot_cell(x.summary.rms_rot_rad()),
            rot_cell(x.summary.max_rot_rad),
        ]);
    }
    format!(
        "\nSessions ({name}): the first session's rows are judged in the robot's base frame; \
         each later session's after fitting only its frame (6 parameters, no model \
         parameter):\n{}",
        t.render("  ")
    )
}

/// The main model's per-pose errors in `--json`, computed while they are serialised.
struct PosesJson<'a, const N: usize>(&'a Judged<'a, N>);

impl<const N: usize> Serialize for PosesJson<'_, N> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let j = self.0;
        s.collect_seq(
            j.main
                .errors(j.meas, j.split)
                .enumerate()
                .map(|(i, e)| PoseJson {
                    index: i + 1,
                    pose_id: j.labels.pose_id(i),
                    line: j.labels.line(i).unwrap_or(0),
                    e_pos_m: e.pos_m,
                    e_pos_norm_m: e.pos_norm_m,
                    e_rot_rad: j.has_rot.then_some(e.rot_rad),
                    e_rot_norm_rad: j.has_rot.then_some(e.rot_norm_rad),
                }),
        )
    }
}

#[derive(Serialize)]
struct DataRef<'a> {
    path: String,
    sha256: &'a str,
}

#[derive(Serialize)]
struct TargetsJson {
    pos_m: f64,
    rot_rad: f64,
}

#[derive(Serialize)]
struct Eq3Json {
    tumour_radius_m: f64,
    insertion_m: f64,
    d_m: f64,
    allowed_rot_rad: f64,
    rot_ok: Option<bool>,
}

fn summary_json<const N: usize>(e: &Scored<'_, N>, t: Targets, has_rot: bool) -> SummaryJson {
    let v = Verdict::judge(&e.summary, t.pos_m, t.rot_rad);
    SummaryJson {
        name: e.name.clone(),
        poses: e.summary.count,
        max_pos_m: e.summary.max_pos_m,
        rms_pos_m: e.summary.rms_pos_m(),
        max_rot_rad: has_rot.then_some(e.summary.max_rot_rad),
        rms_rot_rad: has_rot.then(|| e.summary.rms_rot_rad()),
        pos_ok: v.pos_ok,
        rot_ok: has_rot.then_some(v.rot_ok),
        passed: v.pos_ok && (v.rot_ok || !has_rot),
    }
}

pub fn run(args: &Args) -> Result<(), CliError> {
    let model = robot_arg::resolve_model(&args.model, &args.chain)?;
    let effects = model
        .file
        .effects()
        .map_err(|m| CliError::input(format!("{}: {m}", args.model)))?;
    let name = model_label(
        model
            .file
            .algorithm()
            .map_or("NOM".to_string(), |a| a.name().to_uppercase()),
        effects,
    );
    kincal::with_any_robot!(&model.robot, r => validate(r, &name, &model.file, effects, args))
}

fn validate<const N: usize>(
    robot: &Robot<N>,
    name: &str,
    file: &kincal_io::model_file::ModelFile,
    effects: kincal::EffectSet,
    args: &Args,
) -> Result<(), CliError> {
    let needed = effects
        .iter()
        .chain(robot.active_effects().iter())
        .fold(kincal::EffectSet::NONE, kincal::EffectSet::with);
    let loaded = data::read_poses::<N>(
        &args.data,
        robot,
        needed,
        DataOptions {
            require_pose: true,
            allow_out_of_limits: args.allow_out_of_limits,
        },
        args.constraints.is_some(),
    )?;
    let (set, meas, labels, split) = match loaded {
        data::PoseFile::Rows(set)
            if !kincal_io::constraints::has_contacts(&set)
                && kincal_io::constraints::has_instrument_sessions(&set) =>
        {
            let (split, meas) = SessionSplit::of(&set, robot)?;
            let labels = RowLabels::of_set(&set);
            (set, meas, labels, Some(split))
        }
        data::PoseFile::Rows(set) => return validate_contacts(robot, name, file, args, &set),
        data::PoseFile::Poses { set, meas, labels } => (set, meas, labels, None),
    };
    let split = split.as_ref();
    let has_rot = meas.iter().any(|m| m.mask.has_orientation());
    let fail = |(i, e): (usize, kincal::Error)| core_error(e, &set.source, |_| labels.line(i));
    let main = score(name, robot, &meas, split).map_err(fail)?;
    let variants: Vec<(String, Robot<N>)> = file
        .variants::<N>()
        .map_err(|m| CliError::input(format!("{}: {m}", args.model)))?;
    // The variant that is this model carries its effects in its name too.
    let bare = name.split(" + ").next().unwrap_or(name);
    let evals = variants
        .iter()
        .map(|(n, r)| score(if n == bare { name } else { n }, r, &meas, split))
        .collect::<Result<Vec<_>, _>>()
        .map_err(fail)?;
    for e in std::iter::once(&main).chain(&evals) {
        refuse_non_finite(e, &set.source, &labels)?;
    }
    let targets = Targets {
        pos_m: args.target_pos_mm * 1e-3,
        rot_rad: args.target_rot_deg.to_radians(),
    };
    let id = |i: usize| match labels.pose_id(i) {
        Some(p) => p.to_string(),
        None => (i + 1).to_string(),
    };

    let biopsy = Biopsy::of(args, &main);

    // Outputs first, so a refused path fails before anything is printed.
    let mut inputs: Vec<&Path> = vec![&args.data];
    let model_path = Path::new(&args.model);
    if model_path.is_file() {
        inputs.push(model_path);
    }
    if let Some(p) = &args.json {
        let judged = Judged {
            main: &main,
            evals: &evals,
            meas: &meas,
            sha256: &set.sha256,
            labels: &labels,
            targets,
            has_rot,
            split,
        };
        write_json(p, &inputs, args, &judged, &biopsy)?;
    }
    if let Some(p) = &args.plot {
        let series: Vec<Series> = evals
            .iter()
            .map(|e| Series {
                name: e.name.clone(),
                errors: e.errors(&meas, split).collect(),
            })
            .collect();
        let title = format!("{} on {}", args.model, args.data.display());
        pose_errors::write_error_figure(p, &inputs, &title, &series, has_rot, targets)?;
    }

    let mut out = String::new();
    let _ = writeln!(
        out,
        "Validation of {} ({name} model of '{}') on {}: {}{}",
        args.model,
        file.robot.name,
        set.source,
        poses_text(&labels),
        if has_rot { "" } else { " (position only)" }
    );
    if calibrated_on(file, &set.sha256) {
        let w = "in-sample: DATA is the file this model was calibrated on (same SHA-256); these errors flatter the model, validate on poses the calibration did not see";
        eprintln!("kincal: warning: {w}");
        let _ = writeln!(out, "Warning: {w}");
    }
    if !args.quiet {
        // Streamed to stdout: one row per pose, never held whole.
        let _ = writeln!(out, "\nPer-pose errors ({name}, measured − model):");
        crate::report::emit(&out);
        out.clear();
        let mask = |i: usize| meas.get(i).map_or(ComponentMask::ALL, |m| m.mask);
        crate::report::emit_streamed_table(
            &pose_table_header(has_rot),
            || pose_table_rows(main.errors(&meas, split), id, has_rot, mask),
            "  ",
        );
    }
    out.push_str(&summary_section(
        args, file, name, &main, &evals, targets, has_rot,
    ));
    if let Some(s) = &main.sessions {
        out.push_str(&sessions_text(s, name, has_rot));
    }
    // Eq. (3) is the ARIA biopsy's budget: printed for ARIA or when asked for (--biopsy-d-mm).
    if is_aria(file) || args.biopsy_d_mm.is_some() {
        out.push_str(&eq3_text(args, &biopsy, &main, has_rot));
    }
    if let Some(p) = &args.plot {
        let _ = writeln!(out, "Error figure written to {}", p.display());
    }
    if let Some(p) = &args.json {
        let _ = writeln!(out, "Report written to {}", p.display());
    }
    crate::report::emit(&out);
    Ok(())
}

/// The biopsy budget of eq. (3): the distance d [m] at the puncture point (`--biopsy-d-mm`,
/// else the model's worst position error), the tumour radius and insertion depth [m], and
/// the orientation error it allows [rad] (`None` when d is not below the radius).
struct Biopsy {
    d_m: f64,
    tumour_radius_m: f64,
    insertion_m: f64,
    allowed_rot_rad: Option<f64>,
}

impl Biopsy {
    fn of<const N: usize>(args: &Args, main: &Scored<'_, N>) -> Self {
        let d_m = args
            .biopsy_d_mm
            .map_or(main.summary.max_pos_m, |d| d * 1e-3);
        let tumour_radius_m = args.tumour_radius_mm * 1e-3;
        let insertion_m = args.insertion_mm * 1e-3;
        Biopsy {
            d_m,
            tumour_radius_m,
            insertion_m,
            allowed_rot_rad: biopsy_allowed_rotation_rad(tumour_radius_m, d_m, insertion_m).ok(),
        }
    }
}

/// A model's errors on the data, and what they are judged against.
struct Judged<'a, const N: usize> {
    main: &'a Scored<'a, N>,
    evals: &'a [Scored<'a, N>],
    meas: &'a [Measurement<N>],
    /// SHA-256 of DATA.
    sha256: &'a str,
    labels: &'a RowLabels,
    targets: Targets,
    has_rot: bool,
    split: Option<&'a SessionSplit<N>>,
}

/// Writes `--json`: summaries of the model and of every variant, eq. (3), per-pose errors.
fn write_json<const N: usize>(
    path: &Path,
    inputs: &[&Path],
    args: &Args,
    j: &Judged<'_, N>,
    biopsy: &Biopsy,
) -> Result<(), CliError> {
    let (main, targets, has_rot) = (j.main, j.targets, j.has_rot);
    let report = ReportJson {
        model: &args.model,
        data: DataRef {
            path: args.data.display().to_string(),
            sha256: j.sha256,
        },
        targets: TargetsJson {
            pos_m: targets.pos_m,
            rot_rad: targets.rot_rad,
        },
        eq3: biopsy.allowed_rot_rad.map(|a| Eq3Json {
            tumour_radius_m: biopsy.tumour_radius_m,
            insertion_m: biopsy.insertion_m,
            d_m: biopsy.d_m,
            allowed_rot_rad: a,
            rot_ok: has_rot.then_some(main.summary.max_rot_rad < a),
        }),
        summary: summary_json(main, targets, has_rot),
        variants: j
            .evals
            .iter()
            .map(|e| summary_json(e, targets, has_rot))
            .collect(),
        sessions: main.sessions.as_deref().map(|s| sessions_json(s, has_rot)),
        poses: PosesJson(j),
    };
    // Written as it is serialised: the per-pose part of a million rows is never held.
    kincal_io::files::write_atomic(path, inputs, |w| {
        serde_json::to_writer_pretty(&mut *w, &report)?;
        w.write_all(b"\n")
    })?;
    Ok(())
}

/// The summary against the targets, and of every model in the file when it has several.
fn summary_section<const N: usize>(
    args: &Args,
    file: &kincal_io::model_file::ModelFile,
    name: &str,
    main: &Scored<'_, N>,
    evals: &[Scored<'_, N>],
    targets: Targets,
    has_rot: bool,
) -> String {
    let mut out = String::new();
    let default_targets = args.target_pos_mm == 1.0 && args.target_rot_deg == 0.66;
    let whose = if is_aria(file) {
        "the paper's ARIA targets"
    } else if default_targets {
        "the paper's ARIA biopsy targets; set --target-pos-mm/--target-rot-deg for this robot"
    } else {
        "targets"
    };
    let _ = writeln!(
        out,
        "\nSummary (per pose: e_p < {} mm, e_φ < {}°; {whose}):",
        args.target_pos_mm, args.target_rot_deg
    );
    out.push_str(&summary_table(
        [(main.name.as_str(), &main.summary)],
        targets,
        has_rot,
    ));
    if evals.len() > 1 || evals.first().is_some_and(|e| e.name != name) {
        let _ = writeln!(out, "\nAll models in {}:", args.model);
        out.push_str(&summary_table(
            evals.iter().map(|e| (e.name.as_str(), &e.summary)),
            targets,
            has_rot,
        ));
        out.push_str(&bounded_runs_note(file));
    }
    out
}

/// Eq. (3): the orientation error a biopsy allows at the model's worst position error, and
/// whether the worst orientation error is within it.
fn eq3_text<const N: usize>(
    args: &Args,
    biopsy: &Biopsy,
    main: &Scored<'_, N>,
    has_rot: bool,
) -> String {
    let d_m = biopsy.d_m;
    match biopsy.allowed_rot_rad {
        Some(a) => format!(
            "\nEq. (3): with d = {:.4} mm at the puncture point (r_t = {} mm, l_max = {} mm)\n  a biopsy allows e_φ up to {:.4}°{}\n",
            d_m * 1e3,
            args.tumour_radius_mm,
            args.insertion_mm,
            a.to_degrees(),
            if has_rot {
                format!(
                    ": worst e_φ {:.4}° {}",
                    main.summary.max_rot_rad.to_degrees(),
                    if main.summary.max_rot_rad < a {
                        "PASS"
                    } else {
                        "FAIL"
                    }
                )
            } else {
                String::new()
            }
        ),
        None => format!(
            "\nEq. (3): d = {:.4} mm is not below r_t = {} mm: no orientation error is allowed\n",
            d_m * 1e3,
            args.tumour_radius_mm
        ),
    }
}

/// Says which recorded runs ended on their OPT1 interval bounds (at least
/// `report::BOUND_DOMINATED_FRACTION` of their identified parameters): such a run's errors
/// measure its intervals, not the data, so a "NOT met" in its column has that reason.
fn bounded_runs_note(file: &kincal_io::model_file::ModelFile) -> String {
    let Some(cal) = &file.calibration else {
        return String::new();
    };
    let mut out = String::new();
    for run in &cal.results {
        let identified = run.parameters.len();
        let nb = run.parameters.iter().filter(|p| p.at_bound).count();
        if nb == 0
            || (nb as f64) < crate::report::BOUND_DOMINATED_FRACTION * identified.max(1) as f64
        {
            continue;
        }
        let _ = writeln!(
            out,
            "  {} ended on its bounds ({nb} of {identified} identified parameters at ±{} mm / ±{}°):\n    \
             its intervals exclude the data's optimum, so its errors measure the intervals, not the data\n    \
             (calibrate again with wider --bounds-mm/--bounds-deg to judge it)",
            run.algorithm.to_uppercase(),
            cal.options.bounds_length_mm,
            cal.options.bounds_angle_deg,
        );
    }
    out
}

/// Validation of contact data: the consistency of the predicted tool points per target and
/// plane (scatter about the target or plane re-estimated by each model: RMS and max, mm)
/// and the error of every known distance, for the model and its variants.
fn validate_contacts<const N: usize>(
    robot: &Robot<N>,
    name: &str,
    file: &kincal_io::model_file::ModelFile,
    args: &Args,
    set: &kincal_io::measurements::MeasurementSet,
) -> Result<(), CliError> {
    let cons = args
        .constraints
        .as_deref()
        .map(kincal_io::constraints::read_constraints)
        .transpose()?;
    let cd = kincal_io::constraints::build::<N>(set, cons.as_ref(), robot, 1.0)?;
    let line_of = |i: usize| cd.row_of(i).and_then(|r| set.rows.get(r)).map(|r| r.line);
    let variants: Vec<(String, Robot<N>)> = file
        .variants::<N>()
        .map_err(|m| CliError::input(format!("{}: {m}", args.model)))?;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "Validation of {} on {}: {} contacts at {} targets/planes, {} known distances",
        args.model,
        set.source,
        cd.contacts.len(),
        cd.groups.len(),
        cd.distances.len()
    );
    if !cd.instrument.is_empty() {
        let _ = writeln!(
            out,
            "  ({} instrument rows are not scored here: validate them without the contact rows)",
            cd.instrument.len()
        );
    }
    let mut table = Table::new(&[
        "model",
        "mean RMS [mm]",
        "max [mm]",
        "mean |dist err| [mm]",
        "max |dist err| [mm]",
    ]);
    let mut reports = Vec::new();
    for (n, r) in std::iter::once((name.to_string(), *robot)).chain(variants) {
        let j = cd
            .report_json(&r)
            .map_err(|e| core_error(e, &set.source, line_of))?;
        let groups: Vec<_> = j.targets.iter().chain(j.planes.iter()).collect();
        let mean_rms = groups.iter().map(|g| g.rms_mm).sum::<f64>() / groups.len().max(1) as f64;
        let max = groups.iter().map(|g| g.max_mm).fold(0.0, f64::max);
        let errs: Vec<f64> = j
            .distances
            .iter()
            .filter_map(|d| d.error_mm)
            .map(f64::abs)
            .collect();
        let (mean_d, max_d) = if errs.is_empty() {
            ("–".to_string(), "–".to_string())
        } else {
            (
                format!("{:.4}", errs.iter().sum::<f64>() / errs.len() as f64),
                format!("{:.4}", errs.iter().fold(0.0, |a: f64, &b| a.max(b))),
            )
        };
        table.row(vec![
            n.clone(),
            format!("{mean_rms:.4}"),
            format!("{max:.4}"),
            mean_d,
            max_d,
        ]);
        reports.push((n, j));
    }
    out.push_str(&table.render("  "));
    if let Some((_, j)) = reports.first()
        && !args.quiet
    {
        out.push_str(&kincal_io::constraints::report_text(j));
    }
    if let Some(path) = &args.json {
        let map: std::collections::BTreeMap<&str, &kincal_io::model_file::ConstraintsJson> =
            reports.iter().map(|(n, j)| (n.as_str(), j)).collect();
        let text = serde_json::to_string_pretty(&map)
            .map_err(|e| CliError::io(format!("{}: {e}", path.display())))?;
        let mut inputs: Vec<&Path> = vec![&args.data];
        if let Some(c) = &args.constraints {
            inputs.push(c);
        }
        kincal_io::files::write_atomic(path, &inputs, |w| w.write_all(text.as_bytes()))?;
    }
    crate::report::emit(&out);
    Ok(())
}
