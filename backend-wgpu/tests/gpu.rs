//! The wgpu backend against the CPU backend within the cross-backend tolerances
//! (`vrrt_tests::Tolerance`), plus its own behaviour: no-adapter
//! error, write ordering, indirect dispatch, timestamps, validation counting, embedding.
//!
//! Without a Vulkan adapter the tests print `skipped: no Vulkan adapter` and pass, unless
//! `VRRT_REQUIRE_VULKAN=1`. Validation layers are always requested; every test asserts that the
//! executor saw no validation error.

#[path = "gpu/harness.rs"]
mod harness;

use harness::{
    accumulate_params, assert_clean, both, gpu, options, payloads, require_vulkan, samples,
    surfaces, tile_levels, Both, Rng, H, PLANES, W,
};
use vrrt_core::camera::{Camera, View};
use vrrt_core::executor::{BufferId, Executor, Groups, Pass};
use vrrt_core::glam::Vec3;
use vrrt_core::kernels::{atrous, buckets};
use vrrt_core::payload;
use vrrt_cpu::CpuExecutor;
use vrrt_tests::{layouts, Tolerance};
use vrrt_wgpu::{ExecError, WgpuError, WgpuExecutor};

#[test]
fn accumulate_matches_cpu() {
    let Some(mut b) = both() else { return };
    let mut rng = Rng(1);
    let n = W * H * PLANES;
    let history = b.buffer(bytemuck::cast_slice(&payloads(&mut rng, n)));
    let samples = b.buffer(bytemuck::cast_slice(&samples(&mut rng, n)));
    let changes = b.buffer(&vec![0u8; n as usize * 4]);
    let counters = b.buffer(&[0u8; payload::COUNTERS_LEN as usize * 4]);
    let [depth, normals] = [0; 2].map(|_| b.buffer(&vec![0u8; (W * H) as usize * 4]));
    let params = accumulate_params();
    let buffers = [history, samples, changes, counters, depth, normals];
    b.dispatch(&Pass::over_grid(
        &vrrt_core::kernels::ACCUMULATE,
        &buffers,
        bytemuck::bytes_of(&params),
        W,
        H,
        PLANES,
    ));
    b.assert_within(
        history,
        n as usize * 8,
        "accumulate",
        (layouts::PAYLOAD, &Tolerance::DEFAULT),
    );
    assert_clean(&b.gpu);
}

/// Runs two à-trous iterations (steps 1 and 2, the second reading the first's output) on both
/// backends and compares each within the table's tolerance (the second a half-ULP more: it
/// filters the first's rounded output).
fn atrous_within_tolerance(b: &mut Both) {
    let mut rng = Rng(2);
    let n = W * H * PLANES;
    let input: Vec<vrrt_core::payload::PackedFiltered> = (0..n)
        .map(|_| {
            vrrt_core::payload::Filtered {
                value: rng.value(),
                variance: rng.unit() * 2.0,
            }
            .pack()
        })
        .collect();
    let input = b.buffer(bytemuck::cast_slice(&input));
    // The G-buffer as an engine writes it, seen through a camera whose rays the positions follow.
    let camera = Camera::from_basis(Vec3::ZERO, Vec3::X, -Vec3::Y, Vec3::Z, 0.6);
    let view = View {
        camera,
        prev_camera: camera,
    };
    let (depth, normal_roughness): (Vec<f32>, Vec<u32>) = surfaces(&mut rng)
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let t = s.pack(i as u32 % W, i as u32 / W, &camera);
            (t.depth, t.normal_roughness)
        })
        .unzip();
    let depth = b.buffer(bytemuck::cast_slice(&depth));
    let normal_roughness = b.buffer(bytemuck::cast_slice(&normal_roughness));
    let view = b.buffer(bytemuck::bytes_of(&view));
    let tiles = b.buffer(bytemuck::cast_slice(&tile_levels()));
    // No guide or penumbra plane: one unread element each.
    let guide = b.buffer(bytemuck::bytes_of(&vrrt_core::kernels::reflect::NO_GUIDE));
    let penumbra = b.buffer(bytemuck::bytes_of(&vrrt_core::kernels::reflect::NO_GUIDE));
    let out = [
        b.buffer(&vec![0u8; n as usize * 8]),
        b.buffer(&vec![0u8; n as usize * 8]),
    ];
    for (i, step) in [1u32, 2].into_iter().enumerate() {
        let params = atrous::AtrousParams {
            width: W,
            height: H,
            step,
            iteration: i as u32,
            ..Default::default()
        };
        let src = if i == 0 { input } else { out[0] };
        let buffers = [
            src,
            depth,
            normal_roughness,
            view,
            tiles,
            guide,
            penumbra,
            out[i],
        ];
        b.dispatch(&Pass::over_grid(
            &vrrt_core::kernels::ATROUS,
            &buffers,
            bytemuck::bytes_of(&params),
            W,
            H,
            PLANES,
        ));
    }
    for (i, id) in out.into_iter().enumerate() {
        let tol = Tolerance::DEFAULT.halves(1 + i as u32);
        b.assert_within(
            id,
            n as usize * 4,
            &format!("atrous step {}", i + 1),
            (layouts::FILTERED, &tol),
        );
    }
}

/// The filter within tolerance on hostile inputs (zeros, huge and tiny values, sky).
#[test]
fn atrous_matches_cpu() {
    let Some(mut b) = both() else { return };
    atrous_within_tolerance(&mut b);
    assert_clean(&b.gpu);
}

fn bucket_case(b: &mut Both, rng: &mut Rng, width: u32, height: u32) {
    let requests: Vec<u32> = (0..width * height)
        .map(|_| match rng.below(20) {
            0 => buckets::NO_RAYS,
            1 => buckets::BUCKET_COUNT + rng.below(10),
            _ => rng.below(buckets::BUCKET_COUNT),
        })
        .collect();
    let requests = b.buffer(bytemuck::cast_slice(&requests));
    let counts = b.buffer(&vec![0u8; buckets::COUNTS_LEN as usize * 4]);
    let params = buckets::BucketParams { width, height };
    let buffers = [requests, counts];
    b.dispatch(&Pass::over_grid(
        &vrrt_core::kernels::COUNT_BUCKETS,
        &buffers,
        bytemuck::bytes_of(&params),
        width,
        height,
        1,
    ));
    b.assert_within(
        counts,
        buckets::COUNTS_LEN as usize * 4,
        &format!("count_buckets {width}x{height}"),
        (layouts::INTS, &Tolerance::DEFAULT),
    );
}

#[test]
fn buckets_match_cpu() {
    let Some(mut b) = both() else { return };
    let mut rng = Rng(3);
    bucket_case(&mut b, &mut rng, W, H);
    // Several rings.
    bucket_case(&mut b, &mut rng, 300, 170);
    assert_clean(&b.gpu);
}

/// Writes are ordered with recorded passes: the second pass sees the rewritten samples and the
/// first pass's history (accumulation is in place; a copy snapshots it in between), the first
/// one does not see the rewrite. Also covers indirect dispatch and a write of a length that is
/// not a multiple of 4.
#[test]
fn writes_stay_ordered_and_indirect_dispatch_works() {
    let Some(mut b) = both() else { return };
    let mut rng = Rng(4);
    let n = W * H * PLANES;
    let history = b.buffer(bytemuck::cast_slice(&payloads(&mut rng, n)));
    let samples_buf = b.buffer(bytemuck::cast_slice(&samples(&mut rng, n)));
    let snapshot = b.buffer(&vec![0u8; n as usize * 8]);
    let changes = b.buffer(&vec![0u8; n as usize * 4]);
    let counters = b.buffer(&[0u8; payload::COUNTERS_LEN as usize * 4]);
    let [depth, normals] = [0; 2].map(|_| b.buffer(&vec![0u8; (W * H) as usize * 4]));
    let params = accumulate_params();
    let params = bytemuck::bytes_of(&params);
    let first = [history, samples_buf, changes, counters, depth, normals];
    b.dispatch(&Pass::over_grid(
        &vrrt_core::kernels::ACCUMULATE,
        &first,
        params,
        W,
        H,
        PLANES,
    ));
    let words = n * 2;
    let copy = vrrt_core::kernels::copy::CopyParams {
        row: 64,
        len: words,
    };
    b.dispatch(&Pass::over_grid(
        &vrrt_core::kernels::COPY,
        &[history, snapshot],
        bytemuck::bytes_of(&copy),
        64,
        words.div_ceil(64),
        1,
    ));
    b.write(samples_buf, bytemuck::cast_slice(&samples(&mut rng, n)));
    let Groups::Direct(groups) = Pass::over_grid(
        &vrrt_core::kernels::ACCUMULATE,
        &first,
        params,
        W,
        H,
        PLANES,
    )
    .groups
    else {
        unreachable!()
    };
    let mut args = vec![0u32; 4];
    args[1..].copy_from_slice(&groups);
    let args = b.buffer(bytemuck::cast_slice(&args));
    let second = [history, samples_buf, changes, counters, depth, normals];
    b.dispatch(&Pass {
        kernel: &vrrt_core::kernels::ACCUMULATE,
        buffers: &second,
        params,
        groups: Groups::Indirect {
            buffer: args,
            offset: 4,
        },
    });
    let payload = (layouts::PAYLOAD, &Tolerance::DEFAULT);
    b.assert_within(
        snapshot,
        n as usize * 8,
        "accumulate before the write",
        payload,
    );
    b.assert_within(
        history,
        n as usize * 8,
        "accumulate after the write (indirect)",
        payload,
    );

    // 7 bytes: the 8th keeps its value.
    let word = b.buffer(&[0xaa; 8]);
    b.write(word, &[1, 2, 3, 4, 5, 6, 7]);
    let mut got = [0u8; 8];
    b.gpu.read_buffer(word, &mut got).unwrap();
    assert_eq!(got, [1, 2, 3, 4, 5, 6, 7, 0xaa]);
    b.assert_same(word, 8, "unaligned write");
    assert_clean(&b.gpu);
}

#[test]
fn passes_are_timed() {
    let Some(mut gpu) = gpu() else { return };
    let n = W * H * PLANES;
    let ids: Vec<BufferId> = [8, 8, 4, 4, 4, 4]
        .iter()
        .map(|s| gpu.create_buffer(n as u64 * s).unwrap())
        .collect();
    let params = accumulate_params();
    for _ in 0..3 {
        gpu.dispatch(&Pass::over_grid(
            &vrrt_core::kernels::ACCUMULATE,
            &ids,
            bytemuck::bytes_of(&params),
            W,
            H,
            PLANES,
        ))
        .unwrap();
    }
    gpu.finish().unwrap();
    println!(
        "timestamp period {} ns, timings: {:?}",
        gpu.queue().get_timestamp_period(),
        gpu.timings()
    );
    if gpu.timestamps_enabled() {
        assert_eq!(gpu.timings().len(), 3);
        assert!(gpu
            .timings()
            .iter()
            .all(|t| t.entry == "accumulate" && t.ms >= 0.0));
    } else {
        assert!(gpu.timings().is_empty());
    }
    gpu.clear_timings();
    assert!(gpu.timings().is_empty());
    assert_clean(&gpu);
}

#[test]
fn plan_errors_are_reported() {
    let Some(mut gpu) = gpu() else { return };
    let a = gpu.create_buffer(64).unwrap();
    let params = accumulate_params();
    let aliased = [a; 6];
    let err = gpu
        .dispatch(&Pass::over_grid(
            &vrrt_core::kernels::ACCUMULATE,
            &aliased,
            bytemuck::bytes_of(&params),
            1,
            1,
            1,
        ))
        .unwrap_err();
    assert!(
        matches!(err, WgpuError::Exec(ExecError::AliasedBinding(_))),
        "{err}"
    );
    let err = gpu
        .dispatch(&Pass::over_grid(
            &vrrt_core::kernels::ACCUMULATE,
            &[a],
            bytemuck::bytes_of(&params),
            1,
            1,
            1,
        ))
        .unwrap_err();
    assert!(matches!(err, WgpuError::Exec(ExecError::Plan(_))), "{err}");
    // Indirect counts in a buffer the pass writes (`history`, binding 0, accumulated in place).
    let bufs = [0; 6].map(|_| gpu.create_buffer(64).unwrap());
    let err = gpu
        .dispatch(&Pass {
            kernel: &vrrt_core::kernels::ACCUMULATE,
            buffers: &bufs,
            params: bytemuck::bytes_of(&params),
            groups: Groups::Indirect {
                buffer: bufs[0],
                offset: 0,
            },
        })
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        ExecError::IndirectWritten(bufs[0]).to_string()
    );
    assert!(
        matches!(err, WgpuError::Exec(ExecError::IndirectWritten(b)) if b == bufs[0]),
        "{err}"
    );
    assert!(matches!(
        gpu.create_buffer(6),
        Err(WgpuError::Exec(ExecError::UnalignedSize(6)))
    ));
    assert!(matches!(
        gpu.write_buffer(a, &[0; 65]),
        Err(WgpuError::Exec(ExecError::OutOfRange { .. }))
    ));
    assert!(matches!(
        gpu.read_buffer(BufferId(99), &mut [0; 4]),
        Err(WgpuError::Exec(ExecError::UnknownBuffer(_)))
    ));
    assert_clean(&gpu);
}

/// Both error sources are really counted: a wgpu validation error outside the executor's own
/// operations, and a message injected into the Vulkan debug messengers.
#[test]
fn validation_errors_are_counted() {
    let Some(gpu) = gpu() else { return };
    // Unaligned size with mapped_at_creation: a wgpu validation error, caught by the handler.
    let _bad = gpu.device().create_buffer(&wgpu::BufferDescriptor {
        label: Some("deliberately invalid"),
        size: 6,
        usage: wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: true,
    });
    assert_eq!(
        gpu.validation_errors(),
        1,
        "{:?}",
        gpu.validation_log().messages()
    );
    if gpu.validation_layer_active() {
        // SAFETY: only reads the instance handles to inject a debug message.
        let hal = unsafe { gpu.device().as_hal::<wgpu::hal::api::Vulkan>() }.unwrap();
        let shared = hal.shared_instance();
        let debug_utils =
            ash::ext::debug_utils::Instance::new(shared.entry(), shared.raw_instance());
        let data = ash::vk::DebugUtilsMessengerCallbackDataEXT::default()
            .message_id_name(c"VRRT-test")
            .message(c"deliberate test message");
        // SAFETY: valid callback data; VK_EXT_debug_utils is enabled (validation requested).
        unsafe {
            debug_utils.submit_debug_utils_message(
                ash::vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
                ash::vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION,
                &data,
            )
        };
        assert_eq!(
            gpu.validation_errors(),
            2,
            "{:?}",
            gpu.validation_log().messages()
        );
        assert!(gpu.validation_log().messages()[1].contains("deliberate test message"));
    }
}

/// A storage buffer of the application's own, holding `bytes`.
fn app_buffer(device: &wgpu::Device, queue: &wgpu::Queue, bytes: &[u8]) -> wgpu::Buffer {
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("engine history"),
        size: bytes.len() as u64,
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    queue.write_buffer(&buffer, 0, bytes);
    buffer
}

/// Embedding: the application's device and encoder, an imported buffer, results read after the
/// application submits.
#[test]
fn embedded_in_an_engine() {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::VULKAN,
        flags: wgpu::InstanceFlags::VALIDATION | wgpu::InstanceFlags::DEBUG,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter = || pollster::block_on(instance.request_adapter(&Default::default()));
    if let Err(e) = adapter() {
        assert!(!require_vulkan(), "VRRT_REQUIRE_VULKAN=1 but: {e}");
        println!("skipped: no Vulkan adapter ({e})");
        return;
    }
    // A device without immediates is refused with a clear error.
    let (device, queue) =
        pollster::block_on(adapter().unwrap().request_device(&Default::default())).unwrap();
    let err = WgpuExecutor::from_device(device, queue).unwrap_err();
    assert!(matches!(err, WgpuError::MissingFeatures(_)), "{err}");
    assert!(err.to_string().contains("IMMEDIATES"), "{err}");

    let (device, queue) =
        pollster::block_on(adapter().unwrap().request_device(&wgpu::DeviceDescriptor {
            required_features: wgpu::Features::IMMEDIATES,
            required_limits: wgpu::Limits {
                max_immediate_size: 128,
                ..wgpu::Limits::default()
            },
            ..Default::default()
        }))
        .unwrap();
    let mut gpu = WgpuExecutor::from_device(device.clone(), queue.clone()).unwrap();
    let mut cpu = CpuExecutor::new();

    let mut rng = Rng(5);
    let n = W * H * PLANES;
    let history = payloads(&mut rng, n);
    let samples = samples(&mut rng, n);
    // The history, accumulated in place, is the application's buffer.
    let history_bytes: &[u8] = bytemuck::cast_slice(&history);
    let app_history = app_buffer(&device, &queue, history_bytes);
    let history_g = gpu.import_buffer(app_history.clone()).unwrap();
    assert_eq!(gpu.buffer(history_g).unwrap(), &app_history);
    let history_c = cpu.create_buffer(history_bytes.len() as u64).unwrap();
    cpu.write_buffer(history_c, history_bytes).unwrap();
    let samples_bytes: &[u8] = bytemuck::cast_slice(&samples);
    let (samples_g, samples_c) = (
        gpu.create_buffer(samples_bytes.len() as u64).unwrap(),
        cpu.create_buffer(samples_bytes.len() as u64).unwrap(),
    );
    gpu.write_buffer(samples_g, samples_bytes).unwrap();
    cpu.write_buffer(samples_c, samples_bytes).unwrap();
    let counters = payload::COUNTERS_LEN as u64 * 4;
    let (counters_g, counters_c) = (
        gpu.create_buffer(counters).unwrap(),
        cpu.create_buffer(counters).unwrap(),
    );
    let changes = n as u64 * 4;
    let (changes_g, changes_c) = (
        gpu.create_buffer(changes).unwrap(),
        cpu.create_buffer(changes).unwrap(),
    );

    let geometry = (W * H) as u64 * 4;
    let [depth_g, normals_g] = [0; 2].map(|_| gpu.create_buffer(geometry).unwrap());
    let [depth_c, normals_c] = [0; 2].map(|_| cpu.create_buffer(geometry).unwrap());

    let params = accumulate_params();
    let gpu_buffers = [
        history_g, samples_g, changes_g, counters_g, depth_g, normals_g,
    ];
    let gpu_pass = Pass::over_grid(
        &vrrt_core::kernels::ACCUMULATE,
        &gpu_buffers,
        bytemuck::bytes_of(&params),
        W,
        H,
        PLANES,
    );
    let mut encoder = device.create_command_encoder(&Default::default());
    gpu.encode(&mut encoder, &[gpu_pass]).unwrap();
    queue.submit([encoder.finish()]);
    cpu.dispatch(&Pass {
        buffers: &[
            history_c, samples_c, changes_c, counters_c, depth_c, normals_c,
        ],
        ..gpu_pass
    })
    .unwrap();

    let mut g = vec![0u8; history_bytes.len()];
    let mut c = vec![0u8; history_bytes.len()];
    gpu.read_buffer(history_g, &mut g).unwrap();
    cpu.read_buffer(history_c, &mut c).unwrap();
    assert!(g == c, "embedded accumulate differs from the CPU");
    assert_clean(&gpu);
}

/// In a child process whose Vulkan loader finds no driver, construction fails with the
/// documented error instead of panicking.
#[test]
fn no_adapter_is_an_error() {
    if std::env::var_os("VRRT_WGPU_NO_DRIVER_CHILD").is_some() {
        match WgpuExecutor::new_headless(options()) {
            Err(e) => {
                println!("child got: {e}");
                assert!(e.to_string().contains("no Vulkan adapter"), "{e}");
            }
            Ok(e) => panic!("got an adapter without a driver: {:?}", e.adapter_info()),
        }
        return;
    }
    let missing = "/nonexistent/vrrt-no-such-icd.json";
    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "no_adapter_is_an_error",
            "--nocapture",
            "--test-threads=1",
        ])
        .env("VRRT_WGPU_NO_DRIVER_CHILD", "1")
        .env("VK_ICD_FILENAMES", missing)
        .env("VK_DRIVER_FILES", missing)
        .env_remove("VK_ADD_DRIVER_FILES")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!(
        "child stdout:\n{stdout}\nchild stderr:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "child failed");
    assert!(stdout.contains("no Vulkan adapter"));
}

/// A buffer beyond the device's `max_buffer_size` is refused with the limit's name before wgpu
/// sees it (the executor stays usable and validation clean), and a destroyed device surfaces as
/// an error from the executor's calls, not an abort.
#[test]
fn oversized_buffers_and_a_destroyed_device_are_errors() {
    let Some(mut e) = gpu() else { return };
    let max = e.device().limits().max_buffer_size;
    let too_big = (max / 4).saturating_add(1).saturating_mul(4);
    match e.create_buffer(too_big) {
        Err(WgpuError::Limit(why)) => assert!(why.contains("max_buffer_size"), "{why}"),
        other => panic!("{too_big} bytes: {other:?}"),
    }
    let b = e.create_buffer(64).unwrap();
    e.write_buffer(b, &[7u8; 64]).unwrap();
    let mut out = [0u8; 64];
    e.read_buffer(b, &mut out).unwrap();
    assert_eq!(out, [7u8; 64]);
    assert_clean(&e);

    e.device().destroy();
    // Each call returns (none aborts); reading back and uploading must fail.
    let read = e.read_buffer(b, &mut out);
    let write = e.write_buffer(b, &[1u8; 64]);
    let finish = e.finish();
    println!("after the device was destroyed: read {read:?}, write {write:?}, finish {finish:?}");
    assert!(
        read.is_err() && write.is_err(),
        "a destroyed device must surface as an error"
    );
}
