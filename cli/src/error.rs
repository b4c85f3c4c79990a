//! The CLI's error type and its exit codes (spec/cli.md): 2 usage, 3 bad input, 4 numerical
//! failure. Output files that cannot be written exit with 1.

use std::fmt;

use crate::files::{OutputError, OutputErrorKind};
use crate::measurements::InputError;

/// Exit status of a failed command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Exit {
    /// An output could not be written (file system).
    Io = 1,
    /// Wrong or contradictory arguments (clap's own usage errors also exit 2).
    Usage = 2,
    /// A bad input file: file, line, column and reason.
    Input = 3,
    /// No convergence, rank too low, unreachable pose.
    Numeric = 4,
}

/// A command failure: what to print on stderr and the exit status.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CliError {
    pub exit: Exit,
    pub message: String,
}

impl CliError {
    pub fn usage(message: impl Into<String>) -> Self {
        CliError {
            exit: Exit::Usage,
            message: message.into(),
        }
    }
    pub fn input(message: impl Into<String>) -> Self {
        CliError {
            exit: Exit::Input,
            message: message.into(),
        }
    }
    pub fn numeric(message: impl Into<String>) -> Self {
        CliError {
            exit: Exit::Numeric,
            message: message.into(),
        }
    }
    pub fn io(message: impl Into<String>) -> Self {
        CliError {
            exit: Exit::Io,
            message: message.into(),
        }
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for CliError {}

impl From<InputError> for CliError {
    fn from(e: InputError) -> Self {
        CliError::input(e.to_string())
    }
}

impl From<OutputError> for CliError {
    fn from(e: OutputError) -> Self {
        match e.kind {
            // Naming an input as the output is a contradictory command line.
            OutputErrorKind::SameAsInput => CliError::usage(e.to_string()),
            OutputErrorKind::Io => CliError::io(e.to_string()),
        }
    }
}

/// A core error at pose `pose_line` of `file` (if known), classified for the exit status.
pub fn core_error(
    e: kincal::Error,
    file: &str,
    pose_line: impl Fn(usize) -> Option<u64>,
) -> CliError {
    use kincal::Error as E;
    let at = |index: usize| match pose_line(index) {
        Some(line) => format!("{file}:{line}"),
        None => file.to_string(),
    };
    match e {
        E::NonFinite { index, .. } => CliError::input(format!("{}: {e}", at(index))),
        E::BadPose { pose } => CliError::input(format!("{}: {e}", at(pose.0))),
        E::BadGroup { .. } | E::DegenerateGroup { .. } | E::BadDistance { .. } => {
            CliError::input(format!("{file}: {e}"))
        }
        E::OutOfLimits { .. } | E::MissingInput { .. } | E::DimensionMismatch { .. } => {
            CliError::input(format!("{file}: {e}"))
        }
        _ => CliError::numeric(format!("{file}: {e}")),
    }
}
