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
//! the positioner's import, and TIAGo's refusal without the user's URDF;
//! MUKCa imported for every robot (rows against the raw files, refusals), its nominal and
//! leave-one-location-out consistency (the test's own computation from `kincal predict`),
//! MATE's single-coordinate rows, and `--base-link/--tip-link` on a URDF ROBOT.

use std::path::{Path, PathBuf};

use serde_json::Value;

mod common;
use common::{kincal, text};

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

/// `observed-point data.csv --out obs.csv` as docs/real-data.sh runs it; returns stdout.
fn observed_point(dir: &Path) -> String {
    let o = kincal(&["observed-point", "data.csv", "--out", "obs.csv"], dir);
    assert!(o.status.success(), "{}", text(&o));
    text(&o)
}

/// crossval of `data` as docs/real-data.sh runs it; returns its JSON.
fn crossval_of(dir: &Path, data: &str, extra: &[&str]) -> Value {
    let mut args = vec![
        "crossval",
        data,
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
    if extra.contains(&"--folds") {
        // The caller's fold count replaces the default 5.
        let at = args.iter().position(|a| *a == "--folds").unwrap();
        args.drain(at..at + 2);
    }
    args.extend_from_slice(extra);
    let o = kincal(&args, dir);
    assert!(o.status.success(), "{}", text(&o));
    serde_json::from_str(&std::fs::read_to_string(dir.join("cv.json")).unwrap()).unwrap()
}

/// crossval of the data as imported.
fn crossval(dir: &Path, extra: &[&str]) -> Value {
    crossval_of(dir, "data.csv", extra)
}

/// Held-out RMS (position [mm], rotation [deg]) of the nominal and the calibrated model.
fn held_out(cv: &Value) -> ((f64, f64), (f64, f64)) {
    let get = |m: &str, k: &str| num(cv, &["heldout", m, k]);
    (
        (
            get("nominal", "rms_pos_mm"),
            get("calibrated", "rms_pos_mm"),
        ),
        (
            get("nominal", "rms_rot_deg"),
            get("calibrated", "rms_rot_deg"),
        ),
    )
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
    // The note is prose and wraps at 100 columns: read it with the line breaks taken out.
    let flat = out.split_whitespace().collect::<Vec<_>>().join(" ");
    let line = &flat[flat.find("FK check").expect("FK check note")..];
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

    // At the point the camera looks at (322 mm along its axis), where the position is
    // measured precisely: the gain in position grows to 8.8x.
    let out = observed_point(dir.path());
    assert!(
        out.contains("re-expressed 322.5 mm along z (auto)"),
        "{out}"
    );
    let ((nom_p, cal_p), (nom_r, cal_r)) = held_out(&crossval_of(dir.path(), "obs.csv", &[]));
    assert!(cal_p < 0.2 * nom_p, "{cal_p} mm vs {nom_p} mm");
    assert!(cal_r < 0.5 * nom_r, "{cal_r}° vs {nom_r}°");
    close(
        nom_p,
        6.459,
        "FR3 nominal held-out RMS position at the observed point [mm]",
    );
    close(
        cal_p,
        0.738,
        "FR3 calibrated held-out RMS position at the observed point [mm]",
    );
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
    // 4.974 mm while fold 2's OLS fit stopped "converged" at cost 135.66 on a crawl (every
    // cut of a step 1857 times the parameters' norm failed); OLS now hands such a fit to
    // OPT2's trust region and reaches the fold's minimum, 62.54 (kincal::identify solvers,
    // core/tests/ols_stop.rs). Every fold is still OLS's own fit. At that fold's minimum
    // the tool's rx is data-deficient (the analysis's test repeated at the fitted model,
    // core/src/identify/at_fit.rs): held, the fold's held-out error 4.6995 → 4.7040 mm, all
    // folds 4.2462 → 4.2473 mm and 0.4485° → 0.4494°.
    close(cal_p, 4.247, "UR10e calibrated held-out RMS position [mm]");
    let algorithms: Vec<&str> = cv["per_fold"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["algorithm"].as_str().unwrap())
        .collect();
    assert_eq!(algorithms, ["ols"; 5]);
    close(nom_r, 0.6006, "UR10e nominal held-out RMS rotation [deg]");
    close(
        cal_r,
        0.4494,
        "UR10e calibrated held-out RMS rotation [deg]",
    );
    assert_eq!(cv["outliers"]["suspects"].as_array().unwrap().len(), 2);
}

#[test]
fn ur10e_held_out_residual_clearly_below_nominal_at_the_observed_point() {
    let Some(root) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    import(&root, "figaroh-ur10e", dir.path());
    // The camera's axes converge 486 mm ahead (within 24 mm RMS): its position carries the
    // orientation noise times 0.49 m; re-expressed there, the calibration gains 2.5x.
    let out = observed_point(dir.path());
    assert!(
        out.contains("re-expressed 485.5 mm along z (auto)"),
        "{out}"
    );
    assert!(out.contains("miss RMS 23.7 mm"), "{out}");
    let cv = crossval_of(dir.path(), "obs.csv", &[]);
    let ((nom_p, cal_p), (nom_r, cal_r)) = held_out(&cv);
    assert!(cal_p < 0.5 * nom_p, "{cal_p} mm vs {nom_p} mm");
    assert!(cal_r < 0.85 * nom_r, "{cal_r}° vs {nom_r}°");
    close(
        nom_p,
        4.566,
        "UR10e nominal held-out RMS position at the observed point [mm]",
    );
    close(
        cal_p,
        1.789,
        "UR10e calibrated held-out RMS position at the observed point [mm]",
    );
    close(nom_r, 0.6012, "UR10e nominal held-out RMS rotation [deg]");
    close(
        cal_r,
        0.4446,
        "UR10e calibrated held-out RMS rotation [deg]",
    );
    // Leave-one-out agrees.
    let ((nom_p, cal_p), _) = held_out(&crossval_of(dir.path(), "obs.csv", &["--folds", "23"]));
    assert!(
        cal_p < 0.5 * nom_p,
        "leave-one-out: {cal_p} mm vs {nom_p} mm"
    );
}

#[test]
fn talos_position_only_calibrates_with_its_identifiability_report() {
    let Some(root) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = import(&root, "figaroh-talos-arm", dir.path());
    assert!(out.contains("61 poses, 9 joints, positions only"), "{out}");
    assert!(!out.contains("held at 0"), "{out}");
    let data = std::fs::read_to_string(dir.path().join("data.csv")).unwrap();
    let header = data.lines().find(|l| !l.starts_with('#')).unwrap();
    assert_eq!(header, "pose_id,q1,q2,q3,q4,q5,q6,q7,q8,q9,x,y,z");
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
    assert!(t.contains("identifiable:           39"), "{t}");
    assert!(t.contains("structurally redundant: 9"), "{t}");
    let cv = crossval(dir.path(), &[]);
    let (nom_p, cal_p) = (
        num(&cv, &["heldout", "nominal", "rms_pos_mm"]),
        num(&cv, &["heldout", "calibrated", "rms_pos_mm"]),
    );
    assert!(cal_p < 0.25 * nom_p, "{cal_p} mm vs {nom_p} mm");
    close(nom_p, 5.455, "TALOS nominal held-out RMS position [mm]");
    close(cal_p, 0.760, "TALOS calibrated held-out RMS position [mm]");
    assert!(cv["heldout"]["calibrated"]["rms_rot_deg"].is_null());
}

#[test]
fn positioner_imports_and_tiago_without_its_urdf_is_a_usage_error() {
    let Some(root) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = import(&root, "ical-2axis-positioner", dir.path());
    assert!(out.contains("205 poses, 2 joints, full poses"), "{out}");
    {
        // TIAGo needs the user's URDF (not shipped): a usage error saying where to get it.
        let name = "figaroh-tiago-mocap";
        let src = root.join(name);
        let o = kincal(
            &[
                "import-dataset",
                "tiago",
                src.to_str().unwrap(),
                "--out",
                "x.csv",
            ],
            dir.path(),
        );
        assert_eq!(o.status.code(), Some(2), "{name}: {}", text(&o));
        assert!(
            text(&o).contains("tiago_description"),
            "{name}: {}",
            text(&o)
        );
        assert!(!dir.path().join("x.csv").exists());
    }
}

/// `import-dataset mukca --robot-id ID` into `dir` as ID.csv / ID.toml / ID-constraints.toml.
fn import_mukca(root: &Path, id: &str, dir: &Path) -> String {
    let src = root.join("mukca");
    let (csv, toml, cons) = (
        format!("{id}.csv"),
        format!("{id}.toml"),
        format!("{id}-constraints.toml"),
    );
    let o = kincal(
        &[
            "import-dataset",
            "mukca",
            src.to_str().unwrap(),
            "--robot-id",
            id,
            "--out",
            &csv,
            "--robot-out",
            &toml,
            "--constraints-out",
            &cons,
        ],
        dir,
    );
    assert!(o.status.success(), "{id}: {}", text(&o));
    text(&o)
}

/// The data rows of a written CSV (header, then rows), comments skipped.
fn csv_rows(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let body = std::fs::read_to_string(path).unwrap();
    let mut lines = body.lines().filter(|l| !l.starts_with('#'));
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    (header, rows)
}

#[test]
fn mukca_imports_every_robot_with_sessions_targets_and_distances() {
    let Some(root) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    // (id, joints, locations, rows: the hole_0 + hole_1 lines of its folders)
    for (id, n, locations, rows) in [
        ("panda_1", 7, 3, 182),
        ("panda_1_with_sensor", 7, 2, 120),
        ("kuka_14", 7, 3, 180),
        ("dinova_1", 6, 4, 137),
        ("dinova_2", 6, 4, 181),
    ] {
        let out = import_mukca(&root, id, dir.path());
        assert!(
            out.contains(&format!("{rows} rows ({locations} locations")),
            "{id}: {out}"
        );
        let (header, data) = csv_rows(&dir.path().join(format!("{id}.csv")));
        let mut want = vec!["pose_id", "session", "target"]
            .into_iter()
            .map(str::to_string)
            .collect::<Vec<_>>();
        want.extend((1..=n).map(|k| format!("q{k}")));
        assert_eq!(header, want, "{id}");
        assert_eq!(data.len(), rows, "{id}");
        // Every row against its raw line: pose_id LOCATION/sK/LINE names hole_K.csv's line.
        for r in data.iter().step_by(7) {
            let parts: Vec<&str> = r[0].split('/').collect();
            let (loc, socket, line) = (parts[0], parts[1], parts[2].parse::<usize>().unwrap());
            assert_eq!(r[1], loc, "{id}: session");
            assert_eq!(r[2], format!("{loc}/{socket}"), "{id}: target");
            let raw = std::fs::read_to_string(
                root.join(format!("mukca/data/{id}/{loc}/hole_{}.csv", &socket[1..])),
            )
            .unwrap();
            let raw_q: Vec<f64> = raw
                .lines()
                .nth(line - 1)
                .unwrap()
                .split(',')
                .map(|v| v.trim().parse().unwrap())
                .collect();
            let got: Vec<f64> = r[3..].iter().map(|v| v.parse().unwrap()).collect();
            assert_eq!(got, raw_q, "{id}: {} differs from the raw file", r[0]);
        }
        let cons =
            std::fs::read_to_string(dir.path().join(format!("{id}-constraints.toml"))).unwrap();
        let t: toml::Value = toml::from_str(&cons).unwrap();
        let d = t["distance"].as_array().unwrap();
        assert_eq!(d.len(), locations, "{id}");
        for e in d {
            assert_eq!(e["m"].as_float(), Some(0.05));
            let b = e["between"].as_array().unwrap();
            let (s0, s1) = (b[0].as_str().unwrap(), b[1].as_str().unwrap());
            assert_eq!(
                s0.strip_suffix("/s0"),
                s1.strip_suffix("/s1"),
                "{id}: {s0} {s1}"
            );
        }
    }
    // The robot file is the URDF chain up to the ball: panda.urdf's ball_joint (30.1 mm below
    // the TCP) is the tool point.
    let robot = std::fs::read_to_string(dir.path().join("panda_1.toml")).unwrap();
    assert!(robot.contains("panda.urdf"), "{robot}");
}

#[test]
fn mukca_refuses_missing_ids_files_and_bad_numbers() {
    let Some(root) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    let src = root.join("mukca");
    let run = |args: &[&str]| {
        let mut a = vec!["import-dataset", "mukca"];
        a.extend_from_slice(args);
        kincal(&a, dir.path())
    };
    let s = src.to_str().unwrap();
    let o = run(&[s, "--out", "x.csv", "--constraints-out", "c.toml"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--robot-id is required") && text(&o).contains("panda_1"));
    let o = run(&[
        s,
        "--robot-id",
        "panda_9",
        "--out",
        "x.csv",
        "--constraints-out",
        "c.toml",
    ]);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    assert!(text(&o).contains("panda_9"), "{}", text(&o));
    let o = run(&[s, "--robot-id", "panda_1", "--out", "x.csv"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--constraints-out"), "{}", text(&o));
    // A copy with a missing hole_1.csv and one with a bad number.
    let copy = dir.path().join("mukca");
    let loc = copy.join("data/panda_1/front");
    std::fs::create_dir_all(&loc).unwrap();
    std::fs::create_dir_all(copy.join("urdf")).unwrap();
    std::fs::copy(src.join("urdf/panda.urdf"), copy.join("urdf/panda.urdf")).unwrap();
    let raw = std::fs::read_to_string(src.join("data/panda_1/front/hole_0.csv")).unwrap();
    std::fs::write(loc.join("hole_0.csv"), &raw).unwrap();
    let c = copy.to_str().unwrap();
    let args = [
        c,
        "--robot-id",
        "panda_1",
        "--out",
        "x.csv",
        "--constraints-out",
        "c.toml",
    ];
    let o = run(&args);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    assert!(text(&o).contains("hole_1.csv"), "{}", text(&o));
    let bad = raw.replacen(',', ",nan_x,", 1);
    std::fs::write(loc.join("hole_1.csv"), raw.clone()).unwrap();
    std::fs::write(loc.join("hole_0.csv"), bad).unwrap();
    let o = run(&args);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    assert!(text(&o).contains("hole_0.csv:1: 8 values"), "{}", text(&o));
    let bad = raw.replacen("e+00,", "e+00,x", 1);
    std::fs::write(loc.join("hole_0.csv"), bad).unwrap();
    let o = run(&args);
    assert!(
        text(&o).contains("hole_0.csv:1:2: expected a finite joint reading"),
        "{}",
        text(&o)
    );
    assert!(!dir.path().join("x.csv").exists());
}

#[test]
fn mate_imports_single_coordinate_contacts_and_poses() {
    let Some(root) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = import(&root, "figaroh-mate-planes", dir.path());
    assert!(out.contains("40 rows (30 plane contacts"), "{out}");
    let (header, rows) = csv_rows(&dir.path().join("data.csv"));
    assert_eq!(
        header,
        [
            "pose_id",
            "q1",
            "q2",
            "q3",
            "x",
            "y",
            "z",
            "roll_deg",
            "pitch_deg",
            "yaw_deg"
        ]
    );
    // Raw first rows: x: 0.3044,102.93,18.17,55.512 (deg); z: -0.004,-35.02,45.84,113.976.
    // q_1 is negated (the files' q_1 turns the other way than mate.urdf's axis).
    let x2 = &rows[0];
    assert_eq!(x2[0], "x/2");
    assert!((x2[1].parse::<f64>().unwrap() + 102.93_f64.to_radians()).abs() < 1e-15);
    assert!((x2[2].parse::<f64>().unwrap() - 18.17_f64.to_radians()).abs() < 1e-12);
    assert_eq!(
        (x2[4].as_str(), x2[5].as_str(), x2[6].as_str()),
        ("0.3044", "", "")
    );
    let z2 = rows.iter().find(|r| r[0] == "z/2").unwrap();
    assert!((z2[3].parse::<f64>().unwrap() - 113.976_f64.to_radians()).abs() < 1e-15);
    assert_eq!(
        (z2[4].as_str(), z2[5].as_str(), z2[6].as_str()),
        ("", "", "-0.004")
    );
    let p = rows.iter().filter(|r| r[0].starts_with("pose/")).count();
    assert_eq!(p, 10);
}

/// MATE's 30 single-coordinate plane contacts with mate.urdf's own base frame: 5-fold
/// held-out rows (docs/real-data.md, "MATE"), and the evidence for the q_1 sign: at the
/// nominal model the x-plane contacts lie at x = 0.3029 m (the file: 0.3044).
#[test]
fn mate_plane_contacts_calibrate_held_out() {
    let Some(root) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    import(&root, "figaroh-mate-planes", dir.path());
    let text_in = std::fs::read_to_string(dir.path().join("data.csv")).unwrap();
    let planes: String = text_in
        .lines()
        .filter(|l| !l.starts_with("pose/"))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(dir.path().join("planes.csv"), planes).unwrap();
    let o = kincal(
        &[
            "crossval",
            "planes.csv",
            "--robot",
            "robot.toml",
            "--folds",
            "5",
            "--seed",
            "1",
            "--allow-out-of-limits",
            "--json",
            "cv.json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
    let cv: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("cv.json")).unwrap())
            .unwrap();
    let nominal = num(&cv, &["heldout", "nominal", "rms_pos_mm"]);
    let calibrated = num(&cv, &["heldout", "calibrated", "rms_pos_mm"]);
    close(nominal, 14.670, "MATE nominal held-out RMS [mm]");
    close(calibrated, 3.624, "MATE calibrated held-out RMS [mm]");
    // The x-plane contacts at the nominal model: mean predicted x.
    let (_, rows) = csv_rows(&dir.path().join("data.csv"));
    let x_rows: Vec<Vec<String>> = rows
        .iter()
        .filter(|r| r[0].starts_with("x/"))
        .cloned()
        .collect();
    let mut csv = String::from("q1,q2,q3\n");
    for r in &x_rows {
        csv.push_str(&format!("{},{},{}\n", r[1], r[2], r[3]));
    }
    std::fs::write(dir.path().join("q.csv"), csv).unwrap();
    let o = kincal(
        &[
            "predict",
            "robot.toml",
            "q.csv",
            "--out",
            "p.csv",
            "--allow-out-of-limits",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
    let (header, pred) = csv_rows(&dir.path().join("p.csv"));
    let xc = header
        .iter()
        .position(|h| h == "x" || h == "x_m")
        .expect("x column");
    let mean_x = pred
        .iter()
        .map(|r| r[xc].parse::<f64>().unwrap())
        .sum::<f64>()
        / pred.len() as f64;
    assert!((mean_x - 0.3029).abs() < 5e-4, "mean x {mean_x}");
    // calibrate on the single-coordinate rows: the residual table gives |e| over the given
    // coordinate of each row (it printed 0.000000 before, the rows having no full position)
    // and a dash for the orientation, which no row measures.
    let o = kincal(
        &[
            "calibrate",
            "planes.csv",
            "--robot",
            "robot.toml",
            "--allow-out-of-limits",
            "--out",
            "model.json",
        ],
        dir.path(),
    );
    let out = text(&o);
    assert!(o.status.success(), "{out}");
    let cells = |prefix: &str| -> Vec<String> {
        let line = out
            .lines()
            .find(|l| l.trim_start().starts_with(prefix))
            .unwrap_or_else(|| panic!("no {prefix:?} row in {out}"));
        line.split("  ")
            .map(str::trim)
            .filter(|c| !c.is_empty())
            .map(str::to_string)
            .collect()
    };
    let before = cells("before (initial)");
    let after = cells("after OLS");
    let rms = |c: &[String]| c[1].parse::<f64>().unwrap();
    // The nominal in-sample RMS is crossval's nominal figure (the same rows, no fit).
    close(rms(&before), 14.670, "MATE nominal in-sample RMS [mm]");
    assert!(rms(&after) > 0.5 && rms(&after) < 2.0, "{out}");
    assert_eq!((before[3].as_str(), after[4].as_str()), ("-", "-"), "{out}");
    // validate's per-pose table: a y-plane contact has e_y only (dashes for x and z), and
    // |e_p| is |e_y|.
    let o = kincal(
        &[
            "validate",
            "model.json",
            "planes.csv",
            "--allow-out-of-limits",
        ],
        dir.path(),
    );
    let out = text(&o);
    assert!(o.status.success(), "{out}");
    let row: Vec<&str> = out
        .lines()
        .find(|l| l.trim_start().starts_with("y/"))
        .unwrap_or_else(|| panic!("no y/ row in {out}"))
        .split_whitespace()
        .collect();
    assert_eq!((row[1], row[3]), ("-", "-"), "{out}");
    let e_y: f64 = row[2].parse().unwrap();
    let norm: f64 = row[4].parse().unwrap();
    assert!(e_y != 0.0 && (e_y.abs() - norm).abs() < 2e-6, "{out}");
}

#[test]
fn urdf_robot_arguments_take_base_and_tip_links() {
    let Some(root) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    let urdf = root.join("mukca/urdf/panda.urdf");
    let u = urdf.to_str().unwrap();
    std::fs::write(
        dir.path().join("q.csv"),
        "q1,q2,q3,q4,q5,q6,q7\n0,0,0,-1.5,0,1.5,0\n",
    )
    .unwrap();
    // Without a tip link the Panda's tree (fingers, ball) is refused, naming the leaves.
    let o = kincal(&["predict", u, "q.csv", "--out", "p.csv"], dir.path());
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    assert!(text(&o).contains("choose a tip link") && text(&o).contains("ball_link"));
    let o = kincal(
        &[
            "predict",
            u,
            "q.csv",
            "--out",
            "p.csv",
            "--tip-link",
            "ball_link",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
    let (_, rows) = csv_rows(&dir.path().join("p.csv"));
    // (The 4×4 FK agreement of this chain is checked in the URDF unit tests.)
    assert_eq!(rows.len(), 1);
    // A chain that does not exist: exit 3, naming both links and the URDF line.
    let o = kincal(
        &[
            "predict",
            u,
            "q.csv",
            "--out",
            "p.csv",
            "--base-link",
            "panda_hand",
            "--tip-link",
            "panda_link3",
        ],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    let t = text(&o);
    assert!(
        t.contains("panda_link3") && t.contains("panda_hand") && t.contains("panda.urdf:"),
        "{t}"
    );
    // The flags on a robot that is not a URDF: a usage error.
    let o = kincal(
        &[
            "predict",
            "aria",
            "q.csv",
            "--out",
            "p.csv",
            "--tip-link",
            "x",
        ],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
}

/// Consistency of predicted ball centres per target, from `predict`'s x, y, z: (mean
/// absolute distance to the target's mean [mm], mean over targets of the RMS [mm], mean
/// |distance − 50 mm|
/// between each session's two targets [mm]). The test's own implementation, independent of
/// `kincal validate`.
fn consistency(targets: &[String], xyz: &[[f64; 3]]) -> (f64, f64, f64) {
    let mut groups: std::collections::BTreeMap<&str, Vec<[f64; 3]>> = Default::default();
    for (t, p) in targets.iter().zip(xyz) {
        groups.entry(t.as_str()).or_default().push(*p);
    }
    let mean = |ps: &[[f64; 3]]| {
        let n = ps.len() as f64;
        [0, 1, 2].map(|k| ps.iter().map(|p| p[k]).sum::<f64>() / n)
    };
    let dist = |a: [f64; 3], b: [f64; 3]| {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let means: std::collections::BTreeMap<&str, [f64; 3]> =
        groups.iter().map(|(t, ps)| (*t, mean(ps))).collect();
    let d: Vec<f64> = groups
        .iter()
        .flat_map(|(t, ps)| ps.iter().map(|p| dist(*p, means[t])))
        .collect();
    let mean_abs = d.iter().sum::<f64>() / d.len() as f64;
    // `kincal validate`'s "mean RMS": the mean over targets of each target's RMS scatter.
    let rms = groups
        .iter()
        .map(|(t, ps)| {
            (ps.iter().map(|p| dist(*p, means[t]).powi(2)).sum::<f64>() / ps.len() as f64).sqrt()
        })
        .sum::<f64>()
        / groups.len() as f64;
    let dist_err: Vec<f64> = means
        .iter()
        .filter_map(|(t, m)| {
            let s1 = means.get(format!("{}/s1", t.strip_suffix("/s0")?).as_str())?;
            Some((dist(*m, *s1) - 0.05).abs())
        })
        .collect();
    let de = dist_err.iter().sum::<f64>() / dist_err.len() as f64;
    (mean_abs * 1e3, rms * 1e3, de * 1e3)
}

/// Predicted ball centres of `rows` (MUKCa CSV rows: pose_id, session, target, q…) by MODEL.
fn predict_points(dir: &Path, model: &str, rows: &[Vec<String>], tag: &str) -> Vec<[f64; 3]> {
    let n = rows[0].len() - 3;
    let mut q = (1..=n)
        .map(|k| format!("q{k}"))
        .collect::<Vec<_>>()
        .join(",");
    q.push('\n');
    for r in rows {
        q.push_str(&r[3..].join(","));
        q.push('\n');
    }
    let (qf, pf) = (format!("{tag}-q.csv"), format!("{tag}-p.csv"));
    std::fs::write(dir.join(&qf), q).unwrap();
    let o = kincal(
        &["predict", model, &qf, "--out", &pf, "--allow-out-of-limits"],
        dir,
    );
    assert!(o.status.success(), "{}", text(&o));
    let (h, p) = csv_rows(&dir.join(&pf));
    let col = |c: &str| h.iter().position(|x| x == c).unwrap();
    let (x, y, z) = (col("x"), col("y"), col("z"));
    p.iter()
        .map(|r| {
            [
                r[x].parse().unwrap(),
                r[y].parse().unwrap(),
                r[z].parse().unwrap(),
            ]
        })
        .collect()
}

#[test]
fn mukca_nominal_consistency_per_location() {
    let Some(root) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    // Nominal (URDF) scatter of the predicted ball centre per socket, per location of
    // panda_1, mean |p − p̄| [mm]: an independent URDF forward kinematics (Python, 4×4 chain of
    // the URDF's origins and axes) gives 7.459, 10.338, 7.987 mm; MUKCa's README states
    // 8.28 mm (train) and 7.79 mm (test) for its Panda.
    import_mukca(&root, "panda_1", dir.path());
    let (_, rows) = csv_rows(&dir.path().join("panda_1.csv"));
    for (loc, want) in [("back-high", 7.459), ("front", 10.338), ("right", 7.987)] {
        let sub: Vec<Vec<String>> = rows.iter().filter(|r| r[1] == loc).cloned().collect();
        let targets: Vec<String> = sub.iter().map(|r| r[2].clone()).collect();
        let xyz = predict_points(dir.path(), "panda_1.toml", &sub, loc);
        let (mean_abs, rms, _) = consistency(&targets, &xyz);
        assert!(
            (mean_abs - want).abs() < 0.0015,
            "{loc}: {mean_abs} mm, want {want}"
        );
        assert!(rms >= mean_abs);
    }
}
/// Leave-one-location-out on MUKCa robot `id`: per held-out location, nominal and
/// calibrated consistency of the held-out rows (see [`consistency`]).
type Fold = (String, (f64, f64, f64), (f64, f64, f64));

fn mukca_leave_one_location_out(root: &Path, id: &str, dir: &Path, extra: &[&str]) -> Vec<Fold> {
    import_mukca(root, id, dir);
    let (header, rows) = csv_rows(&dir.join(format!("{id}.csv")));
    let mut locations: Vec<String> = rows.iter().map(|r| r[1].clone()).collect();
    locations.dedup();
    let mut folds = Vec::new();
    for loc in &locations {
        let (test, train): (Vec<_>, Vec<_>) = rows.iter().cloned().partition(|r| &r[1] == loc);
        let tag = format!("{id}-{loc}");
        let mut csv = header.join(",") + "\n";
        for r in &train {
            csv.push_str(&r.join(","));
            csv.push('\n');
        }
        std::fs::write(dir.join(format!("{tag}-train.csv")), csv).unwrap();
        let mut cons = String::new();
        for l in locations.iter().filter(|l| *l != loc) {
            cons.push_str(&format!(
                "[[distance]]\nbetween = [\"{l}/s0\", \"{l}/s1\"]\nm = 0.05\n\n"
            ));
        }
        std::fs::write(dir.join(format!("{tag}-c.toml")), cons).unwrap();
        let (train_f, cons_f, model_f, robot_f) = (
            format!("{tag}-train.csv"),
            format!("{tag}-c.toml"),
            format!("{tag}-model.json"),
            format!("{id}.toml"),
        );
        let mut args = vec![
            "calibrate",
            &train_f,
            "--robot",
            &robot_f,
            "--constraints",
            &cons_f,
            "--out",
            &model_f,
            "--allow-out-of-limits",
        ];
        args.extend_from_slice(extra);
        let o = kincal(&args, dir);
        assert!(o.status.success(), "{tag}: {}", text(&o));
        let targets: Vec<String> = test.iter().map(|r| r[2].clone()).collect();
        let nominal = consistency(&targets, &predict_points(dir, &robot_f, &test, &tag));
        let calibrated = consistency(
            &targets,
            &predict_points(dir, &model_f, &test, &format!("{tag}-cal")),
        );
        folds.push((loc.clone(), nominal, calibrated));
    }
    folds
}

/// Fold means of (nominal, calibrated) × (mean |.|, mean RMS, |distance error|) [mm].
fn fold_means(folds: &[Fold]) -> [[f64; 3]; 2] {
    let n = folds.len() as f64;
    let m = |f: &dyn Fn(&Fold) -> f64| folds.iter().map(f).sum::<f64>() / n;
    [
        [m(&|f| f.1.0), m(&|f| f.1.1), m(&|f| f.1.2)],
        [m(&|f| f.2.0), m(&|f| f.2.1), m(&|f| f.2.2)],
    ]
}

/// docs/real-data.md, "MUKCa": held out by location (leave one location out), the figures
/// of the table to 2 %. The calibrated Panda beats MUKCa's own 0.347 mm (test locations); the
/// Kinova stops near 3 mm with a worse distance than nominal. (An independent MUKCa-style
/// re-implementation — 6-D origin corrections of every joint, pure Python — gave the same
/// panda_1 folds to 0.02 mm: 0.970, 0.659, 0.726 mm against 0.963, 0.673, 0.722 here.)
#[test]
fn mukca_held_out_by_location_beats_the_papers_panda_figure() {
    let Some(root) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    // (id, nominal [mean |.|, mean RMS, |dist err|], calibrated [...]) [mm]
    let cases: [(&str, [f64; 3], [f64; 3]); 4] = [
        ("panda_1", [8.595, 9.313, 2.557], [0.786, 0.842, 0.455]),
        (
            "panda_2_clean",
            [7.849, 8.568, 1.454],
            [0.282, 0.315, 0.187],
        ),
        ("kuka_14", [0.778, 0.832, 0.136], [0.239, 0.268, 0.104]),
        ("dinova_1", [6.212, 6.561, 1.077], [3.233, 3.467, 4.954]),
    ];
    for (id, nominal, calibrated) in cases {
        let folds = mukca_leave_one_location_out(&root, id, dir.path(), &[]);
        let [nom, cal] = fold_means(&folds);
        for k in 0..3 {
            close(nom[k], nominal[k], &format!("{id} nominal [{k}]"));
            close(cal[k], calibrated[k], &format!("{id} calibrated [{k}]"));
        }
    }
}

/// `kincal diagnose` on MUKCa contact data (docs/real-data.md, "A real diagnosis"), held out
/// by location, floor σ = 0.17 mm: the figures of the table to 2 %, and the verdicts.
#[test]
fn mukca_diagnosis_panda_and_kinova() {
    let Some(root) = realdata() else { return };
    let dir = tempfile::tempdir().unwrap();
    let close = |got: f64, want: f64, what: &str| {
        assert!(
            (got - want).abs() <= 0.02 * want.abs().max(0.1),
            "{what}: {got} vs {want}"
        );
    };
    // (id, geometric mean |e|, RMS, |dist err| [mm], gap z, status,
    //  (candidate, mean |e| [mm], paired z))
    for (id, mean, rms, dist, gap, status, cand) in [
        (
            "panda_2_clean",
            0.2810,
            0.3292,
            0.1866,
            6.48,
            "unexplained",
            ("joint_cyclic", 0.2737, 1.71),
        ),
        (
            "dinova_1",
            3.1754,
            3.6864,
            4.9538,
            139.0,
            "unexplained",
            ("joint_compliance", 3.2270, -0.98),
        ),
    ] {
        import_mukca(&root, id, dir.path());
        let json = format!("{id}-diag.json");
        let o = kincal(
            &[
                "diagnose",
                &format!("{id}.csv"),
                "--robot",
                &format!("{id}.toml"),
                "--constraints",
                &format!("{id}-constraints.toml"),
                "--allow-out-of-limits",
                "--sigma-pos-mm",
                "0.17",
                "--json",
                &json,
                "--out",
                "unused.json",
            ],
            dir.path(),
        );
        assert!(o.status.success(), "{id}: {}", text(&o));
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join(&json)).unwrap())
                .unwrap();
        let geo = &v["candidates"][0];
        assert_eq!(geo["effects"].as_array().unwrap().len(), 0, "{id}");
        close(geo["heldout_mean_mm"].as_f64().unwrap(), mean, id);
        close(geo["heldout_rms_mm"].as_f64().unwrap(), rms, id);
        close(geo["distance_error_mm"].as_f64().unwrap(), dist, id);
        close(v["gap_z"].as_f64().unwrap(), gap, id);
        assert_eq!(v["verdict"]["status"], status, "{id}");
        let c = v["candidates"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["effects"] == serde_json::json!([cand.0]))
            .unwrap_or_else(|| panic!("{id}: no {}", cand.0));
        close(c["heldout_mean_mm"].as_f64().unwrap(), cand.1, id);
        close(c["improvement_z"].as_f64().unwrap(), cand.2, id);
        // What the data cannot express is said, not guessed.
        let not: Vec<&str> = v["not_candidates"]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| n["effect"].as_str().unwrap())
            .collect();
        assert!(
            not.contains(&"backlash") && not.contains(&"base_frame"),
            "{id}"
        );
        assert_eq!(
            not.contains(&"joint_compliance"),
            id.starts_with("panda"),
            "{id}"
        );
    }
}
