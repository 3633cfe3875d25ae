//! The wgpu engine against the CPU engine (on lavapipe in CI): images within 1e-4, gradients
//! within 1e-3 of the largest of their kind, including a scene split into bands because its
//! pairs exceed a (deliberately small) binding limit.

mod support;

use autonomy::gaussians::Gaussians;
use autonomy::splat::gpu::{AdapterPolicy, GpuError, GpuOptions, GpuRasteriser};
use autonomy::splat::{cpu, EngineChoice, Rasteriser, RenderError};
use support::{assert_close, assert_gradients_close, camera, linear_loss_gradients, scene};

/// The engine on any adapter; `None` (with the reason printed) only when there is none.
fn engine(binding_cap: Option<u64>) -> Option<GpuRasteriser> {
    engine_with(GpuOptions {
        binding_cap,
        ..GpuOptions::default()
    })
}

/// The engine on any adapter, opened with `options`.
fn engine_with(options: GpuOptions) -> Option<GpuRasteriser> {
    match GpuRasteriser::with_options(AdapterPolicy::AllowSoftware, options) {
        Ok(gpu) => {
            eprintln!("wgpu adapter: {}", gpu.describe());
            Some(gpu)
        }
        Err(GpuError::NoAdapter(reason)) => {
            eprintln!("SKIPPED: no wgpu adapter at all: {reason}");
            None
        }
        Err(e) => panic!("an adapter exists but the engine failed: {e}"),
    }
}

fn assert_matches_cpu(
    gpu: &GpuRasteriser,
    gaussians: &Gaussians,
    width: u32,
    height: u32,
    seed: u64,
) {
    let cam = camera(width, height);
    let expected = cpu::render(gaussians, &cam).expect("cpu render");
    let got = gpu.render(gaussians, &cam).expect("gpu render");
    assert_close("colour", &got.images.colour, &expected.images.colour, 1e-4);
    assert_close("depth", &got.images.depth, &expected.images.depth, 1e-4);
    assert_close(
        "silhouette",
        &got.images.silhouette,
        &expected.images.silhouette,
        1e-4,
    );
    let image_grads = linear_loss_gradients(seed, (width * height) as usize);
    let expected = cpu::backward(&expected, &image_grads).expect("cpu backward");
    let got = gpu.backward(&got, &image_grads).expect("gpu backward");
    assert_gradients_close(&got, &expected, 1e-3);
}

#[test]
fn gpu_engine_matches_the_cpu_engine() {
    let Some(gpu) = engine(None) else { return };
    // 37 x 29: edge tiles partly outside the image.
    let cam = camera(37, 29);
    for seed in 20..23 {
        assert_matches_cpu(&gpu, &scene(seed, 60, &cam), 37, 29, 300 + seed);
    }
    // Dense and opaque: pixels saturate and stop early; lists longer than one staging batch.
    let cam = camera(64, 48);
    let mut dense = scene(43, 700, &cam);
    dense.logit_opacities.iter_mut().for_each(|l| *l += 2.0);
    assert_matches_cpu(&gpu, &dense, 64, 48, 9);
}

#[test]
fn both_backward_reductions_match_the_cpu_engine() {
    // The backward pass sums by subgroup where the adapter has subgroups (lavapipe has) and in
    // workgroup memory otherwise: both variants against the CPU engine, on lists longer than a
    // batch (the subgroup variant's batch is shorter where subgroups are narrow).
    for subgroups in [true, false] {
        let Some(gpu) = engine_with(GpuOptions {
            subgroups,
            ..GpuOptions::default()
        }) else {
            return;
        };
        if !subgroups {
            assert!(!gpu.has_subgroups(), "subgroups off when asked");
        }
        eprintln!("subgroup sums: {}", gpu.has_subgroups());
        let cam = camera(64, 48);
        let mut dense = scene(45, 700, &cam);
        dense.logit_opacities.iter_mut().for_each(|l| *l += 2.0);
        assert_matches_cpu(&gpu, &dense, 64, 48, 11);
        assert_fisher_matches_cpu(&gpu, &dense, 64, 48);
        let cam = camera(37, 29);
        assert_matches_cpu(&gpu, &scene(22, 60, &cam), 37, 29, 12);
    }
}

/// The Fisher mode of both engines on the same scene: each Gaussian's 8 values within 1e-3 of
/// the largest of that parameter.
fn assert_fisher_matches_cpu(gpu: &GpuRasteriser, gaussians: &Gaussians, width: u32, height: u32) {
    let cam = camera(width, height);
    let expected = cpu::fisher(&cpu::render(gaussians, &cam).expect("cpu render"));
    let got = gpu
        .fisher(&gpu.render(gaussians, &cam).expect("gpu render"))
        .expect("gpu fisher");
    assert_eq!(got.len(), expected.len());
    for k in 0..autonomy::splat::FISHER_PARAMETERS {
        let largest = expected.iter().fold(0.0f32, |m, h| m.max(h[k].abs()));
        assert!(largest > 0.0, "parameter {k} has information");
        for (i, (g, e)) in got.iter().zip(&expected).enumerate() {
            assert!(
                (g[k] - e[k]).abs() <= 1e-3 * largest,
                "gaussian {i} parameter {k}: gpu {} vs cpu {}",
                g[k],
                e[k]
            );
        }
    }
}

#[test]
fn gpu_fisher_matches_the_cpu_engine() {
    let Some(gpu) = engine(None) else { return };
    let cam = camera(37, 29);
    assert_fisher_matches_cpu(&gpu, &scene(21, 60, &cam), 37, 29);
    let cam = camera(64, 48);
    let mut dense = scene(44, 500, &cam);
    dense.logit_opacities.iter_mut().for_each(|l| *l += 2.0);
    assert_fisher_matches_cpu(&gpu, &dense, 64, 48);
    // Banded: a small binding limit splits the image.
    let Some(banded) = engine(Some(16 * 1024)) else {
        return;
    };
    let cam = camera(32, 80);
    let mut wide = scene(5, 300, &cam);
    wide.log_radii.iter_mut().for_each(|r| *r += 0.7);
    assert_fisher_matches_cpu(&banded, &wide, 32, 80);
}

#[test]
fn gpu_engine_splits_pairs_above_the_binding_limit_into_bands() {
    // 16 KiB bindings hold 4096 pairs, 341 splat records, or one row of tiles of a 32-pixel-wide
    // image (14 KiB): the 5 rows of 32 x 80 need several bands.
    let Some(gpu) = engine(Some(16 * 1024)) else {
        return;
    };
    let cam = camera(32, 80);
    let mut gaussians = scene(5, 300, &cam);
    gaussians.log_radii.iter_mut().for_each(|r| *r += 0.7);
    let render = gpu.render(&gaussians, &cam).expect("gpu render");
    assert!(
        render.band_count() > 1,
        "{} pairs fit one band",
        render.pair_count()
    );
    assert_matches_cpu(&gpu, &gaussians, 32, 80, 77);
}

#[test]
fn gpu_engine_edge_cases_match_the_cpu_engine() {
    let Some(gpu) = engine(None) else { return };
    let cam = camera(40, 30);
    // No Gaussians at all.
    let empty = Gaussians::default();
    let render = gpu.render(&empty, &cam).expect("empty render");
    assert!(render.images.silhouette.iter().all(|s| *s == 0.0));
    let grads = gpu
        .backward(&render, &linear_loss_gradients(1, 1200))
        .expect("empty backward");
    assert!(grads.touched.is_empty());
    // Everything behind the camera.
    let mut behind = scene(3, 20, &cam);
    let forward = cam.world_from_camera.rotation * nalgebra::Vector3::z();
    for m in &mut behind.means {
        let p = nalgebra::Vector3::new(m[0], m[1], m[2]).cast::<f64>() - 8.0 * forward;
        *m = [p.x as f32, p.y as f32, p.z as f32];
    }
    let render = gpu.render(&behind, &cam).expect("render");
    assert_eq!(render.pair_count(), 0);
    assert!(render.images.silhouette.iter().all(|s| *s == 0.0));
    // NaN is refused, not rendered.
    let mut bad = scene(4, 5, &cam);
    bad.means[2][1] = f32::NAN;
    assert!(matches!(
        gpu.render(&bad, &cam),
        Err(RenderError::Gaussians(_))
    ));
}

#[test]
fn engine_choice_parses_and_cpu_is_always_available() {
    assert_eq!("GPU".parse::<EngineChoice>(), Ok(EngineChoice::Gpu));
    assert_eq!("auto".parse::<EngineChoice>(), Ok(EngineChoice::Auto));
    assert!("cuda".parse::<EngineChoice>().is_err());
    let cam = camera(16, 16);
    let engine = Rasteriser::select(EngineChoice::Cpu);
    let rendered = engine.render(&scene(1, 10, &cam), &cam).expect("render");
    let direct = cpu::render(&scene(1, 10, &cam), &cam).expect("render");
    assert_eq!(rendered.images(), &direct.images);
}

/// The Gaussians whose `keep` flag is set, as pruning leaves them.
fn kept(g: &Gaussians, keep: &[bool]) -> Gaussians {
    let mut out = Gaussians::default();
    for i in (0..g.len()).filter(|i| keep[*i]) {
        out.means.push(g.means[i]);
        out.log_radii.push(g.log_radii[i]);
        out.logit_opacities.push(g.logit_opacities[i]);
        out.colours.push(g.colours[i]);
    }
    out
}

/// `iterations` CPU mapping iterations on `views` in turn: the reference the resident GPU
/// iteration must reproduce. Returns the loss terms of each.
fn cpu_iterations(
    gaussians: &mut Gaussians,
    adam: &mut autonomy::adam::Adam,
    views: &[(autonomy::camera::PinholeCamera, autonomy::splat::Images)],
    iterations: usize,
) -> Vec<autonomy::loss::LossTerms> {
    (0..iterations)
        .map(|i| {
            let (cam, target) = &views[i % views.len()];
            let render = cpu::render(gaussians, cam).expect("cpu render");
            let (terms, image_grads) = autonomy::loss::mapping_loss(
                &render.images,
                autonomy::loss::Target {
                    colour: &target.colour,
                    depth: &target.depth,
                },
            );
            let grads = cpu::backward(&render, &image_grads).expect("cpu backward");
            adam.step(gaussians, &grads);
            terms
        })
        .collect()
}

/// The resident iteration (render, loss, backward, Adam in one submit) against the CPU
/// engine's, on a map that grows (as densification grows it: only the new Gaussians
/// uploaded) and shrinks (as pruning does: compacted on the GPU from one bit per Gaussian),
/// with its traffic: after warm-up no buffer is created, one submit per iteration, nothing
/// uploaded and at most 64 bytes read back. The resident render (densification's) matches
/// the CPU engine's render of the same map.
#[test]
fn resident_iterations_match_the_cpu_engine_and_stay_on_the_gpu() {
    use autonomy::adam::{Adam, LearningRates};
    use autonomy::splat::gpu::ResidentMap;
    let Some(gpu) = engine(None) else { return };
    let (width, height) = (64, 48);
    let cam = camera(width, height);
    let mut other = cam;
    other.world_from_camera.translation.vector.x += 0.05;
    // Targets: renders of the scene moved a little, so every Gaussian has a gradient.
    let truth = scene(11, 600, &cam);
    let views: Vec<_> = [cam, other]
        .iter()
        .map(|c| (*c, cpu::render(&truth, c).expect("target").images))
        .collect();
    let mut start = truth.clone();
    for (i, m) in start.means.iter_mut().enumerate() {
        m[i % 3] += 0.01 * (((i * 7919) % 13) as f32 / 6.0 - 1.0);
    }
    let mut resident = ResidentMap::new(&gpu, LearningRates::default());
    for (c, images) in &views {
        resident
            .add_view(&gpu, c, &images.colour, &images.depth)
            .expect("view");
    }
    // Three steps: 600 Gaussians, grown to 900 (new ones appended), shrunk to every other.
    let mut cpu_map = start.clone();
    let mut cpu_adam = Adam::new(LearningRates::default());
    let mut gpu_map = start;
    let mut gpu_adam = Adam::new(LearningRates::default());
    for step in 0..3 {
        if step == 1 {
            let extra = scene(12, 300, &cam);
            for map in [&mut cpu_map, &mut gpu_map] {
                map.means.extend_from_slice(&extra.means);
                map.log_radii.extend_from_slice(&extra.log_radii);
                map.logit_opacities
                    .extend_from_slice(&extra.logit_opacities);
                map.colours.extend_from_slice(&extra.colours);
            }
        }
        if step == 2 {
            // The GPU's copy is compacted on the GPU; the host's Adam is not used again.
            let keep: Vec<bool> = (0..cpu_map.len()).map(|i| i % 2 == 0).collect();
            cpu_map = kept(&cpu_map, &keep);
            cpu_adam.retain(&keep);
            gpu_map = kept(&gpu_map, &keep);
            gpu_adam.retain(&keep);
        }
        let n = gpu_map.len();
        gpu_adam.resize(n);
        let before = gpu.traffic();
        match step {
            0 => resident
                .load(&gpu, &gpu_map, gpu_adam.state())
                .expect("load"),
            1 => resident.append(&gpu, &gpu_map).expect("append"),
            _ => {
                let keep: Vec<bool> = (0..resident.len()).map(|i| i % 2 == 0).collect();
                resident.retain(&gpu, &keep).expect("retain");
            }
        }
        let change = gpu.traffic() - before;
        assert_eq!(resident.len(), n, "step {step}: Gaussians resident");
        if step > 0 {
            // Only the new Gaussians (300 x 32 bytes) or one bit per Gaussian go up, with a
            // few counts and parameters; no buffer is made (the capacity holds 1024).
            let limit = if step == 1 { 300 * 32 + 128 } else { 256 };
            assert!(
                change.uploaded <= limit,
                "step {step}: {} bytes uploaded to change the map",
                change.uploaded
            );
            assert_eq!(change.buffers, 0, "step {step}: buffers made");
            assert_eq!(change.submits, 1, "step {step}: submits");
            resident.begin_step(&gpu);
        }
        let rendered = resident.render(&gpu, 0).expect("resident render");
        let reference = cpu::render(&gpu_map, &views[0].0).expect("cpu render");
        for (name, a, b) in [
            ("colour", &rendered.colour, &reference.images.colour),
            ("depth", &rendered.depth, &reference.images.depth),
            (
                "silhouette",
                &rendered.silhouette,
                &reference.images.silhouette,
            ),
        ] {
            assert_close(&format!("step {step}: resident {name}"), a, b, 1e-4);
        }
        let expected = cpu_iterations(&mut cpu_map, &mut cpu_adam, &views, 4);
        let mut got = Vec::new();
        for i in 0..4 {
            if i == 1 {
                // Warm-up over: every later iteration stays on the GPU.
                let warm = gpu.traffic();
                got.push(resident.iterate(&gpu, i % 2).expect("iterate"));
                let one = gpu.traffic() - warm;
                assert_eq!(
                    one.buffers, 0,
                    "step {step}: buffers created in an iteration"
                );
                assert_eq!(one.submits, 1, "step {step}: submits in an iteration");
                assert_eq!(
                    one.uploaded, 0,
                    "step {step}: bytes uploaded in an iteration"
                );
                assert!(
                    one.read_back <= 64,
                    "step {step}: {} bytes read back",
                    one.read_back
                );
            } else if i == 2 {
                // Timed by GPU timestamps: the same iteration (its loss is checked against
                // the CPU's below like the others), and every pass of it named.
                let (terms, passes) = gpu
                    .time_passes(|| resident.iterate(&gpu, i % 2))
                    .expect("timed iterate");
                got.push(terms);
                check_pass_times(passes, width, height);
            } else {
                got.push(resident.iterate(&gpu, i % 2).expect("iterate"));
            }
        }
        let mut touched = vec![false; n];
        resident
            .store(&gpu, &mut gpu_map, gpu_adam.state_mut(), &mut touched)
            .expect("store");
        for (g, e) in got.iter().zip(&expected) {
            for (name, a, b) in [
                ("depth L1", g.depth_l1, e.depth_l1),
                ("colour L1", g.colour_l1, e.colour_l1),
                ("SSIM", g.ssim, e.ssim),
            ] {
                assert!(
                    (a - b).abs() <= 1e-4 * b.abs().max(1e-2),
                    "step {step} {name}: gpu {a}, cpu {b}"
                );
            }
        }
        assert!(touched.iter().any(|t| *t), "step {step}: nothing touched");
        let flat = |g: &Gaussians| -> Vec<f32> {
            g.means
                .iter()
                .flatten()
                .chain(&g.log_radii)
                .chain(&g.logit_opacities)
                .chain(g.colours.iter().flatten())
                .copied()
                .collect()
        };
        assert_close("map after the step", &flat(&gpu_map), &flat(&cpu_map), 1e-4);
        let (a, b) = (gpu_adam.state(), cpu_adam.state());
        assert_eq!(a.steps, b.steps, "step {step}: Adam's step counts");
        assert_close("first moments", &flat(a.first), &flat(b.first), 1e-4);
    }
}

/// One resident iteration's passes by kernel: each stage once, the radix sort's passes as
/// many as the key has bytes (the depth's 4, the tile's 1 here), every time finite.
fn check_pass_times(passes: Option<autonomy::splat::gpu::PassTimes>, width: u32, height: u32) {
    let Some(passes) = passes else {
        eprintln!("SKIPPED: this adapter has no GPU timestamps");
        return;
    };
    let count = |entry: &str| {
        passes
            .iter()
            .find(|(name, _, _)| name == entry)
            .map_or(0, |(_, n, _)| *n)
    };
    for entry in [
        "project",
        "count_pairs",
        "emit_pairs",
        "forward",
        "loss_total",
        "backward",
        "chain",
        "adam_step",
    ] {
        assert_eq!(count(entry), 1, "passes of {entry}: {passes:?}");
    }
    let tiles = width.div_ceil(16) * height.div_ceil(16);
    let tile_bytes = (32 - (tiles - 1).leading_zeros()).div_ceil(8) as usize;
    assert_eq!(count("histogram_pass"), 4 + tile_bytes, "{passes:?}");
    assert_eq!(count("scatter_pass"), 4 + tile_bytes, "{passes:?}");
    assert!(
        passes.iter().all(|(_, _, ms)| ms.is_finite() && *ms >= 0.0),
        "{passes:?}"
    );
    assert!(
        passes.iter().map(|(_, _, ms)| ms).sum::<f64>() > 0.0,
        "{passes:?}"
    );
}
