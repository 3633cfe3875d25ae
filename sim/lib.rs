//! splatloop's host: steps a MuJoCo unicycle robot, renders its RGB-D camera offscreen through
//! EGL, and writes datasets with exact poses. The autonomy side lives in the `autonomy` crate;
//! data flows one way, sim -> autonomy -> sim. The layers, lowest first: `platform` (MuJoCo,
//! EGL, the camera, the robot), `worlds`, `episode` (the closed loop), `output` (files and
//! recordings), `commands` (the command line); ARCHITECTURE.md says what each may use.

pub mod commands;
pub mod episode;
pub mod error;
pub mod output;
pub mod platform;
pub mod worlds;

pub use commands::{bench, sweep};
pub use episode::{controls, evaluate, planners, record, survey};
pub use error::{Result, SimError};
pub(crate) use output::canvas;
pub use output::{dataset, novel_view, plot, rerun_log};
pub use platform::{camera, egl, mujoco, robot};
pub use worlds::{floorplan, labels, scene, spawn, world, world_check, worldgen};

/// `bench world`'s generation and import timings (kept at its old path).
pub use commands::bench::worlds as bench_worlds;
