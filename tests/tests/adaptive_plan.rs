//! The adaptive frame plan (skip what a scene does not need) against the same frames with nothing
//! skipped, on the CPU backend: a still, converged scene (2 rays a pixel, history complete: still
//! history is `2 · max_history` = 128 rays, reached by frame 64) saves at least 75% of its rays
//! and skips the gradient prepass, within 30% of the error of a run that spends its whole budget
//! forever (which keeps adding rays to its history: `docs/algorithms/adaptive-plan.md`);
//! on the moving scene the skipped filter work costs less than 2%; a signal without a source
//! costs no pass.

use vrrt_core::executor::Executor;
use vrrt_core::settings::{FilterSettings, PrepassSettings, RateSettings, Settings};
use vrrt_cpu::CpuExecutor;
use vrrt_scene::render::{reference, Readback, ReferenceSpec, Renderer, Signal};

const SIZE: (u32, u32) = (128, 72);
const SIGNAL: Signal = Signal::Ao { max_distance: 1.0 };

/// Nothing skipped: every still pixel keeps its rays, every tile runs every filter iteration,
/// and saved rays are spent.
fn unskipped(rays_per_pixel: f32) -> Settings {
    Settings {
        rates: RateSettings {
            rays_per_pixel,
            still_sigma: 0.0,
            ..Default::default()
        },
        filter: FilterSettings {
            skip_sigma: 0.0,
            ..Default::default()
        },
        prepass: PrepassSettings {
            stratum: 4,
            ..Default::default()
        },
        ..Settings::default()
    }
}

struct Run {
    rel_mse: f64,
    traced_over_budget: f64,
    prepass_runs: u32,
    tile_iterations: f64,
}

/// Mean relMSE over the reference frames, and what was traced and run over `measure`.
fn run(
    scene: &str,
    settings: Settings,
    frames: u32,
    measure: std::ops::Range<u32>,
    refs: &[(u32, Vec<f32>)],
) -> Run {
    let scene = vrrt_scene::builtin::builtin(scene).unwrap();
    let mut exec = CpuExecutor::new();
    let mut r = Renderer::new(&mut exec, SIZE.0, SIZE.1, SIGNAL, 0, settings).unwrap();
    let (mut err, mut traced, mut budget, mut runs) = (0.0, 0u64, 0.0f64, 0);
    let (mut tiles_run, mut tiles_full) = (0u64, 0u64);
    for i in 0..frames {
        let out = r
            .render(&mut exec, &scene.frame(i), Readback::default())
            .unwrap();
        if let Some((_, reference)) = refs.iter().find(|(f, _)| *f == i) {
            err += out
                .denoised
                .iter()
                .zip(reference)
                .map(|(&a, &b)| (a as f64 - b as f64).powi(2) / ((b as f64).powi(2) + 1e-2))
                .sum::<f64>()
                / reference.len() as f64;
        }
        if measure.contains(&i) {
            traced += out.rays_traced;
            budget += out.budget;
            runs += out.gradient_ran as u32;
            let (run, configured) = out.filter_work();
            tiles_run += run;
            tiles_full += configured;
        }
    }
    Run {
        rel_mse: err / refs.len() as f64,
        traced_over_budget: traced as f64 / budget,
        prepass_runs: runs,
        tile_iterations: tiles_run as f64 / tiles_full as f64,
    }
}

fn references(scene: &str, frames: impl Iterator<Item = u32>) -> Vec<(u32, Vec<f32>)> {
    let scene = vrrt_scene::builtin::builtin(scene).unwrap();
    let mut exec = CpuExecutor::new();
    frames
        .map(|i| {
            let r = reference(
                &mut exec,
                &scene.frame(i),
                (SIZE.0, SIZE.1),
                ReferenceSpec {
                    signal: SIGNAL,
                    reflections: &Default::default(),
                    spp: 256,
                },
                |_, _| {},
            );
            (i, r.unwrap().mean)
        })
        .collect()
}

#[test]
fn still_converged_scene_saves_rays_and_the_prepass() {
    let refs = references("room_static", (96..112).step_by(4));
    let full = run("room_static", unskipped(2.0), 112, 96..112, &refs);
    let save = Settings {
        rates: RateSettings {
            rays_per_pixel: 2.0,
            spend_saved_rays: false,
            ..Default::default()
        },
        prepass: PrepassSettings {
            stratum: 4,
            ..Default::default()
        },
        ..Settings::default()
    };
    let adaptive = run("room_static", save, 112, 96..112, &refs);
    println!(
        "still scene: relMSE {:.6} unskipped, {:.6} adaptive ({:+.1}%); rays traced {:.1}% of the \
         budget; filter tile-iterations run {:.1}%; prepass ran {} times",
        full.rel_mse,
        adaptive.rel_mse,
        100.0 * (adaptive.rel_mse / full.rel_mse - 1.0),
        100.0 * adaptive.traced_over_budget,
        100.0 * adaptive.tile_iterations,
        adaptive.prepass_runs
    );
    assert!(
        adaptive.traced_over_budget <= 0.25,
        "fewer than 75% of rays saved"
    );
    assert!(
        adaptive.rel_mse <= 1.3 * full.rel_mse,
        "error up by more than 30%"
    );
    assert_eq!(adaptive.prepass_runs, 0, "the prepass ran on a still scene");
    assert!(adaptive.tile_iterations < 0.5, "the filter skipped little");
    assert!(full.traced_over_budget > 0.95 && full.tile_iterations == 1.0);
}

#[test]
fn moving_scene_loses_nothing_to_skipping() {
    let refs = references("room", (40..64).step_by(4));
    let full = run("room", unskipped(1.0), 64, 40..64, &refs);
    let adaptive = run(
        "room",
        Settings {
            prepass: PrepassSettings {
                stratum: 4,
                ..Default::default()
            },
            ..Settings::default()
        },
        64,
        40..64,
        &refs,
    );
    println!(
        "moving scene: relMSE {:.6} unskipped, {:.6} adaptive ({:+.2}%); filter tile-iterations \
         run {:.1}%",
        full.rel_mse,
        adaptive.rel_mse,
        100.0 * (adaptive.rel_mse / full.rel_mse - 1.0),
        100.0 * adaptive.tile_iterations
    );
    assert!(
        adaptive.rel_mse <= 1.02 * full.rel_mse,
        "error up by more than 2%"
    );
    assert!(adaptive.tile_iterations < 0.9, "the filter skipped little");
}

#[test]
fn a_signal_without_a_source_costs_no_pass() {
    let scene = vrrt_scene::builtin::builtin("room").unwrap();
    let mut exec = CpuExecutor::new();
    let mut r = Renderer::new(&mut exec, 32, 18, Signal::Shadows, 1, Settings::default()).unwrap();
    let mut dark = scene.frame(0);
    dark.lights.clear();
    exec.clear_timings();
    let out = r.render(&mut exec, &dark, Readback::default()).unwrap();
    assert!(out.signal_absent);
    assert_eq!(out.rays_traced, 0);
    assert!(
        exec.timings().is_empty(),
        "passes ran: {:?}",
        exec.timings()
    );
    assert!(out.denoised.iter().all(|&v| v == 1.0));
    // Back with a light: a fresh start, traced and denoised.
    let out = r
        .render(&mut exec, &scene.frame(1), Readback::default())
        .unwrap();
    assert!(!out.signal_absent && out.rays_traced > 0);
    assert!(out.denoised.iter().all(|v| v.is_finite()));
}
