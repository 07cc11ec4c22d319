//! Input generators, one per kernel. Values mix the ordinary with the hostile: zeros, huge and
//! tiny magnitudes, negatives, sky pixels, and image sizes that are not multiples of the
//! workgroup size.

use crate::inputs::{self, Images};
use crate::layouts::{FLOATS, INTS, PAYLOAD, SAMPLE};
use crate::{BufferSpec, Case, Tolerance};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;
use vrrt_core::executor::KernelDesc;
use vrrt_core::glam::Vec3;
use vrrt_core::kernels::gradient::GradientSample;
use vrrt_core::kernels::{accumulate, buckets, copy, detect, fill, reproject};
use vrrt_core::payload::{self, PackedPayload, PackedSample, Payload, Sample};
use vrrt_core::quantize;
use vrrt_core::surface::{Surface, NO_INSTANCE};

/// A case generator: `(rng, width, height) -> Case`.
pub type Generator = fn(&mut Pcg32, u32, u32) -> Case;

/// Every kernel's generator and the tolerance its results are held to. Adding a kernel adds one
/// line here.
pub static TABLE: &[(&str, Generator, Tolerance)] = &[
    ("accumulate", accumulate_case, DECIDED),
    ("detect", detect_case, Tolerance::DEFAULT),
    (
        "atrous",
        crate::filter_cases::atrous_case,
        Tolerance::DEFAULT,
    ),
    (
        "atrous_tiled",
        crate::filter_cases::atrous_tiled_case,
        Tolerance::DEFAULT,
    ),
    (
        "atrous_pair",
        crate::filter_cases::atrous_pair_case,
        Tolerance::DEFAULT,
    ),
    (
        "atrous_engine",
        crate::ingest_cases::atrous_engine_case,
        Tolerance::DEFAULT,
    ),
    (
        "classify",
        crate::filter_cases::classify_case,
        Tolerance::DEFAULT,
    ),
    ("count_buckets", buckets_case, Tolerance::DEFAULT),
    ("reproject", reproject_case, Tolerance::DEFAULT),
    (
        "reproject_engine",
        crate::ingest_cases::reproject_engine_case,
        DECIDED,
    ),
    ("variance", crate::filter_cases::variance_case, DECIDED),
    (
        "balance",
        crate::balance_cases::balance_case,
        Tolerance::DEFAULT,
    ),
    ("trim_count", crate::balance_cases::trim_count_case, DECIDED),
    (
        "trim_cut",
        crate::balance_cases::trim_cut_case,
        Tolerance::DEFAULT,
    ),
    ("apply", crate::balance_cases::apply_case, DECIDED),
    ("refill", crate::balance_cases::refill_case, DECIDED),
    (
        "detect_refill",
        crate::balance_cases::detect_refill_case,
        DECIDED,
    ),
    (
        "detect_refill_tiled",
        crate::balance_cases::detect_refill_tiled_case,
        DECIDED,
    ),
    (
        "refill_fit",
        crate::balance_cases::refill_fit_case,
        Tolerance::DEFAULT,
    ),
    (
        "refill_cap",
        crate::balance_cases::refill_cap_case,
        Tolerance::DEFAULT,
    ),
    ("fill", fill_case, Tolerance::DEFAULT),
    ("ingest", crate::ingest_cases::ingest_case, DECIDED),
    ("copy", copy_case, Tolerance::DEFAULT),
    ("gbuffer", crate::trace_cases::gbuffer_case, DECIDED),
    (
        "raygen_ao",
        crate::trace_cases::raygen_ao_case,
        Tolerance::DEFAULT,
    ),
    (
        "raygen_shadow",
        crate::trace_cases::raygen_shadow_case,
        Tolerance::DEFAULT,
    ),
    (
        "penumbra_guide",
        crate::trace_cases::penumbra_guide_case,
        Tolerance::DEFAULT,
    ),
    ("ao_guide_march", crate::guide_cases::march_case, DECIDED),
    ("ao_guide_blur", crate::guide_cases::blur_case, DECIDED),
    (
        "ao_demodulate",
        crate::guide_cases::demodulate_case,
        Tolerance::DEFAULT,
    ),
    (
        "ao_remodulate",
        crate::guide_cases::remodulate_case,
        Tolerance::DEFAULT,
    ),
    (
        "ao_remodulate_into",
        crate::guide_cases::remodulate_into_case,
        Tolerance::DEFAULT,
    ),
    (
        "gradient_project",
        crate::gradient_cases::project_case,
        Tolerance::DEFAULT,
    ),
    (
        "gradient_ao",
        crate::gradient_cases::ao_case,
        Tolerance::DEFAULT,
    ),
    (
        "gradient_shadow",
        crate::gradient_cases::shadow_case,
        Tolerance::DEFAULT,
    ),
    (
        "gradient_atrous",
        crate::gradient_cases::atrous_case,
        Tolerance::DEFAULT,
    ),
    ("raygen_reflect", crate::reflect_cases::raygen_case, DECIDED),
    (
        "reflect_tiles",
        crate::reflect_cases::tiles_case,
        Tolerance::DEFAULT,
    ),
    (
        "reflect_motion",
        crate::reflect_cases::motion_case,
        Tolerance::DEFAULT,
    ),
    (
        "reflect_reuse",
        crate::reflect_cases::reuse_case,
        Tolerance::DEFAULT,
    ),
    (
        "reflect_guide",
        crate::reflect_cases::guide_case,
        Tolerance::DEFAULT,
    ),
];

/// Cases whose outputs a float comparison decides (the buffers marked `decided`, each with its
/// reason): 1% of those elements may differ; every other word is held to the default.
pub(crate) const DECIDED: Tolerance = Tolerance::deciding(0.01);

/// Image sizes every case runs at: a single pixel, odd sizes, and one spanning many groups.
pub const SIZES: &[(u32, u32)] = &[(1, 1), (37, 19), (130, 67)];

/// Signal planes used by per-plane kernels.
pub const PLANES: u32 = 2;

/// A raygen case's sample pattern: both patterns across [`SIZES`] (odd, odd, even widths), or
/// a third of the time a reference's replicate.
pub fn sampling(rng: &mut Pcg32, w: u32) -> u32 {
    if rng.random_range(0..3) == 0 {
        vrrt_core::sampling::REPLICATE_PATTERN
    } else {
        w & 1
    }
}

/// Deterministic generator for reproducible cases.
pub fn rng(seed: u64) -> Pcg32 {
    Pcg32::seed_from_u64(seed)
}

/// A float drawn from a hostile mixture: mostly `[0, 1)`, with zeros, huge, tiny and negative
/// values.
pub fn value(rng: &mut Pcg32) -> f32 {
    match rng.random_range(0..100) {
        0..10 => 0.0,
        10..15 => rng.random_range(1e20..1e30),
        15..20 => rng.random_range(1e-30..1e-20),
        20..25 => -rng.random::<f32>(),
        25..30 => rng.random_range(1.0..1000.0),
        _ => rng.random(),
    }
}

fn unit_vector(rng: &mut Pcg32) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if v.length_squared() > 1e-3 && v.length_squared() <= 1.0 {
            return v.normalize();
        }
    }
}

/// A G-buffer texel: a plausible surface near its neighbours, or sky.
pub fn surface(rng: &mut Pcg32, x: u32, y: u32) -> Surface {
    if rng.random_range(0..10) == 0 {
        return Surface {
            instance: NO_INSTANCE,
            ..Surface::default()
        };
    }
    let n = if rng.random_bool(0.7) {
        Vec3::Y
    } else {
        unit_vector(rng)
    };
    let depth = rng.random_range(0.5..50.0);
    let p = Vec3::new(x as f32 * 0.01 * depth, y as f32 * 0.01 * depth, depth);
    Surface {
        px: p.x,
        py: p.y,
        pz: p.z,
        depth,
        nx: n.x,
        ny: n.y,
        nz: n.z,
        instance: rng.random_range(0..4),
        gx: n.x,
        gy: n.y,
        gz: n.z,
        roughness: 1.0,
        prev_x: x as f32,
        prev_y: y as f32,
        prev_px: p.x,
        prev_py: p.y,
        prev_pz: p.z,
    }
}

pub(crate) fn groups(kernel: &KernelDesc, w: u32, h: u32, planes: u32) -> [u32; 3] {
    let [x, y, z] = kernel.workgroup_size;
    [w.div_ceil(x), h.div_ceil(y), planes.div_ceil(z)]
}

/// History lengths at the extremes: 0, fractional, at and past the clamp.
pub(crate) const EXTREME_LENGTHS: &[f32] = &[0.0, 0.5, 1.0, 63.5, 64.0, 70.0];
/// History lengths around the young-history rules (`spatial_until` 4, short histories).
pub(crate) const YOUNG_LENGTHS: &[f32] = &[0.0, 0.5, 1.0, 2.0, 3.9, 4.0, 7.9, 8.0, 10.0, 64.0];

/// Random history of the given `lengths`.
pub(crate) fn histories(rng: &mut Pcg32, n: usize, lengths: &[f32]) -> Vec<PackedPayload> {
    (0..n)
        .map(|_| {
            Payload {
                m1: value(rng),
                m2: value(rng),
                count: lengths[rng.random_range(0..lengths.len())],
                rng_index: rng.random(),
            }
            .pack()
        })
        .collect()
}

/// This frame's samples, some non-finite (the clean-up policy drops and counts them) and some
/// untraced.
fn hostile_samples(rng: &mut Pcg32, n: usize) -> Vec<PackedSample> {
    let hostile = |rng: &mut Pcg32| match rng.random_range(0..40) {
        0 => f32::NAN,
        1 => f32::INFINITY,
        2 => f32::NEG_INFINITY,
        _ => value(rng),
    };
    (0..n)
        .map(|_| Sample {
            m1: hostile(rng),
            m2: hostile(rng),
            rays: rng.random_range(0..17),
            first: 0.0,
        })
        .map(|s| s.pack())
        .collect()
}

fn accumulate_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let n = (w * h * PLANES) as usize;
    let history = histories(rng, n, EXTREME_LENGTHS);
    let samples = hostile_samples(rng, n);
    let changes: Vec<f32> = (0..n)
        .map(|_| [0.0, 0.0, 0.25, 0.5, 0.75, 1.0][rng.random_range(0..6)])
        .collect();
    let storage = [quantize::STORAGE_F16, quantize::STORAGE_UNORM8][rng.random_range(0..2)];
    let params = accumulate::AccumulateParams {
        width: w,
        height: h,
        max_history: 64.0,
        rng_wrap: 256,
        clamp_radius: if rng.random_bool(0.5) {
            rng.random_range(1..4)
        } else {
            0
        },
        clamp_gamma: 1.0,
        firefly_max: if rng.random_bool(0.5) { 10.0 } else { 0.0 },
        storage,
        use_changes: rng.random_range(0..2),
        change_threshold: 0.5,
        shadow_threshold: 0.25,
        shadow_planes: rng.random_range(1..1 << PLANES),
        drop_sigma: [0.75, 1.5, 3.0][rng.random_range(0..3)],
        min_variance: [0.0, 1e-4][rng.random_range(0..2)],
        surface_clamp_planes: rng.random_range(0..1 << PLANES),
        surface_clamp_radius: rng.random_range(0..4),
        normal_threshold: 0.9,
        depth_tolerance: 0.05,
        confirm_planes: rng.random_range(0..1 << PLANES),
        confirm_sigma: [1.25, 3.0][rng.random_range(0..2)],
    };
    let g = Images::pack(&surfaces(rng, w, h), w, &inputs::test_view());
    Case {
        name: format!(
            "accumulate {w}x{h}x{PLANES} clamp {} surface {} {:b} storage {storage} changes {} shadows {:b} drop {} confirm {:b} {}",
            params.clamp_radius,
            params.surface_clamp_radius,
            params.surface_clamp_planes,
            params.use_changes,
            params.shadow_planes,
            params.drop_sigma,
            params.confirm_planes,
            params.confirm_sigma
        ),
        kernel: &vrrt_core::kernels::ACCUMULATE,
        buffers: vec![
            // Whether history is dropped compares `λ` and the rays' z-score with thresholds:
            // decided.
            BufferSpec::from_pod(&history, PAYLOAD).decided(),
            BufferSpec::from_pod(&samples, SAMPLE),
            BufferSpec::from_pod(&changes, FLOATS),
            BufferSpec::from_pod(&[0u32; payload::COUNTERS_LEN as usize], INTS),
            BufferSpec::from_pod(&g.depth, FLOATS),
            BufferSpec::from_pod(&g.normal_roughness, INTS),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&vrrt_core::kernels::ACCUMULATE, w, h, PLANES),
    }
}

/// Detector parameters over their ranges (window radii 0–3, both significances).
pub(crate) fn detect_params(rng: &mut Pcg32, w: u32, h: u32) -> detect::DetectParams {
    detect::DetectParams {
        width: w,
        height: h,
        radius: rng.random_range(0..=4),
        shadow_radius: rng.random_range(0..=4),
        shadow_planes: rng.random_range(0..1 << PLANES),
        z_full: [1.0, 3.0, 5.0][rng.random_range(0..3)],
        min_variance: [0.0, 1e-4][rng.random_range(0..2)],
        ao_planes: rng.random_range(0..1 << PLANES),
        ao_z_full: [1.0, 2.0][rng.random_range(0..2)],
        ao_gain: [1.0, 3.0, 8.0][rng.random_range(0..3)],
        ao_cap: [0.3, 0.5, 1.0][rng.random_range(0..3)],
    }
}

fn detect_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let n = (w * h * PLANES) as usize;
    let history = histories(rng, n, EXTREME_LENGTHS);
    let samples = hostile_samples(rng, n);
    let params = detect_params(rng, w, h);
    Case {
        name: format!(
            "detect {w}x{h}x{PLANES} radius {} shadows {:b} radius {} ao {:b} σ {}",
            params.radius,
            params.shadow_planes,
            params.shadow_radius,
            params.ao_planes,
            params.ao_z_full
        ),
        kernel: &vrrt_core::kernels::DETECT,
        buffers: vec![
            BufferSpec::from_pod(&history, PAYLOAD),
            BufferSpec::from_pod(&samples, SAMPLE),
            BufferSpec::from_pod(&vec![0.5f32; n], FLOATS),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&vrrt_core::kernels::DETECT, w, h, PLANES),
    }
}

fn buckets_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    // Two plane groups' requests.
    let requests: Vec<u32> = (0..w * h * 2)
        .map(|_| match rng.random_range(0..20) {
            0 => buckets::NO_RAYS,
            1 => buckets::BUCKET_COUNT + rng.random_range(0..100),
            _ => rng.random_range(0..buckets::BUCKET_COUNT),
        })
        .collect();
    // Counts accumulate into whatever the buffer holds.
    let counts: Vec<u32> = (0..2 * buckets::COUNTS_LEN)
        .map(|_| rng.random_range(0..3))
        .collect();
    let params = buckets::BucketParams {
        width: w,
        height: h,
    };
    Case {
        name: format!("count_buckets {w}x{h}x2"),
        kernel: &vrrt_core::kernels::COUNT_BUCKETS,
        buffers: vec![
            BufferSpec::from_pod(&requests, INTS),
            BufferSpec::from_pod(&counts, INTS),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&vrrt_core::kernels::COUNT_BUCKETS, w, h, 2),
    }
}

/// A random G-buffer whose positions lie on the test camera's rays ([`inputs::test_view`]), so
/// positions reconstructed from depth match the surfaces'.
pub(crate) fn surfaces(rng: &mut Pcg32, w: u32, h: u32) -> Vec<Surface> {
    let camera = inputs::test_view().camera;
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let s = surface(rng, x, y);
            let p = camera.unproject(x as f32, y as f32, s.depth, w, h);
            Surface {
                px: p.x,
                py: p.y,
                pz: p.z,
                prev_px: p.x,
                prev_py: p.y,
                prev_pz: p.z,
                ..s
            }
        })
        .collect()
}

pub(crate) fn reproject_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let mut current = surfaces(rng, w, h);
    for s in &mut current {
        // Motion of up to 1.5 pixels, sometimes far off screen.
        s.prev_x += rng.random_range(-1.5..1.5);
        s.prev_y += rng.random_range(-1.5..1.5);
        if rng.random_range(0..20) == 0 {
            s.prev_x = -1.0e9;
        }
    }
    let mut previous = current.clone();
    for s in &mut previous {
        if rng.random_range(0..5) == 0 {
            *s = surface(rng, 0, 0);
        }
    }
    let n = (w * h * PLANES) as usize;
    let params = reproject::ReprojectParams {
        width: w,
        height: h,
        planes: PLANES,
        reset: rng.random_range(0..8) / 7,
        frame_index: rng.random(),
        supersample_target: [0.0, 16.0, 64.0][rng.random_range(0..3)],
        use_mask: rng.random_range(0..2),
        gradient_stratum: [0, 3, 8][rng.random_range(0..3)],
        gradient_threshold: rng.random_range(0.2..0.9),
        gradient_scale: [1.0, 8.0][rng.random_range(0..2)],
        still_history: [0.0, 2.0][rng.random_range(0..2)],
        still_variance: [0.0, 1e-3, 1.0][rng.random_range(0..3)],
        max_history: [3.0, 64.0, 128.0][rng.random_range(0..3)],
        importance_group: [reproject::NO_GROUP, 0, 1][rng.random_range(0..3)],
        parallax_plane: [reproject::NO_PLANE, 0, 1][rng.random_range(0..3)],
        // One group for both planes, or one each.
        plane_groups: [0, 0x10][rng.random_range(0..2)],
        ..Default::default()
    };
    let (tw, th) = vrrt_core::kernels::reflect::tile_grid(w, h);
    let importance: Vec<f32> = (0..tw * th).map(|_| rng.random_range(0.25..4.0)).collect();
    // Parallax positions: the surface motion moved by up to 3 pixels, some off screen.
    let parallax: Vec<[f32; 2]> = current
        .iter()
        .map(|s| {
            if rng.random_range(0..20) == 0 {
                [f32::NAN, -1.0e9]
            } else {
                [
                    s.prev_x + rng.random_range(-3.0..3.0),
                    s.prev_y + rng.random_range(-3.0..3.0),
                ]
            }
        })
        .collect();
    let mask: Vec<u32> = (0..w * h).map(|_| rng.random_range(0..4)).collect();
    let (gw, gh) = vrrt_core::buffers::grid_size(w, h, params.gradient_stratum);
    let params = reproject::ReprojectParams {
        gradient_width: gw,
        gradient_height: gh,
        ..params
    };
    let gradient: Vec<GradientSample> = (0..gw * gh * PLANES)
        .map(|_| GradientSample {
            delta: rng.random_range(0.0..1.0),
            luminance: [0.0, 0.5, 1.0][rng.random_range(0..3)],
        })
        .collect();
    let view = inputs::test_view();
    let (cur, prev) = (
        Images::pack(&current, w, &view),
        Images::pack(&previous, w, &view),
    );
    Case {
        name: format!(
            "reproject {w}x{h}x{PLANES} reset {} groups {:x}",
            params.reset, params.plane_groups
        ),
        kernel: &vrrt_core::kernels::REPROJECT,
        buffers: vec![
            cur.depth(),
            cur.normal_roughness(),
            cur.motion(),
            prev.depth(),
            prev.normal_roughness(),
            inputs::view(&view),
            BufferSpec::from_pod(&histories(rng, n, YOUNG_LENGTHS), PAYLOAD),
            BufferSpec::from_pod(&mask, INTS),
            BufferSpec::from_pod(&gradient, FLOATS),
            BufferSpec::from_pod(&importance, FLOATS),
            BufferSpec::from_pod(&parallax, FLOATS),
            BufferSpec::from_pod(&vec![PackedPayload::default(); n], PAYLOAD),
            BufferSpec::from_pod(&vec![0u32; n], INTS),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&vrrt_core::kernels::REPROJECT, w, h, 1),
    }
}

fn fill_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let len = w * h + 5;
    let data: Vec<u32> = (0..len + 7).map(|_| rng.random()).collect();
    let params = fill::FillParams {
        len,
        value: rng.random(),
    };
    Case {
        name: format!("fill {len}"),
        kernel: &vrrt_core::kernels::FILL,
        buffers: vec![BufferSpec::from_pod(&data, INTS)],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: [len.div_ceil(fill::GROUP), 1, 1],
    }
}

fn copy_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    // A row that is not a multiple of the workgroup and a length that ends mid-row.
    let row = w + 3;
    let len = row * h - w / 2;
    let src: Vec<u32> = (0..len + 9).map(|_| rng.random()).collect();
    let dst: Vec<u32> = (0..len + 9).map(|_| rng.random()).collect();
    let params = copy::CopyParams { row, len };
    Case {
        name: format!("copy {len} in rows of {row}"),
        kernel: &vrrt_core::kernels::COPY,
        buffers: vec![
            BufferSpec::from_pod(&src, INTS),
            BufferSpec::from_pod(&dst, INTS),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&vrrt_core::kernels::COPY, row, h, 1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kernel_has_a_case() {
        for kernel in vrrt_core::kernels::ALL {
            assert!(
                TABLE.iter().any(|(name, _, _)| *name == kernel.entry),
                "kernel `{}` has no equivalence case",
                kernel.entry
            );
        }
    }

    #[test]
    fn copy_copies_len_words_and_nothing_else() {
        let case = copy_case(&mut rng(3), 37, 19);
        let out = crate::run_case(&mut vrrt_cpu::CpuExecutor::new(), &case).unwrap();
        let (src, dst) = (&case.buffers[0].data, &case.buffers[1].data);
        let len = src.len() - 9;
        assert_eq!(&out[1][..len], &src[..len]);
        assert_eq!(&out[1][len..], &dst[len..]);
    }

    #[test]
    fn buckets_count_every_requesting_pixel_once() {
        let (w, h) = (130, 67);
        let case = buckets_case(&mut rng(7), w, h);
        let before = &case.buffers[1].data;
        let out = crate::run_case(&mut vrrt_cpu::CpuExecutor::new(), &case).unwrap();
        let pixels = (w * h) as usize;
        for g in 0..2 {
            let requests = &case.buffers[0].data[g * pixels..(g + 1) * pixels];
            let base = g * buckets::COUNTS_LEN as usize;
            let added = |i: usize| out[1][base + i] - before[base + i];
            for b in 0..buckets::BUCKET_COUNT as usize {
                let want = requests.iter().filter(|&&r| r as usize == b).count() as u32;
                assert_eq!(added(b), want, "group {g} bucket {b}");
                let per_ring: u32 = (1..=buckets::MAX_RINGS as usize)
                    .map(|ring| added(ring * buckets::BUCKET_COUNT as usize + b))
                    .sum();
                assert_eq!(per_ring, want, "rings of group {g} bucket {b}");
            }
        }
    }
}
