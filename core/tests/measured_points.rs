//! Measurements of points on the end effector ([`Measurement::point`]): the model pose and
//! its Jacobian against central finite differences, and identification from several
//! position-only points on one body (the tool rotation becomes identifiable).

mod common;

use common::{SplitMix64, arm7, full_state, mul_abt, perturbed, rot_rows, small_rotation_log};
use kincal::identify::{
    Algorithm, ComponentMask, IdentifyOptions, Measurement, Workspace, analyze, identify,
};
use kincal::params::{FrameParam, ParamId};
use kincal::{Effect, EffectSet, JacobianColumn, ParamIndex, Robot, aria};

/// Largest accepted relative error between analytic and finite-difference columns (as in
/// `jacobian_fd.rs`).
const REL_TOL: f64 = 1e-6;
/// Column magnitude below which the error is measured absolutely (times this floor).
const SCALE_FLOOR: f64 = 1e-3;
/// Central-difference step [m or rad per unit].
const STEP: f64 = 1e-6;

type Ws = Workspace<128>;

fn workspace() -> Box<Ws> {
    // SAFETY: all-zero is a valid Workspace (documented).
    unsafe { Box::new_zeroed().assume_init() }
}

fn fd_column<const N: usize>(robot: &Robot<N>, m: &Measurement<N>, i: usize) -> JacobianColumn {
    let id = ParamId::from_index(ParamIndex(i), N).expect("index");
    // Effect parameters enter through a factor; keep the geometric step for all (columns of
    // effects whose factor is small are compared absolutely through SCALE_FLOOR).
    let h = match id {
        ParamId::Thermal => 1e-3,
        ParamId::Compliance(_) => 1e-7,
        _ => STEP,
    };
    let v = robot.param(ParamIndex(i)).expect("param");
    let eval = |x: f64| {
        let mut r = *robot;
        r.set_param(ParamIndex(i), x).expect("set_param");
        m.model_pose(&r).expect("model pose")
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

fn check_point_columns<const N: usize>(name: &str, robot: &Robot<N>, seed: u64) {
    let mut rng = SplitMix64::new(seed);
    let mut jac = vec![[0.0; 6]; Robot::<N>::NUM_PARAMS];
    for c in 0..10 {
        let state = full_state(&mut rng, robot.limits());
        let point = [
            rng.uniform(-0.1, 0.1),
            rng.uniform(-0.1, 0.1),
            rng.uniform(0.0, 0.2),
        ];
        let m = Measurement {
            point: Some(point),
            ..Measurement::new(state.q, kincal::Transform::identity())
        };
        let m = Measurement { state, ..m };
        let pose = m.model_jacobian(robot, &mut jac).expect("jacobian");
        // The model pose is the tool frame moved to the point, not rotated.
        let t = robot.fk(&state).expect("fk");
        let want = t * nalgebra::Translation3::new(point[0], point[1], point[2]);
        assert!((pose.to_homogeneous() - want.to_homogeneous()).abs().max() < 1e-15);
        assert!((pose.rotation.matrix() - t.rotation.matrix()).abs().max() == 0.0);
        for (i, col) in jac.iter().enumerate() {
            let fd = fd_column(robot, &m, i);
            let block = |r: std::ops::Range<usize>| {
                let diff = r
                    .clone()
                    .map(|k| (col[k] - fd[k]).abs())
                    .fold(0.0, f64::max);
                let scale = r.map(|k| fd[k].abs()).fold(0.0, f64::max);
                diff / scale.max(SCALE_FLOOR)
            };
            let (ep, er) = (block(0..3), block(3..6));
            let id = ParamId::from_index(ParamIndex(i), N).expect("index");
            assert!(
                ep < REL_TOL && er < REL_TOL,
                "{name}, config {c}, column {i} ({id}): relative error {ep:.3e} (position), \
                 {er:.3e} (orientation)\n analytic {col:?}\n fd       {fd:?}"
            );
        }
    }
}

#[test]
fn point_jacobian_matches_finite_differences() {
    check_point_columns("perturbed ARIA", &perturbed(&aria::nominal(), 31), 32);
    check_point_columns("perturbed 7-joint arm", &perturbed(&arm7(), 33), 34);
}

/// Noise-free position-only measurements of `points` (in the tool frame) at `n` poses.
fn point_data(truth: &Robot<6>, points: &[[f64; 3]], n: usize, seed: u64) -> Vec<Measurement<6>> {
    let mut rng = SplitMix64::new(seed);
    let mut out = Vec::new();
    for _ in 0..n {
        let q = rng.q_within(truth.limits());
        for &p in points {
            let mut m = Measurement::new(q, kincal::Transform::identity());
            m.point = Some(p);
            m.mask = ComponentMask::POSITION;
            m.pose = m.model_pose(truth).expect("truth");
            out.push(m);
        }
    }
    out
}

#[test]
fn several_points_determine_the_tool_orientation() {
    let start = aria::nominal();
    let mut truth = start;
    // A tool frame the calibration must find: 4 cm out, turned by ~0.2 rad.
    for (k, v) in [0.01, -0.02, 0.04, 0.1, -0.15, 0.05]
        .into_iter()
        .enumerate()
    {
        truth
            .set_param(ParamIndex(ParamId::Tool(FrameParam::ALL[k]).index(6).0), v)
            .expect("tool");
    }
    truth.set_param(ParamIndex(7), 0.4105).expect("a_2"); // a_2 = 0.41 -> 0.4105
    let requested = start.param_set(EffectSet::of(Effect::ToolFrame));
    let opts = IdentifyOptions::new(Algorithm::Ols, requested);
    let mut ws = workspace();

    // One point (the tool origin): the orientation of the last frame is invisible, fewer
    // parameters are identifiable than with full poses.
    let single = point_data(&truth, &[[0.0; 3]], 40, 41);
    let a1 = analyze(&start, &single, &opts, &mut ws).expect("analyze");
    let mut full = single.clone();
    for m in &mut full {
        m.mask = ComponentMask::ALL;
        m.pose = m.model_pose(&truth).expect("truth");
    }
    let a_full = analyze(&start, &full, &opts, &mut ws).expect("analyze");
    assert!(a1.identifiable.len() < a_full.identifiable.len());

    // Three non-collinear points on the probe: as many as with full poses.
    let probe = [[0.05, 0.0, 0.02], [-0.03, 0.04, 0.0], [0.0, -0.05, 0.06]];
    let data = point_data(&truth, &probe, 40, 42);
    let a3 = analyze(&start, &data, &opts, &mut ws).expect("analyze");
    assert_eq!(a3.identifiable, a_full.identifiable);
    assert!(a3.data_deficient.is_empty());
    let fit = identify(&start, &data, &opts, &mut ws).expect("identify");
    assert!(
        fit.fitted.rms_pos_m < 1e-10,
        "rms {:e}",
        fit.fitted.rms_pos_m
    );
    // The fitted model predicts the whole tool pose, orientation included, at new poses.
    let mut rng = SplitMix64::new(43);
    for _ in 0..20 {
        let q = rng.q_within(truth.limits());
        let (a, b) = (fit.robot.fk_q(&q).unwrap(), truth.fk_q(&q).unwrap());
        assert!((a.to_homogeneous() - b.to_homogeneous()).abs().max() < 1e-8);
    }
    // With one point it cannot: the fit matches the points but not the orientation.
    let fit1 = identify(&start, &single, &opts, &mut ws).expect("identify");
    assert!(fit1.fitted.rms_pos_m < 1e-10);
    let q = rng.q_within(truth.limits());
    let (a, b) = (fit1.robot.fk_q(&q).unwrap(), truth.fk_q(&q).unwrap());
    assert!((a.rotation.matrix() - b.rotation.matrix()).abs().max() > 1e-3);
}

#[test]
fn non_finite_point_is_refused() {
    let mut m = Measurement::new([0.0; 6], kincal::Transform::identity());
    m.point = Some([0.0, f64::NAN, 0.0]);
    let opts = IdentifyOptions::new(Algorithm::Ols, aria::nominal().geometric_param_set());
    let err = identify(&aria::nominal(), &[m; 30], &opts, &mut workspace()).unwrap_err();
    assert!(
        matches!(err, kincal::Error::NonFinite { .. }),
        "unexpected error {err:?}"
    );
}
