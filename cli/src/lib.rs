//! The `kincal` command-line tool as a library: argument parsing, the commands, human-readable
//! text, progress and plots, so that integration tests exercise exactly the code the binary
//! runs. The file formats and the calibration runs live in kincal-io (`io/`).

// The argument structs' doc comments are the `--help` text, where units read `[mm]`; escaping
// them for rustdoc would print the backslashes in the help.
#![allow(rustdoc::broken_intra_doc_links, rustdoc::private_intra_doc_links)]

pub mod args;
pub mod cmd_calibrate;
pub mod cmd_crossval;
pub mod cmd_demo;
pub mod cmd_design_tool;
pub mod cmd_diagnose;
pub mod cmd_evaluate;
pub mod cmd_export;
pub mod cmd_import;
pub mod cmd_markers;
pub mod cmd_observed_point;
pub mod cmd_predict;
pub mod cmd_select;
pub mod cmd_validate;
pub mod crossval_contacts;
pub mod design_args;
pub mod designs;
pub mod diagnose_contacts;
pub mod diagnosis_plot;
pub mod error;
pub mod file_plan;
pub mod plate;
pub mod plot;
pub mod progress;
pub mod report;
pub mod study;
pub mod study_plot;

// The file formats moved to kincal-io; re-exported under their old paths so that the
// commands (and code written against `kincal_cli::measurements` etc.) keep their imports.
pub use kincal_io::{
    calibration, constraints, data, datasets, datasets_contact, datasets_hilti, files,
    measurements, model_file, plausibility, robot_arg, robot_file, tool_file, units, urdf,
    urdf_update,
};
