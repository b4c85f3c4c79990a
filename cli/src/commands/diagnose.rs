//! `kincal diagnose DATA --robot ROBOT [--sigma-pos-mm S] [--sigma-rot-deg S] --json
//! REPORT.json --out MODEL`: the sim-to-real diagnosis of spec/effects.md. The core
//! (`kincal::diagnosis`) does every computation; this module reads the data, formats the
//! report (JSON per spec/cli.md and readable text), draws the plots and writes the model.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use kincal::diagnosis::{Config, Diagnosis, Method, ModelScore, Reason, Status};
use kincal::identify::Measurement;
use kincal::{Effect, EffectSet, ParamId, ParamIndex, ParamSet, Robot};

use crate::error::CliError;
use crate::plots::diagnosis::Outputs;
use crate::report::{self, Table, label, quantity_label};
use kincal_io::data::{self, DataOptions};
use kincal_io::diagnose::{
    self, FilesJson, Options, SigmaNames, effects_text, reason_text, suspect_rows, warning_text,
};
use kincal_io::diagnose_sessions::{SESSIONS_METHOD, Sessions, separate_by};
use kincal_io::measurements::MeasurementSet;

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
   Gross outliers are screened first (suspect rows, named by CSV line, are left out: at
   most 64 or a tenth of the rows; more rows over the threshold are heavy tails, none is
   left out, and REPORT.json's outlier_screen and a warning say how many); the
   stated σ is checked against the repeats and the residuals. Repeats noisier than the
   stated σ raise the floor to theirs, unless their differences follow the order of the
   rows (the set-up drifted during the session: the repeats measure the drift too; a
   repeats_drift warning, and the stated σ stays the floor). With fewer than 5 pose
   groups per fold, in-sample nested tests replace cross-validation (method in the report).
6. Sessions: with a `session` column naming several set-ups, each session's rows are
   registered into the robot's base frame (rigid fit, alternating with the geometric
   calibration); a candidate whose columns lie in the span of the per-session frames, or
   whose input (temp_c, s1..sN) is constant within every session, is confounded with the
   sessions (confounded_with: session_frame) and never chosen; the report says what data
   would separate them, and where the gap lies by session, extra_ column and prismatic
   reading.

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
    /// Candidate effects (comma-separated; default: every effect whose inputs DATA has);
    /// joint_scale@JOINT (a joint name, qK or sensor; repeatable) gives the joint_scale
    /// candidate the scale of those joints only, as calibrate --effects does
    #[arg(long, value_name = "E1,E2", value_delimiter = ',', value_parser = kincal_io::effects_arg::parse_effect_item)]
    pub candidates: Vec<kincal_io::effects_arg::EffectItem>,
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

pub fn run(args: &Args) -> Result<(), CliError> {
    let spec = kincal_io::robot_arg::resolve_robot(&args.robot, &args.chain)?;
    let kinds = kincal::with_any_robot!(&spec.robot, r => r.joint_kinds().to_vec());
    let choice = kincal_io::effects_arg::resolve(&args.candidates, &spec.joint_names, &kinds)
        .map_err(|e| CliError::usage(e.message.replacen("--effects", "--candidates", 1)))?;
    kincal::with_any_robot!(&spec.robot, r => {
        if let Some(text) = contact_diagnosis(r, args, choice.scale_joints.is_some())? {
            report::emit(&text);
            return Ok(());
        }
        let out = execute(r, &spec.name, args, choice.scale_joints.as_deref())?;
        // The run time goes to the screen only: the report files are byte-for-byte
        // reproducible.
        report::emit(&format!("{}Diagnosis took {:.2} s.\n", out.text, out.seconds));
        Ok(())
    })
}

/// The diagnosis of data with target/plane rows ([`kincal_io::diagnose_contacts`]); `None`
/// for instrument data. Writes REPORT.json and the readable report; no model (contact data
/// are calibrated by `kincal calibrate`).
fn contact_diagnosis<const N: usize>(
    robot: &Robot<N>,
    args: &Args,
    selectors: bool,
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
    if args.prior.is_some() {
        return Err(CliError::usage(
            "--prior: the contact-data diagnosis writes no model, so there is nothing to fit \
             with a prior (calibrate contact data with `kincal calibrate --constraints`)",
        ));
    }
    if selectors {
        return Err(CliError::usage(
            "--candidates joint_scale@JOINT: the contact-data diagnosis tests whole effects only \
             (give joint_scale without a joint)",
        ));
    }
    let candidates = candidate_effects(args);
    let options = kincal_io::diagnose_contacts::Options {
        candidates: &candidates,
        no_pairs: args.no_pairs,
        constraints: args.constraints.as_deref(),
        sigma_pos_mm: args.sigma_pos_mm,
        folds: args.folds,
    };
    let pb = crate::progress::spinner("diagnosing contact data (every candidate held out)");
    let report = kincal_io::diagnose_contacts::run(robot, &set, &options);
    pb.finish_and_clear();
    let report = report?;
    let (mut text, json) = (
        crate::commands::diagnose_contacts::text(&report),
        kincal_io::diagnose_contacts::json(&report),
    );
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

/// What a diagnosis produced (for the demo, which validates the models further).
#[derive(Debug, Clone)]
pub struct Outcome<const N: usize> {
    pub diagnosis: Box<Diagnosis<N>>,
    /// The readable report, as written to its file.
    pub text: String,
    /// Run time [s] (for the screen, never written).
    pub seconds: f64,
}

/// The candidate effects of `--candidates`, without their joint selectors.
fn candidate_effects(args: &Args) -> Vec<Effect> {
    let mut out: Vec<Effect> = Vec::new();
    for item in &args.candidates {
        if !out.contains(&item.effect) {
            out.push(item.effect);
        }
    }
    out
}

fn options(args: &Args, scale_joints: Option<&[usize]>) -> Result<Options, CliError> {
    if args.folds < 2 {
        return Err(CliError::usage(format!(
            "--folds {}: at least 2 folds are needed",
            args.folds
        )));
    }
    Ok(Options {
        sigma_pos_mm: args.sigma_pos_mm,
        sigma_rot_deg: args.sigma_rot_deg,
        candidates: candidate_effects(args),
        scale_joints: scale_joints.map(<[usize]>::to_vec),
        pairs: !args.no_pairs,
        folds: args.folds,
        seed: args.seed,
    })
}

/// Reads DATA, runs the diagnosis and writes every output; returns the readable report.
/// `scale_joints`: the joints (0-based) of the `joint_scale@JOINT` selectors, resolved.
pub fn execute<const N: usize>(
    robot: &Robot<N>,
    name: &str,
    args: &Args,
    scale_joints: Option<&[usize]>,
) -> Result<Outcome<N>, CliError> {
    let t0 = Instant::now();
    if args.prior == Some(crate::args::PriorArg::Auto) {
        return Err(CliError::usage(
            "--prior auto chooses the size by held-out error: run `kincal crossval --prior auto`, \
             then pass the size it reports (--prior MM,DEG)",
        ));
    }
    let options = options(args, scale_joints)?;
    let set = data::read(
        &args.data,
        robot,
        options.effects_to_read(),
        DataOptions {
            require_pose: true,
            allow_out_of_limits: args.allow_out_of_limits,
        },
    )?;
    let pb = crate::progress::spinner("diagnosing (cross-validating every candidate)");
    let study = diagnose::run(robot, &set, &options, SIGMA_FLAGS);
    pb.finish_and_clear();
    let study = study?;
    let seconds = t0.elapsed().as_secs_f64();
    let outputs = Outputs::new(&args.json, args.report.as_deref(), &args.out);
    let mut inputs: Vec<&Path> = vec![&args.data];
    let robot_path = Path::new(&args.robot);
    if robot_path.is_file() {
        inputs.push(robot_path);
    }

    // Everything is rendered first, then the paths are checked (never an input, never the
    // same file twice), then each file is written atomically.
    let model_text = diagnose::model_file(
        name,
        robot,
        &study,
        args.prior_kinds.sizes(args.prior),
        &set,
        &args.data,
        args.allow_out_of_limits,
    )?
    .to_json();
    let d = &study.diagnosis;
    let plots = crate::plots::diagnosis::render_all::<N>(d, &study.meas, &study.poses, &outputs)?;
    let report = diagnose::report(&study, &set, &args.data, Some(files_json(&outputs)));
    let json_text = diagnose::report_text(&report);
    let mut text = readable::<N>(name, &set, d, &study.meas);
    if let Some(sessions) = &study.sessions {
        text.push_str(&sessions_text(sessions, d));
    }
    text.push_str(&super::diagnose_where::text(&study.breakdown));
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
    check_outputs(&files, &inputs)?;
    for (path, content) in &files {
        kincal_io::files::write_atomic(path, &inputs, |w| w.write_all(content.as_bytes()))?;
    }
    Ok(Outcome {
        diagnosis: study.diagnosis,
        text,
        seconds,
    })
}

/// How the CLI names the noise arguments in io's messages.
const SIGMA_FLAGS: SigmaNames<'static> = SigmaNames {
    pos: "--sigma-pos-mm",
    rot: "--sigma-rot-deg",
};

/// REPORT.json's `files`: the other outputs.
fn files_json(outputs: &Outputs) -> FilesJson {
    FilesJson {
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
    }
}

/// Refuses an output that is an input or that another output names too.
fn check_outputs(files: &[(&Path, &str)], inputs: &[&Path]) -> Result<(), CliError> {
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
    Ok(())
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

/// The readable report: overview, where, which, verdict and how far, explainable at all.
pub fn readable<const N: usize>(
    robot: &str,
    set: &MeasurementSet,
    d: &Diagnosis<N>,
    meas: &[Measurement<N>],
) -> String {
    let mut s = String::new();
    overview_text(&mut s, robot, set, d, meas);
    where_text(&mut s, d);
    which_text(&mut s, d);
    verdict_text(&mut s, d);
    explainable_text(&mut s, d);
    s
}

/// The data, the noise floor, the geometric calibration's gap, suspects and warnings.
fn overview_text<const N: usize>(
    s: &mut String,
    robot: &str,
    set: &MeasurementSet,
    d: &Diagnosis<N>,
    meas: &[Measurement<N>],
) {
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
    // A component type no row measures (and no σ stated) has no noise floor: say so
    // instead of the core's placeholder σ.
    let floor = |known: bool, value: String, stated: bool, dof: f64, kind: &str| {
        if known {
            format!("{value} ({})", src(stated, dof))
        } else {
            format!("{kind} not measured")
        }
    };
    let pos = floor(
        n.measured_pos || n.stated_pos,
        format!("{} mm", mm(n.sigma_pos_m)),
        n.stated_pos,
        n.dof_pos,
        "position",
    );
    let rot = floor(
        n.measured_rot || n.stated_rot,
        format!("{}°", deg(n.sigma_rot_rad)),
        n.stated_rot,
        n.dof_rot,
        "orientation",
    );
    let pure = match (
        n.measured_pos || n.stated_pos,
        n.measured_rot || n.stated_rot,
    ) {
        (true, true) => format!("{} mm, {}°", mm(n.rms_pos_m()), deg(n.rms_rot_rad())),
        (true, false) => format!("{} mm", mm(n.rms_pos_m())),
        (false, _) => format!("{}°", deg(n.rms_rot_rad())),
    };
    let _ = writeln!(
        s,
        "Noise floor: {pos} and {rot} per axis; pure noise gives an RMS of √3σ = {pure}."
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
        // At the cap every row over the threshold is excluded, but a few more would have
        // excluded none (too_many_suspects): the user should know how close that was.
        let cap_note = if d.n_suspects >= d.suspect_cap {
            format!(
                "\n  (the cap: the screen excludes at most {} rows here, {} or a tenth of the rows)",
                d.suspect_cap,
                kincal::diagnosis::MAX_SUSPECTS
            )
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "Suspect rows (gross outliers, excluded from every fit and test): {}{cap_note}\n",
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
}

/// WHERE: the geometric calibration's residuals by axis, octant and correlated quantity.
fn where_text<const N: usize>(s: &mut String, d: &Diagnosis<N>) {
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
}

/// WHICH: every candidate's held-out score, with long notes as footnotes.
fn which_text<const N: usize>(s: &mut String, d: &Diagnosis<N>) {
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
        } else if c.session.confounded() {
            long_note(session_note(c), &mut footnotes)
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
}

/// VERDICT and HOW FAR, with the verdict's identified effect parameters.
fn verdict_text<const N: usize>(s: &mut String, d: &Diagnosis<N>) {
    let n = &d.noise;
    let v = &d.verdict;
    let _ = writeln!(
        s,
        "\nVERDICT: {} — {}",
        v.status.name(),
        match v.status {
            Status::NoGap => "the geometric model is already at the noise floor".to_string(),
            Status::Unexplained if v.reason == Reason::ConfoundedWithSessions =>
                "a gap; the candidates that close part of it are confounded with the sessions"
                    .to_string(),
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
}

/// EXPLAINABLE AT ALL: the library-free smooth check.
fn explainable_text<const N: usize>(s: &mut String, d: &Diagnosis<N>) {
    let v = &d.verdict;
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
}

// ---------------------------------------------------------------------------------------
// Several sessions

/// SESSIONS: the sessions, the candidates confounded with them and what would separate
/// them.
fn sessions_text<const N: usize>(sessions: &Sessions<N>, d: &Diagnosis<N>) -> String {
    let mut s = format!(
        "\nSESSIONS — {} sessions ({}): {SESSIONS_METHOD}.\n",
        sessions.names.len(),
        sessions
            .names
            .iter()
            .enumerate()
            .map(|(k, n)| format!("{n}: {} rows", sessions.rows(k)))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mut any = false;
    for c in d.candidates().iter().filter(|c| c.effects.len() == 1) {
        if c.session.confounded() {
            any = true;
            let _ = writeln!(s, "  {}: {}", effects_text(c.effects), session_note(c));
        }
    }
    if !any {
        let _ = writeln!(
            s,
            "  no candidate is confounded with the sessions (sin θ of every effect column and √w of every input above {})",
            Config::default().session_sin_max
        );
    }
    if let Some(sep) = separate_by(d) {
        let _ = writeln!(s, "  what would separate them: {sep}");
    }
    s
}

/// Why a candidate is confounded with the sessions, in words.
fn session_note(c: &ModelScore) -> String {
    let t = &c.session;
    let mut parts = Vec::new();
    if t.input_constant {
        parts.push(format!(
            "its input is constant within every session (√(within-session share of its variance) = {:.3}): it is estimated only from differences between sessions, so it is confounded with the session (its base frame and whatever else differs between the set-ups); not chosen",
            t.input_sin.unwrap_or(0.0)
        ));
    }
    if t.columns_in_span {
        parts.push(format!(
            "its columns lie in the span of the per-session base frames and the geometry (largest sin θ = {:.3}): a rigid frame per session does the same; not chosen",
            t.column_sin
        ));
    }
    if parts.is_empty() {
        parts.push("not confounded with the sessions".into());
    } else if !t.columns_in_span {
        parts.push(format!(
            "its columns themselves are not in the session frames' span (sin θ = {:.3}): the data see its pattern, but cannot attribute it to its input",
            t.column_sin
        ));
    }
    format!("confounded with the session frame: {}", parts.join("; "))
}
