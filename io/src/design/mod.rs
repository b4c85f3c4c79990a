//! The runs of the design commands (`kincal select-poses`, `design-tool`,
//! `evaluate-designs`) and of Python's `kincal.select_poses`/`design_tool`/
//! `evaluate_designs`, as data: the resolved setting (`context`), the data-acquisition
//! designs (`designs`), the Monte-Carlo comparison of designs (`study`), the pose selection
//! (`pose_selection`), the calibration-tool search (`tool_design`), the evaluation of
//! several designs (`evaluation`) and the socket plates compared with them (`plate`). Front
//! ends word the results; nothing here prints.

pub mod context;
pub mod designs;
pub mod evaluation;
pub mod plate;
pub mod pose_selection;
pub mod study;
pub mod tool_design;

/// Progress of a long run, reported to the front end (a bar on a terminal; nothing in
/// Python). Calls come from worker threads, hence `Sync`. Every method defaults to nothing.
pub trait Progress: Sync {
    /// A new stage of `len` steps, `message` saying what it does.
    fn stage(&self, _len: u64, _message: &str) {}
    /// A new message within the current stage.
    fn message(&self, _message: &str) {}
    /// `n` more steps done.
    fn inc(&self, _n: u64) {}
}

/// No progress reports.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Progress for Silent {}
