//! `splatloop bench`: measures and prints a table.

use crate::commands::world::tempfile_dir;
use anyhow::Result;
use autonomy::splat::gpu::GpuOptions;
use autonomy::splat::{EngineChoice, Rasteriser};
use clap::ValueEnum;
use std::path::PathBuf;

/// `splatloop bench`'s flags.
#[derive(clap::Args)]
pub struct BenchArgs {
    /// What to measure.
    #[arg(value_enum)]
    what: BenchTarget,
    /// World to measure in.
    #[arg(long, default_value = "worlds/room.xml")]
    world: PathBuf,
    /// Frames timed per resolution (sensor); frames of the tour mapped (map: at most its 46).
    #[arg(long, default_value_t = 300)]
    frames: usize,
    /// Timed iterations per row (render), after one warm-up.
    #[arg(long, default_value_t = 5)]
    iterations: usize,
    /// Gaussian counts (render).
    #[arg(long, value_delimiter = ',', default_value = "10000,100000,1000000")]
    gaussians: Vec<usize>,
    /// Splat engines to time (render, map): cpu, gpu (any adapter, software included) or auto
    /// (a hardware GPU if there is one); an engine that resolves to one already timed is
    /// skipped.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "cpu,auto")]
    engine: Vec<EngineChoice>,
    /// Whether the GPU engine's backward pass sums by subgroup where the adapter has
    /// subgroups (render, map); `true,false` times both kernels in one run.
    #[arg(long, value_delimiter = ',', default_value = "true", action = clap::ArgAction::Set)]
    gpu_subgroups: Vec<bool>,
}

/// What `splatloop bench` measures.
#[derive(Clone, Copy, ValueEnum)]
pub enum BenchTarget {
    /// RGB-D frames/s at 320x240 and 640x480, physics steps/s.
    Sensor,
    /// One mapping iteration (forward + loss + backward + Adam) of each splat engine, with the
    /// GPU's traffic and, where the adapter has timestamps, its resident iteration's GPU time
    /// per kernel.
    Render,
    /// The mapping loss with its gradient (L1 + SSIM) at 320x240 and 640x480: the serial
    /// reference against the SIMD version on every core.
    Loss,
    /// Mapping steps (densify, iterations, prune) as the map of a 70 m2 apartment grows.
    Map,
    /// Full RT-GuIDE plans over 1e4-3e6 Gaussians of clutter per collision engine, and
    /// scoring 500 viewpoints over 1e6 Gaussians.
    Plan,
    /// A plan of each planner (rtguide, fbe, agslam) over 1e4-1e6 Gaussians of clutter.
    Planners,
    /// World generation per kind (4 seeds each), and `world import` of 1e5- and 1e6-triangle
    /// scenes (a suite world exported and subdivided) with the colliders it builds.
    World,
}

/// Runs the benchmark asked for and prints its table.
pub fn bench(args: BenchArgs) -> Result<()> {
    let BenchArgs {
        what,
        world,
        frames,
        iterations,
        gaussians,
        engine,
        gpu_subgroups,
    } = args;
    let engines = || distinct_engines(&engine, &gpu_subgroups);
    match what {
        BenchTarget::Render => render(engines(), &gaussians, iterations),
        BenchTarget::Loss => loss(iterations),
        BenchTarget::Plan => plan(&engine, &gaussians),
        BenchTarget::Planners => planners(&gaussians),
        BenchTarget::World => worlds(world),
        BenchTarget::Map => map(engines(), frames),
        BenchTarget::Sensor => sensor(&world, frames),
    }
}

/// One mapping iteration per engine, resolution and Gaussian count.
fn render(engines: Vec<Rasteriser>, gaussians: &[usize], iterations: usize) -> Result<()> {
    for rasteriser in engines {
        let name = rasteriser.describe();
        let rows = crate::bench::bench_render(
            &rasteriser,
            &[(320, 240), (640, 480)],
            gaussians,
            iterations.max(1),
        )?;
        print_render_bench(&name, &rows);
        print_pass_times(&rows);
    }
    Ok(())
}

/// The mapping loss: the reference against the SIMD version.
fn loss(iterations: usize) -> Result<()> {
    let rows = crate::bench::bench_loss(&[(320, 240), (640, 480)], iterations);
    println!("threads: {}", rayon::current_num_threads());
    println!(
        "| resolution | reference ms | SIMD, fresh scratch ms | SIMD, kept workspace ms | \
         kept vs reference | kept vs fresh |"
    );
    println!("|---|---:|---:|---:|---:|---:|");
    for r in &rows {
        println!(
            "| {}x{} | {:.2} | {:.2} | {:.2} | {:.1}x | {:.2}x |",
            r.resolution.0,
            r.resolution.1,
            r.reference * 1e3,
            r.simd * 1e3,
            r.kept * 1e3,
            r.reference / r.kept,
            r.simd / r.kept
        );
    }
    Ok(())
}

/// RT-GuIDE plans per collision engine, and viewpoint scoring.
fn plan(engine: &[EngineChoice], gaussians: &[usize]) -> Result<()> {
    let counts = if gaussians == [10_000, 100_000, 1_000_000] {
        vec![10_000, 100_000, 1_000_000, 3_000_000]
    } else {
        gaussians.to_vec()
    };
    let gpu = engine.iter().any(|e| *e != EngineChoice::Cpu);
    let rows = crate::bench::bench_plan(&counts, 100_000, gpu);
    println!("| Gaussians | collision engine | first plan ms | plan ms (median of 3, upkeep included) | sync+graph ms | search ms | information ms | segments |");
    println!("|---:|---|---:|---:|---:|---:|---:|---:|");
    for r in &rows {
        println!(
            "| {} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {} |",
            r.gaussians,
            r.engine,
            r.first * 1e3,
            r.plan * 1e3,
            r.stages[0] * 1e3,
            r.stages[1] * 1e3,
            r.stages[2] * 1e3,
            r.segments
        );
    }
    let (build, score, brute) = crate::bench::bench_viewpoints(1_000_000, 500);
    println!(
            "500 viewpoints over 1e6 Gaussians: grid build {:.1} ms, scoring {:.2} ms ({:.1} us each); brute force {:.2} ms each",
            build * 1e3,
            score * 1e3,
            score * 1e6 / 500.0,
            brute * 1e3
        );
    Ok(())
}

/// A plan of each planner.
fn planners(gaussians: &[usize]) -> Result<()> {
    let candidates = autonomy::explore::agslam::AgslamConfig::default().candidates;
    println!("| Gaussians | planner | plan ms (median of 3) | candidates | outcome |");
    println!("|---:|---|---:|---:|---|");
    for r in crate::bench::bench_planners(gaussians, candidates) {
        println!(
            "| {} | {} | {:.1} | {} | {} |",
            r.gaussians,
            r.planner,
            r.plan * 1e3,
            r.candidates,
            r.outcome
        );
    }
    Ok(())
}

/// World generation per kind, and imports of large scenes.
fn worlds(world: PathBuf) -> Result<()> {
    let dir = tempfile_dir()?;
    let rows = crate::bench_worlds::bench_generate(&dir, 4)?;
    println!("| kind | seed | candidates | floor m2 | collidable geoms | generate + check ms |");
    println!("|---|---:|---:|---:|---:|---:|");
    for r in &rows {
        println!(
            "| {} | {} | {} | {:.1} | {} | {:.0} |",
            r.kind.name(),
            r.seed,
            r.candidates,
            r.area,
            r.geoms,
            r.seconds * 1e3
        );
    }
    let scene = if world == std::path::Path::new("worlds/room.xml") {
        std::path::PathBuf::from("worlds/suite/apartment_03.xml")
    } else {
        world
    };
    let imports = crate::bench_worlds::bench_import(&scene, &dir, &[100_000, 1_000_000])?;
    println!("import of {} exported and subdivided:", scene.display());
    println!("| triangles | meshes | solid voxels | collider boxes | import s |");
    println!("|---:|---:|---:|---:|---:|");
    for (seconds, s) in &imports {
        println!(
            "| {} | {} | {} | {} | {:.2} |",
            s.triangles, s.meshes, s.voxels, s.colliders, seconds
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// Mapping steps as an apartment's map grows, per engine.
fn map(engines: Vec<Rasteriser>, frames: usize) -> Result<()> {
    for rasteriser in engines {
        let name = rasteriser.describe();
        let (rows, quality) = crate::bench::bench_map(rasteriser, 320, 240, 10, frames)?;
        print_map_bench(&name, &rows, &quality);
    }
    Ok(())
}

/// Camera frames and physics steps per second.
fn sensor(world: &std::path::Path, frames: usize) -> Result<()> {
    let (device, rows) = crate::bench::bench_sensor(world, frames.max(1))?;
    println!("device: {device}");
    println!("| what | count | seconds | per second | x baseline |");
    println!("|---|---:|---:|---:|---:|");
    let baseline = rows
        .iter()
        .find(|r| r.what.contains("baseline"))
        .map(|r| r.rate());
    for row in &rows {
        let ratio = match baseline {
            Some(b) if row.what.starts_with("RGB-D") => {
                format!("{:.1}", row.rate() / b)
            }
            _ => String::from("-"),
        };
        println!(
            "| {} | {} | {:.3} | {:.1} | {ratio} |",
            row.what,
            row.count,
            row.seconds,
            row.rate()
        );
    }
    Ok(())
}

/// The engines `choices` resolve to, each once: `auto` on a machine without a hardware GPU is
/// the CPU engine, timed once even when `cpu` is also listed.
/// The engines to time: each choice with each subgroup setting, those that resolve to one
/// already listed (the same adapter and kernels) left out.
fn distinct_engines(choices: &[EngineChoice], subgroups: &[bool]) -> Vec<Rasteriser> {
    let mut engines: Vec<Rasteriser> = Vec::new();
    for &choice in choices {
        for &subgroups in subgroups {
            let options = GpuOptions {
                subgroups,
                ..GpuOptions::default()
            };
            let rasteriser = Rasteriser::select_with(choice, options);
            let name = rasteriser.describe();
            if engines.iter().any(|e| e.describe() == name) {
                println!("({choice:?} resolved to {name}, already timed)");
            } else {
                engines.push(rasteriser);
            }
        }
    }
    engines
}

fn print_render_bench(engine: &str, rows: &[crate::bench::RenderBenchRow]) {
    println!("engine: {engine}");
    println!("| resolution | Gaussians | mode | pixel-splat pairs | forward ms | loss ms | backward ms | Adam ms | iteration ms | pairs/s (M) | buffers created | submits | bytes up | bytes back |");
    println!("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        let stages = match r.stages {
            Some(s) => s.map(|v| format!("{:.2}", v * 1e3)),
            None => std::array::from_fn(|_| "-".to_string()),
        };
        let traffic = match r.traffic {
            Some(t) => [t.buffers, t.submits, t.uploaded, t.read_back].map(|v| v.to_string()),
            None => std::array::from_fn(|_| "-".to_string()),
        };
        println!(
            "| {}x{} | {} | {} | {} | {} | {} | {} | {} | {:.2} | {:.0} | {} | {} | {} | {} |",
            r.resolution.0,
            r.resolution.1,
            r.gaussians,
            r.mode,
            r.pairs,
            stages[0],
            stages[1],
            stages[2],
            stages[3],
            r.iteration * 1e3,
            r.pairs as f64 / r.iteration / 1e6,
            traffic[0],
            traffic[1],
            traffic[2],
            traffic[3],
        );
    }
}

/// The resident rows' GPU time per kernel (timestamps around each compute pass of one
/// iteration), one table per row that has them.
fn print_pass_times(rows: &[crate::bench::RenderBenchRow]) {
    for r in rows {
        let Some(passes) = &r.passes else { continue };
        let total: f64 = passes.iter().map(|(_, _, ms)| ms).sum();
        println!(
            "resident iteration by kernel, {}x{}, {} Gaussians (GPU timestamps, one iteration; sum {:.3} ms of {:.3} ms wall):",
            r.resolution.0,
            r.resolution.1,
            r.gaussians,
            total,
            r.iteration * 1e3
        );
        println!("| kernel | passes | GPU ms | share |");
        println!("|---|---:|---:|---:|");
        for (entry, count, ms) in passes {
            let share = if total > 0.0 { ms / total * 100.0 } else { 0.0 };
            println!("| {entry} | {count} | {ms:.3} | {share:.1}% |");
        }
    }
}

fn print_map_bench(
    engine: &str,
    rows: &[crate::bench::MapBenchRow],
    quality: &crate::bench::MapQuality,
) {
    println!("engine: {engine}; 320x240, 10 iterations per step, apartment tour");
    println!("| step | Gaussians | added | pruned | keyframe window | densify ms | optimise ms | prune ms | step ms | GPU buffers made, submits, MB up, MB back |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|");
    for r in rows {
        let s = r.report.seconds.map(|v| v * 1e3);
        let traffic = match r.traffic {
            Some(t) => format!(
                "{}, {}, {:.2}, {:.2}",
                t.buffers,
                t.submits,
                t.uploaded as f64 / 1e6,
                t.read_back as f64 / 1e6
            ),
            None => "-".into(),
        };
        println!(
            "| {} | {} | {} | {} | {} | {:.0} | {:.0} | {:.0} | {:.0} | {traffic} |",
            r.step,
            r.report.gaussians,
            r.report.added,
            r.report.pruned,
            r.report.window,
            s[0],
            s[1],
            s[2],
            r.seconds * 1e3
        );
    }
    let mut times: Vec<f64> = rows.iter().map(|r| r.seconds).collect();
    times.sort_by(f64::total_cmp);
    if let (Some(max), false) = (times.last(), times.is_empty()) {
        println!(
            "steps: {}, median {:.0} ms, max {:.0} ms; final map {} Gaussians",
            times.len(),
            times[times.len() / 2] * 1e3,
            max * 1e3,
            rows.last().map_or(0, |r| r.report.gaussians)
        );
    }
    println!(
        "held-out views: {}, mean PSNR {:.2} dB, mean depth MAE {:.2} cm",
        quality.views,
        quality.psnr,
        quality.depth_mae * 100.0
    );
}
