//! Back-to-front gradients, tile by tile: each (tile, splat) entry of the lists gets its own
//! screen-space gradient (no atomics), then the entries are summed per splat.

use super::forward::{alpha, footprint, lane_offsets, CHUNKS, CHUNKS_PER_ROW, LANES};
use super::project::{ScreenGradient, Splat};
use super::Render;
use crate::splat::{ImageGradients, MAX_ALPHA, MIN_ALPHA, TILE};
use rayon::prelude::*;
use wide::{f32x8, CmpGe, CmpLe, CmpLt};

fn gather(values: &[f32], stride: usize, channel: usize, p0: usize, lanes: usize) -> f32x8 {
    let mut a = [0.0; LANES];
    for (l, v) in a.iter_mut().enumerate().take(lanes) {
        *v = values[(p0 + l) * stride + channel];
    }
    f32x8::new(a)
}

/// Per-pixel inputs of one tile, as SIMD chunks.
struct TileInputs {
    grad: [[f32x8; 5]; CHUNKS],
    transmittance: [f32x8; CHUNKS],
    count: [f32x8; CHUNKS],
}

fn tile_inputs(render: &Render, g: &ImageGradients, x0: usize, y0: usize) -> TileInputs {
    let (w, h) = (render.images.width, render.images.height);
    let mut inputs = TileInputs {
        grad: [[f32x8::ZERO; 5]; CHUNKS],
        transmittance: [f32x8::ONE; CHUNKS],
        count: [f32x8::ZERO; CHUNKS],
    };
    for c in 0..CHUNKS {
        let y = y0 + c / CHUNKS_PER_ROW;
        let xb = x0 + (c % CHUNKS_PER_ROW) * LANES;
        if y >= h || xb >= w {
            continue;
        }
        let lanes = LANES.min(w - xb);
        let p0 = y * w + xb;
        inputs.grad[c] = [
            gather(&g.colour, 3, 0, p0, lanes),
            gather(&g.colour, 3, 1, p0, lanes),
            gather(&g.colour, 3, 2, p0, lanes),
            gather(&g.depth, 1, 0, p0, lanes),
            gather(&g.silhouette, 1, 0, p0, lanes),
        ];
        inputs.transmittance[c] = gather(&render.final_transmittance, 1, 0, p0, lanes);
        let counts = render.contributor_count[p0..p0 + lanes]
            .iter()
            .map(|&n| n as f32);
        let mut a = [0.0; LANES];
        for (slot, n) in a.iter_mut().zip(counts) {
            *slot = n;
        }
        inputs.count[c] = f32x8::new(a);
    }
    inputs
}

/// How a splat's screen-space gradient becomes its parameters' (the chain rule of
/// `chain_to_parameters`, as the coefficients the Fisher pass applies to every pixel).
#[derive(Debug, Clone, Copy)]
pub struct Chain {
    /// fx, fy of the camera.
    pub focal: [f32; 2],
    /// The camera's rotation into the world (row-major).
    pub rotation: [[f32; 3]; 3],
}

/// What a backward pass sums.
#[derive(Debug, Clone, Copy)]
pub enum Mode<'a> {
    /// Screen-space gradients per splat (the chain rule follows once per splat).
    Gradient,
    /// Per splat, the squared per-pixel parameter gradients (the Fisher diagonal).
    Fisher(&'a Chain),
    /// Per pixel, the gradient with respect to a camera motion tau in se(3); the pass returns
    /// the sum of their outer products, J_tau^T J_tau.
    Pose(&'a Chain),
    /// Both the Fisher diagonal and J_tau^T J_tau, in one walk over the lists.
    FisherAndPose(&'a Chain),
}

impl Chain {
    /// Per splat: d mean_camera_j / d (u, v, radius, depth) for j = x, y, z.
    fn camera_coefficients(&self, s: &Splat) -> [[f32; 4]; 3] {
        let [fx, fy] = self.focal;
        let [px, py, pz] = s.camera_point;
        let world_radius = s.radius * pz / fx;
        let inv_z2 = 1.0 / (pz * pz);
        [
            [fx / pz, 0.0, 0.0, 0.0],
            [0.0, fy / pz, 0.0, 0.0],
            [
                -fx * px * inv_z2,
                -fy * py * inv_z2,
                -fx * world_radius * inv_z2,
                1.0,
            ],
        ]
    }

    /// Per splat: d mean_world_j / d (u, v, radius, depth) for j = x, y, z, then d log-radius
    /// / d radius and d logit-opacity / d opacity.
    fn coefficients(&self, s: &Splat) -> ([[f32; 4]; 3], f32, f32) {
        // d camera = (s0 fx / z, s1 fy / z, s7 - (s0 fx px + s1 fy py + s2 fx wr) / z^2).
        let camera = self.camera_coefficients(s);
        let mut world = [[0.0f32; 4]; 3];
        for (j, row) in world.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|k| self.rotation[j][k] * camera[k][c]).sum();
            }
        }
        (world, s.radius, s.opacity * (1.0 - s.opacity))
    }
}

/// One tile's backward pass in `mode`; returns the tile's J_tau^T J_tau in the pose mode
/// (zero otherwise).
fn tile_backward(
    splats: &[Splat],
    list: &[u32],
    inputs: &TileInputs,
    x0: usize,
    y0: usize,
    mode: Mode<'_>,
    out: &mut [(ScreenGradient, bool)],
) -> [[f64; 6]; 6] {
    let mut pose = [[f32x8::ZERO; 6]; CHUNKS];
    let mut transmittance = inputs.transmittance;
    let mut behind = [[f32x8::ZERO; 5]; CHUNKS];
    let max_count = inputs
        .count
        .iter()
        .map(|c| c.to_array().into_iter().fold(0.0f32, f32::max))
        .fold(0.0, f32::max) as usize;
    let (min_alpha, max_alpha) = (
        f32x8::splat(MIN_ALPHA as f32),
        f32x8::splat(MAX_ALPHA as f32),
    );
    for position in (0..max_count.min(list.len())).rev() {
        let s = &splats[list[position] as usize];
        let Some((r0, r1, c0, c1)) = footprint(s, x0, y0) else {
            continue;
        };
        let values = [s.colour[0], s.colour[1], s.colour[2], s.depth, 1.0].map(f32x8::splat);
        let rank = f32x8::splat(position as f32);
        let mut acc = [f32x8::ZERO; 8];
        let (coefficients, camera) = match mode {
            Mode::Gradient => (None, None),
            Mode::Fisher(c) => (Some(c.coefficients(s)), None),
            Mode::Pose(c) => (None, Some(c.camera_coefficients(s))),
            Mode::FisherAndPose(c) => (Some(c.coefficients(s)), Some(c.camera_coefficients(s))),
        };
        let mut contributed = false;
        for row in r0..=r1 {
            let y = (y0 + row) as f32;
            for col in c0..=c1 {
                let c = row * CHUNKS_PER_ROW + col;
                let xs = lane_offsets() + f32x8::splat((x0 + col * LANES) as f32);
                let (a, raw, dx, dy) = alpha(s, xs, y);
                let valid = a.cmp_ge(min_alpha) & rank.cmp_lt(inputs.count[c]);
                if !valid.any() {
                    continue;
                }
                contributed = true;
                // Transmittance in front of this splat, undone from the one behind it.
                let t = valid.blend(transmittance[c] / (f32x8::ONE - a), transmittance[c]);
                transmittance[c] = t;
                let weight = valid.blend(a * t, f32x8::ZERO);
                let grad = &inputs.grad[c];
                let mut d_alpha = f32x8::ZERO;
                for ch in 0..5 {
                    d_alpha += grad[ch] * (values[ch] - behind[c][ch]);
                    behind[c][ch] = valid.blend(
                        a * values[ch] + (f32x8::ONE - a) * behind[c][ch],
                        behind[c][ch],
                    );
                }
                let d_alpha = valid.blend(d_alpha * t, f32x8::ZERO);
                // The 0.99 clamp cuts the gradient to the Gaussian's shape and opacity.
                let smooth = raw.cmp_le(max_alpha);
                let d_q = smooth.blend(d_alpha * a * f32x8::splat(-0.5), f32x8::ZERO);
                let inv_r2 = f32x8::splat(s.inv_radius2);
                let screen = [
                    d_q * f32x8::splat(-2.0) * dx * inv_r2,
                    d_q * f32x8::splat(-2.0) * dy * inv_r2,
                    d_q * f32x8::splat(-2.0 / s.radius) * (dx * dx + dy * dy) * inv_r2,
                    smooth.blend(d_alpha * a * f32x8::splat(1.0 / s.opacity), f32x8::ZERO),
                    grad[0] * weight,
                    grad[1] * weight,
                    grad[2] * weight,
                    grad[3] * weight,
                ];
                if let Some(rows) = &camera {
                    // d mu_cam / d tau = [I | -[mu_cam]x]: translation d, rotation mu x d.
                    let [su, sv, sr, _, _, _, _, sd] = screen;
                    let d = rows.map(|r| {
                        su * f32x8::splat(r[0])
                            + sv * f32x8::splat(r[1])
                            + sr * f32x8::splat(r[2])
                            + sd * f32x8::splat(r[3])
                    });
                    let [px, py, pz] = s.camera_point.map(f32x8::splat);
                    let j = &mut pose[c];
                    j[0] += d[0];
                    j[1] += d[1];
                    j[2] += d[2];
                    j[3] += py * d[2] - pz * d[1];
                    j[4] += pz * d[0] - px * d[2];
                    j[5] += px * d[1] - py * d[0];
                }
                match &coefficients {
                    None if camera.is_none() => {
                        for (a, v) in acc.iter_mut().zip(screen) {
                            *a += v;
                        }
                    }
                    None => {}
                    Some((world, d_radius, d_opacity)) => {
                        let [su, sv, sr, _, _, _, _, sd] = screen;
                        for (j, row) in world.iter().enumerate() {
                            let m = su * f32x8::splat(row[0])
                                + sv * f32x8::splat(row[1])
                                + sr * f32x8::splat(row[2])
                                + sd * f32x8::splat(row[3]);
                            acc[j] += m * m;
                        }
                        let r = sr * f32x8::splat(*d_radius);
                        let o = screen[3] * f32x8::splat(*d_opacity);
                        acc[3] += r * r;
                        acc[4] += o * o;
                        for ch in 0..3 {
                            acc[5 + ch] += screen[4 + ch] * screen[4 + ch];
                        }
                    }
                }
            }
        }
        out[position] = (acc.map(|v| v.reduce_add()), contributed);
    }
    let mut jtj = [[0.0f64; 6]; 6];
    if matches!(mode, Mode::Pose(_) | Mode::FisherAndPose(_)) {
        for j in &pose {
            let lanes = j.map(|v| v.to_array());
            for l in 0..LANES {
                for (r, row) in jtj.iter_mut().enumerate() {
                    for (c, v) in row.iter_mut().enumerate() {
                        *v += f64::from(lanes[r][l]) * f64::from(lanes[c][l]);
                    }
                }
            }
        }
    }
    jtj
}

/// Screen-space gradient of every splat, and whether it contributed to any pixel (in the
/// Fisher mode each splat's Fisher diagonal, parameter order of `FISHER_PARAMETERS`); and
/// J_tau^T J_tau in the pose mode.
pub fn screen_gradients(
    render: &Render,
    g: &ImageGradients,
    mode: Mode<'_>,
) -> (Vec<(ScreenGradient, bool)>, [[f64; 6]; 6]) {
    let tiles = &render.tiles;
    let mut per_entry = vec![([0.0f32; 8], false); tiles.entries.len()];
    // Split the entry gradients into each tile's disjoint range.
    let mut rest = per_entry.as_mut_slice();
    let mut work = Vec::with_capacity(tiles.tiles_x * tiles.tiles_y);
    for t in 0..tiles.tiles_x * tiles.tiles_y {
        let (head, tail) = rest.split_at_mut(tiles.offsets[t + 1] - tiles.offsets[t]);
        work.push((t, head));
        rest = tail;
    }
    let jtj = work
        .into_par_iter()
        .map(|(t, out)| {
            let list = tiles.list(t);
            if list.is_empty() {
                return [[0.0; 6]; 6];
            }
            let (x0, y0) = ((t % tiles.tiles_x) * TILE, (t / tiles.tiles_x) * TILE);
            let inputs = tile_inputs(render, g, x0, y0);
            tile_backward(&render.splats, list, &inputs, x0, y0, mode, out)
        })
        .reduce(
            || [[0.0; 6]; 6],
            |mut a, b| {
                for (ra, rb) in a.iter_mut().zip(b) {
                    for (x, y) in ra.iter_mut().zip(rb) {
                        *x += y;
                    }
                }
                a
            },
        );
    let mut screen = vec![([0.0f32; 8], false); render.splats.len()];
    for (slot, (entry, contributed)) in tiles.entries.iter().zip(&per_entry) {
        let (s, touched) = &mut screen[*slot as usize];
        for (a, b) in s.iter_mut().zip(entry) {
            *a += b;
        }
        *touched |= contributed;
    }
    (screen, jtj)
}
