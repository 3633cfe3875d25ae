//! `splatloop run`: the closed loop of DESIGN.md's tick. Physics every step, the drive
//! controller every step, the camera at its rate, and every mapping period the mapper takes
//! the newest frame and the planner a new (v, w) schedule, which the robot follows until the
//! next plan. With `Latency::Wall` the compute time of mapping and planning is charged to
//! simulated time: the previous schedule keeps running meanwhile, as on a robot.

use crate::camera::SensorConfig;
use crate::dataset::DatasetWriter;
use crate::egl::EglContext;
use crate::error::{Result, SimError};
use crate::record::Versions;
use crate::robot::{Pose2, UnicycleCommand};
use crate::world::World;
use autonomy::mapping::{Frame, Mapper, MapperConfig};
use autonomy::planner::unicycle::State;
use autonomy::planner::{CollisionEngine, PlanFailure, PlannerConfig, Recovery, RtGuidePlanner};
use autonomy::splat::{EngineChoice, Rasteriser};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

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
    /// The camera.
    pub sensor: SensorConfig,
    /// Hidden test views sampled in free space for the evaluation (0: none).
    pub test_views: usize,
    /// Splat engine asked for.
    #[serde(skip)]
    pub engine: EngineChoice,
    /// Replace an earlier episode in `out`.
    #[serde(skip)]
    pub overwrite: bool,
    /// Episode folder.
    #[serde(skip)]
    pub out: PathBuf,
}

/// Median and 95th percentile of a stage's wall seconds.
#[derive(Debug, Clone, Copy, Serialize, Default)]
pub struct StageTime {
    /// Median, seconds.
    pub median: f64,
    /// 95th percentile, seconds.
    pub p95: f64,
}

fn stage(mut v: Vec<f64>) -> StageTime {
    if v.is_empty() {
        return StageTime::default();
    }
    v.sort_by(f64::total_cmp);
    StageTime {
        median: v[v.len() / 2],
        p95: v[((v.len() as f64 * 0.95).ceil() as usize).clamp(1, v.len()) - 1],
    }
}

/// What an episode measured (metrics.json).
#[derive(Debug, Clone, Serialize)]
pub struct Metrics {
    /// Simulated seconds.
    pub simulated_seconds: f64,
    /// Wall seconds of the whole run.
    pub wall_seconds: f64,
    /// Simulated seconds per wall second.
    pub real_time_factor: f64,
    /// Metres driven.
    pub path_length: f64,
    /// Physics steps with a robot-world contact (floor excluded).
    pub collision_steps: usize,
    /// Recovery events (turn in place after a planner failure, back off after no progress).
    pub recovery_events: usize,
    /// Planner failures by kind.
    pub plan_failures: std::collections::BTreeMap<String, usize>,
    /// Gaussians in the final map.
    pub gaussians: usize,
    /// Camera frames written.
    pub frames: usize,
    /// Mapping steps.
    pub mapping_steps: usize,
    /// Wall time of a mapping step.
    pub mapping: StageTime,
    /// Wall time of a plan.
    pub planning: StageTime,
    /// The splat engine used.
    pub engine: String,
    /// The map on hidden test views.
    pub evaluation: crate::evaluate::Evaluation,
}

#[derive(Serialize)]
struct EpisodeFile<'a> {
    command: &'static str,
    config: &'a RunConfig,
    versions: Versions,
    final_pose: Pose2,
}

/// A (v, w) schedule: controls of `period` seconds each from `start`.
#[derive(Debug, Clone)]
struct Schedule {
    start: f64,
    period: f64,
    controls: Vec<UnicycleCommand>,
}

impl Schedule {
    fn idle(start: f64) -> Self {
        Schedule {
            start,
            period: 1.0,
            controls: Vec::new(),
        }
    }

    fn at(&self, t: f64) -> UnicycleCommand {
        let k = ((t - self.start) / self.period).floor();
        if k < 0.0 {
            return UnicycleCommand { v: 0.0, w: 0.0 };
        }
        self.controls
            .get(k as usize)
            .copied()
            .unwrap_or(UnicycleCommand { v: 0.0, w: 0.0 })
    }
}

/// The recovery manoeuvres: a look around (turn in place for 3 s) or a back-off. The unicycle
/// cannot reverse, so backing off turns in place to `away` (half round when not known) and
/// drives 0.15 m that way. Steps of 0.1 s.
fn recovery_schedule(kind: Recovery, start: f64, heading: f64, away: Option<f64>) -> Schedule {
    let tick = 0.1;
    let turn_rate = 0.9;
    let controls = match kind {
        Recovery::TurnInPlace => vec![
            UnicycleCommand {
                v: 0.0,
                w: turn_rate
            };
            30
        ],
        Recovery::BackOff => {
            let target = away.unwrap_or(heading + std::f64::consts::PI);
            let diff = (target - heading + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            let turn_ticks = (diff.abs() / turn_rate / tick).round() as usize;
            let mut c = vec![
                UnicycleCommand {
                    v: 0.0,
                    w: turn_rate * diff.signum()
                };
                turn_ticks
            ];
            c.extend(vec![UnicycleCommand { v: 0.3, w: 0.0 }; 5]);
            c
        }
    };
    Schedule {
        start,
        period: tick,
        controls,
    }
}

/// Runs an episode; `on_progress(sim_time, gaussians)` is called after each mapping step.
pub fn run_episode(config: &RunConfig, on_progress: &mut dyn FnMut(f64, usize)) -> Result<Metrics> {
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
    let wall = Instant::now();
    let mut world = World::load(&config.world, &config.sensor)?;
    let gl = EglContext::new()?;
    let mut camera = world.make_camera(&config.sensor, config.seed, &gl)?;
    let mut writer = DatasetWriter::create(&config.out, config.sensor.max_range, config.overwrite)?;
    let engine = Rasteriser::select(config.engine);
    let engine_name = engine.describe();
    let mut mapper = Mapper::new(
        MapperConfig {
            iterations: config.iterations,
            ..MapperConfig::default()
        },
        engine,
    );
    let mut planner_config = PlannerConfig::default();
    planner_config.mount.intrinsics = *camera.intrinsics();
    planner_config.mount.range = config.sensor.max_range;
    let mut planner = RtGuidePlanner::new(planner_config, CollisionEngine::Grid);

    let timestep = world.model().timestep();
    let steps = (config.budget / timestep).round() as u64;
    let frame_period = 1.0 / config.camera_rate;
    let (mut next_frame, mut next_think) = (0.0, 0.0);
    let mut frame = camera.blank_frame();
    let mut have_frame = false;
    let mut current = Schedule::idle(0.0);
    let mut pending: Option<Schedule> = None;
    let (mut mapping_times, mut planning_times) = (Vec::new(), Vec::new());
    let mut failures = std::collections::BTreeMap::new();
    let (mut collision_steps, mut recovery_events, mut path_length) = (0, 0, 0.0);
    let mut last_pose = world.pose();
    let mut progress_check = (0.0, last_pose);
    for _ in 0..steps {
        let time = world.data().time();
        if time + 0.5 * timestep >= next_frame {
            camera.capture_into(world.data(), &mut frame)?;
            writer.write_frame(&frame)?;
            have_frame = true;
            next_frame += frame_period;
        }
        if let Some(p) = pending.take() {
            if time + 0.5 * timestep >= p.start {
                current = p;
            } else {
                pending = Some(p);
            }
        }
        if have_frame && time + 0.5 * timestep >= next_think {
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
            let pose = world.pose();
            let robot = State {
                x: pose.x,
                y: pose.y,
                theta: pose.theta,
            };
            // No progress for 10 s: back off and replan.
            let stuck = time - progress_check.0 >= 10.0
                && ((pose.x - progress_check.1.x).powi(2) + (pose.y - progress_check.1.y).powi(2))
                    .sqrt()
                    < 0.2;
            let plan = if stuck {
                Err(None)
            } else {
                planner.plan(mapper.map(), robot).map_err(Some)
            };
            let t2 = Instant::now();
            mapping_times.push((t1 - t0).as_secs_f64());
            planning_times.push((t2 - t1).as_secs_f64());
            let delay = match config.latency {
                Latency::Wall => (t2 - t0).as_secs_f64(),
                Latency::None => 0.0,
            };
            let start = time + delay;
            if let Ok(p) = &plan {
                tracing::debug!(
                    "t = {time:.1} s at ({:.2}, {:.2}): goal ({:.2}, {:.2}), {} candidates, xi {}, controls {:?}",
                    pose.x, pose.y, p.local_goal[0], p.local_goal[1], p.candidates, p.information, p.controls
                );
            }
            let schedule = match plan {
                Ok(p) => Schedule {
                    start,
                    period: 1.0,
                    controls: p
                        .controls
                        .iter()
                        .map(|u| UnicycleCommand { v: u.v, w: u.w })
                        .collect(),
                },
                Err(failure) => {
                    recovery_events += 1;
                    let (name, kind, away) = match &failure {
                        Some(PlanFailure::StartInCollision { away }) => (
                            "StartInCollision".to_owned(),
                            Recovery::BackOff,
                            Some(*away),
                        ),
                        Some(f) => (format!("{f:?}"), f.recovery(), None),
                        None => ("NoProgress".to_owned(), Recovery::BackOff, None),
                    };
                    tracing::info!(
                        "t = {time:.1} s: {} -> recovery {kind:?}",
                        failure
                            .as_ref()
                            .map_or("no progress for 10 s".to_owned(), PlanFailure::to_string)
                    );
                    *failures.entry(name).or_insert(0) += 1;
                    progress_check = (time, pose);
                    recovery_schedule(kind, start, pose.theta, away)
                }
            };
            if time - progress_check.0 >= 10.0 {
                progress_check = (time, pose);
            }
            pending = Some(schedule);
            on_progress(time, mapper.map().len());
        }
        world.step(current.at(time))?;
        if world.robot_collisions().next().is_some() {
            collision_steps += 1;
        }
        let pose = world.pose();
        path_length += ((pose.x - last_pose.x).powi(2) + (pose.y - last_pose.y).powi(2)).sqrt();
        last_pose = pose;
    }
    autonomy::ply::write(mapper.map(), &config.out.join("map.ply"))
        .map_err(|e| SimError::Mapping(e.to_string()))?;
    let simulated = world.data().time();
    let final_pose = world.pose();
    // Evaluate last: it moves the robot to each test pose.
    let poses = crate::evaluate::sample_test_poses(
        &world,
        [-15.0, -15.0],
        [15.0, 15.0],
        config.test_views,
        config.seed ^ 0x7e57,
    );
    let evaluation = crate::evaluate::evaluate(
        &mut world,
        &mut camera,
        mapper.engine(),
        mapper.map(),
        &poses,
    )?;
    let wall_seconds = wall.elapsed().as_secs_f64();
    let metrics = Metrics {
        simulated_seconds: simulated,
        wall_seconds,
        real_time_factor: simulated / wall_seconds,
        path_length,
        collision_steps,
        recovery_events,
        plan_failures: failures,
        gaussians: mapper.map().len(),
        frames: writer.frame_count(),
        mapping_steps: mapper.steps(),
        mapping: stage(mapping_times),
        planning: stage(planning_times),
        engine: engine_name,
        evaluation,
    };
    crate::dataset::write_json(&config.out.join("metrics.json"), &metrics)?;
    writer.finish(&EpisodeFile {
        command: "run",
        config,
        versions: Versions::current(&gl),
        final_pose,
    })?;
    Ok(metrics)
}
