//! Pipelines: features resolved, programs lowered, and megakernels compiled per scene size.
//!
//! The program part of a kernel is fixed when the pipeline is linked. What depends on the
//! scene alive at launch (arena chunks, stack depth, instance levels, and which of the
//! pipeline's features its structures can call for) selects a *variant*, compiled on first
//! use and cached; a launch after the scene grew compiles a new one.

use crate::gpu::Gpu;
use crate::kernel::{self, KernelConfig, Sizes, group_flags};
use crate::program::instance::{
    self, BINDING_STRIDE, GroupPrograms, LowerInput, Lowered, ProgramLoc,
};
use crate::program::{GroupObject, ModuleSource};
use optik_api::{
    Accuracy, Error, ExceptionFlags, FeatureSet, Handle, Module, PipelineLinkOptions,
    ProgramFeatures, ProgramGroup, ProgramGroupDesc, ProgramKind, RawHandle, Result, SceneFeatures,
};
use optik_core::frontend::{self, BindingInfo, BindingKind, CompiledModule};
use std::collections::HashMap;
use std::sync::Arc;

/// One group of a pipeline.
pub(crate) struct PipelineGroup {
    /// [`group_flags`] bits.
    pub flags: u32,
}

/// A compiled kernel for one scene size.
pub(crate) struct Variant {
    pub pipeline: wgpu::ComputePipeline,
    pub user_layout: wgpu::BindGroupLayout,
    pub backend_layout: wgpu::BindGroupLayout,
    pub source: String,
}

/// A linked pipeline.
///
/// (Public only as `WgpuBackend`'s `optik_core::Backend::Pipeline`, the type optik-core's
/// device keeps; its insides stay private to this crate.)
pub struct PipelineObject {
    pub(crate) features: FeatureSet,
    pub(crate) accuracy: Accuracy,
    pub(crate) link: PipelineLinkOptions,
    pub(crate) groups: Vec<PipelineGroup>,
    /// A group's index in `groups` from its handle.
    pub(crate) group_index: HashMap<RawHandle, u32>,
    pub(crate) lowered: Lowered,
    /// Per module: its bindings (numbers as the user wrote them) and their offset.
    pub(crate) bindings: Vec<(u32, Vec<BindingInfo>)>,
    /// Compiled kernels by scene sizes, the features compiled (the pipeline's, narrowed to
    /// the live structures) and whether they are the instrumented (counting) one.
    pub(crate) variants: HashMap<(Sizes, FeatureSet, bool), Arc<Variant>>,
    /// Low 16 bits of the device id.
    pub(crate) device16: u32,
    /// The device whose groups the pipeline links (what SBT headers must name).
    pub(crate) device: optik_api::DeviceId,
}

/// What the programs of `groups` use (the front end's analysis of their modules).
pub(crate) fn program_features(groups: &[&GroupObject]) -> ProgramFeatures {
    let descs: Vec<&ProgramGroupDesc> = groups.iter().map(|g| &g.desc).collect();
    optik_core::features::program_features(&descs, |p| {
        groups.iter().find_map(|g| {
            g.desc
                .programs()
                .into_iter()
                .zip(g.sources.iter())
                .find(|((_, q), _)| q.module == p.module)
                .map(|(_, s)| &s.compiled)
        })
    })
}

/// Links a pipeline over `groups` (handle and object) with the `features` optik-core resolved.
pub(crate) fn link(
    link: &PipelineLinkOptions,
    groups: &[(ProgramGroup, &GroupObject)],
    features: FeatureSet,
    accuracy: Accuracy,
    device16: u32,
) -> Result<PipelineObject> {
    // optik-core has checked that the groups include a raygen group.
    // The modules of the programs, once each, by handle.
    let mut sources: Vec<(Module, Arc<ModuleSource>)> = Vec::new();
    for (_, g) in groups {
        for ((_, program), source) in g.desc.programs().into_iter().zip(g.sources.iter()) {
            if !sources.iter().any(|(m, _)| *m == program.module) {
                sources.push((program.module, source.clone()));
            }
        }
    }
    if sources.len() > 7 {
        return Err(Error::unsupported(format!(
            "the pipeline's programs come from {} modules; the wgpu backend links at most 7 into one kernel (put programs in fewer modules)",
            sources.len()
        )));
    }
    // Recompiled with the pipeline's payload length (RtPayload's size).
    let compiled: Vec<CompiledModule> = sources
        .iter()
        .map(|(_, s)| frontend::compile(&s.source, features.num_payload_values))
        .collect::<Result<_>>()?;
    let module_index = |m: Module| sources.iter().position(|(h, _)| *h == m);
    let mut group_programs = Vec::new();
    let mut pipeline_groups = Vec::new();
    let mut group_index = HashMap::new();
    for (gi, (handle, g)) in groups.iter().enumerate() {
        let mut gp = GroupPrograms::default();
        let mut flags = 0;
        for (kind, program) in g.desc.programs() {
            let mi = module_index(program.module)
                .ok_or_else(|| Error::backend("program module missing from the pipeline"))?;
            let info = compiled[mi].program(&program.entry).ok_or_else(|| {
                Error::backend(format!(
                    "program `{}` vanished on recompilation",
                    program.entry
                ))
            })?;
            let loc = Some(ProgramLoc {
                module: mi,
                function: info.function,
            });
            match kind {
                ProgramKind::Raygen => gp.raygen = loc,
                ProgramKind::Miss => gp.miss = loc,
                ProgramKind::ClosestHit => {
                    gp.closest_hit = loc;
                    flags |= group_flags::CLOSEST_HIT;
                }
                ProgramKind::AnyHit => {
                    gp.any_hit = loc;
                    flags |= group_flags::ANY_HIT;
                }
                ProgramKind::Intersection => {
                    gp.intersection = loc;
                    flags |= group_flags::INTERSECTION;
                }
                ProgramKind::DirectCallable => {
                    gp.direct = loc;
                    flags |= group_flags::DIRECT;
                }
                ProgramKind::ContinuationCallable => {
                    gp.continuation = loc;
                    flags |= group_flags::CONTINUATION;
                }
                ProgramKind::Exception => gp.exception = loc,
            }
        }
        group_programs.push(gp);
        group_index.insert(handle.raw(), gi as u32);
        pipeline_groups.push(PipelineGroup { flags });
    }
    let lowered = instance::lower(&LowerInput {
        modules: compiled.iter().collect(),
        groups: group_programs,
        max_trace_depth: link.max_trace_depth,
        max_direct_depth: link.max_direct_callable_depth,
        max_continuation_depth: link.max_continuation_callable_depth,
        exceptions_on: !features.exceptions.is_empty(),
        user_throws: features.exceptions.contains(ExceptionFlags::USER),
        any_hit: features.any_hit,
        intersection: features.intersection,
    })?;
    let bindings = compiled
        .iter()
        .enumerate()
        .map(|(mi, m)| (mi as u32 * BINDING_STRIDE, m.bindings.clone()))
        .collect();
    Ok(PipelineObject {
        features,
        accuracy,
        link: *link,
        groups: pipeline_groups,
        group_index,
        lowered,
        bindings,
        variants: HashMap::new(),
        device16,
        device: groups[0].0.raw().device,
    })
}

impl PipelineObject {
    /// The kernel for `sizes` and the live structures' features `scene` (`None`: no
    /// structure), compiled on first use; with `counters`, the instrumented kernel of the
    /// traffic benchmark (`kernel::counters`). The kernel holds the pipeline's features
    /// less those no live structure has ([`FeatureSet::narrowed_to`]): a pipeline forced to
    /// any graph and every primitive type traces a lone triangle GAS with the kernel an
    /// `Auto` pipeline would have, and compiles the general one when instances appear.
    pub(crate) fn variant(
        &mut self,
        gpu: &Gpu,
        sizes: Sizes,
        scene: Option<SceneFeatures>,
        counters: bool,
    ) -> Result<Arc<Variant>> {
        let features = match scene {
            Some(scene) => self.features.narrowed_to(&scene),
            None => self.features,
        };
        if let Some(v) = self.variants.get(&(sizes, features, counters)) {
            return Ok(v.clone());
        }
        let f64 = gpu.features.contains(wgpu::Features::SHADER_F64);
        let source = kernel::generate(&KernelConfig {
            features: &features,
            accuracy: self.accuracy,
            f64,
            device16: self.device16,
            max_direct: self.link.max_direct_callable_depth,
            max_continuation: self.link.max_continuation_callable_depth,
            sizes,
            lowered: &self.lowered,
            counters,
        });
        check_kernel(&source, f64)?;
        if let Some(dir) = &gpu.kernel_dir {
            write_kernel(dir, &source)?;
        }
        let v = Arc::new(compile(gpu, &source, &self.bindings, sizes, counters)?);
        self.variants.insert((sizes, features, counters), v.clone());
        Ok(v)
    }
}

/// Writes a kernel to `dir` as `kernel-<hash of its text>.wgsl` (`WgpuOptions::kernel_dir`).
fn write_kernel(dir: &std::path::Path, source: &str) -> Result<()> {
    use std::hash::{Hash, Hasher};
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    source.hash(&mut hasher);
    let path = dir.join(format!("kernel-{:016x}.wgsl", hasher.finish()));
    std::fs::write(&path, source).map_err(|e| {
        Error::invalid(format!(
            "{} (WgpuOptions::kernel_dir, {}): cannot write {}: {e}; expected a folder this process can write",
            dir.display(),
            crate::KERNEL_DIR_ENV,
            path.display()
        ))
    })
}

/// Parses and validates a generated kernel with naga: a failure is optik's bug, reported
/// with the offending line rather than as a driver error.
pub(crate) fn check_kernel(source: &str, f64: bool) -> Result<()> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| {
        Error::backend(format!(
            "internal error: the generated wgpu kernel does not parse:\n{}",
            e.emit_to_string(source)
        ))
    })?;
    let mut caps = naga::valid::Capabilities::default();
    caps.set(naga::valid::Capabilities::FLOAT64, f64);
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), caps)
        .validate(&module)
        .map_err(|e| {
            Error::backend(format!(
                "internal error: the generated wgpu kernel does not validate:\n{}",
                e.emit_to_string(source)
            ))
        })?;
    Ok(())
}

fn compile(
    gpu: &Gpu,
    source: &str,
    bindings: &[(u32, Vec<BindingInfo>)],
    sizes: Sizes,
    counters: bool,
) -> Result<Variant> {
    let filterable = gpu.features.contains(wgpu::Features::FLOAT32_FILTERABLE);
    let mut user_entries = Vec::new();
    let mut storage_count = 2 + sizes.chunks + counters as u32;
    for (offset, list) in bindings {
        for b in list {
            let ty = match b.kind {
                BindingKind::Params { size } => wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: std::num::NonZeroU64::new(size.max(16) as u64),
                },
                BindingKind::StorageBuffer { read_only, .. } => {
                    storage_count += 1;
                    wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    }
                }
                BindingKind::Texture2d => wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                BindingKind::Sampler => wgpu::BindingType::Sampler(if filterable {
                    wgpu::SamplerBindingType::Filtering
                } else {
                    wgpu::SamplerBindingType::NonFiltering
                }),
            };
            user_entries.push(wgpu::BindGroupLayoutEntry {
                binding: offset + b.binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty,
                count: None,
            });
        }
    }
    let limit = gpu.limits.max_storage_buffers_per_shader_stage;
    if storage_count > limit {
        return Err(Error::limit(format!(
            "the kernel needs {storage_count} storage buffer bindings ({} for the scene's acceleration structures, which fill {} chunks of at most {} bytes each); the adapter allows {limit}",
            sizes.chunks + 2,
            sizes.chunks,
            gpu.limits.max_storage_buffer_binding_size
        )));
    }
    let storage = |binding| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let mut backend_entries = vec![wgpu::BindGroupLayoutEntry {
        binding: 0,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: std::num::NonZeroU64::new(64),
        },
        count: None,
    }];
    for b in 1..3 + sizes.chunks {
        backend_entries.push(storage(b));
    }
    if counters {
        backend_entries.push(wgpu::BindGroupLayoutEntry {
            binding: kernel::counters::binding(sizes.chunks),
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: false },
                has_dynamic_offset: false,
                min_binding_size: std::num::NonZeroU64::new(kernel::counters::BUFFER_BYTES),
            },
            count: None,
        });
    }
    gpu.scoped("compiling the wgpu megakernel", || {
        let user_layout = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("optik user bindings"),
                entries: &user_entries,
            });
        let backend_layout =
            gpu.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some("optik backend bindings"),
                    entries: &backend_entries,
                });
        let layout = gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("optik megakernel"),
                bind_group_layouts: &[Some(&user_layout), Some(&backend_layout)],
                immediate_size: 0,
            });
        let module = gpu
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("optik megakernel"),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let pipeline = gpu
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("optik megakernel"),
                layout: Some(&layout),
                module: &module,
                entry_point: Some("_optik_main"),
                compilation_options: Default::default(),
                cache: None,
            });
        Variant {
            pipeline,
            user_layout,
            backend_layout,
            source: source.to_string(),
        }
    })
}
