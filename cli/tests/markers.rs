//! `kincal markers` end to end on a synthetic motion-capture export: known end-effector
//! poses (ARIA FK at random joints), a mocap frame far from the base frame, marker noise,
//! a swapped probe-marker pair, an occluded marker, a knocked base marker, and a frame
//! that cannot be registered (refused, or left out and listed with --skip-failed). Then
//! the written poses calibrate, and --points gives position-only rows with point columns.

use std::fs;
use std::path::Path;

use kincal::aria;
use kincal::pose::{Transform, pose_from_xyz_rpy, quaternion_to_matrix};
use kincal::rng::SplitMix64;

mod common;
use common::{kincal, text};

const SIGMA_M: f64 = 5e-5;

/// Base markers [mm] in the robot base frame and an asymmetric probe [mm] in the tool frame.
const BASE: [(&str, [f64; 3]); 4] = [
    ("B1", [300.0, 0.0, 0.0]),
    ("B2", [-200.0, 250.0, 0.0]),
    ("B3", [-150.0, -300.0, 0.0]),
    ("B4", [100.0, 100.0, 50.0]),
];
const PROBE: [(&str, [f64; 3]); 5] = [
    ("P1", [0.0, 0.0, 0.0]),
    ("P2", [120.0, 0.0, 0.0]),
    ("P3", [0.0, 85.0, 0.0]),
    ("P4", [-60.0, -30.0, 10.0]),
    ("P5", [30.0, -100.0, 20.0]),
];

fn apply(t: &Transform, p_mm: [f64; 3]) -> [f64; 3] {
    let q = t.transform_point(&nalgebra::Point3::new(
        p_mm[0] * 1e-3,
        p_mm[1] * 1e-3,
        p_mm[2] * 1e-3,
    ));
    [q.x, q.y, q.z]
}

struct Synthetic {
    dir: tempfile::TempDir,
    truth: Vec<Transform>,
}

/// 24 frames; frame 5 has P2/P4 swapped, frame 9 an occluded P3, frame 12 a knocked B2
/// (+5 mm), frame 17 only two probe markers visible (cannot be registered).
fn synthetic() -> Synthetic {
    let dir = tempfile::tempdir().unwrap();
    let robot = aria::nominal();
    let mut rng = SplitMix64::new(7);
    let t_mocap_base = pose_from_xyz_rpy([1.2, -0.4, 0.9], [0.3, -0.2, 2.0]);
    let mut export = String::from("frame,marker,x_mm,y_mm,z_mm\n");
    let mut joints = String::from("# robot: aria\nframe,q1,q2,q3,q4,q5,q6\n");
    let mut truth = Vec::new();
    let noise = |rng: &mut SplitMix64| SIGMA_M * rng.normal();
    for f in 1..=24 {
        let lim = robot.limits();
        let q: Vec<f64> = (0..6)
            .map(|j| {
                let (lo, hi) = (lim[j].lower.max(-2.5), lim[j].upper.min(2.5));
                lo + (hi - lo) * rng.uniform()
            })
            .collect();
        let qa: [f64; 6] = q.clone().try_into().unwrap();
        let t_base_ee = robot.fk_q(&qa).unwrap();
        truth.push(t_base_ee);
        let t_mocap_ee = t_mocap_base * t_base_ee;
        joints.push_str(&format!(
            "f{f},{}\n",
            q.iter()
                .map(|v| format!("{v:?}"))
                .collect::<Vec<_>>()
                .join(",")
        ));
        let mut rows: Vec<(String, Option<[f64; 3]>)> = Vec::new();
        for (name, p) in BASE {
            let mut m = apply(&t_mocap_base, p);
            if f == 12 && name == "B2" {
                m[0] += 0.005;
            }
            rows.push((name.into(), Some(m)));
        }
        for (name, p) in PROBE {
            let m = apply(&t_mocap_ee, p);
            let occluded = f == 9 && name == "P3";
            let hidden_f17 = f == 17 && name != "P1" && name != "P2";
            let visible = !(occluded || hidden_f17);
            rows.push((name.into(), visible.then_some(m)));
        }
        if f == 5 {
            let (a, b) = (
                rows.iter().position(|r| r.0 == "P2").unwrap(),
                rows.iter().position(|r| r.0 == "P4").unwrap(),
            );
            let tmp = rows[a].1;
            rows[a].1 = rows[b].1;
            rows[b].1 = tmp;
        }
        for (name, m) in rows {
            match m {
                Some(m) => export.push_str(&format!(
                    "f{f},{name},{:?},{:?},{:?}\n",
                    (m[0] + noise(&mut rng)) * 1e3,
                    (m[1] + noise(&mut rng)) * 1e3,
                    (m[2] + noise(&mut rng)) * 1e3
                )),
                None => export.push_str(&format!("f{f},{name},,,\n")),
            }
        }
    }
    // An export frame without joint readings: listed as unused.
    export.push_str("f99,P1,1,2,3\n");
    let mut design = String::from("units = \"mm\"\nsigma_mm = 0.05\n[base]\n");
    for (n, p) in BASE {
        design.push_str(&format!("{n} = [{:?}, {:?}, {:?}]\n", p[0], p[1], p[2]));
    }
    design.push_str("[probe]\n");
    for (n, p) in PROBE {
        design.push_str(&format!("{n} = [{:?}, {:?}, {:?}]\n", p[0], p[1], p[2]));
    }
    fs::write(dir.path().join("export.csv"), export).unwrap();
    fs::write(dir.path().join("joints.csv"), joints).unwrap();
    fs::write(dir.path().join("design.toml"), design).unwrap();
    Synthetic { dir, truth }
}

fn args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec![
        "markers",
        "export.csv",
        "--design",
        "design.toml",
        "--joints",
        "joints.csv",
        "--robot",
        "aria",
    ];
    a.extend_from_slice(extra);
    a
}

#[test]
fn failed_frame_is_refused_and_named() {
    let s = synthetic();
    let o = kincal(&args(&["--out", "poses.csv"]), s.dir.path());
    let t = text(&o);
    assert_eq!(o.status.code(), Some(3), "{t}");
    assert!(t.contains("frame f17"), "{t}");
    assert!(
        t.contains("probe: 2 marker(s) visible, at least 3 needed"),
        "{t}"
    );
    assert!(!s.dir.path().join("poses.csv").exists());
}

#[test]
fn poses_outliers_and_skipped_frames() {
    let s = synthetic();
    let o = kincal(
        &args(&[
            "--out",
            "poses.csv",
            "--skip-failed",
            "--residuals",
            "res.csv",
        ]),
        s.dir.path(),
    );
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    // Swapped pair, occluded marker, knocked base marker, unusable and unused frames named.
    assert!(
        t.contains("frame f5: probe marker P2 swapped with P4"),
        "{t}"
    );
    assert!(
        t.contains("frame f5: probe marker P4 swapped with P2"),
        "{t}"
    );
    assert!(t.contains("frame f12: base marker B2 moved"), "{t}");
    assert!(t.contains("frame f17"), "{t}");
    assert!(
        t.contains("Export frames without joint readings (not used): f99"),
        "{t}"
    );
    // No other marker is flagged.
    let flagged: Vec<&str> = t
        .lines()
        .filter(|l| l.contains(" marker ") && l.starts_with("  frame"))
        .collect();
    assert_eq!(flagged.len(), 3, "{t}");
    let res = fs::read_to_string(s.dir.path().join("res.csv")).unwrap();
    assert!(res.contains("f9,probe,P3,missing"), "{res}");
    // The written poses: 23 frames (f17 left out and listed in the comments), each close to
    // the truth (σ = 0.05 mm per axis on 4–5 markers per body: a few tenths of a mm at the
    // end effector through the base registration's lever).
    let data = fs::read_to_string(s.dir.path().join("poses.csv")).unwrap();
    assert!(data.contains("# left out: frame f17"), "{data}");
    let rows: Vec<&str> = data
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .collect();
    assert_eq!(rows.len(), 23);
    let header: Vec<&str> = data
        .lines()
        .find(|l| !l.starts_with('#'))
        .unwrap()
        .split(',')
        .collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    for r in rows {
        let c: Vec<&str> = r.split(',').collect();
        let f: usize = c[col("pose_id")][1..].parse().unwrap();
        let num = |n: &str| c[col(n)].parse::<f64>().unwrap();
        let truth = s.truth[f - 1];
        let dp = (nalgebra::Vector3::new(num("x"), num("y"), num("z")) - truth.translation.vector)
            .norm();
        let r = quaternion_to_matrix(&[num("qw"), num("qx"), num("qy"), num("qz")]).unwrap();
        let dr = kincal::pose::rotation_log(&(r * truth.rotation.matrix().transpose())).norm();
        assert!(dp < 5e-4 && dr < 3e-3, "frame f{f}: {dp:e} m, {dr:e} rad");
    }
    // The poses calibrate: the nominal ARIA is exact up to the marker noise.
    let o = kincal(
        &[
            "calibrate",
            "poses.csv",
            "--robot",
            "aria",
            "--out",
            "m.json",
        ],
        s.dir.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn points_mode_writes_position_rows_per_marker() {
    let s = synthetic();
    let o = kincal(
        &args(&["--out", "points.csv", "--points", "--skip-failed"]),
        s.dir.path(),
    );
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let data = fs::read_to_string(s.dir.path().join("points.csv")).unwrap();
    let header = data.lines().find(|l| !l.starts_with('#')).unwrap();
    assert!(header.contains("point_x,point_y,point_z"), "{header}");
    assert!(!header.contains("qw"), "{header}");
    // Frame f17 (2 probe markers) now contributes its 2 points; f5's swapped pair and f9's
    // occluded marker are not written: 24 frames × 5 − 2 − 1 − 3 = 114 rows.
    let rows = data.lines().filter(|l| !l.starts_with('#')).count() - 1;
    assert_eq!(rows, 114, "{t}");
    // Several points on one body: calibrating with the tool frame finds its rotation too.
    let o = kincal(
        &[
            "calibrate",
            "points.csv",
            "--robot",
            "aria",
            "--effects",
            "tool_frame",
            "--out",
            "m.json",
        ],
        s.dir.path(),
    );
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let model: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(s.dir.path().join("m.json")).unwrap()).unwrap();
    let params = model["robot"]["parameters"].as_array().unwrap();
    let status = |label: &str| {
        params
            .iter()
            .find(|p| p["label"] == label)
            .map(|p| p["status"].as_str().unwrap().to_string())
            .unwrap()
    };
    // With one point per row the tool rotation would be structurally redundant; with the
    // probe's five points it is identified (or redundant only with link 6's own angles).
    let identified = ["tool_rx", "tool_ry", "tool_rz"]
        .iter()
        .filter(|l| status(l) == "identified")
        .count();
    assert!(identified >= 1, "{t}");
}

/// A rhombus probe [mm]: P3 and P4 mirror images about the P1–P2 axis (issue: a symmetric
/// probe kept the wrong 3-marker subset and wrote a pose turned 180° with exit 0).
const RHOMBUS: [(&str, [f64; 3]); 4] = [
    ("P1", [0.0, 0.0, 0.0]),
    ("P2", [60.0, 0.0, 0.0]),
    ("P3", [30.0, 40.0, 0.0]),
    ("P4", [30.0, -40.0, 0.0]),
];

/// Six frames of the rhombus probe, no base markers; in frame f3 the export reports P4 where
/// P3 is (a ghost / a marker labelled twice).
fn symmetric_probe_session(dir: &Path) {
    let robot = aria::nominal();
    let mut rng = SplitMix64::new(11);
    let mut export = String::from("frame,marker,x_mm,y_mm,z_mm\n");
    let mut joints = String::from("# robot: aria\nframe,q1,q2,q3,q4,q5,q6\n");
    for f in 1..=6 {
        let q: [f64; 6] = std::array::from_fn(|_| -1.0 + 2.0 * rng.uniform());
        let t = robot.fk_q(&q).unwrap();
        joints.push_str(&format!("f{f},{}\n", q.map(|v| format!("{v:?}")).join(",")));
        let p3 = apply(&t, RHOMBUS[2].1);
        for (name, p) in RHOMBUS {
            let m = if f == 3 && name == "P4" {
                p3
            } else {
                apply(&t, p)
            };
            export.push_str(&format!(
                "f{f},{name},{:?},{:?},{:?}\n",
                (m[0] + SIGMA_M * rng.normal()) * 1e3,
                (m[1] + SIGMA_M * rng.normal()) * 1e3,
                (m[2] + SIGMA_M * rng.normal()) * 1e3
            ));
        }
    }
    let mut design = String::from("units = \"mm\"\nsigma_mm = 0.05\n[probe]\n");
    for (n, p) in RHOMBUS {
        design.push_str(&format!("{n} = [{:?}, {:?}, {:?}]\n", p[0], p[1], p[2]));
    }
    fs::write(dir.join("export.csv"), export).unwrap();
    fs::write(dir.join("joints.csv"), joints).unwrap();
    fs::write(dir.join("design.toml"), design).unwrap();
}

#[test]
fn symmetric_probe_is_flagged_and_an_ambiguous_frame_refused() {
    let dir = tempfile::tempdir().unwrap();
    symmetric_probe_session(dir.path());
    let o = kincal(&args(&["--out", "poses.csv"]), dir.path());
    // Prose on stdout wraps at 100 columns: compare with the line breaks taken out.
    let t = text(&o).split_whitespace().collect::<Vec<_>>().join(" ");
    assert_eq!(o.status.code(), Some(3), "{t}");
    // The design check names the congruent triangles, the margin and the threshold.
    // (The rhombus's triangles are isosceles and congruent in pairs; the closest is named.)
    assert!(t.contains("warning: probe design: triangle"), "{t}");
    assert!(
        t.contains("within 0.000 mm (outlier threshold 0.200 mm)"),
        "{t}"
    );
    // The frame is refused with both subsets and the 180° between their poses.
    assert!(t.contains("frame f3"), "{t}");
    assert!(t.contains("probe markers ambiguous: excluding P"), "{t}");
    assert!(
        t.contains("fits equally well, with poses 180.0° apart"),
        "{t}"
    );
    assert!(!dir.path().join("poses.csv").exists());
    // With --skip-failed the other five frames are written, f3 is not.
    let o = kincal(&args(&["--out", "poses.csv", "--skip-failed"]), dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let csv = fs::read_to_string(dir.path().join("poses.csv")).unwrap();
    let frames: Vec<&str> = csv
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("pose_id") && !l.is_empty())
        .collect();
    assert_eq!(frames.len(), 5, "{csv}");
}
