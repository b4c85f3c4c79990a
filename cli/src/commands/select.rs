//! `kincal select-poses`: observability-optimal poses (eq. 18), the workspace-clustering
//! design, or an optimal local design, written as a measurement-format pose file.

use std::fmt::Write as _;
use std::path::PathBuf;

use kincal::observability::{Index, Indices};
use kincal::selection::Constraints;

use crate::commands::design::args::{Context, RobotErrorArgs, SelectionArgs, SetupArgs};
use crate::commands::design::designs::{self, Design, OwnedPool};
use crate::error::CliError;
use kincal_io::measurements::{PoseRow, write_poses_csv};
use kincal_io::robot_arg::resolve_robot;

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

/// Constraint check of a design: joint margin, region and cone (local designs).
fn constraint_report<const N: usize>(ctx: &Context<N>, d: &Design<N>, c: &Constraints) -> String {
    let mut min_margin = f64::INFINITY;
    let mut ok = 0;
    for q in &d.q {
        for (v, l) in q.iter().zip(ctx.robot.limits().iter()) {
            min_margin = min_margin.min((v - l.lower).min(l.upper - v));
        }
        if c.admits(&ctx.robot, q).unwrap_or(false) {
            ok += 1;
        }
    }
    format!(
        "{ok} of {} poses satisfy the constraints; smallest distance to a joint limit {:.1}°",
        d.q.len(),
        min_margin.to_degrees()
    )
}

fn select<const N: usize>(
    robot: kincal::Robot<N>,
    name: &str,
    args: &Args,
) -> Result<(), CliError> {
    let ctx = Context::new(robot, name, &args.setup)?;
    let settings = args.selection.settings()?;
    let study = ctx.study(args.scenario.scenario(), ctx.seed);
    let pb = crate::progress::counter(settings.pool as u64, "candidate pool");
    let mut out = String::new();
    let (design, pool, constraints): (Design<N>, OwnedPool<N>, Constraints) = match args.design {
        Which::Standard => {
            let (d, s, p) = designs::standard_design(&ctx, &settings, &pb)?;
            let _ = writeln!(
                out,
                "Exchange: {} evaluations, {} exchanges, {} refinements; {} from {:.4e} (greedy start) to {:.4e}",
                s.evaluations,
                s.exchanges,
                s.refinements,
                settings.index.name(),
                s.initial_value,
                s.value
            );
            let c = Constraints {
                region: Some(settings.workspace),
                cone: None,
                joint_margin_rad: ctx.margin_rad,
                min_dexterity: 0.0,
            };
            (d, p, c)
        }
        Which::Region => {
            let (d, s, p) = designs::region_design(&ctx, &settings, &study, &pb)?;
            let _ = writeln!(
                out,
                "Exchange: {} evaluations, {} exchanges; {} from {:.4e} to {:.4e}",
                s.evaluations,
                s.exchanges,
                settings.index.name(),
                s.initial_value,
                s.value
            );
            (d, p, ctx.local_constraints(settings.min_dexterity))
        }
        Which::Clustering => {
            let (d, c, p) = designs::clustering_design(&ctx, &settings, &study, &pb)?;
            let _ = writeln!(
                out,
                "Clustering: spread of the per-pose index {:.3} (ln ratio; tolerance {}), {} occupied cubes",
                c.spread, settings.tolerance, c.occupied_cubes
            );
            (d, p, ctx.local_constraints(settings.min_dexterity))
        }
    };
    pb.finish_and_clear();
    let sel = design.indices(&ctx)?;
    let random = designs::random_subsets(
        &ctx,
        &pool,
        settings.m,
        args.compare_random,
        ctx.seed ^ 0xAB,
    )?;
    let mut head = String::new();
    let _ = writeln!(head, "Pose selection: {}", ctx.describe());
    let _ = writeln!(head, "{}", design.note);
    head.push_str(&out);
    let _ = writeln!(
        head,
        "\nIndices of the selection and of {} random {}-pose sets from the same pool ({} candidates):",
        random.len(),
        settings.m,
        pool.q.len()
    );
    head.push_str(&index_table(&sel, &random));
    let _ = writeln!(
        head,
        "\nConstraints: {}",
        constraint_report(&ctx, &design, &constraints)
    );
    let _ = writeln!(head, "Wrote {}", args.out.display());
    let rows: Vec<PoseRow> = design
        .q
        .iter()
        .zip(&design.reference)
        .enumerate()
        .map(|(l, (q, t))| PoseRow {
            pose_id: Some((l + 1).to_string()),
            q_rad: q.to_vec(),
            position_m: [t.translation.x, t.translation.y, t.translation.z],
            quaternion_wxyz: kincal_io::tool_file::quaternion(t),
        })
        .collect();
    kincal_io::files::write_atomic(&args.out, &[], |w| write_poses_csv(w, N, true, &rows))?;
    crate::report::emit(&head);
    Ok(())
}
