//! One Monte-Carlo calibration run on the built-in ARIA: random robot, the Table 2 tool's
//! measurements (true-robot IK at each reference pose), OLS identification of the 24
//! geometric parameters with the design's analysis reused, validation at 60 poses of the
//! working region. A study of 10,000 runs costs 10,000 × this CPU time (split over the
//! cores by the CLI).
//!
//! Run: `cargo bench -p kincal --bench montecarlo -- --noplot --warm-up-time 1
//! --measurement-time 5`. Wall time: grows with the shared machine's load.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use kincal::identify::{Measurement, Workspace};
use kincal::ik::{IkOptions, solve_ik};
use kincal::montecarlo::{
    Acquisition, Design, Scenario, Study, joint_sincos, prepare, simulate_run,
};
use kincal::pose::Transform;
use kincal::{JointState, aria};

fn montecarlo(c: &mut Criterion) {
    let nominal = aria::nominal();
    let ik = |t: &Transform| {
        solve_ik(
            &nominal,
            t,
            &JointState::new(aria::TOOL_SEED_Q),
            &IkOptions::default(),
        )
        .ok()
        .map(|s| s.q)
    };
    let refs: Vec<Transform> = (0..10).map(|l| aria::tool_pose(l).expect("pose")).collect();
    let q: Vec<[f64; 6]> = refs.iter().map(|t| ik(t).expect("reachable")).collect();
    let mut grid = [Transform::identity(); 64];
    let n = aria::working_region_grid(4, 4, 2, &mut grid);
    let vq: Vec<[f64; 6]> = grid[..n].iter().filter_map(ik).collect();
    let vs: Vec<[[f64; 2]; 6]> = vq.iter().map(joint_sincos).collect();
    let study = Study {
        nominal,
        params: nominal.geometric_param_set(),
        validation_q: &vq,
        validation_sincos: &vs,
        validation_nominal: &[],
        scenario: Scenario::paper(),
        seed: 1,
    };
    let mut ws = Box::<Workspace<24>>::default();
    let mut data = vec![Measurement::new([0.0; 6], Transform::identity()); 10];
    for (name, acquisition) in [
        ("tool", Acquisition::Tool),
        ("instrument", Acquisition::Instrument),
    ] {
        let design = Design {
            acquisition,
            q: &q,
            reference: &refs,
        };
        let analysis = prepare(&study, &design, &mut ws, &mut data).expect("prepare");
        let mut run = 0u64;
        c.bench_function(&format!("calibration_run_table2_{name}"), |b| {
            b.iter(|| {
                run += 1;
                black_box(simulate_run(
                    &study, &design, &analysis, run, &mut ws, &mut data,
                ))
            })
        });
    }
}

criterion_group!(benches, montecarlo);
criterion_main!(benches);
