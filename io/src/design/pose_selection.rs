//! The pose selection of `kincal select-poses` and `kincal.select_poses`: an
//! observability-optimal design (standard or in the working region) or the workspace
//! clustering, its indices next to random m-pose sets from the same pool, its constraint
//! check, and its rows in the measurement format.

use kincal::observability::Indices;
use kincal::selection::{ClusterSelection, Constraints, Selection};

use crate::design::Progress;
use crate::design::context::{Context, SelectionSettings};
use crate::design::designs::{self, Design};
use crate::error::Error;
use crate::measurements::PoseRow;

/// Which selection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Which {
    /// Anywhere in the joint ranges with the end effector inside the workspace box.
    Standard,
    /// Inside the working region, within the cone, robustly reachable.
    Region,
    /// The paper's workspace clustering.
    Clustering,
}

impl Which {
    /// By name: `standard`, `region` or `clustering`.
    pub fn parse(s: &str) -> Option<Which> {
        match s {
            "standard" => Some(Which::Standard),
            "region" => Some(Which::Region),
            "clustering" => Some(Which::Clustering),
            _ => None,
        }
    }
}

/// How the search went.
#[derive(Debug, Clone, Copy)]
pub enum Search {
    /// The exchange of the standard and region designs.
    Exchange(Selection),
    /// The workspace clustering.
    Clustering(ClusterSelection),
}

/// A selection with what a report says about it.
#[derive(Debug, Clone)]
pub struct PoseSelection<const N: usize> {
    pub design: Design<N>,
    pub search: Search,
    /// Candidates in the pool.
    pub pool_size: usize,
    /// Every index of the selection.
    pub indices: Indices,
    /// Every index of each random m-pose set from the same pool.
    pub random: Vec<Indices>,
    /// Poses satisfying the design's constraints (joint margin, region, cone).
    pub admitted: usize,
    /// Smallest distance of a selected joint value to its limit [rad].
    pub min_margin_rad: f64,
}

/// Selects `settings.m` poses by `which`; `compare_random` random m-pose sets of the pool
/// are scored beside it. The robust-reach test of the local designs uses `ctx`'s robots
/// with the `robot_errors` scenario (see [`crate::design::context::ScenarioSpec::robot_errors`]).
pub fn select_poses<const N: usize>(
    ctx: &Context<N>,
    settings: &SelectionSettings,
    which: Which,
    robot_errors: kincal::montecarlo::Scenario,
    compare_random: usize,
    pb: &dyn Progress,
) -> Result<PoseSelection<N>, Error> {
    let study = ctx.study(robot_errors, ctx.seed);
    pb.stage(settings.pool as u64, "candidate pool");
    let (design, pool, search, constraints) = match which {
        Which::Standard => {
            let (d, s, p) = designs::standard_design(ctx, settings, pb)?;
            let c = Constraints {
                region: Some(settings.workspace),
                cone: None,
                joint_margin_rad: ctx.margin_rad,
                min_dexterity: 0.0,
            };
            (d, p, Search::Exchange(s), c)
        }
        Which::Region => {
            let (d, s, p) = designs::region_design(ctx, settings, &study, pb)?;
            let c = ctx.local_constraints(settings.min_dexterity);
            (d, p, Search::Exchange(s), c)
        }
        Which::Clustering => {
            let (d, s, p) = designs::clustering_design(ctx, settings, &study, pb)?;
            let c = ctx.local_constraints(settings.min_dexterity);
            (d, p, Search::Clustering(s), c)
        }
    };
    let indices = design.indices(ctx)?;
    let random = designs::random_subsets(ctx, &pool, settings.m, compare_random, ctx.seed ^ 0xAB)?;
    let (admitted, min_margin_rad) = constraint_check(ctx, &design, &constraints);
    Ok(PoseSelection {
        design,
        search,
        pool_size: pool.q.len(),
        indices,
        random,
        admitted,
        min_margin_rad,
    })
}

/// Poses of `d` satisfying `c`, and the smallest distance to a joint limit [rad].
fn constraint_check<const N: usize>(
    ctx: &Context<N>,
    d: &Design<N>,
    c: &Constraints,
) -> (usize, f64) {
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
    (ok, min_margin)
}

/// The design's nominal poses as rows of a pose file (`pose_id` 1, 2, …).
pub fn pose_rows<const N: usize>(design: &Design<N>) -> Vec<PoseRow> {
    design
        .q
        .iter()
        .zip(&design.reference)
        .enumerate()
        .map(|(l, (q, t))| PoseRow {
            pose_id: Some((l + 1).to_string()),
            q_rad: q.to_vec(),
            position_m: [t.translation.x, t.translation.y, t.translation.z],
            quaternion_wxyz: crate::tool_file::quaternion(t),
        })
        .collect()
}
