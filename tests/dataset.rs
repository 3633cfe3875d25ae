//! Datasets: what is written reads back, the geometry in it is consistent, and the same
//! controls and seed give the same bytes.

use crate::support::{fixture, repo_path};
use splatloop::camera::{RgbdFrame, SensorConfig};
use splatloop::dataset::Dataset;
use splatloop::record::{record, RecordConfig};
use std::path::Path;

fn record_spin(out: &Path, seed: u64, noise: Option<f64>) {
    let config = RecordConfig {
        world: repo_path("worlds/room.xml"),
        controls: fixture("spin.csv").to_string_lossy().into_owned(),
        duration: 2.0,
        frame_rate: 5.0,
        seed,
        sensor: SensorConfig {
            depth_noise_sigma: noise,
            ..SensorConfig::default()
        },
        start: None,
        overwrite: false,
        rerun: Default::default(),
        out: out.to_owned(),
    };
    let summary = record(&config, &mut |_| {}).expect("recording");
    assert_eq!(summary.frames, 11, "frames at t = 0, 0.2, ..., 2.0");
}

/// Bilinear depth at a sub-pixel position, if the 4 neighbours are valid and agree (no edge).
fn depth_at(frame: &RgbdFrame, u: f64, v: f64) -> Option<f64> {
    let k = frame.camera.intrinsics;
    let (u0, v0) = (u.floor(), v.floor());
    if u0 < 0.0 || v0 < 0.0 || u0 + 1.0 >= f64::from(k.width) || v0 + 1.0 >= f64::from(k.height) {
        return None;
    }
    let at = |du: usize, dv: usize| {
        f64::from(frame.depth[(v0 as usize + dv) * k.width as usize + u0 as usize + du])
    };
    let d = [at(0, 0), at(1, 0), at(0, 1), at(1, 1)];
    let (lo, hi) = d
        .iter()
        .fold((f64::MAX, 0.0f64), |(lo, hi), x| (lo.min(*x), hi.max(*x)));
    if lo <= 0.0 || hi - lo > 0.02 {
        return None;
    }
    let (fu, fv) = (u - u0, v - v0);
    Some(
        d[0] * (1.0 - fu) * (1.0 - fv)
            + d[1] * fu * (1.0 - fv)
            + d[2] * (1.0 - fu) * fv
            + d[3] * fu * fv,
    )
}

#[test]
fn back_projected_depth_of_two_frames_agrees_on_the_walls_within_1cm() {
    let dir = tempfile::tempdir().expect("tempdir");
    record_spin(dir.path(), 0, None);
    let dataset = Dataset::open(dir.path()).expect("opens");
    assert_eq!(dataset.frames.len(), 11);
    // Frames 0 and 3: 0.3 rad apart while turning in place; they share most of their view.
    let (a, b) = (
        dataset.load(0).expect("frame 0"),
        dataset.load(3).expect("frame 3"),
    );
    let b_from_world = b.camera.world_from_camera.inverse();
    let k = a.camera.intrinsics;
    let mut compared = 0;
    for v in (0..k.height).step_by(3) {
        for u in (0..k.width).step_by(3) {
            let Some(depth) = depth_at(&a, f64::from(u), f64::from(v)) else {
                continue;
            };
            let point = a
                .camera
                .back_project_to_world(f64::from(u), f64::from(v), depth);
            if point.z < 0.1 {
                continue; // the floor; the test is about walls and furniture
            }
            let Some((ub, vb, _)) = b.camera.intrinsics.project(&(b_from_world * point)) else {
                continue;
            };
            let Some(depth_b) = depth_at(&b, ub, vb) else {
                continue;
            };
            let point_b = b.camera.back_project_to_world(ub, vb, depth_b);
            let gap = (point - point_b).norm();
            // A surface hidden in one view is not a disagreement; everything else must agree.
            if gap > 0.2 {
                continue;
            }
            assert!(
                gap <= 0.01,
                "pixel ({u}, {v}) lands {gap:.4} m from frame 3's point"
            );
            compared += 1;
        }
    }
    assert!(
        compared >= 1000,
        "only {compared} wall pixels seen by both frames"
    );
}

#[test]
fn the_files_describe_the_same_camera_and_poses() {
    let dir = tempfile::tempdir().expect("tempdir");
    record_spin(dir.path(), 0, None);
    let dataset = Dataset::open(dir.path()).expect("opens");
    let k = dataset.camera.intrinsics();
    assert_eq!(
        (k.width, k.height, dataset.camera.depth_scale),
        (320, 240, 5000.0)
    );
    let transforms: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("transforms.json")).expect("transforms.json"),
    )
    .expect("json");
    assert_eq!(transforms["depth_unit_scale_factor"].as_f64(), Some(0.0002));
    assert_eq!(
        transforms["cx"].as_f64(),
        Some(k.cx + 0.5),
        "nerfstudio pixel centres at +0.5"
    );
    let frames = transforms["frames"].as_array().expect("frames");
    assert_eq!(frames.len(), dataset.frames.len());
    for (entry, frame) in frames.iter().zip(&dataset.frames) {
        // OpenGL axes: column 2 is the optical z axis negated, column 3 the position.
        let m = |r: usize, c: usize| entry["transform_matrix"][r][c].as_f64().expect("number");
        let rotation = frame.world_from_camera.rotation.to_rotation_matrix();
        let t = frame.world_from_camera.translation.vector;
        for r in 0..3 {
            assert!((m(r, 2) + rotation[(r, 2)]).abs() < 1e-6);
            assert!((m(r, 1) + rotation[(r, 1)]).abs() < 1e-6);
            assert!((m(r, 0) - rotation[(r, 0)]).abs() < 1e-6);
            assert!((m(r, 3) - t[r]).abs() < 1e-6);
        }
        // The camera rides 0.4 m above the floor on a level robot.
        assert!((t.z - 0.401).abs() < 0.005, "camera height {}", t.z);
    }
    let episode: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("episode.json")).expect("episode.json"),
    )
    .expect("json");
    assert_eq!(episode["config"]["seed"].as_u64(), Some(0));
    // The MuJoCo that ran, which is the one the bindings were built against.
    let mujoco = splatloop::mujoco::version();
    assert_eq!(
        episode["versions"]["mujoco"].as_str(),
        Some(mujoco.as_str())
    );
    assert_eq!(mujoco, splatloop::mujoco::HEADER_VERSION);
}

fn folder_bytes(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).expect("readable") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let name = path
                    .strip_prefix(dir)
                    .expect("inside")
                    .to_string_lossy()
                    .into_owned();
                files.push((name, std::fs::read(&path).expect("bytes")));
            }
        }
    }
    files.sort();
    files
}

#[test]
fn the_same_controls_and_seed_write_byte_identical_datasets() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (first, second, other_seed) = (
        dir.path().join("a"),
        dir.path().join("b"),
        dir.path().join("c"),
    );
    record_spin(&first, 3, Some(0.005));
    record_spin(&second, 3, Some(0.005));
    record_spin(&other_seed, 4, Some(0.005));
    let (a, b, c) = (
        folder_bytes(&first),
        folder_bytes(&second),
        folder_bytes(&other_seed),
    );
    assert_eq!(
        a.len(),
        11 * 4 + 9,
        "11 RGB, depth, instance and semantic PNGs and 9 metadata files"
    );
    for ((name_a, bytes_a), (name_b, bytes_b)) in a.iter().zip(&b) {
        assert_eq!(name_a, name_b);
        assert!(
            bytes_a == bytes_b,
            "{name_a} differs between two identical recordings"
        );
    }
    let depth_differs = a
        .iter()
        .zip(&c)
        .any(|((n, x), (_, y))| n.starts_with("depth/") && x != y);
    assert!(depth_differs, "another seed must give other depth noise");
}

#[test]
fn a_degree_3_map_loads_with_plyfile_as_the_reference_loader_reads_it() {
    // plyfile (what graphdeco-inria's loader reads PLYs with), pinned in .venv by setup.sh.
    let python = repo_path(".venv/bin/python");
    assert!(
        python.exists(),
        "{} is missing: scripts/setup.sh installs plyfile into .venv",
        python.display()
    );
    let n = 500;
    let gaussians = autonomy::synthetic::room_surface(n, 7);
    let map = autonomy::map::GaussianMap::new(gaussians, (0..n).map(|k| k as f32).collect());
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("map.ply");
    autonomy::ply::write_with_sh_degree(&map, &path, 3).expect("write");
    // The reference loader's reads: 62 float properties it knows (x..z, normals, f_dc_0..2,
    // f_rest_0..44, opacity, scale_0..2, rot_0..3) plus our uncertainty, and the values.
    let script = "import sys, plyfile\n\
        v = plyfile.PlyData.read(sys.argv[1])['vertex']\n\
        names = [p.name for p in v.properties]\n\
        known = [n for n in names if n != 'uncertainty']\n\
        print(len(known), v.count, names.index('f_rest_44') - names.index('f_rest_0') + 1, \
        max(abs(float(x)) for x in v['f_rest_17']), float(v['x'][3]), float(v['uncertainty'][9]))";
    let out = std::process::Command::new(&python)
        .args(["-c", script])
        .arg(&path)
        .output()
        .expect("python runs");
    assert!(
        out.status.success(),
        "plyfile failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let said = String::from_utf8_lossy(&out.stdout);
    let words: Vec<&str> = said.split_whitespace().collect();
    assert_eq!(words[..4], ["62", "500", "45", "0.0"], "{said}");
    let x: f32 = words[4].parse().expect("x");
    assert_eq!(x, map.gaussians.means[3][0]);
    assert_eq!(words[5].parse::<f32>().expect("u"), 9.0);
}

fn record_world(out: &Path, world: &str, masks: bool) -> Dataset {
    let config = RecordConfig {
        world: repo_path(world),
        controls: "spin".into(),
        duration: 2.0,
        frame_rate: 5.0,
        seed: 0,
        sensor: SensorConfig {
            masks,
            ..SensorConfig::default()
        },
        start: None,
        overwrite: false,
        rerun: Default::default(),
        out: out.to_owned(),
    };
    record(&config, &mut |_| {}).expect("recording");
    Dataset::open(out).expect("opens")
}

/// What the generator places: the classes a generated world's masks may hold.
const GENERATED_KINDS: [&str; 9] = [
    "floor", "wall", "block", "sofa", "cylinder", "table", "rack", "vase", "ball",
];

#[test]
fn labels_name_every_id_in_the_masks_and_a_generated_worlds_classes_are_its_kinds() {
    let dir = tempfile::tempdir().expect("tempdir");
    for world in [
        "worlds/suite/office_01.xml",
        "worlds/suite/warehouse_01.xml",
    ] {
        let out = dir.path().join(world.replace('/', "_"));
        let dataset = record_world(&out, world, true);
        let labels = dataset.labels.as_ref().expect("labels.json");
        let mut classes_seen = std::collections::BTreeSet::new();
        let mut instances_seen = std::collections::BTreeSet::new();
        for index in 0..dataset.frames.len() {
            let (instance, semantic) = dataset
                .load_masks(index)
                .expect("reads")
                .expect("masks in every frame");
            let k = dataset.camera.intrinsics();
            assert_eq!(instance.len(), k.pixel_count());
            for (&i, &c) in instance.iter().zip(&semantic) {
                if i == 0 {
                    assert_eq!(c, 0, "nothing has no class");
                    continue;
                }
                let listed = labels
                    .instances
                    .iter()
                    .find(|l| l.id == i)
                    .unwrap_or_else(|| panic!("{world}: instance {i} is not in labels.json"));
                assert_eq!(c, listed.class, "{world}: semantic = the instance's class");
                assert!(labels.classes.iter().any(|l| l.id == c));
                instances_seen.insert(i);
                classes_seen.insert(c);
            }
        }
        assert!(
            instances_seen.len() >= 3,
            "{world}: a turn should show several instances: {instances_seen:?}"
        );
        for class in &labels.classes {
            assert!(
                GENERATED_KINDS.contains(&class.name.as_str()),
                "{world}: class {:?} is no kind the generator places",
                class.name
            );
        }
        let names: Vec<&str> = labels.classes.iter().map(|c| c.name.as_str()).collect();
        assert!(
            names.contains(&"wall") && names.contains(&"floor"),
            "{names:?}"
        );
        // The robot is never an instance.
        let world = splatloop::world::World::load(&repo_path(world), &SensorConfig::default())
            .expect("world");
        for instance in &labels.instances {
            for geom in &instance.geoms {
                assert!(!world.robot().owns_geom(geom.id), "{}", instance.name);
            }
        }
        let episode: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.join("episode.json")).expect("episode.json"),
        )
        .expect("json");
        let files: Vec<&str> = episode["files"]
            .as_array()
            .expect("manifest")
            .iter()
            .filter_map(|f| f.as_str())
            .collect();
        for file in [
            "labels.json",
            "instance.txt",
            "semantic.txt",
            "instance/000000.png",
            "semantic/000010.png",
        ] {
            assert!(files.contains(&file), "the manifest lists {file}");
        }
    }
}

#[test]
fn a_dataset_without_masks_has_none_and_reads_as_before() {
    let dir = tempfile::tempdir().expect("tempdir");
    let dataset = record_world(dir.path(), "worlds/room.xml", false);
    assert!(dataset.labels.is_none());
    assert!(!dir.path().join("instance").exists() && !dir.path().join("labels.json").exists());
    assert_eq!(dataset.frames.len(), 11);
    assert!(dataset.frames.iter().all(|f| f.masks.is_none()));
    assert!(dataset.load(3).expect("loads").instance.is_empty());
    assert_eq!(dataset.load_masks(3).expect("reads"), None);
}
