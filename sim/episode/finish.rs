//! The end of an episode: the map's files, the evaluation on the hidden test set,
//! trajectory.png, metrics.json, and the episode folder moved into place.

use super::listen::TickEvent;
use super::metrics::{percentiles, Metrics};
use super::tick::Episode;
use super::{peak_memory_bytes, EpisodeFile, StopRequest, POINT_CLOUD};
use crate::error::{Result, SimError};
use crate::evaluate::{evaluate, Evaluation};
use crate::record::Versions;

impl Episode {
    /// Evaluates the map and writes the episode folder (map.ply, points.ply, trajectory.png,
    /// metrics.json, episode.json), whether the episode ran to its end or not: one stopped
    /// early by its caller says so in `ended`.
    pub fn finish(mut self) -> Result<Metrics> {
        let ended = self
            .ended
            .take()
            .unwrap_or_else(|| format!("stopped by the caller at t = {:.1} s", self.time()));
        self.tally.path.push(self.world.pose());
        self.write_map()?;
        let simulated = self.time();
        let final_pose = self.world.pose();
        let stop = self.config.stop.clone();
        let evaluation = evaluate(
            &self.world,
            &mut self.camera,
            self.mapper.engine(),
            self.mapper.map(),
            &self.tests,
            &|| stop.requested().is_some(),
        )?;
        // A signal during the evaluation stops it (nothing is scored) and is said in `ended`.
        let ended = match stop.requested() {
            Some(signal) if !ended.starts_with("interrupted") => format!(
                "interrupted at t = {simulated:.1} s by {} during the evaluation (not scored; {ended})",
                StopRequest::signal_name(signal)
            ),
            _ => ended,
        };
        if evaluation.coverage.is_finite() {
            self.coverage_over_time
                .push([simulated, evaluation.coverage]);
            // The same few views as during the episode (the final scores use every view).
            if let Some(psnr) = self
                .truth_views
                .psnr(self.mapper.engine(), self.mapper.map())?
            {
                self.psnr_over_time.push([simulated, psnr]);
            }
        }
        self.write_trajectory_png(simulated, &evaluation)?;
        let mut metrics = self.metrics(simulated, ended, evaluation);
        let mut listeners = std::mem::take(&mut self.listeners.others);
        let finished = TickEvent::Finished {
            time: simulated,
            coverage: metrics.evaluation.coverage,
        };
        for listener in &mut listeners {
            listener.hear(&finished)?;
        }
        let rerun = self.listeners.rerun.take();
        let writer = self.listeners.writer;
        crate::dataset::write_json(&writer.dir().join("metrics.json"), &metrics)?;
        let interrupted = self.config.stop.requested().is_some();
        metrics.folder = writer.finish(
            &EpisodeFile {
                command: "run",
                config: &self.config,
                versions: Versions::current(&self.gl).with_engine(&self.engine_name),
                start_pose: self.start_pose,
                final_pose,
                planner_settings: self.planner_settings,
            },
            interrupted,
        )?;
        // The recording is flushed after the folder is in place: a viewer that went away must
        // not strand a complete episode in its staging folder.
        if let Some(mut log) = rerun {
            use super::listen::TickListener;
            log.hear(&finished)?;
            log.finish()?;
        }
        Ok(metrics)
    }

    /// points.ply (the means, for nerfstudio) and map.ply.
    fn write_map(&self) -> Result<()> {
        let dir = self.listeners.writer.dir();
        let map = self.mapper.map();
        crate::dataset::write_point_cloud(
            &dir.join(POINT_CLOUD),
            &map.gaussians.means,
            &map.gaussians.colours,
        )?;
        autonomy::ply::write_with_sh_degree(map, &dir.join("map.ply"), self.config.ply_sh_degree)
            .map_err(|e| SimError::Mapping(e.to_string()))
    }

    /// The top-down picture of the path and the map, titled with the scores.
    fn write_trajectory_png(&self, simulated: f64, evaluation: &Evaluation) -> Result<()> {
        let world = &self.config.world;
        let title = format!(
            "{} | {} | {:.0} of {:.0} s | coverage {} | PSNR {}",
            world.file_name().map_or_else(
                || world.display().to_string(),
                |n| n.to_string_lossy().into_owned()
            ),
            &self.planner_name,
            simulated,
            self.config.budget,
            score(100.0 * evaluation.coverage, "%"),
            score(evaluation.psnr, " dB")
        );
        crate::plot::write_trajectory_png(
            &self.listeners.writer.dir().join("trajectory.png"),
            &self.world,
            &self.tally.path,
            self.mapper.map(),
            &title,
        )
        .map(|_extent| ())
    }

    /// metrics.json's contents.
    fn metrics(&self, simulated: f64, ended: String, evaluation: Evaluation) -> Metrics {
        let wall_seconds = self.wall.elapsed().as_secs_f64();
        let times = &self.tally.times;
        Metrics {
            simulated_seconds: simulated,
            wall_seconds,
            real_time_factor: simulated / wall_seconds,
            path_length: self.tally.path_length,
            camera_path_length: self.tally.camera_path_length,
            collision_steps: self.tally.collision_steps,
            recovery_events: self.control.recovery_events,
            retraces: self.control.retraces,
            late_plans: self.control.late_plans,
            start_pose_error: percentiles(self.control.start_pose_errors.clone()),
            plan_failures: self.control.failures.clone(),
            gaussians: self.mapper.map().len(),
            frames: self.listeners.writer.frame_count(),
            mapping_steps: self.mapper.steps(),
            mapping: percentiles(times.mapping.clone()),
            planning: percentiles(times.planning.clone()),
            camera: percentiles(times.camera.clone()),
            physics: percentiles(times.physics.clone()),
            engine: self.engine_name.clone(),
            planner: self.planner_name.clone(),
            planner_settings: self.planner_settings.clone(),
            ended,
            peak_memory_bytes: peak_memory_bytes(),
            evaluation,
            coverage_over_time: self.coverage_over_time.clone(),
            done_at: self.done.as_ref().map(|(at, _)| *at),
            psnr_over_time: self.psnr_over_time.clone(),
            folder: self.listeners.writer.target().to_owned(),
        }
    }
}

/// A score with one decimal and its unit, or "n/a" when it was not measured.
fn score(value: f64, unit: &str) -> String {
    if value.is_finite() {
        format!("{value:.1}{unit}")
    } else {
        "n/a".into()
    }
}
