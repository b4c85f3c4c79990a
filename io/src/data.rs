//! Conversions between measurement-file rows and core types: joint states and measured
//! poses. No kinematics here: the rotation conventions live in `kincal::pose`.

use std::path::Path;

use kincal::identify::{ComponentMask, Measurement};
use kincal::pose::{pose_from_xyz_rpy, quaternion_to_matrix, transform};
use kincal::{Effect, EffectSet, JointState, Robot, Transform};
use nalgebra::Vector3;

use crate::error::Error as CliError;
use crate::measurements::{MeasurementRow, MeasurementSet, Orientation, ReadOptions};
use crate::model_file::PoseLabel;

/// How a command reads DATA.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DataOptions {
    /// The rows must carry measured poses (x, y, z at least).
    pub require_pose: bool,
    /// Accept joint readings outside the robot's limits.
    pub allow_out_of_limits: bool,
}

/// Reads DATA for `robot`: its joint count, its limits (unless allowed), and the auxiliary
/// columns the model's effects need (`effects`: those the command will use).
pub fn read<const N: usize>(
    path: &Path,
    robot: &Robot<N>,
    effects: EffectSet,
    opts: DataOptions,
) -> Result<MeasurementSet, CliError> {
    let set = crate::measurements::read_measurements(path, &read_options(robot, opts))?;
    require_inputs(&set, effects)?;
    Ok(set)
}

/// How [`read`] reads DATA for `robot`.
pub fn read_options<const N: usize>(robot: &Robot<N>, opts: DataOptions) -> ReadOptions {
    let mut ro = ReadOptions::new(N);
    ro.joint_limits = Some(robot.limits().iter().map(|l| (l.lower, l.upper)).collect());
    ro.allow_out_of_limits = opts.allow_out_of_limits;
    ro.require_pose = opts.require_pose;
    ro
}

/// [`read`] row by row for one-pass commands: `on_row` gets each checked row (after the
/// columns `effects` need were checked), and no row is kept, so memory does not grow with
/// the file. Returns the file's description (`rows` empty).
pub fn stream<const N: usize>(
    path: &Path,
    robot: &Robot<N>,
    effects: EffectSet,
    opts: DataOptions,
    mut on_row: impl FnMut(&MeasurementSet, MeasurementRow) -> Result<(), CliError>,
) -> Result<MeasurementSet, CliError> {
    let mut checked = false;
    crate::measurements::stream_measurements(path, &read_options(robot, opts), |set, row| {
        if !checked {
            require_inputs(set, effects)?;
            checked = true;
        }
        on_row(set, row)
    })
    .map_err(|e| match e {
        crate::measurements::StreamError::Input(e) => e.into(),
        crate::measurements::StreamError::Row(e) => e,
    })
}

/// Refuses data without the columns that `effects` need, naming the missing column.
pub fn require_inputs(set: &MeasurementSet, effects: EffectSet) -> Result<(), CliError> {
    let missing = |col: &str, effect: Effect, what: &str| {
        CliError::input(format!(
            "{}:{}: missing column '{col}': the {effect} effect needs {what}",
            set.source, set.header_line
        ))
    };
    if effects.contains(Effect::Backlash) && !set.has_approach {
        return Err(missing(
            "s1",
            Effect::Backlash,
            &format!("the approach directions s1..s{}", set.n_joints),
        ));
    }
    if effects.contains(Effect::Thermal) && !set.has_temperature {
        return Err(missing(
            "temp_c",
            Effect::Thermal,
            "the arm temperature in °C",
        ));
    }
    Ok(())
}

/// The joint state of a row (readings, approach directions, temperature).
pub fn joint_state<const N: usize>(row: &MeasurementRow) -> JointState<N> {
    let mut q = [0.0; N];
    for (d, s) in q.iter_mut().zip(&row.q_rad) {
        *d = *s;
    }
    let approach = row.approach.as_ref().map(|s| {
        let mut a = [0.0; N];
        for (d, v) in a.iter_mut().zip(s) {
            *d = f64::from(*v);
        }
        a
    });
    JointState {
        q,
        approach,
        temp_c: row.temp_c,
    }
}

/// The measured pose of a row and which components it carries; `None` without a position.
pub fn measured_pose(
    row: &MeasurementRow,
    source: &str,
) -> Result<Option<(Transform, ComponentMask)>, CliError> {
    if let (None, Some(c)) = (row.position_m, row.partial_m) {
        // Some coordinates only: the mask says which (spec: empty components).
        let mut mask = 0u8;
        let mut p = [0.0; 3];
        for (k, v) in c.iter().enumerate() {
            if let Some(v) = v {
                p[k] = *v;
                mask |= 1 << k;
            }
        }
        return Ok(Some((
            transform(
                nalgebra::Matrix3::identity(),
                Vector3::new(p[0], p[1], p[2]),
            ),
            ComponentMask(mask),
        )));
    }
    let Some(p) = row.position_m else {
        return Ok(None);
    };
    Ok(Some(match row.orientation {
        None => (
            transform(
                nalgebra::Matrix3::identity(),
                Vector3::new(p[0], p[1], p[2]),
            ),
            ComponentMask::POSITION,
        ),
        Some(Orientation::Rpy {
            roll_rad,
            pitch_rad,
            yaw_rad,
        }) => (
            pose_from_xyz_rpy(p, [roll_rad, pitch_rad, yaw_rad]),
            ComponentMask::ALL,
        ),
        Some(Orientation::Quaternion { w, x, y, z }) => {
            let r = quaternion_to_matrix(&[w, x, y, z]).map_err(|e| {
                CliError::input(format!(
                    "{source}:{}: column 'qw': {e}: expected a unit quaternion",
                    row.line
                ))
            })?;
            (
                transform(r, Vector3::new(p[0], p[1], p[2])),
                ComponentMask::ALL,
            )
        }
    }))
}

/// Every row as a core measurement (the set must have positions); `point_x/y/z` become
/// [`Measurement::point`].
pub fn measurements<const N: usize>(set: &MeasurementSet) -> Result<Vec<Measurement<N>>, CliError> {
    measurements_of_sessions(set, false)
}

/// [`measurements`], and with `several_sessions` rows of several sessions too, each still
/// in its own session's frame (the caller registers them, [`crate::session_frames`]).
pub fn measurements_of_sessions<const N: usize>(
    set: &MeasurementSet,
    several_sessions: bool,
) -> Result<Vec<Measurement<N>>, CliError> {
    let first = set.rows.first().map(FirstRow::of);
    set.rows
        .iter()
        .map(|row| pose_row(&set.source, row, first.as_ref(), several_sessions))
        .collect()
}

/// The session and line of a file's first data row: a pose row of another session is
/// refused against it.
struct FirstRow {
    session: Option<String>,
    line: u64,
}

impl FirstRow {
    fn of(row: &MeasurementRow) -> Self {
        FirstRow {
            session: row.session.clone(),
            line: row.line,
        }
    }
}

/// One row of `source` as a core measurement: refused when it is a contact row, has no
/// position, or (unless `several_sessions`) belongs to another session than `first`.
fn pose_row<const N: usize>(
    source: &str,
    row: &MeasurementRow,
    first: Option<&FirstRow>,
    several_sessions: bool,
) -> Result<Measurement<N>, CliError> {
    let first_session = first.and_then(|f| f.session.as_deref());
    if !several_sessions && row.session.as_deref() != first_session {
        return Err(CliError::input(format!(
            "{}:{}: column 'session': {}",
            source,
            row.line,
            crate::constraints::instrument_sessions_refused(
                first_session.unwrap_or(""),
                first.map_or(0, |f| f.line),
                row.session.as_deref().unwrap_or("")
            )
        )));
    }
    if let Some(id) = row.target.as_ref().or(row.plane.as_ref()) {
        let col = if row.target.is_some() {
            "target"
        } else {
            "plane"
        };
        return Err(CliError::input(format!(
            "{}:{}: column '{col}': contact row ({col} {id:?}) where this command \
             expects measured poses: expected x, y, z (contact rows are read by \
             calibrate, validate, crossval and predict)",
            source, row.line
        )));
    }
    let (pose, mask) = measured_pose(row, source)?.ok_or_else(|| {
        CliError::input(format!(
            "{}:{}: missing column 'x': expected measured poses (x, y, z)",
            source, row.line
        ))
    })?;
    Ok(Measurement {
        state: joint_state::<N>(row),
        pose,
        mask,
        weight: 1.0,
        point: row.point_m,
    })
}

/// Where each pose row sits in DATA: its line and `pose_id`, kept compactly (a line and a
/// label index per row, each label's text once per run of rows sharing it), so that a file
/// of a million rows costs ~30 bytes a row here, not a `MeasurementRow`'s ~450.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RowLabels {
    lines: Vec<u64>,
    /// Per row: index into `id_ends` of its label, [`NO_ID`] without one.
    id_of_row: Vec<usize>,
    /// End of each label in `ids` (a label starts where the previous one ends).
    id_ends: Vec<usize>,
    ids: String,
}

/// [`RowLabels::id_of_row`] of a row without `pose_id`.
const NO_ID: usize = usize::MAX;

impl RowLabels {
    /// Appends a row at `line` labelled `pose_id`.
    pub fn push(&mut self, line: u64, pose_id: Option<&str>) {
        self.lines.push(line);
        let Some(id) = pose_id else {
            self.id_of_row.push(NO_ID);
            return;
        };
        // Rows of one pose (several markers) are adjacent: their label is stored once.
        let last = self.id_ends.len().checked_sub(1);
        if let Some(k) = last.filter(|&k| self.id(k) == Some(id)) {
            self.id_of_row.push(k);
            return;
        }
        self.ids.push_str(id);
        self.id_ends.push(self.ids.len());
        self.id_of_row.push(self.id_ends.len() - 1);
    }

    /// The labels of every row of `set`.
    pub fn of_set(set: &MeasurementSet) -> Self {
        let mut labels = RowLabels::default();
        for r in &set.rows {
            labels.push(r.line, r.pose_id.as_deref());
        }
        labels
    }

    /// Label `k` (an index into `id_ends`).
    fn id(&self, k: usize) -> Option<&str> {
        let start = match k.checked_sub(1) {
            Some(p) => *self.id_ends.get(p)?,
            None => 0,
        };
        self.ids.get(start..*self.id_ends.get(k)?)
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.lines.len()
    }

    /// True without rows.
    pub fn is_empty(&self) -> bool {
        self.lines.is_empty()
    }

    /// 1-based line of the file where row `index` (zero-based) starts.
    pub fn line(&self, index: usize) -> Option<u64> {
        self.lines.get(index).copied()
    }

    /// `pose_id` of row `index`, if the file has that column.
    pub fn pose_id(&self, index: usize) -> Option<&str> {
        self.id(*self.id_of_row.get(index)?)
    }

    /// Line and `pose_id` of row `index`, as model files record them.
    pub fn label(&self, index: usize) -> Option<PoseLabel> {
        Some(PoseLabel {
            line: self.line(index)?,
            pose_id: self.pose_id(index).map(str::to_string),
        })
    }

    /// Robot poses among the rows (the rows of one session): rows sharing a `pose_id` are
    /// one pose, a row without one is a pose (as [`MeasurementSet::pose_count`]).
    pub fn pose_count(&self) -> usize {
        let unlabelled = self.id_of_row.iter().filter(|&&k| k == NO_ID).count();
        let mut labels: Vec<usize> = (0..self.id_ends.len()).collect();
        labels.sort_unstable_by(|&a, &b| self.id(a).cmp(&self.id(b)));
        labels.dedup_by(|a, b| self.id(*a) == self.id(*b));
        unlabelled + labels.len()
    }
}

/// DATA of a command on measured poses (`validate`, `calibrate`), read by
/// [`read_poses`].
#[derive(Debug, Clone)]
pub enum PoseFile<const N: usize> {
    /// Instrument rows: the core measurements and each row's label, nothing else per row;
    /// `set` describes the file (columns, source, SHA-256; its `rows` are empty).
    Poses {
        set: MeasurementSet,
        meas: Vec<Measurement<N>>,
        labels: RowLabels,
    },
    /// Contact (target/plane) rows, instrument rows in several sessions (one frame each), or
    /// every row when the caller asked to keep them: the whole file.
    Rows(MeasurementSet),
}

/// [`read`] and [`measurements`] in one pass for commands on measured poses: each row
/// becomes a core measurement and a compact label as it is read, and is dropped (issue #16
/// item 6: a million-row file must not be held as `MeasurementRow`s). Files with a
/// `target` or `plane` column keep their rows and come back as [`PoseFile::Rows`] when a
/// row is a contact or `keep_rows` asks for them. Errors come in the order of
/// [`read`] then [`measurements`]: the file's, then a missing column, then the first
/// row that is not a measured pose.
pub fn read_poses<const N: usize>(
    path: &Path,
    robot: &Robot<N>,
    effects: EffectSet,
    opts: DataOptions,
    keep_rows: bool,
) -> Result<PoseFile<N>, CliError> {
    let mut meas = Vec::new();
    let mut labels = RowLabels::default();
    let mut kept = Vec::new();
    let mut first: Option<FirstRow> = None;
    let mut refused: Option<CliError> = None;
    let streamed = crate::measurements::stream_measurements(
        path,
        &read_options(robot, opts),
        |set, row| -> Result<(), std::convert::Infallible> {
            if keep_rows || set.has_target || set.has_plane || set.has_session {
                kept.push(row);
                return Ok(());
            }
            if refused.is_some() {
                return Ok(());
            }
            let first = first.get_or_insert_with(|| FirstRow::of(&row));
            match pose_row::<N>(&set.source, &row, Some(first), false) {
                Ok(m) => {
                    meas.push(m);
                    labels.push(row.line, row.pose_id.as_deref());
                }
                Err(e) => refused = Some(e),
            }
            Ok(())
        },
    );
    let mut set = match streamed {
        Ok(set) => set,
        Err(crate::measurements::StreamError::Input(e)) => return Err(e.into()),
        Err(crate::measurements::StreamError::Row(never)) => match never {},
    };
    set.rows = kept;
    require_inputs(&set, effects)?;
    if let Some(e) = refused {
        return Err(e);
    }
    if keep_rows
        || crate::constraints::has_contacts(&set)
        || crate::constraints::has_instrument_sessions(&set)
    {
        return Ok(PoseFile::Rows(set));
    }
    if !set.rows.is_empty() {
        // Target/plane or session columns without a contact row or a second session:
        // poses after all.
        meas = measurements::<N>(&set)?;
        labels = RowLabels::of_set(&set);
        set.rows = Vec::new();
    }
    Ok(PoseFile::Poses { set, meas, labels })
}

/// Line of the file where pose `index` (zero-based row) starts.
pub fn line_of(set: &MeasurementSet, index: usize) -> Option<u64> {
    set.rows.get(index).map(|r| r.line)
}

#[cfg(test)]
mod tests {
    use super::*;

    const OPTS: DataOptions = DataOptions {
        require_pose: true,
        allow_out_of_limits: true,
    };

    fn file(text: &str) -> (tempfile::TempDir, std::path::PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.csv");
        std::fs::write(&path, text).unwrap();
        (dir, path)
    }

    fn read_both(text: &str) -> (MeasurementSet, PoseFile<6>) {
        let (_dir, path) = file(text);
        let robot = kincal::aria::nominal();
        let set = read(&path, &robot, EffectSet::NONE, OPTS).unwrap();
        let poses = read_poses::<6>(&path, &robot, EffectSet::NONE, OPTS, false).unwrap();
        (set, poses)
    }

    /// Poses of several markers (rows sharing a pose_id, not all adjacent), comments, blank
    /// lines and a record over two lines: the one-pass reader gives the same measurements,
    /// lines, labels and pose count as reading every row first.
    #[test]
    fn read_poses_equals_read_then_measurements() {
        let text = "# robot: aria\n\n\
            pose_id,q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz\n\
            a,0.1,0.2,0.3,0.4,0.5,0.6,0.5,0.1,0.3,1,0,0,0\n\
            a,0.1,0.2,0.3,0.4,0.5,0.6,0.5,0.1,0.31,1,0,0,0\n\n\
            \"b\nc\",0,0,0,0,0,0,0.4,0,0.2,0,1,0,0\n\
            a,0.1,0.2,0.3,0.4,0.5,0.6,0.5,0.12,0.3,1,0,0,0\n\
            d,-0.1,0.2,-0.3,0.4,-0.5,0.6,0.3,0.2,0.1,0.5,0.5,0.5,0.5\n";
        let (set, poses) = read_both(text);
        let PoseFile::Poses {
            set: desc,
            meas,
            labels,
        } = poses
        else {
            panic!("instrument rows read as contacts");
        };
        assert_eq!(meas, measurements::<6>(&set).unwrap());
        assert_eq!(labels, RowLabels::of_set(&set));
        assert_eq!(labels.len(), 5);
        for (i, r) in set.rows.iter().enumerate() {
            assert_eq!(labels.line(i), Some(r.line));
            assert_eq!(labels.pose_id(i), r.pose_id.as_deref());
            assert_eq!(labels.label(i).map(|l| l.pose_id), Some(r.pose_id.clone()));
        }
        assert_eq!(labels.line(5), None);
        assert_eq!(
            (0..5).map(|i| labels.line(i).unwrap()).collect::<Vec<_>>(),
            vec![4, 5, 7, 9, 10]
        );
        assert_eq!(labels.pose_id(2), Some("b\nc"));
        // a, "b\nc" and d.
        assert_eq!((labels.pose_count(), set.pose_count()), (3, 3));
        assert_eq!(
            (desc.sha256.clone(), desc.rows.len()),
            (set.sha256.clone(), 0)
        );
        assert_eq!(desc.header_line, set.header_line);
    }

    #[test]
    fn row_labels_count_poses_as_the_set_does() {
        let mut l = RowLabels::default();
        assert!(l.is_empty());
        assert_eq!(l.pose_count(), 0);
        for (line, id) in [(2, Some("x")), (3, Some("y")), (4, Some("x")), (5, None)] {
            l.push(line, id);
        }
        l.push(6, None);
        l.push(7, Some(""));
        l.push(8, Some(""));
        // x, y, "" and two rows without a label.
        assert_eq!(l.pose_count(), 5);
        assert_eq!(l.pose_id(2), Some("x"));
        assert_eq!(l.pose_id(3), None);
        assert_eq!(l.pose_id(6), Some(""));
        assert_eq!(l.line(4), Some(6));
    }

    /// The first error is the one `read` then `measurements` gives: a refused row (another
    /// session) comes after an unreadable later row, and before nothing else.
    #[test]
    fn read_poses_reports_errors_in_read_order() {
        let head = "q1,q2,q3,q4,q5,q6,x,y,z,session\n";
        let row = "0,0,0,0,0,0,0.4,0,0.2";
        let robot = kincal::aria::nominal();
        let err = |text: &str| {
            let (_dir, path) = file(text);
            let one = read(&path, &robot, EffectSet::NONE, OPTS)
                .and_then(|s| measurements::<6>(&s).map(|_| ()))
                .unwrap_err();
            let two = read_poses::<6>(&path, &robot, EffectSet::NONE, OPTS, false).unwrap_err();
            assert_eq!(
                one.message.replace(&*path.display().to_string(), "D"),
                two.message.replace(&*path.display().to_string(), "D")
            );
            two.message
        };
        let e = err(&format!(
            "{head}{row},s1\n{row},s2\n{row},s1\n0,x,0,0,0,0,0,0,0,s1\n"
        ));
        assert!(e.contains(":5:") && e.contains("q2"), "{e}");
        // Instrument rows in several sessions come back whole: the session-frame path
        // checks their rules (a session that resumes is refused there, naming its line).
        let (_d, path) = file(&format!("{head}{row},s1\n{row},s2\n{row},s1\n"));
        let got = read_poses::<6>(&path, &robot, EffectSet::NONE, OPTS, false).unwrap();
        assert!(matches!(&got, PoseFile::Rows(s) if s.rows.len() == 3));
        // One session: poses after all.
        let (_d, path) = file(&format!("{head}{row},s1\n{row},s1\n"));
        let got = read_poses::<6>(&path, &robot, EffectSet::NONE, OPTS, false).unwrap();
        assert!(matches!(&got, PoseFile::Poses { meas, .. } if meas.len() == 2));
        // The missing column of an effect comes before a refused row.
        let (_dir, path) = file(&format!("{head}{row},s1\n{row},s2\n"));
        let e = read_poses::<6>(
            &path,
            &robot,
            EffectSet::NONE.with(kincal::Effect::Thermal),
            OPTS,
            false,
        )
        .unwrap_err();
        assert!(e.message.contains("temp_c"), "{}", e.message);
    }

    #[test]
    fn contact_rows_and_kept_rows_come_back_whole() {
        let text = "q1,q2,q3,q4,q5,q6,x,y,z,target\n\
            0,0,0,0,0,0,,,,t1\n0.1,0,0,0,0,0,,,,t1\n0,0.1,0,0,0,0,0.4,0,0.2,\n";
        let (_dir, path) = file(text);
        let robot = kincal::aria::nominal();
        let got = read_poses::<6>(&path, &robot, EffectSet::NONE, OPTS, false).unwrap();
        assert!(matches!(&got, PoseFile::Rows(s) if s.rows.len() == 3));
        // A target column without a contact row: poses after all.
        let text = "q1,q2,q3,q4,q5,q6,x,y,z,target\n0,0.1,0,0,0,0,0.4,0,0.2,\n";
        let (_d2, path) = file(text);
        let got = read_poses::<6>(&path, &robot, EffectSet::NONE, OPTS, false).unwrap();
        assert!(
            matches!(&got, PoseFile::Poses { meas, labels, set } if meas.len() == 1 && labels.line(0) == Some(2) && set.rows.is_empty())
        );
        // Kept when asked (--constraints).
        let got = read_poses::<6>(&path, &robot, EffectSet::NONE, OPTS, true).unwrap();
        assert!(matches!(&got, PoseFile::Rows(s) if s.rows.len() == 1));
    }
}
