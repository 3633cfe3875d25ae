//! The RGB-D sensor against MuJoCo's own geometry (mj_ray): depth convention, intrinsics,
//! optical frame, range cut-off and noise.

use crate::support::{repo_path, room};
use splatloop::camera::{RgbdCamera, RgbdFrame, SensorConfig};
use splatloop::egl::EglContext;
use splatloop::mujoco::ObjKind;
use splatloop::robot::Pose2;
use splatloop::world::World;

/// Geom groups the sensor sees (0-2); the robot lives in group 3.
const VISIBLE_GROUPS: u8 = 0b111;

/// Three poses that look at walls, furniture and the floor from 1-5 m. The first is near but
/// deliberately not exactly -pi/2 (the exact half turn has its own regression test).
#[allow(clippy::approx_constant)]
const POSES: [Pose2; 3] = [
    Pose2 {
        x: -1.5,
        y: 0.0,
        theta: -1.5708,
    },
    Pose2 {
        x: -1.0,
        y: -1.2,
        theta: 0.6,
    },
    Pose2 {
        x: 1.0,
        y: 0.8,
        theta: 2.4,
    },
];

struct Probe {
    u: usize,
    v: usize,
    ray_depth: Option<f64>,
    ray_geom: Option<usize>,
}

/// Casts mj_ray through pixel (u, v) using only K and world_from_camera; the direction has
/// unit optical z, so the hit distance is planar depth.
fn cast(world: &World, frame: &RgbdFrame, u: f64, v: f64) -> Option<(f64, usize)> {
    let camera = &frame.camera;
    let origin = camera.world_from_camera.translation.vector.into();
    let direction = camera.world_from_camera.rotation * camera.intrinsics.ray(u, v);
    world
        .data()
        .ray(
            &origin,
            &direction,
            VISIBLE_GROUPS,
            Some(world.robot().body),
        )
        .map(|hit| (hit.distance, hit.geom))
}

/// Pixels on a grid whose ray and its 4 neighbours' rays hit the same geom at nearly the same
/// depth: away from silhouettes, where one pixel of rasterisation difference is no error.
fn interior_probes(world: &World, frame: &RgbdFrame, step: usize) -> Vec<Probe> {
    let k = frame.camera.intrinsics;
    let mut probes = Vec::new();
    for v in (step / 2..k.height as usize - 1).step_by(step) {
        for u in (step / 2..k.width as usize - 1).step_by(step) {
            let centre = cast(world, frame, u as f64, v as f64);
            let stable = [(-1.0, 0.0), (1.0, 0.0), (0.0, -1.0), (0.0, 1.0)]
                .iter()
                .all(
                    |(du, dv)| match (centre, cast(world, frame, u as f64 + du, v as f64 + dv)) {
                        (Some((d0, g0)), Some((d1, g1))) => g0 == g1 && (d0 - d1).abs() < 0.05 * d0,
                        (None, None) => true,
                        _ => false,
                    },
                );
            if stable {
                probes.push(Probe {
                    u,
                    v,
                    ray_depth: centre.map(|c| c.0),
                    ray_geom: centre.map(|c| c.1),
                });
            }
        }
    }
    probes
}

fn capture_at(world: &mut World, camera: &mut RgbdCamera, pose: Pose2) -> RgbdFrame {
    world.set_start(pose);
    camera.capture(world.data()).expect("capture")
}

#[test]
fn depth_matches_mj_ray_within_5mm() {
    let gl = EglContext::new().expect("EGL");
    let mut world = room();
    let mut camera = world
        .make_camera(&SensorConfig::default(), 0, &gl)
        .expect("camera");
    let mut compared = 0;
    for pose in POSES {
        let frame = capture_at(&mut world, &mut camera, pose);
        let w = frame.camera.intrinsics.width as usize;
        for probe in interior_probes(&world, &frame, 12) {
            let Some(expected) = probe.ray_depth.filter(|d| (1.0..=5.0).contains(d)) else {
                continue;
            };
            let rendered = f64::from(frame.depth[probe.v * w + probe.u]);
            let geom = probe.ray_geom.expect("a depth comes with a geom");
            // Curved primitives are drawn as polygons: allow their chord sagitta (1.5 cm for
            // MuJoCo's default slices on these sizes); flat faces must agree to 5 mm.
            let flat = world.model().geom_type(geom).is_flat_faced();
            let tolerance = if flat { 0.005 } else { 0.015 };
            assert!(
                (rendered - expected).abs() <= tolerance,
                "pose {pose:?} pixel ({}, {}) on geom {:?}: rendered {rendered:.4} m, mj_ray {expected:.4} m",
                probe.u,
                probe.v,
                world.model().name(ObjKind::Geom, geom)
            );
            if !flat {
                continue;
            }
            compared += 1;
        }
    }
    assert!(
        compared >= 50,
        "only {compared} flat-faced pixels between 1 and 5 m were compared"
    );
}

#[test]
fn each_pixel_ray_hits_the_geom_the_pixel_shows() {
    let gl = EglContext::new().expect("EGL");
    let mut world = room();
    let mut camera = world
        .make_camera(&SensorConfig::default(), 0, &gl)
        .expect("camera");
    let mut compared = 0;
    let mut geoms_seen = std::collections::BTreeSet::new();
    for pose in POSES {
        let frame = capture_at(&mut world, &mut camera, pose);
        let ids = camera.capture_geom_ids(world.data()).expect("segmentation");
        let w = frame.camera.intrinsics.width as usize;
        for probe in interior_probes(&world, &frame, 10) {
            let shown = ids[probe.v * w + probe.u];
            let hit = probe.ray_geom.map_or(-1, |g| g as i32);
            assert_eq!(
                shown, hit,
                "pose {pose:?} pixel ({}, {}) shows geom {shown} but its ray hits {hit}",
                probe.u, probe.v
            );
            geoms_seen.insert(shown);
            compared += 1;
        }
    }
    assert!(compared >= 50, "only {compared} pixels compared");
    assert!(
        geoms_seen.len() >= 4,
        "the poses should show several geoms: {geoms_seen:?}"
    );
}

#[test]
fn depth_beyond_max_range_reads_zero() {
    let gl = EglContext::new().expect("EGL");
    let sensor = SensorConfig {
        max_range: 2.0,
        ..SensorConfig::default()
    };
    let mut world = World::load(&repo_path("worlds/room.xml"), &sensor).expect("room");
    let mut camera = world.make_camera(&sensor, 0, &gl).expect("camera");
    let frame = capture_at(&mut world, &mut camera, POSES[1]);
    let w = frame.camera.intrinsics.width as usize;
    let (mut far, mut near) = (0, 0);
    for probe in interior_probes(&world, &frame, 8) {
        let rendered = frame.depth[probe.v * w + probe.u];
        match probe.ray_depth {
            Some(d) if d > 2.02 => {
                assert_eq!(
                    rendered, 0.0,
                    "pixel at {d:.3} m beyond a 2 m range reads {rendered}"
                );
                far += 1;
            }
            Some(d) if d < 1.98 => {
                assert!((f64::from(rendered) - d).abs() < 0.015, "{rendered} vs {d}");
                near += 1;
            }
            _ => {}
        }
    }
    assert!(
        far >= 20 && near >= 20,
        "{far} far and {near} near pixels checked"
    );
}

#[test]
fn depth_noise_is_seeded_and_has_the_requested_spread() {
    let gl = EglContext::new().expect("EGL");
    let mut world = room();
    let exact = world
        .make_camera(&SensorConfig::default(), 0, &gl)
        .and_then(|mut c| c.capture(world.data()))
        .expect("exact frame");
    let noisy_config = SensorConfig {
        depth_noise_sigma: Some(0.01),
        ..SensorConfig::default()
    };
    let capture = |seed, world: &World| {
        world
            .make_camera(&noisy_config, seed, &gl)
            .and_then(|mut c| c.capture(world.data()))
            .expect("noisy frame")
    };
    let (a, b, c) = (capture(7, &world), capture(7, &world), capture(8, &world));
    assert_eq!(a.depth, b.depth, "same seed, same noise");
    assert_ne!(a.depth, c.depth, "another seed, other noise");
    let residuals: Vec<f64> = exact
        .depth
        .iter()
        .zip(&a.depth)
        .filter(|(e, _)| **e > 0.5 && **e < 4.5)
        .map(|(e, n)| f64::from(*n) - f64::from(*e))
        .collect();
    let n = residuals.len() as f64;
    let mean = residuals.iter().sum::<f64>() / n;
    let sigma = (residuals.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n).sqrt();
    assert!(n > 10_000.0, "{n} valid pixels");
    assert!(mean.abs() < 1e-3, "noise mean {mean}");
    assert!((sigma - 0.01).abs() < 1e-3, "noise sigma {sigma}");
    world.reset();
}

/// Regression: a camera facing exactly -y (a half turn from the identity) once came out with
/// the identity rotation.
#[test]
fn the_optical_frame_is_right_for_a_half_turn() {
    let mut world = room();
    world.set_start(Pose2 {
        x: -1.5,
        y: 0.0,
        theta: -std::f64::consts::FRAC_PI_2,
    });
    let gl = EglContext::new().expect("EGL");
    let camera = world
        .make_camera(&SensorConfig::default(), 0, &gl)
        .expect("camera");
    let rotation = camera.world_from_camera(world.data()).rotation;
    let forward = rotation * nalgebra::Vector3::z();
    let down = rotation * nalgebra::Vector3::y();
    let right = rotation * nalgebra::Vector3::x();
    assert!(
        (forward - nalgebra::Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-6,
        "{forward}"
    );
    assert!(
        (down - nalgebra::Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-6,
        "{down}"
    );
    assert!(
        (right - nalgebra::Vector3::new(-1.0, 0.0, 0.0)).norm() < 1e-6,
        "{right}"
    );
}

/// Pixels on a grid (every 5th) with a depth return and one instance in their 3x3
/// neighbourhood (silhouette edges excluded): how many there are, how many show an instance
/// whose geoms hold the geom MuJoCo's own mj_ray hits through the pixel, and the instances
/// seen.
fn masks_against_mj_ray(
    world: &mut World,
    camera: &mut RgbdCamera,
    poses: &[Pose2],
) -> (usize, usize, std::collections::BTreeSet<u16>) {
    let labels = camera.labels().expect("masks are on by default").clone();
    let (mut compared, mut agreed) = (0, 0);
    let mut seen = std::collections::BTreeSet::new();
    for &pose in poses {
        let frame = capture_at(world, camera, pose);
        let k = frame.camera.intrinsics;
        let (w, h) = (k.width as usize, k.height as usize);
        assert_eq!(frame.instance.len(), w * h, "a mask with every frame");
        for v in (1..h - 1).step_by(5) {
            for u in (1..w - 1).step_by(5) {
                let id = frame.instance[v * w + u];
                let interior = (v - 1..=v + 1)
                    .all(|y| (u - 1..=u + 1).all(|x| frame.instance[y * w + x] == id));
                if frame.depth[v * w + u] <= 0.0 || !interior {
                    continue;
                }
                compared += 1;
                let hit = cast(world, &frame, u as f64, v as f64).map(|(_, geom)| geom);
                let holds = usize::from(id)
                    .checked_sub(1)
                    .and_then(|i| labels.instances.get(i))
                    .is_some_and(|instance| instance.geoms.iter().any(|g| Some(g.id) == hit));
                if holds {
                    agreed += 1;
                    seen.insert(id);
                }
            }
        }
    }
    (compared, agreed, seen)
}

#[test]
fn each_masked_pixel_shows_the_instance_mj_ray_hits_in_generated_and_imported_worlds() {
    let dir = tempfile::tempdir().expect("tempdir");
    // An imported OBJ scene: a generated world exported and imported again (its objects
    // become bodies).
    let original = World::load(
        &repo_path("worlds/suite/apartment_03.xml"),
        &SensorConfig::default(),
    )
    .expect("world");
    let obj = dir.path().join("scene.obj");
    splatloop::scene::export::export_world(&original, &obj, false).expect("export");
    let imported = dir.path().join("imported.xml");
    splatloop::scene::import::import_scene(&splatloop::scene::import::ImportConfig {
        scene: obj,
        up: splatloop::scene::Up::Y,
        scale: 1.0,
        floor: None,
        spawn: Some(original.start()),
        out: imported.clone(),
        overwrite: false,
    })
    .expect("import");
    let gl = EglContext::new().expect("EGL");
    for path in [
        repo_path("worlds/suite/apartment_01.xml"),
        repo_path("worlds/suite/office_01.xml"),
        repo_path("worlds/suite/warehouse_01.xml"),
        imported,
    ] {
        let mut world = World::load(&path, &SensorConfig::default()).expect("world");
        let mut camera = world
            .make_camera(&SensorConfig::default(), 0, &gl)
            .expect("camera");
        // Starts the robot can reach, with room around it (a pose under a table could put
        // the camera inside a leg, which the near plane clips and mj_ray hits from inside).
        let poses: Vec<Pose2> = (1..=4)
            .map(|seed| {
                splatloop::spawn::place_robot(&mut world, splatloop::spawn::Spawn::Random, seed)
                    .expect("a random start")
            })
            .collect();
        let (compared, agreed, seen) = masks_against_mj_ray(&mut world, &mut camera, &poses);
        assert!(
            compared >= 1000,
            "{}: only {compared} pixels compared",
            path.display()
        );
        assert!(
            agreed as f64 >= 0.995 * compared as f64,
            "{}: {agreed} of {compared} masked pixels show the instance mj_ray hits",
            path.display()
        );
        assert!(
            seen.len() >= 4,
            "{}: the views should show several instances: {seen:?}",
            path.display()
        );
    }
}
