//! What a sequence run produces: per-frame records (the rows of `frames.csv`), the images handed
//! to the caller after each frame, and the whole-sequence results and their averages.

use super::{mean, mean_finite, Part};
use vrrt_core::kernels::gradient::GradientSample;
use vrrt_scene::image::Image;
use vrrt_scene::metrics::{self, SequenceMetrics, SequenceSummary};
use vrrt_scene::render::FrameOutput;

/// Frames at the start of a sequence left out of timing means: backends compile pipelines when
/// a kernel first runs (some first run on the second frame, e.g. the gradient prepass) and
/// allocate on first use.
pub const WARMUP_FRAMES: usize = 2;

/// Pixel-planes of a frame where the change detector acted on history (`λ > 0`: shortened or
/// dropped) against those where the oracle dropped it.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct Detection {
    /// Both.
    pub hits: u64,
    /// The oracle only.
    pub misses: u64,
    /// The detector only.
    pub false_positives: u64,
    /// Neither.
    pub quiet: u64,
}

impl Detection {
    /// Scores the detector's `λ` against the oracle's changes (same layout; `λ` 0 or 1).
    pub fn score(lambda: &[f32], oracle: &[GradientSample]) -> Detection {
        let mut d = Detection::default();
        for (l, o) in lambda.iter().zip(oracle) {
            match (*l > 0.0, o.lambda() > 0.5) {
                (true, true) => d.hits += 1,
                (false, true) => d.misses += 1,
                (true, false) => d.false_positives += 1,
                (false, false) => d.quiet += 1,
            }
        }
        d
    }

    /// The sum of two scores.
    pub fn plus(self, o: Detection) -> Detection {
        Detection {
            hits: self.hits + o.hits,
            misses: self.misses + o.misses,
            false_positives: self.false_positives + o.false_positives,
            quiet: self.quiet + o.quiet,
        }
    }

    /// Share of the oracle's changes the detector missed (NaN without any).
    pub fn miss_rate(&self) -> f64 {
        self.misses as f64 / (self.hits + self.misses) as f64
    }

    /// Share of the unchanged pixels the detector flagged (NaN without any).
    pub fn false_positive_rate(&self) -> f64 {
        self.false_positives as f64 / (self.false_positives + self.quiet) as f64
    }
}

/// One frame's numbers (a row of `frames.csv`). With several parts, each metric is the mean over
/// the parts (PSNR: of their mean MSE), so that a signal with many planes does not outweigh one.
#[derive(Clone, Debug, Default)]
pub struct FrameRecord {
    /// Frame index.
    pub frame: u32,
    /// Rays traced (per plane).
    pub rays_traced: u64,
    /// The load balancer's budget (expected rays).
    pub budget: f64,
    /// Expected rays requested.
    pub requested: f64,
    /// Expected rays granted.
    pub granted: f64,
    /// relMSE of the reported image.
    pub relmse: f64,
    /// RMSE.
    pub rmse: f64,
    /// PSNR (dB).
    pub psnr: f64,
    /// SSIM.
    pub ssim: f64,
    /// Mean LDR-FLIP.
    pub flip: f64,
    /// Temporal error against the previous frame (NaN on the first).
    pub temporal: f64,
    /// relMSE over the moving mask (NaN when the mask is empty).
    pub moving_relmse: f64,
    /// relMSE of the raw samples (the denoiser's input).
    pub raw_relmse: f64,
    /// The relMSE the reference's own noise adds to [`Self::relmse`]
    /// ([`metrics::reference_rel_noise`]; NaN where its standard error is unknown).
    pub reference_noise: f64,
    /// relMSE over the pixels without history: every pixel of a reset frame (the first, a camera
    /// cut), else the disoccluded ones (NaN when there are none).
    pub fresh_relmse: f64,
    /// The relMSE the reference's own noise adds to [`Self::fresh_relmse`] (NaN where its
    /// standard error is unknown or there are no fresh pixels).
    pub fresh_reference_noise: f64,
    /// Pixels [`Self::fresh_relmse`] is over.
    pub fresh_pixels: usize,
    /// Rays the change detector traced (per plane; 0 when it did not run or re-traces nothing).
    pub detector_rays: u64,
    /// relMSE outside the moving mask (what a detector's false positives would cost).
    pub static_relmse: f64,
    /// The change detector's mask against the oracle's, when both were there.
    pub detection: Option<Detection>,
    /// Power spectrum of the reported image's error (mean over parts; default when unmeasured).
    pub error_spectrum: metrics::ErrorSpectrum,
    /// Power spectrum of the raw samples' error.
    pub raw_spectrum: metrics::ErrorSpectrum,
    /// relMSE of each part, in the order of [`SequenceResult::parts`].
    pub part_relmse: Vec<f64>,
    /// Wall-clock milliseconds of the frame (render and read back).
    pub ms_frame: f64,
    /// The ray budget the frame ran with, rays per pixel (fixed, or from `--budget-ms`).
    pub budget_rpp: f64,
    /// Milliseconds of the ray-tracing passes (`raygen_*`), what `--budget-ms` controls.
    pub trace_ms: f64,
    /// Milliseconds per pass entry point, summed over dispatches of the frame.
    pub passes: Vec<(&'static str, f64)>,
    /// The temporal-gradient prepass ran.
    pub prepass_ran: bool,
    /// Share of the à-trous tile-iterations (over tiles with geometry) the adaptive filter
    /// skipped.
    pub filter_skipped: f64,
    /// Share of tiles without geometry (no pass does work there).
    pub empty_tiles: f64,
    /// The signal had no source: no pass ran.
    pub signal_absent: bool,
}

impl FrameRecord {
    /// `rays_traced - budget`.
    pub fn overshoot(&self) -> f64 {
        self.rays_traced as f64 - self.budget
    }

    /// Rays of the budget left untraced (0 when over budget).
    pub fn rays_saved(&self) -> f64 {
        (self.budget - self.rays_traced as f64).max(0.0)
    }
}

/// A frame handed to the caller of [`run_sequence`](super::run_sequence) (for writing images).
pub struct FrameView<'a> {
    /// Its numbers.
    pub record: &'a FrameRecord,
    /// The renderer's output.
    pub output: &'a FrameOutput,
    /// Each part's images.
    pub parts: &'a [PartFrame],
}

/// One part's images of a frame.
pub struct PartFrame {
    /// The part.
    pub part: Part,
    /// The reported image (denoised, or raw for `raw`).
    pub test: Image,
    /// The raw samples.
    pub raw: Image,
    /// The reference (when measuring).
    pub reference: Option<Image>,
    /// Moving-region mask (when measuring).
    pub moving: Option<Vec<bool>>,
}

/// One part's sequence metrics.
pub struct PartMetrics {
    /// The part.
    pub part: Part,
    /// Metrics of the reported image (masked by the moving mask).
    pub metrics: SequenceMetrics,
    /// relMSE of the raw input, per frame measured.
    pub raw_relmse: Vec<f64>,
}

/// Sequence-wide results.
pub struct SequenceResult {
    /// Per-frame rows.
    pub records: Vec<FrameRecord>,
    /// Each part's metrics, in plane order.
    pub parts: Vec<PartMetrics>,
    /// Pass entry points in order of first appearance.
    pub pass_names: Vec<&'static str>,
}

impl SequenceResult {
    /// Whole-sequence metrics of the reported image: the one part's, or the means over the
    /// parts (PSNR: of their mean MSE) with counts summed.
    pub fn summary(&self) -> SequenceSummary {
        let s: Vec<SequenceSummary> = self.parts.iter().map(|p| p.metrics.summary()).collect();
        let avg = |v: fn(&SequenceSummary) -> f64| mean_finite(s.iter().map(v));
        let avg_some = |v: fn(&SequenceSummary) -> Option<f64>| {
            Some(mean_finite(s.iter().filter_map(v))).filter(|m| !m.is_nan())
        };
        let mean_mse = avg(|s| s.mean_mse);
        SequenceSummary {
            frames: s.iter().map(|s| s.frames).max().unwrap_or(0),
            mean_mse,
            mean_rmse: avg(|s| s.mean_rmse),
            mean_rel_mse: avg(|s| s.mean_rel_mse),
            psnr_of_mean_mse: metrics::psnr_from_mse(mean_mse),
            mean_ssim: avg(|s| s.mean_ssim),
            temporal: avg_some(|s| s.temporal),
            mean_masked_rel_mse: avg_some(|s| s.mean_masked_rel_mse),
            mean_masked_rmse: avg_some(|s| s.mean_masked_rmse),
            masked_frames: s.iter().map(|s| s.masked_frames).max().unwrap_or(0),
            non_finite: s.iter().map(|s| s.non_finite).sum(),
            reference_non_finite: s.iter().map(|s| s.reference_non_finite).sum(),
        }
    }

    /// Mean over the frames of the second half (the converged part) of a per-frame value.
    pub fn second_half_mean(&self, value: impl Fn(&FrameRecord) -> f64) -> f64 {
        let n = self.records.len();
        let v: Vec<f32> = self.records[n / 2..]
            .iter()
            .map(|r| value(r) as f32)
            .collect();
        mean(&v)
    }

    /// Mean over all frames of a per-frame value (NaN skipped).
    pub fn mean_of(&self, value: impl Fn(&FrameRecord) -> f64) -> f64 {
        mean_finite(self.records.iter().map(value))
    }

    /// The detector's scores summed over the frames that have one (`None`: never scored).
    pub fn detection(&self) -> Option<Detection> {
        self.records
            .iter()
            .filter_map(|r| r.detection)
            .reduce(Detection::plus)
    }

    /// relMSE over every pixel without history in the sequence, pooled (each fresh pixel counts
    /// once, so the first frame, the cut and a disoccluded sliver weigh by their pixels); NaN
    /// when there are none.
    pub fn fresh_relmse(&self) -> f64 {
        self.pooled_over_fresh(|r| r.fresh_relmse)
    }

    /// The relMSE the references' noise adds to [`Self::fresh_relmse`], pooled the same way
    /// (NaN where a frame with fresh pixels lacks it).
    pub fn fresh_reference_noise(&self) -> f64 {
        self.pooled_over_fresh(|r| r.fresh_reference_noise)
    }

    /// `f` of every frame with fresh pixels, weighted by their number.
    fn pooled_over_fresh(&self, f: impl Fn(&FrameRecord) -> f64) -> f64 {
        let (mut sum, mut n) = (0.0, 0usize);
        for r in self.records.iter().filter(|r| !r.fresh_relmse.is_nan()) {
            sum += f(r) * r.fresh_pixels as f64;
            n += r.fresh_pixels;
        }
        if n == 0 {
            f64::NAN
        } else {
            sum / n as f64
        }
    }

    /// The frames whose timings count: all after the first [`WARMUP_FRAMES`], or every frame of
    /// a sequence no longer than that.
    pub fn timed_records(&self) -> &[FrameRecord] {
        self.records
            .get(WARMUP_FRAMES..)
            .filter(|r| !r.is_empty())
            .unwrap_or(&self.records)
    }

    /// Mean ms per frame of each pass over `records` (of this sequence).
    pub fn pass_means(&self, records: &[FrameRecord]) -> Vec<(&'static str, f64)> {
        let n = records.len().max(1) as f64;
        self.pass_names
            .iter()
            .map(|&name| {
                let total: f64 = records
                    .iter()
                    .flat_map(|r| r.passes.iter())
                    .filter(|(p, _)| *p == name)
                    .map(|(_, ms)| ms)
                    .sum();
                (name, total / n)
            })
            .collect()
    }
}
