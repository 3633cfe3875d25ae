//! GPU timestamps around each compute pass of one stretch of work, so `bench render` can show
//! where a resident iteration's time goes on an adapter that has them (hardware GPUs do, and
//! lavapipe). Nothing is written outside a recording, so timed runs pay nothing for it.

use std::sync::Mutex;

/// Passes one recording can time (two queries each; wgpu allows 4096 queries a set).
const PASSES: u32 = 1024;

/// GPU time per kernel entry over one recording: the entry, its passes, milliseconds; in the
/// order of each entry's first pass.
pub type PassTimes = Vec<(String, usize, f64)>;

/// The query set and the names of the passes recorded into it.
pub struct PassTimer {
    queries: wgpu::QuerySet,
    /// Nanoseconds per timestamp tick.
    period_ns: f64,
    /// Entry names of the passes recorded so far; `None` outside a recording.
    recording: Mutex<Option<Vec<String>>>,
}

impl PassTimer {
    /// A timer on a device opened with `Features::TIMESTAMP_QUERY`.
    pub(crate) fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        let queries = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("pass timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: 2 * PASSES,
        });
        PassTimer {
            queries,
            period_ns: f64::from(queue.get_timestamp_period()),
            recording: Mutex::new(None),
        }
    }

    /// The timestamp writes for the next pass, named `entry`: `None` outside a recording or
    /// once it is full (that pass then goes untimed).
    pub(crate) fn writes(&self, entry: &str) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        let mut guard = self.recording.lock().ok()?;
        let passes = guard.as_mut()?;
        let index = u32::try_from(passes.len()).ok().filter(|&i| i < PASSES)?;
        passes.push(entry.to_owned());
        Some(wgpu::ComputePassTimestampWrites {
            query_set: &self.queries,
            beginning_of_pass_write_index: Some(2 * index),
            end_of_pass_write_index: Some(2 * index + 1),
        })
    }

    /// Starts a recording (dropping any unfinished one).
    pub(crate) fn start(&self) {
        if let Ok(mut guard) = self.recording.lock() {
            *guard = Some(Vec::new());
        }
    }

    /// Ends the recording: the passes' names in order.
    pub(crate) fn stop(&self) -> Vec<String> {
        self.recording
            .lock()
            .ok()
            .and_then(|mut guard| guard.take())
            .unwrap_or_default()
    }

    /// The query set the recorded passes wrote.
    pub(crate) fn queries(&self) -> &wgpu::QuerySet {
        &self.queries
    }

    /// Sums the passes' durations per entry, from their (begin, end) ticks.
    pub(crate) fn per_entry(&self, names: &[String], ticks: &[u64]) -> PassTimes {
        let mut times: PassTimes = Vec::new();
        for (name, pair) in names.iter().zip(ticks.chunks_exact(2)) {
            let ms = pair[1].saturating_sub(pair[0]) as f64 * self.period_ns * 1e-6;
            match times.iter_mut().find(|(entry, _, _)| entry == name) {
                Some((_, passes, total)) => {
                    *passes += 1;
                    *total += ms;
                }
                None => times.push((name.clone(), 1, ms)),
            }
        }
        times
    }
}
