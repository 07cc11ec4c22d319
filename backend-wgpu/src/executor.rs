//! The executor itself: device setup (headless or an application's device), the embedding
//! accessors, and the [`Executor`] impl, whose methods delegate to the modules that own each
//! step (`buffers`, `dispatch`, `submit`). The state every module works on lives here.

use std::collections::HashMap;
use std::fmt;

use crate::pipelines::Kernel;
use crate::timings::Timer;
use crate::validation::{Messenger, ValidationLog};
use crate::{WgpuError, BUFFER_USAGES, MIN_IMMEDIATE_SIZE};
use vrrt_core::executor::{BindingLimit, BufferId, Executor, Pass, PassTiming};

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

/// Runs VRRT plans with wgpu on Vulkan. See the [crate documentation](crate).
pub struct WgpuExecutor {
    // Dropped first: destroyed while the device still keeps the VkInstance alive.
    pub(crate) messenger: Option<Messenger>,
    pub(crate) log: ValidationLog,
    pub(crate) validation_requested: bool,
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    pub(crate) adapter_info: wgpu::AdapterInfo,
    pub(crate) _instance: Option<wgpu::Instance>,
    pub(crate) module: Option<wgpu::ShaderModule>,
    pub(crate) kernels: HashMap<&'static str, Kernel>,
    pub(crate) bind_groups: HashMap<(&'static str, Vec<BufferId>), wgpu::BindGroup>,
    pub(crate) buffers: Vec<wgpu::Buffer>,
    /// The application's textures (`import_texture`).
    pub(crate) textures: Vec<crate::textures::Imported>,
    /// Commands recorded by the executor and not yet submitted.
    pub(crate) encoder: Option<wgpu::CommandEncoder>,
    /// Mappable buffer reused by readbacks.
    pub(crate) readback: Option<wgpu::Buffer>,
    /// Present iff the device has [`wgpu::Features::TIMESTAMP_QUERY`].
    pub(crate) timer: Option<Timer>,
    pub(crate) timings: Vec<PassTiming>,
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
    ///
    /// ```no_run
    /// use vrrt_core::denoiser::Denoiser;
    /// use vrrt_core::payload::PackedFiltered;
    /// use vrrt_core::executor::Executor;
    /// use vrrt_core::settings::Settings;
    /// use vrrt_wgpu::{WgpuExecutor, WgpuOptions};
    ///
    /// let mut gpu = WgpuExecutor::new_headless(WgpuOptions::default())?;
    /// println!("denoising on {}", gpu.adapter_info().name);
    /// let (width, height) = (1280, 720);
    /// let mut denoiser = Denoiser::new(&mut gpu, width, height, Settings::default())?;
    /// # let frame = vrrt_core::denoiser::FrameInfo::default();
    /// # let (depth, normal_roughness) = (Vec::<f32>::new(), Vec::<u32>::new());
    /// # let motion = Vec::<[u32; 2]>::new();
    /// # let trace = |_: &[u32]| Vec::<vrrt_core::payload::PackedSample>::new();
    /// // Each frame: the cameras and the G-buffer (`FrameInfo`, images in the formats of
    /// // `vrrt_core::packing`), the rays to trace, the samples, the denoised image.
    /// denoiser.begin_frame(&mut gpu, frame)?;
    /// let inputs = denoiser.inputs();
    /// gpu.write_buffer(inputs.depth, bytemuck::cast_slice(&depth))?;
    /// gpu.write_buffer(inputs.normal_roughness, bytemuck::cast_slice(&normal_roughness))?;
    /// gpu.write_buffer(inputs.motion, bytemuck::cast_slice(&motion))?;
    /// denoiser.plan_rays(&mut gpu)?;
    /// let rays = denoiser.read_rays(&mut gpu)?;
    /// gpu.write_buffer(denoiser.samples(), bytemuck::cast_slice(&trace(&rays)))?;
    /// denoiser.resolve(&mut gpu)?;
    /// let mut out = vec![PackedFiltered::default(); (width * height) as usize];
    /// gpu.read_buffer(denoiser.output(), bytemuck::cast_slice_mut(&mut out))?;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
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
    ///
    /// ```no_run
    /// use vrrt_core::denoiser::Denoiser;
    /// use vrrt_core::settings::Settings;
    /// use vrrt_wgpu::WgpuExecutor;
    ///
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// # let adapter: wgpu::Adapter = unimplemented!();
    /// // The application creates its device with what the denoiser needs: immediates for the
    /// // kernels' parameters, and the storage buffers per pass its largest kernel binds.
    /// let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
    ///     required_features: wgpu::Features::IMMEDIATES,
    ///     required_limits: wgpu::Limits {
    ///         max_immediate_size: vrrt_wgpu::MIN_IMMEDIATE_SIZE,
    ///         max_storage_buffers_per_shader_stage:
    ///             adapter.limits().max_storage_buffers_per_shader_stage,
    ///         ..wgpu::Limits::default()
    ///     },
    ///     ..Default::default()
    /// }))?;
    /// let mut gpu = WgpuExecutor::from_device(device.clone(), queue.clone())?;
    /// let denoiser = Denoiser::new(&mut gpu, 1280, 720, Settings::default())?;
    /// // The application's G-buffer pass renders straight into the denoiser's input buffers.
    /// let depth: &wgpu::Buffer = gpu.buffer(denoiser.inputs().depth).expect("allocated by new");
    /// # Ok(())
    /// # }
    /// ```
    pub fn from_device(device: wgpu::Device, queue: wgpu::Queue) -> Result<Self, WgpuError> {
        let missing = wgpu::Features::IMMEDIATES - device.features();
        if !missing.is_empty() {
            return Err(WgpuError::MissingFeatures(missing));
        }
        Ok(Self::build(device, queue, ValidationLog::new()))
    }

    fn build(device: wgpu::Device, queue: wgpu::Queue, log: ValidationLog) -> Self {
        let messenger = Messenger::register(&device, &log);
        let timer = Timer::new(&device, &queue);
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
            textures: Vec::new(),
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
    /// device's instance. See [`validation`](crate::validation).
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
}

impl Executor for WgpuExecutor {
    type Error = WgpuError;

    fn name(&self) -> &'static str {
        "wgpu"
    }

    fn binding_limit(&self) -> BindingLimit {
        let limits = self.device.limits();
        let binding = limits.max_storage_buffer_binding_size;
        if binding <= limits.max_buffer_size {
            BindingLimit {
                bytes: binding,
                name: "max_storage_buffer_binding_size",
            }
        } else {
            BindingLimit {
                bytes: limits.max_buffer_size,
                name: "max_buffer_size",
            }
        }
    }

    /// Buffers have [`BUFFER_USAGES`]; wgpu zero-initialises them.
    fn create_buffer(&mut self, size_bytes: u64) -> Result<BufferId, WgpuError> {
        self.create(size_bytes, BUFFER_USAGES)
    }

    /// Recorded as a copy from a staging buffer into the pending encoder, so it is ordered with
    /// the passes recorded before and after it. A length that is not a multiple of 4 costs a
    /// readback of the last word.
    fn write_buffer(&mut self, buffer: BufferId, data: &[u8]) -> Result<(), WgpuError> {
        self.write(buffer, data)
    }

    /// Records the pass into the pending encoder (with begin/end timestamps when enabled).
    fn dispatch(&mut self, pass: &Pass<'_>) -> Result<(), WgpuError> {
        self.record_pending(pass)
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
