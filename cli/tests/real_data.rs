//! The public real-robot data sets (docs/real-data.md), read where they are shared:
//! `../../shared/realdata` relative to this crate (the repository's sibling `shared/`
//! folder), or `$KINCAL_REALDATA`. Nothing is copied into the repository.
//!
//! Without the folder the tests are skipped with a message, except under `CI=true`, where
//! a missing folder is a failure (the numbers of docs/real-data.md must stay checked).
//!
//! Checked: the FR3 and UR10e held-out residuals against the nominal model's (the numbers
//! docs/real-data.md states, to 2 %), the FR3 description's FK against the robot's own
//! TCP poses, TALOS calibrating from position-only rows with its identifiability report,
//! the positioner's import, and the refusal of the sets that cannot be used as they are.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

const BIN: &str = env!("CARGO_BIN_EXE_kincal");

fn realdata() -> Option<PathBuf> {
    let dir = std::env::var_os("KINCAL_REALDATA").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/realdata"),
        PathBuf::from,
    );
    if dir.is_dir() {
        return Some(dir);
    }
    let msg = format!(
        "real-data folder {} not found (set KINCAL_REALDATA)",
        dir.display()
    );
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("{msg}; CI=true: the real-data tests must run");
    }
    eprintln!("skipping: {msg}");
    None
}

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

/// Imports `name` into `dir` as data.csv / robot.toml; returns the import's output.
fn import(root: &Path, name: &str, dir: &Path) -> String {
    let src = root.join(name);
    let o = kincal(
        &[
            "import-dataset",
            name,
            src.to_str().unwrap(),
            "--out",
            "data.csv",
            "--robot-out",
            "robot.toml",
        ],
        dir,
    );
    assert!(o.status.success(), "{}", text(&o));
    text(&o)
}

/// crossval as docs/real-data.sh runs it; returns its JSON.
fn crossval(dir: &Path, extra: &[&str]) -> Value {
    let mut args = vec![
        "crossval",
        "data.csv",
        "--robot",
        "robot.toml",
        "--effects",
        "base_frame,tool_frame",
        "--init-frames",
        "--folds",
        "5",
        "--seed",
        "1",
        "--json",
        "cv.json",
    ];
    args.extend_from_slice(extra);
    let o = kincal(&args, dir);
    assert!(o.status.success(), "{}", text(&o));
    serde_json::from_str(&std::fs::read_to_string(dir.join("cv.json")).unwrap()).unwrap()
}

fn num(v: &Value, path: &[&str]) -> f64 {
    let mut x = v;
    for p in path {
        x = &x[*p];
    }
    x.as_f64()
        .unwrap_or_else(|| panic!("{path:?} is not a number: {x}"))
}

#[track_caller]
fn close(got: f64, want: f64, what: &str) {
    assert!(
        (got - want).abs() <= 0.02 * want.abs(),
        "{what}: {got} differs from the documented {want} by more than 2 % (update docs/real-data.md if this is intended)"
    );
}

#[test]
fn fr3_held_out_residual_clearly_below_nominal() {
    let Some(root) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = import(&root, "robotkinecal-fr3", dir.path());
    // The description's FK against Franka's own TCP poses: one constant transform to 0.1 mm.
    let line = out
        .lines()
        .find(|l| l.contains("FK check"))
        .expect("FK check note");
    let mm: f64 = line
        .split(" to ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .expect("FK deviation");
    assert!(mm < 0.1, "{line}");
    let cv = crossval(dir.path(), &[]);
    let (nom_p, cal_p) = (
        num(&cv, &["heldout", "nominal", "rms_pos_mm"]),
        num(&cv, &["heldout", "calibrated", "rms_pos_mm"]),
    );
    let (nom_r, cal_r) = (
        num(&cv, &["heldout", "nominal", "rms_rot_deg"]),
        num(&cv, &["heldout", "calibrated", "rms_rot_deg"]),
    );
    assert!(cal_p < 0.5 * nom_p, "{cal_p} mm vs {nom_p} mm");
    assert!(cal_r < 0.5 * nom_r, "{cal_r}° vs {nom_r}°");
    close(nom_p, 4.740, "FR3 nominal held-out RMS position [mm]");
    close(cal_p, 1.472, "FR3 calibrated held-out RMS position [mm]");
    close(nom_r, 0.6894, "FR3 nominal held-out RMS rotation [deg]");
    close(cal_r, 0.2153, "FR3 calibrated held-out RMS rotation [deg]");
}

#[test]
fn ur10e_held_out_orientation_improves_position_stays_at_the_noise() {
    let Some(root) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    import(&root, "figaroh-ur10e", dir.path());
    let cv = crossval(dir.path(), &[]);
    let (nom_p, cal_p) = (
        num(&cv, &["heldout", "nominal", "rms_pos_mm"]),
        num(&cv, &["heldout", "calibrated", "rms_pos_mm"]),
    );
    let (nom_r, cal_r) = (
        num(&cv, &["heldout", "nominal", "rms_rot_deg"]),
        num(&cv, &["heldout", "calibrated", "rms_rot_deg"]),
    );
    // 23 poses: the orientation improves on held-out poses; the position does not (the
    // nominal geometry's held-out error is already at the camera's noise, docs/real-data.md).
    assert!(cal_r < 0.85 * nom_r, "{cal_r}° vs {nom_r}°");
    close(nom_p, 4.369, "UR10e nominal held-out RMS position [mm]");
    close(cal_p, 4.974, "UR10e calibrated held-out RMS position [mm]");
    close(nom_r, 0.6006, "UR10e nominal held-out RMS rotation [deg]");
    close(
        cal_r,
        0.4712,
        "UR10e calibrated held-out RMS rotation [deg]",
    );
    assert_eq!(cv["outliers"]["suspects"].as_array().unwrap().len(), 2);
}

#[test]
fn talos_position_only_calibrates_with_its_identifiability_report() {
    let Some(root) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = import(&root, "figaroh-talos-arm", dir.path());
    assert!(out.contains("positions only"), "{out}");
    assert!(out.contains("arm_left_5_joint is held at 0"), "{out}");
    let data = std::fs::read_to_string(dir.path().join("data.csv")).unwrap();
    let header = data.lines().find(|l| !l.starts_with('#')).unwrap();
    assert_eq!(
        header,
        "pose_id,q1,q2,q3,q4,q5,q6,q7,q8,x,y,z,extra_arm_left_5_joint"
    );
    let o = kincal(
        &[
            "calibrate",
            "data.csv",
            "--robot",
            "robot.toml",
            "--effects",
            "base_frame,tool_frame",
            "--init-frames",
            "--allow-data-deficiency",
            "--out",
            "model.json",
        ],
        dir.path(),
    );
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    // What position-only data of one point cannot determine: the tool rotation.
    for p in ["tool_rx", "tool_ry", "tool_rz"] {
        assert!(
            t.lines()
                .any(|l| l.trim_start().starts_with(p)
                    && l.contains("no effect on the measured pose")),
            "{p} not reported as invisible:\n{t}"
        );
    }
    assert!(t.contains("identifiable:           35"), "{t}");
    assert!(t.contains("structurally redundant: 9"), "{t}");
    let cv = crossval(dir.path(), &[]);
    let (nom_p, cal_p) = (
        num(&cv, &["heldout", "nominal", "rms_pos_mm"]),
        num(&cv, &["heldout", "calibrated", "rms_pos_mm"]),
    );
    assert!(cal_p < 0.25 * nom_p, "{cal_p} mm vs {nom_p} mm");
    close(nom_p, 5.459, "TALOS nominal held-out RMS position [mm]");
    close(cal_p, 0.917, "TALOS calibrated held-out RMS position [mm]");
    assert!(cv["heldout"]["calibrated"]["rms_rot_deg"].is_null());
}

#[test]
fn positioner_imports_and_unusable_sets_are_refused_with_reasons() {
    let Some(root) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = import(&root, "ical-2axis-positioner", dir.path());
    assert!(out.contains("205 poses, 2 joints, full poses"), "{out}");
    for (name, why) in [
        ("figaroh-tiago-mocap", "prismatic"),
        ("figaroh-mate-planes", "whether the data are real"),
        ("mukca", "ball-in-socket"),
        ("hilti-jaibot-stationing", "non-commercial"),
    ] {
        let src = root.join(name);
        let o = kincal(
            &[
                "import-dataset",
                name,
                src.to_str().unwrap(),
                "--out",
                "x.csv",
            ],
            dir.path(),
        );
        assert_eq!(o.status.code(), Some(3), "{name}: {}", text(&o));
        assert!(text(&o).contains(why), "{name}: {}", text(&o));
        assert!(!dir.path().join("x.csv").exists());
    }
}
