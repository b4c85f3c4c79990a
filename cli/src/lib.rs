//! The `kincal` command-line tool as a library: argument parsing, the commands, human-readable
//! text, progress and plots, so that integration tests exercise exactly the code the binary
//! runs. The file formats and the calibration runs live in kincal-io (`io/`).

// The argument structs' doc comments are the `--help` text, where units read `[mm]`; escaping
// them for rustdoc would print the backslashes in the help.
#![allow(rustdoc::broken_intra_doc_links, rustdoc::private_intra_doc_links)]

pub mod args;
pub mod commands;
pub mod error;
pub mod file_plan;
pub mod plots;
pub mod progress;
pub mod report;
