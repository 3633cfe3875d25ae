//! `splatloop render`: a saved map rendered at a trajectory's poses, as a dataset.

use super::progress::Progress;
use anyhow::{Context, Result};
use autonomy::splat::EngineChoice;
use std::path::PathBuf;

/// `splatloop render`'s flags.
#[derive(clap::Args)]
pub struct RenderArgs {
    /// The map (map.ply of an episode, or any 3DGS PLY).
    #[arg(long)]
    map: PathBuf,
    /// TUM trajectory (`timestamp tx ty tz qx qy qz qw`, world_from_camera, optical frame).
    #[arg(long)]
    poses: PathBuf,
    /// camera.json with the intrinsics; default: the one beside --poses.
    #[arg(long)]
    camera: Option<PathBuf>,
    /// Output folder (must be new or empty).
    #[arg(long, default_value = "runs/render")]
    out: PathBuf,
    /// Replace the output folder if it holds an earlier dataset.
    #[arg(long)]
    overwrite: bool,
    /// Splat engine: auto, cpu or gpu.
    #[arg(long, value_enum, default_value_t = EngineChoice::Auto)]
    engine: EngineChoice,
}

pub fn render(args: RenderArgs) -> Result<()> {
    let camera = match args.camera {
        Some(c) => c,
        None => args
            .poses
            .parent()
            .unwrap_or(std::path::Path::new("."))
            .join("camera.json"),
    };
    let config = crate::novel_view::RenderConfig {
        map: args.map,
        poses: args.poses,
        camera,
        out: args.out,
        engine: args.engine,
        overwrite: args.overwrite,
    };
    let mut bar = Progress::new(
        0,
        "{spinner} rendering [{bar:30}] {pos}/{len} views ({eta})",
        "rendering",
    );
    let frames = crate::novel_view::render_map(&config, &mut |done, total| {
        bar.set_length(total as u64);
        bar.update(done as u64, || format!("{done}/{total} views"));
    })
    .with_context(|| format!("rendering {} failed", config.map.display()))?;
    bar.finish();
    println!(
        "rendered {frames} views of {} into {}",
        config.map.display(),
        config.out.display()
    );
    Ok(())
}
