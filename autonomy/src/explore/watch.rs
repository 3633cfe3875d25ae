//! Watches that notice a robot getting nowhere: no progress for a while (back off and
//! replan), and recoveries that never get it out (the episode ends, saying where).

use crate::drive::Pose2;

/// No progress: for `SECONDS` the robot stayed within `RADIUS` and its heading swept less
/// than `TURN`. Turning counts because the camera is what explores: a look-around in place
/// (a full turn, then the turn toward the next goal) sees new surfaces without moving, while
/// a robot jiggling between two headings does not.
#[derive(Debug, Clone)]
pub struct ProgressWatch {
    check: (f64, Pose2),
    /// The heading unwrapped over the samples so far, radians.
    heading: f64,
    /// The least and most unwrapped heading since the window began.
    swept: (f64, f64),
}

impl ProgressWatch {
    /// Simulated seconds without progress before the planner is overruled.
    pub const SECONDS: f64 = 10.0;
    /// Metres the robot must move within that time...
    pub const RADIUS: f64 = 0.2;
    /// ... or radians of heading its camera must sweep (a half turn).
    pub const TURN: f64 = std::f64::consts::PI;

    /// Watching from `pose` at time 0.
    pub fn new(pose: Pose2) -> Self {
        ProgressWatch {
            check: (0.0, pose),
            heading: pose.theta,
            swept: (pose.theta, pose.theta),
        }
    }

    /// Takes in the pose at a think, holding schedules included; samples must come less than
    /// half a turn of heading apart (the drive turns at most 0.9 rad/s, thinks are 1 s apart).
    pub fn observe(&mut self, pose: &Pose2) {
        self.heading += crate::drive::wrap_angle(pose.theta - self.heading);
        self.swept = (
            self.swept.0.min(self.heading),
            self.swept.1.max(self.heading),
        );
    }

    /// Whether the robot made no progress by `time`.
    pub fn stalled(&self, time: f64, pose: &Pose2) -> bool {
        let (t0, p0) = self.check;
        time - t0 >= Self::SECONDS
            && pose.distance([p0.x, p0.y]) < Self::RADIUS
            && self.swept.1 - self.swept.0 < Self::TURN
    }

    /// Starts a new window at `time` when a recovery began or the window ran out.
    pub fn update(&mut self, time: f64, pose: Pose2, recovered: bool) {
        if recovered || time - self.check.0 >= Self::SECONDS {
            self.observe(&pose);
            self.check = (time, pose);
            self.swept = (self.heading, self.heading);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Feeds one pose per second for `seconds` (heading from `heading(t)`, standing at the
    /// origin) and says whether the watch called it stalled at the end.
    fn stalled_after(seconds: usize, heading: impl Fn(f64) -> f64) -> bool {
        let at = |t: f64| Pose2 {
            x: 0.0,
            y: 0.0,
            theta: crate::drive::wrap_angle(heading(t)),
        };
        let mut watch = ProgressWatch::new(at(0.0));
        for s in 1..=seconds {
            let t = s as f64;
            watch.observe(&at(t));
            if t < seconds as f64 {
                assert!(!watch.stalled(t, &at(t)), "stalled early at {t} s");
            }
        }
        watch.stalled(seconds as f64, &at(seconds as f64))
    }

    #[test]
    fn standing_or_jiggling_is_no_progress_but_a_look_around_is() {
        assert!(stalled_after(10, |_| 0.3));
        // +-60 degrees back and forth: two thirds of a half turn swept.
        assert!(stalled_after(10, |t| if (t as usize).is_multiple_of(2) {
            1.0
        } else {
            -1.0
        }));
        // A full turn at 0.8 rad/s through the wrap at +-pi, then standing.
        assert!(!stalled_after(10, |t| 3.0 + 0.8 * t.min(8.0)));
        // The other way round.
        assert!(!stalled_after(10, |t| -3.0 - 0.8 * t.min(8.0)));
        // Just under a half turn is still none.
        assert!(stalled_after(10, |t| 0.3 * t.min(10.0)));
    }

    #[test]
    fn a_new_window_forgets_the_turns_of_the_last() {
        let pose = |theta: f64| Pose2 {
            x: 0.0,
            y: 0.0,
            theta,
        };
        let mut watch = ProgressWatch::new(pose(0.0));
        for s in 1..=8 {
            watch.observe(&pose(0.5 * s as f64));
        }
        assert!(!watch.stalled(10.0, &pose(4.0)));
        watch.update(10.0, pose(4.0), false);
        for s in 11..=20 {
            watch.observe(&pose(4.0));
            assert_eq!(watch.stalled(s as f64, &pose(4.0)), s == 20, "at {s} s");
        }
    }
}
