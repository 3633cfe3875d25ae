//! `splatloop record`: an open-loop drive written as a dataset.

use super::progress::Progress;
use super::RerunArgs;
use crate::camera::SensorConfig;
use crate::record::{record as record_drive, RecordConfig};
use crate::robot::Pose2;
use crate::spawn::parse_pose;
use anyhow::{Context, Result};
use std::path::PathBuf;

/// `splatloop record`'s flags.
#[derive(clap::Args)]
pub struct RecordArgs {
    /// MJCF world that includes the robot (models/unicycle.xml).
    #[arg(long, default_value = "worlds/room.xml")]
    world: PathBuf,
    /// CSV of `t,v,w` rows (commands hold until the next row), or a built-in pattern:
    /// circle, spin, straight, arcs.
    #[arg(long, default_value = "circle")]
    controls: String,
    /// Simulated seconds to drive.
    #[arg(long, default_value_t = 20.0, allow_negative_numbers = true)]
    duration: f64,
    /// Output folder (must be new or empty).
    #[arg(long, default_value = "runs/record")]
    out: PathBuf,
    /// Replace the output folder if it holds an earlier dataset.
    #[arg(long)]
    overwrite: bool,
    /// Camera frames per simulated second.
    #[arg(long, default_value_t = 5.0)]
    fps: f64,
    /// Image width, pixels.
    #[arg(long, default_value_t = 320)]
    width: u32,
    /// Image height, pixels.
    #[arg(long, default_value_t = 240)]
    height: u32,
    /// Depth beyond this many metres reads 0.
    #[arg(long, default_value_t = 5.0)]
    max_range: f64,
    /// Standard deviation of Gaussian depth noise in metres (off when absent).
    #[arg(long)]
    depth_noise: Option<f64>,
    /// Instance and semantic masks with every frame (instance/, semantic/, labels.json), from
    /// a segmentation pass of the camera; false skips them.
    #[arg(long, action = clap::ArgAction::Set, num_args = 0..=1, default_value_t = true,
          default_missing_value = "true", value_name = "BOOL")]
    masks: bool,
    /// Seed for every random choice.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Start pose `x,y,theta` (metres, radians); default: the world's `spawn` site.
    #[arg(long, value_parser = parse_pose, allow_hyphen_values = true)]
    start: Option<Pose2>,
    #[command(flatten)]
    rerun: RerunArgs,
}

impl RecordArgs {
    /// The drive these flags describe.
    pub fn into_config(self) -> RecordConfig {
        let args = self;
        RecordConfig {
            world: args.world,
            controls: args.controls,
            duration: args.duration,
            frame_rate: args.fps,
            seed: args.seed,
            sensor: SensorConfig {
                width: args.width,
                height: args.height,
                max_range: args.max_range,
                depth_noise_sigma: args.depth_noise,
                masks: args.masks,
                ..SensorConfig::default()
            },
            start: args.start,
            overwrite: args.overwrite,
            rerun: args.rerun.target(1),
            out: args.out,
        }
    }
}

/// `splatloop record`'s flags, parsed on their own.
#[derive(clap::Parser)]
#[command(name = "splatloop record", no_binary_name = true)]
struct RecordLine {
    #[command(flatten)]
    args: RecordArgs,
}

/// The drive `splatloop record WORDS` would record: the same flags, defaults and errors (the
/// Python package's `record` uses this).
pub fn record_config_from_words(words: Vec<String>) -> Result<RecordConfig> {
    use clap::Parser;
    let line = RecordLine::try_parse_from(words).map_err(|e| anyhow::anyhow!("{}", e.render()))?;
    Ok(line.args.into_config())
}

/// Records the drive with a progress bar.
pub fn record(args: RecordArgs) -> Result<()> {
    let config = args.into_config();
    let mut bar = Progress::new(
        (config.duration * 1000.0).round() as u64,
        "{spinner} recording [{bar:30}] {msg} sim s ({elapsed} wall, eta {eta})",
        "recording",
    );
    let total = config.duration;
    let summary = record_drive(&config, &mut |t| {
        bar.update((t * 1000.0) as u64, || format!("{t:.1}/{total:.0} sim s"));
    })
    .with_context(|| format!("recording {} failed", config.world.display()))
    .map_err(|error| super::run::with_kept_work(error, &config.out))?;
    bar.finish();
    println!(
        "wrote {} frames to {} (robot ended at x = {:.2} m, y = {:.2} m, theta = {:.2} rad; {} collision steps)",
        summary.frames,
        summary.out.display(),
        summary.final_pose.x,
        summary.final_pose.y,
        summary.final_pose.theta,
        summary.collision_steps
    );
    Ok(())
}
