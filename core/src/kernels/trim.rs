//! Trim: the rays [`super::apply`] realises never exceed the group's budget.
//!
//! Why: the balancer fits the *expected* rays to the budget ([`super::balance`]: fractional
//! rates, a partial ring step), and apply realises each fraction with a blue-noise test, so the
//! rays actually traced are that expectation plus the noise of thousands of coin flips: some
//! frames trace more than their budget. Rounding each pixel down would waste a large share of
//! the budget (most undersampled pixels are fractional); trimming only the excess does not.
//!
//! How, by construction and the same on every backend: every tracing pixel's last ray gets a
//! priority bin ([`last_ray`]). A ray the coin flip granted (the fraction's) lies in the lower
//! bins, by how far its rate cleared the noise relative to the fraction, `(frac − noise) /
//! frac`: uniform over the noise, so trimming the lowest bins takes the same share of every
//! fraction's rays, and the realised rates scale down with the fractions. A last ray that is a
//! whole one (no coin flip decided it) lies in the upper bins, so it goes only once every
//! flipped ray has. [`count`] builds, per plane group, the histogram of those bins and the total
//! rays; [`cut`] finds the lowest bin such that taking the last ray of every pixel below it
//! brings the total within the budget, and apply takes exactly those ([`trimmed_rays`]). The
//! histogram decides, not the order in which invocations ran, so the pixels trimmed are the
//! same on every backend and every run.

use super::balance::{granted_rate, Balance, POLICY_KEEP};
use super::buckets::{ring_id, BUCKET_COUNT, GROUP, MAX_RATE};
use super::{TrimCountIo, TrimCutIo, WorkgroupIds};
use crate::atomic;
use crate::blue_noise;
use crate::lanes::{self, clamp_column, Lanes};
use crate::math;
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Priority bins of the histogram: [`FLIPPED_BINS`] for the rays a coin flip granted, the rest
/// for whole ones. The trim removes whole bins, so it may take up to one bin's pixels more than
/// the excess: finer bins waste less of the budget, coarser ones cost less workgroup memory and
/// time (clearing and flushing the histogram is per workgroup, not per pixel).
pub const BINS: u32 = 256;
/// Bins of the flipped rays: the trim takes from them first, and almost always only from them.
pub const FLIPPED_BINS: u32 = 224;
/// Words of one plane group's histogram: [`BINS`] counts, then the group's total rays.
pub const HIST_LEN: u32 = BINS + 1;

/// Offset of the blue-noise mask per plane group (coprime with the mask's edge, far apart):
/// groups at the same fractional rate trace different pixels instead of all the same ones.
pub const GROUP_NOISE_SHIFT: [u32; 2] = [23, 41];

/// Push constants of [`count`] (and what apply realises rays with).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TrimParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Frame number: animates the blue-noise thresholds.
    pub frame_index: u32,
}

/// Push constants of [`cut`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CutParams {
    /// Plane groups (one invocation each).
    pub groups: u32,
    /// The balancer's policy: [`POLICY_KEEP`] grants every request as asked, with no budget
    /// to hold, so nothing is trimmed.
    pub policy: u32,
    /// On a reset frame whose refill lists spend a reserve, its share of the main pass's budget
    /// (`refill::reserve`); else 0.
    pub reset_share: f32,
}

/// Rays pixel `(x, y)` of plane group `group` realises from its granted rate before any trim,
/// and the priority bin of its last ray (meaningless when it traces none).
// Always inlined: called per lane from the lanes runners, it takes their instructions
// (a call is compiled for the baseline, where `floor` is a library call).
#[inline(always)]
pub fn last_ray(
    x: u32,
    y: u32,
    group: u32,
    bucket: u32,
    p: &TrimParams,
    d: &Balance,
    noise: &[f32],
) -> (u32, u32) {
    let rate = bucket_rate(x, y, bucket, p, d);
    realise(rate, pixel_noise(x, y, group, p, noise))
}

/// The rate the balancer grants pixel `(x, y)`'s request `bucket`: 0 without one (no rays).
#[inline(always)]
pub fn bucket_rate(x: u32, y: u32, bucket: u32, p: &TrimParams, d: &Balance) -> f32 {
    if bucket < BUCKET_COUNT {
        granted_rate(bucket, ring_id(x, y, p.width, p.height), d)
    } else {
        0.0
    }
}

/// The blue-noise threshold of pixel `(x, y)` of plane group `group` this frame.
#[inline(always)]
pub fn pixel_noise(x: u32, y: u32, group: u32, p: &TrimParams, noise: &[f32]) -> f32 {
    blue_noise::animate(noise[noise_index(x, y, group) as usize], p.frame_index)
}

/// Where pixel `(x, y)` of plane group `group` reads the blue-noise mask.
#[inline(always)]
fn noise_index(x: u32, y: u32, group: u32) -> u32 {
    blue_noise::mask_index(
        x + group * GROUP_NOISE_SHIFT[0],
        y + group * GROUP_NOISE_SHIFT[1],
    )
}

/// [`realise`] of `N` pixels of row `y` (columns `xs`, plane group `group`) at rates `rates`:
/// their rays and last rays' bins. The noise is gathered first and the rest is vector code.
#[inline(always)]
pub fn realise_row<const N: usize>(
    rates: Lanes<f32, N>,
    xs: Lanes<u32, N>,
    y: u32,
    group: u32,
    p: &TrimParams,
    noise: &[f32],
) -> (Lanes<u32, N>, Lanes<u32, N>) {
    let frame = p.frame_index;
    let u = Lanes::<f32, N>::gather(noise, xs.map(|x| noise_index(x, y, group)))
        .map(|v| blue_noise::animate(v, frame));
    let realised = rates.zip(u, realise);
    (realised.map(|(n, _)| n), realised.map(|(_, b)| b))
}

/// The rays of `rate` at noise threshold `u` and the priority bin of the last one: the rate's
/// fractional part is realised by the test `frac > u` (1.5 is one ray, plus a second where the
/// noise is below 1/2).
#[inline(always)]
pub fn realise(rate: f32, u: f32) -> (u32, u32) {
    // Rates are never negative and at most `MAX_RATE`.
    let whole = math::floor_small(math::clamp(rate, 0.0, MAX_RATE as f32));
    let frac = rate - whole as f32;
    let extra = frac > u;
    let (v, n, first) = if extra {
        ((frac - u) / frac, FLIPPED_BINS, 0)
    } else {
        (u, BINS - FLIPPED_BINS, FLIPPED_BINS)
    };
    (whole + extra as u32, first + bin(v, n))
}

/// `floor(v · n)` within `0..n`, for `v` in `[0, 1]`.
#[inline(always)]
fn bin(v: f32, n: u32) -> u32 {
    math::floor_small(math::clamp(v * n as f32, 0.0, (n - 1) as f32))
}

/// Rays pixel `(x, y)` of plane group `group` traces: [`last_ray`]'s, less the last one where
/// its priority fell below the group's cut ([`Balance::cut`]).
#[inline(always)]
pub fn trimmed_rays(
    x: u32,
    y: u32,
    group: u32,
    bucket: u32,
    p: &TrimParams,
    d: &Balance,
    noise: &[f32],
) -> u32 {
    let (rays, b) = last_ray(x, y, group, bucket, p, d, noise);
    trim_last(rays, b, d.cut)
}

/// `rays` less the last one where its bin `b` fell below the group's cut `cut`.
#[inline(always)]
pub fn trim_last(rays: u32, b: u32, cut: u32) -> u32 {
    rays - (rays > 0 && b < cut) as u32
}

/// Workgroup memory of [`count`].
#[repr(C)]
#[derive(Copy, Clone, Pod, Zeroable)]
pub struct Local {
    /// The workgroup's histogram ([`HIST_LEN`] words).
    pub hist: [u32; HIST_LEN as usize],
    /// The granted rate of every bucket: a workgroup lies in one ring (`buckets::count`'s
    /// workgroups), so its pixels look their rates up instead of each resolving one.
    pub rates: [f32; BUCKET_COUNT as usize],
}

/// Invocations of a [`count`] workgroup.
const THREADS: u32 = GROUP * GROUP;

/// Phase 1 of [`count`]: the workgroup's histogram starts at zero, and its ring's rates are
/// resolved once.
#[inline(always)]
pub fn clear(ids: WorkgroupIds, p: &TrimParams, io: TrimCountIo<'_>, local: &mut Local) {
    let mut i = ids.local_index;
    while i < HIST_LEN {
        local.hist[i as usize] = 0;
        i += THREADS;
    }
    let b = ids.local_index;
    if b < BUCKET_COUNT {
        let g = ids.group;
        let ring = ring_id(g.x * GROUP, g.y * GROUP, p.width, p.height);
        local.rates[b as usize] = granted_rate(b, ring, &io.decision[g.z as usize]);
    }
}

/// Phase 2 of [`count`], one call per `N` pixels of a row ([`crate::lanes`]): each tracing
/// pixel adds its rays and its last ray's bin. The dispatch's z is the plane group.
#[inline(always)]
pub fn count<const N: usize>(
    ids: WorkgroupIds,
    p: &TrimParams,
    io: TrimCountIo<'_>,
    local: &mut Local,
) {
    let TrimCountIo {
        requests, noise, ..
    } = io;
    let id = ids.global;
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let row = id.z * w * h + id.y * w;
    let x0 = id.x as i32;
    let words = Lanes::<u32, N>::load_row(requests, row, x0, w);
    let mut rates = Lanes::<f32, N>::splat(0.0);
    lanes::each_lane!(l in N {
        let bucket = super::requests::bucket_of(words.0[l]);
        // Outside the image or without rays: rate 0, so no ray.
        let last = BUCKET_COUNT - 1;
        let rate = local.rates[if bucket < last { bucket } else { last } as usize];
        if bucket < BUCKET_COUNT && id.x + (l as u32) < w {
            rates.0[l] = rate;
        }
    });
    let xs = Lanes::<u32, N>::from_index(|l| clamp_column(x0 + l as i32, w));
    let (rays, bins) = realise_row(rates, xs, id.y, id.z, p, noise);
    // The adds one lane after another: lanes may share a bin.
    lanes::each_lane!(l in N {
        if rays.0[l] > 0 {
            atomic::add_workgroup(&mut local.hist[bins.0[l] as usize], 1);
            atomic::add_workgroup(&mut local.hist[BINS as usize], rays.0[l]);
        }
    });
}

/// Phase 3 of [`count`]: the workgroup's non-zero words go to its group's histogram, one global
/// atomic each.
#[inline(always)]
pub fn flush(ids: WorkgroupIds, _p: &TrimParams, io: TrimCountIo<'_>, local: &mut Local) {
    let TrimCountIo { hist, .. } = io;
    let base = ids.group.z * HIST_LEN;
    let mut i = ids.local_index;
    while i < HIST_LEN {
        let n = local.hist[i as usize];
        if n != 0 {
            atomic::add(&mut hist[(base + i) as usize], n);
        }
        i += THREADS;
    }
}

/// The lowest bin `c` such that the pixels of bins below it hold at least `excess` last rays
/// (all [`BINS`] when even every last ray is not enough), and those rays.
#[inline]
pub fn cut_bin(hist: &[u32], base: usize, excess: u32) -> (u32, u32) {
    let mut c = 0;
    let mut taken = 0u32;
    while c < BINS && taken < excess {
        taken += hist[base + c as usize];
        c += 1;
    }
    (c, taken)
}

/// One invocation per plane group: the group's cut ([`Balance::cut`]) from its histogram, the
/// rays it then traces ([`Balance::traced`]), and the rays the frame may trace with its refill
/// lists ([`Balance::allowed`]).
#[inline]
pub fn cut(id: UVec3, p: &CutParams, io: TrimCutIo<'_>) {
    let TrimCutIo { hist, decision } = io;
    let g = id.x;
    if g >= p.groups {
        return;
    }
    let base = (g * HIST_LEN) as usize;
    let total = hist[base + BINS as usize];
    let d = &mut decision[g as usize];
    // Whole rays: what the budget allows, rounded down.
    let allowed = math::max(math::floor(d.budget), 0.0) as u32;
    let (c, taken) = if p.policy == POLICY_KEEP || total <= allowed {
        (0, 0)
    } else {
        cut_bin(hist, base, total - allowed)
    };
    d.cut = c;
    d.traced = total - taken;
    d.allowed = math::max(math::floor(d.budget + d.paid), 0.0) as u32
        + super::refill::reserve(d, p.reset_share);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::balance::{POLICY_BALANCE, POLICY_FIXED};
    use std::vec::Vec;

    /// Realises `rates` (one per pixel of a 64-wide image, group 0) as apply would, with the
    /// cut of a `budget`: the rays of each pixel, and the decision.
    fn realise(rates: &[f32], budget: f32, frame: u32, policy: u32) -> (Vec<u32>, Balance) {
        let noise = crate::blue_noise::generate_mask();
        let p = TrimParams {
            width: 64,
            height: (rates.len() / 64) as u32,
            frame_index: frame,
        };
        let mut hist = std::vec![0u32; HIST_LEN as usize];
        let decisions: Vec<Balance> = rates
            .iter()
            .map(|&r| Balance {
                mode: crate::kernels::balance::MODE_FIXED,
                fixed_rate: r,
                budget,
                ..Balance::default()
            })
            .collect();
        for (i, d) in decisions.iter().enumerate() {
            let (x, y) = (i as u32 % 64, i as u32 / 64);
            let (rays, b) = last_ray(x, y, 0, 0, &p, d, &noise);
            if rays > 0 {
                hist[b as usize] += 1;
                hist[BINS as usize] += rays;
            }
        }
        let mut out = [decisions[0]];
        let io = TrimCutIo {
            hist: &hist,
            decision: &mut out,
        };
        cut(
            UVec3::ZERO,
            &CutParams {
                groups: 1,
                policy,
                reset_share: 0.0,
            },
            io,
        );
        let rays = decisions
            .iter()
            .enumerate()
            .map(|(i, d)| {
                let d = Balance {
                    cut: out[0].cut,
                    ..*d
                };
                trimmed_rays(i as u32 % 64, i as u32 / 64, 0, 0, &p, &d, &noise)
            })
            .collect();
        (rays, out[0])
    }

    /// A small deterministic generator (xorshift) for the random rates.
    fn rates(seed: u32, pixels: usize, max: f32) -> Vec<f32> {
        let mut s = seed.max(1);
        (0..pixels)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 17;
                s ^= s << 5;
                (s >> 8) as f32 / (1u32 << 24) as f32 * max
            })
            .collect()
    }

    #[test]
    fn realised_rays_never_exceed_the_budget() {
        let mut trimmed_frames = 0;
        for seed in 1..200u32 {
            let max = [0.3, 1.0, 2.5, 15.9][seed as usize % 4];
            let rates = rates(seed, 64 * 16, max);
            let expected: f32 = rates.iter().map(|&r| r.min(16.0)).sum();
            // Budgets at, just below and just above the expectation: where the coin flips land.
            for budget in [expected, expected * 0.99, expected * 1.01, 0.0] {
                let (rays, d) = realise(&rates, budget, seed, POLICY_BALANCE);
                let traced: u32 = rays.iter().sum();
                assert_eq!(traced, d.traced, "seed {seed}");
                // Within the budget, unless even every pixel's last ray was not enough.
                assert!(
                    traced as f32 <= budget.floor() || d.cut == BINS,
                    "seed {seed}: {traced} rays, budget {budget}"
                );
                if budget > 0.0 && d.cut > 0 {
                    trimmed_frames += 1;
                    // The trim takes whole bins: at most one bin's pixels beyond the excess.
                    let slack = budget.floor() - traced as f32;
                    assert!(slack < rays.len() as f32 / 16.0, "seed {seed}: {slack}");
                }
            }
        }
        assert!(trimmed_frames > 50, "{trimmed_frames}");
    }

    #[test]
    fn nothing_is_trimmed_within_the_budget_or_without_one() {
        let rates = rates(7, 64 * 16, 2.0);
        let expected: f32 = rates.iter().sum();
        let untrimmed = realise(&rates, 1e9, 3, POLICY_BALANCE).0;
        assert_eq!(realise(&rates, 1e9, 3, POLICY_FIXED).1.cut, 0);
        let (kept, d) = realise(&rates, expected * 0.5, 3, POLICY_KEEP);
        assert_eq!((kept, d.cut), (untrimmed, 0));
    }
}
