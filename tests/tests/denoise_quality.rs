//! Accuracy of the denoiser against converged ground truth on the built-in moving scene, on the
//! CPU backend: SVGF (fixed 1 ray per pixel) must cut the raw input's error at least tenfold once
//! converged, and VRRT at the same ray budget must beat SVGF while never breaking its budget.

use vrrt_core::kernels::balance::MODE_KEEP;
use vrrt_core::kernels::buckets::{bucket_to_rate, ring_count, ring_id, BUCKET_COUNT};
use vrrt_core::settings::Settings;
use vrrt_cpu::CpuExecutor;
use vrrt_scene::render::{reference, Readback, ReferenceSpec, Renderer, Signal};

const SIZE: (u32, u32) = (160, 90);
const FRAMES: u32 = 48;
const SIGNAL: Signal = Signal::Ao { max_distance: 1.0 };

fn rel_mse(test: &[f32], reference: &[f32]) -> f64 {
    let sum: f64 = test
        .iter()
        .zip(reference)
        .map(|(&a, &b)| (a as f64 - b as f64).powi(2) / ((b as f64).powi(2) + 1e-2))
        .sum();
    sum / test.len() as f64
}

struct Run {
    denoised: f64,
    raw: f64,
    max_overshoot: f64,
    max_allowed: f64,
}

/// Mean relMSE over the odd frames of the second half, and the worst budget overshoot.
fn run(settings: Settings, references: &[(u32, Vec<f32>)]) -> Run {
    let scene = vrrt_scene::builtin::builtin("room").unwrap();
    let mut exec = CpuExecutor::new();
    let mut r = Renderer::new(
        &mut exec,
        SIZE.0,
        SIZE.1,
        SIGNAL,
        scene.lights.len(),
        settings,
    )
    .unwrap();
    let (mut denoised, mut raw) = (0.0, 0.0);
    let (mut max_overshoot, mut max_allowed) = (0.0f64, 0.0f64);
    let mut ring_pixels = vec![0u32; ring_count(SIZE.0, SIZE.1) as usize];
    for y in 0..SIZE.1 {
        for x in 0..SIZE.0 {
            ring_pixels[ring_id(x, y, SIZE.0, SIZE.1) as usize] += 1;
        }
    }
    let largest_ring = *ring_pixels.iter().max().unwrap() as f64;
    for i in 0..FRAMES {
        let out = r
            .render(&mut exec, &scene.frame(i), Readback::default())
            .unwrap();
        let d = out.decisions[0];
        if d.mode != MODE_KEEP {
            assert!(
                d.granted as f64 <= d.budget as f64 * (1.0 + 1e-5),
                "frame {i}: granted {} > budget {}",
                d.granted,
                d.budget
            );
            // The invariant: traced rays exceed the budget by at most one bucket step of one ring
            // (here bounded by the largest ring), fractional rates' noise included.
            let t = d.bucket_threshold.min(BUCKET_COUNT - 2);
            let step = (bucket_to_rate(t + 1) - bucket_to_rate(t)) as f64;
            max_allowed = max_allowed.max(step * largest_ring);
            max_overshoot = max_overshoot.max(out.rays_traced as f64 - d.budget as f64);
        }
        if let Some((_, reference)) = references.iter().find(|(f, _)| *f == i) {
            denoised += rel_mse(&out.denoised, reference);
            raw += rel_mse(&out.raw, reference);
        }
    }
    let n = references.len() as f64;
    Run {
        denoised: denoised / n,
        raw: raw / n,
        max_overshoot,
        max_allowed,
    }
}

#[test]
fn svgf_converges_and_vrrt_beats_it_at_the_same_budget() {
    let scene = vrrt_scene::builtin::builtin("room").unwrap();
    let mut exec = CpuExecutor::new();
    let references: Vec<(u32, Vec<f32>)> = (FRAMES / 2..FRAMES)
        .filter(|i| i % 2 == 1)
        .map(|i| {
            (
                i,
                reference(
                    &mut exec,
                    &scene.frame(i),
                    (SIZE.0, SIZE.1),
                    ReferenceSpec {
                        signal: SIGNAL,
                        reflections: &Default::default(),
                        spp: 256,
                    },
                    |_, _| {},
                )
                .unwrap()
                .mean,
            )
        })
        .collect();
    let svgf = run(Settings::svgf(1.0), &references);
    let vrrt = run(Settings::default(), &references);
    println!("raw 1 rpp relMSE {:.5}", svgf.raw);
    println!(
        "SVGF 1 rpp relMSE {:.5} ({:.1}x lower than raw)",
        svgf.denoised,
        svgf.raw / svgf.denoised
    );
    println!(
        "VRRT 1 rpp relMSE {:.5} ({:.2}x lower than SVGF); max overshoot of traced over budget {:.0} rays (bound {:.0})",
        vrrt.denoised,
        svgf.denoised / vrrt.denoised,
        vrrt.max_overshoot,
        vrrt.max_allowed
    );
    assert!(
        svgf.denoised * 10.0 <= svgf.raw,
        "SVGF is not 10x below raw"
    );
    assert!(
        vrrt.denoised < svgf.denoised,
        "VRRT is not better than SVGF"
    );
    assert!(vrrt.max_overshoot <= vrrt.max_allowed, "budget broken");
}
