//! Model files from C (std builds only): `kincal_model_read` and `kincal_model_read_buffer`
//! read a model file written by the kincal CLI through kincal-io's reader, the same one the
//! CLI and Octave use, so a file the CLI refuses is refused here with the same message and
//! position (`kincal_read_error`). The firmware (no_std) library has no file reader: compile
//! the model in instead (`kincal export --c-header`), or define `KINCAL_NO_STD` to hide these
//! declarations.

use core::ffi::{CStr, c_char};

use kincal_io::model_read::{self, Model};

use crate::robot::{from_any, kincal_robot};
use crate::status::{FfiResult, kincal_error, kincal_status};

/// Capacity of `kincal_read_error.message` in bytes, including the terminating NUL.
pub const KINCAL_READ_MESSAGE_LEN: usize = 512;

/// Why a file was refused, where in it, in words: a caller-owned plain struct (pass NULL when
/// not wanted). Every call that takes one overwrites all of it: on success `line` and
/// `column` 0 and `message` empty; on `KINCAL_STATUS_BAD_FILE` the reader's message (the
/// CLI's, e.g. `"model.json:12:5: not valid JSON: …"`) and its position; on any other status
/// that status's text.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub struct kincal_read_error {
    /// 1-based line of the fault, 0 when the message names no line.
    pub line: usize,
    /// 1-based column of the fault, 0 when the message names none: bytes in a model file,
    /// the cell (field) number in a measurement CSV.
    pub column: usize,
    /// NUL-terminated UTF-8 message, cut at a character boundary if longer than the buffer.
    pub message: [c_char; KINCAL_READ_MESSAGE_LEN],
}

/// A refusal by the file reader: its message and position, and the status.
struct Refusal {
    status: kincal_status,
    message: String,
    source: String,
}

type ReadResult<T> = Result<T, Refusal>;

fn refusal(e: kincal_io::Error, source: &str) -> Refusal {
    // A variant the file does not hold is a bad argument, not a bad file.
    let status = match e.kind {
        kincal_io::Kind::Usage => kincal_status::InvalidArgument,
        _ => kincal_status::BadFile,
    };
    Refusal {
        status,
        message: e.message,
        source: source.to_string(),
    }
}

impl kincal_read_error {
    pub(crate) fn from_message(message: &str, line: usize, column: usize) -> Self {
        let mut out = kincal_read_error {
            line,
            column,
            message: [0; KINCAL_READ_MESSAGE_LEN],
        };
        let mut end = message.len().min(KINCAL_READ_MESSAGE_LEN - 1);
        while !message.is_char_boundary(end) {
            end -= 1;
        }
        for (dst, src) in out
            .message
            .iter_mut()
            .zip(message.as_bytes().iter().take(end))
        {
            *dst = *src as c_char;
        }
        out
    }
}

/// The path of a C string (any bytes on Unix).
pub(crate) fn path_of(p: &CStr) -> std::path::PathBuf {
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        std::path::PathBuf::from(std::ffi::OsStr::from_bytes(p.to_bytes()))
    }
    #[cfg(not(unix))]
    {
        std::path::PathBuf::from(p.to_string_lossy().into_owned())
    }
}

/// The optional variant name (NULL = the stored model).
///
/// # Safety
/// `variant` is NULL or a NUL-terminated string.
unsafe fn variant_name<'a>(variant: *const c_char) -> FfiResult<&'a str> {
    if variant.is_null() {
        return Ok(model_read::STORED);
    }
    // SAFETY: non-NULL and NUL-terminated by contract.
    unsafe { CStr::from_ptr(variant) }
        .to_str()
        .map_err(|_| kincal_error::new(kincal_status::InvalidArgument).arg(c"variant"))
}

/// The robot struct of `variant` of a model read from `source`.
fn robot_of(model: ReadResult<Model>, variant: &str, source: &str) -> ReadResult<kincal_robot> {
    let model = model?;
    let any = model_read::variant(&model, variant, source).map_err(|e| refusal(e, source))?;
    from_any(&any).map_err(|e| Refusal {
        status: e.kind(),
        message: format!("{source}: the model does not fit kincal_robot"),
        source: source.to_string(),
    })
}

/// Writes the outcome of a read to `robot_out`, `read_err` and `err`.
///
/// # Safety
/// `robot_out` NULL or writable; `read_err` NULL or writable; checked for alignment here.
unsafe fn finish_read(
    result: FfiResult<ReadResult<kincal_robot>>,
    robot_out: *mut kincal_robot,
    read_err: *mut kincal_read_error,
) -> FfiResult {
    let (outcome, detail) = match result {
        Err(e) => (
            Err(e),
            kincal_read_error::from_message(&status_text(e.kind()), 0, 0),
        ),
        Ok(Err(r)) => {
            let (line, column) = model_read::position(&r.message, &r.source);
            let to_usize = |v: Option<u64>| v.and_then(|v| usize::try_from(v).ok()).unwrap_or(0);
            let detail =
                kincal_read_error::from_message(&r.message, to_usize(line), to_usize(column));
            (Err(kincal_error::new(r.status)), detail)
        }
        Ok(Ok(robot)) => {
            let out = crate::args::Out::new(robot_out, 1, 1, c"robot_out");
            let outcome = out.map(|out| {
                // SAFETY: checked by `Out::new`; writable by contract.
                unsafe { out.put(robot) }
            });
            (outcome, kincal_read_error::from_message("", 0, 0))
        }
    };
    if !read_err.is_null() && read_err.is_aligned() {
        // SAFETY: NULL and alignment checked; writable by contract.
        unsafe { read_err.write(detail) };
    }
    outcome
}

pub(crate) fn status_text(s: kincal_status) -> String {
    s.text().to_string_lossy().into_owned()
}

/// Reads the model file at `path` (written by `kincal calibrate`, `diagnose`, …) into
/// `robot_out`, with the CLI's validation: schema version, every parameter present once by
/// its label, joint count, length parameters, effects, finite plausible numbers.
///
/// - `path`: NUL-terminated file name (any bytes on Unix).
/// - `variant`: NULL or `""` for the model the file stores; `"NOM"` for every parameter at
///   its nominal value (the model the calibration started from); `"OLS"`, `"OPT1"`, `"OPT2"`
///   for the stored model with that algorithm's identified parameters (case-insensitive).
/// - `robot_out`: written on success only; need not be initialised.
/// - `read_err`: why the file was refused and where (line, column, message), or NULL.
/// - `err`: detail on failure, or NULL.
///
/// Returns OK, NULL_POINTER, MISALIGNED_POINTER, BAD_FILE (unreadable or refused: see
/// `read_err`) or INVALID_ARGUMENT (a variant the file does not hold, or not UTF-8).
/// Available in std builds only (not in the firmware library).
///
/// # Safety
/// `path` and non-NULL `variant` are NUL-terminated strings; `robot_out`, `read_err` and
/// `err` are NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_model_read(
    path: *const c_char,
    variant: *const c_char,
    robot_out: *mut kincal_robot,
    read_err: *mut kincal_read_error,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let result = (|| -> FfiResult<ReadResult<kincal_robot>> {
            crate::args::Out::new(robot_out, 1, 1, c"robot_out")?;
            if path.is_null() {
                return Err(crate::args::null(c"path"));
            }
            // SAFETY: non-NULL and NUL-terminated by contract.
            let path = path_of(unsafe { CStr::from_ptr(path) });
            // SAFETY: forwarded contract.
            let variant = unsafe { variant_name(variant) }?;
            let source = path.display().to_string();
            let model = model_read::read_model_file(&path).map_err(|e| refusal(e, &source));
            Ok(robot_of(model, variant, &source))
        })();
        // SAFETY: forwarded contract.
        unsafe { finish_read(result, robot_out, read_err) }
    })
}

/// As `kincal_model_read`, from the file's bytes in memory (`bytes`, `bytes_len` bytes of
/// UTF-8; no NUL needed). Messages name the source `"buffer"` (e.g. `"buffer:3:7: …"`).
///
/// # Safety
/// `bytes` readable for `bytes_len` bytes; the other pointers as in `kincal_model_read`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_model_read_buffer(
    bytes: *const c_char,
    bytes_len: usize,
    variant: *const c_char,
    robot_out: *mut kincal_robot,
    read_err: *mut kincal_read_error,
    err: *mut kincal_error,
) -> kincal_status {
    ffi_boundary!(err = err; {
        let result = (|| -> FfiResult<ReadResult<kincal_robot>> {
            crate::args::Out::new(robot_out, 1, 1, c"robot_out")?;
            let bytes = arg_slice!(bytes, bytes_len, bytes_len);
            // SAFETY: forwarded contract.
            let variant = unsafe { variant_name(variant) }?;
            let bytes: Vec<u8> = bytes.iter().map(|&b| b as u8).collect();
            let source = "buffer";
            let model = model_read::read_model_bytes(&bytes, source).map_err(|e| refusal(e, source));
            Ok(robot_of(model, variant, source))
        })();
        // SAFETY: forwarded contract.
        unsafe { finish_read(result, robot_out, read_err) }
    })
}
