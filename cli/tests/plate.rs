//! `evaluate-designs --plate`: socket plates against the Table 2 tool (issue #13, item 6).
//! Small runs: the table's shape, a noise-free plate recovering every tool point up to
//! the base frame, a seeded figure, reproducibility whatever the thread count, bad input.

use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;

const BIN: &str = env!("CARGO_BIN_EXE_kincal");

fn kincal(args: &[&str], dir: &Path, threads: &str) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .env("RAYON_NUM_THREADS", threads)
        .output()
        .expect("run kincal")
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

fn plates(path: &Path) -> Vec<Value> {
    let v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v["plates"].as_array().unwrap().clone()
}

fn row<'a>(rows: &'a [Value], name: &str) -> &'a Value {
    rows.iter()
        .find(|r| r["name"] == name)
        .unwrap_or_else(|| panic!("no row {name}"))
}

fn stat(r: &Value, what: &str, s: &str) -> f64 {
    r[what][s].as_f64().unwrap()
}

const PLATES: &[&str] = &["--plate", "p50=50,1,10", "--plate", "p200=200,3,36"];

fn args<'a>(runs: &'a str, json: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec![
        "evaluate-designs",
        "--designs",
        "table2",
        "--runs",
        runs,
        "--json",
        json,
    ];
    a.extend_from_slice(PLATES);
    a.extend_from_slice(extra);
    a
}

#[test]
fn plate_table_has_every_design_and_is_reproducible_whatever_the_threads() {
    let dir = tempfile::tempdir().unwrap();
    let text = ok(&kincal(
        &args("30", "a.json", &["--plate-plot", "plate.svg"]),
        dir.path(),
        "2",
    ));
    // The table: a header and one line per design, tools first.
    let at = text
        .find("Socket plates vs the designs above")
        .expect(&text);
    // The header (three lines), a rule, one line per design, every line within 100 columns
    // (issue #19). (The heading is prose and wraps at 100 columns: the table starts at its
    // header.)
    let table: Vec<&str> = text[at..]
        .lines()
        .skip_while(|l| !l.trim_start().starts_with("design "))
        .take(7)
        .collect();
    assert!(
        table[0].contains("reg e_p") && table[1].contains("median") && table[2].contains("[mm]"),
        "{text}"
    );
    assert!(table[3].trim().chars().all(|c| c == '-'), "{text}");
    for (line, name) in table[4..].iter().zip(["table2", "p50", "p200"]) {
        assert!(line.trim_start().starts_with(name), "{line}");
        assert_eq!(line.split_whitespace().count(), 11, "{line}");
    }
    for line in text[at..].lines() {
        assert!(
            line.chars().count() <= 100,
            "a line of {} columns:\n{line}",
            line.chars().count()
        );
    }
    assert!(text.contains("Plate verdicts:"), "{text}");
    assert!(text.contains("the base frame"), "{text}");
    let svg = std::fs::read_to_string(dir.path().join("plate.svg")).unwrap();
    assert!(svg.contains("<svg") && svg.contains("plate 200 mm"), "svg");
    let a = plates(&dir.path().join("a.json"));
    assert_eq!(a.len(), 3);
    let p200 = row(&a, "p200");
    assert_eq!(p200["contacts"], 36);
    assert_eq!(p200["placements"], 3);
    // A run fails when the fit does not converge (an ill-conditioned plate): rare here.
    assert!(p200["failed"].as_u64().unwrap() <= 3, "{p200}");
    // A plate cannot see the base frame: absolute errors stay at millimetres while the
    // registered ones are fractions of one.
    let (abs, reg) = (
        stat(p200, "absolute_worst_pose_e_p_mm", "median"),
        stat(p200, "registered_worst_pose_e_p_mm", "median"),
    );
    assert!(abs > 10.0 && reg < 2.0, "{abs} {reg}");
    // Same numbers on one thread.
    ok(&kincal(&args("30", "b.json", &[]), dir.path(), "1"));
    assert_eq!(a, plates(&dir.path().join("b.json")));
}

#[test]
fn noise_free_plate_recovers_the_truth_up_to_the_base_frame() {
    let dir = tempfile::tempdir().unwrap();
    let exact = [
        "--noise-pos-mm",
        "0",
        "--noise-rot-deg",
        "0",
        "--tool-tol-mm",
        "0",
        "--tool-tol-deg",
        "0",
    ];
    ok(&kincal(&args("8", "n.json", &exact), dir.path(), "2"));
    let rows = plates(&dir.path().join("n.json"));
    // The 3-placement plate (36 contacts); one placement with 10 contacts barely
    // determines the arm and is not a recovery test.
    let r = row(&rows, "p200");
    assert_eq!(r["failed"], 0, "{r}");
    let reg = stat(r, "registered_worst_pose_e_p_mm", "max");
    assert!(reg < 1e-6, "p200: {reg} mm");
    assert!(stat(r, "absolute_worst_pose_e_p_mm", "median") > 1.0);
    // The known-pose tool recovers the absolute poses.
    let t = row(&rows, "table2");
    assert!(stat(t, "absolute_worst_pose_e_p_mm", "max") < 1e-6, "{t}");
}

#[test]
fn seeded_plate_figure_is_stable() {
    let dir = tempfile::tempdir().unwrap();
    ok(&kincal(&args("100", "s.json", &[]), dir.path(), "2"));
    let rows = plates(&dir.path().join("s.json"));
    // Seed 1, 100 runs, recorded when the comparison was written (p200: 99 of 100 runs
    // converge; registered e_p median 0.704 mm, p95 1.272 mm).
    let p95 = stat(row(&rows, "p200"), "registered_worst_pose_e_p_mm", "p95");
    let expected = P200_P95_MM;
    assert!(
        (p95 - expected).abs() <= 0.02 * expected,
        "p200 registered e_p p95 {p95} mm, expected {expected} mm"
    );
}

const P200_P95_MM: f64 = 1.272480934510399;

#[test]
fn bad_plate_arguments_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    for bad in [
        vec!["evaluate-designs", "--plate", "x=50,3,11"],
        vec!["evaluate-designs", "--plate", "x=50"],
        vec!["evaluate-designs", "--plate-plot", "p.svg"],
    ] {
        let o = kincal(&bad, dir.path(), "1");
        assert_eq!(o.status.code(), Some(2), "{bad:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("--plate"), "{err}");
    }
}
