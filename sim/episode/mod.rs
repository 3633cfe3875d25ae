//! One closed-loop episode, as a library: [`Episode`] steps DESIGN's tick a think period at a
//! time (physics every step, the drive controller every step, the camera at its rate, and
//! every think period the mapper takes the newest frame and the planner, or the caller, a new
//! (v, w) schedule, which the robot follows until the next). With `Latency::Wall` the compute
//! time of mapping and planning is charged to simulated time: the previous schedule keeps
//! running meanwhile, as on a robot. `splatloop run` is [`run_episode`], a loop over it.

use crate::camera::SensorConfig;
use crate::error::{Result, SimError};
use crate::record::Versions;
use crate::rerun_log::RerunTarget;
use crate::robot::Pose2;
use crate::spawn::Spawn;
use autonomy::splat::EngineChoice;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

pub mod controls;
pub mod evaluate;
pub mod planners;
pub mod record;
pub mod survey;

mod control;
mod finish;
mod listen;
mod metrics;
mod tally;
mod tick;

pub use crate::planners::{
    AgslamOptions, PlannerChoice, PlannerContext, PlannerKind, PlannerOptions, PythonPlannerSpec,
    RtGuideOptions,
};
pub use listen::{TickEvent, TickListener};
pub use metrics::{percentiles, Metrics, Percentiles};
pub use tally::StageTimes;
pub use tick::{Episode, StepReport, Think};

/// The map's means as a coloured point cloud, which transforms.json names for nerfstudio.
pub const POINT_CLOUD: &str = "points.ply";

/// How compute time relates to simulated time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Latency {
    /// The robot keeps executing its previous plan while the autonomy thinks.
    #[default]
    Wall,
    /// The world waits for the autonomy.
    None,
}

/// Everything that defines an episode.
#[derive(Debug, Clone, Serialize)]
pub struct RunConfig {
    /// MJCF world.
    pub world: PathBuf,
    /// Simulated seconds to explore.
    pub budget: f64,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Camera frames per simulated second.
    pub camera_rate: f64,
    /// Seconds between mapping + planning steps.
    pub think_period: f64,
    /// Adam iterations per mapping step.
    pub iterations: usize,
    /// Latency model.
    pub latency: Latency,
    /// The planner (a Python one needs its object: [`Episode::with_planner`]).
    pub planner: PlannerChoice,
    /// The planners' own settings.
    pub planner_options: PlannerOptions,
    /// The camera.
    pub sensor: SensorConfig,
    /// Hidden test views sampled in free space for the evaluation (0: none).
    pub test_views: usize,
    /// End the episode when the planner says it is done (else it runs to its budget with the
    /// robot still and the mapper on its schedule: the same mapping time for every planner).
    pub stop_when_done: bool,
    /// With the planner done at t, end at this multiple of t (within the budget): a sweep's
    /// survey runs to the time every other planner then gets.
    pub done_factor: Option<f64>,
    /// Spherical-harmonic degree of map.ply: 0, or 3 for the reference 3DGS loader.
    pub ply_sh_degree: u8,
    /// How the start pose is chosen.
    pub spawn: Spawn,
    /// Splat engine asked for.
    #[serde(skip)]
    pub engine: EngineChoice,
    /// Replace an earlier episode in `out`.
    #[serde(skip)]
    pub overwrite: bool,
    /// A rerun recording of the episode, if one is wanted.
    #[serde(skip)]
    pub rerun: RerunTarget,
    /// Set by a signal handler to stop at the next tick (the episode is still written).
    #[serde(skip)]
    pub stop: StopRequest,
    /// Makes every write fail after this many frames, as a full disk would (tests).
    #[serde(skip)]
    pub fail_writes_after: Option<usize>,
    /// Episode folder.
    #[serde(skip)]
    pub out: PathBuf,
}

#[derive(Serialize)]
struct EpisodeFile<'a> {
    command: &'static str,
    config: &'a RunConfig,
    versions: Versions,
    /// The start pose actually used (`config.spawn` says how it was chosen).
    start_pose: Pose2,
    final_pose: Pose2,
    /// The planner's settings (`config.planner` names it).
    planner_settings: serde_json::Value,
}

/// What the progress callback hears after each think.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    /// Simulated seconds.
    pub time: f64,
    /// Gaussians in the map.
    pub gaussians: usize,
    /// Coverage of the hidden test set so far (refreshed every 10 simulated seconds).
    pub coverage: Option<f64>,
}

/// Peak resident memory of this process in bytes (Linux's VmHWM), 0 where unknown.
pub fn peak_memory_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|status| {
            status.lines().find_map(|line| {
                let kb = line.strip_prefix("VmHWM:")?.trim().strip_suffix("kB")?;
                kb.trim().parse::<u64>().ok()
            })
        })
        .map_or(0, |kb| kb * 1024)
}

/// The seed of an episode's hidden test set: derived from the episode's, so `splatloop eval`
/// with the same seed rebuilds the same set.
pub fn test_seed(seed: u64) -> u64 {
    seed ^ 0x7e57
}

impl RunConfig {
    /// Refuses settings no episode can run with, before anything is loaded.
    pub fn validate(&self) -> Result<()> {
        for (what, v) in [
            ("budget", self.budget),
            ("camera rate", self.camera_rate),
            ("think period", self.think_period),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(SimError::InvalidArgument {
                    what,
                    detail: format!("{v}; give a positive number"),
                });
            }
        }
        if let Some(f) = self.done_factor.filter(|f| !(f.is_finite() && *f >= 1.0)) {
            return Err(SimError::InvalidArgument {
                what: "--done-factor",
                detail: format!("{f}; give a multiple of the planner's time of 1 or more"),
            });
        }
        self.sensor.validate()
    }
}

/// Runs an episode to its end and writes it; `on_progress` is called after each think.
/// An error in a tick still leaves the episode written, and is then returned.
pub fn run_episode(config: &RunConfig, on_progress: &mut dyn FnMut(Progress)) -> Result<Metrics> {
    run_to_end(Episode::new(config)?, on_progress)
}

/// Steps `episode` until it ends, then writes it; `on_progress` is called after each think.
/// An error in a tick still leaves the episode written, and is then returned.
pub fn run_to_end(mut episode: Episode, on_progress: &mut dyn FnMut(Progress)) -> Result<Metrics> {
    let outcome = loop {
        match episode.step() {
            Ok(report) => {
                if let Some(progress) = report.progress {
                    on_progress(progress);
                }
                if report.ended.is_some() {
                    break Ok(());
                }
            }
            Err(e) => break Err(e),
        }
    };
    let metrics = episode.finish()?;
    outcome.map(|()| metrics)
}

/// A request to stop the episode at its next tick, set from a signal handler: 0 while none
/// came, else the exit code the process should end with (130 for SIGINT, 143 for SIGTERM).
#[derive(Debug, Clone, Default)]
pub struct StopRequest(Arc<AtomicUsize>);

impl StopRequest {
    /// Exit code of SIGINT (128 + 2).
    pub const SIGINT: usize = 130;
    /// Exit code of SIGTERM (128 + 15).
    pub const SIGTERM: usize = 143;

    /// The flag a signal handler stores its exit code into.
    pub fn flag(&self) -> Arc<AtomicUsize> {
        Arc::clone(&self.0)
    }

    /// The exit code asked for, if a stop was requested.
    pub fn requested(&self) -> Option<usize> {
        match self.0.load(Ordering::Relaxed) {
            0 => None,
            code => Some(code),
        }
    }

    /// The signal behind an exit code, as a person names it.
    pub fn signal_name(code: usize) -> &'static str {
        match code {
            Self::SIGINT => "SIGINT",
            Self::SIGTERM => "SIGTERM",
            _ => "a stop request",
        }
    }
}
