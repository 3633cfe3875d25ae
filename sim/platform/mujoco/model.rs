//! `mjModel`: loading an MJCF, name lookups, and read access to the arrays the host needs.

use super::sys;
use crate::error::{Result, SimError};
use std::ffi::{CStr, CString};
use std::os::raw::c_char;
use std::path::{Path, PathBuf};
use std::ptr::NonNull;

/// Kinds of named MuJoCo objects we look up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObjKind {
    /// A body.
    Body,
    /// A joint.
    Joint,
    /// A geom.
    Geom,
    /// A site.
    Site,
    /// A camera.
    Camera,
    /// An actuator.
    Actuator,
    /// A mesh asset.
    Mesh,
    /// A texture.
    Texture,
    /// A material.
    Material,
    /// A custom text (`<custom><text name=.. data=..>`).
    Text,
}

impl ObjKind {
    fn raw(self) -> sys::mjtObj {
        match self {
            ObjKind::Body => sys::mjtObj::mjOBJ_BODY,
            ObjKind::Joint => sys::mjtObj::mjOBJ_JOINT,
            ObjKind::Geom => sys::mjtObj::mjOBJ_GEOM,
            ObjKind::Site => sys::mjtObj::mjOBJ_SITE,
            ObjKind::Camera => sys::mjtObj::mjOBJ_CAMERA,
            ObjKind::Actuator => sys::mjtObj::mjOBJ_ACTUATOR,
            ObjKind::Mesh => sys::mjtObj::mjOBJ_MESH,
            ObjKind::Texture => sys::mjtObj::mjOBJ_TEXTURE,
            ObjKind::Material => sys::mjtObj::mjOBJ_MATERIAL,
            ObjKind::Text => sys::mjtObj::mjOBJ_TEXT,
        }
    }

    /// The word a person uses for this kind.
    pub fn label(self) -> &'static str {
        match self {
            ObjKind::Body => "body",
            ObjKind::Joint => "joint",
            ObjKind::Geom => "geom",
            ObjKind::Site => "site",
            ObjKind::Camera => "camera",
            ObjKind::Actuator => "actuator",
            ObjKind::Mesh => "mesh",
            ObjKind::Texture => "texture",
            ObjKind::Material => "material",
            ObjKind::Text => "custom text",
        }
    }

    /// How many the model has (`int` before MuJoCo 4, `mjtSize` from 4 on).
    fn count(self, m: &sys::mjModel) -> usize {
        let n = match self {
            ObjKind::Body => m.nbody,
            ObjKind::Joint => m.njnt,
            ObjKind::Geom => m.ngeom,
            ObjKind::Site => m.nsite,
            ObjKind::Camera => m.ncam,
            ObjKind::Actuator => m.nu,
            ObjKind::Mesh => m.nmesh,
            ObjKind::Texture => m.ntex,
            ObjKind::Material => m.nmat,
            ObjKind::Text => m.ntext,
        };
        usize::try_from(n).unwrap_or(0)
    }
}

/// Geom shapes the host distinguishes: ground vs. obstacles, and flat-faced vs. curved (the
/// renderer draws curved primitives as polygons, mj_ray intersects them exactly).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GeomType {
    /// An infinite plane (floors).
    Plane,
    /// A height field (terrain).
    HeightField,
    /// A box.
    Box,
    /// A triangle mesh.
    Mesh,
    /// A sphere, capsule, ellipsoid or cylinder.
    Curved,
}

impl GeomType {
    /// Whether this is ground the robot drives on rather than an obstacle.
    pub fn is_ground(self) -> bool {
        matches!(self, GeomType::Plane | GeomType::HeightField)
    }

    /// Whether the renderer draws exactly the surface mj_ray intersects.
    pub fn is_flat_faced(self) -> bool {
        !matches!(self, GeomType::Curved)
    }
}

/// A geom's primitive, as MuJoCo compiled it (sizes in [`Model::geom_size`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// An infinite plane.
    Plane,
    /// A height field.
    HeightField,
    /// A sphere (radius).
    Sphere,
    /// A capsule (radius, half-length along z).
    Capsule,
    /// An ellipsoid (three semi-axes).
    Ellipsoid,
    /// A cylinder (radius, half-height along z).
    Cylinder,
    /// A box (three half-sizes).
    Box,
    /// A mesh, by mesh id; MuJoCo collides it as its convex hull.
    Mesh(usize),
    /// Anything newer MuJoCo versions add (signed-distance fields).
    Other,
}

/// What a material says about a surface's look.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaterialInfo {
    /// Colour (multiplies the texture).
    pub rgba: [f32; 4],
    /// Its texture.
    pub texture: Option<usize>,
    /// 2D texture repetitions.
    pub repeat: [f32; 2],
    /// Whether the repetitions are per metre rather than per surface.
    pub uniform: bool,
}

/// A texture's pixels as MuJoCo holds them.
#[derive(Debug, Clone)]
pub struct TextureInfo<'a> {
    /// A 2D texture (else a cube or skybox: six square faces stacked).
    pub flat: bool,
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels (six times the width for a cube).
    pub height: usize,
    /// RGB bytes, row by row (converted when MuJoCo keeps another channel count).
    pub rgb: std::borrow::Cow<'a, [u8]>,
}

/// A compiled MuJoCo model, owned; freed on drop.
pub struct Model {
    raw: NonNull<sys::mjModel>,
    path: PathBuf,
}

// SAFETY: mjModel is a plain heap block with no thread affinity; we only mutate it through
// `&mut self`.
unsafe impl Send for Model {}
// SAFETY: shared access only reads the block.
unsafe impl Sync for Model {}

impl Drop for Model {
    fn drop(&mut self) {
        // SAFETY: raw came from mj_loadXML and is freed exactly once here.
        unsafe { sys::mj_deleteModel(self.raw.as_ptr()) }
    }
}

impl std::fmt::Debug for Model {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Model").field("path", &self.path).finish()
    }
}

impl Model {
    /// Compiles an MJCF file; MuJoCo's own message comes back in the error.
    pub fn from_xml(path: &Path) -> Result<Self> {
        super::install_log_hooks();
        if path.is_dir() {
            return Err(SimError::InvalidArgument {
                what: "world",
                detail: format!(
                    "{} is a folder; give the world's MJCF file (e.g. worlds/room.xml)",
                    path.display()
                ),
            });
        }
        if !path.is_file() {
            return Err(SimError::MissingFile {
                what: "MJCF model",
                path: path.to_owned(),
            });
        }
        let c_path = CString::new(path.to_string_lossy().as_bytes()).map_err(|_| {
            SimError::InvalidArgument {
                what: "model path",
                detail: "contains a NUL byte".into(),
            }
        })?;
        let mut message = [0 as c_char; 1024];
        // SAFETY: c_path is NUL-terminated; the error buffer is writable for its stated length.
        let raw = unsafe {
            sys::mj_loadXML(
                c_path.as_ptr(),
                std::ptr::null(),
                message.as_mut_ptr(),
                message.len() as i32,
            )
        };
        match NonNull::new(raw) {
            Some(raw) => Ok(Model {
                raw,
                path: path.to_owned(),
            }),
            None => {
                // SAFETY: MuJoCo NUL-terminates the message inside the buffer.
                let text = unsafe { CStr::from_ptr(message.as_ptr()) }
                    .to_string_lossy()
                    .trim()
                    .to_owned();
                Err(SimError::BadModel {
                    path: path.to_owned(),
                    message: if text.is_empty() {
                        "unknown error".into()
                    } else {
                        text
                    },
                })
            }
        }
    }

    /// The MJCF file the model came from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    pub(crate) fn raw(&self) -> &sys::mjModel {
        // SAFETY: raw is valid for the lifetime of self.
        unsafe { self.raw.as_ref() }
    }

    pub(crate) fn raw_ptr(&self) -> *const sys::mjModel {
        self.raw.as_ptr()
    }

    /// Looks up an object by name; the error names the kind, the name and the file.
    pub fn id(&self, kind: ObjKind, name: &str, hint: &'static str) -> Result<usize> {
        let missing = || SimError::MissingName {
            kind: kind.label(),
            name: name.to_owned(),
            path: self.path.clone(),
            hint,
        };
        let c_name = CString::new(name).map_err(|_| missing())?;
        // SAFETY: the model pointer is valid and c_name is NUL-terminated.
        let id = unsafe { sys::mj_name2id(self.raw_ptr(), kind.raw() as i32, c_name.as_ptr()) };
        if id < 0 {
            Err(missing())
        } else {
            Ok(id as usize)
        }
    }

    /// The name of object `id` of `kind`, if it has one.
    pub fn name(&self, kind: ObjKind, id: usize) -> Option<String> {
        if id >= kind.count(self.raw()) {
            return None;
        }
        // SAFETY: id is in range, checked above.
        let ptr = unsafe { sys::mj_id2name(self.raw_ptr(), kind.raw() as i32, id as i32) };
        if ptr.is_null() {
            None
        } else {
            // SAFETY: MuJoCo returns a NUL-terminated name inside the model.
            Some(
                unsafe { CStr::from_ptr(ptr) }
                    .to_string_lossy()
                    .into_owned(),
            )
        }
    }

    /// Physics timestep in seconds.
    pub fn timestep(&self) -> f64 {
        self.raw().opt.timestep
    }

    /// Number of geoms.
    pub fn geom_count(&self) -> usize {
        self.raw().ngeom as usize
    }

    /// Number of bodies.
    pub fn body_count(&self) -> usize {
        self.raw().nbody as usize
    }

    /// Number of generalised positions.
    pub fn nq(&self) -> usize {
        self.raw().nq as usize
    }

    /// Number of degrees of freedom.
    pub fn nv(&self) -> usize {
        self.raw().nv as usize
    }

    /// Number of actuators.
    pub fn nu(&self) -> usize {
        self.raw().nu as usize
    }

    /// The body a geom is attached to.
    pub fn geom_body(&self, geom: usize) -> usize {
        let m = self.raw();
        array(m.geom_bodyid, m.ngeom)[geom] as usize
    }

    /// Shape class of a geom.
    pub fn geom_type(&self, geom: usize) -> GeomType {
        let m = self.raw();
        match array(m.geom_type, m.ngeom)[geom] {
            t if t == sys::mjtGeom::mjGEOM_PLANE as i32 => GeomType::Plane,
            t if t == sys::mjtGeom::mjGEOM_HFIELD as i32 => GeomType::HeightField,
            t if t == sys::mjtGeom::mjGEOM_BOX as i32 => GeomType::Box,
            t if t == sys::mjtGeom::mjGEOM_MESH as i32 => GeomType::Mesh,
            _ => GeomType::Curved,
        }
    }

    /// The exact primitive of a geom, for the host's own geometry (floor plans, export).
    pub fn geom_shape(&self, geom: usize) -> Shape {
        let m = self.raw();
        let t = array(m.geom_type, m.ngeom)[geom];
        let is = |g: sys::mjtGeom| t == g as i32;
        if is(sys::mjtGeom::mjGEOM_PLANE) {
            Shape::Plane
        } else if is(sys::mjtGeom::mjGEOM_HFIELD) {
            Shape::HeightField
        } else if is(sys::mjtGeom::mjGEOM_SPHERE) {
            Shape::Sphere
        } else if is(sys::mjtGeom::mjGEOM_CAPSULE) {
            Shape::Capsule
        } else if is(sys::mjtGeom::mjGEOM_ELLIPSOID) {
            Shape::Ellipsoid
        } else if is(sys::mjtGeom::mjGEOM_CYLINDER) {
            Shape::Cylinder
        } else if is(sys::mjtGeom::mjGEOM_BOX) {
            Shape::Box
        } else if is(sys::mjtGeom::mjGEOM_MESH) {
            let mesh = array(m.geom_dataid, m.ngeom)[geom];
            if mesh >= 0 && i64::from(mesh) < count(m.nmesh) {
                Shape::Mesh(mesh as usize)
            } else {
                Shape::Other
            }
        } else {
            Shape::Other
        }
    }

    /// Whether a geom takes part in collisions (contype or conaffinity set): visual-only geoms
    /// do not stop the robot.
    pub fn geom_collides(&self, geom: usize) -> bool {
        let m = self.raw();
        array(m.geom_contype, m.ngeom)[geom] != 0 || array(m.geom_conaffinity, m.ngeom)[geom] != 0
    }

    /// A mesh's vertices in the frame of the geoms that use it (MuJoCo recentres meshes at
    /// compile time and moves the geom frame to match).
    pub fn mesh_vertices(&self, mesh: usize) -> &[[f32; 3]] {
        let m = self.raw();
        if mesh >= m.nmesh as usize {
            return &[];
        }
        let start = array(m.mesh_vertadr, m.nmesh)[mesh] as usize;
        let count = array(m.mesh_vertnum, m.nmesh)[mesh] as usize;
        let all = array(m.mesh_vert, 3 * m.nmeshvert);
        let flat = &all[3 * start..3 * (start + count)];
        // SAFETY: [f32; 3] has the layout of three consecutive f32s, and `flat` holds 3 * count.
        unsafe { std::slice::from_raw_parts(flat.as_ptr().cast::<[f32; 3]>(), count) }
    }

    /// A geom's colour and material (the material's colour and texture win when it has one).
    pub fn geom_appearance(&self, geom: usize) -> ([f32; 4], Option<usize>) {
        let m = self.raw();
        let rgba = array(m.geom_rgba, 4 * m.ngeom);
        let material = array(m.geom_matid, m.ngeom)[geom];
        (
            [
                rgba[4 * geom],
                rgba[4 * geom + 1],
                rgba[4 * geom + 2],
                rgba[4 * geom + 3],
            ],
            (material >= 0 && i64::from(material) < count(m.nmat)).then_some(material as usize),
        )
    }

    /// A material's colour, texture, 2D repetition and whether that repetition is per metre.
    pub fn material(&self, material: usize) -> MaterialInfo {
        let m = self.raw();
        let rgba = array(m.mat_rgba, 4 * m.nmat);
        // From MuJoCo 3 a material has a texture per role; the colour one is ours.
        #[cfg(mujoco_3)]
        let texture = {
            let roles = sys::mjtTextureRole::mjNTEXROLE as usize;
            array(m.mat_texid, roles * m.nmat as usize)
                [material * roles + sys::mjtTextureRole::mjTEXROLE_RGB as usize]
        };
        #[cfg(not(mujoco_3))]
        let texture = array(m.mat_texid, m.nmat)[material];
        let repeat = array(m.mat_texrepeat, 2 * m.nmat);
        MaterialInfo {
            rgba: [
                rgba[4 * material],
                rgba[4 * material + 1],
                rgba[4 * material + 2],
                rgba[4 * material + 3],
            ],
            texture: (texture >= 0 && i64::from(texture) < count(m.ntex))
                .then_some(texture as usize),
            repeat: [repeat[2 * material], repeat[2 * material + 1]],
            uniform: is_set(array(m.mat_texuniform, m.nmat)[material]),
        }
    }

    /// A texture's pixels (RGB rows; a cube texture's six faces stacked) and whether it is 2D.
    pub fn texture(&self, texture: usize) -> TextureInfo<'_> {
        let m = self.raw();
        let width = array(m.tex_width, m.ntex)[texture] as usize;
        let height = array(m.tex_height, m.ntex)[texture] as usize;
        let start = array(m.tex_adr, m.ntex)[texture] as usize;
        let flat = array(m.tex_type, m.ntex)[texture] == sys::mjtTexture::mjTEXTURE_2D as i32;
        // MuJoCo 2 keeps RGB in tex_rgb; from 3 on tex_data has tex_nchannel bytes a pixel.
        #[cfg(mujoco_3)]
        let (all, channels) = (
            array(m.tex_data, m.ntexdata),
            (array(m.tex_nchannel, m.ntex)[texture].max(1)) as usize,
        );
        #[cfg(not(mujoco_3))]
        let (all, channels) = (array(m.tex_rgb, m.ntexdata), 3usize);
        let end = (start + channels * width * height).min(all.len());
        let pixels = &all[start.min(end)..end];
        let rgb = if channels == 3 {
            std::borrow::Cow::Borrowed(pixels)
        } else {
            std::borrow::Cow::Owned(
                pixels
                    .chunks(channels)
                    .flat_map(|p| {
                        let grey = p[0];
                        [grey, *p.get(1).unwrap_or(&grey), *p.get(2).unwrap_or(&grey)]
                    })
                    .collect(),
            )
        };
        TextureInfo {
            flat,
            width,
            height,
            rgb,
        }
    }

    /// A mesh's vertex normals, as MuJoCo renders them (one per vertex).
    pub fn mesh_normals(&self, mesh: usize) -> &[[f32; 3]] {
        let m = self.raw();
        if mesh >= m.nmesh as usize {
            return &[];
        }
        let start = array(m.mesh_vertadr, m.nmesh)[mesh] as usize;
        let count = array(m.mesh_vertnum, m.nmesh)[mesh] as usize;
        let all = array(m.mesh_normal, 3 * m.nmeshvert);
        let flat = &all[3 * start..3 * (start + count)];
        // SAFETY: [f32; 3] has the layout of three consecutive f32s, and `flat` holds 3 * count.
        unsafe { std::slice::from_raw_parts(flat.as_ptr().cast::<[f32; 3]>(), count) }
    }

    /// A mesh's triangles, as indices into [`Model::mesh_vertices`].
    pub fn mesh_faces(&self, mesh: usize) -> &[[i32; 3]] {
        let m = self.raw();
        if mesh >= m.nmesh as usize {
            return &[];
        }
        let start = array(m.mesh_faceadr, m.nmesh)[mesh] as usize;
        let count = array(m.mesh_facenum, m.nmesh)[mesh] as usize;
        let all = array(m.mesh_face, 3 * m.nmeshface);
        let flat = &all[3 * start..3 * (start + count)];
        // SAFETY: [i32; 3] has the layout of three consecutive i32s, and `flat` holds 3 * count.
        unsafe { std::slice::from_raw_parts(flat.as_ptr().cast::<[i32; 3]>(), count) }
    }

    /// Size parameters of a geom (radius first for spheres and cylinders).
    pub fn geom_size(&self, geom: usize) -> [f64; 3] {
        let m = self.raw();
        let s = array(m.geom_size, 3 * m.ngeom);
        [s[3 * geom], s[3 * geom + 1], s[3 * geom + 2]]
    }

    /// Position of a body in its parent's frame.
    pub fn body_offset(&self, body: usize) -> [f64; 3] {
        let m = self.raw();
        let p = array(m.body_pos, 3 * m.nbody);
        [p[3 * body], p[3 * body + 1], p[3 * body + 2]]
    }

    /// The data of the custom text named `name` (`<custom><text name=".." data=".."/>`): how a
    /// hand-made world says what it means beyond names and numbers.
    pub fn custom_text(&self, name: &str) -> Option<String> {
        let id = self.id(ObjKind::Text, name, "").ok()?;
        let m = self.raw();
        let address = usize::try_from(array(m.text_adr, m.ntext)[id]).ok()?;
        let size = usize::try_from(array(m.text_size, m.ntext)[id]).ok()?;
        let data = array(m.text_data, m.ntextdata);
        let bytes: Vec<u8> = data
            .get(address..address + size)?
            .iter()
            .take_while(|&&c| c != 0)
            .map(|&c| c as u8)
            .collect();
        Some(String::from_utf8_lossy(&bytes).into_owned())
    }

    /// Visibility group of a geom (0..5).
    pub fn geom_group(&self, geom: usize) -> i32 {
        let m = self.raw();
        array(m.geom_group, m.ngeom)[geom]
    }

    /// Whether `body` is `ancestor` or lies below it in the kinematic tree.
    pub fn body_is_in_subtree(&self, body: usize, ancestor: usize) -> bool {
        let m = self.raw();
        let parents = array(m.body_parentid, m.nbody);
        let mut b = body;
        loop {
            if b == ancestor {
                return true;
            }
            if b == 0 {
                return false;
            }
            b = parents[b] as usize;
        }
    }

    /// Vertical field of view of a camera, radians.
    pub fn camera_fovy(&self, camera: usize) -> f64 {
        let m = self.raw();
        array(m.cam_fovy, m.ncam)[camera].to_radians()
    }

    /// Address in qpos of a joint's first coordinate.
    pub fn joint_qpos_address(&self, joint: usize) -> usize {
        let m = self.raw();
        array(m.jnt_qposadr, m.njnt)[joint] as usize
    }

    /// Address in qvel of a joint's first degree of freedom.
    pub fn joint_dof_address(&self, joint: usize) -> usize {
        let m = self.raw();
        array(m.jnt_dofadr, m.njnt)[joint] as usize
    }

    /// Whether a joint is a free joint (7 qpos, 6 dof).
    pub fn joint_is_free(&self, joint: usize) -> bool {
        let m = self.raw();
        array(m.jnt_type, m.njnt)[joint] == sys::mjtJoint::mjJNT_FREE as i32
    }

    /// The body a joint moves.
    pub fn joint_body(&self, joint: usize) -> usize {
        let m = self.raw();
        array(m.jnt_bodyid, m.njnt)[joint] as usize
    }

    /// The joint an actuator drives, if it drives a joint.
    pub fn actuator_joint(&self, actuator: usize) -> Option<usize> {
        let m = self.raw();
        let trn_type = array(m.actuator_trntype, m.nu)[actuator];
        if trn_type != sys::mjtTrn::mjTRN_JOINT as i32 {
            return None;
        }
        Some(array(m.actuator_trnid, 2 * m.nu)[2 * actuator] as usize)
    }

    /// Near and far clipping distances of the OpenGL projection, metres.
    pub fn clip_planes(&self) -> (f64, f64) {
        let m = self.raw();
        let extent = m.stat.extent;
        (
            f64::from(m.vis.map.znear) * extent,
            f64::from(m.vis.map.zfar) * extent,
        )
    }

    /// Prepares the model for an offscreen sensor of `width` x `height`: the offscreen buffer
    /// must be at least that large; multisampling is off unless asked for (it blends depths
    /// across silhouettes and costs several times the frame time on llvmpipe).
    pub fn configure_offscreen(&mut self, width: u32, height: u32, multisample: bool) {
        // SAFETY: &mut self gives exclusive access to the model block.
        let m = unsafe { self.raw.as_mut() };
        m.vis.global.offwidth = m.vis.global.offwidth.max(width as i32);
        m.vis.global.offheight = m.vis.global.offheight.max(height as i32);
        m.vis.quality.offsamples = if multisample { 4 } else { 0 };
    }

    /// Sets the near clipping plane as a distance in metres, so depth starts close to the lens.
    pub fn set_near_clip(&mut self, near: f64) {
        // SAFETY: &mut self gives exclusive access to the model block.
        let m = unsafe { self.raw.as_mut() };
        m.vis.map.znear = (near / m.stat.extent) as f32;
    }
}

/// Views a model array of `count` elements; MuJoCo allocates every array at load time.
/// A MuJoCo flag: an mjtByte before MuJoCo 4, an mjtBool (C bool) from 4 on.
#[cfg(mujoco_4)]
fn is_set(flag: bool) -> bool {
    flag
}

/// A MuJoCo flag: an mjtByte before MuJoCo 4, an mjtBool (C bool) from 4 on.
#[cfg(not(mujoco_4))]
fn is_set(flag: u8) -> bool {
    flag != 0
}

/// A model count as i64, whatever MuJoCo's type for it (`int` before 3.x, the 64-bit `mjtSize`
/// from 3.x on): a cast would be a no-op, and a lint, under the newer MuJoCo.
fn count(n: impl Into<i64>) -> i64 {
    n.into()
}

/// A model array of `count` elements (`int` sizes before MuJoCo 4, `mjtSize` from 4 on).
fn array<'a, T>(ptr: *const T, count: impl TryInto<usize>) -> &'a [T] {
    let count = count.try_into().unwrap_or(0);
    if ptr.is_null() || count == 0 {
        return &[];
    }
    // SAFETY: MuJoCo allocates `count` elements at `ptr` for the model's lifetime, which
    // outlives every borrow handed out through `&Model`.
    unsafe { std::slice::from_raw_parts(ptr, count) }
}
