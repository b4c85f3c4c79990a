//! Instrument rows in several sessions through the CLI (docs/constraints.md, "Sessions
//! with instrument rows"): `calibrate` fits a frame per session after the first, recovers
//! ARIA's virtual truth from noise-free positions measured in three frames metres apart,
//! and reports each session's frame; `validate` judges each later session after fitting
//! only its frame, and `crossval --group-by session` holds out whole sessions.

mod common;

use std::fs;

use common::{kincal, text};
use kincal::pose::{pose_from_vector6, pose_to_vector6, rotation_log};
use kincal::{JointState, Robot, Transform, aria};
use kincal_io::model_file::ModelFile;
use serde_json::Value;

/// Session `s0` in the robot's base frame, `s1` and `s2` in frames moved by metres.
const FRAMES: [[f64; 6]; 3] = [
    [0.0; 6],
    [1.5, -0.4, 0.2, 0.1, -0.2, 0.9],
    [-2.0, 3.0, -0.5, -0.3, 0.2, -1.7],
];

/// The three markers on the tool (tool frame, metres).
const POINTS: [[f64; 3]; 3] = [[0.05, 0.0, 0.0], [0.0, 0.05, 0.0], [0.0, 0.0, 0.05]];

/// Joint readings of pose `k` of session `s`.
fn q_of(k: usize, s: usize) -> [f64; 6] {
    let mut q = aria::TOOL_SEED_Q;
    for (j, v) in q.iter_mut().enumerate() {
        *v += 0.6 * (1.7 * (k + 12 * s) as f64 + 2.3 * j as f64).sin();
    }
    q
}

/// Marker `k % 3` of pose `k` of session `s` as `robot` places it, in the robot's base frame.
fn marker(robot: &Robot<6>, k: usize, s: usize) -> nalgebra::Vector3<f64> {
    let pt = POINTS[k % 3];
    (robot.fk(&JointState::new(q_of(k, s))).unwrap()
        * nalgebra::Translation3::new(pt[0], pt[1], pt[2]))
    .translation
    .vector
}

/// Positions of the markers by ARIA's virtual truth, `rows[s]` poses in session `s`,
/// measured in `FRAMES[s]` (noise-free).
fn csv_sessions(rows: &[usize]) -> String {
    csv_in(&FRAMES, rows)
}

/// [`csv_sessions`] with session `s` measured in `frames[s]`.
fn csv_in(frames: &[[f64; 6]], rows: &[usize]) -> String {
    let truth = aria::virtual_truth();
    let mut out = String::from("q1,q2,q3,q4,q5,q6,point_x,point_y,point_z,x,y,z,session\n");
    for (s, &n) in rows.iter().enumerate() {
        let frame = pose_from_vector6(&frames[s]);
        for k in 0..n {
            let q = q_of(k, s);
            let pt = POINTS[k % 3];
            let p = frame * nalgebra::Point3::from(marker(&truth, k, s));
            let cells: Vec<String> = q.iter().map(|v| format!("{v}")).collect();
            out.push_str(&format!(
                "{},{},{},{},{},{},{},s{s}\n",
                cells.join(","),
                pt[0],
                pt[1],
                pt[2],
                p.x,
                p.y,
                p.z
            ));
        }
    }
    out
}

/// 12 poses in each of the three sessions.
fn csv() -> String {
    csv_sessions(&[12, 12, 12])
}

#[test]
fn calibrate_fits_a_frame_per_session_and_recovers_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("inst.csv"), csv()).unwrap();
    let o = kincal(
        &[
            "calibrate",
            "inst.csv",
            "--robot",
            "aria",
            "--algorithm",
            "ols",
            "--out",
            "m.json",
        ],
        dir.path(),
    );
    let out = text(&o);
    assert_eq!(o.status.code(), Some(0), "{out}");
    assert!(
        out.contains(
            "Session frames: instrument rows of session \"s0\" are in the robot's base frame"
        ),
        "{out}"
    );
    // s1's frame: translation 1500, -400, 200 mm.
    let line = out
        .lines()
        .find(|l| l.trim_start().starts_with("s1 "))
        .expect(&out);
    let v: Vec<f64> = line
        .split_whitespace()
        .skip(2)
        .map(|x| x.parse().unwrap())
        .collect();
    for (got, want) in v.iter().zip([1500.0, -400.0, 200.0]) {
        assert!((got - want).abs() < 1e-3, "{line}");
    }
    let model: Value =
        serde_json::from_str(&fs::read_to_string(dir.path().join("m.json")).unwrap()).unwrap();
    let after = &model["calibration"]["residuals"]["after"];
    let rms = after["rms_pos_mm"].as_f64().expect("rms");
    assert!(rms < 1e-6, "rms {rms} mm: {after}");
    let before = model["calibration"]["residuals"]["before"]["rms_pos_mm"]
        .as_f64()
        .unwrap();
    assert!(
        before > 0.1,
        "the nominal model must not fit already: {before} mm"
    );
    // predict gives the base-frame poses of every row (the sessions' frames are not applied).
    let o = kincal(
        &["predict", "m.json", "inst.csv", "--out", "p.csv"],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert_eq!(
        fs::read_to_string(dir.path().join("p.csv"))
            .unwrap()
            .lines()
            .count(),
        37
    );
    // The robust fit has one base frame: refused (exit 2) rather than silently wrong.
    let o = kincal(
        &[
            "calibrate",
            "inst.csv",
            "--robot",
            "aria",
            "--robust",
            "huber",
            "--out",
            "r.json",
        ],
        dir.path(),
    );
    let out = text(&o);
    assert_eq!(o.status.code(), Some(2), "{out}");
    assert!(
        out.contains("--robust is not implemented for instrument rows in several sessions"),
        "{out}"
    );
}

/// How far apart two frames are: translation [m] and rotation angle [rad].
fn frame_gap(got: &Transform, want: &Transform) -> (f64, f64) {
    let d = got.inverse() * want;
    (
        d.translation.vector.norm(),
        rotation_log(d.rotation.matrix()).norm(),
    )
}

/// The frame of `--json`'s session entry `x` (`None` for the base session).
fn json_frame(x: &Value) -> Option<Transform> {
    let v: Vec<f64> = x["frame"]
        .as_array()?
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    Some(pose_from_vector6(&[v[0], v[1], v[2], v[3], v[4], v[5]]))
}

fn validate_json(dir: &std::path::Path, model: &Robot<6>, name: &str) -> (Value, String) {
    fs::write(
        dir.join(format!("{name}.json")),
        ModelFile::nominal("aria", model).to_json(),
    )
    .unwrap();
    let model_arg = format!("{name}.json");
    let json_arg = format!("{name}-v.json");
    let o = kincal(
        &["validate", &model_arg, "inst.csv", "--json", &json_arg],
        dir,
    );
    let out = text(&o);
    assert_eq!(o.status.code(), Some(0), "{out}");
    let v: Value = serde_json::from_str(&fs::read_to_string(dir.join(&json_arg)).unwrap()).unwrap();
    (v, out)
}

#[test]
fn validate_judges_each_later_session_after_fitting_only_its_frame() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("inst.csv"), csv()).unwrap();
    // The true model: every session fits to rounding, and each frame is the construction's.
    let truth = aria::virtual_truth();
    let (v, out) = validate_json(dir.path(), &truth, "truth");
    assert!(out.contains("Sessions (NOM)"), "{out}");
    let sessions = v["sessions"].as_array().expect("sessions");
    assert_eq!(sessions.len(), 3, "{v}");
    for (s, x) in sessions.iter().enumerate() {
        assert_eq!(x["session"], format!("s{s}"));
        assert_eq!(x["rows"], 12);
        let rms_mm = x["rms_pos_m"].as_f64().unwrap() * 1e3;
        assert!(rms_mm < 1e-6, "session s{s}: RMS {rms_mm} mm");
        match json_frame(x) {
            None => assert_eq!(s, 0, "only the first session is in the base frame"),
            Some(f) => {
                let (dt, dr) = frame_gap(&f, &pose_from_vector6(&FRAMES[s]));
                assert!(
                    dt < 1e-9 && dr < 1e-9,
                    "s{s}: frame off by {dt} m, {dr} rad"
                );
            }
        }
    }
    assert!(
        v["summary"]["rms_pos_m"].as_f64().unwrap() < 1e-9,
        "{}",
        v["summary"]
    );
    eprintln!("validate truth: {}", v["sessions"]);

    // The truth with its base moved by D: the first session (base frame) sees |p − D·p| on
    // every row; each later session's frame absorbs D (frame T_s·D⁻¹, errors zero).
    let d = pose_from_vector6(&[0.01, -0.02, 0.005, 0.02, -0.01, 0.03]);
    let moved = truth
        .with_base(pose_to_vector6(&(d * pose_from_vector6(&truth.base()))))
        .unwrap();
    let (v, _) = validate_json(dir.path(), &moved, "moved");
    let errs: Vec<f64> = (0..12)
        .map(|k| {
            let p = nalgebra::Point3::from(marker(&truth, k, 0));
            (p - d * p).norm()
        })
        .collect();
    let want_rms = (errs.iter().map(|e| e * e).sum::<f64>() / 12.0).sqrt();
    let want_max = errs.iter().copied().fold(0.0, f64::max);
    assert!(want_rms > 1e-3, "D must move the markers: {want_rms} m");
    let sessions = v["sessions"].as_array().expect("sessions");
    let s0 = &sessions[0];
    assert!(json_frame(s0).is_none());
    let (rms, max) = (
        s0["rms_pos_m"].as_f64().unwrap(),
        s0["max_pos_m"].as_f64().unwrap(),
    );
    assert!((rms - want_rms).abs() < 1e-12, "{rms} vs {want_rms}");
    assert!((max - want_max).abs() < 1e-12, "{max} vs {want_max}");
    for (s, x) in sessions.iter().enumerate().skip(1) {
        let rms_mm = x["rms_pos_m"].as_f64().unwrap() * 1e3;
        assert!(rms_mm < 1e-6, "session s{s}: RMS {rms_mm} mm");
        let want = pose_from_vector6(&FRAMES[s]) * d.inverse();
        let (dt, dr) = frame_gap(&json_frame(x).unwrap(), &want);
        assert!(
            dt < 1e-9 && dr < 1e-9,
            "s{s}: frame off by {dt} m, {dr} rad"
        );
    }
    // The summary runs over all 36 rows; only the first session's 12 carry an error.
    let all = v["summary"]["rms_pos_m"].as_f64().unwrap();
    let want_all = (errs.iter().map(|e| e * e).sum::<f64>() / 36.0).sqrt();
    assert!((all - want_all).abs() < 1e-12, "{all} vs {want_all}");
    // The per-pose errors are the frame-fitted ones: the later sessions' rows are zero.
    let poses = v["poses"].as_array().unwrap();
    assert_eq!(poses.len(), 36);
    let norm = |i: usize| poses[i]["e_pos_norm_m"].as_f64().unwrap();
    assert!((norm(0) - errs[0]).abs() < 1e-12);
    assert!((12..36).all(|i| norm(i) < 1e-9), "{}", poses[20]);

    // The nominal model: the first session's error is |p_true − p_nominal| per row; each
    // later session's the residual of the best rigid fit of the nominal's markers to the
    // measured ones, by Horn's quaternion method (the test's own, not the core's
    // Kabsch/Gauss–Newton).
    let nominal = aria::nominal();
    let (v, _) = validate_json(dir.path(), &nominal, "nominal");
    let sessions = v["sessions"].as_array().expect("sessions");
    let s0: Vec<f64> = (0..12)
        .map(|k| (marker(&truth, k, 0) - marker(&nominal, k, 0)).norm())
        .collect();
    let want0 = (s0.iter().map(|e| e * e).sum::<f64>() / 12.0).sqrt();
    let got0 = sessions[0]["rms_pos_m"].as_f64().unwrap();
    assert!((got0 - want0).abs() < 1e-12, "s0: {got0} vs {want0}");
    for (s, x) in sessions.iter().enumerate().skip(1) {
        let frame = pose_from_vector6(&FRAMES[s]);
        let a: Vec<_> = (0..12).map(|k| marker(&nominal, k, s)).collect();
        let b: Vec<_> = (0..12)
            .map(|k| (frame * nalgebra::Point3::from(marker(&truth, k, s))).coords)
            .collect();
        let want = horn_rms(&a, &b);
        let got = x["rms_pos_m"].as_f64().unwrap();
        assert!(
            want > 1e-4,
            "the nominal must differ after the fit: {want} m"
        );
        assert!((got - want).abs() < 1e-9 * want, "s{s}: {got} vs {want}");
        eprintln!(
            "validate nominal, s{s}: RMS {} mm (Horn: {} mm)",
            got * 1e3,
            want * 1e3
        );
    }
}

/// RMS [m] of the residuals of the best rigid motion taking points `a` onto `b` (least
/// squares), by Horn's closed-form unit quaternion (1987): the eigenvector of the largest
/// eigenvalue of the 4×4 matrix of the cross-covariance.
fn horn_rms(a: &[nalgebra::Vector3<f64>], b: &[nalgebra::Vector3<f64>]) -> f64 {
    let n = a.len() as f64;
    let ca = a.iter().sum::<nalgebra::Vector3<f64>>() / n;
    let cb = b.iter().sum::<nalgebra::Vector3<f64>>() / n;
    let mut m = nalgebra::Matrix3::zeros();
    for (x, y) in a.iter().zip(b) {
        m += (x - ca) * (y - cb).transpose();
    }
    let s = |i: usize, j: usize| m[(i, j)];
    #[rustfmt::skip]
    let k = nalgebra::Matrix4::new(
        s(0, 0) + s(1, 1) + s(2, 2), s(1, 2) - s(2, 1), s(2, 0) - s(0, 2), s(0, 1) - s(1, 0),
        s(1, 2) - s(2, 1), s(0, 0) - s(1, 1) - s(2, 2), s(0, 1) + s(1, 0), s(2, 0) + s(0, 2),
        s(2, 0) - s(0, 2), s(0, 1) + s(1, 0), -s(0, 0) + s(1, 1) - s(2, 2), s(1, 2) + s(2, 1),
        s(0, 1) - s(1, 0), s(2, 0) + s(0, 2), s(1, 2) + s(2, 1), -s(0, 0) - s(1, 1) + s(2, 2),
    );
    let e = k.symmetric_eigen();
    let q = e.eigenvectors.column(e.eigenvalues.imax()).into_owned();
    let r = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
        q[0], q[1], q[2], q[3],
    ));
    let sum: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| ((y - cb) - r * (x - ca)).norm_squared())
        .sum();
    (sum / n).sqrt()
}

#[test]
fn crossval_by_session_recovers_the_truth_and_refuses_other_groupings() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("inst.csv"), csv()).unwrap();
    let o = kincal(
        &[
            "crossval",
            "inst.csv",
            "--robot",
            "aria",
            "--group-by",
            "session",
            "--json",
            "cv.json",
        ],
        dir.path(),
    );
    let out = text(&o);
    assert_eq!(o.status.code(), Some(0), "{out}");
    assert!(
        out.contains("each held-out session is scored after fitting only its frame"),
        "{out}"
    );
    let v: Value =
        serde_json::from_str(&fs::read_to_string(dir.path().join("cv.json")).unwrap()).unwrap();
    assert_eq!(v["folds"].as_array().unwrap().len(), 3, "{v}");
    let held = &v["held_out"];
    assert_eq!(held["scored_groups"], 3, "{v}");
    let cal = held["calibrated"]["rms_mm"].as_f64().unwrap();
    let nom = held["nominal"]["rms_mm"].as_f64().unwrap();
    assert!(cal < 1e-6, "calibrated held-out RMS {cal} mm: {v}");
    assert!(
        nom > 0.1,
        "the nominal model must not fit already: {nom} mm"
    );
    eprintln!("crossval by session: held-out RMS nominal {nom} mm, calibrated {cal} mm");
    // The first session measured in a frame 2 cm and 0.03 rad off the ROBOT's base, the
    // base frame fitted (`--effects base_frame`): a fold holding that session out trains on
    // frames of their own only (the base is gauge there), so it is scored after fitting its
    // frame too; the others identify the base from it. The truth is recovered in every fold.
    let mut frames = FRAMES;
    frames[0] = [0.01, -0.02, 0.005, 0.02, -0.01, 0.03];
    fs::write(dir.path().join("moved.csv"), csv_in(&frames, &[12, 12, 12])).unwrap();
    let o = kincal(
        &[
            "crossval",
            "moved.csv",
            "--robot",
            "aria",
            "--effects",
            "base_frame",
            "--json",
            "cv2.json",
        ],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let v: Value =
        serde_json::from_str(&fs::read_to_string(dir.path().join("cv2.json")).unwrap()).unwrap();
    assert_eq!(v["group_by"], "session", "the default with sessions: {v}");
    let cal = v["held_out"]["calibrated"]["max_mm"].as_f64().unwrap();
    assert!(cal < 1e-6, "calibrated held-out max {cal} mm: {v}");
    eprintln!("crossval, first session moved: held-out max calibrated {cal} mm");
    // A held-out row of a framed session has no frame to be scored in: refused (usage).
    let o = kincal(
        &[
            "crossval",
            "inst.csv",
            "--robot",
            "aria",
            "--group-by",
            "pose-id",
        ],
        dir.path(),
    );
    let out = text(&o);
    assert_eq!(o.status.code(), Some(2), "{out}");
    assert!(out.contains("expected --group-by session"), "{out}");
}

#[test]
fn a_later_session_with_too_few_rows_is_refused_naming_its_line() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("bad.csv"), csv_sessions(&[12, 12, 2])).unwrap();
    // Session s2 starts on line 1 + 24 + 1.
    for args in [
        &["validate", "aria", "bad.csv"][..],
        &[
            "crossval",
            "bad.csv",
            "--robot",
            "aria",
            "--group-by",
            "session",
        ][..],
    ] {
        let o = kincal(args, dir.path());
        let out = text(&o);
        assert_eq!(o.status.code(), Some(3), "{args:?}: {out}");
        assert!(
            out.contains("bad.csv:26: column 'session'"),
            "{args:?}: {out}"
        );
        assert!(out.contains("\"s2\""), "{args:?}: {out}");
    }
}
