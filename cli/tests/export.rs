//! `kincal export`: the URDF read back by this test's own minimal URDF reader (origin/axis
//! chain and 4×4 products, not `urdf.rs`) reproduces the model file's FK on random
//! configurations, for a model calibrated by `kincal calibrate` on simulated ARIA data and
//! for a perturbed 7R arm; the mDH table (CSV, YAML) reads back to the model file's exact
//! parameters; bad input exits 2/3 with a reason.

use std::f64::consts::FRAC_PI_2;
use std::fs;
use std::path::Path;
use std::process::{Command, Output};

use kincal::model::{JointLimits, Link};
use kincal::pose::matrix_to_quaternion;
use kincal::{ParamId, Robot, aria};
use kincal_io::model_file::{self, ModelFile};

mod common;
use common::kincal;

/// FK agreement of the exported URDF with the model [m] and rotation-matrix entries.
const FK_TOL: f64 = 1e-12;

type M4 = [[f64; 4]; 4];

fn code(o: &Output) -> i32 {
    o.status.code().expect("exit code")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A small deterministic generator (64-bit LCG), uniform in [0, 1).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn within(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

fn random_q<const N: usize>(r: &Robot<N>, rng: &mut Lcg) -> [f64; N] {
    let lim = r.limits();
    std::array::from_fn(|i| {
        let lo = lim[i].lower.max(-3.0);
        let hi = lim[i].upper.min(3.0);
        rng.within(lo, hi)
    })
}

// ---------- an independent minimal URDF reader ----------

fn mul(a: &M4, b: &M4) -> M4 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..4).map(|k| a[i][k] * b[k][j]).sum()))
}

fn identity() -> M4 {
    std::array::from_fn(|i| std::array::from_fn(|j| if i == j { 1.0 } else { 0.0 }))
}

/// URDF `<origin>`: Trans(xyz)·Rz(yaw)·Ry(pitch)·Rx(roll), written out by hand.
fn origin(xyz: [f64; 3], rpy: [f64; 3]) -> M4 {
    let (sr, cr) = rpy[0].sin_cos();
    let (sp, cp) = rpy[1].sin_cos();
    let (sy, cy) = rpy[2].sin_cos();
    [
        [
            cy * cp,
            cy * sp * sr - sy * cr,
            cy * sp * cr + sy * sr,
            xyz[0],
        ],
        [
            sy * cp,
            sy * sp * sr + cy * cr,
            sy * sp * cr - cy * sr,
            xyz[1],
        ],
        [-sp, cp * sr, cp * cr, xyz[2]],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// Rotation by `q` about the unit axis `k` (Rodrigues).
fn axis_rotation(k: [f64; 3], q: f64) -> M4 {
    let n = (k[0] * k[0] + k[1] * k[1] + k[2] * k[2]).sqrt();
    let [x, y, z] = k.map(|v| v / n);
    let (s, c) = q.sin_cos();
    let t = 1.0 - c;
    [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y, 0.0],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x, 0.0],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// The value of attribute `name` in the first tag `<tag …>` of `text`.
fn attr(text: &str, tag: &str, name: &str) -> Option<String> {
    let start = text.find(&format!("<{tag} "))?;
    let end = start + text[start..].find('>')?;
    let t = &text[start..end];
    let key = format!(" {name}=\"");
    let a = t.find(&key)? + key.len();
    let b = a + t[a..].find('"')?;
    Some(t[a..b].to_string())
}

fn three(s: &str) -> [f64; 3] {
    let v: Vec<f64> = s
        .split_whitespace()
        .map(|x| x.parse().expect("number"))
        .collect();
    [v[0], v[1], v[2]]
}

#[derive(Debug)]
struct UrdfJoint {
    kind: String,
    parent: String,
    child: String,
    origin: M4,
    axis: [f64; 3],
}

/// The kinematic joints (a `<joint>` with a type, parent and child; transmission joints are
/// skipped).
fn read_joints(urdf: &str) -> Vec<UrdfJoint> {
    urdf.split("<joint ")
        .skip(1)
        .filter_map(|chunk| {
            let body = &chunk[..chunk.find("</joint>")?];
            let body = format!("<joint {body}");
            Some(UrdfJoint {
                kind: attr(&body, "joint", "type")?,
                parent: attr(&body, "parent", "link")?,
                child: attr(&body, "child", "link")?,
                origin: origin(
                    three(&attr(&body, "origin", "xyz").unwrap_or("0 0 0".into())),
                    three(&attr(&body, "origin", "rpy").unwrap_or("0 0 0".into())),
                ),
                axis: three(&attr(&body, "axis", "xyz").unwrap_or("1 0 0".into())),
            })
        })
        .collect()
}

/// The tip link in the base link for the movable joints' values `q` (in chain order).
fn urdf_fk(joints: &[UrdfJoint], base: &str, tip: &str, q: &[f64]) -> M4 {
    let mut path = Vec::new();
    let mut link = tip.to_string();
    while link != base {
        let j = joints
            .iter()
            .find(|j| j.child == link)
            .unwrap_or_else(|| panic!("no joint above {link}"));
        path.push(j);
        link = j.parent.clone();
    }
    path.reverse();
    let mut t = identity();
    let mut k = 0;
    for j in path {
        t = mul(&t, &j.origin);
        if j.kind != "fixed" {
            assert!(j.kind == "revolute" || j.kind == "continuous", "{}", j.kind);
            t = mul(&t, &axis_rotation(j.axis, q[k]));
            k += 1;
        }
    }
    assert_eq!(k, q.len(), "movable joints on the chain");
    t
}

fn assert_urdf_matches_model<const N: usize>(urdf: &str, model: &Robot<N>, seed: u64) {
    assert_chain_matches_model(urdf, "base_link", "tool0", model, seed);
}

fn assert_chain_matches_model<const N: usize>(
    urdf: &str,
    base: &str,
    tip: &str,
    model: &Robot<N>,
    seed: u64,
) {
    let joints = read_joints(urdf);
    let mut rng = Lcg(seed);
    let mut worst = 0.0f64;
    for _ in 0..200 {
        let q = random_q(model, &mut rng);
        let want = model.fk_q(&q).unwrap();
        let got = urdf_fk(&joints, base, tip, &q);
        let m = want.to_homogeneous();
        for (i, row) in got.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                worst = worst.max((v - m[(i, j)]).abs());
            }
        }
    }
    assert!(
        worst < FK_TOL,
        "URDF FK differs from the model by {worst:e}"
    );
    assert!(worst.is_finite());
    eprintln!("URDF vs model FK, {N} joints: worst difference {worst:e} over 200 configurations");
}

// ---------- fixtures ----------

/// A measurement CSV of the ARIA truth's exact poses at 30 random configurations.
fn aria_data(rng: &mut Lcg) -> String {
    let truth = aria::virtual_truth();
    let mut s = String::from("pose_id,q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz\n");
    for l in 0..30 {
        let q = random_q(&truth, rng);
        let t = truth.fk_q(&q).unwrap();
        let p = t.translation.vector;
        let quat = matrix_to_quaternion(t.rotation.matrix());
        let mut cells = vec![format!("p{l}")];
        cells.extend(
            q.iter()
                .chain(&[p.x, p.y, p.z])
                .chain(&quat)
                .map(|v| format!("{v}")),
        );
        s.push_str(&cells.join(","));
        s.push('\n');
    }
    s
}

/// A model file of ARIA calibrated by `kincal calibrate` on simulated data.
fn calibrated_aria(dir: &Path) -> ModelFile {
    fs::write(dir.join("data.csv"), aria_data(&mut Lcg(7))).unwrap();
    let o = kincal(
        &[
            "calibrate",
            "data.csv",
            "--robot",
            "aria",
            "--out",
            "model.json",
        ],
        dir,
    );
    assert_eq!(code(&o), 0, "calibrate: {}", stderr(&o));
    read_model(&dir.join("model.json"))
}

fn read_model(path: &Path) -> ModelFile {
    model_file::parse(&fs::read_to_string(path).unwrap(), "model").unwrap()
}

/// A 7R arm (Franka-like) with every link parameter, the base and the tool perturbed.
fn arm_7r() -> Robot<7> {
    let mut rng = Lcg(42);
    let nominal = [
        (0.333, 0.0, 0.0),
        (0.0, 0.0, -FRAC_PI_2),
        (0.316, 0.0, FRAC_PI_2),
        (0.0, 0.0825, FRAC_PI_2),
        (0.384, -0.0825, -FRAC_PI_2),
        (0.0, 0.0, FRAC_PI_2),
        (0.107, 0.088, FRAC_PI_2),
    ];
    let links = nominal.map(|(d, a, alpha)| Link {
        theta0: rng.within(-0.01, 0.01),
        d: d + rng.within(-0.002, 0.002),
        a: a + rng.within(-0.002, 0.002),
        alpha: alpha + rng.within(-0.005, 0.005),
        beta: 0.0,
    });
    let limits = [JointLimits::new(-2.8, 2.8); 7];
    let mut r = Robot::new(links, limits)
        .unwrap()
        .with_base([0.1, -0.2, 0.05, 0.01, -0.02, 0.3])
        .unwrap()
        .with_tool([0.0, 0.01, 0.1034, 0.0, 0.0, -0.785])
        .unwrap();
    // A nonzero β where the model identifies β (parallel neighbour axes, if any).
    for (i, lp) in r.length_params().clone().iter().enumerate() {
        if *lp == kincal::model::LengthParam::Beta {
            let id = ParamId::Link {
                link: i,
                kind: kincal::params::LinkParam::Beta,
            };
            r.set_param(id.index(7), 0.003).unwrap();
        }
    }
    r
}

// ---------- URDF round trips ----------

#[test]
fn urdf_of_a_calibrated_aria_reproduces_its_fk() {
    let dir = tempfile::tempdir().unwrap();
    let file = calibrated_aria(dir.path());
    let model = file.robot.robot::<6>().unwrap();
    assert_ne!(
        model.links(),
        aria::nominal().links(),
        "the calibration moved the model off the nominal"
    );
    let o = kincal(&["export", "model.json", "--urdf", "aria.urdf"], dir.path());
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let urdf = fs::read_to_string(dir.path().join("aria.urdf")).unwrap();
    assert_urdf_matches_model(&urdf, &model, 1);
}

#[test]
fn urdf_of_a_7r_arm_reproduces_its_fk() {
    let dir = tempfile::tempdir().unwrap();
    let r = arm_7r();
    fs::write(
        dir.path().join("arm7.json"),
        ModelFile::nominal("arm7", &r).to_json(),
    )
    .unwrap();
    let o = kincal(
        &[
            "export",
            "arm7.json",
            "--urdf",
            "arm7.urdf",
            "--base-link",
            "base_link",
        ],
        dir.path(),
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let urdf = fs::read_to_string(dir.path().join("arm7.urdf")).unwrap();
    assert_urdf_matches_model(
        &urdf,
        &read_model(&dir.path().join("arm7.json"))
            .robot
            .robot::<7>()
            .unwrap(),
        2,
    );
    assert_urdf_matches_model(&urdf, &r, 3);
}

#[test]
fn the_independent_reader_sees_a_wrong_urdf() {
    // The check can fail: a URDF of another robot does not match the model.
    let dir = tempfile::tempdir().unwrap();
    let o = kincal(&["export", "aria", "--urdf", "nominal.urdf"], dir.path());
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let urdf = fs::read_to_string(dir.path().join("nominal.urdf")).unwrap();
    let joints = read_joints(&urdf);
    let truth = aria::virtual_truth();
    let q = [0.3, -0.2, 0.5, 1.0, -0.7, 0.4];
    let got = urdf_fk(&joints, "base_link", "tool0", &q);
    let want = truth.fk_q(&q).unwrap().to_homogeneous();
    let diff = (0..3)
        .map(|i| (got[i][3] - want[(i, 3)]).abs())
        .fold(0.0, f64::max);
    assert!(diff > 1e-4, "nominal vs truth differ by {diff:e} m only");
    let nominal = aria::nominal().fk_q(&q).unwrap().to_homogeneous();
    let same = (0..3)
        .map(|i| (got[i][3] - nominal[(i, 3)]).abs())
        .fold(0.0, f64::max);
    assert!(same < FK_TOL, "{same:e}");
}

// ---------- mDH table round trips ----------

/// The model file's label for a CSV/YAML (frame, column) cell.
fn label_of(frame: &str, column: &str) -> String {
    let kind = column.rsplit_once('_').map_or(column, |(k, _)| k);
    match frame {
        "base" | "tool" => format!("{frame}_{kind}"),
        link if column == "value" => link.to_string(),
        link => format!("{kind}_{link}"),
    }
}

/// (label, value, std_error) of every number of a CSV table.
fn read_csv_table(text: &str) -> Vec<(String, f64, Option<f64>)> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let mut out = Vec::new();
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        assert_eq!(cells.len(), header.len(), "{line}");
        let frame = cells[0];
        for (col, cell) in header.iter().zip(&cells).skip(1) {
            if cell.is_empty()
                || col.starts_with("std_")
                || [
                    "length_param",
                    "joint_type",
                    "lower_rad",
                    "upper_rad",
                    "unit",
                ]
                .contains(col)
            {
                continue;
            }
            let std_col = format!("std_{col}");
            let std = header
                .iter()
                .position(|h| *h == std_col)
                .and_then(|k| cells[k].parse::<f64>().ok());
            out.push((label_of(frame, col), cell.parse().unwrap(), std));
        }
    }
    out
}

/// (label, value, std_error) of every number of the YAML table's links, base and tool.
fn read_yaml_table(text: &str) -> Vec<(String, f64, Option<f64>)> {
    let mut out = Vec::new();
    for line in text.lines() {
        let (frame, body) = if let Some(b) = line.strip_prefix("  - {link: ") {
            let (n, rest) = b.split_once(',').unwrap();
            (n.to_string(), rest)
        } else if let Some(b) = line.strip_prefix("base: ") {
            ("base".to_string(), b)
        } else if let Some(b) = line.strip_prefix("tool: ") {
            ("tool".to_string(), b)
        } else {
            continue;
        };
        let (values, std) = body.split_once("std_error:").unwrap_or((body, ""));
        let pairs = |s: &str| -> Vec<(String, f64)> {
            s.split([',', '{', '}'])
                .filter_map(|kv| kv.split_once(':'))
                .filter_map(|(k, v)| Some((k.trim().to_string(), v.trim().parse().ok()?)))
                .filter(|(k, _)| k != "lower_rad" && k != "upper_rad")
                .collect()
        };
        let std = pairs(std);
        for (k, v) in pairs(values) {
            let s = std.iter().find(|(c, _)| *c == k).map(|(_, s)| *s);
            out.push((label_of(&frame, &k), v, s));
        }
    }
    out
}

fn assert_table_is_the_model(table: &[(String, f64, Option<f64>)], file: &ModelFile, what: &str) {
    let geometric: Vec<_> = file
        .robot
        .parameters
        .iter()
        .filter(|p| {
            matches!(
                ParamId::parse(&p.label, file.robot.n_joints),
                Some(ParamId::Link { .. } | ParamId::Base(_) | ParamId::Tool(_))
            )
        })
        .collect();
    assert_eq!(
        table.len(),
        geometric.len(),
        "{what}: one cell per parameter"
    );
    let mut with_std = 0;
    for p in geometric {
        let (_, v, s) = table
            .iter()
            .find(|(l, _, _)| *l == p.label)
            .unwrap_or_else(|| panic!("{what}: {} missing", p.label));
        assert_eq!(v.to_bits(), p.value.to_bits(), "{what}: {}", p.label);
        assert_eq!(
            s.map(f64::to_bits),
            p.std_error.map(f64::to_bits),
            "{what}: std error of {}",
            p.label
        );
        with_std += usize::from(s.is_some());
    }
    assert!(
        with_std > 0,
        "{what}: the calibrated model has standard errors"
    );
}

#[test]
fn mdh_tables_read_back_to_the_exact_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let file = calibrated_aria(dir.path());
    let o = kincal(
        &[
            "export",
            "model.json",
            "--mdh-table",
            "t.csv",
            "--urdf",
            "t.urdf",
        ],
        dir.path(),
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let o = kincal(
        &["export", "model.json", "--mdh-table", "t.yaml"],
        dir.path(),
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let csv = fs::read_to_string(dir.path().join("t.csv")).unwrap();
    assert!(csv.starts_with("frame,theta0_rad,d_m,a_m,alpha_rad,beta_rad,"));
    assert_table_is_the_model(&read_csv_table(&csv), &file, "CSV");
    let yaml = fs::read_to_string(dir.path().join("t.yaml")).unwrap();
    assert_table_is_the_model(&read_yaml_table(&yaml), &file, "YAML");
}

#[test]
fn yaml_numbers_are_floats_for_yaml_1_1_and_read_back() {
    use kincal_cli::commands::export::yaml_number;
    for v in [1e-7, -2.5e-9, 1e20, 0.1, 1.0 / 3.0, -0.0048, 0.0, 6.02e23] {
        let s = yaml_number(v);
        assert_eq!(s.parse::<f64>().unwrap().to_bits(), v.to_bits(), "{s}");
        if s.contains('e') {
            assert!(
                s.contains('.') && (s.contains("e-") || s.contains("e+")),
                "{s}"
            );
        }
    }
}

#[test]
fn effects_appear_in_the_table_and_block_the_urdf_unless_dropped() {
    let dir = tempfile::tempdir().unwrap();
    let r = aria::nominal();
    let mut file = ModelFile::nominal("aria", &r);
    file.robot.effects = vec!["joint_compliance".into()];
    for p in &mut file.robot.parameters {
        if p.label == "compliance_2" {
            p.value = 2.5e-5;
        }
    }
    fs::write(dir.path().join("m.json"), file.to_json()).unwrap();
    let o = kincal(&["export", "m.json", "--urdf", "m.urdf"], dir.path());
    assert_eq!(code(&o), 3, "{}", stderr(&o));
    assert!(stderr(&o).contains("joint_compliance"), "{}", stderr(&o));
    assert!(stderr(&o).contains("--drop-effects"), "{}", stderr(&o));
    assert!(!dir.path().join("m.urdf").exists());
    let o = kincal(
        &[
            "export",
            "m.json",
            "--urdf",
            "m.urdf",
            "--drop-effects",
            "--mdh-table",
            "m.csv",
        ],
        dir.path(),
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let csv = fs::read_to_string(dir.path().join("m.csv")).unwrap();
    let rows: Vec<&str> = csv
        .lines()
        .filter(|l| l.starts_with("compliance_"))
        .collect();
    assert_eq!(
        rows.len(),
        6,
        "every compliance parameter of the listed effect"
    );
    let c2: Vec<&str> = rows
        .iter()
        .find(|l| l.starts_with("compliance_2,"))
        .unwrap()
        .split(',')
        .collect();
    // value and unit follow the 5 link, length_param, joint_type, 2 limit and 6 frame columns.
    assert_eq!(c2[16].parse::<f64>().unwrap(), 2.5e-5, "{csv}");
    assert_eq!(c2[17], "rad/(N·m)");
    assert!(
        !csv.contains("backlash_"),
        "effects the model lacks are left out"
    );
}

// ---------- bad input ----------

#[test]
fn bad_input_exits_with_a_reason() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(
        d.join("m.json"),
        ModelFile::nominal("aria", &aria::nominal()).to_json(),
    )
    .unwrap();
    let cases: [(&[&str], i32, &str); 6] = [
        (&["export", "m.json"], 2, "nothing to export"),
        (
            &["export", "m.json", "--urdf", "m.json"],
            2,
            "names the same file as the input MODEL",
        ),
        (
            &["export", "m.json", "--mdh-table", "./m.json"],
            2,
            "names the same file as the input MODEL",
        ),
        (
            &["export", "m.json", "--mdh-table", "t.txt"],
            2,
            ".csv, .yaml or .yml",
        ),
        (
            &[
                "export",
                "m.json",
                "--urdf",
                "m.urdf",
                "--mdh-table",
                "m.urdf",
            ],
            2,
            "name the same file",
        ),
        (
            &[
                "export",
                "m.json",
                "--mdh-table",
                "t.csv",
                "--from",
                "x.urdf",
            ],
            2,
            "--urdf",
        ),
    ];
    for (args, want, reason) in cases {
        let o = kincal(args, d);
        assert_eq!(code(&o), want, "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(reason), "{args:?}: {}", stderr(&o));
    }
    // --from naming the output is refused before anything else.
    let o = kincal(
        &["export", "m.json", "--urdf", "r.urdf", "--from", "r.urdf"],
        d,
    );
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    let text = fs::read_to_string(d.join("m.json")).unwrap();
    fs::write(
        d.join("new.json"),
        text.replace("\"schema_version\": \"1.0\"", "\"schema_version\": \"2.0\""),
    )
    .unwrap();
    let o = kincal(&["export", "new.json", "--urdf", "n.urdf"], d);
    assert_eq!(code(&o), 3, "{}", stderr(&o));
    assert!(stderr(&o).contains("newer"), "{}", stderr(&o));
    assert!(!d.join("n.urdf").exists());
    assert_eq!(
        fs::read_to_string(d.join("m.json")).unwrap(),
        text,
        "input untouched"
    );
}

// ---------- C header ----------

/// The C program printing every field of the exported initializer with 17 significant
/// digits (enough to read back the exact double).
const C_MAIN: &str = r#"#include <stdio.h>
#include "robot.h"
int main(void) {
    const kincal_robot *r = &exported_robot;
    size_t i;
    printf("n %u\n", (unsigned)r->n_joints);
    for (i = 0; i < KINCAL_MAX_JOINTS; i++) printf("length %u\n", (unsigned)r->length_param[i]);
    for (i = 0; i < KINCAL_MAX_PARAMS; i++) printf("params %.17g\n", r->params[i]);
    for (i = 0; i < KINCAL_MAX_GEOMETRIC_PARAMS; i++) printf("nominal %.17g\n", r->nominal[i]);
    for (i = 0; i < KINCAL_MAX_JOINTS; i++) printf("lower %.17g\n", r->limits_lower[i]);
    for (i = 0; i < KINCAL_MAX_JOINTS; i++) printf("upper %.17g\n", r->limits_upper[i]);
    for (i = 0; i < KINCAL_MAX_JOINTS; i++) printf("mass %.17g\n", r->link_masses_kg[i]);
    printf("tool_mass %.17g\n", r->tool_mass_kg);
    for (i = 0; i < 3; i++) printf("gravity %.17g\n", r->gravity[i]);
    return 0;
}
"#;

/// Compiles the exported header with a strict C11 compiler and returns the printed fields.
fn compile_and_print(dir: &Path) -> Vec<(String, f64)> {
    fs::write(dir.join("main.c"), C_MAIN).unwrap();
    let include = Path::new(env!("CARGO_MANIFEST_DIR")).join("../include");
    let o = Command::new("cc")
        .args(["-std=c11", "-Wall", "-Wextra", "-Werror", "-pedantic", "-I"])
        .arg(&include)
        .args(["-I", ".", "main.c", "-o", "print_robot"])
        .current_dir(dir)
        .output()
        .expect("a C compiler `cc`");
    assert!(o.status.success(), "cc: {}", stderr(&o));
    let o = Command::new(dir.join("print_robot")).output().unwrap();
    assert!(o.status.success());
    String::from_utf8(o.stdout)
        .unwrap()
        .lines()
        .map(|l| {
            let (k, v) = l.split_once(' ').unwrap();
            (k.to_string(), v.parse().unwrap())
        })
        .collect()
}

fn field(printed: &[(String, f64)], key: &str) -> Vec<f64> {
    printed
        .iter()
        .filter(|(k, _)| k == key)
        .map(|(_, v)| *v)
        .collect()
}

#[test]
fn c_header_compiles_strictly_and_holds_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let file = calibrated_aria(dir.path());
    let model = file.robot.robot::<6>().unwrap();
    let o = kincal(
        &[
            "export",
            "model.json",
            "--c-header",
            "robot.h",
            "--c-name",
            "exported_robot",
        ],
        dir.path(),
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let printed = compile_and_print(dir.path());
    assert_eq!(field(&printed, "n"), [6.0]);
    let mut want = vec![0.0; Robot::<6>::NUM_PARAMS];
    model.read_params(&mut want).unwrap();
    let params = field(&printed, "params");
    for (i, (got, w)) in params.iter().zip(&want).enumerate() {
        assert_eq!(got.to_bits(), w.to_bits(), "params[{i}]");
    }
    assert!(params[want.len()..].iter().all(|v| *v == 0.0));
    let lengths = field(&printed, "length");
    for (i, lp) in model.length_params().iter().enumerate() {
        let want = f64::from(u8::from(*lp == kincal::model::LengthParam::Beta));
        assert_eq!(lengths[i], want, "length_param[{i}]");
    }
    let lower = field(&printed, "lower");
    let upper = field(&printed, "upper");
    for (i, l) in model.limits().iter().enumerate() {
        assert_eq!((lower[i], upper[i]), (l.lower, l.upper), "limits[{i}]");
    }
    // The robot rebuilt from the printed numbers has the model's FK exactly.
    let mut rebuilt = aria::nominal();
    rebuilt.write_params(&params[..want.len()]).unwrap();
    let mut rng = Lcg(11);
    for _ in 0..50 {
        let q = random_q(&model, &mut rng);
        assert_eq!(
            rebuilt.fk_q(&q).unwrap().to_homogeneous(),
            model.fk_q(&q).unwrap().to_homogeneous()
        );
    }
    let nominal = field(&printed, "nominal");
    let mut nominal_want = vec![0.0; Robot::<6>::NUM_PARAMS];
    file.robot
        .nominal_robot::<6>()
        .unwrap()
        .read_params(&mut nominal_want)
        .unwrap();
    assert_eq!(
        nominal[..Robot::<6>::NUM_GEOMETRIC_PARAMS],
        nominal_want[..Robot::<6>::NUM_GEOMETRIC_PARAMS]
    );
    let o = kincal(
        &[
            "export",
            "model.json",
            "--c-header",
            "x.h",
            "--c-name",
            "2bad",
        ],
        dir.path(),
    );
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(stderr(&o).contains("not a C identifier"));
}

// ---------- --from: the user's own URDF updated ----------

/// A 4R arm with a fixed mount, parallel axes (j2, j3), a camera branch, a mesh, a comment and
/// a gazebo tag, all of which must survive the update.
const OWN_URDF: &str = r#"<?xml version="1.0"?>
<robot name="own">
  <!-- a comment that must stay -->
  <link name="base_link"/>
  <link name="mount"/>
  <link name="l1"/>
  <link name="l2">
    <visual><origin xyz="0.2 0 0" rpy="0 1.5 0"/><geometry><mesh filename="package://own/l2.stl"/></geometry></visual>
    <inertial><origin xyz="0.2 0 0" rpy="0 0 0"/><mass value="2.5"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.03"/></inertial>
  </link>
  <link name="l3"/>
  <link name="cam"/>
  <link name="l4"/>
  <link name="tool0"/>
  <joint name="mount_joint" type="fixed"><parent link="base_link"/><child link="mount"/><origin xyz="0 0 0.1" rpy="0 0 0.3"/></joint>
  <joint name="j1" type="revolute"><parent link="mount"/><child link="l1"/><origin xyz="0 0 0.2" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0.1 0.3" rpy="0.1 0 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="10" velocity="1"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/><origin xyz="0.4 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/><limit lower="-2.5" upper="2.5" effort="10" velocity="1"/></joint>
  <joint name="cam_joint" type="fixed"><parent link="l3"/><child link="cam"/><origin xyz="0.05 0.05 0" rpy="0 0 1"/></joint>
  <joint name="j4" type="revolute"><parent link="l3"/><child link="l4"/><origin xyz="0.3 0 0.05" rpy="0 0 0"/><axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="tool_joint" type="fixed"><parent link="l4"/><child link="tool0"/><origin xyz="0.1 0 0" rpy="0 1.2 0"/></joint>
  <gazebo reference="l2"><material>Gazebo/Orange</material></gazebo>
</robot>
"#;

/// Every `<origin …/>` tag removed: what an update must leave exactly as it was.
fn without_origins(text: &str) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some(i) = rest.find("<origin") {
        out.push_str(&rest[..i]);
        rest = &rest[i + rest[i..].find("/>").unwrap() + 2..];
    }
    out.push_str(rest);
    out
}

/// Exports a perturbed model of the chain `base`→`tip` of `text` with --from and checks FK
/// and that nothing but chain joint origins changed.
fn check_from<const N: usize>(
    nominal: &Robot<N>,
    text: &str,
    base: &str,
    tip: &str,
    seed: u64,
) -> usize {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("own.urdf"), text).unwrap();
    let mut rng = Lcg(seed);
    let mut model = *nominal;
    let mut file = ModelFile::nominal("own", nominal);
    for i in 0..Robot::<N>::NUM_GEOMETRIC_PARAMS {
        let idx = kincal::ParamIndex(i);
        let v = model.param(idx).unwrap() + rng.within(-2e-3, 2e-3);
        model.set_param(idx, v).unwrap();
    }
    for p in &mut file.robot.parameters {
        let id = ParamId::parse(&p.label, N).unwrap();
        p.value = model.param(id.index(N)).unwrap();
    }
    fs::write(d.join("m.json"), file.to_json()).unwrap();
    let o = kincal(
        &[
            "export",
            "m.json",
            "--urdf",
            "out.urdf",
            "--from",
            "own.urdf",
            "--base-link",
            base,
            "--tip-link",
            tip,
        ],
        d,
    );
    assert_eq!(code(&o), 0, "{}", stderr(&o));
    let out = fs::read_to_string(d.join("out.urdf")).unwrap();
    let model = read_model(&d.join("m.json")).robot.robot::<N>().unwrap();
    assert_chain_matches_model(&out, base, tip, &model, seed);
    assert_eq!(
        without_origins(&out),
        without_origins(text),
        "only origins change"
    );
    // The nominal URDF does not match the perturbed model: the check can fail.
    let joints = read_joints(text);
    let q = [0.2; N];
    let got = urdf_fk(&joints, base, tip, &q);
    let want = model.fk_q(&q).unwrap().to_homogeneous();
    assert!((0..3).any(|i| (got[i][3] - want[(i, 3)]).abs() > 1e-5));
    out.lines()
        .zip(text.lines())
        .filter(|(a, b)| a != b)
        .count()
}

/// The nominal robot of an imported URDF chain as a `Robot<N>` (parameters, length choices
/// and limits copied).
fn import<const N: usize>(text: &str, base: Option<&str>, tip: &str) -> Robot<N> {
    let imp = kincal_io::urdf::import_urdf_str(
        text,
        "own.urdf",
        &kincal_io::urdf::ChainSelection {
            base_link: base,
            tip_link: Some(tip),
        },
    )
    .unwrap();
    let any = imp.robot;
    kincal::with_any_robot!(&any, r => {
        let mut out = Robot::<N>::new(
            [Link { theta0: 0.0, d: 0.0, a: 0.0, alpha: 0.0, beta: 0.0 }; N],
            [JointLimits::new(-3.0, 3.0); N],
        )
        .unwrap();
        assert_eq!(r.links().len(), N);
        let mut p = vec![0.0; Robot::<N>::NUM_PARAMS];
        for (i, v) in p.iter_mut().enumerate() {
            *v = r.param(kincal::ParamIndex(i)).unwrap();
        }
        for (l, lp) in r.length_params().iter().enumerate() {
            out.set_length_param(l, *lp).unwrap();
        }
        out.write_params(&p).unwrap();
        out.set_limits(std::array::from_fn(|i| r.limits()[i])).unwrap();
        out
    })
}

#[test]
fn from_updates_only_the_chain_origins_of_the_users_urdf() {
    let nominal = import::<4>(OWN_URDF, Some("base_link"), "tool0");
    let changed = check_from(&nominal, OWN_URDF, "base_link", "tool0", 5);
    assert_eq!(changed, 5, "j1..j4 and tool_joint lines");
}

#[test]
fn from_works_on_real_urdfs() {
    let Some(dir) = std::env::var_os("KINCAL_REALDATA")
        .map(std::path::PathBuf::from)
        .or_else(|| {
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .ancestors()
                .skip(2)
                .map(|a| a.join("shared/realdata"))
                .find(|p| p.is_dir())
        })
    else {
        eprintln!("shared/realdata not found: real URDFs not checked");
        return;
    };
    let ur = fs::read_to_string(dir.join("figaroh-ur10e/robot_ur10e.urdf")).unwrap();
    let nominal = import::<6>(&ur, Some("base_link"), "tool0");
    check_from(&nominal, &ur, "base_link", "tool0", 8);
    let panda = fs::read_to_string(dir.join("mukca/urdf/panda.urdf")).unwrap();
    let nominal = import::<7>(&panda, None, "ball_link");
    let root = read_joints(&panda)
        .iter()
        .map(|j| j.parent.clone())
        .find(|p| !read_joints(&panda).iter().any(|j| j.child == *p))
        .unwrap();
    check_from(&nominal, &panda, &root, "ball_link", 9);
}

#[test]
fn from_refuses_a_chain_that_is_not_the_models() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("own.urdf"), OWN_URDF).unwrap();
    fs::write(
        d.join("m.json"),
        ModelFile::nominal("aria", &aria::nominal()).to_json(),
    )
    .unwrap();
    let o = kincal(
        &[
            "export",
            "m.json",
            "--urdf",
            "o.urdf",
            "--from",
            "own.urdf",
            "--tip-link",
            "tool0",
        ],
        d,
    );
    assert_eq!(code(&o), 3, "{}", stderr(&o));
    assert!(
        stderr(&o).contains("has 4 revolute/prismatic joints, the model has 6"),
        "{}",
        stderr(&o)
    );
    // Same joint count, other geometry: the axes do not match.
    let nominal4 = import::<4>(OWN_URDF, Some("base_link"), "tool0");
    let mut moved = nominal4;
    moved.set_param(kincal::ParamIndex(2), 0.05).unwrap();
    fs::write(
        d.join("m4.json"),
        ModelFile::nominal("own", &moved).to_json(),
    )
    .unwrap();
    let o = kincal(
        &[
            "export",
            "m4.json",
            "--urdf",
            "o.urdf",
            "--from",
            "own.urdf",
            "--tip-link",
            "tool0",
        ],
        d,
    );
    assert_eq!(code(&o), 3, "{}", stderr(&o));
    assert!(
        stderr(&o).contains("not calibrated from this URDF"),
        "{}",
        stderr(&o)
    );
    assert!(!d.join("o.urdf").exists());
    let o = kincal(
        &[
            "export", "m4.json", "--urdf", "own.urdf", "--from", "own.urdf",
        ],
        d,
    );
    assert_eq!(code(&o), 2, "{}", stderr(&o));
    assert!(
        stderr(&o).contains("names the same file as the input --from"),
        "{}",
        stderr(&o)
    );
}
