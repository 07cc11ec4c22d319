//! One pass, from check to commands: [`AshExecutor::prepare`] runs every check before anything
//! is recorded (so a bad pass leaves the command buffer untouched), [`AshExecutor::emit_pass`]
//! records the barriers its buffers need, its descriptor set, push constants, dispatch and
//! timestamps. Used for the executor's own stream and for engines' command buffers alike.

use crate::arena::Arena;
use crate::pipelines::{descriptor_type, Pipeline};
use crate::track::BarrierBatch;
use crate::{AshError, AshExecutor};
use ash::vk;
use vrrt_core::executor::{Access, Groups, Pass};

impl AshExecutor {
    /// Checks a pass against its kernel, the buffers ([`Pass::check`], shared by every backend)
    /// and the device limits, and creates its pipeline if needed. Records nothing.
    pub(crate) fn prepare(&mut self, pass: &Pass<'_>) -> Result<Pipeline, AshError> {
        pass.check(
            |id| match self.texture(id) {
                Some(t) => Some(t.bytes),
                None => self.entry(id).ok().map(|e| e.size),
            },
            |id| self.texture(id).is_some(),
        )?;
        for (&id, binding) in pass.buffers.iter().zip(pass.kernel.bindings) {
            if let Some(t) = self.texture(id) {
                if binding.access == Access::Storage && t.layout != vk::ImageLayout::GENERAL {
                    return Err(AshError::Texture(format!(
                        "{id:?} is written by `{}` but is in layout {:?}, not GENERAL",
                        binding.name, t.layout
                    )));
                }
                continue;
            }
            let e = self.entry(id)?;
            if e.vk_size > u64::from(self.max_storage_range) {
                return Err(AshError::BindingTooLarge {
                    buffer: id,
                    size: e.size,
                    max: self.max_storage_range,
                });
            }
        }
        if let Groups::Direct(groups) = pass.groups {
            if groups.iter().zip(self.max_groups).any(|(&g, m)| g > m) {
                return Err(AshError::TooManyGroups {
                    entry: pass.kernel.entry,
                    groups,
                    max: self.max_groups,
                });
            }
        }
        self.pipeline(pass.kernel)
    }

    /// Records a prepared pass into `cmd`, with the barriers its buffers need, using descriptor
    /// sets and queries of `arena`.
    pub(crate) fn emit_pass(
        &mut self,
        cmd: vk::CommandBuffer,
        arena: &mut Arena,
        pass: &Pass<'_>,
        p: Pipeline,
    ) -> Result<(), AshError> {
        let kernel = pass.kernel;
        // Allocate first: a failure then leaves nothing half-recorded.
        let set = if p.set_layout != vk::DescriptorSetLayout::null() {
            Some(arena.descriptor_set(&self.device, p.set_layout, kernel.bindings.len() as u32)?)
        } else {
            None
        };
        let queries = match self.timestamps {
            Some(_) => Some(arena.timestamp_pair(&self.device, cmd, kernel.entry)?),
            None => None,
        };

        let mut batch = BarrierBatch::default();
        if let Groups::Indirect { buffer, .. } = pass.groups {
            let e = self.entry_mut(buffer)?;
            batch.access(
                &mut e.hazard,
                e.buffer,
                vk::PipelineStageFlags::DRAW_INDIRECT,
                vk::AccessFlags::INDIRECT_COMMAND_READ,
            );
            arena.buffers.push(buffer);
        }
        let mut infos = Vec::with_capacity(pass.buffers.len());
        for (&id, binding) in pass.buffers.iter().zip(kernel.bindings) {
            if let Some(t) = self.texture(id) {
                // The engine keeps its images' layouts and synchronises its own accesses (see
                // `import_image`); the executor's own images were left ready for shader access.
                let info = vk::DescriptorImageInfo {
                    sampler: vk::Sampler::null(),
                    image_view: t.view,
                    image_layout: t.layout,
                };
                infos.push(Descriptor::Image(descriptor_type(binding.access), info));
                continue;
            }
            let e = self.entry_mut(id)?;
            let flags = if binding.access.writes() {
                vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE
            } else {
                vk::AccessFlags::SHADER_READ
            };
            batch.access(
                &mut e.hazard,
                e.buffer,
                vk::PipelineStageFlags::COMPUTE_SHADER,
                flags,
            );
            infos.push(Descriptor::Buffer(vk::DescriptorBufferInfo {
                buffer: e.buffer,
                offset: 0,
                range: e.vk_size,
            }));
            arena.buffers.push(id);
        }

        let d = &self.device;
        // SAFETY: `cmd` is recording (caller); every handle is alive; the set is not in use.
        unsafe {
            if let Some(set) = set {
                write_set(d, set, &infos);
            }
            batch.emit(d, cmd);
            if let Some((pool, q)) = queries {
                d.cmd_write_timestamp(cmd, vk::PipelineStageFlags::COMPUTE_SHADER, pool, q);
            }
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, p.pipeline);
            if let Some(set) = set {
                d.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::COMPUTE,
                    p.layout,
                    0,
                    &[set],
                    &[],
                );
            }
            if p.push_size > 0 {
                let mut bytes = pass.params.to_vec();
                bytes.resize(p.push_size as usize, 0);
                d.cmd_push_constants(cmd, p.layout, vk::ShaderStageFlags::COMPUTE, 0, &bytes);
            }
            match pass.groups {
                Groups::Direct([x, y, z]) => d.cmd_dispatch(cmd, x, y, z),
                Groups::Indirect { buffer, offset } => {
                    d.cmd_dispatch_indirect(cmd, self.entry(buffer)?.buffer, offset)
                }
            }
            if let Some((pool, q)) = queries {
                d.cmd_write_timestamp(cmd, vk::PipelineStageFlags::COMPUTE_SHADER, pool, q + 1);
            }
        }
        Ok(())
    }
}

/// Writes `infos` to `set`, binding `i` from `infos[i]`.
///
/// # Safety
/// `set` and every handle in `infos` are alive, and `set` is not in use.
unsafe fn write_set(d: &ash::Device, set: vk::DescriptorSet, infos: &[Descriptor]) {
    let writes: Vec<vk::WriteDescriptorSet<'_>> = infos
        .iter()
        .enumerate()
        .map(|(i, info)| {
            let write = vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(i as u32);
            match info {
                Descriptor::Buffer(b) => write
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .buffer_info(std::slice::from_ref(b)),
                Descriptor::Image(ty, image) => write
                    .descriptor_type(*ty)
                    .image_info(std::slice::from_ref(image)),
            }
        })
        .collect();
    // SAFETY: caller's contract.
    unsafe { d.update_descriptor_sets(&writes, &[]) };
}

/// One binding's descriptor.
enum Descriptor {
    Buffer(vk::DescriptorBufferInfo),
    Image(vk::DescriptorType, vk::DescriptorImageInfo),
}
