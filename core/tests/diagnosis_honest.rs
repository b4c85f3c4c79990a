//! Regression tests of issue #12 (an honest diagnosis): each failed on the code before
//! the fix it names.

mod common;

use common::arm7;
use kincal::diagnosis::{
    Config, DiagWorkspace, Diagnosis, GapTest, Method, ModelScore, Part, PoseDiagnosis, Reason,
    Status, Warning, decide, diagnose,
};
use kincal::identify::{Algorithm, IdentifyOptions, Measurement, Workspace, analyze, identify};
use kincal::ik::{IkOptions, solve_ik};
use kincal::rng::SplitMix64;
use kincal::sim::{
    SessionConfig, add_effect, add_noise, measure, perturb_geometry, simulate_session,
};
use kincal::{Effect, EffectSet, JointState, ParamId, Robot, Transform, aria};

/// Noise-free measurements of `truth` at `n` random configurations within the limits, each
/// with random approach directions.
fn random_poses<const N: usize>(truth: &Robot<N>, n: usize, seed: u64) -> Vec<Measurement<N>> {
    let mut rng = SplitMix64::new(seed);
    (0..n)
        .map(|_| {
            let mut st = JointState::new([0.0; N]);
            for (q, l) in st.q.iter_mut().zip(truth.limits()) {
                *q = rng.range(l.lower.max(-3.0), l.upper.min(3.0));
            }
            let mut a = [0.0; N];
            for v in a.iter_mut() {
                *v = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
            }
            st.approach = Some(a);
            let mut m = Measurement::new(st.q, truth.fk(&st).unwrap());
            m.state = st;
            m
        })
        .collect()
}

fn backlash_not_structural<const N: usize>(robot: &Robot<N>) {
    let data = random_poses(robot, 40, 3);
    let requested = robot
        .geometric_param_set()
        .union(&Effect::Backlash.params(N));
    let mut opts = IdentifyOptions::new(Algorithm::Ols, requested);
    opts.allow_data_deficiency = true;
    let mut ws = Box::<Workspace<128>>::default();
    let a = analyze(robot, &data, &opts, &mut ws).unwrap();
    for j in 0..N {
        let i = ParamId::Backlash(j).index(N);
        assert!(
            !a.structural.contains(i.0),
            "backlash_{} of a {N}-joint arm called structurally redundant (partner {:?})",
            j + 1,
            a.partner[i.0]
        );
        assert!(
            a.identifiable.contains(i.0),
            "backlash_{} not identified",
            j + 1
        );
    }
}

/// Issue #12 item 1: the structural test drew the approach signs from a Halton digit test
/// that was −1 for the last joint in every sample, so backlash of joint 6 looked
/// redundant with theta0_6.
#[test]
fn backlash_of_every_joint_is_structurally_identifiable() {
    backlash_not_structural(&aria::nominal());
    backlash_not_structural(&arm7());
}

/// A noise-free reference fit recovers backlash of joint 6 (1.5 mrad) to 0.1 %.
#[test]
fn reference_fit_identifies_backlash_of_joint_6() {
    let mut truth = aria::nominal();
    let b6 = 1.5e-3;
    let i6 = ParamId::Backlash(5).index(6);
    truth.set_param(i6, b6).unwrap();
    let data = random_poses(&truth, 60, 5);
    let requested = truth
        .geometric_param_set()
        .union(&Effect::Backlash.params(6));
    let mut opts = IdentifyOptions::new(Algorithm::Ols, requested);
    opts.allow_data_deficiency = true;
    let mut ws = Box::<Workspace<64>>::default();
    let fit = identify(&aria::nominal(), &data, &opts, &mut ws).unwrap();
    assert!(fit.analysis.identifiable.contains(i6.0));
    let got = fit.robot.param(i6).unwrap();
    assert!(
        ((got - b6) / b6).abs() < 1e-3,
        "backlash_6 fitted {got:.6e}, truth {b6:.6e}"
    );
}

// ---------------------------------------------------------------------------------------
// The diagnosis (items 2, 3a, 4, 5, 6).

type DiagWs = DiagWorkspace<80>;

fn diag_workspace() -> Box<DiagWs> {
    // SAFETY: all-zero is a valid DiagWorkspace (documented).
    unsafe { Box::new_zeroed().assume_init() }
}

/// The nominal ARIA with random geometric errors (2 mm, 1°).
fn geometric_truth(seed: u64) -> Robot<6> {
    perturb_geometry(
        &aria::nominal(),
        2e-3,
        1f64.to_radians(),
        &mut SplitMix64::new(seed),
    )
    .unwrap()
}

/// A blind-suite session (60 poses, 20 repeated, approach directions and temperatures)
/// on `truth`, exact poses; `edit` changes the settings.
fn exact_session(
    truth: &Robot<6>,
    seed: u64,
    edit: impl FnOnce(&mut SessionConfig),
) -> (Vec<Measurement<6>>, Vec<u32>, SessionConfig) {
    let mut cfg = SessionConfig::blind_training();
    edit(&mut cfg);
    let n = cfg.measurements();
    let mut data = vec![Measurement::new([0.0; 6], Transform::identity()); n];
    let mut groups = vec![0u32; n];
    simulate_session(
        truth,
        &aria::TOOL_SEED_Q,
        &SessionConfig {
            sigma_pos_m: 0.0,
            sigma_rot_rad: 0.0,
            ..cfg
        },
        &mut SplitMix64::new(seed),
        &mut data,
        &mut groups,
    )
    .unwrap();
    (data, groups, cfg)
}

/// The session with noise.
fn noisy_session(
    truth: &Robot<6>,
    seed: u64,
    edit: impl FnOnce(&mut SessionConfig),
) -> (Vec<Measurement<6>>, Vec<u32>) {
    let (mut data, groups, cfg) = exact_session(truth, seed, edit);
    measure(
        truth,
        &mut data,
        cfg.sigma_pos_m,
        cfg.sigma_rot_rad,
        &mut SplitMix64::new(seed ^ 0x55),
    )
    .unwrap();
    (data, groups)
}

fn run_diag(
    data: &[Measurement<6>],
    groups: &[u32],
    cfg: &Config,
) -> (Diagnosis<6>, Vec<PoseDiagnosis>) {
    let mut ws = diag_workspace();
    let mut poses = vec![PoseDiagnosis::default(); data.len()];
    let d = diagnose(&aria::nominal(), data, groups, cfg, &mut poses, &mut ws).unwrap();
    (d, poses)
}

fn names(set: EffectSet) -> String {
    set.iter().map(|e| e.name()).collect::<Vec<_>>().join("+")
}

fn summary(d: &Diagnosis<6>) -> String {
    format!(
        "{} {} conf {:?} closed pos {:.2} total {:.2} gap z {:.1} remaining z {:.1} ({:.1} pos, {:.1} rot) method {:?} reason {:?} suspects {:?} warnings {:?}",
        d.verdict.status.name(),
        names(d.verdict.effects),
        d.verdict
            .confounded()
            .iter()
            .map(|&c| names(c))
            .collect::<Vec<_>>(),
        d.verdict.gap_closed_fraction,
        d.verdict
            .candidate
            .map_or(0.0, |c| d.candidates[c].gap_closed_total_fraction),
        d.gap.z,
        d.remaining.z,
        d.remaining.z_pos,
        d.remaining.z_rot,
        d.method,
        d.verdict.reason,
        d.suspects(),
        d.warnings().collect::<Vec<_>>()
    )
}

/// Issue #12 item 2: a gap that lives in rotation (a tool-frame rotation about the tool
/// origin, backlash of joint 6) is not `unexplained` when the right candidate brings the
/// held-out rotation to the floor; position and rotation shares are reported apart.
#[test]
fn rotation_gaps_are_explained_by_the_right_candidate() {
    // Scale error of joint 6 alone (2e-3): mostly rotation about axis 6.
    let mut scale = geometric_truth(21);
    scale.set_param(ParamId::Scale(5).index(6), 2e-3).unwrap();
    // Backlash of joint 6 alone (1.5 mrad): mostly rotation.
    let mut wrist = geometric_truth(22);
    wrist
        .set_param(ParamId::Backlash(5).index(6), 1.5e-3)
        .unwrap();
    for (truth, effect, seed) in [
        (scale, Effect::JointScale, 31),
        (wrist, Effect::Backlash, 32),
    ] {
        let (data, groups) = noisy_session(&truth, seed, |_| {});
        let (d, _) = run_diag(&data, &groups, &Config::default());
        let s = summary(&d);
        eprintln!(
            "{effect:?}: {s} rot rms {:.3e} -> {:.3e}, pos {:.3e} -> {:.3e}",
            d.baseline.heldout_rms_rot_rad,
            d.final_heldout_rms_rot_rad,
            d.baseline.heldout_rms_pos_m,
            d.final_heldout_rms_pos_m
        );
        assert_ne!(d.verdict.status, Status::Unexplained, "{effect:?}: {s}");
        assert_ne!(d.verdict.status, Status::NoGap, "{effect:?}: {s}");
        assert_eq!(d.verdict.effects, EffectSet::of(effect), "{s}");
        let w = &d.candidates[d.verdict.candidate.unwrap()];
        assert!(w.gap_closed_rot_fraction > 0.8, "{effect:?}: rot share {s}");
        assert!(w.gap_closed_total_fraction > 0.8, "{effect:?}: {s}");
        // The held-out rotation is at the floor: within 15 % of √3·σ_rot.
        let floor = d.noise.rms_rot_rad();
        assert!(
            d.final_heldout_rms_rot_rad < 1.15 * floor,
            "{effect:?}: rot {:.3e} floor {floor:.3e}",
            d.final_heldout_rms_rot_rad
        );
        assert!(
            w.z_rot > 3.0,
            "{effect:?}: rotation improvement z {}",
            w.z_rot
        );
    }
}

/// Issue #12 item 3a: an effect outside the library (an anisotropic scale error of the
/// instrument, 1e-3 along x, measured by a laser tracker at 0.02 mm) is never
/// `explained` while its own remaining-gap test is significant; it is
/// `partially_explained` with the reason and the part saying where the remainder lies.
#[test]
fn explained_only_when_the_remaining_gap_is_not_significant() {
    let sigma_p = 2e-5;
    let sigma_r = 0.005f64.to_radians();
    let mut partial_with_reason = 0;
    for seed in 0..6u64 {
        let truth = geometric_truth(100 + seed);
        let (mut data, groups, _) = exact_session(&truth, 200 + seed, |_| {});
        let mut rng = SplitMix64::new(300 + seed);
        for m in data.iter_mut() {
            let mut p = m.pose;
            p.translation.vector.x *= 1.0 + 1e-3;
            m.pose = add_noise(&p, sigma_p, sigma_r, &mut rng);
        }
        let cfg = Config {
            sigma_pos_m: Some(sigma_p),
            sigma_rot_rad: Some(sigma_r),
            ..Config::default()
        };
        let (d, _) = run_diag(&data, &groups, &cfg);
        let s = summary(&d);
        eprintln!("aniso {seed}: {s}");
        if d.verdict.status == Status::Explained {
            assert!(d.remaining.z <= cfg.z_gap, "seed {seed}: over-claim {s}");
        }
        if let Reason::RemainingGap { z, part } = d.verdict.reason {
            assert_eq!(d.verdict.status, Status::PartiallyExplained, "{s}");
            assert!(z > cfg.z_gap && (z - d.remaining.z).abs() < 1e-12, "{s}");
            assert_ne!(part, Part::Rotation, "the remainder is in position: {s}");
            partial_with_reason += 1;
        }
    }
    assert!(
        partial_with_reason > 0,
        "no case reached the remaining-gap rule"
    );
}

/// Issue #12 item 4: with σ stated twice too large a clear effect is still found (a
/// significant paired improvement is a gap), and the repeats and the residuals say the
/// data are about 2× quieter than stated.
#[test]
fn misstated_sigma_does_not_hide_a_clear_effect_and_is_flagged() {
    let mut truth = geometric_truth(41);
    add_effect(
        &mut truth,
        Effect::JointCompliance,
        0.35,
        &mut SplitMix64::new(42),
    )
    .unwrap();
    let (data, groups) = noisy_session(&truth, 44, |_| {});
    let cfg = Config {
        sigma_pos_m: Some(2e-4),
        sigma_rot_rad: Some(0.04f64.to_radians()),
        ..Config::default()
    };
    let (d, _) = run_diag(&data, &groups, &cfg);
    let s = summary(&d);
    eprintln!("sigma stated 2x: {s}");
    assert!(d.gap.z < cfg.z_gap, "not the regime of the test: {s}");
    assert_ne!(d.verdict.status, Status::NoGap, "{s}");
    assert_eq!(
        d.verdict.effects,
        EffectSet::of(Effect::JointCompliance),
        "{s}"
    );
    let w: Vec<&Warning> = d.warnings().collect();
    assert!(
        w.iter()
            .any(|w| matches!(w, Warning::GapDespiteGapTest { .. })),
        "{s}"
    );
    let repeats = w.iter().find_map(|w| match w {
        Warning::NoiseVsRepeats {
            part: Part::Position,
            ratio,
            ..
        } => Some(*ratio),
        _ => None,
    });
    let r = repeats.unwrap_or_else(|| panic!("no repeat warning: {s}"));
    assert!((0.3..0.75).contains(&r), "repeats ratio {r}: {s}");
    assert!(
        w.iter().any(|w| matches!(
            w,
            Warning::NoiseVsResiduals {
                part: Part::Rotation,
                ..
            }
        )),
        "{s}"
    );
    // Stated right: no noise warning.
    let right = Config {
        sigma_pos_m: Some(1e-4),
        sigma_rot_rad: Some(0.02f64.to_radians()),
        ..Config::default()
    };
    let (d, _) = run_diag(&data, &groups, &right);
    assert!(
        !d.warnings().any(|w| matches!(
            w,
            Warning::NoiseVsRepeats { .. } | Warning::NoiseVsResiduals { .. }
        )),
        "{}",
        summary(&d)
    );
}

/// A set-up that drifts during the session (a random walk of 0.06 mm per row and axis,
/// the repeats measured after all first poses) on an arm with clear joint compliance:
/// the repeats span the drift, so they scatter several times the stated 0.1 mm. Before
/// the drift test they overruled the stated σ, the raised floor swallowed the drift's gap
/// and the verdict was `explained` joint_compliance with the held-out position error
/// three times the stated floor. Now the drift is named, the stated σ stays the floor and
/// the verdict is not `explained`; without the drift nothing changes.
#[test]
fn repeats_that_drift_keep_the_stated_floor_and_are_named() {
    let mut truth = geometric_truth(61);
    add_effect(
        &mut truth,
        Effect::JointCompliance,
        0.5,
        &mut SplitMix64::new(62),
    )
    .unwrap();
    let (clean, groups) = noisy_session(&truth, 63, |_| {});
    let mut drifted = clean.clone();
    let mut rng = SplitMix64::new(64);
    let mut walk = [0.0; 3];
    for m in drifted.iter_mut() {
        for (k, w) in walk.iter_mut().enumerate() {
            *w += 6e-5 * rng.normal();
            m.pose.translation.vector[k] += *w;
        }
    }
    let cfg = Config {
        sigma_pos_m: Some(1e-4),
        sigma_rot_rad: Some(0.02f64.to_radians()),
        ..Config::default()
    };
    let drift_warning = |d: &Diagnosis<6>| {
        d.warnings().find_map(|w| match w {
            Warning::RepeatsDrift {
                part: Part::Position,
                ratio,
                z,
            } => Some((*ratio, *z)),
            _ => None,
        })
    };
    let (d, _) = run_diag(&drifted, &groups, &cfg);
    let s = summary(&d);
    eprintln!("drifting set-up: {s}");
    let (ratio, z) = drift_warning(&d).unwrap_or_else(|| panic!("drift not named: {s}"));
    assert!(z > 3.0 && ratio > 2.0, "ratio {ratio} z {z}: {s}");
    assert_eq!(d.noise.sigma_pos_m, 1e-4, "{s}");
    assert_eq!(d.noise.overruled_pos, None, "{s}");
    assert!(
        !d.warnings().any(|w| matches!(
            w,
            Warning::NoiseVsRepeats {
                part: Part::Position,
                ..
            }
        )),
        "{s}"
    );
    assert_ne!(d.verdict.status, Status::Explained, "{s}");
    assert_ne!(d.verdict.status, Status::NoGap, "{s}");
    let (d, _) = run_diag(&clean, &groups, &cfg);
    let s = summary(&d);
    assert!(drift_warning(&d).is_none(), "{s}");
    assert_eq!(d.verdict.status, Status::Explained, "{s}");
    assert_eq!(
        d.verdict.effects,
        EffectSet::of(Effect::JointCompliance),
        "{s}"
    );
}

/// A translation of the measured positions that follows the temperature and not the arm
/// (the instrument's stand, or the arm's mount, expanding as the room and the arm warm up
/// over the session): `thermal`'s column `(T − 20 °C)·g(q)` fits its common part
/// `(T − 20 °C)·ḡ` and closed most of the gap, so it was called `explained`; the form
/// check puts the translation in its place, which explains the data as well, so the verdict
/// must not be `explained` (`form_not_determined`, naming thermal). A true length expansion
/// of the same session stays `explained`: there the configuration-dependent part decides.
#[test]
fn a_drift_that_follows_the_warm_up_is_not_called_thermal() {
    for seed in 0..3u64 {
        let truth = geometric_truth(100 + seed);
        let (mut drifted, groups, _) = exact_session(&truth, 200 + seed, |_| {});
        // Along the mean tool position (where thermal's column points on average), 0.4 mm
        // at the end of the 22 → 42 °C ramp.
        let mean = drifted.iter().fold(nalgebra::Vector3::zeros(), |a, m| {
            a + m.pose.translation.vector
        }) / drifted.len() as f64;
        let per_k = mean.normalize() * (4e-4 / 22.0);
        let mut rng = SplitMix64::new(300 + seed);
        for m in drifted.iter_mut() {
            let dt = m.state.temp_c.unwrap() - 20.0;
            m.pose.translation.vector += per_k * dt;
            m.pose = add_noise(&m.pose, 1e-4, 0.02f64.to_radians(), &mut rng);
        }
        let (d, _) = run_diag(&drifted, &groups, &Config::default());
        let s = summary(&d);
        eprintln!("mount drift {seed}: {s} form {:?}", d.form);
        assert!(d.verdict.effects.contains(Effect::Thermal), "{s}");
        assert_ne!(d.verdict.status, Status::Explained, "{s}");
        assert!(
            matches!(
                d.verdict.reason,
                Reason::FormNotDetermined {
                    effect: Effect::Thermal,
                    ..
                }
            ),
            "{s}"
        );
        assert_eq!(d.form.effect, Some(Effect::Thermal), "{s}");
        assert!(d.form.evaluated && d.form.equivalent, "{s}");
    }
    // A true length expansion, 4× the simulator's coefficient (weaker ones are near the
    // mocap's noise, where the form check rightly finds the translation as good).
    let mut warm = geometric_truth(400);
    add_effect(&mut warm, Effect::Thermal, 4.0, &mut SplitMix64::new(500)).unwrap();
    let (mut clean, groups, _) = exact_session(&warm, 600, |_| {});
    let mut rng = SplitMix64::new(700);
    for m in clean.iter_mut() {
        m.pose = add_noise(&m.pose, 1e-4, 0.02f64.to_radians(), &mut rng);
    }
    let (d, _) = run_diag(&clean, &groups, &Config::default());
    let s = summary(&d);
    eprintln!("length expansion: {s} form {:?}", d.form);
    assert_eq!(d.verdict.status, Status::Explained, "{s}");
    assert_eq!(d.verdict.effects, EffectSet::of(Effect::Thermal), "{s}");
    assert_eq!(d.form.effect, Some(Effect::Thermal), "{s}");
    assert!(
        d.form.evaluated && !d.form.equivalent && d.form.z >= 3.0,
        "{s}"
    );
}

/// Issue #12 item 5: gross outliers (5 mm on one pose, a wrong joint row on another, a
/// 3 mm one on a third) in a clear joint-compliance case: still `explained`
/// joint_compliance, and the rows are named.
#[test]
fn gross_outliers_are_named_and_do_not_spoil_the_verdict() {
    let mut truth = geometric_truth(51);
    add_effect(
        &mut truth,
        Effect::JointCompliance,
        1.0,
        &mut SplitMix64::new(52),
    )
    .unwrap();
    let (clean, groups) = noisy_session(&truth, 53, |_| {});
    let (d0, _) = run_diag(&clean, &groups, &Config::default());
    assert_eq!(d0.verdict.status, Status::Explained, "{}", summary(&d0));
    assert!(d0.suspects().is_empty(), "{}", summary(&d0));
    let mut data = clean.clone();
    // Rows 25, 40, 55 are poses measured once (the first 20 are repeated).
    data[25].pose.translation.vector.z += 5e-3;
    data[40].state.q = clean[47].state.q;
    data[55].pose.translation.vector.x -= 3e-3;
    let (d, poses) = run_diag(&data, &groups, &Config::default());
    let s = summary(&d);
    eprintln!("outliers: {s}\n  clean: {}", summary(&d0));
    assert_eq!(d.verdict.status, Status::Explained, "{s}");
    assert_eq!(
        d.verdict.effects,
        EffectSet::of(Effect::JointCompliance),
        "{s}"
    );
    assert_eq!(d.suspects(), &[25, 40, 55], "{s}");
    assert!(poses[25].suspect && !poses[24].suspect);
    // The screen's cap on 80 rows is a tenth of them; three rows were over the threshold.
    assert_eq!((d.suspect_cap, d.rows_over_threshold), (8, 3), "{s}");
    // Judged on the clean rows: the gap closed matches the clean data's within 0.05.
    assert!(
        (d.verdict.gap_closed_fraction - d0.verdict.gap_closed_fraction).abs() < 0.05,
        "{s} vs {}",
        summary(&d0)
    );
}

/// More rows over the outlier threshold than the cap (a tenth of 80 rows): none excluded,
/// and the warning and the result say how many were over and what the cap was.
#[test]
fn too_many_outliers_are_counted_against_the_cap() {
    let truth = geometric_truth(61);
    let (mut data, groups) = noisy_session(&truth, 62, |_| {});
    // Twelve poses measured once (rows 20..), each 4 mm off: more than 8 = 80/10.
    for l in (24..72).step_by(4) {
        data[l].pose.translation.vector.z += 4e-3;
    }
    let (d, poses) = run_diag(&data, &groups, &Config::default());
    let s = summary(&d);
    assert!(
        d.suspects().is_empty() && poses.iter().all(|p| !p.suspect),
        "{s}"
    );
    let warned = d.warnings().find_map(|w| match *w {
        Warning::TooManySuspects { count, cap } => Some((count, cap)),
        _ => None,
    });
    let (count, cap) = warned.unwrap_or_else(|| panic!("no too_many_suspects: {s}"));
    assert_eq!(cap, 8, "{s}");
    // Most of the twelve fail (4 mm is ~20σ against a robust scale): more than the cap.
    assert!(count > cap && count <= 12, "{count}: {s}");
    assert_eq!((d.suspect_cap, d.rows_over_threshold), (8, count), "{s}");
}

/// The ten poses of the paper's Table 2 reached by IK on `truth`, each measured `repeats`
/// times (group = pose), noise 0.1 mm / 0.02°.
fn table2_session(truth: &Robot<6>, repeats: usize, seed: u64) -> (Vec<Measurement<6>>, Vec<u32>) {
    let mut data = Vec::new();
    let mut groups = Vec::new();
    for l in 0..10 {
        let target = aria::tool_pose(l).unwrap();
        let sol = solve_ik(
            truth,
            &target,
            &JointState::new(aria::TOOL_SEED_Q),
            &IkOptions::default(),
        )
        .unwrap();
        for _ in 0..repeats {
            data.push(Measurement::new(sol.q, target));
            groups.push(l as u32 + 1);
        }
    }
    measure(
        truth,
        &mut data,
        1e-4,
        0.02f64.to_radians(),
        &mut SplitMix64::new(seed),
    )
    .unwrap();
    (data, groups)
}

/// Issue #12 item 6: the paper's regime, the ten Table 2 poses measured three times, with
/// a clear joint-compliance truth: too few groups for cross-validation, so the in-sample
/// nested test decides, says so, and lists every indistinguishable candidate.
#[test]
fn table2_three_times_uses_the_nested_test_and_finds_compliance() {
    let mut found = 0;
    for seed in 0..3u64 {
        let mut truth = geometric_truth(60 + seed);
        add_effect(
            &mut truth,
            Effect::JointCompliance,
            3.0,
            &mut SplitMix64::new(70 + seed),
        )
        .unwrap();
        let (data, groups) = table2_session(&truth, 3, 80 + seed);
        let cfg = Config {
            sigma_pos_m: Some(1e-4),
            sigma_rot_rad: Some(0.02f64.to_radians()),
            ..Config::default()
        };
        let (d, _) = run_diag(&data, &groups, &cfg);
        let s = summary(&d);
        eprintln!("table2x3 {seed}: {s}");
        assert_eq!(d.method, Method::InSampleNested, "{s}");
        assert!(
            matches!(
                d.verdict.status,
                Status::Explained | Status::PartiallyExplained
            ),
            "seed {seed}: {s}"
        );
        let named = d.verdict.effects == EffectSet::of(Effect::JointCompliance)
            || d.verdict
                .confounded()
                .contains(&EffectSet::of(Effect::JointCompliance));
        assert!(
            named,
            "seed {seed}: compliance neither chosen nor listed: {s}"
        );
        // Every listed alternative is indistinguishable from the winner.
        let w = d.verdict.candidate.unwrap();
        for c in d.candidates() {
            if d.verdict.confounded().contains(&c.effects) {
                assert!(c.z_vs_winner < 3.0 && c.significant, "{s}");
            }
        }
        found += usize::from(d.verdict.effects == d.candidates[w].effects);
    }
    assert_eq!(found, 3);
}

/// Equally good alternatives are listed even when they fall in another status class
/// (issue #12 item 6, last point).
#[test]
fn equally_good_alternatives_are_listed_whatever_their_class() {
    let gap = GapTest {
        z: 10.0,
        ..GapTest::default()
    };
    let cfg = Config::default();
    let score = |effects, fitted_params| ModelScore {
        effects,
        requested: Default::default(),
        identifiable: Default::default(),
        structural: Default::default(),
        data_deficient: Default::default(),
        dropped: [None; kincal::diagnosis::MAX_DROPPED],
        fitted_params,
        distinctness: 1.0,
        least_distinct: None,
        evaluated: true,
        heldout_rms_pos_m: 0.0,
        heldout_rms_rot_rad: 0.0,
        heldout_chi2: 0.0,
        improvement_z: 0.0,
        significant: false,
        z_vs_best: 0.0,
        z_vs_winner: 0.0,
        gap_closed_fraction: 0.0,
        gap_closed_rot_fraction: 0.0,
        gap_closed_total_fraction: 0.0,
        z_pos: 0.0,
        z_rot: 0.0,
        session: Default::default(),
    };
    let mut a = score(EffectSet::of(Effect::JointScale), 30);
    let mut b = score(EffectSet::of(Effect::JointCyclic), 48);
    a.gap_closed_total_fraction = 0.85;
    b.gap_closed_total_fraction = 0.7;
    for s in [&mut a, &mut b] {
        s.improvement_z = 8.0;
        s.significant = true;
        s.heldout_chi2 = 100.0;
    }
    let mut s = [a, b];
    let v = decide(&mut s, |_, _| 0.5, &gap, &cfg);
    assert_eq!(v.status, Status::Explained);
    assert_eq!(v.confounded(), &[EffectSet::of(Effect::JointCyclic)]);
}
