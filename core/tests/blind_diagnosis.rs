//! The blind test of the sim-to-real diagnosis: simulated arms whose hidden effect the test
//! knows and the diagnosis does not.
//!
//! Each case: the nominal ARIA with random manufacturing errors (uniform within the
//! paper's ±5 mm / ±5° on every identified geometric parameter), plus no hidden effect,
//! one of the seven, or a pair, each with random parameters of realistic shape
//! ([`kincal::sim::add_effect`]) scaled to a target size ρ — the RMS position residual the
//! effect alone leaves after a noise-free geometric calibration on the training poses, in
//! units of the noise's √3·σ_pos — drawn log-uniformly in [0.7, 12]. Cases with every
//! hidden effect at ρ ≥ 3 are "strong" (the targets apply), the others "weak" (reported
//! separately). Training: 60 poses in the biopsy region (±30° orientation cone) solved by
//! IK on the true arm, 20 of them measured twice (half from the same approach
//! directions), approach directions and a 22→42 °C temperature ramp recorded, noise
//! 0.1 mm and 0.02° per axis; the noise floor is estimated from the repeats. Withheld: 40
//! more poses the diagnosis never sees, on which the chosen model and the geometric one
//! are compared (gap closed, spec/effects.md, with N = √3·0.1 mm).
//!
//! `blind_suite` (default: 120 cases — 12 without an effect, 12 per effect, 6 per pair;
//! a few seconds, the core is optimised in test builds) prints the confusion matrix and
//! asserts the targets; the larger `blind_suite_full` (576 cases) is `#[ignore]`d — run it in release:
//! `cargo test -p kincal --release --test blind_diagnosis -- --ignored --nocapture`.

use std::time::{Duration, Instant};

use kincal::diagnosis::{Config, DiagWorkspace, PoseDiagnosis, Status, diagnose};
use kincal::identify::{Measurement, Workspace};
use kincal::rng::SplitMix64;
use kincal::sim::{
    SessionConfig, add_effect, effect_to_noise_ratio, measure, only_effects, perturb_geometry,
    scale_effect, simulate_session,
};
use kincal::{Effect, EffectSet, Robot, Transform, aria};

const SIGMA_POS_M: f64 = 1e-4;
const STRONG_RHO: f64 = 3.0;
const WITHHELD: usize = 40;

const PAIRS: [(Effect, Effect); 4] = [
    (Effect::JointCompliance, Effect::Backlash),
    (Effect::BaseFrame, Effect::ToolFrame),
    (Effect::JointCompliance, Effect::Thermal),
    (Effect::JointScale, Effect::BaseFrame),
];

#[derive(Debug, Clone)]
struct CaseResult {
    hidden: EffectSet,
    /// Smallest ρ over the hidden effects (∞ for none).
    rho: f64,
    /// Size factor of each hidden effect relative to the realistic upper magnitude.
    sizes: Vec<(Effect, f64)>,
    status: Status,
    verdict: EffectSet,
    confounded: Vec<EffectSet>,
    gap_closed_cv: f64,
    withheld_before_m: f64,
    withheld_after_m: f64,
    gap_closed_withheld: f64,
    gap_z: f64,
    elapsed: Duration,
}

impl CaseResult {
    fn strong(&self) -> bool {
        self.rho >= STRONG_RHO
    }
    fn right(&self) -> bool {
        if self.hidden.is_empty() {
            self.status == Status::NoGap
        } else {
            self.verdict == self.hidden
        }
    }
    /// Right, or the truth reported among the confounded candidates.
    fn right_or_confounded(&self) -> bool {
        self.right() || self.confounded.contains(&self.hidden)
    }
}

fn names(s: EffectSet) -> String {
    if s.is_empty() {
        "-".into()
    } else {
        s.iter().map(|e| e.name()).collect::<Vec<_>>().join("+")
    }
}

fn empty(n: usize) -> Vec<Measurement<6>> {
    vec![Measurement::new([0.0; 6], Transform::identity()); n]
}

fn rms_pos(robot: &Robot<6>, data: &[Measurement<6>]) -> f64 {
    let s: f64 = data
        .iter()
        .map(|m| {
            let t = robot.fk(&m.state).unwrap();
            (m.pose.translation.vector - t.translation.vector).norm_squared()
        })
        .sum();
    (s / data.len() as f64).sqrt()
}

fn run_case(
    seed: u64,
    hidden: EffectSet,
    rho_range: [f64; 2],
    ws: &mut DiagWorkspace<80>,
) -> CaseResult {
    let nominal = aria::nominal();
    let rng = SplitMix64::new(seed);
    let mut truth = perturb_geometry(&nominal, 5e-3, 5f64.to_radians(), &mut rng.fork(1)).unwrap();
    let mut erng = rng.fork(2);
    for e in hidden.iter() {
        add_effect(&mut truth, e, 1.0, &mut erng).unwrap();
    }
    // Poses: IK on the true arm (effects at their drawn shape), exact poses for now.
    let train_cfg = SessionConfig::blind_training();
    let n = train_cfg.measurements();
    let mut train = empty(n);
    let mut groups = vec![0u32; n];
    simulate_session(
        &truth,
        &aria::TOOL_SEED_Q,
        &SessionConfig {
            sigma_pos_m: 0.0,
            sigma_rot_rad: 0.0,
            ..train_cfg
        },
        &mut rng.fork(3),
        &mut train,
        &mut groups,
    )
    .unwrap();
    let held_cfg = SessionConfig {
        poses: WITHHELD,
        repeated: 0,
        sigma_pos_m: 0.0,
        sigma_rot_rad: 0.0,
        ..train_cfg
    };
    let mut held = empty(WITHHELD);
    let mut held_groups = vec![0u32; WITHHELD];
    simulate_session(
        &truth,
        &aria::TOOL_SEED_Q,
        &held_cfg,
        &mut rng.fork(4),
        &mut held,
        &mut held_groups,
    )
    .unwrap();
    // Scale each hidden effect to its target size.
    let mut fit_ws = Box::<Workspace<32>>::default();
    let mut rho_rng = rng.fork(5);
    let mut sizes = Vec::new();
    let mut rho_min = f64::INFINITY;
    for e in hidden.iter() {
        let target = rho_range[0] * (rho_range[1] / rho_range[0]).powf(rho_rng.uniform());
        let alone = only_effects(&truth, EffectSet::of(e));
        let mut scratch = train.clone();
        let rho1 = effect_to_noise_ratio(&nominal, &alone, &mut scratch, SIGMA_POS_M, &mut fit_ws)
            .unwrap();
        let factor = target / rho1;
        scale_effect(&mut truth, e, factor).unwrap();
        sizes.push((e, factor));
        rho_min = rho_min.min(target);
    }
    // Measure with noise.
    let mut mrng = rng.fork(6);
    measure(
        &truth,
        &mut train,
        train_cfg.sigma_pos_m,
        train_cfg.sigma_rot_rad,
        &mut mrng,
    )
    .unwrap();
    measure(
        &truth,
        &mut held,
        train_cfg.sigma_pos_m,
        train_cfg.sigma_rot_rad,
        &mut mrng,
    )
    .unwrap();
    // The blind diagnosis.
    let mut poses = vec![PoseDiagnosis::default(); n];
    let t = Instant::now();
    let d = diagnose(
        &nominal,
        &train,
        &groups,
        &Config::default(),
        &mut poses,
        ws,
    )
    .unwrap();
    let elapsed = t.elapsed();
    // Withheld poses: the chosen model against the geometric one.
    let before = rms_pos(&d.geometric, &held);
    let after = rms_pos(&d.model, &held);
    let floor = 3f64.sqrt() * SIGMA_POS_M;
    let closed = if before > floor {
        ((before - after) / (before - floor)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    CaseResult {
        hidden,
        rho: rho_min,
        sizes,
        status: d.verdict.status,
        verdict: d.verdict.effects,
        confounded: d.verdict.confounded().to_vec(),
        gap_closed_cv: d.verdict.gap_closed_fraction,
        withheld_before_m: before,
        withheld_after_m: after,
        gap_closed_withheld: closed,
        gap_z: d.gap.z,
        elapsed,
    }
}

fn kinds() -> Vec<EffectSet> {
    let mut k = vec![EffectSet::NONE];
    k.extend(Effect::ALL.iter().map(|&e| EffectSet::of(e)));
    k.extend(PAIRS.iter().map(|&(a, b)| EffectSet::of(a).with(b)));
    k
}

fn run_suite(none: usize, singles: usize, pairs: usize, rho_range: [f64; 2]) -> Vec<CaseResult> {
    // SAFETY: all-zero is a valid DiagWorkspace (documented); avoids a large stack value.
    let mut ws: Box<DiagWorkspace<80>> = unsafe { Box::new_zeroed().assume_init() };
    let mut out = Vec::new();
    for (ki, kind) in kinds().into_iter().enumerate() {
        let count = match kind.len() {
            0 => none,
            1 => singles,
            _ => pairs,
        };
        for s in 0..count {
            let seed = 0x5eed_0000 + (ki as u64) * 1000 + s as u64;
            out.push(run_case(seed, kind, rho_range, &mut ws));
        }
    }
    out
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let k = v.len() / 2;
    if v.len() % 2 == 1 {
        v[k]
    } else {
        0.5 * (v[k - 1] + v[k])
    }
}

struct Summary {
    strong_accuracy: f64,
    none_accuracy: f64,
    median_closed_withheld: f64,
}

fn report(results: &[CaseResult]) -> Summary {
    let col = |r: &CaseResult| -> String {
        match r.status {
            Status::NoGap => "no_gap".into(),
            Status::Unexplained => "unexplained".into(),
            _ if r.verdict.len() == 1 => names(r.verdict),
            _ if r.verdict == r.hidden => "right pair".into(),
            _ => "other pair".into(),
        }
    };
    let mut cols: Vec<String> = vec!["no_gap".into()];
    cols.extend(Effect::ALL.iter().map(|e| e.name().to_string()));
    cols.extend(["right pair", "other pair", "unexplained"].map(String::from));
    let short = |c: &str| -> String { c.split('_').map(|w| &w[..w.len().min(4)]).collect() };
    for (label, strong) in [("strong (rho >= 3)", true), ("weak (rho < 3)", false)] {
        let subset: Vec<&CaseResult> = results
            .iter()
            .filter(|r| r.hidden.is_empty() || r.strong() == strong)
            .filter(|r| strong || !r.hidden.is_empty())
            .collect();
        if subset.is_empty() {
            continue;
        }
        println!("\nConfusion matrix, {label}: rows truth, columns verdict");
        print!("{:>26}", "");
        for c in &cols {
            print!(" {:>9}", short(c));
        }
        println!(" {:>6} {:>6}", "right", "r|conf");
        for kind in kinds() {
            let rows: Vec<&&CaseResult> = subset.iter().filter(|r| r.hidden == kind).collect();
            if rows.is_empty() {
                continue;
            }
            print!("{:>26}", names(kind));
            for c in &cols {
                print!(" {:>9}", rows.iter().filter(|r| &col(r) == c).count());
            }
            let right = rows.iter().filter(|r| r.right()).count();
            let rc = rows.iter().filter(|r| r.right_or_confounded()).count();
            println!(" {:>3}/{:<3} {:>3}", right, rows.len(), rc);
        }
    }
    let strong: Vec<&CaseResult> = results
        .iter()
        .filter(|r| !r.hidden.is_empty() && r.strong())
        .collect();
    let weak: Vec<&CaseResult> = results
        .iter()
        .filter(|r| !r.hidden.is_empty() && !r.strong())
        .collect();
    let none: Vec<&CaseResult> = results.iter().filter(|r| r.hidden.is_empty()).collect();
    let acc = |v: &[&CaseResult], f: fn(&CaseResult) -> bool| {
        v.iter().filter(|r| f(r)).count() as f64 / v.len().max(1) as f64
    };
    let summary = Summary {
        strong_accuracy: acc(&strong, CaseResult::right),
        none_accuracy: acc(&none, CaseResult::right),
        median_closed_withheld: median(strong.iter().map(|r| r.gap_closed_withheld).collect()),
    };
    println!(
        "\nPer hidden effect (strong cases): right / right-or-confounded / n, right and explained, median gap closed (withheld), median size factor"
    );
    for kind in kinds().into_iter().skip(1) {
        let rows: Vec<&&CaseResult> = strong.iter().filter(|r| r.hidden == kind).collect();
        if rows.is_empty() {
            continue;
        }
        let sizes: Vec<String> = kind
            .iter()
            .map(|e| {
                let f: Vec<f64> = rows
                    .iter()
                    .flat_map(|r| r.sizes.iter().filter(|s| s.0 == e).map(|s| s.1))
                    .collect();
                format!("{}x{:.2}", e.name(), median(f))
            })
            .collect();
        println!(
            "  {:32} {:>3} / {:>3} / {:>3}   explained {:>3}   closed {:.3}   sizes {}",
            names(kind),
            rows.iter().filter(|r| r.right()).count(),
            rows.iter().filter(|r| r.right_or_confounded()).count(),
            rows.len(),
            rows.iter()
                .filter(|r| r.right() && r.status == Status::Explained)
                .count(),
            median(rows.iter().map(|r| r.gap_closed_withheld).collect()),
            sizes.join(" ")
        );
    }
    let z: Vec<f64> = none.iter().map(|r| r.gap_z).collect();
    let zm = z.iter().sum::<f64>() / z.len().max(1) as f64;
    let zs =
        (z.iter().map(|v| (v - zm) * (v - zm)).sum::<f64>() / (z.len().max(2) - 1) as f64).sqrt();
    println!(
        "gap test without a hidden effect: z mean {zm:.2}, sd {zs:.2}, max {:.2} (threshold 3)",
        z.iter().copied().fold(f64::NEG_INFINITY, f64::max)
    );
    let mut by_rho = [(0usize, 0usize); 4];
    for r in results.iter().filter(|r| !r.hidden.is_empty()) {
        let k = match r.rho {
            x if x < 1.0 => 0,
            x if x < 2.0 => 1,
            x if x < 3.0 => 2,
            _ => 3,
        };
        by_rho[k].1 += 1;
        if r.right() {
            by_rho[k].0 += 1;
        }
    }
    println!(
        "right verdicts by effect size rho: [0.7,1) {}/{}, [1,2) {}/{}, [2,3) {}/{}, >=3 {}/{}",
        by_rho[0].0,
        by_rho[0].1,
        by_rho[1].0,
        by_rho[1].1,
        by_rho[2].0,
        by_rho[2].1,
        by_rho[3].0,
        by_rho[3].1
    );
    let times: Vec<f64> = results
        .iter()
        .map(|r| r.elapsed.as_secs_f64() * 1e3)
        .collect();
    println!(
        "\nnone: no_gap in {}/{}; strong: right {}/{} ({:.1} %), right or confounded {}/{}; weak: right {}/{}",
        none.iter().filter(|r| r.right()).count(),
        none.len(),
        strong.iter().filter(|r| r.right()).count(),
        strong.len(),
        100.0 * summary.strong_accuracy,
        strong.iter().filter(|r| r.right_or_confounded()).count(),
        strong.len(),
        weak.iter().filter(|r| r.right()).count(),
        weak.len(),
    );
    println!(
        "gap closed on withheld poses, strong cases: median {:.3} (CV estimate median {:.3}); held-out RMS median {:.3} mm -> {:.3} mm",
        summary.median_closed_withheld,
        median(strong.iter().map(|r| r.gap_closed_cv).collect()),
        1e3 * median(strong.iter().map(|r| r.withheld_before_m).collect()),
        1e3 * median(strong.iter().map(|r| r.withheld_after_m).collect()),
    );
    println!(
        "diagnosis time per case ({}): median {:.1} ms, max {:.1} ms",
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        },
        median(times.clone()),
        times.iter().copied().fold(0.0, f64::max)
    );
    println!("\nMisses, and right verdicts closing under half the gap on the withheld poses:");
    for r in results
        .iter()
        .filter(|r| !r.right() || (!r.hidden.is_empty() && r.gap_closed_withheld < 0.5))
    {
        println!(
            "  truth {:30} rho {:5.2} -> {:20} {:>24} conf [{}] closed cv {:.2} withheld {:.2} ({:.3} -> {:.3} mm)",
            names(r.hidden),
            r.rho,
            r.status.name(),
            names(r.verdict),
            r.confounded
                .iter()
                .map(|s| names(*s))
                .collect::<Vec<_>>()
                .join(", "),
            r.gap_closed_cv,
            r.gap_closed_withheld,
            1e3 * r.withheld_before_m,
            1e3 * r.withheld_after_m
        );
    }
    summary
}

fn assert_targets(s: &Summary) {
    assert!(
        s.strong_accuracy >= 0.95,
        "verdict accuracy on strong cases {:.3} < 0.95",
        s.strong_accuracy
    );
    assert!(
        s.none_accuracy >= 0.95,
        "no_gap rate without a hidden effect {:.3} < 0.95",
        s.none_accuracy
    );
    assert!(
        s.median_closed_withheld >= 0.9,
        "median gap closed {:.3} < 0.9",
        s.median_closed_withheld
    );
}

#[test]
fn blind_suite() {
    let results = run_suite(12, 12, 6, [0.7, 12.0]);
    let s = report(&results);
    assert_targets(&s);
}

#[test]
#[ignore = "576 cases: run in release with --ignored"]
fn blind_suite_full() {
    let results = run_suite(60, 60, 24, [0.7, 12.0]);
    let s = report(&results);
    assert_targets(&s);
}
