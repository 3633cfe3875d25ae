//! The loss and its gradient, and the whole loop: render, loss, backward, Adam.

use autonomy::adam::{Adam, LearningRates};
use autonomy::camera::{Intrinsics, PinholeCamera};
use autonomy::gaussians::{Gaussians, Gradients};
use autonomy::loss::{
    loss_generic, loss_simd, loss_simd_in, mapping_loss, LossWorkspace, RgbdSlices, Target,
};
use autonomy::math::{Isometry3, Point3, Vector3};
use autonomy::metrics::psnr;
use autonomy::splat::cpu;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn loss_f64(colour: &[f64], depth: &[f64], tc: &[f64], td: &[f64], w: usize, h: usize) -> f64 {
    let (mut gc, mut gd) = (vec![0.0; colour.len()], vec![0.0; depth.len()]);
    let rendered = RgbdSlices { colour, depth };
    let target = RgbdSlices {
        colour: tc,
        depth: td,
    };
    let [d, c, s] = loss_generic(rendered, target, (w, h), &mut gc, &mut gd);
    d + 0.4 * c + 0.1 * (1.0 - s)
}

#[test]
fn loss_gradient_matches_central_finite_differences() {
    let (w, h) = (21, 17);
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let colour: Vec<f64> = (0..3 * w * h).map(|_| rng.gen_range(0.0..1.0)).collect();
    let target: Vec<f64> = colour
        .iter()
        .map(|c| (c + rng.gen_range(-0.3..0.3)).clamp(0.0, 1.0))
        .collect();
    let depth: Vec<f64> = (0..w * h).map(|_| rng.gen_range(1.0..3.0)).collect();
    let target_depth: Vec<f64> = depth
        .iter()
        .map(|d| {
            if rng.gen_bool(0.2) {
                0.0
            } else {
                d + rng.gen_range(-0.2..0.2)
            }
        })
        .collect();
    let (mut gc, mut gd) = (vec![0.0; 3 * w * h], vec![0.0; w * h]);
    loss_generic(
        RgbdSlices {
            colour: &colour,
            depth: &depth,
        },
        RgbdSlices {
            colour: &target,
            depth: &target_depth,
        },
        (w, h),
        &mut gc,
        &mut gd,
    );
    let eps = 1e-6;
    for i in (0..3 * w * h).step_by(7) {
        let (mut plus, mut minus) = (colour.clone(), colour.clone());
        plus[i] += eps;
        minus[i] -= eps;
        let numeric = (loss_f64(&plus, &depth, &target, &target_depth, w, h)
            - loss_f64(&minus, &depth, &target, &target_depth, w, h))
            / (2.0 * eps);
        let relative = (numeric - gc[i]).abs() / numeric.abs().max(gc[i].abs()).max(1e-12);
        assert!(
            relative < 1e-4,
            "colour[{i}]: analytic {}, numeric {numeric}",
            gc[i]
        );
    }
    for p in (0..w * h).step_by(5) {
        let (mut plus, mut minus) = (depth.clone(), depth.clone());
        plus[p] += eps;
        minus[p] -= eps;
        let numeric = (loss_f64(&colour, &plus, &target, &target_depth, w, h)
            - loss_f64(&colour, &minus, &target, &target_depth, w, h))
            / (2.0 * eps);
        assert!(
            (numeric - gd[p]).abs() < 1e-6,
            "depth[{p}]: analytic {}, numeric {numeric}",
            gd[p]
        );
        if target_depth[p] == 0.0 {
            assert_eq!(gd[p], 0.0, "unmeasured pixels carry no depth gradient");
        }
    }
}

/// A 640x480 frame pair with structure at every scale SSIM sees (stripes, blobs, noise) and
/// no pixel where the L1 terms' kink could be crossed by a finite difference: every colour and
/// depth differs from its target by at least 0.01.
fn vga_pair() -> (Vec<f32>, Vec<f32>, Vec<f32>, Vec<f32>, usize, usize) {
    let (w, h) = (640, 480);
    let mut rng = ChaCha8Rng::seed_from_u64(640);
    let mut colour = Vec::with_capacity(3 * w * h);
    let mut target = Vec::with_capacity(3 * w * h);
    for y in 0..h {
        for x in 0..w {
            for c in 0..3 {
                let base = 0.5
                    + 0.3 * ((x as f32 * 0.07 + c as f32).sin() * (y as f32 * 0.05).cos())
                    + rng.gen_range(-0.1..0.1);
                let offset: f32 = rng.gen_range(0.01..0.15);
                let sign = if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
                colour.push(base);
                target.push(base + sign * offset);
            }
        }
    }
    let depth: Vec<f32> = (0..w * h).map(|p| 1.0 + (p % 97) as f32 * 0.02).collect();
    let target_depth: Vec<f32> = depth
        .iter()
        .map(|d| {
            if rng.gen_bool(0.1) {
                0.0
            } else {
                d + if rng.gen_bool(0.5) { 0.05 } else { -0.05 }
            }
        })
        .collect();
    (colour, depth, target, target_depth, w, h)
}

#[test]
fn simd_loss_matches_the_f64_reference_and_finite_differences_at_640x480() {
    let (colour, depth, target, target_depth, w, h) = vga_pair();
    let wide = |v: &[f32]| v.iter().map(|x| f64::from(*x)).collect::<Vec<f64>>();
    let (colour64, depth64) = (wide(&colour), wide(&depth));
    let (target64, target_depth64) = (wide(&target), wide(&target_depth));
    let (mut gc64, mut gd64) = (vec![0.0; 3 * w * h], vec![0.0; w * h]);
    let reference = loss_generic(
        RgbdSlices {
            colour: &colour64,
            depth: &depth64,
        },
        RgbdSlices {
            colour: &target64,
            depth: &target_depth64,
        },
        (w, h),
        &mut gc64,
        &mut gd64,
    );
    let (mut gc, mut gd) = (vec![f32::NAN; 3 * w * h], vec![f32::NAN; w * h]);
    let fast = loss_simd(
        RgbdSlices {
            colour: &colour,
            depth: &depth,
        },
        RgbdSlices {
            colour: &target,
            depth: &target_depth,
        },
        (w, h),
        &mut gc,
        &mut gd,
    );
    for (term, (a, b)) in ["depth L1", "colour L1", "SSIM"]
        .iter()
        .zip(fast.iter().zip(reference.iter()))
    {
        assert!(
            (f64::from(*a) - b).abs() < 1e-5 * b.abs().max(1e-3),
            "{term}: simd {a}, reference {b}"
        );
    }
    // Every gradient entry, against the largest one (the entries are ~1e-7: per-pixel means).
    let largest = gc64.iter().fold(0.0f64, |m, g| m.max(g.abs()));
    for (i, (a, b)) in gc.iter().zip(&gc64).enumerate() {
        assert!(
            (f64::from(*a) - b).abs() < 1e-4 * largest,
            "colour gradient {i}: simd {a}, reference {b} (largest {largest})"
        );
    }
    for (p, (a, b)) in gd.iter().zip(&gd64).enumerate() {
        assert!(
            (f64::from(*a) - b).abs() < 1e-6 * b.abs().max(1e-12),
            "depth gradient {p}: simd {a}, reference {b}"
        );
    }
    // Central differences of the f64 loss at corners, edges and the middle: the window's
    // zero padding is where a blur's bookkeeping goes wrong first.
    let eps = 1e-4;
    let pixels = [
        (0, 0),
        (w - 1, 0),
        (0, h - 1),
        (w - 1, h - 1),
        (3, 200),
        (637, 17),
        (320, 4),
        (321, 240),
    ];
    for (x, y) in pixels {
        for c in [0, 2] {
            let i = 3 * (y * w + x) + c;
            let (mut plus, mut minus) = (colour64.clone(), colour64.clone());
            plus[i] += eps;
            minus[i] -= eps;
            let numeric = (loss_f64(&plus, &depth64, &target64, &target_depth64, w, h)
                - loss_f64(&minus, &depth64, &target64, &target_depth64, w, h))
                / (2.0 * eps);
            let analytic = f64::from(gc[i]);
            assert!(
                (numeric - analytic).abs() < 1e-3 * numeric.abs() + 1e-4 * largest,
                "colour ({x}, {y}, {c}): simd {analytic}, numeric {numeric}"
            );
        }
    }
}

/// The top-left `cw` x `ch` pixels of a row-major image `w` pixels wide with `channels` floats
/// per pixel, as a packed image of its own.
fn crop(v: &[f32], w: usize, channels: usize, cw: usize, ch: usize) -> Vec<f32> {
    (0..ch)
        .flat_map(|y| v[y * w * channels..(y * w + cw) * channels].to_vec())
        .collect()
}

#[test]
fn a_kept_loss_workspace_gives_fresh_scratch_results_bit_for_bit_across_sizes() {
    // The mapper keeps one workspace for every iteration (and the sizes of a run never change,
    // but a reused Python mapper's may): stale rows or padding from an earlier call at another
    // size must never leak into a later one.
    let (colour, depth, target, target_depth, w, h) = vga_pair();
    let mut workspace = LossWorkspace::default();
    // Full size, a crop whose width is no multiple of 8, then full size again with the images
    // swapped (other values everywhere).
    let cases = [
        (w, h, false),
        (203, 77, false),
        (w, h, true),
        (203, 77, true),
    ];
    for (cw, ch, swap) in cases {
        let (a, b) = if swap {
            (&target, &colour)
        } else {
            (&colour, &target)
        };
        let (rc, tc) = (crop(a, w, 3, cw, ch), crop(b, w, 3, cw, ch));
        let (rd, td) = (
            crop(&depth, w, 1, cw, ch),
            crop(&target_depth, w, 1, cw, ch),
        );
        let rendered = RgbdSlices {
            colour: &rc,
            depth: &rd,
        };
        let measured = RgbdSlices {
            colour: &tc,
            depth: &td,
        };
        let (mut gc, mut gd) = (vec![0.0; 3 * cw * ch], vec![0.0; cw * ch]);
        let fresh = loss_simd(rendered, measured, (cw, ch), &mut gc, &mut gd);
        // The kept call's outputs start as garbage: every entry must be written.
        let (mut kc, mut kd) = (vec![f32::NAN; 3 * cw * ch], vec![f32::NAN; cw * ch]);
        let kept = loss_simd_in(
            rendered,
            measured,
            (cw, ch),
            &mut kc,
            &mut kd,
            &mut workspace,
        );
        assert_eq!(fresh, kept, "{cw}x{ch} swapped {swap}: terms");
        assert!(
            gc.iter().zip(&kc).all(|(x, y)| x.to_bits() == y.to_bits()),
            "{cw}x{ch} swapped {swap}: colour gradient"
        );
        assert!(
            gd.iter().zip(&kd).all(|(x, y)| x.to_bits() == y.to_bits()),
            "{cw}x{ch} swapped {swap}: depth gradient"
        );
    }
}

#[test]
fn the_simd_loss_is_the_same_bit_for_bit_on_any_number_of_threads() {
    // The loss cuts the image into one band of rows per thread, and each band recomputes
    // the rows of SSIM planes either side of it: a band edge in a new place must change no
    // gradient entry and no term (README: thread count does not change a trajectory).
    // Sizes: VGA, and a crop whose height leaves a short last band and rows < 11 per band.
    let (colour, depth, target, target_depth, w, _) = vga_pair();
    for (cw, ch) in [(640, 480), (203, 37)] {
        let (rc, tc) = (crop(&colour, w, 3, cw, ch), crop(&target, w, 3, cw, ch));
        let (rd, td) = (
            crop(&depth, w, 1, cw, ch),
            crop(&target_depth, w, 1, cw, ch),
        );
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a thread pool");
            let (mut gc, mut gd) = (vec![f32::NAN; 3 * cw * ch], vec![f32::NAN; cw * ch]);
            let terms = pool.install(|| {
                loss_simd(
                    RgbdSlices {
                        colour: &rc,
                        depth: &rd,
                    },
                    RgbdSlices {
                        colour: &tc,
                        depth: &td,
                    },
                    (cw, ch),
                    &mut gc,
                    &mut gd,
                )
            });
            (terms, gc, gd)
        };
        let one = run(1);
        for threads in [2, 5, 16] {
            let many = run(threads);
            assert_eq!(one.0, many.0, "{cw}x{ch}, {threads} threads: terms");
            let same =
                |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
            assert!(
                same(&one.1, &many.1),
                "{cw}x{ch}, {threads} threads: colour gradient"
            );
            assert!(
                same(&one.2, &many.2),
                "{cw}x{ch}, {threads} threads: depth gradient"
            );
        }
    }
}

#[test]
fn identical_images_have_zero_loss_and_unit_ssim() {
    let (w, h) = (30, 20);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let colour: Vec<f32> = (0..3 * w * h).map(|_| rng.gen()).collect();
    let depth: Vec<f32> = (0..w * h).map(|_| rng.gen_range(0.5..4.0)).collect();
    let images = autonomy::splat::Images {
        width: w,
        height: h,
        colour: colour.clone(),
        depth: depth.clone(),
        silhouette: vec![1.0; w * h],
    };
    let (terms, grads) = mapping_loss(
        &images,
        Target {
            colour: &colour,
            depth: &depth,
        },
    );
    assert!((terms.ssim - 1.0).abs() < 1e-5, "SSIM {}", terms.ssim);
    assert!(terms.total().abs() < 1e-5, "loss {}", terms.total());
    assert!(grads.depth.iter().all(|g| *g == 0.0));
}

fn look_at(eye: Point3, target: Point3, k: Intrinsics) -> PinholeCamera {
    // Optical frame: z forward, y down (world z is up).
    let view = Isometry3::face_towards(&eye, &target, &-Vector3::z());
    PinholeCamera {
        intrinsics: k,
        world_from_camera: view,
    }
}

/// 40 Gaussians in a 1 m box around the origin, seen from around it.
fn ground_truth() -> (Gaussians, Vec<PinholeCamera>, PinholeCamera) {
    let mut rng = ChaCha8Rng::seed_from_u64(40);
    let mut g = Gaussians::default();
    for _ in 0..40 {
        g.push(
            [
                rng.gen_range(-0.5..0.5),
                rng.gen_range(-0.5..0.5),
                rng.gen_range(-0.5..0.5),
            ],
            rng.gen_range(0.05..0.15),
            rng.gen_range(0.5..0.95),
            [rng.gen(), rng.gen(), rng.gen()],
        );
    }
    let k = Intrinsics::from_fovy(50f64.to_radians(), 64, 48);
    let eye = |angle: f64, height: f64| Point3::new(3.0 * angle.cos(), 3.0 * angle.sin(), height);
    let views = [0.0, 0.5, 1.0, 1.5]
        .iter()
        .map(|a| look_at(eye(*a, 0.4), Point3::origin(), k))
        .collect();
    let held_out = look_at(eye(0.75, 0.2), Point3::origin(), k);
    (g, views, held_out)
}

#[test]
fn three_hundred_iterations_fit_a_perturbed_scene() {
    let (truth, views, held_out) = ground_truth();
    let targets: Vec<_> = views
        .iter()
        .map(|v| cpu::render(&truth, v).expect("render").images)
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    let mut g = truth.clone();
    for i in 0..g.len() {
        for a in 0..3 {
            g.means[i][a] += rng.gen_range(-0.005..0.005);
            g.colours[i][a] = (g.colours[i][a] + rng.gen_range(-0.15..0.15)).clamp(0.0, 1.0);
        }
        g.log_radii[i] += rng.gen_range(-0.1..0.1);
        g.logit_opacities[i] += rng.gen_range(-0.5..0.5);
    }
    let mut adam = Adam::new(LearningRates::default());
    let mut losses = Vec::new();
    for _ in 0..300 {
        let mut total = Gradients::zeros(g.len());
        let mut loss = 0.0;
        for (view, target) in views.iter().zip(&targets) {
            let render = cpu::render(&g, view).expect("render");
            let (terms, image_grads) = mapping_loss(
                &render.images,
                Target {
                    colour: &target.colour,
                    depth: &target.depth,
                },
            );
            loss += terms.total();
            total.accumulate(&cpu::backward(&render, &image_grads).expect("backward"));
        }
        adam.step(&mut g, &total);
        losses.push(loss);
    }
    let (first, last) = (losses[0], *losses.last().expect("300 losses"));
    assert!(last * 10.0 <= first, "loss went from {first} to {last}");
    let truth_view = cpu::render(&truth, &held_out).expect("render").images;
    let fitted_view = cpu::render(&g, &held_out).expect("render").images;
    let quality = psnr(&fitted_view.colour, &truth_view.colour);
    eprintln!("fit: loss {first:.4} -> {last:.5}, held-out PSNR {quality:.1} dB");
    assert!(
        quality >= 35.0,
        "held-out PSNR {quality:.1} dB (loss {first} -> {last})"
    );
}
