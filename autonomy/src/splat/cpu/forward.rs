//! Front-to-back compositing, one tile per rayon task, 8 pixels per SIMD step.

use super::project::Splat;
use super::tiles::TileLists;
use crate::camera::Intrinsics;
use crate::splat::{Images, MAX_ALPHA, MIN_ALPHA, MIN_TRANSMITTANCE, TILE};
use rayon::prelude::*;
use wide::{f32x8, CmpGe, CmpLt};

/// Pixels per SIMD vector.
pub const LANES: usize = 8;
/// SIMD vectors per tile row.
pub const CHUNKS_PER_ROW: usize = TILE / LANES;
/// SIMD vectors per tile.
pub const CHUNKS: usize = TILE * CHUNKS_PER_ROW;

/// Lane offsets 0..8 as floats.
pub fn lane_offsets() -> f32x8 {
    f32x8::new([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0])
}

/// Alpha of `s` at 8 pixels `(xs, y)`: (clamped alpha, raw alpha, dx, dy); both passes call
/// this so they agree bit for bit.
#[inline(always)]
pub fn alpha(s: &Splat, xs: f32x8, y: f32) -> (f32x8, f32x8, f32x8, f32x8) {
    let dx = xs - f32x8::splat(s.u);
    let dy = f32x8::splat(y - s.v);
    let q = (dx * dx + dy * dy) * f32x8::splat(s.inv_radius2);
    let raw = f32x8::splat(s.opacity) * (q * f32x8::splat(-0.5)).exp();
    (raw.min(f32x8::splat(MAX_ALPHA as f32)), raw, dx, dy)
}

/// Rows (inclusive, tile-relative) and chunk columns of tile (x0, y0) that `s` can touch.
#[inline(always)]
pub fn footprint(s: &Splat, x0: usize, y0: usize) -> Option<(usize, usize, usize, usize)> {
    let top = (s.v - s.extent).ceil() - y0 as f32;
    let bottom = (s.v + s.extent).floor() - y0 as f32;
    let left = (s.u - s.extent).ceil() - x0 as f32;
    let right = (s.u + s.extent).floor() - x0 as f32;
    let last = (TILE - 1) as f32;
    if bottom < 0.0 || right < 0.0 || top > last || left > last {
        return None;
    }
    let r0 = top.max(0.0) as usize;
    let r1 = bottom.min(last) as usize;
    let c0 = left.max(0.0) as usize / LANES;
    let c1 = right.min(last) as usize / LANES;
    Some((r0, r1, c0, c1))
}

/// Whether each lane of chunk (row, col) of tile (x0, y0) lies inside the image.
pub fn inside_mask(x0: usize, y0: usize, row: usize, col: usize, w: usize, h: usize) -> f32x8 {
    let xs = lane_offsets() + f32x8::splat((x0 + col * LANES) as f32);
    let in_x = xs.cmp_lt(f32x8::splat(w as f32));
    if y0 + row < h {
        in_x
    } else {
        f32x8::ZERO
    }
}

struct TileOutput {
    colour: [[f32x8; 3]; CHUNKS],
    depth: [f32x8; CHUNKS],
    silhouette: [f32x8; CHUNKS],
    transmittance: [f32x8; CHUNKS],
    count: [f32x8; CHUNKS],
}

fn composite_tile(
    splats: &[Splat],
    list: &[u32],
    x0: usize,
    y0: usize,
    w: usize,
    h: usize,
) -> TileOutput {
    let mut out = TileOutput {
        colour: [[f32x8::ZERO; 3]; CHUNKS],
        depth: [f32x8::ZERO; CHUNKS],
        silhouette: [f32x8::ZERO; CHUNKS],
        transmittance: [f32x8::ONE; CHUNKS],
        count: [f32x8::ZERO; CHUNKS],
    };
    // done: lanes outside the image, or whose transmittance ran out.
    let mut done = [f32x8::ZERO; CHUNKS];
    let mut chunks_done = 0;
    for (c, d) in done.iter_mut().enumerate() {
        *d = !inside_mask(x0, y0, c / CHUNKS_PER_ROW, c % CHUNKS_PER_ROW, w, h);
        chunks_done += usize::from(d.all());
    }
    let (min_alpha, min_t) = (
        f32x8::splat(MIN_ALPHA as f32),
        f32x8::splat(MIN_TRANSMITTANCE as f32),
    );
    for (position, &slot) in list.iter().enumerate() {
        if chunks_done == CHUNKS {
            break;
        }
        let s = &splats[slot as usize];
        let Some((r0, r1, c0, c1)) = footprint(s, x0, y0) else {
            continue;
        };
        let position = f32x8::splat((position + 1) as f32);
        for row in r0..=r1 {
            let y = (y0 + row) as f32;
            for col in c0..=c1 {
                let c = row * CHUNKS_PER_ROW + col;
                if done[c].all() {
                    continue;
                }
                let xs = lane_offsets() + f32x8::splat((x0 + col * LANES) as f32);
                let (a, _, _, _) = alpha(s, xs, y);
                let valid = a.cmp_ge(min_alpha) & !done[c];
                if !valid.any() {
                    continue;
                }
                let t = out.transmittance[c];
                let next = t * (f32x8::ONE - a);
                let stop = valid & next.cmp_lt(min_t);
                let include = valid & !stop;
                let weight = include.blend(a * t, f32x8::ZERO);
                for (channel, value) in out.colour[c].iter_mut().zip(s.colour) {
                    *channel += weight * f32x8::splat(value);
                }
                out.depth[c] += weight * f32x8::splat(s.depth);
                out.silhouette[c] += weight;
                out.transmittance[c] = include.blend(next, t);
                out.count[c] = include.blend(position, out.count[c]);
                if stop.any() {
                    done[c] |= stop;
                    chunks_done += usize::from(done[c].all());
                }
            }
        }
    }
    out
}

/// Composites every tile; returns the images, the final transmittance and the contributor
/// count of each pixel.
pub fn composite(
    splats: &[Splat],
    tiles: &TileLists,
    k: &Intrinsics,
) -> (Images, Vec<f32>, Vec<u32>) {
    let (w, h) = (k.width as usize, k.height as usize);
    let outputs: Vec<TileOutput> = (0..tiles.tiles_x * tiles.tiles_y)
        .into_par_iter()
        .map(|t| {
            let (x0, y0) = ((t % tiles.tiles_x) * TILE, (t / tiles.tiles_x) * TILE);
            composite_tile(splats, tiles.list(t), x0, y0, w, h)
        })
        .collect();
    let mut images = Images::zeros(w, h);
    let mut transmittance = vec![1.0; w * h];
    let mut count = vec![0u32; w * h];
    for (t, out) in outputs.iter().enumerate() {
        let (x0, y0) = ((t % tiles.tiles_x) * TILE, (t / tiles.tiles_x) * TILE);
        for c in 0..CHUNKS {
            let y = y0 + c / CHUNKS_PER_ROW;
            if y >= h {
                break;
            }
            let xb = x0 + (c % CHUNKS_PER_ROW) * LANES;
            let lanes = LANES.min(w.saturating_sub(xb));
            let rgb = out.colour[c].map(|v| v.to_array());
            let (d, s, tr, n) = (
                out.depth[c].to_array(),
                out.silhouette[c].to_array(),
                out.transmittance[c].to_array(),
                out.count[c].to_array(),
            );
            for l in 0..lanes {
                let p = y * w + xb + l;
                for ch in 0..3 {
                    images.colour[3 * p + ch] = rgb[ch][l];
                }
                images.depth[p] = d[l];
                images.silhouette[p] = s[l];
                transmittance[p] = tr[l];
                count[p] = n[l] as u32;
            }
        }
    }
    (images, transmittance, count)
}
