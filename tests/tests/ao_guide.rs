//! The AO guide (`vrrt_core::kernels::ao_guide`, `filter.ao_guide_directions`) divides what the
//! AO planes' spatial filter reads and multiplies its output back, through the whole frame on the
//! CPU backend (the kernels' own equivalence across backends is in `equivalence.rs`).

use vrrt_core::settings::{FilterSettings, Settings};
use vrrt_cpu::CpuExecutor;
use vrrt_scene::builtin::builtin;
use vrrt_scene::render::{Readback, Renderer, Signal};

const SIZE: (u32, u32) = (64, 36);
const FRAMES: u32 = 3;
const AO: Signal = Signal::Ao { max_distance: 1.0 };

/// The denoised frames of the room with `settings`.
fn denoised(settings: Settings) -> Vec<Vec<f32>> {
    let scene = builtin("room").expect("built-in scene");
    let mut exec = CpuExecutor::new();
    let (w, h) = SIZE;
    let mut r = Renderer::new(&mut exec, w, h, AO, scene.lights.len(), settings).unwrap();
    (0..FRAMES)
        .map(|i| {
            r.render(&mut exec, &scene.frame(i), Readback::default())
                .unwrap()
                .denoised
        })
        .collect()
}

/// The default settings with the guide's `directions` (0 = off) and `filter` changed.
fn with_guide(directions: u32, filter: FilterSettings) -> Settings {
    Settings {
        filter: FilterSettings {
            ao_guide_directions: directions,
            ..filter
        },
        ..Settings::default()
    }
}

/// Where nothing is filtered (no à-trous iteration, no spatial estimate) each pixel's own
/// history passes through, and dividing it by the guide and multiplying it back must cancel:
/// the frames are those without the guide, to the binary16 roundings of the divided moments,
/// of the filter's output and of the product (three half-ULPs, 1.5e-3 relative).
#[test]
fn the_guide_cancels_where_nothing_is_filtered() {
    let passthrough = FilterSettings {
        atrous_iterations: 0,
        spatial_until: 0.0,
        ao_spatial_until: 0.0,
        wide_until: 0.0,
        ..Settings::default().filter
    };
    let off = denoised(with_guide(0, passthrough));
    let on = denoised(with_guide(16, passthrough));
    for (i, (a, b)) in off.iter().zip(&on).enumerate() {
        for (p, (&x, &y)) in a.iter().zip(b).enumerate() {
            assert!(
                (x - y).abs() <= 1.5e-3 * x.abs() + 1e-6,
                "frame {i}, pixel {p}: {x} without the guide, {y} with it"
            );
        }
    }
}

/// With the filter on, the guide changes the reset frame's image (every pixel there leans on
/// its neighbours), and what it gives stays AO: finite and within [0, 1].
#[test]
fn the_guide_reshapes_the_filtered_image() {
    let filter = Settings::default().filter;
    let off = denoised(with_guide(0, filter));
    let on = denoised(with_guide(16, filter));
    let changed = off[0].iter().zip(&on[0]).filter(|(a, b)| a != b).count();
    assert!(
        changed > off[0].len() / 10,
        "the guide changed {changed} of {} pixels of the reset frame",
        off[0].len()
    );
    for (i, frame) in on.iter().enumerate() {
        for &v in frame {
            assert!(v.is_finite() && (0.0..=1.0).contains(&v), "frame {i}: {v}");
        }
    }
}
