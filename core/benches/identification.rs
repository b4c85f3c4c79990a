//! Criterion benchmarks of identification: a full 10-pose, 24-parameter ARIA calibration
//! (Table 2 poses, Table 3 truth, start at Table 1) per algorithm, with the identifiability
//! analysis included and with it done once beforehand (as a Monte-Carlo study does).

use criterion::{Criterion, criterion_group, criterion_main};
use kincal::identify::{
    Algorithm, Bounds, IdentifyOptions, Measurement, Workspace, analyze, identify,
    identify_with_analysis,
};
use kincal::ik::{IkOptions, solve_ik};
use kincal::{JointState, aria};
use std::hint::black_box;

fn tool_data() -> Vec<Measurement<6>> {
    let truth = aria::virtual_truth();
    (0..10)
        .map(|l| {
            let target = aria::tool_pose(l).expect("pose");
            let s = solve_ik(
                &truth,
                &target,
                &JointState::new(aria::TOOL_SEED_Q),
                &IkOptions::default(),
            )
            .expect("reachable");
            Measurement::new(s.q, truth.fk_q(&s.q).expect("fk"))
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let nominal = aria::nominal();
    let data = tool_data();
    let bounds = Bounds::around(&nominal, 0.05, 1.0);
    let mut ws = Box::<Workspace<32>>::default();
    for alg in Algorithm::ALL {
        let mut opts = IdentifyOptions::new(alg, nominal.geometric_param_set());
        opts.bounds = Some(&bounds);
        let analysis = analyze(&nominal, &data, &opts, &mut ws).expect("analysis");
        c.bench_function(
            &format!("calibrate_10_poses_24_params/{}/with_analysis", alg.name()),
            |b| {
                b.iter(|| {
                    black_box(identify(&nominal, black_box(&data), &opts, &mut ws).expect("fit"))
                })
            },
        );
        c.bench_function(
            &format!(
                "calibrate_10_poses_24_params/{}/analysis_reused",
                alg.name()
            ),
            |b| {
                b.iter(|| {
                    black_box(
                        identify_with_analysis(
                            &nominal,
                            black_box(&data),
                            &opts,
                            &analysis,
                            &mut ws,
                        )
                        .expect("fit"),
                    )
                })
            },
        );
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
