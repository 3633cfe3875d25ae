//! Map quality metrics: coverage (and which points it covers) against a brute-force search,
//! SSIM against its closed form.

use autonomy::metrics::{coverage, covered, ssim};
use rand::{Rng, SeedableRng};

#[test]
fn coverage_equals_a_brute_force_search() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let mut point = || -> [f32; 3] {
        [
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(0.0..0.5),
        ]
    };
    let means: Vec<[f32; 3]> = (0..3000).map(|_| point()).collect();
    let mut surface: Vec<[f32; 3]> = (0..2000).map(|_| point()).collect();
    // Points just inside and just outside 5 cm of a mean.
    for m in means.iter().take(50) {
        surface.push([m[0] + 0.0499, m[1], m[2]]);
        surface.push([m[0], m[1] - 0.0501, m[2]]);
    }
    let brute_mask: Vec<bool> = surface
        .iter()
        .map(|p| {
            means
                .iter()
                .any(|m| (0..3).map(|k| (m[k] - p[k]).powi(2)).sum::<f32>() <= 0.05f32 * 0.05)
        })
        .collect();
    assert_eq!(covered(&surface, &means, 0.05), brute_mask);
    let brute = brute_mask.iter().filter(|c| **c).count() as f64 / surface.len() as f64;
    let fast = coverage(&surface, &means, 0.05);
    assert_eq!(fast, brute);
    assert!(
        fast > 0.05 && fast < 0.95,
        "coverage {fast} does not exercise both sides"
    );
    assert_eq!(coverage(&surface, &[], 0.05), 0.0);
    // Maps that changed (means dropped, moved, renumbered) and a non-finite mean, which
    // covers nothing.
    let mut moved = means.clone();
    moved.reverse();
    for m in moved.iter_mut().step_by(3) {
        m[0] += 0.03;
    }
    for some in [
        means.clone(),
        means[..1000].to_vec(),
        moved,
        means[2990..].to_vec(),
        means.clone(),
    ] {
        let mut some = some;
        some.push([f32::NAN, 0.0, 0.0]);
        let brute: Vec<bool> = surface
            .iter()
            .map(|p| {
                some.iter()
                    .any(|m| (0..3).map(|k| (m[k] - p[k]).powi(2)).sum::<f32>() <= 0.05f32 * 0.05)
            })
            .collect();
        assert_eq!(
            covered(&surface, &some, 0.05),
            brute,
            "{} means",
            some.len()
        );
    }
}

#[test]
fn ssim_of_flat_images_matches_the_closed_form() {
    let (w, h) = (24, 20);
    let flat = |c: [f32; 3]| -> Vec<f32> { (0..w * h).flat_map(|_| c).collect() };
    let (a, b) = ([0.2f32, 0.5, 0.9], [0.3f32, 0.5, 0.6]);
    // Flat images through a zero-padded window of mass alpha (1 inside, less near the border):
    // mu = alpha c, var_x = alpha (1 - alpha) x^2, cov = alpha (1 - alpha) x y.
    let weights: Vec<f64> = (-5..=5)
        .map(|t: i32| (-f64::from(t * t) / 4.5).exp())
        .collect();
    let total: f64 = weights.iter().sum();
    let mass = |i: usize, n: usize| -> f64 {
        (-5..=5i64)
            .zip(&weights)
            .filter(|(t, _)| (0..n as i64).contains(&(i as i64 + t)))
            .map(|(_, w)| w / total)
            .sum()
    };
    let (c1, c2) = (1e-4f64, 9e-4f64);
    let mut expected = 0.0;
    for c in 0..3 {
        let (x, y) = (f64::from(a[c]), f64::from(b[c]));
        for py in 0..h {
            for px in 0..w {
                let al = mass(px, w) * mass(py, h);
                let v = al * (1.0 - al);
                expected += (2.0 * al * al * x * y + c1) / (al * al * (x * x + y * y) + c1)
                    * (2.0 * v * x * y + c2)
                    / (v * (x * x + y * y) + c2);
            }
        }
    }
    expected /= (3 * w * h) as f64;
    let got = ssim(&flat(a), &flat(b), w, h);
    assert!((got - expected).abs() < 1e-6, "{got} vs {expected}");
    assert!((ssim(&flat(a), &flat(a), w, h) - 1.0).abs() < 1e-12);
}

#[test]
fn ssim_falls_as_noise_grows() {
    let (w, h) = (32, 32);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let image: Vec<f32> = (0..3 * w * h).map(|i| ((i % 97) as f32) / 97.0).collect();
    let mut noisy = |sigma: f32| -> Vec<f32> {
        image
            .iter()
            .map(|v| v + sigma * rng.gen_range(-1.0f32..1.0))
            .collect()
    };
    let (small, large) = (noisy(0.02), noisy(0.2));
    assert!(ssim(&image, &small, w, h) > ssim(&image, &large, w, h) + 0.1);
}
