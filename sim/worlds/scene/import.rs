//! `splatloop world import`: a textured OBJ + MTL scene as a world. The scene is turned to Z
//! up and scaled; its floor (the largest upward surface near the bottom) is moved to z = 0.
//! Each (object, material) becomes a visual mesh with its diffuse texture or colour; the
//! colliders are the scene voxelised at 5 cm from just above the floor to `COLLIDER_TOP`,
//! merged into boxes, on an invisible ground plane (so wheels on the floor are not a
//! collision). Everything is written under temporary names and takes its place only when the
//! world compiles and its spawn is free: a failure leaves nothing behind.

use super::voxels::{Cuboid, Voxels};
use super::Up;
use crate::camera::SensorConfig;
use crate::error::{Result, SimError};
use crate::floorplan::FloorPlan;
use crate::robot::Pose2;
use crate::spawn::{place_robot, Spawn};
use crate::world::World;
use crate::worldgen::mjcf::{n, v3};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Voxel side of the colliders, metres.
pub const VOXEL: f64 = 0.05;

/// Colliders start this far above the floor (below is wheel contact), metres.
const COLLIDER_BOTTOM: f64 = 0.02;

/// Colliders reach this high above the floor: above the robot (0.4 m) with room to spare.
pub const COLLIDER_TOP: f64 = 1.0;

/// Enclosed empty space up to this area, in a voxel layer, is a closed object's inside and
/// is filled; larger enclosed space is a sealed room and stays empty, m2.
const MAX_HOLLOW_AREA: f64 = 4.0;

/// Least upward-facing area a floor has, m2.
const MIN_FLOOR_AREA: f64 = 1.0;

/// What to import.
#[derive(Debug, Clone)]
pub struct ImportConfig {
    /// The OBJ file (its MTL and textures beside it, as it names them).
    pub scene: PathBuf,
    /// Which axis of the file points up.
    pub up: Up,
    /// Metres per file unit.
    pub scale: f64,
    /// The floor's height in the scene (after turning and scaling), metres; else found.
    pub floor: Option<f64>,
    /// The start pose; else the free pose with the most room near the scene's centre.
    pub spawn: Option<Pose2>,
    /// The MJCF to write; meshes and textures go to `<stem>_assets/` beside it.
    pub out: PathBuf,
    /// Replace earlier output.
    pub overwrite: bool,
}

/// What an import made.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ImportSummary {
    /// The world file.
    pub out: PathBuf,
    /// World bounds after turning, scaling and moving the floor to 0: (min, max) corners.
    pub bounds: ([f64; 3], [f64; 3]),
    /// Triangles read.
    pub triangles: usize,
    /// Visual meshes written (one per object and material).
    pub meshes: usize,
    /// Materials in the MTL.
    pub materials: usize,
    /// Textures copied.
    pub textures: usize,
    /// Collider boxes.
    pub colliders: usize,
    /// Solid voxels they cover.
    pub voxels: usize,
    /// Height of the floor in the file's frame, scaled, before it was moved to 0, metres.
    pub floor_height: f64,
    /// The start pose.
    pub spawn: Pose2,
}

fn bad_scene(path: &Path, detail: String) -> SimError {
    SimError::BadScene {
        path: path.to_path_buf(),
        detail,
    }
}

/// Imports a scene; see the module documentation.
pub fn import_scene(config: &ImportConfig) -> Result<ImportSummary> {
    let (scene_dir, models, materials, inputs) = read_scene(config)?;
    let (mut pieces, mut lo, mut hi, triangles) = world_triangles(config, &models)?;
    let floor = match config.floor {
        Some(z) if z.is_finite() => z,
        Some(z) => return Err(SimError::InvalidArgument { what: "floor", detail: format!("{z}; give the floor's height in metres") }),
        None => find_floor(&pieces, lo[2], hi[2]).ok_or_else(|| bad_scene(&config.scene, format!(
        "no floor: no horizontal surface of {MIN_FLOOR_AREA} m2 or more in the lowest third of the scene; check --up ({} now) or give its height with --floor", match config.up { Up::Y => "y", Up::Z => "z" }
    )))?,
    };
    for piece in &mut pieces {
        for t in &mut piece.triangles {
            for p in t.iter_mut() {
                p[2] -= floor;
            }
        }
    }
    lo[2] -= floor;
    hi[2] -= floor;

    let (voxels, colliders) = voxelise(&pieces, lo, hi);
    let spawn = write_world(
        config,
        &pieces,
        &materials,
        &scene_dir,
        &colliders,
        (lo, hi),
        &inputs,
    )?;
    Ok(ImportSummary {
        out: config.out.clone(),
        bounds: (lo, hi),
        triangles,
        meshes: pieces.len(),
        materials: materials.len(),
        textures: materials
            .iter()
            .filter(|m| m.diffuse_texture.is_some())
            .count(),
        colliders: colliders.len(),
        voxels: voxels.count(),
        floor_height: floor,
        spawn,
    })
}

/// What `read_scene` gives: the scene's folder, its models, its materials, and every file it
/// read (the OBJ, its MTLs, their textures), which no output may replace.
type SceneFiles = (PathBuf, Vec<tobj::Model>, Vec<tobj::Material>, Vec<PathBuf>);

/// Checks the arguments and reads the OBJ, its MTL and its textures' names.
fn read_scene(config: &ImportConfig) -> Result<SceneFiles> {
    if !(config.scale.is_finite() && config.scale > 0.0) {
        return Err(SimError::InvalidArgument {
            what: "scale",
            detail: format!(
                "{}; give a positive number of metres per unit",
                config.scale
            ),
        });
    }
    if !config.scene.is_file() {
        return Err(SimError::MissingFile {
            what: "OBJ scene",
            path: config.scene.clone(),
        });
    }
    crate::dataset::refuse_overwrite(&config.out, config.overwrite, &[&config.scene])?;
    let text = std::fs::read_to_string(&config.scene)
        .map_err(|e| SimError::io("cannot read", &config.scene, e))?;
    check_obj_lines(&config.scene, &text)?;
    let scene_dir = config
        .scene
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, materials) = tobj::load_obj(&config.scene, &options)
        .map_err(|e| bad_scene(&config.scene, format!("{e}")))?;
    let materials = match materials {
        Ok(m) => m,
        Err(e) => return Err(material_error(&config.scene, &scene_dir, &text, e)),
    };
    // Textures must exist, and be PNG: MuJoCo 2.2 reads no other image format.
    for m in &materials {
        if let Some(file) = &m.diffuse_texture {
            let path = scene_dir.join(file.trim());
            if !path.is_file() {
                return Err(SimError::MissingFile {
                    what: "texture (map_Kd of the MTL)",
                    path,
                });
            }
            if !path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("png"))
            {
                return Err(bad_scene(&path, format!("material {}'s texture is not a PNG; MuJoCo reads PNG textures only, so convert it", m.name)));
            }
        }
    }
    let mut inputs = vec![config.scene.clone()];
    inputs.extend(text.lines().filter_map(|line| {
        let name = line.trim().strip_prefix("mtllib")?.trim();
        (!name.is_empty()).then(|| scene_dir.join(name))
    }));
    inputs.extend(
        materials
            .iter()
            .filter_map(|m| m.diffuse_texture.as_ref())
            .map(|file| scene_dir.join(file.trim())),
    );
    let borrowed: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    crate::dataset::refuse_overwrite(&config.out, config.overwrite, &borrowed)?;
    Ok((scene_dir, models, materials, inputs))
}

/// The models' triangles in the world frame (Z up, metres), degenerate ones dropped, with
/// the bounds and the count of every triangle read; a scene of no or absurd size refused.
#[allow(clippy::type_complexity)]
fn world_triangles(
    config: &ImportConfig,
    models: &[tobj::Model],
) -> Result<(Vec<Piece>, [f64; 3], [f64; 3], usize)> {
    let mut pieces: Vec<Piece> = Vec::new();
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut triangles = 0usize;
    for model in models {
        let mesh = &model.mesh;
        let point = |i: u32| {
            let i = i as usize;
            let p = [0, 1, 2].map(|a| f64::from(mesh.positions[3 * i + a]) * config.scale);
            config.up.to_world(p)
        };
        let uv = |i: u32| {
            let i = i as usize;
            (mesh.texcoords.len() >= 2 * (i + 1)).then(|| {
                [
                    f64::from(mesh.texcoords[2 * i]),
                    f64::from(mesh.texcoords[2 * i + 1]),
                ]
            })
        };
        let mut piece = Piece {
            material: mesh.material_id,
            name: model.name.clone(),
            triangles: Vec::new(),
            uvs: Vec::new(),
        };
        for t in mesh.indices.chunks_exact(3) {
            let tri = [point(t[0]), point(t[1]), point(t[2])];
            for p in &tri {
                for a in 0..3 {
                    lo[a] = lo[a].min(p[a]);
                    hi[a] = hi[a].max(p[a]);
                }
            }
            triangles += 1;
            if area(&tri) < 1e-12 {
                continue;
            }
            piece.triangles.push(tri);
            piece.uvs.push([uv(t[0]), uv(t[1]), uv(t[2])]);
        }
        if !piece.triangles.is_empty() {
            pieces.push(piece);
        }
    }
    if pieces.is_empty() {
        return Err(bad_scene(
            &config.scene,
            "no triangles (faces) in the file".into(),
        ));
    }
    let extent = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
    if extent > 1000.0 {
        return Err(bad_scene(&config.scene, format!("the scene is {extent:.0} m across at --scale {}: units look like millimetres or centimetres; try --scale 0.001 or --scale 0.01", config.scale)));
    }
    if extent < 1.0 {
        return Err(bad_scene(&config.scene, format!("the scene is {extent:.2} m across at --scale {}: too small for the robot; if its units are not metres, give --scale (for example 10 or 100)", config.scale)));
    }
    Ok((pieces, lo, hi, triangles))
}

/// Colliders: the scene voxelised in the band the robot moves through, enclosed space
/// filled, merged into boxes.
fn voxelise(pieces: &[Piece], lo: [f64; 3], hi: [f64; 3]) -> (Voxels, Vec<Cuboid>) {
    let top = COLLIDER_TOP.min(hi[2]);
    let origin = [lo[0] - VOXEL, lo[1] - VOXEL, COLLIDER_BOTTOM];
    let dims = [
        ((hi[0] - lo[0]) / VOXEL).ceil() as usize + 2,
        ((hi[1] - lo[1]) / VOXEL).ceil() as usize + 2,
        (((top - COLLIDER_BOTTOM) / VOXEL).ceil() as usize).max(1),
    ];
    let mut voxels = Voxels::new(origin, VOXEL, dims);
    for piece in pieces {
        for t in &piece.triangles {
            voxels.add_triangle(*t);
        }
    }
    voxels.fill_enclosed(MAX_HOLLOW_AREA);
    let colliders = voxels.merge();

    (voxels, colliders)
}

/// Writes the assets into a staging folder and the world under a temporary name, finds and
/// checks the spawn, then moves both into place; nothing is left behind on failure.
fn write_world(
    config: &ImportConfig,
    pieces: &[Piece],
    materials: &[tobj::Material],
    scene_dir: &Path,
    colliders: &[Cuboid],
    (lo, hi): ([f64; 3], [f64; 3]),
    inputs: &[PathBuf],
) -> Result<Pose2> {
    let stem = config
        .out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    let folder = config
        .out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
    std::fs::create_dir_all(&folder).map_err(|e| SimError::io("cannot create", &folder, e))?;
    let assets_name = format!("{stem}_assets");
    let assets = folder.join(&assets_name);
    let borrowed: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    crate::dataset::refuse_overwrite(&assets, config.overwrite, &borrowed)?;
    let staging_name = format!(".{stem}_assets.partial");
    let staging = folder.join(&staging_name);
    let candidate = folder.join(format!(".{stem}.candidate.xml"));
    let clean = || {
        let _ = std::fs::remove_dir_all(&staging);
        let _ = std::fs::remove_file(&candidate);
    };
    clean();
    let result = (|| {
        std::fs::create_dir_all(&staging)
            .map_err(|e| SimError::io("cannot create", &staging, e))?;
        let assets_xml = write_assets(pieces, materials, scene_dir, &staging)?;
        let robot = crate::worldgen::asset_paths(&folder)?.robot;
        let world_text = |meshdir: &str, spawn: Option<Pose2>| {
            mjcf(
                meshdir,
                &robot,
                &assets_xml,
                colliders,
                spawn,
                &config.scene,
            )
        };
        std::fs::write(&candidate, world_text(&staging_name, None))
            .map_err(|e| SimError::io("cannot write", &candidate, e))?;
        let mut world = World::load(&candidate, &SensorConfig::default())?;
        let spawn = match config.spawn {
            Some(p) => p,
            None => roomiest_pose(&world, [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])])?,
        };
        let spawn = place_robot(&mut world, Spawn::Pose(spawn), 0)?;
        if config.spawn.is_some() {
            refuse_bad_spawn(&mut world, spawn)?;
        }
        std::fs::write(&candidate, world_text(&assets_name, Some(spawn)))
            .map_err(|e| SimError::io("cannot write", &candidate, e))?;
        if assets.exists() {
            std::fs::remove_dir_all(&assets)
                .map_err(|e| SimError::io("cannot replace", &assets, e))?;
        }
        std::fs::rename(&staging, &assets).map_err(|e| SimError::io("cannot write", &assets, e))?;
        std::fs::rename(&candidate, &config.out)
            .map_err(|e| SimError::io("cannot write", &config.out, e))?;
        Ok(spawn)
    })();
    if result.is_err() {
        clean();
    }
    result
}

/// Refuses a spawn given with `--spawn` that `world check` would reject (off the scene, no
/// floor under it, no room, or the robot able to drive off the edge): the world written must
/// pass the check that users run on it.
fn refuse_bad_spawn(world: &mut World, spawn: Pose2) -> Result<()> {
    world.set_start(spawn);
    let (report, _) = crate::world_check::check_world(world)?;
    let about_spawn: Vec<&String> = report
        .problems
        .iter()
        .filter(|p| {
            p.starts_with("the spawn")
                || p.starts_with("the world is not closed")
                || p.starts_with("no floor")
        })
        .collect();
    if about_spawn.is_empty() {
        return Ok(());
    }
    Err(SimError::InvalidArgument {
        what: "spawn",
        detail: format!(
            "({:.2}, {:.2}): {}; give a pose inside the scene on its floor, or leave --spawn out to let the import choose the roomiest one",
            spawn.x,
            spawn.y,
            about_spawn.iter().map(|p| p.as_str()).collect::<Vec<_>>().join("; ")
        ),
    })
}

/// The triangles of one object in one material.
struct Piece {
    material: Option<usize>,
    name: String,
    triangles: Vec<[[f64; 3]; 3]>,
    uvs: Vec<[Option<[f64; 2]>; 3]>,
}

/// A triangle's normal, not normalised: its length is twice the triangle's area.
fn normal(t: &[[f64; 3]; 3]) -> [f64; 3] {
    let a = [0, 1, 2].map(|k| t[1][k] - t[0][k]);
    let b = [0, 1, 2].map(|k| t[2][k] - t[0][k]);
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn area(t: &[[f64; 3]; 3]) -> f64 {
    let c = normal(t);
    0.5 * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt()
}

/// The floor's height: among the 2 cm height bins in the lowest third of the scene, the one
/// holding the most area of horizontal triangles (either winding), area-weighted.
fn find_floor(pieces: &[Piece], bottom: f64, top: f64) -> Option<f64> {
    let bin = 0.02;
    let limit = bottom + (top - bottom) / 3.0;
    let mut bins: std::collections::BTreeMap<i64, (f64, f64)> = std::collections::BTreeMap::new();
    for t in pieces.iter().flat_map(|p| &p.triangles) {
        let nz = normal(t)[2];
        let size = area(t);
        let z = (t[0][2] + t[1][2] + t[2][2]) / 3.0;
        if size > 0.0 && (0.5 * nz.abs() / size) > 0.95 && z <= limit {
            let entry = bins.entry((z / bin).floor() as i64).or_insert((0.0, 0.0));
            entry.0 += size;
            entry.1 += size * z;
        }
    }
    let (_, (a, weighted)) = bins.into_iter().max_by(|x, y| x.1 .0.total_cmp(&y.1 .0))?;
    (a >= MIN_FLOOR_AREA).then(|| weighted / a)
}

/// Writes one OBJ per piece and the PNG textures into `dir`; returns the MJCF asset and geom
/// lines.
fn write_assets(
    pieces: &[Piece],
    materials: &[tobj::Material],
    scene_dir: &Path,
    dir: &Path,
) -> Result<(String, String)> {
    let (mut assets, mut geoms) = (String::new(), String::new());
    let mut copied: Vec<usize> = Vec::new();
    let mut objects = 0usize;
    for (m, material) in materials.iter().enumerate() {
        let kd = material.diffuse.unwrap_or([0.8, 0.8, 0.8]);
        if let Some(file) = &material.diffuse_texture {
            let target = dir.join(format!("texture_{m}.png"));
            let source = scene_dir.join(file.trim());
            std::fs::copy(&source, &target).map_err(|e| SimError::io("cannot copy", &source, e))?;
            copied.push(m);
            let _ = writeln!(
                assets,
                "    <texture name=\"texture_{m}\" type=\"2d\" file=\"texture_{m}.png\"/>"
            );
            let _ = writeln!(
                assets,
                "    <material name=\"material_{m}\" texture=\"texture_{m}\"/>"
            );
        } else {
            let _ = writeln!(
                assets,
                "    <material name=\"material_{m}\" rgba=\"{} 1\"/>",
                v3(f64::from(kd[0]), f64::from(kd[1]), f64::from(kd[2]))
            );
        }
    }
    for (k, piece) in pieces.iter().enumerate() {
        let textured = piece.material.is_some_and(|m| copied.contains(&m))
            && piece.uvs.iter().all(|t| t.iter().all(Option::is_some));
        let mut obj = String::new();
        let mut triangles = piece.triangles.clone();
        let mut uvs = piece.uvs.clone();
        if let Some(sliver) = flat_mesh_sliver(&triangles) {
            triangles.push(sliver);
            uvs.push([Some([0.0, 0.0]); 3]);
        }
        for t in &triangles {
            for p in t {
                let _ = writeln!(obj, "v {:.6} {:.6} {:.6}", p[0], p[1], p[2]);
            }
        }
        if textured {
            for t in &uvs {
                for uv in t.iter().flatten() {
                    let _ = writeln!(obj, "vt {:.6} {:.6}", uv[0], uv[1]);
                }
            }
        }
        for f in 0..triangles.len() {
            let [a, b, c] = [3 * f + 1, 3 * f + 2, 3 * f + 3];
            if textured {
                let _ = writeln!(obj, "f {a}/{a} {b}/{b} {c}/{c}");
            } else {
                let _ = writeln!(obj, "f {a} {b} {c}");
            }
        }
        let path = dir.join(format!("mesh_{k}.obj"));
        std::fs::write(&path, obj).map_err(|e| SimError::io("cannot write", &path, e))?;
        let _ = writeln!(
            assets,
            "    <mesh name=\"mesh_{k}\" file=\"mesh_{k}.obj\"/>"
        );
        let material = match piece.material {
            Some(m) if m < materials.len() && (textured || !copied.contains(&m)) => {
                format!(" material=\"material_{m}\"")
            }
            Some(m) if m < materials.len() => {
                let kd = materials[m].diffuse.unwrap_or([0.8, 0.8, 0.8]);
                format!(
                    " rgba=\"{} 1\"",
                    v3(f64::from(kd[0]), f64::from(kd[1]), f64::from(kd[2]))
                )
            }
            _ => String::new(),
        };
        let name = object_name(&piece.name);
        // An object's pieces (one per material) form one body: one instance in the masks,
        // its class the object's name (`chair_001` -> `chair`).
        if k == 0 || pieces[k - 1].name != piece.name {
            if k > 0 {
                geoms.push_str("    </body>\n");
            }
            objects += 1;
            let _ = writeln!(geoms, "    <body name=\"{name}_{objects}\">");
        }
        let _ = writeln!(geoms, "      <geom name=\"visual_{k}_{name}\" type=\"mesh\" mesh=\"mesh_{k}\" contype=\"0\" conaffinity=\"0\"{material}/>");
    }
    if !pieces.is_empty() {
        geoms.push_str("    </body>\n");
    }
    Ok((assets, geoms))
}

/// An OBJ object or group name as an MJCF name: letters and digits kept, anything else `_`;
/// `object` for an unnamed one.
fn object_name(name: &str) -> String {
    let name: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    let trimmed = name.trim_matches('_');
    if trimmed.is_empty() {
        "object".into()
    } else {
        trimmed.to_owned()
    }
}

/// MuJoCo 2.2's mj_ray misses a mesh whose vertices all lie in one plane (its convex hull is
/// degenerate), though OpenGL draws it: a flat piece (a floor, a wall quad) gets a 1 mm
/// triangle 1 mm behind its plane, which no camera sees, so rays find it.
fn flat_mesh_sliver(triangles: &[[[f64; 3]; 3]]) -> Option<[[f64; 3]; 3]> {
    let t = triangles.first()?;
    let a = [0, 1, 2].map(|k| t[1][k] - t[0][k]);
    let c = normal(t);
    let length = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    let normal = c.map(|v| v / length);
    let distance = |p: &[f64; 3]| {
        (0..3)
            .map(|k| (p[k] - t[0][k]) * normal[k])
            .sum::<f64>()
            .abs()
    };
    if triangles.iter().flatten().any(|p| distance(p) > 1e-6) {
        return None;
    }
    let la = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    let along = a.map(|v| v / la);
    let across = [0, 1, 2].map(|k| {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        normal[i] * along[j] - normal[j] * along[i]
    });
    let base = [0, 1, 2].map(|k| t[0][k] - 1e-3 * normal[k]);
    Some([
        base,
        [0, 1, 2].map(|k| base[k] + 1e-3 * along[k]),
        [0, 1, 2].map(|k| base[k] + 1e-3 * across[k]),
    ])
}

/// The world's MJCF text.
fn mjcf(
    meshdir: &str,
    robot: &str,
    (assets, geoms): &(String, String),
    colliders: &[super::voxels::Cuboid],
    spawn: Option<Pose2>,
    scene: &Path,
) -> String {
    let mut x = String::new();
    let _ = writeln!(x, "<!-- Imported by `splatloop world import` from {}: visual meshes per object and material, an object's in one body named after it; colliders are the scene voxelised at {VOXEL} m up to {COLLIDER_TOP} m, merged into boxes (group 4, invisible). -->", scene.display());
    let _ = writeln!(x, "<mujoco model=\"imported\">");
    let _ = writeln!(
        x,
        "  <compiler meshdir=\"{meshdir}\" texturedir=\"{meshdir}\" angle=\"radian\"/>"
    );
    let _ = writeln!(x, "  <option timestep=\"0.002\" integrator=\"implicit\"/>");
    let _ = writeln!(x, "  <visual>\n    <quality offsamples=\"0\"/>\n    <headlight ambient=\"0.35 0.35 0.35\" diffuse=\"0.5 0.5 0.5\" specular=\"0 0 0\"/>\n    <map znear=\"0.01\"/>\n  </visual>");
    let _ = writeln!(x, "  <include file=\"{robot}\"/>");
    let _ = writeln!(x, "  <asset>\n{assets}  </asset>");
    let _ = writeln!(x, "  <worldbody>");
    let _ = writeln!(x, "    <light name=\"ceiling\" pos=\"0 0 3\" dir=\"0 0 -1\" directional=\"true\" diffuse=\"0.5 0.5 0.5\"/>");
    let _ = writeln!(
        x,
        "    <geom name=\"ground\" type=\"plane\" size=\"0 0 1\" group=\"4\" rgba=\"0 0 0 0\"/>"
    );
    x.push_str(geoms);
    for (k, c) in colliders.iter().enumerate() {
        let _ = writeln!(x, "    <geom name=\"collider_{k}\" type=\"box\" pos=\"{}\" size=\"{}\" group=\"4\" rgba=\"0 0 0 0\"/>", v3(c.centre[0], c.centre[1], c.centre[2]), v3(c.half[0], c.half[1], c.half[2]));
    }
    if let Some(s) = spawn {
        let _ = writeln!(
            x,
            "    <site name=\"spawn\" pos=\"{}\" euler=\"0 0 {}\" size=\"0.05\" group=\"5\"/>",
            v3(s.x, s.y, 0.0),
            n(s.theta)
        );
    }
    let _ = writeln!(x, "  </worldbody>\n</mujoco>");
    x
}

/// The free cell with the most room, a metre of distance from `centre` costing 5 cm of room.
fn roomiest_pose(world: &World, centre: [f64; 2]) -> Result<Pose2> {
    let plan = FloorPlan::of(world)?;
    let outside = plan.outside();
    let best = (0..plan.len())
        .filter(|&c| plan.is_free(c) && !outside[c])
        .map(|c| {
            let [x, y] = plan.centre(c);
            (
                plan.clearance(c) - 0.05 * (x - centre[0]).hypot(y - centre[1]),
                c,
            )
        })
        .max_by(|a, b| a.0.total_cmp(&b.0));
    let Some((_, c)) = best else {
        return Err(SimError::InvalidArgument {
            what: "spawn",
            detail: format!("no free pose inside the scene: nowhere has {:.2} m of room for the robot; give one with --spawn x,y,yaw or check --scale", plan.clearance_needed),
        });
    };
    let [x, y] = plan.centre(c);
    Ok(Pose2 { x, y, theta: 0.0 })
}

/// Finds the first malformed line of an OBJ (tobj's errors name no line).
fn check_obj_lines(path: &Path, text: &str) -> Result<()> {
    let (mut positions, mut texcoords, mut normals) = (0i64, 0i64, 0i64);
    for (number, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        let fields: Vec<&str> = words.collect();
        let floats = |need: usize| {
            fields.len() >= need
                && fields
                    .iter()
                    .take(need)
                    .all(|f| f.parse::<f64>().is_ok_and(f64::is_finite))
        };
        let problem = match keyword {
            "v" if !floats(3) => Some("a vertex needs three numbers: v x y z"),
            "vt" if !floats(1) => Some("a texture coordinate needs numbers: vt u v"),
            "vn" if !floats(3) => Some("a normal needs three numbers: vn x y z"),
            "f" => {
                let ok = fields.len() >= 3
                    && fields.iter().all(|f| {
                        let parts: Vec<&str> = f.split('/').collect();
                        let index = |s: &str, count: i64| {
                            s.parse::<i64>()
                                .is_ok_and(|i| (i > 0 && i <= count) || (i < 0 && -i <= count))
                        };
                        !parts.is_empty()
                            && parts.len() <= 3
                            && index(parts[0], positions)
                            && parts
                                .get(1)
                                .is_none_or(|s| s.is_empty() || index(s, texcoords))
                            && parts
                                .get(2)
                                .is_none_or(|s| s.is_empty() || index(s, normals))
                    });
                (!ok).then_some("a face needs three or more vertex references (v, v/vt, v//vn or v/vt/vn) to vertices defined above it")
            }
            _ => None,
        };
        if let Some(what) = problem {
            return Err(bad_scene(
                path,
                format!("line {}: {what}: {:?}", number + 1, line.trim()),
            ));
        }
        match keyword {
            "v" => positions += 1,
            "vt" => texcoords += 1,
            "vn" => normals += 1,
            _ => {}
        }
    }
    Ok(())
}

/// Says which MTL failed and where.
fn material_error(scene: &Path, dir: &Path, text: &str, error: tobj::LoadError) -> SimError {
    for line in text.lines() {
        let Some(name) = line.trim().strip_prefix("mtllib") else {
            continue;
        };
        let mtl = dir.join(name.trim());
        if !mtl.is_file() {
            return SimError::MissingFile {
                what: "MTL file (mtllib of the OBJ)",
                path: mtl,
            };
        }
        if let Ok(body) = std::fs::read_to_string(&mtl) {
            for (number, line) in body.lines().enumerate() {
                let mut words = line.split_whitespace();
                let keyword = words.next().unwrap_or("");
                let fields: Vec<&str> = words.collect();
                let need = match keyword {
                    "Ka" | "Kd" | "Ks" | "Ke" => 3,
                    "Ns" | "Ni" | "d" | "Tr" => 1,
                    _ => 0,
                };
                if need > 0
                    && (fields.len() < need
                        || !fields.iter().take(need).all(|f| f.parse::<f64>().is_ok()))
                {
                    return bad_scene(
                        &mtl,
                        format!(
                            "line {}: {keyword} needs {need} number(s): {:?}",
                            number + 1,
                            line.trim()
                        ),
                    );
                }
            }
        }
        return bad_scene(&mtl, format!("{error}"));
    }
    bad_scene(scene, format!("its materials could not be read: {error}"))
}
