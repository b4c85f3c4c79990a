//! The held-out error of a model on instrument rows in several sessions (docs/constraints.md,
//! "Sessions with instrument rows"). A session measured in a frame of its own says nothing
//! about where that frame is, so the honest error of a model on it is the error after
//! fitting that session's rigid frame only (6 parameters, no model parameter): core's
//! [`fit_session_frame`], the inner fit calibrate eliminates by a Schur complement, with
//! unit weights on metres and radians. `kincal validate` (its per-session table and the
//! per-pose errors) and `kincal crossval --group-by session` (and Python's
//! `kincal.crossval`, through [`crate::crossval_contacts`]) score through here.

use kincal::identify::{
    Algorithm, IdentifyOptions, MIN_FRAME_ROWS, Measurement, fit_session_frame,
};
use kincal::validation::{ErrorSummary, PoseErrors};
use kincal::{ParamSet, Robot, Transform};

use crate::constraints::ContactData;

/// How the first session (its instrument rows in the robot's base frame by the file's
/// convention) is scored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BaseSession {
    /// In the robot's base frame, as the file says (`validate`: the model's base is judged).
    InBaseFrame,
    /// After fitting its frame too (`crossval`: a held-out first session is not seen by the
    /// training rows, whose later sessions have frames of their own, so nothing fixes the
    /// base it would be judged in).
    FitFrame,
}

/// A model's errors on the active (positive-weight) instrument rows of one session.
#[derive(Debug, Clone)]
pub struct SessionScore {
    /// The session id.
    pub session: String,
    /// Its instrument rows `start..start + len` in [`ContactData::instrument`].
    pub start: usize,
    pub len: usize,
    /// Scored rows (positive weight).
    pub rows: usize,
    /// The fitted frame (robot base → the session's measuring frame); `None`: scored in the
    /// robot's base frame.
    pub frame: Option<Transform>,
    /// Errors after the frame (measured − frame·model), per kind over the rows measuring it.
    pub summary: ErrorSummary,
    /// Mean |e_p| \[m\] over the rows measuring a position component.
    pub mean_pos_m: f64,
}

/// The options of every session-frame fit here: OLS weights (1 per metre and per radian,
/// exact orientation error), no model parameter.
#[must_use]
pub fn frame_options() -> IdentifyOptions<'static> {
    IdentifyOptions::new(Algorithm::Ols, ParamSet::new())
}

/// The errors of `m` at `robot`, measured in `frame` when given (measured − frame·model,
/// in that frame), components `m` does not measure zero.
pub fn pose_errors<const N: usize>(
    robot: &Robot<N>,
    m: &Measurement<N>,
    frame: Option<&Transform>,
) -> Result<PoseErrors, kincal::Error> {
    let t = m.model_pose(robot)?;
    let t = frame.map_or(t, |f| f * t);
    Ok(PoseErrors::between(&m.pose, &t).masked(m.mask))
}

/// Every instrument session of `cd` scored at `robot`: first the base session (the rows
/// outside every framed session, named `cd.base_session`), then each framed session in
/// order; a session with no active row comes back with `rows == 0` and no frame, and so
/// does a base session to be fitted with fewer than [`MIN_FRAME_ROWS`] active rows (a
/// first session of mostly contact rows: its few instrument rows fix no frame, they are
/// not scored; later sessions are held to that minimum when the data are read). Errors:
/// the instrument index of the session's first row with core's error (a frame the active
/// rows do not fix, kinematics).
pub fn score_sessions<const N: usize>(
    robot: &Robot<N>,
    cd: &ContactData<N>,
    base: BaseSession,
) -> Result<Vec<SessionScore>, (usize, kincal::Error)> {
    let base_end = cd.sessions.first().map_or(cd.instrument.len(), |s| s.start);
    let base_name = cd.base_session.clone().unwrap_or_default();
    // (session, start, len, whether its frame is fitted, whether it is the base session)
    let fit_base = base == BaseSession::FitFrame;
    let runs = std::iter::once((base_name, 0, base_end, fit_base, true)).chain(
        cd.sessions
            .iter()
            .zip(&cd.session_names)
            .map(|(s, n)| (n.clone(), s.start, s.len, true, false)),
    );
    let opts = frame_options();
    let mut out = Vec::with_capacity(cd.sessions.len() + 1);
    for (session, start, len, fit, is_base) in runs {
        let rows = cd.instrument.get(start..start + len).unwrap_or(&[]);
        let mut active = rows.iter().filter(|m| m.weight > 0.0).count();
        if fit && is_base && active < MIN_FRAME_ROWS {
            active = 0;
        }
        let frame = if fit && active > 0 {
            Some(fit_session_frame(robot, rows, &opts).map_err(|e| (start, e))?)
        } else {
            None
        };
        let (mut summary, mut sum_pos, mut n_pos) = (ErrorSummary::default(), 0.0, 0usize);
        let scored = rows
            .iter()
            .enumerate()
            .filter(|(_, m)| active > 0 && m.weight > 0.0);
        for (k, m) in scored {
            let e = pose_errors(robot, m, frame.as_ref()).map_err(|e| (start + k, e))?;
            summary.add_measured(&e, m.mask);
            if (0..3).any(|c| m.mask.has(c)) {
                sum_pos += e.pos_norm_m;
                n_pos += 1;
            }
        }
        out.push(SessionScore {
            session,
            start,
            len,
            rows: active,
            frame,
            summary,
            mean_pos_m: sum_pos / n_pos.max(1) as f64,
        });
    }
    Ok(out)
}

/// The index into [`score_sessions`]'s result of the session of every instrument row of
/// `cd` (0: the base session).
#[must_use]
pub fn session_of_instrument_rows<const N: usize>(cd: &ContactData<N>) -> Vec<usize> {
    let mut of = vec![0; cd.instrument.len()];
    for (k, s) in cd.sessions.iter().enumerate() {
        for v in of.iter_mut().skip(s.start).take(s.len) {
            *v = k + 1;
        }
    }
    of
}

#[cfg(test)]
mod tests {
    use super::*;
    use kincal::aria;
    use kincal::identify::{ComponentMask, InstrumentSession};
    use kincal::pose::pose_from_vector6;

    /// Positions of ARIA's tool by the nominal model: `base` rows in the base frame, then
    /// six in `frame`.
    fn data(base: usize, frame: &Transform) -> ContactData<6> {
        let robot = aria::nominal();
        let row = |k: usize, f: &Transform| {
            let mut q = aria::TOOL_SEED_Q;
            for (j, v) in q.iter_mut().enumerate() {
                *v += 0.5 * (1.3 * k as f64 + 2.1 * j as f64).sin();
            }
            let mut m = Measurement::new(q, Transform::identity());
            m.mask = ComponentMask::POSITION;
            m.pose = f * m.model_pose(&robot).unwrap();
            m
        };
        let mut instrument: Vec<_> = (0..base).map(|k| row(k, &Transform::identity())).collect();
        instrument.extend((0..6).map(|k| row(10 + k, frame)));
        ContactData {
            instrument_rows: (0..instrument.len()).collect(),
            instrument,
            contacts: Vec::new(),
            contact_rows: Vec::new(),
            groups: Vec::new(),
            info: Vec::new(),
            distances: Vec::new(),
            distance_specs: Vec::new(),
            file: None,
            sessions: vec![InstrumentSession {
                start: base,
                len: 6,
            }],
            session_names: vec!["b".into()],
            base_session: Some("a".into()),
        }
    }

    #[test]
    fn a_base_session_too_small_for_a_frame_is_left_unscored_when_frames_are_fitted() {
        let frame = pose_from_vector6(&[0.3, -1.0, 0.2, 0.4, 0.1, -0.7]);
        let robot = aria::nominal();
        let cd = data(2, &frame);
        let fitted = score_sessions(&robot, &cd, BaseSession::FitFrame).unwrap();
        assert_eq!((fitted[0].rows, fitted[0].summary.count), (0, 0));
        assert!(fitted[0].frame.is_none());
        let got = fitted[1].frame.unwrap();
        let gap = (got.inverse() * frame).translation.vector.norm();
        assert!(
            gap < 1e-12 && fitted[1].summary.rms_pos_m() < 1e-12,
            "{gap}"
        );
        // In the base frame the two rows are scored as they are (exact: zero error).
        let inbase = score_sessions(&robot, &cd, BaseSession::InBaseFrame).unwrap();
        assert_eq!((inbase[0].rows, inbase[0].summary.count), (2, 2));
        assert!(inbase[0].summary.max_pos_m < 1e-15);
        // Three rows fix the base session's frame: scored after its fit.
        let cd = data(3, &frame);
        let fitted = score_sessions(&robot, &cd, BaseSession::FitFrame).unwrap();
        assert_eq!(fitted[0].rows, 3);
        assert!(fitted[0].frame.is_some());
        assert_eq!(session_of_instrument_rows(&cd), [0, 0, 0, 1, 1, 1, 1, 1, 1]);
    }
}
