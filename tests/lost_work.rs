//! Nothing lost, round two: one test per way a demanding user lost work, hung a command or
//! was misled (D1-D20 of the issue), each named after what broke. The hang and signal tests
//! are bounded in time: a command that hangs fails the test instead of stalling it.

use crate::support::{binary, entries, repo_path, run_config, signal, snapshot, tiny_map};
use splatloop::camera::{RgbdFrame, SensorConfig};
use splatloop::dataset::DatasetWriter;
use splatloop::episode::{run_episode, PlannerKind};
use splatloop::record::{record, RecordConfig};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs `command` to its end, failing the test after `limit` (and killing it).
fn output_within(command: &mut Command, limit: Duration) -> Output {
    let child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starts");
    let id = child.id();
    let (sender, receiver) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = sender.send(child.wait_with_output());
    });
    match receiver.recv_timeout(limit) {
        Ok(output) => output.expect("output"),
        Err(_) => {
            let _ = Command::new("kill")
                .args(["-KILL", &id.to_string()])
                .status();
            panic!("the command still ran after {limit:?}: it hangs");
        }
    }
}

/// Waits for a child's end for at most `limit`; kills it and fails the test after that.
fn wait_within(child: &mut Child, limit: Duration) -> std::process::ExitStatus {
    let started = Instant::now();
    loop {
        if let Some(status) = child.try_wait().expect("poll") {
            return status;
        }
        if started.elapsed() > limit {
            let _ = child.kill();
            panic!("still running after {limit:?}: the signal was not honoured");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// Waits until `path` exists, failing after `limit`.
fn wait_for(path: &Path, limit: Duration) {
    let started = Instant::now();
    while !path.exists() {
        assert!(
            started.elapsed() < limit,
            "{} did not appear in {limit:?}",
            path.display()
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// A recorded drive of `duration` s (5 frames a second, the first at 0) into `out`.
fn recorded(out: &Path, duration: f64, overwrite: bool) -> splatloop::Result<usize> {
    record(
        &RecordConfig {
            world: repo_path("worlds/room.xml"),
            controls: "circle".into(),
            duration,
            frame_rate: 5.0,
            seed: 1,
            sensor: SensorConfig::default(),
            start: None,
            overwrite,
            rerun: Default::default(),
            out: out.to_path_buf(),
        },
        &mut |_| {},
    )
    .map(|summary| summary.frames)
}

/// An 8 x 6 frame, for writer-level tests.
fn small_frame(time: f64) -> RgbdFrame {
    use autonomy::camera::{Intrinsics, PinholeCamera};
    RgbdFrame {
        time,
        rgb: vec![128; 3 * 8 * 6],
        depth: vec![1.5; 8 * 6],
        camera: PinholeCamera {
            intrinsics: Intrinsics {
                fx: 6.0,
                fy: 6.0,
                cx: 3.5,
                cy: 2.5,
                width: 8,
                height: 6,
            },
            world_from_camera: autonomy::math::Isometry3::identity(),
        },
        instance: Vec::new(),
    }
}

/// Hidden siblings a run keeps beside a folder (`.NAME.partial`, `.NAME.lock`, `.NAME.old`).
fn leftovers(out: &Path) -> Vec<String> {
    let name = out
        .file_name()
        .expect("name")
        .to_string_lossy()
        .into_owned();
    std::fs::read_dir(out.parent().expect("parent"))
        .expect("read")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(&format!(".{name}.")))
        .collect()
}

/// D1
#[test]
fn world_check_plot_never_writes_over_the_world_or_an_existing_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let world = dir.path().join("room_copy.xml");
    // The world itself as --plot: refused, the world unchanged.
    let before = std::fs::read(repo_path("worlds/room.xml")).expect("room");
    let output = output_within(
        binary().args([
            "world",
            "check",
            "worlds/room.xml",
            "--plot",
            "worlds/room.xml",
        ]),
        Duration::from_secs(120),
    );
    assert!(!output.status.success());
    assert!(stderr(&output).contains("own input"), "{}", stderr(&output));
    assert_eq!(
        std::fs::read(repo_path("worlds/room.xml")).expect("room"),
        before
    );
    // An existing file: refused without --overwrite, replaced with it.
    std::fs::write(&world, "keep me").expect("write");
    let output = output_within(
        binary()
            .args(["world", "check", "worlds/room.xml", "--plot"])
            .arg(&world),
        Duration::from_secs(120),
    );
    assert!(!output.status.success());
    assert!(
        stderr(&output).contains("--overwrite"),
        "{}",
        stderr(&output)
    );
    assert_eq!(std::fs::read(&world).expect("kept"), b"keep me");
    let output = output_within(
        binary()
            .args(["world", "check", "worlds/room.xml", "--overwrite", "--plot"])
            .arg(&world),
        Duration::from_secs(120),
    );
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(std::fs::read(&world).expect("png").starts_with(b"\x89PNG"));
}

/// D2
#[test]
fn files_a_user_adds_while_an_overwrite_run_runs_are_kept() {
    let temp = tempfile::tempdir().expect("tempdir");
    let dir = std::fs::canonicalize(temp.path()).expect("real path");
    let out = dir.join("ep");
    recorded(&out, 0.4, false).expect("earlier episode");
    let earlier = snapshot(&out);
    let mut writer = DatasetWriter::create(&out, 5.0, true).expect("overwrite accepted");
    writer.write_frame(&small_frame(0.0)).expect("frame");
    // The user's notes arrive while the episode runs.
    std::fs::write(out.join("notes.txt"), "notes").expect("notes");
    let error = writer
        .finish(&serde_json::json!({"command": "test"}), false)
        .expect_err("the folder now holds a user's file");
    let text = format!("{error:#}");
    let beside = dir.join("ep.new");
    assert!(text.contains(&beside.display().to_string()), "{text}");
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).expect("kept"),
        "notes"
    );
    let mut now = snapshot(&out);
    now.retain(|(p, _)| p != Path::new("notes.txt"));
    assert_eq!(now, earlier, "the earlier episode is as it was");
    assert_eq!(entries(&beside.join("rgb.txt")), 1, "the new one is beside");
    assert!(leftovers(&out).is_empty(), "{:?}", leftovers(&out));
}

/// D4
#[test]
fn an_episode_into_a_mount_point_is_written_in_place() {
    let dir = tempfile::tempdir().expect("tempdir");
    let source = dir.path().join("volume");
    let mount = dir.path().join("mnt");
    std::fs::create_dir_all(&source).expect("source");
    std::fs::create_dir_all(&mount).expect("mount point");
    // A bind mount in a private mount namespace: a mount point as a Docker volume is one,
    // gone when the namespace ends; what was written stays in `source`.
    let bin = env!("CARGO_BIN_EXE_splatloop");
    let script = format!(
        "mount --bind '{src}' '{mnt}' && \
         '{bin}' record --duration 0.4 --out '{mnt}' && \
         '{bin}' record --duration 0.6 --out '{mnt}' --overwrite",
        src = source.display(),
        mnt = mount.display(),
    );
    let output = output_within(
        Command::new("unshare")
            .args(["--mount", "sh", "-c", &script])
            .current_dir(repo_path("")),
        Duration::from_secs(300),
    );
    assert!(
        output.status.success(),
        "a mount point as --out (unshare needs root, as in CI): {}",
        stderr(&output)
    );
    assert_eq!(entries(&source.join("rgb.txt")), 4, "the second episode");
    assert_eq!(
        std::fs::read_dir(source.join("rgb")).expect("rgb").count(),
        4
    );
    let own: Vec<String> = std::fs::read_dir(&source)
        .expect("read")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(own.is_empty(), "left inside the volume: {own:?}");
    assert!(leftovers(&mount).is_empty(), "{:?}", leftovers(&mount));
}

/// D5
#[test]
fn the_emptiness_check_stops_at_once_and_never_follows_links() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("loops");
    std::fs::create_dir_all(&out).expect("folder");
    std::os::unix::fs::symlink(".", out.join("a")).expect("link");
    std::os::unix::fs::symlink(".", out.join("b")).expect("link");
    for (overwrite, says) in [(false, "is not empty"), (true, "no splatloop manifest")] {
        let mut command = binary();
        command
            .args(["record", "--duration", "0.4", "--out"])
            .arg(&out);
        if overwrite {
            command.arg("--overwrite");
        }
        let output = output_within(&mut command, Duration::from_secs(60));
        assert!(!output.status.success());
        assert!(stderr(&output).contains(says), "{}", stderr(&output));
    }
    // A real episode with a link loop added: --overwrite names the link, in bounded time.
    let episode = dir.path().join("episode");
    recorded(&episode, 0.4, false).expect("episode");
    std::os::unix::fs::symlink(".", episode.join("rgb/loop")).expect("link");
    let output = output_within(
        binary()
            .args(["record", "--duration", "0.4", "--overwrite", "--out"])
            .arg(&episode),
        Duration::from_secs(60),
    );
    assert!(!output.status.success());
    assert!(stderr(&output).contains("rgb/loop"), "{}", stderr(&output));
}

/// Starts a one-world, one-planner sweep of `seeds` 60 s room episodes into `out`.
fn start_sweep(out: &Path, seeds: &str) -> Child {
    binary()
        .args([
            "sweep",
            "--worlds",
            "worlds/room.xml",
            "--planners",
            "rtguide",
            "--seeds",
            seeds,
            "--budget",
            "60",
            "--latency",
            "none",
            "--engine",
            "cpu",
            "--test-views",
            "3",
            "--jobs",
            "1",
            "--out",
        ])
        .arg(out)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("sweep starts")
}

/// The staging folder of the sweep's episode of `seed` (rtguide in the room), once it
/// has frames.
fn wait_for_episode_frames(out: &Path, seed: u64) {
    let staging = out.join(format!("room/rtguide/.{seed}.partial/rgb/000002.png"));
    wait_for(&staging, Duration::from_secs(300));
}

/// Whether a process whose command line mentions `text` is running.
fn running_with(text: &str) -> bool {
    Command::new("pgrep")
        .args(["-f", text])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// D6
#[test]
fn a_signal_stops_a_sweep_and_its_running_episode_and_the_sweep_resumes() {
    let dir = tempfile::tempdir().expect("tempdir");
    for (name, code) in [("-INT", 130), ("-TERM", 143)] {
        let out = dir.path().join(format!("sweep{code}"));
        let mut sweep = start_sweep(&out, "1..3");
        wait_for_episode_frames(&out, 1);
        signal(sweep.id(), name);
        let status = wait_within(&mut sweep, Duration::from_secs(120));
        assert_eq!(status.code(), Some(code), "{name}");
        assert!(
            !running_with(&out.display().to_string()),
            "{name}: an episode of the sweep still runs"
        );
        // No episode started after the signal; the stopped one is not complete.
        for seed in [2, 3] {
            assert!(
                !out.join(format!("room/rtguide/{seed}")).exists()
                    && !out.join(format!("room/rtguide/.{seed}.partial")).exists(),
                "{name}: seed {seed} started"
            );
        }
        let metrics = std::fs::read_to_string(out.join("room/rtguide/1/metrics.json"))
            .expect("the stopped episode is written");
        assert!(metrics.contains("\"ended\": \"interrupted"), "{metrics}");
    }
}

/// D7
#[test]
fn a_huge_seed_range_is_refused_before_anything_is_allocated() {
    let dir = tempfile::tempdir().expect("tempdir");
    for seeds in ["1..18446744073709551615", "1..10000000", "0..10000"] {
        let output = output_within(
            binary()
                .args([
                    "sweep",
                    "--worlds",
                    "worlds/room.xml",
                    "--planners",
                    "rtguide",
                    "--budget",
                    "10",
                    "--seeds",
                    seeds,
                    "--out",
                ])
                .arg(dir.path().join("big")),
            Duration::from_secs(30),
        );
        assert_eq!(
            output.status.code(),
            Some(1),
            "{seeds}: {}",
            stderr(&output)
        );
        assert!(
            stderr(&output).contains("more than 10000 seeds"),
            "{}",
            stderr(&output)
        );
        assert!(!dir.path().join("big/sweep.json").exists());
    }
}

/// D8
#[test]
fn a_refused_sweep_writes_no_sweep_json() {
    let dir = tempfile::tempdir().expect("tempdir");
    let twin = dir.path().join("twin");
    std::fs::create_dir_all(&twin).expect("twin");
    std::fs::copy(repo_path("worlds/room.xml"), twin.join("room.xml")).expect("copy");
    let out = dir.path().join("sweep");
    let refused: [Vec<String>; 2] = [
        vec![
            "--worlds".into(),
            "worlds/room.xml".into(),
            "--planners".into(),
            "rtguide,nonsense".into(),
        ],
        vec![
            "--worlds".into(),
            format!("worlds/room.xml,{}", twin.join("room.xml").display()),
        ],
    ];
    for words in refused {
        let output = output_within(
            binary().arg("sweep").args(&words).arg("--out").arg(&out),
            Duration::from_secs(30),
        );
        assert!(!output.status.success(), "{words:?}");
        assert!(
            !out.join("sweep.json").exists(),
            "{words:?} left sweep.json"
        );
    }
}

/// D10
#[test]
fn sweep_episode_beside_a_running_sweep_is_refused_and_records_nothing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("sweep");
    let mut sweep = start_sweep(&out, "1");
    wait_for_episode_frames(&out, 1);
    let output = output_within(
        binary()
            .args(["sweep", "episode", "--index", "0", "--out"])
            .arg(&out),
        Duration::from_secs(60),
    );
    assert!(!output.status.success());
    assert!(
        stderr(&output).contains("a sweep is running"),
        "{}",
        stderr(&output)
    );
    signal(sweep.id(), "-INT");
    wait_within(&mut sweep, Duration::from_secs(120));
    let log = std::fs::read_to_string(out.join("room/rtguide/1.log")).unwrap_or_default();
    assert!(
        !log.contains("another splatloop run"),
        "the refused task wrote the log: {log}"
    );
    let failures: Vec<_> = std::fs::read_dir(out.join("room/rtguide"))
        .expect("folder")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("fail"))
        .collect();
    let texts: Vec<String> = failures
        .iter()
        .map(|f| std::fs::read_to_string(out.join("room/rtguide").join(f)).unwrap_or_default())
        .collect();
    assert!(
        texts.iter().all(|t| !t.contains("another splatloop run")),
        "{texts:?}"
    );
}

/// D11
#[test]
fn a_refused_setting_leaves_no_staging_folder_or_lock_and_dot_is_the_current_folder() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("ep");
    for words in [
        vec!["--planner", "agslam", "--agslam-candidates", "0"],
        vec!["--planner", "agslam", "--pose-weight", "nan"],
        vec!["--rtguide-commit", "-1"],
    ] {
        let output = output_within(
            binary()
                .arg("run")
                .args(&words)
                .args(["--budget", "2", "--out"])
                .arg(&out),
            Duration::from_secs(120),
        );
        assert!(!output.status.success(), "{words:?}");
        assert!(!out.exists(), "{words:?}");
        assert!(
            leftovers(&out).is_empty(),
            "{words:?}: {:?}",
            leftovers(&out)
        );
    }
    // `--out .` in an empty folder: the episode lands in it, nothing is left beside.
    let here = dir.path().join("here");
    std::fs::create_dir_all(&here).expect("here");
    let output = output_within(
        Command::new(env!("CARGO_BIN_EXE_splatloop"))
            .current_dir(&here)
            .args(["record", "--duration", "0.4", "--out", ".", "--world"])
            .arg(repo_path("worlds/room.xml")),
        Duration::from_secs(120),
    );
    assert!(output.status.success(), "{}", stderr(&output));
    assert_eq!(entries(&here.join("rgb.txt")), 3);
    assert!(leftovers(&here).is_empty(), "{:?}", leftovers(&here));
    let hidden: Vec<_> = std::fs::read_dir(&here)
        .expect("read")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name())
        .filter(|n| n.to_string_lossy().starts_with('.'))
        .collect();
    assert!(hidden.is_empty(), "{hidden:?}");
}

/// D12
#[test]
fn eval_refuses_one_file_for_both_of_its_outputs() {
    let dir = tempfile::tempdir().expect("tempdir");
    let map = dir.path().join("map.ply");
    tiny_map(&map);
    let both = dir.path().join("scores");
    let output = output_within(
        binary()
            .args([
                "eval",
                "--world",
                "worlds/room.xml",
                "--test-views",
                "2",
                "--map",
            ])
            .arg(&map)
            .arg("--out")
            .arg(&both)
            .arg("--surface-out")
            .arg(dir.path().join(".").join("scores")),
        Duration::from_secs(120),
    );
    assert!(!output.status.success());
    assert!(stderr(&output).contains("both name"), "{}", stderr(&output));
    assert!(!both.exists());
}

/// The room exported as an OBJ scene (scene.obj, scene.mtl, textures) in `dir`.
fn exported_room(dir: &Path) -> PathBuf {
    let obj = dir.join("scene.obj");
    let output = output_within(
        binary()
            .args(["world", "export", "worlds/room.xml", "--out"])
            .arg(&obj),
        Duration::from_secs(120),
    );
    assert!(output.status.success(), "{}", stderr(&output));
    obj
}

/// D13
#[test]
fn import_never_writes_over_its_own_mtl() {
    let dir = tempfile::tempdir().expect("tempdir");
    let obj = exported_room(dir.path());
    let mtl = dir.path().join("scene.mtl");
    let before = std::fs::read(&mtl).expect("mtl");
    let output = output_within(
        binary()
            .args(["world", "import"])
            .arg(&obj)
            .arg("--overwrite")
            .arg("--out")
            .arg(&mtl),
        Duration::from_secs(300),
    );
    assert!(!output.status.success());
    assert!(stderr(&output).contains("own input"), "{}", stderr(&output));
    assert_eq!(std::fs::read(&mtl).expect("mtl"), before);
}

/// D14
#[test]
fn import_refuses_a_spawn_that_world_check_would_reject() {
    let dir = tempfile::tempdir().expect("tempdir");
    let obj = exported_room(dir.path());
    let world = dir.path().join("imported.xml");
    let output = output_within(
        binary()
            .args(["world", "import"])
            .arg(&obj)
            .args(["--spawn", "50,50,0", "--out"])
            .arg(&world),
        Duration::from_secs(300),
    );
    assert!(!output.status.success(), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("invalid spawn"),
        "{}",
        stderr(&output)
    );
    assert!(!world.exists());
}

/// D15
#[test]
fn render_refuses_a_pose_list_with_nan_timestamps() {
    let dir = tempfile::tempdir().expect("tempdir");
    let episode = dir.path().join("episode");
    recorded(&episode, 0.4, false).expect("episode");
    let map = dir.path().join("map.ply");
    tiny_map(&map);
    let poses = dir.path().join("poses.txt");
    std::fs::write(&poses, "NaN 0 0 0.35 0 0 0 1\n").expect("poses");
    let out = dir.path().join("rendered");
    let output = output_within(
        binary()
            .args(["render", "--map"])
            .arg(&map)
            .arg("--poses")
            .arg(&poses)
            .arg("--camera")
            .arg(episode.join("camera.json"))
            .arg("--out")
            .arg(&out),
        Duration::from_secs(120),
    );
    assert!(!output.status.success());
    assert!(
        stderr(&output).contains("is not a number of seconds"),
        "{}",
        stderr(&output)
    );
    assert!(!out.exists());
}

/// D16
#[test]
fn no_test_views_scores_null_not_zero() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut config = run_config(
        "worlds/room.xml",
        PlannerKind::RtGuide,
        2.0,
        dir.path().join("ep"),
    );
    config.test_views = 0;
    run_episode(&config, &mut |_| {}).expect("episode");
    let metrics: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("ep/metrics.json")).expect("metrics"),
    )
    .expect("json");
    for score in ["psnr", "ssim", "depth_mae", "depth_rmse", "coverage"] {
        assert!(
            metrics["evaluation"][score].is_null(),
            "{score}: {}",
            metrics["evaluation"][score]
        );
    }
}

/// D17
#[test]
fn a_world_without_a_spawn_site_says_where_the_robot_starts() {
    let dir = tempfile::tempdir().expect("tempdir");
    // The room without its spawn site, where its relative includes still resolve.
    std::os::unix::fs::symlink(repo_path("models"), dir.path().join("models")).expect("link");
    let worlds = dir.path().join("worlds");
    std::fs::create_dir_all(&worlds).expect("worlds");
    std::os::unix::fs::symlink(repo_path("worlds/assets"), worlds.join("assets")).expect("link");
    let room = std::fs::read_to_string(repo_path("worlds/room.xml")).expect("room");
    let without: String = room
        .lines()
        .filter(|l| !l.contains("name=\"spawn\""))
        .map(|l| format!("{l}\n"))
        .collect();
    assert_ne!(without, room);
    let world = worlds.join("no_spawn.xml");
    std::fs::write(&world, without).expect("world");
    let output = output_within(
        binary()
            .args(["record", "--duration", "0.2", "--world"])
            .arg(&world)
            .arg("--out")
            .arg(dir.path().join("drive")),
        Duration::from_secs(120),
    );
    // The room's origin holds a pillar: the warning says why the start is there, then the
    // start is refused as any blocked start is.
    assert!(!output.status.success());
    let text = stderr(&output);
    let warning = text.find("has no site named \"spawn\"").expect(&text);
    let refusal = text.find("is inside pillar").expect(&text);
    assert!(warning < refusal, "{text}");
}

/// D18
#[test]
fn a_leftover_earlier_episode_is_put_back_not_deleted() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("ep");
    recorded(&out, 0.4, false).expect("episode");
    let earlier = snapshot(&out);
    // A run died between finish's two renames: the only copy is `.ep.old`.
    let aside = dir.path().join(".ep.old");
    std::fs::rename(&out, &aside).expect("aside");
    let refused = recorded(&out, 0.4, false).expect_err("ep holds the earlier episode again");
    assert!(refused.to_string().contains("not empty"), "{refused}");
    assert_eq!(snapshot(&out), earlier);
    assert!(!aside.exists());
    // Beside a complete target, an `.old` holding a user's file is refused, not deleted.
    std::fs::create_dir_all(&aside).expect("aside");
    std::fs::write(aside.join("mine.txt"), "mine").expect("mine");
    let refused = recorded(&out, 0.4, true).expect_err("a user's file in .ep.old");
    assert!(refused.to_string().contains(".ep.old"), "{refused}");
    assert_eq!(
        std::fs::read_to_string(aside.join("mine.txt")).expect("kept"),
        "mine"
    );
}

/// D19
#[test]
fn an_interrupted_overwrite_run_keeps_the_complete_episode_and_writes_beside_it() {
    let temp = tempfile::tempdir().expect("tempdir");
    let dir = std::fs::canonicalize(temp.path()).expect("real path");
    let out = dir.join("ep");
    recorded(&out, 0.4, false).expect("complete episode");
    let earlier = snapshot(&out);
    let mut child = binary()
        .args([
            "run",
            "--budget",
            "60",
            "--latency",
            "none",
            "--engine",
            "cpu",
            "--test-views",
            "2",
            "--overwrite",
            "--out",
        ])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starts");
    wait_for(
        &dir.join(".ep.partial/rgb/000001.png"),
        Duration::from_secs(300),
    );
    signal(child.id(), "-INT");
    let status = wait_within(&mut child, Duration::from_secs(120));
    assert_eq!(status.code(), Some(130));
    let mut text = String::new();
    use std::io::Read;
    child
        .stderr
        .take()
        .expect("stderr")
        .read_to_string(&mut text)
        .expect("read");
    let beside = dir.join("ep.interrupted");
    assert!(text.contains(&beside.display().to_string()), "{text}");
    assert_eq!(snapshot(&out), earlier, "the complete episode is kept");
    let metrics = std::fs::read_to_string(beside.join("metrics.json")).expect("interrupted one");
    assert!(metrics.contains("\"ended\": \"interrupted"), "{metrics}");
}

/// D20
#[test]
fn a_signal_during_the_final_evaluation_stops_it() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("ep");
    // Thousands of hidden views: the evaluation takes far longer than the 1 s episode.
    let mut child = binary()
        .args([
            "run",
            "--budget",
            "1",
            "--latency",
            "none",
            "--engine",
            "cpu",
            "--test-views",
            "4000",
            "--out",
        ])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("starts");
    // map.ply is written just before the evaluation starts.
    wait_for(
        &dir.path().join(".ep.partial/map.ply"),
        Duration::from_secs(300),
    );
    let signalled = Instant::now();
    signal(child.id(), "-INT");
    let status = wait_within(&mut child, Duration::from_secs(60));
    assert_eq!(status.code(), Some(130));
    assert!(signalled.elapsed() < Duration::from_secs(30));
    let metrics: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).expect("metrics"))
            .expect("json");
    let ended = metrics["ended"].as_str().expect("ended");
    assert!(ended.contains("during the evaluation"), "{ended}");
    assert!(metrics["evaluation"]["psnr"].is_null());
}

/// D9
#[test]
fn an_asked_area_at_the_edge_of_a_kinds_range_is_made() {
    use splatloop::worldgen::{generate, GenerateConfig, WorldKind};
    let dir = tempfile::tempdir().expect("tempdir");
    for (kind, area) in [
        (WorldKind::Warehouse, 300.0),
        (WorldKind::Warehouse, 296.0),
        (WorldKind::Apartment, 50.0),
        (WorldKind::Apartment, 120.0),
        (WorldKind::Office, 200.0),
    ] {
        let out = dir.path().join(format!("{}_{area}.xml", kind.name()));
        let world = generate(
            &GenerateConfig {
                kind,
                seed: 1,
                area: Some(area),
                out: out.clone(),
                overwrite: false,
            },
            &mut |_, _| {},
        )
        .unwrap_or_else(|e| panic!("{} of {area} m2: {e}", kind.name()));
        assert!(
            (world.area - area).abs() <= 0.02 * area,
            "{} asked {area}, made {}",
            kind.name(),
            world.area
        );
        // world check's floor plan measures the outer walls too: more, never less.
        assert!(world.report.floor_area > world.area);
        assert!(out.is_file());
    }
}
