//! VRRT-rs inside an application that already has a wgpu device: the executor wraps the
//! application's device and queue ([`WgpuExecutor::from_device`]) and records the denoiser's
//! passes into the application's own command encoder ([`WgpuExecutor::encode`]). wgpu inserts
//! every barrier, also between the application's commands and the denoiser's.
//!
//! `cargo run --release -p vrrt-examples --example wgpu_engine`
//!
//! Prints `skipped: no Vulkan adapter` and succeeds without a Vulkan driver, unless
//! `VRRT_REQUIRE_VULKAN=1`. `VRRT_VALIDATION=1` runs it under the Khronos validation layer.

use vrrt_core::denoiser::Denoiser;
use vrrt_core::payload::PackedFiltered;
use vrrt_examples::{
    assert_close, capture, cpu_frames, frame_info, gbuffer, require_vulkan, settings, trace,
    validation, values, FRAMES, HALF_STEPS, HEIGHT, PIXELS, WIDTH,
};
use vrrt_wgpu::WgpuExecutor;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // The application's own instance, adapter, device and queue.
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::VULKAN,
        flags: if validation() {
            wgpu::InstanceFlags::VALIDATION | wgpu::InstanceFlags::DEBUG
        } else {
            wgpu::InstanceFlags::empty()
        },
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter = match pollster::block_on(instance.request_adapter(&Default::default())) {
        Ok(adapter) => adapter,
        Err(e) if !require_vulkan() => {
            println!("skipped: no Vulkan adapter ({e})");
            return Ok(());
        }
        Err(e) => return Err(format!("VRRT_REQUIRE_VULKAN=1 but: {e}").into()),
    };
    // What the denoiser needs from the device: immediates (push constants) for its parameters,
    // and as many storage buffers per pass as its largest kernel binds.
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_features: wgpu::Features::IMMEDIATES,
        required_limits: wgpu::Limits {
            max_immediate_size: vrrt_wgpu::MIN_IMMEDIATE_SIZE,
            max_storage_buffers_per_shader_stage:
                adapter.limits().max_storage_buffers_per_shader_stage,
            ..wgpu::Limits::default()
        },
        ..Default::default()
    }))?;
    println!("adapter: {}", adapter.get_info().name);

    let mut gpu = WgpuExecutor::from_device(device.clone(), queue.clone())?;
    let mut d = Denoiser::new(&mut gpu, WIDTH, HEIGHT, settings()).map_err(|e| e.to_string())?;
    let output_bytes = (PIXELS * size_of::<PackedFiltered>()) as u64;
    // The application's buffer it reads the denoised image back from.
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("app readback"),
        size: output_bytes,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let buffer = |gpu: &WgpuExecutor, id| gpu.buffer(id).expect("denoiser buffer").clone();

    let reference = cpu_frames();
    let mut worst = 0;
    for (frame, want) in (0..FRAMES).zip(&reference) {
        d.begin_frame(&mut gpu, frame_info(frame))?;
        // The application's G-buffer pass writes the denoiser's input buffers (here uploads).
        for (id, bytes) in gbuffer(frame).uploads(d.inputs()) {
            queue.write_buffer(&buffer(&gpu, id), 0, bytes);
        }

        // Reprojection, requests and load balancing, recorded into the application's encoder.
        let plan = capture(&mut gpu, |e| d.plan_rays(e))?;
        let mut encoder = device.create_command_encoder(&Default::default());
        gpu.encode(&mut encoder, &plan.get())?;
        queue.submit([encoder.finish()]);

        // An engine's ray-tracing pass would read the work list `d.work()` on the GPU (pixels
        // and their rays, `work_list::work_item`; `d.args()` is its indirect dispatch); this
        // example traces on the host.
        let rays = d.read_rays(&mut gpu)?;
        assert_eq!(
            rays, want.rays,
            "frame {frame}: rays differ from the CPU backend"
        );
        let samples = buffer(&gpu, d.samples());
        queue.write_buffer(&samples, 0, bytemuck::cast_slice(&trace(frame, &rays)));

        // Accumulation and filtering, then the application's own copy of the result.
        let resolve = capture(&mut gpu, |e| d.resolve(e))?;
        let mut encoder = device.create_command_encoder(&Default::default());
        gpu.encode(&mut encoder, &resolve.get())?;
        let output = buffer(&gpu, d.output());
        encoder.copy_buffer_to_buffer(&output, 0, &readback, 0, output_bytes);
        queue.submit([encoder.finish()]);

        readback.map_async(wgpu::MapMode::Read, .., |r| r.expect("map readback"));
        device.poll(wgpu::PollType::wait_indefinitely())?;
        let denoised: Vec<PackedFiltered> =
            bytemuck::pod_collect_to_vec(&readback.get_mapped_range(..)?);
        readback.unmap();
        // Not bit-exact: the GPU's math is its own ([`assert_close`]).
        let err = assert_close(
            &format!("frame {frame}"),
            &values(&denoised),
            &want.denoised,
            HALF_STEPS,
        );
        worst = worst.max(err);
    }
    let errors = gpu.validation_errors();
    assert_eq!(errors, 0, "{:?}", gpu.validation_log().messages());
    println!(
        "ok: {FRAMES} frames match the CPU backend (largest difference {worst} binary16 steps)"
    );
    Ok(())
}
