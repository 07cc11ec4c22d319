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
//! **Non-finite values** never poison a metric silently: a pixel whose test value has any NaN or
//! ±inf channel is counted in [`ErrorMetrics::non_finite`] (reference pixels in
//! `reference_non_finite`) and *excluded* from the pixelwise metrics, which are computed over the
//! remaining pixels (all NaN when none remain). SSIM and FLIP need a complete grid, so there a
//! non-finite test pixel is replaced by the worst case: the clamped value farthest from the
//! reference (0 or 1). Check `non_finite == 0` before trusting a comparison.

#[cfg(feature = "flip")]
use crate::image::Image;
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

/// Error of one test image against its reference. See the [module docs](self) for conventions.
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
/// SSIM, with non-finite pixels counted. FLIP is separate ([`flip`]) because it costs more.
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

// ---------------------------------------------------------------------------------------------
// SSIM
// ---------------------------------------------------------------------------------------------

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

/// Mean SSIM of the clamped `[0,1]` luminance (see the [module docs](self)).
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

// ---------------------------------------------------------------------------------------------
// FLIP
// ---------------------------------------------------------------------------------------------

/// Converts an image to tightly packed sRGB8 RGB for FLIP (grey replicated for one channel).
/// `worst_against`: replace non-finite pixels by the byte farthest from that image's byte.
#[cfg(feature = "flip")]
fn flip_rgb8(image: ImageRef<'_>, worst_against: Option<&[u8]>) -> Result<Vec<u8>, MetricsError> {
    use crate::image::srgb8;
    let c = image.channels();
    if c == 2 {
        return Err(MetricsError::UnsupportedChannels(c));
    }
    let mut out = Vec::with_capacity(image.pixel_count() * 3);
    for i in 0..image.pixel_count() {
        let p = image.pixel_at(i);
        let rgb = if c == 1 {
            [p[0]; 3]
        } else {
            [p[0], p[1], p[2]]
        };
        match worst_against {
            Some(reference) if !all_finite(p) => {
                out.extend((0..3).map(|k| if reference[i * 3 + k] >= 128 { 0 } else { 255 }));
            }
            _ => out.extend(rgb.map(srgb8)),
        }
    }
    Ok(out)
}

/// Per-pixel LDR-FLIP error map (one channel, `[0,1]`) of `test` against `reference`, both
/// clamped and sRGB-encoded to 8 bits first. `pixels_per_degree`: viewing condition, 67 for the
/// FLIP paper's default (`nv_flip::DEFAULT_PIXELS_PER_DEGREE`). Useful as a heatmap overlay.
#[cfg(feature = "flip")]
pub fn flip_map(
    test: ImageRef<'_>,
    reference: ImageRef<'_>,
    pixels_per_degree: f32,
) -> Result<Image, MetricsError> {
    check_same_shape(test, reference)?;
    let too_big = || MetricsError::UnsupportedChannels(test.channels());
    let w = u32::try_from(test.width()).map_err(|_| too_big())?;
    let h = u32::try_from(test.height()).map_err(|_| too_big())?;
    let reference_bytes = flip_rgb8(reference, None)?;
    let test_bytes = flip_rgb8(test, Some(&reference_bytes))?;
    let reference_image = nv_flip::FlipImageRgb8::with_data(w, h, &reference_bytes);
    let test_image = nv_flip::FlipImageRgb8::with_data(w, h, &test_bytes);
    let map = nv_flip::flip(reference_image, test_image, pixels_per_degree);
    Ok(Image::new(test.width(), test.height(), 1, map.to_vec())
        .expect("FLIP map has the image's shape"))
}

/// Mean LDR-FLIP error (in `[0,1]`, 0 = identical) at the default 67 pixels per degree; the
/// single FLIP number the FLIP authors recommend reporting. See [`flip_map`].
#[cfg(feature = "flip")]
pub fn flip(test: ImageRef<'_>, reference: ImageRef<'_>) -> Result<f64, MetricsError> {
    let map = flip_map(test, reference, nv_flip::DEFAULT_PIXELS_PER_DEGREE)?;
    Ok(map.data().iter().map(|&v| f64::from(v)).sum::<f64>() / map.data().len() as f64)
}

// ---------------------------------------------------------------------------------------------
// Sequences
// ---------------------------------------------------------------------------------------------

/// Metrics of one frame of a sequence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameMetrics {
    /// Frame index within the sequence (0-based, in push order).
    pub frame: usize,
    /// The frame's own error.
    pub metrics: ErrorMetrics,
    /// Temporal error against the previous frame, `mean |e_t - e_{t-1}|` with `e = test - ref`
    /// over samples finite in both frames; `None` for the first frame.
    pub temporal: Option<f64>,
    /// Error restricted to the frame's mask, if one was given and it selected any pixel.
    pub masked: Option<MaskedError>,
}

/// Whole-sequence averages of [`FrameMetrics`].
///
/// Means are over frames whose value is not NaN (a frame with no finite pixel is skipped; its
/// pixels still show in `non_finite`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SequenceSummary {
    /// Frames pushed.
    pub frames: usize,
    /// Mean of per-frame MSE.
    pub mean_mse: f64,
    /// Mean of per-frame RMSE.
    pub mean_rmse: f64,
    /// Mean of per-frame relMSE.
    pub mean_rel_mse: f64,
    /// PSNR of `mean_mse` (per-frame PSNRs may be infinite, so they are not averaged).
    pub psnr_of_mean_mse: f64,
    /// Mean of per-frame SSIM.
    pub mean_ssim: f64,
    /// Temporal error (flicker): mean over frames t ≥ 1 of the per-frame temporal error.
    /// `None` for fewer than two frames.
    pub temporal: Option<f64>,
    /// Mean masked relMSE over frames whose mask selected pixels; `None` if none did.
    pub mean_masked_rel_mse: Option<f64>,
    /// Mean masked RMSE over the same frames.
    pub mean_masked_rmse: Option<f64>,
    /// Frames that contributed a masked error.
    pub masked_frames: usize,
    /// Non-finite test pixels over all frames.
    pub non_finite: usize,
    /// Non-finite reference pixels over all frames.
    pub reference_non_finite: usize,
}

/// Accumulates metrics of an image sequence frame by frame, including the temporal error.
///
/// The temporal error measures flicker that per-frame metrics miss: a constant bias is
/// temporally stable (error 0) while an error that changes from frame to frame is not.
#[derive(Debug, Clone, Default)]
pub struct SequenceMetrics {
    shape: Option<(usize, usize, usize)>,
    /// Previous frame's `test - reference` per sample, NaN where either was non-finite.
    previous_error: Vec<f32>,
    frames: Vec<FrameMetrics>,
}

impl SequenceMetrics {
    /// An empty sequence.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds the next frame. `mask` (one `bool` per pixel) selects pixels for
    /// [`FrameMetrics::masked`]. All frames must have the same shape.
    pub fn push(
        &mut self,
        test: ImageRef<'_>,
        reference: ImageRef<'_>,
        mask: Option<&[bool]>,
    ) -> Result<&FrameMetrics, MetricsError> {
        check_same_shape(test, reference)?;
        if let Some(s) = self.shape {
            if s != shape(test) {
                return Err(MetricsError::ShapeMismatch {
                    test: shape(test),
                    reference: s,
                });
            }
        }
        let masked = match mask {
            Some(mask) => masked_error(test, reference, mask)?,
            None => None,
        };
        let metrics = compare(test, reference)?;
        let c = test.channels();
        let error: Vec<f32> = (0..test.pixel_count())
            .flat_map(|i| {
                let (x, y) = (test.pixel_at(i), reference.pixel_at(i));
                let ok = all_finite(x) && all_finite(y);
                (0..c).map(move |k| if ok { x[k] - y[k] } else { f32::NAN })
            })
            .collect();
        let temporal = (!self.frames.is_empty()).then(|| {
            let (mut sum, mut count) = (0.0f64, 0usize);
            for (&e, &p) in error.iter().zip(&self.previous_error) {
                if e.is_finite() && p.is_finite() {
                    sum += (f64::from(e) - f64::from(p)).abs();
                    count += 1;
                }
            }
            if count == 0 {
                f64::NAN
            } else {
                sum / count as f64
            }
        });
        self.shape = Some(shape(test));
        self.previous_error = error;
        self.frames.push(FrameMetrics {
            frame: self.frames.len(),
            metrics,
            temporal,
            masked,
        });
        Ok(self.frames.last().expect("just pushed"))
    }

    /// Per-frame metrics so far.
    pub fn frames(&self) -> &[FrameMetrics] {
        &self.frames
    }

    /// Whole-sequence averages so far.
    pub fn summary(&self) -> SequenceSummary {
        fn mean(values: impl Iterator<Item = f64>) -> Option<f64> {
            let (mut sum, mut n) = (0.0, 0usize);
            for v in values.filter(|v| !v.is_nan()) {
                sum += v;
                n += 1;
            }
            (n > 0).then(|| sum / n as f64)
        }
        let f = &self.frames;
        let mean_mse = mean(f.iter().map(|m| m.metrics.mse)).unwrap_or(f64::NAN);
        SequenceSummary {
            frames: f.len(),
            mean_mse,
            mean_rmse: mean(f.iter().map(|m| m.metrics.rmse)).unwrap_or(f64::NAN),
            mean_rel_mse: mean(f.iter().map(|m| m.metrics.rel_mse)).unwrap_or(f64::NAN),
            psnr_of_mean_mse: psnr_from_mse(mean_mse),
            mean_ssim: mean(f.iter().map(|m| m.metrics.ssim)).unwrap_or(f64::NAN),
            temporal: mean(f.iter().filter_map(|m| m.temporal)),
            mean_masked_rel_mse: mean(f.iter().filter_map(|m| m.masked.map(|e| e.rel_mse))),
            mean_masked_rmse: mean(f.iter().filter_map(|m| m.masked.map(|e| e.rmse))),
            masked_frames: f.iter().filter(|m| m.masked.is_some()).count(),
            non_finite: f.iter().map(|m| m.metrics.non_finite).sum(),
            reference_non_finite: f.iter().map(|m| m.metrics.reference_non_finite).sum(),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Monte Carlo standard error
// ---------------------------------------------------------------------------------------------

/// Noise level of a Monte Carlo estimate (e.g. a reference render), from its accumulators.
#[derive(Debug, Clone, PartialEq)]
pub struct StandardError {
    /// Standard error of the mean per sample (same layout as the inputs); NaN where an input
    /// was non-finite.
    pub per_sample: Vec<f32>,
    /// Average standard error over the finite entries.
    pub mean: f64,
    /// Root of the mean variance of the mean over finite entries: the RMSE this estimate is
    /// expected to have against the true image, comparable with [`ErrorMetrics::rmse`].
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;

    fn img(w: usize, h: usize, c: usize, data: Vec<f32>) -> Image {
        Image::new(w, h, c, data).unwrap()
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    /// Deterministic test pattern, exactly reproducible in other tools (small rationals).
    fn pattern(w: usize, h: usize) -> (Image, Image) {
        let mut x = Vec::new();
        let mut y = Vec::new();
        for i in 0..h {
            for j in 0..w {
                let r = ((i * 73 + j * 151) % 97) as f32 / 96.0;
                let n = (((i * 31 + j * 17) % 13) as f32 - 6.0) / 60.0;
                y.push(r);
                x.push((r + n).clamp(0.0, 1.0));
            }
        }
        (img(w, h, 1, x), img(w, h, 1, y))
    }

    #[test]
    fn identical_images() {
        let (_, y) = pattern(16, 12);
        let m = compare(y.view(), y.view()).unwrap();
        assert_eq!(m.mse, 0.0);
        assert_eq!(m.rmse, 0.0);
        assert_eq!(m.rel_mse, 0.0);
        assert_eq!(m.psnr, f64::INFINITY);
        assert!(close(m.ssim, 1.0, 1e-12), "{}", m.ssim);
        assert_eq!(
            (m.pixels, m.non_finite, m.reference_non_finite),
            (192, 0, 0)
        );
    }

    #[test]
    fn hand_computed_small_case() {
        // Errors 0.1, -0.2, 0.0, 0.3 on references 0.5, 0, 1, 0.1.
        let y = img(2, 2, 1, vec![0.5, 0.0, 1.0, 0.1]);
        let x = img(2, 2, 1, vec![0.6, -0.2, 1.0, 0.4]);
        let m = compare(x.view(), y.view()).unwrap();
        let mse = (0.01 + 0.04 + 0.0 + 0.09) / 4.0;
        assert!(close(m.mse, mse, 1e-7));
        assert!(close(m.rmse, mse.sqrt(), 1e-7));
        let rel = (0.01 / (0.25 + 0.01) + 0.04 / 0.01 + 0.0 + 0.09 / (0.01 + 0.01)) / 4.0;
        assert!(close(m.rel_mse, rel, 1e-6), "{} vs {rel}", m.rel_mse);
        assert!(close(m.psnr, 10.0 * (1.0 / mse).log10(), 1e-5));
        assert!(close(psnr_from_mse(0.01), 20.0, 1e-12));
    }

    #[test]
    fn rgb_metrics_average_over_channels() {
        let y = img(1, 1, 3, vec![0.0, 0.0, 0.0]);
        let x = img(1, 1, 3, vec![0.3, 0.0, 0.0]);
        let m = compare(x.view(), y.view()).unwrap();
        assert!(close(m.mse, 0.09 / 3.0, 1e-8));
        assert!(close(m.rel_mse, 0.09 / 0.01 / 3.0, 1e-5));
    }

    #[test]
    fn ssim_of_constant_images_matches_closed_form() {
        // Constant images: means a, b and zero variance, so
        // SSIM = (2ab + C1) / (a² + b² + C1) exactly, for any window or border rule.
        for (a, b) in [(0.5f32, 0.6f32), (0.2, 0.2), (0.0, 1.0), (0.9, 0.3)] {
            for (w, h) in [(32, 24), (5, 3)] {
                let x = img(w, h, 1, vec![a; w * h]);
                let y = img(w, h, 1, vec![b; w * h]);
                let (a, b) = (f64::from(a), f64::from(b));
                let expect = (2.0 * a * b + SSIM_C1) / (a * a + b * b + SSIM_C1);
                let got = ssim(x.view(), y.view()).unwrap();
                assert!(
                    close(got, expect, 1e-9),
                    "{a} {b} {w}x{h}: {got} vs {expect}"
                );
            }
        }
        // Clamping: values above 1 behave as 1.
        let x = img(12, 12, 1, vec![3.0; 144]);
        let y = img(12, 12, 1, vec![1.0; 144]);
        assert!(close(ssim(x.view(), y.view()).unwrap(), 1.0, 1e-12));
    }

    #[test]
    fn ssim_constant_offset_on_structured_image() {
        // y + offset keeps the structure term at 1; only the luminance term drops, so SSIM
        // stays high but below 1 and decreases with the offset.
        let (_, y) = pattern(24, 20);
        let shifted = |d: f32| img(24, 20, 1, y.data().iter().map(|v| v * 0.5 + d).collect());
        let half = img(24, 20, 1, y.data().iter().map(|v| v * 0.5).collect());
        let s1 = ssim(shifted(0.05).view(), half.view()).unwrap();
        let s2 = ssim(shifted(0.2).view(), half.view()).unwrap();
        assert!(s1 < 1.0 && s2 < s1 && s2 > 0.5, "{s1} {s2}");
    }

    #[test]
    fn ssim_matches_scikit_image() {
        // Reference: skimage.metrics.structural_similarity(x, y, data_range=1.0,
        // gaussian_weights=True, sigma=1.5, use_sample_covariance=False) on `pattern(24, 20)`
        // (float32 values promoted to float64), scikit-image 0.26.0.
        let (x, y) = pattern(24, 20);
        let got = ssim(x.view(), y.view()).unwrap();
        assert!(close(got, 0.979_105_695_588_829_4, 1e-9), "{got}");
        // An unrelated image: x2[i][j] = ((29 i + 41 j) mod 89) / 88.
        let x2: Vec<f32> = (0..20)
            .flat_map(|i| (0..24).map(move |j| ((i * 29 + j * 41) % 89) as f32 / 88.0))
            .collect();
        let got = ssim(img(24, 20, 1, x2).view(), y.view()).unwrap();
        assert!(close(got, -0.097_782_301_650_601_53, 1e-9), "{got}");
    }

    #[test]
    fn rgb_ssim_uses_luminance() {
        let (x, y) = pattern(16, 16);
        let grey = |i: &Image| {
            img(
                16,
                16,
                3,
                i.data().iter().flat_map(|&v| [v, v, v]).collect(),
            )
        };
        let s1 = ssim(x.view(), y.view()).unwrap();
        let s3 = ssim(grey(&x).view(), grey(&y).view()).unwrap();
        assert!(close(s1, s3, 1e-6), "{s1} vs {s3}");
        assert!(close(f64::from(luminance(&[1.0, 1.0, 1.0])), 1.0, 1e-6));
    }

    #[test]
    fn shape_mismatch_is_an_error() {
        let a = Image::zeros(2, 2, 1);
        let b = Image::zeros(2, 2, 3);
        assert!(matches!(
            compare(a.view(), b.view()),
            Err(MetricsError::ShapeMismatch { .. })
        ));
        assert!(matches!(
            masked_error(a.view(), a.view(), &[true]),
            Err(MetricsError::LengthMismatch { .. })
        ));
    }

    #[test]
    fn non_finite_pixels_are_counted_and_excluded() {
        let y = img(4, 1, 1, vec![0.5, 0.5, 0.5, 0.5]);
        let x = img(4, 1, 1, vec![0.6, f32::NAN, f32::INFINITY, 0.4]);
        let m = compare(x.view(), y.view()).unwrap();
        assert_eq!((m.pixels, m.non_finite, m.reference_non_finite), (2, 2, 0));
        assert!(close(m.mse, 0.01, 1e-7), "{}", m.mse);
        assert!(m.ssim.is_finite() && m.ssim < 1.0);

        // RGB: one bad channel excludes the whole pixel.
        let y = img(2, 1, 3, vec![0.0; 6]);
        let x = img(2, 1, 3, vec![0.0, f32::NEG_INFINITY, 0.0, 0.1, 0.1, 0.1]);
        let m = compare(x.view(), y.view()).unwrap();
        assert_eq!((m.pixels, m.non_finite), (1, 1));
        assert!(close(m.mse, 0.01, 1e-7));

        // Everything broken: NaN metrics, but counted, never silently "perfect".
        let x = img(2, 1, 1, vec![f32::NAN; 2]);
        let y = img(2, 1, 1, vec![0.0, f32::NAN]);
        let m = compare(x.view(), y.view()).unwrap();
        assert_eq!((m.pixels, m.non_finite, m.reference_non_finite), (0, 2, 1));
        assert!(m.rmse.is_nan() && m.rel_mse.is_nan() && m.psnr.is_nan());
    }

    #[test]
    fn non_finite_is_worst_case_in_ssim() {
        let y = img(12, 12, 1, vec![0.8; 144]);
        let mut bad = vec![0.8; 144];
        bad[60] = f32::NAN;
        let dark = {
            let mut v = vec![0.8; 144];
            v[60] = 0.0;
            v
        };
        let s_nan = ssim(img(12, 12, 1, bad).view(), y.view()).unwrap();
        let s_dark = ssim(img(12, 12, 1, dark).view(), y.view()).unwrap();
        assert_eq!(s_nan, s_dark);
        assert!(s_nan < 1.0);
    }

    #[test]
    fn masked_error_selects_pixels() {
        let y = img(3, 1, 1, vec![0.0, 0.0, 0.0]);
        let x = img(3, 1, 1, vec![0.1, 0.5, f32::NAN]);
        assert_eq!(masked_error(x.view(), y.view(), &[false; 3]).unwrap(), None);
        let m = masked_error(x.view(), y.view(), &[false, true, false])
            .unwrap()
            .unwrap();
        assert_eq!((m.pixels, m.non_finite), (1, 0));
        assert!(close(m.rmse, 0.5, 1e-7));
        assert!(close(m.rel_mse, 0.25 / 0.01, 1e-4));
        let m = masked_error(x.view(), y.view(), &[true, false, true])
            .unwrap()
            .unwrap();
        assert_eq!((m.pixels, m.non_finite), (1, 1));
        assert!(close(m.rmse, 0.1, 1e-7));
        let m = masked_error(x.view(), y.view(), &[false, false, true])
            .unwrap()
            .unwrap();
        assert_eq!((m.pixels, m.non_finite), (0, 1));
        assert!(m.rmse.is_nan());
    }

    #[test]
    fn temporal_error_of_constant_offset_is_zero() {
        let mut seq = SequenceMetrics::new();
        for t in 0..5 {
            let y = img(
                4,
                3,
                3,
                (0..36)
                    .map(|i| ((i * 7 + t * 5) % 11) as f32 / 10.0)
                    .collect(),
            );
            let x = img(4, 3, 3, y.data().iter().map(|v| v + 0.25).collect());
            let f = *seq.push(x.view(), y.view(), None).unwrap();
            assert_eq!(f.frame, t);
            assert!(close(f.metrics.rmse, 0.25, 1e-6));
            match f.temporal {
                None => assert_eq!(t, 0),
                Some(e) => assert!(e.abs() < 1e-6, "frame {t}: {e}"),
            }
        }
        let s = seq.summary();
        assert_eq!(s.frames, 5);
        assert!(s.temporal.unwrap().abs() < 1e-6);
        assert!(close(s.mean_rmse, 0.25, 1e-6));
        assert_eq!((s.masked_frames, s.mean_masked_rel_mse), (0, None));
    }

    #[test]
    fn temporal_error_of_flicker() {
        // Error alternates +0.1 / -0.1 on a static reference: per-frame RMSE 0.1, temporal 0.2.
        let y = img(2, 2, 1, vec![0.5; 4]);
        let mut seq = SequenceMetrics::new();
        assert_eq!(seq.summary().temporal, None);
        for t in 0..4 {
            let d = if t % 2 == 0 { 0.1 } else { -0.1 };
            let x = img(2, 2, 1, vec![0.5 + d; 4]);
            let mask = [t == 2, false, false, false];
            seq.push(x.view(), y.view(), Some(&mask)).unwrap();
        }
        let s = seq.summary();
        assert!(close(s.temporal.unwrap(), 0.2, 1e-6));
        assert!(close(s.mean_rmse, 0.1, 1e-6));
        assert!(close(s.psnr_of_mean_mse, 20.0, 1e-4));
        assert_eq!(s.masked_frames, 1);
        assert!(close(s.mean_masked_rmse.unwrap(), 0.1, 1e-6));
        assert_eq!(seq.frames().len(), 4);

        // A frame of another size is rejected and leaves the sequence unchanged.
        let big = Image::zeros(3, 3, 1);
        assert!(seq.push(big.view(), big.view(), None).is_err());
        assert_eq!(seq.frames().len(), 4);
    }

    #[test]
    fn temporal_error_skips_non_finite_samples() {
        let y = img(2, 1, 1, vec![0.0, 0.0]);
        let mut seq = SequenceMetrics::new();
        seq.push(img(2, 1, 1, vec![0.1, f32::NAN]).view(), y.view(), None)
            .unwrap();
        let f = *seq
            .push(img(2, 1, 1, vec![0.3, 0.0]).view(), y.view(), None)
            .unwrap();
        assert!(close(f.temporal.unwrap(), 0.2, 1e-6));
        assert_eq!(seq.summary().non_finite, 1);
    }

    #[test]
    fn standard_error_by_hand() {
        // Samples {0, 2}: mean 1, mean of squares 2, unbiased variance 2, SE = sqrt(2/2) = 1.
        // Samples {1, 1}: SE 0.
        let se = standard_error(&[1.0f32, 1.0], &[2.0f32, 1.0], 2).unwrap();
        assert_eq!(se.per_sample, vec![1.0, 0.0]);
        assert!(close(se.mean, 0.5, 1e-12));
        assert!(close(se.rms, (0.5f64).sqrt(), 1e-12));
        assert_eq!(se.non_finite, 0);

        // Four samples {0, 0, 1, 1}: mean 0.5, E[x²] 0.5, s² = 0.25·4/3, SE = sqrt(1/12).
        let se = standard_error(&[0.5f64], &[0.5f64], 4).unwrap();
        assert!(close(
            f64::from(se.per_sample[0]),
            (1.0f64 / 12.0).sqrt(),
            1e-7
        ));

        // Rounding that makes mean_sq < mean² clamps to zero variance instead of NaN.
        let se = standard_error(&[0.1f32], &[0.0099999f32], 100).unwrap();
        assert_eq!(se.per_sample[0], 0.0);

        let se = standard_error(&[f32::NAN, 0.0], &[0.0, 0.0], 10).unwrap();
        assert_eq!(se.non_finite, 1);
        assert!(se.per_sample[0].is_nan() && se.mean == 0.0);

        assert_eq!(
            standard_error(&[0.0f32], &[0.0], 1),
            Err(MetricsError::TooFewSamples(1))
        );
        assert!(matches!(
            standard_error(&[0.0f32], &[], 5),
            Err(MetricsError::LengthMismatch { .. })
        ));
    }

    #[cfg(feature = "flip")]
    #[test]
    fn flip_identity_and_ordering() {
        let (x, y) = pattern(32, 32);
        assert_eq!(flip(y.view(), y.view()).unwrap(), 0.0);
        let e = flip(x.view(), y.view()).unwrap();
        assert!(e > 0.0 && e < 1.0, "{e}");
        let worse = img(32, 32, 1, y.data().iter().map(|v| 1.0 - v).collect());
        assert!(flip(worse.view(), y.view()).unwrap() > e);
        // RGB grey equals single-channel grey.
        let grey = |i: &Image| {
            img(
                32,
                32,
                3,
                i.data().iter().flat_map(|&v| [v, v, v]).collect(),
            )
        };
        assert!(close(
            flip(grey(&x).view(), grey(&y).view()).unwrap(),
            e,
            1e-9
        ));
        let map = flip_map(x.view(), y.view(), 67.0).unwrap();
        assert_eq!((map.width(), map.height(), map.channels()), (32, 32, 1));
        // Non-finite test pixels count as the worst case, not as a match.
        let mut bad = y.data().to_vec();
        bad[100] = f32::NAN;
        assert!(flip(img(32, 32, 1, bad).view(), y.view()).unwrap() > 0.0);
        assert!(matches!(
            flip(Image::zeros(2, 2, 2).view(), Image::zeros(2, 2, 2).view()),
            Err(MetricsError::UnsupportedChannels(2))
        ));
    }
}
