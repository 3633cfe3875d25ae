//! The survey's route, from the world's exact floor plan: look-around points chosen by what a
//! full turn there would see that no earlier one saw, visited greedily by gain per metre, and
//! joined by shortest paths that keep to open floor.
//!
//! What a look-around sees is a 2D model of the camera turned through a full circle: rays in
//! every direction from the point, each ending at the first obstacle cell (at the robot's
//! heights) within the camera's range. The targets are the obstacle cells that face free
//! space inside the world: walls, furniture, legs. Points are candidates on a lattice over the
//! reachable floor with room to turn; a point is visited while its turn sees at least
//! `min_gain` new targets (half a metre of wall at 5 cm cells), so the route turns only where
//! it sees something new and ends when nothing reachable is left unseen.

use crate::floorplan::FloorPlan;
use autonomy::math::TotalF64;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// How the route is chosen.
#[derive(Debug, Clone, Copy)]
pub struct TourConfig {
    /// Room a look-around point keeps from obstacles, metres; paths may go closer (doors)
    /// but pay for it.
    pub clearance: f64,
    /// The camera's range, metres.
    pub range: f64,
    /// Rays of a look-around.
    pub rays: usize,
    /// Spacing of the candidate lattice, metres.
    pub spacing: f64,
    /// New targets a look-around must see to be worth its turn.
    pub min_gain: usize,
    /// A turn's cost in metres of driving (its duration at the survey's speed).
    pub turn_cost: f64,
    /// Path cost factor through cells with less than `clearance` of room.
    pub narrow_cost: f64,
}

impl Default for TourConfig {
    fn default() -> Self {
        TourConfig {
            clearance: 0.45,
            range: 5.0,
            rays: 720,
            spacing: 0.5,
            min_gain: 10,
            // A full turn at 0.9 rad/s takes 7 s; at 0.5 m/s that is 3.5 m of driving.
            turn_cost: std::f64::consts::TAU / 0.9 * 0.5,
            narrow_cost: 3.0,
        }
    }
}

/// The route: the look-around points in order, each with the path that reaches it.
#[derive(Debug, Clone, Default)]
pub struct Tour {
    /// Look-around points (world x, y), the start first.
    pub stops: Vec<[f64; 2]>,
    /// Cell centres from the previous stop to each stop (empty for the start).
    pub paths: Vec<Vec<[f64; 2]>>,
    /// Targets the route's look-arounds see.
    pub seen: usize,
    /// Targets a look-around from some candidate point would see.
    pub visible: usize,
    /// All targets (obstacle cells facing the inside).
    pub targets: usize,
}

/// Obstacle cells with a 4-neighbour that is free floor inside the world.
pub fn targets(plan: &FloorPlan, outside: &[bool]) -> Vec<usize> {
    let [w, h] = plan.size;
    (0..plan.len())
        .filter(|&c| {
            if !plan.is_occupied(c) {
                return false;
            }
            let (i, j) = (c % w, c / w);
            let mut sides = Vec::with_capacity(4);
            if i > 0 {
                sides.push(c - 1);
            }
            if i + 1 < w {
                sides.push(c + 1);
            }
            if j > 0 {
                sides.push(c - w);
            }
            if j + 1 < h {
                sides.push(c + w);
            }
            sides
                .into_iter()
                .any(|n| !plan.is_occupied(n) && !outside[n])
        })
        .collect()
}

/// The obstacle cells a full turn at cell `from` sees: along each of `rays` directions the
/// first occupied cell within `range`, sorted, without repeats.
pub fn look_around(plan: &FloorPlan, from: usize, range: f64, rays: usize) -> Vec<usize> {
    let [w, h] = plan.size;
    let [x0, y0] = plan.centre(from);
    let step = 0.25 * plan.cell;
    let steps = (range / step).ceil() as usize;
    let mut hits = Vec::new();
    for k in 0..rays {
        let a = std::f64::consts::TAU * k as f64 / rays as f64;
        let (dx, dy) = (a.cos() * step, a.sin() * step);
        for s in 1..=steps {
            let (x, y) = (x0 + dx * s as f64, y0 + dy * s as f64);
            let fi = ((x - plan.origin[0]) / plan.cell).floor();
            let fj = ((y - plan.origin[1]) / plan.cell).floor();
            if fi < 0.0 || fj < 0.0 || fi >= w as f64 || fj >= h as f64 {
                break;
            }
            let c = fj as usize * w + fi as usize;
            if plan.is_occupied(c) {
                hits.push(c);
                break;
            }
        }
    }
    hits.sort_unstable();
    hits.dedup();
    hits
}

/// Path costs from `from` over the cells that pass `open` (8-connected, metres, times
/// `narrow_cost` through cells with less than `clearance` of room), and each cell's previous.
fn distances(
    plan: &FloorPlan,
    from: usize,
    open: &[bool],
    config: &TourConfig,
) -> (Vec<f64>, Vec<usize>) {
    let mut distance = vec![f64::INFINITY; plan.len()];
    let mut previous = vec![usize::MAX; plan.len()];
    distance[from] = 0.0;
    previous[from] = from;
    let mut queue = BinaryHeap::from([(Reverse(TotalF64(0.0)), from)]);
    let w = plan.size[0];
    while let Some((Reverse(TotalF64(d)), c)) = queue.pop() {
        if d > distance[c] {
            continue;
        }
        for n in plan.neighbours(c) {
            if !open[n] {
                continue;
            }
            let diagonal = n % w != c % w && n / w != c / w;
            let length = plan.cell
                * if diagonal {
                    std::f64::consts::SQRT_2
                } else {
                    1.0
                };
            let factor = if plan.clearance(n) < config.clearance {
                config.narrow_cost
            } else {
                1.0
            };
            let nd = d + length * factor;
            if nd < distance[n] {
                distance[n] = nd;
                previous[n] = c;
                queue.push((Reverse(TotalF64(nd)), n));
            }
        }
    }
    (distance, previous)
}

/// Whether cell `c` is a candidate look-around point: on the lattice, reachable, with room to
/// turn.
pub fn is_candidate(plan: &FloorPlan, reachable: &[bool], c: usize, config: &TourConfig) -> bool {
    let lattice = ((config.spacing / plan.cell).round() as usize).max(1);
    let w = plan.size[0];
    reachable[c]
        && plan.clearance(c) >= config.clearance
        && (c % w).is_multiple_of(lattice)
        && (c / w).is_multiple_of(lattice)
}

/// Plans the route from cell `start` over the cells the robot can reach from it.
pub fn plan_tour(plan: &FloorPlan, start: usize, config: &TourConfig) -> Tour {
    let outside = plan.outside();
    let target_cells = targets(plan, &outside);
    let mut index = vec![u32::MAX; plan.len()];
    for (k, &c) in target_cells.iter().enumerate() {
        index[c] = k as u32;
    }
    let reachable = plan.flood(start, |c| plan.is_free(c) || c == start);
    let mut candidates: Vec<usize> = (0..plan.len())
        .filter(|&c| is_candidate(plan, &reachable, c, config))
        .collect();
    candidates.push(start);
    let sees = |c: usize| -> Vec<u32> {
        look_around(plan, c, config.range, config.rays)
            .into_iter()
            .map(|t| index[t])
            .filter(|&k| k != u32::MAX)
            .collect()
    };
    let views: Vec<Vec<u32>> = candidates.iter().map(|&c| sees(c)).collect();
    let mut visible = vec![false; target_cells.len()];
    for v in &views {
        for &k in v {
            visible[k as usize] = true;
        }
    }
    let mut seen = vec![false; target_cells.len()];
    let mut tour = Tour {
        stops: vec![plan.centre(start)],
        paths: vec![Vec::new()],
        visible: visible.iter().filter(|v| **v).count(),
        targets: target_cells.len(),
        ..Tour::default()
    };
    for &k in views.last().into_iter().flatten() {
        seen[k as usize] = true;
    }
    let mut at = start;
    loop {
        let (distance, previous) = distances(plan, at, &reachable, config);
        let mut best: Option<(f64, usize)> = None;
        for (n, &c) in candidates.iter().enumerate() {
            let gain = views[n].iter().filter(|&&k| !seen[k as usize]).count();
            if gain < config.min_gain || !distance[c].is_finite() {
                continue;
            }
            let score = gain as f64 / (distance[c] + config.turn_cost);
            if best.is_none_or(|(s, _)| score > s) {
                best = Some((score, n));
            }
        }
        let Some((_, n)) = best else { break };
        let goal = candidates[n];
        let mut cells = vec![goal];
        while let Some(&last) = cells.last() {
            if last == at {
                break;
            }
            cells.push(previous[last]);
        }
        cells.reverse();
        tour.paths
            .push(cells.iter().skip(1).map(|&c| plan.centre(c)).collect());
        tour.stops.push(plan.centre(goal));
        for &k in &views[n] {
            seen[k as usize] = true;
        }
        at = goal;
    }
    tour.seen = seen.iter().filter(|s| **s).count();
    tour
}
