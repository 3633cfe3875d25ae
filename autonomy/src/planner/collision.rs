//! Collision checks of robot sample points against every Gaussian (DESIGN.md: a point
//! collides when its distance to a Gaussian mean is below r_robot + 3 r). Brute force is the
//! reference; [`CollisionGrid`] gives the same answers from a uniform 3-D hash grid that is
//! kept in sync with the map incrementally.

use crate::gaussians::Gaussians;
use crate::map::ClassifyOptions;
use std::collections::HashMap;

/// The robot as the collision check sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CollisionModel {
    /// Radius of the sphere around each sample point, metres.
    pub robot_radius: f32,
    /// Height of the sample points above the floor, metres.
    pub centre_height: f32,
    /// lambda_g: multiples of a Gaussian's radius added to the robot's.
    pub gaussian_scale: f32,
}

impl Default for CollisionModel {
    fn default() -> Self {
        // The unicycle of models/unicycle.xml: 0.5 x 0.6 m footprint (wheels included),
        // 0.5 m tall; a 0.35 m sphere at 0.25 m covers its body.
        CollisionModel {
            robot_radius: 0.35,
            centre_height: 0.25,
            gaussian_scale: 3.0,
        }
    }
}

impl CollisionModel {
    /// Whether point `p` collides with a Gaussian at `mean` with radius `radius`.
    #[inline]
    pub fn collides(&self, p: [f32; 3], mean: [f32; 3], radius: f32) -> bool {
        let reach = self.robot_radius + self.gaussian_scale * radius;
        let d = [p[0] - mean[0], p[1] - mean[1], p[2] - mean[2]];
        d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < reach * reach
    }
}

/// The Gaussians planning considers: means and radii (the ground plane already left out).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Obstacles {
    /// Means.
    pub means: Vec<[f32; 3]>,
    /// Radii, metres.
    pub radii: Vec<f32>,
}

impl Obstacles {
    /// Every Gaussian `options` includes (the ground plane left out).
    pub fn from_gaussians(g: &Gaussians, options: &ClassifyOptions) -> Self {
        let mut o = Obstacles::default();
        o.refill(g, options);
        o
    }

    /// [`Obstacles::from_gaussians`] into the existing buffers (no fresh allocation per plan).
    pub fn refill(&mut self, g: &Gaussians, options: &ClassifyOptions) {
        use rayon::prelude::*;
        self.means.clear();
        self.radii.clear();
        // rayon keeps the map's order in what it extends.
        self.means.par_extend(
            g.means
                .par_iter()
                .with_min_len(1 << 14)
                .filter(|m| options.includes(m))
                .copied(),
        );
        self.radii.par_extend(
            g.means
                .par_iter()
                .zip(g.log_radii.par_iter())
                .with_min_len(1 << 14)
                .filter(|(m, _)| options.includes(m))
                .map(|(_, r)| r.exp()),
        );
    }

    /// Number of obstacles.
    pub fn len(&self) -> usize {
        self.means.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.means.is_empty()
    }
}

/// Per point: does it collide with any obstacle? Checks every pair.
pub fn brute_force(
    model: &CollisionModel,
    obstacles: &Obstacles,
    points: &[[f32; 3]],
) -> Vec<bool> {
    use rayon::prelude::*;
    points
        .par_iter()
        .map(|p| {
            obstacles
                .means
                .iter()
                .zip(&obstacles.radii)
                .any(|(m, r)| model.collides(*p, *m, *r))
        })
        .collect()
}

type Cell = [i32; 3];

/// A uniform 3-D hash grid over obstacle means. Obstacles up to `radius_cap` live in the cell
/// of their mean (cell side = r_robot + lambda_g radius_cap, so a query reads the 27 cells
/// around its point); larger ones sit in a short list checked against every query.
#[derive(Debug, Clone)]
pub struct CollisionGrid {
    model: CollisionModel,
    cell: f32,
    radius_cap: f32,
    cells: HashMap<Cell, Vec<u32>>,
    /// Where each obstacle is filed: its cell, or None for the oversize list.
    filed: Vec<Option<Cell>>,
    oversize: Vec<u32>,
    means: Vec<[f32; 3]>,
    radii: Vec<f32>,
}

/// What one [`CollisionGrid::sync`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SyncReport {
    /// Obstacles filed for the first time.
    pub inserted: usize,
    /// Obstacles that changed cell (or list).
    pub moved: usize,
    /// Obstacles dropped from the end.
    pub removed: usize,
}

impl CollisionGrid {
    /// An empty grid for `model`; obstacles wider than `radius_cap` go to the oversize list.
    pub fn new(model: CollisionModel, radius_cap: f32) -> Self {
        CollisionGrid {
            model,
            cell: model.robot_radius + model.gaussian_scale * radius_cap,
            radius_cap,
            cells: HashMap::new(),
            filed: Vec::new(),
            oversize: Vec::new(),
            means: Vec::new(),
            radii: Vec::new(),
        }
    }

    fn cell_of(&self, p: [f32; 3]) -> Cell {
        p.map(|v| (v / self.cell).floor() as i32)
    }

    fn unfile(&mut self, i: usize) {
        match self.filed[i] {
            Some(c) => {
                if let Some(list) = self.cells.get_mut(&c) {
                    if let Some(k) = list.iter().position(|j| *j as usize == i) {
                        list.swap_remove(k);
                    }
                    if list.is_empty() {
                        self.cells.remove(&c);
                    }
                }
            }
            None => {
                if let Some(k) = self.oversize.iter().position(|j| *j as usize == i) {
                    self.oversize.swap_remove(k);
                }
            }
        }
    }

    fn file(&mut self, i: usize) -> Option<Cell> {
        if self.radii[i] > self.radius_cap {
            self.oversize.push(i as u32);
            None
        } else {
            let c = self.cell_of(self.means[i]);
            self.cells.entry(c).or_default().push(i as u32);
            Some(c)
        }
    }

    /// Brings the grid up to date with `obstacles`, touching only what changed: new
    /// obstacles are filed, ones that left their cell are moved, ones past the new end are
    /// dropped. (Indices are positions in `obstacles`; after a map prune that reorders them,
    /// most obstacles change index and the sync costs about a rebuild.)
    pub fn sync(&mut self, obstacles: &Obstacles) -> SyncReport {
        let mut report = SyncReport::default();
        let n = obstacles.len();
        while self.filed.len() > n {
            let i = self.filed.len() - 1;
            self.unfile(i);
            self.filed.pop();
            self.means.pop();
            self.radii.pop();
            report.removed += 1;
        }
        for i in 0..self.filed.len() {
            let (m, r) = (obstacles.means[i], obstacles.radii[i]);
            if m == self.means[i] && r == self.radii[i] {
                continue;
            }
            let old = self.filed[i];
            self.means[i] = m;
            self.radii[i] = r;
            let new = if r > self.radius_cap {
                None
            } else {
                Some(self.cell_of(m))
            };
            if new != old {
                self.unfile(i);
                self.filed[i] = self.file(i);
                report.moved += 1;
            }
        }
        for i in self.filed.len()..n {
            self.means.push(obstacles.means[i]);
            self.radii.push(obstacles.radii[i]);
            let c = self.file(i);
            self.filed.push(c);
            report.inserted += 1;
        }
        report
    }

    /// Obstacles filed.
    pub fn len(&self) -> usize {
        self.filed.len()
    }

    /// Whether the grid is empty.
    pub fn is_empty(&self) -> bool {
        self.filed.is_empty()
    }

    /// Whether `p` collides with any obstacle.
    pub fn point_collides(&self, p: [f32; 3]) -> bool {
        let c = self.cell_of(p);
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if let Some(list) = self.cells.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) {
                        for &j in list {
                            let j = j as usize;
                            if self.model.collides(p, self.means[j], self.radii[j]) {
                                return true;
                            }
                        }
                    }
                }
            }
        }
        self.oversize.iter().any(|&j| {
            self.model
                .collides(p, self.means[j as usize], self.radii[j as usize])
        })
    }

    /// Per point: does it collide?
    pub fn check(&self, points: &[[f32; 3]]) -> Vec<bool> {
        points.iter().map(|p| self.point_collides(*p)).collect()
    }

    /// The model the grid checks with.
    pub fn model(&self) -> &CollisionModel {
        &self.model
    }
}
