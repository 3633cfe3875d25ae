//! One interface for every exploration planner, and what they share: the executor that turns a
//! target into collision-free motion primitives, the schedules the host follows, the recovery
//! manoeuvres and the watches that notice a robot making no progress. A comparison of planners
//! then measures where each chooses to go, not how each drives.

pub mod agslam;
pub mod evidence;
pub mod executor;
pub mod fbe;
pub mod frontier;
pub mod retrace;
pub mod schedule;
pub mod unseen;
pub mod watch;

use crate::camera::PinholeCamera;
use crate::drive::{Pose2, UnicycleCommand};
use crate::map::GaussianMap;

/// One camera frame as a planner sees it: the metric planar depth (row-major, 0 = no return)
/// and the camera it was taken with.
#[derive(Debug, Clone, Copy)]
pub struct Observation<'a> {
    /// Interleaved RGB, 3 bytes per pixel (empty where only depth was taken).
    pub rgb: &'a [u8],
    /// Planar depth per pixel, metres; 0 where the sensor saw nothing.
    pub depth: &'a [f32],
    /// Intrinsics and the optical frame's pose in the world.
    pub camera: &'a PinholeCamera,
    /// The sensor's largest range, metres.
    pub max_range: f64,
    /// The robot's planar pose when the frame was taken.
    pub robot: Pose2,
}

/// A schedule of constant commands with the states the unicycle model predicts for them.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// One command per `period` seconds.
    pub commands: Vec<UnicycleCommand>,
    /// Seconds each command lasts.
    pub period: f64,
    /// The start state, then the state after each command.
    pub states: Vec<Pose2>,
    /// Where the planner wants to go (its goal pose), when it has one.
    pub target: Option<Pose2>,
    /// The coarse path the executor followed toward the target (robot first), metres.
    pub guidance: Vec<[f64; 2]>,
    /// The planner's own score of the plan (RT-GuIDE's xi, FBE's utility, AG-SLAM's score).
    pub score: f64,
    /// Candidates the planner compared.
    pub candidates: usize,
    /// The predicted states of the candidate trajectories the chosen one was picked from
    /// (a recording draws them beside it); empty when the planner compared none.
    pub alternatives: Vec<Vec<Pose2>>,
    /// Seconds from its start the host follows it before asking again: 0 replaces it at the
    /// next think, infinity holds it to its end (a look around).
    pub commit: f64,
}

impl Plan {
    /// A plan no search made (the survey's driver, a test's schedule): `states` are the start
    /// and the state after each command; no target, guidance or alternatives, replaced at the
    /// next think.
    pub fn unsearched(commands: Vec<UnicycleCommand>, period: f64, states: Vec<Pose2>) -> Self {
        Plan {
            commands,
            period,
            states,
            target: None,
            guidance: Vec::new(),
            score: 0.0,
            candidates: 1,
            alternatives: Vec::new(),
            commit: 0.0,
        }
    }

    /// An unsearched plan that drives `commands` from `start`, one per `period` seconds:
    /// its states are the unicycle model's (what a scripted or outside planner gives
    /// without a search of its own).
    pub fn driven(start: Pose2, commands: Vec<UnicycleCommand>, period: f64) -> Self {
        let mut states = Vec::with_capacity(commands.len() + 1);
        states.push(start);
        let mut at = start;
        for u in &commands {
            at = crate::drive::advance(&at, u, period);
            states.push(at);
        }
        Plan::unsearched(commands, period, states)
    }
}

/// What a planner answers when asked for a plan.
#[derive(Debug, Clone, PartialEq)]
pub enum Decision {
    /// Follow this plan until the next one.
    Go(Plan),
    /// No plan: the host runs the failure's recovery and asks again.
    Fail(PlanFailure),
    /// Nothing is left to do (no frontier, the survey complete): the robot holds still while
    /// the mapper goes on to the episode's budget (or the episode ends, with the host's
    /// `--stop-when-done`), saying why.
    Done(String),
    /// The planner cannot go on (an error in a planner from outside, e.g. a Python exception):
    /// the episode ends now, saying why.
    Abort(String),
}

/// Why no plan came back, and what the host can do about it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlanFailure {
    /// Nothing mapped yet (or only floor).
    #[error("the map has no Gaussians above the ground plane yet; turn in place to look around")]
    EmptyMap,
    /// The robot's own position is in collision with the map.
    #[error("the robot's position collides with the map (an obstacle within r_robot + 3 r); back off toward heading {away:.2} rad and replan")]
    StartInCollision {
        /// Heading (radians) pointing away from the colliding Gaussians: where to back off.
        away: f64,
    },
    /// Every primitive from the start collides.
    #[error("every motion primitive from here collides; turn in place to look around")]
    NoCollisionFreeCandidate,
    /// Collision-free primitives exist, but every one passes within the clearance of cells
    /// the depth frames have not shown free (RT-GuIDE's frontier regions): the map has nothing
    /// there to collide with because nothing there was seen. Told apart from
    /// [`PlanFailure::NoCollisionFreeCandidate`] because its cause and cure differ.
    #[error("every collision-free motion primitive from here passes near space not yet seen free; turn in place to look around")]
    NoCandidateClearOfUnseen,
    /// No goal is reachable.
    #[error("no goal is reachable from here; turn in place to look around")]
    GoalUnreachable,
    /// The planner's grid has no way out of the robot's position: no cell beyond the disc the
    /// robot's footprint frees has a path. A grid that takes what the robot fits under (a
    /// table top inside AG-SLAM's 1.3 m band) for a wall boxes in a place the robot's body
    /// just drove to; looking around sees the same top again. Told apart from
    /// [`PlanFailure::GoalUnreachable`] because the host's cure differs: after a look around,
    /// drive back the way the robot came.
    #[error("the planner's grid has no way out of here (is the robot under something it fits under?); turn in place to look around, then drive back the way it came")]
    BoxedIn,
}

/// What the host should do after a failure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Recovery {
    /// Spin on the spot to see more.
    TurnInPlace,
    /// Turn to `away` (world heading, radians) and drive off a little, then replan. The
    /// drive is unchecked, so it always carries the heading the start check found clear:
    /// there is no back-off without one (a blind "half round" drove into what the robot had
    /// last turned its back on).
    BackOff {
        /// The heading to drive off along.
        away: f64,
    },
}

impl PlanFailure {
    /// The recovery the planner suggests.
    pub fn recovery(&self) -> Recovery {
        match self {
            PlanFailure::StartInCollision { away } => Recovery::BackOff { away: *away },
            _ => Recovery::TurnInPlace,
        }
    }

    /// A short stable name for counting failures in metrics.json.
    pub fn kind(&self) -> &'static str {
        match self {
            PlanFailure::EmptyMap => "EmptyMap",
            PlanFailure::StartInCollision { .. } => "StartInCollision",
            PlanFailure::NoCollisionFreeCandidate => "NoCollisionFreeCandidate",
            PlanFailure::NoCandidateClearOfUnseen => "NoCandidateClearOfUnseen",
            PlanFailure::GoalUnreachable => "GoalUnreachable",
            PlanFailure::BoxedIn => "BoxedIn",
        }
    }
}

/// An exploration planner: it sees every camera frame and the map, and every planning period
/// says where the robot goes next.
pub trait Planner {
    /// The name on the command line.
    fn name(&self) -> &str;
    /// The planner's settings, for metrics.json and episode.json.
    fn settings(&self) -> serde_json::Value;
    /// Takes in one camera frame (planners that keep their own grid update it here).
    fn observe(&mut self, _observation: &Observation<'_>, _map: &GaussianMap) {}
    /// Plans from `start`, the pose the robot will have when the plan begins.
    fn plan(&mut self, map: &GaussianMap, start: Pose2) -> Decision;
}
