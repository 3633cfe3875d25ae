//! The robot's RGB-D sensor: a MuJoCo camera rendered offscreen into RGB, metric planar depth
//! and a pose in the OpenCV optical frame.

use crate::egl::EglContext;
use crate::error::{Result, SimError};
use crate::labels::Labels;
use crate::mujoco::{Data, Model, RenderFlags, SceneRenderer};
use autonomy::camera::{Intrinsics, PinholeCamera};
use autonomy::math::{Isometry3, Matrix3, Rotation3, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Smallest and largest image side the sensor accepts.
pub const RESOLUTION_RANGE: std::ops::RangeInclusive<u32> = 16..=4096;

/// How the sensor is set up.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SensorConfig {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Depth beyond this many metres reads 0 (no return).
    pub max_range: f64,
    /// Standard deviation of additive Gaussian depth noise, metres; `None` for exact depth.
    pub depth_noise_sigma: Option<f64>,
    /// Instance and semantic masks with every frame (a segmentation pass of the same camera).
    #[serde(default = "masks_on")]
    pub masks: bool,
    /// Rendering features (all off by default: a depth camera sees no shadows).
    #[serde(skip)]
    pub flags: RenderFlags,
}

fn masks_on() -> bool {
    true
}

impl Default for SensorConfig {
    fn default() -> Self {
        SensorConfig {
            width: 320,
            height: 240,
            max_range: 5.0,
            depth_noise_sigma: None,
            masks: true,
            flags: RenderFlags::default(),
        }
    }
}

impl SensorConfig {
    /// Refuses resolutions, ranges and noise levels the sensor cannot honour.
    pub fn validate(&self) -> Result<()> {
        for (side, value) in [("width", self.width), ("height", self.height)] {
            if !RESOLUTION_RANGE.contains(&value) {
                return Err(SimError::InvalidArgument {
                    what: "resolution",
                    detail: format!(
                        "{side} {value} is outside {}..={} pixels",
                        RESOLUTION_RANGE.start(),
                        RESOLUTION_RANGE.end()
                    ),
                });
            }
        }
        if !(self.max_range.is_finite() && self.max_range > 0.0) {
            return Err(SimError::InvalidArgument {
                what: "max range",
                detail: format!("{} must be a positive number of metres", self.max_range),
            });
        }
        // 16-bit depth PNGs at 5000 per metre end at 65535 / 5000 = 13.107 m.
        let deepest = f64::from(u16::MAX) / crate::dataset::DEPTH_SCALE;
        if self.max_range > deepest {
            return Err(SimError::InvalidArgument {
                what: "max range",
                detail: format!(
                    "{} m is beyond what a 16-bit depth PNG at {} per metre holds ({deepest:.3} m); give at most {:.1}",
                    self.max_range,
                    crate::dataset::DEPTH_SCALE,
                    (deepest * 10.0).floor() / 10.0
                ),
            });
        }
        if let Some(sigma) = self.depth_noise_sigma {
            if !(sigma.is_finite() && sigma >= 0.0) {
                return Err(SimError::InvalidArgument {
                    what: "depth noise",
                    detail: format!("sigma {sigma} must be a non-negative number of metres"),
                });
            }
        }
        Ok(())
    }
}

/// One RGB-D measurement: rows top to bottom, depth in metres (0 = no return).
#[derive(Debug, Clone, PartialEq)]
pub struct RgbdFrame {
    /// Simulated time of the capture, seconds.
    pub time: f64,
    /// Interleaved RGB, `3 * W * H` bytes.
    pub rgb: Vec<u8>,
    /// Planar depth, `W * H` metres.
    pub depth: Vec<f32>,
    /// Intrinsics and the pose of the optical frame.
    pub camera: PinholeCamera,
    /// The instance each pixel shows (`W * H`, 0 = nothing; [`Labels`]); empty when the
    /// camera makes no masks.
    pub instance: Vec<u16>,
}

/// Converts MuJoCo's camera orientation (looking along -z, y up) to the optical frame.
pub fn optical_from_mujoco_camera(world_from_mujoco_camera: &Matrix3) -> Rotation3 {
    let flip = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0));
    // MuJoCo's matrix is orthonormal already; `from_matrix` would re-orthogonalise iteratively
    // from the identity and stalls on exact half turns (a camera facing -y).
    Rotation3::from_matrix_unchecked(world_from_mujoco_camera * flip)
}

/// The RGB-D camera: a renderer bound to one model camera.
pub struct RgbdCamera {
    renderer: SceneRenderer,
    camera_id: usize,
    intrinsics: Intrinsics,
    near: f64,
    far: f64,
    max_range: f64,
    noise: Option<(Normal<f64>, ChaCha8Rng)>,
    raw_rgb: Vec<u8>,
    raw_depth: Vec<f32>,
    /// The world's labels, when the camera makes masks.
    labels: Option<Arc<Labels>>,
    /// The instance mask as read (bottom-to-top rows).
    raw_instance: Vec<u16>,
}

impl RgbdCamera {
    /// Binds model camera `camera_id`; the model must have been prepared with
    /// [`Model::configure_offscreen`] for this resolution.
    pub fn new(
        model: Arc<Model>,
        camera_id: usize,
        config: &SensorConfig,
        seed: u64,
        gl: &EglContext,
    ) -> Result<Self> {
        config.validate()?;
        let (near, far) = model.clip_planes();
        let intrinsics =
            Intrinsics::from_fovy(model.camera_fovy(camera_id), config.width, config.height);
        let noise = match config.depth_noise_sigma {
            Some(sigma) if sigma > 0.0 => Some((
                Normal::new(0.0, sigma).map_err(|e| SimError::InvalidArgument {
                    what: "depth noise",
                    detail: e.to_string(),
                })?,
                ChaCha8Rng::seed_from_u64(seed),
            )),
            _ => None,
        };
        let renderer = SceneRenderer::new(model, config.width, config.height, config.flags, gl)?;
        let pixels = intrinsics.pixel_count();
        Ok(RgbdCamera {
            renderer,
            camera_id,
            intrinsics,
            near,
            far,
            max_range: config.max_range,
            noise,
            raw_rgb: vec![0; 3 * pixels],
            raw_depth: vec![0.0; pixels],
            labels: None,
            raw_instance: Vec::new(),
        })
    }

    /// The camera that also renders each frame's instance mask with `labels` (a second,
    /// segmentation pass of the same camera: MuJoCo draws colour or ids, not both at once).
    pub fn with_labels(mut self, labels: Arc<Labels>) -> Self {
        self.labels = Some(labels);
        self
    }

    /// The labels the masks use, when the camera makes them.
    pub fn labels(&self) -> Option<&Arc<Labels>> {
        self.labels.as_ref()
    }

    /// The intrinsics K of the images.
    pub fn intrinsics(&self) -> &Intrinsics {
        &self.intrinsics
    }

    /// The pose of the optical frame in the world for the current state.
    pub fn world_from_camera(&self, data: &Data) -> Isometry3 {
        let rotation = optical_from_mujoco_camera(&data.camera_rotation(self.camera_id));
        Isometry3::from_parts(
            data.camera_position(self.camera_id).coords.into(),
            UnitQuaternion::from_rotation_matrix(&rotation),
        )
    }

    /// An empty frame for [`RgbdCamera::capture_into`] to fill, so loops render once per frame.
    pub fn blank_frame(&self) -> RgbdFrame {
        RgbdFrame {
            time: 0.0,
            rgb: Vec::new(),
            depth: Vec::new(),
            camera: PinholeCamera {
                intrinsics: self.intrinsics,
                world_from_camera: Isometry3::identity(),
            },
            instance: Vec::new(),
        }
    }

    /// Renders the current state.
    pub fn capture(&mut self, data: &Data) -> Result<RgbdFrame> {
        let mut frame = self.blank_frame();
        self.capture_into(data, &mut frame)?;
        Ok(frame)
    }

    /// Renders the current state into `frame`, reusing its buffers: RGB-D, and the instance
    /// mask when the camera has labels.
    pub fn capture_into(&mut self, data: &Data, frame: &mut RgbdFrame) -> Result<()> {
        let Some(labels) = self.labels.clone() else {
            return self.capture_rgbd_into(data, frame);
        };
        self.renderer
            .render_raw(data, self.camera_id, &mut self.raw_rgb, &mut self.raw_depth)?;
        // The segmentation of the same scene draws while the colour and depth are converted.
        self.renderer.start_segmentation();
        self.finish_rgbd(data, frame);
        let (codes, geom_of_code) = self.renderer.read_segmentation();
        let instance_of_code: Vec<u16> = geom_of_code
            .iter()
            .map(|&g| labels.instance_of_geom(g))
            .collect();
        let w = self.intrinsics.width as usize;
        self.raw_instance.clear();
        self.raw_instance
            .extend(codes.map(|code| instance_of_code.get(code).copied().unwrap_or(0)));
        frame.instance.resize(self.raw_instance.len(), 0);
        flip_rows(&self.raw_instance, &mut frame.instance, w);
        Ok(())
    }

    /// Renders only RGB-D into `frame` (no mask, whatever the camera makes): what the
    /// evaluation's views need.
    pub fn capture_rgbd_into(&mut self, data: &Data, frame: &mut RgbdFrame) -> Result<()> {
        self.renderer
            .render_raw(data, self.camera_id, &mut self.raw_rgb, &mut self.raw_depth)?;
        self.finish_rgbd(data, frame);
        frame.instance.clear();
        Ok(())
    }

    /// The raw buffers of the last render as the frame's images, pose and time.
    fn finish_rgbd(&mut self, data: &Data, frame: &mut RgbdFrame) {
        let (w, h) = (
            self.intrinsics.width as usize,
            self.intrinsics.height as usize,
        );
        frame.time = data.time();
        frame.camera = PinholeCamera {
            intrinsics: self.intrinsics,
            world_from_camera: self.world_from_camera(data),
        };
        frame.rgb.resize(3 * w * h, 0);
        frame.depth.resize(w * h, 0.0);
        flip_rows(&self.raw_rgb, &mut frame.rgb, 3 * w);
        flip_rows(&self.raw_depth, &mut frame.depth, w);
        for d in &mut frame.depth {
            *d = self.metric_depth(*d);
        }
        if let Some((normal, rng)) = &mut self.noise {
            for d in frame.depth.iter_mut().filter(|d| **d > 0.0) {
                *d = (f64::from(*d) + normal.sample(rng)).max(0.0) as f32;
            }
        }
    }

    /// Planar metric depth from an OpenGL depth-buffer value (DESIGN.md), 0 past the range.
    fn metric_depth(&self, z: f32) -> f32 {
        if z >= 1.0 {
            return 0.0;
        }
        let d = self.near / (1.0 - f64::from(z) * (1.0 - self.near / self.far));
        if d > self.max_range {
            0.0
        } else {
            d as f32
        }
    }

    /// The geom id seen at each pixel (rows top to bottom, -1 for nothing): ground truth for
    /// tests and segmentation datasets.
    pub fn capture_geom_ids(&mut self, data: &Data) -> Result<Vec<i32>> {
        let mut raw = vec![-1; self.intrinsics.pixel_count()];
        self.renderer
            .render_geom_ids(data, self.camera_id, &mut raw)?;
        let mut ids = vec![-1; raw.len()];
        flip_rows(&raw, &mut ids, self.intrinsics.width as usize);
        Ok(ids)
    }
}

/// Copies `src` into `dst` with the row order reversed: OpenGL rows run bottom to top, images
/// top to bottom.
fn flip_rows<T: Copy>(src: &[T], dst: &mut [T], row_len: usize) {
    for (dst_row, src_row) in dst
        .chunks_exact_mut(row_len)
        .zip(src.chunks_exact(row_len).rev())
    {
        dst_row.copy_from_slice(src_row);
    }
}
