//! Collision checks of robot sample points against every Gaussian (DESIGN.md: a point
//! collides when its distance to a Gaussian mean is below r_robot + 3 r). Brute force is the
//! reference; [`CollisionGrid`] gives the same answers from a uniform 3-D hash grid that is
//! kept in sync with the map incrementally.

use super::lattice::{CellPoints, PointLattice};
use super::mirror::{Change, Record};
use crate::gaussians::Gaussians;
use crate::map::ClassifyOptions;

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

/// Whether `p` collides with any obstacle of `cell` (values are radii):
/// [`CollisionModel::collides`] over every one without branches, so it vectorises.
fn any_collides(cell: &CellPoints, model: &CollisionModel, p: [f32; 3]) -> bool {
    let mut hit = false;
    let points = cell.x.iter().zip(&cell.y).zip(&cell.z);
    for (((x, y), z), r) in points.zip(&cell.value) {
        let reach = model.robot_radius + model.gaussian_scale * r;
        let d = [p[0] - x, p[1] - y, p[2] - z];
        hit |= d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < reach * reach;
    }
    hit
}

/// A uniform 3-D grid over obstacle means, by slot (see [`super::mirror`]), on a lattice
/// anchored at the world origin. Obstacles up to `radius_cap` live in the cell of their mean
/// (cell side = r_robot + lambda_g radius_cap, so a query reads the 27 cells around its
/// point); larger ones sit in the overflow cell, which every query reads.
#[derive(Debug, Clone)]
pub struct CollisionGrid {
    model: CollisionModel,
    radius_cap: f32,
    /// Obstacle means, valued by radius.
    lattice: PointLattice,
}

/// What one [`CollisionGrid::apply`] or [`CollisionGrid::sync`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SyncReport {
    /// Obstacles filed for the first time.
    pub inserted: usize,
    /// Obstacles that changed cell (or list).
    pub moved: usize,
    /// Obstacles dropped.
    pub removed: usize,
}

impl CollisionGrid {
    /// An empty grid for `model`; obstacles wider than `radius_cap` go to the overflow cell.
    pub fn new(model: CollisionModel, radius_cap: f32) -> Self {
        CollisionGrid {
            model,
            radius_cap,
            lattice: PointLattice::new(model.robot_radius + model.gaussian_scale * radius_cap),
        }
    }

    /// Applies the mirror's changes, touching only the slots they name.
    pub fn apply(&mut self, changes: &[Change]) -> SyncReport {
        let mut report = SyncReport::default();
        for c in changes.iter() {
            if c.new.is_none() && self.lattice.remove(c.slot).is_some() {
                report.removed += 1;
            }
        }
        self.lattice.cover_points(
            changes
                .iter()
                .filter_map(|c| c.new.as_ref().map(|r| &r.mean)),
        );
        for c in changes.iter() {
            if let Some(r) = c.new {
                if self.lattice.remove(c.slot).is_some() {
                    report.moved += 1;
                } else {
                    report.inserted += 1;
                }
                let oversize = r.radius > self.radius_cap;
                self.lattice.insert(c.slot, r.mean, r.radius, oversize);
            }
        }
        report
    }

    /// Brings the grid up to date with `obstacles`, obstacle i in slot i, touching only what
    /// changed (for callers that keep an [`Obstacles`] list rather than a mirror).
    pub fn sync(&mut self, obstacles: &Obstacles) -> SyncReport {
        let n = obstacles.len();
        let mut changes = Vec::new();
        for (i, (m, r)) in obstacles.means.iter().zip(&obstacles.radii).enumerate() {
            if self.lattice.filed(i as u32) != Some((*m, *r)) {
                changes.push(Change {
                    slot: i as u32,
                    old: None,
                    new: Some(Record {
                        mean: *m,
                        radius: *r,
                        uncertainty: 0.0,
                    }),
                });
            }
        }
        for slot in n..self.lattice.slot_end() {
            changes.push(Change {
                slot: slot as u32,
                old: None,
                new: None,
            });
        }
        self.apply(&changes)
    }

    /// Obstacles filed.
    pub fn len(&self) -> usize {
        self.lattice.len()
    }

    /// Whether the grid is empty.
    pub fn is_empty(&self) -> bool {
        self.lattice.is_empty()
    }

    /// The cells a query at `p` reads: its own first (where a hit is likeliest), then its
    /// 26 neighbours, then the overflow cell.
    fn cells_around(&self, p: [f32; 3]) -> impl Iterator<Item = &CellPoints> {
        let c = self.lattice.key(p);
        const AROUND: [i32; 3] = [0, -1, 1];
        AROUND
            .iter()
            .flat_map(|dz| AROUND.iter().map(move |dy| (*dz, *dy)))
            .flat_map(|(dz, dy)| AROUND.iter().map(move |dx| [*dx, dy, dz]))
            .filter_map(move |d| self.lattice.find([c[0] + d[0], c[1] + d[1], c[2] + d[2]]))
            .map(|k| self.lattice.get(k))
            .chain(std::iter::once(self.lattice.overflow()))
    }

    /// Whether `p` collides with any obstacle.
    pub fn point_collides(&self, p: [f32; 3]) -> bool {
        self.cells_around(p)
            .any(|cell| any_collides(cell, &self.model, p))
    }

    /// The means of every obstacle `p` collides with.
    pub fn colliding_means(&self, p: [f32; 3]) -> Vec<[f32; 3]> {
        let mut means = Vec::new();
        for cell in self.cells_around(p) {
            for k in 0..cell.len() {
                let m = cell.point(k);
                if self.model.collides(p, m, cell.value[k]) {
                    means.push(m);
                }
            }
        }
        means
    }

    /// How far `p` is inside the obstacles it collides with: the largest reach less distance
    /// over them, 0 when it collides with none. A way out of a start in collision is a move
    /// that makes this smaller, wherever the obstacles are.
    pub fn penetration(&self, p: [f32; 3]) -> f32 {
        let mut deepest = 0.0f32;
        for cell in self.cells_around(p) {
            for k in 0..cell.len() {
                let m = cell.point(k);
                let reach = self.model.robot_radius + self.model.gaussian_scale * cell.value[k];
                let d =
                    ((p[0] - m[0]).powi(2) + (p[1] - m[1]).powi(2) + (p[2] - m[2]).powi(2)).sqrt();
                deepest = deepest.max(reach - d);
            }
        }
        deepest
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
