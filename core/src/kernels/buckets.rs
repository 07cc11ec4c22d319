//! Ray-rate buckets and rings, and the bucket-counting histogram the load balancer reads.
//!
//! Seed: vrrt-call-of-duty-2026, "Load balancing" (`VrrtBucketToRayRate`, `VrrtGetRingId`, counting
//! with `InterlockedAdd` on groupshared memory, then one global atomic per bucket per group).
//! Workgroups are 16×16 and ring tiles 32×16, so every pixel of a workgroup is in the same ring:
//! the per-ring histogram costs nothing beyond the per-bucket one.

use super::CountBucketsIo;
use super::{pixel_index, WorkgroupIds};
use crate::atomic;
use bytemuck::{Pod, Zeroable};

/// `1 / MIN_RATE_DIVISOR` is the lowest fractional ray rate (1/64).
pub const MIN_RATE_DIVISOR: u32 = 64;
/// Highest ray rate (16 rays per pixel).
pub const MAX_RATE: u32 = 16;
/// Buckets `0..64` hold rates `1/64 … 1/1`, buckets `64..80` hold `1 … 16` rays (the seed's
/// mapping: buckets 63 and 64 both mean one ray).
pub const BUCKET_COUNT: u32 = MIN_RATE_DIVISOR + MAX_RATE;
/// Request value of a pixel that needs no ray at all (sky, VRS mask off): in no bucket.
pub const NO_RAYS: u32 = u32::MAX;
/// Ring tiles, in pixels (the seed's `VRRT_RING_DIM` for 16×16 groups).
pub const RING_TILE: [u32; 2] = [32, 16];
/// Most rings counted (a 4K target has 60).
pub const MAX_RINGS: u32 = 64;
/// Length in `u32` of one plane group's counts: `BUCKET_COUNT` totals, then `BUCKET_COUNT` per
/// ring. The counts buffer holds one such histogram per group.
pub const COUNTS_LEN: u32 = BUCKET_COUNT * (1 + MAX_RINGS);
/// Workgroup edge of [`count`]; also the ring-tile height.
pub const GROUP: u32 = 16;

/// Rays per pixel of bucket `b` (the seed's `VrrtBucketToRayRate`).
#[inline]
pub fn bucket_to_rate(b: u32) -> f32 {
    if b >= MIN_RATE_DIVISOR {
        (b - MIN_RATE_DIVISOR + 1) as f32
    } else {
        1.0 / (MIN_RATE_DIVISOR - b) as f32
    }
}

/// Bucket whose rate is nearest to `rate` (rays per pixel): `rate >= 1` rounds to whole rays
/// (buckets 64..80, capped at 16), fractions round `1/rate` (buckets 0..63, floored at 1/64).
/// Zero or negative or NaN rates map to [`NO_RAYS`]. Both roundings are computed and one is
/// selected, so a row of lanes decides without a branch per pixel.
#[inline]
pub fn rate_to_bucket(rate: f32) -> u32 {
    use crate::math::{clamp, floor_small};
    // Clamped to where `floor_small` is exact (a rate of 0 or below is no rays whatever they
    // give), so that lanes convert in vector registers.
    let whole = floor_small(clamp(rate + 0.5, 0.0, MAX_RATE as f32));
    let divisor = floor_small(clamp(1.0 / rate + 0.5, 0.0, MIN_RATE_DIVISOR as f32));
    // A divisor of 1 only for rates in [2/3, 1): one ray, bucket 64 (63 would mean the same).
    let fraction = if divisor <= 1 {
        MIN_RATE_DIVISOR
    } else {
        MIN_RATE_DIVISOR - divisor
    };
    // `whole` is at least 1 where it is taken; below 1 it is 0 and the sum stays in range.
    let b = if rate >= 1.0 {
        MIN_RATE_DIVISOR + whole - 1
    } else {
        fraction
    };
    if rate > 0.0 {
        b
    } else {
        NO_RAYS
    }
}

/// Number of rings of a `width × height` image, at least 1, at most [`MAX_RINGS`].
#[inline]
pub fn ring_count(width: u32, height: u32) -> u32 {
    let nx = width.div_ceil(RING_TILE[0]);
    let ny = height.div_ceil(RING_TILE[1]);
    let n = (if nx < ny { nx } else { ny }).div_ceil(2);
    n.clamp(1, MAX_RINGS)
}

/// Ring of pixel `(x, y)`: the distance in tiles to the nearest screen edge (higher = closer to
/// the centre), clamped to `ring_count - 1`.
// Always inlined: called per lane from the lanes runners, it takes their instructions
// (a call is compiled for the baseline, where `floor` is a library call).
#[inline(always)]
pub fn ring_id(x: u32, y: u32, width: u32, height: u32) -> u32 {
    let nx = width.div_ceil(RING_TILE[0]);
    let ny = height.div_ceil(RING_TILE[1]);
    let (tx, ty) = (x / RING_TILE[0], y / RING_TILE[1]);
    let rx = if tx < nx - 1 - tx { tx } else { nx - 1 - tx };
    let ry = if ty < ny - 1 - ty { ty } else { ny - 1 - ty };
    let r = if rx < ry { rx } else { ry };
    let last = ring_count(width, height) - 1;
    if r < last {
        r
    } else {
        last
    }
}

/// Push constants of the bucket-counting kernel.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BucketParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

/// Phase 1: invocations `0..BUCKET_COUNT` zero the workgroup histogram.
#[inline]
pub fn clear(
    ids: WorkgroupIds,
    _p: &BucketParams,
    _io: CountBucketsIo<'_>,
    local: &mut [u32; BUCKET_COUNT as usize],
) {
    if ids.local_index < BUCKET_COUNT {
        local[ids.local_index as usize] = 0;
    }
}

/// Phase 2: each pixel adds itself to its bucket in workgroup memory. The dispatch's z is the
/// plane group, whose requests are the z-th layer of `requests`.
#[inline]
pub fn count(
    ids: WorkgroupIds,
    p: &BucketParams,
    io: CountBucketsIo<'_>,
    local: &mut [u32; BUCKET_COUNT as usize],
) {
    let CountBucketsIo { requests, .. } = io;
    let id = ids.global;
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let layer = (id.z * p.width * p.height) as usize;
    let b = super::requests::bucket_of(requests[layer + pixel_index(id.x, id.y, p.width)]);
    if b < BUCKET_COUNT {
        atomic::add_workgroup(&mut local[b as usize], 1);
    }
}

/// Phase 3: invocation `b` adds the workgroup's count of bucket `b` to its group's total and to
/// its ring's row: one global atomic per bucket per workgroup, not one per pixel.
#[inline]
pub fn flush(
    ids: WorkgroupIds,
    p: &BucketParams,
    io: CountBucketsIo<'_>,
    local: &mut [u32; BUCKET_COUNT as usize],
) {
    let CountBucketsIo { counts, .. } = io;
    let (local_index, group) = (ids.local_index, ids.group);
    if local_index >= BUCKET_COUNT {
        return;
    }
    let n = local[local_index as usize];
    if n == 0 {
        return;
    }
    let ring = ring_id(group.x * GROUP, group.y * GROUP, p.width, p.height);
    let base = group.z * COUNTS_LEN;
    atomic::add(&mut counts[(base + local_index) as usize], n);
    atomic::add(
        &mut counts[(base + (1 + ring) * BUCKET_COUNT + local_index) as usize],
        n,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`rate_to_bucket`] as it was written with early returns: the selects decide the same.
    fn branchy(rate: f32) -> u32 {
        if !(rate > 0.0) {
            return NO_RAYS;
        }
        if rate >= 1.0 {
            let r = (rate + 0.5).floor().min(MAX_RATE as f32) as u32;
            return MIN_RATE_DIVISOR + r - 1;
        }
        let d = (1.0 / rate + 0.5).floor().min(MIN_RATE_DIVISOR as f32) as u32;
        if d <= 1 {
            MIN_RATE_DIVISOR
        } else {
            MIN_RATE_DIVISOR - d
        }
    }

    #[test]
    fn rate_to_bucket_selects_as_the_branches_did() {
        let special = [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            0.0,
            -0.0,
            -3.0,
            1e-38,
            f32::MIN_POSITIVE,
            2.0 / 3.0,
            1.0,
            16.5,
            1e30,
        ];
        let sweep = (0..20_000).map(|i| i as f32 * 0.001 - 1.0);
        for rate in special.into_iter().chain(sweep) {
            assert_eq!(rate_to_bucket(rate), branchy(rate), "{rate}");
        }
    }

    #[test]
    fn rates_match_the_seed() {
        assert_eq!(bucket_to_rate(0), 1.0 / 64.0);
        assert_eq!(bucket_to_rate(62), 0.5);
        assert_eq!(bucket_to_rate(63), 1.0);
        assert_eq!(bucket_to_rate(64), 1.0);
        assert_eq!(bucket_to_rate(79), 16.0);
        for b in 1..BUCKET_COUNT {
            assert!(bucket_to_rate(b) >= bucket_to_rate(b - 1));
        }
    }

    #[test]
    fn rate_to_bucket_inverts_bucket_to_rate() {
        for b in 0..BUCKET_COUNT {
            if b == 63 {
                continue; // same rate as 64; requests use 64
            }
            assert_eq!(rate_to_bucket(bucket_to_rate(b)), b, "bucket {b}");
        }
        assert_eq!(rate_to_bucket(0.0), NO_RAYS);
        assert_eq!(rate_to_bucket(f32::NAN), NO_RAYS);
        assert_eq!(rate_to_bucket(1000.0), BUCKET_COUNT - 1);
        assert_eq!(rate_to_bucket(1e-9), 0);
        assert_eq!(rate_to_bucket(0.9), MIN_RATE_DIVISOR);
    }

    #[test]
    fn rings_grow_toward_the_centre() {
        let (w, h) = (1280, 720);
        assert_eq!(ring_count(w, h), 20);
        assert_eq!(ring_id(0, 0, w, h), 0);
        assert_eq!(ring_id(w - 1, h - 1, w, h), 0);
        assert_eq!(ring_id(w / 2, h / 2, w, h), 19);
        assert_eq!(ring_count(1, 1), 1);
        assert_eq!(ring_id(0, 0, 1, 1), 0);
        assert!(ring_count(3840, 2160) <= MAX_RINGS);
    }
}
