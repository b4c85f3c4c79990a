//! The diagnosis of multi-session data (a `session` column naming several set-ups, e.g.
//! total-station stationings): each session's rows registered into the robot's base frame
//! ([`crate::session_frames`]), and the report's data on what is confounded with the
//! sessions (REPORT.json's `sessions`, `verdict.confounded_with_sessions`,
//! `verdict.separate_by`). The core's `kincal::diagnosis::sessions` decides the confounding;
//! front ends word it.

use kincal::diagnosis::{self, Config, Diagnosis};
use kincal::identify::Measurement;
use kincal::{Effect, EffectSet, Robot, Transform};
use serde::Serialize;

use crate::data;
use crate::error::{Error, core_error};
use crate::measurements::MeasurementSet;

/// How the sessions are handled, as REPORT.json's `sessions.method` and the readable report
/// say it.
pub const SESSIONS_METHOD: &str = "each session's rows registered into the robot's base frame by the rigid fit of the model's points to the measured ones, alternating 3 rounds with the geometric calibration; the frames are fitted on all rows (not refitted per fold); a candidate is confounded with the sessions when every effect column lies in the span of the geometric and per-session base-frame columns, or its input (temp_c, s1..sN) is constant within every session, both at sin θ ≤ 0.1";

/// Rows of several sessions, each registered into the robot's base frame.
#[derive(Debug, Clone)]
pub struct Sessions<const N: usize> {
    /// Session names in order of first appearance.
    pub names: Vec<String>,
    /// Per row: its session's index into `names`.
    pub index: Vec<u16>,
    /// The rows in the robot's base frame.
    pub data: Vec<Measurement<N>>,
    /// Per session: robot base → the session's measuring frame.
    pub frames: Vec<Transform>,
}

/// With a `session` column naming two sessions or more: every session's rows registered
/// into the robot's base frame; `None` for one session. Errors (bad input, naming the file
/// and line): more sessions than the core handles, a session with fewer than 3 rows.
pub fn session_frames<const N: usize>(
    robot: &Robot<N>,
    set: &MeasurementSet,
    cfg: &Config,
) -> Result<Option<Sessions<N>>, Error> {
    let Some((names, index)) = crate::session_frames::sessions(set) else {
        return Ok(None);
    };
    if names.len() > diagnosis::MAX_SESSIONS {
        return Err(Error::input(format!(
            "{}: column 'session': {} sessions, the diagnosis handles at most {}",
            set.source,
            names.len(),
            diagnosis::MAX_SESSIONS
        )));
    }
    for (k, name) in names.iter().enumerate() {
        let rows: Vec<usize> = (0..index.len())
            .filter(|&l| usize::from(index[l]) == k)
            .collect();
        if rows.len() < 3 {
            return Err(Error::input(format!(
                "{}:{}: column 'session': session {name:?} has {} row(s): each session's base frame is fitted to its rows, which needs at least 3 positions",
                set.source,
                rows.first()
                    .and_then(|&l| data::line_of(set, l))
                    .unwrap_or(0),
                rows.len()
            )));
        }
    }
    let raw = data::measurements_of_sessions::<N>(set, true)?;
    // The noise only sets the rigid fit's collinearity test.
    let sigma = cfg.sigma_pos_m.unwrap_or(1e-3);
    let r = crate::session_frames::register(robot, &raw, &index, names.len(), sigma)
        .map_err(|e| core_error(e, &set.source, |i| data::line_of(set, i)))?;
    Ok(Some(Sessions {
        names,
        index,
        data: r.data,
        frames: r.frames,
    }))
}

impl<const N: usize> Sessions<N> {
    /// Rows of session `k`.
    pub fn rows(&self, k: usize) -> usize {
        self.index.iter().filter(|&&s| usize::from(s) == k).count()
    }

    /// REPORT.json's `sessions`.
    pub fn json(&self) -> SessionsJson {
        SessionsJson {
            count: self.names.len(),
            frames: self
                .names
                .iter()
                .zip(&self.frames)
                .enumerate()
                .map(|(k, (name, f))| {
                    let t = &f.translation.vector;
                    SessionFrameJson {
                        session: name.clone(),
                        rows: self.rows(k),
                        translation_mm: [t.x * 1e3, t.y * 1e3, t.z * 1e3],
                        rotation_deg: f.rotation.angle().to_degrees(),
                    }
                })
                .collect(),
            method: SESSIONS_METHOD,
        }
    }
}

/// REPORT.json's `sessions`: several sessions, each registered in its own base frame.
#[derive(Debug, Clone, Serialize)]
pub struct SessionsJson {
    pub count: usize,
    /// Per session: name, rows, the registered frame (robot base → session frame).
    pub frames: Vec<SessionFrameJson>,
    pub method: &'static str,
}

#[derive(Debug, Clone, Serialize)]
pub struct SessionFrameJson {
    pub session: String,
    pub rows: usize,
    pub translation_mm: [f64; 3],
    pub rotation_deg: f64,
}

/// The single effects confounded with the sessions (pairs inherit it from them).
pub fn session_confounded<const N: usize>(d: &Diagnosis<N>) -> EffectSet {
    d.candidates()
        .iter()
        .filter(|c| c.effects.len() == 1 && c.evaluated && c.session.confounded())
        .fold(EffectSet::NONE, |acc, c| {
            c.effects.iter().fold(acc, EffectSet::with)
        })
}

/// What data would separate the session-confounded candidates from the sessions (`None`
/// when none is confounded).
pub fn separate_by<const N: usize>(d: &Diagnosis<N>) -> Option<String> {
    let single = |e: Effect| {
        d.candidates()
            .iter()
            .find(|c| c.effects == EffectSet::of(e) && c.session.confounded())
    };
    let mut out = Vec::new();
    if single(Effect::Thermal).is_some_and(|c| c.session.input_constant) {
        out.push("for thermal: two temperatures within one session (the robot warming up or cooling down during one set-up), or two sessions at different temperatures in the same set-up (same floor, same instrument stationing)".to_string());
    }
    if single(Effect::Backlash).is_some_and(|c| c.session.input_constant) {
        out.push("for backlash: both approach directions within one session".to_string());
    }
    let spanned: Vec<&str> = d
        .candidates()
        .iter()
        .filter(|c| c.effects.len() == 1 && c.session.columns_in_span)
        .flat_map(|c| c.effects.iter().map(|e| e.name()))
        .collect();
    if !spanned.is_empty() {
        out.push(format!(
            "for {}: one session (one base frame) over the poses that excite it",
            spanned.join(", ")
        ));
    }
    (!out.is_empty()).then(|| out.join("; "))
}
