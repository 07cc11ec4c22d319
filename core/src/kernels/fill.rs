//! Fills a `u32` buffer with a value: resets counters (the bucket histogram) on the GPU timeline,
//! so a frame needs no host writes between passes and records into one command buffer.

use super::FillIo;
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Invocations per workgroup.
pub const GROUP: u32 = 64;

/// Push constants of [`fill`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FillParams {
    /// Words to write, from the start of the buffer.
    pub len: u32,
    /// Value written.
    pub value: u32,
}

/// One invocation per word.
pub fn fill(id: UVec3, p: &FillParams, io: FillIo<'_>) {
    let FillIo { buf } = io;
    if id.x < p.len {
        buf[id.x as usize] = p.value;
    }
}
