//! `--effects joint_scale@JOINT` (kincal-io's `effects_arg`): the scale of the named joints
//! only, in `calibrate` and `crossval`. A 4R arm (a URDF the test writes) with a planted
//! scale error on `elbow` only: noise-free rows (the core's FK of the planted model) give
//! that scale back to 1e-9 with `joint_scale@elbow`; the other joints' scales are not
//! identified (exactly 0 in the model file). A joint the robot does not have exits 2 naming
//! it.

use std::path::Path;
use std::process::{Command, Output};

use kincal::any::AnyRobot;
use kincal::params::ParamId;
use kincal::rng::SplitMix64;
use kincal_io::urdf::{ChainSelection, import_urdf_str};

const BIN: &str = env!("CARGO_BIN_EXE_kincal");

fn kincal(args: &[&str], dir: &Path) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run kincal")
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

const NAMES: [&str; 4] = ["shoulder_yaw", "shoulder_pitch", "elbow", "wrist"];

fn urdf() -> String {
    let mut s = String::from("<robot name=\"arm4\">\n<link name=\"base\"/>\n");
    let origins = [
        ("0 0 0.3", "0 0 0"),
        ("0 0.05 0.1", "1.5707963 0 0"),
        ("0.4 0 0", "0 0 0.2"),
        ("0.3 0 0.02", "-1.5707963 0 0"),
    ];
    let mut parent = "base".to_string();
    for (k, (n, (xyz, rpy))) in NAMES.iter().zip(origins).enumerate() {
        let child = format!("l{}", k + 1);
        s.push_str(&format!(
            "<link name=\"{child}\"/>\n<joint name=\"{n}\" type=\"revolute\"><parent link=\"{parent}\"/>\
             <child link=\"{child}\"/><origin xyz=\"{xyz}\" rpy=\"{rpy}\"/><axis xyz=\"0 0 1\"/>\
             <limit lower=\"-2.5\" upper=\"2.5\" effort=\"1\" velocity=\"1\"/></joint>\n"
        ));
        parent = child;
    }
    s.push_str("<link name=\"tool\"/>\n<joint name=\"tool_joint\" type=\"fixed\"><parent link=\"l4\"/>\
                <child link=\"tool\"/><origin xyz=\"0.1 0.02 0.05\" rpy=\"0 0 0\"/></joint>\n</robot>\n");
    s
}

/// Planted: elbow scale 1 + 0.002.
const PLANTED: f64 = 2e-3;

fn folder() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let text = urdf();
    std::fs::write(dir.path().join("arm4.urdf"), &text).unwrap();
    let imp = import_urdf_str(&text, "arm4.urdf", &ChainSelection::default()).unwrap();
    let AnyRobot::J4(mut truth) = imp.robot else {
        panic!("4 joints")
    };
    truth
        .set_param(ParamId::Scale(2).index(4), PLANTED)
        .unwrap();
    let mut rng = SplitMix64::new(3);
    let mut csv = String::from("pose_id,q1,q2,q3,q4,x,y,z,qw,qx,qy,qz\n");
    for i in 0..30 {
        let q: [f64; 4] = std::array::from_fn(|_| rng.range(-2.0, 2.0));
        let t = truth.fk_q(&q).unwrap();
        let p = t.translation.vector;
        let [w, x, y, z] = kincal::pose::matrix_to_quaternion(t.rotation.matrix());
        csv.push_str(&format!(
            "{i},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?}\n",
            q[0], q[1], q[2], q[3], p.x, p.y, p.z, w, x, y, z
        ));
    }
    std::fs::write(dir.path().join("data.csv"), csv).unwrap();
    dir
}

#[test]
fn joint_scale_of_one_joint_is_identified_alone() {
    let dir = folder();
    let o = kincal(
        &[
            "calibrate",
            "data.csv",
            "--robot",
            "arm4.urdf",
            "--effects",
            "joint_scale@elbow",
            "--out",
            "m.json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("joint_scale (q3 only)"), "{}", text(&o));
    let m = kincal_io::model_read::read_model_file(&dir.path().join("m.json")).unwrap();
    let AnyRobot::J4(r) = m.robot else {
        panic!("4 joints")
    };
    let k = r.effect_params().scale;
    assert!((k[2] - PLANTED).abs() < 1e-9, "elbow scale {:e}", k[2]);
    assert_eq!(
        [k[0], k[1], k[3]],
        [0.0; 3],
        "only the elbow's scale: {k:?}"
    );
    // By column name too, in crossval.
    let o = kincal(
        &[
            "crossval",
            "data.csv",
            "--robot",
            "arm4.urdf",
            "--effects",
            "joint_scale@q3",
            "--json",
            "cv.json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn a_joint_the_robot_does_not_have_exits_2_naming_it() {
    let dir = folder();
    for cmd in ["calibrate", "crossval"] {
        let out_flag = if cmd == "calibrate" {
            "--out"
        } else {
            "--json"
        };
        let o = kincal(
            &[
                cmd,
                "data.csv",
                "--robot",
                "arm4.urdf",
                "--effects",
                "base_frame,joint_scale@knee",
                out_flag,
                "out.json",
            ],
            dir.path(),
        );
        assert_eq!(o.status.code(), Some(2), "{cmd}: {}", text(&o));
        assert!(text(&o).contains("no joint 'knee'"), "{cmd}: {}", text(&o));
        assert!(text(&o).contains("elbow"), "{cmd}: {}", text(&o));
        assert!(!dir.path().join("out.json").exists());
    }
    // A selector on an effect that has none: clap's usage error.
    let o = kincal(
        &[
            "calibrate",
            "data.csv",
            "--robot",
            "arm4.urdf",
            "--effects",
            "backlash@elbow",
            "--out",
            "m.json",
        ],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("only joint_scale"), "{}", text(&o));
}
