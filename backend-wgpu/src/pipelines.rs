//! Compute pipelines: the embedded SPIR-V module (loaded once, on first use) and one pipeline
//! with its bind group layout per kernel entry point, created on first use and cached. Layouts
//! follow the kernel's bindings (read-only storage unless the kernel may write the buffer; a
//! sampled texture where it reads the engine's).

use std::borrow::Cow;

use crate::{WgpuError, WgpuExecutor, SPIRV};
use vrrt_core::executor::{Access, KernelDesc};

/// A cached pipeline with its bind group layout.
pub(crate) struct Kernel {
    pub(crate) pipeline: wgpu::ComputePipeline,
    pub(crate) layout: wgpu::BindGroupLayout,
}

impl WgpuExecutor {
    fn module(&mut self) -> Result<&wgpu::ShaderModule, WgpuError> {
        if self.module.is_none() {
            let words = spirv_words(SPIRV)?;
            let module = self.scoped(|| {
                self.device
                    .create_shader_module(wgpu::ShaderModuleDescriptor {
                        label: Some("vrrt.spv"),
                        source: wgpu::ShaderSource::SpirV(Cow::Owned(words)),
                    })
            })?;
            self.module = Some(module);
        }
        Ok(self.module.as_ref().expect("just created"))
    }

    /// Creates the pipeline of `desc` unless it is cached.
    pub(crate) fn ensure_kernel(&mut self, desc: &'static KernelDesc) -> Result<(), WgpuError> {
        if self.kernels.contains_key(desc.entry) {
            return Ok(());
        }
        let max = self.device.limits().max_immediate_size;
        if !desc.params_size.is_multiple_of(4) || desc.params_size > max {
            return Err(WgpuError::Limit(format!(
                "kernel `{}` takes {} bytes of immediates; the device allows {max} (multiples of 4)",
                desc.entry, desc.params_size
            )));
        }
        let module = self.module()?.clone();
        let entries: Vec<wgpu::BindGroupLayoutEntry> = desc
            .bindings
            .iter()
            .enumerate()
            .map(|(i, binding)| wgpu::BindGroupLayoutEntry {
                binding: i as u32,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: match binding.access {
                    Access::Sampled => wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    Access::Storage => wgpu::BindingType::StorageTexture {
                        // rust-gpu declares storage images readable.
                        access: wgpu::StorageTextureAccess::ReadWrite,
                        format: crate::textures::OUTPUT_FORMAT,
                        view_dimension: wgpu::TextureViewDimension::D2,
                    },
                    _ => wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage {
                            read_only: !binding.access.writes(),
                        },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                },
                count: None,
            })
            .collect();
        let kernel = self.scoped(|| {
            let layout = self
                .device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some(desc.entry),
                    entries: &entries,
                });
            let pipeline_layout =
                self.device
                    .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                        label: Some(desc.entry),
                        bind_group_layouts: &[Some(&layout)],
                        immediate_size: desc.params_size,
                    });
            let pipeline = self
                .device
                .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(desc.entry),
                    layout: Some(&pipeline_layout),
                    module: &module,
                    entry_point: Some(desc.entry),
                    compilation_options: Default::default(),
                    cache: None,
                });
            Kernel { pipeline, layout }
        })?;
        self.kernels.insert(desc.entry, kernel);
        Ok(())
    }
}

/// SPIR-V bytes as words, in native byte order.
fn spirv_words(bytes: &[u8]) -> Result<Vec<u32>, WgpuError> {
    const MAGIC: u32 = 0x0723_0203;
    if !bytes.len().is_multiple_of(4) || bytes.len() < 20 {
        return Err(WgpuError::InvalidSpirv(format!("{} bytes", bytes.len())));
    }
    let mut words: Vec<u32> = bytemuck::pod_collect_to_vec(bytes);
    if words[0] == MAGIC.swap_bytes() {
        words.iter_mut().for_each(|w| *w = w.swap_bytes());
    }
    if words[0] != MAGIC {
        return Err(WgpuError::InvalidSpirv(format!(
            "magic number {:#010x}",
            words[0]
        )));
    }
    Ok(words)
}
