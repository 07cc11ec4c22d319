//! The work lists: what `apply` and the refill lists hand to ray generation, and what an engine
//! that traces the rays itself reads. An entry is one word, the pixel and its rays
//! ([`work_entry`]); each list counts its entries and its dispatch groups in `ARGS_LEN` words
//! an indirect dispatch reads. Below every kernel that writes or reads a list, so none of them
//! imports another for it.

use crate::atomic;
use crate::lanes::{self, Lanes};

/// Invocations per workgroup of list-driven kernels (the work list's dispatch granularity).
pub const LIST_GROUP: u32 = 64;
/// Words of the indirect-arguments buffer: `[count, groups_x, groups_y, groups_z]`.
pub const ARGS_LEN: u32 = 4;

/// Bits of a [`work_entry`] holding the pixel index: images up to 2^28 pixels (16384²).
pub const WORK_PIXEL_BITS: u32 = 28;
/// Most pixels an image may have, so every pixel index fits a [`work_entry`] (the last index is
/// left out: with all bits set it is [`SKIPPED`]).
pub const MAX_PIXELS: u64 = (1 << WORK_PIXEL_BITS) - 1;

/// The work-list word of pixel `pix` tracing `rays` rays (1 to [`MAX_RATE`](super::buckets::MAX_RATE)): the pixel in the low
/// [`WORK_PIXEL_BITS`], `rays - 1` above.
#[inline]
pub fn work_entry(pix: u32, rays: u32) -> u32 {
    pix | ((rays - 1) << WORK_PIXEL_BITS)
}

/// The pixel index and ray count of a [`work_entry`].
#[inline]
pub fn work_item(entry: u32) -> (usize, u32) {
    (
        (entry & ((1 << WORK_PIXEL_BITS) - 1)) as usize,
        (entry >> WORK_PIXEL_BITS) + 1,
    )
}

/// A work-list entry that traces nothing: what [`refill::cap`](super::refill::cap) leaves of
/// an entry the lists had no room for (ray generation skips it).
pub const SKIPPED: u32 = u32::MAX;

/// Appends the lanes that `trace` (pixels `pix0 + l`, `rays[l]` rays each) to group `group`'s
/// work list (`work[group · pixels..]`, counted in `args[4 · group]`, whose `args[4 · group + 1]`
/// ends as the number of [`LIST_GROUP`]-wide groups). The row reserves its slots with one
/// atomic add: invocations contending for one counter are what a CPU core pays for (two threads
/// adding per pixel were slower than one; see `docs/results/per-pass.md`).
#[inline(always)]
pub fn append<const N: usize>(
    work: &mut [u32],
    args: &mut [u32],
    group: u32,
    pixels: u32,
    pix0: u32,
    traces: Lanes<bool, N>,
    rays: Lanes<u32, N>,
) {
    let mut count = 0;
    lanes::each_lane!(l in N {
        count += traces.0[l] as u32;
    });
    if count == 0 {
        return;
    }
    let a = (group * ARGS_LEN) as usize;
    let first = atomic::add(&mut args[a], count);
    let mut slot = first;
    lanes::each_lane!(l in N {
        if traces.0[l] {
            work[(group * pixels + slot) as usize] = work_entry(pix0 + l as u32, rays.0[l]);
            slot += 1;
        }
    });
    // The slots that start a list group raise its group count (the last such slot wins).
    let last = slot - 1;
    if first.is_multiple_of(LIST_GROUP) || last / LIST_GROUP != first / LIST_GROUP {
        atomic::max(&mut args[a + 1], last / LIST_GROUP + 1);
    }
}
