//! Shared helpers: paths of the committed worlds and fixtures, and a loaded room.

use splatloop::camera::SensorConfig;
use splatloop::world::World;
use std::path::PathBuf;

/// A file under the repository root.
pub fn repo_path(relative: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(relative)
}

/// A tiny MJCF under tests/fixtures.
pub fn fixture(name: &str) -> PathBuf {
    repo_path(&format!("tests/fixtures/{name}"))
}

/// The default world with the default sensor.
pub fn room() -> World {
    World::load(&repo_path("worlds/room.xml"), &SensorConfig::default()).expect("room loads")
}

/// A closed-loop episode in `world` (repository-relative) for the tests: seed 3, latency
/// none, the CPU engine, 20 hidden views, 10 mapping iterations, ending when the planner is
/// done.
pub fn run_config(
    world: &str,
    planner: splatloop::episode::PlannerKind,
    budget: f64,
    out: std::path::PathBuf,
) -> splatloop::episode::RunConfig {
    splatloop::episode::RunConfig {
        world: repo_path(world),
        budget,
        seed: 3,
        camera_rate: 5.0,
        think_period: 1.0,
        iterations: 10,
        latency: splatloop::episode::Latency::None,
        planner: planner.into(),
        planner_options: Default::default(),
        sensor: SensorConfig::default(),
        test_views: 20,
        // Most tests assert how a planner ended; the default (to the budget) has its own.
        stop_when_done: true,
        done_factor: None,
        ply_sh_degree: 0,
        spawn: splatloop::spawn::Spawn::Site,
        engine: autonomy::splat::EngineChoice::Cpu,
        overwrite: false,
        rerun: Default::default(),
        stop: Default::default(),
        fail_writes_after: None,
        out,
    }
}
