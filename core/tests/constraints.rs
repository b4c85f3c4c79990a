//! Instrument-free calibration ([`kincal::identify::constraints`]): noise-free recovery of
//! the geometry, the ball offset (tool translation), targets and planes from contacts at
//! unknown targets with one known distance; the gauge (base frame, scale) named by the
//! identifiability analysis; noisy fits within their standard errors.

mod common;

use common::{SplitMix64, arm7};
use kincal::identify::{
    Algorithm, ConstraintData, Contact, Distance, Group, GroupKind, IdentifyOptions, Workspace,
    analyze_constrained, distance_estimate, group_estimate, identify_constrained,
};
use kincal::ik::{IkOptions, solve_ik};
use kincal::params::{ParamId, ParamSet};
use kincal::{JointState, ParamIndex, Robot, Transform};

type Ws = Workspace<128>;

fn workspace() -> Box<Ws> {
    // SAFETY: all-zero is a valid Workspace (documented).
    unsafe { Box::new_zeroed().assume_init() }
}

/// Nominal arm with a ball 10 cm out along the tool z axis.
fn nominal() -> Robot<7> {
    arm7()
        .with_tool([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
        .expect("tool")
}

/// The "true" arm: every link parameter and the base perturbed, the ball offset off by
/// millimetres.
/// Only parameters the analysis keeps are perturbed (structurally redundant ones are
/// equivalent only to first order, so a finite change of them is not representable).
fn truth(seed: u64) -> Robot<7> {
    let nominal = nominal();
    let probe = synthetic(&nominal, 10, 0, 5, 99);
    let mut ws = workspace();
    let opts = IdentifyOptions::new(Algorithm::Ols, geometric());
    let a = analyze_constrained(&nominal, &data(&probe), &opts, &mut ws).expect("analysis");
    let mut rng = SplitMix64::new(seed);
    let mut r = nominal;
    for i in 0..7 {
        for k in 0..5 {
            let idx = ParamIndex(5 * i + k);
            if !a.identifiable.contains(idx.0) {
                continue;
            }
            let h = if k == 1 || k == 2 { 0.003 } else { 0.01 };
            let v = r.param(idx).expect("param") + rng.uniform(-h, h);
            r.set_param(idx, v).expect("set");
        }
    }
    let base = [0.01, -0.02, 0.03, 0.02, -0.01, 0.05];
    for (k, v) in base.into_iter().enumerate() {
        r.set_param(ParamIndex(35 + k), v).expect("base");
    }
    for (k, v) in [0.002, -0.003, 0.104].into_iter().enumerate() {
        if a.identifiable.contains(41 + k) {
            r.set_param(ParamIndex(41 + k), v).expect("tool");
        }
    }
    r
}

fn rot(axis: [f64; 3], angle: f64) -> nalgebra::Rotation3<f64> {
    nalgebra::Rotation3::from_scaled_axis(nalgebra::Vector3::new(
        axis[0] * angle,
        axis[1] * angle,
        axis[2] * angle,
    ))
}

/// Joint states holding the tool point of `robot` at `p` in `n` orientations tilted up to
/// `tilt` rad from `r0` (IK on the true robot, seeded at `q0`).
fn holds(
    robot: &Robot<7>,
    p: [f64; 3],
    r0: nalgebra::Rotation3<f64>,
    q0: [f64; 7],
    n: usize,
    tilt: f64,
    rng: &mut SplitMix64,
) -> Vec<Contact<7>> {
    let opts = IkOptions {
        extra_seeds: 4,
        first_solution: true,
        ..IkOptions::default()
    };
    let mut out = Vec::new();
    let mut tries = 0;
    while out.len() < n && tries < 10 * n {
        tries += 1;
        let r = r0 * rot(rng.unit_vector(), rng.uniform(0.0, tilt));
        let pose = Transform::from_parts(nalgebra::Translation3::new(p[0], p[1], p[2]), r);
        if let Ok(sol) = solve_ik(robot, &pose, &JointState::new(q0), &opts)
            && sol.residual_pos_m < 1e-12
        {
            out.push(Contact::new(sol.q));
        }
    }
    assert_eq!(out.len(), n, "IK failed");
    out
}

struct Set {
    contacts: Vec<Contact<7>>,
    groups: Vec<Group>,
    distances: Vec<Distance>,
    targets: Vec<[f64; 3]>,
}

/// `n_targets` targets (the first two a known distance apart) with `per` contacts each,
/// plus `n_planes` planes with `per + 2` contacts each.
fn synthetic(robot: &Robot<7>, n_targets: usize, n_planes: usize, per: usize, seed: u64) -> Set {
    let mut rng = SplitMix64::new(seed);
    let mut s = Set {
        contacts: vec![],
        groups: vec![],
        distances: vec![],
        targets: vec![],
    };
    let add = |s: &mut Set, kind: GroupKind, c: Vec<Contact<7>>| {
        s.groups.push(Group {
            kind,
            start: s.contacts.len(),
            len: c.len(),
        });
        s.contacts.extend(c);
    };
    for _ in 0..n_targets {
        let q0 = rng.q_within(robot.limits()).map(|v| 0.6 * v);
        let t0 = robot.fk(&JointState::new(q0)).expect("fk");
        let p = t0.translation.vector;
        let p = [p.x, p.y, p.z];
        let c = holds(robot, p, t0.rotation, q0, per, 0.4, &mut rng);
        s.targets.push(p);
        add(&mut s, GroupKind::Target, c);
    }
    if n_targets >= 2 {
        let (a, b) = (s.targets[0], s.targets[1]);
        let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        s.distances.push(Distance {
            a: 0,
            b: 1,
            m: d,
            weight: 1.0,
        });
    }
    for _ in 0..n_planes {
        let q0 = rng.q_within(robot.limits()).map(|v| 0.6 * v);
        let t0 = robot.fk(&JointState::new(q0)).expect("fk");
        let c0 = t0.translation.vector;
        let n = nalgebra::Vector3::from(rng.unit_vector());
        let u = n.cross(&nalgebra::Vector3::new(0.3, 0.5, 0.8)).normalize();
        let v = n.cross(&u);
        let mut c = Vec::new();
        for _ in 0..per + 2 {
            let p = c0 + u * rng.uniform(-0.1, 0.1) + v * rng.uniform(-0.1, 0.1);
            c.extend(holds(
                robot,
                [p.x, p.y, p.z],
                t0.rotation,
                q0,
                1,
                0.3,
                &mut rng,
            ));
        }
        add(&mut s, GroupKind::Plane, c);
    }
    s
}

fn geometric() -> ParamSet {
    let mut set = ParamSet::new();
    for i in 0..Robot::<7>::NUM_GEOMETRIC_PARAMS {
        set.insert(i).expect("insert");
    }
    set
}

fn data(s: &Set) -> ConstraintData<'_, 7> {
    ConstraintData {
        instrument: &[],
        contacts: &s.contacts,
        groups: &s.groups,
        distances: &s.distances,
    }
}

fn name(i: usize) -> String {
    format!("{:?}", ParamId::from_index(ParamIndex(i), 7).expect("id"))
}

#[test]
fn noise_free_targets_planes_and_a_distance_recover_the_geometry() {
    let truth = truth(7);
    let set = synthetic(&truth, 14, 3, 6, 11);
    let d = data(&set);
    let mut ws = workspace();
    let opts = IdentifyOptions::new(Algorithm::Ols, geometric());
    let fit = identify_constrained(&nominal(), &d, &opts, &mut ws).expect("identify");
    let a = &fit.analysis;
    eprintln!(
        "iters {} initial {:?} fitted {:?} gauge {:?} dd {:?} structural {:?}",
        fit.iterations,
        fit.initial,
        fit.fitted,
        a.gauge.iter().map(name).collect::<Vec<_>>(),
        a.data_deficient.iter().map(name).collect::<Vec<_>>(),
        a.structural.iter().map(name).collect::<Vec<_>>()
    );
    // The whole base is gauge (no external reference), scale is not (a distance).
    for k in 0..6 {
        assert!(a.gauge.contains(35 + k), "base {k} not reported as gauge");
    }
    assert!(
        !a.gauge.iter().any(|i| i < 35 && !is_link1_rigid(i)),
        "gauge {:?}",
        a.gauge.iter().map(name).collect::<Vec<_>>()
    );
    assert!(
        a.data_deficient.is_empty(),
        "{:?}",
        a.data_deficient.iter().map(name).collect::<Vec<_>>()
    );
    assert!(fit.fitted.rms_pos_m < 1e-10, "rms {}", fit.fitted.rms_pos_m);
    // Every fitted parameter equals the truth (the gauge absorbs the base difference).
    for i in a.identifiable.iter() {
        let (got, want) = (
            fit.robot.param(ParamIndex(i)).unwrap(),
            truth.param(ParamIndex(i)).unwrap(),
        );
        assert!((got - want).abs() < 1e-9, "{} {got} vs {want}", name(i));
    }
    // Targets: a rigid image of the truth (distances between them preserved), planes flat.
    let est: Vec<_> = (0..set.groups.len())
        .map(|g| group_estimate(&fit.robot, &d, g).unwrap())
        .collect();
    for i in 0..set.targets.len() {
        assert!(est[i].max_m < 1e-10);
        for j in 0..i {
            let dt = dist(set.targets[i], set.targets[j]);
            let de = dist(est[i].point, est[j].point);
            assert!((dt - de).abs() < 1e-9, "targets {i},{j}: {dt} vs {de}");
        }
    }
    for e in &est[set.targets.len()..] {
        assert!(e.max_m < 1e-10, "plane scatter {}", e.max_m);
    }
    let de = distance_estimate(&fit.robot, &d, 0).unwrap().unwrap();
    assert!((de - set.distances[0].m).abs() < 1e-10);
}

fn is_link1_rigid(i: usize) -> bool {
    // θ0 and d of link 1 duplicate a rigid motion of the base.
    i < 5
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[test]
fn without_a_distance_one_length_is_the_scale_gauge() {
    let truth = truth(3);
    let mut set = synthetic(&truth, 10, 0, 6, 5);
    set.distances.clear();
    let d = data(&set);
    let mut ws = workspace();
    let opts = IdentifyOptions::new(Algorithm::Ols, geometric());
    let a = analyze_constrained(&nominal(), &d, &opts, &mut ws).expect("analysis");
    let lengths: Vec<_> = a
        .gauge
        .iter()
        .filter(|&i| {
            let id = ParamId::from_index(ParamIndex(i), 7).unwrap();
            id.is_length() && !matches!(id, ParamId::Base(_)) && !is_link1_rigid(i)
        })
        .collect();
    assert_eq!(
        lengths.len(),
        1,
        "{:?}",
        a.gauge.iter().map(name).collect::<Vec<_>>()
    );
    assert!(a.gauge.contains(35));
    // With the distance back, no length is gauge.
    let set2 = synthetic(&truth, 10, 0, 6, 5);
    let a2 = analyze_constrained(&nominal(), &data(&set2), &opts, &mut ws).expect("analysis");
    assert!(a2.gauge.iter().all(
        |i| !ParamId::from_index(ParamIndex(i), 7).unwrap().is_length() || !(5..35).contains(&i)
    ));
}
