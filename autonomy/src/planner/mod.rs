//! The RT-GuIDE planner (DESIGN.md "RT-GuIDE planner"; the RT-GuIDE paper, IV-B): regions
//! of the map with utility Omega, a topological graph that picks a guidance path with the best
//! Omega / e^d, a motion-primitive A* toward the path's local goal with every sample point
//! collision-checked against every Gaussian, and the candidate that sees the most
//! high-uncertainty and the fewest low-uncertainty Gaussians. Failures come back as values.

pub mod collision;
mod extensions;
pub mod gpu_collision;
pub mod graph;
pub mod information;
pub mod lattice;
pub mod mirror;
pub mod progress;
pub mod search;
pub mod tally;
pub mod unicycle;

use crate::map::{ClassifyOptions, GaussianMap};
use collision::CollisionModel;
use graph::{local_goal, TopologicalGraph, KEEP_RADIUS};
use information::{CameraMount, ViewCounter};
use progress::TargetProgress;
use search::SearchConfig;
use std::time::Instant;
use tally::Tally;
use unicycle::{Pose2, UnicycleCommand};

/// Spacing of the collision samples along a viewpoint's edge, metres.
const EDGE_STEP: f64 = 0.1;
/// Viewpoints tried per plan before the goal counts as unreachable.
const MAX_EDGE_CHECKS: usize = 64;

/// Settings of the planner (the paper's values by default).
#[derive(Debug, Clone, PartialEq)]
pub struct PlannerConfig {
    /// Side of a region, metres.
    pub region_size: f64,
    /// A new odometry node is added when none is nearer than this, metres.
    pub odometry_spacing: f64,
    /// Viewpoints sampled around each region.
    pub viewpoints_per_region: usize,
    /// Viewpoints nearer than this (through the graph) count as reached and are not chosen,
    /// metres; without it Omega / e^d keeps choosing a viewpoint next to the robot.
    pub min_viewpoint_distance: f64,
    /// The last target is kept while it scores at least this share of the best viewpoint.
    pub keep_target_fraction: f64,
    /// ... and for at most this many plans in a row without its route coming shorter
    /// (`progress::PROGRESS_STEP`), so one the robot cannot close on is given up.
    pub keep_target_plans: usize,
    /// Utility factor of viewpoints within `min_viewpoint_distance` of a reached target.
    pub visited_utility_factor: f64,
    /// The A*.
    pub search: SearchConfig,
    /// The robot for collision checks.
    pub collision: CollisionModel,
    /// The camera for information.
    pub mount: CameraMount,
    /// Which Gaussians planning leaves out (the ground plane).
    pub classify: ClassifyOptions,
    /// The grid files Gaussians up to this radius in cells; larger ones are checked always.
    pub grid_radius_cap: f32,
    /// Cell side of the information grid, metres.
    pub information_cell: f32,
    /// Seconds of each plan the robot drives before the next plan may replace it (0: the
    /// paper's replanning every period; a flagged extension, `--rtguide-commit`).
    pub commit_seconds: f64,
    /// Reach viewpoints along the free space of a 2D evidence grid (built from the depth
    /// frames, as FBE's) when their straight edge into the graph is blocked (off: the paper's
    /// straight edges; a flagged extension, `--rtguide-free-space-edges`).
    pub free_space_edges: bool,
    /// Give unseen space utility: a viewpoint beside each frontier cluster of the evidence
    /// grid, facing it, with the uncertainty of a Gaussian nothing has seen (half a region
    /// side; off: the paper's regions of Gaussians only, so space nothing has been seen in
    /// draws nobody; a flagged extension, `--rtguide-frontier-regions`). With it, candidates
    /// also keep clear of cells the grid has not seen.
    pub frontier_regions: bool,
    /// With frontier regions: while a frontier viewpoint is offered, regions' viewpoints
    /// yield to it. A region's Omega is a displacement per mapping step, which Adam keeps to
    /// about its step size (1.7 mm at 10 iterations), some 300 times below a frontier's;
    /// but e^d weighs 6 m more of path as much, and the robot lingered among nearby regions
    /// with a room unseen 15 m off (office_02: 600 s in one room). They come back when no
    /// frontier viewpoint can be chosen. Off: they compete by Omega / e^d (a flagged
    /// extension, `--rtguide-frontiers-first`, on by default on the command line).
    pub frontiers_first: bool,
    /// With frontier regions: the episode ends once no frontier is left to view and every
    /// region's Omega is below `settled_omega`. Then nothing the planner values is left: the
    /// regions' utility is the mapper's jitter, Omega / e^d an argmax over noise that picks
    /// the nearest viewpoint, then the next, and the robot drove in circles for the rest of
    /// the budget while the mapper's revisits moved Gaussians off the surface (office_04 from
    /// 600 s of 1345 s; warehouse_02 lost 1.7 points of coverage). But the revisits also
    /// refine: ended there, the apartment's PSNR was 1.3 dB under the survey's and office_03
    /// mapped 5 points less. Off: the paper's planner, which runs to the budget (a flagged
    /// extension, `--rtguide-finish`, off by default).
    pub finish_when_explored: bool,
    /// Reached viewpoints are set aside, offered again only when no other viewpoint can be
    /// chosen, and then all of them (a new round): the revisits tour the map's regions. Off,
    /// a reached viewpoint keeps `visited_utility_factor` of its utility, which e^d outweighs
    /// 2.3 m further on, so once the frontiers are spent and Omega is the mapper's jitter the
    /// robot hopped among the viewpoints of the room it stood in (office_11, generated with a
    /// seed outside the suite: 470 s of 948 within 2 m of one point). A flagged extension,
    /// `--rtguide-tour`, on by default in the host (off here: the paper's planner).
    pub tour_viewpoints: bool,
    /// A region is settled below this Omega, metres per mapping step: the most Adam moves a
    /// Gaussian pulled steadily one way (its position rate on each axis, every iteration),
    /// so one region's Gaussians moving less on average are jittering, not converging. The
    /// host sets it from the mapper's settings (`settled_omega`).
    pub settled_omega: f64,
}

/// The most a mapping step of `iterations` Adam iterations at position rate `rate` (metres)
/// moves a Gaussian: `rate` on each of three axes, every iteration.
pub fn settled_omega(iterations: usize, rate: f64) -> f64 {
    iterations as f64 * rate * 3f64.sqrt()
}

/// Clearance from occupied cells of a free-space edge, metres.
const PATH_CLEARANCE: f64 = 0.3;
/// A frontier viewpoint lies within this of the frontier cell it looks at, metres (FBE's goal
/// radius once expanded).
const FRONTIER_GOAL_RADIUS: f64 = 1.5;
/// Goals of one cluster checked against the Gaussians per plan.
const FRONTIER_GOAL_CHECKS: usize = 64;
/// ... with this clearance from anything not free, metres (FBE's goal clearance).
const FRONTIER_GOAL_CLEARANCE: f64 = 0.35;
/// The utility of unseen space, per metre of region side. Omega is the mean displacement of a
/// region's Gaussians; a Gaussian in space nothing has seen is known only to lie somewhere in
/// its region, on average about half a side (0.48) from the region's centre. A frontier opens
/// that much in proportion to its length against a region's side (a whole side at most).
const UNSEEN_UNCERTAINTY: f64 = 0.5;

/// A frontier target reached with its anchor more than this fraction of the image's half
/// width off the optical axis gets a turn to face it first (at the edge of the image its
/// depth rays are the fewest).
const LOOK_FRACTION: f64 = 0.5;
/// Most plans in a row a look at a reached frontier may take (half a turn is 4 at 0.9 rad/s);
/// a robot that does not turn gives up on it.
const MAX_LOOK_PLANS: usize = 5;
/// RT-GuIDE's evidence grid takes space for seen only this near the camera, metres. Rays
/// reach 5 m, but what is seen only from that far is mapped sparsely: with free space to the
/// rays' end, a room seen through its door had no frontier, was never entered and its
/// furniture never mapped (apartment_02: 71.6% against the survey's 78.4%; 78.2% at 3 m). The
/// frontier stays at the edge of what was seen from near, as the survey's look-arounds do.
/// How near: where one frame still maps the floor densely. The mapper places a Gaussian at
/// every second pixel row; seen from the camera's 0.4 m with fy = 208 px, those rows land on
/// the floor (d^2 + h^2) / h * 2 / fy apart, 10 cm (two coverage radii) at 2.0 m. At 3 m
/// (22 cm apart) office_03 ended with its floor and walls covered more thinly than the
/// survey's everywhere, not in one missed room (`eval --surface-out`, BENCHMARKS.md).
const FREE_RANGE: f64 = 2.0;
/// A frontier whose cell nearest its centroid is this near a cleared one's is not offered
/// again, metres (FBE's blacklist radius).
const CLEARED_FRONTIER_RADIUS: f64 = 0.5;
/// Give-ups after which a frontier is cleared for good: one it cannot reach is not retried
/// for ever once it is the last one left.
const MAX_FRONTIER_ATTEMPTS: usize = 3;

impl Default for PlannerConfig {
    fn default() -> Self {
        PlannerConfig {
            region_size: 2.5,
            odometry_spacing: 1.0,
            viewpoints_per_region: 8,
            min_viewpoint_distance: 1.0,
            keep_target_fraction: 0.1,
            keep_target_plans: 15,
            visited_utility_factor: 0.1,
            search: SearchConfig::default(),
            collision: CollisionModel::default(),
            mount: CameraMount::default(),
            classify: ClassifyOptions::default(),
            grid_radius_cap: 0.05,
            // With boxes fitted to each cell's members, 1 m scored 500 views fastest of
            // 0.35 / 0.5 / 0.7 / 1 / 1.5 / 2 m (BENCHMARKS.md).
            information_cell: 1.0,
            commit_seconds: 0.0,
            free_space_edges: false,
            frontier_regions: false,
            frontiers_first: false,
            finish_when_explored: false,
            tour_viewpoints: false,
            // The default mapper's; the host sets the episode's own.
            settled_omega: {
                let mapper = crate::mapping::MapperConfig::default();
                settled_omega(mapper.iterations, f64::from(mapper.rates.means))
            },
        }
    }
}

use crate::explore::evidence::{ClassGrid, EvidenceConfig, EvidenceGrid};
pub use crate::explore::executor::{CollisionEngine, Executor, ExecutorConfig};
use crate::explore::fbe::FrontierView;
use crate::explore::unseen::{body_evidence, FOOTPRINT};
pub use crate::explore::{PlanFailure, Recovery};

/// RT-GuIDE's plan with its diagnostics: the controls to apply, one per second.
#[derive(Debug, Clone, PartialEq)]
pub struct RtGuidePlan {
    /// (v, w) per segment.
    pub controls: Vec<UnicycleCommand>,
    /// Start state and the end state of each segment.
    pub states: Vec<Pose2>,
    /// xi summed over the segment end states.
    pub information: f64,
    /// The guidance path (robot, then graph nodes), metres.
    pub guidance: Vec<[f64; 2]>,
    /// The local goal the search aimed at.
    pub local_goal: [f64; 2],
    /// Candidates scored.
    pub candidates: usize,
    /// The scored candidates' states (the chosen one among them).
    pub alternatives: Vec<Vec<Pose2>>,
    /// Seconds: sync + regions + graph, search, information.
    pub seconds: [f64; 3],
}

/// The planner and the state it keeps between plans: the graph, and its copy of the map with
/// everything derived from it (collision grid, uncertainty tallies, counting grid), brought up
/// to date from what changed.
#[derive(Debug)]
pub struct RtGuidePlanner {
    config: PlannerConfig,
    graph: TopologicalGraph,
    executor: Executor,
    tally: Tally,
    counter: ViewCounter,
    /// The viewpoint the last plan headed for: kept while it scores at least
    /// `keep_target_fraction` of the best, so two similar viewpoints do not make the robot
    /// dither between them.
    target: Option<[f64; 2]>,
    /// Whether the robot is closing on the target.
    target_progress: TargetProgress,
    /// Targets the robot has reached.
    visited: Vec<[f64; 2]>,
    /// The evidence grid of free-space edges and frontier viewpoints (when either is on).
    evidence: Option<EvidenceGrid>,
    /// This plan's frontier viewpoints with the frontier cells they look at.
    frontier_offers: Vec<([f64; 2], [f64; 2])>,
    /// The frontier cell the target looks at, when it is a frontier viewpoint.
    target_frontier: Option<[f64; 2]>,
    /// Frontier cells reached, or given up `MAX_FRONTIER_ATTEMPTS` times: offered no more
    /// (FBE's blacklist).
    cleared_frontiers: Vec<[f64; 2]>,
    /// A frontier target reached without facing it, and the plans spent turning to it.
    look_at: Option<([f64; 2], usize)>,
    /// Frontier cells given up since the offers last ran dry: offered again only when no
    /// other frontier is, since a target is given up for the local planner's failures too.
    set_aside_frontiers: Vec<[f64; 2]>,
    /// Every give-up, to count a frontier's attempts.
    given_up_frontiers: Vec<[f64; 2]>,
    /// This plan's frontier clusters left out only because their viewpoint is at the robot:
    /// not yet viewed, so exploration is not over.
    frontiers_at_robot: usize,
}

/// What one plan comes to: a plan to drive, or the end of the exploration with its reason.
#[derive(Debug, Clone, PartialEq)]
pub enum RtGuideStep {
    /// Drive this.
    Plan(RtGuidePlan),
    /// Nothing is left to explore (`PlannerConfig::finish_when_explored`): why.
    Explored(String),
}

impl RtGuidePlanner {
    /// A planner with an empty graph.
    pub fn new(config: PlannerConfig, engine: CollisionEngine) -> Self {
        let executor = Executor::new(
            ExecutorConfig {
                search: config.search.clone(),
                collision: config.collision,
                classify: config.classify,
                grid_radius_cap: config.grid_radius_cap,
                limits: crate::drive::DriveLimits::default(),
            },
            engine,
        );
        let evidence = (config.free_space_edges || config.frontier_regions).then(|| {
            let body = body_evidence(&config.collision, config.mount.height);
            EvidenceGrid::new(EvidenceConfig {
                // The near range is for frontiers (what is seen thinly is not yet seen); with
                // free-space edges alone the grid only finds paths, and at 2 m it found none
                // out of the corridor fixture in 60 s.
                free_range: if config.frontier_regions {
                    FREE_RANGE
                } else {
                    body.free_range
                },
                ..body
            })
        });
        let tally = Tally::new(config.region_size);
        let counter = ViewCounter::new(config.mount, config.information_cell);
        RtGuidePlanner {
            config,
            graph: TopologicalGraph::default(),
            executor,
            tally,
            counter,
            target: None,
            target_progress: TargetProgress::default(),
            visited: Vec::new(),
            evidence,
            frontier_offers: Vec::new(),
            target_frontier: None,
            cleared_frontiers: Vec::new(),
            look_at: None,
            set_aside_frontiers: Vec::new(),
            given_up_frontiers: Vec::new(),
            frontiers_at_robot: 0,
        }
    }

    /// A planner whose evidence grid starts as `grid` instead of empty (its own settings
    /// replaced by the grid's): for fixtures that need the robot to have seen a given floor,
    /// as the host's trap test does.
    pub fn with_evidence(
        config: PlannerConfig,
        engine: CollisionEngine,
        grid: EvidenceGrid,
    ) -> Self {
        let mut planner = RtGuidePlanner::new(config, engine);
        planner.evidence = Some(grid);
        planner
    }

    /// The topological graph.
    pub fn graph(&self) -> &TopologicalGraph {
        &self.graph
    }

    /// Plans from `robot` over `map`.
    /// Never ends the exploration: `step` does, when the config says so.
    pub fn plan(&mut self, map: &GaussianMap, robot: Pose2) -> Result<RtGuidePlan, PlanFailure> {
        match self.step_with(map, robot, false)? {
            RtGuideStep::Plan(plan) => Ok(plan),
            // `step_with` ends nothing when told not to.
            RtGuideStep::Explored(_) => Err(PlanFailure::GoalUnreachable),
        }
    }

    /// Plans from `robot` over `map`, or says the exploration is over
    /// (`PlannerConfig::finish_when_explored`).
    pub fn step(&mut self, map: &GaussianMap, robot: Pose2) -> Result<RtGuideStep, PlanFailure> {
        self.step_with(map, robot, self.config.finish_when_explored)
    }

    fn step_with(
        &mut self,
        map: &GaussianMap,
        robot: Pose2,
        finish: bool,
    ) -> Result<RtGuideStep, PlanFailure> {
        let t0 = Instant::now();
        self.update(map);
        if let Some(grid) = &mut self.evidence {
            grid.set_gaussians(&map.gaussians.means);
        }
        self.plan_with(robot, t0, finish)
    }

    /// Brings the executor's copy of the map and everything derived from it up to date,
    /// touching only the Gaussians that changed.
    fn update(&mut self, map: &GaussianMap) {
        let changes = self.executor.sync(map);
        self.tally.apply(changes);
        self.counter.apply(changes);
        self.counter.set_stats(&self.tally.stats());
    }

    /// One plan, as the paper's phases with the flagged extensions' hooks between them:
    /// bookkeeping of a reached target, the graph's viewpoints (regions', then frontiers'),
    /// the best viewpoint with a clear edge, the local goal along its path, the candidate
    /// trajectories, and the one that sees the most.
    fn plan_with(
        &mut self,
        robot: Pose2,
        t0: Instant,
        finish: bool,
    ) -> Result<RtGuideStep, PlanFailure> {
        if self.tally.count() == 0 {
            return Err(PlanFailure::EmptyMap);
        }
        self.executor.check_start(&robot)?;
        self.note_reached_target(robot);
        if let Some(turn) = self.turn_to_reached_frontier(robot, t0) {
            return Ok(RtGuideStep::Plan(turn));
        }
        // A frontier target kept for as long as any target may be without the robot closing
        // on it, and not reached, is given up.
        if self.target_progress.stalled_plans() >= self.config.keep_target_plans {
            self.give_up_target_frontier();
        }
        // Viewpoints first: clearing them renumbers the nodes after them.
        self.graph.clear_viewpoints();
        let source = self
            .graph
            .visit([robot.x, robot.y], self.config.odometry_spacing);
        let view = self.evidence.as_mut().map(|grid| {
            grid.mark_free_disc([robot.x, robot.y], FOOTPRINT);
            FrontierView::new(grid.classes(), robot, PATH_CLEARANCE, FOOTPRINT)
        });
        let offered = self.add_region_viewpoints(robot);
        if let Some(view) = view.as_ref().filter(|_| self.config.frontier_regions) {
            if let Some(reason) = self.offer_frontier_viewpoints(view, robot, finish) {
                return Ok(RtGuideStep::Explored(reason));
            }
        }
        let choice = self.choose_viewpoint(robot, source, view.as_ref(), offered)?;
        let (guidance, goal) = self.aim(robot, choice, view.as_ref());
        let t1 = Instant::now();
        let mut trajectories = self.executor.candidates(robot, goal);
        if trajectories.is_empty() {
            return Err(PlanFailure::NoCollisionFreeCandidate);
        }
        if let Some(view) = view.as_ref().filter(|_| self.config.frontier_regions) {
            trajectories = self.keep_clear_of_unseen(trajectories, view, robot, goal);
            if trajectories.is_empty() {
                return Err(PlanFailure::NoCandidateClearOfUnseen);
            }
        }
        let t2 = Instant::now();
        let mut plan = self.most_informative(trajectories, guidance, goal)?;
        plan.seconds = [
            (t1 - t0).as_secs_f64(),
            (t2 - t1).as_secs_f64(),
            t2.elapsed().as_secs_f64(),
        ];
        Ok(RtGuideStep::Plan(plan))
    }

    /// A reached target is remembered: looking at a region makes its Gaussians move, so its
    /// utility does not fall, and without this the robot shuttles between two viewpoints.
    fn note_reached_target(&mut self, robot: Pose2) {
        let Some(t) = self.target else { return };
        if (t[0] - robot.x).hypot(t[1] - robot.y) >= self.config.min_viewpoint_distance {
            return;
        }
        self.visited.push(t);
        self.target = None;
        if let Some(anchor) = self.target_frontier.take() {
            self.cleared_frontiers.push(anchor);
            // Reached is within a metre of the viewpoint, whatever the robot faces: a
            // frontier it drove up to sideways was never seen, and cleared unseen it is
            // never offered again (office_02: a corridor's mouth cleared at 5 s while the
            // robot faced the room). It turns to face it before going on.
            self.look_at = Some((anchor, 0));
        }
    }

    /// The regions' viewpoints (the paper's): `viewpoints_per_region` around each region's
    /// centroid at the distance its bounding sphere fills the view, those clear of the map
    /// and not at the robot, worth the region's Omega (a tenth of it once reached, unless
    /// the tour sets reached ones aside).
    fn add_region_viewpoints(&mut self, robot: Pose2) -> OfferedViewpoints {
        let cfg = &self.config;
        let k = &cfg.mount.intrinsics;
        let half_fov = (k.cx / k.fx).atan().min((k.cy / k.fy).atan());
        // The shortest distance at which the region's bounding sphere fits the view.
        let reach = cfg.region_size * 3f64.sqrt() / 2.0 / half_fov.sin();
        let mut offered = OfferedViewpoints::default();
        for region in self.tally.regions() {
            let candidates: Vec<([f64; 2], f64)> = (0..cfg.viewpoints_per_region)
                .map(|j| {
                    let a = std::f64::consts::TAU * j as f64 / cfg.viewpoints_per_region as f64;
                    let p = [
                        region.centroid[0] + reach * a.cos(),
                        region.centroid[1] + reach * a.sin(),
                    ];
                    (p, a + std::f64::consts::PI)
                })
                .collect();
            let points: Vec<[f32; 3]> = candidates
                .iter()
                .map(|(p, _)| [p[0] as f32, p[1] as f32, cfg.collision.centre_height])
                .collect();
            let hits = self.executor.collisions(&points);
            for ((p, heading), hit) in candidates.into_iter().zip(hits) {
                // A viewpoint the robot stands at is reached, not a goal.
                let near = (p[0] - robot.x).hypot(p[1] - robot.y) < cfg.min_viewpoint_distance;
                if hit || near {
                    continue;
                }
                let seen = self
                    .visited
                    .iter()
                    .any(|v| (v[0] - p[0]).hypot(v[1] - p[1]) < cfg.min_viewpoint_distance);
                let omega = if seen && !cfg.tour_viewpoints {
                    region.omega * cfg.visited_utility_factor
                } else {
                    region.omega
                };
                let node = self.graph.add_viewpoint(p, omega, heading);
                offered.regions.push(node);
                if seen && cfg.tour_viewpoints {
                    offered.reached.push(node);
                }
            }
        }
        offered
    }

    /// The best viewpoint whose edge into the graph is clear of the map (the paper's Omega /
    /// e^d, the previous target kept while it scores near the best): a viewpoint is joined to
    /// its nearest odometry node by a straight line, which can cross a wall (the viewpoint
    /// then lies outside the known space and A* would push into the wall). With the
    /// extensions, a blocked edge may be bypassed along the evidence grid's free space, the
    /// regions' viewpoints yield to frontiers', and the tour's reached viewpoints wait.
    fn choose_viewpoint(
        &mut self,
        robot: Pose2,
        source: usize,
        view: Option<&FrontierView>,
        offered: OfferedViewpoints,
    ) -> Result<Choice, PlanFailure> {
        let cfg = self.config.clone();
        // Frontiers first: the regions' viewpoints yield while a frontier is offered, and come
        // back if no frontier viewpoint can be chosen (one within `min_viewpoint_distance` of
        // the graph's node at the robot, say), so an offer that cannot be taken never leaves
        // the robot without a goal.
        let mut set_aside = Vec::new();
        for node in &offered.reached {
            set_aside.extend(self.graph.take_edges(*node));
        }
        let mut yielded = Vec::new();
        if cfg.frontiers_first && !self.frontier_offers.is_empty() {
            for node in &offered.regions {
                yielded.extend(self.graph.take_edges(*node));
            }
        }
        let previous = self.target.filter(|t| {
            (t[0] - robot.x).hypot(t[1] - robot.y) >= cfg.min_viewpoint_distance
                && self.target_progress.stalled_plans() < cfg.keep_target_plans
        });
        let mut checked = 0;
        loop {
            let Some((best, path, _)) = self.graph.best_viewpoint_keeping(
                source,
                cfg.min_viewpoint_distance,
                previous,
                cfg.keep_target_fraction,
            ) else {
                if !yielded.is_empty() {
                    tracing::debug!("no frontier viewpoint can be chosen; the regions' come back");
                    self.graph.restore(std::mem::take(&mut yielded));
                    continue;
                }
                if !set_aside.is_empty() {
                    tracing::debug!("no viewpoint not yet reached can be chosen; a new round");
                    self.graph.restore(std::mem::take(&mut set_aside));
                    self.visited.clear();
                    continue;
                }
                return Err(PlanFailure::GoalUnreachable);
            };
            let from = if path.len() >= 2 {
                self.graph.nodes[path[path.len() - 2]].position
            } else {
                [robot.x, robot.y]
            };
            let to = self.graph.nodes[best].position;
            checked += 1;
            let chosen = |free_path| Choice {
                best,
                path: path.clone(),
                free_path,
                previous,
            };
            if self.executor.segment_free(from, to, EDGE_STEP) {
                return Ok(chosen(None));
            }
            // With free-space edges, a viewpoint whose straight edge is blocked is still
            // reached along the evidence grid's free space from the robot; so is a frontier
            // viewpoint always, since the grid placed it (through a door, say) where it has a
            // path.
            let frontier = self.frontier_offers.iter().any(|(p, _)| *p == to);
            if let Some(view) = view.filter(|_| cfg.free_space_edges || frontier) {
                if view.path_length(to).is_finite() {
                    return Ok(chosen(Some(view.guidance(robot, to))));
                }
            }
            if checked >= MAX_EDGE_CHECKS {
                // The tour's new round here too: viewpoints not yet reached may all lie behind
                // walls (office_11 with the tour ended stuck, every plan's 64 checks spent).
                if set_aside.is_empty() {
                    return Err(PlanFailure::GoalUnreachable);
                }
                tracing::debug!("no viewpoint not yet reached has a clear edge; a new round");
                self.graph.restore(std::mem::take(&mut set_aside));
                self.visited.clear();
                checked = 0;
            }
            self.graph.detach(best);
        }
    }

    /// Makes the chosen viewpoint the target and finds the local goal the A* aims at: the
    /// paper's (the guidance path's last point within the horizon), or along a grid path what
    /// the robot sees of it. Returns the guidance path and the goal.
    fn aim(
        &mut self,
        robot: Pose2,
        choice: Choice,
        view: Option<&FrontierView>,
    ) -> (Vec<[f64; 2]>, [f64; 2]) {
        let horizon = self.config.search.horizon;
        let target = self.graph.nodes[choice.best].position;
        let same = choice
            .previous
            .is_some_and(|p| (p[0] - target[0]).hypot(p[1] - target[1]) < KEEP_RADIUS);
        if let graph::NodeKind::Viewpoint { omega, .. } = self.graph.nodes[choice.best].kind {
            tracing::debug!(
                "target ({:.2}, {:.2}) omega {omega:.4}, previous {:.2?} (kept: {same}, {} plans stalled), {} visited",
                target[0],
                target[1],
                self.target,
                self.target_progress.stalled_plans(),
                self.visited.len()
            );
        }
        self.target = Some(target);
        self.target_frontier = self
            .frontier_offers
            .iter()
            .find(|(p, _)| *p == target)
            .map(|(_, c)| *c);
        let (guidance, goal) = match choice.free_path {
            Some(guidance) => {
                // A grid path turns corners (through doors): the A* aims at what the robot
                // sees of it on the grid the path was found in.
                let sees =
                    |p: [f64; 2]| view.is_some_and(|v| v.grid.line_of_sight([robot.x, robot.y], p));
                let goal = crate::explore::executor::visible_along(
                    &guidance,
                    horizon,
                    crate::explore::executor::LOOKAHEAD_STEP,
                    sees,
                );
                (guidance, goal)
            }
            None => {
                let mut guidance = vec![[robot.x, robot.y]];
                guidance.extend(choice.path.iter().map(|i| self.graph.nodes[*i].position));
                let local = local_goal(&guidance, horizon).unwrap_or([robot.x, robot.y]);
                let goal = match view {
                    Some(view) => self.seen_graph_goal(robot, &guidance, local, &view.grid),
                    None => local,
                };
                (guidance, goal)
            }
        };
        let remaining = crate::explore::executor::polyline_length(&guidance);
        if same {
            self.target_progress.observe(remaining);
        } else {
            self.target_progress.start(remaining);
        }
        (guidance, goal)
    }

    /// The candidate that sees the most (the paper's xi: high-uncertainty Gaussians in view
    /// minus low ones, summed over its states; ties to the cheaper), with the others as
    /// alternatives. `seconds` is left for the caller.
    fn most_informative(
        &self,
        trajectories: Vec<search::Trajectory>,
        guidance: Vec<[f64; 2]>,
        goal: [f64; 2],
    ) -> Result<RtGuidePlan, PlanFailure> {
        let counter = &self.counter;
        let scored: Vec<(f64, &search::Trajectory)> = trajectories
            .iter()
            .map(|t| {
                let xi = t.states[1..].iter().map(|s| counter.information(s)).sum();
                (xi, t)
            })
            .collect();
        let (information, best) = scored
            .iter()
            .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cost.total_cmp(&a.1.cost)))
            .map(|(xi, t)| (*xi, (*t).clone()))
            .ok_or(PlanFailure::NoCollisionFreeCandidate)?;
        Ok(RtGuidePlan {
            controls: best.controls,
            states: best.states,
            information,
            guidance,
            local_goal: goal,
            candidates: scored.len(),
            alternatives: scored.iter().map(|(_, t)| t.states.clone()).collect(),
            seconds: [0.0; 3],
        })
    }
}

/// The graph nodes of this plan's region viewpoints.
#[derive(Debug, Default)]
struct OfferedViewpoints {
    /// Every region viewpoint (they yield to frontiers' when frontiers come first).
    regions: Vec<usize>,
    /// Those reached before, which the tour sets aside until no other can be chosen.
    reached: Vec<usize>,
}

/// The viewpoint a plan heads for.
#[derive(Debug)]
struct Choice {
    /// Its graph node.
    best: usize,
    /// The graph path to it from the robot's node.
    path: Vec<usize>,
    /// A path along the evidence grid's free space, when its straight edge was blocked.
    free_path: Option<Vec<[f64; 2]>>,
    /// The previous target, while it may be kept.
    previous: Option<[f64; 2]>,
}

impl crate::explore::Planner for RtGuidePlanner {
    fn name(&self) -> &'static str {
        "rtguide"
    }

    fn settings(&self) -> serde_json::Value {
        let c = &self.config;
        serde_json::json!({
            "region_size": c.region_size,
            "viewpoints_per_region": c.viewpoints_per_region,
            "min_viewpoint_distance": c.min_viewpoint_distance,
            "horizon": c.search.horizon,
            "candidates": c.search.candidates,
            "information_cell": c.information_cell,
            "commit_seconds": c.commit_seconds,
            "free_space_edges": c.free_space_edges,
            "frontier_regions": c.frontier_regions,
            "frontiers_first": c.frontiers_first,
            "finish_when_explored": c.finish_when_explored,
            "tour_viewpoints": c.tour_viewpoints,
            "settled_omega": c.settled_omega,
        })
    }

    fn observe(&mut self, observation: &crate::explore::Observation<'_>, _map: &GaussianMap) {
        if let Some(grid) = &mut self.evidence {
            grid.observe(observation, FOOTPRINT);
        }
    }

    fn plan(&mut self, map: &GaussianMap, start: Pose2) -> crate::explore::Decision {
        use crate::explore::{Decision, Plan};
        match self.step(map, start) {
            Ok(RtGuideStep::Explored(reason)) => Decision::Done(reason),
            Ok(RtGuideStep::Plan(p)) => {
                tracing::debug!(
                    "at ({:.2}, {:.2}): goal ({:.2}, {:.2}), guidance {:.2?}, {} candidates, xi {}, controls {:?}",
                    start.x, start.y, p.local_goal[0], p.local_goal[1], p.guidance, p.candidates, p.information, p.controls
                );
                let target = p.guidance.last().map(|g| Pose2 {
                    x: g[0],
                    y: g[1],
                    theta: start.theta,
                });
                Decision::Go(Plan {
                    commands: p.controls,
                    period: self.config.search.primitives.duration,
                    states: p.states,
                    target,
                    guidance: p.guidance,
                    score: p.information,
                    candidates: p.candidates,
                    alternatives: p.alternatives,
                    commit: self.config.commit_seconds,
                })
            }
            Err(f) => Decision::Fail(f),
        }
    }
}

#[cfg(test)]
mod tests;
