//! The unicycle's motion primitives (DESIGN.md: 3 x 5 controls over [0, 0.6] x [-0.9, 0.9],
//! 1 s each), integrated exactly: straight lines and circular arcs.

pub use crate::drive::{advance, DriveLimits, Pose2, UnicycleCommand};

/// The primitive set.
#[derive(Debug, Clone, PartialEq)]
pub struct Primitives {
    /// The controls.
    pub controls: Vec<UnicycleCommand>,
    /// Duration of each, seconds.
    pub duration: f64,
}

impl Primitives {
    /// `nv` x `nw` controls evenly over [0, v_max] x [-w_max, w_max] (nv, nw >= 2).
    pub fn grid(nv: usize, nw: usize, v_max: f64, w_max: f64, duration: f64) -> Self {
        let mut controls = Vec::new();
        for i in 0..nv {
            for j in 0..nw {
                controls.push(UnicycleCommand {
                    v: v_max * i as f64 / (nv.max(2) - 1) as f64,
                    w: -w_max + 2.0 * w_max * j as f64 / (nw.max(2) - 1) as f64,
                });
            }
        }
        Primitives { controls, duration }
    }

    /// The paper's set: 3 x 5 over the drive limits ([0, 0.6] x [-0.9, 0.9]), 1 s.
    pub fn rtguide() -> Self {
        let limits = DriveLimits::default();
        Primitives::grid(3, 5, limits.max_forward, limits.max_turn, 1.0)
    }
}
