//! A calibration of measured poses as every front end runs it (`kincal calibrate`, Python's
//! `kincal.calibrate`): the rows and the plausibility findings before the fit, and the model
//! file after it. Front ends add only their wording, progress and report text.

use kincal::Robot;
use kincal::identify::Measurement;

use crate::calibration::Calibration;
use crate::data;
use crate::error::Error;
use crate::measurements::MeasurementSet;
use crate::model_file::{DataJson, ModelFile, PoseLabel};
use crate::plausibility::{self, DataFindings};

/// Pose rows ready for the fit.
#[derive(Debug, Clone)]
pub struct PoseData<const N: usize> {
    pub meas: Vec<Measurement<N>>,
    /// Measured components over all rows (the least-squares rows).
    pub rows: usize,
    /// What cannot be right about the data (`errors`: refused unless the caller allows
    /// implausible data) and what is suspicious (`warnings`).
    pub findings: DataFindings,
}

/// The rows of `set` as core measurements, with the plausibility findings for `start`
/// (`frames_unknown`: the base and tool frames will be estimated first).
pub fn pose_data<const N: usize>(
    set: &MeasurementSet,
    start: &Robot<N>,
    frames_unknown: bool,
) -> Result<PoseData<N>, Error> {
    let meas = data::measurements::<N>(set)?;
    Ok(pose_data_of(meas, &set.source, start, frames_unknown))
}

/// [`pose_data`] of measurements already read (`data::read_poses`) from `source`.
pub fn pose_data_of<const N: usize>(
    meas: Vec<Measurement<N>>,
    source: &str,
    start: &Robot<N>,
    frames_unknown: bool,
) -> PoseData<N> {
    let findings = plausibility::check_data(start, &meas, source, frames_unknown);
    let rows = meas
        .iter()
        .map(|m| (0..6).filter(|&k| m.mask.has(k)).count())
        .sum();
    PoseData {
        meas,
        rows,
        findings,
    }
}

/// The model file of calibration `cal` of `set` (read from `data_path`): the first run's
/// model, every run, the robust fit's suspects, and the data's and result's warnings. Also
/// returns the warnings about the result alone (the data's were known before the fit).
pub fn model_file<const N: usize>(
    name: &str,
    cal: &Calibration<N>,
    set: &MeasurementSet,
    data_path: &str,
    data: &PoseData<N>,
    allow_out_of_limits: bool,
) -> (ModelFile, Vec<String>) {
    let label = |i: usize| {
        set.rows.get(i).map(|r| PoseLabel {
            line: r.line,
            pose_id: r.pose_id.clone(),
        })
    };
    let data_json = DataJson {
        path: data_path.to_string(),
        sha256: set.sha256.clone(),
        poses: data.meas.len(),
        rows: data.rows,
    };
    model_file_of(name, cal, data_json, data, &label, allow_out_of_limits)
}

/// [`model_file`] with the data's reference (`data_json`) and each row's label (`label`:
/// line and `pose_id` of row `i`, e.g. `data::RowLabels::label`) given.
pub fn model_file_of<const N: usize>(
    name: &str,
    cal: &Calibration<N>,
    data_json: DataJson,
    data: &PoseData<N>,
    label: &dyn Fn(usize) -> Option<PoseLabel>,
    allow_out_of_limits: bool,
) -> (ModelFile, Vec<String>) {
    let mut file = ModelFile::from_calibration(name, cal, 0, data_json, allow_out_of_limits);
    file.record_robust(cal, 0, label);
    let result_warnings = plausibility::check_result(&file);
    let warnings = data
        .findings
        .errors
        .iter()
        .chain(&data.findings.warnings)
        .chain(&result_warnings)
        .cloned()
        .collect();
    if let Some(c) = file.calibration.as_mut() {
        c.warnings = warnings;
    }
    (file, result_warnings)
}
