//! Nothing lost: a run stopped by SIGINT or SIGTERM is written in full with equal image and
//! list counts (masks included); `--overwrite` replaces only an episode's own files; a failed run leaves the earlier
//! episode as it was; one run at a time per folder, and a killed run does not keep the lock;
//! no command writes over its inputs or an existing file without `--overwrite`; the bad
//! inputs that used to pass silently are errors or warnings; progress shows without a
//! terminal.

use crate::support::{binary, entries, fixture, repo_path, run_config, signal, snapshot, tiny_map};
use splatloop::camera::SensorConfig;
use splatloop::dataset::{read_trajectory, CameraFile, Dataset, DatasetWriter};
use splatloop::episode::{run_episode, PlannerKind, RunConfig};
use splatloop::record::{record, RecordConfig};
use splatloop::robot::Pose2;
use std::path::Path;
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

fn pngs(dir: &Path) -> usize {
    std::fs::read_dir(dir).map_or(0, |d| d.count())
}

/// Waits until the run writing `out` has `frames` frames in its staging folder.
fn wait_for_frames(child: &mut Child, out: &Path, frames: usize) {
    let staging = out.with_file_name(format!(
        ".{}.partial/rgb",
        out.file_name().expect("name").to_string_lossy()
    ));
    let started = Instant::now();
    while pngs(&staging) < frames {
        assert!(
            child.try_wait().expect("poll").is_none(),
            "the run ended before it was stopped"
        );
        assert!(
            started.elapsed() < Duration::from_secs(300),
            "no frames after 300 s"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

fn assert_whole_episode(out: &Path) {
    let frames = pngs(&out.join("rgb"));
    assert!(frames > 0);
    // Masks are on by default: their images and lists count the same.
    for images in ["depth", "instance", "semantic"] {
        assert_eq!(pngs(&out.join(images)), frames, "{images}/");
    }
    for list in [
        "rgb.txt",
        "depth.txt",
        "instance.txt",
        "semantic.txt",
        "groundtruth.txt",
    ] {
        assert_eq!(entries(&out.join(list)), frames, "{list}");
    }
    let transforms: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("transforms.json")).expect("transforms"),
    )
    .expect("valid JSON");
    assert_eq!(
        transforms["frames"].as_array().expect("frames").len(),
        frames
    );
    assert!(out.join("map.ply").is_file() && out.join("trajectory.png").is_file());
    assert_eq!(Dataset::open(out).expect("reads back").frames.len(), frames);
}

#[test]
fn a_run_stopped_by_sigint_or_sigterm_is_written_in_full_and_exits_130_or_143() {
    let dir = tempfile::tempdir().expect("tempdir");
    for (name, code) in [("-INT", 130), ("-TERM", 143)] {
        let out = dir.path().join(format!("ep{code}"));
        let mut child = binary()
            .args([
                "run",
                "--budget",
                "120",
                "--latency",
                "none",
                "--engine",
                "cpu",
                "--test-views",
                "3",
                "--out",
            ])
            .arg(&out)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("starts");
        wait_for_frames(&mut child, &out, 8);
        signal(child.id(), name);
        let status = child.wait().expect("ends");
        assert_eq!(status.code(), Some(code), "{name}");
        assert_whole_episode(&out);
        let metrics: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.join("metrics.json")).expect("metrics"),
        )
        .expect("json");
        let ended = metrics["ended"].as_str().expect("ended");
        assert!(ended.starts_with("interrupted at t = "), "{ended}");
    }
}

fn record_config(out: &Path, duration: f64, overwrite: bool) -> RecordConfig {
    RecordConfig {
        world: repo_path("worlds/room.xml"),
        controls: "spin".into(),
        duration,
        frame_rate: 5.0,
        seed: 0,
        sensor: SensorConfig::default(),
        start: None,
        overwrite,
        rerun: Default::default(),
        out: out.to_owned(),
    }
}

#[test]
fn overwrite_replaces_only_an_episodes_own_files_and_never_a_users() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("episode");
    record(&record_config(&out, 1.0, false), &mut |_| {}).expect("first");
    std::fs::write(out.join("thesis.tex"), "years of work").expect("write");
    std::fs::create_dir(out.join("docs")).expect("mkdir");
    std::fs::write(out.join("docs/notes.md"), "notes").expect("write");
    let before = snapshot(&out);
    let error = record(&record_config(&out, 2.0, true), &mut |_| {}).expect_err("refused");
    let text = error.to_string();
    assert!(
        text.contains("thesis.tex") && text.contains("docs/notes.md"),
        "{text}"
    );
    assert_eq!(snapshot(&out), before, "nothing touched");
    // Without the user's files, the episode is replaced.
    std::fs::remove_file(out.join("thesis.tex")).expect("rm");
    std::fs::remove_dir_all(out.join("docs")).expect("rm");
    let summary = record(&record_config(&out, 2.0, true), &mut |_| {}).expect("replaced");
    assert_eq!(summary.frames, 11);
    assert_eq!(entries(&out.join("rgb.txt")), 11);
    // Without --overwrite an episode is never replaced.
    let error = record(&record_config(&out, 1.0, false), &mut |_| {}).expect_err("refused");
    assert!(error.to_string().contains("--overwrite"), "{error}");
}

#[test]
fn a_run_that_fails_while_writing_leaves_the_earlier_episode_intact() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("episode");
    record(&record_config(&out, 1.0, false), &mut |_| {}).expect("first");
    let before = snapshot(&out);
    let old = Dataset::open(&out).expect("reads");
    let labels = std::sync::Arc::new(old.labels.clone().expect("masks by default"));
    let mut writer = DatasetWriter::create(&out, 5.0, true).expect("writer");
    writer.write_labels(labels.clone()).expect("labels");
    writer.fail_writes_after(3);
    let mut failed = None;
    for k in 0..old.frames.len() {
        if let Err(e) = writer.write_frame(&old.load(k).expect("frame")) {
            failed = Some(e);
            break;
        }
    }
    let error = failed.expect("the injected failure");
    assert!(error.to_string().contains("cannot write"), "{error}");
    drop(writer);
    assert_eq!(snapshot(&out), before, "the earlier episode is untouched");
    // And a finish that fails (the disk filled up at the end) changes nothing either.
    let mut writer = DatasetWriter::create(&out, 5.0, true).expect("writer");
    writer.write_labels(labels).expect("labels");
    writer
        .write_frame(&old.load(0).expect("frame"))
        .expect("one frame");
    writer.fail_writes_after(1);
    writer
        .finish(&serde_json::json!({"command": "test"}), false)
        .expect_err("fails");
    assert_eq!(snapshot(&out), before);
}

#[test]
fn an_error_mid_episode_is_written_into_ended_and_the_earlier_episode_kept() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("episode");
    record(&record_config(&out, 0.4, false), &mut |_| {}).expect("an earlier episode");
    let before = snapshot(&out);
    let config = RunConfig {
        budget: 5.0,
        seed: 0,
        iterations: 2,
        test_views: 0,
        overwrite: true,
        fail_writes_after: Some(6),
        ..run_config("worlds/room.xml", PlannerKind::RtGuide, 5.0, out.clone())
    };
    let error = run_episode(&config, &mut |_| {}).expect_err("the disk fills up");
    assert!(error.chain().contains("no space left"), "{}", error.chain());
    assert_eq!(snapshot(&out), before, "the earlier episode is untouched");
    // What was written of the failed run says why it ended.
    let staging = dir.path().join(".episode.partial");
    let metrics: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(staging.join("metrics.json")).expect("metrics"),
    )
    .expect("json");
    let ended = metrics["ended"].as_str().expect("ended");
    assert!(
        ended.starts_with("error at t = 1.2 s") && ended.contains("no space left"),
        "{ended}"
    );
    assert!(staging.join("map.ply").is_file());
}

#[test]
fn one_run_at_a_time_per_folder_and_a_killed_run_leaves_no_lock() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("episode");
    let first = DatasetWriter::create(&out, 5.0, false).expect("first");
    let error = DatasetWriter::create(&out, 5.0, false)
        .err()
        .expect("second refused");
    assert!(
        error.to_string().contains("another splatloop run"),
        "{error}"
    );
    drop(first);
    drop(DatasetWriter::create(&out, 5.0, false).expect("free again"));
    // Across processes: a second run is refused; the first killed outright frees the folder.
    let mut child = binary()
        .args(["record", "--controls", "spin", "--duration", "600", "--out"])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("starts");
    wait_for_frames(&mut child, &out, 3);
    let second = binary()
        .args(["record", "--duration", "1", "--out"])
        .arg(&out)
        .output()
        .expect("runs");
    assert!(!second.status.success());
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert!(stderr.contains("another splatloop run"), "{stderr}");
    signal(child.id(), "-KILL");
    child.wait().expect("ends");
    let third = binary()
        .args(["record", "--duration", "0.4", "--out"])
        .arg(&out)
        .output()
        .expect("runs");
    assert!(
        third.status.success(),
        "{}",
        String::from_utf8_lossy(&third.stderr)
    );
    assert_eq!(entries(&out.join("rgb.txt")), 3);
}

#[test]
fn no_command_writes_over_its_inputs_or_an_existing_file_without_overwrite() {
    let dir = tempfile::tempdir().expect("tempdir");
    let map = dir.path().join("map.ply");
    tiny_map(&map);
    let scores = dir.path().join("scores.json");
    // Both of eval's outputs: the scores (--out) and the surface points (--surface-out).
    for (flag, written) in [("--out", "psnr"), ("--surface-out", "x,y,z,covered")] {
        let eval = |out: &Path, overwrite: bool| {
            let mut command = binary();
            command
                .args(["eval", "--test-views", "2", "--engine", "cpu", "--map"])
                .arg(&map)
                .arg(flag)
                .arg(out);
            if overwrite {
                command.arg("--overwrite");
            }
            command.output().expect("runs")
        };
        std::fs::write(&scores, "mine").expect("write");
        let refused = eval(&scores, false);
        assert!(!refused.status.success(), "{flag}");
        assert!(String::from_utf8_lossy(&refused.stderr).contains("--overwrite"));
        assert_eq!(std::fs::read_to_string(&scores).expect("kept"), "mine");
        let onto_map = eval(&map, true);
        assert!(!onto_map.status.success(), "{flag}");
        assert!(String::from_utf8_lossy(&onto_map.stderr).contains("own input"));
        assert!(
            autonomy::ply::read(&map).is_ok(),
            "{flag}: the map survives"
        );
        assert!(eval(&scores, true).status.success(), "{flag}");
        assert!(std::fs::read_to_string(&scores)
            .expect("scores")
            .contains(written));
    }
    // render into the folder that holds its own map, even with --overwrite.
    let episode = dir.path().join("episode");
    record(&record_config(&episode, 0.4, false), &mut |_| {}).expect("episode");
    let inner_map = episode.join("map.ply");
    tiny_map(&inner_map);
    let config = splatloop::novel_view::RenderConfig {
        map: inner_map.clone(),
        poses: episode.join("groundtruth.txt"),
        camera: episode.join("camera.json"),
        out: episode.clone(),
        engine: autonomy::splat::EngineChoice::Cpu,
        overwrite: true,
    };
    let error = splatloop::novel_view::render_map(&config, &mut |_, _| {}).expect_err("refused");
    assert!(error.to_string().contains("own input"), "{error}");
    assert!(inner_map.is_file());
}

#[test]
fn an_adapter_name_that_matches_nothing_warns_and_falls_back() {
    let out = binary()
        .args([
            "bench",
            "render",
            "--engine",
            "gpu",
            "--gaussians",
            "200",
            "--iterations",
            "1",
        ])
        .env("WGPU_ADAPTER_NAME", "no-such-adapter-anywhere")
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("matches none"), "{stderr}");
}

#[test]
fn sizes_and_poses_from_files_are_checked_like_the_command_lines() {
    let dir = tempfile::tempdir().expect("tempdir");
    let camera = dir.path().join("camera.json");
    std::fs::write(&camera, r#"{"K": [[100, 0, 50], [0, 100, 50], [0, 0, 1]], "W": 300000, "H": 240, "depth_scale": 5000, "max_range": 5, "convention": ""}"#).expect("write");
    let error = CameraFile::read(&camera).expect_err("refused");
    assert!(error.to_string().contains("W = 300000"), "{error}");
    let poses = dir.path().join("groundtruth.txt");
    std::fs::write(&poses, "0.0 1 2 3 0 0 0 1\n0.2 NaN 0 0 0 0 0 1\n").expect("write");
    let error = read_trajectory(&poses).expect_err("refused");
    assert!(error.to_string().contains("not a pose"), "{error}");
}

#[test]
fn the_silent_cases_are_errors_or_warnings() {
    let dir = tempfile::tempdir().expect("tempdir");
    // Depth past what a 16-bit PNG holds.
    let sensor = SensorConfig {
        max_range: 20.0,
        ..SensorConfig::default()
    };
    let error = sensor.validate().expect_err("refused");
    assert!(error.to_string().contains("16-bit"), "{error}");
    // A start inside an obstacle, and a world without a floor.
    let mut config = record_config(&dir.path().join("a"), 1.0, false);
    config.start = Some(Pose2 {
        x: -0.3,
        y: 0.0,
        theta: 0.0,
    });
    let error = record(&config, &mut |_| {}).expect_err("in the pillar");
    assert!(error.to_string().contains("pillar"), "{error}");
    let mut config = record_config(&dir.path().join("b"), 1.0, false);
    config.world = fixture("no_floor.xml");
    let error = record(&config, &mut |_| {}).expect_err("no floor");
    assert!(error.to_string().contains("no floor"), "{error}");
    // A camera faster than the physics.
    let run = RunConfig {
        seed: 0,
        camera_rate: 1000.0,
        iterations: 1,
        test_views: 0,
        ..run_config(
            "worlds/room.xml",
            PlannerKind::RtGuide,
            1.0,
            dir.path().join("c"),
        )
    };
    let error = run_episode(&run, &mut |_| {}).expect_err("refused");
    assert!(
        error.to_string().contains("faster than the physics"),
        "{error}"
    );
    // The controls error lists the patterns that exist, and each one it lists exists.
    let limits = splatloop::robot::DriveLimits::default();
    let error = splatloop::controls::ControlSchedule::from_arg("zigzag", &limits)
        .expect_err("refused")
        .to_string();
    assert!(
        error.contains("arcs") && !error.contains("survey"),
        "{error}"
    );
    for (name, _) in splatloop::controls::PATTERNS {
        assert!(
            splatloop::controls::ControlSchedule::pattern(name).is_some(),
            "{name}"
        );
    }
    // A foreign 3DGS PLY with anisotropic scales and higher harmonics: read, and said so.
    let ply = dir.path().join("foreign.ply");
    let names = [
        "x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "f_rest_0", "f_rest_1", "opacity", "scale_0",
        "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3",
    ];
    let mut bytes = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex 2\n{}end_header\n",
        names
            .iter()
            .map(|n| format!("property float {n}\n"))
            .collect::<String>()
    )
    .into_bytes();
    for scales in [[-3.0f32, -2.0, -1.0], [-2.0, -2.0, -2.0]] {
        let values = [
            1.0, 0.0, 0.5, 0.1, 0.1, 0.1, 0.0, 0.0, 2.0, scales[0], scales[1], scales[2], 1.0, 0.0,
            0.0, 0.0,
        ];
        for v in values {
            bytes.extend_from_slice(&f32::to_le_bytes(v));
        }
    }
    std::fs::write(&ply, bytes).expect("write");
    let out = binary()
        .args(["eval", "--test-views", "1", "--engine", "cpu", "--map"])
        .arg(&ply)
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("1 of 2 Gaussians were anisotropic"),
        "{stderr}"
    );
    assert!(stderr.contains("f_rest_"), "{stderr}");
}

#[test]
fn a_torn_last_frame_is_skipped_with_a_warning() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("episode");
    record(&record_config(&out, 1.0, false), &mut |_| {}).expect("episode");
    let frames = Dataset::open(&out).expect("reads").frames.len();
    // The run was killed after one list got the next frame's line, half of it in another.
    let append = |name: &str, text: &str| {
        use std::io::Write;
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(out.join(name))
            .expect("open");
        f.write_all(text.as_bytes()).expect("append");
    };
    append("rgb.txt", "9.000000 rgb/000099.png\n");
    append("depth.txt", "9.000000 dep");
    let dataset = Dataset::open(&out).expect("still reads");
    assert_eq!(dataset.frames.len(), frames);
}

#[test]
fn progress_lines_appear_when_stderr_is_not_a_terminal() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = binary()
        .args(["record", "--controls", "spin", "--duration", "3", "--out"])
        .arg(dir.path().join("episode"))
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let lines: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("recording: "))
        .collect();
    assert!(lines.len() >= 5, "{stderr}");
    assert!(
        lines.last().is_some_and(|l| l.contains("done (100%")),
        "{lines:?}"
    );
    // A run says how far it is too; its CPU engine on a machine without a GPU is not news.
    let out = binary()
        .args([
            "run",
            "--budget",
            "2",
            "--latency",
            "none",
            "--test-views",
            "0",
            "--out",
        ])
        .arg(dir.path().join("run"))
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.lines().any(|l| l.starts_with("exploring: ")),
        "{stderr}"
    );
    assert!(!stderr.contains("no usable GPU adapter"), "{stderr}");
}

#[test]
fn an_os_error_is_reported_once() {
    let dir = tempfile::tempdir().expect("tempdir");
    let map = dir.path().join("map.ply");
    tiny_map(&map);
    let poses = dir.path().join("poses.txt");
    std::fs::write(&poses, "0 0 0 0.35 0 0 0 1\n").expect("poses");
    let out = binary()
        .args(["render", "--engine", "cpu", "--map"])
        .arg(&map)
        .arg("--poses")
        .arg(&poses)
        .arg("--camera")
        .arg(dir.path().join("missing.json"))
        .arg("--out")
        .arg(dir.path().join("out"))
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert_eq!(
        stderr.matches("No such file or directory").count(),
        1,
        "{stderr}"
    );
}
