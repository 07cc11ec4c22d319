//! [`super::detect_refill`] with the detector's terms from workgroup memory: a GPU workgroup
//! computes each texel's terms ([`detect::pixel_terms`]: two binary16 words unpacked and two
//! divisions) once for its pixels and their halo, then each invocation adds up its `(2r+1)²`
//! window from there, instead of loading and computing every texel of it on its own (25 at the
//! default radius, 81 at the largest). The terms are added in the plain kernel's order, so `λ`
//! and the lists are the same, bit for bit.

use super::super::detect::{self, plane_window};
use super::super::{plane_group, DetectRefillTiledIo, WorkgroupIds};
use super::{list, DetectRefillParams, Seen};
use crate::lanes::Lanes;
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Pixels per side of a workgroup (its threads are `GROUP`×`GROUP`).
pub const GROUP: u32 = 8;
/// The largest window radius (`detector.radius` and `detector.shadow_radius` are at most 4).
pub const HALO: u32 = 4;
/// Texels per side of a tile.
const SIDE: u32 = GROUP + 2 * HALO;
/// Texels of a tile.
const LEN: u32 = SIDE * SIDE;
/// Most planes of one plane group.
const PLANES: u32 = 4;
/// Invocations of a workgroup.
const THREADS: u32 = GROUP * GROUP;

/// Workgroup memory of [`detect_refill_tiled`](super::super::DETECT_REFILL_TILED): per plane of
/// the group (in plane order) and term (this frame's mean, the history mean, the variance of
/// their difference), the tile's terms.
#[repr(C)]
#[derive(Copy, Clone, Pod, Zeroable)]
pub struct Tile {
    terms: [f32; (3 * PLANES * LEN) as usize],
}

/// The pixel of tile texel `(tx, ty)` of workgroup `group`, `None` outside the image.
#[inline]
fn texel_pixel(group: UVec3, tx: u32, ty: u32, w: u32, h: u32) -> Option<(u32, u32)> {
    let x = (group.x * GROUP + tx) as i32 - HALO as i32;
    let y = (group.y * GROUP + ty) as i32 - HALO as i32;
    if x >= 0 && y >= 0 && x < w as i32 && y < h as i32 {
        Some((x as u32, y as u32))
    } else {
        None
    }
}

/// Phase 1: the terms of every texel of the tile, for every plane of the group.
#[inline]
pub fn load(
    ids: WorkgroupIds,
    p: &DetectRefillParams,
    io: DetectRefillTiledIo<'_>,
    tile: &mut Tile,
) {
    let DetectRefillTiledIo {
        samples, history, ..
    } = io;
    let r = &p.refill;
    let (w, h) = (r.width, r.height);
    let mut i = ids.local_index;
    while i < LEN {
        let at = texel_pixel(ids.group, i % SIDE, i / SIDE, w, h);
        let (mut z, mut slot) = (0, 0);
        while z < r.planes {
            if plane_group(r.plane_groups, z) == ids.group.z {
                let t = match at {
                    Some((x, y)) => {
                        let q = ((z * h + y) * w + x) as usize;
                        detect::pixel_terms(
                            samples[q].unpack(),
                            history[q].unpack(),
                            true,
                            &p.detect,
                        )
                    }
                    None => [0.0; 3],
                };
                let base = 3 * slot * LEN + i;
                tile.terms[base as usize] = t[0];
                tile.terms[(base + LEN) as usize] = t[1];
                tile.terms[(base + 2 * LEN) as usize] = t[2];
                slot += 1;
            }
            z += 1;
        }
        i += THREADS;
    }
}

/// Phase 2: each invocation adds up its window's terms (rows in order, each row's columns in
/// order, as [`detect::lambda`] does), writes `λ` of each plane and lists the pixel as
/// [`super::detect_refill`] does.
#[inline]
pub fn finish(
    ids: WorkgroupIds,
    p: &DetectRefillParams,
    io: DetectRefillTiledIo<'_>,
    tile: &mut Tile,
) {
    let DetectRefillTiledIo {
        requests,
        samples,
        history,
        changes,
        work,
        args,
        hist,
    } = io;
    let r = &p.refill;
    let (w, h) = (r.width, r.height);
    let (lx, ly) = (ids.local_index % GROUP, ids.local_index / GROUP);
    let (x, y) = (ids.group.x * GROUP + lx, ids.group.y * GROUP + ly);
    if x >= w || y >= h {
        return;
    }
    let id = UVec3::new(x, y, ids.group.z);
    let mut seen = Seen::<1>::new();
    let (mut z, mut slot) = (0, 0);
    while z < r.planes {
        if plane_group(r.plane_groups, z) == id.z {
            let (radius, z_full) = plane_window(&p.detect, z);
            let base = 3 * slot * LEN;
            let (mut s, mut m, mut v) = (0.0, 0.0, 0.0);
            let mut dy = 0;
            while dy <= 2 * radius {
                let first = base + (ly + HALO - radius + dy) * SIDE + lx + HALO - radius;
                let mut dx = 0;
                while dx <= 2 * radius {
                    let t = first + dx;
                    s += tile.terms[t as usize];
                    m += tile.terms[(t + LEN) as usize];
                    v += tile.terms[(t + 2 * LEN) as usize];
                    dx += 1;
                }
                dy += 1;
            }
            let lambda = detect::plane_lambda(&p.detect, z, detect::lambda_of([s, m, v], z_full));
            changes[((z * h + y) * w + x) as usize] = lambda;
            seen.plane(id, z, r, (samples, history), Lanes([lambda]));
            slot += 1;
        }
        z += 1;
    }
    list(id, r, requests, seen.listed(), (work, args, hist));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_declared_workgroup_is_the_tiles() {
        assert_eq!(
            super::super::super::DETECT_REFILL_TILED.workgroup_size,
            [GROUP, GROUP, 1]
        );
    }

    /// The denoiser dispatches it with `detect_refill`'s buffers (`Pass::variant_over_grid`).
    #[test]
    fn it_binds_what_detect_refill_binds() {
        use super::super::super::{DETECT_REFILL, DETECT_REFILL_TILED};
        assert_eq!(DETECT_REFILL_TILED.bindings, DETECT_REFILL.bindings);
        assert_eq!(DETECT_REFILL_TILED.params_size, DETECT_REFILL.params_size);
    }
}
