//! The schedule the host follows between plans, the recovery manoeuvres, and the pose a plan
//! must start from when it begins after a compute delay.

use super::{Plan, Recovery};
use crate::drive::{advance, wrap_angle, DriveLimits, Pose2, UnicycleCommand};

/// Constant commands of `period` seconds each from `start`.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    /// Simulated time the first command begins, seconds.
    pub start: f64,
    /// Seconds per command.
    pub period: f64,
    /// The commands.
    pub commands: Vec<UnicycleCommand>,
    /// Seconds from `start` it runs before the planner is asked again (infinity for a
    /// recovery manoeuvre or a look around, which replanning every period would cut short).
    pub commit: f64,
}

/// Steps of a recovery manoeuvre, seconds.
const RECOVERY_TICK: f64 = 0.1;
/// Seconds of a look around (a little over half a turn at 0.9 rad/s).
const LOOK_AROUND: f64 = 3.0;
/// Metres a back-off drives once turned away.
pub const BACK_OFF_DISTANCE: f64 = 0.15;
/// Forward speed of a back-off, m/s.
const BACK_OFF_SPEED: f64 = 0.3;

/// `ticks` recovery ticks turning in place at `rate` rad/s (a look around, a full turn).
fn turning(rate: f64, ticks: usize) -> Vec<UnicycleCommand> {
    vec![UnicycleCommand { v: 0.0, w: rate }; ticks]
}

impl Schedule {
    /// Standing still from `start`.
    pub fn idle(start: f64) -> Self {
        Schedule {
            start,
            period: 1.0,
            commands: Vec::new(),
            commit: 0.0,
        }
    }

    /// A plan's commands from `start`.
    pub fn from_plan(plan: &Plan, start: f64) -> Self {
        Schedule {
            start,
            period: plan.period,
            commands: plan.commands.clone(),
            commit: plan.commit,
        }
    }

    /// The recovery manoeuvres from a robot facing `heading`: a look around (turn in place)
    /// or a back-off. The unicycle cannot reverse, so backing off turns in place to its
    /// `away` and drives a little that way, unchecked: the heading the map says is clear
    /// (`executor::escape_heading`).
    pub fn recovery(kind: Recovery, start: f64, heading: f64, limits: &DriveLimits) -> Self {
        let turn_rate = limits.max_turn;
        let ticks = |seconds: f64| (seconds / RECOVERY_TICK).round() as usize;
        let commands = match kind {
            Recovery::TurnInPlace => turning(turn_rate, ticks(LOOK_AROUND)),
            Recovery::BackOff { away } => {
                let diff = wrap_angle(away - heading);
                let mut c = vec![
                    UnicycleCommand {
                        v: 0.0,
                        w: turn_rate * diff.signum()
                    };
                    ticks(diff.abs() / turn_rate)
                ];
                let speed = BACK_OFF_SPEED.min(limits.max_forward);
                c.extend(vec![
                    UnicycleCommand { v: speed, w: 0.0 };
                    ticks(BACK_OFF_DISTANCE / speed)
                ]);
                c
            }
        };
        Self::held(start, commands)
    }

    /// A manoeuvre of `commands`, one per recovery tick from `start`, held to its end.
    fn held(start: f64, commands: Vec<UnicycleCommand>) -> Self {
        Schedule {
            start,
            period: RECOVERY_TICK,
            commands,
            commit: f64::INFINITY,
        }
    }

    /// A whole turn in place, at least 360 degrees, held to its end: what a robot blocked
    /// again at its spawn does, where it has no trail to retrace. A look around turns 155
    /// degrees, and between two of them the plans turn the robot back toward its target, so
    /// looks around alone can sweep the same sector for ever while the floor every
    /// candidate must cross lies unseen on the other side (robustness-as-is, warehouse_02,
    /// RT-GuIDE spawn 3: stuck at its spawn after 8 looks around in 47 s).
    pub fn full_turn(start: f64, limits: &DriveLimits) -> Self {
        let rate = limits.max_turn;
        let ticks = (std::f64::consts::TAU / (rate * RECOVERY_TICK)).ceil() as usize;
        Self::held(start, turning(rate, ticks))
    }

    /// When the last command ends.
    pub fn end(&self) -> f64 {
        self.start + self.period * self.commands.len() as f64
    }

    /// Whether the schedule is still within its commitment at `time`.
    pub fn holding_at(&self, time: f64) -> bool {
        time < self.end().min(self.start + self.commit)
    }

    /// The command at simulated time `t`: standing still before the start and after the end.
    pub fn at(&self, t: f64) -> UnicycleCommand {
        let k = ((t - self.start) / self.period).floor();
        if k < 0.0 {
            return UnicycleCommand::STOP;
        }
        self.commands
            .get(k as usize)
            .copied()
            .unwrap_or(UnicycleCommand::STOP)
    }

    /// Where the unicycle model puts the robot after following the schedule from `pose` at
    /// `time` for `lead` seconds: the pose a plan that starts after the compute delay must
    /// start from.
    pub fn predict(&self, pose: Pose2, time: f64, lead: f64) -> Pose2 {
        predict(|t| self.at(t), pose, time, lead)
    }
}

/// Where the unicycle model puts the robot after following `command` (the command at each
/// simulated time) from `pose` at `time` for `lead` seconds, in steps of 20 ms, each with the
/// command at its middle (exact when the commands change on the steps' bounds, as schedules'
/// whole periods do; a start summed step by step could land just short of a bound).
pub fn predict(
    command: impl Fn(f64) -> UnicycleCommand,
    pose: Pose2,
    time: f64,
    lead: f64,
) -> Pose2 {
    let dt: f64 = 0.02;
    let steps = (lead / dt).ceil().max(0.0) as usize;
    (0..steps).fold(pose, |state, k| {
        let from = k as f64 * dt;
        let step = dt.min(lead - from).max(0.0);
        advance(&state, &command(time + from + 0.5 * step), step)
    })
}
