//! `kincal import-dataset tiago DIR --urdf TIAGO.urdf`: FIGAROH's TIAGo motion-capture set
//! (../shared/realdata/figaroh-tiago-mocap, `qualysis_base_hand_calibration.csv`, Apache-2.0)
//! with the robot description the user supplies. PAL Robotics' TIAGo URDF is CC BY-NC-ND and
//! not shipped with the set nor with kincal: the user brings it (pal-robotics/tiago_robot,
//! package `tiago_description`, expanded from its xacro; FIGAROH's example ships a copy).
//!
//! What the file holds (one row per static pose, 35 rows): `x1,y1,z1 … x4,y4,z4`, four
//! points on the hand in the motion-capture frame [m]; `torso_lift_joint` (prismatic) [m];
//! `arm_1_joint … arm_7_joint` [rad]. FIGAROH's own TIAGo configuration uses one marker on
//! `arm_7_joint`'s link, position only; so do the rows here:
//! - `x, y, z` = point 1 (the measured point), `extra_x2 … extra_z4` the other three points,
//!   carried through untouched;
//! - `q1..qN` the URDF chain's joints in chain order, each read from the column of the same
//!   name (default chain `base_footprint` → `arm_7_link`: the torso lift and the 7 arm
//!   joints; `--base-link`/`--tip-link` choose another one, which must move exactly the
//!   joints the file records);
//! - the base frame (motion capture → `base_footprint`) and the point's place on the hand
//!   (the tool translation) are unknown: calibrate with `--effects base_frame,tool_frame
//!   --init-frames`.

use std::path::Path;

use crate::datasets::{Imported, Parts, read_table, row};
use crate::error::Error as CliError;
use crate::robot_arg::UrdfChainArgs;
use crate::robot_file::RobotDescription;
use crate::urdf::{ChainSelection, import_urdf_file};

/// The names `import-dataset` accepts for this set (alias first).
pub const NAMES: [&str; 2] = ["tiago", "figaroh-tiago-mocap"];

/// The set's measurement file (its published name).
pub const CSV_FILE: &str = "qualysis_base_hand_calibration.csv";

/// The joint columns of the file, in the robot's chain order.
pub const JOINTS: [&str; 8] = [
    "torso_lift_joint",
    "arm_1_joint",
    "arm_2_joint",
    "arm_3_joint",
    "arm_4_joint",
    "arm_5_joint",
    "arm_6_joint",
    "arm_7_joint",
];

/// Default chain: the mobile base's footprint to the last arm link (the marker's link in
/// FIGAROH's configuration).
pub const DEFAULT_BASE_LINK: &str = "base_footprint";
/// See [`DEFAULT_BASE_LINK`].
pub const DEFAULT_TIP_LINK: &str = "arm_7_link";

/// Why the set cannot be imported without `--urdf` (a usage error: the user must add it).
pub const NEEDS_URDF: &str = "the TIAGo set needs the robot's URDF: pass --urdf TIAGO.urdf. \
    PAL Robotics' TIAGo URDF is licensed CC BY-NC-ND and is not shipped with the data set nor \
    with kincal; get it from PAL Robotics' tiago_description package \
    (github.com/pal-robotics/tiago_robot, expand the xacro with `xacro tiago.urdf.xacro > \
    tiago.urdf`) or FIGAROH's TIAGo example (examples/tiago/urdf)";

/// One row of the file: its line, the four points [m] and the joint readings in
/// [`JOINTS`] order (metres for the torso lift, radians for the arm).
#[derive(Debug, Clone, PartialEq)]
pub struct TiagoRow {
    pub line: u64,
    pub points_m: [[f64; 3]; 4],
    pub q: [f64; 8],
}

/// Reads the set's CSV in its published layout (columns found by name; every cell a finite
/// number; errors name the file, line and column). Needs no URDF.
pub fn read_rows(path: &Path) -> Result<Vec<TiagoRow>, CliError> {
    let t = read_table(path)?;
    let pc: Vec<[usize; 3]> = (1..=4)
        .map(|k| {
            Ok([
                t.col(&format!("x{k}"))?,
                t.col(&format!("y{k}"))?,
                t.col(&format!("z{k}"))?,
            ])
        })
        .collect::<Result<_, CliError>>()?;
    let jc: Vec<usize> = JOINTS.iter().map(|j| t.col(j)).collect::<Result<_, _>>()?;
    let known: Vec<String> = (1..=4)
        .flat_map(|k| ["x", "y", "z"].map(|c| format!("{c}{k}")))
        .chain(JOINTS.iter().map(|j| (*j).to_string()))
        .collect();
    if let Some(h) = t.header.iter().find(|h| !known.contains(h)) {
        return Err(CliError::input(format!(
            "{}:1: unexpected column '{h}': the set's layout is x1..z4 and {}",
            t.path,
            JOINTS.join(", ")
        )));
    }
    (0..t.rows.len())
        .map(|r| {
            let mut points_m = [[0.0; 3]; 4];
            for (p, cols) in points_m.iter_mut().zip(&pc) {
                for (v, &c) in p.iter_mut().zip(cols) {
                    *v = t.num(r, c)?;
                }
            }
            let mut q = [0.0; 8];
            for (v, &c) in q.iter_mut().zip(&jc) {
                *v = t.num(r, c)?;
            }
            Ok(TiagoRow {
                line: t.rows[r].0,
                points_m,
                q,
            })
        })
        .collect()
}

/// The chain the flags select, defaults filled in.
fn selection(chain: &UrdfChainArgs) -> ChainSelection<'_> {
    ChainSelection {
        base_link: chain.base_link.as_deref().or(Some(DEFAULT_BASE_LINK)),
        tip_link: chain.tip_link.as_deref().or(Some(DEFAULT_TIP_LINK)),
    }
}

/// For each model joint, its index in [`JOINTS`]; the chain must move exactly the joints
/// the file records (a left-out reading would be lost and its joint frozen at 0).
fn joint_columns(joint_names: &[String], urdf: &Path) -> Result<Vec<usize>, CliError> {
    let mut idx = Vec::with_capacity(joint_names.len());
    for n in joint_names {
        let k = JOINTS.iter().position(|j| j == n).ok_or_else(|| {
            CliError::input(format!(
                "{}: the chosen chain moves joint '{n}', which the TIAGo set does not record \
                 (it records {}); choose --base-link/--tip-link around those joints",
                urdf.display(),
                JOINTS.join(", ")
            ))
        })?;
        idx.push(k);
    }
    if let Some(missing) = JOINTS
        .iter()
        .enumerate()
        .find(|(k, _)| !idx.contains(k))
        .map(|(_, j)| j)
    {
        return Err(CliError::input(format!(
            "{}: the chosen chain ({}) leaves out '{missing}', whose reading the set records: \
             choose a base link above it and a tip link below it",
            urdf.display(),
            joint_names.join(", ")
        )));
    }
    Ok(idx)
}

/// Largest minus smallest of `v`.
fn spread(v: impl Iterator<Item = f64>) -> f64 {
    let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    });
    hi - lo
}

fn distance(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Imports the set in `dir` with the user's URDF (`None`: the usage error [`NEEDS_URDF`]).
pub fn import(
    dir: &Path,
    urdf: Option<&Path>,
    chain: &UrdfChainArgs,
) -> Result<Imported, CliError> {
    let urdf = urdf.ok_or_else(|| CliError::usage(NEEDS_URDF))?;
    if !dir.is_dir() {
        return Err(CliError::input(format!(
            "{}: not a folder: expected the data set's folder (e.g. ../shared/realdata/figaroh-tiago-mocap)",
            dir.display()
        )));
    }
    let csv_path = dir.join(CSV_FILE);
    let rows = read_rows(&csv_path)?;
    let sel = selection(chain);
    let imported = import_urdf_file(urdf, &sel).map_err(|e| CliError::input(e.to_string()))?;
    let cols = joint_columns(&imported.joint_names, urdf)?;
    let out_rows = rows
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let mut m = row(
                format!("{}", i + 1),
                cols.iter().map(|&k| r.q[k]).collect(),
                r.points_m[0],
                None,
            );
            m.extras = r.points_m[1..]
                .iter()
                .flatten()
                .map(|v| format!("{v:?}"))
                .collect();
            m
        })
        .collect();
    let same_34 = rows
        .iter()
        .filter(|r| r.points_m[2] == r.points_m[3])
        .count();
    let d12 = spread(
        rows.iter()
            .map(|r| distance(&r.points_m[0], &r.points_m[1])),
    );
    let d23 = spread(
        rows.iter()
            .map(|r| distance(&r.points_m[1], &r.points_m[2])),
    );
    let lift = spread(rows.iter().map(|r| r.q[0]));
    let chain_label = format!("{} -> {}", imported.base_link, imported.tip_link);
    let mut notes = vec![
        format!(
            "position-only rows: x, y, z = point 1 (x1, y1, z1) in the motion-capture frame, \
             as FIGAROH's TIAGo configuration uses it; points 2-4 kept as extra_x2..extra_z4. \
             The base frame (motion capture -> {}) and the point's place on {} (tool \
             translation) are unknown: calibrate with --effects base_frame,tool_frame \
             --init-frames",
            imported.base_link, imported.tip_link
        ),
        format!(
            "rigid-body check: |p1-p2| varies by {d12:.1e} m and |p2-p3| by {d23:.1e} m over \
             {} rows; points 3 and 4 are identical in {same_34} rows (one tracked rigid body \
             rather than independent markers: the rows are not independent marker noise)",
            rows.len()
        ),
        format!(
            "robot: {} (the user's URDF), chain {chain_label}; torso_lift_joint is prismatic \
             (moves {lift:.3} m here)",
            urdf.display()
        ),
    ];
    notes.extend(imported.notes.iter().map(|n| format!("URDF: {n}")));
    let robot_name = imported.robot_name.clone();
    let n_joints = imported.joint_names.len();
    let label = format!("{robot_name} (the user's URDF, {chain_label})");
    Parts {
        name: "figaroh-tiago-mocap",
        files: &[&csv_path, urdf],
        robot_label: &label,
        n_joints,
        rows: out_rows,
        form: None,
        extra_columns: (2..=4)
            .flat_map(|k| ["x", "y", "z"].map(|c| format!("extra_{c}{k}")))
            .collect(),
        robot: RobotDescription {
            name: robot_name,
            joint_names: imported.joint_names,
            robot: imported.robot,
        },
        robot_comments: vec![
            format!(
                " TIAGo: the user's URDF (PAL Robotics, CC BY-NC-ND: not shipped), chain {chain_label},"
            ),
            " converted by kincal import-dataset tiago. Do not redistribute it with the data.".into(),
        ],
        notes,
    }
    .finish()
}

#[cfg(test)]
#[path = "datasets_tiago_tests.rs"]
mod tests;
