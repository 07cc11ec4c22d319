//! The engine's own textures: imported once, bound where a kernel reads a texture
//! (`Access::Sampled`, the `ingest` pass), never copied. Their ids share the buffers' id space
//! with the top bit set, so a texture id can never name a buffer.

use crate::{WgpuError, WgpuExecutor};
use vrrt_core::executor::BufferId;

/// The bit that marks a texture id.
const TEXTURE_BIT: u32 = 1 << 31;

/// An imported texture: the view passes bind and the bytes of its first mip level (what a pass
/// reading it moves).
pub(crate) struct Imported {
    pub(crate) view: wgpu::TextureView,
    pub(crate) bytes: u64,
}

impl WgpuExecutor {
    /// Wraps an application's texture so the `ingest` pass (`Denoiser::ingest`) can read it with
    /// texel fetches, as it is, every frame it is bound. It must belong to this executor's device
    /// and be a 2D, single-sampled texture with [`wgpu::TextureUsages::TEXTURE_BINDING`] and a
    /// float-sampled format (R32F, RG16F, RGBA16F, RGB10A2, RGBA8 and the like; depth formats are
    /// not accepted yet). Its first mip level is read.
    pub fn import_texture(&mut self, texture: &wgpu::Texture) -> Result<BufferId, WgpuError> {
        let refuse = |why: String| Err(WgpuError::Texture(why));
        let format = texture.format();
        if !texture
            .usage()
            .contains(wgpu::TextureUsages::TEXTURE_BINDING)
        {
            return refuse(format!(
                "lacks TEXTURE_BINDING usage ({:?})",
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
        if !matches!(
            format.sample_type(None, None),
            Some(wgpu::TextureSampleType::Float { .. })
        ) {
            return refuse(format!("format {format:?} is not read as floats"));
        }
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            label: Some("vrrt engine texture"),
            base_mip_level: 0,
            mip_level_count: Some(1),
            ..Default::default()
        });
        let texel = format.block_copy_size(None).unwrap_or(4) as u64;
        let bytes = texture.width() as u64 * texture.height() as u64 * texel;
        let id = BufferId(TEXTURE_BIT | self.textures.len() as u32);
        self.textures.push(Imported { view, bytes });
        Ok(id)
    }

    /// The imported texture `id`, if it is one.
    pub(crate) fn imported(&self, id: BufferId) -> Option<&Imported> {
        if id.0 & TEXTURE_BIT == 0 {
            return None;
        }
        self.textures.get((id.0 & !TEXTURE_BIT) as usize)
    }
}
