//! `splatloop world export`: every visible world geom (the robot's excluded) as triangles in
//! the world frame, one OBJ object per geom, with an MTL material per MuJoCo material (its
//! colour and texture, written as PNG) or per plain colour. Boxes carry their whole texture
//! on each face, as MuJoCo draws a cube texture; planes repeat theirs as the material says.

use super::Up;
use crate::error::{Result, SimError};
use crate::evaluate::WORLD_GROUPS;
use crate::mujoco::{Model, ObjKind, Shape};
use crate::world::World;
use nalgebra::{Matrix3, Point3, Vector3};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Segments around a tessellated circle.
const SEGMENTS: usize = 48;

/// What an export wrote.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ExportSummary {
    /// The OBJ file.
    pub obj: PathBuf,
    /// Objects (geoms) written.
    pub objects: usize,
    /// Triangles written.
    pub triangles: usize,
    /// Materials in the MTL.
    pub materials: usize,
    /// Texture images written.
    pub textures: usize,
}

/// A triangle soup with normals and texture coordinates, in a geom's local frame.
#[derive(Default)]
struct Surface {
    positions: Vec<Vector3<f64>>,
    normals: Vec<Vector3<f64>>,
    uvs: Vec<[f64; 2]>,
    triangles: Vec<[usize; 3]>,
}

impl Surface {
    fn vertex(&mut self, p: Vector3<f64>, n: Vector3<f64>, uv: [f64; 2]) -> usize {
        self.positions.push(p);
        self.normals.push(n);
        self.uvs.push(uv);
        self.positions.len() - 1
    }

    fn quad(&mut self, corners: [usize; 4]) {
        self.triangles.push([corners[0], corners[1], corners[2]]);
        self.triangles.push([corners[0], corners[2], corners[3]]);
    }
}

/// Writes `world` as `obj` with an MTL beside it and the textures in `<stem>_textures/`.
pub fn export_world(world: &World, obj: &Path, overwrite: bool) -> Result<ExportSummary> {
    let model = world.model();
    let data = world.data();
    let stem = obj
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    let folder = obj
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
    let mtl = folder.join(format!("{stem}.mtl"));
    let textures_dir = folder.join(format!("{stem}_textures"));
    for path in [obj, mtl.as_path(), textures_dir.as_path()] {
        crate::dataset::refuse_overwrite(path, overwrite, &[model.path()])?;
    }
    let mut text = format!(
        "# Exported by splatloop from {}: Y up, metres.\nmtllib {stem}.mtl\n",
        model.path().display()
    );
    let mut library = MaterialLibrary {
        stem: stem.clone(),
        textures_dir: textures_dir.clone(),
        materials: BTreeMap::new(),
        texture_files: Vec::new(),
    };
    let (mut base, mut objects, mut triangles) = (1usize, 0usize, 0usize);
    for geom in 0..model.geom_count() {
        let group = model.geom_group(geom);
        if world.robot().owns_geom(geom)
            || !(0..8).contains(&group)
            || WORLD_GROUPS >> group & 1 == 0
        {
            continue;
        }
        let (rgba, material) = model.geom_appearance(geom);
        let info = material.map(|m| model.material(m));
        let alpha = info.map_or(rgba[3], |i| i.rgba[3]);
        if alpha <= 0.0 {
            continue;
        }
        let Some(surface) = geom_surface(model, geom, info) else {
            continue;
        };
        // The material: MuJoCo's own, or one per plain colour.
        let material_name = library.name_for(model, rgba, material, info);
        let position = data.geom_position(geom);
        let rotation: Matrix3<f64> = data.geom_rotation(geom);
        let name = model
            .name(ObjKind::Geom, geom)
            .unwrap_or_else(|| format!("geom_{geom}"));
        write_object(
            &mut text,
            &name,
            &material_name,
            &surface,
            position,
            rotation,
            base,
        );
        base += surface.positions.len();
        objects += 1;
        triangles += surface.triangles.len();
    }
    write_scene_files(model, &library, &mtl, obj, &text)?;
    Ok(ExportSummary {
        obj: obj.to_path_buf(),
        objects,
        triangles,
        materials: library.materials.len(),
        textures: library.texture_files.len(),
    })
}

/// A geom's surface in its own frame, `None` for what has none to export (an infinite plane,
/// a height field).
fn geom_surface(
    model: &Model,
    geom: usize,
    info: Option<crate::mujoco::MaterialInfo>,
) -> Option<Surface> {
    let size = model.geom_size(geom);
    Some(match model.geom_shape(geom) {
        Shape::Box => cuboid(size),
        Shape::Plane => {
            if size[0] <= 0.0 || size[1] <= 0.0 {
                return None;
            }
            plane(size, info)
        }
        Shape::Sphere => ellipsoid([size[0]; 3]),
        Shape::Ellipsoid => ellipsoid(size),
        Shape::Cylinder => cylinder(size[0], size[1], false),
        Shape::Capsule => cylinder(size[0], size[1], true),
        Shape::Mesh(mesh) => mesh_surface(
            model.mesh_vertices(mesh),
            model.mesh_normals(mesh),
            model.mesh_faces(mesh),
        ),
        Shape::HeightField | Shape::Other => return None,
    })
}

/// The materials the exported geoms use, and the textures they name.
struct MaterialLibrary {
    /// The OBJ's stem (textures go to `<stem>_textures/`).
    stem: String,
    textures_dir: PathBuf,
    /// MTL entries by name.
    materials: BTreeMap<String, String>,
    /// Texture files to write and the MuJoCo texture each holds.
    texture_files: Vec<(PathBuf, usize)>,
}

impl MaterialLibrary {
    /// The material of a geom of colour `rgba`: MuJoCo's own, or one per plain colour; added
    /// to the library on first use.
    fn name_for(
        &mut self,
        model: &Model,
        rgba: [f32; 4],
        material: Option<usize>,
        info: Option<crate::mujoco::MaterialInfo>,
    ) -> String {
        let (stem, textures_dir) = (&self.stem, &self.textures_dir);
        let (materials, texture_files) = (&mut self.materials, &mut self.texture_files);
        match (material, info) {
            (Some(m), Some(i)) => {
                let name = model
                    .name(ObjKind::Material, m)
                    .unwrap_or_else(|| format!("material_{m}"));
                if !materials.contains_key(&name) {
                    let mut entry = format!(
                        "newmtl {name}\nKd {:.4} {:.4} {:.4}\n",
                        i.rgba[0], i.rgba[1], i.rgba[2]
                    );
                    if let Some(t) = i.texture {
                        let file = format!(
                            "{}.png",
                            model
                                .name(ObjKind::Texture, t)
                                .unwrap_or_else(|| format!("texture_{t}"))
                        );
                        let _ = writeln!(entry, "map_Kd {stem}_textures/{file}");
                        if !texture_files.iter().any(|(_, k)| *k == t) {
                            texture_files.push((textures_dir.join(&file), t));
                        }
                    }
                    materials.insert(name.clone(), entry);
                }
                name
            }
            _ => {
                let name = format!(
                    "rgba_{:02x}{:02x}{:02x}",
                    (rgba[0] * 255.0).round() as u8,
                    (rgba[1] * 255.0).round() as u8,
                    (rgba[2] * 255.0).round() as u8
                );
                materials.entry(name.clone()).or_insert_with(|| {
                    format!(
                        "newmtl {name}\nKd {:.4} {:.4} {:.4}\n",
                        rgba[0], rgba[1], rgba[2]
                    )
                });
                name
            }
        }
    }
}

/// Appends one geom as an OBJ object: its vertices placed in the world and turned Y up,
/// its faces numbered from `base`.
fn write_object(
    text: &mut String,
    name: &str,
    material_name: &str,
    surface: &Surface,
    position: Point3<f64>,
    rotation: Matrix3<f64>,
    base: usize,
) {
    let _ = writeln!(text, "o {name}\nusemtl {material_name}");
    for p in &surface.positions {
        let w = Point3::from(position.coords + rotation * p);
        let f = Up::Y.from_world([w.x, w.y, w.z]);
        let _ = writeln!(text, "v {:.6} {:.6} {:.6}", f[0], f[1], f[2]);
    }
    for uv in &surface.uvs {
        let _ = writeln!(text, "vt {:.6} {:.6}", uv[0], uv[1]);
    }
    for n in &surface.normals {
        let w = rotation * n;
        let f = Up::Y.from_world([w.x, w.y, w.z]);
        let _ = writeln!(text, "vn {:.6} {:.6} {:.6}", f[0], f[1], f[2]);
    }
    for t in &surface.triangles {
        let [a, b, c] = t.map(|i| i + base);
        let _ = writeln!(text, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}");
    }
}

/// Writes the textures, the MTL and the OBJ under temporary names, then gives each its name,
/// so a failure leaves no partial scene.
fn write_scene_files(
    model: &Model,
    library: &MaterialLibrary,
    mtl: &Path,
    obj: &Path,
    text: &str,
) -> Result<()> {
    let (textures_dir, texture_files, materials) = (
        &library.textures_dir,
        &library.texture_files,
        &library.materials,
    );
    let write = |path: &Path, bytes: &[u8]| -> Result<PathBuf> {
        let temporary = partial(path);
        std::fs::write(&temporary, bytes).map_err(|e| SimError::io("cannot write", path, e))?;
        Ok(temporary)
    };
    let mut pending = Vec::new();
    if !texture_files.is_empty() {
        std::fs::create_dir_all(textures_dir)
            .map_err(|e| SimError::io("cannot create", textures_dir, e))?;
        for (path, t) in texture_files {
            let info = model.texture(*t);
            // A cube texture's first face (MuJoCo repeats one image on all six).
            let rows = if info.flat { info.height } else { info.width };
            let bytes = &info.rgb[..(3 * info.width * rows).min(info.rgb.len())];
            let temporary = partial(path);
            crate::dataset::write_rgb_png(&temporary, info.width as u32, rows as u32, bytes)?;
            pending.push((temporary, path.clone()));
        }
    }
    let mtl_text: String = materials.values().map(|m| format!("{m}\n")).collect();
    pending.push((write(mtl, mtl_text.as_bytes())?, mtl.to_path_buf()));
    pending.push((write(obj, text.as_bytes())?, obj.to_path_buf()));
    for (from, to) in pending {
        std::fs::rename(&from, &to).map_err(|e| SimError::io("cannot write", &to, e))?;
    }
    Ok(())
}

/// Where `path` is written before it takes its name.
fn partial(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".partial");
    path.with_file_name(name)
}

/// A box of half sizes `s`: four vertices per face, the whole texture on each face.
fn cuboid(s: [f64; 3]) -> Surface {
    let mut out = Surface::default();
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let n = Vector3::from_fn(|i, _| if i == axis { sign } else { 0.0 });
            // Two in-plane axes, ordered so the corners wind counter-clockwise seen from outside.
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let (u, v) = if sign > 0.0 { (u, v) } else { (v, u) };
            let corner = |a: f64, b: f64| {
                let mut p = Vector3::zeros();
                p[axis] = sign * s[axis];
                p[u] = a * s[u];
                p[v] = b * s[v];
                p
            };
            let ids = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                .map(|(a, b)| out.vertex(corner(a, b), n, [0.5 * (a + 1.0), 0.5 * (b + 1.0)]));
            out.quad(ids);
        }
    }
    out
}

/// A plane's drawn rectangle, facing +z, its texture repeated as the material says.
fn plane(s: [f64; 3], material: Option<crate::mujoco::MaterialInfo>) -> Surface {
    let mut out = Surface::default();
    let repeat = material.map_or([1.0, 1.0], |m| {
        [f64::from(m.repeat[0]), f64::from(m.repeat[1])]
    });
    let uniform = material.is_some_and(|m| m.uniform);
    let n = Vector3::z();
    let ids = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)].map(|(a, b)| {
        let p = Vector3::new(a * s[0], b * s[1], 0.0);
        let uv = if uniform {
            [p.x * repeat[0], p.y * repeat[1]]
        } else {
            [0.5 * (a + 1.0) * repeat[0], 0.5 * (b + 1.0) * repeat[1]]
        };
        out.vertex(p, n, uv)
    });
    out.quad(ids);
    out
}

/// An ellipsoid of semi-axes `s` (a sphere when equal), as latitude-longitude quads.
fn ellipsoid(s: [f64; 3]) -> Surface {
    let mut out = Surface::default();
    let rings = SEGMENTS / 2;
    let mut grid = Vec::new();
    for i in 0..=rings {
        let polar = std::f64::consts::PI * i as f64 / rings as f64;
        let mut row = Vec::new();
        for j in 0..=SEGMENTS {
            let a = std::f64::consts::TAU * j as f64 / SEGMENTS as f64;
            let unit = Vector3::new(polar.sin() * a.cos(), polar.sin() * a.sin(), polar.cos());
            let p = Vector3::new(unit.x * s[0], unit.y * s[1], unit.z * s[2]);
            let n = Vector3::new(unit.x / s[0], unit.y / s[1], unit.z / s[2]).normalize();
            row.push(out.vertex(
                p,
                n,
                [j as f64 / SEGMENTS as f64, 1.0 - i as f64 / rings as f64],
            ));
        }
        grid.push(row);
    }
    for i in 0..rings {
        for j in 0..SEGMENTS {
            out.quad([
                grid[i][j],
                grid[i + 1][j],
                grid[i + 1][j + 1],
                grid[i][j + 1],
            ]);
        }
    }
    out
}

/// A cylinder of radius `r` and half height `h` along z, with flat caps (or round ones: a
/// capsule).
fn cylinder(r: f64, h: f64, round: bool) -> Surface {
    let mut out = Surface::default();
    let ring = |out: &mut Surface, z: f64, v: f64| -> Vec<usize> {
        (0..=SEGMENTS)
            .map(|j| {
                let a = std::f64::consts::TAU * j as f64 / SEGMENTS as f64;
                out.vertex(
                    Vector3::new(r * a.cos(), r * a.sin(), z),
                    Vector3::new(a.cos(), a.sin(), 0.0),
                    [j as f64 / SEGMENTS as f64, v],
                )
            })
            .collect()
    };
    let (bottom, top) = (ring(&mut out, -h, 0.0), ring(&mut out, h, 1.0));
    for j in 0..SEGMENTS {
        out.quad([bottom[j], bottom[j + 1], top[j + 1], top[j]]);
    }
    for (z, sign) in [(-h, -1.0), (h, 1.0)] {
        if round {
            let cap = ellipsoid([r; 3]);
            let base = out.positions.len();
            for ((p, n), uv) in cap.positions.iter().zip(&cap.normals).zip(&cap.uvs) {
                if p.z * sign >= -1e-12 {
                    out.vertex(p + Vector3::new(0.0, 0.0, z), *n, *uv);
                } else {
                    // Below the cap's equator: flattened onto it, so the hemisphere closes.
                    out.vertex(Vector3::new(p.x, p.y, z), *n, *uv);
                }
            }
            out.triangles
                .extend(cap.triangles.iter().map(|t| t.map(|i| i + base)));
        } else {
            let n = Vector3::new(0.0, 0.0, sign);
            let centre = out.vertex(Vector3::new(0.0, 0.0, z), n, [0.5, 0.5]);
            let rim: Vec<usize> = (0..SEGMENTS)
                .map(|j| {
                    let a = std::f64::consts::TAU * j as f64 / SEGMENTS as f64;
                    out.vertex(
                        Vector3::new(r * a.cos(), r * a.sin(), z),
                        n,
                        [0.5 + 0.5 * a.cos(), 0.5 + 0.5 * a.sin()],
                    )
                })
                .collect();
            for j in 0..SEGMENTS {
                let (a, b) = (rim[j], rim[(j + 1) % SEGMENTS]);
                out.triangles.push(if sign > 0.0 {
                    [centre, a, b]
                } else {
                    [centre, b, a]
                });
            }
        }
    }
    out
}

/// A mesh as MuJoCo compiled it, with its normals (no texture coordinates).
fn mesh_surface(vertices: &[[f32; 3]], normals: &[[f32; 3]], faces: &[[i32; 3]]) -> Surface {
    let mut out = Surface::default();
    for (k, v) in vertices.iter().enumerate() {
        let p = Vector3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2]));
        let n = normals.get(k).map_or(Vector3::z(), |n| {
            Vector3::new(f64::from(n[0]), f64::from(n[1]), f64::from(n[2]))
        });
        out.vertex(p, n, [0.0, 0.0]);
    }
    out.triangles.extend(
        faces
            .iter()
            .filter(|f| f.iter().all(|&i| i >= 0 && (i as usize) < vertices.len()))
            .map(|f| f.map(|i| i as usize)),
    );
    out
}
