//! The wgpu engine: the CPU engine's structure in WGSL. Projection (one thread per Gaussian),
//! binning into 16x16 tiles (count, exclusive scan, emit), a stable radix sort of the
//! (tile, depth) keys, tile ranges, front-to-back compositing per tile, and back-to-front
//! gradients summed per tile and added with compare-and-swap float atomics.
//!
//! The image is processed in bands of tile rows, as many as it takes for each band's pair and
//! pixel buffers to fit the adapter's storage binding limit (one band is the usual case); each
//! band keeps its sorted lists for the backward pass.

mod device;
pub(crate) mod kernels;
mod resident;
mod timing;

pub use device::{AdapterPolicy, GpuDevice, GpuError, GpuOptions, Traffic};
pub use resident::ResidentMap;
pub use timing::PassTimes;

use super::{validate_camera, FisherDiagonal, ImageGradients, Images, RenderError, TILE};
use crate::camera::PinholeCamera;
use crate::gaussians::{Gaussians, Gradients};
use kernels::{linear_groups, Kernels};

/// Uniform block shared by the kernels; mirrors `Params` in common.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuParams {
    camera_from_world: [f32; 16],
    fx: f32,
    fy: f32,
    cx: f32,
    cy: f32,
    width: u32,
    height: u32,
    tiles_x: u32,
    tiles_y: u32,
    count: u32,
    near: f32,
    min_alpha: f32,
    max_alpha: f32,
    min_transmittance: f32,
    band_start: u32,
    band_end: u32,
    pad: u32,
}

/// Bytes per Gaussian in the largest per-Gaussian buffer (the splat records).
const SPLAT_BYTES: u64 = 48;
/// Floats per pixel of the forward output.
const PIXEL_FLOATS: usize = 7;

/// Copies the forward kernel's pixels (`PIXEL_FLOATS` each) into `images` from pixel `first`
/// on: colour, depth, silhouette.
fn unpack_pixels(values: &[f32], first: usize, images: &mut Images) {
    for (i, v) in values.chunks_exact(PIXEL_FLOATS).enumerate() {
        let p = first + i;
        images.colour[3 * p..3 * p + 3].copy_from_slice(&v[..3]);
        images.depth[p] = v[3];
        images.silhouette[p] = v[4];
    }
}

/// The engine: a device and its compiled kernels.
pub struct GpuRasteriser {
    gpu: GpuDevice,
    kernels: Kernels,
}

impl std::fmt::Debug for GpuRasteriser {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "GpuRasteriser({})", self.gpu.describe())
    }
}

/// Sorted pairs of one band, kept for the backward pass.
struct BandLists {
    pair_splats: wgpu::Buffer,
    ranges: wgpu::Buffer,
}

/// One band of tile rows: its uniform, lists and forward output.
struct Band {
    rows: (u32, u32),
    uniform: wgpu::Buffer,
    lists: BandLists,
    pixels: wgpu::Buffer,
    pairs: u64,
}

/// A forward pass and the GPU state its backward pass needs.
pub struct GpuRender {
    /// The images.
    pub images: Images,
    params: GpuParams,
    gaussians: wgpu::Buffer,
    splats: wgpu::Buffer,
    bands: Vec<Band>,
}

impl std::fmt::Debug for GpuRender {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "GpuRender({} bands, {} pairs)",
            self.bands.len(),
            self.pair_count()
        )
    }
}

impl GpuRender {
    /// (tile, splat) pairs binned, summed over bands.
    pub fn pair_count(&self) -> u64 {
        self.bands.iter().map(|b| b.pairs).sum()
    }

    /// Tile-row bands the image was split into to fit the binding limit.
    pub fn band_count(&self) -> usize {
        self.bands.len()
    }
}

impl From<GpuError> for RenderError {
    fn from(e: GpuError) -> Self {
        RenderError::Gpu(e.to_string())
    }
}

impl GpuRasteriser {
    /// Opens an adapter under `policy`; `binding_cap` lowers the storage binding limit
    /// (tests use it to force splitting).
    pub fn new(policy: AdapterPolicy, binding_cap: Option<u64>) -> Result<Self, GpuError> {
        Self::with_options(
            policy,
            GpuOptions {
                binding_cap,
                ..GpuOptions::default()
            },
        )
    }

    /// Opens an adapter under `policy` with `options` (e.g. subgroups off, to compare the
    /// kernels).
    pub fn with_options(policy: AdapterPolicy, options: GpuOptions) -> Result<Self, GpuError> {
        let gpu = GpuDevice::open(policy, options)?;
        let kernels = Kernels::new(&gpu);
        gpu.check()?;
        Ok(GpuRasteriser { gpu, kernels })
    }

    /// The adapter, in words.
    pub fn describe(&self) -> String {
        self.gpu.describe()
    }

    /// The host's traffic with the device so far (buffers created, submits, bytes each way).
    pub fn traffic(&self) -> Traffic {
        self.gpu.traffic()
    }

    /// Runs `work` with its compute passes timed on the GPU (see [`GpuDevice::time_passes`]).
    pub fn time_passes<T, E: From<GpuError>>(
        &self,
        work: impl FnOnce() -> Result<T, E>,
    ) -> Result<(T, Option<PassTimes>), E> {
        self.gpu.time_passes(work)
    }

    /// Whether the adapter is a software rasteriser.
    pub fn is_software(&self) -> bool {
        self.gpu.is_software()
    }

    /// Whether the backward pass sums by subgroup.
    pub fn has_subgroups(&self) -> bool {
        self.gpu.has_subgroups()
    }

    fn params(&self, camera: &PinholeCamera, count: usize) -> GpuParams {
        let k = camera.intrinsics;
        let m = camera
            .world_from_camera
            .inverse()
            .to_homogeneous()
            .cast::<f32>();
        let mut camera_from_world = [0.0f32; 16];
        // Column-major, as WGSL's mat4x4 expects.
        camera_from_world.copy_from_slice(m.as_slice());
        GpuParams {
            camera_from_world,
            fx: k.fx as f32,
            fy: k.fy as f32,
            cx: k.cx as f32,
            cy: k.cy as f32,
            width: k.width,
            height: k.height,
            tiles_x: (k.width as usize).div_ceil(TILE) as u32,
            tiles_y: (k.height as usize).div_ceil(TILE) as u32,
            count: count as u32,
            near: super::NEAR_PLANE as f32,
            min_alpha: super::MIN_ALPHA as f32,
            max_alpha: super::MAX_ALPHA as f32,
            min_transmittance: super::MIN_TRANSMITTANCE as f32,
            band_start: 0,
            band_end: 0,
            pad: 0,
        }
    }

    fn check_size(&self, gaussians: usize, pixels: usize) -> Result<(), GpuError> {
        let limit = self.gpu.max_binding;
        let bytes = gaussians as u64 * SPLAT_BYTES;
        if bytes > limit {
            return Err(GpuError::TooLarge(format!(
                "{gaussians} Gaussians need {bytes} bytes of splat records but this adapter \
                 binds at most {limit}; use --engine cpu or fewer Gaussians"
            )));
        }
        if gaussians > u32::MAX as usize / 4 || pixels > u32::MAX as usize / 8 {
            return Err(GpuError::TooLarge(format!(
                "{gaussians} Gaussians are too many"
            )));
        }
        Ok(())
    }

    /// Counts the pairs of the band `rows`; returns the per-splat offsets (scanned) and the
    /// total.
    fn count_band(
        &self,
        state: &BandInputs,
        rows: (u32, u32),
    ) -> Result<(wgpu::Buffer, wgpu::Buffer, wgpu::Buffer, u64), GpuError> {
        let gpu = &self.gpu;
        let n = state.params.count;
        let params = GpuParams {
            band_start: rows.0,
            band_end: rows.1,
            ..state.params
        };
        let uniform = gpu.uniform("band params", &params);
        let offsets = gpu.storage("pair offsets", u64::from(n) * 4);
        let dummy = gpu.storage("unused", 16);
        let dummy2 = gpu.storage("unused", 16);
        let dummy3 = gpu.storage("unused", 16);
        let dummy4 = gpu.storage("unused", 16);
        let dummy5 = gpu.storage("unused", 16);
        let bind = self.kernels.bin.bind(
            gpu,
            &[
                &uniform,
                state.splats,
                state.rects,
                &offsets,
                &dummy,
                &dummy2,
                &dummy3,
                &dummy4,
                &dummy5,
            ],
        );
        let mut encoder = gpu.encoder();
        self.kernels
            .bin
            .dispatch(&mut encoder, "count_pairs", &bind, linear_groups(n));
        let total = self.kernels.scan(gpu, &mut encoder, &offsets, n);
        let total_value = gpu.read::<u32>(encoder, &total, 1)?;
        Ok((uniform, offsets, total, u64::from(total_value[0])))
    }

    /// Emits, sorts and ranges the pairs of one band; returns its lists.
    fn bin_band(
        &self,
        state: &BandInputs,
        uniform: &wgpu::Buffer,
        offsets: &wgpu::Buffer,
        total: &wgpu::Buffer,
        pairs: u32,
        encoder: &mut wgpu::CommandEncoder,
    ) -> BandLists {
        let gpu = &self.gpu;
        let p = state.params;
        let bytes = u64::from(pairs) * 4;
        let mut a = [
            gpu.storage("pair tiles", bytes),
            gpu.storage("pair depths", bytes),
            gpu.storage("pair splats", bytes),
        ];
        let mut b = [
            gpu.storage("pair tiles (sorted)", bytes),
            gpu.storage("pair depths (sorted)", bytes),
            gpu.storage("pair splats (sorted)", bytes),
        ];
        let ranges = gpu.storage("tile ranges", u64::from(p.tiles_x * p.tiles_y) * 8);
        let bind = self.kernels.bin.bind(
            gpu,
            &[
                uniform,
                state.splats,
                state.rects,
                offsets,
                &a[0],
                &a[1],
                &a[2],
                &ranges,
                total,
            ],
        );
        self.kernels
            .bin
            .dispatch(encoder, "emit_pairs", &bind, linear_groups(p.count));
        // Radix sort: the depth's 4 bytes, then as many of the tile's as it has.
        let tile_bits = 32 - (p.tiles_x * p.tiles_y).saturating_sub(1).leading_zeros();
        let mut passes: Vec<(u32, u32)> = (0..4).map(|byte| (byte * 8, 0)).collect();
        passes.extend((0..tile_bits.div_ceil(8)).map(|byte| (byte * 8, 1)));
        let blocks = pairs.div_ceil(kernels::GROUP).max(1);
        let histogram = gpu.storage("sort histogram", u64::from(blocks) * 256 * 4);
        for (shift, from_tile) in passes {
            let sort_params = gpu.uniform("sort params", &[blocks, 0, shift, from_tile]);
            let bind = self.kernels.sort.bind(
                gpu,
                &[
                    &sort_params,
                    &a[0],
                    &a[1],
                    &a[2],
                    &histogram,
                    &b[0],
                    &b[1],
                    &b[2],
                    total,
                ],
            );
            let groups = linear_groups(pairs);
            self.kernels
                .sort
                .dispatch(encoder, "histogram_pass", &bind, groups);
            self.kernels.scan(gpu, encoder, &histogram, blocks * 256);
            self.kernels
                .sort
                .dispatch(encoder, "scatter_pass", &bind, groups);
            std::mem::swap(&mut a, &mut b);
        }
        encoder.clear_buffer(&ranges, 0, None);
        let bind = self.kernels.bin.bind(
            gpu,
            &[
                uniform,
                state.splats,
                state.rects,
                offsets,
                &a[0],
                &a[1],
                &a[2],
                &ranges,
                total,
            ],
        );
        self.kernels
            .bin
            .dispatch(encoder, "tile_ranges", &bind, linear_groups(pairs));
        let [_, _, pair_splats] = a;
        BandLists {
            pair_splats,
            ranges,
        }
    }

    /// Splits the tile rows into bands whose pairs and pixels fit the binding limit, and
    /// bins each.
    fn bin_bands(&self, state: &BandInputs) -> Result<Vec<Band>, GpuError> {
        let max_pairs = self.gpu.max_binding / 4;
        let row_bytes = u64::from(state.params.width) * TILE as u64 * PIXEL_FLOATS as u64 * 4;
        let mut todo = vec![(0, state.params.tiles_y)];
        let mut bands = Vec::new();
        while let Some(rows) = todo.pop() {
            let tall = u64::from(rows.1 - rows.0) * row_bytes > self.gpu.max_binding;
            let (uniform, offsets, total, pairs) = if tall {
                (None, None, None, 0)
            } else {
                let (u, o, t, p) = self.count_band(state, rows)?;
                (Some(u), Some(o), Some(t), p)
            };
            // The sort's histogram holds 256 counters per 256 pairs: as many as the pairs.
            let (Some(uniform), Some(offsets), Some(total), false) =
                (uniform, offsets, total, pairs > max_pairs)
            else {
                if rows.1 - rows.0 == 1 {
                    return Err(GpuError::TooLarge(format!(
                        "one row of tiles needs {pairs} (tile, Gaussian) pairs and {row_bytes} \
                         bytes of pixels but this adapter binds at most {} bytes; use --engine \
                         cpu, fewer Gaussians or a smaller image",
                        self.gpu.max_binding
                    )));
                }
                let middle = (rows.0 + rows.1) / 2;
                todo.push((middle, rows.1));
                todo.push((rows.0, middle));
                continue;
            };
            let mut encoder = self.gpu.encoder();
            let lists = self.bin_band(
                state,
                &uniform,
                &offsets,
                &total,
                pairs as u32,
                &mut encoder,
            );
            self.gpu.submit(encoder)?;
            let height =
                ((rows.1 - rows.0) * TILE as u32).min(state.params.height - rows.0 * TILE as u32);
            let pixels = self.gpu.storage(
                "band pixels",
                u64::from(height) * u64::from(state.params.width) * PIXEL_FLOATS as u64 * 4,
            );
            bands.push(Band {
                rows,
                uniform,
                lists,
                pixels,
                pairs,
            });
        }
        Ok(bands)
    }

    /// Renders colour, depth and silhouette.
    pub fn render(
        &self,
        gaussians: &Gaussians,
        camera: &PinholeCamera,
    ) -> Result<GpuRender, RenderError> {
        gaussians.validate()?;
        validate_camera(camera)?;
        let (w, h) = (
            camera.intrinsics.width as usize,
            camera.intrinsics.height as usize,
        );
        self.check_size(gaussians.len(), w * h)?;
        let gpu = &self.gpu;
        let params = self.params(camera, gaussians.len());
        let packed = resident::pack(gaussians);
        let gaussian_buffer = gpu.storage_with("gaussians", &packed);
        let splats = gpu.storage("splats", gaussians.len() as u64 * SPLAT_BYTES);
        let rects = gpu.storage("tile rects", gaussians.len() as u64 * 16);
        let uniform = gpu.uniform("params", &params);
        let unused_screen = gpu.storage("unused", 16);
        let unused_gradients = gpu.storage("unused", 16);
        let bind = self.kernels.project.bind(
            gpu,
            &[
                &uniform,
                &gaussian_buffer,
                &splats,
                &rects,
                &unused_screen,
                &unused_gradients,
            ],
        );
        let mut encoder = gpu.encoder();
        self.kernels
            .project
            .dispatch(&mut encoder, "project", &bind, linear_groups(params.count));
        gpu.submit(encoder)?;
        let state = BandInputs {
            params,
            splats: &splats,
            rects: &rects,
        };
        let bands = self.bin_bands(&state)?;
        let mut images = Images::zeros(w, h);
        for band in &bands {
            let mut encoder = gpu.encoder();
            let bind = self.kernels.forward.bind(
                gpu,
                &[
                    &band.uniform,
                    &splats,
                    &band.lists.pair_splats,
                    &band.lists.ranges,
                    &band.pixels,
                ],
            );
            self.kernels.forward.dispatch(
                &mut encoder,
                "forward",
                &bind,
                (params.tiles_x, band.rows.1 - band.rows.0),
            );
            let first = band.rows.0 as usize * TILE * w;
            let count = (band.rows.1 as usize * TILE).min(h) * w - first;
            let values: Vec<f32> = gpu.read(encoder, &band.pixels, count * PIXEL_FLOATS)?;
            unpack_pixels(&values, first, &mut images);
        }
        Ok(GpuRender {
            images,
            params,
            gaussians: gaussian_buffer,
            splats,
            bands,
        })
    }

    /// Runs the per-tile backward kernel `entry` over every band with per-pixel gradients
    /// `image_gradients`; returns the per-Gaussian sums (9 floats as bits each).
    fn walk_bands(
        &self,
        render: &GpuRender,
        image_gradients: &ImageGradients,
        entry: &str,
    ) -> Result<wgpu::Buffer, RenderError> {
        let pixel_count = render.images.width * render.images.height;
        image_gradients.check(pixel_count)?;
        let gpu = &self.gpu;
        let params = render.params;
        let count = params.count as usize;
        let screen = gpu.storage("screen gradients", count as u64 * 36);
        let mut encoder = gpu.encoder();
        encoder.clear_buffer(&screen, 0, None);
        gpu.submit(encoder)?;
        let width = render.images.width;
        for band in &render.bands {
            let first = band.rows.0 as usize * TILE * width;
            let end = (band.rows.1 as usize * TILE * width).min(pixel_count);
            let packed: Vec<f32> = (first..end)
                .flat_map(|p| {
                    [
                        image_gradients.colour[3 * p],
                        image_gradients.colour[3 * p + 1],
                        image_gradients.colour[3 * p + 2],
                        image_gradients.depth[p],
                        image_gradients.silhouette[p],
                    ]
                })
                .collect();
            let pixel_gradients = gpu.storage_with("pixel gradients", &packed);
            let mut encoder = gpu.encoder();
            let bind = self.kernels.backward.bind(
                gpu,
                &[
                    &band.uniform,
                    &render.splats,
                    &band.lists.pair_splats,
                    &band.lists.ranges,
                    &band.pixels,
                    &pixel_gradients,
                    &screen,
                    &render.gaussians,
                ],
            );
            self.kernels.backward.dispatch(
                &mut encoder,
                entry,
                &bind,
                (params.tiles_x, band.rows.1 - band.rows.0),
            );
            gpu.submit(encoder)?;
        }
        Ok(screen)
    }

    /// The diagonal Fisher information of the view `render` drew (colour and depth with an
    /// upstream gradient of 1, each pixel squared on its own), as the CPU engine's `fisher`.
    pub fn fisher(&self, render: &GpuRender) -> Result<FisherDiagonal, RenderError> {
        let pixels = render.images.width * render.images.height;
        let ones = ImageGradients {
            colour: vec![1.0; 3 * pixels],
            depth: vec![1.0; pixels],
            silhouette: vec![0.0; pixels],
        };
        let screen = self.walk_bands(render, &ones, "fisher")?;
        let count = render.params.count as usize;
        let bits: Vec<u32> = self.gpu.read(self.gpu.encoder(), &screen, count * 9)?;
        Ok(bits
            .chunks_exact(9)
            .map(|h| std::array::from_fn(|k| f32::from_bits(h[k])))
            .collect())
    }

    /// Gradients of a loss with per-pixel gradients `image_gradients` with respect to every
    /// parameter of the Gaussians that `render` drew.
    pub fn backward(
        &self,
        render: &GpuRender,
        image_gradients: &ImageGradients,
    ) -> Result<Gradients, RenderError> {
        let screen = self.walk_bands(render, image_gradients, "backward")?;
        let gpu = &self.gpu;
        let params = render.params;
        let count = params.count as usize;
        let uniform = gpu.uniform("params", &params);
        let unused_rects = gpu.storage("unused", 16);
        let gradient_buffer = gpu.storage("gradients", count as u64 * 36);
        let bind = self.kernels.project.bind(
            gpu,
            &[
                &uniform,
                &render.gaussians,
                &render.splats,
                &unused_rects,
                &screen,
                &gradient_buffer,
            ],
        );
        let mut encoder = gpu.encoder();
        self.kernels
            .project
            .dispatch(&mut encoder, "chain", &bind, linear_groups(params.count));
        let values: Vec<f32> = gpu.read(encoder, &gradient_buffer, count * 9)?;
        let mut gradients = Gradients::zeros(count);
        for (i, g) in values.chunks_exact(9).enumerate() {
            gradients.means[i] = [g[0], g[1], g[2]];
            gradients.log_radii[i] = g[3];
            gradients.logit_opacities[i] = g[4];
            gradients.colours[i] = [g[5], g[6], g[7]];
            if g[8] != 0.0 {
                gradients.touched.push(i as u32);
            }
        }
        Ok(gradients)
    }
}

/// What binning a band reads.
struct BandInputs<'a> {
    params: GpuParams,
    splats: &'a wgpu::Buffer,
    rects: &'a wgpu::Buffer,
}
