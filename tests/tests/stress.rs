//! Numerical stress suite: the denoiser driven directly with synthetic inputs.
//!
//! Each case owns the samples exactly: after [`Denoiser::plan_rays`] it reads the rays granted per
//! pixel and writes `Sample`s for them into [`Denoiser::samples`] itself (no raygen), over a flat
//! G-buffer plane seen head-on (static camera, exact reprojection) or an all-sky G-buffer. Every
//! case runs on every available backend: the CPU always, wgpu and ash when a Vulkan adapter
//! exists (otherwise "skipped: no Vulkan adapter", unless `VRRT_REQUIRE_VULKAN=1`). Each case
//! prints its measured figure per backend. `VRRT_STRESS_LONG=1` runs the long variants (10,000
//! frames of f16 history instead of 1,000, 4K on every backend for more frames).

#[path = "stress/rig.rs"]
mod rig;

use rig::{hash, long, mean, noise, non_finite, on_every_backend, pattern, plane, sky, Rig};
use std::time::Instant;
use vrrt_core::denoiser::{Denoiser, DenoiserError};
use vrrt_core::settings::{
    FilterSettings, Settings, SettingsError, StoragePrecision, TemporalSettings,
};
use vrrt_core::{binary16, quantize};

/// 1% of samples NaN, +Inf, -Inf, 1e30 or negative for 60 frames: no output pixel is ever
/// non-finite, the counters see every one, and once injection stops the output returns to within
/// 5% of a clean run. Samples are binary16 ([`PackedSample`]): 1e30 saturates to 65504 when
/// packed (counted by neither counter); a negative one is clamped to 0 by the clean-up. The
/// firefly clamp (at the signal's known maximum, 1) is the defence against such finite
/// outliers: without it a 65504 sample would dominate a pixel for thousands of frames.
#[test]
fn non_finite_and_huge_samples_are_contained() {
    let (w, h, inject, recover) = (23, 17, 60u32, 120u32);
    let settings = Settings {
        temporal: TemporalSettings {
            firefly_max: 1.0,
            ..Default::default()
        },
        ..Settings::svgf(1.0)
    };
    let bad = |x: u32, y: u32, z: u32, f: u32| -> Option<u32> {
        let k = hash(x, y, z, f ^ 0x5555);
        (f < inject && k.is_multiple_of(100)).then_some((k / 100) % 5)
    };
    let dirty = |x, y, z, f| match bad(x, y, z, f) {
        Some(0) => (f32::NAN, 0.0),
        Some(1) => (f32::INFINITY, f32::INFINITY),
        Some(2) => (0.5, f32::NEG_INFINITY),
        Some(3) => (1e30, 1e30),
        Some(_) => (-0.25, 0.0625),
        None => pattern(x, y, z, f),
    };
    let (mut drop_expected, mut clamp_expected) = (0, 0);
    for f in 0..inject {
        for y in 0..h {
            for x in 0..w {
                match bad(x, y, 0, f) {
                    Some(4) => clamp_expected += 1,
                    Some(3) => {}
                    Some(_) => drop_expected += 1,
                    None => {}
                }
            }
        }
    }
    on_every_backend("non-finite injection", |b| {
        let mut clean = Rig::new(b, w, h, settings, plane(w, h));
        let mut reference = Vec::new();
        for f in 0..inject + recover {
            clean.frame(b, false, pattern);
            if f >= inject - 1 {
                reference.push(clean.output(b));
            }
        }
        let mut rig = Rig::new(b, w, h, settings, plane(w, h));
        let mut worst_non_finite = 0;
        let (mut err_at_stop, mut err_end, mut recovered_after) = (0.0, 0.0, None);
        for f in 0..inject + recover {
            rig.frame(b, false, dirty);
            let out = rig.output(b);
            worst_non_finite = worst_non_finite.max(non_finite(&out));
            if f >= inject - 1 {
                let r = &reference[(f + 1 - inject) as usize];
                let diff: f64 = out
                    .iter()
                    .zip(r)
                    .map(|(&a, &b)| (a as f64 - b as f64).abs())
                    .sum::<f64>()
                    / out.len() as f64;
                let err = diff / mean(r);
                if f == inject - 1 {
                    err_at_stop = err;
                }
                if err < 0.05 && recovered_after.is_none() {
                    recovered_after = Some(f + 1 - inject);
                }
                err_end = err;
            }
        }
        let [dropped, clamped] = rig.counters(b);
        assert_eq!(worst_non_finite, 0);
        assert_eq!((dropped, clamped), (drop_expected, clamp_expected));
        assert!(
            err_end < 0.05,
            "error {err_end} after {recover} clean frames"
        );
        format!(
            "non-finite outputs 0; dropped {dropped}, clamped {clamped}; error vs clean {:.2}% at \
             stop, < 5% after {} frames, {:.3}% after {recover}",
            err_at_stop * 100.0,
            recovered_after.unwrap(),
            err_end * 100.0
        )
    });
}

/// A noisy static scene with f16 history for 1,000 frames (10,000 with `VRRT_STRESS_LONG=1`):
/// the mean stays within 1e-3 of the f32-history run on the same samples. Then the true value
/// of half the pixels steps up and every pixel reaches its new value to within one f16 unit
/// (no stuck pixel); the figure is the slowest pixel's frame count.
#[test]
fn f16_history_does_not_drift_or_stick() {
    let (w, h) = (16, 16);
    let frames = if long() { 10_000 } else { 1_000 };
    let truth = |x: u32, y: u32| 0.05 + 0.9 * ((x * 5 + y * 3) % 17) as f32 / 16.0;
    let noisy = move |x, y, z, f| {
        let v = truth(x, y) + 0.05 * noise(x, y, z, f);
        (v, v * v)
    };
    let stepped = |x: u32, y: u32| truth(x, y) * 0.8 + if x < w / 2 { 0.15 } else { 0.0 };
    let reference_mean = (0..h)
        .flat_map(|y| (0..w).map(move |x| truth(x, y) as f64))
        .sum::<f64>()
        / (w * h) as f64;
    on_every_backend("f16 drift + stuck", |b| {
        let settings = |storage| Settings {
            temporal: TemporalSettings {
                storage,
                ..Default::default()
            },
            ..Settings::svgf(1.0)
        };
        // The packed history is binary16: its mean is held against the truth. The noise alone
        // leaves about 3e-4 (one standard deviation: 256 pixels, a 64-ray history of ±0.05
        // uniform noise, relative to the mean); a drift would grow with the frames.
        let mut f16_run = Rig::new(b, w, h, settings(StoragePrecision::F16), plane(w, h));
        let mut worst_drift = 0.0f64;
        for f in 0..frames {
            f16_run.frame(b, false, noisy);
            if (f + 1) % (frames / 10) == 0 {
                let m16: Vec<f32> = f16_run.history(b).iter().map(|p| p.m1).collect();
                let drift = (mean(&m16) - reference_mean).abs() / reference_mean;
                worst_drift = worst_drift.max(drift);
            }
        }
        assert!(worst_drift < 1.5e-3, "f16 drift {worst_drift}");

        // Step: noise-free samples at the new values until every pixel holds its value.
        let limit = 10 * 64;
        let mut reached = vec![None; (w * h) as usize];
        for k in 1..=limit {
            f16_run.frame(b, false, |x, y, _, _| {
                let v = stepped(x, y);
                (v, v * v)
            });
            let hist = f16_run.history(b);
            for (i, p) in hist.iter().enumerate() {
                let (x, y) = (i as u32 % w, i as u32 / w);
                let want = binary16::f32_to_f16(stepped(x, y));
                let got = binary16::f32_to_f16(p.m1);
                if reached[i].is_none() && want.abs_diff(got) <= 1 {
                    reached[i] = Some(k);
                }
            }
            if reached.iter().all(Option::is_some) {
                break;
            }
        }
        let stuck = reached.iter().filter(|r| r.is_none()).count();
        assert_eq!(stuck, 0, "{stuck} pixels stuck after {limit} frames");
        let slowest = reached.iter().flatten().max().unwrap();
        format!(
            "{frames} frames: packed f16 history vs truth, worst of 10 checks {worst_drift:.2e}; \
             step reached (±1 f16 unit) by every pixel in {slowest} frames (history 64)"
        )
    });
}

/// The seed's r8 shadow: an unshadowed pixel (1.0) that kept its stale 0.0 history. With unorm8
/// storage and the stuck correction it reaches 1.0; without, rounding swallows the last steps and
/// it never does.
#[test]
fn unorm8_shadow_reaches_one_only_with_the_correction() {
    let (w, h) = (5, 3);
    on_every_backend("unorm8 stuck shadow", |b| {
        let mut figures = Vec::new();
        for correction in [true, false] {
            let settings = Settings {
                temporal: TemporalSettings {
                    storage: StoragePrecision::Unorm8,
                    stuck_correction: correction,
                    ..Default::default()
                },
                ..Settings::svgf(1.0)
            };
            let mut rig = Rig::new(b, w, h, settings, plane(w, h));
            for _ in 0..100 {
                rig.frame(b, false, |_, _, _, _| (0.0, 0.0));
            }
            let mut reached = None;
            let mut last = 0.0;
            for k in 1..=600 {
                rig.frame(b, false, |_, _, _, _| (1.0, 1.0));
                let hist = rig.history(b);
                last = hist.iter().map(|p| p.m1).fold(1.0, f32::min);
                if last == 1.0 {
                    reached = Some(k);
                    break;
                }
            }
            if correction {
                let k = reached.expect("unorm8 with correction never reached 1.0");
                figures.push(format!("with correction 1.0 after {k} frames"));
            } else {
                assert!(reached.is_none(), "reached 1.0 without the correction");
                assert!(last < 0.9, "stuck at {last}");
                figures.push(format!(
                    "without: stuck at {last:.4} ({}/255) after 600 frames",
                    (last * 255.0).round()
                ));
            }
        }
        figures.join("; ")
    });
}

/// HDR extremes, all-black and all-white frames, zero variance and denormals, in f16 and
/// (for [0, 1]) unorm8 storage: outputs are finite and their mean is the input quantized to the
/// format. GPUs may flush f32 denormals to zero; both are accepted there, and reported.
#[test]
fn hdr_extremes_black_white_and_denormals() {
    let (w, h) = (9, 7);
    let cases: &[(StoragePrecision, f32)] = &[
        (StoragePrecision::F16, 0.0),
        (StoragePrecision::F16, 1e-6),
        (StoragePrecision::F16, 1.0),
        (StoragePrecision::F16, 6e4),
        (StoragePrecision::F16, 1e-40),
        (StoragePrecision::Unorm8, 0.0),
        (StoragePrecision::Unorm8, 1.0),
    ];
    on_every_backend("HDR/black/white/denormal", |b| {
        let mut worst = 0.0f64;
        let mut flushed = Vec::new();
        for &(storage, v) in cases {
            let settings = Settings {
                temporal: TemporalSettings {
                    storage,
                    ..Default::default()
                },
                ..Settings::svgf(1.0)
            };
            let mut rig = Rig::new(b, w, h, settings, plane(w, h));
            for _ in 0..6 {
                rig.frame(b, false, |_, _, _, _| (v, v * v));
            }
            let out = rig.output(b);
            assert_eq!(non_finite(&out), 0, "{storage:?} {v}");
            let expected = quantize::quantize(storage.code(), v) as f64;
            let got = mean(&out);
            if v == 1e-40 && got == 0.0 && expected != 0.0 {
                flushed.push(format!("{storage:?}"));
                continue;
            }
            let rel = if expected == 0.0 {
                got.abs()
            } else {
                (got - expected).abs() / expected
            };
            assert!(
                rel < 1e-5,
                "{storage:?} {v}: mean {got}, expected {expected}"
            );
            worst = worst.max(rel);
        }
        // Extremes side by side, noisy: only finiteness is asked.
        let mut rig = Rig::new(b, w, h, Settings::svgf(1.0), plane(w, h));
        for _ in 0..6 {
            rig.frame(b, false, |x, y, z, f| {
                let v = if (x + y) % 2 == 0 { 1e-6 } else { 6e4 } * (1.0 + 0.5 * noise(x, y, z, f));
                (v, v * v)
            });
        }
        assert_eq!(non_finite(&rig.output(b)), 0);
        format!(
            "{} cases finite, worst relative mean error {worst:.1e}; denormal flushed to 0: {}",
            cases.len(),
            if flushed.is_empty() {
                "none".to_string()
            } else {
                flushed.join(", ")
            }
        )
    });
}

/// Degenerate and huge resolutions with full VRRT (balancer, fractional rates), a resize
/// mid-sequence (a new denoiser), a camera cut, a frame with no geometry, and zero sizes.
#[test]
fn resolutions_resize_cut_sky_and_zero_size() {
    let constant = |_, _, _, _| (0.5f32, 0.25f32);
    on_every_backend("resolutions/resize/cut/sky", |b| {
        let mut figures = Vec::new();
        for (w, h) in [(1, 1), (1, 29), (29, 1), (33, 17)] {
            let mut rig = Rig::new(b, w, h, Settings::default(), plane(w, h));
            for _ in 0..8 {
                rig.frame(b, false, constant);
            }
            let out = rig.output(b);
            assert_eq!(non_finite(&out), 0, "{w}x{h}");
            for p in rig.history(b).iter().filter(|p| p.count >= 1.0) {
                assert_eq!(p.m1, 0.5, "{w}x{h}");
            }
        }

        // 4K, one frame (two, with the full filter, with VRRT_STRESS_LONG=1), on every backend:
        // with the engine-native inputs no buffer passes software Vulkan's 128 MiB
        // storage-buffer range (lavapipe's maxStorageBufferRange).
        let (w, h) = (3840, 2160);
        let t = Instant::now();
        // The full filter is ~170 taps a pixel; the CI variant keeps one à-trous pass and the
        // 3×3 variance window, enough to run every pass at 4K.
        let settings = if long() {
            Settings::default()
        } else {
            Settings {
                filter: FilterSettings {
                    atrous_iterations: 1,
                    spatial_radius: 1,
                    ..Default::default()
                },
                ..Settings::default()
            }
        };
        let mut rig = Rig::new(b, w, h, settings, plane(w, h));
        let mut traced = 0;
        for _ in 0..if long() { 2 } else { 1 } {
            traced = rig.frame(b, false, constant);
        }
        let out = rig.output(b);
        assert_eq!(non_finite(&out), 0, "4K");
        figures.push(format!(
            "4K: {traced} rays, finite, {:.1} s",
            t.elapsed().as_secs_f64()
        ));

        // Resize: a new denoiser at another size continues the sequence.
        let mut rig = Rig::new(b, 20, 12, Settings::svgf(1.0), plane(20, 12));
        for _ in 0..10 {
            rig.frame(b, false, constant);
        }
        let mut rig = Rig::new(b, 13, 21, Settings::svgf(1.0), plane(13, 21));
        for _ in 0..10 {
            rig.frame(b, false, constant);
        }
        let m = mean(&rig.output(b));
        assert!((m - 0.5).abs() < 1e-6, "after resize {m}");

        // Camera cut: the reset frame holds only its own samples.
        let mut rig = Rig::new(b, 17, 9, Settings::svgf(1.0), plane(17, 9));
        for _ in 0..20 {
            rig.frame(b, false, |_, _, _, _| (0.2, 0.04));
        }
        rig.frame(b, true, |_, _, _, _| (0.8, 0.64));
        let hist = rig.history(b);
        // 0.8 as the f16 history stores it.
        let stored = quantize::quantize(quantize::STORAGE_F16, 0.8);
        assert!(hist.iter().all(|p| p.m1 == stored && p.count == 1.0));
        let cut_mean = mean(&rig.output(b));
        assert!(
            (cut_mean - stored as f64).abs() < 1e-6,
            "after cut {cut_mean}"
        );

        // No geometry: nothing is traced, nothing is NaN.
        let mut rig = Rig::new(b, 31, 15, Settings::default(), sky(31, 15));
        let mut sky_rays = 0;
        for _ in 0..3 {
            sky_rays += rig.frame(b, false, |_, _, _, _| (f32::NAN, f32::NAN));
        }
        assert_eq!(sky_rays, 0);
        assert_eq!(non_finite(&rig.output(b)), 0);
        assert_eq!(rig.counters(b), [0, 0]);

        // Zero sizes, and more pixels than a work-list entry can index, are a settings error
        // (before any buffer is made), not a panic.
        for (w, h) in [(0, 4), (4, 0), (0, 0), (16385, 16384)] {
            match Denoiser::new(b, w, h, Settings::default()) {
                Err(DenoiserError::Settings(e @ SettingsError::Resolution { .. })) => {
                    if w == 0 && h == 0 {
                        figures.push(format!("0x0: \"{e}\""));
                    }
                }
                other => panic!("{w}x{h}: {other:?}"),
            }
        }
        figures.push("1x1 1x29 29x1 33x17 resize cut sky: finite, exact means".into());
        figures.join("; ")
    });
}

/// Property tests on the core math every kernel shares. The balancer's budget invariant has its
/// own property test next to the balancer (`budget_invariant_over_random_histograms` in
/// `core/src/kernels/balance.rs`) and is not repeated here.
mod properties {
    use proptest::prelude::*;
    use vrrt_core::glam::Vec3;
    use vrrt_core::math;
    use vrrt_core::payload::{self, Payload, Sample};
    use vrrt_core::surface;
    use vrrt_core::{binary16, quantize};

    fn unit() -> impl Strategy<Value = Vec3> {
        (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)
            .prop_filter("non-degenerate", |(x, y, z)| x * x + y * y + z * z > 1e-4)
            .prop_map(|(x, y, z)| Vec3::new(x, y, z).normalize())
    }

    /// A consistent payload: `m2 >= m1²`.
    fn payload() -> impl Strategy<Value = Payload> {
        (0.0f32..1e4, 0.0f32..1.0, 0.0f32..200.0).prop_map(|(m1, spread, count)| Payload {
            m1,
            m2: m1 * m1 * (1.0 + spread),
            count,
            rng_index: 0,
        })
    }

    fn sample() -> impl Strategy<Value = Sample> {
        (0.0f32..1e4, 0.0f32..1.0, 1u32..17).prop_map(|(m1, spread, rays)| Sample {
            m1,
            m2: m1 * m1 * (1.0 + spread),
            rays,
            ..Sample::default()
        })
    }

    fn storage() -> impl Strategy<Value = u32> {
        prop_oneof![Just(quantize::STORAGE_F16), Just(quantize::STORAGE_UNORM8)]
    }

    proptest! {
        /// Edge-stopping weights (normal, plane distance, combined; à-trous luminance uses the
        /// same `exp(-x)` with `x >= 0`) stay in [0, 1].
        #[test]
        fn edge_stopping_weights_are_in_unit_interval(
            n in unit(), m in unit(), power in 0.0f32..256.0,
            p in prop::array::uniform3(-100.0f32..100.0), q in prop::array::uniform3(-100.0f32..100.0),
            scale in 0.0f32..10.0, x in 0.0f32..1e6,
        ) {
            let nw = surface::normal_weight(n, m, power);
            prop_assert!((0.0..=1.0).contains(&nw), "normal {nw}");
            let pw = surface::plane_weight(Vec3::from(p), n, Vec3::from(q), scale);
            prop_assert!((0.0..=1.0).contains(&pw), "plane {pw}");
            let lw = math::exp(-x);
            prop_assert!((0.0..=1.0).contains(&lw), "luminance {lw}");
        }

        /// Merging consistent moments keeps `m2 >= m1²` (up to f32 rounding), and storing at any
        /// precision keeps it exactly (within the format's range).
        #[test]
        fn merged_second_moment_stays_above_mean_squared(
            prev in payload(), s in sample(), storage in storage(),
        ) {
            let merged = payload::accumulate(prev, s, 64.0, 0);
            prop_assert!(merged.m2 >= merged.m1 * merged.m1 * (1.0 - 1e-5), "{merged:?}");
            let stored = payload::store(prev, s, merged, storage);
            // Within the format's range: f16 saturates m2 at 65504 (m1 above ~256).
            let floor = (stored.m1 * stored.m1).min(quantize::max_value(storage));
            prop_assert!(stored.m2 >= floor, "{stored:?}");
            prop_assert!(stored.variance() >= 0.0);
        }

        /// Merging two frames' samples into history gives the same moments in either order
        /// (within f32 rounding) while the history clamp is not reached.
        #[test]
        fn moment_merge_is_order_independent(prev in payload(), a in sample(), b in sample()) {
            let ab = payload::accumulate(payload::accumulate(prev, a, 1e6, 0), b, 1e6, 0);
            let ba = payload::accumulate(payload::accumulate(prev, b, 1e6, 0), a, 1e6, 0);
            prop_assert!((ab.count - ba.count).abs() <= 1e-5 * ab.count, "{ab:?} {ba:?}");
            prop_assert!((ab.m1 - ba.m1).abs() <= 1e-5 * ab.m1.abs().max(1e-30), "{ab:?} {ba:?}");
            prop_assert!((ab.m2 - ba.m2).abs() <= 1e-5 * ab.m2.abs().max(1e-30), "{ab:?} {ba:?}");
        }

        /// The stuck correction never moves a stored value away from the change, nor by more
        /// than one unit past plain rounding.
        #[test]
        fn stuck_correction_moves_toward_the_new_value(
            prev in 0.0f32..70000.0, delta in -1.0f32..1.0, scale in prop_oneof![Just(1e-6f32), Just(1e-3), Just(1.0)],
        ) {
            let accum = (prev + delta * scale * prev.max(1.0)).max(0.0);
            let s = quantize::STORAGE_F16;
            let stored = quantize::store_with_correction(s, accum, prev, accum);
            let (qs, qa) = (binary16::f32_to_f16(stored), binary16::f32_to_f16(quantize::quantize(s, accum)));
            prop_assert!(qs.abs_diff(qa) <= 1);
            let qp = quantize::quantize(s, prev);
            if accum > prev {
                prop_assert!(stored >= qp.min(binary16::F16_MAX));
            } else if accum < prev {
                prop_assert!(stored <= qp);
            }
        }
    }
}
