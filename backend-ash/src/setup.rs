//! Headless instance and device creation, adapter selection and the validation messenger.

use crate::spirv::{cap, ModuleInfo};
use crate::{AdapterInfo, AdapterType, AshError};
use ash::vk;
use std::ffi::{c_char, c_void, CStr};
use std::io::Write;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Counts what the validation messenger reports.
#[derive(Debug, Default)]
pub(crate) struct DebugState {
    pub errors: AtomicU32,
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    let counted = severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR)
        || (severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING)
            && types.contains(vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION));
    if counted && !user.is_null() {
        // SAFETY: `user` is the `Arc<DebugState>` kept alive by the executor (or by instance
        // creation) for as long as the messenger exists.
        unsafe { &*(user as *const DebugState) }
            .errors
            .fetch_add(1, Ordering::Relaxed);
    }
    // SAFETY: the layer passes valid callback data for the duration of the call.
    let message = unsafe { data.as_ref().and_then(|d| d.message_as_c_str()) }
        .map(|m| m.to_string_lossy().into_owned())
        .unwrap_or_default();
    let _ = writeln!(
        std::io::stderr(),
        "[vulkan {severity:?} {types:?}] {message}"
    );
    vk::FALSE
}

/// What the executor keeps of a device it created itself.
pub(crate) struct Owned {
    /// Keeps the loader library loaded until the instance is destroyed.
    pub _entry: ash::Entry,
    pub messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
}

/// A freshly created instance and device.
pub(crate) struct Headless {
    pub owned: Owned,
    pub debug: Option<Arc<DebugState>>,
    pub instance: ash::Instance,
    pub device: ash::Device,
    pub physical_device: vk::PhysicalDevice,
    pub queue_family_index: u32,
    pub queue: vk::Queue,
}

fn no_adapter(reason: impl Into<String>) -> AshError {
    AshError::NoAdapter(reason.into())
}

fn messenger_info(state: &Arc<DebugState>) -> vk::DebugUtilsMessengerCreateInfoEXT<'static> {
    vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(
            vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
        )
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(debug_callback))
        .user_data(Arc::as_ptr(state) as *mut c_void)
}

/// Adapter type rank: discrete first.
fn rank(t: AdapterType) -> u32 {
    match t {
        AdapterType::DiscreteGpu => 0,
        AdapterType::IntegratedGpu => 1,
        AdapterType::VirtualGpu => 2,
        AdapterType::Cpu => 3,
        AdapterType::Other => 4,
    }
}

pub(crate) fn adapter_info(
    instance: &ash::Instance,
    pd: vk::PhysicalDevice,
) -> (AdapterInfo, vk::PhysicalDeviceLimits) {
    // SAFETY: `pd` belongs to `instance`.
    let props = unsafe { instance.get_physical_device_properties(pd) };
    let name = props
        .device_name_as_c_str()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let adapter_type = match props.device_type {
        vk::PhysicalDeviceType::DISCRETE_GPU => AdapterType::DiscreteGpu,
        vk::PhysicalDeviceType::INTEGRATED_GPU => AdapterType::IntegratedGpu,
        vk::PhysicalDeviceType::VIRTUAL_GPU => AdapterType::VirtualGpu,
        vk::PhysicalDeviceType::CPU => AdapterType::Cpu,
        _ => AdapterType::Other,
    };
    let info = AdapterInfo {
        name,
        adapter_type,
        vendor_id: props.vendor_id,
        device_id: props.device_id,
        api_version: props.api_version,
        driver_version: props.driver_version,
        timestamps: false,
        timestamp_period_ns: props.limits.timestamp_period,
    };
    (info, props.limits)
}

/// The largest single allocation the device allows (`maxMemoryAllocationSize`, Vulkan 1.1), so a
/// buffer beyond it is refused with the limit's name instead of a driver error.
pub(crate) fn max_allocation(instance: &ash::Instance, pd: vk::PhysicalDevice) -> u64 {
    let mut m3 = vk::PhysicalDeviceMaintenance3Properties::default();
    let mut props = vk::PhysicalDeviceProperties2::default().push_next(&mut m3);
    // SAFETY: `pd` belongs to `instance`, which is Vulkan 1.1 or later (checked at creation).
    unsafe { instance.get_physical_device_properties2(pd, &mut props) };
    m3.max_memory_allocation_size
}

/// Device features the module needs, as far as this device supports them; `None` if it lacks a
/// required one.
struct Features {
    core: vk::PhysicalDeviceFeatures,
    v11: vk::PhysicalDeviceVulkan11Features<'static>,
    v12: vk::PhysicalDeviceVulkan12Features<'static>,
}

fn features_for(
    instance: &ash::Instance,
    pd: vk::PhysicalDevice,
    module: &ModuleInfo,
) -> Result<Features, String> {
    let mut v11 = vk::PhysicalDeviceVulkan11Features::default();
    let mut v12 = vk::PhysicalDeviceVulkan12Features::default();
    let mut f2 = vk::PhysicalDeviceFeatures2::default()
        .push_next(&mut v11)
        .push_next(&mut v12);
    // SAFETY: device supports Vulkan 1.2 (checked by the caller), so these structs are known.
    unsafe { instance.get_physical_device_features2(pd, &mut f2) };
    let core_sup = f2.features;
    let (v11, v12) = (v11, v12);
    let mut want = Features {
        core: vk::PhysicalDeviceFeatures::default(),
        v11: vk::PhysicalDeviceVulkan11Features::default(),
        v12: vk::PhysicalDeviceVulkan12Features::default(),
    };
    let need = |c: u32| module.has_capability(c);
    let check = |needed: bool, supported: vk::Bool32, name: &str, enable: &mut vk::Bool32| {
        if needed && supported == vk::FALSE {
            return Err(format!("lacks {name}"));
        }
        if needed {
            *enable = vk::TRUE;
        }
        Ok(())
    };
    // rust-gpu's Vulkan targets always declare VulkanMemoryModel: required regardless.
    check(
        true,
        v12.vulkan_memory_model,
        "vulkanMemoryModel",
        &mut want.v12.vulkan_memory_model,
    )?;
    // Optional but enabled when supported (the module may use device-scope atomics).
    if v12.vulkan_memory_model_device_scope == vk::TRUE {
        want.v12.vulkan_memory_model_device_scope = vk::TRUE;
    }
    check(
        need(cap::VULKAN_MEMORY_MODEL_DEVICE_SCOPE),
        v12.vulkan_memory_model_device_scope,
        "vulkanMemoryModelDeviceScope",
        &mut want.v12.vulkan_memory_model_device_scope,
    )?;
    check(
        need(cap::INT64),
        core_sup.shader_int64,
        "shaderInt64",
        &mut want.core.shader_int64,
    )?;
    check(
        need(cap::INT16),
        core_sup.shader_int16,
        "shaderInt16",
        &mut want.core.shader_int16,
    )?;
    check(
        need(cap::FLOAT64),
        core_sup.shader_float64,
        "shaderFloat64",
        &mut want.core.shader_float64,
    )?;
    check(
        need(cap::INT8),
        v12.shader_int8,
        "shaderInt8",
        &mut want.v12.shader_int8,
    )?;
    check(
        need(cap::FLOAT16),
        v12.shader_float16,
        "shaderFloat16",
        &mut want.v12.shader_float16,
    )?;
    check(
        need(cap::STORAGE_BUFFER_8BIT_ACCESS),
        v12.storage_buffer8_bit_access,
        "storageBuffer8BitAccess",
        &mut want.v12.storage_buffer8_bit_access,
    )?;
    check(
        need(cap::STORAGE_BUFFER_16BIT_ACCESS),
        v11.storage_buffer16_bit_access,
        "storageBuffer16BitAccess",
        &mut want.v11.storage_buffer16_bit_access,
    )?;
    Ok(want)
}

/// Whether `exts` lists the extension `name`.
fn has_ext(exts: &[vk::ExtensionProperties], name: &CStr) -> bool {
    exts.iter().any(|e| e.extension_name_as_c_str() == Ok(name))
}

/// The validation layer and its debug messenger's extension, added to `layers` and
/// `extensions` (and synchronization validation where asked and available): the messenger's
/// state, and whether synchronization validation is on. Refused with a clear message, not
/// silently skipped, when the layer or `VK_EXT_debug_utils` is missing: validation was asked for.
fn enable_validation(
    entry: &ash::Entry,
    instance_exts: &[vk::ExtensionProperties],
    sync_validation: bool,
    layers: &mut Vec<*const c_char>,
    extensions: &mut Vec<*const c_char>,
) -> Result<(Option<Arc<DebugState>>, bool), AshError> {
    // SAFETY: valid entry.
    let available = unsafe { entry.enumerate_instance_layer_properties() }.unwrap_or_default();
    if !available
        .iter()
        .any(|l| l.layer_name_as_c_str() == Ok(VALIDATION_LAYER))
    {
        return Err(AshError::ValidationUnavailable(
            "layer VK_LAYER_KHRONOS_validation is not installed (Debian: vulkan-validationlayers)"
                .into(),
        ));
    }
    layers.push(VALIDATION_LAYER.as_ptr());
    // SAFETY: valid entry, layer present.
    let layer_exts =
        unsafe { entry.enumerate_instance_extension_properties(Some(VALIDATION_LAYER)) }
            .unwrap_or_default();
    if !has_ext(instance_exts, ash::ext::debug_utils::NAME)
        && !has_ext(&layer_exts, ash::ext::debug_utils::NAME)
    {
        return Err(AshError::ValidationUnavailable(
            "VK_EXT_debug_utils is not available".into(),
        ));
    }
    extensions.push(ash::ext::debug_utils::NAME.as_ptr());
    let sync = sync_validation && has_ext(&layer_exts, ash::ext::validation_features::NAME);
    if sync {
        extensions.push(ash::ext::validation_features::NAME.as_ptr());
    }
    Ok((Some(Arc::new(DebugState::default())), sync))
}

/// The system's Vulkan loader, if it offers Vulkan 1.1 or later.
fn load_entry() -> Result<ash::Entry, AshError> {
    // SAFETY: loading the system Vulkan loader; failure is reported, not fatal.
    let entry = unsafe { ash::Entry::load() }
        .map_err(|e| no_adapter(format!("cannot load the Vulkan loader ({e})")))?;
    // SAFETY: valid entry.
    let version = unsafe { entry.try_enumerate_instance_version() }
        .map_err(|e| no_adapter(format!("vkEnumerateInstanceVersion: {e}")))?
        .unwrap_or(vk::API_VERSION_1_0);
    if version < vk::API_VERSION_1_1 {
        return Err(no_adapter("the Vulkan loader only supports Vulkan 1.0"));
    }
    Ok(entry)
}

/// Creates an instance (with validation if asked) and a device on the best adapter.
pub(crate) fn create(
    validation: bool,
    sync_validation: bool,
    module: &ModuleInfo,
) -> Result<Headless, AshError> {
    let entry = load_entry()?;
    // SAFETY: valid entry.
    let instance_exts =
        unsafe { entry.enumerate_instance_extension_properties(None) }.unwrap_or_default();
    let mut extensions: Vec<*const c_char> = Vec::new();
    let mut layers: Vec<*const c_char> = Vec::new();
    let mut flags = vk::InstanceCreateFlags::empty();
    if has_ext(&instance_exts, ash::khr::portability_enumeration::NAME) {
        extensions.push(ash::khr::portability_enumeration::NAME.as_ptr());
        flags |= vk::InstanceCreateFlags::ENUMERATE_PORTABILITY_KHR;
    }
    let (debug, sync) = if validation {
        enable_validation(
            &entry,
            &instance_exts,
            sync_validation,
            &mut layers,
            &mut extensions,
        )?
    } else {
        (None, false)
    };

    let app = vk::ApplicationInfo::default()
        .application_name(c"vrrt")
        .engine_name(c"vrrt-ash")
        .api_version(vk::API_VERSION_1_2);
    let mut create = vk::InstanceCreateInfo::default()
        .application_info(&app)
        .enabled_layer_names(&layers)
        .enabled_extension_names(&extensions)
        .flags(flags);
    // Messages of vkCreateInstance/vkDestroyInstance go to a messenger chained here.
    let mut early = debug.as_ref().map(messenger_info);
    if let Some(early) = early.as_mut() {
        create = create.push_next(early);
    }
    let enabled_checks = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
    let mut checks =
        vk::ValidationFeaturesEXT::default().enabled_validation_features(&enabled_checks);
    if sync {
        create = create.push_next(&mut checks);
    }
    // SAFETY: valid create info; pointers outlive the call.
    let instance = unsafe { entry.create_instance(&create, None) }
        .map_err(|e| no_adapter(format!("vkCreateInstance: {e}")))?;

    let messenger = match &debug {
        Some(state) => {
            let du = ash::ext::debug_utils::Instance::new(&entry, &instance);
            // SAFETY: extension enabled; `state` outlives the messenger (kept by the executor).
            match unsafe { du.create_debug_utils_messenger(&messenger_info(state), None) } {
                Ok(m) => Some((du, m)),
                Err(e) => {
                    // SAFETY: nothing else was created from the instance.
                    unsafe { instance.destroy_instance(None) };
                    return Err(AshError::vk("vkCreateDebugUtilsMessengerEXT")(e));
                }
            }
        }
        None => None,
    };
    let owned = Owned {
        _entry: entry,
        messenger,
    };
    let destroy_instance = |owned: &Owned| {
        // SAFETY: no device was created (or it was destroyed); children destroyed first.
        unsafe {
            if let Some((du, m)) = &owned.messenger {
                du.destroy_debug_utils_messenger(*m, None);
            }
            instance.destroy_instance(None);
        }
    };
    match create_device(&instance, module) {
        Ok((device, physical_device, queue_family_index)) => {
            // SAFETY: queue 0 of this family was requested at device creation.
            let queue = unsafe { device.get_device_queue(queue_family_index, 0) };
            Ok(Headless {
                owned,
                debug,
                instance,
                device,
                physical_device,
                queue_family_index,
                queue,
            })
        }
        Err(e) => {
            destroy_instance(&owned);
            Err(e)
        }
    }
}

fn create_device(
    instance: &ash::Instance,
    module: &ModuleInfo,
) -> Result<(ash::Device, vk::PhysicalDevice, u32), AshError> {
    // SAFETY: valid instance.
    let devices = unsafe { instance.enumerate_physical_devices() }
        .map_err(|e| no_adapter(format!("vkEnumeratePhysicalDevices: {e}")))?;
    if devices.is_empty() {
        return Err(no_adapter("no physical device"));
    }
    let mut rejected = Vec::new();
    let mut candidates = Vec::new();
    for pd in devices {
        let (info, _) = adapter_info(instance, pd);
        if info.api_version < vk::API_VERSION_1_2 {
            rejected.push(format!("{}: Vulkan 1.2 not supported", info.name));
            continue;
        }
        // SAFETY: `pd` belongs to `instance`.
        let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        let compute: Vec<(u32, &vk::QueueFamilyProperties)> = (0u32..)
            .zip(families.iter())
            .filter(|(_, f)| f.queue_flags.contains(vk::QueueFlags::COMPUTE) && f.queue_count > 0)
            .collect();
        // Prefer a family with timestamps.
        let Some(&(family, _)) = compute
            .iter()
            .find(|(_, f)| f.timestamp_valid_bits > 0)
            .or_else(|| compute.first())
        else {
            rejected.push(format!("{}: no compute queue", info.name));
            continue;
        };
        match features_for(instance, pd, module) {
            Ok(features) => candidates.push((rank(info.adapter_type), pd, family, features)),
            Err(why) => rejected.push(format!("{}: {why}", info.name)),
        }
    }
    // Stable sort: among equal types, the loader's order.
    candidates.sort_by_key(|c| c.0);
    let Some((_, pd, family, mut features)) = candidates.into_iter().next() else {
        return Err(no_adapter(format!(
            "no suitable physical device ({})",
            rejected.join("; ")
        )));
    };

    // SAFETY: `pd` belongs to `instance`.
    let dev_exts =
        unsafe { instance.enumerate_device_extension_properties(pd) }.unwrap_or_default();
    let mut extensions = Vec::new();
    // Required by the spec where the implementation offers it (MoltenVK).
    let portability = c"VK_KHR_portability_subset";
    if dev_exts
        .iter()
        .any(|e| e.extension_name_as_c_str() == Ok(portability))
    {
        extensions.push(portability.as_ptr());
    }
    let priorities = [1.0f32];
    let queues = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(family)
        .queue_priorities(&priorities)];
    let mut f2 = vk::PhysicalDeviceFeatures2::default().features(features.core);
    let create = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queues)
        .enabled_extension_names(&extensions)
        .push_next(&mut f2)
        .push_next(&mut features.v11)
        .push_next(&mut features.v12);
    // SAFETY: valid create info; features checked as supported.
    let device = unsafe { instance.create_device(pd, &create, None) }
        .map_err(|e| no_adapter(format!("vkCreateDevice: {e}")))?;
    Ok((device, pd, family))
}
