//! Opening a wgpu device for compute, and the small buffer chores every kernel needs
//! (storage buffers, uniforms, read-back), with wgpu's errors turned into values.

use super::timing::{PassTimer, PassTimes};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use wgpu::util::DeviceExt;

/// Which adapters may serve the GPU engine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AdapterPolicy {
    /// Only a hardware GPU (discrete, integrated or virtual): what `--engine auto` wants.
    HardwareOnly,
    /// A hardware GPU if there is one, else a software rasteriser such as lavapipe.
    AllowSoftware,
}

/// Why no GPU device could be opened or a GPU operation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GpuError {
    /// No adapter fits the policy.
    #[error("no usable GPU adapter ({0})")]
    NoAdapter(String),
    /// The adapter refused a device.
    #[error("the GPU adapter refused a device: {0}")]
    Device(String),
    /// wgpu reported a validation, memory or device-loss error.
    #[error("GPU error: {0}")]
    Operation(String),
    /// The problem does not fit this adapter's limits even after splitting.
    #[error("{0}")]
    TooLarge(String),
}

/// What the host has asked of the device so far: the proxies of a GPU engine's cost that any
/// adapter shows (a software one too), for `bench render` and the tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Traffic {
    /// Buffers created.
    pub buffers: u64,
    /// Command buffers submitted to the queue.
    pub submits: u64,
    /// Bytes written from the host into buffers.
    pub uploaded: u64,
    /// Bytes copied back to the host.
    pub read_back: u64,
}

impl std::ops::Sub for Traffic {
    type Output = Traffic;

    fn sub(self, earlier: Traffic) -> Traffic {
        Traffic {
            buffers: self.buffers - earlier.buffers,
            submits: self.submits - earlier.submits,
            uploaded: self.uploaded - earlier.uploaded,
            read_back: self.read_back - earlier.read_back,
        }
    }
}

impl Traffic {
    /// The traffic of one of `n` equal operations (an iteration, when this is the traffic of
    /// `n` of them).
    pub fn per(self, n: u64) -> Traffic {
        let n = n.max(1);
        Traffic {
            buffers: self.buffers / n,
            submits: self.submits / n,
            uploaded: self.uploaded / n,
            read_back: self.read_back / n,
        }
    }
}

/// The running totals behind [`Traffic`].
#[derive(Debug, Default)]
struct TrafficCounters {
    buffers: AtomicU64,
    submits: AtomicU64,
    uploaded: AtomicU64,
    read_back: AtomicU64,
}

/// A device and queue, with the adapter they came from.
pub struct GpuDevice {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Name, backend and type of the adapter.
    pub info: wgpu::AdapterInfo,
    /// Largest storage binding, bytes (the adapter's, or lower when asked).
    pub max_binding: u64,
    errors: Arc<Mutex<Vec<String>>>,
    traffic: TrafficCounters,
    /// Per-pass GPU timestamps, where the adapter has them.
    timer: Option<Arc<PassTimer>>,
    /// Whether subgroup operations are on (the adapter has them and the options allow them).
    subgroups: bool,
}

/// How a device is opened.
#[derive(Debug, Clone, Copy)]
pub struct GpuOptions {
    /// Lowers the storage binding limit to this many bytes (tests use a small cap to exercise
    /// splitting on small scenes).
    pub binding_cap: Option<u64>,
    /// Use subgroup operations where the adapter has them (the backward pass sums by
    /// subgroup); off forces the workgroup-memory kernels, e.g. to compare the two.
    pub subgroups: bool,
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions {
            binding_cap: None,
            subgroups: true,
        }
    }
}

impl std::fmt::Debug for GpuDevice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "GpuDevice({})", self.describe())
    }
}

fn is_hardware(info: &wgpu::AdapterInfo) -> bool {
    matches!(
        info.device_type,
        wgpu::DeviceType::DiscreteGpu
            | wgpu::DeviceType::IntegratedGpu
            | wgpu::DeviceType::VirtualGpu
    )
}

/// Picks an adapter: `WGPU_ADAPTER_NAME` when set, else the best hardware GPU, else (if the
/// policy allows) a software one. `WGPU_BACKEND` and the other wgpu variables apply.
fn pick_adapter(
    instance: &wgpu::Instance,
    policy: AdapterPolicy,
) -> Result<wgpu::Adapter, GpuError> {
    let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
    // WGPU_ADAPTER_NAME: matched here (a case-insensitive substring, as wgpu matches it) so
    // that a name matching nothing is a warning and the usual choice, never a panic.
    if let Some(wanted) = std::env::var_os("WGPU_ADAPTER_NAME") {
        let wanted = wanted.to_string_lossy().to_lowercase();
        let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
        match adapters
            .iter()
            .position(|a| a.get_info().name.to_lowercase().contains(&wanted))
        {
            Some(k) => return Ok(adapters[k].clone()),
            None => tracing::warn!(
                "WGPU_ADAPTER_NAME={wanted:?} matches none of the adapters ({}); choosing as if it were unset",
                names.join(", ")
            ),
        }
    }
    let rank = |a: &wgpu::Adapter| match a.get_info().device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    let seen: Vec<String> = adapters
        .iter()
        .map(|a| {
            let i = a.get_info();
            format!("{} ({:?}, {:?})", i.name, i.device_type, i.backend)
        })
        .collect();
    let best = adapters
        .into_iter()
        .filter(|a| {
            a.get_downlevel_capabilities()
                .flags
                .contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
        })
        .filter(|a| policy == AdapterPolicy::AllowSoftware || is_hardware(&a.get_info()))
        .min_by_key(rank);
    best.ok_or_else(|| {
        let wanted = match policy {
            AdapterPolicy::HardwareOnly => "a hardware GPU",
            AdapterPolicy::AllowSoftware => "any compute-capable adapter",
        };
        if seen.is_empty() {
            GpuError::NoAdapter(format!(
                "wanted {wanted}; wgpu found no adapter at all (is a Vulkan driver installed? \
                 scripts/setup.sh installs Mesa's lavapipe)"
            ))
        } else {
            GpuError::NoAdapter(format!("wanted {wanted}; found {}", seen.join(", ")))
        }
    })
}

impl GpuDevice {
    /// Opens a device with the adapter's own limits, under `options`.
    pub fn open(policy: AdapterPolicy, options: GpuOptions) -> Result<Self, GpuError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pick_adapter(&instance, policy)?;
        let info = adapter.get_info();
        let limits = adapter.limits();
        let wanted = if options.subgroups {
            wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::SUBGROUP
        } else {
            wgpu::Features::TIMESTAMP_QUERY
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("splatloop splat engine"),
            // Timestamps only where the adapter has them: `bench render`'s per-pass table.
            // Subgroups where it has them and they are wanted: the backward pass's sums.
            required_features: adapter.features() & wanted,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&errors);
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            tracing::error!("wgpu: {e}");
            if let Ok(mut list) = sink.lock() {
                list.push(e.to_string());
            }
        }));
        let adapter_max = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let max_binding = options
            .binding_cap
            .map_or(adapter_max, |cap| cap.min(adapter_max))
            .max(256);
        let subgroups = device.features().contains(wgpu::Features::SUBGROUP);
        let timer = device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| Arc::new(PassTimer::new(&device, &queue)));
        Ok(GpuDevice {
            device,
            queue,
            info,
            max_binding,
            errors,
            traffic: TrafficCounters::default(),
            subgroups,
            timer,
        })
    }

    /// One line naming the adapter, e.g. for benchmark tables.
    pub fn describe(&self) -> String {
        format!(
            "{} ({:?}, {:?}, driver {}{})",
            self.info.name,
            self.info.device_type,
            self.info.backend,
            self.info.driver_info,
            if self.subgroups { "; subgroups" } else { "" }
        )
    }

    /// Whether the kernels may use subgroup operations.
    pub fn has_subgroups(&self) -> bool {
        self.subgroups
    }

    /// Whether this is a software rasteriser (lavapipe, SwiftShader).
    pub fn is_software(&self) -> bool {
        !is_hardware(&self.info)
    }

    /// Returns the errors wgpu reported since the last check as one error.
    pub fn check(&self) -> Result<(), GpuError> {
        let mut list = self
            .errors
            .lock()
            .map_err(|_| GpuError::Operation("error log poisoned".into()))?;
        if list.is_empty() {
            Ok(())
        } else {
            let all = list.join("; ");
            list.clear();
            Err(GpuError::Operation(all))
        }
    }

    /// The host's traffic with the device so far.
    pub fn traffic(&self) -> Traffic {
        let t = &self.traffic;
        Traffic {
            buffers: t.buffers.load(Ordering::Relaxed),
            submits: t.submits.load(Ordering::Relaxed),
            uploaded: t.uploaded.load(Ordering::Relaxed),
            read_back: t.read_back.load(Ordering::Relaxed),
        }
    }

    fn count(counter: &AtomicU64, amount: u64) {
        counter.fetch_add(amount, Ordering::Relaxed);
    }

    /// Creates a buffer, counted.
    pub fn create_buffer(&self, descriptor: &wgpu::BufferDescriptor<'_>) -> wgpu::Buffer {
        Self::count(&self.traffic.buffers, 1);
        self.device.create_buffer(descriptor)
    }

    /// Writes `data` into `buffer` at `offset` through the queue, counted.
    pub fn write<T: bytemuck::Pod>(&self, buffer: &wgpu::Buffer, offset: u64, data: &[T]) {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        Self::count(&self.traffic.uploaded, bytes.len() as u64);
        self.queue.write_buffer(buffer, offset, bytes);
    }

    /// Submits `encoder` without waiting, counted.
    pub fn enqueue(&self, encoder: wgpu::CommandEncoder) {
        Self::count(&self.traffic.submits, 1);
        self.queue.submit([encoder.finish()]);
    }

    /// A storage buffer of at least `bytes` bytes (wgpu refuses empty bindings).
    pub fn storage(&self, label: &str, bytes: u64) -> wgpu::Buffer {
        self.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(16).next_multiple_of(4),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// A storage buffer holding `data` (padded when empty).
    pub fn storage_with<T: bytemuck::Pod>(&self, label: &str, data: &[T]) -> wgpu::Buffer {
        if data.is_empty() {
            return self.storage(label, 16);
        }
        Self::count(&self.traffic.buffers, 1);
        Self::count(&self.traffic.uploaded, std::mem::size_of_val(data) as u64);
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::cast_slice(data),
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
            })
    }

    /// A uniform buffer holding `value`.
    pub fn uniform<T: bytemuck::Pod>(&self, label: &str, value: &T) -> wgpu::Buffer {
        Self::count(&self.traffic.buffers, 1);
        Self::count(&self.traffic.uploaded, std::mem::size_of::<T>() as u64);
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::bytes_of(value),
                usage: wgpu::BufferUsages::UNIFORM,
            })
    }

    /// Submits `encoder` and copies the first `count` values of `source` back to the host.
    pub fn read<T: bytemuck::Pod>(
        &self,
        mut encoder: wgpu::CommandEncoder,
        source: &wgpu::Buffer,
        count: usize,
    ) -> Result<Vec<T>, GpuError> {
        let bytes = (count * std::mem::size_of::<T>()) as u64;
        if bytes == 0 {
            self.enqueue(encoder);
            self.check()?;
            return Ok(Vec::new());
        }
        let padded = bytes.next_multiple_of(4);
        let staging = self.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read-back"),
            size: padded,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        encoder.copy_buffer_to_buffer(source, 0, &staging, 0, padded);
        self.enqueue(encoder);
        let values = self.map_read(&staging, bytes as usize)?;
        Ok(bytemuck::pod_collect_to_vec::<u8, T>(&values))
    }

    /// Waits for the queue, then copies the first `bytes` bytes of the mappable `staging`
    /// buffer back to the host (counted) and unmaps it, so it can be reused.
    pub fn map_read(&self, staging: &wgpu::Buffer, bytes: usize) -> Result<Vec<u8>, GpuError> {
        let (sender, receiver) = std::sync::mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |result| {
            // The receiver outlives the poll below; a failed send only means it gave up.
            let _ = sender.send(result);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Operation(format!("waiting for the GPU: {e}")))?;
        self.check()?;
        receiver
            .recv()
            .map_err(|_| GpuError::Operation("read-back never completed".into()))?
            .map_err(|e| GpuError::Operation(format!("mapping a read-back buffer: {e}")))?;
        let view = staging
            .get_mapped_range(..)
            .map_err(|e| GpuError::Operation(format!("reading a mapped buffer: {e}")))?;
        let values = view[..bytes].to_vec();
        drop(view);
        staging.unmap();
        Self::count(&self.traffic.read_back, bytes as u64);
        Ok(values)
    }

    /// Submits `encoder` and waits for it.
    pub fn submit(&self, encoder: wgpu::CommandEncoder) -> Result<(), GpuError> {
        self.enqueue(encoder);
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Operation(format!("waiting for the GPU: {e}")))?;
        self.check()
    }

    /// The pass timer the kernels write timestamps through (`None`: the adapter has none).
    pub(crate) fn timer(&self) -> Option<Arc<PassTimer>> {
        self.timer.clone()
    }

    /// Runs `work` with every compute pass it records timed on the GPU, and returns its
    /// result with the time per kernel entry (`None` where the adapter has no timestamps).
    /// Reading the timestamps back costs a submit and a buffer, so keep it out of timed runs.
    pub fn time_passes<T, E: From<GpuError>>(
        &self,
        work: impl FnOnce() -> Result<T, E>,
    ) -> Result<(T, Option<PassTimes>), E> {
        let Some(timer) = &self.timer else {
            return Ok((work()?, None));
        };
        timer.start();
        let result = work();
        let names = timer.stop();
        let value = result?;
        if names.is_empty() {
            return Ok((value, Some(Vec::new())));
        }
        let queries = 2 * names.len() as u32;
        let resolved = self.create_buffer(&wgpu::BufferDescriptor {
            label: Some("pass timestamps"),
            size: u64::from(queries) * 8,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut encoder = self.encoder();
        encoder.resolve_query_set(timer.queries(), 0..queries, &resolved, 0);
        let ticks: Vec<u64> = self.read(encoder, &resolved, queries as usize)?;
        Ok((value, Some(timer.per_entry(&names, &ticks))))
    }

    /// A fresh command encoder.
    pub fn encoder(&self) -> wgpu::CommandEncoder {
        self.device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None })
    }
}
