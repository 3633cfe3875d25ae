//! The executor every planner shares: its copy of the map with the dense Gaussian collision
//! check (every sample point against every Gaussian, through the incremental grid, brute force
//! or a GPU), the start check that gives a back-off heading, and the motion-primitive A* that
//! turns a target pose and a coarse guidance path into 1 s unicycle primitives.

use super::evidence::ClassGrid;
use super::unseen::keep_clear_of_unseen;
use super::{Plan, PlanFailure};
use crate::drive::{wrap_angle, DriveLimits, Pose2, UnicycleCommand};
use crate::map::{ClassifyOptions, GaussianMap};
use crate::planner::collision::{self, CollisionGrid, CollisionModel, Obstacles};
use crate::planner::gpu_collision::GpuCollision;
use crate::planner::mirror::{Change, MapMirror};
use crate::planner::search::{search, SearchConfig, Trajectory};

/// How the executor checks collisions.
#[derive(Debug)]
pub enum CollisionEngine {
    /// Every point against every Gaussian (the reference; slow).
    BruteForce,
    /// The incremental hash grid.
    Grid,
    /// Every point against every Gaussian on a GPU.
    Gpu(Box<GpuCollision>),
}

/// Spacing of the points tried as the A*'s goal along a guidance path, metres.
pub const LOOKAHEAD_STEP: f64 = 0.2;

/// Settings of the executor.
#[derive(Debug, Clone, PartialEq)]
pub struct ExecutorConfig {
    /// The A*.
    pub search: SearchConfig,
    /// The robot for collision checks.
    pub collision: CollisionModel,
    /// Which Gaussians are not obstacles (the ground plane).
    pub classify: ClassifyOptions,
    /// The grid files Gaussians up to this radius in cells; larger ones are checked always.
    pub grid_radius_cap: f32,
    /// The robot's drive limits (turns toward a goal's heading use the largest turn rate).
    pub limits: DriveLimits,
}

impl Default for ExecutorConfig {
    fn default() -> Self {
        ExecutorConfig {
            search: SearchConfig::default(),
            collision: CollisionModel::default(),
            classify: ClassifyOptions::default(),
            grid_radius_cap: 0.05,
            limits: DriveLimits::default(),
        }
    }
}

/// The executor and its copy of the map, brought up to date from what changed.
#[derive(Debug)]
pub struct Executor {
    config: ExecutorConfig,
    mirror: MapMirror,
    changes: Vec<Change>,
    grid: CollisionGrid,
    engine: CollisionEngine,
    /// The brute-force and GPU engines' list of every obstacle, refilled each sync (reused:
    /// refilling is cheaper than allocating millions of entries anew).
    obstacles: Obstacles,
}

/// The collision sample point of a pose.
pub fn sample_point(model: &CollisionModel, s: &Pose2) -> [f32; 3] {
    [s.x as f32, s.y as f32, model.centre_height]
}

/// Headings tried for a way out of a start in collision (every 22.5 degrees).
const ESCAPE_HEADINGS: usize = 16;

/// Where a robot whose start collides with the map should back off to: of `push` (straight
/// away from the obstacles it touches) and every `ESCAPE_HEADINGS` heading, the one whose
/// point a back-off's drive away (`BACK_OFF_DISTANCE`) is least deep in the obstacles
/// (`penetration`), the nearest to `push` among equals. Pushing away alone fails between two
/// obstacles: in a gap narrower than the collision model (a door whose jamb's Gaussians grew
/// as the robot passed), away from one side is into the other, and back-offs alternate
/// without end (apartment_02: stuck after 12 back-offs in 47 s); along the gap is the way out.
pub fn escape_heading(robot: &Pose2, push: f64, penetration: impl Fn([f64; 2]) -> f32) -> f64 {
    let reach = super::schedule::BACK_OFF_DISTANCE;
    let depth_toward = |h: f64| penetration([robot.x + reach * h.cos(), robot.y + reach * h.sin()]);
    let mut best = (push, depth_toward(push));
    for k in 0..ESCAPE_HEADINGS {
        let h = wrap_angle(push + std::f64::consts::TAU * k as f64 / ESCAPE_HEADINGS as f64);
        let depth = depth_toward(h);
        let nearer = wrap_angle(h - push).abs() < wrap_angle(best.0 - push).abs();
        if depth < best.1 || (depth == best.1 && nearer) {
            best = (h, depth);
        }
    }
    best.0
}

impl Executor {
    /// An executor with an empty map.
    pub fn new(config: ExecutorConfig, engine: CollisionEngine) -> Self {
        let grid = CollisionGrid::new(config.collision, config.grid_radius_cap);
        Executor {
            config,
            mirror: MapMirror::new(),
            changes: Vec::new(),
            grid,
            engine,
            obstacles: Obstacles::default(),
        }
    }

    /// The settings.
    pub fn config(&self) -> &ExecutorConfig {
        &self.config
    }

    /// Brings the copy of the map up to date, touching only the Gaussians that changed, and
    /// returns those changes (planners that keep their own derived state apply them too).
    pub fn sync(&mut self, map: &GaussianMap) -> &[Change] {
        self.mirror
            .sync(map, &self.config.classify, &mut self.changes);
        // The grid is kept whatever the engine, so a failing GPU can hand over at once.
        self.grid.apply(&self.changes);
        if !matches!(self.engine, CollisionEngine::Grid) {
            self.obstacles.refill(&map.gaussians, &self.config.classify);
        }
        if let CollisionEngine::Gpu(gpu) = &mut self.engine {
            if let Err(e) = gpu.upload(&self.obstacles) {
                tracing::warn!("GPU collision upload failed ({e}); using the grid");
                self.engine = CollisionEngine::Grid;
            }
        }
        &self.changes
    }

    /// Which of `points` collide with the map.
    pub fn collisions(&self, points: &[[f32; 3]]) -> Vec<bool> {
        let model = &self.config.collision;
        match &self.engine {
            CollisionEngine::BruteForce => collision::brute_force(model, &self.obstacles, points),
            CollisionEngine::Grid => self.grid.check(points),
            CollisionEngine::Gpu(gpu) => {
                gpu.check(model, &self.obstacles, points)
                    .unwrap_or_else(|e| {
                        tracing::warn!("GPU collision check failed ({e}); using brute force");
                        collision::brute_force(model, &self.obstacles, points)
                    })
            }
        }
    }

    /// Whether the robot at `pose` is clear of the map.
    pub fn is_free(&self, pose: &Pose2) -> bool {
        !self.collisions(&[sample_point(&self.config.collision, pose)])[0]
    }

    /// Fails with the heading away from the colliding Gaussians (the sum of their unit
    /// offsets) when the robot's own position collides.
    pub fn check_start(&self, robot: &Pose2) -> Result<(), PlanFailure> {
        let p = sample_point(&self.config.collision, robot);
        if !self.collisions(&[p])[0] {
            return Ok(());
        }
        let (mut ax, mut ay) = (0.0f64, 0.0f64);
        for m in self.grid.colliding_means(p) {
            let (dx, dy) = (robot.x - f64::from(m[0]), robot.y - f64::from(m[1]));
            let n = dx.hypot(dy).max(1e-6);
            ax += dx / n;
            ay += dy / n;
        }
        let height = self.config.collision.centre_height;
        let away = escape_heading(robot, ay.atan2(ax), |q| {
            self.grid.penetration([q[0] as f32, q[1] as f32, height])
        });
        Err(PlanFailure::StartInCollision { away })
    }

    /// Whether the straight segment between two points is clear, sampled every `step` metres.
    pub fn segment_free(&self, from: [f64; 2], to: [f64; 2], step: f64) -> bool {
        let steps = ((to[0] - from[0]).hypot(to[1] - from[1]) / step).ceil() as usize;
        let h = self.config.collision.centre_height;
        let samples: Vec<[f32; 3]> = (1..=steps)
            .map(|k| {
                let t = k as f64 / steps as f64;
                [
                    (from[0] + t * (to[0] - from[0])) as f32,
                    (from[1] + t * (to[1] - from[1])) as f32,
                    h,
                ]
            })
            .collect();
        !self.collisions(&samples).contains(&true)
    }

    /// The motion-primitive A* from `robot` toward `goal`: collision-free candidates,
    /// complete ones first; empty when every primitive from the start collides.
    pub fn candidates(&self, robot: Pose2, goal: [f64; 2]) -> Vec<Trajectory> {
        let model = self.config.collision;
        let mut free = |segments: &[Vec<Pose2>]| -> Vec<bool> {
            let mut points = Vec::new();
            let mut owner = Vec::new();
            for (k, seg) in segments.iter().enumerate() {
                for s in seg {
                    points.push(sample_point(&model, s));
                    owner.push(k);
                }
            }
            let hits = self.collisions(&points);
            let mut ok = vec![true; segments.len()];
            for (hit, k) in hits.into_iter().zip(owner) {
                if hit {
                    ok[k] = false;
                }
            }
            ok
        };
        search(&self.config.search, robot, goal, &mut free)
    }

    /// Drives toward `target` along `guidance` (a polyline from the robot; the straight line
    /// when empty): the A* aims at the farthest point up to one horizon along the guidance
    /// that the robot `sees` (`visible_along`) and the cheapest complete candidate is taken.
    /// With `unseen` (an `UnseenGuard`'s classes), the collision-free candidates are kept
    /// clear of floor not seen free first (`unseen::keep_clear_of_unseen`);
    /// [`PlanFailure::NoCandidateClearOfUnseen`] when none is. Within the goal tolerance of the
    /// target the robot turns in place to the target's heading instead.
    pub fn drive_to(
        &self,
        robot: Pose2,
        target: Pose2,
        guidance: &[[f64; 2]],
        sees: impl Fn([f64; 2]) -> bool,
        unseen: Option<&ClassGrid>,
    ) -> Result<Plan, PlanFailure> {
        self.check_start(&robot)?;
        let search = &self.config.search;
        if robot.distance([target.x, target.y]) <= search.goal_tolerance {
            return Ok(self.turn_to(robot, target));
        }
        let mut path = vec![[robot.x, robot.y]];
        if guidance.len() >= 2 {
            path.extend_from_slice(&guidance[1..]);
        } else {
            path.push([target.x, target.y]);
        }
        let goal = visible_along(&path, search.horizon, LOOKAHEAD_STEP, sees);
        let trajectories = self.candidates(robot, goal);
        if trajectories.is_empty() {
            return Err(PlanFailure::NoCollisionFreeCandidate);
        }
        let trajectories = match unseen {
            Some(grid) => {
                let period = search.primitives.duration;
                keep_clear_of_unseen(trajectories, grid, period, robot, goal)
            }
            None => trajectories,
        };
        let candidates = trajectories.len();
        let alternatives = trajectories.iter().map(|t| t.states.clone()).collect();
        let best = trajectories
            .into_iter()
            .next()
            .ok_or(PlanFailure::NoCandidateClearOfUnseen)?;
        Ok(Plan {
            commands: best.controls,
            period: search.primitives.duration,
            states: best.states,
            target: Some(target),
            guidance: path,
            score: -best.cost,
            candidates,
            alternatives,
            commit: 0.0,
        })
    }

    /// Turning in place to `target`'s heading at up to the largest turn rate, in whole periods.
    fn turn_to(&self, robot: Pose2, target: Pose2) -> Plan {
        let period = self.config.search.primitives.duration;
        let turn = wrap_angle(target.theta - robot.theta);
        let steps = (turn.abs() / (self.config.limits.max_turn * period) - 1e-9)
            .ceil()
            .max(1.0) as usize;
        let w = turn / (steps as f64 * period);
        let command = UnicycleCommand { v: 0.0, w };
        let mut states = vec![robot];
        for _ in 0..steps {
            let last = states[states.len() - 1];
            states.push(crate::drive::advance(&last, &command, period));
        }
        Plan {
            commands: vec![command; steps],
            period,
            states,
            target: Some(target),
            guidance: vec![[robot.x, robot.y]],
            score: 0.0,
            candidates: 1,
            alternatives: Vec::new(),
            commit: 0.0,
        }
    }
}

/// A polyline's length, metres.
pub fn polyline_length(path: &[[f64; 2]]) -> f64 {
    path.windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum()
}

/// The point `length` metres along a polyline (its end when shorter): measured along the path,
/// not in a straight line, so a goal round a corner is not looked for through the wall.
pub fn along(path: &[[f64; 2]], length: f64) -> [f64; 2] {
    let mut left = length;
    for w in path.windows(2) {
        let (a, b) = (w[0], w[1]);
        let d = (b[0] - a[0]).hypot(b[1] - a[1]);
        if d >= left && d > 0.0 {
            let t = left / d;
            return [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
        }
        left -= d;
    }
    path.last().copied().unwrap_or([0.0, 0.0])
}

/// The farthest point up to `length` metres along `path` (a polyline from the robot) that
/// `sees` (the robot's line of sight to it), tried every `step` metres and stopping at the
/// first hidden one. Aimed at a point round a corner, the A*'s incomplete candidates end
/// nearest it, against the wall beside the corner, and the robot never turns the corner; aimed
/// at what the robot sees, it follows the path. The first step is taken even when hidden.
pub fn visible_along(
    path: &[[f64; 2]],
    length: f64,
    step: f64,
    sees: impl Fn([f64; 2]) -> bool,
) -> [f64; 2] {
    let reach = length.min(polyline_length(path));
    let tries = (reach / step).ceil().max(1.0) as usize;
    let mut goal = along(path, step.min(reach));
    for k in 2..=tries {
        let p = along(path, (k as f64 * step).min(reach));
        if !sees(p) {
            break;
        }
        goal = p;
    }
    goal
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Penetration into obstacles (centre, reach) by brute force, in the plane.
    fn depth(obstacles: &[([f64; 2], f64)], q: [f64; 2]) -> f32 {
        obstacles
            .iter()
            .map(|(m, reach)| (reach - (q[0] - m[0]).hypot(q[1] - m[1])) as f32)
            .fold(0.0, f32::max)
    }

    #[test]
    fn a_start_between_two_obstacles_backs_off_along_the_gap() {
        // A wall along y = 0.5 and a jamb's end at (0.15, -0.5), both reaching 0.52 m: the
        // robot at the origin is in both, and straight away from the wall is into the jamb.
        let mut obstacles: Vec<([f64; 2], f64)> =
            (-20..=20).map(|k| ([0.05 * k as f64, 0.5], 0.52)).collect();
        obstacles.push(([0.15, -0.5], 0.52));
        let robot = Pose2 {
            x: 0.0,
            y: 0.0,
            theta: 0.0,
        };
        let push = -std::f64::consts::FRAC_PI_2;
        let away = escape_heading(&robot, push, |q| depth(&obstacles, q));
        let at = |h: f64| {
            let d = crate::explore::schedule::BACK_OFF_DISTANCE;
            [d * h.cos(), d * h.sin()]
        };
        // Every heading on a fine circle: none is less deep than the one chosen by more than
        // the coarse circle's step allows, and the push itself is deeper.
        let finest = (0..360)
            .map(|k| depth(&obstacles, at(std::f64::consts::TAU * k as f64 / 360.0)))
            .fold(f32::INFINITY, f32::min);
        let chosen = depth(&obstacles, at(away));
        assert!(chosen <= finest + 0.01, "{chosen} vs {finest}");
        assert!(chosen < depth(&obstacles, at(push)) - 0.05, "away {away}");
        // Along the gap (west, away from the jamb), not across it.
        assert!(away.cos() < -0.7, "away {away}");
    }

    #[test]
    fn a_start_against_one_obstacle_backs_straight_away_from_it() {
        // One obstacle ahead: every heading that clears it ties, and the push wins.
        let obstacles = [([0.3, 0.0], 0.4)];
        let robot = Pose2 {
            x: 0.0,
            y: 0.0,
            theta: 0.0,
        };
        let push = std::f64::consts::PI;
        let away = escape_heading(&robot, push, |q| depth(&obstacles, q));
        assert_eq!(away, push);
    }
}
