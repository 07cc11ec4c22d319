//! Metrics of a frame sequence: per-frame errors, the temporal (flicker) error between frames,
//! and whole-sequence averages, which single-image metrics cannot express.

use super::{
    all_finite, check_same_shape, compare, masked_error, psnr_from_mse, shape, ErrorMetrics,
    MaskedError, MetricsError,
};
use crate::image::ImageRef;

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
