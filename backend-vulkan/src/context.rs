//! The Vulkan instance and logical device of one optik device: device choice, extensions and
//! features, the validation layer and its messenger.

use crate::error::VkResultExt;
use crate::probe::{self, REQUIRED_EXTENSIONS, VulkanDeviceInfo};
use crate::validation::{self, MessageLog};
use ash::vk;
use optik_api::{Error, Result};
use std::sync::Arc;

/// How to open a Vulkan device. [`VulkanOptions::from_env`] reads the environment; tests build
/// one directly.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VulkanOptions {
    /// Enable the Khronos validation layer and collect its messages
    /// ([`VulkanBackend::take_validation_messages`]). `OPTIK_VALIDATION=1`.
    ///
    /// [`VulkanBackend::take_validation_messages`]: crate::VulkanBackend::take_validation_messages
    pub validation: bool,
    /// Which device: an index of [`fn@crate::probe`]'s list or a part of its name.
    /// `OPTIK_VULKAN_DEVICE`. Default: the first usable device, discrete GPUs first.
    pub device: Option<String>,
    /// Keep user buffers in device-local memory and copy through staging buffers even where
    /// all memory is host-visible (lavapipe), to exercise the path discrete GPUs take.
    /// `OPTIK_VULKAN_STAGING=1`.
    pub force_staging: bool,
    /// Keep a pipeline cache on disk (`$OPTIK_CACHE_PATH`, else `$XDG_CACHE_HOME/optik`, else
    /// `~/.cache/optik`); off with `OPTIK_CACHE_DISABLE=1`.
    pub pipeline_cache: bool,
    /// The pipeline cache's directory, instead of the one the environment names.
    pub cache_dir: Option<std::path::PathBuf>,
    /// Caps the invocations of one `vkCmdTraceRaysKHR` below the device's limits, so that
    /// splitting a launch into several dispatches is tested with small launches. `None`: the
    /// device's limits alone.
    pub max_dispatch_invocations: Option<u64>,
    /// Whether `TriangleTest::Watertight` (the default) may use the driver's triangles
    /// where they can serve (docs/vulkan-backend.md §2.4): `Some(true)` when the driver
    /// passed optik's check (`optik::triangle_check`), `Some(false)` to keep optik's
    /// triangle stage for every triangle; `None` lets `optik::open` run the check (cached
    /// per driver) and leaves the backend's own `open` on optik's triangles.
    /// `OPTIK_VULKAN_DRIVER_TRIANGLES=1` or `0`.
    pub driver_triangles: Option<bool>,
}

impl VulkanOptions {
    /// The options the environment asks for.
    pub fn from_env() -> Self {
        let flag = |name: &str| {
            std::env::var(name).is_ok_and(|v| v == "1" || v.eq_ignore_ascii_case("true"))
        };
        VulkanOptions {
            validation: validation::requested_by_env(),
            device: std::env::var("OPTIK_VULKAN_DEVICE")
                .ok()
                .filter(|s| !s.is_empty()),
            force_staging: flag("OPTIK_VULKAN_STAGING"),
            pipeline_cache: !flag("OPTIK_CACHE_DISABLE"),
            cache_dir: None,
            max_dispatch_invocations: None,
            driver_triangles: match std::env::var("OPTIK_VULKAN_DRIVER_TRIANGLES").as_deref() {
                Ok("1") | Ok("true") => Some(true),
                Ok("0") | Ok("false") => Some(false),
                _ => None,
            },
        }
    }
}

impl Default for VulkanOptions {
    fn default() -> Self {
        Self::from_env()
    }
}

/// An instance, a device with the ray tracing extensions, its queue and extension loaders.
pub struct Context {
    /// The Vulkan loader.
    pub entry: ash::Entry,
    /// The instance.
    pub instance: ash::Instance,
    messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    /// The validation layer's messages (empty without validation).
    pub log: Arc<MessageLog>,
    /// The physical device in use.
    pub physical: vk::PhysicalDevice,
    /// The logical device.
    pub device: ash::Device,
    /// The one queue optik submits to.
    pub queue: vk::Queue,
    /// Its family.
    pub queue_family: u32,
    /// `VK_KHR_acceleration_structure` functions.
    pub accel: ash::khr::acceleration_structure::Device,
    /// `VK_KHR_ray_tracing_pipeline` functions.
    pub rt: ash::khr::ray_tracing_pipeline::Device,
    /// The device's properties.
    pub info: VulkanDeviceInfo,
    /// Memory types and heaps.
    pub memory: vk::PhysicalDeviceMemoryProperties,
    /// User buffers live in device-local memory and move through staging buffers.
    pub staging: bool,
    /// The most invocations one `vkCmdTraceRaysKHR` of a launch runs
    /// (`maxRayDispatchInvocationCount`, or [`VulkanOptions::max_dispatch_invocations`]).
    pub dispatch_invocations: u64,
}

// SAFETY: ash's handles are plain values; optik serialises every use of the device's
// externally synchronised objects (queue, pools) behind the device's lock.
unsafe impl Send for Context {}
// SAFETY: as above.
unsafe impl Sync for Context {}

impl Context {
    /// Creates the device `options` ask for, on the process's kept instance
    /// ([`crate::instance`]).
    pub fn new(options: &VulkanOptions) -> Result<Context> {
        let shared = crate::instance::shared(options.validation)?;
        let (entry, instance) = (shared.entry.clone(), shared.instance.clone());
        let log = Arc::new(MessageLog::default());
        for m in shared.creation_log.take() {
            log.push(m);
        }
        // Every messenger of an instance hears every message of it: with several devices open
        // at once on the validated instance, a message reaches each of their logs.
        let messenger = match &shared.debug_utils {
            Some(loader) => {
                let info = validation::messenger_info(&log);
                // SAFETY: the log outlives the messenger (Context drops the messenger first).
                let m = unsafe { loader.create_debug_utils_messenger(&info, None) }
                    .or_vk("vkCreateDebugUtilsMessengerEXT")?;
                Some((loader.clone(), m))
            }
            None => None,
        };
        match Self::with_instance(entry.clone(), instance.clone(), options) {
            Ok((physical, device, queue_family, info)) => {
                // SAFETY: valid device and queue family.
                let queue = unsafe { device.get_device_queue(queue_family, 0) };
                let accel = ash::khr::acceleration_structure::Device::new(&instance, &device);
                let rt = ash::khr::ray_tracing_pipeline::Device::new(&instance, &device);
                // SAFETY: `physical` belongs to the instance.
                let memory = unsafe { instance.get_physical_device_memory_properties(physical) };
                let staging = info.separate_device_memory || options.force_staging;
                let dispatch_invocations = options
                    .max_dispatch_invocations
                    .unwrap_or(u64::MAX)
                    .min(info.max_ray_dispatch_invocation_count as u64)
                    .max(1);
                Ok(Context {
                    entry,
                    instance,
                    messenger,
                    log,
                    physical,
                    device,
                    queue,
                    queue_family,
                    accel,
                    rt,
                    info,
                    memory,
                    staging,
                    dispatch_invocations,
                })
            }
            Err(e) => {
                // SAFETY: no device was created; the messenger goes, the instance is kept.
                unsafe {
                    if let Some((loader, m)) = &messenger {
                        loader.destroy_debug_utils_messenger(*m, None);
                    }
                }
                Err(e)
            }
        }
    }

    /// Picks the physical device and creates the logical device.
    fn with_instance(
        _entry: ash::Entry,
        instance: ash::Instance,
        options: &VulkanOptions,
    ) -> Result<(vk::PhysicalDevice, ash::Device, u32, VulkanDeviceInfo)> {
        // SAFETY: valid instance.
        let physicals =
            unsafe { instance.enumerate_physical_devices() }.or_vk("vkEnumeratePhysicalDevices")?;
        let infos: Vec<VulkanDeviceInfo> = physicals
            .iter()
            .enumerate()
            .map(|(i, p)| probe::device_info(&instance, *p, i))
            .collect::<Result<_>>()?;
        let describe = |infos: &[VulkanDeviceInfo]| {
            infos
                .iter()
                .map(|i| {
                    if i.usable() {
                        format!("[{}] {} (usable)", i.index, i.name)
                    } else {
                        format!("[{}] {} lacks {}", i.index, i.name, i.missing.join(", "))
                    }
                })
                .collect::<Vec<_>>()
                .join("; ")
        };
        if infos.is_empty() {
            return Err(Error::unsupported(
                "Vulkan finds no device; install a driver with ray tracing (lavapipe: mesa-vulkan-drivers >= 24.1)",
            ));
        }
        let chosen = match &options.device {
            Some(want) => {
                let found = match want.parse::<usize>() {
                    Ok(i) => infos.get(i),
                    Err(_) => infos
                        .iter()
                        .find(|i| i.name.to_lowercase().contains(&want.to_lowercase())),
                };
                let info = found.ok_or_else(|| {
                    Error::invalid(format!(
                        "OPTIK_VULKAN_DEVICE={want} names no Vulkan device; the devices are: {}",
                        describe(&infos)
                    ))
                })?;
                if !info.usable() {
                    return Err(Error::unsupported(format!(
                        "the Vulkan device {} cannot run optik: it lacks {}",
                        info.name,
                        info.missing.join(", ")
                    )));
                }
                info
            }
            None => {
                let rank = |t: vk::PhysicalDeviceType| match t {
                    vk::PhysicalDeviceType::DISCRETE_GPU => 0,
                    vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
                    vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
                    vk::PhysicalDeviceType::CPU => 3,
                    _ => 4,
                };
                infos
                    .iter()
                    .filter(|i| i.usable())
                    .min_by_key(|i| (rank(i.device_type), i.index))
                    .ok_or_else(|| {
                        Error::unsupported(format!(
                            "no Vulkan device has ray tracing pipelines: {}; optik needs {}",
                            describe(&infos),
                            REQUIRED_EXTENSIONS
                                .iter()
                                .map(|n| n.to_string_lossy())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ))
                    })?
            }
        };
        let physical = physicals[chosen.index];
        // SAFETY: valid physical device.
        let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
        let queue_family = families
            .iter()
            .position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE))
            .ok_or_else(|| {
                Error::unsupported(format!(
                    "the Vulkan device {} has no compute queue",
                    chosen.name
                ))
            })? as u32;
        let priorities = [1.0f32];
        let queues = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let extension_names: Vec<*const std::ffi::c_char> =
            REQUIRED_EXTENSIONS.iter().map(|n| n.as_ptr()).collect();
        let mut f12 = vk::PhysicalDeviceVulkan12Features::default().buffer_device_address(true);
        let mut fas = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default()
            .acceleration_structure(true);
        // Primitive culling lets pipelines skip the primitive types their scene lacks.
        let mut frt = vk::PhysicalDeviceRayTracingPipelineFeaturesKHR::default()
            .ray_tracing_pipeline(true)
            .ray_traversal_primitive_culling(chosen.primitive_culling);
        // f64 keeps the watertight triangle test's exact fallback (optik's triangle stage).
        let core = vk::PhysicalDeviceFeatures::default().shader_float64(chosen.shader_float64);
        let create = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queues)
            .enabled_extension_names(&extension_names)
            .enabled_features(&core)
            .push_next(&mut f12)
            .push_next(&mut fas)
            .push_next(&mut frt);
        let devices = optik_core::vulkan_loader::changing_devices();
        // SAFETY: the device supports every extension and feature enabled (probed above).
        let device = unsafe { instance.create_device(physical, &create, None) };
        drop(devices);
        let device = device.or_vk("vkCreateDevice")?;
        Ok((physical, device, queue_family, chosen.clone()))
    }

    /// Index of a memory type in `allowed` (a bit mask) with `required` flags, preferring ones
    /// that also have `preferred` and lack `avoided`.
    pub fn memory_type(
        &self,
        allowed: u32,
        required: vk::MemoryPropertyFlags,
        preferred: vk::MemoryPropertyFlags,
        avoided: vk::MemoryPropertyFlags,
    ) -> Option<u32> {
        let types = &self.memory.memory_types[..self.memory.memory_type_count as usize];
        let candidates = || {
            types
                .iter()
                .enumerate()
                .filter(|(i, t)| allowed & (1 << i) != 0 && t.property_flags.contains(required))
        };
        candidates()
            .find(|(_, t)| {
                t.property_flags.contains(preferred) && !t.property_flags.intersects(avoided)
            })
            .or_else(|| candidates().find(|(_, t)| t.property_flags.contains(preferred)))
            .or_else(|| candidates().next())
            .map(|(i, _)| i as u32)
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        // SAFETY: the owner destroyed every object created from the device before dropping
        // the context; the messenger goes before the log it points to.
        unsafe {
            let _ = self.device.device_wait_idle();
            let devices = optik_core::vulkan_loader::changing_devices();
            self.device.destroy_device(None);
            drop(devices);
            if let Some((loader, m)) = &self.messenger {
                loader.destroy_debug_utils_messenger(*m, None);
            }
            // The instance is kept for the process's life (crate::instance says why).
        }
    }
}
