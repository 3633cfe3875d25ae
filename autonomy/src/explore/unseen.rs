//! Keeping the robot clear of floor not yet seen free: RT-GuIDE's frontier-regions extension
//! and the executor safety FBE and AG-SLAM get (`FbeConfig::avoid_unseen`,
//! `AgslamConfig::avoid_unseen`, flagged). The Gaussian collision check knows only surfaces
//! the camera has seen: the unseen side of a table passes it as floor.

use super::evidence::{CellClass, ClassGrid, EvidenceConfig, EvidenceGrid, FreeCells};
use super::Observation;
use crate::drive::Pose2;
use crate::map::GaussianMap;
use crate::planner::collision::CollisionModel;
use crate::planner::search::{self, Trajectory};

/// The robot's footprint radius, metres: within it of where the robot stands a candidate may
/// stay as near unseen cells as the robot already is.
pub const FOOTPRINT: f64 = 0.3;
/// Candidates keep this from cells not seen free (unseen, or where a depth ray ended),
/// metres: the chassis' corner radius (0.30 m, what a turn in place sweeps) and a cell, so
/// that any pose a candidate reaches can be turned in place. A whole cell, not half: a ray
/// that grazes an obstacle marks free the cells it crosses, their centres inside the
/// obstacle's edge too, so its surface lies up to a cell nearer than the first cell not seen
/// free; with half a cell the robot stopped 0.30 m from a cylinder whose side it had never
/// faced and turned into it (office_02, 415 steps at 275 s). At 0.22 m from unseen cells
/// only (the chassis' half width and a cell) the robot drove to 0.30 m of a wall it had not
/// seen and its corner struck it as it turned (apartment_02, twice in 663 s); and a hole in
/// the Gaussians on a table's side that depth rays had hit let it turn into the table
/// (apartment, 41 s). Not the full collision radius: unseen cells wrap round every door jamb,
/// and at 0.35 m no candidate through a door into an unseen room passed (office_01, before
/// the clear-start fallback of `keep_clear_of_unseen`).
pub const UNFREE_CLEARANCE: f64 = 0.35;
/// ... along a straight drive: the wheels' outer half width (0.245 m) and a little.
pub const STRAIGHT_CLEARANCE: f64 = 0.27;

/// Height slices of the evidence grid's free space, from 0.1 m to the camera: a cell is free
/// once a ray has crossed it below the camera. A ray over the top of something taller than
/// the camera proves nothing below it (office_02's 0.55 m cylinder); what is lower shows its
/// top, whose hits mark its cells. One slice: more would ask for low rays near the robot,
/// where the camera cannot see the floor (office_03 with 4: stuck at the spawn).
pub const HEIGHT_SLICES: u32 = 1;

/// An evidence grid whose free space is what the robot's body fits through: free evidence
/// only from rays between the obstacle band's bottom and the body's top (`collision`'s
/// sphere), crossing a cell below the camera (`camera_height`); rays over a table top say
/// nothing about the floor under it.
pub fn body_evidence(collision: &CollisionModel, camera_height: f64) -> EvidenceConfig {
    let defaults = EvidenceConfig::default();
    EvidenceConfig {
        free_height: f64::from(collision.centre_height + collision.robot_radius),
        free_from_height: defaults.min_height,
        height_slices: HEIGHT_SLICES,
        slices_top: camera_height,
        filled_class: CellClass::Unknown,
        frame_votes: false,
        free_cells: FreeCells::Crossed,
        ..defaults
    }
}

/// Per cell of an evidence grid, the distance to the nearest cell not seen free: one no ray
/// has crossed yet, or one where rays ended (an obstacle, whether the Gaussians show it yet
/// or not).
pub struct UnfreeDistance<'a> {
    grid: &'a ClassGrid,
    distance: Vec<f64>,
}

impl<'a> UnfreeDistance<'a> {
    /// The distances over `grid`.
    pub fn new(grid: &'a ClassGrid) -> Self {
        let free: Vec<bool> = grid.classes.iter().map(|c| *c == CellClass::Free).collect();
        UnfreeDistance {
            grid,
            distance: crate::explore::frontier::clearance(grid, &free),
        }
    }

    /// How many of `t`'s segments, from its start, have every sample point (10 cm apart)
    /// `radius` from cells not seen free; points within the footprint of `start` need only be
    /// as far as `start` is (the robot stands there), points off the grid fail.
    pub fn clear_segments(
        &self,
        t: &search::Trajectory,
        period: f64,
        radius: f64,
        start: Pose2,
    ) -> usize {
        let distance = |x: f64, y: f64| self.grid.cell_of([x, y]).map(|c| self.distance[c]);
        // Within its footprint the robot may stay as near as it stands, not come nearer: a
        // short arc (0.3 m) lies wholly inside it, and passed unchecked into a table the
        // Gaussians had a hole in (apartment, 41 s).
        let standing = distance(start.x, start.y).unwrap_or(0.0).min(radius);
        t.controls
            .iter()
            .zip(&t.states)
            .take_while(|(u, s)| {
                let points = search::segment_points(s, u, period, 0.1);
                let last = points.len().saturating_sub(1);
                points.iter().enumerate().all(|(k, p)| {
                    let within = (p.x - start.x).hypot(p.y - start.y) <= FOOTPRINT;
                    // A straight drive sweeps the wheels' half width; a turn, and any pose a
                    // turn may start from (a segment's end), the corner radius.
                    let sweep = if u.w == 0.0 && k != last {
                        STRAIGHT_CLEARANCE.min(radius)
                    } else {
                        radius
                    };
                    let need = if within { standing.min(sweep) } else { sweep };
                    distance(p.x, p.y).is_some_and(|d| d >= need) || (within && standing == 0.0)
                })
            })
            .count()
    }
}

/// Sent into rooms it has not seen, the robot also keeps clear of the grid's cells not
/// seen free: the Gaussian check alone takes the unseen side of a table for floor, and a
/// hole in the Gaussians where depth rays ended for a way through. When every candidate
/// comes near unseen cells (the room beyond a door the robot has only glimpsed), it drives
/// the clear start of the one that ends nearest the goal, to look from closer, rather than
/// failing where it stands.
pub fn keep_clear_of_unseen(
    trajectories: Vec<Trajectory>,
    grid: &ClassGrid,
    period: f64,
    robot: Pose2,
    goal: [f64; 2],
) -> Vec<Trajectory> {
    let unseen = UnfreeDistance::new(grid);
    let clear = |t: &Trajectory| unseen.clear_segments(t, period, UNFREE_CLEARANCE, robot);
    let (kept, near_unseen): (Vec<_>, Vec<_>) = trajectories
        .into_iter()
        .partition(|t| clear(t) == t.controls.len());
    if !kept.is_empty() {
        return kept;
    }
    let prefix = |mut t: Trajectory| {
        let k = clear(&t);
        t.controls.truncate(k);
        t.states.truncate(k + 1);
        (k > 0).then_some(t)
    };
    let remaining = |t: &Trajectory| {
        let end = t.states[t.states.len() - 1];
        (end.x - goal[0]).hypot(end.y - goal[1])
    };
    near_unseen
        .into_iter()
        .filter_map(prefix)
        .min_by(|a, b| remaining(a).total_cmp(&remaining(b)))
        .into_iter()
        .collect()
}

/// A body-height evidence grid kept beside a planner's own, only to keep its executor's
/// candidates clear of floor not yet seen free (FBE's and AG-SLAM's `avoid_unseen`): the
/// planner's grid, as its paper defines it, still decides where to go.
#[derive(Debug, Clone)]
pub struct UnseenGuard {
    grid: EvidenceGrid,
}

impl UnseenGuard {
    /// A guard for a robot of `collision`'s size whose camera is `camera_height` up.
    pub fn new(collision: &CollisionModel, camera_height: f64) -> Self {
        UnseenGuard {
            grid: EvidenceGrid::new(body_evidence(collision, camera_height)),
        }
    }

    /// Takes in one camera frame (its rays; the robot's footprint free).
    pub fn observe(&mut self, observation: &Observation<'_>) {
        self.grid.observe(observation, FOOTPRINT);
    }

    /// The cell classes a plan from `robot` over `map` keeps its candidates clear by.
    pub fn classes(&mut self, robot: Pose2, map: &GaussianMap) -> ClassGrid {
        self.grid.mark_free_disc([robot.x, robot.y], FOOTPRINT);
        self.grid.set_gaussians(&map.gaussians.means);
        self.grid.classes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::drive::{advance, UnicycleCommand};
    use crate::math::Point3;

    /// The apartment's kitchen table as the camera sees it from one side: a 0.74 m solid
    /// block (x in [1, 2], y in [-0.5, 0.5]) between the camera at (0, 0, 0.4) and a wall at
    /// x = 4. Rays to the wall over the table cross its far half at 0.8-1.2 m; rays to its
    /// near face end there. The papers' grid (free up to 1.3 m) takes the far half, which no
    /// ray at the body's height reached, for floor; the guard's grid does not.
    fn seen_over_a_table(grid: &mut EvidenceGrid) {
        let camera = Point3::new(0.0, 0.0, 0.4);
        for k in -20..=20 {
            let y = 0.025 * k as f64;
            // Low rays end on the table's near face.
            for z in [0.1, 0.2, 0.3, 0.5, 0.6, 0.7] {
                grid.integrate_ray(camera, Point3::new(1.0, y, z));
            }
            // Higher rays pass over the top to the wall.
            for z in [1.0, 1.1, 1.2, 1.25] {
                grid.integrate_ray(camera, Point3::new(4.0, y, z));
            }
        }
    }

    #[test]
    fn the_unseen_side_of_a_table_seen_over_its_top_is_floor_to_the_paper_grid_only() {
        let mut paper = EvidenceGrid::new(EvidenceConfig::default());
        seen_over_a_table(&mut paper);
        let collision = CollisionModel::default();
        let mut guard = UnseenGuard::new(&collision, 0.4);
        seen_over_a_table(&mut guard.grid);
        let far_side = [1.8, 0.0];
        let paper = paper.classes();
        let body = guard.grid.classes();
        let class = |g: &ClassGrid| g.cell_of(far_side).map(|c| g.classes[c]);
        assert_eq!(class(&paper), Some(CellClass::Free));
        assert_ne!(class(&body), Some(CellClass::Free));
        // A candidate that turns round the table's far side: the guard drops it, and keeps
        // one that stays on the near side.
        let robot = Pose2 {
            x: 0.3,
            y: 0.0,
            theta: 0.0,
        };
        let trajectory = |u: UnicycleCommand| {
            let mut states = vec![robot];
            for _ in 0..3 {
                let s = states[states.len() - 1];
                states.push(advance(&s, &u, 1.0));
            }
            Trajectory {
                controls: vec![u; 3],
                states,
                cost: 0.0,
                distance_to_goal: 0.0,
            }
        };
        let into_it = trajectory(UnicycleCommand { v: 0.6, w: 0.0 });
        let away = trajectory(UnicycleCommand { v: 0.0, w: 0.6 });
        let kept = keep_clear_of_unseen(
            vec![into_it.clone(), away.clone()],
            &body,
            1.0,
            robot,
            [2.0, 0.0],
        );
        assert_eq!(kept, vec![away]);
    }
}
