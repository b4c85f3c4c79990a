//! `kincal calibrate DATA --robot ROBOT [--effects E1,E2] [--algorithm ols|opt1|opt2|all]
//! --out MODEL`.

use std::path::{Path, PathBuf};

use kincal::identify::Algorithm;
use kincal::{EffectSet, Robot};

use crate::args::{AlgorithmArg, OrientationArg, parse_effect, positive};
use crate::calibration::{self, Failure, Settings, Weighting};
use crate::data::{self, DataOptions};
use crate::error::{CliError, core_error};
use crate::model_file::{DataJson, ModelFile};
use crate::report;
use crate::robot_arg;

pub const LONG_ABOUT: &str = "\
Identifies the robot's parameters from measured poses: the geometric (modified DH / Hayati)
parameters θ0, a, α and d or β of every link, plus the parameters of the effects named with
--effects. The identifiability analysis runs first: structurally redundant parameters (no
data could separate them) and data-deficient ones (these poses cannot) are reported with the
identified parameter their Jacobian column is most aligned with. Data-deficient parameters
are an error (exit 4, report on stderr) unless --allow-data-deficiency.

Prints the identifiability report (rank, condition number), the parameter table (nominal,
identified, change and standard error; lengths in mm, angles in degrees), residuals before
and after, and estimate correlations above 0.95. With --algorithm all the three algorithms
run in parallel and are shown side by side with a consensus check: two algorithms disagree
on a parameter when they differ by more than 3 combined standard errors
(sqrt(se_a² + se_b²), each run's errors rescaled to the smallest residual variance of the
runs, so a run stuck on its bounds does not widen the tolerance) plus 1e-8 in SI units. The model file then stores the OLS model and
records OPT1, OPT2 and the consensus.

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

Unknown base and tool frames (a camera on the wrist observing a board, a tracker set up
anywhere): --effects base_frame,tool_frame identifies them with the geometry, starting from
the ROBOT's frames; when those are far off (more than a few cm or degrees), --init-frames
first estimates both frames from the data with the nominal geometry (hand-eye equation for
full poses, alternating rigid fits for positions; kincal::frames) and starts from there.

Exit status: 0 success, 2 usage, 3 bad input (file:line, column and reason), 4 numerical
failure (rank too low, no convergence).";

pub const EXAMPLE: &str = "\
Example:
  kincal calibrate poses.csv --robot aria --algorithm all --out aria-model.json
  kincal calibrate poses.csv --robot aria --effects joint_compliance --sigma-pos-mm 0.1 \\
      --sigma-rot-deg 0.02 --out aria-compliant.json";

#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Measurement CSV: joint readings and measured poses
    #[arg(value_name = "DATA")]
    pub data: PathBuf,
    /// Built-in robot name (aria) or robot description file: the initial model
    #[arg(long, value_name = "ROBOT")]
    pub robot: String,
    /// Effects to identify with the geometry (comma-separated names of spec/effects.md)
    #[arg(long, value_name = "E1,E2", value_delimiter = ',', value_parser = parse_effect)]
    pub effects: Vec<kincal::Effect>,
    /// Identification algorithm
    #[arg(long, value_enum, default_value = "ols")]
    pub algorithm: AlgorithmArg,
    /// Model file to write (JSON)
    #[arg(long, value_name = "MODEL")]
    pub out: PathBuf,
    /// OPT1 interval half-width for lengths [mm] (paper: 5 mm manufacturing tolerance)
    #[arg(long, value_name = "MM", default_value = "5", value_parser = positive)]
    pub bounds_mm: f64,
    /// OPT1 interval half-width for angles [deg] (paper: 5°)
    #[arg(long, value_name = "DEG", default_value = "5", value_parser = positive)]
    pub bounds_deg: f64,
    /// Accept joint readings outside the robot's joint limits
    #[arg(long)]
    pub allow_out_of_limits: bool,
    /// Fit the identifiable subset when the poses leave some parameters undetermined
    #[arg(long)]
    pub allow_data_deficiency: bool,
    /// Weight of the position rows [1/m²] (default 1)
    #[arg(long, value_name = "W", value_parser = positive, conflicts_with_all = ["sigma_pos_mm", "sigma_rot_deg"])]
    pub weight_pos: Option<f64>,
    /// Weight of the rotation rows [1/rad²] (default 1)
    #[arg(long, value_name = "W", value_parser = positive, conflicts_with_all = ["sigma_pos_mm", "sigma_rot_deg"])]
    pub weight_rot: Option<f64>,
    /// Instrument position noise, 1σ per axis [mm]: weight 1/σ²
    #[arg(long, value_name = "S", value_parser = positive, requires = "sigma_rot_deg")]
    pub sigma_pos_mm: Option<f64>,
    /// Instrument orientation noise, 1σ per axis [deg]: weight 1/σ²
    #[arg(long, value_name = "S", value_parser = positive, requires = "sigma_pos_mm")]
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
}

impl Args {
    fn settings(&self) -> Settings {
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
            effects: self
                .effects
                .iter()
                .fold(EffectSet::NONE, |acc, &e| acc.with(e)),
            algorithms: self.algorithm.algorithms(),
            bounds_length_m: self.bounds_mm * 1e-3,
            bounds_angle_rad: self.bounds_deg.to_radians(),
            weighting,
            orientation: self.orientation_error.into(),
            allow_data_deficiency: self.allow_data_deficiency,
            max_iterations: self.max_iterations,
        }
    }
}

pub fn run(args: &Args) -> Result<(), CliError> {
    let spec = robot_arg::resolve_robot(&args.robot)?;
    kincal::with_any_robot!(&spec.robot, r => calibrate(r, &spec.name, args))
}

fn calibrate<const N: usize>(start: &Robot<N>, name: &str, args: &Args) -> Result<(), CliError> {
    let settings = args.settings();
    let set = data::read(
        &args.data,
        start,
        settings.effects,
        DataOptions {
            require_pose: true,
            allow_out_of_limits: args.allow_out_of_limits,
        },
    )?;
    let meas = data::measurements::<N>(&set)?;
    let initial;
    let start = if args.init_frames {
        let (r, note) = calibration::init_frames(start, &meas, &set.source)?;
        eprintln!("{note}");
        initial = r;
        &initial
    } else {
        start
    };
    let rows: usize = meas
        .iter()
        .map(|m| (0..6).filter(|&k| m.mask.has(k)).count())
        .sum();
    let names: Vec<&str> = settings.algorithms.iter().map(|a| a.name()).collect();
    let pb = crate::progress::spinner(format!("identifying ({})", names.join(", ")));
    let result = calibration::calibrate(start, &meas, &settings);
    pb.finish_and_clear();
    let cal = match result {
        Ok(c) => c,
        Err(Failure::Deficient {
            analysis,
            singular_values,
        }) => {
            return Err(CliError::numeric(format!(
                "{}: rank deficient: the data determine {} of the {} structurally identifiable parameters\n{}\
                 hint: add poses that move the data-deficient parameters, or pass --allow-data-deficiency to fit the identifiable subset",
                set.source,
                analysis.rank,
                analysis.requested.len() - analysis.structural.len(),
                report::identifiability::<N>(&analysis, &singular_values, meas.len(), rows)
            )));
        }
        Err(Failure::Core { algorithm, error }) => {
            let e = core_error(error, &set.source, |i| data::line_of(&set, i));
            let hint = match (algorithm, error) {
                (Some(Algorithm::Ols), kincal::Error::NotConverged { .. }) => {
                    "\nhint: Gauss–Newton (OLS) can stall far from the solution or on nearly singular data; \
                     OPT2 (Levenberg–Marquardt) is more robust: --algorithm opt2"
                }
                (Some(_), kincal::Error::NotConverged { .. }) => {
                    "\nhint: raise --max-iterations, or add poses that determine the parameters better"
                }
                _ => "",
            };
            return Err(match algorithm {
                Some(a) => CliError {
                    exit: e.exit,
                    message: format!("{} failed: {}{hint}", a.name().to_uppercase(), e.message),
                },
                None => e,
            });
        }
    };

    let data_json = DataJson {
        path: args.data.display().to_string(),
        sha256: set.sha256.clone(),
        poses: meas.len(),
        rows,
    };
    let file = ModelFile::from_calibration(name, &cal, 0, data_json, args.allow_out_of_limits);
    let text = file.to_json();
    let mut inputs: Vec<&Path> = vec![&args.data];
    let robot_path = Path::new(&args.robot);
    if robot_path.is_file() {
        inputs.push(robot_path);
    }
    crate::files::write_atomic(&args.out, &inputs, |w| w.write_all(text.as_bytes()))?;

    let mut out = summary(&cal, name, &set.source, meas.len(), rows);
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
                .map(|e| e.name())
                .collect::<Vec<_>>()
                .join(", ")
        }
    ));
    s.push_str(&report::identifiability::<N>(
        &cal.analysis,
        &cal.singular_values,
        poses,
        rows,
    ));
    s.push('\n');
    if cal.runs.len() == 1 {
        s.push_str(&format!(
            "Parameters ({}; lengths in mm, angles in degrees):\n",
            cal.runs[0].ident.algorithm.name().to_uppercase()
        ));
        s.push_str(&report::parameters::<N>(cal, 0));
    } else {
        s.push_str("Identified parameters by algorithm (lengths in mm, angles in degrees):\n");
        s.push_str(&report::side_by_side::<N>(cal));
    }
    s.push('\n');
    let (wp, wr) = cal.settings.weighting.weights();
    s.push_str(&format!(
        "Residuals (weights: {} per m², {} per rad²):\n",
        report::fmt_small(wp),
        report::fmt_small(wr)
    ));
    s.push_str(&report::residuals::<N>(cal));
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
                "  note: {nb} {} parameter(s) ended on their interval bound (±{} mm, ±{}°): if the prior is too narrow, widen --bounds-mm/--bounds-deg\n",
                run.ident.algorithm.name().to_uppercase(),
                cal.settings.bounds_length_m * 1e3,
                cal.settings.bounds_angle_rad.to_degrees()
            ));
        }
    }
    if matches!(cal.settings.weighting, Weighting::Unit) {
        s.push_str(
            "  (unit weights: the std errors assume one noise level for position [m] and rotation [rad] rows;\n   \
             state --sigma-pos-mm/--sigma-rot-deg for std errors that follow the instrument)\n",
        );
    }
    s.push('\n');
    for k in 0..cal.runs.len() {
        s.push_str(&report::correlations::<N>(cal, k));
    }
    if let Some(c) = &cal.consensus {
        s.push('\n');
        s.push_str(&report::consensus::<N>(c));
    }
    s
}
