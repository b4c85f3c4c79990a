//! `kincal.Robot`: a model (built-in, robot description, URDF chain or model file) and the
//! core's kinematics on it. Arrays in and out are numpy, lengths in metres, angles in
//! radians (prismatic joints in metres).

use kincal::any::AnyRobot;
use kincal::ik::{IkOptions, solve_ik};
use kincal::kinematics::Frames;
use kincal::{JointState, ParamId, ParamIndex, Robot as CoreRobot, Transform, with_any_robot};
use kincal_io::model_file::ModelFile;
use kincal_io::robot_arg::{self, UrdfChainArgs};
use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

use crate::errors;
use crate::pose::{homogeneous, transform_from_matrix};

/// A robot model: nominal (built-in, robot description, URDF chain) or calibrated (model
/// file, or the result of :func:`kincal.calibrate`).
#[pyclass(frozen, module = "kincal")]
#[derive(Debug, Clone)]
pub struct Robot {
    pub(crate) name: String,
    pub(crate) robot: AnyRobot,
    /// The model file this robot came from or would be written as.
    pub(crate) file: ModelFile,
}

impl Robot {
    pub(crate) fn nominal(name: String, robot: AnyRobot) -> Self {
        let file = with_any_robot!(&robot, r => ModelFile::nominal(&name, r));
        Robot { name, robot, file }
    }

    pub(crate) fn n_joints(&self) -> usize {
        with_any_robot!(&self.robot, r => r.links().len())
    }
}

/// `q` as `[f64; N]`, or a `UsageError` naming the expected length.
fn joints<const N: usize>(py: Python<'_>, q: &[f64]) -> PyResult<[f64; N]> {
    q.try_into().map_err(|_| {
        errors::usage(
            py,
            format!("q has {} values: expected {N} (one per joint)", q.len()),
        )
    })
}

fn state<const N: usize>(
    py: Python<'_>,
    q: &[f64],
    approach: Option<&[f64]>,
    temp_c: Option<f64>,
) -> PyResult<JointState<N>> {
    let approach = match approach {
        Some(a) => Some(joints::<N>(py, a).map_err(|_| {
            errors::usage(py, format!("approach has {} values: expected {N}", a.len()))
        })?),
        None => None,
    };
    Ok(JointState {
        q: joints::<N>(py, q)?,
        approach,
        temp_c,
    })
}

fn fk_one<const N: usize>(
    py: Python<'_>,
    r: &CoreRobot<N>,
    st: &JointState<N>,
) -> PyResult<Transform> {
    r.fk(st).map_err(|e| errors::from_core(py, e))
}

/// Poses of many configurations (rows of `q`), without the GIL.
fn fk_many<const N: usize>(
    py: Python<'_>,
    r: &CoreRobot<N>,
    q: &Array2<f64>,
) -> PyResult<Array3<f64>> {
    let rows: Vec<[f64; N]> = q
        .rows()
        .into_iter()
        .map(|row| joints::<N>(py, &row.to_vec()))
        .collect::<PyResult<_>>()?;
    let poses = py.detach(|| {
        rows.iter()
            .map(|q| r.fk_q(q))
            .collect::<Result<Vec<Transform>, kincal::Error>>()
    });
    let poses = poses.map_err(|e| errors::from_core(py, e))?;
    let mut out = Array3::zeros((poses.len(), 4, 4));
    for (mut m, t) in out.outer_iter_mut().zip(&poses) {
        m.assign(&homogeneous(t));
    }
    Ok(out)
}

fn frames_of<const N: usize>(
    py: Python<'_>,
    r: &CoreRobot<N>,
    st: &JointState<N>,
) -> PyResult<Array3<f64>> {
    let mut f = Frames::<N>::default();
    r.fk_frames(st, &mut f)
        .map_err(|e| errors::from_core(py, e))?;
    let all: Vec<&Transform> = std::iter::once(&f.t_base_0)
        .chain(f.t_base_link.iter())
        .chain(std::iter::once(&f.t_base_ee))
        .collect();
    let mut out = Array3::zeros((all.len(), 4, 4));
    for (mut m, t) in out.outer_iter_mut().zip(all) {
        m.assign(&homogeneous(t));
    }
    Ok(out)
}

fn labels<const N: usize>(count: usize) -> Vec<String> {
    (0..count)
        .filter_map(|i| ParamId::from_index(ParamIndex(i), N).ok())
        .map(|id| id.to_string())
        .collect()
}

fn jacobian_of<const N: usize>(
    py: Python<'_>,
    r: &CoreRobot<N>,
    st: &JointState<N>,
    effects: bool,
) -> PyResult<(Array2<f64>, Vec<String>)> {
    let count = if effects {
        CoreRobot::<N>::NUM_PARAMS
    } else {
        CoreRobot::<N>::NUM_GEOMETRIC_PARAMS
    };
    let mut cols = vec![[0.0; 6]; count];
    r.jacobian(st, &mut cols)
        .map_err(|e| errors::from_core(py, e))?;
    let mut j = Array2::zeros((6, count));
    for (c, col) in cols.iter().enumerate() {
        for (k, v) in col.iter().enumerate() {
            j[[k, c]] = *v;
        }
    }
    Ok((j, labels::<N>(count)))
}

struct IkResult {
    q: Vec<f64>,
    residual_pos_m: f64,
    residual_rot_rad: f64,
    iterations: u32,
}

fn ik_of<const N: usize>(
    py: Python<'_>,
    r: &CoreRobot<N>,
    target: &Transform,
    seed: Option<&[f64]>,
    opts: &IkOptions,
) -> PyResult<IkResult> {
    let seed_q = match seed {
        Some(s) => joints::<N>(py, s)?,
        // The middle of each joint's range (within ±π).
        None => {
            let mut q = [0.0; N];
            for (v, l) in q.iter_mut().zip(r.limits()) {
                *v = 0.5 * (l.lower.max(-std::f64::consts::PI) + l.upper.min(std::f64::consts::PI));
            }
            q
        }
    };
    let seed = JointState::new(seed_q);
    let sol = py
        .detach(|| solve_ik(r, target, &seed, opts))
        .map_err(|e| errors::from_core(py, e))?;
    Ok(IkResult {
        q: sol.q.to_vec(),
        residual_pos_m: sol.residual_pos_m,
        residual_rot_rad: sol.residual_rot_rad,
        iterations: sol.iterations,
    })
}

#[pymethods]
impl Robot {
    /// Robot name (as recorded in model files).
    #[getter]
    fn name(&self) -> &str {
        &self.name
    }

    /// Number of joints.
    #[getter]
    #[pyo3(name = "n_joints")]
    fn py_n_joints(&self) -> usize {
        self.n_joints()
    }

    /// Joint limits, shape (n_joints, 2): lower, upper [rad] ([m] for prismatic joints).
    #[getter]
    fn joint_limits<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let lim: Vec<(f64, f64)> = with_any_robot!(&self.robot, r => r.limits().iter().map(|l| (l.lower, l.upper)).collect());
        let mut a = Array2::zeros((lim.len(), 2));
        for (i, (lo, hi)) in lim.into_iter().enumerate() {
            a[[i, 0]] = lo;
            a[[i, 1]] = hi;
        }
        a.into_pyarray(py)
    }

    /// Whether each joint is prismatic (its reading in metres) rather than revolute.
    #[getter]
    fn prismatic(&self) -> Vec<bool> {
        with_any_robot!(&self.robot, r => r
            .joint_kinds()
            .iter()
            .map(|k| matches!(k, kincal::JointKind::Prismatic))
            .collect())
    }

    /// Labels of every model parameter in the core's order (``theta0_1``, ``d_1``, …,
    /// ``base_px``, …, ``tool_rz``, then the effects' parameters).
    #[getter]
    fn param_labels(&self) -> Vec<String> {
        with_any_robot!(&self.robot, r => labels_of(r))
    }

    /// Every parameter value, in the order of :attr:`param_labels` [m, rad, or the
    /// effect's unit].
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let v = with_any_robot!(&self.robot, r => params_of(r));
        Ok(Array1::from(v.map_err(|e| errors::from_core(py, e))?).into_pyarray(py))
    }

    /// A copy with every parameter set to ``values`` (order of :attr:`param_labels`;
    /// [m, rad, effect units]), e.g. a simulated "true" robot for a study.
    fn with_params(&self, py: Python<'_>, values: Vec<f64>) -> PyResult<Robot> {
        let robot = with_any_robot!(&self.robot, r => set_params(r, &values).map(AnyRobot::from))
            .map_err(|e| errors::from_core(py, e))?;
        Ok(Robot::nominal(self.name.clone(), robot))
    }

    /// End-effector pose ``T_e^b`` as a 4x4 homogeneous matrix [m] for joint readings ``q``
    /// (shape (n_joints,), [rad]); with ``q`` of shape (M, n_joints), the M poses, shape
    /// (M, 4, 4), computed without the GIL. ``approach`` (each -1, 0, +1) and ``temp_c``
    /// [°C] feed the backlash and thermal effects of a calibrated model.
    #[pyo3(signature = (q, approach=None, temp_c=None))]
    fn fk<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        approach: Option<PyReadonlyArray1<'py, f64>>,
        temp_c: Option<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        if let Ok(batch) = q.extract::<PyReadonlyArray2<'py, f64>>() {
            if approach.is_some() || temp_c.is_some() {
                return Err(errors::usage(
                    py,
                    "approach and temp_c apply to one configuration: call fk per row",
                ));
            }
            let q = batch.as_array().to_owned();
            let out = with_any_robot!(&self.robot, r => fk_many(py, r, &q))?;
            return Ok(out.into_pyarray(py).into_any());
        }
        let q: Vec<f64> = q.extract()?;
        let approach = approach.map(|a| a.as_array().to_vec());
        let t = with_any_robot!(&self.robot, r => {
            let st = state(py, &q, approach.as_deref(), temp_c)?;
            fk_one(py, r, &st)
        })?;
        Ok(homogeneous(&t).into_pyarray(py).into_any())
    }

    /// Every frame at ``q`` [rad], shape (n_joints + 2, 4, 4) [m]: frame 0 (``T_0^b``),
    /// frames 1..n_joints (after each joint's link), and the tool ``T_e^b``.
    #[pyo3(signature = (q, approach=None, temp_c=None))]
    fn frames<'py>(
        &self,
        py: Python<'py>,
        q: Vec<f64>,
        approach: Option<Vec<f64>>,
        temp_c: Option<f64>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let out = with_any_robot!(&self.robot, r => {
            let st = state(py, &q, approach.as_deref(), temp_c)?;
            frames_of(py, r, &st)
        })?;
        Ok(out.into_pyarray(py))
    }

    /// The identification Jacobian at ``q`` [rad]: shape (6, P), rows ``[Δp [m]; Δφ [rad]]``
    /// in the base frame, one column per parameter (the geometric ones: links, base, tool;
    /// with ``effects=True`` every parameter), and the columns' labels.
    #[pyo3(signature = (q, effects=false, approach=None, temp_c=None))]
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        q: Vec<f64>,
        effects: bool,
        approach: Option<Vec<f64>>,
        temp_c: Option<f64>,
    ) -> PyResult<(Bound<'py, PyArray2<f64>>, Vec<String>)> {
        let (j, l) = with_any_robot!(&self.robot, r => {
            let st = state(py, &q, approach.as_deref(), temp_c)?;
            jacobian_of(py, r, &st, effects)
        })?;
        Ok((j.into_pyarray(py), l))
    }

    /// Inverse kinematics: joint readings [rad] whose pose is ``target`` (4x4, [m]), from
    /// ``seed`` (default: the middle of each joint's range) and ``extra_seeds`` more.
    /// Returns ``(q, residual_pos_m, residual_rot_rad, iterations)``; raises
    /// ``NumericError`` when no seed converges.
    #[pyo3(signature = (target, seed=None, max_iterations=200, tol_pos_m=1e-11, tol_rot_rad=1e-11, extra_seeds=16))]
    #[allow(clippy::too_many_arguments)]
    fn ik<'py>(
        &self,
        py: Python<'py>,
        target: PyReadonlyArray2<'py, f64>,
        seed: Option<Vec<f64>>,
        max_iterations: u32,
        tol_pos_m: f64,
        tol_rot_rad: f64,
        extra_seeds: usize,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, f64, f64, u32)> {
        let target = transform_from_matrix(py, &target.as_array(), "target")?;
        let opts = IkOptions {
            max_iterations,
            tol_pos_m,
            tol_rot_rad,
            extra_seeds,
            first_solution: false,
        };
        let sol = with_any_robot!(&self.robot, r => ik_of(py, r, &target, seed.as_deref(), &opts))?;
        Ok((
            Array1::from(sol.q).into_pyarray(py),
            sol.residual_pos_m,
            sol.residual_rot_rad,
            sol.iterations,
        ))
    }

    /// Errors of this model on measured rows (``data``: a :class:`Measurements` or a CSV
    /// path), measured minus model in the base frame, as ``kincal validate`` computes them:
    /// a dict of ``pos_m`` (M, 3) [m], ``rot_rad`` (M, 3) [rad] (rotation vector; zero
    /// where not measured), ``pos_norm_m`` (M,) and ``rot_norm_rad`` (M,).
    #[pyo3(signature = (data, allow_out_of_limits=false))]
    fn pose_errors<'py>(
        &self,
        py: Python<'py>,
        data: &Bound<'py, PyAny>,
        allow_out_of_limits: bool,
    ) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        let set = crate::measurements::measurement_set(py, data, self, allow_out_of_limits)?;
        let errors = with_any_robot!(&self.robot, r => pose_errors_of(py, r, &set))?;
        let m = errors.len();
        let pos = Array2::from_shape_fn((m, 3), |(i, k)| errors[i].pos_m[k]);
        let rot = Array2::from_shape_fn((m, 3), |(i, k)| errors[i].rot_rad[k]);
        let out = pyo3::types::PyDict::new(py);
        out.set_item("pos_m", pos.into_pyarray(py))?;
        out.set_item("rot_rad", rot.into_pyarray(py))?;
        out.set_item(
            "pos_norm_m",
            Array1::from_iter(errors.iter().map(|e| e.pos_norm_m)).into_pyarray(py),
        )?;
        out.set_item(
            "rot_norm_rad",
            Array1::from_iter(errors.iter().map(|e| e.rot_norm_rad)).into_pyarray(py),
        )?;
        Ok(out)
    }

    /// The model file of this robot as a dict (the JSON kincal writes: ``schema_version``,
    /// ``robot``, and ``calibration`` for a calibrated model).
    fn model_file<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::json::loads(py, &self.file.to_json())
    }

    /// Writes the model file (JSON) atomically to ``path``.
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        let text = self.file.to_json();
        kincal_io::files::write_atomic(&path, &[], |w| w.write_all(text.as_bytes()))
            .map_err(|e| errors::from_io(py, &e.into(), &[]))
    }

    fn __repr__(&self) -> String {
        format!("Robot({:?}, n_joints={})", self.name, self.n_joints())
    }
}

fn pose_errors_of<const N: usize>(
    py: Python<'_>,
    r: &CoreRobot<N>,
    set: &kincal_io::measurements::MeasurementSet,
) -> PyResult<Vec<kincal::validation::PoseErrors>> {
    let meas = kincal_io::data::measurements::<N>(set)
        .map_err(|e| errors::from_io(py, &e, &[&set.source]))?;
    meas.iter()
        .enumerate()
        .map(|(i, m)| {
            kincal::validation::PoseErrors::of_measurement(r, m).map_err(|e| {
                let e = kincal_io::error::core_error(e, &set.source, |_| {
                    kincal_io::data::line_of(set, i)
                });
                errors::from_io(py, &e, &[&set.source])
            })
        })
        .collect()
}

fn labels_of<const N: usize>(_r: &CoreRobot<N>) -> Vec<String> {
    labels::<N>(CoreRobot::<N>::NUM_PARAMS)
}

fn set_params<const N: usize>(
    r: &CoreRobot<N>,
    values: &[f64],
) -> Result<CoreRobot<N>, kincal::Error> {
    let mut out = *r;
    out.write_params(values)?;
    Ok(out)
}

fn params_of<const N: usize>(r: &CoreRobot<N>) -> Result<Vec<f64>, kincal::Error> {
    let mut v = vec![0.0; CoreRobot::<N>::NUM_PARAMS];
    r.read_params(&mut v)?;
    Ok(v)
}

/// The ARIA arm of Arent et al. 2024: ``"nominal"`` (Table 1 geometry, eq. (2) limits),
/// ``"virtual_truth"`` (the simulation study's true robot, Table 3) or ``"real_identified"``
/// (the paper's identification of the real arm).
#[pyfunction]
#[pyo3(signature = (variant="nominal"))]
pub fn aria(py: Python<'_>, variant: &str) -> PyResult<Robot> {
    let robot = match variant {
        "nominal" => kincal::aria::nominal(),
        "virtual_truth" => kincal::aria::virtual_truth(),
        "real_identified" => kincal::aria::real_identified(),
        v => {
            return Err(errors::usage(
                py,
                format!("variant {v:?}: expected 'nominal', 'virtual_truth' or 'real_identified'"),
            ));
        }
    };
    Ok(Robot::nominal("aria".into(), AnyRobot::from(robot)))
}

/// A robot or model: a built-in name (``"aria"``), a robot description (TOML), a URDF
/// (``base_link``/``tip_link`` choose the chain; default: the single root to the single
/// leaf) or a model file (JSON, nominal or calibrated). Bad files raise
/// ``FileFormatError`` with ``path``, ``line`` and ``column``.
#[pyfunction]
#[pyo3(signature = (source, base_link=None, tip_link=None))]
pub fn load_robot(
    py: Python<'_>,
    source: std::path::PathBuf,
    base_link: Option<String>,
    tip_link: Option<String>,
) -> PyResult<Robot> {
    let arg = source.to_string_lossy().into_owned();
    let chain = UrdfChainArgs {
        base_link,
        tip_link,
    };
    let spec = py
        .detach(|| robot_arg::resolve_model(&arg, &chain))
        .map_err(|e| errors::from_io(py, &e, &[&arg]))?;
    Ok(Robot {
        name: spec.file.robot.name.clone(),
        robot: spec.robot,
        file: spec.file,
    })
}
