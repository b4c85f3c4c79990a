//! Measurement CSV from C (std builds only): the file read by kincal-io's reader, the one the
//! CLI uses (spec/measurements.md), so a file the CLI refuses is refused here with the same
//! message and position (`kincal_read_error`).
//!
//! Memory follows the ABI's rule (caller-owned buffers, nothing kept): a read takes two
//! calls. `kincal_measurements_read_sizes` reads and checks the file and reports the sizes;
//! the caller allocates; `kincal_measurements_read` reads the file again into those buffers
//! (lengths must match, so a file that changed in between gives `KINCAL_STATUS_BAD_LENGTH`;
//! read such a file into memory and use the `_buffer` variants). The outputs are laid out as
//! `kincal_measurements` takes them, so they can be passed straight to `kincal_identify`.

use core::ffi::{CStr, c_char};

use kincal_io::measurements::{
    Header, InputError, MeasurementSet, ReadOptions, parse_header, parse_measurements,
};

use crate::kinematics::kincal_joint_aux;
use crate::model_read::{kincal_read_error, path_of, status_text};
use crate::robot::{KINCAL_MAX_JOINTS, kincal_robot, to_any};
use crate::status::{FfiResult, kincal_error, kincal_status};

/// `flags` bit of the measurement readers: accept joint readings outside the robot's limits.
pub const KINCAL_READ_ALLOW_OUT_OF_LIMITS: u32 = 1;
/// `flags` bit of the measurement readers: refuse a file without the position columns x, y, z.
pub const KINCAL_READ_REQUIRE_POSE: u32 = 2;

/// What a measurement file holds: the sizes of the buffers `kincal_measurements_read` fills,
/// and which optional columns the file has. Plain data, written by
/// `kincal_measurements_read_sizes`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[allow(non_camel_case_types)]
pub struct kincal_measurement_sizes {
    /// Data rows L (≥ 1).
    pub n_rows: usize,
    /// Joints N: the robot's, or without a robot the highest `qK` of the header.
    pub n_joints: usize,
    /// Header columns (names in `text`).
    pub n_columns: usize,
    /// Comment lines before the header (in `text`).
    pub n_comments: usize,
    /// `extra_*` columns (values per row in `text`).
    pub n_extra: usize,
    /// Bytes of `text`, every string's NUL included.
    /// Length of `text` (ignored when NULL).
    pub text_len: usize,
    /// 1-based line of the header row.
    pub header_line: usize,
    /// Orientation columns: 0 none, 1 roll/pitch/yaw, 2 qw/qx/qy/qz.
    pub orientation: u32,
    /// Non-zero: the file has x, y, z.
    pub has_position: u32,
    /// Non-zero: the file has `pose_id` (one label per row in `text`).
    pub has_pose_id: u32,
    /// Non-zero: the file has the approach directions s1..sN.
    pub has_approach: u32,
    /// Non-zero: the file has `temp_c`.
    pub has_temperature: u32,
    /// Non-zero: the file has contact columns (`point_x/y/z`, `target`, `plane`, `session`),
    /// which these outputs do not carry: read such files with the CLI (`kincal calibrate`).
    /// Target and plane rows come out with mask 0.
    pub has_contacts: u32,
}

/// Where `kincal_measurements_read` writes: caller-owned buffers, each NULL when not wanted
/// or exactly the length `kincal_measurement_sizes` gives (L rows, N joints).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub struct kincal_measurement_buffers {
    /// Joint readings [rad, or m for a prismatic joint], L × N row-major; `q_len` = L·N.
    pub q: *mut f64,
    /// Length of `q` (ignored when NULL).
    pub q_len: usize,
    /// Measured poses, L 4×4 column-major transforms [m]; `poses_len` = 16·L. Rows without
    /// an orientation have the identity rotation, rows without a position the identity pose.
    pub poses: *mut f64,
    /// Length of `poses` (ignored when NULL).
    pub poses_len: usize,
    /// Measured components per row, as `kincal_measurements.masks`: 0x3f a full pose, 0x07
    /// a position, the bits of the coordinates given for a partial position, 0 none;
    /// `masks_len` = L.
    pub masks: *mut u8,
    /// Length of `masks` (ignored when NULL).
    pub masks_len: usize,
    /// Approach directions and temperature per row (flags set when the file has them);
    /// `aux_len` = L.
    pub aux: *mut kincal_joint_aux,
    /// Length of `aux` (ignored when NULL).
    pub aux_len: usize,
    /// 1-based file line of each row; `lines_len` = L.
    pub lines: *mut usize,
    /// Length of `lines` (ignored when NULL).
    pub lines_len: usize,
    /// The file's text, NUL-terminated UTF-8 strings one after another: the comments
    /// (without the `#`, as written), the column names, then per row its `pose_id` (when
    /// the file has one) and its `n_extra` extra cells; `text_len` = the sizes' `text_len`.
    pub text: *mut c_char,
    /// Length of `text` (ignored when NULL).
    pub text_len: usize,
}

/// A file read and checked, with its header as written.
struct FileRead {
    set: MeasurementSet,
    header: Header,
}

/// A refused file: the reader's message and its position (cell number from the header).
struct Refused {
    message: String,
    line: usize,
    column: usize,
}

impl Refused {
    fn new(e: &InputError, header: Option<&Header>) -> Self {
        let column = e.column.as_deref().map_or(0, |name| {
            name.strip_prefix('#')
                .and_then(|k| k.parse().ok())
                .or_else(|| {
                    header
                        .and_then(|h| h.columns.iter().position(|c| c == name))
                        .map(|i| i + 1)
                })
                .unwrap_or(0)
        });
        Refused {
            message: e.to_string(),
            line: e.line.and_then(|l| usize::try_from(l).ok()).unwrap_or(0),
            column,
        }
    }
}

/// The reader's refusal (a bad file), or a failure of the arguments.
type ReadOutcome<T> = FfiResult<Result<T, Refused>>;

fn refusal(source: &str, line: Option<u64>, column: Option<&str>, reason: &str) -> InputError {
    InputError {
        path: source.to_string(),
        line,
        column: column.map(str::to_string),
        reason: reason.to_string(),
    }
}

/// The joint count and limits to read with: the robot's, or the header's joint count.
fn read_options(
    robot: Option<&kincal_robot>,
    flags: u32,
    header: &Header,
    source: &str,
) -> FfiResult<Result<ReadOptions, InputError>> {
    let mut opts = match robot {
        Some(r) => {
            let n = to_any(r)?.n_joints();
            let mut o = ReadOptions::new(n);
            o.joint_limits = Some(
                r.limits_lower
                    .iter()
                    .zip(&r.limits_upper)
                    .take(n)
                    .map(|(l, u)| (*l, *u))
                    .collect(),
            );
            o
        }
        None => {
            let n = header.joint_count();
            let line = Some(header.line);
            if n == 0 {
                let why = "missing required column: expected joint columns q1..qN";
                return Ok(Err(refusal(source, line, Some("q1"), why)));
            }
            if n > KINCAL_MAX_JOINTS {
                let why =
                    format!("{n} joints: expected at most {KINCAL_MAX_JOINTS} (KINCAL_MAX_JOINTS)");
                return Ok(Err(refusal(source, line, Some(&format!("q{n}")), &why)));
            }
            ReadOptions::new(n)
        }
    };
    opts.allow_out_of_limits = flags & KINCAL_READ_ALLOW_OUT_OF_LIMITS != 0;
    opts.require_pose = flags & KINCAL_READ_REQUIRE_POSE != 0;
    Ok(Ok(opts))
}

/// Reads `bytes` (named `source` in messages) with kincal-io's reader.
fn read_bytes(
    bytes: &[u8],
    source: &str,
    robot: Option<&kincal_robot>,
    flags: u32,
) -> ReadOutcome<FileRead> {
    if flags & !(KINCAL_READ_ALLOW_OUT_OF_LIMITS | KINCAL_READ_REQUIRE_POSE) != 0 {
        return Err(kincal_error::new(kincal_status::InvalidArgument).arg(c"flags"));
    }
    let header = match parse_header(bytes, source) {
        Ok(h) => h,
        Err(e) => return Ok(Err(Refused::new(&e, None))),
    };
    let opts = match read_options(robot, flags, &header, source)? {
        Ok(o) => o,
        Err(e) => return Ok(Err(Refused::new(&e, Some(&header)))),
    };
    Ok(match parse_measurements(bytes, source, &opts) {
        Ok(set) => Ok(FileRead { set, header }),
        Err(e) => Err(Refused::new(&e, Some(&header))),
    })
}

/// The file at `path` (NUL-terminated) read into memory, then as [`read_bytes`].
///
/// # Safety
/// `path` NULL or NUL-terminated.
unsafe fn read_path(
    path: *const c_char,
    robot: Option<&kincal_robot>,
    flags: u32,
) -> ReadOutcome<FileRead> {
    if path.is_null() {
        return Err(crate::args::null(c"path"));
    }
    // SAFETY: non-NULL and NUL-terminated by contract.
    let path = path_of(unsafe { CStr::from_ptr(path) });
    let source = path.display().to_string();
    match std::fs::read(&path) {
        Ok(bytes) => read_bytes(&bytes, &source, robot, flags),
        Err(e) => {
            let why = format!("cannot open the file: {e}");
            Ok(Err(Refused::new(&refusal(&source, None, None, &why), None)))
        }
    }
}

/// The caller's bytes as a slice.
///
/// # Safety
/// `bytes` NULL or readable for `bytes_len` bytes.
unsafe fn buffer<'a>(bytes: *const c_char, bytes_len: usize) -> FfiResult<&'a [u8]> {
    let b = arg_slice!(bytes, bytes_len, bytes_len);
    // SAFETY: `c_char` and `u8` have the same size and alignment.
    Ok(unsafe { core::slice::from_raw_parts(b.as_ptr().cast::<u8>(), b.len()) })
}

/// The strings of `text`, in their order (see `kincal_measurement_buffers.text`).
fn text_items(f: &FileRead) -> impl Iterator<Item = &str> {
    let rows = f.set.rows.iter().flat_map(|r| {
        r.pose_id
            .as_deref()
            .into_iter()
            .chain(r.extras.iter().map(String::as_str))
    });
    f.set
        .comments
        .iter()
        .map(String::as_str)
        .chain(f.header.columns.iter().map(String::as_str))
        .chain(rows)
}

fn sizes_of(f: &FileRead) -> kincal_measurement_sizes {
    let s = &f.set;
    let flag = |b: bool| u32::from(b);
    kincal_measurement_sizes {
        n_rows: s.rows.len(),
        n_joints: s.n_joints,
        n_columns: f.header.columns.len(),
        n_comments: s.comments.len(),
        n_extra: s.extra_columns.len(),
        text_len: text_items(f).map(|t| t.len() + 1).sum(),
        header_line: usize::try_from(s.header_line).unwrap_or(usize::MAX),
        orientation: match s.orientation_form {
            None => 0,
            Some(kincal_io::measurements::OrientationForm::Rpy) => 1,
            Some(kincal_io::measurements::OrientationForm::Quaternion) => 2,
        },
        has_position: flag(s.has_position),
        has_pose_id: flag(s.has_pose_id()),
        has_approach: flag(s.has_approach),
        has_temperature: flag(s.has_temperature),
        has_contacts: flag(s.has_point || s.has_target || s.has_plane || s.has_session),
    }
}

/// Writes the outcome of a read to `read_err` and, when it succeeded, lets `write` use it.
///
/// # Safety
/// `read_err` NULL or writable (alignment checked here).
unsafe fn finish<T>(
    outcome: ReadOutcome<T>,
    read_err: *mut kincal_read_error,
    write: impl FnOnce(T) -> FfiResult,
) -> FfiResult {
    let (result, detail) = match outcome {
        Err(e) => (
            Err(e),
            kincal_read_error::from_message(&status_text(e.kind()), 0, 0),
        ),
        Ok(Err(r)) => (
            Err(kincal_error::new(kincal_status::BadFile)),
            kincal_read_error::from_message(&r.message, r.line, r.column),
        ),
        Ok(Ok(v)) => match write(v) {
            Ok(()) => (Ok(()), kincal_read_error::from_message("", 0, 0)),
            Err(e) => (
                Err(e),
                kincal_read_error::from_message(&status_text(e.kind()), 0, 0),
            ),
        },
    };
    if !read_err.is_null() && read_err.is_aligned() {
        // SAFETY: NULL and alignment checked; writable by contract.
        unsafe { read_err.write(detail) };
    }
    result
}

/// The identity as 16 column-major values.
const IDENTITY: [f64; 16] = [
    1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
];

/// The pose and mask of every row (identity and 0 for rows without a position).
fn poses_of(set: &MeasurementSet) -> Result<Vec<([f64; 16], u8)>, Refused> {
    set.rows
        .iter()
        .map(
            |row| match kincal_io::data::measured_pose(row, &set.source) {
                Ok(Some((t, mask))) => Ok((crate::pose::to_matrix(&t), mask.0)),
                Ok(None) => Ok((IDENTITY, 0)),
                Err(e) => Err(Refused {
                    line: usize::try_from(row.line).unwrap_or(0),
                    column: 0,
                    message: e.message,
                }),
            },
        )
        .collect()
}

fn aux_of(set: &MeasurementSet) -> Vec<kincal_joint_aux> {
    set.rows
        .iter()
        .map(|row| {
            let mut approach = [0.0; KINCAL_MAX_JOINTS];
            for (d, s) in approach.iter_mut().zip(row.approach.iter().flatten()) {
                *d = f64::from(*s);
            }
            kincal_joint_aux {
                has_approach: u32::from(row.approach.is_some()),
                has_temp: u32::from(row.temp_c.is_some()),
                approach,
                temp_c: row.temp_c.unwrap_or(0.0),
            }
        })
        .collect()
}

/// Copies the file into the caller's buffers (all checked before any is written).
///
/// # Safety
/// Every non-NULL pointer of `b` writable for its stated length.
unsafe fn write_buffers(f: &FileRead, b: &kincal_measurement_buffers) -> FfiResult {
    let sizes = sizes_of(f);
    let (l, n) = (sizes.n_rows, sizes.n_joints);
    let ln = l
        .checked_mul(n)
        .ok_or_else(|| crate::args::bad_length(c"buffers->q", usize::MAX, b.q_len))?;
    let out_q = out_opt(b.q, b.q_len, ln, c"buffers->q")?;
    let out_p = out_opt(b.poses, b.poses_len, 16 * l, c"buffers->poses")?;
    let out_m = out_opt(b.masks, b.masks_len, l, c"buffers->masks")?;
    let out_a = out_opt(b.aux, b.aux_len, l, c"buffers->aux")?;
    let out_l = out_opt(b.lines, b.lines_len, l, c"buffers->lines")?;
    let out_t = out_opt(b.text, b.text_len, sizes.text_len, c"buffers->text")?;
    // A quaternion the core refuses is a refusal of the file, found before any write.
    let poses = poses_of(&f.set).map_err(|_| kincal_error::new(kincal_status::BadFile))?;
    let q: Vec<f64> = f
        .set
        .rows
        .iter()
        .flat_map(|r| r.q_rad.iter().copied())
        .collect();
    let flat: Vec<f64> = poses.iter().flat_map(|(t, _)| t.iter().copied()).collect();
    let masks: Vec<u8> = poses.iter().map(|(_, m)| *m).collect();
    let lines: Vec<usize> = f
        .set
        .rows
        .iter()
        .map(|r| usize::try_from(r.line).unwrap_or(usize::MAX))
        .collect();
    let text: Vec<c_char> = text_items(f)
        .flat_map(|t| t.bytes().chain(core::iter::once(0)))
        .map(|b| b as c_char)
        .collect();
    // SAFETY: each buffer checked (NULL, alignment, length) above; writable by contract;
    // the sources are Rust values.
    unsafe {
        if let Some(o) = out_q {
            o.write(&q);
        }
        if let Some(o) = out_p {
            o.write(&flat);
        }
        if let Some(o) = out_m {
            o.write(&masks);
        }
        if let Some(o) = out_a {
            o.write(&aux_of(&f.set));
        }
        if let Some(o) = out_l {
            o.write(&lines);
        }
        if let Some(o) = out_t {
            o.write(&text);
        }
    }
    Ok(())
}

fn out_opt<T: Copy>(
    p: *mut T,
    len: usize,
    expected: usize,
    name: &'static CStr,
) -> FfiResult<Option<crate::args::Out<T>>> {
    if p.is_null() {
        return Ok(None);
    }
    crate::args::Out::new(p, len, expected, name).map(Some)
}

/// Checks the quaternions of a read file (a refusal of the file, with its line).
fn checked(f: FileRead) -> Result<FileRead, Refused> {
    poses_of(&f.set).map(|_| f)
}

/// Reads and checks the measurement CSV at `path` (spec/measurements.md) with the CLI's
/// reader and writes its sizes to `sizes_out`, for the buffers of `kincal_measurements_read`.
///
/// - `path`: NUL-terminated file name (any bytes on Unix).
/// - `robot`: the robot the data are for (its joint count: exactly q1..qN; its limits,
///   inclusive), or NULL to take the joint count from the header (the highest `qK`) and
///   check no limits.
/// - `flags`: `KINCAL_READ_ALLOW_OUT_OF_LIMITS`, `KINCAL_READ_REQUIRE_POSE`, or 0.
/// - `sizes_out`: written on success.
/// - `read_err`: why the file was refused and where (line; column = the cell number), or
///   NULL.
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, INVALID_ARGUMENT (`flags`), BAD_FILE
/// (unreadable or refused: see `read_err`), any status of `kincal_robot_validate`.
/// Available in std builds only.
///
/// # Safety
/// `path` NUL-terminated; `robot` NULL or readable; `sizes_out`, `read_err`, `err` NULL or
/// writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_measurements_read_sizes(
    path: *const c_char,
    robot: *const kincal_robot,
    flags: u32,
    sizes_out: *mut kincal_measurement_sizes,
    read_err: *mut kincal_read_error,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let outcome = (|| -> ReadOutcome<FileRead> {
            let r = arg_opt!(robot);
            arg_out1!(sizes_out);
            // SAFETY: forwarded contract.
            Ok(unsafe { read_path(path, r, flags) }?.and_then(checked))
        })();
        // SAFETY: forwarded contract.
        unsafe {
            finish(outcome, read_err, |f| {
                let out = arg_out1!(sizes_out);
                out.put(sizes_of(&f));
                Ok(())
            })
        }
    })
}

/// Reads the measurement CSV at `path` into the caller's buffers, whose lengths
/// `kincal_measurements_read_sizes` gave for the same `path`, `robot` and `flags`.
///
/// - `buffers`: where to write (each pointer NULL or of exactly its stated length).
/// - the other arguments as `kincal_measurements_read_sizes`.
///
/// Returns the statuses of `kincal_measurements_read_sizes`, and BAD_LENGTH when a buffer's
/// length does not fit the file (`argument` names it). Outputs are written on success only.
///
/// # Safety
/// As `kincal_measurements_read_sizes`; `buffers` readable, each of its non-NULL pointers
/// writable for its length.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_measurements_read(
    path: *const c_char,
    robot: *const kincal_robot,
    flags: u32,
    buffers: *const kincal_measurement_buffers,
    read_err: *mut kincal_read_error,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let outcome = (|| -> ReadOutcome<(FileRead, kincal_measurement_buffers)> {
            let r = arg_opt!(robot);
            let b = *arg_ref!(buffers);
            // SAFETY: forwarded contract.
            Ok(unsafe { read_path(path, r, flags) }?.and_then(checked).map(|f| (f, b)))
        })();
        // SAFETY: forwarded contract.
        unsafe { finish(outcome, read_err, |(f, b)| write_buffers(&f, &b)) }
    })
}

/// As `kincal_measurements_read_sizes`, from the file's bytes in memory (`bytes`,
/// `bytes_len` bytes; no NUL needed). Messages name the source `"buffer"`.
///
/// # Safety
/// `bytes` readable for `bytes_len` bytes; the other pointers as in
/// `kincal_measurements_read_sizes`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_measurements_read_buffer_sizes(
    bytes: *const c_char,
    bytes_len: usize,
    robot: *const kincal_robot,
    flags: u32,
    sizes_out: *mut kincal_measurement_sizes,
    read_err: *mut kincal_read_error,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let outcome = (|| -> ReadOutcome<FileRead> {
            let r = arg_opt!(robot);
            arg_out1!(sizes_out);
            // SAFETY: forwarded contract.
            let bytes = unsafe { buffer(bytes, bytes_len) }?;
            Ok(read_bytes(bytes, "buffer", r, flags)?.and_then(checked))
        })();
        // SAFETY: forwarded contract.
        unsafe {
            finish(outcome, read_err, |f| {
                let out = arg_out1!(sizes_out);
                out.put(sizes_of(&f));
                Ok(())
            })
        }
    })
}

/// As `kincal_measurements_read`, from the file's bytes in memory (see
/// `kincal_measurements_read_buffer_sizes`).
///
/// # Safety
/// As `kincal_measurements_read_buffer_sizes` and `kincal_measurements_read`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_measurements_read_buffer(
    bytes: *const c_char,
    bytes_len: usize,
    robot: *const kincal_robot,
    flags: u32,
    buffers: *const kincal_measurement_buffers,
    read_err: *mut kincal_read_error,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let outcome = (|| -> ReadOutcome<(FileRead, kincal_measurement_buffers)> {
            let r = arg_opt!(robot);
            let b = *arg_ref!(buffers);
            // SAFETY: forwarded contract.
            let bytes = unsafe { buffer(bytes, bytes_len) }?;
            Ok(read_bytes(bytes, "buffer", r, flags)?.and_then(checked).map(|f| (f, b)))
        })();
        // SAFETY: forwarded contract.
        unsafe { finish(outcome, read_err, |(f, b)| write_buffers(&f, &b)) }
    })
}
