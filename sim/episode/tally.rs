//! What an episode counts as it runs: the path, distances, contacts and each stage's wall
//! times, for metrics.json and trajectory.png.

use crate::robot::Pose2;
use nalgebra::Vector3;

/// Physics steps between the poses of the drawn path (0.1 s at MuJoCo's 2 ms).
const PATH_EVERY: u64 = 50;

/// Wall seconds of each stage of a tick, one entry per time it ran.
#[derive(Debug, Clone, Default)]
pub struct StageTimes {
    /// Camera capture, with the listeners and the planner's look at the frame.
    pub camera: Vec<f64>,
    /// Mapping steps.
    pub mapping: Vec<f64>,
    /// Plans.
    pub planning: Vec<f64>,
    /// Physics steps.
    pub physics: Vec<f64>,
}

/// The running totals of an episode.
#[derive(Debug, Clone)]
pub struct Tally {
    /// The path for trajectory.png: the start, then a pose every [`PATH_EVERY`] steps.
    pub path: Vec<Pose2>,
    /// Metres the robot's base drove.
    pub path_length: f64,
    /// Metres the camera travelled between frames.
    pub camera_path_length: f64,
    /// Physics steps with the robot touching something.
    pub collision_steps: usize,
    /// Wall times per stage.
    pub times: StageTimes,
    last_pose: Pose2,
    last_camera: Option<Vector3<f64>>,
    /// Simulated time of the last contact (warnings are per contact episode).
    last_touch: f64,
}

impl Tally {
    /// Nothing yet, the robot at `start`.
    pub fn new(start: Pose2) -> Self {
        Tally {
            path: vec![start],
            path_length: 0.0,
            camera_path_length: 0.0,
            collision_steps: 0,
            times: StageTimes::default(),
            last_pose: start,
            last_camera: None,
            last_touch: f64::NEG_INFINITY,
        }
    }

    /// A frame was taken from `at`.
    pub fn camera_at(&mut self, at: Vector3<f64>) {
        if let Some(previous) = self.last_camera {
            self.camera_path_length += (at - previous).norm();
        }
        self.last_camera = Some(at);
    }

    /// Physics step `step` (counted from 0) ended with the robot at `pose`.
    pub fn moved(&mut self, step: u64, pose: Pose2) {
        self.path_length += (pose.x - self.last_pose.x).hypot(pose.y - self.last_pose.y);
        self.last_pose = pose;
        if (step + 1).is_multiple_of(PATH_EVERY) {
            self.path.push(pose);
        }
    }

    /// A step at `time` ended in contact; whether this begins a new contact episode (one
    /// warning each: contacts flicker from step to step).
    pub fn touched(&mut self, time: f64) -> bool {
        let new = time - self.last_touch > 0.5;
        self.last_touch = time;
        self.collision_steps += 1;
        new
    }
}
