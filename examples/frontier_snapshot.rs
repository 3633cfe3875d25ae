//! Replays an episode folder's depth frames into FBE's evidence grid (its default settings)
//! up to a time and draws what the planner sees there as a PNG: unknown grey, free white,
//! occupied black, the robot's reachable free component green, frontier cells red, clusters
//! (more than ten cells, joined across cut-off free cells as FBE's default joins them) dark
//! red, the world's obstacles outlined blue, the path yellow. For looking into a frontier
//! planner's choices and endings.
//!
//! ```sh
//! cargo run --release --example frontier_snapshot -- EPISODE_FOLDER WORLD.xml SECONDS OUT.png [rays]
//! ```
//!
//! `rays` draws the grid as it was before the papers' rules (every ray counted, every crossed
//! cell free, a seen cell filled with Gaussians unknown), for comparing the two on the same
//! frames.

use autonomy::explore::evidence::{CellClass, EvidenceConfig, EvidenceGrid, FreeCells};
use autonomy::explore::frontier;
use splatloop::camera::SensorConfig;
use splatloop::dataset::Dataset;
use splatloop::floorplan::FloorPlan;
use splatloop::world::World;
use std::path::PathBuf;

/// FBE's footprint radius, marked free round the robot each frame.
const FOOTPRINT: f64 = 0.3;
/// Pixels per grid cell in the picture.
const SCALE: usize = 3;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (folder, world, seconds, out, rays) = match args.as_slice() {
        [f, w, s, o] => (f, w, s, o, false),
        [f, w, s, o, r] if r == "rays" => (f, w, s, o, true),
        _ => {
            return Err(
                "usage: frontier_snapshot EPISODE_FOLDER WORLD.xml SECONDS OUT.png [rays]".into(),
            )
        }
    };
    let until: f64 = seconds.parse()?;
    let dataset = Dataset::open(&PathBuf::from(folder))?;
    let world = World::load(&PathBuf::from(world), &SensorConfig::default())?;
    let plan = FloorPlan::of(&world)?;
    let means = autonomy::ply::read(&PathBuf::from(folder).join("map.ply"))?
        .gaussians
        .means;
    let config = if rays {
        EvidenceConfig {
            frame_votes: false,
            free_cells: FreeCells::Crossed,
            filled_class: CellClass::Unknown,
            ..EvidenceConfig::default()
        }
    } else {
        EvidenceConfig::default()
    };
    let mut grid = EvidenceGrid::new(config);
    let mut path = Vec::new();
    for index in 0..dataset.frames.len() {
        let frame = dataset.load(index)?;
        if frame.time > until {
            break;
        }
        let at = frame.camera.world_from_camera.translation.vector;
        grid.integrate(&frame.depth, &frame.camera);
        grid.mark_free_disc([at.x, at.y], FOOTPRINT);
        path.push([at.x, at.y]);
    }
    grid.set_gaussians(&means);
    let classes = grid.classes();
    let robot = path.last().copied().ok_or("no frame before that time")?;
    let free = frontier::reachable_free(&classes, robot);
    let cells = frontier::frontier_cells(&classes, &free);
    // FBE's default clusters: joined across the free cells the opening cut off.
    let through = frontier::cut_free_border(&classes, &free);
    let clusters = frontier::clusters_through(&classes, &cells, &through);
    let mut in_cluster = vec![false; classes.len()];
    for c in clusters.iter().flat_map(|c| &c.cells) {
        in_cluster[*c] = true;
    }
    let [w, h] = classes.size;
    let mut rgb = vec![0u8; w * h * 3 * SCALE * SCALE];
    for c in 0..classes.len() {
        let p = classes.centre(c);
        let wall = plan
            .cell_of(p[0], p[1])
            .is_some_and(|k| plan.is_occupied(k));
        let colour = if in_cluster[c] {
            [150, 0, 0]
        } else if cells[c] {
            [255, 80, 80]
        } else if free[c] {
            [140, 230, 140]
        } else {
            match classes.classes[c] {
                CellClass::Free => [255, 255, 255],
                CellClass::Occupied => [0, 0, 0],
                CellClass::Unknown => [128, 128, 128],
            }
        };
        let colour = if wall && classes.classes[c] != CellClass::Occupied {
            [60, 60, 255]
        } else {
            colour
        };
        let (x, y) = (c % w, h - 1 - c / w);
        for dy in 0..SCALE {
            for dx in 0..SCALE {
                let i = ((y * SCALE + dy) * w * SCALE + x * SCALE + dx) * 3;
                rgb[i..i + 3].copy_from_slice(&colour);
            }
        }
    }
    for p in &path {
        if let Some(c) = classes.cell_of(*p) {
            let (x, y) = (c % w, h - 1 - c / w);
            let i = ((y * SCALE + 1) * w * SCALE + x * SCALE + 1) * 3;
            rgb[i..i + 3].copy_from_slice(&[230, 200, 0]);
        }
    }
    let file = std::fs::File::create(out)?;
    let mut encoder = png::Encoder::new(
        std::io::BufWriter::new(file),
        (w * SCALE) as u32,
        (h * SCALE) as u32,
    );
    encoder.set_color(png::ColorType::Rgb);
    encoder.write_header()?.write_image_data(&rgb)?;
    println!(
        "{} clusters ({} frontier cells) at t <= {until} s; robot at ({:.2}, {:.2}); grid origin {:?}, {} x {} cells",
        clusters.len(),
        cells.iter().filter(|c| **c).count(),
        robot[0],
        robot[1],
        classes.origin,
        w,
        h
    );
    Ok(())
}
