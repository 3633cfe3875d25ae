//! The rerun recording of an episode, read back by rerun's own CLI (`rerun rrd print`, from
//! the pip rerun-sdk that scripts/setup.sh pins in .venv): every frame's image, depth, camera
//! and path, every mapping step's map, every plan. The read-back needs a build with
//! `--features rerun` (scripts/test.sh runs it so); without it, asking for a recording is
//! refused with what to do.

use crate::support::run_config;
use splatloop::episode::{run_episode, PlannerKind};
use splatloop::rerun_log::RerunTarget;
#[cfg(feature = "rerun")]
use {crate::support::repo_path, std::collections::BTreeMap, std::path::Path};

/// A room episode of `budget` simulated seconds in `dir`/episode, without hidden views (the
/// recording is what is checked), recording to `rerun`.
fn room_episode(
    dir: &std::path::Path,
    budget: f64,
    rerun: RerunTarget,
) -> splatloop::episode::RunConfig {
    let mut config = run_config(
        "worlds/room.xml",
        PlannerKind::RtGuide,
        budget,
        dir.join("episode"),
    );
    config.test_views = 0;
    config.rerun = rerun;
    config
}

#[cfg(feature = "rerun")]
/// Rows per entity path and the data columns seen there, from `rerun rrd print`'s summary
/// (one line per chunk: "Chunk(..) with N rows (..) - /entity - data columns: [..]").
fn rows_per_entity(file: &Path) -> BTreeMap<String, (usize, String)> {
    let rerun = repo_path(".venv/bin/rerun");
    assert!(
        rerun.exists(),
        "{} is missing: scripts/setup.sh installs the rerun-sdk into .venv",
        rerun.display()
    );
    let output = std::process::Command::new(rerun)
        .args(["rrd", "print"])
        .arg(file)
        .env("RERUN_ANALYTICS", "0")
        .output()
        .expect("rerun runs");
    assert!(
        output.status.success(),
        "rerun rrd print failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let mut entities = BTreeMap::<String, (usize, String)>::new();
    for line in String::from_utf8_lossy(&output.stdout).lines() {
        let Some(rest) = line.strip_prefix("Chunk(") else {
            continue;
        };
        let rows: usize = rest
            .split(" with ")
            .nth(1)
            .and_then(|s| s.split(' ').next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("no row count in {line:?}"));
        let mut parts = line.split(" - ");
        let entity = parts.nth(1).expect("an entity path").trim().to_string();
        let columns = parts.next().unwrap_or_default().to_string();
        let entry = entities.entry(entity).or_default();
        entry.0 += rows;
        entry.1.push_str(&columns);
    }
    entities
}

#[cfg(feature = "rerun")]
#[test]
fn a_ten_second_recording_holds_every_frame_map_and_plan() {
    let dir = tempfile::tempdir().expect("temp dir");
    let file = dir.path().join("episode.rrd");
    let config = room_episode(
        dir.path(),
        10.0,
        RerunTarget {
            file: Some(file.clone()),
            connect: None,
            map_every: 1,
        },
    );
    let metrics = run_episode(&config, &mut |_| {}).expect("episode runs");
    let entities = rows_per_entity(&file);
    let rows = |entity: &str| entities.get(entity).map_or(0, |e| e.0);
    let columns = |entity: &str| {
        entities
            .get(entity)
            .map(|e| e.1.clone())
            .unwrap_or_default()
    };

    // Every frame: the pinhole at its pose, the image, the depth, the path so far.
    assert!(metrics.frames >= 50, "{} frames", metrics.frames);
    for entity in [
        "/world/camera/rgb",
        "/world/camera/depth",
        "/world/robot/path",
    ] {
        assert_eq!(rows(entity), metrics.frames, "{entity}: {entities:?}");
    }
    assert!(columns("/world/camera/rgb").contains("Image:buffer"));
    assert!(columns("/world/camera/depth").contains("DepthImage:meter"));
    let camera = columns("/world/camera");
    assert!(
        camera.contains("Pinhole:image_from_camera") && camera.contains("Transform3D:mat3x3"),
        "{camera}"
    );
    assert_eq!(rows("/world/camera"), metrics.frames);
    // Every frame's masks, as segmentation images named by labels.json (an annotation
    // context logged once, static).
    for entity in ["/world/camera/instance", "/world/camera/semantic"] {
        let (n, logged) = (rows(entity), columns(entity));
        assert!(
            (metrics.frames..=metrics.frames + 1).contains(&n),
            "{entity}: {n} rows for {} frames",
            metrics.frames
        );
        assert!(
            logged.contains("SegmentationImage:buffer") && logged.contains("AnnotationContext"),
            "{entity}: {logged}"
        );
    }
    // Every mapping step: the map, in colour and by uncertainty.
    assert!(metrics.mapping_steps >= 9, "{}", metrics.mapping_steps);
    for entity in ["/world/map/colour", "/world/map/uncertainty"] {
        assert_eq!(rows(entity), metrics.mapping_steps, "{entity}");
        assert!(columns(entity).contains("Points3D:positions"));
    }
    // Every plan: its candidates and the one chosen (a plan per think that did not fail).
    let plans = rows("/world/plan/chosen");
    let failures: usize = metrics.plan_failures.values().sum();
    assert!(
        plans >= 1 && plans + failures <= metrics.mapping_steps,
        "{plans} plans"
    );
    assert_eq!(rows("/world/plan/candidates"), plans);
    assert_eq!(rows("/timing/mapping_ms"), metrics.mapping_steps);
    assert_eq!(rows("/metrics/gaussians"), metrics.mapping_steps);
}

#[cfg(feature = "rerun")]
#[test]
fn a_recording_inside_the_episode_folder_or_over_a_file_is_refused() {
    let dir = tempfile::tempdir().expect("temp dir");
    let inside = RerunTarget {
        file: Some(dir.path().join("episode").join("inside.rrd")),
        connect: None,
        map_every: 1,
    };
    let mut config = room_episode(dir.path(), 1.0, inside);
    let error = run_episode(&config, &mut |_| {}).expect_err("refused");
    assert!(
        error.to_string().contains("inside the episode folder"),
        "{error}"
    );
    let existing = dir.path().join("old.rrd");
    std::fs::write(&existing, b"earlier").expect("write");
    config.rerun.file = Some(existing.clone());
    config.out = dir.path().join("second");
    let error = run_episode(&config, &mut |_| {}).expect_err("refused");
    assert!(error.to_string().contains("--overwrite"), "{error}");
    assert_eq!(std::fs::read(&existing).expect("read"), b"earlier");
}

#[cfg(not(feature = "rerun"))]
#[test]
fn a_recording_without_the_rerun_feature_says_how_to_build_one() {
    let dir = tempfile::tempdir().expect("temp dir");
    let wanted = RerunTarget {
        file: Some(dir.path().join("episode.rrd")),
        connect: None,
        map_every: 1,
    };
    let config = room_episode(dir.path(), 1.0, wanted);
    let error = run_episode(&config, &mut |_| {}).expect_err("refused");
    assert!(error.to_string().contains("--features rerun"), "{error}");
}

#[cfg(feature = "rerun")]
#[test]
fn a_live_viewer_receives_what_a_file_would_hold() {
    let dir = tempfile::tempdir().expect("temp dir");
    // A free port: bound, read back, released for rerun's server.
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port();
    let saved = dir.path().join("live.rrd");
    // rerun's own server, saving what it receives: what a viewer would show.
    let mut server = std::process::Command::new(repo_path(".venv/bin/rerun"))
        .args(["--port", &port.to_string(), "--save"])
        .arg(&saved)
        .env("RERUN_ANALYTICS", "0")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("rerun's server starts");
    // Until it listens.
    let listening = (0..100).any(|_| {
        std::thread::sleep(std::time::Duration::from_millis(100));
        std::net::TcpStream::connect(("127.0.0.1", port)).is_ok()
    });
    let config = room_episode(
        dir.path(),
        3.0,
        RerunTarget {
            file: None,
            connect: Some(format!("127.0.0.1:{port}")),
            map_every: 1,
        },
    );
    let metrics = listening.then(|| run_episode(&config, &mut |_| {}));
    // The server writes as it receives; give it a moment before reading the file.
    std::thread::sleep(std::time::Duration::from_secs(2));
    let _ = server.kill();
    let _ = server.wait();
    let metrics = metrics
        .expect("rerun's server listens")
        .expect("episode runs");
    let entities = rows_per_entity(&saved);
    let rows = |entity: &str| entities.get(entity).map_or(0, |e| e.0);
    assert_eq!(rows("/world/camera/rgb"), metrics.frames, "{entities:?}");
    assert_eq!(rows("/world/map/colour"), metrics.mapping_steps);
}

#[cfg(feature = "rerun")]
#[test]
fn a_recorded_drive_logs_every_frame_it_writes() {
    use splatloop::camera::SensorConfig;
    use splatloop::record::{record, RecordConfig};
    let dir = tempfile::tempdir().expect("temp dir");
    let file = dir.path().join("drive.rrd");
    let config = RecordConfig {
        world: repo_path("worlds/room.xml"),
        controls: "circle".into(),
        duration: 2.0,
        frame_rate: 5.0,
        seed: 0,
        sensor: SensorConfig::default(),
        start: None,
        overwrite: false,
        rerun: RerunTarget {
            file: Some(file.clone()),
            connect: None,
            map_every: 1,
        },
        out: dir.path().join("drive"),
    };
    let summary = record(&config, &mut |_| {}).expect("recording");
    let entities = rows_per_entity(&file);
    let rows = |entity: &str| entities.get(entity).map_or(0, |e| e.0);
    for entity in [
        "/world/camera",
        "/world/camera/rgb",
        "/world/camera/depth",
        "/world/robot/path",
    ] {
        assert_eq!(rows(entity), summary.frames, "{entity}: {entities:?}");
    }
    // An open-loop drive has no map and no plans.
    assert_eq!(rows("/world/map/colour") + rows("/world/plan/chosen"), 0);
}

/// D3 of "nothing lost, round two": a viewer address nothing answers at is refused before the
/// episode runs (it used to run whole, exit 1 and strand the episode in `.NAME.partial`).
#[cfg(feature = "rerun")]
#[test]
fn a_viewer_that_is_not_there_is_refused_before_the_episode() {
    let dir = tempfile::tempdir().expect("tempdir");
    // A port nothing listens on: bound, then let go.
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port();
    let config = room_episode(
        dir.path(),
        3.0,
        RerunTarget {
            file: None,
            connect: Some(format!("127.0.0.1:{port}")),
            map_every: 1,
        },
    );
    let error = run_episode(&config, &mut |_| {}).expect_err("no viewer there");
    assert!(
        error.to_string().contains("no rerun viewer answers"),
        "{error}"
    );
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .expect("read")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name())
        .collect();
    assert!(left.is_empty(), "{left:?}");
}
