//! Replays an episode folder's depth frames into the papers' evidence grid twice, once with each
//! rule for free cells ([`FreeCells`]), and counts against the world's floor plan what no view
//! can clear: frontier cells, and cells taken for free, that lie inside an obstacle. The same
//! frames go into both grids, so the difference is the rule's, not a path's.
//!
//! ```sh
//! cargo run --release --example evidence_replay -- EPISODE_FOLDER WORLD.xml
//! ```

use autonomy::explore::evidence::{CellClass, EvidenceConfig, EvidenceGrid, FreeCells};
use autonomy::explore::frontier;
use splatloop::camera::SensorConfig;
use splatloop::dataset::Dataset;
use splatloop::floorplan::FloorPlan;
use splatloop::world::World;
use std::path::PathBuf;

/// Radius marked free round the camera's plan position each frame (the robot's footprint).
const FOOTPRINT: f64 = 0.2;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [folder, world] = args.as_slice() else {
        return Err("usage: evidence_replay EPISODE_FOLDER WORLD.xml".into());
    };
    let dataset = Dataset::open(&PathBuf::from(folder))?;
    let world = World::load(&PathBuf::from(world), &SensorConfig::default())?;
    let plan = FloorPlan::of(&world)?;
    let means = autonomy::ply::read(&PathBuf::from(folder).join("map.ply"))?
        .gaussians
        .means;
    let rules = [FreeCells::PapersLines, FreeCells::Crossed];
    let mut grids: Vec<EvidenceGrid> = rules
        .iter()
        .map(|&free_cells| {
            EvidenceGrid::new(EvidenceConfig {
                free_cells,
                ..EvidenceConfig::default()
            })
        })
        .collect();
    let checkpoints = [60.0, 120.0, 200.0, f64::INFINITY];
    let mut next = 0;
    println!(
        "| time s | rule | free cells | frontier cells | of them inside an obstacle | free cells inside an obstacle |"
    );
    println!("|---:|---|---|---:|---:|---:|");
    for index in 0..dataset.frames.len() {
        let frame = dataset.load(index)?;
        let at = frame.camera.world_from_camera.translation.vector;
        for grid in &mut grids {
            grid.integrate(&frame.depth, &frame.camera);
            grid.mark_free_disc([at.x, at.y], FOOTPRINT);
        }
        let last = index + 1 == dataset.frames.len();
        if next < checkpoints.len() && (frame.time >= checkpoints[next] || last) {
            next += 1;
            for (rule, grid) in rules.iter().zip(&mut grids) {
                grid.set_gaussians(&means);
                let classes = grid.classes();
                let free = frontier::reachable_free(&classes, [at.x, at.y]);
                let cells = frontier::frontier_cells(&classes, &free);
                let inside = |c: usize| {
                    let p = classes.centre(c);
                    plan.cell_of(p[0], p[1])
                        .is_some_and(|k| plan.is_occupied(k))
                };
                let fronts: Vec<usize> = (0..classes.len()).filter(|c| cells[*c]).collect();
                let free_cells = (0..classes.len())
                    .filter(|c| classes.classes[*c] == CellClass::Free)
                    .count();
                let free_inside = (0..classes.len())
                    .filter(|c| classes.classes[*c] == CellClass::Free && inside(*c))
                    .count();
                println!(
                    "| {:.0} | {:?} | {} | {} | {} | {} |",
                    frame.time,
                    rule,
                    free_cells,
                    fronts.len(),
                    fronts.iter().filter(|c| inside(**c)).count(),
                    free_inside
                );
            }
        }
    }
    Ok(())
}
