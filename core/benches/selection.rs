//! One pose selection as `kincal select-poses` / evaluate-designs' standard design makes it
//! (ARIA, 24 geometric parameters, unit columns, a pool of 2000 joint-space candidates,
//! m = 10, index O, one start, 200 refinement trials), with the candidates skipped by their
//! bounds (selection/bound.rs, the default) and with every candidate evaluated exactly (the
//! selection before issue #18 goal 5's change; the poses chosen are the same). CPU time of
//! the benchmark thread.
//!
//! Run: `cargo bench -p kincal --bench selection -- --noplot --warm-up-time 1
//! --measurement-time 10`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use kincal::aria;
use kincal::identify::Workspace;
use kincal::observability::{Index, ObservabilityOptions, PoseBlock};
use kincal::rng::SplitMix64;
use kincal::selection::{
    Constraints, Objective, Pool, SelectOptions, SelectScratch, fill_pool, sample_joint_space,
    select_poses,
};

mod common;
use common::ThreadCpuTime;

const P: usize = 24;

fn bench(c: &mut Criterion<ThreadCpuTime>) {
    let robot = aria::nominal();
    let obs = ObservabilityOptions::new(robot.geometric_param_set());
    let cons = Constraints {
        joint_margin_rad: 0.05,
        ..Constraints::none()
    };
    let k = 2000;
    let mut q = vec![[0.0; 6]; k];
    let got = sample_joint_space(&robot, &cons, &mut SplitMix64::new(1), &mut q, 100 * k)
        .expect("sample");
    assert_eq!(got, k);
    let mut ws = Box::<Workspace<P>>::default();
    let mut blocks: Vec<PoseBlock<P>> = vec![[[0.0; P]; 6]; k];
    let mut pos = vec![[0.0; 3]; k];
    fill_pool(&robot, &q, &obs, &mut ws, &mut blocks, &mut pos).expect("pool");
    let pool = Pool {
        q: &q,
        blocks: &blocks,
        pos: &pos,
    };
    let mut opts = SelectOptions::new(Objective::Index(Index::O), 1);
    opts.starts = 1;
    for (name, exact) in [
        ("select_poses_o_2000", false),
        ("select_poses_o_2000_exact", true),
    ] {
        let mut s = Box::<SelectScratch<P>>::default();
        s.set_exact_only(exact);
        let mut out = [[0.0; 6]; 10];
        let sel = select_poses(
            &robot, &pool, 10, &obs, &cons, &opts, &mut ws, &mut s, &mut out,
        )
        .expect("select");
        println!(
            "{name}: O {:.6}, {} evaluations, {} skipped by their bound",
            sel.value,
            sel.evaluations,
            s.skipped()
        );
        c.bench_function(name, |b| {
            b.iter(|| {
                black_box(
                    select_poses(
                        &robot, &pool, 10, &obs, &cons, &opts, &mut ws, &mut s, &mut out,
                    )
                    .expect("select"),
                )
            })
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().with_measurement(ThreadCpuTime).sample_size(10);
    targets = bench
}
criterion_main!(benches);
