//! `kincal evaluate-designs`: Monte-Carlo comparison of data-acquisition designs (Section
//! 4.4, Fig. 7) on the same random robots.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use kincal::montecarlo::Acquisition;
use kincal_io::design::context::{Context, SelectionSettings};
use kincal_io::design::designs::Design;
use kincal_io::design::evaluation::{self as ev, Built, DesignChoice};
use kincal_io::design::plate::{self as io_plate, Plate, PlateSpec};
use kincal_io::design::pose_selection::Search;
use kincal_io::design::study::{self as io_study, DesignResult};
use kincal_io::robot_arg::resolve_robot;

use crate::commands::design::args::{ScenarioArgs, SelectionArgs, SetupArgs};
use crate::commands::design::{plate, study};
use crate::error::CliError;

pub const LONG_ABOUT: &str = "\
Monte-Carlo evaluation of data-acquisition designs (the paper's Section 4.4 and Fig. 7, as a
distribution over many robots instead of one).

Each run draws a random true robot (every identified parameter off by a uniform error up to
--length-error-mm / --angle-error-deg, the paper's 5 mm and 5°), simulates the design's
measurements on it, identifies the parameters from the nominal model (OLS), and measures the
identified model's errors e_p, e_φ against the true robot over the validation grid inside the
working region; the run's result is its worst grid pose. Run k of every design uses the same
robot k (and the same noise draws per pose index), so designs are compared on the same robots.

How a design is measured:
  instrument  commanded configurations, the pose measured by motion capture / a tracker with
              noise --noise-pos-mm, --noise-rot-deg (1σ per axis);
  tool        the end effector mated with the reference poses of a calibration tool: the
              physical pose is the drawing's plus a manufacturing error (uniform, ±--tool-tol-mm,
              ±--tool-tol-deg per axis, fixed per run) and seating noise (as above); the
              readings come from the true robot's inverse kinematics; the identification uses
              the drawing's poses.

Designs (--designs): standard = whole-workspace, observability-optimal, instrument-measured;
clustering = workspace clustering in the working region (poses of equal per-pose index in
mutually different cubes of --cube-mm), used as a tool; table2 = the paper's calibration
tool. Add tools with --tool NAME=FILE.csv (e.g. from design-tool) and instrument-measured
configurations with --commanded NAME=FILE.csv (e.g. from select-poses).

Socket plates (--plate NAME=D_MM,PLACEMENTS,CONTACTS, instrument-free: two ball sockets at
unknown positions, one known distance, the plate placed several times) are compared with the
designs above on the same robots, each scored absolute (base frame) and registered (after
the best rigid base registration, the only figure a plate can give): a second table, which
plates match --plate-match (registered e_p median and p95), and --plate-plot.

Prints a table (median, 95th percentile and maximum over the runs of the worst-pose errors),
the ordering and the paper's targets (1 mm, 0.66°) as verdicts, and the timing; --plot writes
the comparison figure (SVG), --json the numbers (no run times: the file is byte-for-byte
reproducible). Reproducible from --seed, in parallel (set
RAYON_NUM_THREADS to choose the thread count; results do not depend on it).";

pub const EXAMPLE: &str = "\
Examples:
  kincal evaluate-designs --runs 10000 --plot fig7.svg
  kincal evaluate-designs --designs table2 --tool mine=tool.csv --runs 10000";

/// A built-in design.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BuiltIn {
    Standard,
    Clustering,
    Table2,
}

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub setup: SetupArgs,
    #[command(flatten)]
    pub scenario: ScenarioArgs,
    #[command(flatten)]
    pub selection: SelectionArgs,
    /// Built-in designs, comma-separated (standard, clustering, table2)
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "standard,clustering,table2"
    )]
    pub designs: Vec<BuiltIn>,
    /// A calibration tool file to evaluate, as NAME=FILE.csv (repeatable)
    #[arg(long = "tool", value_name = "NAME=FILE")]
    pub tools: Vec<String>,
    /// Commanded configurations measured by an instrument, as NAME=FILE.csv (a measurement
    /// CSV; only q1..qN are used; repeatable)
    #[arg(long = "commanded", value_name = "NAME=FILE")]
    pub commanded: Vec<String>,
    /// A socket plate to compare with the tools (instrument-free: two sockets D_MM apart at
    /// unknown positions, PLACEMENTS placements, CONTACTS contacts in all), as
    /// NAME=D_MM,PLACEMENTS,CONTACTS (repeatable; see docs/socket-plate.md)
    #[arg(long = "plate", value_name = "NAME=D_MM,PLACEMENTS,CONTACTS")]
    pub plates: Vec<String>,
    /// The design the plates must match (registered e_p median and p95) [default: optimised
    /// if given, else table2]
    #[arg(long, value_name = "NAME")]
    pub plate_match: Option<String>,
    /// Write the plate comparison figure (SVG; with --plate)
    #[arg(long, value_name = "FILE.svg")]
    pub plate_plot: Option<PathBuf>,
    /// Monte-Carlo runs per design
    #[arg(long, default_value_t = 10000)]
    pub runs: u64,
    /// Write the comparison figure (SVG)
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
    /// Write the numbers (JSON)
    #[arg(long, value_name = "FILE.json")]
    pub json: Option<PathBuf>,
}

impl BuiltIn {
    fn io(self) -> ev::BuiltIn {
        match self {
            BuiltIn::Standard => ev::BuiltIn::Standard,
            BuiltIn::Clustering => ev::BuiltIn::Clustering,
            BuiltIn::Table2 => ev::BuiltIn::Table2,
        }
    }
}

fn named(arg: &str, flag: &str) -> Result<(String, PathBuf), CliError> {
    match arg.split_once('=') {
        Some((n, f)) if !n.trim().is_empty() && !f.is_empty() => {
            Ok((n.trim().to_string(), PathBuf::from(f)))
        }
        _ => Err(CliError::usage(format!(
            "{flag} '{arg}': expected NAME=FILE"
        ))),
    }
}

pub fn run(args: &Args) -> Result<(), CliError> {
    if args.runs == 0 {
        return Err(CliError::usage("--runs: expected at least 1"));
    }
    for t in &args.tools {
        named(t, "--tool")?;
    }
    for c in &args.commanded {
        named(c, "--commanded")?;
    }
    let plates = parse_plates(args)?;
    if args.plate_plot.is_some() && args.plates.is_empty() {
        return Err(CliError::usage("--plate-plot: give at least one --plate"));
    }
    let spec = resolve_robot(&args.setup.robot, &args.setup.chain)?;
    kincal::with_any_robot!(&spec.robot, r => evaluate(*r, &spec.name, args, &plates))
}

fn parse_plates(args: &Args) -> Result<Vec<PlateSpec>, CliError> {
    args.plates
        .iter()
        .map(|p| io_plate::parse_plate(p))
        .collect()
}

/// The designs of the arguments (built-in ones from the seed, then the files), and the
/// lines saying how the selected ones were found.
pub fn build_designs<const N: usize>(
    ctx: &Context<N>,
    args: &Args,
    settings: &SelectionSettings,
    log: &mut String,
) -> Result<Vec<Design<N>>, CliError> {
    // Arguments first: a typo should not wait for the built-in designs.
    let choice = DesignChoice {
        builtin: args.designs.iter().map(|b| b.io()).collect(),
        tools: args
            .tools
            .iter()
            .map(|t| named(t, "--tool"))
            .collect::<Result<_, _>>()?,
        commanded: args
            .commanded
            .iter()
            .map(|c| named(c, "--commanded"))
            .collect::<Result<_, _>>()?,
    };
    let pb = crate::progress::counter(settings.pool as u64, "designs");
    let built = ev::build_designs(
        ctx,
        &choice,
        settings,
        &args.scenario.spec(),
        &crate::progress::Bar(&pb),
    );
    pb.finish_and_clear();
    let built = built?;
    for b in &built {
        search_line(b, settings, log);
    }
    Ok(built.into_iter().map(|b| b.design).collect())
}

/// How a selected design was found (nothing for the others).
fn search_line<const N: usize>(b: &Built<N>, settings: &SelectionSettings, log: &mut String) {
    match &b.search {
        Some(Search::Exchange(s)) => {
            let _ = writeln!(
                log,
                "  standard: {} = {:.4} ({} evaluations, {} exchanges, {} refinements)",
                settings.index.name(),
                s.value,
                s.evaluations,
                s.exchanges,
                s.refinements
            );
        }
        Some(Search::Clustering(c)) => {
            let _ = writeln!(
                log,
                "  clustering: spread {:.3} (ln ratio), {} = {:.4}, {} occupied cubes",
                c.spread,
                settings.index.name(),
                c.value,
                c.occupied_cubes
            );
        }
        None => {}
    }
}

fn verdicts(results: &[DesignResult]) -> String {
    let mut s = String::new();
    let get = |n: &str| results.iter().find(|r| r.name == n);
    if let (Some(std), locals) = (
        get("standard"),
        results
            .iter()
            .filter(|r| r.name != "standard" && r.acquisition == Acquisition::Tool)
            .collect::<Vec<_>>(),
    ) {
        for l in locals {
            let (a, b) = (std.pos(), l.pos());
            let (c, d) = (std.rot(), l.rot());
            let smaller =
                a.median < b.median && a.p95 < b.p95 && c.median < d.median && c.p95 < d.p95;
            let _ = writeln!(
                s,
                "  whole-workspace data vs {}: median and p95 of e_p and e_φ {} ({:.3}/{:.3} mm vs {:.3}/{:.3} mm)",
                l.name,
                if smaller {
                    "smaller"
                } else {
                    "NOT all smaller"
                },
                a.median,
                a.p95,
                b.median,
                b.p95
            );
        }
    }
    for r in results {
        let (p, a) = (r.pos(), r.rot());
        let _ = writeln!(
            s,
            "  {}: 95 % of the runs have every validation pose within {:.3} mm and {:.3}° ({} 1 mm / 0.66°); worst run {:.3} mm, {:.3}°{}",
            r.name,
            p.p95,
            a.p95,
            if p.p95 < 1.0 && a.p95 < 0.66 {
                "inside"
            } else {
                "NOT inside"
            },
            p.max,
            a.max,
            if r.failed > 0 {
                format!(
                    "; {} runs failed ({})",
                    r.failed,
                    r.first_failure.as_deref().unwrap_or("")
                )
            } else {
                String::new()
            }
        );
    }
    s
}

/// The socket plates of the arguments, their names distinct from the designs'.
fn build_plates<const N: usize>(
    ctx: &Context<N>,
    args: &Args,
    specs: &[PlateSpec],
    designs: &[Design<N>],
    robust: u64,
) -> Result<Vec<Plate<N>>, CliError> {
    let pb = crate::progress::counter(
        specs.len() as u64,
        "socket plates: robustly reachable contacts",
    );
    let plates = io_plate::build_plates(
        ctx,
        specs,
        designs,
        (args.scenario.scenario(), robust),
        "--plate",
        &crate::progress::Bar(&pb),
    );
    pb.finish_and_clear();
    plates
}

/// The plates' comparison with the designs, appended to `out`.
fn compare_plates<const N: usize>(
    ctx: &Context<N>,
    args: &Args,
    designs: &[Design<N>],
    plates: &[Plate<N>],
    out: &mut String,
) -> Result<Vec<io_plate::Row>, CliError> {
    let total = args.runs * (designs.len() + plates.len()) as u64;
    let pb = crate::progress::counter(total, "plate comparison: calibrations");
    let done = io_plate::compare(
        ctx,
        designs,
        plates,
        args.scenario.scenario(),
        args.runs,
        &crate::progress::Bar(&pb),
    );
    pb.finish_and_clear();
    let io_plate::Comparison { rows, wall_s } = done?;
    let reference = args
        .plate_match
        .clone()
        .unwrap_or_else(|| io_plate::default_reference(designs));
    let _ = writeln!(
        out,
        "\nSocket plates vs the designs above, on the same {} robots: worst validation pose per run, absolute (base frame) and registered (after the best rigid base registration):",
        args.runs
    );
    out.push_str(&plate::table(&rows));
    let _ = writeln!(out, "\nPlate verdicts:");
    out.push_str(&plate::verdicts(&rows, &reference));
    let _ = writeln!(
        out,
        "  ({} calibrations in {wall_s:.2} s)",
        rows.len() as u64 * args.runs
    );
    Ok(rows)
}

fn evaluate<const N: usize>(
    robot: kincal::Robot<N>,
    name: &str,
    args: &Args,
    plate_specs: &[PlateSpec],
) -> Result<(), CliError> {
    let ctx = Context::new(robot, name, &args.setup.setup())?;
    let settings = args.selection.settings()?;
    let mut log = String::new();
    let designs = build_designs(&ctx, args, &settings, &mut log)?;
    let plates = build_plates(&ctx, args, plate_specs, &designs, settings.robust_robots)?;
    let mut out = String::new();
    let _ = writeln!(out, "Design evaluation: {}", ctx.describe());
    let _ = writeln!(out, "Scenario: {}", args.scenario.describe());
    let _ = writeln!(out, "Designs:");
    for d in &designs {
        let _ = writeln!(out, "  {}: {}", d.name, d.note);
    }
    for p in &plates {
        let _ = writeln!(out, "  {}: {}", p.spec.name, p.note);
    }
    out.push_str(&log);
    let pb = crate::progress::calibrations(args.runs * designs.len() as u64, "Monte-Carlo");
    let (results, timing) = io_study::run_study(
        &ctx,
        &designs,
        args.scenario.scenario(),
        args.runs,
        ctx.seed,
        "Monte-Carlo",
        &crate::progress::Bar(&pb),
    )?;
    pb.finish_and_clear();
    let _ = writeln!(
        out,
        "\nWorst validation pose per run, over {} runs per design (same robots for every design):",
        args.runs
    );
    out.push_str(&study::table(&results));
    let _ = writeln!(out, "\nVerdicts:");
    out.push_str(&verdicts(&results));
    let _ = writeln!(out, "\nTiming: {}", study::timing_line(&timing));
    let plate_rows = if plates.is_empty() {
        None
    } else {
        Some(compare_plates(&ctx, args, &designs, &plates, &mut out)?)
    };
    crate::report::emit(&out);
    let inputs: Vec<&Path> = Vec::new();
    let subtitle = format!(
        "{} runs per design, seed {}; {}",
        args.runs,
        ctx.seed,
        args.scenario.describe()
    );
    if let (Some(p), Some(rows)) = (&args.plate_plot, &plate_rows) {
        plate::write_plot(p, &inputs, &subtitle, rows)?;
    }
    if let Some(p) = &args.plot {
        crate::plots::study::write_comparison(
            p,
            &inputs,
            "Design comparison: errors after calibration inside the working region",
            &subtitle,
            &results,
        )?;
    }
    if let Some(p) = &args.json {
        let json = ev::json(
            &ctx,
            args.runs,
            &args.scenario.spec(),
            &results,
            &timing,
            plate_rows.as_deref(),
        );
        kincal_io::files::write_atomic(p, &inputs, |w| {
            serde_json::to_writer_pretty(&mut *w, &json).map_err(std::io::Error::other)?;
            w.write_all(b"\n")
        })?;
    }
    Ok(())
}
