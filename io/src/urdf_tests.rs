//! URDF import/export tests. The reference FK is computed here directly from the URDF:
//! `T = Π origin_j · Rot(axis_j, q_j)` along the chain, independent of the mDH conversion.

use std::f64::consts::PI;
use std::path::PathBuf;

use kincal::any::AnyRobot;
use kincal::pose::Transform;
use kincal::with_any_robot;
use nalgebra::{Matrix3, Rotation3, Translation3, Vector3};

use super::*;

/// FK agreement [m] and [1] (rotation-matrix entries).
const FK_TOL: f64 = 1e-12;

/// `shared/realdata`: `$KINCAL_REALDATA`, else the first `shared/realdata` found beside
/// the workspace or above it (CI clones the repository with `shared/` beside it). Missing
/// data fail the test under `CI=true` and skip it (with a message) otherwise.
fn realdata() -> Option<PathBuf> {
    if let Ok(p) = std::env::var("KINCAL_REALDATA") {
        return Some(PathBuf::from(p));
    }
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let found = root
        .ancestors()
        .skip(1)
        .map(|a| a.join("shared/realdata"))
        .find(|p| p.is_dir());
    if found.is_none() {
        let msg = format!(
            "shared/realdata not found beside or above {} (set KINCAL_REALDATA)",
            root.display()
        );
        if std::env::var("CI").is_ok_and(|v| v == "true") {
            panic!("{msg}");
        }
        eprintln!("SKIPPED: {msg}");
    }
    found
}

struct Rng(u64);
impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }
    fn pick(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }
}

/// Direct URDF FK of the chain `path` (every joint on it), revolute values from `q`.
fn urdf_fk(path: &[&urdf_rs::Joint], q: &[f64]) -> Transform {
    let mut t = Transform::identity();
    let mut k = 0;
    for j in path {
        let o = &j.origin;
        let rpy = o.rpy.0;
        let r = Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]);
        t *= Transform::from_parts(Translation3::new(o.xyz[0], o.xyz[1], o.xyz[2]), r);
        if matches!(j.joint_type, JointType::Revolute | JointType::Continuous) {
            let axis = Vector3::from(j.axis.xyz.0).normalize();
            t *= Transform::from_parts(
                Translation3::identity(),
                Rotation3::from_scaled_axis(axis * q[k]),
            );
            k += 1;
        }
    }
    t
}

fn max_diff(a: &Transform, b: &Transform) -> f64 {
    (a.translation.vector - b.translation.vector)
        .amax()
        .max((a.rotation.matrix() - b.rotation.matrix()).amax())
}

fn model_fk(robot: &AnyRobot, q: &[f64]) -> Transform {
    with_any_robot!(robot, r => {
        let mut a = [0.0; 8];
        a[..q.len()].copy_from_slice(q);
        fk_slice(r, &a)
    })
}

fn fk_slice<const N: usize>(r: &kincal::Robot<N>, q: &[f64; 8]) -> Transform {
    let mut a = [0.0; N];
    a.copy_from_slice(&q[..N]);
    r.fk_q(&a).expect("fk")
}

fn random_q(rng: &mut Rng, robot: &AnyRobot) -> Vec<f64> {
    with_any_robot!(robot, r => r
        .limits()
        .iter()
        .map(|l| rng.uniform(l.lower.max(-PI), l.upper.min(PI)))
        .collect())
}

/// Imports the chain, checks FK against the direct URDF FK and the export→import round
/// trip, and returns the import.
fn check_import(urdf: &urdf_rs::Robot, sel: &ChainSelection<'_>, label: &str) -> ImportedUrdf {
    let imp = import_urdf(urdf, label, sel).unwrap_or_else(|e| panic!("{label}: {e}"));
    let (_, _, path) = select_chain(urdf, label, sel).expect("chain");
    let mut rng = Rng(0xA11CE ^ label.len() as u64);
    let exported = export_urdf(
        &imp.robot,
        &UrdfExport {
            robot_name: &imp.robot_name,
            base_link: &imp.base_link,
            tip_link: &imp.tip_link,
            joint_names: Some(&imp.joint_names),
            allow_dropping_effects: false,
        },
    )
    .expect("export");
    let back = import_urdf_str(&exported, "exported.urdf", &ChainSelection::default())
        .unwrap_or_else(|e| panic!("{label}: re-import: {e}\n{exported}"));
    assert_eq!(back.joint_names, imp.joint_names);
    let mut worst: f64 = 0.0;
    let mut worst_rt: f64 = 0.0;
    for trial in 0..50 {
        let q = if trial == 0 {
            vec![0.0; imp.joint_names.len()]
        } else {
            random_q(&mut rng, &imp.robot)
        };
        let t_ref = urdf_fk(&path, &q);
        worst = worst.max(max_diff(&model_fk(&imp.robot, &q), &t_ref));
        worst_rt = worst_rt.max(max_diff(&model_fk(&back.robot, &q), &t_ref));
    }
    assert!(worst < FK_TOL, "{label}: imported FK differs by {worst:e}");
    assert!(
        worst_rt < FK_TOL,
        "{label}: export->import FK differs by {worst_rt:e}"
    );
    // Limits and masses survive the round trip.
    with_any_robot!(&imp.robot, r => with_any_robot!(&back.robot, b => {
        assert_eq!(r.limits().as_slice(), b.limits().as_slice(), "{label}: limits");
        for (x, y) in r.mass().link_masses_kg.iter().zip(b.mass().link_masses_kg.iter()) {
            assert!((x - y).abs() < 1e-12, "{label}: masses");
        }
        assert!((r.mass().tool_mass_kg - b.mass().tool_mass_kg).abs() < 1e-12);
    }));
    if std::env::var("KINCAL_SHOW").is_ok() {
        eprintln!(
            "{label}: {} joints {:?}, fixed folded {:?}, notes {:?}",
            imp.joint_names.len(),
            imp.joint_names,
            imp.fixed_joints,
            imp.notes
        );
        with_any_robot!(&imp.robot, r => {
            for (i, l) in r.links().iter().enumerate() {
                eprintln!(
                    "  {}: theta0 {:+.6} d {:+.6} a {:+.6} alpha {:+.6} beta {:+.3e} [{:?}] m {:.3}",
                    i + 1, l.theta0, l.d, l.a, l.alpha, l.beta, r.length_params()[i], r.mass().link_masses_kg[i]
                );
            }
            eprintln!("  base {:?}\n  tool {:?}\n  tool mass {} gravity {:?}", r.base(), r.tool(), r.mass().tool_mass_kg, r.mass().gravity);
        });
        eprintln!("  worst FK diff {worst:e}, round trip {worst_rt:e}");
    }
    imp
}

#[test]
fn real_urdfs_import_and_round_trip() {
    let Some(dir) = realdata() else {
        return;
    };
    // (file, base, tip, revolute joints expected)
    let cases: &[(&str, Option<&str>, Option<&str>, usize)] = &[
        (
            "figaroh-ur10e/robot_ur10e.urdf",
            Some("base_link"),
            Some("tool0"),
            6,
        ),
        (
            "figaroh-ur10e/robot_ur10e.urdf",
            Some("world"),
            Some("ref_camera_link"),
            6,
        ),
        ("figaroh-mate-planes/mate.urdf", None, None, 3),
        ("mukca/urdf/panda.urdf", None, Some("ball_link"), 7),
        (
            "mukca/urdf/panda_plus_bota.urdf",
            None,
            Some("ball_link"),
            7,
        ),
        ("mukca/urdf/iiwa14.urdf", None, Some("ball_link"), 7),
        ("mukca/urdf/iiwa14_epfl.urdf", None, None, 7),
        ("mukca/urdf/gen3lite.urdf", None, Some("tool_frame"), 6),
        ("mukca/urdf/vx300s.urdf", None, Some("ball_link"), 6),
        (
            "hilti-jaibot-stationing/data/trailblazer.urdf",
            Some("dsr_base_0"),
            Some("prism"),
            6,
        ),
    ];
    for (file, base, tip, n) in cases {
        let text =
            std::fs::read_to_string(dir.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        let urdf = urdf_rs::read_from_string(&text).unwrap_or_else(|e| panic!("{file}: {e}"));
        let sel = ChainSelection {
            base_link: *base,
            tip_link: *tip,
        };
        let imp = check_import(&urdf, &sel, &format!("{file} {base:?}->{tip:?}"));
        assert_eq!(imp.joint_names.len(), *n, "{file}");
    }
}

#[test]
fn real_urdf_errors_are_clear() {
    let Some(dir) = realdata() else {
        return;
    };
    let read = |f: &str| {
        urdf_rs::read_from_string(&std::fs::read_to_string(dir.join(f)).unwrap()).unwrap()
    };
    // Panda: the hand branches into the fingers and the ball.
    let e = import_urdf(
        &read("mukca/urdf/panda.urdf"),
        "panda.urdf",
        &ChainSelection::default(),
    )
    .unwrap_err();
    let s = e.to_string();
    assert!(
        s.contains("branches") && s.contains("ball_link") && s.contains("panda_leftfinger"),
        "{s}"
    );
    // Hilti: the lifting column is prismatic, its two upper stages mimic the first; they
    // collapse into one prismatic model joint under the 6R arm.
    let sel = ChainSelection {
        base_link: Some("base_link"),
        tip_link: Some("prism"),
    };
    let imp = import_urdf(
        &read("hilti-jaibot-stationing/data/trailblazer.urdf"),
        "t.urdf",
        &sel,
    )
    .unwrap();
    assert_eq!(imp.robot.n_joints(), 7);
    assert_eq!(imp.robot.joint_kind(0), kincal::JointKind::Prismatic);
    assert!((1..7).all(|j| imp.robot.joint_kind(j) == kincal::JointKind::Revolute));
    assert!(
        imp.notes
            .iter()
            .any(|n| n.contains("column_prismatic_joint"))
    );
    // UR10e: several leaves.
    let e = import_urdf(
        &read("figaroh-ur10e/robot_ur10e.urdf"),
        "ur.urdf",
        &ChainSelection::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("choose a tip link"), "{e}");
}

/// A random URDF: `n` revolute/continuous joints with random origins and axes (some axes
/// parallel, some intersecting, some negative or unnormalised), fixed joints between them,
/// and a side branch, so a tip must be named when `branch` is set.
fn random_urdf(rng: &mut Rng, n: usize, branch: bool) -> String {
    let mut s = String::from("<robot name=\"rand\">\n<link name=\"root\"/>\n");
    let mut parent = "root".to_string();
    let mut k = 0;
    let mut idx = 0;
    while k < n {
        idx += 1;
        let child = format!("l{idx}");
        let kind = match rng.pick(5) {
            0 if k > 0 => "fixed",
            1 => "continuous",
            _ => "revolute",
        };
        let xyz = [
            rng.uniform(-0.4, 0.4),
            rng.uniform(-0.4, 0.4),
            rng.uniform(-0.4, 0.4),
        ];
        let rpy = match rng.pick(4) {
            0 => [0.0; 3],
            1 => [PI / 2.0, 0.0, 0.0],
            _ => [
                rng.uniform(-PI, PI),
                rng.uniform(-1.5, 1.5),
                rng.uniform(-PI, PI),
            ],
        };
        let axis = match rng.pick(4) {
            0 => [0.0, 0.0, 1.0],
            1 => [0.0, -2.0, 0.0],
            _ => [
                rng.uniform(-1.0, 1.0),
                rng.uniform(-1.0, 1.0),
                rng.uniform(0.2, 1.0),
            ],
        };
        s.push_str(&format!("<link name=\"{child}\"><inertial><mass value=\"{}\"/><inertia ixx=\"0\" ixy=\"0\" ixz=\"0\" iyy=\"0\" iyz=\"0\" izz=\"0\"/></inertial></link>\n", rng.uniform(0.0, 3.0)));
        s.push_str(&format!(
            "<joint name=\"j{idx}\" type=\"{kind}\"><parent link=\"{parent}\"/><child link=\"{child}\"/><origin xyz=\"{} {} {}\" rpy=\"{} {} {}\"/><axis xyz=\"{} {} {}\"/><limit lower=\"-2.5\" upper=\"2.8\" effort=\"1\" velocity=\"1\"/></joint>\n",
            xyz[0], xyz[1], xyz[2], rpy[0], rpy[1], rpy[2], axis[0], axis[1], axis[2]
        ));
        if kind != "fixed" {
            k += 1;
        }
        parent = child;
    }
    s.push_str(&format!("<link name=\"tip\"/>\n<joint name=\"tipj\" type=\"fixed\"><parent link=\"{parent}\"/><child link=\"tip\"/><origin xyz=\"0.01 0.02 0.1\" rpy=\"0.3 -0.2 0.1\"/></joint>\n"));
    if branch {
        s.push_str("<link name=\"side\"/>\n<joint name=\"sidej\" type=\"fixed\"><parent link=\"l1\"/><child link=\"side\"/></joint>\n");
    }
    s.push_str("</robot>\n");
    s
}

#[test]
fn synthetic_urdfs_import_and_round_trip() {
    let mut rng = Rng(99);
    for trial in 0..60 {
        let n = 1 + trial % 8;
        let branch = trial % 3 == 0;
        let text = random_urdf(&mut rng, n, branch);
        let urdf = urdf_rs::read_from_string(&text).expect("parse");
        let sel = ChainSelection {
            base_link: None,
            tip_link: if branch { Some("tip") } else { None },
        };
        let imp = check_import(&urdf, &sel, &format!("synthetic {trial}"));
        assert_eq!(imp.joint_names.len(), n);
        assert_eq!(imp.base_link, "root");
        assert_eq!(imp.tip_link, "tip");
        if branch {
            assert!(import_urdf(&urdf, "b", &ChainSelection::default()).is_err());
        }
    }
}

fn chain_urdf(joints: &str) -> String {
    format!(
        "<robot name=\"t\"><link name=\"a\"/><link name=\"b\"/><link name=\"c\"/>{joints}</robot>"
    )
}

#[test]
fn synthetic_errors_name_the_joint() {
    let rev = "<joint name=\"j1\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"0\" velocity=\"0\"/></joint>";
    let cases = [
        (
            format!(
                "{rev}<joint name=\"p\" type=\"prismatic\"><parent link=\"b\"/><child link=\"c\"/><axis xyz=\"0 0 1\"/><limit lower=\"-3.14159\" upper=\"3.14159\" effort=\"0\" velocity=\"0\"/></joint>"
            ),
            "joint p",
            "look like radians",
        ),
        (
            format!(
                "{rev}<joint name=\"m\" type=\"revolute\"><parent link=\"b\"/><child link=\"c\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"0\" velocity=\"0\"/><mimic joint=\"j1\"/></joint>"
            ),
            "joint j1, joint m",
            "total multiplier 2",
        ),
        (
            format!(
                "{rev}<joint name=\"z\" type=\"revolute\"><parent link=\"b\"/><child link=\"c\"/><axis xyz=\"0 0 0\"/><limit lower=\"-1\" upper=\"1\" effort=\"0\" velocity=\"0\"/></joint>"
            ),
            "joint z",
            "no direction",
        ),
        (
            format!(
                "{rev}<joint name=\"nl\" type=\"revolute\"><parent link=\"b\"/><child link=\"c\"/><axis xyz=\"0 0 1\"/></joint>"
            ),
            "joint nl",
            "without usable limits",
        ),
        (
            format!(
                "{rev}<joint name=\"x\" type=\"fixed\"><parent link=\"b\"/><child link=\"nowhere\"/></joint>"
            ),
            "joint x",
            "does not define",
        ),
    ];
    for (joints, key, reason) in cases {
        let e = import_urdf_str(&chain_urdf(&joints), "t.urdf", &ChainSelection::default())
            .unwrap_err();
        assert_eq!(e.file, "t.urdf");
        assert_eq!(e.key.as_deref(), Some(key), "{e}");
        assert!(e.to_string().contains(reason), "{e}");
    }
    // Only fixed joints: no revolute joint.
    let fixed = "<joint name=\"f\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint><joint name=\"g\" type=\"fixed\"><parent link=\"b\"/><child link=\"c\"/></joint>";
    let e = import_urdf_str(&chain_urdf(fixed), "t.urdf", &ChainSelection::default()).unwrap_err();
    assert!(e.to_string().contains("0 revolute/prismatic joints"), "{e}");
    // Tip not below base.
    let sel = ChainSelection {
        base_link: Some("b"),
        tip_link: Some("a"),
    };
    let e = import_urdf_str(&chain_urdf(rev), "t.urdf", &sel).unwrap_err();
    assert!(e.to_string().contains("not below"), "{e}");
    // Not XML.
    assert!(import_urdf_str("<robot", "t.urdf", &ChainSelection::default()).is_err());
}

#[test]
fn export_refuses_effects_and_keeps_calibrated_geometry() {
    let mut r = kincal::aria::real_identified();
    let any = AnyRobot::from(r);
    let spec = UrdfExport {
        robot_name: "aria",
        base_link: "base_link",
        tip_link: "tool0",
        joint_names: None,
        allow_dropping_effects: false,
    };
    let text = export_urdf(&any, &spec).expect("export");
    let back = import_urdf_str(&text, "aria.urdf", &ChainSelection::default()).expect("import");
    let mut rng = Rng(5);
    for _ in 0..50 {
        let q = random_q(&mut rng, &any);
        let d = max_diff(&model_fk(&any, &q), &model_fk(&back.robot, &q));
        assert!(d < FK_TOL, "calibrated ARIA through URDF differs by {d:e}");
    }
    // A model with compliance is refused unless dropping is allowed.
    let idx = kincal::ParamId::Compliance(1).index(6);
    r.set_param(idx, 1e-3).unwrap();
    let any = AnyRobot::from(r);
    let e = export_urdf(&any, &spec).unwrap_err();
    assert!(e.to_string().contains("joint_compliance"), "{e}");
    assert!(
        export_urdf(
            &any,
            &UrdfExport {
                allow_dropping_effects: true,
                ..spec
            }
        )
        .is_ok()
    );
}

#[test]
fn urdf_rpy_matches_core_convention() {
    // URDF rpy is fixed-axis roll, pitch, yaw: R = Rz(y)·Ry(p)·Rx(r), as the core's.
    let o = urdf_rs::Pose {
        xyz: urdf_rs::Vec3([0.1, 0.2, 0.3]),
        rpy: urdf_rs::Vec3([0.3, -0.7, 2.0]),
    };
    let t = origin_transform(&o);
    let r = Rotation3::from_axis_angle(&Vector3::z_axis(), 2.0)
        * Rotation3::from_axis_angle(&Vector3::y_axis(), -0.7)
        * Rotation3::from_axis_angle(&Vector3::x_axis(), 0.3);
    let m: Matrix3<f64> = *r.matrix();
    assert!((t.rotation.matrix() - m).amax() < 1e-15);
}

/// A revolute joint (its value `q`) as a transform about the unit `axis`.
fn turn(axis: [f64; 3], q: f64) -> Transform {
    Transform::from_parts(
        Translation3::identity(),
        Rotation3::from_scaled_axis(Vector3::from(axis).normalize() * q),
    )
}

fn at(xyz: [f64; 3], rpy: [f64; 3]) -> Transform {
    Transform::from_parts(
        Translation3::new(xyz[0], xyz[1], xyz[2]),
        Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}

#[test]
fn mimic_joints_collapse_into_their_driver_exactly() {
    // a -j1-> b; b -d-> side (the driver, on another branch); b -m-> c (mimic 0.5·d + 0.3
    // about y); c -fixed (along and about y)-> c2; c2 -m2-> e (mimic 0.5·d − 0.2 about the
    // same line); e -j3-> tip. Model joints: j1, d (read by m and m2), j3.
    let lim = "<limit lower=\"-2\" upper=\"2\" effort=\"0\" velocity=\"0\"/>";
    let text = format!(
        "<robot name=\"mimic\">\n\
         <link name=\"a\"/><link name=\"b\"/><link name=\"side\"/><link name=\"c\"/>\n\
         <link name=\"c2\"/><link name=\"e\"/><link name=\"tip\"/>\n\
         <joint name=\"j1\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><origin xyz=\"0 0 0.3\" rpy=\"0 0 0\"/><axis xyz=\"0 0 1\"/>{lim}</joint>\n\
         <joint name=\"d\" type=\"revolute\"><parent link=\"b\"/><child link=\"side\"/><origin xyz=\"0.5 0 0\" rpy=\"0 0 0\"/><axis xyz=\"1 0 0\"/><limit lower=\"-1.5\" upper=\"1.25\" effort=\"0\" velocity=\"0\"/></joint>\n\
         <joint name=\"m\" type=\"revolute\"><parent link=\"b\"/><child link=\"c\"/><origin xyz=\"0.1 0.2 0.3\" rpy=\"0.2 0 0\"/><axis xyz=\"0 1 0\"/>{lim}<mimic joint=\"d\" multiplier=\"0.5\" offset=\"0.3\"/></joint>\n\
         <joint name=\"f\" type=\"fixed\"><parent link=\"c\"/><child link=\"c2\"/><origin xyz=\"0 0.15 0\" rpy=\"0 0.7 0\"/></joint>\n\
         <joint name=\"m2\" type=\"revolute\"><parent link=\"c2\"/><child link=\"e\"/><origin xyz=\"0 0 0\" rpy=\"0 0 0\"/><axis xyz=\"0 1 0\"/>{lim}<mimic joint=\"d\" multiplier=\"0.5\" offset=\"-0.2\"/></joint>\n\
         <joint name=\"j3\" type=\"revolute\"><parent link=\"e\"/><child link=\"tip\"/><origin xyz=\"0.4 0 0.1\" rpy=\"0 0 0.3\"/><axis xyz=\"0 0 1\"/>{lim}</joint>\n\
         </robot>"
    );
    let sel = ChainSelection {
        base_link: None,
        tip_link: Some("tip"),
    };
    let imp = import_urdf_str(&text, "mimic.urdf", &sel).expect("import");
    assert_eq!(imp.joint_names, ["j1", "d", "j3"]);
    with_any_robot!(&imp.robot, r => {
        let l = r.limits().get(1).copied().expect("3 joints");
        assert_eq!((l.lower, l.upper), (-1.5, 1.25), "driver's limits");
    });
    assert!(
        imp.notes
            .iter()
            .any(|n| n.contains("m, m2") && n.contains("`d`")),
        "{:?}",
        imp.notes
    );
    let mut rng = Rng(0x3141);
    let mut worst: f64 = 0.0;
    for _ in 0..50 {
        let q: Vec<f64> = (0..3).map(|_| rng.uniform(-1.2, 1.2)).collect();
        let (q1, qd, q3) = (q[0], q[1], q[2]);
        let reference = at([0.0, 0.0, 0.3], [0.0; 3])
            * turn([0.0, 0.0, 1.0], q1)
            * at([0.1, 0.2, 0.3], [0.2, 0.0, 0.0])
            * turn([0.0, 1.0, 0.0], 0.5 * qd + 0.3)
            * at([0.0, 0.15, 0.0], [0.0, 0.7, 0.0])
            * turn([0.0, 1.0, 0.0], 0.5 * qd - 0.2)
            * at([0.4, 0.0, 0.1], [0.0, 0.0, 0.3])
            * turn([0.0, 0.0, 1.0], q3);
        worst = worst.max(max_diff(&model_fk(&imp.robot, &q), &reference));
    }
    assert!(worst < FK_TOL, "mimic chain FK differs by {worst:e}");

    // Refused, naming the joints: a total multiplier of 0.5, and mimics about another line.
    let half = text.replace(
        "multiplier=\"0.5\" offset=\"-0.2\"",
        "multiplier=\"0\" offset=\"-0.2\"",
    );
    let e = import_urdf_str(&half, "mimic.urdf", &sel).unwrap_err();
    assert!(e.to_string().contains("total multiplier 0.5"), "{e}");
    assert_eq!(e.line, Some(6), "{e}");
    let skew = text.replace("rpy=\"0 0.7 0\"", "rpy=\"0.7 0 0\"");
    let e = import_urdf_str(&skew, "mimic.urdf", &sel).unwrap_err();
    assert_eq!(e.key.as_deref(), Some("joint m2"), "{e}");
    assert!(e.to_string().contains("another line"), "{e}");
    assert!(e.to_string().starts_with("mimic.urdf:8: joint m2"), "{e}");
    // A mimic of a mimic has no single driver.
    let chained = text.replace(
        "<mimic joint=\"d\" multiplier=\"0.5\" offset=\"-0.2\"/>",
        "<mimic joint=\"m\"/>",
    );
    let e = import_urdf_str(&chained, "mimic.urdf", &sel).unwrap_err();
    assert!(e.to_string().contains("itself mimics"), "{e}");
}

#[test]
fn errors_carry_the_urdf_line() {
    let Some(dir) = realdata() else {
        return;
    };
    let path = dir.join("hilti-jaibot-stationing/data/trailblazer.urdf");
    let sel = ChainSelection {
        base_link: Some("base_link"),
        tip_link: Some("prism"),
    };
    // The chain through the column imports (prismatic joints are modelled).
    import_urdf_file(&path, &sel).unwrap();
    // A chain that does not exist names both links, at the tip link's line.
    let sel = ChainSelection {
        base_link: Some("dsr_base_0"),
        tip_link: Some("column_tip"),
    };
    let e = import_urdf_file(&path, &sel).unwrap_err();
    assert!(
        e.to_string().contains("column_tip") && e.to_string().contains("dsr_base_0"),
        "{e}"
    );
    assert!(e.line.is_some(), "{e}");
}

/// The `urdf_import` fuzz target's input (kept as a seed): an attribute `:ixz` with an empty
/// namespace prefix under a default namespace made RustyXML (urdf-rs's reader) panic while
/// printing the element back; `<x:link>` was read as a `<link>`. Prefixed names are refused
/// with their line and column before the reader sees them; `xmlns:p` declarations (xacro
/// leftovers on `<robot>`) and a default namespace still pass.
#[test]
fn namespace_prefixed_names_are_refused_before_the_xml_reader() {
    let fuzz = include_str!("../../fuzz/seeds/urdf_import/regression-empty-namespace-prefix");
    let err = import_urdf_str(fuzz, "fuzz.urdf", &ChainSelection::default()).unwrap_err();
    let column = fuzz
        .lines()
        .nth(2)
        .and_then(|l| l.find(" :ixz="))
        .map(|c| c + 2);
    assert_eq!((err.line, err.column), (Some(3), column), "{err}");
    assert!(
        err.reason
            .starts_with("the name ':ixz' has a namespace prefix"),
        "{err}"
    );
    let body = r#"<link name="a"/><link name="b"/><joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>"#;
    let refused = [
        (
            format!(r#"<robot name="r" xmlns="u">{body}<link name="c" :ixz="0"/></robot>"#),
            ":ixz",
        ),
        (
            format!(r#"<robot name="r" xml:lang="en">{body}</robot>"#),
            "xml:lang",
        ),
        (
            format!(r#"<robot name="r" xmlns:x="u">{body}<x:link name="c"/></robot>"#),
            "x:link",
        ),
        (
            format!(r#"<xmlns:robot name="r">{body}</xmlns:robot>"#),
            "xmlns:robot",
        ),
    ];
    for (text, name) in &refused {
        let err = import_urdf_str(text, "ns.urdf", &ChainSelection::default()).unwrap_err();
        assert!(
            err.reason
                .contains(&format!("the name '{name}' has a namespace prefix")),
            "{name}: {err}"
        );
        assert_eq!(err.line, Some(1), "{err}");
        assert_eq!(
            Some(text.find(name).unwrap() + 1),
            err.column,
            "{name}: {err}"
        );
    }
    // Namespace declarations are blanked before the reader sees them (it panicked printing
    // `xmlns:xmlns` back: the second fuzz input); lines and columns stay those of the file.
    let accepted = [
        format!(r#"<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">{body}</robot>"#),
        format!(r#"<robot name="r" xmlns="u">{body}</robot>"#),
        format!(r#"<robot name="r:'x'">{body}<!-- <x:y/> --></robot>"#),
        format!(r#"<robot name="r" xmlns:xmlns="/" xmlns:a="1 >" xmlns:="u">{body}</robot>"#),
        format!("<robot name=\"r\" xmlns:a=\"é\n\">{body}</robot>"),
    ];
    for text in &accepted {
        let imp = import_urdf_str(text, "ok.urdf", &ChainSelection::default());
        assert!(imp.is_ok(), "{text}: {:?}", imp.err());
    }
    let blanked = check_markup(&accepted[4], "ok.urdf").unwrap();
    assert_eq!(blanked.lines().count(), accepted[4].lines().count());
    let first = blanked.lines().next().unwrap();
    assert_eq!(first.trim_end(), "<robot name=\"r\"", "{blanked}");
    assert_eq!(first.len(), accepted[4].lines().next().unwrap().len());
    let bad_line = format!("<robot name=\"r\" xmlns:a=\"\n\">\n{body}<x:link/></robot>");
    let err = import_urdf_str(&bad_line, "ns.urdf", &ChainSelection::default()).unwrap_err();
    assert_eq!(err.line, Some(3), "{err}");
    let second = include_str!("../../fuzz/seeds/urdf_import/regression-xmlns-xmlns-declaration");
    assert!(import_urdf_str(second, "fuzz.urdf", &ChainSelection::default()).is_err());
    // The third: `xmlns:xmlns` behind a `<?` the scan once skipped two bytes of (the reader
    // ends it at the first `>` after a `?`). The scan now ends it there too, and whatever
    // it mistakes, no `xmlns` or `xml:` may reach the reader outside a blanked declaration.
    let third =
        include_str!("../../fuzz/seeds/urdf_import/regression-xmlns-behind-processing-instruction");
    assert!(import_urdf_str(third, "fuzz.urdf", &ChainSelection::default()).is_err());
    for hidden in [
        format!("<?pi x?><robot name=\"r\">{body}</robot><!-- xmlns -->"),
        format!("<robot name=\"xml:r\">{body}</robot>"),
    ] {
        let err = import_urdf_str(&hidden, "ns.urdf", &ChainSelection::default()).unwrap_err();
        assert!(
            err.reason.contains("outside a start tag's attributes"),
            "{err}"
        );
    }
}
