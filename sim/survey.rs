//! The ground-truth survey (DESIGN.md "Comparison planners"): a lawn-mower path over all the
//! free space the robot can reach, with a look around at every row end and every few metres,
//! driven by a pursuit controller on the true pose. It knows the world (mj_ray), so its map is
//! the upper bound the exploration planners are compared with.

use crate::error::{Result, SimError};
use crate::evaluate::free;
use crate::robot::{DriveLimits, Pose2, UnicycleCommand};
use crate::world::World;
use autonomy::drive::{advance, wrap_angle};
use autonomy::explore::{Decision, Plan, Planner};
use autonomy::map::GaussianMap;
use autonomy::math::TotalF64;
use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};
use std::f64::consts::TAU;

/// How the lawn-mower is laid out.
#[derive(Debug, Clone, Copy)]
pub struct SurveyConfig {
    /// Side of a free-space cell, metres.
    pub cell: f64,
    /// Clearance the path keeps from the world (robot footprint 0.31 m plus margin), metres.
    pub clearance: f64,
    /// Distance between lawn-mower rows, metres.
    pub row_spacing: f64,
    /// Path length between look-arounds, metres.
    pub spin_every: f64,
    /// Half-width of the square searched for free space around the start, metres.
    pub extent: f64,
}

impl Default for SurveyConfig {
    fn default() -> Self {
        SurveyConfig {
            cell: 0.1,
            clearance: 0.45,
            row_spacing: 1.5,
            spin_every: 3.0,
            extent: 15.0,
        }
    }
}

/// One step of the survey: drive to a point, or turn a full circle where the robot stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SurveyStep {
    /// Drive to (x, y).
    GoTo([f64; 2]),
    /// Turn in place through a full circle.
    LookAround,
}

/// Cells reachable from the start with the clearance, found by flood fill.
struct FreeGrid {
    origin: [f64; 2],
    cell: f64,
    side: usize,
    reachable: Vec<bool>,
}

impl FreeGrid {
    fn flood(world: &World, start: [f64; 2], config: &SurveyConfig) -> Result<Self> {
        let side = (2.0 * config.extent / config.cell).ceil() as usize;
        let origin = [start[0] - config.extent, start[1] - config.extent];
        let mut grid = FreeGrid {
            origin,
            cell: config.cell,
            side,
            reachable: vec![false; side * side],
        };
        let seed = grid.cell_of(start);
        let mut visited = vec![false; side * side];
        let mut queue = VecDeque::new();
        let [sx, sy] = grid.centre(seed);
        if !free(world, sx, sy, config.clearance) {
            return Err(SimError::InvalidArgument {
                what: "survey start",
                detail: format!(
                    "the robot's start ({:.2}, {:.2}) has less than {:.2} m of clearance or is not \
                     inside a closed world; the survey needs walls all round and room to drive",
                    start[0], start[1], config.clearance
                ),
            });
        }
        visited[seed] = true;
        queue.push_back(seed);
        while let Some(c) = queue.pop_front() {
            grid.reachable[c] = true;
            for n in grid.neighbours(c) {
                if !visited[n] {
                    visited[n] = true;
                    let [x, y] = grid.centre(n);
                    if free(world, x, y, config.clearance) {
                        queue.push_back(n);
                    }
                }
            }
        }
        Ok(grid)
    }

    fn cell_of(&self, p: [f64; 2]) -> usize {
        let i = ((p[0] - self.origin[0]) / self.cell).floor() as usize;
        let j = ((p[1] - self.origin[1]) / self.cell).floor() as usize;
        j.min(self.side - 1) * self.side + i.min(self.side - 1)
    }

    fn centre(&self, c: usize) -> [f64; 2] {
        [
            self.origin[0] + (c % self.side) as f64 * self.cell + 0.5 * self.cell,
            self.origin[1] + (c / self.side) as f64 * self.cell + 0.5 * self.cell,
        ]
    }

    /// The 8 neighbours inside the grid.
    fn neighbours(&self, c: usize) -> impl Iterator<Item = usize> + '_ {
        let (i, j) = ((c % self.side) as isize, (c / self.side) as isize);
        let side = self.side as isize;
        (-1..=1)
            .flat_map(move |dj| (-1..=1).map(move |di| (i + di, j + dj)))
            .filter(move |&(x, y)| {
                (x, y) != (i, j) && (0..side).contains(&x) && (0..side).contains(&y)
            })
            .map(move |(x, y)| (y * side + x) as usize)
    }

    /// Shortest 8-connected path of reachable cells from `a` to `b` by Euclidean length
    /// (Dijkstra: a breadth-first search would zigzag, every staircase being as short).
    fn path(&self, a: usize, b: usize) -> Vec<usize> {
        let mut previous = vec![usize::MAX; self.reachable.len()];
        let mut distance = vec![f64::INFINITY; self.reachable.len()];
        distance[a] = 0.0;
        previous[a] = a;
        let mut queue = BinaryHeap::from([(Reverse(TotalF64(0.0)), a)]);
        while let Some((Reverse(TotalF64(d)), c)) = queue.pop() {
            if c == b {
                break;
            }
            if d > distance[c] {
                continue;
            }
            for n in self.neighbours(c) {
                let diagonal = n % self.side != c % self.side && n / self.side != c / self.side;
                let nd = d + if diagonal {
                    std::f64::consts::SQRT_2
                } else {
                    1.0
                };
                if self.reachable[n] && nd < distance[n] {
                    distance[n] = nd;
                    previous[n] = c;
                    queue.push((Reverse(TotalF64(nd)), n));
                }
            }
        }
        if previous[b] == usize::MAX {
            return Vec::new();
        }
        let mut path = vec![b];
        while path[path.len() - 1] != a {
            path.push(previous[path[path.len() - 1]]);
        }
        path.reverse();
        path
    }
}

/// Lays out the survey of the free space reachable from the robot's current pose: rows
/// `row_spacing` apart, alternating direction, joined by shortest free paths, with a look
/// around at the start, at each row end and every `spin_every` metres.
pub fn plan_survey(world: &World, config: &SurveyConfig) -> Result<Vec<SurveyStep>> {
    let pose = world.pose();
    let start = [pose.x, pose.y];
    let grid = FreeGrid::flood(world, start, config)?;
    let rows_every = (config.row_spacing / config.cell).round().max(1.0) as usize;
    // Row stops: the reachable runs of every `rows_every`-th row, as (first, last) cells.
    let (mut lo_row, mut hi_row) = (usize::MAX, 0);
    for (c, r) in grid.reachable.iter().enumerate() {
        if *r {
            lo_row = lo_row.min(c / grid.side);
            hi_row = hi_row.max(c / grid.side);
        }
    }
    let mut stops: Vec<usize> = Vec::new();
    let mut forward = true;
    let first_row = lo_row + (hi_row - lo_row) % rows_every / 2;
    for j in (first_row..=hi_row).step_by(rows_every) {
        let mut runs = Vec::new();
        let mut i = 0;
        while i < grid.side {
            if grid.reachable[j * grid.side + i] {
                let begin = i;
                while i < grid.side && grid.reachable[j * grid.side + i] {
                    i += 1;
                }
                runs.push((j * grid.side + begin, j * grid.side + i - 1));
            } else {
                i += 1;
            }
        }
        if !forward {
            runs.reverse();
            for r in &mut runs {
                *r = (r.1, r.0);
            }
        }
        for (a, b) in runs {
            stops.push(a);
            stops.push(b);
        }
        forward = !forward;
    }
    let mut steps = vec![SurveyStep::LookAround];
    let mut at = grid.cell_of(start);
    let mut since_spin = 0.0;
    for stop in stops {
        let path = grid.path(at, stop);
        if path.is_empty() {
            continue;
        }
        // Points every ~0.3 m along the cell path, the last one exact.
        let spacing = (0.3 / config.cell).round().max(1.0) as usize;
        for (k, c) in path.iter().enumerate().skip(1) {
            if k % spacing == 0 || k == path.len() - 1 {
                steps.push(SurveyStep::GoTo(grid.centre(*c)));
                since_spin += spacing as f64 * config.cell;
                if since_spin >= config.spin_every {
                    steps.push(SurveyStep::LookAround);
                    since_spin = 0.0;
                }
            }
        }
        if steps.last() != Some(&SurveyStep::LookAround) {
            steps.push(SurveyStep::LookAround);
            since_spin = 0.0;
        }
        at = stop;
    }
    Ok(steps)
}

/// Follows survey steps on the true pose: turn toward the next point, drive while facing it.
#[derive(Debug, Clone)]
pub struct SurveyDriver {
    limits: DriveLimits,
    steps: Vec<SurveyStep>,
    next: usize,
    turned: f64,
    last_heading: Option<f64>,
}

impl SurveyDriver {
    /// A driver at the first step.
    pub fn new(steps: Vec<SurveyStep>, limits: DriveLimits) -> Self {
        SurveyDriver {
            limits,
            steps,
            next: 0,
            turned: 0.0,
            last_heading: None,
        }
    }

    /// Steps left, the current one included.
    pub fn remaining(&self) -> usize {
        self.steps.len() - self.next
    }

    /// The command for the robot at `pose`; stops once every step is done.
    pub fn command(&mut self, pose: Pose2) -> UnicycleCommand {
        let stop = UnicycleCommand { v: 0.0, w: 0.0 };
        loop {
            let Some(step) = self.steps.get(self.next) else {
                return stop;
            };
            match *step {
                SurveyStep::LookAround => {
                    if let Some(last) = self.last_heading {
                        self.turned += wrap_angle(pose.theta - last).abs();
                    }
                    self.last_heading = Some(pose.theta);
                    if self.turned < TAU {
                        return UnicycleCommand {
                            v: 0.0,
                            w: self.limits.max_turn,
                        };
                    }
                }
                SurveyStep::GoTo([x, y]) => {
                    let (dx, dy) = (x - pose.x, y - pose.y);
                    if dx.hypot(dy) > 0.12 {
                        let error = wrap_angle(dy.atan2(dx) - pose.theta);
                        let turn = self.limits.max_turn;
                        let w = (2.0 * error).clamp(-turn, turn);
                        let v = if error.abs() > 0.4 {
                            0.0
                        } else {
                            (0.5 * error.cos()).min(dx.hypot(dy) + 0.1)
                        };
                        return UnicycleCommand { v, w };
                    }
                }
            }
            self.next += 1;
            self.turned = 0.0;
            self.last_heading = None;
        }
    }
}

/// The survey as a planner: each plan runs the pursuit driver on the unicycle model for one
/// planning period in steps of `tick`, from the pose the plan starts at, so the survey drives
/// through the same tick as every other planner. It knows the world; nothing else does.
#[derive(Debug, Clone)]
pub struct SurveyPlanner {
    driver: SurveyDriver,
    period: f64,
    tick: f64,
}

impl SurveyPlanner {
    /// Steps of the pursuit driver within a plan, seconds.
    pub const TICK: f64 = 0.05;

    /// The survey of `world`, planned from the robot's start, replanned every `period`.
    pub fn new(world: &World, config: &SurveyConfig, period: f64) -> Result<Self> {
        let limits = world.robot().limits;
        Ok(SurveyPlanner {
            driver: SurveyDriver::new(plan_survey(world, config)?, limits),
            period,
            tick: Self::TICK,
        })
    }
}

impl Planner for SurveyPlanner {
    fn name(&self) -> &'static str {
        "survey"
    }

    fn settings(&self) -> serde_json::Value {
        let c = SurveyConfig::default();
        serde_json::json!({
            "row_spacing": c.row_spacing,
            "clearance": c.clearance,
            "spin_every": c.spin_every,
            "steps": self.driver.steps.len(),
        })
    }

    fn plan(&mut self, _map: &GaussianMap, start: Pose2) -> Decision {
        if self.driver.remaining() == 0 {
            return Decision::Done("survey complete".to_owned());
        }
        let n = (self.period / self.tick).round().max(1.0) as usize;
        let mut states = vec![start];
        let mut commands = Vec::with_capacity(n);
        for _ in 0..n {
            let at = states[states.len() - 1];
            let u = self.driver.command(at);
            commands.push(u);
            states.push(advance(&at, &u, self.tick));
        }
        Decision::Go(Plan {
            commands,
            period: self.tick,
            states,
            target: None,
            guidance: Vec::new(),
            score: 0.0,
            candidates: 1,
            commit: 0.0,
        })
    }
}
