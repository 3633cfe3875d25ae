//! The episode as a library: stepping an `Episode` by hand writes what `splatloop run`'s loop
//! writes, for every planner; a caller's own commands drive the robot as the unicycle model
//! says, and the dataset records where it went.

use crate::support::run_config;
use splatloop::dataset::Dataset;
use splatloop::episode::{run_episode, Episode, PlannerKind, Think};
use splatloop::robot::UnicycleCommand;

/// A short episode for these tests: 10 s in the room, no hidden views.
fn short(planner: PlannerKind, out: std::path::PathBuf) -> splatloop::episode::RunConfig {
    let mut config = run_config("worlds/room.xml", planner, 10.0, out);
    config.test_views = 0;
    config
}

#[test]
fn stepping_an_episode_by_hand_writes_what_run_writes_for_every_planner() {
    let dir = tempfile::tempdir().expect("tempdir");
    for planner in PlannerKind::ALL {
        let name = planner.name();
        let run = short(planner, dir.path().join(format!("{name}-run")));
        let ran = run_episode(&run, &mut |_| {}).expect("run_episode");
        let stepped = short(planner, dir.path().join(format!("{name}-stepped")));
        let mut episode = Episode::new(&stepped).expect("episode");
        let mut steps = 0;
        loop {
            // Looking at the frame between steps must not change what happens.
            let frame_time = episode.observe().expect("frame").time;
            let report = episode.step().expect("step");
            steps += 1;
            assert!(report.time > frame_time, "{name}: time went backwards");
            if report.ended.is_some() {
                break;
            }
        }
        let metrics = episode.finish().expect("finish");
        assert_eq!(metrics.ended, ran.ended, "{name}");
        assert_eq!(metrics.mapping_steps, ran.mapping_steps, "{name}");
        assert!(steps >= ran.mapping_steps, "{name}: {steps} steps");
        for file in ["groundtruth.txt", "map.ply"] {
            let read = |folder: &str| {
                std::fs::read(dir.path().join(folder).join(file)).expect("episode file")
            };
            assert!(
                read(&format!("{name}-run")) == read(&format!("{name}-stepped")),
                "{name}: {file} differs between run_episode and stepping"
            );
        }
    }
}

#[test]
fn a_caller_drives_five_seconds_as_the_drive_model_says_then_the_planner_takes_over() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("driven");
    let mut episode = Episode::new(&short(PlannerKind::RtGuide, out.clone())).expect("episode");
    // A slow left arc of radius 0.5 m from the room's spawn: clear of everything.
    let command = UnicycleCommand { v: 0.2, w: 0.4 };
    let limits = episode.world().robot().limits;
    assert!(episode
        .apply(UnicycleCommand {
            v: limits.max_forward * 2.0,
            w: 0.0
        })
        .is_err());
    assert!(episode
        .apply(UnicycleCommand {
            v: f64::NAN,
            w: 0.0
        })
        .is_err());
    let mut observed = Vec::new();
    let mut pose = episode.pose();
    for second in 0..5 {
        observed.push(episode.observe().expect("frame").clone());
        episode.apply(command).expect("a command within the limits");
        let report = episode.step().expect("step");
        assert_eq!(
            report.think,
            Some(Think::Driven(command)),
            "second {second}"
        );
        assert_eq!(report.frames, 5, "second {second}");
        assert_eq!(report.collision_steps, 0, "second {second}");
        // The wheels' controller realises the unicycle model to within its spin-up: measured
        // 2026-12-04 at most 0.8 cm and 0.009 rad in a second (the first, from rest).
        let model = autonomy::drive::advance(&pose, &command, 1.0);
        let (moved, turned) = (
            report.pose.distance([model.x, model.y]),
            autonomy::drive::wrap_angle(report.pose.theta - model.theta).abs(),
        );
        assert!(
            moved < 0.02 && turned < 0.03,
            "second {second}: {:?} against the model's {model:?}",
            report.pose
        );
        eprintln!("second {second}: {moved:.4} m, {turned:.4} rad from the model");
        pose = report.pose;
    }
    // Arc after five seconds: the heading turned by about 2 rad in all.
    let start = episode.world().start();
    let turned = autonomy::drive::wrap_angle(pose.theta - start.theta);
    assert!((turned - 2.0).abs() < 0.15, "turned {turned} rad in 5 s");
    // Then the planner: asked at every think that no recovery holds.
    let mut planned = 0;
    loop {
        observed.push(episode.observe().expect("frame").clone());
        let report = episode.step().expect("step");
        assert!(!matches!(report.think, Some(Think::Driven(_))));
        planned += usize::from(matches!(report.think, Some(Think::Planned(_))));
        if report.ended.is_some() {
            break;
        }
    }
    assert!(planned >= 3, "the planner was asked {planned} times");
    let metrics = episode.finish().expect("finish");
    assert_eq!(metrics.frames, 50);
    // The dataset holds every frame; those the caller saw are there with their exact poses.
    let dataset = Dataset::open(&out).expect("dataset");
    assert_eq!(dataset.frames.len(), 50);
    for frame in &observed {
        let written = dataset
            .frames
            .iter()
            .find(|f| (f.time - frame.time).abs() < 1e-6)
            .unwrap_or_else(|| panic!("no frame at t = {}", frame.time));
        let (a, b) = (written.world_from_camera, frame.camera.world_from_camera);
        assert!(
            (a.translation.vector - b.translation.vector).norm() < 1e-5
                && a.rotation.angle_to(&b.rotation) < 1e-5,
            "t = {}: written {a:?}, seen {b:?}",
            frame.time
        );
    }
}
