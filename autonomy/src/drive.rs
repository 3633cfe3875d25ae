//! The unicycle's planar pose, its command and its drive limits: the one definition every
//! planner, the executor, the host's drive controller and the survey share, so a comparison
//! cannot give one planner a faster robot than another.

use serde::{Deserialize, Serialize};

/// A planar pose in the world frame: position (m) and heading (rad, counter-clockwise from +x).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose2 {
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// Heading, radians, counter-clockwise from +x.
    pub theta: f64,
}

impl Pose2 {
    /// Straight-line distance between the positions, metres.
    pub fn distance(&self, to: [f64; 2]) -> f64 {
        (to[0] - self.x).hypot(to[1] - self.y)
    }
}

/// A unicycle command: forward speed v (m/s) and turn rate w (rad/s, counter-clockwise).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct UnicycleCommand {
    /// Forward speed, m/s.
    pub v: f64,
    /// Turn rate, rad/s.
    pub w: f64,
}

impl UnicycleCommand {
    /// Standing still.
    pub const STOP: UnicycleCommand = UnicycleCommand { v: 0.0, w: 0.0 };
}

/// The robot's velocity limits (v in [0, 0.6] m/s, |w| <= 0.9 rad/s; the unicycle
/// does not reverse).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DriveLimits {
    /// Largest forward speed, m/s.
    pub max_forward: f64,
    /// Largest turn rate magnitude, rad/s.
    pub max_turn: f64,
}

impl Default for DriveLimits {
    fn default() -> Self {
        DriveLimits {
            max_forward: 0.6,
            max_turn: 0.9,
        }
    }
}

impl DriveLimits {
    /// The command brought inside the limits.
    pub fn clamp(&self, u: UnicycleCommand) -> UnicycleCommand {
        UnicycleCommand {
            v: u.v.clamp(0.0, self.max_forward),
            w: u.w.clamp(-self.max_turn, self.max_turn),
        }
    }

    /// Whether the command is inside the limits (to a rounding error).
    pub fn admits(&self, u: UnicycleCommand) -> bool {
        let eps = 1e-9;
        u.v >= -eps && u.v <= self.max_forward + eps && u.w.abs() <= self.max_turn + eps
    }
}

/// The exact pose after driving `u` for `t` seconds from `s`: a straight line or a circular arc.
pub fn advance(s: &Pose2, u: &UnicycleCommand, t: f64) -> Pose2 {
    let theta = s.theta + u.w * t;
    if u.w.abs() < 1e-9 {
        Pose2 {
            x: s.x + u.v * t * s.theta.cos(),
            y: s.y + u.v * t * s.theta.sin(),
            theta,
        }
    } else {
        let r = u.v / u.w;
        Pose2 {
            x: s.x + r * (theta.sin() - s.theta.sin()),
            y: s.y - r * (theta.cos() - s.theta.cos()),
            theta,
        }
    }
}

/// An angle wrapped into (-pi, pi].
pub fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let r = (a + PI).rem_euclid(TAU) - PI;
    if r <= -PI {
        r + TAU
    } else {
        r
    }
}
