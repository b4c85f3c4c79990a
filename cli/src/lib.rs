//! The `kincal` command-line tool as a library: the commands and the file formats
//! (measurement CSV, robot description TOML, URDF import, model JSON), so that integration
//! tests and the fuzz targets (`fuzz/`) exercise exactly the code the binary runs.

// The argument structs' doc comments are the `--help` text, where units read `[mm]`; escaping
// them for rustdoc would print the backslashes in the help.
#![allow(rustdoc::broken_intra_doc_links, rustdoc::private_intra_doc_links)]

pub mod args;
pub mod calibration;
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
pub mod constraints;
pub mod crossval_contacts;
pub mod data;
pub mod datasets;
pub mod datasets_contact;
pub mod design_args;
pub mod designs;
pub mod diagnose_contacts;
pub mod diagnosis_plot;
pub mod error;
pub mod file_plan;
pub mod files;
pub mod measurements;
pub mod model_file;
pub mod plate;
pub mod plausibility;
pub mod plot;
pub mod progress;
pub mod report;
pub mod robot_arg;
pub mod robot_file;
pub mod study;
pub mod study_plot;
pub mod tool_file;
pub mod units;
pub mod urdf;
pub mod urdf_update;
