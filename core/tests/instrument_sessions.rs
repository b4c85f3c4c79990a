//! One base frame per session for instrument rows ([`kincal::identify::instrument_sessions`]):
//! noise-free recovery of the geometry and of every session's frame (instrument rows only,
//! the first session in the base frame; and every session in a frame of its own, mixed
//! with targets, where the analysis names the base as gauge); noisy fits within their
//! standard errors over many seeds, with σ² corrected for 6 eliminated parameters per
//! session.

mod common;

use common::{SplitMix64, arm7};
use kincal::identify::{
    Algorithm, ComponentMask, ConstraintData, Contact, Group, GroupKind, Identification,
    IdentifyOptions, InstrumentSession, Measurement, Workspace, analyze_constrained,
    identify_constrained,
};
use kincal::ik::{IkOptions, solve_ik};
use kincal::params::{ParamId, ParamSet};
use kincal::pose::pose_from_vector6;
use kincal::{JointState, ParamIndex, Robot, Transform};

type Ws = Workspace<128>;

fn workspace() -> Box<Ws> {
    // SAFETY: all-zero is a valid Workspace (documented).
    unsafe { Box::new_zeroed().assume_init() }
}

/// Nominal arm with a ball 10 cm out along the tool z axis.
fn nominal() -> Robot<7> {
    arm7()
        .with_tool([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
        .expect("tool")
}

fn geometric() -> ParamSet {
    let mut set = ParamSet::new();
    for i in 0..Robot::<7>::NUM_GEOMETRIC_PARAMS {
        set.insert(i).expect("insert");
    }
    set
}

fn name(i: usize) -> String {
    format!("{:?}", ParamId::from_index(ParamIndex(i), 7).expect("id"))
}

/// Three markers on the tool: positions of each make the tool's orientation observable.
const POINTS: [[f64; 3]; 3] = [[0.05, 0.0, 0.0], [0.0, 0.05, 0.0], [0.0, 0.0, 0.05]];

/// Instrument rows in `n` sessions of `per` rows (positions of the three markers, noise
/// σ per axis in metres), each session measured in a random frame; with `first_in_base`
/// the first session is measured in the robot's base frame and is no [`InstrumentSession`].
struct Rows {
    rows: Vec<Measurement<7>>,
    sessions: Vec<InstrumentSession>,
    /// Per session (all of them), robot base → measuring frame.
    frames: Vec<Transform>,
}

fn instrument_rows(
    robot: &Robot<7>,
    n: usize,
    per: usize,
    first_in_base: bool,
    sigma: f64,
    rng: &mut SplitMix64,
) -> Rows {
    let mut out = Rows {
        rows: vec![],
        sessions: vec![],
        frames: vec![],
    };
    for s in 0..n {
        let frame = if s == 0 && first_in_base {
            Transform::identity()
        } else {
            let mut v = [0.0; 6];
            for (k, x) in v.iter_mut().enumerate() {
                *x = if k < 3 {
                    rng.uniform(-3.0, 3.0)
                } else {
                    rng.uniform(-1.5, 1.5)
                };
            }
            pose_from_vector6(&v)
        };
        if !(s == 0 && first_in_base) {
            out.sessions.push(InstrumentSession {
                start: out.rows.len(),
                len: per,
            });
        }
        for k in 0..per {
            let q = rng.q_within(robot.limits()).map(|v| 0.8 * v);
            let mut m = Measurement::new(q, Transform::identity());
            m.mask = ComponentMask::POSITION;
            m.point = Some(POINTS[k % 3]);
            m.pose = frame * m.model_pose(robot).expect("fk");
            m.pose.translation.vector += nalgebra::Vector3::from(gauss3(rng, sigma));
            out.rows.push(m);
        }
        out.frames.push(frame);
    }
    out
}

fn gauss3(rng: &mut SplitMix64, sigma: f64) -> [f64; 3] {
    let mut g = [0.0; 3];
    for v in &mut g {
        let (u1, u2) = (rng.uniform(1e-12, 1.0), rng.unit());
        *v = sigma * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
    }
    g
}

/// The truth: the nominal arm with every parameter the analysis of `data` keeps perturbed
/// (structurally redundant ones are equivalent only to first order), base included unless
/// it is gauge.
fn truth_for(data: &ConstraintData<'_, 7>, seed: u64) -> Robot<7> {
    let nominal = nominal();
    let mut ws = workspace();
    let opts = IdentifyOptions::new(Algorithm::Ols, geometric());
    let a = analyze_constrained(&nominal, data, &opts, &mut ws).expect("analysis");
    let mut rng = SplitMix64::new(seed);
    let mut r = nominal;
    for i in a.identifiable.iter() {
        let id = ParamId::from_index(ParamIndex(i), 7).expect("id");
        let h = if id.is_length() { 0.003 } else { 0.01 };
        let v = r.param(ParamIndex(i)).expect("param") + rng.uniform(-h, h);
        r.set_param(ParamIndex(i), v).expect("set");
    }
    r
}

/// The rows re-measured by `truth` in the same frames (noise-free).
fn remeasure(truth: &Robot<7>, rows: &mut Rows) {
    let bounds: Vec<(usize, usize)> = rows
        .sessions
        .iter()
        .map(|s| (s.start, s.start + s.len))
        .collect();
    let offset = rows.frames.len() - rows.sessions.len();
    for (l, m) in rows.rows.iter_mut().enumerate() {
        let s = bounds
            .iter()
            .position(|&(a, b)| (a..b).contains(&l))
            .map_or(0, |k| k + offset);
        m.pose = rows.frames[s] * m.model_pose(truth).expect("fk");
    }
}

fn frame_error(a: &Transform, b: &Transform) -> (f64, f64) {
    let d = a.inverse() * b;
    (
        d.translation.vector.norm(),
        kincal::pose::rotation_log(d.rotation.matrix()).norm(),
    )
}

fn check_recovery(
    fit: &Identification<7>,
    truth: &Robot<7>,
    d: &ConstraintData<'_, 7>,
    rows: &Rows,
) {
    let opts = IdentifyOptions::new(Algorithm::Ols, geometric());
    assert!(fit.fitted.rms_pos_m < 1e-10, "rms {}", fit.fitted.rms_pos_m);
    assert!(
        fit.analysis.data_deficient.is_empty(),
        "{:?}",
        fit.analysis
            .data_deficient
            .iter()
            .map(name)
            .collect::<Vec<_>>()
    );
    let mut worst = 0.0f64;
    for i in fit.analysis.identifiable.iter() {
        let (got, want) = (
            fit.robot.param(ParamIndex(i)).unwrap(),
            truth.param(ParamIndex(i)).unwrap(),
        );
        worst = worst.max((got - want).abs());
        assert!((got - want).abs() < 1e-9, "{} {got} vs {want}", name(i));
    }
    let offset = rows.frames.len() - rows.sessions.len();
    let mut worst_frame = (0.0f64, 0.0f64);
    for s in 0..rows.sessions.len() {
        let got = d.session_frame(&fit.robot, s, &opts).expect("frame");
        let (dt, dr) = frame_error(&got, &rows.frames[s + offset]);
        worst_frame = (worst_frame.0.max(dt), worst_frame.1.max(dr));
        assert!(dt < 1e-9 && dr < 1e-9, "session {s}: {dt} m, {dr} rad");
    }
    eprintln!(
        "iterations {}, {} parameters, worst parameter error {worst:.1e}, worst frame {:.1e} m {:.1e} rad",
        fit.iterations,
        fit.analysis.identifiable.len(),
        worst_frame.0,
        worst_frame.1
    );
}

#[test]
fn noise_free_sessions_recover_the_geometry_and_every_frame() {
    let mut rng = SplitMix64::new(41);
    let mut rows = instrument_rows(&nominal(), 4, 30, true, 0.0, &mut rng);
    let view = |r: &Rows| -> (Vec<Measurement<7>>, Vec<InstrumentSession>) {
        (r.rows.clone(), r.sessions.clone())
    };
    let (m, s) = view(&rows);
    let probe = ConstraintData {
        instrument: &m,
        contacts: &[],
        groups: &[],
        distances: &[],
        sessions: &s,
    };
    let truth = truth_for(&probe, 5);
    remeasure(&truth, &mut rows);
    let d = ConstraintData {
        instrument: &rows.rows,
        contacts: &[],
        groups: &[],
        distances: &[],
        sessions: &rows.sessions,
    };
    let mut ws = workspace();
    let opts = IdentifyOptions::new(Algorithm::Ols, geometric());
    let fit = identify_constrained(&nominal(), &d, &opts, &mut ws).expect("identify");
    // The first session is in the base frame: the base is observable, nothing is gauge.
    assert!(
        fit.analysis.gauge.is_empty(),
        "{:?}",
        fit.analysis.gauge.iter().map(name).collect::<Vec<_>>()
    );
    for k in [35, 36, 38, 39] {
        assert!(fit.analysis.identifiable.contains(k), "{}", name(k));
    }
    check_recovery(&fit, &truth, &d, &rows);
    // OPT2 (its own solver over the same reduced rows) lands on the same model.
    let opts2 = IdentifyOptions::new(Algorithm::Opt2, geometric());
    let fit2 = identify_constrained(&nominal(), &d, &opts2, &mut ws).expect("identify");
    check_recovery(&fit2, &truth, &d, &rows);
}

fn rot(axis: [f64; 3], angle: f64) -> nalgebra::Rotation3<f64> {
    nalgebra::Rotation3::from_scaled_axis(nalgebra::Vector3::new(
        axis[0] * angle,
        axis[1] * angle,
        axis[2] * angle,
    ))
}

/// `n` joint states holding the tool point of `robot` at a random point in orientations
/// tilted up to 0.4 rad (IK on `robot`).
fn target_contacts(robot: &Robot<7>, n: usize, rng: &mut SplitMix64) -> Vec<Contact<7>> {
    let opts = IkOptions {
        extra_seeds: 4,
        first_solution: true,
        ..IkOptions::default()
    };
    let q0 = rng.q_within(robot.limits()).map(|v| 0.6 * v);
    let t0 = robot.fk(&JointState::new(q0)).expect("fk");
    let mut out = Vec::new();
    let mut tries = 0;
    while out.len() < n && tries < 10 * n {
        tries += 1;
        let r = t0.rotation * rot(rng.unit_vector(), rng.uniform(0.0, 0.4));
        let pose = Transform::from_parts(t0.translation, r);
        if let Ok(sol) = solve_ik(robot, &pose, &JointState::new(q0), &opts)
            && sol.residual_pos_m < 1e-12
        {
            out.push(Contact::new(sol.q));
        }
    }
    assert_eq!(out.len(), n, "IK failed");
    out
}

#[test]
fn every_session_in_its_own_frame_with_targets_makes_the_base_gauge() {
    let mut rng = SplitMix64::new(97);
    let mut rows = instrument_rows(&nominal(), 3, 24, false, 0.0, &mut rng);
    let d0 = ConstraintData {
        instrument: &rows.rows.clone(),
        contacts: &[],
        groups: &[],
        distances: &[],
        sessions: &rows.sessions.clone(),
    };
    let truth = truth_for(&d0, 13);
    // The base is gauge: the truth keeps the nominal base, so the frames are recoverable.
    for k in 35..41 {
        assert_eq!(truth.param(ParamIndex(k)), nominal().param(ParamIndex(k)));
    }
    remeasure(&truth, &mut rows);
    let mut contacts = Vec::new();
    let mut groups = Vec::new();
    for _ in 0..4 {
        let c = target_contacts(&truth, 6, &mut rng);
        groups.push(Group {
            kind: GroupKind::Target,
            start: contacts.len(),
            len: c.len(),
        });
        contacts.extend(c);
    }
    let d = ConstraintData {
        instrument: &rows.rows,
        contacts: &contacts,
        groups: &groups,
        distances: &[],
        sessions: &rows.sessions,
    };
    assert!(!d.has_external_reference() && d.has_length_reference());
    let mut ws = workspace();
    let opts = IdentifyOptions::new(Algorithm::Ols, geometric());
    let fit = identify_constrained(&nominal(), &d, &opts, &mut ws).expect("identify");
    let gauge: Vec<_> = fit.analysis.gauge.iter().collect();
    for k in 35..41 {
        assert!(gauge.contains(&k), "base {} not gauge: {gauge:?}", name(k));
    }
    // No length is held as a scale gauge: the instrument measures lengths in any frame.
    assert!(
        gauge.iter().all(|&i| i >= 35
            || !ParamId::from_index(ParamIndex(i), 7).unwrap().is_length()
            || i < 5),
        "{:?}",
        gauge.iter().map(|&i| name(i)).collect::<Vec<_>>()
    );
    check_recovery(&fit, &truth, &d, &rows);
    // Targets consistent to the noise-free level.
    for g in 0..groups.len() {
        let e = kincal::identify::group_estimate(&fit.robot, &d, g).expect("estimate");
        assert!(e.max_m < 1e-10, "target {g}: {}", e.max_m);
    }
}

#[test]
fn noisy_estimates_lie_within_their_standard_errors() {
    let sigma = 1e-4;
    let mut z2 = Vec::new();
    let mut outside_3 = 0;
    let mut sigma_ratio = Vec::new();
    for seed in 0..16u64 {
        let mut rng = SplitMix64::new(500 + seed);
        let rows = instrument_rows(&nominal(), 4, 15, true, 0.0, &mut rng);
        let probe = ConstraintData {
            instrument: &rows.rows,
            contacts: &[],
            groups: &[],
            distances: &[],
            sessions: &rows.sessions,
        };
        let truth = truth_for(&probe, 900 + seed);
        let mut noisy = Rows {
            rows: rows.rows.clone(),
            sessions: rows.sessions.clone(),
            frames: rows.frames.clone(),
        };
        remeasure(&truth, &mut noisy);
        for m in &mut noisy.rows {
            m.pose.translation.vector += nalgebra::Vector3::from(gauss3(&mut rng, sigma));
        }
        let d = ConstraintData {
            instrument: &noisy.rows,
            contacts: &[],
            groups: &[],
            distances: &[],
            sessions: &noisy.sessions,
        };
        let mut ws = workspace();
        let opts = IdentifyOptions::new(Algorithm::Ols, geometric());
        let fit = identify_constrained(&nominal(), &d, &opts, &mut ws).expect("identify");
        sigma_ratio.push(fit.sigma2.sqrt() / sigma);
        for i in fit.analysis.identifiable.iter() {
            let se = fit.std_errors[i];
            let e = fit.robot.param(ParamIndex(i)).unwrap() - truth.param(ParamIndex(i)).unwrap();
            let z = e / se;
            z2.push(z * z);
            if z.abs() > 3.0 {
                outside_3 += 1;
            }
        }
    }
    let mean = z2.iter().sum::<f64>() / z2.len() as f64;
    let mean_ratio = sigma_ratio.iter().sum::<f64>() / sigma_ratio.len() as f64;
    eprintln!(
        "{} estimates over 16 seeds: mean z² {mean:.3}, {outside_3} beyond 3 se, mean σ̂/σ {mean_ratio:.3}",
        z2.len()
    );
    // σ̂ is unbiased only with 6 parameters per session subtracted from the degrees of
    // freedom (4 sessions × 45 coordinates, 18 eliminated: ~7 % low otherwise).
    assert!((mean_ratio - 1.0).abs() < 0.045, "mean σ̂/σ {mean_ratio}");
    assert!(
        (0.6..1.6).contains(&mean),
        "mean z² {mean} over {}",
        z2.len()
    );
    assert!(
        outside_3 as f64 <= 0.02 * z2.len() as f64,
        "{outside_3} of {} beyond 3 se",
        z2.len()
    );
}
