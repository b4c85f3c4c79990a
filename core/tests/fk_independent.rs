//! Forward kinematics against an independent plain-matrix implementation (4×4 arrays,
//! std `sin`/`cos`, written in `common`), and against the paper's Table 2 through the
//! measurement-format example.

mod common;

use common::{
    SplitMix64, arm7, full_state, max_abs_diff, perturbed, plain_fk, plain_fk_frames,
    pose_distance, table2_pose,
};
use kincal::{Frames, JointState, Robot, aria};

/// FK agreement with the plain implementation, rotation elements [1] and position [m].
const FK_TOL: f64 = 1e-12;
/// Random configurations per robot.
const CONFIGS: usize = 200;

/// Joint readings of the measurement-format example are rounded to 4 decimals, i.e. by up
/// to 5e-5 rad per joint. With lever arms of ~0.5 m, six independent roundings move the
/// tool by about √6·5e-5·0.5 ≈ 6e-5 m and rotate it by about √6·5e-5 rad ≈ 0.007°
/// (measured: 1.3e-5 m, 0.003°).
const EXAMPLE_POS_TOL_M: f64 = 1e-4;
/// See [`EXAMPLE_POS_TOL_M`].
const EXAMPLE_ROT_TOL_DEG: f64 = 0.01;

fn check_against_plain<const N: usize>(name: &str, robot: &Robot<N>, seed: u64) {
    let mut rng = SplitMix64::new(seed);
    for c in 0..CONFIGS {
        let q = rng.q_within(robot.limits());
        let t = robot.fk_q(&q).expect("fk");
        let m = plain_fk(robot.links(), &robot.base(), &robot.tool(), &q);
        let (dr, dp) = max_abs_diff(&t, &m);
        assert!(
            dr < FK_TOL && dp < FK_TOL,
            "{name}, config {c}, q = {q:?}: rotation diff {dr:.2e}, position diff {dp:.2e}"
        );
    }
}

#[test]
fn nominal_aria_matches_plain_matrices() {
    check_against_plain("nominal ARIA", &aria::nominal(), 100);
}

#[test]
fn table3_and_table4_robots_match_plain_matrices() {
    check_against_plain("Table 3 robot", &aria::virtual_truth(), 101);
    check_against_plain("Table 4 robot", &aria::real_identified(), 102);
}

#[test]
fn seven_joint_arm_matches_plain_matrices() {
    check_against_plain("7-joint arm", &arm7(), 103);
}

/// A robot with β ≠ 0 on every link, rotated base and tool frames, and every effect: the
/// plain FK is fed joint angles q + Δθ computed here from spec/effects.md and lengths
/// times 1 + κ·(T − 20).
#[test]
fn perturbed_robot_with_every_effect_matches_plain_matrices() {
    let robot = perturbed(&aria::nominal(), 104);
    let e = *robot.effect_params();
    let mut rng = SplitMix64::new(105);
    for c in 0..CONFIGS {
        let state = full_state(&mut rng, robot.limits());
        let (q, s, temp) = (
            state.q,
            state.approach.expect("approach"),
            state.temp_c.expect("temp"),
        );
        let tau = robot.gravity_torques(&q);
        let angles: Vec<f64> = (0..6)
            .map(|j| {
                let cy = e.cyclic[j];
                q[j] + e.compliance[j] * tau[j]
                    + e.scale[j] * q[j]
                    + cy[0] * q[j].sin()
                    + cy[1] * q[j].cos()
                    + cy[2] * (2.0 * q[j]).sin()
                    + cy[3] * (2.0 * q[j]).cos()
                    + e.backlash[j] * s[j]
            })
            .collect();
        let scale = 1.0 + e.thermal_kappa * (temp - 20.0);
        let (m, frames) =
            plain_fk_frames(robot.links(), &robot.base(), &robot.tool(), &angles, scale);
        let t = robot.fk(&state).expect("fk");
        let (dr, dp) = max_abs_diff(&t, &m);
        assert!(
            dr < FK_TOL && dp < FK_TOL,
            "config {c}: rotation diff {dr:.2e}, position diff {dp:.2e}"
        );
        // Every intermediate frame too.
        let mut f = Frames::<6>::default();
        robot.fk_frames(&state, &mut f).expect("fk_frames");
        let (dr, dp) = max_abs_diff(&f.t_base_0, &frames[0]);
        assert!(dr < FK_TOL && dp < FK_TOL, "config {c}: base frame");
        for (i, t) in f.t_base_link.iter().enumerate() {
            let (dr, dp) = max_abs_diff(t, &frames[i + 1]);
            assert!(
                dr < FK_TOL && dp < FK_TOL,
                "config {c}: frame {}: rotation diff {dr:.2e}, position diff {dp:.2e}",
                i + 1
            );
        }
        let (dr, dp) = max_abs_diff(&f.t_base_ee, &m);
        assert!(dr < FK_TOL && dp < FK_TOL, "config {c}: end effector");
        assert!((f.length_scale - scale).abs() < 1e-15);
    }
}

/// The example row of spec/measurements.md: aria::TOOL_SEED_Q is Table 2 pose 1 on the
/// nominal ARIA, up to the rounding of its joint values.
#[test]
fn measurement_example_reproduces_table2_pose1() {
    let robot = aria::nominal();
    let t = robot.fk_q(&aria::TOOL_SEED_Q).expect("fk");
    let (dp, dr) = pose_distance(&t, &table2_pose(0));
    eprintln!(
        "TOOL_SEED_Q vs Table 2 pose 1: {:.3e} m, {:.4} deg",
        dp,
        dr.to_degrees()
    );
    assert!(dp < EXAMPLE_POS_TOL_M, "position off by {dp} m");
    assert!(
        dr.to_degrees() < EXAMPLE_ROT_TOL_DEG,
        "orientation off by {} deg",
        dr.to_degrees()
    );
    // And kincal's own Table 2 conversion agrees with the one written in the test.
    let (dp, dr) = pose_distance(&aria::tool_pose(0).expect("pose"), &table2_pose(0));
    assert!(dp < 1e-15 && dr < 1e-15);
}

/// `fk_q` is `fk` of a state with readings only.
#[test]
fn fk_q_equals_fk_with_plain_state() {
    let robot = aria::nominal();
    let mut rng = SplitMix64::new(106);
    for _ in 0..20 {
        let q = rng.q_within(robot.limits());
        let a = robot.fk_q(&q).expect("fk_q");
        let b = robot.fk(&JointState::new(q)).expect("fk");
        assert_eq!(a, b);
    }
}
