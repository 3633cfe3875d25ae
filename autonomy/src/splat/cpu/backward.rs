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

fn tile_backward(
    splats: &[Splat],
    list: &[u32],
    inputs: &TileInputs,
    x0: usize,
    y0: usize,
    out: &mut [(ScreenGradient, bool)],
) {
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
                for ch in 0..3 {
                    acc[4 + ch] += grad[ch] * weight;
                }
                acc[7] += grad[3] * weight;
                // The 0.99 clamp cuts the gradient to the Gaussian's shape and opacity.
                let smooth = raw.cmp_le(max_alpha);
                let d_q = smooth.blend(d_alpha * a * f32x8::splat(-0.5), f32x8::ZERO);
                let inv_r2 = f32x8::splat(s.inv_radius2);
                acc[0] += d_q * f32x8::splat(-2.0) * dx * inv_r2;
                acc[1] += d_q * f32x8::splat(-2.0) * dy * inv_r2;
                acc[2] += d_q * f32x8::splat(-2.0 / s.radius) * (dx * dx + dy * dy) * inv_r2;
                acc[3] += smooth.blend(d_alpha * a * f32x8::splat(1.0 / s.opacity), f32x8::ZERO);
            }
        }
        out[position] = (acc.map(|v| v.reduce_add()), contributed);
    }
}

/// Screen-space gradient of every splat, and whether it contributed to any pixel.
pub fn screen_gradients(render: &Render, g: &ImageGradients) -> Vec<(ScreenGradient, bool)> {
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
    work.into_par_iter().for_each(|(t, out)| {
        let list = tiles.list(t);
        if list.is_empty() {
            return;
        }
        let (x0, y0) = ((t % tiles.tiles_x) * TILE, (t / tiles.tiles_x) * TILE);
        let inputs = tile_inputs(render, g, x0, y0);
        tile_backward(&render.splats, list, &inputs, x0, y0, out);
    });
    let mut screen = vec![([0.0f32; 8], false); render.splats.len()];
    for (slot, (entry, contributed)) in tiles.entries.iter().zip(&per_entry) {
        let (s, touched) = &mut screen[*slot as usize];
        for (a, b) in s.iter_mut().zip(entry) {
            *a += b;
        }
        *touched |= contributed;
    }
    screen
}
