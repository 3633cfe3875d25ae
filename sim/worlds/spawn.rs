//! Where an episode starts: the world's `spawn` site, a given pose, or a seeded random pose
//! anywhere the robot can reach from the site with room around it, so that seeds give
//! different episodes in one world. Every start is checked against MuJoCo's own contacts.

use crate::error::{Result, SimError};
use crate::floorplan::FloorPlan;
use crate::robot::Pose2;
use crate::world::World;
use rand::SeedableRng;
use serde::Serialize;

/// Room a random start keeps around the robot, metres (less where no cell has that much).
pub const RANDOM_SPAWN_CLEARANCE: f64 = 0.6;

/// Random starts drawn before giving up.
const RANDOM_TRIES: usize = 100;

/// How the start pose is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Spawn {
    /// The world's `spawn` site (the origin without one).
    Site,
    /// Seeded, uniform over the reachable free space.
    Random,
    /// This pose.
    Pose(Pose2),
}

impl std::str::FromStr for Spawn {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "site" => Ok(Spawn::Site),
            "random" => Ok(Spawn::Random),
            text => parse_pose(text)
                .map(Spawn::Pose)
                .map_err(|e| format!("{e}; or use site or random")),
        }
    }
}

/// A pose `x,y,yaw` (metres, radians) from the command line.
pub fn parse_pose(text: &str) -> std::result::Result<Pose2, String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| format!("expected x,y,yaw: {e}"))?;
    match values[..] {
        [x, y, theta] if values.iter().all(|v| v.is_finite()) => Ok(Pose2 { x, y, theta }),
        _ => Err("expected three finite numbers x,y,yaw".into()),
    }
}

/// Puts the robot at its start as `spawn` asks (random draws use `seed`) and returns the
/// pose; a start where the robot touches the world is an error that names what it touches.
pub fn place_robot(world: &mut World, spawn: Spawn, seed: u64) -> Result<Pose2> {
    match spawn {
        Spawn::Site if !world.has_spawn_site() => tracing::warn!(
            "{} has no site named \"spawn\", so the robot starts at the origin facing +x; add <site name=\"spawn\" pos=\"X Y 0\"/> to the world or pass --spawn x,y,yaw (or random)",
            world.model().path().display()
        ),
        Spawn::Site => {}
        Spawn::Pose(pose) => world.set_start(pose),
        Spawn::Random => {
            let plan = FloorPlan::of(world)?;
            let site = world.start();
            let mut reachable = plan.reachable_from(site.x, site.y);
            if !reachable.iter().any(|r| *r) {
                // No usable site: the largest free space instead.
                let largest = plan
                    .components(|c| plan.is_free(c))
                    .into_iter()
                    .max_by_key(Vec::len);
                for c in largest.unwrap_or_default() {
                    reachable[c] = true;
                }
            }
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x5fa7_5ea7);
            let mut placed = false;
            for _ in 0..RANDOM_TRIES {
                let Some(pose) = plan.sample_pose(&reachable, RANDOM_SPAWN_CLEARANCE, &mut rng)
                else {
                    break;
                };
                world.set_start(pose);
                if world.robot_collisions().next().is_none() {
                    placed = true;
                    break;
                }
            }
            if !placed {
                return Err(SimError::InvalidArgument {
                    what: "spawn",
                    detail: format!(
                        "no collision-free pose with {:.2} m of clearance in {}; check the world with `splatloop world check`",
                        plan.clearance_needed,
                        world.model().path().display()
                    ),
                });
            }
        }
    }
    let start = world.start();
    if let Some(contact) = world.robot_collisions().next() {
        let name = world.touched_name(&contact);
        return Err(SimError::InvalidArgument {
            what: "spawn",
            detail: format!(
                "the robot at ({:.2}, {:.2}, yaw {:.2}) is inside {name}; pick a free pose (`splatloop world check` shows the free space)",
                start.x, start.y, start.theta
            ),
        });
    }
    Ok(start)
}
