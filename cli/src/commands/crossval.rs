//! `kincal crossval DATA --robot ROBOT [--effects E1,E2] [--init-frames] [--folds K]`:
//! held-out residuals of the nominal geometry and of the calibrated model (k-fold
//! cross-validation by pose_id), the noise floor (repeats, or an upper bound from the
//! residuals), and the outliers a robust fit names. Every number comes from the core:
//! `frames::estimate_frames`, `identify::identify`, `identify::identify_robust`,
//! `validation::{PoseErrors, ErrorSummary}`, `noise::{pooled_repeat_scatter,
//! residual_sigma}` (the diagnosis's noise-floor estimator).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use kincal::identify::{Loss, PriorSizes};
use kincal::validation::ErrorSummary;
use kincal::{EffectSet, Robot};

use crate::error::CliError;
use kincal_io::crossval::{self as cv, Options, PriorChoice, Weighting};
use kincal_io::crossval_contacts as ccv;
use kincal_io::data::{self, DataOptions};
use kincal_io::effects_arg::EffectChoice;
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
    /// Effects to identify with the geometry (comma-separated names of spec/effects.md;
    /// joint_scale@JOINT for one joint's scale: a joint name, qK or sensor, repeatable)
    #[arg(long, value_name = "E1,E2", value_delimiter = ',', value_parser = kincal_io::effects_arg::parse_effect_item)]
    pub effects: Vec<kincal_io::effects_arg::EffectItem>,
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
    pub group_by: Option<kincal_io::crossval_contacts::GroupBy>,
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
    let kinds = kincal::with_any_robot!(&spec.robot, r => r.joint_kinds().to_vec());
    let choice = kincal_io::effects_arg::resolve(&args.effects, &spec.joint_names, &kinds)?;
    kincal::with_any_robot!(&spec.robot, r => crossval(r, &spec.name, &choice, args))
}

/// io's options from the arguments.
fn options(args: &Args, choice: &EffectChoice) -> Options {
    Options {
        effects: choice.effects,
        scale_joints: choice.scale_joints.clone(),
        init_frames: args.init_frames,
        folds: args.folds,
        seed: args.seed,
        geometry: args.geometry.clone(),
        weighting: match (args.sigma_pos_mm, args.sigma_rot_deg, args.unit_weights) {
            (Some(pos_mm), Some(rot_deg), _) => Weighting::Stated { pos_mm, rot_deg },
            (_, _, true) => Weighting::Unit,
            _ => Weighting::Residual,
        },
        robust: args.robust.map(Loss::from),
        max_iterations: args.max_iterations,
        prior: match args.prior {
            None => PriorChoice::None,
            Some(crate::args::PriorArg::Auto) => PriorChoice::Auto {
                template: args.prior_kinds.apply(PriorSizes::DEFAULT),
            },
            Some(p @ crate::args::PriorArg::Sizes { .. }) => args
                .prior_kinds
                .sizes(Some(p))
                .map_or(PriorChoice::None, PriorChoice::Sizes),
        },
    }
}

fn crossval<const N: usize>(
    nominal: &Robot<N>,
    name: &str,
    choice: &EffectChoice,
    args: &Args,
) -> Result<(), CliError> {
    let effects = choice.effects;
    let set = data::read(
        &args.data,
        nominal,
        effects,
        DataOptions {
            require_pose: true,
            allow_out_of_limits: args.allow_out_of_limits,
        },
    )?;
    if ccv::takes_this_route(&set, args.constraints.is_some()) {
        return crossval_contacts(nominal, args, &set, choice);
    }
    if args.group_by.is_some() {
        return Err(CliError::usage(
            "--group-by applies to data with target/plane rows (instrument data: folds by pose_id)",
        ));
    }
    let options = options(args, choice);
    let pb = crate::progress::spinner(format!("cross-validating ({} folds)", args.folds));
    let study = cv::run(nominal, &set, &options);
    pb.finish_and_clear();
    let study = study?;
    let mut s = readable(&study, &set, nominal, name, args);

    // Outputs.
    let mut inputs: Vec<&Path> = vec![&args.data];
    let robot_path = Path::new(&args.robot);
    if robot_path.is_file() {
        inputs.push(robot_path);
    }
    if let Some(p) = &args.json {
        let doc = cv::json(&study, &set, nominal, name, &options);
        let text = serde_json::to_string_pretty(&doc).map_err(|e| CliError::io(e.to_string()))?;
        kincal_io::files::write_atomic(p, &inputs, |w| w.write_all(text.as_bytes()))?;
        let _ = writeln!(s, "JSON written to {}.", p.display());
    }
    if let Some(p) = &args.plot {
        let svg = crate::plots::pose_errors::heldout_svg(
            &format!("{name}: held-out errors per pose ({} folds)", args.folds),
            &study.held_nom,
            &study.held_cal,
            study.orientation,
        )
        .map_err(|e| CliError::io(format!("{}: cannot draw the figure: {e}", p.display())))?;
        kincal_io::files::write_atomic(p, &inputs, |w| w.write_all(svg.as_bytes()))?;
        let _ = writeln!(s, "Figure written to {}.", p.display());
    }
    if let Some(p) = &args.robot_out {
        let r = cv::robot_with_frames(nominal, &study, &options, &set.source)?;
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

/// The readable report: the set-up, weights, prior, residual tables, noise floor and
/// outliers.
fn readable<const N: usize>(
    study: &cv::Study<N>,
    set: &MeasurementSet,
    nominal: &Robot<N>,
    name: &str,
    args: &Args,
) -> String {
    let mut s = String::new();
    setup_text(&mut s, study, set, name, args);
    prior_text(
        &mut s,
        study.prior,
        args.prior == Some(crate::args::PriorArg::Auto),
        &study.auto_table,
        study.orientation,
    );
    changes_text(&mut s, study, nominal);
    residuals_text(&mut s, study);
    noise_text(&mut s, study);
    outliers_text(&mut s, study, set, args);
    s
}

/// The data, the models, the fits and the weighting.
fn setup_text<const N: usize>(
    s: &mut String,
    study: &cv::Study<N>,
    set: &MeasurementSet,
    name: &str,
    args: &Args,
) {
    let (orientation, w) = (study.orientation, study.weights);
    let _ = writeln!(
        s,
        "Cross-validation of '{name}' on {}:\n  {} poses (pose_id groups, {} rows), {} folds (seed {}), {}",
        set.source,
        study.n_groups,
        study.meas.len(),
        args.folds,
        args.seed,
        if orientation {
            "full poses"
        } else {
            "positions only"
        }
    );
    let effects = args
        .effects
        .iter()
        .fold(EffectSet::NONE, |a, i| a.with(i.effect));
    let eff_names: Vec<&str> = effects.iter().map(|e| e.name()).collect();
    let _ = writeln!(
        s,
        "Models: nominal = ROBOT geometry{}; calibrated = geometry ({}){}{}",
        if study.req_nom.is_empty() {
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
}

/// Prints the prior (and `--prior auto`'s search).
fn prior_text(
    s: &mut String,
    prior: Option<PriorSizes>,
    auto: bool,
    table: &[cv::AutoRow],
    orientation: bool,
) {
    let Some(p) = prior else {
        if auto {
            let _ = writeln!(
                s,
                "Prior (auto): none is within 2 % of the best held-out error"
            );
        }
        return;
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
    }
}

/// The largest change from nominal and the identifiability of the calibrated model.
fn changes_text<const N: usize>(s: &mut String, study: &cv::Study<N>, nominal: &Robot<N>) {
    let ((dl, pl), (da, pa)) = cv::largest_changes(&study.all.robot, nominal, &study.req_cal);
    let _ = writeln!(
        s,
        "Largest change from nominal (calibrated on all poses): |Δ length| {:.3} mm ({pl}), |Δ angle| {:.3}° ({pa}){}",
        dl * 1e3,
        da.to_degrees(),
        if study.prior.is_some() {
            let ((dl, pl), (da, pa)) =
                cv::largest_changes(&study.no_prior, nominal, &study.req_cal);
            format!(
                "; without the prior {:.3} mm ({pl}), {:.3}° ({pa})",
                dl * 1e3,
                da.to_degrees()
            )
        } else {
            String::new()
        }
    );
    if let Some(a) = &study.all.analysis {
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
}

/// The residual table (held-out and in-sample), the held-out ratio and the per-fold table.
fn residuals_text<const N: usize>(s: &mut String, study: &cv::Study<N>) {
    let orientation = study.orientation;
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
    let (s_nom, s_cal) = (&study.heldout_nominal, &study.heldout_calibrated);
    t.row(line("nominal, held-out", s_nom));
    t.row(line("calibrated, held-out", s_cal));
    t.row(line("nominal, in-sample", &study.insample_nominal));
    t.row(line("calibrated, in-sample", &study.insample_calibrated));
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
    for f in &study.folds {
        let keep = |i: usize| study.fold_of[i] == f.fold;
        let (a, b) = (
            cv::summarize(&study.meas, &study.held_nom, keep),
            cv::summarize(&study.meas, &study.held_cal, keep),
        );
        ft.row(vec![
            format!("{}", f.fold + 1),
            f.poses.to_string(),
            format!("{:.4}", a.rms_pos_m() * 1e3),
            format!("{:.4}", b.rms_pos_m() * 1e3),
            f.data_deficient.to_string(),
            f.algorithm.to_uppercase(),
        ]);
    }
    s.push_str("Per fold (RMS):\n");
    s.push_str(&ft.render("  "));
    s.push('\n');
}

/// The noise floor: the repeats' scatter, or the residuals' upper bound.
fn noise_text<const N: usize>(s: &mut String, study: &cv::Study<N>) {
    let orientation = study.orientation;
    match study.repeats {
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
        }
        Err(why) => {
            let (sig_p, sig_r) = (study.residual_sigma_pos_m, study.residual_sigma_rot_rad);
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
        }
    }
}

/// The outlier fit: its scales and the suspects, or why it failed.
fn outliers_text<const N: usize>(
    s: &mut String,
    study: &cv::Study<N>,
    set: &MeasurementSet,
    args: &Args,
) {
    let orientation = study.orientation;
    let report = &study.robust_report;
    match &study.robust {
        Ok(r) => {
            let suspects = study.suspects();
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
        }
        Err(e) => {
            let _ = writeln!(s, "Robust fit failed: {e} (no outlier test)");
        }
    }
}

/// The loss of the outlier fit on all poses: `--robust`'s, Cauchy by default.
fn outlier_loss(args: &Args) -> Loss {
    args.robust.map_or(Loss::Cauchy, Loss::from)
}

/// Cross-validation of contact data by whole groups (see [`kincal_io::crossval_contacts`]).
/// Why `--robust` is refused with instrument rows in several sessions.
pub(crate) const ROBUST_SESSIONS: &str = "--robust is not implemented for instrument rows in \
     several sessions (the robust fit has one base frame; each later session's frame is \
     fitted only by the plain fit): drop --robust, or give one session's instrument rows";

fn crossval_contacts<const N: usize>(
    nominal: &Robot<N>,
    args: &Args,
    set: &MeasurementSet,
    choice: &EffectChoice,
) -> Result<(), CliError> {
    if args.init_frames || args.plot.is_some() || args.robot_out.is_some() || args.prior.is_some() {
        return Err(CliError::usage(
            "--init-frames, --prior, --plot and --robot-out are not implemented for data with \
             target/plane rows",
        ));
    }
    if args.robust.is_some() && kincal_io::constraints::has_instrument_sessions(set) {
        return Err(CliError::usage(ROBUST_SESSIONS));
    }
    let cons = args
        .constraints
        .as_deref()
        .map(kincal_io::constraints::read_constraints)
        .transpose()?;
    let plan = ccv::Plan {
        group_by: args.group_by.unwrap_or(ccv::GroupBy::default_for(set)),
        folds: args.folds,
        seed: args.seed,
        requested: ccv::requested_params(nominal, &args.geometry, choice),
        weight_pos: ccv::weight_pos(args.sigma_pos_mm),
        max_iterations: args.max_iterations,
        constraints: cons.as_ref(),
        robust: args.robust.map(Loss::from),
    };
    let report = ccv::run(nominal, set, &plan)?;
    let (text, json) = (
        crate::commands::crossval_contacts::text(&report),
        ccv::json(&report),
    );
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
