//! Reference dumps and a profiling driver for the diagnosis (ignored tests, run by hand).
//!
//! `KINCAL_DIAG_DUMP=FILE cargo test -p kincal --test diagnosis_dump -- --ignored dump`
//! writes the full `Debug` form of every diagnosis (and of its per-pose records but their
//! stored smooth-check features, internal scratch) over a set
//! of simulated sessions: every effect alone, none, several seeds and sizes. `Debug` prints
//! each `f64` in its shortest round-trip form, so two dumps are equal byte for byte exactly
//! when every output is bit-identical: the check that a speed-up changed no result (run it
//! on the code before and after, then `cmp`).
//!
//! `KINCAL_DIAG_SIZE=N cargo test -p kincal --test diagnosis_dump -- --ignored one_size`
//! runs one diagnosis of the bench's session of `N` measurements (callgrind driver:
//! `valgrind --tool=callgrind` on the test binary with `--ignored one_size`).

use kincal::diagnosis::{Config, DiagWorkspace, PoseDiagnosis, diagnose};
use kincal::identify::Measurement;
use kincal::rng::SplitMix64;
use kincal::sim::{SessionConfig, add_effect, perturb_geometry, simulate_session};
use kincal::{Effect, Robot, Transform, aria};
use std::fmt::Write as _;

fn workspace() -> Box<DiagWorkspace<80>> {
    // SAFETY: all-zero is a valid DiagWorkspace (documented).
    unsafe { Box::new_zeroed().assume_init() }
}

/// A simulated session of `n` measurements (3/4 distinct poses, 1/4 repeats) on a truth
/// with `effect` (the bench's session for `JointCompliance`, size 1, seed 120).
fn session(
    n: usize,
    effect: Option<Effect>,
    seed: u64,
) -> (Robot<6>, Vec<Measurement<6>>, Vec<u32>) {
    let nominal = aria::nominal();
    let mut rng = SplitMix64::new(seed);
    let mut truth = perturb_geometry(&nominal, 5e-3, 5f64.to_radians(), &mut rng).unwrap();
    if let Some(e) = effect {
        add_effect(&mut truth, e, 1.0, &mut rng).unwrap();
    }
    let cfg = SessionConfig {
        poses: n / 4 * 3,
        repeated: n / 4,
        ..SessionConfig::blind_training()
    };
    let mut data = vec![Measurement::new([0.0; 6], Transform::identity()); n];
    let mut groups = vec![0u32; n];
    simulate_session(
        &truth,
        &aria::TOOL_SEED_Q,
        &cfg,
        &mut rng,
        &mut data,
        &mut groups,
    )
    .unwrap();
    (nominal, data, groups)
}

#[test]
#[ignore = "writes a reference dump; run by hand (module documentation)"]
fn dump() {
    let path = std::env::var("KINCAL_DIAG_DUMP").expect("KINCAL_DIAG_DUMP=FILE");
    let mut ws = workspace();
    let mut text = String::new();
    let mut cases: Vec<(usize, Option<Effect>, u64)> =
        vec![(120, Some(Effect::JointCompliance), 120)];
    for (i, e) in Effect::ALL.iter().enumerate() {
        cases.push((120, Some(*e), 7 + i as u64));
        cases.push((240, Some(*e), 70 + i as u64));
    }
    cases.push((120, None, 3));
    cases.push((1_000, Some(Effect::JointCompliance), 120));
    cases.push((1_000, Some(Effect::JointCyclic), 11));
    for (n, effect, seed) in cases {
        let (nominal, data, groups) = session(n, effect, seed);
        let mut poses = vec![PoseDiagnosis::default(); n];
        let d = diagnose(
            &nominal,
            &data,
            &groups,
            &Config::default(),
            &mut poses,
            &mut ws,
        );
        writeln!(text, "== {n} {effect:?} {seed}\n{d:?}").unwrap();
        for p in &poses {
            // The smooth check's stored features are internal scratch (their layout is
            // free to change); every other field, public or scratch, is dumped.
            let line = format!("{p:?}");
            let line = match (line.find(", smooth: ["), line.rfind(']')) {
                (Some(a), Some(b)) if b > a => format!("{}{}", &line[..a], &line[b + 1..]),
                _ => line,
            };
            writeln!(text, "{line}").unwrap();
        }
    }
    std::fs::write(path, text).unwrap();
}

#[test]
#[ignore = "profiling driver; run by hand (module documentation)"]
fn one_size() {
    let n: usize = std::env::var("KINCAL_DIAG_SIZE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(120);
    let (nominal, data, groups) = session(n, Some(Effect::JointCompliance), 120);
    let mut poses = vec![PoseDiagnosis::default(); n];
    let mut ws = workspace();
    let d = diagnose(
        &nominal,
        &data,
        &groups,
        &Config::default(),
        &mut poses,
        &mut ws,
    )
    .unwrap();
    assert_eq!(d.n_candidates, 28);
    println!(
        "bytes: DiagWorkspace<MAX_MODEL_PARAMS> {}, PoseDiagnosis {}, Measurement<6> {}",
        size_of::<DiagWorkspace<{ kincal::identify::MAX_MODEL_PARAMS }>>(),
        size_of::<PoseDiagnosis>(),
        size_of::<Measurement<6>>()
    );
}
