//! What `run`, `reference` and `bench` share: parsing of sizes, scenes, signals and denoiser
//! configurations, cached references, and the render-and-measure loop over a frame sequence.

use crate::backend::{Backend, BackendKind};
use anyhow::{anyhow, bail, Context, Result};
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;
use vrrt_core::denoiser::Settings;
use vrrt_core::kernels::reproject::FLAG_DISOCCLUDED;
use vrrt_core::plan::Executor;
use vrrt_core::reflections::ReflectionSettings;
use vrrt_scene::image::{Image, ImageRef};
use vrrt_scene::metrics::{self, SequenceMetrics, SequenceSummary};
use vrrt_scene::reference_cache::{ReferenceCache, ReferenceKey, StdErr};
use vrrt_scene::render::{self, FrameOutput, Readback, Renderer, Signal};
use vrrt_scene::{FrameGeometry, Scene};

/// Version of the reference cache entries this command writes and reads; bump it when the
/// renderer's estimator changes so that stale references are not reused.
pub const REFERENCE_VERSION: u32 = 1;

/// Largest accepted width or height.
pub const MAX_DIMENSION: u32 = 8192;

/// Reference change (per frame, any plane; relative above 1, see [`moving_mask`]) above which a
/// pixel counts as "moving".
pub const MOVING_THRESHOLD: f32 = 0.02;

/// Parses `WxH` (e.g. `256x144`); both must be in `1..=MAX_DIMENSION`.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("`{s}` is not a size: expected WxH, e.g. 256x144");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if w == 0 || h == 0 {
        return Err(format!("size {w}x{h}: width and height must be at least 1"));
    }
    if w > MAX_DIMENSION || h > MAX_DIMENSION {
        return Err(format!(
            "size {w}x{h}: width and height must be at most {MAX_DIMENSION}"
        ));
    }
    Ok((w, h))
}

/// Parses a ray budget in rays per pixel per frame: `0 < rpp <= 16`.
pub fn parse_rpp(s: &str) -> Result<f32, String> {
    let v: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number of rays per pixel"))?;
    if !(v > 0.0 && v <= 16.0) {
        return Err(format!(
            "ray budget {v} rays per pixel is out of range (0 < rpp <= 16)"
        ));
    }
    Ok(v)
}

/// Parses a backend name (`auto`, `cpu`, `wgpu`, `ash`).
pub fn parse_backend(s: &str) -> Result<BackendKind, String> {
    s.parse()
}

/// The signal kinds on the command line.
#[derive(Copy, Clone, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SignalKind {
    /// Ambient occlusion (one plane), up to `--ao-radius`.
    Ao,
    /// Area-light shadows (one plane per light).
    Shadows,
    /// Glossy reflections (one plane of HDR radiance; default settings).
    Reflections,
    /// AO, shadows and reflections in one frame, sharing one ray budget.
    All,
}

impl SignalKind {
    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            SignalKind::Ao => "ao",
            SignalKind::Shadows => "shadows",
            SignalKind::Reflections => "reflections",
            SignalKind::All => "all",
        }
    }

    /// The renderer's signal, with the AO distance `ao_radius`.
    pub fn signal(self, ao_radius: f32) -> Signal {
        match self {
            SignalKind::Ao => Signal::Ao {
                max_distance: ao_radius,
            },
            SignalKind::Shadows => Signal::Shadows,
            SignalKind::Reflections => Signal::Reflections(ReflectionSettings::default()),
            SignalKind::All => Signal::All {
                max_distance: ao_radius,
                reflections: ReflectionSettings::default(),
            },
        }
    }
}

/// One signal among a frame's planes (`Signal::All` has three). Each part is measured against
/// its own reference, cached under the part's signal alone, so `all` reuses the references of
/// `ao`, `shadows` and `reflections`; and its images keep 1, 3 or 4 channels, which PNG, EXR
/// and the cache need.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Part {
    /// `ao`, `shadows` or `reflections`: the suffix of its files and columns.
    pub name: &'static str,
    /// The signal on its own.
    pub signal: Signal,
    /// First plane and how many.
    pub planes: (u32, u32),
}

/// The parts of `signal` in plane order, for a scene with `lights` lights.
pub fn parts(signal: Signal, lights: usize) -> Vec<Part> {
    let layout = signal.layout(lights);
    let mut parts = Vec::new();
    if let (Some(plane), Signal::Ao { max_distance } | Signal::All { max_distance, .. }) =
        (layout.ao, signal)
    {
        parts.push(Part {
            name: "ao",
            signal: Signal::Ao { max_distance },
            planes: (plane, 1),
        });
    }
    if let Some(planes) = layout.shadows {
        parts.push(Part {
            name: "shadows",
            signal: Signal::Shadows,
            planes,
        });
    }
    if let (Some(plane), Some(r)) = (layout.reflections, signal.reflections()) {
        parts.push(Part {
            name: "reflections",
            signal: Signal::Reflections(r),
            planes: (plane, 1),
        });
    }
    parts
}

/// A denoiser configuration: the baselines and the stages of VRRT.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum Config {
    /// No denoising: this frame's raw samples at a fixed rate.
    Raw,
    /// SVGF at a fixed rate.
    Svgf,
    /// SVGF with a variance clamp of history.
    SvgfClamp,
    /// VRRT supersampling only (no load balancing, no undersampling).
    VrrtSuper,
    /// VRRT supersampling with load balancing (no undersampling).
    VrrtBalance,
    /// Full VRRT: supersampling, load balancing and undersampling.
    Vrrt,
    /// Full VRRT in "save" mode: rays the plan saves stay unspent.
    VrrtSave,
    /// Full VRRT with nothing skipped: every tile runs every filter iteration and still pixels
    /// keep their rays (what the adaptive plan is measured against).
    VrrtNoskip,
}

impl Config {
    /// Every configuration, baselines first.
    pub const ALL: [Config; 8] = [
        Config::Raw,
        Config::Svgf,
        Config::SvgfClamp,
        Config::VrrtSuper,
        Config::VrrtBalance,
        Config::Vrrt,
        Config::VrrtSave,
        Config::VrrtNoskip,
    ];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Config::Raw => "raw",
            Config::Svgf => "svgf",
            Config::SvgfClamp => "svgf-clamp",
            Config::VrrtSuper => "vrrt-super",
            Config::VrrtBalance => "vrrt-balance",
            Config::Vrrt => "vrrt",
            Config::VrrtSave => "vrrt-save",
            Config::VrrtNoskip => "vrrt-noskip",
        }
    }

    /// Denoiser settings for a budget of `rpp` rays per pixel and `signal`. Temporal gradients
    /// are off for signals with reflections, which the gradient prepass cannot re-trace
    /// (`Renderer::new` refuses them).
    pub fn settings(self, rpp: f32, signal: Signal) -> Settings {
        let vrrt = Settings {
            rays_per_pixel: rpp,
            ..Settings::default()
        };
        let mut settings = match self {
            Config::Raw | Config::Svgf => Settings::svgf(rpp),
            Config::SvgfClamp => Settings {
                clamp_radius: 1,
                ..Settings::svgf(rpp)
            },
            Config::VrrtSuper => Settings {
                load_balance: false,
                undersample: false,
                ..vrrt
            },
            Config::VrrtBalance => Settings {
                undersample: false,
                ..vrrt
            },
            Config::Vrrt => vrrt,
            Config::VrrtSave => Settings {
                spend_saved_rays: false,
                ..vrrt
            },
            Config::VrrtNoskip => Settings {
                skip_sigma: 0.0,
                still_sigma: 0.0,
                ..vrrt
            },
        };
        if signal.reflections().is_some() {
            settings.gradient_stratum = 0;
        }
        settings
    }

    /// True when the reported image is the raw samples rather than the denoised output.
    pub fn reports_raw(self) -> bool {
        self == Config::Raw
    }
}

/// Appends a `,ms_<pass>` column name for every pass in `names`.
pub fn pass_header(s: &mut String, names: &[&str]) {
    for p in names {
        let _ = write!(s, ",ms_{p}");
    }
}

/// Appends the milliseconds of every pass in `names` (0 where it did not run).
pub fn pass_columns(s: &mut String, passes: &[(&'static str, f64)], names: &[&str]) {
    for p in names {
        let ms = passes
            .iter()
            .find(|(n, _)| n == p)
            .map_or(0.0, |(_, ms)| *ms);
        let _ = write!(s, ",{ms:.4}");
    }
}

/// Opens a backend, turning failure into a one-line error.
pub fn open_backend(kind: BackendKind, validation: bool) -> Result<(Backend, String)> {
    Backend::open(kind, validation).map_err(|e| anyhow!("cannot open the {kind:?} backend: {e}"))
}

/// A scene and the name its references are cached under.
pub struct LoadedScene {
    /// The scene.
    pub scene: Scene,
    /// Built-in name, or the mesh file's stem.
    pub key: String,
}

/// Loads a built-in scene by name, or a mesh file (`.obj`, `.ply`, `.ply.gz`, `.glb`, `.gltf`)
/// shown by [`vrrt_scene::builtin::showcase`].
pub fn load_scene(spec: &str) -> Result<LoadedScene> {
    use vrrt_scene::builtin;
    if builtin::BUILTINS.iter().any(|b| b.name == spec) {
        let scene = builtin::builtin(spec).map_err(|e| anyhow!("{e}"))?;
        return Ok(LoadedScene {
            scene,
            key: spec.to_string(),
        });
    }
    let path = Path::new(spec);
    let is_mesh = vrrt_scene::load::Format::from_path(path).is_some();
    if !is_mesh && !path.exists() {
        // Not a mesh path: report it as an unknown scene name, listing the built-ins.
        let e = builtin::builtin(spec).err().map(|e| e.to_string());
        bail!("{}", e.unwrap_or_else(|| format!("unknown scene `{spec}`")));
    }
    let mesh = vrrt_scene::load::load_mesh(path).map_err(|e| anyhow!("{e}"))?;
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .map(|n| n.split('.').next().unwrap_or(n).to_string())
        .filter(|n| !n.is_empty())
        .unwrap_or_else(|| "mesh".into());
    Ok(LoadedScene {
        scene: builtin::showcase(&name, &mesh),
        key: name,
    })
}

/// Stacked planes (`plane * pixels + pixel`) as an interleaved image; two planes are padded
/// with a zero third channel (images have 1, 3 or 4 channels).
pub fn planes_to_image(stacked: &[f32], width: u32, height: u32, planes: u32) -> Image {
    let pixels = (width * height) as usize;
    let planes = planes as usize;
    let channels = if planes == 2 { 3 } else { planes };
    let mut data = vec![0.0f32; pixels * channels];
    for p in 0..planes {
        for i in 0..pixels {
            data[i * channels + p] = stacked[p * pixels + i];
        }
    }
    Image::new(width as usize, height as usize, channels, data).expect("image of the frame size")
}

/// A reference image and its mean standard error over pixels.
pub struct FrameReference {
    /// The converged image, interleaved planes.
    pub image: Image,
    /// Mean over pixels and planes of the per-pixel standard error.
    pub mean_stderr: f64,
    /// True when it came from the cache.
    pub cached: bool,
}

/// Where references come from: the on-disk cache, else traced (and then stored).
pub struct References {
    cache: Option<ReferenceCache>,
    /// Print a progress line while tracing.
    pub progress: bool,
}

impl References {
    /// The cache at [`ReferenceCache::from_env`] (none if no cache directory can be found).
    pub fn from_env(progress: bool) -> Self {
        let cache = ReferenceCache::from_env();
        if cache.is_none() {
            eprintln!("note: no reference cache directory (set $VRRT_REFERENCE_CACHE or $HOME); references are traced every time");
        }
        References { cache, progress }
    }

    /// The cache directory, if any.
    pub fn cache_dir(&self) -> Option<&Path> {
        self.cache.as_ref().map(|c| c.root())
    }

    /// The reference of frame `f` of `scene_key`: from the cache, or traced on `exec` with
    /// `spp` samples per pixel and stored.
    #[allow(clippy::too_many_arguments)]
    pub fn get(
        &self,
        exec: &mut Backend,
        scene_key: &str,
        f: &FrameGeometry,
        (width, height): (u32, u32),
        signal: Signal,
        spp: u32,
    ) -> Result<FrameReference> {
        let key = ReferenceKey {
            scene: scene_key.to_string(),
            frame: f.index,
            width,
            height,
            spp: spp as u64,
            signal: signal.name(),
            version: REFERENCE_VERSION,
        };
        let planes = signal.planes(f.lights.len());
        if let Some(hit) = self.cache.as_ref().and_then(|c| c.load(&key)) {
            let mean_stderr = match &hit.stderr {
                StdErr::Scalar(v) => *v,
                StdErr::Image(img) => mean(img.data()),
            };
            return Ok(FrameReference {
                image: hit.image,
                mean_stderr,
                cached: true,
            });
        }
        let progress = self.progress;
        let frame = f.index;
        let r = render::reference(exec, f, width, height, signal, spp, |done, total| {
            if progress {
                eprint!(
                    "\r{:<72}",
                    format!("reference: frame {frame}, {done}/{total} spp")
                );
            }
        })
        .map_err(|e| anyhow!("tracing the reference of frame {frame}: {e}"))?;
        let image = planes_to_image(&r.mean, width, height, planes);
        let stderr = planes_to_image(&r.stderr, width, height, planes);
        let mean_stderr = mean(&r.stderr);
        if let Some(cache) = &self.cache {
            if let Err(e) = cache.store(&key, image.view(), &StdErr::Image(stderr)) {
                eprintln!("warning: reference not cached: {e}");
            }
        }
        Ok(FrameReference {
            image,
            mean_stderr,
            cached: false,
        })
    }
}

/// Mean of the finite values (NaN if none).
pub fn mean_finite(values: impl IntoIterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for v in values.into_iter().filter(|v| v.is_finite()) {
        s += v;
        n += 1;
    }
    if n == 0 {
        f64::NAN
    } else {
        s / n as f64
    }
}

/// Mean of the finite values (NaN if none).
pub fn mean(v: &[f32]) -> f64 {
    mean_finite(v.iter().map(|&x| f64::from(x)))
}

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
    /// Denoiser configuration.
    pub config: Config,
    /// Ray budget, rays per pixel per frame.
    pub rpp: f32,
    /// Read back the debug overlays.
    pub overlays: bool,
    /// Compare against references (off: timing only).
    pub measure: bool,
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
    /// relMSE of each part, in the order of [`SequenceResult::parts`].
    pub part_relmse: Vec<f64>,
    /// Wall-clock milliseconds of the frame (render and read back).
    pub ms_frame: f64,
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

/// A frame handed to the caller of [`run_sequence`] (for writing images).
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
    /// Metrics of the raw input.
    pub raw_metrics: SequenceMetrics,
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

    /// Mean ms per frame of each pass.
    pub fn pass_means(&self) -> Vec<(&'static str, f64)> {
        let n = self.records.len().max(1) as f64;
        self.pass_names
            .iter()
            .map(|&name| {
                let total: f64 = self
                    .records
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
    let settings = opts.config.settings(opts.rpp, opts.signal);
    let mut renderer = Renderer::new(exec, width, height, opts.signal, sc.lights.len(), settings)
        .map_err(|e| anyhow!("cannot create the denoiser: {e}"))?;
    let mut parts: Vec<PartMetrics> = parts(opts.signal, sc.lights.len())
        .into_iter()
        .map(|part| PartMetrics {
            part,
            metrics: SequenceMetrics::new(),
            raw_metrics: SequenceMetrics::new(),
        })
        .collect();
    let mut records = Vec::new();
    let mut pass_names: Vec<&'static str> = Vec::new();
    let mut prev_references: Vec<Option<Image>> = vec![None; parts.len()];
    for i in 0..opts.frames {
        let f = sc.frame(i);
        let mut references = Vec::new();
        for p in &parts {
            references.push(if opts.measure {
                Some(refs.get(exec, &scene.key, &f, opts.size, p.part.signal, opts.spp)?)
            } else {
                None
            });
        }
        exec.clear_timings();
        let start = Instant::now();
        let out = renderer
            .render(
                exec,
                &f,
                Readback {
                    overlays: opts.overlays,
                },
            )
            .map_err(|e| anyhow!("rendering frame {i}: {e}"))?;
        let ms_frame = start.elapsed().as_secs_f64() * 1e3;
        let mut per_pass: HashMap<&'static str, f64> = HashMap::new();
        let mut order = Vec::new();
        for t in exec.timings() {
            if !per_pass.contains_key(t.entry) {
                order.push(t.entry);
            }
            *per_pass.entry(t.entry).or_default() += t.ms;
            if !pass_names.contains(&t.entry) {
                pass_names.push(t.entry);
            }
        }
        let d = out.decision;
        let (run, configured) = out.filter_work(settings.atrous_iterations);
        let all_tiles: u32 = out.tiles.iter().sum();
        let mut record = FrameRecord {
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
            budget: d.budget as f64,
            requested: d.requested as f64,
            granted: d.granted as f64,
            ms_frame,
            passes: order.iter().map(|&p| (p, per_pass[p])).collect(),
            relmse: f64::NAN,
            rmse: f64::NAN,
            psnr: f64::NAN,
            ssim: f64::NAN,
            flip: f64::NAN,
            temporal: f64::NAN,
            moving_relmse: f64::NAN,
            raw_relmse: f64::NAN,
            part_relmse: Vec::new(),
        };
        let mut frames = Vec::new();
        let mut measured: Vec<PartError> = Vec::new();
        for ((p, reference), prev) in parts.iter_mut().zip(references).zip(&prev_references) {
            let (first, planes) = p.part.planes;
            let range = first as usize * pixels..(first + planes) as usize * pixels;
            let raw = planes_to_image(&out.raw[range.clone()], width, height, planes);
            let test = if opts.config.reports_raw() {
                raw.clone()
            } else {
                planes_to_image(&out.denoised[range], width, height, planes)
            };
            let mut moving = None;
            if let Some(r) = &reference {
                let mask = moving_mask(&out.flags, &r.image, prev.as_ref());
                let fm = p
                    .metrics
                    .push(test.view(), r.image.view(), Some(&mask))
                    .context("metrics")?;
                let rm = p
                    .raw_metrics
                    .push(raw.view(), r.image.view(), None)
                    .context("metrics")?;
                measured.push(PartError {
                    relmse: fm.metrics.rel_mse,
                    rmse: fm.metrics.rmse,
                    mse: fm.metrics.mse,
                    ssim: fm.metrics.ssim,
                    flip: flip(test.view(), r.image.view()),
                    temporal: fm.temporal.unwrap_or(f64::NAN),
                    moving_relmse: fm.masked.map_or(f64::NAN, |m| m.rel_mse),
                    raw_relmse: rm.metrics.rel_mse,
                });
                moving = Some(mask);
            }
            frames.push(PartFrame {
                part: p.part,
                test,
                raw,
                reference: reference.map(|r| r.image),
                moving,
            });
        }
        if !measured.is_empty() {
            let avg = |v: fn(&PartError) -> f64| mean_finite(measured.iter().map(v));
            record.relmse = avg(|e| e.relmse);
            record.rmse = avg(|e| e.rmse);
            record.psnr = metrics::psnr_from_mse(avg(|e| e.mse));
            record.ssim = avg(|e| e.ssim);
            record.flip = avg(|e| e.flip);
            record.temporal = avg(|e| e.temporal);
            record.moving_relmse = avg(|e| e.moving_relmse);
            record.raw_relmse = avg(|e| e.raw_relmse);
            record.part_relmse = measured.iter().map(|e| e.relmse).collect();
        }
        on_frame(&FrameView {
            record: &record,
            output: &out,
            parts: &frames,
        })?;
        records.push(record);
        prev_references = frames.into_iter().map(|p| p.reference).collect();
    }
    Ok(SequenceResult {
        records,
        parts,
        pass_names,
    })
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
}

fn flip(test: ImageRef<'_>, reference: ImageRef<'_>) -> f64 {
    metrics::flip(test, reference).unwrap_or(f64::NAN)
}

/// Pixels flagged disoccluded, or whose reference changed (in any channel) since the previous
/// frame by more than [`MOVING_THRESHOLD`], relative to the previous value where that exceeds 1
/// (HDR radiance, where an absolute threshold would flag every highlight).
pub fn moving_mask(flags: &[u32], reference: &Image, previous: Option<&Image>) -> Vec<bool> {
    let c = reference.channels();
    (0..flags.len())
        .map(|i| {
            let disoccluded = flags[i] & FLAG_DISOCCLUDED != 0;
            let changed = previous.is_some_and(|p| {
                (0..c).any(|k| {
                    let (now, before) = (reference.data()[i * c + k], p.data()[i * c + k]);
                    (now - before).abs() > MOVING_THRESHOLD * before.abs().max(1.0)
                })
            });
            disoccluded || changed
        })
        .collect()
}

/// Formats a float for CSV and tables (`nan` for NaN).
pub fn fmt(v: f64, digits: usize) -> String {
    if v.is_nan() {
        "nan".into()
    } else {
        format!("{v:.digits$}")
    }
}
