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
    if surface.is_empty() {
        return 0.0;
    }
    let hits = covered(surface, means, radius)
        .iter()
        .filter(|c| **c)
        .count();
    hits as f64 / surface.len() as f64
}

/// For each `surface` point, whether a Gaussian mean lies within `radius`: where a map is
/// missing, not only how much. Means are filed in a hash of cubes of side `radius`, so each
/// point looks at 27 cells: linear in points plus means. Non-finite means cover nothing.
pub fn covered(surface: &[[f32; 3]], means: &[[f32; 3]], radius: f32) -> Vec<bool> {
    let cell = |p: &[f32; 3]| p.map(|v| (v / radius).floor() as i32);
    let mut grid: HashMap<[i32; 3], Vec<u32>> = HashMap::new();
    for (i, m) in means.iter().enumerate() {
        if m.iter().all(|v| v.is_finite()) {
            grid.entry(cell(m)).or_default().push(i as u32);
        }
    }
    let r2 = radius * radius;
    surface
        .iter()
        .map(|p| {
            let c = cell(p);
            (-1..=1).any(|dx| {
                (-1..=1).any(|dy| {
                    (-1..=1).any(|dz| {
                        grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz])
                            .is_some_and(|ids| {
                                ids.iter().any(|&i| {
                                    let m = &means[i as usize];
                                    (0..3).map(|k| (m[k] - p[k]).powi(2)).sum::<f32>() <= r2
                                })
                            })
                    })
                })
            })
        })
        .collect()
}
