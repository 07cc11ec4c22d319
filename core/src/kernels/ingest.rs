//! Ingest: the engine's own G-buffer textures, in its conventions ([`crate::inputs`]), decoded
//! once into the denoiser's formats. It writes this frame's depth and normal + roughness, which
//! the denoiser keeps as last frame's next frame, and the motion; every later pass reads those.

use super::IngestIo;
use crate::inputs::{decode_depth, decode_motion, decode_normal, IngestParams};
use crate::packing;
use crate::textures::Fetch;
use glam::UVec3;

/// One pixel: depth, normal + roughness and motion from the engine's textures.
#[inline(always)]
pub fn ingest(
    id: UVec3,
    p: &IngestParams,
    io: IngestIo<'_>,
    engine_depth: impl Fetch,
    engine_normal: impl Fetch,
    engine_motion: impl Fetch,
) {
    let IngestIo {
        view,
        depth,
        normal_roughness,
        motion,
    } = io;
    let (x, y, w) = (id.x, id.y, p.width);
    if x >= w || y >= p.height {
        return;
    }
    let pix = super::pixel_index(x, y, w);
    let v = &view[0];
    let d = decode_depth(engine_depth.load(x, y, w).x, p);
    let (n, roughness) = decode_normal(engine_normal.load(x, y, w), p, &v.camera);
    let m = decode_motion(
        engine_motion.load(x, y, w),
        p,
        x,
        y,
        d,
        [&v.camera, &v.prev_camera],
    );
    depth[pix] = d;
    normal_roughness[pix] = packing::pack_normal_roughness(n, roughness * roughness);
    motion[pix] = packing::pack_motion(m.x, m.y, m.z);
}
