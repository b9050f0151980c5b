//! [`CpuBackend`]: the CPU backend's `optik_core::Backend` ([`CpuDevice`] is the device
//! users hold: optik-core's checks in front of it).
//!
//! All objects live in one table set behind a mutex. Launches run synchronously inside
//! `launch` (OptiX allows a launch to finish before it returns), so `synchronize` has
//! nothing to wait for and a launch's buffers cannot change under it; other calls on the
//! device wait while a launch runs.

use crate::accel::{
    self, Gas, Ias, MicromapArrayData, MicromapLookup, SceneTable, Transform, Traversable, handle,
};
use crate::launch::{self, LaunchShared};
use crate::pipeline::{
    self, GroupObject, ModuleObject, NativeModuleDesc, PipelineObject, PreparedModules,
};
use crate::program::abi::{Bindings, BoundBuffer, BoundResource, BoundTexture};
use crate::sbt::{self, RecordBytes};
use crate::traversal::TraceConfig;
use optik_accel::decode::BufferBytes;
use optik_api::{
    Accel, AccelBufferSizes, AccelBuildOptions, Accuracy, BackendKind, Buffer, BuildInput,
    DeviceId, DeviceProperties, Error, ErrorKind, ExceptionFlags, FeatureSet, GroupRegion, Handle,
    LaunchOptions, LaunchSize, LaunchWatch, MicromapArray, Module, ModuleCompileOptions,
    OpacityMicromapArrayDesc, Pipeline, PipelineCompileOptions, PipelineLinkOptions, ProgramGroup,
    ProgramGroupDesc, ProgramSource, Resource, Result, SceneFeatures, ShaderBindingTable, Texture,
    TextureDesc, TransformDesc, TraversableHandle,
};
use optik_core::HandleTable;
use optik_core::frontend::BindingInfo;
use std::sync::{Arc, Mutex, MutexGuard};

/// Deepest nesting of callables a pipeline may link with (each level is a native stack
/// frame of the launch thread).
pub const MAX_CALLABLE_DEPTH: u32 = 64;
/// Stack size of launch threads: traces nest up to 31 deep, each with programs and
/// callables on the stack.
const THREAD_STACK_BYTES: usize = 64 << 20;

/// 16-byte aligned bytes: what programs read `vec4<f32>`s and the like out of.
#[repr(C, align(16))]
#[derive(Clone, Copy)]
struct Chunk([u8; 16]);

/// A buffer's memory.
struct BufferData {
    chunks: Vec<Chunk>,
    size: usize,
}

impl BufferData {
    fn zeroed(size: u64) -> Result<BufferData> {
        let size = usize::try_from(size).map_err(|_| {
            Error::new(
                ErrorKind::OutOfMemory,
                "buffer size exceeds the address space",
            )
        })?;
        let mut chunks = Vec::new();
        chunks.try_reserve_exact(size.div_ceil(16)).map_err(|_| {
            Error::new(
                ErrorKind::OutOfMemory,
                format!("cannot allocate a buffer of {size} bytes"),
            )
        })?;
        chunks.resize(size.div_ceil(16), Chunk([0; 16]));
        Ok(BufferData { chunks, size })
    }

    fn bytes(&self) -> &[u8] {
        &bytemuck_chunks(&self.chunks)[..self.size]
    }

    fn bytes_mut(&mut self) -> &mut [u8] {
        let size = self.size;
        &mut bytemuck_chunks_mut(&mut self.chunks)[..size]
    }
}

fn bytemuck_chunks(c: &[Chunk]) -> &[u8] {
    // SAFETY: `Chunk` is 16 plain bytes without padding.
    unsafe { std::slice::from_raw_parts(c.as_ptr() as *const u8, c.len() * 16) }
}

fn bytemuck_chunks_mut(c: &mut [Chunk]) -> &mut [u8] {
    // SAFETY: as above; the borrow is unique.
    unsafe { std::slice::from_raw_parts_mut(c.as_mut_ptr() as *mut u8, c.len() * 16) }
}

/// A texture's texels.
struct TextureData {
    desc: TextureDesc,
    texels: BufferData,
}

/// What an acceleration structure object was made from.
enum AccelOrigin {
    /// Built from inputs (kept for updates).
    Build {
        options: AccelBuildOptions,
        inputs: Vec<BuildInput>,
    },
    /// A transform.
    Transform,
}

struct AccelObject {
    traversable: Arc<Traversable>,
    origin: AccelOrigin,
    size: u64,
}

struct State {
    buffers: HandleTable<Buffer, BufferData>,
    textures: HandleTable<Texture, TextureData>,
    accels: HandleTable<Accel, AccelObject>,
    scene: SceneTable,
    micromaps: HandleTable<MicromapArray, Arc<MicromapArrayData>>,
    modules: HandleTable<Module, ModuleObject>,
    groups: HandleTable<ProgramGroup, Arc<GroupObject>>,
    pipelines: HandleTable<Pipeline, Arc<PipelineObject>>,
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
            backend: BackendKind::Cpu,
            device_name: format!(
                "{} (optik-cpu, {} threads)",
                cpu_name(),
                pool.current_num_threads()
            ),
        };
        Ok(CpuBackend {
            id,
            props,
            state: Mutex::new(State {
                buffers: HandleTable::new(id),
                textures: HandleTable::new(id),
                accels: HandleTable::new(id),
                scene: SceneTable::new(id),
                micromaps: HandleTable::new(id),
                modules: HandleTable::new(id),
                groups: HandleTable::new(id),
                pipelines: HandleTable::new(id),
                accuracy: Accuracy::default(),
            }),
            pool: Mutex::new(Arc::new(pool)),
        })
    }

    /// Launches from now on run on `threads` threads (0: one per core).
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

    /// A module of Rust programs, usable in program groups like a compiled WGSL module.
    pub fn create_native_module(&self, desc: NativeModuleDesc) -> Result<Module> {
        let module = ModuleObject::native(desc)?;
        Ok(self.state().modules.insert(module))
    }

    /// The accuracy a pipeline was created with (the device's setting at its creation).
    pub fn pipeline_accuracy(&self, pipeline: Pipeline) -> Result<Accuracy> {
        Ok(self.state().pipelines.get(pipeline)?.accuracy)
    }

    /// The built traversable behind `accel`, for tools and tests (the layout `accel`
    /// documents).
    pub fn traversable(&self, accel: Accel) -> Result<Arc<Traversable>> {
        Ok(self.state().accels.get(accel)?.traversable.clone())
    }

    fn state(&self) -> MutexGuard<'_, State> {
        // A panic inside a call never leaves the tables half-updated (objects are inserted
        // whole), so a poisoned lock is safe to keep using.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn insert_accel(
        &self,
        st: &mut State,
        traversable: Traversable,
        origin: AccelOrigin,
        size: u64,
    ) -> Result<Accel> {
        let traversable = Arc::new(traversable);
        let accel = st.accels.insert(AccelObject {
            traversable: traversable.clone(),
            origin,
            size,
        });
        let raw = accel.raw();
        if raw.slot >= handle::MAX_SLOTS {
            st.accels.remove(accel)?;
            return Err(Error::limit(format!(
                "this device holds at most {} acceleration structures and transforms",
                handle::MAX_SLOTS
            )));
        }
        st.scene.set(raw.slot, raw.generation, traversable);
        Ok(accel)
    }

    fn live_scene_features(st: &State) -> Option<SceneFeatures> {
        st.accels
            .iter()
            .map(|(_, a)| a.traversable.features())
            .reduce(SceneFeatures::union)
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

    fn set_accuracy(&self, accuracy: Accuracy) -> Result<()> {
        if accuracy.triangle == optik_api::TriangleTest::Driver {
            return Err(Error::unsupported(
                "TriangleTest::Driver is the Vulkan driver's own triangle test; the cpu backend intersects triangles itself: choose TriangleTest::Watertight or TriangleTest::MollerTrumbore",
            ));
        }
        self.state().accuracy = accuracy;
        Ok(())
    }

    fn create_buffer(&self, size: u64) -> Result<Buffer> {
        let data = BufferData::zeroed(size)?;
        Ok(self.state().buffers.insert(data))
    }

    fn write_buffer(&self, buffer: Buffer, offset: u64, data: &[u8]) -> Result<()> {
        let mut st = self.state();
        let b = st.buffers.get_mut(buffer)?;
        b.bytes_mut()[offset as usize..offset as usize + data.len()].copy_from_slice(data);
        Ok(())
    }

    fn read_buffer(&self, buffer: Buffer, offset: u64, out: &mut [u8]) -> Result<()> {
        let st = self.state();
        let b = st.buffers.get(buffer)?;
        out.copy_from_slice(&b.bytes()[offset as usize..offset as usize + out.len()]);
        Ok(())
    }

    fn buffer_size(&self, buffer: Buffer) -> Result<u64> {
        Ok(self.state().buffers.get(buffer)?.size as u64)
    }

    fn destroy_buffer(&self, buffer: Buffer) -> Result<()> {
        self.state().buffers.remove(buffer).map(drop)
    }

    fn create_texture(&self, desc: &TextureDesc) -> Result<Texture> {
        let bytes = desc.width as u64 * desc.height as u64 * desc.format.texel_size() as u64;
        let texels = BufferData::zeroed(bytes)?;
        Ok(self.state().textures.insert(TextureData {
            desc: *desc,
            texels,
        }))
    }

    fn write_texture(&self, texture: Texture, data: &[u8]) -> Result<()> {
        let mut st = self.state();
        let t = st.textures.get_mut(texture)?;
        t.texels.bytes_mut().copy_from_slice(data);
        Ok(())
    }

    fn texture_desc(&self, texture: Texture) -> Result<TextureDesc> {
        Ok(self.state().textures.get(texture)?.desc)
    }

    fn destroy_texture(&self, texture: Texture) -> Result<()> {
        self.state().textures.remove(texture).map(drop)
    }

    fn accel_memory_usage(
        &self,
        _options: &AccelBuildOptions,
        inputs: &[BuildInput],
        keys: usize,
    ) -> Result<AccelBufferSizes> {
        Ok(accel::memory_usage(inputs, keys))
    }

    fn accel_build(
        &self,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
        keys: usize,
    ) -> Result<Accel> {
        let mut guard = self.state();
        let st = &mut *guard;
        let data = Inputs {
            buffers: &st.buffers,
            micromaps: &st.micromaps,
        };
        let traversable = match &inputs[0] {
            BuildInput::Instances(ia) => Traversable::Instances(Ias::build(
                options,
                ia,
                &data,
                &st.scene,
                self.props.max_traversable_graph_depth,
            )?),
            _ => Traversable::Geometry(Gas::build(options, inputs, &data, &data)?),
        };
        let size = accel::memory_usage(inputs, keys)
            .output_size_in_bytes
            .max(traversable.size_in_bytes());
        let origin = AccelOrigin::Build {
            options: *options,
            inputs: inputs.to_vec(),
        };
        self.insert_accel(st, traversable, origin, size)
    }

    fn accel_update(
        &self,
        accel: Accel,
        _options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<()> {
        // Refits keep the build's options (optik-core checked that the update's agree).
        let mut guard = self.state();
        let st = &mut *guard;
        let object = st.accels.get(accel)?;
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
            buffers: &st.buffers,
            micromaps: &st.micromaps,
        };
        match (&mut traversable, &inputs[0]) {
            (Traversable::Instances(ias), BuildInput::Instances(ia)) => {
                ias.refit(ia, &data, &st.scene, self.props.max_traversable_graph_depth)?
            }
            (Traversable::Geometry(gas), _) => gas.refit(&built_with, inputs, &data, &data)?,
            _ => {
                return Err(Error::invalid(
                    "accel_update: the inputs' kind differs from the build's",
                ));
            }
        }
        let traversable = Arc::new(traversable);
        let object = st.accels.get_mut(accel)?;
        object.traversable = traversable.clone();
        object.origin = AccelOrigin::Build {
            options: built_with,
            inputs: inputs.to_vec(),
        };
        let raw = accel.raw();
        st.scene.set(raw.slot, raw.generation, traversable);
        Ok(())
    }

    fn accel_compact(&self, accel: Accel) -> Result<Accel> {
        let mut guard = self.state();
        let st = &mut *guard;
        let object = st.accels.get(accel)?;
        let AccelOrigin::Build { options, inputs } = &object.origin else {
            return Err(Error::backend("accel_compact was given a transform"));
        };
        let compacted = object.traversable.compacted();
        let size = compacted.size_in_bytes();
        let origin = AccelOrigin::Build {
            options: *options,
            inputs: inputs.clone(),
        };
        self.insert_accel(st, compacted, origin, size)
    }

    fn accel_build_record(
        &self,
        accel: Accel,
    ) -> Result<Option<(AccelBuildOptions, Vec<BuildInput>)>> {
        Ok(match &self.state().accels.get(accel)?.origin {
            AccelOrigin::Build { options, inputs } => Some((*options, inputs.clone())),
            AccelOrigin::Transform => None,
        })
    }

    fn accel_size(&self, accel: Accel) -> Result<u64> {
        Ok(self.state().accels.get(accel)?.size)
    }

    fn create_transform(&self, desc: &TransformDesc) -> Result<Accel> {
        let mut guard = self.state();
        let st = &mut *guard;
        let t = Transform::new(desc, &st.scene, self.props.max_traversable_graph_depth)?;
        let size = t.size_in_bytes();
        self.insert_accel(st, Traversable::Transform(t), AccelOrigin::Transform, size)
    }

    fn create_opacity_micromap_array(
        &self,
        desc: &OpacityMicromapArrayDesc,
    ) -> Result<MicromapArray> {
        Ok(self
            .state()
            .micromaps
            .insert(Arc::new(MicromapArrayData::new(desc))))
    }

    fn traversable_handle(&self, accel: Accel) -> Result<TraversableHandle> {
        self.state().accels.get(accel)?;
        let raw = accel.raw();
        Ok(handle::encode(self.id, raw.slot, raw.generation))
    }

    fn destroy_accel(&self, accel: Accel) -> Result<()> {
        let mut st = self.state();
        st.accels.remove(accel)?;
        st.scene.remove(accel.raw().slot);
        Ok(())
    }

    fn destroy_micromap_array(&self, array: MicromapArray) -> Result<()> {
        self.state().micromaps.remove(array).map(drop)
    }

    fn create_module(
        &self,
        module_options: &ModuleCompileOptions,
        pipeline_options: &PipelineCompileOptions,
        source: &ProgramSource,
    ) -> Result<(Module, String)> {
        let payload_len = pipeline_options.num_payload_values.or(32);
        let compiled = Arc::new(optik_core::frontend::compile(source, payload_len)?);
        let (module, log) = crate::jit_glue::compile(compiled, module_options)?;
        Ok((self.state().modules.insert(module), log))
    }

    fn module_programs(&self, module: Module) -> Result<Vec<String>> {
        Ok(self
            .state()
            .modules
            .get(module)?
            .programs
            .keys()
            .cloned()
            .collect())
    }

    fn destroy_module(&self, module: Module) -> Result<()> {
        self.state().modules.remove(module).map(drop)
    }

    fn create_program_groups(&self, descs: &[ProgramGroupDesc]) -> Result<Vec<ProgramGroup>> {
        let mut st = self.state();
        let mut objects = Vec::with_capacity(descs.len());
        for (i, desc) in descs.iter().enumerate() {
            let modules = &st.modules;
            let module = |m: Module| modules.get(m).map(|o| (o.compiled.clone(), o.native));
            let program = |p: &optik_api::ProgramRef| {
                Ok(modules.get(p.module)?.programs.get(&p.entry).cloned())
            };
            objects.push(Arc::new(GroupObject::new(i, desc, &module, &program)?));
        }
        Ok(objects.into_iter().map(|g| st.groups.insert(g)).collect())
    }

    fn group_region(&self, group: ProgramGroup) -> Result<GroupRegion> {
        Ok(self.state().groups.get(group)?.desc.region())
    }

    fn destroy_program_group(&self, group: ProgramGroup) -> Result<()> {
        self.state().groups.remove(group).map(drop)
    }

    fn create_pipeline(
        &self,
        _pipeline_options: &PipelineCompileOptions,
        link_options: &PipelineLinkOptions,
        groups: &[ProgramGroup],
        features: &FeatureSet,
    ) -> Result<Pipeline> {
        let mut st = self.state();
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
        let group_objects = groups
            .iter()
            .enumerate()
            .map(|(i, g)| {
                st.groups
                    .get(*g)
                    .map(|o| (*g, o.clone()))
                    .map_err(|e| e.context(format!("groups[{i}]")))
            })
            .collect::<Result<Vec<_>>>()?;
        let features = *features;
        let bindings = pipeline_bindings(&group_objects)?;
        let accuracy = st.accuracy;
        let object = PipelineObject {
            trace: pipeline::select_trace(&features, accuracy),
            groups: pipeline::with_payload_registers(group_objects, features.num_payload_values),
            features,
            link: *link_options,
            accuracy,
            bindings,
        };
        Ok(st.pipelines.insert(Arc::new(object)))
    }

    fn program_features(&self, groups: &[ProgramGroup]) -> Result<optik_api::ProgramFeatures> {
        let st = self.state();
        let objects = groups
            .iter()
            .enumerate()
            .map(|(i, g)| {
                st.groups
                    .get(*g)
                    .cloned()
                    .map_err(|e| e.context(format!("groups[{i}]")))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(pipeline::program_features(&objects))
    }

    fn scene_features(&self) -> Result<Option<SceneFeatures>> {
        Ok(Self::live_scene_features(&self.state()))
    }

    fn pipeline_features(&self, pipeline: Pipeline) -> Result<FeatureSet> {
        Ok(self.state().pipelines.get(pipeline)?.features)
    }

    fn pipeline_bindings(&self, pipeline: Pipeline) -> Result<Vec<BindingInfo>> {
        Ok(self.state().pipelines.get(pipeline)?.bindings.clone())
    }

    fn destroy_pipeline(&self, pipeline: Pipeline) -> Result<()> {
        self.state().pipelines.remove(pipeline).map(drop)
    }

    fn launch(
        &self,
        pipeline: Pipeline,
        params: &[u8],
        resources: &[Resource],
        sbt: &ShaderBindingTable,
        size: LaunchSize,
        options: &LaunchOptions,
    ) -> Result<()> {
        let pool = self.pool.lock().unwrap_or_else(|e| e.into_inner()).clone();
        let mut guard = self.state();
        let st = &mut *guard;
        let pipeline = st.pipelines.get(pipeline)?.clone();
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
        let State {
            buffers,
            textures,
            scene,
            micromaps,
            ..
        } = st;
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
                    // SAFETY: the range was checked above; the buffer outlives the launch
                    // (the state lock is held) and no reference to its bytes exists while
                    // programs use the pointer.
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
            scene,
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
        let st = dev.state();
        let p = st.pipelines.get(pipeline).unwrap();
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
        let st = dev.state();
        let groups = &st.pipelines.get(p).unwrap().groups;
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
