//! ROS 2 bags (MCAP storage, CDR messages) to the measurement CSV (spec/measurements.md):
//! joint readings from a `sensor_msgs/msg/JointState` topic, measurements from a
//! `geometry_msgs/msg/PoseStamped` or `TransformStamped` topic (6-D poses) or a
//! `PointStamped` topic (positions).
//!
//! A calibration pose is a standstill: a run of joint readings that stays within
//! `still_tol` of its first reading for at least `min_still_s`. Each measurement is paired
//! with the joint reading nearest in time (at most `max_skew_s` away); measurements paired
//! with a moving arm, or outside a standstill's time span, are dropped. Each standstill
//! with measurements becomes one row: the mean joint reading and the mean measurement,
//! `pose_id` its number. Every drop is counted with its reason ([`BagSummary`]).
//!
//! Bad bags are input errors (exit 3) with the reason: not MCAP or truncated, a topic that
//! is missing, a message type or encoding not read here, a clock that jumps (a stamp earlier
//! than its predecessor by more than `max_skew_s`, or header stamps whose offset from the
//! recorder's clock changes by more than `max_clock_jump_s`), joints missing from a reading.

use std::collections::BTreeMap;
use std::path::Path;

use crate::cdr;
use crate::error::Error;
pub use crate::mcap_reader::MAX_RECORD_BYTES;
use crate::measurements::{MeasurementRow, MeasurementSet, Orientation, OrientationForm};

/// What a measurement topic carries.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MeasurementTopic {
    /// 6-D poses: `PoseStamped` or `TransformStamped`.
    Pose(String),
    /// Positions: `PointStamped`.
    Point(String),
}

impl MeasurementTopic {
    fn name(&self) -> &str {
        match self {
            MeasurementTopic::Pose(t) | MeasurementTopic::Point(t) => t,
        }
    }
}

/// Which time a message is placed at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Clock {
    /// `header.stamp`: when the sensor took the reading (default).
    Header,
    /// The recorder's log time: when the message reached the bag.
    Receive,
}

/// How a bag becomes rows (the flags of `kincal import-bag`).
#[derive(Debug, Clone, PartialEq)]
pub struct BagOptions {
    pub joints_topic: String,
    pub measurement: MeasurementTopic,
    /// The robot's joint names, in model order: readings are mapped by name. `None`: every
    /// position of a reading, in message order.
    pub joint_names: Option<Vec<String>>,
    /// Written into the CSV's `# robot:` comment.
    pub robot_name: Option<String>,
    pub clock: Clock,
    /// Largest time between a measurement and the joint reading it is paired with [s].
    pub max_skew_s: f64,
    /// Largest deviation of a joint from the standstill's first reading [rad, or m for a
    /// prismatic joint].
    pub still_tol: f64,
    /// Shortest standstill [s].
    pub min_still_s: f64,
    /// Largest distance of a measured position from the standstill's mean [m]: a larger
    /// spread means the measured frame moved while the joints did not.
    pub still_pos_tol_m: f64,
    /// Largest change of (header stamp − log time) between consecutive messages [s].
    pub max_clock_jump_s: f64,
}

impl BagOptions {
    /// The documented defaults for the given topics.
    pub fn new(joints_topic: &str, measurement: MeasurementTopic) -> Self {
        BagOptions {
            joints_topic: joints_topic.to_string(),
            measurement,
            joint_names: None,
            robot_name: None,
            clock: Clock::Header,
            max_skew_s: DEFAULT_MAX_SKEW_S,
            still_tol: DEFAULT_STILL_TOL,
            min_still_s: DEFAULT_MIN_STILL_S,
            still_pos_tol_m: DEFAULT_STILL_POS_TOL_MM / 1000.0,
            max_clock_jump_s: DEFAULT_MAX_CLOCK_JUMP_S,
        }
    }

    fn check(&self) -> Result<(), Error> {
        for (flag, v) in [
            ("--max-skew-s", self.max_skew_s),
            ("--still-tol", self.still_tol),
            ("--min-still-s", self.min_still_s),
            ("--still-pos-tol-mm", self.still_pos_tol_m),
            ("--max-clock-jump-s", self.max_clock_jump_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::usage(format!(
                    "{flag} must be a finite number >= 0, got {v}"
                )));
            }
        }
        if self.joints_topic == self.measurement.name() {
            return Err(Error::usage(format!(
                "--joints and the measurement topic are the same topic '{}'",
                self.joints_topic
            )));
        }
        Ok(())
    }
}

pub const DEFAULT_MAX_SKEW_S: f64 = 0.05;
pub const DEFAULT_STILL_TOL: f64 = 1e-3;
pub const DEFAULT_MIN_STILL_S: f64 = 0.5;
pub const DEFAULT_STILL_POS_TOL_MM: f64 = 1.0;
pub const DEFAULT_MAX_CLOCK_JUMP_S: f64 = 1.0;

/// What was read, kept and dropped.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BagSummary {
    pub joint_messages: usize,
    pub measurement_messages: usize,
    /// Standstills found in the joint readings.
    pub standstills: usize,
    pub rows: usize,
    /// Reason -> count (joint readings, measurements or standstills, as the reason says).
    pub dropped: BTreeMap<String, usize>,
    /// Joint names in the readings that are not the robot's (ignored).
    pub ignored_joints: Vec<String>,
}

impl BagSummary {
    fn drop(&mut self, reason: &str) {
        *self.dropped.entry(reason.to_string()).or_insert(0) += 1;
    }

    /// Human-readable lines for stderr.
    pub fn lines(&self) -> Vec<String> {
        let mut out = vec![format!(
            "{} joint readings, {} measurements, {} standstills -> {} rows",
            self.joint_messages, self.measurement_messages, self.standstills, self.rows
        )];
        for (reason, n) in &self.dropped {
            out.push(format!("dropped {n}: {reason}"));
        }
        if !self.ignored_joints.is_empty() {
            out.push(format!(
                "ignored joints not in the robot: {}",
                self.ignored_joints.join(", ")
            ));
        }
        out
    }
}

/// A bag read into rows.
#[derive(Debug, Clone)]
pub struct BagImport {
    pub set: MeasurementSet,
    pub summary: BagSummary,
}

/// Reads a bag: an `.mcap` file, or a rosbag2 folder (its `.mcap` files in name order).
/// The files are streamed: memory grows with the largest record and the rows kept, not with
/// the bag (a bag that also holds camera images can be many GB).
pub fn import_bag_path(path: &Path, opts: &BagOptions) -> Result<BagImport, Error> {
    let files = bag_files(path)?;
    let mut parts = Vec::with_capacity(files.len());
    for f in &files {
        let file = std::fs::File::open(f)
            .map_err(|e| Error::input(format!("{}: cannot read: {e}", f.display())))?;
        parts.push((f.display().to_string(), std::io::BufReader::new(file)));
    }
    let mut imported = import_bag_readers(parts, opts)?;
    for f in &files {
        let sha = crate::files::sha256_file(f)
            .map_err(|e| Error::input(format!("{}: cannot read: {e}", f.display())))?;
        imported
            .set
            .comments
            .insert(0, format!(" source: {} sha256 {sha}", f.display()));
    }
    imported.set.source = path.display().to_string();
    Ok(imported)
}

/// The MCAP files of a bag path.
fn bag_files(path: &Path) -> Result<Vec<std::path::PathBuf>, Error> {
    if !path.is_dir() {
        return Ok(vec![path.to_path_buf()]);
    }
    let mut files: Vec<_> = std::fs::read_dir(path)
        .map_err(|e| Error::input(format!("{}: cannot list: {e}", path.display())))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .is_some_and(|x| x.eq_ignore_ascii_case("mcap"))
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(Error::input(format!(
            "{}: a folder without .mcap files (import-bag reads the MCAP storage of ROS 2; convert sqlite3 bags with `ros2 bag convert`)",
            path.display()
        )));
    }
    Ok(files)
}

/// One message placed in time.
#[derive(Debug, Clone)]
struct Timed<T> {
    t_ns: i128,
    log_ns: u64,
    /// 1-based number of the message on its topic (file order), for messages.
    number: usize,
    value: T,
}

/// A measurement: position [m] and, for poses, the quaternion (w, x, y, z).
#[derive(Debug, Clone, Copy)]
struct Measured {
    position_m: [f64; 3],
    quaternion_wxyz: Option<[f64; 4]>,
}

const JOINT_STATE: &[&str] = &["sensor_msgs/msg/JointState", "sensor_msgs/JointState"];
const POSE_STAMPED: &[&str] = &["geometry_msgs/msg/PoseStamped", "geometry_msgs/PoseStamped"];
const TRANSFORM_STAMPED: &[&str] = &[
    "geometry_msgs/msg/TransformStamped",
    "geometry_msgs/TransformStamped",
];
const POINT_STAMPED: &[&str] = &[
    "geometry_msgs/msg/PointStamped",
    "geometry_msgs/PointStamped",
];

/// Reads the bytes of one or more MCAP files (`(name, bytes)`, in order) into rows.
pub fn import_bag_bytes(parts: &[(&str, &[u8])], opts: &BagOptions) -> Result<BagImport, Error> {
    import_bag_readers(parts.iter().map(|(n, b)| (n.to_string(), *b)), opts)
}

/// Reads one or more MCAP streams (`(name, reader)`, in order) into rows.
fn import_bag_readers<R: std::io::Read>(
    parts: impl IntoIterator<Item = (String, R)>,
    opts: &BagOptions,
) -> Result<BagImport, Error> {
    opts.check()?;
    let parts: Vec<(String, R)> = parts.into_iter().collect();
    let mut summary = BagSummary::default();
    let mut topics_seen: BTreeMap<String, String> = BTreeMap::new();
    let mut joints: Vec<Timed<Vec<f64>>> = Vec::new();
    let mut measured: Vec<Timed<Measured>> = Vec::new();
    let mut frames = FrameNames::default();
    let mut first_names: Option<Vec<String>> = None;
    let source = parts
        .iter()
        .map(|(n, _)| n.as_str())
        .collect::<Vec<_>>()
        .join(", ");
    for (name, reader) in parts {
        let name = name.as_str();
        for msg in crate::mcap_reader::Messages::new(reader) {
            let msg = msg.map_err(|e| not_mcap(name, &e))?;
            let topic = msg.channel.topic.as_str();
            let schema = msg
                .channel
                .schema
                .as_ref()
                .map(|s| s.name.clone())
                .unwrap_or_default();
            topics_seen
                .entry(topic.to_string())
                .or_insert_with(|| schema.clone());
            let is_joints = topic == opts.joints_topic;
            if !is_joints && topic != opts.measurement.name() {
                continue;
            }
            let encoding = msg.channel.message_encoding.as_str();
            let (flag, expected): (&str, &[&[&str]]) = if is_joints {
                ("--joints", &[JOINT_STATE])
            } else {
                match opts.measurement {
                    MeasurementTopic::Pose(_) => ("--pose", &[POSE_STAMPED, TRANSFORM_STAMPED]),
                    MeasurementTopic::Point(_) => ("--point", &[POINT_STAMPED]),
                }
            };
            let known = expected
                .iter()
                .any(|names| names.contains(&schema.as_str()));
            if !known || encoding != "cdr" {
                let want: Vec<&str> = expected.iter().map(|n| n[0]).collect();
                return Err(Error::input(format!(
                    "{name}: topic '{topic}' carries '{schema}' in encoding '{encoding}'; {flag} reads {} in encoding 'cdr'",
                    want.join(" or ")
                )));
            }
            let data: &[u8] = &msg.data;
            let bad = |e: cdr::CdrError, n: usize| {
                Error::input(format!(
                    "{name}: topic '{topic}' message {n} ('{schema}'): {e}"
                ))
            };
            if is_joints {
                summary.joint_messages += 1;
                let n = summary.joint_messages;
                let js = cdr::joint_state(data).map_err(|e| bad(e, n))?;
                let t_ns = time_of(opts.clock, js.header.stamp_ns, msg.log_time);
                match map_joints(&js, opts, &mut first_names, &mut summary).map_err(|e| {
                    Error::input(format!("{name}: topic '{topic}' message {n}: {e}"))
                })? {
                    Some(q) => joints.push(Timed {
                        t_ns,
                        log_ns: msg.log_time,
                        number: n,
                        value: q,
                    }),
                    None => continue,
                }
            } else {
                summary.measurement_messages += 1;
                let n = summary.measurement_messages;
                let (header, value, child) = if POINT_STAMPED.contains(&schema.as_str()) {
                    let p = cdr::point_stamped(data).map_err(|e| bad(e, n))?;
                    let m = Measured {
                        position_m: p.point_m,
                        quaternion_wxyz: None,
                    };
                    (p.header, m, String::new())
                } else {
                    let p = if POSE_STAMPED.contains(&schema.as_str()) {
                        cdr::pose_stamped(data)
                    } else {
                        cdr::transform_stamped(data)
                    }
                    .map_err(|e| bad(e, n))?;
                    let m = Measured {
                        position_m: p.position_m,
                        quaternion_wxyz: Some(p.quaternion_wxyz),
                    };
                    (p.header, m, p.child_frame_id)
                };
                frames.note(&header.frame_id, &child).map_err(|e| {
                    Error::input(format!("{name}: topic '{topic}' message {n}: {e}"))
                })?;
                measured.push(Timed {
                    t_ns: time_of(opts.clock, header.stamp_ns, msg.log_time),
                    log_ns: msg.log_time,
                    number: n,
                    value,
                });
            }
        }
    }
    for topic in [opts.joints_topic.as_str(), opts.measurement.name()] {
        if !topics_seen.contains_key(topic) {
            let list: Vec<String> = topics_seen
                .iter()
                .map(|(t, s)| format!("{t} ({s})"))
                .collect();
            return Err(Error::input(format!(
                "{source}: no messages on topic '{topic}'; the bag's topics: {}",
                if list.is_empty() {
                    "none".to_string()
                } else {
                    list.join(", ")
                }
            )));
        }
    }
    if joints.is_empty() {
        return Err(Error::input(format!(
            "{source}: topic '{}' has no reading of the robot's joints",
            opts.joints_topic
        )));
    }
    check_clock(&source, &opts.joints_topic, &mut joints, opts)?;
    check_clock(&source, opts.measurement.name(), &mut measured, opts)?;
    let n_joints = joints.first().map_or(0, |j| j.value.len());
    let runs = standstills(&joints, opts);
    summary.standstills = runs.iter().filter(|r| r.still).count();
    let assigned = assign(&measured, &joints, &runs, opts, &mut summary);
    let rows = average_rows(&joints, &runs, &assigned, &measured, opts, &mut summary);
    summary.rows = rows.len();
    let set = measurement_set(&source, n_joints, rows, opts, &frames);
    Ok(BagImport { set, summary })
}

fn not_mcap(name: &str, e: &dyn std::fmt::Display) -> Error {
    Error::input(format!(
        "{name}: not a readable MCAP file (truncated or damaged?): {e}"
    ))
}

fn time_of(clock: Clock, stamp_ns: i128, log_ns: u64) -> i128 {
    match clock {
        Clock::Header => stamp_ns,
        Clock::Receive => i128::from(log_ns),
    }
}

fn secs(ns: i128) -> f64 {
    ns as f64 * 1e-9
}

/// The frame names of the measurements: one frame pair for the whole topic.
#[derive(Debug, Default)]
struct FrameNames {
    frame_id: Option<String>,
    child_frame_id: Option<String>,
}

impl FrameNames {
    fn note(&mut self, frame: &str, child: &str) -> Result<(), String> {
        for (kept, now, what) in [
            (&mut self.frame_id, frame, "header.frame_id"),
            (&mut self.child_frame_id, child, "child_frame_id"),
        ] {
            match kept {
                None => *kept = Some(now.to_string()),
                Some(k) if k != now => {
                    return Err(format!(
                        "{what} changes from '{k}' to '{now}': one topic must measure one frame in one frame"
                    ));
                }
                Some(_) => {}
            }
        }
        Ok(())
    }
}

/// A reading's positions in model order; `None` when the reading has none of the robot's
/// joints (another publisher on the same topic, e.g. a gripper), counted as dropped.
fn map_joints(
    js: &cdr::JointState,
    opts: &BagOptions,
    first_names: &mut Option<Vec<String>>,
    summary: &mut BagSummary,
) -> Result<Option<Vec<f64>>, String> {
    if !js.name.is_empty() && js.name.len() != js.position.len() {
        return Err(format!(
            "{} names but {} positions",
            js.name.len(),
            js.position.len()
        ));
    }
    let Some(wanted) = &opts.joint_names else {
        // By order: every reading must name the same joints as the first.
        match first_names {
            None => *first_names = Some(js.name.clone()),
            Some(first) if *first != js.name => {
                return Err(format!(
                    "joint names [{}] differ from the first reading's [{}]; give --robot to map joints by name",
                    js.name.join(", "),
                    first.join(", ")
                ));
            }
            Some(_) => {}
        }
        if js.position.is_empty() {
            return Err("a reading without positions".into());
        }
        return Ok(Some(js.position.clone()));
    };
    if js.name.is_empty() {
        return Err("the reading names no joints, so they cannot be mapped to the robot's by name (drop --robot to map by order)".into());
    }
    let mut q = Vec::with_capacity(wanted.len());
    let mut missing = Vec::new();
    for w in wanted {
        match js.name.iter().position(|n| n == w) {
            Some(i) => q.push(js.position.get(i).copied().unwrap_or(f64::NAN)),
            None => missing.push(w.as_str()),
        }
    }
    if missing.len() == wanted.len() {
        summary.drop("joint readings without any of the robot's joints");
        return Ok(None);
    }
    if !missing.is_empty() {
        return Err(format!(
            "the robot's joints {} are missing from the reading (it names {})",
            missing.join(", "),
            js.name.join(", ")
        ));
    }
    for n in &js.name {
        if !wanted.contains(n) && !summary.ignored_joints.contains(n) {
            summary.ignored_joints.push(n.clone());
        }
    }
    Ok(Some(q))
}

/// Sorts a topic's messages by time after checking, in file order (the recorder's arrival
/// order), that its clock does not jump.
fn check_clock<T>(
    source: &str,
    topic: &str,
    msgs: &mut [Timed<T>],
    opts: &BagOptions,
) -> Result<(), Error> {
    if opts.clock == Clock::Header && !msgs.is_empty() && msgs.iter().all(|m| m.t_ns == 0) {
        return Err(Error::input(format!(
            "{source}: topic '{topic}': every header stamp is zero; use --clock receive to place messages at the recorder's time"
        )));
    }
    let max_back_ns = (opts.max_skew_s * 1e9) as i128;
    let max_jump_ns = (opts.max_clock_jump_s * 1e9) as i128;
    for pair in msgs.windows(2) {
        let [a, b] = pair else { continue };
        if b.t_ns < a.t_ns - max_back_ns {
            return Err(Error::input(format!(
                "{source}: topic '{topic}' message {}: clock jumps back by {:.3} s (from {:.9} s to {:.9} s)",
                b.number,
                secs(a.t_ns - b.t_ns),
                secs(a.t_ns),
                secs(b.t_ns)
            )));
        }
        if opts.clock == Clock::Header {
            let offset_a = a.t_ns - i128::from(a.log_ns);
            let offset_b = b.t_ns - i128::from(b.log_ns);
            if (offset_b - offset_a).abs() > max_jump_ns {
                return Err(Error::input(format!(
                    "{source}: topic '{topic}' message {}: clock jump: the header stamp moved {:.3} s against the recorder's clock (more than --max-clock-jump-s {})",
                    b.number,
                    secs(offset_b - offset_a),
                    opts.max_clock_jump_s
                )));
            }
        }
    }
    msgs.sort_by_key(|m| m.t_ns);
    Ok(())
}

/// A run of consecutive joint readings within `still_tol` of its first reading.
#[derive(Debug, Clone, Copy)]
struct Run {
    first: usize,
    /// One past the last reading.
    end: usize,
    t_first_ns: i128,
    t_last_ns: i128,
    still: bool,
}

/// Splits the (time-sorted) joint readings into runs; a run lasting `min_still_s` or more
/// is a standstill.
fn standstills(joints: &[Timed<Vec<f64>>], opts: &BagOptions) -> Vec<Run> {
    let mut runs = Vec::new();
    let mut first = 0;
    while first < joints.len() {
        let Some(start) = joints.get(first) else {
            break;
        };
        let mut end = first + 1;
        while let Some(next) = joints.get(end) {
            let within = next
                .value
                .iter()
                .zip(&start.value)
                .all(|(a, b)| (a - b).abs() <= opts.still_tol);
            if !within {
                break;
            }
            end += 1;
        }
        let t_last_ns = joints.get(end - 1).map_or(start.t_ns, |j| j.t_ns);
        let finite = joints
            .get(first..end)
            .is_some_and(|s| s.iter().all(|j| j.value.iter().all(|v| v.is_finite())));
        runs.push(Run {
            first,
            end,
            t_first_ns: start.t_ns,
            t_last_ns,
            still: finite && end - first >= 2 && secs(t_last_ns - start.t_ns) >= opts.min_still_s,
        });
        first = end;
    }
    runs
}

/// For each run, the measurements paired with it (indices into `measured`).
fn assign(
    measured: &[Timed<Measured>],
    joints: &[Timed<Vec<f64>>],
    runs: &[Run],
    opts: &BagOptions,
    summary: &mut BagSummary,
) -> Vec<Vec<usize>> {
    let mut out = vec![Vec::new(); runs.len()];
    let max_skew_ns = (opts.max_skew_s * 1e9) as i128;
    for (k, m) in measured.iter().enumerate() {
        let finite = m.value.position_m.iter().all(|v| v.is_finite())
            && m.value
                .quaternion_wxyz
                .is_none_or(|q| q.iter().all(|v| v.is_finite()) && norm4(q) > 0.5);
        if !finite {
            summary.drop(
                "measurements with a non-finite value or a degenerate quaternion (tracking lost?)",
            );
            continue;
        }
        let Some(nearest) = nearest_reading(joints, m.t_ns) else {
            continue;
        };
        let skew = joints
            .get(nearest)
            .map_or(i128::MAX, |j| (j.t_ns - m.t_ns).abs());
        if skew > max_skew_ns {
            summary.drop("measurements with no joint reading within --max-skew-s");
            continue;
        }
        let Some(r) = runs
            .iter()
            .position(|r| r.first <= nearest && nearest < r.end)
        else {
            continue;
        };
        let Some(run) = runs.get(r) else { continue };
        if !run.still {
            summary.drop("measurements while the arm moved");
        } else if m.t_ns < run.t_first_ns || m.t_ns > run.t_last_ns {
            summary.drop("measurements at the edge of a standstill (outside its first and last joint reading)");
        } else if let Some(list) = out.get_mut(r) {
            list.push(k);
        }
    }
    out
}

/// Index of the joint reading nearest in time (readings sorted by time).
fn nearest_reading(joints: &[Timed<Vec<f64>>], t_ns: i128) -> Option<usize> {
    let i = joints.partition_point(|j| j.t_ns < t_ns);
    let before = i.checked_sub(1);
    let after = (i < joints.len()).then_some(i);
    match (before, after) {
        (Some(b), Some(a)) => {
            let db = joints.get(b).map_or(i128::MAX, |j| t_ns - j.t_ns);
            let da = joints.get(a).map_or(i128::MAX, |j| j.t_ns - t_ns);
            Some(if db <= da { b } else { a })
        }
        (b, a) => b.or(a),
    }
}

fn norm4(q: [f64; 4]) -> f64 {
    q.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// One averaged standstill.
#[derive(Debug, Clone)]
struct Row {
    q: Vec<f64>,
    measured: Measured,
    t_mean_s: f64,
    samples: usize,
}

/// The standstills with measurements as rows: mean joint reading, mean measurement.
fn average_rows(
    joints: &[Timed<Vec<f64>>],
    runs: &[Run],
    assigned: &[Vec<usize>],
    measured: &[Timed<Measured>],
    opts: &BagOptions,
    summary: &mut BagSummary,
) -> Vec<Row> {
    let mut rows = Vec::new();
    for (run, picks) in runs.iter().zip(assigned) {
        if !run.still {
            continue;
        }
        let ms: Vec<&Timed<Measured>> = picks.iter().filter_map(|&k| measured.get(k)).collect();
        if ms.is_empty() {
            summary.drop("standstills without a measurement");
            continue;
        }
        let readings = joints.get(run.first..run.end).unwrap_or_default();
        let q = mean_vec(readings.iter().map(|j| j.value.as_slice()));
        let position_m = mean3(ms.iter().map(|m| m.value.position_m));
        let spread_m = ms
            .iter()
            .map(|m| dist3(m.value.position_m, position_m))
            .fold(0.0, f64::max);
        if spread_m > opts.still_pos_tol_m {
            summary.drop("standstills whose measured position spread exceeds --still-pos-tol-mm (the measured frame moved while the joints stood still)");
            continue;
        }
        let quaternion_wxyz = mean_quaternion(ms.iter().filter_map(|m| m.value.quaternion_wxyz));
        let t_mean_s = ms.iter().map(|m| secs(m.t_ns)).sum::<f64>() / ms.len() as f64;
        rows.push(Row {
            q,
            measured: Measured {
                position_m,
                quaternion_wxyz,
            },
            t_mean_s,
            samples: ms.len(),
        });
    }
    rows
}

fn mean_vec<'a>(vs: impl Iterator<Item = &'a [f64]>) -> Vec<f64> {
    let mut sum: Vec<f64> = Vec::new();
    let mut n = 0usize;
    for v in vs {
        if sum.is_empty() {
            sum = vec![0.0; v.len()];
        }
        for (s, x) in sum.iter_mut().zip(v) {
            *s += x;
        }
        n += 1;
    }
    sum.iter().map(|s| s / n.max(1) as f64).collect()
}

fn mean3(vs: impl Iterator<Item = [f64; 3]>) -> [f64; 3] {
    let mut sum = [0.0; 3];
    let mut n = 0usize;
    for v in vs {
        for (s, x) in sum.iter_mut().zip(v) {
            *s += x;
        }
        n += 1;
    }
    sum.map(|s| s / n.max(1) as f64)
}

fn dist3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// The normalised sum of the unit quaternions, each turned to the first one's hemisphere
/// (q and -q are one rotation): for the small spreads of one standstill this is the mean
/// rotation to second order.
fn mean_quaternion(qs: impl Iterator<Item = [f64; 4]>) -> Option<[f64; 4]> {
    let mut sum = [0.0; 4];
    let mut first: Option<[f64; 4]> = None;
    for q in qs {
        let n = norm4(q);
        let u = q.map(|v| v / n);
        let f = *first.get_or_insert(u);
        let dot: f64 = u.iter().zip(f).map(|(a, b)| a * b).sum();
        let sign = if dot < 0.0 { -1.0 } else { 1.0 };
        for (s, v) in sum.iter_mut().zip(u) {
            *s += sign * v;
        }
    }
    first?;
    let n = norm4(sum);
    Some(sum.map(|v| v / n))
}

/// The rows as a measurement set (quaternion form for poses), with the import's settings
/// and frames in comments, and `extra_stamp_s`/`extra_samples` for traceability.
fn measurement_set(
    source: &str,
    n_joints: usize,
    rows: Vec<Row>,
    opts: &BagOptions,
    frames: &FrameNames,
) -> MeasurementSet {
    let is_pose = matches!(opts.measurement, MeasurementTopic::Pose(_));
    let mut comments = Vec::new();
    if let Some(r) = &opts.robot_name {
        comments.push(format!(" robot: {r}"));
    }
    comments.push(format!(
        " import-bag: joints '{}' ({}), {} '{}', clock {}, max skew {} s, still tol {}, min still {} s, still pos tol {} mm",
        opts.joints_topic,
        if opts.joint_names.is_some() {
            "mapped by name"
        } else {
            "by order"
        },
        if is_pose { "poses" } else { "points" },
        opts.measurement.name(),
        match opts.clock {
            Clock::Header => "header",
            Clock::Receive => "receive",
        },
        opts.max_skew_s,
        opts.still_tol,
        opts.min_still_s,
        opts.still_pos_tol_m * 1000.0
    ));
    let frame = frames.frame_id.as_deref().unwrap_or("");
    let child = frames.child_frame_id.as_deref().unwrap_or("");
    comments.push(format!(
        " measured: {}{} in frame '{frame}' (the rows' base frame is this frame)",
        if is_pose { "pose" } else { "point" },
        if child.is_empty() {
            String::new()
        } else {
            format!(" of '{child}'")
        }
    ));
    let rows = rows
        .into_iter()
        .enumerate()
        .map(|(i, r)| MeasurementRow {
            line: 0,
            pose_id: Some((i + 1).to_string()),
            q_rad: r.q,
            position_m: Some(r.measured.position_m),
            orientation: r
                .measured
                .quaternion_wxyz
                .map(|[w, x, y, z]| Orientation::Quaternion { w, x, y, z }),
            point_m: None,
            approach: None,
            temp_c: None,
            extras: vec![format!("{}", r.t_mean_s), r.samples.to_string()],
            partial_m: None,
            target: None,
            plane: None,
            session: None,
        })
        .collect();
    MeasurementSet {
        source: source.to_string(),
        comments,
        n_joints,
        rows,
        extra_columns: vec!["extra_stamp_s".into(), "extra_samples".into()],
        orientation_form: is_pose.then_some(OrientationForm::Quaternion),
        has_position: true,
        has_point: false,
        has_target: false,
        has_plane: false,
        has_session: false,
        has_approach: false,
        has_temperature: false,
        sha256: String::new(),
        header_line: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAGIC: &[u8] = b"\x89MCAP0\r\n";

    fn record(opcode: u8, body: &[u8]) -> Vec<u8> {
        let mut out = vec![opcode];
        out.extend_from_slice(&(body.len() as u64).to_le_bytes());
        out.extend_from_slice(body);
        out
    }

    fn mcap_str(s: &str) -> Vec<u8> {
        let mut out = (s.len() as u32).to_le_bytes().to_vec();
        out.extend_from_slice(s.as_bytes());
        out
    }

    /// An uncompressed chunk whose only record declares `declared` bytes of body.
    fn bag_with_chunk_record_of(declared: u64) -> Vec<u8> {
        let mut inner = vec![0x05u8]; // a message record header...
        inner.extend_from_slice(&declared.to_le_bytes()); // ...declaring this much body
        inner.extend_from_slice(&[0; 16]);
        let mut chunk = Vec::new();
        chunk.extend_from_slice(&0u64.to_le_bytes()); // message_start_time
        chunk.extend_from_slice(&0u64.to_le_bytes()); // message_end_time
        chunk.extend_from_slice(&declared.to_le_bytes()); // uncompressed_size
        chunk.extend_from_slice(&0u32.to_le_bytes()); // uncompressed_crc (0: not checked)
        chunk.extend_from_slice(&mcap_str("")); // no compression
        chunk.extend_from_slice(&(inner.len() as u64).to_le_bytes());
        chunk.extend_from_slice(&inner);
        let mut header = mcap_str("ros2");
        header.extend_from_slice(&mcap_str("kincal-test"));
        let mut bag = MAGIC.to_vec();
        bag.extend(record(0x01, &header));
        bag.extend(record(0x06, &chunk));
        bag
    }

    /// A channel record whose topic declares ≈ 4 GiB: binrw would reserve that before
    /// reading (the fuzz target's second finding); the prefix check refuses it first.
    #[test]
    fn a_string_longer_than_its_record_is_refused_before_parsing() {
        let opts = BagOptions::new("/joint_states", MeasurementTopic::Pose("/tool".into()));
        let mut channel = Vec::new();
        channel.extend_from_slice(&1u16.to_le_bytes()); // id
        channel.extend_from_slice(&0u16.to_le_bytes()); // schema id
        channel.extend_from_slice(&0xFFFF_0000u32.to_le_bytes()); // topic length
        channel.extend_from_slice(b"/joint_states");
        let mut header = mcap_str("ros2");
        header.extend_from_slice(&mcap_str("kincal-test"));
        let mut bag = MAGIC.to_vec();
        bag.extend(record(0x01, &header));
        bag.extend(record(0x04, &channel));
        let Err(err) = import_bag_bytes(&[("damaged.mcap", &bag)], &opts) else {
            panic!("a channel whose topic overruns its record is refused");
        };
        let text = err.to_string();
        assert!(
            text.contains("damaged.mcap: not a readable MCAP file")
                && text.contains("channel topic declares 4294901760 bytes"),
            "{text}"
        );
    }

    /// A damaged length field must be refused, not allocated: the fuzz target's crash was a
    /// multi-GB allocation for a record that a chunk declared.
    #[test]
    fn a_record_longer_than_the_limit_is_refused_before_allocation() {
        let opts = BagOptions::new("/joint_states", MeasurementTopic::Pose("/tool".into()));
        for declared in [1u64 << 40, (MAX_RECORD_BYTES as u64) + 1, u64::MAX] {
            let bag = bag_with_chunk_record_of(declared);
            let Err(err) = import_bag_bytes(&[("damaged.mcap", &bag)], &opts) else {
                panic!("a bag declaring a {declared}-byte record is refused");
            };
            let text = err.to_string();
            assert!(
                text.contains("damaged.mcap: not a readable MCAP file"),
                "{text}"
            );
        }
    }

    /// The ros_bag fuzz target's inputs (kept as fuzz/seeds/ros_bag/regression-record-overruns-uncompressed-chunk-*): a record longer than its
    /// uncompressed chunk made `mcap`'s reader underflow (a panic in this debug build). Now
    /// the framing guard refuses it with the record's offset.
    #[test]
    fn the_fuzz_inputs_with_a_record_overrunning_its_chunk_are_refused() {
        let inputs: [(&[u8], usize, u64); 2] = [
            (
                include_bytes!(
                    "../../fuzz/seeds/ros_bag/regression-record-overruns-uncompressed-chunk-1"
                ),
                187,
                2146,
            ),
            (
                include_bytes!(
                    "../../fuzz/seeds/ros_bag/regression-record-overruns-uncompressed-chunk-2"
                ),
                829,
                1024,
            ),
        ];
        let opts = BagOptions::new("/joint_states", MeasurementTopic::Pose("/tool".into()));
        for (bag, at, declared) in inputs {
            let Err(err) = import_bag_bytes(&[("fuzz.mcap", bag)], &opts) else {
                panic!("the fuzz input is refused");
            };
            let text = err.to_string();
            assert!(
                text.contains("fuzz.mcap: not a readable MCAP file")
                    && text.contains(&format!(
                        "the record at byte {at} declares {declared} bytes"
                    )),
                "{text}"
            );
        }
    }
}
