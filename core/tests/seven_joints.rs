//! A made-up 7-joint (redundant, Panda-like) arm through the generic core: IK, the d/β
//! choice and run-time dispatch. Its FK is checked against the plain-matrix chain in
//! `fk_independent.rs`, its Jacobian against finite differences in `jacobian_fd.rs`, its
//! gravity torques in `gravity.rs`.

mod common;

use common::{SplitMix64, arm7, pose_distance};
use kincal::any::AnyRobot;
use kincal::ik::{IkOptions, solve_ik};
use kincal::{Error, JointState, LengthParam, Robot, with_any_robot};

/// Pose accuracy an IK solution must reach, checked by FK [m].
const IK_POS_TOL_M: f64 = 1e-9;
/// See [`IK_POS_TOL_M`] [rad].
const IK_ROT_TOL_RAD: f64 = 1e-9;
/// Random reachable targets.
const TARGETS: usize = 15;

#[test]
fn ik_reaches_random_reachable_poses() {
    let robot = arm7();
    let mut rng = SplitMix64::new(500);
    for t in 0..TARGETS {
        let q_true = rng.q_within(robot.limits());
        let target = robot.fk_q(&q_true).expect("fk");
        // Seed: the true configuration disturbed by up to 0.3 rad per joint, clamped.
        let mut seed = q_true;
        for (v, l) in seed.iter_mut().zip(robot.limits()) {
            *v = (*v + rng.uniform(-0.3, 0.3)).clamp(l.lower, l.upper);
        }
        let sol = solve_ik(
            &robot,
            &target,
            &JointState::new(seed),
            &IkOptions::default(),
        )
        .unwrap_or_else(|e| panic!("target {t}: {e}"));
        robot.check_limits(&sol.q).expect("within limits");
        let (dp, dr) = pose_distance(&robot.fk_q(&sol.q).expect("fk"), &target);
        assert!(
            dp < IK_POS_TOL_M && dr < IK_ROT_TOL_RAD,
            "target {t}: FK of the answer misses by {dp:.3e} m, {dr:.3e} rad"
        );
    }
}

/// Redundancy: a seed that is itself a solution is returned as is (the null-space motion
/// does not wander off).
#[test]
fn ik_keeps_a_seed_that_solves() {
    let robot = arm7();
    let mut rng = SplitMix64::new(501);
    for _ in 0..5 {
        let q = rng.q_within(robot.limits());
        let target = robot.fk_q(&q).expect("fk");
        let sol =
            solve_ik(&robot, &target, &JointState::new(q), &IkOptions::default()).expect("ik");
        let d = q
            .iter()
            .zip(sol.q)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(d < 1e-9, "moved by {d}");
        assert_eq!(sol.seed_index, 0);
    }
}

#[test]
fn ik_unreachable_far_away() {
    let robot = arm7();
    let mut target = robot.fk_q(&[0.1; 7]).expect("fk");
    target.translation.vector.z += 5.0;
    let opts = IkOptions {
        max_iterations: 50,
        extra_seeds: 4,
        ..IkOptions::default()
    };
    assert!(matches!(
        solve_ik(&robot, &target, &JointState::new([0.1; 7]), &opts),
        Err(Error::Unreachable { residual_pos_m, .. }) if residual_pos_m > 3.5
    ));
}

/// Alternating ±90° twists: no two consecutive axes parallel, so every link identifies d.
#[test]
fn length_params_of_the_seven_joint_arm() {
    assert_eq!(arm7().length_params(), &[LengthParam::D; 7]);
    assert_eq!(arm7().geometric_param_set().len(), 4 * 7);
    assert_eq!(Robot::<7>::NUM_PARAMS, 12 * 7 + 13);
    assert_eq!(Robot::<7>::NUM_GEOMETRIC_PARAMS, 5 * 7 + 12);
}

/// Run-time dispatch reaches the same generic code.
#[test]
fn any_robot_dispatches_to_seven_joints() {
    let robot = arm7();
    let any = AnyRobot::from(robot);
    assert_eq!(any.n_joints(), 7);
    assert!(matches!(any, AnyRobot::J7(_)));
    let z = with_any_robot!(&any, r => r.links().iter().map(|l| l.d).sum::<f64>());
    assert!((z - (0.333 + 0.316 + 0.384 + 0.107)).abs() < 1e-15);
    let built = AnyRobot::new(robot.links(), robot.limits()).expect("any");
    assert_eq!(built.n_joints(), 7);
}
