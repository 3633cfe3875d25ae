//! The splat renderers: gradients against finite differences, the CPU engine against the
//! scalar reference, and the edge cases.

mod support;

use autonomy::gaussians::{Gaussians, Gradients};
use autonomy::splat::{cpu, reference, ImageGradients, RenderError};
use support::{assert_close, assert_gradients_close, camera, linear_loss_gradients, scene};

fn linear_loss(exact: &[[f64; 5]], g: &ImageGradients) -> f64 {
    exact
        .iter()
        .enumerate()
        .map(|(p, v)| {
            (0..3)
                .map(|c| v[c] * f64::from(g.colour[3 * p + c]))
                .sum::<f64>()
                + v[3] * f64::from(g.depth[p])
                + v[4] * f64::from(g.silhouette[p])
        })
        .sum()
}

/// Every parameter of Gaussian `i` as (name, getter/setter index).
const PARAMETERS: [&str; 8] = [
    "mean.x",
    "mean.y",
    "mean.z",
    "log_radius",
    "logit_opacity",
    "r",
    "g",
    "b",
];

fn parameter(g: &mut Gaussians, i: usize, which: usize) -> &mut f32 {
    match which {
        0..=2 => &mut g.means[i][which],
        3 => &mut g.log_radii[i],
        4 => &mut g.logit_opacities[i],
        _ => &mut g.colours[i][which - 5],
    }
}

fn gradient(g: &Gradients, i: usize, which: usize) -> f32 {
    match which {
        0..=2 => g.means[i][which],
        3 => g.log_radii[i],
        4 => g.logit_opacities[i],
        _ => g.colours[i][which - 5],
    }
}

#[test]
fn reference_gradients_match_central_finite_differences() {
    let cam = camera(40, 30);
    let (mut compared, mut straddled) = (0, 0);
    for seed in 0..3 {
        let gaussians = scene(seed, 12, &cam);
        let image_grads = linear_loss_gradients(100 + seed, 40 * 30);
        let analytic = reference::backward(&gaussians, &cam, &image_grads).expect("backward");
        for i in 0..gaussians.len() {
            let scale = (0..8)
                .map(|w| gradient(&analytic, i, w).abs())
                .fold(0.0f32, f32::max);
            for which in 0..8 {
                let eps = 2e-4;
                let mut plus = gaussians.clone();
                let mut minus = gaussians.clone();
                let base = *parameter(&mut plus, i, which);
                *parameter(&mut plus, i, which) = base + eps;
                *parameter(&mut minus, i, which) = base - eps;
                let step =
                    f64::from(*parameter(&mut plus, i, which) - *parameter(&mut minus, i, which));
                let same_sets = reference::contributors(&plus, &cam).expect("sets")
                    == reference::contributors(&minus, &cam).expect("sets");
                if !same_sets {
                    straddled += 1;
                    continue;
                }
                let (_, hi) = reference::render(&plus, &cam).expect("render");
                let (_, lo) = reference::render(&minus, &cam).expect("render");
                let numeric =
                    (linear_loss(&hi, &image_grads) - linear_loss(&lo, &image_grads)) / step;
                let exact = f64::from(gradient(&analytic, i, which));
                // Tiny gradients are dominated by the finite difference's own error.
                if exact.abs().max(numeric.abs()) < 1e-2 * f64::from(scale).max(1e-3) {
                    continue;
                }
                let relative = (exact - numeric).abs() / exact.abs().max(numeric.abs());
                assert!(
                    relative < 1e-2,
                    "seed {seed} Gaussian {i} {}: analytic {exact:.6e}, numeric {numeric:.6e}",
                    PARAMETERS[which]
                );
                compared += 1;
            }
        }
    }
    assert!(compared > 150, "only {compared} gradients compared");
    assert!(
        straddled * 10 < compared,
        "{straddled} finite differences crossed a cut-off"
    );
}

#[test]
fn cpu_engine_matches_the_scalar_reference() {
    // 37 x 29: edge tiles are partly outside the image.
    let cam = camera(37, 29);
    for seed in 10..14 {
        let gaussians = scene(seed, 40, &cam);
        let render = cpu::render(&gaussians, &cam).expect("engine render");
        let (expected, _) = reference::render(&gaussians, &cam).expect("reference render");
        assert_close("colour", &render.images.colour, &expected.colour, 1e-5);
        assert_close("depth", &render.images.depth, &expected.depth, 1e-5);
        assert_close(
            "silhouette",
            &render.images.silhouette,
            &expected.silhouette,
            1e-5,
        );
        let image_grads = linear_loss_gradients(200 + seed, 37 * 29);
        let engine = cpu::backward(&render, &image_grads).expect("engine backward");
        let expected = reference::backward(&gaussians, &cam, &image_grads).expect("reference");
        assert_gradients_close(&engine, &expected, 1e-4);
    }
}

#[test]
fn cpu_engine_matches_the_reference_on_a_dense_scene_with_early_termination() {
    // Hundreds of overlapping opaque Gaussians: pixels saturate and stop early.
    let cam = camera(48, 32);
    let mut gaussians = scene(42, 400, &cam);
    gaussians.logit_opacities.iter_mut().for_each(|l| *l += 2.0);
    let render = cpu::render(&gaussians, &cam).expect("engine render");
    let (expected, _) = reference::render(&gaussians, &cam).expect("reference render");
    let saturated = expected.silhouette.iter().filter(|s| **s > 0.99).count();
    assert!(saturated > 300, "only {saturated} saturated pixels");
    assert_close("colour", &render.images.colour, &expected.colour, 1e-5);
    assert_close("depth", &render.images.depth, &expected.depth, 1e-5);
    let image_grads = linear_loss_gradients(7, 48 * 32);
    let engine = cpu::backward(&render, &image_grads).expect("engine backward");
    let expected = reference::backward(&gaussians, &cam, &image_grads).expect("reference");
    assert_gradients_close(&engine, &expected, 1e-4);
}

#[test]
fn no_gaussians_render_empty_images() {
    let cam = camera(32, 32);
    let render = cpu::render(&Gaussians::default(), &cam).expect("render");
    assert!(render
        .images
        .colour
        .iter()
        .chain(&render.images.silhouette)
        .all(|v| *v == 0.0));
    let grads = cpu::backward(&render, &ImageGradients::zeros(32 * 32)).expect("backward");
    assert!(grads.touched.is_empty());
}

#[test]
fn gaussians_behind_the_camera_are_culled() {
    let cam = camera(32, 32);
    let mut gaussians = scene(3, 20, &cam);
    // Mirror every mean through the camera centre: all behind it.
    let centre = cam.world_from_camera.translation.vector;
    for m in &mut gaussians.means {
        for a in 0..3 {
            m[a] = (2.0 * centre[a]) as f32 - m[a];
        }
    }
    let render = cpu::render(&gaussians, &cam).expect("render");
    assert_eq!(render.visible_count(), 0);
    assert!(render.images.silhouette.iter().all(|v| *v == 0.0));
    let grads = cpu::backward(&render, &linear_loss_gradients(1, 32 * 32)).expect("backward");
    assert!(grads.means.iter().flatten().all(|v| *v == 0.0));
}

#[test]
fn one_gaussian_covering_the_whole_image() {
    let cam = camera(40, 30);
    let centre = cam.back_project_to_world(19.5, 14.5, 1.0);
    let mut gaussians = Gaussians::default();
    gaussians.push(
        [centre.x as f32, centre.y as f32, centre.z as f32],
        100.0,
        0.8,
        [0.2, 0.4, 0.6],
    );
    let render = cpu::render(&gaussians, &cam).expect("render");
    let (expected, _) = reference::render(&gaussians, &cam).expect("reference");
    assert_close(
        "silhouette",
        &render.images.silhouette,
        &expected.silhouette,
        1e-5,
    );
    // A huge, flat Gaussian: every pixel sees nearly its full opacity and colour.
    for p in 0..40 * 30 {
        assert!((render.images.silhouette[p] - 0.8).abs() < 1e-3);
        assert!((render.images.colour[3 * p + 2] - 0.48).abs() < 1e-3);
        assert!((render.images.depth[p] - 0.8).abs() < 1e-3);
    }
}

#[test]
fn nan_parameters_are_refused_not_rendered() {
    let cam = camera(16, 16);
    let mut gaussians = scene(5, 4, &cam);
    gaussians.log_radii[2] = f32::NAN;
    let error = cpu::render(&gaussians, &cam).expect_err("NaN must be refused");
    assert!(matches!(error, RenderError::Gaussians(_)), "{error}");
    assert!(error.to_string().contains("Gaussian 2"), "{error}");
    gaussians.log_radii[2] = 0.0;
    gaussians.colours.pop();
    assert!(
        cpu::render(&gaussians, &cam).is_err(),
        "mismatched arrays must be refused"
    );
}
