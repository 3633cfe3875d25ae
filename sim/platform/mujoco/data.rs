//! `mjData`: the simulation state, stepping, contacts and ray casts.

use super::sys;
use super::Model;
use crate::error::{Result, SimError};
use nalgebra::{Matrix3, Point3, Vector3};
use std::ptr::NonNull;
use std::sync::Arc;

/// Simulation state of one model; owns its `mjData` and shares the model.
pub struct Data {
    raw: NonNull<sys::mjData>,
    model: Arc<Model>,
}

// SAFETY: mjData has no thread affinity; mutation only happens through `&mut self`.
unsafe impl Send for Data {}

impl Drop for Data {
    fn drop(&mut self) {
        // SAFETY: raw came from mj_makeData and is freed exactly once.
        unsafe { sys::mj_deleteData(self.raw.as_ptr()) }
    }
}

/// A contact between two geoms, as MuJoCo's collision detection reports it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// First geom.
    pub geom1: usize,
    /// Second geom.
    pub geom2: usize,
    /// Signed distance (negative: penetration), metres.
    pub distance: f64,
    /// Contact point in the world frame.
    pub position: Point3<f64>,
}

/// The nearest geom a ray hits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// Distance along the ray in units of the direction's length.
    pub distance: f64,
    /// The geom hit.
    pub geom: usize,
}

impl Data {
    /// Allocates state for `model` and computes the initial kinematics.
    pub fn new(model: Arc<Model>) -> Result<Self> {
        // SAFETY: the model pointer is valid; mj_makeData returns null only on allocation failure.
        let raw = unsafe { sys::mj_makeData(model.raw_ptr()) };
        let raw = NonNull::new(raw).ok_or_else(|| SimError::InvalidArgument {
            what: "model",
            detail: "MuJoCo could not allocate its data (out of memory?)".into(),
        })?;
        let mut data = Data { raw, model };
        data.forward();
        Ok(data)
    }

    /// The model this state belongs to.
    pub fn model(&self) -> &Arc<Model> {
        &self.model
    }

    fn raw(&self) -> &sys::mjData {
        // SAFETY: raw is valid for the lifetime of self.
        unsafe { self.raw.as_ref() }
    }

    fn raw_mut(&mut self) -> &mut sys::mjData {
        // SAFETY: raw is valid and &mut self is exclusive.
        unsafe { self.raw.as_mut() }
    }

    pub(crate) fn raw_ptr(&self) -> *const sys::mjData {
        self.raw.as_ptr()
    }

    /// Advances one physics step; an exploding simulation (NaN/Inf accelerations) is an error
    /// instead of silently reset state.
    pub fn step(&mut self) -> Result<()> {
        // SAFETY: model and data pointers are valid and belong together.
        unsafe { sys::mj_step(self.model.raw_ptr(), self.raw.as_ptr()) };
        self.check_warnings()
    }

    /// Recomputes kinematics, contacts and everything derived from qpos/qvel.
    pub fn forward(&mut self) {
        // SAFETY: model and data pointers are valid and belong together.
        unsafe { sys::mj_forward(self.model.raw_ptr(), self.raw.as_ptr()) }
    }

    /// Resets to the model's initial state (qpos0, zero velocity, time 0).
    pub fn reset(&mut self) {
        // SAFETY: model and data pointers are valid and belong together.
        unsafe { sys::mj_resetData(self.model.raw_ptr(), self.raw.as_ptr()) };
        self.forward();
    }

    fn check_warnings(&mut self) -> Result<()> {
        let bad = [
            (sys::mjtWarning::mjWARN_BADQACC, "NaN or huge acceleration"),
            (sys::mjtWarning::mjWARN_BADQVEL, "NaN or huge velocity"),
            (sys::mjtWarning::mjWARN_BADQPOS, "NaN or huge position"),
            (sys::mjtWarning::mjWARN_BADCTRL, "NaN or huge control"),
        ];
        for (warning, detail) in bad {
            if self.raw().warning[warning as usize].number > 0 {
                let time = self.time();
                self.raw_mut().warning[warning as usize].number = 0;
                return Err(SimError::Unstable {
                    time,
                    detail: detail.into(),
                });
            }
        }
        Ok(())
    }

    /// Simulated time, seconds.
    pub fn time(&self) -> f64 {
        self.raw().time
    }

    /// Generalised positions.
    pub fn qpos(&self) -> &[f64] {
        slice(self.raw().qpos, self.model.nq())
    }

    /// Generalised positions, writable (call [`Data::forward`] after editing).
    pub fn qpos_mut(&mut self) -> &mut [f64] {
        let n = self.model.nq();
        slice_mut(self.raw_mut().qpos, n)
    }

    /// Generalised velocities.
    pub fn qvel(&self) -> &[f64] {
        slice(self.raw().qvel, self.model.nv())
    }

    /// Generalised velocities, writable.
    pub fn qvel_mut(&mut self) -> &mut [f64] {
        let n = self.model.nv();
        slice_mut(self.raw_mut().qvel, n)
    }

    /// Actuator controls, writable.
    pub fn ctrl_mut(&mut self) -> &mut [f64] {
        let n = self.model.nu();
        slice_mut(self.raw_mut().ctrl, n)
    }

    /// World position of a body's frame.
    pub fn body_position(&self, body: usize) -> Point3<f64> {
        point(slice(self.raw().xpos, 3 * self.model.body_count()), body)
    }

    /// World position of a camera.
    pub fn camera_position(&self, camera: usize) -> Point3<f64> {
        point(slice(self.raw().cam_xpos, 3 * self.camera_count()), camera)
    }

    /// World orientation of a camera (columns: the camera's x, y, z axes in MuJoCo's
    /// convention, looking along -z with y up).
    pub fn camera_rotation(&self, camera: usize) -> Matrix3<f64> {
        rotation(slice(self.raw().cam_xmat, 9 * self.camera_count()), camera)
    }

    /// World position of a site.
    pub fn site_position(&self, site: usize) -> Point3<f64> {
        point(slice(self.raw().site_xpos, 3 * self.site_count()), site)
    }

    /// World orientation of a site.
    pub fn site_rotation(&self, site: usize) -> Matrix3<f64> {
        rotation(slice(self.raw().site_xmat, 9 * self.site_count()), site)
    }

    /// World position of a geom's frame.
    pub fn geom_position(&self, geom: usize) -> Point3<f64> {
        point(
            slice(self.raw().geom_xpos, 3 * self.model.geom_count()),
            geom,
        )
    }

    /// World orientation of a geom's frame.
    pub fn geom_rotation(&self, geom: usize) -> Matrix3<f64> {
        rotation(
            slice(self.raw().geom_xmat, 9 * self.model.geom_count()),
            geom,
        )
    }

    fn camera_count(&self) -> usize {
        self.model.raw().ncam as usize
    }

    fn site_count(&self) -> usize {
        self.model.raw().nsite as usize
    }

    /// The contacts of the last step or forward.
    pub fn contacts(&self) -> impl Iterator<Item = Contact> + '_ {
        let d = self.raw();
        slice(d.contact as *const sys::mjContact, d.ncon as usize)
            .iter()
            .map(|c| Contact {
                geom1: c.geom1 as usize,
                geom2: c.geom2 as usize,
                distance: c.dist,
                position: Point3::new(c.pos[0], c.pos[1], c.pos[2]),
            })
    }

    /// Casts a ray from `origin` along `direction` against the geoms whose group is enabled in
    /// `groups` (bit i = group i), ignoring `exclude_body`. Distance is in multiples of
    /// `direction`'s length.
    pub fn ray(
        &self,
        origin: &Point3<f64>,
        direction: &Vector3<f64>,
        groups: u8,
        exclude_body: Option<usize>,
    ) -> Option<RayHit> {
        let mut group_mask = [0u8; 6];
        for (i, g) in group_mask.iter_mut().enumerate() {
            *g = (groups >> i) & 1;
        }
        let mut geom = -1i32;
        // SAFETY: all pointers reference live arrays of the sizes MuJoCo expects (3, 3, 6).
        let distance = unsafe {
            sys::mj_ray(
                self.model.raw_ptr(),
                self.raw_ptr(),
                origin.coords.as_ptr(),
                direction.as_ptr(),
                group_mask.as_ptr(),
                // Static geoms count (an mjtByte before MuJoCo 4, a C bool from 4 on).
                c_flag(true),
                exclude_body.map_or(-1, |b| b as i32),
                &mut geom,
                // MuJoCo 4 also reports the surface normal at the hit; we need no normal.
                #[cfg(mujoco_4)]
                std::ptr::null_mut(),
            )
        };
        (geom >= 0 && distance >= 0.0).then_some(RayHit {
            distance,
            geom: geom as usize,
        })
    }
}

fn point(values: &[f64], index: usize) -> Point3<f64> {
    Point3::new(
        values[3 * index],
        values[3 * index + 1],
        values[3 * index + 2],
    )
}

/// MuJoCo stores 3x3 matrices row-major.
fn rotation(values: &[f64], index: usize) -> Matrix3<f64> {
    Matrix3::from_row_slice(&values[9 * index..9 * index + 9])
}

fn slice<'a, T>(ptr: *const T, len: usize) -> &'a [T] {
    if ptr.is_null() || len == 0 {
        return &[];
    }
    // SAFETY: MuJoCo allocates these arrays with the model's sizes for the data's lifetime.
    unsafe { std::slice::from_raw_parts(ptr, len) }
}

fn slice_mut<'a, T>(ptr: *mut T, len: usize) -> &'a mut [T] {
    if ptr.is_null() || len == 0 {
        return &mut [];
    }
    // SAFETY: as in `slice`; callers hold `&mut Data`, so the borrow is exclusive.
    unsafe { std::slice::from_raw_parts_mut(ptr, len) }
}

/// A C flag argument from a bool, whatever MuJoCo's type for it (`mjtByte` before 4, `bool`
/// from 4 on): `.into()` would be a no-op, and a lint, under MuJoCo 4.
fn c_flag<T: From<bool>>(value: bool) -> T {
    T::from(value)
}
