//! End-to-end tests of instrument-free calibration (docs/constraints.md): `calibrate` on
//! contact rows at unknown targets with one known distance (ARIA's virtual truth, noise
//! free), `validate`, `crossval --group-by`, and the refusals of bad input (exit 3 naming
//! file, line and column).

use std::fs;
use std::path::Path;

use kincal::ik::{IkOptions, solve_ik};
use kincal::{JointState, Robot, Transform, aria};
use serde_json::Value;

mod common;
use common::{kincal, text};

/// Deterministic uniform numbers (SplitMix64).
struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}

/// Joint readings holding the truth's tool origin at the tool point of `q0` in `n`
/// orientations tilted up to 0.35 rad.
fn holds(truth: &Robot<6>, q0: [f64; 6], n: usize, rng: &mut Rng) -> (Vec<[f64; 6]>, [f64; 3]) {
    let t0 = truth.fk(&JointState::new(q0)).unwrap();
    let p = t0.translation.vector;
    let opts = IkOptions {
        extra_seeds: 4,
        first_solution: true,
        ..IkOptions::default()
    };
    let mut out = Vec::new();
    let mut tries = 0;
    while out.len() < n && tries < 20 * n {
        tries += 1;
        let axis = nalgebra::Vector3::new(
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
        );
        let r = t0.rotation
            * nalgebra::Rotation3::from_scaled_axis(axis.normalize() * rng.uniform(0.05, 0.35));
        let pose = Transform::from_parts(nalgebra::Translation3::from(p), r);
        if let Ok(sol) = solve_ik(truth, &pose, &JointState::new(q0), &opts)
            && sol.residual_pos_m < 1e-12
        {
            out.push(sol.q);
        }
    }
    assert_eq!(out.len(), n);
    (out, [p.x, p.y, p.z])
}

struct Fixture {
    dir: tempfile::TempDir,
    targets: Vec<[f64; 3]>,
}

/// `n_targets` targets in `sessions` sessions, `per` contacts each; the first two targets
/// of each session a known distance apart (in constraints.toml).
fn fixture(n_targets: usize, sessions: usize, per: usize) -> Fixture {
    let truth = aria::virtual_truth();
    let mut rng = Rng(17);
    let mut csv = String::from("q1,q2,q3,q4,q5,q6,target,session\n");
    let mut toml = String::new();
    let mut targets = Vec::new();
    for t in 0..n_targets {
        let s = t % sessions;
        let mut q0 = aria::TOOL_SEED_Q;
        for v in q0.iter_mut() {
            *v += rng.uniform(-0.5, 0.5);
        }
        let (qs, p) = holds(&truth, q0, per, &mut rng);
        for q in qs {
            let cells: Vec<String> = q.iter().map(|v| format!("{v}")).collect();
            csv.push_str(&format!("{},t{t},loc{s}\n", cells.join(",")));
        }
        targets.push(p);
    }
    for s in 0..sessions {
        let (a, b) = (s, s + sessions);
        if b < n_targets {
            let d = dist(targets[a], targets[b]);
            toml.push_str(&format!(
                "[[distance]]\nbetween = [\"t{a}\", \"t{b}\"]\nm = {d}\n\n"
            ));
        }
    }
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("contacts.csv"), csv).unwrap();
    fs::write(dir.path().join("constraints.toml"), toml).unwrap();
    Fixture { dir, targets }
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[test]
fn calibrate_and_validate_from_contacts_recover_the_targets() {
    let f = fixture(12, 3, 6);
    let dir = f.dir.path();
    let o = kincal(
        &[
            "calibrate",
            "contacts.csv",
            "--robot",
            "aria",
            "--constraints",
            "constraints.toml",
            "--out",
            "model.json",
        ],
        dir,
    );
    let out = text(&o);
    assert_eq!(o.status.code(), Some(0), "{out}");
    assert!(out.contains("base frame: NOT observable"), "{out}");
    assert!(out.contains("not observable (gauge)"), "{out}");
    assert!(out.contains("Known distances"), "{out}");
    let model: Value =
        serde_json::from_str(&fs::read_to_string(dir.join("model.json")).unwrap()).unwrap();
    let c = &model["calibration"]["constraints"];
    let targets = c["targets"].as_array().unwrap();
    assert_eq!(targets.len(), f.targets.len());
    let xyz = |t: &Value| -> [f64; 3] {
        let v = t["xyz_m"].as_array().unwrap();
        [
            v[0].as_f64().unwrap(),
            v[1].as_f64().unwrap(),
            v[2].as_f64().unwrap(),
        ]
    };
    for t in targets {
        assert!(t["rms_mm"].as_f64().unwrap() < 1e-6, "{t}");
    }
    // The estimated targets are a rigid image of the true ones (the base is a gauge).
    for i in 0..targets.len() {
        for j in 0..i {
            let (want, got) = (
                dist(f.targets[i], f.targets[j]),
                dist(xyz(&targets[i]), xyz(&targets[j])),
            );
            assert!(
                (want - got).abs() < 1e-8,
                "targets {i}, {j}: {got} vs {want}"
            );
        }
    }
    for d in c["distances"].as_array().unwrap() {
        assert!(d["error_mm"].as_f64().unwrap().abs() < 1e-6, "{d}");
    }
    // validate reports consistency per target and the distance errors.
    let o = kincal(
        &[
            "validate",
            "model.json",
            "contacts.csv",
            "--constraints",
            "constraints.toml",
        ],
        dir,
    );
    let out = text(&o);
    assert_eq!(o.status.code(), Some(0), "{out}");
    assert!(
        out.contains("Consistency") && out.contains("Known distances"),
        "{out}"
    );
    // crossval holds out whole sessions: noise-free, the calibrated model is consistent on
    // held-out placements, the nominal one is not.
    let o = kincal(
        &[
            "crossval",
            "contacts.csv",
            "--robot",
            "aria",
            "--constraints",
            "constraints.toml",
            "--group-by",
            "session",
            "--folds",
            "3",
            "--json",
            "cv.json",
        ],
        dir,
    );
    let out = text(&o);
    assert_eq!(o.status.code(), Some(0), "{out}");
    let cv: Value =
        serde_json::from_str(&fs::read_to_string(dir.join("cv.json")).unwrap()).unwrap();
    let held = &cv["held_out"];
    assert_eq!(held["scored_groups"].as_u64(), Some(12), "{cv}");
    assert!(
        held["calibrated"]["max_mm"].as_f64().unwrap() < 1e-5,
        "{cv}"
    );
    assert!(held["nominal"]["mean_mm"].as_f64().unwrap() > 0.1, "{cv}");
    // predict gives the tool point of contact rows: the contacts of a target coincide.
    let o = kincal(
        &["predict", "model.json", "contacts.csv", "--out", "pred.csv"],
        dir,
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let pred = fs::read_to_string(dir.join("pred.csv")).unwrap();
    let rows: Vec<Vec<f64>> = pred
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("q1") && !l.is_empty())
        .map(|l| l.split(',').filter_map(|c| c.parse().ok()).collect())
        .collect();
    assert_eq!(rows.len(), 72);
    for k in 0..3 {
        assert!(
            (rows[0][6 + k] - rows[5][6 + k]).abs() < 1e-9,
            "{:?} {:?}",
            rows[0],
            rows[5]
        );
    }
    // diagnose on contact rows: held out by session; without a stated noise floor the
    // verdict is undecided, and the noise-free geometric model is not beaten.
    let o = kincal(
        &[
            "diagnose",
            "contacts.csv",
            "--robot",
            "aria",
            "--json",
            "d.json",
            "--out",
            "d.json2",
        ],
        dir,
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(
        text(&o).contains("VERDICT: undecided (noise floor unknown)"),
        "{}",
        text(&o)
    );
    assert!(text(&o).contains("held out by session"), "{}", text(&o));
    // A prior has nothing to act on in the contact routes of crossval and diagnose: refused
    // (exit 2) rather than silently ignored.
    for (cmd, why) in [
        (
            "crossval",
            "not implemented for data with target/plane rows",
        ),
        ("diagnose", "writes no model"),
    ] {
        let mut args = vec![cmd, "contacts.csv", "--robot", "aria", "--prior", "5,1"];
        if cmd == "diagnose" {
            args.extend(["--json", "p.json", "--out", "p_model.json"]);
        }
        let o = kincal(&args, dir);
        assert_eq!(o.status.code(), Some(2), "{cmd}: {}", text(&o));
        assert!(text(&o).contains(why), "{cmd}: {}", text(&o));
    }
}

/// Rewrites line `line` (1-based) of `name` with `edit`.
fn edit_line(dir: &Path, name: &str, line: usize, edit: impl Fn(&str) -> String) {
    let p = dir.join(name);
    let text = fs::read_to_string(&p).unwrap();
    let lines: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i + 1 == line {
                edit(l)
            } else {
                l.to_string()
            }
        })
        .collect();
    fs::write(&p, lines.join("\n") + "\n").unwrap();
}

fn assert_refused(dir: &Path, args: &[&str], want: &str) {
    let o = kincal(args, dir);
    let out = text(&o);
    assert_eq!(o.status.code(), Some(3), "{out}");
    assert!(out.contains(want), "expected {want:?} in {out}");
}

#[test]
fn bad_contact_input_exits_3_naming_file_line_and_column() {
    let cal = [
        "calibrate",
        "contacts.csv",
        "--robot",
        "aria",
        "--constraints",
        "constraints.toml",
        "--out",
        "m.json",
    ];
    // A target with one row: rename the first contact's target.
    let f = fixture(6, 1, 4);
    edit_line(f.dir.path(), "contacts.csv", 2, |l| {
        l.replace(",t0,", ",lonely,")
    });
    assert_refused(
        f.dir.path(),
        &cal,
        "contacts.csv:2: column 'target': target \"lonely\" has 1 row(s)",
    );
    // A distance naming an unknown target.
    let f = fixture(6, 1, 4);
    fs::write(
        f.dir.path().join("constraints.toml"),
        "# plate\n[[distance]]\nbetween = [\"t0\", \"nope\"]\nm = 0.05\n",
    )
    .unwrap();
    assert_refused(
        f.dir.path(),
        &cal,
        "constraints.toml:2: key 'between': no row of contacts.csv names target \"nope\"",
    );
    // A pose and a target on one row.
    let f = fixture(6, 1, 4);
    let csv = fs::read_to_string(f.dir.path().join("contacts.csv")).unwrap();
    let csv = csv.replacen("q6,target,session", "q6,x,y,z,target,session", 1);
    let csv: Vec<String> = csv
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 {
                return l.to_string();
            }
            let mut c: Vec<&str> = l.split(',').collect();
            let extra = if i == 3 {
                ["0.1", "", ""]
            } else {
                ["", "", ""]
            };
            for (k, v) in extra.into_iter().enumerate() {
                c.insert(6 + k, v);
            }
            c.join(",")
        })
        .collect();
    fs::write(f.dir.path().join("contacts.csv"), csv.join("\n") + "\n").unwrap();
    assert_refused(f.dir.path(), &cal, "contacts.csv:4: column 'x':");
    // A session with too few rows.
    let f = fixture(6, 1, 4);
    edit_line(f.dir.path(), "contacts.csv", 5, |l| {
        l.replace(",loc0", ",alone")
    });
    assert_refused(
        f.dir.path(),
        &cal,
        "contacts.csv:5: column 'session': session \"alone\" has 1 row(s)",
    );
    // A constraints file with an unknown key names its line.
    let f = fixture(6, 1, 4);
    fs::write(
        f.dir.path().join("constraints.toml"),
        "[[distance]]\nbetween = [\"t0\", \"t1\"]\nm = 0.05\n\n[[target]]\nid = \"t2\"\nxyz = [0, 0, 0]\n",
    )
    .unwrap();
    assert_refused(f.dir.path(), &cal, "constraints.toml:7");
    // A session after the first with instrument rows gets a frame of its own and needs
    // three of them: "s1" has two (and two contacts of a target, so it is not too small).
    let f = fixture(6, 1, 4);
    let truth = aria::virtual_truth();
    let mut csv = String::from("q1,q2,q3,q4,q5,q6,x,y,z,target,session\n");
    for k in 0..7 {
        let mut q = aria::TOOL_SEED_Q;
        q[0] += 0.05 * k as f64;
        q[2] += 0.03 * k as f64;
        let p = truth.fk(&JointState::new(q)).unwrap().translation.vector;
        let cells: Vec<String> = q.iter().map(|v| format!("{v}")).collect();
        let (xyz, target, s) = match k {
            0..3 => (format!("{},{},{}", p.x, p.y, p.z), "", "s0"),
            3 | 6 => (format!("{},{},{}", p.x + 1.0, p.y, p.z), "", "s1"),
            _ => (",,".to_string(), "t9", "s1"),
        };
        csv.push_str(&format!("{},{xyz},{target},{s}\n", cells.join(",")));
    }
    fs::write(f.dir.path().join("inst.csv"), csv).unwrap();
    assert_refused(
        f.dir.path(),
        &[
            "calibrate",
            "inst.csv",
            "--robot",
            "aria",
            "--out",
            "m.json",
        ],
        "inst.csv:5: column 'session': session \"s1\" has 2 instrument row(s) (x, y, z): \
         expected at least 3",
    );
    // Collinear plane contacts: plane "edge" touched at five points along a line.
    let f = fixture(6, 1, 4);
    let truth = aria::virtual_truth();
    let t0 = truth.fk(&JointState::new(aria::TOOL_SEED_Q)).unwrap();
    let opts = IkOptions::default();
    let mut csv = fs::read_to_string(f.dir.path().join("contacts.csv")).unwrap();
    let first_line = csv.lines().count() + 1;
    for k in 0..5 {
        let mut pose = t0;
        pose.translation.vector.x += 0.02 * k as f64;
        let q = solve_ik(&truth, &pose, &JointState::new(aria::TOOL_SEED_Q), &opts)
            .unwrap()
            .q;
        let cells: Vec<String> = q.iter().map(|v| format!("{v}")).collect();
        csv.push_str(&format!("{},,loc0,edge\n", cells.join(",")));
    }
    let csv = csv.replacen("q6,target,session", "q6,target,session,plane", 1);
    let csv: Vec<String> = csv
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i > 0 && i + 1 < first_line {
                format!("{l},")
            } else {
                l.to_string()
            }
        })
        .collect();
    fs::write(f.dir.path().join("contacts.csv"), csv.join("\n") + "\n").unwrap();
    let want = format!(
        "contacts.csv:{first_line}: column 'plane': the contacts of plane \"edge\" are collinear"
    );
    assert_refused(f.dir.path(), &cal, &want);
}

#[test]
fn robust_calibration_from_contacts_names_a_bad_contact() {
    let f = fixture(12, 3, 6);
    let dir = f.dir.path();
    // Line 9 (a contact of t1): joint 2 read 0.02 rad off, the tool point some 10 mm away.
    edit_line(dir, "contacts.csv", 9, |l| {
        let mut c: Vec<String> = l.split(',').map(str::to_string).collect();
        c[1] = format!("{}", c[1].parse::<f64>().unwrap() + 0.02);
        c.join(",")
    });
    let o = kincal(
        &[
            "calibrate",
            "contacts.csv",
            "--robot",
            "aria",
            "--constraints",
            "constraints.toml",
            "--robust",
            "cauchy",
            "--out",
            "model.json",
        ],
        dir,
    );
    let out = text(&o);
    assert!(o.status.success(), "{out}");
    assert!(out.contains("Robust fit (cauchy IRLS"), "{out}");
    let suspects = out
        .lines()
        .skip_while(|l| !l.starts_with("Suspect rows"))
        .collect::<Vec<_>>();
    assert!(
        suspects.first().is_some_and(|l| l.ends_with(": 1")),
        "{out}"
    );
    assert!(
        suspects.iter().any(|l| l.trim_start().starts_with("9 ")),
        "{out}"
    );
}

/// `crossval --robust` on contact data: four contacts (of four targets in three sessions)
/// read with joint 2 0.02 rad off, some 10 mm from their socket. Held out by session, the
/// plain fit is pulled by the bad training contacts and its held-out error shows it; the
/// robust fit (the constrained IRLS of `calibrate --robust`) is not.
#[test]
fn robust_crossval_from_contacts_beats_the_plain_fit_held_out() {
    let f = fixture(12, 3, 6);
    let dir = f.dir.path();
    for line in [9, 21, 33, 45] {
        edit_line(dir, "contacts.csv", line, |l| {
            let mut c: Vec<String> = l.split(',').map(str::to_string).collect();
            c[1] = format!("{}", c[1].parse::<f64>().unwrap() + 0.02);
            c.join(",")
        });
    }
    let held_out = |robust: Option<&str>| -> (f64, Value) {
        let mut args = vec![
            "crossval",
            "contacts.csv",
            "--robot",
            "aria",
            "--constraints",
            "constraints.toml",
            "--group-by",
            "session",
            "--folds",
            "3",
            "--json",
            "cv.json",
        ];
        if let Some(loss) = robust {
            args.extend(["--robust", loss]);
        }
        let o = kincal(&args, dir);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        let cv: Value =
            serde_json::from_str(&fs::read_to_string(dir.join("cv.json")).unwrap()).unwrap();
        let m = cv["held_out"]["calibrated"]["mean_mm"].as_f64().unwrap();
        (m, cv)
    };
    let (plain, _) = held_out(None);
    for loss in ["cauchy", "huber"] {
        let (robust, cv) = held_out(Some(loss));
        assert_eq!(cv["robust_loss"].as_str(), Some(loss), "{cv}");
        eprintln!("held-out mean |e|: plain {plain:.4} mm, {loss} {robust:.4} mm");
        assert!(
            robust < 0.8 * plain,
            "{loss}: {robust} vs plain {plain}: {cv}"
        );
    }
}
