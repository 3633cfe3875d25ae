//! Differentiable rasterisation of isotropic Gaussians (DESIGN.md "Gaussian map"): colour,
//! depth and silhouette images, and the gradients of any per-pixel loss.
//!
//! [`reference`] is a plain f64 scalar implementation of the equations, the ground truth for
//! tests; [`cpu`] is the engine (16x16 tiles, depth-sorted per-tile lists, SIMD, rayon) and
//! [`gpu`] the same structure in WGSL. All three apply the same cut-offs, so they render the
//! same images; [`Rasteriser`] picks the engine.

pub mod cpu;
mod engine;
pub mod gpu;
pub mod reference;

pub use engine::{EngineChoice, Rasteriser, Rendered};

use crate::camera::PinholeCamera;
use crate::gaussians::GaussianError;
use thiserror::Error;

/// Side of a square screen tile, pixels.
pub const TILE: usize = 16;
/// Contributions below this are skipped (one 8-bit step).
pub const MIN_ALPHA: f64 = 1.0 / 255.0;
/// A pixel stops compositing before its transmittance would fall below this.
pub const MIN_TRANSMITTANCE: f64 = 1e-4;
/// Per-Gaussian alpha is clamped here so (1 - alpha) never vanishes (3DGS does the same).
pub const MAX_ALPHA: f64 = 0.99;
/// Gaussians closer to the camera than this (metres, optical z) are culled.
pub const NEAR_PLANE: f64 = 0.01;

/// Why a render was refused.
#[derive(Debug, Error, PartialEq)]
pub enum RenderError {
    /// The parameters are malformed or contain NaN.
    #[error(transparent)]
    Gaussians(#[from] GaussianError),
    /// The camera cannot form an image.
    #[error("invalid camera: {0}")]
    Camera(String),
    /// The GPU engine failed (validation, memory, device loss) or the scene exceeds its limits.
    #[error("GPU engine: {0}")]
    Gpu(String),
    /// A render from one engine was handed to another engine's backward pass.
    #[error("this render came from the {0} engine; run backward on the engine that rendered it")]
    EngineMismatch(&'static str),
    /// Per-pixel gradient images of the wrong size.
    #[error("gradient images have {got} pixels, the render has {expected}")]
    GradientSize {
        /// Pixels expected.
        expected: usize,
        /// Pixels given.
        got: usize,
    },
}

/// Checks that a camera can form an image.
pub fn validate_camera(camera: &PinholeCamera) -> Result<(), RenderError> {
    let k = &camera.intrinsics;
    let finite = [k.fx, k.fy, k.cx, k.cy].iter().all(|v| v.is_finite())
        && camera
            .world_from_camera
            .translation
            .vector
            .iter()
            .all(|v| v.is_finite())
        && camera
            .world_from_camera
            .rotation
            .coords
            .iter()
            .all(|v| v.is_finite());
    if !finite || k.fx <= 0.0 || k.fy <= 0.0 || k.width == 0 || k.height == 0 {
        return Err(RenderError::Camera(format!(
            "need finite positive focal lengths and a non-empty image, got {k:?}"
        )));
    }
    Ok(())
}

/// Rendered images, row-major, rows top to bottom.
#[derive(Debug, Clone, PartialEq)]
pub struct Images {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Interleaved RGB, 3 per pixel.
    pub colour: Vec<f32>,
    /// Composited camera depth (optical z), metres; not normalised by the silhouette.
    pub depth: Vec<f32>,
    /// Accumulated opacity in [0, 1].
    pub silhouette: Vec<f32>,
}

impl Images {
    /// Black, empty images.
    pub fn zeros(width: usize, height: usize) -> Self {
        Images {
            width,
            height,
            colour: vec![0.0; 3 * width * height],
            depth: vec![0.0; width * height],
            silhouette: vec![0.0; width * height],
        }
    }
}

/// Parameters per Gaussian in the diagonal Fisher information: mean x, y, z, log-radius,
/// logit-opacity, colour r, g, b.
pub const FISHER_PARAMETERS: usize = 8;

/// The diagonal Fisher information of one view, per Gaussian (indexed like the Gaussians; zero
/// for those the view does not see).
pub type FisherDiagonal = Vec<[f32; FISHER_PARAMETERS]>;

/// Gradients of the loss with respect to each output image, same layout as [`Images`].
#[derive(Debug, Clone, PartialEq)]
pub struct ImageGradients {
    /// d loss / d colour (3 per pixel).
    pub colour: Vec<f32>,
    /// d loss / d depth.
    pub depth: Vec<f32>,
    /// d loss / d silhouette.
    pub silhouette: Vec<f32>,
}

impl ImageGradients {
    /// Zero gradients for `pixels` pixels.
    pub fn zeros(pixels: usize) -> Self {
        ImageGradients {
            colour: vec![0.0; 3 * pixels],
            depth: vec![0.0; pixels],
            silhouette: vec![0.0; pixels],
        }
    }

    fn check(&self, pixels: usize) -> Result<(), RenderError> {
        for got in [
            self.colour.len() / 3,
            self.depth.len(),
            self.silhouette.len(),
        ] {
            if got != pixels || self.colour.len() != 3 * pixels {
                return Err(RenderError::GradientSize {
                    expected: pixels,
                    got,
                });
            }
        }
        Ok(())
    }
}
