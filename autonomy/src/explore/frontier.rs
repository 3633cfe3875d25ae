//! Frontiers on a class grid (AG-SLAM's FBE): the free mask opened with a 3 x 3 kernel and cut
//! to the robot's connected component; frontier cells are the free mask dilated 3 x 3, minus
//! the free mask, that are unknown; 8-connected clusters of more than ten cells; the cluster
//! with the highest count / (mean cell distance + 20) is chosen. Distances to obstacles and
//! shortest paths over the free space serve the goal sampling and the guidance path.

use super::evidence::{CellClass, ClassGrid};
use crate::math::TotalF64;
use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};

/// A cluster of frontier cells.
#[derive(Debug, Clone, PartialEq)]
pub struct Cluster {
    /// Its cells (grid indices), ascending.
    pub cells: Vec<usize>,
    /// The mean of its cell centres, metres.
    pub centroid: [f64; 2],
}

impl Cluster {
    /// Its cell nearest its centroid (ties: the lower cell): a cluster that bends round a room
    /// has its centroid out on seen floor, where there is nothing to look at.
    pub fn anchor(&self, grid: &ClassGrid) -> [f64; 2] {
        let m = self.centroid;
        let d = |p: [f64; 2]| (p[0] - m[0]).hypot(p[1] - m[1]);
        self.cells
            .iter()
            .map(|c| grid.centre(*c))
            .min_by(|a, b| d(*a).total_cmp(&d(*b)))
            .unwrap_or(m)
    }
}

/// Clusters need more cells than this (AG-SLAM's code).
pub const MIN_CLUSTER_CELLS: usize = 10;
/// The distance offset of the choice, cells.
pub const DISTANCE_OFFSET: f64 = 20.0;

fn morph(grid: &ClassGrid, mask: &[bool], keep: bool) -> Vec<bool> {
    // keep = true: erosion (every 3 x 3 neighbour set); false: dilation (any set).
    let [w, h] = grid.size;
    let mut out = vec![false; mask.len()];
    for y in 0..h {
        for x in 0..w {
            let mut all = true;
            let mut any = false;
            for dy in -1i64..=1 {
                for dx in -1i64..=1 {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    let v = nx >= 0
                        && ny >= 0
                        && nx < w as i64
                        && ny < h as i64
                        && mask[ny as usize * w + nx as usize];
                    all &= v;
                    any |= v;
                }
            }
            out[y * w + x] = if keep { all } else { any };
        }
    }
    out
}

/// The free mask opened 3 x 3 and cut to the 8-connected component of the free cell nearest
/// `robot` (the robot's own cell when it is free); all false when nothing is free.
pub fn reachable_free(grid: &ClassGrid, robot: [f64; 2]) -> Vec<bool> {
    let free: Vec<bool> = grid.classes.iter().map(|c| *c == CellClass::Free).collect();
    let opened = morph(grid, &morph(grid, &free, true), false);
    let opened: Vec<bool> = opened.iter().zip(&free).map(|(o, f)| *o && *f).collect();
    let mut component = vec![false; grid.len()];
    let Some(seed) = nearest(grid, robot, &opened) else {
        return component;
    };
    let mut queue = VecDeque::from([seed]);
    component[seed] = true;
    while let Some(c) = queue.pop_front() {
        for n in grid.neighbours8(c) {
            if opened[n] && !component[n] {
                component[n] = true;
                queue.push_back(n);
            }
        }
    }
    component
}

/// The set cell of `mask` nearest `p` (ties by index).
fn nearest(grid: &ClassGrid, p: [f64; 2], mask: &[bool]) -> Option<usize> {
    if let Some(c) = grid.cell_of(p) {
        if mask[c] {
            return Some(c);
        }
    }
    (0..grid.len()).filter(|c| mask[*c]).min_by(|a, b| {
        let (ca, cb) = (grid.centre(*a), grid.centre(*b));
        let da = (ca[0] - p[0]).hypot(ca[1] - p[1]);
        let db = (cb[0] - p[0]).hypot(cb[1] - p[1]);
        da.total_cmp(&db)
    })
}

/// Cells of `class` in the ring round the free mask: the mask dilated 3 x 3, minus the mask.
fn border(grid: &ClassGrid, free: &[bool], class: CellClass) -> Vec<bool> {
    morph(grid, free, false)
        .into_iter()
        .enumerate()
        .map(|(c, d)| d && !free[c] && grid.classes[c] == class)
        .collect()
}

/// Frontier cells: the free mask dilated 3 x 3, minus the free mask, that are unknown.
pub fn frontier_cells(grid: &ClassGrid, free: &[bool]) -> Vec<bool> {
    border(grid, free, CellClass::Unknown)
}

/// 8-connected clusters of frontier cells with more than `MIN_CLUSTER_CELLS` cells, in order
/// of their lowest cell.
pub fn clusters(grid: &ClassGrid, frontier: &[bool]) -> Vec<Cluster> {
    clusters_through(grid, frontier, &vec![false; grid.len()])
}

/// Free cells that border the robot's component `free` but are not in it: the opening cut them
/// off (a door seen from afar gives lines of free cells with unseen cells between them, too
/// thin to survive it), yet they are no obstacle, only free space not known to be reachable.
pub fn cut_free_border(grid: &ClassGrid, free: &[bool]) -> Vec<bool> {
    border(grid, free, CellClass::Free)
}

/// [`clusters`], where two frontier cells are also joined through cells of `through` (they
/// join the cluster's connectivity, not its cells or its count).
pub fn clusters_through(grid: &ClassGrid, frontier: &[bool], through: &[bool]) -> Vec<Cluster> {
    let mut seen = vec![false; grid.len()];
    let mut out = Vec::new();
    for start in 0..grid.len() {
        if !frontier[start] || seen[start] {
            continue;
        }
        seen[start] = true;
        let mut cells = vec![start];
        let mut queue = VecDeque::from([start]);
        while let Some(c) = queue.pop_front() {
            for n in grid.neighbours8(c) {
                if (frontier[n] || through[n]) && !seen[n] {
                    seen[n] = true;
                    if frontier[n] {
                        cells.push(n);
                    }
                    queue.push_back(n);
                }
            }
        }
        if cells.len() > MIN_CLUSTER_CELLS {
            cells.sort_unstable();
            let n = cells.len() as f64;
            let sum = cells.iter().fold([0.0, 0.0], |s, c| {
                let p = grid.centre(*c);
                [s[0] + p[0], s[1] + p[1]]
            });
            out.push(Cluster {
                cells,
                centroid: [sum[0] / n, sum[1] / n],
            });
        }
    }
    out
}

/// count / (mean distance in cells from the robot + 20): AG-SLAM's "combined" utility.
pub fn utility(grid: &ClassGrid, cluster: &Cluster, robot: [f64; 2]) -> f64 {
    let mean = cluster
        .cells
        .iter()
        .map(|c| {
            let p = grid.centre(*c);
            (p[0] - robot[0]).hypot(p[1] - robot[1]) / grid.cell
        })
        .sum::<f64>()
        / cluster.cells.len() as f64;
    cluster.cells.len() as f64 / (mean + DISTANCE_OFFSET)
}

/// The clusters ranked by utility, best first (ties by order).
pub fn ranked(grid: &ClassGrid, clusters: &[Cluster], robot: [f64; 2]) -> Vec<(usize, f64)> {
    let mut r: Vec<(usize, f64)> = clusters
        .iter()
        .enumerate()
        .map(|(i, c)| (i, utility(grid, c, robot)))
        .collect();
    r.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    r
}

/// Per cell, the distance to the nearest cell outside `mask`, metres (two-pass 3-4 chamfer,
/// within 8% of the Euclidean distance).
pub fn clearance(grid: &ClassGrid, mask: &[bool]) -> Vec<f64> {
    let [w, h] = grid.size;
    let big = u32::MAX / 2;
    let mut d: Vec<u32> = mask.iter().map(|m| if *m { big } else { 0 }).collect();
    let at = |x: i64, y: i64, d: &Vec<u32>| -> u32 {
        if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
            0
        } else {
            d[y as usize * w + x as usize]
        }
    };
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let i = y as usize * w + x as usize;
            let v = d[i]
                .min(at(x - 1, y, &d) + 3)
                .min(at(x, y - 1, &d) + 3)
                .min(at(x - 1, y - 1, &d) + 4)
                .min(at(x + 1, y - 1, &d) + 4);
            d[i] = v;
        }
    }
    for y in (0..h as i64).rev() {
        for x in (0..w as i64).rev() {
            let i = y as usize * w + x as usize;
            let v = d[i]
                .min(at(x + 1, y, &d) + 3)
                .min(at(x, y + 1, &d) + 3)
                .min(at(x + 1, y + 1, &d) + 4)
                .min(at(x - 1, y + 1, &d) + 4);
            d[i] = v;
        }
    }
    d.into_iter()
        .map(|v| f64::from(v) / 3.0 * grid.cell)
        .collect()
}

/// Shortest 8-connected path lengths (metres) over `passable` cells from `source`.
pub fn distances(grid: &ClassGrid, passable: &[bool], source: usize) -> (Vec<f64>, Vec<usize>) {
    let mut dist = vec![f64::INFINITY; grid.len()];
    let mut parent = vec![usize::MAX; grid.len()];
    let mut open = BinaryHeap::new();
    dist[source] = 0.0;
    open.push(Reverse((TotalF64(0.0), source)));
    let w = grid.size[0];
    while let Some(Reverse((TotalF64(d), c))) = open.pop() {
        if d > dist[c] {
            continue;
        }
        for n in grid.neighbours8(c) {
            if !passable[n] {
                continue;
            }
            let diagonal = (n % w != c % w) && (n / w != c / w);
            let step = if diagonal {
                std::f64::consts::SQRT_2
            } else {
                1.0
            } * grid.cell;
            if d + step < dist[n] {
                dist[n] = d + step;
                parent[n] = c;
                open.push(Reverse((TotalF64(d + step), n)));
            }
        }
    }
    (dist, parent)
}

/// The cell path from the source to `to` through `parent` (source first), as cell centres
/// every `every` cells and the end.
pub fn path_to(grid: &ClassGrid, parent: &[usize], to: usize, every: usize) -> Vec<[f64; 2]> {
    let mut cells = vec![to];
    let mut at = to;
    while parent[at] != usize::MAX {
        at = parent[at];
        cells.push(at);
    }
    cells.reverse();
    let mut out: Vec<[f64; 2]> = cells
        .iter()
        .step_by(every.max(1))
        .map(|c| grid.centre(*c))
        .collect();
    if (cells.len() - 1) % every.max(1) != 0 {
        out.push(grid.centre(to));
    }
    out
}
