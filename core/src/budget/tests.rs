//! The controller against synthetic cost sequences: a frame's time is `rays × ms per ray`,
//! with the rays a budget buys at a fixed fill.

use super::*;

/// Rays a budget of one ray per pixel buys (a 100x100 image, a quarter of it empty).
const FILL: f64 = 7500.0;

/// Runs `frames` frames through `b`, the ray cost of frame `i` given by `cost(i)` (ms per
/// ray), and returns each frame's tracing time.
fn simulate(b: &mut MsBudget, frames: usize, cost: impl Fn(usize) -> f64) -> std::vec::Vec<f64> {
    (0..frames)
        .map(|i| {
            let rpp = b.rays_per_pixel();
            let rays = (rpp as f64 * FILL).round() as u64;
            let ms = rays as f64 * cost(i);
            b.update(TraceCost {
                rays_per_pixel: rpp,
                rays,
                ms,
            });
            ms
        })
        .collect()
}

fn controller() -> MsBudget {
    MsBudget::new(1.5, 0.25, 16.0, 1.0)
}

/// First frame from which every later frame is within `tol` of the target.
fn settled(times: &[f64], target: f64, tol: f64) -> usize {
    times
        .iter()
        .rposition(|t| (t / target - 1.0).abs() > tol)
        .map_or(0, |i| i + 1)
}

#[test]
fn meets_the_target_from_the_second_frame() {
    let mut b = controller();
    // 1 rpp would cost 3 ms: the budget halves.
    let times = simulate(&mut b, 10, |_| 3.0 / FILL);
    assert!(settled(&times, 1.5, 0.01) <= 1, "{times:?}");
    assert!((b.rays_per_pixel() - 0.5).abs() < 1e-3);
}

#[test]
fn a_cost_step_up_settles_within_three_frames() {
    let mut b = controller();
    let times = simulate(&mut b, 60, |i| if i < 30 { 1.0 } else { 3.0 } / FILL);
    // The jump frame and the next overshoot (the median needs two frames to see the step).
    assert!(times[30] > 4.0 && times[31] > 4.0, "{:?}", &times[28..36]);
    assert!(settled(&times, 1.5, 0.1) <= 32, "{:?}", &times[28..36]);
    assert!(times[32..].iter().all(|&t| t <= 1.5 * 1.001));
}

#[test]
fn a_cost_step_down_rises_without_overshoot() {
    let mut b = controller();
    let times = simulate(&mut b, 60, |i| if i < 30 { 3.0 } else { 1.0 } / FILL);
    // Rising at most 1.25x a frame: 3x takes five frames, each under the target.
    assert!(
        times[30..].iter().all(|&t| t <= 1.5 * 1.001),
        "{:?}",
        &times[28..40]
    );
    assert!(settled(&times, 1.5, 0.1) <= 37, "{:?}", &times[28..40]);
}

#[test]
fn noise_neither_oscillates_nor_drifts() {
    let mut b = controller();
    // ±10% cost noise, deterministic, and one spike of 4x a frame.
    let noise = |i: usize| {
        let h = (i as u32).wrapping_mul(2_654_435_761) >> 16;
        let spike = if i == 40 { 4.0 } else { 1.0 };
        (0.9 + 0.2 * (h & 0xffff) as f64 / 65535.0) * spike / FILL
    };
    let mut budgets = std::vec::Vec::new();
    for i in 0..80 {
        simulate(&mut b, 1, |_| noise(i));
        budgets.push(b.rays_per_pixel());
    }
    let tail = &budgets[10..];
    let (lo, hi) = tail
        .iter()
        .fold((f32::MAX, 0.0f32), |(lo, hi), &r| (lo.min(r), hi.max(r)));
    // The budget stays within the noise's ±10% (the spike is outvoted by the median).
    assert!(lo > 1.5 / 1.15 && hi < 1.5 / 0.85, "{lo} {hi} {tail:?}");
}

#[test]
fn fixed_costs_converge_to_the_target() {
    // 0.5 ms a frame whatever the rays, plus the rays.
    let mut b = controller();
    let mut times = std::vec::Vec::new();
    for _ in 0..40 {
        let rpp = b.rays_per_pixel();
        let rays = (rpp as f64 * FILL).round() as u64;
        let ms = 0.5 + rays as f64 / FILL;
        b.update(TraceCost {
            rays_per_pixel: rpp,
            rays,
            ms,
        });
        times.push(ms);
    }
    assert!(settled(&times, 1.5, 0.02) < 20, "{times:?}");
}

#[test]
fn floor_and_ceiling_hold() {
    let mut b = controller();
    simulate(&mut b, 10, |_| 100.0 / FILL);
    assert_eq!(b.rays_per_pixel(), 0.25);
    let mut b = controller();
    simulate(&mut b, 40, |_| 0.001 / FILL);
    assert_eq!(b.rays_per_pixel(), 16.0);
    assert_eq!(MsBudget::new(1.0, 0.5, 4.0, 10.0).rays_per_pixel(), 4.0);
}

#[test]
fn useless_timings_keep_the_last_budget() {
    let mut b = controller();
    simulate(&mut b, 5, |_| 3.0 / FILL);
    let good = b.rays_per_pixel();
    for ms in [0.0, -1.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let frame = TraceCost {
            rays_per_pixel: good,
            rays: 1000,
            ms,
        };
        assert_eq!(b.update(frame), good, "ms = {ms}");
    }
    let no_rays = TraceCost {
        rays_per_pixel: good,
        rays: 0,
        ms: 1.0,
    };
    assert_eq!(b.update(no_rays), good);
    for rpp in [0.0, f32::NAN, f32::INFINITY] {
        let frame = TraceCost {
            rays_per_pixel: rpp,
            rays: 1000,
            ms: 1.0,
        };
        assert_eq!(b.update(frame), good, "rpp = {rpp}");
    }
}

#[test]
fn trace_time_sums_only_the_raygen_passes() {
    let t = |entry, ms| PassTiming { entry, ms };
    let timings = [
        t("gbuffer", 5.0),
        t("raygen_ao", 1.0),
        t("atrous", 2.0),
        t("raygen_shadow", 0.5),
        t("raygen_reflect", 0.25),
    ];
    assert_eq!(trace_ms(&timings), 1.75);
}

#[test]
fn off_unless_a_target_is_set() {
    let rates = RateSettings::default();
    assert!(MsBudget::from_settings(&rates).is_none());
    let on = RateSettings {
        budget_ms: 2.0,
        rays_per_pixel: 0.1,
        ..rates
    };
    let b = MsBudget::from_settings(&on).expect("on");
    assert_eq!(b.rays_per_pixel(), on.budget_floor);
    assert_eq!(b.target_ms(), 2.0);
}
