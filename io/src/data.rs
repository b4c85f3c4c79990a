//! Conversions between measurement-file rows and core types: joint states and measured
//! poses. No kinematics here: the rotation conventions live in `kincal::pose`.

use std::path::Path;

use kincal::identify::{ComponentMask, Measurement};
use kincal::pose::{pose_from_xyz_rpy, quaternion_to_matrix, transform};
use kincal::{Effect, EffectSet, JointState, Robot, Transform};
use nalgebra::Vector3;

use crate::error::Error as CliError;
use crate::measurements::{MeasurementRow, MeasurementSet, Orientation, ReadOptions};

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
    let first = set.rows.first();
    let first_session = first.and_then(|r| r.session.as_deref());
    set.rows
        .iter()
        .map(|row| {
            if !several_sessions && row.session.as_deref() != first_session {
                return Err(CliError::input(format!(
                    "{}:{}: column 'session': {}",
                    set.source,
                    row.line,
                    crate::constraints::instrument_sessions_refused(
                        first_session.unwrap_or(""),
                        first.map_or(0, |r| r.line),
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
                    set.source, row.line
                )));
            }
            let (pose, mask) = measured_pose(row, &set.source)?.ok_or_else(|| {
                CliError::input(format!(
                    "{}:{}: missing column 'x': expected measured poses (x, y, z)",
                    set.source, row.line
                ))
            })?;
            Ok(Measurement {
                state: joint_state::<N>(row),
                pose,
                mask,
                weight: 1.0,
                point: row.point_m,
            })
        })
        .collect()
}

/// Line of the file where pose `index` (zero-based row) starts.
pub fn line_of(set: &MeasurementSet, index: usize) -> Option<u64> {
    set.rows.get(index).map(|r| r.line)
}
