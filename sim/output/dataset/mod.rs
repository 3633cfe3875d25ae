//! The episode folder of DESIGN.md: TUM RGB-D files, camera.json, nerfstudio transforms.json,
//! episode.json. Written while an episode runs and read back for evaluation and tests.

mod images;
mod place;
mod reader;
mod writer;

pub use images::{
    read_depth_png, read_mask_png, read_rgb_png, write_depth_png, write_mask_png, write_rgb_png,
};
pub use reader::{read_trajectory, Dataset, DatasetFrame};
pub(crate) use writer::write_json;
pub use writer::DatasetWriter;

use crate::error::{Result, SimError};
use autonomy::camera::Intrinsics;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Depth PNG units: 5000 per metre (TUM), so 1 unit = 0.2 mm and the range tops out at 13.1 m.
pub const DEPTH_SCALE: f64 = 5000.0;

/// `camera.json`: the intrinsics every frame shares.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraFile {
    /// K as rows.
    #[serde(rename = "K")]
    pub k: [[f64; 3]; 3],
    /// Image width, pixels.
    #[serde(rename = "W")]
    pub width: u32,
    /// Image height, pixels.
    #[serde(rename = "H")]
    pub height: u32,
    /// Depth PNG units per metre.
    pub depth_scale: f64,
    /// Depth beyond this reads 0.
    pub max_range: f64,
    /// Convention reminder for readers of the file.
    pub convention: String,
}

impl CameraFile {
    /// Describes `intrinsics`.
    pub fn new(intrinsics: &Intrinsics, max_range: f64) -> Self {
        let m = intrinsics.matrix();
        CameraFile {
            k: [
                [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
                [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
                [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
            ],
            width: intrinsics.width,
            height: intrinsics.height,
            depth_scale: DEPTH_SCALE,
            max_range,
            convention: "OpenCV optical frame (x right, y down, z forward); pixel centres at \
                         integer coordinates; planar depth; poses are world_from_camera"
                .into(),
        }
    }

    /// Reads a camera.json.
    pub fn read(path: &std::path::Path) -> crate::error::Result<Self> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| crate::error::SimError::io("cannot read", path, e))?;
        let camera: CameraFile =
            serde_json::from_str(&text).map_err(|e| crate::error::SimError::BadDataset {
                path: path.to_owned(),
                detail: format!("{e}; expected the camera.json of a splatloop dataset"),
            })?;
        // Sizes from a file are checked as the command line's are: a damaged file must not
        // make the renderer allocate a 280 GB image.
        let bad = |detail: String| crate::error::SimError::BadDataset {
            path: path.to_owned(),
            detail,
        };
        for (side, value) in [("W", camera.width), ("H", camera.height)] {
            if !crate::camera::RESOLUTION_RANGE.contains(&value) {
                return Err(bad(format!(
                    "{side} = {value} is outside {}..={} pixels",
                    crate::camera::RESOLUTION_RANGE.start(),
                    crate::camera::RESOLUTION_RANGE.end()
                )));
            }
        }
        let k = camera.k;
        if !(k.iter().flatten().all(|v| v.is_finite()) && k[0][0] > 0.0 && k[1][1] > 0.0) {
            return Err(bad(format!(
                "K = {k:?} needs finite entries and positive focal lengths"
            )));
        }
        if !(camera.max_range.is_finite() && camera.max_range > 0.0) {
            return Err(bad(format!(
                "max_range = {} must be a positive number of metres",
                camera.max_range
            )));
        }
        Ok(camera)
    }

    /// The intrinsics back.
    pub fn intrinsics(&self) -> Intrinsics {
        Intrinsics {
            fx: self.k[0][0],
            fy: self.k[1][1],
            cx: self.k[0][2],
            cy: self.k[1][2],
            width: self.width,
            height: self.height,
        }
    }
}

/// One kind of per-frame image: the folder its PNGs go in and the TUM list that names them.
/// The writer, the reader and [`remove_frames`] take every file name from these constants, so
/// a renamed file cannot leave one of them behind.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ImageFiles {
    /// The folder of PNGs, relative to the dataset.
    pub folder: &'static str,
    /// The TUM list of `timestamp folder/NNNNNN.png` lines.
    pub list: &'static str,
}

impl ImageFiles {
    /// A frame's image, relative to the dataset (what the lists and transforms.json hold).
    pub fn entry(&self, file: &str) -> String {
        format!("{}/{file}", self.folder)
    }
}

/// Colour images (8-bit RGB PNGs).
pub(crate) const RGB: ImageFiles = ImageFiles {
    folder: "rgb",
    list: "rgb.txt",
};
/// Depth maps (16-bit PNGs in `DEPTH_SCALE` units).
pub(crate) const DEPTH: ImageFiles = ImageFiles {
    folder: "depth",
    list: "depth.txt",
};
/// Instance masks (16-bit ids of labels.json's instances).
pub(crate) const INSTANCE: ImageFiles = ImageFiles {
    folder: "instance",
    list: "instance.txt",
};
/// Semantic masks (16-bit ids of labels.json's classes).
pub(crate) const SEMANTIC: ImageFiles = ImageFiles {
    folder: "semantic",
    list: "semantic.txt",
};
/// The camera poses, TUM format.
pub(crate) const GROUNDTRUTH: &str = "groundtruth.txt";
/// nerfstudio's frame list.
pub(crate) const TRANSFORMS: &str = "transforms.json";
/// The intrinsics ([`CameraFile`]).
pub(crate) const CAMERA: &str = "camera.json";
/// The instances and classes the masks' ids refer to.
pub(crate) const LABELS: &str = "labels.json";

/// The files of a dataset that hold or name its images: the image folders, their TUM lists
/// and transforms.json.
pub const FRAME_FILES: [&str; 9] = [
    RGB.folder,
    DEPTH.folder,
    INSTANCE.folder,
    SEMANTIC.folder,
    RGB.list,
    DEPTH.list,
    INSTANCE.list,
    SEMANTIC.list,
    TRANSFORMS,
];

/// Removes a finished episode's images and every list that names them (`FRAME_FILES`),
/// keeping what its numbers and poses are (metrics.json, episode.json, groundtruth.txt,
/// camera.json, the maps): a benchmark sweep reads none of the images, which are most of an
/// episode's bytes (about 0.2 GB at 320x240 for 300 s). A folder without them is no longer a
/// dataset: `Dataset::open` refuses it, saying why. Returns the bytes freed.
pub fn remove_frames(dir: &Path) -> Result<u64> {
    let mut freed = 0;
    for name in FRAME_FILES {
        let path = dir.join(name);
        let Ok(meta) = std::fs::symlink_metadata(&path) else {
            continue;
        };
        if meta.is_dir() {
            freed += folder_bytes(&path);
            std::fs::remove_dir_all(&path).map_err(|e| SimError::io("cannot remove", &path, e))?;
        } else {
            freed += meta.len();
            std::fs::remove_file(&path).map_err(|e| SimError::io("cannot remove", &path, e))?;
        }
    }
    Ok(freed)
}

/// The bytes of the files directly in `dir` (the image folders are flat).
fn folder_bytes(dir: &Path) -> u64 {
    std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .filter_map(|e| e.ok()?.metadata().ok())
                .map(|m| m.len())
                .sum()
        })
        .unwrap_or(0)
}

/// Refuses to write `out` when it exists and `overwrite` is not set, and always when it is one
/// of the command's `inputs` or holds one (a folder): no command writes over what it reads.
pub fn refuse_overwrite(out: &Path, overwrite: bool, inputs: &[&Path]) -> Result<()> {
    let resolved = |p: &Path| std::fs::canonicalize(p).ok();
    if let Some(target) = resolved(out) {
        for input in inputs {
            if let Some(input) = resolved(input) {
                if input.starts_with(&target) {
                    return Err(SimError::InvalidArgument {
                        what: "output",
                        detail: format!(
                            "{} would overwrite this command's own input {}; choose another output",
                            out.display(),
                            input.display()
                        ),
                    });
                }
            }
        }
        if !overwrite {
            return Err(SimError::InvalidArgument {
                what: "output",
                detail: format!("{} exists; pass --overwrite to replace it", out.display()),
            });
        }
    }
    Ok(())
}

/// Where a run into `out` keeps its frames until the episode is complete (to tell a user
/// whose run failed where its work is).
pub fn staging_folder(out: &Path) -> Option<std::path::PathBuf> {
    place::Places::resolve(out).ok().map(|p| p.staging)
}

/// Refuses two outputs of one command that name the same file (`--out X --surface-out X`):
/// the second would silently replace the first.
pub fn refuse_same_outputs(outputs: &[(&'static str, &Path)]) -> Result<()> {
    // Compared as the OS would resolve them: the parent's real path and the name.
    let resolved = |p: &Path| -> Option<std::path::PathBuf> {
        let parent = p
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        Some(std::fs::canonicalize(parent).ok()?.join(p.file_name()?))
    };
    for (i, (first, a)) in outputs.iter().enumerate() {
        for (second, b) in &outputs[i + 1..] {
            let same = match (resolved(a), resolved(b)) {
                (Some(x), Some(y)) => x == y,
                _ => a == b,
            };
            if same {
                return Err(SimError::InvalidArgument {
                    what: "output",
                    detail: format!(
                        "{first} and {second} both name {}; give each its own file",
                        a.display()
                    ),
                });
            }
        }
    }
    Ok(())
}

/// Writes points with 8-bit colours as a binary PLY (x y z red green blue): the coloured point
/// cloud nerfstudio's `ply_file_path` names, read by Open3D and every PLY viewer.
pub fn write_point_cloud(path: &Path, points: &[[f32; 3]], colours: &[[f32; 3]]) -> Result<()> {
    use std::io::Write;
    let io = |e: std::io::Error| SimError::io("cannot write", path, e);
    let file = std::fs::File::create(path).map_err(io)?;
    let mut out = std::io::BufWriter::new(file);
    let n = points.len().min(colours.len());
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
    )
    .map_err(io)?;
    for (p, c) in points.iter().zip(colours).take(n) {
        for v in p {
            out.write_all(&v.to_le_bytes()).map_err(io)?;
        }
        let byte = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        out.write_all(&[byte(c[0]), byte(c[1]), byte(c[2])])
            .map_err(io)?;
    }
    out.flush().map_err(io)
}
