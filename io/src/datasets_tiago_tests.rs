//! The TIAGo import on a TIAGo-like robot the test builds itself (PAL's URDF is not shipped):
//! a mobile base (fixed to the footprint, with continuous wheel joints on side branches), a
//! fixed torso column, the prismatic torso lift, a 2-joint head branch, a 7R arm with a fixed
//! joint folded in mid-arm, a tool link and a gripper branch whose right finger mimics the
//! left. Synthetic rows are written in the set's own file layout from the test's own 4×4
//! chain (its own RPY and Rodrigues matrices, not the importer's code).

use std::collections::HashMap;
use std::fmt::Write as _;

use kincal::any::AnyRobot;
use kincal::identify::{Algorithm, ComponentMask, IdentifyOptions, Measurement, analyze, identify};
use kincal::pose::Transform;
use kincal::{Effect, EffectSet};
use nalgebra::{Matrix3, Matrix4, Vector3, Vector4};

use super::*;

#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Fixed,
    Revolute,
    Continuous,
    Prismatic,
}

/// One URDF joint of the test robot.
#[derive(Clone)]
struct TJoint {
    name: &'static str,
    kind: Kind,
    parent: &'static str,
    child: &'static str,
    xyz: [f64; 3],
    rpy: [f64; 3],
    axis: [f64; 3],
    limits: (f64, f64),
    mimic: Option<&'static str>,
}

#[allow(clippy::too_many_arguments)]
fn tj(
    name: &'static str,
    kind: Kind,
    parent: &'static str,
    child: &'static str,
    xyz: [f64; 3],
    rpy: [f64; 3],
    axis: [f64; 3],
    limits: (f64, f64),
) -> TJoint {
    TJoint {
        name,
        kind,
        parent,
        child,
        xyz,
        rpy,
        axis,
        limits,
        mimic: None,
    }
}

const H: f64 = std::f64::consts::FRAC_PI_2;
const Z: [f64; 3] = [0.0, 0.0, 1.0];
const R0: [f64; 3] = [0.0; 3];
const ARM: (f64, f64) = (-2.5, 2.5);

/// The TIAGo-like tree (made-up numbers of TIAGo's size, not PAL's file).
// Long by design: a data table, one entry per joint of the tree.
fn robot_joints() -> Vec<TJoint> {
    use Kind::*;
    let mut j = vec![
        tj(
            "base_footprint_joint",
            Fixed,
            "base_footprint",
            "base_link",
            [0.0, 0.0, 0.0985],
            R0,
            Z,
            (0.0, 0.0),
        ),
        tj(
            "wheel_left_joint",
            Continuous,
            "base_link",
            "wheel_left_link",
            [0.0, 0.2, 0.0],
            [-H, 0.0, 0.0],
            Z,
            (0.0, 0.0),
        ),
        tj(
            "wheel_right_joint",
            Continuous,
            "base_link",
            "wheel_right_link",
            [0.0, -0.2, 0.0],
            [-H, 0.0, 0.0],
            Z,
            (0.0, 0.0),
        ),
        tj(
            "torso_fixed_joint",
            Fixed,
            "base_link",
            "torso_fixed_link",
            [-0.062, 0.0, 0.193],
            R0,
            Z,
            (0.0, 0.0),
        ),
        tj(
            "torso_lift_joint",
            Prismatic,
            "torso_fixed_link",
            "torso_lift_link",
            [0.0, 0.0, 0.597],
            R0,
            Z,
            (0.0, 0.35),
        ),
        tj(
            "head_1_joint",
            Revolute,
            "torso_lift_link",
            "head_1_link",
            [0.182, 0.0, 0.0],
            R0,
            Z,
            (-1.2, 1.2),
        ),
        tj(
            "head_2_joint",
            Revolute,
            "head_1_link",
            "head_2_link",
            [0.005, 0.0, 0.098],
            [H, 0.0, 0.0],
            Z,
            (-1.0, 0.7),
        ),
        tj(
            "arm_1_joint",
            Revolute,
            "torso_lift_link",
            "arm_1_link",
            [0.155, 0.014, -0.151],
            [0.0, 0.0, -H],
            Z,
            (0.0, 2.7),
        ),
        tj(
            "arm_2_joint",
            Revolute,
            "arm_1_link",
            "arm_2_link",
            [0.125, 0.0195, -0.031],
            [H, 0.0, 0.0],
            Z,
            (-1.5, 1.0),
        ),
        tj(
            "arm_3_joint",
            Revolute,
            "arm_2_link",
            "arm_3_link",
            [0.0895, 0.0, -0.0015],
            [-H, 0.0, H],
            Z,
            (-3.4, 1.5),
        ),
        tj(
            "arm_4_joint",
            Revolute,
            "arm_3_link",
            "arm_4_link",
            [-0.02, -0.027, -0.222],
            [-H, -H, 0.0],
            Z,
            (-0.3, 2.3),
        ),
        tj(
            "arm_4_cover_joint",
            Fixed,
            "arm_4_link",
            "arm_4_cover_link",
            [-0.081, 0.01, 0.0135],
            [0.0, 0.0, 0.3],
            Z,
            (0.0, 0.0),
        ),
        tj(
            "arm_5_joint",
            Revolute,
            "arm_4_cover_link",
            "arm_5_link",
            [-0.081, 0.01, 0.0135],
            [0.0, -H, -0.3],
            Z,
            (-2.0, 2.0),
        ),
        tj(
            "arm_6_joint",
            Revolute,
            "arm_5_link",
            "arm_6_link",
            [0.0, 0.0, 0.15],
            [-H, -H, 0.0],
            Z,
            (-1.4, 1.4),
        ),
        tj(
            "arm_7_joint",
            Revolute,
            "arm_6_link",
            "arm_7_link",
            [0.0, 0.0, 0.0],
            [H, 0.0, H],
            Z,
            ARM,
        ),
        tj(
            "arm_tool_joint",
            Fixed,
            "arm_7_link",
            "arm_tool_link",
            [0.0, 0.0, 0.046],
            [H, -H, H],
            Z,
            (0.0, 0.0),
        ),
        tj(
            "gripper_joint",
            Fixed,
            "arm_tool_link",
            "gripper_link",
            [0.01, 0.0, 0.0],
            [0.0, 0.0, -H],
            Z,
            (0.0, 0.0),
        ),
        tj(
            "gripper_left_finger_joint",
            Prismatic,
            "gripper_link",
            "gripper_left_finger_link",
            [0.0, 0.0, 0.0],
            R0,
            [1.0, 0.0, 0.0],
            (0.0, 0.045),
        ),
        tj(
            "gripper_right_finger_joint",
            Prismatic,
            "gripper_link",
            "gripper_right_finger_link",
            [0.0, 0.0, 0.0],
            R0,
            [-1.0, 0.0, 0.0],
            (0.0, 0.045),
        ),
    ];
    if let Some(r) = j
        .iter_mut()
        .find(|j| j.name == "gripper_right_finger_joint")
    {
        r.mimic = Some("gripper_left_finger_joint");
    }
    j
}

fn urdf_text(joints: &[TJoint]) -> String {
    let mut links: Vec<&str> = vec!["base_footprint"];
    links.extend(joints.iter().map(|j| j.child));
    let mut s = String::from("<?xml version=\"1.0\"?>\n<robot name=\"tiago_like\">\n");
    for l in &links {
        let _ = writeln!(s, "  <link name=\"{l}\"/>");
    }
    for j in joints {
        let kind = match j.kind {
            Kind::Fixed => "fixed",
            Kind::Revolute => "revolute",
            Kind::Continuous => "continuous",
            Kind::Prismatic => "prismatic",
        };
        let v = |a: [f64; 3]| format!("{:?} {:?} {:?}", a[0], a[1], a[2]);
        let _ = writeln!(s, "  <joint name=\"{}\" type=\"{kind}\">", j.name);
        let _ = writeln!(
            s,
            "    <parent link=\"{}\"/>\n    <child link=\"{}\"/>\n    <origin xyz=\"{}\" rpy=\"{}\"/>",
            j.parent,
            j.child,
            v(j.xyz),
            v(j.rpy)
        );
        if j.kind != Kind::Fixed {
            let _ = writeln!(s, "    <axis xyz=\"{}\"/>", v(j.axis));
        }
        if matches!(j.kind, Kind::Revolute | Kind::Prismatic) {
            let _ = writeln!(
                s,
                "    <limit lower=\"{:?}\" upper=\"{:?}\" effort=\"10\" velocity=\"1\"/>",
                j.limits.0, j.limits.1
            );
        }
        if let Some(m) = j.mimic {
            let _ = writeln!(
                s,
                "    <mimic joint=\"{m}\" multiplier=\"1\" offset=\"0\"/>"
            );
        }
        s.push_str("  </joint>\n");
    }
    s.push_str("</robot>\n");
    s
}

/// The test's own rotation from URDF roll, pitch, yaw: Rz(y)·Ry(p)·Rx(r).
fn rpy_matrix([r, p, y]: [f64; 3]) -> Matrix3<f64> {
    let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, r.cos(), -r.sin(), 0.0, r.sin(), r.cos());
    let ry = Matrix3::new(p.cos(), 0.0, p.sin(), 0.0, 1.0, 0.0, -p.sin(), 0.0, p.cos());
    let rz = Matrix3::new(y.cos(), -y.sin(), 0.0, y.sin(), y.cos(), 0.0, 0.0, 0.0, 1.0);
    rz * ry * rx
}

/// Rodrigues: rotation by `angle` about the unit vector `k`.
fn rodrigues(k: Vector3<f64>, angle: f64) -> Matrix3<f64> {
    let kx = Matrix3::new(0.0, -k.z, k.y, k.z, 0.0, -k.x, -k.y, k.x, 0.0);
    Matrix3::identity() + kx * angle.sin() + kx * kx * (1.0 - angle.cos())
}

fn homogeneous(r: Matrix3<f64>, p: Vector3<f64>) -> Matrix4<f64> {
    let mut m = Matrix4::identity();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(&p);
    m
}

/// The test's own FK: the 4×4 product from `base` down to `tip` (found by walking up from
/// the tip), joint values by name (0 for joints not given).
fn chain_fk(joints: &[TJoint], base: &str, tip: &str, q: &HashMap<&str, f64>) -> Matrix4<f64> {
    let mut path = Vec::new();
    let mut link = tip;
    while link != base {
        let j = joints
            .iter()
            .find(|j| j.child == link)
            .expect("tip below base");
        path.push(j);
        link = j.parent;
    }
    path.reverse();
    let mut t = Matrix4::identity();
    for j in path {
        t *= homogeneous(rpy_matrix(j.rpy), Vector3::from(j.xyz));
        let v = q.get(j.name).copied().unwrap_or(0.0);
        let k = Vector3::from(j.axis).normalize();
        t *= match j.kind {
            Kind::Fixed => Matrix4::identity(),
            Kind::Revolute | Kind::Continuous => homogeneous(rodrigues(k, v), Vector3::zeros()),
            Kind::Prismatic => homogeneous(Matrix3::identity(), k * v),
        };
    }
    t
}

/// The motion-capture frame's pose of `base_footprint` (unknown to the import).
fn mocap_base() -> Matrix4<f64> {
    homogeneous(
        rpy_matrix([0.03, -0.02, 0.05]),
        Vector3::new(0.09, 0.08, -0.03),
    )
}

/// The hand's four points in `arm_7_link` (3 and 4 identical, as in the real file).
const MARKERS: [[f64; 3]; 4] = [
    [0.02, 0.03, 0.21],
    [-0.05, 0.01, 0.16],
    [0.03, -0.04, 0.12],
    [0.03, -0.04, 0.12],
];

/// A small deterministic generator (SplitMix64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn within(&mut self, (lo, hi): (f64, f64)) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

/// `n` random readings in [`JOINTS`] order within the test robot's limits.
fn random_q(joints: &[TJoint], n: usize, seed: u64) -> Vec<[f64; 8]> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| {
            std::array::from_fn(|k| {
                let j = joints.iter().find(|j| j.name == JOINTS[k]).unwrap();
                rng.within(j.limits)
            })
        })
        .collect()
}

/// The hand's points in the motion-capture frame for reading `q` of `joints`.
fn points(joints: &[TJoint], q: &[f64; 8]) -> [[f64; 3]; 4] {
    let qm: HashMap<&str, f64> = JOINTS.iter().copied().zip(q.iter().copied()).collect();
    let t = mocap_base() * chain_fk(joints, "base_footprint", "arm_7_link", &qm);
    MARKERS.map(|m| {
        let p = t * Vector4::new(m[0], m[1], m[2], 1.0);
        [p.x, p.y, p.z]
    })
}

/// The set's CSV layout (x1..z4, torso_lift_joint, arm_1..7_joint), every digit kept.
fn csv_text(joints: &[TJoint], qs: &[[f64; 8]]) -> String {
    let mut s = String::new();
    let cols: Vec<String> = (1..=4)
        .flat_map(|k| ["x", "y", "z"].map(|c| format!("{c}{k}")))
        .chain(JOINTS.iter().map(|j| (*j).to_string()))
        .collect();
    s.push_str(&cols.join(","));
    s.push('\n');
    for q in qs {
        let cells: Vec<String> = points(joints, q)
            .iter()
            .flatten()
            .chain(q.iter())
            .map(|v| format!("{v:?}"))
            .collect();
        s.push_str(&cells.join(","));
        s.push('\n');
    }
    s
}

/// A set folder with the CSV of `truth` and `urdf_of` written as URDF; returns (dir, urdf).
fn set_folder(
    truth: &[TJoint],
    urdf_of: &[TJoint],
    qs: &[[f64; 8]],
) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join(CSV_FILE), csv_text(truth, qs)).unwrap();
    let urdf = dir.path().join("tiago_like.urdf");
    std::fs::write(&urdf, urdf_text(urdf_of)).unwrap();
    (dir, urdf)
}

fn j8(robot: &AnyRobot) -> kincal::Robot<8> {
    match robot {
        AnyRobot::J8(r) => *r,
        _ => panic!("expected 8 joints (torso lift + 7R)"),
    }
}

fn to_m4(t: &Transform) -> Matrix4<f64> {
    t.to_homogeneous()
}

#[test]
fn import_gives_the_rows_and_a_model_equal_to_the_tests_own_chain() {
    let joints = robot_joints();
    let qs = random_q(&joints, 35, 7);
    let (dir, urdf) = set_folder(&joints, &joints, &qs);
    let imp = import(dir.path(), Some(&urdf), &UrdfChainArgs::default()).unwrap();
    assert_eq!(imp.robot.joint_names, JOINTS);
    assert_eq!(imp.set.rows.len(), 35);
    assert_eq!(imp.set.extra_columns.len(), 9);
    let robot = j8(&imp.robot.robot);
    assert_eq!(robot.joint_kinds()[0], kincal::JointKind::Prismatic);
    let mut worst: f64 = 0.0;
    for (r, q) in imp.set.rows.iter().zip(&qs) {
        // The row is the file's: joints in chain order, point 1, points 2..4 as extras.
        assert_eq!(r.q_rad, q.to_vec());
        let p = points(&joints, q);
        assert_eq!(r.position_m, Some(p[0]));
        let extras: Vec<f64> = r.extras.iter().map(|e| e.parse().unwrap()).collect();
        assert_eq!(extras, p[1..].iter().flatten().copied().collect::<Vec<_>>());
        // The imported model's FK (base_footprint -> arm_7_link) times the test's own base
        // and marker equals the row's point.
        let t = mocap_base() * to_m4(&robot.fk_q(q).unwrap());
        let m = MARKERS[0];
        let mp = t * Vector4::new(m[0], m[1], m[2], 1.0);
        for (a, b) in [mp.x, mp.y, mp.z].iter().zip(&p[0]) {
            worst = worst.max((a - b).abs());
        }
    }
    assert!(worst < 1e-12, "model vs the test's own chain: {worst:e} m");
    // The notes say what the rows are and what the rigid-body check found.
    assert!(
        imp.notes.iter().any(|n| n.contains("identical in 35 rows")),
        "{:?}",
        imp.notes
    );
    // The CSV comments name both source files with their SHA-256.
    let src: Vec<&String> = imp
        .set
        .comments
        .iter()
        .filter(|c| c.contains("sha256"))
        .collect();
    assert_eq!(src.len(), 2, "{:?}", imp.set.comments);
}

/// Planted errors in every arm and torso origin and in the torso's axis: calibrating the
/// nominal import (base and tool frames unknown) on noise-free rows of the erroneous robot
/// predicts new poses of it to 1e-9 m, from a nominal error of centimetres.
#[test]
fn calibration_recovers_planted_errors() {
    let nominal = robot_joints();
    let mut truth = nominal.clone();
    let mut rng = Rng(99);
    for j in truth.iter_mut() {
        if JOINTS.contains(&j.name) || j.name == "arm_4_cover_joint" {
            for v in j.xyz.iter_mut() {
                *v += rng.within((-3e-3, 3e-3));
            }
            for v in j.rpy.iter_mut() {
                *v += rng.within((-5e-3, 5e-3));
            }
        }
        if j.name == "torso_lift_joint" {
            j.axis = [0.01, -0.008, 1.0];
        }
    }
    let qs = random_q(&nominal, 60, 11);
    let (dir, urdf) = set_folder(&truth, &nominal, &qs);
    let imp = import(dir.path(), Some(&urdf), &UrdfChainArgs::default()).unwrap();
    let start = j8(&imp.robot.robot);
    let nominal_robot = start;
    let meas: Vec<Measurement<8>> = imp
        .set
        .rows
        .iter()
        .map(|r| {
            let q: [f64; 8] = r.q_rad.clone().try_into().unwrap();
            let p = r.position_m.unwrap();
            let pose = Transform::from_parts(
                nalgebra::Translation3::new(p[0], p[1], p[2]),
                nalgebra::Rotation3::identity(),
            );
            let mut m = Measurement::new(q, pose);
            m.mask = ComponentMask::POSITION;
            m
        })
        .collect();
    // As `calibrate --init-frames` does: base and tool frames estimated first (the nominal
    // tool origin lies on the last axis, where the analysis would find its angle invisible).
    let (start, _) = crate::calibration::init_frames(&start, &meas, "tiago-like").unwrap();
    let set = start.param_set(EffectSet::of(Effect::BaseFrame).with(Effect::ToolFrame));
    let mut ws = crate::calibration::new_workspace();
    let mut opts = IdentifyOptions::new(Algorithm::Ols, set);
    opts.allow_data_deficiency = true;
    let a = analyze(&start, &meas, &opts, &mut ws).unwrap();
    let mut opts = IdentifyOptions::new(Algorithm::Ols, a.identifiable);
    opts.allow_data_deficiency = true;
    opts.max_iterations = 200;
    opts.xtol = 1e-14;
    opts.ftol = 1e-16;
    let id = identify(&start, &meas, &opts, &mut ws).unwrap();
    // Everett's count for a complete model, 4R + 2P + 6, less the 3 tool angles one point
    // cannot see: 4·7 + 2 + 6 − 3 = 33.
    assert_eq!(a.identifiable.len(), 33, "{:?}", a.structural);
    assert!(id.fitted.max_pos_m < 1e-9, "in-sample: {:?}", id.fitted);
    let fit = id.robot;
    // Held out: new readings of the erroneous robot.
    let (mut before, mut after): (f64, f64) = (0.0, 0.0);
    for q in random_q(&nominal, 40, 12) {
        let p = points(&truth, &q)[0];
        // The nominal model in the true base frame with the true marker, against the fit.
        let m = MARKERS[0];
        let nom = mocap_base()
            * to_m4(&nominal_robot.fk_q(&q).unwrap())
            * Vector4::new(m[0], m[1], m[2], 1.0);
        before = before.max((nom.xyz() - Vector3::from(p)).norm());
        let v = fit.fk_q(&q).unwrap().translation.vector;
        after = after.max((v - Vector3::from(p)).norm());
    }
    eprintln!("tiago-like held out: nominal {before:e} m, calibrated {after:e} m");
    assert!(
        before > 5e-3,
        "the planted errors should show: {before:e} m"
    );
    assert!(
        after < 1e-9,
        "held-out after calibration: {after:e} m (before {before:e} m)"
    );
}

#[test]
fn refusals_name_what_is_missing() {
    let joints = robot_joints();
    let qs = random_q(&joints, 5, 1);
    let (dir, urdf) = set_folder(&joints, &joints, &qs);
    // No URDF: a usage error saying where to get it.
    let e = import(dir.path(), None, &UrdfChainArgs::default()).unwrap_err();
    assert_eq!(e.kind, crate::error::Kind::Usage);
    assert!(e.message.contains("tiago_description") && e.message.contains("CC BY-NC-ND"));
    // A chain that leaves out the torso lift.
    let chain = UrdfChainArgs {
        base_link: Some("torso_lift_link".into()),
        tip_link: None,
    };
    let e = import(dir.path(), Some(&urdf), &chain).unwrap_err();
    assert!(
        e.message.contains("leaves out 'torso_lift_joint'"),
        "{}",
        e.message
    );
    // A chain through a joint the set does not record (the head).
    let chain = UrdfChainArgs {
        base_link: None,
        tip_link: Some("head_2_link".into()),
    };
    let e = import(dir.path(), Some(&urdf), &chain).unwrap_err();
    assert!(e.message.contains("'head_1_joint'"), "{}", e.message);
    // A link that does not exist: the URDF importer's error.
    let chain = UrdfChainArgs {
        base_link: None,
        tip_link: Some("gripper_tool_link".into()),
    };
    let e = import(dir.path(), Some(&urdf), &chain).unwrap_err();
    assert_eq!(e.kind, crate::error::Kind::Input);
    assert!(e.message.contains("gripper_tool_link"), "{}", e.message);
    // A tip further down (through fixed joints) still moves exactly the recorded joints.
    let chain = UrdfChainArgs {
        base_link: None,
        tip_link: Some("gripper_link".into()),
    };
    assert!(import(dir.path(), Some(&urdf), &chain).is_ok());
    // A bad cell names file, line and column.
    let csv = dir.path().join(CSV_FILE);
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let first = lines[2].split_once(',').unwrap().1.to_string();
    lines[2] = format!("x,{first}");
    let text = lines.join("\n");
    std::fs::write(&csv, text).unwrap();
    let e = import(dir.path(), Some(&urdf), &UrdfChainArgs::default()).unwrap_err();
    assert!(e.message.contains(":3: column 'x1'"), "{}", e.message);
}

/// The published file (if ../shared holds it) parses in its own layout without a URDF.
#[test]
fn the_real_file_parses() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/realdata/figaroh-tiago-mocap")
        .join(CSV_FILE);
    if !path.is_file() {
        eprintln!("skipping: {} not found", path.display());
        return;
    }
    let rows = read_rows(&path).unwrap();
    assert_eq!(rows.len(), 35);
    assert!(rows.iter().all(|r| r.points_m[2] == r.points_m[3]));
    let (lo, hi) = rows
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| {
            (lo.min(r.q[0]), hi.max(r.q[0]))
        });
    assert!(
        (0.0..0.05).contains(&lo) && (0.3..0.36).contains(&hi),
        "{lo} {hi}"
    );
    assert!(rows.iter().all(|r| r.q[1..].iter().all(|v| v.abs() < 3.2)));
    assert_eq!(rows[0].line, 2);
}
