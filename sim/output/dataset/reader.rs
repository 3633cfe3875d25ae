//! Reads an episode folder back: the camera, the poses, and each frame's images.

use super::{read_depth_png, read_rgb_png, CameraFile};
use crate::camera::RgbdFrame;
use crate::error::{Result, SimError};
use autonomy::camera::PinholeCamera;
use autonomy::math::{Isometry3, UnitQuaternion, Vector3};
use nalgebra::{Quaternion, Translation3};
use std::path::{Path, PathBuf};

/// One entry of the dataset: time, pose and image files.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetFrame {
    /// Timestamp, seconds.
    pub time: f64,
    /// Pose of the optical frame.
    pub world_from_camera: Isometry3,
    /// RGB file, relative to the folder.
    pub rgb: PathBuf,
    /// Depth file, relative to the folder.
    pub depth: PathBuf,
}

/// An episode folder opened for reading.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// The folder.
    pub dir: PathBuf,
    /// camera.json.
    pub camera: CameraFile,
    /// Frames in time order.
    pub frames: Vec<DatasetFrame>,
}

impl Dataset {
    /// Opens a folder written by [`super::DatasetWriter`] (or any TUM folder with camera.json).
    pub fn open(dir: &Path) -> Result<Self> {
        let camera = CameraFile::read(&dir.join("camera.json"))?;
        let rgb = read_list(&dir.join("rgb.txt"), 1)?;
        let depth = read_list(&dir.join("depth.txt"), 1)?;
        let poses = read_trajectory(&dir.join("groundtruth.txt"))?;
        let (mut rgb, mut depth, mut poses) = (rgb, depth, poses);
        // A run killed between two lists' lines leaves the last frame in some lists only:
        // that torn frame is skipped, anything else is a damaged dataset.
        let least = rgb.len().min(depth.len()).min(poses.len());
        let most = rgb.len().max(depth.len()).max(poses.len());
        if most == least + 1 {
            tracing::warn!(
                "{}: the last frame is torn ({} rgb, {} depth, {} pose lines; the run was stopped while writing it): reading the {least} whole frames",
                dir.display(),
                rgb.len(),
                depth.len(),
                poses.len()
            );
            rgb.truncate(least);
            depth.truncate(least);
            poses.truncate(least);
        }
        if rgb.len() != depth.len() || rgb.len() != poses.len() {
            return Err(SimError::BadDataset {
                path: dir.to_owned(),
                detail: format!(
                    "{} rgb, {} depth and {} pose lines do not match",
                    rgb.len(),
                    depth.len(),
                    poses.len()
                ),
            });
        }
        let frames = rgb
            .into_iter()
            .zip(depth)
            .zip(poses)
            .map(|(((time, rgb), (_, depth)), (_, pose))| DatasetFrame {
                time,
                world_from_camera: pose,
                rgb: PathBuf::from(&rgb[0]),
                depth: PathBuf::from(&depth[0]),
            })
            .collect();
        Ok(Dataset {
            dir: dir.to_owned(),
            camera,
            frames,
        })
    }

    /// Loads frame `index`'s images.
    pub fn load(&self, index: usize) -> Result<RgbdFrame> {
        let entry = self
            .frames
            .get(index)
            .ok_or_else(|| SimError::InvalidArgument {
                what: "frame index",
                detail: format!("{index} >= {} frames", self.frames.len()),
            })?;
        let (w, h, rgb) = read_rgb_png(&self.dir.join(&entry.rgb))?;
        let (dw, dh, depth) = read_depth_png(&self.dir.join(&entry.depth))?;
        let k = self.camera.intrinsics();
        if (w, h) != (k.width, k.height) || (dw, dh) != (k.width, k.height) {
            return Err(SimError::BadDataset {
                path: self.dir.join(&entry.rgb),
                detail: format!(
                    "images are not {}x{} as camera.json says",
                    k.width, k.height
                ),
            });
        }
        Ok(RgbdFrame {
            time: entry.time,
            rgb,
            depth,
            camera: PinholeCamera {
                intrinsics: k,
                world_from_camera: entry.world_from_camera,
            },
        })
    }
}

/// Reads `timestamp field...` lines, skipping comments.
fn read_list(path: &Path, fields: usize) -> Result<Vec<(f64, Vec<String>)>> {
    let text = std::fs::read_to_string(path).map_err(|e| SimError::io("cannot read", path, e))?;
    let mut rows = Vec::new();
    let count = text.lines().count();
    for (n, line) in text.lines().enumerate() {
        // A last line without its newline was being written when the run stopped.
        let torn = n + 1 == count && !text.ends_with('\n');
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut parts = line.split_whitespace();
        let bad = || SimError::BadDataset {
            path: path.to_owned(),
            detail: format!("line {}: expected a timestamp and {fields} fields", n + 1),
        };
        let time = parts.next().and_then(|t| t.parse::<f64>().ok());
        if let Some(time) = time.filter(|t| !t.is_finite()) {
            return Err(SimError::BadDataset {
                path: path.to_owned(),
                detail: format!(
                    "line {}: the timestamp {time} is not a number of seconds",
                    n + 1
                ),
            });
        }
        let rest: Vec<String> = parts.map(str::to_owned).collect();
        let Some(time) = time.filter(|_| rest.len() == fields) else {
            if torn {
                tracing::warn!("{}: skipping the torn last line {}", path.display(), n + 1);
                break;
            }
            return Err(bad());
        };
        rows.push((time, rest));
    }
    Ok(rows)
}

/// Reads a TUM trajectory (`timestamp tx ty tz qx qy qz qw`).
pub fn read_trajectory(path: &Path) -> Result<Vec<(f64, Isometry3)>> {
    read_list(path, 7)?
        .into_iter()
        .map(|(time, fields)| {
            let v: Vec<f64> = fields
                .iter()
                .map(|f| f.parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|e| SimError::BadDataset {
                    path: path.to_owned(),
                    detail: format!("at t = {time}: {e}"),
                })?;
            let q = Quaternion::new(v[6], v[3], v[4], v[5]);
            if !v.iter().all(|x| x.is_finite()) || q.norm() < 1e-6 {
                return Err(SimError::BadDataset {
                    path: path.to_owned(),
                    detail: format!(
                        "the pose at t = {time} is not a pose (NaN, infinite, or a zero quaternion): {fields:?}"
                    ),
                });
            }
            let rotation = UnitQuaternion::from_quaternion(q);
            Ok((
                time,
                Isometry3::from_parts(Translation3::from(Vector3::new(v[0], v[1], v[2])), rotation),
            ))
        })
        .collect()
}
