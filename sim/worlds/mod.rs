//! Worlds: loading one, generating one by seed, importing and exporting scenes, floor plans, spawns and checks.

pub mod floorplan;
pub mod labels;
pub mod scene;
pub mod spawn;
pub mod world;
pub mod world_check;
pub mod worldgen;
