//! Evaluation on hidden views (DESIGN.md "Evaluation"): test poses sampled uniformly (seeded)
//! in the world's free space, MuJoCo's render as the ground truth, the map's render compared
//! with it. PSNR and SSIM on RGB, depth MAE and RMSE on pixels with ground truth, and coverage:
//! the share of surface points ray-cast (mj_ray) from the test cameras that have a Gaussian
//! mean within 5 cm. Everything runs on a scratch copy of the world's state, so an episode can
//! be evaluated while it runs and is not disturbed.

use crate::camera::RgbdCamera;
use crate::error::{Result, SimError};
use crate::mujoco::Data;
use crate::robot::Pose2;
use crate::world::World;
use autonomy::camera::PinholeCamera;
use autonomy::map::GaussianMap;
use autonomy::metrics::{psnr, ssim};
use autonomy::splat::Rasteriser;
use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use serde::Serialize;
use std::sync::Arc;

/// Geom groups the world's visible geoms use (the robot's are group 3).
pub const WORLD_GROUPS: u8 = 0b111;

/// Distance within which a Gaussian mean covers a surface point (DESIGN.md), metres.
pub const COVERAGE_RADIUS: f32 = 0.05;

/// Every how many pixels (in x and in y) a coverage ray is cast.
const COVERAGE_PIXEL_STRIDE: u32 = 8;

/// Scores of a map on hidden views.
#[derive(Debug, Clone, Serialize)]
pub struct Evaluation {
    /// Test views.
    pub views: usize,
    /// Mean PSNR, dB. NaN (null in metrics.json) when there was no test view, as for the
    /// other scores: no measurement is not a score of 0.
    pub psnr: f64,
    /// Mean SSIM (11x11 Gaussian window), in [-1, 1].
    pub ssim: f64,
    /// Mean absolute depth error on pixels with ground truth, metres.
    pub depth_mae: f64,
    /// Root mean square depth error on pixels with ground truth, metres.
    pub depth_rmse: f64,
    /// Share of the surface points seen from the test poses with a Gaussian mean within 5 cm.
    pub coverage: f64,
    /// Surface points the coverage is measured on.
    pub surface_points: usize,
}

/// Whether a robot at (x, y) stands in free space: rays in 16 directions at the wheels'
/// (0.1 m) and the camera's (0.35 m) heights all hit the world (so it is inside it) no nearer
/// than `clearance`.
pub fn free(world: &World, x: f64, y: f64, clearance: f64) -> bool {
    [0.1, 0.35].iter().all(|&z| {
        (0..16).all(|k| {
            let a = std::f64::consts::TAU * f64::from(k) / 16.0;
            let hit = world.data().ray(
                &Point3::new(x, y, z),
                &Vector3::new(a.cos(), a.sin(), 0.0),
                WORLD_GROUPS,
                Some(world.robot().body),
            );
            hit.is_some_and(|h| h.distance >= clearance)
        })
    })
}

/// Samples `count` poses uniformly (seeded) over `[lo, hi]` in x and y, keeping those in free
/// space with 0.4 m of clearance.
pub fn sample_test_poses(
    world: &World,
    lo: [f64; 2],
    hi: [f64; 2],
    count: usize,
    seed: u64,
) -> Vec<Pose2> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut poses = Vec::new();
    let mut tries = 0;
    while poses.len() < count && tries < 400 * count {
        tries += 1;
        let (x, y) = (rng.gen_range(lo[0]..hi[0]), rng.gen_range(lo[1]..hi[1]));
        if free(world, x, y, 0.4) {
            poses.push(Pose2 {
                x,
                y,
                theta: rng.gen_range(-std::f64::consts::PI..std::f64::consts::PI),
            });
        }
    }
    poses
}

/// The hidden test set of a world: poses and the surface points their cameras see.
#[derive(Debug, Clone)]
pub struct TestSet {
    /// Robot poses the map is rendered from.
    pub poses: Vec<Pose2>,
    /// Ground-truth surface points within the sensor's range of the test cameras.
    pub surface: Vec<[f32; 3]>,
}

impl TestSet {
    /// Samples `count` test poses (seeded) over the default +-15 m square and casts coverage
    /// rays from their cameras, every 8th pixel, up to `max_range`.
    pub fn sample(
        world: &World,
        camera: &RgbdCamera,
        count: usize,
        seed: u64,
        max_range: f64,
    ) -> Result<Self> {
        let poses = sample_test_poses(world, [-15.0, -15.0], [15.0, 15.0], count, seed);
        let mut data = scratch(world)?;
        let k = camera.intrinsics();
        let mut surface = Vec::new();
        for pose in &poses {
            world.robot().place(&mut data, *pose);
            let pose = camera.world_from_camera(&data);
            for v in (0..k.height).step_by(COVERAGE_PIXEL_STRIDE as usize) {
                for u in (0..k.width).step_by(COVERAGE_PIXEL_STRIDE as usize) {
                    let ray = k.ray(f64::from(u), f64::from(v));
                    let direction = pose.rotation * (ray / ray.norm());
                    let origin = Point3::from(pose.translation.vector);
                    let Some(hit) =
                        data.ray(&origin, &direction, WORLD_GROUPS, Some(world.robot().body))
                    else {
                        continue;
                    };
                    if hit.distance <= max_range {
                        let p = origin + direction * hit.distance;
                        surface.push([p.x as f32, p.y as f32, p.z as f32]);
                    }
                }
            }
        }
        Ok(TestSet { poses, surface })
    }
}

/// Test views the map's PSNR is followed on while an episode runs (a subsample of the test
/// set, spread over it): one splat render each per measurement.
pub const PSNR_OVER_TIME_VIEWS: usize = 10;

/// Ground-truth colour images of a few test views, rendered once before the episode, so the
/// map's PSNR over time costs only the map's renders.
pub struct TruthViews {
    views: Vec<(PinholeCamera, Vec<f32>)>,
}

impl TruthViews {
    /// Renders `count` of the test set's views, spread over it, with `camera` (a camera of
    /// its own, so the episode's sensor noise stream is not touched).
    pub fn capture(
        world: &World,
        camera: &mut RgbdCamera,
        tests: &TestSet,
        count: usize,
    ) -> Result<Self> {
        let mut data = scratch(world)?;
        let mut frame = camera.blank_frame();
        let stride = tests.poses.len().div_ceil(count.max(1)).max(1);
        let mut views = Vec::new();
        for pose in tests.poses.iter().step_by(stride).take(count) {
            world.robot().place(&mut data, *pose);
            camera.capture_rgbd_into(&data, &mut frame)?;
            let truth = frame.rgb.iter().map(|c| f32::from(*c) / 255.0).collect();
            views.push((frame.camera, truth));
        }
        Ok(TruthViews { views })
    }

    /// The map's mean PSNR on these views; `None` without views.
    pub fn psnr(&self, engine: &Rasteriser, map: &GaussianMap) -> Result<Option<f64>> {
        if self.views.is_empty() {
            return Ok(None);
        }
        let mut sum = 0.0;
        for (camera, truth) in &self.views {
            let rendered = engine
                .render(&map.gaussians, camera)
                .map_err(|e| SimError::Mapping(e.to_string()))?;
            sum += psnr(&rendered.images().colour, truth);
        }
        Ok(Some(sum / self.views.len() as f64))
    }
}

/// For each of the test set's surface points, whether the map has a Gaussian mean within
/// the coverage radius: where the map is missing, for comparing two maps point by point.
pub fn covered_surface(tests: &TestSet, map: &GaussianMap) -> Vec<bool> {
    autonomy::metrics::covered(&tests.surface, &map.gaussians.means, COVERAGE_RADIUS)
}

/// A fresh state of the world's model, for rendering and ray casting away from the episode.
fn scratch(world: &World) -> Result<Data> {
    let mut data = Data::new(Arc::clone(world.model()))?;
    data.forward();
    Ok(data)
}

/// Renders the ground truth at each test pose (on a scratch state: the world is untouched)
/// and the map from the same camera, and scores the map.
/// Stops between views when `stopped` says so (a signal): then nothing is scored, as with no
/// test view.
pub fn evaluate(
    world: &World,
    camera: &mut RgbdCamera,
    engine: &Rasteriser,
    map: &GaussianMap,
    tests: &TestSet,
    stopped: &dyn Fn() -> bool,
) -> Result<Evaluation> {
    let mut data = scratch(world)?;
    let mut frame = camera.blank_frame();
    let (w, h) = (
        camera.intrinsics().width as usize,
        camera.intrinsics().height as usize,
    );
    let (mut psnr_sum, mut ssim_sum) = (0.0, 0.0);
    let (mut abs_sum, mut sq_sum, mut pixels) = (0.0, 0.0, 0usize);
    for pose in &tests.poses {
        if stopped() {
            return Ok(Evaluation::none());
        }
        world.robot().place(&mut data, *pose);
        camera.capture_rgbd_into(&data, &mut frame)?;
        let rendered = engine
            .render(&map.gaussians, &frame.camera)
            .map_err(|e| SimError::Mapping(e.to_string()))?;
        let truth: Vec<f32> = frame.rgb.iter().map(|c| f32::from(*c) / 255.0).collect();
        let images = rendered.images();
        psnr_sum += psnr(&images.colour, &truth);
        ssim_sum += ssim(&images.colour, &truth, w, h);
        for (r, t) in images.depth.iter().zip(&frame.depth) {
            if *t > 0.0 {
                let e = f64::from(r - t);
                abs_sum += e.abs();
                sq_sum += e * e;
                pixels += 1;
            }
        }
    }
    // Means of nothing are NaN, which metrics.json writes as null.
    let n = tests.poses.len() as f64;
    let p = pixels as f64;
    let coverage = if tests.surface.is_empty() || stopped() {
        f64::NAN
    } else {
        autonomy::metrics::coverage(&tests.surface, &map.gaussians.means, COVERAGE_RADIUS)
    };
    Ok(Evaluation {
        views: tests.poses.len(),
        psnr: psnr_sum / n,
        ssim: ssim_sum / n,
        depth_mae: abs_sum / p,
        depth_rmse: (sq_sum / p).sqrt(),
        coverage,
        surface_points: tests.surface.len(),
    })
}

impl Evaluation {
    /// No score at all: no view rendered, no surface point checked.
    pub fn none() -> Self {
        Evaluation {
            views: 0,
            psnr: f64::NAN,
            ssim: f64::NAN,
            depth_mae: f64::NAN,
            depth_rmse: f64::NAN,
            coverage: f64::NAN,
            surface_points: 0,
        }
    }
}
