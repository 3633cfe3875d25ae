//! Collision checks on a GPU: every point against every obstacle, one thread per obstacle.
//! The obstacles are uploaded once per plan ([`GpuCollision::upload`]); each check sends only
//! its points.

use super::collision::{CollisionModel, Obstacles};
use crate::splat::gpu::kernels::{linear_groups, Access, Module};
use crate::splat::gpu::{AdapterPolicy, GpuDevice, GpuError, GpuOptions};

/// The GPU collision engine.
pub struct GpuCollision {
    gpu: GpuDevice,
    module: Module,
    uploaded: Option<(wgpu::Buffer, u32)>,
}

impl std::fmt::Debug for GpuCollision {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "GpuCollision({})", self.gpu.describe())
    }
}

impl GpuCollision {
    /// Opens an adapter under `policy`.
    pub fn new(policy: AdapterPolicy) -> Result<Self, GpuError> {
        let gpu = GpuDevice::open(policy, GpuOptions::default())?;
        let module = Module::new(
            &gpu,
            "collision",
            include_str!("collision.wgsl"),
            &[Access::Uniform, Access::Read, Access::Read, Access::Write],
            &["collide"],
        );
        gpu.check()?;
        Ok(GpuCollision {
            gpu,
            module,
            uploaded: None,
        })
    }

    /// The adapter, in words.
    pub fn describe(&self) -> String {
        self.gpu.describe()
    }

    /// Uploads the obstacles later checks run against.
    pub fn upload(&mut self, obstacles: &Obstacles) -> Result<(), GpuError> {
        let bytes = obstacles.len() as u64 * 16;
        if bytes > self.gpu.max_binding {
            return Err(GpuError::TooLarge(format!(
                "{} obstacles need {bytes} bytes; this adapter binds at most {}",
                obstacles.len(),
                self.gpu.max_binding
            )));
        }
        let packed: Vec<[f32; 4]> = obstacles
            .means
            .iter()
            .zip(&obstacles.radii)
            .map(|(m, r)| [m[0], m[1], m[2], *r])
            .collect();
        let buffer = self.gpu.storage_with("obstacles", &packed);
        self.uploaded = Some((buffer, obstacles.len() as u32));
        self.gpu.check()
    }

    /// Per point: does it collide with any uploaded obstacle? Uploads `obstacles` first when
    /// their count differs from what is on the GPU.
    pub fn check(
        &self,
        model: &CollisionModel,
        obstacles: &Obstacles,
        points: &[[f32; 3]],
    ) -> Result<Vec<bool>, GpuError> {
        let Some((buffer, count)) = &self.uploaded else {
            return Err(GpuError::Operation(
                "no obstacles uploaded; call upload first".into(),
            ));
        };
        if *count as usize != obstacles.len() {
            return Err(GpuError::Operation(format!(
                "{} obstacles uploaded, {} given; call upload again",
                count,
                obstacles.len()
            )));
        }
        if points.is_empty() {
            return Ok(Vec::new());
        }
        let gpu = &self.gpu;
        let params = gpu.uniform(
            "collision params",
            &[
                *count,
                points.len() as u32,
                model.robot_radius.to_bits(),
                model.gaussian_scale.to_bits(),
            ],
        );
        let packed: Vec<[f32; 4]> = points.iter().map(|p| [p[0], p[1], p[2], 0.0]).collect();
        let point_buffer = gpu.storage_with("points", &packed);
        let hits = gpu.storage("hits", points.len() as u64 * 4);
        let bind = self
            .module
            .bind(gpu, &[&params, buffer, &point_buffer, &hits]);
        let mut encoder = gpu.encoder();
        encoder.clear_buffer(&hits, 0, None);
        self.module
            .dispatch(&mut encoder, "collide", &bind, linear_groups(*count));
        let flags: Vec<u32> = gpu.read(encoder, &hits, points.len())?;
        Ok(flags.into_iter().map(|f| f != 0).collect())
    }
}
