//! `splatloop world check`: whether a world is fit for an episode. The robot must start
//! without touching anything, inside a closed world with a floor, and every cell where it fits
//! must be reachable from its start; geoms must not intersect each other. Runs on the compiled
//! model, so hand-made, generated and imported worlds are judged alike.

use crate::error::Result;
use crate::floorplan::FloorPlan;
use crate::mujoco::ObjKind;
use crate::robot::Pose2;
use crate::world::World;
use nalgebra::{Point3, Vector3};
use serde::Serialize;

/// Unreachable free space smaller than this is a rounding speck, not a problem, m2.
const MIN_POCKET_AREA: f64 = 0.02;

/// Clearance of a room's core, metres: openings narrower than twice this (doors, up to
/// 1.4 m) separate regions.
pub const REGION_CORE_CLEARANCE: f64 = 0.72;

/// A region's core smaller than this is not a region, m2.
const MIN_REGION_AREA: f64 = 0.25;

/// Geoms overlapping by less than this only touch, metres.
const TOUCH_TOLERANCE: f64 = 1e-3;

/// Geom groups a floor may be in: every group but the robot's (3), since collision-only
/// floors (an imported scene's ground plane) are often hidden in groups 4 and 5.
const FLOOR_GROUPS: u8 = 0b11_0111;

/// Distance between the floor probes along the reachable space, metres.
const FLOOR_PROBE_SPACING: f64 = 1.0;

/// What a check found.
#[derive(Debug, Clone, Serialize)]
pub struct WorldReport {
    /// Area inside the world's outer boundary, m2: the outer walls' and every obstacle's
    /// footprint included (what a floor plan measures; a generated world's `area` is the floor
    /// inside its walls, 4-7% less).
    pub floor_area: f64,
    /// Area inside the outer walls that no obstacle covers at the robot's heights, m2.
    pub free_area: f64,
    /// Area where the robot fits with its clearance, m2.
    pub robot_area: f64,
    /// Of that, the share reachable from the start.
    pub reachable_share: f64,
    /// Regions: spaces joined only through openings narrower than 1.45 m (rooms, aisles).
    pub regions: usize,
    /// The clearance the robot needs (its radius plus margin), metres.
    pub clearance: f64,
    /// The start pose checked.
    pub spawn: Pose2,
    /// Collidable geoms besides the robot's.
    pub geoms: usize,
    /// World bounds of the geoms: (min x, min y), (max x, max y).
    pub bounds: ([f64; 2], [f64; 2]),
    /// Everything wrong, each phrased with what and where.
    pub problems: Vec<String>,
}

impl WorldReport {
    /// Whether the world passed every check.
    pub fn ok(&self) -> bool {
        self.problems.is_empty()
    }
}

/// Checks `world` with the robot at its start pose.
pub fn check_world(world: &World) -> Result<(WorldReport, FloorPlan)> {
    let plan = FloorPlan::of(world)?;
    let spawn = world.start();
    let model = world.model();
    let name = |geom: usize| {
        model
            .name(ObjKind::Geom, geom)
            .unwrap_or_else(|| format!("geom {geom}"))
    };
    let mut problems = Vec::new();

    // The start: MuJoCo's own contacts, then the plan's clearance.
    let touching: Vec<String> = world
        .robot_collisions()
        .map(|c| world.touched_name(&c))
        .collect();
    if !touching.is_empty() {
        problems.push(format!(
            "the spawn ({:.2}, {:.2}) puts the robot into {}",
            spawn.x,
            spawn.y,
            touching.join(", ")
        ));
    }
    let reachable = plan.reachable_from(spawn.x, spawn.y);
    let reached = reachable.iter().filter(|r| **r).count();
    if reached == 0 {
        problems.push(format!(
            "the spawn ({:.2}, {:.2}) has less than {:.2} m of clearance",
            spawn.x, spawn.y, plan.clearance_needed
        ));
    }
    if let Some(edge) = (0..plan.len()).find(|&c| reachable[c] && plan.on_border(c)) {
        let [x, y] = plan.centre(edge);
        problems.push(format!(
            "the world is not closed: the robot can drive from the spawn off its edge near ({x:.1}, {y:.1})"
        ));
    }

    // Areas, and free space the robot cannot get to.
    let outside = plan.outside();
    let inside = |c: usize| !outside[c];
    let floor_cells = (0..plan.len()).filter(|&c| inside(c)).count();
    let free_cells = (0..plan.len())
        .filter(|&c| inside(c) && !plan.is_occupied(c))
        .count();
    let robot_cells = (0..plan.len())
        .filter(|&c| inside(c) && plan.is_free(c))
        .count();
    if reached > 0 {
        let pockets = plan.components(|c| inside(c) && plan.is_free(c) && !reachable[c]);
        for pocket in pockets
            .iter()
            .filter(|p| plan.area(p.len()) >= MIN_POCKET_AREA)
        {
            let [x, y] = centroid(&plan, pocket);
            problems.push(format!(
                "{:.2} m2 of free space around ({x:.2}, {y:.2}) cannot be reached from the spawn",
                plan.area(pocket.len())
            ));
        }
    }

    // A floor under the start and along the reachable space: a downward ray from just above
    // the floor must meet a surface near z = 0.
    let stride = ((FLOOR_PROBE_SPACING / plan.cell).round() as usize).max(1);
    let mut probes: Vec<[f64; 2]> = vec![[spawn.x, spawn.y]];
    probes.extend(
        (0..plan.len())
            .filter(|&c| {
                reachable[c] && (c % plan.size[0]) % stride == 0 && (c / plan.size[0]) % stride == 0
            })
            .map(|c| plan.centre(c)),
    );
    if let Some([x, y]) = probes.into_iter().find(|&[x, y]| !floor_at(world, x, y)) {
        problems.push(format!(
            "no floor under ({x:.2}, {y:.2}): the robot would fall (add a ground plane or a floor box with its top at z = 0)"
        ));
    }

    // Geoms that intersect: pairs from different bodies, or both on the world body.
    let footprints = &plan.footprints;
    let boxes: Vec<_> = footprints.iter().map(|f| f.bounds()).collect();
    for a in 0..footprints.len() {
        for b in a + 1..footprints.len() {
            let ((alo, ahi), (blo, bhi)) = (boxes[a], boxes[b]);
            if alo[0] >= bhi[0] || blo[0] >= ahi[0] || alo[1] >= bhi[1] || blo[1] >= ahi[1] {
                continue;
            }
            let (ga, gb) = (footprints[a].geom, footprints[b].geom);
            let (ba, bb) = (model.geom_body(ga), model.geom_body(gb));
            if ba == bb && ba != 0 {
                continue;
            }
            let depth = footprints[a].penetration(&footprints[b]);
            if depth > TOUCH_TOLERANCE {
                problems.push(format!(
                    "geoms {} and {} intersect by {:.0} mm",
                    name(ga),
                    name(gb),
                    depth * 1e3
                ));
            }
        }
    }

    let core = REGION_CORE_CLEARANCE;
    let regions = plan
        .components(|c| reachable[c] && plan.clearance(c) >= core)
        .iter()
        .filter(|g| plan.area(g.len()) >= MIN_REGION_AREA)
        .count();
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for f in footprints {
        let (a, b) = f.bounds();
        for k in 0..2 {
            lo[k] = lo[k].min(a[k]);
            hi[k] = hi[k].max(b[k]);
        }
    }
    let report = WorldReport {
        floor_area: plan.area(floor_cells),
        free_area: plan.area(free_cells),
        robot_area: plan.area(robot_cells),
        reachable_share: if robot_cells == 0 {
            0.0
        } else {
            reached as f64 / robot_cells as f64
        },
        regions,
        clearance: plan.clearance_needed,
        spawn,
        geoms: footprints.len(),
        bounds: (lo, hi),
        problems,
    };
    Ok((report, plan))
}

/// Whether there is a floor under (x, y): a surface within 5 cm of z = 0 below a point just
/// above it. Three rays a few millimetres apart: one ray can slip down a mesh's edge.
pub fn floor_at(world: &World, x: f64, y: f64) -> bool {
    let down = Vector3::new(0.0, 0.0, -1.0);
    [[0.0, 0.0], [0.0031, 0.0017], [-0.0023, 0.0029]]
        .iter()
        .any(|d| {
            let origin = Point3::new(x + d[0], y + d[1], 0.05);
            let hit = world
                .data()
                .ray(&origin, &down, FLOOR_GROUPS, Some(world.robot().body));
            hit.is_some_and(|h| h.distance <= 0.1)
        })
}

/// An error unless the robot's start has a floor under it (a world without one drops it).
pub fn require_floor(world: &World) -> crate::error::Result<()> {
    let start = world.start();
    if floor_at(world, start.x, start.y) {
        return Ok(());
    }
    Err(crate::error::SimError::InvalidArgument {
        what: "world",
        detail: format!(
            "no floor under the robot's start ({:.2}, {:.2}) in {}: it would fall; add a ground plane (<geom type=\"plane\" size=\"0 0 1\"/>) or a floor with its top at z = 0",
            start.x,
            start.y,
            world.model().path().display()
        ),
    })
}

/// Mean centre of a group of cells.
fn centroid(plan: &FloorPlan, cells: &[usize]) -> [f64; 2] {
    let n = cells.len().max(1) as f64;
    let sum = cells.iter().fold([0.0, 0.0], |s, &c| {
        let p = plan.centre(c);
        [s[0] + p[0], s[1] + p[1]]
    });
    [sum[0] / n, sum[1] / n]
}
