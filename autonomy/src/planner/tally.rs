//! Running sums over the planner's Gaussians: the uncertainty statistics that set the
//! high / low thresholds, and each region's count, centroid and mean uncertainty (Omega). They follow
//! the mirror's changes, so a plan reads them without a pass over the map.
//!
//! The sums are fixed-point integers: exact, so adding and removing Gaussians in any order
//! gives the same totals as summing afresh, and episodes repeat bit for bit.

use super::graph::Region;
use super::mirror::{Change, Record};
use crate::map::UncertaintyStats;
use std::collections::BTreeMap;

/// Fixed-point units per metre of uncertainty.
const SCALE: f64 = 4_294_967_296.0;
/// Uncertainties are clamped to this (metres) so the sums cannot overflow.
const MAX_UNCERTAINTY: f64 = 256.0;
/// Fixed-point units per metre of position (about a micrometre).
const POSITION_SCALE: f64 = 1_048_576.0;

/// One region's sums.
#[derive(Debug, Clone, Copy, Default)]
struct RegionSums {
    uncertainty: i128,
    position: [i128; 3],
    count: i64,
}

fn quantise(u: f32) -> i128 {
    // NaN becomes 0 (the mapper refuses NaN; this only keeps the sums finite).
    (f64::from(u).clamp(0.0, MAX_UNCERTAINTY) * SCALE).round() as i128
}

/// The statistics of the included Gaussians' uncertainty and the regions they fall in.
#[derive(Debug, Clone)]
pub struct Tally {
    region_size: f64,
    sum: i128,
    sum_sq: i128,
    count: i64,
    /// Region (z, y, x lattice index, so regions come out z-major) -> its sums.
    regions: BTreeMap<[i32; 3], RegionSums>,
}

impl Tally {
    /// Empty sums; regions are the cubes of side `region_size` of a lattice anchored at the
    /// world origin, so a region keeps its place (and its viewpoints) as the map grows.
    pub fn new(region_size: f64) -> Self {
        Tally {
            region_size,
            sum: 0,
            sum_sq: 0,
            count: 0,
            regions: BTreeMap::new(),
        }
    }

    /// Applies the mirror's changes.
    pub fn apply(&mut self, changes: &[Change]) {
        for c in changes {
            if let Some(r) = &c.old {
                self.add(r, -1);
            }
            if let Some(r) = &c.new {
                self.add(r, 1);
            }
        }
    }

    fn add(&mut self, r: &Record, sign: i64) {
        let q = quantise(r.uncertainty) * i128::from(sign);
        let q_sq = quantise(r.uncertainty).pow(2) * i128::from(sign);
        self.sum += q;
        self.sum_sq += q_sq;
        self.count += sign;
        let k = |v: f32| (f64::from(v) / self.region_size).floor() as i32;
        let key = [k(r.mean[2]), k(r.mean[1]), k(r.mean[0])];
        let entry = self.regions.entry(key).or_default();
        entry.uncertainty += q;
        for a in 0..3 {
            // Positions saturate far beyond any map (f64 -> int casts clamp).
            let p = (f64::from(r.mean[a]) * POSITION_SCALE).round() as i64;
            entry.position[a] += i128::from(p) * i128::from(sign);
        }
        entry.count += sign;
        if entry.count == 0 {
            self.regions.remove(&key);
        }
    }

    /// Gaussians counted.
    pub fn count(&self) -> usize {
        self.count.max(0) as usize
    }

    /// Mean and standard deviation of the counted uncertainties.
    pub fn stats(&self) -> UncertaintyStats {
        if self.count <= 0 {
            return UncertaintyStats::default();
        }
        let n = self.count as f64;
        let mean = self.sum as f64 / SCALE / n;
        // n^2 var = n sum(q^2) - sum(q)^2, exactly in integers where it fits.
        let spread = i128::from(self.count)
            .checked_mul(self.sum_sq)
            .and_then(|a| self.sum.checked_mul(self.sum).map(|b| a - b));
        let var = match spread {
            Some(s) => s.max(0) as f64 / (n * n * SCALE * SCALE),
            None => (self.sum_sq as f64 / (SCALE * SCALE) / n - mean * mean).max(0.0),
        };
        UncertaintyStats {
            mean: mean as f32,
            std: var.sqrt() as f32,
            count: self.count(),
        }
    }

    /// The occupied regions, z-major, each with its Gaussians' mean uncertainty.
    pub fn regions(&self) -> Vec<Region> {
        let size = self.region_size;
        self.regions
            .iter()
            .map(|(key, sums)| {
                let n = sums.count as f64;
                Region {
                    centre: [key[2], key[1], key[0]].map(|k| (f64::from(k) + 0.5) * size),
                    centroid: sums.position.map(|p| p as f64 / POSITION_SCALE / n),
                    count: sums.count as usize,
                    omega: sums.uncertainty as f64 / SCALE / n,
                }
            })
            .collect()
    }
}
