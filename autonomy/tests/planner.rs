//! The RT-GuIDE planner: collision engines against brute force, A* around a wall and in the
//! open, information counts, Dijkstra and Omega / e^d, and failures as values.

use autonomy::gaussians::Gaussians;
use autonomy::map::{GaussianMap, UncertaintyClass};
use autonomy::planner::collision::{brute_force, CollisionGrid, CollisionModel, Obstacles};
use autonomy::planner::graph::{local_goal, NodeKind, TopologicalGraph};
use autonomy::planner::information::{CameraMount, ViewCounter};
use autonomy::planner::search::{search, segment_points, SearchConfig};
use autonomy::planner::unicycle::{advance, Pose2, UnicycleCommand};
use autonomy::planner::{CollisionEngine, PlanFailure, PlannerConfig, Recovery, RtGuidePlanner};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn random_obstacles(seed: u64, n: usize) -> Obstacles {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut o = Obstacles::default();
    for k in 0..n {
        o.means.push([
            rng.gen_range(-5.0..5.0),
            rng.gen_range(-5.0..5.0),
            rng.gen_range(0.0..2.0),
        ]);
        // A few are wider than the grid's cap and go to its oversize list.
        o.radii.push(if k % 50 == 0 {
            rng.gen_range(0.1..0.4)
        } else {
            rng.gen_range(0.002..0.05)
        });
    }
    o
}

/// Random points, and points just inside and just outside some obstacle's reach.
fn query_points(seed: u64, o: &Obstacles, model: &CollisionModel) -> Vec<[f32; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut points: Vec<[f32; 3]> = (0..300)
        .map(|_| {
            [
                rng.gen_range(-5.5..5.5),
                rng.gen_range(-5.5..5.5),
                rng.gen_range(-0.3..2.3),
            ]
        })
        .collect();
    for k in 0..200 {
        let j = rng.gen_range(0..o.len());
        let reach = model.robot_radius + model.gaussian_scale * o.radii[j];
        let d: [f32; 3] = [
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        ];
        let norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-3);
        let r = reach * if k % 2 == 0 { 0.999 } else { 1.001 };
        points.push([0, 1, 2].map(|a| o.means[j][a] + d[a] / norm * r));
    }
    points
}

#[test]
fn grid_answers_equal_brute_force_and_follow_map_changes_incrementally() {
    let model = CollisionModel::default();
    let mut obstacles = random_obstacles(1, 3000);
    let mut grid = CollisionGrid::new(model, 0.05);
    let first = grid.sync(&obstacles);
    assert_eq!(first.inserted, 3000);
    let points = query_points(2, &obstacles, &model);
    let expected = brute_force(&model, &obstacles, &points);
    assert!(expected.iter().any(|h| *h) && expected.iter().any(|h| !*h));
    assert_eq!(grid.check(&points), expected);
    // The map changes a little: some Gaussians move, some are added, the last few pruned.
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for i in (0..obstacles.len()).step_by(37) {
        obstacles.means[i][0] += rng.gen_range(-0.6..0.6);
    }
    let extra = random_obstacles(4, 200);
    obstacles.means.truncate(2950);
    obstacles.radii.truncate(2950);
    obstacles.means.extend(extra.means);
    obstacles.radii.extend(extra.radii);
    let update = grid.sync(&obstacles);
    assert!(
        update.moved + update.inserted + update.removed < 400,
        "{update:?}"
    );
    let points = query_points(5, &obstacles, &model);
    assert_eq!(
        grid.check(&points),
        brute_force(&model, &obstacles, &points)
    );
}

#[test]
fn gpu_collision_answers_equal_brute_force() {
    use autonomy::planner::gpu_collision::GpuCollision;
    use autonomy::splat::gpu::{AdapterPolicy, GpuError};
    let mut gpu = match GpuCollision::new(AdapterPolicy::AllowSoftware) {
        Ok(g) => g,
        Err(GpuError::NoAdapter(reason)) => {
            eprintln!("SKIPPED: no wgpu adapter at all: {reason}");
            return;
        }
        Err(e) => panic!("an adapter exists but the engine failed: {e}"),
    };
    let model = CollisionModel::default();
    let obstacles = random_obstacles(6, 2000);
    gpu.upload(&obstacles).expect("upload");
    let points = query_points(7, &obstacles, &model);
    let got = gpu.check(&model, &obstacles, &points).expect("gpu check");
    assert_eq!(got, brute_force(&model, &obstacles, &points));
}

#[test]
fn a_planner_on_the_wgpu_engine_plans_as_one_on_the_grid() {
    use autonomy::planner::gpu_collision::GpuCollision;
    use autonomy::splat::gpu::{AdapterPolicy, GpuError};
    let gpu = match GpuCollision::new(AdapterPolicy::AllowSoftware) {
        Ok(g) => g,
        Err(GpuError::NoAdapter(reason)) => {
            eprintln!("SKIPPED: no wgpu adapter at all: {reason}");
            return;
        }
        Err(e) => panic!("an adapter exists but the engine failed: {e}"),
    };
    let mut on_gpu = RtGuidePlanner::new(
        PlannerConfig::default(),
        CollisionEngine::Gpu(Box::new(gpu)),
    );
    let mut on_grid = RtGuidePlanner::new(PlannerConfig::default(), CollisionEngine::Grid);
    let mut map = map_of(&wall());
    for step in 0..2 {
        let robot = Pose2 {
            x: 0.2 * step as f64,
            y: -0.3,
            theta: 0.2,
        };
        let (a, b) = (on_gpu.plan(&map, robot), on_grid.plan(&map, robot));
        let (a, b) = (a.expect("gpu plan"), b.expect("grid plan"));
        assert_eq!(
            (&a.controls, &a.states, a.information, &a.guidance),
            (&b.controls, &b.states, b.information, &b.guidance),
            "step {step}"
        );
        // The wall's lower half slides toward the robot between plans.
        for m in map.gaussians.means.iter_mut().filter(|m| m[2] < 0.5) {
            m[0] -= 0.4;
        }
    }
}

/// A 3 m wide, 1 m tall wall of 2 cm Gaussians across x = 2.
fn wall() -> Obstacles {
    let mut o = Obstacles::default();
    let mut y = -1.5;
    while y <= 1.5 {
        let mut z = 0.06;
        while z <= 1.0 {
            o.means.push([2.0, y, z]);
            o.radii.push(0.02);
            z += 0.04;
        }
        y += 0.04;
    }
    o
}

#[test]
fn the_search_goes_around_a_wall_and_ends_nearer_the_goal() {
    let model = CollisionModel::default();
    let obstacles = wall();
    let mut grid = CollisionGrid::new(model, 0.05);
    grid.sync(&obstacles);
    let config = SearchConfig::default();
    let start = Pose2 {
        x: 0.0,
        y: 0.0,
        theta: 0.0,
    };
    let goal = [4.0, 0.0];
    let mut free = |segments: &[Vec<Pose2>]| -> Vec<bool> {
        segments
            .iter()
            .map(|seg| {
                !seg.iter()
                    .any(|s| grid.point_collides([s.x as f32, s.y as f32, model.centre_height]))
            })
            .collect()
    };
    let found = search(&config, start, goal, &mut free);
    assert!(!found.is_empty());
    let best = &found[0];
    let end = best.states.last().expect("states");
    let before = 4.0;
    let after = ((goal[0] - end.x).powi(2) + (goal[1] - end.y).powi(2)).sqrt();
    assert!(after < before - 0.5, "ended {after:.2} m from the goal");
    // Re-sample the executed trajectory densely: every point keeps r_robot from every
    // Gaussian's surface.
    for (s, u) in best.states.iter().zip(&best.controls) {
        for p in segment_points(s, u, 1.0, 0.005) {
            for (m, r) in obstacles.means.iter().zip(&obstacles.radii) {
                let d = ((p.x as f32 - m[0]).powi(2)
                    + (p.y as f32 - m[1]).powi(2)
                    + (model.centre_height - m[2]).powi(2))
                .sqrt();
                assert!(
                    d - r >= model.robot_radius,
                    "{d} from a Gaussian of radius {r}"
                );
            }
        }
    }
}

#[test]
fn in_an_empty_map_the_search_reaches_the_goal_the_same_way_every_time() {
    let config = SearchConfig::default();
    let start = Pose2 {
        x: 1.0,
        y: -1.0,
        theta: 0.5,
    };
    let goal = [3.5, 1.5];
    let mut free = |segments: &[Vec<Pose2>]| vec![true; segments.len()];
    let a = search(&config, start, goal, &mut free);
    let b = search(&config, start, goal, &mut free);
    assert_eq!(a, b);
    assert!(a[0].distance_to_goal <= config.goal_tolerance, "{:?}", a[0]);
    // The states are the exact unicycle arcs of the controls.
    let mut s = start;
    for (u, next) in a[0].controls.iter().zip(&a[0].states[1..]) {
        s = advance(&s, u, 1.0);
        assert!((s.x - next.x).abs() < 1e-12 && (s.y - next.y).abs() < 1e-12);
    }
}

#[test]
fn unicycle_arcs_match_numerical_integration() {
    let s = Pose2 {
        x: 0.3,
        y: -0.2,
        theta: 1.1,
    };
    for u in [
        UnicycleCommand { v: 0.6, w: 0.9 },
        UnicycleCommand { v: 0.3, w: -0.45 },
        UnicycleCommand { v: 0.6, w: 0.0 },
    ] {
        let exact = advance(&s, &u, 1.0);
        let mut n = s;
        let dt = 1e-5;
        for _ in 0..100_000 {
            n.x += u.v * n.theta.cos() * dt;
            n.y += u.v * n.theta.sin() * dt;
            n.theta += u.w * dt;
        }
        assert!(
            (exact.x - n.x).abs() < 1e-4 && (exact.y - n.y).abs() < 1e-4,
            "{u:?}"
        );
    }
}

#[test]
fn information_counts_equal_brute_force_and_prefer_high_uncertainty() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let means: Vec<[f32; 3]> = (0..5000)
        .map(|_| {
            [
                rng.gen_range(-6.0..6.0),
                rng.gen_range(-6.0..6.0),
                rng.gen_range(0.0..2.5),
            ]
        })
        .collect();
    let classes: Vec<UncertaintyClass> = (0..5000)
        .map(|i| match i % 3 {
            0 => UncertaintyClass::High,
            1 => UncertaintyClass::Low,
            _ => UncertaintyClass::Other,
        })
        .collect();
    let counter = ViewCounter::from_classes(&means, &classes, CameraMount::default(), 0.5);
    for k in 0..50 {
        let s = Pose2 {
            x: rng.gen_range(-6.0..6.0),
            y: rng.gen_range(-6.0..6.0),
            theta: rng.gen_range(-3.2..3.2),
        };
        assert_eq!(
            counter.count(&s),
            counter.count_brute_force(&s),
            "state {k}"
        );
    }
    // Two viewpoints: one faces a cluster of high-uncertainty Gaussians, the other a cluster
    // of low ones.
    let mut means = Vec::new();
    let mut classes = Vec::new();
    for i in 0..200 {
        let t = i as f32 * 0.01;
        means.push([3.0, -0.5 + t * 0.5, 0.2 + 0.5 * t]);
        classes.push(UncertaintyClass::High);
        means.push([-3.0, -0.5 + t * 0.5, 0.2 + 0.5 * t]);
        classes.push(UncertaintyClass::Low);
    }
    let counter = ViewCounter::from_classes(&means, &classes, CameraMount::default(), 0.5);
    let east = Pose2 {
        x: 0.0,
        y: 0.0,
        theta: 0.0,
    };
    let west = Pose2 {
        x: 0.0,
        y: 0.0,
        theta: std::f64::consts::PI,
    };
    assert_eq!(counter.count(&east), (200, 0));
    assert!(counter.information(&east) > counter.information(&west));
}

#[test]
fn dijkstra_and_the_omega_over_e_to_the_d_choice_on_a_hand_built_graph() {
    let mut g = TopologicalGraph::default();
    let a = g.visit([0.0, 0.0], 1.0);
    let b = g.visit([2.0, 0.0], 1.0);
    let c = g.visit([2.0, 2.0], 1.0);
    assert_eq!(
        g.visit([0.3, 0.0], 1.0),
        a,
        "a node within the spacing is reused"
    );
    // Near but poor, far but rich: 1 / e^1 = 0.37 vs 5 / e^(2 + 2 + 1) = 0.034.
    let near = g.add_viewpoint([0.0, 1.0], 1.0, 0.0);
    let far = g.add_viewpoint([2.0, 3.0], 5.0, 0.0);
    let paths = g.dijkstra(a);
    assert!((paths.distance[c] - 4.0).abs() < 1e-12);
    assert!((paths.distance[far] - 5.0).abs() < 1e-12);
    assert_eq!(paths.path_to(far), vec![a, b, c, far]);
    let (best, path, score) = g.best_viewpoint(a, 0.0).expect("reachable");
    assert_eq!(best, near);
    assert_eq!(path, vec![a, near]);
    assert!((score - (-1.0f64).exp()).abs() < 1e-12);
    // Viewpoints nearer than the minimum count as reached.
    let (best, _, _) = g.best_viewpoint(a, 2.0).expect("reachable");
    assert_eq!(best, far);
    // From c the rich one is near: 5 / e = 1.84 beats 1 / e^5.
    let (best, _, _) = g.best_viewpoint(c, 0.0).expect("reachable");
    assert_eq!(best, far);
    g.clear_viewpoints();
    assert!(g.nodes.iter().all(|n| n.kind == NodeKind::Odometry));
    assert!(g.best_viewpoint(a, 0.0).is_none());
    // The last target is kept while it scores at least half the best, not below.
    let best_now = g.add_viewpoint([0.0, 1.0], 1.0, 0.0); // 1 / e = 0.37
    let close = g.add_viewpoint([0.0, -1.0], 0.8, 0.0); // 0.8 / e = 0.29
    let poor = g.add_viewpoint([-1.0, 0.0], 0.4, 0.0); // 0.4 / e = 0.15
    let pick = |previous| {
        g.best_viewpoint_keeping(a, 0.0, previous, 0.5)
            .expect("reachable")
            .0
    };
    assert_eq!(pick(None), best_now);
    assert_eq!(pick(Some([0.1, -1.0])), close);
    assert_eq!(
        pick(Some([-1.0, 0.1])),
        best_now,
        "{poor} scores under half the best"
    );
    // The local goal: the furthest point of the path within range.
    let goal = local_goal(&[[0.0, 0.0], [3.0, 0.0], [3.0, 10.0]], 5.0).expect("goal");
    assert!(
        (goal[0] - 3.0).abs() < 1e-9 && (goal[1] - 4.0).abs() < 1e-6,
        "{goal:?}"
    );
}

fn map_of(obstacles: &Obstacles) -> GaussianMap {
    let mut g = Gaussians::default();
    for (m, r) in obstacles.means.iter().zip(&obstacles.radii) {
        g.push(*m, *r, 0.9, [0.5; 3]);
    }
    let uncertainty = (0..g.len()).map(|i| (i % 7) as f32 * 1e-4).collect();
    GaussianMap::new(g, uncertainty)
}

#[test]
fn failures_come_back_as_values_with_a_recovery() {
    let mut planner = RtGuidePlanner::new(PlannerConfig::default(), CollisionEngine::Grid);
    let origin = Pose2 {
        x: 0.0,
        y: 0.0,
        theta: 0.0,
    };
    assert_eq!(
        planner.plan(&GaussianMap::default(), origin),
        Err(PlanFailure::EmptyMap)
    );
    // Start in collision: a Gaussian right at the robot.
    let mut obstacles = wall();
    obstacles.means.push([0.1, 0.0, 0.25]);
    obstacles.radii.push(0.02);
    let failure = planner
        .plan(&map_of(&obstacles), origin)
        .expect_err("in collision");
    // The Gaussian sits right at the robot and the wall is 2 m ahead (+x): away is -x.
    match failure {
        PlanFailure::StartInCollision { away } => {
            assert!(
                (away.abs() - std::f64::consts::PI).abs() < 0.3,
                "away {away}"
            )
        }
        other => panic!("expected StartInCollision, got {other:?}"),
    }
    // The back-off carries that heading.
    assert!(matches!(
        failure.recovery(),
        Recovery::BackOff { away } if (away.abs() - std::f64::consts::PI).abs() < 0.3
    ));
    // Boxed in: a ring of Gaussians 0.45 m away; every primitive that moves collides and
    // turning in place never gets anywhere.
    let mut ring = Obstacles::default();
    for k in 0..120 {
        let a = std::f32::consts::TAU * k as f32 / 120.0;
        ring.means.push([0.45 * a.cos(), 0.45 * a.sin(), 0.25]);
        ring.radii.push(0.01);
    }
    let mut planner = RtGuidePlanner::new(PlannerConfig::default(), CollisionEngine::Grid);
    match planner.plan(&map_of(&ring), origin) {
        Err(f) => assert_eq!(f.recovery(), Recovery::TurnInPlace, "{f}"),
        Ok(plan) => assert!(
            plan.controls.iter().all(|u| u.v == 0.0),
            "a boxed-in robot was sent {:?}",
            plan.controls
        ),
    }
    // In the open with the wall ahead, a plan comes back and its information is the sum of
    // its states' counts.
    let mut planner = RtGuidePlanner::new(PlannerConfig::default(), CollisionEngine::Grid);
    let plan = planner.plan(&map_of(&wall()), origin).expect("plan");
    assert!(!plan.controls.is_empty());
    assert_eq!(plan.states.len(), plan.controls.len() + 1);
    // Plans from new places grow the graph; earlier viewpoints must not confuse the indices.
    for x in [1.2, -1.3, -0.2] {
        let moved = Pose2 {
            x,
            y: -1.0,
            theta: 0.0,
        };
        planner
            .plan(&map_of(&wall()), moved)
            .expect("plan from a new place");
    }
    let odometry = planner
        .graph()
        .nodes
        .iter()
        .filter(|n| n.kind == NodeKind::Odometry)
        .count();
    assert_eq!(odometry, 4);
}

#[test]
fn viewpoints_behind_a_wall_are_not_targets() {
    // A closed 10 x 10 m room of settled Gaussians, and far outside it a cluster of very
    // uncertain ones: its viewpoints all lie outside the walls, where the robot cannot go.
    let mut g = Gaussians::default();
    let mut uncertainty = Vec::new();
    for k in 0..100 {
        let s = -5.0 + 0.1 * k as f32;
        for z in [0.1f32, 0.25, 0.4, 0.55, 0.7, 0.85, 1.0] {
            for p in [[s, -5.0, z], [s, 5.0, z], [-5.0, s, z], [5.0, s, z]] {
                g.push(p, 0.02, 0.9, [0.5; 3]);
                uncertainty.push(1e-4 * (k % 3) as f32);
            }
        }
    }
    for k in 0..400 {
        let p = [12.0 + 0.01 * (k % 20) as f32, 0.01 * (k / 20) as f32, 0.5];
        g.push(p, 0.02, 0.9, [0.5; 3]);
        uncertainty.push(1.0);
    }
    let map = GaussianMap::new(g, uncertainty);
    let origin = Pose2 {
        x: 0.0,
        y: 0.0,
        theta: 0.0,
    };
    let mut planner = RtGuidePlanner::new(PlannerConfig::default(), CollisionEngine::Grid);
    let plan = planner
        .plan(&map, origin)
        .expect("a target inside the room");
    let target = plan.guidance.last().copied().expect("guidance");
    assert!(
        target[0].abs() < 5.0 && target[1].abs() < 5.0,
        "the target {target:?} is outside the walls"
    );
    // Without the wall the cluster's viewpoints win: the check above is what kept them out.
    let mut cluster = Gaussians::default();
    for i in 0..map.len() {
        if map.uncertainty[i] == 1.0 {
            cluster.push(map.gaussians.means[i], 0.02, 0.9, [0.5; 3]);
        }
    }
    let open = GaussianMap::new(cluster, vec![1.0; 400]);
    let mut planner = RtGuidePlanner::new(PlannerConfig::default(), CollisionEngine::Grid);
    let plan = planner.plan(&open, origin).expect("plan in the open");
    let target = plan.guidance.last().copied().expect("guidance");
    assert!(target[0] > 5.0, "{target:?}");
}

/// The planner's copy of the map, and the collision grid, tallies and counting grid that
/// follow its changes, against answers computed afresh from the map after every edit: moves,
/// uncertainty updates, growth, Gaussians sinking into the ground plane, and prunes that
/// renumber the map.
#[test]
fn incremental_upkeep_equals_a_fresh_pass_after_moves_growth_and_prunes() {
    use autonomy::map::ClassifyOptions;
    use autonomy::planner::graph::regions;
    use autonomy::planner::mirror::MapMirror;
    use autonomy::planner::tally::Tally;
    let options = ClassifyOptions::default();
    let model = CollisionModel::default();
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let mut random_gaussians = |g: &mut Gaussians, u: &mut Vec<f32>, n: usize| {
        for _ in 0..n {
            let p = [
                rng.gen_range(-6.0..6.0),
                rng.gen_range(-6.0..6.0),
                rng.gen_range(-0.1..2.5),
            ];
            let r = if rng.gen_bool(0.02) { 0.2 } else { 0.02 };
            g.push(p, r, 0.9, [0.5; 3]);
            u.push(rng.gen_range(0.0..1e-3));
        }
    };
    let (mut g, mut u) = (Gaussians::default(), Vec::new());
    random_gaussians(&mut g, &mut u, 4000);
    let mut map = GaussianMap::new(g, u);
    let mut mirror = MapMirror::new();
    let mut changes = Vec::new();
    let mut grid = CollisionGrid::new(model, 0.05);
    let mut tally = Tally::new(2.5);
    let mut counter = ViewCounter::new(CameraMount::default(), 1.0);
    let mut edit_rng = ChaCha8Rng::seed_from_u64(22);
    for round in 0..6usize {
        mirror.sync(&map, &options, &mut changes);
        grid.apply(&changes);
        tally.apply(&changes);
        counter.apply(&changes);
        let stats = tally.stats();
        counter.set_stats(&stats);

        // Statistics and regions against one pass over the map.
        let fresh = map.stats(&options);
        assert_eq!(stats.count, fresh.count, "round {round}");
        assert!(
            (stats.mean - fresh.mean).abs() <= 1e-6 * fresh.mean,
            "round {round}"
        );
        assert!(
            (stats.std - fresh.std).abs() <= 1e-5 * fresh.std,
            "round {round}"
        );
        let (running, reference) = (tally.regions(), regions(&map, &options, 2.5));
        assert_eq!(running.len(), reference.len(), "round {round}");
        for (a, b) in running.iter().zip(&reference) {
            assert_eq!((a.centre, a.count), (b.centre, b.count), "round {round}");
            assert!((a.omega - b.omega).abs() <= 1e-9, "round {round}");
            for k in 0..3 {
                assert!(
                    (a.centroid[k] - b.centroid[k]).abs() <= 1e-5,
                    "round {round}"
                );
            }
        }
        // Collisions against brute force over the map's obstacles now.
        let obstacles = Obstacles::from_gaussians(&map.gaussians, &options);
        assert_eq!(grid.len(), obstacles.len(), "round {round}");
        let points = query_points(30 + round as u64, &obstacles, &model);
        assert_eq!(
            grid.check(&points),
            brute_force(&model, &obstacles, &points),
            "round {round}"
        );
        // Counts against a counter built afresh from the map's classes.
        let classes: Vec<UncertaintyClass> = (0..map.len())
            .map(|i| {
                if options.includes(&map.gaussians.means[i]) {
                    stats.class_of(map.uncertainty[i])
                } else {
                    UncertaintyClass::Excluded
                }
            })
            .collect();
        let fresh_counter =
            ViewCounter::from_classes(&map.gaussians.means, &classes, CameraMount::default(), 1.0);
        for k in 0..40 {
            let s = Pose2 {
                x: edit_rng.gen_range(-6.0..6.0),
                y: edit_rng.gen_range(-6.0..6.0),
                theta: edit_rng.gen_range(-3.2..3.2),
            };
            let count = counter.count(&s);
            assert_eq!(count, fresh_counter.count(&s), "round {round} state {k}");
            assert_eq!(
                count,
                counter.count_brute_force(&s),
                "round {round} state {k}"
            );
        }

        // Edit the map as a mapping step would, and then some.
        let n = map.len();
        for i in (round..n).step_by(9) {
            map.gaussians.means[i][0] += edit_rng.gen_range(-0.3..0.3);
        }
        for i in (round..n).step_by(5) {
            map.uncertainty[i] = edit_rng.gen_range(0.0..2e-3);
        }
        for i in (round..n).step_by(97) {
            map.gaussians.means[i][2] = if map.gaussians.means[i][2] < 0.05 {
                1.0
            } else {
                0.0
            };
        }
        let (mut g, mut u) = (std::mem::take(&mut map.gaussians), Vec::new());
        random_gaussians(&mut g, &mut u, 300);
        map.gaussians = g;
        map.adopt_new_gaussians();
        let grown = map.len();
        map.uncertainty[n..grown].copy_from_slice(&u);
        if round % 2 == 1 {
            // A prune: every 7th Gaussian goes, renumbering the rest. Only they are reported.
            let keep: Vec<bool> = (0..map.len()).map(|i| i % 7 != round).collect();
            let gone = (0..map.len())
                .filter(|i| !keep[*i] && options.includes(&map.gaussians.means[*i]))
                .count();
            mirror.sync(&map, &options, &mut changes);
            grid.apply(&changes);
            tally.apply(&changes);
            counter.apply(&changes);
            map.retain(&keep);
            mirror.sync(&map, &options, &mut changes);
            assert_eq!(
                changes.len(),
                gone,
                "round {round}: a prune reported more than it removed"
            );
            grid.apply(&changes);
            tally.apply(&changes);
            counter.apply(&changes);
        }
    }
}
