//! Equivalence cases of the spatial filter (`variance`, `classify`, `atrous`), split off to keep
//! `cases` short.

use crate::cases::{groups, histories, surfaces, value, PLANES, YOUNG_LENGTHS};
use crate::inputs::{self, Images};
use crate::layouts::{FILTERED, FLOATS, INTS, PAYLOAD};
use crate::{BufferSpec, Case};
use rand::Rng;
use rand_pcg::Pcg32;
use vrrt_core::kernels::{atrous, classify, reflect, reproject, variance};
use vrrt_core::payload::{Filtered, PackedFiltered};

pub(crate) fn variance_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let n = (w * h * PLANES) as usize;
    // Some planes take the AO normal exponent: both weights are exercised.
    let params = variance::VarianceParams {
        width: w,
        height: h,
        ao_planes: rng.random_range(0..1 << PLANES),
        ao_normal_power: 8.0,
        ao_spatial_until: 8.0,
        guide_plane: guide_plane(rng),
        guide_scale: 0.44,
        // Some planes widen the window of their fewest-ray pixels: both windows are exercised.
        wide_until: 3.0,
        wide_planes: rng.random_range(0..1 << PLANES),
        ..Default::default()
    };
    let view = inputs::test_view();
    let g = Images::pack(&surfaces(rng, w, h), w, &view);
    let guide = guide(rng, w, h);
    let (tw, th) = classify::tile_grid(w, h);
    let tiles: Vec<u32> = (0..tw * th)
        .map(|_| match rng.random_range(0..8) {
            0 => classify::tile_key(f32::NAN),
            _ => 0,
        })
        .collect();
    Case {
        name: format!(
            "variance {w}x{h}x{PLANES} ao {:b} wide {:b} guide {}",
            params.ao_planes, params.wide_planes, params.guide_plane as i32
        ),
        kernel: &vrrt_core::kernels::VARIANCE,
        buffers: vec![
            BufferSpec::from_pod(&histories(rng, n, YOUNG_LENGTHS), PAYLOAD),
            g.depth(),
            g.normal_roughness(),
            inputs::view(&view),
            BufferSpec::from_pod(&guide, FLOATS),
            // A weight sum at the edge of the normal range (hostile inputs) chooses between the
            // spatial and the temporal estimate, and a GPU that flushes subnormals to zero
            // chooses the other: decided, and the tile maxima with them.
            BufferSpec::from_pod(&vec![PackedFiltered::default(); n], FILTERED).decided(),
            // Tile words, zeroed as the host does, with a few left high to stay the maximum.
            BufferSpec::from_pod(&tiles, INTS).decided(),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&vrrt_core::kernels::VARIANCE, w, h, PLANES),
    }
}

pub(crate) fn classify_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let (tw, th) = classify::tile_grid(w, h);
    // Tile words as the variance pass leaves them: empty tiles, worst variances, and NaN or
    // infinite ones (a buggy writer): classify's guard.
    let tiles: Vec<u32> = (0..tw * th)
        .map(|_| match rng.random_range(0..8) {
            0 => 0,
            1 => classify::tile_key([f32::NAN, f32::INFINITY][rng.random_range(0..2)]),
            _ => classify::tile_key(value(rng).abs() * 1e-3),
        })
        .collect();
    let params = classify::ClassifyParams {
        width: w,
        height: h,
        iterations: rng.random_range(0..6),
        skip_sigma: [0.0, 0.004, 0.02, 0.3][rng.random_range(0..4)],
    };
    Case {
        name: format!(
            "classify {w}x{h} sigma {} cap {}",
            params.skip_sigma, params.iterations
        ),
        kernel: &vrrt_core::kernels::CLASSIFY,
        buffers: vec![
            BufferSpec::from_pod(&tiles, INTS),
            BufferSpec::from_pod(&[0u32; classify::HISTOGRAM_LEN as usize], INTS),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&vrrt_core::kernels::CLASSIFY, tw, th, 1),
    }
}

pub(crate) fn atrous_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let n = (w * h * PLANES) as usize;
    let input: Vec<PackedFiltered> = (0..n)
        .map(|_| {
            Filtered {
                value: value(rng),
                variance: value(rng).abs(),
            }
            .pack()
        })
        .collect();
    let view = inputs::test_view();
    let g = Images::pack(&surfaces(rng, w, h), w, &view);
    let iteration = rng.random_range(0..5);
    let params = atrous::AtrousParams {
        width: w,
        height: h,
        step: 1 << iteration,
        iteration,
        cap_variance: rng.random_range(0..2),
        ao_planes: rng.random_range(0..1 << PLANES),
        ao_normal_power: 8.0,
        symmetric_planes: rng.random_range(0..1 << PLANES),
        guide_plane: guide_plane(rng),
        guide_scale: 0.44,
        guided_sigma_luminance: 3.0,
        penumbra_plane: guide_plane(rng),
        penumbra_scale: 2.0,
        penumbra_sigma_luminance: 2.0,
        ..atrous::AtrousParams::default()
    };
    let guide = guide(rng, w, h);
    let penumbra = penumbra(rng, w, h);
    let (tw, th) = classify::tile_grid(w, h);
    // Tiles needing 0..=5 iterations: some pass through, some filter.
    let tiles: Vec<u32> = (0..tw * th).map(|_| rng.random_range(0..6)).collect();
    Case {
        name: format!(
            "atrous {w}x{h}x{PLANES} step {} cap {} ao {:b} pairs {:b} guide {} penumbra {}",
            params.step,
            params.cap_variance,
            params.ao_planes,
            params.symmetric_planes,
            params.guide_plane as i32,
            params.penumbra_plane as i32
        ),
        kernel: &vrrt_core::kernels::ATROUS,
        buffers: vec![
            BufferSpec::from_pod(&input, FILTERED),
            g.depth(),
            g.normal_roughness(),
            inputs::view(&view),
            BufferSpec::from_pod(&tiles, INTS),
            BufferSpec::from_pod(&guide, FLOATS),
            BufferSpec::from_pod(&penumbra, FLOATS),
            BufferSpec::from_pod(&vec![PackedFiltered::default(); n], FILTERED),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&vrrt_core::kernels::ATROUS, w, h, PLANES),
    }
}

/// `atrous`'s case through the tiled kernel (`atrous_tiled`): the same buffers, dispatched over
/// its lattice grid (`atrous::tile::grid`).
pub(crate) fn atrous_tiled_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let base = atrous_case(rng, w, h);
    let p: atrous::AtrousParams = bytemuck::pod_read_unaligned(&base.params);
    let (gw, gh) = atrous::tile::grid(w, h, p.step);
    Case {
        name: base.name.replace("atrous", "atrous_tiled"),
        kernel: &vrrt_core::kernels::ATROUS_TILED,
        groups: groups(&vrrt_core::kernels::ATROUS_TILED, gw, gh, PLANES),
        ..base
    }
}

/// `atrous`'s case through the fused first two iterations (`atrous_pair`): the same buffers,
/// the first iteration at step 1 (its number still drawn: the tiles' counts decide both).
pub(crate) fn atrous_pair_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let base = atrous_case(rng, w, h);
    let mut p: atrous::AtrousParams = bytemuck::pod_read_unaligned(&base.params);
    p.step = 1;
    p.iteration = p.iteration.min(3);
    Case {
        name: base
            .name
            .replace("atrous", "atrous_pair")
            .replace(&format!("step {}", base_step(&base)), "steps 1, 2"),
        kernel: &vrrt_core::kernels::ATROUS_PAIR,
        params: bytemuck::bytes_of(&p).to_vec(),
        groups: groups(&vrrt_core::kernels::ATROUS_PAIR, w, h, PLANES),
        ..base
    }
}

/// The step an `atrous` case was drawn with.
fn base_step(case: &Case) -> u32 {
    bytemuck::pod_read_unaligned::<atrous::AtrousParams>(&case.params).step
}

/// A guided plane, or none (`NO_PLANE`): both paths of the filters are exercised.
fn guide_plane(rng: &mut Pcg32) -> u32 {
    [0, 1, reproject::NO_PLANE][rng.random_range(0..3)]
}

/// A hit-distance guide per pixel: `log2` distances of hits and misses, and pixels without one.
fn guide(rng: &mut Pcg32, w: u32, h: u32) -> Vec<f32> {
    (0..w * h)
        .map(|_| match rng.random_range(0..6) {
            0 => reflect::NO_GUIDE,
            1 => reflect::MISS_DISTANCE.log2(),
            _ => rng.random_range(-13.0..13.0),
        })
        .collect()
}

/// A penumbra guide per pixel: widths in pixels below and above the floor of 1, and pixels
/// without a blocker nearby.
fn penumbra(rng: &mut Pcg32, w: u32, h: u32) -> Vec<f32> {
    (0..w * h)
        .map(|_| match rng.random_range(0..4) {
            0 => reflect::NO_GUIDE,
            _ => rng.random_range(0.0..40.0),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cases::{rng, SIZES};

    /// The tiled kernel filters as the plain one does, at every step, on every size (edges,
    /// sizes that are no multiple of a workgroup or a lattice): on the CPU, word for word.
    #[test]
    fn tiled_atrous_is_atrous() {
        let mut steps = [false; 5];
        for seed in 0..12u64 {
            for &(w, h) in SIZES {
                let plain = atrous_case(&mut rng(90 + seed), w, h);
                let tiled = atrous_tiled_case(&mut rng(90 + seed), w, h);
                let p: atrous::AtrousParams = bytemuck::pod_read_unaligned(&plain.params);
                steps[p.iteration as usize] = true;
                let mut cpu = vrrt_cpu::CpuExecutor::new();
                let a = crate::run_case(&mut cpu, &plain).unwrap();
                let b = crate::run_case(&mut cpu, &tiled).unwrap();
                let r = crate::compare(&plain, &crate::Tolerance::DEFAULT, &a, &b);
                assert!(r.is_exact(), "{}: {r:?}", tiled.name);
            }
        }
        assert_eq!(steps, [true; 5], "every step exercised");
    }

    /// The fused pair gives what two `atrous` passes (steps 1 and 2, the second reading the
    /// first's output) give: on the CPU, word for word, on every size.
    #[test]
    fn atrous_pair_is_two_atrous_iterations() {
        use vrrt_core::kernels::ATROUS;
        for seed in 0..12u64 {
            for &(w, h) in SIZES {
                let pair = atrous_pair_case(&mut rng(190 + seed), w, h);
                let p: atrous::AtrousParams = bytemuck::pod_read_unaligned(&pair.params);
                let mut first = Case {
                    kernel: &ATROUS,
                    groups: groups(&ATROUS, w, h, PLANES),
                    ..pair.clone()
                };
                let mut cpu = vrrt_cpu::CpuExecutor::new();
                let once = crate::run_case(&mut cpu, &first).unwrap();
                let next = atrous::AtrousParams {
                    step: 2,
                    iteration: p.iteration + 1,
                    ..p
                };
                first.buffers[0].data = once[7].clone();
                first.params = bytemuck::bytes_of(&next).to_vec();
                let twice = crate::run_case(&mut cpu, &first).unwrap();
                let fused = crate::run_case(&mut cpu, &pair).unwrap();
                let tol = crate::Tolerance::DEFAULT;
                let r = crate::compare_words(FILTERED, &tol, &twice[7], &fused[7]);
                assert!(r.is_exact(), "{}: {r:?}", pair.name);
            }
        }
    }
}
