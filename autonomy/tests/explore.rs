//! The planner interface and the comparison planners: the evidence grid and frontiers against
//! brute force and hand-counted cases, FBE closing a ray-cast room, the Fisher backward against
//! per-pixel one-hot passes of the f64 reference, EIG's properties, the eq 13 path by hand,
//! the pose information, and what every planner must do (limits, failures, repeatability).

use autonomy::camera::{Intrinsics, PinholeCamera};
use autonomy::drive::{advance, DriveLimits, Pose2};
use autonomy::explore::agslam::{
    expected_information_gain, path_score, AgslamConfig, AgslamPlanner, SparseFisher, TrainMode,
};
use autonomy::explore::evidence::{
    CellClass, ClassGrid, EvidenceConfig, EvidenceGrid, FreeCells, SAMPLED_FRACTIONS,
};
use autonomy::explore::executor::{CollisionEngine, ExecutorConfig};
use autonomy::explore::fbe::{FbeConfig, FbePlanner};
use autonomy::explore::frontier::{self, Cluster};
use autonomy::explore::{Decision, Observation, PlanFailure, Planner, Recovery};
use autonomy::gaussians::Gaussians;
use autonomy::map::GaussianMap;
use autonomy::mapping::{Frame, Mapper, MapperConfig};
use autonomy::math::Point3;
use autonomy::planner::information::CameraMount;
use autonomy::planner::{PlannerConfig, RtGuidePlanner};
use autonomy::splat::{cpu, reference, ImageGradients, Rasteriser, FISHER_PARAMETERS};
use autonomy::synthetic::{look_at, BoxScene};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::HashMap;

#[test]
fn frontier_cells_equal_a_brute_force_scan() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..20 {
        let (w, h) = (40, 30);
        let mut g = ClassGrid::filled([w, h], [0.0, 0.0], 0.05, CellClass::Unknown);
        // A free blob around the middle with holes, walls and unknown specks.
        for y in 0..h {
            for x in 0..w {
                let d = ((x as f64 - 20.0).powi(2) + (y as f64 - 15.0).powi(2)).sqrt();
                g.classes[y * w + x] = if d < 11.0 {
                    match rng.gen_range(0..20) {
                        0 => CellClass::Occupied,
                        1 => CellClass::Unknown,
                        _ => CellClass::Free,
                    }
                } else if rng.gen_bool(0.1) {
                    CellClass::Occupied
                } else {
                    CellClass::Unknown
                };
            }
        }
        let robot = g.centre(15 * w + 20);
        let free = frontier::reachable_free(&g, robot);
        let cells = frontier::frontier_cells(&g, &free);
        // Definition 1: (free dilated 3 x 3) minus free, and unknown, by brute force.
        // Definition 2: an unknown cell with one of its 8 neighbours in the free component.
        for c in 0..g.len() {
            let (x, y) = ((c % w) as i64, (c / w) as i64);
            let mut dilated = false;
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64 {
                        dilated |= free[ny as usize * w + nx as usize];
                    }
                }
            }
            let one = dilated && !free[c] && g.classes[c] == CellClass::Unknown;
            let two = g.classes[c] == CellClass::Unknown && g.neighbours8(c).any(|n| free[n]);
            assert_eq!(cells[c], one, "cell {c}");
            assert_eq!(cells[c], two, "cell {c}");
        }
        assert!(cells.iter().any(|f| *f), "the blob has a frontier");
    }
}

#[test]
fn clusters_need_more_than_ten_cells() {
    let mut g = ClassGrid::filled([40, 10], [0.0, 0.0], 0.05, CellClass::Unknown);
    let mut frontier_mask = vec![false; g.len()];
    // A 10-cell run on row 2 and an 11-cell run on row 7, far apart.
    for x in 0..10 {
        frontier_mask[2 * 40 + x] = true;
    }
    for x in 20..31 {
        frontier_mask[7 * 40 + x] = true;
    }
    g.classes[0] = CellClass::Free;
    let clusters = frontier::clusters(&g, &frontier_mask);
    assert_eq!(clusters.len(), 1);
    assert_eq!(clusters[0].cells.len(), 11);
    let expected_x = (20..31).map(|x| (x as f64 + 0.5) * 0.05).sum::<f64>() / 11.0;
    assert!((clusters[0].centroid[0] - expected_x).abs() < 1e-9);
}

#[test]
fn the_choice_is_count_over_distance_plus_twenty() {
    let g = ClassGrid::filled([400, 400], [0.0, 0.0], 0.05, CellClass::Unknown);
    let run = |x0: usize, y: usize, n: usize| Cluster {
        cells: (x0..x0 + n).map(|x| y * 400 + x).collect(),
        centroid: [0.0, 0.0],
    };
    let robot = g.centre(0);
    // Small and near: 15 cells about 10 cells away; large and far: 60 cells about 200 away.
    let near = run(10, 0, 15);
    let far = run(200, 0, 60);
    let u_near = frontier::utility(&g, &near, robot);
    let u_far = frontier::utility(&g, &far, robot);
    let mean = |c: &Cluster| {
        c.cells
            .iter()
            .map(|i| {
                let p = g.centre(*i);
                (p[0] - robot[0]).hypot(p[1] - robot[1]) / 0.05
            })
            .sum::<f64>()
            / c.cells.len() as f64
    };
    assert!((u_near - 15.0 / (mean(&near) + 20.0)).abs() < 1e-12);
    assert!((u_far - 60.0 / (mean(&far) + 20.0)).abs() < 1e-12);
    // 15 / (17 + 20) = 0.405 beats 60 / (229.5 + 20) = 0.240.
    let ranked = frontier::ranked(&g, &[far.clone(), near.clone()], robot);
    assert_eq!(ranked[0].0, 1, "the near one wins: {ranked:?}");
    // A 300-cell far cluster: 300 / (349.5 + 20) = 0.81 beats the near one.
    let huge = run(200, 1, 300);
    let ranked = frontier::ranked(&g, &[near, huge], robot);
    assert_eq!(ranked[0].0, 1, "the huge one wins: {ranked:?}");
}

/// The papers' grid with free evidence in every cell a ray crosses (RT-GuIDE's rule).
fn crossed() -> EvidenceConfig {
    EvidenceConfig {
        free_cells: FreeCells::Crossed,
        ..EvidenceConfig::default()
    }
}

/// The cell of a plan point in 5 cm cells.
fn lattice(x: f64, y: f64) -> [i64; 2] {
    [(x / 0.05).floor() as i64, (y / 0.05).floor() as i64]
}

/// AG-SLAM's `update_occ_map` for one frame, transcribed cell by cell: occupied where an end
/// in the band lies, else free on the line from the camera's cell to each such end (the cell
/// nearest the exact line at every step of the major axis) or at a sampled point in the band.
fn papers_frame_by_brute_force(
    origin: Point3,
    ends: &[Point3],
) -> std::collections::BTreeMap<[i64; 2], bool> {
    let (low, high, range) = (0.1, 1.3, 7.0);
    let mut cells = std::collections::BTreeMap::new();
    let camera = lattice(origin.x, origin.y);
    for end in ends {
        let length = (end - origin).norm();
        for f in SAMPLED_FRACTIONS {
            let p = origin + f * (end - origin);
            if f * length <= range && (low..=high).contains(&p.z) {
                cells.entry(lattice(p.x, p.y)).or_insert(false);
            }
        }
        if length > range || !(low..=high).contains(&end.z) {
            continue;
        }
        let e = lattice(end.x, end.y);
        let (dx, dy) = (e[0] - camera[0], e[1] - camera[1]);
        let n = dx.abs().max(dy.abs());
        for k in 0..n {
            let t = k as f64 / n as f64;
            let at = |a: i64, d: i64| (a as f64 + t * d as f64).round() as i64;
            cells
                .entry([at(camera[0], dx), at(camera[1], dy)])
                .or_insert(false);
        }
    }
    for end in ends {
        if (end - origin).norm() <= range && (low..=high).contains(&end.z) {
            cells.insert(lattice(end.x, end.y), true);
        }
    }
    cells
}

#[test]
fn the_papers_grid_frees_their_lines_and_sampled_points_and_nothing_else() {
    // Rays from a camera 0.4 m up to walls in the band, to the floor, over the band and beyond
    // the range, each frame against the transcription of the authors' update. Ends are chosen
    // so that every line has an odd number of steps along its major axis: then no step of the
    // exact line falls half-way between two cells, where Bresenham implementations may differ.
    let origin = Point3::new(0.012, 0.037, 0.4);
    let camera = lattice(origin.x, origin.y);
    let mut rng = 0x9e37_79b9_7f4a_7c15u64;
    let mut uniform = move || {
        rng = rng
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    for frame in 0..20 {
        let mut ends = Vec::new();
        while ends.len() < 40 {
            let (a, r) = (std::f64::consts::TAU * uniform(), 0.3 + 7.5 * uniform());
            let z = [0.0, 0.05, 0.2, 0.7, 1.25, 1.6][ends.len() % 6];
            let end = Point3::new(origin.x + r * a.cos(), origin.y + r * a.sin(), z);
            let e = lattice(end.x, end.y);
            if (e[0] - camera[0]).abs().max((e[1] - camera[1]).abs()) % 2 == 1 {
                ends.push(end);
            }
        }
        let mut grid = EvidenceGrid::new(EvidenceConfig::default());
        grid.integrate_frame(origin, &ends);
        let expected = papers_frame_by_brute_force(origin, &ends);
        let g = grid.classes();
        let mut free = 0;
        for c in 0..g.len() {
            let p = g.centre(c);
            let l = lattice(p[0], p[1]);
            let want = match expected.get(&l) {
                Some(true) => CellClass::Occupied,
                Some(false) => CellClass::Free,
                None => CellClass::Unknown,
            };
            assert_eq!(g.classes[c], want, "frame {frame}, cell {l:?}");
            free += usize::from(want == CellClass::Free);
        }
        assert!(free > 100, "frame {frame}: only {free} free cells");
    }
}

#[test]
fn one_ray_clears_up_to_the_wall_marks_it_and_leaves_what_is_behind() {
    // Every crossed cell (RT-GuIDE's grid); the papers' lines and samples have their own test.
    let mut grid = EvidenceGrid::new(crossed());
    // From (0, 0.025, 0.4) to a wall point 2 m ahead at the same height.
    grid.integrate_ray(Point3::new(0.0, 0.025, 0.4), Point3::new(2.0, 0.025, 0.4));
    for k in 0..40 {
        let x = 0.025 + 0.05 * k as f64;
        assert_eq!(grid.class([x, 0.025]), CellClass::Free, "x = {x}");
    }
    assert_eq!(grid.class([2.025, 0.025]), CellClass::Occupied);
    assert_eq!(grid.class([2.125, 0.025]), CellClass::Unknown);
    assert_eq!(grid.class([1.0, 0.525]), CellClass::Unknown);
    // A ray to the floor clears without marking an obstacle; one above the band's top is cut.
    grid.integrate_ray(Point3::new(0.0, 0.525, 0.4), Point3::new(1.0, 0.525, 0.0));
    assert_eq!(grid.class([0.975, 0.525]), CellClass::Free);
    grid.integrate_ray(Point3::new(0.0, 1.025, 0.4), Point3::new(4.0, 1.025, 2.2));
    let cut = 4.0 * (1.3 - 0.4) / (2.2 - 0.4);
    assert_eq!(grid.class([cut - 0.1, 1.025]), CellClass::Free);
    assert_eq!(grid.class([cut + 0.1, 1.025]), CellClass::Unknown);
    assert_eq!(grid.class([3.975, 1.025]), CellClass::Unknown);
}

#[test]
fn with_a_low_free_height_a_ray_over_a_table_clears_only_below_it() {
    // From the camera (0.4 m) to a wall point 3 m ahead at 1.0 m, over a table: with the
    // free height at 0.6 m (RT-GuIDE's grid: the robot's top) the ray clears only its first
    // metre, and still marks the wall.
    let mut grid = EvidenceGrid::new(EvidenceConfig {
        free_height: 0.6,
        ..crossed()
    });
    grid.integrate_ray(Point3::new(0.0, 0.025, 0.4), Point3::new(3.0, 0.025, 1.0));
    let cut = 3.0 * (0.6 - 0.4) / (1.0 - 0.4);
    for k in 0..60 {
        let x = 0.025 + 0.05 * k as f64;
        let expected = if x < cut - 0.05 {
            CellClass::Free
        } else if x > cut + 0.05 {
            CellClass::Unknown
        } else {
            continue;
        };
        assert_eq!(grid.class([x, 0.025]), expected, "x = {x}");
    }
    assert_eq!(grid.class([3.025, 0.025]), CellClass::Occupied);
    // A table top's Gaussians (0.73 m) are no obstacle under it; a leg's are.
    let top: Vec<[f32; 3]> = (0..60).map(|_| [1.5, 0.5, 0.73]).collect();
    let leg: Vec<[f32; 3]> = (0..60).map(|_| [1.5, 0.5, 0.3]).collect();
    grid.integrate_ray(Point3::new(0.0, 0.525, 0.4), Point3::new(2.0, 0.525, 0.0));
    grid.set_gaussians(&top);
    assert_eq!(grid.class([1.525, 0.525]), CellClass::Free);
    grid.set_gaussians(&leg);
    assert_eq!(grid.class([1.525, 0.525]), CellClass::Occupied);
    // AG-SLAM's band (1.3 m) clears the whole way and counts the top.
    let mut agslam = EvidenceGrid::new(EvidenceConfig::default());
    agslam.integrate_ray(Point3::new(0.0, 0.025, 0.4), Point3::new(3.0, 0.025, 1.0));
    assert_eq!(agslam.class([2.475, 0.025]), CellClass::Free);
    assert_eq!(agslam.class([3.025, 0.025]), CellClass::Occupied);
}

/// A wall at x = 2 m seen square-on from 0.4 m high across a 1 m wide strip, with 30 Gaussian
/// means (more than 25, at most 50) in each cell of the column just before it: the cells rays
/// crossed in front of a densely mapped wall.
fn a_strip_before_a_filled_wall(config: EvidenceConfig) -> EvidenceGrid {
    let mut grid = EvidenceGrid::new(config);
    let mut means = Vec::new();
    for k in 0..20 {
        let y = 0.025 + 0.05 * k as f64;
        for z in [0.15, 0.25, 0.35, 0.45] {
            grid.integrate_ray(Point3::new(0.0, y, 0.4), Point3::new(2.0, y, z));
        }
        means.extend((0..30).map(|i| [1.975, y as f32, 0.2 + 0.005 * i as f32]));
    }
    grid.set_gaussians(&means);
    grid
}

#[test]
fn a_seen_cell_filled_with_gaussians_is_no_frontier_in_the_papers_grid() {
    // AG-SLAM's code: more than 25 means drop a cell from free space, but its frontier asks
    // for cells with no evidence (argmax = unknown), so such a cell is neither free nor a
    // frontier. RT-GuIDE's grid (and the executor's guard) keep it unknown, as tuned.
    let papers = a_strip_before_a_filled_wall(EvidenceConfig::default());
    let body = autonomy::explore::unseen::body_evidence(
        &autonomy::planner::collision::CollisionModel::default(),
        0.4,
    );
    let rtguide = a_strip_before_a_filled_wall(body);
    let frontier_near_the_wall = |grid: &EvidenceGrid| {
        let g = grid.classes();
        let free = frontier::reachable_free(&g, [1.0, 0.5]);
        let cells = frontier::frontier_cells(&g, &free);
        (0..g.len())
            .filter(|c| cells[*c])
            .filter(|c| {
                let p = g.centre(*c);
                p[0] > 1.9 && p[1] > 0.2 && p[1] < 0.8
            })
            .count()
    };
    for k in 4..16 {
        let p = [1.975, 0.025 + 0.05 * k as f64];
        assert_eq!(papers.class(p), CellClass::Occupied, "{p:?}");
        assert_eq!(papers.class([1.925, p[1]]), CellClass::Free, "{p:?}");
        assert_eq!(rtguide.class(p), CellClass::Unknown, "{p:?}");
    }
    assert_eq!(frontier_near_the_wall(&papers), 0);
    assert!(frontier_near_the_wall(&rtguide) >= 12);
    // More than 50 means mark it occupied in both.
    let mut dense = a_strip_before_a_filled_wall(body);
    let many: Vec<[f32; 3]> = (0..60)
        .map(|i| [1.975, 0.525, 0.2 + 0.0025 * i as f32])
        .collect();
    dense.set_gaussians(&many);
    assert_eq!(dense.class([1.975, 0.525]), CellClass::Occupied);
}

#[test]
fn a_frame_votes_once_per_cell_so_rays_grazing_a_wall_do_not_outvote_its_end_points() {
    // A 12 cm thick wall whose face (x = 2.045) lies 4.5 cm into its 5 cm cells (x in [2.0,
    // 2.05]), seen at a slant from (1, 0, 0.4): one frame of rays to the face every 2 cm along
    // y at four heights. Each face cell holds the ends of the rays aimed at it, and is crossed
    // by the rays aimed further along, which reach the face through its 4.5 cm of air. Counting rays, those crossings outvote
    // the ends, the face turns free and the wall's unseen inside becomes a frontier the whole
    // wall long; AG-SLAM's code (end points weigh 100 crossings, frames normalised) keeps the
    // face occupied. The same rays, one per frame, give the ray count's answer.
    let origin = Point3::new(1.0, 0.0, 0.4);
    let ends: Vec<Point3> = (0..150)
        .flat_map(|k| {
            let y = 1.0 + 0.02 * k as f64;
            [0.15, 0.3, 0.45, 0.6].map(|z| Point3::new(2.045, y, z))
        })
        .collect();
    let mut votes = EvidenceGrid::new(EvidenceConfig::default());
    votes.integrate_frame(origin, &ends);
    let mut counts = EvidenceGrid::new(EvidenceConfig {
        frame_votes: false,
        ..crossed()
    });
    counts.integrate_frame(origin, &ends);
    let mut by_ray = EvidenceGrid::new(crossed());
    for end in &ends {
        by_ray.integrate_ray(origin, *end);
    }
    assert_eq!(by_ray.classes(), counts.classes());
    let face = |grid: &EvidenceGrid, class: CellClass| {
        (0..50)
            .filter(|k| grid.class([2.025, 1.525 + 0.05 * *k as f64]) == class)
            .count()
    };
    assert_eq!(face(&votes, CellClass::Occupied), 50);
    assert!(
        face(&counts, CellClass::Free) >= 25,
        "counting rays, the face is mostly free: {}",
        face(&counts, CellClass::Free)
    );
    // The cells before the face are free in both; behind it nothing is seen.
    for grid in [&votes, &counts] {
        assert_eq!(grid.class([1.975, 2.5]), CellClass::Free);
        assert_eq!(grid.class([2.075, 2.5]), CellClass::Unknown);
    }
    let frontier_behind_the_face = |grid: &EvidenceGrid| {
        let g = grid.classes();
        let free = frontier::reachable_free(&g, [1.6, 1.5]);
        let cells = frontier::frontier_cells(&g, &free);
        (0..g.len())
            .filter(|c| cells[*c] && g.centre(*c)[0] > 2.05)
            .count()
    };
    assert_eq!(frontier_behind_the_face(&votes), 0);
    assert!(frontier_behind_the_face(&counts) >= 10);
}

#[test]
fn with_a_free_range_a_long_ray_clears_only_near_the_camera_and_still_marks_its_wall() {
    // A level ray 5 m to a wall point: with free evidence to 3 m only, the cells up to 3 m
    // are free, those from 3 m to the wall stay unseen (a frontier at 3 m), the wall is hit.
    let mut grid = EvidenceGrid::new(EvidenceConfig {
        free_range: 3.0,
        ..crossed()
    });
    grid.integrate_ray(Point3::new(0.0, 0.025, 0.4), Point3::new(5.0, 0.025, 0.4));
    for k in 0..100 {
        let x = 0.025 + 0.05 * k as f64;
        let expected = if x < 3.0 - 0.05 {
            CellClass::Free
        } else if x > 3.0 + 0.05 {
            CellClass::Unknown
        } else {
            continue;
        };
        assert_eq!(grid.class([x, 0.025]), expected, "x = {x}");
    }
    assert_eq!(grid.class([5.025, 0.025]), CellClass::Occupied);
}

#[test]
fn free_evidence_comes_only_from_where_a_ray_is_within_the_height_band() {
    // Rays along one row of cells, falling to the floor, rising over the band, level below,
    // within and above it: each cell is free exactly where a brute-force walk along the ray
    // (1 mm steps) is within [free_from_height, free_height], unseen where it never is. A ray
    // sliding under an overhang at floor height (a ball's lower half) clears nothing.
    let config = EvidenceConfig {
        free_from_height: 0.1,
        free_height: 0.6,
        ..crossed()
    };
    let rays = [
        ([0.0, 0.4], [4.0, 0.0]),
        ([0.0, 0.4], [4.0, 1.2]),
        ([0.0, 0.05], [3.0, 0.0]),
        ([0.0, 0.05], [3.0, 0.3]),
        ([0.0, 0.3], [2.5, 0.3]),
        ([0.0, 0.8], [2.5, 0.8]),
        ([0.0, 0.8], [4.0, -0.2]),
    ];
    let margin = 0.005;
    for (from, to) in rays {
        let mut grid = EvidenceGrid::new(config);
        let (origin, end) = (
            Point3::new(0.0, 0.025, from[1]),
            Point3::new(to[0], 0.025, to[1]),
        );
        grid.integrate_ray(origin, end);
        let cells = (to[0] / 0.05).floor() as usize;
        let mut checked = 0;
        for k in 0..cells {
            let heights: Vec<f64> = (0..=50)
                .map(|i| 0.05 * k as f64 + 0.001 * i as f64)
                .map(|x| from[1] + (to[1] - from[1]) * x / to[0])
                .collect();
            let within = |lo: f64, hi: f64| heights.iter().any(|&z| z >= lo && z <= hi);
            let expected = if within(0.1 + margin, 0.6 - margin) {
                CellClass::Free
            } else if !within(0.1 - margin, 0.6 + margin) {
                CellClass::Unknown
            } else {
                continue;
            };
            checked += 1;
            let x = 0.025 + 0.05 * k as f64;
            assert_eq!(
                grid.class([x, 0.025]),
                expected,
                "ray {from:?} -> {to:?}, x = {x}"
            );
        }
        assert!(
            checked + 4 >= cells,
            "ray {from:?} -> {to:?}: {checked} of {cells}"
        );
    }
}

#[test]
fn with_height_slices_a_cell_is_free_only_once_rays_crossed_it_at_every_height() {
    // A camera 0.4 m up looks along one row of cells at a 0.55 m box (x 1.5-1.7 m) before a
    // wall at 4 m: a fan of rays to the floor, the box and the wall. Each cell's class is
    // checked against a brute-force walk (0.1 mm steps) that marks the slice of every height
    // a free ray passes: free exactly when all four slices of 0.1-0.4 m are marked. The box's
    // far side, crossed only by rays over its top, is unseen with slices and free without.
    let config = EvidenceConfig {
        free_from_height: 0.1,
        free_height: 0.6,
        height_slices: 4,
        slices_top: 0.4,
        ..crossed()
    };
    let origin = Point3::new(0.0, 0.025, 0.4);
    let ends: Vec<Point3> = (0..=120)
        .map(|k| {
            // A level direction at angle a below (+) or above (-) the horizon.
            let a = (-25.0 + 0.5 * k as f64).to_radians();
            let slope = -a.tan();
            let floor = if slope < 0.0 {
                0.4 / -slope
            } else {
                f64::INFINITY
            };
            let x_box = 1.5;
            let z_box = 0.4 + slope * x_box;
            let x = if (0.0..=0.55).contains(&z_box) && floor > x_box {
                x_box
            } else {
                floor.min(4.0)
            };
            Point3::new(x, 0.025, 0.4 + slope * x)
        })
        .collect();
    let mut sliced = EvidenceGrid::new(config);
    let mut plain = EvidenceGrid::new(EvidenceConfig {
        height_slices: 0,
        ..config
    });
    for end in &ends {
        sliced.integrate_ray(origin, *end);
        plain.integrate_ray(origin, *end);
    }
    let cells = 80usize;
    let mut marked = vec![0u32; cells];
    let mut hit_cells = vec![false; cells];
    for end in &ends {
        let hit = end.z >= config.min_height && end.z <= config.max_height;
        let end_cell = (end.x / 0.05).floor() as usize;
        if hit && end_cell < cells {
            hit_cells[end_cell] = true;
        }
        let steps = (end.x / 1e-4) as usize;
        for i in 0..steps {
            let x = i as f64 * 1e-4;
            let z = origin.z + (end.z - origin.z) * x / end.x;
            let c = (x / 0.05).floor() as usize;
            if (hit && c == end_cell) || !(0.1..=0.6).contains(&z) || c >= cells {
                continue;
            }
            if z <= 0.4 {
                marked[c] |= 1 << (((z - 0.1) / 0.075).floor() as u32).min(3);
            }
        }
    }
    let mut free = 0;
    for (c, &mask) in marked.iter().enumerate() {
        if hit_cells[c] {
            continue;
        }
        let x = 0.025 + 0.05 * c as f64;
        let expected = if mask == 0b1111 {
            free += 1;
            CellClass::Free
        } else {
            CellClass::Unknown
        };
        assert_eq!(
            sliced.class([x, 0.025]),
            expected,
            "x = {x}, slices {mask:04b}"
        );
    }
    assert!(free > 20, "{free} free cells");
    // One slice (RT-GuIDE's): free where a ray crossed below the camera; the box's far side
    // is still unseen, the floor before it free as without slices.
    let mut one = EvidenceGrid::new(EvidenceConfig {
        height_slices: 1,
        ..config
    });
    for end in &ends {
        one.integrate_ray(origin, *end);
    }
    for x in [1.775, 1.825, 1.875] {
        assert_eq!(sliced.class([x, 0.025]), CellClass::Unknown, "x = {x}");
        assert_eq!(one.class([x, 0.025]), CellClass::Unknown, "x = {x}");
        assert_eq!(plain.class([x, 0.025]), CellClass::Free, "x = {x}");
    }
    for x in [0.775, 1.025, 1.275] {
        assert_eq!(one.class([x, 0.025]), CellClass::Free, "x = {x}");
        assert_eq!(plain.class([x, 0.025]), CellClass::Free, "x = {x}");
    }
}

fn mount(width: u32, height: u32) -> CameraMount {
    CameraMount {
        intrinsics: Intrinsics::from_fovy(60f64.to_radians(), width, height),
        range: 5.0,
        ..CameraMount::default()
    }
}

/// Distance from the robot's centre to the nearest wall or box of the scene, metres.
fn clearance(scene: &BoxScene, p: &Pose2) -> f64 {
    let r = &scene.room;
    let mut d = (p.x - r.min[0])
        .min(r.max[0] - p.x)
        .min(p.y - r.min[1])
        .min(r.max[1] - p.y);
    for b in &scene.boxes {
        let dx = (b.min[0] - p.x).max(p.x - b.max[0]).max(0.0);
        let dy = (b.min[1] - p.y).max(p.y - b.max[1]).max(0.0);
        d = d.min(dx.hypot(dy));
    }
    d
}

struct Run {
    ended: Option<String>,
    min_clearance: f64,
    commands: Vec<autonomy::drive::UnicycleCommand>,
    poses: Vec<Pose2>,
}

/// A closed loop in a ray-cast scene: 5 frames per 1 s plan, the mapper on each plan's last
/// frame, the plan's commands applied exactly by the unicycle model.
fn closed_loop(planner: &mut dyn Planner, scene: &BoxScene, start: Pose2, plans: usize) -> Run {
    let m = mount(96, 72);
    let mut mapper = Mapper::new(
        MapperConfig {
            iterations: 5,
            ..MapperConfig::default()
        },
        Rasteriser::Cpu,
    );
    let mut pose = start;
    let mut run = Run {
        ended: None,
        min_clearance: f64::INFINITY,
        commands: Vec::new(),
        poses: vec![start],
    };
    for _ in 0..plans {
        let camera = m.camera_at(&pose);
        let frame = scene.render(&camera);
        planner.observe(
            &Observation {
                rgb: &[],
                depth: &frame.depth,
                camera: &camera,
                max_range: 5.0,
                robot: pose,
            },
            mapper.map(),
        );
        mapper
            .integrate(
                &Frame {
                    colour: frame.colour,
                    depth: frame.depth,
                },
                &camera.world_from_camera.to_homogeneous(),
                &camera.intrinsics,
            )
            .expect("integrate");
        let schedule: Vec<(autonomy::drive::UnicycleCommand, f64)> =
            match planner.plan(mapper.map(), pose) {
                Decision::Go(plan) => {
                    run.commands.extend(plan.commands.iter().copied());
                    plan.commands.iter().map(|u| (*u, plan.period)).collect()
                }
                Decision::Fail(f) => {
                    assert_eq!(f.recovery(), Recovery::TurnInPlace, "{f}");
                    vec![(autonomy::drive::UnicycleCommand { v: 0.0, w: 0.9 }, 1.0)]
                }
                Decision::Done(reason) => {
                    run.ended = Some(reason);
                    break;
                }
                Decision::Abort(reason) => panic!("FBE never aborts: {reason}"),
            };
        // One second of the schedule, with 5 frames along it for the grid.
        let mut left = 1.0;
        let mut queue = schedule.clone();
        let mut since_frame = 0.0;
        while left > 1e-9 {
            let Some((u, d)) = queue.first_mut() else {
                break;
            };
            let dt = d.min(left).min(0.05);
            pose = advance(&pose, u, dt);
            *d -= dt;
            left -= dt;
            since_frame += dt;
            if *d <= 1e-9 {
                queue.remove(0);
            }
            run.min_clearance = run.min_clearance.min(clearance(scene, &pose));
            if since_frame >= 0.2 - 1e-9 && left > 1e-9 {
                since_frame = 0.0;
                let camera = m.camera_at(&pose);
                let f = scene.render(&camera);
                planner.observe(
                    &Observation {
                        rgb: &[],
                        depth: &f.depth,
                        camera: &camera,
                        max_range: 5.0,
                        robot: pose,
                    },
                    mapper.map(),
                );
            }
        }
        run.poses.push(pose);
    }
    run
}

fn fbe() -> FbePlanner {
    FbePlanner::new(
        FbeConfig::default(),
        ExecutorConfig::default(),
        CollisionEngine::Grid,
    )
}

fn room_start() -> Pose2 {
    Pose2 {
        x: -1.0,
        y: -1.0,
        theta: 0.3,
    }
}

#[test]
fn fbe_explores_a_ray_cast_room_until_no_frontier_it_has_not_tried_is_left() {
    let scene = BoxScene::room();
    let mut planner = fbe();
    let run = closed_loop(&mut planner, &scene, room_start(), 150);
    let ended = run.ended.expect("FBE ends by itself");
    // No frontier left, or only clusters it has visited: unseen pockets inside the table-sized
    // box, whose top the papers' grid draws free lines across, joined into one cluster (22
    // cells) across those lines; no view clears them. Never a cluster it has not tried.
    let all_visited = ended
        .strip_prefix("no reachable frontier left: ")
        .and_then(|rest| {
            let (left, rest) = rest.split_once(" frontier clusters remain, ")?;
            let (visited, _) = rest.split_once(" of them already visited")?;
            Some(left == visited)
        })
        .unwrap_or(false);
    assert!(
        ended.starts_with("no frontier left") || all_visited,
        "{ended}"
    );
    // The robot's footprint (0.3 m) never touched a wall or box.
    assert!(run.min_clearance > 0.3, "clearance {}", run.min_clearance);
    let limits = DriveLimits::default();
    assert!(run.commands.iter().all(|u| limits.admits(*u)));
}

/// Three Gaussians in front of a 16 x 16 camera, overlapping.
fn three() -> (Gaussians, PinholeCamera) {
    let mut g = Gaussians::default();
    g.push([0.1, 0.05, 2.0], 0.12, 0.7, [0.9, 0.2, 0.1]);
    g.push([-0.1, 0.0, 2.3], 0.2, 0.5, [0.1, 0.8, 0.3]);
    g.push([0.0, -0.1, 2.6], 0.25, 0.8, [0.3, 0.3, 0.9]);
    let camera = PinholeCamera {
        intrinsics: Intrinsics::from_fovy(40f64.to_radians(), 16, 16),
        world_from_camera: autonomy::math::Isometry3::identity(),
    };
    (g, camera)
}

#[test]
fn the_fisher_backward_squares_each_pixel_on_its_own() {
    let (g, camera) = three();
    let reference_h = reference::fisher(&g, &camera).expect("reference fisher");
    // sum_p (d f_p / d w)^2 from one-hot backward passes: pixel p's colour and depth get 1.
    let pixels = 16 * 16;
    let mut by_hand = vec![[0.0f64; FISHER_PARAMETERS]; g.len()];
    for p in 0..pixels {
        let mut grads = ImageGradients::zeros(pixels);
        grads.colour[3 * p..3 * p + 3].fill(1.0);
        grads.depth[p] = 1.0;
        let d = reference::backward(&g, &camera, &grads).expect("backward");
        for i in 0..g.len() {
            let per = [
                d.means[i][0],
                d.means[i][1],
                d.means[i][2],
                d.log_radii[i],
                d.logit_opacities[i],
                d.colours[i][0],
                d.colours[i][1],
                d.colours[i][2],
            ];
            for k in 0..FISHER_PARAMETERS {
                by_hand[i][k] += f64::from(per[k]) * f64::from(per[k]);
            }
        }
    }
    let cpu_h = cpu::fisher(&cpu::render(&g, &camera).expect("render"));
    for i in 0..g.len() {
        for k in 0..FISHER_PARAMETERS {
            let (r, h, c) = (reference_h[i][k], by_hand[i][k], f64::from(cpu_h[i][k]));
            let scale = r.abs().max(1e-3);
            assert!(
                (r - h).abs() / scale < 1e-4,
                "gaussian {i} param {k}: {r} vs {h}"
            );
            assert!(
                (r - c).abs() / scale < 2e-3,
                "gaussian {i} param {k}: cpu {c} vs {r}"
            );
        }
    }
    // Not the square of the summed gradient.
    let mut all = ImageGradients::zeros(pixels);
    all.colour.fill(1.0);
    all.depth.fill(1.0);
    let summed = reference::backward(&g, &camera, &all).expect("backward");
    let squared = f64::from(summed.means[0][0]).powi(2);
    assert!((squared - reference_h[0][0]).abs() > 1e-3 * reference_h[0][0].abs().max(1e-9));
}

#[test]
fn culled_gaussians_get_no_information() {
    let (mut g, camera) = three();
    g.push([0.0, 0.0, -1.0], 0.1, 0.9, [0.5; 3]); // behind the camera
    g.push([30.0, 0.0, 2.0], 0.1, 0.9, [0.5; 3]); // far off screen
    let h = cpu::fisher(&cpu::render(&g, &camera).expect("render"));
    assert_eq!(h[3], [0.0; FISHER_PARAMETERS]);
    assert_eq!(h[4], [0.0; FISHER_PARAMETERS]);
    assert!(h[0].iter().all(|v| *v > 0.0));
}

fn dense(h: &[[f32; FISHER_PARAMETERS]]) -> SparseFisher {
    SparseFisher {
        indices: (0..h.len() as u32).collect(),
        values: h.to_vec(),
    }
}

#[test]
fn eig_falls_as_the_training_set_grows_and_is_scale_free() {
    let (g, camera) = three();
    let h_x = cpu::fisher(&cpu::render(&g, &camera).expect("render"));
    let train = vec![[0.5f32; FISHER_PARAMETERS]; g.len()];
    let lambda = 1.0;
    let before = expected_information_gain(&h_x, &train, lambda);
    let mut grown = train.clone();
    for (t, x) in grown.iter_mut().zip(&h_x) {
        for (a, b) in t.iter_mut().zip(x) {
            *a += b;
        }
    }
    let after = expected_information_gain(&h_x, &grown, lambda);
    assert!(after < before, "{after} < {before}");
    // Scaling H_cand, H_train and lambda together leaves EIG unchanged.
    let scale = 1e-6f32;
    let s = |h: &[[f32; FISHER_PARAMETERS]]| -> Vec<[f32; FISHER_PARAMETERS]> {
        h.iter().map(|v| v.map(|x| x * scale)).collect()
    };
    let scaled = expected_information_gain(&s(&h_x), &s(&train), lambda * f64::from(scale));
    assert!(
        (scaled - before).abs() / before < 1e-4,
        "{scaled} vs {before}"
    );
    // The sparse form agrees with the dense one.
    let sparse = dense(&h_x).eig(&train, &HashMap::new(), lambda);
    assert!((sparse - before).abs() / before < 1e-9);
}

#[test]
fn a_two_view_path_score_matches_a_hand_computation() {
    let config = AgslamConfig::default();
    let train = vec![[1.0f32; FISHER_PARAMETERS], [3.0; FISHER_PARAMETERS]];
    let a = vec![[2.0f32; FISHER_PARAMETERS], [0.0; FISHER_PARAMETERS]];
    let b = vec![[1.0f32; FISHER_PARAMETERS], [4.0; FISHER_PARAMETERS]];
    let views = vec![(dense(&a), 1.5), (dense(&b), -0.5)];
    let score = path_score(&views, 10, 5, &train, &config, 0.25);
    // View 1: tr = 8 * 2 / (1 + 1) = 8. View 2 against H_train + a: 8 * 1 / (3 + 1) +
    // 8 * 4 / (3 + 1) = 2 + 8 = 10. Pose terms 0.2 * 5 * (1.5 - 0.5).
    let hand = (0.2 * 5.0 * (1.5 + -0.5) + 8f64.ln() + 10f64.ln()) / 10.0 + 30.0 * 0.25;
    assert!((score - hand).abs() < 1e-9, "{score} vs {hand}");
}

#[test]
fn well_observed_gaussians_are_worth_less_than_new_ones() {
    let scene = BoxScene::room();
    let m = mount(64, 48);
    let mut mapper = Mapper::new(MapperConfig::default(), Rasteriser::Cpu);
    // Map the room's -y half from its middle.
    let mut seen_pose = Pose2 {
        x: 0.0,
        y: 0.0,
        theta: -std::f64::consts::FRAC_PI_2,
    };
    for k in 0..6 {
        seen_pose.theta = -std::f64::consts::FRAC_PI_2 + 0.3 * (k as f64 - 2.5);
        let camera = m.camera_at(&seen_pose);
        let f = scene.render(&camera);
        mapper
            .integrate(
                &Frame {
                    colour: f.colour,
                    depth: f.depth,
                },
                &camera.world_from_camera.to_homogeneous(),
                &camera.intrinsics,
            )
            .expect("integrate");
    }
    let mut planner = AgslamPlanner::new(
        AgslamConfig {
            resolution_divisor: 1,
            ..AgslamConfig::default()
        },
        m,
        ExecutorConfig::default(),
        CollisionEngine::Grid,
    );
    let seen = m.camera_at(&Pose2 {
        x: 0.0,
        y: 0.0,
        theta: -std::f64::consts::FRAC_PI_2,
    });
    for _ in 0..20 {
        planner.add_keyframe(mapper.map(), seen);
    }
    // The same Gaussians again from the same place, against Gaussians no keyframe saw: the
    // map plus an unseen copy shifted to the +y wall.
    let map = mapper.map();
    let mut unseen = map.gaussians.clone();
    for m in &mut unseen.means {
        m[1] = -m[1];
    }
    let train = planner.train_for(map);
    let mut all = map.gaussians.clone();
    for i in 0..unseen.len() {
        all.push(
            unseen.means[i],
            unseen.log_radii[i].exp(),
            1.0 / (1.0 + (-unseen.logit_opacities[i]).exp()),
            unseen.colours[i],
        );
    }
    let mut train_all = train.clone();
    train_all.resize(all.len(), [0.0; FISHER_PARAMETERS]);
    let eig = |theta: f64| {
        let camera = m.camera_at(&Pose2 {
            x: 0.0,
            y: 0.0,
            theta,
        });
        let h = cpu::fisher(&cpu::render(&all, &camera).expect("render"));
        expected_information_gain(&h, &train_all, 1.0)
    };
    let old = eig(-std::f64::consts::FRAC_PI_2);
    let new = eig(std::f64::consts::FRAC_PI_2);
    assert!(old < 0.5 * new, "seen {old} vs new {new}");
}

#[test]
fn incremental_and_full_training_sets_agree_on_a_settled_map() {
    let (g, _) = three();
    let map = GaussianMap::new(g.clone(), vec![0.0; g.len()]);
    let m = mount(32, 24);
    let make = |train| {
        AgslamPlanner::new(
            AgslamConfig {
                train,
                resolution_divisor: 1,
                ..AgslamConfig::default()
            },
            m,
            ExecutorConfig::default(),
            CollisionEngine::Grid,
        )
    };
    let (mut inc, mut full) = (make(TrainMode::Incremental), make(TrainMode::Full));
    for k in 0..4 {
        let camera = look_at(
            [0.3 * k as f64 - 0.4, -0.2, -0.5],
            [0.0, 0.0, 2.3],
            m.intrinsics,
        );
        inc.add_keyframe(&map, camera);
        full.add_keyframe(&map, camera);
    }
    let (a, b) = (inc.train_for(&map), full.train_for(&map));
    for (x, y) in a.iter().zip(&b) {
        for (p, q) in x.iter().zip(y) {
            assert!((p - q).abs() <= 1e-5 * p.abs().max(1e-6), "{p} vs {q}");
        }
        assert!(x.iter().any(|v| *v > 0.0));
    }
}

#[test]
fn pose_information_is_positive_definite_and_texture_constrains_more() {
    // A wall 2 m ahead, densely tiled with Gaussians: checkered colours against a flat grey.
    let wall = |textured: bool| {
        let mut g = Gaussians::default();
        for i in 0..40 {
            for j in 0..30 {
                let (x, y) = (-1.0 + 0.05 * i as f32, -0.75 + 0.05 * j as f32);
                let c = if textured && (i / 4 + j / 4) % 2 == 0 {
                    0.9
                } else {
                    0.4
                };
                g.push(
                    [x, y, 2.0 + 0.2 * (x * 3.0).sin() * (y * 2.0).cos()],
                    0.03,
                    0.9,
                    [c; 3],
                );
            }
        }
        g
    };
    let camera = PinholeCamera {
        intrinsics: Intrinsics::from_fovy(50f64.to_radians(), 64, 48),
        world_from_camera: autonomy::math::Isometry3::identity(),
    };
    let info = |g: &Gaussians| {
        let r = cpu::render(g, &camera).expect("render");
        cpu::fisher_and_pose(&r).1
    };
    let (textured, flat) = (info(&wall(true)), info(&wall(false)));
    let m = nalgebra::Matrix6::from_fn(|r, c| textured[r][c]);
    let eigen = m.symmetric_eigen();
    assert!(
        eigen.eigenvalues.iter().all(|e| *e > 0.0),
        "{:?}",
        eigen.eigenvalues
    );
    let (lt, lf) = (cpu::log_det(&textured, -1e9), cpu::log_det(&flat, -1e9));
    assert!(lt > lf, "textured {lt} vs flat {lf}");
    // log det by Cholesky equals the eigenvalues' log sum.
    let by_eigen: f64 = eigen.eigenvalues.iter().map(|e| e.ln()).sum();
    assert!((lt - by_eigen).abs() < 1e-6 * by_eigen.abs().max(1.0));
}

/// A map of a wall of Gaussians 2 m ahead of the origin.
fn wall_map() -> GaussianMap {
    let mut g = Gaussians::default();
    for i in 0..60 {
        for j in 0..20 {
            g.push(
                [2.0, -1.5 + 0.05 * i as f32, 0.05 + 0.06 * j as f32],
                0.03,
                0.9,
                [0.6; 3],
            );
        }
    }
    let n = g.len();
    GaussianMap::new(g, (0..n).map(|i| (i % 5) as f32 * 1e-3).collect())
}

fn planners() -> Vec<Box<dyn Planner>> {
    let rt = PlannerConfig {
        mount: mount(64, 48),
        ..PlannerConfig::default()
    };
    vec![
        Box::new(RtGuidePlanner::new(rt, CollisionEngine::Grid)),
        Box::new(fbe()),
        Box::new(AgslamPlanner::new(
            AgslamConfig::default(),
            mount(64, 48),
            ExecutorConfig::default(),
            CollisionEngine::Grid,
        )),
    ]
}

#[test]
fn every_planner_fails_with_a_recovery_when_it_starts_inside_an_obstacle() {
    let mut map = wall_map();
    // Obstacles right at the robot, on its +x side.
    for k in 0..6 {
        map.gaussians
            .push([0.12, -0.1 + 0.04 * k as f32, 0.25], 0.02, 0.9, [0.5; 3]);
        map.uncertainty.push(0.0);
    }
    map.adopt_new_gaussians();
    let start = Pose2 {
        x: 0.0,
        y: 0.0,
        theta: 0.0,
    };
    for mut planner in planners() {
        let name = planner.name().to_owned();
        // The frontier planners begin with a look around; the next plan is the real one.
        let mut decision = planner.plan(&map, start);
        if let Decision::Go(plan) = &decision {
            assert!(
                plan.commit.is_infinite(),
                "{name}: the first plan is a held look around"
            );
            decision = planner.plan(&map, start);
        }
        match decision {
            Decision::Fail(f @ PlanFailure::StartInCollision { away }) => {
                assert_eq!(f.recovery(), Recovery::BackOff { away }, "{name}");
                assert!(
                    (away.abs() - std::f64::consts::PI).abs() < 0.5,
                    "{name}: away {away}"
                );
            }
            other => panic!("{name}: expected StartInCollision, got {other:?}"),
        }
    }
}

#[test]
fn every_planner_stays_within_the_drive_limits_and_repeats_exactly() {
    let scene = BoxScene::room();
    let limits = DriveLimits::default();
    for k in 0..3 {
        let runs: Vec<Run> = (0..2)
            .map(|_| {
                let mut planner = planners().swap_remove(k);
                closed_loop(planner.as_mut(), &scene, room_start(), 8)
            })
            .collect();
        let name = planners()[k].name().to_owned();
        assert!(
            runs[0].commands.iter().all(|u| limits.admits(*u)),
            "{name}: {:?}",
            runs[0].commands
        );
        assert!(!runs[0].commands.is_empty(), "{name} planned");
        assert_eq!(runs[0].commands, runs[1].commands, "{name} repeats");
        assert_eq!(runs[0].poses, runs[1].poses, "{name} repeats");
    }
}

#[test]
fn a_schedule_holds_for_its_commitment_and_recoveries_to_their_end() {
    use autonomy::explore::schedule::Schedule;
    use autonomy::explore::Plan;
    let u = autonomy::drive::UnicycleCommand { v: 0.3, w: 0.1 };
    let plan = |commit: f64| Plan {
        commands: vec![u; 5],
        period: 1.0,
        states: Vec::new(),
        target: None,
        guidance: Vec::new(),
        score: 0.0,
        candidates: 1,
        alternatives: Vec::new(),
        commit,
    };
    let replaced = Schedule::from_plan(&plan(0.0), 10.0);
    assert!(!replaced.holding_at(10.0));
    let committed = Schedule::from_plan(&plan(2.0), 10.0);
    assert!(committed.holding_at(11.99) && !committed.holding_at(12.0));
    let held = Schedule::from_plan(&plan(f64::INFINITY), 10.0);
    assert!(held.holding_at(14.99) && !held.holding_at(15.0));
    let limits = DriveLimits::default();
    let back_off = Schedule::recovery(Recovery::BackOff { away: 1.0 }, 3.0, 0.0, &limits);
    assert!(back_off.holding_at(back_off.end() - 1e-6) && !back_off.holding_at(back_off.end()));
    assert!(back_off.commands.iter().all(|c| limits.admits(*c)));
    // The back-off turns to the heading given, then drives 0.15 m that way.
    let end = back_off.predict(Pose2::default(), 3.0, back_off.end() - 3.0);
    assert!((end.theta - 1.0).abs() < 0.1, "{end:?}");
    let driven = 0.3 * back_off.commands.iter().filter(|c| c.v > 0.0).count() as f64 * 0.1;
    assert!((driven - 0.15).abs() < 1e-9);
}

#[test]
fn a_free_space_path_goes_through_the_gap_and_keeps_its_clearance() {
    use autonomy::explore::fbe::FrontierView;
    // 4 x 3 m of free floor with a wall across x = 2 m and a 1 m gap at y in [1.8, 2.8].
    let (w, h) = (80, 60);
    let mut g = ClassGrid::filled([w, h], [0.0, 0.0], 0.05, CellClass::Free);
    for c in 0..g.len() {
        let (x, y) = (c % w, c / w);
        let edge = x == 0 || y == 0 || x == w - 1 || y == h - 1;
        let wall = (39..=41).contains(&x) && !(36..56).contains(&y);
        if edge || wall {
            g.classes[c] = CellClass::Occupied;
        }
    }
    let robot = Pose2 {
        x: 1.0,
        y: 0.6,
        theta: 0.0,
    };
    let view = FrontierView::new(g.clone(), robot, 0.3, 0.3);
    let target = [3.0, 0.6];
    let path = view.guidance(robot, target);
    assert!(view.path_length(target).is_finite());
    // Brute force: every point of the path is at least 0.3 m (less half a cell) from every
    // occupied cell centre, except within the footprint of the start.
    let occupied: Vec<[f64; 2]> = (0..g.len())
        .filter(|c| g.classes[*c] == CellClass::Occupied)
        .map(|c| g.centre(c))
        .collect();
    for p in &path {
        if (p[0] - robot.x).hypot(p[1] - robot.y) <= 0.35 {
            continue;
        }
        let d = occupied
            .iter()
            .map(|o| (o[0] - p[0]).hypot(o[1] - p[1]))
            .fold(f64::INFINITY, f64::min);
        assert!(d >= 0.3 - 0.06, "{p:?} is {d:.3} m from the wall");
    }
    // It crosses the wall's line inside the gap, and is longer than the straight line.
    assert!(path
        .windows(2)
        .any(|s| s[0][0] < 2.0 && s[1][0] >= 2.0 && (1.8..2.8).contains(&s[1][1])));
    assert!(view.path_length(target) > 2.0 + 1.0);
}

#[test]
fn goals_by_a_frontier_are_the_admitted_cells_nearest_the_cluster_by_brute_force() {
    use autonomy::explore::fbe::FrontierView;
    // 6 x 4 m: the west 3 m seen and free (a box in it), the east unknown, walls round.
    let (w, h) = (120, 80);
    let mut g = ClassGrid::filled([w, h], [0.0, 0.0], 0.05, CellClass::Unknown);
    for c in 0..g.len() {
        let (x, y) = (c % w, c / w);
        let edge = x == 0 || y == 0 || x == w - 1 || y == h - 1;
        let furniture = (40..=52).contains(&x) && (30..=44).contains(&y);
        g.classes[c] = if edge || furniture {
            CellClass::Occupied
        } else if x < 60 {
            CellClass::Free
        } else {
            CellClass::Unknown
        };
    }
    let robot = Pose2 {
        x: 0.8,
        y: 2.0,
        theta: 0.0,
    };
    let view = FrontierView::new(g.clone(), robot, 0.3, 0.3);
    assert!(!view.clusters.is_empty());
    for (radius, clearance) in [(1.0, 0.35), (0.4, 0.35), (1.5, 0.6)] {
        for cluster in &view.clusters {
            let c = cluster.centroid;
            let mut brute: Vec<usize> = (0..g.len())
                .filter(|i| {
                    let p = g.centre(*i);
                    (p[0] - c[0]).hypot(p[1] - c[1]) <= radius
                        && view.clearance[*i] >= clearance
                        && view.distance[*i].is_finite()
                })
                .collect();
            brute.sort_by(|a, b| {
                let (pa, pb) = (g.centre(*a), g.centre(*b));
                (pa[0] - c[0])
                    .hypot(pa[1] - c[1])
                    .total_cmp(&(pb[0] - c[0]).hypot(pb[1] - c[1]))
                    .then(view.distance[*a].total_cmp(&view.distance[*b]))
                    .then(a.cmp(b))
            });
            let brute: Vec<[f64; 2]> = brute.into_iter().map(|i| g.centre(i)).collect();
            // 0.4 m is too near a frontier for 0.35 m of clearance beside the box: none.
            assert_eq!(brute.is_empty(), radius < 0.5);
            assert_eq!(view.goals_near(c, radius, clearance), brute);
        }
    }
    // The frontier runs along x = 3 m; its viewpoint keeps the clearance on the seen side.
    let goal = view.goals_near(view.clusters[0].centroid, 1.0, 0.35)[0];
    assert!((2.5..3.0).contains(&goal[0]), "{goal:?}");
}

#[test]
fn line_of_sight_on_the_grid_matches_the_exact_segment_test() {
    // 4 x 4 m free with a wall block at x in [1.95, 2.05], y in [0, 2.5].
    let (w, h) = (80, 80);
    let mut g = ClassGrid::filled([w, h], [0.0, 0.0], 0.05, CellClass::Free);
    for c in 0..g.len() {
        let (x, y) = (c % w, c / w);
        if (39..41).contains(&x) && y < 50 {
            g.classes[c] = CellClass::Occupied;
        }
    }
    // Exact: does the segment meet the wall's rectangle (slab test)?
    let hits_wall = |a: [f64; 2], b: [f64; 2]| -> bool {
        let (lo, hi) = ([1.95, 0.0], [2.05, 2.5]);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for i in 0..2 {
            let d = b[i] - a[i];
            if d.abs() < 1e-12 {
                if a[i] < lo[i] || a[i] > hi[i] {
                    return false;
                }
            } else {
                let (ta, tb) = ((lo[i] - a[i]) / d, (hi[i] - a[i]) / d);
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
        }
        t0 <= t1
    };
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (mut seen, mut hidden) = (0, 0);
    for _ in 0..2000 {
        let a = [rng.gen_range(0.1..3.9), rng.gen_range(0.1..3.9)];
        let b = [rng.gen_range(0.1..3.9), rng.gen_range(0.1..3.9)];
        // Segments that pass within a quarter cell of the wall's corner are left out.
        let corner: [f64; 2] = [2.0, 2.5];
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let t = (((corner[0] - a[0]) * dx + (corner[1] - a[1]) * dy) / (dx * dx + dy * dy))
            .clamp(0.0, 1.0);
        let near = (a[0] + t * dx - corner[0]).hypot(a[1] + t * dy - corner[1]) < 0.1;
        let inside = |p: [f64; 2]| (1.9..2.1).contains(&p[0]) && p[1] < 2.6;
        if near || inside(a) || inside(b) {
            continue;
        }
        let exact = !hits_wall(a, b);
        assert_eq!(g.line_of_sight(a, b), exact, "{a:?} -> {b:?}");
        if exact {
            seen += 1;
        } else {
            hidden += 1;
        }
    }
    assert!(seen > 200 && hidden > 200, "{seen} seen, {hidden} hidden");
    // An unseen cell blocks the view like an occupied one; off the grid blocks too.
    let unseen = g.cell_of([1.0, 3.0]).expect("on the grid");
    g.classes[unseen] = CellClass::Unknown;
    assert!(!g.line_of_sight([0.5, 3.0], [1.5, 3.0]));
    assert!(!g.line_of_sight([0.5, 3.5], [4.5, 3.5]));
}

#[test]
fn the_lookahead_is_the_farthest_point_of_the_path_the_robot_sees_by_brute_force() {
    use autonomy::explore::executor::{along, visible_along};
    // The path goes north past the wall's end, east behind it and back south: the wall at
    // x = 2 m, y < 2.5 m hides its last leg from the start.
    let (w, h) = (80, 80);
    let mut g = ClassGrid::filled([w, h], [0.0, 0.0], 0.05, CellClass::Free);
    for c in 0..g.len() {
        if (39..41).contains(&(c % w)) && c / w < 50 {
            g.classes[c] = CellClass::Occupied;
        }
    }
    let path: [[f64; 2]; 4] = [[1.0, 1.0], [1.0, 3.2], [3.0, 3.2], [3.0, 1.0]];
    let sees = |p: [f64; 2]| g.line_of_sight(path[0], p);
    let total: f64 = path
        .windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum();
    // Brute force: every centimetre along the path; the first hidden point lies past the
    // turn, where the line of sight meets the wall's end.
    let first_hidden = (1..=(total * 100.0) as usize)
        .map(|i| i as f64 / 100.0)
        .find(|s| !sees(along(&path, *s)))
        .expect("the wall hides part of the path");
    assert!(
        first_hidden > 2.2 && first_hidden < total - 1.0,
        "hidden from {first_hidden} m"
    );
    let step = 0.2;
    for horizon in [1.0, 3.0, 3.7, 5.0, 8.0] {
        let goal = visible_along(&path, horizon, step, sees);
        let expected = along(&path, horizon.min(first_hidden));
        // Within one step short of the brute force, never past it or past the horizon.
        let d = (goal[0] - expected[0]).hypot(goal[1] - expected[1]);
        assert!(
            d <= step + 1e-9,
            "horizon {horizon}: {goal:?} vs {expected:?}"
        );
        assert!(sees(goal), "{goal:?} is hidden");
    }
    // Short of the wall's shadow the goal is the plain lookahead; the first step is taken
    // even when everything is hidden.
    assert_eq!(visible_along(&path, 3.0, step, sees), along(&path, 3.0));
    assert_eq!(
        visible_along(&path, 3.0, step, |_| false),
        along(&path, step)
    );
}
