//! Kinematics benchmarks on the nominal ARIA: six sines and cosines (libm against the core's
//! bit-identical `kincal::sin_cos`, one at a time, and `kincal::sin_cos_lanes`, all six
//! together as FK takes them), FK, FK + joint Jacobian, FK + identification Jacobian
//! (geometric columns and all columns), IK of a Table 2 pose and of random reachable targets
//! (control-loop preset from 5° seeds, global search, default).
//!
//! FK and the Jacobians cycle through a precomputed table of random configurations within the
//! joint limits (one per iteration): a single fixed configuration lets the branch predictor
//! and libm's argument reduction learn one path and reads faster than a controller sees.
//!
//! Run: `cargo bench -p kincal --bench kinematics -- --noplot --warm-up-time 1
//! --measurement-time 3`. Targets on the 2-core build machine: FK < 100 ns, FK + Jacobian
//! < 300 ns.
//!
//! The build machine is shared, so wall-clock figures grow with its load. FK and Jacobian
//! are therefore measured twice: in wall time (criterion's default) and, under
//! `cpu_time/…`, in the benchmark thread's own CPU time (Linux
//! `CLOCK_THREAD_CPUTIME_ID`), which other processes do not inflate (much: caches and SMT
//! siblings are still shared).

use std::hint::black_box;

use criterion::measurement::Measurement;
use criterion::{Criterion, criterion_group, criterion_main};
use kincal::ik::{IkOptions, solve_ik};
use kincal::rng::SplitMix64;
use kincal::{JacobianColumn, JointState, Robot, aria};

mod common;
use common::{ThreadCpuTime, thread_cpu_ns};

/// Configurations in the table (a power of two: the index wraps with a mask).
const TABLE: usize = 1024;

/// `TABLE` joint states uniform within the ARIA limits (fixed seed: every run times the same
/// configurations), with approach directions and a temperature when `effects` is set.
fn random_states(robot: &Robot<6>, effects: bool) -> Vec<JointState<6>> {
    let mut rng = SplitMix64::new(0x6b69_6e63_616c);
    (0..TABLE)
        .map(|_| {
            let q = core::array::from_fn(|j| {
                let l = robot.limits()[j];
                rng.range(l.lower, l.upper)
            });
            if effects {
                JointState {
                    q,
                    approach: Some(core::array::from_fn(|_| [-1.0, 0.0, 1.0][rng.below(3)])),
                    temp_c: Some(rng.range(15.0, 35.0)),
                }
            } else {
                JointState::new(q)
            }
        })
        .collect()
}

fn kinematics<M: Measurement + 'static>(c: &mut Criterion<M>, prefix: &str) {
    let robot = aria::nominal();
    let states = random_states(&robot, false);
    let mut k = 0usize;
    let mut next = move || {
        k = (k + 1) & (TABLE - 1);
        k
    };
    // Six sines and cosines (one FK's worth) of random angles over ±2π: libm against the
    // core's bit-identical versions, one angle at a time and six at once.
    let mut rng = SplitMix64::new(0x5c05);
    let angles: Vec<[f64; 6]> = (0..TABLE)
        .map(|_| core::array::from_fn(|_| rng.range(-std::f64::consts::TAU, std::f64::consts::TAU)))
        .collect();
    c.bench_function(&format!("{prefix}sincos6_libm"), |b| {
        b.iter(|| black_box(&angles[next()]).map(libm::sincos))
    });
    c.bench_function(&format!("{prefix}sincos6_kincal"), |b| {
        b.iter(|| black_box(&angles[next()]).map(kincal::sin_cos))
    });
    c.bench_function(&format!("{prefix}sincos6_lanes"), |b| {
        b.iter(|| kincal::sin_cos_lanes(black_box(&angles[next()])))
    });
    c.bench_function(&format!("{prefix}fk_aria"), |b| {
        b.iter(|| black_box(&robot).fk(black_box(&states[next()])))
    });
    let mut joint = [[0.0; 6]; 6];
    c.bench_function(&format!("{prefix}fk_joint_jacobian_aria"), |b| {
        b.iter(|| {
            black_box(&robot).joint_jacobian(black_box(&states[next()]), black_box(&mut joint))
        })
    });
    let mut geo = [[0.0; 6]; Robot::<6>::NUM_GEOMETRIC_PARAMS];
    c.bench_function(&format!("{prefix}fk_jacobian_geometric_aria"), |b| {
        b.iter(|| black_box(&robot).jacobian(black_box(&states[next()]), black_box(&mut geo[..])))
    });
    // All effect columns, with approach directions and a temperature.
    let states = random_states(&robot, true);
    let mut full: [JacobianColumn; Robot::<6>::NUM_PARAMS] = [[0.0; 6]; Robot::<6>::NUM_PARAMS];
    c.bench_function(&format!("{prefix}fk_jacobian_all_effects_aria"), |b| {
        b.iter(|| black_box(&robot).jacobian(black_box(&states[next()]), black_box(&mut full[..])))
    });
}

fn wall(c: &mut Criterion) {
    kinematics(c, "");
}

fn ik(c: &mut Criterion) {
    let robot = aria::nominal();
    let target = aria::tool_pose(2).expect("Table 2 pose 3");
    let seed = JointState::new(aria::TOOL_SEED_Q);
    let mut g = c.benchmark_group("ik_table2_pose3");
    g.sample_size(20);
    g.bench_function("default", |b| {
        b.iter(|| solve_ik(&robot, black_box(&target), &seed, &IkOptions::default()))
    });
    let first = IkOptions {
        first_solution: true,
        ..IkOptions::default()
    };
    g.bench_function("first_solution", |b| {
        b.iter(|| solve_ik(&robot, black_box(&target), &seed, &first))
    });
    g.finish();
}

/// IK on random reachable targets (`fk(q)`, `q` from [`random_states`], one target per
/// iteration): the control-loop preset from seeds within 5° of `q` (clamped), the global
/// search and the default from ARIA's Table 2 seed. Failures (about 1 in 1,000 for the
/// control loop, see tests/ik_fast.rs) are timed as they come.
fn ik_random<M: Measurement + 'static>(c: &mut Criterion<M>, prefix: &str) {
    let robot = aria::nominal();
    let mut rng = SplitMix64::new(0x1c_5eed);
    let cases: Vec<_> = random_states(&robot, false)
        .into_iter()
        .map(|s| {
            let target = robot
                .fk(&s)
                .expect("fk of a configuration within the limits");
            let near = core::array::from_fn(|j| {
                let l = robot.limits()[j];
                let d = 5f64.to_radians();
                (s.q[j] + rng.range(-d, d)).clamp(l.lower, l.upper)
            });
            (target, JointState::new(near))
        })
        .collect();
    let home = JointState::new(aria::TOOL_SEED_Q);
    let mut k = 0usize;
    let mut next = move || {
        k = (k + 1) & (TABLE - 1);
        k
    };
    let mut g = c.benchmark_group(format!("{prefix}ik_random"));
    let local = IkOptions::control_loop();
    g.bench_function("control_loop_5deg_seed", |b| {
        b.iter(|| {
            let (target, seed) = &cases[next()];
            solve_ik(&robot, black_box(target), seed, &local)
        })
    });
    let global = IkOptions::global_search();
    g.bench_function("global_search", |b| {
        b.iter(|| solve_ik(&robot, black_box(&cases[next()].0), &home, &global))
    });
    g.sample_size(10);
    let default = IkOptions::default();
    g.bench_function("default", |b| {
        b.iter(|| solve_ik(&robot, black_box(&cases[next()].0), &home, &default))
    });
    g.finish();
}

fn cpu_time(c: &mut Criterion<ThreadCpuTime>) {
    if thread_cpu_ns().is_some() {
        kinematics(c, "cpu_time/");
        ik_random(c, "cpu_time/");
    } else {
        eprintln!("no thread CPU clock: CPU-time benchmarks skipped");
    }
}

criterion_group!(benches, wall, ik);
criterion_group! {
    name = cpu_benches;
    config = Criterion::default().with_measurement(ThreadCpuTime);
    targets = cpu_time
}
criterion_main!(benches, cpu_benches);
