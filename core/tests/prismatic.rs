//! Prismatic and sensor joints, long chains: a lifting column under a 6R arm (P+6R), 2R+P+R, a 7R
//! arm on a rail (P+7R) and a 12-joint mobile manipulator (P+P+R base, P column, 7R arm, R
//! tool roll).
//!
//! Independent checks: FK against the test's own 4×4 chain (`Rz(θ0)·Tz(d + q)·Tx(a)·Rx(α)·
//! Ry(β)` for a prismatic joint), every identification-Jacobian column (links, base, tool,
//! effects) against central finite differences of FK, the IK joint Jacobian through IK
//! reaching FK targets, and noise-free identification recovering the parameters it is asked
//! for to 1e-9.

mod common;

use common::{
    ARM7_LINKS, Mat4, SplitMix64, mat_from_vector6, mat_link, mat_mul, mat_rot_x, mat_rot_y,
    mat_rot_z, mat_trans, max_abs_diff, mul_abt, pose_distance, rot_rows, small_rotation_log,
};
use kincal::identify::{Algorithm, IdentifyOptions, Measurement, Workspace, analyze, identify};
use kincal::ik::{IkOptions, solve_ik};
use kincal::params::{CyclicTerm, ParamId};
use kincal::{
    Effect, EffectSet, Error, JacobianColumn, JointKind, JointLimits, JointState, Link, MassModel,
    ParamIndex, Robot,
};

const P: JointKind = JointKind::Prismatic;
const R: JointKind = JointKind::Revolute;
const S: JointKind = JointKind::Sensor;

/// Largest accepted relative error of an analytic Jacobian column (see `jacobian_fd.rs`).
const REL_TOL: f64 = 1e-6;
/// Column magnitude below which the error is measured absolutely.
const SCALE_FLOOR: f64 = 1e-3;
/// Noise-free recovery tolerance (m or rad).
const RECOVERY_TOL: f64 = 1e-9;

type Ws = Workspace<64>;

fn rev(lo: f64, hi: f64) -> JointLimits {
    JointLimits::new(lo, hi)
}

fn build<const N: usize>(
    links: [Link; N],
    limits: [JointLimits; N],
    kinds: [JointKind; N],
    masses: [f64; N],
) -> Robot<N> {
    Robot::new(links, limits)
        .and_then(|r| r.with_joint_kinds(&kinds))
        .and_then(|r| {
            r.with_mass(MassModel {
                link_masses_kg: masses,
                tool_mass_kg: 0.5,
                gravity: [0.0, 0.0, -9.81],
            })
        })
        .and_then(|r| r.with_tool([0.01, 0.02, 0.08, 0.1, -0.2, 0.05]))
        .expect("test chain")
}

/// A lifting column (vertical slide, 0–0.6 m) carrying a 6R arm.
fn lift_6r() -> Robot<7> {
    let h = core::f64::consts::FRAC_PI_2;
    build(
        [
            Link::dh(0.1, 0.3, 0.05, 0.0),
            Link::dh(0.0, 0.2, 0.0, h),
            Link::dh(-h, 0.0, 0.4, 0.0),
            Link::dh(0.0, 0.02, 0.03, h),
            Link::dh(0.0, 0.35, 0.0, -h),
            Link::dh(0.0, 0.0, 0.0, h),
            Link::dh(0.0, 0.1, 0.0, 0.0),
        ],
        [
            rev(0.0, 0.6),
            rev(-3.0, 3.0),
            rev(-2.0, 2.0),
            rev(-2.5, 2.5),
            rev(-3.0, 3.0),
            rev(-2.0, 2.0),
            rev(-3.0, 3.0),
        ],
        [P, R, R, R, R, R, R],
        [8.0, 3.0, 2.5, 1.5, 1.2, 0.6, 0.3],
    )
}

/// Two revolute joints, a slide along the second link, a wrist joint.
fn rrpr() -> Robot<4> {
    let h = core::f64::consts::FRAC_PI_2;
    build(
        [
            Link::dh(0.0, 0.25, 0.0, h),
            Link::dh(0.2, 0.0, 0.05, -h),
            Link::dh(0.3, 0.15, 0.02, h),
            Link::dh(0.0, 0.08, 0.01, 0.0),
        ],
        [
            rev(-3.0, 3.0),
            rev(-2.0, 2.0),
            rev(-0.2, 0.4),
            rev(-3.0, 3.0),
        ],
        [R, R, P, R],
        [2.0, 1.5, 1.0, 0.4],
    )
}

/// A Panda-like 7R arm on a horizontal rail (the slide axis is the base x axis: the base
/// frame turns z onto x).
fn rail_7r() -> Robot<8> {
    let h = core::f64::consts::FRAC_PI_2;
    let r = build(
        [
            // Rail: slides along base x; then turn back so the arm's first axis is vertical.
            Link::dh(0.0, 0.5, 0.0, -h),
            ARM7_LINKS[0],
            ARM7_LINKS[1],
            ARM7_LINKS[2],
            ARM7_LINKS[3],
            ARM7_LINKS[4],
            ARM7_LINKS[5],
            ARM7_LINKS[6],
        ],
        [
            rev(-1.0, 1.0),
            rev(-2.8, 2.8),
            rev(-1.7, 1.7),
            rev(-2.8, 2.8),
            rev(-3.0, -0.1),
            rev(-2.8, 2.8),
            rev(0.0, 3.7),
            rev(-2.8, 2.8),
        ],
        [P, R, R, R, R, R, R, R],
        [10.0, 4.0, 4.0, 3.0, 2.7, 1.3, 1.5, 0.5],
    );
    r.with_base([0.0, 0.0, 0.2, 0.0, h, 0.0]).expect("base")
}

/// A 12-joint mobile manipulator: base x and y slides and yaw (P+P+R), a lifting column (P),
/// a 7R arm and a tool roll (R).
fn mobile_12() -> Robot<12> {
    let h = core::f64::consts::FRAC_PI_2;
    let r = build(
        [
            // x slide (base z turned onto x by the base frame), then turn onto y.
            Link::dh(0.0, 0.0, 0.0, h),
            // y slide, then turn back to vertical.
            Link::dh(-h, 0.0, 0.0, -h),
            // yaw about vertical.
            Link::dh(0.0, 0.3, 0.1, 0.0),
            // column: vertical slide.
            Link::dh(0.2, 0.4, 0.05, 0.0),
            Link::dh(0.0, 0.333, 0.0, -h),
            Link::dh(0.0, 0.0, 0.0, h),
            Link::dh(0.0, 0.316, 0.0825, h),
            Link::dh(0.0, 0.0, -0.0825, -h),
            Link::dh(0.0, 0.384, 0.0, h),
            Link::dh(0.0, 0.0, 0.088, h),
            Link::dh(0.0, 0.107, 0.0, -h),
            Link::dh(0.0, 0.05, 0.01, 0.0),
        ],
        [
            rev(-2.0, 2.0),
            rev(-2.0, 2.0),
            rev(-3.0, 3.0),
            rev(0.0, 0.8),
            rev(-2.8, 2.8),
            rev(-1.7, 1.7),
            rev(-2.8, 2.8),
            rev(-3.0, -0.1),
            rev(-2.8, 2.8),
            rev(0.0, 3.7),
            rev(-2.8, 2.8),
            rev(-3.0, 3.0),
        ],
        [P, P, R, P, R, R, R, R, R, R, R, R],
        [
            40.0, 40.0, 20.0, 8.0, 4.0, 4.0, 3.0, 2.7, 1.3, 1.5, 0.5, 0.2,
        ],
    );
    r.with_base([0.0, 0.0, 0.1, 0.0, h, 0.0]).expect("base")
}

/// A lifting column whose top tilts (two sensor joints about horizontal axes, as read by an
/// accelerometer: readings within ±0.03 rad) under a 6R arm: P+2S+6R.
fn column_tilt_6r() -> Robot<9> {
    let h = core::f64::consts::FRAC_PI_2;
    build(
        [
            Link::dh(0.1, 0.3, 0.05, h),
            Link::dh(0.0, 0.0, 0.0, -h),
            Link::dh(0.0, 0.2, 0.0, 0.0),
            Link::dh(0.0, 0.2, 0.0, h),
            Link::dh(-h, 0.0, 0.4, 0.0),
            Link::dh(0.0, 0.02, 0.03, h),
            Link::dh(0.0, 0.35, 0.0, -h),
            Link::dh(0.0, 0.0, 0.0, h),
            Link::dh(0.0, 0.1, 0.0, 0.0),
        ],
        [
            rev(0.0, 0.6),
            rev(-0.03, 0.03),
            rev(-0.03, 0.03),
            rev(-3.0, 3.0),
            rev(-2.0, 2.0),
            rev(-2.5, 2.5),
            rev(-3.0, 3.0),
            rev(-2.0, 2.0),
            rev(-3.0, 3.0),
        ],
        [P, S, S, R, R, R, R, R, R],
        [8.0, 0.0, 0.0, 3.0, 2.5, 1.5, 1.2, 0.6, 0.3],
    )
}

/// The test's own FK: 4×4 matrices, a prismatic reading added to d (not scaled).
fn own_fk<const N: usize>(robot: &Robot<N>, disp: &[f64; N], scale: f64) -> Mat4 {
    let mut t = mat_from_vector6(&robot.base());
    for (j, (l, &q)) in robot.links().iter().zip(disp).enumerate() {
        let a = match robot.joint_kind(j) {
            JointKind::Revolute | JointKind::Sensor => mat_link(l, q, scale),
            JointKind::Prismatic => {
                let m = mat_mul(&mat_rot_z(l.theta0), &mat_trans(0.0, 0.0, l.d * scale + q));
                let m = mat_mul(&m, &mat_trans(l.a * scale, 0.0, 0.0));
                let m = mat_mul(&m, &mat_rot_x(l.alpha));
                mat_mul(&m, &mat_rot_y(l.beta))
            }
        };
        t = mat_mul(&t, &a);
    }
    mat_mul(&t, &mat_from_vector6(&robot.tool()))
}

/// Every link perturbed (β too), base/tool non-zero, effects non-zero except the cyclic terms
/// of prismatic joints (which do not apply).
fn perturbed<const N: usize>(robot: &Robot<N>, seed: u64) -> Robot<N> {
    let mut rng = SplitMix64::new(seed);
    let mut r = *robot;
    for i in 0..N {
        let l = r.links()[i];
        let new = [
            l.theta0 + rng.nonzero(0.05),
            l.d + rng.nonzero(0.005),
            l.a + rng.nonzero(0.005),
            l.alpha + rng.nonzero(0.087),
            rng.nonzero(0.087),
        ];
        for (k, v) in new.into_iter().enumerate() {
            r.set_param(ParamIndex(5 * i + k), v).expect("link");
        }
    }
    for (k, b) in r.base().into_iter().enumerate() {
        r.set_param(ParamIndex(5 * N + k), b + rng.nonzero(0.05))
            .expect("base");
    }
    let effects = r
        .param_set(EffectSet::NONE.with(Effect::JointCompliance))
        .union(&Effect::JointScale.params(N))
        .union(&Effect::JointCyclic.params(N))
        .union(&Effect::Backlash.params(N));
    let mut set = effects;
    r.remove_inapplicable(&mut set);
    for i in set.iter().filter(|&i| i >= 5 * N + 12) {
        r.set_param(ParamIndex(i), rng.nonzero(2e-3))
            .expect("effect");
    }
    r.set_param(ParamIndex(Robot::<N>::NUM_PARAMS - 1), 2.3e-5)
        .expect("thermal");
    r
}

fn state<const N: usize>(rng: &mut SplitMix64, robot: &Robot<N>) -> JointState<N> {
    JointState {
        q: rng.q_within(robot.limits()),
        approach: Some(rng.approach()),
        temp_c: Some(rng.uniform(5.0, 45.0)),
    }
}

// ---------------------------------------------------------------------------------------
// FK

fn check_fk<const N: usize>(robot: &Robot<N>, seed: u64) {
    let mut rng = SplitMix64::new(seed);
    for _ in 0..30 {
        let q = rng.q_within(robot.limits());
        let t = robot.fk_q(&q).expect("fk");
        let (dr, dp) = max_abs_diff(&t, &own_fk(robot, &q, 1.0));
        assert!(dr < 1e-12 && dp < 1e-12, "FK off by {dp:e} m, {dr:e}");
    }
    // With every effect: the displacements the core reports, the thermal factor on the fixed
    // lengths only.
    let pert = perturbed(robot, seed + 1);
    for _ in 0..10 {
        let st = state(&mut rng, &pert);
        let disp = pert.joint_angles(&st).expect("angles");
        let scale = pert.length_scale(&st).expect("scale");
        let (dr, dp) = max_abs_diff(&pert.fk(&st).expect("fk"), &own_fk(&pert, &disp, scale));
        assert!(dr < 1e-12 && dp < 1e-12, "FK with effects off by {dp:e} m");
    }
}

#[test]
fn fk_matches_the_tests_own_chain() {
    check_fk(&lift_6r(), 1);
    check_fk(&rrpr(), 2);
    check_fk(&rail_7r(), 3);
    check_fk(&mobile_12(), 4);
}

/// A prismatic reading moves the following frames along the joint axis by exactly the
/// reading, and leaves every orientation alone.
#[test]
fn a_slide_translates_along_its_axis() {
    let robot = lift_6r();
    let q0 = [0.1, 0.3, -0.4, 0.5, 0.2, -0.3, 0.7];
    let mut q1 = q0;
    q1[0] += 0.25;
    let (t0, t1) = (robot.fk_q(&q0).unwrap(), robot.fk_q(&q1).unwrap());
    let dp = t1.translation.vector - t0.translation.vector;
    // Axis of joint 1: base z (identity base).
    assert!((dp - nalgebra::Vector3::new(0.0, 0.0, 0.25)).norm() < 1e-15);
    assert!((t1.rotation.matrix() - t0.rotation.matrix()).norm() < 1e-15);
}

/// Effects on a slide: scale Δd = k·q, compliance Δd = c·F with F the gravity force along the
/// axis (here vertical: −g times the mass carried), backlash Δd = b·s; thermal leaves the
/// reading alone.
#[test]
fn effects_on_a_slide() {
    let mut robot = lift_6r();
    let q = [0.4, 0.3, -0.4, 0.5, 0.2, -0.3, 0.7];
    let carried: f64 = robot.mass().link_masses_kg.iter().sum::<f64>() + robot.mass().tool_mass_kg;
    let f = robot.gravity_torques(&q)[0];
    assert!((f - (-9.81 * carried)).abs() < 1e-12, "F = {f}");
    robot.set_param(ParamId::Scale(0).index(7), 1e-3).unwrap();
    robot
        .set_param(ParamId::Compliance(0).index(7), 2e-6)
        .unwrap();
    robot
        .set_param(ParamId::Backlash(0).index(7), 5e-4)
        .unwrap();
    robot.set_param(ParamId::Thermal.index(7), 1e-4).unwrap();
    let mut st = JointState::new(q);
    st.approach = Some([-1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    st.temp_c = Some(30.0);
    let disp = robot.joint_angles(&st).unwrap();
    let want = 0.4 + 1e-3 * 0.4 + 2e-6 * f - 5e-4;
    assert!((disp[0] - want).abs() < 1e-15, "{} vs {want}", disp[0]);
    // Thermal: d_1 (0.3 m) grows by κ·ΔT, the slide does not.
    let t = robot.fk(&st).unwrap();
    let mut cold = st;
    cold.temp_c = Some(20.0);
    let t20 = robot.fk(&cold).unwrap();
    let (dr, dp) = max_abs_diff(&t, &own_fk(&robot, &disp, 1.0 + 1e-4 * 10.0));
    assert!(dr < 1e-12 && dp < 1e-12);
    assert!((t.translation.vector - t20.translation.vector).norm() > 1e-5);
}

/// A cyclic error has no meaning on a slide: refused when set and when the joint becomes
/// prismatic with one; left out of the parameter set; its Jacobian columns are zero.
#[test]
fn cyclic_terms_are_refused_on_a_slide() {
    let mut robot = lift_6r();
    let i = ParamId::Cyclic(0, CyclicTerm::Sin1).index(7);
    assert!(matches!(
        robot.set_param(i, 1e-3),
        Err(Error::InvalidParameter { index, .. }) if index == i.0
    ));
    robot.set_param(i, 0.0).expect("zero is fine");
    let set = robot.param_set(EffectSet::NONE.with(Effect::JointCyclic));
    assert!(!set.contains(i.0));
    assert!(set.contains(ParamId::Cyclic(1, CyclicTerm::Sin1).index(7).0));
    let mut r = rrpr();
    r.set_joint_kind(2, R).unwrap();
    let c = ParamId::Cyclic(2, CyclicTerm::Cos2).index(4);
    r.set_param(c, 1e-3).unwrap();
    assert!(matches!(
        r.set_joint_kind(2, P),
        Err(Error::InvalidParameter { index, .. }) if index == c.0
    ));
}

// ---------------------------------------------------------------------------------------
// Identification Jacobian against finite differences

fn step<const N: usize>(robot: &Robot<N>, st: &JointState<N>, id: ParamId) -> f64 {
    let q = st.q;
    let factor = match id {
        ParamId::Compliance(j) => robot.gravity_torques(&q)[j],
        ParamId::Scale(j) => q[j],
        ParamId::Cyclic(j, t) => {
            let (s, c) = q[j].sin_cos();
            [s, c, (2.0 * q[j]).sin(), (2.0 * q[j]).cos()][t as usize]
        }
        ParamId::Backlash(j) => st.approach.map_or(0.0, |s| s[j]),
        ParamId::Thermal => st.temp_c.map_or(0.0, |t| t - 20.0),
        _ => 1.0,
    };
    1e-6 / factor.abs().max(1e-3)
}

fn fd_column<const N: usize>(robot: &Robot<N>, st: &JointState<N>, i: usize) -> JacobianColumn {
    let id = ParamId::from_index(ParamIndex(i), N).unwrap();
    if robot.set_param_allowed(i) {
        let h = step(robot, st, id);
        let v = robot.param(ParamIndex(i)).unwrap();
        let eval = |x: f64| {
            let mut r = *robot;
            r.set_param(ParamIndex(i), x).unwrap();
            r.fk(st).unwrap()
        };
        let (tp, tm) = (eval(v + h), eval(v - h));
        let dp = (tp.translation.vector - tm.translation.vector) / (2.0 * h);
        let w = small_rotation_log(&mul_abt(&rot_rows(&tp), &rot_rows(&tm)));
        [
            dp.x,
            dp.y,
            dp.z,
            w[0] / (2.0 * h),
            w[1] / (2.0 * h),
            w[2] / (2.0 * h),
        ]
    } else {
        [0.0; 6]
    }
}

trait Allowed {
    fn set_param_allowed(&self, i: usize) -> bool;
}
impl<const N: usize> Allowed for Robot<N> {
    /// Whether the parameter can take a non-zero value (not a cyclic term of a slide).
    fn set_param_allowed(&self, i: usize) -> bool {
        let mut r = *self;
        r.set_param(ParamIndex(i), 1e-3).is_ok()
    }
}

fn rel_error(a: &JacobianColumn, fd: &JacobianColumn) -> f64 {
    let block = |r: std::ops::Range<usize>| {
        let diff = r.clone().map(|k| (a[k] - fd[k]).abs()).fold(0.0, f64::max);
        let scale = r.map(|k| fd[k].abs()).fold(0.0, f64::max);
        diff / scale.max(SCALE_FLOOR)
    };
    block(0..3).max(block(3..6))
}

fn check_jacobian<const N: usize>(robot: &Robot<N>, seed: u64) {
    let pert = perturbed(robot, seed);
    let mut rng = SplitMix64::new(seed + 100);
    let mut jac = vec![[0.0; 6]; Robot::<N>::NUM_PARAMS];
    for _ in 0..8 {
        let st = state(&mut rng, &pert);
        pert.jacobian(&st, &mut jac).expect("jacobian");
        for (i, col) in jac.iter().enumerate() {
            let fd = fd_column(&pert, &st, i);
            let e = rel_error(col, &fd);
            let name = ParamId::from_index(ParamIndex(i), N).unwrap();
            assert!(
                e < REL_TOL,
                "{name}: relative error {e:e} ({col:?} vs {fd:?})"
            );
        }
    }
}

#[test]
fn jacobian_matches_finite_differences_for_every_column() {
    check_jacobian(&lift_6r(), 11);
    check_jacobian(&rrpr(), 12);
    check_jacobian(&rail_7r(), 13);
    check_jacobian(&mobile_12(), 14);
    check_jacobian(&column_tilt_6r(), 15);
}

// ---------------------------------------------------------------------------------------
// IK

fn check_ik<const N: usize>(robot: &Robot<N>, seed: u64) {
    let mut rng = SplitMix64::new(seed);
    for t in 0..8 {
        let q_true = rng.q_within(robot.limits());
        let target = robot.fk_q(&q_true).unwrap();
        let mut seed_q = q_true;
        for (v, l) in seed_q.iter_mut().zip(robot.limits()) {
            let w = 0.1 * (l.upper - l.lower).min(3.0);
            *v = (*v + rng.uniform(-w, w)).clamp(l.lower, l.upper);
        }
        let sol = solve_ik(
            robot,
            &target,
            &JointState::new(seed_q),
            &IkOptions::default(),
        )
        .unwrap_or_else(|e| panic!("target {t}: {e}"));
        robot.check_limits(&sol.q).unwrap();
        let (dp, dr) = pose_distance(&robot.fk_q(&sol.q).unwrap(), &target);
        assert!(dp < 1e-9 && dr < 1e-9, "target {t}: {dp:e} m {dr:e} rad");
    }
}

#[test]
fn ik_reaches_fk_targets() {
    check_ik(&lift_6r(), 21);
    check_ik(&rrpr(), 22);
    check_ik(&rail_7r(), 23);
    check_ik(&mobile_12(), 24);
    check_ik(&column_tilt_6r(), 25);
}

// ---------------------------------------------------------------------------------------
// Identification

/// Noise-free full poses of `truth` at random configurations.
fn data<const N: usize>(truth: &Robot<N>, n: usize, seed: u64) -> Vec<Measurement<N>> {
    let mut rng = SplitMix64::new(seed);
    (0..n)
        .map(|_| {
            let q = rng.q_within(truth.limits());
            Measurement::new(q, truth.fk_q(&q).unwrap())
        })
        .collect()
}

/// The geometric parameters the data determine (from the core's analysis at the nominal
/// model); the truth is the nominal model with exactly those perturbed, so a noise-free fit
/// must land on it. Returns (identifiable count, worst error, its label).
fn recover<const N: usize>(nominal: &Robot<N>, seed: u64) -> (usize, Vec<String>, f64, String) {
    let mut ws = Box::<Ws>::default();
    let probe = data(nominal, 60, seed);
    let opts = IdentifyOptions::new(Algorithm::Ols, nominal.geometric_param_set());
    let a = analyze(nominal, &probe, &opts, &mut ws).expect("analysis");
    let names = |set: &kincal::ParamSet| {
        set.iter()
            .map(|i| ParamId::from_index(ParamIndex(i), N).unwrap().to_string())
            .collect::<Vec<_>>()
    };
    println!(
        "{N} joints: rank {}, structural {:?}, data-deficient {:?}",
        a.rank,
        names(&a.structural),
        names(&a.data_deficient)
    );
    let mut rng = SplitMix64::new(seed + 1);
    let mut truth = *nominal;
    for i in a.identifiable.iter() {
        let id = ParamId::from_index(ParamIndex(i), N).unwrap();
        let size = if id.is_length() { 0.005 } else { 0.02 };
        let v = truth.param(ParamIndex(i)).unwrap();
        truth
            .set_param(ParamIndex(i), v + rng.nonzero(size))
            .unwrap();
    }
    let meas = data(&truth, 60, seed + 2);
    let opts = IdentifyOptions::new(Algorithm::Ols, a.identifiable);
    let r = identify(nominal, &meas, &opts, &mut ws).expect("identify");
    assert_eq!(r.analysis.rank, a.rank);
    let mut worst = (0.0, String::new());
    for i in a.identifiable.iter() {
        let e = (r.robot.param(ParamIndex(i)).unwrap() - truth.param(ParamIndex(i)).unwrap()).abs();
        if e > worst.0 {
            worst = (
                e,
                ParamId::from_index(ParamIndex(i), N).unwrap().to_string(),
            );
        }
    }
    (a.rank, names(&a.structural), worst.0, worst.1)
}

#[test]
fn noise_free_identification_recovers_mixed_chains() {
    // A slide first, on a fixed base: its θ0 and d are identifiable, every link gives 4.
    let (rank, structural, e, which) = recover(&lift_6r(), 31);
    assert_eq!((rank, structural.len()), (4 * 7, 0), "P+6R");
    assert!(e < RECOVERY_TOL, "P+6R: {which} off by {e:e}");
    // A slide inside the chain: where its axis line lies does not matter, so two lengths
    // after it duplicate earlier ones (a slide contributes 2 parameters fewer than a
    // revolute joint: Everett's 4R + 2P + 6) and the analysis names them.
    let (rank, structural, e, which) = recover(&rrpr(), 32);
    assert_eq!(rank, 4 * 4 - 2, "2R+P+R");
    assert_eq!(structural, ["a_3", "d_4"]);
    assert!(e < RECOVERY_TOL, "2R+P+R: {which} off by {e:e}");
    let (rank, structural, e, which) = recover(&rail_7r(), 33);
    assert_eq!((rank, structural.len()), (4 * 8, 0), "P+7R");
    assert!(e < RECOVERY_TOL, "P+7R: {which} off by {e:e}");
}

/// The 12-joint chain: slides inside the chain (y slide, column) make four parameters
/// redundant (the analysis names them); every identifiable parameter is recovered.
#[test]
fn noise_free_identification_recovers_the_twelve_joint_chain() {
    let (rank, structural, e, which) = recover(&mobile_12(), 34);
    println!("12-joint chain: {rank} of 48 geometric parameters identifiable");
    assert_eq!(rank, 48 - 4, "rank {rank}");
    assert_eq!(structural, ["a_2", "a_4", "theta0_5", "d_5"]);
    assert!(e < RECOVERY_TOL, "12 joints: {which} off by {e:e}");
}

/// Constraint data (instrument-free): a moving slide reads a length, so the scale is not a
/// gauge; a slide that never moves leaves it one.
#[test]
fn a_moving_slide_fixes_the_scale_of_constraint_data() {
    use kincal::identify::constraints::{ConstraintData, Contact};
    let robot = lift_6r();
    let mut rng = SplitMix64::new(41);
    let moving: Vec<Contact<7>> = (0..20)
        .map(|_| Contact::new(rng.q_within(robot.limits())))
        .collect();
    let mut still = moving.clone();
    for c in &mut still {
        c.state.q[0] = 0.3;
    }
    let set = robot.geometric_param_set();
    let d = |c: &[Contact<7>]| {
        ConstraintData {
            instrument: &[],
            contacts: c,
            groups: &[],
            distances: &[],
            sessions: &[],
        }
        .prismatic_fixes_scale(&robot, &set)
    };
    assert!(d(&moving));
    assert!(!d(&still));
    // With the slide's scale requested, its share of the scaling is absorbed again.
    let with_scale = set.union(&Effect::JointScale.params(7));
    let data = ConstraintData {
        instrument: &[],
        contacts: &moving,
        groups: &[],
        distances: &[],
        sessions: &[],
    };
    assert!(!data.prismatic_fixes_scale(&robot, &with_scale));
}

/// Timing of the 12-joint chain (printed; run with `--release -- --nocapture` for the
/// figures in docs/reliability.md): FK, and a noise-free OLS calibration of its 44
/// identifiable parameters from 60 poses, single-threaded wall time.
#[test]
fn twelve_joint_chain_timing() {
    use std::time::Instant;
    let robot = mobile_12();
    let mut rng = SplitMix64::new(51);
    let qs: Vec<[f64; 12]> = (0..1000).map(|_| rng.q_within(robot.limits())).collect();
    let t = Instant::now();
    let mut acc = 0.0;
    for _ in 0..100 {
        for q in &qs {
            acc += robot.fk_q(q).unwrap().translation.vector.x;
        }
    }
    let fk_ns = t.elapsed().as_nanos() as f64 / 1e5;
    assert!(acc.is_finite());
    let t = Instant::now();
    let (rank, _, e, _) = recover(&robot, 34);
    let cal_ms = t.elapsed().as_secs_f64() * 1e3;
    assert!(e < RECOVERY_TOL);
    println!(
        "12-joint chain: FK {fk_ns:.0} ns; analysis + perturbation + OLS calibration of {rank} parameters from 60 poses {cal_ms:.1} ms"
    );
}

// ---------------------------------------------------------------------------------------
// Sensor joints

#[test]
fn sensor_joints_are_revolute_in_fk_and_have_no_transmission_terms() {
    let r = column_tilt_6r();
    check_fk(&r, 41);
    assert_eq!(r.joint_kinds(), [P, S, S, R, R, R, R, R, R]);
    assert!(r.has_sensor_joints() && r.has_prismatic());
    // Cyclic terms and backlash of a sensor joint do not apply; its scale (the gain) does.
    let set = r.param_set(Effect::ALL.iter().fold(EffectSet::NONE, |s, &e| s.with(e)));
    assert!(!set.contains(ParamId::Backlash(1).index(9).0));
    assert!(!set.contains(ParamId::Cyclic(2, CyclicTerm::Sin1).index(9).0));
    assert!(set.contains(ParamId::Scale(1).index(9).0));
    assert!(set.contains(ParamId::Backlash(3).index(9).0));
    let mut m = r;
    let b = ParamId::Backlash(1).index(9);
    assert!(matches!(
        m.set_param(b, 1e-3),
        Err(Error::InvalidParameter { index, .. }) if index == b.0
    ));
    // A revolute joint with backlash cannot become a sensor joint.
    let b3 = ParamId::Backlash(3).index(9);
    m.set_param(b3, 1e-3).unwrap();
    assert!(matches!(
        m.set_joint_kind(3, S),
        Err(Error::InvalidParameter { index, .. }) if index == b3.0
    ));
    // Kinds are exclusive: a sensor joint made prismatic is no longer a sensor joint.
    m.set_joint_kind(2, P).unwrap();
    assert_eq!(m.joint_kind(2), P);
    m.set_joint_kind(2, S).unwrap();
    assert_eq!(m.joint_kind(2), S);
}

/// IK does not command a sensor joint: it stays at the seed's reading, and the arm makes up
/// for a tilt that differs from the one the target was computed with.
#[test]
fn ik_holds_sensor_joints_at_their_reading() {
    let robot = column_tilt_6r();
    let mut rng = SplitMix64::new(51);
    for t in 0..6 {
        let q_true = rng.q_within(robot.limits());
        let target = robot.fk_q(&q_true).unwrap();
        let mut seed_q = q_true;
        seed_q[1] = (q_true[1] + 0.01).min(0.03);
        seed_q[2] = (q_true[2] - 0.01).max(-0.03);
        for v in seed_q.iter_mut().skip(3) {
            *v += rng.uniform(-0.1, 0.1);
        }
        let sol = solve_ik(
            &robot,
            &target,
            &JointState::new(seed_q),
            &IkOptions::default(),
        )
        .unwrap_or_else(|e| panic!("target {t}: {e}"));
        assert_eq!((sol.q[1], sol.q[2]), (seed_q[1], seed_q[2]), "target {t}");
        let (dp, dr) = pose_distance(&robot.fk_q(&sol.q).unwrap(), &target);
        assert!(dp < 1e-9 && dr < 1e-9, "target {t}: {dp:e} m {dr:e} rad");
    }
}

/// The gain of a sensor joint (its joint_scale parameter) and the geometry are recovered from
/// noise-free positions, for a bending gain of 1.6 and for a sensor mounted the wrong way
/// round (gain −1: k = −2).
#[test]
fn noise_free_identification_recovers_sensor_gains() {
    let nominal = column_tilt_6r();
    for (seed, k) in [(61, 0.6), (62, -2.0)] {
        let mut ws = Box::<Ws>::default();
        let mut set = nominal.geometric_param_set();
        set.insert(ParamId::Scale(1).index(9).0).unwrap();
        set.insert(ParamId::Scale(2).index(9).0).unwrap();
        let probe = data(&nominal, 80, seed);
        let a = analyze(
            &nominal,
            &probe,
            &IdentifyOptions::new(Algorithm::Ols, set),
            &mut ws,
        )
        .expect("analysis");
        assert!(a.identifiable.contains(ParamId::Scale(1).index(9).0));
        assert!(a.identifiable.contains(ParamId::Scale(2).index(9).0));
        let mut rng = SplitMix64::new(seed + 1);
        let mut truth = nominal;
        for i in a.identifiable.iter() {
            let id = ParamId::from_index(ParamIndex(i), 9).unwrap();
            let v = truth.param(ParamIndex(i)).unwrap();
            let new = match id {
                ParamId::Scale(_) => k,
                _ if id.is_length() => v + rng.nonzero(0.005),
                _ => v + rng.nonzero(0.02),
            };
            truth.set_param(ParamIndex(i), new).unwrap();
        }
        let meas = data(&truth, 80, seed + 2);
        let r = identify(
            &nominal,
            &meas,
            &IdentifyOptions::new(Algorithm::Ols, a.identifiable),
            &mut ws,
        )
        .expect("identify");
        for j in [1, 2] {
            let got = r.robot.effect_params().scale[j];
            assert!(
                (got - k).abs() < RECOVERY_TOL,
                "gain of joint {j}: {got} vs {k}"
            );
        }
        let worst = a
            .identifiable
            .iter()
            .map(|i| {
                (r.robot.param(ParamIndex(i)).unwrap() - truth.param(ParamIndex(i)).unwrap()).abs()
            })
            .fold(0.0, f64::max);
        assert!(worst < RECOVERY_TOL, "worst parameter off by {worst:e}");
        // The nominal model (gain 1) is off by the gain's share of the tilt: the data do
        // tell the gains apart.
        let before = meas
            .iter()
            .map(|m| {
                (nominal.fk_q(&m.state.q).unwrap().translation.vector - m.pose.translation.vector)
                    .norm()
            })
            .fold(0.0, f64::max);
        assert!(before > 1e-3, "nominal off by only {before:e} m");
    }
}
