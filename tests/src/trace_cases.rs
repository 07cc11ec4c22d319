//! Equivalence cases of the ray-tracing kernels (G-buffer, AO and shadow raygen) on real geometry:
//! a random frame of the built-in animated `room` (moving objects, thin railing, sky), so rays hit
//! edges, thin poles and nothing at all.

use crate::inputs::{self, Images};
use crate::layouts::{FLOATS, INTS, PAYLOAD, SAMPLE};
use crate::{BufferSpec, Case, Word};
use rand::Rng;
use rand_pcg::Pcg32;
use vrrt_core::camera::View;
use vrrt_core::glam::Vec3;
use vrrt_core::kernels::gbuffer::surface_at;
use vrrt_core::kernels::raygen::{self, AreaLight};
use vrrt_core::kernels::{penumbra, work_list};
use vrrt_core::payload::{PackedPayload, PackedSample, Payload, Sample};
use vrrt_core::surface::Surface;
use vrrt_scene::FrameGeometry;

const F: Word = Word::F32;
const U: Word = Word::U32;
/// `BvhNode`: bounds are floats, `first` and `count` integers.
const NODE: &[Word] = &[F, F, F, U, F, F, F, U];
/// `Triangle`: nine coordinates, then the instance id.
const TRIANGLE: &[Word] = &[F, F, F, F, F, F, F, F, F, U];

/// A random frame of the animated room.
pub fn room_frame(rng: &mut Pcg32) -> FrameGeometry {
    let scene = vrrt_scene::builtin::builtin("room").expect("built-in scene");
    scene.frame(rng.random_range(0..scene.frame_count))
}

/// The G-buffer of `frame` at `w × h`, computed natively (the input of the raygen cases).
pub fn surfaces(frame: &FrameGeometry, w: u32, h: u32) -> Vec<Surface> {
    let p = frame.gbuffer_params(w, h);
    let g = &frame.geometry;
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            surface_at(
                x,
                y,
                &p,
                &g.nodes,
                &g.triangles,
                &g.normals,
                &frame.instances,
            )
        })
        .collect()
}

/// The cameras of `frame`.
pub fn frame_view(frame: &FrameGeometry) -> View {
    View {
        camera: frame.camera,
        prev_camera: frame.prev_camera,
    }
}

/// The packed G-buffer of `frame` at `w × h` (its `surfaces`).
pub fn images(frame: &FrameGeometry, w: u32, h: u32) -> Images {
    Images::pack(&surfaces(frame, w, h), w, &frame_view(frame))
}

/// What the renderer's ray generation binds of a G-buffer: depth, normal + roughness, the
/// renderer's geometry, and the view.
pub(crate) fn raygen_inputs(g: &Images, frame: &FrameGeometry) -> [BufferSpec; 4] {
    [
        g.depth(),
        g.normal_roughness(),
        g.geometry(),
        inputs::view(&frame_view(frame)),
    ]
}

pub(crate) fn groups(
    kernel: &vrrt_core::executor::KernelDesc,
    w: u32,
    h: u32,
    planes: u32,
) -> [u32; 3] {
    let [x, y, z] = kernel.workgroup_size;
    [w.div_ceil(x), h.div_ceil(y), planes.div_ceil(z)]
}

/// Geometry buffers shared by all three kernels: nodes, then triangles.
pub(crate) fn geometry_buffers(frame: &FrameGeometry) -> [BufferSpec; 2] {
    [
        BufferSpec::from_pod(&frame.geometry.nodes, NODE),
        BufferSpec::from_pod(&frame.geometry.triangles, TRIANGLE),
    ]
}

/// `gbuffer`: primary rays of a random room frame.
pub fn gbuffer_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let frame = room_frame(rng);
    let [nodes, tris] = geometry_buffers(&frame);
    Case {
        name: format!("gbuffer {w}x{h} frame {}", frame.index),
        kernel: &vrrt_core::kernels::GBUFFER,
        buffers: vec![
            nodes,
            tris,
            BufferSpec::from_pod(&frame.geometry.normals, FLOATS),
            BufferSpec::from_pod(&frame.instances, FLOATS),
            BufferSpec::from_pod(&vec![0f32; (w * h) as usize], FLOATS),
            // Octahedral codes round a normalised float normal to 11 bits: decided.
            BufferSpec::from_pod(&vec![0u32; (w * h) as usize], INTS).decided(),
            BufferSpec::from_pod(
                &vec![[0u32; 2]; (w * h) as usize],
                &[Word::Half2, Word::Half2],
            ),
            BufferSpec::from_pod(&vec![[0u32; 2]; (w * h) as usize], &[U, U]).decided(),
        ],
        params: bytemuck::bytes_of(&frame.gbuffer_params(w, h)).to_vec(),
        groups: groups(&vrrt_core::kernels::GBUFFER, w, h, 1),
    }
}

/// A work list over a random subset of pixels in random order, each entry with the rays it traces
/// (1..=4, `work_list::work_entry`), and the reprojected history holding each pixel's rng index (including indices about to wrap).
pub(crate) struct WorkList {
    work: Vec<u32>,
    args: [u32; 8],
    /// Which of the two lists (plane groups) the kernel traces.
    pub(crate) list: u32,
    pub(crate) history: Vec<PackedPayload>,
    pub(crate) groups: [u32; 3],
}

impl WorkList {
    /// Two shuffled work lists of random pixels and rays, one after the other as `apply` lays out
    /// two plane groups' lists, and which one to trace: the other must be left alone.
    pub(crate) fn new(rng: &mut Pcg32, w: u32, h: u32, planes: u32) -> WorkList {
        let pixels = w * h;
        let mut work = Vec::new();
        let mut args = [0u32; 8];
        for list in 0..2 {
            let traced: Vec<u32> = (0..pixels)
                .filter(|_| rng.random_range(0..4) != 0)
                .collect();
            let mut entries: Vec<u32> = traced
                .into_iter()
                .map(|pix| work_list::work_entry(pix, rng.random_range(1..5)))
                .collect();
            for i in (1..entries.len()).rev() {
                entries.swap(i, rng.random_range(0..=i));
            }
            let count = entries.len() as u32;
            entries.resize(pixels as usize, 0);
            work.extend(entries);
            let groups = count.div_ceil(vrrt_core::kernels::RAYGEN_AO.workgroup_size[0]);
            args[4 * list..4 * list + 4].copy_from_slice(&[count, groups, 1, 1]);
        }
        let list = rng.random_range(0..2);
        let history = (0..pixels * planes)
            .map(|_| {
                Payload {
                    rng_index: match rng.random_range(0..4) {
                        0 => 0,
                        1 => 0xffff - rng.random_range(0..4),
                        _ => rng.random(),
                    },
                    ..Payload::default()
                }
                .pack()
            })
            .collect();
        // One group more than the list needs: invocations past the count must do nothing.
        let groups = [args[4 * list as usize + 1] + 1, 1, 1];
        WorkList {
            work,
            args,
            list,
            history,
            groups,
        }
    }

    /// Entries of the traced list.
    pub(crate) fn count(&self) -> u32 {
        self.args[4 * self.list as usize]
    }

    pub(crate) fn buffers(&self) -> [BufferSpec; 2] {
        [
            BufferSpec::from_pod(&self.work, INTS),
            BufferSpec::from_pod(&self.args, INTS),
        ]
    }
}

/// `raygen_ao`: AO rays from the room's G-buffer over a work list, two planes.
pub fn raygen_ao_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let frame = room_frame(rng);
    let planes = crate::cases::PLANES;
    let n = (w * h * planes) as usize;
    let [nodes, tris] = geometry_buffers(&frame);
    let list = WorkList::new(rng, w, h, planes);
    let params = raygen::AoParams {
        width: w,
        height: h,
        planes,
        max_distance: rng.random_range(0.2..4.0),
        list: list.list,
        frame: rng.random(),
        sampling: crate::cases::sampling(rng, w),
        _pad: 0,
    };
    let [work, args] = list.buffers();
    let [depth, normal_roughness, geometry, view] = raygen_inputs(&images(&frame, w, h), &frame);
    Case {
        name: format!(
            "raygen_ao {w}x{h}x{planes} frame {} list {}",
            frame.index,
            list.count()
        ),
        kernel: &vrrt_core::kernels::RAYGEN_AO,
        buffers: vec![
            work,
            args,
            depth,
            normal_roughness,
            geometry,
            view,
            BufferSpec::from_pod(&list.history, PAYLOAD),
            nodes,
            tris,
            BufferSpec::from_pod(&vec![PackedSample::default(); n], SAMPLE),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: list.groups,
    }
}

/// `raygen_shadow`: the room's moving light on plane 0, a small fixed light by the wall on 1.
pub fn raygen_shadow_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let frame = room_frame(rng);
    let planes = crate::cases::PLANES;
    let n = (w * h * planes) as usize;
    let mut lights = frame.lights.clone();
    lights.push(AreaLight::new(
        Vec3::new(-5.5, 2.0, -4.5),
        Vec3::Z * 0.5,
        Vec3::Y * 0.5,
    ));
    lights.truncate(planes as usize);
    let [nodes, tris] = geometry_buffers(&frame);
    let list = WorkList::new(rng, w, h, planes);
    // Shadows after another signal's plane, sometimes with planes that have no light.
    let first_plane = rng.random_range(0..planes);
    lights.truncate(rng.random_range(1..=(planes - first_plane) as usize));
    let params = raygen::ShadowParams {
        width: w,
        height: h,
        planes: planes - first_plane,
        first_plane,
        list: list.list,
        frame: rng.random(),
        sampling: crate::cases::sampling(rng, w),
        // The blocker records of one shadow plane (some without a light), or of none (1×1).
        blocker_plane: if w == 1 {
            vrrt_core::kernels::reproject::NO_PLANE
        } else {
            rng.random_range(first_plane..planes)
        },
    };
    let [work, args] = list.buffers();
    let [depth, normal_roughness, geometry, view] = raygen_inputs(&images(&frame, w, h), &frame);
    Case {
        name: format!(
            "raygen_shadow {w}x{h}x{planes} frame {} list {} blockers {}",
            frame.index,
            list.count(),
            params.blocker_plane as i32
        ),
        kernel: &vrrt_core::kernels::RAYGEN_SHADOW,
        buffers: vec![
            work,
            args,
            depth,
            normal_roughness,
            geometry,
            view,
            BufferSpec::from_pod(&list.history, PAYLOAD),
            nodes,
            tris,
            BufferSpec::from_pod(&lights, FLOATS),
            BufferSpec::from_pod(&vec![PackedSample::default(); n], SAMPLE),
            BufferSpec::from_pod(&vec![0.0f32; (w * h) as usize], FLOATS),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: list.groups,
    }
}

/// `penumbra_guide`: the window mean of blocker records (lit, blocked, behind the surface) of
/// pixels that traced this frame or not, over the room's depth (sky included).
pub fn penumbra_guide_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let frame = room_frame(rng);
    let planes = crate::cases::PLANES;
    let samples: Vec<PackedSample> = (0..w * h * planes)
        .map(|_| {
            let rays = rng.random_range(0..3);
            let m1 = rng.random_range(0.0..=1.0);
            Sample {
                m1,
                m2: m1,
                rays,
                first: 0.0,
            }
            .pack()
        })
        .collect();
    let blockers: Vec<f32> = (0..w * h)
        .map(|_| match rng.random_range(0..4) {
            0 => raygen::NO_BLOCKER,
            1 => 0.0,
            _ => rng.random_range(0.0..2.0),
        })
        .collect();
    let params = penumbra::PenumbraParams {
        width: w,
        height: h,
        plane: rng.random_range(0..planes),
        radius: rng.random_range(0..=3),
        pixel_angle: frame.camera.tan_half_fov_y * 2.0 / h as f32,
    };
    let [depth, ..] = raygen_inputs(&images(&frame, w, h), &frame);
    Case {
        name: format!(
            "penumbra_guide {w}x{h} plane {} radius {}",
            params.plane, params.radius
        ),
        kernel: &vrrt_core::kernels::PENUMBRA_GUIDE,
        buffers: vec![
            BufferSpec::from_pod(&samples, SAMPLE),
            BufferSpec::from_pod(&blockers, FLOATS),
            depth,
            BufferSpec::from_pod(&vec![0.0f32; (w * h) as usize], FLOATS),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&vrrt_core::kernels::PENUMBRA_GUIDE, w, h, 1),
    }
}
