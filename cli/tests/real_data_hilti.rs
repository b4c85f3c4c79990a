//! The Hilti stationing set (docs/real-data.md, "Hilti"), read where it is shared:
//! `../../shared/realdata/hilti-jaibot-stationing` or `$KINCAL_REALDATA`. Its licence is
//! CC BY-NC-SA 3.0: nothing of it is copied into the repository.
//!
//! Without the folder the tests are skipped with a message, except under `CI=true`, where
//! a missing folder is a failure. Checked: the import (rows per session, the sensor
//! joints' readings against the test's own tilt of the raw accelerations) and every figure
//! of the study table in docs/real-data.md to 2 %; the diagnosis of the set (`kincal
//! diagnose --sigma-pos-mm 0.75`): its verdict, thermal confounded with the sessions, and
//! the figures of docs/real-data.md's diagnosis table to 2 %.

use std::path::{Path, PathBuf};

mod common;
use common::{kincal, kincal_optimised, text};

fn realdata() -> Option<PathBuf> {
    let dir = std::env::var_os("KINCAL_REALDATA").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/realdata"),
        PathBuf::from,
    );
    if dir.is_dir() {
        return Some(dir.join("hilti-jaibot-stationing"));
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

/// Whether an optimised `kincal` is at hand: this test binary is optimised, or
/// `KINCAL_RELEASE_BIN` names a release CLI (scripts/test.sh builds one first and sets it).
/// Without one the slow studies are skipped with a message, except under `CI=true`.
fn optimised_or_skip() -> bool {
    if !cfg!(debug_assertions) || std::env::var_os("KINCAL_RELEASE_BIN").is_some() {
        return true;
    }
    let msg = "the Hilti study needs an optimised kincal: set KINCAL_RELEASE_BIN to a release \
               build of the CLI, or run the test with --release";
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("{msg}; CI=true: the real-data tests must run");
    }
    eprintln!("skipping: {msg}");
    false
}

fn close(got: f64, want: f64, what: &str) {
    assert!(
        (got - want).abs() <= 0.02 * want.abs(),
        "{what}: {got} differs from docs/real-data.md's {want} by more than 2 %"
    );
}

/// The numbers after `label` on the line that starts with it.
fn numbers_after(out: &str, label: &str) -> Vec<f64> {
    let line = out
        .lines()
        .find(|l| l.starts_with(label))
        .unwrap_or_else(|| panic!("no line '{label}' in\n{out}"));
    line[label.len()..]
        .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .filter_map(|t| t.parse::<f64>().ok())
        .collect()
}

/// Imports the set (with the study when `study`), checks the import and returns the text.
fn import_hilti(src: &Path, dir: &Path, study: bool) -> String {
    let run = if study { kincal_optimised } else { kincal };
    let mut args = vec![
        "import-dataset",
        "hilti",
        src.to_str().unwrap(),
        "--out",
        "data.csv",
        "--robot-out",
        "robot.toml",
    ];
    if study {
        args.push("--study");
    }
    let o = run(&args, dir);
    let out = text(&o);
    assert!(o.status.success(), "{out}");
    check_import(&out, dir);
    out
}

/// The numbers of the study table's row for `session` (its first word is the session's
/// name and its second a number: "flat in-sample: ..." is not the `flat` row).
fn session_row(out: &str, session: &str) -> Vec<f64> {
    let line = out
        .lines()
        .find(|l| {
            let mut words = l.split_whitespace();
            words.next() == Some(session) && words.next().is_some_and(|w| w.parse::<f64>().is_ok())
        })
        .unwrap_or_else(|| panic!("no study row for '{session}' in\n{out}"));
    numbers_after(line, session)
}

#[test]
fn hilti_imports_sessions_with_sensor_joints() {
    let Some(src) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    import_hilti(&src, dir.path(), false);
}

/// The study took 63 s in a release build (load average 23 on 2 cores) and far longer unoptimised,
/// so it runs the optimised CLI (`optimised_or_skip`); docs/real-data.sh reruns the same
/// figures.
#[test]
fn hilti_study_matches_the_docs() {
    let Some(src) = realdata().filter(|_| optimised_or_skip()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = import_hilti(&src, dir.path(), true);
    study_matches_the_docs(&out);
}

/// `kincal diagnose` on the imported set with the total station's stated noise (about
/// 20 s of one core in release): the verdict, the thermal candidate confounded with the
/// sessions (input constant within each session) and never chosen, and the figures of
/// docs/real-data.md's Hilti diagnosis table.
#[test]
fn hilti_diagnosis_matches_the_docs() {
    let Some(src) = realdata().filter(|_| optimised_or_skip()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    import_hilti(&src, dir.path(), false);
    let o = kincal_optimised(
        &[
            "diagnose",
            "data.csv",
            "--robot",
            "robot.toml",
            "--sigma-pos-mm",
            "0.75",
            "--json",
            "REPORT.json",
            "--out",
            "model.json",
        ],
        dir.path(),
    );
    let out = text(&o);
    assert!(o.status.success(), "{out}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("REPORT.json")).unwrap())
            .unwrap();
    let v = &r["verdict"];
    assert_eq!(v["status"], DOC_DIAG_STATUS, "{v}");
    assert_eq!(v["effects"], serde_json::json!(DOC_DIAG_EFFECTS), "{v}");
    let thermal = r["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["effects"] == serde_json::json!(["thermal"]))
        .unwrap_or_else(|| panic!("no thermal candidate in {r}"));
    assert_eq!(
        thermal["confounded_with"],
        serde_json::json!(["session_frame"])
    );
    assert_eq!(thermal["session"]["input_constant_within_sessions"], true);
    assert!(
        v["confounded_with_sessions"]
            .as_array()
            .unwrap()
            .contains(&serde_json::json!("thermal")),
        "{v}"
    );
    assert!(
        v["separate_by"]
            .as_str()
            .is_some_and(|s| s.contains("two temperatures within one session")),
        "{v}"
    );
    assert!(out.contains("confounded with the session frame"), "{out}");
    let f = |x: &serde_json::Value| x.as_f64().unwrap();
    close(
        f(&r["baseline"]["heldout_rms_pos_mm"]),
        DOC_DIAG_GEOMETRIC_MM,
        "geometric held out",
    );
    close(
        f(&v["heldout_rms_pos_mm"]),
        DOC_DIAG_VERDICT_MM,
        "verdict held out",
    );
    close(
        f(&thermal["heldout_rms_pos_mm"]),
        DOC_DIAG_THERMAL_MM,
        "thermal held out",
    );
    let by_session = r["where"]["by"]
        .as_array()
        .unwrap()
        .iter()
        .find(|b| b["by"] == "session")
        .unwrap_or_else(|| panic!("no session breakdown in {r}"));
    for (name, geo, verdict) in DOC_DIAG_SESSIONS {
        let bin = by_session["bins"]
            .as_array()
            .unwrap()
            .iter()
            .find(|b| b["label"] == name)
            .unwrap_or_else(|| panic!("no session {name} in {by_session}"));
        close(f(&bin["geometric_mm"]), geo, &format!("{name}: geometric"));
        close(f(&bin["verdict_mm"]), verdict, &format!("{name}: verdict"));
    }
}

fn check_import(out: &str, dir: &Path) {
    assert!(
        out.contains("3090 poses, 11 joints, positions only"),
        "{out}"
    );
    let robot = std::fs::read_to_string(dir.join("robot.toml")).unwrap();
    assert_eq!(robot.matches("type = \"sensor\"").count(), 4, "{robot}");
    assert_eq!(robot.matches("type = \"prismatic\"").count(), 1, "{robot}");

    // The first row of flat.yaml: the test's own tilts from the raw accelerations.
    let csv = std::fs::read_to_string(dir.join("data.csv")).unwrap();
    let mut lines = csv.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let first: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| -> f64 {
        let i = header.iter().position(|h| *h == n).unwrap();
        first[i].parse().unwrap()
    };
    let base = [
        -0.022369499504566192_f64,
        0.08970485925674439,
        9.80731496810913,
    ];
    let column = [
        0.016074942890554667_f64,
        -0.08326615765690804,
        9.807277997334799,
    ];
    let tilt = |a: [f64; 3]| [a[1].atan2(a[2]), (-a[0]).atan2(a[2])];
    let (tb, tc) = (tilt(base), tilt(column));
    assert!((col("q1") - tb[0]).abs() < 1e-15 && (col("q2") - tb[1]).abs() < 1e-15);
    assert!((col("q3") - 1.979983608937645).abs() < 1e-15);
    assert!((col("q4") - (tc[0] - tb[0])).abs() < 1e-15);
    assert!((col("q5") - (tc[1] - tb[1])).abs() < 1e-15);
    assert!((col("x") - 7.332081008983251).abs() < 1e-15);
    let sess = header.iter().position(|h| *h == "session").unwrap();
    assert_eq!(first[sess], "flat");
    let n_outdoor = csv.lines().filter(|l| l.contains(",outdoor,")).count();
    assert_eq!(n_outdoor, 80 + 369);
}

/// The study tables of docs/real-data.md.
fn study_matches_the_docs(out: &str) {
    assert!(
        out.contains(&format!("final model: {DOC_FINAL_MODEL}")),
        "{out}"
    );
    let ins = numbers_after(out, "flat in-sample:");
    close(ins[0], DOC_FLAT_GEOMETRY_MM, "flat in-sample, geometry");
    close(
        ins[1],
        DOC_FLAT_SENSORS_MM,
        "flat in-sample, geometry + sensors",
    );
    let held = numbers_after(out, "flat held-out (5 folds): geometry + sensor joints");
    close(held[0], DOC_FLAT_HELD_OUT_MM, "flat held out");
    let gains = numbers_after(out, "gains 1+k (column bending x, y):");
    close(gains[0], DOC_GAINS[0], "bending gain x");
    close(gains[1], DOC_GAINS[1], "bending gain y");
    for (name, cad, geo, sensors, loso) in DOC_SESSIONS {
        let v = session_row(out, name);
        close(v[0], cad, &format!("{name}: CAD + rigid base"));
        if name == "flat" {
            close(v[1], loso, "flat: leave one session out");
        } else {
            close(v[1], geo, &format!("{name}: geometry"));
            close(v[2], sensors, &format!("{name}: geometry + sensors"));
            close(v[3], loso, &format!("{name}: leave one session out"));
        }
    }
    numbered_lines_close(out, "variant", &DOC_VARIANTS);
    numbered_lines_close(out, "level", &DOC_LEVEL);
}

// The diagnosis figures docs/real-data.md states (held-out RMS |Δp| in mm).
const DOC_DIAG_STATUS: &str = "partially_explained";
const DOC_DIAG_EFFECTS: [&str; 2] = ["joint_scale", "joint_cyclic"];
const DOC_DIAG_GEOMETRIC_MM: f64 = 1.789;
const DOC_DIAG_VERDICT_MM: f64 = 1.274;
const DOC_DIAG_THERMAL_MM: f64 = 1.788;
const DOC_DIAG_SESSIONS: [(&str, f64, f64); 7] = [
    ("flat", 1.74, 1.37),
    ("outdoor", 1.57, 1.27),
    ("pallet", 1.70, 1.27),
    ("orthogonal_wood", 1.45, 1.06),
    ("wood_left_track", 1.61, 0.99),
    ("seesaw", 2.57, 1.77),
    ("diagonal_wood", 1.68, 1.01),
];

// The figures docs/real-data.md states (RMS |Δp| in mm).
const DOC_FINAL_MODEL: &str = "base tilt at gain 1, 2 bending gains";
const DOC_FLAT_GEOMETRY_MM: f64 = 3.47;
const DOC_FLAT_SENSORS_MM: f64 = 1.28;
const DOC_FLAT_HELD_OUT_MM: f64 = 1.30;
const DOC_GAINS: [f64; 2] = [2.218, 1.184];
/// Session, CAD + rigid base, geometry (flat), final model (flat), leave one session out.
const DOC_SESSIONS: [(&str, f64, f64, f64, f64); 7] = [
    ("flat", 9.30, 0.0, 0.0, 1.83),
    ("outdoor", 8.82, 3.56, 1.60, 1.60),
    ("pallet", 9.65, 4.11, 2.25, 1.79),
    ("orthogonal_wood", 9.18, 3.88, 1.70, 1.41),
    ("wood_left_track", 10.96, 5.22, 2.78, 1.62),
    ("seesaw", 10.52, 5.62, 3.65, 2.96),
    ("diagonal_wood", 9.53, 4.29, 2.23, 1.71),
];
/// The variants' rows (kincal-io `hilti_study::VARIANTS` order): flat in-sample, flat held
/// out, outdoor, pallet, orthogonal_wood, wood_left_track, seesaw, diagonal_wood.
const DOC_VARIANTS: [[f64; 8]; 5] = [
    [1.22, 1.25, 1.75, 2.71, 2.15, 12.47, 7.34, 3.78],
    [1.28, 1.30, 1.60, 2.25, 1.70, 2.78, 3.65, 2.23],
    [3.98, 4.07, 3.54, 3.80, 3.76, 3.75, 4.74, 3.87],
    [1.31, 1.33, 1.61, 2.29, 1.75, 3.81, 3.84, 2.35],
    [0.80, 0.83, 1.30, 1.90, 1.36, 2.05, 2.85, 1.78],
];
/// The variants' rows with a level new frame (kincal-io `hilti_study::LEVEL_VARIANTS`):
/// flat, outdoor, pallet, orthogonal_wood, wood_left_track, seesaw, diagonal_wood.
const DOC_LEVEL: [[f64; 7]; 2] = [
    [1.28, 1.79, 2.27, 2.70, 3.44, 5.78, 3.02],
    [0.80, 3.28, 1.97, 6.80, 4.62, 16.20, 6.49],
];

/// Each line `"{prefix} k: a b c … | …"` of `out` (k from 1) carries the figures of
/// `wants[k - 1]` before its `|`, each within the documented rounding.
fn numbered_lines_close<const K: usize>(out: &str, prefix: &str, wants: &[[f64; K]]) {
    for (i, want) in wants.iter().enumerate() {
        let label = format!("{prefix} {}:", i + 1);
        let line = out
            .lines()
            .find(|l| l.starts_with(&label))
            .unwrap_or_else(|| panic!("no line '{label}' in\n{out}"));
        let got = numbers_after(line.split('|').next().unwrap_or_default(), &label);
        assert_eq!(got.len(), want.len(), "{line}");
        for (g, w) in got.iter().zip(want) {
            close(*g, *w, &format!("{label} {line}"));
        }
    }
}
