//! End to end, the backends agree: the built-in `room` scene, rendered through full
//! VRRT at 1 ray per pixel (what `vrrt run` does by default) for [`FRAMES`] frames of each signal
//! (AO, shadows, reflections), gives on every available Vulkan backend (wgpu, ash) a denoised
//! output within [`MIN_PSNR`] dB of the CPU backend's, frame by frame.
//!
//! Why a sequence and not only the kernels: the GPU kernels evaluate `exp2`, `log2` and `rsqrt`
//! natively and may fuse multiply-adds, so each kernel agrees with the CPU only within a tolerance
//! (`tests/equivalence.rs`). Over a sequence those last-bit differences are fed back through the
//! temporal history, and a float that decides an integer (a pixel's ray count, a work list) can
//! flip and send the frames apart. This test bounds that growth over the scene's animation, which
//! must include the camera's motion and its cut (checked, so a shorter animation cannot pass
//! vacuously).
//!
//! The size is small enough for lavapipe in a debug build ([`SIZE`]). GPU backends run with the
//! validation layers on and any validation error fails the test. Without a Vulkan adapter the GPU rows print
//! "skipped: no Vulkan adapter", unless `VRRT_REQUIRE_VULKAN=1`.

mod gpu;

use std::time::Instant;
use vrrt_backend::{Backend, BackendKind};
use vrrt_cli::session::Config;
use vrrt_core::executor::Executor;
use vrrt_core::settings::Settings;
use vrrt_scene::events::EventKind;
use vrrt_scene::image::ImageRef;
use vrrt_scene::metrics::{self, psnr_from_mse};
use vrrt_scene::render::{Readback, Renderer, Signal};
use vrrt_scene::scene::Scene;

/// Image size. The sequence's events are frames, so any size has them all; the size sets how
/// many pixels can diverge. At a quarter of these pixels lavapipe matched the CPU bit for bit in
/// most frames, which tested little; this size still suits a debug build on lavapipe.
const SIZE: (u32, u32) = (128, 72);
/// Frames of each signal: the room's camera cut (frame 60) and the motion on either side of it.
const FRAMES: u32 = 96;
/// The bound of issue 45, per frame. Not to be loosened to make a backend pass: a frame below it
/// is a divergence to report.
const MIN_PSNR: f64 = 60.0;

/// One frame of one backend: the denoised planes (plane-stacked) and the rays it traced, which
/// tells a flipped ray-count decision from a drift in the filters.
struct Frame {
    denoised: Vec<f32>,
    rays_traced: u64,
}

/// The three signals, with the CLI's defaults (AO radius 1, default reflection settings).
fn signals() -> [(&'static str, Signal); 3] {
    [
        ("ao", Signal::Ao { max_distance: 1.0 }),
        ("shadows", Signal::Shadows),
        ("reflections", Signal::Reflections),
    ]
}

/// Checks that the first [`FRAMES`] frames hold the camera's motion and its cut, and prints the
/// scene's events with whether the sequence reaches them.
fn check_sequence_events(scene: &Scene) {
    let events = scene.events();
    for e in &events {
        let inside = if e.frame < FRAMES {
            ""
        } else {
            " (not rendered)"
        };
        println!("event: frame {:>3} {}{inside}", e.frame, e.label);
    }
    assert!(
        events
            .iter()
            .any(|e| e.kind == EventKind::CameraCut && e.frame < FRAMES),
        "no camera cut within the first {FRAMES} frames"
    );
    let moving = (1..FRAMES).any(|i| {
        let f = scene.frame(i);
        !f.camera_cut && f.camera != f.prev_camera
    });
    assert!(
        moving,
        "the camera does not move within the first {FRAMES} frames"
    );
}

/// Renders [`FRAMES`] frames of `signal` on `exec` with the settings of `vrrt run`'s default
/// configuration (full VRRT, 1 ray per pixel), à-trous (its first two iterations fused) and the
/// detector from workgroup tiles on ash (both paths of each are held to the CPU's frames: wgpu
/// takes the default ones).
fn render(exec: &mut Backend, scene: &Scene, signal: Signal) -> Vec<Frame> {
    let mut settings = Config::Vrrt.settings(Settings::default(), 1.0, signal);
    let tiles = exec.name() == "ash";
    settings.filter.workgroup_tiles = tiles;
    settings.detector.workgroup_tiles = tiles;
    settings.filter.fused_pair = tiles;
    let (w, h) = SIZE;
    let mut r = Renderer::new(exec, w, h, signal, scene.lights.len(), settings)
        .unwrap_or_else(|e| panic!("{}: cannot create the renderer: {e}", exec.name()));
    (0..FRAMES)
        .map(|i| {
            let out = r
                .render(exec, &scene.frame(i), Readback::default())
                .unwrap_or_else(|e| panic!("{}: frame {i}: {e}", exec.name()));
            Frame {
                denoised: out.denoised,
                rays_traced: out.rays_traced,
            }
        })
        .collect()
}

/// The PSNR peak of a reference frame. AO and shadow visibility lie in `[0, 1]`: the peak is 1,
/// the range, as in `vrrt_scene::metrics` (`PSNR_PEAK`), so these numbers read like every other
/// PSNR the project reports and a dark frame is not judged harder than a bright one. Reflections
/// are HDR radiance with no fixed range: the peak is the CPU frame's largest finite value, so
/// 60 dB means an RMS difference of a thousandth of the frame's brightest pixel, whatever the
/// scene's exposure.
fn peak(signal: Signal, reference: &[f32]) -> f64 {
    match signal {
        Signal::Reflections => reference
            .iter()
            .filter(|v| v.is_finite())
            .fold(0.0f32, |m, &v| m.max(v))
            .max(f32::MIN_POSITIVE) as f64,
        _ => 1.0,
    }
}

/// One frame's agreement: the mean squared error divided by the peak squared (the PSNR is
/// `psnr_from_mse` of it), and the non-finite values of the test frame.
fn normalized_mse(signal: Signal, test: &[f32], reference: &[f32]) -> (f64, usize) {
    // Plane-stacked planes as one image of `planes × height` rows: the pixelwise metrics do not
    // care about the layout.
    let rows = test.len() / SIZE.0 as usize;
    let image = |d| ImageRef::new(d, SIZE.0 as usize, rows, 1).expect("frame shape");
    let m = metrics::compare(image(test), image(reference)).expect("same shape");
    let p = peak(signal, reference);
    (m.mse / (p * p), m.non_finite)
}

/// A backend's agreement over a sequence: the lowest frame, the mean, the frames equal bit for
/// bit and the first that is not (where the sequence starts to diverge), and what failed.
struct Summary {
    min: (f64, u32),
    mean: f64,
    exact_frames: u32,
    first_inexact: Option<u32>,
    failures: Vec<String>,
}

/// Compares a GPU backend's frames with the CPU backend's. The mean is the PSNR of the mean
/// normalized MSE (`psnr_from_mse`), since identical frames have an infinite PSNR.
fn summarize(signal: (&str, Signal), backend: &str, cpu: &[Frame], gpu: &[Frame]) -> Summary {
    let mut s = Summary {
        min: (f64::INFINITY, 0),
        mean: 0.0,
        exact_frames: 0,
        first_inexact: None,
        failures: Vec::new(),
    };
    let mut sum = 0.0;
    for (i, (c, g)) in cpu.iter().zip(gpu).enumerate() {
        let (mse, non_finite) = normalized_mse(signal.1, &g.denoised, &c.denoised);
        let psnr = psnr_from_mse(mse);
        sum += mse;
        if g.denoised == c.denoised {
            s.exact_frames += 1;
        } else {
            s.first_inexact.get_or_insert(i as u32);
        }
        if psnr < s.min.0 || psnr.is_nan() {
            s.min = (psnr, i as u32);
        }
        // A NaN PSNR (no finite pixel left) fails too.
        if psnr.is_nan() || psnr < MIN_PSNR || non_finite > 0 {
            s.failures.push(format!(
                "{} on {backend}, frame {i}: PSNR {psnr:.2} dB < {MIN_PSNR} dB \
                 ({non_finite} non-finite; rays traced cpu {} vs {})",
                signal.0, c.rays_traced, g.rays_traced
            ));
        }
    }
    s.mean = psnr_from_mse(sum / cpu.len() as f64);
    s
}

#[test]
fn every_backend_agrees_with_the_cpu_over_the_animated_sequence() {
    let start = Instant::now();
    let scene = vrrt_scene::builtin::builtin("room").unwrap();
    check_sequence_events(&scene);
    let mut backends = gpu::backends();
    let mut failures = Vec::new();
    for signal in signals() {
        let t = Instant::now();
        let mut cpu_backend = Backend::open(BackendKind::Cpu, false).unwrap().0;
        let cpu = render(&mut cpu_backend, &scene, signal.1);
        println!(
            "\n{} ({FRAMES} frames at {}x{}; cpu {:.1} s)",
            signal.0,
            SIZE.0,
            SIZE.1,
            t.elapsed().as_secs_f64()
        );
        println!(
            "  {:<7} {:>11} {:>6} {:>8} {:>6} {:>8} {:>7}",
            "backend", "min PSNR dB", "frame", "mean dB", "exact", "first ≠", "time s"
        );
        for b in backends.iter_mut() {
            let t = Instant::now();
            let gpu = render(b, &scene, signal.1);
            let s = summarize(signal, b.name(), &cpu, &gpu);
            println!(
                "  {:<7} {:>11.2} {:>6} {:>8.2} {:>6} {:>8} {:>7.1}",
                b.name(),
                s.min.0,
                s.min.1,
                s.mean,
                format!("{}/{FRAMES}", s.exact_frames),
                s.first_inexact.map_or("-".into(), |f| f.to_string()),
                t.elapsed().as_secs_f64()
            );
            failures.extend(s.failures);
        }
    }
    failures.extend(gpu::validation_failures(&backends));
    println!("\ntotal {:.1} s", start.elapsed().as_secs_f64());
    // The bound of issue 45 stays at 60 dB: a frame below it is a finding, not a tolerance to tune.
    assert!(
        failures.is_empty(),
        "frames below {MIN_PSNR} dB or validation errors ({}):\n{}",
        failures.len(),
        failures.join("\n")
    );
}
