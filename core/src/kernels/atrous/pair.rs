//! The first two à-trous iterations (steps 1 and 2) in one dispatch: a GPU workgroup filters
//! the second iteration's [`GROUP`]×[`GROUP`] pixels from the first iteration's results, which
//! it computes itself, in workgroup memory, for them and their halo. The first iteration's
//! result never goes through memory: two passes' reads and writes (16 bytes per pixel for AO)
//! become one's, for the price of filtering the halo again (a workgroup filters `(GROUP + 8)²`
//! pixels in its first iteration, 4x its own).
//!
//! Only steps 1 and 2 fuse: every later step's halo is wider, and the 3×3-blurred variance
//! reads unit offsets, so a lattice of pixels ([`super::tile`]) cannot carry it. The results are
//! word for word those of two [`super::atrous`] iterations: the first iteration's are rounded to
//! binary16 as that pass stores them, and every pixel decides from its own tile's iteration
//! count ([`crate::kernels::classify`]), the halo's included.

use super::super::classify::tile_index;
use super::super::{AtrousPairIo, WorkgroupIds};
use super::tile::{filter_texel, Decoded, TexelArrays, Texels};
use super::AtrousParams;
use super::{passes_through, Extra, InputVariance, VarianceRows};
use crate::lanes::{self, Lanes};
use crate::payload::PackedFiltered;
use bytemuck::Zeroable;
use glam::{UVec3, Vec3};

/// Pixels per side of a workgroup's output (its threads are `GROUP`×`GROUP`).
pub const GROUP: u32 = 8;
/// Pixels per side of the first iteration's region: the output and the second iteration's
/// reach (two taps of step 2) either side.
const FIRST: u32 = GROUP + 8;
/// Texels per side of the tile: the first iteration's region and its reach (two taps of step
/// 1) either side.
const SIDE: u32 = FIRST + 4;
/// Texels of a tile.
const LEN: usize = (SIDE * SIDE) as usize;
/// Where the output starts in the tile, along each axis.
const MARGIN: u32 = (SIDE - GROUP) / 2;

/// Workgroup memory of [`atrous_pair`](super::super::ATROUS_PAIR): the tile's texels, and the
/// first iteration's result at each texel of its region (packed as that pass stores it).
#[repr(C)]
#[derive(Copy, Clone, Zeroable)]
pub struct Pair {
    input: TexelArrays<SIDE, LEN>,
    first: [PackedFiltered; LEN],
}

/// The parameters of the two iterations: those given for the first (whatever their step, it
/// is 1), and the next.
#[inline(always)]
fn iterations(p: &AtrousParams) -> (AtrousParams, AtrousParams) {
    let first = AtrousParams { step: 1, ..*p };
    let second = AtrousParams {
        step: 2,
        iteration: p.iteration + 1,
        ..*p
    };
    (first, second)
}

/// Pixel of tile texel `(i, j)` of workgroup `group`, `None` outside the image.
#[inline(always)]
fn pixel(group: UVec3, i: u32, j: u32, p: &AtrousParams) -> Option<(u32, u32)> {
    let x = (group.x * GROUP + i) as i32 - MARGIN as i32;
    let y = (group.y * GROUP + j) as i32 - MARGIN as i32;
    if x >= 0 && y >= 0 && x < p.width as i32 && y < p.height as i32 {
        Some((x as u32, y as u32))
    } else {
        None
    }
}

/// Phase 1: the workgroup's invocations load and decode the tile's texels between them.
#[inline]
pub fn load(ids: WorkgroupIds, p: &AtrousParams, io: AtrousPairIo<'_>, pair: &mut Pair) {
    let AtrousPairIo {
        input,
        depth,
        normal_roughness,
        ..
    } = io;
    let mut i = ids.local_index;
    while i < LEN as u32 {
        let t = i as usize;
        match pixel(ids.group, i % SIDE, i / SIDE, p) {
            Some((x, y)) => {
                let d = Decoded::at(x, y, ids.group.z, p, (input, depth, normal_roughness));
                pair.input.put(t, d);
            }
            None => pair.input.clear(t),
        }
        i += GROUP * GROUP;
    }
}

/// Phase 2: the first iteration over the region, each invocation a few of its pixels, from the
/// tile (or passed through, as [`super::atrous`]).
#[inline]
pub fn first(ids: WorkgroupIds, p: &AtrousParams, io: AtrousPairIo<'_>, pair: &mut Pair) {
    let AtrousPairIo {
        input,
        view,
        tiles,
        guide,
        penumbra,
        ..
    } = io;
    let (p1, _) = iterations(p);
    let (w, h) = (p.width, p.height);
    let extra = Extra {
        view: &view[0],
        guide,
        penumbra,
    };
    let mut r = ids.local_index;
    while r < FIRST * FIRST {
        let (i, j) = (r % FIRST + 2, r / FIRST + 2);
        let t = (i + j * SIDE) as usize;
        r += GROUP * GROUP;
        let Some((x, y)) = pixel(ids.group, i, j, p) else {
            pair.first[t] = PackedFiltered::default();
            continue;
        };
        let id = UVec3::new(x, y, ids.group.z);
        let index = ((id.z * h + y) * w + x) as usize;
        let texels = &pair.input;
        let cd = texels.depth(t);
        if passes_through(&p1, id.z, cd, tiles[tile_index(x, y, w)]) {
            pair.first[t] = input[index];
            continue;
        }
        let variances = InputVariance::new(input, id, &p1);
        pair.first[t] = filter_texel(id, &p1, (texels, t, 1), variances, extra);
    }
}

/// Phase 3: each invocation's pixel, the second iteration from the first's results (or passed
/// through, as [`super::atrous`]).
#[inline]
pub fn second(ids: WorkgroupIds, p: &AtrousParams, io: AtrousPairIo<'_>, pair: &mut Pair) {
    let AtrousPairIo {
        view,
        tiles,
        guide,
        penumbra,
        out,
        ..
    } = io;
    let (_, p2) = iterations(p);
    let (w, h) = (p.width, p.height);
    let (i, j) = (
        ids.local_index % GROUP + MARGIN,
        ids.local_index / GROUP + MARGIN,
    );
    let Some((x, y)) = pixel(ids.group, i, j, p) else {
        return;
    };
    let id = UVec3::new(x, y, ids.group.z);
    let index = ((id.z * h + y) * w + x) as usize;
    let t = (i + j * SIDE) as usize;
    let texels = First(&*pair);
    let cd = texels.depth(t);
    if passes_through(&p2, id.z, cd, tiles[tile_index(x, y, w)]) {
        out[index] = pair.first[t];
        return;
    }
    let extra = Extra {
        view: &view[0],
        guide,
        penumbra,
    };
    let rows = FirstVariance {
        texels,
        x0: ids.group.x * GROUP,
        y0: ids.group.y * GROUP,
        width: w,
    };
    out[index] = filter_texel(id, &p2, (texels, t, 2), rows, extra);
}

/// The first iteration's variances around a workgroup's pixels (`(x0, y0)` the first): its 3×3
/// neighbours, clamped to the image, lie within the region.
#[derive(Copy, Clone)]
struct FirstVariance<'a> {
    texels: First<'a>,
    x0: u32,
    y0: u32,
    width: u32,
}

impl VarianceRows<1> for FirstVariance<'_> {
    #[inline(always)]
    fn row(&self, x0: i32, y: u32) -> Lanes<f32, 1> {
        let x = lanes::clamp_column(x0, self.width);
        let t = (x + MARGIN - self.x0) + (y + MARGIN - self.y0) * SIDE;
        Lanes([self.texels.filtered(t as usize).1])
    }
}

/// The tile's texels as the second iteration reads them: the first iteration's results.
#[derive(Copy, Clone)]
struct First<'a>(&'a Pair);

impl Texels for First<'_> {
    const SIDE: u32 = SIDE;

    #[inline(always)]
    fn depth(&self, t: usize) -> f32 {
        (&self.0.input).depth(t)
    }

    #[inline(always)]
    fn filtered(&self, t: usize) -> (f32, f32) {
        let f = self.0.first[t].unpack();
        (f.value, f.variance)
    }

    #[inline(always)]
    fn direction(&self, t: usize) -> Vec3 {
        (&self.0.input).direction(t)
    }
}

#[cfg(test)]
mod tests {
    /// The denoiser dispatches it with `atrous`'s buffers (`Pass::variant_over_grid`).
    #[test]
    fn it_binds_what_atrous_binds() {
        use super::super::super::{ATROUS, ATROUS_PAIR};
        assert_eq!(ATROUS_PAIR.bindings, ATROUS.bindings);
        assert_eq!(ATROUS_PAIR.params_size, ATROUS.params_size);
        assert_eq!(ATROUS_PAIR.workgroup_size, [super::GROUP, super::GROUP, 1]);
    }
}
