//! The `splatloop` command line.

use anyhow::{Context, Result};
use autonomy::splat::{EngineChoice, Rasteriser};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use splatloop::camera::SensorConfig;
use splatloop::record::{record, RecordConfig};
use splatloop::robot::Pose2;
use splatloop::spawn::{parse_pose, Spawn};
use std::path::PathBuf;

/// Headless closed-loop active mapping: a MuJoCo unicycle robot with an offscreen RGB-D
/// camera, an online Gaussian-splatting map and an exploration planner.
#[derive(Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    /// Log filter (error, warn, info, debug, trace, or a tracing directive).
    #[arg(long, global = true, default_value = "info", env = "SPLATLOOP_LOG")]
    log: String,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
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
    Bench {
        /// What to measure.
        #[arg(value_enum)]
        what: BenchTarget,
        /// World to measure in.
        #[arg(long, default_value = "worlds/room.xml")]
        world: PathBuf,
        /// Frames timed per resolution (sensor).
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
        #[arg(long, value_delimiter = ',', default_value = "cpu,auto")]
        engine: Vec<String>,
    },
}

#[derive(Subcommand)]
enum WorldCommand {
    /// Generate a world by seed: an apartment (3-6 rooms, 50-120 m2), an office (a corridor
    /// with 4-8 rooms, 80-200 m2) or a warehouse (shelving rows and walled rooms, 120-300 m2).
    /// Candidates that fail `world check` are never written; the next sub-seed is tried.
    Generate {
        /// Seed; the same seed and options give the same file, byte for byte.
        #[arg(long)]
        seed: u64,
        /// apartment, office or warehouse.
        #[arg(long)]
        kind: String,
        /// Floor area inside the outer walls, m2 (default: drawn from the kind's range).
        #[arg(long)]
        area: Option<f64>,
        /// MJCF file to write; it includes models/unicycle.xml and uses worlds/assets/ by
        /// paths relative to itself.
        #[arg(long)]
        out: PathBuf,
        /// Replace the file if it exists.
        #[arg(long)]
        overwrite: bool,
    },
    /// Import a textured OBJ + MTL scene (Blender, scans) as a world: visual meshes per object
    /// and material with their diffuse textures or colours, colliders from the scene voxelised
    /// at 5 cm (merged into boxes), the floor moved to z = 0, a spawn site.
    Import {
        /// The OBJ file; its MTL and textures are read from where it names them.
        scene: PathBuf,
        /// The file's up axis: y (OBJ's convention, Blender's default) or z.
        #[arg(long, default_value = "y")]
        up: String,
        /// Metres per file unit (0.01 for centimetres).
        #[arg(long, default_value_t = 1.0)]
        scale: f64,
        /// Height of the floor in the scene, metres after --up and --scale (default: the
        /// largest horizontal surface in the lowest third of the scene).
        #[arg(long, allow_hyphen_values = true)]
        floor: Option<f64>,
        /// Start pose x,y,yaw in the imported world (default: the free pose with the most room
        /// near the scene's centre).
        #[arg(long, value_parser = parse_pose, allow_hyphen_values = true)]
        spawn: Option<Pose2>,
        /// MJCF file to write; meshes and textures go to <name>_assets/ beside it.
        #[arg(long)]
        out: PathBuf,
        /// Replace earlier output.
        #[arg(long)]
        overwrite: bool,
    },
    /// Export a world's surfaces (primitives and meshes, with materials and textures) as a
    /// Y-up OBJ + MTL, for Blender and back.
    Export {
        /// MJCF world.
        world: PathBuf,
        /// OBJ file to write (the MTL and <name>_textures/ go beside it).
        #[arg(long)]
        out: PathBuf,
        /// Replace earlier output.
        #[arg(long)]
        overwrite: bool,
    },
    /// Generate the benchmark suite: PER_KIND worlds of each kind (seeds 1..=PER_KIND) and
    /// manifest.json (file, seed, kind, area, rooms, doors).
    Suite {
        /// Folder to write (worlds/suite in the repository).
        #[arg(long, default_value = "worlds/suite")]
        out: PathBuf,
        /// Worlds per kind.
        #[arg(long, default_value_t = 4)]
        per_kind: u64,
        /// Replace existing files.
        #[arg(long)]
        overwrite: bool,
    },
    /// Check a world: the spawn is collision-free and on a floor, the world is closed, every
    /// place the robot fits is reachable from the spawn, no geoms intersect. Prints the floor,
    /// free and reachable areas and the regions; exits non-zero when a problem is found.
    Check {
        /// MJCF world that includes the robot.
        world: PathBuf,
        /// Check from this start pose `x,y,yaw` instead of the world's spawn site.
        #[arg(long, value_parser = parse_pose, allow_hyphen_values = true)]
        spawn: Option<Pose2>,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
        /// Also draw the floor plan into this PNG (obstacles grey, reachable green,
        /// unreachable free space red, the spawn blue).
        #[arg(long)]
        plot: Option<PathBuf>,
    },
}

#[derive(Clone, Copy, ValueEnum)]
enum BenchTarget {
    /// RGB-D frames/s at 320x240 and 640x480, physics steps/s.
    Sensor,
    /// One mapping iteration (forward + loss + backward + Adam) of each splat engine.
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

#[derive(clap::Args)]
struct RunArgs {
    /// MJCF world that includes the robot (models/unicycle.xml).
    #[arg(long, default_value = "worlds/room.xml")]
    world: PathBuf,
    /// Planner: rtguide (RT-GuIDE: information-driven, on the map alone), fbe (frontier
    /// exploration, AG-SLAM's baseline), agslam (AG-SLAM's Fisher-information planner) or
    /// survey (full turns at the points of the world's floor plan, which it knows, that see
    /// the most: the bound to compare with). All but the survey drive through the same
    /// executor.
    #[arg(long, default_value = "rtguide")]
    planner: String,
    /// Simulated seconds to explore.
    #[arg(long, default_value_t = 60.0)]
    budget: f64,
    /// Seed (sensor noise, the hidden test set and a random spawn).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    options: EpisodeOptions,
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

/// Where a rerun recording of the episode goes (needs a build with `--features rerun`,
/// which scripts/setup.sh makes).
#[derive(clap::Args)]
struct RerunArgs {
    /// Write a rerun recording (.rrd: camera images and poses, path, plans, map, scalars);
    /// open it with `rerun FILE.rrd`.
    #[arg(long, value_name = "FILE.rrd")]
    rerun: Option<PathBuf>,
    /// Stream the recording to a running rerun viewer (HOST:PORT, e.g. 127.0.0.1:9876, or a
    /// rerun+http:// URL).
    #[arg(long, value_name = "ADDR")]
    rerun_connect: Option<String>,
}

impl RerunArgs {
    fn target(&self, map_every: usize) -> splatloop::rerun_log::RerunTarget {
        splatloop::rerun_log::RerunTarget {
            file: self.rerun.clone(),
            connect: self.rerun_connect.clone(),
            map_every,
        }
    }
}

#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
struct SweepArgs {
    #[command(subcommand)]
    step: Option<SweepStep>,
    /// Worlds: files and quoted shell patterns, comma-separated ("worlds/suite/*.xml").
    #[arg(long, value_delimiter = ',', required = true)]
    worlds: Vec<String>,
    /// Planners, comma-separated (rtguide, fbe, agslam, survey).
    #[arg(long, value_delimiter = ',', required = true)]
    planners: Vec<String>,
    /// Seeds: a list (1,2,5), an inclusive range (1..4), or both (1..3,7).
    #[arg(long, required = true)]
    seeds: Option<String>,
    /// Simulated seconds of every episode.
    #[arg(long, conflicts_with = "budget_survey_factor")]
    budget: Option<f64>,
    /// Run the survey first in each world and seed, then give every planner F times the
    /// survey's time there (the comparison protocol).
    #[arg(long, value_name = "F")]
    budget_survey_factor: Option<f64>,
    /// The survey's own budget with --budget-survey-factor, simulated seconds.
    #[arg(long, default_value_t = 900.0)]
    survey_budget: f64,
    #[command(flatten)]
    options: EpisodeOptions,
    /// The sweep's folder (a rerun with the same settings resumes it).
    #[arg(long, required = true)]
    out: Option<PathBuf>,
    /// Episodes at once (local backend; with ray, the most in flight).
    #[arg(long)]
    jobs: Option<usize>,
    /// local (child processes here), ray (a task per episode on a Ray cluster) or slurm
    /// (write an sbatch array script and its submit script; runs nothing).
    #[arg(long, value_enum, default_value = "local")]
    backend: SweepBackend,
    /// Ray cluster address (`ray start --head` prints it); none starts a local Ray for the
    /// sweep.
    #[arg(long)]
    ray_address: Option<String>,
    /// The Python with Ray (default: .venv/bin/python of the checkout, as scripts/setup.sh
    /// makes it, else python3).
    #[arg(long, env = "SPLATLOOP_PYTHON")]
    ray_python: Option<PathBuf>,
    /// CPUs each episode reserves (Ray's num_cpus, Slurm's --cpus-per-task).
    #[arg(long, default_value_t = 1)]
    cpus_per_episode: usize,
}

#[derive(Subcommand)]
enum SweepStep {
    /// Run one episode of the sweep in OUT by its index (a Slurm array task's command);
    /// nothing when it is already complete.
    Episode {
        /// The sweep's folder.
        #[arg(long)]
        out: PathBuf,
        /// The episode's index (results.csv's `index`).
        #[arg(long)]
        index: usize,
    },
    /// Gather results.csv, summary.md, summary.png and coverage_over_time.png from the
    /// episodes in OUT (what a sweep does when it ends).
    Collect {
        /// The sweep's folder.
        #[arg(long)]
        out: PathBuf,
    },
}

#[derive(Clone, Copy, ValueEnum)]
enum SweepBackend {
    Local,
    Ray,
    Slurm,
}

/// The options of an episode that a sweep passes on to every one of its episodes (it owns
/// the world, planner, budget, seed and folder); serialised into sweep.json by their long
/// names, and turned back into those flags for each episode.
#[derive(clap::Args, serde::Serialize, serde::Deserialize, Debug, Clone, PartialEq)]
struct EpisodeOptions {
    /// RT-GuIDE's uncertainty of a Gaussian: l2 (its displacement's norm, the paper's) or sq
    /// (the squared norm: the paper's Table II ablation).
    #[arg(long, default_value = "l2")]
    rtguide_uncertainty: String,
    /// RT-GuIDE: seconds of each plan the robot drives before the next plan may replace it
    /// (0: the paper's replanning every second; more is a flagged extension).
    #[arg(long, default_value_t = 0.0)]
    rtguide_commit: f64,
    /// RT-GuIDE: reach a viewpoint along the free space of a 2D evidence grid (built from
    /// the depth frames) when its straight edge into the graph crosses the map (a flagged
    /// extension; off is the paper's straight edges).
    #[arg(long, action = clap::ArgAction::Set, num_args = 0..=1, default_value_t = false,
          default_missing_value = "true", value_name = "BOOL")]
    rtguide_free_space_edges: bool,
    /// RT-GuIDE: give unseen space utility, a viewpoint beside each frontier of a 2D evidence
    /// grid worth the uncertainty of unseen space, reached along the grid's free space, and
    /// candidates clear of unseen cells (a flagged extension, on by default: the paper's
    /// regions of Gaussians alone leave rooms unentered; `false`, with `--rtguide-frontiers-first
    /// false --rtguide-tour false`, is the paper's planner).
    // Sweeps begun before the flag existed ran the paper's planner: their settings lack it.
    #[arg(long, action = clap::ArgAction::Set, num_args = 0..=1, default_value_t = true,
          default_missing_value = "true", value_name = "BOOL")]
    #[serde(default)]
    rtguide_frontier_regions: bool,
    /// RT-GuIDE with frontier regions: while a frontier viewpoint is offered, regions'
    /// viewpoints yield to it, so the robot does not linger among nearby regions while a
    /// room is left unseen farther off (a flagged extension, on by default; `false`: they
    /// compete by Omega / e^d).
    // Sweeps begun before the flag existed ran without it: their settings lack it.
    #[arg(long, action = clap::ArgAction::Set, num_args = 0..=1, default_value_t = true,
          default_missing_value = "true", value_name = "BOOL")]
    #[serde(default)]
    rtguide_frontiers_first: bool,
    /// RT-GuIDE with frontier regions: end the episode once no frontier is left to view and
    /// every region's Gaussians have settled (they move less per mapping step than Adam
    /// moves one pulled steadily): no loops among revisits, but no refinement either, so
    /// the map's PSNR and density stop where the exploration did (a flagged extension, off
    /// by default: the paper's planner runs to the budget; BENCHMARKS.md has both).
    // Sweeps begun before the flag existed ran to the budget: their settings lack it.
    #[arg(long, action = clap::ArgAction::Set, num_args = 0..=1, default_value_t = false,
          default_missing_value = "true", value_name = "BOOL")]
    #[serde(default)]
    rtguide_finish: bool,
    /// RT-GuIDE: set reached viewpoints aside until no other can be chosen, then offer them
    /// all again, so the revisits once the frontiers are spent tour the map's regions instead
    /// of circling among the viewpoints of the room the robot stands in (a flagged extension,
    /// on by default; `false`: the paper's rule, a reached viewpoint keeps a tenth of its
    /// utility; BENCHMARKS.md has both).
    // Sweeps begun before the flag existed ran without it: their settings lack it.
    #[arg(long, action = clap::ArgAction::Set, num_args = 0..=1, default_value_t = true,
          default_missing_value = "true", value_name = "BOOL")]
    #[serde(default)]
    rtguide_tour: bool,
    /// agslam: weight of the localisation term log det(J^T J) in the goal score (the
    /// authors' code's 0.5; 0 is the paper's Table 3 ablation).
    #[arg(long, default_value_t = 0.5)]
    pose_weight: f64,
    /// agslam: goal poses sampled around the chosen frontier cluster per plan (the authors
    /// use 256; the default is what fits the 1 s planning period on one CPU core, see
    /// BENCHMARKS.md).
    #[arg(long, default_value_t = autonomy::explore::agslam::AgslamConfig::default().candidates)]
    agslam_candidates: usize,
    /// agslam: keep H_train incrementally (each keyframe's Fisher added once) or recompute it
    /// over every keyframe at each plan (full, as the authors' code; slower, same choices on
    /// a settled map).
    #[arg(long, default_value = "incremental")]
    agslam_train: String,
    /// Camera frames per simulated second.
    #[arg(long, default_value_t = 5.0)]
    camera_rate: f64,
    /// Adam iterations per mapping step (one step per second).
    #[arg(long, default_value_t = 10)]
    iterations: usize,
    /// wall: mapping and planning time is charged to simulated time (the robot keeps driving
    /// its previous plan); none: the world waits.
    #[arg(long, default_value = "wall")]
    latency: String,
    #[command(flatten)]
    #[serde(flatten)]
    view: ViewArgs,
    /// Start pose: site (the world's `spawn` site), random (seeded by --seed, anywhere the
    /// robot can reach from the site with 0.6 m of room), or x,y,yaw (metres, radians).
    #[arg(long, default_value = "site", allow_hyphen_values = true, value_parser = check_spawn)]
    spawn: String,
    /// Spherical-harmonic degree of map.ply: 0 (compact, read by every viewer) or 3 (zero
    /// f_rest_0..44 added, as graphdeco-inria's reference loader requires by default).
    #[arg(long, default_value_t = 0, value_parser = parse_sh_degree)]
    ply_sh_degree: u8,
    /// Hidden test views for the evaluation, sampled in free space (0: skip).
    #[arg(long, default_value_t = 100)]
    test_views: usize,
}

/// `--spawn` is kept as typed (so a sweep can pass it on) but checked when parsed.
fn check_spawn(text: &str) -> Result<String, String> {
    text.parse::<Spawn>().map(|_| text.to_string())
}

/// The camera size and splat engine of the commands that render a map.
#[derive(clap::Args, serde::Serialize, serde::Deserialize, Debug, Clone, PartialEq)]
struct ViewArgs {
    /// Splat engine: auto (a hardware GPU if any), cpu or gpu.
    #[arg(long, default_value = "auto")]
    engine: String,
    /// Image width, pixels.
    #[arg(long, default_value_t = 320)]
    width: u32,
    /// Image height, pixels.
    #[arg(long, default_value_t = 240)]
    height: u32,
}

#[derive(clap::Args)]
struct EvalArgs {
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

#[derive(clap::Args)]
struct RenderArgs {
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
    #[arg(long, default_value = "auto")]
    engine: String,
}

#[derive(clap::Args)]
struct RecordArgs {
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
    /// Seed for every random choice.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Start pose `x,y,theta` (metres, radians); default: the world's `spawn` site.
    #[arg(long, value_parser = parse_pose, allow_hyphen_values = true)]
    start: Option<Pose2>,
    #[command(flatten)]
    rerun: RerunArgs,
}

fn parse_sh_degree(text: &str) -> Result<u8, String> {
    match text {
        "0" => Ok(0),
        "3" => Ok(3),
        other => Err(format!("{other:?}: map.ply is written at degree 0 or 3")),
    }
}

fn main() -> std::process::ExitCode {
    use clap::{CommandFactory, FromArgMatches};
    // --version names the MuJoCo this binary runs (and the one it was built against); the
    // string lives as long as the process, as clap wants.
    let version = format!(
        "{} (MuJoCo {}, built against {})",
        env!("CARGO_PKG_VERSION"),
        splatloop::mujoco::version(),
        splatloop::mujoco::HEADER_VERSION
    );
    let cli = match Cli::command()
        .version(&*version.leak())
        .try_get_matches()
        .and_then(|m| Cli::from_arg_matches(&m))
    {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    let filter = tracing_subscriber::EnvFilter::try_new(&cli.log)
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .init();
    match run(cli.command) {
        Ok(Some(code)) => std::process::ExitCode::from(code),
        Ok(None) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// Runs a command; `Some(code)` when it was stopped by a signal and must exit with `code`.
fn run(command: Command) -> Result<Option<u8>> {
    let done = |r: Result<()>| r.map(|()| None);
    match command {
        Command::Record(args) => done(run_record(args)),
        Command::Run(args) => run_run(args),
        Command::Sweep(args) => run_sweep(args),
        Command::Eval(args) => done(run_eval(args)),
        Command::Render(args) => done(run_render(args)),
        Command::World(command) => done(run_world(command)),
        Command::Bench {
            what,
            world,
            frames,
            iterations,
            gaussians,
            engine,
        } => done(match what {
            BenchTarget::Render => {
                for rasteriser in distinct_engines(&engine)? {
                    let name = rasteriser.describe();
                    let rows = splatloop::bench::bench_render(
                        &rasteriser,
                        &[(320, 240), (640, 480)],
                        &gaussians,
                        iterations.max(1),
                    )?;
                    print_render_bench(&name, &rows);
                }
                Ok(())
            }
            BenchTarget::Loss => {
                let rows = splatloop::bench::bench_loss(&[(320, 240), (640, 480)], iterations);
                println!("threads: {}", rayon::current_num_threads());
                println!("| resolution | reference ms | SIMD ms | speed-up |");
                println!("|---|---:|---:|---:|");
                for r in &rows {
                    println!(
                        "| {}x{} | {:.2} | {:.2} | {:.1}x |",
                        r.resolution.0,
                        r.resolution.1,
                        r.reference * 1e3,
                        r.simd * 1e3,
                        r.reference / r.simd
                    );
                }
                Ok(())
            }
            BenchTarget::Plan => {
                let counts = if gaussians == [10_000, 100_000, 1_000_000] {
                    vec![10_000, 100_000, 1_000_000, 3_000_000]
                } else {
                    gaussians.clone()
                };
                let gpu = engine.iter().any(|e| e != "cpu");
                let rows = splatloop::bench::bench_plan(&counts, 100_000, gpu);
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
                let (build, score, brute) = splatloop::bench::bench_viewpoints(1_000_000, 500);
                println!(
                    "500 viewpoints over 1e6 Gaussians: grid build {:.1} ms, scoring {:.2} ms ({:.1} us each); brute force {:.2} ms each",
                    build * 1e3,
                    score * 1e3,
                    score * 1e6 / 500.0,
                    brute * 1e3
                );
                Ok(())
            }
            BenchTarget::Planners => {
                let candidates = autonomy::explore::agslam::AgslamConfig::default().candidates;
                println!("| Gaussians | planner | plan ms (median of 3) | candidates | outcome |");
                println!("|---:|---|---:|---:|---|");
                for r in splatloop::bench::bench_planners(&gaussians, candidates) {
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
            BenchTarget::World => {
                let dir = tempfile_dir()?;
                let rows = splatloop::bench_worlds::bench_generate(&dir, 4)?;
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
                let imports =
                    splatloop::bench_worlds::bench_import(&scene, &dir, &[100_000, 1_000_000])?;
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
            BenchTarget::Map => {
                for rasteriser in distinct_engines(&engine)? {
                    let name = rasteriser.describe();
                    let (rows, quality) = splatloop::bench::bench_map(rasteriser, 320, 240, 10)?;
                    print_map_bench(&name, &rows, &quality);
                }
                Ok(())
            }
            BenchTarget::Sensor => {
                let (device, rows) = splatloop::bench::bench_sensor(&world, frames.max(1))?;
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
        }),
    }
}

/// A fresh scratch folder under the system's temporary directory.
fn tempfile_dir() -> Result<std::path::PathBuf> {
    let dir = std::env::temp_dir().join(format!("splatloop-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    Ok(dir)
}

/// The engines `choices` resolve to, each once: `auto` on a machine without a hardware GPU is
/// the CPU engine, timed once even when `cpu` is also listed.
fn distinct_engines(choices: &[String]) -> Result<Vec<Rasteriser>> {
    let mut engines: Vec<Rasteriser> = Vec::new();
    for choice in choices {
        let choice: EngineChoice = choice.parse().map_err(anyhow::Error::msg)?;
        let rasteriser = Rasteriser::select(choice);
        let name = rasteriser.describe();
        if engines.iter().any(|e| e.describe() == name) {
            println!("({choice:?} resolved to {name}, already timed)");
        } else {
            engines.push(rasteriser);
        }
    }
    Ok(engines)
}

fn print_render_bench(engine: &str, rows: &[splatloop::bench::RenderBenchRow]) {
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

fn print_map_bench(
    engine: &str,
    rows: &[splatloop::bench::MapBenchRow],
    quality: &splatloop::bench::MapQuality,
) {
    println!("engine: {engine}; 320x240, 10 iterations per step, apartment tour");
    println!("| step | Gaussians | added | pruned | keyframe window | densify ms | optimise ms | prune ms | step ms |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        let s = r.report.seconds.map(|v| v * 1e3);
        println!(
            "| {} | {} | {} | {} | {} | {:.0} | {:.0} | {:.0} | {:.0} |",
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

fn run_run(args: RunArgs) -> Result<Option<u8>> {
    use splatloop::episode::{run_episode, Latency, RunConfig};
    let latency = match args.options.latency.as_str() {
        "wall" => Latency::Wall,
        "none" => Latency::None,
        other => anyhow::bail!("unknown latency model {other:?}; use wall or none"),
    };
    let config = RunConfig {
        world: args.world,
        budget: args.budget,
        seed: args.seed,
        camera_rate: args.options.camera_rate,
        think_period: 1.0,
        iterations: args.options.iterations,
        latency,
        planner: args.planner.parse().map_err(anyhow::Error::msg)?,
        planner_options: splatloop::episode::PlannerOptions {
            rtguide_uncertainty: match args.options.rtguide_uncertainty.as_str() {
                "l2" => autonomy::mapping::UncertaintyNorm::L2,
                "sq" => autonomy::mapping::UncertaintyNorm::Sq,
                other => anyhow::bail!("unknown --rtguide-uncertainty {other:?}; use l2 or sq"),
            },
            rtguide_commit: args.options.rtguide_commit,
            rtguide_free_space_edges: args.options.rtguide_free_space_edges,
            rtguide_frontier_regions: args.options.rtguide_frontier_regions,
            rtguide_frontiers_first: args.options.rtguide_frontiers_first,
            rtguide_finish: args.options.rtguide_finish,
            rtguide_tour: args.options.rtguide_tour,
            pose_weight: args.options.pose_weight,
            agslam_candidates: args.options.agslam_candidates,
            agslam_train: match args.options.agslam_train.as_str() {
                "incremental" => autonomy::explore::agslam::TrainMode::Incremental,
                "full" => autonomy::explore::agslam::TrainMode::Full,
                other => anyhow::bail!("unknown --agslam-train {other:?}; use incremental or full"),
            },
        },
        sensor: SensorConfig {
            width: args.options.view.width,
            height: args.options.view.height,
            ..SensorConfig::default()
        },
        test_views: args.options.test_views,
        ply_sh_degree: args.options.ply_sh_degree,
        spawn: args.options.spawn.parse().map_err(anyhow::Error::msg)?,
        engine: args
            .options
            .view
            .engine
            .parse()
            .map_err(anyhow::Error::msg)?,
        overwrite: args.overwrite,
        rerun: args.rerun.target(args.rerun_map_every),
        stop: splatloop::episode::StopRequest::default(),
        fail_writes_after: None,
        out: args.out,
    };
    // Ctrl-C or a cluster's SIGTERM stops the episode at its next tick; it is still written.
    for (signal, code) in [
        (
            signal_hook::consts::SIGINT,
            splatloop::episode::StopRequest::SIGINT,
        ),
        (
            signal_hook::consts::SIGTERM,
            splatloop::episode::StopRequest::SIGTERM,
        ),
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
    let metrics = run_episode(&config, &mut |p| {
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
    .with_context(|| format!("exploring {} failed", config.world.display()))?;
    bar.finish();
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
        config.out.display()
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

fn run_sweep(args: SweepArgs) -> Result<Option<u8>> {
    use splatloop::sweep::{self, Backend, Sweep, SweepSpec};
    let binary = std::env::current_exe().context("cannot find the splatloop binary")?;
    let gathered = |sweep: &Sweep| -> Result<()> {
        let rows = sweep::results::collect(sweep)?;
        let complete = rows.iter().filter(|r| r.status == "complete").count();
        println!(
            "{}: {complete} of {} episodes complete; wrote results.csv, summary.md, summary.png and coverage_over_time.png",
            sweep.out.display(),
            rows.len()
        );
        Ok(())
    };
    match args.step {
        Some(SweepStep::Collect { out }) => {
            gathered(&Sweep::load(&out)?)?;
            return Ok(None);
        }
        Some(SweepStep::Episode { out, index }) => {
            let sweep = Sweep::load(&out)?;
            return match sweep::run_one(&sweep, index, &binary)? {
                None => {
                    println!(
                        "episode {index} is complete: {}",
                        sweep.folder(&sweep.episodes[index]).display()
                    );
                    Ok(None)
                }
                Some(error) => anyhow::bail!("episode {index} failed: {error}"),
            };
        }
        None => {}
    }
    let out = args.out.context("--out is required")?;
    let budget = match (args.budget, args.budget_survey_factor) {
        (Some(s), None) if s > 0.0 && s.is_finite() => sweep::Budget::Seconds(s),
        (None, Some(f)) if f > 0.0 && f.is_finite() => sweep::Budget::SurveyFactor {
            factor: f,
            survey_budget: args.survey_budget,
        },
        (None, None) => anyhow::bail!(
            "give each episode's budget: --budget SECONDS, or --budget-survey-factor F"
        ),
        _ => {
            anyhow::bail!("the budget must be a positive number of seconds (or a positive factor)")
        }
    };
    let run_options = match serde_json::to_value(&args.options)? {
        serde_json::Value::Object(map) => map,
        _ => anyhow::bail!("the run options did not serialise as an object"),
    };
    let spec = SweepSpec {
        worlds: sweep::resolve_worlds(&args.worlds)?,
        planners: args.planners,
        seeds: sweep::parse_seeds(args.seeds.as_deref().unwrap_or_default())?,
        budget,
        run_options,
    };
    let sweep = Sweep::open(&out, spec)?;
    let backend = match args.backend {
        SweepBackend::Local => Backend::Local {
            jobs: args.jobs.unwrap_or(1),
        },
        SweepBackend::Ray => Backend::Ray {
            address: args.ray_address,
            python: args.ray_python.unwrap_or_else(|| default_python(&binary)),
            jobs: args.jobs,
            cpus_per_episode: args.cpus_per_episode as f64,
        },
        SweepBackend::Slurm => {
            let files = sweep::slurm::write_slurm(&sweep, &binary, args.cpus_per_episode)?;
            println!(
                "wrote {} (array task N runs episode N of {}) and {}; submit with: bash {}",
                files.script.display(),
                sweep.episodes.len(),
                files.submit.display(),
                files.submit.display()
            );
            return Ok(None);
        }
    };
    let mut bar = Progress::new(
        sweep.episodes.len() as u64,
        "{spinner} sweep [{bar:30}] {msg} ({elapsed} wall)",
        "sweep",
    );
    let report = sweep::run_sweep(&sweep, &backend, &binary, &mut |p| {
        bar.update((p.complete + p.failed) as u64, || {
            let eta = p
                .eta_seconds
                .map_or(String::new(), |s| format!(", eta {:.0} s", s));
            format!(
                "{}/{} complete, {} running, {} failed{eta}",
                p.complete, p.total, p.running, p.failed
            )
        });
    })?;
    bar.finish();
    println!(
        "sweep: {} episodes: {} complete before, {} run now, {} failed",
        report.total,
        report.skipped,
        report.ran,
        report.failed.len()
    );
    gathered(&sweep)?;
    if !report.failed.is_empty() {
        for (index, error) in &report.failed {
            eprintln!(
                "episode {index} failed: {}",
                error.lines().next().unwrap_or("")
            );
        }
        anyhow::bail!(
            "{} episodes failed; results.csv and summary.md say which (rerun the same command to retry them)",
            report.failed.len()
        );
    }
    Ok(None)
}

/// The Python that Ray is installed for: the checkout's .venv (scripts/setup.sh makes it),
/// found from the working folder or from the binary's place in target/, else python3.
fn default_python(binary: &std::path::Path) -> PathBuf {
    let venv = |root: &std::path::Path| root.join(".venv/bin/python");
    let candidates = std::iter::once(PathBuf::from("."))
        .chain(binary.ancestors().skip(1).take(4).map(PathBuf::from));
    for root in candidates {
        if venv(&root).exists() {
            return venv(&root);
        }
    }
    PathBuf::from("python3")
}

fn run_eval(args: EvalArgs) -> Result<()> {
    for out in [&args.out, &args.surface_out].into_iter().flatten() {
        splatloop::dataset::refuse_overwrite(out, args.overwrite, &[&args.map, &args.world])?;
    }
    let sensor = SensorConfig {
        width: args.view.width,
        height: args.view.height,
        ..SensorConfig::default()
    };
    let (evaluation, surface) = splatloop::novel_view::evaluate_map_surface(
        &args.map,
        &args.world,
        &sensor,
        args.test_views,
        args.seed,
        args.view.engine.parse().map_err(anyhow::Error::msg)?,
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

fn run_render(args: RenderArgs) -> Result<()> {
    let camera = match args.camera {
        Some(c) => c,
        None => args
            .poses
            .parent()
            .unwrap_or(std::path::Path::new("."))
            .join("camera.json"),
    };
    let config = splatloop::novel_view::RenderConfig {
        map: args.map,
        poses: args.poses,
        camera,
        out: args.out,
        engine: args.engine.parse().map_err(anyhow::Error::msg)?,
        overwrite: args.overwrite,
    };
    let mut bar = Progress::new(
        0,
        "{spinner} rendering [{bar:30}] {pos}/{len} views ({eta})",
        "rendering",
    );
    let frames = splatloop::novel_view::render_map(&config, &mut |done, total| {
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

fn run_world(command: WorldCommand) -> Result<()> {
    use splatloop::worldgen::{generate, GenerateConfig, WorldKind};
    let mut say_rejected = |sub_seed: u32, why: &str| {
        eprintln!(
            "candidate {sub_seed} rejected ({why}); trying candidate {}",
            sub_seed + 1
        );
    };
    match command {
        WorldCommand::Generate {
            seed,
            kind,
            area,
            out,
            overwrite,
        } => {
            let kind: WorldKind = kind.parse().map_err(anyhow::Error::msg)?;
            let config = GenerateConfig {
                kind,
                seed,
                area,
                out,
                overwrite,
            };
            let world = generate(&config, &mut say_rejected)
                .with_context(|| format!("generating {} failed", config.out.display()))?;
            println!(
                "wrote {} ({} seed {}, candidate {}): {:.1} m2, {} rooms, {} doors, {} geoms, {:.1}% of the free space reachable",
                world.file.display(),
                kind.name(),
                seed,
                world.sub_seed,
                world.area,
                world.rooms,
                world.doors,
                world.report.geoms,
                100.0 * world.report.reachable_share
            );
            Ok(())
        }
        WorldCommand::Import {
            scene,
            up,
            scale,
            floor,
            spawn,
            out,
            overwrite,
        } => {
            let config = splatloop::scene::import::ImportConfig {
                scene,
                up: up.parse().map_err(anyhow::Error::msg)?,
                scale,
                floor,
                spawn,
                out,
                overwrite,
            };
            let started = std::time::Instant::now();
            let s = splatloop::scene::import::import_scene(&config)
                .with_context(|| format!("importing {} failed", config.scene.display()))?;
            let (lo, hi) = s.bounds;
            println!(
                "wrote {} in {:.1} s: bounds x {:.2} .. {:.2}, y {:.2} .. {:.2}, z {:.2} .. {:.2} m (floor found at {:.3} m, moved to 0); {} triangles, {} meshes, {} materials ({} textured), {} collider boxes over {} voxels; spawn ({:.2}, {:.2}, yaw {:.2})",
                s.out.display(), started.elapsed().as_secs_f64(), lo[0], hi[0], lo[1], hi[1], lo[2], hi[2], s.floor_height, s.triangles, s.meshes, s.materials, s.textures, s.colliders, s.voxels, s.spawn.x, s.spawn.y, s.spawn.theta
            );
            Ok(())
        }
        WorldCommand::Export {
            world,
            out,
            overwrite,
        } => {
            let loaded = splatloop::world::World::load(&world, &SensorConfig::default())
                .with_context(|| format!("exporting {} failed", world.display()))?;
            let s = splatloop::scene::export::export_world(&loaded, &out, overwrite)
                .with_context(|| format!("exporting {} failed", world.display()))?;
            println!(
                "wrote {}: {} objects, {} triangles, {} materials, {} textures (Y up; import with `splatloop world import`)",
                s.obj.display(), s.objects, s.triangles, s.materials, s.textures
            );
            Ok(())
        }
        WorldCommand::Suite {
            out,
            per_kind,
            overwrite,
        } => {
            let mut manifest = Vec::new();
            for kind in WorldKind::ALL {
                for seed in 1..=per_kind {
                    let file = out.join(format!("{}_{seed:02}.xml", kind.name()));
                    let config = GenerateConfig {
                        kind,
                        seed,
                        area: None,
                        out: file,
                        overwrite,
                    };
                    let world = generate(&config, &mut say_rejected)
                        .with_context(|| format!("generating {} failed", config.out.display()))?;
                    println!(
                        "wrote {}: {:.1} m2, {} rooms",
                        world.file.display(),
                        world.area,
                        world.rooms
                    );
                    manifest.push(serde_json::json!({
                        "file": world.file.file_name().map(|n| n.to_string_lossy().into_owned()),
                        "kind": kind.name(),
                        "seed": seed,
                        "sub_seed": world.sub_seed,
                        "area_m2": (world.area * 10.0).round() / 10.0,
                        "rooms": world.rooms,
                        "doors": world.doors,
                        "regions": world.report.regions,
                    }));
                }
            }
            let path = out.join("manifest.json");
            std::fs::write(&path, serde_json::to_string_pretty(&manifest)? + "\n")
                .with_context(|| format!("cannot write {}", path.display()))?;
            println!("wrote {}", path.display());
            Ok(())
        }
        WorldCommand::Check {
            world,
            spawn,
            json,
            plot,
        } => {
            let mut loaded = splatloop::world::World::load(&world, &SensorConfig::default())
                .with_context(|| format!("checking {} failed", world.display()))?;
            if let Some(pose) = spawn {
                loaded.set_start(pose);
            }
            let (report, plan) = splatloop::world_check::check_world(&loaded)?;
            if let Some(png) = &plot {
                let reachable = plan.reachable_from(report.spawn.x, report.spawn.y);
                splatloop::plot::write_floor_plan_png(png, &plan, &reachable, report.spawn)?;
            }
            if json {
                println!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                print_world_report(&world, &report);
            }
            if !report.ok() {
                anyhow::bail!(
                    "{} has {} problem(s)",
                    world.display(),
                    report.problems.len()
                );
            }
            Ok(())
        }
    }
}

fn print_world_report(path: &std::path::Path, r: &splatloop::world_check::WorldReport) {
    let ((x0, y0), (x1, y1)) = (
        (r.bounds.0[0], r.bounds.0[1]),
        (r.bounds.1[0], r.bounds.1[1]),
    );
    println!("world: {}", path.display());
    if r.geoms == 0 {
        println!("bounds: no collidable geoms besides the robot's");
    } else {
        println!(
            "bounds: x {x0:.2} .. {x1:.2}, y {y0:.2} .. {y1:.2} m; {} collidable geoms",
            r.geoms
        );
    }
    println!(
        "floor area (inside the outer walls): {:.1} m2",
        r.floor_area
    );
    println!(
        "free area (no obstacle at the robot's heights): {:.1} m2",
        r.free_area
    );
    println!(
        "robot area (clearance {:.2} m): {:.1} m2, {:.1}% reachable from the spawn ({:.2}, {:.2}, yaw {:.2})",
        r.clearance,
        r.robot_area,
        100.0 * r.reachable_share,
        r.spawn.x,
        r.spawn.y,
        r.spawn.theta
    );
    println!(
        "regions (joined only through openings under 1.45 m): {}",
        r.regions
    );
    if r.ok() {
        println!("problems: none");
    } else {
        println!("problems:");
        for p in &r.problems {
            println!("  - {p}");
        }
    }
}

fn print_evaluation(e: &splatloop::evaluate::Evaluation) {
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

/// Progress for a person: an indicatif bar on a terminal; without one (CI logs, cluster
/// jobs), where the bar would draw nothing, a plain line on stderr every tenth of the work or
/// every 30 s.
struct Progress {
    bar: ProgressBar,
    what: &'static str,
    plain: bool,
    started: std::time::Instant,
    last_line: std::time::Instant,
    last_tenth: u64,
}

impl Progress {
    /// A bar of `length` steps drawn with `template` (indicatif's default style if the
    /// template does not parse); `what` names the work in plain lines.
    fn new(length: u64, template: &str, what: &'static str) -> Self {
        use std::io::IsTerminal;
        let bar = ProgressBar::new(length);
        bar.set_style(
            ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        let now = std::time::Instant::now();
        Progress {
            bar,
            what,
            plain: !std::io::stderr().is_terminal(),
            started: now,
            last_line: now,
            last_tenth: 0,
        }
    }

    fn set_length(&self, length: u64) {
        self.bar.set_length(length);
    }

    /// Moves to `position` with `message` (built only when it is shown).
    fn update(&mut self, position: u64, message: impl FnOnce() -> String) {
        self.bar.set_position(position);
        if !self.plain {
            self.bar.set_message(message());
            return;
        }
        let length = self.bar.length().unwrap_or(0).max(1);
        let tenth = (10 * position / length).min(10);
        if tenth > self.last_tenth || self.last_line.elapsed().as_secs_f64() >= 30.0 {
            self.last_tenth = tenth;
            self.last_line = std::time::Instant::now();
            eprintln!(
                "{}: {} ({}%, {:.0} s wall)",
                self.what,
                message(),
                100 * position.min(length) / length,
                self.started.elapsed().as_secs_f64()
            );
        }
    }

    fn finish(&self) {
        self.bar.finish_and_clear();
        if self.plain {
            eprintln!(
                "{}: done (100%, {:.0} s wall)",
                self.what,
                self.started.elapsed().as_secs_f64()
            );
        }
    }
}

fn run_record(args: RecordArgs) -> Result<()> {
    let config = RecordConfig {
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
            ..SensorConfig::default()
        },
        start: args.start,
        overwrite: args.overwrite,
        rerun: args.rerun.target(1),
        out: args.out,
    };
    let mut bar = Progress::new(
        (config.duration * 1000.0).round() as u64,
        "{spinner} recording [{bar:30}] {msg} sim s ({elapsed} wall, eta {eta})",
        "recording",
    );
    let total = config.duration;
    let summary = record(&config, &mut |t| {
        bar.update((t * 1000.0) as u64, || format!("{t:.1}/{total:.0} sim s"));
    })
    .with_context(|| format!("recording {} failed", config.world.display()))?;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The options as `splatloop run` parses them from `words`.
    fn run_options(words: &[String]) -> EpisodeOptions {
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
        assert!(defaults.rtguide_frontier_regions && !defaults.rtguide_free_space_edges);
        assert!(defaults.rtguide_frontiers_first && !defaults.rtguide_finish);
        assert!(defaults.rtguide_tour);
        for switches in 0..32 {
            let options = EpisodeOptions {
                rtguide_frontier_regions: switches & 1 != 0,
                rtguide_free_space_edges: switches & 2 != 0,
                rtguide_frontiers_first: switches & 4 != 0,
                rtguide_finish: switches & 8 != 0,
                rtguide_tour: switches & 16 != 0,
                ..defaults.clone()
            };
            let map = match serde_json::to_value(&options).expect("serialises") {
                serde_json::Value::Object(map) => map,
                other => panic!("not an object: {other}"),
            };
            let words = splatloop::sweep::spec::option_words(&map);
            assert_eq!(run_options(&words), options, "{words:?}");
        }
        // A bare switch is on; sweeps from before the frontier switches (no keys)
        // read as the paper's planner.
        let bare = run_options(&["--rtguide-free-space-edges".into()]);
        assert!(bare.rtguide_free_space_edges);
        let mut old = match serde_json::to_value(&defaults).expect("serialises") {
            serde_json::Value::Object(map) => map,
            other => panic!("not an object: {other}"),
        };
        old.remove("rtguide_frontier_regions");
        old.remove("rtguide_frontiers_first");
        old.remove("rtguide_finish");
        old.remove("rtguide_tour");
        let read: EpisodeOptions =
            serde_json::from_value(serde_json::Value::Object(old)).expect("reads");
        assert!(!read.rtguide_frontier_regions && !read.rtguide_frontiers_first);
        assert!(!read.rtguide_finish && !read.rtguide_tour);
    }
}
