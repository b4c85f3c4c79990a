//! `kincal.select_poses`, `kincal.design_tool` and `kincal.evaluate_designs`: the runs of
//! `kincal select-poses`, `design-tool` and `evaluate-designs` (io's `design` modules), with
//! keyword arguments instead of flags and numpy arrays and dicts instead of text. Every
//! number matches the command line's for the same settings and seed.

use std::path::{Path, PathBuf};

use kincal::Robot as CoreRobot;
use kincal::observability::Index;
use kincal_io::design::Silent;
use kincal_io::design::context::{Context, ScenarioSpec, SelectionSettings, Setup, region};
use kincal_io::design::designs::Design;
use kincal_io::design::evaluation::{self as ev, BuiltIn, DesignChoice};
use kincal_io::design::plate::{self as pl, PlateSpec};
use kincal_io::design::pose_selection::{self as ps, Which};
use kincal_io::design::study;
use kincal_io::design::tool_design::{self as td, ToolObjective, ToolOptions};
use numpy::IntoPyArray;
use numpy::ndarray::{Array2, Array3};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors;
use crate::pose::homogeneous;
use crate::robot::Robot;

/// `v` if finite and ≥ 0, else a `UsageError` naming `name`.
fn non_negative(py: Python<'_>, name: &str, v: f64) -> PyResult<f64> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(errors::usage(
            py,
            format!("{name} = {v}: expected a finite number >= 0"),
        ))
    }
}

/// The working region, orientations, grid, margin and seed, checked.
#[allow(clippy::too_many_arguments)]
fn setup(
    py: Python<'_>,
    region_m: Option<[f64; 6]>,
    working_rpy_deg: Option<Vec<[f64; 3]>>,
    cone_deg: f64,
    grid: [usize; 3],
    margin_deg: f64,
    seed: u64,
) -> PyResult<Setup> {
    if let Some(b) = region_m {
        region(b, "region").map_err(|e| errors::from_io(py, &e, &[]))?;
    }
    let rpy = working_rpy_deg.unwrap_or_default();
    if rpy.iter().flatten().any(|v| !v.is_finite()) {
        return Err(errors::usage(py, "working_rpy_deg: expected finite angles"));
    }
    if grid.iter().any(|g| !(1..=50).contains(g)) {
        return Err(errors::usage(
            py,
            format!("grid {grid:?}: expected counts in 1..=50"),
        ));
    }
    Ok(Setup {
        region: region_m,
        working_rpy_deg: rpy,
        cone_deg: non_negative(py, "cone_deg", cone_deg)?,
        grid,
        margin_deg: non_negative(py, "margin_deg", margin_deg)?,
        seed,
    })
}

/// The scenario in the user's units, checked.
fn scenario(py: Python<'_>, v: [f64; 6]) -> PyResult<ScenarioSpec> {
    let names = [
        "length_error_mm",
        "angle_error_deg",
        "noise_pos_mm",
        "noise_rot_deg",
        "tool_tol_mm",
        "tool_tol_deg",
    ];
    for (n, x) in names.iter().zip(v) {
        non_negative(py, n, x)?;
    }
    Ok(ScenarioSpec {
        length_error_mm: v[0],
        angle_error_deg: v[1],
        noise_pos_mm: v[2],
        noise_rot_deg: v[3],
        tool_tol_mm: v[4],
        tool_tol_deg: v[5],
    })
}

/// The selection settings of the pose selections, checked.
#[allow(clippy::too_many_arguments)]
fn selection(
    py: Python<'_>,
    m: usize,
    index: &str,
    pool: usize,
    starts: usize,
    refine: usize,
    workspace: [f64; 6],
    cube_mm: f64,
    tolerance: f64,
    min_dexterity: f64,
    robust_robots: u64,
) -> PyResult<SelectionSettings> {
    let index = kincal_io::design::context::parse_index(index).map_err(|e| errors::usage(py, e))?;
    if !(cube_mm.is_finite() && cube_mm > 0.0) {
        return Err(errors::usage(
            py,
            format!("cube_mm = {cube_mm}: expected a finite number > 0"),
        ));
    }
    SelectionSettings {
        m,
        index,
        pool,
        starts,
        refine_trials: refine,
        workspace: region(workspace, "workspace").map_err(|e| errors::from_io(py, &e, &[]))?,
        cube_m: cube_mm * 1e-3,
        tolerance: non_negative(py, "tolerance", tolerance)?,
        min_dexterity: non_negative(py, "min_dexterity", min_dexterity)?,
        robust_robots,
    }
    .checked("m")
    .map_err(|e| errors::from_io(py, &e, &[]))
}

/// The context of `robot` (GIL released: the validation grid is solved by IK).
fn context<const N: usize>(
    py: Python<'_>,
    robot: &CoreRobot<N>,
    name: &str,
    s: &Setup,
) -> PyResult<Context<N>> {
    py.detach(|| Context::new(*robot, name, s))
        .map_err(|e| errors::from_io(py, &e, &[]))
}

/// A design's configurations (M, N) [rad] and reference poses (M, 4, 4) [m].
fn design_dict<'py, const N: usize>(
    py: Python<'py>,
    d: &Design<N>,
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    out.set_item("name", &d.name)?;
    out.set_item("note", &d.note)?;
    let q = Array2::from_shape_fn((d.q.len(), N), |(i, j)| d.q[i][j]);
    out.set_item("q", q.into_pyarray(py))?;
    let mut poses = Array3::zeros((d.reference.len(), 4, 4));
    for (mut m, t) in poses.outer_iter_mut().zip(&d.reference) {
        m.assign(&homogeneous(t));
    }
    out.set_item("poses", poses.into_pyarray(py))?;
    Ok(out)
}

fn select_run<'py, const N: usize>(
    py: Python<'py>,
    robot: &CoreRobot<N>,
    name: &str,
    s: &Setup,
    settings: &SelectionSettings,
    (which, errors_spec, compare_random): (Which, ScenarioSpec, usize),
    out: Option<PathBuf>,
) -> PyResult<Bound<'py, PyDict>> {
    let ctx = context(py, robot, name, s)?;
    let sel = py
        .detach(|| {
            ps::select_poses(
                &ctx,
                settings,
                which,
                errors_spec.robot_errors(),
                compare_random,
                &Silent,
            )
        })
        .map_err(|e| errors::from_io(py, &e, &[]))?;
    if let Some(path) = &out {
        let rows = ps::pose_rows(&sel.design);
        kincal_io::files::write_atomic(path, &[], |w| {
            kincal_io::measurements::write_poses_csv(w, N, true, &rows)
        })
        .map_err(|e| errors::from_io(py, &kincal_io::Error::from(e), &[]))?;
    }
    let d = design_dict(py, &sel.design)?;
    let indices = PyDict::new(py);
    let random = PyDict::new(py);
    for i in Index::ALL {
        indices.set_item(i.name(), sel.indices.get(i))?;
        let r: Vec<f64> = sel.random.iter().map(|x| x.get(i)).collect();
        random.set_item(i.name(), r.into_pyarray(py))?;
    }
    d.set_item("indices", indices)?;
    d.set_item("random_indices", random)?;
    d.set_item("pool_size", sel.pool_size)?;
    d.set_item("admitted", sel.admitted)?;
    d.set_item("min_margin_deg", sel.min_margin_rad.to_degrees())?;
    Ok(d)
}

/// Selects ``m`` calibration poses, as ``kincal select-poses``: ``design`` ``"standard"``
/// (anywhere in the joint ranges, end effector inside ``workspace`` [m]), ``"region"`` (in
/// the working region ``region`` [m], approach axis within ``cone_deg`` of the working
/// orientations ``working_rpy_deg`` [deg], reachable by ``robust_robots`` random robots off
/// by ``length_error_mm``/``angle_error_deg``) or ``"clustering"`` (cubes of ``cube_mm``).
/// The index ``index`` (``"o"``, ``"o1"`` … ``"o5"``, ``"aopt"``, ``"dopt"``) is maximised
/// over a pool of ``pool`` candidates from ``starts`` starts. Returns a dict: ``q`` (m, N)
/// [rad], ``poses`` (m, 4, 4) [m] (nominal), ``indices`` (name → value), ``random_indices``
/// (name → array over ``compare_random`` random m-pose sets of the pool), ``pool_size``,
/// ``admitted`` (poses meeting the constraints), ``min_margin_deg``, ``name``, ``note``.
/// ``out``: also write the pose CSV the command writes. The GIL is released.
#[pyfunction]
#[pyo3(signature = (robot, *, design="standard", m=10, index="o", pool=2000, starts=8, refine=200, workspace=[-1.0, -1.0, 0.05, 1.0, 1.0, 1.5], cube_mm=100.0, tolerance=0.1, min_dexterity=0.08, robust_robots=32, compare_random=1000, length_error_mm=5.0, angle_error_deg=5.0, region=None, working_rpy_deg=None, cone_deg=20.0, grid=[4, 4, 2], margin_deg=5.0, seed=1, out=None))]
#[allow(clippy::too_many_arguments)]
pub fn select_poses<'py>(
    py: Python<'py>,
    robot: &Robot,
    design: &str,
    m: usize,
    index: &str,
    pool: usize,
    starts: usize,
    refine: usize,
    workspace: [f64; 6],
    cube_mm: f64,
    tolerance: f64,
    min_dexterity: f64,
    robust_robots: u64,
    compare_random: usize,
    length_error_mm: f64,
    angle_error_deg: f64,
    region: Option<[f64; 6]>,
    working_rpy_deg: Option<Vec<[f64; 3]>>,
    cone_deg: f64,
    grid: [usize; 3],
    margin_deg: f64,
    seed: u64,
    out: Option<PathBuf>,
) -> PyResult<Bound<'py, PyDict>> {
    let which = Which::parse(design).ok_or_else(|| {
        errors::usage(
            py,
            format!("design {design:?}: expected 'standard', 'region' or 'clustering'"),
        )
    })?;
    let s = setup(
        py,
        region,
        working_rpy_deg,
        cone_deg,
        grid,
        margin_deg,
        seed,
    )?;
    let settings = selection(
        py,
        m,
        index,
        pool,
        starts,
        refine,
        workspace,
        cube_mm,
        tolerance,
        min_dexterity,
        robust_robots,
    )?;
    let spec = scenario(py, [length_error_mm, angle_error_deg, 0.0, 0.0, 0.0, 0.0])?;
    kincal::with_any_robot!(&robot.robot, r => {
        select_run(py, r, &robot.name, &s, &settings, (which, spec, compare_random), out)
    })
}

fn tool_run<'py, const N: usize>(
    py: Python<'py>,
    robot: &CoreRobot<N>,
    name: &str,
    s: &Setup,
    o: &ToolOptions,
    baseline: Option<&(String, PathBuf)>,
    out: Option<&Path>,
) -> PyResult<Bound<'py, PyAny>> {
    let ctx = context(py, robot, name, s)?;
    let files: Vec<String> = baseline
        .iter()
        .map(|(_, p)| p.display().to_string())
        .collect();
    let files: Vec<&str> = files.iter().map(String::as_str).collect();
    let given = baseline.as_ref().map(|(n, p)| (n.as_str(), p.as_path()));
    let d = py
        .detach(|| {
            let base = td::baseline(&ctx, given, "baseline")?;
            td::design_tool(&ctx, &base, o, &Silent)
        })
        .map_err(|e| errors::from_io(py, &e, &files))?;
    if let Some(path) = out {
        let comments = td::tool_comments(&ctx, &d, o, s.margin_deg);
        kincal_io::files::write_atomic(path, &[], |w| {
            kincal_io::tool_file::write_tool(w, &comments, &d.tool.reference, &d.tool.q)
        })
        .map_err(|e| errors::from_io(py, &kincal_io::Error::from(e), &[]))?;
    }
    let doc = crate::json::loads(py, &td::json(&ctx, &d).to_string())?;
    doc.set_item("tool", design_dict(py, &d.tool)?)?;
    let plates: Vec<(f64, usize)> = d.plates.iter().map(|p| (p.z_m, p.sockets)).collect();
    doc.set_item("plate_sockets", plates)?;
    Ok(doc)
}

/// Designs a calibration tool that beats a baseline tool on the Monte-Carlo criterion, as
/// ``kincal design-tool``: ``m`` sockets on one plate height (``plate_z_mm`` [mm], default
/// the region's bottom, middle and top), on a grid of ``grid_mm`` [mm], orientations
/// Rz(yaw)·Rx(roll) from ``rolls_deg`` × ``yaws_deg`` [deg], at least ``min_separation_mm``
/// apart, chosen by each of ``objectives`` (``"pv"``, ``"pv01"``, ``"o"``, ``"dopt"``),
/// screened with ``screen_runs`` runs and compared with ``runs`` runs. ``baseline``:
/// ``(name, tool_file)`` (default: ARIA's Table 2 tool). The scenario: random robots off by
/// ``length_error_mm``/``angle_error_deg``, noise ``noise_pos_mm``/``noise_rot_deg`` (1σ
/// per axis), tool tolerance ``tool_tol_mm``/``tool_tol_deg``. Returns the dict ``kincal
/// design-tool --json`` writes (``plate_z_m`` [m], ``objective``, ``screening_score``,
/// ``beats_baseline``, ``designs``: errors in mm and degrees), plus ``tool`` (``q`` (m, N)
/// [rad], ``poses`` (m, 4, 4) [m]) and ``plate_sockets`` ([(z [m], sockets)]). ``out``:
/// also write the tool file the command writes. The GIL is released.
#[pyfunction]
#[pyo3(signature = (robot, *, m=10, starts=8, min_dexterity=0.08, robust_robots=32, plate_z_mm=None, grid_mm=25.0, rolls_deg=vec![-150.0, -160.0], yaws_deg=vec![-90.0, 0.0, 90.0, 180.0], min_separation_mm=60.0, objectives=vec!["pv".to_string(), "pv01".to_string(), "o".to_string(), "dopt".to_string()], baseline=None, screen_runs=1000, runs=10000, length_error_mm=5.0, angle_error_deg=5.0, noise_pos_mm=0.05, noise_rot_deg=0.02, tool_tol_mm=0.05, tool_tol_deg=0.02, region=None, working_rpy_deg=None, cone_deg=20.0, grid=[4, 4, 2], margin_deg=5.0, seed=1, out=None))]
#[allow(clippy::too_many_arguments)]
pub fn design_tool<'py>(
    py: Python<'py>,
    robot: &Robot,
    m: usize,
    starts: usize,
    min_dexterity: f64,
    robust_robots: u64,
    plate_z_mm: Option<Vec<f64>>,
    grid_mm: f64,
    rolls_deg: Vec<f64>,
    yaws_deg: Vec<f64>,
    min_separation_mm: f64,
    objectives: Vec<String>,
    baseline: Option<(String, PathBuf)>,
    screen_runs: u64,
    runs: u64,
    length_error_mm: f64,
    angle_error_deg: f64,
    noise_pos_mm: f64,
    noise_rot_deg: f64,
    tool_tol_mm: f64,
    tool_tol_deg: f64,
    region: Option<[f64; 6]>,
    working_rpy_deg: Option<Vec<[f64; 3]>>,
    cone_deg: f64,
    grid: [usize; 3],
    margin_deg: f64,
    seed: u64,
    out: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    let objectives = objectives
        .iter()
        .map(|o| {
            ToolObjective::parse(o).ok_or_else(|| {
                errors::usage(
                    py,
                    format!("objective {o:?}: expected 'pv', 'pv01', 'o' or 'dopt'"),
                )
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    if !(grid_mm.is_finite() && grid_mm > 0.0) {
        return Err(errors::usage(
            py,
            format!("grid_mm = {grid_mm}: expected a finite number > 0"),
        ));
    }
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    if !finite(&rolls_deg) || !finite(&yaws_deg) || !finite(plate_z_mm.as_deref().unwrap_or(&[])) {
        return Err(errors::usage(
            py,
            "plate_z_mm, rolls_deg, yaws_deg: expected finite numbers",
        ));
    }
    let options = ToolOptions {
        m,
        starts,
        min_dexterity: non_negative(py, "min_dexterity", min_dexterity)?,
        robust_robots,
        plate_z_mm,
        grid_mm,
        rolls_deg,
        yaws_deg,
        min_separation_mm: non_negative(py, "min_separation_mm", min_separation_mm)?,
        objectives,
        screen_runs,
        runs,
        scenario: scenario(
            py,
            [
                length_error_mm,
                angle_error_deg,
                noise_pos_mm,
                noise_rot_deg,
                tool_tol_mm,
                tool_tol_deg,
            ],
        )?,
    };
    options
        .check(|f| {
            if f == "poses" {
                "m".into()
            } else {
                f.to_string()
            }
        })
        .map_err(|e| errors::from_io(py, &e, &[]))?;
    let s = setup(
        py,
        region,
        working_rpy_deg,
        cone_deg,
        grid,
        margin_deg,
        seed,
    )?;
    kincal::with_any_robot!(&robot.robot, r => {
        tool_run(py, r, &robot.name, &s, &options, baseline.as_ref(), out.as_deref())
    })
}

/// The plates of `evaluate_designs`, checked: `(name, d_mm, placements, contacts)`.
fn plate_specs(
    py: Python<'_>,
    plates: Vec<(String, f64, usize, usize)>,
) -> PyResult<Vec<PlateSpec>> {
    plates
        .into_iter()
        .enumerate()
        .map(|(i, (name, distance_mm, placements, contacts))| {
            PlateSpec::checked(&name, distance_mm, placements, contacts).map_err(|why| {
                errors::usage(
                    py,
                    format!(
                        "plates[{i}] = ({name:?}, {distance_mm}, {placements}, {contacts}): {why} (expected (name, d_mm, placements, contacts))"
                    ),
                )
            })
        })
        .collect()
}

fn evaluate_run<'py, const N: usize>(
    py: Python<'py>,
    robot: &CoreRobot<N>,
    name: &str,
    s: &Setup,
    (choice, settings, spec): (&DesignChoice, &SelectionSettings, ScenarioSpec),
    (runs, plates): (u64, &[PlateSpec]),
) -> PyResult<Bound<'py, PyAny>> {
    let ctx = context(py, robot, name, s)?;
    let files: Vec<String> = choice
        .tools
        .iter()
        .chain(&choice.commanded)
        .map(|(_, p)| p.display().to_string())
        .collect();
    let files: Vec<&str> = files.iter().map(String::as_str).collect();
    // As the command: the designs, the plates, the study, then the plates' comparison.
    let (results, timing, rows) = py
        .detach(|| {
            let built = ev::build_designs(&ctx, choice, settings, &spec, &Silent)?;
            let designs: Vec<Design<N>> = built.into_iter().map(|b| b.design).collect();
            let probe = (spec.scenario(), settings.robust_robots);
            let plates = pl::build_plates(&ctx, plates, &designs, probe, "plates", &Silent)?;
            let (results, timing) = study::run_study(
                &ctx,
                &designs,
                spec.scenario(),
                runs,
                ctx.seed,
                "Monte-Carlo",
                &Silent,
            )?;
            let rows = if plates.is_empty() {
                None
            } else {
                let c = pl::compare(&ctx, &designs, &plates, spec.scenario(), runs, &Silent)?;
                Some(c.rows)
            };
            Ok::<_, kincal_io::Error>((results, timing, rows))
        })
        .map_err(|e| errors::from_io(py, &e, &files))?;
    let doc = ev::json(&ctx, runs, &spec, &results, &timing, rows.as_deref());
    crate::json::loads(py, &doc.to_string())
}

/// Monte-Carlo comparison of data-acquisition designs on the same random robots, as
/// ``kincal evaluate-designs``: the built-in ``designs`` (``"standard"``, ``"clustering"``,
/// ``"table2"``), ``tools`` (name → tool file) and ``commanded`` (name → measurement CSV of
/// configurations), each calibrated ``runs`` times. ``plates``: socket plates compared with
/// them on the same robots, as ``--plate NAME=D_MM,PLACEMENTS,CONTACTS``: tuples ``(name,
/// d_mm, placements, contacts)`` (two ball sockets ``d_mm`` [mm] apart at unknown positions,
/// placed ``placements`` times, ``contacts`` contacts in all, at least 2 per socket).
/// Selection, scenario and setting keywords as :func:`select_poses` and
/// :func:`design_tool`. Returns the dict ``kincal evaluate-designs --json`` writes:
/// ``designs`` (per design: ``worst_pose_e_p_mm``, ``worst_pose_e_phi_deg`` (median, p95,
/// max, mean), …), ``scenario`` [m, rad], ``validation_poses``, ``calibrations``; with
/// plates also ``plates`` (the designs, then the plates: ``kind``, ``contacts``,
/// ``placements``, ``distance_mm``, ``failed``, ``absolute_worst_pose_e_p_mm``,
/// ``registered_worst_pose_e_p_mm`` [mm], ``…_e_phi_deg`` [deg], each median, p95, max,
/// mean). The GIL is released.
#[pyfunction]
#[pyo3(signature = (robot, *, designs=vec!["standard".to_string(), "clustering".to_string(), "table2".to_string()], tools=Vec::new(), commanded=Vec::new(), plates=Vec::new(), runs=10000, m=10, index="o", pool=2000, starts=8, refine=200, workspace=[-1.0, -1.0, 0.05, 1.0, 1.0, 1.5], cube_mm=100.0, tolerance=0.1, min_dexterity=0.08, robust_robots=32, length_error_mm=5.0, angle_error_deg=5.0, noise_pos_mm=0.05, noise_rot_deg=0.02, tool_tol_mm=0.05, tool_tol_deg=0.02, region=None, working_rpy_deg=None, cone_deg=20.0, grid=[4, 4, 2], margin_deg=5.0, seed=1))]
#[allow(clippy::too_many_arguments)]
pub fn evaluate_designs<'py>(
    py: Python<'py>,
    robot: &Robot,
    designs: Vec<String>,
    tools: Vec<(String, PathBuf)>,
    commanded: Vec<(String, PathBuf)>,
    plates: Vec<(String, f64, usize, usize)>,
    runs: u64,
    m: usize,
    index: &str,
    pool: usize,
    starts: usize,
    refine: usize,
    workspace: [f64; 6],
    cube_mm: f64,
    tolerance: f64,
    min_dexterity: f64,
    robust_robots: u64,
    length_error_mm: f64,
    angle_error_deg: f64,
    noise_pos_mm: f64,
    noise_rot_deg: f64,
    tool_tol_mm: f64,
    tool_tol_deg: f64,
    region: Option<[f64; 6]>,
    working_rpy_deg: Option<Vec<[f64; 3]>>,
    cone_deg: f64,
    grid: [usize; 3],
    margin_deg: f64,
    seed: u64,
) -> PyResult<Bound<'py, PyAny>> {
    if runs == 0 {
        return Err(errors::usage(py, "runs: expected at least 1"));
    }
    let builtin = designs
        .iter()
        .map(|d| {
            BuiltIn::parse(d).ok_or_else(|| {
                errors::usage(
                    py,
                    format!("design {d:?}: expected 'standard', 'clustering' or 'table2'"),
                )
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    let choice = DesignChoice {
        builtin,
        tools,
        commanded,
    };
    let plates = plate_specs(py, plates)?;
    let s = setup(
        py,
        region,
        working_rpy_deg,
        cone_deg,
        grid,
        margin_deg,
        seed,
    )?;
    let settings = selection(
        py,
        m,
        index,
        pool,
        starts,
        refine,
        workspace,
        cube_mm,
        tolerance,
        min_dexterity,
        robust_robots,
    )?;
    let spec = scenario(
        py,
        [
            length_error_mm,
            angle_error_deg,
            noise_pos_mm,
            noise_rot_deg,
            tool_tol_mm,
            tool_tol_deg,
        ],
    )?;
    kincal::with_any_robot!(&robot.robot, r => {
        evaluate_run(py, r, &robot.name, &s, (&choice, &settings, spec), (runs, &plates))
    })
}
