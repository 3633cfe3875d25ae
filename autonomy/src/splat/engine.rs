//! Choosing between the CPU and the wgpu engine, and calling whichever was chosen.

use super::gpu::{AdapterPolicy, GpuOptions, GpuRasteriser, GpuRender};
use super::{cpu, ImageGradients, Images, RenderError};
use crate::camera::PinholeCamera;
use crate::gaussians::{Gaussians, Gradients};
use std::str::FromStr;

/// What the user asked for (`--engine`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum EngineChoice {
    /// The GPU engine on a hardware GPU, else the CPU engine.
    #[default]
    Auto,
    /// The CPU engine.
    Cpu,
    /// The GPU engine on any adapter, software ones included; the CPU engine (with a
    /// warning) when there is none.
    Gpu,
}

impl FromStr for EngineChoice {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(EngineChoice::Auto),
            "cpu" => Ok(EngineChoice::Cpu),
            "gpu" => Ok(EngineChoice::Gpu),
            other => Err(format!("unknown engine {other:?}; use auto, cpu or gpu")),
        }
    }
}

/// The engine in use.
#[derive(Debug)]
pub enum Rasteriser {
    /// The native CPU engine.
    Cpu,
    /// The wgpu engine.
    Gpu(Box<GpuRasteriser>),
}

/// A forward pass of either engine.
#[derive(Debug)]
pub enum Rendered {
    /// From the CPU engine.
    Cpu(cpu::Render),
    /// From the wgpu engine.
    Gpu(GpuRender),
}

impl Rendered {
    /// The images.
    pub fn images(&self) -> &Images {
        match self {
            Rendered::Cpu(r) => &r.images,
            Rendered::Gpu(r) => &r.images,
        }
    }

    /// (tile, Gaussian) pairs of the tile lists; times 256 pixels, the work of a forward pass.
    pub fn tile_pairs(&self) -> u64 {
        match self {
            Rendered::Cpu(r) => (r.tile_pair_count() / (super::TILE * super::TILE)) as u64,
            Rendered::Gpu(r) => r.pair_count(),
        }
    }
}

impl Rasteriser {
    /// Picks the engine for `choice`. Never fails: without a usable adapter it logs why and
    /// returns the CPU engine (a warning when the GPU was asked for explicitly).
    pub fn select(choice: EngineChoice) -> Self {
        Self::select_with(choice, GpuOptions::default())
    }

    /// [`Rasteriser::select`] with the GPU engine opened under `options` (`bench render`
    /// compares its kernels so).
    pub fn select_with(choice: EngineChoice, options: GpuOptions) -> Self {
        let policy = match choice {
            EngineChoice::Cpu => return Rasteriser::Cpu,
            EngineChoice::Auto => AdapterPolicy::HardwareOnly,
            EngineChoice::Gpu => AdapterPolicy::AllowSoftware,
        };
        match GpuRasteriser::with_options(policy, options) {
            Ok(gpu) => {
                tracing::info!("splat engine: gpu on {}", gpu.describe());
                Rasteriser::Gpu(Box::new(gpu))
            }
            Err(e) if choice == EngineChoice::Gpu => {
                tracing::warn!("--engine gpu: {e}; falling back to the CPU engine");
                Rasteriser::Cpu
            }
            Err(e) => {
                // The normal case on a machine without a GPU: nothing a person must act on.
                tracing::debug!("splat engine: cpu ({e})");
                Rasteriser::Cpu
            }
        }
    }

    /// The GPU engine, when it is the one in use (for its resident iteration).
    pub fn gpu(&self) -> Option<&GpuRasteriser> {
        match self {
            Rasteriser::Cpu => None,
            Rasteriser::Gpu(g) => Some(g),
        }
    }

    /// Whether this is the GPU engine.
    pub fn is_gpu(&self) -> bool {
        matches!(self, Rasteriser::Gpu(_))
    }

    /// "cpu" or "gpu (adapter)".
    pub fn describe(&self) -> String {
        match self {
            Rasteriser::Cpu => format!("cpu ({} threads)", rayon::current_num_threads()),
            Rasteriser::Gpu(g) => format!("gpu: {}", g.describe()),
        }
    }

    /// Renders colour, depth and silhouette.
    pub fn render(
        &self,
        gaussians: &Gaussians,
        camera: &PinholeCamera,
    ) -> Result<Rendered, RenderError> {
        match self {
            Rasteriser::Cpu => cpu::render(gaussians, camera).map(Rendered::Cpu),
            Rasteriser::Gpu(g) => g.render(gaussians, camera).map(Rendered::Gpu),
        }
    }

    /// The diagonal Fisher information of the view `rendered` drew (AG-SLAM eqs 7-9).
    pub fn fisher(&self, rendered: &Rendered) -> Result<super::FisherDiagonal, RenderError> {
        match (self, rendered) {
            (Rasteriser::Cpu, Rendered::Cpu(r)) => Ok(cpu::fisher(r)),
            (Rasteriser::Gpu(g), Rendered::Gpu(r)) => g.fisher(r),
            (_, Rendered::Cpu(_)) => Err(RenderError::EngineMismatch("cpu")),
            (_, Rendered::Gpu(_)) => Err(RenderError::EngineMismatch("gpu")),
        }
    }

    /// Gradients of a per-pixel loss with respect to every parameter.
    pub fn backward(
        &self,
        rendered: &Rendered,
        image_gradients: &ImageGradients,
    ) -> Result<Gradients, RenderError> {
        match (self, rendered) {
            (Rasteriser::Cpu, Rendered::Cpu(r)) => cpu::backward(r, image_gradients),
            (Rasteriser::Gpu(g), Rendered::Gpu(r)) => g.backward(r, image_gradients),
            (_, Rendered::Cpu(_)) => Err(RenderError::EngineMismatch("cpu")),
            (_, Rendered::Gpu(_)) => Err(RenderError::EngineMismatch("gpu")),
        }
    }
}
