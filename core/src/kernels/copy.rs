//! Copies one `u32` buffer into another: a pass that only moves bytes, run through the same
//! executor as the denoiser's passes, so a per-pass report can measure the bandwidth those passes
//! are bounded by (the memory-bound floor of a denoiser).

use super::CopyIo;
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Words each invocation copies: a GPU starts workgroups at a limited rate, and one word per
/// 64-wide workgroup invocation kept an H100 far below its memory's copy rate, which four reach
/// (see `docs/results/per-pass.md`).
pub const WORDS_PER_INVOCATION: u32 = 4;
/// Invocations of a workgroup (`kernels::COPY`).
const GROUP: u32 = 64;

/// Push constants of [`copy`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CopyParams {
    /// Invocations per row of the dispatch grid (a multiple of the workgroup width, 64, keeps
    /// every invocation busy); invocation `(x, y)` is number `y * row + x`.
    pub row: u32,
    /// Words to copy.
    pub len: u32,
}

/// Invocation `k` copies words `(k / 64) · 256 + k % 64 + 64 · j`, `j < 4`, below `len`: the 64
/// invocations of a workgroup read 4 consecutive runs of 64 words, and `len / 4` invocations
/// copy everything.
pub fn copy(id: UVec3, p: &CopyParams, io: CopyIo<'_>) {
    let CopyIo { src, dst } = io;
    if id.x >= p.row {
        return;
    }
    let k = id.y * p.row + id.x;
    let base = (k / GROUP) * (GROUP * WORDS_PER_INVOCATION) + k % GROUP;
    let mut j = 0;
    while j < WORDS_PER_INVOCATION {
        let i = base + j * GROUP;
        if i < p.len {
            dst[i as usize] = src[i as usize];
        }
        j += 1;
    }
}
