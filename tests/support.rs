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
