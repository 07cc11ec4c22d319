//! Counting validation errors without installing a global logger.
//!
//! Two sources feed one [`ValidationLog`] per executor:
//! - **wgpu validation errors** (WebGPU rules checked by wgpu-core): every device operation the
//!   executor performs runs inside an error scope, and a headless executor also installs a
//!   counting [`wgpu::Device::on_uncaptured_error`] handler (so nothing ever panics). An executor
//!   built with [`WgpuExecutor::from_device`](crate::WgpuExecutor::from_device) leaves the
//!   application's handler alone and relies on its scopes.
//! - **Vulkan validation-layer errors**: wgpu-hal forwards the layer's messages to the `log` crate,
//!   which would force a global logger on library users. Instead the executor registers its own
//!   `VK_EXT_debug_utils` messenger on the `VkInstance` behind the device (wgpu enables that
//!   extension with [`wgpu::InstanceFlags::DEBUG`]) and counts every message of severity `ERROR`.
//!   The messenger is destroyed when the executor is dropped.
//!
//! The messenger sees every message of the instance while it lives, including errors caused by
//! other users of the same instance (an engine's own rendering, say).

use ash::vk;
use std::ffi::c_void;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};

use crate::{WgpuError, WgpuExecutor};

/// Messages kept for diagnostics; later ones are only counted.
const MAX_MESSAGES: usize = 64;

/// Validation-layer message ids ignored because they are known false positives of the layer or
/// of wgpu itself (wgpu-hal filters the same ids from its own log output).
const IGNORED_MESSAGE_IDS: &[i32] = &[
    // VUID-StandaloneSpirv-None-10684: https://github.com/gfx-rs/wgpu/issues/7696
    0xb210_f7c2_u32 as i32,
    // VUID-vkCmdEndDebugUtilsLabelEXT-commandBuffer-01912 (layers 1.3.240–1.3.250): debug labels
    // opened and closed in different command buffers.
    0x5614_6426,
];

#[derive(Debug, Default)]
struct LogInner {
    count: AtomicU32,
    messages: Mutex<Vec<String>>,
}

/// A shared count of validation errors, with the first messages kept for diagnostics.
///
/// Cloning shares the same log.
#[derive(Clone, Debug, Default)]
pub struct ValidationLog {
    inner: Arc<LogInner>,
}

impl ValidationLog {
    /// A new, empty log.
    pub fn new() -> Self {
        Self::default()
    }

    /// Errors recorded so far.
    pub fn count(&self) -> u32 {
        self.inner.count.load(Ordering::Relaxed)
    }

    /// The first recorded messages (at most 64), prefixed with their source (`wgpu:` or `vulkan:`).
    pub fn messages(&self) -> Vec<String> {
        match self.inner.messages.lock() {
            Ok(m) => m.clone(),
            Err(poisoned) => poisoned.into_inner().clone(),
        }
    }

    /// Records one error.
    pub fn record(&self, message: String) {
        record(&self.inner, message);
    }

    /// A handler for [`wgpu::Device::on_uncaptured_error`] that records errors instead of
    /// panicking (wgpu's default handler panics).
    pub fn uncaptured_error_handler(&self) -> Arc<dyn wgpu::UncapturedErrorHandler> {
        let log = self.clone();
        Arc::new(move |e: wgpu::Error| log.record(format!("wgpu: {e}")))
    }
}

fn record(inner: &LogInner, message: String) {
    inner.count.fetch_add(1, Ordering::Relaxed);
    let mut m = match inner.messages.lock() {
        Ok(m) => m,
        Err(poisoned) => poisoned.into_inner(),
    };
    if m.len() < MAX_MESSAGES {
        m.push(message);
    }
}

impl WgpuExecutor {
    /// Runs `f` inside error scopes; a captured error is logged and returned.
    pub(crate) fn scoped<T>(&self, f: impl FnOnce() -> T) -> Result<T, WgpuError> {
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
}

/// A `VK_EXT_debug_utils` messenger counting error messages into a [`ValidationLog`].
pub(crate) struct Messenger {
    loader: ash::ext::debug_utils::Instance,
    handle: vk::DebugUtilsMessengerEXT,
    /// Whether `VK_LAYER_KHRONOS_validation` is installed (wgpu enables it with
    /// [`wgpu::InstanceFlags::VALIDATION`]).
    pub(crate) layer_installed: bool,
    // Keeps the callback's user data alive until the messenger is destroyed.
    _log: Arc<LogInner>,
}

impl Messenger {
    /// Registers a messenger on the Vulkan instance behind `device`. `None` when the device is
    /// not a Vulkan device or its instance was created without `VK_EXT_debug_utils`.
    ///
    /// The messenger must be dropped while `device` (or a clone of it) is still alive: the
    /// device keeps the `VkInstance` alive.
    pub(crate) fn register(device: &wgpu::Device, log: &ValidationLog) -> Option<Self> {
        // SAFETY: the hal device is only used to read the instance handles; nothing is destroyed
        // through it, and the guard is dropped at the end of this function.
        let hal = unsafe { device.as_hal::<wgpu::hal::api::Vulkan>() }?;
        let shared = hal.shared_instance();
        if !shared.extensions().contains(&ash::ext::debug_utils::NAME) {
            return None;
        }
        // SAFETY: plain query of the loader.
        let layers =
            unsafe { shared.entry().enumerate_instance_layer_properties() }.unwrap_or_default();
        let layer_installed = layers.iter().any(|l| {
            l.layer_name_as_c_str()
                .is_ok_and(|n| n == c"VK_LAYER_KHRONOS_validation")
        });
        let loader = ash::ext::debug_utils::Instance::new(shared.entry(), shared.raw_instance());
        let user_data = Arc::as_ptr(&log.inner) as *mut c_void;
        let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR)
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                    | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(Some(on_message))
            .user_data(user_data);
        // SAFETY: the extension is enabled on this instance (checked above); `user_data` points
        // into `log.inner`, which the returned value keeps alive until it destroys the messenger.
        let handle = unsafe { loader.create_debug_utils_messenger(&info, None) }.ok()?;
        Some(Messenger {
            loader,
            handle,
            layer_installed,
            _log: log.inner.clone(),
        })
    }
}

impl Drop for Messenger {
    fn drop(&mut self) {
        // SAFETY: created by `register` on this loader's instance, which outlives `self` (see
        // `register`); destroyed exactly once.
        unsafe { self.loader.destroy_debug_utils_messenger(self.handle, None) };
    }
}

unsafe extern "system" fn on_message(
    _severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        if data.is_null() || user_data.is_null() {
            return;
        }
        // SAFETY: `user_data` is the `LogInner` registered with this messenger, alive until the
        // messenger is destroyed; `data` is valid for the duration of the callback.
        let (log, data) = unsafe { (&*(user_data as *const LogInner), &*data) };
        if IGNORED_MESSAGE_IDS.contains(&data.message_id_number) {
            return;
        }
        // SAFETY: as above; the strings are NUL-terminated or null.
        let text = unsafe { data.message_as_c_str() }
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        record(log, format!("vulkan: {text}"));
    }));
    vk::FALSE
}
