//! `mjv_` scene + `mjr_` OpenGL context: renders a model camera into client buffers.
//!
//! Needs an OpenGL context current on the calling thread ([`crate::egl::EglContext`]).

use super::sys;
use super::{Data, Model};
use crate::egl::{EglContext, GlFlush};
use crate::error::{Result, SimError};
use std::sync::{Arc, Mutex, MutexGuard};

/// The process's one lock on MuJoCo's OpenGL calls where the C side needs one.
/// `mjr_makeContext` runs MuJoCo's OpenGL loader (glad), whose function table and extension
/// list are process-wide C globals written on every call, so every renderer is made under
/// it. On a software renderer every draw and read-back is made under it too: Mesa's llvmpipe
/// (22.3, the CI machine's) crashed inside `mjr_render` in one thread while a second thread's
/// context read pixels (two closed-loop tests side by side, SIGSEGV in swrast_dri.so; all
/// other threads idle). The lock guards C state, not ours; a GPU driver renders its contexts
/// side by side unlocked.
static GL_CALLS: Mutex<()> = Mutex::new(());

/// Waits for [`GL_CALLS`] (a panic elsewhere while holding it leaves no C state half-done
/// that the next call could trip on, so a poisoned lock is taken as is).
fn lock_gl_calls() -> MutexGuard<'static, ()> {
    GL_CALLS
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Rendering features of the sensor; all off by default because they cost 10x on llvmpipe
/// and a real depth camera sees none of them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RenderFlags {
    /// Shadow mapping.
    pub shadows: bool,
    /// Planar reflections.
    pub reflections: bool,
    /// The skybox behind everything.
    pub skybox: bool,
    /// 4x multisampled offscreen buffer (smooth edges, mixed depths at silhouettes).
    pub multisample: bool,
}

impl RenderFlags {
    /// MuJoCo's own defaults: every effect on; the baseline the sensor defaults are measured
    /// against.
    pub fn mujoco_defaults() -> Self {
        RenderFlags {
            shadows: true,
            reflections: true,
            skybox: true,
            multisample: true,
        }
    }
}

/// A scene and an OpenGL context for one model at one resolution.
pub struct SceneRenderer {
    model: Arc<Model>,
    scene: Box<sys::mjvScene>,
    context: Box<sys::mjrContext>,
    option: sys::mjvOption,
    camera: sys::mjvCamera,
    perturb: sys::mjvPerturb,
    width: u32,
    height: u32,
    rgb_scratch: Vec<u8>,
    /// glFlush, to start a segmentation pass drawing before its pixels are read.
    flush: Option<GlFlush>,
    /// Whether draws and read-backs take [`GL_CALLS`] (a software renderer).
    serialised: bool,
}

impl Drop for SceneRenderer {
    fn drop(&mut self) {
        let _turn = self.gl_turn();
        // SAFETY: scene and context were made by mjv_makeScene/mjr_makeContext and are freed
        // once; the owner keeps the GL context alive longer than this renderer.
        unsafe {
            sys::mjr_freeContext(self.context.as_mut());
            sys::mjv_freeScene(self.scene.as_mut());
        }
    }
}

impl SceneRenderer {
    /// Allocates the scene and the GL resources of `model` (textures, meshes, the offscreen
    /// framebuffer). The model's offscreen buffer must already be at least `width` x `height`
    /// ([`Model::configure_offscreen`]).
    pub fn new(
        model: Arc<Model>,
        width: u32,
        height: u32,
        flags: RenderFlags,
        gl: &EglContext,
    ) -> Result<Self> {
        let vis = &model.raw().vis;
        if width as i32 > vis.global.offwidth || height as i32 > vis.global.offheight {
            return Err(SimError::InvalidArgument {
                what: "resolution",
                detail: format!(
                    "{width}x{height} exceeds the model's offscreen buffer {}x{}",
                    vis.global.offwidth, vis.global.offheight
                ),
            });
        }
        // Cameras made on several threads at once (parallel tests, a library user's
        // parallel episodes) take turns in MuJoCo's OpenGL loader.
        let _loader = lock_gl_calls();
        // SAFETY: mjvScene, mjrContext, mjvOption, mjvCamera and mjvPerturb are plain C structs
        // that their mj*_default* functions fully initialise; make* allocate against a valid
        // model while the caller's GL context is current (the `gl` borrow).
        unsafe {
            let mut scene: Box<sys::mjvScene> = Box::default();
            sys::mjv_defaultScene(scene.as_mut());
            sys::mjv_makeScene(model.raw_ptr(), scene.as_mut(), 4000);
            let mut context: Box<sys::mjrContext> = Box::default();
            sys::mjr_defaultContext(context.as_mut());
            sys::mjr_makeContext(
                model.raw_ptr(),
                context.as_mut(),
                sys::mjtFontScale::mjFONTSCALE_50 as i32,
            );
            sys::mjr_setBuffer(sys::mjtFramebuffer::mjFB_OFFSCREEN as i32, context.as_mut());
            if context.currentBuffer != sys::mjtFramebuffer::mjFB_OFFSCREEN as i32 {
                return Err(SimError::Egl(
                    "the OpenGL context has no offscreen framebuffer".into(),
                ));
            }
            let mut option = sys::mjvOption::default();
            sys::mjv_defaultOption(&mut option);
            let mut camera = sys::mjvCamera::default();
            sys::mjv_defaultCamera(&mut camera);
            camera.type_ = sys::mjtCamera::mjCAMERA_FIXED as i32;
            let mut perturb = sys::mjvPerturb::default();
            sys::mjv_defaultPerturb(&mut perturb);

            scene.flags[sys::mjtRndFlag::mjRND_SHADOW as usize] = flags.shadows as u8;
            scene.flags[sys::mjtRndFlag::mjRND_REFLECTION as usize] = flags.reflections as u8;
            scene.flags[sys::mjtRndFlag::mjRND_SKYBOX as usize] = flags.skybox as u8;
            scene.flags[sys::mjtRndFlag::mjRND_FOG as usize] = 0;
            scene.flags[sys::mjtRndFlag::mjRND_HAZE as usize] = 0;
            Ok(SceneRenderer {
                model,
                scene,
                context,
                option,
                camera,
                perturb,
                width,
                height,
                rgb_scratch: vec![0; (width * height * 3) as usize],
                flush: gl.gl_flush(),
                serialised: gl.is_software(),
            })
        }
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// This renderer's turn at OpenGL: [`GL_CALLS`] held on a software renderer, nothing
    /// on a GPU.
    fn gl_turn(&self) -> Option<MutexGuard<'static, ()>> {
        self.serialised.then(lock_gl_calls)
    }

    fn viewport(&self) -> sys::mjrRect {
        sys::mjrRect {
            left: 0,
            bottom: 0,
            width: self.width as i32,
            height: self.height as i32,
        }
    }

    fn draw(&mut self, data: &Data, camera: usize) {
        self.camera.fixedcamid = camera as i32;
        self.update_scene(data);
        self.render_scene();
    }

    fn update_scene(&mut self, data: &Data) {
        // SAFETY: every struct was initialised in `new`; model and data belong together
        // (checked by the caller through Arc identity).
        unsafe {
            sys::mjv_updateScene(
                self.model.raw_ptr(),
                data.raw_ptr() as *mut sys::mjData,
                &self.option,
                &self.perturb,
                &mut self.camera,
                sys::mjtCatBit::mjCAT_ALL as i32,
                self.scene.as_mut(),
            );
        }
    }

    fn render_scene(&mut self) {
        let viewport = self.viewport();
        // SAFETY: the scene was updated for this model; the GL context is current.
        unsafe {
            // Bind this renderer's own offscreen buffer: another renderer on the same GL
            // context (a second world's camera) may have bound its own since.
            sys::mjr_setBuffer(
                sys::mjtFramebuffer::mjFB_OFFSCREEN as i32,
                self.context.as_mut(),
            );
            sys::mjr_render(viewport, self.scene.as_mut(), self.context.as_ref());
        }
    }

    fn check_same_model(&self, data: &Data, camera: usize) -> Result<()> {
        if !Arc::ptr_eq(&self.model, data.model()) {
            return Err(SimError::InvalidArgument {
                what: "render",
                detail: "the data belongs to another model than the renderer".into(),
            });
        }
        if camera >= self.model.raw().ncam as usize {
            return Err(SimError::InvalidArgument {
                what: "camera",
                detail: format!("camera id {camera} out of range"),
            });
        }
        Ok(())
    }

    /// Renders `camera` into `rgb` (W*H*3) and the raw OpenGL depth buffer `depth` (W*H, in
    /// [0, 1]), both with OpenGL's bottom-to-top row order.
    pub fn render_raw(
        &mut self,
        data: &Data,
        camera: usize,
        rgb: &mut [u8],
        depth: &mut [f32],
    ) -> Result<()> {
        self.check_same_model(data, camera)?;
        let pixels = (self.width * self.height) as usize;
        if rgb.len() != 3 * pixels || depth.len() != pixels {
            return Err(SimError::InvalidArgument {
                what: "render buffers",
                detail: format!("need {} RGB bytes and {pixels} depths", 3 * pixels),
            });
        }
        let _turn = self.gl_turn();
        self.draw(data, camera);
        // SAFETY: buffer sizes were checked against the viewport above.
        unsafe {
            sys::mjr_readPixels(
                rgb.as_mut_ptr(),
                depth.as_mut_ptr(),
                self.viewport(),
                self.context.as_ref(),
            )
        };
        Ok(())
    }

    /// Renders the geom id seen at each pixel (bottom-to-top rows); -1 where nothing is.
    pub fn render_geom_ids(&mut self, data: &Data, camera: usize, ids: &mut [i32]) -> Result<()> {
        self.check_same_model(data, camera)?;
        let pixels = (self.width * self.height) as usize;
        if ids.len() != pixels {
            return Err(SimError::InvalidArgument {
                what: "render buffers",
                detail: format!("need {pixels} ids"),
            });
        }
        self.camera.fixedcamid = camera as i32;
        self.update_scene(data);
        self.start_segmentation();
        let (codes, geom_of_code) = self.read_segmentation();
        for (id, code) in ids.iter_mut().zip(codes) {
            *id = geom_of_code.get(code).copied().unwrap_or(-1);
        }
        Ok(())
    }

    /// Starts drawing the scene of the last render (the same camera, state and instant) with
    /// segmentation colours, flushed so the renderer draws it while the caller works on;
    /// [`SceneRenderer::read_segmentation`] reads it.
    pub fn start_segmentation(&mut self) {
        let _turn = self.gl_turn();
        let segment = sys::mjtRndFlag::mjRND_SEGMENT as usize;
        let idcolor = sys::mjtRndFlag::mjRND_IDCOLOR as usize;
        self.scene.flags[segment] = 1;
        self.scene.flags[idcolor] = 1;
        self.render_scene();
        self.scene.flags[segment] = 0;
        self.scene.flags[idcolor] = 0;
        if let Some(flush) = self.flush {
            // SAFETY: glFlush takes no arguments; the GL context this renderer draws with is
            // current on this thread.
            unsafe { flush() };
        }
    }

    /// Reads the segmentation [`SceneRenderer::start_segmentation`] drew: each pixel's code
    /// (bottom-to-top rows) and, indexed by code, the geom it shows (-1: nothing, or no geom).
    pub fn read_segmentation(&mut self) -> (impl Iterator<Item = usize> + '_, Vec<i32>) {
        let turn = self.gl_turn();
        // SAFETY: the scratch buffer holds W*H*3 bytes; no depth is requested.
        unsafe {
            sys::mjr_readPixels(
                self.rgb_scratch.as_mut_ptr(),
                std::ptr::null_mut(),
                self.viewport(),
                self.context.as_ref(),
            )
        };
        drop(turn);
        // The colour encodes 1 + the index into the scene's geom list.
        let geom_of_code: Vec<i32> = std::iter::once(-1)
            .chain(self.scene_geoms().iter().map(|g| {
                if g.objtype == sys::mjtObj::mjOBJ_GEOM as i32 {
                    g.objid
                } else {
                    -1
                }
            }))
            .collect();
        let codes = self
            .rgb_scratch
            .chunks_exact(3)
            .map(|px| usize::from(px[0]) | usize::from(px[1]) << 8 | usize::from(px[2]) << 16);
        (codes, geom_of_code)
    }

    fn scene_geoms(&self) -> &[sys::mjvGeom] {
        let n = self.scene.ngeom.max(0) as usize;
        if n == 0 || self.scene.geoms.is_null() {
            return &[];
        }
        // SAFETY: mjv_updateScene filled `ngeom` entries of the scene's geom array.
        unsafe { std::slice::from_raw_parts(self.scene.geoms, n) }
    }
}
