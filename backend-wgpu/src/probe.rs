//! Lists the adapters wgpu finds, with the properties that matter to optik.

use std::fmt;

/// One adapter wgpu can open.
#[derive(Clone, Debug)]
pub struct AdapterReport {
    /// Adapter name ("llvmpipe (LLVM 15.0.6, 256 bits)", "NVIDIA H100").
    pub name: String,
    /// The graphics API wgpu reaches it through.
    pub backend: String,
    /// Integrated, discrete, CPU, ...
    pub device_type: String,
    /// Whether the adapter is a GPU (discrete, integrated or virtual) rather than a software
    /// rasteriser such as llvmpipe (`DeviceType::Cpu`) or an adapter of unknown type: the
    /// facade's automatic choice only takes GPUs.
    pub gpu: bool,
    /// Driver name and version.
    pub driver: String,
    /// Largest storage buffer binding in bytes (sizes BVH buffers).
    pub max_storage_buffer_binding_size: u64,
    /// Largest buffer in bytes.
    pub max_buffer_size: u64,
    /// Most storage buffers one shader stage may bind.
    pub max_storage_buffers_per_shader_stage: u32,
    /// Largest workgroup count per dimension.
    pub max_compute_workgroups_per_dimension: u32,
    /// Most invocations per workgroup.
    pub max_compute_invocations_per_workgroup: u32,
    /// Whether wgpu's experimental ray query feature is offered (optik does not need it).
    pub ray_query: bool,
}

impl fmt::Display for AdapterReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} ({} via {}, driver {})",
            self.name, self.device_type, self.backend, self.driver
        )?;
        writeln!(
            f,
            "  max storage buffer binding      {} bytes",
            self.max_storage_buffer_binding_size
        )?;
        writeln!(
            f,
            "  max buffer size                 {} bytes",
            self.max_buffer_size
        )?;
        writeln!(
            f,
            "  storage buffers per stage       {}",
            self.max_storage_buffers_per_shader_stage
        )?;
        writeln!(
            f,
            "  workgroups per dimension        {}",
            self.max_compute_workgroups_per_dimension
        )?;
        writeln!(
            f,
            "  invocations per workgroup       {}",
            self.max_compute_invocations_per_workgroup
        )?;
        write!(
            f,
            "  experimental ray query          {}",
            if self.ray_query { "offered" } else { "no" }
        )
    }
}

/// The instance optik uses: every native backend wgpu was built with, honouring wgpu's
/// environment variables (`WGPU_BACKEND`, ...).
///
/// One instance per process, never dropped: each wgpu instance is a Vulkan instance, and
/// NVIDIA's driver fails `vkCreateInstance` after about 29 create/destroy rounds in one
/// process (optik-vulkan's `instance` module has the measurement).
pub(crate) fn instance() -> wgpu::Instance {
    static INSTANCE: std::sync::OnceLock<wgpu::Instance> = std::sync::OnceLock::new();
    INSTANCE
        .get_or_init(|| {
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
            desc.backends = wgpu::Backends::PRIMARY.with_env();
            wgpu::Instance::new(desc)
        })
        .clone()
}

/// Every adapter wgpu finds here.
pub fn probe() -> Vec<AdapterReport> {
    let instance = instance();
    let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::PRIMARY));
    adapters
        .iter()
        .map(|a| {
            let info = a.get_info();
            let limits = a.limits();
            AdapterReport {
                name: info.name.clone(),
                backend: format!("{:?}", info.backend),
                device_type: format!("{:?}", info.device_type),
                gpu: matches!(
                    info.device_type,
                    wgpu::DeviceType::DiscreteGpu
                        | wgpu::DeviceType::IntegratedGpu
                        | wgpu::DeviceType::VirtualGpu
                ),
                driver: format!("{} {}", info.driver, info.driver_info)
                    .trim()
                    .to_string(),
                max_storage_buffer_binding_size: limits.max_storage_buffer_binding_size,
                max_buffer_size: limits.max_buffer_size,
                max_storage_buffers_per_shader_stage: limits.max_storage_buffers_per_shader_stage,
                max_compute_workgroups_per_dimension: limits.max_compute_workgroups_per_dimension,
                max_compute_invocations_per_workgroup: limits.max_compute_invocations_per_workgroup,
                ray_query: a
                    .features()
                    .contains(wgpu::Features::EXPERIMENTAL_RAY_QUERY),
            }
        })
        .collect()
}
