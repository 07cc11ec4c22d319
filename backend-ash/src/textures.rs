//! The engine's own images, read where a kernel reads a texture (`Access::Sampled`: the decode of
//! the engine's G-buffer) as sampled-image descriptors, never copied. Their ids share the
//! buffers' id space with the top bit set, so a texture id never names a buffer. The engine owns
//! an imported image's layout and synchronization; images the executor creates itself (for hosts
//! without an engine) are uploaded and left in `SHADER_READ_ONLY_OPTIMAL`.

use crate::alloc::memory_type;
use crate::{AshError, AshExecutor};
use ash::vk;
use vrrt_core::executor::{BufferId, Executor};

/// The bit that marks a texture id.
const TEXTURE_BIT: u32 = 1 << 31;

/// A texture passes can bind.
pub(crate) struct Texture {
    pub(crate) view: vk::ImageView,
    pub(crate) layout: vk::ImageLayout,
    /// Bytes of the image (what a pass reading it moves).
    pub(crate) bytes: u64,
    /// The image and memory the executor created, destroyed with it (none when imported).
    pub(crate) owned: Option<(vk::Image, vk::DeviceMemory)>,
    /// Width and height in texels.
    pub(crate) extent: (u32, u32),
}

impl AshExecutor {
    /// Binds an engine's image view where a kernel reads the engine's G-buffer (`Denoiser::ingest`),
    /// as it is, every frame it is bound.
    ///
    /// # Safety
    /// `view` belongs to this executor's device and stays alive while passes may bind it. It is a
    /// 2D view (one mip level, one layer) of a single-sampled image with `SAMPLED` usage in a
    /// float-sampled format, or of a depth format's depth aspect, of `width × height` texels of
    /// `texel_bytes`. Whenever a recorded pass
    /// reads it, the image is in `layout` (`SHADER_READ_ONLY_OPTIMAL` or `GENERAL`) and the
    /// engine's writes to it were made available to compute-shader reads by a barrier of its own.
    pub unsafe fn import_image(
        &mut self,
        view: vk::ImageView,
        layout: vk::ImageLayout,
        width: u32,
        height: u32,
        texel_bytes: u32,
    ) -> Result<BufferId, AshError> {
        let layouts = [
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            vk::ImageLayout::GENERAL,
        ];
        if !layouts.contains(&layout) {
            return Err(AshError::Texture(format!(
                "an engine image is read in SHADER_READ_ONLY_OPTIMAL or GENERAL layout, not {layout:?}"
            )));
        }
        Ok(self.add_texture(Texture {
            view,
            layout,
            bytes: width as u64 * height as u64 * texel_bytes as u64,
            owned: None,
            extent: (width, height),
        }))
    }

    /// A device-local `width × height` image of `format` (`texel_bytes` per texel; a depth format
    /// holds its depth) holding `data` (rows packed tightly), for a host without an engine of its
    /// own: uploaded through the staging ring in the executor's stream and left in
    /// `SHADER_READ_ONLY_OPTIMAL`.
    pub fn create_image(
        &mut self,
        width: u32,
        height: u32,
        format: vk::Format,
        texel_bytes: u32,
        data: &[u8],
    ) -> Result<BufferId, AshError> {
        let bytes = width as u64 * height as u64 * texel_bytes as u64;
        if width == 0 || height == 0 || data.len() as u64 != bytes {
            return Err(AshError::Texture(format!(
                "{} bytes for a {width}x{height} image of {texel_bytes}-byte texels",
                data.len()
            )));
        }
        let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
        let (image, memory, view) = self.new_image(width, height, format, usage)?;
        let texture = Texture {
            view,
            layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            bytes,
            owned: Some((image, memory)),
            extent: (width, height),
        };
        let id = self.add_texture(texture);
        self.upload_image(image, (width, height), aspect_of(format), data)?;
        Ok(id)
    }

    /// A device-local R32F image for the denoiser to write (`Denoiser::resolve_into`), for a
    /// host without an engine of its own: in `GENERAL` layout, read with [`Self::read_image`].
    pub fn create_output_image(&mut self, width: u32, height: u32) -> Result<BufferId, AshError> {
        if width == 0 || height == 0 {
            return Err(AshError::Texture(format!("a {width}x{height} image")));
        }
        let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
        let format = vk::Format::R32_SFLOAT;
        let (image, memory, view) = self.new_image(width, height, format, usage)?;
        let id = self.add_texture(Texture {
            view,
            layout: vk::ImageLayout::GENERAL,
            bytes: width as u64 * height as u64 * 4,
            owned: Some((image, memory)),
            extent: (width, height),
        });
        let cmd = self.recording()?;
        let color = vk::ImageAspectFlags::COLOR;
        let to_general = image_barrier(
            image,
            color,
            vk::ImageLayout::UNDEFINED,
            vk::ImageLayout::GENERAL,
        )
        .dst_access_mask(vk::AccessFlags::SHADER_WRITE);
        let (top, compute) = (
            vk::PipelineStageFlags::TOP_OF_PIPE,
            vk::PipelineStageFlags::COMPUTE_SHADER,
        );
        let none = vk::DependencyFlags::empty();
        // SAFETY: `cmd` is recording; the image lives until the executor drops.
        unsafe {
            self.device
                .cmd_pipeline_barrier(cmd, top, compute, none, &[], &[], &[to_general]);
        }
        Ok(id)
    }

    /// Copies the texels of an image made by [`Self::create_output_image`] into `out` (rows
    /// packed tightly, 4 bytes a texel), after the passes recorded before: waits for them.
    pub fn read_image(&mut self, id: BufferId, out: &mut [u8]) -> Result<(), AshError> {
        let Some(Texture {
            owned: Some((image, _)),
            layout: vk::ImageLayout::GENERAL,
            bytes,
            extent: (width, height),
            ..
        }) = self.texture(id)
        else {
            return Err(AshError::Texture(format!(
                "{id:?} is not an output image of the executor"
            )));
        };
        let (image, bytes, width, height) = (*image, *bytes, *width, *height);
        if out.len() as u64 != bytes {
            return Err(AshError::Texture(format!(
                "{} bytes asked of {bytes}",
                out.len()
            )));
        }
        let cmd = self.recording()?;
        let dst = self.readback_buffer(bytes)?;
        let color = vk::ImageAspectFlags::COLOR;
        let written = image_barrier(
            image,
            color,
            vk::ImageLayout::GENERAL,
            vk::ImageLayout::GENERAL,
        )
        .src_access_mask(vk::AccessFlags::SHADER_WRITE)
        .dst_access_mask(vk::AccessFlags::TRANSFER_READ);
        let to_host = vk::BufferMemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::HOST_READ)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .buffer(dst)
            .offset(0)
            .size(vk::WHOLE_SIZE);
        let region = copy_region(0, width, height, color);
        let (compute, transfer, host) = (
            vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::HOST,
        );
        let (d, none) = (&self.device, vk::DependencyFlags::empty());
        // SAFETY: `cmd` is recording; the image and buffer live until the submission completes.
        unsafe {
            d.cmd_pipeline_barrier(cmd, compute, transfer, none, &[], &[], &[written]);
            d.cmd_copy_image_to_buffer(cmd, image, vk::ImageLayout::GENERAL, dst, &[region]);
            d.cmd_pipeline_barrier(cmd, transfer, host, none, &[], &[to_host], &[]);
        }
        self.finish()?;
        self.readback.as_ref().expect("created above").read(out);
        Ok(())
    }

    fn add_texture(&mut self, texture: Texture) -> BufferId {
        self.textures.push(texture);
        BufferId(TEXTURE_BIT | (self.textures.len() as u32 - 1))
    }

    /// The texture `id`, if it is one.
    pub(crate) fn texture(&self, id: BufferId) -> Option<&Texture> {
        if id.0 & TEXTURE_BIT == 0 {
            return None;
        }
        self.textures.get((id.0 & !TEXTURE_BIT) as usize)
    }

    /// An image with device-local memory and a view of it.
    fn new_image(
        &mut self,
        width: u32,
        height: u32,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
    ) -> Result<(vk::Image, vk::DeviceMemory, vk::ImageView), AshError> {
        let d = &self.device;
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width,
                height,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid create infos; on every error path what was created is destroyed once.
        unsafe {
            let image = d
                .create_image(&info, None)
                .map_err(AshError::vk("vkCreateImage"))?;
            let req = d.get_image_memory_requirements(image);
            let required = vk::MemoryPropertyFlags::empty();
            let local = vk::MemoryPropertyFlags::DEVICE_LOCAL;
            let Some(index) = memory_type(&self.mem_props, req.memory_type_bits, required, local)
            else {
                d.destroy_image(image, None);
                return Err(AshError::NoMemoryType("image"));
            };
            let alloc = vk::MemoryAllocateInfo::default()
                .allocation_size(req.size)
                .memory_type_index(index);
            let memory = match d.allocate_memory(&alloc, None) {
                Ok(m) => m,
                Err(e) => {
                    d.destroy_image(image, None);
                    return Err(AshError::vk("vkAllocateMemory")(e));
                }
            };
            let view_info = vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(format)
                .subresource_range(range(aspect_of(format)));
            let view = d
                .bind_image_memory(image, memory, 0)
                .and_then(|()| d.create_image_view(&view_info, None));
            match view {
                Ok(view) => Ok((image, memory, view)),
                Err(e) => {
                    d.destroy_image(image, None);
                    d.free_memory(memory, None);
                    Err(AshError::vk("vkCreateImageView")(e))
                }
            }
        }
    }

    /// Records the upload of `data` into `image` (layout `UNDEFINED`) and its transition to
    /// `SHADER_READ_ONLY_OPTIMAL`, visible to compute-shader reads.
    fn upload_image(
        &mut self,
        image: vk::Image,
        (width, height): (u32, u32),
        aspect: vk::ImageAspectFlags,
        data: &[u8],
    ) -> Result<(), AshError> {
        let cmd = self.recording()?;
        let (src, offset) = self.staging.push(&self.device, &self.mem_props, data)?;
        let to_transfer = image_barrier(
            image,
            aspect,
            vk::ImageLayout::UNDEFINED,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        )
        .dst_access_mask(vk::AccessFlags::TRANSFER_WRITE);
        let to_shader = image_barrier(
            image,
            aspect,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        )
        .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
        .dst_access_mask(vk::AccessFlags::SHADER_READ);
        let region = copy_region(offset, width, height, aspect);
        let d = &self.device;
        let none = vk::DependencyFlags::empty();
        // SAFETY: `cmd` is recording; the image and staging buffer live until it completes.
        unsafe {
            let (top, transfer) = (
                vk::PipelineStageFlags::TOP_OF_PIPE,
                vk::PipelineStageFlags::TRANSFER,
            );
            d.cmd_pipeline_barrier(cmd, top, transfer, none, &[], &[], &[to_transfer]);
            let dst = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
            d.cmd_copy_buffer_to_image(cmd, src, image, dst, &[region]);
            let compute = vk::PipelineStageFlags::COMPUTE_SHADER;
            d.cmd_pipeline_barrier(cmd, transfer, compute, none, &[], &[], &[to_shader]);
        }
        Ok(())
    }
}

/// Destroys the images the executor created (imported ones are the engine's).
///
/// # Safety
/// No pending GPU work may use them.
pub(crate) unsafe fn destroy(textures: Vec<Texture>, device: &ash::Device) {
    for t in textures {
        if let Some((image, memory)) = t.owned {
            // SAFETY: caller's contract; each object destroyed once.
            unsafe {
                device.destroy_image_view(t.view, None);
                device.destroy_image(image, None);
                device.free_memory(memory, None);
            }
        }
    }
}

/// A layout transition of `image`'s one level and layer (of `aspect`), no accesses yet.
fn image_barrier(
    image: vk::Image,
    aspect: vk::ImageAspectFlags,
    old: vk::ImageLayout,
    new: vk::ImageLayout,
) -> vk::ImageMemoryBarrier<'static> {
    vk::ImageMemoryBarrier::default()
        .old_layout(old)
        .new_layout(new)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(range(aspect))
}

/// A copy of a whole `width × height` image (its `aspect`) from or to a buffer at `offset`, rows
/// packed.
fn copy_region(
    offset: u64,
    width: u32,
    height: u32,
    aspect: vk::ImageAspectFlags,
) -> vk::BufferImageCopy {
    vk::BufferImageCopy::default()
        .buffer_offset(offset)
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: aspect,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        })
        .image_extent(vk::Extent3D {
            width,
            height,
            depth: 1,
        })
}

/// The aspect a texel fetch of `format` reads: depth for a depth format, else colour.
fn aspect_of(format: vk::Format) -> vk::ImageAspectFlags {
    match format {
        vk::Format::D16_UNORM | vk::Format::D32_SFLOAT | vk::Format::X8_D24_UNORM_PACK32 => {
            vk::ImageAspectFlags::DEPTH
        }
        _ => vk::ImageAspectFlags::COLOR,
    }
}

/// The one mip level and layer of an image's `aspect`.
fn range(aspect: vk::ImageAspectFlags) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: aspect,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}
