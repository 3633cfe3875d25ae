//! `splatloop record`: drives the robot open-loop through a world and writes the dataset.

use crate::camera::SensorConfig;
use crate::controls::ControlSchedule;
use crate::dataset::DatasetWriter;
use crate::egl::EglContext;
use crate::error::{Result, SimError};
use crate::rerun_log::{RerunLog, RerunTarget};
use crate::robot::Pose2;
use crate::spawn::{place_robot, Spawn};
use crate::world::World;
use serde::Serialize;
use std::path::PathBuf;

/// Everything that defines a recording; written into episode.json.
#[derive(Debug, Clone, Serialize)]
pub struct RecordConfig {
    /// The MJCF world.
    pub world: PathBuf,
    /// Control file or pattern name.
    pub controls: String,
    /// Simulated seconds to drive.
    pub duration: f64,
    /// Camera frames per simulated second.
    pub frame_rate: f64,
    /// Seed of every random choice (depth noise).
    pub seed: u64,
    /// The sensor.
    pub sensor: SensorConfig,
    /// Start pose override (else the world's `spawn` site).
    pub start: Option<Pose2>,
    /// Replace an existing dataset in `out`.
    #[serde(skip)]
    pub overwrite: bool,
    /// A rerun recording of the drive, if one is wanted.
    #[serde(skip)]
    pub rerun: RerunTarget,
    /// Output folder (not recorded: the same episode is the same bytes wherever it lands).
    #[serde(skip)]
    pub out: PathBuf,
}

impl RecordConfig {
    /// Refuses durations and rates that make no sense.
    pub fn validate(&self) -> Result<()> {
        if !(self.duration.is_finite() && self.duration > 0.0) {
            return Err(SimError::InvalidArgument {
                what: "duration",
                detail: format!(
                    "{} s; give a positive number of simulated seconds",
                    self.duration
                ),
            });
        }
        if !(self.frame_rate.is_finite() && self.frame_rate > 0.0) {
            return Err(SimError::InvalidArgument {
                what: "frame rate",
                detail: format!("{} Hz; give a positive rate", self.frame_rate),
            });
        }
        self.sensor.validate()
    }
}

/// What episode.json records besides the config.
#[derive(Debug, Serialize)]
struct EpisodeFile<'a> {
    command: &'static str,
    config: &'a RecordConfig,
    versions: Versions,
    timestep: f64,
    frames: usize,
    collision_steps: usize,
    final_pose: Pose2,
}

/// Versions of everything that shapes the output.
#[derive(Debug, Serialize)]
pub struct Versions {
    /// This crate.
    pub splatloop: &'static str,
    /// The git commit the binary was built from ("unknown" outside a checkout): sweeps that
    /// resume across sessions say which build made each episode.
    pub commit: &'static str,
    /// libmujoco.
    pub mujoco: String,
    /// The EGL device and the GL vendor, renderer and version: the camera's images come from
    /// it, and another renderer changes a trajectory (README, "Reproducing a run").
    pub renderer: String,
    /// The CPU features the binary was built for (x86-64-v3's AVX2 and FMA, or a native
    /// build's AVX-512): they decide the SIMD paths.
    pub target_features: Vec<&'static str>,
    /// The CPU it ran on (/proc/cpuinfo's model name).
    pub cpu: String,
    /// Threads of the CPU engine's pool.
    pub threads: usize,
    /// The splat engine and, for the GPU, its adapter (runs; none for a recorded drive).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub splat_engine: Option<String>,
}

/// The CPU features a build may have been compiled with that change its arithmetic paths.
fn target_features() -> Vec<&'static str> {
    let mut on = Vec::new();
    macro_rules! feature {
        ($($name:tt),*) => {$(
            if cfg!(target_feature = $name) {
                on.push($name);
            }
        )*};
    }
    feature!("sse4.2", "avx", "avx2", "fma", "bmi2", "avx512f", "avx512bw", "avx512vl", "neon");
    on
}

/// /proc/cpuinfo's first model name, or "unknown".
fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|info| {
            info.lines().find_map(|l| {
                l.strip_prefix("model name")?
                    .split_once(':')
                    .map(|(_, m)| m.trim().to_owned())
            })
        })
        .unwrap_or_else(|| "unknown".into())
}

impl Versions {
    /// Collects the versions in use: what decides an episode's numbers.
    pub fn current(gl: &EglContext) -> Self {
        Versions {
            splatloop: env!("CARGO_PKG_VERSION"),
            commit: env!("SPLATLOOP_COMMIT"),
            mujoco: crate::mujoco::version(),
            renderer: gl.description().to_owned(),
            target_features: target_features(),
            cpu: cpu_model(),
            threads: rayon::current_num_threads(),
            splat_engine: None,
        }
    }

    /// With the splat engine an episode used.
    pub fn with_engine(mut self, engine: &str) -> Self {
        self.splat_engine = Some(engine.to_owned());
        self
    }
}

/// What a recording produced.
#[derive(Debug, Clone)]
pub struct RecordSummary {
    /// The dataset folder.
    pub out: PathBuf,
    /// Frames written.
    pub frames: usize,
    /// Physics steps in which the robot touched something other than the floor.
    pub collision_steps: usize,
    /// Where the robot ended.
    pub final_pose: Pose2,
}

/// Runs the recording; `on_progress` receives simulated time after each frame.
pub fn record(config: &RecordConfig, on_progress: &mut dyn FnMut(f64)) -> Result<RecordSummary> {
    config.validate()?;
    config.rerun.check(&config.out, config.overwrite)?;
    let mut world = World::load(&config.world, &config.sensor)?;
    let schedule = ControlSchedule::from_arg(&config.controls, &world.robot().limits)?;
    world.check_frame_rate(config.frame_rate, "frame rate")?;
    // A start inside an obstacle would throw the robot; one without a floor would drop it.
    let spawn = config.start.map_or(Spawn::Site, Spawn::Pose);
    place_robot(&mut world, spawn, config.seed)?;
    crate::world_check::require_floor(&world)?;
    let gl = EglContext::new()?;
    let mut camera = world.make_camera(&config.sensor, config.seed, &gl)?;
    let mut writer = DatasetWriter::create(&config.out, config.sensor.max_range, config.overwrite)?;
    if let Some(labels) = camera.labels() {
        writer.write_labels(std::sync::Arc::clone(labels))?;
    }
    let mut rerun = RerunLog::open(
        &config.rerun,
        &format!("record {} {}", config.world.display(), config.controls),
    )?;
    if let (Some(log), Some(labels)) = (&mut rerun, camera.labels()) {
        log.labels(std::sync::Arc::clone(labels))?;
    }
    let mut path = Vec::new();

    let timestep = world.model().timestep();
    let steps = (config.duration / timestep).round() as u64;
    let frame_period = 1.0 / config.frame_rate;
    let mut next_frame = 0.0;
    let mut collision_steps = 0;
    let mut frame = camera.blank_frame();
    for step in 0..=steps {
        // Capture at the frame times, then act on the schedule for the next step.
        let time = world.data().time();
        if time + 0.5 * timestep >= next_frame {
            camera.capture_into(world.data(), &mut frame)?;
            writer.write_frame(&frame)?;
            if let Some(log) = &rerun {
                path.push(world.pose());
                log.at(time);
                log.frame(
                    &frame.camera,
                    &frame.rgb,
                    &frame.depth,
                    &frame.instance,
                    &path,
                )?;
            }
            next_frame += frame_period;
            on_progress(time);
        }
        if step == steps {
            break;
        }
        world.step(schedule.at(time))?;
        if world.robot_collisions().next().is_some() {
            collision_steps += 1;
        }
    }
    let final_pose = world.pose();
    let frames = writer.frame_count();
    // The dataset is put in place before the recording is flushed: a viewer that went away
    // must not strand a complete dataset in its staging folder.
    let out = writer.finish(
        &EpisodeFile {
            command: "record",
            config,
            versions: Versions::current(&gl),
            timestep,
            frames,
            collision_steps,
            final_pose,
        },
        false,
    )?;
    if let Some(log) = rerun {
        log.finish()?;
    }
    Ok(RecordSummary {
        out,
        frames,
        collision_steps,
        final_pose,
    })
}
