//! Seeded random scenes for the renderer tests.

use autonomy::camera::{Intrinsics, PinholeCamera};
use autonomy::gaussians::Gaussians;
use autonomy::math::{Isometry3, Translation3, UnitQuaternion};
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
