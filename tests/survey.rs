//! The survey's route: a look-around sees what a brute-force line of sight sees; the route
//! leaves nothing a look-around could still see; its paths are drivable; and in every suite
//! world it plans a route that sees the reachable surfaces.

use crate::support::repo_path;
use splatloop::camera::SensorConfig;
use splatloop::floorplan::FloorPlan;
use splatloop::survey::tour::{is_candidate, look_around, plan_tour, targets, TourConfig};
use splatloop::world::World;
use std::collections::BTreeSet;

const CELL: f64 = 0.05;

/// A grid of `w` x `h` cells with walls round it and the given boxes (cell ranges) filled.
fn grid(w: usize, h: usize, boxes: &[(usize, usize, usize, usize)]) -> FloorPlan {
    let mut occupied = vec![false; w * h];
    for j in 0..h {
        for i in 0..w {
            let wall = i < 2 || j < 2 || i + 2 >= w || j + 2 >= h;
            let inside = boxes
                .iter()
                .any(|&(i0, i1, j0, j1)| (i0..=i1).contains(&i) && (j0..=j1).contains(&j));
            occupied[j * w + i] = wall || inside;
        }
    }
    FloorPlan::from_occupancy([0.0, 0.0], CELL, [w, h], occupied, 0.36)
}

/// Whether some point of occupied cell `t` can be reached from `from`'s centre along a
/// straight line that crosses no other occupied cell, within `range`.
fn brute_force_visible(plan: &FloorPlan, from: usize, t: usize, range: f64) -> bool {
    let [x0, y0] = plan.centre(from);
    let [tx, ty] = plan.centre(t);
    let w = plan.size[0];
    let offsets = [-0.49, -0.25, 0.0, 0.25, 0.49];
    for ox in offsets {
        for oy in offsets {
            let (px, py) = (tx + ox * CELL, ty + oy * CELL);
            let length = (px - x0).hypot(py - y0);
            if length > range {
                continue;
            }
            let steps = (length / (CELL / 40.0)).ceil() as usize;
            let clear = (1..=steps).all(|s| {
                let f = s as f64 / steps as f64;
                let (x, y) = (x0 + f * (px - x0), y0 + f * (py - y0));
                let c = (y / CELL).floor() as usize * w + (x / CELL).floor() as usize;
                c == t || !plan.is_occupied(c)
            });
            if clear {
                return true;
            }
        }
    }
    false
}

#[test]
fn a_look_around_sees_what_a_line_of_sight_sees() {
    // 6 x 4 m: a pillar and a thin wall.
    let plan = grid(120, 80, &[(40, 50, 30, 40), (80, 81, 10, 50)]);
    let outside = plan.outside();
    let all = targets(&plan, &outside);
    let range = 4.0;
    for (i, j) in [(20, 20), (60, 60), (100, 30), (60, 35)] {
        let from = j * 120 + i;
        let hits: BTreeSet<usize> = look_around(&plan, from, range, 720).into_iter().collect();
        let truth: BTreeSet<usize> = all
            .iter()
            .copied()
            .filter(|&t| brute_force_visible(&plan, from, t, range))
            .collect();
        let true_hits = hits.iter().filter(|c| truth.contains(c)).count();
        assert!(
            true_hits as f64 >= 0.99 * hits.len() as f64,
            "from ({i}, {j}): {} of {} hits are visible",
            true_hits,
            hits.len()
        );
        let found = truth.iter().filter(|c| hits.contains(c)).count();
        assert!(
            found as f64 >= 0.9 * truth.len() as f64,
            "from ({i}, {j}): found {found} of {} visible targets",
            truth.len()
        );
    }
    // Behind the pillar from the left: the cell at its right face's middle is hidden.
    let hidden = 35 * 120 + 51;
    assert!(!brute_force_visible(&plan, 35 * 120 + 20, hidden, range));
    assert!(!look_around(&plan, 35 * 120 + 20, range, 720).contains(&hidden));
}

#[test]
fn the_route_leaves_nothing_a_look_around_could_still_see() {
    // Two 4 x 4 m rooms joined by a 0.9 m door in the wall between them, a box in each.
    let (w, h) = (170, 84);
    let mut boxes = vec![(83, 86, 0, 83), (30, 40, 30, 40), (120, 135, 50, 60)];
    boxes[0] = (83, 86, 0, 32);
    boxes.push((83, 86, 51, 83));
    let plan = grid(w, h, &boxes);
    let config = TourConfig::default();
    let start = 20 * w + 20;
    let tour = plan_tour(&plan, start, &config);
    assert!(tour.stops.len() >= 2);
    // It went through the door: a stop in the far room.
    assert!(
        tour.stops.iter().any(|p| p[0] > 87.0 * CELL),
        "{:?}",
        tour.stops
    );
    // Nothing any candidate could still see is left: every candidate's look-around adds
    // fewer than min_gain targets to what the route's look-arounds saw.
    let seen: BTreeSet<usize> = tour
        .stops
        .iter()
        .flat_map(|p| {
            let c = plan.cell_of(p[0], p[1]).expect("on the grid");
            look_around(&plan, c, config.range, config.rays)
        })
        .collect();
    let all: BTreeSet<usize> = targets(&plan, &plan.outside()).into_iter().collect();
    let reachable = plan.flood(start, |c| plan.is_free(c));
    for c in 0..plan.len() {
        if is_candidate(&plan, &reachable, c, &config) {
            let new = look_around(&plan, c, config.range, config.rays)
                .into_iter()
                .filter(|t| all.contains(t) && !seen.contains(t))
                .count();
            assert!(
                new < config.min_gain,
                "cell {c} would still see {new} new targets"
            );
        }
    }
    assert_eq!(tour.seen, seen.intersection(&all).count());
    // The paths are chains of neighbouring cells the robot fits in, from stop to stop.
    for (k, path) in tour.paths.iter().enumerate().skip(1) {
        let mut previous = tour.stops[k - 1];
        for p in path {
            assert!((p[0] - previous[0]).abs() < 1.01 * CELL + 1e-9);
            assert!((p[1] - previous[1]).abs() < 1.01 * CELL + 1e-9);
            let c = plan.cell_of(p[0], p[1]).expect("on the grid");
            assert!(
                plan.is_free(c),
                "path cell {c} has {:.2} m",
                plan.clearance(c)
            );
            previous = *p;
        }
        assert_eq!(previous, tour.stops[k]);
    }
}

#[test]
fn in_every_suite_world_the_route_sees_the_reachable_surfaces() {
    for kind in ["apartment", "office", "warehouse"] {
        for n in 1..=4 {
            let path = repo_path(&format!("worlds/suite/{kind}_0{n}.xml"));
            let world = World::load(&path, &SensorConfig::default()).expect("world");
            let config = splatloop::survey::SurveyConfig::default();
            let (steps, tour) = splatloop::survey::plan_survey(&world, &config).expect("survey");
            assert!(steps.len() > tour.stops.len());
            let share = tour.seen as f64 / tour.visible as f64;
            assert!(
                share > 0.95,
                "{}: the route sees {:.1}% of what look-arounds could",
                path.display(),
                100.0 * share
            );
        }
    }
}
