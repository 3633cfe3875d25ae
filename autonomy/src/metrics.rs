//! Map quality metrics (RT-GuIDE V-C): PSNR and SSIM on RGB in [0, 1], depth errors, and
//! coverage of ground-truth surface points.

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

/// The 27 cube offsets around a point, its own cube first: most covered points find their
/// mean there and stop.
const NEIGHBOURS: [[i32; 3]; 27] = {
    let mut out = [[0; 3]; 27];
    let mut k = 1;
    let mut d = 0;
    while d < 27 {
        let offset = [d / 9 - 1, d / 3 % 3 - 1, d % 3 - 1];
        if !(offset[0] == 0 && offset[1] == 0 && offset[2] == 0) {
            out[k] = offset;
            k += 1;
        }
        d += 1;
    }
    out
};

/// For each `surface` point, whether a Gaussian mean lies within `radius`: where a map is
/// missing, not only how much. Means are sorted into cubes of side `radius` (a hash from cube
/// to its run of means, no allocation per cube), so each point looks at 27 cubes at most, its
/// own first; the points are checked in parallel. Linear in points plus means (an episode
/// measures its hidden points after every step). Non-finite means cover nothing.
pub fn covered(surface: &[[f32; 3]], means: &[[f32; 3]], radius: f32) -> Vec<bool> {
    use rayon::prelude::*;
    // Each finite mean's cube, numbered in order of first appearance; then the means bucketed
    // by cube (a counting sort).
    let mut cubes: rustc_hash::FxHashMap<[i32; 3], u32> = Default::default();
    let mut counts: Vec<u32> = Vec::new();
    let bucket_of: Vec<u32> = means
        .iter()
        .map(|m| {
            if !m.iter().all(|v| v.is_finite()) {
                return u32::MAX;
            }
            let b = *cubes.entry(cube(m, radius)).or_insert_with(|| {
                counts.push(0);
                (counts.len() - 1) as u32
            });
            counts[b as usize] += 1;
            b
        })
        .collect();
    let mut starts = Vec::with_capacity(counts.len() + 1);
    let mut total = 0u32;
    starts.push(0);
    for c in &counts {
        total += c;
        starts.push(total);
    }
    let mut fill = starts.clone();
    let mut order = vec![0u32; total as usize];
    for (j, &b) in bucket_of.iter().enumerate() {
        if b != u32::MAX {
            order[fill[b as usize] as usize] = j as u32;
            fill[b as usize] += 1;
        }
    }
    let r2 = radius * radius;
    surface
        .par_iter()
        .map(|p| {
            let c = cube(p, radius);
            NEIGHBOURS.iter().any(|d| {
                cubes
                    .get(&[c[0] + d[0], c[1] + d[1], c[2] + d[2]])
                    .is_some_and(|&b| {
                        let run = starts[b as usize] as usize..starts[b as usize + 1] as usize;
                        order[run].iter().any(|&j| {
                            let m = &means[j as usize];
                            (0..3).map(|k| (m[k] - p[k]).powi(2)).sum::<f32>() <= r2
                        })
                    })
            })
        })
        .collect()
}

/// The cube of side `radius` holding `p`.
fn cube(p: &[f32; 3], radius: f32) -> [i32; 3] {
    p.map(|v| (v / radius).floor() as i32)
}
