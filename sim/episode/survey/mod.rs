//! The ground-truth survey (the upper bound the exploration planners are compared with): it
//! knows the world's exact floor plan, plans a route of look-around points that together see
//! every obstacle surface the robot can reach (`tour`), and drives it with a pursuit
//! controller on the true pose through the same tick as every other planner.

pub mod tour;

use crate::error::{Result, SimError};
use crate::floorplan::FloorPlan;
use crate::robot::{DriveLimits, Pose2, UnicycleCommand};
use crate::world::World;
use autonomy::drive::{advance, wrap_angle};
use autonomy::explore::{Decision, Plan, Planner};
use autonomy::map::GaussianMap;
use std::f64::consts::TAU;
pub use tour::{plan_tour, Tour, TourConfig};

/// Why a survey episode ends when its route is driven (metrics.json's `ended`); a survey that
/// ends on its budget instead saw less than a survey does, which the sweep reports.
pub const SURVEY_COMPLETE: &str = "survey complete";

/// The survey's cruise speed (the pursuit driver's), m/s.
const CRUISE: f64 = 0.5;

/// How the survey is laid out.
#[derive(Debug, Clone, Copy)]
pub struct SurveyConfig {
    /// The route's settings; its range and turn cost are set from the camera and the robot.
    pub tour: TourConfig,
    /// Spacing of the points the driver pursues along a path, metres.
    pub waypoint_spacing: f64,
}

impl Default for SurveyConfig {
    fn default() -> Self {
        SurveyConfig {
            tour: TourConfig::default(),
            waypoint_spacing: 0.3,
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

/// Plans the survey from the robot's current pose: the route's look-arounds, with the points
/// along each path between them. Returns the steps and the route.
pub fn plan_survey(world: &World, config: &SurveyConfig) -> Result<(Vec<SurveyStep>, Tour)> {
    let pose = world.pose();
    let plan = FloorPlan::of(world)?;
    let start = plan
        .cell_of(pose.x, pose.y)
        .filter(|&c| plan.neighbours(c).any(|n| plan.is_free(n)))
        .ok_or_else(|| SimError::InvalidArgument {
            what: "survey start",
            detail: format!(
                "the robot's start ({:.2}, {:.2}) has no room to drive ({:.2} m of clearance needed)",
                pose.x, pose.y, plan.clearance_needed
            ),
        })?;
    let tour = plan_tour(&plan, start, &config.tour);
    let every = ((config.waypoint_spacing / plan.cell).round() as usize).max(1);
    let mut steps = vec![SurveyStep::LookAround];
    for path in tour.paths.iter().skip(1) {
        for (k, p) in path.iter().enumerate() {
            if (k + 1) % every == 0 || k + 1 == path.len() {
                steps.push(SurveyStep::GoTo(*p));
            }
        }
        steps.push(SurveyStep::LookAround);
    }
    Ok((steps, tour))
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
                            (CRUISE * error.cos()).min(dx.hypot(dy) + 0.1)
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
    config: SurveyConfig,
    tour: Tour,
    period: f64,
    tick: f64,
}

impl SurveyPlanner {
    /// Steps of the pursuit driver within a plan, seconds.
    pub const TICK: f64 = 0.05;

    /// The survey of `world` for a camera of `range` metres, planned from the robot's start,
    /// replanned every `period`.
    pub fn new(world: &World, config: &SurveyConfig, range: f64, period: f64) -> Result<Self> {
        let limits = world.robot().limits;
        let mut config = *config;
        config.tour.range = range;
        config.tour.turn_cost = TAU / limits.max_turn * CRUISE;
        let (steps, tour) = plan_survey(world, &config)?;
        Ok(SurveyPlanner {
            driver: SurveyDriver::new(steps, limits),
            config,
            tour,
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
        let c = &self.config.tour;
        serde_json::json!({
            "clearance": c.clearance,
            "range": c.range,
            "lattice": c.spacing,
            "min_gain": c.min_gain,
            "look_arounds": self.tour.stops.len(),
            "route_length": self.tour.paths.iter().map(|p| length(p)).sum::<f64>(),
            "targets": self.tour.targets,
            "targets_visible": self.tour.visible,
            "targets_seen": self.tour.seen,
            "steps": self.driver.steps.len(),
        })
    }

    fn plan(&mut self, _map: &GaussianMap, start: Pose2) -> Decision {
        if self.driver.remaining() == 0 {
            return Decision::Done(SURVEY_COMPLETE.to_owned());
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
        Decision::Go(Plan::unsearched(commands, self.tick, states))
    }
}

/// Length of a polyline, metres.
fn length(points: &[[f64; 2]]) -> f64 {
    points
        .windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum()
}
