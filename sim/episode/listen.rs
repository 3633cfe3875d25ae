//! What a tick reports, and who listens: the dataset writer, the rerun recording and any
//! listener a caller adds hear each stage's outcome instead of being written into the loop.

use super::Progress;
use crate::camera::RgbdFrame;
use crate::dataset::DatasetWriter;
use crate::error::Result;
use crate::rerun_log::RerunLog;
use crate::robot::Pose2;
use autonomy::explore::Decision;
use autonomy::map::GaussianMap;

/// One stage's outcome, as a tick reports it to its listeners.
#[derive(Debug)]
pub enum TickEvent<'a> {
    /// The camera took a frame (`path`: the robot's path so far, a pose every 0.1 s).
    Frame {
        /// The frame, its capture time and camera.
        frame: &'a RgbdFrame,
        /// The robot's path so far.
        path: &'a [Pose2],
        /// Wall seconds of the capture.
        seconds: f64,
    },
    /// The mapper integrated the newest frame.
    Mapped {
        /// Simulated seconds.
        time: f64,
        /// The map after the step.
        map: &'a GaussianMap,
        /// Wall seconds of the step.
        seconds: f64,
    },
    /// The planner was asked (`decision` is `None` when the progress watch overruled it).
    Planned {
        /// Simulated seconds.
        time: f64,
        /// What the planner answered.
        decision: Option<&'a Decision>,
        /// Wall seconds of the plan.
        seconds: f64,
    },
    /// The map's coverage of the hidden test set was measured.
    Coverage {
        /// Simulated seconds.
        time: f64,
        /// Fraction of the test set's surface points covered.
        coverage: f64,
    },
    /// A think period's mapping and planning are over.
    Thought(Progress),
    /// The episode is over and evaluated.
    Finished {
        /// Simulated seconds at the end.
        time: f64,
        /// Final coverage of the hidden test set.
        coverage: f64,
    },
}

/// Something that follows an episode as it runs (a progress bar, a recording, a logger).
pub trait TickListener {
    /// Hears one event; an error ends the episode (which is still written).
    fn hear(&mut self, event: &TickEvent<'_>) -> Result<()>;
}

impl<F: FnMut(&TickEvent<'_>)> TickListener for F {
    fn hear(&mut self, event: &TickEvent<'_>) -> Result<()> {
        self(event);
        Ok(())
    }
}

impl TickListener for DatasetWriter {
    fn hear(&mut self, event: &TickEvent<'_>) -> Result<()> {
        match event {
            TickEvent::Frame { frame, .. } => self.write_frame(frame),
            _ => Ok(()),
        }
    }
}

impl TickListener for RerunLog {
    fn hear(&mut self, event: &TickEvent<'_>) -> Result<()> {
        match *event {
            TickEvent::Frame {
                frame,
                path,
                seconds,
            } => {
                self.at(frame.time);
                self.frame(
                    &frame.camera,
                    &frame.rgb,
                    &frame.depth,
                    &frame.instance,
                    path,
                )?;
                self.scalar("timing/camera_ms", 1e3 * seconds)
            }
            TickEvent::Mapped { time, map, seconds } => {
                self.at(time);
                self.map(map)?;
                self.scalar("timing/mapping_ms", 1e3 * seconds)?;
                self.scalar("metrics/gaussians", map.len() as f64)
            }
            TickEvent::Planned {
                decision, seconds, ..
            } => {
                self.scalar("timing/planning_ms", 1e3 * seconds)?;
                match decision {
                    Some(Decision::Go(plan)) => self.plan(&plan.alternatives, &plan.states),
                    _ => Ok(()),
                }
            }
            TickEvent::Coverage { coverage, .. } => self.scalar("metrics/coverage", coverage),
            TickEvent::Thought(_) => Ok(()),
            TickEvent::Finished { time, coverage } => {
                self.at(time);
                self.scalar("metrics/coverage", coverage)
            }
        }
    }
}

/// The episode's own listeners (its dataset and recording, which `finish` closes) and the
/// ones callers added, told in that order.
pub(super) struct Listeners {
    /// The episode folder being written.
    pub writer: DatasetWriter,
    /// The rerun recording, when one was asked for.
    pub rerun: Option<RerunLog>,
    /// Added by [`super::Episode::listen`].
    pub others: Vec<Box<dyn TickListener>>,
}

impl Listeners {
    /// Tells every listener; the first error stops the telling.
    pub fn tell(&mut self, event: &TickEvent<'_>) -> Result<()> {
        self.writer.hear(event)?;
        if let Some(log) = &mut self.rerun {
            log.hear(event)?;
        }
        for listener in &mut self.others {
            listener.hear(event)?;
        }
        Ok(())
    }
}
