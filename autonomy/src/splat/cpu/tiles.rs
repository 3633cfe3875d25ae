//! Binning splats into 16x16 tiles and sorting each tile's list front to back by a 32-bit
//! depth key (the bits of a positive f32 order like the float), ties by index.

use super::project::Splat;
use crate::camera::Intrinsics;
use crate::splat::TILE;
use rayon::prelude::*;

/// Per-tile lists of splat slots, concatenated; `offsets[t]..offsets[t + 1]` is tile t's list.
#[derive(Debug, Clone, Default)]
pub struct TileLists {
    /// Tiles across.
    pub tiles_x: usize,
    /// Tiles down.
    pub tiles_y: usize,
    /// Start of each tile's list in `entries` (tiles + 1 values).
    pub offsets: Vec<usize>,
    /// Slots into the splat array, depth-sorted within each tile.
    pub entries: Vec<u32>,
}

/// Inclusive tile rectangle a splat's footprint covers.
fn tile_rect(s: &Splat, tiles_x: usize, tiles_y: usize) -> (usize, usize, usize, usize) {
    let clamp = |v: f32, n: usize| (v.max(0.0) as usize / TILE).min(n - 1);
    (
        clamp(s.u - s.extent, tiles_x),
        clamp(s.u + s.extent, tiles_x),
        clamp(s.v - s.extent, tiles_y),
        clamp(s.v + s.extent, tiles_y),
    )
}

impl TileLists {
    /// Bins and sorts.
    pub fn build(splats: &[Splat], intrinsics: &Intrinsics) -> Self {
        let tiles_x = (intrinsics.width as usize).div_ceil(TILE);
        let tiles_y = (intrinsics.height as usize).div_ceil(TILE);
        let tile_count = tiles_x * tiles_y;
        // Count, prefix-sum, fill: the classic two-pass bucket layout.
        let mut offsets = vec![0usize; tile_count + 1];
        for s in splats {
            let (x0, x1, y0, y1) = tile_rect(s, tiles_x, tiles_y);
            for ty in y0..=y1 {
                for tx in x0..=x1 {
                    offsets[ty * tiles_x + tx + 1] += 1;
                }
            }
        }
        for t in 0..tile_count {
            offsets[t + 1] += offsets[t];
        }
        let mut keys = vec![0u64; offsets[tile_count]];
        let mut cursor = offsets.clone();
        for (slot, s) in splats.iter().enumerate() {
            let key = (u64::from(s.depth.to_bits()) << 32) | slot as u64;
            let (x0, x1, y0, y1) = tile_rect(s, tiles_x, tiles_y);
            for ty in y0..=y1 {
                for tx in x0..=x1 {
                    let t = ty * tiles_x + tx;
                    keys[cursor[t]] = key;
                    cursor[t] += 1;
                }
            }
        }
        // Sort each tile's list in parallel; the slot in the low bits breaks depth ties.
        let mut rest = keys.as_mut_slice();
        let mut lists = Vec::with_capacity(tile_count);
        for t in 0..tile_count {
            let (head, tail) = rest.split_at_mut(offsets[t + 1] - offsets[t]);
            lists.push(head);
            rest = tail;
        }
        lists.into_par_iter().for_each(|list| list.sort_unstable());
        let entries = keys.iter().map(|k| *k as u32).collect();
        TileLists {
            tiles_x,
            tiles_y,
            offsets,
            entries,
        }
    }

    /// The sorted slots of tile `t`.
    pub fn list(&self, t: usize) -> &[u32] {
        &self.entries[self.offsets[t]..self.offsets[t + 1]]
    }
}
