//! Adapters for the instrument-free (contact) data sets of `kincal import-dataset`: rows
//! that say where the tool point is *held* (spec/measurements.md, "Points, constraints and
//! sessions"), not where an instrument saw it.
//!
//! - `mukca` (`--robot-id ID`): a ball on the end effector held in one of two sockets of a
//!   3D-printed plate, 50 mm apart, in 10–44 configurations per socket; the plate is placed
//!   at several locations (`data/ID/LOCATION/hole_0.csv`, `hole_1.csv`: one configuration
//!   per line, no header, rad). Each location is a `session` (the plate's placement; one base
//!   frame each), its sockets the targets `LOCATION/s0` and `LOCATION/s1`, and the
//!   constraints file gives one `[[distance]]` of 0.050 m per location. The robot is the
//!   set's URDF from its base link to `ball_link`: the tool point is the ball centre, nominal
//!   from the URDF's `ball_joint`.
//! - `figaroh-mate-planes`: a 3-joint arm touching three planes `x = 0.3044`, `y = -0.43791`,
//!   `z = -0.004` (m) ten times each: every contact row carries the one coordinate it
//!   constrains (the other two left empty), joints converted from degrees; the ten full
//!   poses of `transformed_poses.csv` follow as 6-D rows (`roll_deg`, `pitch_deg`, `yaw_deg`).
//!
//! Both write the CSV text themselves (the rows have columns the plain measurement writer
//! does not have); numbers are written in the shortest form that reads back exactly.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::error::Error as CliError;
use crate::robot_arg::UrdfChainArgs;
use crate::robot_file::RobotDescription;
use crate::urdf::{ChainSelection, import_urdf_file};

/// Distance between the two sockets of the MUKCa plate [m] (caliper-checked; MUKCa README,
/// the optimiser's `--distance` default).
pub const MUKCA_SOCKET_DISTANCE_M: f64 = 0.050;

/// One imported contact set: the CSV text, the constraints file, the robot.
#[derive(Debug, Clone)]
pub struct ContactImport {
    /// The measurement CSV (comments, header, rows).
    pub csv: String,
    /// The constraints file (TOML), when the set has known geometry.
    pub constraints: Option<String>,
    /// The nominal robot.
    pub robot: RobotDescription,
    /// Comment lines of the robot description file.
    pub robot_comments: Vec<String>,
    /// What was assumed (also in the CSV comments).
    pub notes: Vec<String>,
    /// Number of data rows.
    pub rows: usize,
    /// One line on what the rows are.
    pub what: String,
}

/// Options of the contact sets.
#[derive(Debug, Clone, Default)]
pub struct ContactOptions {
    /// MUKCa: which robot's recordings (`data/<ID>`).
    pub robot_id: Option<String>,
    /// Overrides the set's URDF chain.
    pub chain: UrdfChainArgs,
}

/// The contact sets (names) this module imports.
pub const CONTACT_SETS: &[&str] = &["mukca", "figaroh-mate-planes"];

/// Imports contact set `name` from `dir`.
pub fn import(name: &str, dir: &Path, opts: &ContactOptions) -> Result<ContactImport, CliError> {
    if !dir.is_dir() {
        return Err(CliError::input(format!(
            "{}: not a folder: expected the data set's folder (e.g. ../shared/realdata/{name})",
            dir.display()
        )));
    }
    match name {
        "mukca" => mukca(dir, opts),
        "figaroh-mate-planes" => mate(dir, opts),
        _ => Err(CliError::usage(format!(
            "'{name}' is not a contact data set"
        ))),
    }
}

/// Shortest decimal that reads back to the same double.
fn num(v: f64) -> String {
    crate::measurements::format_f64(v)
}

fn sha256(path: &Path) -> Result<String, CliError> {
    crate::files::sha256_file(path)
        .map_err(|e| CliError::input(format!("{}: cannot read: {e}", path.display())))
}

/// Numeric rows with their 1-based line numbers.
type NumberRows = Vec<(usize, Vec<f64>)>;

/// A headerless numeric CSV (MUKCa): rows of exactly `n` finite numbers, with their line.
fn read_numbers(path: &Path, n: usize) -> Result<NumberRows, CliError> {
    let name = path.display();
    let text = std::fs::read_to_string(path).map_err(|e| {
        CliError::input(format!(
            "{name}: cannot read: {e} (every location folder has hole_0.csv and hole_1.csv)"
        ))
    })?;
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').collect();
        if cells.len() != n {
            return Err(CliError::input(format!(
                "{name}:{}: {} values, expected {n} joint readings [rad] for this robot",
                i + 1,
                cells.len()
            )));
        }
        let mut q = Vec::with_capacity(n);
        for (c, cell) in cells.iter().enumerate() {
            match cell.trim().parse::<f64>() {
                Ok(v) if v.is_finite() => q.push(v),
                _ => {
                    return Err(CliError::input(format!(
                        "{name}:{}:{}: expected a finite joint reading [rad], found {cell:?}",
                        i + 1,
                        c + 1
                    )));
                }
            }
        }
        rows.push((i + 1, q));
    }
    if rows.is_empty() {
        return Err(CliError::input(format!("{name}: no configurations")));
    }
    Ok(rows)
}

/// The URDF, base and tip links of a MUKCa robot id.
fn mukca_robot_of(id: &str) -> Option<(&'static str, &'static str)> {
    if id == "panda_1_with_sensor" {
        Some(("panda_plus_bota.urdf", "panda_link0"))
    } else if id.starts_with("panda_") {
        Some(("panda.urdf", "panda_link0"))
    } else if id.starts_with("kuka_14") {
        Some(("iiwa14.urdf", "base_link"))
    } else if id.starts_with("dinova_") {
        Some(("gen3lite.urdf", "kinova_base_link"))
    } else {
        None
    }
}

/// The robot ids of the set (folders of `data/`).
fn mukca_ids(dir: &Path) -> Vec<String> {
    sorted_dirs(&dir.join("data"))
        .iter()
        .filter_map(|p| p.file_name().map(|f| f.to_string_lossy().into_owned()))
        .collect()
}

fn sorted_dirs(dir: &Path) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_dir())
                .collect()
        })
        .unwrap_or_default();
    out.sort();
    out
}

fn mukca(dir: &Path, opts: &ContactOptions) -> Result<ContactImport, CliError> {
    let ids = mukca_ids(dir);
    let Some(id) = opts.robot_id.as_deref() else {
        return Err(CliError::usage(format!(
            "mukca: --robot-id is required (one of {})",
            ids.join(", ")
        )));
    };
    let Some((urdf_name, default_base)) = mukca_robot_of(id) else {
        return Err(CliError::usage(format!(
            "mukca: unknown robot id '{id}': expected one of {}",
            ids.join(", ")
        )));
    };
    let data_dir = dir.join("data").join(id);
    if !data_dir.is_dir() {
        return Err(CliError::input(format!(
            "{}: not a folder: robot id '{id}' has no recordings (ids found: {})",
            data_dir.display(),
            ids.join(", ")
        )));
    }
    let urdf_path = dir.join("urdf").join(urdf_name);
    let sel = ChainSelection {
        base_link: opts.chain.base_link.as_deref().or(Some(default_base)),
        tip_link: opts.chain.tip_link.as_deref().or(Some("ball_link")),
    };
    let imported =
        import_urdf_file(&urdf_path, &sel).map_err(|e| CliError::input(e.to_string()))?;
    let n = imported.joint_names.len();
    let locations = sorted_dirs(&data_dir);
    if locations.is_empty() {
        return Err(CliError::input(format!(
            "{}: no location folders",
            data_dir.display()
        )));
    }
    let mut files: Vec<PathBuf> = Vec::new();
    let mut body = String::new();
    let mut constraints = format!(
        "# MUKCa plate for robot id {id}: the two sockets of each location are {} mm apart\n\
         # (caliper-checked; MUKCa README). Written by kincal import-dataset mukca.\n",
        MUKCA_SOCKET_DISTANCE_M * 1e3
    );
    let mut rows = 0;
    for loc_dir in &locations {
        let loc = loc_dir
            .file_name()
            .map_or_else(String::new, |f| f.to_string_lossy().into_owned());
        for socket in 0..2 {
            let f = loc_dir.join(format!("hole_{socket}.csv"));
            let qs = read_numbers(&f, n)?;
            for (line, q) in &qs {
                let _ = write!(body, "{loc}/s{socket}/{line},{loc},{loc}/s{socket}");
                for v in q {
                    let _ = write!(body, ",{}", num(*v));
                }
                body.push('\n');
            }
            rows += qs.len();
            files.push(f);
        }
        let _ = writeln!(
            constraints,
            "\n[[distance]]\nbetween = [\"{loc}/s0\", \"{loc}/s1\"]\nm = {}",
            num(MUKCA_SOCKET_DISTANCE_M)
        );
    }
    let notes = vec![
        format!(
            "robot: {urdf_name}, chain {} -> {} ({n} joints); the tool point is the ball centre (ball_joint), to be identified",
            imported.base_link, imported.tip_link
        ),
        "session = location folder (one plate placement, one base frame); target LOCATION/s0 and /s1 = hole_0 and hole_1; pose_id = LOCATION/sK/LINE (line of hole_K.csv)".into(),
        format!(
            "constraints: one [[distance]] of {} m per location (the sockets' spacing)",
            num(MUKCA_SOCKET_DISTANCE_M)
        ),
        "hole_K_pose.csv (the robot's own FK) is not measurement data and is not read".into(),
    ];
    let mut csv = String::new();
    let _ = writeln!(
        csv,
        "# dataset: mukca, robot id {id} (imported by kincal import-dataset)"
    );
    for f in files
        .iter()
        .map(PathBuf::as_path)
        .chain([urdf_path.as_path()])
    {
        let rel = f.strip_prefix(dir).unwrap_or(f);
        let _ = writeln!(csv, "# source: {} (sha256 {})", rel.display(), sha256(f)?);
    }
    let _ = writeln!(csv, "# robot: {} ({urdf_name})", imported.robot_name);
    for note in &notes {
        let _ = writeln!(csv, "# note: {note}");
    }
    csv.push_str("pose_id,session,target");
    for k in 1..=n {
        let _ = write!(csv, ",q{k}");
    }
    csv.push('\n');
    csv.push_str(&body);
    Ok(ContactImport {
        csv,
        constraints: Some(constraints),
        robot: RobotDescription {
            name: format!("mukca-{id}"),
            joint_names: imported.joint_names,
            robot: imported.robot,
        },
        robot_comments: vec![format!(
            " MUKCa robot id {id}: {urdf_name} of the mukca set (MIT), chain {} -> {}, converted by kincal import-dataset",
            imported.base_link, imported.tip_link
        )],
        notes,
        rows,
        what: format!(
            "{} locations (sessions), {} targets, ball-in-socket rows",
            locations.len(),
            2 * locations.len()
        ),
    })
}

/// A headed CSV of the MATE set: header names and rows (line, numbers).
fn read_headed(path: &Path) -> Result<(Vec<String>, NumberRows), CliError> {
    let name = path.display();
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::input(format!("{name}: cannot read: {e}")))?;
    let mut lines = text.lines().enumerate();
    let header: Vec<String> = lines
        .next()
        .map(|(_, h)| h.split(',').map(|s| s.trim().to_string()).collect())
        .unwrap_or_default();
    let mut rows = Vec::new();
    for (i, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').collect();
        if cells.len() != header.len() {
            return Err(CliError::input(format!(
                "{name}:{}: {} values, the header has {}",
                i + 1,
                cells.len(),
                header.len()
            )));
        }
        let mut v = Vec::new();
        for (c, cell) in cells.iter().enumerate() {
            match cell.trim().parse::<f64>() {
                Ok(x) if x.is_finite() => v.push(x),
                _ => {
                    return Err(CliError::input(format!(
                        "{name}:{}:{}: column '{}': expected a finite number, found {cell:?}",
                        i + 1,
                        c + 1,
                        header[c]
                    )));
                }
            }
        }
        rows.push((i + 1, v));
    }
    if rows.is_empty() {
        return Err(CliError::input(format!("{name}: no data rows")));
    }
    Ok((header, rows))
}

fn expect_header(path: &Path, header: &[String], want: &[&str]) -> Result<(), CliError> {
    if header.iter().map(String::as_str).eq(want.iter().copied()) {
        Ok(())
    } else {
        Err(CliError::input(format!(
            "{}:1: header {:?}, expected the set's published {want:?}",
            path.display(),
            header
        )))
    }
}

fn mate(dir: &Path, opts: &ContactOptions) -> Result<ContactImport, CliError> {
    let urdf_path = dir.join("mate.urdf");
    let imported = import_urdf_file(&urdf_path, &opts.chain.selection())
        .map_err(|e| CliError::input(e.to_string()))?;
    if imported.joint_names.len() != 3 {
        return Err(CliError::input(format!(
            "{}: chain {} -> {} has {} joints; the MATE rows have 3",
            urdf_path.display(),
            imported.base_link,
            imported.tip_link,
            imported.joint_names.len()
        )));
    }
    let mut files = Vec::new();
    let mut body = String::new();
    let mut rows = 0;
    for (axis, col) in [("x", 0usize), ("y", 1), ("z", 2)] {
        let f = dir.join(format!("10_points_{axis}.csv"));
        let (header, data) = read_headed(&f)?;
        expect_header(&f, &header, &[&format!("{axis}1"), "q_1", "q_2", "q_3"])?;
        for (line, v) in &data {
            let mut xyz = [String::new(), String::new(), String::new()];
            xyz[col] = num(v[0]);
            let _ = write!(body, "{axis}/{line},{}", q_rad(&mate_joints(&v[1..4])));
            let _ = writeln!(body, ",{},{},{},,,", xyz[0], xyz[1], xyz[2]);
        }
        rows += data.len();
        files.push(f);
    }
    let poses = dir.join("transformed_poses.csv");
    let mut n_poses = 0;
    if poses.is_file() {
        let (header, data) = read_headed(&poses)?;
        expect_header(
            &poses,
            &header,
            &[
                "x1", "y1", "z1", "phix1", "phiy1", "phiz1", "q_1", "q_2", "q_3",
            ],
        )?;
        for (line, v) in &data {
            let _ = writeln!(
                body,
                "pose/{line},{},{},{},{},{},{},{}",
                q_rad(&mate_joints(&v[6..9])),
                num(v[0]),
                num(v[1]),
                num(v[2]),
                num(v[3]),
                num(v[4]),
                num(v[5])
            );
        }
        n_poses = data.len();
        rows += data.len();
        files.push(poses);
    }
    let notes = vec![
        format!(
            "robot: mate.urdf, chain {} -> {}",
            imported.base_link, imported.tip_link
        ),
        "contact rows x/LINE, y/LINE, z/LINE: the tool point on the plane x = 0.3044, y = -0.43791 or z = -0.004 m (the files' constant column), in the robot's base frame; only that coordinate is given".into(),
        "joint readings converted from degrees (the files' unit, as FIGAROH's calibration_plane.py reads them)".into(),
        "q1 = -q_1: the files' q_1 turns the arm the other way than mate.urdf's joint q_1 (with the reading as published, the best-fit planes of the x and y contacts meet at 47 deg and lie 595 mm from x = 0.3044; negated, they meet at 83.5 deg and the nominal model puts them at x = 0.3029 and y = -0.4237 m, see docs/real-data.md)".into(),
        "pose/LINE rows: transformed_poses.csv as full poses, R = Rz(phiz1)·Ry(phiy1)·Rx(phix1) in degrees (assumed, the file does not say); their frame is unverified".into(),
        "10_points_in_radians.csv is not read: its positions are placeholders (all 0) and its rows match none of the plane files".into(),
        "provenance: the set's README cannot say whether the data are real".into(),
    ];
    let mut csv =
        String::from("# dataset: figaroh-mate-planes (imported by kincal import-dataset)\n");
    for f in files.iter().chain([&urdf_path]) {
        let rel = f.strip_prefix(dir).unwrap_or(f);
        let _ = writeln!(csv, "# source: {} (sha256 {})", rel.display(), sha256(f)?);
    }
    let _ = writeln!(csv, "# robot: {} (mate.urdf)", imported.robot_name);
    for note in &notes {
        let _ = writeln!(csv, "# note: {note}");
    }
    csv.push_str("pose_id,q1,q2,q3,x,y,z,roll_deg,pitch_deg,yaw_deg\n");
    csv.push_str(&body);
    Ok(ContactImport {
        csv,
        constraints: None,
        robot: RobotDescription {
            name: "mate".into(),
            joint_names: imported.joint_names,
            robot: imported.robot,
        },
        robot_comments: vec![format!(
            " MATE 3-joint arm: mate.urdf of the figaroh-mate-planes set (FIGAROH, Apache-2.0), chain {} -> {}, converted by kincal import-dataset",
            imported.base_link, imported.tip_link
        )],
        notes,
        rows,
        what: format!(
            "{} plane contacts (one coordinate each), {n_poses} full poses",
            rows - n_poses
        ),
    })
}

/// MATE's joint readings (degrees) in mate.urdf's sense: q_1 negated. With the published
/// sign, the x- and y-plane contacts are individually flat (about 5 mm) but their planes
/// meet at 47° instead of 90° at the nominal model; with q_1 negated they meet at
/// 83.5° and lie at the files' plane positions to 1.5 mm (x) and 14 mm (y) with mate.urdf's
/// own base frame. A reading that turns the other way than the model's axis is the one
/// explanation that fits both (docs/real-data.md, "MATE").
fn mate_joints(q_deg: &[f64]) -> Vec<f64> {
    q_deg
        .iter()
        .enumerate()
        .map(|(k, &q)| if k == 0 { -q } else { q })
        .collect()
}

/// Joint readings in degrees as comma-separated radians.
fn q_rad(q_deg: &[f64]) -> String {
    q_deg
        .iter()
        .map(|d| num(d.to_radians()))
        .collect::<Vec<_>>()
        .join(",")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measurements::{ReadOptions, parse_measurements};

    fn shared() -> Option<PathBuf> {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/realdata");
        if dir.is_dir() {
            return Some(dir);
        }
        assert!(
            std::env::var("CI").map_or(true, |v| v != "true"),
            "CI=true: shared/realdata is required"
        );
        eprintln!("SKIPPED: {} not found", dir.display());
        None
    }

    /// The written CSVs read back through the measurement reader: MUKCa's rows are targets
    /// with sessions, MATE's contacts carry one coordinate each.
    #[test]
    fn imported_csvs_read_back_as_constraint_rows() {
        let Some(root) = shared() else { return };
        let opts = ContactOptions {
            robot_id: Some("panda_1".into()),
            chain: UrdfChainArgs::default(),
        };
        let imp = import("mukca", &root.join("mukca"), &opts).expect("mukca");
        let set = parse_measurements(imp.csv.as_bytes(), "mukca.csv", &ReadOptions::new(7))
            .expect("mukca reads back");
        assert_eq!(set.rows.len(), imp.rows);
        assert!(set.has_target && set.has_session);
        let r = &set.rows[0];
        assert_eq!(r.target.as_deref(), Some("back-high/s0"));
        assert_eq!(r.session.as_deref(), Some("back-high"));
        assert!(r.position_m.is_none() && r.orientation.is_none());

        let imp = import(
            "figaroh-mate-planes",
            &root.join("figaroh-mate-planes"),
            &ContactOptions::default(),
        )
        .expect("mate");
        let set = parse_measurements(imp.csv.as_bytes(), "mate.csv", &ReadOptions::new(3))
            .expect("mate reads back");
        assert_eq!(set.rows.len(), 40);
        let x = set
            .rows
            .iter()
            .find(|r| r.pose_id.as_deref() == Some("x/2"))
            .unwrap();
        let y = set
            .rows
            .iter()
            .find(|r| r.pose_id.as_deref() == Some("y/2"))
            .unwrap();
        let pose = set
            .rows
            .iter()
            .find(|r| r.pose_id.as_deref() == Some("pose/2"))
            .unwrap();
        assert!(x.target.is_none() && pose.orientation.is_some());
        assert_eq!(x.partial_m, Some([Some(0.3044), None, None]));
        assert_eq!(y.partial_m, Some([None, Some(-0.43791), None]));
    }
}
