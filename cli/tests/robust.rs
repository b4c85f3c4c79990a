//! End-to-end tests of `kincal calibrate --robust`: a simulated session of a perturbed ARIA
//! with small noise and one corrupted row (a 5 mm glitch) written as a measurement CSV; the
//! robust fit must name that row (CSV line and pose_id), land closer to the truth than the
//! plain least-squares fit, record the loss, scales and suspects in the model file, and
//! refuse bad loss names as a usage error.

use std::fs;
use std::path::Path;
use std::process::Output;

use kincal::identify::Measurement;
use kincal::pose::matrix_to_quaternion;
use kincal::rng::SplitMix64;
use kincal::sim::{SessionConfig, perturb_geometry, simulate_session};
use kincal::{ParamId, Robot, Transform, aria};
use serde_json::Value;

mod common;
use common::kincal;

/// Size of the glitch added to one row's x [m].
const GLITCH_M: f64 = 5e-3;
/// Index (data order) of the corrupted row.
const BAD_ROW: usize = 23;
/// Instrument noise of the session, 1σ per axis: 0.05 mm and 0.01°.
const SIGMA_POS_MM: f64 = 0.05;
const SIGMA_ROT_DEG: f64 = 0.01;

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn ok(o: &Output) -> String {
    assert_eq!(
        o.status.code(),
        Some(0),
        "stdout:\n{}\nstderr:\n{}",
        text(&o.stdout),
        text(&o.stderr)
    );
    text(&o.stdout)
}

/// The simulated data set: the true robot, the CSV text, and the corrupted row's CSV line
/// and pose_id.
struct Session {
    truth: Robot<6>,
    csv: String,
    bad_line: u64,
    bad_pose_id: String,
}

/// 60 poses on a perturbed ARIA (±2 mm, ±1° per geometric parameter), noise
/// `SIGMA_POS_MM`/`SIGMA_ROT_DEG`, no repeats; row `BAD_ROW` gets `GLITCH_M` added to x.
fn session(seed: u64) -> Session {
    let mut rng = SplitMix64::new(seed);
    let truth = perturb_geometry(&aria::nominal(), 2e-3, 1f64.to_radians(), &mut rng).unwrap();
    let cfg = SessionConfig {
        repeated: 0,
        record_approach: false,
        temperature_c: None,
        sigma_pos_m: SIGMA_POS_MM * 1e-3,
        sigma_rot_rad: SIGMA_ROT_DEG.to_radians(),
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
    let mut csv = String::from(
        "# robot: aria (simulated session, one corrupted row)\npose_id,q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz\n",
    );
    let mut bad_line = 0;
    for (i, (m, g)) in data.iter().zip(&groups).enumerate() {
        let mut p = m.pose.translation.vector;
        if i == BAD_ROW {
            p.x += GLITCH_M;
            // Lines are 1-based; the row about to be written is the next one.
            bad_line = csv.lines().count() as u64 + 1;
        }
        let q = matrix_to_quaternion(m.pose.rotation.matrix());
        let mut cells = vec![format!("p{g}")];
        cells.extend(m.state.q.iter().map(|v| format!("{v}")));
        cells.extend([p.x, p.y, p.z].iter().map(|v| format!("{v}")));
        cells.extend(q.iter().map(|v| format!("{v}")));
        csv.push_str(&cells.join(","));
        csv.push('\n');
    }
    Session {
        truth,
        csv,
        bad_line,
        bad_pose_id: format!("p{}", groups[BAD_ROW]),
    }
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&fs::read_to_string(path).unwrap()).unwrap()
}

/// Distance of a model file's identified parameters from the truth: (RMS over the length
/// parameters [mm], RMS over the angle parameters [deg]).
fn error_to_truth(model: &Value, truth: &Robot<6>) -> (f64, f64, usize) {
    let (mut sl, mut nl, mut sa, mut na) = (0.0, 0usize, 0.0, 0usize);
    for p in model["robot"]["parameters"].as_array().unwrap() {
        if p["identified"] != true {
            continue;
        }
        let id = ParamId::parse(p["label"].as_str().unwrap(), 6).unwrap();
        let d = p["value"].as_f64().unwrap() - truth.param(id.index(6)).unwrap();
        if id.is_length() {
            sl += (d * 1e3).powi(2);
            nl += 1;
        } else {
            sa += d.to_degrees().powi(2);
            na += 1;
        }
    }
    assert!(nl > 0 && na > 0, "lengths and angles identified");
    ((sl / nl as f64).sqrt(), (sa / na as f64).sqrt(), nl + na)
}

#[test]
fn robust_calibration_names_the_glitch_and_beats_the_plain_fit() {
    let s = session(7);
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("data.csv"), &s.csv).unwrap();
    let (sp, sr) = (SIGMA_POS_MM.to_string(), SIGMA_ROT_DEG.to_string());
    let base = [
        "calibrate",
        "data.csv",
        "--robot",
        "aria",
        "--sigma-pos-mm",
        &sp,
        "--sigma-rot-deg",
        &sr,
    ];
    let run = |extra: &[&str]| {
        let mut a: Vec<&str> = base.to_vec();
        a.extend_from_slice(extra);
        kincal(&a, dir.path())
    };

    // Plain least squares: no robust block, the model file as before.
    let plain_out = ok(&run(&["--out", "plain.json"]));
    assert!(!plain_out.contains("Suspect rows"), "{plain_out}");
    let plain = json(&dir.path().join("plain.json"));
    assert!(plain["calibration"].get("robust").is_none());
    assert!(plain["calibration"]["results"][0].get("robust").is_none());

    // Robust (Cauchy).
    let out = ok(&run(&["--robust", "cauchy", "--out", "robust.json"]));
    assert!(out.contains("Robust fit (cauchy IRLS"), "{out}");
    assert!(out.contains("Suspect rows"), "{out}");
    // (a) The suspect table names the corrupted row by line and pose_id; any other suspect is a borderline clean row.
    let row = out
        .lines()
        .skip_while(|l| !l.starts_with("Suspect rows"))
        .find(|l| {
            l.split_whitespace().next() == Some(s.bad_line.to_string().as_str())
                && l.split_whitespace().nth(1) == Some(s.bad_pose_id.as_str())
        });
    assert!(
        row.is_some(),
        "line {} / pose {} not in the suspect table:\n{out}",
        s.bad_line,
        s.bad_pose_id
    );
    let model = json(&dir.path().join("robust.json"));
    let r = &model["calibration"]["robust"];
    assert_eq!(r["loss"], "cauchy");
    assert_eq!(r["algorithm"], "ols");
    let suspects = r["suspects"].as_array().unwrap();
    let bad = suspects
        .iter()
        .find(|x| x["line"] == s.bad_line)
        .unwrap_or_else(|| panic!("line {} not a suspect: {r:#}", s.bad_line));
    assert_eq!(bad["pose_id"], s.bad_pose_id.as_str());
    let d = bad["distance"].as_f64().unwrap();
    assert!(d > 20.0, "a 5 mm glitch at 0.05 mm noise: d = {d}");
    // Any other name is a clean pose's own borderline draw (docs/reliability.md), not a
    // second gross error.
    for x in suspects.iter().filter(|x| x["line"] != s.bad_line) {
        let d = x["distance"].as_f64().unwrap();
        assert!(d < 6.5, "clean row named far above the threshold: {x}");
    }
    let w = bad["robust_weight"].as_f64().unwrap();
    assert!(w < 0.05, "Cauchy all but drops the glitch: weight {w}");
    let e_p = bad["pos_mm"].as_f64().unwrap();
    assert!((e_p - 5.0).abs() < 0.5, "|e_p| of the glitch {e_p} mm");
    // The robust scale is the instrument's noise, not inflated by the glitch.
    let scale = r["scale_pos_mm"].as_f64().unwrap();
    assert!(
        scale > 0.5 * SIGMA_POS_MM && scale < 1.5 * SIGMA_POS_MM,
        "σ_pos {scale} mm"
    );
    assert_eq!(
        model["calibration"]["results"][0]["robust"]["suspects"],
        r["suspects"]
    );

    // (b) The robust parameters are closer to the truth than the plain ones.
    let (pl, pa, n) = error_to_truth(&plain, &s.truth);
    let (rl, ra, m) = error_to_truth(&model, &s.truth);
    assert_eq!(n, m, "same identified set");
    eprintln!(
        "parameter error to the truth: plain {pl:.4} mm / {pa:.5}°, robust {rl:.4} mm / {ra:.5}°"
    );
    assert!(
        rl < 0.5 * pl && ra < 0.5 * pa,
        "robust {rl} mm / {ra}° not clearly closer than plain {pl} mm / {pa}°"
    );

    // The model file reads back: validate takes it like any model.
    ok(&kincal(
        &["validate", "robust.json", "data.csv", "--quiet"],
        dir.path(),
    ));

    // With unknown frames (--effects base_frame,tool_frame --init-frames) too.
    let out = ok(&run(&[
        "--robust",
        "cauchy",
        "--effects",
        "base_frame,tool_frame",
        "--init-frames",
        "--allow-data-deficiency",
        "--out",
        "frames.json",
    ]));
    let frames = json(&dir.path().join("frames.json"));
    let sus = frames["calibration"]["robust"]["suspects"]
        .as_array()
        .unwrap();
    assert!(
        sus.iter().any(|x| x["line"] == s.bad_line),
        "frames: {sus:?}\n{out}"
    );

    // With --algorithm all every algorithm is fitted robustly and names the glitch.
    let out = ok(&run(&[
        "--robust",
        "huber",
        "--algorithm",
        "all",
        "--bounds-mm",
        "10",
        "--out",
        "all.json",
    ]));
    assert!(out.contains("Robust fit (huber IRLS"), "{out}");
    let all = json(&dir.path().join("all.json"));
    assert_eq!(all["calibration"]["robust"]["loss"], "huber");
    for res in all["calibration"]["results"].as_array().unwrap() {
        let sus = res["robust"]["suspects"].as_array().unwrap();
        assert!(
            sus.iter().any(|x| x["line"] == s.bad_line),
            "{}: {sus:?}",
            res["algorithm"]
        );
    }
}

#[test]
fn bad_robust_options_are_usage_errors() {
    let s = session(3);
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("data.csv"), &s.csv).unwrap();
    let cases: [(&[&str], &[&str]); 4] = [
        (&["--robust", "tukey"], &["tukey", "huber", "cauchy"]),
        (&["--robust", "Cauchy2"], &["Cauchy2", "huber", "cauchy"]),
        (&["--robust-tuning", "3"], &["--robust"]),
        (&["--robust", "huber", "--robust-tuning", "0"], &["> 0"]),
    ];
    for (extra, words) in cases {
        let mut a = vec![
            "calibrate",
            "data.csv",
            "--robot",
            "aria",
            "--out",
            "m.json",
        ];
        a.extend_from_slice(extra);
        let o = kincal(&a, dir.path());
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {err}");
        for w in words {
            assert!(err.contains(w), "{extra:?}: '{w}' not in: {err}");
        }
        assert!(!dir.path().join("m.json").exists(), "{extra:?}");
    }
}
