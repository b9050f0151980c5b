//! [`Device<B>`]: `optik_api::Device` for every backend, checking each call once.

use crate::Backend;
use crate::{features, validate};
use optik_api::{
    Accel, AccelBufferSizes, AccelBuildOptions, Accuracy, BackendKind, Buffer, BuildFlags,
    BuildInput, BuildOperation, DeviceId, DeviceProperties, Error, FeatureSet, GroupRegion,
    LaunchOptions, LaunchSize, MicromapArray, Module, ModuleCompileOptions,
    OpacityMicromapArrayDesc, Pipeline, PipelineCompileOptions, PipelineLinkOptions, ProgramGroup,
    ProgramGroupDesc, ProgramKind, ProgramSource, Resource, Result, SbtHeader, ShaderBindingTable,
    Texture, TextureDesc, TransformDesc, TraversableHandle,
};

/// Most payload registers a module or pipeline may ask for (OptiX's 32).
const MAX_PAYLOAD_VALUES: u32 = 32;

/// An optik device: the backend `B` behind the checks every backend shares.
///
/// Dereferences to `B` for what a backend offers beyond the API (the CPU device's thread
/// count, the wgpu device's kernel source, the Vulkan device's validation log).
pub struct Device<B: Backend> {
    backend: B,
}

impl<B: Backend> Device<B> {
    /// The device of `backend`.
    pub fn new(backend: B) -> Self {
        Self { backend }
    }

    /// The backend behind the checks.
    pub fn backend(&self) -> &B {
        &self.backend
    }

    fn sizes(&self) -> impl Fn(Buffer) -> Result<u64> + '_ {
        |b| self.backend.buffer_size(b)
    }

    /// The build record of `accel`, refusing transforms in `call`.
    fn built(&self, accel: Accel, call: &str) -> Result<(AccelBuildOptions, Vec<BuildInput>)> {
        self.backend.accel_build_record(accel)?.ok_or_else(|| {
            Error::invalid(format!(
                "{call} takes an acceleration structure, and this is a transform; transforms are not {}, create a new one instead",
                if call == "accel_update" {
                    "updated"
                } else {
                    "compacted"
                }
            ))
        })
    }

    /// Checks that every program a group names exists in its module with the kind the
    /// group uses it as.
    fn check_group(&self, i: usize, desc: &ProgramGroupDesc) -> Result<()> {
        for (kind, program) in desc.programs() {
            let context = || {
                format!(
                    "program_groups[{i}] ({} program `{}`)",
                    kind.name(),
                    program.entry
                )
            };
            let names = self
                .backend
                .module_programs(program.module)
                .map_err(|e| e.context(context()))?;
            if !names.contains(&program.entry) {
                let mut same: Vec<&str> = names
                    .iter()
                    .filter(|n| ProgramKind::from_function_name(n) == Some(kind))
                    .map(String::as_str)
                    .collect();
                same.sort_unstable();
                return Err(Error::invalid(format!(
                    "the module has no program of that name (its {} programs: {})",
                    kind.name(),
                    if same.is_empty() {
                        "none".to_string()
                    } else {
                        same.join(", ")
                    }
                ))
                .context(context()));
            }
            match ProgramKind::from_function_name(&program.entry) {
                Some(actual) if actual == kind => {}
                Some(actual) => {
                    return Err(Error::invalid(format!(
                        "`{}` is a {} program (by its prefix), but the group uses it as its {} program; name that program `{}...`",
                        program.entry,
                        actual.name(),
                        kind.name(),
                        kind.prefix()
                    ))
                    .context(context()));
                }
                // Native programs of the CPU backend need no WGSL prefix.
                None => {}
            }
        }
        Ok(())
    }
}

impl<B: Backend> std::ops::Deref for Device<B> {
    type Target = B;

    fn deref(&self) -> &B {
        &self.backend
    }
}

impl<B: Backend> optik_api::Device for Device<B> {
    fn id(&self) -> DeviceId {
        self.backend.id()
    }

    fn backend(&self) -> BackendKind {
        self.backend.kind()
    }

    fn properties(&self) -> &DeviceProperties {
        self.backend.properties()
    }

    fn accuracy(&self) -> Accuracy {
        self.backend.accuracy()
    }

    fn set_accuracy(&self, accuracy: Accuracy) -> Result<()> {
        self.backend.set_accuracy(accuracy)
    }

    fn create_buffer(&self, size: u64) -> Result<Buffer> {
        validate::buffer_create(size, self.backend.properties())?;
        self.backend.create_buffer(size)
    }

    fn write_buffer(&self, buffer: Buffer, offset: u64, data: &[u8]) -> Result<()> {
        validate::buffer_range(
            "write_buffer",
            buffer,
            offset,
            data.len() as u64,
            &self.sizes(),
        )?;
        self.backend.write_buffer(buffer, offset, data)
    }

    fn read_buffer(&self, buffer: Buffer, offset: u64, out: &mut [u8]) -> Result<()> {
        validate::buffer_range(
            "read_buffer",
            buffer,
            offset,
            out.len() as u64,
            &self.sizes(),
        )?;
        self.backend.read_buffer(buffer, offset, out)
    }

    fn buffer_size(&self, buffer: Buffer) -> Result<u64> {
        self.backend.buffer_size(buffer)
    }

    fn destroy_buffer(&self, buffer: Buffer) -> Result<()> {
        self.backend.destroy_buffer(buffer)
    }

    fn create_texture(&self, desc: &TextureDesc) -> Result<Texture> {
        validate::texture(desc)?;
        self.backend.create_texture(desc)
    }

    fn write_texture(&self, texture: Texture, data: &[u8]) -> Result<()> {
        let desc = self.backend.texture_desc(texture)?;
        validate::texture_data(&desc, data)?;
        self.backend.write_texture(texture, data)
    }

    fn destroy_texture(&self, texture: Texture) -> Result<()> {
        self.backend.destroy_texture(texture)
    }

    fn accel_memory_usage(
        &self,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<AccelBufferSizes> {
        let keys =
            validate::build_inputs(options, inputs, self.backend.properties(), &self.sizes())?;
        self.backend.accel_memory_usage(options, inputs, keys)
    }

    fn accel_build(&self, options: &AccelBuildOptions, inputs: &[BuildInput]) -> Result<Accel> {
        let keys =
            validate::build_inputs(options, inputs, self.backend.properties(), &self.sizes())?;
        if options.operation != BuildOperation::Build {
            return Err(Error::invalid(
                "accel_build needs build_options.operation = Build; refit an existing structure with accel_update",
            ));
        }
        self.backend.accel_build(options, inputs, keys)
    }

    fn accel_update(
        &self,
        accel: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<()> {
        let (built_with, built_inputs) = self.built(accel, "accel_update")?;
        validate::update(&built_with, &built_inputs, options, inputs)?;
        validate::build_inputs(options, inputs, self.backend.properties(), &self.sizes())?;
        self.backend.accel_update(accel, options, inputs)
    }

    fn accel_compact(&self, accel: Accel) -> Result<Accel> {
        let (built_with, _) = self.built(accel, "accel_compact")?;
        if !built_with.flags.contains(BuildFlags::ALLOW_COMPACTION) {
            return Err(Error::invalid(
                "accel_compact: the acceleration structure was built without BuildFlags::ALLOW_COMPACTION; rebuild it with that flag",
            ));
        }
        self.backend.accel_compact(accel)
    }

    fn accel_size(&self, accel: Accel) -> Result<u64> {
        self.backend.accel_size(accel)
    }

    fn create_transform(&self, desc: &TransformDesc) -> Result<Accel> {
        validate::transform(desc)?;
        self.backend.create_transform(desc)
    }

    fn create_opacity_micromap_array(
        &self,
        desc: &OpacityMicromapArrayDesc,
    ) -> Result<MicromapArray> {
        validate::micromap_array(desc)?;
        self.backend.create_opacity_micromap_array(desc)
    }

    fn traversable_handle(&self, accel: Accel) -> Result<TraversableHandle> {
        self.backend.traversable_handle(accel)
    }

    fn destroy_accel(&self, accel: Accel) -> Result<()> {
        self.backend.destroy_accel(accel)
    }

    fn destroy_micromap_array(&self, array: MicromapArray) -> Result<()> {
        self.backend.destroy_micromap_array(array)
    }

    fn create_module(
        &self,
        module_options: &ModuleCompileOptions,
        pipeline_options: &PipelineCompileOptions,
        source: &ProgramSource,
    ) -> Result<(Module, String)> {
        let payload = pipeline_options.num_payload_values.or(MAX_PAYLOAD_VALUES);
        if payload > MAX_PAYLOAD_VALUES {
            return Err(Error::limit(format!(
                "pipeline_options.num_payload_values is {payload}; at most {MAX_PAYLOAD_VALUES} payload registers exist"
            )));
        }
        self.backend
            .create_module(module_options, pipeline_options, source)
    }

    fn destroy_module(&self, module: Module) -> Result<()> {
        self.backend.destroy_module(module)
    }

    fn create_program_groups(&self, descs: &[ProgramGroupDesc]) -> Result<Vec<ProgramGroup>> {
        for (i, desc) in descs.iter().enumerate() {
            self.check_group(i, desc)?;
        }
        self.backend.create_program_groups(descs)
    }

    fn destroy_program_group(&self, group: ProgramGroup) -> Result<()> {
        self.backend.destroy_program_group(group)
    }

    fn create_pipeline(
        &self,
        pipeline_options: &PipelineCompileOptions,
        link_options: &PipelineLinkOptions,
        groups: &[ProgramGroup],
    ) -> Result<Pipeline> {
        if groups.is_empty() {
            return Err(Error::invalid(
                "create_pipeline needs at least one program group (a raygen group)",
            ));
        }
        let mut raygen = false;
        for (i, g) in groups.iter().enumerate() {
            let region = self
                .backend
                .group_region(*g)
                .map_err(|e| e.context(format!("groups[{i}]")))?;
            raygen |= region == GroupRegion::Raygen;
        }
        if !raygen {
            return Err(Error::invalid(
                "create_pipeline: none of the groups is a raygen group; launches start in a raygen program",
            ));
        }
        let programs = self.backend.program_features(groups)?;
        let scene = self.backend.scene_features()?;
        let features = features::resolve(
            pipeline_options,
            link_options,
            scene,
            &programs,
            self.backend.properties().max_trace_depth,
        )?;
        self.backend
            .create_pipeline(pipeline_options, link_options, groups, &features)
    }

    fn pipeline_features(&self, pipeline: Pipeline) -> Result<FeatureSet> {
        self.backend.pipeline_features(pipeline)
    }

    fn destroy_pipeline(&self, pipeline: Pipeline) -> Result<()> {
        self.backend.destroy_pipeline(pipeline)
    }

    fn sbt_record_pack_header(&self, group: ProgramGroup) -> Result<[u8; 32]> {
        Ok(SbtHeader::pack(group, self.backend.group_region(group)?))
    }

    fn launch_with(
        &self,
        pipeline: Pipeline,
        params: &[u8],
        resources: &[Resource],
        sbt: &ShaderBindingTable,
        size: LaunchSize,
        options: &LaunchOptions,
    ) -> Result<()> {
        let bindings = self.backend.pipeline_bindings(pipeline)?;
        let props = self.backend.properties();
        validate::launch_size(size, props)?;
        validate::sbt(sbt, props, &self.sizes())?;
        validate::launch_bindings(params, resources, &bindings, &self.sizes())?;
        for r in resources {
            match r {
                Resource::Buffer {
                    binding,
                    buffer,
                    offset,
                    size,
                } => {
                    let what = format!("resource at binding {binding}");
                    let total = self
                        .backend
                        .buffer_size(*buffer)
                        .map_err(|e| e.context(&what))?;
                    let len = size.unwrap_or(total.saturating_sub(*offset));
                    validate::buffer_range(&what, *buffer, *offset, len, &self.sizes())?;
                }
                Resource::Texture { binding, texture } => {
                    self.backend
                        .texture_desc(*texture)
                        .map_err(|e| e.context(format!("resource at binding {binding}")))?;
                }
                Resource::Sampler { .. } => {}
            }
        }
        self.backend
            .launch(pipeline, params, resources, sbt, size, options)
    }

    fn synchronize(&self) -> Result<()> {
        self.backend.synchronize()
    }

    fn take_diagnostics(&self) -> Vec<String> {
        self.backend.take_diagnostics()
    }
}
