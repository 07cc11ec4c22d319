//! Equivalence cases of the reflection kernels on a random frame of the built-in room, with the
//! roughness of each pixel redrawn so mirrors, glossy and too-rough surfaces sit side by side, and
//! ray records mixing this frame's, stale and empty ones.

use crate::inputs::{self, Images};
use crate::layouts::{FLOATS, PAYLOAD, SAMPLE};
use crate::trace_cases::{frame_view, geometry_buffers, room_frame, surfaces, WorkList};
use crate::{BufferSpec, Case, Word};
use rand::Rng;
use rand_pcg::Pcg32;
use vrrt_core::glam::Vec3;
use vrrt_core::kernels::raygen::AreaLight;
use vrrt_core::kernels::reflect::{self, RayHit, Shading};
use vrrt_core::payload::{PackedSample, Sample};
use vrrt_core::surface::Surface;
use vrrt_scene::FrameGeometry;

const F: Word = Word::F32;
const U: Word = Word::U32;
/// `RayHit`: six floats, the frame stamp, the mean log hit distance.
const HIT: &[Word] = &[F, F, F, F, F, F, U, F];

/// The room's G-buffer with roughness redrawn per pixel.
fn glossy_surfaces(rng: &mut Pcg32, frame: &FrameGeometry, w: u32, h: u32) -> Vec<Surface> {
    let mut s = surfaces(frame, w, h);
    for t in &mut s {
        t.roughness = [0.0, 0.02, 0.15, 0.3, 0.5, 0.8, 1.0][rng.random_range(0..7)];
    }
    s
}

/// The packed G-buffer of `surfaces` of `frame` and its buffers as the ray-generation kernels
/// bind them (depth, normal + roughness, geometry, view).
fn packed(surfaces: &[Surface], frame: &FrameGeometry, w: u32) -> (Images, [BufferSpec; 4]) {
    let g = Images::pack(surfaces, w, &frame_view(frame));
    let specs = [
        g.depth(),
        g.normal_roughness(),
        g.geometry(),
        inputs::view(&frame_view(frame)),
    ];
    (g, specs)
}

fn shading(rng: &mut Pcg32, frame: &FrameGeometry) -> Shading {
    let eye = frame.camera.origin();
    Shading {
        eye_x: eye.x,
        eye_y: eye.y,
        eye_z: eye.z,
        max_roughness: [0.3, 0.5, 1.0][rng.random_range(0..3)],
        light_probes: [0, 1, 7][rng.random_range(0..3)],
        ..Shading::default()
    }
}

/// The frame's light plus a small one by the wall.
fn lights(frame: &FrameGeometry) -> Vec<AreaLight> {
    let mut l = frame.lights.clone();
    l.push(AreaLight::new(
        Vec3::new(-5.5, 2.0, -4.5),
        Vec3::Z * 0.5,
        Vec3::Y * 0.5,
    ));
    l
}

/// Ray records around `surfaces`: hits at random distances, some stamped with `frame`, some
/// stale, some empty, with pdfs from tiny to huge.
fn hits(rng: &mut Pcg32, surfaces: &[Surface], frame: u32) -> Vec<RayHit> {
    surfaces
        .iter()
        .map(|s| {
            let dir = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(0.05..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize();
            let distance = [0.01, 1.0, 7.0, reflect::MISS_DISTANCE][rng.random_range(0..4)];
            let p = s.position() + dir * distance;
            RayHit {
                hx: p.x,
                hy: p.y,
                hz: p.z,
                radiance: [0.0, 0.3, 5.0, rng.random_range(0.0..1.0)][rng.random_range(0..4)],
                pdf: [0.0, 1e-6, 0.5, 40.0, 1e6][rng.random_range(0..5)],
                distance,
                frame: if rng.random_range(0..4) == 0 {
                    frame.wrapping_add(1)
                } else {
                    frame
                },
                log_distance: rng.random_range(-14.0..14.0),
            }
        })
        .collect()
}

/// `raygen_reflect`: reflection rays over a work list into one of two planes.
pub fn raygen_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let frame = room_frame(rng);
    let planes = crate::cases::PLANES;
    let n = (w * h * planes) as usize;
    let [nodes, tris] = geometry_buffers(&frame);
    let list = WorkList::new(rng, w, h, planes);
    let lights = lights(&frame);
    let params = reflect::RaygenParams {
        width: w,
        height: h,
        plane: rng.random_range(0..planes),
        lights: rng.random_range(0..=lights.len() as u32),
        frame: rng.random(),
        list: list.list,
        sampling: crate::cases::sampling(rng, w),
        // The refill lists' pass adds to what the main pass wrote.
        merge: rng.random_range(0..2),
        shading: shading(rng, &frame),
    };
    let prior: Vec<PackedSample> = (0..n)
        .map(|_| {
            let rays = [0u32, 1, 3][rng.random_range(0..3)];
            let m1 = rng.random_range(0.0f32..4.0);
            Sample {
                m1,
                m2: m1 * m1 + rng.random_range(0.0f32..1.0),
                rays,
                first: m1,
            }
            .pack()
        })
        .collect();
    let prior_hits: Vec<RayHit> = (0..w * h)
        .map(|_| RayHit {
            log_distance: rng.random_range(-2.0f32..6.0),
            ..RayHit::default()
        })
        .collect();
    let [work, args] = list.buffers();
    let (_, [depth, normal_roughness, geometry, view]) =
        packed(&glossy_surfaces(rng, &frame, w, h), &frame, w);
    Case {
        name: format!(
            "raygen_reflect {w}x{h} plane {} sampling {} frame {} list {}",
            params.plane,
            params.sampling,
            frame.index,
            list.count()
        ),
        kernel: &vrrt_core::kernels::RAYGEN_REFLECT,
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
            // The GGX sampler accepts or rejects each try by a float comparison: a one-ULP input
            // difference may pick another direction, and the sample and hit with it.
            BufferSpec::from_pod(&prior, SAMPLE).decided(),
            BufferSpec::from_pod(&prior_hits, HIT).decided(),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: list.groups,
    }
}

/// `reflect_tiles`: tracer rays per 16×16 tile.
pub fn tiles_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let frame = room_frame(rng);
    let [nodes, tris] = geometry_buffers(&frame);
    let lights = lights(&frame);
    let min_rate = rng.random_range(0.1..1.0);
    let params = reflect::TileParams {
        width: w,
        height: h,
        lights: rng.random_range(0..=lights.len() as u32),
        frame: rng.random(),
        min_rate,
        max_rate: min_rate + rng.random_range(0.0..3.0),
        sigma: rng.random_range(0.01..0.5),
        _pad: 0,
        shading: shading(rng, &frame),
    };
    let (tw, th) = reflect::tile_grid(w, h);
    let (_, gbuffer) = packed(&glossy_surfaces(rng, &frame, w, h), &frame, w);
    let mut buffers = gbuffer.to_vec();
    buffers.extend([
        nodes,
        tris,
        BufferSpec::from_pod(&lights, FLOATS),
        BufferSpec::from_pod(&vec![0.0f32; (tw * th) as usize], FLOATS),
    ]);
    Case {
        name: format!("reflect_tiles {w}x{h} frame {}", frame.index),
        kernel: &vrrt_core::kernels::REFLECT_TILES,
        buffers,
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: crate::trace_cases::groups(&vrrt_core::kernels::REFLECT_TILES, tw, th, 1),
    }
}

/// `reflect_motion`: parallax from last frame's records, with the room's camera motion.
pub fn motion_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let frame = room_frame(rng);
    let surfaces = glossy_surfaces(rng, &frame, w, h);
    let stamp: u32 = rng.random();
    let eye = frame.camera.origin();
    let params = reflect::MotionParams {
        width: w,
        height: h,
        frame: stamp,
        radius: rng.random_range(0..=3),
        eye_x: eye.x,
        eye_y: eye.y,
        eye_z: eye.z,
        max_roughness: [0.3, 0.5, 1.0][rng.random_range(0..3)],
        prev_camera: frame.prev_camera,
    };
    let (g, [_, _, _, view]) = packed(&surfaces, &frame, w);
    Case {
        name: format!("reflect_motion {w}x{h} frame {}", frame.index),
        kernel: &vrrt_core::kernels::REFLECT_MOTION,
        buffers: vec![
            g.depth(),
            g.normal_roughness(),
            g.motion(),
            view,
            BufferSpec::from_pod(&hits(rng, &surfaces, stamp), HIT),
            BufferSpec::from_pod(&vec![[0.0f32; 2]; (w * h) as usize], FLOATS),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: crate::trace_cases::groups(&vrrt_core::kernels::REFLECT_MOTION, w, h, 1),
    }
}

/// `reflect_reuse`: neighbours' records reweighted into one of two planes of samples.
pub fn reuse_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let frame = room_frame(rng);
    let planes = crate::cases::PLANES;
    let surfaces = glossy_surfaces(rng, &frame, w, h);
    let stamp: u32 = rng.random();
    let samples: Vec<PackedSample> = (0..w * h * planes)
        .map(|_| {
            let m1 = rng.random_range(0.0..3.0);
            Sample {
                m1,
                m2: m1 * m1 + rng.random_range(0.0..1.0),
                rays: rng.random_range(0..4),
                first: m1,
            }
        })
        .map(|s| s.pack())
        .collect();
    let params = reflect::ReuseParams {
        width: w,
        height: h,
        plane: rng.random_range(0..planes),
        frame: stamp,
        radius: rng.random_range(0..=3),
        plane_threshold: [0.005, 0.02, 0.5][rng.random_range(0..3)],
        _pad: [0; 2],
        shading: shading(rng, &frame),
    };
    let (_, [depth, normal_roughness, geometry, view]) = packed(&surfaces, &frame, w);
    Case {
        name: format!(
            "reflect_reuse {w}x{h} plane {} radius {}",
            params.plane, params.radius
        ),
        kernel: &vrrt_core::kernels::REFLECT_REUSE,
        buffers: vec![
            depth,
            normal_roughness,
            geometry,
            view,
            BufferSpec::from_pod(&hits(rng, &surfaces, stamp), HIT),
            BufferSpec::from_pod(&samples, SAMPLE),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: crate::trace_cases::groups(&vrrt_core::kernels::REFLECT_REUSE, w, h, 1),
    }
}

/// `reflect_guide`: the mean log hit distance of this frame's records (some stale, some without
/// a ray) around each pixel.
pub fn guide_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let frame = room_frame(rng);
    let surfaces = glossy_surfaces(rng, &frame, w, h);
    let stamp: u32 = rng.random();
    let params = reflect::GuideParams {
        width: w,
        height: h,
        frame: stamp,
        radius: rng.random_range(0..=3),
    };
    Case {
        name: format!("reflect_guide {w}x{h} radius {}", params.radius),
        kernel: &vrrt_core::kernels::REFLECT_GUIDE,
        buffers: vec![
            BufferSpec::from_pod(&hits(rng, &surfaces, stamp), HIT),
            BufferSpec::from_pod(&vec![0.0f32; (w * h) as usize], FLOATS),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: crate::trace_cases::groups(&vrrt_core::kernels::REFLECT_GUIDE, w, h, 1),
    }
}
