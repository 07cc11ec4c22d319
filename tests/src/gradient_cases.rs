//! Equivalence cases of the temporal-gradient prepass (`kernels::gradient`): forward projection and
//! re-trace on two consecutive frames of the animated `room` (moving box, sphere and light, so
//! samples move, get occluded and change value), and the à-trous reconstruction on hostile values.

use crate::cases::{value, PLANES};
use crate::inputs;
use crate::layouts::{FLOATS, INTS, PAYLOAD, SAMPLE};
use crate::trace_cases::{frame_view, images};
use crate::{BufferSpec, Case, Word};
use rand::Rng;
use rand_pcg::Pcg32;
use vrrt_core::glam::Vec3;
use vrrt_core::kernels::gbuffer::InstanceData;
use vrrt_core::kernels::gradient::{self, GradientSample, EMPTY_KEY};
use vrrt_core::kernels::raygen::AreaLight;
use vrrt_core::payload::{PackedPayload, PackedSample, Payload, Sample};
use vrrt_scene::FrameGeometry;

const F: Word = Word::F32;
const U: Word = Word::U32;
const NODE: &[Word] = &[F, F, F, U, F, F, F, U];
const TRIANGLE: &[Word] = &[F, F, F, F, F, F, F, F, F, U];

/// Two consecutive frames of the room (`prev`, `cur`), a random stratum size and the grid.
struct Pair {
    prev: FrameGeometry,
    cur: FrameGeometry,
    stratum: u32,
    grid: (u32, u32),
    /// Last frame's index and sample pattern, which the re-trace reproduces.
    prev_frame: u32,
    sampling: u32,
}

fn pair(rng: &mut Pcg32, w: u32, h: u32) -> Pair {
    let scene = vrrt_scene::builtin::builtin("room").expect("built-in scene");
    let i = rng.random_range(1..scene.frame_count);
    let stratum = rng.random_range(3..=8);
    Pair {
        prev: scene.frame(i - 1),
        cur: scene.frame(i),
        stratum,
        grid: (w.div_ceil(stratum), h.div_ceil(stratum)),
        prev_frame: rng.random(),
        // Both sample patterns across `cases::SIZES` (odd, odd, even widths).
        sampling: w & 1,
    }
}

fn next_maps(f: &FrameGeometry) -> Vec<InstanceData> {
    f.instances.iter().map(|i| i.inverse()).collect()
}

/// `gradient_project`: real surfaces of two frames, last frame's rays random (a third untraced).
pub fn project_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let p = pair(rng, w, h);
    let samples: Vec<PackedSample> = (0..w * h)
        .map(|_| {
            Sample {
                m1: rng.random(),
                m2: rng.random(),
                rays: [0, 0, 1, 1, 2, 16][rng.random_range(0..6)],
                first: rng.random(),
            }
            .pack()
        })
        .collect();
    let (gw, gh) = p.grid;
    let params = gradient::ProjectParams {
        width: w,
        height: h,
        stratum: p.stratum,
        grid_width: gw,
        grid_height: gh,
        frame_index: rng.random(),
        index_mask: gradient::index_mask(w * h),
        normal_threshold: 0.9,
        plane_threshold: 0.02,
        camera: p.cur.camera,
    };
    let (prev, cur) = (images(&p.prev, w, h), images(&p.cur, w, h));
    Case {
        name: format!(
            "gradient_project {w}x{h} S{} frame {}",
            p.stratum, p.cur.index
        ),
        kernel: &vrrt_core::kernels::GRADIENT_PROJECT,
        buffers: vec![
            prev.depth(),
            prev.normal_roughness(),
            prev.geometry(),
            cur.depth(),
            cur.normal_roughness(),
            cur.geometry(),
            inputs::view(&frame_view(&p.cur)),
            BufferSpec::from_pod(&samples, SAMPLE),
            BufferSpec::from_pod(&next_maps(&p.cur), FLOATS),
            BufferSpec::from_pod(&vec![EMPTY_KEY; (gw * gh) as usize], INTS),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: [
            gw.div_ceil(vrrt_core::kernels::GRADIENT_PROJECT.workgroup_size[0]),
            gh.div_ceil(vrrt_core::kernels::GRADIENT_PROJECT.workgroup_size[1]),
            1,
        ],
    }
}

/// Inputs of both re-trace kernels: keys (a fifth empty), last frame's history and samples.
fn retrace_inputs(rng: &mut Pcg32, p: &Pair, w: u32, h: u32) -> (Vec<BufferSpec>, [u32; 3]) {
    let (gw, gh) = p.grid;
    let mask = gradient::index_mask(w * h);
    let keys: Vec<u32> = (0..gw * gh)
        .map(|_| {
            if rng.random_range(0..5) == 0 {
                EMPTY_KEY
            } else {
                (rng.random::<u32>() & !mask) | rng.random_range(0..w * h)
            }
        })
        .collect();
    let n = (w * h * PLANES) as usize;
    let payload: Vec<PackedPayload> = (0..n)
        .map(|_| {
            Payload {
                rng_index: match rng.random_range(0..4) {
                    0 => 0xffff - rng.random_range(0..4),
                    _ => rng.random(),
                },
                ..Payload::default()
            }
            .pack()
        })
        .collect();
    let samples: Vec<PackedSample> = (0..n)
        .map(|_| Sample {
            m1: 0.5,
            m2: 0.5,
            rays: rng.random_range(0..3),
            first: rng.random_range(0..2) as f32,
        })
        .map(|s| s.pack())
        .collect();
    let prev = images(&p.prev, w, h);
    let buffers = vec![
        BufferSpec::from_pod(&keys, INTS),
        prev.depth(),
        prev.normal_roughness(),
        prev.geometry(),
        inputs::view(&frame_view(&p.cur)),
        BufferSpec::from_pod(&next_maps(&p.cur), FLOATS),
        BufferSpec::from_pod(&payload, PAYLOAD),
        BufferSpec::from_pod(&samples, SAMPLE),
        BufferSpec::from_pod(&p.cur.geometry.nodes, NODE),
        BufferSpec::from_pod(&p.cur.geometry.triangles, TRIANGLE),
    ];
    let groups = [gw.div_ceil(8), gh.div_ceil(8), 1];
    (buffers, groups)
}

fn retrace_params(p: &Pair, w: u32, h: u32, max_distance: f32) -> gradient::RetraceParams {
    gradient::RetraceParams {
        width: w,
        height: h,
        planes: PLANES,
        grid_width: p.grid.0,
        grid_height: p.grid.1,
        index_mask: gradient::index_mask(w * h),
        max_distance,
        rng_wrap: 1 << 16,
        frame: p.prev_frame,
        sampling: p.sampling,
        _pad: [0; 2],
    }
}

/// `gradient_ao`: re-trace last frame's 0th AO ray of each cell's sample in the current room.
pub fn ao_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let p = pair(rng, w, h);
    let (mut buffers, groups) = retrace_inputs(rng, &p, w, h);
    let cells = (p.grid.0 * p.grid.1 * PLANES) as usize;
    buffers.push(BufferSpec::from_pod(
        &vec![GradientSample::default(); cells],
        FLOATS,
    ));
    let params = retrace_params(&p, w, h, rng.random_range(0.2..4.0));
    Case {
        name: format!(
            "gradient_ao {w}x{h}x{PLANES} S{} frame {}",
            p.stratum, p.cur.index
        ),
        kernel: &vrrt_core::kernels::GRADIENT_AO,
        buffers,
        params: bytemuck::bytes_of(&params).to_vec(),
        groups,
    }
}

/// `gradient_shadow`: the same towards the room's (moving) light and a fixed one.
pub fn shadow_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let p = pair(rng, w, h);
    let (mut buffers, groups) = retrace_inputs(rng, &p, w, h);
    let mut lights = p.cur.lights.clone();
    lights.push(AreaLight::new(
        Vec3::new(-5.5, 2.0, -4.5),
        Vec3::Z * 0.5,
        Vec3::Y * 0.5,
    ));
    lights.truncate(PLANES as usize);
    buffers.push(BufferSpec::from_pod(&lights, FLOATS));
    let cells = (p.grid.0 * p.grid.1 * PLANES) as usize;
    buffers.push(BufferSpec::from_pod(
        &vec![GradientSample::default(); cells],
        FLOATS,
    ));
    let params = retrace_params(&p, w, h, 0.0);
    Case {
        name: format!(
            "gradient_shadow {w}x{h}x{PLANES} S{} frame {}",
            p.stratum, p.cur.index
        ),
        kernel: &vrrt_core::kernels::GRADIENT_SHADOW,
        buffers,
        params: bytemuck::bytes_of(&params).to_vec(),
        groups,
    }
}

/// `gradient_atrous`: one iteration on a grid of hostile values (grid = image size here).
pub fn atrous_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let n = (w * h * PLANES) as usize;
    let input: Vec<GradientSample> = (0..n)
        .map(|_| GradientSample {
            delta: value(rng).abs(),
            luminance: value(rng).abs(),
        })
        .collect();
    let params = gradient::GradientAtrousParams {
        grid_width: w,
        grid_height: h,
        step: [1, 2, 4, 8][rng.random_range(0..4)],
        _pad: 0,
    };
    Case {
        name: format!("gradient_atrous {w}x{h}x{PLANES} step {}", params.step),
        kernel: &vrrt_core::kernels::GRADIENT_ATROUS,
        buffers: vec![
            BufferSpec::from_pod(&input, FLOATS),
            BufferSpec::from_pod(&vec![GradientSample::default(); n], FLOATS),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: [w.div_ceil(8), h.div_ceil(8), PLANES],
    }
}
