//! SSIM with an 11x11 Gaussian window (sigma 1.5), zero-padded like conv2d(padding=5), and its
//! gradient with respect to the first image. Generic so tests can run it in f64.

use num_traits::Float;

/// Window half-width: 11 taps.
pub(crate) const RADIUS: usize = 5;
/// Window standard deviation, pixels.
const SIGMA: f32 = 1.5;
pub(crate) const C1: f32 = 0.01 * 0.01;
pub(crate) const C2: f32 = 0.03 * 0.03;

/// Scalars SSIM runs on.
pub trait Real: Float + From<f32> + Send + Sync + std::iter::Sum {}
impl Real for f32 {}
impl Real for f64 {}

pub(crate) fn window<F: Real>() -> [F; 2 * RADIUS + 1] {
    let raw: [f32; 2 * RADIUS + 1] = std::array::from_fn(|i| {
        (-((i as f32 - RADIUS as f32).powi(2)) / (2.0 * SIGMA * SIGMA)).exp()
    });
    let sum: f32 = raw.iter().sum();
    raw.map(|v| <F as From<f32>>::from(v / sum))
}

/// Separable zero-padded Gaussian blur of a W x H image. The window is symmetric, so this
/// operator is its own adjoint: the same call back-propagates through it.
fn blur<F: Real>(image: &[F], w: usize, h: usize, scratch: &mut Vec<F>) -> Vec<F> {
    let k = window::<F>();
    scratch.clear();
    scratch.resize(w * h, F::zero());
    let mut out = vec![F::zero(); w * h];
    // Rows: out[x] += k[t] * in[x + t - R], for the x where the source exists.
    for y in 0..h {
        let src = &image[y * w..(y + 1) * w];
        let dst = &mut scratch[y * w..(y + 1) * w];
        for (t, &kt) in k.iter().enumerate() {
            let shift = t as isize - RADIUS as isize;
            let (d0, s0) = if shift < 0 {
                ((-shift) as usize, 0)
            } else {
                (0, shift as usize)
            };
            let n = w.saturating_sub(d0.max(s0));
            for (d, s) in dst[d0..d0 + n].iter_mut().zip(&src[s0..s0 + n]) {
                *d = *d + kt * *s;
            }
        }
    }
    // Columns, whole rows at a time so the inner loop is contiguous.
    for y in 0..h {
        for (t, &kt) in k.iter().enumerate() {
            let sy = y as isize + t as isize - RADIUS as isize;
            if sy < 0 || sy >= h as isize {
                continue;
            }
            let sy = sy as usize;
            let (dst, src) = (y * w, sy * w);
            for x in 0..w {
                out[dst + x] = out[dst + x] + kt * scratch[src + x];
            }
        }
    }
    out
}

/// Mean SSIM of single-channel images `x` (rendered) and `y` (target), W x H, and
/// `d mean / d x` scaled by `scale` added into `grad`.
pub fn ssim_channel<F: Real>(x: &[F], y: &[F], w: usize, h: usize, scale: F, grad: &mut [F]) -> F {
    let n = w * h;
    let mut scratch = Vec::new();
    let mut blurred = |img: &[F]| blur(img, w, h, &mut scratch);
    let mu_x = blurred(x);
    let mu_y = blurred(y);
    let xx: Vec<F> = x.iter().map(|v| *v * *v).collect();
    let yy: Vec<F> = y.iter().map(|v| *v * *v).collect();
    let xy: Vec<F> = x.iter().zip(y).map(|(a, b)| *a * *b).collect();
    let (e_xx, e_yy, e_xy) = (blurred(&xx), blurred(&yy), blurred(&xy));
    let (c1, c2) = (<F as From<f32>>::from(C1), <F as From<f32>>::from(C2));
    let two = <F as From<f32>>::from(2.0);
    let inv_n = F::one() / <F as From<f32>>::from(n as f32);
    let mut total = F::zero();
    // Per-pixel d S / d (mu_x, E_xx, E_xy), already divided by n and scaled.
    let (mut d_mu, mut d_exx, mut d_exy) =
        (vec![F::zero(); n], vec![F::zero(); n], vec![F::zero(); n]);
    for p in 0..n {
        let (mx, my) = (mu_x[p], mu_y[p]);
        let var_x = e_xx[p] - mx * mx;
        let var_y = e_yy[p] - my * my;
        let cov = e_xy[p] - mx * my;
        let (a1, a2) = (two * mx * my + c1, two * cov + c2);
        let (b1, b2) = (mx * mx + my * my + c1, var_x + var_y + c2);
        let s = a1 * a2 / (b1 * b2);
        total = total + s;
        let ds_dmu = two * my * a2 / (b1 * b2) - two * mx * s / b1;
        let ds_dvar = -s / b2;
        let ds_dcov = two * a1 / (b1 * b2);
        let k = scale * inv_n;
        // mu_x also enters var_x = E_xx - mu_x^2 and cov = E_xy - mu_x mu_y.
        d_mu[p] = k * (ds_dmu - two * mx * ds_dvar - my * ds_dcov);
        d_exx[p] = k * ds_dvar;
        d_exy[p] = k * ds_dcov;
    }
    let (g_mu, g_exx, g_exy) = (blurred(&d_mu), blurred(&d_exx), blurred(&d_exy));
    for p in 0..n {
        grad[p] = grad[p] + g_mu[p] + two * x[p] * g_exx[p] + y[p] * g_exy[p];
    }
    total * inv_n
}
