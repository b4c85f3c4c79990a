//! Inverse kinematics on the paper's Table 2 calibration-tool poses, checked by FK of the
//! returned readings (not by the residual the solver reports), plus the unreachable case
//! and the nearest-to-seed rule.

mod common;

use common::{SplitMix64, perturbed, pose_distance, table2_pose};
use kincal::ik::{IkOptions, IkSolution, solve_ik};
use kincal::{Error, JointState, Robot, Transform, aria};

/// Pose accuracy an IK solution must reach, checked by FK [m].
const IK_POS_TOL_M: f64 = 1e-9;
/// See [`IK_POS_TOL_M`] [rad].
const IK_ROT_TOL_RAD: f64 = 1e-9;
/// Two IK solutions closer than this (max |Δq|) are the same configuration [rad].
const SAME_Q_TOL_RAD: f64 = 1e-7;

fn max_abs(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Checks a solution independently: within the limits (inclusive), and FK reaches the target.
fn check_solution<const N: usize>(
    what: &str,
    robot: &Robot<N>,
    target: &Transform,
    seed: &JointState<N>,
    sol: &IkSolution<N>,
) {
    for (j, (&v, l)) in sol.q.iter().zip(robot.limits()).enumerate() {
        assert!(
            v >= l.lower && v <= l.upper,
            "{what}: joint {} = {v} outside [{}, {}]",
            j + 1,
            l.lower,
            l.upper
        );
    }
    let mut state = *seed;
    state.q = sol.q;
    let reached = robot.fk(&state).expect("fk");
    let (dp, dr) = pose_distance(&reached, target);
    assert!(
        dp < IK_POS_TOL_M && dr < IK_ROT_TOL_RAD,
        "{what}: FK of the IK answer misses the target by {dp:.3e} m, {dr:.3e} rad"
    );
}

fn solve_all_table2(name: &str, robot: &Robot<6>, opts: &IkOptions) {
    let seed = JointState::new(aria::TOOL_SEED_Q);
    for l in 0..10 {
        let target = table2_pose(l);
        let sol = solve_ik(robot, &target, &seed, opts)
            .unwrap_or_else(|e| panic!("{name}, Table 2 pose {}: {e}", l + 1));
        check_solution(
            &format!("{name}, Table 2 pose {}", l + 1),
            robot,
            &target,
            &seed,
            &sol,
        );
    }
}

#[test]
fn nominal_reaches_every_table2_pose() {
    solve_all_table2("nominal ARIA", &aria::nominal(), &IkOptions::default());
}

#[test]
fn table3_robot_reaches_every_table2_pose() {
    solve_all_table2(
        "Table 3 robot",
        &aria::virtual_truth(),
        &IkOptions::default(),
    );
}

#[test]
fn first_solution_option_also_reaches_every_pose() {
    let opts = IkOptions {
        first_solution: true,
        ..IkOptions::default()
    };
    solve_all_table2("nominal ARIA, first_solution", &aria::nominal(), &opts);
    solve_all_table2(
        "Table 3 robot, first_solution",
        &aria::virtual_truth(),
        &opts,
    );
}

/// Effects are compensated: with compliance, scale, cyclic error, backlash and thermal
/// expansion in the model (and approach directions and temperature in the seed), FK of
/// the answer, with the same effects, reaches the target.
#[test]
fn ik_compensates_every_effect() {
    let mut robot = perturbed(&aria::nominal(), 200);
    // Keep the Table 1 geometry and frames so the Table 2 poses stay inside the workspace;
    // only the effects are perturbed.
    let clean = aria::nominal();
    for i in 0..Robot::<6>::NUM_GEOMETRIC_PARAMS {
        let v = clean.param(kincal::ParamIndex(i)).expect("param");
        robot.set_param(kincal::ParamIndex(i), v).expect("set");
    }
    assert_eq!(robot.active_effects().len(), 5);
    let seed = JointState {
        q: aria::TOOL_SEED_Q,
        approach: Some([1.0, -1.0, 0.0, 1.0, 1.0, -1.0]),
        temp_c: Some(35.0),
    };
    for l in 0..10 {
        let target = table2_pose(l);
        let sol = solve_ik(&robot, &target, &seed, &IkOptions::default())
            .unwrap_or_else(|e| panic!("pose {}: {e}", l + 1));
        check_solution(
            &format!("ARIA with effects, pose {}", l + 1),
            &robot,
            &target,
            &seed,
            &sol,
        );
        // Without the compensation the readings would differ: the model really has effects.
        let plain = solve_ik(&clean, &target, &seed, &IkOptions::default()).expect("plain");
        assert!(max_abs(&plain.q, &sol.q) > 1e-4);
    }
}

#[test]
fn pose_five_metres_away_is_unreachable() {
    let robot = aria::nominal();
    let mut target = table2_pose(0);
    target.translation.vector.x += 5.0;
    let opts = IkOptions {
        max_iterations: 50,
        ..IkOptions::default()
    };
    match solve_ik(&robot, &target, &JointState::new(aria::TOOL_SEED_Q), &opts) {
        Err(Error::Unreachable {
            residual_pos_m,
            residual_rot_rad,
        }) => {
            // The arm reaches about 1.2 m from the base, the target is ~5.5 m away.
            assert!(residual_pos_m > 4.0, "residual {residual_pos_m}");
            assert!(residual_rot_rad.is_finite());
        }
        other => panic!("expected Unreachable, got {other:?}"),
    }
}

/// Distinct IK branches of a pose, found from random seeds with no extra seeds.
fn branches(robot: &Robot<6>, target: &Transform, count: usize) -> Vec<[f64; 6]> {
    let mut rng = SplitMix64::new(201);
    let opts = IkOptions {
        extra_seeds: 0,
        ..IkOptions::default()
    };
    let mut found: Vec<[f64; 6]> = Vec::new();
    for _ in 0..count {
        let seed = JointState::new(rng.q_within(robot.limits()));
        if let Ok(sol) = solve_ik(robot, target, &seed, &opts)
            && found.iter().all(|f| max_abs(f, &sol.q) > 0.1)
        {
            found.push(sol.q);
        }
    }
    found
}

/// A seed that is itself a solution comes back unchanged (it is the nearest solution),
/// on every branch; a seed slightly off a branch comes back on that branch.
#[test]
fn nearest_to_seed_rule() {
    let robot = aria::nominal();
    let target = table2_pose(2);
    let sols = branches(&robot, &target, 40);
    assert!(
        sols.len() >= 2,
        "expected several IK branches, found {}",
        sols.len()
    );
    let mut rng = SplitMix64::new(202);
    for q in &sols {
        let seed = JointState::new(*q);
        check_solution(
            "branch",
            &robot,
            &target,
            &seed,
            &IkSolution {
                q: *q,
                residual_pos_m: 0.0,
                residual_rot_rad: 0.0,
                iterations: 0,
                seed_index: 0,
            },
        );
        let sol = solve_ik(&robot, &target, &seed, &IkOptions::default()).expect("ik");
        assert!(
            max_abs(&sol.q, q) < SAME_Q_TOL_RAD,
            "seed {q:?} is a solution but IK returned {:?}",
            sol.q
        );
        assert_eq!(sol.seed_index, 0);
        // Slightly off the branch: still that branch (the nearest solution).
        let mut near = *q;
        for v in &mut near {
            *v += rng.uniform(-0.02, 0.02);
        }
        if robot.check_limits(&near).is_ok() {
            let sol = solve_ik(
                &robot,
                &target,
                &JointState::new(near),
                &IkOptions::default(),
            )
            .expect("ik");
            assert!(
                max_abs(&sol.q, q) < SAME_Q_TOL_RAD,
                "seed near {q:?} gave {:?}",
                sol.q
            );
        }
    }
}
