//! [`CpuBackend`]: the CPU backend's `optik_core::Backend` ([`CpuDevice`] is the device
//! users hold: optik-core's checks in front of it).
//!
//! optik-core owns the objects (the associated types: buffer memory, textures, built
//! traversables, compiled modules, groups and pipelines) and lends them to each call under
//! its lock; the backend's own lock holds what is no object: the accuracy setting and the
//! scene table that resolves traversable handles during traversal. Launches run
//! synchronously inside `launch` (OptiX allows a launch to finish before it returns), so
//! `synchronize` has nothing to wait for and a launch's buffers cannot change under it;
//! other calls on the device wait while a launch runs.

use crate::accel::{self, Gas, Ias, MicromapLookup, SceneTable, Transform, Traversable, handle};
use crate::launch::{self, LaunchShared};
use crate::objects::{
    AccelObject, AccelOrigin, BufferData, GroupObject, MicromapArrayData, ModuleObject,
    PipelineObject, TextureData,
};
use crate::pipeline::{self, NativeModuleDesc, PreparedModules};
use crate::program::abi::{Bindings, BoundBuffer, BoundResource, BoundTexture};
use crate::sbt::{self, RecordBytes};
use crate::traversal::TraceConfig;
use optik_accel::decode::BufferBytes;
use optik_api::{
    Accel, AccelBufferSizes, AccelBuildOptions, Accuracy, BackendKind, Buffer, BuildInput,
    DeviceId, DeviceProperties, Error, ExceptionFlags, FeatureSet, GroupRegion, Handle,
    LaunchOptions, LaunchSize, LaunchWatch, MicromapArray, Module, ModuleCompileOptions,
    OpacityMicromapArrayDesc, Pipeline, PipelineCompileOptions, PipelineLinkOptions, ProgramGroup,
    ProgramGroupDesc, ProgramSource, Resource, Result, SceneFeatures, ShaderBindingTable,
    TextureDesc, TransformDesc, TraversableHandle,
};
use optik_core::frontend::BindingInfo;
use optik_core::{HandleTable, Objects};
use std::sync::{Arc, Mutex, MutexGuard};

/// Deepest nesting of callables a pipeline may link with (each level is a native stack
/// frame of the launch thread).
pub const MAX_CALLABLE_DEPTH: u32 = 64;
/// Stack size of launch threads: traces nest up to 31 deep, each with programs and
/// callables on the stack.
const THREAD_STACK_BYTES: usize = 64 << 20;

/// What the backend keeps that is no object.
struct State {
    /// Traversable handle → traversable, by the structure's handle slot: what instances and
    /// traces resolve handles through.
    scene: SceneTable,
    accuracy: Accuracy,
}

/// Buffer bytes and micromaps for the builders.
struct Inputs<'a> {
    buffers: &'a HandleTable<Buffer, BufferData>,
    micromaps: &'a HandleTable<MicromapArray, Arc<MicromapArrayData>>,
}

impl BufferBytes for Inputs<'_> {
    fn bytes(&self, buffer: Buffer) -> Result<&[u8]> {
        self.buffers.get(buffer).map(|b| b.bytes())
    }
}

impl RecordBytes for Inputs<'_> {
    fn buffer(&self, buffer: Buffer) -> Result<&[u8]> {
        self.buffers.get(buffer).map(|b| b.bytes())
    }
}

impl MicromapLookup for Inputs<'_> {
    fn micromap_array(&self, array: MicromapArray) -> Result<Arc<MicromapArrayData>> {
        self.micromaps.get(array).cloned()
    }
}

/// The CPU device users hold: optik-core's checks in front of [`CpuBackend`], whose own
/// methods (thread count, native modules) it dereferences to.
pub type CpuDevice = optik_core::Device<CpuBackend>;

/// The CPU backend: robust traversal over obvhs-built BVHs, programs JIT-compiled from WGSL
/// (or native Rust closures), launches on a rayon thread pool.
pub struct CpuBackend {
    id: DeviceId,
    props: DeviceProperties,
    state: Mutex<State>,
    pool: Mutex<Arc<rayon::ThreadPool>>,
}

fn thread_pool(threads: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .stack_size(THREAD_STACK_BYTES)
        .thread_name(|i| format!("optik-cpu-{i}"))
        .build()
        .map_err(|e| Error::backend(format!("cannot start launch threads: {e}")))
}

/// The host processor's model name (`/proc/cpuinfo`), or the architecture where that is not
/// readable; the CPU device's `device_name` begins with it.
pub fn cpu_name() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|n| n.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string())
}

impl CpuBackend {
    /// A device launching on as many threads as the machine has cores.
    pub fn new() -> Result<CpuBackend> {
        Self::with_threads(0)
    }

    /// A device launching on `threads` threads (0: one per core). Results do not depend on
    /// the count.
    pub fn with_threads(threads: usize) -> Result<CpuBackend> {
        let id = DeviceId::next();
        let pool = thread_pool(threads)?;
        let props = DeviceProperties {
            max_trace_depth: 31,
            max_traversable_graph_depth: 16,
            max_primitives_per_build_input: 1 << 29,
            max_instances_per_ias: 1 << 24,
            max_instance_id: 1 << 24,
            max_sbt_offset: 1 << 24,
            num_bits_instance_visibility_mask: 8,
            max_sbt_records_per_build_input: 1 << 16,
            sbt_record_header_size: optik_api::sbt::SBT_RECORD_HEADER_SIZE,
            sbt_record_alignment: optik_api::sbt::SBT_RECORD_ALIGNMENT,
            max_sbt_record_stride: 4096,
            max_payload_values: 32,
            max_attribute_values: 8,
            max_launch_size: 1 << 32,
            max_buffer_size: 1 << 40,
            max_binding_size: 1 << 40,
            backend: BackendKind::Cpu,
            device_name: format!(
                "{} (optik-cpu, {})",
                cpu_name(),
                match pool.current_num_threads() {
                    1 => "1 thread".to_string(),
                    n => format!("{n} threads"),
                }
            ),
            driver: format!("optik-cpu {}", env!("CARGO_PKG_VERSION")),
        };
        Ok(CpuBackend {
            id,
            props,
            state: Mutex::new(State {
                scene: SceneTable::new(id),
                accuracy: Accuracy::default(),
            }),
            pool: Mutex::new(Arc::new(pool)),
        })
    }

    /// Launches from now on run on `threads` threads (0: one per core). The device's name
    /// (`DeviceProperties::device_name`) keeps the count it was created with: properties are
    /// fixed for a device's life, as on the other backends.
    pub fn set_threads(&self, threads: usize) -> Result<()> {
        let pool = thread_pool(threads)?;
        *self.pool.lock().unwrap_or_else(|e| e.into_inner()) = Arc::new(pool);
        Ok(())
    }

    /// The number of launch threads.
    pub fn threads(&self) -> usize {
        self.pool
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .current_num_threads()
    }

    /// The launch pool (shared: a launch or build keeps it while `set_threads` replaces it).
    /// Builds and refits run on it too, so a device set to one thread builds on one.
    fn launch_pool(&self) -> Arc<rayon::ThreadPool> {
        self.pool.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    fn state(&self) -> MutexGuard<'_, State> {
        // A panic inside a call never leaves the tables half-updated (objects are inserted
        // whole), so a poisoned lock is safe to keep using.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Makes `traversable` the structure `handle` (about to be inserted) stands for in the
    /// scene table.
    fn enter(
        &self,
        st: &mut State,
        handle: Accel,
        traversable: Traversable,
        origin: AccelOrigin,
        size: u64,
    ) -> Result<AccelObject> {
        let raw = handle.raw();
        if raw.slot >= handle::MAX_SLOTS {
            return Err(Error::limit(format!(
                "this device holds at most {} acceleration structures and transforms",
                handle::MAX_SLOTS
            )));
        }
        let traversable = Arc::new(traversable);
        st.scene.set(raw.slot, raw.generation, traversable.clone());
        Ok(AccelObject {
            traversable,
            origin,
            size,
        })
    }
}

/// What the CPU device offers beyond the API, on the objects optik-core keeps.
pub trait CpuDeviceExt {
    /// A module of Rust programs, usable in program groups like a compiled WGSL module.
    fn create_native_module(&self, desc: NativeModuleDesc) -> Result<Module>;
    /// The accuracy a pipeline was created with (the device's setting at its creation).
    fn pipeline_accuracy(&self, pipeline: Pipeline) -> Result<Accuracy>;
    /// The built traversable behind `accel`, for tools and tests (the layout `accel`
    /// documents).
    fn traversable(&self, accel: Accel) -> Result<Arc<Traversable>>;
}

impl CpuDeviceExt for CpuDevice {
    fn create_native_module(&self, desc: NativeModuleDesc) -> Result<Module> {
        let module = ModuleObject::native(desc)?;
        Ok(self.objects().modules.insert(module))
    }

    fn pipeline_accuracy(&self, pipeline: Pipeline) -> Result<Accuracy> {
        Ok(self.objects().pipelines.get(pipeline)?.accuracy)
    }

    fn traversable(&self, accel: Accel) -> Result<Arc<Traversable>> {
        Ok(self.objects().accels.get(accel)?.traversable.clone())
    }
}

/// A panic turned into an error (no panic crosses the API).
fn panic_message(p: Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

/// The union of the pipeline's modules' bindings; a binding declared differently by two
/// modules is an error.
fn pipeline_bindings(groups: &[(ProgramGroup, Arc<GroupObject>)]) -> Result<Vec<BindingInfo>> {
    let mut out: Vec<BindingInfo> = Vec::new();
    for (_, g) in groups {
        for (_, m) in &g.modules {
            for b in &m.bindings {
                match out.iter().find(|o| o.binding == b.binding) {
                    Some(o) if o.kind != b.kind => {
                        return Err(Error::invalid(format!(
                            "binding {} is `{}` ({:?}) in one module and `{}` ({:?}) in another; a pipeline's modules must agree on their bindings",
                            b.binding, o.name, o.kind, b.name, b.kind
                        )));
                    }
                    Some(_) => {}
                    None => out.push(b.clone()),
                }
            }
        }
    }
    Ok(out)
}

impl optik_core::Backend for CpuBackend {
    type Buffer = BufferData;
    type Texture = TextureData;
    type Accel = AccelObject;
    type MicromapArray = Arc<MicromapArrayData>;
    type Module = ModuleObject;
    type ProgramGroup = Arc<GroupObject>;
    type Pipeline = Arc<PipelineObject>;

    fn id(&self) -> DeviceId {
        self.id
    }

    fn kind(&self) -> BackendKind {
        BackendKind::Cpu
    }

    fn properties(&self) -> &DeviceProperties {
        &self.props
    }

    fn accuracy(&self) -> Accuracy {
        self.state().accuracy
    }

    fn set_accuracy(&self, _objects: &Objects<Self>, accuracy: Accuracy) -> Result<()> {
        if accuracy.triangle == optik_api::TriangleTest::Driver {
            return Err(Error::unsupported(
                "TriangleTest::Driver is the Vulkan driver's own triangle test; the cpu backend intersects triangles itself: choose TriangleTest::Watertight or TriangleTest::MollerTrumbore",
            ));
        }
        self.state().accuracy = accuracy;
        Ok(())
    }

    fn create_buffer(&self, size: u64) -> Result<BufferData> {
        BufferData::zeroed(size)
    }

    fn write_buffer(&self, buffer: &mut BufferData, offset: u64, data: &[u8]) -> Result<()> {
        buffer.bytes_mut()[offset as usize..offset as usize + data.len()].copy_from_slice(data);
        Ok(())
    }

    fn read_buffer(&self, buffer: &mut BufferData, offset: u64, out: &mut [u8]) -> Result<()> {
        out.copy_from_slice(&buffer.bytes()[offset as usize..offset as usize + out.len()]);
        Ok(())
    }

    fn buffer_size(&self, buffer: &BufferData) -> u64 {
        buffer.size as u64
    }

    fn destroy_buffer(&self, _buffer: BufferData) -> Result<()> {
        Ok(())
    }

    fn create_texture(&self, desc: &TextureDesc) -> Result<TextureData> {
        let bytes = desc.width as u64 * desc.height as u64 * desc.format.texel_size() as u64;
        Ok(TextureData {
            desc: *desc,
            texels: BufferData::zeroed(bytes)?,
        })
    }

    fn write_texture(&self, texture: &mut TextureData, data: &[u8]) -> Result<()> {
        texture.texels.bytes_mut().copy_from_slice(data);
        Ok(())
    }

    fn texture_desc(&self, texture: &TextureData) -> TextureDesc {
        texture.desc
    }

    fn destroy_texture(&self, _texture: TextureData) -> Result<()> {
        Ok(())
    }

    fn accel_memory_usage(
        &self,
        _objects: &mut Objects<Self>,
        _options: &AccelBuildOptions,
        inputs: &[BuildInput],
        keys: usize,
    ) -> Result<AccelBufferSizes> {
        Ok(accel::memory_usage(inputs, keys))
    }

    fn accel_build(
        &self,
        objects: &mut Objects<Self>,
        handle: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
        keys: usize,
    ) -> Result<AccelObject> {
        let mut st = self.state();
        let data = Inputs {
            buffers: &objects.buffers,
            micromaps: &objects.micromaps,
        };
        // obvhs builds in parallel on the current rayon pool: the device's launch pool, so a
        // device set to one thread builds on one (the tree is the same on any number).
        let pool = self.launch_pool();
        let traversable = pool.install(|| -> Result<Traversable> {
            Ok(match &inputs[0] {
                BuildInput::Instances(ia) => Traversable::Instances(Ias::build(
                    options,
                    ia,
                    &data,
                    &st.scene,
                    self.props.max_traversable_graph_depth,
                )?),
                _ => Traversable::Geometry(Gas::build(options, inputs, &data, &data)?),
            })
        })?;
        let size = accel::memory_usage(inputs, keys)
            .output_size_in_bytes
            .max(traversable.size_in_bytes());
        let origin = AccelOrigin::Build {
            options: *options,
            inputs: inputs.to_vec(),
        };
        self.enter(&mut st, handle, traversable, origin, size)
    }

    fn accel_update(
        &self,
        objects: &mut Objects<Self>,
        accel: Accel,
        _options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<()> {
        // Refits keep the build's options (optik-core checked that the update's agree).
        let mut st = self.state();
        let object = objects.accels.get(accel)?;
        let AccelOrigin::Build {
            options: built_with,
            ..
        } = &object.origin
        else {
            return Err(Error::backend("accel_update was given a transform"));
        };
        let built_with = *built_with;
        let mut traversable = (*object.traversable).clone();
        let data = Inputs {
            buffers: &objects.buffers,
            micromaps: &objects.micromaps,
        };
        match (&mut traversable, &inputs[0]) {
            (Traversable::Instances(ias), BuildInput::Instances(ia)) => {
                ias.refit(ia, &data, &st.scene, self.props.max_traversable_graph_depth)?
            }
            // A refit decodes and permutes on the current rayon pool, as a build does:
            // the device's launch pool.
            (Traversable::Geometry(gas), _) => {
                let pool = self.launch_pool();
                pool.install(|| gas.refit(&built_with, inputs, &data, &data))?
            }
            _ => {
                return Err(Error::invalid(
                    "accel_update: the inputs' kind differs from the build's",
                ));
            }
        }
        let traversable = Arc::new(traversable);
        let object = objects.accels.get_mut(accel)?;
        object.traversable = traversable.clone();
        object.origin = AccelOrigin::Build {
            options: built_with,
            inputs: inputs.to_vec(),
        };
        let raw = accel.raw();
        st.scene.set(raw.slot, raw.generation, traversable);
        Ok(())
    }

    fn accel_compact(
        &self,
        objects: &mut Objects<Self>,
        accel: Accel,
        handle: Accel,
    ) -> Result<AccelObject> {
        let object = objects.accels.get(accel)?;
        let AccelOrigin::Build { options, inputs } = &object.origin else {
            return Err(Error::backend("accel_compact was given a transform"));
        };
        let compacted = object.traversable.compacted();
        let size = compacted.size_in_bytes();
        let origin = AccelOrigin::Build {
            options: *options,
            inputs: inputs.clone(),
        };
        self.enter(&mut self.state(), handle, compacted, origin, size)
    }

    fn accel_build_record(
        &self,
        accel: &AccelObject,
    ) -> Option<(AccelBuildOptions, Vec<BuildInput>)> {
        match &accel.origin {
            AccelOrigin::Build { options, inputs } => Some((*options, inputs.clone())),
            AccelOrigin::Transform => None,
        }
    }

    fn accel_size(&self, accel: &AccelObject) -> u64 {
        accel.size
    }

    fn accel_features(&self, accel: &AccelObject) -> SceneFeatures {
        accel.traversable.features()
    }

    fn create_transform(
        &self,
        _objects: &mut Objects<Self>,
        handle: Accel,
        desc: &TransformDesc,
    ) -> Result<AccelObject> {
        let mut st = self.state();
        let t = Transform::new(desc, &st.scene, self.props.max_traversable_graph_depth)?;
        let size = t.size_in_bytes();
        self.enter(
            &mut st,
            handle,
            Traversable::Transform(t),
            AccelOrigin::Transform,
            size,
        )
    }

    fn create_opacity_micromap_array(
        &self,
        desc: &OpacityMicromapArrayDesc,
    ) -> Result<Arc<MicromapArrayData>> {
        Ok(Arc::new(MicromapArrayData::new(desc)))
    }

    fn traversable_handle(&self, accel: Accel, _object: &AccelObject) -> Result<TraversableHandle> {
        let raw = accel.raw();
        Ok(handle::encode(self.id, raw.slot, raw.generation))
    }

    fn destroy_accel(
        &self,
        _objects: &mut Objects<Self>,
        accel: Accel,
        _object: AccelObject,
    ) -> Result<()> {
        self.state().scene.remove(accel.raw().slot);
        Ok(())
    }

    fn destroy_micromap_array(&self, _array: Arc<MicromapArrayData>) -> Result<()> {
        Ok(())
    }

    fn create_module(
        &self,
        module_options: &ModuleCompileOptions,
        pipeline_options: &PipelineCompileOptions,
        source: &ProgramSource,
    ) -> Result<(ModuleObject, String)> {
        let payload_len = pipeline_options.num_payload_values.or(32);
        let compiled = Arc::new(optik_core::frontend::compile(source, payload_len)?);
        crate::jit_glue::compile(compiled, module_options)
    }

    fn module_programs(&self, module: &ModuleObject) -> Vec<String> {
        module.programs.keys().cloned().collect()
    }

    fn destroy_module(&self, _module: ModuleObject) -> Result<()> {
        Ok(())
    }

    fn create_program_groups(
        &self,
        objects: &Objects<Self>,
        descs: &[ProgramGroupDesc],
    ) -> Result<Vec<Arc<GroupObject>>> {
        let modules = &objects.modules;
        let module = |m: Module| modules.get(m).map(|o| (o.compiled.clone(), o.native));
        let program =
            |p: &optik_api::ProgramRef| Ok(modules.get(p.module)?.programs.get(&p.entry).cloned());
        descs
            .iter()
            .enumerate()
            .map(|(i, desc)| GroupObject::new(i, desc, &module, &program).map(Arc::new))
            .collect()
    }

    fn group_region(&self, group: &Arc<GroupObject>) -> GroupRegion {
        group.desc.region()
    }

    fn destroy_program_group(&self, _group: Arc<GroupObject>) -> Result<()> {
        Ok(())
    }

    fn create_pipeline(
        &self,
        objects: &Objects<Self>,
        _pipeline_options: &PipelineCompileOptions,
        link_options: &PipelineLinkOptions,
        groups: &[ProgramGroup],
        features: &FeatureSet,
    ) -> Result<Arc<PipelineObject>> {
        for (what, depth) in [
            (
                "max_direct_callable_depth",
                link_options.max_direct_callable_depth,
            ),
            (
                "max_continuation_callable_depth",
                link_options.max_continuation_callable_depth,
            ),
        ] {
            if depth > MAX_CALLABLE_DEPTH {
                return Err(Error::limit(format!(
                    "link_options.{what} is {depth}; this device allows at most {MAX_CALLABLE_DEPTH}"
                )));
            }
        }
        let group_objects: Vec<(ProgramGroup, Arc<GroupObject>)> = groups
            .iter()
            .copied()
            .zip(objects.groups_of(groups)?.into_iter().cloned())
            .collect();
        let features = *features;
        let bindings = pipeline_bindings(&group_objects)?;
        let accuracy = self.state().accuracy;
        Ok(Arc::new(PipelineObject {
            trace: pipeline::select_trace(&features, accuracy),
            groups: pipeline::with_payload_registers(group_objects, features.num_payload_values),
            features,
            link: *link_options,
            accuracy,
            bindings,
        }))
    }

    fn program_features(
        &self,
        objects: &Objects<Self>,
        groups: &[ProgramGroup],
    ) -> Result<optik_api::ProgramFeatures> {
        let objects: Vec<Arc<GroupObject>> =
            objects.groups_of(groups)?.into_iter().cloned().collect();
        Ok(pipeline::program_features(&objects))
    }

    fn pipeline_features(&self, pipeline: &Arc<PipelineObject>) -> FeatureSet {
        pipeline.features
    }

    fn pipeline_bindings(&self, pipeline: &Arc<PipelineObject>) -> Vec<BindingInfo> {
        pipeline.bindings.clone()
    }

    fn destroy_pipeline(&self, _pipeline: Arc<PipelineObject>) -> Result<()> {
        Ok(())
    }

    fn launch(
        &self,
        objects: &mut Objects<Self>,
        pipeline: Pipeline,
        params: &[u8],
        resources: &[Resource],
        sbt: &ShaderBindingTable,
        size: LaunchSize,
        options: &LaunchOptions,
    ) -> Result<()> {
        let pool = self.launch_pool();
        let st = self.state();
        let pipeline = objects.pipelines.get(pipeline)?.clone();
        if size.is_empty() {
            return Ok(());
        }
        let watch = LaunchWatch::new(options)?;
        // Binding 0: the params bytes, copied into aligned memory that lives for the launch.
        let mut params_copy = BufferData::zeroed(params.len() as u64)?;
        params_copy.bytes_mut().copy_from_slice(params);
        let slots = resources
            .iter()
            .map(|r| r.binding() as usize + 1)
            .max()
            .unwrap_or(1);
        let mut bound = vec![BoundResource::None; slots];
        bound[0] = BoundResource::Buffer(BoundBuffer {
            ptr: params_copy.chunks.as_mut_ptr() as *mut u8,
            len: params.len(),
        });
        let Objects {
            buffers,
            textures,
            micromaps,
            ..
        } = objects;
        for r in resources {
            bound[r.binding() as usize] = match r {
                Resource::Buffer {
                    buffer,
                    offset,
                    size,
                    ..
                } => {
                    let b = buffers.get_mut(*buffer)?;
                    let len = size.unwrap_or(b.size as u64 - offset) as usize;
                    // SAFETY: the range was checked by optik-core; the buffer outlives the
                    // launch (the object lock is held) and no reference to its bytes exists
                    // while programs use the pointer.
                    let ptr = unsafe { (b.chunks.as_mut_ptr() as *mut u8).add(*offset as usize) };
                    BoundResource::Buffer(BoundBuffer { ptr, len })
                }
                Resource::Texture { texture, .. } => {
                    let t = textures.get(*texture)?;
                    BoundResource::Texture(BoundTexture {
                        ptr: t.texels.chunks.as_ptr() as *const u8,
                        width: t.desc.width,
                        height: t.desc.height,
                        format: t.desc.format,
                    })
                }
                Resource::Sampler { sampler, .. } => BoundResource::Sampler(*sampler),
            };
        }
        let bindings = Bindings { resources: &bound };
        let prepared = PreparedModules::new(&pipeline, &bindings);
        let resolved = {
            let data = Inputs { buffers, micromaps };
            sbt::resolve(
                sbt,
                self.id,
                &pipeline,
                &prepared,
                &data,
                self.props.max_sbt_record_stride,
            )?
        };
        let features = pipeline.features;
        let shared = LaunchShared {
            sbt: resolved,
            scene: &st.scene,
            bindings: &bindings,
            size: [size.width, size.height, size.depth],
            config: TraceConfig {
                primitive_types: features.primitive_types,
                intersection: features.intersection,
                micromaps: features.opacity_micromaps,
                debug_exceptions: features.exceptions.contains(ExceptionFlags::DEBUG),
                max_graph_depth: self.props.max_traversable_graph_depth,
            },
            features,
            link: pipeline.link,
            trace: pipeline.trace,
            stop: watch.flag(),
        };
        let outcome =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| launch::run(&shared, &pool)));
        drop(shared);
        drop(params_copy);
        outcome.map_err(|p| {
            Error::backend(format!(
                "a program panicked during the launch: {}",
                panic_message(p)
            ))
        })?;
        watch.finish()
    }

    fn synchronize(&self) -> Result<()> {
        Ok(())
    }
}

#[cfg(all(test, feature = "jit"))]
mod tests {
    use super::*;
    use crate::pipeline::ProgramCode;
    use optik_api::{Device, ProgramRef, Setting};

    /// Registers 0..=4 are used (`p[4]` in the raygen).
    const SOURCE: &str = r#"
fn raygen__main() {
    var p: RtPayload;
    p[4] = 1u;
    rt_trace(vec2<u32>(0u, 0u), vec3<f32>(0.0), vec3<f32>(0.0, 0.0, 1.0), 0.0, 1.0, 0.0,
             0xFFu, 0u, 0u, 1u, 0u, &p);
}
fn miss__main() {
    rt_set_payload(2u, 1u);
}
"#;

    /// The `RtPayload` length each program of `pipeline` was compiled with.
    fn compiled_registers(dev: &CpuDevice, pipeline: Pipeline) -> Vec<u32> {
        let objects = dev.objects();
        let p = objects.pipelines.get(pipeline).unwrap();
        p.groups
            .iter()
            .filter_map(|(_, g)| match &g.programs.main {
                Some(ProgramCode::Jit { source, .. }) => Some(source.payload_len),
                _ => None,
            })
            .collect()
    }

    fn pipeline(dev: &CpuDevice, module: Setting<u32>, pipeline: Setting<u32>) -> Pipeline {
        let options = |n| PipelineCompileOptions {
            num_payload_values: n,
            ..Default::default()
        };
        let (m, _) = dev
            .create_module(
                &ModuleCompileOptions::default(),
                &options(module),
                &ProgramSource::new("payload.wgsl", SOURCE),
            )
            .unwrap();
        let groups = dev
            .create_program_groups(&[
                ProgramGroupDesc::Raygen(ProgramRef::new(m, "raygen__main")),
                ProgramGroupDesc::Miss(Some(ProgramRef::new(m, "miss__main"))),
            ])
            .unwrap();
        dev.create_pipeline(&options(pipeline), &PipelineLinkOptions::default(), &groups)
            .unwrap()
    }

    #[test]
    fn pipelines_compile_modules_for_their_payload_registers() {
        let dev = CpuBackend::with_threads(1).map(CpuDevice::new).unwrap();
        // Auto: the module has 32 registers, the pipeline resolves the 5 the programs use.
        let p = pipeline(&dev, Setting::Auto, Setting::Auto);
        assert_eq!(compiled_registers(&dev, p), [5, 5]);
        // A pipeline asking for more than the programs use gets what it asks for.
        let p = pipeline(&dev, Setting::Value(8), Setting::Value(12));
        assert_eq!(compiled_registers(&dev, p), [12, 12]);
        // Matching counts keep the module's code.
        let p = pipeline(&dev, Setting::Value(6), Setting::Value(6));
        assert_eq!(compiled_registers(&dev, p), [6, 6]);
        let objects = dev.objects();
        let groups = &objects.pipelines.get(p).unwrap().groups;
        let modules: Vec<&crate::program::JitModule> = groups
            .iter()
            .filter_map(|(_, g)| match &g.programs.main {
                Some(ProgramCode::Jit { module, .. }) => Some(module),
                _ => None,
            })
            .collect();
        assert!(crate::program::JitModule::same_code(modules[0], modules[1]));
    }
}

#[cfg(test)]
mod name_tests {
    use super::*;
    use optik_core::Backend;

    #[test]
    fn the_device_name_counts_its_launch_threads() {
        let name = |threads| {
            CpuBackend::with_threads(threads)
                .expect("a CPU device")
                .properties()
                .device_name
                .clone()
        };
        assert!(name(1).ends_with("(optik-cpu, 1 thread)"), "{}", name(1));
        assert!(name(3).ends_with("(optik-cpu, 3 threads)"), "{}", name(3));
    }
}
