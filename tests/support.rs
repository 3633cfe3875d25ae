//! Shared helpers: paths of the committed worlds and fixtures, a loaded room, the binary,
//! signals, list counts, folder snapshots and a tiny map.

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

/// The splatloop binary, run from the repository's root.
pub fn binary() -> std::process::Command {
    let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_splatloop"));
    command.current_dir(repo_path(""));
    command
}

/// Sends a process a signal by `kill` (`-INT`, `-TERM`, `-KILL`).
pub fn signal(pid: u32, name: &str) {
    let status = std::process::Command::new("kill")
        .args([name, &pid.to_string()])
        .status()
        .expect("kill");
    assert!(status.success());
}

/// Entries of a list file (comments skipped).
pub fn entries(path: &std::path::Path) -> usize {
    std::fs::read_to_string(path)
        .unwrap_or_default()
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .count()
}

/// Every file under `dir` (relative to it) with its bytes, sorted.
pub fn snapshot(dir: &std::path::Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).expect("read dir") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let bytes = std::fs::read(&path).expect("read");
                files.push((path.strip_prefix(dir).expect("under").to_path_buf(), bytes));
            }
        }
    }
    files.sort();
    files
}

/// A map of 20 Gaussians in the room, written as a PLY.
pub fn tiny_map(path: &std::path::Path) {
    let mut gaussians = autonomy::gaussians::Gaussians::default();
    for k in 0..20 {
        gaussians.means.push([1.0 + 0.05 * k as f32, 0.0, 0.5]);
        gaussians.colours.push([0.5, 0.4, 0.3]);
        gaussians.log_radii.push((0.05f32).ln());
        gaussians.logit_opacities.push(2.0);
    }
    let map = autonomy::map::GaussianMap::new(gaussians, vec![0.0; 20]);
    autonomy::ply::write(&map, path).expect("map");
}
