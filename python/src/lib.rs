//! `splatloop._splatloop`: the Rust half of the Python package. An `Episode` is the library's
//! closed-loop episode, stepped from Python a think period at a time, with its frames as numpy
//! arrays (one copy each); a Python object can plan in the loop (`run_with_planner`), wrap the
//! built-in planners (`BuiltinPlanner`) and read the map (`Map`); a `Dataset` reads an episode
//! folder's frames. The Python half (`splatloop.Env`, the Gymnasium environment) builds on
//! these.

mod arrays;
mod dataset;
mod episode;
mod map;
mod planners;

use pyo3::exceptions::{PyFileNotFoundError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use splatloop::SimError;

/// A host error as the Python exception a user expects, its whole cause chain in the message.
fn to_py(error: SimError) -> PyErr {
    let message = error.chain();
    match error {
        SimError::MissingFile { .. } => PyFileNotFoundError::new_err(message),
        SimError::InvalidArgument { .. } => PyValueError::new_err(message),
        _ => PyRuntimeError::new_err(message),
    }
}

/// A command line's parse error (clap's own message, with the valid values) as a ValueError.
fn words_error(error: anyhow::Error) -> PyErr {
    PyValueError::new_err(format!("{error:#}"))
}

/// Records an open-loop drive as `splatloop record WORDS` does; returns (frames, collision
/// steps, final pose (x, y, theta)).
#[pyfunction]
fn record_drive(words: Vec<String>) -> PyResult<(usize, usize, (f64, f64, f64))> {
    let config = splatloop::commands::record_config_from_words(words).map_err(words_error)?;
    let summary = splatloop::record::record(&config, &mut |_| {}).map_err(to_py)?;
    let p = summary.final_pose;
    Ok((summary.frames, summary.collision_steps, (p.x, p.y, p.theta)))
}

/// The module.
#[pymodule]
fn _splatloop(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<episode::Episode>()?;
    m.add_class::<dataset::Dataset>()?;
    m.add_class::<map::Map>()?;
    m.add_class::<arrays::Frame>()?;
    m.add_class::<planners::Plan>()?;
    m.add_class::<planners::PlanFailure>()?;
    m.add_class::<planners::PlannerContext>()?;
    m.add_class::<planners::BuiltinPlanner>()?;
    m.add_function(wrap_pyfunction!(planners::run_with_planner, m)?)?;
    m.add_function(wrap_pyfunction!(planners::run_cli, m)?)?;
    m.add_function(wrap_pyfunction!(record_drive, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
