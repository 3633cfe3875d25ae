//! The command line as a library: each command's flags and what it does, one file per
//! command; `main.rs` only parses and dispatches.

use anyhow::Result;
use clap::{Parser, Subcommand};
use std::path::PathBuf;

pub mod bench;
mod eval;
pub(crate) mod progress;
pub mod python;
mod record;
mod render;
pub(crate) mod run;
pub mod sweep;
pub(crate) mod world;

pub use bench::cli::{BenchArgs, BenchTarget};
pub use eval::EvalArgs;
pub use record::{record_config_from_words, RecordArgs};
pub use render::RenderArgs;
pub use run::{
    run_config_from_words, run_words_with_planner, PlannerFactory, RunArgs, RunOptions, ViewArgs,
};
pub use sweep::cli::{SweepArgs, SweepBackend};
pub use world::WorldCommand;

/// Headless closed-loop active mapping: a MuJoCo unicycle robot with an offscreen RGB-D
/// camera, an online Gaussian-splatting map and an exploration planner.
#[derive(Parser)]
#[command(version, about, long_about = None)]
pub struct Cli {
    /// Log filter (error, warn, info, debug, trace, or a tracing directive).
    #[arg(long, global = true, default_value = "info", env = "SPLATLOOP_LOG")]
    pub log: String,
    /// The command to run.
    #[command(subcommand)]
    pub command: Command,
}

/// splatloop's commands.
#[derive(Subcommand)]
pub enum Command {
    /// Explore a world on its own: map it online and plan (RT-GuIDE, or the survey) every tick; write the
    /// dataset, map.ply and metrics.json.
    Run(RunArgs),
    /// Run worlds x planners x seeds as separate episodes (OUT/WORLD/PLANNER/SEED/), N at a
    /// time, on a Ray cluster or as a Slurm array; resumable; then results.csv, summary.md
    /// and the charts.
    Sweep(SweepArgs),
    /// Drive the robot open-loop through a world and write an RGB-D dataset with exact poses.
    Record(RecordArgs),
    /// Score a saved map on hidden views of a world (PSNR, SSIM, depth errors, coverage); with
    /// an episode's seed and camera size the test set is that episode's.
    Eval(EvalArgs),
    /// Render a saved map's RGB and depth at the poses of a TUM groundtruth.txt, with the
    /// intrinsics of a camera.json, into a new dataset folder.
    Render(RenderArgs),
    /// Worlds: generate one by seed, check one, import or export a scene.
    #[command(subcommand)]
    World(WorldCommand),
    /// Measure performance and print a table.
    Bench(BenchArgs),
}

/// Where a rerun recording of the episode goes (needs a build with `--features rerun`,
/// which `scripts/setup.sh --with-rerun` makes).
#[derive(clap::Args)]
pub struct RerunArgs {
    /// Write a rerun recording (.rrd: camera images and poses, path, plans, map, scalars);
    /// open it with `rerun FILE.rrd`.
    #[arg(long, value_name = "FILE.rrd")]
    pub rerun: Option<PathBuf>,
    /// Stream the recording to a running rerun viewer (HOST:PORT, e.g. 127.0.0.1:9876, or a
    /// rerun+http:// URL).
    #[arg(long, value_name = "ADDR")]
    pub rerun_connect: Option<String>,
}

impl RerunArgs {
    /// Where the recording goes, logging the map every `map_every` mapping steps.
    pub fn target(&self, map_every: usize) -> crate::rerun_log::RerunTarget {
        crate::rerun_log::RerunTarget {
            file: self.rerun.clone(),
            connect: self.rerun_connect.clone(),
            map_every,
        }
    }
}

/// Runs a command; `Some(code)` when it was stopped by a signal and must exit with `code`.
pub fn run(command: Command) -> Result<Option<u8>> {
    let done = |r: Result<()>| r.map(|()| None);
    match command {
        Command::Record(args) => done(record::record(args)),
        Command::Run(args) => run::run(args),
        Command::Sweep(args) => sweep::cli::sweep(args),
        Command::Eval(args) => done(eval::eval(args)),
        Command::Render(args) => done(render::render(args)),
        Command::World(command) => done(world::world(command)),
        Command::Bench(args) => done(bench::cli::bench(args)),
    }
}
