//! # vrrt-ash
//!
//! The raw-Vulkan backend of VRRT-rs, on [`ash`]. It runs the kernels of `vrrt-core` from the one
//! SPIR-V module built by rust-gpu (`shaders/vrrt.spv`, embedded at compile time), either on a
//! device it creates itself ([`AshExecutor::new_headless`]) or inside an engine's device
//! ([`AshExecutor::from_raw`] + [`AshExecutor::record_into`]).
//!
//! ## What it does with Vulkan
//! - **Buffers**: device-local storage buffers (usage `STORAGE | TRANSFER_SRC | TRANSFER_DST |
//!   INDIRECT`), one memory allocation each, zero-filled at creation with `vkCmdFillBuffer`.
//!   Uploads go through a host-visible staging ring, readbacks through a host-visible (preferably
//!   host-cached) buffer; both use host-coherent memory.
//! - **Pipelines**: one compute pipeline per [`KernelDesc::entry`], created on first use and
//!   cached; descriptor set 0 holds one storage buffer per binding, in order; one push-constant
//!   range of `params_size` bytes (none if 0).
//! - **Recording**: everything (fills, uploads, dispatches, readback copies) is recorded, in call
//!   order, into one command buffer that is submitted by [`Executor::finish`] /
//!   [`Executor::read_buffer`] (or [`AshExecutor::flush`]) and waited on with a fence. Descriptor
//!   sets come from pools that are reset once that submission has completed.
//! - **Synchronization**: every buffer's accesses are tracked; before a command, buffer memory
//!   barriers are inserted exactly where a hazard exists (compute→compute read-after-write,
//!   write-after-write and write-after-read; transfer↔compute around uploads and readbacks;
//!   compute→indirect for [`Groups::Indirect`]). Independent passes get no barrier.
//! - **Timestamps**: when the queue family has `timestampValidBits > 0`, each dispatch is
//!   bracketed by two timestamps (at the compute-shader stage); [`Executor::timings`] reports them
//!   in milliseconds once the work has completed.
//!
//! No per-pixel math lives here: the backend only moves bytes and launches work.

#![deny(unsafe_op_in_unsafe_fn)]

mod alloc;
mod arena;
mod error;
mod setup;
mod spirv;
mod track;

pub use ash;
pub use error::AshError;

use alloc::{Allocation, HostBuffer, Staging, STORAGE_USAGE};
use arena::{Arena, Timestamps};
use ash::vk;
use setup::{DebugState, Owned};
use spirv::ModuleInfo;
use std::collections::HashMap;
use std::ffi::CString;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use track::{BarrierBatch, Hazard};
use vrrt_core::plan::{BufferId, Executor, Groups, KernelDesc, Pass, PassTiming};

/// Options of [`AshExecutor::new_headless`].
#[derive(Clone, Debug)]
pub struct AshOptions {
    /// Enable `VK_LAYER_KHRONOS_validation` with a `VK_EXT_debug_utils` messenger that logs to
    /// stderr and counts errors (see [`AshExecutor::validation_errors`]). Construction fails if the
    /// layer is not installed. Default: `true` iff the environment has `VRRT_VALIDATION=1`.
    pub validation: bool,
    /// With `validation`, also turn on the layer's synchronization validation (hazards between
    /// commands are reported as errors) when `VK_EXT_validation_features` is available.
    /// Default: `true`.
    pub sync_validation: bool,
}

impl Default for AshOptions {
    fn default() -> Self {
        AshOptions {
            validation: std::env::var("VRRT_VALIDATION").is_ok_and(|v| v == "1"),
            sync_validation: true,
        }
    }
}

/// Kind of physical device.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum AdapterType {
    /// A discrete GPU.
    DiscreteGpu,
    /// A GPU integrated with the CPU.
    IntegratedGpu,
    /// A virtualized GPU.
    VirtualGpu,
    /// A software implementation on the CPU (e.g. lavapipe).
    Cpu,
    /// Anything else.
    Other,
}

/// The physical device an executor runs on.
#[derive(Clone, Debug, PartialEq)]
pub struct AdapterInfo {
    /// `deviceName`, e.g. `llvmpipe (LLVM 15, 256 bits)`.
    pub name: String,
    /// Kind of device.
    pub adapter_type: AdapterType,
    /// PCI vendor id.
    pub vendor_id: u32,
    /// Vendor-specific device id.
    pub device_id: u32,
    /// Vulkan version the device supports (`vk::api_version_*` to decode).
    pub api_version: u32,
    /// Vendor-specific driver version.
    pub driver_version: u32,
    /// Whether the executor's queue writes timestamps (`timestampValidBits > 0`).
    pub timestamps: bool,
    /// Nanoseconds per timestamp tick (`timestampPeriod`).
    pub timestamp_period_ns: f32,
}

/// Vulkan objects of an engine that an executor borrows (see [`AshExecutor::from_raw`]).
#[derive(Clone)]
pub struct RawVulkan {
    /// The instance the device was created from (used for physical-device queries).
    pub instance: ash::Instance,
    /// The logical device. It must have been created with Vulkan 1.2+ and the
    /// `vulkanMemoryModel` feature of `VkPhysicalDeviceVulkan12Features` enabled (rust-gpu's
    /// SPIR-V declares the `VulkanMemoryModel` capability), plus
    /// `vulkanMemoryModelDeviceScope` if the module uses device-scope atomics.
    pub device: ash::Device,
    /// The physical device of `device`.
    pub physical_device: vk::PhysicalDevice,
    /// A queue with compute support. The executor submits its own work (uploads, readbacks,
    /// dispatches not recorded with [`AshExecutor::record_into`]) to it.
    pub queue: vk::Queue,
    /// Family of `queue`; command buffers given to [`AshExecutor::record_into`] must belong to
    /// a pool of this family.
    pub queue_family_index: u32,
}

/// Passes recorded into a user command buffer by [`AshExecutor::record_into`]. Holds the
/// descriptor sets and timestamp queries that command buffer uses; hand it back to
/// [`AshExecutor::retire`] once the command buffer has finished executing.
#[must_use = "retire the recording once its command buffer has completed, or its resources leak"]
#[derive(Debug)]
pub struct Recording {
    id: u64,
    passes: usize,
}

impl Recording {
    /// Number of passes recorded.
    pub fn passes(&self) -> usize {
        self.passes
    }
}

struct BufferEntry {
    buffer: vk::Buffer,
    /// Null for imported buffers (not owned).
    memory: vk::DeviceMemory,
    /// Size the user asked for.
    size: u64,
    /// Size of the Vulkan buffer (`size`, at least 4): the descriptor range.
    vk_size: u64,
    hazard: Hazard,
}

#[derive(Copy, Clone)]
struct Pipeline {
    pipeline: vk::Pipeline,
    layout: vk::PipelineLayout,
    /// Null if the kernel has no bindings.
    set_layout: vk::DescriptorSetLayout,
    /// Push-constant bytes (params rounded up to 4), 0 if none.
    push_size: u32,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq)]
enum StreamState {
    Idle,
    Recording,
    InFlight,
}

/// The executor's own command buffer and what its submission uses.
struct Stream {
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    state: StreamState,
    arena: Arena,
}

/// Runs plans with raw Vulkan. See the [crate docs](crate).
pub struct AshExecutor {
    instance: ash::Instance,
    device: ash::Device,
    physical_device: vk::PhysicalDevice,
    queue: vk::Queue,
    queue_family_index: u32,
    info: AdapterInfo,
    mem_props: vk::PhysicalDeviceMemoryProperties,
    max_groups: [u32; 3],
    max_storage_range: u32,
    timestamps: Option<Timestamps>,
    module_info: ModuleInfo,
    module: vk::ShaderModule,
    pipelines: HashMap<&'static str, Pipeline>,
    buffers: Vec<Option<BufferEntry>>,
    stream: Stream,
    staging: Staging,
    readback: Option<HostBuffer>,
    external: HashMap<u64, Arena>,
    spare_arenas: Vec<Arena>,
    next_recording: u64,
    timings: Vec<PassTiming>,
    debug: Option<Arc<DebugState>>,
    /// Present iff the executor created the instance and device (and destroys them).
    owned: Option<Owned>,
}

impl AshExecutor {
    /// Creates its own Vulkan 1.2 instance and device on the best adapter (discrete > integrated
    /// > virtual > CPU) that has a compute queue and `vulkanMemoryModel`.
    ///
    /// Errors: [`AshError::NoAdapter`] (displays `no Vulkan adapter: …`) when the loader is missing
    /// or no device qualifies; [`AshError::ValidationUnavailable`] when validation is asked for
    /// but the layer is not installed. Never panics for lack of Vulkan.
    pub fn new_headless(options: AshOptions) -> Result<Self, AshError> {
        let module_info = spirv::parse(spirv::SPIRV)?;
        let h = setup::create(options.validation, options.sync_validation, &module_info)?;
        Self::build(
            RawVulkan {
                instance: h.instance,
                device: h.device,
                physical_device: h.physical_device,
                queue: h.queue,
                queue_family_index: h.queue_family_index,
            },
            module_info,
            Some(h.owned),
            h.debug,
        )
    }

    /// Wraps an engine's Vulkan objects. The executor never destroys them; it creates (and on
    /// drop destroys) only its own objects: shader module, pipelines, descriptor and query pools,
    /// a command pool, a fence, and the buffers it allocates.
    ///
    /// # Safety
    /// - All handles are valid, belong together, and outlive the executor.
    /// - `raw.device` was created with Vulkan 1.2+ and `vulkanMemoryModel` enabled (see
    ///   [`RawVulkan::device`]).
    /// - The queue is externally synchronized: nothing else may use it while a method of the
    ///   executor that submits ([`Executor::finish`], [`Executor::read_buffer`],
    ///   [`AshExecutor::flush`], [`AshExecutor::record_into`], [`AshExecutor::destroy_buffer`])
    ///   runs.
    /// - Before dropping the executor, every command buffer recorded with
    ///   [`AshExecutor::record_into`] has completed or been discarded.
    ///
    /// Validation messages go to the engine's own messenger: [`AshExecutor::validation_errors`]
    /// is always 0 here.
    pub unsafe fn from_raw(raw: RawVulkan) -> Result<Self, AshError> {
        let module_info = spirv::parse(spirv::SPIRV)?;
        Self::build(raw, module_info, None, None)
    }

    fn build(
        raw: RawVulkan,
        module_info: ModuleInfo,
        owned: Option<Owned>,
        debug: Option<Arc<DebugState>>,
    ) -> Result<Self, AshError> {
        let (mut info, limits) = setup::adapter_info(&raw.instance, raw.physical_device);
        // SAFETY: valid physical device (caller's contract).
        let (mem_props, families) = unsafe {
            (
                raw.instance
                    .get_physical_device_memory_properties(raw.physical_device),
                raw.instance
                    .get_physical_device_queue_family_properties(raw.physical_device),
            )
        };
        let bits = families
            .get(raw.queue_family_index as usize)
            .map_or(0, |f| f.timestamp_valid_bits);
        let timestamps = (bits > 0 && limits.timestamp_period > 0.0).then(|| Timestamps {
            period_ns: limits.timestamp_period,
            mask: if bits >= 64 {
                u64::MAX
            } else {
                (1u64 << bits) - 1
            },
        });
        info.timestamps = timestamps.is_some();
        // From here on, Drop cleans up whatever was created.
        let mut ex = AshExecutor {
            instance: raw.instance,
            device: raw.device,
            physical_device: raw.physical_device,
            queue: raw.queue,
            queue_family_index: raw.queue_family_index,
            info,
            mem_props,
            max_groups: limits.max_compute_work_group_count,
            max_storage_range: limits.max_storage_buffer_range,
            timestamps,
            module_info,
            module: vk::ShaderModule::null(),
            pipelines: HashMap::new(),
            buffers: Vec::new(),
            stream: Stream {
                pool: vk::CommandPool::null(),
                cmd: vk::CommandBuffer::null(),
                fence: vk::Fence::null(),
                state: StreamState::Idle,
                arena: Arena::default(),
            },
            staging: Staging::default(),
            readback: None,
            external: HashMap::new(),
            spare_arenas: Vec::new(),
            next_recording: 0,
            timings: Vec::new(),
            debug,
            owned,
        };
        let d = &ex.device;
        let module_create = vk::ShaderModuleCreateInfo::default().code(&ex.module_info.words);
        // SAFETY: valid device; the words are a parsed SPIR-V module.
        unsafe {
            ex.module = d
                .create_shader_module(&module_create, None)
                .map_err(AshError::vk("vkCreateShaderModule"))?;
            ex.stream.pool = d
                .create_command_pool(
                    &vk::CommandPoolCreateInfo::default()
                        .queue_family_index(ex.queue_family_index)
                        .flags(vk::CommandPoolCreateFlags::TRANSIENT),
                    None,
                )
                .map_err(AshError::vk("vkCreateCommandPool"))?;
            ex.stream.cmd = d
                .allocate_command_buffers(
                    &vk::CommandBufferAllocateInfo::default()
                        .command_pool(ex.stream.pool)
                        .level(vk::CommandBufferLevel::PRIMARY)
                        .command_buffer_count(1),
                )
                .map_err(AshError::vk("vkAllocateCommandBuffers"))?[0];
            ex.stream.fence = d
                .create_fence(&vk::FenceCreateInfo::default(), None)
                .map_err(AshError::vk("vkCreateFence"))?;
        }
        Ok(ex)
    }

    /// The adapter this executor runs on.
    pub fn adapter_info(&self) -> &AdapterInfo {
        &self.info
    }

    /// Validation errors (ERROR-severity messages, and WARNING-severity messages of the
    /// VALIDATION type) reported so far; 0 when validation is off or the device is borrowed.
    pub fn validation_errors(&self) -> u32 {
        self.debug
            .as_ref()
            .map_or(0, |d| d.errors.load(Ordering::Relaxed))
    }

    /// Whether this executor created its instance with the validation layer and counts its
    /// messages.
    pub fn validation_enabled(&self) -> bool {
        self.debug.is_some()
    }

    /// The instance (owned or borrowed).
    pub fn instance(&self) -> &ash::Instance {
        &self.instance
    }

    /// The logical device (owned or borrowed).
    pub fn device(&self) -> &ash::Device {
        &self.device
    }

    /// The physical device.
    pub fn physical_device(&self) -> vk::PhysicalDevice {
        self.physical_device
    }

    /// The queue the executor submits to.
    pub fn queue(&self) -> vk::Queue {
        self.queue
    }

    /// Family of [`AshExecutor::queue`].
    pub fn queue_family_index(&self) -> u32 {
        self.queue_family_index
    }

    fn entry(&self, id: BufferId) -> Result<&BufferEntry, AshError> {
        self.buffers
            .get(id.0 as usize)
            .and_then(Option::as_ref)
            .ok_or(AshError::UnknownBuffer(id))
    }

    fn entry_mut(&mut self, id: BufferId) -> Result<&mut BufferEntry, AshError> {
        self.buffers
            .get_mut(id.0 as usize)
            .and_then(Option::as_mut)
            .ok_or(AshError::UnknownBuffer(id))
    }

    /// The Vulkan buffer behind `id`, to bind in the engine's own passes. Its size is
    /// [`AshExecutor::buffer_size`] (at least 4 bytes in Vulkan).
    pub fn raw_buffer(&self, id: BufferId) -> Result<vk::Buffer, AshError> {
        Ok(self.entry(id)?.buffer)
    }

    /// Size in bytes of buffer `id`, as created or imported.
    pub fn buffer_size(&self, id: BufferId) -> Result<u64, AshError> {
        Ok(self.entry(id)?.size)
    }

    /// Wraps an engine's buffer so passes can bind it. The executor never destroys it.
    ///
    /// Its first `size_bytes` bytes (a nonzero multiple of 4) are the binding. The executor
    /// assumes the engine has already synchronized earlier accesses to it with the compute-shader
    /// stage (see [`AshExecutor::record_into`]).
    ///
    /// # Safety
    /// `buffer` belongs to this executor's device, is at least `size_bytes` long, is bound to
    /// memory, and outlives its use (until [`AshExecutor::destroy_buffer`] or the executor's
    /// drop). It must have usage `STORAGE_BUFFER`, plus `TRANSFER_DST` to be written with
    /// [`Executor::write_buffer`], `TRANSFER_SRC` to be read with [`Executor::read_buffer`], and
    /// `INDIRECT_BUFFER` to hold [`Groups::Indirect`] counts.
    pub unsafe fn import_buffer(
        &mut self,
        buffer: vk::Buffer,
        size_bytes: u64,
    ) -> Result<BufferId, AshError> {
        if !size_bytes.is_multiple_of(4) || size_bytes == 0 {
            return Err(AshError::UnalignedSize(size_bytes));
        }
        self.buffers.push(Some(BufferEntry {
            buffer,
            memory: vk::DeviceMemory::null(),
            size: size_bytes,
            vk_size: size_bytes,
            hazard: Hazard::default(),
        }));
        Ok(BufferId(self.buffers.len() as u32 - 1))
    }

    /// Destroys a buffer the executor created (imported buffers are only forgotten). Waits for
    /// the executor's own pending work first. The id becomes invalid.
    ///
    /// Fails with [`AshError::BufferInUse`] if a [`Recording`] that uses it was not retired.
    pub fn destroy_buffer(&mut self, id: BufferId) -> Result<(), AshError> {
        self.entry(id)?;
        if self.external.values().any(|a| a.buffers.contains(&id)) {
            return Err(AshError::BufferInUse(id));
        }
        if self.stream.state != StreamState::Idle {
            self.finish()?;
        }
        if let Some(e) = self.buffers[id.0 as usize].take() {
            if e.memory != vk::DeviceMemory::null() {
                // SAFETY: no pending work uses it (stream idle, no unretired recording).
                unsafe {
                    Allocation {
                        buffer: e.buffer,
                        memory: e.memory,
                    }
                    .destroy(&self.device)
                };
            }
        }
        Ok(())
    }

    /// Submits the work recorded so far without waiting for it (no-op if there is none).
    pub fn flush(&mut self) -> Result<(), AshError> {
        if self.stream.state != StreamState::Recording {
            return Ok(());
        }
        let cmd = self.stream.cmd;
        let result = (|| {
            // SAFETY: `cmd` is recording; the fence is unsignaled and not in use (stream was
            // not in flight); the queue is ours to use (from_raw contract).
            unsafe {
                self.device
                    .end_command_buffer(cmd)
                    .map_err(AshError::vk("vkEndCommandBuffer"))?;
                let cmds = [cmd];
                let submit = vk::SubmitInfo::default().command_buffers(&cmds);
                self.device
                    .queue_submit(self.queue, &[submit], self.stream.fence)
                    .map_err(AshError::vk("vkQueueSubmit"))
            }
        })();
        match result {
            Ok(()) => {
                self.stream.state = StreamState::InFlight;
                Ok(())
            }
            Err(e) => {
                // Nothing was submitted: drop the recorded work.
                self.stream.state = StreamState::Idle;
                let _ = self.stream.arena.reset(&self.device);
                self.staging.reset();
                Err(e)
            }
        }
    }

    /// Waits for the in-flight submission, collects its timings and recycles its resources.
    fn wait(&mut self) -> Result<(), AshError> {
        if self.stream.state != StreamState::InFlight {
            return Ok(());
        }
        // SAFETY: the fence was submitted with the stream's work.
        unsafe {
            self.device
                .wait_for_fences(&[self.stream.fence], true, u64::MAX)
                .map_err(AshError::vk("vkWaitForFences"))?;
            self.device
                .reset_fences(&[self.stream.fence])
                .map_err(AshError::vk("vkResetFences"))?;
        }
        self.stream.state = StreamState::Idle;
        self.staging.reset();
        let timed = match self.timestamps {
            Some(ts) => self
                .stream
                .arena
                .collect_timings(&self.device, ts, true, &mut self.timings)
                .map(|_| ()),
            None => Ok(()),
        };
        self.stream.arena.reset(&self.device)?;
        timed
    }

    /// Makes the stream's command buffer ready to record into.
    fn recording(&mut self) -> Result<vk::CommandBuffer, AshError> {
        match self.stream.state {
            StreamState::Recording => return Ok(self.stream.cmd),
            StreamState::InFlight => self.wait()?,
            StreamState::Idle => {}
        }
        // SAFETY: the pool's command buffer is not pending (stream idle).
        unsafe {
            self.device
                .reset_command_pool(self.stream.pool, vk::CommandPoolResetFlags::empty())
                .map_err(AshError::vk("vkResetCommandPool"))?;
            self.device
                .begin_command_buffer(
                    self.stream.cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .map_err(AshError::vk("vkBeginCommandBuffer"))?;
        }
        self.stream.state = StreamState::Recording;
        Ok(self.stream.cmd)
    }

    /// Checks a pass against its kernel, the buffers and the device limits, and creates its
    /// pipeline if needed. Records nothing.
    fn prepare(&mut self, pass: &Pass<'_>) -> Result<Pipeline, AshError> {
        pass.validate()?;
        let kernel = pass.kernel;
        for (i, &id) in pass.buffers.iter().enumerate() {
            let e = self.entry(id)?;
            if pass.buffers[..i].contains(&id) {
                return Err(AshError::AliasedBinding(id));
            }
            if e.vk_size > u64::from(self.max_storage_range) {
                return Err(AshError::BindingTooLarge {
                    buffer: id,
                    size: e.size,
                    max: self.max_storage_range,
                });
            }
        }
        match pass.groups {
            Groups::Direct(groups) => {
                if groups.iter().zip(self.max_groups).any(|(&g, m)| g > m) {
                    return Err(AshError::TooManyGroups {
                        entry: kernel.entry,
                        groups,
                        max: self.max_groups,
                    });
                }
            }
            Groups::Indirect { buffer, offset } => {
                let size = self.entry(buffer)?.size;
                if offset + 12 > size {
                    return Err(AshError::OutOfRange {
                        buffer,
                        bytes: offset + 12,
                        size,
                    });
                }
                let written = pass
                    .buffers
                    .iter()
                    .zip(kernel.bindings)
                    .any(|(&b, binding)| b == buffer && binding.access.writes());
                if written {
                    return Err(AshError::AliasedBinding(buffer));
                }
            }
        }
        self.pipeline(kernel)
    }

    /// The cached pipeline of `kernel`, created on first use.
    fn pipeline(&mut self, kernel: &'static KernelDesc) -> Result<Pipeline, AshError> {
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
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
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

    /// Records a prepared pass into `cmd`, with the barriers its buffers need, using descriptor
    /// sets and queries of `arena`.
    fn emit_pass(
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
            infos.push(vk::DescriptorBufferInfo {
                buffer: e.buffer,
                offset: 0,
                range: e.vk_size,
            });
            arena.buffers.push(id);
        }

        let d = &self.device;
        // SAFETY: `cmd` is recording (caller); every handle is alive; the set is not in use.
        unsafe {
            if let Some(set) = set {
                let writes: Vec<vk::WriteDescriptorSet<'_>> = infos
                    .iter()
                    .enumerate()
                    .map(|(i, info)| {
                        vk::WriteDescriptorSet::default()
                            .dst_set(set)
                            .dst_binding(i as u32)
                            .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                            .buffer_info(std::slice::from_ref(info))
                    })
                    .collect();
                d.update_descriptor_sets(&writes, &[]);
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

    /// Records `passes` into the engine's command buffer `cmd`, in order.
    ///
    /// Before recording, any work the executor has pending (buffer creation fills, uploads) is
    /// submitted to [`AshExecutor::queue`] without waiting, so `cmd` must be submitted to that
    /// same queue (later), and it then runs after those uploads.
    ///
    /// **Barriers the executor inserts** (all `vkCmdPipelineBarrier` with buffer memory barriers
    /// on whole buffers): between passes of this call, and against earlier work of the executor
    /// itself (uploads, fills, earlier passes, including earlier `record_into` calls),
    /// read-after-write `COMPUTE_SHADER/SHADER_WRITE` (or `TRANSFER/TRANSFER_WRITE`) →
    /// `COMPUTE_SHADER/SHADER_READ` (`DRAW_INDIRECT/INDIRECT_COMMAND_READ` for the counts of
    /// [`Groups::Indirect`]), write-after-write, and write-after-read execution dependencies.
    ///
    /// **What the engine must insert**:
    /// - *before* this call, for every buffer its own commands accessed (e.g. imported buffers
    ///   its ray-tracing pass wrote): a barrier from that access to
    ///   `COMPUTE_SHADER` with `SHADER_READ | SHADER_WRITE` (plus `DRAW_INDIRECT` /
    ///   `INDIRECT_COMMAND_READ` for indirect-count buffers);
    /// - *after* it, before its own commands use buffers the passes wrote: a barrier from
    ///   `COMPUTE_SHADER` / `SHADER_WRITE` to its consumer's stage and access (and from
    ///   `COMPUTE_SHADER` / `SHADER_READ` before it overwrites a buffer the passes read).
    ///
    /// Timestamp queries are recorded as for the executor's own work when the queue family
    /// supports them (including a `vkCmdResetQueryPool` when a query pool is first used); their
    /// timings are added to [`Executor::timings`] by [`AshExecutor::retire`].
    ///
    /// Fails before recording anything if a pass is invalid.
    ///
    /// # Safety
    /// - `cmd` is a primary or secondary command buffer in the recording state, outside a render
    ///   pass, allocated from a pool of [`AshExecutor::queue_family_index`]; it is submitted to
    ///   [`AshExecutor::queue`] after this call returns, or discarded.
    /// - The returned [`Recording`] is given to [`AshExecutor::retire`] only after `cmd` has
    ///   finished executing (or was discarded), and before the executor is dropped all such
    ///   command buffers have completed.
    pub unsafe fn record_into(
        &mut self,
        cmd: vk::CommandBuffer,
        passes: &[Pass<'_>],
    ) -> Result<Recording, AshError> {
        let pipelines = passes
            .iter()
            .map(|p| self.prepare(p))
            .collect::<Result<Vec<_>, _>>()?;
        self.flush()?;
        let mut arena = self.spare_arenas.pop().unwrap_or_default();
        let id = self.next_recording;
        self.next_recording += 1;
        for (pass, &p) in passes.iter().zip(&pipelines) {
            if let Err(e) = self.emit_pass(cmd, &mut arena, pass, p) {
                // `cmd` may hold some of the arena's sets: keep it until drop.
                self.external.insert(id, arena);
                return Err(e);
            }
        }
        self.external.insert(id, arena);
        Ok(Recording {
            id,
            passes: passes.len(),
        })
    }

    /// Recycles the descriptor sets and queries of a recording and adds its timings to
    /// [`Executor::timings`] (none if the queries were never executed).
    ///
    /// # Safety
    /// The command buffer `recording` was recorded into has finished executing, or was never
    /// submitted.
    pub unsafe fn retire(&mut self, recording: Recording) -> Result<(), AshError> {
        let Some(mut arena) = self.external.remove(&recording.id) else {
            return Ok(());
        };
        let timed = match self.timestamps {
            Some(ts) => arena
                .collect_timings(&self.device, ts, false, &mut self.timings)
                .map(|_| ()),
            None => Ok(()),
        };
        let reset = arena.reset(&self.device);
        self.spare_arenas.push(arena);
        timed.and(reset)
    }
}

impl Executor for AshExecutor {
    type Error = AshError;

    fn name(&self) -> &'static str {
        "ash"
    }

    fn create_buffer(&mut self, size_bytes: u64) -> Result<BufferId, AshError> {
        if !size_bytes.is_multiple_of(4) {
            return Err(AshError::UnalignedSize(size_bytes));
        }
        let vk_size = size_bytes.max(4);
        let cmd = self.recording()?;
        let a = alloc::allocate(
            &self.device,
            &self.mem_props,
            vk_size,
            STORAGE_USAGE,
            vk::MemoryPropertyFlags::empty(),
            vk::MemoryPropertyFlags::DEVICE_LOCAL,
            "storage buffer",
        )?;
        let mut hazard = Hazard::default();
        let mut batch = BarrierBatch::default();
        batch.access(
            &mut hazard,
            a.buffer,
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::TRANSFER_WRITE,
        );
        // SAFETY: `cmd` is recording; the buffer was just created.
        unsafe {
            batch.emit(&self.device, cmd);
            self.device
                .cmd_fill_buffer(cmd, a.buffer, 0, vk::WHOLE_SIZE, 0);
        }
        self.buffers.push(Some(BufferEntry {
            buffer: a.buffer,
            memory: a.memory,
            size: size_bytes,
            vk_size,
            hazard,
        }));
        Ok(BufferId(self.buffers.len() as u32 - 1))
    }

    fn write_buffer(&mut self, buffer: BufferId, data: &[u8]) -> Result<(), AshError> {
        let size = self.entry(buffer)?.size;
        if data.len() as u64 > size {
            return Err(AshError::OutOfRange {
                buffer,
                bytes: data.len() as u64,
                size,
            });
        }
        if data.is_empty() {
            return Ok(());
        }
        let cmd = self.recording()?;
        let (src, offset) = self.staging.push(&self.device, &self.mem_props, data)?;
        let e = self.buffers[buffer.0 as usize]
            .as_mut()
            .expect("checked above");
        let mut batch = BarrierBatch::default();
        batch.access(
            &mut e.hazard,
            e.buffer,
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::TRANSFER_WRITE,
        );
        let region = vk::BufferCopy {
            src_offset: offset,
            dst_offset: 0,
            size: data.len() as u64,
        };
        // SAFETY: `cmd` is recording; both buffers are alive until the submission completes.
        unsafe {
            batch.emit(&self.device, cmd);
            self.device.cmd_copy_buffer(cmd, src, e.buffer, &[region]);
        }
        Ok(())
    }

    fn dispatch(&mut self, pass: &Pass<'_>) -> Result<(), AshError> {
        let p = self.prepare(pass)?;
        let cmd = self.recording()?;
        let mut arena = std::mem::take(&mut self.stream.arena);
        let result = self.emit_pass(cmd, &mut arena, pass, p);
        self.stream.arena = arena;
        result
    }

    fn read_buffer(&mut self, buffer: BufferId, out: &mut [u8]) -> Result<(), AshError> {
        let size = self.entry(buffer)?.size;
        if out.len() as u64 > size {
            return Err(AshError::OutOfRange {
                buffer,
                bytes: out.len() as u64,
                size,
            });
        }
        if out.is_empty() {
            return self.finish();
        }
        let cmd = self.recording()?;
        let len = out.len() as u64;
        if self.readback.as_ref().is_none_or(|r| r.size < len) {
            if let Some(old) = self.readback.take() {
                // SAFETY: only used inside read_buffer, whose submission has completed.
                unsafe { old.destroy(&self.device) };
            }
            self.readback = Some(HostBuffer::new(
                &self.device,
                &self.mem_props,
                len.next_power_of_two(),
                true,
            )?);
        }
        let dst = self.readback.as_ref().expect("just created").alloc.buffer;
        let e = self.buffers[buffer.0 as usize]
            .as_mut()
            .expect("checked above");
        let mut batch = BarrierBatch::default();
        batch.access(
            &mut e.hazard,
            e.buffer,
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::TRANSFER_READ,
        );
        let mut to_host = BarrierBatch::default();
        to_host.push(
            dst,
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::TRANSFER_WRITE,
            vk::PipelineStageFlags::HOST,
            vk::AccessFlags::HOST_READ,
        );
        // SAFETY: `cmd` is recording; both buffers are alive until the submission completes.
        unsafe {
            batch.emit(&self.device, cmd);
            self.device.cmd_copy_buffer(
                cmd,
                e.buffer,
                dst,
                &[vk::BufferCopy {
                    src_offset: 0,
                    dst_offset: 0,
                    size: len,
                }],
            );
            to_host.emit(&self.device, cmd);
        }
        self.finish()?;
        self.readback.as_ref().expect("created above").read(out);
        Ok(())
    }

    fn finish(&mut self) -> Result<(), AshError> {
        self.flush()?;
        self.wait()
    }

    fn timings(&self) -> &[PassTiming] {
        &self.timings
    }

    fn clear_timings(&mut self) {
        self.timings.clear();
    }
}

impl Drop for AshExecutor {
    fn drop(&mut self) {
        let d = &self.device;
        // SAFETY: after the wait nothing of ours is pending (borrowed devices: the user promised
        // that recordings completed); each object is destroyed once; null handles are ignored.
        unsafe {
            if self.owned.is_some() {
                let _ = d.device_wait_idle();
            } else if self.stream.state == StreamState::InFlight {
                let _ = d.wait_for_fences(&[self.stream.fence], true, u64::MAX);
            }
            for (_, p) in self.pipelines.drain() {
                d.destroy_pipeline(p.pipeline, None);
                d.destroy_pipeline_layout(p.layout, None);
                d.destroy_descriptor_set_layout(p.set_layout, None);
            }
            d.destroy_shader_module(self.module, None);
            for e in self.buffers.drain(..).flatten() {
                if e.memory != vk::DeviceMemory::null() {
                    Allocation {
                        buffer: e.buffer,
                        memory: e.memory,
                    }
                    .destroy(d);
                }
            }
            self.staging.destroy(d);
            if let Some(r) = self.readback.take() {
                r.destroy(d);
            }
            self.stream.arena.destroy(d);
            for (_, mut a) in self.external.drain() {
                a.destroy(d);
            }
            for mut a in self.spare_arenas.drain(..) {
                a.destroy(d);
            }
            d.destroy_fence(self.stream.fence, None);
            d.destroy_command_pool(self.stream.pool, None);
            if let Some(owned) = self.owned.take() {
                d.destroy_device(None);
                if let Some((du, m)) = &owned.messenger {
                    du.destroy_debug_utils_messenger(*m, None);
                }
                self.instance.destroy_instance(None);
                drop(owned); // unloads the loader last
            }
        }
    }
}

// The executor can move between threads (e.g. into a render thread).
const _: fn() = || {
    fn assert_send<T: Send>() {}
    assert_send::<AshExecutor>();
};
