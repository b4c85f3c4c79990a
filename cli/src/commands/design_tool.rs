//! `kincal design-tool`: an optimised calibration tool (beyond the paper): m reference poses
//! a workshop can make — on one plate height, from a few discrete orientations, a minimum
//! spacing apart, reachable with margin by robots with manufacturing errors — chosen to beat
//! a baseline tool (ARIA: Table 2) on the Monte-Carlo criterion.

use std::fmt::Write as _;
use std::path::PathBuf;

use kincal::montecarlo::{Acquisition, robustly_reachable};
use kincal::observability::{Index, ObservabilityOptions, PoseBlock, pose_block};
use kincal::pose::{Transform, rpy_to_matrix, transform};
use kincal::selection::{Constraints, Objective, SelectOptions};
use nalgebra::Vector3;
use rayon::prelude::*;

use crate::commands::design::args::{Context, DesignSizeArgs, P, ScenarioArgs, SetupArgs, finite};
use crate::commands::design::designs::{self, Design, OwnedPool};
use crate::commands::design::study::{self, DesignResult};
use crate::error::CliError;
use kincal_io::robot_arg::resolve_robot;

pub const LONG_ABOUT: &str = "\
Designs a calibration tool that beats a baseline tool (ARIA: the paper's Table 2) on the
Monte-Carlo criterion inside the working region, and writes it as a tool specification a
workshop can manufacture.

Implementable by construction: every reference pose lies on one plate height (--plate-z-mm,
one tool per height is tried), on a grid of --grid-mm in the region's x–y extent, with one of a
few orientations R = Rz(yaw)·Rx(roll) (--rolls-deg × --yaws-deg), at least
--min-separation-mm from the others (room for the sockets), within --margin-deg of no joint
limit, at least --min-dexterity from singularities, and reached within the limits by
--robust-robots random robots with the scenario's manufacturing errors.

Search: for every plate height and every objective (the I-optimal prediction variance over
the validation grid, with orientation rows weighted 1 and 0.1 m/rad, and the indices O and D),
DETMAX exchanges over the candidate sockets give one tool each. Each tool is screened against
the baseline with --screen-runs Monte-Carlo runs on robots of their own (seed + 1); the score
is the largest of the four ratios median/95th percentile of e_p/e_φ to the baseline's. The
best tool is then evaluated with --runs runs on the main seed's robots, the same robots as the
baseline, and written to --out: pose_id, x_mm, y_mm, z_mm, roll_deg, pitch_deg, yaw_deg and
the nominal configuration (extra_q*_rad), with the design assumptions as comments.

The candidates are the plate grid's sockets and the objectives --objectives, so the pose
selections' pool flags of select-poses and evaluate-designs (--index, --pool, --refine,
--workspace, --cube-mm, --tolerance) do not apply and are refused (exit 2) rather than
ignored.";

pub const EXAMPLE: &str = "\
Example:
  kincal design-tool --out tool.csv --plot tool-vs-table2.svg
  kincal evaluate-designs --tool optimised=tool.csv --runs 10000";

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub setup: SetupArgs,
    #[command(flatten)]
    pub scenario: ScenarioArgs,
    #[command(flatten)]
    pub selection: DesignSizeArgs,
    /// Plate heights to try [mm] (default: the region's bottom, middle and top)
    #[arg(long, value_parser = finite, value_delimiter = ',', value_name = "Z1,Z2,..")]
    pub plate_z_mm: Option<Vec<f64>>,
    /// Socket grid spacing on the plate [mm]
    #[arg(long, default_value_t = 25.0, value_parser = crate::args::positive)]
    pub grid_mm: f64,
    /// Roll angles of the orientations [deg]
    #[arg(long, default_value = "-150,-160", value_parser = finite, value_delimiter = ',', allow_hyphen_values = true)]
    pub rolls_deg: Vec<f64>,
    /// Yaw angles of the orientations [deg]
    #[arg(long, default_value = "-90,0,90,180", value_parser = finite, value_delimiter = ',', allow_hyphen_values = true)]
    pub yaws_deg: Vec<f64>,
    /// Smallest distance between two sockets [mm]
    #[arg(long, default_value_t = 60.0, value_parser = crate::args::non_negative)]
    pub min_separation_mm: f64,
    /// Objectives to try, comma-separated: pv (prediction variance over the validation
    /// grid, orientation rows weighted 1 m/rad), pv01 (weighted 0.1 m/rad), o (eq. 17), dopt
    #[arg(long, value_delimiter = ',', default_value = "pv,pv01,o,dopt")]
    pub objectives: Vec<ObjectiveArg>,
    /// The tool to beat, NAME=FILE.csv (ARIA default: the Table 2 tool)
    #[arg(long, value_name = "NAME=FILE")]
    pub baseline: Option<String>,
    /// Monte-Carlo runs per candidate tool in the screening
    #[arg(long, default_value_t = 1000)]
    pub screen_runs: u64,
    /// Monte-Carlo runs of the final comparison
    #[arg(long, default_value_t = 10000)]
    pub runs: u64,
    /// Output tool specification (CSV)
    #[arg(long, value_name = "TOOL.csv")]
    pub out: PathBuf,
    /// Write the comparison figure (SVG)
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
    /// Write the numbers (JSON)
    #[arg(long, value_name = "FILE.json")]
    pub json: Option<PathBuf>,
}

/// An objective of the tool search.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ObjectiveArg {
    Pv,
    Pv01,
    O,
    Dopt,
}

impl ObjectiveArg {
    /// (label, orientation-row weight [m/rad], objective).
    fn spec(self) -> (&'static str, f64, Objective) {
        match self {
            ObjectiveArg::Pv => (
                "prediction variance (w 1)",
                1.0,
                Objective::PredictionVariance,
            ),
            ObjectiveArg::Pv01 => (
                "prediction variance (w 0.1)",
                0.1,
                Objective::PredictionVariance,
            ),
            ObjectiveArg::O => ("O (eq. 17)", 1.0, Objective::Index(Index::O)),
            ObjectiveArg::Dopt => ("D-optimal", 1.0, Objective::Index(Index::DOpt)),
        }
    }

    /// The `--objectives` name: the screening table's short column.
    fn flag(self) -> &'static str {
        match self {
            ObjectiveArg::Pv => "pv",
            ObjectiveArg::Pv01 => "pv01",
            ObjectiveArg::O => "o",
            ObjectiveArg::Dopt => "dopt",
        }
    }
}

pub fn run(args: &Args) -> Result<(), CliError> {
    if args.objectives.is_empty() {
        return Err(CliError::usage("--objectives: expected at least one"));
    }
    if args.runs == 0 || args.screen_runs == 0 {
        return Err(CliError::usage(
            "--runs and --screen-runs: expected at least 1",
        ));
    }
    if args.rolls_deg.is_empty() || args.yaws_deg.is_empty() {
        return Err(CliError::usage(
            "--rolls-deg and --yaws-deg: expected at least one angle",
        ));
    }
    let spec = resolve_robot(&args.setup.robot, &args.setup.chain)?;
    kincal::with_any_robot!(&spec.robot, r => design(*r, &spec.name, args))
}

/// Candidate sockets of one plate: admissible, robustly reachable configurations.
fn plate_candidates<const N: usize>(
    ctx: &Context<N>,
    args: &Args,
    z: f64,
    c: &Constraints,
    robots: u64,
    pb: &indicatif::ProgressBar,
) -> Result<(Vec<[f64; N]>, Vec<Transform>), CliError> {
    let r = ctx.region;
    let step = args.grid_mm * 1e-3;
    let nx = ((r.max_m[0] - r.min_m[0]) / step + 1e-9).floor() as usize + 1;
    let ny = ((r.max_m[1] - r.min_m[1]) / step + 1e-9).floor() as usize + 1;
    let mut targets = Vec::new();
    for ix in 0..nx {
        for iy in 0..ny {
            let p = Vector3::new(
                r.min_m[0] + ix as f64 * step,
                r.min_m[1] + iy as f64 * step,
                z,
            );
            for &roll in &args.rolls_deg {
                for &yaw in &args.yaws_deg {
                    targets.push(transform(
                        rpy_to_matrix(roll.to_radians(), 0.0, yaw.to_radians()),
                        p,
                    ));
                }
            }
        }
    }
    pb.set_length(targets.len() as u64);
    pb.set_position(0);
    let study = ctx.study(args.scenario.scenario(), ctx.seed);
    type Found<const N: usize> = Result<Option<([f64; N], Transform)>, kincal::Error>;
    let found: Vec<Found<N>> = targets
        .par_iter()
        .map(|t| {
            pb.inc(1);
            let Some(q) = ctx.quick_ik(t, c) else {
                return Ok(None);
            };
            if robots > 0 && !robustly_reachable(&study, t, &q, robots)? {
                return Ok(None);
            }
            Ok(Some((q, *t)))
        })
        .collect();
    let mut q = Vec::new();
    let mut poses = Vec::new();
    for f in found {
        if let Some((a, b)) = f.map_err(|e| CliError::numeric(format!("tool candidates: {e}")))? {
            q.push(a);
            poses.push(b);
        }
    }
    Ok((q, poses))
}

/// `[median, p95]` of e_p and e_φ against the baseline: the largest ratio (< 1 beats it on
/// all four); infinite with failed runs.
fn score(r: &DesignResult, base: &DesignResult) -> f64 {
    if r.failed > 0 || r.max_pos_mm.is_empty() {
        return f64::INFINITY;
    }
    let (p, a, bp, ba) = (r.pos(), r.rot(), base.pos(), base.rot());
    [
        p.median / bp.median,
        p.p95 / bp.p95,
        a.median / ba.median,
        a.p95 / ba.p95,
    ]
    .into_iter()
    .fold(0.0, f64::max)
}

/// The score as printed: an infinite one says why (failed runs are disqualifying).
fn score_text(s: f64, r: &DesignResult) -> String {
    if s.is_finite() {
        format!("{s:.3}")
    } else if r.failed > 0 {
        format!("inf ({} failed)", r.failed)
    } else if r.max_pos_mm.is_empty() {
        "inf (no runs)".into()
    } else {
        "inf (baseline error 0)".into()
    }
}

struct Candidate<const N: usize> {
    design: Design<N>,
    z: f64,
    objective: String,
    /// `objective`'s `--objectives` name (the screening table's column).
    objective_flag: &'static str,
}

fn design<const N: usize>(
    robot: kincal::Robot<N>,
    name: &str,
    args: &Args,
) -> Result<(), CliError> {
    let ctx = Context::new(robot, name, &args.setup)?;
    let sizes = &args.selection;
    let m = sizes.m()?;
    let scenario = args.scenario.scenario();
    let baseline = match (&args.baseline, ctx.is_aria) {
        (Some(b), _) => {
            let (n, f) = b
                .split_once('=')
                .ok_or_else(|| CliError::usage(format!("--baseline '{b}': expected NAME=FILE")))?;
            designs::tool_from_file(&ctx, n, std::path::Path::new(f))?
        }
        (None, true) => designs::table2_design(&ctx)?,
        (None, false) => {
            return Err(CliError::usage(format!(
                "robot '{name}' has no built-in tool to beat: give --baseline NAME=FILE.csv"
            )));
        }
    };
    let heights: Vec<f64> = match &args.plate_z_mm {
        Some(v) => v.iter().map(|z| z * 1e-3).collect(),
        None => {
            let r = ctx.region;
            vec![r.min_m[2], 0.5 * (r.min_m[2] + r.max_m[2]), r.max_m[2]]
        }
    };
    for &z in &heights {
        if z < ctx.region.min_m[2] - 1e-12 || z > ctx.region.max_m[2] + 1e-12 {
            return Err(CliError::usage(format!(
                "--plate-z-mm {}: outside the working region's z range",
                z * 1e3
            )));
        }
    }
    let c = Constraints {
        region: Some(ctx.region),
        cone: None,
        joint_margin_rad: ctx.margin_rad,
        min_dexterity: sizes.min_dexterity,
    };
    let mut log = String::new();
    let _ = writeln!(log, "Tool design: {}", ctx.describe());
    let _ = writeln!(log, "Scenario: {}", args.scenario.describe());
    let _ = writeln!(
        log,
        "Sockets: grid {} mm, rolls {:?}°, yaws {:?}°, separation ≥ {} mm, joint margin {}°, dexterity ≥ {}, reached by {} random robots",
        args.grid_mm,
        args.rolls_deg,
        args.yaws_deg,
        args.min_separation_mm,
        args.setup.margin_deg,
        sizes.min_dexterity,
        sizes.robust_robots
    );
    let objectives: Vec<(&str, f64, Objective, &'static str)> = args
        .objectives
        .iter()
        .map(|o| {
            let (label, w, objective) = o.spec();
            (label, w, objective, o.flag())
        })
        .collect();
    let pb = crate::progress::counter(0, "tool candidates");
    let mut candidates: Vec<Candidate<N>> = Vec::new();
    for &z in &heights {
        pb.set_message(format!("sockets on the plate at z = {:.0} mm", z * 1e3));
        let (q, poses) = plate_candidates(&ctx, args, z, &c, sizes.robust_robots, &pb)?;
        let _ = writeln!(
            log,
            "  plate z = {:.0} mm: {} admissible sockets",
            z * 1e3,
            q.len()
        );
        if q.len() < m {
            continue;
        }
        for &(label, w, objective, flag) in &objectives {
            pb.set_message(format!("z = {:.0} mm: selecting by {label}", z * 1e3));
            let mut obs = ObservabilityOptions::new(ctx.params);
            obs.rot_weight = w;
            let pool = OwnedPool::new(&ctx, &obs, q.clone())?;
            let reference: Vec<PoseBlock<P>> = {
                let mut ws = Box::<kincal::identify::Workspace<P>>::default();
                ctx.validation_q
                    .iter()
                    .map(|vq| {
                        let mut b = [[0.0; P]; 6];
                        pose_block(&ctx.robot, vq, &obs, &mut ws, &mut b).map(|_| b)
                    })
                    .collect::<Result<_, _>>()
                    .map_err(|e| CliError::numeric(format!("validation blocks: {e}")))?
            };
            let mut opts = SelectOptions::new(objective, ctx.seed);
            opts.starts = sizes.starts.max(1);
            opts.refine_trials = 0;
            opts.min_separation_m = args.min_separation_mm * 1e-3;
            let sel = designs::select_best(
                &ctx,
                &pool,
                m,
                &obs,
                &c,
                &opts,
                Some(&reference),
                &indicatif::ProgressBar::hidden(),
            );
            let Ok((sq, _)) = sel else {
                let _ = writeln!(
                    log,
                    "    {label}: no selection ({})",
                    sel.err().map_or(String::new(), |e| e.message)
                );
                continue;
            };
            let reference_poses: Vec<Transform> = sq
                .iter()
                .map(|qq| {
                    let i = pool.q.iter().position(|p| p == qq).unwrap_or(0);
                    poses[i]
                })
                .collect();
            candidates.push(Candidate {
                design: Design {
                    name: format!("z{:.0}-{}", z * 1e3, candidates.len() + 1),
                    acquisition: Acquisition::Tool,
                    q: sq,
                    reference: reference_poses,
                    note: String::new(),
                },
                z,
                objective: label.to_string(),
                objective_flag: flag,
            });
        }
    }
    pb.finish_and_clear();
    if candidates.is_empty() {
        return Err(CliError::numeric(
            "no candidate tool: too few admissible sockets (loosen --grid-mm, --min-dexterity, --margin-deg or --min-separation-mm)",
        ));
    }
    // Screening on robots of their own.
    let mut screen: Vec<Design<N>> = vec![baseline.clone()];
    screen.extend(candidates.iter().map(|c| c.design.clone()));
    let (sres, _) = study::run_study(
        &ctx,
        &screen,
        scenario,
        args.screen_runs,
        ctx.seed.wrapping_add(1),
        "screening candidate tools",
    )?;
    let _ = writeln!(
        log,
        "\nScreening ({} runs each, seed {}; score = largest ratio to {} of median/p95 e_p, e_φ; objective as --objectives: {}):",
        args.screen_runs,
        ctx.seed.wrapping_add(1),
        baseline.name,
        args.objectives
            .iter()
            .map(|o| format!("{} = {}", o.flag(), o.spec().0))
            .collect::<Vec<_>>()
            .join(", ")
    );
    // Headers on two lines and the objective by its flag name: the table fits 100 columns
    // (issue #19; the full names are in the heading above).
    let mut t = crate::report::Table::new(&[
        "tool",
        "plate z\n[mm]",
        "objective",
        "O\n(eq. 17)",
        "e_p med\n[mm]",
        "e_p p95\n[mm]",
        "e_φ med\n[deg]",
        "e_φ p95\n[deg]",
        "failed",
        "score",
    ]);
    let base = &sres[0];
    let mut best: Option<(f64, usize)> = None;
    for (k, (cand, r)) in candidates.iter().zip(&sres[1..]).enumerate() {
        let s = score(r, base);
        if best.is_none_or(|(b, _)| s < b) {
            best = Some((s, k));
        }
        let (p, a) = (r.pos(), r.rot());
        t.row(vec![
            cand.design.name.clone(),
            format!("{:.0}", cand.z * 1e3),
            cand.objective_flag.to_string(),
            format!("{:.4}", r.o),
            format!("{:.3}", p.median),
            format!("{:.3}", p.p95),
            format!("{:.3}", a.median),
            format!("{:.3}", a.p95),
            r.failed.to_string(),
            score_text(s, r),
        ]);
    }
    let (p, a) = (base.pos(), base.rot());
    t.row(vec![
        base.name.clone(),
        "-".into(),
        "baseline".into(),
        format!("{:.4}", base.o),
        format!("{:.3}", p.median),
        format!("{:.3}", p.p95),
        format!("{:.3}", a.median),
        format!("{:.3}", a.p95),
        base.failed.to_string(),
        "1".into(),
    ]);
    log.push_str(&t.render("  "));
    if candidates
        .iter()
        .zip(&sres[1..])
        .any(|(_, r)| !score(r, base).is_finite())
    {
        let _ = writeln!(
            log,
            "  (score inf: the candidate failed in some runs (IK or identification), or had none; it is never chosen)"
        );
    }
    let Some((best_score, k)) = best else {
        return Err(CliError::numeric("no candidate tool"));
    };
    let chosen = &candidates[k];
    let mut tool = chosen.design.clone();
    tool.name = "optimised".into();
    tool.note = format!(
        "optimised tool: plate z = {:.0} mm, {} sockets chosen by {}",
        chosen.z * 1e3,
        tool.q.len(),
        chosen.objective
    );
    let _ = writeln!(
        log,
        "\nChosen: {} ({}), screening score {best_score:.3}",
        chosen.design.name, tool.note
    );
    // Final comparison on the main seed's robots.
    let (fres, timing) = study::run_study(
        &ctx,
        &[baseline.clone(), tool.clone()],
        scenario,
        args.runs,
        ctx.seed,
        "final comparison",
    )?;
    let _ = writeln!(
        log,
        "\nFinal comparison, {} runs on the same random robots (seed {}):",
        args.runs, ctx.seed
    );
    log.push_str(&study::table(&fres));
    let (b, o) = (&fres[0], &fres[1]);
    let beats = o.failed == 0
        && o.pos().median < b.pos().median
        && o.pos().p95 < b.pos().p95
        && o.rot().median < b.rot().median
        && o.rot().p95 < b.rot().p95;
    let _ = writeln!(
        log,
        "\nVerdict: the optimised tool {} {} on median and p95 of e_p and e_φ (e_p {:.3}/{:.3} mm vs {:.3}/{:.3} mm; e_φ {:.3}/{:.3}° vs {:.3}/{:.3}°)",
        if beats { "beats" } else { "does NOT beat" },
        b.name,
        o.pos().median,
        o.pos().p95,
        b.pos().median,
        b.pos().p95,
        o.rot().median,
        o.rot().p95,
        b.rot().median,
        b.rot().p95
    );
    let _ = writeln!(log, "Timing: {}", study::timing_line(&timing));
    // Tool specification.
    let mut comments = vec![
        "kincal calibration-tool specification (design-tool)".to_string(),
        format!("robot: {}", ctx.robot_name),
        format!(
            "plate height z = {:.1} mm in the robot base frame; R = Rz(yaw)·Ry(pitch)·Rx(roll)",
            chosen.z * 1e3
        ),
        format!(
            "sockets at least {} mm apart; joint margin {}°; reached by {} random robots (±{} mm, ±{}°)",
            args.min_separation_mm,
            args.setup.margin_deg,
            sizes.robust_robots,
            args.scenario.errors.length_error_mm,
            args.scenario.errors.angle_error_deg
        ),
        format!("chosen by {}; seed {}", chosen.objective, ctx.seed),
        format!(
            "Monte-Carlo ({} runs, {}): worst validation pose e_p median {:.3} mm, p95 {:.3} mm; e_phi median {:.3} deg, p95 {:.3} deg ({}: {:.3}, {:.3} mm; {:.3}, {:.3} deg)",
            args.runs,
            args.scenario.describe(),
            o.pos().median,
            o.pos().p95,
            o.rot().median,
            o.rot().p95,
            b.name,
            b.pos().median,
            b.pos().p95,
            b.rot().median,
            b.rot().p95
        ),
        "extra_q*_rad: the nominal robot's configuration at each pose (for programming the approach)".into(),
    ];
    comments.retain(|c| !c.is_empty());
    kincal_io::files::write_atomic(&args.out, &[], |w| {
        kincal_io::tool_file::write_tool(w, &comments, &tool.reference, &tool.q)
    })?;
    let _ = writeln!(log, "Wrote {}", args.out.display());
    if let Some(pth) = &args.plot {
        crate::plots::study::write_comparison(
            pth,
            &[],
            &format!("Optimised calibration tool vs {}", b.name),
            &format!(
                "{} runs on the same random robots, seed {}; {}",
                args.runs,
                ctx.seed,
                args.scenario.describe()
            ),
            &fres,
        )?;
    }
    if let Some(pth) = &args.json {
        let json = serde_json::json!({
            "robot": ctx.robot_name,
            "seed": ctx.seed,
            "plate_z_m": chosen.z,
            "objective": chosen.objective,
            "screening_score": best_score,
            "beats_baseline": beats,
            "designs": study::results_json(&fres),
        });
        kincal_io::files::write_atomic(pth, &[], |w| {
            serde_json::to_writer_pretty(&mut *w, &json).map_err(std::io::Error::other)?;
            w.write_all(b"\n")
        })?;
    }
    crate::report::emit(&log);
    Ok(())
}
