//! `kincal evaluate-designs`: Monte-Carlo comparison of data-acquisition designs (Section
//! 4.4, Fig. 7) on the same random robots.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use kincal::montecarlo::Acquisition;

use crate::commands::design::args::{Context, ScenarioArgs, SelectionArgs, SetupArgs};
use crate::commands::design::designs::{self, Design};
use crate::commands::design::study::{self, DesignResult, Timing};
use crate::error::CliError;
use kincal_io::robot_arg::resolve_robot;

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
    for p in &args.plates {
        crate::commands::design::plate::parse_plate(p)?;
    }
    if args.plate_plot.is_some() && args.plates.is_empty() {
        return Err(CliError::usage("--plate-plot: give at least one --plate"));
    }
    let spec = resolve_robot(&args.setup.robot, &args.setup.chain)?;
    kincal::with_any_robot!(&spec.robot, r => evaluate(*r, &spec.name, args))
}

/// Builds the requested designs (built-in ones from the seed, then the files).
pub fn build_designs<const N: usize>(
    ctx: &Context<N>,
    builtin: &[BuiltIn],
    tools: &[String],
    commanded: &[String],
    sel: &SelectionArgs,
    scenario: &ScenarioArgs,
    log: &mut String,
) -> Result<Vec<Design<N>>, CliError> {
    let settings = sel.settings()?;
    // Arguments first: a typo should not wait for the built-in designs.
    let tools: Vec<(String, PathBuf)> = tools
        .iter()
        .map(|t| named(t, "--tool"))
        .collect::<Result<_, _>>()?;
    let commanded: Vec<(String, PathBuf)> = commanded
        .iter()
        .map(|c| named(c, "--commanded"))
        .collect::<Result<_, _>>()?;
    let mut from_files = Vec::new();
    for (name, path) in &tools {
        from_files.push(designs::tool_from_file(ctx, name, path)?);
    }
    for (name, path) in &commanded {
        from_files.push(designs::commanded_from_file(ctx, name, path)?);
    }
    let mut out = Vec::new();
    for b in builtin {
        let d = match b {
            BuiltIn::Standard => {
                let pb = crate::progress::counter(
                    settings.pool as u64,
                    "standard design: sampling the workspace",
                );
                let (d, s, _) = designs::standard_design(ctx, &settings, &pb)?;
                pb.finish_and_clear();
                let _ = writeln!(
                    log,
                    "  standard: {} = {:.4} ({} evaluations, {} exchanges, {} refinements)",
                    settings.index.name(),
                    s.value,
                    s.evaluations,
                    s.exchanges,
                    s.refinements
                );
                d
            }
            BuiltIn::Clustering => {
                let pb = crate::progress::counter(
                    settings.pool as u64,
                    "clustering design: robust poses of the working region",
                );
                let study = ctx.study(scenario.scenario(), ctx.seed);
                let (d, c, _) = designs::clustering_design(ctx, &settings, &study, &pb)?;
                pb.finish_and_clear();
                let _ = writeln!(
                    log,
                    "  clustering: spread {:.3} (ln ratio), {} = {:.4}, {} occupied cubes",
                    c.spread,
                    settings.index.name(),
                    c.value,
                    c.occupied_cubes
                );
                d
            }
            BuiltIn::Table2 => designs::table2_design(ctx)?,
        };
        out.push(d);
    }
    out.extend(from_files);
    let mut names: Vec<&str> = out.iter().map(|d| d.name.as_str()).collect();
    names.sort_unstable();
    if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
        return Err(CliError::usage(format!("two designs are named '{}'", w[0])));
    }
    if out.is_empty() {
        return Err(CliError::usage("no design to evaluate"));
    }
    Ok(out)
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

fn evaluate<const N: usize>(
    robot: kincal::Robot<N>,
    name: &str,
    args: &Args,
) -> Result<(), CliError> {
    let ctx = Context::new(robot, name, &args.setup)?;
    let mut log = String::new();
    let designs = build_designs(
        &ctx,
        &args.designs,
        &args.tools,
        &args.commanded,
        &args.selection,
        &args.scenario,
        &mut log,
    )?;
    let robust = args.selection.settings()?.robust_robots;
    let probe = ctx.study(args.scenario.scenario(), ctx.seed);
    // Robustly reachable contacts take a while for large plates: a bar per plate.
    let pb = crate::progress::counter(
        args.plates.len() as u64,
        "socket plates: robustly reachable contacts",
    );
    let plates = args
        .plates
        .iter()
        .map(|p| {
            let plate = crate::commands::design::plate::build_plate(
                &ctx,
                &crate::commands::design::plate::parse_plate(p)?,
                &probe,
                robust,
            );
            pb.inc(1);
            plate
        })
        .collect::<Result<Vec<_>, _>>()?;
    pb.finish_and_clear();
    for (i, p) in plates.iter().enumerate() {
        let name = &p.spec.name;
        let clash = designs.iter().any(|d| &d.name == name)
            || plates[..i].iter().any(|o| &o.spec.name == name);
        if clash {
            return Err(CliError::usage(format!(
                "--plate: two designs are named '{name}'"
            )));
        }
    }
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
    let (results, timing) = study::run_study(
        &ctx,
        &designs,
        args.scenario.scenario(),
        args.runs,
        ctx.seed,
        "Monte-Carlo",
    )?;
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
        let (rows, wall_s) = crate::commands::design::plate::compare(
            &ctx,
            &designs,
            &plates,
            args.scenario.scenario(),
            args.runs,
        )?;
        let reference = args.plate_match.clone().unwrap_or_else(|| {
            if designs.iter().any(|d| d.name == "optimised") {
                "optimised".into()
            } else {
                "table2".into()
            }
        });
        let _ = writeln!(
            out,
            "\nSocket plates vs the designs above, on the same {} robots: worst validation pose per run, absolute (base frame) and registered (after the best rigid base registration):",
            args.runs
        );
        out.push_str(&crate::commands::design::plate::table(&rows));
        let _ = writeln!(out, "\nPlate verdicts:");
        out.push_str(&crate::commands::design::plate::verdicts(&rows, &reference));
        let _ = writeln!(
            out,
            "  ({} calibrations in {wall_s:.2} s)",
            rows.len() as u64 * args.runs
        );
        Some(rows)
    };
    crate::report::emit(&out);
    let inputs: Vec<&Path> = Vec::new();
    if let (Some(p), Some(rows)) = (&args.plate_plot, &plate_rows) {
        crate::commands::design::plate::write_plot(
            p,
            &inputs,
            &format!(
                "{} runs per design, seed {}; {}",
                args.runs,
                ctx.seed,
                args.scenario.describe()
            ),
            rows,
        )?;
    }
    if let Some(p) = &args.plot {
        crate::plots::study::write_comparison(
            p,
            &inputs,
            "Design comparison: errors after calibration inside the working region",
            &format!(
                "{} runs per design, seed {}; {}",
                args.runs,
                ctx.seed,
                args.scenario.describe()
            ),
            &results,
        )?;
    }
    if let Some(p) = &args.json {
        let mut json = report_json(&ctx, args, &results, &timing);
        if let Some(rows) = &plate_rows {
            json["plates"] = crate::commands::design::plate::json(rows);
        }
        kincal_io::files::write_atomic(p, &inputs, |w| {
            serde_json::to_writer_pretty(&mut *w, &json).map_err(std::io::Error::other)?;
            w.write_all(b"\n")
        })?;
    }
    Ok(())
}

fn report_json<const N: usize>(
    ctx: &Context<N>,
    args: &Args,
    results: &[DesignResult],
    t: &Timing,
) -> serde_json::Value {
    let s = args.scenario.scenario();
    serde_json::json!({
        "robot": ctx.robot_name,
        "seed": ctx.seed,
        "runs": args.runs,
        "validation_poses": ctx.validation_q.len(),
        "scenario": {
            "length_error_m": s.length_error_m, "angle_error_rad": s.angle_error_rad,
            "noise_pos_m": s.noise_pos_m, "noise_rot_rad": s.noise_rot_rad,
            "tool_tol_pos_m": s.tool_tol_pos_m, "tool_tol_rot_rad": s.tool_tol_rot_rad,
        },
        "designs": study::results_json(results),
        // Run times and the thread count are on the screen only (the Timing line): the
        // file is byte-for-byte reproducible whatever the machine.
        "calibrations": t.calibrations,
    })
}
