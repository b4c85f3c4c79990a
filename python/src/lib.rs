//! The Python extension `kincal._kincal` (package `kincal`): a thin shell over the core
//! (`kincal`) and the io crate (`kincal-io`). No formula and no parser here: the shell
//! converts numpy arrays to core types and back, releases the GIL on long work, and turns
//! errors into the exceptions of `kincal/_errors.py`.

mod calibrate;
mod design;
mod errors;
mod json;
mod measurements;
mod pose;
mod robot;
mod studies;

use pyo3::prelude::*;

#[pymodule]
fn _kincal(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<robot::Robot>()?;
    m.add_class::<measurements::Measurements>()?;
    m.add_function(wrap_pyfunction!(robot::aria, m)?)?;
    m.add_function(wrap_pyfunction!(robot::load_robot, m)?)?;
    m.add_function(wrap_pyfunction!(measurements::read_measurements_file, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate::calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(studies::crossval, m)?)?;
    m.add_function(wrap_pyfunction!(studies::diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(design::select_poses, m)?)?;
    m.add_function(wrap_pyfunction!(design::design_tool, m)?)?;
    m.add_function(wrap_pyfunction!(design::evaluate_designs, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
