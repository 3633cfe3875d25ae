//! The unicycle's motion primitives (DESIGN.md: 3 x 5 controls over [0, 0.6] x [-0.9, 0.9],
//! 1 s each), integrated exactly: straight lines and circular arcs.

/// A planar robot state: position (m) and heading (rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// Heading, radians.
    pub theta: f64,
}

/// A constant (v, w) command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Control {
    /// Forward speed, m/s.
    pub v: f64,
    /// Turn rate, rad/s.
    pub w: f64,
}

/// The primitive set.
#[derive(Debug, Clone, PartialEq)]
pub struct Primitives {
    /// The controls.
    pub controls: Vec<Control>,
    /// Duration of each, seconds.
    pub duration: f64,
}

impl Primitives {
    /// `nv` x `nw` controls evenly over [0, v_max] x [-w_max, w_max] (nv, nw >= 2).
    pub fn grid(nv: usize, nw: usize, v_max: f64, w_max: f64, duration: f64) -> Self {
        let mut controls = Vec::new();
        for i in 0..nv {
            for j in 0..nw {
                controls.push(Control {
                    v: v_max * i as f64 / (nv.max(2) - 1) as f64,
                    w: -w_max + 2.0 * w_max * j as f64 / (nw.max(2) - 1) as f64,
                });
            }
        }
        Primitives { controls, duration }
    }

    /// The paper's set: 3 x 5 over [0, 0.6] x [-0.9, 0.9], 1 s.
    pub fn rtguide() -> Self {
        Primitives::grid(3, 5, 0.6, 0.9, 1.0)
    }
}

/// The exact state after driving `u` for `t` seconds from `s`.
pub fn advance(s: &State, u: &Control, t: f64) -> State {
    let theta = s.theta + u.w * t;
    if u.w.abs() < 1e-9 {
        State {
            x: s.x + u.v * t * s.theta.cos(),
            y: s.y + u.v * t * s.theta.sin(),
            theta,
        }
    } else {
        let r = u.v / u.w;
        State {
            x: s.x + r * (theta.sin() - s.theta.sin()),
            y: s.y - r * (theta.cos() - s.theta.cos()),
            theta,
        }
    }
}
