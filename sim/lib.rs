//! splatloop's host: steps a MuJoCo unicycle robot, renders its RGB-D camera offscreen through
//! EGL, and writes datasets with exact poses. The autonomy side lives in the `autonomy` crate;
//! data flows one way, sim -> autonomy -> sim.

pub mod bench;
pub mod bench_worlds;
pub mod camera;
mod canvas;
pub mod commands;
pub mod controls;
pub mod dataset;
pub mod egl;
pub mod episode;
pub mod error;
pub mod evaluate;
pub mod floorplan;
pub mod mujoco;
pub mod novel_view;
pub mod planners;
pub mod plot;
pub mod record;
pub mod rerun_log;
pub mod robot;
pub mod scene;
pub mod spawn;
pub mod survey;
pub mod sweep;
pub mod world;
pub mod world_check;
pub mod worldgen;

pub use error::{Result, SimError};
