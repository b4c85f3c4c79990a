//! The "explainable at all?" check (`diagnosis/smooth.rs`): a model-free smooth function of
//! the joint angles, cross-validated on the diagnosis's folds, against effects the test
//! applies outside the library, pure noise, and an in-library effect.

#[path = "common/outside.rs"]
mod outside;

use kincal::diagnosis::{Config, DiagWorkspace, Diagnosis, PoseDiagnosis, diagnose};
use kincal::rng::SplitMix64;
use kincal::sim::{add_effect, perturb_geometry};
use kincal::{Effect, Robot, aria};
use outside::{Design, MOCAP, Outside, OutsideEffect, detectability, measure, states};

fn workspace() -> Box<DiagWorkspace<80>> {
    // SAFETY: all-zero is a valid DiagWorkspace (documented).
    unsafe { Box::new_zeroed().assume_init() }
}

fn stated() -> Config {
    Config {
        sigma_pos_m: Some(MOCAP.sigma_pos_m),
        sigma_rot_rad: Some(MOCAP.sigma_rot_rad),
        ..Config::default()
    }
}

fn truth(seed: u64) -> Robot<6> {
    perturb_geometry(
        &aria::nominal(),
        2e-3,
        1f64.to_radians(),
        &mut SplitMix64::new(seed),
    )
    .unwrap()
}

/// A diagnosis of 80 random poses (20 repeated) on `truth` with `effects` outside the
/// library; returns it with the detectability (position, rotation).
fn run(truth: &Robot<6>, effects: &[OutsideEffect], seed: u64) -> (Diagnosis<6>, (f64, f64)) {
    let mut rng = SplitMix64::new(seed);
    let st = states(
        truth,
        Design::Random {
            poses: 80,
            repeated: 20,
        },
        &mut rng,
    );
    let (data, groups) = measure(truth, effects, &st, &MOCAP, true, &mut rng);
    let rho = detectability(truth, effects, &st, &MOCAP);
    let mut poses = vec![PoseDiagnosis::default(); data.len()];
    let mut ws = workspace();
    let d = diagnose(
        &aria::nominal(),
        &data,
        &groups,
        &stated(),
        &mut poses,
        &mut ws,
    )
    .unwrap();
    (d, rho)
}

/// Whitened share of the held-out excess a model with held-out total `chi2` removes (the
/// check's `share_of_gap` definition, from the diagnosis's own totals).
fn whitened_share(d: &Diagnosis<6>, chi2: f64) -> f64 {
    let q = d.baseline.heldout_chi2;
    let e = q / d.gap.ratio;
    ((q.sqrt() - chi2.sqrt()) / (q.sqrt() - e.sqrt())).clamp(0.0, 1.0)
}

#[test]
fn smooth_out_of_library_effects_are_explainable() {
    for (k, kind) in [Outside::QuadraticCompliance, Outside::CompliantMount]
        .into_iter()
        .enumerate()
    {
        let t = truth(10 + k as u64);
        let e = OutsideEffect::draw(kind, 2.0, &mut SplitMix64::new(20 + k as u64));
        let (d, rho) = run(&t, &[e], 30 + k as u64);
        let s = d.explainable;
        println!(
            "{}: rho {:.1}/{:.1}, gap z {:.1}, verdict {} {:?}, smooth share {:.2} (pos {:.2}, rot {:.2}) z {:.1}; held-out RMS {:.3} -> {:.3} mm",
            kind.name(),
            rho.0,
            rho.1,
            d.gap.z,
            d.verdict.status.name(),
            d.verdict.effects,
            s.share_of_gap,
            s.share_pos,
            s.share_rot,
            s.z,
            d.baseline.heldout_rms_pos_m * 1e3,
            s.heldout_rms_pos_m * 1e3,
        );
        assert!(rho.0.max(rho.1) > 3.0, "the case must be detectable");
        assert!(s.evaluated && s.significant, "{s:?}");
        assert!(s.share_of_gap > 0.6, "{s:?}");
        // Independent: the held-out totals agree with the RMS values reported.
        assert!(s.heldout_rms_pos_m < d.baseline.heldout_rms_pos_m);
        assert!((whitened_share(&d, s.heldout_chi2) - s.share_of_gap).abs() < 1e-9);
    }
}

#[test]
fn pure_noise_is_not_explainable() {
    let mut shares = Vec::new();
    for s in 0..6 {
        let (d, _) = run(&truth(100 + s), &[], 200 + s);
        let c = d.explainable;
        println!(
            "noise {s}: share {:.3} z {:.2} significant {}",
            c.share_of_gap, c.z, c.significant
        );
        assert!(c.evaluated);
        assert!(!c.significant, "{c:?}");
        assert!(c.z < 3.0);
        shares.push(c.share_of_gap);
    }
    let mean = shares.iter().sum::<f64>() / shares.len() as f64;
    assert!(mean < 0.1, "{shares:?}");
}

#[test]
fn an_in_library_effect_is_as_explainable_as_its_candidate() {
    for (k, (effect, size)) in [(Effect::JointCompliance, 1.0), (Effect::JointCyclic, 3.0)]
        .into_iter()
        .enumerate()
    {
        let mut t = truth(40 + k as u64);
        add_effect(&mut t, effect, size, &mut SplitMix64::new(50 + k as u64)).unwrap();
        let (d, _) = run(&t, &[], 60 + k as u64);
        let single = d
            .candidates()
            .iter()
            .find(|c| c.effects == kincal::EffectSet::of(effect))
            .unwrap();
        let cand = whitened_share(&d, single.heldout_chi2);
        let s = d.explainable;
        println!(
            "{effect:?}: candidate share {cand:.2} (z {:.1}), smooth share {:.2} (z {:.1})",
            single.improvement_z, s.share_of_gap, s.z
        );
        // The generic model needs more data than the right parametric one (it must learn
        // the structure the candidate knows): at 80 poses it recovers 0.5–0.7 of the gap
        // where the candidate recovers 0.9–1 (a lower bound of what is explainable).
        assert!(cand > 0.6);
        assert!(s.significant && s.share_of_gap > 0.4, "{s:?}");
        assert!(
            s.share_of_gap > 0.5 * cand && s.share_of_gap <= cand + 0.05,
            "{s:?}"
        );
    }
}

#[test]
#[ignore]
fn probe_sizes() {
    let t = truth(1);
    let mut rng = SplitMix64::new(2);
    let st = states(
        &t,
        Design::Random {
            poses: 80,
            repeated: 0,
        },
        &mut rng,
    );
    let mut lo = [9.0f64; 6];
    let mut hi = [-9.0f64; 6];
    for (s, _) in &st {
        for j in 0..6 {
            lo[j] = lo[j].min(s.q[j]);
            hi[j] = hi[j].max(s.q[j]);
        }
    }
    println!("q ranges {lo:.2?} {hi:.2?}");
    for kind in Outside::ALL {
        let e = OutsideEffect::draw(kind, 1.0, &mut SplitMix64::new(3));
        let rho = detectability(&t, &[e], &st, &MOCAP);
        let rl = detectability(&t, &[e], &st, &outside::LASER);
        println!(
            "{}: mocap rho {:.2}/{:.2}, laser {:.2}",
            kind.name(),
            rho.0,
            rho.1,
            rl.0
        );
    }
}
