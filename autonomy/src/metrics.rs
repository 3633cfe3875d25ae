//! Map quality metrics (RT-GuIDE V-C): PSNR and SSIM on RGB in [0, 1], depth errors, and
//! coverage of ground-truth surface points.

use std::collections::HashMap;

/// Peak signal-to-noise ratio in dB of two RGB images in [0, 1] (values are clamped first).
pub fn psnr(a: &[f32], b: &[f32]) -> f64 {
    let mse = a
        .iter()
        .zip(b)
        .map(|(x, y)| f64::from(x.clamp(0.0, 1.0) - y.clamp(0.0, 1.0)).powi(2))
        .sum::<f64>()
        / a.len().max(1) as f64;
    if mse == 0.0 {
        f64::INFINITY
    } else {
        -10.0 * mse.log10()
    }
}

/// Mean absolute depth error over pixels where `truth` has a measurement.
pub fn depth_mae(rendered: &[f32], truth: &[f32]) -> f64 {
    let (sum, n) = rendered
        .iter()
        .zip(truth)
        .filter(|(_, t)| **t > 0.0)
        .fold((0.0, 0usize), |(s, n), (r, t)| {
            (s + f64::from(r - t).abs(), n + 1)
        });
    if n == 0 {
        0.0
    } else {
        sum / n as f64
    }
}

/// Mean SSIM (11x11 Gaussian window, sigma 1.5) over the three channels of two interleaved
/// RGB images in [0, 1] of `width` x `height` (values are clamped first), as the mapping loss
/// measures it.
pub fn ssim(a: &[f32], b: &[f32], width: usize, height: usize) -> f64 {
    let n = width * height;
    if n == 0 || a.len() < 3 * n || b.len() < 3 * n {
        return 0.0;
    }
    let mut unused = vec![0.0f64; n];
    (0..3)
        .map(|c| {
            let x: Vec<f64> = (0..n)
                .map(|p| f64::from(a[3 * p + c].clamp(0.0, 1.0)))
                .collect();
            let y: Vec<f64> = (0..n)
                .map(|p| f64::from(b[3 * p + c].clamp(0.0, 1.0)))
                .collect();
            crate::ssim::ssim_channel(&x, &y, width, height, 0.0, &mut unused)
        })
        .sum::<f64>()
        / 3.0
}

/// Fraction of `surface` points with a Gaussian mean within `radius` (DESIGN.md's coverage,
/// radius 5 cm): the share of [`covered`] that is true.
pub fn coverage(surface: &[[f32; 3]], means: &[[f32; 3]], radius: f32) -> f64 {
    SurfaceIndex::new(surface, radius).coverage(means)
}

/// For each `surface` point, whether a Gaussian mean lies within `radius`: where a map is
/// missing, not only how much. Non-finite means cover nothing.
pub fn covered(surface: &[[f32; 3]], means: &[[f32; 3]], radius: f32) -> Vec<bool> {
    SurfaceIndex::new(surface, radius).covered(means)
}

/// Surface points filed for coverage queries of many maps (an episode measures the same
/// hidden points after every step). Space is cut into cubes of side `radius`; each cube lists
/// the points in it and its 26 neighbours, which are the only ones a mean inside it can be
/// within `radius` of. A query then looks up each mean's one cube and checks a handful of
/// points: linear in the means, with no allocation per mean.
#[derive(Debug, Clone)]
pub struct SurfaceIndex {
    surface: Vec<[f32; 3]>,
    radius: f32,
    /// Cube -> (start, length) in `points`.
    cubes: HashMap<[i32; 3], (u32, u32)>,
    /// Surface point indices, cube by cube.
    points: Vec<u32>,
}

impl SurfaceIndex {
    /// Files `surface` for queries at `radius`.
    pub fn new(surface: &[[f32; 3]], radius: f32) -> Self {
        let mut near: HashMap<[i32; 3], Vec<u32>> = HashMap::new();
        for (i, p) in surface.iter().enumerate() {
            let c = cube(p, radius);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        near.entry([c[0] + dx, c[1] + dy, c[2] + dz])
                            .or_default()
                            .push(i as u32);
                    }
                }
            }
        }
        let mut cubes = HashMap::with_capacity(near.len());
        let mut points = Vec::with_capacity(27 * surface.len());
        for (key, list) in near {
            cubes.insert(key, (points.len() as u32, list.len() as u32));
            points.extend(list);
        }
        SurfaceIndex {
            surface: surface.to_vec(),
            radius,
            cubes,
            points,
        }
    }

    /// The surface points.
    pub fn surface(&self) -> &[[f32; 3]] {
        &self.surface
    }

    /// For each surface point, whether one of `means` lies within the radius.
    pub fn covered(&self, means: &[[f32; 3]]) -> Vec<bool> {
        let r2 = self.radius * self.radius;
        let mut hit = vec![false; self.surface.len()];
        for m in means {
            if !m.iter().all(|v| v.is_finite()) {
                continue;
            }
            let Some(&(start, len)) = self.cubes.get(&cube(m, self.radius)) else {
                continue;
            };
            for &i in &self.points[start as usize..(start + len) as usize] {
                let i = i as usize;
                if !hit[i] {
                    let p = &self.surface[i];
                    hit[i] = (0..3).map(|k| (m[k] - p[k]).powi(2)).sum::<f32>() <= r2;
                }
            }
        }
        hit
    }

    /// Fraction of the surface points with one of `means` within the radius (0 without points).
    pub fn coverage(&self, means: &[[f32; 3]]) -> f64 {
        if self.surface.is_empty() {
            return 0.0;
        }
        let hits = self.covered(means).iter().filter(|c| **c).count();
        hits as f64 / self.surface.len() as f64
    }
}

/// The cube of side `radius` holding `p`.
fn cube(p: &[f32; 3], radius: f32) -> [i32; 3] {
    p.map(|v| (v / radius).floor() as i32)
}
