//! `kincal import-dataset tiago DIR --urdf TIAGO.urdf` on a small synthetic folder in the
//! set's layout (the rows' numbers and the model's FK are checked in kincal-io's
//! `datasets_tiago` tests): the rows and robot written, the refusals and their exit codes.

use std::path::Path;
use std::process::{Command, Output};

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

const JOINTS: [&str; 8] = [
    "torso_lift_joint",
    "arm_1_joint",
    "arm_2_joint",
    "arm_3_joint",
    "arm_4_joint",
    "arm_5_joint",
    "arm_6_joint",
    "arm_7_joint",
];

/// base_footprint -(fixed)- torso_fixed_link -(P)- torso_lift_link -(7R)- arm_7_link, and a
/// head branch.
fn urdf() -> String {
    let mut s = String::from("<robot name=\"mini_tiago\">\n<link name=\"base_footprint\"/>\n");
    let mut joint = |name: &str, kind: &str, parent: &str, child: &str, xyz: &str, lim: &str| {
        s.push_str(&format!(
            "<link name=\"{child}\"/>\n<joint name=\"{name}\" type=\"{kind}\"><parent link=\"{parent}\"/>\
             <child link=\"{child}\"/><origin xyz=\"{xyz}\" rpy=\"0 0.1 0\"/><axis xyz=\"0 0 1\"/>{lim}</joint>\n"
        ));
    };
    joint(
        "torso_fixed_joint",
        "fixed",
        "base_footprint",
        "torso_fixed_link",
        "0 0 0.3",
        "",
    );
    let p = "<limit lower=\"0\" upper=\"0.35\" effort=\"1\" velocity=\"1\"/>";
    let r = "<limit lower=\"-2.5\" upper=\"2.5\" effort=\"1\" velocity=\"1\"/>";
    joint(
        "torso_lift_joint",
        "prismatic",
        "torso_fixed_link",
        "torso_lift_link",
        "0 0 0.6",
        p,
    );
    joint(
        "head_1_joint",
        "revolute",
        "torso_lift_link",
        "head_1_link",
        "0.2 0 0",
        r,
    );
    let mut parent = "torso_lift_link".to_string();
    for k in 1..=7 {
        let child = format!("arm_{k}_link");
        joint(
            &format!("arm_{k}_joint"),
            "revolute",
            &parent,
            &child,
            "0.05 0.01 0.1",
            r,
        );
        parent = child;
    }
    s.push_str("</robot>\n");
    s
}

/// The set's CSV layout with `n` rows.
fn csv(n: usize) -> String {
    let mut cols: Vec<String> = (1..=4)
        .flat_map(|k| ["x", "y", "z"].map(|c| format!("{c}{k}")))
        .collect();
    cols.extend(JOINTS.iter().map(|j| (*j).to_string()));
    let mut s = cols.join(",") + "\n";
    for i in 0..n {
        let v: Vec<String> = (0..20)
            .map(|c| format!("{}", 0.01 * (i + c) as f64))
            .collect();
        s.push_str(&v.join(","));
        s.push('\n');
    }
    s
}

fn folder() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("set");
    std::fs::create_dir(&set).unwrap();
    std::fs::write(set.join("qualysis_base_hand_calibration.csv"), csv(6)).unwrap();
    std::fs::write(dir.path().join("tiago.urdf"), urdf()).unwrap();
    dir
}

#[test]
fn imports_with_the_users_urdf() {
    let dir = folder();
    let o = kincal(
        &[
            "import-dataset",
            "tiago",
            "set",
            "--urdf",
            "tiago.urdf",
            "--out",
            "data.csv",
            "--robot-out",
            "robot.toml",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("6 poses, 8 joints, positions only"),
        "{}",
        text(&o)
    );
    let data = std::fs::read_to_string(dir.path().join("data.csv")).unwrap();
    let header = data.lines().find(|l| !l.starts_with('#')).unwrap();
    assert!(header.contains("q8") && !header.contains("q9"), "{header}");
    assert!(
        header.contains("extra_x2") && header.contains("extra_z4"),
        "{header}"
    );
    let robot = std::fs::read_to_string(dir.path().join("robot.toml")).unwrap();
    assert!(
        robot.contains("torso_lift_joint") && robot.contains("prismatic"),
        "{robot}"
    );
    assert!(!robot.contains("head_1_joint"), "{robot}");
}

#[test]
fn refusals_exit_2_for_usage_and_3_for_a_chain_that_does_not_exist() {
    let dir = folder();
    let run = |extra: &[&str]| {
        let mut a = vec!["import-dataset", "tiago", "set", "--out", "data.csv"];
        a.extend_from_slice(extra);
        kincal(&a, dir.path())
    };
    // No URDF: where to get it.
    let o = run(&[]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("not shipped"), "{}", text(&o));
    // A tip link that does not exist: the URDF named (bad input).
    let o = run(&["--urdf", "tiago.urdf", "--tip-link", "gripper_tool_link"]);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    assert!(text(&o).contains("gripper_tool_link"), "{}", text(&o));
    // A chain that leaves out the torso lift.
    let o = run(&["--urdf", "tiago.urdf", "--base-link", "torso_lift_link"]);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    assert!(text(&o).contains("torso_lift_joint"), "{}", text(&o));
    assert!(!dir.path().join("data.csv").exists());
    // --urdf belongs to tiago only.
    let o = kincal(
        &[
            "import-dataset",
            "figaroh-ur10e",
            "set",
            "--urdf",
            "tiago.urdf",
            "--out",
            "data.csv",
        ],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    // --list says what TIAGo needs instead of calling it unusable.
    let o = kincal(&["import-dataset", "--list"], dir.path());
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("figaroh-tiago-mocap") && t.contains("needs --urdf"),
        "{t}"
    );
    assert!(!t.contains("Not usable"), "{t}");
}
