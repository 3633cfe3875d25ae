//! The host's safety check with wall latency: a plan is checked against the map of its think,
//! but the robot drives it on while the next think maps and plans (0.5-1 s here), and the
//! newest frame can show a surface across it that the older map did not hold (a table's far
//! side). Once a mapping step ends, the poses the robot will pass before the next plan starts
//! are checked against the new map, and the robot stands still if any collides, as a robot's
//! safety layer would stop it. Every planner gets the same check; it is not charged to the
//! think's latency (it runs beside planning on a robot).

use crate::robot::Pose2;
use autonomy::explore::executor::{CollisionEngine, Executor, ExecutorConfig};
use autonomy::map::GaussianMap;

/// The executor's copy of the map that the check runs against, kept in step incrementally.
#[derive(Debug)]
pub struct SafetyCheck {
    executor: Executor,
}

impl SafetyCheck {
    /// A check with the robot model every planner's executor uses.
    pub fn new() -> Self {
        SafetyCheck {
            executor: Executor::new(ExecutorConfig::default(), CollisionEngine::Grid),
        }
    }

    /// Whether every pose of `poses` is clear of `map` (brought into the copy first).
    pub fn clear(&mut self, map: &GaussianMap, poses: &[Pose2]) -> bool {
        self.executor.sync(map);
        poses.iter().all(|p| self.executor.is_free(p))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use autonomy::gaussians::Gaussians;

    #[test]
    fn the_check_agrees_with_a_brute_force_executor_pose_by_pose() {
        // A table-like cluster of small Gaussians at robot height, 2 m ahead.
        let mut g = Gaussians::default();
        for i in 0..20 {
            for j in 0..6 {
                g.push(
                    [2.0 + 0.03 * j as f32, -0.3 + 0.03 * i as f32, 0.25],
                    0.02,
                    0.9,
                    [0.5; 3],
                );
            }
        }
        let n = g.len();
        let map = GaussianMap::new(g, vec![0.0; n]);
        let mut reference = Executor::new(ExecutorConfig::default(), CollisionEngine::BruteForce);
        reference.sync(&map);
        let mut check = SafetyCheck::new();
        // Nothing mapped yet: nothing blocks.
        let ahead: Vec<Pose2> = (0..=60)
            .map(|k| Pose2 {
                x: 0.05 * k as f64,
                y: 0.2,
                theta: 0.0,
            })
            .collect();
        assert!(check.clear(&GaussianMap::default(), &ahead));
        let mut blocked = 0;
        for p in &ahead {
            let want = reference.is_free(p);
            assert_eq!(check.clear(&map, std::slice::from_ref(p)), want, "{p:?}");
            blocked += usize::from(!want);
        }
        assert!(blocked > 0 && blocked < ahead.len(), "{blocked} blocked");
        assert!(!check.clear(&map, &ahead));
    }
}
