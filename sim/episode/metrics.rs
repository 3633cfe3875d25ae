//! What an episode measured (metrics.json): its stages' wall times, its path, its collisions
//! and recoveries, the planner and its settings, and the map's scores on the hidden test set.

use serde::Serialize;

/// Median and 95th percentile of a figure measured many times (a stage's wall seconds, the
/// error of a predicted start pose in metres).
#[derive(Debug, Clone, Copy, Serialize, Default)]
pub struct Percentiles {
    /// Median.
    pub median: f64,
    /// 95th percentile.
    pub p95: f64,
}

/// The median and 95th percentile of `v` (zeros when empty).
pub fn percentiles(mut v: Vec<f64>) -> Percentiles {
    if v.is_empty() {
        return Percentiles::default();
    }
    v.sort_by(f64::total_cmp);
    Percentiles {
        median: v[v.len() / 2],
        p95: v[((v.len() as f64 * 0.95).ceil() as usize).clamp(1, v.len()) - 1],
    }
}

/// What an episode measured (metrics.json).
#[derive(Debug, Clone, Serialize)]
pub struct Metrics {
    /// Simulated seconds.
    pub simulated_seconds: f64,
    /// Wall seconds of the whole run.
    pub wall_seconds: f64,
    /// Simulated seconds per wall second.
    pub real_time_factor: f64,
    /// Metres the robot's base drove (its origin on the floor, summed every physics step).
    pub path_length: f64,
    /// Metres the camera moved from frame to frame: the length of groundtruth.txt's positions,
    /// which is what trajectory tools (evo) report; longer than the base's when it turns, the
    /// camera sitting 0.2 m ahead of the axle.
    pub camera_path_length: f64,
    /// Physics steps with a robot-world contact (floor excluded).
    pub collision_steps: usize,
    /// Recovery events (turn in place after a planner failure, back off after no progress,
    /// a retrace when a look around did not unblock the plans).
    pub recovery_events: usize,
    /// Of those, retraces: drives back along the way the robot came.
    pub retraces: usize,
    /// Plans dropped under `--latency wall` because their think outlasted the lead they were
    /// made for while the robot moved on (always 0 with `--latency none`).
    pub late_plans: usize,
    /// How far, metres, the robot was from the pose its schedules were planned from when they
    /// started: the error of the compute delay's prediction (zeros with `--latency none`).
    pub start_pose_error: Percentiles,
    /// Planner failures by kind.
    pub plan_failures: std::collections::BTreeMap<String, usize>,
    /// Gaussians in the final map.
    pub gaussians: usize,
    /// Camera frames written.
    pub frames: usize,
    /// Mapping steps.
    pub mapping_steps: usize,
    /// Wall time of a mapping step.
    pub mapping: Percentiles,
    /// Wall time of a plan.
    pub planning: Percentiles,
    /// Wall time of a camera frame: render, read back, write the PNGs.
    pub camera: Percentiles,
    /// Wall time of a physics step (drive controller included).
    pub physics: Percentiles,
    /// The splat engine used.
    pub engine: String,
    /// The planner that drove the robot.
    pub planner: String,
    /// Its settings.
    pub planner_settings: serde_json::Value,
    /// Why the episode ended: "budget", "survey complete", or "stuck: ...".
    pub ended: String,
    /// Peak resident memory of the process (VmHWM), bytes; 0 where the OS does not say.
    pub peak_memory_bytes: u64,
    /// The map on hidden test views.
    pub evaluation: crate::evaluate::Evaluation,
    /// Coverage of the hidden test set over the episode: `[simulated seconds, coverage]` every
    /// 10 simulated seconds (the progress display's rate) and at the end (the evaluation's).
    pub coverage_over_time: Vec<[f64; 2]>,
    /// The map's PSNR (dB) at the instants of `coverage_over_time`, on a fixed subsample of
    /// the hidden views (`PSNR_OVER_TIME_VIEWS`, spread over the set; the final `evaluation`
    /// uses them all): planners compared at equal times, not only at their ends.
    pub psnr_over_time: Vec<[f64; 2]>,
    /// When the planner said it was done (simulated seconds; null when it never did): the
    /// episode ran on to its budget from there, the robot still and the mapper on its schedule.
    pub done_at: Option<f64>,
    /// Where the episode folder was written: `--out`, or beside it when the episode was
    /// interrupted and did not replace a complete one (not in metrics.json).
    #[serde(skip)]
    pub folder: std::path::PathBuf,
}
