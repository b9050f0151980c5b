//! [`Backend`]: what a backend implements, unchecked, and the objects it makes.

use crate::Objects;
use crate::frontend::BindingInfo;
use optik_api::{
    Accel, AccelBufferSizes, AccelBuildOptions, Accuracy, BackendKind, BuildInput, DeviceId,
    DeviceProperties, FeatureSet, GroupRegion, LaunchOptions, LaunchSize, ModuleCompileOptions,
    OpacityMicromapArrayDesc, Pipeline, PipelineCompileOptions, PipelineLinkOptions,
    ProgramFeatures, ProgramGroup, ProgramGroupDesc, ProgramSource, Resource, Result,
    SceneFeatures, ShaderBindingTable, TextureDesc, TransformDesc, TraversableHandle,
};

/// A backend's device: the calls of [`optik_api::Device`] without the checks
/// [`crate::Device`] makes before it calls them, and the objects they make.
///
/// [`crate::Device`] owns the objects: it keeps each kind in a [`crate::HandleTable`] of
/// [`Objects`] under one lock, looks handles up (a destroyed or foreign handle is an error
/// worded once, whatever the backend) and passes the objects in. Calls whose inputs name
/// further objects (build inputs naming buffers, a pipeline's groups, a launch's resources
/// and SBT) get the tables themselves, locked. A backend never calls back into
/// [`crate::Device`], so its own lock, if it has one, is always taken second.
///
/// Each method's documentation says what has been checked by the time it runs. Methods
/// that only report (`buffer_size`, `texture_desc`, `accel_build_record`, `accel_size`,
/// `accel_features`, `module_programs`, `group_region`, `pipeline_features`,
/// `pipeline_bindings`) give [`crate::Device`] what its checks and answers need.
pub trait Backend: Send + Sync + Sized + 'static {
    /// A buffer.
    type Buffer: Send;
    /// A texture.
    type Texture: Send;
    /// An acceleration structure or a transform.
    type Accel: Send;
    /// An opacity micromap array.
    type MicromapArray: Send;
    /// A compiled module.
    type Module: Send;
    /// A program group.
    type ProgramGroup: Send;
    /// A linked pipeline.
    type Pipeline: Send;

    /// Whether the backend's devices go through the system's Vulkan loader: then
    /// [`crate::Device`] holds [`crate::vulkan_loader::using`] through every call, and the
    /// backend opens and destroys its devices under
    /// [`crate::vulkan_loader::changing_devices`].
    const USES_VULKAN_LOADER: bool = false;

    /// The device's id; every handle it returns carries it.
    fn id(&self) -> DeviceId;
    /// The backend.
    fn kind(&self) -> BackendKind;
    /// Limits and constants.
    fn properties(&self) -> &DeviceProperties;
    /// The accuracy setting in force.
    fn accuracy(&self) -> Accuracy;
    /// `Ok` while the device works; after the device was lost, the error that says so
    /// (`ErrorKind::DeviceLost`), which [`crate::Device`] returns from every later call
    /// before it looks at any argument.
    fn alive(&self) -> Result<()> {
        Ok(())
    }
    /// Chooses the triangle and box tests; what a backend can do differs, so it decides
    /// (with the live objects in view: a backend may refuse to switch while structures
    /// built the other way are alive).
    fn set_accuracy(&self, objects: &Objects<Self>, accuracy: Accuracy) -> Result<()>;

    /// Creates a zero-filled buffer; `size` is within `max_buffer_size`.
    fn create_buffer(&self, size: u64) -> Result<Self::Buffer>;
    /// Writes `data` at `offset`; the range lies inside the buffer.
    fn write_buffer(&self, buffer: &mut Self::Buffer, offset: u64, data: &[u8]) -> Result<()>;
    /// Reads `out.len()` bytes from `offset` after earlier launches; the range lies inside.
    fn read_buffer(&self, buffer: &mut Self::Buffer, offset: u64, out: &mut [u8]) -> Result<()>;
    /// The buffer's size in bytes.
    fn buffer_size(&self, buffer: &Self::Buffer) -> u64;
    /// Frees a buffer [`crate::Device`] has taken out of its table.
    fn destroy_buffer(&self, buffer: Self::Buffer) -> Result<()>;

    /// Creates a texture; `desc` has been checked.
    fn create_texture(&self, desc: &TextureDesc) -> Result<Self::Texture>;
    /// The description the texture was created with.
    fn texture_desc(&self, texture: &Self::Texture) -> TextureDesc;
    /// Writes all texels; `data` has the texture's size.
    fn write_texture(&self, texture: &mut Self::Texture, data: &[u8]) -> Result<()>;
    /// Frees a texture taken out of its table.
    fn destroy_texture(&self, texture: Self::Texture) -> Result<()>;

    /// The memory a build would need; options and inputs have been checked
    /// (`crate::validate::build_inputs`), `motion_keys` is their key count.
    fn accel_memory_usage(
        &self,
        objects: &mut Objects<Self>,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
        motion_keys: usize,
    ) -> Result<AccelBufferSizes>;
    /// Builds a structure that will have the handle `handle`; options (operation `Build`)
    /// and inputs have been checked, `motion_keys` is their key count. The buffers and
    /// micromap arrays the inputs name are looked up in `objects`.
    fn accel_build(
        &self,
        objects: &mut Objects<Self>,
        handle: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
        motion_keys: usize,
    ) -> Result<Self::Accel>;
    /// The options and inputs the structure was last built or updated from; `None` for a
    /// transform.
    fn accel_build_record(
        &self,
        accel: &Self::Accel,
    ) -> Option<(AccelBuildOptions, Vec<BuildInput>)>;
    /// Refits the structure `accel` (in `objects`), which is no transform and was built
    /// with `ALLOW_UPDATE`; the update keeps its kinds and counts and the inputs have been
    /// checked.
    fn accel_update(
        &self,
        objects: &mut Objects<Self>,
        accel: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<()>;
    /// A compacted copy of the structure `accel` (in `objects`, no transform, built with
    /// `ALLOW_COMPACTION`) that will have the handle `handle`.
    fn accel_compact(
        &self,
        objects: &mut Objects<Self>,
        accel: Accel,
        handle: Accel,
    ) -> Result<Self::Accel>;
    /// The structure's size in bytes.
    fn accel_size(&self, accel: &Self::Accel) -> u64;
    /// What the structure or transform holds, for pipelines whose options are `Auto`.
    fn accel_features(&self, accel: &Self::Accel) -> SceneFeatures;
    /// Creates a transform that will have the handle `handle`; `desc` has been checked
    /// except for its child handle.
    fn create_transform(
        &self,
        objects: &mut Objects<Self>,
        handle: Accel,
        desc: &TransformDesc,
    ) -> Result<Self::Accel>;
    /// Builds a micromap array; `desc` has been checked.
    fn create_opacity_micromap_array(
        &self,
        desc: &OpacityMicromapArrayDesc,
    ) -> Result<Self::MicromapArray>;
    /// The traversable handle of the structure or transform `accel` (whose handle is
    /// `handle`).
    fn traversable_handle(&self, handle: Accel, accel: &Self::Accel) -> Result<TraversableHandle>;
    /// Frees a structure or transform taken out of its table (`handle` was its handle;
    /// `objects` holds the rest).
    fn destroy_accel(
        &self,
        objects: &mut Objects<Self>,
        handle: Accel,
        accel: Self::Accel,
    ) -> Result<()>;
    /// Frees a micromap array taken out of its table.
    fn destroy_micromap_array(&self, array: Self::MicromapArray) -> Result<()>;

    /// Compiles a module; `pipeline_options.num_payload_values` is at most 32.
    fn create_module(
        &self,
        module_options: &ModuleCompileOptions,
        pipeline_options: &PipelineCompileOptions,
        source: &ProgramSource,
    ) -> Result<(Self::Module, String)>;
    /// The names of the module's programs.
    fn module_programs(&self, module: &Self::Module) -> Vec<String>;
    /// Frees a module taken out of its table.
    fn destroy_module(&self, module: Self::Module) -> Result<()>;
    /// Creates program groups; every program they name exists in its module (which is
    /// alive in `objects`) and is of the kind the group uses it as.
    fn create_program_groups(
        &self,
        objects: &Objects<Self>,
        descs: &[ProgramGroupDesc],
    ) -> Result<Vec<Self::ProgramGroup>>;
    /// The SBT region the group's records belong in.
    fn group_region(&self, group: &Self::ProgramGroup) -> GroupRegion;
    /// Frees a program group taken out of its table.
    fn destroy_program_group(&self, group: Self::ProgramGroup) -> Result<()>;
    /// Links a pipeline; `groups` is not empty, every group is alive in `objects` and one
    /// is a raygen group, and `features` is what [`crate::Device`] resolved for it
    /// ([`crate::features::resolve`] over [`Backend::program_features`] and the live
    /// structures' [`Backend::accel_features`]).
    fn create_pipeline(
        &self,
        objects: &Objects<Self>,
        pipeline_options: &PipelineCompileOptions,
        link_options: &PipelineLinkOptions,
        groups: &[ProgramGroup],
        features: &FeatureSet,
    ) -> Result<Self::Pipeline>;
    /// What the programs of `groups` (alive in `objects`) use: their modules' front-end
    /// analysis ([`crate::features::program_features`]), and for programs that are not
    /// WGSL what they declare.
    fn program_features(
        &self,
        objects: &Objects<Self>,
        groups: &[ProgramGroup],
    ) -> Result<ProgramFeatures>;
    /// The features the pipeline was compiled with.
    fn pipeline_features(&self, pipeline: &Self::Pipeline) -> FeatureSet;
    /// The `@group(0)` bindings the pipeline's programs use (a binding may be listed once
    /// per module).
    fn pipeline_bindings(&self, pipeline: &Self::Pipeline) -> Vec<BindingInfo>;
    /// Frees a pipeline taken out of its table.
    fn destroy_pipeline(&self, pipeline: Self::Pipeline) -> Result<()>;

    /// Launches `pipeline` (in `objects`); the size is within the device's limit, the
    /// SBT's regions aligned and inside their buffers, params and resources match the
    /// pipeline's bindings and every resource is alive and in range. Record headers are
    /// the backend's to read.
    #[allow(clippy::too_many_arguments)]
    fn launch(
        &self,
        objects: &mut Objects<Self>,
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
    /// Takes back every object still alive when the device is dropped (a backend that
    /// must wait for its launches, or free objects in an order, does so here; by default
    /// they are dropped).
    fn release(&self, objects: Objects<Self>) {
        drop(objects);
    }
}
