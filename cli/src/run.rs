//! `vrrt run`: renders a scene through one denoiser configuration, measures every frame against
//! its reference and writes `frames.csv`, images and (optionally) debug overlays.

use crate::limits::LimitArgs;
use crate::outdir::OutDir;
use crate::plot;
use crate::progress::Progress;
use crate::session::{
    self, fmt, load_scene, mean_finite, open_backend, parse_backend, parse_budget_ms, parse_rpp,
    parse_size, plane_names, Config, FrameRecord, FrameView, LoadedScene, References,
    SequenceOptions, SequenceResult, SignalArg, WARMUP_FRAMES,
};
use anyhow::{anyhow, bail, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use vrrt_backend::BackendKind;
use vrrt_core::kernels::buckets::{bucket_to_rate, BUCKET_COUNT};
use vrrt_core::settings::Settings;
use vrrt_scene::image::{write_exr, write_heatmap_png, write_png, Image, ImageRef};

/// Options of `vrrt run`.
#[derive(Clone, Debug, clap::Args)]
pub struct RunArgs {
    /// Built-in scene (room, room_static, thicket; bunny and dragon after `vrrt fetch`), or a
    /// mesh file (.obj, .ply, .ply.gz, .glb, .gltf).
    #[arg(long, default_value = "room")]
    pub scene: String,
    /// Frames to render (from frame 0).
    #[arg(long, default_value_t = 48)]
    pub frames: u32,
    /// Image size, WxH.
    #[arg(long, default_value = "256x144", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Backend: auto, cpu, wgpu or ash.
    #[arg(long, default_value = "cpu", value_parser = parse_backend)]
    pub backend: BackendKind,
    /// Denoiser configuration (`raw` reports the raw samples, no denoising).
    #[arg(long, value_enum, default_value = "vrrt")]
    pub denoiser: Config,
    /// Ray budget in rays per pixel per frame (0 < rpp <= 16; default `rates.rays_per_pixel` of
    /// `--settings`, 1 without). Wins over the settings file.
    #[arg(long, value_parser = parse_rpp)]
    pub rpp: Option<f32>,
    /// Ray budget in milliseconds of ray tracing per frame (`rates.budget_ms`): each frame's
    /// rays per pixel follow from the measured cost of the last frames, between
    /// `rates.budget_floor` and `rates.budget_ceiling`, starting from `--rpp`. 0 = the fixed
    /// `--rpp`. Wins over the settings file.
    #[arg(long, value_name = "MS", value_parser = parse_budget_ms)]
    pub budget_ms: Option<f32>,
    /// Settings file (TOML: the tables `[temporal]`, `[rates]`, `[prepass]`, `[detector]`,
    /// `[filter]` and `[reflections]`; fields left out keep their defaults, unknown fields are
    /// errors; `vrrt info --settings` prints the defaults). It replaces the defaults that the
    /// other options start from, and they win over it: `--denoiser` applies its changes on top
    /// (svgf turns VRRT's rates and the adaptive filter off, vrrt-save keeps saved rays, …),
    /// `--rpp` replaces `rates.rays_per_pixel`, and `--signal` decides the planes (and, for
    /// reflections alone, `rates.reset_payback` 64; but for shadows alone, `rates.reset_refill`
    /// 0).
    #[arg(long, value_name = "FILE")]
    pub settings: Option<PathBuf>,
    /// Signal to trace and denoise.
    #[arg(long, value_enum, default_value = "ao")]
    pub signal: SignalArg,
    /// Ambient occlusion maximum distance.
    #[arg(long, default_value_t = 1.0)]
    pub ao_radius: f32,
    /// Reference samples per pixel.
    #[arg(long, default_value_t = 256)]
    pub spp: u32,
    /// Output directory. It holds only this run's files: the files an earlier `vrrt run` wrote
    /// there (listed in its `.vrrt-run-manifest`) are removed first, and nothing else in it is
    /// touched.
    #[arg(long, default_value = "out/run")]
    pub out: PathBuf,
    /// Write PNGs of every n-th frame (clamped to [0, 1]: reflections are HDR radiance, which
    /// `denoised_last*.exr` keeps).
    #[arg(long, default_value_t = 8)]
    pub every: u32,
    /// Write debug overlays every frame: requested and granted rays, history length after
    /// reprojection and after accumulation (heatmaps), and a budget bar chart.
    #[arg(long)]
    pub overlays: bool,
    /// Enable the Vulkan validation layers (wgpu, ash); `VRRT_VALIDATION=1` does too.
    #[arg(long)]
    pub validation: bool,
    /// Limits on a mesh file given as the scene.
    #[command(flatten, next_help_heading = "Limits on a mesh file")]
    pub limits: LimitArgs,
}

/// Most reference samples per pixel (`--spp`): 128 times the default, a bound on the
/// references' cost (a mistyped number is refused instead of rendering without end), and the
/// most their 16-bit random sequence index holds without wrapping
/// ([`vrrt_scene::render::REFERENCE_RNG_BASE`]).
pub const MAX_SPP: u32 = 1 << 15;

/// Most frames of a sequence (`--frames`): the scenes' animations are far shorter.
pub const MAX_FRAMES: u32 = 1 << 16;

/// Checks the options that clap's parsers do not, before anything is loaded, removed or
/// rendered.
pub fn check_common(frames: u32, spp: u32, ao_radius: f32) -> Result<()> {
    if !(1..=MAX_FRAMES).contains(&frames) {
        bail!("--frames must be between 1 and {MAX_FRAMES}, got {frames}");
    }
    if !(1..=MAX_SPP).contains(&spp) {
        bail!("--spp must be between 1 and {MAX_SPP}, got {spp}");
    }
    if !(ao_radius.is_finite() && ao_radius > 0.0) {
        bail!("--ao-radius must be a positive distance, got {ao_radius}");
    }
    Ok(())
}

/// Runs `vrrt run`.
pub fn run(args: &RunArgs) -> Result<()> {
    check_common(args.frames, args.spp, args.ao_radius)?;
    if args.every == 0 {
        bail!("--every must be at least 1");
    }
    let mut base = load_settings(args.settings.as_deref())?;
    if let Some(ms) = args.budget_ms {
        base.rates.budget_ms = ms;
    }
    let rpp = args.rpp.unwrap_or(base.rates.rays_per_pixel);
    let scene = load_scene(&args.scene, &args.limits.limits())?;
    let frames = clamp_frames(args.frames, scene.scene.frames_available());
    let (mut exec, why) = open_backend(args.backend, args.validation)?;
    let device = exec.device();
    let out = OutDir::prepare(&args.out, "run")?;
    let refs = References::from_env(true);
    let opts = SequenceOptions {
        size: args.size,
        frames,
        signal: args.signal.signal(args.ao_radius),
        spp: args.spp,
        base,
        config: args.denoiser,
        rpp,
        overlays: args.overlays,
        measure: true,
    };
    let out = &out;
    let (w, h) = args.size;
    let mut last_denoised = Vec::new();
    let mut progress = Progress::new("frame", frames.into(), 10);
    let result = session::run_sequence(&mut exec, &scene, &opts, &refs, |v| {
        frame_files(out, args, frames, v, &mut last_denoised)?;
        progress.set(u64::from(v.record.frame) + 1, || {
            format!(
                "relMSE {}, {} rays, {:.1} ms",
                fmt(v.record.relmse, 5),
                v.record.rays_traced,
                v.record.ms_frame
            )
        });
        Ok(())
    })?;
    drop(progress);
    for (tag, img) in &last_denoised {
        write_exr(out.file(&format!("denoised_last{tag}.exr"))?, img.view())?;
    }
    let part_names: Vec<&str> = result.parts.iter().map(|p| p.part.name).collect();
    let csv = frames_csv(&result.records, &part_names, &result.pass_names);
    out.write("frames.csv", csv.as_bytes())?;
    exec.warn_validation_errors();

    let rs = &result;
    let mut t = Table::default();
    t.row(
        "backend",
        format!("{} — {device}", exec_name(args.backend, &exec)),
    );
    if args.backend == BackendKind::Auto {
        t.row("auto chose it because", why);
    }
    describe(&mut t, args, &scene, frames, &opts, rpp);
    quality_rows(&mut t, rs);
    cost_rows(&mut t, rs, &opts, (w, h));
    timing_rows(&mut t, rs);
    t.row("output", out.dir().display().to_string());
    println!("{}", t.0);
    Ok(())
}

/// The summary `vrrt run` prints: one `key value` line per row.
#[derive(Default)]
struct Table(String);

impl Table {
    fn row(&mut self, k: &str, v: String) {
        self.0.push_str(&format!("  {k:<28} {v}\n"));
    }
}

/// Frame `v`'s images: every `--every`th frame's and the last one's PNGs, the overlays when
/// asked; the last frame's denoised images are kept in `last_denoised` for the EXR.
fn frame_files(
    out: &OutDir,
    args: &RunArgs,
    frames: u32,
    v: &FrameView<'_>,
    last_denoised: &mut Vec<(String, Image)>,
) -> Result<()> {
    let i = v.record.frame;
    let several = v.parts.len() > 1;
    for p in v.parts {
        // With several parts each has its own files: `frame0007_ao_denoised.png`.
        let tag = if several {
            format!("_{}", p.part.name)
        } else {
            String::new()
        };
        if i.is_multiple_of(args.every) || i + 1 == frames {
            let png = |what: &str| out.file(&format!("frame{i:04}{tag}_{what}.png"));
            write_png(png("denoised")?, p.test.view())?;
            write_png(png("raw")?, p.raw.view())?;
            if let Some(r) = &p.reference {
                write_png(png("reference")?, r.view())?;
            }
        }
        if i + 1 == frames {
            last_denoised.push((tag, p.test.clone()));
        }
    }
    if args.overlays {
        write_overlays(out, v, args.size)?;
    }
    Ok(())
}

/// What ran: the scene, size, frames, denoiser and budget, signal and settings file.
fn describe(
    t: &mut Table,
    args: &RunArgs,
    scene: &LoadedScene,
    frames: u32,
    opts: &SequenceOptions,
    rpp: f32,
) {
    let (w, h) = args.size;
    t.row("scene", scene.key.clone());
    t.row("size", format!("{w}x{h}"));
    t.row("frames", frames.to_string());
    t.row(
        "denoiser / budget",
        if opts.base.rates.budget_ms > 0.0 {
            format!(
                "{} at {} ms of ray tracing (from {rpp} rpp)",
                args.denoiser.name(),
                opts.base.rates.budget_ms
            )
        } else {
            format!("{} at {rpp} rpp", args.denoiser.name())
        },
    );
    let ao_radius = opts
        .signal
        .ao_distance()
        .map_or(String::new(), |r| format!(", AO radius {r}"));
    t.row(
        "signal",
        format!(
            "{}{ao_radius}; planes {}",
            args.signal.name(),
            plane_names(opts.signal, scene.scene.lights.len()).join(", ")
        ),
    );
    if let Some(path) = &args.settings {
        t.row("settings file", path.display().to_string());
    }
}

/// The errors: the output's and the raw input's over the second half, the whole sequence's,
/// each part's.
fn quality_rows(t: &mut Table, rs: &SequenceResult) {
    t.row(
        "relMSE, 2nd half (output)",
        fmt(rs.second_half_mean(|r| r.relmse), 6),
    );
    t.row(
        "relMSE, 2nd half (raw input)",
        fmt(rs.second_half_mean(|r| r.raw_relmse), 6),
    );
    let s = rs.summary();
    t.row(
        "whole sequence",
        format!(
            "relMSE {}, PSNR {} dB, SSIM {}, FLIP {}, temporal {}, moving relMSE {}",
            fmt(s.mean_rel_mse, 6),
            fmt(s.psnr_of_mean_mse, 2),
            fmt(s.mean_ssim, 4),
            fmt(rs.mean_of(|r| r.flip), 4),
            fmt(s.temporal.unwrap_or(f64::NAN), 5),
            fmt(s.mean_masked_rel_mse.unwrap_or(f64::NAN), 6)
        ),
    );
    if rs.parts.len() > 1 {
        for p in &rs.parts {
            let ps = p.metrics.summary();
            t.row(
                &format!("  {}", p.part.name),
                format!(
                    "relMSE {}, moving relMSE {}, raw relMSE {}",
                    fmt(ps.mean_rel_mse, 6),
                    fmt(ps.mean_masked_rel_mse.unwrap_or(f64::NAN), 6),
                    fmt(mean_finite(p.raw_relmse.iter().copied()), 6)
                ),
            );
        }
    }
    if s.non_finite > 0 {
        eprintln!("warning: {} non-finite output pixels", s.non_finite);
    }
}

/// What the frames cost in rays: per frame, the tracing time against its budget, the largest
/// overshoot, and what the adaptive plan skipped.
fn cost_rows(t: &mut Table, rs: &SequenceResult, opts: &SequenceOptions, (w, h): (u32, u32)) {
    let pixels = (w * h) as f64;
    let rays = rs.mean_of(|r| r.rays_traced as f64);
    t.row(
        "rays per frame",
        format!("{rays:.0} ({:.3} per pixel)", rays / pixels),
    );
    t.row(
        "ray tracing",
        tracing_summary(&rs.records, opts.base.rates.budget_ms),
    );
    let overshoot = rs
        .records
        .iter()
        .map(FrameRecord::overshoot)
        .fold(f64::NEG_INFINITY, f64::max);
    t.row("max budget overshoot (rays)", format!("{overshoot:.0}"));
    let n = rs.records.len().max(1) as f64;
    let budget: f64 = rs.records.iter().map(|r| r.budget).sum();
    let saved: f64 = rs.records.iter().map(FrameRecord::rays_saved).sum();
    t.row(
        "adaptive plan",
        format!(
            "prepass ran on {}/{} frames; rays saved {:.1}% of the budget; filter tile-iterations \
             skipped {:.1}%; empty tiles {:.1}%; {} frames without a signal",
            rs.records.iter().filter(|r| r.prepass_ran).count(),
            rs.records.len(),
            if budget > 0.0 {
                100.0 * saved / budget
            } else {
                0.0
            },
            100.0 * rs.mean_of(|r| r.filter_skipped),
            100.0 * rs.records.iter().map(|r| r.empty_tiles).sum::<f64>() / n,
            rs.records.iter().filter(|r| r.signal_absent).count()
        ),
    );
}

/// Time per frame (warm-up frames left out) and per pass.
fn timing_rows(t: &mut Table, rs: &SequenceResult) {
    let timed = rs.timed_records();
    let warmup = &rs.records[..rs.records.len() - timed.len()];
    let ms = mean_finite(timed.iter().map(|r| r.ms_frame));
    t.row(
        "ms per frame (mean)",
        if warmup.is_empty() {
            format!(
                "{ms:.2} over all {} frames (too few to leave out {WARMUP_FRAMES} warm-up frames)",
                timed.len()
            )
        } else {
            let warm: Vec<String> = warmup
                .iter()
                .map(|r| format!("{:.1}", r.ms_frame))
                .collect();
            format!(
                "{ms:.2} over frames {}–{}; warm-up frames excluded ({} ms)",
                warmup.len(),
                rs.records.len() - 1,
                warm.join(", ")
            )
        },
    );
    for (name, ms) in rs.pass_means(timed) {
        t.row(&format!("  {name}"), format!("{ms:.3} ms"));
    }
}

/// The settings file at `path` (see [`crate::settings`]), or the defaults without one.
pub fn load_settings(path: Option<&Path>) -> Result<Settings> {
    path.map_or(Ok(Settings::default()), crate::settings::load)
}

/// Frames beyond the scene's animation are not rendered.
pub fn clamp_frames(frames: u32, available: u32) -> u32 {
    if frames > available {
        eprintln!("note: the scene has {available} frames; rendering {available}");
        available
    } else {
        frames
    }
}

fn exec_name(kind: BackendKind, exec: &vrrt_backend::Backend) -> String {
    use vrrt_core::executor::Executor;
    match kind {
        BackendKind::Auto => format!("auto → {}", exec.name()),
        _ => exec.name().to_string(),
    }
}

/// The tracing time per frame against the target of `--budget-ms` (0: none), and the budgets.
fn tracing_summary(records: &[FrameRecord], target_ms: f32) -> String {
    let traced: Vec<&FrameRecord> = records.iter().filter(|r| !r.signal_absent).collect();
    let n = traced.len().max(1) as f64;
    let mean = traced.iter().map(|r| r.trace_ms).sum::<f64>() / n;
    let worst = traced.iter().map(|r| r.trace_ms).fold(0.0, f64::max);
    let budget = traced.iter().map(|r| r.budget_rpp).sum::<f64>() / n;
    let mut line = format!("{mean:.3} ms a frame (worst {worst:.3}), budget {budget:.3} rpp");
    if target_ms > 0.0 {
        let target = target_ms as f64;
        let over = traced.iter().filter(|r| r.trace_ms > 1.1 * target).count();
        let (lo, hi) = traced.iter().fold((f64::MAX, 0.0f64), |(lo, hi), r| {
            (lo.min(r.budget_rpp), hi.max(r.budget_rpp))
        });
        let _ = write!(
            line,
            " ({lo:.3}..{hi:.3}); target {target} ms: mean {:+.1}%, worst {:+.1}%, {over} frames \
             over +10%",
            100.0 * (mean / target - 1.0),
            100.0 * (worst / target - 1.0),
        );
    }
    line
}

/// `frames.csv`: one row per frame (with several parts, their mean metrics and then each part's
/// `relmse_<part>`), then per-pass milliseconds.
pub fn frames_csv(records: &[FrameRecord], part_names: &[&str], pass_names: &[&str]) -> String {
    let mut s = String::from(
        "frame,rays_traced,budget,requested,granted,overshoot,rays_saved,prepass_ran,filter_skipped,empty_tiles,signal_absent,relmse,rmse,psnr,ssim,flip,temporal,moving_relmse,fresh_relmse,fresh_pixels,detector_rays,reference_noise,fresh_reference_noise",
    );
    let several = part_names.len() > 1;
    if several {
        for p in part_names {
            let _ = write!(s, ",relmse_{p}");
        }
    }
    s.push_str(",ms_frame,budget_rpp,trace_ms");
    session::pass_header(&mut s, pass_names);
    s.push('\n');
    for r in records {
        let _ = write!(
            s,
            "{},{},{:.1},{:.1},{:.1},{:.1},{:.1},{},{:.4},{:.4},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.frame,
            r.rays_traced,
            r.budget,
            r.requested,
            r.granted,
            r.overshoot(),
            r.rays_saved(),
            r.prepass_ran as u8,
            r.filter_skipped,
            r.empty_tiles,
            r.signal_absent as u8,
            fmt(r.relmse, 7),
            fmt(r.rmse, 7),
            fmt(r.psnr, 3),
            fmt(r.ssim, 5),
            fmt(r.flip, 5),
            fmt(r.temporal, 7),
            fmt(r.moving_relmse, 7),
            fmt(r.fresh_relmse, 7),
            r.fresh_pixels,
            r.detector_rays,
            fmt(r.reference_noise, 7),
            fmt(r.fresh_reference_noise, 7),
        );
        if several {
            for k in 0..part_names.len() {
                let v = r.part_relmse.get(k).copied().unwrap_or(f64::NAN);
                let _ = write!(s, ",{}", fmt(v, 7));
            }
        }
        let _ = write!(
            s,
            ",{:.3},{:.4},{:.4}",
            r.ms_frame, r.budget_rpp, r.trace_ms
        );
        session::pass_columns(&mut s, &r.passes, pass_names);
        s.push('\n');
    }
    s
}

fn heatmap(path: &Path, values: &[f32], (w, h): (u32, u32), max: f32) -> Result<()> {
    let img = ImageRef::new(values, w as usize, h as usize, 1).map_err(|e| anyhow!("{e}"))?;
    write_heatmap_png(path, img, max)?;
    Ok(())
}

fn write_overlays(out: &OutDir, v: &FrameView<'_>, size: (u32, u32)) -> Result<()> {
    let i = v.record.frame;
    let o = v.output;
    let requested: Vec<f32> = o
        .requests
        .iter()
        .map(|&b| {
            if b >= BUCKET_COUNT {
                0.0
            } else {
                bucket_to_rate(b)
            }
        })
        .collect();
    let granted: Vec<f32> = o.rays.clone();
    let max_rays = requested
        .iter()
        .chain(&granted)
        .copied()
        .fold(1.0f32, f32::max);
    if !requested.is_empty() {
        heatmap(
            &out.file(&format!("frame{i:04}_requested.png"))?,
            &requested,
            size,
            max_rays,
        )?;
    }
    heatmap(
        &out.file(&format!("frame{i:04}_granted.png"))?,
        &granted,
        size,
        max_rays,
    )?;
    if !o.history_accumulated.is_empty() {
        let max_history = o.history_accumulated.iter().copied().fold(1.0f32, f32::max);
        heatmap(
            &out.file(&format!("frame{i:04}_history_accumulated.png"))?,
            &o.history_accumulated,
            size,
            max_history,
        )?;
    }
    let r = v.record;
    plot::budget_bars(
        &out.file(&format!("frame{i:04}_budget.png"))?,
        i,
        &[
            ("requested", r.requested),
            ("granted", r.granted),
            ("budget", r.budget),
            ("traced", r.rays_traced as f64),
        ],
    )?;
    Ok(())
}
