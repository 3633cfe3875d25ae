//! The equations of DESIGN.md, written out per pixel in f64 with no tiles, no SIMD and no
//! cleverness: the reference the engines are tested against, and the function finite
//! differences are taken of.

use super::{validate_camera, ImageGradients, Images, RenderError, FISHER_PARAMETERS};
use super::{MAX_ALPHA, MIN_ALPHA, MIN_TRANSMITTANCE, NEAR_PLANE};
use crate::camera::PinholeCamera;
use crate::gaussians::{Gaussians, Gradients};
use crate::math::{Point3, Vector3};

/// A Gaussian projected into the image.
#[derive(Debug, Clone, Copy)]
struct Projected {
    index: usize,
    /// Pixel position of the centre.
    u: f64,
    v: f64,
    /// Optical-z depth.
    depth: f64,
    /// Radius in pixels.
    radius: f64,
    opacity: f64,
    colour: [f64; 3],
    /// Camera-frame centre.
    camera_point: Vector3,
}

fn project(gaussians: &Gaussians, camera: &PinholeCamera) -> Vec<Projected> {
    let camera_from_world = camera.world_from_camera.inverse();
    let k = &camera.intrinsics;
    let mut projected: Vec<Projected> = (0..gaussians.len())
        .filter_map(|i| {
            let m = gaussians.means[i];
            let p =
                camera_from_world * Point3::new(f64::from(m[0]), f64::from(m[1]), f64::from(m[2]));
            if p.z < NEAR_PLANE {
                return None;
            }
            let radius = f64::from(gaussians.log_radii[i]).exp();
            let opacity = 1.0 / (1.0 + (-f64::from(gaussians.logit_opacities[i])).exp());
            let c = gaussians.colours[i];
            Some(Projected {
                index: i,
                u: k.fx * p.x / p.z + k.cx,
                v: k.fy * p.y / p.z + k.cy,
                depth: p.z,
                radius: k.fx * radius / p.z,
                opacity,
                colour: [f64::from(c[0]), f64::from(c[1]), f64::from(c[2])],
                camera_point: p.coords,
            })
        })
        .collect();
    // Front to back; ties broken by index, as the engines do.
    projected.sort_by(|a, b| a.depth.total_cmp(&b.depth).then(a.index.cmp(&b.index)));
    projected
}

/// Alpha of `g` at pixel (x, y), and whether the 0.99 clamp was active.
fn alpha(g: &Projected, x: f64, y: f64) -> (f64, bool) {
    let (dx, dy) = (x - g.u, y - g.v);
    let q = (dx * dx + dy * dy) / (g.radius * g.radius);
    let raw = g.opacity * (-0.5 * q).exp();
    if raw > MAX_ALPHA {
        (MAX_ALPHA, true)
    } else {
        (raw, false)
    }
}

/// Validates the inputs, projects, and returns the image size.
fn prepare(
    gaussians: &Gaussians,
    camera: &PinholeCamera,
) -> Result<(Vec<Projected>, usize, usize), RenderError> {
    gaussians.validate()?;
    validate_camera(camera)?;
    let k = &camera.intrinsics;
    Ok((
        project(gaussians, camera),
        k.width as usize,
        k.height as usize,
    ))
}

/// Composites one pixel: (r, g, b, depth, silhouette), the contributing slots front to back,
/// and the transmittance left.
fn composite_pixel(projected: &[Projected], x: f64, y: f64) -> ([f64; 5], Vec<usize>, f64) {
    let mut t = 1.0;
    let mut out = [0.0; 5];
    let mut contributors = Vec::new();
    for (slot, g) in projected.iter().enumerate() {
        let (a, _) = alpha(g, x, y);
        if a < MIN_ALPHA {
            continue;
        }
        let next = t * (1.0 - a);
        if next < MIN_TRANSMITTANCE {
            break;
        }
        let weight = a * t;
        for c in 0..3 {
            out[c] += g.colour[c] * weight;
        }
        out[3] += g.depth * weight;
        out[4] += weight;
        contributors.push(slot);
        t = next;
    }
    (out, contributors, t)
}

/// Renders colour, depth and silhouette; also returns each pixel's exact f64 values
/// (r, g, b, depth, silhouette) for finite differences.
pub fn render(
    gaussians: &Gaussians,
    camera: &PinholeCamera,
) -> Result<(Images, Vec<[f64; 5]>), RenderError> {
    let (projected, w, h) = prepare(gaussians, camera)?;
    let mut images = Images::zeros(w, h);
    let mut exact = vec![[0.0; 5]; w * h];
    for y in 0..h {
        for x in 0..w {
            let (out, _, _) = composite_pixel(&projected, x as f64, y as f64);
            let p = y * w + x;
            for c in 0..3 {
                images.colour[3 * p + c] = out[c] as f32;
            }
            images.depth[p] = out[3] as f32;
            images.silhouette[p] = out[4] as f32;
            exact[p] = out;
        }
    }
    Ok((images, exact))
}

/// The Gaussians (by index) that contribute to each pixel, front to back. Finite differences
/// are only meaningful between two parameter values with the same sets: a change of set is a
/// jump of the 1/255 or transmittance cut-off, not a derivative.
pub fn contributors(
    gaussians: &Gaussians,
    camera: &PinholeCamera,
) -> Result<Vec<Vec<usize>>, RenderError> {
    let (projected, w, h) = prepare(gaussians, camera)?;
    let mut sets = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let (_, slots, _) = composite_pixel(&projected, x as f64, y as f64);
            sets.push(slots.into_iter().map(|s| projected[s].index).collect());
        }
    }
    Ok(sets)
}

/// Calls `each` with the screen-space gradients (d/du, d/dv, d/dradius_px, d/dopacity,
/// d/dcolour (3), d/ddepth) that pixel (x, y) gives each of its contributors, back to front,
/// for upstream gradients `grads` on (r, g, b, depth, silhouette).
fn pixel_screen_gradients(
    projected: &[Projected],
    x: f64,
    y: f64,
    grads: [f64; 5],
    each: &mut dyn FnMut(&Projected, [f64; 8]),
) {
    let (_, contributors, mut t) = composite_pixel(projected, x, y);
    // Back to front: `behind` is what is composited behind the current Gaussian.
    let mut behind = [0.0f64; 5];
    for &slot in contributors.iter().rev() {
        let g = &projected[slot];
        let (a, clamped) = alpha(g, x, y);
        t /= 1.0 - a;
        let weight = a * t;
        let values = [g.colour[0], g.colour[1], g.colour[2], g.depth, 1.0];
        // d out / d alpha = T (value - behind).
        let mut d_alpha = 0.0;
        for c in 0..5 {
            d_alpha += grads[c] * t * (values[c] - behind[c]);
            behind[c] = a * values[c] + (1.0 - a) * behind[c];
        }
        let mut s = [0.0f64; 8];
        for c in 0..3 {
            s[4 + c] = grads[c] * weight;
        }
        s[7] = grads[3] * weight;
        if !clamped {
            // alpha = o exp(-q/2), q = ((x-u)^2 + (y-v)^2) / r^2.
            let (dx, dy) = (x - g.u, y - g.v);
            let r2 = g.radius * g.radius;
            let d_q = -0.5 * a * d_alpha;
            s[0] = d_q * (-2.0 * dx / r2);
            s[1] = d_q * (-2.0 * dy / r2);
            s[2] = d_q * (-2.0 * (dx * dx + dy * dy) / (r2 * g.radius));
            s[3] = d_alpha * a / g.opacity;
        }
        each(g, s);
    }
}

/// A Gaussian's screen-space gradients chained to its parameters: mean x, y, z (world),
/// log-radius, logit-opacity, colour r, g, b.
fn chain(
    g: &Projected,
    s: &[f64; 8],
    k: &crate::camera::Intrinsics,
    rotation: &crate::math::UnitQuaternion,
) -> [f64; 8] {
    let (px, py, pz) = (g.camera_point.x, g.camera_point.y, g.camera_point.z);
    let radius = g.radius * pz / k.fx;
    let d_depth = s[7]
        - s[0] * k.fx * px / (pz * pz)
        - s[1] * k.fy * py / (pz * pz)
        - s[2] * k.fx * radius / (pz * pz);
    let d_world = rotation * Vector3::new(s[0] * k.fx / pz, s[1] * k.fy / pz, d_depth);
    [
        d_world.x,
        d_world.y,
        d_world.z,
        s[2] * k.fx / pz * radius,
        s[3] * g.opacity * (1.0 - g.opacity),
        s[4],
        s[5],
        s[6],
    ]
}

/// Gradients of a loss whose per-pixel gradients are `image_gradients`, in f64 then rounded.
pub fn backward(
    gaussians: &Gaussians,
    camera: &PinholeCamera,
    image_gradients: &ImageGradients,
) -> Result<Gradients, RenderError> {
    let (projected, w, h) = prepare(gaussians, camera)?;
    image_gradients.check(w * h)?;
    let k = &camera.intrinsics;
    let n = gaussians.len();
    // Per Gaussian: d/du, d/dv, d/dradius_px, d/dopacity, d/dcolour (3), d/ddepth.
    let mut screen = vec![[0.0f64; 8]; n];
    let mut touched = vec![false; n];
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            let grads = [
                f64::from(image_gradients.colour[3 * p]),
                f64::from(image_gradients.colour[3 * p + 1]),
                f64::from(image_gradients.colour[3 * p + 2]),
                f64::from(image_gradients.depth[p]),
                f64::from(image_gradients.silhouette[p]),
            ];
            pixel_screen_gradients(
                &projected,
                x as f64,
                y as f64,
                grads,
                &mut |g, per_pixel| {
                    touched[g.index] = true;
                    for (acc, v) in screen[g.index].iter_mut().zip(per_pixel) {
                        *acc += v;
                    }
                },
            );
        }
    }
    // Chain the screen-space gradients to the parameters.
    let mut gradients = Gradients::zeros(n);
    let rotation = camera.world_from_camera.rotation;
    for g in &projected {
        let d = chain(g, &screen[g.index], k, &rotation).map(|v| v as f32);
        let i = g.index;
        gradients.means[i] = [d[0], d[1], d[2]];
        gradients.log_radii[i] = d[3];
        gradients.logit_opacities[i] = d[4];
        gradients.colours[i] = [d[5], d[6], d[7]];
    }
    gradients.touched = (0..n as u32).filter(|&i| touched[i as usize]).collect();
    Ok(gradients)
}

/// The diagonal Fisher information of colour and depth (AG-SLAM eqs 7-9): per Gaussian and
/// parameter (mean x, y, z, log-radius, logit-opacity, colour r, g, b), the sum over pixels of
/// the squared per-pixel gradient of the pixel's colour and depth channels summed (an
/// upstream gradient of 1 on each). Each pixel is squared on its own.
pub fn fisher(
    gaussians: &Gaussians,
    camera: &PinholeCamera,
) -> Result<Vec<[f64; FISHER_PARAMETERS]>, RenderError> {
    let (projected, w, h) = prepare(gaussians, camera)?;
    let k = &camera.intrinsics;
    let rotation = camera.world_from_camera.rotation;
    let mut h_out = vec![[0.0f64; FISHER_PARAMETERS]; gaussians.len()];
    let grads = [1.0, 1.0, 1.0, 1.0, 0.0];
    for y in 0..h {
        for x in 0..w {
            pixel_screen_gradients(&projected, x as f64, y as f64, grads, &mut |g, s| {
                let per_pixel = chain(g, &s, k, &rotation);
                for (acc, d) in h_out[g.index].iter_mut().zip(per_pixel) {
                    *acc += d * d;
                }
            });
        }
    }
    Ok(h_out)
}
