//! Measurement CSV reading and writing (spec/measurements.md).
//!
//! Reading converts every angle to radians and every length to metres, checks each cell
//! and reports the first problem with file, line, column and what was expected. Files are
//! streamed record by record and hashed (SHA-256 of the raw bytes) while they are read.
//!
//! Writing uses the shortest decimal form that reads back to the same `f64`, so
//! write → read is bit-exact.

use std::fmt;
use std::fs::File;
use std::io::{self, BufRead, BufReader, Read, Write};
use std::path::Path;

use sha2::{Digest, Sha256};

/// Tolerance on `| |q| - 1 |` for a quaternion to be accepted (and then normalised).
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-6;

/// Below this distance from 1 the norm of a quaternion is taken as 1 and its components
/// are kept bit for bit (renormalising would only move them by rounding, and would make
/// write → read not bit-exact).
const QUATERNION_UNIT_EPS: f64 = 8.0 * f64::EPSILON;

/// How to read a measurement file.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadOptions {
    /// Number of joints of the robot: the file must have exactly the columns q1..qN.
    pub n_joints: usize,
    /// Inclusive joint limits in radians (SI units for prismatic joints), one per joint.
    pub joint_limits: Option<Vec<(f64, f64)>>,
    /// Accept joint readings outside `joint_limits`.
    pub allow_out_of_limits: bool,
    /// The file must hold measured poses: at least the position columns x, y, z
    /// (orientation stays optional: position-only data is valid measured data).
    pub require_pose: bool,
}

impl ReadOptions {
    /// Options for an `n_joints` robot with no limits and no pose requirement.
    pub fn new(n_joints: usize) -> Self {
        ReadOptions {
            n_joints,
            joint_limits: None,
            allow_out_of_limits: false,
            require_pose: false,
        }
    }
}

/// Which orientation columns a file had.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OrientationForm {
    /// `roll`, `pitch`, `yaw`: R = Rz(yaw)·Ry(pitch)·Rx(roll).
    Rpy,
    /// `qw`, `qx`, `qy`, `qz`.
    Quaternion,
}

/// A measured orientation, angles in radians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Orientation {
    /// R = Rz(yaw)·Ry(pitch)·Rx(roll).
    Rpy {
        roll_rad: f64,
        pitch_rad: f64,
        yaw_rad: f64,
    },
    /// Unit quaternion (normalised on read).
    Quaternion { w: f64, x: f64, y: f64, z: f64 },
}

impl Orientation {
    /// The form of this orientation.
    pub fn form(&self) -> OrientationForm {
        match self {
            Orientation::Rpy { .. } => OrientationForm::Rpy,
            Orientation::Quaternion { .. } => OrientationForm::Quaternion,
        }
    }
}

/// One measured pose (one data row of the file).
#[derive(Debug, Clone, PartialEq)]
pub struct MeasurementRow {
    /// 1-based line number in the file where the row starts.
    pub line: u64,
    /// `pose_id` label, if the file has that column.
    pub pose_id: Option<String>,
    /// Joint readings q1..qN in radians.
    pub q_rad: Vec<f64>,
    /// End-effector origin in the base frame, metres.
    pub position_m: Option<[f64; 3]>,
    pub orientation: Option<Orientation>,
    /// The measured point's position in the tool frame [m] (`point_x/y/z`): the row
    /// measures that point of the end effector rather than the tool-frame origin.
    pub point_m: Option<[f64; 3]>,
    /// s1..sN, each -1, 0 or 1.
    pub approach: Option<Vec<i8>>,
    /// Arm temperature, °C.
    pub temp_c: Option<f64>,
    /// Values of the `extra_` columns, in the order of `MeasurementSet::extra_columns`.
    pub extras: Vec<String>,
    /// Some but not all of x, y, z (the others left empty: not measured on this row);
    /// `position_m` is then `None`. `None` when all three or none are given.
    pub partial_m: Option<[Option<f64>; 3]>,
    /// `target` id: the row's tool point is held at this unknown (or known) point; the row
    /// has no pose.
    pub target: Option<String>,
    /// `plane` id: the row's tool point lies on this plane; the row has no pose.
    pub plane: Option<String>,
    /// `session` id (set-up sharing one base frame).
    pub session: Option<String>,
}

impl MeasurementRow {
    /// A row with joint readings only (everything else absent).
    pub fn joints_only(line: u64, q_rad: Vec<f64>) -> Self {
        MeasurementRow {
            line,
            pose_id: None,
            q_rad,
            position_m: None,
            orientation: None,
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

    /// Whether the row is a constraint row (`target` or `plane`).
    pub fn is_constraint(&self) -> bool {
        self.target.is_some() || self.plane.is_some()
    }

    /// Whether the row measures anything (a coordinate, a target or a plane).
    pub fn measures_something(&self) -> bool {
        self.position_m.is_some() || self.partial_m.is_some() || self.is_constraint()
    }
}

/// A whole measurement file.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasurementSet {
    /// File name as given (used in messages).
    pub source: String,
    /// Comment lines before the header, without the leading `#` (rest kept verbatim).
    pub comments: Vec<String>,
    pub n_joints: usize,
    pub rows: Vec<MeasurementRow>,
    /// Names of the `extra_` columns (full names, prefix included), in file order.
    pub extra_columns: Vec<String>,
    pub orientation_form: Option<OrientationForm>,
    pub has_position: bool,
    /// The file has the `point_x, point_y, point_z` columns.
    pub has_point: bool,
    /// The file has a `target` column.
    pub has_target: bool,
    /// The file has a `plane` column.
    pub has_plane: bool,
    /// The file has a `session` column.
    pub has_session: bool,
    pub has_approach: bool,
    pub has_temperature: bool,
    /// Lower-case hex SHA-256 of the file's bytes.
    pub sha256: String,
    /// 1-based line of the header row (for messages about missing columns).
    pub header_line: u64,
}

impl MeasurementSet {
    /// True if the file carried a `pose_id` column.
    pub fn has_pose_id(&self) -> bool {
        self.rows.first().is_some_and(|r| r.pose_id.is_some())
    }

    /// Robot poses (configurations) in the file: rows sharing a `pose_id` (within a
    /// session) are one pose seen by several markers or points; a row without one is a pose.
    pub fn pose_count(&self) -> usize {
        let mut seen = std::collections::HashSet::new();
        self.rows
            .iter()
            .filter(|r| match &r.pose_id {
                Some(id) => seen.insert((r.session.as_deref(), id.as_str())),
                None => true,
            })
            .count()
    }
}

/// A rejected input: file, line, column and what was expected.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InputError {
    pub path: String,
    pub line: Option<u64>,
    pub column: Option<String>,
    pub reason: String,
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.path)?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
        }
        write!(f, ": ")?;
        if let Some(col) = &self.column {
            write!(f, "column '{col}': ")?;
        }
        write!(f, "{}", self.reason)
    }
}

impl std::error::Error for InputError {}

/// Reads and checks a measurement file.
pub fn read_measurements(path: &Path, opts: &ReadOptions) -> Result<MeasurementSet, InputError> {
    let (file, name) = open(path)?;
    parse_measurements(file, &name, opts)
}

/// Opens a measurement file; its name for messages.
fn open(path: &Path) -> Result<(File, String), InputError> {
    let name = path.display().to_string();
    match File::open(path) {
        Ok(file) => Ok((file, name)),
        Err(e) => Err(InputError {
            path: name,
            line: None,
            column: None,
            reason: format!("cannot open the file: {e}"),
        }),
    }
}

/// Reads and checks measurement CSV from any reader; `source_name` is used in messages.
pub fn parse_measurements(
    reader: impl Read,
    source_name: &str,
    opts: &ReadOptions,
) -> Result<MeasurementSet, InputError> {
    Parser::new(source_name, opts)?.run(reader)
}

/// Reads a measurement file row by row without keeping the rows: `on_row` gets the file's
/// description (columns and flags; `rows` and `sha256` empty) and each checked row in file
/// order. For one-pass commands (`predict`) on files of any length: memory stays that of
/// one row. Returns the description with its `sha256`.
pub fn stream_measurements<E>(
    path: &Path,
    opts: &ReadOptions,
    on_row: impl FnMut(&MeasurementSet, MeasurementRow) -> Result<(), E>,
) -> Result<MeasurementSet, StreamError<E>> {
    let (file, name) = open(path)?;
    Parser::new(&name, opts)?.run_with(file, on_row)
}

/// Why [`stream_measurements`] stopped: the file was refused, or the row handler failed.
#[derive(Debug)]
pub enum StreamError<E> {
    Input(InputError),
    Row(E),
}

impl<E> From<InputError> for StreamError<E> {
    fn from(e: InputError) -> Self {
        StreamError::Input(e)
    }
}

/// The header row of a measurement file, names as written (trimmed): for a binding that
/// reads a file without knowing the robot (it takes the joint count from the file, then reads
/// with [`parse_measurements`]) and shows the columns. Only the header is parsed; comments
/// and rows are checked by [`parse_measurements`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Header {
    /// 1-based line of the header row.
    pub line: u64,
    /// Column names, in file order.
    pub columns: Vec<String>,
}

impl Header {
    /// The highest joint index K of a column `qK` (any unit), 0 without joint columns.
    pub fn joint_count(&self) -> usize {
        self.columns
            .iter()
            .filter_map(|c| match classify(c) {
                Ok((Kind::Joint(k), _)) => Some(k + 1),
                _ => None,
            })
            .max()
            .unwrap_or(0)
    }
}

/// Reads the header row (after the comment and blank lines) of measurement CSV.
pub fn parse_header(reader: impl Read, source_name: &str) -> Result<Header, InputError> {
    let err = |line: Option<u64>, reason: String| InputError {
        path: source_name.to_string(),
        line,
        column: None,
        reason,
    };
    let hashing = HashingReader::new(reader).map_err(|e| err(None, format!("read error: {e}")))?;
    let mut src = Records::new(BufReader::with_capacity(64 * 1024, hashing));
    let mut raw = Vec::new();
    loop {
        let at = src.line;
        let io_err = |e: io::Error| err(Some(at), format!("read error: {e}"));
        if !src.skip_blank_lines().map_err(io_err)? || src.peek().map_err(io_err)? != Some(b'#') {
            break;
        }
        src.read_raw_line(&mut raw).map_err(io_err)?;
    }
    let at = src.line;
    let line = src
        .read_record()
        .map_err(|e| err(Some(at), format!("read error: {e}")))?
        .ok_or_else(|| {
            err(
                Some(src.line),
                "empty file: expected a header row (q1..qN, ...) and data rows".into(),
            )
        })?;
    let columns = src
        .fields()
        .map_err(|(i, e)| {
            err(
                Some(line),
                format!(
                    "column #{} is not valid UTF-8 ({e}): expected UTF-8 text",
                    i + 1
                ),
            )
        })?
        .iter()
        .map(|c| c.trim().to_string())
        .collect();
    Ok(Header { line, columns })
}

// ---------------------------------------------------------------------------------------
// Reading

/// Passes bytes through, hashing all of them and hiding a leading UTF-8 byte-order mark.
struct HashingReader<R> {
    inner: R,
    hasher: Sha256,
    pending: [u8; 3],
    pending_len: usize,
    pending_pos: usize,
}

impl<R: Read> HashingReader<R> {
    fn new(mut inner: R) -> io::Result<Self> {
        let mut head = [0u8; 3];
        let mut n = 0;
        while n < 3 {
            match inner.read(&mut head[n..]) {
                Ok(0) => break,
                Ok(k) => n += k,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
        let mut hasher = Sha256::new();
        hasher.update(&head[..n]);
        let bom = n == 3 && head == [0xEF, 0xBB, 0xBF];
        Ok(HashingReader {
            inner,
            hasher,
            pending: head,
            pending_len: if bom { 0 } else { n },
            pending_pos: 0,
        })
    }

    fn finish_hex(self) -> String {
        hex(&self.hasher.finalize())
    }
}

impl<R: Read> Read for HashingReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.pending_pos < self.pending_len {
            let k = (self.pending_len - self.pending_pos).min(buf.len());
            buf[..k].copy_from_slice(&self.pending[self.pending_pos..self.pending_pos + k]);
            self.pending_pos += k;
            return Ok(k);
        }
        let n = self.inner.read(buf)?;
        self.hasher.update(&buf[..n]);
        Ok(n)
    }
}

fn hex(bytes: &[u8]) -> String {
    use fmt::Write as _;
    let mut s = String::with_capacity(bytes.len() * 2);
    for b in bytes {
        let _ = write!(s, "{b:02x}");
    }
    s
}

/// Splits the byte stream into CSV records (csv-core), counting lines exactly: a record's
/// line is the line of its first byte, whatever the line endings and blank lines.
struct Records<R> {
    rdr: R,
    core: csv_core::Reader,
    /// 1-based line number of the next unread byte.
    line: u64,
    out: Vec<u8>,
    ends: Vec<usize>,
    n_out: usize,
    n_ends: usize,
}

/// Longest record (line, or lines of one quoted record) read: a longer one is refused
/// instead of buffered without limit (`kincal calibrate /dev/zero`).
pub const MAX_RECORD_BYTES: usize = 1 << 20;
/// Most fields in one record.
pub const MAX_FIELDS: usize = 4096;
/// Longest field (a pose label or an extra column included).
pub const MAX_FIELD_BYTES: usize = 64 * 1024;

fn too_long(what: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, what)
}

fn count_newlines(b: &[u8]) -> u64 {
    b.iter().filter(|&&c| c == b'\n').count() as u64
}

impl<R: BufRead> Records<R> {
    fn new(rdr: R) -> Self {
        Records {
            rdr,
            core: csv_core::Reader::new(),
            line: 1,
            out: vec![0; 4096],
            ends: vec![0; 64],
            n_out: 0,
            n_ends: 0,
        }
    }

    fn into_inner(self) -> R {
        self.rdr
    }

    fn peek(&mut self) -> io::Result<Option<u8>> {
        Ok(self.rdr.fill_buf()?.first().copied())
    }

    /// Skips line terminators (blank lines); false at the end of the input.
    fn skip_blank_lines(&mut self) -> io::Result<bool> {
        loop {
            let buf = self.rdr.fill_buf()?;
            if buf.is_empty() {
                return Ok(false);
            }
            let k = buf
                .iter()
                .take_while(|&&b| b == b'\n' || b == b'\r')
                .count();
            self.line += count_newlines(&buf[..k]);
            let more = k < buf.len();
            self.rdr.consume(k);
            if more {
                return Ok(true);
            }
        }
    }

    /// Reads one raw line, terminator included.
    fn read_raw_line(&mut self, raw: &mut Vec<u8>) -> io::Result<()> {
        raw.clear();
        let limit = MAX_RECORD_BYTES as u64 + 1;
        (&mut self.rdr).take(limit).read_until(b'\n', raw)?;
        if raw.len() > MAX_RECORD_BYTES {
            return Err(too_long(format!(
                "line longer than {MAX_RECORD_BYTES} bytes: expected a comment line of ordinary length"
            )));
        }
        self.line += count_newlines(raw);
        Ok(())
    }

    /// Reads the next record; returns its line, or None at the end of the input.
    fn read_record(&mut self) -> io::Result<Option<u64>> {
        if !self.skip_blank_lines()? {
            return Ok(None);
        }
        let start = self.line;
        self.n_out = 0;
        self.n_ends = 0;
        loop {
            let input = self.rdr.fill_buf()?;
            let (res, nin, nout, nend) = self.core.read_record(
                input,
                &mut self.out[self.n_out..],
                &mut self.ends[self.n_ends..],
            );
            self.line += count_newlines(&input[..nin]);
            self.rdr.consume(nin);
            self.n_out += nout;
            self.n_ends += nend;
            match res {
                csv_core::ReadRecordResult::InputEmpty => {}
                csv_core::ReadRecordResult::OutputFull => {
                    if self.out.len() >= MAX_RECORD_BYTES {
                        return Err(too_long(format!(
                            "record longer than {MAX_RECORD_BYTES} bytes (no line end, or an \
                             unterminated quote): expected rows of ordinary length"
                        )));
                    }
                    let n = (self.out.len() * 2).min(MAX_RECORD_BYTES);
                    self.out.resize(n, 0);
                }
                csv_core::ReadRecordResult::OutputEndsFull => {
                    if self.ends.len() >= MAX_FIELDS {
                        return Err(too_long(format!(
                            "more than {MAX_FIELDS} fields in one row: expected the header's columns"
                        )));
                    }
                    let n = (self.ends.len() * 2).min(MAX_FIELDS);
                    self.ends.resize(n, 0);
                }
                csv_core::ReadRecordResult::Record => return Ok(Some(start)),
                csv_core::ReadRecordResult::End => return Ok(None),
            }
        }
    }

    /// The fields of the last record; on invalid UTF-8, the field index and the error.
    fn fields(&self) -> Result<Vec<&str>, (usize, std::str::Utf8Error)> {
        let mut from = 0;
        let mut v = Vec::with_capacity(self.n_ends);
        for (i, &end) in self.ends[..self.n_ends].iter().enumerate() {
            v.push(std::str::from_utf8(&self.out[from..end]).map_err(|e| (i, e))?);
            from = end;
        }
        Ok(v)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Unit {
    None,
    Rad,
    Deg,
    M,
    Mm,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    PoseId,
    Target,
    Plane,
    Session,
    Joint(usize),
    Pos(usize),
    Point(usize),
    Rpy(usize),
    Quat(usize),
    Approach(usize),
    Temp,
    Extra(usize),
}

#[derive(Debug, Clone)]
struct Column {
    name: String,
    kind: Kind,
    unit: Unit,
}

const POS_NAMES: [&str; 3] = ["x", "y", "z"];
const POINT_NAMES: [&str; 3] = ["point_x", "point_y", "point_z"];
const RPY_NAMES: [&str; 3] = ["roll", "pitch", "yaw"];
const QUAT_NAMES: [&str; 4] = ["qw", "qx", "qy", "qz"];

const KNOWN_COLUMNS: &str = "expected q1..qN, x/y/z, roll/pitch/yaw, qw/qx/qy/qz, \
                             point_x/point_y/point_z, pose_id, target, plane, session, \
                             s1..sN, temp_c, or a user column prefixed with extra_";

/// Parses `k` in `q<k>` / `s<k>`: decimal, no sign, no leading zero.
fn index_suffix(s: &str) -> Option<usize> {
    if s.is_empty() || !s.bytes().all(|b| b.is_ascii_digit()) || s.starts_with('0') {
        return None;
    }
    s.parse().ok()
}

/// Classifies a header name (everything but `extra_`, which the caller handles).
fn classify(name: &str) -> Result<(Kind, Unit), String> {
    match name {
        "pose_id" => return Ok((Kind::PoseId, Unit::None)),
        "target" => return Ok((Kind::Target, Unit::None)),
        "plane" => return Ok((Kind::Plane, Unit::None)),
        "session" => return Ok((Kind::Session, Unit::None)),
        "temp_c" => return Ok((Kind::Temp, Unit::None)),
        _ => {}
    }
    let (base, unit) = if let Some(b) = name.strip_suffix("_rad") {
        (b, Unit::Rad)
    } else if let Some(b) = name.strip_suffix("_deg") {
        (b, Unit::Deg)
    } else if let Some(b) = name.strip_suffix("_mm") {
        (b, Unit::Mm)
    } else if let Some(b) = name.strip_suffix("_m") {
        (b, Unit::M)
    } else {
        (name, Unit::None)
    };
    let angle_unit = |kind: Kind| match unit {
        Unit::None | Unit::Rad | Unit::Deg => Ok((kind, unit)),
        _ => Err(format!(
            "'{base}' is an angle: expected no unit suffix, _rad or _deg"
        )),
    };
    if let Some(i) = POINT_NAMES.iter().position(|&n| n == base) {
        return match unit {
            Unit::None | Unit::M | Unit::Mm => Ok((Kind::Point(i), unit)),
            _ => Err(format!(
                "'{base}' is a length: expected no unit suffix, _m or _mm"
            )),
        };
    }
    if let Some(i) = POS_NAMES.iter().position(|&n| n == base) {
        return match unit {
            Unit::None | Unit::M | Unit::Mm => Ok((Kind::Pos(i), unit)),
            _ => Err(format!(
                "'{base}' is a length: expected no unit suffix, _m or _mm"
            )),
        };
    }
    if let Some(i) = RPY_NAMES.iter().position(|&n| n == base) {
        return angle_unit(Kind::Rpy(i));
    }
    if let Some(i) = QUAT_NAMES.iter().position(|&n| n == base) {
        return if unit == Unit::None {
            Ok((Kind::Quat(i), unit))
        } else {
            Err(format!(
                "quaternion component '{base}' takes no unit suffix"
            ))
        };
    }
    if let Some(k) = base.strip_prefix('q').and_then(index_suffix) {
        return angle_unit(Kind::Joint(k - 1));
    }
    if let Some(k) = base.strip_prefix('s').and_then(index_suffix) {
        return if unit == Unit::None {
            Ok((Kind::Approach(k - 1), unit))
        } else {
            Err(format!("approach direction '{base}' takes no unit suffix"))
        };
    }
    Err(format!("unknown column: {KNOWN_COLUMNS}"))
}

/// Where each value of a row goes.
struct Layout {
    columns: Vec<Column>,
    joint_cols: Vec<usize>,
    pos_cols: Option<[usize; 3]>,
    point_cols: Option<[usize; 3]>,
    rpy_cols: Option<[usize; 3]>,
    quat_cols: Option<[usize; 4]>,
    approach_cols: Option<Vec<usize>>,
    temp_col: Option<usize>,
    pose_id_col: Option<usize>,
    target_col: Option<usize>,
    plane_col: Option<usize>,
    session_col: Option<usize>,
    extra_cols: Vec<usize>,
}

struct Parser<'a> {
    source: &'a str,
    opts: &'a ReadOptions,
}

fn show(cell: &str) -> String {
    const MAX: usize = 40;
    if cell.chars().count() > MAX {
        let cut: String = cell.chars().take(MAX).collect();
        format!("{:?}…", cut)
    } else {
        format!("{cell:?}")
    }
}

fn parse_number(cell: &str) -> Result<f64, String> {
    let t = cell.trim();
    if t.is_empty() {
        return Err("expected a number, found an empty cell".into());
    }
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!("expected a finite number, found {}", show(cell))),
        Err(_) => Err(format!("expected a number, found {}", show(cell))),
    }
}

/// Refuses a joint reading, position, point or angle beyond
/// [`crate::units::MAX_MAGNITUDE_SI`] (after unit conversion) and a temperature beyond
/// ±1000 °C: finite, but not a measurement.
fn plausible(kind: Kind, v: f64) -> Result<f64, String> {
    let why = match kind {
        Kind::Joint(_) | Kind::Pos(_) | Kind::Point(_) | Kind::Rpy(_) => {
            crate::units::implausible_si(v)
        }
        Kind::Temp => (v.abs() > 1e3)
            .then(|| format!("{v} °C is implausible: expected a temperature within ±1000 °C")),
        Kind::PoseId
        | Kind::Quat(_)
        | Kind::Approach(_)
        | Kind::Extra(_)
        | Kind::Target
        | Kind::Plane
        | Kind::Session => None,
    };
    why.map_or(Ok(v), Err)
}

fn convert(v: f64, unit: Unit) -> f64 {
    match unit {
        Unit::Deg => v.to_radians(),
        Unit::Mm => v / 1000.0,
        Unit::None | Unit::Rad | Unit::M => v,
    }
}

impl<'a> Parser<'a> {
    fn new(source: &'a str, opts: &'a ReadOptions) -> Result<Self, InputError> {
        let p = Parser { source, opts };
        if opts.n_joints == 0 {
            return Err(p.err(None, None, "the robot must have at least one joint"));
        }
        if let Some(l) = &opts.joint_limits
            && l.len() != opts.n_joints
        {
            return Err(p.err(
                None,
                None,
                format!(
                    "joint limits are given for {} joints but the robot has {}",
                    l.len(),
                    opts.n_joints
                ),
            ));
        }
        Ok(p)
    }

    fn err(
        &self,
        line: Option<u64>,
        column: Option<&str>,
        reason: impl Into<String>,
    ) -> InputError {
        InputError {
            path: self.source.to_string(),
            line,
            column: column.map(str::to_string),
            reason: reason.into(),
        }
    }

    fn io_err(&self, line: Option<u64>, e: io::Error) -> InputError {
        if e.kind() == io::ErrorKind::InvalidData {
            // A record over the size caps: a property of the file, not a failed read.
            return self.err(line, None, e.to_string());
        }
        self.err(line, None, format!("read error: {e}"))
    }

    /// Refuses a field longer than [`MAX_FIELD_BYTES`], naming its column.
    fn check_field_lengths(
        &self,
        fields: &[&str],
        columns: &[Column],
        line: u64,
    ) -> Result<(), InputError> {
        match fields.iter().position(|f| f.len() > MAX_FIELD_BYTES) {
            None => Ok(()),
            Some(i) => {
                let hash = format!("#{}", i + 1);
                let name = columns.get(i).map_or(hash.as_str(), |c| c.name.as_str());
                Err(self.err(
                    Some(line),
                    Some(name),
                    format!(
                        "cell longer than {MAX_FIELD_BYTES} bytes: expected a number or a short label"
                    ),
                ))
            }
        }
    }

    fn run(&self, reader: impl Read) -> Result<MeasurementSet, InputError> {
        let mut rows = Vec::new();
        let mut set = self
            .run_with(reader, |_, row| {
                rows.push(row);
                Ok::<(), std::convert::Infallible>(())
            })
            .map_err(|e| match e {
                StreamError::Input(e) => e,
                StreamError::Row(never) => match never {},
            })?;
        rows.shrink_to_fit();
        set.rows = rows;
        Ok(set)
    }

    /// Reads the file and hands each checked row to `on_row` with the file's description
    /// (its `rows` empty, its `sha256` empty until the end), keeping no row.
    fn run_with<E>(
        &self,
        reader: impl Read,
        mut on_row: impl FnMut(&MeasurementSet, MeasurementRow) -> Result<(), E>,
    ) -> Result<MeasurementSet, StreamError<E>> {
        let hashing = HashingReader::new(reader).map_err(|e| self.io_err(None, e))?;
        let mut src = Records::new(BufReader::with_capacity(64 * 1024, hashing));

        // Preamble: comment lines ('#') and blank lines before the header.
        let mut comments = Vec::new();
        let mut raw = Vec::new();
        loop {
            let at = src.line;
            if !src
                .skip_blank_lines()
                .map_err(|e| self.io_err(Some(at), e))?
            {
                break;
            }
            let at = src.line;
            let first = src.peek().map_err(|e| self.io_err(Some(at), e))?;
            if first != Some(b'#') {
                break;
            }
            src.read_raw_line(&mut raw)
                .map_err(|e| self.io_err(Some(at), e))?;
            let content = raw.strip_suffix(b"\n").unwrap_or(&raw);
            let content = content.strip_suffix(b"\r").unwrap_or(content);
            if content.contains(&b'\r') {
                // A lone CR would end the line for the CSV records but not here, and the
                // comment could not be written back (found by fuzzing).
                return Err(self
                    .err(
                        Some(at),
                        None,
                        "comment line contains a carriage return (CR) before its end: expected \
                     one line ending in LF or CR LF",
                    )
                    .into());
            }
            match std::str::from_utf8(&content[1..]) {
                Ok(c) => comments.push(c.to_string()),
                Err(e) => {
                    return Err(self
                        .err(
                            Some(at),
                            None,
                            format!("comment is not valid UTF-8 ({e}): expected UTF-8 text"),
                        )
                        .into());
                }
            }
        }

        // Header.
        let at = src.line;
        let header_line = match src.read_record().map_err(|e| self.io_err(Some(at), e))? {
            Some(line) => line,
            None => {
                return Err(self
                    .err(
                        Some(src.line),
                        None,
                        "empty file: expected a header row (q1..qN, ...) and data rows",
                    )
                    .into());
            }
        };
        let header = src.fields().map_err(|(i, e)| {
            self.err(
                Some(header_line),
                Some(&format!("#{}", i + 1)),
                format!("column name is not valid UTF-8 ({e}): expected UTF-8 text"),
            )
        })?;
        let layout = self.layout(&header, header_line)?;
        let n_fields = layout.columns.len();

        let mut set = MeasurementSet {
            source: self.source.to_string(),
            comments,
            n_joints: self.opts.n_joints,
            rows: Vec::new(),
            extra_columns: layout
                .extra_cols
                .iter()
                .map(|&c| layout.columns[c].name.clone())
                .collect(),
            orientation_form: if layout.rpy_cols.is_some() {
                Some(OrientationForm::Rpy)
            } else if layout.quat_cols.is_some() {
                Some(OrientationForm::Quaternion)
            } else {
                None
            },
            has_position: layout.pos_cols.is_some(),
            has_point: layout.point_cols.is_some(),
            has_target: layout.target_col.is_some(),
            has_plane: layout.plane_col.is_some(),
            has_session: layout.session_col.is_some(),
            has_approach: layout.approach_cols.is_some(),
            has_temperature: layout.temp_col.is_some(),
            sha256: String::new(),
            header_line,
        };

        // Data rows.
        let mut n_rows = 0u64;
        loop {
            let at = src.line;
            let Some(line) = src.read_record().map_err(|e| self.io_err(Some(at), e))? else {
                break;
            };
            let fields = src.fields().map_err(|(i, e)| {
                let column = layout.columns.get(i).map(|c| c.name.clone());
                self.err(
                    Some(line),
                    Some(column.as_deref().unwrap_or(&format!("#{}", i + 1))),
                    format!("cell is not valid UTF-8 ({e}): expected UTF-8 text"),
                )
            })?;
            self.check_field_lengths(&fields, &layout.columns, line)?;
            let row = self.row(&layout, &fields, line, n_fields)?;
            on_row(&set, row).map_err(StreamError::Row)?;
            n_rows += 1;
        }
        if n_rows == 0 {
            return Err(self
                .err(
                    Some(header_line),
                    None,
                    "no data rows: expected at least one row after the header",
                )
                .into());
        }
        set.sha256 = src.into_inner().into_inner().finish_hex();
        Ok(set)
    }

    // Long by design: the header's rules, one per column group, in the order spec/measurements.md states them.
    fn layout(&self, header: &[&str], line: u64) -> Result<Layout, InputError> {
        let n = self.opts.n_joints;
        let at = |col: &str, reason: String| self.err(Some(line), Some(col), reason);

        let mut columns: Vec<Column> = Vec::with_capacity(header.len());
        let mut joints: Vec<Option<usize>> = vec![None; n];
        let mut pos: [Option<usize>; 3] = [None; 3];
        let mut point: [Option<usize>; 3] = [None; 3];
        let mut rpy: [Option<usize>; 3] = [None; 3];
        let mut quat: [Option<usize>; 4] = [None; 4];
        let mut approach: Vec<Option<usize>> = vec![None; n];
        let mut temp = None;
        let mut pose_id = None;
        let (mut target, mut plane, mut session) = (None, None, None);
        let mut extra_cols = Vec::new();

        for (i, raw) in header.iter().enumerate() {
            let name = raw.trim();
            if name.is_empty() {
                return Err(self.err(
                    Some(line),
                    Some(&format!("#{}", i + 1)),
                    format!("empty column name: {KNOWN_COLUMNS}"),
                ));
            }
            let (kind, unit) = if name.starts_with("extra_") {
                (Kind::Extra(extra_cols.len()), Unit::None)
            } else {
                classify(name).map_err(|r| at(name, r))?
            };
            let slot: &mut Option<usize> = match kind {
                Kind::PoseId => &mut pose_id,
                Kind::Target => &mut target,
                Kind::Plane => &mut plane,
                Kind::Session => &mut session,
                Kind::Temp => &mut temp,
                Kind::Pos(a) => &mut pos[a],
                Kind::Point(a) => &mut point[a],
                Kind::Rpy(a) => &mut rpy[a],
                Kind::Quat(a) => &mut quat[a],
                Kind::Joint(k) => {
                    if k >= n {
                        return Err(at(
                            name,
                            format!(
                                "the robot has {n} joints: expected joint columns q1..q{n} only"
                            ),
                        ));
                    }
                    &mut joints[k]
                }
                Kind::Approach(k) => {
                    if k >= n {
                        return Err(at(
                            name,
                            format!(
                                "the robot has {n} joints: expected approach columns s1..s{n} only"
                            ),
                        ));
                    }
                    &mut approach[k]
                }
                Kind::Extra(_) => {
                    if let Some(prev) = columns.iter().find(|c| c.name == name) {
                        return Err(at(
                            name,
                            format!("duplicate column (same as '{}')", prev.name),
                        ));
                    }
                    extra_cols.push(i);
                    columns.push(Column {
                        name: name.to_string(),
                        kind,
                        unit,
                    });
                    continue;
                }
            };
            if let Some(prev) = *slot {
                return Err(at(
                    name,
                    format!(
                        "duplicate column (same quantity as '{}')",
                        columns[prev].name
                    ),
                ));
            }
            *slot = Some(i);
            columns.push(Column {
                name: name.to_string(),
                kind,
                unit,
            });
        }

        // Joints: exactly q1..qN.
        let mut joint_cols = Vec::with_capacity(n);
        for (k, c) in joints.iter().enumerate() {
            match c {
                Some(c) => joint_cols.push(*c),
                None => {
                    return Err(at(
                        &format!("q{}", k + 1),
                        format!(
                            "missing required column: the robot has {n} joints, expected q1..q{n}"
                        ),
                    ));
                }
            }
        }

        // A group of columns must be all present or all absent.
        fn group<const K: usize>(
            cols: [Option<usize>; K],
            names: &[&str; K],
        ) -> Result<Option<[usize; K]>, String> {
            if cols.iter().all(Option::is_none) {
                return Ok(None);
            }
            let mut out = [0; K];
            for k in 0..K {
                match cols[k] {
                    Some(c) => out[k] = c,
                    None => return Err(names[k].to_string()),
                }
            }
            Ok(Some(out))
        }
        let pos_cols = group(pos, &POS_NAMES).map_err(|missing| {
            at(
                &missing,
                "missing column: position columns x, y, z come together".into(),
            )
        })?;
        let point_cols = group(point, &POINT_NAMES).map_err(|missing| {
            at(
                &missing,
                "missing column: point columns point_x, point_y, point_z come together".into(),
            )
        })?;
        let rpy_cols = group(rpy, &RPY_NAMES).map_err(|missing| {
            at(
                &missing,
                "missing column: orientation columns roll, pitch, yaw come together".into(),
            )
        })?;
        let quat_cols = group(quat, &QUAT_NAMES).map_err(|missing| {
            at(
                &missing,
                "missing column: quaternion columns qw, qx, qy, qz come together".into(),
            )
        })?;
        if let (Some(r), Some(q)) = (rpy_cols, quat_cols) {
            // Name the first column of the form that starts later in the header.
            let (r0, q0) = (*r.iter().min().unwrap(), *q.iter().min().unwrap());
            return Err(at(
                &columns[r0.max(q0)].name,
                "both orientation forms given (roll/pitch/yaw and qw/qx/qy/qz): expected one"
                    .into(),
            ));
        }
        let constraint_cols = target.is_some() || plane.is_some();
        if pos_cols.is_none() {
            if let (Some(c), false) = (point_cols.map(|p| p[0]), constraint_cols) {
                return Err(at(
                    "x",
                    format!(
                        "missing column: a measured point ('{}') needs its measured position (x, y, z)",
                        columns[c].name
                    ),
                ));
            }
            if let Some(c) = rpy_cols.map(|r| r[0]).or(quat_cols.map(|q| q[0])) {
                return Err(at(
                    "x",
                    format!(
                        "missing column: an orientation ('{}') needs a position (x, y, z)",
                        columns[c].name
                    ),
                ));
            }
            if self.opts.require_pose && !constraint_cols {
                return Err(at(
                    "x",
                    "missing column: measured poses are required (x, y, z, optionally \
                     roll/pitch/yaw or qw/qx/qy/qz)"
                        .into(),
                ));
            }
        }
        let approach_cols = if approach.iter().all(Option::is_none) {
            None
        } else {
            let mut v = Vec::with_capacity(n);
            for (k, c) in approach.iter().enumerate() {
                match c {
                    Some(c) => v.push(*c),
                    None => {
                        return Err(at(
                            &format!("s{}", k + 1),
                            format!("missing column: approach columns s1..s{n} come together"),
                        ));
                    }
                }
            }
            Some(v)
        };

        Ok(Layout {
            columns,
            joint_cols,
            pos_cols,
            point_cols,
            rpy_cols,
            quat_cols,
            approach_cols,
            temp_col: temp,
            pose_id_col: pose_id,
            target_col: target,
            plane_col: plane,
            session_col: session,
            extra_cols,
        })
    }

    // Long by design: one pass over a CSV row in column-group order, each error naming its line and column.
    fn row(
        &self,
        layout: &Layout,
        rec: &[&str],
        line: u64,
        n_fields: usize,
    ) -> Result<MeasurementRow, InputError> {
        let cols = &layout.columns;
        let first_is_text = matches!(
            cols[0].kind,
            Kind::PoseId | Kind::Extra(_) | Kind::Target | Kind::Plane | Kind::Session
        );
        if rec.first().is_some_and(|f| f.starts_with('#'))
            && (rec.len() != n_fields || !first_is_text)
        {
            return Err(self.err(
                Some(line),
                None,
                "comment line after the header: comments ('#') are only allowed before the header",
            ));
        }
        if rec.len() != n_fields {
            let column = cols.get(rec.len()).map(|c| c.name.as_str());
            let reason = if rec.len() < n_fields {
                format!(
                    "expected {n_fields} fields as in the header, found {} (this column is missing)",
                    rec.len()
                )
            } else {
                format!(
                    "expected {n_fields} fields as in the header, found {}",
                    rec.len()
                )
            };
            return Err(self.err(Some(line), column, reason));
        }

        let num = |c: usize| -> Result<f64, InputError> {
            let col = &cols[c];
            parse_number(rec[c])
                .map(|v| convert(v, col.unit))
                .and_then(|v| plausible(col.kind, v))
                .map_err(|r| self.err(Some(line), Some(&col.name), r))
        };

        let pose_id = match layout.pose_id_col {
            Some(c) => {
                let v = rec[c];
                if v.trim().is_empty() {
                    return Err(self.err(
                        Some(line),
                        Some(&cols[c].name),
                        "expected a pose label, found an empty cell",
                    ));
                }
                Some(v.to_string())
            }
            None => None,
        };

        let mut q_rad = Vec::with_capacity(layout.joint_cols.len());
        for (k, &c) in layout.joint_cols.iter().enumerate() {
            let v = num(c)?;
            if let (Some(limits), false) = (&self.opts.joint_limits, self.opts.allow_out_of_limits)
            {
                let (lo, hi) = limits[k];
                if !(lo..=hi).contains(&v) {
                    return Err(self.err(
                        Some(line),
                        Some(&cols[c].name),
                        format!(
                            "joint {} reading {} rad ({}°, cell {}) is outside the joint limits: \
                             expected a value within [{lo}, {hi}] rad",
                            k + 1,
                            v,
                            v.to_degrees(),
                            show(rec[c]),
                        ),
                    ));
                }
            }
            q_rad.push(v);
        }

        // Text ids: empty means "not on this row" for target/plane, never for session.
        let text = |c: Option<usize>| -> Option<(usize, String)> {
            c.and_then(|c| {
                let v = rec[c].trim();
                (!v.is_empty()).then(|| (c, v.to_string()))
            })
        };
        let target = text(layout.target_col);
        let plane = text(layout.plane_col);
        let session = match layout.session_col {
            Some(c) => match text(Some(c)) {
                Some((_, v)) => Some(v),
                None => {
                    return Err(self.err(
                        Some(line),
                        Some(&cols[c].name),
                        "expected a session id, found an empty cell",
                    ));
                }
            },
            None => None,
        };
        if let (Some((_, t)), Some((c, p))) = (&target, &plane) {
            return Err(self.err(
                Some(line),
                Some(&cols[*c].name),
                format!(
                    "the row names target {t:?} and plane {p:?}: expected one of them (a row \
                     holds its tool point at a target or on a plane)"
                ),
            ));
        }
        let constraint = target.as_ref().or(plane.as_ref());
        // Position components: each may be empty (not measured on this row).
        let mut coords = [None; 3];
        if let Some(p) = layout.pos_cols {
            for (k, &c) in p.iter().enumerate() {
                if !rec[c].trim().is_empty() {
                    coords[k] = Some(num(c)?);
                }
            }
        }
        let orientation_cells: Vec<usize> = layout
            .rpy_cols
            .map(|r| r.to_vec())
            .or(layout.quat_cols.map(|q| q.to_vec()))
            .unwrap_or_default();
        let orientation_given = orientation_cells
            .iter()
            .filter(|&&c| !rec[c].trim().is_empty())
            .count();
        if let Some((tc, id)) = constraint {
            let pose_cell = layout
                .pos_cols
                .iter()
                .flatten()
                .chain(orientation_cells.iter())
                .find(|&&c| !rec[c].trim().is_empty());
            if let Some(&c) = pose_cell {
                return Err(self.err(
                    Some(line),
                    Some(&cols[c].name),
                    format!(
                        "the row is a contact with {} {id:?} and also has a measured pose: \
                         expected an empty cell (a target or plane row has no pose columns)",
                        cols[*tc].name
                    ),
                ));
            }
        }
        let n_coords = coords.iter().flatten().count();
        let position_m = match coords {
            [Some(x), Some(y), Some(z)] => Some([x, y, z]),
            _ => None,
        };
        let partial_m = (n_coords > 0 && n_coords < 3).then_some(coords);
        if orientation_given > 0 && (orientation_given < orientation_cells.len() || n_coords < 3) {
            let c = orientation_cells
                .iter()
                .copied()
                .find(|&c| rec[c].trim().is_empty())
                .or(layout
                    .pos_cols
                    .and_then(|p| p.into_iter().find(|&c| rec[c].trim().is_empty())))
                .unwrap_or(orientation_cells[0]);
            return Err(self.err(
                Some(line),
                Some(&cols[c].name),
                "expected a number, found an empty cell (an orientation needs all its \
                 components and the full position x, y, z)",
            ));
        }
        if self.opts.require_pose && n_coords == 0 && constraint.is_none() {
            let c = layout
                .pos_cols
                .map(|p| p[0])
                .or(layout.target_col)
                .or(layout.plane_col)
                .unwrap_or(0);
            return Err(self.err(
                Some(line),
                Some(&cols[c].name),
                "expected a number, found an empty cell (the row measures nothing: give a \
                 coordinate, a target or a plane)",
            ));
        }

        // The point columns may be left empty (all three): the default, the tool origin.
        let point_m = match layout.point_cols {
            Some(p) if p.iter().all(|&c| rec[c].trim().is_empty()) => {
                if constraint.is_some() {
                    Some([0.0; 3])
                } else {
                    None
                }
            }
            Some(p) => Some([num(p[0])?, num(p[1])?, num(p[2])?]),
            None => None,
        };

        let orientation = if orientation_given == 0 {
            None
        } else if let Some(r) = layout.rpy_cols {
            Some(Orientation::Rpy {
                roll_rad: num(r[0])?,
                pitch_rad: num(r[1])?,
                yaw_rad: num(r[2])?,
            })
        } else if let Some(q) = layout.quat_cols {
            let (w, x, y, z) = (num(q[0])?, num(q[1])?, num(q[2])?, num(q[3])?);
            let norm = (w * w + x * x + y * y + z * z).sqrt();
            if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
                return Err(self.err(
                    Some(line),
                    Some(&cols[q[0]].name),
                    format!(
                        "quaternion (qw, qx, qy, qz) = ({w}, {x}, {y}, {z}) has norm {norm}: \
                         expected a unit quaternion (norm within {QUATERNION_NORM_TOLERANCE} of 1)"
                    ),
                ));
            }
            Some(if (norm - 1.0).abs() <= QUATERNION_UNIT_EPS {
                Orientation::Quaternion { w, x, y, z }
            } else {
                Orientation::Quaternion {
                    w: w / norm,
                    x: x / norm,
                    y: y / norm,
                    z: z / norm,
                }
            })
        } else {
            None
        };

        let approach = match &layout.approach_cols {
            Some(ac) => {
                let mut v = Vec::with_capacity(ac.len());
                for &c in ac {
                    let cell = rec[c];
                    let value = cell.trim().parse::<f64>().ok();
                    let s = match [-1i8, 0, 1]
                        .into_iter()
                        .find(|&k| value == Some(f64::from(k)))
                    {
                        Some(k) => k,
                        None => {
                            return Err(self.err(
                                Some(line),
                                Some(&cols[c].name),
                                format!("expected -1, 0 or 1, found {}", show(cell)),
                            ));
                        }
                    };
                    v.push(s);
                }
                Some(v)
            }
            None => None,
        };

        let temp_c = match layout.temp_col {
            Some(c) => Some(num(c)?),
            None => None,
        };

        let extras = layout
            .extra_cols
            .iter()
            .map(|&c| rec[c].to_string())
            .collect();

        Ok(MeasurementRow {
            line,
            pose_id,
            q_rad,
            position_m,
            orientation,
            point_m,
            approach,
            temp_c,
            extras,
            partial_m,
            target: target.map(|(_, v)| v),
            plane: plane.map(|(_, v)| v),
            session,
        })
    }
}

// ---------------------------------------------------------------------------------------
// Writing

/// One row of `predict` output.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseRow {
    pub pose_id: Option<String>,
    pub q_rad: Vec<f64>,
    pub position_m: [f64; 3],
    /// Unit quaternion (w, x, y, z).
    pub quaternion_wxyz: [f64; 4],
}

/// Formats a number with the shortest decimal form that reads back to the same `f64`
/// (plain notation, exponent form for very small or very large magnitudes).
pub fn format_f64(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 || (1e-5..1e16).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

fn invalid(msg: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, msg)
}

fn finite(v: f64, row: usize, column: &str) -> io::Result<String> {
    if v.is_finite() {
        Ok(format_f64(v))
    } else {
        Err(invalid(format!(
            "row {}: column '{column}': cannot write the non-finite value {v}",
            row + 1
        )))
    }
}

fn csv_io(e: csv::Error) -> io::Error {
    match e.into_kind() {
        csv::ErrorKind::Io(e) => e,
        other => io::Error::other(format!("CSV write error: {other:?}")),
    }
}

/// Writes `predict` output: `pose_id` (if `with_pose_id`), `q1..qN`, `x,y,z` [m],
/// `qw,qx,qy,qz`. Refuses non-finite values and rows of the wrong length.
pub fn write_poses_csv(
    out: impl Write,
    n_joints: usize,
    with_pose_id: bool,
    rows: &[PoseRow],
) -> io::Result<()> {
    let mut w = PosesCsvWriter::new(out, n_joints, with_pose_id)?;
    for r in rows {
        w.write(r)?;
    }
    w.finish()
}

/// [`write_poses_csv`] one row at a time, so that `predict` streams a file of any length.
#[derive(Debug)]
pub struct PosesCsvWriter<W: Write> {
    w: csv::Writer<W>,
    n_joints: usize,
    with_pose_id: bool,
    /// Rows written so far (for messages).
    rows: usize,
    rec: Vec<String>,
}

impl<W: Write> PosesCsvWriter<W> {
    /// Writes the header.
    pub fn new(out: W, n_joints: usize, with_pose_id: bool) -> io::Result<Self> {
        let mut header: Vec<String> = Vec::new();
        if with_pose_id {
            header.push("pose_id".into());
        }
        header.extend((1..=n_joints).map(|k| format!("q{k}")));
        header.extend(POS_NAMES.iter().map(|s| s.to_string()));
        header.extend(QUAT_NAMES.iter().map(|s| s.to_string()));
        let mut w = csv::WriterBuilder::new().from_writer(out);
        w.write_record(&header).map_err(csv_io)?;
        Ok(PosesCsvWriter {
            w,
            n_joints,
            with_pose_id,
            rows: 0,
            rec: Vec::with_capacity(header.len()),
        })
    }

    /// Rows written so far.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Writes one row.
    pub fn write(&mut self, r: &PoseRow) -> io::Result<()> {
        let (i, n_joints, rec) = (self.rows, self.n_joints, &mut self.rec);
        rec.clear();
        match (&r.pose_id, self.with_pose_id) {
            (Some(id), true) if !id.trim().is_empty() => rec.push(id.clone()),
            (None, false) => {}
            (_, true) => {
                return Err(invalid(format!("row {}: pose_id missing or empty", i + 1)));
            }
            (Some(_), false) => {
                return Err(invalid(format!(
                    "row {}: pose_id given but the output has no pose_id column",
                    i + 1
                )));
            }
        }
        if r.q_rad.len() != n_joints {
            return Err(invalid(format!(
                "row {}: {} joint values, expected {n_joints}",
                i + 1,
                r.q_rad.len()
            )));
        }
        for (k, &q) in r.q_rad.iter().enumerate() {
            rec.push(finite(q, i, &format!("q{}", k + 1))?);
        }
        for (&p, name) in r.position_m.iter().zip(POS_NAMES) {
            rec.push(finite(p, i, name)?);
        }
        for (&c, name) in r.quaternion_wxyz.iter().zip(QUAT_NAMES) {
            rec.push(finite(c, i, name)?);
        }
        self.w.write_record(&*rec).map_err(csv_io)?;
        self.rows += 1;
        Ok(())
    }

    /// Flushes the output.
    pub fn finish(mut self) -> io::Result<()> {
        self.w.flush()
    }
}

/// Writes a whole measurement set so that it reads back identically (apart from `line`
/// numbers, `source` and `sha256`): comments, `pose_id`, `q1..qN` [rad], `x,y,z` [m],
/// orientation in the set's form (`roll,pitch,yaw` [rad] or `qw,qx,qy,qz`),
/// `point_x,point_y,point_z` [m], `s1..sN`, `temp_c`, then the `extra_` columns.
// Long by design: the column groups of spec/measurements.md in order, header and rows side by side.
pub fn write_measurements_csv(mut out: impl Write, set: &MeasurementSet) -> io::Result<()> {
    let n = set.n_joints;
    for c in &set.comments {
        if c.contains(['\n', '\r']) {
            return Err(invalid(format!("comment {c:?} spans several lines")));
        }
        writeln!(out, "#{c}")?;
    }
    for e in &set.extra_columns {
        if !e.starts_with("extra_") {
            return Err(invalid(format!(
                "extra column '{e}' does not start with 'extra_'"
            )));
        }
    }
    let with_pose_id = set.has_pose_id();

    let mut header: Vec<String> = Vec::new();
    if with_pose_id {
        header.push("pose_id".into());
    }
    header.extend((1..=n).map(|k| format!("q{k}")));
    if set.has_position {
        header.extend(POS_NAMES.iter().map(|s| s.to_string()));
    }
    match set.orientation_form {
        Some(OrientationForm::Rpy) => header.extend(RPY_NAMES.iter().map(|s| s.to_string())),
        Some(OrientationForm::Quaternion) => {
            header.extend(QUAT_NAMES.iter().map(|s| s.to_string()))
        }
        None => {}
    }
    if set.has_point {
        header.extend(POINT_NAMES.iter().map(|s| s.to_string()));
    }
    for (has, name) in [
        (set.has_target, "target"),
        (set.has_plane, "plane"),
        (set.has_session, "session"),
    ] {
        if has {
            header.push(name.into());
        }
    }
    if set.has_approach {
        header.extend((1..=n).map(|k| format!("s{k}")));
    }
    if set.has_temperature {
        header.push("temp_c".into());
    }
    header.extend(set.extra_columns.iter().cloned());

    let mut w = csv::WriterBuilder::new().from_writer(out);
    w.write_record(&header).map_err(csv_io)?;
    let mut rec: Vec<String> = Vec::with_capacity(header.len());
    for (i, r) in set.rows.iter().enumerate() {
        let bad = |what: &str| invalid(format!("row {} (line {}): {what}", i + 1, r.line));
        rec.clear();
        match (&r.pose_id, with_pose_id) {
            (Some(id), true) if !id.trim().is_empty() => rec.push(id.clone()),
            (None, false) => {}
            _ => return Err(bad("pose_id empty or present in some rows only")),
        }
        if r.q_rad.len() != n {
            return Err(bad(&format!(
                "{} joint values, expected {n}",
                r.q_rad.len()
            )));
        }
        for (k, &q) in r.q_rad.iter().enumerate() {
            rec.push(finite(q, i, &format!("q{}", k + 1))?);
        }
        let coords = match (r.position_m, r.partial_m) {
            (Some(p), None) => Some(p.map(Some)),
            (None, Some(c)) => Some(c),
            (None, None) => None,
            (Some(_), Some(_)) => return Err(bad("both position_m and partial_m")),
        };
        match (coords, set.has_position) {
            (Some(p), true) => {
                for (a, v) in p.iter().enumerate() {
                    match v {
                        Some(v) => rec.push(finite(*v, i, POS_NAMES[a])?),
                        None => rec.push(String::new()),
                    }
                }
            }
            // Empty cells: a row that measures no coordinate (contact or joint-only row).
            (None, true) => rec.extend(std::iter::repeat_n(String::new(), 3)),
            (None, false) => {}
            _ => return Err(bad("position does not match has_position")),
        }
        match (r.orientation, set.orientation_form) {
            (
                Some(Orientation::Rpy {
                    roll_rad,
                    pitch_rad,
                    yaw_rad,
                }),
                Some(OrientationForm::Rpy),
            ) => {
                for (a, v) in [roll_rad, pitch_rad, yaw_rad].into_iter().enumerate() {
                    rec.push(finite(v, i, RPY_NAMES[a])?);
                }
            }
            (Some(Orientation::Quaternion { w, x, y, z }), Some(OrientationForm::Quaternion)) => {
                for (a, v) in [w, x, y, z].into_iter().enumerate() {
                    rec.push(finite(v, i, QUAT_NAMES[a])?);
                }
            }
            (None, None) => {}
            (None, Some(f)) => {
                let k = if f == OrientationForm::Rpy { 3 } else { 4 };
                rec.extend(std::iter::repeat_n(String::new(), k));
            }
            _ => return Err(bad("orientation does not match orientation_form")),
        }
        match (r.point_m, set.has_point) {
            (Some(p), true) => {
                for (a, &v) in p.iter().enumerate() {
                    rec.push(finite(v, i, POINT_NAMES[a])?);
                }
            }
            (None, true) => rec.extend(std::iter::repeat_n(String::new(), 3)),
            (None, false) => {}
            _ => return Err(bad("point does not match has_point")),
        }
        for (v, has, name) in [
            (&r.target, set.has_target, "target"),
            (&r.plane, set.has_plane, "plane"),
            (&r.session, set.has_session, "session"),
        ] {
            match (v, has) {
                (Some(id), true) if !id.trim().is_empty() && id.trim() == id => {
                    rec.push(id.clone())
                }
                (None, true) if name != "session" => rec.push(String::new()),
                (None, false) => {}
                _ => return Err(bad(&format!("{name} does not match has_{name}"))),
            }
        }
        match (&r.approach, set.has_approach) {
            (Some(s), true) if s.len() == n => {
                for &v in s {
                    if !(-1..=1).contains(&v) {
                        return Err(bad(&format!("approach value {v} is not -1, 0 or 1")));
                    }
                    rec.push(v.to_string());
                }
            }
            (None, false) => {}
            _ => return Err(bad("approach does not match has_approach / n_joints")),
        }
        match (r.temp_c, set.has_temperature) {
            (Some(t), true) => rec.push(finite(t, i, "temp_c")?),
            (None, false) => {}
            _ => return Err(bad("temp_c does not match has_temperature")),
        }
        if r.extras.len() != set.extra_columns.len() {
            return Err(bad("number of extras does not match extra_columns"));
        }
        rec.extend(r.extras.iter().cloned());
        w.write_record(&rec).map_err(csv_io)?;
    }
    w.flush()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    const SPEC_EXAMPLE: &str = "# robot: aria\n\
        # instrument: motion capture, 0.1 mm\n\
        pose_id,q1,q2,q3,q4,q5,q6,x,y,z,roll_deg,pitch_deg,yaw_deg\n\
        1,0.4813,0.7750,-1.0383,3.6605,1.1053,-2.8499,0.566,0.354,0.235,-150,0,0\n";

    fn opts(n: usize) -> ReadOptions {
        ReadOptions::new(n)
    }

    fn parse(s: &str, n: usize) -> Result<MeasurementSet, InputError> {
        parse_measurements(s.as_bytes(), "data.csv", &opts(n))
    }

    fn parse_with(s: &str, o: &ReadOptions) -> Result<MeasurementSet, InputError> {
        parse_measurements(s.as_bytes(), "data.csv", o)
    }

    #[track_caller]
    fn rejects(s: &str, o: &ReadOptions, line: Option<u64>, column: Option<&str>, words: &str) {
        let e = parse_with(s, o).expect_err("input should be rejected");
        assert_eq!(e.path, "data.csv", "{e}");
        assert_eq!(e.line, line, "{e}");
        assert_eq!(e.column.as_deref(), column, "{e}");
        assert!(
            e.reason.contains(words),
            "reason {:?} lacks {words:?}",
            e.reason
        );
    }

    /// Regression (fuzz/measurements_csv): a comment holding a lone CR was accepted but
    /// could not be written back; it is now refused with its line.
    #[test]
    fn comment_with_a_lone_carriage_return_is_refused() {
        let text = "#\rh\nq1,q2,q3,q4,q5,q6,x,y,z\n6,9,6,3,6,1,6,6,6";
        rejects(text, &opts(6), Some(1), None, "carriage return");
        // CR LF line ends stay fine.
        let m = parse("# a\r\n# b\r\nq1\r\n0.5\r\n", 1).unwrap();
        assert_eq!(m.comments, vec![" a", " b"]);
    }

    #[test]
    fn point_columns_read_write_and_refusals() {
        let text = "q1,q2,x,y,z,point_x_mm,point_y_mm,point_z_mm\n0.1,0.2,1,2,3,10,-20,30\n";
        let set = parse(text, 2).expect("parse");
        assert!(set.has_point);
        assert_eq!(set.rows[0].point_m, Some([0.01, -0.02, 0.03]));
        assert!(set.rows[0].orientation.is_none());
        let mut out = Vec::new();
        write_measurements_csv(&mut out, &set).expect("write");
        let back = parse(std::str::from_utf8(&out).unwrap(), 2).expect("reparse");
        assert_eq!(back.rows[0].point_m, set.rows[0].point_m);
        let o = opts(2);
        rejects(
            "q1,q2,x,y,z,point_x,point_y\n0,0,1,2,3,0,0\n",
            &o,
            Some(1),
            Some("point_z"),
            "come together",
        );
        rejects(
            "q1,q2,point_x,point_y,point_z\n0,0,1,2,3\n",
            &o,
            Some(1),
            Some("x"),
            "needs its measured position",
        );
        rejects(
            "q1,q2,x,y,z,point_x_deg,point_y,point_z\n0,0,1,2,3,0,0,0\n",
            &o,
            Some(1),
            Some("point_x_deg"),
            "is a length",
        );
    }

    /// Target, plane and session columns, empty position components; round trip.
    #[test]
    fn contact_rows_partial_coordinates_and_sessions() {
        let text = "q1,q2,x,y,z,roll,pitch,yaw,point_x_mm,point_y_mm,point_z_mm,target,plane,session\n\
                    0.1,0.2,,,,,,,0,0,50,s0,,loc1\n\
                    0.3,0.4,,,,,,,0,0,50,s0,,loc1\n\
                    0.5,0.6,,,,,,,,,,,table,loc2\n\
                    0.7,0.8,0.25,,,,,,0,0,0,,,loc2\n\
                    0.9,1.0,1,2,3,0,0,0,,,,,,loc2\n";
        let mut o = opts(2);
        o.require_pose = true;
        let set = parse_with(text, &o).expect("parse");
        assert!(set.has_target && set.has_plane && set.has_session);
        let r = &set.rows;
        assert_eq!(r[0].target.as_deref(), Some("s0"));
        assert_eq!(r[0].point_m, Some([0.0, 0.0, 0.05]));
        assert!(r[0].position_m.is_none() && r[0].orientation.is_none());
        assert_eq!(r[2].plane.as_deref(), Some("table"));
        assert_eq!(r[2].point_m, Some([0.0; 3]));
        assert_eq!(r[3].partial_m, Some([Some(0.25), None, None]));
        assert_eq!(r[3].point_m, Some([0.0; 3]));
        assert!(r[3].position_m.is_none());
        assert_eq!(r[4].position_m, Some([1.0, 2.0, 3.0]));
        assert_eq!(r[4].session.as_deref(), Some("loc2"));
        let mut out = Vec::new();
        write_measurements_csv(&mut out, &set).expect("write");
        let back = parse_with(std::str::from_utf8(&out).unwrap(), &o).expect("reparse");
        assert_eq!(back.rows.len(), set.rows.len());
        for (a, b) in back.rows.iter().zip(&set.rows) {
            assert_eq!(
                (&a.target, &a.plane, &a.session),
                (&b.target, &b.plane, &b.session)
            );
            assert_eq!(
                (a.position_m, a.partial_m, a.point_m),
                (b.position_m, b.partial_m, b.point_m)
            );
        }
    }

    #[test]
    fn contact_row_refusals_name_line_and_column() {
        let mut o = opts(2);
        o.require_pose = true;
        let h = "q1,q2,x,y,z,roll,pitch,yaw,target,plane,session\n";
        // A pose and a target on one row.
        rejects(
            &format!("{h}0,0,,,,,,,t,,a\n0,0,1,,,,,,t,,a\n"),
            &o,
            Some(3),
            Some("x"),
            "also has a measured pose",
        );
        rejects(
            &format!("{h}0,0,,,,,0.1,,t,,a\n"),
            &o,
            Some(2),
            Some("pitch"),
            "also has a measured pose",
        );
        // A target and a plane on one row.
        rejects(
            &format!("{h}0,0,,,,,,,t,p,a\n"),
            &o,
            Some(2),
            Some("plane"),
            "expected one of them",
        );
        // An empty session id.
        rejects(
            &format!("{h}0,0,,,,,,,t,,\n"),
            &o,
            Some(2),
            Some("session"),
            "session id",
        );
        // An orientation without the full position.
        rejects(
            &format!("{h}0,0,1,2,,0,0,0,,,a\n"),
            &o,
            Some(2),
            Some("z"),
            "full position",
        );
        // A row that measures nothing where poses are required.
        rejects(
            &format!("{h}0,0,,,,,,,,,a\n"),
            &o,
            Some(2),
            Some("x"),
            "measures nothing",
        );
    }

    /// Two joints, full RPY pose; a handy base for rejection tests.
    const H2: &str = "q1,q2,x,y,z,roll,pitch,yaw\n";

    // ---------------------------------------------------------------- happy paths

    #[test]
    fn reads_spec_example() {
        let m = parse(SPEC_EXAMPLE, 6).unwrap();
        assert_eq!(m.source, "data.csv");
        assert_eq!(
            m.comments,
            vec![" robot: aria", " instrument: motion capture, 0.1 mm"]
        );
        assert_eq!(m.n_joints, 6);
        assert_eq!(m.rows.len(), 1);
        assert_eq!(m.orientation_form, Some(OrientationForm::Rpy));
        assert!(m.has_position && !m.has_approach && !m.has_temperature);
        assert!(m.has_pose_id());
        assert!(m.extra_columns.is_empty());
        let r = &m.rows[0];
        assert_eq!(r.line, 4);
        assert_eq!(r.pose_id.as_deref(), Some("1"));
        assert_eq!(
            r.q_rad,
            vec![0.4813, 0.7750, -1.0383, 3.6605, 1.1053, -2.8499]
        );
        assert_eq!(r.position_m, Some([0.566, 0.354, 0.235]));
        assert_eq!(
            r.orientation,
            Some(Orientation::Rpy {
                roll_rad: (-150f64).to_radians(),
                pitch_rad: 0.0,
                yaw_rad: 0.0
            })
        );
        assert_eq!(r.approach, None);
        assert_eq!(r.temp_c, None);
        assert_eq!(
            m.sha256,
            "92414770f6615aa46c1a758ead009e49e209bfc3e061aae5ee4869d88fb5f969"
        );
    }

    #[test]
    fn converts_deg_and_mm() {
        let m = parse(
            "q1_deg,q2_rad,q3,q4_deg,x_mm,y_m,z,roll_deg,pitch_rad,yaw\n\
             90,0.5,0.25,-180,566,0.354,235,45,0.25,-0.5\n",
            4,
        )
        .unwrap();
        let r = &m.rows[0];
        assert_eq!(r.q_rad, vec![PI / 2.0, 0.5, 0.25, -PI]);
        assert_eq!(r.position_m, Some([0.566, 0.354, 235.0]));
        assert_eq!(
            r.orientation,
            Some(Orientation::Rpy {
                roll_rad: PI / 4.0,
                pitch_rad: 0.25,
                yaw_rad: -0.5
            })
        );
    }

    #[test]
    fn reads_quaternion_form_and_normalises() {
        let m = parse(
            "q1,x,y,z,qw,qx,qy,qz\n\
             0.1,1,2,3,1,0,0,0\n\
             0.2,1,2,3,0.5,0.5,0.5,0.5\n\
             0.3,1,2,3,1.0000005,0,0,0\n\
             0.4,1,2,3,0,0.6,0,0.8000004\n",
            1,
        )
        .unwrap();
        assert_eq!(m.orientation_form, Some(OrientationForm::Quaternion));
        let q = |i: usize| match m.rows[i].orientation {
            Some(Orientation::Quaternion { w, x, y, z }) => [w, x, y, z],
            other => panic!("{other:?}"),
        };
        assert_eq!(q(0), [1.0, 0.0, 0.0, 0.0]);
        assert_eq!(q(1), [0.5, 0.5, 0.5, 0.5]);
        assert_eq!(q(2), [1.0, 0.0, 0.0, 0.0]);
        let v = q(3);
        let norm = v.iter().map(|c| c * c).sum::<f64>().sqrt();
        assert!((norm - 1.0).abs() < 1e-15, "{norm}");
        assert!(v[3] < 0.8000004 && v[3] > 0.8);
    }

    #[test]
    fn columns_in_any_order_with_all_optional_columns() {
        let m = parse(
            "extra_note,temp_c,s2,yaw,z,q2,pitch,s1,y,pose_id,roll,x,q1,extra_op\n\
             \"a, b\",21.5,-1,3,0.3,0.2,2,1,0.2,P7,1,0.1,0.1,ann\n\
             ,22,0,3,0.3,0.2,2,+1,0.2,P7,1,0.1,0.1,\n",
            2,
        )
        .unwrap();
        assert_eq!(m.extra_columns, vec!["extra_note", "extra_op"]);
        assert!(m.has_approach && m.has_temperature && m.has_position);
        let r = &m.rows[0];
        assert_eq!(r.pose_id.as_deref(), Some("P7"));
        assert_eq!(r.q_rad, vec![0.1, 0.2]);
        assert_eq!(r.position_m, Some([0.1, 0.2, 0.3]));
        assert_eq!(
            r.orientation,
            Some(Orientation::Rpy {
                roll_rad: 1.0,
                pitch_rad: 2.0,
                yaw_rad: 3.0
            })
        );
        assert_eq!(r.approach, Some(vec![1, -1]));
        assert_eq!(r.temp_c, Some(21.5));
        assert_eq!(r.extras, vec!["a, b", "ann"]);
        assert_eq!(m.rows[1].approach, Some(vec![1, 0]));
        assert_eq!(m.rows[1].extras, vec!["", ""]);
        assert_eq!(m.rows[1].line, 3);
    }

    #[test]
    fn joint_only_and_position_only_are_valid() {
        let m = parse("q1,q2\n0.1,0.2\n", 2).unwrap();
        assert!(!m.has_position && m.orientation_form.is_none());
        assert_eq!(m.rows[0].position_m, None);

        let o = ReadOptions {
            require_pose: true,
            ..opts(2)
        };
        let m = parse_with("q1,q2,x_mm,y_mm,z_mm\n0.1,0.2,1,2,3\n", &o).unwrap();
        assert!(m.has_position && m.orientation_form.is_none());
        assert_eq!(m.rows[0].position_m, Some([0.001, 0.002, 0.003]));
        assert_eq!(m.rows[0].orientation, None);
    }

    #[test]
    fn line_numbers_count_comments_blank_lines_crlf_and_quoted_newlines() {
        let s =
            "\u{feff}# a\r\n\r\n#b\r\nq1,extra_t\r\n0.1,x\r\n\r\n0.2,\"two\nlines\"\r\n0.3,y\r\n";
        let m = parse(s, 1).unwrap();
        assert_eq!(m.comments, vec![" a", "b"]);
        let lines: Vec<u64> = m.rows.iter().map(|r| r.line).collect();
        assert_eq!(lines, vec![5, 7, 9]);
        assert_eq!(m.rows[1].extras, vec!["two\nlines"]);
        let lf = parse("q1\n1\n\n\n2\n\n", 1).unwrap();
        assert_eq!(
            lf.rows.iter().map(|r| r.line).collect::<Vec<_>>(),
            vec![2, 5]
        );
        // Errors after a multi-line cell point at the right line.
        let e = parse("q1,extra_a\n1,\"a\n\nb\"\r\n\r\nx,b\n", 1).unwrap_err();
        assert_eq!((e.line, e.column.as_deref()), (Some(6), Some("q1")), "{e}");
        // The hash covers the raw bytes, byte-order mark included.
        assert_eq!(m.sha256, hex(&Sha256::digest(s.as_bytes())));
    }

    /// Hands out one byte per read: exercises the BOM and buffering logic.
    struct Trickle<'a>(&'a [u8]);
    impl Read for Trickle<'_> {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            if self.0.is_empty() || buf.is_empty() {
                return Ok(0);
            }
            buf[0] = self.0[0];
            self.0 = &self.0[1..];
            Ok(1)
        }
    }

    #[test]
    fn byte_by_byte_reader_gives_same_result() {
        let whole = parse(SPEC_EXAMPLE, 6).unwrap();
        let trickled =
            parse_measurements(Trickle(SPEC_EXAMPLE.as_bytes()), "data.csv", &opts(6)).unwrap();
        assert_eq!(whole, trickled);
        let bom = format!("\u{feff}{SPEC_EXAMPLE}");
        let m = parse_measurements(Trickle(bom.as_bytes()), "data.csv", &opts(6)).unwrap();
        assert_eq!(m.rows, whole.rows);
        assert_eq!(m.comments, whole.comments);
        assert_ne!(m.sha256, whole.sha256);
    }

    #[test]
    fn reads_from_a_file_and_streams_many_rows() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.csv");
        let mut f = io::BufWriter::new(File::create(&path).unwrap());
        writeln!(f, "# big").unwrap();
        writeln!(f, "q1,q2,x,y,z,qw,qx,qy,qz").unwrap();
        for i in 0..50_000 {
            writeln!(
                f,
                "{},{},1,2,3,1,0,0,0",
                i as f64 * 1e-5,
                -(i as f64) * 1e-5
            )
            .unwrap();
        }
        drop(f);
        let m = read_measurements(&path, &opts(2)).unwrap();
        assert_eq!(m.rows.len(), 50_000);
        assert_eq!(m.rows[49_999].line, 50_002);
        assert_eq!(m.source, path.display().to_string());
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(m.sha256, hex(&Sha256::digest(&bytes)));
    }

    // ---------------------------------------------------------------- rejections

    #[test]
    fn rejects_missing_file() {
        let e = read_measurements(Path::new("/nonexistent/d.csv"), &opts(1)).unwrap_err();
        assert_eq!(e.path, "/nonexistent/d.csv");
        assert_eq!(e.line, None);
        assert!(e.reason.contains("cannot open"), "{e}");
    }

    #[test]
    fn error_display_names_file_line_and_column() {
        let e = parse("q1,q2,q3\n1,2,3\n1,2,abc\n", 3).unwrap_err();
        assert_eq!(
            e.to_string(),
            "data.csv:3: column 'q3': expected a number, found \"abc\""
        );
        let e = parse("", 3).unwrap_err();
        assert!(e.to_string().starts_with("data.csv:1: empty file"), "{e}");
        let e = InputError {
            path: "a.csv".into(),
            line: None,
            column: None,
            reason: "r".into(),
        };
        assert_eq!(e.to_string(), "a.csv: r");
        let _: &dyn std::error::Error = &e;
    }

    #[test]
    fn rejects_unknown_column() {
        rejects(
            "q1,foo\n1,2\n",
            &opts(1),
            Some(1),
            Some("foo"),
            "unknown column",
        );
        rejects(
            "#c\nq1,Q2\n1,2\n",
            &opts(2),
            Some(2),
            Some("Q2"),
            "unknown column",
        );
        rejects(
            "q1,q01\n1,2\n",
            &opts(2),
            Some(1),
            Some("q01"),
            "unknown column",
        );
        rejects(
            "q0,q1\n1,2\n",
            &opts(1),
            Some(1),
            Some("q0"),
            "unknown column",
        );
        rejects(
            "q1,,q2\n1,2,3\n",
            &opts(2),
            Some(1),
            Some("#2"),
            "empty column name",
        );
    }

    #[test]
    fn rejects_wrong_unit_suffix() {
        rejects(
            "q1,x_deg,y,z\n1,2,3,4\n",
            &opts(1),
            Some(1),
            Some("x_deg"),
            "length",
        );
        rejects("q1_mm\n1\n", &opts(1), Some(1), Some("q1_mm"), "angle");
        rejects(
            "q1,s1_deg\n1,1\n",
            &opts(1),
            Some(1),
            Some("s1_deg"),
            "no unit",
        );
        rejects(
            "q1,x,y,z,qw_rad,qx,qy,qz\n1,1,1,1,1,0,0,0\n",
            &opts(1),
            Some(1),
            Some("qw_rad"),
            "no unit",
        );
    }

    #[test]
    fn rejects_extra_joint_column() {
        rejects(
            "q1,q2,q3,q4,q5,q6,q7\n1,1,1,1,1,1,1\n",
            &opts(6),
            Some(1),
            Some("q7"),
            "expected joint columns q1..q6",
        );
        rejects("q1,s1,s2\n1,1,1\n", &opts(1), Some(1), Some("s2"), "s1..s1");
    }

    #[test]
    fn rejects_missing_joint_column() {
        rejects(
            "q1,q2,q4,q5,q6\n1,1,1,1,1\n",
            &opts(6),
            Some(1),
            Some("q3"),
            "missing required column",
        );
        rejects("x,y,z\n1,1,1\n", &opts(2), Some(1), Some("q1"), "missing");
    }

    #[test]
    fn rejects_duplicate_columns() {
        rejects(
            "q1,x,y,z,x_mm\n1,1,1,1,1\n",
            &opts(1),
            Some(1),
            Some("x_mm"),
            "duplicate",
        );
        rejects(
            "q1_deg,q1\n1,1\n",
            &opts(1),
            Some(1),
            Some("q1"),
            "duplicate",
        );
        rejects(
            "q1,temp_c,temp_c\n1,1,1\n",
            &opts(1),
            Some(1),
            Some("temp_c"),
            "duplicate",
        );
        rejects(
            "q1,extra_a,extra_a\n1,1,1\n",
            &opts(1),
            Some(1),
            Some("extra_a"),
            "duplicate",
        );
        rejects(
            "pose_id,q1,pose_id\na,1,b\n",
            &opts(1),
            Some(1),
            Some("pose_id"),
            "duplicate",
        );
    }

    #[test]
    fn rejects_incomplete_groups() {
        rejects(
            "q1,x,y\n1,1,1\n",
            &opts(1),
            Some(1),
            Some("z"),
            "x, y, z come together",
        );
        rejects(
            "q1,x,y,z,roll,yaw\n1,1,1,1,1,1\n",
            &opts(1),
            Some(1),
            Some("pitch"),
            "roll, pitch, yaw",
        );
        rejects(
            "q1,x,y,z,qw,qx,qy\n1,1,1,1,1,0,0\n",
            &opts(1),
            Some(1),
            Some("qz"),
            "qw, qx, qy, qz",
        );
        rejects(
            "q1,q2,s2\n1,1,1\n",
            &opts(2),
            Some(1),
            Some("s1"),
            "s1..s2 come together",
        );
    }

    #[test]
    fn rejects_both_orientation_forms() {
        rejects(
            "q1,x,y,z,roll,pitch,yaw,qw,qx,qy,qz\n1,1,1,1,0,0,0,1,0,0,0\n",
            &opts(1),
            Some(1),
            Some("qw"),
            "both orientation forms",
        );
        rejects(
            "q1,x,y,z,qx,qw,qy,qz,yaw,pitch,roll\n1,1,1,1,0,1,0,0,0,0,0\n",
            &opts(1),
            Some(1),
            Some("yaw"),
            "both orientation forms",
        );
    }

    #[test]
    fn rejects_orientation_without_position() {
        rejects(
            "q1,roll,pitch,yaw\n1,0,0,0\n",
            &opts(1),
            Some(1),
            Some("x"),
            "needs a position",
        );
        rejects(
            "q1,qw,qx,qy,qz\n1,1,0,0,0\n",
            &opts(1),
            Some(1),
            Some("x"),
            "needs a position",
        );
    }

    #[test]
    fn require_pose_rejects_joint_only_data() {
        let o = ReadOptions {
            require_pose: true,
            ..opts(2)
        };
        rejects(
            "#c\nq1,q2\n1,2\n",
            &o,
            Some(2),
            Some("x"),
            "measured poses are required",
        );
    }

    #[test]
    fn rejects_non_numbers() {
        let o = opts(2);
        rejects(
            &format!("{H2}1,2,3,4,5,6,7,8\n1,2,3,4,5,six,7,8\n"),
            &o,
            Some(3),
            Some("roll"),
            "expected a number, found \"six\"",
        );
        rejects(
            &format!("{H2}1,2,3,,5,6,7,8\n"),
            &o,
            Some(2),
            Some("y"),
            "empty cell",
        );
        rejects(
            "q1,q2\n1,2\n1,0x10\n",
            &o,
            Some(3),
            Some("q2"),
            "expected a number",
        );
        rejects(
            "q1,q2\n1,\"1,5\"\n",
            &o,
            Some(2),
            Some("q2"),
            "expected a number",
        );
    }

    #[test]
    fn rejects_nan_and_infinity() {
        for bad in [
            "NaN",
            "nan",
            "inf",
            "-inf",
            "infinity",
            "+Infinity",
            "1e999",
        ] {
            rejects(
                &format!("q1,temp_c\n1,20\n1,{bad}\n"),
                &opts(1),
                Some(3),
                Some("temp_c"),
                "expected a finite number",
            );
        }
        rejects("q1_deg\nNaN\n", &opts(1), Some(2), Some("q1_deg"), "finite");
    }

    #[test]
    fn rejects_bad_approach_values() {
        for bad in ["2", "0.5", "-2", "x", ""] {
            rejects(
                &format!("q1,q2,s1,s2\n1,1,1,-1\n1,1,0,{bad}\n"),
                &opts(2),
                Some(3),
                Some("s2"),
                "expected -1, 0 or 1",
            );
        }
    }

    #[test]
    fn rejects_non_unit_quaternion() {
        let h = "q1,x,y,z,qw,qx,qy,qz\n";
        rejects(
            &format!("{h}1,1,1,1,1.1,0,0,0\n"),
            &opts(1),
            Some(2),
            Some("qw"),
            "expected a unit quaternion",
        );
        rejects(
            &format!("{h}1,1,1,1,1,0,0,0\n1,1,1,1,0,0,0,0\n"),
            &opts(1),
            Some(3),
            Some("qw"),
            "norm 0",
        );
        rejects(
            &format!("{h}1,1,1,1,1.000002,0,0,0\n"),
            &opts(1),
            Some(2),
            Some("qw"),
            "unit quaternion",
        );
    }

    #[test]
    fn joint_limits_are_inclusive_and_enforced() {
        let lim = ReadOptions {
            joint_limits: Some(vec![(-1.0, 1.0), (-PI / 2.0, PI / 2.0)]),
            ..opts(2)
        };
        // On the limits: accepted (q2 in degrees converts exactly to ±π/2).
        let m = parse_with("q1,q2_deg\n1,90\n-1,-90\n", &lim).unwrap();
        assert_eq!(m.rows[1].q_rad, vec![-1.0, -PI / 2.0]);
        rejects(
            "q1,q2_deg\n1,90\n0,90.001\n",
            &lim,
            Some(3),
            Some("q2_deg"),
            "outside the joint limits",
        );
        rejects(
            "q1,q2\n-1.0000001,0\n",
            &lim,
            Some(2),
            Some("q1"),
            "[-1, 1]",
        );
        let allow = ReadOptions {
            allow_out_of_limits: true,
            ..lim.clone()
        };
        let m = parse_with("q1,q2\n5,-5\n", &allow).unwrap();
        assert_eq!(m.rows[0].q_rad, vec![5.0, -5.0]);
    }

    #[test]
    fn rejects_inconsistent_options() {
        rejects("q1\n1\n", &opts(0), None, None, "at least one joint");
        let o = ReadOptions {
            joint_limits: Some(vec![(-1.0, 1.0)]),
            ..opts(2)
        };
        rejects(
            "q1,q2\n1,1\n",
            &o,
            None,
            None,
            "limits are given for 1 joints",
        );
    }

    #[test]
    fn rejects_empty_file_and_header_only() {
        rejects("", &opts(1), Some(1), None, "empty file");
        rejects("\n\n", &opts(1), Some(3), None, "empty file");
        rejects(
            "# only\n# comments\n",
            &opts(1),
            Some(3),
            None,
            "empty file",
        );
        rejects("# c\nq1,q2\n", &opts(2), Some(2), None, "no data rows");
        rejects("q1,q2\n\n\n", &opts(2), Some(1), None, "no data rows");
    }

    #[test]
    fn rejects_wrong_number_of_fields() {
        rejects(
            &format!("{H2}1,2,3,4,5,6,7,8\n1,2,3,4,5,6,7\n"),
            &opts(2),
            Some(3),
            Some("yaw"),
            "expected 8 fields as in the header, found 7",
        );
        rejects(
            &format!("{H2}1,2,3,4,5,6,7,8,9\n"),
            &opts(2),
            Some(2),
            None,
            "expected 8 fields as in the header, found 9",
        );
    }

    #[test]
    fn rejects_comment_after_header() {
        rejects(
            "q1,q2\n1,2\n# late\n3,4\n",
            &opts(2),
            Some(3),
            None,
            "only allowed before",
        );
        // With a text first column a '#'-label is data, but a comment line still fails.
        rejects(
            "pose_id,q1\n#1,2\n# note\n",
            &opts(1),
            Some(3),
            None,
            "only allowed before",
        );
        let m = parse("pose_id,q1\n#1,2\n", 1).unwrap();
        assert_eq!(m.rows[0].pose_id.as_deref(), Some("#1"));
    }

    #[test]
    fn rejects_empty_pose_id() {
        rejects(
            "pose_id,q1\na,1\n ,2\n",
            &opts(1),
            Some(3),
            Some("pose_id"),
            "pose label",
        );
    }

    #[test]
    fn rejects_invalid_utf8() {
        let mut bytes = b"q1,extra_n\n1,ok\n2,".to_vec();
        bytes.extend_from_slice(&[0xff, 0xfe]);
        bytes.push(b'\n');
        let e = parse_measurements(&bytes[..], "data.csv", &opts(1)).unwrap_err();
        assert_eq!(e.line, Some(3), "{e}");
        assert_eq!(e.column.as_deref(), Some("extra_n"), "{e}");
        assert!(e.reason.contains("UTF-8"), "{e}");

        let mut bytes = b"#ok\n# bad \xff\nq1\n1\n".to_vec();
        bytes.push(b'\n');
        let e = parse_measurements(&bytes[..], "data.csv", &opts(1)).unwrap_err();
        assert_eq!(e.line, Some(2), "{e}");
        assert!(e.reason.contains("UTF-8"), "{e}");
    }

    // ---------------------------------------------------------------- writing

    /// Deterministic generator of awkward doubles.
    struct Gen(u64);
    impl Gen {
        fn next_u64(&mut self) -> u64 {
            // xorshift64*
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
        }
        fn unit(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
        }
        /// Any finite double the readers accept (magnitude at most
        /// `units::MAX_MAGNITUDE_SI`): random bit patterns, special values, plain decimals.
        fn any(&mut self) -> f64 {
            match self.next_u64() % 6 {
                0 => {
                    let v = f64::from_bits(self.next_u64());
                    if v.is_finite() { v % 1e3 } else { 0.1 }
                }
                1 => [
                    0.0,
                    -0.0,
                    5e-324,
                    -2.2250738585072014e-308,
                    999.9999999999999,
                    f64::MIN_POSITIVE,
                ][(self.next_u64() % 6) as usize],
                2 => (self.unit() - 0.5) * 1e-7,
                3 => (self.unit() - 0.5) * 2e3,
                _ => (self.unit() - 0.5) * 2.0 * PI,
            }
        }
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    fn orientation_bits(o: &Option<Orientation>) -> Vec<u64> {
        match o {
            None => vec![],
            Some(Orientation::Rpy {
                roll_rad,
                pitch_rad,
                yaw_rad,
            }) => bits(&[*roll_rad, *pitch_rad, *yaw_rad]),
            Some(Orientation::Quaternion { w, x, y, z }) => bits(&[*w, *x, *y, *z]),
        }
    }

    /// Bit-exact comparison of everything but `line`, `source` and `sha256`.
    fn assert_same(a: &MeasurementSet, b: &MeasurementSet) {
        assert_eq!(a.comments, b.comments);
        assert_eq!(a.n_joints, b.n_joints);
        assert_eq!(a.extra_columns, b.extra_columns);
        assert_eq!(a.orientation_form, b.orientation_form);
        assert_eq!(
            (a.has_position, a.has_approach, a.has_temperature),
            (b.has_position, b.has_approach, b.has_temperature)
        );
        assert_eq!(a.rows.len(), b.rows.len());
        for (ra, rb) in a.rows.iter().zip(&b.rows) {
            assert_eq!(ra.pose_id, rb.pose_id);
            assert_eq!(bits(&ra.q_rad), bits(&rb.q_rad));
            assert_eq!(
                ra.position_m.map(|p| bits(&p)),
                rb.position_m.map(|p| bits(&p))
            );
            assert_eq!(
                orientation_bits(&ra.orientation),
                orientation_bits(&rb.orientation)
            );
            assert_eq!(ra.approach, rb.approach);
            assert_eq!(ra.temp_c.map(f64::to_bits), rb.temp_c.map(f64::to_bits));
            assert_eq!(ra.extras, rb.extras);
        }
    }

    fn write_to_string(m: &MeasurementSet) -> String {
        let mut out = Vec::new();
        write_measurements_csv(&mut out, m).unwrap();
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn format_f64_round_trips_extremes() {
        let mut g = Gen(0x9E37_79B9_7F4A_7C15);
        let mut values = vec![
            0.0,
            -0.0,
            5e-324,
            f64::MAX,
            f64::MIN,
            1e-5,
            f64::from_bits(1e16f64.to_bits() - 1),
        ];
        values.extend((0..20_000).map(|_| g.any()));
        for v in values {
            let s = format_f64(v);
            let back: f64 = s.parse().unwrap();
            assert_eq!(back.to_bits(), v.to_bits(), "{v:?} -> {s}");
            assert!(s.len() <= 24, "{s}");
        }
        assert_eq!(format_f64(0.1), "0.1");
        assert_eq!(format_f64(-0.0), "-0");
        assert_eq!(format_f64(1e-7), "1e-7");
    }

    #[test]
    fn round_trip_rpy_set_is_bit_exact() {
        let mut g = Gen(42);
        let n = 3;
        let rows = (0..300)
            .map(|i| MeasurementRow {
                line: 0,
                pose_id: Some(format!("p{}", i / 3)),
                q_rad: (0..n).map(|_| g.any()).collect(),
                position_m: Some([g.any(), g.any(), g.any()]),
                orientation: Some(Orientation::Rpy {
                    roll_rad: g.any(),
                    pitch_rad: g.any(),
                    yaw_rad: g.any(),
                }),
                point_m: None,
                approach: Some(vec![-1, 0, 1]),
                temp_c: Some(g.any()),
                extras: vec![format!("a,\"b\" {i}"), String::new()],
                partial_m: None,
                target: None,
                plane: None,
                session: None,
            })
            .collect();
        let set = MeasurementSet {
            source: "mem".into(),
            comments: vec![" robot: aria".into(), "".into(), "#x, y".into()],
            n_joints: n,
            rows,
            extra_columns: vec!["extra_note".into(), "extra_empty".into()],
            orientation_form: Some(OrientationForm::Rpy),
            has_position: true,
            has_point: false,
            has_target: false,
            has_plane: false,
            has_session: false,
            has_approach: true,
            has_temperature: true,
            sha256: String::new(),
            header_line: 4,
        };
        let text = write_to_string(&set);
        let back = parse(&text, n).unwrap();
        assert_same(&set, &back);
        assert_eq!(write_to_string(&back), text);
    }

    #[test]
    fn round_trip_of_read_data_is_bit_exact() {
        // Degrees, millimetres and not-quite-unit quaternions: read, write, read again.
        let mut g = Gen(7);
        let mut text = String::from("#q\nq2_deg,q1_deg,x_mm,y_mm,z_mm,qx,qw,qy,qz,pose_id\n");
        for i in 0..500 {
            let mut q = [
                g.unit() - 0.5,
                g.unit() - 0.5,
                g.unit() - 0.5,
                g.unit() - 0.5,
            ];
            let norm = q.iter().map(|c| c * c).sum::<f64>().sqrt();
            let scale = 1.0 + (g.unit() - 0.5) * 1.9e-6;
            for c in &mut q {
                *c *= scale / norm;
            }
            text.push_str(&format!(
                "{},{},{},{},{},{},{},{},{},id{i}\n",
                (g.unit() - 0.5) * 360.0,
                (g.unit() - 0.5) * 360.0,
                (g.unit() - 0.5) * 2000.0,
                (g.unit() - 0.5) * 2000.0,
                (g.unit() - 0.5) * 2000.0,
                q[1],
                q[0],
                q[2],
                q[3]
            ));
        }
        let first = parse(&text, 2).unwrap();
        let written = write_to_string(&first);
        let second = parse(&written, 2).unwrap();
        assert_same(&first, &second);
        assert_eq!(write_to_string(&second), written);
        // Position-only and joint-only sets, too.
        for src in ["q1,x,y,z\n0.1,1e-300,2,3\n", "q1\n-0\n"] {
            let a = parse(src, 1).unwrap();
            let b = parse(&write_to_string(&a), 1).unwrap();
            assert_same(&a, &b);
        }
    }

    #[test]
    fn write_measurements_refuses_inconsistent_sets() {
        let mut set = parse(SPEC_EXAMPLE, 6).unwrap();
        set.rows[0].q_rad[2] = f64::NAN;
        assert!(write_measurements_csv(Vec::new(), &set).is_err());
        let mut set = parse(SPEC_EXAMPLE, 6).unwrap();
        set.comments.push("two\nlines".into());
        assert!(write_measurements_csv(Vec::new(), &set).is_err());
        let mut set = parse(SPEC_EXAMPLE, 6).unwrap();
        set.orientation_form = Some(OrientationForm::Quaternion);
        assert!(write_measurements_csv(Vec::new(), &set).is_err());
    }

    #[test]
    fn poses_csv_has_the_predict_columns_and_round_trips() {
        let mut g = Gen(99);
        let rows: Vec<PoseRow> = (0..100)
            .map(|i| {
                let mut q = [
                    g.unit() - 0.5,
                    g.unit() - 0.5,
                    g.unit() - 0.5,
                    g.unit() - 0.5,
                ];
                let norm = q.iter().map(|c| c * c).sum::<f64>().sqrt();
                q.iter_mut().for_each(|c| *c /= norm);
                PoseRow {
                    pose_id: Some(format!("{}", i % 7)),
                    q_rad: (0..6).map(|_| g.any()).collect(),
                    position_m: [g.any(), g.any(), g.any()],
                    quaternion_wxyz: q,
                }
            })
            .collect();
        let mut out = Vec::new();
        write_poses_csv(&mut out, 6, true, &rows).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.starts_with("pose_id,q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz\n"));
        let back = parse(&text, 6).unwrap();
        assert_eq!(back.orientation_form, Some(OrientationForm::Quaternion));
        for (r, b) in rows.iter().zip(&back.rows) {
            assert_eq!(r.pose_id, b.pose_id);
            assert_eq!(bits(&r.q_rad), bits(&b.q_rad));
            assert_eq!(bits(&r.position_m), bits(&b.position_m.unwrap()));
            assert_eq!(
                bits(&r.quaternion_wxyz),
                orientation_bits(&b.orientation),
                "normalised quaternions are kept bit for bit"
            );
        }

        // Without pose_id.
        let plain: Vec<PoseRow> = rows
            .iter()
            .map(|r| PoseRow {
                pose_id: None,
                ..r.clone()
            })
            .collect();
        let mut out = Vec::new();
        write_poses_csv(&mut out, 6, false, &plain).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.starts_with("q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz\n"));
        assert!(!parse(&text, 6).unwrap().has_pose_id());
    }

    #[test]
    fn poses_csv_refuses_bad_rows() {
        let ok = PoseRow {
            pose_id: None,
            q_rad: vec![0.0, 1.0],
            position_m: [0.0; 3],
            quaternion_wxyz: [1.0, 0.0, 0.0, 0.0],
        };
        let nan = PoseRow {
            position_m: [0.0, f64::INFINITY, 0.0],
            ..ok.clone()
        };
        let e = write_poses_csv(Vec::new(), 2, false, &[ok.clone(), nan]).unwrap_err();
        assert!(e.to_string().contains("row 2: column 'y'"), "{e}");
        assert!(write_poses_csv(Vec::new(), 3, false, std::slice::from_ref(&ok)).is_err());
        assert!(write_poses_csv(Vec::new(), 2, true, std::slice::from_ref(&ok)).is_err());
        let labelled = PoseRow {
            pose_id: Some("a".into()),
            ..ok
        };
        assert!(write_poses_csv(Vec::new(), 2, false, &[labelled]).is_err());
    }
}
