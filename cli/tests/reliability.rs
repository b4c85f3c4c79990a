//! Reliability of the commands' outputs: identical inputs give bit-identical files whatever
//! the thread count (rayon runs the algorithms and the candidates in parallel), and a failed
//! command leaves an existing output as it was, with no temporary file behind.

use std::fs;
use std::path::Path;
use std::process::{Command, Output};

use kincal::identify::Measurement;
use kincal::pose::matrix_to_quaternion;
use kincal::rng::SplitMix64;
use kincal::sim::{SessionConfig, add_effect, perturb_geometry, simulate_session};
use kincal::{Effect, Transform, aria};

const BIN: &str = env!("CARGO_BIN_EXE_kincal");

fn kincal(args: &[&str], dir: &Path, threads: Option<usize>) -> Output {
    let mut c = Command::new(BIN);
    c.args(args).current_dir(dir);
    if let Some(t) = threads {
        c.env("RAYON_NUM_THREADS", t.to_string());
    }
    c.output().expect("run kincal")
}

fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "kincal failed ({}): {}",
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A simulated measuring session of a perturbed ARIA with a hidden joint-compliance effect,
/// noise 0.1 mm / 0.02°, 60 poses of which 20 repeated, approach directions and temperature.
fn session_csv(seed: u64) -> String {
    let mut rng = SplitMix64::new(seed);
    let mut truth = perturb_geometry(&aria::nominal(), 2e-3, 1f64.to_radians(), &mut rng).unwrap();
    add_effect(&mut truth, Effect::JointCompliance, 3.0, &mut rng).unwrap();
    let cfg = SessionConfig {
        record_approach: true,
        temperature_c: Some([22.0, 42.0]),
        ..SessionConfig::blind_training()
    };
    let n = cfg.measurements();
    let mut data = vec![Measurement::new([0.0; 6], Transform::identity()); n];
    let mut groups = vec![0u32; n];
    simulate_session(
        &truth,
        &aria::TOOL_SEED_Q,
        &cfg,
        &mut rng,
        &mut data,
        &mut groups,
    )
    .unwrap();
    let mut s = String::from(
        "# robot: aria (simulated)\npose_id,q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz,s1,s2,s3,s4,s5,s6,temp_c\n",
    );
    for (m, g) in data.iter().zip(&groups) {
        let p = m.pose.translation.vector;
        let q = matrix_to_quaternion(m.pose.rotation.matrix());
        let mut cells = vec![format!("p{g}")];
        cells.extend(m.state.q.iter().map(|v| format!("{v}")));
        cells.extend([p.x, p.y, p.z].iter().map(|v| format!("{v}")));
        cells.extend(q.iter().map(|v| format!("{v}")));
        cells.extend(
            m.state
                .approach
                .unwrap()
                .iter()
                .map(|v| format!("{}", *v as i32)),
        );
        cells.push(format!("{}", m.state.temp_c.unwrap()));
        s.push_str(&cells.join(","));
        s.push('\n');
    }
    s
}

/// The files a command run wrote, by name, in a fresh directory with `data.csv`.
fn run_in_fresh_dir(csv: &str, args: &[&str], threads: usize, outputs: &[&str]) -> Vec<Vec<u8>> {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("data.csv"), csv).unwrap();
    ok(&kincal(args, dir.path(), Some(threads)));
    outputs
        .iter()
        .map(|name| fs::read(dir.path().join(name)).unwrap())
        .collect()
}

#[test]
fn calibrate_all_algorithms_is_bit_identical_with_one_and_two_threads() {
    let csv = session_csv(21);
    let args = [
        "calibrate",
        "data.csv",
        "--robot",
        "aria",
        "--effects",
        "joint_compliance,joint_scale",
        "--algorithm",
        "all",
        "--out",
        "model.json",
    ];
    let one = run_in_fresh_dir(&csv, &args, 1, &["model.json"]);
    let two = run_in_fresh_dir(&csv, &args, 2, &["model.json"]);
    let again = run_in_fresh_dir(&csv, &args, 2, &["model.json"]);
    assert!(
        String::from_utf8_lossy(&one[0]).contains("\"opt2\""),
        "the model file does not record the three algorithms"
    );
    assert!(one == two, "model.json differs between 1 and 2 threads");
    assert!(two == again, "model.json differs between two runs");
}

#[test]
fn diagnose_is_bit_identical_with_one_and_two_threads() {
    let csv = session_csv(22);
    let args = [
        "diagnose",
        "data.csv",
        "--robot",
        "aria",
        "--json",
        "report.json",
        "--out",
        "model.json",
    ];
    let files = ["report.json", "model.json"];
    let one = run_in_fresh_dir(&csv, &args, 1, &files);
    let two = run_in_fresh_dir(&csv, &args, 2, &files);
    for (k, name) in files.iter().enumerate() {
        assert!(one[k] == two[k], "{name} differs between 1 and 2 threads");
    }
    assert!(String::from_utf8_lossy(&one[0]).contains("joint_compliance"));
}

/// Names in `dir` other than `keep`.
fn strays(dir: &Path, keep: &[&str]) -> Vec<String> {
    fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !keep.contains(&n.as_str()))
        .collect()
}

#[test]
fn a_failed_command_leaves_an_existing_output_untouched_and_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let csv = session_csv(23);
    fs::write(d.join("data.csv"), &csv).unwrap();
    ok(&kincal(
        &[
            "calibrate",
            "data.csv",
            "--robot",
            "aria",
            "--out",
            "model.json",
        ],
        d,
        None,
    ));
    let model = fs::read(d.join("model.json")).unwrap();
    // Bad data (a NaN) and a numerically impossible request (no data for the effect):
    // both fail before any output is written; model.json stays as it was.
    let bad: String = csv
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 5 {
                let mut cells: Vec<&str> = l.split(',').collect();
                cells[3] = "NaN";
                cells.join(",")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    fs::write(d.join("bad.csv"), bad).unwrap();
    let o = kincal(
        &[
            "calibrate",
            "bad.csv",
            "--robot",
            "aria",
            "--out",
            "model.json",
        ],
        d,
        None,
    );
    assert_eq!(
        o.status.code(),
        Some(3),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let o = kincal(
        &["predict", "model.json", "bad.csv", "--out", "model.json"],
        d,
        None,
    );
    // (The outputs are checked against the inputs before any input is read.)
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(fs::read(d.join("model.json")).unwrap(), model);
    // An output in a directory that does not exist: an error, nothing written anywhere.
    let o = kincal(
        &[
            "calibrate",
            "data.csv",
            "--robot",
            "aria",
            "--out",
            "missing/model.json",
        ],
        d,
        None,
    );
    assert!(!o.status.success());
    assert_eq!(
        strays(d, &["data.csv", "bad.csv", "model.json"]),
        Vec::<String>::new()
    );
    // A successful run replaces the whole file (written to a temporary, then renamed):
    // the result is exactly what a fresh run writes, and no temporary file remains.
    fs::write(d.join("model.json"), vec![b'x'; 200_000]).unwrap();
    ok(&kincal(
        &[
            "calibrate",
            "data.csv",
            "--robot",
            "aria",
            "--out",
            "model.json",
        ],
        d,
        None,
    ));
    assert_eq!(fs::read(d.join("model.json")).unwrap(), model);
    assert_eq!(
        strays(d, &["data.csv", "bad.csv", "model.json"]),
        Vec::<String>::new()
    );
}

#[test]
fn a_model_file_from_a_future_schema_is_refused_with_a_clear_message() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("data.csv"), session_csv(24)).unwrap();
    ok(&kincal(
        &[
            "calibrate",
            "data.csv",
            "--robot",
            "aria",
            "--out",
            "model.json",
        ],
        d,
        None,
    ));
    let text = fs::read_to_string(d.join("model.json")).unwrap();
    let future = text.replacen(
        "\"schema_version\": \"1.0\"",
        "\"schema_version\": \"3.1\"",
        1,
    );
    assert_ne!(future, text);
    fs::write(d.join("future.json"), future).unwrap();
    for args in [
        vec!["validate", "future.json", "data.csv"],
        vec!["predict", "future.json", "data.csv", "--out", "p.csv"],
    ] {
        let o = kincal(&args, d, None);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(3), "{args:?}: {err}");
        assert!(
            err.contains("schema_version 3.1 is newer") && err.contains("upgrade kincal"),
            "{args:?}: {err}"
        );
        assert!(!d.join("p.csv").exists());
    }
}
