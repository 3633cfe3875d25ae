//! Worlds: the generator (20 seeds of each kind pass every check, a seed repeats byte for
//! byte, the committed suite is what the generator makes), the reachability check against a
//! brute force by MuJoCo's own ray casts (with a sealed room it must report), random spawns,
//! and the bad inputs of `world generate` and `--spawn`.

use crate::support::{fixture, repo_path};
use splatloop::camera::SensorConfig;
use splatloop::evaluate::WORLD_GROUPS;
use splatloop::floorplan::FloorPlan;
use splatloop::robot::Pose2;
use splatloop::spawn::{place_robot, Spawn};
use splatloop::world::World;
use splatloop::world_check::check_world;
use splatloop::worldgen::{generate, GenerateConfig, WorldKind};
use std::collections::VecDeque;

fn load(path: &std::path::Path) -> World {
    World::load(path, &SensorConfig::default()).expect("world loads")
}

#[test]
fn twenty_seeds_of_each_kind_pass_every_check_and_repeat_byte_for_byte() {
    let dir = tempfile::tempdir().expect("tempdir");
    for kind in WorldKind::ALL {
        let (lo, hi) = kind.area_range();
        let rooms = match kind {
            WorldKind::Apartment => 3..=6,
            WorldKind::Office => 4..=8,
            WorldKind::Warehouse => 1..=3,
        };
        for seed in 1..=20 {
            let out = dir.path().join(format!("{}_{seed}.xml", kind.name()));
            let config = GenerateConfig {
                kind,
                seed,
                area: None,
                out: out.clone(),
                overwrite: false,
            };
            let world = generate(&config, &mut |_, _| {}).expect("generates");
            let name = format!("{} seed {seed}", kind.name());
            assert!(world.report.ok(), "{name}: {:?}", world.report.problems);
            assert!(
                (lo..=hi).contains(&world.area),
                "{name}: {:.1} m2",
                world.area
            );
            assert!(
                rooms.contains(&world.rooms),
                "{name}: {} rooms",
                world.rooms
            );
            assert!(
                world.wall_height >= 2.5,
                "{name}: walls {:.2} m",
                world.wall_height
            );
            for w in &world.door_widths {
                assert!((1.0..=1.4).contains(w), "{name}: a {w:.2} m door");
            }
            assert!(
                world.doors >= world.rooms.saturating_sub(1),
                "{name}: {} doors",
                world.doors
            );
            assert!(world.report.reachable_share > 0.999, "{name}");
            // The file on disk passes the check on its own, from its own spawn site.
            let (again, _) = check_world(&load(&out)).expect("check");
            assert!(again.ok(), "{name} on disk: {:?}", again.problems);
            if seed <= 2 {
                let copy = dir.path().join(format!("{}_{seed}_again.xml", kind.name()));
                let config = GenerateConfig {
                    out: copy.clone(),
                    ..config
                };
                generate(&config, &mut |_, _| {}).expect("generates again");
                let (a, b) = (
                    std::fs::read(&out).expect("read"),
                    std::fs::read(&copy).expect("read"),
                );
                assert!(a == b, "{name}: two runs differ");
            }
        }
    }
}

#[test]
fn the_committed_suite_is_what_the_generator_makes() {
    let manifest: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(repo_path("worlds/suite/manifest.json")).expect("manifest"),
    )
    .expect("manifest parses");
    let entries = manifest.as_array().expect("a list");
    assert!(entries.len() >= 12);
    // Written at the suite's depth under worlds/, so the relative include paths are the same.
    let dir = tempfile::tempdir_in(repo_path("worlds")).expect("tempdir");
    for kind in WorldKind::ALL {
        let count = entries.iter().filter(|e| e["kind"] == kind.name()).count();
        assert!(count >= 4, "{} worlds of kind {}", count, kind.name());
    }
    for entry in entries {
        let file = entry["file"].as_str().expect("file");
        let kind: WorldKind = entry["kind"].as_str().expect("kind").parse().expect("kind");
        let seed = entry["seed"].as_u64().expect("seed");
        let out = dir.path().join(file);
        let config = GenerateConfig {
            kind,
            seed,
            area: None,
            out: out.clone(),
            overwrite: false,
        };
        let world = generate(&config, &mut |_, _| {}).expect("generates");
        let committed =
            std::fs::read(repo_path(&format!("worlds/suite/{file}"))).expect("committed");
        assert!(
            std::fs::read(&out).expect("fresh") == committed,
            "{file} differs from a fresh generation"
        );
        assert_eq!(entry["rooms"].as_u64(), Some(world.rooms as u64), "{file}");
        assert!(
            (entry["area_m2"].as_f64().expect("area") - world.area).abs() < 0.06,
            "{file}"
        );
    }
}

/// Whether the robot fits at (x, y) by MuJoCo's rays: 64 directions at five heights up to the
/// robot's top, every one hitting the world (so it is inside) no nearer than `clearance`.
/// Returns the nearest hit.
fn ray_clearance(world: &World, x: f64, y: f64) -> f64 {
    let mut nearest = f64::INFINITY;
    for z in [0.03, 0.1, 0.2, 0.3, 0.4] {
        for k in 0..64 {
            let a = std::f64::consts::TAU * f64::from(k) / 64.0;
            let hit = world.data().ray(
                &nalgebra::Point3::new(x, y, z),
                &nalgebra::Vector3::new(a.cos(), a.sin(), 0.0),
                WORLD_GROUPS,
                Some(world.robot().body),
            );
            nearest = nearest.min(hit.map_or(f64::INFINITY, |h| h.distance));
        }
    }
    nearest
}

#[test]
fn reachability_agrees_with_a_brute_force_by_mj_ray_and_finds_the_sealed_room() {
    let world = load(&fixture("sealed_room.xml"));
    let (report, plan) = check_world(&world).expect("check");
    let needed = plan.clearance_needed;
    // The brute force: a 0.1 m grid, free by rays, flooded 8-connected from the spawn.
    let (x0, y0, step) = (-4.05, -2.05, 0.1);
    let (nx, ny) = (82usize, 42usize);
    let clearance: Vec<f64> = (0..nx * ny)
        .map(|c| {
            ray_clearance(
                &world,
                x0 + (c % nx) as f64 * step,
                y0 + (c / nx) as f64 * step,
            )
        })
        .collect();
    let free = |c: usize| clearance[c] >= needed && clearance[c].is_finite();
    let start = (((0.0 - y0) / step).round() as usize) * nx + ((-2.5 - x0) / step).round() as usize;
    let mut reached = vec![false; nx * ny];
    let mut queue = VecDeque::from([start]);
    reached[start] = free(start);
    assert!(reached[start], "the spawn is free by rays");
    while let Some(c) = queue.pop_front() {
        let (i, j) = ((c % nx) as isize, (c / nx) as isize);
        for (di, dj) in [
            (-1, -1),
            (0, -1),
            (1, -1),
            (-1, 0),
            (1, 0),
            (-1, 1),
            (0, 1),
            (1, 1),
        ] {
            let (a, b) = (i + di, j + dj);
            if a < 0 || b < 0 || a >= nx as isize || b >= ny as isize {
                continue;
            }
            let n = b as usize * nx + a as usize;
            if !reached[n] && free(n) {
                reached[n] = true;
                queue.push_back(n);
            }
        }
    }
    let reachable = plan.reachable_from(-2.5, 0.0);
    let (mut compared, mut disagree) = (0, 0);
    for c in 0..nx * ny {
        // Cells within 5 cm of the threshold are a matter of rounding either way.
        if (clearance[c] - needed).abs() < 0.05 {
            continue;
        }
        let (x, y) = (x0 + (c % nx) as f64 * step, y0 + (c / nx) as f64 * step);
        let ours = plan.cell_of(x, y).is_some_and(|k| reachable[k]);
        compared += 1;
        if ours != reached[c] {
            disagree += 1;
        }
    }
    eprintln!("{disagree} of {compared} cells disagree");
    assert!(compared > 2500, "{compared} cells compared");
    assert!(
        disagree * 200 <= compared,
        "{disagree} of {compared} cells disagree"
    );
    // Both find the east room free but unreachable, and the check reports it.
    let east = (((0.0 - y0) / step).round() as usize) * nx + ((3.0 - x0) / step).round() as usize;
    assert!(free(east) && !reached[east]);
    assert!(
        report
            .problems
            .iter()
            .any(|p| p.contains("cannot be reached") && p.contains("(3.0")),
        "{:?}",
        report.problems
    );
    assert!(report.reachable_share < 0.8, "{}", report.reachable_share);
}

#[test]
fn random_spawns_are_seeded_collision_free_and_spread_out() {
    let path = repo_path("worlds/suite/office_01.xml");
    let mut poses: Vec<Pose2> = Vec::new();
    for seed in 0..8 {
        let mut world = load(&path);
        let pose = place_robot(&mut world, Spawn::Random, seed).expect("a random spawn");
        assert_eq!(world.robot_collisions().count(), 0, "seed {seed}");
        let plan = FloorPlan::of(&world).expect("plan");
        let cell = plan.cell_of(pose.x, pose.y).expect("on the plan");
        assert!(
            plan.clearance(cell) >= 0.55,
            "seed {seed}: {:.2} m of room",
            plan.clearance(cell)
        );
        let mut again = load(&path);
        assert_eq!(
            place_robot(&mut again, Spawn::Random, seed).expect("again"),
            pose
        );
        poses.push(pose);
    }
    let spread = poses
        .iter()
        .flat_map(|a| poses.iter().map(move |b| (a.x - b.x).hypot(a.y - b.y)))
        .fold(0.0, f64::max);
    assert!(
        spread > 4.0,
        "random spawns within {spread:.2} m of each other"
    );
}

#[test]
fn a_spawn_inside_an_obstacle_is_refused_with_its_name() {
    let mut world = load(&repo_path("worlds/room.xml"));
    let error = place_robot(
        &mut world,
        Spawn::Pose(Pose2 {
            x: -0.3,
            y: 0.0,
            theta: 0.0,
        }),
        1,
    )
    .expect_err("the pillar is there");
    assert!(error.to_string().contains("pillar"), "{error}");
    // The check says the same of a world whose site is inside an obstacle.
    world.set_start(Pose2 {
        x: -0.3,
        y: 0.0,
        theta: 0.0,
    });
    let (report, _) = check_world(&world).expect("check");
    assert!(
        report.problems.iter().any(|p| p.contains("pillar")),
        "{:?}",
        report.problems
    );
}

#[test]
fn generate_refuses_bad_areas_kinds_and_existing_files() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("w.xml");
    let config = GenerateConfig {
        kind: WorldKind::Office,
        seed: 1,
        area: Some(30.0),
        out: out.clone(),
        overwrite: false,
    };
    let error = generate(&config, &mut |_, _| {}).expect_err("too small");
    assert!(error.to_string().contains("between 80 and 200"), "{error}");
    assert!(!out.exists(), "nothing written");
    assert!("castle".parse::<WorldKind>().is_err());
    std::fs::write(&out, "mine").expect("write");
    let config = GenerateConfig {
        area: None,
        ..config
    };
    let error = generate(&config, &mut |_, _| {}).expect_err("exists");
    assert!(error.to_string().contains("--overwrite"), "{error}");
    assert_eq!(std::fs::read_to_string(&out).expect("read"), "mine");
    let leftovers: Vec<_> = std::fs::read_dir(dir.path()).expect("dir").collect();
    assert_eq!(leftovers.len(), 1, "no candidate files left behind");
}

#[test]
fn trajectory_png_shows_the_whole_world_with_its_title() {
    let dir = tempfile::tempdir().expect("tempdir");
    let world = load(&repo_path("worlds/suite/warehouse_02.xml"));
    let (report, _) = check_world(&world).expect("check");
    let png = dir.path().join("trajectory.png");
    let map = autonomy::map::GaussianMap::new(Default::default(), Vec::new());
    let path = [world.start()];
    let (lo, hi) =
        splatloop::plot::write_trajectory_png(&png, &world, &path, &map, "a title").expect("plot");
    let (wlo, whi) = report.bounds;
    assert!(whi[0] - wlo[0] > 15.0, "a world larger than the room");
    assert!(
        lo[0] <= wlo[0] && lo[1] <= wlo[1] && hi[0] >= whi[0] && hi[1] >= whi[1],
        "{lo:?}..{hi:?} does not cover {wlo:?}..{whi:?}"
    );
    // The outer walls are drawn at the world's four corners (dark pixels there).
    let (width, height, rgb) = splatloop::dataset::read_rgb_png(&png).expect("png");
    let scale = 1200.0 / (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let map_height = ((hi[1] - lo[1]) * scale).ceil() as usize;
    assert!(
        height as usize > map_height,
        "room for the title and legend"
    );
    for (x, y) in [
        (wlo[0] + 0.03, wlo[1] + 0.03),
        (whi[0] - 0.03, wlo[1] + 0.03),
        (wlo[0] + 0.03, whi[1] - 0.03),
        (whi[0] - 0.03, whi[1] - 0.03),
    ] {
        let px = ((x - lo[0]) * scale) as usize;
        let py = 24 + map_height - 1 - ((y - lo[1]) * scale) as usize;
        let i = 3 * (py * width as usize + px);
        assert!(
            rgb[i] < 120,
            "no wall drawn at ({x:.2}, {y:.2}): {:?}",
            &rgb[i..i + 3]
        );
    }
}
