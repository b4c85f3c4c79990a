//! Starting base and tool frames from measured poses (`kincal::frames`): exact on
//! noise-free data of the nominal geometry, close with noise and small geometric errors,
//! for full poses, one point and several points; degenerate data are errors.

mod common;

use common::SplitMix64;
use kincal::frames::estimate_frames;
use kincal::identify::{ComponentMask, Measurement};
use kincal::pose::{pose_error, pose_from_vector6, pose_to_vector6};
use kincal::{OrientationError, ParamIndex, Robot, Transform, aria};

/// Far-off frames: the base turned by ~2 rad and moved a metre, the tool by ~1.6 rad.
const BASE: [f64; 6] = [0.8, -1.1, 0.6, 0.9, -1.2, 1.3];
const TOOL: [f64; 6] = [0.06, -0.03, 0.11, 1.2, 0.7, -0.8];

fn gauss(rng: &mut SplitMix64) -> f64 {
    let u1 = rng.uniform(1e-300, 1.0);
    let u2 = rng.unit();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

fn truth(geometry_error: bool) -> Robot<6> {
    let mut r = aria::nominal()
        .with_base(BASE)
        .and_then(|r| r.with_tool(TOOL))
        .expect("truth");
    if geometry_error {
        r.set_param(ParamIndex(7), 0.412).expect("a_2");
        r.set_param(ParamIndex(15), 0.02).expect("theta0_4");
    }
    r
}

fn data(
    truth: &Robot<6>,
    points: &[Option<[f64; 3]>],
    mask: ComponentMask,
    n: usize,
    sigma: f64,
    seed: u64,
) -> Vec<Measurement<6>> {
    let mut rng = SplitMix64::new(seed);
    let mut out = Vec::new();
    for _ in 0..n {
        let q = rng.q_within(truth.limits());
        for &point in points {
            let mut m = Measurement::new(q, Transform::identity());
            m.point = point;
            m.mask = mask;
            let mut t = m.model_pose(truth).expect("pose");
            t.translation.vector += nalgebra::Vector3::new(
                sigma * gauss(&mut rng),
                sigma * gauss(&mut rng),
                sigma * gauss(&mut rng),
            );
            m.pose = t;
            out.push(m);
        }
    }
    out
}

fn frame_error(a: &[f64; 6], b: &[f64; 6]) -> (f64, f64) {
    let e = pose_error(
        &pose_from_vector6(a),
        &pose_from_vector6(b),
        OrientationError::Exact,
    );
    (
        (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt(),
        (e[3] * e[3] + e[4] * e[4] + e[5] * e[5]).sqrt(),
    )
}

#[test]
fn full_poses_give_both_frames_exactly() {
    let t = truth(false);
    let d = data(&t, &[None], ComponentMask::ALL, 12, 0.0, 1);
    let est = estimate_frames(&aria::nominal(), &d).expect("estimate");
    assert!(est.tool_rotation_estimated);
    let (bp, br) = frame_error(&est.robot.base(), &BASE);
    let (tp, tr) = frame_error(&est.robot.tool(), &TOOL);
    assert!(
        bp < 1e-9 && br < 1e-9 && tp < 1e-9 && tr < 1e-9,
        "{bp:e} {br:e} {tp:e} {tr:e}"
    );
    assert!(est.rms_pos_m < 1e-9 && est.rms_rot_rad < 1e-9);
    // Gravity turns with the base frame.
    let g = est.base_change.rotation * nalgebra::Vector3::new(0.0, 0.0, -9.81);
    let got = est.robot.mass().gravity;
    assert!((nalgebra::Vector3::from(got) - g).norm() < 1e-12);
    // The estimate starts from the robot's own frames: a start near the truth gives the same.
    let near = aria::nominal()
        .with_base([0.7, -1.0, 0.5, 1.0, -1.1, 1.2])
        .expect("near");
    let est2 = estimate_frames(&near, &d).expect("estimate");
    assert!(frame_error(&est2.robot.base(), &BASE).0 < 1e-9);
}

#[test]
fn noise_and_geometric_error_leave_frames_close() {
    let t = truth(true);
    let d = data(&t, &[None], ComponentMask::ALL, 40, 1e-4, 2);
    let est = estimate_frames(&aria::nominal(), &d).expect("estimate");
    let (bp, br) = frame_error(&est.robot.base(), &BASE);
    let (tp, tr) = frame_error(&est.robot.tool(), &TOOL);
    // Close enough for the identification to take over (millimetres, a degree or so).
    assert!(
        bp < 0.02 && br < 0.03 && tp < 0.02 && tr < 0.03,
        "{bp} {br} {tp} {tr}"
    );
}

#[test]
fn one_point_gives_base_and_tool_translation() {
    let t = truth(false);
    let d = data(&t, &[None], ComponentMask::POSITION, 30, 0.0, 3);
    let est = estimate_frames(&aria::nominal(), &d).expect("estimate");
    assert!(!est.tool_rotation_estimated);
    let (bp, br) = frame_error(&est.robot.base(), &BASE);
    assert!(bp < 1e-7 && br < 1e-7, "{bp:e} {br:e}");
    // The tool origin (in the last link frame) is found; its rotation stays as it was.
    let got = pose_from_vector6(&est.robot.tool()).translation.vector;
    let want = pose_from_vector6(&TOOL).translation.vector;
    assert!((got - want).norm() < 1e-7);
    assert_eq!(pose_to_vector6(&est.tool_change)[3..], [0.0; 3]);
    assert!(est.rms_pos_m < 1e-7);
}

#[test]
fn several_points_give_the_tool_rotation() {
    let t = truth(false);
    let probe = [
        Some([0.05, 0.0, 0.0]),
        Some([0.0, 0.04, 0.01]),
        Some([-0.03, -0.02, 0.05]),
    ];
    let d = data(&t, &probe, ComponentMask::POSITION, 20, 0.0, 4);
    let est = estimate_frames(&aria::nominal(), &d).expect("estimate");
    assert!(est.tool_rotation_estimated);
    let (tp, tr) = frame_error(&est.robot.tool(), &TOOL);
    assert!(tp < 1e-7 && tr < 1e-7, "{tp:e} {tr:e}");
}

#[test]
fn degenerate_data_are_errors() {
    let t = truth(false);
    // Two poses: too few.
    let d = data(&t, &[None], ComponentMask::ALL, 2, 0.0, 5);
    assert!(estimate_frames(&aria::nominal(), &d).is_err());
    // Only joint 1 moves: every relative rotation is about one axis.
    let mut d = data(&t, &[None], ComponentMask::ALL, 1, 0.0, 6);
    let q0 = d[0].state.q;
    for k in 1..10 {
        let mut q = q0;
        q[0] += 0.3 * k as f64;
        let mut m = Measurement::new(q, Transform::identity());
        m.pose = m.model_pose(&t).expect("pose");
        d.push(m);
    }
    assert!(matches!(
        estimate_frames(&aria::nominal(), &d),
        Err(kincal::Error::RankDeficient { .. })
    ));
}
