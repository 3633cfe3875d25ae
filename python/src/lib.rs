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
    let rgb = PyArray1::from_slice(py, &frame.rgb).reshape([h, w, 3])?;
    let depth = PyArray1::from_slice(py, &frame.depth).reshape([h, w])?;
    let m = frame.camera.world_from_camera.to_homogeneous();
    let pose: Vec<f64> = (0..16).map(|i| m[(i / 4, i % 4)]).collect();
    let pose = PyArray1::from_vec(py, pose).reshape([4, 4])?;
    let intrinsics = vec![k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0];
    let intrinsics = PyArray1::from_vec(py, intrinsics).reshape([3, 3])?;
    let dict = PyDict::new(py);
    dict.set_item("rgb", rgb)?;
    dict.set_item("depth", depth)?;
    dict.set_item("pose", pose)?;
    dict.set_item("K", intrinsics)?;
    dict.set_item("time", frame.time)?;
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
        let map = self.get()?.map();
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
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
