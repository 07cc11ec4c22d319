//! Where in spatial frequency the error of a test image lies: the power spectrum of
//! `test − reference`. White sampling noise spreads its power evenly; blue-noise sampling moves it
//! to high frequencies, which a spatial filter removes. What a denoiser leaves at low frequencies
//! is the blotchy error the eye sees.
//!
//! Conventions: the error image is the mean over channels of `test − reference` per pixel (0 where
//! either is not finite); `E(k)` is its 2D DFT (`rustfft`, no window: the images are compared
//! whole); the power of frequency `k` is `|E(k)|² / N` for `N` pixels, so by Parseval the powers
//! average to the error's MSE and white noise of variance `σ²` has a flat spectrum at `σ²`. A
//! frequency's radius is `√(fx² + fy²)` in cycles per pixel, `fx, fy ∈ [−½, ½)`.

use super::{check_same_shape, MetricsError};
use crate::image::ImageRef;
use rustfft::{num_complex::Complex, FftPlanner};

/// Upper edge of the low band in cycles per pixel (a quarter of Nyquist): structures wider than
/// 8 pixels. White noise puts `π/64 ≈ 4.9%` of its power there.
pub const LOW_BAND: f64 = 0.125;

/// Radial bins of [`ErrorSpectrum::radial`], evenly spaced in radius from 0 to `√½`.
pub const RADIAL_BINS: usize = 16;

/// The error's power by frequency band, in MSE units (`dc + low + high` is the error's MSE).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ErrorSpectrum {
    /// Power of frequency 0: the squared mean error (bias).
    pub dc: f64,
    /// Power of the nonzero frequencies below [`LOW_BAND`].
    pub low: f64,
    /// Power at and above [`LOW_BAND`].
    pub high: f64,
    /// Radially averaged power (mean of `|E(k)|² / N` over the frequencies of each bin; 0 for an
    /// empty bin), DC excluded.
    pub radial: Vec<f64>,
}

impl ErrorSpectrum {
    /// The field-wise mean of `spectra` (frames or parts of a sequence); all zero when empty.
    pub fn mean<'a>(spectra: impl IntoIterator<Item = &'a ErrorSpectrum>) -> ErrorSpectrum {
        let mut m = ErrorSpectrum {
            radial: vec![0.0; RADIAL_BINS],
            ..ErrorSpectrum::default()
        };
        let mut count = 0.0;
        for s in spectra {
            m.dc += s.dc;
            m.low += s.low;
            m.high += s.high;
            for (a, b) in m.radial.iter_mut().zip(&s.radial) {
                *a += b;
            }
            count += 1.0;
        }
        if count > 0.0 {
            m.dc /= count;
            m.low /= count;
            m.high /= count;
            m.radial.iter_mut().for_each(|a| *a /= count);
        }
        m
    }

    /// Share of the error's (non-DC) power below [`LOW_BAND`]; NaN for an error without any.
    pub fn low_fraction(&self) -> f64 {
        let total = self.low + self.high;
        if total > 0.0 {
            self.low / total
        } else {
            f64::NAN
        }
    }
}

/// The power spectrum of `test − reference` (see the module docs).
pub fn error_spectrum(
    test: ImageRef<'_>,
    reference: ImageRef<'_>,
) -> Result<ErrorSpectrum, MetricsError> {
    check_same_shape(test, reference)?;
    let (w, h) = (test.width(), test.height());
    let n = w * h;
    let mut e: Vec<Complex<f64>> = (0..n)
        .map(|i| {
            let (t, r) = (test.pixel_at(i), reference.pixel_at(i));
            let d: f64 = t.iter().zip(r).map(|(a, b)| (a - b) as f64).sum();
            let d = d / t.len().max(1) as f64;
            Complex::new(if d.is_finite() { d } else { 0.0 }, 0.0)
        })
        .collect();
    let mut spectrum = ErrorSpectrum {
        radial: vec![0.0; RADIAL_BINS],
        ..ErrorSpectrum::default()
    };
    if n == 0 {
        return Ok(spectrum);
    }
    let mut planner = FftPlanner::new();
    let rows = planner.plan_fft_forward(w);
    for row in e.chunks_exact_mut(w) {
        rows.process(row);
    }
    let cols = planner.plan_fft_forward(h);
    let mut column = vec![Complex::new(0.0, 0.0); h];
    for x in 0..w {
        for (y, c) in column.iter_mut().enumerate() {
            *c = e[y * w + x];
        }
        cols.process(&mut column);
        for (y, c) in column.iter().enumerate() {
            e[y * w + x] = *c;
        }
    }
    let freq = |k: usize, len: usize| k.min(len - k) as f64 / len as f64;
    let mut counts = vec![0usize; RADIAL_BINS];
    for y in 0..h {
        for x in 0..w {
            let power = e[y * w + x].norm_sqr() / n as f64;
            if x == 0 && y == 0 {
                spectrum.dc = power / n as f64;
                continue;
            }
            let r = freq(x, w).hypot(freq(y, h));
            if r < LOW_BAND {
                spectrum.low += power / n as f64;
            } else {
                spectrum.high += power / n as f64;
            }
            let bin = ((r / 0.5f64.sqrt() * RADIAL_BINS as f64) as usize).min(RADIAL_BINS - 1);
            spectrum.radial[bin] += power;
            counts[bin] += 1;
        }
    }
    for (p, c) in spectrum.radial.iter_mut().zip(counts) {
        if c > 0 {
            *p /= c as f64;
        }
    }
    Ok(spectrum)
}
