//! The load balancer: from the bucket histogram, choose the bucket threshold and ring threshold
//! that bring the expected rays of the frame to the budget (water filling).
//!
//! Seed: vrrt-call-of-duty-2026, "Load balancing" and "Load balancer - refinement"; the garbled
//! listing is read as ALGORITHMS.md "Load balancer (water filling)" states it:
//!
//! - Over budget: the largest threshold `t` with `Σ_b c[b]·rate(min(b, t)) <= R`; every pixel gets
//!   `min(b, t)`, and pixels in rings `>= k` (the screen centre) keep one more step, `min(b, t+1)`,
//!   with the smallest `k` (most inner rings) that keeps the total within `R`.
//! - Under budget: the largest `t` with `Σ_b c[b]·rate(max(b, t)) <= R`; every pixel gets
//!   `max(b, t)`, inner rings `>= k` get `max(b, t+1)`.
//!
//! Both sums are non-decreasing in `t`, so the expected rays granted never exceed `R` whenever the
//! budget can be met at all (even 1/64 ray for every requesting pixel may be too much: then `t = 0`
//! and the overshoot is reported). The balancer only picks thresholds; [`super::apply`] applies them.
//!
//! Beyond the seed: whole buckets and rings are coarse (one ring can hold a quarter of the screen,
//! and no bucket lies between 1/2 and 1 ray), so what is left of the budget after the last whole
//! ring goes to the next ring out as a fraction of the step (`partial`), realised per pixel by the
//! same blue-noise test as fractional rates. This is the seed's "fractional buckets" refinement
//! without more buckets: the expected rays land on the budget, not up to a ring's step below it.
//!
//! [`POLICY_FIXED`] is the SVGF baseline: every requesting pixel traces `rays_per_pixel`, however
//! fractional (1.5 is one ray plus a second with probability 1/2), so baselines spend the same
//! budget as VRRT.

use super::buckets::{bucket_to_rate, BUCKET_COUNT, COUNTS_LEN};
use super::BalanceIo;
use crate::math;
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// No threshold applied: the requests fit the budget exactly (or raising is off).
pub const MODE_KEEP: u32 = 0;
/// Requests clamped down to the threshold.
pub const MODE_OVER: u32 = 1;
/// Requests raised up to the threshold.
pub const MODE_UNDER: u32 = 2;
/// Every requesting pixel gets `fixed_rate` rays.
pub const MODE_FIXED: u32 = 3;

/// Grant every request as asked (supersampling without a budget).
pub const POLICY_KEEP: u32 = 0;
/// Fit the requests to the budget (VRRT).
pub const POLICY_BALANCE: u32 = 1;
/// Ignore the requests' rates: every requesting pixel traces `rays_per_pixel` (SVGF baseline).
pub const POLICY_FIXED: u32 = 2;

/// Most plane groups (signals) balanced in one frame.
pub const MAX_GROUPS: u32 = 4;

/// Push constants of the balancer.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BalanceParams {
    /// Target average rays per pixel and plane. The frame's budget is this times the pixels that
    /// asked for rays (sky and VRS-masked pixels neither cost nor earn budget) times the planes.
    pub rays_per_pixel: f32,
    /// Rings of the image (`buckets::ring_count`).
    pub ring_count: u32,
    /// Nonzero: spend unused budget by raising low requests; zero ("save" mode): leave it unspent.
    pub raise: u32,
    /// [`POLICY_KEEP`], [`POLICY_BALANCE`] or [`POLICY_FIXED`].
    pub policy: u32,
    /// Plane groups (1..=[`MAX_GROUPS`]), each with its own requests, decision and work list.
    pub groups: u32,
    /// Which group each plane belongs to (`super::plane_group`).
    pub plane_groups: u32,
    /// Signal planes: a group's ray costs one ray per plane it has.
    pub planes: u32,
    /// Least share of the rays a group gets under [`POLICY_BALANCE`], as a fraction of its equal
    /// share (0..=1); 1 gives every group `rays_per_pixel` ([`group_rates`]).
    pub signal_floor: f32,
}

/// The balancer's decision (what [`super::apply`] reads) and its bookkeeping.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Balance {
    /// [`MODE_KEEP`], [`MODE_OVER`], [`MODE_UNDER`] or [`MODE_FIXED`].
    pub mode: u32,
    /// Bucket threshold `t`.
    pub bucket_threshold: u32,
    /// Rings `>= ring_threshold` get one more step (`t + 1`); `ring_count` means none.
    pub ring_threshold: u32,
    /// Ring `ring_threshold - 1` gets this fraction (0..1) of the extra step.
    pub partial: f32,
    /// Expected rays requested (sum of requested rates).
    pub requested: f32,
    /// Expected rays granted (sum of granted rates).
    pub granted: f32,
    /// The budget the decision was made for.
    pub budget: f32,
    /// Rays of every requesting pixel in [`MODE_FIXED`].
    pub fixed_rate: f32,
}

/// The bucket a pixel requesting bucket `b` in ring `ring` is granted.
#[inline]
pub fn granted_bucket(b: u32, ring: u32, d: &Balance) -> u32 {
    let t = d.bucket_threshold + (ring >= d.ring_threshold) as u32;
    match d.mode {
        MODE_OVER => {
            if b < t {
                b
            } else {
                t
            }
        }
        MODE_UNDER => {
            if b > t {
                b
            } else {
                t
            }
        }
        _ => b,
    }
}

/// Expected rays of a pixel requesting bucket `b < BUCKET_COUNT` in ring `ring`: the granted
/// bucket's rate, plus the partial step in ring `ring_threshold - 1`. Fractional;
/// [`super::apply`] realises it.
#[inline]
pub fn granted_rate(b: u32, ring: u32, d: &Balance) -> f32 {
    if d.mode == MODE_FIXED {
        return d.fixed_rate;
    }
    let rate = bucket_to_rate(granted_bucket(b, ring, d));
    if d.partial > 0.0 && ring + 1 == d.ring_threshold {
        // As if the pixel were one ring further in.
        let stepped = bucket_to_rate(granted_bucket(b, d.ring_threshold, d));
        rate + d.partial * (stepped - rate)
    } else {
        rate
    }
}

/// Expected rays if every bucket `b` of the histogram at `base` is mapped to `min(b, t)` (`down`)
/// or `max(b, t)`.
fn rays_at(counts: &[u32], base: usize, t: u32, down: bool) -> f32 {
    let mut sum = 0.0f32;
    let mut b = 0;
    while b < BUCKET_COUNT {
        let g = if down == (b < t) { b } else { t };
        sum += counts[base + b as usize] as f32 * bucket_to_rate(g);
        b += 1;
    }
    sum
}

/// Pixels of ring `r` that the extra step of threshold `t` would change (`b > t` over budget,
/// `b <= t` under).
fn ring_pixels_moved(counts: &[u32], base: usize, r: u32, t: u32, down: bool) -> f32 {
    let base = base + ((1 + r) * BUCKET_COUNT) as usize;
    let mut n = 0u32;
    let mut b = 0;
    while b < BUCKET_COUNT {
        if down == (b > t) {
            n += counts[base + b as usize];
        }
        b += 1;
    }
    n as f32
}

/// Rays per pixel of each plane group: one budget of `rays_per_pixel` rays for every plane,
/// shared by what each group asks for.
///
/// A group's share of the frame's rays is its share of the rays requested (each group's ray
/// costs one ray per plane it has), so every signal gets the same fraction of its request: a
/// quiet, converged AO asks for fractions of a ray and gives its rays to a signal refilling
/// history or still noisy. Requests already carry each signal's measured state (history length,
/// temporal variance; `reproject::requested_rate`). Every group keeps at least `signal_floor` of
/// its equal share, so none stops reacting. Equal rates with one group, when nothing is asked
/// for, and outside [`POLICY_BALANCE`].
///
/// Why requests and not a Neyman split by each signal's relative variance: history is clamped
/// in rays, so past the refill a signal's steady-state noise barely depends on its rays a frame;
/// the rays pay off where history is young, which is what the requests count. On the
/// multi-signal room frame (README "Per-signal ray rates") every split by measured variance
/// tried ended worse than equal shares.
pub fn group_rates(counts: &[u32], p: &BalanceParams) -> [f32; MAX_GROUPS as usize] {
    let equal = [p.rays_per_pixel; MAX_GROUPS as usize];
    if p.groups < 2 || p.groups > MAX_GROUPS || p.policy != POLICY_BALANCE || p.signal_floor >= 1.0
    {
        return equal;
    }
    // Weights: rays requested, times the planes each ray costs. Groups without a requesting
    // pixel get no floor (they would spend nothing of it).
    let mut cost = [0.0f32; MAX_GROUPS as usize];
    let mut weight = [0.0f32; MAX_GROUPS as usize];
    let mut floor = [0.0f32; MAX_GROUPS as usize];
    let (mut planes, mut total) = (0.0f32, 0.0f32);
    let mut g = 0;
    while g < p.groups {
        let i = g as usize;
        cost[i] = super::group_planes(p.plane_groups, p.planes, g) as f32;
        weight[i] = rays_at(counts, (g * COUNTS_LEN) as usize, 0, false) * cost[i];
        planes += cost[i];
        total += weight[i];
        g += 1;
    }
    if !(total > 0.0) {
        return equal;
    }
    g = 0;
    while g < p.groups {
        let i = g as usize;
        if weight[i] > 0.0 {
            floor[i] = p.signal_floor * cost[i] / planes;
        }
        g += 1;
    }
    // Groups whose share falls under their floor get the floor; the others share the rest by
    // weight. Each round fixes at least one more group or ends.
    let mut fixed = [0u32; MAX_GROUPS as usize];
    let mut round = 0;
    while round < MAX_GROUPS {
        let (left, weights) = free_share(&weight, &floor, &fixed, p.groups);
        let mut changed = false;
        g = 0;
        while g < p.groups {
            let i = g as usize;
            if fixed[i] == 0 && !(left * weight[i] >= floor[i] * weights) {
                fixed[i] = 1;
                changed = true;
            }
            g += 1;
        }
        if !changed {
            break;
        }
        round += 1;
    }
    let (left, weights) = free_share(&weight, &floor, &fixed, p.groups);
    let mut rates = equal;
    g = 0;
    while g < p.groups {
        let i = g as usize;
        let share = if fixed[i] != 0 {
            floor[i]
        } else if weights > 0.0 {
            left * weight[i] / weights
        } else {
            0.0
        };
        rates[i] = share * planes * p.rays_per_pixel / cost[i];
        g += 1;
    }
    rates
}

/// What the groups not `fixed` at their floor share: the share left and their summed weight.
fn free_share(
    weight: &[f32; MAX_GROUPS as usize],
    floor: &[f32; MAX_GROUPS as usize],
    fixed: &[u32; MAX_GROUPS as usize],
    groups: u32,
) -> (f32, f32) {
    let (mut left, mut weights) = (1.0f32, 0.0f32);
    let mut g = 0;
    while g < groups {
        let i = g as usize;
        if fixed[i] != 0 {
            left -= floor[i];
        } else {
            weights += weight[i];
        }
        g += 1;
    }
    (left, weights)
}

/// Solves for the thresholds of plane group `group` at `rays_per_pixel`. Its histogram is the
/// group's part of `counts` (`buckets::count`: totals, then one row per ring).
pub fn solve(counts: &[u32], group: u32, rays_per_pixel: f32, p: &BalanceParams) -> Balance {
    let base = (group * COUNTS_LEN) as usize;
    let requested = rays_at(counts, base, 0, false);
    let mut active = 0u32;
    let mut b = 0;
    while b < BUCKET_COUNT {
        active += counts[base + b as usize];
        b += 1;
    }
    let budget = rays_per_pixel * active as f32;
    if p.policy == POLICY_FIXED {
        return Balance {
            mode: MODE_FIXED,
            ring_threshold: p.ring_count,
            requested: budget,
            granted: budget,
            budget,
            fixed_rate: rays_per_pixel,
            ..Balance::default()
        };
    }
    let keep = Balance {
        mode: MODE_KEEP,
        ring_threshold: p.ring_count,
        requested,
        granted: requested,
        budget,
        ..Balance::default()
    };
    let down = requested > budget;
    if p.policy == POLICY_KEEP || requested == budget || (!down && p.raise == 0) {
        return keep;
    }
    // Largest t whose total fits (both sums are non-decreasing in t).
    let mut t = 0u32;
    let mut fit = rays_at(counts, base, 0, down);
    let mut cand = 1;
    while cand < BUCKET_COUNT {
        let r = rays_at(counts, base, cand, down);
        if r <= budget {
            t = cand;
            fit = r;
        }
        cand += 1;
    }
    // Rings from the centre outward get t + 1 while it fits; the next ring out gets the rest as
    // a fraction of the step.
    let mut k = p.ring_count;
    let mut granted = fit;
    let mut partial = 0.0f32;
    if fit <= budget && t + 1 < BUCKET_COUNT {
        let step = bucket_to_rate(t + 1) - bucket_to_rate(t);
        while k > 0 {
            let add = step * ring_pixels_moved(counts, base, k - 1, t, down);
            if granted + add > budget {
                partial = math::clamp((budget - granted) / add, 0.0, 1.0);
                granted += partial * add;
                break;
            }
            granted += add;
            k -= 1;
        }
    }
    Balance {
        mode: if down { MODE_OVER } else { MODE_UNDER },
        bucket_threshold: t,
        ring_threshold: k,
        partial,
        requested,
        granted,
        budget,
        ..Balance::default()
    }
}

/// One invocation: writes each plane group's decision ([`solve`] at its [`group_rates`]) to
/// `out[group]` and resets its work list's arguments, `args[4·group..]`, to `[0, 0, 1, 1]`
/// (count, groups x, y, z).
pub fn balance(id: UVec3, p: &BalanceParams, io: BalanceIo<'_>) {
    let BalanceIo { counts, out, args } = io;
    if id.x == 0 && id.y == 0 && id.z == 0 {
        let rates = group_rates(counts, p);
        let mut g = 0;
        while g < p.groups {
            out[g as usize] = solve(counts, g, rates[g as usize], p);
            let a = (g * super::apply::ARGS_LEN) as usize;
            args[a] = 0;
            args[a + 1] = 0;
            args[a + 2] = 1;
            args[a + 3] = 1;
            g += 1;
        }
    }
}

#[cfg(test)]
mod tests;
