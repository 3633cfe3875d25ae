//! The floor plan of a compiled world: a grid of 5 cm cells over the world, which cells an
//! obstacle covers at the heights the robot occupies, how far each cell is from the nearest
//! obstacle, and which cells the robot can reach from a pose. Built from MuJoCo's own compiled
//! geometry (every collidable geom's pose and shape), so it holds for hand-made, generated and
//! imported worlds alike.

pub mod footprint;

use crate::error::{Result, SimError};
use crate::robot::Pose2;
use crate::world::World;
use footprint::Footprint;
use std::collections::VecDeque;

/// Side of a floor-plan cell, metres.
pub const CELL: f64 = 0.05;

/// Space the robot keeps from obstacles beyond its own radius, metres.
pub const ROBOT_MARGIN: f64 = 0.05;

/// Heights below this are the floor (wheel contact), not an obstacle, metres.
const FLOOR_BAND: f64 = 0.02;

/// Empty space kept around the world's geoms, so the grid's border is outside the world.
const BORDER: f64 = 1.0;

/// The most cells a plan may hold (a 200 m square at 5 cm); larger worlds get coarser cells.
const MAX_CELLS: usize = 16_000_000;

/// The grid over a world with what stands on it.
#[derive(Debug, Clone)]
pub struct FloorPlan {
    /// World x-y of the first cell's lower corner.
    pub origin: [f64; 2],
    /// Cell side, metres.
    pub cell: f64,
    /// Cells along x and y.
    pub size: [usize; 2],
    /// The robot's radius plus the margin: the clearance a cell needs to be free, metres.
    pub clearance_needed: f64,
    /// Whether an obstacle covers some of the cell at the robot's heights.
    occupied: Vec<bool>,
    /// Distance from the cell's centre to the nearest obstacle, metres (estimated from the
    /// nearest occupied cell: the centre-to-centre distance less half a cell).
    clearance: Vec<f32>,
    /// Footprints of the world's collidable geoms.
    pub footprints: Vec<Footprint>,
}

impl FloorPlan {
    /// The floor plan of `world`'s geoms (the robot's own excluded) at the state it holds.
    pub fn of(world: &World) -> Result<Self> {
        let model = world.model();
        let data = world.data();
        let robot = world.robot();
        // The robot's reach: its footprint radius around the body and its top.
        let body = data.body_position(robot.body);
        let (mut radius, mut top) = (0.0f64, 0.0f64);
        let mut footprints = Vec::new();
        for geom in 0..model.geom_count() {
            if !model.geom_collides(geom) {
                continue;
            }
            let Some(f) = Footprint::of(model, data, geom) else {
                continue;
            };
            if robot.owns_geom(geom) {
                for p in &f.polygon {
                    radius = radius.max((p[0] - body.x).hypot(p[1] - body.y));
                }
                top = top.max(f.z[1] - body.z);
            } else {
                footprints.push(f);
            }
        }
        let band = [FLOOR_BAND, top + ROBOT_MARGIN];
        let (mut lo, mut hi) = ([-1.0f64, -1.0], [1.0f64, 1.0]);
        for f in &footprints {
            let (a, b) = f.bounds();
            for k in 0..2 {
                lo[k] = lo[k].min(a[k]);
                hi[k] = hi[k].max(b[k]);
            }
        }
        let extent = [hi[0] - lo[0] + 2.0 * BORDER, hi[1] - lo[1] + 2.0 * BORDER];
        if !(extent[0].is_finite() && extent[1].is_finite()) || extent[0].max(extent[1]) > 5000.0 {
            return Err(SimError::InvalidArgument {
                what: "world",
                detail: format!(
                    "its geoms span {:.0} m x {:.0} m; a world for this robot is at most a few \
                     hundred metres across (wrong units?)",
                    extent[0], extent[1]
                ),
            });
        }
        let mut cell = CELL;
        while (extent[0] / cell).ceil() * (extent[1] / cell).ceil() > MAX_CELLS as f64 {
            cell *= 2.0;
        }
        let size = [
            (extent[0] / cell).ceil() as usize,
            (extent[1] / cell).ceil() as usize,
        ];
        let origin = [lo[0] - BORDER, lo[1] - BORDER];
        let mut occupied = vec![false; size[0] * size[1]];
        for f in &footprints {
            if f.z[1] > band[0] && f.z[0] < band[1] {
                rasterise(f, origin, cell, size, &mut occupied);
            }
        }
        let mut plan =
            FloorPlan::from_occupancy(origin, cell, size, occupied, radius + ROBOT_MARGIN);
        plan.footprints = footprints;
        Ok(plan)
    }

    /// A plan from an occupancy grid drawn by hand (tests, and tools that have no world):
    /// the clearances are computed as for a world's.
    pub fn from_occupancy(
        origin: [f64; 2],
        cell: f64,
        size: [usize; 2],
        occupied: Vec<bool>,
        clearance_needed: f64,
    ) -> Self {
        assert_eq!(occupied.len(), size[0] * size[1], "one flag per cell");
        let clearance = distance_transform(&occupied, size)
            .into_iter()
            .map(|d| ((d.sqrt() - 0.5) * cell).max(0.0) as f32)
            .collect();
        FloorPlan {
            origin,
            cell,
            size,
            clearance_needed,
            occupied,
            clearance,
            footprints: Vec::new(),
        }
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.occupied.len()
    }

    /// Whether the plan has no cells (never: every plan has a border).
    pub fn is_empty(&self) -> bool {
        self.occupied.is_empty()
    }

    /// The cell holding (x, y), if it is on the grid.
    pub fn cell_of(&self, x: f64, y: f64) -> Option<usize> {
        let i = ((x - self.origin[0]) / self.cell).floor();
        let j = ((y - self.origin[1]) / self.cell).floor();
        let inside =
            i >= 0.0 && j >= 0.0 && (i as usize) < self.size[0] && (j as usize) < self.size[1];
        inside.then(|| j as usize * self.size[0] + i as usize)
    }

    /// World x-y of a cell's centre.
    pub fn centre(&self, c: usize) -> [f64; 2] {
        [
            self.origin[0] + ((c % self.size[0]) as f64 + 0.5) * self.cell,
            self.origin[1] + ((c / self.size[0]) as f64 + 0.5) * self.cell,
        ]
    }

    /// Whether an obstacle covers part of cell `c` at the robot's heights.
    pub fn is_occupied(&self, c: usize) -> bool {
        self.occupied[c]
    }

    /// Distance from cell `c`'s centre to the nearest obstacle, metres.
    pub fn clearance(&self, c: usize) -> f64 {
        f64::from(self.clearance[c])
    }

    /// Whether the robot fits at cell `c` with its margin.
    pub fn is_free(&self, c: usize) -> bool {
        self.clearance(c) >= self.clearance_needed
    }

    /// The 8 neighbours of a cell that are on the grid.
    pub fn neighbours(&self, c: usize) -> impl Iterator<Item = usize> + '_ {
        let (i, j) = ((c % self.size[0]) as isize, (c / self.size[0]) as isize);
        let (w, h) = (self.size[0] as isize, self.size[1] as isize);
        (-1..=1)
            .flat_map(move |dj| (-1..=1).map(move |di| (i + di, j + dj)))
            .filter(move |&(x, y)| (x, y) != (i, j) && (0..w).contains(&x) && (0..h).contains(&y))
            .map(move |(x, y)| (y * w + x) as usize)
    }

    /// Whether a cell lies on the grid's outer edge (beyond every geom).
    pub fn on_border(&self, c: usize) -> bool {
        let (i, j) = (c % self.size[0], c / self.size[0]);
        i == 0 || j == 0 || i + 1 == self.size[0] || j + 1 == self.size[1]
    }

    /// Cells connected to `start` through cells that pass `open`, 8-connected; empty when
    /// `start` itself does not pass.
    pub fn flood(&self, start: usize, open: impl Fn(usize) -> bool) -> Vec<bool> {
        let mut reached = vec![false; self.len()];
        if !open(start) {
            return reached;
        }
        reached[start] = true;
        let mut queue = VecDeque::from([start]);
        while let Some(c) = queue.pop_front() {
            for n in self.neighbours(c) {
                if !reached[n] && open(n) {
                    reached[n] = true;
                    queue.push_back(n);
                }
            }
        }
        reached
    }

    /// Free cells the robot can drive to from (x, y).
    pub fn reachable_from(&self, x: f64, y: f64) -> Vec<bool> {
        match self.cell_of(x, y) {
            Some(c) => self.flood(c, |n| self.is_free(n)),
            None => vec![false; self.len()],
        }
    }

    /// Cells outside the world: connected to the grid's border without crossing an obstacle.
    pub fn outside(&self) -> Vec<bool> {
        let mut outside = vec![false; self.len()];
        let mut queue = VecDeque::new();
        for c in 0..self.len() {
            if self.on_border(c) && !self.occupied[c] {
                outside[c] = true;
                queue.push_back(c);
            }
        }
        while let Some(c) = queue.pop_front() {
            let (i, j) = (c % self.size[0], c / self.size[0]);
            // 4-connected: a diagonal step would slip through the corner where two walls meet.
            let mut step = |n: usize| {
                if !outside[n] && !self.occupied[n] {
                    outside[n] = true;
                    queue.push_back(n);
                }
            };
            if i > 0 {
                step(c - 1);
            }
            if i + 1 < self.size[0] {
                step(c + 1);
            }
            if j > 0 {
                step(c - self.size[0]);
            }
            if j + 1 < self.size[1] {
                step(c + self.size[0]);
            }
        }
        outside
    }

    /// Connected groups (8-connected) of the cells that pass `member`, each as its cells.
    pub fn components(&self, member: impl Fn(usize) -> bool) -> Vec<Vec<usize>> {
        let mut seen = vec![false; self.len()];
        let mut groups = Vec::new();
        for c in 0..self.len() {
            if seen[c] || !member(c) {
                continue;
            }
            let mut group = vec![c];
            seen[c] = true;
            let mut k = 0;
            while k < group.len() {
                let at = group[k];
                k += 1;
                for n in self.neighbours(at) {
                    if !seen[n] && member(n) {
                        seen[n] = true;
                        group.push(n);
                    }
                }
            }
            groups.push(group);
        }
        groups
    }

    /// Area of `cells` cells, m2.
    pub fn area(&self, cells: usize) -> f64 {
        cells as f64 * self.cell * self.cell
    }

    /// A pose drawn uniformly over the reachable cells with at least `clearance` metres of
    /// room (the most open cells when none has that much), heading uniform; `None` when no
    /// cell is reachable.
    pub fn sample_pose(
        &self,
        reachable: &[bool],
        clearance: f64,
        rng: &mut impl rand::Rng,
    ) -> Option<Pose2> {
        let cells: Vec<usize> = (0..self.len()).filter(|&c| reachable[c]).collect();
        let best = cells.iter().map(|&c| self.clearance(c)).fold(0.0, f64::max);
        let wanted = clearance.min(best);
        let roomy: Vec<usize> = cells
            .into_iter()
            .filter(|&c| self.clearance(c) >= wanted)
            .collect();
        if roomy.is_empty() {
            return None;
        }
        let c = roomy[rng.gen_range(0..roomy.len())];
        let [x, y] = self.centre(c);
        Some(Pose2 {
            x,
            y,
            theta: rng.gen_range(-std::f64::consts::PI..std::f64::consts::PI),
        })
    }
}

/// Marks the cells whose square the footprint's polygon overlaps.
fn rasterise(f: &Footprint, origin: [f64; 2], cell: f64, size: [usize; 2], occupied: &mut [bool]) {
    let (lo, hi) = f.bounds();
    let index = |v: f64, o: f64, n: usize| (((v - o) / cell).floor().max(0.0) as usize).min(n - 1);
    let (i0, i1) = (
        index(lo[0], origin[0], size[0]),
        index(hi[0], origin[0], size[0]),
    );
    let (j0, j1) = (
        index(lo[1], origin[1], size[1]),
        index(hi[1], origin[1], size[1]),
    );
    for j in j0..=j1 {
        for i in i0..=i1 {
            let x = origin[0] + i as f64 * cell;
            let y = origin[1] + j as f64 * cell;
            let square = [[x, y], [x + cell, y], [x + cell, y + cell], [x, y + cell]];
            if footprint::polygon_penetration(&square, &f.polygon) > 1e-9 {
                occupied[j * size[0] + i] = true;
            }
        }
    }
}

/// Squared Euclidean distance, in cells, from each cell to the nearest occupied one
/// (Felzenszwalb and Huttenlocher's two passes of the 1D lower envelope); infinite when
/// nothing is occupied.
pub fn distance_transform(occupied: &[bool], size: [usize; 2]) -> Vec<f64> {
    let [w, h] = size;
    let mut d: Vec<f64> = occupied
        .iter()
        .map(|&o| if o { 0.0 } else { f64::INFINITY })
        .collect();
    let mut line = Vec::new();
    for i in 0..w {
        line.clear();
        line.extend((0..h).map(|j| d[j * w + i]));
        let out = envelope(&line);
        for j in 0..h {
            d[j * w + i] = out[j];
        }
    }
    for j in 0..h {
        let out = envelope(&d[j * w..(j + 1) * w]);
        d[j * w..(j + 1) * w].copy_from_slice(&out);
    }
    d
}

/// One dimension of the distance transform: min over q of (p - q)^2 + f(q).
fn envelope(f: &[f64]) -> Vec<f64> {
    let n = f.len();
    let mut out = vec![f64::INFINITY; n];
    let mut hull: Vec<usize> = Vec::with_capacity(n);
    let mut starts: Vec<f64> = Vec::with_capacity(n + 1);
    for q in 0..n {
        if !f[q].is_finite() {
            continue;
        }
        let meet = |p: usize| {
            ((f[q] + (q * q) as f64) - (f[p] + (p * p) as f64)) / (2.0 * (q as f64 - p as f64))
        };
        while let Some(&p) = hull.last() {
            if meet(p) <= starts[starts.len() - 1] {
                hull.pop();
                starts.pop();
            } else {
                break;
            }
        }
        let s = hull.last().map_or(f64::NEG_INFINITY, |&p| meet(p));
        hull.push(q);
        starts.push(s);
    }
    if hull.is_empty() {
        return out;
    }
    let mut k = 0;
    for (p, o) in out.iter_mut().enumerate() {
        while k + 1 < hull.len() && starts[k + 1] <= p as f64 {
            k += 1;
        }
        let q = hull[k];
        *o = (p as f64 - q as f64).powi(2) + f[q];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_transform_equals_brute_force() {
        let size = [23, 17];
        let occupied: Vec<bool> = (0..size[0] * size[1])
            .map(|c| (c * 7919) % 37 == 0)
            .collect();
        let d = distance_transform(&occupied, size);
        for c in 0..occupied.len() {
            let (i, j) = ((c % size[0]) as f64, (c / size[0]) as f64);
            let brute = (0..occupied.len())
                .filter(|&o| occupied[o])
                .map(|o| ((o % size[0]) as f64 - i).powi(2) + ((o / size[0]) as f64 - j).powi(2))
                .fold(f64::INFINITY, f64::min);
            assert_eq!(d[c], brute, "cell {c}");
        }
    }
}
