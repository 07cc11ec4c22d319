//! The wgpu backend of VRRT-rs: runs the rust-gpu kernels of `shaders/vrrt.spv` through wgpu on
//! Vulkan.
//!
//! The SPIR-V module is embedded at build time and translated by naga (`ShaderSource::SpirV`),
//! which wgpu validates like any other shader; one compute pipeline per
//! [`KernelDesc::entry`](vrrt_core::plan::KernelDesc) is created on first use and cached.
//! Kernels take their parameters as *immediates* (Vulkan push constants,
//! [`wgpu::Features::IMMEDIATES`]) and their storage buffers at group 0, binding `i`.
//!
//! Two ways to use it:
//! - **Standalone** ([`WgpuExecutor::new_headless`]): the executor owns a device and queue and
//!   implements [`Executor`]: passes are recorded into a pending command encoder, submitted by
//!   [`Executor::read_buffer`] / [`Executor::finish`], which wait for the GPU.
//! - **Embedded in an engine** ([`WgpuExecutor::from_device`] + [`WgpuExecutor::encode`]): the
//!   executor uses the application's device and queue and records passes into the
//!   application's own [`wgpu::CommandEncoder`]. Buffers can be shared both ways
//!   ([`WgpuExecutor::buffer`], [`WgpuExecutor::import_buffer`]).
//!
//! wgpu tracks buffer usages itself: the barriers between a pass that writes a buffer and a later
//! pass, copy or indirect dispatch that reads it are inserted automatically, within one command
//! encoder and across submissions on the same queue.

pub mod validation;

use std::borrow::Cow;
use std::collections::HashMap;
use std::fmt;
use std::sync::{Arc, Mutex};

use validation::{Messenger, ValidationLog};
use vrrt_core::plan::{
    BufferId, Executor, Groups, KernelDesc, Pass, PassTiming, PlanError,
};
use wgpu::util::DeviceExt as _;

/// The embedded SPIR-V module (`shaders/vrrt.spv`, checked in; see `shaders-builder`).
pub static SPIRV: &[u8] =
    include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders/vrrt.spv"));

/// Immediate (push-constant) bytes a headless device is created with, at least.
pub const MIN_IMMEDIATE_SIZE: u32 = 128;

/// Timestamped passes per query-set batch (two queries each); a full batch is submitted.
const TIMESTAMP_PASSES: u32 = 256;

/// Buffer usages of every buffer the executor creates.
pub const BUFFER_USAGES: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_SRC)
    .union(wgpu::BufferUsages::COPY_DST)
    .union(wgpu::BufferUsages::INDIRECT);

/// Errors of the wgpu backend.
#[derive(Debug)]
pub enum WgpuError {
    /// No Vulkan adapter could be found (no driver, or the loader is missing).
    NoAdapter(String),
    /// The adapter refused to create a device.
    RequestDevice(String),
    /// The device lacks features the executor needs.
    MissingFeatures(wgpu::Features),
    /// A device limit is too low for a kernel or for the executor.
    Limit(String),
    /// The embedded module is not SPIR-V.
    InvalidSpirv(String),
    /// wgpu reported an error (validation, out of memory, internal) for an operation of the
    /// executor. Also counted by [`WgpuExecutor::validation_errors`].
    Wgpu(String),
    /// Mapping a buffer or waiting for the device failed.
    Device(String),
    /// The pass does not match its kernel.
    Plan(PlanError),
    /// A buffer id this executor does not know.
    UnknownBuffer(BufferId),
    /// A write or read beyond the end of a buffer.
    OutOfRange {
        /// The buffer.
        buffer: BufferId,
        /// Bytes asked for (end offset).
        bytes: u64,
        /// Bytes the buffer has.
        size: u64,
    },
    /// Buffer sizes must be multiples of 4 bytes.
    UnalignedSize(u64),
    /// The same buffer bound twice in one pass.
    AliasedBinding(BufferId),
    /// A buffer (typically an imported one) lacks a usage the operation needs.
    MissingUsage {
        /// The buffer.
        buffer: BufferId,
        /// Usages it lacks.
        missing: wgpu::BufferUsages,
    },
}

impl fmt::Display for WgpuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            WgpuError::NoAdapter(why) => write!(f, "no Vulkan adapter: {why}"),
            WgpuError::RequestDevice(why) => write!(f, "cannot create a wgpu device: {why}"),
            WgpuError::MissingFeatures(missing) => {
                write!(f, "the wgpu device lacks required features: {missing:?}")
            }
            WgpuError::Limit(why) => write!(f, "device limit too low: {why}"),
            WgpuError::InvalidSpirv(why) => write!(f, "invalid SPIR-V module: {why}"),
            WgpuError::Wgpu(e) => write!(f, "wgpu error: {e}"),
            WgpuError::Device(e) => write!(f, "device error: {e}"),
            WgpuError::Plan(e) => write!(f, "{e}"),
            WgpuError::UnknownBuffer(b) => write!(f, "unknown buffer {b:?}"),
            WgpuError::OutOfRange {
                buffer,
                bytes,
                size,
            } => {
                write!(
                    f,
                    "{bytes} bytes do not fit buffer {buffer:?} of {size} bytes"
                )
            }
            WgpuError::UnalignedSize(s) => write!(f, "buffer size {s} is not a multiple of 4"),
            WgpuError::AliasedBinding(b) => write!(f, "buffer {b:?} bound twice in one pass"),
            WgpuError::MissingUsage { buffer, missing } => {
                write!(f, "buffer {buffer:?} lacks usages {missing:?}")
            }
        }
    }
}

impl std::error::Error for WgpuError {}

/// How [`WgpuExecutor::new_headless`] picks and configures its device.
#[derive(Clone, Debug)]
pub struct WgpuOptions {
    /// Enable the Vulkan validation layer and wgpu debug information
    /// ([`wgpu::InstanceFlags::VALIDATION`] | [`wgpu::InstanceFlags::DEBUG`]) and count their
    /// errors (see [`WgpuExecutor::validation_errors`]). Default: environment variable
    /// `VRRT_VALIDATION` is `1`.
    pub validation: bool,
    /// Time each pass with GPU timestamps when the adapter supports
    /// [`wgpu::Features::TIMESTAMP_QUERY`]. Default: true.
    pub timestamps: bool,
    /// Adapter preference. Default: [`wgpu::PowerPreference::HighPerformance`] (discrete, then
    /// integrated GPUs, then others; software adapters such as lavapipe come last but are
    /// accepted).
    pub power_preference: wgpu::PowerPreference,
    /// Only accept a software (CPU) adapter such as lavapipe. Default: false.
    pub force_fallback_adapter: bool,
}

impl Default for WgpuOptions {
    fn default() -> Self {
        WgpuOptions {
            validation: std::env::var("VRRT_VALIDATION").is_ok_and(|v| v == "1"),
            timestamps: true,
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
        }
    }
}

/// A cached pipeline with its bind group layout.
struct Kernel {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

/// Timestamps of passes submitted together, copied to `readback`.
struct TimestampBatch {
    readback: wgpu::Buffer,
    entries: Vec<&'static str>,
}

/// GPU timestamp state: one query set reused by successive batches (queue order makes the
/// resolve of a batch run before the next batch's writes).
struct Timer {
    query_set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    /// Nanoseconds per tick.
    period: f32,
    /// Passes recorded into the pending encoder, in order.
    recording: Vec<&'static str>,
    submitted: Vec<TimestampBatch>,
    free: Vec<wgpu::Buffer>,
}

/// Runs VRRT plans with wgpu on Vulkan. See the [crate documentation](crate).
pub struct WgpuExecutor {
    // Dropped first: destroyed while the device still keeps the VkInstance alive.
    messenger: Option<Messenger>,
    log: ValidationLog,
    validation_requested: bool,
    device: wgpu::Device,
    queue: wgpu::Queue,
    adapter_info: wgpu::AdapterInfo,
    _instance: Option<wgpu::Instance>,
    module: Option<wgpu::ShaderModule>,
    kernels: HashMap<&'static str, Kernel>,
    bind_groups: HashMap<(&'static str, Vec<BufferId>), wgpu::BindGroup>,
    buffers: Vec<wgpu::Buffer>,
    encoder: Option<wgpu::CommandEncoder>,
    readback: Option<wgpu::Buffer>,
    timer: Option<Timer>,
    timings: Vec<PassTiming>,
}

impl fmt::Debug for WgpuExecutor {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("WgpuExecutor")
            .field("adapter", &self.adapter_info.name)
            .field("buffers", &self.buffers.len())
            .field("kernels", &self.kernels.len())
            .field("timestamps", &self.timer.is_some())
            .field("validation_errors", &self.log.count())
            .finish_non_exhaustive()
    }
}

impl WgpuExecutor {
    /// Creates a Vulkan device of its own (no surface).
    ///
    /// Requests [`wgpu::Features::IMMEDIATES`] (required), [`wgpu::Features::TIMESTAMP_QUERY`]
    /// when supported and `options.timestamps` is set, and the adapter's own limits (all storage
    /// buffers per stage it offers, its largest buffers, at least [`MIN_IMMEDIATE_SIZE`] bytes of
    /// immediates). Never panics: without a Vulkan driver the error is
    /// [`WgpuError::NoAdapter`], whose message contains `no Vulkan adapter`.
    pub fn new_headless(options: WgpuOptions) -> Result<Self, WgpuError> {
        let mut flags = wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL;
        if options.validation {
            flags |= wgpu::InstanceFlags::VALIDATION | wgpu::InstanceFlags::DEBUG;
        }
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN,
            flags,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: options.power_preference,
            force_fallback_adapter: options.force_fallback_adapter,
            compatible_surface: None,
            apply_limit_buckets: false,
        }))
        .map_err(|e| WgpuError::NoAdapter(e.to_string()))?;

        let supported = adapter.features();
        let mut features = wgpu::Features::IMMEDIATES;
        if !supported.contains(features) {
            return Err(WgpuError::MissingFeatures(features - supported));
        }
        if options.timestamps && supported.contains(wgpu::Features::TIMESTAMP_QUERY) {
            features |= wgpu::Features::TIMESTAMP_QUERY;
        }
        let limits = adapter.limits();
        if limits.max_immediate_size < MIN_IMMEDIATE_SIZE {
            return Err(WgpuError::Limit(format!(
                "adapter offers {} bytes of immediates, {MIN_IMMEDIATE_SIZE} needed",
                limits.max_immediate_size
            )));
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("vrrt"),
            required_features: features,
            required_limits: limits,
            ..Default::default()
        }))
        .map_err(|e| WgpuError::RequestDevice(e.to_string()))?;

        let log = ValidationLog::new();
        device.on_uncaptured_error(log.uncaptured_error_handler());
        let mut executor = Self::build(device, queue, log);
        executor.validation_requested = options.validation;
        executor._instance = Some(instance);
        Ok(executor)
    }

    /// Wraps an application's device and queue (for embedding in an engine).
    ///
    /// The device must have been created with [`wgpu::Features::IMMEDIATES`] and a
    /// `max_immediate_size` covering the kernels' parameters (32 bytes today;
    /// [`MIN_IMMEDIATE_SIZE`] is a safe request). Passes are timed when it has
    /// [`wgpu::Features::TIMESTAMP_QUERY`]. The application's uncaptured-error handler is left
    /// untouched: the executor catches the errors of its own operations with error scopes.
    /// Vulkan-layer errors are counted when the application's instance was created with
    /// [`wgpu::InstanceFlags::DEBUG`] (and [`wgpu::InstanceFlags::VALIDATION`] for the layer).
    pub fn from_device(device: wgpu::Device, queue: wgpu::Queue) -> Result<Self, WgpuError> {
        let missing = wgpu::Features::IMMEDIATES - device.features();
        if !missing.is_empty() {
            return Err(WgpuError::MissingFeatures(missing));
        }
        Ok(Self::build(device, queue, ValidationLog::new()))
    }

    fn build(device: wgpu::Device, queue: wgpu::Queue, log: ValidationLog) -> Self {
        let messenger = Messenger::register(&device, &log);
        let timer = device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| Timer {
                query_set: device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("vrrt timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: 2 * TIMESTAMP_PASSES,
                }),
                resolve: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("vrrt timestamp resolve"),
                    size: 2 * TIMESTAMP_PASSES as u64 * wgpu::QUERY_SIZE as u64,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
                period: queue.get_timestamp_period(),
                recording: Vec::new(),
                submitted: Vec::new(),
                free: Vec::new(),
            });
        WgpuExecutor {
            messenger,
            log,
            validation_requested: false,
            adapter_info: device.adapter_info(),
            device,
            queue,
            _instance: None,
            module: None,
            kernels: HashMap::new(),
            bind_groups: HashMap::new(),
            buffers: Vec::new(),
            encoder: None,
            readback: None,
            timer,
            timings: Vec::new(),
        }
    }

    /// The adapter the device runs on.
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.adapter_info
    }

    /// The device.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The queue work is submitted to.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// True when passes recorded by [`Executor::dispatch`] are timed with GPU timestamps.
    pub fn timestamps_enabled(&self) -> bool {
        self.timer.is_some()
    }

    /// Validation errors seen so far: wgpu errors raised by this executor's operations (or, for
    /// a headless executor, anywhere on its device) plus Vulkan validation-layer errors on the
    /// device's instance. See [`validation`].
    pub fn validation_errors(&self) -> u32 {
        self.log.count()
    }

    /// The log behind [`Self::validation_errors`], with the first messages.
    pub fn validation_log(&self) -> &ValidationLog {
        &self.log
    }

    /// True when Vulkan validation-layer errors are being counted: a messenger is registered and
    /// the Khronos validation layer is installed (and, for a headless executor, was requested
    /// with [`WgpuOptions::validation`]; for [`Self::from_device`] whether the application's
    /// instance enabled the layer cannot be checked).
    pub fn validation_layer_active(&self) -> bool {
        let layer = self.messenger.as_ref().is_some_and(|m| m.layer_installed);
        layer && (self.validation_requested || self._instance.is_none())
    }

    /// The wgpu buffer behind `id`, to use in the application's own passes.
    pub fn buffer(&self, id: BufferId) -> Option<&wgpu::Buffer> {
        self.buffers.get(id.0 as usize)
    }

    /// Wraps an application's buffer so passes can bind it. It must belong to this executor's
    /// device, have [`wgpu::BufferUsages::STORAGE`] and a size that is a multiple of 4; reading,
    /// writing it or using it for indirect dispatch additionally needs `COPY_SRC`, `COPY_DST` or
    /// `INDIRECT` (checked when used).
    pub fn import_buffer(&mut self, buffer: wgpu::Buffer) -> Result<BufferId, WgpuError> {
        let id = BufferId(self.buffers.len() as u32);
        if !buffer.size().is_multiple_of(4) {
            return Err(WgpuError::UnalignedSize(buffer.size()));
        }
        if !buffer.usage().contains(wgpu::BufferUsages::STORAGE) {
            return Err(WgpuError::MissingUsage {
                buffer: id,
                missing: wgpu::BufferUsages::STORAGE,
            });
        }
        self.buffers.push(buffer);
        Ok(id)
    }

    /// Records `passes` into the application's `encoder` (which must come from this executor's
    /// device), without timestamps.
    ///
    /// Work still pending in the executor (e.g. from [`Executor::write_buffer`]) is submitted
    /// first, so it runs before the application's command buffer once that is submitted. wgpu
    /// inserts the barriers between the passes and with the application's own commands.
    /// Nothing runs until the application finishes and submits `encoder` to the queue; to read
    /// results, submit, then call [`Executor::read_buffer`] (or copy and map them yourself).
    /// Validation errors in the recorded passes are reported by wgpu when the encoder is finished
    /// or submitted, to the application's error scopes or handler.
    pub fn encode(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        passes: &[Pass<'_>],
    ) -> Result<(), WgpuError> {
        self.submit()?;
        for pass in passes {
            self.prepare(pass)?;
        }
        for pass in passes {
            self.record(encoder, pass, None);
        }
        Ok(())
    }

    fn get(&self, id: BufferId) -> Result<&wgpu::Buffer, WgpuError> {
        self.buffers
            .get(id.0 as usize)
            .ok_or(WgpuError::UnknownBuffer(id))
    }

    fn require(&self, id: BufferId, usage: wgpu::BufferUsages) -> Result<&wgpu::Buffer, WgpuError> {
        let b = self.get(id)?;
        let missing = usage - b.usage();
        if missing.is_empty() {
            Ok(b)
        } else {
            Err(WgpuError::MissingUsage {
                buffer: id,
                missing,
            })
        }
    }

    /// Runs `f` inside error scopes; a captured error is logged and returned.
    fn scoped<T>(&self, f: impl FnOnce() -> T) -> Result<T, WgpuError> {
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let internal = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let value = f();
        let errors = [internal.pop(), oom.pop(), validation.pop()].map(pollster::block_on);
        match errors.into_iter().flatten().next() {
            None => Ok(value),
            Some(e) => {
                let msg = e.to_string();
                self.log.record(format!("wgpu: {msg}"));
                Err(WgpuError::Wgpu(msg))
            }
        }
    }

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

    fn ensure_kernel(&mut self, desc: &'static KernelDesc) -> Result<(), WgpuError> {
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
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage {
                        read_only: !binding.access.writes(),
                    },
                    has_dynamic_offset: false,
                    min_binding_size: None,
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

    /// Checks a pass and creates what it needs (pipeline, bind group).
    fn prepare(&mut self, pass: &Pass<'_>) -> Result<(), WgpuError> {
        pass.validate().map_err(WgpuError::Plan)?;
        for (i, id) in pass.buffers.iter().enumerate() {
            self.require(*id, wgpu::BufferUsages::STORAGE)?;
            if pass.buffers[..i].contains(id) {
                return Err(WgpuError::AliasedBinding(*id));
            }
        }
        if let Groups::Indirect { buffer, offset } = pass.groups {
            let size = self.require(buffer, wgpu::BufferUsages::INDIRECT)?.size();
            if offset + 12 > size {
                return Err(WgpuError::OutOfRange {
                    buffer,
                    bytes: offset + 12,
                    size,
                });
            }
        }
        self.ensure_kernel(pass.kernel)?;
        let key = (pass.kernel.entry, pass.buffers.to_vec());
        if !self.bind_groups.contains_key(&key) {
            let layout = &self.kernels[pass.kernel.entry].layout;
            let entries: Vec<wgpu::BindGroupEntry<'_>> = pass
                .buffers
                .iter()
                .enumerate()
                .map(|(i, id)| wgpu::BindGroupEntry {
                    binding: i as u32,
                    resource: self.buffers[id.0 as usize].as_entire_binding(),
                })
                .collect();
            let group = self.scoped(|| {
                self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(pass.kernel.entry),
                    layout,
                    entries: &entries,
                })
            })?;
            self.bind_groups.insert(key, group);
        }
        Ok(())
    }

    /// Records a prepared pass.
    fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        pass: &Pass<'_>,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let kernel = &self.kernels[pass.kernel.entry];
        let group = &self.bind_groups[&(pass.kernel.entry, pass.buffers.to_vec())];
        let mut cpass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(pass.kernel.entry),
            timestamp_writes: timestamps,
        });
        cpass.set_pipeline(&kernel.pipeline);
        cpass.set_bind_group(0, group, &[]);
        if !pass.params.is_empty() {
            cpass.set_immediates(0, pass.params);
        }
        match pass.groups {
            Groups::Direct([x, y, z]) => cpass.dispatch_workgroups(x, y, z),
            Groups::Indirect { buffer, offset } => {
                cpass.dispatch_workgroups_indirect(&self.buffers[buffer.0 as usize], offset)
            }
        }
    }

    fn pending_encoder(&mut self) -> wgpu::CommandEncoder {
        self.encoder.take().unwrap_or_else(|| {
            self.device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("vrrt"),
                })
        })
    }

    /// Submits the pending encoder (with the resolve of its timestamps), without waiting.
    fn submit(&mut self) -> Result<(), WgpuError> {
        let Some(mut encoder) = self.encoder.take() else {
            return Ok(());
        };
        if let Some(timer) = &mut self.timer {
            if !timer.recording.is_empty() {
                let n = timer.recording.len() as u32;
                let bytes = 2 * n as u64 * wgpu::QUERY_SIZE as u64;
                let readback = timer.free.pop().unwrap_or_else(|| {
                    self.device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("vrrt timestamp readback"),
                        size: timer.resolve.size(),
                        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    })
                });
                encoder.resolve_query_set(&timer.query_set, 0..2 * n, &timer.resolve, 0);
                encoder.copy_buffer_to_buffer(&timer.resolve, 0, &readback, 0, bytes);
                timer.submitted.push(TimestampBatch {
                    readback,
                    entries: std::mem::take(&mut timer.recording),
                });
            }
        }
        self.scoped(|| {
            self.queue.submit([encoder.finish()]);
        })
    }

    /// Submits pending work, waits for the device, maps `extra` (a buffer and a byte count) and
    /// the timestamp batches, collects the timings, and hands the mapped `extra` to `read`.
    fn submit_and_wait(
        &mut self,
        extra: Option<(&wgpu::Buffer, u64)>,
        read: impl FnOnce(&[u8]),
    ) -> Result<(), WgpuError> {
        self.submit()?;
        let status: Arc<Mutex<Vec<Result<(), wgpu::BufferAsyncError>>>> = Arc::default();
        let map = |buffer: &wgpu::Buffer, bytes: u64| {
            let status = status.clone();
            buffer.map_async(wgpu::MapMode::Read, 0..bytes, move |r| {
                status.lock().unwrap_or_else(|p| p.into_inner()).push(r)
            });
        };
        let batches = self
            .timer
            .as_mut()
            .map(|t| std::mem::take(&mut t.submitted))
            .unwrap_or_default();
        for batch in &batches {
            map(
                &batch.readback,
                2 * batch.entries.len() as u64 * wgpu::QUERY_SIZE as u64,
            );
        }
        if let Some((buffer, bytes)) = extra {
            map(buffer, bytes);
        }
        let expected = batches.len() + usize::from(extra.is_some());
        let polled = self
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| WgpuError::Device(e.to_string()));
        let results = std::mem::take(&mut *status.lock().unwrap_or_else(|p| p.into_inner()));
        let mapped = if let Err(e) = polled {
            Err(e)
        } else if results.len() != expected {
            Err(WgpuError::Device(format!(
                "{} of {expected} buffers mapped",
                results.len()
            )))
        } else if let Some(Err(e)) = results.into_iter().find(Result::is_err) {
            Err(WgpuError::Device(e.to_string()))
        } else {
            Ok(())
        };
        if mapped.is_ok() {
            if let Some(timer) = &mut self.timer {
                let ns_per_tick = timer.period as f64;
                for batch in &batches {
                    let bytes = 2 * batch.entries.len() as u64 * wgpu::QUERY_SIZE as u64;
                    let view = batch
                        .readback
                        .get_mapped_range(0..bytes)
                        .map_err(|e| WgpuError::Device(e.to_string()))?;
                    let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&view);
                    drop(view);
                    for (entry, t) in batch.entries.iter().zip(ticks.chunks_exact(2)) {
                        let ticks = t[1].saturating_sub(t[0]);
                        self.timings.push(PassTiming {
                            entry,
                            ms: ticks as f64 * ns_per_tick * 1e-6,
                        });
                    }
                }
            }
            if let Some((buffer, bytes)) = extra {
                let view = buffer
                    .get_mapped_range(0..bytes)
                    .map_err(|e| WgpuError::Device(e.to_string()))?;
                read(&view);
            }
        }
        // Unmap everything that was mapped, also on failure, and recycle the timestamp buffers.
        if let Some((buffer, _)) = extra {
            buffer.unmap();
        }
        for batch in batches {
            batch.readback.unmap();
            if let Some(timer) = &mut self.timer {
                timer.free.push(batch.readback);
            }
        }
        mapped
    }

    /// Copies `out.len()` bytes at `offset` of `id` into `out` (waits for pending work).
    fn read_range(&mut self, id: BufferId, offset: u64, out: &mut [u8]) -> Result<(), WgpuError> {
        let src = self.require(id, wgpu::BufferUsages::COPY_SRC)?.clone();
        let end = offset + out.len() as u64;
        if end > src.size() {
            return Err(WgpuError::OutOfRange {
                buffer: id,
                bytes: end,
                size: src.size(),
            });
        }
        let bytes = (out.len() as u64).next_multiple_of(4);
        if bytes == 0 {
            return self.finish();
        }
        let readback = match self.readback.take() {
            Some(b) if b.size() >= bytes => b,
            _ => self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("vrrt readback"),
                size: bytes.next_power_of_two(),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
        };
        let mut encoder = self.pending_encoder();
        encoder.copy_buffer_to_buffer(&src, offset, &readback, 0, bytes);
        self.encoder = Some(encoder);
        // Mapped memory need not be aligned for `T`: copy bytes.
        let result = self.submit_and_wait(Some((&readback, bytes)), |m| {
            out.copy_from_slice(&m[..out.len()])
        });
        self.readback = Some(readback);
        result
    }

    /// Records a copy of `data` (a multiple of 4 bytes) to `offset` of `dst` in the pending
    /// encoder, so it stays ordered with recorded passes.
    fn stage_write(
        &mut self,
        dst: &wgpu::Buffer,
        offset: u64,
        data: &[u8],
    ) -> Result<(), WgpuError> {
        let staging = self.scoped(|| {
            self.device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("vrrt upload"),
                    contents: data,
                    usage: wgpu::BufferUsages::COPY_SRC,
                })
        })?;
        let mut encoder = self.pending_encoder();
        encoder.copy_buffer_to_buffer(&staging, 0, dst, offset, data.len() as u64);
        self.encoder = Some(encoder);
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

impl Executor for WgpuExecutor {
    type Error = WgpuError;

    fn name(&self) -> &'static str {
        "wgpu"
    }

    /// Buffers have [`BUFFER_USAGES`]; wgpu zero-initialises them.
    fn create_buffer(&mut self, size_bytes: u64) -> Result<BufferId, WgpuError> {
        if !size_bytes.is_multiple_of(4) {
            return Err(WgpuError::UnalignedSize(size_bytes));
        }
        let id = BufferId(self.buffers.len() as u32);
        let buffer = self.scoped(|| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("vrrt buffer"),
                size: size_bytes,
                usage: BUFFER_USAGES,
                mapped_at_creation: false,
            })
        })?;
        self.buffers.push(buffer);
        Ok(id)
    }

    /// Recorded as a copy from a staging buffer into the pending encoder, so it is ordered with
    /// the passes recorded before and after it. A length that is not a multiple of 4 costs a
    /// readback of the last word.
    fn write_buffer(&mut self, buffer: BufferId, data: &[u8]) -> Result<(), WgpuError> {
        let dst = self.require(buffer, wgpu::BufferUsages::COPY_DST)?.clone();
        if data.len() as u64 > dst.size() {
            return Err(WgpuError::OutOfRange {
                buffer,
                bytes: data.len() as u64,
                size: dst.size(),
            });
        }
        let aligned = data.len() & !3;
        if aligned > 0 {
            self.stage_write(&dst, 0, &data[..aligned])?;
        }
        if aligned < data.len() {
            let mut word = [0u8; 4];
            self.read_range(buffer, aligned as u64, &mut word)?;
            let tail = &data[aligned..];
            word[..tail.len()].copy_from_slice(tail);
            self.stage_write(&dst, aligned as u64, &word)?;
        }
        Ok(())
    }

    /// Records the pass into the pending encoder (with begin/end timestamps when enabled).
    fn dispatch(&mut self, pass: &Pass<'_>) -> Result<(), WgpuError> {
        self.prepare(pass)?;
        if self
            .timer
            .as_ref()
            .is_some_and(|t| t.recording.len() as u32 == TIMESTAMP_PASSES)
        {
            self.submit()?;
        }
        let mut encoder = self.pending_encoder();
        let index = self.timer.as_ref().map(|t| 2 * t.recording.len() as u32);
        let writes =
            self.timer
                .as_ref()
                .zip(index)
                .map(|(t, i)| wgpu::ComputePassTimestampWrites {
                    query_set: &t.query_set,
                    beginning_of_pass_write_index: Some(i),
                    end_of_pass_write_index: Some(i + 1),
                });
        self.record(&mut encoder, pass, writes);
        if let Some(timer) = &mut self.timer {
            timer.recording.push(pass.kernel.entry);
        }
        self.encoder = Some(encoder);
        Ok(())
    }

    fn read_buffer(&mut self, buffer: BufferId, out: &mut [u8]) -> Result<(), WgpuError> {
        self.read_range(buffer, 0, out)
    }

    fn finish(&mut self) -> Result<(), WgpuError> {
        self.submit_and_wait(None, |_| {})
    }

    /// GPU durations of the passes recorded by [`Executor::dispatch`] (empty when timestamps
    /// are not supported; passes recorded by [`WgpuExecutor::encode`] are not timed).
    fn timings(&self) -> &[PassTiming] {
        &self.timings
    }

    fn clear_timings(&mut self) {
        self.timings.clear();
    }
}

impl Drop for WgpuExecutor {
    /// Submits work still pending (writes into shared buffers land); does not wait. wgpu keeps
    /// the resources in use alive until the GPU is done with them.
    fn drop(&mut self) {
        let _ = self.submit();
    }
}
