//! The high level of RT-GuIDE (DESIGN.md): regions with utility Omega, a topological graph of
//! odometry and viewpoint nodes, Dijkstra from the robot, and the guidance path with the best
//! Omega / e^d.

use crate::map::{ClassifyOptions, GaussianMap};
use crate::math::TotalF64;
use std::collections::BTreeMap;

/// Viewpoints this close to the last plan's target count as the same target, metres.
pub const KEEP_RADIUS: f64 = 0.5;

/// A cuboid of the known space and its utility.
#[derive(Debug, Clone, PartialEq)]
pub struct Region {
    /// Centre of the cube, metres.
    pub centre: [f64; 3],
    /// Mean position of its Gaussians, metres: viewpoints are sampled around it (the paper's
    /// "Gaussian region centroid"), so a cube that reaches past a wall is looked at where its
    /// Gaussians are, not from its empty half.
    pub centroid: [f64; 3],
    /// Gaussians inside (ground plane left out).
    pub count: usize,
    /// Mean uncertainty of those Gaussians.
    pub omega: f64,
}

/// The map's (non-ground) Gaussians by cube of side `size` of a lattice anchored at the
/// world origin, each occupied cube with its mean uncertainty, z-major. One pass over the
/// map: the reference the planner's running [`super::tally::Tally`] is checked against.
pub fn regions(map: &GaussianMap, options: &ClassifyOptions, size: f64) -> Vec<Region> {
    let mut sums: BTreeMap<[i64; 3], (f64, [f64; 3], usize)> = BTreeMap::new();
    for (m, u) in map.gaussians.means.iter().zip(&map.uncertainty) {
        if options.includes(m) {
            let k = |v: f32| (f64::from(v) / size).floor() as i64;
            let e = sums
                .entry([k(m[2]), k(m[1]), k(m[0])])
                .or_insert((0.0, [0.0; 3], 0));
            e.0 += f64::from(*u);
            for a in 0..3 {
                e.1[a] += f64::from(m[a]);
            }
            e.2 += 1;
        }
    }
    sums.into_iter()
        .map(|(k, (sum, position, count))| Region {
            centre: [k[2], k[1], k[0]].map(|k| (k as f64 + 0.5) * size),
            centroid: position.map(|p| p / count as f64),
            count,
            omega: sum / count as f64,
        })
        .collect()
}

/// What a node of the graph is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NodeKind {
    /// A place the robot has been.
    Odometry,
    /// A place to look at a region from, with the region's utility.
    Viewpoint {
        /// Omega of the region.
        omega: f64,
        /// Heading that faces the region, radians.
        heading: f64,
    },
}

/// A node: a position on the floor and its kind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Node {
    /// x, y in metres.
    pub position: [f64; 2],
    /// Its kind.
    pub kind: NodeKind,
}

/// The topological graph: odometry nodes persist, viewpoints are replaced every plan.
#[derive(Debug, Clone, Default)]
pub struct TopologicalGraph {
    /// Nodes.
    pub nodes: Vec<Node>,
    /// Undirected edges (a, b, length).
    pub edges: Vec<(usize, usize, f64)>,
}

fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

/// The result of a Dijkstra search: distances and predecessors.
#[derive(Debug, Clone)]
pub struct ShortestPaths {
    /// Path length from the source (infinite when unreachable).
    pub distance: Vec<f64>,
    /// Previous node on the shortest path.
    pub previous: Vec<Option<usize>>,
}

impl ShortestPaths {
    /// Nodes from the source to `target`.
    pub fn path_to(&self, target: usize) -> Vec<usize> {
        let mut path = vec![target];
        let mut at = target;
        while let Some(p) = self.previous[at] {
            path.push(p);
            at = p;
        }
        path.reverse();
        path
    }
}

impl TopologicalGraph {
    /// The odometry node nearest `p`.
    pub fn nearest_odometry(&self, p: [f64; 2]) -> Option<(usize, f64)> {
        self.nodes
            .iter()
            .enumerate()
            .filter(|(_, n)| n.kind == NodeKind::Odometry)
            .map(|(i, n)| (i, distance(n.position, p)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// Adds an odometry node at the robot's position when none is within `spacing`, joined to
    /// the nearest one. Returns the node the robot is at.
    pub fn visit(&mut self, p: [f64; 2], spacing: f64) -> usize {
        match self.nearest_odometry(p) {
            Some((i, d)) if d <= spacing => i,
            nearest => {
                self.nodes.push(Node {
                    position: p,
                    kind: NodeKind::Odometry,
                });
                let new = self.nodes.len() - 1;
                if let Some((i, d)) = nearest {
                    self.edges.push((i, new, d));
                }
                new
            }
        }
    }

    /// Removes every viewpoint (and its edges).
    pub fn clear_viewpoints(&mut self) {
        let keep: Vec<bool> = self
            .nodes
            .iter()
            .map(|n| n.kind == NodeKind::Odometry)
            .collect();
        let mut remap = vec![usize::MAX; self.nodes.len()];
        let mut next = 0;
        for (i, k) in keep.iter().enumerate() {
            if *k {
                remap[i] = next;
                next += 1;
            }
        }
        self.nodes.retain(|n| n.kind == NodeKind::Odometry);
        self.edges = self
            .edges
            .iter()
            .filter(|(a, b, _)| keep[*a] && keep[*b])
            .map(|(a, b, d)| (remap[*a], remap[*b], *d))
            .collect();
    }

    /// Adds a viewpoint joined to the closest odometry node.
    pub fn add_viewpoint(&mut self, position: [f64; 2], omega: f64, heading: f64) -> usize {
        let nearest = self.nearest_odometry(position);
        self.nodes.push(Node {
            position,
            kind: NodeKind::Viewpoint { omega, heading },
        });
        let new = self.nodes.len() - 1;
        if let Some((i, d)) = nearest {
            self.edges.push((i, new, d));
        }
        new
    }

    /// Cuts every edge of node `i`, so no path reaches it (a viewpoint found to lie behind a
    /// wall).
    pub fn detach(&mut self, i: usize) {
        self.take_edges(i);
    }

    /// Cuts every edge of node `i` and returns them, for `restore` to put back.
    pub fn take_edges(&mut self, i: usize) -> Vec<(usize, usize, f64)> {
        let (taken, kept) = self.edges.iter().partition(|(a, b, _)| *a == i || *b == i);
        self.edges = kept;
        taken
    }

    /// Puts back edges `take_edges` cut.
    pub fn restore(&mut self, edges: Vec<(usize, usize, f64)>) {
        self.edges.extend(edges);
    }

    /// Dijkstra from `source`.
    pub fn dijkstra(&self, source: usize) -> ShortestPaths {
        let n = self.nodes.len();
        let mut adjacency = vec![Vec::new(); n];
        for (a, b, d) in &self.edges {
            adjacency[*a].push((*b, *d));
            adjacency[*b].push((*a, *d));
        }
        let mut distance = vec![f64::INFINITY; n];
        let mut previous = vec![None; n];
        let mut heap = std::collections::BinaryHeap::new();
        distance[source] = 0.0;
        heap.push(std::cmp::Reverse((TotalF64(0.0), source)));
        while let Some(std::cmp::Reverse((TotalF64(d), u))) = heap.pop() {
            if d > distance[u] {
                continue;
            }
            for &(v, w) in &adjacency[u] {
                let nd = d + w;
                if nd < distance[v] {
                    distance[v] = nd;
                    previous[v] = Some(u);
                    heap.push(std::cmp::Reverse((TotalF64(nd), v)));
                }
            }
        }
        ShortestPaths { distance, previous }
    }

    /// The viewpoint with the best Omega / e^d from `source` among those at least
    /// `min_distance` away, and its path; `None` when no such viewpoint is reachable.
    pub fn best_viewpoint(
        &self,
        source: usize,
        min_distance: f64,
    ) -> Option<(usize, Vec<usize>, f64)> {
        self.best_viewpoint_keeping(source, min_distance, None, 1.0)
    }

    /// [`TopologicalGraph::best_viewpoint`], except that a viewpoint within
    /// `KEEP_RADIUS` of `previous` (the last plan's target) wins while it scores at least
    /// `keep_fraction` of the best. Region utilities jump by several times from one mapping
    /// step to the next (a region just looked at has Gaussians that just moved), so without
    /// this the robot turns back and forth between two targets and never leaves.
    pub fn best_viewpoint_keeping(
        &self,
        source: usize,
        min_distance: f64,
        previous: Option<[f64; 2]>,
        keep_fraction: f64,
    ) -> Option<(usize, Vec<usize>, f64)> {
        let paths = self.dijkstra(source);
        let scores: Vec<(usize, f64)> = self
            .nodes
            .iter()
            .enumerate()
            .filter_map(|(i, n)| match n.kind {
                NodeKind::Viewpoint { omega, .. }
                    if paths.distance[i].is_finite() && paths.distance[i] >= min_distance =>
                {
                    Some((i, omega / paths.distance[i].exp()))
                }
                _ => None,
            })
            .collect();
        let (mut best, mut score) = scores
            .iter()
            .copied()
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))?;
        if let Some(target) = previous {
            let kept = scores.iter().copied().find(|(i, s)| {
                let p = self.nodes[*i].position;
                (p[0] - target[0]).hypot(p[1] - target[1]) < KEEP_RADIUS
                    && *s >= keep_fraction * score
            });
            if let Some((i, s)) = kept {
                (best, score) = (i, s);
            }
        }
        Some((best, paths.path_to(best), score))
    }
}

/// The point of `path` (a polyline from the robot) furthest along it that is still within
/// `range` of its start (straight-line distance).
pub fn local_goal(path: &[[f64; 2]], range: f64) -> Option<[f64; 2]> {
    let start = *path.first()?;
    let mut goal = start;
    for w in path.windows(2) {
        let (a, b) = (w[0], w[1]);
        if distance(start, b) <= range {
            goal = b;
            continue;
        }
        // Walk the segment to where it leaves the range (bisection on a monotone stretch).
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            let p = [a[0] + mid * (b[0] - a[0]), a[1] + mid * (b[1] - a[1])];
            if distance(start, p) <= range {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        return Some([a[0] + lo * (b[0] - a[0]), a[1] + lo * (b[1] - a[1])]);
    }
    Some(goal)
}
