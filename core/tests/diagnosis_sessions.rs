//! Confounding with the sessions (#14 item 5; core/src/diagnosis/sessions.rs): a thermal
//! expansion present only as a per-session constant temperature cannot be attributed to
//! temperature (each session has its own base frame and set-up), while the same arm with
//! two temperatures inside one session identifies it. Both directions are checked, so the
//! test fails if the session test is missing (thermal chosen) or too eager (thermal never
//! chosen).

use kincal::diagnosis::{
    Config, DiagWorkspace, Diagnosis, PoseDiagnosis, Reason, diagnose_sessions_into,
};
use kincal::identify::Measurement;
use kincal::rng::SplitMix64;
use kincal::{Effect, EffectSet, JointState, ParamId, Robot, aria};

/// Thermal expansion of the truth [1/K] (steel is ~1.2e-5; this is exaggerated so that the
/// effect, about 0.6 mm at the reach over ±10 K, stands far above the noise).
const KAPPA: f64 = 1e-4;
/// Position noise, 1σ per axis [m].
const SIGMA: f64 = 5e-5;
const ROWS_PER_SESSION: usize = 120;
/// Measured components (full poses: position-only rows leave the fit of thermal with the
/// geometry slow to converge on this arm).
const MASK: kincal::identify::ComponentMask = kincal::identify::ComponentMask::ALL;

/// Rows of two sessions (0 and 1) measured in the robot's base frame (as registered):
/// `temp(session, k)` gives row k's temperature.
fn data(temp: impl Fn(u16, usize) -> f64) -> (Vec<Measurement<6>>, Vec<u16>) {
    let mut truth = aria::nominal();
    truth
        .set_param(ParamId::Thermal.index(6), KAPPA)
        .expect("thermal parameter");
    let mut rng = SplitMix64::new(0x5e55_1045);
    let mut out = Vec::new();
    let mut sessions = Vec::new();
    for s in 0..2u16 {
        for k in 0..ROWS_PER_SESSION {
            let mut st = JointState::new([0.0; 6]);
            for (q, l) in st.q.iter_mut().zip(truth.limits()) {
                *q = rng.range(l.lower.max(-2.5), l.upper.min(2.5));
            }
            st.temp_c = Some(temp(s, k));
            let mut pose = truth.fk(&st).expect("fk");
            for v in pose.translation.vector.iter_mut() {
                *v += SIGMA * rng.normal();
            }
            let mut m = Measurement::new(st.q, pose);
            m.mask = MASK;
            m.state = st;
            out.push(m);
            sessions.push(s);
        }
    }
    (out, sessions)
}

fn run(data: &[Measurement<6>], sessions: &[u16]) -> Box<Diagnosis<6>> {
    let robot: Robot<6> = aria::nominal();
    let groups: Vec<u32> = (0..data.len() as u32).collect();
    let cfg = Config {
        sigma_pos_m: Some(SIGMA),
        sigma_rot_rad: Some(1e-4),
        candidates: Some(
            EffectSet::NONE
                .with(Effect::Thermal)
                .with(Effect::JointScale)
                .with(Effect::BaseFrame),
        ),
        pairs: false,
        ..Config::default()
    };
    let mut poses = vec![PoseDiagnosis::default(); data.len()];
    // SAFETY: the core documents all-zero as a valid `DiagWorkspace`.
    let mut ws: Box<DiagWorkspace<80>> = unsafe { Box::new_zeroed().assume_init() };
    let mut out = Box::new(Diagnosis::new(&robot));
    diagnose_sessions_into(
        &robot, data, &groups, sessions, &cfg, &mut poses, &mut ws, &mut out,
    )
    .expect("diagnosis");
    out
}

fn thermal(d: &Diagnosis<6>) -> kincal::diagnosis::ModelScore {
    *d.candidates()
        .iter()
        .find(|c| c.effects == EffectSet::of(Effect::Thermal))
        .expect("thermal candidate")
}

/// One temperature per session (10 °C and 30 °C): thermal improves the fit, but its input
/// is constant within each session, so it is listed as confounded with the sessions and
/// not chosen.
#[test]
fn thermal_constant_within_sessions_is_confounded_not_chosen() {
    let (data, sessions) = data(|s, _| if s == 0 { 10.0 } else { 30.0 });
    let d = run(&data, &sessions);
    let t = thermal(&d);
    assert!(t.evaluated && t.significant, "{t:?}");
    assert!(t.session.evaluated, "{:?}", t.session);
    assert!(
        t.session.input_constant && t.session.confounded(),
        "{:?}",
        t.session
    );
    assert!(
        t.session.input_sin.is_some_and(|s| s < 1e-12),
        "{:?}",
        t.session
    );
    assert!(
        !d.verdict.effects.contains(Effect::Thermal),
        "thermal chosen: {:?}",
        d.verdict
    );
    assert!(
        d.verdict
            .confounded()
            .contains(&EffectSet::of(Effect::Thermal)),
        "thermal not listed as confounded: {:?}",
        d.verdict
    );
    // A global base-frame error is the sum of the per-session frames: its columns lie in
    // their span.
    let base = d
        .candidates()
        .iter()
        .find(|c| c.effects == EffectSet::of(Effect::BaseFrame))
        .expect("base_frame candidate");
    if base.evaluated {
        assert!(
            base.session.columns_in_span && base.session.column_sin < 1e-6,
            "{:?}",
            base.session
        );
    }
    if d.verdict.effects.is_empty() {
        assert_eq!(d.verdict.reason, Reason::ConfoundedWithSessions);
    }
}

/// The same arm with two temperatures inside session 0 (10 °C and 30 °C alternating;
/// session 1 at 30 °C): thermal is not confounded, it is chosen, and it lowers the
/// held-out RMS far below the geometric model's.
#[test]
fn thermal_varying_within_a_session_is_identified() {
    let (data, sessions) = data(|s, k| if s == 0 && k % 2 == 0 { 10.0 } else { 30.0 });
    let d = run(&data, &sessions);
    let t = thermal(&d);
    assert!(
        t.session.evaluated && !t.session.confounded(),
        "{:?}",
        t.session
    );
    assert!(
        t.session.input_sin.is_some_and(|s| s > 0.5),
        "{:?}",
        t.session
    );
    assert_eq!(
        d.verdict.effects,
        EffectSet::of(Effect::Thermal),
        "{:?}",
        d.verdict
    );
    let gain = d.baseline.heldout_rms_pos_m - t.heldout_rms_pos_m;
    assert!(
        gain > 0.5 * d.baseline.heldout_rms_pos_m && t.improvement_z > 3.0,
        "held-out gain {gain} m of {} m, z {}",
        d.baseline.heldout_rms_pos_m,
        t.improvement_z
    );
    let k = d.model.param(ParamId::Thermal.index(6)).unwrap();
    assert!((k - KAPPA).abs() < 0.05 * KAPPA, "kappa {k} vs {KAPPA}");
}
