//! MUKCa's Franka Panda recordings (../shared/realdata/mukca, read from there, never
//! copied; `KINCAL_REALDATA` overrides the folder) as constraint data, shared by the
//! `mukca` bench and the convergence test: every location a plate placement with two
//! sockets (`hole_0.csv`, `hole_1.csv`, rad) 50 mm apart. The Panda is built from
//! `panda.urdf`'s joint origins (copied below), so no URDF reader is needed here.

#![allow(dead_code)]

use kincal::axis_chain::{AxisChain, JointAxis};
use kincal::identify::{ConstraintData, Contact, Distance, Group, GroupKind};
use kincal::params::num_params;
use kincal::{JointLimits, Robot, Transform};
use nalgebra::{Rotation3, Translation3, Vector3};
use std::path::{Path, PathBuf};

/// Workspace capacity: every parameter of a 7-joint model.
pub const P: usize = num_params(7);

/// The Panda recordings calibrated with `panda.urdf` (MUKCa's data folders).
pub const PANDAS: &[&str] = &[
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
pub fn panda() -> Robot<7> {
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

pub fn realdata() -> PathBuf {
    std::env::var_os("KINCAL_REALDATA").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/realdata"),
        PathBuf::from,
    )
}

/// The data folder when MUKCa is there; `None` (and a note on stderr) when a test should
/// skip.
pub fn root_or_skip() -> Option<PathBuf> {
    let root = realdata();
    if root.join("mukca/data").is_dir() {
        Some(root)
    } else {
        eprintln!("MUKCa not found under {}: skipped", root.display());
        None
    }
}

/// The geometry and the ball centre (tool translation) of `nominal`, as `kincal
/// calibrate` requests them on contact data.
pub fn geometry_and_ball(nominal: &Robot<7>) -> kincal::params::ParamSet {
    let mut requested = nominal.geometric_param_set();
    for k in 0..3 {
        requested.insert(5 * 7 + 6 + k).expect("tool translation");
    }
    requested
}

/// One robot's contacts (locations in name order, socket 0 then 1), sockets, distances.
pub struct Recording {
    pub name: &'static str,
    pub contacts: Vec<Contact<7>>,
    pub groups: Vec<Group>,
    pub distances: Vec<Distance>,
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

pub fn recording(root: &Path, name: &'static str) -> Recording {
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
    pub fn view(&self) -> ConstraintData<'_, 7> {
        ConstraintData {
            instrument: &[],
            contacts: &self.contacts,
            groups: &self.groups,
            distances: &self.distances,
            sessions: &[],
        }
    }
}
