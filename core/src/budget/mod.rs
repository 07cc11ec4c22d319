//! A ray budget in milliseconds: the user sets the time ray tracing may take per frame, and
//! [`MsBudget`] turns it into next frame's rays per pixel from what recent frames cost.
//!
//! Why two estimates: a frame's tracing time is `rays × ms per ray`, and the rays a budget of
//! `r` rays per pixel buys are `r × fill`, fewer than `r × pixels` (empty pixels trace none,
//! save mode leaves rays unspent). Each is estimated from the last frames and the next budget is
//! `target / (ms per ray × fill)`. Fixed costs of a pass (dispatch, the work list) count as
//! part of the per-ray cost; the loop still settles where the time meets the target, since the
//! budget of frame `n + 1` is `r · target / ms(r)`, which converges while the fixed part is
//! below the target.
//!
//! Why the filter: each estimate is the median of the last [`WINDOW`] frames (one slow frame, a
//! hiccup of the OS or the driver, does not move it), followed by an exponential average
//! ([`ALPHA`]) against the noise of the rest; when the median departs from the average by more
//! than [`SNAP`] the average jumps to it, so a step in cost (the camera moves into dense
//! geometry) is followed after two frames instead of ten. The budget rises by at most [`RISE`] a
//! frame and falls at once: a frame over the target is what the user asked to avoid, one under
//! it only costs some rays. Host-side and allocation-free, like the rest of core.

use crate::executor::PassTiming;
use crate::kernels;
use crate::settings::RateSettings;

/// Frames whose median each estimate follows (odd: one outlier is outvoted).
pub const WINDOW: usize = 3;
/// Weight of a new median in the smoothed estimate, when it is within [`SNAP`] of it.
pub const ALPHA: f64 = 0.3;
/// Relative departure of the median from the smoothed estimate from which the estimate jumps to
/// the median (a cost step, not noise).
pub const SNAP: f64 = 0.25;
/// Largest factor by which the budget rises from one frame to the next.
pub const RISE: f32 = 1.25;

/// The entries of the passes that trace the signal's rays (`raygen_*`): their time is what the
/// budget in milliseconds controls.
pub const TRACE_ENTRIES: [&str; 3] = [
    kernels::RAYGEN_AO.entry,
    kernels::RAYGEN_SHADOW.entry,
    kernels::RAYGEN_REFLECT.entry,
];

/// Milliseconds spent in the ray-tracing passes ([`TRACE_ENTRIES`]) among `timings`.
pub fn trace_ms(timings: &[PassTiming]) -> f64 {
    timings
        .iter()
        .filter(|t| TRACE_ENTRIES.contains(&t.entry))
        .map(|t| t.ms)
        .sum()
}

/// What one frame's tracing cost: the feedback of [`MsBudget::update`].
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TraceCost {
    /// The budget the frame ran with, rays per pixel.
    pub rays_per_pixel: f32,
    /// Rays traced, per plane (each signal's rays weighted by its share of the planes, as
    /// `rays_per_pixel` counts them).
    pub rays: u64,
    /// Milliseconds the ray-tracing passes took ([`trace_ms`]).
    pub ms: f64,
}

/// A quantity estimated from recent frames: median of the last [`WINDOW`], then smoothed.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
struct Estimate {
    recent: [f64; WINDOW],
    /// Samples in `recent` (up to `WINDOW`).
    seen: usize,
    /// Where the next sample goes in `recent`.
    next: usize,
    /// The estimate; 0 before the first sample.
    value: f64,
}

impl Estimate {
    fn push(&mut self, x: f64) {
        self.recent[self.next] = x;
        self.next = (self.next + 1) % WINDOW;
        self.seen = (self.seen + 1).min(WINDOW);
        let mut sorted = [0.0; WINDOW];
        sorted[..self.seen].copy_from_slice(&self.recent[..self.seen]);
        let window = &mut sorted[..self.seen];
        window.sort_unstable_by(f64::total_cmp);
        // Of two samples the larger: a higher cost or fill is the safe side of the target.
        let median = window[self.seen / 2];
        if self.value <= 0.0 || (median / self.value - 1.0).abs() > SNAP {
            self.value = median;
        } else {
            self.value += ALPHA * (median - self.value);
        }
    }
}

/// The controller of a ray budget in milliseconds (`rates.budget_ms`): fed each frame's
/// [`TraceCost`], it returns the next frame's rays per pixel, between a floor and a ceiling.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MsBudget {
    target_ms: f64,
    floor: f32,
    ceiling: f32,
    rays_per_pixel: f32,
    /// Milliseconds per ray.
    cost: Estimate,
    /// Rays traced per unit of budget (rays per pixel).
    fill: Estimate,
}

impl MsBudget {
    /// A controller aiming at `target_ms` of tracing per frame with budgets in `floor..=ceiling`
    /// rays per pixel, starting from `start` (clamped to them) until a frame has been measured.
    /// Inputs are expected valid ([`RateSettings::validate`]); a floor above the ceiling is
    /// taken as the ceiling.
    pub fn new(target_ms: f32, floor: f32, ceiling: f32, start: f32) -> Self {
        let floor = floor.min(ceiling);
        MsBudget {
            target_ms: target_ms as f64,
            floor,
            ceiling,
            rays_per_pixel: start.clamp(floor, ceiling),
            cost: Estimate::default(),
            fill: Estimate::default(),
        }
    }

    /// The controller `rates` asks for (`budget_ms`, `budget_floor`, `budget_ceiling`, starting
    /// from `rays_per_pixel`), or `None` when `budget_ms` is 0 (the fixed ray budget).
    pub fn from_settings(rates: &RateSettings) -> Option<Self> {
        (rates.budget_ms > 0.0).then(|| {
            MsBudget::new(
                rates.budget_ms,
                rates.budget_floor,
                rates.budget_ceiling,
                rates.rays_per_pixel,
            )
        })
    }

    /// The budget for the next frame, rays per pixel.
    pub fn rays_per_pixel(&self) -> f32 {
        self.rays_per_pixel
    }

    /// The target, milliseconds of tracing per frame.
    pub fn target_ms(&self) -> f64 {
        self.target_ms
    }

    /// The estimated cost of one ray in milliseconds (0 before the first measured frame).
    pub fn ms_per_ray(&self) -> f64 {
        self.cost.value
    }

    /// Takes one frame's cost and returns the next frame's budget. A frame that says nothing
    /// about the cost (no ray traced, a timing that is zero, negative or not finite: a backend
    /// without timestamps) leaves the budget as it was.
    pub fn update(&mut self, frame: TraceCost) -> f32 {
        let rays = frame.rays as f64;
        let valid = frame.rays > 0
            && frame.ms.is_finite()
            && frame.ms > 0.0
            && frame.rays_per_pixel.is_finite()
            && frame.rays_per_pixel > 0.0;
        if !valid {
            return self.rays_per_pixel;
        }
        self.cost.push(frame.ms / rays);
        self.fill.push(rays / frame.rays_per_pixel as f64);
        let wanted = self.target_ms / (self.cost.value * self.fill.value);
        let rise = self.rays_per_pixel * RISE;
        let next = if wanted.is_finite() {
            (wanted as f32).min(rise)
        } else {
            rise
        };
        self.rays_per_pixel = next.clamp(self.floor, self.ceiling);
        self.rays_per_pixel
    }
}

#[cfg(all(test, feature = "std"))]
mod tests;
