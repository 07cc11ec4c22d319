//! The executor: its state (every other module adds methods to [`AshExecutor`] and works on
//! these fields), construction (headless or on an engine's device), accessors, the [`Executor`]
//! impl (which delegates to `buffers`, `transfer`, `dispatch` and `stream`) and teardown.

use crate::alloc::{Allocation, HostBuffer, Staging};
use crate::arena::{Arena, Timestamps};
use crate::buffers::BufferEntry;
use crate::embed::RawVulkan;
use crate::pipelines::Pipeline;
use crate::setup::{self, DebugState, Owned};
use crate::spirv::{self, ModuleInfo};
use crate::stream::{Stream, StreamState};
use crate::{AdapterInfo, AshError, AshOptions};
use ash::vk;
use std::collections::HashMap;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use vrrt_core::executor::{BindingLimit, BufferId, Executor, Pass, PassTiming};

/// Runs plans with raw Vulkan. See the [crate docs](crate).
pub struct AshExecutor {
    pub(crate) instance: ash::Instance,
    pub(crate) device: ash::Device,
    pub(crate) physical_device: vk::PhysicalDevice,
    pub(crate) queue: vk::Queue,
    pub(crate) queue_family_index: u32,
    pub(crate) info: AdapterInfo,
    pub(crate) mem_props: vk::PhysicalDeviceMemoryProperties,
    pub(crate) max_groups: [u32; 3],
    pub(crate) max_storage_range: u32,
    pub(crate) max_allocation: u64,
    pub(crate) timestamps: Option<Timestamps>,
    pub(crate) module_info: ModuleInfo,
    pub(crate) module: vk::ShaderModule,
    pub(crate) pipelines: HashMap<&'static str, Pipeline>,
    pub(crate) buffers: Vec<Option<BufferEntry>>,
    /// Engine images (imported) and images created for hosts without an engine.
    pub(crate) textures: Vec<crate::textures::Texture>,
    pub(crate) stream: Stream,
    pub(crate) staging: Staging,
    pub(crate) readback: Option<HostBuffer>,
    pub(crate) external: HashMap<u64, Arena>,
    pub(crate) spare_arenas: Vec<Arena>,
    pub(crate) next_recording: u64,
    pub(crate) timings: Vec<PassTiming>,
    pub(crate) debug: Option<Arc<DebugState>>,
    /// Present iff the executor created the instance and device (and destroys them).
    pub(crate) owned: Option<Owned>,
}

impl AshExecutor {
    /// Creates its own Vulkan 1.2 instance and device on the best adapter (discrete > integrated
    /// > virtual > CPU) that has a compute queue and `vulkanMemoryModel`.
    ///
    /// Errors: [`AshError::NoAdapter`] (displays `no Vulkan adapter: …`) when the loader is missing
    /// or no device qualifies; [`AshError::ValidationUnavailable`] when validation is asked for
    /// but the layer is not installed. Never panics for lack of Vulkan.
    ///
    /// ```no_run
    /// use vrrt_ash::{AshExecutor, AshOptions};
    /// use vrrt_core::denoiser::Denoiser;
    /// use vrrt_core::settings::Settings;
    ///
    /// // Validation from `VRRT_VALIDATION=1`; ask for it explicitly while porting.
    /// let options = AshOptions { validation: true, ..AshOptions::default() };
    /// let mut gpu = match AshExecutor::new_headless(options) {
    ///     Ok(gpu) => gpu,
    ///     Err(e) => return Err(format!("no Vulkan here, use vrrt-cpu instead: {e}").into()),
    /// };
    /// println!("denoising on {}", gpu.adapter_info().name);
    /// let mut denoiser = Denoiser::new(&mut gpu, 1280, 720, Settings::default())?;
    /// // Frames as on any backend: `vrrt_core::denoiser::Denoiser`.
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
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
    ///
    /// ```no_run
    /// use vrrt_ash::ash::{vk, Device, Instance};
    /// use vrrt_ash::{AshExecutor, RawVulkan};
    /// use vrrt_core::denoiser::Denoiser;
    /// use vrrt_core::settings::Settings;
    ///
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// # let (instance, device, physical_device, queue, queue_family_index): (
    /// #     Instance, Device, vk::PhysicalDevice, vk::Queue, u32) = unimplemented!();
    /// // SAFETY: the engine's handles outlive the executor, its device is Vulkan 1.2 with
    /// // `vulkanMemoryModel`, and the engine leaves the queue alone while the executor submits.
    /// let mut gpu = unsafe {
    ///     AshExecutor::from_raw(RawVulkan {
    ///         instance,
    ///         device,
    ///         physical_device,
    ///         queue,
    ///         queue_family_index,
    ///     })?
    /// };
    /// let denoiser = Denoiser::new(&mut gpu, 1280, 720, Settings::default())?;
    /// // The engine's G-buffer pass renders straight into the denoiser's input buffers.
    /// let depth: vk::Buffer = gpu.raw_buffer(denoiser.inputs().depth)?;
    /// # Ok(())
    /// # }
    /// ```
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
        let max_allocation = setup::max_allocation(&raw.instance, raw.physical_device);
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
            max_allocation,
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
            textures: Vec::new(),
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
}

impl Executor for AshExecutor {
    type Error = AshError;

    fn name(&self) -> &'static str {
        "ash"
    }

    /// The smaller of `maxStorageBufferRange` and `maxMemoryAllocationSize`, by name.
    fn binding_limit(&self) -> BindingLimit {
        if self.max_allocation < u64::from(self.max_storage_range) {
            BindingLimit {
                bytes: self.max_allocation,
                name: "maxMemoryAllocationSize",
            }
        } else {
            BindingLimit {
                bytes: u64::from(self.max_storage_range),
                name: "maxStorageBufferRange",
            }
        }
    }

    fn create_buffer(&mut self, size_bytes: u64) -> Result<BufferId, AshError> {
        self.create(size_bytes)
    }

    fn write_buffer(&mut self, buffer: BufferId, data: &[u8]) -> Result<(), AshError> {
        self.upload(buffer, data)
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
        self.readback(buffer, out)
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
            crate::textures::destroy(std::mem::take(&mut self.textures), d);
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
