//! Writes an episode folder frame by frame; the index files are streamed so a crash keeps
//! every frame written so far.

use super::{write_depth_png, write_rgb_png, CameraFile, DEPTH_SCALE};
use crate::camera::RgbdFrame;
use crate::error::{Result, SimError};
use autonomy::math::Isometry3;
use nalgebra::Matrix4;
use serde::Serialize;
use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Streams frames into an episode folder.
pub struct DatasetWriter {
    dir: PathBuf,
    rgb_txt: BufWriter<File>,
    depth_txt: BufWriter<File>,
    groundtruth_txt: BufWriter<File>,
    transforms: Vec<TransformFrame>,
    camera: Option<CameraFile>,
    max_range: f64,
    frames: usize,
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
    frames: &'a [TransformFrame],
}

impl DatasetWriter {
    /// Creates the folder layout. A folder that already holds files is refused so nothing is
    /// lost, unless `overwrite` is set and it is a splatloop dataset (it has episode.json).
    pub fn create(dir: &Path, max_range: f64, overwrite: bool) -> Result<Self> {
        if dir.exists() {
            let occupied = fs::read_dir(dir)
                .map_err(|e| SimError::io("cannot read", dir, e))?
                .next()
                .is_some();
            let is_dataset = dir.join("episode.json").is_file();
            if occupied && !(overwrite && is_dataset) {
                let hint = if overwrite {
                    "it is not a splatloop dataset (no episode.json), so --overwrite leaves it alone"
                } else {
                    "choose a new --out, or pass --overwrite to replace a dataset"
                };
                return Err(SimError::InvalidArgument {
                    what: "output folder",
                    detail: format!("{} is not empty; {hint}", dir.display()),
                });
            }
            if occupied {
                fs::remove_dir_all(dir).map_err(|e| SimError::io("cannot remove", dir, e))?;
            }
        }
        for sub in ["rgb", "depth"] {
            let path = dir.join(sub);
            fs::create_dir_all(&path).map_err(|e| SimError::io("cannot create", &path, e))?;
        }
        // Marks the folder as ours from the start, so a run that is interrupted can be
        // replaced with --overwrite; `finish` writes the real record over it.
        write_json(
            &dir.join("episode.json"),
            &serde_json::json!({ "status": "incomplete: the run that wrote this did not finish" }),
        )?;
        let open = |name: &str, header: &str| -> Result<BufWriter<File>> {
            let path = dir.join(name);
            let mut file = BufWriter::new(
                File::create(&path).map_err(|e| SimError::io("cannot create", &path, e))?,
            );
            file.write_all(header.as_bytes())
                .map_err(|e| SimError::io("cannot write", &path, e))?;
            Ok(file)
        };
        Ok(DatasetWriter {
            dir: dir.to_owned(),
            rgb_txt: open("rgb.txt", "# color images\n# file: splatloop\n# timestamp filename\n")?,
            depth_txt: open("depth.txt", "# depth maps\n# file: splatloop\n# timestamp filename\n")?,
            groundtruth_txt: open(
                "groundtruth.txt",
                "# ground truth trajectory (camera-to-world, OpenCV optical frame)\n# file: splatloop\n# timestamp tx ty tz qx qy qz qw\n",
            )?,
            transforms: Vec::new(),
            camera: None,
            max_range,
            frames: 0,
        })
    }

    /// The folder being written.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Frames written so far.
    pub fn frame_count(&self) -> usize {
        self.frames
    }

    /// Writes one frame's PNGs and index lines.
    pub fn write_frame(&mut self, frame: &RgbdFrame) -> Result<()> {
        let k = frame.camera.intrinsics;
        match &self.camera {
            None => self.camera = Some(CameraFile::new(&k, self.max_range)),
            Some(c) if c.intrinsics() != k => {
                return Err(SimError::InvalidArgument {
                    what: "frame",
                    detail: "every frame of a dataset must share one camera".into(),
                })
            }
            Some(_) => {}
        }
        let name = format!("{:06}.png", self.frames);
        let rgb_rel = format!("rgb/{name}");
        let depth_rel = format!("depth/{name}");
        write_rgb_png(&self.dir.join(&rgb_rel), k.width, k.height, &frame.rgb)?;
        write_depth_png(&self.dir.join(&depth_rel), k.width, k.height, &frame.depth)?;
        let stamp = format!("{:.6}", frame.time);
        let pose = &frame.camera.world_from_camera;
        let (t, q) = (pose.translation.vector, pose.rotation);
        let lines = [
            (&mut self.rgb_txt, format!("{stamp} {rgb_rel}\n"), "rgb.txt"),
            (
                &mut self.depth_txt,
                format!("{stamp} {depth_rel}\n"),
                "depth.txt",
            ),
            (
                &mut self.groundtruth_txt,
                format!(
                    "{stamp} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9}\n",
                    t.x, t.y, t.z, q.i, q.j, q.k, q.w
                ),
                "groundtruth.txt",
            ),
        ];
        for (file, line, name) in lines {
            file.write_all(line.as_bytes())
                .map_err(|e| SimError::io("cannot write", self.dir.join(name), e))?;
        }
        self.transforms.push(TransformFrame {
            file_path: rgb_rel,
            depth_file_path: depth_rel,
            transform_matrix: opengl_matrix(pose),
            timestamp: frame.time,
        });
        self.frames += 1;
        Ok(())
    }

    /// Flushes the index files and writes camera.json, transforms.json and `episode.json`
    /// (whatever the caller wants recorded: config, seed, versions).
    pub fn finish(mut self, episode: &impl Serialize) -> Result<PathBuf> {
        for (file, name) in [
            (&mut self.rgb_txt, "rgb.txt"),
            (&mut self.depth_txt, "depth.txt"),
            (&mut self.groundtruth_txt, "groundtruth.txt"),
        ] {
            file.flush()
                .map_err(|e| SimError::io("cannot write", self.dir.join(name), e))?;
        }
        if let Some(camera) = &self.camera {
            write_json(&self.dir.join("camera.json"), camera)?;
            let k = camera.intrinsics();
            write_json(
                &self.dir.join("transforms.json"),
                &TransformsFile {
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
                    frames: &self.transforms,
                },
            )?;
        }
        write_json(&self.dir.join("episode.json"), episode)?;
        Ok(self.dir)
    }
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
