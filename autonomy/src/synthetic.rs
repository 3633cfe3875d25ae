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

/// An axis-aligned box, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: [f64; 3],
    /// Upper corner.
    pub max: [f64; 3],
}

/// A procedural textured scene for mapping tests and benchmarks that need RGB-D frames
/// without MuJoCo: the inside of a room (walls, floor, ceiling) and solid boxes in it.
#[derive(Debug, Clone)]
pub struct BoxScene {
    /// The room; cameras stay inside it.
    pub room: Aabb,
    /// Solid boxes (furniture, interior walls).
    pub boxes: Vec<Aabb>,
    /// Depth beyond this reads 0 (no return), metres.
    pub max_range: f64,
}

/// A ray-cast RGB-D frame: RGB in [0, 1] (3 per pixel) and planar depth (0: no return).
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticFrame {
    /// Interleaved RGB.
    pub colour: Vec<f32>,
    /// Planar depth, metres.
    pub depth: Vec<f32>,
}

impl BoxScene {
    /// A 6 x 6 x 2.5 m room (centred on the origin, floor at z = 0) with a table-sized box and
    /// a tall cabinet.
    pub fn room() -> Self {
        BoxScene {
            room: Aabb {
                min: [-3.0, -3.0, 0.0],
                max: [3.0, 3.0, 2.5],
            },
            boxes: vec![
                Aabb {
                    min: [0.8, 0.6, 0.0],
                    max: [1.8, 1.4, 0.75],
                },
                Aabb {
                    min: [-2.9, 1.5, 0.0],
                    max: [-2.3, 2.7, 1.9],
                },
            ],
            max_range: 5.0,
        }
    }

    /// A 10 x 7 m apartment (70 m2): three rooms split by interior walls with door gaps, and
    /// furniture.
    pub fn apartment() -> Self {
        let wall = |x0: f64, y0: f64, x1: f64, y1: f64| Aabb {
            min: [x0, y0, 0.0],
            max: [x1, y1, 2.5],
        };
        let block = |x0: f64, y0: f64, x1: f64, y1: f64, h: f64| Aabb {
            min: [x0, y0, 0.0],
            max: [x1, y1, h],
        };
        BoxScene {
            room: Aabb {
                min: [0.0, 0.0, 0.0],
                max: [10.0, 7.0, 2.5],
            },
            boxes: vec![
                // Wall at x = 4 with a door between y = 3 and 4.
                wall(3.9, 0.0, 4.1, 3.0),
                wall(3.9, 4.0, 4.1, 7.0),
                // Wall at y = 4 from x = 4 to 10 with a door between x = 6.5 and 7.5.
                wall(4.1, 3.9, 6.5, 4.1),
                wall(7.5, 3.9, 10.0, 4.1),
                block(1.0, 5.0, 2.6, 6.0, 0.75),
                block(0.1, 0.3, 0.6, 2.0, 1.9),
                block(8.2, 0.8, 9.6, 2.6, 0.5),
                block(5.0, 5.5, 6.0, 6.9, 1.2),
            ],
            max_range: 5.0,
        }
    }

    /// Distance along `direction` (not normalised) to the first surface, and the surface's
    /// normal axis and side.
    fn cast(&self, origin: &Vector3, direction: &Vector3) -> Option<(f64, usize, bool)> {
        let mut best: Option<(f64, usize, bool)> = None;
        // Leaving the room: the nearest exit plane along each axis.
        for axis in 0..3 {
            let d = direction[axis];
            if d.abs() < 1e-12 {
                continue;
            }
            let (bound, positive) = if d > 0.0 {
                (self.room.max[axis], true)
            } else {
                (self.room.min[axis], false)
            };
            let t = (bound - origin[axis]) / d;
            if t > 0.0 && best.is_none_or(|(b, _, _)| t < b) {
                best = Some((t, axis, positive));
            }
        }
        // Entering a box: the slab test.
        for b in &self.boxes {
            let (mut near, mut far, mut axis, mut side) =
                (f64::NEG_INFINITY, f64::INFINITY, 0, false);
            let mut hit = true;
            for a in 0..3 {
                let d = direction[a];
                if d.abs() < 1e-12 {
                    if origin[a] < b.min[a] || origin[a] > b.max[a] {
                        hit = false;
                        break;
                    }
                    continue;
                }
                let (t0, t1) = ((b.min[a] - origin[a]) / d, (b.max[a] - origin[a]) / d);
                let (lo, hi) = if t0 < t1 { (t0, t1) } else { (t1, t0) };
                if lo > near {
                    near = lo;
                    axis = a;
                    side = d < 0.0;
                }
                far = far.min(hi);
            }
            if hit && near <= far && near > 0.0 && best.is_none_or(|(t, _, _)| near < t) {
                best = Some((near, axis, side));
            }
        }
        best
    }

    /// The texture: a base colour per surface orientation, a 0.5 m checker, a gentle ramp.
    fn colour(point: &Vector3, axis: usize, positive: bool) -> [f32; 3] {
        let base = match (axis, positive) {
            (2, false) => [0.55, 0.45, 0.35],
            (2, true) => [0.85, 0.85, 0.8],
            (0, true) => [0.7, 0.35, 0.3],
            (0, false) => [0.3, 0.55, 0.7],
            (1, true) => [0.4, 0.65, 0.35],
            _ => [0.75, 0.7, 0.35],
        };
        let (a, b) = match axis {
            0 => (point.y, point.z),
            1 => (point.x, point.z),
            _ => (point.x, point.y),
        };
        let checker = ((a * 2.0).floor() + (b * 2.0).floor()).rem_euclid(2.0);
        let shade = (0.8 + 0.2 * checker + 0.05 * (a * 1.7 + b).sin()) as f32;
        base.map(|c| (c * shade).clamp(0.0, 1.0))
    }

    /// Ray-casts an RGB-D frame from `camera`.
    pub fn render(&self, camera: &PinholeCamera) -> SyntheticFrame {
        let k = camera.intrinsics;
        let (w, h) = (k.width as usize, k.height as usize);
        let origin = camera.world_from_camera.translation.vector;
        let rotation = camera.world_from_camera.rotation;
        let mut frame = SyntheticFrame {
            colour: vec![0.0; 3 * w * h],
            depth: vec![0.0; w * h],
        };
        for v in 0..h {
            for u in 0..w {
                let ray = k.ray(u as f64, v as f64);
                let direction = rotation * ray;
                let Some((t, axis, positive)) = self.cast(&origin, &direction) else {
                    continue;
                };
                // `ray` has unit z, so t is planar depth.
                if t > self.max_range {
                    continue;
                }
                let p = origin + direction * t;
                let pixel = v * w + u;
                frame.depth[pixel] = t as f32;
                frame.colour[3 * pixel..3 * pixel + 3]
                    .copy_from_slice(&Self::colour(&p, axis, positive));
            }
        }
        frame
    }
}

/// A camera at `eye` looking at `target` (z up), the way a robot's camera would.
pub fn look_at(eye: [f64; 3], target: [f64; 3], intrinsics: Intrinsics) -> PinholeCamera {
    PinholeCamera {
        intrinsics,
        world_from_camera: Isometry3::face_towards(
            &Point3::from(eye),
            &Point3::from(target),
            &-Vector3::z(),
        ),
    }
}
