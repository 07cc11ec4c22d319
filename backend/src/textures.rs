//! Engine textures made from host texels, for the callers that have no engine of their own to
//! render them (tests, benches, the CLI's checks): [`Backend::create_texture`] stores them in a
//! GPU format and hands the CPU backend exactly what a fetch of that format returns, so every
//! backend reads the same values.

use crate::{err, Backend, BackendError};
use vrrt_core::binary16::{f16_to_f32, f32_to_f16};
use vrrt_core::executor::{BufferId, Executor};
use vrrt_core::textures::Texel;

/// The formats [`Backend::create_texture`] stores texels in: what engines write their G-buffers
/// in.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum TextureFormat {
    /// One f32 (depth).
    R32Float,
    /// Two binary16 (2D motion).
    Rg16Float,
    /// Four binary16 (view-space normals and roughness, 2.5D motion).
    Rgba16Float,
    /// Four f32.
    Rgba32Float,
    /// 10-bit unorm RGB and 2-bit alpha (NRD's normal + roughness packing).
    Rgb10a2Unorm,
    /// A depth buffer's f32 depth. wgpu takes no uploads into depth textures (an engine renders
    /// them): on wgpu [`Backend::create_texture`] refuses it.
    Depth32Float,
}

impl TextureFormat {
    /// The wgpu format.
    pub fn wgpu(self) -> wgpu::TextureFormat {
        match self {
            TextureFormat::R32Float => wgpu::TextureFormat::R32Float,
            TextureFormat::Rg16Float => wgpu::TextureFormat::Rg16Float,
            TextureFormat::Rgba16Float => wgpu::TextureFormat::Rgba16Float,
            TextureFormat::Rgba32Float => wgpu::TextureFormat::Rgba32Float,
            TextureFormat::Rgb10a2Unorm => wgpu::TextureFormat::Rgb10a2Unorm,
            TextureFormat::Depth32Float => wgpu::TextureFormat::Depth32Float,
        }
    }

    /// The Vulkan format and its bytes per texel.
    pub fn vulkan(self) -> (vrrt_ash::ash::vk::Format, u32) {
        use vrrt_ash::ash::vk::Format;
        match self {
            TextureFormat::R32Float => (Format::R32_SFLOAT, 4),
            TextureFormat::Rg16Float => (Format::R16G16_SFLOAT, 4),
            TextureFormat::Rgba16Float => (Format::R16G16B16A16_SFLOAT, 8),
            TextureFormat::Rgba32Float => (Format::R32G32B32A32_SFLOAT, 16),
            TextureFormat::Rgb10a2Unorm => (Format::A2B10G10R10_UNORM_PACK32, 4),
            TextureFormat::Depth32Float => (Format::D32_SFLOAT, 4),
        }
    }

    /// `t` stored in this format, as bytes.
    fn encode(self, t: Texel, out: &mut Vec<u8>) {
        let half = |v: f32| f32_to_f16(v) as u16;
        let unorm = |v: f32, bits: u32| {
            let max = ((1u32 << bits) - 1) as f32;
            (v.clamp(0.0, 1.0) * max).round() as u32
        };
        match self {
            TextureFormat::R32Float | TextureFormat::Depth32Float => {
                out.extend_from_slice(&t[0].to_le_bytes())
            }
            TextureFormat::Rg16Float => t[..2]
                .iter()
                .for_each(|&v| out.extend_from_slice(&half(v).to_le_bytes())),
            TextureFormat::Rgba16Float => t
                .iter()
                .for_each(|&v| out.extend_from_slice(&half(v).to_le_bytes())),
            TextureFormat::Rgba32Float => t
                .iter()
                .for_each(|&v| out.extend_from_slice(&v.to_le_bytes())),
            TextureFormat::Rgb10a2Unorm => {
                let w = unorm(t[0], 10)
                    | unorm(t[1], 10) << 10
                    | unorm(t[2], 10) << 20
                    | unorm(t[3], 2) << 30;
                out.extend_from_slice(&w.to_le_bytes());
            }
        }
    }

    /// What a fetch of `t` stored in this format returns.
    pub fn fetched(self, t: Texel) -> Texel {
        let half = |v: f32| f16_to_f32(f32_to_f16(v));
        let unorm = |v: f32, bits: u32| {
            let max = ((1u32 << bits) - 1) as f32;
            (v.clamp(0.0, 1.0) * max).round() / max
        };
        match self {
            TextureFormat::R32Float | TextureFormat::Depth32Float => [t[0], 0.0, 0.0, 1.0],
            TextureFormat::Rg16Float => [half(t[0]), half(t[1]), 0.0, 1.0],
            TextureFormat::Rgba16Float => t.map(half),
            TextureFormat::Rgba32Float => t,
            TextureFormat::Rgb10a2Unorm => [
                unorm(t[0], 10),
                unorm(t[1], 10),
                unorm(t[2], 10),
                unorm(t[3], 2),
            ],
        }
    }
}

impl Backend {
    /// A `width × height` engine texture of `format` holding `texels` (row-major), bound where a
    /// kernel reads the engine's textures (`Denoiser::ingest`). On the CPU backend it holds what a
    /// fetch of `format` returns.
    pub fn create_texture(
        &mut self,
        width: u32,
        height: u32,
        format: TextureFormat,
        texels: &[Texel],
    ) -> Result<BufferId, BackendError> {
        if width == 0 || height == 0 || texels.len() as u64 != width as u64 * height as u64 {
            return Err(err(format!(
                "{} texels for a {width}x{height} texture",
                texels.len()
            )));
        }
        match self {
            Backend::Cpu(e) => {
                let fetched: Vec<Texel> = texels.iter().map(|&t| format.fetched(t)).collect();
                e.create_texture(width, height, &fetched).map_err(err)
            }
            Backend::Wgpu(_) if format == TextureFormat::Depth32Float => Err(err(
                "wgpu takes no uploads into a depth texture: render into it and import it",
            )),
            Backend::Wgpu(e) => {
                let mut bytes = Vec::new();
                texels.iter().for_each(|&t| format.encode(t, &mut bytes));
                let size = wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                };
                let texture = e.device().create_texture(&wgpu::TextureDescriptor {
                    label: Some("vrrt texture"),
                    size,
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: format.wgpu(),
                    usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                });
                e.queue().write_texture(
                    texture.as_image_copy(),
                    &bytes,
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(bytes.len() as u32 / height),
                        rows_per_image: Some(height),
                    },
                    size,
                );
                e.import_texture(&texture).map_err(err)
            }
            Backend::Ash(e) => {
                let mut bytes = Vec::new();
                texels.iter().for_each(|&t| format.encode(t, &mut bytes));
                let (vk_format, texel) = format.vulkan();
                e.create_image(width, height, vk_format, texel, &bytes)
                    .map_err(err)
            }
        }
    }
}

impl Backend {
    /// A `width × height` R32F texture for the denoiser to write (`Denoiser::resolve_into`),
    /// zero-filled, readable with [`Self::read_texture`]: for hosts without an engine.
    pub fn create_output_texture(
        &mut self,
        width: u32,
        height: u32,
    ) -> Result<BufferId, BackendError> {
        if width == 0 || height == 0 {
            return Err(err(format!("a {width}x{height} texture")));
        }
        match self {
            Backend::Cpu(e) => {
                let zeros = vec![[0.0; 4]; width as usize * height as usize];
                e.create_texture(width, height, &zeros).map_err(err)
            }
            Backend::Wgpu(e) => {
                let texture = e.device().create_texture(&wgpu::TextureDescriptor {
                    label: Some("vrrt output"),
                    size: extent(width, height),
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::R32Float,
                    usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
                    view_formats: &[],
                });
                e.import_texture(&texture).map_err(err)
            }
            Backend::Ash(e) => e.create_output_image(width, height).map_err(err),
        }
    }

    /// The texels of a texture made by [`Self::create_output_texture`], after the work recorded
    /// so far, as a fetch of R32F returns them.
    pub fn read_texture(
        &mut self,
        id: BufferId,
        width: u32,
        height: u32,
    ) -> Result<Vec<Texel>, BackendError> {
        let texels = width as usize * height as usize;
        let values: Vec<f32> = match self {
            Backend::Cpu(e) => {
                let mut out = vec![[0.0f32; 4]; texels];
                e.read_buffer(id, bytemuck::cast_slice_mut(&mut out))
                    .map_err(err)?;
                out.iter().map(|t| t[0]).collect()
            }
            Backend::Wgpu(e) => {
                let mut out = vec![0.0f32; texels];
                e.read_texture(id, bytemuck::cast_slice_mut(&mut out))
                    .map_err(err)?;
                out
            }
            Backend::Ash(e) => {
                let mut out = vec![0.0f32; texels];
                e.read_image(id, bytemuck::cast_slice_mut(&mut out))
                    .map_err(err)?;
                out
            }
        };
        Ok(values.into_iter().map(|v| [v, 0.0, 0.0, 1.0]).collect())
    }
}

fn extent(width: u32, height: u32) -> wgpu::Extent3d {
    wgpu::Extent3d {
        width,
        height,
        depth_or_array_layers: 1,
    }
}
