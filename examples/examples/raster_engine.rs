//! VRRT-rs in a raster engine: a small wgpu program rasterizes a real scene with its own WGSL
//! shaders into its own G-buffer textures — reversed-Z depth, view-space normals, UV velocities
//! ([`vrrt_examples::raster`]) — hands them to the denoiser in those conventions
//! (`EngineTextures`, decoded by the ingest pass inside `Frame::render`), and traces the AO rays
//! the denoiser asks for with VRRT's own tracer on the scene's BVH. The scenes are `vrrt-scene`'s:
//! `bunny` (the Stanford bunny of `vrrt fetch`, an orbiting camera) and `room` (a box and a sphere
//! that move, a moving camera), so `vrrt run`'s references apply.
//!
//! What it checks, per scene:
//! - **The G-buffer**: every frame, what the denoiser decoded from the engine's textures against
//!   VRRT's own ray-traced G-buffer of the same frame ([`vrrt_examples::raster::agreement`]):
//!   no pixel on the same face may differ beyond the formats' precision, and at most 1% of the
//!   pixels may see another face (the rasterizer's ties at edges).
//! - **The result**: the denoised frames' relMSE against the references `vrrt run` measures
//!   against (the same cache, the same metric) must be within 7% of what `vrrt run` gets on the
//!   same scene, size and frames with its ray-traced G-buffer. It runs that `vrrt run` here
//!   (`vrrt_cli::session::run_sequence`, CPU backend), so both numbers are measured side by side.
//!   Where the rasterizer covered a pixel that the tracer sees as sky (or the reverse), the two
//!   are not comparable — the reference is 0 there and relMSE divides by `0 + 0.01`, so one such
//!   pixel costs a 64x36 frame 0.04 — and the example says so instead of comparing. That is why
//!   the room runs at 96x54 by default: at 64x36 its back wall's top edge passes within 1/1000
//!   of a pixel of pixel centres in frames 14 and 16, where lavapipe's rasterizer covers them.
//!
//! Why 7%: the two runs are not the same noise. The rasterized depth differs from the traced
//! one in the sixth digit, a few pixels a frame see another face, so after a few frames some AO
//! ray hits differently, the balancer's decisions differ and the two sequences become two
//! realizations of the same estimator, whose means differ by noise: over 15 runs of `bunny`,
//! `room` and `dragon` at 48x27 to 128x72, 24 to 48 frames, without sky ties, from −6.7% to
//! +4.9%, −0.2% on average, 10 of 15 within 2% (2026-11-27, lavapipe). A tolerance of 2% failed
//! the room when AO's cut began spending three frames ahead (−2.64%: the rays moved between
//! frames, and with them both realizations); 7% holds what two realizations measured. The
//! decoded depth and normals are checked pixel by pixel above; this bound is for what only the
//! result shows (the velocities, the output texture).
//!
//! PNGs of the denoised frames and their references go to `target/<profile>/raster_engine/`.
//!
//! `cargo run --release -p vrrt-examples --example raster_engine [-- --scene bunny --frames 24
//! --size 64x36]` (`--scene` may repeat; `--size` applies to every scene). The same frames as
//! `vrrt run --scene bunny --size 64x36 --frames 24`, whose "whole sequence relMSE" is the number
//! matched. Without the bunny mesh (no `vrrt fetch`: CI without network) the bunny is skipped
//! with a message and the room still runs. Without a Vulkan driver it prints `skipped: no Vulkan
//! adapter` and succeeds, unless `VRRT_REQUIRE_VULKAN=1`; `VRRT_VALIDATION=1` runs it under the
//! Khronos validation layer.

use std::error::Error;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vrrt_backend::{Backend, BackendKind};
use vrrt_cli::session::{
    planes_to_image, run_sequence, Config, LoadedScene, ReferenceRequest, References,
    SequenceOptions, SequenceResult,
};
use vrrt_core::frame::Signal;
use vrrt_core::settings::Settings;
use vrrt_examples::raster::agreement::{self, Agreement};
use vrrt_examples::raster::{open_device, AppDevice, RasterDenoiser};
use vrrt_examples::{require_vulkan, validation};
use vrrt_scene::error::SceneError;
use vrrt_scene::image::{write_png, Image};
use vrrt_scene::metrics;

/// `vrrt run`'s defaults: ambient occlusion of radius 1 (`--ao-radius`), 256-spp references
/// (`--spp`), the full VRRT denoiser (`--denoiser vrrt`) at its default budget.
const SIGNAL: Signal = Signal::Ao { max_distance: 1.0 };
const SPP: u32 = 256;
const CONFIG: Config = Config::Vrrt;

/// How far the example's relMSE may lie from `vrrt run`'s, relative.
const TOLERANCE: f64 = 0.07;
/// Most pixels of a frame that may see another face than VRRT's tracer (ties at edges).
const MOST_TIES: f64 = 0.01;
/// Every how many frames PNGs are written (and the last frame).
const PNG_EVERY: u32 = 8;
/// Frames by default: at least 24 of the moving scene.
const FRAMES: u32 = 24;
/// The scenes run by default and their sizes (see the module docs for the room's).
const DEFAULT_SCENES: [(&str, (u32, u32)); 2] = [("bunny", (64, 36)), ("room", (96, 54))];

/// What to run: `--scene NAME` (repeatable), `--frames N`, `--size WxH`. Other arguments (what
/// `cargo test` may pass, e.g. `--nocapture`) are ignored.
struct Options {
    scenes: Vec<(String, (u32, u32))>,
    frames: u32,
}

impl Options {
    fn from_args() -> Result<Options, Box<dyn Error>> {
        let (mut names, mut size, mut frames) = (Vec::new(), None, FRAMES);
        let mut args = std::env::args().skip(1);
        while let Some(arg) = args.next() {
            let mut value = || args.next().ok_or(format!("{arg} needs a value"));
            match arg.as_str() {
                "--scene" => names.push(value()?),
                "--frames" => frames = value()?.parse()?,
                "--size" => size = Some(vrrt_cli::session::parse_size(&value()?)?),
                _ => {}
            }
        }
        if frames == 0 {
            return Err("--frames must be at least 1".into());
        }
        let mut scenes: Vec<_> = DEFAULT_SCENES
            .iter()
            .filter(|(name, _)| names.is_empty() || names.iter().any(|n| n == name))
            .map(|&(name, size)| (name.to_string(), size))
            .collect();
        scenes.extend(
            names
                .into_iter()
                .filter(|n| !DEFAULT_SCENES.iter().any(|(d, _)| d == n))
                .map(|n| (n, (64, 36))),
        );
        if let Some(size) = size {
            scenes.iter_mut().for_each(|s| s.1 = size);
        }
        Ok(Options { scenes, frames })
    }
}

fn main() -> Result<(), Box<dyn Error>> {
    let opts = Options::from_args()?;
    let app = match open_device(validation())? {
        Ok(app) => app,
        Err(why) if !require_vulkan() => {
            println!("skipped: no Vulkan adapter ({why})");
            return Ok(());
        }
        Err(why) => return Err(format!("VRRT_REQUIRE_VULKAN=1 but: {why}").into()),
    };
    println!("adapter: {}", app.adapter);
    let out = output_dir()?;
    // `vrrt run`'s side: the CPU backend (its default) and the reference cache, whose references
    // both sides are measured against.
    let (mut cpu, _) = Backend::open(BackendKind::Cpu, false)?;
    let refs = References::from_env(false);
    for (name, size) in &opts.scenes {
        let Some(scene) = load_scene(name)? else {
            continue;
        };
        let frames = opts.frames.min(scene.scene.frames_available());
        let start = Instant::now();
        let ours = raster_sequence(&app, &scene, *size, frames)?;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        println!(
            "{name} {}x{}: {frames} frames rasterized and denoised in {ms:.0} ms; G-buffer against \
             VRRT's: {} of {} pixels on other faces, {} against the sky, 0 errors",
            size.0, size.1, ours.agreement.face_ties, ours.agreement.pixels, ours.agreement.sky_ties
        );
        let errors = measure(&mut cpu, &refs, &scene, *size, &ours.denoised)?;
        let run = vrrt_run(&mut cpu, &refs, &scene, *size, frames)?;
        write_pngs(&out, &scene, *size, &ours.denoised, (&mut cpu, &refs))?;
        report(&scene.key, (*size, frames), &errors, &run, ours.agreement)?;
    }
    println!("PNGs in {}", out.display());
    Ok(())
}

/// The scene `name` and the key its references are cached under, as `vrrt run --scene name`
/// loads it; `None` (with a message) for a mesh scene whose mesh was not fetched.
fn load_scene(name: &str) -> Result<Option<LoadedScene>, Box<dyn Error>> {
    match vrrt_scene::builtin::builtin(name) {
        Ok(scene) => {
            scene.validate()?;
            Ok(Some(LoadedScene {
                scene,
                key: name.to_string(),
            }))
        }
        Err(e @ SceneError::MeshNotFetched { .. }) => {
            println!("{name}: skipped: {e}");
            Ok(None)
        }
        Err(e) => Err(e.into()),
    }
}

/// What the engine made of a sequence.
struct Sequence {
    /// The denoised AO of each frame.
    denoised: Vec<Vec<f32>>,
    /// Its decoded G-buffers against VRRT's ray-traced ones, all frames together.
    agreement: Agreement,
}

/// Frames `0..frames` of `scene` rasterized and denoised on the application's device; each
/// frame's decoded G-buffer is checked against VRRT's ray-traced one.
fn raster_sequence(
    app: &AppDevice,
    scene: &LoadedScene,
    size: (u32, u32),
    frames: u32,
) -> Result<Sequence, Box<dyn Error>> {
    let settings = CONFIG.settings(Settings::default(), 1.0, SIGNAL);
    let sc = &scene.scene;
    let mut engine = RasterDenoiser::new(&app.device, &app.queue, sc, size, SIGNAL, settings)?;
    let mut seq = Sequence {
        denoised: Vec::new(),
        agreement: Agreement::default(),
    };
    for i in 0..frames {
        let f = sc.frame(i);
        seq.denoised.push(engine.render(sc, &f)?);
        let a = agreement::compare(&engine.read_inputs()?, &agreement::traced(&f, size));
        if a.errors > 0 {
            let p = a.first_error.unwrap_or(0) as u32;
            return Err(format!(
                "{} frame {i}: {} pixels decode to another depth, normal or motion than VRRT's \
                 G-buffer has on the same face (the first at ({}, {}))",
                scene.key,
                a.errors,
                p % size.0,
                p / size.0
            )
            .into());
        }
        let ties = a.face_ties + a.sky_ties;
        if ties as f64 > MOST_TIES * a.pixels as f64 {
            return Err(format!("{} frame {i}: {ties} pixels see other faces", scene.key).into());
        }
        seq.agreement = seq.agreement.plus(a);
    }
    let errors = engine.executor().validation_errors();
    if errors > 0 {
        let log = engine.executor().validation_log().messages();
        return Err(format!("{errors} validation errors: {log:?}").into());
    }
    Ok(seq)
}

/// The reference of frame `i` of `scene` that `vrrt run` measures against (from the cache, or
/// traced on `cpu` and stored).
fn reference(
    cpu: &mut Backend,
    refs: &References,
    scene: &LoadedScene,
    size: (u32, u32),
    i: u32,
) -> Result<Image, Box<dyn Error>> {
    let frame = scene.scene.frame(i);
    let request = ReferenceRequest {
        scene_key: &scene.key,
        frame: &frame,
        size,
        signal: SIGNAL,
        reflections: &Settings::default().reflections,
        spp: SPP,
    };
    Ok(refs.get(cpu, request)?.image)
}

/// relMSE of each denoised frame against its reference, as `vrrt run` computes it.
fn measure(
    cpu: &mut Backend,
    refs: &References,
    scene: &LoadedScene,
    (w, h): (u32, u32),
    denoised: &[Vec<f32>],
) -> Result<Vec<f64>, Box<dyn Error>> {
    (0..denoised.len() as u32)
        .map(|i| {
            let test = planes_to_image(&denoised[i as usize], w, h, 1);
            let r = reference(cpu, refs, scene, (w, h), i)?;
            Ok(metrics::compare(test.view(), r.view())?.rel_mse)
        })
        .collect()
}

/// `vrrt run --scene <key> --size WxH --frames N` (its defaults otherwise): the sequence loop the
/// command runs, on the CPU backend.
fn vrrt_run(
    cpu: &mut Backend,
    refs: &References,
    scene: &LoadedScene,
    size: (u32, u32),
    frames: u32,
) -> Result<SequenceResult, Box<dyn Error>> {
    let base = Settings::default();
    let opts = SequenceOptions {
        size,
        frames,
        signal: SIGNAL,
        spp: SPP,
        base,
        config: CONFIG,
        rpp: base.rates.rays_per_pixel,
        overlays: false,
        measure: true,
    };
    Ok(run_sequence(cpu, scene, &opts, refs, |_| Ok(()))?)
}

/// Prints both relMSEs (whole sequence, and second half) and fails when the example's whole
/// sequence lies more than [`TOLERANCE`] from `vrrt run`'s, unless the rasterizer and the tracer
/// disagreed on the sky somewhere (the module docs say why that is not comparable).
fn report(
    key: &str,
    ((w, h), frames): ((u32, u32), u32),
    ours: &[f64],
    run: &SequenceResult,
    agreement: Agreement,
) -> Result<(), Box<dyn Error>> {
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let (ours_all, ours_half) = (mean(ours), mean(&ours[ours.len() / 2..]));
    let run_all = run.summary().mean_rel_mse;
    let run_half = run.second_half_mean(|r| r.relmse);
    let off = (ours_all - run_all) / run_all;
    println!(
        "{key} {w}x{h}, {frames} frames: relMSE {ours_all:.6} (2nd half {ours_half:.6}); \
         `vrrt run --scene {key} --size {w}x{h} --frames {frames}`: {run_all:.6} (2nd half \
         {run_half:.6}); {:+.2}%",
        off * 100.0
    );
    if agreement.sky_ties > 0 {
        println!(
            "{key}: not compared: {} pixels are a surface in one G-buffer and sky in the other \
             (an outline within a rasterizer's sub-pixel precision of a pixel centre), where the \
             reference is 0",
            agreement.sky_ties
        );
        return Ok(());
    }
    if off.abs() > TOLERANCE {
        return Err(format!(
            "{key}: relMSE {ours_all:.6} is {:+.2}% from vrrt run's {run_all:.6} (at most ±{}%)",
            off * 100.0,
            TOLERANCE * 100.0
        )
        .into());
    }
    Ok(())
}

/// Where the PNGs go: `raster_engine/` beside this program's directory in `target/<profile>/`
/// (examples live in `target/<profile>/examples/`), never outside the build directory.
fn output_dir() -> Result<PathBuf, Box<dyn Error>> {
    let exe = std::env::current_exe()?;
    let profile = exe
        .parent()
        .and_then(Path::parent)
        .ok_or("the program has no directory")?;
    let dir = profile.join("raster_engine");
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}

/// Every [`PNG_EVERY`]th frame's and the last frame's denoised AO and reference.
fn write_pngs(
    out: &Path,
    scene: &LoadedScene,
    (w, h): (u32, u32),
    denoised: &[Vec<f32>],
    (cpu, refs): (&mut Backend, &References),
) -> Result<(), Box<dyn Error>> {
    let last = denoised.len() as u32 - 1;
    for i in (0..=last).filter(|&i| i % PNG_EVERY == 0 || i == last) {
        let stem = format!("{}_{w}x{h}_frame{i:04}", scene.key);
        let test = planes_to_image(&denoised[i as usize], w, h, 1);
        write_png(out.join(format!("{stem}_denoised.png")), test.view())?;
        let r = reference(cpu, refs, scene, (w, h), i)?;
        write_png(out.join(format!("{stem}_reference.png")), r.view())?;
    }
    Ok(())
}
