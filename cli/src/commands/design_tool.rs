//! `kincal design-tool`: an optimised calibration tool (beyond the paper): m reference poses
//! a workshop can make — on one plate height, from a few discrete orientations, a minimum
//! spacing apart, reachable with margin by robots with manufacturing errors — chosen to beat
//! a baseline tool (ARIA: Table 2) on the Monte-Carlo criterion.

use std::fmt::Write as _;
use std::path::PathBuf;

use kincal_io::design::context::Context;
use kincal_io::design::study::DesignResult;
use kincal_io::design::tool_design::{self as td, ToolDesign, ToolObjective, ToolOptions, score};
use kincal_io::robot_arg::resolve_robot;

use crate::commands::design::args::{DesignSizeArgs, ScenarioArgs, SetupArgs, finite};
use crate::commands::design::study;
use crate::error::CliError;

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
    fn io(self) -> ToolObjective {
        match self {
            ObjectiveArg::Pv => ToolObjective::Pv,
            ObjectiveArg::Pv01 => ToolObjective::Pv01,
            ObjectiveArg::O => ToolObjective::O,
            ObjectiveArg::Dopt => ToolObjective::Dopt,
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

    /// The `--objectives` name of an objective's label (the label itself if none matches).
    fn flag_of_label(label: &str) -> &str {
        [Self::Pv, Self::Pv01, Self::O, Self::Dopt]
            .into_iter()
            .find(|o| o.io().spec().0 == label)
            .map_or(label, |o| o.flag())
    }
}

impl Args {
    /// The search's options as kincal-io takes them.
    fn options(&self) -> ToolOptions {
        let sizes = &self.selection;
        ToolOptions {
            m: sizes.poses,
            starts: sizes.starts,
            min_dexterity: sizes.min_dexterity,
            robust_robots: sizes.robust_robots,
            plate_z_mm: self.plate_z_mm.clone(),
            grid_mm: self.grid_mm,
            rolls_deg: self.rolls_deg.clone(),
            yaws_deg: self.yaws_deg.clone(),
            min_separation_mm: self.min_separation_mm,
            objectives: self.objectives.iter().map(|o| o.io()).collect(),
            screen_runs: self.screen_runs,
            runs: self.runs,
            scenario: self.scenario.spec(),
        }
    }
}

pub fn run(args: &Args) -> Result<(), CliError> {
    args.options()
        .check(|flag| format!("--{}", flag.replace('_', "-")))?;
    let spec = resolve_robot(&args.setup.robot, &args.setup.chain)?;
    kincal::with_any_robot!(&spec.robot, r => design(*r, &spec.name, args))
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

/// The header: the setting and, per plate, its sockets and failed selections.
fn sockets_text<const N: usize>(ctx: &Context<N>, args: &Args, d: &ToolDesign<N>) -> String {
    let sizes = &args.selection;
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
    for p in &d.plates {
        let _ = writeln!(
            log,
            "  plate z = {:.0} mm: {} admissible sockets",
            p.z_m * 1e3,
            p.sockets
        );
        for (label, why) in &p.failures {
            let _ = writeln!(log, "    {label}: no selection ({why})");
        }
    }
    log
}

/// One row of the screening table.
fn screening_row(
    name: &str,
    z: &str,
    objective: &str,
    r: &DesignResult,
    score: String,
) -> Vec<String> {
    let (p, a) = (r.pos(), r.rot());
    vec![
        name.to_string(),
        z.to_string(),
        objective.to_string(),
        format!("{:.4}", r.o),
        format!("{:.3}", p.median),
        format!("{:.3}", p.p95),
        format!("{:.3}", a.median),
        format!("{:.3}", a.p95),
        r.failed.to_string(),
        score,
    ]
}

/// The screening: every candidate's score against the baseline, and the choice.
fn screening_text<const N: usize>(ctx: &Context<N>, args: &Args, d: &ToolDesign<N>) -> String {
    let mut log = String::new();
    let Some((base, rest)) = d.screening.split_first() else {
        return log;
    };
    let _ = writeln!(
        log,
        "\nScreening ({} runs each, seed {}; score = largest ratio to {} of median/p95 e_p, e_φ; objective as --objectives: {}):",
        args.screen_runs,
        ctx.seed.wrapping_add(1),
        base.name,
        args.objectives
            .iter()
            .map(|o| format!("{} = {}", o.flag(), o.io().spec().0))
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
    for (cand, r) in d.candidates.iter().zip(rest) {
        let s = score(r, base);
        let z = format!("{:.0}", cand.z_m * 1e3);
        t.row(screening_row(
            &cand.design.name,
            &z,
            ObjectiveArg::flag_of_label(&cand.objective),
            r,
            score_text(s, r),
        ));
    }
    t.row(screening_row(&base.name, "-", "baseline", base, "1".into()));
    log.push_str(&t.render("  "));
    if rest.iter().any(|r| !score(r, base).is_finite()) {
        let _ = writeln!(
            log,
            "  (score inf: the candidate failed in some runs (IK or identification), or had none; it is never chosen)"
        );
    }
    if let Some(chosen) = d.chosen() {
        let _ = writeln!(
            log,
            "\nChosen: {} ({}), screening score {:.3}",
            chosen.design.name, d.tool.note, d.score
        );
    }
    log
}

/// The final comparison and the verdict.
fn final_text<const N: usize>(ctx: &Context<N>, args: &Args, d: &ToolDesign<N>) -> String {
    let mut log = String::new();
    let [b, o] = d.results.as_slice() else {
        return log;
    };
    let _ = writeln!(
        log,
        "\nFinal comparison, {} runs on the same random robots (seed {}):",
        args.runs, ctx.seed
    );
    log.push_str(&study::table(&d.results));
    let _ = writeln!(
        log,
        "\nVerdict: the optimised tool {} {} on median and p95 of e_p and e_φ (e_p {:.3}/{:.3} mm vs {:.3}/{:.3} mm; e_φ {:.3}/{:.3}° vs {:.3}/{:.3}°)",
        if d.beats { "beats" } else { "does NOT beat" },
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
    let _ = writeln!(log, "Timing: {}", study::timing_line(&d.timing));
    log
}

/// `NAME=FILE` of --baseline.
fn baseline_arg(b: &str) -> Result<(&str, &std::path::Path), CliError> {
    b.split_once('=')
        .map(|(n, f)| (n, std::path::Path::new(f)))
        .ok_or_else(|| CliError::usage(format!("--baseline '{b}': expected NAME=FILE")))
}

fn design<const N: usize>(
    robot: kincal::Robot<N>,
    name: &str,
    args: &Args,
) -> Result<(), CliError> {
    let options = args.options();
    let ctx = Context::new(robot, name, &args.setup.setup())?;
    let given = args.baseline.as_deref().map(baseline_arg).transpose()?;
    let baseline = td::baseline(&ctx, given, "--baseline")?;
    let pb = crate::progress::counter(0, "tool candidates");
    let d = td::design_tool(&ctx, &baseline, &options, &crate::progress::Bar(&pb))?;
    pb.finish_and_clear();
    let mut log = sockets_text(&ctx, args, &d);
    log.push_str(&screening_text(&ctx, args, &d));
    log.push_str(&final_text(&ctx, args, &d));
    let comments = td::tool_comments(&ctx, &d, &options, args.setup.margin_deg);
    kincal_io::files::write_atomic(&args.out, &[], |w| {
        kincal_io::tool_file::write_tool(w, &comments, &d.tool.reference, &d.tool.q)
    })?;
    let _ = writeln!(log, "Wrote {}", args.out.display());
    if let (Some(pth), Some(b)) = (&args.plot, d.results.first()) {
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
            &d.results,
        )?;
    }
    if let Some(pth) = &args.json {
        let json = td::json(&ctx, &d);
        kincal_io::files::write_atomic(pth, &[], |w| {
            serde_json::to_writer_pretty(&mut *w, &json).map_err(std::io::Error::other)?;
            w.write_all(b"\n")
        })?;
    }
    crate::report::emit(&log);
    Ok(())
}
