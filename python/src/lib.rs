//! `splatloop._splatloop`: the Rust half of the Python package. An `Episode` is the library's
//! closed-loop episode, stepped from Python a think period at a time, with its frames as numpy
//! arrays (one copy each); a `Dataset` reads an episode folder's frames. The Python half
//! (`splatloop.Env`, the Gymnasium environment) builds on these.

use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::{PyFileNotFoundError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use splatloop::camera::RgbdFrame;
use splatloop::episode::Think;
use splatloop::robot::UnicycleCommand;
use splatloop::SimError;
use std::path::PathBuf;

/// A host error as the Python exception a user expects, its whole cause chain in the message.
fn to_py(error: SimError) -> PyErr {
    let message = error.chain();
    match error {
        SimError::MissingFile { .. } => PyFileNotFoundError::new_err(message),
        SimError::InvalidArgument { .. } => PyValueError::new_err(message),
        _ => PyRuntimeError::new_err(message),
    }
}

/// A frame as a dict of arrays: `rgb` (H, W, 3) uint8, `depth` (H, W) float32 metres,
/// `pose` (4, 4) float64 world_from_camera (optical frame), `K` (3, 3), `time`.
fn frame_dict<'py>(py: Python<'py>, frame: &RgbdFrame) -> PyResult<Bound<'py, PyDict>> {
    let k = &frame.camera.intrinsics;
    let (w, h) = (k.width as usize, k.height as usize);
    let dict = depth_dict(py, &frame.depth, &frame.camera)?;
    dict.set_item(
        "rgb",
        PyArray1::from_slice(py, &frame.rgb).reshape([h, w, 3])?,
    )?;
    dict.set_item("time", frame.time)?;
    Ok(dict)
}

/// A depth image and its camera as arrays: `depth`, `pose`, `K` (see `frame_dict`).
fn depth_dict<'py>(
    py: Python<'py>,
    depth: &[f32],
    camera: &autonomy::camera::PinholeCamera,
) -> PyResult<Bound<'py, PyDict>> {
    let k = &camera.intrinsics;
    let (w, h) = (k.width as usize, k.height as usize);
    let depth = PyArray1::from_slice(py, depth).reshape([h, w])?;
    let m = camera.world_from_camera.to_homogeneous();
    let pose: Vec<f64> = (0..16).map(|i| m[(i / 4, i % 4)]).collect();
    let pose = PyArray1::from_vec(py, pose).reshape([4, 4])?;
    let intrinsics = vec![k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0];
    let intrinsics = PyArray1::from_vec(py, intrinsics).reshape([3, 3])?;
    let dict = PyDict::new(py);
    dict.set_item("depth", depth)?;
    dict.set_item("pose", pose)?;
    dict.set_item("K", intrinsics)?;
    Ok(dict)
}

/// One closed-loop episode (`splatloop run`'s), stepped from Python. It holds the EGL context,
/// so it stays on the thread that made it: used from another, it raises.
#[pyclass(unsendable, module = "splatloop._splatloop")]
struct Episode {
    inner: Option<splatloop::episode::Episode>,
}

impl Episode {
    fn get(&mut self) -> PyResult<&mut splatloop::episode::Episode> {
        self.inner
            .as_mut()
            .ok_or_else(|| PyRuntimeError::new_err("the episode was already written (finish)"))
    }
}

#[pymethods]
impl Episode {
    /// An episode from `splatloop run`'s flags (e.g. `["--world", "worlds/room.xml"]`): the
    /// same defaults and the same errors.
    #[new]
    fn new(words: Vec<String>) -> PyResult<Self> {
        let config = splatloop::commands::run_config_from_words(words)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
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

    /// The map as arrays: `means` (N, 3), `colours` (N, 3) in [0, 1], `opacities` (N,),
    /// `radii` (N,) metres, `uncertainty` (N,) (RT-GuIDE's, metres moved in the last step).
    fn map<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        map_dict(py, self.get()?.map())
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

    /// Simulated seconds.
    fn time(&mut self) -> PyResult<f64> {
        Ok(self.get()?.time())
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

/// A planner written in Python, in the episode's loop: every think period `obj.plan(observation,
/// map)` with `observation` = {"start": (x, y, theta)} (the pose the plan begins from) and `map`
/// the map's arrays; it returns a dict with `commands` ([(v, w), ...], one per `period`
/// seconds, default 1) to drive, a string to end the episode with that reason, or `None` for
/// no plan (the host's recovery). `obj.observe(frame)`, when defined, sees every frame (`depth`,
/// `pose`, `K`). Its decisions go through the same controller as the built-in planners'.
struct PythonPlanner {
    obj: Py<PyAny>,
    class: String,
    /// The first exception the object raised; the episode ends on it and `run` re-raises it.
    error: std::rc::Rc<std::cell::RefCell<Option<PyErr>>>,
}

impl PythonPlanner {
    fn decide(
        &self,
        py: Python<'_>,
        map: &autonomy::map::GaussianMap,
        start: splatloop::robot::Pose2,
    ) -> PyResult<autonomy::explore::Decision> {
        use autonomy::explore::{Decision, Plan, PlanFailure};
        let observation = PyDict::new(py);
        observation.set_item("start", (start.x, start.y, start.theta))?;
        let answer = self
            .obj
            .call_method1(py, "plan", (observation, map_dict(py, map)?))?;
        let answer = answer.bind(py);
        if answer.is_none() {
            return Ok(Decision::Fail(PlanFailure::GoalUnreachable));
        }
        if let Ok(reason) = answer.extract::<String>() {
            return Ok(Decision::Done(reason));
        }
        let commands: Vec<(f64, f64)> = answer.get_item("commands")?.extract()?;
        let period: f64 = match answer.get_item("period") {
            Ok(p) => p.extract()?,
            Err(_) => 1.0,
        };
        let limits = autonomy::drive::DriveLimits::default();
        if !(period.is_finite() && period > 0.0) || commands.is_empty() {
            return Err(PyValueError::new_err(format!(
                "a plan needs commands and a positive period; got {} commands, period {period}",
                commands.len()
            )));
        }
        let mut states = vec![start];
        let mut drive = Vec::with_capacity(commands.len());
        for (v, w) in commands {
            let u = UnicycleCommand { v, w };
            if !(v.is_finite() && w.is_finite() && limits.admits(u)) {
                return Err(PyValueError::new_err(format!(
                    "plan command ({v}, {w}) is outside the drive's limits (0 <= v <= {} m/s, |w| <= {} rad/s)",
                    limits.max_forward, limits.max_turn
                )));
            }
            let last = states[states.len() - 1];
            states.push(autonomy::drive::advance(&last, &u, period));
            drive.push(u);
        }
        Ok(Decision::Go(Plan::unsearched(drive, period, states)))
    }
}

impl autonomy::explore::Planner for PythonPlanner {
    fn name(&self) -> &'static str {
        "python"
    }

    fn settings(&self) -> serde_json::Value {
        serde_json::json!({ "class": self.class })
    }

    fn observe(
        &mut self,
        observation: &autonomy::explore::Observation<'_>,
        _map: &autonomy::map::GaussianMap,
    ) {
        if self.error.borrow().is_some() {
            return;
        }
        Python::with_gil(|py| {
            let outcome = (|| -> PyResult<()> {
                if !self.obj.bind(py).hasattr("observe")? {
                    return Ok(());
                }
                let dict = depth_dict(py, observation.depth, observation.camera)?;
                self.obj.call_method1(py, "observe", (dict,))?;
                Ok(())
            })();
            if let Err(e) = outcome {
                *self.error.borrow_mut() = Some(e);
            }
        });
    }

    fn plan(
        &mut self,
        map: &autonomy::map::GaussianMap,
        start: splatloop::robot::Pose2,
    ) -> autonomy::explore::Decision {
        if let Some(e) = self.error.borrow().as_ref() {
            return autonomy::explore::Decision::Done(format!("the Python planner raised: {e}"));
        }
        Python::with_gil(|py| match self.decide(py, map, start) {
            Ok(decision) => decision,
            Err(e) => {
                let reason = format!("the Python planner raised: {e}");
                *self.error.borrow_mut() = Some(e);
                autonomy::explore::Decision::Done(reason)
            }
        })
    }
}

/// Runs a whole episode (`splatloop run`'s flags in `words`) with `planner`, a Python object,
/// deciding every think period; writes the folder and returns metrics.json as a JSON string.
/// An exception the planner raised ends the episode (still written) and is raised again.
#[pyfunction]
fn run_with_planner(py: Python<'_>, words: Vec<String>, planner: Py<PyAny>) -> PyResult<String> {
    let config = splatloop::commands::run_config_from_words(words)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let class = planner
        .bind(py)
        .get_type()
        .qualname()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "?".to_owned());
    let error = std::rc::Rc::new(std::cell::RefCell::new(None));
    let bridge = PythonPlanner {
        obj: planner,
        class,
        error: error.clone(),
    };
    let episode =
        splatloop::episode::Episode::with_planner(&config, Box::new(bridge)).map_err(to_py)?;
    let metrics = splatloop::episode::run_to_end(episode, &mut |_| {}).map_err(to_py)?;
    if let Some(e) = error.borrow_mut().take() {
        return Err(e);
    }
    serde_json::to_string(&metrics).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// Records an open-loop drive as `splatloop record WORDS` does; returns (frames, collision
/// steps, final pose (x, y, theta)).
#[pyfunction]
fn record_drive(words: Vec<String>) -> PyResult<(usize, usize, (f64, f64, f64))> {
    let config = splatloop::commands::record_config_from_words(words)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let summary = splatloop::record::record(&config, &mut |_| {}).map_err(to_py)?;
    let p = summary.final_pose;
    Ok((summary.frames, summary.collision_steps, (p.x, p.y, p.theta)))
}

/// The map's arrays (see `Episode::map`).
fn map_dict<'py>(
    py: Python<'py>,
    map: &autonomy::map::GaussianMap,
) -> PyResult<Bound<'py, PyDict>> {
    let g = &map.gaussians;
    let n = g.len();
    let flat = |v: &[[f32; 3]]| v.iter().flatten().copied().collect::<Vec<f32>>();
    let dict = PyDict::new(py);
    dict.set_item(
        "means",
        PyArray1::from_vec(py, flat(&g.means)).reshape([n, 3])?,
    )?;
    dict.set_item(
        "colours",
        PyArray1::from_vec(py, flat(&g.colours)).reshape([n, 3])?,
    )?;
    let opacities: Vec<f32> = g
        .logit_opacities
        .iter()
        .map(|l| 1.0 / (1.0 + (-l).exp()))
        .collect();
    dict.set_item("opacities", PyArray1::from_vec(py, opacities))?;
    let radii: Vec<f32> = g.log_radii.iter().map(|l| l.exp()).collect();
    dict.set_item("radii", PyArray1::from_vec(py, radii))?;
    dict.set_item("uncertainty", PyArray1::from_slice(py, &map.uncertainty))?;
    Ok(dict)
}

/// An episode or `record` folder read frame by frame (torn last frames skipped).
#[pyclass(module = "splatloop._splatloop")]
struct Dataset {
    inner: splatloop::dataset::Dataset,
}

#[pymethods]
impl Dataset {
    /// Opens the folder at `path`.
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        if !path.is_dir() {
            return Err(PyFileNotFoundError::new_err(format!(
                "{}: no such dataset folder",
                path.display()
            )));
        }
        let inner = splatloop::dataset::Dataset::open(&path).map_err(to_py)?;
        Ok(Dataset { inner })
    }

    fn __len__(&self) -> usize {
        self.inner.frames.len()
    }

    /// Frame `index` (negative counts from the end) as arrays, with its `timestamp`.
    fn __getitem__<'py>(&self, py: Python<'py>, index: isize) -> PyResult<Bound<'py, PyDict>> {
        let n = self.inner.frames.len() as isize;
        let i = if index < 0 { index + n } else { index };
        if !(0..n).contains(&i) {
            return Err(pyo3::exceptions::PyIndexError::new_err(format!(
                "frame {index} of a dataset of {n}"
            )));
        }
        let frame = self.inner.load(i as usize).map_err(to_py)?;
        let dict = frame_dict(py, &frame)?;
        dict.set_item("timestamp", self.inner.frames[i as usize].time)?;
        Ok(dict)
    }
}

/// The module.
#[pymodule]
fn _splatloop(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Episode>()?;
    m.add_class::<Dataset>()?;
    m.add_function(wrap_pyfunction!(run_with_planner, m)?)?;
    m.add_function(wrap_pyfunction!(record_drive, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
