//! Inverse kinematics: damped least squares (Levenberg–Marquardt damping) within the joint
//! limits, from the caller's seed and a fixed set of further seeds; the converged solution
//! nearest the caller's seed is returned. Effects are compensated: the pose reached is
//! [`Robot::fk`] of the returned readings.

use core::f64::consts::PI;
use core::num::NonZeroU32;

use nalgebra::{ArrayStorage, SMatrix, Vector3, Vector6};

use crate::error::{Error, Quantity, Result, check_finite};
use crate::fixed3::ZERO;
use crate::kinematics::Frames;
use crate::model::{JointState, Robot};
use crate::params::CyclicTerm;

// `joint_rates` destructures a joint's cyclic terms in this order.
const _: () = assert!(
    CyclicTerm::Sin1 as usize == 0
        && CyclicTerm::Cos1 as usize == 1
        && CyclicTerm::Sin2 as usize == 2
        && CyclicTerm::Cos2 as usize == 3
);
use crate::pose::{Transform, rotation_log};

/// Options of [`solve_ik`]. Three presets: [`IkOptions::control_loop`] (seed near the answer,
/// one short descent: microseconds), [`IkOptions::global_search`] (any seed: Halton seeds,
/// short descents, first solution) and the [`Default`] (every one of 17 seeds to the end,
/// the solution nearest the seed: milliseconds). [`IkOptions::validate`] (run by [`solve_ik`]) bounds every field
/// and the total budget `(1 + extra_seeds) · max_iterations` <=
/// [`IkOptions::MAX_TOTAL_ITERATIONS`], so one call's worst case is bounded: a control loop
/// gets an error for absurd options, not a call that never returns.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkOptions {
    /// Iterations per seed, 1..=[`IkOptions::MAX_ITERATIONS`].
    pub max_iterations: u32,
    /// Convergence: position residual below this \[m\], in
    /// (0, [`IkOptions::MAX_TOL_POS_M`]].
    pub tol_pos_m: f64,
    /// Convergence: orientation residual below this \[rad\], in
    /// (0, [`IkOptions::MAX_TOL_ROT_RAD`]].
    pub tol_rot_rad: f64,
    /// Seeds tried after the caller's (a deterministic Halton sequence over the limits,
    /// clipped to ±π), 0..=[`IkOptions::MAX_EXTRA_SEEDS`], and
    /// `(1 + extra_seeds) · max_iterations` <= [`IkOptions::MAX_TOTAL_ITERATIONS`].
    pub extra_seeds: usize,
    /// Stop at the first seed that converges (faster; the answer is then the solution
    /// reached from the earliest converging seed rather than the nearest of all).
    pub first_solution: bool,
}

impl Default for IkOptions {
    fn default() -> Self {
        IkOptions {
            max_iterations: 200,
            tol_pos_m: 1e-11,
            tol_rot_rad: 1e-11,
            extra_seeds: 16,
            first_solution: false,
        }
    }
}

impl IkOptions {
    /// The control-loop preset: one damped least-squares descent from the caller's seed (the
    /// last cycle's answer, near the target), no further seeds, at most 50 iterations.
    /// From seeds within 5° of an answer it converges in 4 iterations (median; 9 at the
    /// 99th percentile on ARIA, 16 on a 7R arm) to the default tolerances, a few
    /// microseconds; it never jumps to another branch. When it returns
    /// [`Error::Unreachable`] (rarely: the answer touches a joint limit or a singularity, about
    /// 1 to 4 in 1,000 random cases in `tests/ik_fast.rs`), fall back to
    /// [`IkOptions::global_search`].
    #[must_use]
    pub const fn control_loop() -> Self {
        IkOptions {
            max_iterations: 50,
            tol_pos_m: 1e-11,
            tol_rot_rad: 1e-11,
            extra_seeds: 0,
            first_solution: true,
        }
    }

    /// The global-search preset, for a target whose branch is unknown (no good seed). Seed
    /// strategy: the caller's seed first, then up to 128 seeds of the Halton sequence over
    /// the joint ranges (clipped to ±π; low-discrepancy, so every branch of the workspace is
    /// visited early), each descent cut off after 20 iterations, stopping at the first that
    /// converges. The cut-off is what makes it fast: a descent that converges from a random
    /// start does so in about 10 iterations (19 at the 99th percentile on ARIA and a 7R
    /// arm), one that has not by 20 is mostly stuck in a local minimum or against a limit,
    /// and a fresh seed is cheaper than waiting (the default spends up to 200 iterations on
    /// each of its 17 seeds). The answer is the first solution found, not the one nearest
    /// the seed. Found a solution for 1,000 of 1,000 random reachable targets of ARIA and 999 of
    /// 1,000 of a 7R arm (`tests/ik_fast.rs`; the default: 997 of the same 1,000 on ARIA).
    #[must_use]
    pub const fn global_search() -> Self {
        IkOptions {
            max_iterations: 20,
            tol_pos_m: 1e-11,
            tol_rot_rad: 1e-11,
            extra_seeds: 128,
            first_solution: true,
        }
    }

    /// Largest `max_iterations`: 5x the default; a descent that has not converged by then
    /// is stuck (a control loop must get an error, not a watchdog reset).
    pub const MAX_ITERATIONS: u32 = 1000;
    /// Largest `extra_seeds`: 16x the default (with `max_iterations` small enough for
    /// [`IkOptions::MAX_TOTAL_ITERATIONS`]).
    pub const MAX_EXTRA_SEEDS: usize = 256;
    /// Largest `(1 + extra_seeds) · max_iterations`: about 6x the default's 3,400 damped
    /// steps (each a few FK evaluations), so a call that never converges still ends in a
    /// bounded time (measured in kincal-ffi's `ik_at_the_bounds_finishes_in_bounded_time`).
    pub const MAX_TOTAL_ITERATIONS: u64 = 20_000;
    /// Largest position tolerance \[m\] (a looser one accepts any pose).
    pub const MAX_TOL_POS_M: f64 = 1.0;
    /// Largest orientation tolerance \[rad\].
    pub const MAX_TOL_ROT_RAD: f64 = core::f64::consts::PI;

    /// Checks every field against its documented bounds: [`Error::InvalidOption`] naming
    /// the field and its value otherwise (a NaN or infinite tolerance included).
    pub fn validate(&self) -> Result<()> {
        let bad = |option: &'static str, value: f64| Err(Error::InvalidOption { option, value });
        if !(1..=Self::MAX_ITERATIONS).contains(&self.max_iterations) {
            return bad("max_iterations", f64::from(self.max_iterations));
        }
        if self.extra_seeds > Self::MAX_EXTRA_SEEDS {
            // (usize as f64 rounds for huge counts; it only reports the value)
            #[allow(clippy::cast_precision_loss)]
            return bad("extra_seeds", self.extra_seeds as f64);
        }
        // `!(x > 0 && x <= max)` also refuses NaN.
        let total = (self.extra_seeds as u64)
            .saturating_add(1)
            .saturating_mul(u64::from(self.max_iterations));
        if total > Self::MAX_TOTAL_ITERATIONS {
            // (the budget names the seeds: the more likely of the two to be raised)
            #[allow(clippy::cast_precision_loss)]
            return bad("extra_seeds", self.extra_seeds as f64);
        }
        if !(self.tol_pos_m > 0.0 && self.tol_pos_m <= Self::MAX_TOL_POS_M) {
            return bad("tol_pos_m", self.tol_pos_m);
        }
        if !(self.tol_rot_rad > 0.0 && self.tol_rot_rad <= Self::MAX_TOL_ROT_RAD) {
            return bad("tol_rot_rad", self.tol_rot_rad);
        }
        Ok(())
    }
}

/// A solution of [`solve_ik`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkSolution<const N: usize> {
    /// Joint readings \[rad\], within the limits.
    pub q: [f64; N],
    /// Position residual \[m\].
    pub residual_pos_m: f64,
    /// Orientation residual \[rad\].
    pub residual_rot_rad: f64,
    /// Iterations used for the chosen seed.
    pub iterations: u32,
    /// Which seed converged to it (0 = the caller's).
    pub seed_index: usize,
}

/// The Halton bases, one per joint (cycled): non-zero by type, so `%` and `/` by them have no
/// division-by-zero panic path for the optimiser to prove away.
const PRIMES: [NonZeroU32; 20] = {
    let p = [
        2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53, 59, 61, 67, 71,
    ];
    let mut out = [NonZeroU32::MIN; 20];
    let mut k = 0;
    while k < 20 {
        out[k] = match NonZeroU32::new(p[k]) {
            Some(v) => v,
            None => panic!("Halton bases are primes"),
        };
        k += 1;
    }
    out
};

fn halton(index: u32, base: NonZeroU32) -> f64 {
    let (mut f, mut r, mut i) = (1.0, 0.0, index);
    while i > 0 {
        f /= f64::from(base.get());
        r += f * f64::from(i % base);
        i /= base;
    }
    r
}

/// Solves `fk(q) = target` for readings `q` within the joint limits.
///
/// Sensor joints ([`crate::JointKind::Sensor`]) are not commanded: they stay at the seed's
/// reading (the tilt the sensor reports now), and the commanded joints compensate for it.
///
/// `seed` supplies the start configuration and, for models with backlash or thermal
/// effects, the approach directions and temperature to compensate. Returns the converged
/// configuration nearest to `seed.q` (joints whose range spans more than 2π are shifted by
/// ±2π towards the seed when that stays within limits), or [`Error::Unreachable`] with the
/// best residual found. Options outside their bounds are [`Error::InvalidOption`].
///
/// ```
/// use kincal::{aria, ik::{solve_ik, IkOptions}, JointState};
/// let robot = aria::nominal();
/// let target = aria::tool_pose(0).unwrap();
/// let sol = solve_ik(&robot, &target, &JointState::new(aria::TOOL_SEED_Q), &IkOptions::default()).unwrap();
/// assert!(sol.residual_pos_m < 1e-9);
/// ```
pub fn solve_ik<const N: usize>(
    robot: &Robot<N>,
    target: &Transform,
    seed: &JointState<N>,
    opts: &IkOptions,
) -> Result<IkSolution<N>> {
    seed.validate()?;
    let t = target.translation.vector;
    check_finite(t.as_slice(), Quantity::Position)?;
    check_finite(target.rotation.matrix().as_slice(), Quantity::Orientation)?;
    // (a NaN tolerance stays NonFinite, as every other non-finite input)
    check_finite(&[opts.tol_pos_m, opts.tol_rot_rad], Quantity::Setting)?;
    opts.validate()?;
    let limits = robot.limits();
    let mut best: Option<IkSolution<N>> = None;
    let mut best_dist = f64::INFINITY;
    let mut best_residual = (f64::INFINITY, f64::INFINITY);
    for s in 0..=opts.extra_seeds {
        let mut start = seed.q;
        if s > 0 {
            let bases = PRIMES.iter().cycle();
            let kinds = robot.joint_kinds();
            let commanded = start.iter_mut().zip(limits.iter()).zip(kinds);
            for (((v, lim), kind), &base) in commanded.zip(bases) {
                if kind == crate::JointKind::Sensor {
                    continue;
                }
                let lo = lim.lower.max(-PI);
                let hi = lim.upper.min(PI);
                // (s <= MAX_EXTRA_SEEDS, validated: the cast is exact)
                let u = halton(s as u32, base);
                *v = if hi > lo {
                    lo + u * (hi - lo)
                } else {
                    lim.lower
                };
            }
        }
        let mut st = *seed;
        st.q = start;
        let (sol, res) = descend(robot, target, st, opts)?;
        if res.0 + res.1 < best_residual.0 + best_residual.1 {
            best_residual = res;
        }
        if let Some(mut sol) = sol {
            sol.seed_index = s;
            shift_towards(&mut sol.q, &seed.q, robot);
            let dist: f64 = sol
                .q
                .iter()
                .zip(seed.q.iter())
                .map(|(a, b)| (a - b) * (a - b))
                .sum();
            if dist < best_dist {
                best_dist = dist;
                best = Some(sol);
            }
            if opts.first_solution {
                break;
            }
        }
    }
    best.ok_or(Error::Unreachable {
        residual_pos_m: best_residual.0,
        residual_rot_rad: best_residual.1,
    })
}

/// Moves joints by ±2π towards `seed` where the limits allow (same pose, nearer readings).
/// Joints with a scale error are left alone: Δθ_j = k_j·q_j is not 2π-periodic, so the
/// shifted reading would reach a different pose; so are prismatic joints (a slide) and
/// sensor joints (held at their reading).
fn shift_towards<const N: usize>(q: &mut [f64; N], seed: &[f64; N], robot: &Robot<N>) {
    let joints = seed
        .iter()
        .zip(robot.limits().iter())
        .zip(robot.effect_params().scale.iter())
        .zip(robot.joint_kinds());
    for (qj, (((&seed_j, lim), &scale), kind)) in q.iter_mut().zip(joints) {
        if scale != 0.0 || kind != crate::JointKind::Revolute {
            continue;
        }
        for k in [-2.0 * PI, 2.0 * PI] {
            let cand = *qj + k;
            if lim.contains(cand) && (cand - seed_j).abs() < (*qj - seed_j).abs() {
                *qj = cand;
            }
        }
    }
}

fn residual<const N: usize>(
    robot: &Robot<N>,
    target: &Transform,
    state: &JointState<N>,
    frames: &mut Frames<N>,
) -> Result<Vector6<f64>> {
    robot.fk_frames(state, frames)?;
    let dp = target.translation.vector - frames.t_base_ee.translation.vector;
    let dr = rotation_log(&crate::fixed3::mat_mul(
        target.rotation.matrix(),
        &frames.t_base_ee.rotation.matrix().transpose(),
    ));
    Ok(Vector6::new(dp.x, dp.y, dp.z, dr.x, dr.y, dr.z))
}

type Outcome<const N: usize> = (Option<IkSolution<N>>, (f64, f64));

/// One damped least-squares descent from `state.q`, projected onto the limits.
fn descend<const N: usize>(
    robot: &Robot<N>,
    target: &Transform,
    mut state: JointState<N>,
    opts: &IkOptions,
) -> Result<Outcome<N>> {
    let limits = robot.limits();
    let clamp = |q: &mut [f64; N]| {
        for (v, l) in q.iter_mut().zip(limits.iter()) {
            // Not `clamp`: its `lower <= upper` assertion is a panic path the compiler cannot
            // remove (the limits were validated when the robot was built).
            *v = v.max(l.lower).min(l.upper);
        }
    };
    clamp(&mut state.q);
    let mut frames = Frames::default();
    let mut e = residual(robot, target, &state, &mut frames)?;
    let mut lambda = 1e-6;
    let norms = |e: &Vector6<f64>| {
        let [[px, py, pz, rx, ry, rz]] = e.data.0;
        (
            crate::fixed3::norm(&Vector3::new(px, py, pz)),
            crate::fixed3::norm(&Vector3::new(rx, ry, rz)),
        )
    };
    for it in 0..opts.max_iterations {
        let (ep, er) = norms(&e);
        if ep < opts.tol_pos_m && er < opts.tol_rot_rad {
            return Ok((
                Some(IkSolution {
                    q: state.q,
                    residual_pos_m: ep,
                    residual_rot_rad: er,
                    iterations: it,
                    seed_index: 0,
                }),
                (ep, er),
            ));
        }
        let mut j = joint_jacobian(robot, &state, &frames);
        // Sensor joints are read, not commanded: the step leaves them at the seed's reading.
        for (col, kind) in j.data.0.iter_mut().zip(robot.joint_kinds()) {
            if kind == crate::JointKind::Sensor {
                *col = [0.0; 6];
            }
        }
        // fixed3's products and solve: nalgebra's (bit for bit) without its asserting
        // accessors, which stay panic paths at opt-level z.
        let jjt = crate::fixed3::gram_rows(&j);
        let mut accepted = false;
        while lambda < 1e9 {
            // JJᵀ + λ·I, entry by entry as nalgebra adds `identity() * λ` (+0 off the diagonal).
            let mut damped = jjt;
            for (c, column) in damped.data.0.iter_mut().enumerate() {
                for (r, v) in column.iter_mut().enumerate() {
                    *v += if r == c { lambda } else { 0.0 };
                }
            }
            let Some(step) = crate::fixed3::cholesky_solve6(&damped, &e) else {
                lambda *= 10.0;
                continue;
            };
            let dq = crate::fixed3::transpose_mul(&j, &step);
            let mut trial = state;
            for (v, d) in trial.q.iter_mut().zip(dq.iter()) {
                *v += d;
            }
            clamp(&mut trial.q);
            let mut f2 = Frames::default();
            let e2 = residual(robot, target, &trial, &mut f2)?;
            if crate::fixed3::norm_squared6(&e2) < crate::fixed3::norm_squared6(&e) {
                state = trial;
                e = e2;
                frames = f2;
                lambda = (lambda * 0.1).max(1e-12);
                accepted = true;
                break;
            }
            lambda *= 10.0;
        }
        if !accepted {
            break;
        }
    }
    Ok((None, norms(&e)))
}

/// The 6×N Jacobian of the pose with respect to the readings: the θ0 columns times
/// dθ_j/dq_j of the scale and cyclic effects, or for a prismatic joint `[z_{j−1}; 0]` times
/// (1 + scale) (compliance's dependence on q is neglected; it only slows convergence
/// slightly).
pub(crate) fn joint_jacobian<const N: usize>(
    robot: &Robot<N>,
    state: &JointState<N>,
    f: &Frames<N>,
) -> SMatrix<f64, 6, N> {
    // Frame j−1 of joint j: frame 0, then each link's frame but the last.
    let mut preceding = [(ZERO, ZERO); N];
    let frames = core::iter::once(&f.t_base_0).chain(f.t_base_link.iter());
    for (slot, t) in preceding.iter_mut().zip(frames) {
        *slot = (
            crate::math::column3(t.rotation.matrix(), 2),
            t.translation.vector,
        );
    }
    let mut j = SMatrix::<f64, 6, N>::from_array_storage(ArrayStorage([[0.0; 6]; N]));
    joint_jacobian_columns(
        robot,
        state,
        &f.t_base_ee.translation.vector,
        &preceding,
        &mut j.data.0,
    );
    j
}

/// [`joint_jacobian`]'s columns from each joint's preceding frame `(z_{j−1}, p_{j−1})` (base
/// axes) and the tool origin `pe`: callers that keep only those (not every [`Frames`] entry)
/// get the same bits.
pub(crate) fn joint_jacobian_columns<const N: usize>(
    robot: &Robot<N>,
    state: &JointState<N>,
    pe: &Vector3<f64>,
    preceding: &[(Vector3<f64>, Vector3<f64>); N],
    columns: &mut [[f64; 6]; N],
) {
    let rates = joint_rates(robot, &state.q);
    // Iterators over fixed-size arrays rather than indices: no per-column look at the
    // joints' effects ([`joint_rates`]), and no bounds checks to stay as panic paths where
    // the optimiser does not inline (opt-level s/z, the firmware target).
    let joints = preceding.iter().zip(rates).zip(robot.turn_mask());
    for (column, ((&(z_prev, p_prev), dtheta), turn)) in columns.iter_mut().zip(joints) {
        // Revolute: [z × (p_e − p); z]·dθ/dq; prismatic: [z; 0]·(1 + scale).
        let lin = (z_prev.cross(&(pe - p_prev)) * turn + z_prev * (1.0 - turn)) * dtheta;
        let ang = z_prev * (dtheta * turn);
        *column = [lin.x, lin.y, lin.z, ang.x, ang.y, ang.z];
    }
}

/// dθ_j/dq_j at the readings `q`: 1 + the scale effect + the cyclic effect's derivative.
/// Without cyclic terms (the usual model) no joint's derivative is evaluated; with them,
/// every joint's is (a joint without terms adds a zero, which leaves the sum's bits as they
/// are), so no branch per joint.
fn joint_rates<const N: usize>(robot: &Robot<N>, q: &[f64; N]) -> [f64; N] {
    let e = robot.effect_params();
    let mut rates = [1.0; N];
    for (rate, &scale) in rates.iter_mut().zip(&e.scale) {
        *rate = 1.0 + scale;
    }
    if crate::model::any_non_zero(e.cyclic.as_flattened()) {
        for ((rate, &q), c) in rates.iter_mut().zip(q).zip(&e.cyclic) {
            let (s1, c1) = crate::math::sin_cos(q);
            let [sin1, cos1, sin2, cos2] = *c;
            *rate +=
                sin1 * c1 - cos1 * s1 + 2.0 * sin2 * (c1 * c1 - s1 * s1) - 4.0 * cos2 * s1 * c1;
        }
    }
    rates
}
