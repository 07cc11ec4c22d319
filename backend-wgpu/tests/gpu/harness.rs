//! The wgpu-vs-CPU harness of the GPU tests (executors, [`Both`], inputs), apart from the tests.

use vrrt_core::executor::{BufferId, Executor, Pass};
use vrrt_core::kernels::{accumulate, classify};
use vrrt_core::payload::{PackedPayload, PackedSample, Payload, Sample};
use vrrt_core::surface::{Surface, NO_INSTANCE};
use vrrt_cpu::CpuExecutor;
use vrrt_tests::{compare_words, Tolerance, Word};
use vrrt_wgpu::{WgpuError, WgpuExecutor, WgpuOptions};

pub const W: u32 = 37;
pub const H: u32 = 19;
pub const PLANES: u32 = 2;

pub fn options() -> WgpuOptions {
    WgpuOptions {
        validation: true,
        ..WgpuOptions::default()
    }
}

pub fn require_vulkan() -> bool {
    std::env::var("VRRT_REQUIRE_VULKAN").is_ok_and(|v| v == "1")
}

/// A validating executor, or `None` (test skipped) without a Vulkan adapter.
pub fn gpu() -> Option<WgpuExecutor> {
    match WgpuExecutor::new_headless(options()) {
        Ok(e) => {
            let info = e.adapter_info();
            println!(
                "adapter: {} ({:?}, driver {} {}), timestamps: {}, validation layer: {}",
                info.name,
                info.device_type,
                info.driver,
                info.driver_info,
                e.timestamps_enabled(),
                e.validation_layer_active()
            );
            Some(e)
        }
        Err(e @ WgpuError::NoAdapter(_)) => {
            assert!(!require_vulkan(), "VRRT_REQUIRE_VULKAN=1 but: {e}");
            println!("skipped: no Vulkan adapter ({e})");
            None
        }
        Err(e) => panic!("cannot create the wgpu executor: {e}"),
    }
}

pub fn assert_clean(e: &WgpuExecutor) {
    assert_eq!(
        e.validation_errors(),
        0,
        "validation errors: {:#?}",
        e.validation_log().messages()
    );
}

/// SplitMix64: deterministic inputs without extra dependencies.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    pub fn below(&mut self, n: u32) -> u32 {
        (self.next() % n as u64) as u32
    }
    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
    /// Mostly `[0, 1)`, with zeros, huge, tiny, negative and large values.
    pub fn value(&mut self) -> f32 {
        match self.below(100) {
            0..10 => 0.0,
            10..15 => 1e20 + self.unit() * 1e29,
            15..20 => 1e-30 + self.unit() * 1e-21,
            20..25 => -self.unit(),
            25..30 => 1.0 + self.unit() * 999.0,
            _ => self.unit(),
        }
    }
}

/// À-trous iterations per tile, varied so that some tiles pass through.
pub fn tile_levels() -> Vec<u32> {
    let (tw, th) = classify::tile_grid(W, H);
    (0..tw * th).map(|t| t % 3).collect()
}

/// Runs the same steps on the CPU and the GPU executor.
pub struct Both {
    pub cpu: CpuExecutor,
    pub gpu: WgpuExecutor,
}

impl Both {
    pub fn buffer(&mut self, data: &[u8]) -> BufferId {
        let c = self.cpu.create_buffer(data.len() as u64).unwrap();
        let g = self.gpu.create_buffer(data.len() as u64).unwrap();
        assert_eq!(c, g);
        self.cpu.write_buffer(c, data).unwrap();
        self.gpu.write_buffer(g, data).unwrap();
        c
    }
    pub fn write(&mut self, id: BufferId, data: &[u8]) {
        self.cpu.write_buffer(id, data).unwrap();
        self.gpu.write_buffer(id, data).unwrap();
    }
    pub fn dispatch(&mut self, pass: &Pass<'_>) {
        self.cpu.dispatch(pass).unwrap();
        self.gpu.dispatch(pass).unwrap();
    }
    /// Reads `id` from both: `(cpu, gpu)` words.
    pub fn read_both(&mut self, id: BufferId, bytes: usize) -> (Vec<u32>, Vec<u32>) {
        let mut c = vec![0u8; bytes];
        let mut g = vec![0u8; bytes];
        self.cpu.read_buffer(id, &mut c).unwrap();
        self.gpu.read_buffer(id, &mut g).unwrap();
        (
            bytemuck::pod_collect_to_vec(&c),
            bytemuck::pod_collect_to_vec(&g),
        )
    }

    /// Reads `id` from both and asserts the GPU's words are within `tol` of the CPU's, word by
    /// word in `layout` (`vrrt_tests::compare_words`).
    pub fn assert_within(
        &mut self,
        id: BufferId,
        bytes: usize,
        what: &str,
        (layout, tol): (&'static [Word], &Tolerance),
    ) {
        let (c, g) = self.read_both(id, bytes);
        let r = compare_words(layout, tol, &c, &g);
        println!(
            "{what}: {} int and {} float words of {} differ (max {} ULP, {:.2e} relative, {} half-ULPs)",
            r.int_mismatches, r.float_mismatches, r.words, r.max_ulp, r.max_rel, r.max_half_ulp
        );
        assert!(r.within(tol), "{what}: outside {tol:?}: {r:?}");
    }

    /// Reads `id` from both and asserts the bytes are identical.
    pub fn assert_same(&mut self, id: BufferId, bytes: usize, what: &str) {
        let (cw, gw) = self.read_both(id, bytes);
        let diff: Vec<_> = (0..cw.len()).filter(|&i| cw[i] != gw[i]).collect();
        if let Some(&i) = diff.first() {
            panic!(
                "{what}: {} of {} words differ; first at word {i}: cpu {:#010x} ({}), gpu {:#010x} ({})",
                diff.len(),
                cw.len(),
                cw[i],
                f32::from_bits(cw[i]),
                gw[i],
                f32::from_bits(gw[i])
            );
        }
    }
}

pub fn both() -> Option<Both> {
    Some(Both {
        cpu: CpuExecutor::new(),
        gpu: gpu()?,
    })
}

pub fn payloads(rng: &mut Rng, n: u32) -> Vec<PackedPayload> {
    (0..n)
        .map(|_| {
            let m1 = rng.value();
            Payload {
                m1,
                m2: m1 * m1 + rng.value(),
                count: match rng.below(4) {
                    0 => 0.0,
                    1 => -1.0,
                    2 => 70.0,
                    _ => rng.unit() * 64.0,
                },
                rng_index: rng.next() as u32,
            }
            .pack()
        })
        .collect()
}

pub fn samples(rng: &mut Rng, n: u32) -> Vec<PackedSample> {
    (0..n)
        .map(|_| {
            let m1 = rng.value();
            Sample {
                m1,
                m2: m1 * m1,
                rays: rng.below(4),
                first: 0.0,
            }
            .pack()
        })
        .collect()
}

pub fn accumulate_params() -> accumulate::AccumulateParams {
    accumulate::AccumulateParams {
        width: W,
        height: H,
        max_history: 64.0,
        rng_wrap: 1 << 16,
        ..Default::default()
    }
}

pub fn surfaces(rng: &mut Rng) -> Vec<Surface> {
    (0..W * H)
        .map(|i| {
            let (x, y) = ((i % W) as f32, (i / W) as f32);
            let (mut nx, mut ny, mut nz) = (
                rng.unit() * 0.4 - 0.2,
                rng.unit() * 0.4 - 0.2,
                1.0 + rng.unit(),
            );
            let len = (nx * nx + ny * ny + nz * nz).sqrt();
            (nx, ny, nz) = (nx / len, ny / len, nz / len);
            let depth = 1.0 + rng.unit() * 9.0;
            Surface {
                px: x * 0.01 * depth,
                py: y * 0.01 * depth,
                pz: depth,
                depth,
                nx,
                ny,
                nz,
                instance: if rng.below(10) == 0 {
                    NO_INSTANCE
                } else {
                    rng.below(5)
                },
                gx: nx,
                gy: ny,
                gz: nz,
                roughness: rng.unit(),
                prev_x: x,
                prev_y: y,
                ..Default::default()
            }
        })
        .collect()
}
