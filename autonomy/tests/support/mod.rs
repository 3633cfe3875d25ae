#![allow(dead_code)] // each test crate uses a different subset
//! Seeded random scenes for the renderer tests.

use autonomy::camera::{Intrinsics, PinholeCamera};
use autonomy::gaussians::{Gaussians, Gradients};
use autonomy::math::{Isometry3, Translation3, UnitQuaternion};
use autonomy::splat::ImageGradients;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A camera at a tilted, non-trivial pose, so the chain rule through R is exercised.
pub fn camera(width: u32, height: u32) -> PinholeCamera {
    PinholeCamera {
        intrinsics: Intrinsics::from_fovy(60f64.to_radians(), width, height),
        world_from_camera: Isometry3::from_parts(
            Translation3::new(0.3, -0.2, 0.5),
            UnitQuaternion::from_euler_angles(0.2, -0.3, 0.4),
        ),
    }
}

/// `n` Gaussians in front of `camera`, 1.5-4 m away, a few pixels to tens of pixels wide.
pub fn scene(seed: u64, n: usize, camera: &PinholeCamera) -> Gaussians {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let k = camera.intrinsics;
    let mut g = Gaussians::default();
    for _ in 0..n {
        let depth = rng.gen_range(1.5..4.0);
        let u = rng.gen_range(-0.1..1.1) * f64::from(k.width);
        let v = rng.gen_range(-0.1..1.1) * f64::from(k.height);
        let p = camera.back_project_to_world(u, v, depth);
        g.push(
            [p.x as f32, p.y as f32, p.z as f32],
            rng.gen_range(0.02..0.25),
            rng.gen_range(0.2..0.95),
            [rng.gen(), rng.gen(), rng.gen()],
        );
    }
    g
}

/// Uniform random numbers in [-1, 1].
pub fn random_weights(seed: u64, n: usize) -> Vec<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect()
}

/// A linear loss sum_p w . (C, D, S) has these per-pixel gradients.
pub fn linear_loss_gradients(seed: u64, pixels: usize) -> ImageGradients {
    ImageGradients {
        colour: random_weights(seed, 3 * pixels),
        depth: random_weights(seed + 1, pixels),
        silhouette: random_weights(seed + 2, pixels),
    }
}

/// Values agree within `tolerance` element by element.
pub fn assert_close(name: &str, engine: &[f32], reference: &[f32], tolerance: f32) {
    assert_eq!(engine.len(), reference.len());
    for (p, (a, b)) in engine.iter().zip(reference).enumerate() {
        assert!(
            (a - b).abs() <= tolerance,
            "{name}[{p}]: engine {a}, reference {b}"
        );
    }
}

/// Gradients agree within `relative` of the largest gradient of the same kind.
pub fn assert_gradients_close(engine: &Gradients, reference: &Gradients, relative: f32) {
    let kinds: [(&str, Vec<f32>, Vec<f32>); 4] = [
        ("means", engine.means.concat(), reference.means.concat()),
        (
            "log_radii",
            engine.log_radii.clone(),
            reference.log_radii.clone(),
        ),
        (
            "logit_opacities",
            engine.logit_opacities.clone(),
            reference.logit_opacities.clone(),
        ),
        (
            "colours",
            engine.colours.concat(),
            reference.colours.concat(),
        ),
    ];
    for (name, e, r) in kinds {
        let scale = r.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        assert!(scale > 0.0, "{name}: reference gradients all zero");
        for (i, (a, b)) in e.iter().zip(&r).enumerate() {
            assert!(
                (a - b).abs() <= relative * scale,
                "{name}[{i}]: engine {a}, reference {b} (scale {scale})"
            );
        }
    }
    assert_eq!(engine.touched, reference.touched);
}
