//! The kernels' G-buffer inputs from `Surface`s, as the buffers of a case: what an engine (or the
//! `gbuffer` kernel) writes, packed by core's [`Surface::pack`].

use crate::{BufferSpec, Word};
use vrrt_core::camera::{Camera, View};
use vrrt_core::glam::Vec3;
use vrrt_core::surface::Surface;

const F: Word = Word::F32;
const U: Word = Word::U32;

/// A camera for synthetic cases: above the origin, looking down −z.
pub fn test_view() -> View {
    let camera = Camera::look_at(Vec3::new(0.3, 0.4, 6.0), Vec3::ZERO, Vec3::Y, 0.9);
    View {
        camera,
        prev_camera: camera,
    }
}

/// The packed input images of a row-major G-buffer.
pub struct Images {
    /// View depth.
    pub depth: Vec<f32>,
    /// Normal + roughness.
    pub normal_roughness: Vec<u32>,
    /// 2.5D motion.
    pub motion: Vec<[u32; 2]>,
    /// The renderer's geometric normal and instance.
    pub geometry: Vec<[u32; 2]>,
}

impl Images {
    /// Packs `surfaces` (`width` per row) with last frame's depth through `view.prev_camera`.
    pub fn pack(surfaces: &[Surface], width: u32, view: &View) -> Images {
        let mut out = Images {
            depth: Vec::with_capacity(surfaces.len()),
            normal_roughness: Vec::with_capacity(surfaces.len()),
            motion: Vec::with_capacity(surfaces.len()),
            geometry: Vec::with_capacity(surfaces.len()),
        };
        for (i, s) in surfaces.iter().enumerate() {
            let (x, y) = (i as u32 % width, i as u32 / width);
            let t = s.pack(x, y, &view.prev_camera);
            out.depth.push(t.depth);
            out.normal_roughness.push(t.normal_roughness);
            out.motion.push(t.motion);
            out.geometry.push(t.hit);
        }
        out
    }

    /// The depth buffer of a case.
    pub fn depth(&self) -> BufferSpec {
        BufferSpec::from_pod(&self.depth, &[F])
    }

    /// The normal + roughness buffer of a case.
    pub fn normal_roughness(&self) -> BufferSpec {
        BufferSpec::from_pod(&self.normal_roughness, &[U])
    }

    /// The motion buffer of a case.
    pub fn motion(&self) -> BufferSpec {
        BufferSpec::from_pod(&self.motion, &[U, U])
    }

    /// The renderer's geometry buffer of a case.
    pub fn geometry(&self) -> BufferSpec {
        BufferSpec::from_pod(&self.geometry, &[U, U])
    }
}

/// The one-element view buffer of a case.
pub fn view(view: &View) -> BufferSpec {
    BufferSpec::from_pod(std::slice::from_ref(view), &[F; 26])
}
