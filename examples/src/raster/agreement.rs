//! How closely the engine's rasterized G-buffer, decoded by the denoiser, agrees with VRRT's own
//! ray-traced one (`kernels::gbuffer`) on the same frame: the check that every convention was
//! decoded right, and the count of pixels where the two see different surfaces.
//!
//! Why surfaces can differ: a rasterizer snaps vertices to a sub-pixel grid (1/256 pixel on
//! lavapipe and most GPUs) while the tracer intersects exactly, so where an edge passes within
//! that of a pixel centre the two may pick different sides of it: another triangle of the same
//! mesh, another object, or — at an object's outline against the sky — a surface where the
//! tracer sees none. Those are ties, not errors; a pixel that sees the same face in both but
//! decodes to another depth, normal or motion is an error.

use vrrt_core::kernels::gbuffer::surface_at;
use vrrt_core::packing::{unpack_hit, unpack_motion, unpack_normal_roughness};
use vrrt_core::surface::{has_surface, Texel};
use vrrt_scene::FrameGeometry;

/// Relative view-depth difference allowed on the same face: the rasterizer interpolates depth
/// from snapped vertices, the tracer from the exact hit.
pub const DEPTH_TOLERANCE: f32 = 1e-4;
/// Smallest cosine between the two shading normals on the same face (their 11-bit octahedral
/// codes are within 0.1° of each other).
pub const NORMAL_COSINE: f32 = 0.999;
/// Motion difference allowed on the same face, pixels, plus [`MOTION_RELATIVE`] of the motion:
/// the engine's velocity is binary16 in UV units, ours binary16 in pixels.
pub const MOTION_TOLERANCE: f32 = 0.02;
/// See [`MOTION_TOLERANCE`].
pub const MOTION_RELATIVE: f32 = 2e-3;

/// One frame's comparison.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct Agreement {
    /// Pixels compared.
    pub pixels: usize,
    /// Pixels where one G-buffer has a surface and the other the sky (outline ties).
    pub sky_ties: usize,
    /// Pixels where both have a surface but not the same face (ties between faces).
    pub face_ties: usize,
    /// Pixels on the same face whose depth, normal, roughness or motion disagree: errors.
    pub errors: usize,
    /// The first error's pixel index, if any.
    pub first_error: Option<usize>,
}

impl Agreement {
    /// Both frames' counts added (the first error of `self` first).
    pub fn plus(self, o: Agreement) -> Agreement {
        Agreement {
            pixels: self.pixels + o.pixels,
            sky_ties: self.sky_ties + o.sky_ties,
            face_ties: self.face_ties + o.face_ties,
            errors: self.errors + o.errors,
            first_error: self.first_error.or(o.first_error),
        }
    }
}

/// VRRT's ray-traced G-buffer of frame `f` at `(width, height)`, per pixel as its G-buffer pass
/// packs it, computed on the host with the pass's own function.
pub fn traced(f: &FrameGeometry, (width, height): (u32, u32)) -> Vec<Texel> {
    let p = f.gbuffer_params(width, height);
    let g = &f.geometry;
    (0..width * height)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            surface_at(x, y, &p, &g.nodes, &g.triangles, &g.normals, &f.instances).pack(
                x,
                y,
                &f.prev_camera,
            )
        })
        .collect()
}

/// Compares the decoded G-buffer `ours` with the ray-traced `traced`, pixel by pixel. The sky's
/// motion is not compared: the tracer gives it the camera's rotation, the engine 0, and no pass
/// reads motion where there is no surface.
pub fn compare(ours: &[Texel], traced: &[Texel]) -> Agreement {
    let mut a = Agreement {
        pixels: ours.len(),
        ..Agreement::default()
    };
    for (i, (o, t)) in ours.iter().zip(traced).enumerate() {
        match (has_surface(o.depth), has_surface(t.depth)) {
            (false, false) => {}
            (true, true) if !same_face(o, t) => a.face_ties += 1,
            (true, true) => {
                if !same_values(o, t) {
                    a.errors += 1;
                    a.first_error = a.first_error.or(Some(i));
                }
            }
            _ => a.sky_ties += 1,
        }
    }
    a
}

/// Smallest cosine between the geometric normals of the same face: within 0.08°, where their
/// 16-bit octahedral codes are at most a step apart; neighbouring faces of a fine scan can be
/// nearly coplanar.
pub const FACE_COSINE: f32 = 0.999_999;

/// Whether both see the same face: the same instance and geometric normal, and shading normals
/// not opposite (which a coincident face of the other winding gives).
fn same_face(o: &Texel, t: &Texel) -> bool {
    let ((go, io), (gt, it)) = (unpack_hit(o.hit), unpack_hit(t.hit));
    let (no, nt) = (normal(o), normal(t));
    io == it && go.dot(gt) >= FACE_COSINE && no.dot(nt) > -0.99
}

fn normal(t: &Texel) -> vrrt_core::glam::Vec3 {
    unpack_normal_roughness(t.normal_roughness).0
}

/// Whether depth, normal, roughness and motion agree within what the formats hold.
fn same_values(o: &Texel, t: &Texel) -> bool {
    let depth = (o.depth - t.depth).abs() <= DEPTH_TOLERANCE * t.depth;
    let (no, ro) = unpack_normal_roughness(o.normal_roughness);
    let (nt, rt) = unpack_normal_roughness(t.normal_roughness);
    let shading = no.dot(nt) >= NORMAL_COSINE && (ro - rt).abs() <= 1e-3;
    let (mo, mt) = (unpack_motion(o.motion), unpack_motion(t.motion));
    let allowed = MOTION_TOLERANCE + MOTION_RELATIVE * mt.abs().max_element();
    let motion = (mo - mt).abs().max_element() <= allowed;
    depth && shading && motion
}
