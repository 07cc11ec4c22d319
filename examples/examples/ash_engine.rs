//! VRRT-rs inside an application that has its own Vulkan instance, device and command buffers:
//! the executor borrows them ([`AshExecutor::from_raw`]) and records the denoiser's passes into
//! the application's command buffer ([`AshExecutor::record_into`]). The denoiser reads the
//! application's own G-buffer images in its conventions ([`AshExecutor::import_image`],
//! `Denoiser::ingest`) and writes the result into the application's own image
//! (`Denoiser::resolve_into`): no copy pass either way.
//!
//! The executor inserts the barriers between its own passes and against its own earlier work
//! (uploads, readbacks, earlier recordings). The application inserts the ones between *its*
//! commands and the denoiser's, marked `BARRIER` below: before the passes, from its last access
//! of a buffer or image to `COMPUTE_SHADER` (read and write); after them, from `COMPUTE_SHADER`
//! writes to its own consumer. Run with `VRRT_VALIDATION=1` to have the synchronization validation layer
//! check them.
//!
//! `cargo run --release -p vrrt-examples --example ash_engine`
//!
//! Prints `skipped: no Vulkan adapter` and succeeds without a Vulkan driver, unless
//! `VRRT_REQUIRE_VULKAN=1`.
#![deny(unsafe_op_in_unsafe_fn)]

use std::ffi::{c_void, CStr};
use std::sync::atomic::{AtomicU32, Ordering};
use vrrt_ash::ash::{self, vk};
use vrrt_ash::{AshExecutor, RawVulkan};
use vrrt_core::denoiser::{Denoiser, EngineTextures};
use vrrt_core::executor::Pass;
use vrrt_examples::{
    assert_close, capture, cpu_frames, frame_info, gbuffer_texels, require_vulkan, settings,
    texture_conventions, trace, validation, FRAMES, HALF_STEPS, HEIGHT, PIXELS, WIDTH,
};

type Error = Box<dyn std::error::Error>;

fn main() -> Result<(), Error> {
    let app = match App::new() {
        Ok(app) => app,
        Err(e) if !require_vulkan() => {
            println!("skipped: no Vulkan adapter ({e})");
            return Ok(());
        }
        Err(e) => return Err(format!("VRRT_REQUIRE_VULKAN=1 but: {e}").into()),
    };
    // The executor is dropped inside `run`, before the application's device.
    let result = run(&app);
    // SAFETY: nothing uses the application's objects any more.
    unsafe { app.destroy() };
    result
}

fn run(app: &App) -> Result<(), Error> {
    let raw = RawVulkan {
        instance: app.instance.clone(),
        device: app.device.clone(),
        physical_device: app.physical_device,
        queue: app.queue,
        queue_family_index: app.family,
    };
    // SAFETY: the handles outlive the executor, the device has vulkanMemoryModel, and only this
    // thread uses the queue.
    let mut ex = unsafe { AshExecutor::from_raw(raw) }?;
    let mut d = Denoiser::new(&mut ex, WIDTH, HEIGHT, settings()).map_err(|e| e.to_string())?;
    let images = AppImages::new(app)?;
    // Imported once: the denoiser binds them as they are every frame. SAFETY: 2D views of
    // single-sampled images of the executor's device, alive until after it is dropped; the
    // barriers below keep them in these layouts whenever the denoiser's passes run.
    let (read, general) = (
        vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        vk::ImageLayout::GENERAL,
    );
    let textures = EngineTextures::new(
        unsafe { ex.import_image(images.depth.view, read, WIDTH, HEIGHT, 4) }?,
        unsafe { ex.import_image(images.normal.view, read, WIDTH, HEIGHT, 16) }?,
        unsafe { ex.import_image(images.motion.view, read, WIDTH, HEIGHT, 16) }?,
        texture_conventions(),
    )?;
    let output = unsafe { ex.import_image(images.ao.view, general, WIDTH, HEIGHT, 4) }?;

    // The application's host-visible buffers: G-buffer and samples it uploads, the image it reads.
    let texel_bytes = [4, 16, 16].map(|b| b * PIXELS as u64);
    let samples_bytes = std::mem::size_of_val(trace(0, &[0; PIXELS]).as_slice()) as u64;
    let src = vk::BufferUsageFlags::TRANSFER_SRC;
    let staging_gbuffer = texel_bytes
        .iter()
        .map(|&bytes| app.host_buffer(bytes, src))
        .collect::<Result<Vec<_>, _>>()?;
    let staging_samples = app.host_buffer(samples_bytes, src)?;
    let readback = app.host_buffer(4 * PIXELS as u64, vk::BufferUsageFlags::TRANSFER_DST)?;

    let reference = cpu_frames();
    let mut worst = 0;
    for (frame, want) in (0..FRAMES).zip(&reference) {
        d.begin_frame(&mut ex, frame_info(frame))?;
        let g = gbuffer_texels(frame);
        let texels: [&[u8]; 3] = [
            bytemuck::cast_slice(&g.depth),
            bytemuck::cast_slice(&g.normal),
            bytemuck::cast_slice(&g.motion),
        ];
        let samples = ex.raw_buffer(d.samples())?;

        // Command buffer 1: the application's G-buffer pass (uploads here, a raster pass in an
        // engine) into its images, then reprojection (which reads them), requests and balancing.
        for (bytes, staging) in texels.iter().zip(&staging_gbuffer) {
            unsafe { staging.write(bytes) };
        }
        let plan = capture(&mut ex, |e| {
            d.ingest(e, &textures)?;
            d.plan_rays(e)
        })?;
        unsafe {
            app.submit(
                &mut ex,
                &plan.get(),
                |cmd| images.upload(app, cmd, &staging_gbuffer),
                |_| {},
            )
        }?;

        // An engine's ray-tracing pass would read the work list `d.work()` on the GPU (pixels
        // and their rays, `work_list::work_item`; `d.args()` is its indirect dispatch); this example
        // reads it back (the executor's own readback, synchronized by its own barriers) and traces on
        // the host.
        let rays = d.read_rays(&mut ex)?;
        assert_eq!(
            rays, want.rays,
            "frame {frame}: rays differ from the CPU backend"
        );

        // Command buffer 2: the application's samples, accumulation and filtering into its image,
        // and the application's copy of that image to the host.
        unsafe { staging_samples.write(bytemuck::cast_slice(&trace(frame, &rays))) };
        let resolve = capture(&mut ex, |e| d.resolve_into(e, output))?;
        unsafe {
            app.submit(
                &mut ex,
                &resolve.get(),
                |cmd| {
                    // BARRIER (write-after-read): last frame's accumulation read the samples buffer.
                    app.barrier(cmd, samples, COMPUTE, TRANSFER_WRITE);
                    app.copy(cmd, staging_samples.buffer, samples, samples_bytes);
                    // BARRIER (read-after-write): accumulation reads what the copy wrote.
                    app.barrier(cmd, samples, TRANSFER_WRITE, COMPUTE);
                    images.ao_for_writing(app, cmd, frame == 0);
                },
                |cmd| images.ao_to_host(app, cmd, &readback),
            )
        }?;
        let mut denoised = vec![0.0f32; PIXELS];
        unsafe { readback.read(bytemuck::cast_slice_mut(&mut denoised)) };
        // Not bit-exact: the GPU's math is its own ([`assert_close`]).
        let err = assert_close(
            &format!("frame {frame}"),
            &denoised,
            &want.denoised,
            HALF_STEPS,
        );
        worst = worst.max(err);
    }
    drop(ex);
    for b in staging_gbuffer
        .into_iter()
        .chain([staging_samples, readback])
    {
        unsafe { b.destroy(&app.device) };
    }
    unsafe { images.destroy(&app.device) };
    verdict(worst);
    Ok(())
}

/// The application's own images: its G-buffer in its conventions (linear depth R32F,
/// view-space normals and UV motion RGBA32F), and the R32F image the denoised AO goes into.
struct AppImages {
    depth: AppImage,
    normal: AppImage,
    motion: AppImage,
    ao: AppImage,
}

impl AppImages {
    fn new(app: &App) -> Result<Self, Error> {
        let gbuffer = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
        let ao = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
        Ok(AppImages {
            depth: app.image(vk::Format::R32_SFLOAT, gbuffer)?,
            normal: app.image(vk::Format::R32G32B32A32_SFLOAT, gbuffer)?,
            motion: app.image(vk::Format::R32G32B32A32_SFLOAT, gbuffer)?,
            ao: app.image(vk::Format::R32_SFLOAT, ao)?,
        })
    }

    /// Records the G-buffer pass: here copies of `staging` (depth, normal, motion) into the
    /// images, left in `SHADER_READ_ONLY_OPTIMAL` for reprojection.
    unsafe fn upload(&self, app: &App, cmd: vk::CommandBuffer, staging: &[HostBuffer]) {
        let (undefined, to_copy, read) = (
            vk::ImageLayout::UNDEFINED,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        );
        for (image, staging) in [&self.depth, &self.normal, &self.motion]
            .iter()
            .zip(staging)
        {
            let image = image.image;
            unsafe {
                // BARRIER (write-after-read): last frame's reprojection read the image.
                app.layout(cmd, image, undefined, to_copy, COMPUTE, TRANSFER_WRITE);
                app.copy_to_image(cmd, staging.buffer, image);
                // BARRIER (read-after-write): reprojection reads what the copy wrote.
                app.layout(cmd, image, to_copy, read, TRANSFER_WRITE, COMPUTE);
            }
        }
    }

    /// BARRIER (write-after-read): last frame's copy to the host read the AO image, which the
    /// last filter pass writes in `GENERAL` layout (from `UNDEFINED` on the `first` frame).
    unsafe fn ao_for_writing(&self, app: &App, cmd: vk::CommandBuffer, first: bool) {
        let general = vk::ImageLayout::GENERAL;
        let before = if first {
            vk::ImageLayout::UNDEFINED
        } else {
            general
        };
        unsafe { app.layout(cmd, self.ao.image, before, general, TRANSFER_READ, COMPUTE) };
    }

    /// The AO image's copy to `readback`, after the last filter pass wrote it.
    unsafe fn ao_to_host(&self, app: &App, cmd: vk::CommandBuffer, readback: &HostBuffer) {
        let general = vk::ImageLayout::GENERAL;
        unsafe {
            // BARRIER (read-after-write): the copy reads what the last filter pass wrote.
            app.layout(cmd, self.ao.image, general, general, COMPUTE, TRANSFER_READ);
            app.copy_from_image(cmd, self.ao.image, readback.buffer);
            // BARRIER: make the copy visible to the host's read after the fence.
            app.barrier(cmd, readback.buffer, TRANSFER_WRITE, HOST_READ);
        }
    }

    unsafe fn destroy(self, device: &ash::Device) {
        for image in [self.depth, self.normal, self.motion, self.ao] {
            // SAFETY: no GPU work uses the images any more.
            unsafe { image.destroy(device) };
        }
    }
}

/// An image with its own device memory and a view of its one level.
struct AppImage {
    image: vk::Image,
    memory: vk::DeviceMemory,
    view: vk::ImageView,
}

impl AppImage {
    unsafe fn destroy(self, device: &ash::Device) {
        // SAFETY: no GPU work uses the image any more.
        unsafe {
            device.destroy_image_view(self.view, None);
            device.destroy_image(self.image, None);
            device.free_memory(self.memory, None);
        }
    }
}

/// The one level and layer of a colour image.
const COLOR: vk::ImageSubresourceRange = vk::ImageSubresourceRange {
    aspect_mask: vk::ImageAspectFlags::COLOR,
    base_mip_level: 0,
    level_count: 1,
    base_array_layer: 0,
    layer_count: 1,
};

/// A copy of a whole `WIDTH × HEIGHT` image from or to a buffer, rows packed.
fn whole_image() -> vk::BufferImageCopy {
    vk::BufferImageCopy::default()
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        })
        .image_extent(vk::Extent3D {
            width: WIDTH,
            height: HEIGHT,
            depth: 1,
        })
}

/// Fails on any validation error the layers printed, else says how close the frames were.
fn verdict(worst: u32) {
    let errors = VALIDATION_ERRORS.load(Ordering::Relaxed);
    assert_eq!(errors, 0, "{errors} validation errors (printed above)");
    println!(
        "ok: {FRAMES} frames match the CPU backend (largest difference {worst} binary16 steps)"
    );
}

/// A pipeline stage and the accesses of it a barrier orders.
type Scope = (vk::PipelineStageFlags, vk::AccessFlags);
/// What [`AshExecutor::record_into`] asks for around its passes: compute shaders, reading and
/// writing storage buffers.
const COMPUTE: Scope = (
    vk::PipelineStageFlags::COMPUTE_SHADER,
    vk::AccessFlags::from_raw(
        vk::AccessFlags::SHADER_READ.as_raw() | vk::AccessFlags::SHADER_WRITE.as_raw(),
    ),
);
const TRANSFER_WRITE: Scope = (
    vk::PipelineStageFlags::TRANSFER,
    vk::AccessFlags::TRANSFER_WRITE,
);
const TRANSFER_READ: Scope = (
    vk::PipelineStageFlags::TRANSFER,
    vk::AccessFlags::TRANSFER_READ,
);
const HOST_READ: Scope = (vk::PipelineStageFlags::HOST, vk::AccessFlags::HOST_READ);

/// Validation-layer errors seen by the application's messenger.
static VALIDATION_ERRORS: AtomicU32 = AtomicU32::new(0);

unsafe extern "system" fn on_message(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    _: *mut c_void,
) -> vk::Bool32 {
    if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        VALIDATION_ERRORS.fetch_add(1, Ordering::Relaxed);
    }
    // SAFETY: the layer passes valid callback data for the duration of the call.
    let message = unsafe { data.as_ref().and_then(|d| d.message_as_c_str()) };
    let message = message.map(CStr::to_string_lossy).unwrap_or_default();
    eprintln!("[vulkan {severity:?}] {message}");
    vk::FALSE
}

/// The application's Vulkan objects.
struct App {
    _entry: ash::Entry,
    instance: ash::Instance,
    messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    physical_device: vk::PhysicalDevice,
    device: ash::Device,
    family: u32,
    queue: vk::Queue,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
}

/// A host-visible, host-coherent buffer, persistently mapped.
struct HostBuffer {
    buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    ptr: *mut u8,
}

impl HostBuffer {
    unsafe fn write(&self, data: &[u8]) {
        // SAFETY: the mapping is at least `data.len()` bytes and no GPU work uses it now.
        unsafe { std::ptr::copy_nonoverlapping(data.as_ptr(), self.ptr, data.len()) };
    }

    unsafe fn read(&self, out: &mut [u8]) {
        // SAFETY: as `write`.
        unsafe { std::ptr::copy_nonoverlapping(self.ptr, out.as_mut_ptr(), out.len()) };
    }

    unsafe fn destroy(self, device: &ash::Device) {
        // SAFETY: no GPU work uses the buffer any more.
        unsafe {
            device.destroy_buffer(self.buffer, None);
            device.free_memory(self.memory, None);
        }
    }
}

impl App {
    /// Instance (with the validation layer when asked), the first device with Vulkan 1.2, a
    /// compute queue and `vulkanMemoryModel` (which rust-gpu's SPIR-V declares), and one command
    /// buffer with its fence.
    fn new() -> Result<App, Error> {
        // SAFETY: loading the system's Vulkan loader.
        let entry = unsafe { ash::Entry::load() }?;
        let layers = [c"VK_LAYER_KHRONOS_validation".as_ptr()];
        let extensions = [
            ash::ext::debug_utils::NAME.as_ptr(),
            ash::ext::validation_features::NAME.as_ptr(),
        ];
        let sync = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&sync);
        let app_info = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_2);
        let mut info = vk::InstanceCreateInfo::default().application_info(&app_info);
        if validation() {
            info = info
                .enabled_layer_names(&layers)
                .enabled_extension_names(&extensions)
                .push_next(&mut features);
        }
        let instance = unsafe { entry.create_instance(&info, None) }?;
        let messenger = validation().then(|| {
            let utils = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                        | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                        | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION,
                )
                .pfn_user_callback(Some(on_message));
            let messenger = unsafe { utils.create_debug_utils_messenger(&info, None) };
            messenger.map(|m| (utils, m))
        });
        let messenger = messenger.transpose()?;

        let mut found = None;
        for pd in unsafe { instance.enumerate_physical_devices() }? {
            let props = unsafe { instance.get_physical_device_properties(pd) };
            let mut v12 = vk::PhysicalDeviceVulkan12Features::default();
            let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut v12);
            unsafe { instance.get_physical_device_features2(pd, &mut f2) };
            let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
            let compute = families
                .iter()
                .position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE));
            if props.api_version >= vk::API_VERSION_1_2 && v12.vulkan_memory_model == vk::TRUE {
                if let Some(family) = compute {
                    found = Some((pd, family as u32, props.device_name_as_c_str()?.to_owned()));
                    break;
                }
            }
        }
        let Some((physical_device, family, name)) = found else {
            return Err("no device with Vulkan 1.2, compute and vulkanMemoryModel".into());
        };
        println!("device: {}", name.to_string_lossy());

        let priorities = [1.0];
        let queues = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(family)
            .queue_priorities(&priorities)];
        let mut v12 = vk::PhysicalDeviceVulkan12Features::default().vulkan_memory_model(true);
        let info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queues)
            .push_next(&mut v12);
        let device = unsafe { instance.create_device(physical_device, &info, None) }?;
        let queue = unsafe { device.get_device_queue(family, 0) };
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        let pool = unsafe { device.create_command_pool(&pool_info, None) }?;
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .command_buffer_count(1);
        let cmd = unsafe { device.allocate_command_buffers(&alloc) }?[0];
        let fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }?;
        Ok(App {
            _entry: entry,
            instance,
            messenger,
            physical_device,
            device,
            family,
            queue,
            pool,
            cmd,
            fence,
        })
    }

    fn host_buffer(&self, size: u64, usage: vk::BufferUsageFlags) -> Result<HostBuffer, Error> {
        let d = &self.device;
        let info = vk::BufferCreateInfo::default().size(size).usage(usage);
        let buffer = unsafe { d.create_buffer(&info, None) }?;
        let req = unsafe { d.get_buffer_memory_requirements(buffer) };
        let flags = vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT;
        let type_index = self
            .memory_type(req.memory_type_bits, flags)
            .ok_or("no host-visible coherent memory")?;
        let alloc = vk::MemoryAllocateInfo::default()
            .allocation_size(req.size)
            .memory_type_index(type_index);
        let memory = unsafe { d.allocate_memory(&alloc, None) }?;
        unsafe { d.bind_buffer_memory(buffer, memory, 0) }?;
        let ptr = unsafe { d.map_memory(memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty()) }?;
        Ok(HostBuffer {
            buffer,
            memory,
            ptr: ptr.cast(),
        })
    }

    /// A memory type allowed by `bits` with `flags`.
    fn memory_type(&self, bits: u32, flags: vk::MemoryPropertyFlags) -> Option<u32> {
        let props = unsafe {
            self.instance
                .get_physical_device_memory_properties(self.physical_device)
        };
        (0..props.memory_type_count).find(|&i| {
            bits & (1 << i) != 0
                && props.memory_types[i as usize]
                    .property_flags
                    .contains(flags)
        })
    }

    /// A `WIDTH × HEIGHT` image of `format` with device memory and a view.
    fn image(&self, format: vk::Format, usage: vk::ImageUsageFlags) -> Result<AppImage, Error> {
        let d = &self.device;
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width: WIDTH,
                height: HEIGHT,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let image = unsafe { d.create_image(&info, None) }?;
        let req = unsafe { d.get_image_memory_requirements(image) };
        let type_index = self
            .memory_type(req.memory_type_bits, vk::MemoryPropertyFlags::DEVICE_LOCAL)
            .or_else(|| self.memory_type(req.memory_type_bits, vk::MemoryPropertyFlags::empty()))
            .ok_or("no memory for an image")?;
        let alloc = vk::MemoryAllocateInfo::default()
            .allocation_size(req.size)
            .memory_type_index(type_index);
        let memory = unsafe { d.allocate_memory(&alloc, None) }?;
        unsafe { d.bind_image_memory(image, memory, 0) }?;
        let view_info = vk::ImageViewCreateInfo::default()
            .image(image)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(format)
            .subresource_range(COLOR);
        let view = unsafe { d.create_image_view(&view_info, None) }?;
        Ok(AppImage {
            image,
            memory,
            view,
        })
    }

    /// An image memory barrier on `image`, from layout `old` to `new`.
    unsafe fn layout(
        &self,
        cmd: vk::CommandBuffer,
        image: vk::Image,
        old: vk::ImageLayout,
        new: vk::ImageLayout,
        src: Scope,
        dst: Scope,
    ) {
        let barrier = vk::ImageMemoryBarrier::default()
            .old_layout(old)
            .new_layout(new)
            .src_access_mask(src.1)
            .dst_access_mask(dst.1)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image)
            .subresource_range(COLOR);
        let none = vk::DependencyFlags::empty();
        unsafe {
            self.device
                .cmd_pipeline_barrier(cmd, src.0, dst.0, none, &[], &[], &[barrier])
        };
    }

    unsafe fn copy_to_image(&self, cmd: vk::CommandBuffer, src: vk::Buffer, image: vk::Image) {
        let layout = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
        let region = [whole_image()];
        unsafe {
            self.device
                .cmd_copy_buffer_to_image(cmd, src, image, layout, &region)
        };
    }

    unsafe fn copy_from_image(&self, cmd: vk::CommandBuffer, image: vk::Image, dst: vk::Buffer) {
        let layout = vk::ImageLayout::GENERAL;
        let region = [whole_image()];
        unsafe {
            self.device
                .cmd_copy_image_to_buffer(cmd, image, layout, dst, &region)
        };
    }

    /// A buffer memory barrier on all of `buffer`.
    unsafe fn barrier(&self, cmd: vk::CommandBuffer, buffer: vk::Buffer, src: Scope, dst: Scope) {
        let barrier = vk::BufferMemoryBarrier::default()
            .src_access_mask(src.1)
            .dst_access_mask(dst.1)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .buffer(buffer)
            .size(vk::WHOLE_SIZE);
        unsafe {
            self.device.cmd_pipeline_barrier(
                cmd,
                src.0,
                dst.0,
                vk::DependencyFlags::empty(),
                &[],
                &[barrier],
                &[],
            )
        };
    }

    unsafe fn copy(&self, cmd: vk::CommandBuffer, src: vk::Buffer, dst: vk::Buffer, size: u64) {
        let region = vk::BufferCopy::default().size(size);
        unsafe { self.device.cmd_copy_buffer(cmd, src, dst, &[region]) };
    }

    /// Records `before`, the denoiser's `passes` and `after` into the application's command
    /// buffer, submits it to the queue the executor was given, and waits for it.
    unsafe fn submit(
        &self,
        ex: &mut AshExecutor,
        passes: &[Pass<'_>],
        before: impl FnOnce(vk::CommandBuffer),
        after: impl FnOnce(vk::CommandBuffer),
    ) -> Result<(), Error> {
        let (d, cmd) = (&self.device, self.cmd);
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        unsafe { d.begin_command_buffer(cmd, &begin) }?;
        before(cmd);
        // SAFETY: `cmd` is recording, outside a render pass, from a pool of the executor's queue
        // family; it is submitted to the executor's queue below and retired once complete.
        let recording = unsafe { ex.record_into(cmd, passes) }?;
        after(cmd);
        unsafe {
            d.end_command_buffer(cmd)?;
            let cmds = [cmd];
            let submit = vk::SubmitInfo::default().command_buffers(&cmds);
            d.queue_submit(self.queue, &[submit], self.fence)?;
            d.wait_for_fences(&[self.fence], true, u64::MAX)?;
            d.reset_fences(&[self.fence])?;
            ex.retire(recording)?;
        }
        Ok(())
    }

    unsafe fn destroy(self) {
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_fence(self.fence, None);
            self.device.destroy_command_pool(self.pool, None);
            self.device.destroy_device(None);
            if let Some((utils, messenger)) = self.messenger {
                utils.destroy_debug_utils_messenger(messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}
