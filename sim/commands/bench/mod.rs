//! `splatloop bench`: what each benchmark measures (here: sensor, render, loss, map, plan,
//! planners), `worlds` (generation and import), `cli` (the flags and the printed tables).

pub mod cli;
pub mod worlds;

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
        ("sensor defaults", 320, 240, RenderFlags::default(), false),
        (
            "sensor defaults + masks",
            320,
            240,
            RenderFlags::default(),
            true,
        ),
        ("sensor defaults", 640, 480, RenderFlags::default(), false),
        (
            "sensor defaults + masks",
            640,
            480,
            RenderFlags::default(),
            true,
        ),
        (
            "MuJoCo defaults (baseline)",
            320,
            240,
            RenderFlags::mujoco_defaults(),
            false,
        ),
    ];
    for (label, width, height, flags, masks) in cases {
        let sensor = SensorConfig {
            width,
            height,
            flags,
            masks,
            ..SensorConfig::default()
        };
        let mut world = World::load(world_path, &sensor)?;
        let mut camera = world.make_camera(&sensor, 0, &gl)?;
        let mut frame = camera.blank_frame();
        // Warm up caches and the driver, then time capture + depth conversion (+ the mask)
        // only.
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

/// One row of `bench render`.
#[derive(Debug, Clone)]
pub struct RenderBenchRow {
    /// The engine, in words.
    pub engine: String,
    /// Image width and height.
    pub resolution: (u32, u32),
    /// Gaussians in the scene.
    pub gaussians: usize,
    /// (pixel, Gaussian) pairs the tile lists hold: the work of one forward pass.
    pub pairs: u64,
    /// How the iteration ran: "host-driven" (each stage called from the host) or "resident"
    /// (the GPU engine's whole iteration in one submit; its stages are not timed apart).
    pub mode: &'static str,
    /// Median seconds of each stage: forward, loss, backward, Adam (host-driven only).
    pub stages: Option<[f64; 4]>,
    /// Median seconds of a whole iteration.
    pub iteration: f64,
    /// The GPU traffic of one iteration after warm-up (GPU engine only).
    pub traffic: Option<autonomy::splat::gpu::Traffic>,
    /// GPU time per kernel of one more resident iteration, from timestamps (resident rows on
    /// an adapter that has them): where the iteration's time goes.
    pub passes: Option<autonomy::splat::gpu::PassTimes>,
}

/// Times mapping iterations (forward + loss + backward + Adam) of `engine` on Gaussians spread
/// over a room's surfaces, fitting a perturbed copy to the original's render.
pub fn bench_render(
    engine: &autonomy::splat::Rasteriser,
    resolutions: &[(u32, u32)],
    counts: &[usize],
    iterations: usize,
) -> std::result::Result<Vec<RenderBenchRow>, autonomy::splat::RenderError> {
    use autonomy::adam::{Adam, LearningRates};
    use autonomy::loss::{mapping_loss, Target};
    use autonomy::splat::{cpu, TILE};
    use autonomy::synthetic::{room_camera, room_surface};
    let mut rows = Vec::new();
    for &count in counts {
        let truth = room_surface(count, 1);
        let mut fitted = room_surface(count, 1);
        for (i, m) in fitted.means.iter_mut().enumerate() {
            // A few millimetres off, so every Gaussian has a gradient.
            m[i % 3] += 0.004 * (((i * 7919) % 13) as f32 / 6.0 - 1.0);
        }
        for &(width, height) in resolutions {
            let camera = room_camera(width, height);
            let target = cpu::render(&truth, &camera)?.images;
            let mut gaussians = fitted.clone();
            let mut adam = Adam::new(LearningRates::default());
            let mut samples: Vec<[f64; 4]> = Vec::new();
            let mut pairs = 0;
            let mut traffic_start = None;
            for i in 0..iterations + 1 {
                if i == 1 {
                    traffic_start = engine.gpu().map(|g| g.traffic());
                }
                let t0 = Instant::now();
                let render = engine.render(&gaussians, &camera)?;
                let t1 = Instant::now();
                let (_, image_grads) = mapping_loss(
                    render.images(),
                    Target {
                        colour: &target.colour,
                        depth: &target.depth,
                    },
                );
                let t2 = Instant::now();
                let grads = engine.backward(&render, &image_grads)?;
                let t3 = Instant::now();
                adam.step(&mut gaussians, &grads);
                let t4 = Instant::now();
                pairs = render.tile_pairs() * (TILE * TILE) as u64;
                samples.push([t1 - t0, t2 - t1, t3 - t2, t4 - t3].map(|d| d.as_secs_f64()));
            }
            let traffic = engine.gpu().map(|g| g.traffic());
            samples.remove(0); // warm-up
            let median = |stage: usize| {
                let mut v: Vec<f64> = samples.iter().map(|s| s[stage]).collect();
                v.sort_by(f64::total_cmp);
                v[v.len() / 2]
            };
            let mut totals: Vec<f64> = samples.iter().map(|s| s.iter().sum()).collect();
            totals.sort_by(f64::total_cmp);
            rows.push(RenderBenchRow {
                engine: engine.describe(),
                resolution: (width, height),
                gaussians: count,
                pairs,
                mode: "host-driven",
                stages: Some([median(0), median(1), median(2), median(3)]),
                iteration: totals[totals.len() / 2],
                traffic: traffic_start
                    .zip(traffic)
                    .map(|(start, end)| (end - start).per(iterations as u64)),
                passes: None,
            });
            if let Some(gpu) = engine.gpu() {
                rows.push(resident_row(
                    gpu, &fitted, &camera, &target, iterations, pairs,
                )?);
            }
        }
    }
    Ok(rows)
}

/// The GPU engine's resident iteration on the same problem as the host-driven rows.
fn resident_row(
    gpu: &autonomy::splat::gpu::GpuRasteriser,
    fitted: &autonomy::gaussians::Gaussians,
    camera: &autonomy::camera::PinholeCamera,
    target: &autonomy::splat::Images,
    iterations: usize,
    pairs: u64,
) -> std::result::Result<RenderBenchRow, autonomy::splat::RenderError> {
    use autonomy::adam::{Adam, LearningRates};
    let mut resident = autonomy::splat::gpu::ResidentMap::new(gpu, LearningRates::default());
    let mut adam = Adam::new(LearningRates::default());
    adam.resize(fitted.len());
    resident.load(gpu, fitted, adam.state())?;
    let view = resident.add_view(gpu, camera, &target.colour, &target.depth)?;
    let mut times = Vec::new();
    let mut start = None;
    for i in 0..iterations + 1 {
        if i == 1 {
            start = Some(gpu.traffic());
        }
        let t0 = Instant::now();
        resident.iterate(gpu, view)?;
        times.push(t0.elapsed().as_secs_f64());
    }
    let end = gpu.traffic();
    // After the timed ones and their traffic: reading the timestamps back costs a submit.
    let (_, passes) = gpu.time_passes(|| resident.iterate(gpu, view))?;
    times.remove(0); // warm-up
    times.sort_by(f64::total_cmp);
    let traffic = start.map(|s| (end - s).per(iterations as u64));
    Ok(RenderBenchRow {
        engine: gpu.describe(),
        resolution: (camera.intrinsics.width, camera.intrinsics.height),
        gaussians: fitted.len(),
        pairs,
        mode: "resident",
        stages: None,
        iteration: times[times.len() / 2],
        traffic,
        passes,
    })
}

/// One row of `bench loss`: median seconds of the loss with its gradient.
#[derive(Debug, Clone)]
pub struct LossBenchRow {
    /// Image width and height.
    pub resolution: (u32, u32),
    /// The reference (`loss_generic` in f32: serial blurs, a task per channel).
    pub reference: f64,
    /// `loss_simd` with fresh scratch memory each call (a band of rows per core, 8 pixels per
    /// SIMD step), as `mapping_loss` runs it.
    pub simd: f64,
    /// `loss_simd_in` with a workspace kept across calls, as the mapper runs it.
    pub kept: f64,
}

/// Times the mapping loss with its gradient on a render of the synthetic room against a
/// render of a perturbed copy, by the reference, the SIMD version with fresh scratch and with
/// a kept workspace, in turn (each call after another's, as in a mapping iteration where the
/// render and backward pass run between losses).
pub fn bench_loss(resolutions: &[(u32, u32)], iterations: usize) -> Vec<LossBenchRow> {
    use autonomy::loss::{loss_generic, loss_simd, loss_simd_in, LossWorkspace, RgbdSlices};
    use autonomy::splat::cpu;
    use autonomy::synthetic::{room_camera, room_surface};
    let truth = room_surface(100_000, 1);
    let mut moved = truth.clone();
    for (i, m) in moved.means.iter_mut().enumerate() {
        m[i % 3] += 0.004 * (((i * 7919) % 13) as f32 / 6.0 - 1.0);
    }
    let mut rows = Vec::new();
    for &(width, height) in resolutions {
        let camera = room_camera(width, height);
        let (Ok(a), Ok(b)) = (cpu::render(&truth, &camera), cpu::render(&moved, &camera)) else {
            continue;
        };
        let (a, b) = (a.images, b.images);
        let n = a.width * a.height;
        let (mut colour_grad, mut depth_grad) = (vec![0.0f32; 3 * n], vec![0.0f32; n]);
        let rendered = RgbdSlices {
            colour: &b.colour,
            depth: &b.depth,
        };
        let target = RgbdSlices {
            colour: &a.colour,
            depth: &a.depth,
        };
        let mut samples = [Vec::new(), Vec::new(), Vec::new()];
        let mut workspace = LossWorkspace::default();
        for _ in 0..iterations.max(1) + 1 {
            let t0 = Instant::now();
            loss_generic(
                rendered,
                target,
                (a.width, a.height),
                &mut colour_grad,
                &mut depth_grad,
            );

            let t1 = Instant::now();
            loss_simd(
                rendered,
                target,
                (a.width, a.height),
                &mut colour_grad,
                &mut depth_grad,
            );
            let t2 = Instant::now();
            loss_simd_in(
                rendered,
                target,
                (a.width, a.height),
                &mut colour_grad,
                &mut depth_grad,
                &mut workspace,
            );
            samples[0].push((t1 - t0).as_secs_f64());
            samples[1].push((t2 - t1).as_secs_f64());
            samples[2].push(t2.elapsed().as_secs_f64());
        }
        let median = |mut v: Vec<f64>| {
            v.remove(0); // warm-up
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let [reference, simd, kept] = samples;
        rows.push(LossBenchRow {
            resolution: (width, height),
            reference: median(reference),
            simd: median(simd),
            kept: median(kept),
        });
    }
    rows
}

/// One row of `bench map`: a mapping step as the map grows.
#[derive(Debug, Clone)]
pub struct MapBenchRow {
    /// Step number (1-based).
    pub step: usize,
    /// What the mapper reported.
    pub report: autonomy::mapping::StepReport,
    /// Wall seconds of the whole step.
    pub seconds: f64,
    /// The GPU traffic of the step (GPU engine only).
    pub traffic: Option<autonomy::splat::gpu::Traffic>,
}

/// Map quality at held-out views after the run.
#[derive(Debug, Clone)]
pub struct MapQuality {
    /// Mean PSNR, dB.
    pub psnr: f64,
    /// Mean depth MAE, metres.
    pub depth_mae: f64,
    /// Held-out views.
    pub views: usize,
}

/// The camera poses of `bench map`: the robot's camera (0.4 m up) spinning in place in each
/// room of the apartment and driving between them through the doors.
pub fn apartment_tour(
    intrinsics: autonomy::camera::Intrinsics,
) -> Vec<autonomy::camera::PinholeCamera> {
    use autonomy::synthetic::look_at;
    let height = 0.4;
    let mut cameras = Vec::new();
    let spin = |cameras: &mut Vec<_>, x: f64, y: f64, frames: usize, offset: f64| {
        for i in 0..frames {
            let a = offset + std::f64::consts::TAU * i as f64 / frames as f64;
            cameras.push(look_at(
                [x, y, height],
                [x + a.cos(), y + a.sin(), height],
                intrinsics,
            ));
        }
    };
    let drive = |cameras: &mut Vec<_>, from: [f64; 2], to: [f64; 2], frames: usize| {
        let heading = (to[1] - from[1]).atan2(to[0] - from[0]);
        for i in 1..=frames {
            let s = i as f64 / frames as f64;
            let (x, y) = (
                from[0] + s * (to[0] - from[0]),
                from[1] + s * (to[1] - from[1]),
            );
            cameras.push(look_at(
                [x, y, height],
                [x + heading.cos(), y + heading.sin(), height],
                intrinsics,
            ));
        }
    };
    spin(&mut cameras, 2.0, 2.5, 10, 0.0);
    drive(&mut cameras, [2.0, 2.5], [3.0, 3.5], 2);
    drive(&mut cameras, [3.0, 3.5], [5.5, 3.5], 4);
    drive(&mut cameras, [5.5, 3.5], [7.0, 2.0], 3);
    spin(&mut cameras, 7.0, 2.0, 10, 0.3);
    drive(&mut cameras, [7.0, 2.0], [7.0, 5.5], 5);
    spin(&mut cameras, 7.0, 5.5, 10, 0.6);
    drive(&mut cameras, [7.0, 5.5], [8.5, 5.5], 2);
    cameras
}

/// Runs the mapper over [`apartment_tour`] in `BoxScene::apartment()` and times every step;
/// then scores the map at held-out views (the spins' poses turned by half a step).
pub fn bench_map(
    engine: autonomy::splat::Rasteriser,
    width: u32,
    height: u32,
    iterations: usize,
    frames: usize,
) -> std::result::Result<(Vec<MapBenchRow>, MapQuality), autonomy::mapping::MapError> {
    use autonomy::camera::Intrinsics;
    use autonomy::mapping::{Frame, Mapper, MapperConfig};
    use autonomy::metrics::{depth_mae, psnr};
    use autonomy::synthetic::{look_at, BoxScene};
    let scene = BoxScene::apartment();
    let k = Intrinsics::from_fovy(60f64.to_radians(), width, height);
    let config = MapperConfig {
        iterations,
        ..MapperConfig::default()
    };
    let mut mapper = Mapper::new(config, engine);
    let mut rows = Vec::new();
    for (i, camera) in apartment_tour(k).iter().take(frames).enumerate() {
        let truth = scene.render(camera);
        let frame = Frame {
            colour: truth.colour,
            depth: truth.depth,
        };
        let traffic_start = mapper.engine().gpu().map(|g| g.traffic());
        let start = Instant::now();
        let report = mapper.integrate(&frame, &camera.world_from_camera.to_homogeneous(), &k)?;
        let seconds = start.elapsed().as_secs_f64();
        let traffic = traffic_start
            .zip(mapper.engine().gpu().map(|g| g.traffic()))
            .map(|(a, b)| b - a);
        rows.push(MapBenchRow {
            step: i + 1,
            report,
            seconds,
            traffic,
        });
    }
    let mut scores = Vec::new();
    for (x, y, offset) in [(2.0, 2.5, 0.0), (7.0, 2.0, 0.3), (7.0, 5.5, 0.6)] {
        for j in 0..4 {
            let a = offset + std::f64::consts::TAU * (2.5 * j as f64 + 0.5) / 10.0;
            let camera = look_at([x, y, 0.4], [x + a.cos(), y + a.sin(), 0.4], k);
            let truth = scene.render(&camera);
            let rendered = mapper.engine().render(&mapper.map().gaussians, &camera)?;
            scores.push((
                psnr(&rendered.images().colour, &truth.colour),
                depth_mae(&rendered.images().depth, &truth.depth),
            ));
        }
    }
    let n = scores.len() as f64;
    let quality = MapQuality {
        psnr: scores.iter().map(|s| s.0).sum::<f64>() / n,
        depth_mae: scores.iter().map(|s| s.1).sum::<f64>() / n,
        views: scores.len(),
    };
    Ok((rows, quality))
}

/// One row of `bench plan`.
#[derive(Debug, Clone)]
pub struct PlanBenchRow {
    /// Gaussians of clutter.
    pub gaussians: usize,
    /// Collision engine.
    pub engine: String,
    /// Seconds of the first plan (the grid's first filing included).
    pub first: f64,
    /// Median seconds of a plan after a small map change (the grid's upkeep included).
    pub plan: f64,
    /// Stages of the last plan: sync + regions + graph, search, information.
    pub stages: [f64; 3],
    /// Trajectory segments of the last plan.
    pub segments: usize,
}

/// `n` Gaussians of clutter on the surfaces of boxes scattered over a 40 x 40 x 3 m lot,
/// leaving a clear 6 m square around the centre where the robot starts; uncertainty random.
pub fn clutter_lot(n: usize, seed: u64) -> autonomy::map::GaussianMap {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut g = autonomy::gaussians::Gaussians::default();
    let boxes: Vec<([f32; 3], [f32; 3])> = (0..400)
        .filter_map(|_| {
            let c = [rng.gen_range(-19.0..19.0f32), rng.gen_range(-19.0..19.0f32)];
            if c[0].abs() < 3.0 && c[1].abs() < 3.0 {
                return None;
            }
            let h = [
                rng.gen_range(0.2..1.0f32),
                rng.gen_range(0.2..1.0f32),
                rng.gen_range(0.3..3.0f32),
            ];
            Some(([c[0], c[1], 0.0], h))
        })
        .collect();
    let mut uncertainty = Vec::with_capacity(n);
    for i in 0..n {
        let (c, h) = boxes[i % boxes.len()];
        // A point on one of the box's four sides or its top.
        let (a, b) = (rng.gen_range(-1.0..1.0f32), rng.gen_range(0.0..1.0f32));
        let p = match rng.gen_range(0..5) {
            0 => [c[0] + h[0], c[1] + a * h[1], b * h[2]],
            1 => [c[0] - h[0], c[1] + a * h[1], b * h[2]],
            2 => [c[0] + a * h[0], c[1] + h[1], b * h[2]],
            3 => [c[0] + a * h[0], c[1] - h[1], b * h[2]],
            _ => [c[0] + a * h[0], c[1] + (2.0 * b - 1.0) * h[1], h[2]],
        };
        g.push(p, rng.gen_range(0.01..0.04), 0.8, [0.5; 3]);
        uncertainty.push(rng.gen_range(0.0..1e-3f32));
    }
    autonomy::map::GaussianMap::new(g, uncertainty)
}

/// Times full plans over [`clutter_lot`] maps with each collision engine.
pub fn bench_plan(counts: &[usize], brute_force_limit: usize, gpu: bool) -> Vec<PlanBenchRow> {
    use autonomy::planner::unicycle::Pose2;
    use autonomy::planner::{CollisionEngine, PlannerConfig, RtGuidePlanner};
    let mut rows = Vec::new();
    for &n in counts {
        let mut map = clutter_lot(n, 7);
        let mut engines: Vec<(String, CollisionEngine)> =
            vec![("grid".into(), CollisionEngine::Grid)];
        if n <= brute_force_limit {
            engines.push(("brute force".into(), CollisionEngine::BruteForce));
        }
        if gpu {
            match autonomy::planner::gpu_collision::GpuCollision::new(
                autonomy::splat::gpu::AdapterPolicy::HardwareOnly,
            ) {
                Ok(g) => engines.push((
                    format!("wgpu: {}", g.describe()),
                    CollisionEngine::Gpu(Box::new(g)),
                )),
                Err(e) => tracing::info!("no wgpu row: {e}"),
            }
        }
        for (name, engine) in engines {
            let mut planner = RtGuidePlanner::new(PlannerConfig::default(), engine);
            let robot = Pose2 {
                x: 0.0,
                y: 0.0,
                theta: 0.3,
            };
            let start = Instant::now();
            let first = planner.plan(&map, robot);
            let first_seconds = start.elapsed().as_secs_f64();
            let mut times = Vec::new();
            let mut last = first;
            for k in 0..3 {
                // A mapping step's worth of change: 1% of the Gaussians move a little, and
                // their uncertainty becomes the distance moved (which shifts the high / low
                // thresholds of every Gaussian, as a real step does).
                for i in (k..map.len()).step_by(100) {
                    map.gaussians.means[i][0] += 0.002;
                    map.uncertainty[i] = 0.002;
                }
                let start = Instant::now();
                last = planner.plan(&map, robot);
                times.push(start.elapsed().as_secs_f64());
            }
            times.sort_by(f64::total_cmp);
            let (stages, segments) = match &last {
                Ok(p) => (p.seconds, p.controls.len()),
                Err(e) => {
                    tracing::warn!("plan failed: {e}");
                    ([0.0; 3], 0)
                }
            };
            rows.push(PlanBenchRow {
                gaussians: n,
                engine: name,
                first: first_seconds,
                plan: times[times.len() / 2],
                stages,
                segments,
            });
        }
    }
    rows
}

/// Seconds to build the information grid over `n` Gaussians and to score `viewpoints`
/// viewpoints with it, and with brute force for the first 20 (seconds per viewpoint).
pub fn bench_viewpoints(n: usize, viewpoints: usize) -> (f64, f64, f64) {
    use autonomy::map::ClassifyOptions;
    use autonomy::planner::information::{CameraMount, ViewCounter};
    use autonomy::planner::mirror::MapMirror;
    use autonomy::planner::unicycle::Pose2;
    let map = clutter_lot(n, 8);
    let start = Instant::now();
    let options = ClassifyOptions::default();
    let mut changes = Vec::new();
    MapMirror::new().sync(&map, &options, &mut changes);
    let cell = autonomy::planner::PlannerConfig::default().information_cell;
    let mut counter = ViewCounter::new(CameraMount::default(), cell);
    counter.apply(&changes);
    counter.set_stats(&map.stats(&options));
    let build = start.elapsed().as_secs_f64();
    let states: Vec<Pose2> = (0..viewpoints)
        .map(|i| {
            let a = i as f64 * 0.618;
            Pose2 {
                x: 15.0 * (a * 1.3).sin(),
                y: 15.0 * (a * 0.7).cos(),
                theta: a,
            }
        })
        .collect();
    let start = Instant::now();
    let total: f64 = states.iter().map(|s| counter.information(s)).sum();
    let score = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let brute: u32 = states
        .iter()
        .take(20)
        .map(|s| counter.count_brute_force(s).0)
        .sum();
    let brute_each = start.elapsed().as_secs_f64() / 20.0;
    tracing::debug!(total, brute, "viewpoint scores");
    (build, score, brute_each)
}

/// One row of `bench planners`.
#[derive(Debug, Clone)]
pub struct PlannersBenchRow {
    /// Map size.
    pub gaussians: usize,
    /// The planner.
    pub planner: String,
    /// Median seconds of a plan (of 3, each after a small map change).
    pub plan: f64,
    /// Candidates the last plan compared.
    pub candidates: usize,
    /// What the last plan decided ("go", or the failure or end).
    pub outcome: String,
}

/// Times a plan of each planner (rtguide, fbe, agslam with `agslam_candidates` goals) over
/// [`clutter_lot`] maps: each planner first sees eight depth frames rendered from the map (and
/// a flat floor) around the start (a look around), then plans three times after small map
/// changes.
pub fn bench_planners(counts: &[usize], agslam_candidates: usize) -> Vec<PlannersBenchRow> {
    use autonomy::drive::Pose2;
    use autonomy::explore::agslam::{AgslamConfig, AgslamPlanner};
    use autonomy::explore::executor::{CollisionEngine, ExecutorConfig};
    use autonomy::explore::fbe::{FbeConfig, FbePlanner};
    use autonomy::explore::{Decision, Observation, Planner};
    use autonomy::planner::information::CameraMount;
    use autonomy::planner::{PlannerConfig, RtGuidePlanner};
    let mount = CameraMount::default();
    let mut rows = Vec::new();
    for &n in counts {
        let mut map = clutter_lot(n, 7);
        let planners: Vec<Box<dyn Planner>> = vec![
            Box::new(RtGuidePlanner::new(
                PlannerConfig::default(),
                CollisionEngine::Grid,
            )),
            Box::new(FbePlanner::new(
                FbeConfig::default(),
                ExecutorConfig::default(),
                CollisionEngine::Grid,
            )),
            Box::new(AgslamPlanner::new(
                AgslamConfig {
                    candidates: agslam_candidates,
                    ..AgslamConfig::default()
                },
                mount,
                ExecutorConfig::default(),
                CollisionEngine::Grid,
            )),
        ];
        for mut planner in planners {
            let robot = Pose2 {
                x: 0.0,
                y: 0.0,
                theta: 0.3,
            };
            for k in 0..8 {
                let pose = Pose2 {
                    theta: 0.3 + std::f64::consts::FRAC_PI_4 * f64::from(k),
                    ..robot
                };
                let camera = mount.camera_at(&pose);
                let mut depth = match autonomy::splat::cpu::render(&map.gaussians, &camera) {
                    Ok(r) => r.images.depth,
                    Err(_) => vec![0.0; mount.intrinsics.pixel_count()],
                };
                // The lot has no floor Gaussians: rays below the horizon end on the floor.
                let k = &mount.intrinsics;
                for (p, d) in depth.iter_mut().enumerate() {
                    let y = (((p / k.width as usize) as f64) - k.cy) / k.fy;
                    let floor = if y > 1e-6 {
                        mount.height / y
                    } else {
                        f64::INFINITY
                    };
                    if floor <= mount.range && (*d <= 0.0 || f64::from(*d) > floor) {
                        *d = floor as f32;
                    }
                }
                planner.observe(
                    &Observation {
                        rgb: &[],
                        depth: &depth,
                        camera: &camera,
                        max_range: mount.range,
                        robot: pose,
                    },
                    &map,
                );
            }
            // The frontier planners open with a held look around; the plans after it count.
            let _ = planner.plan(&map, robot);
            let mut times = Vec::new();
            let mut last = None;
            for k in 0..3 {
                for i in (k..map.len()).step_by(100) {
                    map.gaussians.means[i][0] += 0.002;
                    map.uncertainty[i] = 0.002;
                }
                let start = Instant::now();
                last = Some(planner.plan(&map, robot));
                times.push(start.elapsed().as_secs_f64());
            }
            times.sort_by(f64::total_cmp);
            let (candidates, outcome) = match last {
                Some(Decision::Go(p)) => (p.candidates, "go".to_owned()),
                Some(Decision::Fail(f)) => (0, f.kind().to_owned()),
                Some(Decision::Done(reason) | Decision::Abort(reason)) => (0, reason),
                None => (0, String::new()),
            };
            rows.push(PlannersBenchRow {
                gaussians: n,
                planner: planner.name().to_owned(),
                plan: times[times.len() / 2],
                candidates,
                outcome,
            });
        }
    }
    rows
}
