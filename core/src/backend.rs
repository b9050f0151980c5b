//! [`Backend`]: what a backend implements, unchecked.

use crate::frontend::BindingInfo;
use optik_api::{
    Accel, AccelBufferSizes, AccelBuildOptions, Accuracy, BackendKind, Buffer, BuildInput,
    DeviceId, DeviceProperties, FeatureSet, GroupRegion, LaunchOptions, LaunchSize, MicromapArray,
    Module, ModuleCompileOptions, OpacityMicromapArrayDesc, Pipeline, PipelineCompileOptions,
    PipelineLinkOptions, ProgramFeatures, ProgramGroup, ProgramGroupDesc, ProgramSource, Resource,
    Result, SceneFeatures, ShaderBindingTable, Texture, TextureDesc, TransformDesc,
    TraversableHandle,
};

/// A backend's device: the calls of [`optik_api::Device`] without the checks
/// [`crate::Device`] makes before it calls them.
///
/// Each method's documentation says what has been checked by the time it runs. Handles are
/// not: a backend looks each up in its own `crate::HandleTable`, whose errors are the
/// same on every backend. Methods that only report (`buffer_size`, `texture_desc`,
/// `accel_build_record`, `module_programs`, `group_region`, `pipeline_bindings`) give
/// [`crate::Device`] what its checks need.
pub trait Backend: Send + Sync + 'static {
    /// The device's id; every handle it returns carries it.
    fn id(&self) -> DeviceId;
    /// The backend.
    fn kind(&self) -> BackendKind;
    /// Limits and constants.
    fn properties(&self) -> &DeviceProperties;
    /// The accuracy setting in force.
    fn accuracy(&self) -> Accuracy;
    /// Chooses the triangle and box tests; what a backend can do differs, so it decides.
    fn set_accuracy(&self, accuracy: Accuracy) -> Result<()>;

    /// Creates a zero-filled buffer; `size` is within `max_buffer_size`.
    fn create_buffer(&self, size: u64) -> Result<Buffer>;
    /// Writes `data` at `offset`; the range lies inside the buffer.
    fn write_buffer(&self, buffer: Buffer, offset: u64, data: &[u8]) -> Result<()>;
    /// Reads `out.len()` bytes from `offset` after earlier launches; the range lies inside.
    fn read_buffer(&self, buffer: Buffer, offset: u64, out: &mut [u8]) -> Result<()>;
    /// The buffer's size in bytes.
    fn buffer_size(&self, buffer: Buffer) -> Result<u64>;
    /// Frees the buffer.
    fn destroy_buffer(&self, buffer: Buffer) -> Result<()>;

    /// Creates a texture; `desc` has been checked.
    fn create_texture(&self, desc: &TextureDesc) -> Result<Texture>;
    /// The description the texture was created with.
    fn texture_desc(&self, texture: Texture) -> Result<TextureDesc>;
    /// Writes all texels; `data` has the texture's size.
    fn write_texture(&self, texture: Texture, data: &[u8]) -> Result<()>;
    /// Frees the texture.
    fn destroy_texture(&self, texture: Texture) -> Result<()>;

    /// The memory a build would need; options and inputs have been checked
    /// (`crate::validate::build_inputs`), `motion_keys` is their key count.
    fn accel_memory_usage(
        &self,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
        motion_keys: usize,
    ) -> Result<AccelBufferSizes>;
    /// Builds a structure; options (operation `Build`) and inputs have been checked,
    /// `motion_keys` is their key count.
    fn accel_build(
        &self,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
        motion_keys: usize,
    ) -> Result<Accel>;
    /// The options and inputs `accel` was last built or updated from; `None` for a
    /// transform.
    fn accel_build_record(
        &self,
        accel: Accel,
    ) -> Result<Option<(AccelBuildOptions, Vec<BuildInput>)>>;
    /// Refits `accel`, which is no transform and was built with `ALLOW_UPDATE`; the update
    /// keeps its kinds and counts and the inputs have been checked.
    fn accel_update(
        &self,
        accel: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<()>;
    /// A compacted copy of `accel`, which is no transform and was built with
    /// `ALLOW_COMPACTION`.
    fn accel_compact(&self, accel: Accel) -> Result<Accel>;
    /// The structure's size in bytes.
    fn accel_size(&self, accel: Accel) -> Result<u64>;
    /// Creates a transform; `desc` has been checked except for its child handle.
    fn create_transform(&self, desc: &TransformDesc) -> Result<Accel>;
    /// Builds a micromap array; `desc` has been checked.
    fn create_opacity_micromap_array(
        &self,
        desc: &OpacityMicromapArrayDesc,
    ) -> Result<MicromapArray>;
    /// The traversable handle of a structure or transform.
    fn traversable_handle(&self, accel: Accel) -> Result<TraversableHandle>;
    /// Frees a structure or transform.
    fn destroy_accel(&self, accel: Accel) -> Result<()>;
    /// Frees a micromap array.
    fn destroy_micromap_array(&self, array: MicromapArray) -> Result<()>;

    /// Compiles a module; `pipeline_options.num_payload_values` is at most 32.
    fn create_module(
        &self,
        module_options: &ModuleCompileOptions,
        pipeline_options: &PipelineCompileOptions,
        source: &ProgramSource,
    ) -> Result<(Module, String)>;
    /// The names of the module's programs.
    fn module_programs(&self, module: Module) -> Result<Vec<String>>;
    /// Frees a module.
    fn destroy_module(&self, module: Module) -> Result<()>;
    /// Creates program groups; every program they name exists in its module (which is
    /// alive) and is of the kind the group uses it as.
    fn create_program_groups(&self, descs: &[ProgramGroupDesc]) -> Result<Vec<ProgramGroup>>;
    /// The SBT region the group's records belong in.
    fn group_region(&self, group: ProgramGroup) -> Result<GroupRegion>;
    /// Frees a program group.
    fn destroy_program_group(&self, group: ProgramGroup) -> Result<()>;
    /// Links a pipeline; `groups` is not empty, every group is alive and one is a raygen
    /// group, and `features` is what [`crate::Device`] resolved for it
    /// ([`crate::features::resolve`] over [`Backend::program_features`] and
    /// [`Backend::scene_features`]).
    fn create_pipeline(
        &self,
        pipeline_options: &PipelineCompileOptions,
        link_options: &PipelineLinkOptions,
        groups: &[ProgramGroup],
        features: &FeatureSet,
    ) -> Result<Pipeline>;
    /// What the programs of `groups` use: their modules' front-end analysis
    /// ([`crate::features::program_features`]), and for programs that are not WGSL what
    /// they declare. The groups are checked here (a destroyed group is an error naming its
    /// index).
    fn program_features(&self, groups: &[ProgramGroup]) -> Result<ProgramFeatures>;
    /// The union of the features of every live acceleration structure and transform;
    /// `None` when there is none. What `Auto` pipeline options resolve against.
    fn scene_features(&self) -> Result<Option<SceneFeatures>>;
    /// The features the pipeline was compiled with.
    fn pipeline_features(&self, pipeline: Pipeline) -> Result<FeatureSet>;
    /// The `@group(0)` bindings the pipeline's programs use (a binding may be listed once
    /// per module).
    fn pipeline_bindings(&self, pipeline: Pipeline) -> Result<Vec<BindingInfo>>;
    /// Frees a pipeline.
    fn destroy_pipeline(&self, pipeline: Pipeline) -> Result<()>;

    /// Launches; the pipeline is alive, the size within the device's limit, the SBT's
    /// regions aligned and inside their buffers, params and resources match the pipeline's
    /// bindings and every resource is alive and in range. Record headers are the backend's
    /// to read.
    fn launch(
        &self,
        pipeline: Pipeline,
        params: &[u8],
        resources: &[Resource],
        sbt: &ShaderBindingTable,
        size: LaunchSize,
        options: &LaunchOptions,
    ) -> Result<()>;
    /// Waits for every launch to finish.
    fn synchronize(&self) -> Result<()>;
    /// What the driver reported since the last call (`optik_api::Device::take_diagnostics`).
    fn take_diagnostics(&self) -> Vec<String> {
        Vec::new()
    }
}
