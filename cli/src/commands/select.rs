//! `kincal select-poses`: observability-optimal poses (eq. 18), the workspace-clustering
//! design, or an optimal local design, written as a measurement-format pose file.

use std::fmt::Write as _;
use std::path::PathBuf;

use kincal::observability::{Index, Indices};
use kincal_io::design::context::{Context, SelectionSettings};
use kincal_io::design::pose_selection::{self as ps, PoseSelection, Search};
use kincal_io::measurements::write_poses_csv;
use kincal_io::robot_arg::resolve_robot;

use crate::commands::design::args::{RobotErrorArgs, SelectionArgs, SetupArgs};
use crate::error::CliError;

pub const LONG_ABOUT: &str = "\
Selects m calibration poses (eq. 18: maximise an observability index of the stacked,
unit-column-scaled identification Jacobian at the nominal model, subject to the joint limits).

--design standard    anywhere in the joint ranges with the end effector inside --workspace
                     (the whole workspace above the base plate), for an external instrument;
--design region      inside the working region (--region) with the approach axis within
                     --cone-deg of the working orientations, a joint margin (--margin-deg), a
                     distance from singularities (--min-dexterity) and reachable by
                     --robust-robots random robots of the scenario: poses a tool can hold;
--design clustering  the paper's workspace clustering: the region split into cubes of
                     --cube-mm, m poses of equal per-pose index (the six singular values of a
                     pose's Jacobian, within --tolerance) in mutually different cubes, the
                     best by the index among such.

Method: a candidate pool (--pool), then per start (--starts, in parallel) a greedy D-optimal
initial set, DETMAX exchanges on the chosen --index, and for the standard design a joint-space
refinement (--refine trials); the best start wins. Deterministic for a --seed.

Prints every index (O = eq. 17, O1 Borm–Menq, O2 inverse condition number, O3 σ_min, O4
noise amplification, O5 1/σ_max, A = 1/Σσ⁻¹, D = ln det JᵀJ) of the selection next to the
median and best of random m-pose sets from the same pool, and writes --out: pose_id, q1..qN
[rad], x, y, z [m], qw, qx, qy, qz of the nominal poses (usable as `evaluate-designs
--commanded`, or as a tool after design-tool's format).

The scenario's random robots (--length-error-mm, --angle-error-deg) serve the robust-reach
test only: select-poses simulates no measurement, so design-tool's and evaluate-designs'
noise and tool-tolerance flags (--noise-pos-mm, --noise-rot-deg, --tool-tol-mm,
--tool-tol-deg) do not apply and are refused (exit 2) rather than ignored.";

pub const EXAMPLE: &str = "\
Examples:
  kincal select-poses --design standard --out standard.csv
  kincal select-poses --design clustering --cube-mm 100 --out clustering.csv";

/// Which selection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Which {
    Standard,
    Region,
    Clustering,
}

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub setup: SetupArgs,
    #[command(flatten)]
    pub selection: SelectionArgs,
    #[command(flatten)]
    pub scenario: RobotErrorArgs,
    /// Which design
    #[arg(long, value_enum, default_value = "standard")]
    pub design: Which,
    /// Random m-pose sets from the same pool to compare with
    #[arg(long, default_value_t = 1000)]
    pub compare_random: usize,
    /// Output pose file (CSV)
    #[arg(long, value_name = "POSES.csv")]
    pub out: PathBuf,
}

impl Which {
    fn io(self) -> ps::Which {
        match self {
            Which::Standard => ps::Which::Standard,
            Which::Region => ps::Which::Region,
            Which::Clustering => ps::Which::Clustering,
        }
    }
}

pub fn run(args: &Args) -> Result<(), CliError> {
    let spec = resolve_robot(&args.setup.robot, &args.setup.chain)?;
    kincal::with_any_robot!(&spec.robot, r => select(*r, &spec.name, args))
}

fn fmt_index(i: Index, v: f64) -> String {
    match i {
        Index::DOpt => format!("{v:.3}"),
        _ => format!("{v:.4e}"),
    }
}

/// Table of every index: selection, median and best of the random sets.
pub fn index_table(sel: &Indices, random: &[Indices]) -> String {
    let mut t = crate::report::Table::new(&[
        "index",
        "selected",
        "random median",
        "random best",
        "selected / median",
    ]);
    let names = [
        (Index::O, "O (eq. 17) σmin/σmax"),
        (Index::O1, "O1 Borm–Menq"),
        (Index::O2, "O2 inverse condition"),
        (Index::O3, "O3 σmin"),
        (Index::O4, "O4 noise amplification"),
        (Index::O5, "O5 1/σmax"),
        (Index::AOpt, "A 1/Σσ⁻¹"),
        (Index::DOpt, "D ln det JᵀJ"),
    ];
    for (i, label) in names {
        let mut r: Vec<f64> = random.iter().map(|x| x.get(i)).collect();
        r.sort_by(f64::total_cmp);
        let (med, best) = if r.is_empty() {
            (f64::NAN, f64::NAN)
        } else {
            (r[r.len() / 2], r[r.len() - 1])
        };
        let v = sel.get(i);
        t.row(vec![
            label.to_string(),
            fmt_index(i, v),
            fmt_index(i, med),
            fmt_index(i, best),
            if i == Index::DOpt {
                format!("{:+.2}", v - med)
            } else {
                format!("{:.2}", v / med)
            },
        ]);
    }
    t.render("  ")
}

/// The search line: the exchange's counts, or the clustering's spread.
fn search_line(which: Which, search: &Search, settings: &SelectionSettings) -> String {
    match (which, search) {
        (Which::Standard, Search::Exchange(s)) => format!(
            "Exchange: {} evaluations, {} exchanges, {} refinements; {} from {:.4e} (greedy start) to {:.4e}\n",
            s.evaluations,
            s.exchanges,
            s.refinements,
            settings.index.name(),
            s.initial_value,
            s.value
        ),
        (_, Search::Exchange(s)) => format!(
            "Exchange: {} evaluations, {} exchanges; {} from {:.4e} to {:.4e}\n",
            s.evaluations,
            s.exchanges,
            settings.index.name(),
            s.initial_value,
            s.value
        ),
        (_, Search::Clustering(c)) => format!(
            "Clustering: spread of the per-pose index {:.3} (ln ratio; tolerance {}), {} occupied cubes\n",
            c.spread, settings.tolerance, c.occupied_cubes
        ),
    }
}

/// The report: the design, its search, the index table and the constraint check.
fn report<const N: usize>(
    ctx: &Context<N>,
    args: &Args,
    settings: &SelectionSettings,
    sel: &PoseSelection<N>,
) -> String {
    let mut head = String::new();
    let _ = writeln!(head, "Pose selection: {}", ctx.describe());
    let _ = writeln!(head, "{}", sel.design.note);
    head.push_str(&search_line(args.design, &sel.search, settings));
    let _ = writeln!(
        head,
        "\nIndices of the selection and of {} random {}-pose sets from the same pool ({} candidates):",
        sel.random.len(),
        settings.m,
        sel.pool_size
    );
    head.push_str(&index_table(&sel.indices, &sel.random));
    let _ = writeln!(
        head,
        "\nConstraints: {} of {} poses satisfy the constraints; smallest distance to a joint limit {:.1}°",
        sel.admitted,
        sel.design.q.len(),
        sel.min_margin_rad.to_degrees()
    );
    let _ = writeln!(head, "Wrote {}", args.out.display());
    head
}

fn select<const N: usize>(
    robot: kincal::Robot<N>,
    name: &str,
    args: &Args,
) -> Result<(), CliError> {
    let ctx = Context::new(robot, name, &args.setup.setup())?;
    let settings = args.selection.settings()?;
    let pb = crate::progress::counter(settings.pool as u64, "candidate pool");
    let sel = ps::select_poses(
        &ctx,
        &settings,
        args.design.io(),
        args.scenario.scenario(),
        args.compare_random,
        &crate::progress::Bar(&pb),
    )?;
    pb.finish_and_clear();
    let rows = ps::pose_rows(&sel.design);
    kincal_io::files::write_atomic(&args.out, &[], |w| write_poses_csv(w, N, true, &rows))?;
    crate::report::emit(&report(&ctx, args, &settings, &sel));
    Ok(())
}
