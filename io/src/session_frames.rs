//! One base frame per session for instrument rows (a `session` column: each set-up, e.g. a
//! total-station stationing, measures in its own frame), for the commands whose core has
//! one base frame (the diagnosis).
//!
//! Each session's rows are re-expressed in the robot's base frame by the rigid transform
//! that best maps the model's predicted points onto the measured ones (least squares over
//! the session's positions, [`kincal::registration::weighted_rigid_fit`]). The model is the
//! geometric calibration on the registered rows of all sessions, and the two alternate a
//! few rounds (the frames and the geometry converge together; the first round uses the
//! robot description). What the diagnosis then judges is the geometry and the candidate
//! effects *given* these frames: the frames are fitted on all rows, not refitted per
//! fold (6 parameters per session against hundreds of rows: their leverage on a held-out
//! row is small, and it is stated in the report).

use kincal::identify::{Algorithm, IdentifyOptions, Measurement, identify};
use kincal::registration::weighted_rigid_fit;
use kincal::{Robot, Transform};

use crate::measurements::MeasurementSet;

/// Alternations of registration and geometric calibration (the third changes the frames by
/// micrometres on the Hilti set).
pub const ROUNDS: usize = 3;

/// The sessions of a measurement set: names in order of first appearance and each row's
/// index into them. `None` when the rows carry fewer than two distinct sessions.
pub fn sessions(set: &MeasurementSet) -> Option<(Vec<String>, Vec<u16>)> {
    let mut names: Vec<String> = Vec::new();
    let mut index = Vec::with_capacity(set.rows.len());
    for row in &set.rows {
        let name = row.session.clone().unwrap_or_default();
        let k = match names.iter().position(|n| *n == name) {
            Some(k) => k,
            None => {
                names.push(name);
                names.len() - 1
            }
        };
        index.push(u16::try_from(k).ok()?);
    }
    (names.len() > 1).then_some((names, index))
}

/// The registered rows, the geometric model they were registered with, and per session the
/// transform `T_s` (robot base frame → the session's measuring frame).
#[derive(Debug, Clone)]
pub struct Registered<const N: usize> {
    /// The rows in the robot's base frame (`T_s⁻¹ · pose`).
    pub data: Vec<Measurement<N>>,
    /// The geometric calibration of the last round.
    pub geometric: Robot<N>,
    /// Per session, robot base → measuring frame.
    pub frames: Vec<Transform>,
}

/// Registers every session's rows into `robot`'s base frame, alternating with the geometric
/// calibration ([`ROUNDS`] rounds, rows weighted equally, `sigma_m` the position noise used
/// by the rigid fit's collinearity test). Sessions need three non-collinear points.
pub fn register<const N: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    index: &[u16],
    n_sessions: usize,
    sigma_m: f64,
) -> kincal::Result<Registered<N>> {
    let mut opts = IdentifyOptions::new(Algorithm::Ols, robot.geometric_param_set());
    opts.allow_data_deficiency = true;
    register_with(robot, data, index, n_sessions, sigma_m, &opts)
}

/// [`register`] with the calibration between the registrations run with `opts` (its
/// parameter set: the geometry plus effects, e.g. sensor joints' gains; its iteration limit
/// and tolerances: a study's own).
pub fn register_with<const N: usize>(
    robot: &Robot<N>,
    data: &[Measurement<N>],
    index: &[u16],
    n_sessions: usize,
    sigma_m: f64,
    opts: &IdentifyOptions<'_>,
) -> kincal::Result<Registered<N>> {
    let mut ws = crate::calibration::new_workspace();
    let mut model = *robot;
    let mut out = data.to_vec();
    let mut frames = vec![Transform::identity(); n_sessions];
    for round in 0..ROUNDS {
        for (s, frame) in frames.iter_mut().enumerate() {
            let rows: Vec<usize> = (0..data.len())
                .filter(|&l| index.get(l).is_some_and(|&k| usize::from(k) == s))
                .collect();
            let design = rows
                .iter()
                .map(|&l| Ok(point(&data[l].model_pose(&model)?)))
                .collect::<kincal::Result<Vec<_>>>()?;
            let measured: Vec<[f64; 3]> = rows.iter().map(|&l| point(&data[l].pose)).collect();
            *frame = weighted_rigid_fit(&design, &measured, &vec![1.0; rows.len()], sigma_m)?;
            let inv = frame.inverse();
            for &l in &rows {
                out[l].pose = inv * data[l].pose;
            }
        }
        if round + 1 < ROUNDS {
            model = identify(robot, &out, opts, &mut ws)?.robot;
        }
    }
    Ok(Registered {
        data: out,
        geometric: model,
        frames,
    })
}

fn point(t: &Transform) -> [f64; 3] {
    let v = t.translation.vector;
    [v.x, v.y, v.z]
}

#[cfg(test)]
mod tests {
    use super::*;
    use kincal::aria::nominal as aria;
    use kincal::pose::pose_from_vector6;

    /// Two sessions measured in frames shifted by metres and turned: after registration
    /// every row agrees with the robot's own prediction.
    #[test]
    fn registration_recovers_each_sessions_frame() {
        let robot = aria();
        let frames = [
            pose_from_vector6(&[1.0, -2.0, 0.5, 0.1, -0.2, 0.3]),
            pose_from_vector6(&[-3.0, 0.5, 0.2, -0.4, 0.1, 1.2]),
        ];
        let mut data = Vec::new();
        let mut index = Vec::new();
        for k in 0..40 {
            let x = f64::from(k) * 0.37;
            let q = [
                x.sin(),
                0.5 * x.cos(),
                0.3 + 0.2 * x.sin(),
                x,
                -x * 0.5,
                0.2,
            ];
            let t = robot.fk(&kincal::JointState::new(q)).unwrap();
            let s = k % 2;
            data.push(Measurement::new(q, frames[s as usize] * t));
            index.push(s);
        }
        let r = register(&robot, &data, &index, 2, 1e-4).unwrap();
        for (m, orig) in r.data.iter().zip(&data) {
            let t = orig.model_pose(&robot).unwrap();
            assert!((m.pose.translation.vector - t.translation.vector).norm() < 1e-9);
        }
        for (f, want) in r.frames.iter().zip(&frames) {
            assert!((f.translation.vector - want.translation.vector).norm() < 1e-9);
        }
    }
}
