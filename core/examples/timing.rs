use kincal::identify::*;
use kincal::ik::*;
use kincal::{JointState, aria};
fn main() {
    let truth = aria::virtual_truth();
    let nominal = aria::nominal();
    let data: Vec<_> = (0..10)
        .map(|l| {
            let t = aria::tool_pose(l).unwrap();
            let s = solve_ik(
                &truth,
                &t,
                &JointState::new(aria::TOOL_SEED_Q),
                &IkOptions::default(),
            )
            .unwrap();
            Measurement::new(s.q, truth.fk_q(&s.q).unwrap())
        })
        .collect();
    let mut ws = Box::<Workspace<32>>::default();
    let b = Bounds::around(&nominal, 0.05, 1.0);
    for alg in Algorithm::ALL {
        let mut o = IdentifyOptions::new(alg, nominal.geometric_param_set());
        o.bounds = Some(&b);
        let t = std::time::Instant::now();
        let reps = 200;
        for _ in 0..reps {
            std::hint::black_box(identify(&nominal, &data, &o, &mut ws).unwrap());
        }
        let a = std::time::Instant::now();
        for _ in 0..reps {
            std::hint::black_box(analyze(&nominal, &data, &o, &mut ws).unwrap());
        }
        println!(
            "{alg:?}: identify {:?}  analyze {:?}",
            t.elapsed() / reps,
            a.elapsed() / reps
        );
    }
}
