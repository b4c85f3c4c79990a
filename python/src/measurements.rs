//! `kincal.Measurements`: a measurement CSV (spec/measurements.md) read and written by the
//! io crate; numpy views of its joint readings and measured poses.

use std::path::PathBuf;

use kincal::pose::matrix_to_quaternion;
use kincal_io::data::measured_pose;
use kincal_io::measurements::{
    MeasurementRow, MeasurementSet, Orientation, OrientationForm, ReadOptions, read_measurements,
    write_measurements_csv,
};
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray2, PyArray3, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;

use crate::errors;
use crate::pose::{homogeneous, transform_from_matrix};
use crate::robot::Robot;

/// Rows of a measurement file: joint readings and what was measured at each.
#[pyclass(frozen, module = "kincal")]
#[derive(Debug, Clone)]
pub struct Measurements {
    pub(crate) set: MeasurementSet,
}

/// Reads a measurement CSV for ``robot`` (its joint count and limits). Lengths in the file
/// may be ``_mm`` and angles ``_deg``; the arrays are in metres and radians. A bad file
/// raises ``FileFormatError`` with ``path``, ``line`` and ``field`` (the CSV column).
#[pyfunction]
#[pyo3(name = "read_measurements", signature = (path, robot, require_pose=false, allow_out_of_limits=false))]
pub fn read_measurements_file(
    py: Python<'_>,
    path: PathBuf,
    robot: &Robot,
    require_pose: bool,
    allow_out_of_limits: bool,
) -> PyResult<Measurements> {
    let opts = read_options(robot, require_pose, allow_out_of_limits);
    let set = py
        .detach(|| read_measurements(&path, &opts))
        .map_err(|e| errors::from_input(py, &e))?;
    Ok(Measurements { set })
}

/// The rows a call names: a :class:`Measurements`, or a CSV path read for `robot` (poses
/// required).
pub(crate) fn measurement_set(
    py: Python<'_>,
    data: &Bound<'_, PyAny>,
    robot: &Robot,
    allow_out_of_limits: bool,
) -> PyResult<MeasurementSet> {
    if let Ok(m) = data.cast::<Measurements>() {
        return Ok(m.get().set.clone());
    }
    let path: PathBuf = data.extract()?;
    let opts = read_options(robot, true, allow_out_of_limits);
    py.detach(|| read_measurements(&path, &opts))
        .map_err(|e| errors::from_input(py, &e))
}

pub(crate) fn read_options(
    robot: &Robot,
    require_pose: bool,
    allow_out_of_limits: bool,
) -> ReadOptions {
    let mut opts = ReadOptions::new(robot.n_joints());
    opts.joint_limits = Some(kincal::with_any_robot!(&robot.robot, r => r
        .limits()
        .iter()
        .map(|l| (l.lower, l.upper))
        .collect()));
    opts.allow_out_of_limits = allow_out_of_limits;
    opts.require_pose = require_pose;
    opts
}

#[pymethods]
impl Measurements {
    /// Rows from arrays: joint readings ``q`` (M, n_joints) [rad] and optionally measured
    /// poses (M, 4, 4) [m] (written as x, y, z and a quaternion) and ``pose_ids``.
    #[staticmethod]
    #[pyo3(signature = (q, poses=None, pose_ids=None))]
    fn from_arrays(
        py: Python<'_>,
        q: PyReadonlyArray2<'_, f64>,
        poses: Option<PyReadonlyArray3<'_, f64>>,
        pose_ids: Option<Vec<String>>,
    ) -> PyResult<Self> {
        let q = q.as_array();
        let (m, n) = q.dim();
        if let Some(p) = &poses
            && p.as_array().dim().0 != m
        {
            return Err(errors::usage(
                py,
                format!("poses has {} rows, q has {m}", p.as_array().dim().0),
            ));
        }
        if let Some(ids) = &pose_ids
            && ids.len() != m
        {
            return Err(errors::usage(
                py,
                format!("pose_ids has {} entries, q has {m} rows", ids.len()),
            ));
        }
        let mut rows = Vec::with_capacity(m);
        for (i, qi) in q.rows().into_iter().enumerate() {
            let mut row = MeasurementRow::joints_only(i as u64 + 2, qi.to_vec());
            if let Some(p) = &poses {
                let t = transform_from_matrix(
                    py,
                    &p.as_array().index_axis(numpy::ndarray::Axis(0), i),
                    "poses",
                )?;
                let v = t.translation.vector;
                let [w, x, y, z] = matrix_to_quaternion(t.rotation.matrix());
                row.position_m = Some([v.x, v.y, v.z]);
                row.orientation = Some(Orientation::Quaternion { w, x, y, z });
            }
            row.pose_id = pose_ids.as_ref().and_then(|ids| ids.get(i).cloned());
            rows.push(row);
        }
        Ok(Measurements {
            set: MeasurementSet {
                source: "<arrays>".into(),
                comments: Vec::new(),
                n_joints: n,
                rows,
                extra_columns: Vec::new(),
                orientation_form: poses.as_ref().map(|_| OrientationForm::Quaternion),
                has_position: poses.is_some(),
                has_point: false,
                has_target: false,
                has_plane: false,
                has_session: false,
                has_approach: false,
                has_temperature: false,
                sha256: String::new(),
                header_line: 1,
            },
        })
    }

    /// The file the rows came from (as given).
    #[getter]
    fn source(&self) -> &str {
        &self.set.source
    }

    /// Number of joints.
    #[getter]
    fn n_joints(&self) -> usize {
        self.set.n_joints
    }

    /// SHA-256 of the file's bytes (lower-case hex; empty for rows made from arrays).
    #[getter]
    fn sha256(&self) -> &str {
        &self.set.sha256
    }

    fn __len__(&self) -> usize {
        self.set.rows.len()
    }

    /// Joint readings, shape (M, n_joints) [rad] ([m] for prismatic joints).
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let n = self.set.n_joints;
        Array2::from_shape_fn((self.set.rows.len(), n), |(i, j)| {
            self.set.rows[i].q_rad.get(j).copied().unwrap_or(f64::NAN)
        })
        .into_pyarray(py)
    }

    /// Measured positions, shape (M, 3) [m]; NaN where a row measured no coordinate.
    #[getter]
    fn position_m<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        Array2::from_shape_fn((self.set.rows.len(), 3), |(i, k)| {
            let row = &self.set.rows[i];
            match (row.position_m, row.partial_m) {
                (Some(p), _) => p[k],
                (None, Some(c)) => c[k].unwrap_or(f64::NAN),
                (None, None) => f64::NAN,
            }
        })
        .into_pyarray(py)
    }

    /// Measured poses, shape (M, 4, 4) [m]; rows without a measured orientation are NaN.
    #[getter]
    fn poses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let mut out = Array3::from_elem((self.set.rows.len(), 4, 4), f64::NAN);
        for (mut m, row) in out.outer_iter_mut().zip(&self.set.rows) {
            if row.orientation.is_none() {
                continue;
            }
            if let Some((t, _)) = measured_pose(row, &self.set.source)
                .map_err(|e| errors::from_io(py, &e, &[&self.set.source]))?
            {
                m.assign(&homogeneous(&t));
            }
        }
        Ok(out.into_pyarray(py))
    }

    /// 1-based line of the file where each row starts.
    #[getter]
    fn lines(&self) -> Vec<u64> {
        self.set.rows.iter().map(|r| r.line).collect()
    }

    /// Each row's ``pose_id`` (None without the column).
    #[getter]
    fn pose_ids(&self) -> Vec<Option<String>> {
        self.set.rows.iter().map(|r| r.pose_id.clone()).collect()
    }

    /// Writes the rows as a measurement CSV (SI units), atomically; reading it back gives
    /// the same numbers bit for bit.
    fn write(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let set = &self.set;
        py.detach(|| kincal_io::files::write_atomic(&path, &[], |w| write_measurements_csv(w, set)))
            .map_err(|e| errors::from_io(py, &e.into(), &[]))
    }

    fn __repr__(&self) -> String {
        format!(
            "Measurements({:?}, rows={}, n_joints={})",
            self.set.source,
            self.set.rows.len(),
            self.set.n_joints
        )
    }
}
