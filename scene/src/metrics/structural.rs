//! SSIM (structural similarity) on clamped luminance: a Gaussian-window blur and the "valid"
//! region average, kept apart from the pixelwise metrics because it needs the whole grid.

use super::{
    all_finite, check_same_shape, MetricsError, LUMINANCE_WEIGHTS, SSIM_C1, SSIM_C2, SSIM_SIGMA,
    SSIM_WINDOW,
};
use crate::image::ImageRef;

/// Linear luminance of one pixel: the value itself for one channel, the mean for two, Rec. 709
/// ([`LUMINANCE_WEIGHTS`]) of the first three otherwise (a fourth, alpha, is ignored).
pub fn luminance(pixel: &[f32]) -> f32 {
    match pixel.len() {
        1 => pixel[0],
        2 => 0.5 * (pixel[0] + pixel[1]),
        _ => {
            LUMINANCE_WEIGHTS[0] * pixel[0]
                + LUMINANCE_WEIGHTS[1] * pixel[1]
                + LUMINANCE_WEIGHTS[2] * pixel[2]
        }
    }
}

fn clamp01(v: f32) -> f64 {
    if v.is_nan() {
        0.0
    } else {
        f64::from(v.clamp(0.0, 1.0))
    }
}

/// Normalised 1-D Gaussian weights of the SSIM window.
fn ssim_weights() -> [f64; SSIM_WINDOW] {
    let r = (SSIM_WINDOW / 2) as f64;
    let mut w = [0.0; SSIM_WINDOW];
    for (i, w) in w.iter_mut().enumerate() {
        let d = i as f64 - r;
        *w = (-d * d / (2.0 * SSIM_SIGMA * SSIM_SIGMA)).exp();
    }
    let sum: f64 = w.iter().sum();
    w.map(|v| v / sum)
}

/// Separable Gaussian blur; near borders the window is truncated and renormalised. Only the
/// interior ("valid") values are averaged by [`ssim`] unless the image is smaller than the window.
fn blur(src: &[f64], width: usize, height: usize, w: &[f64; SSIM_WINDOW]) -> Vec<f64> {
    let r = SSIM_WINDOW / 2;
    let pass = |src: &[f64], len: usize, count: usize, at: &dyn Fn(usize, usize) -> usize| {
        let mut out = vec![0.0; src.len()];
        for line in 0..count {
            for i in 0..len {
                let (lo, hi) = (i.saturating_sub(r), (i + r).min(len - 1));
                let (mut acc, mut norm) = (0.0, 0.0);
                for j in lo..=hi {
                    let wj = w[j + r - i];
                    acc += wj * src[at(line, j)];
                    norm += wj;
                }
                out[at(line, i)] = acc / norm;
            }
        }
        out
    };
    let horizontal = pass(src, width, height, &|y, x| y * width + x);
    pass(&horizontal, height, width, &|x, y| y * width + x)
}

/// Range of positions along an axis whose full window fits, or the whole axis if none does.
fn valid_range(len: usize) -> std::ops::Range<usize> {
    let r = SSIM_WINDOW / 2;
    if len >= SSIM_WINDOW {
        r..len - r
    } else {
        0..len
    }
}

/// Mean SSIM of the clamped `[0,1]` luminance (see the [module docs](super)).
///
/// Per-pixel SSIM is averaged over the "valid" region, the pixels at least 5 from every border.
/// Along an axis shorter than the 11-pixel window the whole axis is averaged instead, with the
/// window truncated and renormalised at the border, so tiny test images still get a value.
/// Non-finite test pixels count as the worst case (0 or 1, whichever is farther from the
/// reference); non-finite reference values are clamped (NaN → 0).
pub fn ssim(test: ImageRef<'_>, reference: ImageRef<'_>) -> Result<f64, MetricsError> {
    check_same_shape(test, reference)?;
    let (width, height) = (test.width(), test.height());
    let n = test.pixel_count();
    let mut x = Vec::with_capacity(n);
    let mut y = Vec::with_capacity(n);
    for i in 0..n {
        let yp = reference.pixel_at(i);
        let yl = clamp01(luminance(yp));
        let xp = test.pixel_at(i);
        let xl = if all_finite(xp) {
            clamp01(luminance(xp))
        } else if yl >= 0.5 {
            0.0
        } else {
            1.0
        };
        x.push(xl);
        y.push(yl);
    }
    let w = ssim_weights();
    let xx: Vec<f64> = x.iter().map(|v| v * v).collect();
    let yy: Vec<f64> = y.iter().map(|v| v * v).collect();
    let xy: Vec<f64> = x.iter().zip(&y).map(|(a, b)| a * b).collect();
    let mu_x = blur(&x, width, height, &w);
    let mu_y = blur(&y, width, height, &w);
    let e_xx = blur(&xx, width, height, &w);
    let e_yy = blur(&yy, width, height, &w);
    let e_xy = blur(&xy, width, height, &w);
    let (mut sum, mut count) = (0.0, 0usize);
    for py in valid_range(height) {
        for px in valid_range(width) {
            let i = py * width + px;
            let (mx, my) = (mu_x[i], mu_y[i]);
            let vx = e_xx[i] - mx * mx;
            let vy = e_yy[i] - my * my;
            let cov = e_xy[i] - mx * my;
            let num = (2.0 * mx * my + SSIM_C1) * (2.0 * cov + SSIM_C2);
            let den = (mx * mx + my * my + SSIM_C1) * (vx + vy + SSIM_C2);
            sum += num / den;
            count += 1;
        }
    }
    Ok(sum / count as f64)
}
