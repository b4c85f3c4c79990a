//! End-to-end tests of the design commands: select-poses, design-tool, evaluate-designs.

use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;

const BIN: &str = env!("CARGO_BIN_EXE_kincal");

fn kincal(args: &[&str], dir: &Path, threads: Option<&str>) -> Output {
    let mut c = Command::new(BIN);
    c.args(args).current_dir(dir);
    if let Some(t) = threads {
        c.env("RAYON_NUM_THREADS", t);
    }
    c.output().expect("run kincal")
}

fn ok(o: &Output) -> String {
    assert!(
        o.status.success(),
        "exit {:?}\nstdout:\n{}\nstderr:\n{}",
        o.status.code(),
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn design<'a>(v: &'a Value, name: &str) -> &'a Value {
    v["designs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|d| d["name"] == name)
        .unwrap_or_else(|| panic!("no design {name}"))
}

fn stat(d: &Value, what: &str, s: &str) -> f64 {
    d[what][s].as_f64().unwrap()
}

/// Small but meaningful settings: fewer candidates, starts and runs than the defaults.
const SMALL: &[&str] = &["--pool", "600", "--starts", "2", "--refine", "50"];

#[test]
fn evaluation_reproduces_the_paper_ordering_and_is_reproducible_whatever_the_threads() {
    let dir = tempfile::tempdir().unwrap();
    let run = |out: &str, threads: &str| {
        let mut a = vec![
            "evaluate-designs",
            "--runs",
            "200",
            "--json",
            out,
            "--plot",
            "fig.svg",
        ];
        a.extend_from_slice(SMALL);
        ok(&kincal(&a, dir.path(), Some(threads)))
    };
    let text = run("a.json", "2");
    assert!(text.contains("Verdicts:"), "{text}");
    assert!(text.contains("calibrations in"), "{text}");
    let a = json(&dir.path().join("a.json"));
    let (s, c, t) = (
        design(&a, "standard"),
        design(&a, "clustering"),
        design(&a, "table2"),
    );
    for d in [s, c, t] {
        assert_eq!(d["runs"], 200);
        assert_eq!(d["failed"], 0, "{d}");
        // The paper's simulation result: inside 1 mm and 0.66° (95 % of the runs).
        assert!(stat(d, "worst_pose_e_p_mm", "p95") < 1.0, "{d}");
        assert!(stat(d, "worst_pose_e_phi_deg", "p95") < 0.66, "{d}");
    }
    // Whole-workspace data give smaller errors than both local designs.
    for local in [c, t] {
        for what in ["worst_pose_e_p_mm", "worst_pose_e_phi_deg"] {
            for st in ["median", "p95"] {
                assert!(
                    stat(s, what, st) < stat(local, what, st),
                    "{what} {st}: standard {} vs {} {}",
                    stat(s, what, st),
                    local["name"],
                    stat(local, what, st)
                );
            }
        }
    }
    // Before calibration the robots are far off (5 mm / 5° errors).
    assert!(stat(s, "before_worst_pose_e_p_mm", "median") > 10.0);
    let svg = std::fs::read_to_string(dir.path().join("fig.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("table2") && svg.contains("target 1 mm"));
    // Same seed, one thread: the same numbers.
    run("b.json", "1");
    let b = json(&dir.path().join("b.json"));
    assert_eq!(a["designs"].as_array().unwrap().len(), 3);
    for (x, y) in a["designs"]
        .as_array()
        .unwrap()
        .iter()
        .zip(b["designs"].as_array().unwrap())
    {
        for what in ["worst_pose_e_p_mm", "worst_pose_e_phi_deg", "rms_e_p_mm"] {
            assert_eq!(x[what], y[what], "{}", x["name"]);
        }
        assert_eq!(x["o_eq17"], y["o_eq17"]);
    }
}

#[test]
fn selected_poses_beat_random_poses_and_feed_the_evaluation() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = vec![
        "select-poses",
        "--design",
        "standard",
        "--out",
        "std.csv",
        "--compare-random",
        "300",
    ];
    a.extend_from_slice(SMALL);
    let text = ok(&kincal(&a, dir.path(), None));
    // The eq. (17) row: selected above the best random set.
    let row = text
        .lines()
        .find(|l| l.trim_start().starts_with("O (eq. 17)"))
        .unwrap_or_else(|| panic!("{text}"));
    let v: Vec<f64> = row
        .split_whitespace()
        .filter_map(|w| w.parse::<f64>().ok())
        .collect();
    assert!(
        v.len() >= 3 && v[0] > v[2],
        "selected {} vs best random {}: {row}",
        v[0],
        v[2]
    );
    assert!(
        text.contains("10 of 10 poses satisfy the constraints"),
        "{text}"
    );
    let csv = std::fs::read_to_string(dir.path().join("std.csv")).unwrap();
    assert!(csv.starts_with("pose_id,q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz"));
    assert_eq!(csv.lines().count(), 11);

    // A clustering selection lands in ten different 100 mm cubes of the region.
    let mut c = vec![
        "select-poses",
        "--design",
        "clustering",
        "--out",
        "cl.csv",
        "--compare-random",
        "50",
        "--robust-robots",
        "8",
    ];
    c.extend_from_slice(SMALL);
    let text = ok(&kincal(&c, dir.path(), None));
    assert!(text.contains("Clustering: spread"), "{text}");
    let rows: Vec<Vec<f64>> = std::fs::read_to_string(dir.path().join("cl.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let mut cubes: Vec<(i64, i64, i64)> = rows
        .iter()
        .map(|r| {
            let (x, y, z) = (r[7], r[8], r[9]);
            assert!((0.066..=0.566).contains(&x) && (0.116..=0.592).contains(&y));
            assert!((0.235..=0.335).contains(&z));
            (
                ((x - 0.066) / 0.1).floor() as i64,
                ((y - 0.116) / 0.1).floor().min(4.0) as i64,
                0,
            )
        })
        .collect();
    cubes.sort_unstable();
    cubes.dedup();
    assert_eq!(cubes.len(), 10);

    // The selected poses, measured by an instrument, evaluated next to Table 2.
    let e = ok(&kincal(
        &[
            "evaluate-designs",
            "--designs",
            "table2",
            "--commanded",
            "mine=std.csv",
            "--runs",
            "200",
            "--json",
            "e.json",
        ],
        dir.path(),
        None,
    ));
    assert!(e.contains("mine"), "{e}");
    let j = json(&dir.path().join("e.json"));
    assert!(
        stat(design(&j, "mine"), "worst_pose_e_p_mm", "median")
            < stat(design(&j, "table2"), "worst_pose_e_p_mm", "median")
    );
}

#[test]
fn designed_tool_beats_table2_and_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let text = ok(&kincal(
        &[
            "design-tool",
            "--plate-z-mm",
            "285",
            "--screen-runs",
            "150",
            "--runs",
            "400",
            "--starts",
            "2",
            "--robust-robots",
            "8",
            "--grid-mm",
            "50",
            "--objectives",
            "pv01,dopt",
            "--out",
            "tool.csv",
            "--json",
            "tool.json",
        ],
        dir.path(),
        None,
    ));
    assert!(
        text.contains("Verdict: the optimised tool beats table2"),
        "{text}"
    );
    let j = json(&dir.path().join("tool.json"));
    assert_eq!(j["beats_baseline"], true);
    let (o, t) = (design(&j, "optimised"), design(&j, "table2"));
    for what in ["worst_pose_e_p_mm", "worst_pose_e_phi_deg"] {
        for st in ["median", "p95"] {
            assert!(stat(o, what, st) < stat(t, what, st), "{what} {st}");
        }
    }
    // The specification: one plate height, 60 mm apart, a few orientations.
    let spec = std::fs::read_to_string(dir.path().join("tool.csv")).unwrap();
    assert!(spec.starts_with("# kincal calibration-tool specification"));
    let rows: Vec<Vec<f64>> = spec
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 10);
    for (i, a) in rows.iter().enumerate() {
        assert!((a[3] - 285.0).abs() < 1e-9, "z {}", a[3]);
        assert!([-150.0, -160.0].iter().any(|r| (a[4] - r).abs() < 1e-9));
        assert!(
            [-90.0, 0.0, 90.0, 180.0, -180.0]
                .iter()
                .any(|y| (a[6] - y).abs() < 1e-9)
        );
        for b in &rows[..i] {
            let d = ((a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
            assert!(d >= 60.0 - 1e-9, "{d}");
        }
    }
    // The written tool evaluates like the designed one on the same robots.
    ok(&kincal(
        &[
            "evaluate-designs",
            "--designs",
            "table2",
            "--tool",
            "optimised=tool.csv",
            "--runs",
            "400",
            "--json",
            "back.json",
        ],
        dir.path(),
        None,
    ));
    let back = json(&dir.path().join("back.json"));
    let (a, b) = (design(&back, "optimised"), o);
    let rel = (stat(a, "worst_pose_e_p_mm", "median") - stat(b, "worst_pose_e_p_mm", "median"))
        .abs()
        / stat(b, "worst_pose_e_p_mm", "median");
    assert!(rel < 1e-6, "{rel}");
}

#[test]
fn help_documents_the_design_commands_and_bad_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let top = ok(&kincal(&["help"], dir.path(), None));
    for c in ["select-poses", "design-tool", "evaluate-designs"] {
        assert!(top.contains(c), "{top}");
        let h = ok(&kincal(&["help", c], dir.path(), None));
        assert!(h.contains("Example"), "{c}: {h}");
    }
    std::fs::write(dir.path().join("bad.csv"), "x,y,z,roll,pitch\n1,2,3,0,0\n").unwrap();
    let o = kincal(
        &[
            "evaluate-designs",
            "--designs",
            "table2",
            "--tool",
            "t=bad.csv",
            "--runs",
            "5",
        ],
        dir.path(),
        None,
    );
    assert_eq!(o.status.code(), Some(3));
    assert!(String::from_utf8_lossy(&o.stderr).contains("bad.csv:1"));
    let o = kincal(&["evaluate-designs", "--tool", "nofile"], dir.path(), None);
    assert_eq!(o.status.code(), Some(2));
    let o = kincal(
        &["select-poses", "--robot", "nonesuch", "--out", "x.csv"],
        dir.path(),
        None,
    );
    assert_eq!(o.status.code(), Some(2));
}
