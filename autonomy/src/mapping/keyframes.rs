//! Keyframes: frames kept to optimise against later, and how much of a new frame each sees
//! (SplaTAM's overlap: back-project a grid of the new frame's pixels and count the ones that
//! land inside a keyframe's image at a consistent depth).

use super::Frame;
use crate::camera::PinholeCamera;
use crate::math::Point3;

/// A frame kept for later mapping iterations.
#[derive(Debug, Clone)]
pub struct Keyframe {
    /// Colour and depth.
    pub frame: Frame,
    /// Where it was taken.
    pub camera: PinholeCamera,
}

/// Pixels between overlap samples, each way.
const SAMPLE_STRIDE: usize = 8;

/// World points of a grid of the frame's measured pixels.
pub fn sample_points(frame: &Frame, camera: &PinholeCamera) -> Vec<Point3> {
    let k = camera.intrinsics;
    let (w, h) = (k.width as usize, k.height as usize);
    let mut points = Vec::new();
    for v in (SAMPLE_STRIDE / 2..h).step_by(SAMPLE_STRIDE) {
        for u in (SAMPLE_STRIDE / 2..w).step_by(SAMPLE_STRIDE) {
            let d = frame.depth[v * w + u];
            if d > 0.0 {
                points.push(camera.back_project_to_world(u as f64, v as f64, f64::from(d)));
            }
        }
    }
    points
}

/// Fraction of `points` that `keyframe` sees: inside its image, in front, and not hidden
/// behind what it measured (10% depth tolerance).
pub fn overlap(points: &[Point3], keyframe: &Keyframe) -> f64 {
    if points.is_empty() {
        return 0.0;
    }
    let k = keyframe.camera.intrinsics;
    let camera_from_world = keyframe.camera.world_from_camera.inverse();
    let (w, h) = (k.width as usize, k.height as usize);
    let seen = points
        .iter()
        .filter(|p| {
            let Some((u, v, z)) = k.project(&(camera_from_world * **p)) else {
                return false;
            };
            let (ui, vi) = (u.round(), v.round());
            if ui < 0.0 || vi < 0.0 || ui >= w as f64 || vi >= h as f64 {
                return false;
            }
            let measured = f64::from(keyframe.frame.depth[vi as usize * w + ui as usize]);
            measured == 0.0 || z <= measured * 1.1
        })
        .count();
    seen as f64 / points.len() as f64
}
