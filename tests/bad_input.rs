//! Each kind of bad input gets an error that names the problem, never a crash.

use crate::support::{fixture, repo_path};
use splatloop::camera::SensorConfig;
use splatloop::controls::ControlSchedule;
use splatloop::record::{record, RecordConfig};
use splatloop::robot::DriveLimits;
use splatloop::world::World;
use splatloop::SimError;
use std::path::Path;

fn load(path: &Path) -> SimError {
    World::load(path, &SensorConfig::default()).expect_err("must be refused")
}

#[test]
fn a_missing_world_file_is_named() {
    let error = load(Path::new("worlds/no_such_world.xml"));
    assert!(matches!(error, SimError::MissingFile { .. }), "{error}");
    assert!(
        error.to_string().contains("worlds/no_such_world.xml"),
        "{error}"
    );
}

#[test]
fn malformed_mjcf_gives_mujocos_message_and_the_file() {
    let error = load(&fixture("malformed.xml"));
    let SimError::BadModel { path, message } = &error else {
        panic!("expected BadModel, got {error}");
    };
    assert!(path.ends_with("malformed.xml"));
    assert!(
        message.to_lowercase().contains("xml"),
        "MuJoCo's message: {message}"
    );
}

#[test]
fn a_world_without_the_robot_says_to_include_it() {
    let error = load(&fixture("no_robot.xml"));
    let text = error.to_string();
    assert!(text.contains("body 'robot' not found"), "{text}");
    assert!(text.contains("models/unicycle.xml"), "{text}");
}

#[test]
fn a_robot_without_its_camera_names_the_camera() {
    let text = load(&fixture("robot_without_camera.xml")).to_string();
    assert!(text.contains("camera 'rgbd' not found"), "{text}");
}

#[test]
fn resolutions_outside_the_supported_range_are_refused() {
    for (width, height) in [(8, 240), (320, 0), (5000, 240)] {
        let sensor = SensorConfig {
            width,
            height,
            ..SensorConfig::default()
        };
        let error = World::load(&repo_path("worlds/room.xml"), &sensor).expect_err("refused");
        assert!(
            error.to_string().contains("invalid resolution"),
            "{width}x{height}: {error}"
        );
    }
}

fn record_config(duration: f64, out: &Path) -> RecordConfig {
    RecordConfig {
        world: repo_path("worlds/room.xml"),
        controls: "circle".into(),
        duration,
        frame_rate: 5.0,
        seed: 0,
        sensor: SensorConfig::default(),
        start: None,
        overwrite: false,
        rerun: Default::default(),
        out: out.to_owned(),
    }
}

#[test]
fn a_negative_duration_is_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("episode");
    for duration in [-1.0, 0.0, f64::NAN] {
        let error = record(&record_config(duration, &out), &mut |_| {}).expect_err("refused");
        assert!(error.to_string().contains("invalid duration"), "{error}");
    }
    assert!(
        !out.exists(),
        "nothing may be written for a refused recording"
    );
}

#[test]
fn an_occupied_output_folder_is_not_overwritten() {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("precious.txt"), "keep me").expect("write");
    let error = record(&record_config(1.0, dir.path()), &mut |_| {}).expect_err("refused");
    assert!(error.to_string().contains("is not empty"), "{error}");
    assert_eq!(
        std::fs::read_to_string(dir.path().join("precious.txt")).expect("kept"),
        "keep me"
    );
}

#[test]
fn malformed_control_files_name_the_line() {
    let dir = tempfile::tempdir().expect("tempdir");
    let limits = DriveLimits::default();
    let cases = [
        ("t,v,w\n0,0.2,0\n1,fast,0\n", "line 3"),
        ("0,0.2,0\n0,0.3,0\n", "increasing"),
        ("0,0.9,0\n", "outside v in [0, 0.6]"),
        ("0,NaN,0\n", "finite"),
        ("# nothing\n", "no rows"),
    ];
    for (i, (text, expected)) in cases.iter().enumerate() {
        let path = dir.path().join(format!("case{i}.csv"));
        std::fs::write(&path, text).expect("write");
        let error = ControlSchedule::from_csv(&path, &limits).expect_err("refused");
        assert!(error.to_string().contains(expected), "case {i}: {error}");
    }
    let error = ControlSchedule::from_arg("no_such_pattern", &limits).expect_err("refused");
    assert!(
        error.to_string().contains("not a built-in pattern"),
        "{error}"
    );
}

#[test]
fn the_command_line_reports_errors_and_exits_non_zero() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_splatloop"))
        .args(["record", "--duration", "-2", "--out"])
        .arg(dir.path().join("x"))
        .current_dir(repo_path(""))
        .output()
        .expect("runs");
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("invalid duration"), "{stderr}");
}

#[test]
fn a_nan_state_is_reported_as_an_unstable_simulation() {
    let mut world = crate::support::room();
    world.data_mut().qvel_mut()[0] = f64::NAN;
    let error = world
        .step(splatloop::robot::UnicycleCommand::default())
        .expect_err("MuJoCo's bad-velocity warning must surface");
    assert!(matches!(error, SimError::Unstable { .. }), "{error}");
    assert!(error.to_string().contains("NaN"), "{error}");
    // MuJoCo reset the state; stepping on works and counts from a clean warning slate.
    world
        .step(splatloop::robot::UnicycleCommand::default())
        .expect("recovered");
}
