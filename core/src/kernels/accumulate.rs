//! Temporal accumulation: merges this frame's rays into the reprojected history (after raygen).
//!
//! Seed: vrrt-call-of-duty-2026, "Undersampling" (`TemporalAccumulation`) and "Full pipeline"
//! ("temporal accumulation is a good place to do firefly clamping, and variance-based clamp, if you
//! still want to use it"). The variance clamp is the SVGF baseline's history rectification; VRRT
//! relies on temporal gradients instead, and clamps only its reflections, to their own surface.
//!
//! Order per pixel and plane: input clean-up ([`payload::clean`], counted in the counters buffer),
//! firefly clamp, history shortened where [`super::detect`] found a change (dropped on the
//! reflections' plane only where the pixel's own rays confirm it), optional variance
//! clamp of the history, f32 merge, then storage at the history's
//! precision with the stuck correction ([`payload::store`]).

use super::AccumulateIo;
use super::{detect, plane_index};
use crate::lanes::{self, clamp_column, Lanes};
use crate::payload::{
    self, PackedPayload, PackedSample, Payload, PayloadLanes, Sample, SampleLanes,
};
use crate::{atomic, math, packing, quantize};
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Push constants of [`accumulate`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct AccumulateParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// History length clamp, applied after merging (e.g. 64).
    pub max_history: f32,
    /// The rng index wraps at this value (0 = never), matching its storage width.
    pub rng_wrap: u32,
    /// Radius of the neighbourhood of this frame's samples the history mean is clamped to
    /// (`mean ± clamp_gamma · σ`); 0 turns the variance clamp off.
    pub clamp_radius: u32,
    /// Width of the clamp window in standard deviations.
    pub clamp_gamma: f32,
    /// This frame's per-pixel mean is clamped to this (fireflies); 0 or less turns it off.
    pub firefly_max: f32,
    /// Storage precision of the history moments (`quantize::STORAGE_*`, optionally with
    /// `quantize::STORAGE_NO_CORRECTION`); also sets the ceiling samples are clamped to.
    pub storage: u32,
    /// Read `changes` ([`super::detect`]'s `λ`): history is shortened to `count · (1 − λ)`, and
    /// dropped like a disocclusion above `change_threshold`; 0 leaves `changes` unread.
    pub use_changes: u32,
    /// `λ` above which history is dropped.
    pub change_threshold: f32,
    /// `change_threshold` of the planes in `shadow_planes`.
    pub shadow_threshold: f32,
    /// Planes (bit per plane) that take `shadow_threshold` (`Layout::shadow_planes`).
    pub shadow_planes: u32,
    /// On the planes in `shadow_planes`, history is dropped where this frame's rays (two or
    /// more: a verified pixel's, [`super::refill`]) lie this many standard deviations from it
    /// ([`detect::pixel_z`]); 0 turns the test off.
    pub drop_sigma: f32,
    /// Floor of the per-ray variance of that test.
    pub min_variance: f32,
    /// Planes (bit per plane) whose variance clamp takes `surface_clamp_radius` and only the
    /// window's pixels on the pixel's own surface (the reflections' plane).
    pub surface_clamp_planes: u32,
    /// Window radius of that clamp; 0 leaves those planes to `clamp_radius`.
    pub surface_clamp_radius: u32,
    /// Own surface: normals' cosine at least this (`temporal.normal_threshold`)…
    pub normal_threshold: f32,
    /// …and view depths within this fraction of the pixel's.
    pub depth_tolerance: f32,
    /// Planes (bit per plane) where a drop that `λ` asks for needs the pixel's own rays to
    /// confirm it: they must lie `confirm_sigma` standard deviations from the history
    /// ([`detect::pixel_z`]); unconfirmed, the history is kept whole.
    pub confirm_planes: u32,
    /// Significance of that confirmation; 0 turns it off.
    pub confirm_sigma: f32,
}

/// Clamps the history mean to `mean ± gamma·σ` of this frame's traced samples within `radius`
/// of `id` (with `surface`, only those on `id`'s own surface: a window across an edge mixes in
/// another surface's signal), keeping the history's own variance (its second moment moves with
/// the mean).
fn clamp_history(
    id: UVec3,
    p: &AccumulateParams,
    (radius, surface): (u32, bool),
    (samples, depth, normal_roughness): (&[PackedSample], &[f32], &[u32]),
    prev: Payload,
) -> Payload {
    let r = radius as i32;
    let centre = (id.y * p.width + id.x) as usize;
    // Without `surface` the surfaces are not read (the frame binds a placeholder there).
    let (d0, n0) = if surface {
        (
            depth[centre],
            packing::unpack_normal(normal_roughness[centre]),
        )
    } else {
        (0.0, glam::Vec3::Z)
    };
    let (mut s1, mut s2, mut n) = (0.0f32, 0.0f32, 0.0f32);
    let mut dy = -r;
    while dy <= r {
        let mut dx = -r;
        while dx <= r {
            let (qx, qy) = (id.x as i32 + dx, id.y as i32 + dy);
            if qx >= 0 && qy >= 0 && qx < p.width as i32 && qy < p.height as i32 {
                let q = samples
                    [plane_index(UVec3::new(qx as u32, qy as u32, id.z), p.width, p.height)]
                .unpack();
                let qi = (qy as u32 * p.width + qx as u32) as usize;
                let own = !surface || {
                    let m = packing::unpack_normal(normal_roughness[qi]);
                    n0.dot(m) >= p.normal_threshold
                        && math::abs(depth[qi] - d0) <= p.depth_tolerance * d0
                };
                if q.rays > 0 && math::is_finite(q.m1) && own {
                    s1 += q.m1;
                    s2 += q.m1 * q.m1;
                    n += 1.0;
                }
            }
            dx += 1;
        }
        dy += 1;
    }
    if n < 1.0 || prev.count <= 0.0 {
        return prev;
    }
    let mean = s1 / n;
    let sigma = math::sqrt(math::max(s2 / n - mean * mean, 0.0));
    let m1 = math::clamp(
        prev.m1,
        mean - p.clamp_gamma * sigma,
        mean + p.clamp_gamma * sigma,
    );
    Payload {
        m1,
        m2: prev.variance() + m1 * m1,
        ..prev
    }
}

/// The detector's drops, second-guessed by the pixel's own rays on the planes that ask for it:
/// the reflections' unconfirmed drops keep their history, the shadows' verified changes drop
/// it. `prev` is the reprojected history already shortened by `λ`.
#[inline(always)]
fn second_opinions<const N: usize>(
    p: &AccumulateParams,
    z: u32,
    curr: &SampleLanes<N>,
    stored: &PayloadLanes<N>,
    lambda: Lanes<f32, N>,
    threshold: f32,
    prev: &mut PayloadLanes<N>,
) {
    // The reflections' drops: the detector's 1σ window often reads noise as a change, and
    // dropping a converged reflection by chance costs more than the lag of one unconfirmed drop.
    // A pixel the detector drops has rays of its own (the refill lists give them); they decide.
    // A uniform branch, like the one below.
    if p.confirm_sigma > 0.0 && super::plane_in(p.confirm_planes, z) {
        lanes::each_lane!(l in N {
            let (c, m) = (curr.lane(l), stored.lane(l));
            if lambda.0[l] > threshold
                && c.rays > 0
                && detect::pixel_z(c, m, p.min_variance) < p.confirm_sigma
            {
                prev.count.0[l] = m.count;
            }
        });
    }
    // The shadows' verified pixels ([`super::refill`]): a uniform branch, so the other planes
    // pay nothing for the test.
    if p.drop_sigma > 0.0 && super::plane_in(p.shadow_planes, z) {
        lanes::each_lane!(l in N {
            let c = curr.lane(l);
            if c.rays >= 2 && detect::pixel_z(c, stored.lane(l), p.min_variance) >= p.drop_sigma {
                prev.count.0[l] = 0.0;
            }
        });
    }
}

/// One call per `N` consecutive pixels of a row and one signal plane ([`crate::lanes`]):
/// `history = merge(history, samples)`, in place.
#[inline(always)]
pub fn accumulate<const N: usize>(id: UVec3, p: &AccumulateParams, io: AccumulateIo<'_>) {
    let AccumulateIo {
        history,
        samples,
        changes,
        counters,
        depth,
        normal_roughness,
    } = io;
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let (x0, row) = (id.x as i32, (id.z * h + id.y) * w);
    let live = Lanes::<bool, N>::from_index(|l| id.x + l < w);
    let packed = Lanes::<PackedSample, N>::load_row(samples, row, x0, w);
    let (s1, s2) = packing::unpack_f16x2_lanes(packed.map(|s| s.moments));
    let stored = PayloadLanes::unpack(Lanes::<PackedPayload, N>::load_row(history, row, x0, w));
    let lambda = if p.use_changes != 0 {
        Lanes::<f32, N>::load_row(changes, row, x0, w)
    } else {
        Lanes::splat(0.0)
    };
    let max = quantize::max_value(p.storage);
    let threshold = detect::per_plane(
        p.change_threshold,
        p.shadow_threshold,
        p.shadow_planes,
        id.z,
    );
    let mut curr = SampleLanes::<N> {
        m1: Lanes::splat(0.0),
        m2: Lanes::splat(0.0),
        rays: Lanes::splat(0),
    };
    let mut prev = stored;
    let (mut dropped, mut clamped) = (0u32, 0u32);
    lanes::each_lane!(l in N {
        let raw = Sample {
            m1: s1.0[l],
            m2: s2.0[l],
            rays: packed.0[l].rays(),
            first: 0.0,
        };
        let (mut c, what) = payload::clean(raw, max);
        dropped += (live.0[l] && what == payload::CLEAN_DROPPED) as u32;
        clamped += (live.0[l] && what == payload::CLEAN_CLAMPED) as u32;
        if p.firefly_max > 0.0 {
            c.m1 = math::min(c.m1, p.firefly_max);
            c.m2 = math::min(c.m2, p.firefly_max * p.firefly_max);
        }
        curr.set(l, c);
        // Not `max(…, 0)`-guarded: λ is in [0, 1] by construction.
        let shortened = if lambda.0[l] > threshold {
            0.0
        } else {
            stored.count.0[l] * (1.0 - lambda.0[l])
        };
        if p.use_changes != 0 {
            prev.count.0[l] = shortened;
        }
    });
    if p.use_changes != 0 {
        second_opinions(p, id.z, &curr, &stored, lambda, threshold, &mut prev);
    }
    let surface = p.surface_clamp_radius > 0 && super::plane_in(p.surface_clamp_planes, id.z);
    let radius = if surface {
        p.surface_clamp_radius
    } else {
        p.clamp_radius
    };
    if radius > 0 {
        let inputs = (samples, depth, normal_roughness);
        lanes::each_lane!(l in N {
            let at = UVec3::new(clamp_column(x0 + l as i32, w), id.y, id.z);
            prev.set(l, clamp_history(at, p, (radius, surface), inputs, prev.lane(l)));
        });
    }
    let mut merged = prev;
    lanes::each_lane!(l in N {
        let m = payload::accumulate(prev.lane(l), curr.lane(l), p.max_history, p.rng_wrap);
        merged.set(l, m);
    });
    let m = payload::store_lanes(prev.moments(), curr.moments(), merged.moments(), p.storage);
    let out = PayloadLanes {
        m1: m.m1,
        m2: m.m2,
        ..merged
    }
    .pack();
    out.store(history, row as usize + id.x as usize, live);
    if dropped > 0 {
        atomic::add(&mut counters[payload::COUNTER_NON_FINITE], dropped);
    }
    if clamped > 0 {
        atomic::add(&mut counters[payload::COUNTER_CLAMPED], clamped);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// History of one lit pixel (mean 0.8, per-ray variance 0.16, over 8 rays) on plane 0 after
    /// accumulating `rays` rays of `value` under the detector's `lambda`, with the shadow-plane
    /// mask `shadow_planes` and plane 0 confirming drops at `confirm_sigma`.
    fn accumulated(
        (rays, value): (u32, f32),
        lambda: f32,
        shadow_planes: u32,
        confirm_sigma: f32,
    ) -> Payload {
        let mut history = [Payload::binary(0.8, 8.0).pack()];
        let samples = [Sample::uniform(value, rays).pack()];
        let p = AccumulateParams {
            width: 1,
            height: 1,
            max_history: 64.0,
            use_changes: 1,
            change_threshold: 0.5,
            shadow_threshold: 0.3,
            shadow_planes,
            drop_sigma: 1.5,
            min_variance: 1e-4,
            confirm_planes: 1,
            confirm_sigma,
            ..Default::default()
        };
        let io = AccumulateIo {
            history: &mut history,
            samples: &samples,
            changes: &[lambda],
            counters: &mut [0; payload::COUNTERS_LEN as usize],
            depth: &[1.0],
            normal_roughness: &[packing::pack_normal_roughness(Vec3::Z, 0.0)],
        };
        accumulate::<1>(UVec3::ZERO, &p, io);
        history[0].unpack()
    }

    /// [`accumulated`] with `rays` dark rays and no change detected.
    fn after(rays: u32, shadow_planes: u32) -> Payload {
        accumulated((rays, 0.0), 0.0, shadow_planes, 0.0)
    }

    /// [`accumulated`] with four rays of `value` under a detected change (`λ` 0.9).
    fn after_change(value: f32, confirm_sigma: f32) -> Payload {
        accumulated((4, value), 0.9, 0, confirm_sigma)
    }

    #[test]
    fn only_confirmed_drops_stand_on_confirming_planes() {
        // Rays that agree with the history (0σ) keep it whole: 8 + 4 rays.
        assert_eq!(after_change(0.8, 1.25).count, 12.0);
        // Rays that disagree (0.8 against 0: 3.3σ) confirm the drop: only the new rays remain.
        let dropped = after_change(0.0, 1.25);
        assert_eq!((dropped.m1, dropped.count), (0.0, 4.0));
        // Without confirmation the detector's `λ` alone drops it.
        assert_eq!(after_change(0.8, 0.0).count, 4.0);
    }

    /// History mean of the middle pixel of a row of three after a variance clamp of radius 1
    /// (only the window's own surface with `surface`): the middle pixel's history reads 0.9,
    /// it and its left neighbour traced 0.2 on a floor at depth 1, the right one 5.0 on a wall
    /// at depth 2.
    fn clamped(surface: bool) -> f32 {
        let mut history = [Payload::binary(0.9, 8.0).pack(); 3];
        let samples = [0.2, 0.2, 5.0].map(|v| Sample::uniform(v, 1).pack());
        let floor = packing::pack_normal_roughness(Vec3::Z, 0.0);
        let wall = packing::pack_normal_roughness(Vec3::X, 0.0);
        let p = AccumulateParams {
            width: 3,
            height: 1,
            max_history: 64.0,
            clamp_radius: 1,
            clamp_gamma: 1.0,
            surface_clamp_planes: surface as u32,
            surface_clamp_radius: 1,
            normal_threshold: 0.9,
            depth_tolerance: 0.05,
            ..Default::default()
        };
        let io = AccumulateIo {
            history: &mut history,
            samples: &samples,
            changes: &[0.0; 3],
            counters: &mut [0; payload::COUNTERS_LEN as usize],
            depth: &[1.0, 1.0, 2.0],
            normal_roughness: &[floor, floor, wall],
        };
        accumulate::<1>(UVec3::new(1, 0, 0), &p, io);
        // The clamped history (8 rays) merged with the middle pixel's own ray.
        (history[1].unpack().m1 * 9.0 - 0.2) / 8.0
    }

    #[test]
    fn the_surface_clamp_keeps_to_the_pixels_own_surface() {
        // The floor's two rays agree: the history is clamped to 0.2.
        assert!((clamped(true) - 0.2).abs() < 1e-3, "{}", clamped(true));
        // Across the edge the wall's ray widens the window (mean 1.8, σ 2.26): 0.9 stays.
        assert!((clamped(false) - 0.9).abs() < 1e-3, "{}", clamped(false));
    }

    #[test]
    fn verified_rays_that_disagree_drop_shadow_history() {
        // Four dark rays against p = 0.8 over 8 rays: 3.3σ, dropped on a shadow plane.
        let dropped = after(4, 1);
        assert_eq!((dropped.m1, dropped.count), (0.0, 4.0));
        // Merged on any other plane, and from one ray (never verified) on a shadow plane.
        assert_eq!(after(4, 0).count, 12.0);
        assert_eq!(after(1, 1).count, 9.0);
    }
}
