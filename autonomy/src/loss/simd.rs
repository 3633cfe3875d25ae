//! The mapping loss and its gradient in f32 on every core, 8 pixels per SIMD step: the same
//! function as [`super::loss_generic`] (the f64-capable reference), organised for speed.
//!
//! SSIM needs five blurred quantities per channel forward (mu_x, mu_y, E[x^2], E[y^2], E[xy])
//! and three more backward, each an 11-tap separable blur: a few hundred multiply-adds per
//! pixel, so the work is arranged to stay in the core's cache and never wait on memory. The
//! image is cut into one band of rows per thread; a band streams down its rows once, with
//! two rings of 11 rows:
//! - input rows, deinterleaved into planar x and y per channel as they are first needed;
//! - for each row `f`: the five quantities blurred vertically (the products formed on the fly
//!   from the input ring), then horizontally (the window is symmetric: 6 multiplies, not 11),
//!   then SSIM and its derivatives with respect to (mu_x, E[x^2], E[xy]), kept as three planes
//!   per channel in the plane ring;
//! - five rows behind, row `f - 5`: those planes blurred back the same way (the blur is its
//!   own adjoint) and combined with the pixel's values into the colour gradient, which already
//!   holds the L1 term.
//!
//! A band also computes the five rows of planes either side of it (its neighbours compute
//! them too), so bands never wait on each other: with one band per thread that is 10 extra
//! forward rows per band. Every pixel's arithmetic is the same whatever the bands are, and
//! the sums are taken per row and added in row order, so results do not depend on the thread
//! count, bit for bit.

use super::{RgbdSlices, COLOUR_WEIGHT, SSIM_WEIGHT};
use crate::ssim::{window, C1, C2, RADIUS};
use rayon::prelude::*;
use std::ops::Range;
use wide::{f32x8, CmpGt, CmpLt};

const TAPS: usize = 2 * RADIUS + 1;
const LANES: usize = 8;
const CHANNELS: usize = 3;
/// Quantities blurred forward: x, y, x^2, y^2, xy.
const FORWARD: usize = 5;
/// Planes blurred backward per channel: dS/dmu_x, dS/dE[x^2], dS/dE[xy].
const BACKWARD: usize = 3;

/// Image size, the row length rounded up to whole vectors, and the zero-padded row length
/// the horizontal blur reads from.
#[derive(Clone, Copy)]
struct Layout {
    width: usize,
    height: usize,
    /// `width` rounded up to a multiple of LANES; entries past `width` are kept zero.
    span: usize,
    /// RADIUS zeros, a span, RADIUS zeros.
    padded: usize,
}

impl Layout {
    fn new(width: usize, height: usize) -> Self {
        let span = width.next_multiple_of(LANES);
        Layout {
            width,
            height,
            span,
            padded: span + 2 * RADIUS,
        }
    }
}

/// One band's rings and rows, kept between calls in a [`LossWorkspace`].
#[derive(Default)]
struct BandScratch {
    /// TAPS slots (row r in slot r % TAPS), each CHANNELS x (x, y) rows of `span`.
    inputs: Vec<f32>,
    /// TAPS slots, each CHANNELS x BACKWARD derivative rows of `span`.
    planes: Vec<f32>,
    /// FORWARD zero-padded rows: the vertical blur writes their middle, the horizontal reads.
    padded: Vec<f32>,
    /// The SSIM part of one row's colour gradient, per channel.
    out: Vec<f32>,
    /// A row of zeros: the rows above and below the image.
    zeros: Vec<f32>,
}

impl BandScratch {
    /// Sized for `layout`; ring rows are written before they are read, and their entries past
    /// `width` are rewritten as zeros each time, so nothing from an earlier size leaks in.
    fn fit(&mut self, layout: Layout) {
        let span = layout.span;
        self.inputs.resize(TAPS * CHANNELS * 2 * span, 0.0);
        self.planes.resize(TAPS * CHANNELS * BACKWARD * span, 0.0);
        // Only the middle of a padded row is ever written: its ends stay zero while the
        // length (and so the layout of the middle) stays the same.
        if self.padded.len() != FORWARD * layout.padded {
            self.padded = vec![0.0; FORWARD * layout.padded];
        }
        self.out.resize(CHANNELS * span, 0.0);
        if self.zeros.len() != span {
            self.zeros = vec![0.0; span];
        }
    }
}

/// The SIMD loss's scratch memory, kept by the caller (the mapper keeps one) so that a call
/// allocates and page-faults nothing: each band's rings (about 400 KB at 640 columns, so
/// they stay in the core's cache) and the per-row sums.
#[derive(Default)]
pub struct LossWorkspace {
    bands: Vec<BandScratch>,
    /// Per row: SSIM summed over pixels and channels, colour L1, depth L1.
    row_sums: Vec<[f64; 3]>,
}

impl std::fmt::Debug for LossWorkspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LossWorkspace")
            .field("bands", &self.bands.len())
            .field("rows", &self.row_sums.len())
            .finish()
    }
}

impl LossWorkspace {
    /// Sized for a W x H image cut into `bands` bands.
    fn fit(&mut self, layout: Layout, bands: usize) {
        self.row_sums.resize(layout.height, [0.0; 3]);
        self.bands.resize_with(bands, BandScratch::default);
        for band in &mut self.bands {
            band.fit(layout);
        }
    }
}

#[inline(always)]
fn load(row: &[f32], at: usize) -> f32x8 {
    let mut v = [0.0; LANES];
    v.copy_from_slice(&row[at..at + LANES]);
    f32x8::new(v)
}

#[inline(always)]
fn store(row: &mut [f32], at: usize, v: f32x8) {
    row[at..at + LANES].copy_from_slice(&v.to_array());
}

/// The horizontal blur at `padded[at + RADIUS]` (8 outputs): the symmetric window as five
/// pairs and a centre.
#[inline(always)]
fn blur_horizontal(k: &[f32x8; TAPS], padded: &[f32], at: usize) -> f32x8 {
    let mut acc = load(padded, at + RADIUS) * k[RADIUS];
    for t in 0..RADIUS {
        acc = (load(padded, at + t) + load(padded, at + TAPS - 1 - t)).mul_add(k[t], acc);
    }
    acc
}

/// A band's two rings and the images it reads: everything a row of the band needs.
struct Band<'a> {
    x_img: &'a [f32],
    y_img: &'a [f32],
    layout: Layout,
    k: [f32x8; TAPS],
    /// The colour L1 term's gradient magnitude.
    colour_gain: f32,
    scratch: &'a mut BandScratch,
}

impl Band<'_> {
    /// Input row `r` (x or y) of `channel`, zeros outside the image.
    fn input(&self, r: isize, channel: usize, y: bool) -> &[f32] {
        let span = self.layout.span;
        if r < 0 || r as usize >= self.layout.height {
            return &self.scratch.zeros;
        }
        let at = (((r as usize % TAPS) * CHANNELS + channel) * 2 + usize::from(y)) * span;
        &self.scratch.inputs[at..at + span]
    }

    /// Derivative plane `plane` of `channel` at row `r`, zeros outside the image.
    fn plane(&self, r: isize, channel: usize, plane: usize) -> &[f32] {
        let span = self.layout.span;
        if r < 0 || r as usize >= self.layout.height {
            return &self.scratch.zeros;
        }
        let at = (((r as usize % TAPS) * CHANNELS + channel) * BACKWARD + plane) * span;
        &self.scratch.planes[at..at + span]
    }

    /// Deinterleaves image row `r` into its ring slot, zeros past the width.
    fn load_row(&mut self, r: usize) {
        let Layout { width, span, .. } = self.layout;
        let slot = &mut self.scratch.inputs
            [(r % TAPS) * CHANNELS * 2 * span..(r % TAPS + 1) * CHANNELS * 2 * span];
        let pixels = r * width * CHANNELS..(r + 1) * width * CHANNELS;
        for (which, image) in [self.x_img, self.y_img].into_iter().enumerate() {
            let row = &image[pixels.clone()];
            for channel in 0..CHANNELS {
                let at = (channel * 2 + which) * span;
                let dst = &mut slot[at..at + span];
                for (d, rgb) in dst.iter_mut().zip(row.chunks_exact(CHANNELS)) {
                    *d = rgb[channel];
                }
                dst[width..].fill(0.0);
            }
        }
    }

    /// Row `f`'s derivative planes into the plane ring; returns its SSIM summed over pixels
    /// and channels.
    fn forward_row(&mut self, f: usize, gain: f32x8) -> f64 {
        let Layout {
            width,
            span,
            padded: plen,
            ..
        } = self.layout;
        let k = self.k;
        let (c1, c2, two) = (f32x8::splat(C1), f32x8::splat(C2), f32x8::splat(2.0));
        let lane_index = f32x8::new([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]);
        let mut row_sum = f32x8::ZERO;
        let mut padded = std::mem::take(&mut self.scratch.padded);
        let mut planes = std::mem::take(&mut self.scratch.planes);
        let slot = (f % TAPS) * CHANNELS * BACKWARD * span;
        for channel in 0..CHANNELS {
            let rows = |y: bool| -> [&[f32]; TAPS] {
                std::array::from_fn(|t| {
                    self.input(f as isize + t as isize - RADIUS as isize, channel, y)
                })
            };
            let (xs, ys) = (rows(false), rows(true));
            // Vertical: the five quantities, the products formed from the ring as they go.
            for at in (0..span).step_by(LANES) {
                let mut acc = [f32x8::ZERO; FORWARD];
                for t in 0..TAPS {
                    let (x, y) = (load(xs[t], at), load(ys[t], at));
                    let (kx, ky) = (k[t] * x, k[t] * y);
                    acc[0] += kx;
                    acc[1] += ky;
                    acc[2] = kx.mul_add(x, acc[2]);
                    acc[3] = ky.mul_add(y, acc[3]);
                    acc[4] = kx.mul_add(y, acc[4]);
                }
                for (q, value) in acc.into_iter().enumerate() {
                    store(&mut padded[q * plen..(q + 1) * plen], RADIUS + at, value);
                }
            }
            // Horizontal, then SSIM and its derivatives, 8 pixels at a time.
            let out = &mut planes
                [slot + channel * BACKWARD * span..slot + (channel + 1) * BACKWARD * span];
            for at in (0..span).step_by(LANES) {
                // Spelled out: through `array::from_fn` the blur is not inlined.
                let h = |q: usize| blur_horizontal(&k, &padded[q * plen..(q + 1) * plen], at);
                let (mx, my, exx, eyy, exy) = (h(0), h(1), h(2), h(3), h(4));
                let var_x = exx - mx * mx;
                let var_y = eyy - my * my;
                let cov = exy - mx * my;
                let a1 = two * mx * my + c1;
                let a2 = two * cov + c2;
                let b1 = mx * mx + my * my + c1;
                let b2 = var_x + var_y + c2;
                // One division: 1/b1 = b2/(b1 b2) and 1/b2 = b1/(b1 b2).
                let inv = f32x8::ONE / (b1 * b2);
                let s = a1 * a2 * inv;
                let ds_dmu = two * my * a2 * inv - two * mx * s * (b2 * inv);
                let ds_dvar = -s * (b1 * inv);
                let ds_dcov = two * a1 * inv;
                // Lanes past the width: no pixel, so no SSIM and zero planes (the backward
                // blur reads them as the image's zero padding).
                let valid = (lane_index - f32x8::splat((width - at.min(width)) as f32)).sign_bit();
                row_sum += s & valid;
                let d = [
                    gain * (ds_dmu - two * mx * ds_dvar - my * ds_dcov),
                    gain * ds_dvar,
                    gain * ds_dcov,
                ];
                for (plane, value) in d.into_iter().enumerate() {
                    store(
                        &mut out[plane * span..(plane + 1) * span],
                        at,
                        value & valid,
                    );
                }
            }
        }
        self.scratch.padded = padded;
        self.scratch.planes = planes;
        f64::from(row_sum.reduce_add())
    }

    /// Row `b`'s planes blurred back and combined into `grads` (that row's interleaved colour
    /// gradient, which holds the L1 term).
    fn backward_row(&mut self, b: usize, grads: &mut [f32]) {
        let Layout {
            span, padded: plen, ..
        } = self.layout;
        let k = self.k;
        let two = f32x8::splat(2.0);
        let mut padded = std::mem::take(&mut self.scratch.padded);
        let mut out = std::mem::take(&mut self.scratch.out);
        for channel in 0..CHANNELS {
            let rows: [[&[f32]; TAPS]; BACKWARD] = std::array::from_fn(|plane| {
                std::array::from_fn(|t| {
                    self.plane(b as isize + t as isize - RADIUS as isize, channel, plane)
                })
            });
            for at in (0..span).step_by(LANES) {
                let mut acc = [f32x8::ZERO; BACKWARD];
                for t in 0..TAPS {
                    for (plane, acc) in acc.iter_mut().enumerate() {
                        *acc = load(rows[plane][t], at).mul_add(k[t], *acc);
                    }
                }
                for (plane, value) in acc.into_iter().enumerate() {
                    store(
                        &mut padded[plane * plen..(plane + 1) * plen],
                        RADIUS + at,
                        value,
                    );
                }
            }
            let (xs, ys) = (
                self.input(b as isize, channel, false),
                self.input(b as isize, channel, true),
            );
            let out = &mut out[channel * span..(channel + 1) * span];
            for at in (0..span).step_by(LANES) {
                let h = |q: usize| blur_horizontal(&k, &padded[q * plen..(q + 1) * plen], at);
                let g = [h(0), h(1), h(2)];
                let sum = g[0] + two * load(xs, at) * g[1] + load(ys, at) * g[2];
                store(out, at, sum);
            }
        }
        let (r, rest) = out.split_at(span);
        let (g, bl) = rest.split_at(span);
        for (pixel, ((r, g), bl)) in grads
            .chunks_exact_mut(CHANNELS)
            .zip(r.iter().zip(g).zip(bl))
        {
            pixel[0] += r;
            pixel[1] += g;
            pixel[2] += bl;
        }
        self.scratch.padded = padded;
        self.scratch.out = out;
    }

    /// Row `b`'s colour gradient into `grads` (the row's interleaved entries): the L1 term
    /// first (its pixels are still in cache from `load_row`), then the SSIM part added to
    /// it. Returns the row's colour L1 sum.
    fn finish_row(&mut self, b: usize, grads: &mut [f32]) -> f64 {
        let pixels = b * grads.len()..(b + 1) * grads.len();
        let l1 = l1_term(
            &self.x_img[pixels.clone()],
            &self.y_img[pixels],
            grads,
            self.colour_gain,
            false,
        );
        self.backward_row(b, grads);
        l1
    }

    /// The colour gradient of the rows `rows` into `grads` (their interleaved entries), and
    /// each row's SSIM and colour L1 sums into the first two entries of its `sums`.
    fn run(&mut self, rows: Range<usize>, grads: &mut [f32], sums: &mut [[f64; 3]], gain: f32x8) {
        let height = self.layout.height;
        let row_len = self.layout.width * CHANNELS;
        let forward_lo = rows.start.saturating_sub(RADIUS);
        let forward_hi = (rows.end + RADIUS).min(height);
        let mut next_input = forward_lo.saturating_sub(RADIUS);
        let mut finish = |band: &mut Self, sums: &mut [[f64; 3]], b: usize| {
            let at = (b - rows.start) * row_len;
            sums[b - rows.start][1] = band.finish_row(b, &mut grads[at..at + row_len]);
        };
        for f in forward_lo..forward_hi {
            while next_input < (f + RADIUS + 1).min(height) {
                self.load_row(next_input);
                next_input += 1;
            }
            let sum = self.forward_row(f, gain);
            if rows.contains(&f) {
                sums[f - rows.start][0] = sum;
            }
            // Row f - RADIUS has every plane row it blurs, and its input row is still held.
            if let Some(b) = f.checked_sub(RADIUS).filter(|b| rows.contains(b)) {
                finish(self, sums, b);
            }
        }
        // The last rows of the image: the rows below them are zeros, not computed.
        for b in forward_hi.saturating_sub(RADIUS).max(rows.start)..rows.end {
            finish(self, sums, b);
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
        let t = load(target, at);
        let mut d = load(rendered, at) - t;
        if measured_only {
            d &= t.cmp_gt(f32x8::ZERO);
        }
        sum += d.abs();
        let sign = (d.cmp_gt(f32x8::ZERO) & one) - (d.cmp_lt(f32x8::ZERO) & one);
        store(grads, at, sign * f32x8::splat(gain));
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
    let band_rows = height.div_ceil(rayon::current_num_threads().max(1));
    workspace.fit(layout, height.div_ceil(band_rows));
    let LossWorkspace { bands, row_sums } = workspace;
    let measured = target.depth.par_iter().filter(|d| **d > 0.0).count();
    let depth_inv = if measured > 0 {
        1.0 / measured as f32
    } else {
        0.0
    };
    let inv3 = 1.0 / (3 * n) as f32;
    let colour_gain = COLOUR_WEIGHT * inv3;
    let ssim_gain = f32x8::splat(-SSIM_WEIGHT / 3.0 / n as f32);
    let k = window::<f32>().map(f32x8::splat);
    let row_len = width * CHANNELS;
    colour_grad
        .par_chunks_mut(band_rows * row_len)
        .zip(depth_grad.par_chunks_mut(band_rows * width))
        .zip(row_sums.par_chunks_mut(band_rows))
        .zip(bands.par_iter_mut())
        .enumerate()
        .for_each(|(index, (((grads, depth_grads), sums), scratch))| {
            let rows = index * band_rows..(index * band_rows + sums.len());
            for (offset, sum) in sums.iter_mut().enumerate() {
                let depth = (rows.start + offset) * width..(rows.start + offset + 1) * width;
                sum[2] = l1_term(
                    &rendered.depth[depth.clone()],
                    &target.depth[depth],
                    &mut depth_grads[offset * width..(offset + 1) * width],
                    depth_inv,
                    true,
                );
            }
            let mut band = Band {
                x_img: rendered.colour,
                y_img: target.colour,
                layout,
                k,
                colour_gain,
                scratch,
            };
            band.run(rows, grads, sums, ssim_gain);
        });
    // Sums in row order: the same whatever the bands were.
    let [ssim, colour_l1, depth_l1] = row_sums.iter().fold([0.0f64; 3], |acc, s| {
        [acc[0] + s[0], acc[1] + s[1], acc[2] + s[2]]
    });
    [
        (depth_l1 * f64::from(depth_inv)) as f32,
        (colour_l1 * f64::from(inv3)) as f32,
        (ssim / (3 * n) as f64) as f32,
    ]
}
