//! The render-and-measure loop over a frame sequence: renders each frame through the denoiser,
//! measures every part against its reference and collects the timings.

use super::recycle::Recycling;
use super::{
    fresh_mask, mean_finite, moving_mask, oracle_changes, parts, planes_to_image, Config,
    Detection, FrameRecord, FrameReference, FrameView, LoadedScene, PartFrame, PartMetrics,
    ReferenceRequest, References, SequenceResult,
};
use anyhow::{anyhow, Context, Result};
use std::collections::HashMap;
use std::time::Instant;
use vrrt_backend::Backend;
use vrrt_core::executor::Executor;
use vrrt_core::kernels::gradient::GradientSample;
use vrrt_core::settings::Settings;
use vrrt_scene::image::{Image, ImageRef};
use vrrt_scene::metrics::{self, SequenceMetrics};
use vrrt_scene::render::{FrameOutput, Readback, Renderer, Signal};
use vrrt_scene::FrameGeometry;

/// What one sequence renders.
#[derive(Clone, Debug)]
pub struct SequenceOptions {
    /// Width and height.
    pub size: (u32, u32),
    /// Frames rendered (from frame 0).
    pub frames: u32,
    /// Signal.
    pub signal: Signal,
    /// Reference samples per pixel.
    pub spp: u32,
    /// Denoiser settings the configuration starts from (`Settings::default()`, or a settings
    /// file); the configuration, `rpp` and the signal win over them.
    pub base: Settings,
    /// Denoiser configuration.
    pub config: Config,
    /// Ray budget, rays per pixel per frame.
    pub rpp: f32,
    /// Read back the debug overlays.
    pub overlays: bool,
    /// Compare against references (off: timing only).
    pub measure: bool,
}

/// Renders `opts.frames` frames of `scene` on `exec`, measuring each part against its reference
/// (when `opts.measure`), and calls `on_frame` after each.
pub fn run_sequence(
    exec: &mut Backend,
    scene: &LoadedScene,
    opts: &SequenceOptions,
    refs: &References,
    mut on_frame: impl FnMut(&FrameView<'_>) -> Result<()>,
) -> Result<SequenceResult> {
    let (width, height) = opts.size;
    let pixels = (width * height) as usize;
    let sc = &scene.scene;
    let settings = opts.config.settings(opts.base, opts.rpp, opts.signal);
    // The renderer's buffers come from those of earlier sequences on this executor (all done
    // now, their renderers dropped), so a bench's memory stays flat across its cells.
    let mut pool = refs.pool.borrow_mut();
    pool.release();
    let mut rec = Recycling {
        exec,
        pool: &mut pool,
    };
    // The detector's λ, to score it against the oracle's mask.
    let score_detector = opts.measure && settings.detector.radius > 0;
    let mut renderer = new_renderer(&mut rec, opts, sc.lights.len(), settings, score_detector)?;
    // The frame's planes, all signals' (the renderer sets them from the signal's layout).
    let frame_planes = renderer.denoiser().layout().planes as usize;
    let mut parts: Vec<PartMetrics> = parts(opts.signal, sc.lights.len())
        .into_iter()
        .map(|part| PartMetrics {
            part,
            metrics: SequenceMetrics::new(),
            raw_relmse: Vec::new(),
        })
        .collect();
    let mut records = Vec::new();
    let mut pass_names: Vec<&'static str> = Vec::new();
    let mut prev_references: Vec<Option<FrameReference>> = vec![None; parts.len()];
    // The oracle reads the references even when a timing repeat measures nothing.
    let with_references = opts.measure || opts.config.is_oracle();
    for i in 0..opts.frames {
        let f = sc.frame(i);
        let references = if with_references {
            frame_references(rec.exec, refs, scene, &f, opts, &parts)?
        } else {
            vec![None; parts.len()]
        };
        let oracle = (opts.config.is_oracle() || score_detector)
            .then(|| oracle_frame(pixels * frame_planes, &parts, &references, &prev_references));
        let changes = oracle.as_deref().filter(|_| opts.config.is_oracle());
        rec.clear_timings();
        let start = Instant::now();
        let out = renderer
            .render_with_changes(
                &mut rec,
                &f,
                Readback {
                    overlays: opts.overlays,
                },
                changes,
            )
            .map_err(|e| anyhow!("rendering frame {i}: {e}"))?;
        let ms_frame = start.elapsed().as_secs_f64() * 1e3;
        let passes = pass_times(rec.timings(), &mut pass_names);
        let mut record = new_record(i, &out, ms_frame, passes, frame_planes);
        let fresh = fresh_mask(&out.flags, out.reset);
        if let (Some(o), false) = (&oracle, out.changes.is_empty()) {
            record.detection = Some(Detection::score(&out.changes, o));
        }
        let FrameParts {
            frames,
            references: references_kept,
            measured,
        } = frame_parts(&mut parts, references, &prev_references, &out, &fresh, opts)?;
        record.set_errors(&measured);
        on_frame(&FrameView {
            record: &record,
            output: &out,
            parts: &frames,
        })?;
        records.push(record);
        prev_references = references_kept;
    }
    Ok(SequenceResult {
        records,
        parts,
        pass_names,
    })
}

/// What [`frame_parts`] gives for one frame.
struct FrameParts {
    /// Each part's images.
    frames: Vec<PartFrame>,
    /// Each part's reference, for the oracle's next frame.
    references: Vec<Option<FrameReference>>,
    /// The errors of the parts measured.
    measured: Vec<PartError>,
}

/// Each part of frame `out`: its test and raw images, measured against its reference when
/// `opts.measure`; the references come back either way, for the oracle's next frame.
fn frame_parts(
    parts: &mut [PartMetrics],
    references: Vec<Option<FrameReference>>,
    prev_references: &[Option<FrameReference>],
    out: &FrameOutput,
    fresh: &[bool],
    opts: &SequenceOptions,
) -> Result<FrameParts> {
    let (width, height) = opts.size;
    let pixels = (width * height) as usize;
    let mut frames = Vec::new();
    let mut references_kept = Vec::new();
    let mut measured: Vec<PartError> = Vec::new();
    for ((p, reference), prev) in parts.iter_mut().zip(references).zip(prev_references) {
        let (first, planes) = p.part.planes;
        let range = first as usize * pixels..(first + planes) as usize * pixels;
        let raw = planes_to_image(&out.raw[range.clone()], width, height, planes);
        let test = if opts.config.reports_raw() {
            raw.clone()
        } else {
            planes_to_image(&out.denoised[range], width, height, planes)
        };
        let mut moving = None;
        // Kept for the oracle's next frame even when this repeat measures nothing.
        let measured_reference = reference.as_ref().filter(|_| opts.measure);
        if let Some(r) = measured_reference {
            let (error, mask) = measure_part(p, &test, &raw, r, prev.as_ref(), out, fresh)?;
            measured.push(error);
            moving = Some(mask);
        }
        frames.push(PartFrame {
            part: p.part,
            test,
            raw,
            reference: measured_reference.map(|r| r.image.clone()),
            moving,
        });
        references_kept.push(reference);
    }
    Ok(FrameParts {
        frames,
        references: references_kept,
        measured,
    })
}

/// The sequence's renderer, keeping the detector's output when it is scored.
fn new_renderer(
    rec: &mut Recycling<'_>,
    opts: &SequenceOptions,
    lights: usize,
    settings: Settings,
    keep_changes: bool,
) -> Result<Renderer> {
    let (width, height) = opts.size;
    let mut renderer = Renderer::new(rec, width, height, opts.signal, lights, settings)
        .map_err(|e| anyhow!("cannot create the denoiser: {e}"))?;
    if keep_changes {
        renderer
            .keep_changes(rec)
            .map_err(|e| anyhow!("keeping the detector's output: {e}"))?;
    }
    Ok(renderer)
}

/// The references of frame `f`'s parts (traced, or from the cache).
fn frame_references(
    exec: &mut Backend,
    refs: &References,
    scene: &LoadedScene,
    f: &FrameGeometry,
    opts: &SequenceOptions,
    parts: &[PartMetrics],
) -> Result<Vec<Option<FrameReference>>> {
    parts
        .iter()
        .map(|p| {
            Ok(Some(refs.get(
                exec,
                ReferenceRequest {
                    scene_key: &scene.key,
                    frame: f,
                    size: opts.size,
                    signal: p.part.signal,
                    reflections: &opts.base.reflections,
                    spp: opts.spp,
                },
            )?))
        })
        .collect()
}

/// Each pass's time in this frame's `timings` (dispatches of one entry summed), in the order
/// they first ran; entries not seen before join `pass_names`.
fn pass_times(
    timings: &[vrrt_core::executor::PassTiming],
    pass_names: &mut Vec<&'static str>,
) -> Vec<(&'static str, f64)> {
    let mut per_pass: HashMap<&'static str, f64> = HashMap::new();
    let mut order = Vec::new();
    for t in timings {
        if !per_pass.contains_key(t.entry) {
            order.push(t.entry);
        }
        *per_pass.entry(t.entry).or_default() += t.ms;
        if !pass_names.contains(&t.entry) {
            pass_names.push(t.entry);
        }
    }
    order.iter().map(|&p| (p, per_pass[p])).collect()
}

/// The record of frame `i` from what the renderer reported, its errors not yet measured (NaN).
fn new_record(
    i: u32,
    out: &FrameOutput,
    ms_frame: f64,
    passes: Vec<(&'static str, f64)>,
    frame_planes: usize,
) -> FrameRecord {
    let (run, configured) = out.filter_work();
    let all_tiles: u32 = out.tiles.iter().sum();
    FrameRecord {
        prepass_ran: out.gradient_ran,
        filter_skipped: if configured == 0 {
            0.0
        } else {
            1.0 - run as f64 / configured as f64
        },
        empty_tiles: if all_tiles == 0 {
            0.0
        } else {
            out.tiles[0] as f64 / all_tiles as f64
        },
        signal_absent: out.signal_absent,
        frame: i,
        rays_traced: out.rays_traced,
        budget: out.budget,
        requested: out.requested,
        granted: out.granted,
        ms_frame,
        budget_rpp: out.rays_per_pixel as f64,
        trace_ms: out.trace_ms,
        passes,
        relmse: f64::NAN,
        rmse: f64::NAN,
        psnr: f64::NAN,
        ssim: f64::NAN,
        flip: f64::NAN,
        temporal: f64::NAN,
        moving_relmse: f64::NAN,
        raw_relmse: f64::NAN,
        reference_noise: f64::NAN,
        fresh_relmse: f64::NAN,
        fresh_reference_noise: f64::NAN,
        fresh_pixels: 0,
        static_relmse: f64::NAN,
        detection: None,
        detector_rays: out.gradient_rays / frame_planes as u64,
        part_relmse: Vec::new(),
        error_spectrum: Default::default(),
        raw_spectrum: Default::default(),
    }
}

impl FrameRecord {
    /// The frame's errors: the means over the parts measured (none measured: left NaN).
    fn set_errors(&mut self, measured: &[PartError]) {
        if measured.is_empty() {
            return;
        }
        let avg = |v: fn(&PartError) -> f64| mean_finite(measured.iter().map(v));
        self.relmse = avg(|e| e.relmse);
        self.rmse = avg(|e| e.rmse);
        self.psnr = metrics::psnr_from_mse(avg(|e| e.mse));
        self.ssim = avg(|e| e.ssim);
        self.flip = avg(|e| e.flip);
        self.temporal = avg(|e| e.temporal);
        self.moving_relmse = avg(|e| e.moving_relmse);
        self.raw_relmse = avg(|e| e.raw_relmse);
        self.reference_noise = avg(|e| e.reference_noise);
        self.fresh_relmse = mean_finite(measured.iter().filter_map(|e| e.fresh.map(|f| f.0)));
        self.fresh_reference_noise = mean_finite(
            measured
                .iter()
                .filter(|e| e.fresh.is_some())
                .map(|e| e.fresh_reference_noise),
        );
        self.fresh_pixels = measured.iter().find_map(|e| e.fresh).map_or(0, |f| f.1);
        self.static_relmse = avg(|e| e.static_relmse);
        self.part_relmse = measured.iter().map(|e| e.relmse).collect();
        self.error_spectrum = metrics::ErrorSpectrum::mean(measured.iter().map(|e| &e.spectra[0]));
        self.raw_spectrum = metrics::ErrorSpectrum::mean(measured.iter().map(|e| &e.spectra[1]));
    }
}

/// Part `p`'s errors in this frame (its denoised `test` and `raw` samples against the reference
/// `r`, last frame's `prev` for the moving mask), pushed to its sequence metrics, and the moving
/// mask. The metrics are independent of each other and single-threaded each (at 1080p SSIM and
/// FLIP take most of a frame's time on the GPU backends), so they run side by side.
fn measure_part(
    p: &mut PartMetrics,
    test: &Image,
    raw: &Image,
    r: &FrameReference,
    prev: Option<&FrameReference>,
    out: &FrameOutput,
    fresh: &[bool],
) -> Result<(PartError, Vec<bool>)> {
    let mask = moving_mask(&out.flags, &r.image, prev.map(|p| &p.image));
    let metrics = &mut p.metrics;
    let ((fm, raw_relmse), (flip, rest)) = rayon::join(
        || {
            rayon::join(
                || {
                    metrics
                        .push(test.view(), r.image.view(), Some(&mask))
                        .cloned()
                },
                || metrics::rel_mse(raw.view(), r.image.view()),
            )
        },
        || {
            rayon::join(
                || flip(test.view(), r.image.view()),
                || masked_errors(test, raw, r, &mask, fresh),
            )
        },
    );
    let fm = fm.context("metrics")?;
    let raw_relmse = raw_relmse.context("metrics")?;
    p.raw_relmse.push(raw_relmse);
    let MaskedErrors {
        spectra,
        fresh: fresh_error,
        fresh_reference_noise,
        static_relmse,
    } = rest?;
    let error = PartError {
        relmse: fm.metrics.rel_mse,
        rmse: fm.metrics.rmse,
        mse: fm.metrics.mse,
        ssim: fm.metrics.ssim,
        flip,
        temporal: fm.temporal.unwrap_or(f64::NAN),
        moving_relmse: fm.masked.map_or(f64::NAN, |m| m.rel_mse),
        raw_relmse,
        reference_noise: reference_noise(r, None)?,
        fresh_reference_noise,
        fresh: fresh_error,
        static_relmse,
        spectra,
    };
    Ok((error, mask))
}

/// The errors of [`measure_part`] that keep no state from frame to frame.
struct MaskedErrors {
    spectra: [metrics::ErrorSpectrum; 2],
    fresh: Option<(f64, usize)>,
    fresh_reference_noise: f64,
    static_relmse: f64,
}

/// The error spectra of `test` and `raw`, and `test`'s errors over the `fresh` pixels and
/// outside the moving `mask`.
fn masked_errors(
    test: &Image,
    raw: &Image,
    r: &FrameReference,
    mask: &[bool],
    fresh: &[bool],
) -> Result<MaskedErrors> {
    let spectra = [
        metrics::error_spectrum(test.view(), r.image.view()).context("metrics")?,
        metrics::error_spectrum(raw.view(), r.image.view()).context("metrics")?,
    ];
    let fresh_error =
        metrics::masked_error(test.view(), r.image.view(), fresh).context("metrics")?;
    let still: Vec<bool> = mask.iter().map(|m| !m).collect();
    let static_error =
        metrics::masked_error(test.view(), r.image.view(), &still).context("metrics")?;
    Ok(MaskedErrors {
        spectra,
        fresh: fresh_error.map(|m| (m.rel_mse, m.pixels)),
        fresh_reference_noise: match fresh_error {
            Some(_) => reference_noise(r, Some(fresh))?,
            None => f64::NAN,
        },
        static_relmse: static_error.map_or(f64::NAN, |m| m.rel_mse),
    })
}

/// The relMSE reference `r`'s own noise adds over `mask`'s pixels, or all
/// ([`metrics::reference_rel_noise`]); NaN without its standard error.
fn reference_noise(r: &FrameReference, mask: Option<&[bool]>) -> Result<f64> {
    match &r.stderr {
        Some(se) => {
            metrics::reference_rel_noise(r.image.view(), se.view(), mask).context("metrics")
        }
        None => Ok(f64::NAN),
    }
}

/// One part's error in one frame, before the means over parts of [`FrameRecord`].
struct PartError {
    relmse: f64,
    rmse: f64,
    mse: f64,
    ssim: f64,
    flip: f64,
    temporal: f64,
    moving_relmse: f64,
    raw_relmse: f64,
    /// The relMSE the reference's own noise adds ([`metrics::reference_rel_noise`]).
    reference_noise: f64,
    /// The same over the fresh pixels (NaN when there are none).
    fresh_reference_noise: f64,
    /// relMSE and pixel count over the fresh pixels, when there are any.
    fresh: Option<(f64, usize)>,
    /// relMSE outside the moving mask.
    static_relmse: f64,
    /// Error spectra of the reported image and of the raw samples.
    spectra: [metrics::ErrorSpectrum; 2],
}

/// The oracle's changes for this frame ([`oracle_changes`] per part), one cell per pixel and
/// plane (`Config::VrrtOracle` sets stratum 1). Nothing changes where a reference or last
/// frame's is missing (the first frame resets anyway).
fn oracle_frame(
    cells: usize,
    parts: &[PartMetrics],
    references: &[Option<FrameReference>],
    previous: &[Option<FrameReference>],
) -> Vec<GradientSample> {
    let mut out = vec![GradientSample::default(); cells];
    for ((p, now), before) in parts.iter().zip(references).zip(previous) {
        if let (Some(now), Some(before)) = (now, before) {
            let (first, count) = p.part.planes;
            oracle_changes(now, before, first as usize, count as usize, &mut out);
        }
    }
    out
}

fn flip(test: ImageRef<'_>, reference: ImageRef<'_>) -> f64 {
    metrics::flip(test, reference).unwrap_or(f64::NAN)
}
