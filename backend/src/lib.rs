//! Backend choice: one executor type over the CPU, wgpu and ash backends, and the `auto` rule.
//!
//! `auto` takes the first hardware GPU (discrete, then integrated) that wgpu finds, then one that
//! ash finds, and otherwise the CPU backend: a software Vulkan device (lavapipe) is slower than the
//! native CPU backend, so it is only used when asked for by name.

mod textures;
pub use textures::TextureFormat;

use std::fmt;
use std::sync::Arc;
use vrrt_ash::{AdapterType, AshExecutor, AshOptions};
use vrrt_core::executor::{BindingLimit, BufferId, Executor, Pass, PassTiming, SharedBytes};
use vrrt_cpu::CpuExecutor;
use vrrt_wgpu::{WgpuExecutor, WgpuOptions};

/// Which backend to run on.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum BackendKind {
    /// Best available: a hardware GPU through wgpu or ash, else the CPU.
    Auto,
    /// Native kernels on the CPU.
    Cpu,
    /// wgpu on Vulkan.
    Wgpu,
    /// Raw Vulkan through ash.
    Ash,
}

impl std::str::FromStr for BackendKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(BackendKind::Auto),
            "cpu" => Ok(BackendKind::Cpu),
            "wgpu" => Ok(BackendKind::Wgpu),
            "ash" => Ok(BackendKind::Ash),
            other => Err(format!(
                "unknown backend `{other}` (expected auto, cpu, wgpu or ash)"
            )),
        }
    }
}

/// A backend failure, with the backend's own message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BackendError(pub String);

impl fmt::Display for BackendError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BackendError {}

/// An open backend.
///
/// What `vrrt run --backend NAME` opens, for programs that want the same choice: the `auto`
/// rule, or a backend by name, then any denoiser or renderer on it.
///
/// ```
/// use vrrt_backend::{Backend, BackendKind};
/// use vrrt_core::denoiser::Denoiser;
/// use vrrt_core::settings::Settings;
///
/// // "auto" takes a hardware GPU when there is one; "cpu" runs anywhere.
/// let kind: BackendKind = "cpu".parse()?;
/// let (mut exec, why) = Backend::open(kind, false)?;
/// println!("{} ({why})", exec.device());
/// let denoiser = Denoiser::new(&mut exec, 640, 360, Settings::default())?;
/// assert_eq!(denoiser.size(), (640, 360));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub enum Backend {
    /// CPU backend.
    Cpu(CpuExecutor),
    /// wgpu backend.
    Wgpu(Box<WgpuExecutor>),
    /// ash backend.
    Ash(Box<AshExecutor>),
}

fn err(e: impl fmt::Display) -> BackendError {
    BackendError(e.to_string())
}

/// wgpu options with validation when asked for, or when the options' default has it on
/// (`VRRT_VALIDATION=1`, as in the tests and CI).
fn wgpu_options(validation: bool) -> WgpuOptions {
    let default = WgpuOptions::default();
    WgpuOptions {
        validation: validation || default.validation,
        ..default
    }
}

/// ash options with validation as for [`wgpu_options`].
fn ash_options(validation: bool) -> AshOptions {
    let default = AshOptions::default();
    AshOptions {
        validation: validation || default.validation,
        ..default
    }
}

impl Backend {
    /// Opens `kind`, with the Vulkan validation layers when `validation` is set or the
    /// environment has `VRRT_VALIDATION=1`. Returns the backend and why it was chosen (for `auto`).
    pub fn open(kind: BackendKind, validation: bool) -> Result<(Backend, String), BackendError> {
        match kind {
            BackendKind::Cpu => Ok((Backend::Cpu(CpuExecutor::new()), "asked for".into())),
            BackendKind::Wgpu => {
                let exec = WgpuExecutor::new_headless(wgpu_options(validation)).map_err(err)?;
                Ok((Backend::Wgpu(Box::new(exec)), "asked for".into()))
            }
            BackendKind::Ash => {
                let exec = AshExecutor::new_headless(ash_options(validation)).map_err(err)?;
                Ok((Backend::Ash(Box::new(exec)), "asked for".into()))
            }
            BackendKind::Auto => Ok(Self::auto(validation)),
        }
    }

    fn auto(validation: bool) -> (Backend, String) {
        let mut notes = Vec::new();
        match WgpuExecutor::new_headless(wgpu_options(validation)) {
            Ok(exec) => {
                let info = exec.adapter_info();
                if matches!(
                    info.device_type,
                    wgpu::DeviceType::DiscreteGpu | wgpu::DeviceType::IntegratedGpu
                ) {
                    let why = format!(
                        "wgpu found a hardware GPU: {} ({:?})",
                        info.name, info.device_type
                    );
                    return (Backend::Wgpu(Box::new(exec)), why);
                }
                notes.push(format!("wgpu: only {} ({:?})", info.name, info.device_type));
            }
            Err(e) => notes.push(format!("wgpu: {e}")),
        }
        match AshExecutor::new_headless(ash_options(validation)) {
            Ok(exec) => {
                let info = exec.adapter_info();
                if matches!(
                    info.adapter_type,
                    AdapterType::DiscreteGpu | AdapterType::IntegratedGpu
                ) {
                    let why = format!(
                        "ash found a hardware GPU: {} ({:?})",
                        info.name, info.adapter_type
                    );
                    return (Backend::Ash(Box::new(exec)), why);
                }
                notes.push(format!("ash: only {} ({:?})", info.name, info.adapter_type));
            }
            Err(e) => notes.push(format!("ash: {e}")),
        }
        (
            Backend::Cpu(CpuExecutor::new()),
            format!(
                "no hardware GPU ({}); the native CPU backend beats a software Vulkan device",
                notes.join("; ")
            ),
        )
    }

    /// The device it runs on, in words.
    pub fn device(&self) -> String {
        match self {
            Backend::Cpu(_) => {
                let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
                match vrrt_core::executor::cpu_lanes() {
                    vrrt_core::executor::CpuLanes::Avx512 => {
                        format!("native CPU, {threads} threads")
                    }
                    lanes => format!("native CPU, {threads} threads, lanes limited to {lanes:?}"),
                }
            }
            Backend::Wgpu(e) => format!(
                "{} ({:?})",
                e.adapter_info().name,
                e.adapter_info().device_type
            ),
            Backend::Ash(e) => format!(
                "{} ({:?})",
                e.adapter_info().name,
                e.adapter_info().adapter_type
            ),
        }
    }

    /// Validation-layer and API errors seen so far (0 for the CPU backend).
    pub fn validation_errors(&self) -> u32 {
        match self {
            Backend::Cpu(_) => 0,
            Backend::Wgpu(e) => e.validation_errors(),
            Backend::Ash(e) => e.validation_errors(),
        }
    }

    /// Warns on stderr when the validation layers reported errors (logged as they came).
    pub fn warn_validation_errors(&self) {
        let n = self.validation_errors();
        if n > 0 {
            eprintln!("warning: {n} validation errors were reported");
        }
    }
}

macro_rules! delegate {
    ($self:ident, $e:ident => $call:expr) => {
        match $self {
            Backend::Cpu($e) => $call.map_err(err),
            Backend::Wgpu($e) => $call.map_err(err),
            Backend::Ash($e) => $call.map_err(err),
        }
    };
}

impl Executor for Backend {
    type Error = BackendError;

    fn name(&self) -> &'static str {
        match self {
            Backend::Cpu(e) => e.name(),
            Backend::Wgpu(e) => e.name(),
            Backend::Ash(e) => e.name(),
        }
    }

    fn binding_limit(&self) -> BindingLimit {
        match self {
            Backend::Cpu(e) => e.binding_limit(),
            Backend::Wgpu(e) => e.binding_limit(),
            Backend::Ash(e) => e.binding_limit(),
        }
    }

    fn create_buffer(&mut self, size_bytes: u64) -> Result<BufferId, BackendError> {
        delegate!(self, e => e.create_buffer(size_bytes))
    }

    fn write_buffer(&mut self, buffer: BufferId, data: &[u8]) -> Result<(), BackendError> {
        delegate!(self, e => e.write_buffer(buffer, data))
    }

    fn create_buffer_shared(
        &mut self,
        data: Arc<dyn SharedBytes>,
    ) -> Result<BufferId, BackendError> {
        delegate!(self, e => e.create_buffer_shared(data))
    }

    fn dispatch(&mut self, pass: &Pass<'_>) -> Result<(), BackendError> {
        delegate!(self, e => e.dispatch(pass))
    }

    fn read_buffer(&mut self, buffer: BufferId, out: &mut [u8]) -> Result<(), BackendError> {
        delegate!(self, e => e.read_buffer(buffer, out))
    }

    fn finish(&mut self) -> Result<(), BackendError> {
        delegate!(self, e => e.finish())
    }

    fn timings(&self) -> &[PassTiming] {
        match self {
            Backend::Cpu(e) => e.timings(),
            Backend::Wgpu(e) => e.timings(),
            Backend::Ash(e) => e.timings(),
        }
    }

    fn clear_timings(&mut self) {
        match self {
            Backend::Cpu(e) => e.clear_timings(),
            Backend::Wgpu(e) => e.clear_timings(),
            Backend::Ash(e) => e.clear_timings(),
        }
    }
}
