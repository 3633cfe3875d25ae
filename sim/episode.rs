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
use crate::record::Versions;
use crate::robot::{Pose2, UnicycleCommand};
use crate::spawn::{place_robot, Spawn};
use crate::survey::{plan_survey, SurveyConfig, SurveyDriver};
use crate::world::World;
use autonomy::mapping::{Frame, Mapper, MapperConfig};
use autonomy::planner::unicycle::State;
use autonomy::planner::{CollisionEngine, PlanFailure, PlannerConfig, Recovery, RtGuidePlanner};
use autonomy::splat::{EngineChoice, Rasteriser};
use serde::Serialize;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

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

/// Which planner drives the robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PlannerKind {
    /// RT-GuIDE: information-driven, on the map alone.
    RtGuide,
    /// The ground-truth lawn-mower survey: knows the world, the upper bound.
    Survey,
}

impl PlannerKind {
    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            PlannerKind::RtGuide => "rtguide",
            PlannerKind::Survey => "survey",
        }
    }
}

impl std::str::FromStr for PlannerKind {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "rtguide" => Ok(PlannerKind::RtGuide),
            "survey" => Ok(PlannerKind::Survey),
            "frontier" | "fisher" => Err(format!(
                "planner {s:?} is not built yet; use rtguide or survey"
            )),
            other => Err(format!("unknown planner {other:?}; use rtguide or survey")),
        }
    }
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
    /// Metres the robot's base drove (its origin on the floor, summed every physics step).
    pub path_length: f64,
    /// Metres the camera moved from frame to frame: the length of groundtruth.txt's positions,
    /// which is what trajectory tools (evo) report; longer than the base's when it turns, the
    /// camera sitting 0.2 m ahead of the axle.
    pub camera_path_length: f64,
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
    /// Wall time of a camera frame: render, read back, write the PNGs.
    pub camera: StageTime,
    /// Wall time of a physics step (drive controller included).
    pub physics: StageTime,
    /// The splat engine used.
    pub engine: String,
    /// Why the episode ended: "budget", "survey complete", or "stuck: ...".
    pub ended: String,
    /// Peak resident memory of the process (VmHWM), bytes; 0 where the OS does not say.
    pub peak_memory_bytes: u64,
    /// The map on hidden test views.
    pub evaluation: crate::evaluate::Evaluation,
}

#[derive(Serialize)]
struct EpisodeFile<'a> {
    command: &'static str,
    config: &'a RunConfig,
    versions: Versions,
    /// The start pose actually used (`config.spawn` says how it was chosen).
    start_pose: Pose2,
    final_pose: Pose2,
}

/// A (v, w) schedule: controls of `period` seconds each from `start`.
#[derive(Debug, Clone)]
struct Schedule {
    start: f64,
    period: f64,
    controls: Vec<UnicycleCommand>,
    /// A recovery manoeuvre: it runs to its end before the planner is asked again.
    recovery: bool,
}

impl Schedule {
    fn idle(start: f64) -> Self {
        Schedule {
            start,
            period: 1.0,
            controls: Vec::new(),
            recovery: false,
        }
    }

    /// When the last control ends.
    fn end(&self) -> f64 {
        self.start + self.period * self.controls.len() as f64
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
        recovery: true,
    }
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

/// Recoveries that did not get the robot out: ends an episode whose robot is boxed in.
#[derive(Debug)]
struct StuckWatch {
    anchor: (f64, Pose2),
    recoveries: usize,
}

impl StuckWatch {
    /// Distance the robot must get from where it was to count as free, metres.
    const ESCAPE: f64 = 0.3;
    /// Recoveries and simulated seconds without escaping before the episode ends.
    const RECOVERIES: usize = 5;
    const SECONDS: f64 = 45.0;

    fn new(pose: Pose2) -> Self {
        StuckWatch {
            anchor: (0.0, pose),
            recoveries: 0,
        }
    }

    /// Notes the pose (and whether a recovery was started) at a think; returns the reason to
    /// give up when the robot is boxed in.
    fn update(&mut self, time: f64, pose: Pose2, recovered: bool) -> Option<String> {
        let (t0, p0) = self.anchor;
        if (pose.x - p0.x).hypot(pose.y - p0.y) > Self::ESCAPE {
            self.anchor = (time, pose);
            self.recoveries = 0;
            return None;
        }
        self.recoveries += usize::from(recovered);
        (self.recoveries >= Self::RECOVERIES && time - t0 >= Self::SECONDS).then(|| {
            format!(
                "stuck: {} recoveries in {:.0} s left the robot within {} m of ({:.2}, {:.2}), so \
                 the episode ended early. The robot is boxed in, or the planner finds no way out; \
                 check the world around that point",
                self.recoveries,
                time - t0,
                Self::ESCAPE,
                p0.x,
                p0.y
            )
        })
    }
}

/// Where the unicycle model puts the robot after following `schedule` from `pose` at `time`
/// for `lead` seconds: the pose a plan that starts after the compute delay must start from.
fn predict(pose: Pose2, schedule: &Schedule, time: f64, lead: f64) -> State {
    let mut state = State {
        x: pose.x,
        y: pose.y,
        theta: pose.theta,
    };
    let dt: f64 = 0.02;
    let mut t = 0.0;
    while t < lead {
        let step = dt.min(lead - t);
        let u = schedule.at(time + t);
        state = autonomy::planner::unicycle::advance(
            &state,
            &autonomy::planner::unicycle::Control { v: u.v, w: u.w },
            step,
        );
        t += step;
    }
    state
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
    let mut survey = match config.planner {
        PlannerKind::Survey => Some(SurveyDriver::new(plan_survey(
            &world,
            &SurveyConfig::default(),
        )?)),
        PlannerKind::RtGuide => None,
    };
    // The hidden test set, fixed before the episode so coverage can be reported as it grows.
    let tests = TestSet::sample(
        &world,
        &camera,
        config.test_views,
        test_seed(config.seed),
        config.sensor.max_range,
    )?;

    let timestep = world.model().timestep();
    let steps = (config.budget / timestep).round() as u64;
    let frame_period = 1.0 / config.camera_rate;
    let (mut next_frame, mut next_think, mut next_coverage) = (0.0, 0.0, 0.0);
    let mut coverage = None;
    let mut frame = camera.blank_frame();
    let mut have_frame = false;
    let mut current = Schedule::idle(0.0);
    let mut pending: Option<Schedule> = None;
    let (mut mapping_times, mut planning_times) = (Vec::new(), Vec::new());
    let (mut camera_times, mut physics_times) = (Vec::new(), Vec::new());
    let mut failures = std::collections::BTreeMap::new();
    let (mut collision_steps, mut recovery_events, mut path_length) = (0, 0, 0.0);
    let (mut camera_path_length, mut last_camera) = (0.0, None::<nalgebra::Vector3<f64>>);
    let mut last_pose = world.pose();
    // The path for trajectory.png: a pose every 50 physics steps (0.1 s at 2 ms).
    let mut path = vec![last_pose];
    let mut progress_check = (0.0, last_pose);
    let mut stuck = StuckWatch::new(last_pose);
    let mut recent_delays = std::collections::VecDeque::from([0.0f64]);
    let mut ended = String::from("budget");
    let mut last_touch = f64::NEG_INFINITY;
    // The tick loop; an error ends it like a signal does, and the episode is still written.
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
            if time + 0.5 * timestep >= next_frame {
                let t0 = Instant::now();
                camera.capture_into(world.data(), &mut frame)?;
                writer.write_frame(&frame)?;
                let at = frame.camera.world_from_camera.translation.vector;
                if let Some(previous) = last_camera {
                    camera_path_length += (at - previous).norm();
                }
                last_camera = Some(at);
                camera_times.push(t0.elapsed().as_secs_f64());
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
                mapping_times.push((t1 - t0).as_secs_f64());
                // A recovery manoeuvre runs to its end: replanning every second would cut a
                // back-off's turn short and start it again, and the robot would never get out.
                let recovering = {
                    let active = pending.as_ref().unwrap_or(&current);
                    active.recovery && time + 0.5 * timestep < active.end()
                };
                if survey.is_none() && !recovering {
                    // With wall latency the new schedule starts after the compute delay, so it is
                    // planned from where the current one will have taken the robot by then; the
                    // delay is estimated by the slowest of the last three thinks.
                    let lead = match config.latency {
                        Latency::Wall => recent_delays.iter().copied().fold(0.0, f64::max),
                        Latency::None => 0.0,
                    };
                    let active = pending.as_ref().unwrap_or(&current);
                    let robot = predict(pose, active, time, lead);
                    // No progress for 10 s: back off and replan.
                    let no_progress = time - progress_check.0 >= 10.0
                        && (pose.x - progress_check.1.x).hypot(pose.y - progress_check.1.y) < 0.2;
                    let plan = if no_progress {
                        Err(None)
                    } else {
                        planner.plan(mapper.map(), robot).map_err(Some)
                    };
                    let t2 = Instant::now();
                    planning_times.push((t2 - t1).as_secs_f64());
                    let start = match config.latency {
                        Latency::Wall => {
                            let delay = (t2 - t0).as_secs_f64();
                            recent_delays.push_back(delay);
                            if recent_delays.len() > 3 {
                                recent_delays.pop_front();
                            }
                            time + delay.max(lead)
                        }
                        Latency::None => time,
                    };
                    if let Ok(p) = &plan {
                        tracing::debug!(
                            "t = {time:.1} s at ({:.2}, {:.2}): goal ({:.2}, {:.2}), guidance {:.2?}, {} candidates, xi {}, controls {:?}",
                            robot.x, robot.y, p.local_goal[0], p.local_goal[1], p.guidance, p.candidates, p.information, p.controls
                        );
                    }
                    let recovered = plan.is_err();
                    let schedule = match plan {
                        Ok(p) => Schedule {
                            start,
                            period: 1.0,
                            recovery: false,
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
                                failure.as_ref().map_or(
                                    "no progress for 10 s".to_owned(),
                                    PlanFailure::to_string
                                )
                            );
                            *failures.entry(name).or_insert(0) += 1;
                            progress_check = (time, pose);
                            recovery_schedule(kind, start, robot.theta, away)
                        }
                    };
                    if time - progress_check.0 >= 10.0 {
                        progress_check = (time, pose);
                    }
                    pending = Some(schedule);
                    if let Some(reason) = stuck.update(time, pose, recovered) {
                        tracing::warn!("t = {time:.1} s: {reason}");
                        ended = reason;
                        break;
                    }
                }
                if !tests.surface.is_empty() && time + 0.5 * timestep >= next_coverage {
                    next_coverage += 10.0;
                    coverage = Some(autonomy::metrics::coverage(
                        &tests.surface,
                        &mapper.map().gaussians.means,
                        crate::evaluate::COVERAGE_RADIUS,
                    ));
                }
                on_progress(Progress {
                    time,
                    gaussians: mapper.map().len(),
                    coverage,
                });
            }
            let command = match survey.as_mut() {
                Some(driver) => {
                    let command = driver.command(world.pose());
                    if driver.remaining() == 0 {
                        ended = String::from("survey complete");
                        break;
                    }
                    command
                }
                None => current.at(time),
            };
            let t0 = Instant::now();
            world.step(command)?;
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
        recovery_events,
        plan_failures: failures,
        gaussians: mapper.map().len(),
        frames: writer.frame_count(),
        mapping_steps: mapper.steps(),
        mapping: stage(mapping_times),
        planning: stage(planning_times),
        camera: stage(camera_times),
        physics: stage(physics_times),
        engine: engine_name,
        ended,
        peak_memory_bytes: peak_memory_bytes(),
        evaluation,
    };
    crate::dataset::write_json(&writer.dir().join("metrics.json"), &metrics)?;
    writer.finish(&EpisodeFile {
        command: "run",
        config,
        versions: Versions::current(&gl),
        start_pose,
        final_pose,
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
