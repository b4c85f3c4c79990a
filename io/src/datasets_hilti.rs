//! `kincal import-dataset hilti DIR`: Hilti's "Trailblazer" stationing set
//! (../shared/realdata/hilti-jaibot-stationing; CC BY-NC-SA 3.0: read from there, never
//! copied). A lifting column (one prismatic joint: the URDF's mimic stages collapse into
//! it) carries a 6R Doosan arm; a total station measures a prism on the end effector; two
//! ADXL355 accelerometers sit on the column base and the column tip.
//!
//! What the rows are (spec/measurements.md, docs/robot-description.md):
//! - one YAML file = one `session` (a floor condition): the robot stands still, the total
//!   station's frame is the session's, so every session has its own base frame;
//! - `q1` the column [m], `q2`, `q3` the column tip's tilt about the base x and y axes
//!   relative to the column base [rad] (sensor joints: the column's bending as the two
//!   accelerometers read it), `q4..q9` the arm [rad];
//! - `x, y, z` the prism [m] in the total station's frame (position only);
//! - `temp_c` the session's temperature (21 °C; `outdoor` 9 °C, as the set's README states);
//! - `extra_height_m`, `extra_solution_space`, `extra_kind` (`stationing`/`evaluation`),
//!   `extra_upside_down`, `extra_base_tilt_x`, `extra_base_tilt_y` (the base accelerometer's
//!   tilt [rad]: the floor's slope).
//!
//! Tilt from an accelerometer at rest (it reads the specific force `Rᵀ·(0, 0, g)` in its own
//! axes, which the URDF aligns with the base frame): about x `atan2(a_y, a_z)`, about y
//! `atan2(−a_x, a_z)`. The column's bending is the tip's tilt minus the base's.

use std::path::Path;

use kincal::any::AnyRobot;
use kincal::axis_chain::{AxisChain, JointAxis, link_transform_at_zero};
use kincal::pose::Transform;
use kincal::{JointKind, JointLimits};

use crate::error::Error as CliError;
use crate::measurements::{MeasurementRow, MeasurementSet};
use crate::robot_file::RobotDescription;
use crate::urdf::{ChainSelection, import_urdf_file};

/// The session files in the order the docs report them (`flat` first: it is the training
/// floor), with the temperature the set's README states [°C].
pub const SESSIONS: [(&str, f64); 7] = [
    ("flat", 21.0),
    ("outdoor", 9.0),
    ("pallet", 21.0),
    ("orthogonal_wood", 21.0),
    ("wood_left_track", 21.0),
    ("seesaw", 21.0),
    ("diagonal_wood", 21.0),
];

/// The total station's stated noise, 1σ per axis [m] (the set's README).
pub const SIGMA_POS_M: f64 = 0.75e-3;

/// Range given to the tilt sensor joints [rad] (the readings stay within ±0.03).
const TILT_LIMIT_RAD: f64 = 0.1;

/// Joints of the model.
pub const N: usize = 11;
/// The sensor joints' positions in the chain (base tilt x, y; column bending x, y).
pub const SENSOR_JOINTS: [usize; 4] = [0, 1, 3, 4];

/// Joint names of the model.
pub const JOINT_NAMES: [&str; N] = [
    "base_tilt_x",
    "base_tilt_y",
    "column_prismatic_joint",
    "column_tilt_x",
    "column_tilt_y",
    "dsr_joint1",
    "dsr_joint2",
    "dsr_joint3",
    "dsr_joint4",
    "dsr_joint5",
    "dsr_joint6",
];

/// One measurement of a session file.
#[derive(Debug, Clone, PartialEq)]
pub struct HiltiRow {
    /// 1-based line of its `- id:` entry.
    pub line: u64,
    pub id: u64,
    pub height_m: f64,
    pub solution_space: u32,
    /// `true` for `evaluation_measurements`, `false` for `stationing_measurements`.
    pub evaluation: bool,
    pub upside_down: bool,
    /// Column [m] and arm [rad], as recorded.
    pub joints: [f64; 7],
    /// Prism position in the total station's frame [m].
    pub prism_m: [f64; 3],
    pub base_accel: [f64; 3],
    pub column_accel: [f64; 3],
}

impl HiltiRow {
    /// (about x, about y) tilt of an accelerometer at rest [rad].
    #[must_use]
    pub fn tilt(a: &[f64; 3]) -> [f64; 2] {
        [a[1].atan2(a[2]), (-a[0]).atan2(a[2])]
    }
    /// The column tip's tilt relative to the column base [rad]: the sensor joints' readings.
    #[must_use]
    pub fn bending(&self) -> [f64; 2] {
        let (c, b) = (Self::tilt(&self.column_accel), Self::tilt(&self.base_accel));
        [c[0] - b[0], c[1] - b[1]]
    }
    /// The model's joint readings: the base's tilt (x, y), column, the column's bending
    /// (x, y), the arm.
    #[must_use]
    pub fn q(&self) -> [f64; N] {
        let [bx, by] = self.bending();
        let [tx, ty] = Self::tilt(&self.base_accel);
        let j = &self.joints;
        [tx, ty, j[0], bx, by, j[1], j[2], j[3], j[4], j[5], j[6]]
    }
}

/// Reads one session file: a strict reader of the set's own layout (not a general YAML
/// parser); every error names the file and line.
pub fn read_session(path: &Path) -> Result<Vec<HiltiRow>, CliError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::input(format!("{name}: cannot read: {e}")))?;
    parse_session(&text, &name)
}

/// Parses the text of a session file; `name` names it in errors.
// Long by design: the session file's sections in order (a line-based reader of one vendor format).
pub fn parse_session(text: &str, name: &str) -> Result<Vec<HiltiRow>, CliError> {
    let bad = |line: usize, what: String| CliError::input(format!("{name}:{line}: {what}"));
    // Join flow lists wrapped over several lines into one logical line.
    let mut logical: Vec<(usize, String)> = Vec::new();
    let mut open = 0i32;
    for (i, raw) in text.lines().enumerate() {
        if open > 0 {
            if let Some(last) = logical.last_mut() {
                last.1.push(' ');
                last.1.push_str(raw.trim());
            }
        } else {
            logical.push((i + 1, raw.to_string()));
        }
        open += raw.matches('[').count() as i32 - raw.matches(']').count() as i32;
    }
    let mut rows = Vec::new();
    let mut height: Option<f64> = None;
    let mut space: Option<u32> = None;
    let mut evaluation: Option<bool> = None;
    let mut cur: Option<(usize, Vec<(String, String)>)> = None;
    let finish = |cur: Option<(usize, Vec<(String, String)>)>,
                  ctx: (Option<f64>, Option<u32>, Option<bool>),
                  rows: &mut Vec<HiltiRow>|
     -> Result<(), CliError> {
        let Some((line, kv)) = cur else {
            return Ok(());
        };
        let get = |k: &str| {
            kv.iter()
                .find(|(key, _)| key == k)
                .map(|(_, v)| v.as_str())
                .ok_or_else(|| bad(line, format!("measurement has no `{k}`")))
        };
        let num = |k: &str, v: &str| {
            v.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    bad(
                        line,
                        format!("`{k}`: `{}` is not a finite number", v.trim()),
                    )
                })
        };
        let list = |k: &str| -> Result<Vec<f64>, CliError> {
            let v = get(k)?.trim();
            let inner = v
                .strip_prefix('[')
                .and_then(|s| s.strip_suffix(']'))
                .ok_or_else(|| bad(line, format!("`{k}`: expected a [list], got `{v}`")))?;
            inner.split(',').map(|x| num(k, x)).collect()
        };
        let fixed = |k: &str, n: usize| -> Result<Vec<f64>, CliError> {
            let v = list(k)?;
            if v.len() == n {
                Ok(v)
            } else {
                Err(bad(
                    line,
                    format!("`{k}`: expected {n} numbers, got {}", v.len()),
                ))
            }
        };
        let three = |k: &str| -> Result<[f64; 3], CliError> {
            let v = fixed(k, 3)?;
            Ok([v[0], v[1], v[2]])
        };
        let (Some(height_m), Some(solution_space), Some(evaluation)) = ctx else {
            return Err(bad(
                line,
                "measurement outside column_heights / solution_spaces / *_measurements".into(),
            ));
        };
        let j = fixed("joint_states", 7)?;
        let upside = get("upside_down")?.trim();
        let upside_down = match upside {
            "true" => true,
            "false" => false,
            v => {
                return Err(bad(
                    line,
                    format!("`upside_down`: expected true or false, got `{v}`"),
                ));
            }
        };
        rows.push(HiltiRow {
            line: line as u64,
            id: num("id", get("id")?)? as u64,
            height_m,
            solution_space,
            evaluation,
            upside_down,
            joints: [j[0], j[1], j[2], j[3], j[4], j[5], j[6]],
            prism_m: three("prism_position")?,
            base_accel: three("tilt_sensor_base_accel")?,
            column_accel: three("tilt_sensor_column_accel")?,
        });
        Ok(())
    };
    for (line, l) in &logical {
        let indent = l.len() - l.trim_start().len();
        let t = l.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let key_of = |s: &str| {
            s.split_once(':')
                .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
        };
        if let Some(rest) = t.strip_prefix("- ") {
            finish(cur.take(), (height, space, evaluation), &mut rows)?;
            let kv =
                key_of(rest).ok_or_else(|| bad(*line, format!("expected `- id: N`, got `{t}`")))?;
            cur = Some((*line, vec![kv]));
            continue;
        }
        let (k, v) =
            key_of(t).ok_or_else(|| bad(*line, format!("expected `key: value`, got `{t}`")))?;
        match (indent, k.as_str()) {
            (0, "joint_names" | "column_heights") => {}
            (2, h) => {
                finish(cur.take(), (height, space, evaluation), &mut rows)?;
                height =
                    Some(num_key(h).ok_or_else(|| {
                        bad(*line, format!("column height `{h}` is not a number"))
                    })?);
            }
            (4, "solution_spaces") => {}
            (6, s) => {
                finish(cur.take(), (height, space, evaluation), &mut rows)?;
                space =
                    Some(s.parse().map_err(|_| {
                        bad(*line, format!("solution space `{s}` is not an integer"))
                    })?);
            }
            (8, "stationing_measurements") => {
                finish(cur.take(), (height, space, evaluation), &mut rows)?;
                evaluation = Some(false);
            }
            (8, "evaluation_measurements") => {
                finish(cur.take(), (height, space, evaluation), &mut rows)?;
                evaluation = Some(true);
            }
            _ => match cur.as_mut() {
                Some((_, kv)) => kv.push((k, v)),
                None => return Err(bad(*line, format!("unexpected `{t}`"))),
            },
        }
    }
    finish(cur.take(), (height, space, evaluation), &mut rows)?;
    if rows.is_empty() {
        return Err(CliError::input(format!("{name}: no measurements")));
    }
    Ok(rows)
}

fn num_key(s: &str) -> Option<f64> {
    s.parse::<f64>().ok().filter(|x| x.is_finite())
}

/// The 9-joint model: the shipped URDF's chain `base_link` → `prism` (column P + arm 6R,
/// mimic stages collapsed, the prism's calibrated offset as the tool) with two sensor
/// joints inserted after the column: tilts about the base x and y axes through the arm's
/// mounting point (where the first arm axis meets the column top).
pub fn robot(urdf: &Path) -> Result<RobotDescription, CliError> {
    robot_with_order(urdf, IMPORT_ORDER)
}

/// The chain's first five joints as readings of [`HiltiRow::q`] (base tilt x, y, column,
/// bending x, y) in the import's order.
pub const IMPORT_ORDER: [usize; 5] = [0, 1, 2, 3, 4];

/// The model with its first five joints in `order` (indices into [`HiltiRow::q`]'s first
/// five readings; the arm follows): a tilt joint placed after the column turns about the
/// arm's mounting point, one placed before it about the base origin, so the column's
/// extension lies inside or outside its lever. The joint names follow the order.
pub fn robot_with_order(urdf: &Path, order: [usize; 5]) -> Result<RobotDescription, CliError> {
    let sel = ChainSelection {
        base_link: Some("base_link"),
        tip_link: Some("prism"),
    };
    let imp = import_urdf_file(urdf, &sel).map_err(|e| CliError::input(e.to_string()))?;
    let AnyRobot::J7(r7) = imp.robot else {
        return Err(CliError::input(format!(
            "{}: chain base_link -> prism: expected 7 joints (column + 6 arm), got {}",
            urdf.display(),
            imp.robot.n_joints()
        )));
    };
    let err = |e: kincal::Error| CliError::input(format!("{}: {e}", urdf.display()));
    // Frames of the 7-joint chain at q = 0: joint k turns about z of frame k−1.
    let mut frames = [Transform::identity(); 8];
    frames[0] = *r7.t_base_0();
    for (k, l) in r7.links().iter().enumerate() {
        frames[k + 1] = frames[k] * link_transform_at_zero(l);
    }
    let axis = |t: &Transform| {
        let p = t.translation.vector;
        let z = t.rotation.matrix().column(2).into_owned();
        JointAxis::new([p.x, p.y, p.z], [z.x, z.y, z.z])
    };
    let mount = frames[1].translation.vector;
    let column_at = order.iter().position(|&j| j == 2);
    let mut axes = [axis(&frames[0]); N];
    let mut names = JOINT_NAMES;
    for (k, &j) in order.iter().enumerate() {
        let pivot = if column_at.is_some_and(|c| k > c) {
            [mount.x, mount.y, mount.z]
        } else {
            [0.0; 3]
        };
        let about_x = [1.0, 0.0, 0.0];
        let about_y = [0.0, 1.0, 0.0];
        axes[k] = match j {
            0 | 3 => JointAxis::new(pivot, about_x),
            1 | 4 => JointAxis::new(pivot, about_y),
            _ => axis(&frames[0]),
        };
        names[k] = JOINT_NAMES[j];
    }
    for k in 1..7 {
        axes[k + 4] = axis(&frames[k]);
    }
    let chain = AxisChain {
        t_ref_base: Transform::identity(),
        axes,
        t_ref_tool: frames[7] * kincal::pose::pose_from_vector6(&r7.tool()),
    };
    let l7 = r7.limits();
    let tilt = JointLimits::new(-TILT_LIMIT_RAD, TILT_LIMIT_RAD);
    let mut limits = [
        tilt, tilt, tilt, tilt, tilt, l7[1], l7[2], l7[3], l7[4], l7[5], l7[6],
    ];
    if let Some(c) = column_at.and_then(|c| limits.get_mut(c)) {
        *c = l7[0];
    }
    let mut r9 = chain.to_robot(limits).map_err(err)?;
    for (k, &j) in order.iter().enumerate() {
        let kind = if j == 2 {
            JointKind::Prismatic
        } else {
            JointKind::Sensor
        };
        r9.set_joint_kind(k, kind).map_err(err)?;
    }
    // The model equals the URDF's chain with the tilts at zero.
    let q7 = [2.5, 0.3, -0.4, 0.5, 0.6, -0.7, 0.8];
    let mut q9 = [0.0, 0.0, 0.0, 0.0, 0.0, 0.3, -0.4, 0.5, 0.6, -0.7, 0.8];
    if let Some(c) = column_at.and_then(|c| q9.get_mut(c)) {
        *c = 2.5;
    }
    let (a, b) = (r7.fk_q(&q7).map_err(err)?, r9.fk_q(&q9).map_err(err)?);
    if (a.to_homogeneous() - b.to_homogeneous()).abs().max() > 1e-9 {
        return Err(CliError::input(
            "hilti: the 9-joint model differs from the URDF's chain at zero tilt",
        ));
    }
    Ok(RobotDescription {
        name: "trailblazer-tilt".into(),
        joint_names: names.iter().map(|s| (*s).to_string()).collect(),
        robot: AnyRobot::J11(r9),
    })
}

/// `kincal import-dataset hilti DIR`: every session's rows and the 11-joint model.
pub fn import(dir: &Path) -> Result<crate::datasets::Imported, CliError> {
    let urdf = dir.join("data/trailblazer.urdf");
    let robot = robot(&urdf)?;
    let mut set = measurement_set(dir)?;
    let mut files = vec![urdf.clone()];
    files.extend(
        SESSIONS
            .iter()
            .map(|(s, _)| dir.join("data/datasets").join(format!("{s}.yaml"))),
    );
    let mut comments = vec![
        " dataset: hilti-jaibot-stationing (imported by kincal import-dataset; licence CC BY-NC-SA \
         3.0, Hilti Research: non-commercial, share alike)"
            .to_string(),
    ];
    for f in &files {
        let name = f
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        comments.push(format!(
            " source: {name} (sha256 {})",
            crate::datasets::sha256_of(f)?
        ));
    }
    let notes = vec![
        "one session per floor (YAML file): the total station's frame is the session's, so each \
         session has its own base frame"
            .to_string(),
        "q1, q2: the base accelerometer's tilt about x, y [rad] (sensor joints); q3 the column \
         [m]; q4, q5: the column tip's tilt relative to the base (bending) about x, y [rad] \
         (sensor joints); q6..q11 the arm [rad]; tilt = (atan2(a_y, a_z), atan2(-a_x, a_z))"
            .to_string(),
        "x, y, z: the prism in the total station's frame (position only); temp_c as the set's \
         README states (21 C, outdoor 9 C), constant within a session"
            .to_string(),
    ];
    comments.push(
        " robot: trailblazer-tilt (trailblazer.urdf base_link -> prism, 4 sensor joints)".into(),
    );
    comments.extend(notes.iter().map(|n| format!(" note: {n}")));
    set.comments = comments;
    set.source = files[1].display().to_string();
    Ok(crate::datasets::Imported {
        set,
        robot,
        robot_comments: vec![
            " Hilti Trailblazer: the shipped trailblazer.urdf, chain base_link -> prism (the"
                .into(),
            " mimic column collapsed to one prismatic joint), with sensor joints for the base's"
                .into(),
            " tilt (before the column) and the column tip's bending (after it). Built by".into(),
            " kincal import-dataset hilti; the set is CC BY-NC-SA 3.0 and not copied.".into(),
        ],
        notes,
    })
}

/// One session: name, temperature [°C], rows.
pub type Session = (&'static str, f64, Vec<HiltiRow>);

/// Every session of the set, in [`SESSIONS`] order.
pub fn read_all(dir: &Path) -> Result<Vec<Session>, CliError> {
    SESSIONS
        .iter()
        .map(|&(s, t)| {
            let p = dir.join("data/datasets").join(format!("{s}.yaml"));
            Ok((s, t, read_session(&p)?))
        })
        .collect()
}

/// Extra columns written by the import.
pub const EXTRA_COLUMNS: [&str; 6] = [
    "extra_height_m",
    "extra_solution_space",
    "extra_kind",
    "extra_upside_down",
    "extra_base_tilt_x",
    "extra_base_tilt_y",
];

/// The measurement set of every session (rows in file order, sessions in [`SESSIONS`]
/// order).
pub fn measurement_set(dir: &Path) -> Result<MeasurementSet, CliError> {
    let mut rows = Vec::new();
    for (session, temp, rs) in read_all(dir)? {
        for r in rs {
            let [tx, ty] = HiltiRow::tilt(&r.base_accel);
            rows.push(MeasurementRow {
                line: 0,
                pose_id: Some(format!(
                    "{session}/{}/{}/{}{}",
                    r.height_m,
                    r.solution_space,
                    if r.evaluation { "e" } else { "s" },
                    r.id
                )),
                q_rad: r.q().to_vec(),
                position_m: Some(r.prism_m),
                orientation: None,
                point_m: None,
                approach: None,
                temp_c: Some(temp),
                extras: vec![
                    format!("{}", r.height_m),
                    format!("{}", r.solution_space),
                    (if r.evaluation {
                        "evaluation"
                    } else {
                        "stationing"
                    })
                    .into(),
                    format!("{}", u8::from(r.upside_down)),
                    format!("{tx}"),
                    format!("{ty}"),
                ],
                partial_m: None,
                target: None,
                plane: None,
                session: Some(session.to_string()),
            });
        }
    }
    Ok(MeasurementSet {
        source: dir.display().to_string(),
        comments: Vec::new(),
        n_joints: N,
        rows,
        extra_columns: EXTRA_COLUMNS.iter().map(|s| (*s).to_string()).collect(),
        orientation_form: None,
        has_position: true,
        has_point: false,
        has_target: false,
        has_plane: false,
        has_session: true,
        has_approach: false,
        has_temperature: true,
        sha256: String::new(),
        header_line: 0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir() -> Option<std::path::PathBuf> {
        let d = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../shared/realdata/hilti-jaibot-stationing");
        d.is_dir().then_some(d)
    }

    const TWO: &str =
        "joint_names: [column_prismatic_joint, dsr_joint1, dsr_joint2, dsr_joint3, dsr_joint4,
  dsr_joint5, dsr_joint6]
column_heights:
  1.98:
    solution_spaces:
      0:
        stationing_measurements:
        - id: 0
          time: 1.5
          upside_down: false
          doosan_cmd: [0.4, 0.0, 0.48]
          joint_states: [1.98, 0.1, 0.2,
            0.3, 0.4, 0.5, 0.6]
          prism_position: [7.0, 5.0, 1.0]
          tilt_sensor_base_accel: [0.0, 0.0981, 9.81]
          tilt_sensor_column_accel: [-0.0981, 0.0981, 9.81]
        evaluation_measurements:
        - id: 1
          time: 2.5
          upside_down: true
          doosan_cmd: [0.4, 0.0, 0.48]
          joint_states: [1.98, 0.1, 0.2, 0.3, 0.4, 0.5, 0.7]
          prism_position: [7.0, 5.0, 1.1]
          tilt_sensor_base_accel: [0.0, 0.0, 9.81]
          tilt_sensor_column_accel: [0.0, 0.0, 9.81]
";

    #[test]
    fn parses_the_layout_and_the_tilts() {
        let rows = parse_session(TWO, "t.yaml").unwrap();
        assert_eq!(rows.len(), 2);
        let (a, b) = (&rows[0], &rows[1]);
        assert!(!a.evaluation && b.evaluation && b.upside_down && !a.upside_down);
        assert_eq!((a.height_m, a.solution_space, a.line), (1.98, 0, 8));
        assert_eq!(a.joints, [1.98, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6]);
        // Base tilted about +x by atan(0.01); column additionally about +y by atan(0.01).
        let t = 0.01f64.atan();
        let q = a.q();
        assert!((q[0] - t).abs() < 1e-15 && q[1].abs() < 1e-15, "{q:?}");
        assert!(q[3].abs() < 1e-15 && (q[4] - t).abs() < 1e-15, "{q:?}");
        assert_eq!(q[2], 1.98);
    }

    /// The study's gains (`joint_scale@sensor`) are the scales of exactly the sensor joints.
    #[test]
    fn sensor_selector_picks_the_tilt_joints() {
        let Some(d) = dir() else { return };
        let desc = robot(&d.join("data/trailblazer.urdf")).unwrap();
        let AnyRobot::J11(r) = desc.robot else {
            panic!("11 joints")
        };
        let item = crate::effects_arg::parse_effect_item("joint_scale@sensor").unwrap();
        let c = crate::effects_arg::resolve(&[item], &desc.joint_names, &r.joint_kinds()).unwrap();
        assert_eq!(c.scale_joints, Some(SENSOR_JOINTS.to_vec()));
    }

    #[test]
    fn bad_input_names_the_line() {
        let bad = TWO.replace("[7.0, 5.0, 1.1]", "[7.0, x, 1.1]");
        let e = parse_session(&bad, "t.yaml").unwrap_err().to_string();
        assert!(
            e.contains("t.yaml:18") && e.contains("prism_position"),
            "{e}"
        );
        let bad = TWO.replace("0.5, 0.7]", "0.5]");
        let e = parse_session(&bad, "t.yaml").unwrap_err().to_string();
        assert!(e.contains("expected 7 numbers"), "{e}");
    }
}
