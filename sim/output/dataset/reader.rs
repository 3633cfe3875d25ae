//! Reads an episode folder back: the camera, the poses, each frame's images and, in a
//! dataset written with masks, its labels and each frame's instance and semantic masks
//! (datasets written before masks existed read as before, without them).

use super::{
    read_depth_png, read_mask_png, read_rgb_png, CameraFile, CAMERA, DEPTH, GROUNDTRUTH, INSTANCE,
    LABELS, RGB, SEMANTIC,
};
use crate::camera::RgbdFrame;
use crate::error::{Result, SimError};
use crate::labels::Labels;
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
    /// Instance and semantic mask files, relative to the folder (a dataset with masks).
    pub masks: Option<(PathBuf, PathBuf)>,
}

/// An episode folder opened for reading.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// The folder.
    pub dir: PathBuf,
    /// camera.json.
    pub camera: CameraFile,
    /// labels.json, in a dataset written with masks.
    pub labels: Option<Labels>,
    /// Frames in time order.
    pub frames: Vec<DatasetFrame>,
}

impl Dataset {
    /// Opens a folder written by [`super::DatasetWriter`] (or any TUM folder with camera.json).
    pub fn open(dir: &Path) -> Result<Self> {
        let camera = CameraFile::read(&dir.join(CAMERA))?;
        if !dir.join(RGB.list).exists() && dir.join("metrics.json").exists() {
            return Err(SimError::BadDataset {
                path: dir.to_owned(),
                detail: "an episode folder without its images (no rgb.txt): a sweep run with \
                         --keep-frames false removes them once the episode is complete; rerun \
                         the episode, or the sweep in a new folder, to have them"
                    .into(),
            });
        }
        let labels_path = dir.join(LABELS);
        let labels: Option<Labels> = if labels_path.exists() {
            let text = std::fs::read_to_string(&labels_path)
                .map_err(|e| SimError::io("cannot read", &labels_path, e))?;
            Some(
                serde_json::from_str(&text).map_err(|e| SimError::BadDataset {
                    path: labels_path.clone(),
                    detail: format!("{e}; expected the labels.json of a splatloop dataset"),
                })?,
            )
        } else {
            None
        };
        let mut kinds = vec![RGB, DEPTH];
        if labels.is_some() {
            kinds.extend([INSTANCE, SEMANTIC]);
        }
        let mut lists = kinds
            .iter()
            .map(|kind| read_list(&dir.join(kind.list), 1))
            .collect::<Result<Vec<_>>>()?;
        let mut poses = read_trajectory(&dir.join(GROUNDTRUTH))?;
        let counts: Vec<usize> = lists.iter().map(Vec::len).chain([poses.len()]).collect();
        let least = counts.iter().copied().min().unwrap_or(0);
        let most = counts.iter().copied().max().unwrap_or(0);
        let described = || {
            kinds
                .iter()
                .map(|kind| kind.folder)
                .chain(["pose"])
                .zip(&counts)
                .map(|(name, count)| format!("{count} {name}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        // A run killed between two lists' lines leaves the last frame in some lists only:
        // that torn frame is skipped, anything else is a damaged dataset.
        if most == least + 1 {
            tracing::warn!(
                "{}: the last frame is torn ({} lines; the run was stopped while writing it): reading the {least} whole frames",
                dir.display(),
                described()
            );
            for list in &mut lists {
                list.truncate(least);
            }
            poses.truncate(least);
        } else if most != least {
            return Err(SimError::BadDataset {
                path: dir.to_owned(),
                detail: format!("{} lines do not match", described()),
            });
        }
        let file = |list: usize, frame: usize| PathBuf::from(&lists[list][frame].1[0]);
        let frames = poses
            .iter()
            .enumerate()
            .map(|(i, &(_, pose))| DatasetFrame {
                time: lists[0][i].0,
                world_from_camera: pose,
                rgb: file(0, i),
                depth: file(1, i),
                masks: (lists.len() == 4).then(|| (file(2, i), file(3, i))),
            })
            .collect();
        Ok(Dataset {
            dir: dir.to_owned(),
            camera,
            labels,
            frames,
        })
    }

    fn entry(&self, index: usize) -> Result<&DatasetFrame> {
        self.frames
            .get(index)
            .ok_or_else(|| SimError::InvalidArgument {
                what: "frame index",
                detail: format!("{index} >= {} frames", self.frames.len()),
            })
    }

    /// Checks an image's size against camera.json.
    fn check_size(&self, file: &Path, (w, h): (u32, u32)) -> Result<()> {
        let k = self.camera.intrinsics();
        if (w, h) != (k.width, k.height) {
            return Err(SimError::BadDataset {
                path: self.dir.join(file),
                detail: format!(
                    "the image is {w}x{h}, not {}x{} as camera.json says",
                    k.width, k.height
                ),
            });
        }
        Ok(())
    }

    /// Loads frame `index`'s images (its instance mask too, in a dataset with masks).
    pub fn load(&self, index: usize) -> Result<RgbdFrame> {
        let entry = self.entry(index)?;
        let (w, h, rgb) = read_rgb_png(&self.dir.join(&entry.rgb))?;
        self.check_size(&entry.rgb, (w, h))?;
        let (w, h, depth) = read_depth_png(&self.dir.join(&entry.depth))?;
        self.check_size(&entry.depth, (w, h))?;
        let instance = match self.load_masks(index)? {
            Some((instance, _)) => instance,
            None => Vec::new(),
        };
        Ok(RgbdFrame {
            time: entry.time,
            rgb,
            depth,
            camera: PinholeCamera {
                intrinsics: self.camera.intrinsics(),
                world_from_camera: entry.world_from_camera,
            },
            instance,
        })
    }

    /// Loads frame `index`'s instance and semantic masks (`None` in a dataset without masks).
    pub fn load_masks(&self, index: usize) -> Result<Option<(Vec<u16>, Vec<u16>)>> {
        let entry = self.entry(index)?;
        let Some((instance_file, semantic_file)) = &entry.masks else {
            return Ok(None);
        };
        let (w, h, instance) = read_mask_png(&self.dir.join(instance_file))?;
        self.check_size(instance_file, (w, h))?;
        let (w, h, semantic) = read_mask_png(&self.dir.join(semantic_file))?;
        self.check_size(semantic_file, (w, h))?;
        Ok(Some((instance, semantic)))
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
