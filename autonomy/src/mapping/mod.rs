//! The online mapper (SplaTAM's mapping with RT-GuIDE's uncertainty, DESIGN.md "Gaussian
//! map"): each mapping step takes a posed RGB-D frame, grows the map where it is missing,
//! runs N Adam iterations over the frame and the keyframes that overlap it most, prunes, and
//! sets the uncertainty of every Gaussian the step moved to how far it moved.

mod densify;
mod keyframes;

pub use densify::DensifyConfig;
pub use keyframes::Keyframe;

use crate::adam::{Adam, LearningRates};
use crate::camera::{Intrinsics, PinholeCamera};
use crate::gaussians::sigmoid;
use crate::loss::{mapping_loss_in, LossWorkspace, Target};
use crate::map::GaussianMap;
use crate::math::{Isometry3, Matrix3, Matrix4, Rotation3, Translation3, UnitQuaternion};
use crate::splat::gpu::{GpuRasteriser, ResidentMap};
use crate::splat::{ImageGradients, Rasteriser, RenderError};
use std::time::Instant;
use thiserror::Error;

/// Learning rates of [`Mapper::refine`] as a share of the mapping rates: 3DGS decays its
/// position rate 100x over training; steps without a new frame are late training.
pub const REFINE_RATE_SCALE: f32 = 0.1;

/// One RGB-D image: RGB in [0, 1] (3 per pixel, rows top to bottom) and planar depth in metres
/// (0: no measurement).
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Interleaved RGB.
    pub colour: Vec<f32>,
    /// Planar depth.
    pub depth: Vec<f32>,
}

impl Frame {
    /// A frame from 8-bit RGB.
    pub fn from_rgb8(rgb: &[u8], depth: Vec<f32>) -> Self {
        Frame {
            colour: rgb.iter().map(|c| f32::from(*c) / 255.0).collect(),
            depth,
        }
    }
}

/// Settings of the mapper.
#[derive(Debug, Clone, PartialEq)]
pub struct MapperConfig {
    /// Adam iterations per mapping step (10 in real-time runs, 50 for viewpoint selection).
    pub iterations: usize,
    /// Keyframes (besides the current frame) optimised in each step: those overlapping the
    /// current frame most.
    pub window: usize,
    /// A frame becomes a keyframe only if no keyframe already sees this fraction of it, so the
    /// keyframe set grows with the explored area, not with time.
    pub keyframe_overlap: f64,
    /// Hard cap on keyframes (memory); past it no more are kept.
    pub max_keyframes: usize,
    /// Densification thresholds.
    pub densify: DensifyConfig,
    /// Pruning: Gaussians fainter than this go.
    pub prune_opacity: f32,
    /// Pruning: Gaussians wider than this fraction of the scene radius go.
    pub prune_radius_fraction: f32,
    /// Adam's learning rates.
    pub rates: LearningRates,
    /// How a Gaussian's displacement becomes its uncertainty.
    pub uncertainty: UncertaintyNorm,
}

/// RT-GuIDE's uncertainty of a Gaussian from its displacement d in one mapping step: the
/// L2 norm (the paper's choice), or its square (RTGuIDE-sq, eq 7 as derived; Table II).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum UncertaintyNorm {
    /// |d|.
    #[default]
    L2,
    /// |d|^2.
    Sq,
}

impl UncertaintyNorm {
    /// The uncertainty of a displacement of squared length `squared`.
    pub fn of_squared(self, squared: f32) -> f32 {
        match self {
            UncertaintyNorm::L2 => squared.sqrt(),
            UncertaintyNorm::Sq => squared,
        }
    }
}

impl Default for MapperConfig {
    fn default() -> Self {
        MapperConfig {
            iterations: 10,
            window: 4,
            keyframe_overlap: 0.8,
            max_keyframes: 400,
            densify: DensifyConfig::default(),
            prune_opacity: 0.005,
            prune_radius_fraction: 0.1,
            rates: LearningRates::default(),
            uncertainty: UncertaintyNorm::L2,
        }
    }
}

/// Why a frame was refused; the map is unchanged when one comes back.
#[derive(Debug, Error, PartialEq)]
pub enum MapError {
    /// Image sizes disagree with the intrinsics.
    #[error("frame has {colour} colour values and {depth} depths; {width}x{height} intrinsics need {} and {}", 3 * width * height, width * height)]
    Size {
        /// Colour values given.
        colour: usize,
        /// Depths given.
        depth: usize,
        /// Width from the intrinsics.
        width: usize,
        /// Height from the intrinsics.
        height: usize,
    },
    /// A depth or colour is NaN, infinite, or a depth is negative.
    #[error("frame refused: {0}")]
    BadValues(String),
    /// No pixel has a depth measurement.
    #[error("frame refused: every depth is 0 (no measurement); nothing to map")]
    NoDepth,
    /// The pose is not a rigid transform.
    #[error("pose refused: {0}")]
    BadPose(String),
    /// The renderer failed.
    #[error(transparent)]
    Render(#[from] RenderError),
}

/// What one mapping step did, for logs and benchmarks.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepReport {
    /// Gaussians added.
    pub added: usize,
    /// Gaussians pruned.
    pub pruned: usize,
    /// Gaussians after the step.
    pub gaussians: usize,
    /// Keyframes optimised besides the current frame.
    pub window: usize,
    /// Whether the frame became a keyframe.
    pub keyframe: bool,
    /// Loss on the first and the last iteration.
    pub loss: (f32, f32),
    /// Wall seconds: densify, optimise, prune + uncertainty.
    pub seconds: [f64; 3],
}

/// Checks that `m` is a rigid transform (orthonormal rotation with det +1, last row 0 0 0 1)
/// and returns it as an isometry.
pub fn pose_from_matrix(m: &Matrix4) -> Result<Isometry3, MapError> {
    if m.iter().any(|v| !v.is_finite()) {
        return Err(MapError::BadPose("it contains NaN or infinity".into()));
    }
    let last = m.row(3);
    if (last - nalgebra::RowVector4::new(0.0, 0.0, 0.0, 1.0)).norm() > 1e-9 {
        return Err(MapError::BadPose(format!(
            "its last row is {last} instead of 0 0 0 1"
        )));
    }
    let r: Matrix3 = m.fixed_view::<3, 3>(0, 0).into_owned();
    let orthogonality = (r.transpose() * r - Matrix3::identity()).norm();
    if orthogonality > 1e-5 || r.determinant() < 0.0 {
        return Err(MapError::BadPose(format!(
            "its 3x3 block is not a rotation (|R^T R - I| = {orthogonality:.2e}, det = {:.3})",
            r.determinant()
        )));
    }
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    Ok(Isometry3::from_parts(
        Translation3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]),
        rotation,
    ))
}

fn validate_frame(frame: &Frame, k: &Intrinsics) -> Result<(), MapError> {
    let (w, h) = (k.width as usize, k.height as usize);
    if frame.colour.len() != 3 * w * h || frame.depth.len() != w * h {
        return Err(MapError::Size {
            colour: frame.colour.len(),
            depth: frame.depth.len(),
            width: w,
            height: h,
        });
    }
    if let Some(p) = frame.depth.iter().position(|d| !d.is_finite() || *d < 0.0) {
        return Err(MapError::BadValues(format!(
            "depth at pixel {p} is {}",
            frame.depth[p]
        )));
    }
    if let Some(p) = frame.colour.iter().position(|c| !c.is_finite()) {
        return Err(MapError::BadValues(format!(
            "colour value {p} is {}",
            frame.colour[p]
        )));
    }
    if frame.depth.iter().all(|d| *d == 0.0) {
        return Err(MapError::NoDepth);
    }
    Ok(())
}

/// The online mapper: the map, its keyframes and the engine that renders it.
#[derive(Debug)]
pub struct Mapper {
    config: MapperConfig,
    map: GaussianMap,
    keyframes: Vec<Keyframe>,
    engine: std::sync::Arc<Rasteriser>,
    /// Adam's moments persist across steps (grown on densify, filtered on prune): a Gaussian
    /// that has settled takes small steps, a new one full steps, which is what makes the
    /// displacement a measure of uncertainty. With the GPU engine the moments live in the
    /// resident map (this copy keeps only the rates and stays empty).
    adam: Adam,
    /// SplaTAM's scene radius: the largest measured depth so far / 3.
    scene_radius: f32,
    steps: usize,
    /// The keyframe the next [`Mapper::refine`] iteration starts from (they take turns).
    refine_next: usize,
    /// With the GPU engine: the map's resident copy and the views uploaded to it.
    resident: Option<ResidentViews>,
    /// The CPU engine's loss scratch and image gradients, reused by every iteration.
    loss_workspace: LossWorkspace,
    image_grads: ImageGradients,
}

/// The GPU engine's resident map and which of its views hold what: the current frame's slot
/// (reused every step until the frame becomes a keyframe) and each keyframe's view.
#[derive(Debug)]
struct ResidentViews {
    map: ResidentMap,
    current: Option<usize>,
    keyframes: Vec<usize>,
}

impl Mapper {
    /// An empty map.
    pub fn new(config: MapperConfig, engine: Rasteriser) -> Self {
        let config_rates = config.rates;
        Mapper {
            config,
            map: GaussianMap::default(),
            keyframes: Vec::new(),
            engine: std::sync::Arc::new(engine),
            adam: Adam::new(config_rates),
            scene_radius: 0.0,
            steps: 0,
            refine_next: 0,
            resident: None,
            loss_workspace: LossWorkspace::default(),
            image_grads: ImageGradients::zeros(0),
        }
    }

    /// The map.
    pub fn map(&self) -> &GaussianMap {
        &self.map
    }

    /// The engine in use.
    pub fn engine(&self) -> &Rasteriser {
        &self.engine
    }

    /// The engine, shared: a caller renders the map with the episode's engine (one GPU
    /// device, not two) while the mapper keeps using it.
    pub fn shared_engine(&self) -> std::sync::Arc<Rasteriser> {
        self.engine.clone()
    }

    /// Keyframes kept so far.
    pub fn keyframe_count(&self) -> usize {
        self.keyframes.len()
    }

    /// Mapping steps done.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// One mapping step with `frame` taken at `world_from_camera` (optical frame) with
    /// `intrinsics`. Refused frames leave the map unchanged.
    pub fn integrate(
        &mut self,
        frame: &Frame,
        world_from_camera: &Matrix4,
        intrinsics: &Intrinsics,
    ) -> Result<StepReport, MapError> {
        let result = self.integrate_step(frame, world_from_camera, intrinsics);
        self.forget_resident_after(&result);
        result
    }

    /// A renderer's failure may leave the GPU's copy out of step with the host's map; the
    /// next step uploads it whole again.
    fn forget_resident_after(&mut self, result: &Result<StepReport, MapError>) {
        if let Err(MapError::Render(e)) = result {
            tracing::debug!(%e, "mapping step failed; the resident map will be reloaded");
            self.resident = None;
        }
    }

    fn integrate_step(
        &mut self,
        frame: &Frame,
        world_from_camera: &Matrix4,
        intrinsics: &Intrinsics,
    ) -> Result<StepReport, MapError> {
        let pose = pose_from_matrix(world_from_camera)?;
        validate_frame(frame, intrinsics)?;
        let camera = PinholeCamera {
            intrinsics: *intrinsics,
            world_from_camera: pose,
        };
        crate::splat::validate_camera(&camera)?;
        let mut report = StepReport::default();
        let max_depth = frame.depth.iter().fold(0.0f32, |m, d| m.max(*d));
        self.scene_radius = self.scene_radius.max(max_depth / 3.0);

        let t0 = Instant::now();
        report.added = self.grow(frame, &camera)?;
        let (window, best_overlap) = self.choose_keyframes(frame, &camera);
        report.window = window.len();

        // Optimise: the current frame on two iterations of every three, the window's keyframes
        // in turn on the third. The newest frame carries the new information; the keyframes
        // keep the rest of the map from drifting toward it.
        let t1 = Instant::now();
        let before = self.map.gaussians.means.clone();
        let mut touched = vec![false; self.map.len()];
        self.resize_host_adam();
        let views: Vec<Option<usize>> = (0..self.config.iterations)
            .map(|iteration| {
                (iteration % 3 == 2 && !window.is_empty())
                    .then(|| window[(iteration / 3) % window.len()])
            })
            .collect();
        report.loss = match self.optimise_resident(&views, &mut touched)? {
            Some(loss) => loss,
            None => self.optimise(frame, &camera, &views, &mut touched)?,
        };

        let t2 = Instant::now();
        self.update_uncertainty(&before, &touched);
        report.pruned = self.prune()?;
        report.keyframe = self.keep_keyframe(frame, camera, best_overlap);
        self.steps += 1;
        report.gaussians = self.map.len();
        report.seconds = [
            (t1 - t0).as_secs_f64(),
            (t2 - t1).as_secs_f64(),
            t2.elapsed().as_secs_f64(),
        ];
        tracing::debug!(?report, "mapping step");
        Ok(report)
    }

    /// A mapping step without a new frame, for when the camera brings nothing new (the
    /// robot idle after its planner is done): every iteration on a keyframe, all of them in
    /// turn across steps, so the time improves the whole map instead of fitting one view
    /// seen over and over (which lowers the PSNR of every other view). No growth; the
    /// uncertainty and pruning as in [`Mapper::integrate`]. A step without keyframes does
    /// nothing but count.
    pub fn refine(&mut self) -> Result<StepReport, MapError> {
        let result = self.refine_step();
        self.forget_resident_after(&result);
        result
    }

    fn refine_step(&mut self) -> Result<StepReport, MapError> {
        let mut report = StepReport::default();
        self.steps += 1;
        report.gaussians = self.map.len();
        if self.keyframes.is_empty() || self.config.iterations == 0 {
            return Ok(report);
        }
        let t1 = Instant::now();
        let count = self.keyframes.len();
        let views: Vec<Option<usize>> = (0..self.config.iterations)
            .map(|k| Some((self.refine_next + k) % count))
            .collect();
        self.refine_next = (self.refine_next + self.config.iterations) % count;
        let before = self.map.gaussians.means.clone();
        let mut touched = vec![false; self.map.len()];
        self.resize_host_adam();
        report.window = count.min(views.len());
        // No new information: late-training rates, so the map settles instead of moving on
        // (at the mapping rates, hundreds of such iterations lowered every held-out view's
        // PSNR: BENCHMARKS.md, "A fair comparison").
        self.adam.rates = self.config.rates.scaled(REFINE_RATE_SCALE);
        let outcome = match self.optimise_resident(&views, &mut touched) {
            Ok(Some(loss)) => Ok(loss),
            // Every view is a keyframe: the "current frame" the CPU path takes is never used.
            Ok(None) => {
                let first = self.keyframes[0].clone();
                self.optimise(&first.frame, &first.camera, &views, &mut touched)
            }
            Err(e) => Err(e),
        };
        self.adam.rates = self.config.rates;
        report.loss = outcome?;
        let t2 = Instant::now();
        self.update_uncertainty(&before, &touched);
        report.pruned = self.prune()?;
        report.gaussians = self.map.len();
        report.seconds = [0.0, (t2 - t1).as_secs_f64(), t2.elapsed().as_secs_f64()];
        tracing::debug!(?report, "refining step");
        Ok(report)
    }

    /// Grows the map where the frame shows what it is missing; the count added. With the GPU
    /// engine the frame becomes the resident map's current view, the map is rendered there
    /// without being uploaded, and only the new Gaussians go up.
    fn grow(&mut self, frame: &Frame, camera: &PinholeCamera) -> Result<usize, MapError> {
        let engine = self.engine.clone();
        let added = if let Some(gpu) = engine.gpu() {
            let state = resident_views(
                &mut self.resident,
                gpu,
                &self.map,
                &self.adam,
                &self.keyframes,
            )?;
            let view = match state.current {
                Some(slot) => {
                    state
                        .map
                        .replace_view(gpu, slot, camera, &frame.colour, &frame.depth)?;
                    slot
                }
                None => {
                    let slot = state
                        .map
                        .add_view(gpu, camera, &frame.colour, &frame.depth)?;
                    state.current = Some(slot);
                    slot
                }
            };
            let rendered = if state.map.is_empty() {
                None
            } else {
                Some(state.map.render(gpu, view)?)
            };
            let added = densify::densify(
                &mut self.map.gaussians,
                frame,
                camera,
                rendered.as_ref(),
                &self.config.densify,
            );
            state.map.append(gpu, &self.map.gaussians)?;
            added
        } else {
            let rendered = if self.map.is_empty() {
                None
            } else {
                Some(engine.render(&self.map.gaussians, camera)?)
            };
            densify::densify(
                &mut self.map.gaussians,
                frame,
                camera,
                rendered.as_ref().map(|r| r.images()),
                &self.config.densify,
            )
        };
        self.map.adopt_new_gaussians();

        Ok(added)
    }

    /// The keyframes of the window (those that see most of the frame, at most `window`),
    /// and the best overlap of any keyframe with the frame.
    fn choose_keyframes(&self, frame: &Frame, camera: &PinholeCamera) -> (Vec<usize>, f64) {
        let points = keyframes::sample_points(frame, camera);
        let mut ranked: Vec<(f64, usize)> = self
            .keyframes
            .iter()
            .enumerate()
            .map(|(i, kf)| (keyframes::overlap(&points, kf), i))
            .filter(|(o, _)| *o > 0.0)
            .collect();
        ranked.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let best_overlap = ranked.first().map_or(0.0, |r| r.0);
        ranked.truncate(self.config.window);

        (ranked.into_iter().map(|(_, i)| i).collect(), best_overlap)
    }

    /// The step's iterations on the GPU, resident: nothing uploaded, the map read back once;
    /// the first and last iterations' losses, or `None` (nothing done) with the CPU engine.
    fn optimise_resident(
        &mut self,
        views: &[Option<usize>],
        touched: &mut [bool],
    ) -> Result<Option<(f32, f32)>, MapError> {
        let engine = self.engine.clone();
        let Some(gpu) = engine.gpu() else {
            return Ok(None);
        };
        let rates = self.adam.rates;
        let state = resident_views(
            &mut self.resident,
            gpu,
            &self.map,
            &self.adam,
            &self.keyframes,
        )?;
        let mut loss = (0.0, 0.0);
        state.map.set_rates(gpu, rates);
        state.map.begin_step(gpu);
        for (iteration, keyframe) in views.iter().enumerate() {
            let view = match keyframe {
                Some(k) => state.keyframes[*k],
                None => state.current.ok_or_else(|| {
                    MapError::Render(crate::splat::RenderError::Gpu(
                        "no current frame was uploaded for this mapping step".into(),
                    ))
                })?,
            };
            let terms = state.map.iterate(gpu, view)?;
            if iteration == 0 {
                loss.0 = terms.total();
            }
            loss.1 = terms.total();
        }
        state.map.store_map(gpu, &mut self.map.gaussians, touched)?;
        Ok(Some(loss))
    }

    /// The step's iterations on the CPU engine: render, loss, backward, Adam; the first and
    /// last iterations' losses.
    fn optimise(
        &mut self,
        frame: &Frame,
        camera: &PinholeCamera,
        views: &[Option<usize>],
        touched: &mut [bool],
    ) -> Result<(f32, f32), MapError> {
        let mut loss = (0.0, 0.0);
        for (iteration, keyframe) in views.iter().enumerate() {
            let (view_frame, view_camera) = match keyframe {
                Some(k) => (&self.keyframes[*k].frame, &self.keyframes[*k].camera),
                None => (frame, camera),
            };
            let render = self.engine.render(&self.map.gaussians, view_camera)?;
            let terms = mapping_loss_in(
                render.images(),
                Target {
                    colour: &view_frame.colour,
                    depth: &view_frame.depth,
                },
                &mut self.loss_workspace,
                &mut self.image_grads,
            );
            if iteration == 0 {
                loss.0 = terms.total();
            }
            loss.1 = terms.total();
            let grads = self.engine.backward(&render, &self.image_grads)?;
            for &i in &grads.touched {
                touched[i as usize] = true;
            }
            self.adam.step(&mut self.map.gaussians, &grads);
        }
        Ok(loss)
    }

    /// Sizes the host's Adam state to the map; with the GPU engine the state lives on the GPU
    /// and the host's stays empty (a reload starts its moments at zero).
    fn resize_host_adam(&mut self) {
        if !self.engine.is_gpu() {
            self.adam.resize(self.map.len());
        }
    }

    /// Uncertainty: how far this step moved each Gaussian it touched.
    fn update_uncertainty(&mut self, before: &[[f32; 3]], touched: &[bool]) {
        for (i, moved) in touched.iter().enumerate() {
            if *moved {
                let (a, b) = (before[i], self.map.gaussians.means[i]);
                let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
                self.map.uncertainty[i] = self
                    .config
                    .uncertainty
                    .of_squared(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            }
        }
    }

    /// Drops Gaussians too transparent or too wide (on the GPU too, compacted there); the
    /// count pruned.
    fn prune(&mut self) -> Result<usize, MapError> {
        let max_radius = self.config.prune_radius_fraction * self.scene_radius;
        let g = &self.map.gaussians;
        let keep: Vec<bool> = (0..g.len())
            .map(|i| {
                sigmoid(g.logit_opacities[i]) >= self.config.prune_opacity
                    && g.log_radii[i].exp() <= max_radius
            })
            .collect();
        let pruned = keep.iter().filter(|k| !**k).count();
        if pruned > 0 {
            self.map.retain(&keep);
            let engine = self.engine.clone();
            match (engine.gpu(), self.resident.as_mut()) {
                (Some(gpu), Some(state)) => state.map.retain(gpu, &keep)?,
                _ => self.adam.retain(&keep),
            }
        }

        Ok(pruned)
    }

    /// Keeps the frame if no keyframe already covers it (and there is room); whether it did.
    fn keep_keyframe(&mut self, frame: &Frame, camera: PinholeCamera, best_overlap: f64) -> bool {
        let room = self.keyframes.len() < self.config.max_keyframes;
        if !(best_overlap < self.config.keyframe_overlap && room) {
            return false;
        }
        self.keyframes.push(Keyframe {
            frame: frame.clone(),
            camera,
        });
        // The current frame's view becomes the keyframe's; the next frame takes a new one.
        if let Some(state) = &mut self.resident {
            if let Some(slot) = state.current.take() {
                state.keyframes.push(slot);
            }
        }
        true
    }

    /// Replaces the map (e.g. one read from a PLY); keyframes are dropped.
    pub fn set_map(&mut self, map: GaussianMap) {
        self.map = map;
        self.keyframes.clear();
        self.resident = None;
        self.adam = Adam::new(self.config.rates);
    }
}

/// The GPU engine's resident map, made on first use (or after a failed step dropped it): the
/// host's map, Adam's state and the keyframes uploaded once. It borrows only the fields it
/// reads, so the caller may change the host's map while holding it.
fn resident_views<'a>(
    resident: &'a mut Option<ResidentViews>,
    gpu: &GpuRasteriser,
    map: &GaussianMap,
    adam: &Adam,
    keyframes: &[Keyframe],
) -> Result<&'a mut ResidentViews, MapError> {
    if let Some(state) = resident {
        return Ok(state);
    }
    let mut resident_map = ResidentMap::new(gpu, adam.rates);
    resident_map.load(gpu, &map.gaussians, adam.state())?;
    let mut views = Vec::with_capacity(keyframes.len());
    for kf in keyframes {
        views.push(resident_map.add_view(gpu, &kf.camera, &kf.frame.colour, &kf.frame.depth)?);
    }
    Ok(resident.insert(ResidentViews {
        map: resident_map,
        current: None,
        keyframes: views,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::splat::gpu::{AdapterPolicy, GpuError};
    use crate::synthetic::{look_at, BoxScene};

    /// With the GPU engine the map lives on the GPU between steps, grown by appending and
    /// pruned by compacting there: after every step the GPU's copy is the host's map, bit for
    /// bit, in the same order. A high opacity threshold makes every step prune.
    #[test]
    fn the_resident_map_is_the_hosts_map_after_growth_and_pruning() {
        let gpu = match GpuRasteriser::new(AdapterPolicy::AllowSoftware, None) {
            Ok(g) => g,
            Err(GpuError::NoAdapter(reason)) => {
                eprintln!("SKIPPED: no wgpu adapter at all: {reason}");
                return;
            }
            Err(e) => panic!("an adapter exists but the engine failed: {e}"),
        };
        let config = MapperConfig {
            prune_opacity: 0.3,
            iterations: 6,
            ..MapperConfig::default()
        };
        let mut mapper = Mapper::new(config, Rasteriser::Gpu(Box::new(gpu)));
        let scene = BoxScene::room();
        let intrinsics = Intrinsics::from_fovy(60f64.to_radians(), 96, 72);
        let mut pruned = 0;
        for i in 0..4 {
            let a = 0.4 * i as f64;
            let camera = look_at(
                [0.2 * a.cos(), 0.2 * a.sin(), 1.2],
                [3.0 * a.cos(), 3.0 * a.sin(), 1.0],
                intrinsics,
            );
            let truth = scene.render(&camera);
            let frame = Frame {
                colour: truth.colour,
                depth: truth.depth,
            };
            let report = mapper
                .integrate(
                    &frame,
                    &camera.world_from_camera.to_homogeneous(),
                    &intrinsics,
                )
                .expect("mapping step");
            pruned += report.pruned;
            let engine = mapper.engine.clone();
            let (Some(gpu), Some(state)) = (engine.gpu(), mapper.resident.as_ref()) else {
                panic!("the GPU engine keeps a resident map");
            };
            let mut resident = mapper.map.gaussians.clone();
            let mut touched = vec![false; resident.len()];
            state
                .map
                .store_map(gpu, &mut resident, &mut touched)
                .expect("read the resident map");
            let host = &mapper.map.gaussians;
            let differs = (0..host.len()).find(|&k| {
                resident.means[k] != host.means[k]
                    || resident.log_radii[k] != host.log_radii[k]
                    || resident.logit_opacities[k] != host.logit_opacities[k]
                    || resident.colours[k] != host.colours[k]
            });
            assert_eq!(
                differs, None,
                "step {i}: the resident map differs from the host's at this Gaussian"
            );
        }
        assert!(pruned > 0, "the steps should prune");
    }
}
