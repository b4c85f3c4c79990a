//! Instrument-free calibration through the ABI (`kincal_identify_constraints`): noise-free
//! contacts of a perturbed ARIA (made by the core's IK on the truth) recover its geometry,
//! targets, planes and distance to 1e-9; the result equals the core's on the same data
//! grouped by hand; the gauge is named without an external reference; every bad argument
//! gives its status with the offending row.

use core::ffi::{CStr, c_void};
use core::ptr::{null, null_mut};

use kincal::identify::{
    Algorithm, ConstraintData, Contact, Distance, Group, GroupKind, IdentifyOptions, Measurement,
    Workspace, identify_constrained,
};
use kincal::ik::{IkOptions, solve_ik};
use kincal::params::ParamSet;
use kincal::rng::SplitMix64;
use kincal::{JointState, ParamIndex, Robot, Transform, aria};

use crate::constraints::*;
use crate::identify::*;
use crate::robot::*;
use crate::status::*;

const BALL: [f64; 3] = [0.01, -0.02, 0.1];

fn rot(axis: [f64; 3], angle: f64) -> nalgebra::Rotation3<f64> {
    nalgebra::Rotation3::from_scaled_axis(nalgebra::Vector3::new(
        axis[0] * angle,
        axis[1] * angle,
        axis[2] * angle,
    ))
}

fn uni(rng: &mut SplitMix64, a: f64, b: f64) -> f64 {
    a + (b - a) * rng.uniform()
}

fn unit(rng: &mut SplitMix64) -> [f64; 3] {
    let v = nalgebra::Vector3::new(
        uni(rng, -1.0, 1.0),
        uni(rng, -1.0, 1.0),
        uni(rng, -1.0, 1.0),
    )
    .normalize();
    [v.x, v.y, v.z]
}

fn point(r: &Robot<6>, q: &[f64; 6]) -> [f64; 3] {
    let t = r.fk(&JointState::new(*q)).unwrap();
    let p = t * nalgebra::Point3::from(BALL);
    [p.x, p.y, p.z]
}

/// Readings holding the ball of `robot` at `p` in an orientation tilted from `r0`.
fn hold(
    robot: &Robot<6>,
    p: [f64; 3],
    r0: nalgebra::Rotation3<f64>,
    q0: [f64; 6],
    tilt: f64,
    rng: &mut SplitMix64,
) -> [f64; 6] {
    let opts = IkOptions {
        extra_seeds: 4,
        first_solution: true,
        ..IkOptions::default()
    };
    for _ in 0..50 {
        let r = r0 * rot(unit(rng), uni(rng, 0.0, tilt));
        let ball = r * nalgebra::Vector3::from(BALL);
        let pose = Transform::from_parts(
            nalgebra::Translation3::new(p[0] - ball.x, p[1] - ball.y, p[2] - ball.z),
            r,
        );
        if let Ok(sol) = solve_ik(robot, &pose, &JointState::new(q0), &opts)
            && sol.residual_pos_m < 1e-13
        {
            return sol.q;
        }
    }
    panic!("IK failed");
}

/// Caller-side arrays of one data set (rows interleaved, not sorted by group).
#[derive(Clone, Default)]
struct Rows {
    q: Vec<f64>,
    target: Vec<u32>,
    plane: Vec<u32>,
    session: Vec<u32>,
    point: Vec<f64>,
    coords: Vec<f64>,
    mask: Vec<u8>,
    targets: Vec<kincal_target>,
    planes: Vec<kincal_plane>,
    distances: Vec<kincal_distance>,
    n_sessions: usize,
    /// True target points and plane (normal, offset).
    true_targets: Vec<[f64; 3]>,
    true_planes: Vec<([f64; 3], f64)>,
}

impl Rows {
    fn push(&mut self, q: [f64; 6], target: u32, plane: u32, session: u32) {
        self.q.extend_from_slice(&q);
        self.target.push(target);
        self.plane.push(plane);
        self.session.push(session);
        self.point.extend_from_slice(&BALL);
        self.coords.extend_from_slice(&[0.0; 3]);
        self.mask.push(0);
    }

    fn n(&self) -> usize {
        self.target.len()
    }

    fn view(&self) -> kincal_constraint_data {
        let l = self.n();
        kincal_constraint_data {
            n_rows: l,
            q: self.q.as_ptr(),
            q_len: self.q.len(),
            target: self.target.as_ptr(),
            target_len: l,
            plane: self.plane.as_ptr(),
            plane_len: l,
            session: self.session.as_ptr(),
            session_len: l,
            n_sessions: self.n_sessions,
            point: self.point.as_ptr(),
            point_len: self.point.len(),
            coords: self.coords.as_ptr(),
            coords_len: self.coords.len(),
            coord_mask: self.mask.as_ptr(),
            coord_mask_len: l,
            aux: null(),
            aux_len: 0,
            n_targets: self.targets.len(),
            targets: self.targets.as_ptr(),
            targets_len: self.targets.len(),
            n_planes: self.planes.len(),
            planes: self.planes.as_ptr(),
            planes_len: self.planes.len(),
            n_distances: self.distances.len(),
            distances: if self.distances.is_empty() {
                null()
            } else {
                self.distances.as_ptr()
            },
            distances_len: self.distances.len(),
        }
    }
}

/// Two sessions: 8 unknown targets (5 contacts each), 2 known targets (3 each), 2 unknown
/// planes (6 each), a distance between targets 0 and 1, and 4 partial-coordinate
/// instrument rows in session 0. Rows are interleaved round-robin.
fn synthetic(truth: &Robot<6>, seed: u64) -> Rows {
    let mut rng = SplitMix64::new(seed);
    let mut per_group: Vec<Vec<([f64; 6], u32, u32)>> = Vec::new();
    let mut rows = Rows {
        n_sessions: 2,
        ..Rows::default()
    };
    let seed_q = |rng: &mut SplitMix64| {
        let mut q = aria::TOOL_SEED_Q;
        for v in &mut q {
            *v += uni(rng, -0.5, 0.5);
        }
        q
    };
    for t in 0..10u32 {
        let q0 = seed_q(&mut rng);
        let r0 = truth.fk(&JointState::new(q0)).unwrap().rotation;
        let p = point(truth, &q0);
        let known = t >= 8;
        let n = if known { 3 } else { 5 };
        let contacts = (0..n)
            .map(|_| (hold(truth, p, r0, q0, 0.5, &mut rng), t, KINCAL_NO_GROUP))
            .collect();
        per_group.push(contacts);
        rows.targets.push(kincal_target {
            known: u32::from(known),
            xyz_m: if known { p } else { [0.0; 3] },
        });
        rows.true_targets.push(p);
    }
    for k in 0..2u32 {
        let q0 = seed_q(&mut rng);
        let r0 = truth.fk(&JointState::new(q0)).unwrap().rotation;
        let c0 = nalgebra::Vector3::from(point(truth, &q0));
        let n = nalgebra::Vector3::from(unit(&mut rng));
        let u = n.cross(&nalgebra::Vector3::new(0.3, 0.5, 0.8)).normalize();
        let v = n.cross(&u);
        let contacts = (0..6)
            .map(|_| {
                let p = c0 + u * uni(&mut rng, -0.08, 0.08) + v * uni(&mut rng, -0.08, 0.08);
                (
                    hold(truth, [p.x, p.y, p.z], r0, q0, 0.3, &mut rng),
                    KINCAL_NO_GROUP,
                    k,
                )
            })
            .collect();
        per_group.push(contacts);
        rows.planes.push(kincal_plane::default());
        rows.true_planes.push(([n.x, n.y, n.z], n.dot(&c0)));
    }
    // Interleave: one row of each group in turn. Targets 0..4 and plane 0 in session 0.
    let session_of = |g: usize| u32::from(!(g < 4 || g == 10 || g == 8));
    let longest = per_group.iter().map(Vec::len).max().unwrap();
    for k in 0..longest {
        for (g, list) in per_group.iter().enumerate() {
            if let Some(&(q, t, p)) = list.get(k) {
                rows.push(q, t, p, session_of(g));
            }
        }
    }
    let (a, b) = (rows.true_targets[0], rows.true_targets[1]);
    let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    rows.distances.push(kincal_distance {
        a: 0,
        b: 1,
        m: d,
        weight: 1.0,
    });
    // Partial coordinates: z only, then x and y, of the ball.
    for mask in [0x4u8, 0x3, 0x4, 0x7] {
        let q = seed_q(&mut rng);
        let p = point(truth, &q);
        rows.push(q, KINCAL_NO_GROUP, KINCAL_NO_GROUP, 0);
        let l = rows.n() - 1;
        rows.mask[l] = mask;
        rows.coords[3 * l..3 * l + 3].copy_from_slice(&p);
    }
    rows
}

fn robot_of(r: &Robot<6>) -> kincal_robot {
    crate::robot::from_robot(r).unwrap()
}

fn geometric_opts(robot: &kincal_robot) -> kincal_identify_options {
    let mut o = unsafe { core::mem::zeroed::<kincal_identify_options>() };
    assert_eq!(
        unsafe { kincal_identify_options_default(robot, 0, 0, &mut o, null_mut()) },
        kincal_status::Ok
    );
    o
}

struct Out {
    status: kincal_status,
    err: kincal_error,
    robot: kincal_robot,
    report: Box<kincal_constraints_report>,
    targets: Vec<kincal_group_estimate>,
    planes: Vec<kincal_group_estimate>,
    distances: Vec<f64>,
}

fn run(start: &kincal_robot, rows: &Rows, opts: &kincal_identify_options) -> Out {
    let n_req = opts.requested.iter().filter(|&&m| m != 0).count();
    let size = kincal_identify_constraints_workspace_size(
        6,
        rows.n(),
        rows.targets.len(),
        rows.planes.len(),
        rows.distances.len(),
        rows.n_sessions,
        n_req,
    );
    assert!(size > 0);
    let mut ws = vec![0u128; size.div_ceil(16)];
    let data = rows.view();
    let mut out = Out {
        status: kincal_status::Ok,
        err: kincal_error::CLEAR,
        robot: kincal_robot::ZERO,
        report: Box::new(unsafe { core::mem::zeroed() }),
        targets: vec![kincal_group_estimate::default(); rows.targets.len()],
        planes: vec![kincal_group_estimate::default(); rows.planes.len()],
        distances: vec![0.0; rows.distances.len()],
    };
    out.status = unsafe {
        kincal_identify_constraints(
            start,
            &data,
            opts,
            ws.as_mut_ptr().cast::<c_void>(),
            size,
            &mut out.robot,
            &mut *out.report,
            out.targets.as_mut_ptr(),
            out.targets.len(),
            out.planes.as_mut_ptr(),
            out.planes.len(),
            out.distances.as_mut_ptr(),
            out.distances.len(),
            &mut out.err,
        )
    };
    out
}

fn to6(r: &kincal_robot) -> Robot<6> {
    match crate::robot::to_any(r).unwrap() {
        kincal::any::AnyRobot::J6(r) => r,
        _ => panic!("not 6 joints"),
    }
}

/// The truth: ARIA with every parameter the data identify perturbed (mm, tenths of a
/// degree); the others are not representable exactly by a fit that keeps them fixed.
fn truth() -> Robot<6> {
    let nominal = aria::nominal();
    let probe = synthetic(&nominal, 5);
    let start = robot_of(&nominal);
    let out = run(&start, &probe, &geometric_opts(&start));
    assert_eq!(out.status, kincal_status::Ok, "{:?}", out.err);
    let ident = out.report.identify.analysis.identifiable;
    let mut rng = SplitMix64::new(77);
    let mut t = nominal;
    for (i, &m) in ident.iter().enumerate() {
        if m != 0 {
            let id = kincal::ParamId::from_index(ParamIndex(i), 6).unwrap();
            let h = if id.is_length() { 2e-3 } else { 0.005 };
            let v = t.param(ParamIndex(i)).unwrap() + uni(&mut rng, -h, h);
            t.set_param(ParamIndex(i), v).unwrap();
        }
    }
    t
}

#[test]
fn noise_free_contacts_recover_geometry_targets_planes_and_distance() {
    let truth = truth();
    let rows = synthetic(&truth, 11);
    let start = robot_of(&aria::nominal());
    let opts = geometric_opts(&start);
    let out = run(&start, &rows, &opts);
    assert_eq!(out.status, kincal_status::Ok, "{:?}", out.err);
    let rep = &out.report;
    assert_eq!(rep.external_reference, 1);
    assert_eq!(rep.length_reference, 1);
    assert_eq!(rep.n_instrument_rows, 4);
    assert_eq!(rep.n_contacts, rows.n() - 4);
    assert!(rep.gauge.iter().all(|&g| g == 0), "known targets: no gauge");
    let fitted = to6(&out.robot);
    let mut worst: f64 = 0.0;
    for (i, &m) in rep.identify.analysis.identifiable.iter().enumerate() {
        if m != 0 {
            let d =
                (fitted.param(ParamIndex(i)).unwrap() - truth.param(ParamIndex(i)).unwrap()).abs();
            worst = worst.max(d);
        }
    }
    println!(
        "recovery: worst parameter error {worst:.2e}, fitted rms {:.2e} m, {} iterations",
        rep.identify.fitted.rms_pos_m, rep.identify.iterations
    );
    assert!(worst < 1e-9, "{worst}");
    for (e, t) in out.targets.iter().zip(&rows.true_targets) {
        for k in 0..3 {
            assert!((e.point[k] - t[k]).abs() < 1e-9, "{e:?} vs {t:?}");
        }
        assert!(e.rms_m < 1e-9 && e.max_m < 1e-9);
    }
    for (e, (n, c)) in out.planes.iter().zip(&rows.true_planes) {
        let s = if e.normal[0] * n[0] + e.normal[1] * n[1] + e.normal[2] * n[2] < 0.0 {
            -1.0
        } else {
            1.0
        };
        for k in 0..3 {
            assert!((s * e.normal[k] - n[k]).abs() < 1e-9, "{e:?} vs {n:?}");
        }
        assert!((s * e.offset_m - c).abs() < 1e-9);
        assert!(e.rms_m < 1e-9 && e.contacts == 6);
    }
    assert!((out.distances[0] - rows.distances[0].m).abs() < 1e-9);
}

/// The same data grouped by hand and given to the core: the same model, bit for bit.
#[test]
fn equals_the_core_on_the_same_data() {
    let truth = truth();
    let rows = synthetic(&truth, 12);
    let nominal = aria::nominal();
    let start = robot_of(&nominal);
    let opts = geometric_opts(&start);
    let out = run(&start, &rows, &opts);
    assert_eq!(out.status, kincal_status::Ok, "{:?}", out.err);
    // Core data: instrument rows in order, then groups (targets, planes), rows in order.
    let mut instrument = Vec::new();
    let mut contacts = Vec::new();
    let mut groups = Vec::new();
    let q = |l: usize| -> [f64; 6] { rows.q[6 * l..6 * l + 6].try_into().unwrap() };
    for l in 0..rows.n() {
        if rows.mask[l] != 0 {
            let mut pose = Transform::identity();
            for k in 0..3 {
                if rows.mask[l] & (1 << k) != 0 {
                    pose.translation.vector[k] = rows.coords[3 * l + k];
                }
            }
            let mut m = Measurement::new(q(l), pose);
            m.mask = kincal::identify::ComponentMask(rows.mask[l]);
            m.point = Some(BALL);
            instrument.push(m);
        }
    }
    let n_t = rows.targets.len() as u32;
    for g in 0..(n_t + rows.planes.len() as u32) {
        let start = contacts.len();
        for l in 0..rows.n() {
            let hit = if g < n_t {
                rows.target[l] == g
            } else {
                rows.plane[l] == g - n_t
            };
            if hit {
                contacts.push(Contact {
                    point: BALL,
                    ..Contact::new(q(l))
                });
            }
        }
        let kind = if g < n_t {
            let t = rows.targets[g as usize];
            if t.known != 0 {
                GroupKind::KnownTarget(t.xyz_m)
            } else {
                GroupKind::Target
            }
        } else {
            GroupKind::Plane
        };
        groups.push(Group {
            kind,
            start,
            len: contacts.len() - start,
        });
    }
    let distances = [Distance {
        a: 0,
        b: 1,
        m: rows.distances[0].m,
        weight: 1.0,
    }];
    let data = ConstraintData {
        instrument: &instrument,
        contacts: &contacts,
        groups: &groups,
        distances: &distances,
        sessions: &[],
    };
    let mut set = ParamSet::new();
    for (i, &m) in opts.requested.iter().enumerate() {
        if m != 0 {
            set.insert(i).unwrap();
        }
    }
    let mut bounds = kincal::identify::Bounds::paper_default(&nominal);
    bounds.lower = opts.lower;
    bounds.upper = opts.upper;
    let mut io = IdentifyOptions::new(Algorithm::Ols, set);
    io.bounds = Some(&bounds);
    let mut ws: Box<Workspace<KINCAL_MAX_PARAMS>> = unsafe { Box::new_zeroed().assume_init() };
    let id = identify_constrained(&nominal, &data, &io, &mut ws).unwrap();
    let fitted = to6(&out.robot);
    for i in 0..Robot::<6>::NUM_PARAMS {
        assert_eq!(
            fitted.param(ParamIndex(i)).unwrap().to_bits(),
            id.robot.param(ParamIndex(i)).unwrap().to_bits(),
            "parameter {i}"
        );
    }
    assert_eq!(out.report.identify.iterations, id.iterations);
}

#[test]
fn without_an_external_reference_the_base_and_scale_are_named_as_gauge() {
    let truth = truth();
    let mut rows = synthetic(&truth, 13);
    // No known targets, no instrument rows, no distance.
    for t in &mut rows.targets {
        t.known = 0;
    }
    let keep: Vec<usize> = (0..rows.n()).filter(|&l| rows.mask[l] == 0).collect();
    let mut r2 = Rows {
        n_sessions: 2,
        targets: rows.targets.clone(),
        planes: rows.planes.clone(),
        ..Rows::default()
    };
    for &l in &keep {
        r2.push(
            rows.q[6 * l..6 * l + 6].try_into().unwrap(),
            rows.target[l],
            rows.plane[l],
            rows.session[l],
        );
    }
    let start = robot_of(&aria::nominal());
    let mut opts = geometric_opts(&start);
    // Ask for the base frame too: it is the gauge.
    for label in [
        "base_px", "base_py", "base_pz", "base_rx", "base_ry", "base_rz",
    ] {
        let i = kincal::ParamId::parse(label, 6).unwrap().index(6).0;
        opts.requested[i] = 1;
    }
    opts.allow_data_deficiency = 1;
    let out = run(&start, &r2, &opts);
    assert_eq!(out.status, kincal_status::Ok, "{:?}", out.err);
    assert_eq!(out.report.external_reference, 0);
    assert_eq!(out.report.length_reference, 0);
    let gauge: Vec<String> = (0..KINCAL_MAX_PARAMS)
        .filter(|&i| out.report.gauge[i] != 0)
        .map(|i| {
            kincal::ParamId::from_index(ParamIndex(i), 6)
                .unwrap()
                .to_string()
        })
        .collect();
    println!("gauge: {gauge:?}");
    for label in [
        "base_px", "base_py", "base_pz", "base_rx", "base_ry", "base_rz",
    ] {
        assert!(gauge.iter().any(|g| g == label), "{label} not in {gauge:?}");
    }
    // One length is the scale gauge (no distance, no external reference).
    assert!(
        gauge
            .iter()
            .any(|g| !g.starts_with("base") && kincal::ParamId::parse(g, 6).unwrap().is_length()),
        "{gauge:?}"
    );
    for i in 0..KINCAL_MAX_PARAMS {
        assert!(!(out.report.gauge[i] != 0 && out.report.identify.analysis.identifiable[i] != 0));
    }
}

fn arg(e: &kincal_error) -> &str {
    assert!(!e.argument.is_null());
    unsafe { CStr::from_ptr(e.argument) }.to_str().unwrap()
}

#[test]
fn bad_rows_name_their_row() {
    let nominal = aria::nominal();
    let base = synthetic(&nominal, 21);
    let start = robot_of(&nominal);
    let opts = geometric_opts(&start);

    // A target with one row: drop all but the first contact of target 3.
    let mut rows = base.clone();
    let of3: Vec<usize> = (0..rows.n()).filter(|&l| rows.target[l] == 3).collect();
    for &l in &of3[1..] {
        rows.target[l] = 2;
    }
    let out = run(&start, &rows, &opts);
    assert_eq!(out.status, kincal_status::BadGroup);
    assert_eq!(arg(&out.err), "data->target");
    assert_eq!((out.err.index, out.err.pose), (3, of3[0]));
    assert_eq!((out.err.expected, out.err.found), (2, 1));

    // A distance naming an unknown target.
    let mut rows = base.clone();
    rows.distances[0].b = 42;
    let out = run(&start, &rows, &opts);
    assert_eq!(out.status, kincal_status::BadDistance);
    assert_eq!(
        (out.err.index, out.err.found, out.err.expected),
        (0, 42, 10)
    );

    // Collinear plane contacts: move every contact of plane 1 onto a line (the readings
    // of its first two contacts, alternately).
    let mut rows = base.clone();
    let of_p1: Vec<usize> = (0..rows.n()).filter(|&l| rows.plane[l] == 1).collect();
    for (k, &l) in of_p1.iter().enumerate().skip(2) {
        let src = of_p1[k % 2];
        let q: Vec<f64> = rows.q[6 * src..6 * src + 6].to_vec();
        rows.q[6 * l..6 * l + 6].copy_from_slice(&q);
    }
    let out = run(&start, &rows, &opts);
    assert_eq!(out.status, kincal_status::DegenerateGroup, "{:?}", out.err);
    assert_eq!(arg(&out.err), "data->plane");
    assert_eq!((out.err.index, out.err.pose), (1, of_p1[0]));

    // Coordinates and a target on one row.
    let mut rows = base.clone();
    let l = (0..rows.n()).find(|&l| rows.target[l] == 5).unwrap();
    rows.mask[l] = 0x7;
    let out = run(&start, &rows, &opts);
    assert_eq!(out.status, kincal_status::InvalidArgument);
    assert_eq!((arg(&out.err), out.err.pose), ("data->coord_mask", l));

    // A row that measures nothing.
    let mut rows = base.clone();
    let l = rows.n() - 1;
    rows.mask[l] = 0;
    let out = run(&start, &rows, &opts);
    assert_eq!(out.status, kincal_status::InvalidArgument);
    assert_eq!((arg(&out.err), out.err.pose), ("data->coord_mask", l));

    // A target in two sessions.
    let mut rows = base.clone();
    let of0: Vec<usize> = (0..rows.n()).filter(|&l| rows.target[l] == 0).collect();
    rows.session[of0[2]] = 1;
    let out = run(&start, &rows, &opts);
    assert_eq!(out.status, kincal_status::InvalidArgument);
    assert_eq!((arg(&out.err), out.err.pose), ("data->session", of0[2]));

    // A session with too few rows: a third session holding one instrument row.
    let mut rows = base.clone();
    rows.n_sessions = 3;
    let l = rows.n() - 1;
    for k in 0..rows.n() {
        if rows.mask[k] != 0 {
            rows.session[k] = 2;
        }
    }
    rows.session[l] = 2;
    let keep_three: Vec<usize> = (0..rows.n()).filter(|&k| rows.mask[k] != 0).collect();
    assert_eq!(keep_three.len(), 4);
    for &k in &keep_three[..3] {
        rows.mask[k] = 0;
        rows.target[k] = 9;
        rows.session[k] = 1;
    }
    let out = run(&start, &rows, &opts);
    assert_eq!(out.status, kincal_status::TooFewData, "{:?}", out.err);
    assert_eq!(
        (arg(&out.err), out.err.index, out.err.pose),
        ("data->session", 2, l)
    );

    // A session id beyond n_sessions.
    let mut rows = base.clone();
    rows.session[5] = 2;
    let out = run(&start, &rows, &opts);
    assert_eq!(out.status, kincal_status::IndexOutOfRange);
    assert_eq!(
        (arg(&out.err), out.err.pose, out.err.expected),
        ("data->session", 5, 2)
    );

    // A target id beyond n_targets.
    let mut rows = base.clone();
    rows.target[0] = 10;
    let out = run(&start, &rows, &opts);
    assert_eq!(out.status, kincal_status::IndexOutOfRange);
    assert_eq!(
        (arg(&out.err), out.err.pose, out.err.expected),
        ("data->target", 0, 10)
    );

    // A NaN reading: its row.
    let mut rows = base.clone();
    rows.q[6 * 7 + 2] = f64::NAN;
    let out = run(&start, &rows, &opts);
    assert_eq!(out.status, kincal_status::NonFinite);
    assert_eq!((arg(&out.err), out.err.pose), ("data->q", 7));
}

#[test]
fn the_workspace_is_checked_before_use() {
    let nominal = aria::nominal();
    let rows = synthetic(&nominal, 31);
    let start = robot_of(&nominal);
    let opts = geometric_opts(&start);
    let n_req = opts.requested.iter().filter(|&&m| m != 0).count();
    let size = kincal_identify_constraints_workspace_size(6, rows.n(), 10, 2, 1, 2, n_req);
    assert!(size > 0);
    assert_eq!(
        kincal_identify_constraints_workspace_size(0, 10, 1, 0, 0, 0, 5),
        0
    );
    assert_eq!(
        kincal_identify_constraints_workspace_size(6, 10, 1, 0, 0, 0, 500),
        0
    );
    assert_eq!(
        kincal_identify_constraints_workspace_size(6, usize::MAX / 2, 1, 0, 0, 0, 5),
        0
    );
    let mut ws = vec![0u128; size.div_ceil(16)];
    let data = rows.view();
    let mut out = kincal_robot::ZERO;
    let mut err = kincal_error::CLEAR;
    let s = unsafe {
        kincal_identify_constraints(
            &start,
            &data,
            &opts,
            ws.as_mut_ptr().cast(),
            size - 1,
            &mut out,
            null_mut(),
            null_mut(),
            0,
            null_mut(),
            0,
            null_mut(),
            0,
            &mut err,
        )
    };
    assert_eq!(s, kincal_status::BadLength);
    assert_eq!(
        (arg(&err), err.expected, err.found),
        ("workspace", size, size - 1)
    );
    // Misaligned.
    let s = unsafe {
        kincal_identify_constraints(
            &start,
            &data,
            &opts,
            ws.as_mut_ptr().cast::<u8>().add(8).cast(),
            size,
            &mut out,
            null_mut(),
            null_mut(),
            0,
            null_mut(),
            0,
            null_mut(),
            0,
            &mut err,
        )
    };
    assert_eq!(s, kincal_status::MisalignedPointer);
    // An estimate buffer of the wrong length.
    let mut t = vec![kincal_group_estimate::default(); 3];
    let s = unsafe {
        kincal_identify_constraints(
            &start,
            &data,
            &opts,
            ws.as_mut_ptr().cast(),
            size,
            &mut out,
            null_mut(),
            t.as_mut_ptr(),
            3,
            null_mut(),
            0,
            null_mut(),
            0,
            &mut err,
        )
    };
    assert_eq!(s, kincal_status::BadLength);
    assert_eq!((arg(&err), err.expected, err.found), ("targets_out", 10, 3));
}
