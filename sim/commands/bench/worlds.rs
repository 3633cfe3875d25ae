//! `splatloop bench world`: how long the generator takes per world of each kind, and how
//! long `world import` takes on scenes of 1e5 and 1e6 triangles (a generated world exported,
//! then each triangle split into four until it has enough), with the colliders it builds.

use crate::camera::SensorConfig;
use crate::error::{Result, SimError};
use crate::scene::export::export_world;
use crate::scene::import::{import_scene, ImportConfig, ImportSummary};
use crate::scene::Up;
use crate::world::World;
use crate::worldgen::{generate, GenerateConfig, WorldKind};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// One generated world, timed.
#[derive(Debug, Clone)]
pub struct GenerateRow {
    /// Its kind.
    pub kind: WorldKind,
    /// Its seed.
    pub seed: u64,
    /// Wall seconds, checks and rejected candidates included.
    pub seconds: f64,
    /// Candidates tried.
    pub candidates: u32,
    /// Floor area, m2.
    pub area: f64,
    /// Collidable geoms.
    pub geoms: usize,
}

/// Generates `per_kind` worlds of each kind into `dir`, timing each.
pub fn bench_generate(dir: &Path, per_kind: u64) -> Result<Vec<GenerateRow>> {
    let mut rows = Vec::new();
    for kind in WorldKind::ALL {
        for seed in 1..=per_kind {
            let out = dir.join(format!("{}_{seed}.xml", kind.name()));
            let config = GenerateConfig {
                kind,
                seed,
                area: None,
                out,
                overwrite: true,
            };
            let started = Instant::now();
            let world = generate(&config, &mut |_, _| {})?;
            rows.push(GenerateRow {
                kind,
                seed,
                seconds: started.elapsed().as_secs_f64(),
                candidates: world.sub_seed + 1,
                area: world.area,
                geoms: world.report.geoms,
            });
        }
    }
    Ok(rows)
}

/// Exports `world`, subdivides the scene to at least each of `targets` triangles, imports
/// each and times it.
pub fn bench_import(
    world: &Path,
    dir: &Path,
    targets: &[usize],
) -> Result<Vec<(f64, ImportSummary)>> {
    let loaded = World::load(world, &SensorConfig::default())?;
    let base = dir.join("base.obj");
    export_world(&loaded, &base, true)?;
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj(&base, &options).map_err(|e| SimError::BadScene {
        path: base.clone(),
        detail: e.to_string(),
    })?;
    let mut rows = Vec::new();
    for &target in targets {
        let mut objects: Vec<SceneObject> = models
            .iter()
            .map(|m| {
                let mesh = &m.mesh;
                let vertex = |i: u32| {
                    let i = i as usize;
                    let t = |k: usize| {
                        mesh.texcoords
                            .get(2 * i + k)
                            .copied()
                            .map_or(0.0, f64::from)
                    };
                    [
                        f64::from(mesh.positions[3 * i]),
                        f64::from(mesh.positions[3 * i + 1]),
                        f64::from(mesh.positions[3 * i + 2]),
                        t(0),
                        t(1),
                    ]
                };
                let triangles = mesh
                    .indices
                    .chunks_exact(3)
                    .map(|t| [vertex(t[0]), vertex(t[1]), vertex(t[2])])
                    .collect();
                (m.name.clone(), mesh.material_id, triangles)
            })
            .collect();
        while objects.iter().map(|o| o.2.len()).sum::<usize>() < target {
            for object in &mut objects {
                object.2 = object.2.iter().flat_map(split).collect();
            }
        }
        let materials = std::fs::read_to_string(dir.join("base.mtl"))
            .map_err(|e| SimError::io("cannot read", dir.join("base.mtl"), e))?;
        let names: Vec<String> = materials
            .lines()
            .filter_map(|l| l.strip_prefix("newmtl ").map(str::to_owned))
            .collect();
        let mut text = String::from("mtllib base.mtl\n");
        let mut count = 0;
        for (name, material, triangles) in &objects {
            let _ = writeln!(text, "o {name}");
            if let Some(m) = material.and_then(|m| names.get(m)) {
                let _ = writeln!(text, "usemtl {m}");
            }
            for t in triangles {
                for v in t {
                    let _ = writeln!(
                        text,
                        "v {:.5} {:.5} {:.5}\nvt {:.5} {:.5}",
                        v[0], v[1], v[2], v[3], v[4]
                    );
                }
                let _ = writeln!(
                    text,
                    "f {0}/{0} {1}/{1} {2}/{2}",
                    count + 1,
                    count + 2,
                    count + 3
                );
                count += 3;
            }
        }
        let scene = dir.join(format!("scene_{target}.obj"));
        std::fs::write(&scene, text).map_err(|e| SimError::io("cannot write", &scene, e))?;
        let config = ImportConfig {
            scene,
            up: Up::Y,
            scale: 1.0,
            floor: None,
            spawn: Some(loaded.start()),
            out: dir.join(format!("imported_{target}.xml")),
            overwrite: true,
        };
        let started = Instant::now();
        let summary = import_scene(&config)?;
        rows.push((started.elapsed().as_secs_f64(), summary));
    }
    Ok(rows)
}

/// A triangle's corners: position (x, y, z) and texture coordinates (u, v).
type TexturedTriangle = [[f64; 5]; 3];

/// An object of the scene: its name, material and triangles.
type SceneObject = (String, Option<usize>, Vec<TexturedTriangle>);

/// A triangle (positions and texture coordinates) split at its edge midpoints into four.
fn split(t: &TexturedTriangle) -> [TexturedTriangle; 4] {
    let mid = |a: &[f64; 5], b: &[f64; 5]| [0, 1, 2, 3, 4].map(|k| 0.5 * (a[k] + b[k]));
    let (ab, bc, ca) = (mid(&t[0], &t[1]), mid(&t[1], &t[2]), mid(&t[2], &t[0]));
    [[t[0], ab, ca], [ab, t[1], bc], [ca, bc, t[2]], [ab, bc, ca]]
}
