//! The engine's own textures: imported once, bound where a kernel reads a texture
//! (`Access::Sampled`: the engine's G-buffer) or writes one (`Access::Storage`: the denoised
//! output), never copied. Their ids share the buffers' id space
//! with the top bit set, so a texture id can never name a buffer.

use crate::{WgpuError, WgpuExecutor};
use vrrt_core::executor::{Access, BufferId};

/// The bit that marks a texture id.
const TEXTURE_BIT: u32 = 1 << 31;

/// The format of a texture the denoiser writes (`Denoiser::resolve_into`).
pub(crate) const OUTPUT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

/// An imported texture: the view passes bind and the bytes of its first mip level (what a pass
/// reading it moves).
pub(crate) struct Imported {
    pub(crate) view: wgpu::TextureView,
    pub(crate) bytes: u64,
    pub(crate) texture: wgpu::Texture,
}

impl WgpuExecutor {
    /// Wraps an application's texture so the denoiser can read it with texel fetches (the
    /// engine's G-buffer: `Denoiser::ingest`) or write into it (`Denoiser::resolve_into`), as it
    /// is, every frame it is bound. It must belong to this executor's device and be 2D and
    /// single-sampled. Read: [`wgpu::TextureUsages::TEXTURE_BINDING`] and a float-sampled format
    /// (R32F, RG16F, RGBA16F, RGB10A2, RGBA8 and the like) or a depth format (Depth32Float: its
    /// depth aspect, read as unfilterable floats).
    /// Written: [`wgpu::TextureUsages::STORAGE_BINDING`] and R32F. Its first mip level is
    /// used; what it is bound as is checked when a pass binds it.
    pub fn import_texture(&mut self, texture: &wgpu::Texture) -> Result<BufferId, WgpuError> {
        let refuse = |why: String| Err(WgpuError::Texture(why));
        let format = texture.format();
        let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::STORAGE_BINDING;
        if !texture.usage().intersects(usage) {
            return refuse(format!(
                "has neither TEXTURE_BINDING nor STORAGE_BINDING usage ({:?})",
                texture.usage()
            ));
        }
        if texture.dimension() != wgpu::TextureDimension::D2 || texture.sample_count() != 1 {
            return refuse(format!(
                "must be 2D and single-sampled (is {:?}, {} samples)",
                texture.dimension(),
                texture.sample_count()
            ));
        }
        // A depth format is read through its depth aspect, as unfilterable floats.
        let aspect = if format.has_depth_aspect() {
            wgpu::TextureAspect::DepthOnly
        } else {
            wgpu::TextureAspect::All
        };
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            label: Some("vrrt engine texture"),
            base_mip_level: 0,
            mip_level_count: Some(1),
            aspect,
            ..Default::default()
        });
        let texel = format.block_copy_size(Some(aspect)).unwrap_or(4) as u64;
        let bytes = texture.width() as u64 * texture.height() as u64 * texel;
        let id = BufferId(TEXTURE_BIT | self.textures.len() as u32);
        self.textures.push(Imported {
            view,
            bytes,
            texture: texture.clone(),
        });
        Ok(id)
    }

    /// Refuses a texture bound where it cannot be used: read (`Access::Sampled`) without
    /// TEXTURE_BINDING or a float-sampled format, written (`Access::Storage`) without
    /// STORAGE_BINDING or in another format than R32F.
    pub(crate) fn check_texture(&self, id: BufferId, access: Access) -> Result<(), WgpuError> {
        let Some(t) = self.imported(id) else {
            return Ok(());
        };
        let (usage, format) = (t.texture.usage(), t.texture.format());
        let float = matches!(
            format.sample_type(None, None),
            Some(wgpu::TextureSampleType::Float { .. })
        ) || format.sample_type(Some(wgpu::TextureAspect::DepthOnly), None)
            == Some(wgpu::TextureSampleType::Depth);
        let why = match access {
            Access::Sampled if !usage.contains(wgpu::TextureUsages::TEXTURE_BINDING) => {
                "is read but lacks TEXTURE_BINDING usage".to_string()
            }
            Access::Sampled if !float => {
                format!("is read but its format {format:?} is not read as floats")
            }
            Access::Storage if !usage.contains(wgpu::TextureUsages::STORAGE_BINDING) => {
                "is written but lacks STORAGE_BINDING usage".to_string()
            }
            Access::Storage if format != OUTPUT_FORMAT => {
                format!("is written but is {format:?}, not {OUTPUT_FORMAT:?}")
            }
            _ => return Ok(()),
        };
        Err(WgpuError::Texture(format!("{id:?} {why}")))
    }

    /// The application's texture behind `id`, if `id` is an imported texture.
    pub fn texture(&self, id: BufferId) -> Option<&wgpu::Texture> {
        self.imported(id).map(|t| &t.texture)
    }

    /// Copies the first mip level of imported texture `id` into `out` (rows packed tightly), after
    /// the work recorded so far: submits it and waits. For hosts that check what a pass wrote
    /// into a texture; `out` must hold exactly the level's bytes.
    pub fn read_texture(&mut self, id: BufferId, out: &mut [u8]) -> Result<(), WgpuError> {
        let texture = self
            .texture(id)
            .ok_or_else(|| WgpuError::Texture(format!("{id:?} is not an imported texture")))?
            .clone();
        let (w, h) = (texture.width(), texture.height());
        let texel = texture.format().block_copy_size(None).unwrap_or(4);
        if out.len() as u64 != w as u64 * h as u64 * texel as u64 {
            return Err(WgpuError::Texture(format!(
                "{id:?} holds {w}x{h} texels of {texel} bytes, not {} bytes",
                out.len()
            )));
        }
        vrrt_core::executor::Executor::finish(self)?;
        let row = (w * texel).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let buffer = self.scoped(|| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("vrrt texture readback"),
                size: row as u64 * h as u64,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            })
        })?;
        let mut encoder = self.device.create_command_encoder(&Default::default());
        let layout = wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(row),
            rows_per_image: Some(h),
        };
        let copy = wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout,
        };
        encoder.copy_texture_to_buffer(texture.as_image_copy(), copy, texture.size());
        self.queue.submit([encoder.finish()]);
        let slice = buffer.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| WgpuError::Device(format!("waiting for a texture readback: {e}")))?;
        let mapped = slice
            .get_mapped_range()
            .map_err(|e| WgpuError::Device(format!("mapping a texture readback: {e:?}")))?;
        let packed = (w * texel) as usize;
        for (r, dst) in out.chunks_exact_mut(packed).enumerate() {
            dst.copy_from_slice(&mapped[r * row as usize..][..packed]);
        }
        Ok(())
    }

    /// The imported texture `id`, if it is one.
    pub(crate) fn imported(&self, id: BufferId) -> Option<&Imported> {
        if id.0 & TEXTURE_BIT == 0 {
            return None;
        }
        self.textures.get((id.0 & !TEXTURE_BIT) as usize)
    }
}
