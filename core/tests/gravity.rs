//! Gravity torques of the point-mass model against `τ_j = −∂V/∂q_j`, with the potential
//! energy `V = −Σ_k m_k·g·c_k` computed here from the frame origins of the independent
//! plain-matrix FK (central differences).

mod common;

use common::{SplitMix64, arm7, plain_fk_frames};
use kincal::{MassModel, Robot, aria};

/// Step of the central difference of V [rad].
const H: f64 = 1e-5;
/// Torque agreement, relative to the largest torque of the configuration (V ~ 50 J, so
/// rounding in V/2h is ~1e-10 N·m and truncation ~H²·V ~ 1e-8 N·m).
const TAU_REL_TOL: f64 = 1e-7;
/// Torque below which a joint carries "no" gravity torque [N·m].
const ZERO_TORQUE_NM: f64 = 1e-12;
/// Random configurations per robot.
const CONFIGS: usize = 100;

/// Potential energy [J] at readings `q`, from the nominal geometry of `robot`.
fn potential<const N: usize>(robot: &Robot<N>, q: &[f64; N]) -> f64 {
    let m = robot.mass();
    let (base, tool) = robot.nominal_frames();
    let (ee, frames) = plain_fk_frames(robot.nominal_links(), &base, &tool, q, 1.0);
    let pos = |f: &common::Mat4| [f[0][3], f[1][3], f[2][3]];
    let g = m.gravity;
    let dot = |c: [f64; 3]| g[0] * c[0] + g[1] * c[1] + g[2] * c[2];
    let mut v = -m.tool_mass_kg * dot(pos(&ee));
    for k in 0..N {
        let (a, b) = (pos(&frames[k]), pos(&frames[k + 1]));
        let c = [
            0.5 * (a[0] + b[0]),
            0.5 * (a[1] + b[1]),
            0.5 * (a[2] + b[2]),
        ];
        v -= m.link_masses_kg[k] * dot(c);
    }
    v
}

fn check_torques<const N: usize>(name: &str, robot: &Robot<N>, seed: u64) {
    let mut rng = SplitMix64::new(seed);
    for c in 0..CONFIGS {
        let q = rng.q_within(robot.limits());
        let tau = robot.gravity_torques(&q);
        let scale = tau.iter().fold(1.0_f64, |a, t| a.max(t.abs()));
        for j in 0..N {
            let (mut qp, mut qm) = (q, q);
            qp[j] += H;
            qm[j] -= H;
            let fd = -(potential(robot, &qp) - potential(robot, &qm)) / (2.0 * H);
            assert!(
                (tau[j] - fd).abs() < TAU_REL_TOL * scale,
                "{name}, config {c}, joint {}: τ = {}, −∂V/∂q = {fd}",
                j + 1,
                tau[j]
            );
        }
    }
}

#[test]
fn aria_torques_are_minus_potential_gradient() {
    check_torques("nominal ARIA", &aria::nominal(), 300);
}

/// The torques use the description's nominal geometry: the Table 3 robot (different
/// geometry, Table 1 as nominal) has the same torques, and those are −∂V/∂q of Table 1.
#[test]
fn torques_use_nominal_geometry() {
    check_torques("Table 3 robot", &aria::virtual_truth(), 301);
    let mut rng = SplitMix64::new(302);
    for _ in 0..20 {
        let q = rng.q_within(&aria::JOINT_LIMITS);
        assert_eq!(
            aria::virtual_truth().gravity_torques(&q),
            aria::nominal().gravity_torques(&q)
        );
    }
}

/// A tilted base and gravity not along −z exercise the joint-1 path (axis from the base).
#[test]
fn tilted_base_and_gravity() {
    let robot = aria::nominal()
        .with_base([0.1, -0.05, 0.02, 0.3, -0.4, 0.2])
        .and_then(|r| r.with_tool([0.0, 0.01, 0.12, 0.2, 0.0, -0.3]))
        .and_then(|r| {
            r.with_mass(MassModel {
                gravity: [1.2, -0.7, -9.7],
                ..aria::MASS_MODEL
            })
        })
        .expect("robot");
    check_torques("tilted ARIA", &robot, 303);
    let q = [0.3, 0.5, -0.4, 1.0, 0.7, -0.2];
    // Joint 1 now carries torque (its axis is no longer vertical).
    assert!(robot.gravity_torques(&q)[0].abs() > 0.1);
}

#[test]
fn seven_joint_torques_are_minus_potential_gradient() {
    check_torques("7-joint arm", &arm7(), 304);
}

/// spec/effects.md: on ARIA joint 1 (vertical axis) and joint 6 (masses on its axis)
/// carry no gravity torque; the others do in general.
#[test]
fn aria_joints_1_and_6_carry_no_torque() {
    let robot = aria::nominal();
    let mut rng = SplitMix64::new(305);
    let mut largest = [0.0_f64; 6];
    for _ in 0..CONFIGS {
        let q = rng.q_within(robot.limits());
        let tau = robot.gravity_torques(&q);
        assert!(tau[0].abs() < ZERO_TORQUE_NM, "τ1 = {} at {q:?}", tau[0]);
        assert!(tau[5].abs() < ZERO_TORQUE_NM, "τ6 = {} at {q:?}", tau[5]);
        for (l, t) in largest.iter_mut().zip(tau) {
            *l = l.max(t.abs());
        }
    }
    for (j, l) in largest.iter().enumerate().take(5).skip(1) {
        assert!(*l > 0.1, "joint {} never loaded", j + 1);
    }
}

/// A massless model has no torques; torques scale linearly with the masses.
#[test]
fn torques_scale_with_mass() {
    let robot = aria::nominal();
    let q = [0.2, 0.9, -0.6, 0.4, 1.1, 0.3];
    let light = robot
        .with_mass(MassModel::massless())
        .expect("massless")
        .gravity_torques(&q);
    assert_eq!(light, [0.0; 6]);
    let mut heavy_model = aria::MASS_MODEL;
    heavy_model.link_masses_kg = heavy_model.link_masses_kg.map(|m| 2.0 * m);
    heavy_model.tool_mass_kg *= 2.0;
    let heavy = robot
        .with_mass(heavy_model)
        .expect("heavy")
        .gravity_torques(&q);
    let base = robot.gravity_torques(&q);
    for j in 0..6 {
        assert!((heavy[j] - 2.0 * base[j]).abs() < 1e-12 * (1.0 + base[j].abs()));
    }
}
