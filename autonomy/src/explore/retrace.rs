//! The way the robot came, and the recovery that drives it back that way.
//!
//! Why it exists: a plan fails with "every motion primitive collides" (or "passes near space
//! not yet seen free") at a place the robot has just driven to. Turning in place cannot cure
//! that when what blocks lies where the camera cannot see from here: floor and low objects
//! closer than the camera's lower field edge (0.4 m high, 30 degrees down: the floor 0.7 m
//! ahead of the camera and nearer is never in view), the robot's sides and back. Gaussians or
//! unseen cells there stay as they are however often the robot turns, so every replan fails
//! the same way, and a back-off drives into the same unknown. The space the robot's body has
//! just occupied is free whatever the map says; driving back through it is always possible,
//! and from [`RETRACE_DISTANCE`] back the camera sees the blocked place from outside its
//! blind zone, so the map and the evidence grid can change there.
//!
//! The same cure serves a planner boxed in by its own grid (`PlanFailure::BoxedIn`) twice in
//! place: a planner that routes on its own grid can box in a place its executor let the body
//! drive to (AG-SLAM's 1.3 m band takes a table top for a wall; the 0.5 m robot drives under
//! it, and every look around sees the top again). The trail out is the way the body came in.
//!
//! The chassis is symmetric about the wheel axle (0.25 m either way), so driving the path
//! backwards facing the other way sweeps the same floor as driving it forwards did.

use super::schedule::Schedule;
use crate::drive::{advance, wrap_angle, DriveLimits, Pose2, UnicycleCommand};

/// How far back a retrace drives along the trail, metres: the camera's blind zone ahead of
/// the robot's centre (0.2 m to the camera plus the 0.7 m to the lowest ray's floor point)
/// plus a margin, so the place the plans failed at lies in view once the robot turns to it.
pub const RETRACE_DISTANCE: f64 = 1.0;
/// The least trail worth retracing, metres: less does not get the robot out of the stuck
/// watch's radius.
pub const MIN_RETRACE: f64 = 0.3;
/// Forward speed of a retrace, m/s (a back-off's).
const RETRACE_SPEED: f64 = 0.3;
/// Seconds per command of a retrace.
const RETRACE_TICK: f64 = 0.1;
/// Distance between the trail's points a retrace aims at, metres: a chord this long (up to a
/// trail step more) of the tightest arc the primitives drive (0.6 m/s at 0.9 rad/s, radius
/// 0.67 m) strays at most 7 mm from it.
const WAYPOINT_SPACING: f64 = 0.15;

/// The robot's recent positions, at least [`Trail::SPACING`] apart, with loops erased: when
/// the robot comes back near a point of its trail, what it drove since that point is dropped,
/// so the trail is always a simple way back (a retrace's own drive erases what it retraced).
#[derive(Debug, Clone, PartialEq)]
pub struct Trail {
    points: Vec<[f64; 2]>,
}

impl Trail {
    /// Metres between kept positions.
    pub const SPACING: f64 = 0.05;
    /// Positions kept (the newest): 20 m of trail.
    pub const KEEP: usize = 400;

    /// A trail that starts at `pose`.
    pub fn new(pose: Pose2) -> Self {
        Trail {
            points: vec![[pose.x, pose.y]],
        }
    }

    /// Takes in the robot's position (as often as wanted: nearby positions are skipped).
    pub fn push(&mut self, pose: Pose2) {
        let p = [pose.x, pose.y];
        let near = |q: &[f64; 2]| (q[0] - p[0]).hypot(q[1] - p[1]) < Self::SPACING;
        if self.points.last().is_some_and(near) {
            return;
        }
        if let Some(k) = self.points.iter().rposition(near) {
            // Back near an earlier point: the way back from here is the way back from there.
            self.points.truncate(k + 1);
            return;
        }
        self.points.push(p);
        if self.points.len() > Self::KEEP {
            let extra = self.points.len() - Self::KEEP;
            self.points.drain(..extra);
        }
    }

    /// The trail's length, metres.
    pub fn length(&self) -> f64 {
        self.points
            .windows(2)
            .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
            .sum()
    }

    /// Points back along the trail from its newest, about [`WAYPOINT_SPACING`] apart, up to
    /// `distance` of trail (the last one exactly there, or the trail's oldest point).
    fn back(&self, distance: f64) -> Vec<[f64; 2]> {
        let mut out = Vec::new();
        let (mut travelled, mut since) = (0.0, 0.0);
        for w in self.points.windows(2).rev() {
            let step = (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
            travelled += step;
            since += step;
            if travelled >= distance {
                // The point exactly `distance` back, on this step.
                let t = 1.0 - (travelled - distance) / step;
                out.push([
                    w[1][0] + t * (w[0][0] - w[1][0]),
                    w[1][1] + t * (w[0][1] - w[1][1]),
                ]);
                return out;
            }
            if since >= WAYPOINT_SPACING {
                out.push(w[0]);
                since = 0.0;
            }
        }
        if since > 0.0 {
            out.push(self.points[0]);
        }
        out
    }
}

/// Drives from `from` back along `trail` for up to `distance` metres: at each waypoint a turn
/// in place toward the next, then a straight drive to it, each exact in the unicycle model
/// (rates chosen so whole ticks land on the waypoint, aimed from the pose the commands so far
/// lead to, so no error accumulates). `None` when less than [`MIN_RETRACE`] of trail is left.
pub fn retrace(
    trail: &Trail,
    from: Pose2,
    start: f64,
    distance: f64,
    limits: &DriveLimits,
) -> Option<Schedule> {
    if trail.length().min(distance) < MIN_RETRACE {
        return None;
    }
    let speed = RETRACE_SPEED.min(limits.max_forward);
    let mut pose = from;
    let mut commands = Vec::new();
    let mut drive = |pose: &mut Pose2, u: UnicycleCommand, ticks: usize| {
        for _ in 0..ticks {
            commands.push(u);
            *pose = advance(pose, &u, RETRACE_TICK);
        }
    };
    // The trail's newest point lies up to a spacing behind the robot: that gap is retraced too.
    let gap = trail
        .points
        .last()
        .map_or(0.0, |p| (p[0] - from.x).hypot(p[1] - from.y));
    for w in trail.back((distance - gap).max(0.0)) {
        let (dx, dy) = (w[0] - pose.x, w[1] - pose.y);
        let length = dx.hypot(dy);
        if length < 1e-6 {
            continue;
        }
        let turn = wrap_angle(dy.atan2(dx) - pose.theta);
        let ticks = (turn.abs() / (limits.max_turn * RETRACE_TICK)).ceil() as usize;
        if ticks > 0 {
            let w = turn / (ticks as f64 * RETRACE_TICK);
            drive(&mut pose, UnicycleCommand { v: 0.0, w }, ticks);
        }
        let ticks = (length / (speed * RETRACE_TICK)).ceil().max(1.0) as usize;
        let v = length / (ticks as f64 * RETRACE_TICK);
        drive(&mut pose, UnicycleCommand { v, w: 0.0 }, ticks);
    }
    Some(Schedule {
        start,
        period: RETRACE_TICK,
        commands,
        commit: f64::INFINITY,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(x: f64, y: f64, theta: f64) -> Pose2 {
        Pose2 { x, y, theta }
    }

    /// A trail along an S: forward 1 m, a left arc, a right arc, as the primitives drive.
    fn s_curve() -> (Trail, Vec<Pose2>) {
        let mut p = pose(0.0, 0.0, 0.0);
        let mut trail = Trail::new(p);
        let mut driven = vec![p];
        let legs = [(0.5, 0.0, 2.0), (0.6, 0.9, 1.5), (0.6, -0.9, 1.5)];
        for (v, w, seconds) in legs {
            for _ in 0..(seconds / 0.02) as usize {
                p = advance(&p, &UnicycleCommand { v, w }, 0.02);
                trail.push(p);
                driven.push(p);
            }
        }
        (trail, driven)
    }

    /// Distance from `p` to the polyline `path`.
    fn off_path(p: [f64; 2], path: &[Pose2]) -> f64 {
        path.windows(2)
            .map(|w| {
                let (a, b) = ([w[0].x, w[0].y], [w[1].x, w[1].y]);
                let (ab, ap) = ([b[0] - a[0], b[1] - a[1]], [p[0] - a[0], p[1] - a[1]]);
                let len2 = ab[0] * ab[0] + ab[1] * ab[1];
                let t = if len2 > 0.0 {
                    ((ap[0] * ab[0] + ap[1] * ab[1]) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (a[0] + t * ab[0] - p[0]).hypot(a[1] + t * ab[1] - p[1])
            })
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn a_retrace_drives_back_along_the_way_the_robot_came_and_ends_the_distance_back() {
        let (trail, driven) = s_curve();
        let end = *driven.last().expect("a path");
        let limits = DriveLimits::default();
        let schedule = retrace(&trail, end, 10.0, RETRACE_DISTANCE, &limits).expect("a retrace");
        assert!(schedule.commands.iter().all(|u| limits.admits(*u)));
        assert!(schedule.holding_at(10.0 + schedule.period * 3.0));
        // Every pose the schedule passes through, in 20 ms steps, stays on the path driven.
        let mut p = end;
        let mut worst: f64 = 0.0;
        for u in &schedule.commands {
            for _ in 0..5 {
                p = advance(&p, u, 0.02);
                worst = worst.max(off_path([p.x, p.y], &driven));
            }
        }
        assert!(worst < 0.01, "strays {worst} m from the path driven");
        // It ends RETRACE_DISTANCE back along the path: find that point by walking it.
        let mut left = RETRACE_DISTANCE;
        let mut target = driven[0];
        for w in driven.windows(2).rev() {
            let step = w[1].distance([w[0].x, w[0].y]);
            if step >= left {
                let t = left / step;
                target = pose(
                    w[1].x + t * (w[0].x - w[1].x),
                    w[1].y + t * (w[0].y - w[1].y),
                    0.0,
                );
                break;
            }
            left -= step;
        }
        assert!(
            p.distance([target.x, target.y]) < 0.06,
            "ends at {p:?}, {target:?} expected"
        );
    }

    #[test]
    fn the_trail_erases_loops_and_a_short_trail_is_no_retrace() {
        // Out 1.2 m east, back west to 1 mm of the start: the trail is the start alone.
        let mut trail = Trail::new(pose(0.0, 0.0, 0.0));
        for k in 1..=20 {
            trail.push(pose(0.06 * k as f64, 0.0, 0.0));
        }
        assert!((trail.length() - 1.2).abs() < 1e-9);
        for k in (0..20).rev() {
            trail.push(pose(0.06 * k as f64 + 0.001, 0.0, std::f64::consts::PI));
        }
        assert_eq!(trail.length(), 0.0);
        let limits = DriveLimits::default();
        assert_eq!(
            retrace(&trail, pose(0.0, 0.0, 0.0), 0.0, 1.0, &limits),
            None
        );
        // A retrace's own drive erases what it retraced: after it, the trail ends where it
        // ended, so a second retrace goes on further back instead of returning.
        let (mut trail, driven) = s_curve();
        let before = trail.length();
        let end = *driven.last().expect("a path");
        let schedule = retrace(&trail, end, 0.0, RETRACE_DISTANCE, &limits).expect("a retrace");
        let mut p = end;
        for u in &schedule.commands {
            for _ in 0..5 {
                p = advance(&p, u, 0.02);
                trail.push(p);
            }
        }
        let after = trail.length();
        assert!(
            (before - after - RETRACE_DISTANCE).abs() < 0.08,
            "{before} m -> {after} m"
        );
    }
}
