//! Worlds to and from textured OBJ + MTL scenes: `world export` writes any world's surfaces
//! (primitives tessellated, meshes as they are) with their materials and textures, and
//! `world import` turns a scene (Blender, scans) into a world: visual meshes per object and
//! material, colliders built from the scene voxelised at 5 cm, a floor and a spawn.
//!
//! OBJ files are Y up (the format's convention, Blender's default); MuJoCo is Z up. A point
//! (x, y, z) in the world is (x, z, -y) in the file.

pub mod export;
pub mod import;
pub mod voxels;

/// Which axis of a scene file points up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Up {
    /// Y up (OBJ's convention, Blender's default export).
    Y,
    /// Z up (MuJoCo's, most scans).
    Z,
}

impl std::str::FromStr for Up {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "y" | "Y" => Ok(Up::Y),
            "z" | "Z" => Ok(Up::Z),
            other => Err(format!("unknown up axis {other:?}; use y or z")),
        }
    }
}

impl Up {
    /// A file point in the world frame (Z up).
    pub fn to_world(self, p: [f64; 3]) -> [f64; 3] {
        match self {
            Up::Y => [p[0], -p[2], p[1]],
            Up::Z => p,
        }
    }

    /// A world point in the file's frame.
    pub fn from_world(self, p: [f64; 3]) -> [f64; 3] {
        match self {
            Up::Y => [p[0], p[2], -p[1]],
            Up::Z => p,
        }
    }
}
