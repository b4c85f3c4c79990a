//! Time of a diagnosis over every single effect and every pair (28 candidates) of simulated
//! sessions: poses of the biopsy region, a quarter of the measurements repeats, approach
//! directions and temperatures recorded, a hidden joint compliance. 120 measurements (90
//! poses, 30 repeated; target under 10 ms), 1,000 and 5,000 (target under 0.5 s): the
//! rank tests are O(G log G) in the pose groups.
//! `cargo bench -p kincal --bench diagnosis -- --noplot`
//!
//! Measured (CPU time per run from `cpu_time`, this and the previous code alternated in
//! one session, three rounds each, on a 2-core machine shared with another engineer's
//! builds, load 1.3): 120 rows 7.20–7.30 ms (was 8.25–8.45), 1,000 rows 69.2–71.3 ms (was
//! 70.4–70.8), 5,000 rows 300–310 ms (was 300–323); an earlier round at load 2.8 gave
//! 7.85–8.20 ms at 120 rows for an intermediate state against 8.45–9.30. The earlier
//! sessions' 13.3–13.9 ms at 120 rows for the previous code were taken under a heavier
//! load. Outputs bit-identical (`tests/diagnosis_dump.rs`'s dump, `cmp`).
//! Instructions of one diagnosis (callgrind, `tests/diagnosis_dump.rs`'s `one_size`,
//! release, `diagnose` inclusive): 120 rows 167.1 → 138.9 → 122.5 M, 1,000 rows 1,593.0 →
//! 1,219.0 → 1,206.3 M, 5,000 rows 6,300.7 → 4,888.4 → 4,882.2 M. The last step: gravity
//! torques kept per row across passes and fits (`identify::torques`), the first rows'
//! Jacobian columns kept across the diagnosis's passes at one model (`diagnosis::rows`,
//! 27 rows of the 71-column union in a 96,000-byte pool), the greedy factors of the
//! cross-validation and of the data's identifiability step resumed over the columns
//! neighbouring models share (`cv::Resume`). Both caches hold the first rows only, so
//! 1,000 and 5,000 rows gain little.
//! Shares of a 120-row diagnosis's instructions now: the two Gram kernels 25 %
//! (`add_rows6_in_order`, the cross-validation's, 13 %; `add_rows6`, the fits', 12 %), the
//! smooth checks 24 % (their ridge fits' factor, solve, predict and accumulate 20 %), the
//! identification Jacobians 13 %, the greedy factors 6 %; by step, the
//! nonlinear fits 30 % (the geometric calibration 19 %, the verdict's 11 %), the smooth
//! checks 24 %, the cross-validation 17 %, the extrapolation check 7 %, the outlier
//! screen 6 %.

use criterion::{Criterion, criterion_group, criterion_main};
use kincal::diagnosis::{Config, DiagWorkspace, PoseDiagnosis, diagnose};
use kincal::identify::Measurement;
use kincal::rng::SplitMix64;
use kincal::sim::{SessionConfig, add_effect, perturb_geometry, simulate_session};
use kincal::{Effect, Robot, Transform, aria};

/// Measurements per simulated session: 3/4 distinct poses, 1/4 repeats.
const SIZES: [usize; 3] = [120, 1_000, 5_000];

/// A simulated session of `n` measurements (`n` divisible by 4) and its pose groups.
fn session(n: usize) -> (Robot<6>, Vec<Measurement<6>>, Vec<u32>) {
    let nominal = aria::nominal();
    let mut rng = SplitMix64::new(120);
    let mut truth = perturb_geometry(&nominal, 5e-3, 5f64.to_radians(), &mut rng).unwrap();
    add_effect(&mut truth, Effect::JointCompliance, 1.0, &mut rng).unwrap();
    let cfg = SessionConfig {
        poses: n / 4 * 3,
        repeated: n / 4,
        ..SessionConfig::blind_training()
    };
    assert_eq!(cfg.measurements(), n);
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

/// A zeroed diagnosis workspace on the heap (it is large).
fn workspace() -> Box<DiagWorkspace<80>> {
    // SAFETY: all-zero is a valid DiagWorkspace (documented).
    unsafe { Box::new_zeroed().assume_init() }
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("diagnose, 7 effects + 21 pairs");
    group.sample_size(10);
    for n in SIZES {
        let (nominal, data, groups) = session(n);
        let mut poses = vec![PoseDiagnosis::default(); n];
        let mut ws = workspace();
        let dc = Config::default();
        let d = diagnose(&nominal, &data, &groups, &dc, &mut poses, &mut ws).unwrap();
        assert_eq!(d.n_candidates, 28);
        group.bench_function(format!("{n} measurements"), |b| {
            b.iter(|| {
                std::hint::black_box(
                    diagnose(&nominal, &data, &groups, &dc, &mut poses, &mut ws).unwrap(),
                )
            })
        });
    }
    group.finish();
}

/// Process CPU time \[s\] from /proc/self/stat (user + system; Linux), or `None`.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name's closing parenthesis; utime and stime are 14 and 15.
    let rest = stat.rsplit_once(')')?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// CPU time per diagnosis (about 24,000 measurements' worth of runs, at least 3): on a
/// shared, loaded machine criterion's wall time overstates the cost; the process's CPU
/// time much less so.
fn cpu_time(_c: &mut Criterion) {
    for n in SIZES {
        let (nominal, data, groups) = session(n);
        let mut poses = vec![PoseDiagnosis::default(); n];
        let mut ws = workspace();
        let dc = Config::default();
        let runs = (24_000 / n).max(3);
        if let Some(t0) = cpu_seconds() {
            for _ in 0..runs {
                std::hint::black_box(
                    diagnose(&nominal, &data, &groups, &dc, &mut poses, &mut ws).unwrap(),
                );
            }
            if let Some(t1) = cpu_seconds() {
                println!(
                    "diagnose {n} measurements: {:.2} ms CPU time per run ({runs} runs)",
                    (t1 - t0) * 1e3 / runs as f64
                );
            }
        }
    }
}

criterion_group!(benches, bench, cpu_time);
criterion_main!(benches);
