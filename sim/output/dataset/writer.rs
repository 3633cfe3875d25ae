//! Writes an episode folder frame by frame, so that nothing is lost:
//! - the new episode is written into a staging folder beside the target (`.NAME.partial`) and
//!   takes the target's place only in `finish`, so a run that fails leaves an earlier episode
//!   as it was;
//! - every list (rgb.txt, depth.txt, instance.txt and semantic.txt with masks, groundtruth.txt,
//!   transforms.json's frames) is written and flushed after its frame's images, so the counts
//!   always agree; camera.json is written with the first frame, labels.json before it;
//! - `--overwrite` replaces only what an earlier splatloop run wrote (the manifest in its
//!   episode.json) and refuses, naming them, when the folder holds anything else; `finish`
//!   checks again, since a user may add files while the episode runs, and then writes the new
//!   episode beside the target instead (and says so, as an error);
//! - an interrupted episode never replaces a complete one: it is written beside it;
//! - a staging folder with no frame in it is removed when the writer is dropped unfinished;
//! - a lock file beside the target (`.NAME.lock`, an OS lock the kernel drops when the process
//!   dies) refuses a second run into the same folder.
//!
//! Where these files live, mount points and the recovery of a run that died in `finish`:
//! `place`.

use super::place::{files_under, Places};
use super::{
    write_depth_png, write_mask_png, write_rgb_png, CameraFile, CAMERA, DEPTH, DEPTH_SCALE,
    GROUNDTRUTH, INSTANCE, LABELS, RGB, SEMANTIC, TRANSFORMS,
};
use crate::camera::RgbdFrame;
use crate::error::{Result, SimError};
use crate::labels::Labels;
use autonomy::math::Isometry3;
use nalgebra::Matrix4;
use serde::Serialize;
use std::fs::{self, File};
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// What closes transforms.json after the last frame written so far.
const TRANSFORMS_TAIL: &str = "\n  ]\n}\n";

/// Streams frames into an episode folder.
pub struct DatasetWriter {
    /// The staging folder everything is written into.
    dir: PathBuf,
    /// Where the episode goes and what surrounds it.
    places: Places,
    /// Whether the run may replace an earlier episode.
    overwrite: bool,
    /// `finish` ran (else the drop clears a staging folder without frames).
    finished: bool,
    /// Held for the writer's life; the OS releases it if the process dies.
    _lock: FolderLock,
    rgb_txt: BufWriter<File>,
    depth_txt: BufWriter<File>,
    groundtruth_txt: BufWriter<File>,
    /// transforms.json, valid JSON after every frame; `transforms_end` is where its tail starts.
    transforms: Option<File>,
    transforms_end: u64,
    camera: Option<CameraFile>,
    max_range: f64,
    frames: usize,
    /// Frames after which every write fails (fault injection for the tests of this module's
    /// promises).
    fail_after: Option<usize>,
    /// The point cloud transforms.json names (the caller writes it).
    point_cloud: Option<String>,
    /// The masks' labels and lists, when the frames carry masks.
    masks: Option<MaskFiles>,
}

/// The masks' share of the folder: labels.json (written once), `instance/` and `semantic/`
/// PNGs and their lists.
struct MaskFiles {
    labels: Arc<Labels>,
    instance_txt: BufWriter<File>,
    semantic_txt: BufWriter<File>,
}

#[derive(Serialize)]
struct TransformFrame {
    file_path: String,
    depth_file_path: String,
    transform_matrix: [[f64; 4]; 4],
    timestamp: f64,
}

/// nerfstudio's transforms.json: OpenGL camera axes, pixel centres at +0.5.
#[derive(Serialize)]
struct TransformsFile<'a> {
    camera_model: &'static str,
    fl_x: f64,
    fl_y: f64,
    cx: f64,
    cy: f64,
    w: u32,
    h: u32,
    k1: f64,
    k2: f64,
    p1: f64,
    p2: f64,
    depth_unit_scale_factor: f64,
    /// A coloured point cloud beside it, which nerfstudio's splatfacto starts from.
    #[serde(skip_serializing_if = "Option::is_none")]
    ply_file_path: Option<&'a str>,
    frames: &'a [TransformFrame],
}

/// The lock on an output folder: an OS lock on a file beside it, released (and the file
/// removed) when the writer is dropped, and released by the kernel if the process dies.
struct FolderLock {
    file: File,
    path: PathBuf,
}

impl Drop for FolderLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
        let _ = self.file.unlock();
    }
}

impl DatasetWriter {
    /// Starts an episode for `dir`: takes the lock, checks that an existing folder may be
    /// replaced (see the module), and opens the staging folder.
    pub fn create(dir: &Path, max_range: f64, overwrite: bool) -> Result<Self> {
        if let Some(parent) = dir.parent().filter(|p| !p.as_os_str().is_empty()) {
            fs::create_dir_all(parent).map_err(|e| SimError::io("cannot create", parent, e))?;
        }
        let places = Places::resolve(dir)?;
        let lock_path = places.lock.clone();
        let lock =
            File::create(&lock_path).map_err(|e| SimError::io("cannot create", &lock_path, e))?;
        if let Err(e) = lock.try_lock() {
            return Err(match e {
                std::fs::TryLockError::WouldBlock => SimError::InvalidArgument {
                    what: "output folder",
                    detail: format!("another splatloop run is writing {}; wait for it to end or choose another --out", dir.display()),
                },
                std::fs::TryLockError::Error(e) => SimError::io("cannot lock", &lock_path, e),
            });
        }
        // A lock taken on a file another run just removed guards nothing: it must still be
        // the file at the path.
        {
            use std::os::unix::fs::MetadataExt;
            let held = lock.metadata().map(|m| m.ino()).ok();
            let at_path = fs::metadata(&lock_path).map(|m| m.ino()).ok();
            if held.is_none() || held != at_path {
                return Err(SimError::InvalidArgument {
                    what: "output folder",
                    detail: format!(
                        "another splatloop run was writing {} just now; try again",
                        dir.display()
                    ),
                });
            }
        }
        let lock = FolderLock {
            file: lock,
            path: lock_path,
        };
        for done in places.recover()? {
            tracing::warn!("{done}");
        }
        places.check_target(overwrite)?;
        // A staging folder left by a run that was killed: ours to clear, since we hold the lock.
        let staging = places.staging.clone();
        if staging.exists() {
            fs::remove_dir_all(&staging).map_err(|e| SimError::io("cannot remove", &staging, e))?;
        }
        for sub in [RGB.folder, DEPTH.folder] {
            let path = staging.join(sub);
            fs::create_dir_all(&path).map_err(|e| SimError::io("cannot create", &path, e))?;
        }
        let open = |name: &str, header: &str| open_list(&staging, name, header);
        Ok(DatasetWriter {
            rgb_txt: open(RGB.list, "# color images\n# file: splatloop\n# timestamp filename\n")?,
            depth_txt: open(DEPTH.list, "# depth maps\n# file: splatloop\n# timestamp filename\n")?,
            groundtruth_txt: open(
                GROUNDTRUTH,
                "# ground truth trajectory (camera-to-world, OpenCV optical frame)\n# file: splatloop\n# timestamp tx ty tz qx qy qz qw\n",
            )?,
            dir: staging,
            places,
            overwrite,
            finished: false,
            _lock: lock,
            transforms: None,
            transforms_end: 0,
            camera: None,
            max_range,
            frames: 0,
            fail_after: None,
            point_cloud: None,
            masks: None,
        })
    }

    /// Writes `labels.json` and makes every frame's instance and semantic masks part of the
    /// dataset; call before the first frame, whose masks must then come with every frame.
    pub fn write_labels(&mut self, labels: Arc<Labels>) -> Result<()> {
        if self.frames > 0 || self.masks.is_some() {
            return Err(SimError::InvalidArgument {
                what: "labels",
                detail: "a dataset's labels are written once, before its first frame".into(),
            });
        }
        for sub in [INSTANCE.folder, SEMANTIC.folder] {
            let path = self.dir.join(sub);
            fs::create_dir_all(&path).map_err(|e| SimError::io("cannot create", &path, e))?;
        }
        write_json(&self.dir.join(LABELS), labels.as_ref())?;
        self.masks = Some(MaskFiles {
            labels,
            instance_txt: open_list(
                &self.dir,
                INSTANCE.list,
                "# instance masks (16-bit ids of labels.json's instances, 0 = nothing)\n# file: splatloop\n# timestamp filename\n",
            )?,
            semantic_txt: open_list(
                &self.dir,
                SEMANTIC.list,
                "# semantic masks (16-bit ids of labels.json's classes, 0 = nothing)\n# file: splatloop\n# timestamp filename\n",
            )?,
        });
        Ok(())
    }

    /// Names the coloured point cloud (a PLY beside transforms.json) that transforms.json
    /// points nerfstudio to; call before the first frame. The caller writes the file.
    pub fn name_point_cloud(&mut self, file: &str) {
        self.point_cloud = Some(file.to_owned());
    }

    /// Makes every write fail once `frames` frames are written, as a full disk would.
    pub fn fail_writes_after(&mut self, frames: usize) {
        self.fail_after = Some(frames);
    }

    fn check_fault(&self, path: &Path) -> Result<()> {
        match self.fail_after {
            Some(n) if self.frames >= n => Err(SimError::io(
                "cannot write",
                path,
                std::io::Error::other("no space left on device (injected)"),
            )),
            _ => Ok(()),
        }
    }

    /// The folder files are written into now (the staging folder until `finish`).
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The folder the episode ends up in (absolute).
    pub fn target(&self) -> &Path {
        &self.places.target
    }

    /// Frames written so far.
    pub fn frame_count(&self) -> usize {
        self.frames
    }

    /// Writes one frame's PNGs, then its line in every list, flushed.
    pub fn write_frame(&mut self, frame: &RgbdFrame) -> Result<()> {
        let k = frame.camera.intrinsics;
        match &self.camera {
            None => {
                let camera = CameraFile::new(&k, self.max_range);
                write_json(&self.dir.join(CAMERA), &camera)?;
                self.camera = Some(camera);
            }
            Some(c) if c.intrinsics() != k => {
                return Err(SimError::InvalidArgument {
                    what: "frame",
                    detail: "every frame of a dataset must share one camera".into(),
                })
            }
            Some(_) => {}
        }
        let name = format!("{:06}.png", self.frames);
        let rgb_rel = RGB.entry(&name);
        let depth_rel = DEPTH.entry(&name);
        self.check_fault(&self.dir.join(&rgb_rel))?;
        let masks = match (&self.masks, frame.instance.is_empty()) {
            (Some(masks), false) if frame.instance.len() == k.pixel_count() => Some((
                INSTANCE.entry(&name),
                SEMANTIC.entry(&name),
                masks.labels.semantic(&frame.instance),
            )),
            (Some(_), false) => {
                return Err(SimError::InvalidArgument {
                    what: "frame",
                    detail: format!(
                        "its instance mask has {} pixels, its images {}",
                        frame.instance.len(),
                        k.pixel_count()
                    ),
                })
            }
            (None, true) => None,
            (Some(_), true) => {
                return Err(SimError::InvalidArgument {
                    what: "frame",
                    detail: "this dataset has masks, and the frame came without them".into(),
                })
            }
            (None, false) => {
                return Err(SimError::InvalidArgument {
                    what: "frame",
                    detail: "a frame with masks needs the dataset's labels first (write_labels)"
                        .into(),
                })
            }
        };
        // The frame's PNGs are encoded side by side (the camera waits for them; the pool is
        // idle while it does); any failure is the frame's.
        let dir = &self.dir;
        let (images, mask_images) = rayon::join(
            || {
                rayon::join(
                    || write_rgb_png(&dir.join(&rgb_rel), k.width, k.height, &frame.rgb),
                    || write_depth_png(&dir.join(&depth_rel), k.width, k.height, &frame.depth),
                )
            },
            || match &masks {
                Some((instance_rel, semantic_rel, semantic)) => rayon::join(
                    || write_mask_png(&dir.join(instance_rel), k.width, k.height, &frame.instance),
                    || write_mask_png(&dir.join(semantic_rel), k.width, k.height, semantic),
                ),
                None => (Ok(()), Ok(())),
            },
        );
        images.0?;
        images.1?;
        mask_images.0?;
        mask_images.1?;
        let stamp = format!("{:.6}", frame.time);
        let pose = &frame.camera.world_from_camera;
        let (t, q) = (pose.translation.vector, pose.rotation);
        let mut lines = vec![
            (&mut self.rgb_txt, format!("{stamp} {rgb_rel}\n"), RGB.list),
            (
                &mut self.depth_txt,
                format!("{stamp} {depth_rel}\n"),
                DEPTH.list,
            ),
        ];
        if let (Some(files), Some((instance_rel, semantic_rel, _))) = (&mut self.masks, &masks) {
            lines.push((
                &mut files.instance_txt,
                format!("{stamp} {instance_rel}\n"),
                INSTANCE.list,
            ));
            lines.push((
                &mut files.semantic_txt,
                format!("{stamp} {semantic_rel}\n"),
                SEMANTIC.list,
            ));
        }
        lines.push((
            &mut self.groundtruth_txt,
            format!(
                "{stamp} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9}\n",
                t.x, t.y, t.z, q.i, q.j, q.k, q.w
            ),
            GROUNDTRUTH,
        ));
        for (file, line, name) in lines {
            file.write_all(line.as_bytes())
                .and_then(|()| file.flush())
                .map_err(|e| SimError::io("cannot write", self.dir.join(name), e))?;
        }
        let entry = TransformFrame {
            file_path: rgb_rel,
            depth_file_path: depth_rel,
            transform_matrix: opengl_matrix(pose),
            timestamp: frame.time,
        };
        self.append_transform(&entry)?;
        self.frames += 1;
        Ok(())
    }

    /// Appends a frame to transforms.json in place: the file is rewritten from where its tail
    /// began, so it is whole JSON after every frame.
    fn append_transform(&mut self, entry: &TransformFrame) -> Result<()> {
        let path = self.dir.join(TRANSFORMS);
        let io = |e: std::io::Error| SimError::io("cannot write", &path, e);
        let mut text = String::new();
        if self.transforms.is_none() {
            let k = self
                .camera
                .as_ref()
                .map(CameraFile::intrinsics)
                .ok_or_else(|| io(std::io::Error::other("no camera yet")))?;
            let header = TransformsFile {
                camera_model: "OPENCV",
                fl_x: k.fx,
                fl_y: k.fy,
                // nerfstudio puts pixel centres at +0.5.
                cx: k.cx + 0.5,
                cy: k.cy + 0.5,
                w: k.width,
                h: k.height,
                k1: 0.0,
                k2: 0.0,
                p1: 0.0,
                p2: 0.0,
                depth_unit_scale_factor: 1.0 / DEPTH_SCALE,
                ply_file_path: self.point_cloud.as_deref(),
                frames: &[],
            };
            let json =
                serde_json::to_string_pretty(&header).map_err(|e| io(std::io::Error::other(e)))?;
            // `"frames": []` closes the pretty text: reopen the list.
            let open = json
                .strip_suffix("[]\n}")
                .or_else(|| json.strip_suffix("[]}"))
                .ok_or_else(|| io(std::io::Error::other("unexpected JSON layout")))?;
            text.push_str(open);
            text.push_str("[\n");
            self.transforms = Some(File::create(&path).map_err(io)?);
            self.transforms_end = 0;
        } else {
            text.push_str(",\n");
        }
        let item = serde_json::to_string_pretty(entry).map_err(|e| io(std::io::Error::other(e)))?;
        for line in item.lines() {
            text.push_str("    ");
            text.push_str(line);
            text.push('\n');
        }
        text.pop();
        let file = self
            .transforms
            .as_mut()
            .ok_or_else(|| io(std::io::Error::other("not open")))?;
        file.seek(SeekFrom::Start(self.transforms_end))
            .map_err(io)?;
        file.write_all(text.as_bytes()).map_err(io)?;
        self.transforms_end += text.len() as u64;
        file.write_all(TRANSFORMS_TAIL.as_bytes()).map_err(io)?;
        file.flush().map_err(io)
    }

    /// Writes `episode.json` (whatever the caller records: config, seed, versions, plus the
    /// manifest of every file of the episode) and puts the episode in its folder: the earlier
    /// one there is moved aside, the new one moved into place, the old one deleted. An
    /// `interrupted` episode does not replace a complete one: it is kept beside it, with a
    /// warning. When the target gained files splatloop did not write while the episode ran (or
    /// appeared without `--overwrite`), the episode is kept beside it and the error says where.
    /// Returns where the episode is.
    pub fn finish(mut self, episode: &impl Serialize, interrupted: bool) -> Result<PathBuf> {
        let episode_path = self.dir.join("episode.json");
        self.check_fault(&episode_path)?;
        let mut record = serde_json::to_value(episode).map_err(|e| {
            SimError::io("cannot serialise", &episode_path, std::io::Error::other(e))
        })?;
        let mut files = files_under(&self.dir)?;
        files.push("episode.json".into());
        files.sort();
        files.dedup();
        if let serde_json::Value::Object(map) = &mut record {
            map.insert("files".into(), serde_json::json!(files));
        }
        write_json(&episode_path, &record)?;
        self.finished = true;
        let places = &self.places;
        if interrupted && places.target_complete() {
            let beside = places.keep_beside("interrupted")?;
            tracing::warn!(
                "the episode was interrupted, so it did not replace the complete one in {}: it is in {}",
                places.target.display(),
                beside.display()
            );
            return Ok(beside);
        }
        if let Err(refused) = places.check_target(self.overwrite) {
            let beside = places.keep_beside("new")?;
            return Err(SimError::WrittenBeside {
                path: beside,
                reason: Box::new(refused),
            });
        }
        places.swap_in()?;
        Ok(places.target.clone())
    }
}

impl Drop for DatasetWriter {
    /// A writer dropped before `finish` (the episode failed to start or to run) leaves its
    /// staging folder for the next run to clear only when it holds frames; an empty one is
    /// removed now.
    fn drop(&mut self) {
        if !self.finished && self.frames == 0 {
            let _ = fs::remove_dir_all(&self.dir);
        }
    }
}

/// Creates a list file of the dataset with its header, flushed.
fn open_list(dir: &Path, name: &str, header: &str) -> Result<BufWriter<File>> {
    let path = dir.join(name);
    let mut file =
        BufWriter::new(File::create(&path).map_err(|e| SimError::io("cannot create", &path, e))?);
    file.write_all(header.as_bytes())
        .and_then(|()| file.flush())
        .map_err(|e| SimError::io("cannot write", &path, e))?;
    Ok(file)
}

/// world_from_camera with OpenGL camera axes (x right, y up, z backward), as nerfstudio wants.
fn opengl_matrix(world_from_camera: &Isometry3) -> [[f64; 4]; 4] {
    let flip = Matrix4::from_diagonal(&nalgebra::Vector4::new(1.0, -1.0, -1.0, 1.0));
    let m = world_from_camera.to_homogeneous() * flip;
    std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]))
}

/// Writes pretty JSON with a trailing newline.
pub(crate) fn write_json(path: &Path, value: &impl Serialize) -> Result<()> {
    let mut text = serde_json::to_string_pretty(value)
        .map_err(|e| SimError::io("cannot serialise", path, std::io::Error::other(e)))?;
    text.push('\n');
    fs::write(path, text).map_err(|e| SimError::io("cannot write", path, e))
}
