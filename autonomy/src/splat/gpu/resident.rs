//! The resident mapping iteration: the map, Adam's moments and the views (a camera and the
//! frame it fits) live in GPU buffers, created once and grown by doubling, and one mapping
//! iteration (projection, binning, sort, forward, L1 + SSIM loss and its gradient, backward,
//! chain rule, Adam) is one command buffer, one submit, and a 32-byte read-back (the loss
//! terms and the pair count).
//!
//! Binning reads no counts back: the pair buffers have a capacity (the last count that fitted,
//! doubled when it did not), every kernel after the scan reads the count from the GPU and
//! stops at the capacity, and Adam is skipped when the pairs overflowed, so the host grows the
//! buffers and repeats that iteration; after the first iterations the capacity fits.

use super::kernels::{linear_groups, ScanPlan, GROUP};
use super::{unpack_pixels, GpuParams, GpuRasteriser, PIXEL_FLOATS, SPLAT_BYTES};
use crate::adam::{AdamState, AdamStateMut, LearningRates};
use crate::camera::PinholeCamera;
use crate::gaussians::Gaussians;
use crate::loss::LossTerms;
use crate::splat::{validate_camera, Images, RenderError, TILE};

/// Floats per Gaussian record (and per moment record): mean xyz, log-radius, logit-opacity,
/// rgb.
const RECORD: usize = 8;
/// Floats per pixel of the frame fitted: r, g, b, depth.
const FRAME_FLOATS: usize = 4;
/// Byte offset of `count` in [`GpuParams`].
const COUNT_OFFSET: u64 = 96;
/// Bytes read back per iteration: the four loss terms, the pair count, padding.
const READ_BACK: u64 = 32;

/// Mirrors `AdamParams` in adam.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct AdamParams {
    rates: [f32; 4],
    count: u32,
    pair_capacity: u32,
    pad: [u32; 2],
}

/// One view: the camera's parameters (copied into the shared uniform when it is fitted) and
/// the frame, uploaded once.
struct View {
    params: wgpu::Buffer,
    size: (u32, u32),
    frame: wgpu::Buffer,
}

/// Buffers sized to the map's capacity.
struct MapBuffers {
    capacity: usize,
    gaussians: wgpu::Buffer,
    first: wgpu::Buffer,
    second: wgpu::Buffer,
    steps: wgpu::Buffer,
    touched: wgpu::Buffer,
    splats: wgpu::Buffer,
    rects: wgpu::Buffer,
    offsets: wgpu::Buffer,
    screen: wgpu::Buffer,
    gradients: wgpu::Buffer,
    offsets_scan: ScanPlan,
    /// Pruning: the host's keep bits, a scratch the kept records are gathered into, the
    /// uniforms of the two record strides and one binding per array compacted (the map,
    /// the two moments with stride 8, the step counts with stride 1).
    keep: wgpu::Buffer,
    scratch: wgpu::Buffer,
    compact_params: [wgpu::Buffer; 2],
    compact: Vec<(wgpu::BindGroup, u32)>,
    /// The map and the touched flags read back once per mapping step.
    map_back: wgpu::Buffer,
}

/// Buffers sized to the image.
struct ImageBuffers {
    size: (u32, u32),
    frame: wgpu::Buffer,
    pixels: wgpu::Buffer,
    pixel_gradients: wgpu::Buffer,
    stats: wgpu::Buffer,
    planes: wgpu::Buffer,
    partials: wgpu::Buffer,
    ranges: wgpu::Buffer,
    /// A render's pixels and its pair count, read back (densification's render).
    pixels_back: wgpu::Buffer,
}

/// The (tile, Gaussian) pair buffers, their sort passes and the bindings that use them.
struct PairBuffers {
    capacity: u32,
    sort_passes: Vec<wgpu::BindGroup>,
    histogram_scan: ScanPlan,
    bin: wgpu::BindGroup,
    ranges: wgpu::BindGroup,
    forward: wgpu::BindGroup,
    backward: wgpu::BindGroup,
    adam: wgpu::BindGroup,
}

/// The map and views resident on the GPU, and the iteration over them. The host-side map is
/// the source of truth between mapping steps: [`ResidentMap::load`] before the step's
/// iterations, [`ResidentMap::store`] after them.
pub struct ResidentMap {
    count: usize,
    params: wgpu::Buffer,
    adam_params: wgpu::Buffer,
    terms: wgpu::Buffer,
    staging: wgpu::Buffer,
    views: Vec<View>,
    map: Option<MapBuffers>,
    image: Option<ImageBuffers>,
    pairs: Option<PairBuffers>,
    /// Bindings of the kernels that read only map and image buffers.
    project: Option<wgpu::BindGroup>,
    loss: Option<wgpu::BindGroup>,
    rates: LearningRates,
}

impl std::fmt::Debug for ResidentMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "ResidentMap({} Gaussians, {} views)",
            self.count,
            self.views.len()
        )
    }
}

/// What [`ResidentMap::prepare`] made, borrowed for recording an iteration or a render.
struct Prepared<'a> {
    map: &'a MapBuffers,
    image: &'a ImageBuffers,
    pairs: &'a PairBuffers,
    project: &'a wgpu::BindGroup,
    loss: &'a wgpu::BindGroup,
    view: &'a View,
}

/// Tiles across and down an image of `size` pixels.
fn tile_grid(size: (u32, u32)) -> (u32, u32) {
    (size.0.div_ceil(TILE as u32), size.1.div_ceil(TILE as u32))
}

/// The Gaussians as the kernels' 8-float records.
pub(super) fn pack(g: &Gaussians) -> Vec<[f32; RECORD]> {
    pack_range(g, 0..g.len())
}

/// Gaussians `range` as the kernels' 8-float records (appending packs only the new ones).
fn pack_range(g: &Gaussians, range: std::ops::Range<usize>) -> Vec<[f32; RECORD]> {
    range
        .map(|i| {
            let (m, c) = (g.means[i], g.colours[i]);
            [
                m[0],
                m[1],
                m[2],
                g.log_radii[i],
                g.logit_opacities[i],
                c[0],
                c[1],
                c[2],
            ]
        })
        .collect()
}

fn unpack(records: &[f32], g: &mut Gaussians) {
    for (i, r) in records.chunks_exact(RECORD).enumerate().take(g.len()) {
        g.means[i] = [r[0], r[1], r[2]];
        g.log_radii[i] = r[3];
        g.logit_opacities[i] = r[4];
        g.colours[i] = [r[5], r[6], r[7]];
    }
}

impl ResidentMap {
    /// Adam's rates from the next iteration on.
    pub fn set_rates(&mut self, engine: &GpuRasteriser, rates: LearningRates) {
        self.rates = rates;
        let capacity = self.pairs.as_ref().map_or(0, |p| p.capacity);
        self.write_adam_params(engine, capacity);
    }

    /// An empty resident map on `engine`'s device, fitted with Adam at `rates`.
    pub fn new(engine: &GpuRasteriser, rates: LearningRates) -> Self {
        let gpu = &engine.gpu;
        let uniform = |label, bytes| {
            gpu.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        ResidentMap {
            count: 0,
            params: uniform("view params", std::mem::size_of::<GpuParams>() as u64),
            adam_params: uniform("adam params", std::mem::size_of::<AdamParams>() as u64),
            terms: gpu.storage("loss terms", READ_BACK),
            staging: gpu.create_buffer(&wgpu::BufferDescriptor {
                label: Some("loss read-back"),
                size: READ_BACK,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            views: Vec::new(),
            map: None,
            image: None,
            pairs: None,
            project: None,
            loss: None,
            rates,
        }
    }

    /// Gaussians resident.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether no Gaussian is resident.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Views uploaded so far.
    pub fn view_count(&self) -> usize {
        self.views.len()
    }

    /// Uploads a view: `camera` and the frame it should see (`colour` interleaved RGB in
    /// [0, 1], `depth` in metres, 0 where unmeasured). Returns its index.
    pub fn add_view(
        &mut self,
        engine: &GpuRasteriser,
        camera: &PinholeCamera,
        colour: &[f32],
        depth: &[f32],
    ) -> Result<usize, RenderError> {
        let (params, frame) = self.view_data(engine, camera, colour, depth)?;
        let gpu = &engine.gpu;
        self.views.push(View {
            params: gpu.storage_with("view params (copy source)", &[params]),
            size: (camera.intrinsics.width, camera.intrinsics.height),
            frame: gpu.storage_with("view frame", &frame),
        });
        Ok(self.views.len() - 1)
    }

    /// Replaces view `index` with a new camera and frame of the same size, reusing its
    /// buffers (the mapper's current-frame slot).
    pub fn replace_view(
        &mut self,
        engine: &GpuRasteriser,
        index: usize,
        camera: &PinholeCamera,
        colour: &[f32],
        depth: &[f32],
    ) -> Result<(), RenderError> {
        let k = camera.intrinsics;
        match self.views.get(index) {
            Some(v) if v.size == (k.width, k.height) => {}
            _ => {
                return Err(RenderError::Gpu(format!(
                    "view {index} cannot take a {}x{} frame",
                    k.width, k.height
                )))
            }
        }
        let (params, frame) = self.view_data(engine, camera, colour, depth)?;
        let view = &self.views[index];
        engine.gpu.write(&view.params, 0, &[params]);
        engine.gpu.write(&view.frame, 0, &frame);
        Ok(())
    }

    fn view_data(
        &self,
        engine: &GpuRasteriser,
        camera: &PinholeCamera,
        colour: &[f32],
        depth: &[f32],
    ) -> Result<(GpuParams, Vec<f32>), RenderError> {
        validate_camera(camera)?;
        let k = camera.intrinsics;
        let n = (k.width * k.height) as usize;
        if colour.len() != 3 * n || depth.len() != n {
            return Err(RenderError::Gpu(format!(
                "a {}x{} view needs {} colours and {n} depths, got {} and {}",
                k.width,
                k.height,
                3 * n,
                colour.len(),
                depth.len()
            )));
        }
        let mut params = engine.params(camera, self.count);
        params.band_end = params.tiles_y;
        let measured = depth.iter().filter(|d| **d > 0.0).count() as f32;
        let mut frame: Vec<f32> = Vec::with_capacity(FRAME_FLOATS * n + 4);
        for p in 0..n {
            frame.extend_from_slice(&colour[3 * p..3 * p + 3]);
            frame.push(depth[p]);
        }
        frame.extend_from_slice(&[measured, 0.0, 0.0, 0.0]);
        Ok((params, frame))
    }

    /// Loads the map and Adam's state (moments and per-Gaussian step counts) for a mapping
    /// step, growing the buffers by doubling when the map outgrew them, and clears the touched
    /// flags.
    pub fn load(
        &mut self,
        engine: &GpuRasteriser,
        gaussians: &Gaussians,
        adam: AdamState<'_>,
    ) -> Result<(), RenderError> {
        gaussians.validate()?;
        let gpu = &engine.gpu;
        let n = gaussians.len();
        engine.check_size(n, 0)?;
        self.reserve(engine, n);
        let Some(map) = &self.map else {
            unreachable!("reserved above")
        };
        gpu.write(&map.gaussians, 0, &pack(gaussians));
        let moments = |g: &Gaussians| {
            let mut packed = pack(g);
            packed.resize(n, [0.0; RECORD]);
            packed
        };
        gpu.write(&map.first, 0, &moments(adam.first));
        gpu.write(&map.second, 0, &moments(adam.second));
        let mut steps = adam.steps.to_vec();
        steps.resize(n, 0);
        gpu.write(&map.steps, 0, &steps);
        let mut encoder = gpu.encoder();
        encoder.clear_buffer(&map.touched, 0, None);
        gpu.submit(encoder)?;
        self.set_count(engine, n);
        Ok(())
    }

    fn write_adam_params(&self, engine: &GpuRasteriser, pair_capacity: u32) {
        let r = self.rates;
        engine.gpu.write(
            &self.adam_params,
            0,
            &[AdamParams {
                rates: [r.means, r.log_radii, r.logit_opacities, r.colours],
                count: self.count as u32,
                pair_capacity,
                pad: [0; 2],
            }],
        );
    }

    fn map_buffers(&self, engine: &GpuRasteriser, capacity: usize) -> MapBuffers {
        let gpu = &engine.gpu;
        let c = capacity as u64;
        let offsets = gpu.storage("pair offsets", c * 4);
        let offsets_scan = engine.kernels.scan_plan(gpu, &offsets, capacity as u32);
        let record = c * RECORD as u64 * 4;
        let gaussians = gpu.storage("gaussians", record);
        let first = gpu.storage("adam first moments", record);
        let second = gpu.storage("adam second moments", record);
        let steps = gpu.storage("adam steps", c * 4);
        let keep = gpu.storage("keep bits", c.div_ceil(32) * 4);
        let scratch = gpu.storage("compaction scratch", record);
        let compact_params: [wgpu::Buffer; 2] = std::array::from_fn(|_| {
            gpu.create_buffer(&wgpu::BufferDescriptor {
                label: Some("compact params"),
                size: 16,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });
        let compact = [(&gaussians, 0usize), (&first, 0), (&second, 0), (&steps, 1)]
            .iter()
            .map(|(array, which)| {
                let bind = engine.kernels.compact.bind(
                    gpu,
                    &[&compact_params[*which], &keep, &offsets, array, &scratch],
                );
                (bind, if *which == 0 { RECORD as u32 } else { 1 })
            })
            .collect();
        MapBuffers {
            capacity,
            touched: gpu.storage("touched", c * 4),
            splats: gpu.storage("splats", c * SPLAT_BYTES),
            rects: gpu.storage("tile rects", c * 16),
            screen: gpu.storage("screen gradients", c * 36),
            gradients: gpu.storage("gradients", c * 36),
            map_back: gpu.create_buffer(&wgpu::BufferDescriptor {
                label: Some("map read-back"),
                size: record + c * 4,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            gaussians,
            first,
            second,
            steps,
            offsets,
            offsets_scan,
            keep,
            scratch,
            compact_params,
            compact,
        }
    }

    /// Makes room for `n` Gaussians: the map's buffers doubled until they fit, the records,
    /// moments and step counts of the resident Gaussians copied over on the GPU.
    fn reserve(&mut self, engine: &GpuRasteriser, n: usize) {
        if self.map.as_ref().is_some_and(|m| m.capacity >= n) {
            return;
        }
        let capacity = n.next_power_of_two().max(1024);
        let grown = self.map_buffers(engine, capacity);
        if let Some(old) = &self.map {
            let count = self.count as u64;
            let mut e = engine.gpu.encoder();
            for (from, to, bytes) in [
                (&old.gaussians, &grown.gaussians, count * RECORD as u64 * 4),
                (&old.first, &grown.first, count * RECORD as u64 * 4),
                (&old.second, &grown.second, count * RECORD as u64 * 4),
                (&old.steps, &grown.steps, count * 4),
                (&old.touched, &grown.touched, count * 4),
            ] {
                if bytes > 0 {
                    e.copy_buffer_to_buffer(from, 0, to, 0, bytes);
                }
            }
            engine.gpu.enqueue(e);
        }
        tracing::debug!(capacity, "resident map grown");
        self.map = Some(grown);
        self.project = None;
        self.loss = None;
        self.pairs = None;
    }

    /// Tells every view and Adam how many Gaussians are resident.
    fn set_count(&mut self, engine: &GpuRasteriser, n: usize) {
        self.count = n;
        for view in &self.views {
            engine.gpu.write(&view.params, COUNT_OFFSET, &[n as u32]);
        }
        let capacity = self.pairs.as_ref().map_or(0, |p| p.capacity);
        self.write_adam_params(engine, capacity);
    }

    /// Appends the Gaussians the host pushed since the resident map was last in step with it
    /// (indices from [`Self::len`] on; densification only pushes) with fresh Adam state:
    /// only they are uploaded, the moments and step counts of their slots cleared on the GPU.
    pub fn append(
        &mut self,
        engine: &GpuRasteriser,
        gaussians: &Gaussians,
    ) -> Result<(), RenderError> {
        let (from, n) = (self.count, gaussians.len());
        if n < from {
            return Err(RenderError::Gpu(format!(
                "{n} Gaussians given to append to the {from} resident; load the map instead"
            )));
        }
        if n == from {
            return Ok(());
        }
        gaussians.validate()?;
        engine.check_size(n, 0)?;
        self.reserve(engine, n);
        let Some(map) = &self.map else {
            unreachable!("reserved above")
        };
        let new = pack_range(gaussians, from..n);
        let record = (RECORD * 4) as u64;
        engine.gpu.write(&map.gaussians, from as u64 * record, &new);
        let mut e = engine.gpu.encoder();
        let added = (n - from) as u64;
        e.clear_buffer(&map.first, from as u64 * record, Some(added * record));
        e.clear_buffer(&map.second, from as u64 * record, Some(added * record));
        e.clear_buffer(&map.steps, from as u64 * 4, Some(added * 4));
        e.clear_buffer(&map.touched, from as u64 * 4, Some(added * 4));
        engine.gpu.enqueue(e);
        self.set_count(engine, n);
        Ok(())
    }

    /// Drops the Gaussians whose `keep` is false, as the host's map and Adam's `retain` do:
    /// the host uploads one bit per Gaussian and the GPU compacts the map, the moments and
    /// the step counts in one submit (a prefix sum of the kept, then a gather).
    pub fn retain(&mut self, engine: &GpuRasteriser, keep: &[bool]) -> Result<(), RenderError> {
        let n = self.count;
        if keep.len() != n {
            return Err(RenderError::Gpu(format!(
                "{} keep flags for {n} resident Gaussians",
                keep.len()
            )));
        }
        let kept = keep.iter().filter(|k| **k).count();
        if kept == n {
            return Ok(());
        }
        let Some(map) = &self.map else {
            unreachable!("a non-empty resident map has buffers")
        };
        let mut bits = vec![0u32; n.div_ceil(32)];
        for (i, _) in keep.iter().enumerate().filter(|(_, k)| **k) {
            bits[i / 32] |= 1 << (i % 32);
        }
        let gpu = &engine.gpu;
        gpu.write(&map.keep, 0, &bits);
        for (params, stride) in map.compact_params.iter().zip([RECORD as u32, 1]) {
            gpu.write(params, 0, &[n as u32, stride, 0, 0]);
        }
        let k = &engine.kernels;
        let groups = linear_groups(n as u32);
        let mut e = gpu.encoder();
        e.clear_buffer(&map.offsets, 0, None);
        k.compact
            .dispatch(&mut e, "keep_flags", &map.compact[0].0, groups);
        map.offsets_scan.record(k, &mut e);
        let targets = [&map.gaussians, &map.first, &map.second, &map.steps];
        for ((bind, stride), target) in map.compact.iter().zip(targets) {
            k.compact.dispatch(&mut e, "scatter", bind, groups);
            let bytes = kept as u64 * u64::from(*stride) * 4;
            if bytes > 0 {
                e.copy_buffer_to_buffer(&map.scratch, 0, target, 0, bytes);
            }
        }
        gpu.enqueue(e);
        self.set_count(engine, kept);
        Ok(())
    }

    /// Starts a mapping step on the resident map: no Gaussian touched yet.
    pub fn begin_step(&mut self, engine: &GpuRasteriser) {
        if let Some(map) = &self.map {
            let mut e = engine.gpu.encoder();
            e.clear_buffer(&map.touched, 0, None);
            engine.gpu.enqueue(e);
        }
    }

    fn image_buffers(engine: &GpuRasteriser, size: (u32, u32)) -> ImageBuffers {
        let gpu = &engine.gpu;
        let n = u64::from(size.0) * u64::from(size.1);
        let tiles =
            u64::from(size.0.div_ceil(TILE as u32)) * u64::from(size.1.div_ceil(TILE as u32));
        ImageBuffers {
            size,
            frame: gpu.storage("frame fitted", (n * FRAME_FLOATS as u64 + 4) * 4),
            pixels: gpu.storage("pixels", n * PIXEL_FLOATS as u64 * 4),
            pixel_gradients: gpu.storage("pixel gradients", n * 5 * 4),
            stats: gpu.storage("loss statistics", n * 15 * 4),
            planes: gpu.storage("loss planes", n * 9 * 4),
            partials: gpu.storage("loss partial sums", n.div_ceil(u64::from(GROUP)) * 16),
            ranges: gpu.storage("tile ranges", tiles * 8),
            pixels_back: gpu.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pixels read-back"),
                size: n * PIXEL_FLOATS as u64 * 4 + 16,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
        }
    }

    fn pair_buffers(&self, engine: &GpuRasteriser, capacity: u32) -> PairBuffers {
        let gpu = &engine.gpu;
        let k = &engine.kernels;
        let (Some(map), Some(image)) = (&self.map, &self.image) else {
            unreachable!("pair buffers are made after the map's and the image's")
        };
        let bytes = u64::from(capacity) * 4;
        let a = [
            gpu.storage("pair tiles", bytes),
            gpu.storage("pair depths", bytes),
            gpu.storage("pair splats", bytes),
        ];
        let b = [
            gpu.storage("pair tiles (sorted)", bytes),
            gpu.storage("pair depths (sorted)", bytes),
            gpu.storage("pair splats (sorted)", bytes),
        ];
        let blocks = capacity.div_ceil(GROUP).max(1);
        let histogram = gpu.storage("sort histogram", u64::from(blocks) * 256 * 4);
        let histogram_scan = k.scan_plan(gpu, &histogram, blocks * 256);
        let total = &map.offsets_scan.total;
        let tiles = image.size.0.div_ceil(TILE as u32) * image.size.1.div_ceil(TILE as u32);
        let tile_bits = 32 - tiles.saturating_sub(1).leading_zeros();
        let mut passes: Vec<(u32, u32)> = (0..4).map(|byte| (byte * 8, 0)).collect();
        passes.extend((0..tile_bits.div_ceil(8)).map(|byte| (byte * 8, 1)));
        let mut sort_passes = Vec::new();
        let (mut from, mut to) = (&a, &b);
        for (shift, from_tile) in passes {
            let sort_params = gpu.uniform("sort params", &[blocks, 0, shift, from_tile]);
            sort_passes.push(k.sort.bind(
                gpu,
                &[
                    &sort_params,
                    &from[0],
                    &from[1],
                    &from[2],
                    &histogram,
                    &to[0],
                    &to[1],
                    &to[2],
                    total,
                ],
            ));
            std::mem::swap(&mut from, &mut to);
        }
        let sorted = from;
        // Binning writes the unsorted lists; the tile ranges read the sorted ones.
        let bin_over = |lists: &[wgpu::Buffer; 3]| {
            k.bin.bind(
                gpu,
                &[
                    &self.params,
                    &map.splats,
                    &map.rects,
                    &map.offsets,
                    &lists[0],
                    &lists[1],
                    &lists[2],
                    &image.ranges,
                    total,
                ],
            )
        };
        let bin = bin_over(&a);
        let ranges = bin_over(sorted);
        let forward = k.forward.bind(
            gpu,
            &[
                &self.params,
                &map.splats,
                &sorted[2],
                &image.ranges,
                &image.pixels,
            ],
        );
        let backward = k.backward.bind(
            gpu,
            &[
                &self.params,
                &map.splats,
                &sorted[2],
                &image.ranges,
                &image.pixels,
                &image.pixel_gradients,
                &map.screen,
                &map.gaussians,
            ],
        );
        let adam = k.adam.bind(
            gpu,
            &[
                &self.adam_params,
                &map.gradients,
                &map.gaussians,
                &map.first,
                &map.second,
                &map.steps,
                &map.touched,
                total,
            ],
        );
        PairBuffers {
            capacity,
            sort_passes,
            histogram_scan,
            bin,
            ranges,
            forward,
            backward,
            adam,
        }
    }

    /// Makes whatever buffers and bindings an iteration over a `size` view lacks.
    fn prepare(&mut self, engine: &GpuRasteriser, size: (u32, u32)) -> Result<(), RenderError> {
        let gpu = &engine.gpu;
        if self.map.is_none() {
            self.map = Some(self.map_buffers(engine, 1024));
        }
        if self.image.as_ref().is_none_or(|i| i.size != size) {
            let n = u64::from(size.0) * u64::from(size.1);
            engine.check_size(0, n as usize)?;
            if n * 15 * 4 > engine.gpu.max_binding {
                return Err(RenderError::Gpu(format!(
                    "a {}x{} view needs more than the adapter's {} bytes per binding; use --engine cpu",
                    size.0, size.1, engine.gpu.max_binding
                )));
            }
            self.image = Some(Self::image_buffers(engine, size));
            self.loss = None;
            self.pairs = None;
        }
        let (Some(map), Some(image)) = (&self.map, &self.image) else {
            unreachable!("made above")
        };
        if self.project.is_none() {
            self.project = Some(engine.kernels.project.bind(
                gpu,
                &[
                    &self.params,
                    &map.gaussians,
                    &map.splats,
                    &map.rects,
                    &map.screen,
                    &map.gradients,
                ],
            ));
        }
        if self.loss.is_none() {
            self.loss = Some(engine.kernels.loss.bind(
                gpu,
                &[
                    &self.params,
                    &image.pixels,
                    &image.frame,
                    &image.stats,
                    &image.planes,
                    &image.pixel_gradients,
                    &image.partials,
                    &self.terms,
                ],
            ));
        }
        if self.pairs.is_none() {
            let guess = (self.count as u32).saturating_mul(4).max(1 << 16);
            let capacity = guess.min((engine.gpu.max_binding / 4) as u32);
            self.pairs = Some(self.pair_buffers(engine, capacity));
            self.write_adam_params(engine, capacity);
        }
        Ok(())
    }

    /// One mapping iteration on view `view`: render, loss, gradients, Adam, all on the GPU.
    /// Returns the loss terms (of the map before this iteration's Adam step).
    pub fn iterate(
        &mut self,
        engine: &GpuRasteriser,
        view: usize,
    ) -> Result<LossTerms, RenderError> {
        let size = self.view_size(view)?;
        self.prepare(engine, size)?;
        loop {
            let (terms, pairs) = self.record_and_run(engine, view)?;
            let capacity = self.pairs.as_ref().map_or(0, |p| p.capacity);
            if pairs <= capacity {
                return Ok(terms);
            }
            // Overflowed: nothing was applied; grow and repeat.
            self.grow_pairs(engine, pairs)?;
        }
    }

    /// Renders the resident map at view `view` (colour, depth, silhouette) and reads the
    /// pixels back: densification's render, without uploading the map.
    pub fn render(&mut self, engine: &GpuRasteriser, view: usize) -> Result<Images, RenderError> {
        let size = self.view_size(view)?;
        self.prepare(engine, size)?;
        let (w, h) = (size.0 as usize, size.1 as usize);
        let floats = w * h * PIXEL_FLOATS;
        loop {
            let Prepared {
                map, image, pairs, ..
            } = self.prepared(view);
            let mut e = engine.gpu.encoder();
            self.record_render(engine, &mut e, view);
            let bytes = (floats * 4) as u64;
            e.copy_buffer_to_buffer(&image.pixels, 0, &image.pixels_back, 0, bytes);
            e.copy_buffer_to_buffer(&map.offsets_scan.total, 0, &image.pixels_back, bytes, 4);
            engine.gpu.enqueue(e);
            let back = engine.gpu.map_read(&image.pixels_back, floats * 4 + 4)?;
            let needed = u32::from_le_bytes([
                back[floats * 4],
                back[floats * 4 + 1],
                back[floats * 4 + 2],
                back[floats * 4 + 3],
            ]);
            if needed <= pairs.capacity {
                let values: Vec<f32> = bytemuck::pod_collect_to_vec(&back[..floats * 4]);
                let mut images = Images::zeros(w, h);
                unpack_pixels(&values, 0, &mut images);
                return Ok(images);
            }
            self.grow_pairs(engine, needed)?;
        }
    }

    /// The pair buffers grown to hold `needed` pairs (doubled), or an error past the
    /// adapter's binding limit.
    fn grow_pairs(&mut self, engine: &GpuRasteriser, needed: u32) -> Result<(), RenderError> {
        let capacity = self.pairs.as_ref().map_or(0, |p| p.capacity);
        let limit = (engine.gpu.max_binding / 4) as u32;
        if capacity >= limit {
            return Err(RenderError::Gpu(format!(
                "{needed} (tile, Gaussian) pairs exceed the adapter's binding limit of {limit}; \
                 use --engine cpu or fewer Gaussians"
            )));
        }
        let grown = needed.next_power_of_two().min(limit);
        tracing::debug!(needed, grown, "resident pair buffers grown");
        self.pairs = Some(self.pair_buffers(engine, grown));
        self.write_adam_params(engine, grown);
        Ok(())
    }

    /// The size of view `view`, or an error when there is no such view.
    fn view_size(&self, view: usize) -> Result<(u32, u32), RenderError> {
        match self.views.get(view) {
            Some(v) => Ok(v.size),
            None => Err(RenderError::Gpu(format!(
                "view {view} does not exist ({} uploaded)",
                self.views.len()
            ))),
        }
    }

    /// The buffers and bindings an iteration over `view` records, once [`Self::prepare`] made
    /// them.
    fn prepared(&self, view: usize) -> Prepared<'_> {
        let (Some(map), Some(image), Some(pairs), Some(project), Some(loss), Some(view)) = (
            &self.map,
            &self.image,
            &self.pairs,
            &self.project,
            &self.loss,
            self.views.get(view),
        ) else {
            unreachable!("prepare made every buffer")
        };
        Prepared {
            map,
            image,
            pairs,
            project,
            loss,
            view,
        }
    }

    /// Records the render of view `view` into `e`: its camera into the shared uniform,
    /// projection, binning, the pairs' sort, the tile ranges and the forward pass.
    fn record_render(&self, engine: &GpuRasteriser, e: &mut wgpu::CommandEncoder, view: usize) {
        let k = &engine.kernels;
        let Prepared {
            map,
            image,
            pairs,
            project,
            view: v,
            ..
        } = self.prepared(view);
        let count = self.count as u32;
        let tiles = tile_grid(v.size);
        e.copy_buffer_to_buffer(
            &v.params,
            0,
            &self.params,
            0,
            std::mem::size_of::<GpuParams>() as u64,
        );
        e.clear_buffer(&map.offsets, 0, None);
        e.clear_buffer(&image.ranges, 0, None);
        e.clear_buffer(&map.screen, 0, None);
        let groups = linear_groups(count);
        k.project.dispatch(e, "project", project, groups);
        k.bin.dispatch(e, "count_pairs", &pairs.bin, groups);
        map.offsets_scan.record(k, e);
        k.bin.dispatch(e, "emit_pairs", &pairs.bin, groups);
        let pair_groups = linear_groups(pairs.capacity);
        for bind in &pairs.sort_passes {
            k.sort.dispatch(e, "histogram_pass", bind, pair_groups);
            pairs.histogram_scan.record(k, e);
            k.sort.dispatch(e, "scatter_pass", bind, pair_groups);
        }
        k.bin.dispatch(e, "tile_ranges", &pairs.ranges, pair_groups);
        k.forward.dispatch(e, "forward", &pairs.forward, tiles);
    }

    fn record_and_run(
        &self,
        engine: &GpuRasteriser,
        view: usize,
    ) -> Result<(LossTerms, u32), RenderError> {
        let gpu = &engine.gpu;
        let k = &engine.kernels;
        let Prepared {
            map,
            image,
            pairs,
            project,
            loss,
            view: v,
        } = self.prepared(view);
        let count = self.count as u32;
        let pixel_count = v.size.0 * v.size.1;
        let tiles = tile_grid(v.size);
        let mut e = gpu.encoder();
        e.copy_buffer_to_buffer(&v.frame, 0, &image.frame, 0, v.frame.size());
        self.record_render(engine, &mut e, view);
        let groups = linear_groups(count);
        let pixel_groups = linear_groups(pixel_count);
        for entry in ["loss_h", "loss_v", "loss_bh", "loss_bv"] {
            k.loss.dispatch(&mut e, entry, loss, pixel_groups);
        }
        k.loss.dispatch(&mut e, "loss_total", loss, (1, 1));
        k.backward
            .dispatch(&mut e, "backward", &pairs.backward, tiles);
        k.project.dispatch(&mut e, "chain", project, groups);
        k.adam.dispatch(&mut e, "adam_step", &pairs.adam, groups);
        e.copy_buffer_to_buffer(&self.terms, 0, &self.staging, 0, 16);
        e.copy_buffer_to_buffer(&map.offsets_scan.total, 0, &self.staging, 16, 4);
        gpu.enqueue(e);
        let bytes = gpu.map_read(&self.staging, 20)?;
        let values: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes[..16]);
        let pairs_needed = u32::from_le_bytes([bytes[16], bytes[17], bytes[18], bytes[19]]);
        Ok((
            LossTerms {
                depth_l1: values[0],
                colour_l1: values[1],
                ssim: values[2],
            },
            pairs_needed,
        ))
    }

    /// Copies the map and which Gaussians any iteration since [`Self::begin_step`] touched
    /// back to the host: the one read-back of a mapping step (Adam's state stays on the GPU).
    pub fn store_map(
        &self,
        engine: &GpuRasteriser,
        gaussians: &mut Gaussians,
        touched: &mut [bool],
    ) -> Result<(), RenderError> {
        let n = self.count;
        if gaussians.len() != n || touched.len() != n {
            return Err(RenderError::Gpu(format!(
                "{} Gaussians and {} touched flags given back for {n} resident",
                gaussians.len(),
                touched.len()
            )));
        }
        let Some(map) = &self.map else {
            return Ok(());
        };
        if n == 0 {
            return Ok(());
        }
        let record = (n * RECORD * 4) as u64;
        let flags = (n * 4) as u64;
        let mut e = engine.gpu.encoder();
        e.copy_buffer_to_buffer(&map.gaussians, 0, &map.map_back, 0, record);
        e.copy_buffer_to_buffer(&map.touched, 0, &map.map_back, record, flags);
        engine.gpu.enqueue(e);
        let bytes = engine
            .gpu
            .map_read(&map.map_back, (record + flags) as usize)?;
        let floats: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes[..record as usize]);
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes[record as usize..]);
        unpack(&floats, gaussians);
        for (t, w) in touched.iter_mut().zip(&words) {
            *t |= *w != 0;
        }
        Ok(())
    }

    /// Copies the map, Adam's state and which Gaussians any iteration since [`Self::load`]
    /// touched back to the host (tests and benchmarks compare Adam's state with the CPU's).
    pub fn store(
        &self,
        engine: &GpuRasteriser,
        gaussians: &mut Gaussians,
        adam: AdamStateMut<'_>,
        touched: &mut [bool],
    ) -> Result<(), RenderError> {
        let Some(map) = &self.map else {
            return Ok(());
        };
        let n = self.count;
        if gaussians.len() != n || touched.len() != n {
            return Err(RenderError::Gpu(format!(
                "{} Gaussians and {} touched flags given back for {n} resident",
                gaussians.len(),
                touched.len()
            )));
        }
        let gpu = &engine.gpu;
        let record = (n * RECORD * 4) as u64;
        let flags = (n * 4) as u64;
        let total = 3 * record + 2 * flags;
        let staging = gpu.create_buffer(&wgpu::BufferDescriptor {
            label: Some("map read-back"),
            size: total.max(4),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut e = gpu.encoder();
        let mut at = 0;
        for (source, bytes) in [
            (&map.gaussians, record),
            (&map.first, record),
            (&map.second, record),
            (&map.steps, flags),
            (&map.touched, flags),
        ] {
            if bytes > 0 {
                e.copy_buffer_to_buffer(source, 0, &staging, at, bytes);
            }
            at += bytes;
        }
        gpu.enqueue(e);
        let bytes = gpu.map_read(&staging, total as usize)?;
        let floats: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes[..3 * record as usize]);
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes[3 * record as usize..]);
        let per = n * RECORD;
        unpack(&floats[..per], gaussians);
        unpack(&floats[per..2 * per], adam.first);
        unpack(&floats[2 * per..], adam.second);
        adam.steps.copy_from_slice(&words[..n]);
        for (t, w) in touched.iter_mut().zip(&words[n..]) {
            *t |= *w != 0;
        }
        Ok(())
    }
}
