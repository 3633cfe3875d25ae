//! Evaluation on hidden views (DESIGN.md "Evaluation"): test poses sampled uniformly (seeded)
//! in the world's free space, MuJoCo's render as the ground truth, the map's render compared
//! with it. PSNR on RGB, depth MAE and RMSE on pixels with ground truth.

use crate::camera::RgbdCamera;
use crate::error::Result;
use crate::robot::Pose2;
use crate::world::World;
use autonomy::map::GaussianMap;
use autonomy::metrics::psnr;
use autonomy::splat::Rasteriser;
use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use serde::Serialize;

/// Geom groups the world's visible geoms use (the robot's are group 3).
const WORLD_GROUPS: u8 = 0b111;

/// Scores of a map on hidden views.
#[derive(Debug, Clone, Serialize)]
pub struct Evaluation {
    /// Test views.
    pub views: usize,
    /// Mean PSNR, dB.
    pub psnr: f64,
    /// Mean absolute depth error on pixels with ground truth, metres.
    pub depth_mae: f64,
    /// Root mean square depth error on pixels with ground truth, metres.
    pub depth_rmse: f64,
}

/// Whether a robot at (x, y) stands in free space: rays in 16 directions at 0.25 m all hit the
/// world (so it is inside it) no nearer than `clearance`.
fn free(world: &World, x: f64, y: f64, clearance: f64) -> bool {
    (0..16).all(|k| {
        let a = std::f64::consts::TAU * f64::from(k) / 16.0;
        let hit = world.data().ray(
            &Point3::new(x, y, 0.25),
            &Vector3::new(a.cos(), a.sin(), 0.0),
            WORLD_GROUPS,
            Some(world.robot().body),
        );
        hit.is_some_and(|h| h.distance >= clearance)
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

/// Renders the ground truth at each pose (the robot is placed there) and the map from the same
/// camera; the world's state is changed.
pub fn evaluate(
    world: &mut World,
    camera: &mut RgbdCamera,
    engine: &Rasteriser,
    map: &GaussianMap,
    poses: &[Pose2],
) -> Result<Evaluation> {
    let mut frame = camera.blank_frame();
    let (mut psnr_sum, mut abs_sum, mut sq_sum, mut pixels) = (0.0, 0.0, 0.0, 0usize);
    for pose in poses {
        let robot = world.robot().clone();
        robot.place(world.data_mut(), *pose);
        world.data_mut().forward();
        camera.capture_into(world.data(), &mut frame)?;
        let rendered = engine
            .render(&map.gaussians, &frame.camera)
            .map_err(|e| crate::error::SimError::Mapping(e.to_string()))?;
        let truth: Vec<f32> = frame.rgb.iter().map(|c| f32::from(*c) / 255.0).collect();
        psnr_sum += psnr(&rendered.images().colour, &truth);
        for (r, t) in rendered.images().depth.iter().zip(&frame.depth) {
            if *t > 0.0 {
                let e = f64::from(r - t);
                abs_sum += e.abs();
                sq_sum += e * e;
                pixels += 1;
            }
        }
    }
    let n = poses.len().max(1) as f64;
    let p = pixels.max(1) as f64;
    Ok(Evaluation {
        views: poses.len(),
        psnr: psnr_sum / n,
        depth_mae: abs_sum / p,
        depth_rmse: (sq_sum / p).sqrt(),
    })
}
