//! `trajectory.png`: the episode from above. The world's footprint comes from downward mj_ray
//! casts (floor light, obstacles darker the taller they are, outside white); the map's
//! Gaussians above the floor are dots coloured by uncertainty rank (blue low, through green
//! and yellow, red high); the path is a dark line from a green start to a red end.

use crate::canvas::{ramp, Canvas};
use crate::error::Result;
use crate::evaluate::WORLD_GROUPS;
use crate::robot::Pose2;
use crate::world::World;
use autonomy::map::GaussianMap;
use nalgebra::{Point3, Vector3};
use std::path::Path;

/// Pixels per metre at most, and the longest side of the picture in pixels.
const MAX_SCALE: f64 = 60.0;
const MAX_SIDE: f64 = 1200.0;

/// The floor rectangle a picture shows: (min x, min y), (max x, max y), metres.
pub type Extent = ([f64; 2], [f64; 2]);

/// Draws the world's footprint, the map and the path under `title`, with a metre scale and a
/// legend, and writes the PNG; returns the floor rectangle it shows.
pub fn write_trajectory_png(
    path_png: &Path,
    world: &World,
    path: &[Pose2],
    map: &GaussianMap,
    title: &str,
) -> Result<Extent> {
    // Extent: the whole world (every geom but the robot's), the path and the map above the
    // floor, with a margin.
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    let mut grow = |x: f64, y: f64| {
        if x.is_finite() && y.is_finite() {
            lo = [lo[0].min(x), lo[1].min(y)];
            hi = [hi[0].max(x), hi[1].max(y)];
        }
    };
    for geom in 0..world.model().geom_count() {
        if world.robot().owns_geom(geom) {
            continue;
        }
        if let Some(f) =
            crate::floorplan::footprint::Footprint::of(world.model(), world.data(), geom)
        {
            let (a, b) = f.bounds();
            grow(a[0], a[1]);
            grow(b[0], b[1]);
        }
    }
    for p in path {
        grow(p.x, p.y);
    }
    for m in &map.gaussians.means {
        if m[2] > 0.05 {
            grow(f64::from(m[0]), f64::from(m[1]));
        }
    }
    if !lo[0].is_finite() {
        lo = [-1.0, -1.0];
        hi = [1.0, 1.0];
    }
    let lo = [lo[0].max(-500.0) - 0.5, lo[1].max(-500.0) - 0.5];
    let hi = [hi[0].min(500.0) + 0.5, hi[1].min(500.0) + 0.5];
    let scale = MAX_SCALE.min(MAX_SIDE / (hi[0] - lo[0]).max(hi[1] - lo[1]));
    let (width, height) = (
        ((hi[0] - lo[0]) * scale).ceil() as usize,
        ((hi[1] - lo[1]) * scale).ceil() as usize,
    );
    let mut canvas = Canvas {
        lo,
        scale,
        width,
        height,
        rgb: vec![255; 3 * width * height],
    };
    // The footprint: what a ray straight down from 10 m hits first.
    let down = Vector3::new(0.0, 0.0, -1.0);
    for py in 0..height {
        for px in 0..width {
            let (x, y) = canvas.world_of(px, py);
            let hit = world.data().ray(
                &Point3::new(x, y, 10.0),
                &down,
                WORLD_GROUPS,
                Some(world.robot().body),
            );
            if let Some(hit) = hit {
                let z = 10.0 - hit.distance;
                let shade = if z < 0.02 {
                    [236, 232, 222]
                } else {
                    let g = (170.0 - 50.0 * z.min(2.5)) as u8;
                    [g, g, g]
                };
                canvas.put(px as f64, py as f64, shade);
            }
        }
    }
    // Gaussians above the floor, by uncertainty rank, lowest first so high ones show.
    let mut order: Vec<usize> = (0..map.len())
        .filter(|&i| map.gaussians.means[i][2] > 0.05 && map.uncertainty[i].is_finite())
        .collect();
    order.sort_by(|&a, &b| map.uncertainty[a].total_cmp(&map.uncertainty[b]));
    let n = order.len().max(2) - 1;
    for (rank, &i) in order.iter().enumerate() {
        let m = map.gaussians.means[i];
        let (px, py) = canvas.pixel_of(f64::from(m[0]), f64::from(m[1]));
        canvas.disc(px, py, 1.0, ramp(rank as f64 / n as f64));
    }
    // The path.
    let points: Vec<(f64, f64)> = path.iter().map(|p| canvas.pixel_of(p.x, p.y)).collect();
    for pair in points.windows(2) {
        canvas.line(pair[0], pair[1], 1.2, [30, 30, 60]);
    }
    if let (Some(first), Some(last)) = (points.first(), points.last()) {
        canvas.disc(first.0, first.1, 5.0, [30, 160, 60]);
        canvas.disc(last.0, last.1, 5.0, [200, 30, 30]);
    }
    let picture = annotate(&canvas, title);
    picture.write_png(path_png)?;
    Ok((lo, hi))
}

/// Height of the title band and of the legend band, pixels.
const HEADER: usize = 24;
const FOOTER: usize = 44;
/// Narrowest picture, so the title and legend fit, pixels.
const MIN_WIDTH: usize = 640;

/// The map canvas with a title above and a legend and metre scale below.
fn annotate(map: &Canvas, title: &str) -> Canvas {
    let width = map.width.max(MIN_WIDTH);
    let height = map.height + HEADER + FOOTER;
    let mut out = Canvas {
        lo: map.lo,
        scale: map.scale,
        width,
        height,
        rgb: vec![255; 3 * width * height],
    };
    for row in 0..map.height {
        let from = 3 * row * map.width;
        let to = 3 * ((row + HEADER) * width);
        out.rgb[to..to + 3 * map.width].copy_from_slice(&map.rgb[from..from + 3 * map.width]);
    }
    let ink = [20, 20, 30];
    out.text(6, 8, title, ink);
    // The legend: swatches with words.
    let y = HEADER + map.height + 8;
    let mut x = 6;
    for (colour, word) in [
        ([236, 232, 222], "floor"),
        ([120, 120, 120], "obstacle (darker: taller)"),
        ([30, 160, 60], "start"),
        ([200, 30, 30], "end"),
        ([30, 30, 60], "path"),
    ] {
        out.swatch(x, y, colour);
        out.text(x + 14, y + 1, word, ink);
        x += 14 + 8 * word.len() + 14;
    }
    let y = y + 18;
    out.text(6, y + 1, "Gaussians by uncertainty: low", ink);
    let x = 6 + 8 * 30;
    for k in 0..60 {
        let colour = ramp(k as f64 / 59.0);
        for dy in 0..10 {
            out.put((x + k) as f64, (y + dy) as f64, colour);
        }
    }
    out.text(x + 64, y + 1, "high", ink);
    // A scale bar of a round number of metres, about 80 pixels long.
    let metres = [0.5, 1.0, 2.0, 5.0, 10.0, 20.0]
        .into_iter()
        .find(|m| m * map.scale >= 60.0)
        .unwrap_or(50.0);
    let length = (metres * map.scale).round() as usize;
    let bar_x = width.saturating_sub(length + 60);
    for dx in 0..length {
        for dy in 0..3 {
            out.put((bar_x + dx) as f64, (y + 4 + dy) as f64, ink);
        }
    }
    for end in [bar_x, bar_x + length - 1] {
        for dy in 0..10 {
            out.put(end as f64, (y + dy) as f64, ink);
        }
    }
    out.text(bar_x + length + 6, y + 1, &format!("{metres} m"), ink);
    out
}

/// The floor plan of `world check --plot`: a pixel per cell, north up. Obstacles dark grey,
/// reachable cells green, cells where the robot fits but cannot get to red, floor too close
/// to an obstacle beige, outside white; the spawn a blue dot.
pub fn write_floor_plan_png(
    path_png: &Path,
    plan: &crate::floorplan::FloorPlan,
    reachable: &[bool],
    spawn: Pose2,
) -> Result<()> {
    let [w, h] = plan.size;
    let outside = plan.outside();
    let mut rgb = vec![255u8; 3 * w * h];
    for c in 0..plan.len() {
        let colour = if plan.is_occupied(c) {
            [90, 90, 90]
        } else if reachable[c] {
            [170, 220, 160]
        } else if outside[c] {
            [255, 255, 255]
        } else if plan.is_free(c) {
            [230, 60, 50]
        } else {
            [236, 228, 210]
        };
        let (i, j) = (c % w, c / w);
        let at = 3 * ((h - 1 - j) * w + i);
        rgb[at..at + 3].copy_from_slice(&colour);
    }
    if let Some(c) = plan.cell_of(spawn.x, spawn.y) {
        let (ci, cj) = ((c % w) as isize, (c / w) as isize);
        for dj in -3..=3isize {
            for di in -3..=3isize {
                let (i, j) = (ci + di, cj + dj);
                if di * di + dj * dj <= 9
                    && i >= 0
                    && j >= 0
                    && (i as usize) < w
                    && (j as usize) < h
                {
                    let at = 3 * ((h - 1 - j as usize) * w + i as usize);
                    rgb[at..at + 3].copy_from_slice(&[40, 80, 220]);
                }
            }
        }
    }
    crate::canvas::write_rgb(path_png, w, h, &rgb)
}
