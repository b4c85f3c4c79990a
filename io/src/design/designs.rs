//! The data-acquisition designs of Section 4: standard (whole workspace, observability
//! optimal, measured by an instrument), workspace clustering (poses of equal per-pose index
//! in different cubes of the working region, used as a tool), arbitrary choice (the Table 2
//! tool, or a user's tool file), and commanded pose files. Candidate pools and the starts of
//! the selection run in parallel; every result depends only on the seed.

use kincal::aria;
use kincal::identify::Workspace;
use kincal::montecarlo::{Acquisition, Design as CoreDesign, Study, robustly_reachable};
use kincal::observability::{
    Indices, ObservabilityOptions, PoseBlock, observability, pose_singular_values,
};
use kincal::pose::Transform;
use kincal::rng::SplitMix64;
use kincal::selection::{
    ClusterOptions, ClusterSelection, Constraints, Objective, Pool, SelectOptions, SelectScratch,
    Selection, cluster_select, fill_pool, sample_joint_space, sample_region, select_start,
};
use rayon::prelude::*;

use crate::design::Progress;
use crate::design::context::{Context, P, SelectionSettings};
use crate::error::Error;

/// A design: its poses and how they are measured.
#[derive(Debug, Clone)]
pub struct Design<const N: usize> {
    pub name: String,
    pub acquisition: Acquisition,
    /// Nominal configurations.
    pub q: Vec<[f64; N]>,
    /// Reference poses (tool designs: the drawing; instrument designs: the nominal poses).
    pub reference: Vec<Transform>,
    /// How it was made, for reports.
    pub note: String,
}

impl<const N: usize> Design<N> {
    /// A design from configurations; the reference poses are the nominal model's.
    pub fn from_configs(
        ctx: &Context<N>,
        name: &str,
        acquisition: Acquisition,
        q: Vec<[f64; N]>,
        note: String,
    ) -> Result<Self, Error> {
        let reference = q
            .iter()
            .map(|q| ctx.robot.fk_q(q))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| Error::numeric(format!("design {name}: {e}")))?;
        Ok(Design {
            name: name.to_string(),
            acquisition,
            q,
            reference,
            note,
        })
    }
    /// The core's view.
    pub fn core(&self) -> CoreDesign<'_, N> {
        CoreDesign {
            acquisition: self.acquisition,
            q: &self.q,
            reference: &self.reference,
        }
    }
    /// The observability indices of the design (nominal model, unit-column scaling).
    pub fn indices(&self, ctx: &Context<N>) -> Result<Indices, Error> {
        let obs = ObservabilityOptions::new(ctx.params);
        observability(
            &ctx.robot,
            &self.q,
            &obs,
            &mut Box::<Workspace<P>>::default(),
        )
        .map_err(|e| Error::numeric(format!("design {}: {e}", self.name)))
    }
}

/// A candidate pool with its Jacobian blocks and positions.
#[derive(Debug)]
pub struct OwnedPool<const N: usize> {
    pub q: Vec<[f64; N]>,
    pub blocks: Vec<PoseBlock<P>>,
    pub pos: Vec<[f64; 3]>,
}

impl<const N: usize> OwnedPool<N> {
    /// Blocks and positions of `q`, computed in parallel.
    pub fn new(
        ctx: &Context<N>,
        obs: &ObservabilityOptions,
        q: Vec<[f64; N]>,
    ) -> Result<Self, Error> {
        type Chunk = Result<(Vec<PoseBlock<P>>, Vec<[f64; 3]>), kincal::Error>;
        let chunks: Vec<Chunk> = q
            .par_chunks(64)
            .map(|c| {
                let mut ws = Box::<Workspace<P>>::default();
                let mut blocks = vec![[[0.0; P]; 6]; c.len()];
                let mut pos = vec![[0.0; 3]; c.len()];
                fill_pool(&ctx.robot, c, obs, &mut ws, &mut blocks, &mut pos)?;
                Ok((blocks, pos))
            })
            .collect();
        let mut blocks = Vec::with_capacity(q.len());
        let mut pos = Vec::with_capacity(q.len());
        for c in chunks {
            let (b, p) = c.map_err(|e| Error::numeric(format!("candidate pool: {e}")))?;
            blocks.extend(b);
            pos.extend(p);
        }
        Ok(OwnedPool { q, blocks, pos })
    }
    pub fn pool(&self) -> Pool<'_, N, P> {
        Pool {
            q: &self.q,
            blocks: &self.blocks,
            pos: &self.pos,
        }
    }
}

const CHUNK: usize = 32;

/// `k` admissible configurations drawn uniformly in joint space (chunk `i` of 32 from
/// stream `i` of `seed`, so the pool does not depend on the thread count).
pub fn sample_joint_pool<const N: usize>(
    ctx: &Context<N>,
    c: &Constraints,
    k: usize,
    seed: u64,
    pb: &dyn Progress,
) -> Result<Vec<[f64; N]>, Error> {
    let n_chunks = k.div_ceil(CHUNK);
    let parts: Vec<Result<Vec<[f64; N]>, kincal::Error>> = (0..n_chunks)
        .into_par_iter()
        .map(|i| {
            let mut rng = SplitMix64::new(seed).fork(i as u64);
            let mut out = vec![[0.0; N]; CHUNK];
            let w = sample_joint_space(&ctx.robot, c, &mut rng, &mut out, CHUNK * 5000)?;
            out.truncate(w);
            // Only configurations the pool keeps count (the last chunk is cut to `k`).
            pb.inc(w.min(k.saturating_sub(i * CHUNK)) as u64);
            Ok(out)
        })
        .collect();
    collect_pool(parts, k)
}

/// `k` admissible configurations whose poses are drawn in the region and cone of `c` and
/// solved by inverse kinematics (chunked as [`sample_joint_pool`]); tool poses are kept
/// only when `robust` robots of the study all reach them.
pub fn sample_region_pool<const N: usize>(
    ctx: &Context<N>,
    c: &Constraints,
    k: usize,
    seed: u64,
    robust: Option<(&Study<'_, N>, u64)>,
    pb: &dyn Progress,
) -> Result<Vec<[f64; N]>, Error> {
    let n_chunks = k.div_ceil(CHUNK);
    let parts: Vec<Result<Vec<[f64; N]>, kincal::Error>> = (0..n_chunks)
        .into_par_iter()
        .map(|i| {
            let mut rng = SplitMix64::new(seed).fork(i as u64);
            let mut kept = Vec::with_capacity(CHUNK);
            let mut one = [[0.0; N]; 1];
            let mut attempts = 0;
            while kept.len() < CHUNK && attempts < CHUNK * 200 {
                attempts += 1;
                if sample_region(&ctx.robot, c, &mut rng, &ctx.seed_q, &mut one, 1)? == 0 {
                    continue;
                }
                let q = one[0];
                if let Some((study, robots)) = robust {
                    let t = ctx.robot.fk_q(&q)?;
                    if !robustly_reachable(study, &t, &q, robots)? {
                        continue;
                    }
                }
                kept.push(q);
                if i * CHUNK + kept.len() <= k {
                    pb.inc(1);
                }
            }
            Ok(kept)
        })
        .collect();
    collect_pool(parts, k)
}

fn collect_pool<const N: usize>(
    parts: Vec<Result<Vec<[f64; N]>, kincal::Error>>,
    k: usize,
) -> Result<Vec<[f64; N]>, Error> {
    let mut out = Vec::with_capacity(k);
    for p in parts {
        out.extend(p.map_err(|e| Error::numeric(format!("candidate pool: {e}")))?);
    }
    out.truncate(k);
    Ok(out)
}

/// Runs the starts of the selection in parallel and keeps the best (the lowest start on
/// ties, as [`kincal::selection::select_poses`]). `reference` holds the blocks of the
/// prediction-variance objective.
#[allow(clippy::too_many_arguments)] // the bar is the one extra, optional-in-spirit argument
pub fn select_best<const N: usize>(
    ctx: &Context<N>,
    pool: &OwnedPool<N>,
    m: usize,
    obs: &ObservabilityOptions,
    c: &Constraints,
    opts: &SelectOptions,
    reference: Option<&[PoseBlock<P>]>,
    pb: &dyn Progress,
) -> Result<(Vec<[f64; N]>, Selection), Error> {
    let n = obs.params.len();
    type Start<const N: usize> = Result<(Vec<[f64; N]>, Selection), kincal::Error>;
    let results: Vec<Start<N>> = (0..opts.starts.max(1))
        .into_par_iter()
        .map(|start| {
            let mut ws = Box::<Workspace<P>>::default();
            let mut s = Box::<SelectScratch<P>>::default();
            if let Some(r) = reference {
                s.set_reference(r, n);
            }
            let mut out = vec![[0.0; N]; m];
            let sel = select_start(
                &ctx.robot,
                &pool.pool(),
                m,
                obs,
                c,
                opts,
                start,
                &mut ws,
                &mut s,
                &mut out,
            )?;
            pb.inc(1);
            Ok((out, sel))
        })
        .collect();
    let mut best: Option<(Vec<[f64; N]>, Selection)> = None;
    let mut evaluations = 0;
    for r in results {
        let (q, sel) = r.map_err(|e| Error::numeric(format!("pose selection: {e}")))?;
        evaluations += sel.evaluations;
        if best.as_ref().is_none_or(|(_, b)| sel.value > b.value) {
            best = Some((q, sel));
        }
    }
    let (q, sel) = best.ok_or_else(|| Error::numeric("pose selection: no start"))?;
    Ok((q, Selection { evaluations, ..sel }))
}

/// The standard design: `m` configurations anywhere in the joint ranges (end effector
/// inside the workspace box, joint margin kept) that maximise the index; measured by an
/// instrument. Returns the design, the selection and the pool.
pub fn standard_design<const N: usize>(
    ctx: &Context<N>,
    s: &SelectionSettings,
    pb: &dyn Progress,
) -> Result<(Design<N>, Selection, OwnedPool<N>), Error> {
    let c = Constraints {
        region: Some(s.workspace),
        cone: None,
        joint_margin_rad: ctx.margin_rad,
        min_dexterity: 0.0,
    };
    let obs = ObservabilityOptions::new(ctx.params);
    let q = sample_joint_pool(ctx, &c, s.pool, ctx.seed, pb)?;
    if q.len() < s.m {
        return Err(Error::numeric(format!(
            "standard design: only {} admissible configurations found in the workspace box",
            q.len()
        )));
    }
    let pool = OwnedPool::new(ctx, &obs, q)?;
    let mut opts = SelectOptions::new(Objective::Index(s.index), ctx.seed);
    opts.starts = s.starts;
    opts.refine_trials = s.refine_trials;
    pb.stage(
        opts.starts.max(1) as u64,
        &format!("exchange ({} starts)", opts.starts.max(1)),
    );
    let (q, sel) = select_best(ctx, &pool, s.m, &obs, &c, &opts, None, pb)?;
    let note = format!(
        "standard: {} poses maximising {} over {} joint-space candidates (whole workspace), instrument-measured",
        s.m,
        s.index.name(),
        pool.q.len()
    );
    Ok((
        Design::from_configs(ctx, "standard", Acquisition::Instrument, q, note)?,
        sel,
        pool,
    ))
}

/// The workspace-clustering design: `m` poses of the working region (cone, margin,
/// dexterity, robust reachability) in mutually different cubes of side L with equal
/// per-pose index; used as a tool.
pub fn clustering_design<const N: usize>(
    ctx: &Context<N>,
    s: &SelectionSettings,
    study: &Study<'_, N>,
    pb: &dyn Progress,
) -> Result<(Design<N>, ClusterSelection, OwnedPool<N>), Error> {
    let c = ctx.local_constraints(s.min_dexterity);
    let obs = ObservabilityOptions::new(ctx.params);
    let robust = (s.robust_robots > 0).then_some((study, s.robust_robots));
    let q = sample_region_pool(ctx, &c, s.pool, ctx.seed ^ 0xC1u64, robust, pb)?;
    let pool = OwnedPool::new(ctx, &obs, q)?;
    let per: Vec<[f64; 6]> = pool
        .q
        .par_iter()
        .map_init(Box::<Workspace<P>>::default, |ws, q| {
            pose_singular_values(&ctx.robot, q, &obs, ws)
        })
        .collect::<Result<_, _>>()
        .map_err(|e| Error::numeric(format!("per-pose index: {e}")))?;
    let copts = ClusterOptions {
        region: ctx.region,
        cube_m: s.cube_m,
        tolerance: s.tolerance,
        objective: Objective::Index(s.index),
    };
    let counts = ctx.region.cube_counts(s.cube_m);
    let mut cube_best = vec![(0.0, 0usize); counts[0] * counts[1] * counts[2]];
    let mut chosen = vec![0usize; s.m];
    let cs = cluster_select(
        &pool.pool(),
        &per,
        s.m,
        ctx.params.len(),
        true,
        &copts,
        &mut Box::<SelectScratch<P>>::default(),
        &mut cube_best,
        &mut chosen,
    )
    .map_err(|e| {
        Error::numeric(format!(
            "workspace clustering: {e} (cubes of {} mm: {}×{}×{}; pool {})",
            s.cube_m * 1e3,
            counts[0],
            counts[1],
            counts[2],
            pool.q.len()
        ))
    })?;
    let q: Vec<[f64; N]> = chosen.iter().map(|&i| pool.q[i]).collect();
    let note = format!(
        "workspace clustering: {} poses in different {:.0} mm cubes of the region ({} occupied), per-pose singular values within {:.1} % of the target's (ln-ratio {:.3}{}), best {} among such; used as a tool",
        s.m,
        s.cube_m * 1e3,
        cs.occupied_cubes,
        (cs.spread.exp() - 1.0) * 100.0,
        cs.spread,
        if cs.within_tolerance {
            ""
        } else {
            ", above the tolerance: the smallest spread found"
        },
        s.index.name()
    );
    Ok((
        Design::from_configs(ctx, "clustering", Acquisition::Tool, q, note)?,
        cs,
        pool,
    ))
}

/// The arbitrary-choice design of the paper: the Table 2 calibration tool (ARIA only).
pub fn table2_design<const N: usize>(ctx: &Context<N>) -> Result<Design<N>, Error> {
    if !ctx.is_aria || N != 6 {
        return Err(Error::usage(format!(
            "the Table 2 tool belongs to the built-in aria, not to robot '{}': give the tool as a file",
            ctx.robot_name
        )));
    }
    let mut q = Vec::new();
    let mut reference = Vec::new();
    for l in 0..aria::TOOL_POSES.len() {
        let t = aria::tool_pose(l).ok_or_else(|| Error::numeric("Table 2 pose missing"))?;
        let c = Constraints::none();
        let ql = ctx
            .nominal_ik(&t, &c)
            .ok_or_else(|| Error::numeric(format!("Table 2 pose {} is unreachable", l + 1)))?;
        q.push(ql);
        reference.push(t);
    }
    Ok(Design {
        name: "table2".into(),
        acquisition: Acquisition::Tool,
        q,
        reference,
        note: "arbitrary choice: the paper's Table 2 calibration tool (10 poses, circle r = 0.25 m, z = 0.235 m)".into(),
    })
}

/// A calibration tool from a tool file (reference poses; the nominal configurations by IK).
pub fn tool_from_file<const N: usize>(
    ctx: &Context<N>,
    name: &str,
    path: &std::path::Path,
) -> Result<Design<N>, Error> {
    let poses = crate::tool_file::read_tool(path)?;
    let mut q = Vec::with_capacity(poses.len());
    for p in &poses {
        // The file's nominal configuration (if any) chooses the branch.
        let seed = if p.q_hint.len() == N {
            let mut s = [0.0; N];
            s.copy_from_slice(&p.q_hint);
            Some(s)
        } else {
            None
        };
        let ql = ctx.nominal_ik_from(&p.pose, seed.as_ref(), &Constraints::none()).ok_or_else(|| {
            Error::numeric(format!(
                "{}:{}: the nominal robot cannot reach this reference pose within its joint limits",
                path.display(),
                p.line
            ))
        })?;
        q.push(ql);
    }
    Ok(Design {
        name: name.to_string(),
        acquisition: Acquisition::Tool,
        q,
        reference: poses.iter().map(|p| p.pose).collect(),
        note: format!("tool file {} ({} poses)", path.display(), poses.len()),
    })
}

/// Commanded configurations from a measurement-format file (columns q1..qN; any pose
/// columns are ignored), measured by an instrument.
pub fn commanded_from_file<const N: usize>(
    ctx: &Context<N>,
    name: &str,
    path: &std::path::Path,
) -> Result<Design<N>, Error> {
    let mut opts = crate::measurements::ReadOptions::new(N);
    opts.joint_limits = Some(
        ctx.robot
            .limits()
            .iter()
            .map(|l| (l.lower, l.upper))
            .collect(),
    );
    let set = crate::measurements::read_measurements(path, &opts)?;
    let q: Vec<[f64; N]> = set
        .rows
        .iter()
        .map(|r| {
            let mut q = [0.0; N];
            q.copy_from_slice(&r.q_rad);
            q
        })
        .collect();
    let note = format!("commanded poses {} ({} poses)", path.display(), q.len());
    Design::from_configs(ctx, name, Acquisition::Instrument, q, note)
}

/// An observability-optimal local design: `m` poses of the working region (cone, margin,
/// dexterity, robust reachability) maximising the index, from pool members only (so every
/// pose passed the reachability test); used as a tool.
pub fn region_design<const N: usize>(
    ctx: &Context<N>,
    s: &SelectionSettings,
    study: &Study<'_, N>,
    pb: &dyn Progress,
) -> Result<(Design<N>, Selection, OwnedPool<N>), Error> {
    let c = ctx.local_constraints(s.min_dexterity);
    let obs = ObservabilityOptions::new(ctx.params);
    let robust = (s.robust_robots > 0).then_some((study, s.robust_robots));
    let q = sample_region_pool(ctx, &c, s.pool, ctx.seed ^ 0xC1u64, robust, pb)?;
    if q.len() < s.m {
        return Err(Error::numeric(format!(
            "region design: only {} admissible poses found in the working region",
            q.len()
        )));
    }
    let pool = OwnedPool::new(ctx, &obs, q)?;
    let mut opts = SelectOptions::new(Objective::Index(s.index), ctx.seed);
    opts.starts = s.starts;
    opts.refine_trials = 0;
    pb.stage(
        opts.starts.max(1) as u64,
        &format!("exchange ({} starts)", opts.starts.max(1)),
    );
    let (q, sel) = select_best(ctx, &pool, s.m, &obs, &c, &opts, None, pb)?;
    let note = format!(
        "region: {} poses of the working region maximising {} over {} robust candidates; used as a tool",
        s.m,
        s.index.name(),
        pool.q.len()
    );
    Ok((
        Design::from_configs(ctx, "region", Acquisition::Tool, q, note)?,
        sel,
        pool,
    ))
}

/// Indices of `trials` random m-subsets of the pool (for comparison with a selection).
pub fn random_subsets<const N: usize>(
    ctx: &Context<N>,
    pool: &OwnedPool<N>,
    m: usize,
    trials: usize,
    seed: u64,
) -> Result<Vec<Indices>, Error> {
    let obs = ObservabilityOptions::new(ctx.params);
    (0..trials)
        .into_par_iter()
        .map_init(Box::<Workspace<P>>::default, |ws, t| {
            let mut rng = SplitMix64::new(seed).fork(t as u64);
            let mut pick: Vec<usize> = Vec::with_capacity(m);
            while pick.len() < m.min(pool.q.len()) {
                let i = rng.below(pool.q.len());
                if !pick.contains(&i) {
                    pick.push(i);
                }
            }
            let qs: Vec<[f64; N]> = pick.iter().map(|&i| pool.q[i]).collect();
            observability(&ctx.robot, &qs, &obs, ws)
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| Error::numeric(format!("random subsets: {e}")))
}
