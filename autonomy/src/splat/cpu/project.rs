//! Projection of Gaussians into the image (DESIGN.md: d = e3^T R^T (mu - T),
//! mu2D = K R^T (mu - T) / d, r2D = f r / d), culling, and the chain rule back to the
//! parameters.

use super::super::{MIN_ALPHA, NEAR_PLANE};
use crate::camera::PinholeCamera;
use crate::gaussians::{sigmoid, Gaussians, Gradients};
use rayon::prelude::*;

/// A Gaussian as the rasteriser sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Splat {
    /// Index into [`Gaussians`].
    pub index: u32,
    /// Pixel x of the centre.
    pub u: f32,
    /// Pixel y of the centre.
    pub v: f32,
    /// Radius in pixels.
    pub radius: f32,
    /// 1 / radius^2.
    pub inv_radius2: f32,
    /// Opacity in (0, 1).
    pub opacity: f32,
    /// RGB.
    pub colour: [f32; 3],
    /// Optical-z depth, metres.
    pub depth: f32,
    /// Half-width in pixels of the square outside which alpha < 1/255.
    pub extent: f32,
    /// Centre in the camera frame (for the chain rule).
    pub camera_point: [f32; 3],
}

/// Projects and culls: behind the near plane, too faint to ever reach 1/255, or off screen.
pub fn project(gaussians: &Gaussians, camera: &PinholeCamera) -> Vec<Splat> {
    let k = camera.intrinsics;
    let camera_from_world = camera
        .world_from_camera
        .inverse()
        .to_homogeneous()
        .cast::<f32>();
    let (fx, fy, cx, cy) = (k.fx as f32, k.fy as f32, k.cx as f32, k.cy as f32);
    let (w, h) = (k.width as f32, k.height as f32);
    (0..gaussians.len())
        .into_par_iter()
        .with_min_len(4096)
        .filter_map(|i| {
            let m = gaussians.means[i];
            let p = camera_from_world * nalgebra::Vector4::new(m[0], m[1], m[2], 1.0);
            if f64::from(p.z) < NEAR_PLANE {
                return None;
            }
            let opacity = sigmoid(gaussians.logit_opacities[i]);
            let peak = opacity.min(super::super::MAX_ALPHA as f32);
            if f64::from(peak) < MIN_ALPHA {
                return None;
            }
            let radius = fx * gaussians.log_radii[i].exp() / p.z;
            let (u, v) = (fx * p.x / p.z + cx, fy * p.y / p.z + cy);
            // alpha >= 1/255 needs q <= 2 ln(255 opacity); one pixel of margin for rounding.
            let extent = radius * (2.0 * (opacity * 255.0).ln()).max(0.0).sqrt() + 1.0;
            if u + extent < 0.0 || v + extent < 0.0 || u - extent > w - 1.0 || v - extent > h - 1.0
            {
                return None;
            }
            Some(Splat {
                index: i as u32,
                u,
                v,
                radius,
                inv_radius2: 1.0 / (radius * radius),
                opacity,
                colour: gaussians.colours[i],
                depth: p.z,
                extent,
                camera_point: [p.x, p.y, p.z],
            })
        })
        .collect()
}

/// Screen-space gradients of one splat: d/du, d/dv, d/dradius, d/dopacity, d/dcolour (3),
/// d/ddepth.
pub type ScreenGradient = [f32; 8];

/// Chains screen-space gradients to the parameters (log-radius, logit-opacity, world mean).
pub fn chain_to_parameters(
    splats: &[Splat],
    screen: &[(ScreenGradient, bool)],
    camera: &PinholeCamera,
    gaussian_count: usize,
) -> Gradients {
    let k = camera.intrinsics;
    let (fx, fy) = (k.fx as f32, k.fy as f32);
    let rotation = camera
        .world_from_camera
        .rotation
        .to_rotation_matrix()
        .into_inner()
        .cast::<f32>();
    let mut gradients = Gradients::zeros(gaussian_count);
    for (splat, (s, _)) in splats.iter().zip(screen) {
        let [px, py, pz] = splat.camera_point;
        let world_radius = splat.radius * pz / fx;
        let inv_z2 = 1.0 / (pz * pz);
        let d_depth = s[7] - (s[0] * fx * px + s[1] * fy * py + s[2] * fx * world_radius) * inv_z2;
        let d_camera = nalgebra::Vector3::new(s[0] * fx / pz, s[1] * fy / pz, d_depth);
        let d_world = rotation * d_camera;
        let i = splat.index as usize;
        gradients.means[i] = [d_world.x, d_world.y, d_world.z];
        gradients.log_radii[i] = s[2] * splat.radius;
        gradients.logit_opacities[i] = s[3] * splat.opacity * (1.0 - splat.opacity);
        gradients.colours[i] = [s[4], s[5], s[6]];
    }
    gradients.touched = splats
        .iter()
        .zip(screen)
        .filter(|(_, (_, touched))| *touched)
        .map(|(s, _)| s.index)
        .collect();
    gradients.touched.sort_unstable();
    gradients
}
