//! kincal's failures as Python exceptions (classes in `kincal/_errors.py`): the io crate's
//! [`Kind`] picks the class, and the position in a bad file becomes attributes, so Python
//! code reads `err.line` rather than parsing the message.

use kincal_io::Kind;
use kincal_io::measurements::InputError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// An exception of class `name` (in `kincal._errors`) with `message` and keyword attributes.
fn raise(py: Python<'_>, name: &str, message: &str, kwargs: Option<&Bound<'_, PyDict>>) -> PyErr {
    let made = py
        .import("kincal._errors")
        .and_then(|m| m.getattr(name))
        .and_then(|class| class.call((message,), kwargs));
    match made {
        Ok(instance) => PyErr::from_value(instance),
        Err(e) => e,
    }
}

/// A bad argument (`kincal.UsageError`, a `ValueError`).
pub fn usage(py: Python<'_>, message: impl AsRef<str>) -> PyErr {
    raise(py, "UsageError", message.as_ref(), None)
}

/// A numerical failure (`kincal.NumericError`).
pub fn numeric(py: Python<'_>, message: impl AsRef<str>) -> PyErr {
    raise(py, "NumericError", message.as_ref(), None)
}

fn file_format(
    py: Python<'_>,
    message: &str,
    path: Option<&str>,
    line: Option<u64>,
    column: Option<u64>,
    field: Option<&str>,
) -> PyErr {
    let kwargs = PyDict::new(py);
    let set = || -> PyResult<()> {
        kwargs.set_item("path", path)?;
        kwargs.set_item("line", line)?;
        kwargs.set_item("column", column)?;
        kwargs.set_item("field", field)?;
        Ok(())
    };
    match set() {
        Ok(()) => raise(py, "FileFormatError", message, Some(&kwargs)),
        Err(e) => e,
    }
}

/// A rejected measurement file: its structured position (the CSV column is a name).
pub fn from_input(py: Python<'_>, e: &InputError) -> PyErr {
    file_format(
        py,
        &e.to_string(),
        Some(&e.path),
        e.line,
        None,
        e.column.as_deref(),
    )
}

/// The io crate's error. Its message starts `FILE:LINE[:COLUMN]: ` when it blames a place
/// in a file; `files` are the paths the call read, so the position is recovered exactly
/// (a path may itself hold ':').
pub fn from_io(py: Python<'_>, e: &kincal_io::Error, files: &[&str]) -> PyErr {
    match e.kind {
        Kind::Usage => usage(py, &e.message),
        Kind::Numeric => numeric(py, &e.message),
        Kind::Io => raise(py, "OutputError", &e.message, None),
        Kind::Input => {
            let (path, line, column) = position(&e.message, files);
            file_format(py, &e.message, path, line, column, None)
        }
    }
}

/// `(file, line, column)` at the start of `message`, for the first of `files` it starts with.
fn position<'a>(message: &str, files: &[&'a str]) -> (Option<&'a str>, Option<u64>, Option<u64>) {
    let Some((path, rest)) = files
        .iter()
        .find_map(|f| message.strip_prefix(f).map(|rest| (*f, rest)))
    else {
        return (None, None, None);
    };
    let mut numbers = rest
        .split(':')
        .skip(1)
        .map_while(|part| part.parse::<u64>().ok());
    let line = numbers.next();
    let column = numbers.next();
    (Some(path), line, column)
}

/// A core error from a direct call: bad arguments are `UsageError`, the rest `NumericError`.
pub fn from_core(py: Python<'_>, e: kincal::Error) -> PyErr {
    use kincal::Error as E;
    match e {
        E::NonFinite { .. }
        | E::DimensionMismatch { .. }
        | E::InvalidOption { .. }
        | E::OutOfLimits { .. }
        | E::MissingInput { .. }
        | E::BadPose { .. } => usage(py, e.to_string()),
        _ => numeric(py, e.to_string()),
    }
}
