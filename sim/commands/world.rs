//! `splatloop world`: generate, import, export, the suite, and check.

use crate::camera::SensorConfig;
use crate::robot::Pose2;
use crate::scene::Up;
use crate::spawn::parse_pose;
use crate::worldgen::{GenerateConfig, WorldKind};
use anyhow::{Context, Result};
use clap::Subcommand;
use std::path::PathBuf;

/// `splatloop world`'s subcommands.
#[derive(Subcommand)]
pub enum WorldCommand {
    /// Generate a world by seed: an apartment (3-6 rooms, 50-120 m2), an office (a corridor
    /// with 4-8 rooms, 80-200 m2) or a warehouse (shelving rows and walled rooms, 120-300 m2).
    /// Candidates that fail `world check` are never written; the next sub-seed is tried.
    Generate {
        /// Seed; the same seed and options give the same file, byte for byte.
        #[arg(long)]
        seed: u64,
        /// apartment, office or warehouse.
        #[arg(long, value_enum)]
        kind: WorldKind,
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
        #[arg(long, value_enum, ignore_case = true, default_value_t = Up::Y)]
        up: Up,
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
        /// Replace an existing --plot file (never the world itself).
        #[arg(long)]
        overwrite: bool,
    },
}

pub fn world(command: WorldCommand) -> Result<()> {
    use crate::worldgen::generate;
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
                "wrote {} ({} seed {}, candidate {}): {:.1} m2 of floor inside the walls ({:.1} m2 with the outer walls, as `world check` measures), {} rooms, {} doors, {} geoms, {:.1}% of the free space reachable",
                world.file.display(),
                kind.name(),
                seed,
                world.sub_seed,
                world.area,
                world.report.floor_area,
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
            let config = crate::scene::import::ImportConfig {
                scene,
                up,
                scale,
                floor,
                spawn,
                out,
                overwrite,
            };
            let started = std::time::Instant::now();
            let s = crate::scene::import::import_scene(&config)
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
            let loaded = crate::world::World::load(&world, &SensorConfig::default())
                .with_context(|| format!("exporting {} failed", world.display()))?;
            let s = crate::scene::export::export_world(&loaded, &out, overwrite)
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
        } => suite(&out, per_kind, overwrite, &mut say_rejected),
        WorldCommand::Check {
            world,
            spawn,
            json,
            plot,
            overwrite,
        } => {
            if let Some(png) = &plot {
                crate::dataset::refuse_overwrite(png, overwrite, &[world.as_path()])?;
            }
            check(&world, spawn, json, plot.as_deref())
        }
    }
}

/// `world suite`: PER_KIND worlds of each kind and their manifest.json.
fn suite(
    out: &std::path::Path,
    per_kind: u64,
    overwrite: bool,
    say_rejected: &mut dyn FnMut(u32, &str),
) -> Result<()> {
    use crate::worldgen::generate;
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
            let world = generate(&config, say_rejected)
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

/// `world check`: the report, the floor plan picture when asked, non-zero exit on problems.
fn check(
    world: &std::path::Path,
    spawn: Option<Pose2>,
    json: bool,
    plot: Option<&std::path::Path>,
) -> Result<()> {
    let mut loaded = crate::world::World::load(world, &SensorConfig::default())
        .with_context(|| format!("checking {} failed", world.display()))?;
    if let Some(pose) = spawn {
        loaded.set_start(pose);
    }
    let (report, plan) = crate::world_check::check_world(&loaded)?;
    if let Some(png) = plot {
        let reachable = plan.reachable_from(report.spawn.x, report.spawn.y);
        crate::plot::write_floor_plan_png(png, &plan, &reachable, report.spawn)?;
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_world_report(world, &report);
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

fn print_world_report(path: &std::path::Path, r: &crate::world_check::WorldReport) {
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
        "floor area (inside the outer boundary, the outer walls included): {:.1} m2",
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

/// A fresh scratch folder under the system's temporary directory.
pub fn tempfile_dir() -> Result<std::path::PathBuf> {
    let dir = std::env::temp_dir().join(format!("splatloop-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    Ok(dir)
}
