//! The analytic identification Jacobian (eq. 13a–e plus base, tool and effect columns)
//! against central finite differences of FK, for every one of the 12N+13 parameters.
//!
//! Position rows: `(p(x+h) − p(x−h)) / 2h`. Orientation rows: the exact rotation vector of
//! `R(x+h)·R(x−h)ᵀ` divided by `2h` (independent log written in `common`). Relative error of
//! a column, per block b ∈ {position, orientation}:
//! `max_k |J_analytic[k] − J_fd[k]| / max(max_k |J_fd[k]|, SCALE_FLOOR)`; it must stay below
//! [`REL_TOL`] for every column, block, configuration and robot.

mod common;

use common::{SplitMix64, arm7, full_state, mul_abt, perturbed, rot_rows, small_rotation_log};
use kincal::params::{LinkParam, ParamId};
use kincal::{JacobianColumn, JointState, ParamIndex, Robot, aria};

/// Largest accepted relative error between analytic and finite-difference columns.
const REL_TOL: f64 = 1e-6;
/// Column magnitude below which the error is measured absolutely (times this floor) rather
/// than relatively, in m or rad per parameter unit. Columns that vanish (e.g. the
/// orientation rows of a length, compliance of a joint without gravity torque) must then
/// agree to `REL_TOL · SCALE_FLOOR` = 1e-9.
const SCALE_FLOOR: f64 = 1e-3;
/// Random configurations per robot.
const CONFIGS: usize = 25;

/// Size of the change a finite-difference step makes to a joint angle [rad], a length [m]
/// or the thermal length factor: rounding error ~1e-16/1e-6, truncation ~(1e-6)².
const EFFECTIVE_STEP: f64 = 1e-6;

/// Central-difference step for parameter `id` at `state`. Effect parameters enter through
/// a factor (Δθ_j = c_j·τ_j, k_j·q_j, a_j·sin q_j, b_j·s_j; length factor κ·(T − 20)); the
/// step is divided by that factor so that the angle or length really moves by
/// [`EFFECTIVE_STEP`]. A factor of zero gives a zero column whatever the step.
fn step<const N: usize>(robot: &Robot<N>, state: &JointState<N>, id: ParamId) -> f64 {
    let q = state.q;
    let factor = match id {
        ParamId::Compliance(j) => robot.gravity_torques(&q)[j],
        ParamId::Scale(j) => q[j],
        ParamId::Cyclic(j, t) => {
            let (s, c) = q[j].sin_cos();
            [s, c, (2.0 * q[j]).sin(), (2.0 * q[j]).cos()][t as usize]
        }
        ParamId::Backlash(j) => state.approach.map_or(0.0, |s| s[j]),
        ParamId::Thermal => state.temp_c.map_or(0.0, |t| t - 20.0),
        _ => 1.0,
    };
    EFFECTIVE_STEP / factor.abs().max(1e-3)
}

/// The finite-difference column of parameter `i` at `state`.
fn fd_column<const N: usize>(robot: &Robot<N>, state: &JointState<N>, i: usize) -> JacobianColumn {
    let id = ParamId::from_index(ParamIndex(i), N).expect("index in range");
    let h = step(robot, state, id);
    let v = robot.param(ParamIndex(i)).expect("param");
    let eval = |x: f64| {
        let mut r = *robot;
        r.set_param(ParamIndex(i), x).expect("set_param");
        r.fk(state).expect("fk")
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
}

/// Block-wise relative error (position rows, orientation rows) as documented above.
fn rel_error(analytic: &JacobianColumn, fd: &JacobianColumn) -> (f64, f64) {
    let block = |r: std::ops::Range<usize>| {
        let diff = r
            .clone()
            .map(|k| (analytic[k] - fd[k]).abs())
            .fold(0.0, f64::max);
        let scale = r.map(|k| fd[k].abs()).fold(0.0, f64::max);
        diff / scale.max(SCALE_FLOOR)
    };
    (block(0..3), block(3..6))
}

/// Checks every column at `CONFIGS` random configurations; returns the worst relative error.
fn check_all_columns<const N: usize>(name: &str, robot: &Robot<N>, seed: u64) -> f64 {
    let mut rng = SplitMix64::new(seed);
    let mut worst: f64 = 0.0;
    let mut jac = vec![[0.0; 6]; Robot::<N>::NUM_PARAMS];
    for c in 0..CONFIGS {
        let state = full_state(&mut rng, robot.limits());
        let pose = robot.jacobian(&state, &mut jac).expect("jacobian");
        let fk = robot.fk(&state).expect("fk");
        assert!(
            (pose.to_homogeneous() - fk.to_homogeneous()).abs().max() < 1e-15,
            "{name}: pose returned by jacobian differs from fk"
        );
        for (i, col) in jac.iter().enumerate() {
            let fd = fd_column(robot, &state, i);
            let (ep, er) = rel_error(col, &fd);
            let id = ParamId::from_index(ParamIndex(i), N).expect("index");
            assert!(
                ep < REL_TOL && er < REL_TOL,
                "{name}, config {c} (q = {:?}), column {i} ({id}): relative error {ep:.3e} \
                 (position), {er:.3e} (orientation)\n analytic {col:?}\n fd       {fd:?}",
                state.q
            );
            worst = worst.max(ep).max(er);
        }
    }
    worst
}

#[test]
fn every_column_nominal_aria() {
    let worst = check_all_columns("nominal ARIA", &aria::nominal(), 1);
    eprintln!("nominal ARIA: worst relative error {worst:.2e}");
}

#[test]
fn every_column_table3_robot() {
    let worst = check_all_columns("Table 3 robot", &aria::virtual_truth(), 2);
    eprintln!("Table 3 robot: worst relative error {worst:.2e}");
}

#[test]
fn every_column_perturbed_aria_with_frames_and_effects() {
    let robot = perturbed(&aria::nominal(), 3);
    // The fixture really has what the test claims to cover.
    assert!(robot.links().iter().all(|l| l.beta.abs() > 1e-3));
    assert!(robot.base()[3..].iter().all(|v| v.abs() > 0.1));
    assert!(robot.tool()[3..].iter().all(|v| v.abs() > 0.1));
    assert_eq!(robot.active_effects().len(), 5);
    let worst = check_all_columns("perturbed ARIA", &robot, 4);
    eprintln!("perturbed ARIA: worst relative error {worst:.2e}");
}

#[test]
fn every_column_seven_joint_arm() {
    check_all_columns("7-joint arm", &arm7(), 5);
    check_all_columns("perturbed 7-joint arm", &perturbed(&arm7(), 6), 7);
}

#[test]
fn geometric_only_buffer_matches_the_full_one() {
    let robot = perturbed(&aria::nominal(), 8);
    let mut rng = SplitMix64::new(9);
    let state = full_state(&mut rng, robot.limits());
    let mut full = vec![[0.0; 6]; Robot::<6>::NUM_PARAMS];
    let mut geo = vec![[f64::NAN; 6]; Robot::<6>::NUM_GEOMETRIC_PARAMS];
    robot.jacobian(&state, &mut full).expect("full");
    robot.jacobian(&state, &mut geo).expect("geometric");
    for (i, (g, f)) in geo.iter().zip(full.iter()).enumerate() {
        assert_eq!(g, f, "column {i}");
    }
}

/// The checker itself can fail: a column with the wrong sign, a 1e-5 relative error, or
/// one taken from the neighbouring parameter is rejected.
#[test]
fn checker_rejects_wrong_columns() {
    let robot = aria::nominal();
    let mut rng = SplitMix64::new(10);
    let state = full_state(&mut rng, robot.limits());
    let mut jac = vec![[0.0; 6]; Robot::<6>::NUM_PARAMS];
    robot.jacobian(&state, &mut jac).expect("jacobian");
    let i = ParamId::Link {
        link: 2,
        kind: LinkParam::Alpha,
    }
    .index(6)
    .0;
    let fd = fd_column(&robot, &state, i);
    let (ep, er) = rel_error(&jac[i], &fd);
    assert!(ep < REL_TOL && er < REL_TOL);
    let negated = jac[i].map(|v| -v);
    let (ep, _) = rel_error(&negated, &fd);
    assert!(ep > 1.0);
    let slightly_off = jac[i].map(|v| v * (1.0 + 1e-5));
    let (ep, er) = rel_error(&slightly_off, &fd);
    assert!(ep.max(er) > REL_TOL);
    let (ep, er) = rel_error(&jac[i + 1], &fd);
    assert!(ep.max(er) > REL_TOL);
}

/// Effect columns whose input is absent are zero when the effect is not in the model
/// (nominal ARIA, no approach directions, no temperature).
#[test]
fn effect_columns_without_inputs_are_zero() {
    let robot = aria::nominal();
    let state = JointState::new(aria::TOOL_SEED_Q);
    let mut jac = vec![[1.0; 6]; Robot::<6>::NUM_PARAMS];
    robot.jacobian(&state, &mut jac).expect("jacobian");
    for j in 0..6 {
        assert_eq!(jac[ParamId::Backlash(j).index(6).0], [0.0; 6]);
    }
    assert_eq!(jac[ParamId::Thermal.index(6).0], [0.0; 6]);
}

/// The compliance column uses gravity torques of the nominal geometry: it is the θ0 column
/// times τ_j(q) of the description, unchanged when the calibrated geometry moves.
#[test]
fn compliance_column_uses_nominal_torques() {
    let nominal = aria::nominal();
    let truth = aria::virtual_truth();
    let mut rng = SplitMix64::new(11);
    let q = rng.q_within(nominal.limits());
    assert_eq!(nominal.gravity_torques(&q), truth.gravity_torques(&q));
    let mut jac = vec![[0.0; 6]; Robot::<6>::NUM_PARAMS];
    truth
        .jacobian(&JointState::new(q), &mut jac)
        .expect("jacobian");
    let tau = nominal.gravity_torques(&q);
    for (j, t) in tau.iter().enumerate() {
        let th = jac[ParamId::Link {
            link: j,
            kind: LinkParam::Theta0,
        }
        .index(6)
        .0];
        let c = jac[ParamId::Compliance(j).index(6).0];
        for k in 0..6 {
            assert!((c[k] - th[k] * t).abs() <= 1e-15 * (1.0 + (th[k] * t).abs()));
        }
    }
}

/// Central differences of FK with respect to each reading: `[dp/dq_j; ω_j]` as above.
fn fd_joint_column<const N: usize>(
    robot: &Robot<N>,
    state: &JointState<N>,
    j: usize,
) -> JacobianColumn {
    let h = EFFECTIVE_STEP;
    let eval = |dq: f64| {
        let mut s = *state;
        s.q[j] += dq;
        robot.fk(&s).expect("fk")
    };
    let (tp, tm) = (eval(h), eval(-h));
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
}

/// Worst relative error of [`Robot::joint_jacobian`] against [`fd_joint_column`]; the pose
/// it returns is FK's, bit for bit.
fn check_joint_jacobian<const N: usize>(name: &str, robot: &Robot<N>, seed: u64) -> f64 {
    let mut rng = SplitMix64::new(seed);
    let mut worst: f64 = 0.0;
    for c in 0..CONFIGS {
        let state = full_state(&mut rng, robot.limits());
        let mut jac = [[0.0; 6]; N];
        let pose = robot
            .joint_jacobian(&state, &mut jac)
            .expect("joint_jacobian");
        assert_eq!(
            pose,
            robot.fk(&state).expect("fk"),
            "{name}: pose differs from fk"
        );
        for (j, col) in jac.iter().enumerate() {
            let fd = fd_joint_column(robot, &state, j);
            let (ep, er) = rel_error(col, &fd);
            assert!(
                ep < REL_TOL && er < REL_TOL,
                "{name}, config {c}, joint {j}: relative error {ep:.3e} / {er:.3e}\n \
                 analytic {col:?}\n fd       {fd:?}"
            );
            worst = worst.max(ep).max(er);
        }
    }
    worst
}

/// The controller's joint Jacobian against finite differences of FK in the readings: the
/// nominal ARIA, the perturbed 7-joint arm, and the perturbed ARIA with base, tool, β and the scale,
/// cyclic, backlash and thermal effects (compliance cleared: its dependence on q is the one
/// term the joint Jacobian neglects, documented there).
#[test]
fn joint_jacobian_matches_finite_differences() {
    check_joint_jacobian("nominal ARIA", &aria::nominal(), 11);
    let compliance = kincal::EffectSet::of(kincal::Effect::JointCompliance);
    let mut arm = perturbed(&arm7(), 12);
    arm.clear_effects(compliance);
    check_joint_jacobian("perturbed 7-joint arm", &arm, 13);
    let mut robot = perturbed(&aria::nominal(), 14);
    robot.clear_effects(compliance);
    assert_eq!(robot.active_effects().len(), 4);
    let worst = check_joint_jacobian("perturbed ARIA", &robot, 15);
    eprintln!("joint Jacobian, perturbed ARIA: worst relative error {worst:.2e}");
    // The check can fail: a column of the wrong joint is far off.
    let state = full_state(&mut SplitMix64::new(16), robot.limits());
    let mut jac = [[0.0; 6]; 6];
    robot
        .joint_jacobian(&state, &mut jac)
        .expect("joint_jacobian");
    let (ep, er) = rel_error(&jac[1], &fd_joint_column(&robot, &state, 2));
    assert!(ep.max(er) > 1e-2, "{ep} {er}");
}
