//! The `Device` trait every backend implements (OptiX `OptixDeviceContext` and the calls
//! made on it), device properties and the accuracy setting.

use crate::accel::{
    AccelBufferSizes, AccelBuildOptions, BuildInput, OpacityMicromapArrayDesc, TransformDesc,
    TraversableHandle,
};
use crate::error::Result;
use crate::features::FeatureSet;
use crate::handle::{
    Accel, Buffer, DeviceId, MicromapArray, Module, Pipeline, ProgramGroup, Texture,
};
use crate::launch::{LaunchOptions, LaunchSize, Resource, TextureDesc};
use crate::program::{
    ModuleCompileOptions, PipelineCompileOptions, PipelineLinkOptions, ProgramGroupDesc,
};
use crate::sbt::ShaderBindingTable;

/// The three backends.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum BackendKind {
    /// `optik-cpu`: robust traversal and JIT-compiled programs on the CPU.
    Cpu,
    /// `optik-wgpu`: software traversal in a WGSL compute megakernel.
    Wgpu,
    /// `optik-vulkan`: Vulkan ray tracing pipelines.
    Vulkan,
}

impl BackendKind {
    /// Every backend, in the order of DESIGN.md's table.
    pub const ALL: [BackendKind; 3] = [BackendKind::Cpu, BackendKind::Wgpu, BackendKind::Vulkan];

    /// The name used on the command line (`cpu`, `wgpu`, `vulkan`).
    pub fn name(self) -> &'static str {
        match self {
            BackendKind::Cpu => "cpu",
            BackendKind::Wgpu => "wgpu",
            BackendKind::Vulkan => "vulkan",
        }
    }

    /// The backend named `name`.
    pub fn from_name(name: &str) -> Option<BackendKind> {
        BackendKind::ALL.into_iter().find(|k| k.name() == name)
    }
}

impl std::fmt::Display for BackendKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Limits and constants of a device (OptiX `optixDeviceContextGetProperty`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DeviceProperties {
    /// Largest `max_trace_depth` a pipeline may link with.
    pub max_trace_depth: u32,
    /// Deepest traversable graph (instances and transforms nested, plus the geometry).
    pub max_traversable_graph_depth: u32,
    /// Most primitives in one build input.
    pub max_primitives_per_build_input: u32,
    /// Most instances in one instance acceleration structure.
    pub max_instances_per_ias: u32,
    /// Largest instance id plus one (ids are masked to this many values).
    pub max_instance_id: u32,
    /// Largest instance SBT offset plus one.
    pub max_sbt_offset: u32,
    /// Bits of the instance visibility mask that count.
    pub num_bits_instance_visibility_mask: u32,
    /// Most SBT records one build input may span.
    pub max_sbt_records_per_build_input: u32,
    /// SBT record header size (32).
    pub sbt_record_header_size: u32,
    /// SBT record and stride alignment (16).
    pub sbt_record_alignment: u32,
    /// Largest SBT record stride the backend accepts.
    pub max_sbt_record_stride: u32,
    /// Most payload registers (32).
    pub max_payload_values: u32,
    /// Most attribute registers (8).
    pub max_attribute_values: u32,
    /// Most invocations in one launch (width × height × depth).
    pub max_launch_size: u64,
    /// Largest buffer in bytes.
    pub max_buffer_size: u64,
    /// Largest byte range one buffer resource of a launch may bind (a GPU's storage binding
    /// limit: 128 MiB on lavapipe); bind ranges of a larger buffer and launch in parts.
    pub max_binding_size: u64,
    /// The backend.
    pub backend: BackendKind,
    /// The device's name (the CPU model, the GPU adapter).
    pub device_name: String,
    /// The driver and its version as the platform reports them (Vulkan: the driver's name,
    /// its info string and version; wgpu: the adapter's driver and driver info; CPU: optik's
    /// own version). What depends on the driver's behaviour is cached under it
    /// ([`crate::DeviceProperties::device_name`] and this together name one driver build).
    pub driver: String,
}

/// Triangle intersection test (DESIGN.md §5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum TriangleTest {
    /// Woop, Benthin and Wald's watertight test with an f64 fallback: rays through shared
    /// edges and vertices never leak.
    #[default]
    Watertight,
    /// Möller–Trumbore: not watertight (rays through shared edges can slip between
    /// neighbours). Cheaper per triangle where triangles are tested one at a time; the CPU
    /// backend's four- and eight-lane block tests price it within a few percent of the
    /// watertight test, on either side by machine (`optik bench-report` measures it;
    /// docs/cpu-backend.md §8).
    MollerTrumbore,
    /// The device's own triangle test; Vulkan only (the driver's native triangles, its
    /// fastest path: watertightness is whatever the driver gives). The CPU and wgpu backends
    /// refuse it.
    Driver,
}

/// Bounding box test of traversal (DESIGN.md §5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum BoxTest {
    /// Slab test widened by 1 + 2γ(3) (pbrt-v4, Embree's robust mode): no false misses.
    #[default]
    Conservative,
    /// Plain slab test: may miss boxes a ray grazes. Faster where the widening is a multiply
    /// per box test (wgpu); the CPU backend widens once per ray (the far planes' reciprocal),
    /// so there it runs in the same time as the conservative test (docs/cpu-backend.md §8,
    /// "The slab test's chain").
    Plain,
}

/// The accuracy setting of CPU and wgpu devices: each choice has a measured price in
/// `optik bench-report`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Accuracy {
    /// The triangle test.
    pub triangle: TriangleTest,
    /// The box test.
    pub box_test: BoxTest,
}

impl Accuracy {
    /// The fast options: Möller–Trumbore and plain slabs.
    pub const FAST: Accuracy = Accuracy {
        triangle: TriangleTest::MollerTrumbore,
        box_test: BoxTest::Plain,
    };
    /// The robust default.
    pub const ROBUST: Accuracy = Accuracy {
        triangle: TriangleTest::Watertight,
        box_test: BoxTest::Conservative,
    };

    /// Parses `robust`, `fast`, `watertight+plain`, `mt+conservative`, `driver+conservative`
    /// and the like.
    pub fn parse(s: &str) -> Option<Accuracy> {
        match s {
            "robust" | "default" => return Some(Accuracy::ROBUST),
            "fast" => return Some(Accuracy::FAST),
            _ => {}
        }
        let (tri, bx) = s.split_once('+')?;
        let triangle = match tri {
            "watertight" => TriangleTest::Watertight,
            "mt" | "moller-trumbore" => TriangleTest::MollerTrumbore,
            "driver" => TriangleTest::Driver,
            _ => return None,
        };
        let box_test = match bx {
            "conservative" => BoxTest::Conservative,
            "plain" => BoxTest::Plain,
            _ => return None,
        };
        Some(Accuracy { triangle, box_test })
    }
}

/// A WGSL source with the file name its diagnostics report.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ProgramSource {
    /// Shown in diagnostics as `file:line:column`.
    pub file_name: String,
    /// The user's WGSL.
    pub wgsl: String,
}

impl ProgramSource {
    /// Source text with a file name for diagnostics.
    pub fn new(file_name: impl Into<String>, wgsl: impl Into<String>) -> Self {
        Self {
            file_name: file_name.into(),
            wgsl: wgsl.into(),
        }
    }
}

/// A ray tracing device (OptiX `OptixDeviceContext`): creates and owns buffers, acceleration
/// structures, modules, program groups and pipelines, and launches.
///
/// Object-safe, so `Box<dyn Device>` works and code can loop over backends. Every handle is
/// checked on use; dropping the device frees everything it owns. No call panics on any input.
pub trait Device: Send + Sync {
    /// This device's id; every handle it returns carries it.
    fn id(&self) -> DeviceId;
    /// The backend.
    fn backend(&self) -> BackendKind;
    /// Limits and constants.
    fn properties(&self) -> &DeviceProperties;
    /// The accuracy setting in force.
    fn accuracy(&self) -> Accuracy;
    /// Chooses the triangle and box tests (CPU and wgpu; the Vulkan backend accepts only
    /// what its driver does and errors otherwise). Applies to pipelines created afterwards.
    fn set_accuracy(&self, accuracy: Accuracy) -> Result<()>;

    /// Creates a zero-filled buffer of `size` bytes.
    fn create_buffer(&self, size: u64) -> Result<Buffer>;
    /// Writes `data` at `offset`; the range must lie inside the buffer.
    fn write_buffer(&self, buffer: Buffer, offset: u64, data: &[u8]) -> Result<()>;
    /// Reads `out.len()` bytes from `offset`, after every earlier launch has finished.
    fn read_buffer(&self, buffer: Buffer, offset: u64, out: &mut [u8]) -> Result<()>;
    /// The buffer's size in bytes.
    fn buffer_size(&self, buffer: Buffer) -> Result<u64>;
    /// Frees the buffer.
    fn destroy_buffer(&self, buffer: Buffer) -> Result<()>;

    /// Creates a 2D texture, zero-filled.
    fn create_texture(&self, desc: &TextureDesc) -> Result<Texture>;
    /// Writes all texels, rows packed, `height × width × texel size` bytes.
    fn write_texture(&self, texture: Texture, data: &[u8]) -> Result<()>;
    /// Frees the texture.
    fn destroy_texture(&self, texture: Texture) -> Result<()>;

    /// The memory a build of `inputs` would need (OptiX `optixAccelComputeMemoryUsage`).
    fn accel_memory_usage(
        &self,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<AccelBufferSizes>;
    /// Builds a geometry or instance acceleration structure (OptiX `optixAccelBuild`).
    /// All inputs must be of one kind: geometry of one primitive type, or instances.
    fn accel_build(&self, options: &AccelBuildOptions, inputs: &[BuildInput]) -> Result<Accel>;
    /// Refits `accel` to `inputs` (same kinds and counts as its build; the build must have
    /// had `ALLOW_UPDATE`). Its traversable handle stays the same.
    fn accel_update(
        &self,
        accel: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<()>;
    /// A compacted copy of `accel` (built with `ALLOW_COMPACTION`), with a new handle; the
    /// original stays valid until destroyed.
    fn accel_compact(&self, accel: Accel) -> Result<Accel>;
    /// The size of `accel` in bytes (after compaction, the compacted size).
    fn accel_size(&self, accel: Accel) -> Result<u64>;
    /// Creates a static, matrix-motion or SRT-motion transform traversable.
    fn create_transform(&self, desc: &TransformDesc) -> Result<Accel>;
    /// Builds an opacity micromap array for triangle inputs.
    fn create_opacity_micromap_array(
        &self,
        desc: &OpacityMicromapArrayDesc,
    ) -> Result<MicromapArray>;
    /// The traversable handle of an acceleration structure or transform.
    fn traversable_handle(&self, accel: Accel) -> Result<TraversableHandle>;
    /// Frees an acceleration structure or transform. Instances and transforms that name it
    /// then miss it; nothing dangles.
    fn destroy_accel(&self, accel: Accel) -> Result<()>;
    /// Frees a micromap array.
    fn destroy_micromap_array(&self, array: MicromapArray) -> Result<()>;

    /// Compiles a WGSL module (OptiX `optixModuleCreate`); returns the module and a log.
    /// Errors name the user's `file:line:column`.
    fn create_module(
        &self,
        module_options: &ModuleCompileOptions,
        pipeline_options: &PipelineCompileOptions,
        source: &ProgramSource,
    ) -> Result<(Module, String)>;
    /// Frees a module.
    fn destroy_module(&self, module: Module) -> Result<()>;
    /// Creates program groups (OptiX `optixProgramGroupCreate`).
    fn create_program_groups(&self, descs: &[ProgramGroupDesc]) -> Result<Vec<ProgramGroup>>;
    /// Frees a program group.
    fn destroy_program_group(&self, group: ProgramGroup) -> Result<()>;
    /// Links a pipeline (OptiX `optixPipelineCreate`); `Auto` settings are resolved against
    /// the acceleration structures alive now and the programs (DESIGN.md §6).
    fn create_pipeline(
        &self,
        pipeline_options: &PipelineCompileOptions,
        link_options: &PipelineLinkOptions,
        groups: &[ProgramGroup],
    ) -> Result<Pipeline>;
    /// The features the pipeline was compiled with (DESIGN.md §6).
    fn pipeline_features(&self, pipeline: Pipeline) -> Result<FeatureSet>;
    /// Frees a pipeline.
    fn destroy_pipeline(&self, pipeline: Pipeline) -> Result<()>;
    /// The 32-byte SBT record header for `group` (OptiX `optixSbtRecordPackHeader`).
    fn sbt_record_pack_header(&self, group: ProgramGroup) -> Result<[u8; 32]>;

    /// Launches `size` raygen invocations (OptiX `optixLaunch`). `params` are the bytes of
    /// the `params` uniform; `resources` bind `@group(0)` variables from 1 up. Asynchronous:
    /// [`Device::synchronize`] or a read waits. A launch with a zero dimension does nothing.
    /// The same as [`Device::launch_with`] with default options.
    fn launch(
        &self,
        pipeline: Pipeline,
        params: &[u8],
        resources: &[Resource],
        sbt: &ShaderBindingTable,
        size: LaunchSize,
    ) -> Result<()> {
        self.launch_with(
            pipeline,
            params,
            resources,
            sbt,
            size,
            &LaunchOptions::default(),
        )
    }
    /// [`Device::launch`] that may be stopped early: by `options.deadline`, by
    /// `options.cancel`, or by [`interrupt_launches`](crate::interrupt_launches) (Ctrl-C in
    /// the `optik` command). A stopped launch returns an `ErrorKind::TimedOut` or
    /// `ErrorKind::Cancelled` error and what it wrote is incomplete; the device stays usable.
    /// GPU backends return at once but cannot stop a running shader: later calls wait for
    /// it to end, and a driver watchdog that ends it loses the device
    /// (`ErrorKind::DeviceLost` from then on; open a new device).
    /// A launch with a deadline or a token waits for its work to finish (or stop) before it
    /// returns.
    fn launch_with(
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

    /// What the driver reported since the last call, oldest first: the Khronos validation
    /// layer's messages on the Vulkan backend when validation is on (`OPTIK_VALIDATION=1`);
    /// nothing on backends without such a channel. The conformance suite fails a case on
    /// any (DESIGN.md §9).
    fn take_diagnostics(&self) -> Vec<String> {
        Vec::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accuracy_names_parse() {
        assert_eq!(Accuracy::parse("robust"), Some(Accuracy::ROBUST));
        assert_eq!(Accuracy::parse("fast"), Some(Accuracy::FAST));
        assert_eq!(
            Accuracy::parse("driver+conservative"),
            Some(Accuracy {
                triangle: TriangleTest::Driver,
                box_test: BoxTest::Conservative,
            })
        );
        assert_eq!(Accuracy::parse("driver"), None);
    }
}
