//! The think step's control side: the schedule the robot follows, the one waiting for its
//! start after a compute delay, the pose a new plan starts from, a planner's decision turned
//! into a schedule (its recovery on a failure), and the watches that overrule a planner that
//! gets nowhere.

use super::Latency;
use crate::robot::{DriveLimits, Pose2, UnicycleCommand};
use autonomy::drive::wrap_angle;
use autonomy::explore::retrace::{retrace, Trail, RETRACE_DISTANCE};
use autonomy::explore::schedule::{self, Schedule};
use autonomy::explore::watch::{ProgressWatch, StuckWatch};
use autonomy::explore::{Decision, PlanFailure, Recovery};
use std::collections::{BTreeMap, VecDeque};

/// How far, metres, the robot may have moved on from a late plan's start for the plan to be
/// driven all the same: a few percent of the 0.35 m collision radius.
const LATE_DISTANCE: f64 = 0.02;
/// How far, radians, it may have turned: 2 cm sideways a metre ahead.
const LATE_TURN: f64 = 0.02;
/// A schedule that starts this far, metres, from where it was planned is logged (debug).
const LOGGED_START_ERROR: f64 = 0.05;

/// Schedules, watches and the failure counts of an episode.
#[derive(Debug)]
pub struct Controller {
    latency: Latency,
    limits: DriveLimits,
    current: Schedule,
    /// The next schedule and the pose it was planned from.
    pending: Option<(Schedule, Pose2)>,
    progress: ProgressWatch,
    stuck: StuckWatch,
    /// The way the robot came, for a retrace.
    trail: Trail,
    /// Where the episode began, until the robot has been further than [`StuckWatch::ESCAPE`]
    /// from there (then `None`): while it is known, a plan blocked again gets a full turn.
    at_spawn: Option<Pose2>,
    /// Where the last look around for a blocked plan (every primitive collides or passes
    /// near unseen space) began: blocked again there, the robot retraces its trail instead.
    looked_at: Option<Pose2>,
    /// Wall seconds of the last three plans (with the mapping step's, which is known before
    /// planning starts, the compute delay a plan is planned ahead by).
    recent_plans: VecDeque<f64>,
    /// Planner failures by kind, for metrics.json.
    pub failures: BTreeMap<String, usize>,
    /// Recovery manoeuvres started.
    pub recovery_events: usize,
    /// Of those, retraces: drives back along the trail after a look around did not unblock
    /// the plans, or after no progress.
    pub retraces: usize,
    /// Decisions dropped because their think outlasted the lead they were planned for while
    /// the robot was moving: they start from a pose the robot is not at.
    pub late_plans: usize,
    /// Per schedule started, metres between the robot and the pose it was planned from.
    pub start_pose_errors: Vec<f64>,
}

/// Wall seconds a think took: the mapping step, then the plan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThinkTime {
    /// The mapping step's.
    pub mapping: f64,
    /// The planner's.
    pub planning: f64,
}

/// What the tick does after a think.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// Keep going.
    Continue,
    /// The planner is done, saying why (the episode goes on idle, or ends).
    End(String),
    /// End the episode now, saying why.
    Abort(String),
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
            trail: Trail::new(pose),
            at_spawn: Some(pose),
            looked_at: None,
            recent_plans: VecDeque::from([0.0]),
            failures: BTreeMap::new(),
            recovery_events: 0,
            retraces: 0,
            late_plans: 0,
            start_pose_errors: Vec::new(),
        }
    }

    /// Starts the waiting schedule once its start time has come, noting how far the robot
    /// (at `pose()`, asked only then: this runs every physics step) is from where the schedule
    /// was planned from.
    pub fn advance(&mut self, time: f64, pose: impl FnOnce() -> Pose2) {
        if self.pending.as_ref().is_some_and(|(p, _)| time >= p.start) {
            if let Some((p, from)) = self.pending.take() {
                self.current = p;
                let pose = pose();
                let error = pose.distance([from.x, from.y]);
                if error > LOGGED_START_ERROR {
                    tracing::debug!(
                        "t = {time:.2} s: a schedule starts {error:.3} m from where it was \
                         planned ({from:?}; the robot is at {pose:?}, first command {:?})",
                        self.current.at(time)
                    );
                }
                self.start_pose_errors.push(error);
            }
        }
    }

    /// Drives `schedule` from now on and drops the one waiting: a caller steers instead of
    /// the planner, with nothing to wait out.
    pub fn drive(&mut self, schedule: Schedule) {
        self.current = schedule;
        self.pending = None;
    }

    fn active(&self) -> &Schedule {
        self.pending.as_ref().map_or(&self.current, |(p, _)| p)
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

    /// Takes in the robot's pose after a physics step: the trail a retrace follows back.
    pub fn moved(&mut self, pose: Pose2) {
        self.trail.push(pose);
        if let Some(spawn) = self.at_spawn {
            if pose.distance([spawn.x, spawn.y]) > StuckWatch::ESCAPE {
                self.at_spawn = None;
            }
        }
    }

    /// Whether the robot made no progress for a while: the planner is overruled by a back-off.
    pub fn stalled(&self, time: f64, pose: &Pose2) -> bool {
        self.progress.stalled(time, pose)
    }

    /// Seconds ahead a plan must be made for, once the think's mapping step took `mapping`
    /// wall seconds: that and the slowest of the last three plans with wall latency, none
    /// without. (Estimating the whole think by the slowest of the last three left a quarter
    /// of the plans late: mapping's time jitters by a third from step to step.)
    pub fn lead(&self, mapping: f64) -> f64 {
        match self.latency {
            Latency::Wall => mapping + self.recent_plans.iter().copied().fold(0.0, f64::max),
            Latency::None => 0.0,
        }
    }

    /// The command the robot gets at `time`: the waiting schedule's from its start, the
    /// current one's before.
    fn command_at(&self, time: f64) -> UnicycleCommand {
        match &self.pending {
            Some((p, _)) if time >= p.start => p.at(time),
            _ => self.current.at(time),
        }
    }

    /// The pose the robot will have `lead` seconds after `time`: on the current schedule
    /// until the waiting one starts, then on that.
    pub fn start_pose(&self, pose: Pose2, time: f64, lead: f64) -> Pose2 {
        schedule::predict(|t| self.command_at(t), pose, time, lead)
    }

    /// Takes a think's outcome: `decision` (`None` when the watch overruled the planner)
    /// made from `start_pose` at `time` for `lead` seconds ahead, whose compute took `think`.
    /// Schedules the plan or the recovery, and says whether the episode goes on.
    pub fn take(
        &mut self,
        decision: Option<Decision>,
        time: f64,
        pose: Pose2,
        start_pose: Pose2,
        think: ThinkTime,
        lead: f64,
    ) -> Verdict {
        let delay = think.mapping + think.planning;
        let (start, late) = match self.latency {
            Latency::Wall => {
                self.recent_plans.push_back(think.planning);
                if self.recent_plans.len() > 3 {
                    self.recent_plans.pop_front();
                }
                // A think that outlasts its lead was planned from where the robot would be
                // at `time + lead`; if the robot moves on after that, the plan's commands
                // would be driven from elsewhere, unchecked, so it is dropped and the checked
                // schedule goes on. Standing still, or nearly, the robot is where the plan
                // starts, only later.
                let late = delay > lead && {
                    let then = self.start_pose(pose, time, delay);
                    then.distance([start_pose.x, start_pose.y]) > LATE_DISTANCE
                        || wrap_angle(then.theta - start_pose.theta).abs() > LATE_TURN
                };
                (time + delay.max(lead), late)
            }
            Latency::None => (time, false),
        };
        if late && !matches!(decision, Some(Decision::Done(_) | Decision::Abort(_))) {
            self.late_plans += 1;
            tracing::debug!(
                "t = {time:.1} s: the think took {delay:.2} s, planned for {lead:.2} s \
                 while moving; dropped"
            );
            self.progress.update(time, pose, false);
            return self.watch_stuck(time, pose, false);
        }
        // `None` inside: the watch's "no progress" rather than a planner failure.
        let failure: Option<Option<PlanFailure>> = match decision {
            Some(Decision::Done(reason)) => return Verdict::End(reason),
            Some(Decision::Abort(reason)) => return Verdict::Abort(reason),
            Some(Decision::Go(plan)) => {
                debug_assert!(plan.commands.iter().all(|u| self.limits.admits(*u)));
                self.pending = Some((Schedule::from_plan(&plan, start), start_pose));
                None
            }
            Some(Decision::Fail(f)) => Some(Some(f)),
            None => Some(None),
        };
        let recovered = failure.is_some();
        if let Some(failure) = failure {
            self.recovery_events += 1;
            let name = failure.as_ref().map_or("NoProgress", PlanFailure::kind);
            *self.failures.entry(name.to_owned()).or_insert(0) += 1;
            let schedule = match &failure {
                Some(f) => self.recover_from(f, time, start_pose, start),
                None => self.back_the_way_it_came(time, start_pose, start),
            };
            self.pending = Some((schedule, start_pose));
        }
        self.progress.update(time, pose, recovered);
        self.watch_stuck(time, pose, recovered)
    }

    /// The recovery for a planner's failure: a retrace when blocked again where it looked
    /// around, else the failure's own manoeuvre (a back-off toward the start check's heading).
    fn recover_from(
        &mut self,
        failure: &PlanFailure,
        time: f64,
        start_pose: Pose2,
        start: f64,
    ) -> Schedule {
        tracing::info!(
            "t = {time:.1} s: {failure} -> recovery {:?}",
            failure.recovery()
        );
        if let Some(retrace) = self.blocked_again(failure, start_pose, start) {
            return retrace;
        }
        let (heading, limits) = (start_pose.theta, &self.limits);
        Schedule::recovery(failure.recovery(), start, heading, limits)
    }

    /// A retrace of the trail from `start_pose`, counted, and the look around it answers
    /// forgotten; `None` when the trail is too short.
    fn retrace_trail(&mut self, start_pose: Pose2, start: f64) -> Option<Schedule> {
        let limits = &self.limits;
        let schedule = retrace(&self.trail, start_pose, start, RETRACE_DISTANCE, limits)?;
        self.looked_at = None;
        self.retraces += 1;
        Some(schedule)
    }

    /// The watch's recovery for a robot that made no progress: a retrace of its trail, the
    /// one way out known to be free whatever the map says (the body has just been there), or
    /// a look around where the trail is too short to retrace (near where the episode began).
    ///
    /// It used to turn half round and drive off a little, blind: what the robot had just
    /// turned its back on is straight ahead then (robustness-depth-noise, apartment_02,
    /// RT-GuIDE spawn 3: a collision back-off turned the robot away from ball_16, the plans
    /// after it only turned, and ten seconds on the watch's back-off drove into the ball;
    /// tests/fixtures/ball_behind.xml builds that). The map cannot choose a heading instead:
    /// behind the camera it holds only what was seen before, and with a perturbed sensor it
    /// is what misled the plans in the first place.
    fn back_the_way_it_came(&mut self, time: f64, start_pose: Pose2, start: f64) -> Schedule {
        match self.retrace_trail(start_pose, start) {
            Some(schedule) => {
                tracing::info!(
                    "t = {time:.1} s: no progress for 10 s -> retracing {RETRACE_DISTANCE} m of \
                     the way the robot came"
                );
                schedule
            }
            None => {
                tracing::info!(
                    "t = {time:.1} s: no progress for 10 s and no trail to retrace -> recovery \
                     TurnInPlace"
                );
                let (heading, limits) = (start_pose.theta, &self.limits);
                Schedule::recovery(Recovery::TurnInPlace, start, heading, limits)
            }
        }
    }

    /// A plan blocked where a look around already failed to unblock it gets a retrace: the
    /// robot drives back along its trail, through space its body has just occupied, until
    /// the blocked place is in the camera's view (`autonomy::explore::retrace` says why a
    /// look around cannot cure it). A robot that has not yet left its spawn has no trail: it
    /// turns a full circle instead (`Schedule::full_turn` says why), the only view of its
    /// surroundings it has not had. `None` (a look around, remembered) otherwise.
    ///
    /// A planner boxed in by its own grid counts as blocked: AG-SLAM takes a table top inside
    /// the papers' 1.3 m band for a wall, yet its executor drives the 0.5 m robot under the
    /// table; once there, the grid boxes the robot in and a look around only sees the table
    /// top again (robustness-as-is, apartment_03, spawn 5: stuck under a table at 165-213 s).
    /// Plain "no goal is reachable" does not: RT-GuIDE says it when no viewpoint has a clear
    /// edge, and a retrace there undid its way out of a corridor.
    fn blocked_again(
        &mut self,
        failure: &PlanFailure,
        start_pose: Pose2,
        start: f64,
    ) -> Option<Schedule> {
        let blocked = matches!(
            failure,
            PlanFailure::NoCollisionFreeCandidate
                | PlanFailure::NoCandidateClearOfUnseen
                | PlanFailure::BoxedIn
        );
        if !blocked {
            return None;
        }
        let again = self
            .looked_at
            .is_some_and(|p| start_pose.distance([p.x, p.y]) <= StuckWatch::ESCAPE);
        if !again {
            self.looked_at = Some(start_pose);
            return None;
        }
        let Some(schedule) = self.retrace_trail(start_pose, start) else {
            // Once it has left its spawn: a look around, remembered, as anywhere else.
            self.at_spawn?;
            tracing::info!(
                "t = {start:.1} s: blocked again after a look around at ({:.2}, {:.2}), at the \
                 spawn with no trail to retrace; turning a full circle",
                start_pose.x,
                start_pose.y
            );
            self.looked_at = None;
            return Some(Schedule::full_turn(start, &self.limits));
        };
        tracing::info!(
            "t = {start:.1} s: blocked again after a look around at ({:.2}, {:.2}); retracing \
             {RETRACE_DISTANCE} m of the way the robot came",
            start_pose.x,
            start_pose.y
        );
        Some(schedule)
    }

    /// The stuck watch's verdict after a think.
    fn watch_stuck(&mut self, time: f64, pose: Pose2, recovered: bool) -> Verdict {
        match self.stuck.update(time, pose, recovered) {
            Some(reason) => {
                tracing::warn!("t = {time:.1} s: {reason}");
                // Stuck is the host's verdict, not the planner's: the episode ends.
                Verdict::Abort(reason)
            }
            None => Verdict::Continue,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use autonomy::explore::Plan;

    /// A plan of `seconds` one-second commands `u` from `start`.
    fn plan(u: UnicycleCommand, seconds: usize, start: Pose2) -> Decision {
        let mut states = vec![start];
        for _ in 0..seconds {
            let last = states[states.len() - 1];
            states.push(autonomy::drive::advance(&last, &u, 1.0));
        }
        Decision::Go(Plan::unsearched(vec![u; seconds], 1.0, states))
    }

    impl Controller {
        /// `advance` with the robot where the schedules were planned from.
        fn advance_to(&mut self, time: f64) {
            let from = self.pending.as_ref().map_or(Pose2::default(), |(_, f)| *f);
            self.advance(time, || from);
        }
    }

    fn think(mapping: f64, planning: f64) -> ThinkTime {
        ThinkTime { mapping, planning }
    }

    const FORWARD: UnicycleCommand = UnicycleCommand { v: 0.5, w: 0.0 };
    const TURN: UnicycleCommand = UnicycleCommand { v: 0.0, w: 0.5 };

    #[test]
    fn a_late_plan_while_moving_is_dropped_and_the_checked_schedule_goes_on() {
        let origin = Pose2::default();
        let mut c = Controller::new(origin, Latency::Wall, DriveLimits::default());
        // Standing still, a think of 0.2 s with no lead yet is not late: it starts at 0.2 s.
        let v = c.take(
            Some(plan(FORWARD, 5, origin)),
            0.0,
            origin,
            origin,
            think(0.1, 0.1),
            0.0,
        );
        assert_eq!(v, Verdict::Continue);
        assert_eq!(c.late_plans, 0);
        c.advance_to(0.25);
        assert_eq!(c.command(0.25), FORWARD);
        // The lead is the mapping step's time and the slowest recent plan's.
        let lead = c.lead(0.15);
        assert_eq!(lead, 0.25);
        // Moving, a think of 0.6 s planned for 0.25 s is dropped: forward goes on.
        let at = c.start_pose(origin, 1.0, lead);
        c.take(
            Some(plan(TURN, 3, at)),
            1.0,
            origin,
            at,
            think(0.15, 0.45),
            lead,
        );
        assert_eq!(c.late_plans, 1);
        c.advance_to(1.7);
        assert_eq!(c.command(1.7), FORWARD);
        // The slow plan lengthens the lead; a think within it starts at time + lead.
        let lead = c.lead(0.1);
        assert_eq!(lead, 0.55);
        c.take(
            Some(plan(TURN, 3, at)),
            2.0,
            origin,
            at,
            think(0.1, 0.3),
            lead,
        );
        assert_eq!(c.late_plans, 1);
        c.advance_to(2.5);
        assert_eq!(c.command(2.5), FORWARD);
        c.advance_to(2.6);
        assert_eq!(c.command(2.6), TURN);
    }

    #[test]
    fn a_plan_late_by_less_than_a_couple_of_centimetres_is_driven() {
        let origin = Pose2::default();
        let mut c = Controller::new(origin, Latency::Wall, DriveLimits::default());
        c.take(
            Some(plan(FORWARD, 5, origin)),
            0.0,
            origin,
            origin,
            think(0.0, 0.0),
            0.0,
        );
        c.advance_to(0.0);
        // At 0.5 m/s, 0.03 s late is 1.5 cm on: driven, from 1.53 s.
        let at = c.start_pose(origin, 1.0, 0.5);
        c.take(
            Some(plan(TURN, 3, at)),
            1.0,
            origin,
            at,
            think(0.53, 0.0),
            0.5,
        );
        assert_eq!(c.late_plans, 0);
        c.advance_to(1.54);
        assert_eq!(c.command(1.54), TURN);
        // Turning at 0.5 rad/s, 0.05 s late is 0.025 rad on: dropped.
        let at = c.start_pose(origin, 2.0, 0.53);
        c.take(
            Some(plan(FORWARD, 3, at)),
            2.0,
            origin,
            at,
            think(0.58, 0.0),
            0.53,
        );
        assert_eq!(c.late_plans, 1);
    }

    #[test]
    fn a_late_plan_while_standing_still_starts_when_it_is_ready() {
        let origin = Pose2::default();
        let mut c = Controller::new(origin, Latency::Wall, DriveLimits::default());
        c.take(
            Some(plan(TURN, 1, origin)),
            0.0,
            origin,
            origin,
            think(0.1, 0.0),
            0.0,
        );
        // The turn ends at 1.1 s; a think at 2.0 s planned for 0.1 s that takes 0.7 s finds
        // the robot where it planned from.
        c.advance_to(2.0);
        c.take(
            Some(plan(FORWARD, 2, origin)),
            2.0,
            origin,
            origin,
            think(0.7, 0.0),
            0.1,
        );
        assert_eq!(c.late_plans, 0);
        c.advance_to(2.65);
        assert_eq!(c.command(2.65), UnicycleCommand::STOP);
        // 0.1 m from where it was planned from: the start pose error says so.
        let off = Pose2 {
            x: 0.06,
            y: 0.08,
            theta: 0.0,
        };
        c.advance(2.75, || off);
        assert_eq!(c.command(2.75), FORWARD);
        assert_eq!(c.start_pose_errors.len(), 2);
        assert!((c.start_pose_errors[1] - 0.1).abs() < 1e-12);
    }

    #[test]
    fn the_start_pose_follows_the_current_schedule_until_the_waiting_one_starts() {
        let origin = Pose2::default();
        let mut c = Controller::new(origin, Latency::Wall, DriveLimits::default());
        c.take(
            Some(plan(FORWARD, 5, origin)),
            0.0,
            origin,
            origin,
            think(0.0, 0.0),
            0.0,
        );
        c.advance_to(0.0);
        // A turn waits for 1.5 s; from 1.0 s, 1.0 s ahead is 0.5 s forward, then 0.5 s of
        // turning: (0.25 m, 0, 0.25 rad) from where the robot is at 1.0 s.
        c.take(
            Some(plan(TURN, 3, origin)),
            1.0,
            origin,
            origin,
            think(0.5, 0.0),
            0.5,
        );
        assert_eq!(c.late_plans, 0);
        let p = c.start_pose(origin, 1.0, 1.0);
        let want = Pose2 {
            x: 0.25,
            y: 0.0,
            theta: 0.25,
        };
        assert!(
            (p.x - want.x).abs() < 1e-9 && p.y.abs() < 1e-9 && (p.theta - want.theta).abs() < 1e-9,
            "{p:?}"
        );
    }

    /// The trap's recovery: a plan blocked (every candidate passes near unseen space) where
    /// the robot has just driven gets a look around first; blocked again there, the robot
    /// drives back along the way it came, in bounded time, and ends a retrace's distance
    /// back on its own path. Blocked somewhere else, it looks around first again.
    #[test]
    fn blocked_again_where_it_looked_around_the_robot_retraces_the_way_it_came() {
        let origin = Pose2::default();
        let mut c = Controller::new(origin, Latency::None, DriveLimits::default());
        // It drove 2 m east, then along a quarter circle to the north-east.
        let mut pose = origin;
        for _ in 0..200 {
            pose = autonomy::drive::advance(&pose, &FORWARD, 0.02);
            c.moved(pose);
        }
        let arc = UnicycleCommand { v: 0.5, w: 0.5 };
        for _ in 0..157 {
            pose = autonomy::drive::advance(&pose, &arc, 0.02);
            c.moved(pose);
        }
        let here = pose;
        let blocked = || Some(Decision::Fail(PlanFailure::NoCandidateClearOfUnseen));
        let run = |schedule: &Schedule, from: Pose2| {
            schedule.predict(from, schedule.start, schedule.end() - schedule.start)
        };
        // First a look around in place.
        c.take(blocked(), 10.0, here, here, think(0.0, 0.0), 0.0);
        let (look, _) = c.pending.clone().expect("a look around");
        assert!(look.commands.iter().all(|u| u.v == 0.0 && u.w != 0.0));
        let turned = run(&look, here);
        assert!(turned.distance([here.x, here.y]) < 1e-9);
        // Blocked again from there: a retrace.
        c.take(blocked(), look.end(), turned, turned, think(0.0, 0.0), 0.0);
        assert_eq!((c.retraces, c.recovery_events), (1, 2));
        let (back, _) = c.pending.clone().expect("a retrace");
        assert!(back.holding_at(back.start + 1.0));
        // Bounded: a half turn and a metre at the retrace's speed, with a second to spare.
        let seconds = back.end() - back.start;
        assert!(
            seconds < std::f64::consts::PI / 0.9 + 1.0 / 0.3 + 1.0,
            "{seconds} s"
        );
        // It ends RETRACE_DISTANCE back along the path: on the arc, 1 m before its end
        // (the arc is 0.5 m x 3.14 s = 1.57 m long).
        let mut want = Pose2::default();
        for _ in 0..200 {
            want = autonomy::drive::advance(&want, &FORWARD, 0.02);
        }
        want = autonomy::drive::advance(&want, &arc, (1.57 - RETRACE_DISTANCE) / 0.5);
        let end = run(&back, turned);
        assert!(end.distance([want.x, want.y]) < 0.03, "{end:?}, {want:?}");
        // The retrace is driven: the trail loses what it retraced.
        let mut p = turned;
        for k in 0..(seconds / 0.02).round() as usize {
            p = autonomy::drive::advance(&p, &back.at(back.start + (k as f64 + 0.5) * 0.02), 0.02);
            c.moved(p);
        }
        // Blocked again at the new place: a look around first, not another retrace.
        c.take(blocked(), back.end(), end, end, think(0.0, 0.0), 0.0);
        let (look, _) = c.pending.clone().expect("a look around");
        assert!(look.commands.iter().all(|u| u.v == 0.0));
        assert_eq!(c.retraces, 1);
        // Blocked again there: the next retrace goes on back (west along the straight part),
        // not forward to where the robot was blocked before.
        c.take(blocked(), look.end(), end, end, think(0.0, 0.0), 0.0);
        let (back, _) = c.pending.clone().expect("a second retrace");
        let further = run(&back, end);
        assert_eq!(c.retraces, 2);
        assert!(further.x < end.x - 0.5, "{end:?} -> {further:?}");
    }

    /// The watch's "no progress" never drives blind: with a trail it retraces it (the way the
    /// body came, free whatever the map says), and with none (still near where the episode
    /// began) it looks around in place. It used to turn half round and drive 0.15 m, into
    /// whatever the robot had turned its back on.
    #[test]
    fn no_progress_retraces_the_trail_or_looks_around_but_never_drives_blind() {
        let origin = Pose2::default();
        let run = |schedule: &Schedule, from: Pose2| {
            schedule.predict(from, schedule.start, schedule.end() - schedule.start)
        };
        // Standing where it began: no trail, a look around.
        let mut c = Controller::new(origin, Latency::None, DriveLimits::default());
        c.take(None, 10.0, origin, origin, think(0.0, 0.0), 0.0);
        let (look, _) = c.pending.clone().expect("a look around");
        assert!(look.commands.iter().all(|u| u.v == 0.0 && u.w != 0.0));
        assert_eq!((c.retraces, c.failures.get("NoProgress")), (0, Some(&1)));
        // Drove 2 m east, then turned its back on what lies ahead (east): the way out is west,
        // along the trail, never east.
        let mut pose = origin;
        for _ in 0..200 {
            pose = autonomy::drive::advance(&pose, &FORWARD, 0.02);
            c.moved(pose);
        }
        let turned = Pose2 {
            theta: std::f64::consts::PI,
            ..pose
        };
        c.take(None, 20.0, turned, turned, think(0.0, 0.0), 0.0);
        assert_eq!(c.retraces, 1);
        let (back, _) = c.pending.clone().expect("a retrace");
        let mut p = turned;
        for k in 0..((back.end() - back.start) / 0.02).round() as usize {
            p = autonomy::drive::advance(&p, &back.at(back.start + (k as f64 + 0.5) * 0.02), 0.02);
            assert!(p.x <= turned.x + 1e-9, "drove east to {p:?}");
        }
        let end = run(&back, turned);
        assert!(
            (end.x - (turned.x - RETRACE_DISTANCE)).abs() < 0.03 && end.y.abs() < 0.03,
            "{end:?}"
        );
    }

    /// Turned in place by `schedule`: the whole angle, unwrapped.
    fn turned(schedule: &Schedule) -> f64 {
        assert!(schedule.commands.iter().all(|u| u.v == 0.0));
        let angle = |u: &UnicycleCommand| u.w * schedule.period;
        schedule.commands.iter().map(angle).sum()
    }

    /// Blocked twice where it looked around, at its spawn, with no trail to retrace: the
    /// second answer is a full circle, not another 155-degree look around. Between looks
    /// around the plans turn the robot back toward its target, so looks around alone swept
    /// the same sector for ever (robustness-as-is, warehouse_02, RT-GuIDE spawn 3). Once the
    /// robot has left its spawn, a place without trail (back where it began, the loop
    /// erased) keeps the look around: only the spawn is a place it has seen from one side.
    #[test]
    fn blocked_again_at_the_spawn_turns_a_full_circle() {
        let origin = Pose2::default();
        let blocked = || Some(Decision::Fail(PlanFailure::NoCandidateClearOfUnseen));
        let mut c = Controller::new(origin, Latency::None, DriveLimits::default());
        c.take(blocked(), 2.0, origin, origin, think(0.0, 0.0), 0.0);
        let (look, _) = c.pending.clone().expect("a look around");
        let first = turned(&look);
        assert!(first > 0.0 && first < std::f64::consts::PI, "{first}");
        c.take(blocked(), 8.0, origin, origin, think(0.0, 0.0), 0.0);
        let (circle, _) = c.pending.clone().expect("a full turn");
        assert!(turned(&circle) >= std::f64::consts::TAU - 1e-9);
        assert!(circle.holding_at(circle.start + 1.0));
        assert_eq!((c.retraces, c.recovery_events), (0, 2));
        // Blocked a third time there: a look around again first, then a full circle.
        let end = circle.end();
        c.take(blocked(), end, origin, origin, think(0.0, 0.0), 0.0);
        let (look, _) = c.pending.clone().expect("a look around");
        assert!(turned(&look) < std::f64::consts::PI);

        // Out 1 m east and back to the spawn: the trail's loop is erased, none is left, but
        // the robot has seen the place from elsewhere; blocked twice, it looks around twice.
        let mut c = Controller::new(origin, Latency::None, DriveLimits::default());
        for i in (0..=20).chain((0..20).rev()) {
            let x = 0.05 * f64::from(i);
            c.moved(Pose2 { x, ..origin });
        }
        assert!(c.trail.length() < 1e-9);
        for time in [40.0, 46.0] {
            c.take(blocked(), time, origin, origin, think(0.0, 0.0), 0.0);
            let (look, _) = c.pending.clone().expect("a look around");
            assert!(turned(&look) < std::f64::consts::PI, "at {time} s");
        }
    }

    /// A planner whose own grid boxes in a place the robot just drove to (AG-SLAM under a
    /// table whose top lies inside its 1.3 m band) fails "boxed in" however it turns: the
    /// second such failure there retraces, as a blocked plan's does. Plain "no goal is
    /// reachable" twice in place only looks around (RT-GuIDE's, when no viewpoint has a
    /// clear edge).
    #[test]
    fn boxed_in_again_where_it_looked_around_retraces_the_way_it_came() {
        let origin = Pose2::default();
        let drive_east = || {
            let mut c = Controller::new(origin, Latency::None, DriveLimits::default());
            let mut pose = origin;
            for _ in 0..200 {
                pose = autonomy::drive::advance(&pose, &FORWARD, 0.02);
                c.moved(pose);
            }
            (c, pose)
        };
        let (mut c, here) = drive_east();
        let boxed_in = || Some(Decision::Fail(PlanFailure::BoxedIn));
        c.take(boxed_in(), 10.0, here, here, think(0.0, 0.0), 0.0);
        let (look, _) = c.pending.clone().expect("a look around");
        assert!(look.commands.iter().all(|u| u.v == 0.0 && u.w != 0.0));
        assert_eq!(c.retraces, 0);
        c.take(boxed_in(), look.end(), here, here, think(0.0, 0.0), 0.0);
        assert_eq!((c.retraces, c.recovery_events), (1, 2));
        let (back, _) = c.pending.clone().expect("a retrace");
        // Back along the straight way it came: RETRACE_DISTANCE west of here, on the path.
        let end = back.predict(here, back.start, back.end() - back.start);
        assert!(
            (end.x - (here.x - RETRACE_DISTANCE)).abs() < 0.03 && end.y.abs() < 0.03,
            "{here:?} -> {end:?}"
        );

        let (mut c, here) = drive_east();
        let unreachable = || Some(Decision::Fail(PlanFailure::GoalUnreachable));
        for k in 0..3 {
            c.take(
                unreachable(),
                10.0 + 3.0 * k as f64,
                here,
                here,
                think(0.0, 0.0),
                0.0,
            );
            let (look, _) = c.pending.clone().expect("a look around");
            assert!(look.commands.iter().all(|u| u.v == 0.0 && u.w != 0.0));
        }
        assert_eq!(c.retraces, 0);
    }

    /// The trap fixtures' closed loop: the robot drives east from `from` to x = 0 (its trail),
    /// then from t = 10 s to 70 s `planner` plans whenever no schedule holds, and the
    /// controller's commands are driven in 20 ms steps, until the stuck watch ends it.
    /// `retrace` false forgets every look around, so no retrace ever starts: the trap as it
    /// was.
    fn closed_loop(
        planner: &mut dyn autonomy::explore::Planner,
        map: &autonomy::map::GaussianMap,
        from: Pose2,
        retrace: bool,
    ) -> (Controller, Vec<(f64, Pose2)>, Verdict) {
        let mut pose = from;
        let mut c = Controller::new(pose, Latency::None, DriveLimits::default());
        while pose.x < 0.0 {
            pose = autonomy::drive::advance(&pose, &FORWARD, 0.02);
            c.moved(pose);
        }
        let mut poses = Vec::new();
        let mut verdict = Verdict::Continue;
        let mut time = 10.0;
        while time < 70.0 && verdict == Verdict::Continue {
            c.advance(time, || pose);
            if !c.holding(time + 0.01) {
                let decision = autonomy::explore::Planner::plan(planner, map, pose);
                verdict = c.take(Some(decision), time, pose, pose, think(0.0, 0.0), 0.0);
                if !retrace {
                    c.looked_at = None;
                }
            }
            for k in 0..50 {
                c.advance(time + 0.02 * k as f64, || pose);
                pose = autonomy::drive::advance(
                    &pose,
                    &c.command(time + 0.02 * k as f64 + 0.01),
                    0.02,
                );
                c.moved(pose);
                poses.push((time + 0.02 * k as f64, pose));
            }
            time += 1.0;
        }
        (c, poses, verdict)
    }

    /// The trap, as a fixture: RT-GuIDE's own planner and this controller in a closed loop on
    /// the unicycle model. The robot has driven 2 m east along a seen corridor to a strip of
    /// floor no ray has crossed (0.45-0.6 m ahead, in the camera's blind zone: the camera
    /// 0.2 m ahead of the axle sees the floor only from 0.7 m on), the corridor's open east
    /// end, its frontier, beyond it. The grid never changes here, as in the blind zone it does
    /// not: facing east every candidate passes near the strip (blocked); a look around
    /// gives turns and short moves that end facing east again, blocked, and so on: the
    /// failures of the reported trap, every few seconds within 0.3 m, until the stuck watch
    /// ends the episode. The retrace takes the robot a metre back along its own path, where
    /// the strip is in view, within a bounded time and on the path it drove.
    #[test]
    fn a_robot_blocked_by_unseen_floor_in_its_blind_zone_is_freed_by_the_retrace() {
        use autonomy::explore::evidence::{EvidenceConfig, EvidenceGrid};
        use autonomy::gaussians::Gaussians;
        use autonomy::map::GaussianMap;
        use autonomy::math::Point3;
        use autonomy::planner::{CollisionEngine, PlannerConfig, RtGuidePlanner};

        let strip = |x: f64| (0.45..0.6).contains(&x);
        let corridor = |x: f64, y: f64| (-4.0..4.0).contains(&x) && y.abs() < 0.8;
        let mut grid = EvidenceGrid::new(EvidenceConfig::default());
        let cell = 0.05;
        for j in -40..40 {
            for i in -100..100 {
                let (x, y) = ((f64::from(i) + 0.5) * cell, (f64::from(j) + 0.5) * cell);
                if corridor(x, y) && !strip(x) {
                    // Seen floor: a ray down to it.
                    grid.integrate_ray(Point3::new(x, y, 0.5), Point3::new(x + 1e-3, y, 0.0));
                } else if !corridor(x, y) && x < 4.0 && y.abs() < 1.0 {
                    // The corridor's walls: rays that end in them at the robot's height.
                    grid.integrate_ray(Point3::new(x + 1e-3, y, 0.3), Point3::new(x, y, 0.3));
                }
            }
        }
        // Something mapped (high on a wall, far behind): the planner plans only on a map.
        let mut g = Gaussians::default();
        for k in 0..400 {
            let (i, j) = ((k % 20) as f32, (k / 20) as f32);
            g.push([-3.5 + 0.01 * i, 0.85, 0.6 + 0.01 * j], 0.02, 0.9, [0.5; 3]);
        }
        let map = GaussianMap::new(g, vec![1e-3; 400]);
        let config = PlannerConfig {
            frontier_regions: true,
            ..PlannerConfig::default()
        };

        // The closed loop from t = 10 s, the robot at the origin after 2 m east; `retrace`
        // off shows the trap as it was (looks around only).
        let run = |retrace: bool| {
            let mut planner =
                RtGuidePlanner::with_evidence(config.clone(), CollisionEngine::Grid, grid.clone());
            let from = Pose2 {
                x: -2.0,
                y: 0.0,
                theta: 0.0,
            };
            closed_loop(&mut planner, &map, from, retrace)
        };

        // Without the retrace: the reported trap.
        let (c, poses, verdict) = run(false);
        let blocked = c
            .failures
            .get("NoCandidateClearOfUnseen")
            .copied()
            .unwrap_or(0);
        assert!(blocked >= 5, "{:?}", c.failures);
        assert!(poses
            .iter()
            .all(|(_, p)| p.distance([0.0, 0.0]) < StuckWatch::ESCAPE));
        assert!(
            matches!(verdict, Verdict::Abort(ref why) if why.starts_with("stuck")),
            "{verdict:?}"
        );

        // With it: blocked at 10 s, looked around, blocked again at 15 s 0.3 m on; the retrace
        // takes the robot a metre back along the way it came (through the look around's arc
        // and down the corridor) by 25 s, staying in the corridor, clear of the strip. (The
        // grid does not change here, so the robot comes back and the cycle repeats; in an
        // episode the camera sees the strip from there.) The stuck watch never fires.
        let (c, poses, verdict) = run(true);
        assert_eq!(verdict, Verdict::Continue);
        assert!(c.retraces >= 2, "{} retraces", c.retraces);
        let (freed, at) = poses
            .iter()
            .find(|(_, p)| p.x <= -0.7)
            .copied()
            .expect("the robot gets back down the corridor");
        assert!(freed < 25.0, "back at {freed} s ({at:?})");
        for (t, p) in &poses {
            assert!(
                p.y.abs() < 0.8 - 0.25 && p.x < 0.45 - 0.25,
                "at {t} s: {p:?}"
            );
        }
    }

    /// The table trap, as a fixture: AG-SLAM's own planner and this controller in a closed
    /// loop. A hall (3.2 m wide, walls north, south and west, its east end open: the one
    /// frontier) has a table at its middle whose top (0.75 m, 1.1 x 1.0 m) the robot, 0.5 m
    /// tall, drove under along the hall's axis. AG-SLAM's grid counts depth ends up to 1.3 m
    /// (the papers' band), so the top's cells are occupied: under it the planner is boxed in
    /// ([`PlanFailure::BoxedIn`]), and a look around changes nothing (here the grid is fixed;
    /// in the episode the camera sees the same top again). Without the retrace the stuck watch ends the
    /// episode under the table; with it the robot backs out along the way it came and plans
    /// round the table toward the frontier.
    #[test]
    fn a_robot_boxed_in_under_a_table_by_agslams_grid_is_freed_by_the_retrace() {
        use autonomy::explore::agslam::{AgslamConfig, AgslamPlanner};
        use autonomy::explore::evidence::EvidenceGrid;
        use autonomy::explore::executor::{CollisionEngine, ExecutorConfig};
        use autonomy::explore::fbe::FbeConfig;
        use autonomy::gaussians::Gaussians;
        use autonomy::map::GaussianMap;
        use autonomy::math::Point3;
        use autonomy::planner::information::CameraMount;

        let under_table = |x: f64, y: f64| x.abs() < 0.55 && y.abs() < 0.5;
        let hall = |x: f64, y: f64| (-4.0..6.0).contains(&x) && y.abs() < 1.6;
        // The body-height guard is off: this fixture is about the planner's own grid.
        let config = AgslamConfig {
            frontier: FbeConfig {
                avoid_unseen: false,
                ..FbeConfig::default()
            },
            ..AgslamConfig::default()
        };
        let mut grid = EvidenceGrid::new(config.frontier.evidence);
        let cell = 0.05;
        for j in -40..40 {
            for i in -90..80 {
                let (x, y) = ((f64::from(i) + 0.5) * cell, (f64::from(j) + 0.5) * cell);
                if under_table(x, y) {
                    // The table top, seen from the camera under it: rays that end in it at
                    // 0.74 m, inside the papers' band.
                    grid.integrate_ray(Point3::new(x + 1e-3, y, 0.4), Point3::new(x, y, 0.74));
                } else if hall(x, y) && x < 4.0 {
                    // Seen floor: a ray down to it.
                    grid.integrate_ray(Point3::new(x, y, 0.5), Point3::new(x + 1e-3, y, 0.0));
                } else if !hall(x, y) && x < 4.0 {
                    // The walls: rays that end in them at the robot's height.
                    grid.integrate_ray(Point3::new(x + 1e-3, y, 0.3), Point3::new(x, y, 0.3));
                }
            }
        }
        // The map: the table top's underside (the body, 0.5 m tall, passes under it).
        let mut g = Gaussians::default();
        for i in -10..=10 {
            for j in -9..=9 {
                g.push(
                    [0.05 * i as f32, 0.05 * j as f32, 0.74],
                    0.02,
                    0.9,
                    [0.5; 3],
                );
            }
        }
        let n = g.len();
        let map = GaussianMap::new(g, vec![1e-3; n]);

        let run = |retrace: bool| {
            let mut planner = AgslamPlanner::with_evidence(
                config.clone(),
                CameraMount::default(),
                ExecutorConfig::default(),
                CollisionEngine::Grid,
                grid.clone(),
            );
            // Its first plan is a look around at the start; here it had that long before.
            let from = Pose2 {
                x: -3.0,
                y: 0.0,
                theta: 0.0,
            };
            let _ = autonomy::explore::Planner::plan(&mut planner, &map, from);
            closed_loop(&mut planner, &map, from, retrace)
        };

        // Without the retrace: boxed in, again and again, under the table.
        let (c, poses, verdict) = run(false);
        let boxed_in = c.failures.get("BoxedIn").copied().unwrap_or(0);
        assert!(boxed_in >= 5, "{:?}", c.failures);
        assert!(poses.iter().all(|(_, p)| under_table(p.x, p.y)));
        assert!(
            matches!(verdict, Verdict::Abort(ref why) if why.starts_with("stuck")),
            "{verdict:?}"
        );

        // With it: out from under the table within a look around and a retrace, then round
        // it toward the frontier; the stuck watch never fires.
        let (c, poses, verdict) = run(true);
        assert_eq!(verdict, Verdict::Continue, "{:?}", c.failures);
        assert!(c.retraces >= 1);
        let (out, at) = poses
            .iter()
            .find(|(_, p)| !under_table(p.x, p.y))
            .copied()
            .expect("the robot leaves the table");
        assert!(out < 25.0, "out at {out} s ({at:?})");
        assert!(at.x < 0.0, "it backs out the way it came: {at:?}");
        let east = poses
            .iter()
            .map(|(_, p)| p.x)
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(
            east > 1.0,
            "it gets past the table toward the frontier: {east:.2}"
        );
    }
}
