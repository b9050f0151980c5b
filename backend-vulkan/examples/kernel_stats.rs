//! What a Vulkan driver makes of WGSL compute kernels: registers, spills, code size.
//!
//! `cargo run -p optik-vulkan --example kernel_stats -- KERNEL.wgsl...` compiles each file
//! with naga to SPIR-V (index bounds clamped and loops bounded, as wgpu does), builds a
//! compute pipeline for its `_optik_main` entry point with
//! `VK_KHR_pipeline_executable_properties` statistics, and prints one line per file with what
//! the driver reports (on NVIDIA: register count, binary size, stack, local and shared
//! memory). The kernels are those the wgpu backend writes to `OPTIK_WGPU_KERNEL_DIR`; on
//! the H200 the register count decided the megakernel's incoherent-ray throughput more than
//! its instruction count (docs/wgpu-backend.md §12.3). `OPTIK_VULKAN_DEVICE` picks the
//! device as for the backend; drivers without the extension (lavapipe) say so and exit 1.

use ash::vk;
use std::ffi::CStr;

fn main() {
    let paths: Vec<String> = std::env::args().skip(1).collect();
    if paths.is_empty() {
        eprintln!("usage: kernel_stats KERNEL.wgsl... (kernels from OPTIK_WGPU_KERNEL_DIR)");
        std::process::exit(2);
    }
    if let Err(e) = run(&paths) {
        eprintln!("kernel_stats: {e}");
        std::process::exit(1);
    }
}

/// A kernel's descriptor set layouts by group: (binding, descriptor type) pairs.
type Groups = Vec<Vec<(u32, vk::DescriptorType)>>;

/// The kernel as wgpu would hand it to the driver (close enough for the driver's statistics:
/// the same naga front end, bounds clamps and loop bounding), and the bindings it declares.
fn compile(path: &str) -> Result<(Vec<u32>, Groups), String> {
    let src = std::fs::read_to_string(path).map_err(|e| format!("{path}: cannot read: {e}"))?;
    let module = naga::front::wgsl::parse_str(&src)
        .map_err(|e| format!("{path}: {}", e.emit_to_string(&src)))?;
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .map_err(|e| format!("{path}: {}", e.emit_to_string(&src)))?;
    let mut options = naga::back::spv::Options {
        lang_version: (1, 3),
        bounds_check_policies: naga::proc::BoundsCheckPolicies {
            index: naga::proc::BoundsCheckPolicy::Restrict,
            ..Default::default()
        },
        force_loop_bounding: true,
        ..Default::default()
    };
    options.flags.remove(naga::back::spv::WriterFlags::DEBUG);
    let entry = naga::back::spv::PipelineOptions {
        shader_stage: naga::ShaderStage::Compute,
        entry_point: "_optik_main".into(),
    };
    let words = naga::back::spv::write_vec(&module, &info, &options, Some(&entry))
        .map_err(|e| format!("{path}: SPIR-V: {e}"))?;
    Ok((words, bindings(&module)))
}

/// The descriptor set layouts the module's bindings need, by group.
fn bindings(module: &naga::Module) -> Groups {
    let mut groups: Groups = Vec::new();
    for (_, global) in module.global_variables.iter() {
        let Some(b) = &global.binding else { continue };
        let kind = match global.space {
            naga::AddressSpace::Uniform => vk::DescriptorType::UNIFORM_BUFFER,
            naga::AddressSpace::Storage { .. } => vk::DescriptorType::STORAGE_BUFFER,
            _ => match &module.types[global.ty].inner {
                naga::TypeInner::Sampler { .. } => vk::DescriptorType::SAMPLER,
                naga::TypeInner::Image {
                    class: naga::ImageClass::Storage { .. },
                    ..
                } => vk::DescriptorType::STORAGE_IMAGE,
                _ => vk::DescriptorType::SAMPLED_IMAGE,
            },
        };
        let g = b.group as usize;
        if groups.len() <= g {
            groups.resize(g + 1, Vec::new());
        }
        groups[g].push((b.binding, kind));
    }
    groups
}

/// A Vulkan error as a message naming the call.
fn vk_err(call: &'static str) -> impl Fn(vk::Result) -> String {
    move |e| format!("{call}: {e}")
}

fn run(paths: &[String]) -> Result<(), String> {
    // SAFETY: every Vulkan object below is created, used and destroyed on this thread, in
    // order, with create-info structures that outlive the calls that read them.
    unsafe {
        let entry = ash::Entry::load().map_err(|e| format!("no Vulkan loader: {e}"))?;
        let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
        let instance = entry
            .create_instance(
                &vk::InstanceCreateInfo::default().application_info(&app),
                None,
            )
            .map_err(vk_err("vkCreateInstance"))?;
        let devices = instance
            .enumerate_physical_devices()
            .map_err(vk_err("vkEnumeratePhysicalDevices"))?;
        let wanted = std::env::var("OPTIK_VULKAN_DEVICE").ok();
        let name_of = |p: vk::PhysicalDevice| {
            let props = instance.get_physical_device_properties(p);
            CStr::from_ptr(props.device_name.as_ptr())
                .to_string_lossy()
                .into_owned()
        };
        let physical = devices
            .iter()
            .copied()
            .find(|&p| match &wanted {
                Some(w) => name_of(p).contains(w.as_str()),
                None => {
                    instance.get_physical_device_properties(p).device_type
                        != vk::PhysicalDeviceType::CPU
                }
            })
            // Without a wanted name, a CPU device is better than none.
            .or_else(|| match wanted {
                None => devices.first().copied(),
                Some(_) => None,
            })
            .ok_or("no Vulkan device (or none matching OPTIK_VULKAN_DEVICE)")?;
        println!("device: {}", name_of(physical));
        let extension = ash::khr::pipeline_executable_properties::NAME;
        let offered = instance
            .enumerate_device_extension_properties(physical)
            .map_err(vk_err("vkEnumerateDeviceExtensionProperties"))?;
        if !offered
            .iter()
            .any(|e| CStr::from_ptr(e.extension_name.as_ptr()) == extension)
        {
            return Err(format!(
                "{} does not offer {}: its driver reports no pipeline statistics",
                name_of(physical),
                extension.to_string_lossy()
            ));
        }
        let priorities = [1.0f32];
        let queues = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(0)
            .queue_priorities(&priorities)];
        let extensions = [extension.as_ptr()];
        let mut statistics = vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default()
            .pipeline_executable_info(true);
        let supported = instance.get_physical_device_features(physical);
        let features = vk::PhysicalDeviceFeatures::default()
            .shader_float64(supported.shader_float64 == vk::TRUE)
            .shader_int64(supported.shader_int64 == vk::TRUE);
        let device = instance
            .create_device(
                physical,
                &vk::DeviceCreateInfo::default()
                    .queue_create_infos(&queues)
                    .enabled_extension_names(&extensions)
                    .enabled_features(&features)
                    .push_next(&mut statistics),
                None,
            )
            .map_err(vk_err("vkCreateDevice"))?;
        let executables = ash::khr::pipeline_executable_properties::Device::new(&instance, &device);
        for path in paths {
            match stats_of(&device, &executables, path) {
                Ok(line) => println!("{path}: {line}"),
                Err(e) => println!("{path}: {e}"),
            }
        }
        device.destroy_device(None);
        instance.destroy_instance(None);
    }
    Ok(())
}

/// One kernel's statistics as `name=value` pairs.
///
/// # Safety
/// `device` must be a live device with `pipelineExecutableInfo` enabled.
unsafe fn stats_of(
    device: &ash::Device,
    executables: &ash::khr::pipeline_executable_properties::Device,
    path: &str,
) -> Result<String, String> {
    let (words, groups) = compile(path)?;
    // SAFETY: as for `run`; every object made here is destroyed before returning.
    unsafe {
        let module = device
            .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&words), None)
            .map_err(vk_err("vkCreateShaderModule"))?;
        let mut set_layouts = Vec::new();
        for group in &groups {
            let entries: Vec<_> = group
                .iter()
                .map(|&(binding, kind)| {
                    vk::DescriptorSetLayoutBinding::default()
                        .binding(binding)
                        .descriptor_type(kind)
                        .descriptor_count(1)
                        .stage_flags(vk::ShaderStageFlags::COMPUTE)
                })
                .collect();
            set_layouts.push(
                device
                    .create_descriptor_set_layout(
                        &vk::DescriptorSetLayoutCreateInfo::default().bindings(&entries),
                        None,
                    )
                    .map_err(vk_err("vkCreateDescriptorSetLayout"))?,
            );
        }
        let layout = device
            .create_pipeline_layout(
                &vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts),
                None,
            )
            .map_err(vk_err("vkCreatePipelineLayout"))?;
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"_optik_main");
        let create = vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(layout)
            .flags(vk::PipelineCreateFlags::CAPTURE_STATISTICS_KHR);
        let started = std::time::Instant::now();
        let made = device.create_compute_pipelines(vk::PipelineCache::null(), &[create], None);
        let compile_ms = started.elapsed().as_secs_f64() * 1e3;
        let result = match made {
            Ok(pipelines) => {
                let pipeline = pipelines[0];
                let line = statistics(executables, pipeline)
                    .map(|s| format!("compile {compile_ms:.0} ms; {s}"));
                device.destroy_pipeline(pipeline, None);
                line
            }
            Err((_, e)) => Err(format!("vkCreateComputePipelines: {e}")),
        };
        device.destroy_pipeline_layout(layout, None);
        for l in set_layouts {
            device.destroy_descriptor_set_layout(l, None);
        }
        device.destroy_shader_module(module, None);
        result
    }
}

/// The statistics of every executable of `pipeline`.
///
/// # Safety
/// `pipeline` must be live and created with `CAPTURE_STATISTICS_KHR`.
unsafe fn statistics(
    executables: &ash::khr::pipeline_executable_properties::Device,
    pipeline: vk::Pipeline,
) -> Result<String, String> {
    let mut line = Vec::new();
    // SAFETY: the caller's promise.
    unsafe {
        let info = vk::PipelineInfoKHR::default().pipeline(pipeline);
        let count = executables
            .get_pipeline_executable_properties(&info)
            .map_err(vk_err("vkGetPipelineExecutablePropertiesKHR"))?
            .len();
        for index in 0..count as u32 {
            let which = vk::PipelineExecutableInfoKHR::default()
                .pipeline(pipeline)
                .executable_index(index);
            for s in executables
                .get_pipeline_executable_statistics(&which)
                .map_err(vk_err("vkGetPipelineExecutableStatisticsKHR"))?
            {
                let name = CStr::from_ptr(s.name.as_ptr()).to_string_lossy();
                let value = match s.format {
                    vk::PipelineExecutableStatisticFormatKHR::BOOL32 => s.value.b32.to_string(),
                    vk::PipelineExecutableStatisticFormatKHR::INT64 => s.value.i64.to_string(),
                    vk::PipelineExecutableStatisticFormatKHR::UINT64 => s.value.u64.to_string(),
                    _ => s.value.f64.to_string(),
                };
                line.push(format!("{name}={value}"));
            }
        }
    }
    Ok(line.join(" "))
}
