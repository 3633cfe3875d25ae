//! The mapping loss and its gradient in f32 on every core, 8 pixels per SIMD step: the same
//! function as [`super::loss_generic`] (the f64-capable reference), organised for speed.
//!
//! SSIM needs five blurred images per channel forward (mu_x, mu_y, E[x^2], E[y^2], E[xy]) and
//! three more backward, each an 11-tap separable blur: a few hundred multiply-adds per pixel.
//! Rows are processed in strips of [`STRIP`] rows, one rayon task each, in two phases with a
//! barrier between them (the backward blur of a row needs the forward results of its
//! neighbours' rows):
//! 1. per strip and channel: the five products of the strip's rows and the five rows either
//!    side, blurred vertically into a zero-padded row, then horizontally 8 pixels at a time,
//!    then SSIM and its derivatives with respect to (mu_x, E[x^2], E[xy]) per pixel, kept as
//!    nine planes;
//! 2. per strip and channel: those planes blurred the same way (the window is symmetric, so
//!    the blur is its own adjoint) and combined with the L1 terms into the colour gradient.

use super::{RgbdSlices, COLOUR_WEIGHT, SSIM_WEIGHT};
use crate::ssim::{window, C1, C2, RADIUS};
use rayon::prelude::*;
use wide::{f32x8, CmpGt, CmpLt};

/// Rows per rayon task: 30 tasks at 480 rows, enough to balance 16 cores; the strip's input
/// rows (STRIP + 10) stay in the core's cache.
const STRIP: usize = 16;
const TAPS: usize = 2 * RADIUS + 1;
const LANES: usize = 8;
/// Quantities blurred forward: x, y, x^2, y^2, xy.
const FORWARD: usize = 5;
/// Planes blurred backward per channel: dS/dmu_x, dS/dE[x^2], dS/dE[xy].
const BACKWARD: usize = 3;

/// Image size and the padded row length the horizontal blur reads from.
#[derive(Clone, Copy)]
struct Layout {
    width: usize,
    height: usize,
    /// RADIUS zeros, the row, zeros up to a whole number of vectors, RADIUS zeros.
    padded: usize,
}

impl Layout {
    fn new(width: usize, height: usize) -> Self {
        Layout {
            width,
            height,
            padded: width.next_multiple_of(LANES) + 2 * RADIUS,
        }
    }
}

/// One strip's scratch rows, kept between calls in a [`LossWorkspace`].
#[derive(Default)]
struct StripScratch {
    /// The products of the strip's input rows and RADIUS rows either side (phase 1).
    inputs: Vec<f32>,
    /// One zero-padded row per blurred quantity (FORWARD of them, BACKWARD in phase 2).
    padded: Vec<f32>,
    /// One blurred row per quantity, padded to whole vectors.
    blurred: Vec<f32>,
    /// One channel of a row of the rendered and target images and of the gradient (phase 2).
    x_row: Vec<f32>,
    y_row: Vec<f32>,
    out: Vec<f32>,
}

impl StripScratch {
    /// Sized for `layout`; rows the previous call wrote are overwritten, never read first.
    fn fit(&mut self, layout: Layout) {
        let span = layout.width.next_multiple_of(LANES);
        self.inputs
            .resize((STRIP + 2 * RADIUS) * FORWARD * layout.width, 0.0);
        // The padding columns must be zero: blurs write only the row between them.
        if self.padded.len() != FORWARD * layout.padded {
            self.padded = vec![0.0; FORWARD * layout.padded];
        }
        self.blurred.resize(FORWARD * span, 0.0);
        for row in [&mut self.x_row, &mut self.y_row, &mut self.out] {
            row.resize(span, 0.0);
        }
    }
}

/// The SIMD loss's scratch memory, kept by the caller (the mapper keeps one) so that a call
/// allocates and page-faults nothing: 9 derivative planes of the image (11 MB at 640x480)
/// and each strip's rows, which fresh allocations page-fault in on every call.
#[derive(Default)]
pub struct LossWorkspace {
    planes: Vec<f32>,
    strips: Vec<StripScratch>,
}

impl std::fmt::Debug for LossWorkspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LossWorkspace")
            .field("planes", &self.planes.len())
            .field("strips", &self.strips.len())
            .finish()
    }
}

impl LossWorkspace {
    /// Sized for a W x H image; every entry is written before it is read.
    fn fit(&mut self, layout: Layout) {
        let n = layout.width * layout.height;
        self.planes.resize(n * 3 * BACKWARD, 0.0);
        let strips = layout.height.div_ceil(STRIP);
        self.strips.resize_with(strips, StripScratch::default);
        for strip in &mut self.strips {
            strip.fit(layout);
        }
    }
}

/// `out[x] = sum_t k[t] * rows[t][x]` over the rows that exist (zero padding above and below),
/// written into `out[RADIUS..RADIUS + width]`; 8 pixels at a time, the sum in a register.
#[inline(always)]
fn blur_vertical(k: &[f32; TAPS], rows: &[Option<&[f32]>; TAPS], out: &mut [f32], width: usize) {
    let out = &mut out[RADIUS..RADIUS + width];
    let mut taps = [(f32x8::ZERO, &[][..]); TAPS];
    let mut count = 0;
    for (kt, row) in k.iter().zip(rows) {
        if let Some(row) = row {
            taps[count] = (f32x8::splat(*kt), &row[..width]);
            count += 1;
        }
    }
    let taps = &taps[..count];
    let chunks = width / LANES;
    for c in 0..chunks {
        let at = c * LANES;
        let mut acc = f32x8::ZERO;
        for (kt, row) in taps {
            acc = f32x8::new(load8(row, at)).mul_add(*kt, acc);
        }
        out[at..at + LANES].copy_from_slice(&acc.to_array());
    }
    for x in chunks * LANES..width {
        out[x] = taps.iter().map(|(kt, row)| kt.to_array()[0] * row[x]).sum();
    }
}

/// `out[x] = sum_t k[t] * padded[x + t]`: the horizontal blur of a zero-padded row, 8 pixels
/// at a time.
#[inline(always)]
fn blur_horizontal(k: &[f32; TAPS], padded: &[f32], out: &mut [f32]) {
    let taps: [f32x8; TAPS] = std::array::from_fn(|t| f32x8::splat(k[t]));
    for (c, out) in out.chunks_exact_mut(LANES).enumerate() {
        let mut acc = f32x8::ZERO;
        for (t, kt) in taps.iter().enumerate() {
            acc = f32x8::new(load8(padded, c * LANES + t)).mul_add(*kt, acc);
        }
        out.copy_from_slice(&acc.to_array());
    }
}

#[inline(always)]
fn load8(row: &[f32], at: usize) -> [f32; LANES] {
    let mut v = [0.0; LANES];
    v.copy_from_slice(&row[at..at + LANES]);
    v
}

/// The rows `y - RADIUS ..= y + RADIUS` of an image whose row `r` is `row(r)`, None outside it.
#[inline(always)]
fn window_rows<'a>(
    y: usize,
    height: usize,
    row: impl Fn(usize) -> &'a [f32],
) -> [Option<&'a [f32]>; TAPS] {
    std::array::from_fn(|t| {
        let r = y as isize + t as isize - RADIUS as isize;
        (r >= 0 && (r as usize) < height).then(|| row(r as usize))
    })
}

/// Phase 1 for one strip: the nine derivative planes of its rows (row-major, nine sub-rows
/// per image row: channel-major, then dS/dmu_x, dS/dE[x^2], dS/dE[xy]) and the strip's SSIM
/// sum over pixels and channels.
fn ssim_strip_forward(
    x_img: &[f32],
    y_img: &[f32],
    layout: Layout,
    first_row: usize,
    planes: &mut [f32],
    scale: f32,
    scratch: &mut StripScratch,
) -> f64 {
    let Layout { width, height, .. } = layout;
    let k = window::<f32>();
    let rows = planes.len() / (3 * BACKWARD * width);
    let lo = first_row.saturating_sub(RADIUS);
    let hi = (first_row + rows + RADIUS).min(height);
    // The products of the input rows lo..hi, one channel at a time.
    let StripScratch {
        inputs,
        padded,
        blurred,
        ..
    } = scratch;
    let span = width.next_multiple_of(LANES);
    let c1 = f32x8::splat(C1);
    let c2 = f32x8::splat(C2);
    let two = f32x8::splat(2.0);
    let gain = f32x8::splat(scale);
    let lane_index = f32x8::new([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]);
    let mut total = 0.0f64;
    for channel in 0..3 {
        for r in lo..hi {
            let base = (r - lo) * FORWARD * width;
            let (q, _) = inputs[base..base + FORWARD * width].split_at_mut(FORWARD * width);
            for x in 0..width {
                let a = x_img[3 * (r * width + x) + channel];
                let b = y_img[3 * (r * width + x) + channel];
                q[x] = a;
                q[width + x] = b;
                q[2 * width + x] = a * a;
                q[3 * width + x] = b * b;
                q[4 * width + x] = a * b;
            }
        }
        for row in 0..rows {
            let y = first_row + row;
            for quantity in 0..FORWARD {
                let source = window_rows(y, height, |r| {
                    let at = ((r - lo) * FORWARD + quantity) * width;
                    &inputs[at..at + width]
                });
                let out = &mut padded[quantity * layout.padded..(quantity + 1) * layout.padded];
                blur_vertical(&k, &source, out, width);
            }
            let out_row = &mut planes[row * 3 * BACKWARD * width..(row + 1) * 3 * BACKWARD * width];
            for (q, out) in blurred.chunks_exact_mut(span).enumerate() {
                blur_horizontal(&k, &padded[q * layout.padded..(q + 1) * layout.padded], out);
            }
            let mut row_sum = f32x8::ZERO;
            for x0 in (0..width).step_by(LANES) {
                let [mx, my, exx, eyy, exy]: [f32x8; FORWARD] =
                    std::array::from_fn(|q| f32x8::new(load8(&blurred[q * span..], x0)));
                let var_x = exx - mx * mx;
                let var_y = eyy - my * my;
                let cov = exy - mx * my;
                let a1 = two * mx * my + c1;
                let a2 = two * cov + c2;
                let b1 = mx * mx + my * my + c1;
                let b2 = var_x + var_y + c2;
                let inv = f32x8::ONE / (b1 * b2);
                let s = a1 * a2 * inv;
                let ds_dmu = two * my * a2 * inv - two * mx * s / b1;
                let ds_dvar = -s / b2;
                let ds_dcov = two * a1 * inv;
                let lanes = (width - x0).min(LANES);
                let valid = (lane_index - f32x8::splat(lanes as f32)).sign_bit();
                row_sum += s & valid;
                let d = [
                    gain * (ds_dmu - two * mx * ds_dvar - my * ds_dcov),
                    gain * ds_dvar,
                    gain * ds_dcov,
                ];
                for (plane, value) in d.iter().enumerate() {
                    let at = (channel * BACKWARD + plane) * width + x0;
                    out_row[at..at + lanes].copy_from_slice(&value.to_array()[..lanes]);
                }
            }
            total += f64::from(row_sum.reduce_add());
        }
    }
    total
}

/// Phase 2 for one strip: the derivative planes blurred back and combined with each pixel's
/// values into `colour_grad` (which already holds the L1 term), rows `first_row..`.
fn ssim_strip_backward(
    x_img: &[f32],
    y_img: &[f32],
    layout: Layout,
    first_row: usize,
    planes: &[f32],
    colour_grad: &mut [f32],
    scratch: &mut StripScratch,
) {
    let Layout { width, height, .. } = layout;
    let k = window::<f32>();
    let rows = colour_grad.len() / (3 * width);
    // One row of one channel of each image, and of the gradient, padded to whole vectors.
    let span = width.next_multiple_of(LANES);
    let StripScratch {
        padded,
        blurred,
        x_row,
        y_row,
        out,
        ..
    } = scratch;
    let blurred = &mut blurred[..BACKWARD * span];
    for row in 0..rows {
        let y = first_row + row;
        let pixels = y * width * 3..(y + 1) * width * 3;
        let grads = &mut colour_grad[row * width * 3..(row + 1) * width * 3];
        for channel in 0..3 {
            for plane in 0..BACKWARD {
                let source = window_rows(y, height, |r| {
                    let at = (r * 3 * BACKWARD + channel * BACKWARD + plane) * width;
                    &planes[at..at + width]
                });
                let out = &mut padded[plane * layout.padded..(plane + 1) * layout.padded];
                blur_vertical(&k, &source, out, width);
            }
            let rgb = x_img[pixels.clone()].chunks_exact(3);
            for (x, v) in x_row.iter_mut().zip(rgb) {
                *x = v[channel];
            }
            let rgb = y_img[pixels.clone()].chunks_exact(3);
            for (x, v) in y_row.iter_mut().zip(rgb) {
                *x = v[channel];
            }
            for (plane, out) in blurred.chunks_exact_mut(span).enumerate() {
                let source = &padded[plane * layout.padded..(plane + 1) * layout.padded];
                blur_horizontal(&k, source, out);
            }
            for x0 in (0..width).step_by(LANES) {
                let g: [f32x8; BACKWARD] =
                    std::array::from_fn(|plane| f32x8::new(load8(&blurred[plane * span..], x0)));
                let xs = f32x8::new(load8(x_row, x0));
                let ys = f32x8::new(load8(y_row, x0));
                let sum = g[0] + f32x8::splat(2.0) * xs * g[1] + ys * g[2];
                out[x0..x0 + LANES].copy_from_slice(&sum.to_array());
            }
            for (g, v) in grads.chunks_exact_mut(3).zip(out.iter()) {
                g[channel] += v;
            }
        }
    }
}

/// Sum of |r - t| (over the entries with t > 0 when `measured_only`), and `gain * sign(r - t)`
/// (0 where not measured) written into `grads`; branch-free, since the signs are random.
fn l1_term(
    rendered: &[f32],
    target: &[f32],
    grads: &mut [f32],
    gain: f32,
    measured_only: bool,
) -> f64 {
    let one = f32x8::ONE;
    let mut sum = f32x8::ZERO;
    let chunks = grads.len() / LANES;
    for c in 0..chunks {
        let at = c * LANES;
        let t = f32x8::new(load8(target, at));
        let mut d = f32x8::new(load8(rendered, at)) - t;
        if measured_only {
            d &= t.cmp_gt(f32x8::ZERO);
        }
        sum += d.abs();
        let sign = (d.cmp_gt(f32x8::ZERO) & one) - (d.cmp_lt(f32x8::ZERO) & one);
        grads[at..at + LANES].copy_from_slice(&(sign * f32x8::splat(gain)).to_array());
    }
    let mut total = f64::from(sum.reduce_add());
    for i in chunks * LANES..grads.len() {
        let (r, t) = (rendered[i], target[i]);
        let d = if measured_only && t <= 0.0 {
            0.0
        } else {
            r - t
        };
        total += f64::from(d.abs());
        grads[i] = gain * (f32::from(u8::from(d > 0.0)) - f32::from(u8::from(d < 0.0)));
    }
    total
}

/// The loss terms (depth L1, colour L1, SSIM) of `rendered` against `target`, W x H, with the
/// gradient of the weighted total written into `colour_grad` and `depth_grad`. Agrees with
/// [`super::loss_generic`] to f32 rounding. Allocates its scratch; [`loss_simd_in`] reuses one.
pub fn loss_simd(
    rendered: RgbdSlices<'_, f32>,
    target: RgbdSlices<'_, f32>,
    size: (usize, usize),
    colour_grad: &mut [f32],
    depth_grad: &mut [f32],
) -> [f32; 3] {
    let mut workspace = LossWorkspace::default();
    loss_simd_in(
        rendered,
        target,
        size,
        colour_grad,
        depth_grad,
        &mut workspace,
    )
}

/// [`loss_simd`] with the caller's scratch: after the first call at a size, no allocation.
/// Every entry of `colour_grad` and `depth_grad` is overwritten.
pub fn loss_simd_in(
    rendered: RgbdSlices<'_, f32>,
    target: RgbdSlices<'_, f32>,
    (width, height): (usize, usize),
    colour_grad: &mut [f32],
    depth_grad: &mut [f32],
    workspace: &mut LossWorkspace,
) -> [f32; 3] {
    let n = width * height;
    if n == 0 {
        return [0.0, 0.0, 0.0];
    }
    let layout = Layout::new(width, height);
    workspace.fit(layout);
    let LossWorkspace { planes, strips } = workspace;
    // Depth: measured pixels only.
    let measured = target.depth.par_iter().filter(|d| **d > 0.0).count();
    let depth_inv = if measured > 0 {
        1.0 / measured as f32
    } else {
        0.0
    };
    let depth_l1: f64 = depth_grad
        .par_chunks_mut(STRIP * width)
        .enumerate()
        .map(|(strip, grads)| {
            let first = strip * STRIP * width;
            let range = first..first + grads.len();
            l1_term(
                &rendered.depth[range.clone()],
                &target.depth[range],
                grads,
                depth_inv,
                true,
            )
        })
        .sum::<f64>()
        * f64::from(depth_inv);
    // Phase 1: the SSIM derivative planes, and the colour L1 term into the gradient.
    let inv3 = 1.0 / (3 * n) as f32;
    let scale = -SSIM_WEIGHT / 3.0 / n as f32;
    let (colour_l1, ssim_sum) = planes
        .par_chunks_mut(STRIP * width * 3 * BACKWARD)
        .zip(colour_grad.par_chunks_mut(STRIP * width * 3))
        .zip(strips.par_iter_mut())
        .enumerate()
        .map(|(strip, ((planes, grads), scratch))| {
            let first = strip * STRIP * width * 3;
            let range = first..first + grads.len();
            let l1 = l1_term(
                &rendered.colour[range.clone()],
                &target.colour[range],
                grads,
                COLOUR_WEIGHT * inv3,
                false,
            );
            let s = ssim_strip_forward(
                rendered.colour,
                target.colour,
                layout,
                strip * STRIP,
                planes,
                scale,
                scratch,
            );
            (l1, s)
        })
        .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    // Phase 2: the derivative planes blurred back into the colour gradient.
    let planes = &*planes;
    colour_grad
        .par_chunks_mut(STRIP * width * 3)
        .zip(strips.par_iter_mut())
        .enumerate()
        .for_each(|(strip, (grads, scratch))| {
            ssim_strip_backward(
                rendered.colour,
                target.colour,
                layout,
                strip * STRIP,
                planes,
                grads,
                scratch,
            );
        });
    [
        depth_l1 as f32,
        (colour_l1 * f64::from(inv3)) as f32,
        (ssim_sum / (3 * n) as f64) as f32,
    ]
}
