//! Copies one `u32` buffer into another: a pass that only moves bytes, run through the same
//! executor as the denoiser's passes, so a per-pass report can measure the bandwidth those passes
//! are bounded by (the memory-bound floor of a denoiser).

use super::CopyIo;
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Push constants of [`copy`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CopyParams {
    /// Words per row of the dispatch grid (a multiple of the workgroup width, 64, keeps every
    /// invocation busy); word `y * row + x` is copied by invocation `(x, y)`.
    pub row: u32,
    /// Words to copy.
    pub len: u32,
}

/// One invocation per word: `dst[i] = src[i]` for `i < len`.
pub fn copy(id: UVec3, p: &CopyParams, io: CopyIo<'_>) {
    let CopyIo { src, dst } = io;
    let i = id.y * p.row + id.x;
    if id.x < p.row && i < p.len {
        dst[i as usize] = src[i as usize];
    }
}
