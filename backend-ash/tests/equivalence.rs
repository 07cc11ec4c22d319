//! Runs kernels on the ash backend and on the CPU backend with the same inputs and compares the
//! results within the tolerances of the cross-backend table (`vrrt_tests::Tolerance`): the GPU
//! evaluates transcendentals natively and may fuse multiply-adds.
//!
//! Without a Vulkan adapter every test prints "skipped: no Vulkan adapter" and passes, unless
//! `VRRT_REQUIRE_VULKAN=1`. Validation is on unless `VRRT_VALIDATION=0`; each test asserts that
//! it reported no error.

mod common;
#[path = "equivalence/harness.rs"]
mod harness;

use common::executor;
use harness::{assert_within, check_validation, read, run_both, upload, Launch, Rng};
use vrrt_ash::ash::vk;
use vrrt_ash::{AshError, ExecError};
use vrrt_core::camera::{Camera, View};
use vrrt_core::executor::{BufferId, Executor, Groups, Pass};
use vrrt_core::glam::Vec3;
use vrrt_core::kernels::accumulate::AccumulateParams;
use vrrt_core::kernels::atrous::AtrousParams;
use vrrt_core::kernels::buckets::{BucketParams, BUCKET_COUNT, COUNTS_LEN, NO_RAYS};
use vrrt_core::kernels::classify;
use vrrt_core::kernels::reflect::NO_GUIDE;
use vrrt_core::payload::{self, PackedPayload, PackedSample, Payload, Sample};
use vrrt_core::payload::{Filtered, PackedFiltered};
use vrrt_core::surface::{Surface, NO_INSTANCE};
use vrrt_cpu::CpuExecutor;
use vrrt_tests::{layouts, Tolerance};

const W: u32 = 37;
const H: u32 = 19;
const PLANES: u32 = 2;
/// Five chained à-trous passes each round their output to binary16: a value one half-ULP apart
/// after one pass moves its neighbours' weights in the next, so the chain is allowed a few.
const CHAIN: Tolerance = Tolerance::DEFAULT.halves(4);

#[test]
fn accumulate_matches_cpu() {
    let Some(mut ex) = executor() else { return };
    let n = (W * H * PLANES) as usize;
    let mut rng = Rng(0x1234_5678);
    let history: Vec<PackedPayload> = (0..n)
        .map(|_| {
            let m1 = rng.unit() * 4.0;
            Payload {
                m1,
                m2: m1 * m1 + rng.unit(),
                count: rng.unit() * 80.0 - 2.0,
                rng_index: rng.next(),
            }
            .pack()
        })
        .collect();
    let samples: Vec<PackedSample> = (0..n)
        .map(|_| {
            let m1 = rng.unit() * 8.0;
            Sample {
                m1,
                m2: m1 * m1 * (1.0 + rng.unit()),
                rays: rng.next() % 5,
                first: 0.0,
            }
        })
        .map(|s| s.pack())
        .collect();
    let params = AccumulateParams {
        width: W,
        height: H,
        max_history: 64.0,
        rng_wrap: 1 << 16,
        ..Default::default()
    };
    let changes = vec![0u8; n * 4];
    let counters = [0u8; payload::COUNTERS_LEN as usize * 4];
    // Depth and normals: read only by a variance clamp, which these parameters leave off.
    let geometry = vec![0u8; (W * H) as usize * 4];
    let inputs: [&[u8]; 6] = [
        bytemuck::cast_slice(&history),
        bytemuck::cast_slice(&samples),
        &changes,
        &counters,
        &geometry,
        &geometry,
    ];
    let p = bytemuck::bytes_of(&params);
    let (gpu, cpu) = run_both::<PackedPayload>(
        &mut ex,
        &Launch {
            kernel: &vrrt_core::kernels::ACCUMULATE,
            inputs: &inputs,
            params: p,
            grid: [W, H, PLANES],
            out: 0,
            out_len: n,
        },
    );
    assert_within(
        "accumulate",
        &gpu,
        &cpu,
        layouts::PAYLOAD,
        &Tolerance::DEFAULT,
    );
    assert!(gpu.iter().any(|p| p.unpack().count > 0.0));
    ex.finish().unwrap();
    let t = ex.timings();
    assert_eq!(t.len(), usize::from(ex.adapter_info().timestamps));
    if let Some(t) = t.first() {
        println!("accumulate: {} ms", t.ms);
        assert_eq!(t.entry, "accumulate");
        assert!(t.ms > 0.0, "timestamp delta is zero");
    }
    check_validation(&ex);
}

fn surfaces(rng: &mut Rng) -> Vec<Surface> {
    (0..W * H)
        .map(|i| {
            let (x, y) = ((i % W) as f32, (i / W) as f32);
            let mut s = Surface {
                px: x * 0.1,
                py: y * 0.1,
                pz: 5.0 + rng.unit() * 0.05,
                depth: 5.0 + rng.unit(),
                nx: rng.unit() * 0.2,
                ny: rng.unit() * 0.2,
                nz: 1.0,
                instance: rng.next() % 3,
                roughness: 1.0,
                ..Surface::default()
            };
            let len = (s.nx * s.nx + s.ny * s.ny + s.nz * s.nz).sqrt();
            (s.nx, s.ny, s.nz) = (s.nx / len, s.ny / len, s.nz / len);
            if rng.next().is_multiple_of(11) {
                s.instance = NO_INSTANCE;
            }
            s
        })
        .collect()
}

/// The view the à-trous inputs are seen through.
fn view() -> View {
    let camera = Camera::look_at(
        Vec3::new(0.0, 0.0, -2.0),
        Vec3::new(0.0, 0.0, 5.0),
        Vec3::Y,
        0.8,
    );
    View {
        camera,
        prev_camera: camera,
    }
}

/// The depth and normal + roughness images of `surf`, as an engine writes them.
fn packed(surf: &[Surface]) -> (Vec<f32>, Vec<u32>) {
    surf.iter()
        .enumerate()
        .map(|(i, s)| {
            let t = s.pack(i as u32 % W, i as u32 / W, &view().prev_camera);
            (t.depth, t.normal_roughness)
        })
        .unzip()
}

#[test]
fn atrous_matches_cpu() {
    let Some(mut ex) = executor() else { return };
    let n = (W * H * PLANES) as usize;
    let mut rng = Rng(0x9e37_79b9);
    let input: Vec<PackedFiltered> = (0..n)
        .map(|_| {
            Filtered {
                value: rng.unit() * 3.0,
                variance: rng.unit() * rng.unit(),
            }
            .pack()
        })
        .collect();
    let (depth, normal_roughness) = packed(&surfaces(&mut rng));
    let v = view();
    let tiles = tile_levels();
    let out = vec![0u8; n * 8];
    for (i, step) in [1u32, 2, 4].into_iter().enumerate() {
        let params = AtrousParams {
            width: W,
            height: H,
            step,
            iteration: i as u32,
            ..AtrousParams::default()
        };
        // No guide or penumbra plane: each binding holds one unread element, as a denoiser
        // without reflections or shadows binds it.
        let inputs: [&[u8]; 8] = [
            bytemuck::cast_slice(&input),
            bytemuck::cast_slice(&depth),
            bytemuck::cast_slice(&normal_roughness),
            bytemuck::bytes_of(&v),
            bytemuck::cast_slice(&tiles),
            bytemuck::bytes_of(&NO_GUIDE),
            bytemuck::bytes_of(&NO_GUIDE),
            &out,
        ];
        let p = bytemuck::bytes_of(&params);
        let (gpu, cpu) = run_both::<PackedFiltered>(
            &mut ex,
            &Launch {
                kernel: &vrrt_core::kernels::ATROUS,
                inputs: &inputs,
                params: p,
                grid: [W, H, PLANES],
                out: 7,
                out_len: n,
            },
        );
        assert_within(
            &format!("atrous step {step}"),
            &gpu,
            &cpu,
            layouts::FILTERED,
            &Tolerance::DEFAULT,
        );
        assert_ne!(gpu, input, "the filter did nothing");
    }
    check_validation(&ex);
}

fn requests(rng: &mut Rng, w: u32, h: u32) -> Vec<u32> {
    (0..w * h)
        .map(|_| match rng.next() % 10 {
            0 => NO_RAYS,
            1 => BUCKET_COUNT + rng.next() % 5, // out of range: in no bucket
            _ => rng.next() % BUCKET_COUNT,
        })
        .collect()
}

#[test]
fn buckets_match_cpu() {
    let Some(mut ex) = executor() else { return };
    let mut rng = Rng(0xdead_beef);
    for (w, h) in [(W, H), (131, 77)] {
        let req = requests(&mut rng, w, h);
        let counts = vec![0u8; COUNTS_LEN as usize * 4];
        let params = BucketParams {
            width: w,
            height: h,
        };
        let inputs: [&[u8]; 2] = [bytemuck::cast_slice(&req), &counts];
        let p = bytemuck::bytes_of(&params);
        let (gpu, cpu) = run_both::<u32>(
            &mut ex,
            &Launch {
                kernel: &vrrt_core::kernels::COUNT_BUCKETS,
                inputs: &inputs,
                params: p,
                grid: [w, h, 1],
                out: 1,
                out_len: COUNTS_LEN as usize,
            },
        );
        assert_within(
            "count_buckets",
            &gpu,
            &cpu,
            layouts::INTS,
            &Tolerance::DEFAULT,
        );
        let expected = req.iter().filter(|&&r| r < BUCKET_COUNT).count() as u32;
        assert_eq!(gpu[..BUCKET_COUNT as usize].iter().sum::<u32>(), expected);
    }
    check_validation(&ex);
}

/// À-trous iterations per tile, varied so that some tiles pass through.
fn tile_levels() -> Vec<u32> {
    let (tw, th) = classify::tile_grid(W, H);
    (0..tw * th).map(|t| 1 + t % 5).collect()
}

/// Five dependent à-trous passes (ping-pong) recorded without waits, the fourth launched
/// indirectly, with a `write_buffer` in the middle of the stream. Returns the final buffer.
fn chain<E: Executor>(ex: &mut E, input: &[PackedFiltered], surf: &[Surface]) -> BufferId {
    let (depth, normal_roughness) = packed(surf);
    let v = view();
    let zeros = vec![0u8; std::mem::size_of_val(input)];
    let groups = [W.div_ceil(8), H.div_ceil(8), PLANES];
    let indirect: Vec<u32> = [7u32].into_iter().chain(groups).collect(); // counts at byte 4
    let b = upload(
        ex,
        &[
            bytemuck::cast_slice(input),
            bytemuck::cast_slice(&depth),
            &zeros,
            &zeros,
            bytemuck::cast_slice(&indirect),
            bytemuck::cast_slice(&tile_levels()),
            bytemuck::cast_slice(&normal_roughness),
            bytemuck::bytes_of(&v),
            bytemuck::bytes_of(&NO_GUIDE),
            bytemuck::bytes_of(&NO_GUIDE),
        ],
    );
    let (s, ind) = (b[1], b[4]);
    let mut prev = b[0];
    for (i, step) in [1u32, 2, 4, 8, 16].into_iter().enumerate() {
        let params = AtrousParams {
            width: W,
            height: H,
            step,
            iteration: i as u32,
            ..AtrousParams::default()
        };
        let out = b[2 + i % 2];
        // No guide or penumbra plane: one unread element each.
        let bufs = [prev, s, b[6], b[7], b[5], b[8], b[9], out];
        let mut pass = Pass::over_grid(
            &vrrt_core::kernels::ATROUS,
            &bufs,
            bytemuck::bytes_of(&params),
            W,
            H,
            PLANES,
        );
        if i == 3 {
            pass.groups = Groups::Indirect {
                buffer: ind,
                offset: 4,
            };
        }
        ex.dispatch(&pass).unwrap();
        if i == 2 {
            // Rows 3..6 of the depth replace rows 0..3 mid-stream: later passes must see it
            // (and earlier ones must not).
            ex.write_buffer(
                s,
                bytemuck::cast_slice(&depth[W as usize * 3..W as usize * 6]),
            )
            .unwrap();
        }
        prev = out;
    }
    prev
}

#[test]
fn chained_passes_indirect_and_timestamps() {
    let Some(mut ex) = executor() else { return };
    let mut cpu = CpuExecutor::new();
    let n = (W * H * PLANES) as usize;
    let mut rng = Rng(0x0bad_f00d);
    let input: Vec<PackedFiltered> = (0..n)
        .map(|_| {
            Filtered {
                value: rng.unit(),
                variance: rng.unit() * 0.1,
            }
            .pack()
        })
        .collect();
    let surf = surfaces(&mut rng);
    let g = chain(&mut ex, &input, &surf);
    let c = chain(&mut cpu, &input, &surf);
    assert!(ex.timings().is_empty(), "nothing completed yet");
    let (gpu, want): (Vec<PackedFiltered>, Vec<PackedFiltered>) =
        (read(&mut ex, g, n), read(&mut cpu, c, n));
    assert_within(
        "5 chained atrous passes",
        &gpu,
        &want,
        layouts::FILTERED,
        &CHAIN,
    );
    if ex.adapter_info().timestamps {
        let t = ex.timings();
        assert_eq!(t.len(), 5);
        for t in t {
            println!("{}: {:.4} ms", t.entry, t.ms);
            assert_eq!(t.entry, "atrous");
            assert!(t.ms > 0.0, "timestamp delta is zero");
        }
    }
    ex.clear_timings();
    assert!(ex.timings().is_empty());
    check_validation(&ex);
}

#[test]
fn errors_are_reported_not_panicked() {
    let Some(mut ex) = executor() else { return };
    assert!(matches!(
        ex.create_buffer(6),
        Err(AshError::Exec(ExecError::UnalignedSize(6)))
    ));
    let a = ex.create_buffer(16).unwrap();
    assert!(matches!(
        ex.write_buffer(a, &[0; 20]),
        Err(AshError::Exec(ExecError::OutOfRange { .. }))
    ));
    assert!(matches!(
        ex.write_buffer(BufferId(99), &[0; 4]),
        Err(AshError::Exec(ExecError::UnknownBuffer(_)))
    ));
    let params = BucketParams {
        width: 2,
        height: 2,
    };
    let aliased = [a, a];
    let pass = Pass::over_grid(
        &vrrt_core::kernels::COUNT_BUCKETS,
        &aliased,
        bytemuck::bytes_of(&params),
        2,
        2,
        1,
    );
    assert!(matches!(
        ex.dispatch(&pass),
        Err(AshError::Exec(ExecError::AliasedBinding(_)))
    ));
    let one = [a];
    let pass = Pass::over_grid(
        &vrrt_core::kernels::COUNT_BUCKETS,
        &one,
        bytemuck::bytes_of(&params),
        2,
        2,
        1,
    );
    assert!(matches!(
        ex.dispatch(&pass),
        Err(AshError::Exec(ExecError::Plan(_)))
    ));
    // Indirect counts in the buffer the pass counts into (`counts`, atomic), or past the end.
    let counts = ex.create_buffer(COUNTS_LEN as u64 * 4).unwrap();
    let bufs = [a, counts];
    let mut pass = Pass::over_grid(
        &vrrt_core::kernels::COUNT_BUCKETS,
        &bufs,
        bytemuck::bytes_of(&params),
        2,
        2,
        1,
    );
    pass.groups = Groups::Indirect {
        buffer: counts,
        offset: 0,
    };
    assert!(matches!(
        ex.dispatch(&pass),
        Err(AshError::Exec(ExecError::IndirectWritten(b))) if b == counts
    ));
    pass.groups = Groups::Indirect {
        buffer: a,
        offset: 8,
    };
    assert!(matches!(
        ex.dispatch(&pass),
        Err(AshError::Exec(ExecError::OutOfRange {
            bytes: 20,
            size: 16,
            ..
        }))
    ));
    // Zero-sized buffers work and read back nothing.
    let z = ex.create_buffer(0).unwrap();
    ex.read_buffer(z, &mut []).unwrap();
    let mut four = [1u8; 16];
    ex.read_buffer(a, &mut four).unwrap();
    assert_eq!(four, [0; 16], "buffers start zeroed");
    ex.destroy_buffer(a).unwrap();
    assert!(matches!(
        ex.raw_buffer(a),
        Err(AshError::Exec(ExecError::UnknownBuffer(_)))
    ));
    check_validation(&ex);
}

/// The messenger really counts: a deliberately invalid call (buffer without usage) is reported.
#[test]
fn validation_messenger_counts_errors() {
    let Some(ex) = executor() else { return };
    if !ex.validation_enabled() {
        println!("validation off: nothing to check");
        return;
    }
    assert_eq!(ex.validation_errors(), 0);
    let info = vk::BufferCreateInfo::default()
        .size(64)
        .usage(vk::BufferUsageFlags::empty());
    // SAFETY: invalid on purpose (VUID-VkBufferCreateInfo-usage-requiredbitmask), harmless to
    // the driver; the buffer is destroyed right away.
    unsafe {
        if let Ok(b) = ex.device().create_buffer(&info, None) {
            ex.device().destroy_buffer(b, None);
        }
    }
    println!(
        "errors counted after one invalid call: {}",
        ex.validation_errors()
    );
    assert!(ex.validation_errors() > 0);
}
