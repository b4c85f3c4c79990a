//! A new user's first hour (issue #19): progress lines without a terminal, messages that
//! fit the robot (targets, eq. 3, in-sample, pose counts, dashes), flags that agree.

use std::fs;
use std::path::Path;
use std::process::{Command, Output};

use kincal::ik::{IkOptions, solve_ik};
use kincal::pose::matrix_to_quaternion;
use kincal::{JointState, aria};

const BIN: &str = env!("CARGO_BIN_EXE_kincal");

fn kincal(args: &[&str], dir: &Path, env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(BIN);
    c.args(args).current_dir(dir);
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("run kincal")
}

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn ok(o: &Output) -> String {
    let (out, err) = text(o);
    assert_eq!(o.status.code(), Some(0), "{out}\n{err}");
    out
}

/// Rows of the truth's exact poses at the Table 2 tool poses: one full row per pose and,
/// with `position_twin`, a position-only row of the same pose (same pose_id).
fn table2_csv(position_twin: bool) -> String {
    let truth = aria::virtual_truth();
    let mut s = String::from("# robot: aria\npose_id,q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz\n");
    for l in 0..aria::TOOL_POSES.len() {
        let target = aria::tool_pose(l).unwrap();
        let seed = JointState::new(aria::TOOL_SEED_Q);
        let q = solve_ik(&truth, &target, &seed, &IkOptions::default())
            .unwrap()
            .q;
        let t = truth.fk_q(&q).unwrap();
        let p = t.translation.vector;
        let quat = matrix_to_quaternion(t.rotation.matrix());
        let head: Vec<String> = std::iter::once(format!("p{}", l + 1))
            .chain(q.iter().map(|v| format!("{v}")))
            .chain([p.x, p.y, p.z].iter().map(|v| format!("{v}")))
            .collect();
        let quat: Vec<String> = quat.iter().map(|v| format!("{v}")).collect();
        s.push_str(&format!("{},{}\n", head.join(","), quat.join(",")));
        if position_twin {
            s.push_str(&format!("{},,,,\n", head.join(",")));
        }
    }
    s
}

/// A calibrated ARIA model on `data.csv` plus `twins.csv` (the same poses, two rows each).
fn calibrated() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("data.csv"), table2_csv(false)).unwrap();
    fs::write(dir.path().join("twins.csv"), table2_csv(true)).unwrap();
    ok(&kincal(
        &[
            "calibrate",
            "data.csv",
            "--robot",
            "aria",
            "--out",
            "model.json",
        ],
        dir.path(),
        &[],
    ));
    dir
}

#[test]
fn validate_warns_in_sample_counts_poses_and_dashes_missing_orientation() {
    let dir = calibrated();
    let o = kincal(&["validate", "model.json", "data.csv"], dir.path(), &[]);
    let out = ok(&o);
    let (_, err) = text(&o);
    assert!(err.contains("in-sample"), "{err}");
    assert!(out.contains("Warning: in-sample"), "{out}");
    assert!(out.contains(": 10 poses\n"), "{out}");

    // The same poses with a position-only twin row each: a different file (no warning),
    // 10 poses in 20 rows, and a dash, not 0.000000, for the twins' orientation errors.
    let o = kincal(&["validate", "model.json", "twins.csv"], dir.path(), &[]);
    let out = ok(&o);
    let (_, err) = text(&o);
    assert!(
        !err.contains("in-sample") && !out.contains("in-sample"),
        "{out}{err}"
    );
    assert!(out.contains(": 10 poses (20 rows)"), "{out}");
    let p1: Vec<Vec<&str>> = out
        .lines()
        .map(|l| l.split_whitespace().collect::<Vec<_>>())
        .filter(|c| c.first() == Some(&"p1"))
        .collect();
    assert_eq!(p1.len(), 2, "{out}");
    assert_eq!(p1[0].len(), 9, "{out}");
    assert!(p1[0][5..].iter().all(|c| *c != "-"), "{out}");
    assert_eq!(&p1[1][5..], ["-"; 4], "{out}");

    // crossval counts poses by pose_id too, and the rows beside them.
    let out = ok(&kincal(
        &["crossval", "twins.csv", "--robot", "aria"],
        dir.path(),
        &[],
    ));
    assert!(
        out.contains("\n  10 poses (pose_id groups, 20 rows), 5 folds"),
        "{out}"
    );
}

#[test]
fn aria_targets_and_eq3_only_for_aria() {
    let dir = calibrated();
    let out = ok(&kincal(
        &["validate", "model.json", "data.csv", "--plot", "e.svg"],
        dir.path(),
        &[],
    ));
    assert!(out.contains("the paper's ARIA targets"), "{out}");
    // In-sample errors far below the targets: the norm rows are scaled to the errors and
    // the x-axis label states the target (a line at the target would flatten them).
    let svg = fs::read_to_string(dir.path().join("e.svg")).unwrap();
    // NOM's errors reach the targets (line drawn); OLS's in-sample errors do not.
    assert_eq!(
        svg.matches("pose (target 0.660 deg, above this scale)")
            .count(),
        1,
        "{svg}"
    );
    assert_eq!(
        svg.matches("pose (target 1.00 mm, above this scale)")
            .count(),
        1,
        "{svg}"
    );
    assert!(out.contains("Eq. (3)"), "{out}");

    // The same model under another robot's name: the targets are labelled as ARIA's and
    // the biopsy budget of eq. (3) is not printed unless asked for.
    let model = fs::read_to_string(dir.path().join("model.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&model).unwrap();
    v["robot"]["name"] = "ur10e".into();
    fs::write(dir.path().join("other.json"), v.to_string()).unwrap();
    let out = ok(&kincal(
        &["validate", "other.json", "data.csv"],
        dir.path(),
        &[],
    ));
    // Prose wraps at 100 columns: compare with the line breaks taken out.
    let flat = out.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        flat.contains("set --target-pos-mm/--target-rot-deg for this robot"),
        "{out}"
    );
    assert!(!out.contains("Eq. (3)"), "{out}");
    assert!(out.contains("(OLS model of 'ur10e')"), "{out}");
    let out = ok(&kincal(
        &["validate", "other.json", "data.csv", "--biopsy-d-mm", "0.5"],
        dir.path(),
        &[],
    ));
    assert!(out.contains("Eq. (3)"), "{out}");

    // A model with effects is named by them, not by its algorithm alone.
    ok(&kincal(
        &[
            "calibrate",
            "data.csv",
            "--robot",
            "aria",
            "--effects",
            "joint_compliance",
            "--allow-data-deficiency",
            "--out",
            "jc.json",
        ],
        dir.path(),
        &[],
    ));
    let out = ok(&kincal(
        &["validate", "jc.json", "twins.csv"],
        dir.path(),
        &[],
    ));
    assert!(
        out.contains("(OLS + joint_compliance model of 'aria')"),
        "{out}"
    );
    assert!(out.contains("\n  OLS + joint_compliance "), "{out}");
}

#[test]
fn progress_lines_without_a_terminal_and_no_overshoot() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "select-poses",
        "--design",
        "standard",
        "--out",
        "std.csv",
        "--pool",
        "200",
        "--starts",
        "2",
        "--refine",
        "5",
    ];
    // stderr is a pipe here: plain lines at the interval asked for, the exchange among them.
    let o = kincal(&args, dir.path(), &[("KINCAL_PROGRESS_SECS", "0.01")]);
    ok(&o);
    let (_, err) = text(&o);
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("[progress]"))
        .collect();
    assert!(!lines.is_empty(), "{err}");
    assert!(
        lines.iter().any(|l| l.contains("exchange (2 starts)")),
        "{err}"
    );
    for l in &lines {
        // "msg: pos/len (pct %)": never past the end ("2016/2000").
        if let Some((pos, len)) = l
            .split_whitespace()
            .find_map(|w| w.split_once('/'))
            .and_then(|(a, b)| Some((a.parse::<u64>().ok()?, b.parse::<u64>().ok()?)))
        {
            assert!(pos <= len, "{l}");
        }
    }
}

#[test]
fn opt1_on_its_bounds_is_said_once_and_output_stays_readable() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("data.csv"), table2_csv(false)).unwrap();
    // The truth's θ0_4 = −45.8° lies far outside OPT1's default ±5°.
    let out = ok(&kincal(
        &[
            "calibrate",
            "data.csv",
            "--robot",
            "aria",
            "--algorithm",
            "all",
            "--out",
            "m.json",
        ],
        dir.path(),
        &[],
    ));
    assert!(out.contains("OPT1 ended on its bounds ("), "{out}");
    assert!(
        out.contains("its intervals exclude the data's optimum"),
        "{out}"
    );
    // Only the unbounded pair (OLS, OPT2) is judged; OPT1's pairs are not listed one by one.
    assert!(
        !out.contains("OLS−OPT1") && !out.contains("OPT1−OPT2"),
        "{out}"
    );
    assert_eq!(out.matches("Correlations above").count(), 1, "{out}");
    assert!(!out.contains("-0.000000") && !out.contains("e-15"), "{out}");
    for l in out.lines() {
        assert!(l.chars().count() <= 104, "{} chars: {l}", l.chars().count());
    }
    // validate names the bound case under its table of every recorded model.
    let v = ok(&kincal(
        &["validate", "m.json", "data.csv"],
        dir.path(),
        &[],
    ));
    assert!(v.contains("\n  OPT1 ended on its bounds ("), "{v}");
    assert!(
        v.contains("its errors measure the intervals, not the data"),
        "{v}"
    );
    assert!(
        !v.contains("OLS ended on") && !v.contains("OPT2 ended on"),
        "{v}"
    );
    // The model file still records every disagreement.
    let m: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(dir.path().join("m.json")).unwrap()).unwrap();
    assert!(
        !m["calibration"]["consensus"]["disagreeing"]
            .as_array()
            .unwrap()
            .is_empty()
    );
}

#[test]
fn flags_agree_across_commands() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("data.csv"), table2_csv(false)).unwrap();

    // crossval takes calibrate's `--robust huber|cauchy`; `--robust` alone stays Cauchy.
    let out = ok(&kincal(
        &[
            "crossval", "data.csv", "--robot", "aria", "--robust", "huber",
        ],
        d,
        &[],
    ));
    assert!(out.contains("Fits: robust (huber IRLS)"), "{out}");
    let out = ok(&kincal(
        &["crossval", "data.csv", "--robot", "aria", "--robust"],
        d,
        &[],
    ));
    assert!(out.contains("Fits: robust (cauchy IRLS)"), "{out}");

    // diagnose takes --seed (fold assignment); with only --sigma-pos-mm on data with
    // orientations, the missing noise is named: --sigma-rot-deg, not both.
    let o = kincal(
        &[
            "diagnose",
            "data.csv",
            "--robot",
            "aria",
            "--sigma-pos-mm",
            "0.1",
            "--seed",
            "7",
            "--json",
            "r.json",
            "--out",
            "m.json",
        ],
        d,
        &[],
    );
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(2), "{out}{err}");
    assert!(err.contains("no noise floor"), "{err}");
    assert!(err.contains("--sigma-rot-deg is not given"), "{err}");
    assert!(
        !err.contains("--sigma-pos-mm/--sigma-rot-deg are not given"),
        "{err}"
    );

    // markers: --sigma-pos-mm as everywhere else, --sigma-mm kept as its alias.
    let help = ok(&kincal(&["markers", "--help"], d, &[]));
    assert!(help.contains("--sigma-pos-mm"), "{help}");
    for flag in ["--sigma-pos-mm", "--sigma-mm"] {
        let o = kincal(&["markers", "export.csv", flag, "0.2"], d, &[]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(!err.contains("unexpected argument"), "{flag}: {err}");
    }
}
