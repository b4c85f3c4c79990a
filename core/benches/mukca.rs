//! Criterion benchmark of instrument-free calibration on real data: every MUKCa Franka
//! Panda recording with the set's `panda.urdf` (MUKCa, ../shared/realdata/mukca; read from
//! there, never copied; `KINCAL_REALDATA` overrides the folder). Each location is a placement
//! of the two-socket plate: two targets, their contacts (`hole_0.csv`, `hole_1.csv`, rad),
//! one known distance of 50 mm. Fitted as `kincal calibrate --constraints` does: OLS from
//! the nominal model, every geometric parameter and the ball centre (tool translation),
//! identifiability analysis and covariance included.
//!
//! Two figures: `panda_2` alone (the largest recording: 9 locations, 18 sockets, 559
//! contacts), and all eleven `panda.urdf` recordings one after another (43 locations, 86
//! sockets, 2,720 contacts; `panda_1_with_sensor` has another tool and URDF), each fitted
//! on its own (they are different arms). Issue #13's target: all Panda locations in under
//! 50 ms. Without the data folder the bench says so and measures nothing.
//!
//! The robot is built here from the URDF's joint origins (copied below from `panda.urdf`,
//! checked by the printed nominal and calibrated scatter against docs/real-data.md), so the
//! bench needs no URDF reader (that is `kincal-io`'s, which depends on this crate).

use criterion::{Criterion, criterion_group, criterion_main};
use kincal::axis_chain::{AxisChain, JointAxis};
use kincal::identify::{
    Algorithm, ConstraintData, Contact, Distance, Group, GroupKind, Identification,
    IdentifyOptions, Workspace, identify_constrained,
};
use kincal::params::num_params;
use kincal::{JointLimits, Robot, Transform};
use nalgebra::{Rotation3, Translation3, Vector3};
use std::hint::black_box;
use std::path::{Path, PathBuf};

/// Workspace capacity: every parameter of a 7-joint model.
const P: usize = num_params(7);

/// The Panda recordings calibrated with `panda.urdf` (MUKCa's data folders).
const PANDAS: &[&str] = &[
    "panda_1",
    "panda_2",
    "panda_2_clean",
    "panda_3",
    "panda_3_bis",
    "panda_4",
    "panda_4_clean",
    "panda_6",
    "panda_7",
    "panda_left",
    "panda_right",
];

/// `panda.urdf`'s joint origins (xyz [m], rpy [rad]) of joints 1..7, then the fixed chain
/// to `ball_link`: flange (joint 8), hand (−45° yaw), TCP, ball centre.
const JOINTS: [([f64; 3], [f64; 3]); 7] = [
    ([0.0, 0.0, 0.333], [0.0, 0.0, 0.0]),
    ([0.0, 0.0, 0.0], [-core::f64::consts::FRAC_PI_2, 0.0, 0.0]),
    ([0.0, -0.316, 0.0], [core::f64::consts::FRAC_PI_2, 0.0, 0.0]),
    ([0.0825, 0.0, 0.0], [core::f64::consts::FRAC_PI_2, 0.0, 0.0]),
    (
        [-0.0825, 0.384, 0.0],
        [-core::f64::consts::FRAC_PI_2, 0.0, 0.0],
    ),
    ([0.0, 0.0, 0.0], [core::f64::consts::FRAC_PI_2, 0.0, 0.0]),
    ([0.088, 0.0, 0.0], [core::f64::consts::FRAC_PI_2, 0.0, 0.0]),
];
const TIP: [([f64; 3], [f64; 3]); 4] = [
    ([0.0, 0.0, 0.107], [0.0, 0.0, 0.0]),
    ([0.0, 0.0, 0.0], [0.0, 0.0, -core::f64::consts::FRAC_PI_4]),
    ([0.0, 0.0, 0.1034], [0.0, 0.0, 0.0]),
    (
        [
            7.773_732_033_005_863e-5,
            -4.214_022_515_884_392e-5,
            0.030_128_297_908_475_325,
        ],
        [0.0, 0.0, 0.0],
    ),
];

fn origin((xyz, rpy): ([f64; 3], [f64; 3])) -> Transform {
    Transform::from_parts(
        Translation3::new(xyz[0], xyz[1], xyz[2]),
        Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}

/// The nominal Panda with the ball centre as its tool origin (URDF joint axes are z).
fn panda() -> Robot<7> {
    let mut t = Transform::identity();
    let mut axes = [JointAxis::new([0.0; 3], [0.0, 0.0, 1.0]); 7];
    for (axis, j) in axes.iter_mut().zip(JOINTS) {
        t *= origin(j);
        let (p, u) = (t.translation.vector, t.rotation * Vector3::z());
        *axis = JointAxis::new([p.x, p.y, p.z], [u.x, u.y, u.z]);
    }
    for f in TIP {
        t *= origin(f);
    }
    let chain = AxisChain {
        t_ref_base: Transform::identity(),
        axes,
        t_ref_tool: t,
    };
    chain
        .to_robot([JointLimits::new(-10.0, 10.0); 7])
        .expect("panda")
}

fn realdata() -> PathBuf {
    std::env::var_os("KINCAL_REALDATA").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/realdata"),
        PathBuf::from,
    )
}

/// One robot's contacts (locations in name order, socket 0 then 1), sockets, distances.
struct Recording {
    name: &'static str,
    contacts: Vec<Contact<7>>,
    groups: Vec<Group>,
    distances: Vec<Distance>,
}

fn read_hole(path: &Path) -> Vec<Contact<7>> {
    let text = std::fs::read_to_string(path).expect("hole file");
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let mut q = [0.0; 7];
            for (v, cell) in q.iter_mut().zip(l.split(',')) {
                *v = cell.trim().parse().expect("joint reading");
            }
            Contact::new(q)
        })
        .collect()
}

fn recording(root: &Path, name: &'static str) -> Recording {
    let dir = root.join("mukca/data").join(name);
    let mut locations: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("robot folder")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    locations.sort();
    let mut r = Recording {
        name,
        contacts: Vec::new(),
        groups: Vec::new(),
        distances: Vec::new(),
    };
    for loc in locations {
        for hole in ["hole_0.csv", "hole_1.csv"] {
            let c = read_hole(&loc.join(hole));
            r.groups.push(Group {
                kind: GroupKind::Target,
                start: r.contacts.len(),
                len: c.len(),
            });
            r.contacts.extend(c);
        }
        let b = r.groups.len() - 1;
        r.distances.push(Distance {
            a: b - 1,
            b,
            m: 0.050,
            weight: 1.0,
        });
    }
    r
}

impl Recording {
    fn view(&self) -> ConstraintData<'_, 7> {
        ConstraintData {
            instrument: &[],
            contacts: &self.contacts,
            groups: &self.groups,
            distances: &self.distances,
            sessions: &[],
        }
    }
}

fn calibrate(
    nominal: &Robot<7>,
    r: &Recording,
    opts: &IdentifyOptions<'_>,
    ws: &mut Workspace<P>,
) -> Identification<7> {
    identify_constrained(nominal, &r.view(), opts, ws).expect("identify")
}

fn bench(c: &mut Criterion) {
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
    let panda_2 = recordings
        .iter()
        .find(|r| r.name == "panda_2")
        .expect("panda_2");
    c.bench_function("mukca/panda_2_all_locations", |b| {
        b.iter(|| calibrate(black_box(&nominal), panda_2, &opts, &mut ws))
    });
    // Seconds per iteration: ten samples are enough.
    let mut group = c.benchmark_group("mukca");
    group.sample_size(10);
    group.bench_function("all_11_panda_recordings", |b| {
        b.iter(|| {
            for r in &recordings {
                black_box(calibrate(black_box(&nominal), r, &opts, &mut ws));
            }
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
