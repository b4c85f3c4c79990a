//! `kincal calibrate DATA --robot ROBOT [--effects E1,E2] [--algorithm ols|opt1|opt2|all]
//! [--robust huber|cauchy] --out MODEL`.

use std::path::{Path, PathBuf};

use std::fmt::Write as _;

use kincal::Robot;
use kincal::identify::{Algorithm, RobustOptions};

use crate::args::{AlgorithmArg, LossArg, OrientationArg, positive};
use crate::error::{CliError, core_error};
use crate::report;
use kincal_io::calibration::{self, Failure, Settings, Weighting};
use kincal_io::data::{self, DataOptions};
use kincal_io::model_file::{DataJson, ModelFile, PoseLabel};
use kincal_io::robot_arg;

pub const LONG_ABOUT: &str = "\
Identifies the robot's parameters from measured poses: the geometric (modified DH / Hayati)
parameters θ0, a, α and d or β of every link, plus the parameters of the effects named with
--effects. The identifiability analysis runs first: structurally redundant parameters (no
data could separate them) and data-deficient ones (these poses cannot) are reported with the
identified parameter their Jacobian column is most aligned with. The data test is repeated
at the fitted model: a parameter the poses separate only while the model is off (ARIA's tool
poses and the base's x, with --effects base_frame) is data-deficient too, held at its initial
value while the rest is refitted; the report marks it `at the fitted model` and the model
file's data_deficient entry has found_at_fit = true. Data-deficient parameters are an error
(exit 4, report on stderr) unless --allow-data-deficiency.

Prints the identifiability report (rank, condition number), the parameter table (nominal,
identified, change and standard error; lengths in mm, angles in degrees), residuals before
and after (each kind over the rows measuring it, |e_p| over the given coordinates: a row
giving only x contributes |e_x|; a dash where no row measures the kind), and estimate
correlations above 0.95. With --algorithm all the three algorithms
run in parallel and are shown side by side with a consensus check: two algorithms disagree
on a parameter when they differ by more than 3 combined standard errors
(sqrt(se_a² + se_b²), each run's errors rescaled to the smallest residual variance of the
runs, so a run stuck on its bounds does not widen the tolerance) plus 1e-8 in SI units. The model file then stores the OLS model and
records OPT1, OPT2 and the consensus. An OPT1 or OPT2 that fails (e.g. no convergence
within --max-iterations) is a warning: the comparison goes on without it and the model
file lists it under calibration.failed with its error; OLS failing fails the command.

Weighting: the cost is Σ w_pos·|Δp|² + w_rot·|Δφ|² with Δp in metres and Δφ in radians.
The default weights are 1 and 1 (the paper's). --weight-pos/--weight-rot set them
(1/m², 1/rad²); --sigma-pos-mm/--sigma-rot-deg state the instrument's 1σ noise per axis and
use w = 1/σ², which makes the residual variance σ² printed in the report ≈ 1 when the stated
noise is right. Only the ratio of the two weights changes the estimate.

DATA: measurement CSV (see spec/measurements.md): q1..qN [rad, or _deg], x,y,z [m, or _mm]
and an orientation (roll,pitch,yaw or qw,qx,qy,qz); position-only data (motion-capture
markers, laser-tracker reflectors) identify from the position rows alone, and the
identifiability report then shows what they cannot determine (e.g. the tool rotation, and
link parameters that only turn the end effector about the measured point). Several points
on one body: one row per point, with point_x, point_y, point_z [m, or _mm] giving the
point's position in the tool frame (known by design); the rows measure T_e^b·Trans(point),
so the points share one tool frame and together determine its rotation. Units in the model
file are SI (m, rad).

Robust fit: --robust huber|cauchy fits by iteratively reweighted least squares (core
kincal::identify::identify_robust) instead, so a few bad rows (a glitch of some millimetres,
a row recorded with the wrong joint readings) do not pull the model. Each pose's residual is
standardised by robust per-axis scales σ_p, σ_φ estimated from the residuals themselves (the
median, then the RMS over the accepted poses; not the --sigma-* values, so a misstated noise
does not condemn every row): d² = |e_p|²/σ_p² + |e_φ|²/σ_φ². Its weight is
min(1, c/d) (Huber, convex, started from the least-squares fit) or 1/(1 + d²/c²) (Cauchy,
redescending: a gross outlier ends near weight 0; started from the Huber fit), times the
--weight-*/--sigma-* weighting. c² defaults to the 95 % χ² quantile for the pose's k measured
components (c = 3.55 for a full pose, 2.80 for a position); --robust-tuning C sets c for
every pose. Rows with d² above the 99.99 % χ² quantile (d > 5.28 full pose, > 4.59 position)
are suspects: printed with their CSV line, pose_id, d, residual and robust weight, and
recorded in the model file under calibration.robust with the loss and the scales. The
residual table then covers every row (suspects included); the cost, σ² and standard errors
are those of the robustly weighted fit. With --algorithm all each algorithm is fitted
robustly (OPT1 inside its intervals), the consensus compares the robust fits, and the model
is the robust OLS fit; suspects another algorithm names differently are listed too. With
target/plane rows (core identify_constrained_robust) each contact is one row: its residual
is its distance to its target (3 components) or plane (1), estimated from the group's
weighted contacts; known distances keep their weight.

Unknown base and tool frames (a camera on the wrist observing a board, a tracker set up
anywhere): --effects base_frame,tool_frame identifies them with the geometry, starting from
the ROBOT's frames; when those are far off (more than a few cm or degrees), --init-frames
first estimates both frames from the data with the nominal geometry (hand-eye equation for
full poses, alternating rigid fits for positions; kincal::frames) and starts from there.

Plausibility: measured positions a median of more than 100 reaches from the base cannot be
the robot's (millimetres under a metre header?) and are refused unless --allow-implausible.
Positions out of reach or all within 1 % of the reach of the base, a residual worse after
calibration than before (position or orientation), identified parameters whose standard
error exceeds the --bounds-mm/--bounds-deg tolerance (the data determine them worse than the
manufacturing tolerance does) and identified changes beyond 10× that tolerance are warnings,
on stderr and in the model file (calibration.warnings).

Priors (docs/real-data.md, \"Priors\"): --prior [MM,DEG] adds a Gaussian prior around the
initial model on every link parameter (one σ for lengths [mm] and for angles [deg]; alone:
5 mm, 1°), in every algorithm: one row per parameter, whitened like the data rows, so it
needs --sigma-pos-mm/--sigma-rot-deg. Weakly excited directions then stay near nominal;
data-deficient link parameters are fitted (held by the prior) instead of refused; the
standard errors are posterior ones and σ² = data cost/(rows − n_eff), n_eff the number of
parameters the data determine. The model file records the prior (calibration.options.prior).
`kincal crossval --prior auto` chooses the size by held-out error. --prior-frames MM,DEG
and --prior-effects SIGMA add priors on the base/tool frames and on the effect parameters
(none by default: frames are registered, effects are what a diagnosis asks about); the
same flags, parsed in one place, work on crossval and diagnose (`diagnose --prior` fits
the written model with the prior).

Instrument-free data (docs/constraints.md): rows with a `target` id hold the tool point (a
ball centre, identified as the tool translation) at an unknown fixed point, rows with a
`plane` id on a plane; --constraints FILE (TOML) gives known distances between targets,
known targets and known planes. The 3 unknowns of each target/plane are eliminated, so many
targets cost little. Without an instrument row, known target or known plane the base frame is
not observable, and without a known distance neither is the scale: the report names what it
holds ('not observable (gauge)') and adds the consistency per target (scatter of the
predicted tool point, mm) and every known distance's error; the model file records them.

Exit status: 0 success, 1 the output could not be written, 2 usage, 3 bad input (file:line,
column and reason), 4 numerical failure (rank too low, no convergence).";

pub const EXAMPLE: &str = "\
Example:
  kincal calibrate poses.csv --robot aria --algorithm all --out aria-model.json
  kincal calibrate poses.csv --robot aria --effects joint_compliance --sigma-pos-mm 0.1 \\
      --sigma-rot-deg 0.02 --out aria-compliant.json
  kincal calibrate poses.csv --robot aria --robust cauchy --out aria-robust.json";

#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Measurement CSV: joint readings and measured poses
    #[arg(value_name = "DATA")]
    pub data: PathBuf,
    /// Built-in robot name (aria) or robot description file: the initial model
    #[arg(long, value_name = "ROBOT")]
    pub robot: String,
    #[command(flatten)]
    pub chain: kincal_io::robot_arg::UrdfChainArgs,
    /// Effects to identify with the geometry (comma-separated names of spec/effects.md;
    /// joint_scale@JOINT for one joint's scale: a joint name, qK or sensor, repeatable)
    #[arg(long, value_name = "E1,E2", value_delimiter = ',', value_parser = kincal_io::effects_arg::parse_effect_item)]
    pub effects: Vec<kincal_io::effects_arg::EffectItem>,
    /// Identification algorithm
    #[arg(long, value_enum, default_value = "ols")]
    pub algorithm: AlgorithmArg,
    /// Model file to write (JSON)
    #[arg(long, value_name = "MODEL")]
    pub out: PathBuf,
    /// OPT1 interval half-width for lengths [mm] (paper: 5 mm manufacturing tolerance)
    #[arg(long, value_name = "MM", default_value = "5", value_parser = positive)]
    pub bounds_mm: f64,
    /// OPT1 interval half-width for angles [deg] (paper: 5°; the demo uses 60° because its
    /// truth, the paper's Table 3, lies outside ±5° of the nominal model)
    #[arg(long, value_name = "DEG", default_value = "5", value_parser = positive)]
    pub bounds_deg: f64,
    /// Accept joint readings outside the robot's joint limits
    #[arg(long)]
    pub allow_out_of_limits: bool,
    /// Fit the identifiable subset when the poses leave some parameters undetermined
    #[arg(long)]
    pub allow_data_deficiency: bool,
    /// Weight of the position rows [1/m²] (default 1)
    #[arg(long, value_name = "W", value_parser = crate::args::weight, conflicts_with_all = ["sigma_pos_mm", "sigma_rot_deg"])]
    pub weight_pos: Option<f64>,
    /// Weight of the rotation rows [1/rad²] (default 1)
    #[arg(long, value_name = "W", value_parser = crate::args::weight, conflicts_with_all = ["sigma_pos_mm", "sigma_rot_deg"])]
    pub weight_rot: Option<f64>,
    /// Instrument position noise, 1σ per axis [mm]: weight 1/σ²
    #[arg(long, value_name = "S", value_parser = crate::args::sigma_mm, requires = "sigma_rot_deg")]
    pub sigma_pos_mm: Option<f64>,
    /// Instrument orientation noise, 1σ per axis [deg]: weight 1/σ²
    #[arg(long, value_name = "S", value_parser = crate::args::sigma_deg, requires = "sigma_pos_mm")]
    pub sigma_rot_deg: Option<f64>,
    /// Orientation error used in the cost
    #[arg(long, value_enum, default_value = "exact")]
    pub orientation_error: OrientationArg,
    /// Iteration limit of each algorithm
    #[arg(long, value_name = "N", default_value_t = 200)]
    pub max_iterations: u32,
    /// Estimate the base and tool frames from the data (nominal geometry) before identifying
    #[arg(long)]
    pub init_frames: bool,
    /// Robust fit (IRLS with this loss) instead of least squares; names suspect rows
    #[arg(long, value_enum, value_name = "LOSS")]
    pub robust: Option<LossArg>,
    /// Threshold c of the robust weight on the standardised residual d, for every pose
    /// [1] (default: sqrt of the 95 % χ² quantile for the pose's measured components: 3.55
    /// for a full pose, 2.80 for a position)
    #[arg(long, value_name = "C", value_parser = positive, requires = "robust")]
    pub robust_tuning: Option<f64>,
    /// Fit data that cannot be right for the robot (positions a hundred reaches from the
    /// base: a unit error?) instead of refusing it; the warning stays in the model file
    #[arg(long)]
    pub allow_implausible: bool,
    /// Known geometry of the fixtures (TOML: [[distance]], [[target]], [[plane]]) for
    /// data with target/plane rows (docs/constraints.md)
    #[arg(long, value_name = "FILE")]
    pub constraints: Option<PathBuf>,
    /// Gaussian priors around the initial model on the link parameters: one σ for lengths
    /// [mm] and angles [deg] (`--prior` alone: 5,1); needs --sigma-pos-mm/--sigma-rot-deg
    #[arg(long, value_name = "MM,DEG", value_parser = crate::args::prior, num_args = 0..=1, default_missing_value = "5,1", requires = "sigma_pos_mm")]
    pub prior: Option<crate::args::PriorArg>,
    #[command(flatten)]
    pub prior_kinds: crate::args::PriorKinds,
}

impl Args {
    fn settings(&self, choice: &kincal_io::effects_arg::EffectChoice) -> Settings {
        let weighting = match (
            self.sigma_pos_mm,
            self.sigma_rot_deg,
            self.weight_pos,
            self.weight_rot,
        ) {
            (Some(sp), Some(sr), _, _) => Weighting::Sigma {
                pos_m: sp * 1e-3,
                rot_rad: sr.to_radians(),
            },
            (_, _, None, None) => Weighting::Unit,
            (_, _, wp, wr) => Weighting::Explicit {
                pos: wp.unwrap_or(1.0),
                rot: wr.unwrap_or(1.0),
            },
        };
        Settings {
            effects: choice.effects,
            scale_joints: choice.scale_joints.clone(),
            algorithms: self.algorithm.algorithms(),
            bounds_length_m: self.bounds_mm * 1e-3,
            bounds_angle_rad: self.bounds_deg.to_radians(),
            weighting,
            orientation: self.orientation_error.into(),
            allow_data_deficiency: self.allow_data_deficiency,
            max_iterations: self.max_iterations,
            prior: self.prior_kinds.sizes(self.prior),
            robust: self.robust.map(|loss| {
                let mut o = RobustOptions::new(loss.into());
                if let Some(c) = self.robust_tuning {
                    o.tuning_chi2 = [c * c; 6];
                }
                o
            }),
        }
    }
}

pub fn run(args: &Args) -> Result<(), CliError> {
    let spec = robot_arg::resolve_robot(&args.robot, &args.chain)?;
    let kinds = kincal::with_any_robot!(&spec.robot, r => r.joint_kinds().to_vec());
    let choice = kincal_io::effects_arg::resolve(&args.effects, &spec.joint_names, &kinds)?;
    kincal::with_any_robot!(&spec.robot, r => calibrate(r, &spec.name, &choice, args))
}

fn calibrate<const N: usize>(
    start: &Robot<N>,
    name: &str,
    choice: &kincal_io::effects_arg::EffectChoice,
    args: &Args,
) -> Result<(), CliError> {
    if args.prior == Some(crate::args::PriorArg::Auto) {
        return Err(CliError::usage(
            "--prior auto chooses the size by held-out error: run `kincal crossval --prior auto`, \
             then pass the size it reports (--prior MM,DEG)",
        ));
    }
    let settings = args.settings(choice);
    let loaded = data::read_poses::<N>(
        &args.data,
        start,
        settings.effects,
        DataOptions {
            require_pose: true,
            allow_out_of_limits: args.allow_out_of_limits,
        },
        args.constraints.is_some(),
    )?;
    let (set, meas, labels) = match loaded {
        data::PoseFile::Rows(set) => return calibrate_contacts(start, name, args, &settings, &set),
        data::PoseFile::Poses { set, meas, labels } => (set, meas, labels),
    };
    let pose_data =
        kincal_io::pose_calibration::pose_data_of::<N>(meas, &set.source, start, args.init_frames);
    let findings = &pose_data.findings;
    if let (Some(e), false) = (findings.errors.first(), args.allow_implausible) {
        return Err(CliError::input(format!(
            "{e}\nhint: pass --allow-implausible to fit these data anyway"
        )));
    }
    // Shown before the fit, which may fail on such data.
    for w in findings.errors.iter().chain(&findings.warnings) {
        eprintln!("kincal: warning: {w}");
    }
    let (meas, rows) = (&pose_data.meas, pose_data.rows);
    let initial;
    let start = if args.init_frames {
        let (r, note) = calibration::init_frames(start, meas, &set.source)?;
        eprintln!("{note}");
        initial = r;
        &initial
    } else {
        start
    };
    let names: Vec<&str> = settings.algorithms.iter().map(|a| a.name()).collect();
    let pb = crate::progress::spinner(format!(
        "identifying ({}){}",
        names.join(", "),
        settings
            .robust
            .map_or(String::new(), |r| format!(", robust {}", r.loss.name()))
    ));
    let result = calibration::calibrate(start, meas, &settings);
    pb.finish_and_clear();
    let cal = result.map_err(|f| {
        failure_error::<N>(f, &settings, &set.source, meas.len(), rows, |i| {
            labels.line(i)
        })
    })?;
    warn_failed(&cal, &settings, &set.source, |i| labels.line(i));

    let data_json = DataJson {
        path: args.data.display().to_string(),
        sha256: set.sha256.clone(),
        poses: meas.len(),
        rows,
    };
    let label = |i: usize| labels.label(i);
    let (file, result_warnings) = kincal_io::pose_calibration::model_file_of(
        name,
        &cal,
        data_json,
        &pose_data,
        &label,
        args.allow_out_of_limits,
    );
    for w in &result_warnings {
        eprintln!("kincal: warning: {w}");
    }
    let text = file.to_json();
    let mut inputs: Vec<&Path> = vec![&args.data];
    let robot_path = Path::new(&args.robot);
    if robot_path.is_file() {
        inputs.push(robot_path);
    }
    kincal_io::files::write_atomic(&args.out, &inputs, |w| w.write_all(text.as_bytes()))?;

    let mut out = summary(&cal, name, &set.source, meas.len(), rows);
    out.push_str(&robust_report(&cal, &label));
    out.push_str(&format!(
        "Model written to {} ({} model).\n",
        args.out.display(),
        cal.runs[0].ident.algorithm.name().to_uppercase()
    ));
    report::emit(&out);
    Ok(())
}

/// The whole calibration report.
pub fn summary<const N: usize>(
    cal: &calibration::Calibration<N>,
    robot: &str,
    source: &str,
    poses: usize,
    rows: usize,
) -> String {
    let mut s = String::new();
    s.push_str(&format!(
        "Calibration of '{robot}' from {source}: {poses} poses, effects: {}\n\n",
        if cal.settings.effects.is_empty() {
            "none (geometric model)".to_string()
        } else {
            cal.settings
                .effects
                .iter()
                .map(|e| match (&cal.settings.scale_joints, e) {
                    (Some(js), kincal::Effect::JointScale) => format!(
                        "joint_scale ({} only)",
                        js.iter()
                            .map(|j| format!("q{}", j + 1))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                    _ => e.name().to_string(),
                })
                .collect::<Vec<_>>()
                .join(", ")
        }
    ));
    s.push_str(&report::identifiability::<N>(
        &cal.analysis,
        &cal.singular_values,
        &cal.found_at_fit,
        poses,
        rows,
    ));
    s.push('\n');
    let robust_note = cal
        .settings
        .robust
        .map_or(String::new(), |r| format!(", robust {} fit", r.loss.name()));
    if cal.runs.len() == 1 {
        s.push_str(&format!(
            "Parameters ({}{}; lengths in mm, angles in degrees):\n",
            cal.runs[0].ident.algorithm.name().to_uppercase(),
            robust_note
        ));
        s.push_str(&report::parameters::<N>(cal, 0));
    } else {
        s.push_str(&format!(
            "Identified parameters by algorithm{robust_note} (lengths in mm, angles in degrees):\n"
        ));
        s.push_str(&report::side_by_side::<N>(cal));
    }
    for (algorithm, error) in &cal.failed {
        s.push_str(&format!(
            "  {} failed: {error} (not in the table nor the consensus)\n",
            algorithm.name().to_uppercase()
        ));
    }
    s.push('\n');
    let (wp, wr) = cal.settings.weighting.weights();
    s.push_str(&format!(
        "Residuals (weights: {} per m², {} per rad²):\n",
        report::fmt_small(wp),
        report::fmt_small(wr)
    ));
    s.push_str(&report::residuals::<N>(cal));
    if cal.settings.robust.is_some() {
        s.push_str(
            "  (robust fit: RMS and max over every row, suspects included; cost and σ² of the robustly weighted problem)\n",
        );
    }
    for run in &cal.runs {
        s.push_str(&format!(
            "  σ² {} = {}{}\n",
            run.ident.algorithm.name().to_uppercase(),
            report::fmt_small(run.ident.sigma2),
            if matches!(cal.settings.weighting, Weighting::Sigma { .. }) {
                " (≈ 1 when the stated noise is right)"
            } else {
                ""
            }
        ));
    }
    for run in &cal.runs {
        let nb = run.ident.at_bound.len();
        if nb > 0 {
            s.push_str(&format!(
                "  note: {nb} {} parameter(s) ended on their interval bound (±{} mm, ±{}°);\n        if the prior is too narrow, widen --bounds-mm/--bounds-deg\n",
                run.ident.algorithm.name().to_uppercase(),
                cal.settings.bounds_length_m * 1e3,
                cal.settings.bounds_angle_rad.to_degrees()
            ));
        }
    }
    s.push_str(&prior_report::<N>(cal));
    if matches!(cal.settings.weighting, Weighting::Unit) {
        s.push_str(
            "  (unit weights: the std errors assume one noise level for position [m] and rotation [rad] rows;\n   \
             state --sigma-pos-mm/--sigma-rot-deg for std errors that follow the instrument)\n",
        );
    }
    s.push('\n');
    s.push_str(&report::correlations_all::<N>(cal));
    if let Some(c) = &cal.consensus {
        s.push('\n');
        s.push_str(&report::consensus_of::<N>(cal, c));
    }
    s
}

/// The robust fit's scales and suspect rows (empty without `--robust`): a table for the
/// model's run (the first), and for every other run the suspects that differ from it.
pub fn robust_report<const N: usize>(
    cal: &calibration::Calibration<N>,
    labels: &dyn Fn(usize) -> Option<PoseLabel>,
) -> String {
    let mut s = String::new();
    let Some(opts) = cal.settings.robust else {
        return s;
    };
    let Some((main, rest)) = cal.runs.split_first() else {
        return s;
    };
    let Some(r) = &main.robust else {
        return s;
    };
    let orientation = r.poses.iter().any(|p| p.components > 3);
    let where_ = |i: usize| {
        labels(i).map_or_else(
            || format!("row {}", i + 1),
            |l| {
                format!(
                    "line {} (pose {})",
                    l.line,
                    l.pose_id.as_deref().unwrap_or("-")
                )
            },
        )
    };
    let tuned = if opts.tuning_chi2.iter().all(|&c2| c2 == opts.tuning_chi2[0]) {
        format!("c = {:.3}", opts.tuning_chi2[0].sqrt())
    } else {
        format!(
            "c = {:.2} (full pose) / {:.2} (position): 95 % χ² quantiles",
            opts.tuning_chi2[5].sqrt(),
            opts.tuning_chi2[2].sqrt()
        )
    };
    let _ = writeln!(
        s,
        "\nRobust fit ({} IRLS, {tuned}; {}: {} reweighted fits): robust scales σ_pos {:.4} mm{} per axis",
        opts.loss.name(),
        main.ident.algorithm.name().to_uppercase(),
        r.reweights,
        r.test.scale_pos_m * 1e3,
        if orientation {
            format!(", σ_rot {:.4}°", r.test.scale_rot_rad.to_degrees())
        } else {
            String::new()
        }
    );
    let suspects = r.suspects();
    let _ = writeln!(
        s,
        "Suspect rows (d² above the 99.99 % χ² quantile: d > {:.2} full pose, > {:.2} position): {}",
        opts.suspect_chi2[5].sqrt(),
        opts.suspect_chi2[2].sqrt(),
        if suspects.is_empty() {
            "none".to_string()
        } else {
            suspects.len().to_string()
        }
    );
    if !suspects.is_empty() {
        let mut t = report::Table::new(&[
            "line",
            "pose_id",
            "d",
            "|e_p| [mm]",
            "|e_φ| [deg]",
            "robust weight",
        ]);
        for &i in &suspects {
            let p = &r.poses[i];
            let l = labels(i);
            t.row(vec![
                l.as_ref()
                    .map_or_else(|| "-".into(), |l| l.line.to_string()),
                l.and_then(|l| l.pose_id).unwrap_or_else(|| "-".into()),
                format!("{:.2}", p.distance),
                format!("{:.4}", p.pos_m * 1e3),
                if p.components > 3 {
                    format!("{:.4}", p.rot_rad.to_degrees())
                } else {
                    "-".into()
                },
                format!("{:.3e}", p.robust_weight),
            ]);
        }
        s.push_str(&t.render("  "));
    }
    for run in rest {
        let Some(o) = &run.robust else { continue };
        let theirs = o.suspects();
        let name = run.ident.algorithm.name().to_uppercase();
        if theirs == suspects {
            let _ = writeln!(
                s,
                "  {name} (σ_pos {:.4} mm, {} reweighted fits): the same suspects",
                o.test.scale_pos_m * 1e3,
                o.reweights
            );
        } else {
            let list = |v: Vec<usize>| {
                if v.is_empty() {
                    "none".to_string()
                } else {
                    v.into_iter().map(where_).collect::<Vec<_>>().join(", ")
                }
            };
            let _ = writeln!(
                s,
                "  {name} (σ_pos {:.4} mm, {} reweighted fits) also names: {}; does not name: {}",
                o.test.scale_pos_m * 1e3,
                o.reweights,
                list(
                    theirs
                        .iter()
                        .copied()
                        .filter(|i| !suspects.contains(i))
                        .collect()
                ),
                list(
                    suspects
                        .iter()
                        .copied()
                        .filter(|i| !theirs.contains(i))
                        .collect()
                ),
            );
        }
    }
    s
}

/// One warning per requested algorithm that failed while the model's succeeded (the
/// error as [`failure_error`] words it, hint included): the calibration goes on without
/// that algorithm's column.
fn warn_failed<const N: usize>(
    cal: &calibration::Calibration<N>,
    settings: &Settings,
    source: &str,
    line_of: impl Fn(usize) -> Option<u64> + Copy,
) {
    let model = cal
        .runs
        .first()
        .map_or(String::new(), |r| r.ident.algorithm.name().to_uppercase());
    for &(algorithm, error) in &cal.failed {
        let f = Failure::Core {
            algorithm: Some(algorithm),
            error,
        };
        let e = failure_error::<N>(f, settings, source, 0, 0, line_of);
        let (what, hint) = e
            .message
            .split_once('\n')
            .map_or((e.message.as_str(), String::new()), |(w, h)| {
                (w, format!("\n{h}"))
            });
        eprintln!(
            "kincal: warning: {what}; left out of the comparison (the model is {model}'s){hint}"
        );
    }
}

/// The CLI error of a failed calibration: a rank-deficiency report (exit 4) or the core
/// error with its CSV line and a hint.
fn failure_error<const N: usize>(
    f: Failure,
    settings: &Settings,
    source: &str,
    poses: usize,
    rows: usize,
    line_of: impl Fn(usize) -> Option<u64>,
) -> CliError {
    match f {
        Failure::Deficient {
            analysis,
            singular_values,
            found_at_fit,
        } => CliError::numeric(format!(
            "{source}: rank deficient: the data determine {} of the {} structurally identifiable parameters\n{}\
             hint: add poses that move the data-deficient parameters, or pass --allow-data-deficiency to fit the identifiable subset",
            analysis.rank,
            analysis.requested.len() - analysis.structural.len(),
            report::identifiability::<N>(&analysis, &singular_values, &found_at_fit, poses, rows)
        )),
        Failure::Core { algorithm, error } => {
            let e = core_error(error, source, line_of);
            let hint = match (algorithm, error) {
                (Some(_), kincal::Error::NotConverged { .. }) if settings.robust.is_some() => {
                    "\nhint: the robust reweighting or one of its fits did not settle: raise --max-iterations, \
                     try --robust huber (convex), or --algorithm opt2 (Levenberg–Marquardt)"
                }
                (Some(Algorithm::Ols), kincal::Error::NotConverged { .. }) => {
                    "\nhint: Gauss–Newton (OLS) can stall far from the solution or on nearly singular data; \
                     OPT2 (Levenberg–Marquardt) is more robust: --algorithm opt2"
                }
                (Some(_), kincal::Error::NotConverged { .. }) => {
                    "\nhint: raise --max-iterations, or add poses that determine the parameters better"
                }
                _ => "",
            };
            match algorithm {
                Some(a) => CliError {
                    kind: e.kind,
                    message: format!("{} failed: {}{hint}", a.name().to_uppercase(), e.message),
                },
                None => e,
            }
        }
    }
}

/// Calibration from target/plane (contact) rows, possibly mixed with instrument rows
/// (docs/constraints.md).
fn calibrate_contacts<const N: usize>(
    start: &Robot<N>,
    name: &str,
    args: &Args,
    settings: &Settings,
    set: &kincal_io::measurements::MeasurementSet,
) -> Result<(), CliError> {
    if args.init_frames {
        return Err(CliError::usage(
            "--init-frames needs instrument poses; data with target/plane rows start from the ROBOT's frames",
        ));
    }
    let cons = args
        .constraints
        .as_deref()
        .map(kincal_io::constraints::read_constraints)
        .transpose()?;
    let cd = kincal_io::constraints::build::<N>(
        set,
        cons.as_ref(),
        start,
        settings.weighting.weights().0,
    )?;
    if settings.robust.is_some() && !cd.sessions.is_empty() {
        return Err(CliError::usage(super::crossval::ROBUST_SESSIONS));
    }
    let view = cd.view();
    let rows = kincal_rows(&cd);
    let pb = crate::progress::spinner("identifying from contacts".to_string());
    let result = calibration::calibrate_constrained(start, &view, settings);
    pb.finish_and_clear();
    let line_of = |i: usize| cd.row_of(i).and_then(|r| set.rows.get(r)).map(|r| r.line);
    let cal = result
        .map_err(|f| failure_error::<N>(f, settings, &set.source, cd.rows(), rows, line_of))?;
    warn_failed(&cal, settings, &set.source, line_of);
    let robot = &cal.runs[0].ident.robot;
    let cons_json = cd
        .report_json(robot)
        .map_err(|e| core_error(e, &set.source, line_of))?;
    let data_json = DataJson {
        path: args.data.display().to_string(),
        sha256: set.sha256.clone(),
        poses: cd.rows(),
        rows,
    };
    let mut file = ModelFile::from_calibration(name, &cal, 0, data_json, args.allow_out_of_limits);
    // The robust fit's rows are the core's: instrument rows, then contacts by group.
    let labels: Vec<PoseLabel> = (0..cd.rows())
        .filter_map(|i| cd.row_of(i).and_then(|r| set.rows.get(r)))
        .map(|r| PoseLabel {
            line: r.line,
            pose_id: r.pose_id.clone(),
        })
        .collect();
    let label = |i: usize| labels.get(i).cloned();
    file.record_robust(&cal, 0, &label);
    if let Some(c) = file.calibration.as_mut() {
        c.constraints = Some(cons_json.clone());
    }
    let text = file.to_json();
    let mut inputs: Vec<&Path> = vec![&args.data];
    let robot_path = Path::new(&args.robot);
    if robot_path.is_file() {
        inputs.push(robot_path);
    }
    if let Some(c) = &args.constraints {
        inputs.push(c);
    }
    kincal_io::files::write_atomic(&args.out, &inputs, |w| w.write_all(text.as_bytes()))?;
    let mut out = summary(&cal, name, &set.source, cd.rows(), rows);
    out.push_str(&robust_report(&cal, &label));
    out.push_str(&kincal_io::constraints::reference_note(&view));
    let frames = cd
        .session_frames(robot, &settings.row_options())
        .map_err(|e| core_error(e, &set.source, line_of))?;
    out.push_str(&kincal_io::constraints::session_frames_text(
        cd.base_session.as_deref(),
        &frames,
    ));
    out.push_str(&kincal_io::constraints::report_text(&cons_json));
    out.push_str(&format!(
        "Model written to {} ({} model).\n",
        args.out.display(),
        cal.runs[0].ident.algorithm.name().to_uppercase()
    ));
    report::emit(&out);
    Ok(())
}

/// Residual rows of contact data (before eliminating the nuisance parameters).
fn kincal_rows<const N: usize>(cd: &kincal_io::constraints::ContactData<N>) -> usize {
    let inst: usize = cd
        .instrument
        .iter()
        .map(|m| (0..6).filter(|&k| m.mask.has(k)).count())
        .sum();
    let contacts: usize = cd
        .groups
        .iter()
        .map(|g| g.len * if g.kind.is_target() { 3 } else { 1 })
        .sum();
    inst + contacts + cd.distances.len()
}

/// The prior's lines of the report: sizes, its χ² per run, the parameters it holds.
fn prior_report<const N: usize>(cal: &calibration::Calibration<N>) -> String {
    let Some(p) = cal.settings.prior else {
        return String::new();
    };
    let mut s = format!(
        "  prior: Gaussian around the initial model, σ {:.3} mm (link lengths), {:.3}° (link angles); \
         σ² = data cost/(rows − n_eff), std errors posterior\n",
        p.length_m * 1e3,
        p.angle_rad.to_degrees()
    );
    for run in &cal.runs {
        let r = &run.ident;
        s.push_str(&format!(
            "  prior χ² {} = {} over {} rows",
            r.algorithm.name().to_uppercase(),
            report::fmt_small(r.prior_chi2),
            r.prior_rows
        ));
        if !r.prior_held.is_empty() {
            let held: Vec<String> = r.prior_held.iter().map(report::label::<N>).collect();
            s.push_str(&format!("; held by the prior alone: {}", held.join(", ")));
        }
        s.push('\n');
    }
    s
}
