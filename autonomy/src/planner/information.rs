//! Information of a viewpoint (DESIGN.md): xi = #high-uncertainty Gaussians in view -
//! lambda_xi #low-uncertainty ones, "in view" meaning inside the camera frustum and within
//! the sensor range (planar depth), no occlusion test. A dense 3-D grid of cells answers it
//! exactly: cells wholly inside the view add their counts, cells on the boundary test their
//! members one by one.
//!
//! The grid follows the mirror's changes and keeps each cell's members sorted by
//! uncertainty, so the high / low thresholds, which move with every mapping step, are
//! applied per cell by two binary searches instead of by refiling the map.

use super::lattice::{CellPoints, PointLattice, OVERFLOW};
use super::mirror::{Change, Record};
use super::unicycle::Pose2;
use crate::camera::Intrinsics;
use crate::map::{UncertaintyClass, UncertaintyStats};

/// Where the camera sits on the robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraMount {
    /// Intrinsics of the sensor.
    pub intrinsics: Intrinsics,
    /// Forward offset from the robot's centre, metres.
    pub forward: f64,
    /// Height above the floor, metres.
    pub height: f64,
    /// Sensor range (planar depth), metres.
    pub range: f64,
}

impl Default for CameraMount {
    fn default() -> Self {
        // models/unicycle.xml: camera 0.2 m ahead, 0.4 m up, fovy 60, 320x240; 5 m range.
        CameraMount {
            intrinsics: Intrinsics::from_fovy(60f64.to_radians(), 320, 240),
            forward: 0.2,
            height: 0.4,
            range: 5.0,
        }
    }
}

impl CameraMount {
    /// The level camera of the robot at `s`: optical x to the robot's right, y down, z ahead.
    pub fn camera_at(&self, s: &Pose2) -> crate::camera::PinholeCamera {
        let (c, sn) = (s.theta.cos(), s.theta.sin());
        let rotation = crate::math::Matrix3::new(sn, 0.0, c, -c, 0.0, sn, 0.0, -1.0, 0.0);
        let rotation = crate::math::UnitQuaternion::from_matrix(&rotation);
        let centre = crate::math::Translation3::new(
            s.x + self.forward * c,
            s.y + self.forward * sn,
            self.height,
        );
        crate::camera::PinholeCamera {
            intrinsics: self.intrinsics,
            world_from_camera: crate::math::Isometry3::from_parts(centre, rotation),
        }
    }
}

/// A camera pose reduced to what the frustum test needs.
#[derive(Debug, Clone, Copy)]
struct View {
    centre: [f32; 3],
    forward: [f32; 2],
    range: f32,
    // |x / z| and |y / z| limits of the image.
    half_x: f32,
    half_y_up: f32,
    half_y_down: f32,
}

impl View {
    fn new(mount: &CameraMount, s: &Pose2) -> Self {
        let k = &mount.intrinsics;
        let (c, sn) = (s.theta.cos(), s.theta.sin());
        View {
            centre: [
                (s.x + mount.forward * c) as f32,
                (s.y + mount.forward * sn) as f32,
                mount.height as f32,
            ],
            forward: [c as f32, sn as f32],
            range: mount.range as f32,
            half_x: ((k.cx + 0.5) / k.fx) as f32,
            // Image rows grow downward: the top edge is cy + 0.5 pixels above the centre.
            half_y_up: ((k.cy + 0.5) / k.fy) as f32,
            half_y_down: ((f64::from(k.height) - 0.5 - k.cy) / k.fy) as f32,
        }
    }

    /// Whether the point (x, y, z) is in view. Branch-free, so loops over members vectorise.
    #[inline(always)]
    fn sees(&self, x: f32, y: f32, z: f32) -> bool {
        let d = [x - self.centre[0], y - self.centre[1], z - self.centre[2]];
        let depth = d[0] * self.forward[0] + d[1] * self.forward[1];
        // Optical x points right: (sin, -cos); optical y points down: -world z.
        let right = d[0] * self.forward[1] - d[1] * self.forward[0];
        let up = d[2];
        (depth > 0.0)
            & (depth <= self.range)
            & (right.abs() <= self.half_x * depth)
            & (up <= self.half_y_up * depth)
            & (-up <= self.half_y_down * depth)
    }
}

/// What a view needs of a cell before reading its members, packed apart from them so the
/// scan over the cells under a view stays in cache: a box around the members (tighter than
/// the cell: Gaussians lie on surfaces, so more cells fall wholly inside or outside a view)
/// and the high and low counts under the current thresholds. The box grows with each member
/// that joins and is tightened again only once half the members have left since.
#[derive(Debug, Clone, Copy)]
struct CellSummary {
    lo: [f32; 3],
    hi: [f32; 3],
    high: u32,
    low: u32,
    /// Members that left since the box was last tightened.
    stale: u32,
    /// In this apply's list of boxes to tighten.
    queued: bool,
}

impl Default for CellSummary {
    fn default() -> Self {
        CellSummary {
            lo: [f32::MAX; 3],
            hi: [f32::MIN; 3],
            high: 0,
            low: 0,
            stale: 0,
            queued: false,
        }
    }
}

/// Padding of a cell's box, metres: keeps float rounding from calling a member on the box's
/// face inside a view its own test puts outside.
const BOX_PAD: f32 = 1e-3;

/// (is high, is low) of uncertainty `u`, as counts.
#[inline]
fn class(u: f32, low_below: f32, high_above: f32) -> (u32, u32) {
    (u32::from(u > high_above), u32::from(u < low_below))
}

/// (#high, #low) members of `cell` (values are uncertainties).
fn counts(cell: &CellPoints, low_below: f32, high_above: f32) -> (u32, u32) {
    let (mut high, mut low) = (0u32, 0u32);
    for u in &cell.value {
        let (h, l) = class(*u, low_below, high_above);
        high += h;
        low += l;
    }
    (high, low)
}

/// The tight box around the members of `cell`.
fn bounds(cell: &CellPoints) -> ([f32; 3], [f32; 3]) {
    let extent = |v: &[f32]| {
        v.iter()
            .fold((f32::MAX, f32::MIN), |(lo, hi), x| (lo.min(*x), hi.max(*x)))
    };
    let e = [extent(&cell.x), extent(&cell.y), extent(&cell.z)];
    (e.map(|b| b.0), e.map(|b| b.1))
}

/// (#high, #low) of the members of `cell` that `view` sees.
fn count_seen(cell: &CellPoints, view: &View, low_below: f32, high_above: f32) -> (u32, u32) {
    let (mut high, mut low) = (0u32, 0u32);
    let points = cell.x.iter().zip(&cell.y).zip(&cell.z);
    for (((x, y), z), u) in points.zip(&cell.value) {
        let seen = view.sees(*x, *y, *z);
        let (h, l) = class(*u, low_below, high_above);
        high += u32::from(seen) & h;
        low += u32::from(seen) & l;
    }
    (high, low)
}

/// Per-cell members of the map's Gaussians on a lattice anchored at the world origin, with
/// counts of the high and low ones under the current thresholds.
#[derive(Debug, Clone)]
pub struct ViewCounter {
    /// Gaussian means, valued by uncertainty.
    lattice: PointLattice,
    /// Per cell id (the overflow cell has none: it is always read member by member).
    summaries: Vec<CellSummary>,
    low_below: f32,
    high_above: f32,
    mount: CameraMount,
    /// lambda_xi.
    pub low_weight: f64,
}

impl ViewCounter {
    /// An empty counter with cells of side `cell` metres; nothing is high or low until
    /// [`ViewCounter::set_stats`] or [`ViewCounter::set_thresholds`].
    pub fn new(mount: CameraMount, cell: f32) -> Self {
        ViewCounter {
            lattice: PointLattice::new(cell),
            summaries: Vec::new(),
            low_below: f32::NEG_INFINITY,
            high_above: f32::INFINITY,
            mount,
            low_weight: 1.0,
        }
    }

    /// A counter over `means` already classified (Excluded and Other ones are filed but never
    /// count), for callers without a mirror.
    pub fn from_classes(
        means: &[[f32; 3]],
        classes: &[UncertaintyClass],
        mount: CameraMount,
        cell: f32,
    ) -> Self {
        let changes: Vec<Change> = means
            .iter()
            .zip(classes)
            .enumerate()
            .filter(|(_, (_, c))| **c != UncertaintyClass::Excluded)
            .map(|(i, (m, c))| Change {
                slot: i as u32,
                old: None,
                new: Some(Record {
                    mean: *m,
                    radius: 0.0,
                    uncertainty: match c {
                        UncertaintyClass::High => 1.0,
                        UncertaintyClass::Low => -1.0,
                        _ => 0.0,
                    },
                }),
            })
            .collect();
        let mut counter = ViewCounter::new(mount, cell);
        counter.apply(&changes);
        counter.set_thresholds(-0.5, 0.5);
        counter
    }

    /// Gaussians filed.
    pub fn len(&self) -> usize {
        self.lattice.len()
    }

    /// Whether none are filed.
    pub fn is_empty(&self) -> bool {
        self.lattice.is_empty()
    }

    /// Applies the mirror's changes: members leave and join their cells, whose counts and
    /// boxes follow.
    pub fn apply(&mut self, changes: &[Change]) {
        let (low_below, high_above) = (self.low_below, self.high_above);
        let mut loose: Vec<u32> = Vec::new();
        for change in changes.iter().filter(|c| c.old.is_some()) {
            let Some((c, u)) = self.lattice.remove(change.slot) else {
                continue;
            };
            if c != OVERFLOW {
                let left = self.lattice.get(c).len() as u32;
                let summary = &mut self.summaries[c as usize];
                let (h, l) = class(u, low_below, high_above);
                summary.high -= h;
                summary.low -= l;
                summary.stale += 1;
                if summary.stale >= left.max(1) && !summary.queued {
                    summary.queued = true;
                    loose.push(c);
                }
            }
        }
        self.lattice.cover_points(
            changes
                .iter()
                .filter_map(|c| c.new.as_ref().map(|r| &r.mean)),
        );
        for change in changes {
            let Some(new) = &change.new else {
                continue;
            };
            let c = self
                .lattice
                .insert(change.slot, new.mean, new.uncertainty, false);
            if c != OVERFLOW {
                let c = c as usize;
                if c >= self.summaries.len() {
                    self.summaries.resize(c + 1, CellSummary::default());
                }
                let summary = &mut self.summaries[c];
                let (h, l) = class(new.uncertainty, low_below, high_above);
                summary.high += h;
                summary.low += l;
                for a in 0..3 {
                    summary.lo[a] = summary.lo[a].min(new.mean[a]);
                    summary.hi[a] = summary.hi[a].max(new.mean[a]);
                }
            }
        }
        // Boxes that half their members have left since they were last tight.
        for c in loose {
            let summary = &mut self.summaries[c as usize];
            (summary.lo, summary.hi) = bounds(self.lattice.get(c));
            summary.stale = 0;
            summary.queued = false;
        }
    }

    /// High is above `high_above`, low below `low_below` (metres of uncertainty).
    pub fn set_thresholds(&mut self, low_below: f32, high_above: f32) {
        if low_below.to_bits() == self.low_below.to_bits()
            && high_above.to_bits() == self.high_above.to_bits()
        {
            return;
        }
        self.low_below = low_below;
        self.high_above = high_above;
        for (cell, summary) in self.lattice.cells().iter().zip(&mut self.summaries) {
            (summary.high, summary.low) = counts(cell, low_below, high_above);
        }
    }

    /// RT-GuIDE's thresholds (as [`UncertaintyStats::class_of`]): more than half a
    /// standard deviation above the mean is high, below it low.
    pub fn set_stats(&mut self, stats: &UncertaintyStats) {
        let half = 0.5 * stats.std;
        self.set_thresholds(stats.mean - half, stats.mean + half);
    }

    /// (#high, #low) in view from robot state `s`.
    pub fn count(&self, s: &Pose2) -> (u32, u32) {
        let view = View::new(&self.mount, s);
        let (mut high, mut low) = count_seen(
            self.lattice.overflow(),
            &view,
            self.low_below,
            self.high_above,
        );
        let (f, c) = (view.forward, view.centre);
        let right = [f[1], -f[0]];
        // The view's six half-spaces as (normal, offset): inside when n . (p - c) + o > 0.
        let planes: [([f32; 3], f32); 6] = [
            ([f[0], f[1], 0.0], 0.0),
            ([-f[0], -f[1], 0.0], view.range),
            (
                [
                    view.half_x * f[0] - right[0],
                    view.half_x * f[1] - right[1],
                    0.0,
                ],
                0.0,
            ),
            (
                [
                    view.half_x * f[0] + right[0],
                    view.half_x * f[1] + right[1],
                    0.0,
                ],
                0.0,
            ),
            ([view.half_y_up * f[0], view.half_y_up * f[1], -1.0], 0.0),
            ([view.half_y_down * f[0], view.half_y_down * f[1], 1.0], 0.0),
        ];
        // Cells under the view: its footprint (a triangle) in x, y; its height span in z.
        let far = [
            [c[0], c[1]],
            [
                c[0] + view.range * (f[0] + view.half_x * right[0]),
                c[1] + view.range * (f[1] + view.half_x * right[1]),
            ],
            [
                c[0] + view.range * (f[0] - view.half_x * right[0]),
                c[1] + view.range * (f[1] - view.half_x * right[1]),
            ],
        ];
        let fold = |a: usize| {
            far.iter().fold((f32::MAX, f32::MIN), |(lo, hi), p| {
                (lo.min(p[a]), hi.max(p[a]))
            })
        };
        let ((xl, xh), (yl, yh)) = (fold(0), fold(1));
        let l = &self.lattice;
        let (Some((x0, x1)), Some((y0, y1)), Some((z0, z1))) = (
            l.span(0, xl, xh),
            l.span(1, yl, yh),
            l.span(
                2,
                c[2] - view.half_y_down * view.range,
                c[2] + view.half_y_up * view.range,
            ),
        ) else {
            return (high, low);
        };
        for cz in z0..=z1 {
            for cy in y0..=y1 {
                for cx in x0..=x1 {
                    let Some(k) = l.find([cx, cy, cz]) else {
                        continue;
                    };
                    let cell = &self.summaries[k as usize];
                    if cell.high + cell.low == 0 {
                        continue;
                    }
                    let centre = [0, 1, 2].map(|a| 0.5 * (cell.lo[a] + cell.hi[a]) - c[a]);
                    let half = [0, 1, 2].map(|a| 0.5 * (cell.hi[a] - cell.lo[a]) + BOX_PAD);
                    let mut outside = false;
                    let mut inside = true;
                    for (n, o) in &planes {
                        let v = n[0] * centre[0] + n[1] * centre[1] + n[2] * centre[2] + o;
                        let reach =
                            n[0].abs() * half[0] + n[1].abs() * half[1] + n[2].abs() * half[2];
                        if v + reach < 0.0 {
                            outside = true;
                            break;
                        }
                        inside &= v - reach > 0.0;
                    }
                    if outside {
                        continue;
                    }
                    if inside {
                        high += cell.high;
                        low += cell.low;
                        continue;
                    }
                    let (h, l) = count_seen(l.get(k), &view, self.low_below, self.high_above);
                    high += h;
                    low += l;
                }
            }
        }
        (high, low)
    }

    /// xi of state `s`.
    pub fn information(&self, s: &Pose2) -> f64 {
        let (h, l) = self.count(s);
        f64::from(h) - self.low_weight * f64::from(l)
    }

    /// (#high, #low) in view by checking every filed Gaussian against the thresholds: the
    /// reference.
    pub fn count_brute_force(&self, s: &Pose2) -> (u32, u32) {
        let view = View::new(&self.mount, s);
        let (mut high, mut low) = (0, 0);
        for cell in self.lattice.iter() {
            for k in 0..cell.len() {
                if view.sees(cell.x[k], cell.y[k], cell.z[k]) {
                    if cell.value[k] > self.high_above {
                        high += 1;
                    } else if cell.value[k] < self.low_below {
                        low += 1;
                    }
                }
            }
        }
        (high, low)
    }
}
