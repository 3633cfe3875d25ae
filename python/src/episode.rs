//! `Episode`: the library's closed-loop episode, stepped from Python a think period at a time.

use crate::arrays::frame_dict;
use crate::map::Map;
use crate::planners::{decision_to_py, PlannerContext};
use crate::{to_py, words_error};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use splatloop::episode::{PlannerKind, Think};
use splatloop::robot::UnicycleCommand;
use std::path::PathBuf;

/// One closed-loop episode (`splatloop run`'s), stepped from Python. It holds the EGL context,
/// so it stays on the thread that made it: used from another, it raises.
#[pyclass(unsendable, module = "splatloop._splatloop")]
pub struct Episode {
    inner: Option<splatloop::episode::Episode>,
}

impl Episode {
    fn get(&mut self) -> PyResult<&mut splatloop::episode::Episode> {
        self.inner
            .as_mut()
            .ok_or_else(|| PyRuntimeError::new_err("the episode was already written (finish)"))
    }
}

fn planner_kind(name: &str) -> PyResult<PlannerKind> {
    name.parse().map_err(PyValueError::new_err)
}

#[pymethods]
impl Episode {
    /// An episode from `splatloop run`'s flags (e.g. `["--world", "worlds/room.xml"]`): the
    /// same defaults and the same errors.
    #[new]
    fn new(words: Vec<String>) -> PyResult<Self> {
        let config = splatloop::commands::run_config_from_words(words).map_err(words_error)?;
        let inner = splatloop::episode::Episode::new(&config).map_err(to_py)?;
        Ok(Episode { inner: Some(inner) })
    }

    /// The newest frame (the one the next step maps), as arrays.
    fn observe<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let frame = self.get()?.observe().map_err(to_py)?;
        frame_dict(py, frame)
    }

    /// Drives (v, w) for the next think period instead of the planner.
    fn apply(&mut self, v: f64, w: f64) -> PyResult<()> {
        self.get()?.apply(UnicycleCommand { v, w }).map_err(to_py)
    }

    /// The drive's limits: (most forward speed m/s, most turn rate rad/s).
    fn limits(&mut self) -> PyResult<(f64, f64)> {
        let limits = self.get()?.world().robot().limits;
        Ok((limits.max_forward, limits.max_turn))
    }

    /// Runs one think period; what happened, as a dict (`time`, `pose` (x, y, theta),
    /// `frames`, `collision_steps`, `gaussians`, `think`, `ended`).
    fn step<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let report = self.get()?.step().map_err(to_py)?;
        let dict = PyDict::new(py);
        dict.set_item("time", report.time)?;
        dict.set_item("pose", (report.pose.x, report.pose.y, report.pose.theta))?;
        dict.set_item("frames", report.frames)?;
        dict.set_item("collision_steps", report.collision_steps)?;
        dict.set_item("gaussians", report.gaussians)?;
        let think = match &report.think {
            None => "none",
            Some(Think::Planned(_)) => "planned",
            Some(Think::Overruled) => "overruled",
            Some(Think::Holding) => "holding",
            Some(Think::Driven(_)) => "driven",
            Some(Think::Idle) => "idle",
        };
        dict.set_item("think", think)?;
        dict.set_item("ended", report.ended)?;
        Ok(dict)
    }

    /// The map's coverage of the episode's hidden surface points now (metrics.json's
    /// coverage), `None` without test views.
    fn coverage(&mut self) -> PyResult<Option<f64>> {
        Ok(self.get()?.coverage_now())
    }

    /// The map now (a snapshot: it does not change as the episode goes on).
    fn map(&mut self) -> PyResult<Map> {
        let episode = self.get()?;
        Ok(Map {
            map: episode.map().clone(),
            engine: episode.engine(),
            max_range: episode.config().sensor.max_range,
        })
    }

    /// Writes the map as a 3DGS PLY (spherical-harmonic degree 0, with `uncertainty`).
    fn save_ply(&mut self, path: PathBuf) -> PyResult<()> {
        autonomy::ply::write_with_sh_degree(self.get()?.map(), &path, 0)
            .map_err(|e| PyRuntimeError::new_err(format!("cannot write {}: {e}", path.display())))
    }

    /// Gaussians in the map.
    fn gaussians(&mut self) -> PyResult<usize> {
        Ok(self.get()?.map().len())
    }

    /// Physics steps per think period (for a per-step collision fraction).
    fn steps_per_period(&mut self) -> PyResult<f64> {
        let episode = self.get()?;
        Ok(episode.config().think_period / episode.world().model().timestep())
    }

    /// The robot's planar pose (x, y, theta).
    fn pose(&mut self) -> PyResult<(f64, f64, f64)> {
        let p = self.get()?.pose();
        Ok((p.x, p.y, p.theta))
    }

    /// Simulated seconds.
    fn time(&mut self) -> PyResult<f64> {
        Ok(self.get()?.time())
    }

    /// What the episode's planner was built with.
    fn planner_context(&mut self) -> PyResult<PlannerContext> {
        Ok(PlannerContext {
            context: self.get()?.planner_context(),
        })
    }

    /// Makes the built-in planner `name` an advisor: it sees every frame from now on.
    fn advise(&mut self, name: &str) -> PyResult<()> {
        let kind = planner_kind(name)?;
        self.get()?.advise(kind).map_err(to_py)
    }

    /// What the built-in planner `name` would do from here now: a `Plan`, a `PlanFailure` or
    /// a string (done).
    fn consult(&mut self, py: Python<'_>, name: &str) -> PyResult<PyObject> {
        let kind = planner_kind(name)?;
        let decision = self.get()?.consult(kind).map_err(to_py)?;
        decision_to_py(py, decision)
    }

    /// Evaluates the map and writes the episode folder as `splatloop run` does; metrics.json's
    /// contents as a JSON string.
    fn finish(&mut self) -> PyResult<String> {
        let episode = self
            .inner
            .take()
            .ok_or_else(|| PyRuntimeError::new_err("the episode was already written"))?;
        let metrics = episode.finish().map_err(to_py)?;
        serde_json::to_string(&metrics).map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }
}
