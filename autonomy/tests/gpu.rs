//! The wgpu engine against the CPU engine (on lavapipe in CI): images within 1e-4, gradients
//! within 1e-3 of the largest of their kind, including a scene split into bands because its
//! pairs exceed a (deliberately small) binding limit.

mod support;

use autonomy::gaussians::Gaussians;
use autonomy::splat::gpu::{AdapterPolicy, GpuError, GpuRasteriser};
use autonomy::splat::{cpu, EngineChoice, Rasteriser, RenderError};
use support::{assert_close, assert_gradients_close, camera, linear_loss_gradients, scene};

/// The engine on any adapter; `None` (with the reason printed) only when there is none.
fn engine(binding_cap: Option<u64>) -> Option<GpuRasteriser> {
    match GpuRasteriser::new(AdapterPolicy::AllowSoftware, binding_cap) {
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
