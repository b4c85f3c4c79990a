//! The CLI's error type is kincal-io's [`kincal_io::Error`]: its kind is the exit status
//! (spec/cli.md): 2 usage, 3 bad input, 4 numerical failure, 1 an output that cannot be
//! written.

pub use kincal_io::error::{Error as CliError, Kind as Exit, core_error};
