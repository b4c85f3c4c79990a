//! Pose selection (eq. 18): the m configurations that maximise an observability index
//! within the joint limits, optionally with the end effector inside a workspace region
//! (cuboid) and its approach axis inside a cone; and the workspace-clustering design of
//! Section 4.2 (m poses of equal per-pose index in mutually different cubes).
//!
//! Method, per start ([`select_start`]):
//! 1. a candidate pool of admissible configurations (the caller's, e.g. from
//!    [`sample_joint_space`] or [`sample_region`]) with their Jacobian blocks ([`fill_pool`]);
//! 2. an initial set: a random first candidate, then greedily the candidate that maximises a
//!    regularised D-criterion (so rank-deficient partial sets still compare);
//! 3. DETMAX exchange (Mitchell 1974) on the chosen objective: an excursion of size k adds
//!    the k best candidates one by one and then removes the k points whose removal hurts the
//!    objective least; an improving excursion is kept and k resets to 1, otherwise k grows
//!    up to [`SelectOptions::max_excursion`];
//! 4. local refinement in joint space: random perturbations of one pose at a time, kept when
//!    admissible and improving, with a step that halves after a full round of failures.
//!
//! [`select_poses`] runs [`SelectOptions::starts`] starts and keeps the best (the lowest start
//! on ties), so the result depends only on the seed; a caller may run the starts in
//! parallel with [`select_start`] and pick the best the same way.
//!
//! Objectives are evaluated from the Gram matrix of the set (sum of the blocks' `BᵀB`,
//! [`crate::observability::indices_from_gram`]); report the final set's indices with
//! [`crate::observability::observability`]. Where steps 2 and 3 pick the best of the pool,
//! a candidate whose cheap upper bound ([`bound`]) lies below the best value found so far
//! is skipped without the exact evaluation: the choice is the same, to the bit.

use crate::error::{Error, Result};
use crate::identify::Workspace;
use crate::ik::{IkOptions, solve_ik};
use crate::linalg::gram::cholesky_upper;
use crate::linalg::tri::{solve_upper, solve_upper_transpose};
use crate::math::{cos, sin, sqrt};
use crate::model::{JointState, Robot};
use crate::observability::{
    ColumnScaling, GramScratch, Index, ObservabilityOptions, PoseBlock, gram_update,
    indices_from_gram, pose_block,
};
use crate::pose::{Transform, transform};
use crate::rng::SplitMix64;
use nalgebra::{Matrix3, Vector3};

pub mod bound;
use bound::AddBound;

/// Largest design (m plus the excursion) [`select_start`] handles.
pub const MAX_DESIGN: usize = 64;

/// An axis-aligned box in the base frame \[m\].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Region {
    /// Lower corner.
    pub min_m: [f64; 3],
    /// Upper corner.
    pub max_m: [f64; 3],
}

impl Region {
    /// A region; every `min <= max` and finite, else [`Error::InvalidParameter`].
    pub fn new(min_m: [f64; 3], max_m: [f64; 3]) -> Result<Self> {
        for k in 0..3 {
            if !(min_m[k].is_finite() && max_m[k].is_finite() && min_m[k] <= max_m[k]) {
                return Err(Error::InvalidParameter {
                    index: k,
                    value: min_m[k],
                });
            }
        }
        Ok(Region { min_m, max_m })
    }
    /// Whether `p` lies inside (inclusive).
    #[must_use]
    pub fn contains(&self, p: &[f64; 3]) -> bool {
        (0..3).all(|k| p[k] >= self.min_m[k] && p[k] <= self.max_m[k])
    }
    /// Number of cubes of side `side_m` along each axis (the last one may stick out).
    #[must_use]
    pub fn cube_counts(&self, side_m: f64) -> [usize; 3] {
        let mut c = [1; 3];
        for k in 0..3 {
            let w = self.max_m[k] - self.min_m[k];
            // Rounding: 0.5 m / 0.1 m is 5 cubes, not 6.
            c[k] = libm::ceil(w / side_m - 1e-9).max(1.0) as usize;
        }
        c
    }
    /// Index of the cube of side `side_m` that holds `p` (x fastest), `None` outside.
    #[must_use]
    pub fn cube_of(&self, p: &[f64; 3], side_m: f64) -> Option<usize> {
        if !self.contains(p) || side_m.is_nan() || side_m <= 0.0 {
            return None;
        }
        let c = self.cube_counts(side_m);
        let mut idx = [0usize; 3];
        for k in 0..3 {
            let i = libm::floor((p[k] - self.min_m[k]) / side_m) as usize;
            idx[k] = i.min(c[k] - 1);
        }
        Some(idx[0] + c[0] * (idx[1] + c[1] * idx[2]))
    }
}

/// A cone of directions: the end effector's z axis (approach axis) within `half_angle_rad`
/// of `axis`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cone {
    /// Unit axis in the base frame.
    pub axis: [f64; 3],
    /// Half opening angle \[rad\].
    pub half_angle_rad: f64,
}

impl Cone {
    /// A cone about `axis` (normalised here); fails for a zero axis or a bad angle.
    pub fn new(axis: [f64; 3], half_angle_rad: f64) -> Result<Self> {
        let n = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
        if !(n > 0.0 && n.is_finite()) {
            return Err(Error::InvalidParameter { index: 0, value: n });
        }
        if !(0.0..=core::f64::consts::PI).contains(&half_angle_rad) {
            return Err(Error::InvalidParameter {
                index: 1,
                value: half_angle_rad,
            });
        }
        Ok(Cone {
            axis: axis.map(|v| v / n),
            half_angle_rad,
        })
    }
    /// Whether unit direction `z` lies inside.
    #[must_use]
    pub fn contains(&self, z: &[f64; 3]) -> bool {
        let c = z[0] * self.axis[0] + z[1] * self.axis[1] + z[2] * self.axis[2];
        c >= cos(self.half_angle_rad) - 1e-12
    }
}

/// What an admissible configuration must satisfy besides the joint limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Constraints {
    /// End-effector position inside this box.
    pub region: Option<Region>,
    /// End-effector z axis inside this cone.
    pub cone: Option<Cone>,
    /// Distance kept from every revolute joint's limits \[rad\] (none for prismatic joints,
    /// whose limits are in metres).
    pub joint_margin_rad: f64,
    /// Smallest admissible [`dexterity`] (0: no test). Tool poses need it: near a
    /// singularity a slightly different real robot may not reach the pose, or only with
    /// large joint motions.
    pub min_dexterity: f64,
}

impl Constraints {
    /// Joint limits only.
    #[must_use]
    pub const fn none() -> Self {
        Constraints {
            region: None,
            cone: None,
            joint_margin_rad: 0.0,
            min_dexterity: 0.0,
        }
    }
    /// Whether a pose satisfies the region and cone.
    #[must_use]
    pub fn admits_pose(&self, t: &Transform) -> bool {
        let p = t.translation.vector;
        let z = t.rotation.matrix().column(2);
        self.region.is_none_or(|r| r.contains(&[p.x, p.y, p.z]))
            && self.cone.is_none_or(|c| c.contains(&[z.x, z.y, z.z]))
    }
    /// Whether `q` keeps the margin to every limit.
    #[must_use]
    pub fn within_limits<const N: usize>(&self, robot: &Robot<N>, q: &[f64; N]) -> bool {
        let kinds = robot.joint_kinds();
        q.iter()
            .zip(robot.limits().iter())
            .zip(kinds.iter())
            .all(|((&v, l), &k)| {
                let m = if k == crate::JointKind::Prismatic {
                    0.0
                } else {
                    self.joint_margin_rad
                };
                v.is_finite() && v >= l.lower + m && v <= l.upper - m
            })
    }
    /// Whether `q` is admissible: limits with margin, and its FK pose inside region and cone.
    pub fn admits<const N: usize>(&self, robot: &Robot<N>, q: &[f64; N]) -> Result<bool> {
        if !self.within_limits(robot, q) {
            return Ok(false);
        }
        if self.min_dexterity > 0.0 && dexterity(robot, q)? < self.min_dexterity {
            return Ok(false);
        }
        if self.region.is_none() && self.cone.is_none() {
            return Ok(true);
        }
        Ok(self.admits_pose(&robot.fk_q(q)?))
    }
}

/// Distance from singularity: the smallest singular value of the 6 × N Jacobian of the pose
/// `[p (m); φ (rad)]` with respect to the joints (0 at a singularity; for N < 6 the
/// smallest of the N).
pub fn dexterity<const N: usize>(robot: &Robot<N>, q: &[f64; N]) -> Result<f64> {
    let st = JointState::new(*q);
    let mut frames = crate::kinematics::Frames::default();
    robot.fk_frames(&st, &mut frames)?;
    let j = crate::ik::joint_jacobian(robot, &st, &frames);
    // Eigenvalues of the smaller Gram matrix (JJᵀ for N >= 6, JᵀJ otherwise).
    const M: usize = crate::any::MAX_JOINTS;
    let k = N.min(6);
    let mut g = [[0.0; M]; M];
    for a in 0..k {
        for b in a..k {
            g[a][b] = if N >= 6 {
                (0..N).map(|c| j[(a, c)] * j[(b, c)]).sum()
            } else {
                (0..6).map(|r| j[(r, a)] * j[(r, b)]).sum()
            };
        }
    }
    let (mut eig, mut off) = ([0.0; M], [0.0; M]);
    crate::linalg::symeig::sym_eigenvalues(&mut g, k, &mut eig, &mut off)?;
    Ok(sqrt(eig[k - 1].max(0.0)))
}

/// Sampling range of joint `j`: the limits less the margin, and at most one turn (±π) for
/// joints that turn further (the geometry repeats).
fn joint_range<const N: usize>(robot: &Robot<N>, c: &Constraints, j: usize) -> (f64, f64) {
    let l = robot.limits()[j];
    if robot.joint_kind(j) == crate::JointKind::Prismatic {
        return (l.lower, l.upper);
    }
    let (mut lo, mut hi) = (l.lower + c.joint_margin_rad, l.upper - c.joint_margin_rad);
    if hi - lo > 2.0 * core::f64::consts::PI {
        lo = lo.max(-core::f64::consts::PI);
        hi = hi.min(core::f64::consts::PI);
    }
    (lo, hi)
}

/// Fills `out` with admissible configurations drawn uniformly from the joint ranges
/// (rejection sampling against region and cone); returns how many were written (fewer than
/// `out.len()` when `max_attempts` draws did not suffice).
pub fn sample_joint_space<const N: usize>(
    robot: &Robot<N>,
    c: &Constraints,
    rng: &mut SplitMix64,
    out: &mut [[f64; N]],
    max_attempts: usize,
) -> Result<usize> {
    let mut w = 0;
    for _ in 0..max_attempts {
        if w >= out.len() {
            break;
        }
        let mut q = [0.0; N];
        for (j, v) in q.iter_mut().enumerate() {
            let (lo, hi) = joint_range(robot, c, j);
            *v = rng.range(lo, hi);
        }
        if c.admits(robot, &q)? {
            out[w] = q;
            w += 1;
        }
    }
    Ok(w)
}

/// A rotation whose z axis is `z` (unit) and whose x axis is turned by `spin` about it.
fn frame_with_z(z: &Vector3<f64>, spin: f64) -> Matrix3<f64> {
    let helper = if z.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let x0 = (helper - z * z.dot(&helper)).normalize();
    let y0 = z.cross(&x0);
    let (s, c) = (sin(spin), cos(spin));
    let x = x0 * c + y0 * s;
    let y = z.cross(&x);
    Matrix3::from_columns(&[x, y, *z])
}

/// A random pose in `c`'s region with the z axis uniformly in its cone (uniform on the
/// sphere without a cone) and a uniform spin about it.
pub fn random_pose_in(c: &Constraints, rng: &mut SplitMix64) -> Result<Transform> {
    let Some(r) = c.region else {
        return Err(Error::MissingInput {
            what: crate::error::Quantity::Position,
        });
    };
    let p = Vector3::new(
        rng.range(r.min_m[0], r.max_m[0]),
        rng.range(r.min_m[1], r.max_m[1]),
        rng.range(r.min_m[2], r.max_m[2]),
    );
    let (axis, half) = match c.cone {
        Some(k) => (
            Vector3::new(k.axis[0], k.axis[1], k.axis[2]),
            k.half_angle_rad,
        ),
        None => (Vector3::z(), core::f64::consts::PI),
    };
    // Uniform on the spherical cap: cos θ uniform in [cos half, 1].
    let ct = rng.range(cos(half), 1.0);
    let st = sqrt((1.0 - ct * ct).max(0.0));
    let phi = rng.range(-core::f64::consts::PI, core::f64::consts::PI);
    let local = Vector3::new(st * cos(phi), st * sin(phi), ct);
    let z = frame_with_z(&axis, 0.0) * local;
    let spin = rng.range(-core::f64::consts::PI, core::f64::consts::PI);
    Ok(transform(frame_with_z(&z.normalize(), spin), p))
}

/// Inverse kinematics for `target` from `seed` (the first converging of a few seeds), kept
/// only when admissible under `c` (`Ok(None)` otherwise or when unreachable).
pub fn reach<const N: usize>(
    robot: &Robot<N>,
    target: &Transform,
    seed: &[f64; N],
    c: &Constraints,
) -> Result<Option<[f64; N]>> {
    let opts = IkOptions {
        first_solution: true,
        extra_seeds: 8,
        tol_pos_m: 1e-10,
        tol_rot_rad: 1e-10,
        ..IkOptions::default()
    };
    match solve_ik(robot, target, &JointState::new(*seed), &opts) {
        Ok(sol) if c.admits(robot, &sol.q)? => Ok(Some(sol.q)),
        Ok(_) | Err(Error::Unreachable { .. }) => Ok(None),
        Err(e) => Err(e),
    }
}

/// Fills `out` with admissible configurations whose poses are drawn by [`random_pose_in`]
/// and solved by [`reach`] from `seed`; returns how many were written.
pub fn sample_region<const N: usize>(
    robot: &Robot<N>,
    c: &Constraints,
    rng: &mut SplitMix64,
    seed: &[f64; N],
    out: &mut [[f64; N]],
    max_attempts: usize,
) -> Result<usize> {
    let mut w = 0;
    for _ in 0..max_attempts {
        if w >= out.len() {
            break;
        }
        let t = random_pose_in(c, rng)?;
        if let Some(q) = reach(robot, &t, seed, c)? {
            out[w] = q;
            w += 1;
        }
    }
    Ok(w)
}

/// A candidate pool: configurations, their Jacobian blocks and end-effector positions.
#[derive(Debug, Clone, Copy)]
pub struct Pool<'a, const N: usize, const P: usize> {
    /// Configurations.
    pub q: &'a [[f64; N]],
    /// Their blocks ([`pose_block`]).
    pub blocks: &'a [PoseBlock<P>],
    /// Their end-effector positions \[m\].
    pub pos: &'a [[f64; 3]],
}

impl<const N: usize, const P: usize> Pool<'_, N, P> {
    fn len(&self) -> usize {
        self.q.len().min(self.blocks.len()).min(self.pos.len())
    }
}

/// Computes the blocks and positions of the configurations `q` (`blocks` and `pos` at least
/// as long as `q`).
pub fn fill_pool<const N: usize, const P: usize>(
    robot: &Robot<N>,
    q: &[[f64; N]],
    obs: &ObservabilityOptions,
    ws: &mut Workspace<P>,
    blocks: &mut [PoseBlock<P>],
    pos: &mut [[f64; 3]],
) -> Result<()> {
    if blocks.len() < q.len() || pos.len() < q.len() {
        return Err(Error::CapacityExceeded {
            needed: q.len(),
            capacity: blocks.len().min(pos.len()),
        });
    }
    for ((qk, b), p) in q.iter().zip(blocks.iter_mut()).zip(pos.iter_mut()) {
        let t = pose_block(robot, qk, obs, ws, b)?;
        let v = t.translation.vector;
        *p = [v.x, v.y, v.z];
    }
    Ok(())
}

/// What a selection maximises.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Objective {
    /// An observability index.
    Index(Index),
    /// Minus the prediction variance over a reference set: `−trace((JᵀJ)⁻¹·J_refᵀJ_ref)`,
    /// the expected sum of squared pose errors of the identified model over the reference
    /// poses for unit, independent measurement noise (I-optimality). Needs
    /// [`SelectScratch::set_reference`]. Independent of the column scaling.
    PredictionVariance,
}

/// Options of [`select_poses`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SelectOptions {
    /// What to maximise.
    pub objective: Objective,
    /// Number of starts.
    pub starts: usize,
    /// Largest DETMAX excursion.
    pub max_excursion: usize,
    /// Cap on accepted exchanges per start.
    pub max_exchanges: usize,
    /// Joint-space refinement trials per start (0: none; the poses then stay pool members).
    pub refine_trials: usize,
    /// Initial refinement step (standard deviation per joint) \[rad\].
    pub refine_step_rad: f64,
    /// Smallest distance between two selected end-effector positions \[m\].
    pub min_separation_m: f64,
    /// Seed; start `s` uses `SplitMix64::new(seed).fork(s)`.
    pub seed: u64,
}

impl SelectOptions {
    /// Defaults: 4 starts, excursions up to 3, 200 refinement trials from 0.1 rad.
    #[must_use]
    pub const fn new(objective: Objective, seed: u64) -> Self {
        SelectOptions {
            objective,
            starts: 4,
            max_excursion: 3,
            max_exchanges: 1000,
            refine_trials: 200,
            refine_step_rad: 0.1,
            min_separation_m: 0.0,
            seed,
        }
    }
}

/// Working memory of the selection (large: allocate it zeroed on the heap on a host).
#[derive(Debug, Clone)]
pub struct SelectScratch<const P: usize> {
    g: [[f64; P]; P],
    /// Gram matrix of the set during an excursion.
    tg: [[f64; P]; P],
    trial: [[f64; P]; P],
    chol: [[f64; P]; P],
    reference: [[f64; P]; P],
    has_reference: bool,
    gs: GramScratch<P>,
    blocks: [PoseBlock<P>; MAX_DESIGN],
    bound: AddBound<P>,
    /// Candidates skipped by their bound since the scratch was made (bound.rs).
    skipped: u64,
    /// Every candidate evaluated exactly (no bounds): for tests and benches.
    exact_only: bool,
    /// Candidates ranked by their bounds: (bound, pool index).
    rank: [(f64, u32); RANK_CAPACITY],
}

impl<const P: usize> SelectScratch<P> {
    /// Zeroed scratch.
    #[must_use]
    pub const fn new() -> Self {
        SelectScratch {
            g: [[0.0; P]; P],
            tg: [[0.0; P]; P],
            trial: [[0.0; P]; P],
            chol: [[0.0; P]; P],
            reference: [[0.0; P]; P],
            has_reference: false,
            gs: GramScratch::new(),
            blocks: [[[0.0; P]; 6]; MAX_DESIGN],
            bound: AddBound::new(),
            skipped: 0,
            exact_only: false,
            rank: [(0.0, 0); RANK_CAPACITY],
        }
    }
    /// With `true`, every candidate is evaluated exactly, none skipped by its bound (the
    /// selection is the same either way: see [`bound`]); for tests and benches.
    pub fn set_exact_only(&mut self, on: bool) {
        self.exact_only = on;
    }
    /// Candidates skipped by their bound (not evaluated exactly) since the scratch was made;
    /// they count in [`Selection::evaluations`] all the same.
    #[must_use]
    pub fn skipped(&self) -> u64 {
        self.skipped
    }
    /// Sets the reference poses of [`Objective::PredictionVariance`] from their blocks.
    pub fn set_reference(&mut self, blocks: &[PoseBlock<P>], n: usize) {
        for row in self.reference.iter_mut() {
            row.fill(0.0);
        }
        for b in blocks {
            gram_update(&mut self.reference, b, n, 1.0);
        }
        self.has_reference = !blocks.is_empty();
    }
}

impl<const P: usize> Default for SelectScratch<P> {
    fn default() -> Self {
        Self::new()
    }
}

/// The outcome of a selection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Selection {
    /// Objective of the selected set.
    pub value: f64,
    /// Objective after the greedy initial set.
    pub initial_value: f64,
    /// Objective after the exchange (before refinement).
    pub exchange_value: f64,
    /// Objective evaluations.
    pub evaluations: u64,
    /// Accepted exchanges (excursions).
    pub exchanges: usize,
    /// Accepted refinement moves.
    pub refinements: usize,
    /// Which start gave the result.
    pub start: usize,
}

/// Largest pool whose candidates [`select_start`] ranks by their bounds (larger pools are
/// swept in index order, with the same result).
pub const RANK_CAPACITY: usize = 4096;

/// Which objective a candidate search maximises: the greedy start's regularised D-criterion
/// on `s.g`, or the objective on the excursion's `s.tg`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Greedy,
    Add,
}

struct Eval<'s, const P: usize> {
    s: &'s mut SelectScratch<P>,
    n: usize,
    unit: bool,
    objective: Objective,
    count: u64,
}

impl<const P: usize> Eval<'_, P> {
    /// Objective of the Gram matrix in `s.trial` for `poses` poses.
    fn trial(&mut self, poses: usize) -> Result<f64> {
        self.count += 1;
        let n = self.n;
        match self.objective {
            Objective::Index(i) => {
                let SelectScratch { trial, gs, .. } = &mut *self.s;
                Ok(indices_from_gram(trial, n, poses, self.unit, gs)?.get(i))
            }
            Objective::PredictionVariance => {
                let SelectScratch {
                    trial,
                    chol,
                    reference,
                    gs,
                    ..
                } = &mut *self.s;
                if cholesky_upper(trial, n, 1e-13, chol).is_err() {
                    return Ok(f64::NEG_INFINITY);
                }
                // trace(G⁻¹A) = Σ_k (G⁻¹ a_k)_k with a_k the k-th column of A (upper stored).
                let mut tr = 0.0;
                for k in 0..n {
                    for i in 0..n {
                        gs.off[i] = reference[i.min(k)][i.max(k)];
                    }
                    solve_upper_transpose(chol, n, &mut gs.off[..n])?;
                    solve_upper(chol, n, &mut gs.off[..n])?;
                    tr += gs.off[k];
                }
                Ok(-tr)
            }
        }
    }
    /// Prepares the σ-type bound of [`Eval::add_bound`] for candidates added to `s.tg`.
    fn prepare_add(&mut self) {
        if !self.s.exact_only
            && let Objective::Index(i) = self.objective
            && AddBound::<P>::uses_ritz(i)
        {
            let SelectScratch { tg, bound, .. } = &mut *self.s;
            bound.prepare(tg, self.n, self.unit);
        }
    }
    /// An upper bound of the objective of `s.tg + BᵀB` for `poses` poses, or `None` (a
    /// cheaper, looser one when that is below `best`); [`Eval::prepare_add`] must have seen
    /// the same `s.tg`. Uses `s.trial` as scratch.
    fn add_bound(&mut self, block: &PoseBlock<P>, poses: usize, best: f64) -> Option<f64> {
        let Objective::Index(i) = self.objective else {
            return None;
        };
        if self.s.exact_only {
            return None;
        }
        let SelectScratch {
            tg, trial, bound, ..
        } = &mut *self.s;
        if AddBound::<P>::uses_ritz(i) {
            bound.ritz_bound(block, i, best)
        } else {
            bound::det_bound(tg, block, self.n, poses, self.unit, i, trial)
        }
    }
    /// An upper bound of [`Eval::regularised`] for `s.g + BᵀB`; uses `s.trial` as scratch.
    /// `s.blocks[..set]` must hold the set's blocks (a rank-deficient set's bound uses them).
    fn regularised_bound(&mut self, block: &PoseBlock<P>, set: usize) -> Option<f64> {
        if self.s.exact_only {
            return None;
        }
        let SelectScratch {
            g,
            trial,
            chol,
            gs,
            blocks,
            ..
        } = &mut *self.s;
        if 6 * (set + 1) < self.n {
            let GramScratch { eig, off, .. } = gs;
            bound::regularised_bound_small(
                &blocks[..set],
                block,
                self.n,
                self.unit,
                chol,
                trial,
                eig,
                off,
            )
        } else {
            bound::regularised_bound(g, block, self.n, self.unit, trial)
        }
    }
    /// An upper bound of candidate `block`'s objective in `phase`, or `None`.
    fn bound(
        &mut self,
        phase: Phase,
        block: &PoseBlock<P>,
        poses: usize,
        best: f64,
    ) -> Option<f64> {
        match phase {
            Phase::Greedy => self.regularised_bound(block, poses - 1),
            Phase::Add => self.add_bound(block, poses, best),
        }
    }
    /// The exact objective of candidate `block` in `phase` (`s.g` or `s.tg` plus `BᵀB`).
    fn exact(&mut self, phase: Phase, block: &PoseBlock<P>, poses: usize) -> Result<f64> {
        let n = self.n;
        let SelectScratch { g, tg, trial, .. } = &mut *self.s;
        copy_gram(if phase == Phase::Greedy { g } else { tg }, trial, n);
        gram_update(trial, block, n, 1.0);
        match phase {
            Phase::Greedy => self.regularised(poses),
            Phase::Add => self.trial(poses),
        }
    }
    /// The eligible candidate of largest exact objective in `phase` for `poses` poses (the
    /// lowest index on ties), as `(value, index)`; `None` if none is eligible.
    ///
    /// Every eligible candidate counts as one evaluation, but only those whose upper bound
    /// ([`bound`]) is not below the best value found so far are evaluated exactly, in the
    /// order of decreasing bound (so the best is found early and the rest skipped). A pool
    /// larger than [`RANK_CAPACITY`] is swept in index order instead.
    fn best_candidate(
        &mut self,
        blocks: &[PoseBlock<P>],
        k_pool: usize,
        eligible: &dyn Fn(usize) -> bool,
        phase: Phase,
        poses: usize,
    ) -> Result<Option<(f64, usize)>> {
        let mut best: Option<(f64, usize)> = None;
        if self.s.exact_only || k_pool > RANK_CAPACITY {
            for cand in (0..k_pool).filter(|&c| eligible(c)) {
                self.consider(&blocks[cand], cand, phase, poses, true, &mut best)?;
            }
            return Ok(best);
        }
        // Rank by the cheapest bound (for σ-type indices two Ritz vectors); +∞ for none.
        let mut len = 0;
        for cand in (0..k_pool).filter(|&c| eligible(c)) {
            let u = self.bound(phase, &blocks[cand], poses, f64::INFINITY);
            // No bound (or a NaN one): +∞, evaluated exactly.
            let key = u.filter(|v| !v.is_nan()).unwrap_or(f64::INFINITY);
            self.s.rank[len] = (key, cand as u32);
            len += 1;
        }
        let rank = &mut self.s.rank[..len];
        rank.sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        for r in 0..len {
            let (u, cand) = self.s.rank[r];
            let cand = cand as usize;
            if let Some((b, _)) = best
                && u < b
            {
                // Sorted: every bound from here on is below the best.
                let rest = (len - r) as u64;
                self.count += rest;
                self.s.skipped += rest;
                break;
            }
            // The σ-type bound is refined (more Ritz vectors) now that the best is known; the
            // greedy start's bound does not depend on it, so it is not taken twice.
            let refine = phase == Phase::Add;
            self.consider(&blocks[cand], cand, phase, poses, refine, &mut best)?;
        }
        Ok(best)
    }
    /// Evaluates candidate `cand` exactly and keeps it in `best` if it is better (the lower
    /// index on ties), unless `recheck` and its bound given `best` shows it cannot win: then
    /// it only counts, as skipped.
    fn consider(
        &mut self,
        block: &PoseBlock<P>,
        cand: usize,
        phase: Phase,
        poses: usize,
        recheck: bool,
        best: &mut Option<(f64, usize)>,
    ) -> Result<()> {
        if recheck
            && let Some((b, _)) = *best
            && self.bound(phase, block, poses, b).is_some_and(|u| u < b)
        {
            self.count += 1;
            self.s.skipped += 1;
            return Ok(());
        }
        let v = self.exact(phase, block, poses)?;
        if best.is_none_or(|(b, bi)| v > b || (v == b && cand < bi)) {
            *best = Some((v, cand));
        }
        Ok(())
    }
    /// Regularised D-criterion Σ ln(σ² + ε) of `s.trial` (for growing partial sets).
    fn regularised(&mut self, poses: usize) -> Result<f64> {
        self.count += 1;
        let n = self.n;
        let SelectScratch { trial, gs, .. } = &mut *self.s;
        let ind = indices_from_gram(trial, n, poses, self.unit, gs)?;
        let eps = 1e-9 * ind.sigma_max * ind.sigma_max + 1e-300;
        Ok(gs
            .eig
            .iter()
            .take(n)
            .map(|s| crate::math::ln(s * s + eps))
            .sum())
    }
}

fn copy_gram<const P: usize>(from: &[[f64; P]; P], to: &mut [[f64; P]; P], n: usize) {
    for i in 0..n {
        to[i][i..n].copy_from_slice(&from[i][i..n]);
    }
}

fn zero_gram<const P: usize>(g: &mut [[f64; P]; P], n: usize) {
    for row in g.iter_mut().take(n) {
        row[..n].fill(0.0);
    }
}

fn dist2(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]) * (a[k] - b[k])).sum()
}

/// One start of the selection: see the module documentation. Writes the `m` selected
/// configurations to `out[..m]`.
///
/// Errors: `m` of 0, above [`MAX_DESIGN`] − `max_excursion` or above the pool size
/// ([`Error::TooFewData`] / [`Error::CapacityExceeded`]); `PredictionVariance` without a
/// reference ([`Error::MissingInput`]); errors of the kinematics.
// Long by design: DETMAX's four numbered steps share the design, the Gram and the pool in fixed capacity (no heap).
#[allow(clippy::too_many_arguments)]
pub fn select_start<const N: usize, const P: usize>(
    robot: &Robot<N>,
    pool: &Pool<'_, N, P>,
    m: usize,
    obs: &ObservabilityOptions,
    c: &Constraints,
    opts: &SelectOptions,
    start: usize,
    ws: &mut Workspace<P>,
    s: &mut SelectScratch<P>,
    out: &mut [[f64; N]],
) -> Result<Selection> {
    let k_pool = pool.len();
    let n = obs.params.len();
    if n > P {
        return Err(Error::CapacityExceeded {
            needed: n,
            capacity: P,
        });
    }
    if m == 0 || k_pool < m {
        return Err(Error::TooFewData {
            found: k_pool,
            needed: m.max(1),
        });
    }
    if m + opts.max_excursion > MAX_DESIGN || out.len() < m {
        return Err(Error::CapacityExceeded {
            needed: m + opts.max_excursion,
            capacity: MAX_DESIGN.min(out.len() + opts.max_excursion),
        });
    }
    if opts.objective == Objective::PredictionVariance && !s.has_reference {
        return Err(Error::MissingInput {
            what: crate::error::Quantity::Setting,
        });
    }
    let min_sep2 = opts.min_separation_m * opts.min_separation_m;
    let mut rng = SplitMix64::new(opts.seed).fork(start as u64);
    let mut ev = Eval {
        s,
        n,
        unit: obs.scaling == ColumnScaling::UnitColumns,
        objective: opts.objective,
        count: 0,
    };
    let mut set = [0usize; MAX_DESIGN];
    let spaced = |set: &[usize], cand: usize| {
        min_sep2 <= 0.0
            || set
                .iter()
                .all(|&j| dist2(&pool.pos[j], &pool.pos[cand]) >= min_sep2)
    };

    // 2. Greedy initial set from a random first candidate.
    zero_gram(&mut ev.s.g, n);
    let first = rng.below(k_pool);
    let mut len = add_to(&mut ev.s.g, pool, &mut set, 0, first, n);
    ev.s.blocks[0] = pool.blocks[first];
    while len < m {
        let eligible = |cand: usize| !set[..len].contains(&cand) && spaced(&set[..len], cand);
        let best = ev.best_candidate(pool.blocks, k_pool, &eligible, Phase::Greedy, len + 1)?;
        let Some((_, cand)) = best else {
            return Err(Error::TooFewData {
                found: len,
                needed: m,
            });
        };
        ev.s.blocks[len] = pool.blocks[cand];
        len = add_to(&mut ev.s.g, pool, &mut set, len, cand, n);
    }
    copy_gram(&ev.s.g, &mut ev.s.trial, n);
    let mut cur = ev.trial(m)?;
    let initial_value = cur;

    // 3. DETMAX excursions.
    let mut exchanges = 0;
    let mut k = 1;
    while k <= opts.max_excursion && exchanges < opts.max_exchanges {
        let mut tset = set;
        let mut tlen = len;
        copy_gram(&ev.s.g, &mut ev.s.tg, n);
        let mut grown = 0;
        for _ in 0..k {
            let eligible =
                |cand: usize| !tset[..tlen].contains(&cand) && spaced(&tset[..tlen], cand);
            ev.prepare_add();
            let best = ev.best_candidate(pool.blocks, k_pool, &eligible, Phase::Add, tlen + 1)?;
            let Some((_, cand)) = best else { break };
            tset[tlen] = cand;
            tlen += 1;
            grown += 1;
            gram_update(&mut ev.s.tg, &pool.blocks[cand], n, 1.0);
        }
        for _ in 0..grown {
            let mut best: Option<(f64, usize)> = None;
            for j in 0..tlen {
                copy_gram(&ev.s.tg, &mut ev.s.trial, n);
                gram_update(&mut ev.s.trial, &pool.blocks[tset[j]], n, -1.0);
                let v = ev.trial(tlen - 1)?;
                if best.is_none_or(|(b, _)| v > b) {
                    best = Some((v, j));
                }
            }
            let Some((_, j)) = best else { break };
            gram_update(&mut ev.s.tg, &pool.blocks[tset[j]], n, -1.0);
            tset[j] = tset[tlen - 1];
            tlen -= 1;
        }
        // Exact Gram of the new set (no drift from the updates).
        zero_gram(&mut ev.s.trial, n);
        for &j in &tset[..tlen] {
            gram_update(&mut ev.s.trial, &pool.blocks[j], n, 1.0);
        }
        let v = ev.trial(tlen)?;
        let same = {
            let mut a = tset;
            let mut b = set;
            a[..tlen].sort_unstable();
            b[..len].sort_unstable();
            a[..tlen] == b[..len]
        };
        if tlen == m && !same && v > cur + 1e-12 * cur.abs() {
            set = tset;
            len = tlen;
            copy_gram(&ev.s.trial, &mut ev.s.g, n);
            cur = v;
            exchanges += 1;
            k = 1;
        } else {
            k += 1;
        }
    }
    let exchange_value = cur;

    // 4. Joint-space refinement.
    let mut cfg = [[0.0; N]; MAX_DESIGN];
    let mut pos = [[0.0; 3]; MAX_DESIGN];
    for i in 0..m {
        cfg[i] = pool.q[set[i]];
        pos[i] = pool.pos[set[i]];
        ev.s.blocks[i] = pool.blocks[set[i]];
    }
    let mut refinements = 0;
    let mut step = opts.refine_step_rad;
    let mut fails = 0;
    let mut block = [[0.0; P]; 6];
    for t in 0..opts.refine_trials {
        if step.is_nan() || step <= 1e-3 * opts.refine_step_rad {
            break;
        }
        let i = t % m;
        let mut q = cfg[i];
        for v in q.iter_mut() {
            *v += step * rng.normal();
        }
        let mut improved = false;
        if c.admits(robot, &q)? {
            let tp = pose_block(robot, &q, obs, ws, &mut block)?;
            let p = [tp.translation.x, tp.translation.y, tp.translation.z];
            let ok_sep =
                min_sep2 <= 0.0 || (0..m).all(|j| j == i || dist2(&pos[j], &p) >= min_sep2);
            if ok_sep {
                copy_gram(&ev.s.g, &mut ev.s.trial, n);
                gram_update(&mut ev.s.trial, &ev.s.blocks[i], n, -1.0);
                gram_update(&mut ev.s.trial, &block, n, 1.0);
                let v = ev.trial(m)?;
                if v > cur + 1e-12 * cur.abs() {
                    cfg[i] = q;
                    pos[i] = p;
                    ev.s.blocks[i] = block;
                    zero_gram(&mut ev.s.g, n);
                    for b in 0..m {
                        let SelectScratch { g, blocks, .. } = &mut *ev.s;
                        gram_update(g, &blocks[b], n, 1.0);
                    }
                    copy_gram(&ev.s.g, &mut ev.s.trial, n);
                    cur = ev.trial(m)?;
                    refinements += 1;
                    improved = true;
                }
            }
        }
        if improved {
            fails = 0;
        } else {
            fails += 1;
            if fails >= m {
                step *= 0.5;
                fails = 0;
            }
        }
    }
    out[..m].copy_from_slice(&cfg[..m]);
    Ok(Selection {
        value: cur,
        initial_value,
        exchange_value,
        evaluations: ev.count,
        exchanges,
        refinements,
        start,
    })
}

fn add_to<const N: usize, const P: usize>(
    g: &mut [[f64; P]; P],
    pool: &Pool<'_, N, P>,
    set: &mut [usize; MAX_DESIGN],
    len: usize,
    cand: usize,
    n: usize,
) -> usize {
    set[len] = cand;
    gram_update(g, &pool.blocks[cand], n, 1.0);
    len + 1
}

/// All starts of [`select_start`]; the best set (the lowest start on ties) goes to `out`.
#[allow(clippy::too_many_arguments)]
pub fn select_poses<const N: usize, const P: usize>(
    robot: &Robot<N>,
    pool: &Pool<'_, N, P>,
    m: usize,
    obs: &ObservabilityOptions,
    c: &Constraints,
    opts: &SelectOptions,
    ws: &mut Workspace<P>,
    s: &mut SelectScratch<P>,
    out: &mut [[f64; N]],
) -> Result<Selection> {
    let mut best: Option<Selection> = None;
    let mut cand = [[0.0; N]; MAX_DESIGN];
    for start in 0..opts.starts.max(1) {
        let sel = select_start(robot, pool, m, obs, c, opts, start, ws, s, &mut cand)?;
        if best.is_none_or(|b| sel.value > b.value) {
            out[..m].copy_from_slice(&cand[..m]);
            let evals = best.map_or(0, |b| b.evaluations);
            best = Some(Selection {
                evaluations: sel.evaluations + evals,
                ..sel
            });
        } else if let Some(b) = best.as_mut() {
            b.evaluations += sel.evaluations;
        }
    }
    best.ok_or(Error::TooFewData {
        found: 0,
        needed: 1,
    })
}

/// Options of the workspace-clustering design ([`cluster_select`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClusterOptions {
    /// The region split into cubes.
    pub region: Region,
    /// Cube side L \[m\].
    pub cube_m: f64,
    /// Largest accepted spread of the per-pose indices: `max_k |ln σ_k(q) − ln σ_k(q*)|`
    /// over the chosen poses `q` and the target pose `q*` (0.1 ≈ 10 %).
    pub tolerance: f64,
    /// Among designs within the tolerance, the one maximising this wins.
    pub objective: Objective,
}

/// The outcome of [`cluster_select`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClusterSelection {
    /// Spread of the per-pose indices of the chosen poses (see [`ClusterOptions::tolerance`]).
    pub spread: f64,
    /// Objective of the chosen set.
    pub value: f64,
    /// Pool index of the target pose whose per-pose index the others match.
    pub target: usize,
    /// Whether the spread is within the tolerance (otherwise the smallest spread found).
    pub within_tolerance: bool,
    /// Number of non-empty cubes.
    pub occupied_cubes: usize,
}

/// `max_k |ln a_k − ln b_k|`, as the logarithm of the largest ratio (one logarithm).
fn log_distance(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    let mut r = 1.0f64;
    for k in 0..6 {
        let (x, y) = (a[k].max(1e-300), b[k].max(1e-300));
        r = r.max(x / y).max(y / x);
    }
    crate::math::ln(r)
}

/// The workspace-clustering design (Section 4.2): `m` pool members in mutually different
/// cubes of side L whose per-pose indices `per_pose` (six singular values each,
/// [`crate::observability::pose_singular_values`]) are equal within the tolerance.
///
/// For every pool member as target, the member of each cube nearest to it in per-pose index
/// is found and the `m` nearest cubes are taken; among targets whose design lies within the
/// tolerance the objective decides, otherwise the smallest spread. `cube_best` is scratch of
/// at least [`Region::cube_counts`]' product entries; the chosen pool indices go to
/// `out[..m]`.
#[allow(clippy::too_many_arguments)]
pub fn cluster_select<const N: usize, const P: usize>(
    pool: &Pool<'_, N, P>,
    per_pose: &[[f64; 6]],
    m: usize,
    n_params: usize,
    unit_columns: bool,
    opts: &ClusterOptions,
    s: &mut SelectScratch<P>,
    cube_best: &mut [(f64, usize)],
    out: &mut [usize],
) -> Result<ClusterSelection> {
    let k_pool = pool.len().min(per_pose.len());
    let counts = opts.region.cube_counts(opts.cube_m);
    let n_cubes = counts[0] * counts[1] * counts[2];
    if opts.cube_m.is_nan() || opts.cube_m <= 0.0 || opts.tolerance.is_nan() || opts.tolerance < 0.0
    {
        return Err(Error::InvalidParameter {
            index: 0,
            value: opts.cube_m,
        });
    }
    if cube_best.len() < n_cubes || out.len() < m || m > MAX_DESIGN || n_params > P {
        return Err(Error::CapacityExceeded {
            needed: n_cubes.max(m),
            capacity: cube_best.len().min(out.len()),
        });
    }
    if opts.objective == Objective::PredictionVariance && !s.has_reference {
        return Err(Error::MissingInput {
            what: crate::error::Quantity::Setting,
        });
    }
    let cube = |i: usize| opts.region.cube_of(&pool.pos[i], opts.cube_m);
    let occupied_cubes = {
        for e in cube_best.iter_mut().take(n_cubes) {
            *e = (f64::INFINITY, usize::MAX);
        }
        for i in 0..k_pool {
            if let Some(c) = cube(i) {
                cube_best[c] = (0.0, i);
            }
        }
        cube_best[..n_cubes]
            .iter()
            .filter(|e| e.1 != usize::MAX)
            .count()
    };
    if occupied_cubes < m || m == 0 {
        return Err(Error::TooFewData {
            found: occupied_cubes,
            needed: m.max(1),
        });
    }
    let mut ev = Eval {
        s,
        n: n_params,
        unit: unit_columns,
        objective: opts.objective,
        count: 0,
    };
    // (within tolerance, value or −spread, spread, target, chosen)
    let mut best: Option<(bool, f64, f64, usize, [usize; MAX_DESIGN])> = None;
    for t in 0..k_pool {
        if cube(t).is_none() {
            continue;
        }
        for e in cube_best.iter_mut().take(n_cubes) {
            *e = (f64::INFINITY, usize::MAX);
        }
        for i in 0..k_pool {
            if let Some(c) = cube(i) {
                let d = log_distance(&per_pose[i], &per_pose[t]);
                if d < cube_best[c].0 {
                    cube_best[c] = (d, i);
                }
            }
        }
        // The m nearest cubes (repeated minimum; taken ones are marked with +∞).
        let mut chosen = [0usize; MAX_DESIGN];
        let mut spread = 0.0f64;
        for slot in chosen.iter_mut().take(m) {
            let mut bi = usize::MAX;
            for c in 0..n_cubes {
                if cube_best[c].1 != usize::MAX
                    && (bi == usize::MAX || cube_best[c].0 < cube_best[bi].0)
                {
                    bi = c;
                }
            }
            *slot = cube_best[bi].1;
            spread = spread.max(cube_best[bi].0);
            cube_best[bi].1 = usize::MAX;
        }
        let within = spread <= opts.tolerance;
        let key = if within {
            zero_gram(&mut ev.s.trial, n_params);
            for &i in &chosen[..m] {
                gram_update(&mut ev.s.trial, &pool.blocks[i], n_params, 1.0);
            }
            ev.trial(m)?
        } else {
            -spread
        };
        let better = match best {
            None => true,
            Some((bw, bk, ..)) => (within && !bw) || (within == bw && key > bk),
        };
        if better {
            best = Some((within, key, spread, t, chosen));
        }
    }
    let Some((within, _, spread, target, chosen)) = best else {
        return Err(Error::TooFewData {
            found: 0,
            needed: m,
        });
    };
    zero_gram(&mut ev.s.trial, n_params);
    for &i in &chosen[..m] {
        gram_update(&mut ev.s.trial, &pool.blocks[i], n_params, 1.0);
    }
    let value = ev.trial(m)?;
    out[..m].copy_from_slice(&chosen[..m]);
    Ok(ClusterSelection {
        spread,
        value,
        target,
        within_tolerance: within,
        occupied_cubes,
    })
}
