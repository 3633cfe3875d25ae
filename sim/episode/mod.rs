//! `splatloop run`: the closed loop of DESIGN.md's tick. Physics every step, the drive
//! controller every step, the camera at its rate, and every mapping period the mapper takes
//! the newest frame and the planner a new (v, w) schedule, which the robot follows until the
//! next plan. With `Latency::Wall` the compute time of mapping and planning is charged to
//! simulated time: the previous schedule keeps running meanwhile, as on a robot.

use crate::camera::SensorConfig;
use crate::dataset::DatasetWriter;
use crate::egl::EglContext;
use crate::error::{Result, SimError};
use crate::evaluate::{evaluate, TestSet};
use crate::planners::{self, PlannerContext};
use crate::record::Versions;
use crate::rerun_log::{RerunLog, RerunTarget};
use crate::robot::Pose2;
use crate::spawn::{place_robot, Spawn};
use crate::world::World;
use autonomy::explore::{Decision, Observation};
use autonomy::mapping::{Frame, Mapper, MapperConfig};
use autonomy::splat::{EngineChoice, Rasteriser};
use serde::Serialize;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

mod control;
mod metrics;

pub use crate::planners::{PlannerKind, PlannerOptions};
use control::{Controller, ThinkTime, Verdict};
pub use metrics::{percentiles, Metrics, Percentiles};

/// The map's means as a coloured point cloud, which transforms.json names for nerfstudio.
pub const POINT_CLOUD: &str = "points.ply";

/// How compute time relates to simulated time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Latency {
    /// The robot keeps executing its previous plan while the autonomy thinks.
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
    /// The planner.
    pub planner: PlannerKind,
    /// The planners' own settings.
    pub planner_options: PlannerOptions,
    /// The camera.
    pub sensor: SensorConfig,
    /// Hidden test views sampled in free space for the evaluation (0: none).
    pub test_views: usize,
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

/// What the progress callback hears after each mapping step.
#[derive(Debug, Clone, Copy)]
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

/// Runs an episode; `on_progress` is called after each mapping step.
pub fn run_episode(config: &RunConfig, on_progress: &mut dyn FnMut(Progress)) -> Result<Metrics> {
    for (what, v) in [
        ("budget", config.budget),
        ("camera rate", config.camera_rate),
        ("think period", config.think_period),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(SimError::InvalidArgument {
                what,
                detail: format!("{v}; give a positive number"),
            });
        }
    }
    config.sensor.validate()?;
    config.rerun.check(&config.out, config.overwrite)?;
    let wall = Instant::now();
    let mut world = World::load(&config.world, &config.sensor)?;
    world.check_frame_rate(config.camera_rate, "camera rate")?;
    let start_pose = place_robot(&mut world, config.spawn, config.seed)?;
    crate::world_check::require_floor(&world)?;
    let gl = EglContext::new()?;
    let mut camera = world.make_camera(&config.sensor, config.seed, &gl)?;
    let mut writer = DatasetWriter::create(&config.out, config.sensor.max_range, config.overwrite)?;
    if let Some(frames) = config.fail_writes_after {
        writer.fail_writes_after(frames);
    }
    writer.name_point_cloud(POINT_CLOUD);
    let mut rerun = RerunLog::open(
        &config.rerun,
        &format!(
            "run {} {} seed {}",
            config.world.display(),
            config.planner.name(),
            config.seed
        ),
    )?;
    let engine = Rasteriser::select(config.engine);
    let engine_name = engine.describe();
    let mapper_config = MapperConfig {
        iterations: config.iterations,
        uncertainty: config.planner_options.rtguide_uncertainty,
        ..MapperConfig::default()
    };
    let settled_omega = autonomy::planner::settled_omega(
        mapper_config.iterations,
        f64::from(mapper_config.rates.means),
    );
    let mut mapper = Mapper::new(mapper_config, engine);
    let mut planner = planners::build(
        config.planner,
        &config.planner_options,
        &world,
        PlannerContext {
            intrinsics: *camera.intrinsics(),
            range: config.sensor.max_range,
            seed: config.seed,
            period: config.think_period,
            settled_omega,
        },
    )?;
    let planner_settings = planner.settings();
    // The hidden test set, fixed before the episode so coverage can be reported as it grows.
    let tests = TestSet::sample(
        &world,
        &camera,
        config.test_views,
        test_seed(config.seed),
        config.sensor.max_range,
    )?;

    let timestep = world.model().timestep();
    // Events due within half a step of now happen now.
    let due = |time: f64, at: f64| time + 0.5 * timestep >= at;
    let steps = (config.budget / timestep).round() as u64;
    let frame_period = 1.0 / config.camera_rate;
    let (mut next_frame, mut next_think, mut next_coverage) = (0.0, 0.0, 0.0);
    let mut coverage = None;
    let mut coverage_over_time = Vec::new();
    let mut frame = camera.blank_frame();
    let mut have_frame = false;
    let mut last_pose = world.pose();
    let mut control = Controller::new(last_pose, config.latency, world.robot().limits);
    let (mut mapping_times, mut planning_times) = (Vec::new(), Vec::new());
    let (mut camera_times, mut physics_times) = (Vec::new(), Vec::new());
    let (mut collision_steps, mut path_length) = (0, 0.0);
    let (mut camera_path_length, mut last_camera) = (0.0, None::<nalgebra::Vector3<f64>>);
    // The path for trajectory.png: a pose every 50 physics steps (0.1 s at 2 ms).
    let mut path = vec![last_pose];
    let mut ended = String::from("budget");
    let mut last_touch = f64::NEG_INFINITY;
    // The tick loop: capture, write, think, apply. An error ends it like a signal does, and
    // the episode is still written.
    let outcome: Result<()> = (|| {
        for step in 0..steps {
            if let Some(signal) = config.stop.requested() {
                ended = format!(
                    "interrupted at t = {:.1} s by {}",
                    world.data().time(),
                    StopRequest::signal_name(signal)
                );
                break;
            }
            let time = world.data().time();

            // Capture and write.
            if due(time, next_frame) {
                let t0 = Instant::now();
                camera.capture_into(world.data(), &mut frame)?;
                writer.write_frame(&frame)?;
                let at = frame.camera.world_from_camera.translation.vector;
                if let Some(previous) = last_camera {
                    camera_path_length += (at - previous).norm();
                }
                last_camera = Some(at);
                planner.observe(
                    &Observation {
                        depth: &frame.depth,
                        camera: &frame.camera,
                        max_range: config.sensor.max_range,
                        robot: world.pose(),
                    },
                    mapper.map(),
                );
                camera_times.push(t0.elapsed().as_secs_f64());
                if let Some(log) = &rerun {
                    log.at(time);
                    log.frame(&frame.camera, &frame.rgb, &frame.depth, &path)?;
                    log.scalar("timing/camera_ms", 1e3 * t0.elapsed().as_secs_f64())?;
                }
                have_frame = true;
                next_frame += frame_period;
            }
            control.advance(time + 0.5 * timestep, || world.pose());

            // Think: map the newest frame, then plan from where the robot will be.
            if have_frame && due(time, next_think) {
                next_think += config.think_period;
                let t0 = Instant::now();
                let observation = Frame::from_rgb8(&frame.rgb, frame.depth.clone());
                mapper
                    .integrate(
                        &observation,
                        &frame.camera.world_from_camera.to_homogeneous(),
                        &frame.camera.intrinsics,
                    )
                    .map_err(|e| SimError::Mapping(e.to_string()))?;
                let t1 = Instant::now();
                mapping_times.push((t1 - t0).as_secs_f64());
                if let Some(log) = &mut rerun {
                    log.at(time);
                    log.map(mapper.map())?;
                    log.scalar("timing/mapping_ms", 1e3 * (t1 - t0).as_secs_f64())?;
                    log.scalar("metrics/gaussians", mapper.map().len() as f64)?;
                }
                let pose = world.pose();
                control.observe(&pose);
                if !control.holding(time + 0.5 * timestep) {
                    let lead = control.lead((t1 - t0).as_secs_f64());
                    let start = control.start_pose(pose, time, lead);
                    let decision =
                        (!control.stalled(time, &pose)).then(|| planner.plan(mapper.map(), start));
                    let t2 = Instant::now();
                    planning_times.push((t2 - t1).as_secs_f64());
                    if let Some(log) = &rerun {
                        log.scalar("timing/planning_ms", 1e3 * (t2 - t1).as_secs_f64())?;
                        if let Some(Decision::Go(plan)) = &decision {
                            log.plan(&plan.alternatives, &plan.states)?;
                        }
                    }
                    let think = ThinkTime {
                        mapping: (t1 - t0).as_secs_f64(),
                        planning: (t2 - t1).as_secs_f64(),
                    };
                    if let Verdict::End(reason) =
                        control.take(decision, time, pose, start, think, lead)
                    {
                        ended = reason;
                        break;
                    }
                }
                if !tests.surface.is_empty() && due(time, next_coverage) {
                    next_coverage += 10.0;
                    let now = autonomy::metrics::coverage(
                        &tests.surface,
                        &mapper.map().gaussians.means,
                        crate::evaluate::COVERAGE_RADIUS,
                    );
                    coverage = Some(now);
                    coverage_over_time.push([time, now]);
                    if let Some(log) = &rerun {
                        log.scalar("metrics/coverage", now)?;
                    }
                }
                on_progress(Progress {
                    time,
                    gaussians: mapper.map().len(),
                    coverage,
                });
            }

            // Apply.
            let t0 = Instant::now();
            world.step(control.command(time))?;
            physics_times.push(t0.elapsed().as_secs_f64());
            if let Some(contact) = world.robot_collisions().next() {
                // One warning per contact episode: contacts flicker from step to step.
                if time - last_touch > 0.5 {
                    let name = world.touched_name(&contact);
                    tracing::warn!(
                        "t = {:.1} s: the robot touches {name} at ({:.2}, {:.2})",
                        time,
                        contact.position.x,
                        contact.position.y
                    );
                }
                last_touch = time;
                collision_steps += 1;
            }
            let pose = world.pose();
            path_length += (pose.x - last_pose.x).hypot(pose.y - last_pose.y);
            last_pose = pose;
            if (step + 1) % 50 == 0 {
                path.push(pose);
            }
        }
        Ok(())
    })();
    if let Err(e) = &outcome {
        ended = format!("error at t = {:.1} s: {}", world.data().time(), e.chain());
    }
    path.push(world.pose());
    crate::dataset::write_point_cloud(
        &writer.dir().join(POINT_CLOUD),
        &mapper.map().gaussians.means,
        &mapper.map().gaussians.colours,
    )?;
    autonomy::ply::write_with_sh_degree(
        mapper.map(),
        &writer.dir().join("map.ply"),
        config.ply_sh_degree,
    )
    .map_err(|e| SimError::Mapping(e.to_string()))?;
    let simulated = world.data().time();
    let final_pose = world.pose();
    let evaluation = evaluate(&world, &mut camera, mapper.engine(), mapper.map(), &tests)?;
    if !tests.surface.is_empty() {
        coverage_over_time.push([simulated, evaluation.coverage]);
    }
    let title = format!(
        "{} | {} | {:.0} of {:.0} s | coverage {:.1}% | PSNR {:.1} dB",
        config.world.file_name().map_or_else(
            || config.world.display().to_string(),
            |n| n.to_string_lossy().into_owned()
        ),
        config.planner.name(),
        simulated,
        config.budget,
        100.0 * evaluation.coverage,
        evaluation.psnr
    );
    crate::plot::write_trajectory_png(
        &writer.dir().join("trajectory.png"),
        &world,
        &path,
        mapper.map(),
        &title,
    )?;
    let wall_seconds = wall.elapsed().as_secs_f64();
    let metrics = Metrics {
        simulated_seconds: simulated,
        wall_seconds,
        real_time_factor: simulated / wall_seconds,
        path_length,
        camera_path_length,
        collision_steps,
        recovery_events: control.recovery_events,
        late_plans: control.late_plans,
        start_pose_error: percentiles(control.start_pose_errors.clone()),
        plan_failures: control.failures.clone(),
        gaussians: mapper.map().len(),
        frames: writer.frame_count(),
        mapping_steps: mapper.steps(),
        mapping: percentiles(mapping_times),
        planning: percentiles(planning_times),
        camera: percentiles(camera_times),
        physics: percentiles(physics_times),
        engine: engine_name,
        planner: config.planner.name(),
        planner_settings: planner_settings.clone(),
        ended,
        peak_memory_bytes: peak_memory_bytes(),
        evaluation,
        coverage_over_time,
    };
    if let Some(log) = rerun {
        log.at(simulated);
        log.scalar("metrics/coverage", metrics.evaluation.coverage)?;
        log.finish()?;
    }
    crate::dataset::write_json(&writer.dir().join("metrics.json"), &metrics)?;
    writer.finish(&EpisodeFile {
        command: "run",
        config,
        versions: Versions::current(&gl),
        start_pose,
        final_pose,
        planner_settings,
    })?;
    // Written in full; the tick loop's own error, if any, is still the run's result.
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
