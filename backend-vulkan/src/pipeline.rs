//! Modules, program groups and pipelines (OptiX `optixModuleCreate`, `optixProgramGroupCreate`,
//! `optixPipelineCreate`).
//!
//! A module keeps the front end's compiled module; the SPIR-V is written per pipeline, for
//! the features the pipeline resolves (DESIGN.md §6): the lowering's configuration (payload
//! size, depth tracking, exceptions, ...) comes from the scene and the programs.
//!
//! Vulkan shader groups per optik group: raygen, miss, hit (triangles, or procedural with the
//! user's or optik's intersection stage), exception (a callable), callables (a callable for the
//! direct callable and a miss stage for the continuation callable), plus optik's null callable
//! and null continuation. The stack size is set per launch from the groups' stack sizes and
//! the pipeline's depths, as OptiX's `optixUtilComputeStackSizes` does.

use crate::accel::scene_features;
use crate::device::Inner;
use crate::error::VkResultExt;
use crate::memory::Allocator;
use crate::objects::Objects;
use crate::program::{
    self, HitContext, LoweringConfig, ModuleText, StageRole, TriangleMode, VkStage,
};
use crate::sbt::TranslatedSbt;
use ash::vk;
use optik_api::*;
use optik_core::frontend::{BindingInfo, BindingKind, CompiledModule, DeviceFunction};
use std::collections::HashMap;
use std::ffi::CString;
use std::sync::Arc;

/// A compiled module.
pub struct ModuleObject {
    /// The front end's module: source, IR, programs, bindings.
    pub compiled: Arc<CompiledModule>,
}

/// A program group.
pub struct GroupObject {
    /// What the group holds.
    pub desc: ProgramGroupDesc,
}

/// The Vulkan shader group handles of one optik group in a pipeline.
#[derive(Clone, Debug, Default)]
pub struct GroupHandles {
    /// The raygen, miss, hit, exception or direct callable group's handle; `None` for a
    /// null miss group or callables without a direct callable.
    pub primary: Option<Vec<u8>>,
    /// The continuation callable's miss group handle.
    pub continuation: Option<Vec<u8>>,
    /// A triangle hit group's handle for optik's triangles, where the pipeline mixes them
    /// with the driver's (`primary` then serves the driver's; docs/vulkan-backend.md §2.4).
    pub optik_triangles: Option<Vec<u8>>,
    /// The direct callable's program id in the callable table of calls inlined into
    /// intersection and any-hit stages (program/inline.rs).
    pub direct_id: Option<u32>,
}

/// A linked pipeline.
pub struct PipelineObject {
    /// The Vulkan pipeline.
    pub pipeline: vk::Pipeline,
    /// Its layout.
    pub layout: vk::PipelineLayout,
    /// The user's `@group(0)` and the backend's `@group(1)` set layouts.
    pub set_layouts: [vk::DescriptorSetLayout; 2],
    /// What it was compiled for.
    pub features: FeatureSet,
    /// The lowering settings its stages were compiled with.
    pub config: LoweringConfig,
    /// The `@group(0)` bindings of its modules.
    pub bindings: Vec<BindingInfo>,
    /// Handles by optik group.
    pub handles: HashMap<RawHandle, (GroupRegion, GroupHandles)>,
    /// optik's null callable.
    pub null_callable: Vec<u8>,
    /// optik's null continuation (when continuation callables are called).
    pub null_continuation: Option<Vec<u8>>,
    /// The hit group of records past the user's (a hit without programs, or
    /// `INVALID_HIT_SBT` under debug exceptions), when the pipeline's primitives allow one
    /// group for all; else those records are null records.
    pub past_table: Option<Vec<u8>>,
    /// The same for the second half of the hit records, where the pipeline mixes the
    /// driver's triangles with optik's (§2.4): paths over boxes select them.
    pub past_table_optik: Option<Vec<u8>>,
    /// The stack size to set at launch.
    pub stack_size: u32,
    /// Recent SBT translations.
    pub sbt_cache: Vec<Arc<TranslatedSbt>>,
}

impl PipelineObject {
    /// Frees the pipeline, its layouts and cached SBTs.
    pub fn destroy(mut self, ctx: &crate::context::Context, alloc: &mut Allocator) {
        for t in self.sbt_cache.drain(..) {
            if let Ok(t) = Arc::try_unwrap(t) {
                t.destroy(ctx, alloc);
            }
        }
        // SAFETY: no pending launch uses it (callers wait first).
        unsafe {
            ctx.device.destroy_pipeline(self.pipeline, None);
            ctx.device.destroy_pipeline_layout(self.layout, None);
            for l in self.set_layouts {
                ctx.device.destroy_descriptor_set_layout(l, None);
            }
        }
    }
}

/// Where a stage's WGSL comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Source {
    User(Module),
    /// optik's programs, compiled with the curve basis of their curve stage.
    Internal(u32),
}

/// Every program of every module a pipeline's groups name, and the stages they become.
#[derive(Default)]
struct StagePlan {
    stages: Vec<(Source, StageRole)>,
    index: HashMap<(Source, StageRole), u32>,
}

impl StagePlan {
    fn stage(&mut self, source: Source, role: StageRole) -> u32 {
        if let Some(i) = self.index.get(&(source, role.clone())) {
            return *i;
        }
        let i = self.stages.len() as u32;
        self.stages.push((source, role.clone()));
        self.index.insert((source, role), i);
        i
    }
}

/// Gives every procedural hit group an intersection stage index of its own.
///
/// Mesa's ray tracing pipelines (lavapipe, RADV) inline the any-hit program into the
/// intersection stage; two groups that name the same intersection stage index with different
/// any-hit programs (or one with none) then share one inlined copy, and a group without an
/// any-hit runs another group's. Repeating the stage's create info (same module, same entry)
/// costs one more stage entry and no extra SPIR-V.
fn distinct_intersection_stages(
    groups: &[VkGroup],
    stage_infos: &mut Vec<vk::PipelineShaderStageCreateInfo<'_>>,
) -> Vec<VkGroup> {
    let mut used = std::collections::HashSet::new();
    groups
        .iter()
        .map(|g| match *g {
            VkGroup::Hit {
                closest,
                any,
                intersection: Some(is),
            } if !used.insert(is) => {
                stage_infos.push(stage_infos[is as usize]);
                VkGroup::Hit {
                    closest,
                    any,
                    intersection: Some(stage_infos.len() as u32 - 1),
                }
            }
            other => other,
        })
        .collect()
}

fn vk_stage_flags(s: VkStage) -> vk::ShaderStageFlags {
    match s {
        VkStage::Raygen => vk::ShaderStageFlags::RAYGEN_KHR,
        VkStage::Miss => vk::ShaderStageFlags::MISS_KHR,
        VkStage::ClosestHit => vk::ShaderStageFlags::CLOSEST_HIT_KHR,
        VkStage::AnyHit => vk::ShaderStageFlags::ANY_HIT_KHR,
        VkStage::Intersection => vk::ShaderStageFlags::INTERSECTION_KHR,
        VkStage::Callable => vk::ShaderStageFlags::CALLABLE_KHR,
    }
}

fn all_rt_stages() -> vk::ShaderStageFlags {
    vk::ShaderStageFlags::RAYGEN_KHR
        | vk::ShaderStageFlags::MISS_KHR
        | vk::ShaderStageFlags::CLOSEST_HIT_KHR
        | vk::ShaderStageFlags::ANY_HIT_KHR
        | vk::ShaderStageFlags::INTERSECTION_KHR
        | vk::ShaderStageFlags::CALLABLE_KHR
}

/// A Vulkan shader group by stage indices.
#[derive(Clone, Copy, Debug)]
enum VkGroup {
    General(u32),
    Hit {
        closest: Option<u32>,
        any: Option<u32>,
        intersection: Option<u32>,
    },
}

/// Which Vulkan shader groups serve which optik groups.
struct GroupPlan {
    groups: Vec<VkGroup>,
    /// Per optik group (in the pipeline's order): its region, primary and continuation
    /// Vulkan group.
    user: Vec<UserGroups>,
    null_callable: usize,
    null_continuation: Option<usize>,
    past_table: Option<usize>,
    past_table_optik: Option<usize>,
}

/// The Vulkan groups of one optik group.
struct UserGroups {
    group: RawHandle,
    region: GroupRegion,
    primary: Option<usize>,
    continuation: Option<usize>,
    /// A triangle hit group's group for optik's triangles, where the pipeline mixes kinds.
    optik_triangles: Option<usize>,
}

/// What the device and its live scene add to a pipeline's lowering.
struct DeviceSide {
    /// How triangles are intersected (the device's accuracy).
    triangles: TriangleMode,
    /// The device mixes the driver's triangles with optik's (§2.4).
    mixed: bool,
    /// Live structures have motion.
    scene_motion: bool,
    /// Live structures have opacity micromaps.
    scene_micromaps: bool,
    /// The device has `rayTraversalPrimitiveCulling`.
    primitive_culling: bool,
}

/// Settings for the lowering from the resolved features and the programs.
fn lowering_config(
    features: &FeatureSet,
    link: &PipelineLinkOptions,
    descs: &[&ProgramGroupDesc],
    module_of: &dyn Fn(&ProgramRef) -> Option<Arc<CompiledModule>>,
    device: &DeviceSide,
) -> LoweringConfig {
    let calls = |pred: &dyn Fn(ProgramKind, DeviceFunction) -> bool| {
        descs.iter().flat_map(|d| d.programs()).any(|(kind, p)| {
            module_of(p)
                .and_then(|m| m.program(&p.entry).cloned())
                .is_some_and(|info| info.device_functions.iter().any(|f| pred(kind, *f)))
        })
    };
    let continuation_calls = calls(&|_, f| f == DeviceFunction::ContinuationCall);
    let track_depth = continuation_calls
        || calls(&|k, f| {
            k != ProgramKind::Raygen
                && matches!(
                    f,
                    DeviceFunction::Trace | DeviceFunction::RemainingTraceDepth
                )
        });
    let triangles = features
        .primitive_types
        .contains(PrimitiveTypeFlags::TRIANGLE);
    let micromaps = device.triangles.emulated()
        && triangles
        && (features.opacity_micromaps || device.scene_micromaps);
    let mixed_triangles = device.mixed && triangles;
    // optik's triangle stage reads the ray's face-culling flags from Vulkan's (both faces as
    // SkipTrianglesKHR, which also skips the driver's triangles where they share the scene:
    // paths that disable culling over them go through box twins, accel/mod.rs), or from the
    // state word where the device lacks that flag; its opacity checks with micromaps need
    // the 2-state flag, which only the state keeps.
    let skip_triangles_flag = device.triangles.emulated() && device.primitive_culling;
    let track_ray_flags =
        calls(&|_, f| matches!(f, DeviceFunction::RayFlags | DeviceFunction::RayMask))
            || (device.triangles.emulated() && triangles && !skip_triangles_flag)
            || micromaps;
    let guard_direct_calls =
        calls(&|k, f| k == ProgramKind::DirectCallable && f == DeviceFunction::DirectCall);
    let inline_calls = calls(&|k, f| {
        matches!(k, ProgramKind::Intersection | ProgramKind::AnyHit)
            && f == DeviceFunction::DirectCall
    });
    let exception_program = descs
        .iter()
        .any(|d| matches!(d, ProgramGroupDesc::Exception(_)));
    LoweringConfig {
        payload_len: features.num_payload_values.max(1),
        max_trace_depth: link.max_trace_depth,
        max_direct_callable_depth: link.max_direct_callable_depth,
        max_continuation_callable_depth: link.max_continuation_callable_depth,
        exceptions: features.exceptions,
        exception_program,
        motion: features.motion,
        track_depth,
        track_ray_flags,
        guard_direct_calls,
        continuation_calls,
        inline_calls,
        triangles: device.triangles,
        mixed_triangles,
        skip_triangles_flag,
        motion_structures: features.motion || device.scene_motion,
        micromaps,
        micromap_states: micromaps && features.opacity_micromaps,
        primitive_types: features.primitive_types.0,
    }
}

impl ModuleObject {
    /// The names of its programs.
    pub fn programs(&self) -> Vec<String> {
        self.compiled
            .programs
            .iter()
            .map(|p| p.name.clone())
            .collect()
    }
}

/// Compiles a module with the front end (its SPIR-V is written per pipeline).
pub fn create_module(
    _options: &ModuleCompileOptions,
    pipeline_options: &PipelineCompileOptions,
    source: &ProgramSource,
) -> Result<(ModuleObject, String)> {
    // optik-core has checked the register count.
    let payload = pipeline_options.num_payload_values.or(32);
    let compiled = optik_core::frontend::compile(source, payload)?;
    let mut log = format!(
        "{}: {} program(s)",
        compiled.file_name,
        compiled.programs.len()
    );
    for p in &compiled.programs {
        log.push_str(&format!("\n  {} `{}` (line {})", p.kind, p.name, p.line));
    }
    let module = ModuleObject {
        compiled: Arc::new(compiled),
    };
    Ok((module, log))
}

/// What the programs of `groups` use (optik-core resolves the pipeline's features from it).
pub fn program_features(objects: &Objects, groups: &[ProgramGroup]) -> Result<ProgramFeatures> {
    let (descs, modules) = pipeline_programs(objects, groups)?;
    let desc_refs: Vec<&ProgramGroupDesc> = descs.iter().collect();
    Ok(optik_core::features::program_features(&desc_refs, |p| {
        modules.get(&p.module).map(|m| &**m)
    }))
}

/// The descriptions of `groups` and the compiled modules of their programs.
#[allow(clippy::type_complexity)]
fn pipeline_programs(
    objects: &Objects,
    groups: &[ProgramGroup],
) -> Result<(Vec<ProgramGroupDesc>, HashMap<Module, Arc<CompiledModule>>)> {
    let mut descs = Vec::with_capacity(groups.len());
    for (i, g) in groups.iter().enumerate() {
        descs.push(
            objects
                .groups
                .get(*g)
                .map_err(|e| e.context(format!("groups[{i}]")))?
                .desc
                .clone(),
        );
    }
    let mut modules: HashMap<Module, Arc<CompiledModule>> = HashMap::new();
    for d in &descs {
        for (_, p) in d.programs() {
            let m = objects
                .modules
                .get(p.module)
                .map_err(|e| e.context(format!("program `{}`", p.entry)))?;
            modules.insert(p.module, m.compiled.clone());
        }
    }
    Ok((descs, modules))
}

impl Inner {
    pub fn create_pipeline(
        &mut self,
        objects: &Objects,
        link: &PipelineLinkOptions,
        groups: &[ProgramGroup],
        features: &FeatureSet,
    ) -> Result<PipelineObject> {
        let features = *features;
        let (descs, modules) = pipeline_programs(objects, groups)?;
        let module_of = |p: &ProgramRef| modules.get(&p.module).cloned();
        let desc_refs: Vec<&ProgramGroupDesc> = descs.iter().collect();
        let scene = scene_features(&objects.accels).unwrap_or_default();
        let device = DeviceSide {
            triangles: match self.accuracy.triangle {
                TriangleTest::Driver => TriangleMode::Native,
                TriangleTest::MollerTrumbore => TriangleMode::MollerTrumbore,
                TriangleTest::Watertight => TriangleMode::Watertight {
                    f64: self.ctx.info.shader_float64,
                },
            },
            mixed: self.mixes_triangles(),
            scene_motion: scene.motion.any(),
            scene_micromaps: scene.opacity_micromaps,
            primitive_culling: self.ctx.info.primitive_culling,
        };
        let config = lowering_config(&features, link, &desc_refs, &module_of, &device);

        let recursion = config.max_trace_depth
            + if config.continuation_calls {
                config.max_continuation_callable_depth
            } else {
                0
            };
        if recursion > self.ctx.info.max_ray_recursion_depth {
            return Err(Error::limit(format!(
                "max_trace_depth {} plus max_continuation_callable_depth {} (continuation callables run as nested rays on Vulkan) is {recursion}; this device allows a ray recursion depth of {}",
                config.max_trace_depth,
                config.max_continuation_callable_depth,
                self.ctx.info.max_ray_recursion_depth
            )));
        }
        for (what, v) in [
            ("max_direct_callable_depth", link.max_direct_callable_depth),
            (
                "max_continuation_callable_depth",
                link.max_continuation_callable_depth,
            ),
        ] {
            if v > 255 {
                return Err(Error::limit(format!(
                    "link_options.{what} is {v}; the Vulkan backend tracks at most 255"
                )));
            }
        }
        let bindings = merged_bindings(modules.values())?;
        let direct = DirectCallables::of(&descs, &modules, &config)?;
        let (plan, group_plan) = plan_stages(groups, &descs, &config, &features);
        let stages = self.lower(&plan, &modules, &config, &direct)?;
        let direct_ids: HashMap<RawHandle, u32> = groups
            .iter()
            .zip(&descs)
            .filter_map(|(g, d)| match d {
                ProgramGroupDesc::Callables {
                    direct: Some(p), ..
                } => Some((optik_api::Handle::raw(g), direct.id(p)?)),
                _ => None,
            })
            .collect();
        self.link(
            stages, group_plan, direct_ids, features, config, bindings, recursion,
        )
    }

    /// Lowers every planned stage, one naga pass per source.
    fn lower(
        &self,
        plan: &StagePlan,
        modules: &HashMap<Module, Arc<CompiledModule>>,
        config: &LoweringConfig,
        direct: &DirectCallables,
    ) -> Result<Vec<program::LoweredStage>> {
        let mut by_source: Vec<(Source, Vec<(usize, StageRole)>)> = Vec::new();
        for (i, (source, role)) in plan.stages.iter().enumerate() {
            match by_source.iter_mut().find(|(s, _)| s == source) {
                Some((_, v)) => v.push((i, role.clone())),
                None => by_source.push((*source, vec![(i, role.clone())])),
            }
        }
        let mut out: Vec<Option<program::LoweredStage>> = vec![None; plan.stages.len()];
        for (source, roles) in by_source {
            let role_list: Vec<StageRole> = roles.iter().map(|(_, r)| r.clone()).collect();
            let lowered = match source {
                Source::User(m) => {
                    let compiled = modules
                        .get(&m)
                        .ok_or_else(|| Error::backend("module vanished"))?;
                    let callables = direct.of_module(m);
                    program::lower_stages(
                        ModuleText::User(&compiled.user_source),
                        config,
                        &role_list,
                        Some((compiled, &callables)),
                    )
                    .map_err(|e| e.context(format!("module {}", compiled.file_name)))?
                }
                Source::Internal(basis) => program::lower_stages(
                    ModuleText::Internal { curve_basis: basis },
                    config,
                    &role_list,
                    None,
                )?,
            };
            for ((i, _), stage) in roles.into_iter().zip(lowered) {
                out[i] = Some(stage);
            }
        }
        out.into_iter()
            .map(|s| s.ok_or_else(|| Error::backend("a stage was not lowered")))
            .collect()
    }

    /// Creates the Vulkan pipeline from lowered stages.
    #[allow(clippy::too_many_arguments)]
    fn link(
        &mut self,
        stages: Vec<program::LoweredStage>,
        group_plan: GroupPlan,
        direct_ids: HashMap<RawHandle, u32>,
        features: FeatureSet,
        config: LoweringConfig,
        bindings: Vec<BindingInfo>,
        recursion: u32,
    ) -> Result<PipelineObject> {
        let ctx = self.ctx.clone();
        let device = &ctx.device;
        let mut shader_modules = Vec::with_capacity(stages.len());
        let destroy_modules = |mods: &[vk::ShaderModule]| {
            for m in mods {
                // SAFETY: pipeline creation is over; modules are no longer needed.
                unsafe { device.destroy_shader_module(*m, None) };
            }
        };
        for s in &stages {
            let info = vk::ShaderModuleCreateInfo::default().code(&s.spirv);
            // SAFETY: valid SPIR-V words (validated by the post-pass's output in tests).
            match unsafe { device.create_shader_module(&info, None) } {
                Ok(m) => shader_modules.push(m),
                Err(e) => {
                    destroy_modules(&shader_modules);
                    return Err(crate::error::vk_error("vkCreateShaderModule", e));
                }
            }
        }
        let names: Vec<CString> = stages
            .iter()
            .map(|s| CString::new(s.entry_name.clone()).unwrap_or_default())
            .collect();
        let mut stage_infos: Vec<vk::PipelineShaderStageCreateInfo> = stages
            .iter()
            .zip(&shader_modules)
            .zip(&names)
            .map(|((s, m), n)| {
                vk::PipelineShaderStageCreateInfo::default()
                    .stage(vk_stage_flags(s.stage))
                    .module(*m)
                    .name(n)
            })
            .collect();
        let groups = distinct_intersection_stages(&group_plan.groups, &mut stage_infos);
        let group_infos: Vec<vk::RayTracingShaderGroupCreateInfoKHR> = groups
            .iter()
            .map(|g| match *g {
                VkGroup::General(s) => vk::RayTracingShaderGroupCreateInfoKHR::default()
                    .ty(vk::RayTracingShaderGroupTypeKHR::GENERAL)
                    .general_shader(s)
                    .closest_hit_shader(vk::SHADER_UNUSED_KHR)
                    .any_hit_shader(vk::SHADER_UNUSED_KHR)
                    .intersection_shader(vk::SHADER_UNUSED_KHR),
                VkGroup::Hit {
                    closest,
                    any,
                    intersection,
                } => vk::RayTracingShaderGroupCreateInfoKHR::default()
                    .ty(if intersection.is_some() {
                        vk::RayTracingShaderGroupTypeKHR::PROCEDURAL_HIT_GROUP
                    } else {
                        vk::RayTracingShaderGroupTypeKHR::TRIANGLES_HIT_GROUP
                    })
                    .general_shader(vk::SHADER_UNUSED_KHR)
                    .closest_hit_shader(closest.unwrap_or(vk::SHADER_UNUSED_KHR))
                    .any_hit_shader(any.unwrap_or(vk::SHADER_UNUSED_KHR))
                    .intersection_shader(intersection.unwrap_or(vk::SHADER_UNUSED_KHR)),
            })
            .collect();

        let set_layouts = match self.set_layouts(&bindings) {
            Ok(l) => l,
            Err(e) => {
                destroy_modules(&shader_modules);
                return Err(e);
            }
        };
        let layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        // SAFETY: valid set layouts.
        let layout = match unsafe { device.create_pipeline_layout(&layout_info, None) } {
            Ok(l) => l,
            Err(e) => {
                destroy_modules(&shader_modules);
                // SAFETY: unused layouts.
                unsafe {
                    set_layouts
                        .iter()
                        .for_each(|l| device.destroy_descriptor_set_layout(*l, None))
                };
                return Err(crate::error::vk_error("vkCreatePipelineLayout", e));
            }
        };
        let dynamic = [vk::DynamicState::RAY_TRACING_PIPELINE_STACK_SIZE_KHR];
        let dynamic_info = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic);
        let create = vk::RayTracingPipelineCreateInfoKHR::default()
            .flags(self.skip_flags(&features, &config))
            .stages(&stage_infos)
            .groups(&group_infos)
            .max_pipeline_ray_recursion_depth(recursion)
            .dynamic_state(&dynamic_info)
            .layout(layout);
        // SAFETY: every index in the groups refers to a stage of the right kind.
        let created = unsafe {
            ctx.rt.create_ray_tracing_pipelines(
                vk::DeferredOperationKHR::null(),
                self.cache.handle(),
                &[create],
                None,
            )
        };
        destroy_modules(&shader_modules);
        let pipeline = match created {
            Ok(p) => p[0],
            Err((_, e)) => {
                // SAFETY: unused layouts.
                unsafe {
                    device.destroy_pipeline_layout(layout, None);
                    set_layouts
                        .iter()
                        .for_each(|l| device.destroy_descriptor_set_layout(*l, None));
                }
                return Err(crate::error::vk_error("vkCreateRayTracingPipelinesKHR", e));
            }
        };
        self.cache.save(&ctx);

        let handle_size = ctx.info.shader_group_handle_size as usize;
        let count = group_infos.len();
        // SAFETY: a ray tracing pipeline with `count` groups.
        let all = unsafe {
            ctx.rt.get_ray_tracing_shader_group_handles(
                pipeline,
                0,
                count as u32,
                count * handle_size,
            )
        };
        let all = match all {
            Ok(h) => h,
            Err(e) => {
                // SAFETY: unused pipeline.
                unsafe {
                    device.destroy_pipeline(pipeline, None);
                    device.destroy_pipeline_layout(layout, None);
                    set_layouts
                        .iter()
                        .for_each(|l| device.destroy_descriptor_set_layout(*l, None));
                }
                return Err(crate::error::vk_error(
                    "vkGetRayTracingShaderGroupHandlesKHR",
                    e,
                ));
            }
        };
        let handle = |g: usize| all[g * handle_size..(g + 1) * handle_size].to_vec();
        let mut handles = HashMap::new();
        for u in &group_plan.user {
            handles.insert(
                u.group,
                (
                    u.region,
                    GroupHandles {
                        primary: u.primary.map(handle),
                        continuation: u.continuation.map(handle),
                        optik_triangles: u.optik_triangles.map(handle),
                        direct_id: direct_ids.get(&u.group).copied(),
                    },
                ),
            );
        }
        let stack_size = self.stack_size(pipeline, &group_plan, &stages, &config, recursion);
        let object = PipelineObject {
            pipeline,
            layout,
            set_layouts,
            features,
            config,
            bindings,
            handles,
            null_callable: handle(group_plan.null_callable),
            null_continuation: group_plan.null_continuation.map(handle),
            past_table: group_plan.past_table.map(handle),
            past_table_optik: group_plan.past_table_optik.map(handle),
            stack_size,
            sbt_cache: Vec::new(),
        };
        Ok(object)
    }

    /// Vulkan's skip flags for the primitive types the pipeline does not intersect (DESIGN.md
    /// §6), where the device can skip them.
    fn skip_flags(
        &self,
        features: &FeatureSet,
        config: &LoweringConfig,
    ) -> vk::PipelineCreateFlags {
        let mut flags = vk::PipelineCreateFlags::empty();
        if !self.ctx.info.primitive_culling {
            return flags;
        }
        let triangles = features
            .primitive_types
            .contains(PrimitiveTypeFlags::TRIANGLE);
        if !triangles || (config.triangles.emulated() && !config.mixed_triangles) {
            flags |= vk::PipelineCreateFlags::RAY_TRACING_SKIP_TRIANGLES_KHR;
        }
        let on_aabbs =
            PrimitiveTypeFlags::CUSTOM | PrimitiveTypeFlags::SPHERE | PrimitiveTypeFlags::CURVES;
        let aabbs = features.primitive_types.intersects(on_aabbs)
            || (triangles && config.triangles.emulated());
        if !aabbs {
            flags |= vk::PipelineCreateFlags::RAY_TRACING_SKIP_AABBS_KHR;
        }
        flags
    }

    /// The two descriptor set layouts: the user's `@group(0)` and the backend's `@group(1)`.
    fn set_layouts(&self, bindings: &[BindingInfo]) -> Result<[vk::DescriptorSetLayout; 2]> {
        let stages = all_rt_stages();
        let user: Vec<vk::DescriptorSetLayoutBinding> = bindings
            .iter()
            .map(|b| {
                let ty = match b.kind {
                    BindingKind::Params { .. } => vk::DescriptorType::UNIFORM_BUFFER,
                    BindingKind::StorageBuffer { .. } => vk::DescriptorType::STORAGE_BUFFER,
                    BindingKind::Texture2d => vk::DescriptorType::SAMPLED_IMAGE,
                    BindingKind::Sampler => vk::DescriptorType::SAMPLER,
                };
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b.binding)
                    .descriptor_type(ty)
                    .descriptor_count(1)
                    .stage_flags(stages)
            })
            .collect();
        let backend: Vec<vk::DescriptorSetLayoutBinding> = (0..6)
            .map(|b| {
                let ty = if b == 0 {
                    vk::DescriptorType::UNIFORM_BUFFER
                } else {
                    vk::DescriptorType::STORAGE_BUFFER
                };
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b)
                    .descriptor_type(ty)
                    .descriptor_count(1)
                    .stage_flags(stages)
            })
            .collect();
        let device = &self.ctx.device;
        // SAFETY: valid bindings.
        let first = unsafe {
            device.create_descriptor_set_layout(
                &vk::DescriptorSetLayoutCreateInfo::default().bindings(&user),
                None,
            )
        }
        .or_vk("vkCreateDescriptorSetLayout")?;
        // SAFETY: valid bindings.
        match unsafe {
            device.create_descriptor_set_layout(
                &vk::DescriptorSetLayoutCreateInfo::default().bindings(&backend),
                None,
            )
        } {
            Ok(second) => Ok([first, second]),
            Err(e) => {
                // SAFETY: unused layout.
                unsafe { device.destroy_descriptor_set_layout(first, None) };
                Err(crate::error::vk_error("vkCreateDescriptorSetLayout", e))
            }
        }
    }

    /// The pipeline stack size: OptiX's `optixUtilComputeStackSizes` with Vulkan's group
    /// stack sizes, counting continuation calls as ray levels and callables at every level.
    fn stack_size(
        &self,
        pipeline: vk::Pipeline,
        plan: &GroupPlan,
        stages: &[program::LoweredStage],
        config: &LoweringConfig,
        recursion: u32,
    ) -> u32 {
        let rt = &self.ctx.rt;
        let size = |group: usize, shader: vk::ShaderGroupShaderKHR| -> u64 {
            // SAFETY: a group index of this pipeline.
            unsafe { rt.get_ray_tracing_shader_group_stack_size(pipeline, group as u32, shader) }
        };
        let (mut rg, mut ms, mut ch, mut ah, mut is, mut callable) =
            (0u64, 0u64, 0u64, 0u64, 0u64, 0u64);
        for (g, group) in plan.groups.iter().enumerate() {
            match *group {
                VkGroup::General(s) => {
                    let v = size(g, vk::ShaderGroupShaderKHR::GENERAL);
                    match stages[s as usize].stage {
                        VkStage::Raygen => rg = rg.max(v),
                        VkStage::Miss => ms = ms.max(v),
                        _ => callable = callable.max(v),
                    }
                }
                VkGroup::Hit {
                    closest,
                    any,
                    intersection,
                } => {
                    if closest.is_some() {
                        ch = ch.max(size(g, vk::ShaderGroupShaderKHR::CLOSEST_HIT));
                    }
                    if any.is_some() {
                        ah = ah.max(size(g, vk::ShaderGroupShaderKHR::ANY_HIT));
                    }
                    if intersection.is_some() {
                        is = is.max(size(g, vk::ShaderGroupShaderKHR::INTERSECTION));
                    }
                }
            }
        }
        let direct_depth = if config.guard_direct_calls {
            config.max_direct_callable_depth.max(1)
        } else {
            1
        } as u64;
        let callable_depth = direct_depth + u64::from(config.exception_program);
        let per_level = ch.max(ms).max(is + ah) + callable_depth * callable;
        let total = rg + callable_depth * callable + recursion as u64 * per_level;
        total.min(u32::MAX as u64) as u32
    }
}

/// The direct callables of a pipeline, numbered for the callable table of calls inlined
/// into intersection and any-hit stages (program/inline.rs).
struct DirectCallables {
    /// Program id → module and function name.
    programs: Vec<(Module, String)>,
}

impl DirectCallables {
    /// The direct callables of `descs`. With inlined calls, every direct callable must be in
    /// the module of each intersection and any-hit program that calls one: the stages are
    /// compiled from their module's source.
    fn of(
        descs: &[ProgramGroupDesc],
        modules: &HashMap<Module, Arc<CompiledModule>>,
        config: &LoweringConfig,
    ) -> Result<DirectCallables> {
        let mut programs: Vec<(Module, String)> = Vec::new();
        for d in descs {
            if let ProgramGroupDesc::Callables {
                direct: Some(p), ..
            } = d
                && !programs
                    .iter()
                    .any(|(m, n)| *m == p.module && *n == p.entry)
            {
                programs.push((p.module, p.entry.clone()));
            }
        }
        if config.inline_calls {
            for (kind, p) in descs.iter().flat_map(|d| d.programs()) {
                let calls = matches!(kind, ProgramKind::Intersection | ProgramKind::AnyHit)
                    && modules
                        .get(&p.module)
                        .and_then(|m| m.program(&p.entry))
                        .is_some_and(|info| info.calls(DeviceFunction::DirectCall));
                if !calls {
                    continue;
                }
                if let Some((m, name)) = programs.iter().find(|(m, _)| *m != p.module) {
                    let file = |m: &Module| {
                        modules
                            .get(m)
                            .map_or_else(String::new, |c| c.file_name.clone())
                    };
                    return Err(Error::unsupported(format!(
                        "`{}` ({}) calls rt_direct_call from a {kind} program, and the pipeline's direct callable `{name}` is in another module ({}): Vulkan runs no callables from intersection and any-hit stages, so the Vulkan backend compiles the direct callables into them, which it does for callables of the same module only; put them in one module",
                        p.entry,
                        file(&p.module),
                        file(m)
                    )));
                }
            }
        }
        Ok(DirectCallables { programs })
    }

    /// The program id of direct callable `p`.
    fn id(&self, p: &ProgramRef) -> Option<u32> {
        self.programs
            .iter()
            .position(|(m, n)| *m == p.module && *n == p.entry)
            .map(|i| i as u32)
    }

    /// The ids and names of `module`'s direct callables.
    fn of_module(&self, module: Module) -> Vec<(u32, String)> {
        self.programs
            .iter()
            .enumerate()
            .filter(|(_, (m, _))| *m == module)
            .map(|(i, (_, n))| (i as u32, n.clone()))
            .collect()
    }
}

/// The union of the modules' `@group(0)` bindings; one number, one kind.
fn merged_bindings<'a>(
    modules: impl Iterator<Item = &'a Arc<CompiledModule>>,
) -> Result<Vec<BindingInfo>> {
    let mut out: Vec<BindingInfo> = Vec::new();
    for m in modules {
        for b in &m.bindings {
            match out.iter().find(|o| o.binding == b.binding) {
                Some(o) if std::mem::discriminant(&o.kind) != std::mem::discriminant(&b.kind) => {
                    return Err(Error::invalid(format!(
                        "@binding({}) is `{}` ({:?}) in one module and `{}` ({:?}) in another; modules of one pipeline must agree",
                        b.binding, o.name, o.kind, b.name, b.kind
                    )));
                }
                Some(o) => {
                    // Keep the larger fixed size, so launches check against both.
                    if let (BindingKind::Params { size: a }, BindingKind::Params { size: bsize }) =
                        (o.kind, b.kind)
                        && bsize > a
                    {
                        let i = out.iter().position(|x| x.binding == b.binding).unwrap_or(0);
                        out[i] = b.clone();
                    }
                }
                None => out.push(b.clone()),
            }
        }
    }
    out.sort_by_key(|b| b.binding);
    Ok(out)
}

/// Stages and Vulkan groups for a pipeline's optik groups.
fn plan_stages(
    groups: &[ProgramGroup],
    descs: &[ProgramGroupDesc],
    config: &LoweringConfig,
    features: &FeatureSet,
) -> (StagePlan, GroupPlan) {
    let mut plan = StagePlan::default();
    let mut vk_groups: Vec<VkGroup> = Vec::new();
    let mut user = Vec::new();
    let program = |p: &ProgramRef, kind: ProgramKind, context: Option<HitContext>| {
        (
            Source::User(p.module),
            StageRole::Program {
                name: p.entry.clone(),
                kind,
                context,
            },
        )
    };
    for (g, desc) in groups.iter().zip(descs) {
        let mut optik_triangles = None;
        let add = |vk_groups: &mut Vec<VkGroup>, group: VkGroup| {
            vk_groups.push(group);
            vk_groups.len() - 1
        };
        let (primary, continuation) = match desc {
            ProgramGroupDesc::Raygen(p) => {
                let (s, r) = program(p, ProgramKind::Raygen, None);
                (
                    Some(add(&mut vk_groups, VkGroup::General(plan.stage(s, r)))),
                    None,
                )
            }
            ProgramGroupDesc::Miss(Some(p)) => {
                let (s, r) = program(p, ProgramKind::Miss, None);
                (
                    Some(add(&mut vk_groups, VkGroup::General(plan.stage(s, r)))),
                    None,
                )
            }
            ProgramGroupDesc::Miss(None) => (None, None),
            ProgramGroupDesc::Exception(p) => {
                let (s, r) = program(p, ProgramKind::Exception, None);
                (
                    Some(add(&mut vk_groups, VkGroup::General(plan.stage(s, r)))),
                    None,
                )
            }
            ProgramGroupDesc::HitGroup {
                closest_hit,
                any_hit,
                intersection,
                builtin,
            } => {
                let context = match (intersection, builtin) {
                    (Some(_), _) => HitContext::Custom,
                    (None, BuiltinIntersector::Triangle) => HitContext::Triangles,
                    (None, BuiltinIntersector::Sphere) => HitContext::Sphere,
                    (None, BuiltinIntersector::Curve(_)) => HitContext::Curve,
                };
                let closest = closest_hit.as_ref().map(|p| {
                    let (s, r) = program(p, ProgramKind::ClosestHit, Some(context));
                    plan.stage(s, r)
                });
                let any = any_hit.as_ref().map(|p| {
                    let (s, r) = program(p, ProgramKind::AnyHit, Some(context));
                    plan.stage(s, r)
                });
                let is = match (intersection, builtin) {
                    (Some(p), _) => {
                        let (s, r) = program(p, ProgramKind::Intersection, None);
                        Some(plan.stage(s, r))
                    }
                    (None, BuiltinIntersector::Sphere) => {
                        Some(plan.stage(Source::Internal(0), StageRole::SphereIntersection))
                    }
                    (None, BuiltinIntersector::Curve(t)) => {
                        let basis = optik_api::wgsl::curve_basis(*t);
                        Some(
                            plan.stage(
                                Source::Internal(basis),
                                StageRole::CurveIntersection(basis),
                            ),
                        )
                    }
                    (None, BuiltinIntersector::Triangle) => (config.triangles.emulated()
                        && !config.mixed_triangles)
                        .then(|| plan.stage(Source::Internal(0), StageRole::TriangleIntersection)),
                };
                let primary = add(
                    &mut vk_groups,
                    VkGroup::Hit {
                        closest,
                        any,
                        intersection: is,
                    },
                );
                // Where the driver's triangles and optik's share a scene, a triangle hit
                // group is two Vulkan groups of one closest-hit and any-hit stage each: a
                // triangle group and a procedural one with optik's triangle stage.
                let triangle_group = intersection.is_none()
                    && matches!(builtin, BuiltinIntersector::Triangle)
                    && config.mixed_triangles;
                optik_triangles = triangle_group.then(|| {
                    let stage = plan.stage(Source::Internal(0), StageRole::TriangleIntersection);
                    add(
                        &mut vk_groups,
                        VkGroup::Hit {
                            closest,
                            any,
                            intersection: Some(stage),
                        },
                    )
                });
                (Some(primary), None)
            }
            ProgramGroupDesc::Callables {
                direct,
                continuation,
            } => {
                let d = direct.as_ref().map(|p| {
                    let (s, r) = program(p, ProgramKind::DirectCallable, None);
                    add(&mut vk_groups, VkGroup::General(plan.stage(s, r)))
                });
                let c = continuation.as_ref().map(|p| {
                    let (s, r) = program(p, ProgramKind::ContinuationCallable, None);
                    add(&mut vk_groups, VkGroup::General(plan.stage(s, r)))
                });
                (d, c)
            }
        };
        user.push(UserGroups {
            group: optik_api::Handle::raw(g),
            region: desc.region(),
            primary,
            continuation,
            optik_triangles,
        });
    }
    vk_groups.push(VkGroup::General(
        plan.stage(Source::Internal(0), StageRole::NullCallable),
    ));
    let null_callable = vk_groups.len() - 1;
    let null_continuation = config.continuation_calls.then(|| {
        vk_groups.push(VkGroup::General(
            plan.stage(Source::Internal(0), StageRole::NullContinuation),
        ));
        vk_groups.len() - 1
    });
    let past_table = past_table_group(&mut plan, config, features).map(|g| {
        vk_groups.push(g);
        vk_groups.len() - 1
    });
    // The second half's records past the table serve boxes only.
    let past_table_optik = config.mixed_triangles.then(|| {
        vk_groups.push(VkGroup::Hit {
            closest: None,
            any: None,
            intersection: Some(plan.stage(Source::Internal(0), StageRole::PastTableIntersection)),
        });
        vk_groups.len() - 1
    });
    (
        plan,
        GroupPlan {
            groups: vk_groups,
            user,
            null_callable,
            null_continuation,
            past_table,
            past_table_optik,
        },
    )
}

/// The hit group of the records past the user's: a candidate is a hit without programs
/// (custom primitives, which need an intersection program, are never hit), or raises
/// `INVALID_HIT_SBT` under debug exceptions. One Vulkan group serves one geometry type, so it
/// exists when the pipeline's primitives are all AABBs for Vulkan (emulated triangles,
/// custom primitives, spheres, curves), or all native triangles under debug exceptions
/// (without them, the null record is the same); a pipeline with both keeps null records
/// (docs/vulkan-backend.md §11).
fn past_table_group(
    plan: &mut StagePlan,
    config: &LoweringConfig,
    features: &FeatureSet,
) -> Option<VkGroup> {
    let types = features.primitive_types;
    let triangles = types.contains(PrimitiveTypeFlags::TRIANGLE);
    let native = triangles && (!config.triangles.emulated() || config.mixed_triangles);
    // Where triangle kinds mix, boxes select the second half of the records (§2.4): this
    // group serves the first, the driver's triangles alone.
    let boxes = !config.mixed_triangles
        && (types.intersects(
            PrimitiveTypeFlags::CUSTOM | PrimitiveTypeFlags::SPHERE | PrimitiveTypeFlags::CURVES,
        ) || (triangles && config.triangles.emulated()));
    let internal = Source::Internal(0);
    match (native, boxes) {
        (false, _) => Some(VkGroup::Hit {
            closest: None,
            any: None,
            intersection: Some(plan.stage(internal, StageRole::PastTableIntersection)),
        }),
        (true, false) if config.exceptions.contains(ExceptionFlags::DEBUG) => Some(VkGroup::Hit {
            closest: Some(plan.stage(internal, StageRole::InvalidHitClosestHit)),
            any: Some(plan.stage(internal, StageRole::InvalidHitAnyHit)),
            intersection: None,
        }),
        (true, _) => None,
    }
}
