//! `splatloop bench sensor`: RGB-D frames per second and physics steps per second.

use crate::camera::SensorConfig;
use crate::egl::EglContext;
use crate::error::Result;
use crate::mujoco::RenderFlags;
use crate::robot::UnicycleCommand;
use crate::world::World;
use std::path::Path;
use std::time::Instant;

/// One measured row.
#[derive(Debug, Clone)]
pub struct SensorBenchRow {
    /// What was timed.
    pub what: String,
    /// Repetitions.
    pub count: usize,
    /// Wall seconds.
    pub seconds: f64,
}

impl SensorBenchRow {
    /// Repetitions per second.
    pub fn rate(&self) -> f64 {
        self.count as f64 / self.seconds
    }
}

/// Times frames at each resolution and bare physics steps; returns the renderer's name too.
pub fn bench_sensor(world_path: &Path, frames: usize) -> Result<(String, Vec<SensorBenchRow>)> {
    let gl = EglContext::new()?;
    let mut rows = Vec::new();
    let command = UnicycleCommand { v: 0.3, w: 0.25 };
    let cases = [
        ("sensor defaults", 320, 240, RenderFlags::default()),
        ("sensor defaults", 640, 480, RenderFlags::default()),
        (
            "MuJoCo defaults (baseline)",
            320,
            240,
            RenderFlags::mujoco_defaults(),
        ),
    ];
    for (label, width, height, flags) in cases {
        let sensor = SensorConfig {
            width,
            height,
            flags,
            ..SensorConfig::default()
        };
        let mut world = World::load(world_path, &sensor)?;
        let mut camera = world.make_camera(&sensor, 0, &gl)?;
        let mut frame = camera.capture(world.data())?;
        // Warm up caches and the driver, then time capture + depth conversion only.
        for _ in 0..5 {
            camera.capture_into(world.data(), &mut frame)?;
        }
        let mut render_seconds = 0.0;
        for _ in 0..frames {
            for _ in 0..10 {
                world.step(command)?;
            }
            let start = Instant::now();
            camera.capture_into(world.data(), &mut frame)?;
            render_seconds += start.elapsed().as_secs_f64();
        }
        rows.push(SensorBenchRow {
            what: format!("RGB-D frame {width}x{height}, {label}"),
            count: frames,
            seconds: render_seconds,
        });
    }
    let mut world = World::load(world_path, &SensorConfig::default())?;
    let steps = 20_000;
    let start = Instant::now();
    for _ in 0..steps {
        world.step(command)?;
    }
    rows.push(SensorBenchRow {
        what: "physics step (2 ms, robot driving)".into(),
        count: steps,
        seconds: start.elapsed().as_secs_f64(),
    });
    Ok((gl.description().to_owned(), rows))
}
