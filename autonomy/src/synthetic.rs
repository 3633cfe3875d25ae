//! Procedural Gaussian scenes for benchmarks and tests: Gaussians spread over the surfaces of
//! a box-shaped room, coloured by a pattern of their position.

use crate::camera::{Intrinsics, PinholeCamera};
use crate::gaussians::Gaussians;
use crate::math::{Isometry3, Point3, Vector3};

/// Room half-extent in x and y, metres (a 6 x 6 m room).
pub const ROOM_HALF_WIDTH: f32 = 3.0;
/// Room height, metres.
pub const ROOM_HEIGHT: f32 = 2.5;

/// A tiny deterministic generator (SplitMix64), so the scene needs no RNG dependency.
struct SplitMix(u64);

impl SplitMix {
    fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// `n` Gaussians uniformly over the floor, ceiling and four walls of a 6 x 6 x 2.5 m room,
/// sized so neighbours overlap, opacity 0.9.
pub fn room_surface(n: usize, seed: u64) -> Gaussians {
    let (w, h) = (ROOM_HALF_WIDTH, ROOM_HEIGHT);
    let side = 2.0 * w;
    // Areas: floor, ceiling, then four walls.
    let areas = [
        side * side,
        side * side,
        side * h,
        side * h,
        side * h,
        side * h,
    ];
    let total: f32 = areas.iter().sum();
    let radius = 0.7 * (total / n.max(1) as f32).sqrt();
    let mut rng = SplitMix(seed);
    let mut g = Gaussians::default();
    for _ in 0..n {
        let mut pick = rng.next_f32() * total;
        let mut face = 0;
        while face < 5 && pick > areas[face] {
            pick -= areas[face];
            face += 1;
        }
        let (a, b) = (rng.next_f32() * side - w, rng.next_f32());
        let mean = match face {
            0 => [a, (b * 2.0 - 1.0) * w, 0.0],
            1 => [a, (b * 2.0 - 1.0) * w, h],
            2 => [a, w, b * h],
            3 => [a, -w, b * h],
            4 => [w, a, b * h],
            _ => [-w, a, b * h],
        };
        let pattern = |x: f32| 0.5 + 0.4 * (x * 7.0).sin();
        let colour = [
            pattern(mean[0] + mean[2]),
            pattern(mean[1] * 1.3),
            pattern(mean[0] - mean[1] + 0.5 * mean[2]),
        ];
        g.push(mean, radius, 0.9, colour);
    }
    g
}

/// A camera in the room at 1.2 m looking into a corner: two walls, floor and ceiling in view.
pub fn room_camera(width: u32, height: u32) -> PinholeCamera {
    let eye = Point3::new(-0.5, -0.5, 1.2);
    let target = Point3::new(3.0, 3.0, 1.0);
    PinholeCamera {
        intrinsics: Intrinsics::from_fovy(60f64.to_radians(), width, height),
        world_from_camera: Isometry3::face_towards(&eye, &target, &-Vector3::z()),
    }
}
