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
//! Beyond the seed too: where a group's requests are each pixel's history deficit (AO), the
//! threshold moves every request by the same step instead ([`MODE_SHIFT`] over budget,
//! [`MODE_LIFT`] under it; [`mapped_bucket`] says why), so the rays go where history is shortest.
//!
//! [`POLICY_FIXED`] is the SVGF baseline: every requesting pixel traces `rays_per_pixel`, however
//! fractional (1.5 is one ray plus a second with probability 1/2), so baselines spend the same
//! budget as VRRT.

use super::buckets::{bucket_to_rate, BUCKET_COUNT, COUNTS_LEN, MAX_RINGS};
use super::{BalanceIo, WorkgroupIds};
use crate::math;
use bytemuck::{Pod, Zeroable};

mod shares;
pub use shares::group_rates;

/// No threshold applied: the requests fit the budget exactly (or raising is off).
pub const MODE_KEEP: u32 = 0;
/// Requests clamped down to the threshold.
pub const MODE_OVER: u32 = 1;
/// Requests raised up to the threshold.
pub const MODE_UNDER: u32 = 2;
/// Every requesting pixel gets `fixed_rate` rays.
pub const MODE_FIXED: u32 = 3;
/// Every request lowered by the same number of buckets (`BUCKET_COUNT - 1 - t`), at most to
/// [`SHIFT_FLOOR`] ([`mapped_bucket`]).
pub const MODE_SHIFT: u32 = 4;
/// Lowest bucket [`MODE_SHIFT`] takes a request to (1/2 ray): young history keeps tracing
/// every other frame, so the detector still sees its changes.
pub const SHIFT_FLOOR: u32 = 62;
/// Every request raised by the same number of buckets (`t`), at most to the highest.
pub const MODE_LIFT: u32 = 5;

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
    /// Rays of an entry of the detector's refill lists when they fit (`detector.refill_rays`,
    /// [`super::refill`]).
    pub refill_rays: u32,
    /// Most of a group's budget its refill lists may set aside (`detector.refill_share`): lists
    /// sized to a large disocclusion or change would starve the main pass, whose rays the
    /// listed pixels' neighbours (and, for the reflections, the listed pixels themselves
    /// through ray reuse) need.
    pub refill_share: f32,
    /// Nonzero: last frame's lists were a reset frame's ([`refill_reserve`]).
    pub after_reset: u32,
    /// Bit `g` set: group `g` moves every request by the same step, down over budget
    /// ([`MODE_SHIFT`]) and up under it ([`MODE_LIFT`]), instead of capping the largest
    /// ([`MODE_OVER`]) or raising the smallest ([`MODE_UNDER`]), the seed's.
    pub shift: u32,
}

/// The balancer's decision (what [`super::apply`] reads) and its bookkeeping.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Balance {
    /// [`MODE_KEEP`], [`MODE_OVER`], [`MODE_UNDER`], [`MODE_FIXED`], [`MODE_SHIFT`] or
    /// [`MODE_LIFT`].
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
    /// Priority bin below which a pixel's last ray is trimmed ([`super::trim::cut`]; 0 for none).
    pub cut: u32,
    /// Rays the group traces after the trim ([`super::trim::cut`]).
    pub traced: u32,
    /// Rays of the group's budget set aside for this frame's refill lists ([`refill_reserve`]),
    /// outside `budget`.
    pub paid: f32,
    /// Rays the group may trace this frame, main pass and refill lists together:
    /// `budget + paid`, and on a reset frame its lists' reserve ([`super::trim::cut`]).
    pub allowed: u32,
    /// Rays of a refill entry below [`Self::refill_cut`] ([`super::refill::fit`]; 0: skipped).
    pub refill_lo: u32,
    /// Rays of a refill entry from [`Self::refill_cut`] on.
    pub refill_hi: u32,
    /// The refill entries' priority bin from which they get `refill_hi`.
    pub refill_cut: u32,
    /// Rays the group's refill list traces.
    pub refill_traced: u32,
}

/// The bucket a pixel requesting bucket `b` in ring `ring` is granted.
#[inline]
pub fn granted_bucket(b: u32, ring: u32, d: &Balance) -> u32 {
    mapped_bucket(
        b,
        d.bucket_threshold + (ring >= d.ring_threshold) as u32,
        d.mode,
    )
}

/// Request `b` at threshold `t`: capped at `t` ([`MODE_OVER`]), raised to it ([`MODE_UNDER`]),
/// lowered by `BUCKET_COUNT - 1 - t` buckets ([`MODE_SHIFT`]) or raised by `t`
/// ([`MODE_LIFT`]); non-decreasing in `t`.
///
/// Why the shift: a pixel's error after this frame is about `σ² / (n + g)` for `n` rays of
/// history and `g` new ones, and the allocation that minimises the sum under a budget gives rays
/// where `n + g` is smallest (water filling on history plus rays). Requests are
/// `supersample_target - n` (`reproject::requested_rate`), so lowering them all by one step keeps
/// that order, while capping them (the seed's) hands a pixel disoccluded this frame the same one
/// ray as its neighbours with ten, whenever all of them are short of history (the frames after
/// a camera cut). Below one ray the step goes on to [`SHIFT_FLOOR`], half a ray: a request
/// that fell to nothing would stop the change detector, which reads each pixel's new rays, and
/// a floor of one ray leaves nothing over for the disoccluded pixels (see
/// `docs/algorithms/balancer.md`).
/// Under budget the same reasoning lifts every request alike, where raising the smallest to
/// `t` (the seed's) spends the rays left over on converged pixels, whose history is longest.
#[inline]
pub fn mapped_bucket(b: u32, t: u32, mode: u32) -> u32 {
    match mode {
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
        MODE_SHIFT => {
            let keep = BUCKET_COUNT - 1;
            // Saturating subtractions, written out for the shader target.
            let shift = keep - if t < keep { t } else { keep };
            let shifted = b - if b > shift { shift } else { b };
            let floor = if b < SHIFT_FLOOR { b } else { SHIFT_FLOOR };
            if shifted > floor {
                shifted
            } else {
                floor
            }
        }
        MODE_LIFT => {
            if b + t < BUCKET_COUNT {
                b + t
            } else {
                BUCKET_COUNT - 1
            }
        }
        _ => b,
    }
}

/// Expected rays of a pixel requesting bucket `b < BUCKET_COUNT` in ring `ring`: the granted
/// bucket's rate, plus the partial step in ring `ring_threshold - 1`. Fractional;
/// [`super::apply`] realises it.
// Always inlined: called per lane from the lanes runners, it takes their instructions
// (a call is compiled for the baseline, where `floor` is a library call).
#[inline(always)]
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

/// Expected rays if every bucket `b` of the histogram at `base` is mapped by
/// [`mapped_bucket`]`(b, t, mode)`.
pub fn rays_at(counts: &[u32], base: usize, t: u32, mode: u32) -> f32 {
    let mut sum = 0.0f32;
    let mut b = 0;
    while b < BUCKET_COUNT {
        sum += counts[base + b as usize] as f32 * bucket_to_rate(mapped_bucket(b, t, mode));
        b += 1;
    }
    sum
}

/// Rays that the extra step of threshold `t` (`t + 1`) adds to ring `r`'s pixels. Capped or
/// raised, every pixel it moves goes from `t` to `t + 1`; shifted or lifted, each goes up one
/// bucket of its own.
fn ring_rays_added(counts: &[u32], base: usize, r: u32, t: u32, mode: u32) -> f32 {
    let base = base + ((1 + r) * BUCKET_COUNT) as usize;
    if mode == MODE_SHIFT || mode == MODE_LIFT {
        let mut added = 0.0f32;
        let mut b = 0;
        while b < BUCKET_COUNT {
            let step = bucket_to_rate(mapped_bucket(b, t + 1, mode))
                - bucket_to_rate(mapped_bucket(b, t, mode));
            added += counts[base + b as usize] as f32 * step;
            b += 1;
        }
        return added;
    }
    let down = mode == MODE_OVER;
    let mut n = 0u32;
    let mut b = 0;
    while b < BUCKET_COUNT {
        if down == (b > t) {
            n += counts[base + b as usize];
        }
        b += 1;
    }
    (bucket_to_rate(t + 1) - bucket_to_rate(t)) * n as f32
}

/// Solves for the thresholds of plane group `group` at `rays_per_pixel`. Its histogram is the
/// group's part of `counts` (`buckets::count`: totals, then one row per ring). The serial form
/// of what the balancer's workgroup (`kernels::BALANCE`) computes in parallel, with the same bits.
pub fn solve(
    counts: &[u32],
    group: u32,
    rays_per_pixel: f32,
    spent: f32,
    p: &BalanceParams,
) -> Balance {
    let base = group * COUNTS_LEN;
    let mut s = Search::new(counts, base, rays_per_pixel, spent, p);
    if s.searching == 0 {
        return s.decision;
    }
    let mut fits = [0.0f32; BUCKET_COUNT as usize];
    let mut cand = 0;
    while cand < BUCKET_COUNT {
        fits[cand as usize] = rays_at(counts, base as usize, cand, s.mode);
        cand += 1;
    }
    s.pick(&fits, 0);
    let mut moved = [0.0f32; MAX_RINGS as usize];
    let rings = s.rings(p);
    let mut r = 0;
    while r < rings {
        moved[r as usize] = s.ring_moved(counts, base, r);
        r += 1;
    }
    s.finish(&moved, 0, p)
}

/// One group's threshold search, from the histogram's totals to the decision: what the
/// balancer's phases share through workgroup memory.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Search {
    /// The decision: final when `searching` is 0; else its budget and request, then its
    /// thresholds once [`Self::finish`] ran.
    pub decision: Balance,
    /// Nonzero: thresholds are searched (the requests do not fit, or may be raised).
    pub searching: u32,
    /// How requests are mapped: [`MODE_OVER`] or [`MODE_SHIFT`] over budget, [`MODE_UNDER`] or
    /// [`MODE_LIFT`] under it ([`mapped_bucket`]).
    pub mode: u32,
    /// The threshold picked (largest whose total fits).
    pub t: u32,
    /// Expected rays at `t`.
    pub fit: f32,
}

impl Search {
    /// What the totals of the histogram at `base` decide: the fixed or kept decision, or a
    /// search for thresholds.
    /// `spent`: rays of the group's budget set aside for the refill lists ([`refill_reserve`]).
    pub fn new(
        counts: &[u32],
        base: u32,
        rays_per_pixel: f32,
        spent: f32,
        p: &BalanceParams,
    ) -> Search {
        let shift = (p.shift >> (base / COUNTS_LEN)) & 1 != 0;
        let base = base as usize;
        let requested = rays_at(counts, base, 0, MODE_KEEP);
        let mut active = 0u32;
        let mut b = 0;
        while b < BUCKET_COUNT {
            active += counts[base + b as usize];
            b += 1;
        }
        let rays = rays_per_pixel * active as f32;
        let spent = math::min(spent, p.refill_share * rays);
        let budget = math::max(rays - spent, 0.0);
        let mut s = Search {
            decision: Balance {
                mode: MODE_KEEP,
                ring_threshold: p.ring_count,
                requested,
                granted: requested,
                budget,
                paid: rays - budget,
                ..Balance::default()
            },
            ..Search::default()
        };
        if p.policy == POLICY_FIXED {
            s.decision = Balance {
                mode: MODE_FIXED,
                ring_threshold: p.ring_count,
                requested: budget,
                granted: budget,
                budget,
                fixed_rate: rays_per_pixel,
                ..s.decision
            };
            return s;
        }
        let down = requested > budget;
        s.mode = match (down, shift) {
            (false, false) => MODE_UNDER,
            (false, true) => MODE_LIFT,
            // Shifted, no request falls below the floor: where even that exceeds the budget,
            // the seed's cap decides.
            (true, true) if rays_at(counts, base, 0, MODE_SHIFT) <= budget => MODE_SHIFT,
            (true, _) => MODE_OVER,
        };
        s.searching =
            !(p.policy == POLICY_KEEP || requested == budget || (!down && p.raise == 0)) as u32;
        s
    }

    /// Picks the largest threshold whose total fits the budget (both sums are non-decreasing
    /// in `t`), from `fits[base + t]` = [`rays_at`] of every candidate `t`.
    pub fn pick<const N: usize>(&mut self, fits: &[f32; N], base: usize) {
        let mut t = 0u32;
        let mut fit = fits[base];
        let mut cand = 1;
        while cand < BUCKET_COUNT {
            let r = fits[base + cand as usize];
            if r <= self.decision.budget {
                t = cand;
                fit = r;
            }
            cand += 1;
        }
        self.t = t;
        self.fit = fit;
    }

    /// Rings whose extra step [`Self::finish`] may grant: all of them when the threshold fits
    /// and has a next step, else none.
    pub fn rings(&self, p: &BalanceParams) -> u32 {
        if self.fit <= self.decision.budget && self.t + 1 < BUCKET_COUNT {
            if p.ring_count < MAX_RINGS {
                p.ring_count
            } else {
                MAX_RINGS
            }
        } else {
            0
        }
    }

    /// Rays that the extra step of the picked threshold adds to ring `r`.
    pub fn ring_moved(&self, counts: &[u32], base: u32, r: u32) -> f32 {
        ring_rays_added(counts, base as usize, r, self.t, self.mode)
    }

    /// The decision, from `moved[base + r]` = [`Self::ring_moved`] of every ring `r` below
    /// [`Self::rings`]: rings from the centre outward get `t + 1` while it fits; the next ring
    /// out gets the rest as a fraction of the step.
    pub fn finish<const N: usize>(
        &self,
        moved: &[f32; N],
        base: usize,
        p: &BalanceParams,
    ) -> Balance {
        let budget = self.decision.budget;
        let mut k = p.ring_count;
        let mut granted = self.fit;
        let mut partial = 0.0f32;
        let rings = self.rings(p);
        if rings > 0 {
            k = rings;
            while k > 0 {
                let add = moved[base + k as usize - 1];
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
            mode: self.mode,
            bucket_threshold: self.t,
            ring_threshold: k,
            partial,
            granted,
            ..self.decision
        }
    }
}

/// Plane groups the kernel balances: `p.groups`, at most [`MAX_GROUPS`].
#[inline]
fn groups(p: &BalanceParams) -> u32 {
    if p.groups < MAX_GROUPS {
        p.groups
    } else {
        MAX_GROUPS
    }
}

/// Invocations of the balancer's workgroup (`kernels::BALANCE`): at least one per candidate
/// threshold of a group.
pub const THREADS: u32 = 128;

/// Workgroup memory of the balancer: each group's search, the total at each of its candidate
/// thresholds and the pixels each of its rings' extra step moves.
#[repr(C)]
#[derive(Copy, Clone, Pod, Zeroable)]
pub struct Shared {
    /// One per plane group.
    pub search: [Search; MAX_GROUPS as usize],
    /// `[group][candidate]`: [`rays_at`].
    pub fits: [f32; (MAX_GROUPS * BUCKET_COUNT) as usize],
    /// `[group][ring]`: [`Search::ring_moved`], the rays each ring's extra step adds.
    pub moved: [f32; (MAX_GROUPS * MAX_RINGS) as usize],
}

/// Phase 1: invocation `g` starts group `g`'s search at its share of the budget
/// ([`group_rates`], computed by each such invocation alike).
#[inline]
pub fn setup(ids: WorkgroupIds, p: &BalanceParams, io: BalanceIo<'_>, local: &mut Shared) {
    let g = ids.local_index;
    if g < groups(p) {
        let rates = group_rates(io.counts, p);
        let count = io.refill[(g * super::work_list::ARGS_LEN) as usize];
        let spent = refill_reserve(count, p);
        let base = g * COUNTS_LEN;
        local.search[g as usize] = Search::new(io.counts, base, rates[g as usize], spent, p);
    }
}

/// Rays a group sets aside for this frame's refill lists, from last frame's `count` entries.
///
/// Why: the lists are made after the main pass, from what its rays showed, and they must fit
/// what is left of the frame ([`super::refill::fit`]); the main pass is fitted to the budget
/// less this. Lists change little from one frame to the next, and what is set aside but not
/// needed goes to the lists' own entries (more rays each), so a quarter more than last frame's
/// rays keeps most frames from cutting them. A reset frame's lists (the shadows' mixed
/// windows) say nothing of what the detector will list next: one ray for each of them.
/// [`Search::new`] keeps at most [`BalanceParams::refill_share`] of the group's rays aside.
#[inline]
pub fn refill_reserve(count: u32, p: &BalanceParams) -> f32 {
    if p.after_reset != 0 {
        count as f32
    } else {
        1.25 * (count * p.refill_rays) as f32
    }
}

/// Phase 2: the total at every candidate threshold of every searching group, one sum per
/// invocation and round (the serial [`solve`] runs the same sums one after another).
#[inline]
pub fn sums(ids: WorkgroupIds, p: &BalanceParams, io: BalanceIo<'_>, local: &mut Shared) {
    let mut i = ids.local_index;
    while i < groups(p) * BUCKET_COUNT {
        let (g, cand) = (i / BUCKET_COUNT, i % BUCKET_COUNT);
        let s = local.search[g as usize];
        if s.searching != 0 {
            let base = (g * COUNTS_LEN) as usize;
            local.fits[i as usize] = rays_at(io.counts, base, cand, s.mode);
        }
        i += THREADS;
    }
}

/// Phase 3: invocation `g` picks group `g`'s threshold.
#[inline]
pub fn pick(ids: WorkgroupIds, p: &BalanceParams, _io: BalanceIo<'_>, local: &mut Shared) {
    let g = ids.local_index;
    let Shared { search, fits, .. } = local;
    if g < groups(p) && search[g as usize].searching != 0 {
        search[g as usize].pick(fits, (g * BUCKET_COUNT) as usize);
    }
}

/// Phase 4: the pixels each ring's extra step moves, one ring of one group per invocation and
/// round.
#[inline]
pub fn rings(ids: WorkgroupIds, p: &BalanceParams, io: BalanceIo<'_>, local: &mut Shared) {
    let mut i = ids.local_index;
    while i < groups(p) * MAX_RINGS {
        let (g, r) = (i / MAX_RINGS, i % MAX_RINGS);
        let s = local.search[g as usize];
        if s.searching != 0 && r < s.rings(p) {
            local.moved[i as usize] = s.ring_moved(io.counts, g * COUNTS_LEN, r);
        }
        i += THREADS;
    }
}

/// Phase 5: invocation `g` writes group `g`'s decision to `out[g]` and resets its work lists'
/// arguments, `args[4·g..]` and `refill[4·g..]`, to `[0, 0, 1, 1]` (count, groups x, y, z).
#[inline]
pub fn write(ids: WorkgroupIds, p: &BalanceParams, io: BalanceIo<'_>, local: &mut Shared) {
    let BalanceIo {
        out, args, refill, ..
    } = io;
    let g = ids.local_index;
    if g < groups(p) {
        let s = local.search[g as usize];
        out[g as usize] = if s.searching != 0 {
            s.finish(&local.moved, (g * MAX_RINGS) as usize, p)
        } else {
            s.decision
        };
        let a = (g * super::work_list::ARGS_LEN) as usize;
        // Written out: an array of the two storage references is a pointer to a pointer, which
        // SPIR-V's logical addressing does not have.
        args[a] = 0;
        args[a + 1] = 0;
        args[a + 2] = 1;
        args[a + 3] = 1;
        refill[a] = 0;
        refill[a + 1] = 0;
        refill[a + 2] = 1;
        refill[a + 3] = 1;
    }
}

#[cfg(test)]
mod tests;
