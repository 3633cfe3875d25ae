//! RT-GuIDE's flagged extensions (each behind a `PlannerConfig` switch; off, the planner is
//! the paper's): frontier viewpoints on an evidence grid, the turn to face a frontier reached
//! sideways, the end of the exploration once nothing is left, a graph path aimed along as far
//! as the robot sees, and candidates kept clear of cells not seen free.

use super::*;
use crate::explore::unseen::keep_clear_of_unseen;

impl RtGuidePlanner {
    /// A turn in place toward a frontier target reached without facing it (see
    /// `note_reached_target`), spread over plans, one a second.
    pub(super) fn turn_to_reached_frontier(
        &mut self,
        robot: Pose2,
        t0: Instant,
    ) -> Option<RtGuidePlan> {
        let (anchor, plans) = self.look_at.take()?;
        let k = &self.config.mount.intrinsics;
        let half_width = (k.cx / k.fx).atan();
        let turn = (plans < MAX_LOOK_PLANS)
            .then(|| look_toward(robot, anchor, half_width, &self.config.search))
            .flatten()?;
        tracing::debug!("frontier at {anchor:.2?} reached unseen: turning to it");
        self.look_at = Some((anchor, plans + 1));
        Some(RtGuidePlan {
            information: 0.0,
            guidance: vec![[robot.x, robot.y], anchor],
            local_goal: anchor,
            candidates: 1,
            alternatives: vec![turn.states.clone()],
            seconds: [t0.elapsed().as_secs_f64(), 0.0, 0.0],
            controls: turn.controls,
            states: turn.states,
        })
    }

    /// Frontier regions: a viewpoint beside each frontier, worth the uncertainty of unseen
    /// space. With `finish`, the exploration's end when no frontier is left to view and every
    /// region has settled: its reason.
    pub(super) fn offer_frontier_viewpoints(
        &mut self,
        view: &FrontierView,
        robot: Pose2,
        finish: bool,
    ) -> Option<String> {
        let unseen = UNSEEN_UNCERTAINTY * self.config.region_size;
        self.add_frontier_viewpoints(view, robot, unseen);
        // Only once a frontier was viewed: a first frame facing a wall has a frontier at the
        // robot's feet with no goal clear of the Gaussians (apartment_02 at 0 s).
        let viewed_one = !self.cleared_frontiers.is_empty();
        if !(finish
            && viewed_one
            && self.frontier_offers.is_empty()
            && self.frontiers_at_robot == 0)
        {
            return None;
        }
        let busiest = self
            .tally
            .regions()
            .iter()
            .map(|r| r.omega)
            .fold(0.0, f64::max);
        tracing::debug!("no frontier left; the most unsettled region's Omega {busiest:.6}");
        let settled = self.config.settled_omega;
        (busiest < settled).then(|| {
            format!(
                "explored: no frontier left to view and every region settled (Omega at most {:.2} mm per step, under {:.2} mm)",
                busiest * 1e3,
                settled * 1e3
            )
        })
    }

    /// Sent into rooms it has not seen, the robot also keeps clear of the grid's cells not
    /// seen free (`crate::explore::unseen`).
    pub(super) fn keep_clear_of_unseen(
        &self,
        trajectories: Vec<search::Trajectory>,
        view: &FrontierView,
        robot: Pose2,
        goal: [f64; 2],
    ) -> Vec<search::Trajectory> {
        let period = self.config.search.primitives.duration;
        keep_clear_of_unseen(trajectories, &view.grid, period, robot, goal)
    }
}

/// A turn in place that brings `anchor` to the middle of the image, or `None` when it is
/// already within `LOOK_FRACTION` of the image's half width (`half_width`, radians) of it.
/// Equal segments of the primitives' period, none faster than their fastest turn.
pub(super) fn look_toward(
    robot: Pose2,
    anchor: [f64; 2],
    half_width: f64,
    search: &SearchConfig,
) -> Option<search::Trajectory> {
    let bearing = (anchor[1] - robot.y).atan2(anchor[0] - robot.x);
    let turn = crate::drive::wrap_angle(bearing - robot.theta);
    if turn.abs() <= LOOK_FRACTION * half_width {
        return None;
    }
    let fastest = search
        .primitives
        .controls
        .iter()
        .map(|u| u.w.abs())
        .fold(0.0, f64::max);
    let period = search.primitives.duration;
    if fastest <= 0.0 || period <= 0.0 {
        return None;
    }
    let segments = (turn.abs() / (fastest * period)).ceil().max(1.0) as usize;
    let u = UnicycleCommand {
        v: 0.0,
        w: turn / (segments as f64 * period),
    };
    let mut states = vec![robot];
    for _ in 0..segments {
        let last = states[states.len() - 1];
        states.push(crate::drive::advance(&last, &u, period));
    }
    Some(search::Trajectory {
        controls: vec![u; segments],
        states,
        cost: 0.0,
        distance_to_goal: 0.0,
    })
}

impl RtGuidePlanner {
    /// Where the A* aims along a graph path (with the evidence grid): the paper's local goal
    /// (the path's last point within the horizon, in a straight line from the robot) while
    /// the robot sees it, else the farthest point along the path that it sees. A path that
    /// turns through a door puts the local goal behind the wall beside it; aimed there, the
    /// A*'s incomplete candidates end against that wall and the robot never reaches the door
    /// (office_04: 380 s in one room). Seen: the grid's free cells all the way, or a straight
    /// edge clear of the map's Gaussians, the test the graph's own edges pass.
    pub(super) fn seen_graph_goal(
        &self,
        robot: Pose2,
        guidance: &[[f64; 2]],
        local: [f64; 2],
        grid: &ClassGrid,
    ) -> [f64; 2] {
        let from = [robot.x, robot.y];
        let sees = |p: [f64; 2]| {
            grid.line_of_sight(from, p) || self.executor.segment_free(from, p, EDGE_STEP)
        };
        if sees(local) {
            return local;
        }
        crate::explore::executor::visible_along(
            guidance,
            self.config.search.horizon,
            crate::explore::executor::LOOKAHEAD_STEP,
            sees,
        )
    }

    /// The frontier extension's viewpoints: per frontier cluster, the free cell nearest its
    /// anchor (`Cluster::anchor`) that is clear of the map's Gaussians, facing the anchor,
    /// worth `omega` for a frontier a region's side long and in proportion for shorter ones;
    /// none where the robot stands or for a frontier cleared before, nor for one given up
    /// before while any other frontier is offered.
    pub(super) fn add_frontier_viewpoints(
        &mut self,
        view: &FrontierView,
        robot: Pose2,
        omega: f64,
    ) {
        self.offer_frontiers(view, robot, omega);
        if self.frontier_offers.is_empty() && !self.set_aside_frontiers.is_empty() {
            self.set_aside_frontiers.clear();
            self.offer_frontiers(view, robot, omega);
        }
    }

    /// The target frontier, not reached, is set aside, or cleared on its last attempt.
    pub(super) fn give_up_target_frontier(&mut self) {
        if let Some(f) = self.target_frontier.take() {
            let attempts = 1 + self
                .given_up_frontiers
                .iter()
                .filter(|k| (k[0] - f[0]).hypot(k[1] - f[1]) < CLEARED_FRONTIER_RADIUS)
                .count();
            self.given_up_frontiers.push(f);
            if attempts >= MAX_FRONTIER_ATTEMPTS {
                self.cleared_frontiers.push(f);
            } else {
                self.set_aside_frontiers.push(f);
            }
        }
    }

    /// One pass of `add_frontier_viewpoints`, skipping cleared and set-aside frontiers.
    fn offer_frontiers(&mut self, view: &FrontierView, robot: Pose2, omega: f64) {
        let cfg = &self.config;
        let height = cfg.collision.centre_height;
        self.frontier_offers.clear();
        self.frontiers_at_robot = 0;
        for cluster in &view.clusters {
            let c = cluster.anchor(&view.grid);
            let skipped = self
                .cleared_frontiers
                .iter()
                .chain(&self.set_aside_frontiers)
                .any(|k| (k[0] - c[0]).hypot(k[1] - c[1]) < CLEARED_FRONTIER_RADIUS);
            if skipped {
                tracing::trace!("frontier at {c:.2?}: cleared or set aside before");
                continue;
            }
            // The goals nearest the frontier first; at most FRONTIER_GOAL_CHECKS of them,
            // spread over the list, are checked against the Gaussians, and the first clear wins.
            let goals = view.goals_near(c, FRONTIER_GOAL_RADIUS, FRONTIER_GOAL_CLEARANCE);
            let stride = goals.len().div_ceil(FRONTIER_GOAL_CHECKS).max(1);
            let tried: Vec<[f64; 2]> = goals.into_iter().step_by(stride).collect();
            let points: Vec<[f32; 3]> = tried
                .iter()
                .map(|p| [p[0] as f32, p[1] as f32, height])
                .collect();
            let hits = self.executor.collisions(&points);
            let Some(p) = tried
                .iter()
                .zip(hits)
                .find(|(_, hit)| !hit)
                .map(|(p, _)| *p)
            else {
                tracing::trace!(
                    "frontier at {c:.2?} ({} cells): none of {} goals near it is clear",
                    cluster.cells.len(),
                    tried.len()
                );
                continue;
            };
            if (p[0] - robot.x).hypot(p[1] - robot.y) < cfg.min_viewpoint_distance {
                tracing::trace!("frontier at {c:.2?}: its viewpoint {p:.2?} is at the robot");
                self.frontiers_at_robot += 1;
                continue;
            }
            let length = cluster.cells.len() as f64 * view.grid.cell;
            let utility = omega * (length / cfg.region_size).min(1.0);
            self.graph
                .add_viewpoint(p, utility, (c[1] - p[1]).atan2(c[0] - p[0]));
            self.frontier_offers.push((p, c));
        }
        tracing::debug!(
            "frontier viewpoints: {} of {} clusters ({} cleared before): {:.2?}",
            self.frontier_offers.len(),
            view.clusters.len(),
            self.cleared_frontiers.len(),
            self.frontier_offers
        );
    }
}
