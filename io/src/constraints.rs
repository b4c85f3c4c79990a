//! Instrument-free data for the commands (docs/constraints.md): the constraints file
//! (`--constraints FILE`, TOML: `[[distance]]`, `[[target]]`, `[[plane]]`) and the
//! conversion of a measurement set with `target`, `plane` and `session` rows into the core's
//! [`ConstraintData`]. Every refusal names the file, the line and the column.

use std::collections::HashMap;
use std::path::Path;

use kincal::Transform;
use kincal::identify::{
    ConstraintData, Contact, Distance, Group, GroupKind, IdentifyOptions, InstrumentSession,
    MIN_FRAME_ROWS, Measurement, RowRole, SessionFault, SessionLayout, SessionScratch,
    check_sessions, group_estimate,
};
use kincal::{Error, Robot};
use serde::Deserialize;
use toml::Spanned;

use crate::error::Error as CliError;
use crate::measurements::{MeasurementRow, MeasurementSet};
use crate::model_file::{ConstraintsJson, DistanceJson, GroupJson};

/// A session needs at least this many rows (core's rule, shared with the C ABI).
pub use kincal::identify::MIN_SESSION_ROWS;
/// Plane contacts below this aspect are collinear (core's rule, shared with the C ABI).
pub use kincal::identify::USABLE_PLANE_MIN_ASPECT as CLI_PLANE_MIN_ASPECT;
/// An unknown plane needs at least this many contacts (three define it; only the fourth
/// and later say anything about the robot).
pub const MIN_PLANE_CONTACTS: usize = GroupKind::Plane.min_contacts();

/// A known distance of the constraints file.
#[derive(Debug, Clone, PartialEq)]
pub struct DistanceSpec {
    pub between: [String; 2],
    pub m: f64,
    pub sigma_m: Option<f64>,
    /// 1-based line of the entry.
    pub line: usize,
}

/// A known target of the constraints file.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetSpec {
    pub id: String,
    pub xyz_m: [f64; 3],
    pub line: usize,
}

/// A known plane of the constraints file (`normal·p = offset_m`, normal normalised).
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneSpec {
    pub id: String,
    pub normal: [f64; 3],
    pub offset_m: f64,
    pub line: usize,
}

/// A parsed constraints file.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ConstraintsFile {
    /// As given (for messages).
    pub path: String,
    pub sha256: String,
    pub distances: Vec<DistanceSpec>,
    pub targets: Vec<TargetSpec>,
    pub planes: Vec<PlaneSpec>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    #[serde(default)]
    distance: Vec<Spanned<RawDistance>>,
    #[serde(default)]
    target: Vec<Spanned<RawTarget>>,
    #[serde(default)]
    plane: Vec<Spanned<RawPlane>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDistance {
    between: Spanned<Vec<String>>,
    m: Spanned<f64>,
    #[serde(default)]
    sigma_m: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTarget {
    id: Spanned<String>,
    xyz_m: Spanned<Vec<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPlane {
    id: Spanned<String>,
    normal: Spanned<Vec<f64>>,
    offset_m: Spanned<f64>,
}

/// 1-based line of byte offset `at` in `text`.
fn line_at(text: &str, at: usize) -> usize {
    text.as_bytes()
        .iter()
        .take(at)
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Reads and checks a constraints file.
pub fn read_constraints(path: &Path) -> Result<ConstraintsFile, CliError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path)
        .map_err(|e| CliError::input(format!("{name}: cannot read the constraints file: {e}")))?;
    let text = String::from_utf8(bytes)
        .map_err(|e| CliError::input(format!("{name}: not UTF-8 text ({e})")))?;
    let mut c = parse_constraints(&text, &name)?;
    use sha2::Digest;
    c.sha256 = sha2::Sha256::digest(text.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    Ok(c)
}

/// Parses constraints TOML; `name` is the file name in messages.
pub fn parse_constraints(text: &str, name: &str) -> Result<ConstraintsFile, CliError> {
    let at = |span: std::ops::Range<usize>, key: &str, why: String| {
        CliError::input(format!(
            "{name}:{}: key '{key}': {why}",
            line_at(text, span.start)
        ))
    };
    let raw: RawFile = toml::from_str(text).map_err(|e| {
        let line = e
            .span()
            .map_or(String::new(), |s| format!(":{}", line_at(text, s.start)));
        CliError::input(format!(
            "{name}{line}: {} (expected [[distance]] between/m/sigma_m, [[target]] id/xyz_m, \
             [[plane]] id/normal/offset_m)",
            e.message().trim_end()
        ))
    })?;
    let mut out = ConstraintsFile {
        path: name.to_string(),
        ..ConstraintsFile::default()
    };
    let finite = |v: &Spanned<f64>, key: &str| {
        if v.get_ref().is_finite() {
            Ok(*v.get_ref())
        } else {
            Err(at(v.span(), key, "expected a finite number".into()))
        }
    };
    let id_of = |v: &Spanned<String>| {
        let id = v.get_ref().trim();
        if id.is_empty() {
            Err(at(v.span(), "id", "expected a non-empty id".into()))
        } else {
            Ok(id.to_string())
        }
    };
    let vec3 = |v: &Spanned<Vec<f64>>, key: &str| -> Result<[f64; 3], CliError> {
        match v.get_ref().as_slice() {
            [x, y, z] if [x, y, z].iter().all(|c| c.is_finite()) => Ok([*x, *y, *z]),
            _ => Err(at(
                v.span(),
                key,
                "expected three finite numbers [x, y, z]".into(),
            )),
        }
    };
    for d in &raw.distance {
        let line = line_at(text, d.span().start);
        let r = d.get_ref();
        let between = match r.between.get_ref().as_slice() {
            [a, b] if !a.trim().is_empty() && !b.trim().is_empty() && a.trim() != b.trim() => {
                [a.trim().to_string(), b.trim().to_string()]
            }
            _ => {
                return Err(at(
                    r.between.span(),
                    "between",
                    "expected two different target ids [\"a\", \"b\"]".into(),
                ));
            }
        };
        let m = finite(&r.m, "m")?;
        if m <= 0.0 {
            return Err(at(
                r.m.span(),
                "m",
                format!("expected a positive distance in metres, found {m}"),
            ));
        }
        let sigma_m = match &r.sigma_m {
            Some(s) => {
                let v = finite(s, "sigma_m")?;
                if v <= 0.0 {
                    return Err(at(
                        s.span(),
                        "sigma_m",
                        format!("expected a positive 1-sigma in metres, found {v}"),
                    ));
                }
                Some(v)
            }
            None => None,
        };
        out.distances.push(DistanceSpec {
            between,
            m,
            sigma_m,
            line,
        });
    }
    for t in &raw.target {
        let r = t.get_ref();
        out.targets.push(TargetSpec {
            id: id_of(&r.id)?,
            xyz_m: vec3(&r.xyz_m, "xyz_m")?,
            line: line_at(text, t.span().start),
        });
    }
    for p in &raw.plane {
        let r = p.get_ref();
        let n = vec3(&r.normal, "normal")?;
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if len <= 1e-12 {
            return Err(at(
                r.normal.span(),
                "normal",
                "expected a non-zero normal".into(),
            ));
        }
        out.planes.push(PlaneSpec {
            id: id_of(&r.id)?,
            normal: [n[0] / len, n[1] / len, n[2] / len],
            offset_m: finite(&r.offset_m, "offset_m")? / len,
            line: line_at(text, p.span().start),
        });
    }
    // One definition per id.
    let mut seen: HashMap<&str, usize> = HashMap::new();
    for (id, line) in out
        .targets
        .iter()
        .map(|t| (t.id.as_str(), t.line))
        .chain(out.planes.iter().map(|p| (p.id.as_str(), p.line)))
    {
        if let Some(prev) = seen.insert(id, line) {
            return Err(CliError::input(format!(
                "{name}:{line}: key 'id': {id:?} is already defined on line {prev}: expected one \
                 [[target]] or [[plane]] per id"
            )));
        }
    }
    Ok(out)
}

/// What a group is, for reports.
#[derive(Debug, Clone, PartialEq)]
pub struct GroupInfo {
    pub id: String,
    pub plane: bool,
    pub known: bool,
    pub session: Option<String>,
    /// Line of its first row.
    pub line: u64,
}

/// A measurement set as core constraint data (owned), with the way back to the file.
#[derive(Debug, Clone)]
pub struct ContactData<const N: usize> {
    pub instrument: Vec<Measurement<N>>,
    /// Row (index into the set) of each instrument measurement.
    pub instrument_rows: Vec<usize>,
    pub contacts: Vec<Contact<N>>,
    /// Row of each contact.
    pub contact_rows: Vec<usize>,
    pub groups: Vec<Group>,
    pub info: Vec<GroupInfo>,
    pub distances: Vec<Distance>,
    pub distance_specs: Vec<DistanceSpec>,
    /// The constraints file (path, sha256), if any.
    pub file: Option<(String, String)>,
    /// Instrument rows measured in a frame of their own, one run per session after the
    /// first with instrument rows (docs/constraints.md, "Sessions with instrument rows");
    /// the instrument rows are ordered by session for this.
    pub sessions: Vec<InstrumentSession>,
    /// The session id of each of `sessions`.
    pub session_names: Vec<String>,
    /// The session whose instrument rows are in the robot's base frame (the first with
    /// instrument rows), when instrument rows span several sessions.
    pub base_session: Option<String>,
}

/// A fitted frame of an instrument session, for reports and the model file.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionFrame {
    /// The session id.
    pub session: String,
    /// Its instrument rows with a positive weight.
    pub rows: usize,
    /// Robot base → the session's measuring frame.
    pub frame: Transform,
}

impl<const N: usize> ContactData<N> {
    /// The core's view.
    pub fn view(&self) -> ConstraintData<'_, N> {
        ConstraintData {
            instrument: &self.instrument,
            contacts: &self.contacts,
            groups: &self.groups,
            distances: &self.distances,
            sessions: &self.sessions,
        }
    }

    /// The fitted frame of every instrument session with active rows at `robot`, as the
    /// calibration eliminates it (position and orientation rows weighted by `opts`).
    pub fn session_frames(
        &self,
        robot: &Robot<N>,
        opts: &IdentifyOptions<'_>,
    ) -> Result<Vec<SessionFrame>, Error> {
        let d = self.view();
        let mut out = Vec::new();
        for (s, name) in self.session_names.iter().enumerate() {
            let rows = d.session_rows(s).iter().filter(|m| m.weight > 0.0).count();
            if rows == 0 {
                continue;
            }
            out.push(SessionFrame {
                session: name.clone(),
                rows,
                frame: d.session_frame(robot, s, opts)?,
            });
        }
        Ok(out)
    }

    /// Row (index into the set) of the core's row index (instrument, then contacts).
    pub fn row_of(&self, index: usize) -> Option<usize> {
        match index.checked_sub(self.instrument.len()) {
            None => self.instrument_rows.get(index).copied(),
            Some(c) => self.contact_rows.get(c).copied(),
        }
    }

    /// Number of rows of the set that take part.
    pub fn rows(&self) -> usize {
        self.instrument.len() + self.contacts.len()
    }

    /// Sets the weight of every row: `keep(row index)` → 1, else 0 (held out).
    pub fn select(&mut self, keep: impl Fn(usize) -> bool) {
        for (m, &r) in self.instrument.iter_mut().zip(&self.instrument_rows) {
            m.weight = if keep(r) { 1.0 } else { 0.0 };
        }
        for (c, &r) in self.contacts.iter_mut().zip(&self.contact_rows) {
            c.weight = if keep(r) { 1.0 } else { 0.0 };
        }
    }

    /// The targets, planes and distances as `robot` sees them (rows with a positive weight).
    pub fn report_json(&self, robot: &Robot<N>) -> Result<ConstraintsJson, Error> {
        let d = self.view();
        let mut out = ConstraintsJson {
            file: self.file.as_ref().map(|f| f.0.clone()),
            sha256: self.file.as_ref().map(|f| f.1.clone()),
            targets: Vec::new(),
            planes: Vec::new(),
            distances: Vec::new(),
        };
        for (g, info) in self.info.iter().enumerate() {
            let e = group_estimate(robot, &d, g)?;
            let j = GroupJson {
                id: info.id.clone(),
                session: info.session.clone(),
                known: info.known,
                contacts: e.contacts,
                xyz_m: e.point,
                normal: info.plane.then_some(e.normal),
                offset_m: info.plane.then_some(e.offset_m),
                rms_mm: e.rms_m * 1e3,
                max_mm: e.max_m * 1e3,
            };
            if info.plane {
                out.planes.push(j);
            } else {
                out.targets.push(j);
            }
        }
        for (k, s) in self.distance_specs.iter().enumerate() {
            let p = kincal::identify::distance_estimate(robot, &d, k)?;
            out.distances.push(DistanceJson {
                between: s.between.clone(),
                m: s.m,
                sigma_m: s.sigma_m,
                predicted_m: p,
                error_mm: p.map(|p| (p - s.m) * 1e3),
            });
        }
        Ok(out)
    }
}

/// Whether the set has contact rows.
pub fn has_contacts(set: &MeasurementSet) -> bool {
    set.rows.iter().any(MeasurementRow::is_constraint)
}

/// Why instrument rows in a second session are refused by the commands with one base frame
/// for all instrument rows (the one wording for every reader that refuses them): session
/// `first` began at line `first_line`, the refused row is in `other`.
pub(crate) fn instrument_sessions_refused(first: &str, first_line: u64, other: &str) -> String {
    format!(
        "instrument rows (x, y, z) in two sessions, {first:?} (from line {first_line}) and \
         {other:?} (this row): this command has one base frame for all instrument rows; \
         calibrate, validate, crossval and predict fit a frame per session \
         (docs/constraints.md); expected instrument rows in one session: give rows from one \
         instrument set-up one session id, or use those commands"
    )
}

fn input(set: &MeasurementSet, line: u64, column: &str, why: String) -> CliError {
    CliError::input(format!("{}:{line}: column '{column}': {why}", set.source))
}

/// Core's session and group rules ([`check_sessions`]) on the rows' roles, worded for
/// the file: sessions and groups are indices into `sessions` and `order`.
fn check_layout(
    set: &MeasurementSet,
    roles: &[(RowRole, usize)],
    kinds: &[GroupKind],
    order: &[(String, bool)],
    sessions: &[(Option<&str>, u64)],
) -> Result<(), CliError> {
    let (g, s) = (kinds.len(), sessions.len());
    let (mut gr, mut gf, mut gs) = (vec![0; g], vec![0; g], vec![0; g]);
    let (mut sr, mut sf) = (vec![0; s], vec![0; s]);
    let fault = check_sessions(
        roles.iter().copied(),
        |g| kinds.get(g).copied().unwrap_or(GroupKind::Target),
        &SessionLayout {
            n_groups: g,
            n_sessions: s,
            sessions_given: set.has_session,
            instrument_frames: true,
        },
        SessionScratch {
            group_rows: &mut gr,
            group_first: &mut gf,
            group_session: &mut gs,
            session_rows: &mut sr,
            session_first: &mut sf,
        },
    );
    let Err(fault) = fault else {
        return Ok(());
    };
    let row = |r: usize| &set.rows[r];
    let session_name = |r: usize| row(r).session.as_deref().unwrap_or("").to_string();
    let group = |g: usize| {
        let (id, plane) = &order[g];
        (id.as_str(), if *plane { "plane" } else { "target" })
    };
    Err(match fault {
        SessionFault::GroupInTwoSessions {
            group: g,
            row: r,
            first,
        } => {
            let (id, col) = group(g);
            input(
                set,
                row(r).line,
                col,
                format!(
                    "{col} {id:?} appears in session {:?} (from line {}) and in session {:?}: \
                     expected each {col} in one session (a fixed point of one set-up)",
                    session_name(first),
                    row(first).line,
                    session_name(r)
                ),
            )
        }
        SessionFault::FrameTooSmall {
            session,
            rows,
            first,
        } => input(
            set,
            row(first).line,
            "session",
            format!(
                "session {:?} has {rows} instrument row(s) (x, y, z): expected at least \
                 {MIN_FRAME_ROWS}, not on a line, in a session measured in a frame of its own \
                 (every session after the first with instrument rows gets one, \
                 docs/constraints.md)",
                sessions[session].0.unwrap_or("")
            ),
        ),
        SessionFault::InstrumentInTwoSessions { row: r, first } => input(
            set,
            row(r).line,
            "session",
            instrument_sessions_refused(&session_name(first), row(first).line, &session_name(r)),
        ),
        SessionFault::SessionTooSmall { session, rows, .. } => input(
            set,
            sessions[session].1,
            "session",
            format!(
                "session {:?} has {rows} row(s): expected at least {MIN_SESSION_ROWS} (a set-up \
                 must hold enough contacts to say something)",
                sessions[session].0.unwrap_or("")
            ),
        ),
        SessionFault::GroupTooSmall {
            group: g,
            rows,
            needed,
            first,
        } => {
            let (id, col) = group(g);
            input(
                set,
                row(first).line,
                col,
                format!(
                    "{col} {id:?} has {rows} row(s): expected at least {needed} (an unknown {col} \
                     is estimated from its contacts; give it in the constraints file if it is \
                     known)"
                ),
            )
        }
        other => CliError::input(format!(
            "{}: internal error grouping the rows: {other:?}",
            set.source
        )),
    })
}

/// Orders the instrument rows by session (the first session with instrument rows first: its
/// rows stay in the robot's base frame) and gives every later session a frame of its own.
fn order_instrument_sessions<const N: usize>(
    out: &mut ContactData<N>,
    inst_session: &[usize],
    sessions: &[(Option<&str>, u64)],
) {
    let Some(&base) = inst_session.first() else {
        return;
    };
    if inst_session.iter().all(|&s| s == base) {
        return;
    }
    let mut idx: Vec<usize> = (0..inst_session.len()).collect();
    idx.sort_by_key(|&i| (inst_session[i] != base, inst_session[i]));
    out.instrument = idx.iter().map(|&i| out.instrument[i]).collect();
    out.instrument_rows = idx.iter().map(|&i| out.instrument_rows[i]).collect();
    let name = |s: usize| sessions[s].0.unwrap_or("").to_string();
    out.base_session = Some(name(base));
    let mut k = 0;
    while k < idx.len() {
        let s = inst_session[idx[k]];
        let len = idx[k..]
            .iter()
            .take_while(|&&i| inst_session[i] == s)
            .count();
        if s != base {
            out.sessions.push(InstrumentSession { start: k, len });
            out.session_names.push(name(s));
        }
        k += len;
    }
}

/// Whether instrument rows (x, y, z) of `set` span more than one session: they are then
/// calibrated with a frame per session ([`build`]), through the contact-data path.
pub fn has_instrument_sessions(set: &MeasurementSet) -> bool {
    let mut first: Option<Option<&str>> = None;
    for row in set.rows.iter().filter(|r| !r.is_constraint()) {
        match first {
            None => first = Some(row.session.as_deref()),
            Some(s) if s != row.session.as_deref() => return true,
            Some(_) => {}
        }
    }
    false
}

/// Builds the core's data from `set` and the constraints file: rows grouped by target or
/// plane (in order of first appearance), instrument rows as measurements, known targets
/// and planes from the file, distances weighted by `sigma_m` (`1/(σ²·weight_pos)` relative
/// to a position row; 1 without). Refuses, naming file, line and column: a target with one
/// row (unless known), a plane with fewer than [`MIN_PLANE_CONTACTS`] rows (unless known),
/// a target or plane in two sessions, a session with fewer than [`MIN_SESSION_ROWS`] rows,
/// a session after the first with instrument rows holding fewer than [`MIN_FRAME_ROWS`] of
/// them (it gets a frame of its own, [`order_instrument_sessions`]), a
/// row that measures nothing, a distance or known id that no row names, and plane contacts
/// that are collinear at `start`.
// Long by design: the contact rules of docs/constraints.md in order (sessions, groups, known ids, distances, collinear planes).
pub fn build<const N: usize>(
    set: &MeasurementSet,
    cons: Option<&ConstraintsFile>,
    start: &Robot<N>,
    weight_pos: f64,
) -> Result<ContactData<N>, CliError> {
    let empty = ConstraintsFile::default();
    let cons = cons.unwrap_or(&empty);
    let mut out = ContactData {
        instrument: Vec::new(),
        instrument_rows: Vec::new(),
        contacts: Vec::new(),
        contact_rows: Vec::new(),
        groups: Vec::new(),
        info: Vec::new(),
        distances: Vec::new(),
        distance_specs: cons.distances.clone(),
        file: (!cons.path.is_empty()).then(|| (cons.path.clone(), cons.sha256.clone())),
        sessions: Vec::new(),
        session_names: Vec::new(),
        base_session: None,
    };
    let mut inst_session: Vec<usize> = Vec::new();
    // Sessions and groups (targets, planes) in order of first appearance; each row's role.
    let mut sessions: Vec<(Option<&str>, u64)> = Vec::new();
    let mut order: Vec<(String, bool)> = Vec::new();
    let mut group_index: HashMap<(String, bool), usize> = HashMap::new();
    let mut members: Vec<Vec<usize>> = Vec::new();
    let mut roles: Vec<(RowRole, usize)> = Vec::with_capacity(set.rows.len());
    for (i, row) in set.rows.iter().enumerate() {
        let session = row.session.as_deref();
        let s = match sessions.iter().position(|s| s.0 == session) {
            Some(s) => s,
            None => {
                sessions.push((session, row.line));
                sessions.len() - 1
            }
        };
        let key = match (&row.target, &row.plane) {
            (Some(t), _) => Some((t.clone(), false)),
            (None, Some(p)) => Some((p.clone(), true)),
            _ => None,
        };
        if let Some(key) = key {
            let g = *group_index.entry(key.clone()).or_insert_with(|| {
                order.push(key);
                members.push(Vec::new());
                members.len() - 1
            });
            members[g].push(i);
            roles.push((RowRole::Contact(g), s));
            continue;
        }
        let Some((pose, mask)) = crate::data::measured_pose(row, &set.source)? else {
            return Err(input(
                set,
                row.line,
                "x",
                "the row measures nothing: expected a coordinate (x, y, z), a target or a plane"
                    .into(),
            ));
        };
        roles.push((RowRole::Instrument, s));
        inst_session.push(s);
        out.instrument.push(Measurement {
            state: crate::data::joint_state::<N>(row),
            pose,
            mask,
            weight: 1.0,
            point: row.point_m,
        });
        out.instrument_rows.push(i);
    }
    let known_target = |id: &str| cons.targets.iter().find(|t| t.id == id);
    let known_plane = |id: &str| cons.planes.iter().find(|p| p.id == id);
    let mut kinds = Vec::with_capacity(order.len());
    for (key, rows) in order.iter().zip(&members) {
        let first = &set.rows[rows[0]];
        let (id, plane) = (key.0.as_str(), key.1);
        let col = if plane { "plane" } else { "target" };
        if (plane && known_target(id).is_some()) || (!plane && known_plane(id).is_some()) {
            return Err(input(
                set,
                first.line,
                col,
                format!(
                    "{id:?} is a {col} here but a [[{}]] in the constraints file",
                    if plane { "target" } else { "plane" }
                ),
            ));
        }
        kinds.push(if plane {
            match known_plane(id) {
                Some(p) => GroupKind::KnownPlane {
                    normal: p.normal,
                    offset_m: p.offset_m,
                },
                None => GroupKind::Plane,
            }
        } else {
            match known_target(id) {
                Some(t) => GroupKind::KnownTarget(t.xyz_m),
                None => GroupKind::Target,
            }
        });
    }
    check_layout(set, &roles, &kinds, &order, &sessions)?;
    order_instrument_sessions(&mut out, &inst_session, &sessions);
    for ((key, rows), &kind) in order.iter().zip(&members).zip(&kinds) {
        let first = &set.rows[rows[0]];
        let (id, plane) = (key.0.as_str(), key.1);
        out.groups.push(Group {
            kind,
            start: out.contacts.len(),
            len: rows.len(),
        });
        out.info.push(GroupInfo {
            id: id.to_string(),
            plane,
            known: kind.is_known(),
            session: first.session.clone(),
            line: first.line,
        });
        for &r in rows {
            let row = &set.rows[r];
            out.contacts.push(Contact {
                state: crate::data::joint_state::<N>(row),
                point: row.point_m.unwrap_or([0.0; 3]),
                weight: 1.0,
            });
            out.contact_rows.push(r);
        }
    }
    // Known ids must be used; distances must name targets of the data.
    let group_of =
        |id: &str, plane: bool| out.info.iter().position(|g| g.id == id && g.plane == plane);
    for t in &cons.targets {
        if group_of(&t.id, false).is_none() {
            return Err(CliError::input(format!(
                "{}:{}: key 'id': no row of {} names target {:?}: expected a target of the data",
                cons.path, t.line, set.source, t.id
            )));
        }
    }
    for p in &cons.planes {
        if group_of(&p.id, true).is_none() {
            return Err(CliError::input(format!(
                "{}:{}: key 'id': no row of {} names plane {:?}: expected a plane of the data",
                cons.path, p.line, set.source, p.id
            )));
        }
    }
    for d in &cons.distances {
        let mut ends = [0; 2];
        for (e, id) in ends.iter_mut().zip(&d.between) {
            *e = group_of(id, false).ok_or_else(|| {
                CliError::input(format!(
                    "{}:{}: key 'between': no row of {} names target {id:?}: expected two \
                     targets of the data",
                    cons.path, d.line, set.source
                ))
            })?;
        }
        out.distances.push(Distance {
            a: ends[0],
            b: ends[1],
            m: d.m,
            weight: d.sigma_m.map_or(1.0, |s| 1.0 / (s * s * weight_pos)),
        });
    }
    // Collinear plane contacts at the starting model.
    let view = out.view();
    for (g, info) in out.info.iter().enumerate() {
        if info.plane && !info.known {
            let aspect = match group_estimate(start, &view, g) {
                Ok(e) => e.aspect,
                Err(Error::DegenerateGroup { .. }) => 0.0,
                Err(e) => {
                    return Err(crate::error::core_error(e, &set.source, |i| {
                        out.row_of(i).and_then(|r| set.rows.get(r)).map(|r| r.line)
                    }));
                }
            };
            if aspect < CLI_PLANE_MIN_ASPECT {
                {
                    return Err(input(
                        set,
                        info.line,
                        "plane",
                        format!(
                            "the contacts of plane {:?} are collinear (at the starting model their \
                             spread across their best-fit line is {aspect:.3} of their extent, \
                             below {CLI_PLANE_MIN_ASPECT}): expected contacts spread over the plane",
                            info.id,
                        ),
                    ));
                }
            }
        }
    }
    Ok(out)
}

/// The consistency report: scatter of the predicted tool point per target and plane, and
/// the error of every known distance (mm).
pub fn report_text(c: &ConstraintsJson) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let groups = c.targets.iter().chain(c.planes.iter()).collect::<Vec<_>>();
    if !groups.is_empty() {
        let all: Vec<f64> = groups.iter().map(|g| g.rms_mm).collect();
        let worst = groups.iter().map(|g| g.max_mm).fold(0.0, f64::max);
        let _ = writeln!(
            s,
            "\nConsistency (scatter of the predicted tool point about its target/plane): {} targets, {} planes; \
             mean RMS {:.4} mm, largest {:.4} mm",
            c.targets.len(),
            c.planes.len(),
            all.iter().sum::<f64>() / all.len() as f64,
            worst
        );
        let _ = writeln!(
            s,
            "  {:<24} {:>8} {:>8} {:>10} {:>10}",
            "id", "kind", "contacts", "RMS [mm]", "max [mm]"
        );
        for (g, kind) in c
            .targets
            .iter()
            .map(|g| (g, "target"))
            .chain(c.planes.iter().map(|g| (g, "plane")))
        {
            let _ = writeln!(
                s,
                "  {:<24} {:>8} {:>8} {:>10.4} {:>10.4}{}",
                g.id,
                kind,
                g.contacts,
                g.rms_mm,
                g.max_mm,
                if g.known { "  (known)" } else { "" }
            );
        }
    }
    if !c.distances.is_empty() {
        let _ = writeln!(s, "\nKnown distances:");
        let _ = writeln!(
            s,
            "  {:<36} {:>12} {:>14} {:>11}",
            "between", "known [mm]", "predicted [mm]", "error [mm]"
        );
        for d in &c.distances {
            let _ = writeln!(
                s,
                "  {:<36} {:>12.4} {:>14} {:>11}",
                format!("{} – {}", d.between[0], d.between[1]),
                d.m * 1e3,
                d.predicted_m
                    .map_or("–".into(), |p| format!("{:.4}", p * 1e3)),
                d.error_mm.map_or("–".into(), |e| format!("{e:+.4}"))
            );
        }
    }
    s
}

/// The fitted frame of every instrument session after the first (robot base → its
/// measuring frame: translation in mm, rotation vector in degrees); empty without.
pub fn session_frames_text(base: Option<&str>, frames: &[SessionFrame]) -> String {
    use std::fmt::Write as _;
    let Some(base) = base else {
        return String::new();
    };
    let mut s = format!(
        "\nSession frames: instrument rows of session {base:?} are in the robot's base frame; \
         each later session's frame is fitted to its rows (6 parameters each, eliminated):\n  \
         {:<24} {:>6} {:>34} {:>30}\n",
        "session", "rows", "translation [mm]", "rotation vector [deg]"
    );
    for f in frames {
        let v = kincal::pose::pose_to_vector6(&f.frame);
        let _ = writeln!(
            s,
            "  {:<24} {:>6} {:>10.3} {:>11.3} {:>11.3} {:>9.4} {:>9.4} {:>9.4}",
            f.session,
            f.rows,
            v[0] * 1e3,
            v[1] * 1e3,
            v[2] * 1e3,
            v[3].to_degrees(),
            v[4].to_degrees(),
            v[5].to_degrees()
        );
    }
    s
}

/// What fixes the frame and the scale of contact data (the identifiability report names
/// the parameters held; this says why, also when the base frame was not requested).
pub fn reference_note<const N: usize>(d: &ConstraintData<'_, N>) -> String {
    let mut s = String::from("\nReference:\n");
    if d.has_external_reference() {
        s.push_str("  base frame: referred to by instrument rows or known targets/planes\n");
    } else {
        s.push_str(
            "  base frame: NOT observable (no instrument row, known target or known plane): \
             kept at the ROBOT's; targets and planes are reported in that frame\n",
        );
    }
    if !d.distances.is_empty() {
        let _ = std::fmt::Write::write_fmt(
            &mut s,
            format_args!("  scale: from {} known distance(s)\n", d.distances.len()),
        );
    } else if d.has_length_reference() {
        s.push_str("  scale: from instrument rows or known targets/planes\n");
    } else {
        s.push_str(
            "  scale: NOT observable (no known distance, instrument row, known target or \
             known plane): one length is held (see 'not observable' above), the others are \
             relative to it\n",
        );
    }
    s
}
