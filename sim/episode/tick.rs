//! [`Episode`]: one closed-loop episode that a caller steps a think period at a time. A tick
//! is one physics step and runs these stages, each its own timed function:
//!
//! 1. `begin_tick`: the budget and a stop request end the episode; `capture` takes a frame
//!    when one is due (the listeners write and record it, the planner looks at it); the
//!    controller starts a schedule whose time has come.
//! 2. `think`, once per think period: `map_frame` integrates the newest frame, then the
//!    caller's command (`apply`), a holding recovery, or `plan` (the planner's decision turned
//!    into a schedule or a recovery by the controller) decides what the robot drives;
//!    `measure_coverage` every 10 simulated seconds.
//! 3. `physics`: one MuJoCo step under the controller's command; contacts and the path.

use super::control::{Controller, ThinkTime, Verdict};
use super::listen::{Listeners, TickEvent, TickListener};
use super::tally::Tally;
use super::{test_seed, Progress, RunConfig, StopRequest, POINT_CLOUD};
use crate::camera::{RgbdCamera, RgbdFrame, SensorConfig};
use crate::dataset::DatasetWriter;
use crate::egl::EglContext;
use crate::error::{Result, SimError};
use crate::evaluate::{TestSet, TruthViews, PSNR_OVER_TIME_VIEWS};
use crate::planners::{self, PlannerChoice, PlannerContext, PlannerKind};
use crate::rerun_log::RerunLog;
use crate::robot::{Pose2, UnicycleCommand};
use crate::spawn::place_robot;
use crate::world::World;
use autonomy::explore::schedule::Schedule;
use autonomy::explore::{Decision, Observation, Planner};
use autonomy::map::GaussianMap;
use autonomy::mapping::{Frame, Mapper, MapperConfig};
use autonomy::splat::Rasteriser;
use std::time::Instant;

/// Builds a caller's planner once the episode knows its camera.
type MakePlanner<'a> = Box<dyn FnOnce(&PlannerContext) -> Result<Box<dyn Planner>> + 'a>;

/// Simulated seconds between coverage measurements during an episode.
const COVERAGE_PERIOD: f64 = 10.0;

/// One closed-loop episode: built by [`Episode::new`], advanced one think period at a time by
/// [`Episode::step`], written by [`Episode::finish`]. Dropped without `finish`, its folder
/// stays in its hidden staging place as after a crash.
pub struct Episode {
    pub(super) config: RunConfig,
    pub(super) wall: Instant,
    // Fields drop in order: the camera's GL objects before the context that owns them.
    pub(super) camera: RgbdCamera,
    pub(super) gl: EglContext,
    pub(super) world: World,
    pub(super) listeners: Listeners,
    pub(super) mapper: Mapper,
    pub(super) planner: Box<dyn Planner>,
    pub(super) planner_settings: serde_json::Value,
    /// The planner's name for metrics.json and the picture's title.
    pub(super) planner_name: String,
    /// What the planner was built with (and advisors are).
    context: PlannerContext,
    /// Built-in planners that watch every frame beside the episode's own, so a caller can ask
    /// what they would do ([`Episode::consult`]); they never drive.
    advisors: Vec<(PlannerKind, Box<dyn Planner>)>,
    pub(super) engine_name: String,
    pub(super) tests: TestSet,
    pub(super) start_pose: Pose2,
    clock: Clock,
    frame: RgbdFrame,
    have_frame: bool,
    pub(super) control: Controller,
    pub(super) tally: Tally,
    coverage: Option<f64>,
    pub(super) coverage_over_time: Vec<[f64; 2]>,
    /// A few test views' ground truth, for `psnr_over_time`.
    pub(super) truth_views: TruthViews,
    /// The map's PSNR on `truth_views` at the instants of `coverage_over_time`.
    pub(super) psnr_over_time: Vec<[f64; 2]>,
    caller_command: Option<UnicycleCommand>,
    /// When the planner said it was done, and why: from then on the robot holds still and
    /// the mapper keeps its schedule until the budget (unless `stop_when_done`).
    pub(super) done: Option<(f64, String)>,
    pub(super) ended: Option<String>,
    /// The current tick's first half (stop check, capture) ran; its think and physics not yet.
    mid_tick: bool,
}

/// When things are due, in physics steps and simulated seconds.
#[derive(Debug, Clone)]
struct Clock {
    timestep: f64,
    /// Physics steps in the budget.
    steps: u64,
    /// Physics steps taken.
    step: u64,
    frame_period: f64,
    next_frame: f64,
    next_think: f64,
    next_coverage: f64,
}

impl Clock {
    /// Events due within half a step of now happen now.
    fn due(&self, time: f64, at: f64) -> bool {
        time + 0.5 * self.timestep >= at
    }
}

/// What one think period did, as [`Episode::step`] reports it.
#[derive(Debug, Clone, PartialEq)]
pub enum Think {
    /// The planner decided.
    Planned(Decision),
    /// The progress watch overruled the planner (no progress for a while): a back-off.
    Overruled,
    /// A recovery or look-around still ran; nobody was asked.
    Holding,
    /// The caller's command ([`Episode::apply`]) was driven.
    Driven(UnicycleCommand),
    /// The planner is done: the robot holds still while the mapper goes on.
    Idle,
}

/// What happened in one [`Episode::step`].
#[derive(Debug, Clone, PartialEq)]
pub struct StepReport {
    /// Simulated seconds at the end of the step.
    pub time: f64,
    /// The robot's pose then.
    pub pose: Pose2,
    /// Frames the camera took during the step.
    pub frames: usize,
    /// What the period's think did; `None` when the episode ended before one.
    pub think: Option<Think>,
    /// Physics steps of the period with the robot touching something.
    pub collision_steps: usize,
    /// Gaussians in the map.
    pub gaussians: usize,
    /// Progress after the think, when one completed (what a progress bar shows).
    pub progress: Option<Progress>,
    /// Why the episode ended, once it has (then `finish` writes it).
    pub ended: Option<String>,
}

impl Episode {
    /// Loads the world, places the robot, opens the camera, the episode folder, the recording,
    /// the mapper and the planner, and samples the hidden test set; nothing is stepped yet.
    pub fn new(config: &RunConfig) -> Result<Episode> {
        Self::build(config, None)
    }

    /// An episode driven by the planner `make` builds, once the episode knows its camera,
    /// instead of the built-in one `config.planner` names (a caller's own, e.g. one written in
    /// Python): the same tick, the same executor rules for its decisions, its own name in
    /// metrics.json.
    pub fn with_planner(
        config: &RunConfig,
        make: impl FnOnce(&PlannerContext) -> Result<Box<dyn Planner>>,
    ) -> Result<Episode> {
        Self::build(config, Some(Box::new(make)))
    }

    fn build(config: &RunConfig, make: Option<MakePlanner<'_>>) -> Result<Episode> {
        config.validate()?;
        config.rerun.check(&config.out, config.overwrite)?;
        let wall = Instant::now();
        let mut world = World::load(&config.world, &config.sensor)?;
        world.check_frame_rate(config.camera_rate, "camera rate")?;
        let start_pose = place_robot(&mut world, config.spawn, config.seed)?;
        crate::world_check::require_floor(&world)?;
        let gl = EglContext::new()?;
        let camera = world.make_camera(&config.sensor, config.seed, &gl)?;
        let engine = Rasteriser::select(config.engine);
        let engine_name = engine.describe();
        let mapper_config = MapperConfig {
            iterations: config.iterations,
            uncertainty: config.planner_options.rtguide.uncertainty,
            ..MapperConfig::default()
        };
        let settled_omega = autonomy::planner::settled_omega(
            mapper_config.iterations,
            f64::from(mapper_config.rates.means),
        );
        let mapper = Mapper::new(mapper_config, engine);
        let context = PlannerContext {
            intrinsics: *camera.intrinsics(),
            range: config.sensor.max_range,
            seed: config.seed,
            period: config.think_period,
            settled_omega,
        };
        let planner = match (make, &config.planner) {
            (Some(make), _) => make(&context)?,
            (None, PlannerChoice::Builtin(kind)) => {
                planners::build(*kind, &config.planner_options, &world, context)?
            }
            (None, PlannerChoice::Python(spec)) => {
                return Err(SimError::InvalidArgument {
                    what: "--planner",
                    detail: format!(
                        "python:{}:{} is a Python class: it runs through the Python package (splatloop.run, or `splatloop run`, which starts it)",
                        spec.module, spec.class
                    ),
                })
            }
        };
        let planner_name = planner.name().to_owned();
        let planner_settings = planner.settings();
        // The folder and the recording are opened once every setting has been accepted (the
        // planner's too), so a refused setting leaves nothing behind.
        let mut writer =
            DatasetWriter::create(&config.out, config.sensor.max_range, config.overwrite)?;
        if let Some(frames) = config.fail_writes_after {
            writer.fail_writes_after(frames);
        }
        writer.name_point_cloud(POINT_CLOUD);
        if let Some(labels) = camera.labels() {
            writer.write_labels(std::sync::Arc::clone(labels))?;
        }
        let title = format!(
            "run {} {} seed {}",
            config.world.display(),
            config.planner,
            config.seed
        );
        let mut rerun = RerunLog::open(&config.rerun, &title)?;
        if let (Some(log), Some(labels)) = (&mut rerun, camera.labels()) {
            log.labels(std::sync::Arc::clone(labels))?;
        }
        // Fixed before the episode so coverage can be reported as it grows.
        let tests = TestSet::sample(
            &world,
            &camera,
            config.test_views,
            test_seed(config.seed),
            config.sensor.max_range,
        )?;
        let truth_views = TruthViews::capture(
            &world,
            &mut world.make_camera(
                &SensorConfig {
                    masks: false,
                    ..config.sensor.clone()
                },
                test_seed(config.seed),
                &gl,
            )?,
            &tests,
            PSNR_OVER_TIME_VIEWS,
        )?;
        let timestep = world.model().timestep();
        let clock = Clock {
            timestep,
            steps: (config.budget / timestep).round() as u64,
            step: 0,
            frame_period: 1.0 / config.camera_rate,
            next_frame: 0.0,
            next_think: 0.0,
            next_coverage: 0.0,
        };
        let pose = world.pose();
        Ok(Episode {
            config: config.clone(),
            wall,
            frame: camera.blank_frame(),
            camera,
            gl,
            listeners: Listeners {
                writer,
                rerun,
                others: Vec::new(),
            },
            control: Controller::new(pose, config.latency, world.robot().limits),
            tally: Tally::new(pose),
            world,
            mapper,
            planner,
            planner_settings,
            planner_name,
            context,
            advisors: Vec::new(),
            engine_name,
            tests,
            start_pose,
            clock,
            have_frame: false,
            coverage: None,
            coverage_over_time: Vec::new(),
            truth_views,
            psnr_over_time: Vec::new(),
            caller_command: None,
            done: None,
            ended: None,
            mid_tick: false,
        })
    }

    /// Adds a listener that hears every stage's outcome from now on (after the episode's own
    /// dataset writer and recording).
    pub fn listen(&mut self, listener: Box<dyn TickListener>) {
        self.listeners.others.push(listener);
    }

    /// Runs one think period: the think due now (mapping the newest frame and the planner's
    /// decision, or the caller's command), then physics and the camera until the next think
    /// is due, whose frame [`Episode::observe`] then shows. An error ends the episode (its
    /// folder is still written by `finish`) and is returned.
    pub fn step(&mut self) -> Result<StepReport> {
        let frames = self.listeners.writer.frame_count();
        let collisions = self.tally.collision_steps;
        let mut think = None;
        let mut progress = None;
        let outcome = self.run_period(&mut think, &mut progress);
        self.note_failure(outcome)?;
        Ok(StepReport {
            time: self.time(),
            pose: self.world.pose(),
            frames: self.listeners.writer.frame_count() - frames,
            think,
            collision_steps: self.tally.collision_steps - collisions,
            gaussians: self.mapper.map().len(),
            progress,
            ended: self.ended.clone(),
        })
    }

    /// The newest RGB-D frame, with its camera: the one the next think maps. Before the
    /// first step this takes the first frame.
    pub fn observe(&mut self) -> Result<&RgbdFrame> {
        if !self.mid_tick && self.ended.is_none() {
            let outcome = self.begin_tick();
            self.note_failure(outcome)?;
        }
        Ok(&self.frame)
    }

    /// Drives `command` for the next think period instead of asking the planner (which still
    /// sees every frame, and decides again from the period after, unless `apply` is called
    /// again). A holding recovery is cut short. Refuses commands outside the drive's limits.
    pub fn apply(&mut self, command: UnicycleCommand) -> Result<()> {
        let limits = self.world.robot().limits;
        if !(command.v.is_finite() && command.w.is_finite() && limits.admits(command)) {
            return Err(SimError::InvalidArgument {
                what: "drive command",
                detail: format!(
                    "v = {} m/s, w = {} rad/s; the robot drives 0 <= v <= {} m/s and |w| <= {} rad/s",
                    command.v, command.w, limits.max_forward, limits.max_turn
                ),
            });
        }
        self.caller_command = Some(command);
        Ok(())
    }

    /// Simulated seconds.
    pub fn time(&self) -> f64 {
        self.world.data().time()
    }

    /// The robot's planar pose.
    pub fn pose(&self) -> Pose2 {
        self.world.pose()
    }

    /// The map as it stands.
    pub fn map(&self) -> &GaussianMap {
        self.mapper.map()
    }

    /// The world being explored.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The configuration the episode runs under.
    pub fn config(&self) -> &RunConfig {
        &self.config
    }

    /// The map's coverage of the hidden test set now (metrics.json's coverage; `None` without
    /// test views): a caller's reward, measured on demand.
    pub fn coverage_now(&self) -> Option<f64> {
        (!self.tests.surface.is_empty()).then(|| {
            autonomy::metrics::coverage(
                &self.tests.surface,
                &self.mapper.map().gaussians.means,
                crate::evaluate::COVERAGE_RADIUS,
            )
        })
    }

    /// What the episode's planner was built with: a caller building its own planner, or
    /// wrapping a built-in one, needs the same.
    pub fn planner_context(&self) -> PlannerContext {
        self.context
    }

    /// The splat engine the mapper renders with, shared (a caller's renders of the map use
    /// it too).
    pub fn engine(&self) -> std::sync::Arc<Rasteriser> {
        self.mapper.shared_engine()
    }

    /// Adds `kind` as an advisor: a built-in planner with the episode's settings that sees
    /// every frame from now on beside the episode's own, and answers [`Episode::consult`].
    /// Nothing when it is one already. Its history starts now: add it before the first step
    /// for the whole episode's.
    pub fn advise(&mut self, kind: PlannerKind) -> Result<()> {
        if self.advisors.iter().all(|(k, _)| *k != kind) {
            let planner = planners::build(
                kind,
                &self.config.planner_options,
                &self.world,
                self.context,
            )?;
            self.advisors.push((kind, planner));
        }
        Ok(())
    }

    /// What the built-in planner `kind` would do from the robot's pose now, on the map as it
    /// stands (an advisor, added first if it is not one yet); the robot is not moved.
    pub fn consult(&mut self, kind: PlannerKind) -> Result<Decision> {
        self.advise(kind)?;
        let pose = self.world.pose();
        let map = self.mapper.map();
        let (_, advisor) = self
            .advisors
            .iter_mut()
            .find(|(k, _)| *k == kind)
            .ok_or_else(|| SimError::InvalidArgument {
                what: "planner",
                detail: format!("{} is not an advisor", kind.name()),
            })?;
        Ok(advisor.plan(map, pose))
    }

    /// Why the episode ended, once it has.
    pub fn ended(&self) -> Option<&str> {
        self.ended.as_deref()
    }

    /// Records a failed stage as the episode's end (the tick's error is still the caller's).
    fn note_failure(&mut self, outcome: Result<()>) -> Result<()> {
        if let Err(e) = &outcome {
            self.ended = Some(format!("error at t = {:.1} s: {}", self.time(), e.chain()));
        }
        outcome
    }

    fn think_due(&self) -> bool {
        self.have_frame && self.clock.due(self.time(), self.clock.next_think)
    }

    /// Ticks until the think after this period's is due, or the episode ends.
    fn run_period(
        &mut self,
        think: &mut Option<Think>,
        progress: &mut Option<Progress>,
    ) -> Result<()> {
        while self.ended.is_none() {
            if !self.mid_tick {
                self.begin_tick()?;
                if self.ended.is_some() {
                    break;
                }
            }
            if self.think_due() {
                if think.is_some() {
                    break;
                }
                let (done, heard) = self.think()?;
                *think = Some(done);
                *progress = heard;
                if self.ended.is_some() {
                    break;
                }
            }
            self.physics()?;
            self.mid_tick = false;
        }
        Ok(())
    }

    /// The budget, a stop request, then the camera and the controller's schedule start.
    fn begin_tick(&mut self) -> Result<()> {
        if self.clock.step >= self.clock.steps {
            self.ended = Some(match &self.done {
                Some((at, why)) => format!("budget (planner done at t = {at:.1} s: {why})"),
                None => "budget".to_owned(),
            });
            return Ok(());
        }
        if let (Some((at, why)), Some(factor)) = (&self.done, self.config.done_factor) {
            if self.clock.due(self.time(), factor * at) {
                self.ended = Some(format!(
                    "{factor} x the planner's time (planner done at t = {at:.1} s: {why})"
                ));
                return Ok(());
            }
        }
        if let Some(signal) = self.config.stop.requested() {
            self.ended = Some(format!(
                "interrupted at t = {:.1} s by {}",
                self.time(),
                StopRequest::signal_name(signal)
            ));
            return Ok(());
        }
        self.mid_tick = true;
        let time = self.time();
        if self.clock.due(time, self.clock.next_frame) {
            self.capture()?;
        }
        let world = &self.world;
        self.control
            .advance(time + 0.5 * self.clock.timestep, || world.pose());
        Ok(())
    }

    /// Takes a frame; the listeners write and record it, the planner looks at it.
    fn capture(&mut self) -> Result<()> {
        let t0 = Instant::now();
        self.camera
            .capture_into(self.world.data(), &mut self.frame)?;
        self.tally
            .camera_at(self.frame.camera.world_from_camera.translation.vector);
        self.have_frame = true;
        self.clock.next_frame += self.clock.frame_period;
        let observation = Observation {
            rgb: &self.frame.rgb,
            depth: &self.frame.depth,
            camera: &self.frame.camera,
            max_range: self.config.sensor.max_range,
            robot: self.world.pose(),
        };
        self.planner.observe(&observation, self.mapper.map());
        for (_, advisor) in &mut self.advisors {
            advisor.observe(&observation, self.mapper.map());
        }
        self.listeners.tell(&TickEvent::Frame {
            frame: &self.frame,
            path: &self.tally.path,
            seconds: t0.elapsed().as_secs_f64(),
        })?;
        self.tally.times.camera.push(t0.elapsed().as_secs_f64());
        Ok(())
    }

    /// Maps the newest frame, then lets the caller, a holding schedule or the planner decide;
    /// the coverage when due. Returns what decided, and the progress when the episode goes on.
    fn think(&mut self) -> Result<(Think, Option<Progress>)> {
        let time = self.time();
        self.clock.next_think += self.config.think_period;
        let mapping = self.map_frame(time)?;
        let pose = self.world.pose();
        self.control.observe(&pose);
        let think = if let Some(command) = self.caller_command.take() {
            self.control.drive(Schedule {
                start: time,
                period: self.config.think_period,
                commands: vec![command],
                commit: 0.0,
            });
            Think::Driven(command)
        } else if self.done.is_some() {
            self.control.drive(Schedule {
                start: time,
                period: self.config.think_period,
                commands: vec![UnicycleCommand { v: 0.0, w: 0.0 }],
                commit: 0.0,
            });
            Think::Idle
        } else if self.control.holding(time + 0.5 * self.clock.timestep) {
            Think::Holding
        } else {
            self.plan(time, pose, mapping)?
        };
        if self.ended.is_some() {
            return Ok((think, None));
        }
        self.measure_coverage(time)?;
        let progress = Progress {
            time,
            gaussians: self.mapper.map().len(),
            coverage: self.coverage,
        };
        self.listeners.tell(&TickEvent::Thought(progress))?;
        Ok((think, Some(progress)))
    }

    /// One mapping step on the newest frame; its wall seconds.
    fn map_frame(&mut self, time: f64) -> Result<f64> {
        let t0 = Instant::now();
        if self.done.is_some() {
            // The robot is idle: its frames bring nothing new, so the step refines the map
            // over its keyframes instead of fitting one view again and again.
            self.mapper
                .refine()
                .map_err(|e| SimError::Mapping(e.to_string()))?;
        } else {
            let observation = Frame::from_rgb8(&self.frame.rgb, self.frame.depth.clone());
            self.mapper
                .integrate(
                    &observation,
                    &self.frame.camera.world_from_camera.to_homogeneous(),
                    &self.frame.camera.intrinsics,
                )
                .map_err(|e| SimError::Mapping(e.to_string()))?;
        }
        let seconds = t0.elapsed().as_secs_f64();
        self.tally.times.mapping.push(seconds);
        self.listeners.tell(&TickEvent::Mapped {
            time,
            map: self.mapper.map(),
            seconds,
        })?;
        Ok(seconds)
    }

    /// Asks the planner from where the robot will be once the think is over (unless the
    /// progress watch overrules it) and hands the decision to the controller.
    fn plan(&mut self, time: f64, pose: Pose2, mapping: f64) -> Result<Think> {
        let t0 = Instant::now();
        let lead = self.control.lead(mapping);
        let start = self.control.start_pose(pose, time, lead);
        let decision = (!self.control.stalled(time, &pose))
            .then(|| self.planner.plan(self.mapper.map(), start));
        let planning = t0.elapsed().as_secs_f64();
        self.tally.times.planning.push(planning);
        self.listeners.tell(&TickEvent::Planned {
            time,
            decision: decision.as_ref(),
            seconds: planning,
        })?;
        let think = decision.clone().map_or(Think::Overruled, Think::Planned);
        let spent = ThinkTime { mapping, planning };
        match self.control.take(decision, time, pose, start, spent, lead) {
            Verdict::End(reason) => self.planner_done(time, reason),
            Verdict::Abort(reason) => self.ended = Some(reason),
            Verdict::Continue => {}
        }
        Ok(think)
    }

    /// The planner has nothing left to do. By default the episode goes on to its budget (or
    /// `done_factor` times this time) with the robot still and the mapper on its schedule, so
    /// every planner's map gets the same mapping time; `stop_when_done` ends it now.
    fn planner_done(&mut self, time: f64, reason: String) {
        if self.config.stop_when_done {
            self.done = Some((time, reason.clone()));
            self.ended = Some(reason);
            return;
        }
        tracing::info!(
            "t = {time:.1} s: the planner is done ({reason}); the robot holds still and the mapper goes on"
        );
        self.control.drive(Schedule {
            start: time,
            period: self.config.think_period,
            commands: vec![UnicycleCommand { v: 0.0, w: 0.0 }],
            commit: 0.0,
        });
        self.done = Some((time, reason));
    }

    /// The map's coverage of the hidden test set, every [`COVERAGE_PERIOD`] seconds.
    fn measure_coverage(&mut self, time: f64) -> Result<()> {
        if !self.clock.due(time, self.clock.next_coverage) {
            return Ok(());
        }
        let Some(coverage) = self.coverage_now() else {
            return Ok(());
        };
        self.clock.next_coverage += COVERAGE_PERIOD;
        self.coverage = Some(coverage);
        self.coverage_over_time.push([time, coverage]);
        if let Some(psnr) = self
            .truth_views
            .psnr(self.mapper.engine(), self.mapper.map())?
        {
            self.psnr_over_time.push([time, psnr]);
        }
        self.listeners.tell(&TickEvent::Coverage { time, coverage })
    }

    /// One physics step under the controller's command; contacts and the path.
    fn physics(&mut self) -> Result<()> {
        let time = self.time();
        let t0 = Instant::now();
        self.world.step(self.control.command(time))?;
        self.tally.times.physics.push(t0.elapsed().as_secs_f64());
        if let Some(contact) = self.world.robot_collisions().next() {
            if self.tally.touched(time) {
                let name = self.world.touched_name(&contact);
                tracing::warn!(
                    "t = {time:.1} s: the robot touches {name} at ({:.2}, {:.2})",
                    contact.position.x,
                    contact.position.y
                );
            }
        }
        let pose = self.world.pose();
        self.tally.moved(self.clock.step, pose);
        self.control.moved(pose);
        self.clock.step += 1;
        Ok(())
    }
}
