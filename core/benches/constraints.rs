//! Criterion benchmark of instrument-free calibration: 2,000 contacts over 100 unknown
//! targets (20 ball-in-socket contacts each, orientations tilted up to 0.35 rad), 50 known
//! distances between target pairs (a socket plate per placement, as MUKCa), ARIA's virtual
//! truth, OLS from the nominal model with the identifiability analysis and covariance
//! included. Target: under 50 ms.

use criterion::{Criterion, criterion_group, criterion_main};
use kincal::identify::{
    Algorithm, ConstraintData, Contact, Distance, Group, GroupKind, IdentifyOptions, Workspace,
    identify_constrained,
};
use kincal::ik::{IkOptions, solve_ik};
use kincal::{JointState, Transform, aria};
use std::hint::black_box;

const TARGETS: usize = 100;
const PER_TARGET: usize = 20;

struct Data {
    contacts: Vec<Contact<6>>,
    groups: Vec<Group>,
    distances: Vec<Distance>,
}

fn data() -> Data {
    let truth = aria::virtual_truth();
    let mut state = 7u64;
    let mut unit = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let opts = IkOptions {
        extra_seeds: 2,
        first_solution: true,
        ..IkOptions::default()
    };
    let mut d = Data {
        contacts: Vec::new(),
        groups: Vec::new(),
        distances: Vec::new(),
    };
    let mut points = Vec::new();
    while d.groups.len() < TARGETS {
        let mut q0 = aria::TOOL_SEED_Q;
        for v in q0.iter_mut() {
            *v += unit() - 0.5;
        }
        let t0 = truth.fk(&JointState::new(q0)).expect("fk");
        let start = d.contacts.len();
        let mut tries = 0;
        while d.contacts.len() - start < PER_TARGET && tries < 200 {
            tries += 1;
            let axis = nalgebra::Vector3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5).normalize();
            let r = t0.rotation * nalgebra::Rotation3::from_scaled_axis(axis * (0.35 * unit()));
            let pose =
                Transform::from_parts(nalgebra::Translation3::from(t0.translation.vector), r);
            if let Ok(s) = solve_ik(&truth, &pose, &JointState::new(q0), &opts)
                && s.residual_pos_m < 1e-12
            {
                d.contacts.push(Contact::new(s.q));
            }
        }
        if d.contacts.len() - start < PER_TARGET {
            d.contacts.truncate(start);
            continue;
        }
        d.groups.push(Group {
            kind: GroupKind::Target,
            start,
            len: PER_TARGET,
        });
        points.push(t0.translation.vector);
    }
    for k in 0..TARGETS / 2 {
        d.distances.push(Distance {
            a: 2 * k,
            b: 2 * k + 1,
            m: (points[2 * k] - points[2 * k + 1]).norm(),
            weight: 1.0,
        });
    }
    d
}

fn bench(c: &mut Criterion) {
    let nominal = aria::nominal();
    let d = data();
    let view = ConstraintData {
        instrument: &[],
        contacts: &d.contacts,
        groups: &d.groups,
        distances: &d.distances,
        sessions: &[],
    };
    let mut ws = Box::<Workspace<48>>::default();
    // The geometry and the ball offset (tool translation), as `kincal calibrate` asks.
    let mut requested = nominal.geometric_param_set();
    for i in 36..39 {
        requested.insert(i).expect("tool translation");
    }
    let opts = IdentifyOptions::new(Algorithm::Ols, requested);
    let fit = identify_constrained(&nominal, &view, &opts, &mut ws).expect("identify");
    println!(
        "{} contacts, {} targets, {} distances: {} parameters fitted in {} iterations, RMS {:.2e} m",
        d.contacts.len(),
        d.groups.len(),
        d.distances.len(),
        fit.analysis.rank,
        fit.iterations,
        fit.fitted.rms_pos_m
    );
    c.bench_function("constraints/ols_2000_contacts_100_targets", |b| {
        b.iter(|| {
            identify_constrained(black_box(&nominal), &view, &opts, &mut ws).expect("identify")
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
