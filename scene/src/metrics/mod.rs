//! Error metrics of a test image against a ground-truth reference.
//!
//! Inputs are linear `f32` images ([`ImageRef`]): one channel for AO / shadow signals or RGB
//! radiance. Conventions, fixed here so every report in the project means the same thing:
//!
//! - **Pixelwise metrics** ([`ErrorMetrics::mse`], `rmse`, `rel_mse`, `psnr`) average over every
//!   channel of every *finite* pixel, on the raw linear values (no clamping, no tone mapping).
//! - **relMSE** is `mean((x - y)² / (y² + ε))` per channel with `ε =` [`REL_MSE_EPS`] `= 1e-2`, the
//!   value common in the Monte Carlo denoising literature; ε keeps near-black reference pixels from
//!   dominating. `x` is the test value, `y` the reference.
//! - **PSNR** is `10·log10(peak² / MSE)` with `peak =` [`PSNR_PEAK`] `= 1.0` (the range of AO /
//!   shadow signals; for HDR radiance it is only a log-scaled MSE). Identical images give
//!   `f64::INFINITY` — no cap; use [`psnr_from_mse`] of a mean MSE for sequence averages.
//! - **SSIM** is Wang et al.'s SSIM on luminance clamped to `[0,1]` (linear, not sRGB-encoded):
//!   11×11 Gaussian window with σ = 1.5, `C1 = (0.01)²`, `C2 = (0.03)²`, population (not sample)
//!   statistics, averaged over the pixels whose whole window lies in the image ("valid" region,
//!   as the reference MATLAB code and scikit-image do). See [`ssim`] for small images.
//! - **FLIP** ([`flip`], feature `flip`) is NVIDIA's LDR-FLIP on the clamped, sRGB-encoded 8-bit
//!   images at 67 pixels per degree, through the `nv-flip` crate; the mean of the error map.
//!
//! - **Error spectrum** ([`error_spectrum`]): the power of `test − reference` by spatial
//!   frequency, split at [`LOW_BAND`] cycles per pixel, and radially averaged.
//!
//! **Non-finite values** never poison a metric silently: a pixel whose test value has any NaN or
//! ±inf channel is counted in [`ErrorMetrics::non_finite`] (reference pixels in
//! `reference_non_finite`) and *excluded* from the pixelwise metrics, which are computed over the
//! remaining pixels (all NaN when none remain). SSIM and FLIP need a complete grid, so there a
//! non-finite test pixel is replaced by the worst case: the clamped value farthest from the
//! reference (0 or 1). Check `non_finite == 0` before trusting a comparison.

mod noise;
#[cfg(feature = "flip")]
mod perceptual;
mod pixelwise;
mod sequence;
mod spectrum;
mod structural;
#[cfg(test)]
mod tests;

pub use noise::{reference_rel_noise, standard_error, StandardError};
#[cfg(feature = "flip")]
pub use perceptual::{flip, flip_map};
pub use pixelwise::{compare, masked_error, psnr_from_mse, rel_mse, ErrorMetrics, MaskedError};
pub use sequence::{FrameMetrics, SequenceMetrics, SequenceSummary};
pub use spectrum::{error_spectrum, ErrorSpectrum, LOW_BAND, RADIAL_BINS};
pub use structural::{luminance, ssim};

use crate::image::ImageRef;
use std::fmt;

/// ε of relMSE: `(x - y)² / (y² + ε)`. 1e-2 as commonly used for denoiser evaluation.
pub const REL_MSE_EPS: f64 = 1e-2;

/// Peak signal value of PSNR: 1.0, the range of AO / shadow visibility signals.
pub const PSNR_PEAK: f64 = 1.0;

/// SSIM Gaussian window size (pixels per side).
pub const SSIM_WINDOW: usize = 11;

/// SSIM Gaussian window standard deviation in pixels.
pub const SSIM_SIGMA: f64 = 1.5;

/// SSIM luminance stabiliser `C1 = (K1·L)²` with `K1 = 0.01`, `L = 1`.
pub const SSIM_C1: f64 = 0.01 * 0.01;

/// SSIM contrast stabiliser `C2 = (K2·L)²` with `K2 = 0.03`, `L = 1`.
pub const SSIM_C2: f64 = 0.03 * 0.03;

/// Rec. 709 / sRGB luminance weights of linear RGB, used to reduce RGB to one channel for SSIM.
pub const LUMINANCE_WEIGHTS: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// Why two images (or an image and a mask) cannot be compared.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MetricsError {
    /// Test and reference differ in width, height or channel count (`(w, h, c)` each).
    ShapeMismatch {
        /// Shape of the test image.
        test: (usize, usize, usize),
        /// Shape of the reference.
        reference: (usize, usize, usize),
    },
    /// A mask or per-sample buffer has the wrong length.
    LengthMismatch {
        /// Required length.
        expected: usize,
        /// Length given.
        actual: usize,
    },
    /// The metric is not defined for this many channels (e.g. FLIP on 2 channels).
    UnsupportedChannels(usize),
    /// The standard error needs at least two samples.
    TooFewSamples(u64),
}

impl fmt::Display for MetricsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::ShapeMismatch { test, reference } => write!(
                f,
                "test image is {}x{}x{} but the reference is {}x{}x{}",
                test.0, test.1, test.2, reference.0, reference.1, reference.2
            ),
            Self::LengthMismatch { expected, actual } => {
                write!(f, "buffer has {actual} entries, expected {expected}")
            }
            Self::UnsupportedChannels(c) => write!(f, "metric not defined for {c} channel(s)"),
            Self::TooFewSamples(n) => write!(f, "standard error needs at least 2 samples, got {n}"),
        }
    }
}

impl std::error::Error for MetricsError {}

fn shape(image: ImageRef<'_>) -> (usize, usize, usize) {
    (image.width(), image.height(), image.channels())
}

fn check_same_shape(test: ImageRef<'_>, reference: ImageRef<'_>) -> Result<(), MetricsError> {
    if shape(test) != shape(reference) {
        return Err(MetricsError::ShapeMismatch {
            test: shape(test),
            reference: shape(reference),
        });
    }
    Ok(())
}

fn all_finite(pixel: &[f32]) -> bool {
    pixel.iter().all(|v| v.is_finite())
}
