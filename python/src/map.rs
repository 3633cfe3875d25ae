//! `Map`: a snapshot of the Gaussian map as arrays, rendered with the episode's engine.

use autonomy::camera::{Intrinsics, PinholeCamera};
use autonomy::map::GaussianMap;
use autonomy::splat::Rasteriser;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2};
use pyo3::exceptions::{PyKeyError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::Arc;

/// The map at one instant: `means` (N, 3), `colours` (N, 3) in [0, 1], `opacities` (N,),
/// `radii` (N,) metres, `uncertainty` (N,) (RT-GuIDE's: metres moved in the last mapping
/// step); `len(map)` Gaussians; `map["means"]` works too. Arrays are made when read;
/// `render` draws it with the episode's splat engine.
#[pyclass(frozen, module = "splatloop._splatloop")]
pub struct Map {
    pub map: GaussianMap,
    pub engine: Arc<Rasteriser>,
    /// The sensor's range: rendered depth beyond it reads 0, as the camera's.
    pub max_range: f64,
}

fn flat(v: &[[f32; 3]]) -> Vec<f32> {
    v.iter().flatten().copied().collect()
}

#[pymethods]
impl Map {
    fn __len__(&self) -> usize {
        self.map.len()
    }

    /// Centres, (N, 3) float32 metres in the world frame.
    #[getter]
    fn means<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let n = self.map.len();
        Ok(PyArray1::from_vec(py, flat(&self.map.gaussians.means))
            .reshape([n, 3])?
            .into_any())
    }

    /// Colours, (N, 3) float32 in [0, 1].
    #[getter]
    fn colours<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let n = self.map.len();
        Ok(PyArray1::from_vec(py, flat(&self.map.gaussians.colours))
            .reshape([n, 3])?
            .into_any())
    }

    /// Opacities, (N,) float32 in (0, 1).
    #[getter]
    fn opacities<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        let g = &self.map.gaussians;
        let o: Vec<f32> = g
            .logit_opacities
            .iter()
            .map(|l| 1.0 / (1.0 + (-l).exp()))
            .collect();
        PyArray1::from_vec(py, o).into_any()
    }

    /// Radii, (N,) float32 metres.
    #[getter]
    fn radii<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        let r: Vec<f32> = self
            .map
            .gaussians
            .log_radii
            .iter()
            .map(|l| l.exp())
            .collect();
        PyArray1::from_vec(py, r).into_any()
    }

    /// RT-GuIDE's uncertainty per Gaussian, (N,) float32.
    #[getter]
    fn uncertainty<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        PyArray1::from_slice(py, &self.map.uncertainty).into_any()
    }

    /// `map["means"]`: the attribute of that name.
    fn __getitem__<'py>(slf: &Bound<'py, Self>, key: &str) -> PyResult<Bound<'py, PyAny>> {
        match key {
            "means" | "colours" | "opacities" | "radii" | "uncertainty" => slf.getattr(key),
            other => Err(PyKeyError::new_err(format!(
                "{other:?}: a map has means, colours, opacities, radii and uncertainty"
            ))),
        }
    }

    /// Renders the map from `world_from_camera` ((4, 4), OpenCV optical frame) with
    /// intrinsics `K` ((3, 3)) at `width` x `height`: (rgb (H, W, 3) uint8, depth (H, W)
    /// float32 metres, 0 where the map is less than half opaque or beyond the sensor's range),
    /// as `splatloop render` writes them.
    fn render<'py>(
        &self,
        py: Python<'py>,
        world_from_camera: PyReadonlyArray2<'py, f64>,
        #[allow(non_snake_case)] K: PyReadonlyArray2<'py, f64>,
        width: u32,
        height: u32,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let camera = camera_from_arrays(&world_from_camera, &K, width, height)?;
        let rendered = self
            .engine
            .render(&self.map.gaussians, &camera)
            .map_err(|e| PyRuntimeError::new_err(format!("rendering the map failed: {e}")))?;
        let (rgb, depth) =
            splatloop::novel_view::sensor_images(rendered.images(), self.max_range as f32);
        Ok((
            crate::arrays::rgb_array(py, &rgb, &camera)?,
            crate::arrays::depth_array(py, &depth, &camera)?,
        ))
    }

    /// Writes the map as a 3DGS PLY (spherical-harmonic degree 0, with `uncertainty`).
    fn save_ply(&self, path: PathBuf) -> PyResult<()> {
        autonomy::ply::write_with_sh_degree(&self.map, &path, 0)
            .map_err(|e| PyRuntimeError::new_err(format!("cannot write {}: {e}", path.display())))
    }

    fn __repr__(&self) -> String {
        format!("<splatloop map of {} Gaussians>", self.map.len())
    }
}

/// A pinhole camera from numpy arrays, checked: a rigid pose, a finite K with positive focal
/// lengths, a positive size.
fn camera_from_arrays(
    pose: &PyReadonlyArray2<'_, f64>,
    k: &PyReadonlyArray2<'_, f64>,
    width: u32,
    height: u32,
) -> PyResult<PinholeCamera> {
    let pose = pose.as_array();
    let k = k.as_array();
    if pose.shape() != [4, 4] || k.shape() != [3, 3] {
        return Err(PyValueError::new_err(format!(
            "world_from_camera is (4, 4) and K is (3, 3); got {:?} and {:?}",
            pose.shape(),
            k.shape()
        )));
    }
    if width == 0 || height == 0 || width > 8192 || height > 8192 {
        return Err(PyValueError::new_err(format!(
            "an image of {width} x {height}: give 1 to 8192 pixels a side"
        )));
    }
    if !(pose.iter().all(|v| v.is_finite()) && k.iter().all(|v| v.is_finite())) {
        return Err(PyValueError::new_err(
            "world_from_camera and K must be finite",
        ));
    }
    let m = nalgebra::Matrix4::from_fn(|r, c| pose[[r, c]]);
    let rotation = m.fixed_view::<3, 3>(0, 0).into_owned();
    let orthonormal = (rotation.transpose() * rotation - nalgebra::Matrix3::identity()).norm();
    if orthonormal > 1e-6 || (rotation.determinant() - 1.0).abs() > 1e-6 {
        return Err(PyValueError::new_err(format!(
            "world_from_camera's rotation is not a rotation (|R^T R - I| = {orthonormal:.2e}, det {:.6})",
            rotation.determinant()
        )));
    }
    // Shepperd's closed form (an iterative fit from the identity fails at half turns),
    // renormalised: the matrix is a rotation to 1e-6.
    let rotation = nalgebra::UnitQuaternion::from_rotation_matrix(
        &nalgebra::Rotation3::from_matrix_unchecked(rotation),
    );
    let rotation = nalgebra::UnitQuaternion::new_normalize(rotation.into_inner());
    let translation = nalgebra::Translation3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]);
    let (fx, fy) = (k[[0, 0]], k[[1, 1]]);
    if !(fx > 0.0 && fy > 0.0) {
        return Err(PyValueError::new_err(format!(
            "K's focal lengths must be positive; got fx = {fx}, fy = {fy}"
        )));
    }
    Ok(PinholeCamera {
        intrinsics: Intrinsics {
            fx,
            fy,
            cx: k[[0, 2]],
            cy: k[[1, 2]],
            width,
            height,
        },
        world_from_camera: nalgebra::Isometry3::from_parts(translation, rotation),
    })
}
