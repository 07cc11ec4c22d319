//! Monte Carlo standard error of an estimate from its running moments: how noisy a reference is,
//! so that a test image's error can be judged against the reference's own.

use super::{MetricsError, REL_MSE_EPS};
use crate::image::ImageRef;

/// Noise level of a Monte Carlo estimate (e.g. a reference render), from its accumulators.
#[derive(Debug, Clone, PartialEq)]
pub struct StandardError {
    /// Standard error of the mean per sample (same layout as the inputs); NaN where an input
    /// was non-finite.
    pub per_sample: Vec<f32>,
    /// Average standard error over the finite entries.
    pub mean: f64,
    /// Root of the mean variance of the mean over finite entries: the RMSE this estimate is
    /// expected to have against the true image, comparable with
    /// [`ErrorMetrics::rmse`](super::ErrorMetrics::rmse).
    pub rms: f64,
    /// Entries skipped because an input was non-finite.
    pub non_finite: usize,
}

/// Standard error of the mean per sample from running `mean` and `mean_sq` (mean of squares)
/// over `samples` samples: `sqrt(max(0, mean_sq - mean²) / (samples - 1))`, i.e. the unbiased
/// sample variance divided by `samples`. Computed in `f64` to limit cancellation.
pub fn standard_error<T: Copy + Into<f64>>(
    mean: &[T],
    mean_sq: &[T],
    samples: u64,
) -> Result<StandardError, MetricsError> {
    if mean.len() != mean_sq.len() {
        return Err(MetricsError::LengthMismatch {
            expected: mean.len(),
            actual: mean_sq.len(),
        });
    }
    if samples < 2 {
        return Err(MetricsError::TooFewSamples(samples));
    }
    let denom = (samples - 1) as f64;
    let (mut se_sum, mut var_sum, mut n, mut non_finite) = (0.0, 0.0, 0usize, 0usize);
    let per_sample = mean
        .iter()
        .zip(mean_sq)
        .map(|(&m, &m2)| {
            let (m, m2): (f64, f64) = (m.into(), m2.into());
            if !(m.is_finite() && m2.is_finite()) {
                non_finite += 1;
                return f32::NAN;
            }
            let var_of_mean = (m2 - m * m).max(0.0) / denom;
            se_sum += var_of_mean.sqrt();
            var_sum += var_of_mean;
            n += 1;
            var_of_mean.sqrt() as f32
        })
        .collect();
    let (mean, rms) = if n == 0 {
        (f64::NAN, f64::NAN)
    } else {
        (se_sum / n as f64, (var_sum / n as f64).sqrt())
    };
    Ok(StandardError {
        per_sample,
        mean,
        rms,
        non_finite,
    })
}

/// The relMSE a reference's own noise adds to the error of any test image measured against it
/// ([`ErrorMetrics::rel_mse`](super::ErrorMetrics::rel_mse)): the mean over finite texels of
/// `se² / (y² + ε)`, `y` the reference and `se` its standard error (`stderr`, one channel or as
/// many as the reference). For a test image `x` whose noise is independent of the reference's,
/// `E[(x − y)²] = E[(x − t)²] + se²` against the converged image `t`, so a relMSE less this
/// estimates the error against `t`: at a few hundred samples per pixel the reference's noise is
/// a sizeable part of a good denoiser's relMSE. With `mask` (one flag per pixel) only the
/// pixels it sets count, as [`masked_error`](super::masked_error)'s relMSE.
pub fn reference_rel_noise(
    reference: ImageRef<'_>,
    stderr: ImageRef<'_>,
    mask: Option<&[bool]>,
) -> Result<f64, MetricsError> {
    let c = reference.channels();
    let sc = stderr.channels();
    if (reference.width(), reference.height()) != (stderr.width(), stderr.height())
        || !(sc == 1 || sc == c)
    {
        return Err(MetricsError::ShapeMismatch {
            test: (stderr.width(), stderr.height(), sc),
            reference: (reference.width(), reference.height(), c),
        });
    }
    if let Some(m) = mask {
        if m.len() != reference.pixel_count() {
            return Err(MetricsError::LengthMismatch {
                expected: reference.pixel_count(),
                actual: m.len(),
            });
        }
    }
    let (mut sum, mut n) = (0.0f64, 0usize);
    for i in 0..reference.pixel_count() {
        if mask.is_some_and(|m| !m[i]) {
            continue;
        }
        let (y, se) = (reference.pixel_at(i), stderr.pixel_at(i));
        for (k, &y) in y.iter().enumerate() {
            let (y, se) = (f64::from(y), f64::from(se[k.min(sc - 1)]));
            if y.is_finite() && se.is_finite() {
                sum += se * se / (y * y + REL_MSE_EPS);
                n += 1;
            }
        }
    }
    Ok(if n == 0 { f64::NAN } else { sum / n as f64 })
}
