//! One module per `kincal` command (spec/cli.md): its clap `Args`, its `--help` text and
//! its `run`. The helpers that only some commands need sit beside them: the contact-data
//! runs of `crossval` and `diagnose`, and in `design/` what the three design commands
//! (`select-poses`, `design-tool`, `evaluate-designs`) share.

pub mod calibrate;
pub mod crossval;
pub mod crossval_contacts;
pub mod demo;
pub mod design;
pub mod design_tool;
pub mod diagnose;
pub mod diagnose_contacts;
pub mod diagnose_where;
pub mod evaluate;
pub mod export;
pub mod import;
pub mod import_bag;
pub mod markers;
pub mod observed_point;
pub mod predict;
pub mod select;
pub mod validate;
