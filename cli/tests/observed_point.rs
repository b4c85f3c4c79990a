//! End-to-end tests of `kincal observed-point`: cameras looking at one target from known
//! places (with small pose noise) are re-expressed at the target; the command must find the
//! viewing distance, move every position onto the target, keep the orientations bit for
//! bit, write the point columns so that the original pose is recoverable, and refuse data
//! it cannot handle (no orientation, point columns already, axes that do not converge,
//! bad arguments) with the right exit status and a message naming the problem.

use std::fs;

use kincal::pose::{matrix_to_quaternion, quaternion_to_matrix, rotation_exp};
use kincal::rng::SplitMix64;
use nalgebra::{Matrix3, Vector3};

mod common;
use common::kincal;

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// A camera frame at `eye` whose z axis points at `target`, rolled by `roll` [rad].
fn look_at(eye: Vector3<f64>, target: Vector3<f64>, roll: f64) -> Matrix3<f64> {
    let z = (target - eye).normalize();
    let x = Vector3::y().cross(&z).normalize();
    let y = z.cross(&x);
    Matrix3::from_columns(&[x, y, z]) * rotation_exp(&(Vector3::z() * roll))
}

const TARGET: [f64; 3] = [1.2, 0.05, 1.4];

/// `n` camera poses 0.4–0.55 m from `TARGET`, each axis missing it by up to `miss_m`;
/// returns the CSV and the true viewing distances.
fn cameras(n: usize, miss_m: f64, seed: u64) -> (String, Vec<f64>) {
    let mut rng = SplitMix64::new(seed);
    let target = Vector3::from(TARGET);
    let mut csv =
        String::from("# synthetic eye-in-hand camera poses\npose_id,q1,q2,x,y,z,qw,qx,qy,qz\n");
    let mut dists = Vec::new();
    for i in 0..n {
        let dir = Vector3::new(
            -0.6 - 0.4 * rng.uniform(),
            rng.uniform() - 0.5,
            rng.uniform() - 0.5,
        )
        .normalize();
        let d = 0.4 + 0.15 * rng.uniform();
        let eye = target - dir * d;
        let aim =
            target + Vector3::new(0.0, rng.uniform() - 0.5, rng.uniform() - 0.5) * (2.0 * miss_m);
        let r = look_at(eye, aim, rng.uniform() * 3.0);
        let q = matrix_to_quaternion(&r);
        dists.push((aim - eye).normalize().dot(&(target - eye)));
        csv.push_str(&format!(
            "{i},{},{},{},{},{},{},{},{},{}\n",
            rng.uniform(),
            rng.uniform(),
            eye.x,
            eye.y,
            eye.z,
            q[0],
            q[1],
            q[2],
            q[3]
        ));
    }
    (csv, dists)
}

fn table(csv: &str) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut lines = csv.lines().filter(|l| !l.starts_with('#'));
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn cameras_are_moved_onto_their_target() {
    let dir = tempfile::tempdir().unwrap();
    let (csv, dists) = cameras(30, 0.0, 7);
    fs::write(dir.path().join("cam.csv"), &csv).unwrap();
    let o = kincal(
        &["observed-point", "cam.csv", "--out", "at.csv"],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    assert!(
        out.contains("30 camera poses") && out.contains("converge at (1.2000, 0.0500, 1.4000)"),
        "{out}"
    );

    let written = fs::read_to_string(dir.path().join("at.csv")).unwrap();
    assert!(written.contains("# synthetic eye-in-hand camera poses"));
    assert!(written.contains("# observed-point: poses moved by s = "));
    let (h0, before) = table(&csv);
    let (h1, after) = table(&written);
    assert_eq!(h1[..h0.len()], h0[..]);
    assert_eq!(&h1[h0.len()..], ["point_x", "point_y", "point_z"]);
    let mean = dists.iter().sum::<f64>() / dists.len() as f64;
    for (b, a) in before.iter().zip(&after) {
        // Joints and orientation bit for bit.
        assert_eq!(a[..3], b[..3]);
        assert_eq!(a[6..10], b[6..10]);
        // The point: (0, 0, s), s the mean viewing distance.
        assert_eq!(a[10..12], [0.0, 0.0]);
        assert!((a[12] - mean).abs() < 1e-12, "s {} vs {mean}", a[12]);
        // Every camera looks exactly at the target: moved by its own distance it would land
        // on it; moved by the mean distance it lands on its axis, |d - s| from the target.
        let r = quaternion_to_matrix(&[b[6], b[7], b[8], b[9]]).unwrap();
        let p = Vector3::new(a[3], a[4], a[5]);
        let back = p - r * Vector3::new(0.0, 0.0, a[12]);
        assert!((back - Vector3::new(b[3], b[4], b[5])).norm() < 1e-12);
        let to_target = (Vector3::from(TARGET) - p).norm();
        let d = (Vector3::from(TARGET) - Vector3::new(b[3], b[4], b[5])).norm();
        assert!((to_target - (d - a[12]).abs()).abs() < 1e-9);
    }
}

#[test]
fn a_forced_distance_and_noisy_axes() {
    let dir = tempfile::tempdir().unwrap();
    // Axes missing the target by up to 20 mm: accepted (well under a quarter of 0.45 m).
    let (csv, _) = cameras(25, 0.02, 3);
    fs::write(dir.path().join("cam.csv"), &csv).unwrap();
    let o = kincal(&["observed-point", "cam.csv", "--out", "a.csv"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let o = kincal(
        &[
            "observed-point",
            "cam.csv",
            "--out",
            "b.csv",
            "--distance",
            "0.3",
        ],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(text(&o.stdout).contains("300.0 mm along z (given)"));
    let (_, rows) = table(&fs::read_to_string(dir.path().join("b.csv")).unwrap());
    assert!(rows.iter().all(|r| r[12] == 0.3));
    // Axes missing by up to 0.3 m do not converge: refused unless forced.
    let (csv, _) = cameras(25, 0.3, 3);
    fs::write(dir.path().join("wide.csv"), &csv).unwrap();
    let o = kincal(
        &["observed-point", "wide.csv", "--out", "c.csv"],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(3));
    let e = text(&o.stderr);
    assert!(
        e.contains("wide.csv: the viewing axes do not converge") && e.contains("--distance"),
        "{e}"
    );
    assert!(!dir.path().join("c.csv").exists());
    // The x axis of these frames points sideways: the point lies behind some camera or the
    // axes miss; either way refused.
    let o = kincal(
        &["observed-point", "cam.csv", "--out", "c.csv", "--axis", "x"],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(3), "{}", text(&o.stderr));
}

#[test]
fn bad_inputs_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (csv, _) = cameras(5, 0.0, 1);
    fs::write(dir.path().join("cam.csv"), &csv).unwrap();
    let run = |args: &[&str]| kincal(args, dir.path());

    for (args, exit, needle) in [
        (
            &["observed-point", "cam.csv", "--out", "o.csv", "--axis", "w"][..],
            2,
            "--axis: 'w' is not one of x, y, z",
        ),
        (
            &[
                "observed-point",
                "cam.csv",
                "--out",
                "o.csv",
                "--distance=-1",
            ][..],
            2,
            "--distance: '-1' is neither 'auto' nor a positive distance",
        ),
        (
            &["observed-point", "cam.csv", "--out", "cam.csv"][..],
            2,
            "names the same file as the input DATA 'cam.csv': an input is never overwritten",
        ),
        (
            &["observed-point", "missing.csv", "--out", "o.csv"][..],
            3,
            "missing.csv: cannot open the file",
        ),
    ] {
        let o = run(args);
        assert_eq!(o.status.code(), Some(exit), "{args:?}: {}", text(&o.stderr));
        assert!(
            text(&o.stderr).contains(needle),
            "{args:?}: {}",
            text(&o.stderr)
        );
    }
    assert_eq!(fs::read_to_string(dir.path().join("cam.csv")).unwrap(), csv);

    // Position-only rows: no viewing axis.
    fs::write(
        dir.path().join("pos.csv"),
        "q1,q2,x,y,z\n0,0,1,2,3\n0.1,0,1,2,3.1\n",
    )
    .unwrap();
    let o = run(&["observed-point", "pos.csv", "--out", "o.csv"]);
    assert_eq!(o.status.code(), Some(3));
    assert!(
        text(&o.stderr).contains("pos.csv:2: no orientation"),
        "{}",
        text(&o.stderr)
    );

    // Rows that already measure points.
    fs::write(
        dir.path().join("pts.csv"),
        "q1,x,y,z,qw,qx,qy,qz,point_x,point_y,point_z\n0,1,2,3,1,0,0,0,0,0,0.1\n",
    )
    .unwrap();
    let o = run(&["observed-point", "pts.csv", "--out", "o.csv"]);
    assert_eq!(o.status.code(), Some(3));
    assert!(
        text(&o.stderr).contains("already has point_x"),
        "{}",
        text(&o.stderr)
    );

    // Parallel axes: no point.
    fs::write(
        dir.path().join("par.csv"),
        "q1,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n0,0.1,0,0,1,0,0,0\n0,0,0.1,0,1,0,0,0\n",
    )
    .unwrap();
    let o = run(&["observed-point", "par.csv", "--out", "o.csv"]);
    assert_eq!(o.status.code(), Some(3));
    assert!(text(&o.stderr).contains("parallel"), "{}", text(&o.stderr));
    assert!(!dir.path().join("o.csv").exists());
}
