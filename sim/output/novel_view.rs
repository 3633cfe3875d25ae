//! `splatloop render` and `splatloop eval`: what a saved map is for after the episode. Render
//! writes the map's RGB and depth at the poses of a TUM groundtruth.txt as a dataset folder of
//! its own (the same PNG formats, camera.json, transforms.json); eval scores a map.ply on the
//! hidden test set an episode with the same seed and camera would use.

use crate::camera::{RgbdFrame, SensorConfig};
use crate::dataset::{read_trajectory, CameraFile, DatasetWriter};
use crate::egl::EglContext;
use crate::error::{Result, SimError};
use crate::evaluate::{covered_surface, evaluate, Evaluation, TestSet};
use crate::world::World;
use autonomy::camera::PinholeCamera;
use autonomy::splat::{EngineChoice, Rasteriser};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Where the map is not at least half opaque, the rendered depth reads 0 (no return), as the
/// sensor's does.
pub const MIN_SILHOUETTE: f32 = 0.5;

/// A render as the sensor's images: 8-bit RGB, and the depth of the surface seen (the
/// composited depth divided by the silhouette: it is weighted by opacity), 0 where the map is
/// less than [`MIN_SILHOUETTE`] opaque or beyond `max_range`.
pub fn sensor_images(images: &autonomy::splat::Images, max_range: f32) -> (Vec<u8>, Vec<f32>) {
    let rgb = images
        .colour
        .iter()
        .map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)
        .collect();
    let depth = images
        .depth
        .iter()
        .zip(&images.silhouette)
        .map(|(d, s)| {
            let z = if *s >= MIN_SILHOUETTE { d / s } else { 0.0 };
            if z > 0.0 && z <= max_range {
                z
            } else {
                0.0
            }
        })
        .collect();
    (rgb, depth)
}

/// What `splatloop render` needs.
#[derive(Debug, Clone, Serialize)]
pub struct RenderConfig {
    /// The map (3DGS PLY).
    pub map: PathBuf,
    /// TUM trajectory of world_from_camera poses (optical frame).
    pub poses: PathBuf,
    /// camera.json with the intrinsics.
    pub camera: PathBuf,
    /// Output dataset folder.
    pub out: PathBuf,
    /// Splat engine asked for.
    #[serde(skip)]
    pub engine: EngineChoice,
    /// Replace an earlier dataset in `out`.
    #[serde(skip)]
    pub overwrite: bool,
}

#[derive(Serialize)]
struct RenderRecord<'a> {
    command: &'static str,
    config: &'a RenderConfig,
    engine: String,
}

fn read_map(path: &Path) -> Result<autonomy::map::GaussianMap> {
    if !path.is_file() {
        return Err(SimError::MissingFile {
            what: "map (--map)",
            path: path.to_owned(),
        });
    }
    autonomy::ply::read(path).map_err(|e| SimError::BadDataset {
        path: path.to_owned(),
        detail: format!("{e}; give the map.ply an episode wrote (or any 3DGS PLY)"),
    })
}

/// Renders the map at every pose; returns the frames written. `on_frame(done, total)` reports
/// progress.
pub fn render_map(config: &RenderConfig, on_frame: &mut dyn FnMut(usize, usize)) -> Result<usize> {
    // The episode folder's own writer checks the rest; an output that holds an input never.
    if config.out.exists() {
        crate::dataset::refuse_overwrite(
            &config.out,
            true,
            &[&config.map, &config.poses, &config.camera],
        )?;
    }
    if !config.poses.is_file() {
        return Err(SimError::MissingFile {
            what: "poses (--poses)",
            path: config.poses.clone(),
        });
    }
    let map = read_map(&config.map)?;
    let camera_file = CameraFile::read(&config.camera)?;
    let intrinsics = camera_file.intrinsics();
    let poses = read_trajectory(&config.poses)?;
    if poses.is_empty() {
        return Err(SimError::BadDataset {
            path: config.poses.clone(),
            detail: "no poses; expected lines of `timestamp tx ty tz qx qy qz qw`".into(),
        });
    }
    let engine = Rasteriser::select(config.engine);
    let mut writer = DatasetWriter::create(&config.out, camera_file.max_range, config.overwrite)?;
    for (k, (time, pose)) in poses.iter().enumerate() {
        let camera = PinholeCamera {
            intrinsics,
            world_from_camera: *pose,
        };
        let rendered = engine
            .render(&map.gaussians, &camera)
            .map_err(|e| SimError::Mapping(e.to_string()))?;
        let (rgb, depth) = sensor_images(rendered.images(), camera_file.max_range as f32);
        writer.write_frame(&RgbdFrame {
            time: *time,
            rgb,
            depth,
            camera,
            instance: Vec::new(),
        })?;
        on_frame(k + 1, poses.len());
    }
    let frames = writer.frame_count();
    writer.finish(
        &RenderRecord {
            command: "render",
            config,
            engine: engine.describe(),
        },
        false,
    )?;
    Ok(frames)
}

/// A test-set surface point and whether the map covers it (`splatloop eval --surface-out`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// World position, metres.
    pub position: [f32; 3],
    /// A Gaussian mean lies within the coverage radius.
    pub covered: bool,
}

/// Scores the map at `map_path` in `world` on `views` hidden test views sampled with `seed`
/// (with an episode's seed, camera size and view count, the test set is that episode's), and
/// lists, point by point, the surface its coverage is measured on: two maps evaluated with the
/// same world, seed and camera list the same points in the same order.
pub fn evaluate_map_surface(
    map_path: &Path,
    world_path: &Path,
    sensor: &SensorConfig,
    views: usize,
    seed: u64,
    engine: EngineChoice,
) -> Result<(Evaluation, Vec<SurfacePoint>)> {
    let map = read_map(map_path)?;
    let world = World::load(world_path, sensor)?;
    let gl = EglContext::new()?;
    let mut camera = world.make_camera(sensor, seed, &gl)?;
    let tests = TestSet::sample(
        &world,
        &camera,
        views,
        crate::episode::test_seed(seed),
        sensor.max_range,
    )?;
    let evaluation = evaluate(
        &world,
        &mut camera,
        &Rasteriser::select(engine),
        &map,
        &tests,
        &|| false,
    )?;
    let surface = tests
        .surface
        .iter()
        .zip(covered_surface(&tests, &map))
        .map(|(p, covered)| SurfacePoint {
            position: *p,
            covered,
        })
        .collect();
    Ok((evaluation, surface))
}
