//! Equivalence cases of the load balancer (`balance`, `trim`, `apply`), split off to keep `cases`
//! short.

use crate::cases::{groups, histories, value, EXTREME_LENGTHS, PLANES};
use crate::layouts::{FLOATS, INTS, PAYLOAD, SAMPLE};
use crate::{BufferSpec, Case, Word};
use rand::Rng;
use rand_pcg::Pcg32;
use vrrt_core::kernels::{apply, balance, buckets, refill, trim, work_list};
use vrrt_core::payload::{PackedSample, Sample};

/// Random requests of two plane groups (group-stacked) and their bucket histograms, as
/// `count_buckets` would produce.
fn histogram(rng: &mut Pcg32, w: u32, h: u32) -> (Vec<u32>, Vec<u32>) {
    let pixels = w * h;
    let mut requests = Vec::new();
    let mut counts = vec![0u32; 2 * buckets::COUNTS_LEN as usize];
    for g in 0..2 {
        let base = (g * buckets::COUNTS_LEN) as usize;
        for i in 0..pixels {
            let b = match rng.random_range(0..10) {
                0 => buckets::NO_RAYS,
                1..4 => buckets::MIN_RATE_DIVISOR + rng.random_range(0..buckets::MAX_RATE),
                4..6 => buckets::MIN_RATE_DIVISOR,
                _ => rng.random_range(0..buckets::BUCKET_COUNT),
            };
            if b < buckets::BUCKET_COUNT {
                let ring = buckets::ring_id(i % w, i / w, w, h);
                counts[base + b as usize] += 1;
                counts[base + ((1 + ring) * buckets::BUCKET_COUNT + b) as usize] += 1;
            }
            requests.push(b);
        }
    }
    (requests, counts)
}

const BALANCE: &[Word] = &[
    Word::U32,
    Word::U32,
    Word::U32,
    Word::F32,
    Word::F32,
    Word::F32,
    Word::F32,
    Word::F32,
    Word::U32,
    Word::U32,
    Word::F32,
    Word::U32,
    Word::U32,
    Word::U32,
    Word::U32,
    Word::U32,
];

fn balance_params(rng: &mut Pcg32, w: u32, h: u32) -> balance::BalanceParams {
    let groups = rng.random_range(1..=2);
    balance::BalanceParams {
        rays_per_pixel: [0.25f32, 0.5, 1.0, 2.0, 4.0][rng.random_range(0..5)],
        ring_count: buckets::ring_count(w, h),
        raise: rng.random_range(0..2),
        policy: [
            balance::POLICY_KEEP,
            balance::POLICY_BALANCE,
            balance::POLICY_BALANCE,
            balance::POLICY_FIXED,
        ][rng.random_range(0..4)],
        groups,
        plane_groups: if groups == 2 { 0x10 } else { 0 },
        planes: PLANES,
        signal_floor: [0.0f32, 0.25, 0.9][rng.random_range(0..3)],
        refill_rays: rng.random_range(1..=16),
        refill_share: [0.1f32, 0.5, 1.0][rng.random_range(0..3)],
        // Last frame's lists were a reset frame's, but at 1×1.
        after_reset: (w > 1 && rng.random_range(0..2) == 0) as u32,
        shift: rng.random_range(0..4),
    }
}

/// Last frame's decisions, left in the balancer's output: it overwrites them without reading
/// them.
fn last_decisions(rng: &mut Pcg32) -> [balance::Balance; 2] {
    [0; 2].map(|_| balance::Balance {
        budget: rng.random_range(0.0..20000.0),
        mode: rng.random_range(0..4),
        ..Default::default()
    })
}

pub(crate) fn balance_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let (_, counts) = histogram(rng, w, h);
    let params = balance_params(rng, w, h);
    Case {
        name: format!(
            "balance {w}x{h} rpp {} groups {} shift {:#b} after reset {}",
            params.rays_per_pixel, params.groups, params.shift, params.after_reset
        ),
        kernel: &vrrt_core::kernels::BALANCE,
        buffers: vec![
            BufferSpec::from_pod(&counts, INTS),
            BufferSpec::from_pod(&last_decisions(rng), BALANCE),
            BufferSpec::from_pod(&[7u32; 8], INTS),
            BufferSpec::from_pod(&[rng.random_range(0..300), 7, 7, 7, 40, 7, 7, 7], INTS),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: [1, 1, 1],
    }
}

/// Random requests, the balancer's parameters and its decisions for them, each with a random
/// trim cut (none in a quarter of them).
fn decided(
    rng: &mut Pcg32,
    w: u32,
    h: u32,
) -> (Vec<u32>, balance::BalanceParams, Vec<balance::Balance>) {
    let (requests, counts) = histogram(rng, w, h);
    let p = balance_params(rng, w, h);
    let rates = balance::group_rates(&counts, &p);
    let decisions = (0..p.groups)
        .map(|g| balance::Balance {
            cut: rng.random_range(0..trim::BINS * 4).min(trim::BINS * 2) / 2,
            ..balance::solve(&counts, g, rates[g as usize], 0.0, &p)
        })
        .collect();
    (requests, p, decisions)
}

pub(crate) fn trim_count_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let (requests, p, decisions) = decided(rng, w, h);
    // Counts accumulate into whatever the buffer holds.
    let hist: Vec<u32> = (0..p.groups * trim::HIST_LEN)
        .map(|_| rng.random_range(0..3))
        .collect();
    let params = trim::TrimParams {
        width: w,
        height: h,
        frame_index: rng.random(),
    };
    Case {
        name: format!(
            "trim_count {w}x{h} groups {} mode {}",
            p.groups, decisions[0].mode
        ),
        kernel: &vrrt_core::kernels::TRIM_COUNT,
        buffers: vec![
            BufferSpec::from_pod(&requests, INTS),
            BufferSpec::from_pod(&decisions, BALANCE),
            BufferSpec::from_pod(&vrrt_core::blue_noise::generate_mask(), FLOATS),
            // A pixel's rays and its last ray's bin compare a blue-noise threshold with a float
            // rate: decided.
            BufferSpec::from_pod(&hist, INTS).decided(),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&vrrt_core::kernels::TRIM_COUNT, w, h, p.groups),
    }
}

pub(crate) fn trim_cut_case(rng: &mut Pcg32, _w: u32, _h: u32) -> Case {
    let groups_n = rng.random_range(1..=balance::MAX_GROUPS);
    let hist: Vec<u32> = (0..groups_n * trim::HIST_LEN)
        .map(|i| {
            if i % trim::HIST_LEN == trim::BINS {
                rng.random_range(0..40_000)
            } else {
                rng.random_range(0..40)
            }
        })
        .collect();
    let decisions: Vec<balance::Balance> = (0..groups_n)
        .map(|_| balance::Balance {
            budget: [0.0, 0.5, 123.7, 20_000.0, 1e9][rng.random_range(0..5)],
            paid: [0.0, 17.5][rng.random_range(0..2)],
            cut: 7,
            traced: 7,
            ..balance::Balance::default()
        })
        .collect();
    let params = trim::CutParams {
        groups: groups_n,
        policy: [
            balance::POLICY_BALANCE,
            balance::POLICY_FIXED,
            balance::POLICY_KEEP,
        ][rng.random_range(0..3)],
        reset_share: [0.0, 0.0, 0.5][rng.random_range(0..3)],
    };
    Case {
        name: format!("trim_cut groups {groups_n} policy {}", params.policy),
        kernel: &vrrt_core::kernels::TRIM_CUT,
        buffers: vec![
            BufferSpec::from_pod(&hist, INTS),
            BufferSpec::from_pod(&decisions, BALANCE),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: [1, 1, 1],
    }
}

pub(crate) fn apply_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let (requests, p, decisions) = decided(rng, w, h);
    let n = (w * h) as usize;
    let samples: Vec<PackedSample> = (0..n * PLANES as usize)
        .map(|_| Sample {
            m1: value(rng),
            m2: value(rng),
            rays: rng.random_range(0..5),
            first: 0.0,
        })
        .map(|s| s.pack())
        .collect();
    let params = apply::ApplyParams {
        width: w,
        height: h,
        planes: PLANES,
        frame_index: rng.random(),
        plane_groups: p.plane_groups,
    };
    Case {
        name: format!(
            "apply {w}x{h}x{PLANES} groups {} mode {}",
            p.groups, decisions[0].mode
        ),
        kernel: &vrrt_core::kernels::APPLY,
        buffers: vec![
            BufferSpec::from_pod(&requests, INTS),
            BufferSpec::from_pod(&decisions, BALANCE),
            BufferSpec::from_pod(&vrrt_core::blue_noise::generate_mask(), FLOATS),
            // Which pixels trace, and how many rays, compares a blue-noise threshold with a
            // float rate: decided.
            BufferSpec::from_pod(&vec![0u32; 2 * n], INTS)
                .unordered()
                .decided(),
            BufferSpec::from_pod(&[0u32, 0, 1, 1, 0, 0, 1, 1], INTS).decided(),
            BufferSpec::from_pod(&samples, SAMPLE).decided(),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&vrrt_core::kernels::APPLY, w, h, p.groups),
    }
}

/// Samples of the refill cases: half the pixels untraced, the others 1 or 3 rays.
fn refill_samples(rng: &mut Pcg32, n: usize) -> Vec<PackedSample> {
    (0..n)
        .map(|_| Sample {
            m1: value(rng),
            m2: value(rng),
            rays: [0, 0, 1, 3][rng.random_range(0..4)],
            first: 0.0,
        })
        .map(|s| s.pack())
        .collect()
}

/// List parameters over their ranges, with one or two plane groups.
fn refill_params(rng: &mut Pcg32, w: u32, h: u32, lists: u32) -> refill::RefillParams {
    refill::RefillParams {
        width: w,
        height: h,
        planes: PLANES,
        plane_groups: if lists == 2 { 0x10 } else { 0 },
        threshold: 0.5,
        shadow_threshold: 0.25,
        shadow_planes: rng.random_range(0..1 << PLANES),
        rays: rng.random_range(1..=16),
        verify_sigma: [0.0, 0.75, 1.5][rng.random_range(0..3)],
        verify_history: [1.0, 4.0][rng.random_range(0..2)],
        min_variance: [0.0, 1e-4][rng.random_range(0..2)],
        frame_index: rng.random(),
        fresh_planes: rng.random_range(0..1 << PLANES),
        reset_planes: rng.random_range(0..1 << PLANES),
        reset_contrast: [1.0, 2.0, 4.0][rng.random_range(0..3)],
    }
}

/// A refill histogram (two groups) that the lists add to: some counts there already.
fn refill_hist(rng: &mut Pcg32) -> Vec<u32> {
    (0..2 * refill::FIT_BINS)
        .map(|_| rng.random_range(0..3))
        .collect()
}

/// `refill`: a reset frame's lists of the shadows' mixed and the reflections' contrasted windows.
pub(crate) fn refill_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let (requests, _) = histogram(rng, w, h);
    let lists = rng.random_range(1..=2);
    let samples = refill_samples(rng, (w * h * PLANES) as usize);
    // Reset lists come from the planes a reset tests: at least one.
    let params = refill::RefillParams {
        reset_planes: rng.random_range(1..1 << PLANES),
        ..refill_params(rng, w, h, lists)
    };
    Case {
        name: format!(
            "refill {w}x{h}x{PLANES} groups {lists} tested {:b} shadows {:b} contrast {} rays {}",
            params.reset_planes, params.shadow_planes, params.reset_contrast, params.rays
        ),
        kernel: &vrrt_core::kernels::REFILL,
        buffers: vec![
            BufferSpec::from_pod(&requests, INTS),
            BufferSpec::from_pod(&samples, SAMPLE),
            // The lists follow float comparisons of the rays' means: decided.
            BufferSpec::from_pod(&vec![0u32; (w * h * PLANES) as usize], INTS)
                .unordered()
                .decided(),
            BufferSpec::from_pod(&[0u32, 0, 1, 1, 0, 0, 1, 1], INTS).decided(),
            // Counts of the listed pixels: decided as the lists are.
            BufferSpec::from_pod(&refill_hist(rng), INTS).decided(),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&vrrt_core::kernels::REFILL, w, h, lists),
    }
}

/// `detect_refill`: the detector's `λ` and the lists it makes, with the verification.
pub(crate) fn detect_refill_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let (requests, _) = histogram(rng, w, h);
    let lists = rng.random_range(1..=2);
    let n = (w * h * PLANES) as usize;
    let params = refill::DetectRefillParams {
        detect: crate::cases::detect_params(rng, w, h),
        refill: refill_params(rng, w, h, lists),
    };
    Case {
        name: format!(
            "detect_refill {w}x{h}x{PLANES} groups {lists} radius {} shadows {:b} verify {}",
            params.detect.radius, params.refill.shadow_planes, params.refill.verify_sigma
        ),
        kernel: &vrrt_core::kernels::DETECT_REFILL,
        buffers: vec![
            BufferSpec::from_pod(&requests, INTS),
            BufferSpec::from_pod(&refill_samples(rng, n), SAMPLE),
            BufferSpec::from_pod(&histories(rng, n, EXTREME_LENGTHS), PAYLOAD),
            BufferSpec::from_pod(&vec![f32::NAN; n], FLOATS),
            // The lists follow `λ > threshold` and the verification's z-score: decided.
            BufferSpec::from_pod(&vec![0u32; n], INTS)
                .unordered()
                .decided(),
            BufferSpec::from_pod(&[0u32, 0, 1, 1, 0, 0, 1, 1], INTS).decided(),
            BufferSpec::from_pod(&refill_hist(rng), INTS).decided(),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: groups(&vrrt_core::kernels::DETECT_REFILL, w, h, lists),
    }
}

/// `detect_refill_tiled`: `detect_refill`'s case through the kernel whose window sums come from
/// a workgroup tile.
pub(crate) fn detect_refill_tiled_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let base = detect_refill_case(rng, w, h);
    Case {
        name: base.name.replace("detect_refill", "detect_refill_tiled"),
        kernel: &vrrt_core::kernels::DETECT_REFILL_TILED,
        ..base
    }
}

/// Decisions as [`refill::fit`] leaves them: rays below and from a cut bin, 0 for skipped.
fn fitted_decisions(rng: &mut Pcg32) -> [balance::Balance; 2] {
    [0; 2].map(|_| balance::Balance {
        refill_lo: rng.random_range(0..=2),
        refill_hi: rng.random_range(1..=16),
        refill_cut: rng.random_range(0..=refill::FIT_BINS),
        ..Default::default()
    })
}

/// `refill_cap`: refill lists (two groups, some entries already at 16 rays), their rays from
/// fitted decisions, one list capped.
pub(crate) fn refill_cap_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let pixels = w * h;
    let counts = [0, 1].map(|_| rng.random_range(0..=pixels));
    let work: Vec<u32> = (0..2 * pixels)
        .map(|i| work_list::work_entry(rng.random_range(0..pixels), 1 + (i % 16)))
        .collect();
    let args = [
        counts[0],
        counts[0].div_ceil(64),
        1,
        1,
        counts[1],
        counts[1].div_ceil(64),
        1,
        1,
    ];
    let params = refill::CapParams {
        pixels,
        list: rng.random_range(0..2),
        frame_index: rng.random(),
    };
    let list = params.list as usize;
    Case {
        name: format!(
            "refill_cap {w}x{h} list {} of {}",
            params.list, counts[list]
        ),
        kernel: &vrrt_core::kernels::REFILL_CAP,
        buffers: vec![
            BufferSpec::from_pod(&fitted_decisions(rng), BALANCE),
            BufferSpec::from_pod(&args, INTS),
            BufferSpec::from_pod(&work, INTS),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: [counts[list].div_ceil(64), 1, 1],
    }
}

/// `refill_fit`: two groups' lists of random counts and histograms, fitted into random rooms.
pub(crate) fn refill_fit_case(rng: &mut Pcg32, _w: u32, _h: u32) -> Case {
    let mut hist = vec![0u32; 2 * refill::FIT_BINS as usize];
    let mut args = [0u32, 0, 1, 1, 0, 0, 1, 1];
    for g in 0..2 {
        let count = [0, 1, 50, 3000][rng.random_range(0..4)];
        for _ in 0..count {
            hist[g * refill::FIT_BINS as usize + rng.random_range(0..refill::FIT_BINS) as usize] +=
                1;
        }
        args[4 * g] = count;
    }
    let decisions = [0, 1].map(|_| {
        let traced = rng.random_range(0..20_000);
        balance::Balance {
            traced,
            allowed: traced + [0, 3, 200, 5000, 100_000][rng.random_range(0..5)],
            ..Default::default()
        }
    });
    let params = refill::FitParams {
        groups: 2,
        rays: rng.random_range(1..=16),
        least: rng.random_range(0..=3),
        unbounded: (rng.random_range(0..4) == 0) as u32,
    };
    Case {
        name: format!(
            "refill_fit counts {} {} rays {} least {}",
            args[0], args[4], params.rays, params.least
        ),
        kernel: &vrrt_core::kernels::REFILL_FIT,
        buffers: vec![
            BufferSpec::from_pod(&args, INTS),
            BufferSpec::from_pod(&hist, INTS),
            BufferSpec::from_pod(&decisions, BALANCE),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: [1, 1, 1],
    }
}

#[cfg(test)]
mod tile_tests {
    use super::*;
    use crate::cases::{rng, DECIDED, SIZES};

    /// The tiled detector lists and writes what the plain one does, word for word, at every
    /// radius.
    #[test]
    fn the_tiled_detector_is_the_detector() {
        let mut radii = [false; 5];
        for seed in 0..16u64 {
            for &(w, h) in SIZES {
                let plain = detect_refill_case(&mut rng(300 + seed), w, h);
                let tiled = detect_refill_tiled_case(&mut rng(300 + seed), w, h);
                let p: refill::DetectRefillParams = bytemuck::pod_read_unaligned(&plain.params);
                radii[p.detect.radius as usize] = true;
                radii[p.detect.shadow_radius as usize] = true;
                let mut cpu = vrrt_cpu::CpuExecutor::new();
                let a = crate::run_case(&mut cpu, &plain).unwrap();
                let b = crate::run_case(&mut cpu, &tiled).unwrap();
                let r = crate::compare(&plain, &DECIDED, &a, &b);
                // The lists are filled through atomics: compared as multisets (`unordered`).
                assert!(
                    r.failures == 0 && r.decided_mismatches == 0 && r.float_mismatches == 0,
                    "{}: {r:?}",
                    tiled.name
                );
            }
        }
        assert_eq!(radii, [true; 5], "every radius exercised");
    }
}
