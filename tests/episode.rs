//! The closed loop: the smoke episode on worlds/room.xml (no collisions, coverage and PSNR
//! above measured floors, the same trajectory twice), the survey's map against the same map
//! with half its Gaussians gone, the test poses against MuJoCo's contacts, and a boxed-in
//! robot that must end its episode with a recovery and a reason.

use crate::support::{fixture, repo_path, run_config as config};
use autonomy::splat::{EngineChoice, Rasteriser};
use splatloop::camera::SensorConfig;
use splatloop::dataset::Dataset;
use splatloop::episode::{run_episode, PlannerKind};
use splatloop::evaluate::{evaluate, TestSet};
use splatloop::novel_view::{evaluate_map_surface, render_map, RenderConfig};

#[test]
fn smoke_episode_explores_without_collisions_and_repeats_exactly() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = |name: &str| {
        let config = config(
            "worlds/room.xml",
            PlannerKind::RtGuide,
            60.0,
            dir.path().join(name),
        );
        run_episode(&config, &mut |_| {}).expect("episode")
    };
    let (first, second) = (run("a"), run("b"));
    eprintln!("{first:?}");
    assert_eq!(first.collision_steps, 0);
    assert_eq!(first.ended, "budget");
    assert_eq!(first.frames, 300);
    // Measured on the CI machine (2026-12-02, 60 s, seed 3, the default frontier regions;
    // the same with frontiers first, the default since; the tour, the default since, leaves
    // the path as it was: groundtruth.txt identical with and without it, 2026-12-03):
    // 14.7 m driven, 112073 Gaussians, PSNR 21.4 dB, coverage 91.0% on 20 hidden views (the
    // paper's planner, 2026-11-25: 14.4 m, 20.7 dB, 90.5%). The floors leave room for other
    // machines' float rounding, which changes the trajectory.
    assert!(
        first.path_length > 6.0,
        "drove only {:.2} m",
        first.path_length
    );
    assert!(first.gaussians > 60_000, "{} Gaussians", first.gaussians);
    assert_eq!(first.evaluation.views, 20);
    assert!(
        first.evaluation.psnr > 17.0,
        "PSNR {:.2} dB",
        first.evaluation.psnr
    );
    assert!(
        first.evaluation.coverage > 0.75,
        "coverage {:.3}",
        first.evaluation.coverage
    );
    let read = |d: &str| {
        std::fs::read_to_string(dir.path().join(d).join("groundtruth.txt")).expect("trajectory")
    };
    assert_eq!(
        read("a"),
        read("b"),
        "the same inputs gave different trajectories"
    );
    assert_eq!(first.path_length, second.path_length);
    // camera_path_length is the length of groundtruth.txt's positions.
    let poses = splatloop::dataset::read_trajectory(&dir.path().join("a").join("groundtruth.txt"))
        .expect("poses");
    let from_file: f64 = poses
        .windows(2)
        .map(|w| (w[1].1.translation.vector - w[0].1.translation.vector).norm())
        .sum();
    assert!(
        (first.camera_path_length - from_file).abs() < 1e-6,
        "{} vs {from_file}",
        first.camera_path_length
    );
    assert!(first.camera_path_length > 0.0);
    // transforms.json names the coloured point cloud written beside it: the map's means.
    let transforms: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("a").join("transforms.json")).expect("transforms"),
    )
    .expect("json");
    assert_eq!(transforms["ply_file_path"], "points.ply");
    let cloud = std::fs::read(dir.path().join("a").join("points.ply")).expect("points.ply");
    let header = String::from_utf8_lossy(&cloud[..300]).into_owned();
    assert!(
        header.contains(&format!("element vertex {}\n", first.gaussians)),
        "{header}"
    );
    assert!(header.contains("property uchar red"), "{header}");
    let body = cloud.len() - (header.find("end_header\n").expect("header") + "end_header\n".len());
    assert_eq!(body, 15 * first.gaussians);
    // Everything the episode folder promises is there; the map reads back.
    for file in [
        "metrics.json",
        "episode.json",
        "trajectory.png",
        "camera.json",
        "rgb.txt",
    ] {
        assert!(
            dir.path().join("a").join(file).is_file(),
            "{file} is missing"
        );
    }
    let map = autonomy::ply::read(&dir.path().join("a").join("map.ply")).expect("map.ply");
    assert_eq!(map.len(), first.gaussians);

    // `splatloop eval` on the saved map rebuilds the episode's test set and its scores (the PLY
    // stores colours through f_dc in float32, so not bit for bit).
    let (again, surface) = evaluate_map_surface(
        &dir.path().join("a").join("map.ply"),
        &repo_path("worlds/room.xml"),
        &SensorConfig::default(),
        20,
        3,
        EngineChoice::Cpu,
    )
    .expect("eval");
    assert_eq!(again.surface_points, first.evaluation.surface_points);
    // Point by point (`eval --surface-out`): the covered share is the coverage, and each
    // point's flag is a brute-force search of the map's means.
    assert_eq!(surface.len(), again.surface_points);
    let share = surface.iter().filter(|p| p.covered).count() as f64 / surface.len() as f64;
    assert!(
        (share - again.coverage).abs() < 1e-12,
        "{share} vs {again:?}"
    );
    assert!(
        share > 0.05 && share < 0.999,
        "{share}: both kinds of point"
    );
    for p in surface.iter().step_by(37) {
        let near =
            map.gaussians.means.iter().any(|m| {
                (0..3).map(|k| (m[k] - p.position[k]).powi(2)).sum::<f32>() <= 0.05f32 * 0.05
            });
        assert_eq!(p.covered, near, "{p:?}");
    }
    assert!(
        (again.psnr - first.evaluation.psnr).abs() < 1e-3,
        "{again:?}"
    );
    assert!(
        (again.coverage - first.evaluation.coverage).abs() < 1e-9,
        "{again:?}"
    );

    // `splatloop render` at every 20th pose of the episode: a dataset that reads back, with
    // the poses given, and images that are the map's render at those poses.
    let pose_lines = |text: String| -> Vec<String> {
        text.lines()
            .filter(|l| !l.starts_with('#'))
            .map(str::to_owned)
            .collect()
    };
    let some: Vec<String> = pose_lines(read("a")).into_iter().step_by(20).collect();
    let poses = dir.path().join("poses.txt");
    std::fs::write(&poses, some.join("\n")).expect("poses");
    let rendered = RenderConfig {
        map: dir.path().join("a").join("map.ply"),
        poses,
        camera: dir.path().join("a").join("camera.json"),
        out: dir.path().join("render"),
        engine: EngineChoice::Cpu,
        overwrite: false,
    };
    assert_eq!(render_map(&rendered, &mut |_, _| {}).expect("render"), 15);
    assert_eq!(pose_lines(read("render")), some);
    let dataset = Dataset::open(&dir.path().join("render")).expect("dataset");
    let recorded = Dataset::open(&dir.path().join("a")).expect("dataset");
    let engine = Rasteriser::select(EngineChoice::Cpu);
    for k in [0, 7, 14] {
        let frame = dataset.load(k).expect("frame");
        let images = engine
            .render(&map.gaussians, &frame.camera)
            .expect("render");
        let images = images.images();
        for (byte, c) in frame.rgb.iter().zip(&images.colour) {
            assert!((f32::from(*byte) / 255.0 - c.clamp(0.0, 1.0)).abs() <= 0.5 / 255.0 + 1e-6);
        }
        for ((d, z), s) in frame
            .depth
            .iter()
            .zip(&images.depth)
            .zip(&images.silhouette)
        {
            let expected = if *s >= 0.5 { z / s } else { 0.0 };
            // 16-bit PNG depth: 0.2 mm steps.
            assert!(
                (d - expected).abs() <= 1.1e-4 || expected > 5.0,
                "{d} vs {expected}"
            );
        }
        // Novel views of a 60 s map resemble what the camera saw there.
        let truth = recorded.load(20 * k).expect("frame");
        let to_f = |v: &[u8]| v.iter().map(|b| f32::from(*b) / 255.0).collect::<Vec<_>>();
        let psnr = autonomy::metrics::psnr(&to_f(&frame.rgb), &to_f(&truth.rgb));
        assert!(psnr > 15.0, "view {k}: {psnr:.2} dB");
    }
}

#[test]
fn survey_map_scores_better_than_half_of_it_and_test_poses_are_free() {
    let dir = tempfile::tempdir().expect("tempdir");
    let survey = run_episode(
        &config(
            "worlds/room.xml",
            PlannerKind::Survey,
            250.0,
            dir.path().join("survey"),
        ),
        &mut |_| {},
    )
    .expect("survey");
    eprintln!("{survey:?}");
    assert_eq!(survey.ended, "survey complete");
    assert_eq!(survey.collision_steps, 0);
    let map = autonomy::ply::read(&dir.path().join("survey").join("map.ply")).expect("map.ply");
    let mut half = map.clone();
    let keep: Vec<bool> = (0..half.len()).map(|i| i % 2 == 0).collect();
    half.retain(&keep);

    let sensor = SensorConfig::default();
    let mut world =
        splatloop::world::World::load(&repo_path("worlds/room.xml"), &sensor).expect("world");
    let gl = splatloop::egl::EglContext::new().expect("EGL");
    let mut camera = world.make_camera(&sensor, 1, &gl).expect("camera");
    let tests = TestSet::sample(&world, &camera, 15, 99, sensor.max_range).expect("test set");
    assert_eq!(tests.poses.len(), 15);
    let engine = Rasteriser::select(EngineChoice::Cpu);
    let full = evaluate(&world, &mut camera, &engine, &map, &tests, &|| false).expect("evaluate");
    let halved =
        evaluate(&world, &mut camera, &engine, &half, &tests, &|| false).expect("evaluate");
    eprintln!("full {full:?}\nhalf {halved:?}");
    assert!(full.psnr > halved.psnr + 0.5, "{full:?} vs {halved:?}");
    assert!(full.ssim > halved.ssim, "{full:?} vs {halved:?}");
    assert!(full.coverage > halved.coverage, "{full:?} vs {halved:?}");
    // The survey sees nearly all of the room (measured: 97%).
    assert!(full.coverage > 0.9, "survey coverage {:.3}", full.coverage);

    // Test poses lie in free space: MuJoCo finds no contact between the robot and the world
    // at any of them, and all are inside the room's walls (|x|, |y| < 3 m).
    for pose in &tests.poses {
        assert!(
            pose.x.abs() < 3.0 && pose.y.abs() < 3.0,
            "{pose:?} is outside the room"
        );
        let robot = world.robot().clone();
        robot.place(world.data_mut(), *pose);
        let contacts: Vec<_> = world.robot_collisions().collect();
        assert!(
            contacts.is_empty(),
            "{pose:?} touches the world: {contacts:?}"
        );
    }
}

#[test]
fn a_boxed_in_robot_ends_with_a_recovery_and_a_reason() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut config = config("", PlannerKind::RtGuide, 120.0, dir.path().join("boxed"));
    config.world = fixture("boxed_in.xml");
    config.test_views = 0;
    let metrics = run_episode(&config, &mut |_| {}).expect("episode");
    assert!(metrics.recovery_events >= 1, "{metrics:?}");
    assert!(
        metrics.ended.starts_with("stuck"),
        "ended: {}",
        metrics.ended
    );
    assert!(
        metrics.simulated_seconds < 60.0,
        "took {} s to give up",
        metrics.simulated_seconds
    );
    assert!(metrics.path_length < 0.3);
    // Nothing is lost: the folder is complete.
    assert!(dir.path().join("boxed").join("metrics.json").is_file());
    assert!(dir.path().join("boxed").join("map.ply").is_file());
}

#[test]
fn a_60_s_rtguide_episode_in_a_generated_world_of_each_kind_has_no_collisions() {
    // Measured on the CI machine (2026-12-08, seed 3, latency none, 20 hidden views, the
    // committed suite, RT-GuIDE's defaults): apartment_01 8.8 m, coverage 41.8%, PSNR 12.4 dB;
    // office_01 11.8 m, 38.7%, 13.6 dB; warehouse_01 9.0 m, 1.8%, 7.1 dB (2026-12-03, before
    // the full turn at the spawn: 34.9% / 11.8, 29.5% / 12.3, 14.7% / 8.6).
    //
    // The warehouse's coverage in a minute is no regression signal: the hall is 16 x 13 m,
    // the hidden views are spread over it, and in its first minute the robot sees the part it
    // first turns toward. Both trajectories above drive about 9 m by 60 s, yet one covers
    // 0.2% of the hidden views until 50 s and 15.1% at 60 s, the other 1.8% from 20 s to
    // 60 s and 6.5% at 70 s (three minutes: 52.6% and 37.3%); one recovery apart. There the
    // check is that the robot drives and maps some of what the views see; in the apartment
    // and the office a minute sees a good part of the world, so their floors, a little under
    // the measured values, catch a mapper or planner that regresses.
    let dir = tempfile::tempdir().expect("tempdir");
    // Floors on (coverage, PSNR dB); the warehouse's: some of what the views see is mapped.
    for (world, floors) in [
        ("apartment_01", (0.33, 11.0)),
        ("office_01", (0.30, 11.5)),
        ("warehouse_01", (0.005, f64::NEG_INFINITY)),
    ] {
        let (coverage, psnr) = floors;
        let config = config(
            &format!("worlds/suite/{world}.xml"),
            PlannerKind::RtGuide,
            60.0,
            dir.path().join(world),
        );
        let metrics = run_episode(&config, &mut |_| {}).expect("episode");
        eprintln!(
            "{world}: {:.1} m, {} recoveries, coverage {:.1}%, PSNR {:.1} dB, ended {}",
            metrics.path_length,
            metrics.recovery_events,
            100.0 * metrics.evaluation.coverage,
            metrics.evaluation.psnr,
            metrics.ended
        );
        assert_eq!(metrics.collision_steps, 0, "{world}");
        assert!(metrics.path_length > 6.0, "{world}: {metrics:?}");
        // An episode may end early when RT-GuIDE gets stuck (the RT-GuIDE issue), never at
        // once: it ran and was evaluated.
        assert!(metrics.frames > 100, "{world}: {} frames", metrics.frames);
        assert_eq!(metrics.evaluation.views, 20, "{world}");
        assert!(
            metrics.evaluation.coverage > coverage,
            "{world}: {:?}",
            metrics.evaluation
        );
        assert!(
            metrics.evaluation.psnr > psnr,
            "{world}: {:?}",
            metrics.evaluation
        );
    }
}

/// What decides an episode's numbers is in its episode.json: the renderer (EGL device, GL
/// vendor, renderer and version), the build's CPU features, the CPU, the engine's threads,
/// the splat engine, MuJoCo's version, the commit the binary was built from.
#[test]
fn episode_json_records_what_decides_its_numbers() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("ep");
    let mut run = config("worlds/room.xml", PlannerKind::RtGuide, 2.0, out.clone());
    run.test_views = 0;
    run_episode(&run, &mut |_| {}).expect("episode");
    let episode: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("episode.json")).expect("episode.json"))
            .expect("json");
    let versions = &episode["versions"];
    let renderer = versions["renderer"].as_str().expect("renderer");
    assert_eq!(
        renderer.matches(" / ").count(),
        2,
        "vendor / renderer / version: {renderer}"
    );
    let features: Vec<&str> = versions["target_features"]
        .as_array()
        .expect("features")
        .iter()
        .filter_map(|f| f.as_str())
        .collect();
    assert_eq!(
        features.contains(&"avx2"),
        cfg!(target_feature = "avx2"),
        "{features:?}"
    );
    assert_eq!(
        features.contains(&"fma"),
        cfg!(target_feature = "fma"),
        "{features:?}"
    );
    assert_eq!(
        versions["threads"].as_u64(),
        Some(rayon::current_num_threads() as u64)
    );
    assert!(versions["splat_engine"]
        .as_str()
        .expect("engine")
        .starts_with("cpu ("));
    assert!(!versions["cpu"].as_str().expect("cpu").is_empty());
    assert!(!versions["mujoco"].as_str().expect("mujoco").is_empty());
    // The build's commit: this checkout's HEAD (cargo rebuilds when HEAD moves).
    let commit = versions["commit"].as_str().expect("commit");
    let head = std::process::Command::new("git")
        .args(["rev-parse", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned());
    match head {
        Some(head) => assert_eq!(commit, head),
        None => assert_eq!(commit, "unknown"),
    }
}

/// A scripted planner for the no-progress fixture: drives east from the spawn to x = 1.0 m
/// (the ball's near side is 1.34 m east), turns its back on the ball, then plans standing
/// still for ever, so the progress watch overrules it.
struct TurnsItsBackThenStands {
    phase: Phase,
}

#[derive(Clone, Copy, PartialEq)]
enum Phase {
    Approach,
    TurnAround,
    Stand,
}

impl autonomy::explore::Planner for TurnsItsBackThenStands {
    fn name(&self) -> &str {
        "turns-its-back-then-stands"
    }

    fn settings(&self) -> serde_json::Value {
        serde_json::Value::Null
    }

    fn plan(
        &mut self,
        _map: &autonomy::map::GaussianMap,
        start: autonomy::drive::Pose2,
    ) -> autonomy::explore::Decision {
        use autonomy::drive::{wrap_angle, UnicycleCommand};
        const STOP_AT: f64 = 1.0;
        if self.phase == Phase::Approach && start.x >= STOP_AT - 0.02 {
            self.phase = Phase::TurnAround;
        }
        let facing_west = wrap_angle(start.theta - std::f64::consts::PI).abs() < 0.05;
        if self.phase == Phase::TurnAround && facing_west {
            self.phase = Phase::Stand;
        }
        let command = match self.phase {
            // At most the rest of the way in the 1 s before the next plan.
            Phase::Approach => UnicycleCommand {
                v: (STOP_AT - start.x).clamp(0.0, 0.3),
                w: -wrap_angle(start.theta),
            },
            Phase::TurnAround => UnicycleCommand {
                v: 0.0,
                w: wrap_angle(std::f64::consts::PI - start.theta).clamp(-0.6, 0.6),
            },
            Phase::Stand => UnicycleCommand { v: 0.0, w: 0.0 },
        };
        autonomy::explore::Decision::Go(autonomy::explore::Plan::driven(
            start,
            vec![command; 10],
            0.1,
        ))
    }
}

#[test]
fn a_robot_that_makes_no_progress_backs_off_the_way_it_came_not_into_what_is_behind_it() {
    // robustness-depth-noise, apartment_02, RT-GuIDE spawn 3: a back-off had turned the robot's
    // back on ball_16; ten seconds without progress later the watch's back-off, blind, turned
    // half round and drove 0.15 m into the ball (449 collision steps). Here the ball stands
    // 0.6 m behind a robot that drove up to it, turned away and stands still: driving the
    // way it came is the way out; half round and forward is into the ball.
    let dir = tempfile::tempdir().expect("tempdir");
    let mut config = config("", PlannerKind::RtGuide, 30.0, dir.path().join("behind"));
    config.world = fixture("ball_behind.xml");
    config.test_views = 0;
    let mut episode = splatloop::episode::Episode::with_planner(&config, |_| {
        Ok(Box::new(TurnsItsBackThenStands {
            phase: Phase::Approach,
        }))
    })
    .expect("episode");
    let (mut turned_at, mut overruled_from) = (None, None);
    // A step thinks first, then drives: where it was overruled is where the last one ended
    // (the first from the spawn, the origin).
    let mut before = autonomy::drive::Pose2::default();
    let last = loop {
        let report = episode.step().expect("step");
        if matches!(report.think, Some(splatloop::episode::Think::Overruled)) {
            overruled_from.get_or_insert(before);
        }
        before = report.pose;
        if turned_at.is_none() && report.pose.theta.cos() < -0.99 {
            turned_at = Some(report.pose);
        }
        if report.ended.is_some() {
            break report.pose;
        }
    };
    let metrics = episode.finish().expect("finish");
    eprintln!("{metrics:?}");
    let turned_at = turned_at.expect("the script turned its back on the ball");
    assert!(
        (turned_at.x - 1.0).abs() < 0.1,
        "turned at x = {:.2}",
        turned_at.x
    );
    let overruled_from = overruled_from.expect("the watch overruled a robot standing still");
    assert!(
        overruled_from.distance([turned_at.x, turned_at.y]) < 0.05,
        "overruled at {overruled_from:?}"
    );
    assert_eq!(metrics.plan_failures.get("NoProgress").copied(), Some(1));
    assert_eq!(metrics.collision_steps, 0, "the back-off touched the ball");
    assert_eq!(metrics.retraces, 1);
    // It drove back along its trail, the retrace's metre, away from the ball.
    assert!(
        last.x < turned_at.x - 0.8 && last.y.abs() < 0.1,
        "ended at {last:?}"
    );
}

/// A scripted planner for the blocked-at-the-spawn fixture, after robustness-as-is,
/// warehouse_02, RT-GuIDE spawn 3: every plan from the spawn is blocked by floor the map does
/// not yet hold, on the robot's far side (bearing -100 degrees, 1-2.5 m out); the plans it
/// can make turn the robot back toward its target (east), as RT-GuIDE's did between looks
/// around. Once the map holds that floor, it drives 1.5 m onto it and is done.
struct BlockedUntilItSeesItsFarSide {
    free: bool,
}

impl BlockedUntilItSeesItsFarSide {
    /// The bearing, from the spawn, of the floor that blocks the plans until it is mapped.
    const FAR_SIDE: f64 = -100.0 * std::f64::consts::PI / 180.0;
    /// Why it is done: 1.5 m out on the far side.
    const ARRIVED: &str = "on the far side";

    /// Whether the map holds floor there: Gaussians on the ground within 15 degrees of the
    /// bearing, 1-2.5 m out.
    fn sees_far_side(map: &autonomy::map::GaussianMap) -> bool {
        let on_far_side = |m: &&[f32; 3]| {
            let (x, y) = (f64::from(m[0]), f64::from(m[1]));
            let bearing = autonomy::drive::wrap_angle(y.atan2(x) - Self::FAR_SIDE);
            m[2] < 0.05 && (1.0..2.5).contains(&x.hypot(y)) && bearing.abs() < 0.26
        };
        map.gaussians.means.iter().filter(on_far_side).count() >= 20
    }
}

impl autonomy::explore::Planner for BlockedUntilItSeesItsFarSide {
    fn name(&self) -> &str {
        "blocked-until-it-sees-its-far-side"
    }

    fn settings(&self) -> serde_json::Value {
        serde_json::Value::Null
    }

    fn plan(
        &mut self,
        map: &autonomy::map::GaussianMap,
        start: autonomy::drive::Pose2,
    ) -> autonomy::explore::Decision {
        use autonomy::drive::{wrap_angle, UnicycleCommand};
        use autonomy::explore::{Decision, Plan, PlanFailure};
        self.free = self.free || Self::sees_far_side(map);
        let command = if self.free {
            if start.x.hypot(start.y) >= 1.5 {
                return Decision::Done(Self::ARRIVED.to_owned());
            }
            let error = wrap_angle(Self::FAR_SIDE - start.theta);
            let v = if error.abs() < 0.1 { 0.3 } else { 0.0 };
            UnicycleCommand {
                v,
                w: error.clamp(-0.6, 0.6),
            }
        } else {
            let error = wrap_angle(-start.theta);
            if error.abs() < 0.1 {
                return Decision::Fail(PlanFailure::NoCandidateClearOfUnseen);
            }
            UnicycleCommand {
                v: 0.0,
                w: error.clamp(-0.6, 0.6),
            }
        };
        Decision::Go(Plan::driven(start, vec![command; 10], 0.1))
    }
}

#[test]
fn a_robot_blocked_at_its_spawn_by_floor_it_has_not_seen_turns_a_full_circle_and_gets_free() {
    // robustness-as-is, warehouse_02, RT-GuIDE spawn 3 ended stuck at its spawn at 47 s: a
    // look around turns 155 degrees counter-clockwise, the plans between turned the robot
    // back toward its target, so the camera swept the same sector for ever and the floor
    // every candidate had to cross stayed unseen; blocked again, a robot at its spawn had no
    // trail to retrace. Here that floor lies at bearing -100 degrees, outside what a look
    // around and the turn back show (east, 75 degrees of view, up to 155 degrees round).
    let dir = tempfile::tempdir().expect("tempdir");
    let mut config = config("", PlannerKind::RtGuide, 50.0, dir.path().join("blocked"));
    config.world = fixture("open_floor.xml");
    config.test_views = 0;
    let mut episode = splatloop::episode::Episode::with_planner(&config, |_| {
        Ok(Box::new(BlockedUntilItSeesItsFarSide { free: false }))
    })
    .expect("episode");
    let mut left_at = None;
    let last = loop {
        let report = episode.step().expect("step");
        if left_at.is_none() && report.pose.x.hypot(report.pose.y) > 0.3 {
            left_at = Some(report.time);
        }
        if report.ended.is_some() {
            break report.pose;
        }
    };
    let metrics = episode.finish().expect("finish");
    eprintln!("{metrics:?}");
    assert_eq!(
        metrics.ended,
        BlockedUntilItSeesItsFarSide::ARRIVED,
        "{metrics:?}"
    );
    let left_at = left_at.expect("the robot never left its spawn");
    assert!(left_at < 30.0, "left its spawn only at {left_at:.1} s");
    // Blocked twice: a look around, then the full circle that showed the far side.
    assert_eq!(
        metrics
            .plan_failures
            .get("NoCandidateClearOfUnseen")
            .copied(),
        Some(2)
    );
    assert_eq!((metrics.collision_steps, metrics.retraces), (0, 0));
    let bearing =
        autonomy::drive::wrap_angle(last.y.atan2(last.x) - BlockedUntilItSeesItsFarSide::FAR_SIDE);
    assert!(
        last.x.hypot(last.y) > 1.2 && bearing.abs() < 0.2,
        "ended at {last:?}"
    );
}
