//! The mapping loss of DESIGN.md: mean L1 depth error on measured pixels + 0.4 mean L1 colour
//! error + 0.1 (1 - SSIM), and its gradient with respect to the rendered images.
//! [`loss_generic`] is the reference (generic so tests run it in f64); [`mapping_loss`] runs
//! the same function in f32 on every core with SIMD ([`simd`]).

mod simd;

pub use simd::{loss_simd, loss_simd_in, LossWorkspace};

use crate::splat::{ImageGradients, Images};
use crate::ssim::{ssim_channel, Real};
use rayon::prelude::*;

/// Weight of the colour L1 term (lambda1).
pub const COLOUR_WEIGHT: f32 = 0.4;
/// Weight of the (1 - SSIM) term (lambda2).
pub const SSIM_WEIGHT: f32 = 0.1;

/// An RGB-D image pair of slices, same layout as [`Images`]: interleaved RGB and depth in
/// metres (0 = no measurement).
#[derive(Debug, Clone, Copy)]
pub struct RgbdSlices<'a, F> {
    /// Interleaved RGB in [0, 1].
    pub colour: &'a [F],
    /// Metres, 0 where nothing was measured.
    pub depth: &'a [F],
}

/// A measured RGB-D frame to fit.
pub type Target<'a> = RgbdSlices<'a, f32>;

/// The value of each term, for logs.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LossTerms {
    /// Mean |D^ - D| over measured pixels.
    pub depth_l1: f32,
    /// Mean |C^ - C| over pixels and channels.
    pub colour_l1: f32,
    /// Mean SSIM over pixels and channels.
    pub ssim: f32,
}

impl LossTerms {
    /// The weighted total.
    pub fn total(&self) -> f32 {
        self.depth_l1 + COLOUR_WEIGHT * self.colour_l1 + SSIM_WEIGHT * (1.0 - self.ssim)
    }
}

/// Loss terms (depth L1, colour L1, SSIM) of `rendered` against `target`, both W x H, with the
/// gradient of the weighted total written into `colour_grad` and `depth_grad`. Generic so
/// tests can take finite differences in f64.
pub fn loss_generic<F: Real>(
    rendered: RgbdSlices<'_, F>,
    target: RgbdSlices<'_, F>,
    (width, height): (usize, usize),
    colour_grad: &mut [F],
    depth_grad: &mut [F],
) -> [F; 3] {
    let (rendered_colour, rendered_depth) = (rendered.colour, rendered.depth);
    let (target_colour, target_depth) = (target.colour, target.depth);
    let n = width * height;
    let f = |v: f32| <F as From<f32>>::from(v);
    let sign = |d: F| {
        if d > F::zero() {
            F::one()
        } else if d < F::zero() {
            -F::one()
        } else {
            F::zero()
        }
    };
    // Depth: measured pixels only.
    let measured = target_depth.iter().filter(|d| **d > F::zero()).count();
    let mut depth_l1 = F::zero();
    if measured > 0 {
        let inv = F::one() / f(measured as f32);
        for p in 0..n {
            if target_depth[p] > F::zero() {
                let d = rendered_depth[p] - target_depth[p];
                depth_l1 = depth_l1 + d.abs() * inv;
                depth_grad[p] = sign(d) * inv;
            } else {
                depth_grad[p] = F::zero();
            }
        }
    } else {
        depth_grad.iter_mut().for_each(|g| *g = F::zero());
    }
    // Colour L1.
    let inv3 = F::one() / f((3 * n) as f32);
    let mut colour_l1 = F::zero();
    for i in 0..3 * n {
        let d = rendered_colour[i] - target_colour[i];
        colour_l1 = colour_l1 + d.abs() * inv3;
        colour_grad[i] = f(COLOUR_WEIGHT) * sign(d) * inv3;
    }
    // SSIM per channel (in parallel), averaged; the loss carries -lambda2 / 3 per channel.
    let per_channel: Vec<(F, Vec<F>)> = (0..3)
        .into_par_iter()
        .map(|c| {
            let x: Vec<F> = (0..n).map(|p| rendered_colour[3 * p + c]).collect();
            let y: Vec<F> = (0..n).map(|p| target_colour[3 * p + c]).collect();
            let mut g = vec![F::zero(); n];
            let scale = -f(SSIM_WEIGHT) / f(3.0);
            let mean = ssim_channel(&x, &y, width, height, scale, &mut g);
            (mean, g)
        })
        .collect();
    let mut ssim = F::zero();
    for (c, (mean, g)) in per_channel.iter().enumerate() {
        ssim = ssim + *mean / f(3.0);
        for p in 0..n {
            colour_grad[3 * p + c] = colour_grad[3 * p + c] + g[p];
        }
    }
    [depth_l1, colour_l1, ssim]
}

/// Loss of rendered images against a measured frame, and the image gradients for
/// backpropagation through the renderer (the silhouette does not enter this loss).
pub fn mapping_loss(rendered: &Images, target: Target<'_>) -> (LossTerms, ImageGradients) {
    let mut grads = ImageGradients::zeros(0);
    let terms = mapping_loss_in(rendered, target, &mut LossWorkspace::default(), &mut grads);
    (terms, grads)
}

/// [`mapping_loss`] into the caller's gradients with the caller's scratch, as the mapper's
/// iterations run it: after the first call at a size nothing is allocated or zeroed (fresh
/// buffers are page-faulted in on every call; BENCHMARKS.md has what that costs).
pub fn mapping_loss_in(
    rendered: &Images,
    target: Target<'_>,
    workspace: &mut LossWorkspace,
    grads: &mut ImageGradients,
) -> LossTerms {
    let n = rendered.width * rendered.height;
    if grads.depth.len() != n || grads.colour.len() != 3 * n || grads.silhouette.len() != n {
        *grads = ImageGradients::zeros(n);
    }
    let [depth_l1, colour_l1, ssim] = loss_simd_in(
        RgbdSlices {
            colour: &rendered.colour,
            depth: &rendered.depth,
        },
        target,
        (rendered.width, rendered.height),
        &mut grads.colour,
        &mut grads.depth,
        workspace,
    );
    LossTerms {
        depth_l1,
        colour_l1,
        ssim,
    }
}
