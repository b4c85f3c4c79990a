//! Criterion benchmark of instrument-free calibration on real data: every MUKCa Franka
//! Panda recording with the set's `panda.urdf` (MUKCa, ../shared/realdata/mukca; read from
//! there, never copied; `KINCAL_REALDATA` overrides the folder). Each location is a placement
//! of the two-socket plate: two targets, their contacts (`hole_0.csv`, `hole_1.csv`, rad),
//! one known distance of 50 mm. Fitted as `kincal calibrate --constraints` does: OLS from
//! the nominal model, every geometric parameter and the ball centre (tool translation),
//! identifiability analysis and covariance included.
//!
//! Figures, in the benchmark thread's CPU time (`cpu_time/…`; other jobs on a shared
//! machine do not inflate it much): each recording alone (`mukca/<recording>`), and all
//! eleven `panda.urdf` recordings one after another (`mukca/all_11_panda_recordings`: 43
//! locations, 86 sockets, 2,720 contacts; `panda_1_with_sensor` has another tool and URDF),
//! each fitted on its own (they are different arms). Issue #13's target: all Panda
//! locations in under 50 ms. Without the data folder the bench says so and measures
//! nothing.
//!
//! Figures (docs/constraints.md, Speed): all eleven 66.0 ms (63.0–69.2) before trials were
//! costed without Jacobians (`RowSource::fold_cost`) and contact rows folded by
//! `GramAccumulator::add_rows3`; after, in one session alternating the two binaries (load
//! 17–19 on 2 cores, which inflates both), 123.4 → 80.0 ms and 111.3 → 73.0 ms (ratio
//! 0.65); per recording (second run)
//! panda_3 27.4 → 12.8, panda_4 21.8 → 13.1 ms. Instructions for one pass over the eleven
//! (callgrind, `identify_constrained` inclusive): 976.9M → 681.3M. On a quiet machine (load
//! about 1, another session's machine): all eleven 58.1 ms (55.4–61.3): the 50 ms goal was
//! not met. Then trial costs that stop once above the current cost, no Jacobian scratch in
//! cost passes, leaner contact Jacobians, a three-row Householder fold in the analysis and
//! a two-rows-per-pass Gram fold (every fit bit for bit: `tests/mukca_convergence.rs`):
//! 681.3M → 516.1M instructions; both binaries alternating in one session (load 4–7 on 2
//! cores), all eleven 53.0 → 41.8 ms and 55.0 → 41.9 ms (ratio 0.79, 0.76): **under
//! 50 ms**; per recording (second run) panda_3 11.0 → 8.0, panda_4 9.06 → 6.53 ms.
//!
//! The recordings and the Panda (built from `panda.urdf`'s joint origins, no URDF reader)
//! come from `tests/mukca/mod.rs`, which the convergence test `tests/mukca_convergence.rs`
//! shares.
//!
//! Run: `cargo bench -p kincal --bench mukca -- --noplot`.

use criterion::{Criterion, criterion_group, criterion_main};
use kincal::Robot;
use kincal::identify::{
    Algorithm, Identification, IdentifyOptions, Workspace, identify_constrained,
};
use std::hint::black_box;

mod common;
use common::{ThreadCpuTime, thread_cpu_ns};

#[path = "../tests/mukca/mod.rs"]
mod mukca;
use mukca::{P, PANDAS, Recording, panda, realdata, recording};

fn calibrate(
    nominal: &Robot<7>,
    r: &Recording,
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
) -> Identification<7> {
    identify_constrained(nominal, &r.view(), opts, ws).expect("identify")
}

fn bench(c: &mut Criterion<ThreadCpuTime>) {
    if thread_cpu_ns().is_none() {
        eprintln!("no thread CPU clock: MUKCa benchmarks skipped");
        return;
    }
    let root = realdata();
    if !root.join("mukca/data").is_dir() {
        println!(
            "MUKCa not found under {} (set KINCAL_REALDATA): nothing measured",
            root.display()
        );
        return;
    }
    let nominal = panda();
    let recordings: Vec<Recording> = PANDAS.iter().map(|n| recording(&root, n)).collect();
    let mut ws = Box::<Workspace<P>>::default();
    // The geometry and the ball centre (tool translation), as `kincal calibrate` asks.
    let mut requested = nominal.geometric_param_set();
    for k in 0..3 {
        requested.insert(5 * 7 + 6 + k).expect("tool translation");
    }
    let opts = IdentifyOptions::new(Algorithm::Ols, requested);
    let (mut rows, mut sockets) = (0, 0);
    for r in &recordings {
        let t0 = std::time::Instant::now();
        let fit = calibrate(&nominal, r, &opts, &mut ws);
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        println!(
            "{}: {} contacts, {} sockets, {} distances: {} parameters in {} iterations \
             ({ms:.1} ms once), scatter RMS {:.3} -> {:.3} mm",
            r.name,
            r.contacts.len(),
            r.groups.len(),
            r.distances.len(),
            fit.analysis.rank,
            fit.iterations,
            fit.initial.rms_pos_m * 1e3,
            fit.fitted.rms_pos_m * 1e3
        );
        rows += r.contacts.len();
        sockets += r.groups.len();
    }
    println!("all: {rows} contacts, {sockets} sockets");
    let mut group = c.benchmark_group("mukca");
    group.sample_size(10);
    for r in &recordings {
        group.bench_function(r.name, |b| {
            b.iter(|| calibrate(black_box(&nominal), r, &opts, &mut ws))
        });
    }
    group.bench_function("all_11_panda_recordings", |b| {
        b.iter(|| {
            for r in &recordings {
                black_box(calibrate(black_box(&nominal), r, &opts, &mut ws));
            }
        })
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().with_measurement(ThreadCpuTime);
    targets = bench
}
criterion_main!(benches);
