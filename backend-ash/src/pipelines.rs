//! Compute pipelines: one per kernel entry point of the embedded module, created on first use
//! and cached until the executor is dropped. Descriptor set 0 holds one storage buffer (or, where
//! the kernel reads an engine texture, one sampled image) per binding, in order; one push-constant range of `params_size` bytes (rounded up to 4; none if 0).

use crate::{AshError, AshExecutor};
use ash::vk;
use std::ffi::CString;
use vrrt_core::executor::{Access, KernelDesc};

#[derive(Copy, Clone)]
/// A kernel's compute pipeline and layouts.
pub(crate) struct Pipeline {
    pub(crate) pipeline: vk::Pipeline,
    pub(crate) layout: vk::PipelineLayout,
    /// Null if the kernel has no bindings.
    pub(crate) set_layout: vk::DescriptorSetLayout,
    /// Push-constant bytes (params rounded up to 4), 0 if none.
    pub(crate) push_size: u32,
}

impl AshExecutor {
    /// The cached pipeline of `kernel`, created on first use.
    pub(crate) fn pipeline(&mut self, kernel: &'static KernelDesc) -> Result<Pipeline, AshError> {
        if let Some(p) = self.pipelines.get(kernel.entry) {
            return Ok(*p);
        }
        if !self
            .module_info
            .entry_points
            .iter()
            .any(|e| e == kernel.entry)
        {
            return Err(AshError::MissingEntryPoint(kernel.entry));
        }
        let name =
            CString::new(kernel.entry).map_err(|_| AshError::MissingEntryPoint(kernel.entry))?;
        let d = &self.device;
        let bindings: Vec<vk::DescriptorSetLayoutBinding<'_>> = (0..kernel.bindings.len() as u32)
            .map(|i| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i)
                    .descriptor_type(descriptor_type(kernel.bindings[i as usize].access))
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        let push_size = kernel.params_size.next_multiple_of(4);
        let mut p = Pipeline {
            pipeline: vk::Pipeline::null(),
            layout: vk::PipelineLayout::null(),
            set_layout: vk::DescriptorSetLayout::null(),
            push_size,
        };
        let destroy = |p: &Pipeline| {
            // SAFETY: objects just created, unused; null handles are ignored.
            unsafe {
                d.destroy_pipeline_layout(p.layout, None);
                d.destroy_descriptor_set_layout(p.set_layout, None);
            }
        };
        // SAFETY: valid create infos; on failure, objects created so far are destroyed.
        unsafe {
            if !bindings.is_empty() {
                p.set_layout = d
                    .create_descriptor_set_layout(
                        &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
                        None,
                    )
                    .map_err(AshError::vk("vkCreateDescriptorSetLayout"))?;
            }
            let set_layouts: Vec<vk::DescriptorSetLayout> = if bindings.is_empty() {
                vec![]
            } else {
                vec![p.set_layout]
            };
            let ranges: Vec<vk::PushConstantRange> = if push_size > 0 {
                vec![vk::PushConstantRange {
                    stage_flags: vk::ShaderStageFlags::COMPUTE,
                    offset: 0,
                    size: push_size,
                }]
            } else {
                vec![]
            };
            let layout_info = vk::PipelineLayoutCreateInfo::default()
                .set_layouts(&set_layouts)
                .push_constant_ranges(&ranges);
            p.layout = match d.create_pipeline_layout(&layout_info, None) {
                Ok(l) => l,
                Err(e) => {
                    destroy(&p);
                    return Err(AshError::vk("vkCreatePipelineLayout")(e));
                }
            };
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(self.module)
                .name(&name);
            let info = vk::ComputePipelineCreateInfo::default()
                .stage(stage)
                .layout(p.layout);
            p.pipeline = match d.create_compute_pipelines(vk::PipelineCache::null(), &[info], None)
            {
                Ok(v) => v[0],
                Err((_, e)) => {
                    destroy(&p);
                    return Err(AshError::vk("vkCreateComputePipelines")(e));
                }
            };
        }
        self.pipelines.insert(kernel.entry, p);
        Ok(p)
    }
}

/// The descriptor type of a binding: a sampled image where the kernel reads an engine texture, a
/// storage image where it writes one, else a storage buffer.
pub(crate) fn descriptor_type(access: Access) -> vk::DescriptorType {
    match access {
        Access::Sampled => vk::DescriptorType::SAMPLED_IMAGE,
        Access::Storage => vk::DescriptorType::STORAGE_IMAGE,
        _ => vk::DescriptorType::STORAGE_BUFFER,
    }
}
