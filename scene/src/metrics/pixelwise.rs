//! The pixelwise metrics (MSE, RMSE, relMSE, PSNR), over the whole image or a mask, and
//! [`compare`], which bundles them with SSIM: the numbers every report starts from.

use super::{all_finite, check_same_shape, ssim, MetricsError, PSNR_PEAK, REL_MSE_EPS};
use crate::image::ImageRef;

/// Error of one test image against its reference. See the [module docs](super) for conventions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorMetrics {
    /// Pixels that entered the pixelwise metrics (finite in both images).
    pub pixels: usize,
    /// Test pixels with a NaN or ±inf channel (excluded; worst case in SSIM).
    pub non_finite: usize,
    /// Reference pixels with a NaN or ±inf channel (excluded; a broken reference).
    pub reference_non_finite: usize,
    /// Mean squared error over channels of finite pixels.
    pub mse: f64,
    /// `sqrt(mse)`.
    pub rmse: f64,
    /// Mean of `(x - y)² / (y² + REL_MSE_EPS)`.
    pub rel_mse: f64,
    /// `10·log10(PSNR_PEAK² / mse)`; `+inf` for identical images.
    pub psnr: f64,
    /// Mean SSIM of the clamped luminance, in `[-1, 1]` (1 = identical).
    pub ssim: f64,
}

/// Sums over the finite pixels selected by `select`.
#[derive(Default)]
struct ErrorSums {
    pixels: usize,
    samples: usize,
    non_finite: usize,
    reference_non_finite: usize,
    sq: f64,
    rel: f64,
}

impl ErrorSums {
    fn accumulate(
        test: ImageRef<'_>,
        reference: ImageRef<'_>,
        select: impl Fn(usize) -> bool,
    ) -> Self {
        let mut s = Self::default();
        for i in (0..test.pixel_count()).filter(|&i| select(i)) {
            let (x, y) = (test.pixel_at(i), reference.pixel_at(i));
            let (x_ok, y_ok) = (all_finite(x), all_finite(y));
            s.non_finite += usize::from(!x_ok);
            s.reference_non_finite += usize::from(!y_ok);
            if !(x_ok && y_ok) {
                continue;
            }
            s.pixels += 1;
            s.samples += x.len();
            for (&x, &y) in x.iter().zip(y) {
                let (x, y) = (f64::from(x), f64::from(y));
                let d2 = (x - y) * (x - y);
                s.sq += d2;
                s.rel += d2 / (y * y + REL_MSE_EPS);
            }
        }
        s
    }

    fn mse(&self) -> f64 {
        if self.samples == 0 {
            f64::NAN
        } else {
            self.sq / self.samples as f64
        }
    }

    fn rel_mse(&self) -> f64 {
        if self.samples == 0 {
            f64::NAN
        } else {
            self.rel / self.samples as f64
        }
    }
}

/// PSNR in dB of a mean squared error with peak [`PSNR_PEAK`]: `+inf` for 0, NaN for NaN.
pub fn psnr_from_mse(mse: f64) -> f64 {
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (PSNR_PEAK * PSNR_PEAK / mse).log10()
    }
}

/// All standard metrics of `test` against `reference` (same shape): MSE, RMSE, relMSE, PSNR and
/// SSIM, with non-finite pixels counted. FLIP is separate ([`flip`](super::flip)) because it
/// costs more.
pub fn compare(test: ImageRef<'_>, reference: ImageRef<'_>) -> Result<ErrorMetrics, MetricsError> {
    check_same_shape(test, reference)?;
    let sums = ErrorSums::accumulate(test, reference, |_| true);
    let mse = sums.mse();
    Ok(ErrorMetrics {
        pixels: sums.pixels,
        non_finite: sums.non_finite,
        reference_non_finite: sums.reference_non_finite,
        mse,
        rmse: mse.sqrt(),
        rel_mse: sums.rel_mse(),
        psnr: psnr_from_mse(mse),
        ssim: ssim(test, reference)?,
    })
}

/// relMSE of `test` against `reference` alone: [`compare`]'s without its SSIM, for images whose
/// other errors nobody reads (a denoiser's raw input).
pub fn rel_mse(test: ImageRef<'_>, reference: ImageRef<'_>) -> Result<f64, MetricsError> {
    check_same_shape(test, reference)?;
    Ok(ErrorSums::accumulate(test, reference, |_| true).rel_mse())
}

/// Error restricted to the pixels of a mask (moving or disoccluded regions).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaskedError {
    /// Masked pixels that entered the metrics (finite in both images).
    pub pixels: usize,
    /// Masked test pixels with a NaN or ±inf channel (excluded).
    pub non_finite: usize,
    /// Masked reference pixels with a NaN or ±inf channel (excluded).
    pub reference_non_finite: usize,
    /// Mean squared error over the masked finite pixels (NaN if there are none).
    pub mse: f64,
    /// `sqrt(mse)`.
    pub rmse: f64,
    /// relMSE over the masked finite pixels (NaN if there are none).
    pub rel_mse: f64,
}

/// MSE / RMSE / relMSE over the pixels where `mask` (one `bool` per pixel, row-major) is true.
///
/// `Ok(None)` when the mask selects no pixel, so an empty region is never reported as zero error.
pub fn masked_error(
    test: ImageRef<'_>,
    reference: ImageRef<'_>,
    mask: &[bool],
) -> Result<Option<MaskedError>, MetricsError> {
    check_same_shape(test, reference)?;
    if mask.len() != test.pixel_count() {
        return Err(MetricsError::LengthMismatch {
            expected: test.pixel_count(),
            actual: mask.len(),
        });
    }
    if !mask.contains(&true) {
        return Ok(None);
    }
    let sums = ErrorSums::accumulate(test, reference, |i| mask[i]);
    let mse = sums.mse();
    Ok(Some(MaskedError {
        pixels: sums.pixels,
        non_finite: sums.non_finite,
        reference_non_finite: sums.reference_non_finite,
        mse,
        rmse: mse.sqrt(),
        rel_mse: sums.rel_mse(),
    }))
}
