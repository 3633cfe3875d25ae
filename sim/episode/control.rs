//! The think step's control side: the schedule the robot follows, the one waiting for its
//! start after a compute delay, the pose a new plan starts from, a planner's decision turned
//! into a schedule (its recovery on a failure), and the watches that overrule a planner that
//! gets nowhere.

use super::Latency;
use crate::robot::{DriveLimits, Pose2, UnicycleCommand};
use autonomy::explore::schedule::Schedule;
use autonomy::explore::watch::{ProgressWatch, StuckWatch};
use autonomy::explore::{Decision, PlanFailure, Recovery};
use std::collections::{BTreeMap, VecDeque};

/// Schedules, watches and the failure counts of an episode.
#[derive(Debug)]
pub struct Controller {
    latency: Latency,
    limits: DriveLimits,
    current: Schedule,
    pending: Option<Schedule>,
    progress: ProgressWatch,
    stuck: StuckWatch,
    /// Wall seconds of the last three thinks (the compute delay a plan is planned ahead by).
    recent_delays: VecDeque<f64>,
    /// Planner failures by kind, for metrics.json.
    pub failures: BTreeMap<String, usize>,
    /// Recovery manoeuvres started.
    pub recovery_events: usize,
}

/// What the tick does after a think.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// Keep going.
    Continue,
    /// End the episode, saying why.
    End(String),
}

impl Controller {
    /// Standing still at `pose`.
    pub fn new(pose: Pose2, latency: Latency, limits: DriveLimits) -> Self {
        Controller {
            latency,
            limits,
            current: Schedule::idle(0.0),
            pending: None,
            progress: ProgressWatch::new(pose),
            stuck: StuckWatch::new(pose),
            recent_delays: VecDeque::from([0.0]),
            failures: BTreeMap::new(),
            recovery_events: 0,
        }
    }

    /// Starts the waiting schedule once its start time has come.
    pub fn advance(&mut self, time: f64) {
        if self.pending.as_ref().is_some_and(|p| time >= p.start) {
            if let Some(p) = self.pending.take() {
                self.current = p;
            }
        }
    }

    fn active(&self) -> &Schedule {
        self.pending.as_ref().unwrap_or(&self.current)
    }

    /// The command for the robot at `time`.
    pub fn command(&self, time: f64) -> UnicycleCommand {
        self.current.at(time)
    }

    /// Whether a schedule that holds (a recovery, a look around) is still running: it runs to
    /// its end, because replanning every second would cut a back-off's turn short and the
    /// robot would never get out.
    pub fn holding(&self, time: f64) -> bool {
        self.active().holding_at(time)
    }

    /// Takes in the robot's pose at a think, while a schedule holds too (a look-around's turn
    /// is progress).
    pub fn observe(&mut self, pose: &Pose2) {
        self.progress.observe(pose);
    }

    /// Whether the robot made no progress for a while: the planner is overruled by a back-off.
    pub fn stalled(&self, time: f64, pose: &Pose2) -> bool {
        self.progress.stalled(time, pose)
    }

    /// Seconds ahead a plan must be made for: the slowest of the last three thinks with wall
    /// latency, none without.
    pub fn lead(&self) -> f64 {
        match self.latency {
            Latency::Wall => self.recent_delays.iter().copied().fold(0.0, f64::max),
            Latency::None => 0.0,
        }
    }

    /// The pose the robot will have `lead` seconds after `time` on the active schedule.
    pub fn start_pose(&self, pose: Pose2, time: f64, lead: f64) -> Pose2 {
        self.active().predict(pose, time, lead)
    }

    /// Takes a think's outcome: `decision` (`None` when the watch overruled the planner)
    /// made from `start_pose` at `time`, whose compute took `delay` wall seconds. Schedules
    /// the plan or the recovery, and says whether the episode goes on.
    pub fn take(
        &mut self,
        decision: Option<Decision>,
        time: f64,
        pose: Pose2,
        start_pose: Pose2,
        delay: f64,
        lead: f64,
    ) -> Verdict {
        let start = match self.latency {
            Latency::Wall => {
                self.recent_delays.push_back(delay);
                if self.recent_delays.len() > 3 {
                    self.recent_delays.pop_front();
                }
                time + delay.max(lead)
            }
            Latency::None => time,
        };
        // `None` inside: the watch's "no progress" rather than a planner failure.
        let failure: Option<Option<PlanFailure>> = match decision {
            Some(Decision::Done(reason)) => return Verdict::End(reason),
            Some(Decision::Go(plan)) => {
                debug_assert!(plan.commands.iter().all(|u| self.limits.admits(*u)));
                self.pending = Some(Schedule::from_plan(&plan, start));
                None
            }
            Some(Decision::Fail(f)) => Some(Some(f)),
            None => Some(None),
        };
        let recovered = failure.is_some();
        if let Some(failure) = failure {
            self.recovery_events += 1;
            let (name, kind, away) = match &failure {
                Some(f @ PlanFailure::StartInCollision { away }) => {
                    (f.kind(), Recovery::BackOff, Some(*away))
                }
                Some(f) => (f.kind(), f.recovery(), None),
                None => ("NoProgress", Recovery::BackOff, None),
            };
            tracing::info!(
                "t = {time:.1} s: {} -> recovery {kind:?}",
                failure
                    .as_ref()
                    .map_or("no progress for 10 s".to_owned(), PlanFailure::to_string)
            );
            *self.failures.entry(name.to_owned()).or_insert(0) += 1;
            self.pending = Some(Schedule::recovery(
                kind,
                start,
                start_pose.theta,
                away,
                &self.limits,
            ));
        }
        self.progress.update(time, pose, recovered);
        match self.stuck.update(time, pose, recovered) {
            Some(reason) => {
                tracing::warn!("t = {time:.1} s: {reason}");
                Verdict::End(reason)
            }
            None => Verdict::Continue,
        }
    }
}
