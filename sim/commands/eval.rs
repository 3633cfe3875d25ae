//! `splatloop eval`: a saved map's scores on an episode's hidden views.

use super::run::ViewArgs;
use crate::camera::SensorConfig;
use anyhow::{Context, Result};
use std::path::PathBuf;

/// `splatloop eval`'s flags.
#[derive(clap::Args)]
pub struct EvalArgs {
    /// The map (map.ply of an episode, or any 3DGS PLY).
    #[arg(long)]
    map: PathBuf,
    /// MJCF world the map is of.
    #[arg(long, default_value = "worlds/room.xml")]
    world: PathBuf,
    /// Hidden test views.
    #[arg(long, default_value_t = 100)]
    test_views: usize,
    /// Seed of the test set (the episode's --seed gives the episode's set).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    view: ViewArgs,
    /// Also write the scores to this JSON file (new, unless --overwrite).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also write every surface point the coverage is measured on to this CSV (x,y,z,covered;
    /// new, unless --overwrite): where the map is missing. Two maps evaluated with the same
    /// world, seed and camera list the same points in the same order, so rows compare.
    #[arg(long)]
    surface_out: Option<PathBuf>,
    /// Replace --out and --surface-out if they exist (never the map itself).
    #[arg(long)]
    overwrite: bool,
}

pub fn eval(args: EvalArgs) -> Result<()> {
    if let (Some(out), Some(surface)) = (&args.out, &args.surface_out) {
        crate::dataset::refuse_same_outputs(&[("--out", out), ("--surface-out", surface)])?;
    }
    for out in [&args.out, &args.surface_out].into_iter().flatten() {
        crate::dataset::refuse_overwrite(out, args.overwrite, &[&args.map, &args.world])?;
    }
    let sensor = SensorConfig {
        width: args.view.width,
        height: args.view.height,
        masks: false,
        ..SensorConfig::default()
    };
    let (evaluation, surface) = crate::novel_view::evaluate_map_surface(
        &args.map,
        &args.world,
        &sensor,
        args.test_views,
        args.seed,
        args.view.engine,
    )
    .with_context(|| format!("evaluating {} failed", args.map.display()))?;
    print_evaluation(&evaluation);
    if let Some(out) = &args.out {
        let text = serde_json::to_string_pretty(&evaluation)?;
        std::fs::write(out, text + "\n")
            .with_context(|| format!("cannot write {}", out.display()))?;
    }
    if let Some(out) = &args.surface_out {
        let mut text = String::from("x,y,z,covered\n");
        for p in &surface {
            let [x, y, z] = p.position;
            text += &format!("{x},{y},{z},{}\n", u8::from(p.covered));
        }
        std::fs::write(out, text).with_context(|| format!("cannot write {}", out.display()))?;
    }
    Ok(())
}

pub fn print_evaluation(e: &crate::evaluate::Evaluation) {
    if e.views == 0 {
        println!(
            "hidden views: none (asked for none, or no pose with 0.4 m of clearance was found)"
        );
        return;
    }
    println!(
        "hidden views: {}, PSNR {:.2} dB, SSIM {:.3}, depth MAE {:.3} m, RMSE {:.3} m, coverage {:.1}% of {} surface points",
        e.views,
        e.psnr,
        e.ssim,
        e.depth_mae,
        e.depth_rmse,
        100.0 * e.coverage,
        e.surface_points
    );
}
