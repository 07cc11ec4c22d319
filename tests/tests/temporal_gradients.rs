//! Reacting to change on the built-in room with moving light and objects, CPU backend: the A-SVGF
//! prepass runs when something moves and is skipped when nothing does, and with either the
//! prepass or the change detector (on by default) VRRT (no variance clamping) tracks the changing
//! shadows better than both VRRT with neither and SVGF with variance clamping, while static
//! regions stay as sharp.

use vrrt_core::settings::{
    DetectorSettings, PrepassSettings, SamplePattern, Settings, TemporalSettings,
};
use vrrt_cpu::CpuExecutor;
use vrrt_scene::render::{reference, Readback, ReferenceSpec, Renderer, Signal};

const SIZE: (u32, u32) = (128, 72);
const FIRST: u32 = 40;
const LAST: u32 = 52;

/// Mean squared error in the moving region (reference changed by more than 0.02 since the
/// previous frame) and in the rest, over frames `FIRST..=LAST`.
fn errors(settings: Settings, refs: &[Vec<f32>]) -> (f64, f64, u32) {
    let scene = vrrt_scene::builtin::builtin("room").unwrap();
    let mut exec = CpuExecutor::new();
    let mut r = Renderer::new(
        &mut exec,
        SIZE.0,
        SIZE.1,
        Signal::Shadows,
        scene.lights.len(),
        settings,
    )
    .unwrap();
    let (mut moving, mut still, mut nm, mut ns, mut ran) = (0.0, 0.0, 0usize, 0usize, 0);
    for i in 0..=LAST {
        let out = r
            .render(&mut exec, &scene.frame(i), Readback::default())
            .unwrap();
        if i < FIRST {
            continue;
        }
        ran += out.gradient_ran as u32;
        let (cur, prev) = (&refs[(i - FIRST + 1) as usize], &refs[(i - FIRST) as usize]);
        for k in 0..cur.len() {
            let e = (out.denoised[k] as f64 - cur[k] as f64).powi(2);
            if (cur[k] - prev[k]).abs() > 0.02 {
                moving += e;
                nm += 1;
            } else {
                still += e;
                ns += 1;
            }
        }
    }
    (moving / nm as f64, still / ns as f64, ran)
}

#[test]
fn detection_beats_variance_clamping_on_moving_shadows() {
    let scene = vrrt_scene::builtin::builtin("room").unwrap();
    let mut exec = CpuExecutor::new();
    let refs: Vec<Vec<f32>> = (FIRST - 1..=LAST)
        .map(|i| {
            let f = scene.frame(i);
            reference(
                &mut exec,
                &f,
                (SIZE.0, SIZE.1),
                ReferenceSpec {
                    signal: Signal::Shadows,
                    reflections: &Default::default(),
                    spp: 256,
                },
                |_, _| {},
            )
            .unwrap()
            .mean
        })
        .collect();
    let neither = DetectorSettings {
        radius: 0,
        ..Default::default()
    };
    let grad = Settings {
        prepass: PrepassSettings {
            stratum: 4,
            scale: 32.0,
            ..Default::default()
        },
        detector: neither,
        ..Settings::default()
    };
    let (g_moving, g_still, ran) = errors(grad, &refs);
    let none = Settings {
        detector: neither,
        ..Settings::default()
    };
    let (v_moving, v_still, _) = errors(none, &refs);
    let (d_moving, d_still, _) = errors(Settings::default(), &refs);
    let svgf = Settings::svgf(1.0);
    let clamp = Settings {
        temporal: TemporalSettings {
            clamp_radius: 1,
            ..svgf.temporal
        },
        ..svgf
    };
    let (c_moving, c_still, _) = errors(clamp, &refs);
    println!("moving-region MSE: VRRT+prepass {g_moving:.5}, VRRT+detector {d_moving:.5}, VRRT {v_moving:.5}, SVGF+clamp {c_moving:.5}");
    println!("static-region MSE: VRRT+prepass {g_still:.6}, VRRT+detector {d_still:.6}, VRRT {v_still:.6}, SVGF+clamp {c_still:.6}");
    assert_eq!(
        ran,
        LAST - FIRST + 1,
        "the prepass runs on every moving frame"
    );
    assert!(g_moving < 0.9 * c_moving, "{g_moving} vs clamp {c_moving}");
    assert!(g_moving < 0.75 * v_moving, "{g_moving} vs VRRT {v_moving}");
    assert!(g_still <= v_still, "{g_still} vs VRRT {v_still}");
    assert!(d_moving < 0.9 * c_moving, "{d_moving} vs clamp {c_moving}");
    assert!(d_moving < 0.75 * v_moving, "{d_moving} vs VRRT {v_moving}");
    assert!(d_still <= 1.02 * v_still, "{d_still} vs VRRT {v_still}");
}

#[test]
fn prepass_and_detector_are_skipped_when_nothing_moves() {
    let scene = vrrt_scene::builtin::builtin("room_static").unwrap();
    let mut exec = CpuExecutor::new();
    let settings = Settings {
        prepass: PrepassSettings {
            stratum: 4,
            ..Default::default()
        },
        ..Settings::default()
    };
    let mut r = Renderer::new(
        &mut exec,
        32,
        18,
        Signal::Shadows,
        scene.lights.len(),
        settings,
    )
    .unwrap();
    r.keep_changes(&mut exec).unwrap();
    for i in 0..4 {
        let out = r
            .render(&mut exec, &scene.frame(i), Readback::default())
            .unwrap();
        assert!(!out.gradient_ran, "frame {i}");
        assert!(
            out.changes.is_empty(),
            "the detector ran on still frame {i}"
        );
        assert_eq!(out.gradient_rays, 0);
    }
}

/// Share of the gradient cells whose re-traced AO ray disagrees with last frame's, over frames
/// `FIRST..=LAST` of the room under `sampling`.
fn changed_cells(sampling: SamplePattern) -> f64 {
    let scene = vrrt_scene::builtin::builtin("room").unwrap();
    let mut exec = CpuExecutor::new();
    let settings = Settings {
        temporal: TemporalSettings {
            sampling,
            ..TemporalSettings::default()
        },
        prepass: PrepassSettings {
            stratum: 4,
            ..PrepassSettings::default()
        },
        ..Settings::default()
    };
    let ao = Signal::Ao { max_distance: 1.0 };
    let mut r = Renderer::new(&mut exec, SIZE.0, SIZE.1, ao, 0, settings).unwrap();
    let (mut changed, mut cells) = (0usize, 0usize);
    for i in 0..=LAST {
        let out = r
            .render(&mut exec, &scene.frame(i), Readback { overlays: true })
            .unwrap();
        if i >= FIRST && out.gradient_ran {
            changed += out.gradient_raw.iter().filter(|&&l| l > 0.0).count();
            cells += out.gradient_raw.len();
        }
    }
    changed as f64 / cells as f64
}

#[test]
fn retrace_recreates_last_frames_rays_under_both_patterns() {
    // Only the box, sphere and light move: a re-trace that drew other numbers than last frame's
    // ray would flip about a third of the binary AO values everywhere.
    for sampling in [SamplePattern::PerPixel, SamplePattern::ScreenBlue] {
        let share = changed_cells(sampling);
        println!("{sampling:?}: {share:.4} of the cells changed");
        assert!(share < 0.05, "{sampling:?}: {share}");
    }
}
