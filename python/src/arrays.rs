//! Frames as numpy arrays: the dicts an `Env` observes and a `Dataset` yields, and the `Frame`
//! a Python planner's `observe` sees (which keeps the exact camera, so a wrapped built-in
//! planner sees what it would in the loop).

use autonomy::camera::PinholeCamera;
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::exceptions::PyKeyError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use splatloop::camera::RgbdFrame;
use splatloop::robot::Pose2;

/// A frame as a dict of arrays: `rgb` (H, W, 3) uint8, `depth` (H, W) float32 metres,
/// `pose` (4, 4) float64 world_from_camera (optical frame), `K` (3, 3), `time`.
pub fn frame_dict<'py>(py: Python<'py>, frame: &RgbdFrame) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    dict.set_item("rgb", rgb_array(py, &frame.rgb, &frame.camera)?)?;
    dict.set_item("depth", depth_array(py, &frame.depth, &frame.camera)?)?;
    dict.set_item("pose", pose_array(py, &frame.camera)?)?;
    dict.set_item("K", intrinsics_array(py, &frame.camera)?)?;
    dict.set_item("time", frame.time)?;
    Ok(dict)
}

/// (H, W, 3) uint8.
pub fn rgb_array<'py>(
    py: Python<'py>,
    rgb: &[u8],
    camera: &PinholeCamera,
) -> PyResult<Bound<'py, PyAny>> {
    let k = &camera.intrinsics;
    let shape = [k.height as usize, k.width as usize, 3];
    Ok(PyArray1::from_slice(py, rgb).reshape(shape)?.into_any())
}

/// (H, W) float32 metres.
pub fn depth_array<'py>(
    py: Python<'py>,
    depth: &[f32],
    camera: &PinholeCamera,
) -> PyResult<Bound<'py, PyAny>> {
    image_array(py, depth, camera)
}

/// (H, W) uint16 ids (an instance or semantic mask).
pub fn mask_array<'py>(
    py: Python<'py>,
    ids: &[u16],
    camera: &PinholeCamera,
) -> PyResult<Bound<'py, PyAny>> {
    image_array(py, ids, camera)
}

/// One value per pixel as an (H, W) array.
fn image_array<'py, T: numpy::Element + Copy>(
    py: Python<'py>,
    values: &[T],
    camera: &PinholeCamera,
) -> PyResult<Bound<'py, PyAny>> {
    let k = &camera.intrinsics;
    let shape = [k.height as usize, k.width as usize];
    Ok(PyArray1::from_slice(py, values).reshape(shape)?.into_any())
}

/// (4, 4) float64 world_from_camera.
pub fn pose_array<'py>(py: Python<'py>, camera: &PinholeCamera) -> PyResult<Bound<'py, PyAny>> {
    let m = camera.world_from_camera.to_homogeneous();
    let rows: Vec<Vec<f64>> = (0..4)
        .map(|r| (0..4).map(|c| m[(r, c)]).collect())
        .collect();
    Ok(PyArray2::from_vec2(py, &rows)?.into_any())
}

/// (3, 3) float64 K.
pub fn intrinsics_array<'py>(
    py: Python<'py>,
    camera: &PinholeCamera,
) -> PyResult<Bound<'py, PyAny>> {
    let k = &camera.intrinsics;
    let rows = vec![
        vec![k.fx, 0.0, k.cx],
        vec![0.0, k.fy, k.cy],
        vec![0.0, 0.0, 1.0],
    ];
    Ok(PyArray2::from_vec2(py, &rows)?.into_any())
}

/// One camera frame as a planner sees it: `rgb`, `depth`, `pose`, `K` (as in an `Env`
/// observation), `robot` (x, y, theta) when it was taken and the sensor's `max_range`.
/// `frame["depth"]` works too. Arrays are made when read.
#[pyclass(frozen, module = "splatloop._splatloop")]
pub struct Frame {
    pub rgb: Vec<u8>,
    pub depth: Vec<f32>,
    pub camera: PinholeCamera,
    pub max_range: f64,
    pub robot: Pose2,
}

impl Frame {
    /// The loop's observation, exactly as the episode made it.
    pub fn observation(&self) -> autonomy::explore::Observation<'_> {
        autonomy::explore::Observation {
            rgb: &self.rgb,
            depth: &self.depth,
            camera: &self.camera,
            max_range: self.max_range,
            robot: self.robot,
        }
    }
}

#[pymethods]
impl Frame {
    /// (H, W, 3) uint8.
    #[getter]
    fn rgb<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        rgb_array(py, &self.rgb, &self.camera)
    }

    /// (H, W) float32 metres, 0 where nothing returned.
    #[getter]
    fn depth<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        depth_array(py, &self.depth, &self.camera)
    }

    /// (4, 4) float64 world_from_camera (OpenCV optical frame).
    #[getter]
    fn pose<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        pose_array(py, &self.camera)
    }

    /// (3, 3) float64 intrinsics.
    #[getter(K)]
    fn intrinsics<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        intrinsics_array(py, &self.camera)
    }

    /// The robot's planar pose (x, y, theta) when the frame was taken.
    #[getter]
    fn robot(&self) -> (f64, f64, f64) {
        (self.robot.x, self.robot.y, self.robot.theta)
    }

    /// The sensor's range, metres.
    #[getter]
    fn max_range(&self) -> f64 {
        self.max_range
    }

    /// `frame["depth"]`: the attribute of that name.
    fn __getitem__<'py>(slf: &Bound<'py, Self>, key: &str) -> PyResult<Bound<'py, PyAny>> {
        match key {
            "rgb" | "depth" | "pose" | "K" | "robot" | "max_range" => slf.getattr(key),
            other => Err(PyKeyError::new_err(format!(
                "{other:?}: a frame has rgb, depth, pose, K, robot and max_range"
            ))),
        }
    }
}
