//! Equivalence cases of the AO guide's passes (`kernels::ao_guide`): the march and its blur over
//! a random frame of the built-in room (edges, thin poles, sky), the division of the history and
//! the multiplication back on random planes.

use crate::cases::{self, groups, PLANES};
use crate::layouts::{FILTERED, HALVES, PAYLOAD};
use crate::trace_cases::{images, raygen_inputs, room_frame};
use crate::{BufferSpec, Case};
use rand::Rng;
use rand_pcg::Pcg32;
use vrrt_core::kernels::{self, ao_guide};
use vrrt_core::packing;
use vrrt_core::payload::{Filtered, PackedFiltered, PackedPayload, Payload};

/// `ao_guide_march`: the unblocked fraction of 1–16 directions, marched in 1–8 steps to a
/// radius from a third of the room's pole spacing to twice it, kept from a random last frame's
/// (the same G-buffer; fractions holding none, some or the most directions) or not (no refresh,
/// a reset). Whether a step is blocked compares depths, so a fraction may differ by one
/// direction where a step grazes a surface; whether a pixel marches all directions compares
/// what it holds.
pub fn march_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let frame = room_frame(rng);
    let g = images(&frame, w, h);
    let [depth, normal_roughness, _, view] = raygen_inputs(&g, &frame);
    let directions = rng.random_range(1..=16);
    let params = ao_guide::MarchParams {
        width: w,
        height: h,
        directions,
        steps: rng.random_range(1..=8),
        radius: rng.random_range(0.3..2.0),
        refresh: [0, 1, directions][rng.random_range(0..3)],
        reset: rng.random_range(0..4) / 3,
        first: rng.random_range(0..directions),
        turn: rng.random_range(0.0..1.0),
        normal_threshold: 0.9,
        plane_threshold: 0.02,
    };
    let most = ao_guide::HISTORY * directions as f32;
    let prev_raw: Vec<u32> = (0..w * h)
        .map(|_| {
            let held = [0.0, 0.5 * directions as f32, directions as f32, most];
            let held = held[rng.random_range(0..4)];
            packing::pack_f16x2(rng.random_range(0.0..=1.0), held)
        })
        .collect();
    Case {
        name: format!(
            "ao_guide_march {w}x{h} directions {} steps {} radius {:.2} refresh {} reset {}",
            params.directions, params.steps, params.radius, params.refresh, params.reset
        ),
        kernel: &kernels::AO_GUIDE_MARCH,
        buffers: vec![
            depth,
            normal_roughness,
            g.motion(),
            g.depth(),
            g.normal_roughness(),
            view,
            BufferSpec::from_pod(&prev_raw, HALVES),
            BufferSpec::from_pod(&vec![0u32; (w * h) as usize], HALVES).decided(),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&kernels::AO_GUIDE_MARCH, w, h, 1),
    }
}

/// `ao_guide_march` over the built-in room's first frame held still (no motion, last frame's
/// G-buffer the same) and last frame's fractions `prev_raw` (for the kept guide's test in
/// `tests/ao_guide.rs`).
pub fn still_march_case(w: u32, h: u32, params: ao_guide::MarchParams, prev_raw: &[u32]) -> Case {
    let scene = vrrt_scene::builtin::builtin("room").expect("built-in scene");
    let frame = scene.frame(0);
    let g = images(&frame, w, h);
    let [depth, normal_roughness, _, view] = raygen_inputs(&g, &frame);
    Case {
        name: format!("ao_guide_march {w}x{h}, a still frame"),
        kernel: &kernels::AO_GUIDE_MARCH,
        buffers: vec![
            depth,
            normal_roughness,
            BufferSpec::from_pod(&vec![0u32; 2 * (w * h) as usize], HALVES),
            g.depth(),
            g.normal_roughness(),
            view,
            BufferSpec::from_pod(prev_raw, HALVES),
            BufferSpec::from_pod(&vec![0u32; (w * h) as usize], HALVES),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&kernels::AO_GUIDE_MARCH, w, h, 1),
    }
}

/// `ao_guide_blur`: random fractions (some 0, so the floor shows) averaged over the room's
/// surfaces; which neighbours lie on the pixel's surface compares normals and depths.
pub fn blur_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let frame = room_frame(rng);
    let [depth, normal_roughness, ..] = raygen_inputs(&images(&frame, w, h), &frame);
    let raw: Vec<u32> = (0..w * h)
        .map(|_| {
            let fraction = if rng.random_range(0..4) == 0 {
                0.0
            } else {
                rng.random_range(0.0..=1.0)
            };
            packing::pack_f16x2(fraction, 16.0)
        })
        .collect();
    let params = guide_params(rng, w, h);
    Case {
        name: format!("ao_guide_blur {w}x{h}"),
        kernel: &kernels::AO_GUIDE_BLUR,
        buffers: vec![
            BufferSpec::from_pod(&raw, HALVES),
            depth,
            normal_roughness,
            BufferSpec::from_pod(&vec![0u32; words(w, h)], HALVES).decided(),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&kernels::AO_GUIDE_BLUR, ao_guide::guide_row_words(w), h, 1),
    }
}

/// `ao_demodulate`: random histories (empty ones among them) divided by random guides on a
/// random set of planes.
pub fn demodulate_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let history = histories(rng, w, h);
    let params = guide_params(rng, w, h);
    Case {
        name: format!("ao_demodulate {w}x{h} planes {:b}", params.ao_planes),
        kernel: &kernels::AO_DEMODULATE,
        buffers: vec![
            BufferSpec::from_pod(&history, PAYLOAD),
            BufferSpec::from_pod(&guide(rng, w, h), HALVES),
            BufferSpec::from_pod(&vec![PackedPayload::default(); history.len()], PAYLOAD),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&kernels::AO_DEMODULATE, w, h, PLANES),
    }
}

/// Random histories of every plane, empty and young ones among them.
fn histories(rng: &mut Pcg32, w: u32, h: u32) -> Vec<PackedPayload> {
    (0..w * h * PLANES)
        .map(|_| {
            let m1 = rng.random_range(0.0..=1.0);
            Payload {
                m1,
                m2: m1 * rng.random_range(m1..=1.0),
                count: [0.0, 1.0, 3.5, 24.0][rng.random_range(0..4)],
                rng_index: rng.random_range(0..1 << 16),
            }
            .pack()
        })
        .collect()
}

/// `ao_remodulate`: random filtered values (up to the guide's inverse, as divided ones reach)
/// multiplied back in place.
pub fn remodulate_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let params = guide_params(rng, w, h);
    Case {
        name: format!("ao_remodulate {w}x{h} planes {:b}", params.ao_planes),
        kernel: &kernels::AO_REMODULATE,
        buffers: vec![
            BufferSpec::from_pod(&guide(rng, w, h), HALVES),
            BufferSpec::from_pod(&filtered(rng, w, h), FILTERED),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&kernels::AO_REMODULATE, w, h, PLANES),
    }
}

/// `ao_remodulate_into`: as `ao_remodulate`, into an engine texture (plane `z` at rows
/// `z · height ..`, the value in red).
pub fn remodulate_into_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let params = guide_params(rng, w, h);
    Case {
        name: format!("ao_remodulate_into {w}x{h} planes {:b}", params.ao_planes),
        kernel: &kernels::AO_REMODULATE_INTO,
        buffers: vec![
            BufferSpec::from_pod(&filtered(rng, w, h), FILTERED),
            BufferSpec::from_pod(&guide(rng, w, h), HALVES),
            BufferSpec::output_texture(w, h * cases::PLANES),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&kernels::AO_REMODULATE_INTO, w, h, PLANES),
    }
}

/// The size and a random set of guided planes.
fn guide_params(rng: &mut Pcg32, w: u32, h: u32) -> ao_guide::GuideParams {
    ao_guide::GuideParams {
        width: w,
        height: h,
        ao_planes: rng.random_range(0..1 << PLANES),
    }
}

/// Words of a `w × h` guide (two pixels a word).
fn words(w: u32, h: u32) -> usize {
    (ao_guide::guide_row_words(w) * h) as usize
}

/// A guide per pixel, packed as `blur` packs it: the floor, 1 (no surface, or nothing blocked)
/// and values between.
fn guide(rng: &mut Pcg32, w: u32, h: u32) -> Vec<u32> {
    let mut value = || match rng.random_range(0..4) {
        0 => ao_guide::FLOOR,
        1 => 1.0,
        _ => rng.random_range(ao_guide::FLOOR..1.0),
    };
    (0..words(w, h))
        .map(|_| packing::pack_f16x2(value(), value()))
        .collect()
}

/// Filtered values and variances of every plane, as a divided AO plane holds them.
fn filtered(rng: &mut Pcg32, w: u32, h: u32) -> Vec<PackedFiltered> {
    (0..w * h * PLANES)
        .map(|_| {
            Filtered {
                value: rng.random_range(0.0..=1.0 / ao_guide::FLOOR),
                variance: rng.random_range(0.0..=1.0),
            }
            .pack()
        })
        .collect()
}
