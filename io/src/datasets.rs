//! Adapters for the public real-robot calibration data sets (`kincal import-dataset`): each
//! reads one set as it is published (its own file layout, units and conventions) and gives
//! the measurement CSV rows and the robot's nominal description. Nothing is copied from the
//! sets into the repository; the robot descriptions that are not part of a set are built
//! here from published numbers, each cited where it is used.
//!
//! What every set measures, and how the rows map (spec/measurements.md):
//! - `figaroh-ur10e`: camera on the wrist observing a fixed board; `x1..phiz1` are a full
//!   pose (`R = Rz(phiz)·Ry(phiy)·Rx(phix)`, the CSV's own convention), joints in rad.
//!   Robot: the set's URDF, chain `base_link` → `wrist_3_link`.
//! - `robotkinecal-fr3`: camera on the hand observing a fixed board; `camera_poses.csv` is
//!   the camera pose in the board frame (row-major 3×4), joints in rad. Robot: Franka's
//!   published kinematics (see [`fr3_description`]) with the camera mount of the set's
//!   README as the tool. `tcp_poses.csv` (the robot's own forward kinematics) is only used
//!   to check the description's FK.
//! - `figaroh-talos-arm`: one motion-capture marker on the left gripper, position only,
//!   9 joints (torso 2 + arm 7), all modelled.
//! - `ical-2axis-positioner`: a static sensor measuring the 6-D pose of a target on a
//!   two-axis positioner (`measurements.yaml`, position and unit quaternion). Robot: the
//!   two classical DH rows stated in the set's README.
//!
//! - `figaroh-tiago-mocap` (alias `tiago`): with the user's URDF, see [`crate::datasets_tiago`].
//!
//! Sets that cannot be used as they are say why ([`UNUSABLE`]); sets that need something
//! the user adds say what ([`NEEDS`]).

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use kincal::any::AnyRobot;
use kincal::axis_chain::{AxisChain, JointAxis};
use kincal::pose::{Transform, matrix_to_quaternion, pose_from_xyz_rpy};
use kincal::with_any_robot;
use nalgebra::{Matrix3, Vector3};

use crate::error::Error as CliError;
use crate::measurements::{MeasurementRow, MeasurementSet, Orientation, OrientationForm};
use crate::robot_file::RobotDescription;
use crate::urdf::{ChainSelection, import_urdf_file, import_urdf_str};

/// The sets an adapter exists for: folder name and one line about it.
pub const USABLE: &[(&str, &str)] = &[
    (
        "figaroh-ur10e",
        "UR10e, eye-in-hand camera and fixed board, full 6-D poses (23)",
    ),
    (
        "robotkinecal-fr3",
        "Franka Research 3, eye-in-hand camera and fixed board, full 6-D poses (114)",
    ),
    (
        "figaroh-talos-arm",
        "TALOS torso + left arm, one motion-capture marker, positions only (61)",
    ),
    (
        "ical-2axis-positioner",
        "two-axis positioner seen by a static sensor, full 6-D poses (205)",
    ),
    (
        "mukca",
        "Panda x7, iiwa14, Gen3 lite: ball-in-socket targets 50 mm apart, no instrument \
         (--robot-id ID; sessions, targets and a constraints file)",
    ),
    (
        "hilti-jaibot-stationing",
        "Hilti lifting column + 6R arm, total-station prism, accelerometer tilts as sensor \
         joints, 7 floors as sessions (3090 positions; CC BY-NC-SA: non-commercial; alias hilti)",
    ),
    (
        "figaroh-mate-planes",
        "3-joint arm touching 3 known planes: one coordinate per row (30), plus 10 full poses",
    ),
];

/// The sets in the shared folder that are not used, and why (none at present: TIAGo needs
/// the user's URDF, see [`NEEDS`]).
pub const UNUSABLE: &[(&str, &str)] = &[];

/// The sets that are usable only with something the user adds, and what.
pub const NEEDS: &[(&str, &str)] = &[(
    "figaroh-tiago-mocap",
    "TIAGo torso lift (prismatic) + 7R arm, one motion-capture point, positions only (35); \
     needs --urdf TIAGO.urdf: PAL's TIAGo URDF is CC BY-NC-ND and not shipped \
     (pal-robotics/tiago_robot, tiago_description); alias tiago",
)];

/// One imported set.
#[derive(Debug, Clone)]
pub struct Imported {
    /// The measurement rows, ready to write (comments included).
    pub set: MeasurementSet,
    /// The nominal robot for these rows.
    pub robot: RobotDescription,
    /// Comment lines for the robot description file.
    pub robot_comments: Vec<String>,
    /// What was assumed or checked (also in the CSV comments).
    pub notes: Vec<String>,
}

/// Imports set `name` from its folder `dir`.
pub fn import(name: &str, dir: &Path) -> Result<Imported, CliError> {
    if let Some((_, why)) = UNUSABLE.iter().find(|(n, _)| *n == name) {
        return Err(CliError::input(format!(
            "data set '{name}' is not usable as it is: {why}"
        )));
    }
    if !dir.is_dir() {
        return Err(CliError::input(format!(
            "{}: not a folder: expected the data set's folder (e.g. ../shared/realdata/{name})",
            dir.display()
        )));
    }
    match name {
        "hilti" | "hilti-jaibot-stationing" => crate::datasets_hilti::import(dir),
        "tiago" | "figaroh-tiago-mocap" => Err(CliError::usage(crate::datasets_tiago::NEEDS_URDF)),
        "figaroh-ur10e" => ur10e(dir),
        "robotkinecal-fr3" => fr3(dir),
        "figaroh-talos-arm" => talos(dir),
        "ical-2axis-positioner" => positioner(dir),
        _ => {
            let known: Vec<&str> = USABLE
                .iter()
                .chain(NEEDS)
                .chain(UNUSABLE)
                .map(|(n, _)| *n)
                .collect();
            Err(CliError::usage(format!(
                "unknown data set '{name}': expected one of {}",
                known.join(", ")
            )))
        }
    }
}

// ---------------------------------------------------------------------------------------
// Raw files

/// A CSV file of the set: header and records with their line numbers.
pub(crate) struct Table {
    pub(crate) path: String,
    pub(crate) header: Vec<String>,
    pub(crate) rows: Vec<(u64, Vec<String>)>,
}

pub(crate) fn read_table(path: &Path) -> Result<Table, CliError> {
    let name = path.display().to_string();
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_path(path)
        .map_err(|e| CliError::input(format!("{name}: cannot read: {e}")))?;
    let header = rdr
        .headers()
        .map_err(|e| CliError::input(format!("{name}:1: {e}")))?
        .iter()
        .map(|s| s.trim().to_string())
        .collect();
    let mut rows = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| CliError::input(format!("{name}: {e}")))?;
        let line = rec.position().map_or(0, |p| p.line());
        rows.push((line, rec.iter().map(str::to_string).collect()));
    }
    if rows.is_empty() {
        return Err(CliError::input(format!("{name}: no data rows")));
    }
    Ok(Table {
        path: name,
        header,
        rows,
    })
}

impl Table {
    pub(crate) fn col(&self, name: &str) -> Result<usize, CliError> {
        self.header.iter().position(|h| h == name).ok_or_else(|| {
            CliError::input(format!(
                "{}:1: missing column '{name}' (the set's published layout has it)",
                self.path
            ))
        })
    }
    pub(crate) fn num(&self, row: usize, col: usize) -> Result<f64, CliError> {
        let (line, cells) = &self.rows[row];
        let cell = cells.get(col).map_or("", String::as_str);
        match cell.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(CliError::input(format!(
                "{}:{line}: column '{}': expected a finite number, found {cell:?}",
                self.path, self.header[col]
            ))),
        }
    }
    fn text(&self, row: usize, col: usize) -> String {
        self.rows[row].1.get(col).cloned().unwrap_or_default()
    }
}

pub(crate) fn sha256_of(path: &Path) -> Result<String, CliError> {
    crate::files::sha256_file(path)
        .map_err(|e| CliError::input(format!("{}: cannot read: {e}", path.display())))
}

pub(crate) fn row(
    id: String,
    q: Vec<f64>,
    p: [f64; 3],
    orientation: Option<Orientation>,
) -> MeasurementRow {
    MeasurementRow {
        line: 0,
        pose_id: Some(id),
        q_rad: q,
        position_m: Some(p),
        orientation,
        point_m: None,
        approach: None,
        temp_c: None,
        extras: Vec::new(),
        partial_m: None,
        target: None,
        plane: None,
        session: None,
    }
}

/// The orientation of `r` as a unit quaternion (core's Shepperd conversion, unit to rounding).
fn quaternion(r: &Matrix3<f64>) -> Orientation {
    let [w, x, y, z] = matrix_to_quaternion(r);
    Orientation::Quaternion { w, x, y, z }
}

/// What an adapter read, before the common tail of every import: provenance (files with
/// their SHA-256, robot) and notes as CSV comments, the measurement set, the robot.
pub(crate) struct Parts<'a> {
    /// The set's name (its folder name).
    pub(crate) name: &'a str,
    /// The files read; the first is the measurement set's source.
    pub(crate) files: &'a [&'a Path],
    /// The robot, as named in the CSV comments.
    pub(crate) robot_label: &'a str,
    pub(crate) n_joints: usize,
    pub(crate) rows: Vec<MeasurementRow>,
    pub(crate) form: Option<OrientationForm>,
    pub(crate) extra_columns: Vec<String>,
    pub(crate) robot: RobotDescription,
    pub(crate) robot_comments: Vec<String>,
    pub(crate) notes: Vec<String>,
}

impl Parts<'_> {
    pub(crate) fn finish(self) -> Result<Imported, CliError> {
        let files = self
            .files
            .iter()
            .map(|&f| Ok((f, sha256_of(f)?)))
            .collect::<Result<Vec<_>, CliError>>()?;
        let mut comments = provenance(self.name, &files, self.robot_label);
        comments.extend(self.notes.iter().map(|n| format!(" note: {n}")));
        Ok(Imported {
            set: MeasurementSet {
                source: self.files[0].display().to_string(),
                comments,
                n_joints: self.n_joints,
                rows: self.rows,
                extra_columns: self.extra_columns,
                orientation_form: self.form,
                has_position: true,
                has_point: false,
                has_target: false,
                has_plane: false,
                has_session: false,
                has_approach: false,
                has_temperature: false,
                sha256: String::new(),
                header_line: 0,
            },
            robot: self.robot,
            robot_comments: self.robot_comments,
            notes: self.notes,
        })
    }
}

/// The first comment lines of every imported CSV.
fn provenance(name: &str, files: &[(&Path, String)], robot: &str) -> Vec<String> {
    let mut c = vec![format!(
        " dataset: {name} (imported by kincal import-dataset)"
    )];
    for (p, sha) in files {
        let file = p.file_name().map_or_else(
            || p.display().to_string(),
            |f| f.to_string_lossy().into_owned(),
        );
        c.push(format!(" source: {file} (sha256 {sha})"));
    }
    c.push(format!(" robot: {robot}"));
    c
}

// ---------------------------------------------------------------------------------------
// Robots from joint tables (written as URDF text and imported like any URDF)

/// One joint of a chain table: origin relative to the parent link (URDF convention:
/// `Trans(xyz)·Rz(y)·Ry(p)·Rx(r)`), axis, limits, and the mass of the child link.
struct J {
    name: &'static str,
    revolute: bool,
    xyz: [f64; 3],
    rpy: [f64; 3],
    axis: [f64; 3],
    limits: (f64, f64),
    child_mass_kg: f64,
}

fn joint(
    name: &'static str,
    xyz: [f64; 3],
    rpy: [f64; 3],
    axis: [f64; 3],
    limits: (f64, f64),
    child_mass_kg: f64,
) -> J {
    J {
        name,
        revolute: true,
        xyz,
        rpy,
        axis,
        limits,
        child_mass_kg,
    }
}

fn fixed(name: &'static str, xyz: [f64; 3], rpy: [f64; 3], child_mass_kg: f64) -> J {
    J {
        name,
        revolute: false,
        xyz,
        rpy,
        axis: [0.0, 0.0, 1.0],
        limits: (0.0, 0.0),
        child_mass_kg,
    }
}

fn v3(v: [f64; 3]) -> String {
    format!("{:?} {:?} {:?}", v[0], v[1], v[2])
}

/// The chain as URDF text (links `base`, then one per joint named after it).
fn chain_urdf(robot: &str, joints: &[J]) -> String {
    let mut s =
        format!("<?xml version=\"1.0\"?>\n<robot name=\"{robot}\">\n  <link name=\"base\"/>\n");
    let mut parent = "base".to_string();
    for j in joints {
        let child = format!("{}_link", j.name);
        let _ = writeln!(
            s,
            "  <link name=\"{child}\"><inertial><origin xyz=\"0 0 0\" rpy=\"0 0 0\"/><mass value=\"{:?}\"/>\
             <inertia ixx=\"0\" ixy=\"0\" ixz=\"0\" iyy=\"0\" iyz=\"0\" izz=\"0\"/></inertial></link>",
            j.child_mass_kg
        );
        let kind = if j.revolute { "revolute" } else { "fixed" };
        let _ = writeln!(
            s,
            "  <joint name=\"{}\" type=\"{kind}\"><parent link=\"{parent}\"/><child link=\"{child}\"/>\
             <origin xyz=\"{}\" rpy=\"{}\"/><axis xyz=\"{}\"/>\
             <limit lower=\"{:?}\" upper=\"{:?}\" effort=\"0\" velocity=\"0\"/></joint>",
            j.name,
            v3(j.xyz),
            v3(j.rpy),
            v3(j.axis),
            j.limits.0,
            j.limits.1
        );
        parent = child;
    }
    s.push_str("</robot>\n");
    s
}

fn chain_robot(robot: &str, joints: &[J]) -> Result<RobotDescription, CliError> {
    let text = chain_urdf(robot, joints);
    let imported = import_urdf_str(&text, robot, &ChainSelection::default())
        .map_err(|e| CliError::input(format!("built-in description of {robot}: {e}")))?;
    Ok(RobotDescription {
        name: robot.to_string(),
        joint_names: imported.joint_names,
        robot: imported.robot,
    })
}

/// Franka Research 3: the kinematics Franka publishes for the FR3 (and the Panda), Craig's
/// modified DH `a_{i-1}, d_i, α_{i-1}`: (0, 0.333, 0), (0, 0, −π/2), (0, 0.316, π/2),
/// (0.0825, 0, π/2), (−0.0825, 0.384, −π/2), (0, 0, π/2), (0.088, 0, π/2), flange
/// `d = 0.107` (Franka documentation, "Robot and interface specifications", Denavit–Hartenberg
/// parameters); FR3 joint limits from the same documentation ("Limits for Franka Research
/// 3"): lower (−2.7437, −1.7837, −2.9007, −3.0421, −2.8065, 0.5445, −3.0159), upper
/// (2.7437, 1.7837, 2.9007, −0.1518, 2.8065, 4.5169, 3.0159) rad. No mass model (masses 0:
/// the joint_compliance effect cannot be evaluated without one). The tool frame is the
/// flange (`link8`).
pub fn fr3_description() -> Result<RobotDescription, CliError> {
    use std::f64::consts::FRAC_PI_2 as H;
    let lo = [-2.7437, -1.7837, -2.9007, -3.0421, -2.8065, 0.5445, -3.0159];
    let hi = [2.7437, 1.7837, 2.9007, -0.1518, 2.8065, 4.5169, 3.0159];
    // Craig's A_i = Rx(α_{i-1})·Tx(a_{i-1})·Rz(θ_i)·Tz(d_i) as a URDF joint origin
    // Trans(a, −d·sin α, d·cos α)·Rx(α) with the axis z.
    let dh = [
        (0.0, 0.333, 0.0),
        (0.0, 0.0, -H),
        (0.0, 0.316, H),
        (0.0825, 0.0, H),
        (-0.0825, 0.384, -H),
        (0.0, 0.0, H),
        (0.088, 0.0, H),
    ];
    const NAMES: [&str; 7] = [
        "fr3_joint1",
        "fr3_joint2",
        "fr3_joint3",
        "fr3_joint4",
        "fr3_joint5",
        "fr3_joint6",
        "fr3_joint7",
    ];
    let mut joints: Vec<J> = dh
        .iter()
        .enumerate()
        .map(|(i, &(a, d, al)): (usize, &(f64, f64, f64))| {
            joint(
                NAMES[i],
                [a, -d * al.sin(), d * al.cos()],
                [al, 0.0, 0.0],
                [0.0, 0.0, 1.0],
                (lo[i], hi[i]),
                0.0,
            )
        })
        .collect();
    joints.push(fixed("fr3_flange", [0.0, 0.0, 0.107], [0.0; 3], 0.0));
    chain_robot("fr3", &joints)
}

// ---------------------------------------------------------------------------------------
// The sets

fn ur10e(dir: &Path) -> Result<Imported, CliError> {
    let csv_path = dir.join("calibration.csv");
    let urdf_path = dir.join("robot_ur10e.urdf");
    let t = read_table(&csv_path)?;
    let joints = [
        "shoulder_pan_joint",
        "shoulder_lift_joint",
        "elbow_joint",
        "wrist_1_joint",
        "wrist_2_joint",
        "wrist_3_joint",
    ];
    let jc: Vec<usize> = joints.iter().map(|j| t.col(j)).collect::<Result<_, _>>()?;
    let pc: Vec<usize> = ["x1", "y1", "z1", "phix1", "phiy1", "phiz1"]
        .iter()
        .map(|c| t.col(c))
        .collect::<Result<_, _>>()?;
    let mut rows = Vec::new();
    for r in 0..t.rows.len() {
        let q = jc.iter().map(|&c| t.num(r, c)).collect::<Result<_, _>>()?;
        let v: Vec<f64> = pc.iter().map(|&c| t.num(r, c)).collect::<Result<_, _>>()?;
        rows.push(row(
            format!("{}", r + 1),
            q,
            [v[0], v[1], v[2]],
            Some(Orientation::Rpy {
                roll_rad: v[3],
                pitch_rad: v[4],
                yaw_rad: v[5],
            }),
        ));
    }
    let imported = import_urdf_file(
        &urdf_path,
        &ChainSelection {
            base_link: Some("base_link"),
            tip_link: Some("wrist_3_link"),
        },
    )
    .map_err(|e| CliError::input(e.to_string()))?;
    if imported.joint_names != joints {
        return Err(CliError::input(format!(
            "{}: chain base_link -> wrist_3_link has joints {:?}, expected {joints:?}",
            urdf_path.display(),
            imported.joint_names
        )));
    }
    let notes = vec![
        "pose = the set's x1..phiz1 (R = Rz(phiz1)·Ry(phiy1)·Rx(phix1)), of a camera on wrist_3 \
         relative to a fixed board: base and tool frames unknown"
            .to_string(),
        "robot: the set's robot_ur10e.urdf, chain base_link -> wrist_3_link".to_string(),
    ];
    Parts {
        name: "figaroh-ur10e",
        files: &[&csv_path, &urdf_path],
        robot_label: "ur10e (robot_ur10e.urdf, base_link -> wrist_3_link)",
        n_joints: 6,
        rows,
        form: Some(OrientationForm::Rpy),
        extra_columns: Vec::new(),
        robot: RobotDescription {
            name: "ur10e".into(),
            joint_names: imported.joint_names,
            robot: imported.robot,
        },
        robot_comments: vec![
            " UR10e: robot_ur10e.urdf of the figaroh-ur10e set (FIGAROH, Apache-2.0), chain \
             base_link -> wrist_3_link, converted by kincal import-dataset"
                .into(),
        ],
        notes,
    }
    .finish()
}

/// Reads a row-major 3×4 transform table (`r11..r33, tx..tz`) of the FR3 set.
fn fr3_transforms(t: &Table) -> Result<(Vec<Transform>, f64), CliError> {
    let names = [
        "r11", "r12", "r13", "tx", "r21", "r22", "r23", "ty", "r31", "r32", "r33", "tz",
    ];
    let cols: Vec<usize> = names.iter().map(|n| t.col(n)).collect::<Result<_, _>>()?;
    let mut out = Vec::new();
    let mut worst: f64 = 0.0;
    for r in 0..t.rows.len() {
        let v: Vec<f64> = cols
            .iter()
            .map(|&c| t.num(r, c))
            .collect::<Result<_, _>>()?;
        let m = Matrix3::new(v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10]);
        let dev = (m.transpose() * m - Matrix3::identity()).abs().max();
        worst = worst.max(dev);
        if dev > 1e-3 || m.determinant() <= 0.0 {
            let (line, _) = &t.rows[r];
            return Err(CliError::input(format!(
                "{}:{line}: r11..r33 is not a rotation (|RᵀR − I| = {dev:e}, det {})",
                t.path,
                m.determinant()
            )));
        }
        // The nearest rotation (the file's matrices are orthonormal to ~1e-15).
        let rot =
            nalgebra::Rotation3::from_matrix_eps(&m, 1e-15, 100, nalgebra::Rotation3::identity());
        out.push(kincal::pose::transform(
            *rot.matrix(),
            Vector3::new(v[3], v[7], v[11]),
        ));
    }
    Ok((out, worst))
}

fn fr3(dir: &Path) -> Result<Imported, CliError> {
    let jp = dir.join("joint_positions.csv");
    let cp = dir.join("camera_poses.csv");
    let tp = dir.join("tcp_poses.csv");
    let (tj, tc, tt) = (read_table(&jp)?, read_table(&cp)?, read_table(&tp)?);
    for t in [&tc, &tt] {
        if t.rows.len() != tj.rows.len() {
            return Err(CliError::input(format!(
                "{}: {} rows, but {} has {}: expected one row per sample",
                t.path,
                t.rows.len(),
                tj.path,
                tj.rows.len()
            )));
        }
    }
    let (sj, sc, st) = (tj.col("sample")?, tc.col("sample")?, tt.col("sample")?);
    let qc: Vec<usize> = (1..=7)
        .map(|k| tj.col(&format!("q{k}")))
        .collect::<Result<_, _>>()?;
    let (cams, cam_dev) = fr3_transforms(&tc)?;
    let (tcps, _) = fr3_transforms(&tt)?;
    let desc = fr3_description()?;
    let AnyRobot::J7(flange_robot) = desc.robot else {
        return Err(CliError::input("fr3 description: expected 7 joints"));
    };
    let mut rows = Vec::new();
    let mut tcp_dev = (0.0_f64, 0.0_f64);
    let mut first_tcp: Option<Transform> = None;
    for r in 0..tj.rows.len() {
        let id = tj.text(r, sj);
        if tc.text(r, sc) != id || tt.text(r, st) != id {
            let (line, _) = &tc.rows[r];
            return Err(CliError::input(format!(
                "{}:{line}: sample {:?} does not match joint_positions.csv's {id:?}",
                tc.path,
                tc.text(r, sc)
            )));
        }
        let q: Vec<f64> = qc.iter().map(|&c| tj.num(r, c)).collect::<Result<_, _>>()?;
        // FK agreement with the robot's own TCP poses: TCP = flange·C for one constant C.
        let qa: [f64; 7] = q
            .clone()
            .try_into()
            .map_err(|_| CliError::input("7 joints"))?;
        let f = flange_robot
            .fk_q(&qa)
            .map_err(|e| CliError::input(format!("fr3 FK: {e}")))?;
        let c = f.inverse() * tcps[r];
        match first_tcp {
            None => first_tcp = Some(c),
            Some(c0) => {
                let e = kincal::validation::PoseErrors::between(&c, &c0);
                tcp_dev.0 = tcp_dev.0.max(e.pos_norm_m);
                tcp_dev.1 = tcp_dev.1.max(e.rot_norm_rad);
            }
        }
        let m = cams[r];
        let p = m.translation.vector;
        rows.push(row(
            id,
            q,
            [p.x, p.y, p.z],
            Some(quaternion(m.rotation.matrix())),
        ));
    }
    // The camera mount of the set's README (x 94.5 mm, y −9 mm, z 40.55 mm, 90° about z,
    // relative to link8) as the nominal tool; the calibration refines it.
    let mount = pose_from_xyz_rpy(
        [0.0945, -0.009, 0.04055],
        [0.0, 0.0, std::f64::consts::FRAC_PI_2],
    );
    let tool = *flange_robot.t_n_tool() * mount;
    let robot = flange_robot
        .with_tool(kincal::pose::pose_to_vector6(&tool))
        .map_err(|e| CliError::input(format!("fr3 tool: {e}")))?;
    let notes = vec![
        "pose = camera_poses.csv: the camera in the board frame (orthonormal to \
         max |RᵀR − I| = "
            .to_string()
            + &format!("{cam_dev:.1e}); base (board) frame unknown"),
        "tool = the README's camera mount (x 94.5 mm, y -9 mm, z 40.55 mm, 90° about z from link8), refined by the calibration".to_string(),
        format!(
            "FK check: the robot's own TCP poses (tcp_poses.csv) equal this description's flange pose times one constant transform to {:.3} mm / {:.4}° (max over {} samples)",
            tcp_dev.0 * 1e3,
            tcp_dev.1.to_degrees(),
            tj.rows.len()
        ),
    ];
    Parts {
        name: "robotkinecal-fr3",
        files: &[&jp, &cp, &tp],
        robot_label: "fr3 (Franka's published kinematics, camera mount of the set's README as the tool)",
        n_joints: 7,
        rows,
        form: Some(OrientationForm::Quaternion),
        extra_columns: Vec::new(),
        robot: RobotDescription {
            name: "fr3-camera".into(),
            joint_names: desc.joint_names,
            robot: AnyRobot::J7(robot),
        },
        robot_comments: vec![
            " Franka Research 3 with the robotkinecal-fr3 camera mount as the tool frame.".into(),
            " Kinematics: Franka's published modified DH parameters and FR3 joint limits".into(),
            " (Franka documentation); no mass model. See docs/robots/fr3.toml.".into(),
        ],
        notes,
    }
    .finish()
}

/// TALOS torso + left arm from base_link to gripper_left_base_link, from the joint origins
/// of PAL Robotics' `talos_full_v2.urdf` (as shipped in FIGAROH's TALOS example; the file
/// itself is CC BY-NC-ND and not copied, only these kinematic numbers are used), all 9
/// joints. Masses: the URDF's link masses (the gripper's subtree as the tool mass). Also
/// returns the same chain as joint axes, to check the description's FK against.
// The limits are the URDF's own literals (e.g. -1.57079632679), kept as published.
#[allow(clippy::approx_constant)]
fn talos_description() -> Result<(RobotDescription, AxisChain<9>), CliError> {
    // (name, origin xyz, axis, limits, child link mass [kg])
    type Row = (&'static str, [f64; 3], [f64; 3], (f64, f64), f64);
    let table: [Row; 9] = [
        (
            "torso_1_joint",
            [0.0, 0.0, 0.0722],
            [0.0, 0.0, 1.0],
            (-1.25663706144, 1.25663706144),
            2.294658,
        ),
        (
            "torso_2_joint",
            [0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            (-0.226892802759, 0.733038285838),
            16.97403,
        ),
        (
            "arm_left_1_joint",
            [0.0, 0.1575, 0.232],
            [0.0, 0.0, 1.0],
            (-1.57079632679, 0.785398163397),
            2.714567,
        ),
        (
            "arm_left_2_joint",
            [0.00493, 0.1365, 0.04673],
            [1.0, 0.0, 0.0],
            (0.00872664625997, 2.87106661953),
            2.425086,
        ),
        (
            "arm_left_3_joint",
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            (-2.42600766027, 2.42600766027),
            2.208741,
        ),
        (
            "arm_left_4_joint",
            [0.02, 0.0, -0.273],
            [0.0, 1.0, 0.0],
            (-2.23402144255, -0.00349065850399),
            0.877346,
        ),
        (
            "arm_left_5_joint",
            [-0.02, 0.0, -0.2643],
            [0.0, 0.0, 1.0],
            (-2.51327412287, 2.51327412287),
            1.877923,
        ),
        (
            "arm_left_6_joint",
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            (-1.37008346282, 1.37008346282),
            0.40931,
        ),
        (
            "arm_left_7_joint",
            [0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            (-0.680678408278, 0.680678408278),
            0.308441,
        ),
    ];
    // arm_left_7_link -> wrist_left_ft_link (z −0.051, yaw −3π/2) -> wrist_left_ft_tool_link
    // (z −0.012725, yaw +3π/2) -> gripper_left_base_link (z −0.02875): a pure translation.
    let tool_z = -0.051 - 0.012725 - 0.02875;
    // Gripper subtree (base, motors, inner links, three fingertips) and the F/T sensor.
    let tool_kg =
        0.637534 + 0.134356 + 0.087986 + 3.0 * 0.026301 + 0.107923 + 0.047177 + 0.095 + 0.001;
    let mut joints = Vec::new();
    for &(name, xyz, axis, lim, mass) in &table {
        joints.push(joint(name, xyz, [0.0; 3], axis, lim, mass));
    }
    joints.push(fixed(
        "gripper_left_base_link_joint",
        [0.0, 0.0, tool_z],
        [0.0; 3],
        tool_kg,
    ));
    let desc = chain_robot("talos-left-arm", &joints)?;
    // The same chain as joint axes (all origins have zero rotation).
    let mut p = Vector3::zeros();
    let mut axes = [JointAxis::new([0.0; 3], [0.0, 0.0, 1.0]); 9];
    for (k, &(_, xyz, axis, _, _)) in table.iter().enumerate() {
        p += Vector3::from(xyz);
        axes[k] = JointAxis::new([p.x, p.y, p.z], axis);
    }
    let chain = AxisChain {
        t_ref_base: Transform::identity(),
        axes,
        t_ref_tool: kincal::pose::transform(
            Matrix3::identity(),
            p + Vector3::new(0.0, 0.0, tool_z),
        ),
    };
    Ok((desc, chain))
}

fn talos(dir: &Path) -> Result<Imported, CliError> {
    let path = dir.join("talos_left_arm_02_10_contact.csv");
    let t = read_table(&path)?;
    let names = [
        "torso_1_joint",
        "torso_2_joint",
        "arm_left_1_joint",
        "arm_left_2_joint",
        "arm_left_3_joint",
        "arm_left_4_joint",
        "arm_left_5_joint",
        "arm_left_6_joint",
        "arm_left_7_joint",
    ];
    let jc: Vec<usize> = names.iter().map(|n| t.col(n)).collect::<Result<_, _>>()?;
    let pc: Vec<usize> = ["x1", "y1", "z1"]
        .iter()
        .map(|c| t.col(c))
        .collect::<Result<_, _>>()?;
    let tcol = t.col("t")?;
    let (desc, chain) = talos_description()?;
    let AnyRobot::J9(r9) = &desc.robot else {
        return Err(CliError::input("talos description: expected 9 joints"));
    };
    let mut rows = Vec::new();
    for r in 0..t.rows.len() {
        let q: Vec<f64> = jc.iter().map(|&c| t.num(r, c)).collect::<Result<_, _>>()?;
        let p: Vec<f64> = pc.iter().map(|&c| t.num(r, c)).collect::<Result<_, _>>()?;
        rows.push(row(
            t.text(r, tcol).trim().to_string(),
            q,
            [p[0], p[1], p[2]],
            None,
        ));
    }
    // The model equals the joint-axis chain (checked on the first row).
    if let Some(first) = rows.first() {
        let q: [f64; 9] = first
            .q_rad
            .clone()
            .try_into()
            .map_err(|_| CliError::input("9 joints"))?;
        let (a, b) = (
            r9.fk_q(&q).map_err(|e| CliError::input(e.to_string()))?,
            chain.fk(&q).map_err(|e| CliError::input(e.to_string()))?,
        );
        if (a.to_homogeneous() - b.to_homogeneous()).abs().max() > 1e-9 {
            return Err(CliError::input(
                "talos description: the model differs from the joint-axis chain",
            ));
        }
    }
    let notes = vec![
        "position-only rows: x1,y1,z1 of one motion-capture marker on the left gripper; the frame \
         of the positions and the marker's place on the gripper are unknown (base frame and tool \
         translation to identify; the tool rotation cannot be seen through one point)"
            .to_string(),
        "robot: joint origins and link masses of PAL Robotics' talos_full_v2.urdf (FIGAROH's \
         TALOS example; numbers only, the file is CC BY-NC-ND and not copied)"
            .to_string(),
    ];
    Parts {
        name: "figaroh-talos-arm",
        files: &[&path],
        robot_label: "talos-left-arm (base_link -> gripper_left_base_link)",
        n_joints: 9,
        rows,
        form: None,
        extra_columns: Vec::new(),
        robot: desc,
        robot_comments: vec![
            " TALOS torso + left arm, base_link -> gripper_left_base_link, 9 joints.".into(),
            " Joint origins, limits and link masses are the numbers of PAL Robotics'".into(),
            " talos_full_v2.urdf (FIGAROH TALOS example); the URDF is CC BY-NC-ND and".into(),
            " not copied. Built by kincal import-dataset figaroh-talos-arm.".into(),
        ],
        notes,
    }
    .finish()
}

/// The positioner's entries: (stamp, joints, position, quaternion w, x, y, z), each with
/// its line. A strict reader of the file's own layout (not a general YAML parser): every
/// line must be one of the expected forms.
#[allow(clippy::type_complexity)]
fn read_positioner_yaml(
    path: &Path,
) -> Result<Vec<(u64, String, Vec<f64>, [f64; 3], [f64; 4])>, CliError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::input(format!("{name}: cannot read: {e}")))?;
    let mut out = Vec::new();
    struct Entry {
        line: u64,
        stamp: String,
        joints: Vec<f64>,
        pose: HashMap<String, f64>,
        camera_joints_empty: bool,
    }
    let mut cur: Option<Entry> = None;
    let mut section = "";
    let bad = |line: usize, what: &str| CliError::input(format!("{name}:{}: {what}", line + 1));
    let finish = |e: Entry, out: &mut Vec<_>| -> Result<(), CliError> {
        let g = |k: &str| {
            e.pose.get(k).copied().ok_or_else(|| {
                CliError::input(format!(
                    "{name}:{}: entry '{}' has no pose.{k}",
                    e.line, e.stamp
                ))
            })
        };
        if !e.camera_joints_empty {
            return Err(CliError::input(format!(
                "{name}:{}: entry '{}': expected camera_joints: [] (a static sensor)",
                e.line, e.stamp
            )));
        }
        if e.joints.len() != 2 {
            return Err(CliError::input(format!(
                "{name}:{}: entry '{}' has {} target_joints, expected 2",
                e.line,
                e.stamp,
                e.joints.len()
            )));
        }
        let p = [g("x")?, g("y")?, g("z")?];
        let q = [g("qw")?, g("qx")?, g("qy")?, g("qz")?];
        out.push((e.line, e.stamp, e.joints, p, q));
        Ok(())
    };
    for (i, raw) in text.lines().enumerate() {
        let l = raw.trim_end();
        if l.trim().is_empty() {
            continue;
        }
        if !l.starts_with(' ') {
            // '1593701755':
            let stamp = l
                .strip_suffix(':')
                .map(|s| s.trim_matches('\''))
                .filter(|s| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()))
                .ok_or_else(|| bad(i, "expected an entry key like '1593701755':"))?;
            if let Some(e) = cur.take() {
                finish(e, &mut out)?;
            }
            cur = Some(Entry {
                line: i as u64 + 1,
                stamp: stamp.to_string(),
                joints: Vec::new(),
                pose: HashMap::new(),
                camera_joints_empty: false,
            });
            section = "";
            continue;
        }
        let e = cur
            .as_mut()
            .ok_or_else(|| bad(i, "indented line before the first entry"))?;
        let t = l.trim_start();
        let indent = l.len() - t.len();
        match (indent, t) {
            (2, "camera_joints: []") => e.camera_joints_empty = true,
            (2, "pose:") => section = "pose",
            (2, "target_joints:") => section = "target_joints",
            (4, kv) if section == "pose" => {
                let (k, v) = kv
                    .split_once(": ")
                    .ok_or_else(|| bad(i, "expected 'key: value' under pose"))?;
                let v: f64 = v
                    .trim()
                    .parse()
                    .ok()
                    .filter(|v: &f64| v.is_finite())
                    .ok_or_else(|| bad(i, &format!("pose.{k}: expected a finite number")))?;
                e.pose.insert(k.to_string(), v);
            }
            (2, item) if section == "target_joints" && item.starts_with("- ") => {
                let v: f64 = item[2..]
                    .trim()
                    .parse()
                    .ok()
                    .filter(|v: &f64| v.is_finite())
                    .ok_or_else(|| bad(i, "target_joints: expected a finite number"))?;
                e.joints.push(v);
            }
            _ => return Err(bad(i, &format!("unexpected line {t:?}"))),
        }
    }
    if let Some(e) = cur.take() {
        finish(e, &mut out)?;
    }
    if out.is_empty() {
        return Err(CliError::input(format!("{name}: no entries")));
    }
    Ok(out)
}

fn positioner(dir: &Path) -> Result<Imported, CliError> {
    use std::f64::consts::{FRAC_PI_2 as H, PI};
    let path = dir.join("measurements.yaml");
    let entries = read_positioner_yaml(&path)?;
    let mut rows = Vec::new();
    for (line, stamp, q, p, quat) in entries {
        let ([w, x, y, z], n) = kincal::pose::normalized_quaternion(&quat).map_err(|e| {
            CliError::input(format!(
                "{}:{line}: entry '{stamp}': quaternion: {e}",
                path.display()
            ))
        })?;
        if (n - 1.0).abs() > 1e-6 {
            return Err(CliError::input(format!(
                "{}:{line}: entry '{stamp}': quaternion norm {n}, expected 1",
                path.display()
            )));
        }
        rows.push(row(
            stamp,
            q,
            p,
            Some(Orientation::Quaternion { w, x, y, z }),
        ));
    }
    // Classical DH [d, θ, r, α] = [0, 0, 0, −π/2] and [−0.475, −π/2, 0, 0], each
    // Tz(d)·Rz(θ + q)·Tx(r)·Rx(α), after the base offset Trans(2.2, 0, 1.6)·Rx(π/2) (the
    // set's README, from industrial_calibration's kinematic_calibration example). As URDF
    // joints: origin of joint 1 = base offset·Tz(d1)·Rz(θ1); of joint 2 =
    // Tx(r1)·Rx(α1)·Tz(d2)·Rz(θ2); the tool = Tx(r2)·Rx(α2). No limits are stated: ±2π.
    let o1 = pose_from_xyz_rpy([2.2, 0.0, 1.6], [H, 0.0, 0.0]);
    let o2 = pose_from_xyz_rpy([0.0, 0.0, 0.0], [-H, 0.0, 0.0])
        * pose_from_xyz_rpy([0.0, 0.0, -0.475], [0.0, 0.0, -H]);
    let rpy = |t: &Transform| kincal::pose::matrix_to_rpy(t.rotation.matrix());
    let xyz = |t: &Transform| {
        let v = t.translation.vector;
        [v.x, v.y, v.z]
    };
    let lim = (-2.0 * PI, 2.0 * PI);
    let joints = [
        joint("joint_1", xyz(&o1), rpy(&o1), [0.0, 0.0, 1.0], lim, 0.0),
        joint("joint_2", xyz(&o2), rpy(&o2), [0.0, 0.0, 1.0], lim, 0.0),
        fixed("target_mount", [0.0; 3], [0.0; 3], 0.0),
    ];
    let desc = chain_robot("ical-positioner", &joints)?;
    let notes = vec![
        "pose = the target's pose in the static sensor's frame (position, unit quaternion): base \
         (sensor -> positioner) and tool (target mount -> target) frames unknown"
            .to_string(),
        "robot: the two classical DH rows and base offset stated in the set's README; joint \
         limits not stated (±2π used)"
            .to_string(),
    ];
    Parts {
        name: "ical-2axis-positioner",
        files: &[&path],
        robot_label: "ical-positioner (two revolute axes, classical DH of the README)",
        n_joints: 2,
        rows,
        form: Some(OrientationForm::Quaternion),
        extra_columns: Vec::new(),
        robot: desc,
        robot_comments: vec![
            " Two-axis positioner of industrial_calibration's kinematic_calibration example:"
                .into(),
            " classical DH rows [d, θ, r, α] = [0, 0, 0, -π/2], [-0.475, -π/2, 0, 0] after".into(),
            " Trans(2.2, 0, 1.6)·Rx(π/2), as stated in the ical-2axis-positioner README.".into(),
        ],
        notes,
    }
    .finish()
}

/// Writes a robot description with leading comment lines.
pub fn robot_text(imported: &Imported) -> String {
    let mut s = String::new();
    for c in &imported.robot_comments {
        let _ = writeln!(s, "#{c}");
    }
    s.push_str(&crate::robot_file::write_robot_description(&imported.robot));
    s
}

/// Joint count of a description (for messages).
pub fn n_joints(desc: &RobotDescription) -> usize {
    with_any_robot!(&desc.robot, r => r.links().len())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// docs/robots/fr3.toml is exactly [`fr3_description`] (regenerate with
    /// `KINCAL_BLESS=1 cargo test -p kincal-io fr3_toml`).
    #[test]
    fn fr3_toml_is_the_built_description() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/robots/fr3.toml");
        let desc = fr3_description().unwrap();
        if std::env::var("KINCAL_BLESS").is_ok_and(|v| v == "1") {
            let mut text = String::from(FR3_HEADER);
            text.push_str(&crate::robot_file::write_robot_description(&desc));
            std::fs::write(&path, text).unwrap();
        }
        let loaded = crate::robot_file::load_robot_file(&path).unwrap();
        assert_eq!(
            loaded.robot, desc.robot,
            "regenerate: KINCAL_BLESS=1 cargo test -p kincal-io fr3_toml"
        );
        assert_eq!(loaded.joint_names, desc.joint_names);
    }

    const FR3_HEADER: &str = "\
# Franka Research 3 (7 revolute joints), flange (link8) as the tool frame.
# Kinematics: Franka's published modified DH parameters (Craig convention, a_{i-1}, d_i,
# alpha_{i-1}): (0, 0.333, 0), (0, 0, -pi/2), (0, 0.316, pi/2), (0.0825, 0, pi/2),
# (-0.0825, 0.384, -pi/2), (0, 0, pi/2), (0.088, 0, pi/2), flange d = 0.107 m (Franka
# documentation, \"Robot and interface specifications\"), converted to kincal's model
# A_i = Rz(q_i + theta0)·Tz(d)·Tx(a)·Rx(alpha)·Ry(beta) through the joint axes
# (kincal::axis_chain; exact). Joint limits: Franka documentation, \"Limits for Franka
# Research 3\". No mass model: masses unknown here (joint_compliance needs one).
# Generated by `KINCAL_BLESS=1 cargo test -p kincal-io fr3_toml` from
# io/src/datasets.rs::fr3_description; a test checks that this file loads to exactly it.
# The robotkinecal-fr3 data set's FK check (kincal import-dataset): the robot's own TCP
# poses equal this model's flange pose times one constant transform to 0.06 mm.
";
}
