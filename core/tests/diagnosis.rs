//! The diagnosis engine against independent computations: fold-by-fold nonlinear fits,
//! direct noise estimates, direct correlations, the "real ARIA" study, and the decision
//! rules on synthetic scores.

use kincal::diagnosis::{
    Config, DiagWorkspace, Diagnosis, GapTest, ModelScore, PoseDiagnosis, QuantityKind, Status,
    decide, diagnose,
};
use kincal::identify::{Algorithm, IdentifyOptions, Measurement, Workspace, identify};
use kincal::rng::SplitMix64;
use kincal::sim::{
    SessionConfig, add_effect, measure, perturb_geometry, real_aria_study, real_aria_training,
    scale_effect, simulate_session,
};
use kincal::{Effect, EffectSet, Error, ParamId, Quantity, Robot, Transform, aria};

type Ws = DiagWorkspace<80>;

fn workspace() -> Box<Ws> {
    // SAFETY: all-zero is a valid DiagWorkspace (documented).
    unsafe { Box::new_zeroed().assume_init() }
}

fn empty(n: usize) -> Vec<Measurement<6>> {
    vec![Measurement::new([0.0; 6], Transform::identity()); n]
}

/// A session on `truth` (blind-suite settings unless changed by `edit`).
fn session(
    truth: &Robot<6>,
    seed: u64,
    edit: impl FnOnce(&mut SessionConfig),
) -> (Vec<Measurement<6>>, Vec<u32>) {
    let mut cfg = SessionConfig::blind_training();
    edit(&mut cfg);
    let n = cfg.measurements();
    let mut data = empty(n);
    let mut groups = vec![0u32; n];
    simulate_session(
        truth,
        &aria::TOOL_SEED_Q,
        &cfg,
        &mut SplitMix64::new(seed),
        &mut data,
        &mut groups,
    )
    .unwrap();
    (data, groups)
}

fn truth_with(effect: Option<Effect>, size: f64, seed: u64) -> Robot<6> {
    let mut rng = SplitMix64::new(seed);
    let mut t = perturb_geometry(&aria::nominal(), 2e-3, 1f64.to_radians(), &mut rng).unwrap();
    if let Some(e) = effect {
        add_effect(&mut t, e, size, &mut rng).unwrap();
    }
    t
}

fn run(
    data: &[Measurement<6>],
    groups: &[u32],
    cfg: &Config,
    ws: &mut Ws,
) -> (Diagnosis<6>, Vec<PoseDiagnosis>) {
    let mut poses = vec![PoseDiagnosis::default(); data.len()];
    let d = diagnose(&aria::nominal(), data, groups, cfg, &mut poses, ws).unwrap();
    (d, poses)
}

fn pos_norm(e: &[f64; 6]) -> f64 {
    (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt()
}

/// Held-out residuals of a fold-by-fold nonlinear fit (weight 0 holds a fold out).
fn nonlinear_heldout(
    start: &Robot<6>,
    data: &[Measurement<6>],
    poses: &[PoseDiagnosis],
    requested: kincal::ParamSet,
    d: &Diagnosis<6>,
) -> Vec<[f64; 6]> {
    let mut out = vec![[0.0; 6]; data.len()];
    let mut ws = Box::<Workspace<64>>::default();
    let mut opts = IdentifyOptions::new(Algorithm::Ols, requested);
    opts.weight_pos = d.noise.sigma_pos_m.powi(-2);
    opts.weight_rot = d.noise.sigma_rot_rad.powi(-2);
    opts.allow_data_deficiency = true;
    for f in 0..d.folds as u16 {
        let train: Vec<Measurement<6>> = data
            .iter()
            .zip(poses)
            .map(|(m, p)| Measurement {
                weight: if p.fold == f { 0.0 } else { 1.0 },
                ..*m
            })
            .collect();
        let fit = identify(start, &train, &opts, &mut ws).unwrap();
        for (l, m) in data.iter().enumerate() {
            if poses[l].fold == f {
                out[l] = kincal::pose::pose_error(
                    &m.pose,
                    &fit.robot.fk(&m.state).unwrap(),
                    kincal::OrientationError::Exact,
                );
            }
        }
    }
    out
}

#[test]
fn linearised_cross_validation_matches_fold_by_fold_nonlinear_fits() {
    // Base-frame errors twice the realistic size: the most nonlinear of the effects.
    let mut truth = truth_with(Some(Effect::BaseFrame), 2.0, 7);
    add_effect(
        &mut truth,
        Effect::JointCompliance,
        1.0,
        &mut SplitMix64::new(8),
    )
    .unwrap();
    let (data, groups) = session(&truth, 17, |_| {});
    let mut ws = workspace();
    let cfg = Config {
        candidates: Some(EffectSet::of(Effect::BaseFrame).with(Effect::JointCompliance)),
        ..Config::default()
    };
    let (d, poses) = run(&data, &groups, &cfg, &mut ws);
    assert_eq!(
        d.verdict.effects,
        EffectSet::of(Effect::BaseFrame).with(Effect::JointCompliance)
    );
    let nominal = aria::nominal();
    let base = nonlinear_heldout(&nominal, &data, &poses, nominal.geometric_param_set(), &d);
    let w = d.verdict.candidate.unwrap();
    let fin = nonlinear_heldout(&nominal, &data, &poses, d.candidates[w].identifiable, &d);
    let rms = |v: &mut dyn Iterator<Item = f64>| {
        let (s, n) = v.fold((0.0, 0), |(s, n), x| (s + x * x, n + 1));
        (s / n as f64).sqrt()
    };
    let mut worst_base = 0.0f64;
    let mut worst_fin = 0.0f64;
    for l in 0..data.len() {
        for k in 0..3 {
            worst_base = worst_base.max((poses[l].heldout_baseline[k] - base[l][k]).abs());
            worst_fin = worst_fin.max((poses[l].heldout_final[k] - fin[l][k]).abs());
        }
    }
    let lin_b = rms(&mut poses.iter().map(|p| pos_norm(&p.heldout_baseline)));
    let non_b = rms(&mut base.iter().map(pos_norm));
    let lin_f = rms(&mut poses.iter().map(|p| pos_norm(&p.heldout_final)));
    let non_f = rms(&mut fin.iter().map(pos_norm));
    println!(
        "held-out RMS linearised/nonlinear: baseline {lin_b:.6e}/{non_b:.6e}, final {lin_f:.6e}/{non_f:.6e}; worst per-axis difference {worst_base:.2e}, {worst_fin:.2e} m"
    );
    assert!((lin_b - d.baseline.heldout_rms_pos_m).abs() < 1e-12);
    assert!((lin_f - d.final_heldout_rms_pos_m).abs() < 1e-12);
    // Second-order terms: micrometres against a 0.1 mm noise.
    assert!(worst_base < 5e-6 && worst_fin < 5e-6);
    assert!((lin_b / non_b - 1.0).abs() < 0.01 && (lin_f / non_f - 1.0).abs() < 0.02);
}

#[test]
fn noise_floor_pools_same_direction_repeats_only() {
    let mut truth = truth_with(Some(Effect::Backlash), 1.0, 3);
    scale_effect(&mut truth, Effect::Backlash, 3.0).unwrap();
    let (data, groups) = session(&truth, 5, |c| {
        c.poses = 60;
        c.repeated = 60;
    });
    let mut ws = workspace();
    let (d, _) = run(&data, &groups, &Config::default(), &mut ws);
    // Independent estimate: measured-pose differences of repeat pairs (equal readings)
    // with equal approach directions.
    let (mut ss_p, mut ss_r, mut pairs, mut opposite) = (0.0, 0.0, 0usize, 0usize);
    for r in 0..60 {
        let (a, b) = (&data[r], &data[60 + r]);
        assert_eq!(groups[r], groups[60 + r]);
        if a.state.approach != b.state.approach {
            opposite += 1;
            continue;
        }
        let e = kincal::pose::pose_error(&a.pose, &b.pose, kincal::OrientationError::Exact);
        ss_p += (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) / 2.0;
        ss_r += (e[3] * e[3] + e[4] * e[4] + e[5] * e[5]) / 2.0;
        pairs += 1;
    }
    assert!(pairs > 15 && opposite > 15, "{pairs} {opposite}");
    let sp = (ss_p / (3 * pairs) as f64).sqrt();
    let sr = (ss_r / (3 * pairs) as f64).sqrt();
    assert_eq!(d.noise.repeat_subgroups, pairs);
    assert_eq!(d.noise.dof_pos, (3 * pairs) as f64);
    // Residual differences equal pose differences to second order (rotation vectors
    // compose non-commutatively at 1e-4 relative).
    assert!(
        (d.noise.sigma_pos_m / sp - 1.0).abs() < 1e-9,
        "{} {sp}",
        d.noise.sigma_pos_m
    );
    assert!(
        (d.noise.sigma_rot_rad / sr - 1.0).abs() < 1e-3,
        "{} {sr}",
        d.noise.sigma_rot_rad
    );
    // And close to the simulated σ (~45 degrees of freedom: ±3 standard errors).
    assert!((sp / 1e-4 - 1.0).abs() < 0.35);
    assert_eq!(d.verdict.effects, EffectSet::of(Effect::Backlash));
}

#[test]
fn stated_noise_takes_precedence_and_a_missing_noise_floor_is_an_error() {
    let truth = truth_with(None, 0.0, 11);
    let (data, groups) = session(&truth, 12, |c| c.repeated = 0);
    let mut ws = workspace();
    let mut poses = vec![PoseDiagnosis::default(); data.len()];
    let err = diagnose(
        &aria::nominal(),
        &data,
        &groups,
        &Config::default(),
        &mut poses,
        &mut ws,
    )
    .unwrap_err();
    assert_eq!(
        err,
        Error::MissingInput {
            what: Quantity::NoiseFloor
        }
    );
    let cfg = Config {
        sigma_pos_m: Some(1e-4),
        sigma_rot_rad: Some(0.02f64.to_radians()),
        ..Config::default()
    };
    let (d, _) = run(&data, &groups, &cfg, &mut ws);
    assert_eq!(d.noise.sigma_pos_m, 1e-4);
    assert!(d.noise.dof_pos.is_infinite() && d.noise.stated_pos && d.noise.stated_rot);
    assert_eq!(d.verdict.status, Status::NoGap);
    // Bad inputs.
    let mut w = data.clone();
    w[3].weight = 0.5;
    assert!(diagnose(&aria::nominal(), &w, &groups, &cfg, &mut poses, &mut ws).is_err());
    assert!(matches!(
        diagnose(
            &aria::nominal(),
            &data,
            &groups[1..],
            &cfg,
            &mut poses,
            &mut ws
        ),
        Err(Error::DimensionMismatch { .. })
    ));
    let few = Config { folds: 100, ..cfg };
    assert!(matches!(
        diagnose(&aria::nominal(), &data, &groups, &few, &mut poses, &mut ws),
        Err(Error::TooFewData { .. })
    ));
    // Backlash asked for without approach directions.
    let (plain, pg) = session(&truth, 13, |c| c.record_approach = false);
    let ask = Config {
        candidates: Some(EffectSet::of(Effect::Backlash)),
        ..cfg
    };
    let mut pp = vec![PoseDiagnosis::default(); plain.len()];
    assert_eq!(
        diagnose(&aria::nominal(), &plain, &pg, &ask, &mut pp, &mut ws).unwrap_err(),
        Error::MissingInput {
            what: Quantity::ApproachDirection
        }
    );
}

#[test]
fn the_gap_test_is_calibrated_on_pure_noise() {
    // Stated (true) σ: z should be standard normal under "no effect".
    let cfg = Config {
        sigma_pos_m: Some(1e-4),
        sigma_rot_rad: Some(0.02f64.to_radians()),
        ..Config::default()
    };
    let mut ws = workspace();
    let mut z = Vec::new();
    let mut ratio_expected = Vec::new();
    for s in 0..16 {
        let truth = truth_with(None, 0.0, 100 + s);
        let (data, groups) = session(&truth, 200 + s, |c| c.repeated = 0);
        let (d, _) = run(&data, &groups, &cfg, &mut ws);
        z.push(d.gap.z);
        // The expected held-out RMS (√3σ inflated by the estimation error) against the
        // observed one.
        ratio_expected.push(d.baseline.heldout_rms_pos_m / d.gap.expected_rms_pos_m);
        assert_eq!(d.verdict.status, Status::NoGap, "seed {s}: z {}", d.gap.z);
    }
    let mean = z.iter().sum::<f64>() / z.len() as f64;
    let sd = (z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (z.len() - 1) as f64).sqrt();
    let r = ratio_expected.iter().sum::<f64>() / ratio_expected.len() as f64;
    println!("gap z under noise: mean {mean:.2} sd {sd:.2}; observed/expected RMS {r:.3}");
    assert!(mean.abs() < 0.75 && sd > 0.5 && sd < 1.6);
    assert!((r - 1.0).abs() < 0.05);
}

#[test]
fn where_points_at_temperature_and_approach_and_matches_direct_correlations() {
    let mut ws = workspace();
    for (effect, size, want) in [
        (Effect::Thermal, 15.0, QuantityKind::Temperature),
        (Effect::Backlash, 1.0, QuantityKind::Approach(1)),
    ] {
        let mut truth = truth_with(None, 0.0, 21);
        add_effect(&mut truth, effect, size, &mut SplitMix64::new(22)).unwrap();
        if effect == Effect::Backlash {
            // One dominant joint so the strongest correlate is known.
            let i = ParamId::Backlash(1).index(6);
            truth.set_param(i, 4e-3).unwrap();
        }
        let (data, groups) = session(&truth, 23, |_| {});
        let (d, poses) = run(&data, &groups, &Config::default(), &mut ws);
        let loc = &d.location;
        let best = loc.correlates()[loc.most_correlated.unwrap()];
        assert_eq!(best.quantity, want, "{effect:?}");
        assert!(
            best.explained_pos > 0.3,
            "{effect:?}: {}",
            best.explained_pos
        );
        // Direct Pearson correlation of the quantity with each residual component.
        let v: Vec<f64> = data
            .iter()
            .map(|m| match want {
                QuantityKind::Temperature => m.state.temp_c.unwrap(),
                QuantityKind::Approach(j) => m.state.approach.unwrap()[j],
                _ => unreachable!(),
            })
            .collect();
        let n = v.len() as f64;
        let mv = v.iter().sum::<f64>() / n;
        for k in 0..6 {
            let r: Vec<f64> = poses.iter().map(|p| p.residual[k]).collect();
            let mr = r.iter().sum::<f64>() / n;
            let cov: f64 = v.iter().zip(&r).map(|(a, b)| (a - mv) * (b - mr)).sum();
            let vv: f64 = v.iter().map(|a| (a - mv).powi(2)).sum();
            let rr: f64 = r.iter().map(|b| (b - mr).powi(2)).sum();
            let c = cov / (vv * rr).sqrt();
            assert!((c - best.corr[k]).abs() < 1e-9, "{k}: {c} {}", best.corr[k]);
        }
        // Regions partition the poses; per-axis RMS agree with the residuals.
        assert_eq!(
            loc.regions.iter().map(|r| r.count).sum::<usize>(),
            data.len()
        );
        let rms_x = (poses.iter().map(|p| p.residual[0].powi(2)).sum::<f64>() / n).sqrt();
        assert!((rms_x - loc.rms_axis[0]).abs() < 1e-15);
        assert_eq!(d.verdict.effects, EffectSet::of(effect));
    }
}

#[test]
fn structural_and_data_confounding_are_reported() {
    // Constant temperature (30 °C): thermal expansion is a length scale the geometric
    // parameters absorb exactly.
    let truth = truth_with(Some(Effect::JointCompliance), 1.0, 31);
    let (data, groups) = session(&truth, 32, |c| c.temperature_c = Some([30.0, 30.0]));
    let mut ws = workspace();
    let (d, _) = run(&data, &groups, &Config::default(), &mut ws);
    let thermal = d
        .candidates()
        .iter()
        .find(|c| c.effects == EffectSet::of(Effect::Thermal))
        .unwrap();
    assert!(!thermal.evaluated);
    let kappa = ParamId::Thermal.index(6);
    assert!(thermal.data_deficient.contains(kappa.0));
    let dropped = thermal.dropped[0].unwrap();
    assert_eq!(dropped.param, kappa);
    let partner = ParamId::from_index(dropped.partner.unwrap(), 6).unwrap();
    assert!(partner.is_length(), "{partner}");
    // Compliance of joints 1 and 6 (no gravity torque) is structurally redundant.
    let compliance = d
        .candidates()
        .iter()
        .find(|c| c.effects == EffectSet::of(Effect::JointCompliance))
        .unwrap();
    for j in [0, 5] {
        assert!(
            compliance
                .structural
                .contains(ParamId::Compliance(j).index(6).0)
        );
    }
    assert_eq!(d.verdict.effects, EffectSet::of(Effect::JointCompliance));
}

#[test]
fn real_aria_reproduces_the_paper_and_the_diagnosis_finds_compliance() {
    let n = real_aria_training().measurements();
    let mut train = empty(n);
    let mut groups = vec![0u32; n];
    let mut val = empty(kincal::sim::REAL_ARIA_VALIDATION_POSES);
    let (truth, written) = real_aria_study(&mut train, &mut groups, &mut val).unwrap();
    assert_eq!(written, n);
    let nominal = aria::nominal();
    let rms = |r: &Robot<6>| {
        let s: f64 = val
            .iter()
            .map(|m| {
                (m.pose.translation.vector - r.fk(&m.state).unwrap().translation.vector)
                    .norm_squared()
            })
            .sum();
        (s / val.len() as f64).sqrt()
    };
    let mut ws = workspace();
    let (d, _) = run(&train, &groups, &Config::default(), &mut ws);
    let (before, geo, ext) = (rms(&nominal), rms(&d.geometric), rms(&d.model));
    println!(
        "real ARIA validation RMS: nominal {:.3} mm, geometric {:.3} mm ({:.1}x), diagnosed {:.3} mm; truth's compliance {:.1e}, identified {:?}",
        before * 1e3,
        geo * 1e3,
        before / geo,
        ext * 1e3,
        truth.effect_params().compliance[1],
        d.model.effect_params().compliance
    );
    assert!((4.0..7.0).contains(&(before / geo)), "{}", before / geo);
    assert!((0.35e-3..0.6e-3).contains(&geo));
    assert_eq!(d.verdict.effects, EffectSet::of(Effect::JointCompliance));
    assert_eq!(d.verdict.status, Status::Explained);
    let floor = 3f64.sqrt() * 1e-4;
    assert!((geo - ext) / (geo - floor) > 0.9);
    // The identified compliance of the loaded joints is the truth's within 10 %.
    for j in 1..3 {
        let c = d.model.effect_params().compliance[j];
        assert!(
            (c / truth.effect_params().compliance[j] - 1.0).abs() < 0.1,
            "{j}: {c}"
        );
    }
    // The where-analysis points at a gravity torque or a joint angle the torque follows.
    let q = d.location.correlates()[d.location.most_correlated.unwrap()].quantity;
    assert!(
        matches!(
            q,
            QuantityKind::GravityTorque(_) | QuantityKind::JointAngle(_)
        ),
        "{q:?}"
    );
}

fn score(effects: EffectSet, params: usize, chi2: f64, z: f64, closed: f64) -> ModelScore {
    ModelScore {
        effects,
        requested: Default::default(),
        identifiable: Default::default(),
        structural: Default::default(),
        data_deficient: Default::default(),
        dropped: [None; kincal::diagnosis::MAX_DROPPED],
        fitted_params: params,
        distinctness: 1.0,
        least_distinct: None,
        evaluated: true,
        heldout_rms_pos_m: 0.0,
        heldout_rms_rot_rad: 0.0,
        heldout_chi2: chi2,
        improvement_z: z,
        significant: z > 3.0,
        z_vs_best: 0.0,
        z_vs_winner: 0.0,
        gap_closed_fraction: closed,
        gap_closed_rot_fraction: 0.0,
        gap_closed_total_fraction: closed,
        z_pos: z,
        z_rot: 0.0,
        session: Default::default(),
    }
}

#[test]
fn decision_rules_on_synthetic_scores() {
    let cfg = Config::default();
    let gap = GapTest {
        z: 10.0,
        ..GapTest::default()
    };
    let (a, b, c) = (
        EffectSet::of(Effect::JointScale),
        EffectSet::of(Effect::JointCyclic),
        EffectSet::of(Effect::BaseFrame),
    );
    // No gap: the gap test below its threshold and no significant candidate.
    let mut s = [score(a, 30, 100.0, 2.5, 0.95)];
    let v = decide(&mut s, |_, _| 0.0, &GapTest { z: 2.9, ..gap }, &cfg);
    assert_eq!((v.status, v.effects), (Status::NoGap, EffectSet::NONE));
    // A significant candidate is a gap whatever the gap test says (σ stated too large).
    let mut s = [score(a, 30, 100.0, 8.0, 0.95)];
    let v = decide(&mut s, |_, _| 0.0, &GapTest { z: 2.9, ..gap }, &cfg);
    assert_eq!((v.status, v.effects), (Status::Explained, a));
    // Two indistinguishable singles: the one with fewer parameters wins even though the
    // other has the smaller held-out total; the other is confounded.
    let mut s = [
        score(a, 30, 101.0, 8.0, 0.95),
        score(b, 48, 100.0, 8.0, 0.96),
        score(c, 28, 300.0, 4.0, 0.3),
    ];
    // (base_frame, index 2, is far worse than the best.)
    let v = decide(&mut s, |x, _| if x == 2 { 10.0 } else { 0.5 }, &gap, &cfg);
    assert_eq!((v.status, v.effects), (Status::Explained, a));
    assert_eq!(v.confounded(), &[b]);
    assert_eq!((s[0].z_vs_best, s[1].z_vs_winner), (0.5, 0.5));
    // Distinguishable: the better one wins.
    let v = decide(&mut s, |x, _| if x == 0 { 4.0 } else { 10.0 }, &gap, &cfg);
    assert_eq!(v.effects, b);
    assert!(v.confounded().is_empty());
    // A pair wins only when every single is significantly worse than it.
    let pair = a.with(Effect::BaseFrame);
    let mut s = [
        score(a, 30, 200.0, 8.0, 0.6),
        score(c, 28, 300.0, 5.0, 0.4),
        score(pair, 34, 100.0, 9.0, 0.97),
    ];
    let v = decide(
        &mut s,
        |x, y| if y == 2 && x != 2 { 5.0 } else { 0.0 },
        &gap,
        &cfg,
    );
    assert_eq!((v.status, v.effects), (Status::Explained, pair));
    // When nothing is distinguishable, the smallest (fewest effects, then parameters) wins
    // and the same-size candidate of the same status class is confounded with it.
    let v = decide(&mut s, |_, _| 1.0, &gap, &cfg);
    assert_eq!((v.status, v.effects), (Status::PartiallyExplained, c));
    assert_eq!(v.confounded(), &[a]);
    // Nothing significant, or too small a share: unexplained with no effects.
    let mut s = [score(a, 30, 100.0, 2.0, 0.9)];
    let v = decide(&mut s, |_, _| 0.0, &gap, &cfg);
    assert_eq!(
        (v.status, v.effects),
        (Status::Unexplained, EffectSet::NONE)
    );
    let mut s = [score(a, 30, 100.0, 5.0, 0.2)];
    let v = decide(&mut s, |_, _| 0.0, &gap, &cfg);
    assert_eq!(
        (v.status, v.effects),
        (Status::Unexplained, EffectSet::NONE)
    );
    // Not evaluated (confounded with geometry) never wins.
    let mut s = [score(a, 30, 1.0, 9.0, 1.0), score(c, 28, 50.0, 6.0, 0.9)];
    s[0].evaluated = false;
    let v = decide(&mut s, |_, _| 0.0, &gap, &cfg);
    assert_eq!(v.effects, c);
}

#[test]
fn measure_reproduces_exact_poses_without_noise() {
    let truth = truth_with(Some(Effect::JointCyclic), 1.0, 41);
    let (mut data, _) = session(&truth, 42, |c| {
        c.poses = 5;
        c.repeated = 0;
        c.sigma_pos_m = 0.0;
        c.sigma_rot_rad = 0.0;
    });
    let before = data.clone();
    measure(&truth, &mut data, 0.0, 0.0, &mut SplitMix64::new(1)).unwrap();
    for (a, b) in data.iter().zip(&before) {
        assert!((a.pose.translation.vector - b.pose.translation.vector).norm() < 1e-15);
    }
    // Every pose lies in the biopsy region, on the seed's branch.
    for m in &data {
        let p = m.pose.translation.vector;
        for k in 0..3 {
            assert!(
                p[k] >= aria::WORKING_REGION_MIN_M[k] - 1e-9
                    && p[k] <= aria::WORKING_REGION_MAX_M[k] + 1e-9
            );
        }
        for j in 0..6 {
            assert!((m.state.q[j] - aria::TOOL_SEED_Q[j]).abs() <= 1.5);
        }
    }
}

/// Position-only data: the residuals the diagnosis reports (per pose, by axis and by region)
/// hold no orientation, since none was measured.
#[test]
fn position_only_residuals_have_no_orientation() {
    let truth = truth_with(None, 0.0, 21);
    let (mut data, groups) = session(&truth, 22, |c| c.repeated = 0);
    for m in &mut data {
        m.mask = kincal::identify::ComponentMask::POSITION;
    }
    let cfg = Config {
        sigma_pos_m: Some(1e-4),
        sigma_rot_rad: Some(0.02f64.to_radians()),
        pairs: false,
        ..Config::default()
    };
    let mut ws = workspace();
    let (d, poses) = run(&data, &groups, &cfg, &mut ws);
    assert!(poses.iter().all(|p| p.residual[3..] == [0.0; 3]));
    assert!(pos_norm(&poses[0].residual) > 0.0);
    assert_eq!(d.location.rms_rot_rad, 0.0);
    assert!(d.location.regions.iter().all(|r| r.rms_rot_rad == 0.0));
}

/// `Config::effect_params` restricts a candidate's effect parameters (the front ends'
/// `joint_scale@JOINT`): the joint_scale candidate fits the third joint's scale only, the
/// unrestricted one every joint's it can, and the geometric parameters are the same.
#[test]
fn effect_params_restrict_a_candidate_to_chosen_joints() {
    let truth = truth_with(Some(Effect::JointScale), 1.0, 31);
    let (data, groups) = session(&truth, 32, |_| {});
    let scale = |j: usize| ParamId::Scale(j).index(6).0;
    let base = Config {
        candidates: Some(EffectSet::of(Effect::JointScale)),
        pairs: false,
        ..Config::default()
    };
    let mut only = kincal::ParamSet::new();
    only.insert(scale(2)).unwrap();
    let restricted = Config {
        effect_params: Some(only),
        ..base
    };
    let mut ws = workspace();
    let (all, _) = run(&data, &groups, &base, &mut ws);
    let (one, _) = run(&data, &groups, &restricted, &mut ws);
    let scales = |d: &Diagnosis<6>| -> Vec<usize> {
        (0..6)
            .filter(|&j| d.candidates()[0].identifiable.contains(scale(j)))
            .collect()
    };
    assert_eq!(scales(&one), [2]);
    assert!(scales(&all).len() >= 4, "{:?}", scales(&all));
    let geometric = |d: &Diagnosis<6>| {
        let mut s = d.candidates()[0].identifiable;
        for j in 0..6 {
            s.remove(scale(j));
        }
        s
    };
    assert_eq!(geometric(&one), geometric(&all));
    assert_eq!(
        one.candidates()[0].fitted_params + scales(&all).len() - 1,
        all.candidates()[0].fitted_params
    );
}

/// Issue #14 saw the thermal candidate's fit on position-only ARIA data stop at 200
/// iterations. On simulated position-only sessions with a thermal effect (22 → 42 °C over
/// the session) the geometric + κ fit converges in a few Gauss–Newton iterations and
/// recovers κ to 25 %: the non-convergence is not a property of κ's scale against the
/// lengths. The diagnosis's own fit of its verdict converges but can be slow (seed 5: 74
/// iterations; still open, see the note of #14): the bound below is the solver's cap, the
/// slow case is printed.
#[test]
fn thermal_fit_on_position_only_data_converges() {
    let kappa = ParamId::Thermal.index(6);
    for seed in 0..6u64 {
        let truth = truth_with(Some(Effect::Thermal), 1.0, 100 + seed);
        let (mut data, groups) = session(&truth, 200 + seed, |_| {});
        for m in &mut data {
            m.mask = kincal::identify::ComponentMask::POSITION;
        }
        let nominal = aria::nominal();
        let mut opts = IdentifyOptions::new(
            Algorithm::Ols,
            nominal.param_set(EffectSet::of(Effect::Thermal)),
        );
        opts.weight_pos = 1e8;
        opts.allow_data_deficiency = true;
        let mut ws = Box::<Workspace<64>>::default();
        let fit = identify(&nominal, &data, &opts, &mut ws).unwrap();
        let (got, want) = (fit.robot.param(kappa).unwrap(), truth.param(kappa).unwrap());
        assert!(
            fit.iterations <= 12,
            "seed {seed}: {} iterations",
            fit.iterations
        );
        assert!(
            (got / want - 1.0).abs() < 0.25,
            "seed {seed}: κ {got} vs {want}"
        );
        let cfg = Config {
            sigma_pos_m: Some(1e-4),
            ..Config::default()
        };
        let (d, _) = run(&data, &groups, &cfg, &mut workspace());
        assert!(d.fit.iterations < 200, "seed {seed}: {}", d.fit.iterations);
        if d.fit.iterations >= 60 {
            eprintln!(
                "seed {seed}: the verdict's fit took {} iterations",
                d.fit.iterations
            );
        }
    }
}
