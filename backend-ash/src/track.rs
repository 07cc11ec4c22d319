//! Per-buffer hazard tracking: decides which buffer memory barriers to insert before a command.
//!
//! Each buffer remembers its last write that later commands have not yet been synchronized with
//! (stage and access), which stages it was already made visible to, and which stages read it
//! since. A command that reads needs a barrier only if the pending write is not yet visible to its
//! stage/access (read-after-write); a command that writes needs one after any pending write
//! (write-after-write) or any read since (write-after-read, execution dependency only).

use ash::vk;

/// Synchronization state of one buffer.
#[derive(Copy, Clone, Debug, Default)]
pub(crate) struct Hazard {
    write_stages: vk::PipelineStageFlags,
    write_access: vk::AccessFlags,
    visible_stages: vk::PipelineStageFlags,
    visible_access: vk::AccessFlags,
    read_stages: vk::PipelineStageFlags,
}

const WRITE_ACCESS: vk::AccessFlags = vk::AccessFlags::from_raw(
    vk::AccessFlags::SHADER_WRITE.as_raw()
        | vk::AccessFlags::TRANSFER_WRITE.as_raw()
        | vk::AccessFlags::HOST_WRITE.as_raw()
        | vk::AccessFlags::MEMORY_WRITE.as_raw(),
);

impl Hazard {
    /// Registers an access; returns `(src_stage, src_access)` of the barrier needed before it.
    pub fn access(
        &mut self,
        stage: vk::PipelineStageFlags,
        access: vk::AccessFlags,
    ) -> Option<(vk::PipelineStageFlags, vk::AccessFlags)> {
        let write = access.intersects(WRITE_ACCESS);
        let mut src_stage = vk::PipelineStageFlags::empty();
        let mut src_access = vk::AccessFlags::empty();
        if !self.write_stages.is_empty() {
            let covered = !write
                && self.visible_stages.contains(stage)
                && self.visible_access.contains(access);
            if !covered {
                src_stage |= self.write_stages;
                src_access |= self.write_access;
            }
        }
        if write {
            src_stage |= self.read_stages;
        }
        let barrier = (!src_stage.is_empty()).then_some((src_stage, src_access));
        if write {
            *self = Hazard {
                write_stages: stage,
                write_access: access & WRITE_ACCESS,
                ..Hazard::default()
            };
        } else {
            self.read_stages |= stage;
            if barrier.is_some() {
                self.visible_stages |= stage;
                self.visible_access |= access;
            }
        }
        barrier
    }
}

/// Barriers collected for one command, emitted as one `vkCmdPipelineBarrier`.
#[derive(Default)]
pub(crate) struct BarrierBatch {
    src: vk::PipelineStageFlags,
    dst: vk::PipelineStageFlags,
    barriers: Vec<vk::BufferMemoryBarrier<'static>>,
}

impl BarrierBatch {
    /// Registers `access` at `stage` of `buffer` (tracked by `hazard`), adding a barrier if needed.
    pub fn access(
        &mut self,
        hazard: &mut Hazard,
        buffer: vk::Buffer,
        stage: vk::PipelineStageFlags,
        access: vk::AccessFlags,
    ) {
        if let Some((src_stage, src_access)) = hazard.access(stage, access) {
            self.push(buffer, src_stage, src_access, stage, access);
        }
    }

    /// Adds an explicit barrier.
    pub fn push(
        &mut self,
        buffer: vk::Buffer,
        src_stage: vk::PipelineStageFlags,
        src_access: vk::AccessFlags,
        dst_stage: vk::PipelineStageFlags,
        dst_access: vk::AccessFlags,
    ) {
        self.src |= src_stage;
        self.dst |= dst_stage;
        self.barriers.push(
            vk::BufferMemoryBarrier::default()
                .src_access_mask(src_access)
                .dst_access_mask(dst_access)
                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .buffer(buffer)
                .offset(0)
                .size(vk::WHOLE_SIZE),
        );
    }

    /// Records the barriers (if any) into `cmd`.
    ///
    /// # Safety
    /// `cmd` must be in the recording state; the buffers must be alive.
    pub unsafe fn emit(self, device: &ash::Device, cmd: vk::CommandBuffer) {
        if self.barriers.is_empty() {
            return;
        }
        // SAFETY: caller's contract.
        unsafe {
            device.cmd_pipeline_barrier(
                cmd,
                self.src,
                self.dst,
                vk::DependencyFlags::empty(),
                &[],
                &self.barriers,
                &[],
            )
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    const CS: vk::PipelineStageFlags = vk::PipelineStageFlags::COMPUTE_SHADER;
    const R: vk::AccessFlags = vk::AccessFlags::SHADER_READ;
    const W: vk::AccessFlags = vk::AccessFlags::SHADER_WRITE;

    #[test]
    fn read_after_write_once() {
        let mut h = Hazard::default();
        assert!(h.access(CS, R).is_none(), "fresh buffer needs no barrier");
        assert_eq!(
            h.access(CS, R | W),
            Some((CS, vk::AccessFlags::empty())),
            "write after read"
        );
        assert_eq!(h.access(CS, R), Some((CS, W)), "read after write");
        assert!(h.access(CS, R).is_none(), "already visible");
        assert_eq!(
            h.access(
                vk::PipelineStageFlags::DRAW_INDIRECT,
                vk::AccessFlags::INDIRECT_COMMAND_READ
            ),
            Some((CS, W)),
            "visible to compute is not visible to indirect"
        );
        assert_eq!(
            h.access(CS, R | W).map(|b| b.0),
            Some(CS | vk::PipelineStageFlags::DRAW_INDIRECT)
        );
        assert_eq!(h.access(CS, R | W), Some((CS, W)), "write after write");
    }
}
