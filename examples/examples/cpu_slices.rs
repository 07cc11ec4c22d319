//! VRRT-rs from plain slices on the CPU backend: G-buffer and noisy AO samples in, the denoised
//! image and the rays to trace out. No GPU, no unsafe; the CPU backend runs the very kernels the
//! GPU backends run.
//!
//! `cargo run --release -p vrrt-examples --example cpu_slices`

use vrrt_core::denoiser::Denoiser;
use vrrt_core::executor::Executor;
use vrrt_core::kernels::balance::Balance;
use vrrt_core::payload::{PackedFiltered, PackedSample};
use vrrt_cpu::CpuExecutor;
use vrrt_examples::{
    frame_info, gbuffer, read, settings, trace, truth, values, FRAMES, HEIGHT, PIXELS, WIDTH,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut cpu = CpuExecutor::new();
    // Allocates every buffer once, for this resolution.
    let mut denoiser =
        Denoiser::new(&mut cpu, WIDTH, HEIGHT, settings()).map_err(|e| e.to_string())?;
    let (mut raw_error, mut denoised_error) = (0.0, 0.0);
    for frame in 0..FRAMES {
        // 1. This frame's cameras and G-buffer (the application's depth, normal + roughness and
        //    motion images).
        denoiser.begin_frame(&mut cpu, frame_info(frame))?;
        for (id, bytes) in gbuffer(frame).uploads(denoiser.inputs()) {
            cpu.write_buffer(id, bytes)?;
        }
        // 2. Where the rays go: `rays[i]` rays at pixel `i` this frame.
        denoiser.plan_rays(&mut cpu)?;
        let rays = denoiser.read_rays(&mut cpu)?;
        let decision: Vec<Balance> = read(&mut cpu, denoiser.decision(), 1)?;
        // 3. The application traces them and hands over the noisy samples (`&[Sample]`).
        let samples = trace(frame, &rays);
        cpu.write_buffer(denoiser.samples(), bytemuck::cast_slice(&samples))?;
        // 4. Accumulate and filter: the denoised image.
        denoiser.resolve(&mut cpu)?;
        let denoised = values(&read::<PackedFiltered, CpuExecutor>(
            &mut cpu,
            denoiser.output(),
            PIXELS,
        )?);

        let total: u32 = rays.iter().sum();
        let max = rays.iter().max().copied().unwrap_or(0);
        let (raw, clean) = errors(&truth(frame), &samples, &denoised);
        println!(
            "frame {frame}: {total} rays ({:.2} per pixel, up to {max}), RMSE raw {raw:.3}, denoised {clean:.3}",
            total as f32 / PIXELS as f32
        );
        // The balancer keeps the expected rays within the budget (1 ray per pixel); fractional
        // rates are rounded per pixel by blue noise, so the rays traced are close to it.
        let d = decision[0];
        assert!(d.granted <= d.budget * (1.0 + 1e-5), "over budget: {d:?}");
        raw_error += raw;
        denoised_error += clean;
    }
    // A real check, not a smoke test: the denoiser removes most of the noise.
    assert!(
        denoised_error < 0.25 * raw_error,
        "denoised RMSE {denoised_error} not well below raw {raw_error}"
    );
    println!(
        "ok: denoised error {:.0}% of raw",
        100.0 * denoised_error / raw_error
    );
    Ok(())
}

/// RMSE against the truth of the raw samples (pixels that traced rays) and of the denoised image.
fn errors(truth: &[f32], samples: &[PackedSample], denoised: &[f32]) -> (f32, f32) {
    let rmse = |pairs: Vec<(f32, f32)>| {
        let n = pairs.len().max(1) as f32;
        (pairs.iter().map(|(a, b)| (a - b) * (a - b)).sum::<f32>() / n).sqrt()
    };
    let raw = truth
        .iter()
        .zip(samples.iter().map(|s| s.unpack()))
        .filter(|(_, s)| s.rays > 0)
        .map(|(&t, s)| (t, s.m1));
    let clean = truth.iter().copied().zip(denoised.iter().copied());
    (rmse(raw.collect()), rmse(clean.collect()))
}
