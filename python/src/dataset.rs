//! `Dataset`: an episode or `record` folder read frame by frame, as arrays.

use crate::arrays::{frame_dict, mask_array};
use crate::to_py;
use pyo3::exceptions::{PyFileNotFoundError, PyIndexError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// An episode or `record` folder read frame by frame (torn last frames skipped); a dataset
/// written with masks also yields `instance` and `semantic` (H, W) uint16 ids, which
/// `labels` (labels.json as a dict) names.
#[pyclass(module = "splatloop._splatloop")]
pub struct Dataset {
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
            return Err(PyIndexError::new_err(format!(
                "frame {index} of a dataset of {n}"
            )));
        }
        let frame = self.inner.load(i as usize).map_err(to_py)?;
        let dict = frame_dict(py, &frame)?;
        dict.set_item("timestamp", self.inner.frames[i as usize].time)?;
        if let Some((instance, semantic)) = self.inner.load_masks(i as usize).map_err(to_py)? {
            dict.set_item("instance", mask_array(py, &instance, &frame.camera)?)?;
            dict.set_item("semantic", mask_array(py, &semantic, &frame.camera)?)?;
        }
        Ok(dict)
    }

    /// labels.json as a dict (`classes`: id, name; `instances`: id, name, class, geoms), or
    /// None for a dataset written without masks.
    #[getter]
    fn labels<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let Some(labels) = &self.inner.labels else {
            return Ok(None);
        };
        let text = serde_json::to_string(labels)
            .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?;
        let json = py.import("json")?;
        Ok(Some(json.call_method1("loads", (text,))?))
    }
}
