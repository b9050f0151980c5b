//! What each Vulkan device offers: [`probe`] lists every physical device with the properties
//! optik uses (printed by `optik info`), and says what a device lacks for optik.

use crate::error::VkResultExt;
use ash::vk;
use optik_api::{Error, Result};
use std::ffi::CStr;
use std::fmt;
use std::sync::OnceLock;

/// Device extensions optik needs.
pub const REQUIRED_EXTENSIONS: [&CStr; 3] = [
    ash::khr::acceleration_structure::NAME,
    ash::khr::ray_tracing_pipeline::NAME,
    ash::khr::deferred_host_operations::NAME,
];

/// Which ray tracing extensions a device has.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RayTracingExtensions {
    /// `VK_KHR_acceleration_structure` (needed).
    pub acceleration_structure: bool,
    /// `VK_KHR_ray_tracing_pipeline` (needed).
    pub ray_tracing_pipeline: bool,
    /// `VK_KHR_deferred_host_operations` (needed by the former two).
    pub deferred_host_operations: bool,
    /// `VK_KHR_ray_query` (not used).
    pub ray_query: bool,
    /// `VK_KHR_ray_tracing_maintenance1` (not used).
    pub ray_tracing_maintenance1: bool,
    /// `VK_KHR_ray_tracing_position_fetch` (not used: vertex access is emulated).
    pub ray_tracing_position_fetch: bool,
    /// `VK_EXT_opacity_micromap` (not used: micromaps are unsupported on this backend).
    pub opacity_micromap: bool,
    /// `VK_NV_ray_tracing_motion_blur` (not used).
    pub nv_motion_blur: bool,
}

impl RayTracingExtensions {
    fn from_names(names: &[String]) -> Self {
        let has = |n: &CStr| names.iter().any(|x| x.as_bytes() == n.to_bytes());
        RayTracingExtensions {
            acceleration_structure: has(ash::khr::acceleration_structure::NAME),
            ray_tracing_pipeline: has(ash::khr::ray_tracing_pipeline::NAME),
            deferred_host_operations: has(ash::khr::deferred_host_operations::NAME),
            ray_query: has(ash::khr::ray_query::NAME),
            ray_tracing_maintenance1: has(ash::khr::ray_tracing_maintenance1::NAME),
            ray_tracing_position_fetch: has(c"VK_KHR_ray_tracing_position_fetch"),
            opacity_micromap: has(c"VK_EXT_opacity_micromap"),
            nv_motion_blur: has(c"VK_NV_ray_tracing_motion_blur"),
        }
    }

    fn names(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        for (on, name) in [
            (self.acceleration_structure, "VK_KHR_acceleration_structure"),
            (self.ray_tracing_pipeline, "VK_KHR_ray_tracing_pipeline"),
            (
                self.deferred_host_operations,
                "VK_KHR_deferred_host_operations",
            ),
            (self.ray_query, "VK_KHR_ray_query"),
            (
                self.ray_tracing_maintenance1,
                "VK_KHR_ray_tracing_maintenance1",
            ),
            (
                self.ray_tracing_position_fetch,
                "VK_KHR_ray_tracing_position_fetch",
            ),
            (self.opacity_micromap, "VK_EXT_opacity_micromap"),
            (self.nv_motion_blur, "VK_NV_ray_tracing_motion_blur"),
        ] {
            if on {
                v.push(name);
            }
        }
        v
    }
}

/// One physical device and the properties optik uses, read from the driver.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VulkanDeviceInfo {
    /// Index in the instance's device list (`OPTIK_VULKAN_DEVICE=<index>` picks it).
    pub index: usize,
    /// Device name.
    pub name: String,
    /// Discrete GPU, integrated GPU, CPU, ...
    pub device_type: vk::PhysicalDeviceType,
    /// PCI vendor id.
    pub vendor_id: u32,
    /// PCI device id.
    pub device_id: u32,
    /// The driver's name (`VkPhysicalDeviceDriverProperties`).
    pub driver_name: String,
    /// The driver's version text.
    pub driver_info: String,
    /// The driver version as the driver encodes it.
    pub driver_version: u32,
    /// The device's Vulkan version (major, minor, patch).
    pub api_version: (u32, u32, u32),
    /// Ray tracing extensions present.
    pub extensions: RayTracingExtensions,
    /// `shaderGroupHandleSize` (0 without ray tracing pipelines).
    pub shader_group_handle_size: u32,
    /// `shaderGroupHandleAlignment`.
    pub shader_group_handle_alignment: u32,
    /// `shaderGroupBaseAlignment`.
    pub shader_group_base_alignment: u32,
    /// `maxRayRecursionDepth`.
    pub max_ray_recursion_depth: u32,
    /// `maxShaderGroupStride`.
    pub max_shader_group_stride: u32,
    /// `maxRayHitAttributeSize`.
    pub max_ray_hit_attribute_size: u32,
    /// `maxRayDispatchInvocationCount`.
    pub max_ray_dispatch_invocation_count: u32,
    /// `maxGeometryCount` of one acceleration structure.
    pub max_geometry_count: u64,
    /// `maxInstanceCount`.
    pub max_instance_count: u64,
    /// `maxPrimitiveCount`.
    pub max_primitive_count: u64,
    /// `minAccelerationStructureScratchOffsetAlignment`.
    pub min_scratch_offset_alignment: u32,
    /// `maxStorageBufferRange`.
    pub max_storage_buffer_range: u32,
    /// `minStorageBufferOffsetAlignment`.
    pub min_storage_buffer_offset_alignment: u64,
    /// `maxUniformBufferRange` (the largest launch parameter block).
    pub max_uniform_buffer_range: u32,
    /// `minUniformBufferOffsetAlignment` (the per-dispatch constants of a split launch share
    /// one buffer at multiples of it).
    pub min_uniform_buffer_offset_alignment: u64,
    /// The `rayTraversalPrimitiveCulling` feature: pipelines can skip triangles or AABBs.
    pub primitive_culling: bool,
    /// The `shaderFloat64` feature: optik's watertight triangle test keeps its exact f64
    /// fallback.
    pub shader_float64: bool,
    /// `maxComputeWorkGroupCount` × `maxComputeWorkGroupSize`, per dimension: the largest
    /// ray dispatch per dimension.
    pub max_launch_dimensions: [u64; 3],
    /// The largest device-local memory heap in bytes.
    pub device_local_heap: u64,
    /// Whether some memory is device-local but not host-visible (a discrete GPU: optik then
    /// keeps buffers there and copies through staging buffers).
    pub separate_device_memory: bool,
    /// `pipelineCacheUUID`.
    pub pipeline_cache_uuid: [u8; 16],
    /// What optik needs that this device lacks; empty when optik can use it.
    pub missing: Vec<String>,
}

impl VulkanDeviceInfo {
    /// Whether optik can run on this device.
    pub fn usable(&self) -> bool {
        self.missing.is_empty()
    }

    /// Whether this is a GPU (discrete, integrated or virtual) rather than a software
    /// implementation such as lavapipe (device type CPU), which runs ray tracing correctly but
    /// far slower than optik's CPU backend: the facade's automatic choice skips it.
    pub fn is_gpu(&self) -> bool {
        matches!(
            self.device_type,
            vk::PhysicalDeviceType::DISCRETE_GPU
                | vk::PhysicalDeviceType::INTEGRATED_GPU
                | vk::PhysicalDeviceType::VIRTUAL_GPU
        )
    }
}

impl fmt::Display for VulkanDeviceInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (a, b, c) = self.api_version;
        writeln!(
            f,
            "[{}] {} ({:?}, vendor {:#06x}, device {:#06x})",
            self.index, self.name, self.device_type, self.vendor_id, self.device_id
        )?;
        writeln!(
            f,
            "    driver: {} {} (version {:#x}), Vulkan {a}.{b}.{c}",
            self.driver_name, self.driver_info, self.driver_version
        )?;
        let ext = self.extensions.names();
        writeln!(
            f,
            "    ray tracing extensions: {}",
            if ext.is_empty() {
                "none".to_string()
            } else {
                ext.join(", ")
            }
        )?;
        if self.extensions.ray_tracing_pipeline {
            writeln!(
                f,
                "    shader groups: handle size {}, handle alignment {}, base alignment {}, max stride {}",
                self.shader_group_handle_size,
                self.shader_group_handle_alignment,
                self.shader_group_base_alignment,
                self.max_shader_group_stride
            )?;
            writeln!(
                f,
                "    rays: max recursion depth {}, max hit attribute size {} bytes, max dispatch invocations {}",
                self.max_ray_recursion_depth,
                self.max_ray_hit_attribute_size,
                self.max_ray_dispatch_invocation_count
            )?;
        }
        if self.extensions.acceleration_structure {
            writeln!(
                f,
                "    acceleration structures: max geometries {}, max instances {}, max primitives {}, scratch alignment {}",
                self.max_geometry_count,
                self.max_instance_count,
                self.max_primitive_count,
                self.min_scratch_offset_alignment
            )?;
        }
        writeln!(
            f,
            "    memory: largest device-local heap {} MiB, {}; max storage buffer range {} MiB",
            self.device_local_heap >> 20,
            if self.separate_device_memory {
                "separate device memory (staging copies)"
            } else {
                "host-visible device memory"
            },
            self.max_storage_buffer_range >> 20
        )?;
        if self.missing.is_empty() {
            write!(f, "    usable by optik")
        } else {
            write!(
                f,
                "    not usable by optik: lacks {}",
                self.missing.join(", ")
            )
        }
    }
}

/// Lists every Vulkan physical device with its properties. An error when no Vulkan loader or
/// instance is available.
pub fn probe() -> Result<Vec<VulkanDeviceInfo>> {
    let instance = &crate::instance::shared(false)?.instance;
    // SAFETY: the kept instance is valid for the process's life.
    let physicals =
        unsafe { instance.enumerate_physical_devices() }.or_vk("vkEnumeratePhysicalDevices")?;
    physicals
        .iter()
        .enumerate()
        .map(|(i, p)| device_info(instance, *p, i))
        .collect()
}

/// The Vulkan loader, loaded once per process and never unloaded (its instances are kept
/// too: [`crate::instance`] says why).
pub(crate) fn load_entry() -> Result<ash::Entry> {
    static ENTRY: OnceLock<std::result::Result<ash::Entry, String>> = OnceLock::new();
    let loaded = ENTRY.get_or_init(|| {
        // SAFETY: loading the system's Vulkan loader; its functions are called per the spec.
        unsafe { ash::Entry::load() }.map_err(|e| e.to_string())
    });
    match loaded {
        Ok(entry) => Ok(entry.clone()),
        Err(e) => Err(Error::unsupported(format!(
            "no Vulkan loader found ({e}); install libvulkan1 and a driver with ray tracing (lavapipe: mesa-vulkan-drivers >= 24.1)"
        ))),
    }
}

/// The Vulkan version optik's instance asks for.
pub(crate) const API_VERSION: u32 = vk::API_VERSION_1_2;

pub(crate) fn check_instance_version(entry: &ash::Entry) -> Result<()> {
    // SAFETY: a global command of the loaded entry.
    let version = unsafe { entry.try_enumerate_instance_version() }
        .or_vk("vkEnumerateInstanceVersion")?
        .unwrap_or(vk::API_VERSION_1_0);
    if version < API_VERSION {
        return Err(Error::unsupported(format!(
            "the Vulkan loader supports Vulkan {}.{}; optik needs 1.2",
            vk::api_version_major(version),
            vk::api_version_minor(version)
        )));
    }
    Ok(())
}

fn c_text(chars: &[std::ffi::c_char]) -> String {
    let bytes: Vec<u8> = chars
        .iter()
        .take_while(|c| **c != 0)
        .map(|c| *c as u8)
        .collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Reads a device's properties and what optik needs that it lacks.
pub(crate) fn device_info(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
    index: usize,
) -> Result<VulkanDeviceInfo> {
    // SAFETY: `physical` comes from this instance.
    let ext_props = unsafe { instance.enumerate_device_extension_properties(physical) }
        .or_vk("vkEnumerateDeviceExtensionProperties")?;
    let ext_names: Vec<String> = ext_props
        .iter()
        .map(|e| c_text(&e.extension_name))
        .collect();
    let extensions = RayTracingExtensions::from_names(&ext_names);
    // SAFETY: as above.
    let base = unsafe { instance.get_physical_device_properties(physical) };
    let api = base.api_version;

    let mut rt = vk::PhysicalDeviceRayTracingPipelinePropertiesKHR::default();
    let mut accel = vk::PhysicalDeviceAccelerationStructurePropertiesKHR::default();
    let mut driver = vk::PhysicalDeviceDriverProperties::default();
    {
        let mut props2 = vk::PhysicalDeviceProperties2::default();
        if api >= vk::API_VERSION_1_2 {
            props2 = props2.push_next(&mut driver);
        }
        if extensions.ray_tracing_pipeline {
            props2 = props2.push_next(&mut rt);
        }
        if extensions.acceleration_structure {
            props2 = props2.push_next(&mut accel);
        }
        // SAFETY: every chained struct belongs to a version or extension the device has.
        unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
    }

    let mut missing = Vec::new();
    let mut primitive_culling = false;
    let mut shader_float64 = false;
    if api < vk::API_VERSION_1_2 {
        missing.push(format!(
            "Vulkan 1.2 (it has {}.{})",
            vk::api_version_major(api),
            vk::api_version_minor(api)
        ));
    }
    for (name, have) in [
        (
            "VK_KHR_acceleration_structure",
            extensions.acceleration_structure,
        ),
        (
            "VK_KHR_ray_tracing_pipeline",
            extensions.ray_tracing_pipeline,
        ),
        (
            "VK_KHR_deferred_host_operations",
            extensions.deferred_host_operations,
        ),
    ] {
        if !have {
            missing.push(name.to_string());
        }
    }
    if missing.is_empty() {
        let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut fas = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default();
        let mut frt = vk::PhysicalDeviceRayTracingPipelineFeaturesKHR::default();
        let mut features2 = vk::PhysicalDeviceFeatures2::default()
            .push_next(&mut f12)
            .push_next(&mut fas)
            .push_next(&mut frt);
        // SAFETY: the device has 1.2 and both extensions (checked above).
        unsafe { instance.get_physical_device_features2(physical, &mut features2) };
        shader_float64 = features2.features.shader_float64 == vk::TRUE;
        primitive_culling = frt.ray_traversal_primitive_culling == vk::TRUE;
        for (name, have) in [
            ("the bufferDeviceAddress feature", f12.buffer_device_address),
            (
                "the accelerationStructure feature",
                fas.acceleration_structure,
            ),
            ("the rayTracingPipeline feature", frt.ray_tracing_pipeline),
        ] {
            if have == vk::FALSE {
                missing.push(name.to_string());
            }
        }
        if rt.max_ray_hit_attribute_size < 32 {
            missing.push(format!(
                "32 bytes of hit attributes (it has {})",
                rt.max_ray_hit_attribute_size
            ));
        }
    }

    // SAFETY: as above.
    let memory = unsafe { instance.get_physical_device_memory_properties(physical) };
    let heaps = &memory.memory_heaps[..memory.memory_heap_count as usize];
    let device_local_heap = heaps
        .iter()
        .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
        .map(|h| h.size)
        .max()
        .unwrap_or(0);
    let types = &memory.memory_types[..memory.memory_type_count as usize];
    let separate_device_memory = types.iter().any(|t| {
        t.property_flags
            .contains(vk::MemoryPropertyFlags::DEVICE_LOCAL)
            && !t
                .property_flags
                .contains(vk::MemoryPropertyFlags::HOST_VISIBLE)
    });
    let limits = &base.limits;
    let max_launch_dimensions: [u64; 3] = std::array::from_fn(|i| {
        limits.max_compute_work_group_count[i] as u64 * limits.max_compute_work_group_size[i] as u64
    });

    Ok(VulkanDeviceInfo {
        index,
        name: c_text(&base.device_name),
        device_type: base.device_type,
        vendor_id: base.vendor_id,
        device_id: base.device_id,
        driver_name: c_text(&driver.driver_name),
        driver_info: c_text(&driver.driver_info),
        driver_version: base.driver_version,
        api_version: (
            vk::api_version_major(api),
            vk::api_version_minor(api),
            vk::api_version_patch(api),
        ),
        extensions,
        shader_group_handle_size: rt.shader_group_handle_size,
        shader_group_handle_alignment: rt.shader_group_handle_alignment,
        shader_group_base_alignment: rt.shader_group_base_alignment,
        max_ray_recursion_depth: rt.max_ray_recursion_depth,
        max_shader_group_stride: rt.max_shader_group_stride,
        max_ray_hit_attribute_size: rt.max_ray_hit_attribute_size,
        max_ray_dispatch_invocation_count: rt.max_ray_dispatch_invocation_count,
        max_geometry_count: accel.max_geometry_count,
        max_instance_count: accel.max_instance_count,
        max_primitive_count: accel.max_primitive_count,
        min_scratch_offset_alignment: accel.min_acceleration_structure_scratch_offset_alignment,
        max_storage_buffer_range: limits.max_storage_buffer_range,
        min_storage_buffer_offset_alignment: limits.min_storage_buffer_offset_alignment,
        max_uniform_buffer_range: limits.max_uniform_buffer_range,
        min_uniform_buffer_offset_alignment: limits.min_uniform_buffer_offset_alignment,
        primitive_culling,
        shader_float64,
        max_launch_dimensions,
        device_local_heap,
        separate_device_memory,
        pipeline_cache_uuid: base.pipeline_cache_uuid,
        missing,
    })
}
