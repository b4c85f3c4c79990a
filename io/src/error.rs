//! The error type of every reader, writer and study in this crate, classified by whose fault
//! it is. The kinds' values are the CLI's exit statuses (spec/cli.md): 2 usage, 3 bad input,
//! 4 numerical failure, 1 an output that cannot be written; other front ends map them to
//! their own codes (the C ABI to status codes, Octave to `kincal:` error identifiers).

use std::fmt;

use crate::files::{OutputError, OutputErrorKind};
use crate::measurements::InputError;

/// Whose fault a failure is (its value is the CLI's exit status).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// An output could not be written (file system).
    Io = 1,
    /// Wrong or contradictory arguments (clap's own usage errors also exit 2).
    Usage = 2,
    /// A bad input file: file, line, column and reason.
    Input = 3,
    /// No convergence, rank too low, unreachable pose.
    Numeric = 4,
}

/// A failure: the message (naming file, line and column where there are any) and its kind.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Error {
    pub kind: Kind,
    pub message: String,
}

impl Error {
    pub fn usage(message: impl Into<String>) -> Self {
        Error {
            kind: Kind::Usage,
            message: message.into(),
        }
    }
    pub fn input(message: impl Into<String>) -> Self {
        Error {
            kind: Kind::Input,
            message: message.into(),
        }
    }
    pub fn numeric(message: impl Into<String>) -> Self {
        Error {
            kind: Kind::Numeric,
            message: message.into(),
        }
    }
    pub fn io(message: impl Into<String>) -> Self {
        Error {
            kind: Kind::Io,
            message: message.into(),
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Error {}

impl From<InputError> for Error {
    fn from(e: InputError) -> Self {
        Error::input(e.to_string())
    }
}

impl From<OutputError> for Error {
    fn from(e: OutputError) -> Self {
        match e.kind {
            // Naming an input as the output is a contradictory command line.
            OutputErrorKind::SameAsInput => Error::usage(e.to_string()),
            OutputErrorKind::Io => Error::io(e.to_string()),
        }
    }
}

/// A core error at pose `pose_line` of `file` (if known), classified for the exit status.
pub fn core_error(e: kincal::Error, file: &str, pose_line: impl Fn(usize) -> Option<u64>) -> Error {
    use kincal::Error as E;
    let at = |index: usize| match pose_line(index) {
        Some(line) => format!("{file}:{line}"),
        None => file.to_string(),
    };
    match e {
        // The readers refuse non-finite and implausibly large numbers, so a non-finite
        // value here arose in the computation: its `index` is a parameter, option or vector
        // element, not a row, and no line of DATA is to blame.
        E::NonFinite {
            what: kincal::Quantity::Setting,
            ..
        } => Error::usage(format!(
            "an option gave a non-finite number ({e}): check the weights, noise levels and bounds given"
        )),
        E::NonFinite { .. } => Error::numeric(format!(
            "the computation overflowed while fitting {file} ({e}): the data or the robot hold numbers too large to fit"
        )),
        E::BadPose { pose } => Error::input(format!("{}: {e}", at(pose.0))),
        E::BadGroup { .. } | E::DegenerateGroup { .. } | E::BadDistance { .. } => {
            Error::input(format!("{file}: {e}"))
        }
        E::OutOfLimits { .. } | E::MissingInput { .. } | E::DimensionMismatch { .. } => {
            Error::input(format!("{file}: {e}"))
        }
        _ => Error::numeric(format!("{file}: {e}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kincal::Quantity;

    #[test]
    fn a_non_finite_core_value_is_not_blamed_on_a_row() {
        // Row i starts on line i + 5: an index 1 must not become "d.csv:6".
        let line = |i: usize| Some(i as u64 + 5);
        let e = core_error(
            kincal::Error::NonFinite {
                what: Quantity::Parameter,
                index: 1,
            },
            "d.csv",
            line,
        );
        assert_eq!(e.kind, Kind::Numeric, "{e}");
        assert!(!e.message.contains("d.csv:"), "{e}");
        assert!(e.message.contains("overflowed"), "{e}");
        let e = core_error(
            kincal::Error::NonFinite {
                what: Quantity::Setting,
                index: 0,
            },
            "d.csv",
            line,
        );
        assert_eq!(e.kind, Kind::Usage, "{e}");
        assert!(!e.message.contains("d.csv"), "{e}");
        // A bad pose keeps its row.
        let e = core_error(
            kincal::Error::BadPose {
                pose: kincal::PoseIndex(1),
            },
            "d.csv",
            line,
        );
        assert!(e.message.starts_with("d.csv:6:"), "{e}");
    }
}
