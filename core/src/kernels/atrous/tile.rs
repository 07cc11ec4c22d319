//! [`super::atrous`] with its taps read from workgroup memory: a GPU workgroup first loads and
//! decodes every texel its pixels' taps touch, once, then each invocation filters from there,
//! instead of each of its 24 taps loading and decoding a neighbour of its own.
//!
//! A workgroup covers [`GROUP`]×[`GROUP`] pixels of one *lattice*: those of the same column and
//! row remainder modulo the step (`x = rx + i·step`). Every tap of such a pixel lies on the same
//! lattice, two points further at most, so one tile of `(GROUP + 4)²` texels serves every
//! iteration whatever its step; a square of neighbouring pixels would need `(GROUP + 4·step)²`.
//! The per-tile iteration counts ([`crate::kernels::classify`]) still decide per pixel, and the
//! 3×3-blurred variance (unit offsets, not on the lattice) is read from the buffer.

use super::super::classify::tile_index;
use super::super::{AtrousTiledIo, WorkgroupIds};
use super::AtrousParams;
use super::{
    filter_at, passes_through, Centre, CentreTexels, Extra, InputVariance, TapAt, TapSource,
    VarianceRows,
};
use crate::lanes::Lanes;
use crate::packing;
use crate::payload::PackedFiltered;
use crate::surface;
use crate::trace::normalize;
use bytemuck::Zeroable;
use glam::{UVec3, Vec3};

/// Pixels per side of a workgroup (its threads are `GROUP`×`GROUP`).
pub const GROUP: u32 = 8;
/// Texels per side of its tile: the pixels and two lattice points either side.
const SIDE: u32 = GROUP + 4;
/// Texels of a tile.
const LEN: usize = (SIDE * SIDE) as usize;

/// A workgroup's texels decoded, `SIDE` to a row, `LEN` in all, one array per component. A
/// texel outside the image has depth 0 (no surface: never a tap).
#[repr(C)]
#[derive(Copy, Clone, Zeroable)]
pub struct TexelArrays<const SIDE: u32, const LEN: usize> {
    depth: [f32; LEN],
    value: [f32; LEN],
    variance: [f32; LEN],
    nx: [f32; LEN],
    ny: [f32; LEN],
    nz: [f32; LEN],
}

impl<const SIDE: u32, const LEN: usize> TexelArrays<SIDE, LEN> {
    /// Texel `t` becomes `d`.
    #[inline(always)]
    pub(super) fn put(&mut self, t: usize, d: Decoded) {
        self.depth[t] = d.depth;
        self.value[t] = d.value;
        self.variance[t] = d.variance;
        self.nx[t] = d.direction.x;
        self.ny[t] = d.direction.y;
        self.nz[t] = d.direction.z;
    }

    /// Texel `t` lies outside the image: no surface.
    #[inline(always)]
    pub(super) fn clear(&mut self, t: usize) {
        self.depth[t] = 0.0;
    }
}

/// Workgroup memory of [`atrous_tiled`](super::super::ATROUS_TILED): the tile's texels.
pub type Tile = TexelArrays<SIDE, LEN>;

/// The extent [`atrous_tiled`](super::super::ATROUS_TILED) is dispatched over for an image of
/// `width`×`height` at `step` (as `Pass::over_grid`'s width and height): `step` lattices across,
/// each a whole number of workgroups.
pub fn grid(width: u32, height: u32, step: u32) -> (u32, u32) {
    let side = |n: u32| step * groups_across(n, step) * GROUP;
    (side(width), side(height))
}

/// Workgroups across one lattice of an image `n` pixels wide at `step`.
#[inline]
fn groups_across(n: u32, step: u32) -> u32 {
    n.div_ceil(step).div_ceil(GROUP)
}

/// Where a workgroup's lattice lies along one axis: its remainder `r` and the lattice index
/// `first` of its first pixel (pixel `r + (first + i)·step`).
#[inline]
fn lattice(group: u32, n: u32, step: u32) -> (u32, u32) {
    let across = groups_across(n, step);
    (group / across, (group % across) * GROUP)
}

/// Pixel coordinate of lattice point `first + i − 2` (tile index `i`) along an axis, `None`
/// outside the image.
#[inline]
fn coordinate(r: u32, first: u32, i: u32, step: u32, n: u32) -> Option<u32> {
    let k = (first + i) as i32 - 2;
    let c = r as i32 + k * step as i32;
    if k >= 0 && c < n as i32 {
        Some(c as u32)
    } else {
        None
    }
}

/// Phase 1: the workgroup's invocations load and decode the tile's texels between them.
#[inline]
pub fn load(ids: WorkgroupIds, p: &AtrousParams, io: AtrousTiledIo<'_>, tile: &mut Tile) {
    let AtrousTiledIo {
        input,
        depth,
        normal_roughness,
        ..
    } = io;
    let (w, h, s) = (p.width, p.height, p.step);
    let (rx, fx) = lattice(ids.group.x, w, s);
    let (ry, fy) = lattice(ids.group.y, h, s);
    let z = ids.group.z;
    let mut i = ids.local_index;
    while i < LEN as u32 {
        let t = i as usize;
        let at = (
            coordinate(rx, fx, i % SIDE, s, w),
            coordinate(ry, fy, i / SIDE, s, h),
        );
        match at {
            (Some(x), Some(y)) => {
                tile.put(t, Decoded::at(x, y, z, p, (input, depth, normal_roughness)))
            }
            _ => tile.clear(t),
        }
        i += GROUP * GROUP;
    }
}

/// One texel decoded: what a tile keeps of it.
pub(super) struct Decoded {
    pub depth: f32,
    pub value: f32,
    pub variance: f32,
    /// The normal's decoded, unnormalised direction.
    pub direction: Vec3,
}

impl Decoded {
    /// Pixel `(x, y)` (inside the image) of plane `z`, from the iteration's input and surfaces.
    #[inline(always)]
    pub fn at(
        x: u32,
        y: u32,
        z: u32,
        p: &AtrousParams,
        (input, depth, normal_roughness): (&[PackedFiltered], &[f32], &[u32]),
    ) -> Self {
        let (w, h) = (p.width, p.height);
        let f = input[((z * h + y) * w + x) as usize].unpack();
        Decoded {
            depth: depth[(y * w + x) as usize],
            value: f.value,
            variance: f.variance,
            direction: packing::unpack_direction(normal_roughness[(y * w + x) as usize]),
        }
    }
}

/// Phase 2: each invocation filters its pixel from the tile (or passes it through, as
/// [`super::atrous`]).
#[inline]
pub fn filter(ids: WorkgroupIds, p: &AtrousParams, io: AtrousTiledIo<'_>, tile: &mut Tile) {
    let AtrousTiledIo {
        input,
        view,
        tiles,
        guide,
        penumbra,
        out,
        ..
    } = io;
    let (w, h, s) = (p.width, p.height, p.step);
    let (lx, ly) = (ids.local_index % GROUP, ids.local_index / GROUP);
    let (rx, fx) = lattice(ids.group.x, w, s);
    let (ry, fy) = lattice(ids.group.y, h, s);
    let (Some(x), Some(y)) = (
        coordinate(rx, fx, lx + 2, s, w),
        coordinate(ry, fy, ly + 2, s, h),
    ) else {
        return;
    };
    let id = UVec3::new(x, y, ids.group.z);
    let index = ((id.z * h + y) * w + x) as usize;
    let centre = (lx + 2 + (ly + 2) * SIDE) as usize;
    let cd = tile.depth[centre];
    if passes_through(p, id.z, cd, tiles[tile_index(x, y, w)]) {
        out[index] = input[index];
        return;
    }
    let extra = Extra {
        view: &view[0],
        guide,
        penumbra,
    };
    let variances = InputVariance::new(input, id, p);
    out[index] = filter_texel(id, p, (&*tile, centre, 1), variances, extra);
}

/// [`filter_at`] of pixel `id`, which is texel `t` of `texels`, its taps `stride` texels apart
/// and its 3×3-blurred variance from `variances`.
#[inline(always)]
pub(super) fn filter_texel<T: Texels>(
    id: UVec3,
    p: &AtrousParams,
    (texels, t, stride): (T, usize, i32),
    variances: impl VarianceRows<1>,
    extra: Extra<'_>,
) -> PackedFiltered {
    let (value, variance) = texels.filtered(t);
    let c = CentreTexels {
        depth: Lanes([texels.depth(t)]),
        normal: Lanes([normalize(texels.direction(t))]),
        value: Lanes([value]),
        variance: Lanes([variance]),
    };
    let taps = TileTaps {
        texels,
        centre: t as i32,
        stride,
    };
    filter_at(id, p, (taps, variances), extra, Lanes([id.x]), &c).0[0]
}

/// A workgroup's texels, decoded, `SIDE` to a row: what [`TileTaps`] reads its taps from.
pub(super) trait Texels: Copy {
    /// Texels per row.
    const SIDE: u32;
    /// View depth of texel `t` (0: no surface, or outside the image).
    fn depth(&self, t: usize) -> f32;
    /// Value and variance of texel `t`.
    fn filtered(&self, t: usize) -> (f32, f32);
    /// Decoded (unnormalised) normal direction of texel `t`.
    fn direction(&self, t: usize) -> Vec3;
}

impl<const S: u32, const L: usize> Texels for &TexelArrays<S, L> {
    const SIDE: u32 = S;

    #[inline(always)]
    fn depth(&self, t: usize) -> f32 {
        self.depth[t]
    }

    #[inline(always)]
    fn filtered(&self, t: usize) -> (f32, f32) {
        (self.value[t], self.variance[t])
    }

    #[inline(always)]
    fn direction(&self, t: usize) -> Vec3 {
        Vec3::new(self.nx[t], self.ny[t], self.nz[t])
    }
}

/// Taps from a workgroup's texels: tap `(tx, ty)` of the pixel at texel `centre` is texel
/// `centre + (tx + ty·SIDE)·stride`, whatever the step (a lattice tile's stride is 1).
#[derive(Copy, Clone)]
pub(super) struct TileTaps<T> {
    pub texels: T,
    pub centre: i32,
    pub stride: i32,
}

impl<T: Texels> TileTaps<T> {
    /// Texel index of tap `t`.
    #[inline(always)]
    fn at(&self, t: TapAt) -> usize {
        (self.centre + (t.tx + t.ty * T::SIDE as i32) * self.stride) as usize
    }
}

impl<T: Texels> TapSource<1> for TileTaps<T> {
    #[inline(always)]
    fn depth(&self, _c: &Centre<1>, t: TapAt) -> Lanes<f32, 1> {
        Lanes([self.texels.depth(self.at(t))])
    }

    #[inline(always)]
    fn filtered(&self, _c: &Centre<1>, t: TapAt) -> (Lanes<f32, 1>, Lanes<f32, 1>) {
        let (value, variance) = self.texels.filtered(self.at(t));
        (Lanes([value]), Lanes([variance]))
    }

    #[inline(always)]
    fn cosine2(&self, c: &Centre<1>, t: TapAt) -> Lanes<f32, 1> {
        surface::squared_cosines(c.normal, Lanes([self.texels.direction(self.at(t))]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_declared_workgroup_is_the_tiles() {
        assert_eq!(
            super::super::super::ATROUS_TILED.workgroup_size,
            [GROUP, GROUP, 1]
        );
    }

    /// The denoiser dispatches it with `atrous`'s buffers (`Pass::variant_over_grid`).
    #[test]
    fn it_binds_what_atrous_binds() {
        use super::super::super::{ATROUS, ATROUS_TILED};
        assert_eq!(ATROUS_TILED.bindings, ATROUS.bindings);
        assert_eq!(ATROUS_TILED.params_size, ATROUS.params_size);
    }

    /// Every pixel of an image lies on exactly one lattice point of one workgroup of the grid,
    /// at every step, for sizes that are no multiple of a workgroup or a step.
    #[test]
    fn the_grid_covers_every_pixel_once() {
        for (w, h) in [(1, 1), (37, 19), (130, 67)] {
            for step in [1, 2, 4, 8, 16] {
                let (gw, gh) = grid(w, h, step);
                let mut seen = std::vec![0u32; (w * h) as usize];
                for gy in 0..gh / GROUP {
                    for gx in 0..gw / GROUP {
                        let ((rx, fx), (ry, fy)) = (lattice(gx, w, step), lattice(gy, h, step));
                        for j in 0..GROUP {
                            for i in 0..GROUP {
                                let at = (
                                    coordinate(rx, fx, i + 2, step, w),
                                    coordinate(ry, fy, j + 2, step, h),
                                );
                                if let (Some(x), Some(y)) = at {
                                    seen[(y * w + x) as usize] += 1;
                                }
                            }
                        }
                    }
                }
                assert!(seen.iter().all(|&n| n == 1), "{w}x{h} step {step}");
            }
        }
    }
}
