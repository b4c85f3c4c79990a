//! The calibration-tool search of `kincal design-tool` and `kincal.design_tool`: m reference
//! poses a workshop can make (one plate height, a few discrete orientations, a minimum
//! spacing, reachable with margin by robots with manufacturing errors), chosen to beat a
//! baseline tool (ARIA: Table 2) on the Monte-Carlo criterion. The result is data: the
//! sockets per plate, the screened candidates, the final comparison, the tool file's
//! comments and the `--json` document.

use kincal::montecarlo::{Acquisition, robustly_reachable};
use kincal::observability::{Index, ObservabilityOptions, PoseBlock, pose_block};
use kincal::pose::{Transform, rpy_to_matrix, transform};
use kincal::selection::{Constraints, Objective, SelectOptions};
use nalgebra::Vector3;
use rayon::prelude::*;

use crate::design::context::{Context, P, ScenarioSpec, pose_count};
use crate::design::designs::{self, Design, OwnedPool};
use crate::design::study::{self, DesignResult, Timing};
use crate::design::{Progress, Silent};
use crate::error::Error;

/// An objective of the tool search.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ToolObjective {
    /// Prediction variance over the validation grid, orientation rows weighted 1 m/rad.
    Pv,
    /// … weighted 0.1 m/rad.
    Pv01,
    /// The index O (eq. 17).
    O,
    /// D-optimality.
    Dopt,
}

impl ToolObjective {
    /// By name: `pv`, `pv01`, `o`, `dopt`.
    pub fn parse(s: &str) -> Option<ToolObjective> {
        match s {
            "pv" => Some(ToolObjective::Pv),
            "pv01" => Some(ToolObjective::Pv01),
            "o" => Some(ToolObjective::O),
            "dopt" => Some(ToolObjective::Dopt),
            _ => None,
        }
    }
    /// (label, orientation-row weight [m/rad], objective).
    pub fn spec(self) -> (&'static str, f64, Objective) {
        match self {
            ToolObjective::Pv => (
                "prediction variance (w 1)",
                1.0,
                Objective::PredictionVariance,
            ),
            ToolObjective::Pv01 => (
                "prediction variance (w 0.1)",
                0.1,
                Objective::PredictionVariance,
            ),
            ToolObjective::O => ("O (eq. 17)", 1.0, Objective::Index(Index::O)),
            ToolObjective::Dopt => ("D-optimal", 1.0, Objective::Index(Index::DOpt)),
        }
    }
}

/// What the search may build and how hard it looks.
#[derive(Debug, Clone)]
pub struct ToolOptions {
    /// Reference poses of the tool.
    pub m: usize,
    /// Exchange starts per plate and objective.
    pub starts: usize,
    /// Smallest singular value of the joint Jacobian at a socket.
    pub min_dexterity: f64,
    /// Random robots that must all reach each socket (0: no test).
    pub robust_robots: u64,
    /// Plate heights [mm] (`None`: the region's bottom, middle and top).
    pub plate_z_mm: Option<Vec<f64>>,
    /// Socket grid spacing on the plate [mm].
    pub grid_mm: f64,
    /// Roll angles of the orientations [deg].
    pub rolls_deg: Vec<f64>,
    /// Yaw angles of the orientations [deg].
    pub yaws_deg: Vec<f64>,
    /// Smallest distance between two sockets [mm].
    pub min_separation_mm: f64,
    pub objectives: Vec<ToolObjective>,
    /// Monte-Carlo runs per candidate in the screening.
    pub screen_runs: u64,
    /// Monte-Carlo runs of the final comparison.
    pub runs: u64,
    pub scenario: ScenarioSpec,
}

impl ToolOptions {
    /// Refuses options that cannot give a tool; `flag` names a field (`runs`, …) as the
    /// front end calls it (e.g. `--runs`).
    pub fn check(&self, flag: impl Fn(&str) -> String) -> Result<(), Error> {
        if self.objectives.is_empty() {
            return Err(Error::usage(format!(
                "{}: expected at least one",
                flag("objectives")
            )));
        }
        if self.runs == 0 || self.screen_runs == 0 {
            return Err(Error::usage(format!(
                "{} and {}: expected at least 1",
                flag("runs"),
                flag("screen_runs")
            )));
        }
        if self.rolls_deg.is_empty() || self.yaws_deg.is_empty() {
            return Err(Error::usage(format!(
                "{} and {}: expected at least one angle",
                flag("rolls_deg"),
                flag("yaws_deg")
            )));
        }
        pose_count(self.m, &flag("poses"))?;
        Ok(())
    }
}

/// The sockets of one plate height and the objectives that gave no tool there.
#[derive(Debug, Clone)]
pub struct PlateSockets {
    pub z_m: f64,
    /// Admissible, robustly reachable sockets.
    pub sockets: usize,
    /// (objective label, why) of each selection that failed.
    pub failures: Vec<(String, String)>,
}

/// A candidate tool of the search.
#[derive(Debug, Clone)]
pub struct Candidate<const N: usize> {
    pub design: Design<N>,
    /// Its plate height [m].
    pub z_m: f64,
    /// The objective's label.
    pub objective: String,
}

/// The outcome of the search.
#[derive(Debug, Clone)]
pub struct ToolDesign<const N: usize> {
    pub plates: Vec<PlateSockets>,
    pub candidates: Vec<Candidate<N>>,
    /// Screening results: the baseline first, then each candidate (robots of seed + 1).
    pub screening: Vec<DesignResult>,
    /// Index into `candidates` of the chosen one, and its screening score.
    pub chosen: usize,
    pub score: f64,
    /// The chosen tool, named `optimised`.
    pub tool: Design<N>,
    /// Final comparison on the main seed's robots: `[baseline, tool]`.
    pub results: Vec<DesignResult>,
    pub timing: Timing,
    /// Whether the tool beats the baseline on median and p95 of e_p and e_φ.
    pub beats: bool,
}

impl<const N: usize> ToolDesign<N> {
    /// The chosen candidate.
    pub fn chosen(&self) -> Option<&Candidate<N>> {
        self.candidates.get(self.chosen)
    }
}

/// The tool to beat: `NAME=FILE` when given, else the Table 2 tool of the built-in ARIA.
pub fn baseline<const N: usize>(
    ctx: &Context<N>,
    given: Option<(&str, &std::path::Path)>,
    flag: &str,
) -> Result<Design<N>, Error> {
    match (given, ctx.is_aria) {
        (Some((n, f)), _) => designs::tool_from_file(ctx, n, f),
        (None, true) => designs::table2_design(ctx),
        (None, false) => Err(Error::usage(format!(
            "robot '{}' has no built-in tool to beat: give {flag} NAME=FILE.csv",
            ctx.robot_name
        ))),
    }
}

/// The plate heights [m] to try (`given_mm` in mm), each inside the working region's z
/// range.
pub fn plate_heights<const N: usize>(
    ctx: &Context<N>,
    given_mm: Option<&[f64]>,
    flag: &str,
) -> Result<Vec<f64>, Error> {
    let r = ctx.region;
    let heights = match given_mm {
        Some(v) => v.iter().map(|z| z * 1e-3).collect(),
        None => vec![r.min_m[2], 0.5 * (r.min_m[2] + r.max_m[2]), r.max_m[2]],
    };
    for &z in &heights {
        if z < r.min_m[2] - 1e-12 || z > r.max_m[2] + 1e-12 {
            return Err(Error::usage(format!(
                "{flag} {}: outside the working region's z range",
                z * 1e3
            )));
        }
    }
    Ok(heights)
}

/// The socket constraints: region, joint margin and dexterity (no cone: the orientations
/// are the plate's).
fn socket_constraints<const N: usize>(ctx: &Context<N>, o: &ToolOptions) -> Constraints {
    Constraints {
        region: Some(ctx.region),
        cone: None,
        joint_margin_rad: ctx.margin_rad,
        min_dexterity: o.min_dexterity,
    }
}

/// Candidate sockets of one plate: admissible, robustly reachable configurations.
fn plate_candidates<const N: usize>(
    ctx: &Context<N>,
    o: &ToolOptions,
    z: f64,
    c: &Constraints,
    pb: &dyn Progress,
) -> Result<(Vec<[f64; N]>, Vec<Transform>), Error> {
    let r = ctx.region;
    let step = o.grid_mm * 1e-3;
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
            for &roll in &o.rolls_deg {
                for &yaw in &o.yaws_deg {
                    targets.push(transform(
                        rpy_to_matrix(roll.to_radians(), 0.0, yaw.to_radians()),
                        p,
                    ));
                }
            }
        }
    }
    pb.stage(
        targets.len() as u64,
        &format!("sockets on the plate at z = {:.0} mm", z * 1e3),
    );
    let study = ctx.study(o.scenario.scenario(), ctx.seed);
    let robots = o.robust_robots;
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
        if let Some((a, b)) = f.map_err(|e| Error::numeric(format!("tool candidates: {e}")))? {
            q.push(a);
            poses.push(b);
        }
    }
    Ok((q, poses))
}

/// The identification blocks of the validation poses (the prediction-variance objective's
/// reference).
fn validation_blocks<const N: usize>(
    ctx: &Context<N>,
    obs: &ObservabilityOptions,
) -> Result<Vec<PoseBlock<P>>, Error> {
    let mut ws = Box::<kincal::identify::Workspace<P>>::default();
    ctx.validation_q
        .iter()
        .map(|vq| {
            let mut b = [[0.0; P]; 6];
            pose_block(&ctx.robot, vq, obs, &mut ws, &mut b).map(|_| b)
        })
        .collect::<Result<_, _>>()
        .map_err(|e| Error::numeric(format!("validation blocks: {e}")))
}

/// One candidate per objective from the sockets `q` (poses `poses`) of the plate at `z`;
/// failed selections are recorded in `plate`.
fn plate_tools<const N: usize>(
    ctx: &Context<N>,
    o: &ToolOptions,
    c: &Constraints,
    (z, q, poses): (f64, &[[f64; N]], &[Transform]),
    plate: &mut PlateSockets,
    candidates: &mut Vec<Candidate<N>>,
    pb: &dyn Progress,
) -> Result<(), Error> {
    for (label, w, objective) in o.objectives.iter().map(|x| x.spec()) {
        pb.message(&format!("z = {:.0} mm: selecting by {label}", z * 1e3));
        let mut obs = ObservabilityOptions::new(ctx.params);
        obs.rot_weight = w;
        let pool = OwnedPool::new(ctx, &obs, q.to_vec())?;
        let reference = validation_blocks(ctx, &obs)?;
        let mut opts = SelectOptions::new(objective, ctx.seed);
        opts.starts = o.starts.max(1);
        opts.refine_trials = 0;
        opts.min_separation_m = o.min_separation_mm * 1e-3;
        let sel = designs::select_best(ctx, &pool, o.m, &obs, c, &opts, Some(&reference), &Silent);
        let sq = match sel {
            Ok((sq, _)) => sq,
            Err(e) => {
                plate.failures.push((label.to_string(), e.message));
                continue;
            }
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
            z_m: z,
            objective: label.to_string(),
        });
    }
    Ok(())
}

/// Every candidate tool: per plate height, one per objective.
fn candidate_tools<const N: usize>(
    ctx: &Context<N>,
    o: &ToolOptions,
    heights: &[f64],
    pb: &dyn Progress,
) -> Result<(Vec<PlateSockets>, Vec<Candidate<N>>), Error> {
    let c = socket_constraints(ctx, o);
    let mut plates = Vec::new();
    let mut candidates = Vec::new();
    for &z in heights {
        let (q, poses) = plate_candidates(ctx, o, z, &c, pb)?;
        let mut plate = PlateSockets {
            z_m: z,
            sockets: q.len(),
            failures: Vec::new(),
        };
        if q.len() >= o.m {
            plate_tools(ctx, o, &c, (z, &q, &poses), &mut plate, &mut candidates, pb)?;
        }
        plates.push(plate);
    }
    if candidates.is_empty() {
        return Err(Error::numeric(
            "no candidate tool: too few admissible sockets (loosen --grid-mm, --min-dexterity, --margin-deg or --min-separation-mm)",
        ));
    }
    Ok((plates, candidates))
}

/// `[median, p95]` of e_p and e_φ against the baseline: the largest ratio (< 1 beats it on
/// all four); infinite with failed runs.
pub fn score(r: &DesignResult, base: &DesignResult) -> f64 {
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

/// Whether `o` beats `b` on median and p95 of e_p and e_φ without a failed run.
fn beats(o: &DesignResult, b: &DesignResult) -> bool {
    o.failed == 0
        && o.pos().median < b.pos().median
        && o.pos().p95 < b.pos().p95
        && o.rot().median < b.rot().median
        && o.rot().p95 < b.rot().p95
}

/// Searches the tool: candidates per plate and objective, screened against `baseline` with
/// `screen_runs` runs on robots of seed + 1, the best (lowest [`score`]) compared with it
/// in `runs` runs on the main seed's robots.
pub fn design_tool<const N: usize>(
    ctx: &Context<N>,
    baseline: &Design<N>,
    o: &ToolOptions,
    pb: &dyn Progress,
) -> Result<ToolDesign<N>, Error> {
    let heights = plate_heights(ctx, o.plate_z_mm.as_deref(), "--plate-z-mm")?;
    let (plates, candidates) = candidate_tools(ctx, o, &heights, pb)?;
    let scenario = o.scenario.scenario();
    let mut screen: Vec<Design<N>> = vec![baseline.clone()];
    screen.extend(candidates.iter().map(|c| c.design.clone()));
    let (screening, _) = study::run_study(
        ctx,
        &screen,
        scenario,
        o.screen_runs,
        ctx.seed.wrapping_add(1),
        "screening candidate tools",
        pb,
    )?;
    let (base, rest) = screening
        .split_first()
        .ok_or_else(|| Error::numeric("no candidate tool"))?;
    let mut best: Option<(f64, usize)> = None;
    for (k, r) in rest.iter().enumerate() {
        let s = score(r, base);
        if best.is_none_or(|(b, _)| s < b) {
            best = Some((s, k));
        }
    }
    let Some((best_score, k)) = best else {
        return Err(Error::numeric("no candidate tool"));
    };
    let chosen = &candidates[k];
    let mut tool = chosen.design.clone();
    tool.name = "optimised".into();
    tool.note = format!(
        "optimised tool: plate z = {:.0} mm, {} sockets chosen by {}",
        chosen.z_m * 1e3,
        tool.q.len(),
        chosen.objective
    );
    let (results, timing) = study::run_study(
        ctx,
        &[baseline.clone(), tool.clone()],
        scenario,
        o.runs,
        ctx.seed,
        "final comparison",
        pb,
    )?;
    let beats = match results.as_slice() {
        [b, t] => beats(t, b),
        _ => false,
    };
    Ok(ToolDesign {
        plates,
        candidates,
        screening,
        chosen: k,
        score: best_score,
        tool,
        results,
        timing,
        beats,
    })
}

/// The comment lines of the tool specification file (design assumptions and the final
/// comparison); `margin_deg` is the joint margin as the user gave it.
pub fn tool_comments<const N: usize>(
    ctx: &Context<N>,
    d: &ToolDesign<N>,
    o: &ToolOptions,
    margin_deg: f64,
) -> Vec<String> {
    let (Some(chosen), [b, t]) = (d.chosen(), d.results.as_slice()) else {
        return Vec::new();
    };
    vec![
        "kincal calibration-tool specification (design-tool)".to_string(),
        format!("robot: {}", ctx.robot_name),
        format!(
            "plate height z = {:.1} mm in the robot base frame; R = Rz(yaw)·Ry(pitch)·Rx(roll)",
            chosen.z_m * 1e3
        ),
        format!(
            "sockets at least {} mm apart; joint margin {}°; reached by {} random robots (±{} mm, ±{}°)",
            o.min_separation_mm,
            margin_deg,
            o.robust_robots,
            o.scenario.length_error_mm,
            o.scenario.angle_error_deg
        ),
        format!("chosen by {}; seed {}", chosen.objective, ctx.seed),
        format!(
            "Monte-Carlo ({} runs, {}): worst validation pose e_p median {:.3} mm, p95 {:.3} mm; e_phi median {:.3} deg, p95 {:.3} deg ({}: {:.3}, {:.3} mm; {:.3}, {:.3} deg)",
            o.runs,
            o.scenario.describe(),
            t.pos().median,
            t.pos().p95,
            t.rot().median,
            t.rot().p95,
            b.name,
            b.pos().median,
            b.pos().p95,
            b.rot().median,
            b.rot().p95
        ),
        "extra_q*_rad: the nominal robot's configuration at each pose (for programming the approach)".into(),
    ]
}

/// The numbers of the search (`kincal design-tool --json`).
pub fn json<const N: usize>(ctx: &Context<N>, d: &ToolDesign<N>) -> serde_json::Value {
    let chosen = d.chosen();
    serde_json::json!({
        "robot": ctx.robot_name,
        "seed": ctx.seed,
        "plate_z_m": chosen.map(|c| c.z_m),
        "objective": chosen.map(|c| c.objective.clone()),
        "screening_score": d.score,
        "beats_baseline": d.beats,
        "designs": study::results_json(&d.results),
    })
}
