//! Monte-Carlo evaluation of a data-acquisition design (Section 4.4, Fig. 7): one run draws
//! a random "true" robot, simulates the design's measurements on it, identifies the
//! parameters from the nominal model, and measures the identified model's errors over a
//! validation set of configurations inside the working region.
//!
//! Everything of one run follows from `(seed, run)`: the true robot from stream 1 of
//! `SplitMix64::new(seed).fork(run)`, measurement noise of pose `l` from stream 2 forked by
//! `l`, the tool's manufacturing error of pose `l` from stream 3 forked by `l`. So every
//! design of a study sees the same robots (common random numbers), and a parallel caller
//! gets the same numbers whatever its thread count.
//!
//! Two kinds of acquisition ([`Acquisition`]):
//! - **Instrument**: the robot is commanded to the design's configurations and an external
//!   instrument (motion capture, laser tracker) measures the pose: readings `q` exact,
//!   measured pose = true pose + noise.
//! - **Tool**: the end effector is mated with the reference poses of a calibration tool and
//!   the readings are recorded: the physical pose is the drawing's pose plus the tool's
//!   manufacturing error and a seating noise, the readings follow from the true robot's
//!   inverse kinematics there, and the identification uses the drawing's pose.
//!
//! The errors of a run are those of the identified model against the true robot at the
//! validation configurations: `e_p = |p_true(q) − p_id(q)|`, `e_φ` = angle of
//! `R_true(q)·R_id(q)ᵀ`, summarised by their maximum and RMS over the validation set.

use nalgebra::{Cholesky, SMatrix, SVector, Vector3};

use crate::error::{Error, ParamIndex, Result};
use crate::identify::{
    Algorithm, Identifiability, IdentifyOptions, Measurement, Workspace, analyze,
    identify_with_analysis,
};
use crate::model::{JointState, Robot};
use crate::params::{ParamId, ParamSet};
use crate::pose::{OrientationError, Transform, pose_error, rotation_exp, transform};
use crate::rng::SplitMix64;

/// How the design's poses are measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Acquisition {
    /// Commanded configurations, poses measured by an external instrument.
    Instrument,
    /// Reference poses of a calibration tool, readings recorded at mating.
    Tool,
}

/// The random ingredients of a study. Defaults ([`Scenario::paper`]) are the paper's
/// manufacturing errors and **assumed** measurement figures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scenario {
    /// Each identified length parameter is off by a uniform error in ± this \[m\].
    pub length_error_m: f64,
    /// Each identified angle parameter is off by a uniform error in ± this \[rad\].
    pub angle_error_rad: f64,
    /// Measurement (instrument) or seating (tool) noise, 1σ per axis of position \[m\].
    pub noise_pos_m: f64,
    /// … and of the rotation vector \[rad\].
    pub noise_rot_rad: f64,
    /// Tool designs: manufacturing error of each reference pose, uniform in ± this per
    /// position axis \[m\] …
    pub tool_tol_pos_m: f64,
    /// … and per rotation-vector axis \[rad\].
    pub tool_tol_rot_rad: f64,
}

impl Scenario {
    /// Section 2.4's errors (5 mm, 5°) and **assumed** metrology: 0.05 mm and 0.02° (1σ per
    /// axis) of noise, a static pose averaged over many frames of an optical tracker with a
    /// marker probe (or the seating repeatability of a tool); a tool machined to ±0.05 mm
    /// and ±0.02°. The paper gives no noise figures; errors after calibration scale about
    /// linearly with these.
    #[must_use]
    pub const fn paper() -> Self {
        Scenario {
            length_error_m: 5e-3,
            angle_error_rad: 5.0 * core::f64::consts::PI / 180.0,
            noise_pos_m: 5e-5,
            noise_rot_rad: 0.02 * core::f64::consts::PI / 180.0,
            tool_tol_pos_m: 5e-5,
            tool_tol_rot_rad: 0.02 * core::f64::consts::PI / 180.0,
        }
    }
    fn check(&self) -> Result<()> {
        let v = [
            self.length_error_m,
            self.angle_error_rad,
            self.noise_pos_m,
            self.noise_rot_rad,
            self.tool_tol_pos_m,
            self.tool_tol_rot_rad,
        ];
        if let Some(index) = v.iter().position(|x| !(x.is_finite() && *x >= 0.0)) {
            return Err(Error::InvalidParameter {
                index,
                value: v[index],
            });
        }
        Ok(())
    }
}

/// A design to evaluate.
#[derive(Debug, Clone, Copy)]
pub struct Design<'a, const N: usize> {
    /// How its poses are measured.
    pub acquisition: Acquisition,
    /// Nominal configurations: the commanded ones (instrument), or the nominal model's
    /// inverse kinematics of the reference poses (tool; the start of the true robot's IK).
    pub q: &'a [[f64; N]],
    /// Tool designs: the reference poses of the drawing (same length as `q`).
    pub reference: &'a [Transform],
}

/// What every design of a study shares.
#[derive(Debug, Clone, Copy)]
pub struct Study<'a, const N: usize> {
    /// The nominal model (the start of identification and of the random robots).
    pub nominal: Robot<N>,
    /// Identified parameters (and the ones perturbed in the random robots).
    pub params: ParamSet,
    /// Validation configurations.
    pub validation_q: &'a [[f64; N]],
    /// `[sin q_j, cos q_j]` of the validation configurations ([`joint_sincos`]), so the
    /// validation FK needs no trigonometry; empty: computed per run.
    pub validation_sincos: &'a [[[f64; 2]; N]],
    /// The nominal model's poses there, for the errors before calibration; empty: those
    /// are not computed (they are the same for every design of a study).
    pub validation_nominal: &'a [Transform],
    /// Random ingredients.
    pub scenario: Scenario,
    /// Seed of the study.
    pub seed: u64,
}

/// Errors of one run [m, rad].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RunResult {
    /// Largest e_p over the validation set after calibration.
    pub max_pos_m: f64,
    /// Largest e_φ.
    pub max_rot_rad: f64,
    /// RMS of e_p.
    pub rms_pos_m: f64,
    /// RMS of e_φ.
    pub rms_rot_rad: f64,
    /// Largest e_p of the nominal model (before calibration).
    pub before_max_pos_m: f64,
    /// Largest e_φ of the nominal model.
    pub before_max_rot_rad: f64,
    /// Gauss–Newton iterations.
    pub iterations: u32,
}

/// The identification options of a study: OLS (the paper's main algorithm) on the study's
/// parameters, no covariance, tolerances that stop well below any measurement noise.
#[must_use]
pub fn identify_options<const N: usize>(study: &Study<'_, N>) -> IdentifyOptions<'static> {
    let mut o = IdentifyOptions::new(Algorithm::Ols, study.params);
    o.covariance = false;
    o.xtol = 1e-5;
    o.ftol = 1e-6;
    o.max_iterations = 50;
    o
}

/// The identifiability analysis of a design at the nominal model, done once per design
/// (the runs reuse it). Fails when the design does not determine every parameter.
pub fn prepare<const N: usize, const P: usize>(
    study: &Study<'_, N>,
    design: &Design<'_, N>,
    ws: &mut Workspace<P>,
    data: &mut [Measurement<N>],
) -> Result<Identifiability> {
    study.scenario.check()?;
    let m = design.q.len();
    if data.len() < m || (design.acquisition == Acquisition::Tool && design.reference.len() != m) {
        return Err(Error::DimensionMismatch {
            expected: m,
            found: data.len().min(design.reference.len()),
        });
    }
    let nv = study.validation_q.len();
    for len in [
        study.validation_nominal.len(),
        study.validation_sincos.len(),
    ] {
        if len != 0 && len != nv {
            return Err(Error::DimensionMismatch {
                expected: nv,
                found: len,
            });
        }
    }
    for (d, q) in data.iter_mut().zip(design.q.iter()) {
        *d = Measurement::new(*q, study.nominal.fk_q(q)?);
    }
    let a = analyze(&study.nominal, &data[..m], &identify_options(study), ws)?;
    if !a.data_deficient.is_empty() || a.rank == 0 {
        return Err(Error::RankDeficient {
            rank: a.rank,
            required: a.requested.len() - a.structural.len(),
        });
    }
    Ok(a)
}

/// The random true robot of run `run`: every parameter of `study.params` off by a uniform
/// error (lengths ± `length_error_m`, others ± `angle_error_rad`).
pub fn random_robot<const N: usize>(study: &Study<'_, N>, run: u64) -> Result<Robot<N>> {
    let mut rng = SplitMix64::new(study.seed).fork(run).fork(1);
    let mut r = study.nominal;
    let s = &study.scenario;
    for i in study.params.iter() {
        let id = ParamId::from_index(ParamIndex(i), N)?;
        let half = if id.is_length() {
            s.length_error_m
        } else {
            s.angle_error_rad
        };
        let v = r.param(ParamIndex(i))?;
        r.set_param(ParamIndex(i), v + rng.range(-half, half))?;
    }
    Ok(r)
}

/// `t` moved by `dp` and turned by the rotation vector `dr` (in the base frame).
fn perturb(t: &Transform, dp: Vector3<f64>, dr: Vector3<f64>) -> Transform {
    transform(
        rotation_exp(&dr) * t.rotation.matrix(),
        t.translation.vector + dp,
    )
}

fn normal3(rng: &mut SplitMix64, s: f64) -> Vector3<f64> {
    Vector3::new(rng.normal(), rng.normal(), rng.normal()) * s
}

fn uniform3(rng: &mut SplitMix64, h: f64) -> Vector3<f64> {
    Vector3::new(rng.range(-h, h), rng.range(-h, h), rng.range(-h, h))
}

/// The readings at which `robot` (a true robot near the nominal one) reaches `target`, on the
/// branch of the nominal solution `q0`: Newton's method (quadratic convergence from `q0` in
/// 3–4 steps), and the damped, multi-seed [`crate::ik::solve_ik`] where Newton fails (near
/// a singularity). A solution outside the joint limits is [`Error::OutOfLimits`]; no
/// solution is [`Error::Unreachable`].
pub fn reach_true<const N: usize>(
    robot: &Robot<N>,
    target: &Transform,
    q0: &[f64; N],
) -> Result<[f64; N]> {
    // Newton's answer counts only on the branch of `q0`: a step through a near-singular
    // Jacobian can land on an equivalent but distant solution.
    let newton = newton_ik(robot, target, q0)
        .ok()
        .map(|q| nearest_turn(robot, q, q0))
        .filter(|q| {
            q.iter()
                .zip(q0.iter())
                .all(|(a, b)| (a - b).abs() < BRANCH_RAD)
        });
    let q = match newton {
        Some(q) => q,
        None => {
            let opts = crate::ik::IkOptions {
                first_solution: true,
                tol_pos_m: 1e-12,
                tol_rot_rad: 1e-12,
                ..crate::ik::IkOptions::default()
            };
            let q = crate::ik::solve_ik(robot, target, &JointState::new(*q0), &opts)?.q;
            nearest_turn(robot, q, q0)
        }
    };
    robot.check_limits(&q)?;
    Ok(q)
}

/// A joint of a true robot moves less than this from the nominal solution (manufacturing
/// errors of a few millimetres and degrees, away from singularities) \[rad\].
const BRANCH_RAD: f64 = 0.5;

/// `q` with every joint shifted by whole turns to the reading nearest `q0` that lies within
/// the limits (the same pose).
fn nearest_turn<const N: usize>(robot: &Robot<N>, mut q: [f64; N], q0: &[f64; N]) -> [f64; N] {
    const TURN: f64 = 2.0 * core::f64::consts::PI;
    for ((v, l), &r) in q.iter_mut().zip(robot.limits().iter()).zip(q0.iter()) {
        let k = libm::round((r - *v) / TURN);
        let mut best = *v;
        for dk in [0.0, -1.0, 1.0] {
            let c = *v + (k + dk) * TURN;
            let inside = l.contains(c);
            let better = !l.contains(best) || (c - r).abs() < (best - r).abs();
            if inside && better {
                best = c;
            }
        }
        *v = best;
    }
    q
}

/// Whether the tool pose `target` (nominal solution `q0`) is reached within the joint limits
/// by `robots` random robots of the study's error level (drawn from a stream of their own,
/// so a design check does not reuse the evaluation's robots): a reachability margin for
/// manufacturing errors.
pub fn robustly_reachable<const N: usize>(
    study: &Study<'_, N>,
    target: &Transform,
    q0: &[f64; N],
    robots: u64,
) -> Result<bool> {
    let probe = Study {
        seed: study.seed ^ 0x005E_ED0F_7001,
        ..*study
    };
    for k in 0..robots {
        let truth = random_robot(&probe, k)?;
        match reach_true(&truth, target, q0) {
            Ok(_) => {}
            Err(Error::Unreachable { .. } | Error::OutOfLimits { .. }) => return Ok(false),
            Err(e) => return Err(e),
        }
    }
    Ok(true)
}

fn newton_ik<const N: usize>(
    robot: &Robot<N>,
    target: &Transform,
    q0: &[f64; N],
) -> Result<[f64; N]> {
    let mut st = JointState::new(*q0);
    let mut frames = crate::kinematics::Frames::default();
    for _ in 0..30 {
        robot.fk_frames(&st, &mut frames)?;
        let e = pose_error(target, &frames.t_base_ee, OrientationError::Exact);
        let en = e.iter().map(|v| v * v).sum::<f64>();
        // 1e-10 m / rad: far below any simulated noise or tolerance.
        if en < 1e-20 {
            return Ok(st.q);
        }
        let j = crate::ik::joint_jacobian(robot, &st, &frames);
        if N == 6 {
            // Square: Gaussian elimination with partial pivoting on [J | e].
            let mut a = [[0.0; 7]; 6];
            for (r, row) in a.iter_mut().enumerate() {
                for c in 0..6 {
                    row[c] = j[(r, c)];
                }
                row[6] = e[r];
            }
            let dq = solve6(&mut a).ok_or(Error::NotConverged { iterations: 0 })?;
            for (k, v) in st.q.iter_mut().enumerate() {
                *v += dq[k];
            }
            // Quadratic convergence: after a step below 1e-8 rad the residual is of order
            // 1e-15, far below the 1e-10 test, so the check would only cost an FK.
            if dq.iter().all(|d| d.abs() < 1e-8) {
                return Ok(st.q);
            }
        } else {
            let jjt = j * j.transpose() + SMatrix::<f64, 6, 6>::identity() * 1e-14;
            let Some(ch) = Cholesky::new(jjt) else {
                break;
            };
            let dq: SVector<f64, N> = j.transpose() * ch.solve(&SVector::<f64, 6>::from(e));
            for (k, v) in st.q.iter_mut().enumerate() {
                *v += dq[k];
            }
        }
    }
    Err(Error::NotConverged { iterations: 30 })
}

/// Solves the 6×6 system `[A | b]` in place (partial pivoting); `None` when a pivot is
/// below 1e-12 of the largest entry (near-singular: the caller falls back to damped IK).
fn solve6(a: &mut [[f64; 7]; 6]) -> Option<[f64; 6]> {
    let mut scale = 0.0f64;
    for row in a.iter() {
        for v in &row[..6] {
            scale = scale.max(v.abs());
        }
    }
    let tiny = 1e-12 * scale;
    for k in 0..6 {
        let mut p = k;
        for r in (k + 1)..6 {
            if a[r][k].abs() > a[p][k].abs() {
                p = r;
            }
        }
        if a[p][k].is_nan() || a[p][k].abs() <= tiny {
            return None;
        }
        if p != k {
            a.swap(k, p);
        }
        let inv = 1.0 / a[k][k];
        for r in (k + 1)..6 {
            let f = a[r][k] * inv;
            if f != 0.0 {
                for c in (k + 1)..7 {
                    a[r][c] -= f * a[k][c];
                }
            }
        }
    }
    let mut x = [0.0; 6];
    for k in (0..6).rev() {
        let mut s = a[k][6];
        for c in (k + 1)..6 {
            s -= a[k][c] * x[c];
        }
        x[k] = s / a[k][k];
    }
    Some(x)
}

/// Fills `data[..m]` with run `run`'s measurements of `design` on `truth`.
pub fn simulate_measurements<const N: usize>(
    study: &Study<'_, N>,
    design: &Design<'_, N>,
    truth: &Robot<N>,
    run: u64,
    data: &mut [Measurement<N>],
) -> Result<()> {
    let base = SplitMix64::new(study.seed).fork(run);
    let (noise, tol) = (base.fork(2), base.fork(3));
    let s = &study.scenario;
    for (l, q) in design.q.iter().enumerate() {
        let mut nr = noise.fork(l as u64);
        let dn = (
            normal3(&mut nr, s.noise_pos_m),
            normal3(&mut nr, s.noise_rot_rad),
        );
        let slot = data.get_mut(l).ok_or(Error::CapacityExceeded {
            needed: design.q.len(),
            capacity: l,
        })?;
        *slot = match design.acquisition {
            Acquisition::Instrument => Measurement::new(*q, perturb(&truth.fk_q(q)?, dn.0, dn.1)),
            Acquisition::Tool => {
                let drawing = design.reference.get(l).ok_or(Error::DimensionMismatch {
                    expected: design.q.len(),
                    found: design.reference.len(),
                })?;
                let mut tr = tol.fork(l as u64);
                let made = perturb(
                    drawing,
                    uniform3(&mut tr, s.tool_tol_pos_m),
                    uniform3(&mut tr, s.tool_tol_rot_rad),
                );
                let physical = perturb(&made, dn.0, dn.1);
                Measurement::new(reach_true(truth, &physical, q)?, *drawing)
            }
        };
    }
    Ok(())
}

/// `[sin q_j, cos q_j]` of a configuration (for [`Study::validation_sincos`]).
#[must_use]
pub fn joint_sincos<const N: usize>(q: &[f64; N]) -> [[f64; 2]; N] {
    q.map(|v| {
        let (s, c) = crate::math::sin_cos(v);
        [s, c]
    })
}

/// Position error |p_a − p_b| and rotation angle of `R_a·R_bᵀ` (atan2 of the sine and
/// cosine parts, accurate for every angle).
fn errors(a: &Transform, b: &Transform) -> (f64, f64) {
    let dp = (a.translation.vector - b.translation.vector).norm();
    let m = a.rotation.matrix() * b.rotation.matrix().transpose();
    let v = Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    );
    let angle = crate::math::atan2(0.5 * v.norm(), 0.5 * (m.trace() - 1.0));
    (dp, angle)
}

/// FK at validation pose `k` from its precomputed sines and cosines where possible.
fn fk_at<const N: usize>(study: &Study<'_, N>, robot: &Robot<N>, k: usize) -> Result<Transform> {
    let q = &study.validation_q[k];
    match study.validation_sincos.get(k) {
        Some(sc) => robot.fk_sincos(sc).or_else(|_| robot.fk_q(q)),
        None => robot.fk_sincos(&joint_sincos(q)).or_else(|_| robot.fk_q(q)),
    }
}

/// The validation errors of `model` against `truth` (and of the nominal model, when the
/// study carries its poses).
pub fn validation_errors<const N: usize>(
    study: &Study<'_, N>,
    truth: &Robot<N>,
    model: &Robot<N>,
) -> Result<RunResult> {
    let mut r = RunResult::default();
    let (mut sp, mut sr) = (0.0, 0.0);
    for k in 0..study.validation_q.len() {
        let t_true = fk_at(study, truth, k)?;
        let (ep, er) = errors(&t_true, &fk_at(study, model, k)?);
        if let Some(tn) = study.validation_nominal.get(k) {
            let (bp, br) = errors(&t_true, tn);
            r.before_max_pos_m = r.before_max_pos_m.max(bp);
            r.before_max_rot_rad = r.before_max_rot_rad.max(br);
        }
        r.max_pos_m = r.max_pos_m.max(ep);
        r.max_rot_rad = r.max_rot_rad.max(er);
        sp += ep * ep;
        sr += er * er;
    }
    let k = study.validation_q.len().max(1) as f64;
    r.rms_pos_m = crate::math::sqrt(sp / k);
    r.rms_rot_rad = crate::math::sqrt(sr / k);
    Ok(r)
}

/// One run: random robot `run`, its measurements of `design`, OLS identification from the
/// nominal model with the prepared `analysis`, validation. `data` holds at least the
/// design's number of poses.
pub fn simulate_run<const N: usize, const P: usize>(
    study: &Study<'_, N>,
    design: &Design<'_, N>,
    analysis: &Identifiability,
    run: u64,
    ws: &mut Workspace<P>,
    data: &mut [Measurement<N>],
) -> Result<RunResult> {
    let truth = random_robot(study, run)?;
    let m = design.q.len();
    simulate_measurements(study, design, &truth, run, data)?;
    let id = identify_with_analysis(
        &study.nominal,
        &data[..m],
        &identify_options(study),
        analysis,
        ws,
    )?;
    let mut r = validation_errors(study, &truth, &id.robot)?;
    r.iterations = id.iterations;
    Ok(r)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::aria;
    use std::vec::Vec;

    #[test]
    fn tool_measurements_reach_the_physical_pose_and_noise_free_runs_recover_the_robot() {
        let nominal = aria::nominal();
        let refs: Vec<Transform> = (0..10).map(|l| aria::tool_pose(l).unwrap()).collect();
        let q: Vec<[f64; 6]> = refs
            .iter()
            .map(|t| {
                crate::ik::solve_ik(
                    &nominal,
                    t,
                    &JointState::new(aria::TOOL_SEED_Q),
                    &crate::ik::IkOptions::default(),
                )
                .unwrap()
                .q
            })
            .collect();
        let vq = [q[0], q[3], q[7]];
        let vn: Vec<Transform> = vq.iter().map(|q| nominal.fk_q(q).unwrap()).collect();
        let mut scen = Scenario::paper();
        scen.noise_pos_m = 0.0;
        scen.noise_rot_rad = 0.0;
        scen.tool_tol_pos_m = 0.0;
        scen.tool_tol_rot_rad = 0.0;
        let study = Study {
            nominal,
            params: nominal.geometric_param_set(),
            validation_q: &vq,
            validation_sincos: &[],
            validation_nominal: &vn,
            scenario: scen,
            seed: 42,
        };
        let design = Design {
            acquisition: Acquisition::Tool,
            q: &q,
            reference: &refs,
        };
        let mut ws = std::boxed::Box::<Workspace<24>>::default();
        let mut data = [Measurement::new([0.0; 6], Transform::identity()); 10];
        let a = prepare(&study, &design, &mut ws, &mut data).unwrap();
        assert_eq!(a.rank, 24);
        for run in 0..3 {
            let truth = random_robot(&study, run).unwrap();
            simulate_measurements(&study, &design, &truth, run, &mut data).unwrap();
            for (d, r) in data.iter().zip(refs.iter()) {
                // Noise- and tolerance-free: the true robot reaches the drawing's pose (to
                // the 1e-10 of the true-robot IK).
                let (ep, er) = errors(&truth.fk(&d.state).unwrap(), r);
                assert!(ep < 1e-10 && er < 1e-10, "{ep} {er}");
            }
            let r = simulate_run(&study, &design, &a, run, &mut ws, &mut data).unwrap();
            assert!(r.max_pos_m < 1e-9 && r.max_rot_rad < 1e-9, "{r:?}");
            assert!(r.before_max_pos_m > 1e-3, "{r:?}");
        }
        // Table 2 pose 1 is robustly reachable; a pose at the edge of the reach (arm
        // stretched) is not reached by robots with shorter links.
        assert!(robustly_reachable(&study, &refs[0], &q[0], 16).unwrap());
        let stretched = [0.3, 0.2, -0.3658, 0.4, 0.8, 0.1];
        let t = nominal.fk_q(&stretched).unwrap();
        assert!(!robustly_reachable(&study, &t, &stretched, 16).unwrap());
        // Same run, same robot; different runs, different robots.
        assert_eq!(
            random_robot(&study, 5).unwrap(),
            random_robot(&study, 5).unwrap()
        );
        assert_ne!(
            random_robot(&study, 5).unwrap(),
            random_robot(&study, 6).unwrap()
        );
    }
}
