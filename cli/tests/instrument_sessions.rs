//! Instrument rows in several sessions through the CLI (docs/constraints.md, "Sessions
//! with instrument rows"): `calibrate` fits a frame per session after the first, recovers
//! ARIA's virtual truth from noise-free positions measured in three frames metres apart,
//! and reports each session's frame.

mod common;

use std::fs;

use common::{kincal, text};
use kincal::pose::pose_from_vector6;
use kincal::{JointState, aria};
use serde_json::Value;

/// Positions of three markers on the tool, ARIA's virtual truth, 12 poses per session;
/// session `s0` in the robot's base frame, `s1` and `s2` in frames moved by metres.
fn csv() -> String {
    let truth = aria::virtual_truth();
    let frames = [
        pose_from_vector6(&[0.0; 6]),
        pose_from_vector6(&[1.5, -0.4, 0.2, 0.1, -0.2, 0.9]),
        pose_from_vector6(&[-2.0, 3.0, -0.5, -0.3, 0.2, -1.7]),
    ];
    let points = [[0.05, 0.0, 0.0], [0.0, 0.05, 0.0], [0.0, 0.0, 0.05]];
    let mut out = String::from("q1,q2,q3,q4,q5,q6,point_x,point_y,point_z,x,y,z,session\n");
    for (s, frame) in frames.iter().enumerate() {
        for k in 0..12 {
            let mut q = aria::TOOL_SEED_Q;
            for (j, v) in q.iter_mut().enumerate() {
                *v += 0.6 * (1.7 * (k + 12 * s) as f64 + 2.3 * j as f64).sin();
            }
            let pt = points[k % 3];
            let t = truth.fk(&JointState::new(q)).unwrap()
                * nalgebra::Translation3::new(pt[0], pt[1], pt[2]);
            let p = (frame * t).translation.vector;
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
