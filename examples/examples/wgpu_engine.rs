//! VRRT-rs inside an application that already has a wgpu device: the executor wraps the
//! application's device and queue ([`WgpuExecutor::from_device`]) and records the denoiser's
//! passes into the application's own command encoder ([`WgpuExecutor::encode`]). wgpu inserts
//! every barrier, also between the application's commands and the denoiser's. The denoiser reads
//! the application's own G-buffer textures, in its conventions (view-space normals, UV motion),
//! and writes the result into the application's own R32F texture: no copy pass either way.
//!
//! `cargo run --release -p vrrt-examples --example wgpu_engine`
//!
//! Prints `skipped: no Vulkan adapter` and succeeds without a Vulkan driver, unless
//! `VRRT_REQUIRE_VULKAN=1`. `VRRT_VALIDATION=1` runs it under the Khronos validation layer.

use vrrt_core::denoiser::{Denoiser, EngineTextures};
use vrrt_examples::{
    assert_close, capture, cpu_frames, frame_info, gbuffer_texels, require_vulkan, settings,
    texture_conventions, trace, validation, FRAMES, HALF_STEPS, HEIGHT, PIXELS, WIDTH,
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
    run(&device, &queue)
}

/// The application's frames, each denoised from its textures into its texture and checked
/// against the CPU backend's.
fn run(device: &wgpu::Device, queue: &wgpu::Queue) -> Result<(), Box<dyn std::error::Error>> {
    let mut gpu = WgpuExecutor::from_device(device.clone(), queue.clone())?;
    let mut d = Denoiser::new(&mut gpu, WIDTH, HEIGHT, settings()).map_err(|e| e.to_string())?;
    let AppTextures {
        depth,
        normal,
        motion,
        ao,
    } = AppTextures::new(device);
    // Imported once: the denoiser binds them as they are every frame.
    let textures = EngineTextures::new(
        gpu.import_texture(&depth)?,
        gpu.import_texture(&normal)?,
        gpu.import_texture(&motion)?,
        texture_conventions(),
    )?;
    let output = gpu.import_texture(&ao)?;
    // The application's buffer it reads the denoised image back from (rows padded for copies).
    let row = (WIDTH * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("app readback"),
        size: (row * HEIGHT) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let buffer = |gpu: &WgpuExecutor, id| gpu.buffer(id).expect("denoiser buffer").clone();
    let write = |texture: &wgpu::Texture, bytes: &[u8]| {
        let layout = wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(bytes.len() as u32 / HEIGHT),
            rows_per_image: Some(HEIGHT),
        };
        queue.write_texture(texture.as_image_copy(), bytes, layout, extent());
    };

    let reference = cpu_frames();
    let mut worst = 0;
    for (frame, want) in (0..FRAMES).zip(&reference) {
        d.begin_frame(&mut gpu, frame_info(frame))?;
        // The application's G-buffer pass renders into its textures (here uploads).
        let g = gbuffer_texels(frame);
        write(&depth, bytemuck::cast_slice(&g.depth));
        write(&normal, bytemuck::cast_slice(&g.normal));
        write(&motion, bytemuck::cast_slice(&g.motion));
        d.ingest(&mut gpu, &textures)?;

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

        // Accumulation and filtering into the application's texture, which it then reads.
        let resolve = capture(&mut gpu, |e| d.resolve_into(e, output))?;
        let mut encoder = device.create_command_encoder(&Default::default());
        gpu.encode(&mut encoder, &resolve.get())?;
        let copy = wgpu::TexelCopyBufferInfo {
            buffer: &readback,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(HEIGHT),
            },
        };
        encoder.copy_texture_to_buffer(ao.as_image_copy(), copy, extent());
        queue.submit([encoder.finish()]);

        readback.map_async(wgpu::MapMode::Read, .., |r| r.expect("map readback"));
        device.poll(wgpu::PollType::wait_indefinitely())?;
        let mapped = readback.get_mapped_range(..)?;
        let denoised: Vec<f32> = mapped
            .chunks(row as usize)
            .flat_map(|r| bytemuck::pod_collect_to_vec::<u8, f32>(&r[..WIDTH as usize * 4]))
            .collect();
        drop(mapped);
        readback.unmap();
        assert_eq!(denoised.len(), PIXELS);
        // Not bit-exact: the GPU's math is its own ([`assert_close`]).
        let err = assert_close(
            &format!("frame {frame}"),
            &denoised,
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

/// The application's own textures: its G-buffer, and the image the denoised AO goes into.
struct AppTextures {
    depth: wgpu::Texture,
    normal: wgpu::Texture,
    motion: wgpu::Texture,
    ao: wgpu::Texture,
}

impl AppTextures {
    fn new(device: &wgpu::Device) -> Self {
        let texture = |format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some("app texture"),
                size: extent(),
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let gbuffer = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
        let ao = wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC;
        AppTextures {
            depth: texture(wgpu::TextureFormat::R32Float, gbuffer),
            normal: texture(wgpu::TextureFormat::Rgba32Float, gbuffer),
            motion: texture(wgpu::TextureFormat::Rgba32Float, gbuffer),
            ao: texture(wgpu::TextureFormat::R32Float, ao),
        }
    }
}

/// The application's image size as a wgpu extent.
fn extent() -> wgpu::Extent3d {
    wgpu::Extent3d {
        width: WIDTH,
        height: HEIGHT,
        depth_or_array_layers: 1,
    }
}
