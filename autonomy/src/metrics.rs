//! Image quality metrics (RT-GuIDE V-C): PSNR on RGB in [0, 1], depth errors.

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
