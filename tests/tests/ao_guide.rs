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

/// The kept guide (`filter.ao_guide_refresh`) through the march alone, on a frame whose camera
/// is still: a reset frame marches every direction into each pixel with a surface; the next
/// frame finds all of them where they were and adds `refresh` directions, blending the new
/// fraction in by `refresh / (directions + refresh)`; sky holds none.
#[test]
fn a_kept_guide_adds_refresh_directions_a_frame() {
    use vrrt_core::kernels::ao_guide::{self, MarchParams};
    use vrrt_core::packing::unpack_f16x2;
    use vrrt_tests::{guide_cases::still_march_case, run_case};
    let (w, h) = (48, 27);
    let (directions, refresh) = (8, 2);
    let params = MarchParams {
        width: w,
        height: h,
        directions,
        steps: 6,
        radius: 1.0,
        refresh,
        reset: 1,
        first: 0,
        turn: 0.0,
        normal_threshold: 0.9,
        plane_threshold: 0.02,
    };
    let march = |params: MarchParams, prev: &[u32]| {
        let case = still_march_case(w, h, params, prev);
        let out = run_case(&mut CpuExecutor::new(), &case).unwrap();
        out.last()
            .unwrap()
            .iter()
            .map(|&w| unpack_f16x2(w))
            .collect::<Vec<_>>()
    };
    let first = march(params, &vec![0; (w * h) as usize]);
    let words: Vec<u32> = first
        .iter()
        .map(|&(v, n)| vrrt_core::packing::pack_f16x2(v, n))
        .collect();
    let next_params = MarchParams {
        reset: 0,
        first: refresh,
        turn: 0.3,
        ..params
    };
    let next = march(next_params, &words);
    let (d, k) = (directions as f32, refresh as f32);
    let mut surfaced = 0;
    for (&(v0, n0), &(v1, n1)) in first.iter().zip(&next) {
        if n0 == 0.0 {
            assert_eq!((v0, v1, n1), (1.0, 1.0, 0.0), "sky");
            continue;
        }
        surfaced += 1;
        assert_eq!((n0, n1), (d, d + k), "directions held");
        // The new fraction is a whole number of open directions out of `refresh`.
        let fresh = v0 + (v1 - v0) * (d + k) / k;
        let open = fresh * k;
        assert!(
            (open - open.round()).abs() < 0.02 && (0.0..=k).contains(&open.round()),
            "{v0} → {v1}: {open} open directions of {k}"
        );
    }
    assert!(
        surfaced > (w * h / 2) as usize,
        "{surfaced} pixels with a surface"
    );
    assert!(ao_guide::HISTORY * d >= d + k);
}
