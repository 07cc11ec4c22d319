//! Per-submission transient resources: descriptor sets and timestamp queries. An arena is used by
//! one command buffer's worth of passes and reset once that work has completed.

use crate::AshError;
use ash::vk;
use vrrt_core::executor::{BufferId, PassTiming};

const SETS_PER_POOL: u32 = 64;
const DESCRIPTORS_PER_SET: u32 = 8;
const QUERIES_PER_POOL: u32 = 128;

/// How timestamps of this queue family are converted.
#[derive(Copy, Clone, Debug)]
pub(crate) struct Timestamps {
    /// Nanoseconds per tick.
    pub period_ns: f32,
    /// Mask of valid bits.
    pub mask: u64,
}

struct DescriptorPool {
    pool: vk::DescriptorPool,
    descriptors: u32,
}

/// Descriptor pools and query pools of one submission.
#[derive(Default)]
pub(crate) struct Arena {
    desc_pools: Vec<DescriptorPool>,
    /// Next pool of `desc_pools` to take into use.
    next_pool: usize,
    /// Pool in use, sets and descriptors left in it.
    current: Option<(vk::DescriptorPool, u32, u32)>,
    query_pools: Vec<vk::QueryPool>,
    queries_used: u32,
    /// Entry point and first query of every timed pass.
    passes: Vec<(&'static str, u32)>,
    /// Buffers the recorded passes use (tracked for external recordings).
    pub buffers: Vec<BufferId>,
}

impl Arena {
    /// Allocates a descriptor set of `layout`, which has `bindings` storage-buffer bindings.
    pub fn descriptor_set(
        &mut self,
        device: &ash::Device,
        layout: vk::DescriptorSetLayout,
        bindings: u32,
    ) -> Result<vk::DescriptorSet, AshError> {
        let fits = matches!(self.current, Some((_, sets, descs)) if sets > 0 && descs >= bindings);
        if !fits {
            let need = bindings.max(1);
            if self
                .desc_pools
                .get(self.next_pool)
                .is_some_and(|p| p.descriptors < need)
            {
                // Kept pools are too small for this layout: put a fresh pool in this place.
                self.create_pool(device, need)?;
            } else if self.next_pool >= self.desc_pools.len() {
                self.create_pool(device, need)?;
            }
            let p = &self.desc_pools[self.next_pool];
            self.current = Some((p.pool, SETS_PER_POOL, p.descriptors));
            self.next_pool += 1;
        }
        let Some((pool, sets, descs)) = self.current.as_mut() else {
            unreachable!()
        };
        let layouts = [layout];
        let info = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(*pool)
            .set_layouts(&layouts);
        // SAFETY: pool has room for the set (counted above); layout is alive.
        let set = unsafe { device.allocate_descriptor_sets(&info) }
            .map_err(AshError::vk("vkAllocateDescriptorSets"))?[0];
        *sets -= 1;
        *descs -= bindings;
        Ok(set)
    }

    fn create_pool(&mut self, device: &ash::Device, bindings: u32) -> Result<(), AshError> {
        let descriptors = SETS_PER_POOL * bindings.max(DESCRIPTORS_PER_SET);
        // Any kind may fill a set: a pool holds enough of each.
        let sizes = [
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::STORAGE_BUFFER,
                descriptor_count: descriptors,
            },
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::SAMPLED_IMAGE,
                descriptor_count: descriptors,
            },
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::STORAGE_IMAGE,
                descriptor_count: descriptors,
            },
        ];
        let info = vk::DescriptorPoolCreateInfo::default()
            .max_sets(SETS_PER_POOL)
            .pool_sizes(&sizes);
        // SAFETY: valid create info.
        let pool = unsafe { device.create_descriptor_pool(&info, None) }
            .map_err(AshError::vk("vkCreateDescriptorPool"))?;
        self.desc_pools
            .insert(self.next_pool, DescriptorPool { pool, descriptors });
        Ok(())
    }

    /// Two timestamp queries for a pass of `entry`; records a reset of the query pool into `cmd`
    /// when a pool is first used in this arena's submission.
    pub fn timestamp_pair(
        &mut self,
        device: &ash::Device,
        cmd: vk::CommandBuffer,
        entry: &'static str,
    ) -> Result<(vk::QueryPool, u32), AshError> {
        let pool_index = (self.queries_used / QUERIES_PER_POOL) as usize;
        let first = self.queries_used % QUERIES_PER_POOL;
        if pool_index == self.query_pools.len() {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(QUERIES_PER_POOL);
            // SAFETY: valid create info.
            let pool = unsafe { device.create_query_pool(&info, None) }
                .map_err(AshError::vk("vkCreateQueryPool"))?;
            self.query_pools.push(pool);
        }
        let pool = self.query_pools[pool_index];
        if first == 0 {
            // SAFETY: `cmd` is recording (caller); the pool's earlier use has completed.
            unsafe { device.cmd_reset_query_pool(cmd, pool, 0, QUERIES_PER_POOL) };
        }
        self.passes.push((entry, self.queries_used));
        self.queries_used += 2;
        Ok((pool, first))
    }

    /// Appends the timings of the timed passes to `out`. With `wait`, waits for the results;
    /// without, returns `false` (appending nothing) if some are not available.
    pub fn collect_timings(
        &self,
        device: &ash::Device,
        ts: Timestamps,
        wait: bool,
        out: &mut Vec<PassTiming>,
    ) -> Result<bool, AshError> {
        if self.queries_used == 0 {
            return Ok(true);
        }
        let mut ticks = vec![0u64; self.queries_used as usize];
        let flags = vk::QueryResultFlags::TYPE_64
            | if wait {
                vk::QueryResultFlags::WAIT
            } else {
                vk::QueryResultFlags::empty()
            };
        for (k, chunk) in ticks.chunks_mut(QUERIES_PER_POOL as usize).enumerate() {
            // SAFETY: queries 0..chunk.len() of this pool were reset and written by this arena.
            match unsafe { device.get_query_pool_results(self.query_pools[k], 0, chunk, flags) } {
                Ok(()) => {}
                Err(vk::Result::NOT_READY) if !wait => return Ok(false),
                Err(e) => return Err(AshError::vk("vkGetQueryPoolResults")(e)),
            }
        }
        out.extend(self.passes.iter().map(|&(entry, q)| {
            let (begin, end) = (ticks[q as usize], ticks[q as usize + 1]);
            let delta = end.wrapping_sub(begin) & ts.mask;
            PassTiming {
                entry,
                ms: delta as f64 * f64::from(ts.period_ns) * 1e-6,
            }
        }));
        Ok(true)
    }

    /// Frees every descriptor set and query for reuse (the submission has completed).
    pub fn reset(&mut self, device: &ash::Device) -> Result<(), AshError> {
        for p in &self.desc_pools[..self.next_pool.min(self.desc_pools.len())] {
            // SAFETY: no pending work uses the sets (caller's contract).
            unsafe { device.reset_descriptor_pool(p.pool, vk::DescriptorPoolResetFlags::empty()) }
                .map_err(AshError::vk("vkResetDescriptorPool"))?;
        }
        self.next_pool = 0;
        self.current = None;
        self.queries_used = 0;
        self.passes.clear();
        self.buffers.clear();
        Ok(())
    }

    /// Destroys the pools.
    ///
    /// # Safety
    /// No pending work may use them.
    pub unsafe fn destroy(&mut self, device: &ash::Device) {
        // SAFETY: caller's contract.
        unsafe {
            for p in self.desc_pools.drain(..) {
                device.destroy_descriptor_pool(p.pool, None);
            }
            for q in self.query_pools.drain(..) {
                device.destroy_query_pool(q, None);
            }
        }
        self.next_pool = 0;
        self.current = None;
        self.queries_used = 0;
        self.passes.clear();
        self.buffers.clear();
    }
}
