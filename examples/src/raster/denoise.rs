//! The raster engine with VRRT in it: each frame is one command buffer of the engine's own,
//! holding its G-buffer pass, the copy of its hits into the tracer's buffer, and VRRT's whole
//! frame (`Frame::render`: reprojection decoding the engine's textures, ray rates, VRRT's own AO
//! tracer on the scene's BVH, accumulation and the filter, whose last iteration writes the
//! engine's output texture), recorded with `WgpuExecutor::encode`.

use super::{conventions, RasterEngine};
use crate::{capture, read};
use std::error::Error;
use vrrt_core::denoiser::EngineTextures;
use vrrt_core::executor::BufferId;
use vrrt_core::frame::{Frame, FrameReport, Signal};
use vrrt_core::settings::Settings;
use vrrt_core::surface::Texel;
use vrrt_scene::render::GpuScene;
use vrrt_scene::{FrameGeometry, Scene};
use vrrt_wgpu::{WgpuError, WgpuExecutor};

/// The engine, the denoiser's frame and what the tracer reads of the scene.
pub struct RasterDenoiser {
    device: wgpu::Device,
    queue: wgpu::Queue,
    gpu: WgpuExecutor,
    engine: RasterEngine,
    frame: Frame,
    /// The scene's BVH, lights and instance maps on the executor, for VRRT's tracer.
    bvh: GpuScene,
    /// The engine's R32F texture the denoised signal goes into (plane after plane, down).
    output: BufferId,
    pixels: usize,
}

impl RasterDenoiser {
    /// The engine for `scene` at `size` on the application's device, denoising `signal` with
    /// `settings`. The engine's depth, normal and motion textures and its output texture are
    /// imported once: the denoiser binds them as they are every frame, in the engine's
    /// [`conventions`].
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        size: (u32, u32),
        signal: Signal,
        settings: Settings,
    ) -> Result<Self, Box<dyn Error>> {
        let mut gpu = WgpuExecutor::from_device(device.clone(), queue.clone())?;
        let engine = RasterEngine::new(device, queue, scene, size);
        let t = engine.targets();
        let textures = EngineTextures::new(
            gpu.import_texture(&t.depth)?,
            gpu.import_texture(&t.normal)?,
            gpu.import_texture(&t.motion)?,
            conventions(),
        )?;
        let mut frame = Frame::new(
            &mut gpu,
            size.0,
            size.1,
            signal,
            scene.lights.len(),
            settings,
        )
        .map_err(|e| e.to_string())?;
        let planes = frame.layout().planes;
        let output = gpu.import_texture(&device.create_texture(&wgpu::TextureDescriptor {
            label: Some("engine output"),
            size: wgpu::Extent3d {
                width: size.0,
                height: size.1 * planes,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        }))?;
        frame.set_engine_textures(Some(textures));
        frame.set_output_texture(Some(output));
        Ok(RasterDenoiser {
            device: device.clone(),
            queue: queue.clone(),
            gpu,
            engine,
            frame,
            bvh: GpuScene::default(),
            output,
            pixels: (size.0 * size.1) as usize,
        })
    }

    /// The executor (its validation log).
    pub fn executor(&self) -> &WgpuExecutor {
        &self.gpu
    }

    /// What the denoiser's ingest pass made of the engine's textures in the last frame rendered,
    /// with the hits the engine copied for the tracer: per pixel, in VRRT's own formats
    /// (`surface::Texel`), to hold against VRRT's ray-traced G-buffer ([`super::agreement`]).
    pub fn read_inputs(&mut self) -> Result<Vec<Texel>, WgpuError> {
        let g = self.frame.gbuffer();
        let n = self.pixels;
        let depth: Vec<f32> = read(&mut self.gpu, g.inputs.depth, n)?;
        let normal: Vec<u32> = read(&mut self.gpu, g.inputs.normal_roughness, n)?;
        let motion: Vec<[u32; 2]> = read(&mut self.gpu, g.inputs.motion, n)?;
        let hit: Vec<[u32; 2]> = read(&mut self.gpu, g.geometry, n)?;
        Ok((0..n)
            .map(|i| Texel {
                depth: depth[i],
                normal_roughness: normal[i],
                motion: motion[i],
                hit: hit[i],
            })
            .collect())
    }

    /// Renders frame `f` of `scene` and returns its denoised signal (plane after plane).
    ///
    /// The denoiser's passes are captured rather than run (`Frame::render` only records), so
    /// they go into the engine's command buffer after its G-buffer pass: the G-buffer closure
    /// that `Frame::render` calls only notes which buffer the tracer reads the hits from this
    /// frame (the renderer's `geometry`, two of them in turn), which the engine then fills by a
    /// copy; reprojection reads the engine's textures itself.
    pub fn render(&mut self, scene: &Scene, f: &FrameGeometry) -> Result<Vec<f32>, Box<dyn Error>> {
        let RasterDenoiser {
            gpu, frame, bvh, ..
        } = self;
        bvh.upload(gpu, f)?;
        let frame_scene = bvh.frame_scene(f);
        let (mut report, mut hits) = (FrameReport::default(), None::<BufferId>);
        let passes = capture(gpu, |e| {
            report = frame.render(e, &frame_scene, |_, target| {
                hits = Some(target.geometry);
                Ok(())
            })?;
            Ok(())
        })?;
        let mut encoder = self.device.create_command_encoder(&Default::default());
        self.engine.draw(&mut encoder, scene, f);
        if let Some(id) = hits {
            let buffer = self.gpu.buffer(id).ok_or("no geometry buffer")?.clone();
            self.engine.copy_hits(&mut encoder, &buffer);
        }
        self.gpu.encode(&mut encoder, &passes.get())?;
        self.queue.submit([encoder.finish()]);
        // The rays traced and, with a budget in milliseconds, the next frame's budget.
        self.frame
            .finish(&mut self.gpu, report)
            .map_err(|e| e.to_string())?;
        let planes = self.frame.layout().planes as usize;
        let mut denoised = vec![0.0f32; self.pixels * planes];
        self.gpu
            .read_texture(self.output, bytemuck::cast_slice_mut(&mut denoised))?;
        Ok(denoised)
    }
}

/// The application's device and queue, and its adapter's name.
pub struct AppDevice {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter's name.
    pub adapter: String,
}

/// The application's device: Vulkan, with what the denoiser needs (immediates, as many storage
/// buffers per stage as its largest kernel binds), under the validation layer when `validation`.
/// `Ok(Err(why))` when there is no Vulkan adapter: the caller decides whether that is a skip.
pub fn open_device(validation: bool) -> Result<Result<AppDevice, String>, Box<dyn Error>> {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::VULKAN,
        flags: if validation {
            wgpu::InstanceFlags::VALIDATION | wgpu::InstanceFlags::DEBUG
        } else {
            wgpu::InstanceFlags::empty()
        },
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter = match pollster::block_on(instance.request_adapter(&Default::default())) {
        Ok(adapter) => adapter,
        Err(e) => return Ok(Err(e.to_string())),
    };
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
    Ok(Ok(AppDevice {
        device,
        queue,
        adapter: adapter.get_info().name,
    }))
}
