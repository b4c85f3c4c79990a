//! kincal's file formats and the runs every front end shares: the measurement CSV, model
//! files, robot descriptions (TOML), URDF in and out, tool files, the real-data importers,
//! atomic output files, and the calibration runs over the core. The command line (`cli/`),
//! the C ABI's std build (`ffi/`) and the MEX gateway read files through this crate only, so
//! a file one front end refuses every front end refuses, with the same file:line:column.
//!
//! Errors are [`Error`] values whose [`Kind`] says whose fault a failure is.

// Units in doc comments read `[m]`, `[rad]`, as in the CLI these files came from, where the
// argument structs' doc comments (robot_arg's, with the `clap` feature) are the `--help` text
// and escaping them would print the backslashes there.
#![allow(rustdoc::broken_intra_doc_links, rustdoc::private_intra_doc_links)]

pub mod calibration;
pub mod cdr;
pub mod constraints;
pub mod crossval;
pub mod crossval_contacts;
pub mod data;
pub mod datasets;
pub mod datasets_contact;
pub mod datasets_hilti;
pub mod datasets_tiago;
pub mod design;
pub mod diagnose;
pub mod diagnose_contacts;
pub mod diagnose_sessions;
pub mod diagnose_where;
pub mod effects_arg;
pub mod error;
pub mod files;
pub mod hilti_study;
pub mod mcap_reader;
pub mod measurements;
pub mod model_file;
pub mod model_read;
pub mod plausibility;
pub mod pose_calibration;
pub mod robot_arg;
pub mod robot_file;
pub mod rosbag;
pub mod session_frames;
pub mod session_scores;
pub mod tool_file;
pub mod units;
pub mod urdf;
pub mod urdf_update;

pub use error::{Error, Kind};
