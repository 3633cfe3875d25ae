//! OBJ scenes: export then import gives the same depth (and colours where the look is a
//! plain colour) at 30 poses; imported colliders stop the robot at a wall and a box and let it
//! through a 1.1 m door; Y-up and Z-up copies of a scene import identically; each bad input
//! gives its error and leaves nothing behind.

use crate::support::repo_path;
use splatloop::camera::SensorConfig;
use splatloop::egl::EglContext;
use splatloop::evaluate::sample_test_poses;
use splatloop::robot::{Pose2, UnicycleCommand};
use splatloop::scene::export::export_world;
use splatloop::scene::import::{import_scene, ImportConfig};
use splatloop::scene::Up;
use splatloop::world::World;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

fn load(path: &Path) -> World {
    World::load(path, &SensorConfig::default()).expect("world loads")
}

fn import(
    scene: &Path,
    out: &Path,
    up: Up,
    spawn: Option<Pose2>,
) -> splatloop::Result<splatloop::scene::import::ImportSummary> {
    import_scene(&ImportConfig {
        scene: scene.to_path_buf(),
        up,
        scale: 1.0,
        floor: None,
        spawn,
        out: out.to_path_buf(),
        overwrite: false,
    })
}

#[test]
fn an_exported_then_imported_world_renders_the_same_depth_and_plain_colours() {
    let dir = tempfile::tempdir().expect("tempdir");
    let original = load(&repo_path("worlds/suite/apartment_03.xml"));
    let obj = dir.path().join("scene.obj");
    export_world(&original, &obj, false).expect("export");
    let imported_path = dir.path().join("imported.xml");
    import(&obj, &imported_path, Up::Y, Some(original.start())).expect("import");
    let mut imported = load(&imported_path);
    let mut original = original;
    let gl = EglContext::new().expect("EGL");
    let sensor = SensorConfig::default();
    let mut camera_a = original.make_camera(&sensor, 0, &gl).expect("camera");
    let mut camera_b = imported.make_camera(&sensor, 0, &gl).expect("camera");
    let poses = sample_test_poses(&original, [-15.0, -15.0], [15.0, 15.0], 30, 11);
    assert_eq!(poses.len(), 30);
    let (mut pixels, mut close) = (0usize, 0usize);
    let (mut plain, mut plain_error) = (0usize, 0.0f64);
    for pose in poses {
        original.set_start(pose);
        imported.set_start(pose);
        let a = camera_a.capture(original.data()).expect("capture");
        let b = camera_b.capture(imported.data()).expect("capture");
        let ids = camera_a.capture_geom_ids(original.data()).expect("ids");
        for (k, (da, db)) in a.depth.iter().zip(&b.depth).enumerate() {
            if *da > 0.0 || *db > 0.0 {
                pixels += 1;
                close += usize::from((da - db).abs() <= 0.005);
            }
            // Pixels of geoms with a plain colour (no texture) must keep it.
            let geom = ids[k];
            if geom >= 0 {
                let (_, material) = original.model().geom_appearance(geom as usize);
                let textured = material
                    .and_then(|m| original.model().material(m).texture)
                    .is_some();
                if !textured {
                    plain += 1;
                    plain_error += (0..3)
                        .map(|c| (f64::from(a.rgb[3 * k + c]) - f64::from(b.rgb[3 * k + c])).abs())
                        .sum::<f64>()
                        / 3.0;
                }
            }
        }
    }
    let share = close as f64 / pixels as f64;
    eprintln!("depth within 5 mm on {:.3}% of {pixels} pixels; {plain} plain-colour pixels, mean error {:.2}/255", 100.0 * share, plain_error / plain.max(1) as f64);
    assert!(
        share >= 0.99,
        "depth within 5 mm on only {:.2}% of pixels",
        100.0 * share
    );
    assert!(plain > 500, "only {plain} plain-colour pixels seen");
    // Measured: 0.00/255 (the same colours, lights and normals).
    assert!(
        plain_error / plain as f64 <= 2.0,
        "plain colours differ by {:.1}/255 on average",
        plain_error / plain as f64
    );
}

/// An axis-aligned box as 12 triangles.
fn cuboid(lo: [f64; 3], hi: [f64; 3]) -> Vec<[[f64; 3]; 3]> {
    let corner = |i: usize| {
        [
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ]
    };
    let faces = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    faces
        .iter()
        .flat_map(|f| {
            [
                [corner(f[0]), corner(f[1]), corner(f[2])],
                [corner(f[0]), corner(f[2]), corner(f[3])],
            ]
        })
        .collect()
}

/// A test scene, Z up: an 8 x 4 m room, a wall at x = 0 with a 1.1 m door (y 0.45..1.55),
/// and a 0.6 m box at (-1, -1).
fn test_scene() -> Vec<(&'static str, Vec<[[f64; 3]; 3]>)> {
    let (h, t) = (2.5, 0.05);
    let floor = vec![
        [[-4.0, -2.0, 0.0], [4.0, -2.0, 0.0], [4.0, 2.0, 0.0]],
        [[-4.0, -2.0, 0.0], [4.0, 2.0, 0.0], [-4.0, 2.0, 0.0]],
    ];
    let mut walls = Vec::new();
    walls.extend(cuboid(
        [-4.0 - 2.0 * t, -2.0 - 2.0 * t, 0.0],
        [4.0 + 2.0 * t, -2.0, h],
    ));
    walls.extend(cuboid(
        [-4.0 - 2.0 * t, 2.0, 0.0],
        [4.0 + 2.0 * t, 2.0 + 2.0 * t, h],
    ));
    walls.extend(cuboid([-4.0 - 2.0 * t, -2.0, 0.0], [-4.0, 2.0, h]));
    walls.extend(cuboid([4.0, -2.0, 0.0], [4.0 + 2.0 * t, 2.0, h]));
    walls.extend(cuboid([-t, -2.0, 0.0], [t, 0.45, h]));
    walls.extend(cuboid([-t, 1.55, 0.0], [t, 2.0, h]));
    vec![
        ("floor", floor),
        ("walls", walls),
        ("box", cuboid([-1.3, -1.3, 0.0], [-0.7, -0.7, 0.6])),
    ]
}

/// Writes `objects` as an OBJ in `up` convention with an MTL of plain colours.
fn write_scene(dir: &Path, objects: &[(&str, Vec<[[f64; 3]; 3]>)], up: Up) -> PathBuf {
    let mut obj = String::from("mtllib scene.mtl\n");
    let mut mtl = String::new();
    let mut count = 0;
    for (k, (name, triangles)) in objects.iter().enumerate() {
        let _ = writeln!(obj, "o {name}\nusemtl m{k}");
        let _ = writeln!(mtl, "newmtl m{k}\nKd 0.{k}5 0.5 0.5");
        for t in triangles {
            for p in t {
                let f = up.from_world(*p);
                let _ = writeln!(obj, "v {} {} {}", f[0], f[1], f[2]);
            }
            let _ = writeln!(obj, "f {} {} {}", count + 1, count + 2, count + 3);
            count += 3;
        }
    }
    std::fs::write(dir.join("scene.mtl"), mtl).expect("mtl");
    let path = dir.join("scene.obj");
    std::fs::write(&path, obj).expect("obj");
    path
}

/// Drives straight at 0.4 m/s from `start` for `seconds`; returns where the robot stopped.
fn drive(world: &mut World, start: Pose2, seconds: f64) -> Pose2 {
    world.set_start(start);
    let steps = (seconds / world.model().timestep()) as usize;
    for _ in 0..steps {
        world
            .step(UnicycleCommand { v: 0.4, w: 0.0 })
            .expect("step");
    }
    world.pose()
}

#[test]
fn imported_colliders_stop_the_robot_at_walls_and_boxes_and_let_it_through_a_door() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = write_scene(dir.path(), &test_scene(), Up::Z);
    let out = dir.path().join("world.xml");
    let summary = import(&scene, &out, Up::Z, None).expect("import");
    assert!(summary.colliders > 0 && summary.floor_height.abs() < 1e-9);
    let mut world = load(&out);
    // Through the door (its middle at y = 1.0): from the west room into the east one.
    let through = drive(
        &mut world,
        Pose2 {
            x: -2.5,
            y: 1.0,
            theta: 0.0,
        },
        12.0,
    );
    assert!(
        through.x > 1.5,
        "stopped at x = {:.2} before the door",
        through.x
    );
    // At the east wall (inner face x = 4): stopped in front of it (chassis 0.25 m ahead).
    let wall = drive(
        &mut world,
        Pose2 {
            x: 2.0,
            y: -1.0,
            theta: 0.0,
        },
        10.0,
    );
    assert!(
        wall.x > 3.5 && wall.x < 3.8,
        "at the wall: x = {:.2}",
        wall.x
    );
    // At the box (west face x = -1.3).
    let boxed = drive(
        &mut world,
        Pose2 {
            x: -3.0,
            y: -1.0,
            theta: 0.0,
        },
        10.0,
    );
    assert!(
        boxed.x > -1.85 && boxed.x < -1.5,
        "at the box: x = {:.2}",
        boxed.x
    );
    // Standing on the floor is not a collision.
    world.set_start(Pose2 {
        x: -2.5,
        y: 1.0,
        theta: 0.0,
    });
    assert_eq!(world.robot_collisions().count(), 0);
}

#[test]
fn y_up_and_z_up_copies_of_a_scene_import_to_the_same_world() {
    let (a, b) = (
        tempfile::tempdir().expect("tempdir"),
        tempfile::tempdir().expect("tempdir"),
    );
    let scene_z = write_scene(a.path(), &test_scene(), Up::Z);
    let scene_y = write_scene(b.path(), &test_scene(), Up::Y);
    import(&scene_z, &a.path().join("world.xml"), Up::Z, None).expect("z up");
    import(&scene_y, &b.path().join("world.xml"), Up::Y, None).expect("y up");
    let body = |dir: &Path| {
        let text = std::fs::read_to_string(dir.join("world.xml")).expect("world");
        // The first line names the source file; everything else must agree.
        text.lines().skip(1).collect::<Vec<_>>().join("\n")
    };
    assert!(body(a.path()) == body(b.path()), "the two worlds differ");
    for k in 0..3 {
        let mesh = |dir: &Path| {
            std::fs::read(dir.join(format!("world_assets/mesh_{k}.obj"))).expect("mesh")
        };
        assert!(mesh(a.path()) == mesh(b.path()), "mesh {k} differs");
    }
}

/// The files in `dir`, for checking that a failed import left nothing.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn bad_scenes_give_clear_errors_and_leave_nothing_behind() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let out = d.join("world.xml");
    let expect_error = |scene: &Path, up: Up, scale: f64, needle: &str| {
        let before = listing(d);
        let config = ImportConfig {
            scene: scene.to_path_buf(),
            up,
            scale,
            floor: None,
            spawn: None,
            out: out.clone(),
            overwrite: false,
        };
        let error = import_scene(&config).expect_err(needle).to_string();
        assert!(error.contains(needle), "{error:?} should say {needle:?}");
        assert_eq!(listing(d), before, "{needle}: files left behind");
    };
    expect_error(&d.join("missing.obj"), Up::Z, 1.0, "not found");
    std::fs::write(d.join("bad.obj"), "v 0 0 0\nv 1 0 0\nv 1 1\nf 1 2 3\n").expect("write");
    expect_error(&d.join("bad.obj"), Up::Z, 1.0, "line 3");
    std::fs::write(d.join("face.obj"), "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 7\n").expect("write");
    expect_error(&d.join("face.obj"), Up::Z, 1.0, "line 4");
    std::fs::write(
        d.join("nomtl.obj"),
        "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n",
    )
    .expect("write");
    expect_error(&d.join("nomtl.obj"), Up::Z, 1.0, "gone.mtl");
    std::fs::write(d.join("tex.mtl"), "newmtl a\nKd 1 1 1\nmap_Kd wood.png\n").expect("write");
    std::fs::write(
        d.join("tex.obj"),
        "mtllib tex.mtl\nv 0 0 0\nv 5 0 0\nv 5 5 0\nusemtl a\nf 1 2 3\n",
    )
    .expect("write");
    expect_error(&d.join("tex.obj"), Up::Z, 1.0, "wood.png");
    std::fs::write(d.join("badmtl.mtl"), "newmtl a\nKd 1 one 1\n").expect("write");
    std::fs::write(
        d.join("badmtl.obj"),
        "mtllib badmtl.mtl\nv 0 0 0\nv 5 0 0\nv 5 5 0\nf 1 2 3\n",
    )
    .expect("write");
    expect_error(&d.join("badmtl.obj"), Up::Z, 1.0, "line 2");
    // Walls only, as upright quads: nothing horizontal to stand on.
    let quad =
        |a: [f64; 3], b: [f64; 3]| vec![[a, [b[0], b[1], a[2]], b], [a, b, [a[0], a[1], b[2]]]];
    let walls = vec![(
        "walls",
        [
            quad([-4.0, -2.0, 0.0], [4.0, -2.0, 2.5]),
            quad([-4.0, 2.0, 0.0], [4.0, 2.0, 2.5]),
            quad([-4.0, -2.0, 0.0], [-4.0, 2.0, 2.5]),
        ]
        .concat(),
    )];
    let scene = write_scene(d, &walls, Up::Z);
    expect_error(&scene, Up::Z, 1.0, "no floor");
    // The room in millimetres, and shrunk to 0.8 m.
    let scene = write_scene(d, &test_scene(), Up::Z);
    expect_error(&scene, Up::Z, 1000.0, "--scale 0.001");
    expect_error(&scene, Up::Z, 0.1, "--scale");
    // A 0.6 m wide closet: the robot fits nowhere.
    let closet = vec![
        ("floor", cuboid([-0.3, -0.8, -0.1], [0.3, 0.8, 0.0])),
        (
            "walls",
            [
                cuboid([-0.4, -0.9, 0.0], [-0.3, 0.9, 2.0]),
                cuboid([0.3, -0.9, 0.0], [0.4, 0.9, 2.0]),
                cuboid([-0.3, -0.9, 0.0], [0.3, -0.8, 2.0]),
                cuboid([-0.3, 0.8, 0.0], [0.3, 0.9, 2.0]),
            ]
            .concat(),
        ),
    ];
    let scene = write_scene(d, &closet, Up::Z);
    expect_error(&scene, Up::Z, 1.0, "no free pose");
}
