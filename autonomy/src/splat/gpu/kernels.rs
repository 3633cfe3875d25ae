//! The compiled WGSL kernels, their bind-group layouts, and the dispatch chores: 1-D grids
//! wider than 65535 groups, the recursive exclusive scan, the radix-sort passes.

use super::device::GpuDevice;
use super::timing::PassTimer;
use std::borrow::Cow;
use std::sync::Arc;

const COMMON: &str = include_str!("common.wgsl");
/// Threads per group of the 1-D kernels (GROUP in common.wgsl).
pub const GROUP: u32 = 256;
const MAX_GROUPS_X: u32 = 65535;

/// How a kernel sees one binding.
#[derive(Clone, Copy)]
pub(crate) enum Access {
    Uniform,
    Read,
    Write,
}

/// A module's layout and its entry points' pipelines.
pub struct Module {
    layout: wgpu::BindGroupLayout,
    pipelines: Vec<(&'static str, wgpu::ComputePipeline)>,
    /// Timestamps around each pass while `GpuDevice::time_passes` records.
    timer: Option<Arc<PassTimer>>,
}

impl Module {
    pub(crate) fn new(
        gpu: &GpuDevice,
        name: &str,
        source: &str,
        access: &[Access],
        entries: &[&'static str],
    ) -> Self {
        let device = &gpu.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(name),
            source: wgpu::ShaderSource::Wgsl(Cow::Owned(format!("{COMMON}\n{source}"))),
        });
        let layout_entries: Vec<wgpu::BindGroupLayoutEntry> = access
            .iter()
            .enumerate()
            .map(|(binding, a)| wgpu::BindGroupLayoutEntry {
                binding: binding as u32,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: match a {
                        Access::Uniform => wgpu::BufferBindingType::Uniform,
                        Access::Read => wgpu::BufferBindingType::Storage { read_only: true },
                        Access::Write => wgpu::BufferBindingType::Storage { read_only: false },
                    },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            })
            .collect();
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(name),
            entries: &layout_entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(name),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipelines = entries
            .iter()
            .map(|entry| {
                let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(entry),
                    layout: Some(&pipeline_layout),
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: None,
                });
                (*entry, pipeline)
            })
            .collect();
        Module {
            layout,
            pipelines,
            timer: gpu.timer(),
        }
    }

    fn pipeline(&self, entry: &str) -> &wgpu::ComputePipeline {
        // Entry names are compile-time constants of this file; a miss is a programming error.
        match self.pipelines.iter().find(|(name, _)| *name == entry) {
            Some((_, p)) => p,
            None => unreachable!("kernel {entry} was not compiled"),
        }
    }

    /// Binds `buffers` in order (binding 0, 1, ...).
    pub fn bind(&self, gpu: &GpuDevice, buffers: &[&wgpu::Buffer]) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &self.layout,
            entries: &entries,
        })
    }

    /// Records one dispatch of `entry` over `groups` workgroups.
    pub fn dispatch(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        entry: &str,
        bind: &wgpu::BindGroup,
        groups: (u32, u32),
    ) {
        if groups.0 == 0 || groups.1 == 0 {
            return;
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(entry),
            timestamp_writes: self.timer.as_ref().and_then(|t| t.writes(entry)),
        });
        pass.set_pipeline(self.pipeline(entry));
        pass.set_bind_group(0, bind, &[]);
        pass.dispatch_workgroups(groups.0, groups.1, 1);
    }
}

/// Workgroups for `n` items of a 1-D kernel: x capped at 65535, the rest in y.
pub fn linear_groups(n: u32) -> (u32, u32) {
    let groups = n.div_ceil(GROUP);
    if groups <= MAX_GROUPS_X {
        (groups, 1)
    } else {
        (MAX_GROUPS_X, groups.div_ceil(MAX_GROUPS_X))
    }
}

/// The SSIM window's taps as a WGSL array, the very f32 values the CPU loss uses.
fn window_constant() -> String {
    let taps: Vec<String> = crate::ssim::window::<f32>()
        .iter()
        // Rust prints the shortest decimal that reads back as the same f32.
        .map(|t| format!("{t:?}f"))
        .collect();
    format!(
        "var<private> WINDOW: array<f32, {}> = array<f32, {}>({});",
        taps.len(),
        taps.len(),
        taps.join(", ")
    )
}

/// Every kernel of the engine.
pub struct Kernels {
    /// project, chain.
    pub project: Module,
    /// count_pairs, emit_pairs, tile_ranges.
    pub bin: Module,
    /// scan_blocks, add_block_offsets.
    pub scan: Module,
    /// histogram_pass, scatter_pass.
    pub sort: Module,
    /// forward.
    pub forward: Module,
    /// backward.
    pub backward: Module,
    /// loss_h, loss_v, loss_bh, loss_bv, loss_total.
    pub loss: Module,
    /// adam_step.
    pub adam: Module,
    /// keep_flags, scatter: pruning the resident map.
    pub compact: Module,
}

impl Kernels {
    /// Compiles every kernel.
    pub fn new(gpu: &GpuDevice) -> Self {
        use Access::{Read, Uniform, Write};
        Kernels {
            project: Module::new(
                gpu,
                "project",
                include_str!("project.wgsl"),
                &[Uniform, Read, Write, Write, Read, Write],
                &["project", "chain"],
            ),
            bin: Module::new(
                gpu,
                "bin",
                include_str!("bin.wgsl"),
                &[Uniform, Read, Read, Write, Write, Write, Write, Write, Read],
                &["count_pairs", "emit_pairs", "tile_ranges"],
            ),
            scan: Module::new(
                gpu,
                "scan",
                include_str!("scan.wgsl"),
                &[Uniform, Write, Write],
                &["scan_blocks", "add_block_offsets"],
            ),
            sort: Module::new(
                gpu,
                "sort",
                include_str!("sort.wgsl"),
                &[Uniform, Read, Read, Read, Write, Write, Write, Write, Read],
                &["histogram_pass", "scatter_pass"],
            ),
            forward: Module::new(
                gpu,
                "forward",
                concat!(include_str!("tile.wgsl"), include_str!("forward.wgsl")),
                &[Uniform, Read, Read, Read, Write],
                &["forward"],
            ),
            backward: Module::new(
                gpu,
                "backward",
                if gpu.has_subgroups() {
                    concat!(
                        include_str!("tile.wgsl"),
                        include_str!("backward.wgsl"),
                        include_str!("backward_subgroup.wgsl")
                    )
                } else {
                    concat!(
                        include_str!("tile.wgsl"),
                        include_str!("backward.wgsl"),
                        include_str!("backward_shared.wgsl")
                    )
                },
                &[Uniform, Read, Read, Read, Read, Read, Write, Read],
                &["backward", "fisher"],
            ),
            loss: Module::new(
                gpu,
                "loss",
                &format!("{}\n{}", window_constant(), include_str!("loss.wgsl")),
                &[Uniform, Read, Read, Write, Write, Write, Write, Write],
                &["loss_h", "loss_v", "loss_bh", "loss_bv", "loss_total"],
            ),
            adam: Module::new(
                gpu,
                "adam",
                include_str!("adam.wgsl"),
                &[Uniform, Read, Write, Write, Write, Write, Write, Read],
                &["adam_step"],
            ),
            compact: Module::new(
                gpu,
                "compact",
                include_str!("compact.wgsl"),
                &[Uniform, Read, Write, Read, Write],
                &["keep_flags", "scatter"],
            ),
        }
    }

    /// Records an in-place exclusive prefix sum of the first `n` u32 of `data`; returns a
    /// buffer whose first value will hold the total once the encoder has run.
    pub fn scan(
        &self,
        gpu: &GpuDevice,
        encoder: &mut wgpu::CommandEncoder,
        data: &wgpu::Buffer,
        n: u32,
    ) -> wgpu::Buffer {
        let plan = self.scan_plan(gpu, data, n);
        plan.record(self, encoder);
        plan.total
    }

    /// The buffers and bindings of an exclusive prefix sum of the first `n` u32 of `data`,
    /// made once so that recording it again creates nothing.
    pub fn scan_plan(&self, gpu: &GpuDevice, data: &wgpu::Buffer, n: u32) -> ScanPlan {
        // Level l scans blocks of level l's data and writes block totals to level l + 1.
        let mut levels = Vec::new();
        let mut current = data.clone();
        let mut count = n;
        loop {
            let blocks = count.div_ceil(GROUP).max(1);
            let sums = gpu.storage("scan sums", u64::from(blocks) * 4);
            let params = gpu.uniform("scan params", &[count, 0u32, 0, 0]);
            let bind = self.scan.bind(gpu, &[&params, &current, &sums]);
            levels.push((bind, count));
            if blocks == 1 {
                return ScanPlan {
                    levels,
                    total: sums,
                };
            }
            current = sums;
            count = blocks;
        }
    }
}

/// A prefix sum ready to record: its levels' bindings, and the buffer whose first value holds
/// the total once it has run.
pub struct ScanPlan {
    levels: Vec<(wgpu::BindGroup, u32)>,
    /// The total of the scanned values, in its first u32.
    pub total: wgpu::Buffer,
}

impl ScanPlan {
    /// Records the scan into `encoder`.
    pub fn record(&self, kernels: &Kernels, encoder: &mut wgpu::CommandEncoder) {
        for (bind, count) in &self.levels {
            kernels
                .scan
                .dispatch(encoder, "scan_blocks", bind, linear_groups((*count).max(1)));
        }
        for (bind, count) in self.levels.iter().rev().skip(1) {
            kernels
                .scan
                .dispatch(encoder, "add_block_offsets", bind, linear_groups(*count));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::splat::gpu::{AdapterPolicy, GpuError, GpuOptions};

    /// The exclusive prefix sum against the host's, at lengths round the block size and over
    /// several levels, with the total (the pair count and the sort's histograms rest on it).
    #[test]
    fn the_block_scan_matches_the_host_prefix_sum() {
        let gpu = match GpuDevice::open(AdapterPolicy::AllowSoftware, GpuOptions::default()) {
            Ok(gpu) => gpu,
            Err(GpuError::NoAdapter(reason)) => {
                eprintln!("SKIPPED: no wgpu adapter at all: {reason}");
                return;
            }
            Err(e) => panic!("an adapter exists but the device failed: {e}"),
        };
        let kernels = Kernels::new(&gpu);
        for n in [1u32, 255, 256, 257, 1000, 65_537, 300_000] {
            let values: Vec<u32> = (0..n)
                .map(|i| (i.wrapping_mul(2_654_435_761) >> 27) & 15)
                .collect();
            let data = gpu.storage_with("scan test", &values);
            let mut encoder = gpu.encoder();
            let total = kernels.scan(&gpu, &mut encoder, &data, n);
            gpu.submit(encoder).expect("scan");
            let got: Vec<u32> = gpu.read(gpu.encoder(), &data, n as usize).expect("read");
            let total: Vec<u32> = gpu.read(gpu.encoder(), &total, 1).expect("read total");
            let mut sum = 0u32;
            for (i, (g, v)) in got.iter().zip(&values).enumerate() {
                assert_eq!(*g, sum, "n = {n}: entry {i}");
                sum += v;
            }
            assert_eq!(total[0], sum, "n = {n}: the total");
        }
    }
}
