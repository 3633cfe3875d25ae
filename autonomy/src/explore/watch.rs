//! Watches that notice a robot getting nowhere: no progress for a while (back off and
//! replan), and recoveries that never get it out (the episode ends, saying where).

use crate::drive::Pose2;

/// No progress: the robot stayed within `radius` for `seconds`.
#[derive(Debug, Clone)]
pub struct ProgressWatch {
    check: (f64, Pose2),
}

impl ProgressWatch {
    /// Simulated seconds without progress before the planner is overruled.
    pub const SECONDS: f64 = 10.0;
    /// Metres the robot must move within that time.
    pub const RADIUS: f64 = 0.2;

    /// Watching from `pose` at time 0.
    pub fn new(pose: Pose2) -> Self {
        ProgressWatch { check: (0.0, pose) }
    }

    /// Whether the robot made no progress by `time`.
    pub fn stalled(&self, time: f64, pose: &Pose2) -> bool {
        let (t0, p0) = self.check;
        time - t0 >= Self::SECONDS && pose.distance([p0.x, p0.y]) < Self::RADIUS
    }

    /// Starts a new window at `time` when a recovery began or the window ran out.
    pub fn update(&mut self, time: f64, pose: Pose2, recovered: bool) {
        if recovered || time - self.check.0 >= Self::SECONDS {
            self.check = (time, pose);
        }
    }
}

/// Recoveries that did not get the robot out: ends an episode whose robot is boxed in.
#[derive(Debug, Clone)]
pub struct StuckWatch {
    anchor: (f64, Pose2),
    recoveries: usize,
}

impl StuckWatch {
    /// Distance the robot must get from where it was to count as free, metres.
    pub const ESCAPE: f64 = 0.3;
    /// Recoveries without escaping before the episode ends...
    pub const RECOVERIES: usize = 5;
    /// ... over at least these simulated seconds.
    pub const SECONDS: f64 = 45.0;

    /// Watching from `pose` at time 0.
    pub fn new(pose: Pose2) -> Self {
        StuckWatch {
            anchor: (0.0, pose),
            recoveries: 0,
        }
    }

    /// Notes the pose (and whether a recovery was started) at a think; returns the reason to
    /// give up when the robot is boxed in.
    pub fn update(&mut self, time: f64, pose: Pose2, recovered: bool) -> Option<String> {
        let (t0, p0) = self.anchor;
        if pose.distance([p0.x, p0.y]) > Self::ESCAPE {
            self.anchor = (time, pose);
            self.recoveries = 0;
            return None;
        }
        self.recoveries += usize::from(recovered);
        (self.recoveries >= Self::RECOVERIES && time - t0 >= Self::SECONDS).then(|| {
            format!(
                "stuck: {} recoveries in {:.0} s left the robot within {} m of ({:.2}, {:.2}), so \
                 the episode ended early. The robot is boxed in, or the planner finds no way out; \
                 check the world around that point",
                self.recoveries,
                time - t0,
                Self::ESCAPE,
                p0.x,
                p0.y
            )
        })
    }
}
