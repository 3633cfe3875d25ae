//! The RT-GuIDE planner (DESIGN.md "RT-GuIDE planner"; the RT-GuIDE paper, IV-B): regions
//! of the map with utility Omega, a topological graph that picks a guidance path with the best
//! Omega / e^d, a motion-primitive A* toward the path's local goal with every sample point
//! collision-checked against every Gaussian, and the candidate that sees the most
//! high-uncertainty and the fewest low-uncertainty Gaussians. Failures come back as values.

pub mod collision;
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

/// The robot's footprint radius marked free in the evidence grid, metres.
const FOOTPRINT: f64 = 0.3;
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
/// the clear-start fallback below).
const UNFREE_CLEARANCE: f64 = 0.35;
/// ... along a straight drive: the wheels' outer half width (0.245 m) and a little.
const STRAIGHT_CLEARANCE: f64 = 0.27;

/// Height slices of the evidence grid's free space, from 0.1 m to the camera: a cell is free
/// once a ray has crossed it below the camera. A ray over the top of something taller than
/// the camera proves nothing below it (office_02's 0.55 m cylinder); what is lower shows its
/// top, whose hits mark its cells. One slice: more would ask for low rays near the robot,
/// where the camera cannot see the floor (office_03 with 4: stuck at the spawn).
const HEIGHT_SLICES: u32 = 1;
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

use crate::explore::evidence::{CellClass, ClassGrid, EvidenceConfig, EvidenceGrid};
pub use crate::explore::executor::{CollisionEngine, Executor, ExecutorConfig};
use crate::explore::fbe::FrontierView;
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
            // Free space is what the robot's body fits through: rays above its collision
            // sphere's top say nothing about it, and Gaussians above it do not block it.
            let body_top =
                f64::from(config.collision.centre_height + config.collision.robot_radius);
            let defaults = EvidenceConfig::default();
            EvidenceGrid::new(EvidenceConfig {
                free_height: body_top,
                free_from_height: defaults.min_height,
                height_slices: HEIGHT_SLICES,
                slices_top: config.mount.height,
                // The near range is for frontiers (what is seen thinly is not yet seen); with
                // free-space edges alone the grid only finds paths, and at 2 m it found none
                // out of the corridor fixture in 60 s.
                free_range: if config.frontier_regions {
                    FREE_RANGE
                } else {
                    defaults.free_range
                },
                ..defaults
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

    fn plan_with(
        &mut self,
        robot: Pose2,
        t0: Instant,
        finish: bool,
    ) -> Result<RtGuideStep, PlanFailure> {
        let cfg = &self.config;
        if self.tally.count() == 0 {
            return Err(PlanFailure::EmptyMap);
        }
        let model = cfg.collision;
        self.executor.check_start(&robot)?;
        // A reached target is remembered: looking at a region makes its Gaussians move, so its
        // utility does not fall, and without this the robot shuttles between two viewpoints.
        if let Some(t) = self.target {
            if (t[0] - robot.x).hypot(t[1] - robot.y) < cfg.min_viewpoint_distance {
                self.visited.push(t);
                self.target = None;
                if let Some(anchor) = self.target_frontier.take() {
                    self.cleared_frontiers.push(anchor);
                    // Reached is within a metre of the viewpoint, whatever the robot faces: a
                    // frontier it drove up to sideways was never seen, and cleared unseen it is
                    // never offered again (office_02: a corridor's mouth cleared at 5 s while
                    // the robot faced the room). It turns to face it before going on.
                    self.look_at = Some((anchor, 0));
                }
            }
        }
        // A turn spans plans (one a second); each plan turns what is left of it.
        if let Some((anchor, plans)) = self.look_at.take() {
            let half_width = (cfg.mount.intrinsics.cx / cfg.mount.intrinsics.fx).atan();
            let turn = (plans < MAX_LOOK_PLANS)
                .then(|| look_toward(robot, anchor, half_width, &cfg.search))
                .flatten();
            if let Some(turn) = turn {
                tracing::debug!("frontier at {anchor:.2?} reached unseen: turning to it");
                self.look_at = Some((anchor, plans + 1));
                return Ok(RtGuideStep::Plan(RtGuidePlan {
                    information: 0.0,
                    guidance: vec![[robot.x, robot.y], anchor],
                    local_goal: anchor,
                    candidates: 1,
                    alternatives: vec![turn.states.clone()],
                    seconds: [t0.elapsed().as_secs_f64(), 0.0, 0.0],
                    controls: turn.controls,
                    states: turn.states,
                }));
            }
        }
        // A frontier target kept for as long as any target may be without the robot closing
        // on it, and not reached, is given up.
        if self.target_progress.stalled_plans() >= self.config.keep_target_plans {
            self.give_up_target_frontier();
        }
        // Viewpoints first: clearing them renumbers the nodes after them.
        self.graph.clear_viewpoints();
        let cfg = self.config.clone();
        let source = self.graph.visit([robot.x, robot.y], cfg.odometry_spacing);
        let view = self.evidence.as_mut().map(|grid| {
            grid.mark_free_disc([robot.x, robot.y], FOOTPRINT);
            FrontierView::new(grid.classes(), robot, PATH_CLEARANCE, FOOTPRINT)
        });
        let k = &cfg.mount.intrinsics;
        let half_fov = (k.cx / k.fx).atan().min((k.cy / k.fy).atan());
        // The regions' viewpoints (frontiers may come first).
        let mut region_viewpoints = Vec::new();
        // With the tour, reached viewpoints: in the graph, their edges cut until no other
        // viewpoint can be chosen.
        let mut reached_viewpoints = Vec::new();
        for region in self.tally.regions() {
            // The shortest distance at which the region's bounding sphere fits the view.
            let reach = cfg.region_size * 3f64.sqrt() / 2.0 / half_fov.sin();
            let mut candidates = Vec::new();
            for j in 0..cfg.viewpoints_per_region {
                let a = std::f64::consts::TAU * j as f64 / cfg.viewpoints_per_region as f64;
                let p = [
                    region.centroid[0] + reach * a.cos(),
                    region.centroid[1] + reach * a.sin(),
                ];
                candidates.push((p, a + std::f64::consts::PI));
            }
            let points: Vec<[f32; 3]> = candidates
                .iter()
                .map(|(p, _)| [p[0] as f32, p[1] as f32, model.centre_height])
                .collect();
            let hits = self.executor.collisions(&points);
            for ((p, heading), hit) in candidates.into_iter().zip(hits) {
                // A viewpoint the robot stands at is reached, not a goal.
                let near = (p[0] - robot.x).hypot(p[1] - robot.y) < cfg.min_viewpoint_distance;
                if !hit && !near {
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
                    region_viewpoints.push(node);
                    if seen && cfg.tour_viewpoints {
                        reached_viewpoints.push(node);
                    }
                }
            }
        }
        if let Some(view) = view.as_ref().filter(|_| cfg.frontier_regions) {
            let unseen = UNSEEN_UNCERTAINTY * cfg.region_size;
            self.add_frontier_viewpoints(view, robot, unseen);
            // Only once a frontier was viewed: a first frame facing a wall has a frontier at
            // the robot's feet with no goal clear of the Gaussians (apartment_02 at 0 s).
            let viewed_one = !self.cleared_frontiers.is_empty();
            if finish
                && viewed_one
                && self.frontier_offers.is_empty()
                && self.frontiers_at_robot == 0
            {
                let busiest = self
                    .tally
                    .regions()
                    .iter()
                    .map(|r| r.omega)
                    .fold(0.0, f64::max);
                tracing::debug!("no frontier left; the most unsettled region's Omega {busiest:.6}");
                if busiest < cfg.settled_omega {
                    return Ok(RtGuideStep::Explored(format!(
                        "explored: no frontier left to view and every region settled (Omega at most {:.2} mm per step, under {:.2} mm)",
                        busiest * 1e3,
                        cfg.settled_omega * 1e3
                    )));
                }
            }
        }
        // Frontiers first: the regions' viewpoints yield while a frontier is offered, and come
        // back if no frontier viewpoint can be chosen (one within `min_viewpoint_distance` of
        // the graph's node at the robot, say), so an offer that cannot be taken never leaves
        // the robot without a goal.
        let mut set_aside = Vec::new();
        for node in &reached_viewpoints {
            set_aside.extend(self.graph.take_edges(*node));
        }
        let mut yielded = Vec::new();
        if cfg.frontiers_first && !self.frontier_offers.is_empty() {
            for node in &region_viewpoints {
                yielded.extend(self.graph.take_edges(*node));
            }
        }
        let previous = self.target.filter(|t| {
            (t[0] - robot.x).hypot(t[1] - robot.y) >= cfg.min_viewpoint_distance
                && self.target_progress.stalled_plans() < cfg.keep_target_plans
        });
        // The best viewpoint whose edge into the graph is clear of the map: a viewpoint is
        // joined to its nearest odometry node by a straight line, which can cross a wall (the
        // viewpoint then lies outside the known space and A* would push into the wall).
        let mut checked = 0;
        // With free-space edges, a viewpoint whose straight edge is blocked is still reached
        // along the evidence grid's free space from the robot; so is a frontier viewpoint
        // always, since the grid placed it (through a door, say) where it has a path.
        let mut free_path: Option<Vec<[f64; 2]>> = None;
        let (best, path) = loop {
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
            if self.executor.segment_free(from, to, EDGE_STEP) {
                break (best, path);
            }
            let frontier = self.frontier_offers.iter().any(|(p, _)| *p == to);
            if let Some(view) = view.as_ref().filter(|_| cfg.free_space_edges || frontier) {
                if view.path_length(to).is_finite() {
                    free_path = Some(view.guidance(robot, to));
                    break (best, path);
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
        };
        let target = self.graph.nodes[best].position;
        let same =
            previous.is_some_and(|p| (p[0] - target[0]).hypot(p[1] - target[1]) < KEEP_RADIUS);
        if let graph::NodeKind::Viewpoint { omega, .. } = self.graph.nodes[best].kind {
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
        let (guidance, goal) = match free_path {
            Some(guidance) => {
                // A grid path turns corners (through doors): the A* aims at what the robot
                // sees of it on the grid the path was found in.
                let sees = |p: [f64; 2]| {
                    view.as_ref()
                        .is_some_and(|v| v.grid.line_of_sight([robot.x, robot.y], p))
                };
                let goal = crate::explore::executor::visible_along(
                    &guidance,
                    cfg.search.horizon,
                    crate::explore::executor::LOOKAHEAD_STEP,
                    sees,
                );
                (guidance, goal)
            }
            None => {
                let mut guidance = vec![[robot.x, robot.y]];
                guidance.extend(path.iter().map(|i| self.graph.nodes[*i].position));
                let local = local_goal(&guidance, cfg.search.horizon).unwrap_or([robot.x, robot.y]);
                let goal = match view.as_ref() {
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

        let t1 = Instant::now();
        let mut trajectories = self.executor.candidates(robot, goal);
        // Sent into rooms it has not seen, the robot also keeps clear of the grid's cells not
        // seen free: the Gaussian check alone takes the unseen side of a table for floor, and
        // a hole in the Gaussians where depth rays ended for a way through.
        if let Some(view) = view.as_ref().filter(|_| cfg.frontier_regions) {
            let unseen = UnfreeDistance::new(&view.grid);
            let period = cfg.search.primitives.duration;
            let clear =
                |t: &search::Trajectory| unseen.clear_segments(t, period, UNFREE_CLEARANCE, robot);
            let (kept, near_unseen): (Vec<_>, Vec<_>) = trajectories
                .into_iter()
                .partition(|t| clear(t) == t.controls.len());
            trajectories = kept;
            // When every candidate comes near unseen cells (the room beyond a door the robot
            // has only glimpsed), it drives the clear start of the one that ends nearest the
            // goal, to look from closer, rather than failing where it stands.
            if trajectories.is_empty() {
                let prefix = |mut t: search::Trajectory| {
                    let k = clear(&t);
                    t.controls.truncate(k);
                    t.states.truncate(k + 1);
                    (k > 0).then_some(t)
                };
                let remaining = |t: &search::Trajectory| {
                    let end = t.states[t.states.len() - 1];
                    (end.x - goal[0]).hypot(end.y - goal[1])
                };
                trajectories.extend(
                    near_unseen
                        .into_iter()
                        .filter_map(prefix)
                        .min_by(|a, b| remaining(a).total_cmp(&remaining(b))),
                );
            }
        }
        if trajectories.is_empty() {
            return Err(PlanFailure::NoCollisionFreeCandidate);
        }

        let t2 = Instant::now();
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
        Ok(RtGuideStep::Plan(RtGuidePlan {
            controls: best.controls,
            states: best.states,
            information,
            guidance,
            local_goal: goal,
            candidates: scored.len(),
            alternatives: scored.iter().map(|(_, t)| t.states.clone()).collect(),
            seconds: [
                (t1 - t0).as_secs_f64(),
                (t2 - t1).as_secs_f64(),
                t2.elapsed().as_secs_f64(),
            ],
        }))
    }
}

/// A turn in place that brings `anchor` to the middle of the image, or `None` when it is
/// already within `LOOK_FRACTION` of the image's half width (`half_width`, radians) of it.
/// Equal segments of the primitives' period, none faster than their fastest turn.
fn look_toward(
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

/// Per cell of the evidence grid, the distance to the nearest cell not seen free: one no ray
/// has crossed yet, or one where rays ended (an obstacle, whether the Gaussians show it yet
/// or not).
struct UnfreeDistance<'a> {
    grid: &'a ClassGrid,
    distance: Vec<f64>,
}

impl<'a> UnfreeDistance<'a> {
    fn new(grid: &'a ClassGrid) -> Self {
        let free: Vec<bool> = grid.classes.iter().map(|c| *c == CellClass::Free).collect();
        UnfreeDistance {
            grid,
            distance: crate::explore::frontier::clearance(grid, &free),
        }
    }

    /// How many of `t`'s segments, from its start, have every sample point (10 cm apart)
    /// `radius` from cells not seen free; points within the footprint of `start` need only be
    /// as far as `start` is (the robot stands there), points off the grid fail.
    fn clear_segments(
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

impl RtGuidePlanner {
    /// Where the A* aims along a graph path (with the evidence grid): the paper's local goal
    /// (the path's last point within the horizon, in a straight line from the robot) while
    /// the robot sees it, else the farthest point along the path that it sees. A path that
    /// turns through a door puts the local goal behind the wall beside it; aimed there, the
    /// A*'s incomplete candidates end against that wall and the robot never reaches the door
    /// (office_04: 380 s in one room). Seen: the grid's free cells all the way, or a straight
    /// edge clear of the map's Gaussians, the test the graph's own edges pass.
    fn seen_graph_goal(
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
    fn add_frontier_viewpoints(&mut self, view: &FrontierView, robot: Pose2, omega: f64) {
        self.offer_frontiers(view, robot, omega);
        if self.frontier_offers.is_empty() && !self.set_aside_frontiers.is_empty() {
            self.set_aside_frontiers.clear();
            self.offer_frontiers(view, robot, omega);
        }
    }

    /// The target frontier, not reached, is set aside, or cleared on its last attempt.
    fn give_up_target_frontier(&mut self) {
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
mod tests {
    use super::*;

    /// A straight drive east along y = `y` for `seconds` at 0.5 m/s, one segment per second.
    fn drive_east(y: f64, seconds: usize) -> search::Trajectory {
        let u = UnicycleCommand { v: 0.5, w: 0.0 };
        let mut states = vec![Pose2 {
            x: 0.5,
            y,
            theta: 0.0,
        }];
        for _ in 0..seconds {
            let s = *states.last().expect("a state");
            states.push(crate::drive::advance(&s, &u, 1.0));
        }
        search::Trajectory {
            controls: vec![u; seconds],
            states,
            cost: 0.0,
            distance_to_goal: 0.0,
        }
    }

    /// Seen floor: a 7 x 4 m room round the origin and a 1.5 m wide corridor north from it to
    /// y = 14 m, where it opens onto unseen space; walls two cells thick elsewhere. And a map
    /// of one block of Gaussians 3 m east of the origin that still moves (Omega 1e-3).
    fn room_with_a_corridor() -> (EvidenceGrid, GaussianMap) {
        use crate::gaussians::Gaussians;
        let inside = |x: f64, y: f64| {
            ((-2.0..5.0).contains(&x) && (-2.0..2.0).contains(&y))
                || ((-0.75..0.75).contains(&x) && (-2.0..14.0).contains(&y))
        };
        let grid = seen_floor(inside, [-60, -60], [120, 300], |_, y| y < 14.0);
        let mut g = Gaussians::default();
        for k in 0..400 {
            let (i, j) = ((k % 20) as f32, (k / 20) as f32);
            g.push([3.0 + 0.01 * i, 0.01 * j, 0.5], 0.02, 0.9, [0.5; 3]);
        }
        (grid, GaussianMap::new(g, vec![1e-3; 400]))
    }

    fn frontiers_first_planner(grid: &EvidenceGrid, frontiers_first: bool) -> RtGuidePlanner {
        let mut planner = RtGuidePlanner::new(
            PlannerConfig {
                frontier_regions: true,
                frontiers_first,
                ..PlannerConfig::default()
            },
            CollisionEngine::Grid,
        );
        planner.evidence = Some(grid.clone());
        planner
    }

    #[test]
    fn with_frontiers_first_a_far_frontier_outranks_a_near_region() {
        let (grid, map) = room_with_a_corridor();
        let robot = Pose2 {
            x: 0.0,
            y: 0.0,
            theta: 0.0,
        };
        let target = |frontiers_first: bool| {
            let mut planner = frontiers_first_planner(&grid, frontiers_first);
            let plan = planner.plan(&map, robot).expect("a plan");
            let offers = planner.frontier_offers.clone();
            (plan.guidance.last().copied().expect("guidance"), offers)
        };
        // By Omega / e^d the block's viewpoints win (1e-3 e^-1.6 against 0.75 e^-13).
        let (paper, offers) = target(false);
        assert_eq!(
            offers.len(),
            1,
            "one frontier, the corridor's end: {offers:?}"
        );
        assert!(paper[1] < 5.0, "{paper:?}");
        // First, the frontier: its viewpoint within reach of the corridor's end.
        let (first, _) = target(true);
        assert!(
            (first[1] - 14.0).abs() <= FRONTIER_GOAL_RADIUS + 0.1 && first[0].abs() < 0.75,
            "{first:?}"
        );
    }

    #[test]
    fn with_frontiers_first_a_frontier_that_cannot_be_chosen_gives_the_regions_back() {
        let (grid, map) = room_with_a_corridor();
        // Where the corridor's frontier viewpoint lies, seen from inside the corridor.
        let far = Pose2 {
            x: 0.0,
            y: 8.0,
            theta: 0.0,
        };
        let mut probe = frontiers_first_planner(&grid, true);
        probe.plan(&map, far).expect("a plan");
        assert_eq!(probe.frontier_offers.len(), 1);
        let offer = probe.frontier_offers[0].0;
        // The robot 1.1 m short of it, the graph's node at the robot 0.9 m on, 0.2 m short of
        // the viewpoint: the viewpoint is offered (over 1 m from the robot) but lies within
        // 1 m of the plan's source node through the graph, so it cannot be chosen. The robot
        // faces down the corridor (its walls are in the evidence grid only, which the
        // candidates keep clear of but the search does not know).
        let robot = Pose2 {
            x: offer[0],
            y: offer[1] - 1.1,
            theta: -std::f64::consts::FRAC_PI_2,
        };
        let mut planner = frontiers_first_planner(&grid, true);
        planner
            .graph
            .visit([offer[0], offer[1] - 0.2], planner.config.odometry_spacing);
        let plan = planner
            .plan(&map, robot)
            .expect("the regions' viewpoints come back");
        assert_eq!(planner.frontier_offers.len(), 1);
        assert_eq!(planner.frontier_offers[0].0, offer);
        // The target is one of the block's viewpoints, 3 m east of the origin.
        let target = plan.guidance.last().copied().expect("guidance");
        assert!(target[1] < 6.0, "{target:?}");
    }

    #[test]
    fn a_frontier_reached_facing_away_is_cleared_after_a_turn_to_face_it() {
        let (grid, map) = room_with_a_corridor();
        let far = Pose2 {
            x: 0.0,
            y: 8.0,
            theta: 0.0,
        };
        let mut planner = frontiers_first_planner(&grid, true);
        let plan = planner.plan(&map, far).expect("a plan");
        let (offer, anchor) = planner.frontier_offers[0];
        assert_eq!(
            plan.guidance.last(),
            Some(&offer),
            "the frontier is the target"
        );
        // The robot arrives at the viewpoint with its back to the frontier.
        let away = (offer[1] - anchor[1]).atan2(offer[0] - anchor[0]);
        let arrived = Pose2 {
            x: offer[0],
            y: offer[1],
            theta: away,
        };
        let plan = planner.plan(&map, arrived).expect("a turn");
        assert!(plan.controls.iter().all(|u| u.v == 0.0 && u.w != 0.0));
        let end = plan.states[plan.states.len() - 1];
        let bearing = (anchor[1] - end.y).atan2(anchor[0] - end.x);
        assert!(crate::drive::wrap_angle(bearing - end.theta).abs() < 1e-9);
        assert_eq!(planner.cleared_frontiers, vec![anchor]);
        // A plan later, halfway round, the turn goes on; facing it, the planner moves on.
        let halfway = Pose2 {
            theta: plan.states[1].theta,
            ..arrived
        };
        let rest = planner.plan(&map, halfway).expect("the rest of the turn");
        assert!(rest.controls.iter().all(|u| u.v == 0.0));
        assert_eq!(rest.controls.len(), plan.controls.len() - 1);
        let facing = Pose2 {
            theta: end.theta,
            ..arrived
        };
        let _ = planner.plan(&map, facing);
        assert_eq!(planner.look_at, None);
    }

    #[test]
    fn frontier_viewpoints_are_worth_their_length_and_cleared_ones_are_not_offered() {
        use crate::explore::frontier;
        // 8 x 4 m seen floor with walls round it, except two openings onto unseen space on
        // its east wall: 2 m (a whole region side's worth at 2.5 m regions: 0.8) and 0.7 m.
        let (w, h) = (160, 80);
        let mut g = ClassGrid::filled([w, h], [0.0, 0.0], 0.05, CellClass::Free);
        for c in 0..g.len() {
            let (x, y) = (c % w, c / w);
            let wall = x <= 1 || y <= 1 || y >= h - 2 || (x >= w - 4 && x < w - 2);
            if x >= w - 2 {
                g.classes[c] = CellClass::Unknown;
            } else if wall && !(10..50).contains(&y) && !(60..74).contains(&y) {
                g.classes[c] = CellClass::Occupied;
            }
        }
        let robot = Pose2 {
            x: 1.0,
            y: 2.0,
            theta: 0.0,
        };
        let view = FrontierView::new(g.clone(), robot, PATH_CLEARANCE, FOOTPRINT);
        assert_eq!(view.clusters.len(), 2, "{:?}", view.clusters.len());
        let mut planner = RtGuidePlanner::new(
            PlannerConfig {
                frontier_regions: true,
                ..PlannerConfig::default()
            },
            CollisionEngine::Grid,
        );
        let omega = UNSEEN_UNCERTAINTY * planner.config.region_size;
        planner.add_frontier_viewpoints(&view, robot, omega);
        let first = offered_viewpoints(&planner);
        assert_eq!(first.len(), 2);
        for cluster in &view.clusters {
            // Brute force: the cluster's length in cells, and its viewpoint beside it.
            let length = cluster.cells.len() as f64 * g.cell;
            let expected = omega * (length / planner.config.region_size).min(1.0);
            let (p, worth) = first
                .iter()
                .min_by(|a, b| {
                    let d = |q: [f64; 2]| {
                        (q[0] - cluster.centroid[0]).hypot(q[1] - cluster.centroid[1])
                    };
                    d(a.0).total_cmp(&d(b.0))
                })
                .copied()
                .expect("a viewpoint");
            assert!((worth - expected).abs() < 1e-12, "{worth} vs {expected}");
            assert!(
                (p[0] - cluster.centroid[0]).hypot(p[1] - cluster.centroid[1])
                    <= FRONTIER_GOAL_RADIUS + 0.05
            );
            assert!(
                frontier::clearance(&g, &view.free)[g.cell_of(p).expect("on the grid")]
                    >= FRONTIER_GOAL_CLEARANCE
            );
        }
        // Once the longer one is cleared it is no longer offered; the shorter still is.
        let longer = view
            .clusters
            .iter()
            .max_by_key(|c| c.cells.len())
            .expect("a cluster");
        planner.cleared_frontiers.push(longer.anchor(&g));
        planner.graph.clear_viewpoints();
        planner.add_frontier_viewpoints(&view, robot, omega);
        let second = offered_viewpoints(&planner);
        assert_eq!(second.len(), 1);
        assert!(second[0].1 < first.iter().map(|f| f.1).fold(0.0, f64::max));
        // A given-up frontier is set aside while another is offered, offered again when none
        // is, and cleared for good at its last attempt.
        let shorter = view
            .clusters
            .iter()
            .min_by_key(|c| c.cells.len())
            .expect("a cluster")
            .anchor(&g);
        let worth = |planner: &mut RtGuidePlanner| -> Vec<f64> {
            planner.graph.clear_viewpoints();
            planner.add_frontier_viewpoints(&view, robot, omega);
            offered_viewpoints(planner).iter().map(|o| o.1).collect()
        };
        let give_up = |planner: &mut RtGuidePlanner| {
            planner.target_frontier = Some(shorter);
            planner.give_up_target_frontier();
        };
        planner.cleared_frontiers.clear();
        let both = worth(&mut planner);
        let (high, low) = (both[0].max(both[1]), both[0].min(both[1]));
        give_up(&mut planner);
        assert_eq!(
            worth(&mut planner),
            vec![high],
            "set aside while the other is offered"
        );
        planner.cleared_frontiers.push(longer.anchor(&g));
        assert_eq!(
            worth(&mut planner),
            vec![low],
            "offered again when no other is"
        );
        give_up(&mut planner);
        assert_eq!(
            worth(&mut planner),
            vec![low],
            "the second attempt is not the last"
        );
        give_up(&mut planner);
        assert!(
            worth(&mut planner).is_empty(),
            "the third attempt clears it"
        );
    }

    #[test]
    fn a_look_at_a_reached_frontier_turns_in_place_until_it_faces_it() {
        let search = SearchConfig::default();
        let half_width = 0.5;
        let robot = Pose2 {
            x: 1.0,
            y: 2.0,
            theta: 0.3,
        };
        // Anchors all round the robot, every 10 degrees.
        for k in 0..36 {
            let a = std::f64::consts::TAU * k as f64 / 36.0;
            let anchor = [robot.x + 2.0 * a.cos(), robot.y + 2.0 * a.sin()];
            let off_axis = crate::drive::wrap_angle(a - robot.theta).abs();
            let Some(turn) = look_toward(robot, anchor, half_width, &search) else {
                assert!(off_axis <= LOOK_FRACTION * half_width + 1e-9, "k = {k}");
                continue;
            };
            assert!(off_axis > LOOK_FRACTION * half_width, "k = {k}");
            // In place, within the drive's limits, one primitive period a segment.
            assert_eq!(turn.states.len(), turn.controls.len() + 1);
            for u in &turn.controls {
                assert_eq!(u.v, 0.0);
                assert!(u.w.abs() <= 0.9 + 1e-12, "w {}", u.w);
            }
            // Stepping the controls by the exact unicycle ends facing the anchor, where it
            // stood; the fewest segments that could.
            let mut s = robot;
            for u in &turn.controls {
                s = crate::drive::advance(&s, u, search.primitives.duration);
            }
            assert!((s.x - robot.x).abs() < 1e-12 && (s.y - robot.y).abs() < 1e-12);
            let facing = crate::drive::wrap_angle(a - s.theta).abs();
            assert!(facing < 1e-9, "k = {k}: {facing}");
            assert_eq!(
                turn.controls.len(),
                (off_axis / 0.9).ceil() as usize,
                "k = {k}"
            );
            assert_eq!(turn.states.last(), Some(&s));
        }
    }

    #[test]
    fn a_settled_region_moves_less_than_adam_moves_a_gaussian_pulled_one_way() {
        use crate::adam::{Adam, LearningRates};
        use crate::gaussians::{Gaussians, Gradients};
        // Brute force: Adam's own steps on one Gaussian under a steady pull along (1, -2, 3)
        // (a gradient of any size: Adam normalises it), ten iterations, as one mapping step.
        let rates = LearningRates::default();
        let mut g = Gaussians::default();
        g.push([0.0; 3], 0.02, 0.5, [0.5; 3]);
        let mut adam = Adam::new(rates);
        adam.resize(1);
        let mut grads = Gradients::zeros(1);
        grads.means[0] = [1e-3, -2e-3, 3e-3];
        grads.touched = vec![0];
        for _ in 0..10 {
            adam.step(&mut g, &grads);
        }
        let moved = g.means[0]
            .iter()
            .map(|m| f64::from(*m).powi(2))
            .sum::<f64>()
            .sqrt();
        let bound = settled_omega(10, f64::from(rates.means));
        assert!((moved - bound).abs() < 1e-3 * bound, "{moved} vs {bound}");
    }

    /// The viewpoints the last plan offered, with their utility.
    fn offered_viewpoints(planner: &RtGuidePlanner) -> Vec<([f64; 2], f64)> {
        planner
            .graph
            .nodes
            .iter()
            .filter_map(|n| match n.kind {
                graph::NodeKind::Viewpoint { omega, .. } => Some((n.position, omega)),
                graph::NodeKind::Odometry => None,
            })
            .collect()
    }

    #[test]
    fn with_the_tour_a_reached_viewpoint_waits_until_no_other_can_be_chosen() {
        // One block of moving Gaussians (one region), no evidence grid: its eight viewpoints
        // ring it 4.3 m out. The robot stands 1.2 m west of the west one.
        let (_, map) = room_with_a_corridor();
        let robot = Pose2 {
            x: -2.4,
            y: 0.1,
            theta: 0.0,
        };
        let planner = |tour: bool| {
            RtGuidePlanner::new(
                PlannerConfig {
                    tour_viewpoints: tour,
                    ..PlannerConfig::default()
                },
                CollisionEngine::Grid,
            )
        };
        let target = |p: &mut RtGuidePlanner| {
            p.target = None;
            let plan = p.plan(&map, robot).expect("a plan");
            plan.guidance.last().copied().expect("guidance")
        };
        // Brute force: the graph joins each viewpoint straight to the node at the robot, so
        // the best is the largest Omega e^-d over straight distances, viewpoints within
        // `min_viewpoint_distance` of the robot or of a reached target left out.
        let best = |offered: &[([f64; 2], f64)], reached: &[[f64; 2]], factor: f64| {
            let min = PlannerConfig::default().min_viewpoint_distance;
            let near = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]) < min;
            offered
                .iter()
                .filter(|(p, _)| !near(*p, [robot.x, robot.y]))
                .map(|(p, omega)| {
                    let reached = reached.iter().any(|r| near(*r, *p));
                    let w = if reached { factor } else { 1.0 };
                    (*p, w * omega * (-robot.distance(*p)).exp())
                })
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(p, _)| p)
                .expect("a viewpoint")
        };
        let close = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]) < 1e-6;
        let mut paper = planner(false);
        let first = target(&mut paper);
        let offered = offered_viewpoints(&paper);
        assert_eq!(offered.len(), 8, "{offered:?}");
        assert!(close(first, best(&offered, &[], 1.0)), "{first:?}");
        // Reached, it keeps a tenth of its utility, and e^-d still ranks it first.
        paper.visited.push(first);
        let again = target(&mut paper);
        assert!(close(again, best(&offered, &[first], 0.1)), "{again:?}");
        assert!(
            close(again, first),
            "the paper's planner goes back: {again:?}"
        );
        // With the tour it waits: the next is the best of the others.
        let mut tour = planner(true);
        assert!(close(target(&mut tour), first));
        tour.visited.push(first);
        let next = target(&mut tour);
        assert!(close(next, best(&offered, &[first], 0.0)), "{next:?}");
        assert!(
            robot.distance(next) > robot.distance(first) + 1.0,
            "{next:?}"
        );
        // Every viewpoint reached: a new round, all of them offered at their full utility.
        tour.visited = offered.iter().map(|(p, _)| *p).collect();
        let round = target(&mut tour);
        assert!(close(round, first), "{round:?}");
        assert!(tour.visited.is_empty());
    }

    #[test]
    fn with_the_tour_viewpoints_behind_a_wall_past_the_edge_checks_start_a_new_round() {
        use crate::gaussians::Gaussians;
        // A settled wall at x = 2 m (Omega 0); twelve moving blocks beyond it, whose 96
        // viewpoints all have edges across it, more than a plan's edge checks; one moving
        // block on the robot's side, every viewpoint of it already reached.
        let mut g = Gaussians::default();
        let mut omega = Vec::new();
        let mut block = |g: &mut Gaussians, x: f32, y: f32| {
            for k in 0..100 {
                let (i, j) = ((k % 10) as f32, (k / 10) as f32);
                g.push([x + 0.02 * i, y + 0.02 * j, 0.5], 0.02, 0.9, [0.5; 3]);
                omega.push(1e-3);
            }
        };
        for b in 0..12 {
            block(&mut g, 10.0, -14.0 + 2.5 * b as f32);
        }
        block(&mut g, -3.0, 0.0);
        for k in 0..800 {
            g.push([2.0, -20.0 + 0.05 * k as f32, 0.5], 0.02, 0.9, [0.5; 3]);
            omega.push(0.0);
        }
        let map = GaussianMap::new(g, omega);
        let robot = Pose2::default();
        let mut planner = RtGuidePlanner::new(
            PlannerConfig {
                tour_viewpoints: true,
                ..PlannerConfig::default()
            },
            CollisionEngine::Grid,
        );
        planner.plan(&map, robot).expect("a plan");
        let offered = offered_viewpoints(&planner);
        let beyond = offered
            .iter()
            .filter(|(p, w)| p[0] > 2.0 && *w > 0.0)
            .count();
        assert!(
            beyond > MAX_EDGE_CHECKS,
            "{beyond} viewpoints beyond the wall"
        );
        let near_side: Vec<[f64; 2]> = offered
            .iter()
            .filter(|(p, w)| p[0] < 2.0 && *w > 0.0)
            .map(|(p, _)| *p)
            .collect();
        assert!(!near_side.is_empty());
        planner.target = None;
        planner.visited = near_side.clone();
        let plan = planner
            .plan(&map, robot)
            .expect("a new round, not GoalUnreachable");
        let target = plan.guidance.last().copied().expect("guidance");
        assert!(
            near_side
                .iter()
                .any(|p| (p[0] - target[0]).hypot(p[1] - target[1]) < 1e-6),
            "{target:?}"
        );
        assert!(planner.visited.is_empty());
    }

    #[test]
    fn exploration_ends_only_with_no_frontier_to_view_and_every_region_settled() {
        let (grid, map) = room_with_a_corridor();
        let robot = Pose2 {
            x: 0.0,
            y: 0.0,
            theta: 0.0,
        };
        let settled = PlannerConfig::default().settled_omega;
        // The corridor's frontier, where a planner that reached it keeps it.
        let mut probe = frontiers_first_planner(&grid, true);
        probe.plan(&map, robot).expect("a plan");
        assert_eq!(probe.frontier_offers.len(), 1);
        let anchor = probe.frontier_offers[0].1;
        let step = |finish: bool, cleared: bool, omega: f32, at: Pose2| {
            let mut planner = frontiers_first_planner(&grid, true);
            planner.config.finish_when_explored = finish;
            if cleared {
                planner.cleared_frontiers.push(anchor);
            }
            let moving = GaussianMap::new(map.gaussians.clone(), vec![omega; map.len()]);
            let step = planner.step(&moving, at).expect("a step");
            assert!(planner.frontier_offers.is_empty() || !cleared);
            match step {
                RtGuideStep::Plan(_) => None,
                RtGuideStep::Explored(why) => Some(why),
            }
        };
        let below = (settled * 0.9) as f32;
        let above = (settled * 1.1) as f32;
        // The frontier viewed and the block's Gaussians settled: nothing is left.
        let why = step(true, true, below, robot).expect("explored");
        assert!(why.contains("no frontier left"), "{why}");
        // Any of: the switch off, the frontier still to view, the block still moving.
        assert_eq!(step(false, true, below, robot), None);
        assert_eq!(step(true, false, below, robot), None);
        assert_eq!(step(true, true, above, robot), None);
        // A frontier whose viewpoint is where the robot stands is not offered, yet not viewed.
        let offer = probe.frontier_offers[0].0;
        let there = Pose2 {
            x: offer[0],
            y: offer[1] - 0.5,
            theta: std::f64::consts::FRAC_PI_2,
        };
        let mut standing = frontiers_first_planner(&grid, true);
        standing.plan(&map, there).expect("a plan");
        assert!(standing.frontier_offers.is_empty() && standing.frontiers_at_robot == 1);
        assert_eq!(step(true, false, below, there), None);
        // Before any frontier was viewed nothing ends, frontier or none: a closed room seen
        // whole from a spawn in its middle.
        let closed = closed_room();
        let mut fresh = frontiers_first_planner(&closed, true);
        fresh.config.finish_when_explored = true;
        let still = GaussianMap::new(map.gaussians.clone(), vec![below; map.len()]);
        let step = fresh.step(&still, robot).expect("a step");
        assert!(matches!(step, RtGuideStep::Plan(_)), "{step:?}");
        assert!(fresh.frontier_offers.is_empty() && fresh.frontiers_at_robot == 0);
        fresh.cleared_frontiers.push([9.0, 9.0]);
        let step = fresh.step(&still, robot).expect("a step");
        assert!(matches!(step, RtGuideStep::Explored(_)), "{step:?}");
    }

    /// Seen floor: a 7 x 4 m room round the origin, walled all round (no frontier).
    fn closed_room() -> EvidenceGrid {
        let inside = |x: f64, y: f64| (-2.0..5.0).contains(&x) && (-2.0..2.0).contains(&y);
        seen_floor(inside, [-60, -60], [120, 60], |_, _| true)
    }

    /// An evidence grid of 5 cm cells `lo..hi` (cell indices): free where `inside`, and a
    /// wall two cells thick round it where `walled`; the rest unseen.
    fn seen_floor(
        inside: impl Fn(f64, f64) -> bool,
        lo: [i32; 2],
        hi: [i32; 2],
        walled: impl Fn(f64, f64) -> bool,
    ) -> EvidenceGrid {
        use crate::math::Point3;
        let cell = 0.05;
        let mut grid = EvidenceGrid::new(EvidenceConfig::default());
        for j in lo[1]..hi[1] {
            for i in lo[0]..hi[0] {
                let (x, y) = ((f64::from(i) + 0.5) * cell, (f64::from(j) + 0.5) * cell);
                let near_inside = (-2..=2)
                    .any(|a| (-2..=2).any(|b| inside(x + a as f64 * cell, y + b as f64 * cell)));
                if inside(x, y) {
                    // Free: a ray down to the floor ends in the cell without a hit.
                    grid.integrate_ray(Point3::new(x, y, 0.5), Point3::new(x + 1e-3, y, 0.0));
                } else if near_inside && walled(x, y) {
                    // A wall: a ray that ends in the cell at wall height.
                    grid.integrate_ray(Point3::new(x + 1e-3, y, 0.5), Point3::new(x, y, 0.5));
                }
            }
        }
        grid
    }

    #[test]
    fn the_free_range_is_where_one_frame_maps_the_floor_ten_centimetres_apart() {
        // Brute force: cast the camera's pixel rows (at a hundredth of a row) onto the floor
        // and find the range beyond which rows the mapper's stride apart land more than 10 cm
        // from each other.
        let mount = PlannerConfig::default().mount;
        let k = mount.intrinsics;
        let stride = crate::mapping::DensifyConfig::default().stride as f64;
        let floor = |v: f64| mount.height / ((v - k.cy) / k.fy);
        let mut v = f64::from(k.height) - 1.0;
        let mut dense_to = 0.0;
        while v - stride > k.cy {
            if floor(v - stride) - floor(v) > 0.1 {
                break;
            }
            dense_to = floor(v);
            v -= 0.01;
        }
        assert!(
            (dense_to - FREE_RANGE).abs() < 0.02,
            "dense to {dense_to:.3} m, free range {FREE_RANGE}"
        );
    }

    #[test]
    fn within_its_footprint_the_robot_may_not_come_nearer_to_cells_not_seen_free() {
        // Free floor with an occupied block at x in [3, 4], y in [1, 2]; the robot 0.4 m
        // west of it. Every move below stays inside the robot's footprint (0.3 m).
        let (w, h) = (100, 60);
        let mut g = ClassGrid::filled([w, h], [0.0, 0.0], 0.05, CellClass::Free);
        for c in 0..g.len() {
            let (x, y) = (c % w, c / w);
            if (60..80).contains(&x) && (20..40).contains(&y) {
                g.classes[c] = CellClass::Occupied;
            }
        }
        let distance = UnfreeDistance::new(&g);
        let start = Pose2 {
            x: 2.6,
            y: 1.5,
            theta: 0.0,
        };
        let step = |v: f64, w: f64| {
            let u = UnicycleCommand { v, w };
            search::Trajectory {
                controls: vec![u],
                states: vec![start, crate::drive::advance(&start, &u, 1.0)],
                cost: 0.0,
                distance_to_goal: 0.0,
            }
        };
        let clear = |t: &search::Trajectory| distance.clear_segments(t, 1.0, 0.33, start);
        // 0.25 m on toward the block: inside the footprint, but nearer than it stands.
        assert_eq!(clear(&step(0.25, 0.0)), 0);
        // Turning in place, or an arc that keeps its distance, stays as near as it was.
        assert_eq!(clear(&step(0.0, 0.9)), 1);
        // Away from the block.
        let mut back = step(0.25, 0.0);
        back.states = vec![
            Pose2 {
                theta: std::f64::consts::PI,
                ..start
            },
            Pose2 {
                x: start.x - 0.25,
                theta: std::f64::consts::PI,
                ..start
            },
        ];
        assert_eq!(distance.clear_segments(&back, 1.0, 0.33, back.states[0]), 1);
    }

    #[test]
    fn candidates_keep_the_radius_from_cells_not_seen_free_as_a_brute_force_scan_says() {
        // 5 x 3 m seen free, with a 1 x 1 m block at x in [3, 4], y in [1, 2]: its west half
        // occupied (where depth rays ended; the drive east into it stops there too), its
        // east half unseen.
        let (w, h) = (100, 60);
        let mut g = ClassGrid::filled([w, h], [0.0, 0.0], 0.05, CellClass::Free);
        for c in 0..g.len() {
            let (x, y) = (c % w, c / w);
            if (60..70).contains(&x) && (20..40).contains(&y) {
                g.classes[c] = CellClass::Occupied;
            }
            if (70..80).contains(&x) && (20..40).contains(&y) {
                g.classes[c] = CellClass::Unknown;
            }
        }
        let unseen = UnfreeDistance::new(&g);
        let cells: Vec<[f64; 2]> = (0..g.len())
            .filter(|c| g.classes[*c] != CellClass::Free)
            .map(|c| g.centre(c))
            .collect();
        // Brute force: per segment, the nearest unseen cell centre to any point of it; beyond
        // the grid's edge is unseen too (the ring of cells just outside it).
        let nearest = |t: &search::Trajectory| -> Vec<f64> {
            t.controls
                .iter()
                .zip(&t.states)
                .map(|(u, s)| {
                    search::segment_points(s, u, 1.0, 0.1)
                        .iter()
                        .map(|p| {
                            let edge = (p.x + 0.025)
                                .min(5.025 - p.x)
                                .min(p.y + 0.025)
                                .min(3.025 - p.y);
                            cells
                                .iter()
                                .map(|c| (c[0] - p.x).hypot(c[1] - p.y))
                                .fold(edge, f64::min)
                        })
                        .fold(f64::INFINITY, f64::min)
                })
                .collect()
        };
        let mut partial = 0;
        for y in [0.2, 0.4, 0.5, 0.6, 0.75, 1.5, 2.4, 2.6] {
            let t = drive_east(y, 8);
            let start = t.states[0];
            let d = nearest(&t);
            let expected = d.iter().take_while(|d| **d >= 0.35).count();
            // Away from the chamfer's 8% and the half cell, the two agree.
            let decided = d.iter().take(expected + 1).all(|d| (d - 0.35).abs() > 0.08);
            if decided {
                assert_eq!(
                    unseen.clear_segments(&t, 1.0, 0.35, start),
                    expected,
                    "y = {y}: nearest cell not free per segment {d:.3?} m"
                );
                partial += usize::from(expected > 0 && expected < 8);
            }
        }
        assert!(partial > 0, "no drive is clear for only part of its way");
        // Both sides of the test: some drives pass whole, some not at all.
        let clear =
            |t: &search::Trajectory, start: Pose2| unseen.clear_segments(t, 1.0, 0.35, start);
        assert_eq!(clear(&drive_east(0.5, 8), Pose2::default()), 8);
        // Into the block it stops short; off the grid it stops; a start inside the footprint
        // of an unseen cell passes for its first 0.3 m only.
        assert_eq!(clear(&drive_east(1.5, 8), Pose2::default()), 4);
        assert_eq!(clear(&drive_east(0.5, 12), Pose2::default()), 8);
        let inside = Pose2 {
            x: 3.5,
            y: 1.5,
            theta: 0.0,
        };
        let mut short = drive_east(1.5, 1);
        short.states[0] = inside;
        short.states[1] = crate::drive::advance(&inside, &short.controls[0], 1.0);
        assert_eq!(clear(&short, inside), 0);
        short.controls[0].v = 0.25;
        short.states[1] = crate::drive::advance(&inside, &short.controls[0], 1.0);
        assert_eq!(clear(&short, inside), 1);
    }

    #[test]
    fn a_graph_path_through_a_door_is_aimed_along_as_far_as_the_robot_sees() {
        use crate::gaussians::Gaussians;
        // 6 x 4 m of seen floor, a wall at y in [1.2, 1.3) with a door at x in [2.6, 3.4),
        // in the grid (occupied cells) and in the map (Gaussians up its face).
        let cell = 0.05;
        let (w, h) = (120, 80);
        let door = |x: f64| (2.6..3.4).contains(&x);
        let mut grid = ClassGrid::filled([w, h], [0.0, 0.0], cell, CellClass::Free);
        for c in 0..grid.len() {
            let [x, y] = grid.centre(c);
            if (1.2..1.3).contains(&y) && !door(x) {
                grid.classes[c] = CellClass::Occupied;
            }
        }
        let mut g = Gaussians::default();
        for i in 0..120 {
            let x = 0.025 + 0.05 * i as f64;
            if door(x) {
                continue;
            }
            for k in 0..20 {
                g.push(
                    [x as f32, 1.25, 0.05 + 0.06 * k as f32],
                    0.03,
                    0.9,
                    [0.5; 3],
                );
            }
        }
        let n = g.len();
        let mut planner = RtGuidePlanner::new(
            PlannerConfig {
                frontier_regions: true,
                ..PlannerConfig::default()
            },
            CollisionEngine::Grid,
        );
        planner.executor.sync(&GaussianMap::new(g, vec![1e-3; n]));
        let robot = Pose2 {
            x: 1.0,
            y: 0.5,
            theta: 0.0,
        };
        // East to the door, through it, west along the far side.
        let guidance = [[1.0, 0.5], [3.0, 0.5], [3.0, 2.0], [0.5, 2.0]];
        let horizon = planner.config.search.horizon;
        // Brute force: a segment crosses free cells only, looked at every centimetre.
        let clear = |to: [f64; 2]| {
            let n = ((to[0] - robot.x).hypot(to[1] - robot.y) / 0.01).ceil() as usize;
            (0..=n).all(|k| {
                let t = k as f64 / n.max(1) as f64;
                let (x, y) = (
                    robot.x + t * (to[0] - robot.x),
                    robot.y + t * (to[1] - robot.y),
                );
                let (i, j) = ((x / cell).floor() as usize, (y / cell).floor() as usize);
                grid.classes[j * w + i] == CellClass::Free
            })
        };
        // The paper's local goal (the path's end: all of it within the horizon) is behind the
        // wall west of the door.
        let local = local_goal(&guidance, horizon).expect("a path");
        assert_eq!(local, [0.5, 2.0]);
        assert!(!clear(local));
        // Brute force: every 0.2 m along the path, the last point before the first hidden one.
        let mut points = Vec::new();
        for s in 1..=((horizon / 0.2).round() as usize) {
            let d = 0.2 * s as f64;
            let p = if d <= 2.0 {
                [1.0 + d, 0.5]
            } else if d <= 3.5 {
                [3.0, 0.5 + (d - 2.0)]
            } else {
                [3.0 - (d - 3.5), 2.0]
            };
            points.push(p);
        }
        let first_hidden = points
            .iter()
            .position(|p| !clear(*p))
            .expect("one is hidden");
        let expected = points[first_hidden - 1];
        let goal = planner.seen_graph_goal(robot, &guidance, local, &grid);
        assert!(
            (goal[0] - expected[0]).hypot(goal[1] - expected[1]) < 1e-9,
            "{goal:?} vs {expected:?}"
        );
        // Up into the door, not short of it.
        assert!(goal[0] == 3.0 && goal[1] > 1.2, "{goal:?}");
        // A path the robot sees to its end keeps the paper's local goal.
        let straight = [[1.0, 0.5], [3.0, 0.5], [3.0, 1.0]];
        let local = local_goal(&straight, horizon).expect("a path");
        assert_eq!(
            planner.seen_graph_goal(robot, &straight, local, &grid),
            local
        );
    }
}
