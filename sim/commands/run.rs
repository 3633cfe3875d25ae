//! `splatloop run`: one closed-loop episode, with a progress bar and signal handling.

use super::eval::print_evaluation;
use super::progress::Progress;
use super::RerunArgs;
use crate::camera::SensorConfig;
use crate::episode::{
    run_to_end, Episode, Latency, PlannerChoice, PlannerContext, PlannerOptions, RunConfig,
    StopRequest,
};
use crate::spawn::Spawn;
use anyhow::{Context, Result};
use autonomy::explore::Planner;
use autonomy::splat::EngineChoice;
use std::path::PathBuf;

/// `splatloop run`'s flags.
#[derive(clap::Args)]
pub struct RunArgs {
    /// MJCF world that includes the robot (models/unicycle.xml).
    #[arg(long, default_value = "worlds/room.xml")]
    world: PathBuf,
    /// Planner: rtguide (RT-GuIDE: information-driven, on the map alone), fbe (frontier
    /// exploration, AG-SLAM's baseline), agslam (AG-SLAM's Fisher-information planner) or
    /// survey (full turns at the points of the world's floor plan, which it knows, that see
    /// the most: the bound to compare with). All but the survey drive through the same
    /// executor. python:MODULE:CLASS runs your own planner written in Python (a class with
    /// plan(observation, map); MODULE a dotted module importable from here, or a .py file)
    /// through the Python package, in the same loop: see the README's Python section.
    #[arg(long, default_value = "rtguide", value_parser = parse_planner)]
    planner: PlannerChoice,
    /// Simulated seconds to explore. The episode runs to it even when the planner is done
    /// earlier (the robot holds still, the mapper goes on), unless --stop-when-done.
    #[arg(long, default_value_t = 60.0)]
    budget: f64,
    /// With the planner done at t, end at F x t instead (within the budget): what a sweep
    /// gives its survey in --budget-survey-factor mode, so the survey maps as long as the
    /// planners compared with it.
    #[arg(long, value_name = "F")]
    done_factor: Option<f64>,
    /// Seed (sensor noise, the hidden test set and a random spawn).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    options: RunOptions,
    /// Episode folder (must be new or empty).
    #[arg(long, default_value = "runs/episode")]
    out: PathBuf,
    /// Replace the output folder if it holds an earlier episode (and the --rerun file).
    #[arg(long)]
    overwrite: bool,
    #[command(flatten)]
    rerun: RerunArgs,
    /// With --rerun or --rerun-connect: log the Gaussian map every N mapping steps (one step
    /// per simulated second; a 2e5-Gaussian map is about 5 MB each time).
    #[arg(long, default_value_t = 1, value_name = "N")]
    rerun_map_every: usize,
}

/// The options of an episode that a sweep passes on to every one of its episodes (it owns
/// the world, planner, budget, seed and folder); serialised into sweep.json by their long
/// names, and turned back into those flags for each episode.
#[derive(clap::Args, serde::Serialize, serde::Deserialize, Debug, Clone, PartialEq)]
pub struct RunOptions {
    /// Each planner's own settings.
    #[command(flatten)]
    #[serde(flatten)]
    pub planners: PlannerOptions,
    /// Camera frames per simulated second.
    #[arg(long, default_value_t = 5.0)]
    pub camera_rate: f64,
    /// Adam iterations per mapping step (one step per second).
    #[arg(long, default_value_t = 10)]
    pub iterations: usize,
    /// wall: mapping and planning time is charged to simulated time (the robot keeps driving
    /// its previous plan); none: the world waits.
    #[arg(long, value_enum, default_value_t = Latency::Wall)]
    pub latency: Latency,
    /// The camera size and engine.
    #[command(flatten)]
    #[serde(flatten)]
    pub view: ViewArgs,
    /// Start pose: site (the world's `spawn` site), random (seeded by --seed, anywhere the
    /// robot can reach from the site with 0.6 m of room), or x,y,yaw (metres, radians).
    #[arg(long, default_value = "site", allow_hyphen_values = true, value_parser = check_spawn)]
    pub spawn: String,
    /// Spherical-harmonic degree of map.ply: 0 (compact, read by every viewer) or 3 (zero
    /// f_rest_0..44 added, as graphdeco-inria's reference loader requires by default).
    #[arg(long, default_value_t = 0, value_parser = parse_sh_degree)]
    pub ply_sh_degree: u8,
    /// Hidden test views for the evaluation, sampled in free space (0: skip).
    #[arg(long, default_value_t = 100)]
    pub test_views: usize,
    /// End the episode when the planner says it is done (the old protocol); by default it
    /// runs to its budget, so every planner's map gets the same mapping time.
    #[arg(long, action = clap::ArgAction::Set, num_args = 0..=1, default_value_t = false,
          default_missing_value = "true", value_name = "BOOL")]
    #[serde(default)]
    pub stop_when_done: bool,
    /// Instance and semantic masks with every frame (instance/, semantic/, labels.json), from
    /// a segmentation pass of the camera; false skips them.
    #[arg(long, action = clap::ArgAction::Set, num_args = 0..=1, default_value_t = true,
          default_missing_value = "true", value_name = "BOOL")]
    #[serde(default = "masks_on")]
    pub masks: bool,
    /// Standard deviation of Gaussian noise added to every depth pixel, metres, drawn from
    /// --seed (off when absent): a documented perturbation of the images, so that seeds give
    /// different trajectories and a sweep can show how often a planner fails when the camera's
    /// pixels change a little (as another OpenGL implementation changes them).
    #[arg(long, value_name = "METRES")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth_noise: Option<f64>,
}

fn masks_on() -> bool {
    true
}

/// `--planner`: a built-in name or python:MODULE:CLASS.
fn parse_planner(text: &str) -> Result<PlannerChoice, String> {
    text.parse()
}

/// `--spawn` is kept as typed (so a sweep can pass it on) but checked when parsed.
fn check_spawn(text: &str) -> Result<String, String> {
    text.parse::<Spawn>().map(|_| text.to_string())
}

/// The camera size and splat engine of the commands that render a map.
#[derive(clap::Args, serde::Serialize, serde::Deserialize, Debug, Clone, PartialEq)]
pub struct ViewArgs {
    /// Splat engine: auto (a hardware GPU if any), cpu or gpu.
    #[arg(long, value_enum, default_value_t = EngineChoice::Auto)]
    pub engine: EngineChoice,
    /// Image width, pixels.
    #[arg(long, default_value_t = 320)]
    pub width: u32,
    /// Image height, pixels.
    #[arg(long, default_value_t = 240)]
    pub height: u32,
}

fn parse_sh_degree(text: &str) -> Result<u8, String> {
    match text {
        "0" => Ok(0),
        "3" => Ok(3),
        other => Err(format!("{other:?}: map.ply is written at degree 0 or 3")),
    }
}

impl RunArgs {
    /// The episode these flags describe (no signal handler attached yet).
    pub fn into_config(self) -> Result<RunConfig> {
        Ok(RunConfig {
            world: self.world,
            budget: self.budget,
            seed: self.seed,
            camera_rate: self.options.camera_rate,
            think_period: 1.0,
            iterations: self.options.iterations,
            latency: self.options.latency,
            planner: self.planner,
            planner_options: self.options.planners,
            sensor: SensorConfig {
                width: self.options.view.width,
                height: self.options.view.height,
                masks: self.options.masks,
                depth_noise_sigma: self.options.depth_noise,
                ..SensorConfig::default()
            },
            test_views: self.options.test_views,
            stop_when_done: self.options.stop_when_done,
            done_factor: self.done_factor,
            ply_sh_degree: self.options.ply_sh_degree,
            spawn: self.options.spawn.parse().map_err(anyhow::Error::msg)?,
            engine: self.options.view.engine,
            overwrite: self.overwrite,
            rerun: self.rerun.target(self.rerun_map_every),
            stop: StopRequest::default(),
            fail_writes_after: None,
            out: self.out,
        })
    }
}

/// `splatloop run`'s flags, parsed on their own.
#[derive(clap::Parser)]
#[command(name = "splatloop run", no_binary_name = true)]
struct RunLine {
    #[command(flatten)]
    args: RunArgs,
}

/// The episode `splatloop run WORDS` would run: the same flags, defaults and errors (the
/// Python package builds its episodes with this). A `python:` planner is in the config; the
/// episode needs its object ([`Episode::with_planner`]).
pub fn run_config_from_words(words: Vec<String>) -> Result<RunConfig> {
    use clap::Parser;
    let line = RunLine::try_parse_from(words).map_err(|e| anyhow::anyhow!("{}", e.render()))?;
    line.args.into_config()
}

/// A failed run (a full disk) keeps what it wrote in its staging folder: the error says
/// where, and that the next run into the folder clears it.
pub(crate) fn with_kept_work(error: anyhow::Error, out: &std::path::Path) -> anyhow::Error {
    match crate::dataset::staging_folder(out) {
        Some(staging) if staging.exists() => error.context(format!(
            "what was written is in {}; free space or fix the cause, then rerun (the next run into {} clears it)",
            staging.display(),
            out.display()
        )),
        _ => error,
    }
}

/// Runs the episode with a progress bar; `Some(code)` when a signal stopped it. A Python
/// planner's episode runs in the Python package's interpreter (`super::python`).
pub fn run(args: RunArgs) -> Result<Option<u8>> {
    if let PlannerChoice::Python(spec) = &args.planner {
        return super::python::run_in_python(spec);
    }
    run_config(args.into_config()?, None)
}

/// Builds a caller's own planner for an episode, once the episode knows its camera.
pub type PlannerFactory<'a> =
    Box<dyn FnOnce(&PlannerContext) -> crate::error::Result<Box<dyn Planner>> + 'a>;

/// `splatloop run WORDS` with `make` building the planner (the Python package's `splatloop
/// run --planner python:...`): the same progress bar, signals, summary and exit code;
/// `on_built` sees the episode before its first step.
pub fn run_words_with_planner(
    words: Vec<String>,
    make: PlannerFactory<'_>,
    on_built: &mut dyn FnMut(&Episode),
) -> Result<Option<u8>> {
    use clap::Parser;
    let line = RunLine::try_parse_from(words).map_err(|e| anyhow::anyhow!("{}", e.render()))?;
    run_config(line.args.into_config()?, Some((make, on_built)))
}

type CustomPlanner<'a, 'b> = (PlannerFactory<'a>, &'b mut dyn FnMut(&Episode));

fn run_config(config: RunConfig, custom: Option<CustomPlanner<'_, '_>>) -> Result<Option<u8>> {
    // Ctrl-C or a cluster's SIGTERM stops the episode at its next tick; it is still written.
    for (signal, code) in [
        (signal_hook::consts::SIGINT, StopRequest::SIGINT),
        (signal_hook::consts::SIGTERM, StopRequest::SIGTERM),
    ] {
        signal_hook::flag::register_usize(signal, config.stop.flag(), code)
            .context("cannot install the signal handlers")?;
    }
    let mut bar = Progress::new(
        (config.budget * 1000.0).round() as u64,
        "{spinner} exploring [{bar:30}] {msg} ({elapsed} wall, eta {eta})",
        "exploring",
    );
    let budget = config.budget;
    let episode = match custom {
        Some((make, on_built)) => {
            let episode = Episode::with_planner(&config, make);
            if let Ok(episode) = &episode {
                on_built(episode);
            }
            episode
        }
        None => Episode::new(&config),
    }
    .with_context(|| format!("exploring {} failed", config.world.display()))?;
    let metrics = run_to_end(episode, &mut |p| {
        bar.update((p.time * 1000.0) as u64, || {
            let coverage = p
                .coverage
                .map_or(String::new(), |c| format!(", coverage {:.0}%", 100.0 * c));
            format!(
                "{:.0}/{budget:.0} sim s, {} Gaussians{coverage}",
                p.time, p.gaussians
            )
        });
    })
    .with_context(|| format!("exploring {} failed", config.world.display()))
    .map_err(|error| with_kept_work(error, &config.out))?;
    if config.stop.requested().is_some() {
        bar.finish_interrupted();
    } else {
        bar.finish();
    }
    println!(
        "explored {:.0} sim s in {:.1} wall s (real-time factor {:.2}) with {}: {} Gaussians, {:.1} m driven, {} collision steps, {} recoveries; wrote {}",
        metrics.simulated_seconds,
        metrics.wall_seconds,
        metrics.real_time_factor,
        metrics.engine,
        metrics.gaussians,
        metrics.path_length,
        metrics.collision_steps,
        metrics.recovery_events,
        metrics.folder.display()
    );
    print_evaluation(&metrics.evaluation);
    if metrics.ended != "budget" {
        println!("ended: {}", metrics.ended);
    }
    Ok(config
        .stop
        .requested()
        .map(|code| u8::try_from(code).unwrap_or(1)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commands::{Cli, Command};
    use crate::episode::RtGuideOptions;
    use clap::Parser;

    /// The options as `splatloop run` parses them from `words`.
    fn run_options(words: &[String]) -> RunOptions {
        let mut argv = vec!["splatloop".to_string(), "run".to_string()];
        argv.extend_from_slice(words);
        match Cli::try_parse_from(argv).expect("the words parse").command {
            Command::Run(args) => args.options,
            _ => panic!("not a run"),
        }
    }

    #[test]
    fn a_sweeps_option_words_parse_back_to_its_options_whatever_the_switches_defaults() {
        let defaults = run_options(&[]);
        // The paper's planner is a switch turned off that is on by default.
        let rtguide = defaults.planners.rtguide;
        assert!(rtguide.frontier_regions && !rtguide.free_space_edges);
        assert!(rtguide.frontiers_first && !rtguide.finish);
        assert!(rtguide.tour);
        for switches in 0..32 {
            let mut options = defaults.clone();
            options.planners.rtguide = RtGuideOptions {
                frontier_regions: switches & 1 != 0,
                free_space_edges: switches & 2 != 0,
                frontiers_first: switches & 4 != 0,
                finish: switches & 8 != 0,
                tour: switches & 16 != 0,
                ..rtguide
            };
            let map = match serde_json::to_value(&options).expect("serialises") {
                serde_json::Value::Object(map) => map,
                other => panic!("not an object: {other}"),
            };
            let words = crate::sweep::spec::option_words(&map);
            assert_eq!(run_options(&words), options, "{words:?}");
        }
        // A bare switch is on; sweeps from before the frontier switches (no keys)
        // read as the paper's planner.
        let bare = run_options(&["--rtguide-free-space-edges".into()]);
        assert!(bare.planners.rtguide.free_space_edges);
        let mut old = match serde_json::to_value(&defaults).expect("serialises") {
            serde_json::Value::Object(map) => map,
            other => panic!("not an object: {other}"),
        };
        old.remove("rtguide_frontier_regions");
        old.remove("rtguide_frontiers_first");
        old.remove("rtguide_finish");
        old.remove("rtguide_tour");
        let read: RunOptions =
            serde_json::from_value(serde_json::Value::Object(old)).expect("reads");
        let paper = read.planners.rtguide;
        assert!(!paper.frontier_regions && !paper.frontiers_first);
        assert!(!paper.finish && !paper.tour);
    }
}
