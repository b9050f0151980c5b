//! [`WgpuBackend`]: the wgpu backend's `optik_core::Backend` ([`WgpuDevice`] is the device
//! users hold: optik-core's checks in front of it), and [`WgpuDeviceExt`], the wgpu calls
//! beyond the API that read the device's objects.
//!
//! optik-core's `Device` owns the objects: buffers, textures, acceleration structures and
//! transforms, micromap arrays, modules, program groups and pipelines live in its
//! `Objects` tables as this backend's types (`BufferObject`, `AccelObject`, ...) and are
//! lent to each call under core's lock. The backend's own lock holds only what belongs to
//! no single object: the accuracy setting, the [`Scene`] (the arena holding every
//! structure's words and the GPU handle table that traversal resolves handles with, which
//! every build, kernel variant and launch shares) and the sampler cache. Core holds its
//! lock across each backend call and the backend never calls back into core, so this lock
//! is always taken second and the two cannot deadlock.
//!
//! Handles and the adapter's own limits are checked before anything is changed, so a
//! failed creation, update or launch leaves the device as it was: a structure enters the
//! scene (under the handle core will give it) only once nothing can fail any more. On a lost
//! device every call fails with `ErrorKind::DeviceLost` before core looks at its arguments
//! (`Backend::alive`), so objects stay in core's tables until the device is dropped.
//! Dropping the device drops every object (core hands them back) before the scene they
//! were stored in.

use crate::accel::geometry;
use crate::accel::instances::{self, ChildInfo};
use crate::accel::{self, Refit, Scene};
use crate::gpu::Gpu;
use crate::kernel::Sizes;
use crate::objects::{
    AccelObject, BufferObject, GroupObject, MicromapArrayData, ModuleObject, PipelineObject,
    TextureObject,
};
use crate::pipeline;
use crate::program::ModuleSource;
use optik_accel::MicromapLookup;
use optik_accel::decode::BufferBytes;
use optik_api::{
    Accel, AccelBufferSizes, AccelBuildOptions, Accuracy, BackendKind, Buffer, BufferView,
    BuildInput, BuildOperation, DeviceId, DeviceProperties, Error, FeatureSet, GroupRegion, Handle,
    LaunchSize, MicromapArray, ModuleCompileOptions, OpacityMicromapArrayDesc, Pipeline,
    PipelineCompileOptions, PipelineLinkOptions, ProgramGroup, ProgramGroupDesc, ProgramRef,
    ProgramSource, Resource, Result, SceneFeatures, ShaderBindingTable, TextureDesc, TransformDesc,
    TraversableHandle,
};
use optik_core::frontend::BindingInfo;
use optik_core::{HandleTable, Objects};
use std::sync::{Arc, Mutex, MutexGuard};

/// The wgpu device users hold: optik-core's checks in front of [`WgpuBackend`], whose own
/// methods (memory tracker, limits) it dereferences to; calls that read its objects come
/// with [`WgpuDeviceExt`].
pub type WgpuDevice = optik_core::Device<WgpuBackend>;

/// The objects of a wgpu device, as optik-core keeps them.
pub(crate) type WgpuObjects = Objects<WgpuBackend>;

/// The wgpu backend: optik pipelines run as compute megakernels.
pub struct WgpuBackend {
    id: DeviceId,
    properties: DeviceProperties,
    state: Mutex<State>,
    /// Last, so that it drops after the state's wgpu objects (samplers): the wgpu device
    /// then goes with it, under `Gpu`'s drop (`optik_core::vulkan_loader`).
    gpu: Arc<Gpu>,
}

/// What the backend keeps beside the objects: state that many objects share.
pub(crate) struct State {
    pub accuracy: Accuracy,
    pub scene: Scene,
    pub samplers: Vec<(optik_api::SamplerDesc, wgpu::Sampler)>,
}

/// The environment variable naming a folder for the kernels the devices of
/// [`WgpuBackend::new`] compile ([`WgpuOptions::kernel_dir`]).
pub const KERNEL_DIR_ENV: &str = "OPTIK_WGPU_KERNEL_DIR";

/// Options of [`WgpuBackend::with_options`].
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct WgpuOptions {
    /// A folder where every kernel the device compiles is written, as
    /// `kernel-<hash>.wgsl`, to read the generated code or to hand it to a driver's
    /// statistics (`optik-vulkan`'s `kernel_stats` example: registers, spills;
    /// docs/wgpu-backend.md §12.3). [`WgpuBackend::new`] takes it from
    /// [`KERNEL_DIR_ENV`]. A kernel that cannot be written there fails the call that compiles
    /// it (`create_pipeline`, or a launch that needs a kernel for a grown scene).
    pub kernel_dir: Option<std::path::PathBuf>,
    /// Caps the bytes optik puts in one storage binding below the adapter's
    /// `max_storage_buffer_binding_size` (at least 16 KiB is used). Acceleration structure
    /// data is then split into more, smaller buffers: this is how the splitting that large
    /// scenes need on lavapipe's 128 MiB limit is tested on small scenes.
    pub max_storage_binding: Option<u64>,
    /// Caps the workgroups per dispatch dimension below the adapter's
    /// `max_compute_workgroups_per_dimension`, so that splitting a launch over a 2D grid of
    /// workgroups and refusing launches beyond it can be tested with small launches.
    pub max_workgroups_per_dimension: Option<u32>,
    /// Caps the storage buffers a kernel may bind below the adapter's
    /// `max_storage_buffers_per_shader_stage`, to test the error when the scene's chunks and
    /// the user's buffers need more.
    pub max_storage_buffers_per_stage: Option<u32>,
}

impl WgpuBackend {
    /// Opens the adapter chosen by [`crate::gpu::ADAPTER_ENV`] or the best one found; kernels
    /// are written to the folder [`KERNEL_DIR_ENV`] names, if any.
    pub fn new() -> Result<WgpuBackend> {
        WgpuBackend::with_options(WgpuOptions {
            kernel_dir: std::env::var_os(KERNEL_DIR_ENV).map(std::path::PathBuf::from),
            ..WgpuOptions::default()
        })
    }

    /// [`WgpuBackend::new`] with options.
    pub fn with_options(options: WgpuOptions) -> Result<WgpuBackend> {
        let gpu = Arc::new(Gpu::open(&options)?);
        let id = DeviceId::next();
        let properties = DeviceProperties {
            max_trace_depth: 31,
            max_traversable_graph_depth: 16,
            max_primitives_per_build_input: 1 << 27,
            max_instances_per_ias: 1 << 24,
            max_instance_id: 1 << 24,
            max_sbt_offset: 1 << 24,
            num_bits_instance_visibility_mask: 8,
            max_sbt_records_per_build_input: 1 << 24,
            sbt_record_header_size: optik_api::SBT_RECORD_HEADER_SIZE,
            sbt_record_alignment: optik_api::SBT_RECORD_ALIGNMENT,
            max_sbt_record_stride: 1 << 16,
            max_payload_values: 32,
            max_attribute_values: 8,
            max_launch_size: 1 << 31,
            max_buffer_size: gpu.limits.max_buffer_size,
            max_binding_size: gpu.limits.max_storage_buffer_binding_size,
            backend: BackendKind::Wgpu,
            device_name: gpu.info.name.clone(),
            driver: format!("{} {}", gpu.info.driver, gpu.info.driver_info)
                .trim()
                .to_string(),
        };
        let scene = Scene::new(&gpu)?;
        Ok(WgpuBackend {
            id,
            properties,
            state: Mutex::new(State {
                accuracy: Accuracy::default(),
                scene,
                samplers: Vec::new(),
            }),
            gpu,
        })
    }

    pub(crate) fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    /// The backend's own state, after reporting a lost device: what every call that goes
    /// on to use the GPU takes.
    pub(crate) fn lock(&self) -> Result<MutexGuard<'_, State>> {
        self.gpu.check()?;
        self.state()
    }

    /// The backend's own state, even on a lost device: destroying must still free what an
    /// object held in the scene.
    fn state(&self) -> Result<MutexGuard<'_, State>> {
        self.state
            .lock()
            .map_err(|_| Error::backend("the device's state lock was poisoned by a panic"))
    }

    /// The device's accounting of its live GPU allocations; the tracker stays readable
    /// after the device is dropped.
    pub fn memory(&self) -> crate::MemoryTracker {
        self.gpu.memory.clone()
    }

    /// The adapter's limits as optik uses them (the storage binding size, possibly capped
    /// by [`WgpuOptions`], sizes the scene arena's chunks).
    pub fn limits(&self) -> wgpu::Limits {
        self.gpu.limits.clone()
    }

    /// Destroys the wgpu device under this one, as a driver reset would: every later call
    /// fails with `ErrorKind::DeviceLost`. For testing how applications handle device loss.
    pub fn lose_device_for_testing(&self) {
        self.gpu.device.destroy();
        let _ = self.gpu.device.poll(wgpu::PollType::Poll);
    }
}

mod sealed {
    /// Keeps [`super::WgpuDeviceExt`] implemented by [`super::WgpuDevice`] alone, so that
    /// methods can be added to it without breaking anyone.
    pub trait Sealed {}

    impl Sealed for super::WgpuDevice {}
}

/// The calls a wgpu device offers beyond `optik_api::Device` that read its objects.
///
/// optik-core's device owns the objects, so these live on [`WgpuDevice`] (which can lock
/// them) rather than on [`WgpuBackend`]; bring the trait into scope with
/// `use optik_wgpu::WgpuDeviceExt;`. Sealed: only [`WgpuDevice`] implements it.
pub trait WgpuDeviceExt: sealed::Sealed {
    /// The WGSL of the kernel a launch of `pipeline` would run now (for inspection and
    /// tests of specialisation): the variant for the scene alive now, compiled here if no
    /// launch has needed it yet.
    fn kernel_source(&self, pipeline: Pipeline) -> Result<String>;
}

impl WgpuDeviceExt for WgpuDevice {
    fn kernel_source(&self, pipeline: Pipeline) -> Result<String> {
        let backend = self.backend();
        let mut objects = self.objects();
        let sizes = scene_sizes(&objects.accels, &backend.lock()?.scene);
        let content = scene_content(&objects.accels);
        let p = objects.pipelines.get_mut(pipeline)?;
        Ok(p.variant(&backend.gpu, sizes, content, false)?
            .source
            .clone())
    }
}

/// Buffer bytes for decoding build inputs (after [`refresh`]).
struct HostBytes<'a>(&'a HandleTable<Buffer, BufferObject>);

impl BufferBytes for HostBytes<'_> {
    fn bytes(&self, buffer: Buffer) -> Result<&[u8]> {
        self.0
            .get(buffer)?
            .host_bytes()
            .ok_or_else(|| Error::backend("a build input buffer was not read back"))
    }
}

/// Micromap arrays for optik-accel's geometry builder.
struct Micromaps<'a>(&'a HandleTable<MicromapArray, Arc<MicromapArrayData>>);

impl MicromapLookup for Micromaps<'_> {
    fn micromap_array(&self, array: MicromapArray) -> Result<Arc<MicromapArrayData>> {
        Ok(self.0.get(array)?.clone())
    }
}

fn input_buffers(inputs: &[BuildInput]) -> Vec<Buffer> {
    let mut views: Vec<BufferView> = Vec::new();
    for input in inputs {
        match input {
            BuildInput::Triangles(t) => {
                views.extend(&t.vertex_buffers);
                views.extend(t.indices.map(|i| i.buffer));
                views.extend(t.sbt_index_offsets.map(|o| o.buffer));
                views.extend(t.pre_transform);
                views.extend(t.opacity_micromap.and_then(|o| o.index_buffer));
            }
            BuildInput::CustomPrimitives(c) => {
                views.extend(&c.aabb_buffers);
                views.extend(c.sbt_index_offsets.map(|o| o.buffer));
            }
            BuildInput::Spheres(s) => {
                views.extend(&s.vertex_buffers);
                views.extend(&s.radius_buffers);
                views.extend(s.sbt_index_offsets.map(|o| o.buffer));
            }
            BuildInput::Curves(c) => {
                views.extend(&c.vertex_buffers);
                views.extend(&c.width_buffers);
                views.push(c.index_buffer);
            }
            BuildInput::Instances(i) => views.push(i.instances),
        }
    }
    let mut buffers: Vec<Buffer> = views.iter().map(|v| v.buffer).collect();
    buffers.sort();
    buffers.dedup();
    buffers
}

/// Makes the host copies of `list` current: structures are built on the host from them.
fn refresh(
    buffers: &mut HandleTable<Buffer, BufferObject>,
    gpu: &Gpu,
    list: &[Buffer],
) -> Result<()> {
    for b in list {
        buffers.get_mut(*b)?.bytes(gpu)?;
    }
    Ok(())
}

/// The scene sizes a kernel must be compiled for now: the deepest stack and instance
/// nesting of any live structure, and the arena's chunking.
pub(crate) fn scene_sizes(accels: &HandleTable<Accel, AccelObject>, scene: &Scene) -> Sizes {
    let stack = accels
        .iter()
        .map(|(_, a)| a.stack_need)
        .max()
        .unwrap_or(0)
        .max(1);
    let levels = accels
        .iter()
        .map(|(_, a)| a.levels)
        .max()
        .unwrap_or(1)
        .max(1);
    Sizes {
        chunks: scene.arena.chunks().len() as u32,
        chunk_shift: scene.arena.chunk_shift(),
        stack: stack.div_ceil(8) * 8,
        levels,
    }
}

/// The union of the live structures' features (`None` when there is none): which of a
/// pipeline's features a launch's kernel keeps ([`FeatureSet::narrowed_to`]).
pub(crate) fn scene_content(accels: &HandleTable<Accel, AccelObject>) -> Option<SceneFeatures> {
    accels
        .iter()
        .map(|(_, a)| a.features)
        .reduce(SceneFeatures::union)
}

/// What a parent (instance or transform) needs of the child that the traversable `handle`
/// names; `None` for the null handle.
fn child(
    accels: &HandleTable<Accel, AccelObject>,
    scene: &Scene,
    device: DeviceId,
    handle: u64,
) -> Result<Option<ChildInfo>> {
    match scene.resolve(device, handle)? {
        None => Ok(None),
        Some(h) => Ok(Some(accels.get(h)?.child_info(h))),
    }
}

/// Encodes a structure from `inputs` (validated): its words and metadata.
fn encode(
    objects: &mut WgpuObjects,
    scene: &Scene,
    gpu: &Gpu,
    device: DeviceId,
    options: &AccelBuildOptions,
    inputs: &[BuildInput],
    previous: Option<&Refit>,
) -> Result<(Vec<[u32; 4]>, AccelObject)> {
    refresh(&mut objects.buffers, gpu, &input_buffers(inputs))?;
    let objects = &*objects;
    let bytes = HostBytes(&objects.buffers);
    if let BuildInput::Instances(ia) = &inputs[0] {
        let topology = match previous {
            Some(Refit::Instances(t)) => Some(t),
            _ => None,
        };
        let built = instances::build_instances(
            options,
            ia,
            &bytes,
            &|h| child(&objects.accels, scene, device, h),
            topology,
        )?;
        let object = AccelObject {
            region: (0, built.words.len() as u64),
            bounds: built.bounds,
            stack_need: built.stack_need,
            levels: built.levels,
            features: built.features,
            options: *options,
            inputs: inputs.to_vec(),
            refit: built.refit.map(Refit::Instances).unwrap_or(Refit::None),
            kind_word: accel::layout::kind_word(accel::layout::kind::IAS, 0, 0),
        };
        return Ok((built.words, object));
    }
    let micromaps = Micromaps(&objects.micromaps);
    let built = match previous {
        Some(Refit::Geometry(state)) => {
            geometry::update(options, inputs, &bytes, &micromaps, state)?
        }
        _ => geometry::build(options, inputs, &bytes, &micromaps)?,
    };
    let object = AccelObject {
        region: (0, built.words.len() as u64),
        bounds: built.bounds,
        stack_need: built.stack_need,
        levels: 1,
        features: SceneFeatures::of_geometry(options, inputs),
        options: *options,
        inputs: inputs.to_vec(),
        refit: built
            .refit
            .map(|r| Refit::Geometry(Box::new(r)))
            .unwrap_or(Refit::None),
        kind_word: built.words[0][0],
    };
    Ok((built.words, object))
}

/// Stores encoded words in the arena and registers the object in the scene under
/// `handle`, the handle core will insert it with; the object comes back for core to keep.
fn store(
    scene: &mut Scene,
    gpu: &Gpu,
    props: &DeviceProperties,
    handle: Accel,
    words: &[[u32; 4]],
    mut object: AccelObject,
) -> Result<AccelObject> {
    let depth = object.features.depth + 1;
    if depth > props.max_traversable_graph_depth {
        return Err(Error::limit(format!(
            "this structure would make a traversable graph {depth} levels deep (instances and transforms over geometry); this device allows {}",
            props.max_traversable_graph_depth
        )));
    }
    let n = words.len() as u64;
    let at = scene.arena.alloc(gpu, n)?;
    scene.arena.write(gpu, at, words);
    if let Err(e) = gpu.check() {
        scene.arena.free(at, n);
        return Err(e);
    }
    object.region = (at, n);
    // Registered last: core inserts the object under `handle` once this returns Ok, so the
    // scene never names a slot the table leaves empty.
    scene.register(handle, &object);
    Ok(object)
}

impl optik_core::Backend for WgpuBackend {
    type Buffer = BufferObject;
    type Texture = TextureObject;
    type Accel = AccelObject;
    type MicromapArray = Arc<MicromapArrayData>;
    type Module = ModuleObject;
    type ProgramGroup = GroupObject;
    type Pipeline = PipelineObject;

    const USES_VULKAN_LOADER: bool = true;

    fn id(&self) -> DeviceId {
        self.id
    }

    /// optik-core asks this before every call, so the methods below do not check again
    /// before they start; those that reach the GPU look again after (a loss during the call).
    fn alive(&self) -> Result<()> {
        self.gpu.check()
    }

    fn kind(&self) -> BackendKind {
        BackendKind::Wgpu
    }

    fn properties(&self) -> &DeviceProperties {
        &self.properties
    }

    fn accuracy(&self) -> Accuracy {
        self.state.lock().map(|s| s.accuracy).unwrap_or_default()
    }

    fn set_accuracy(&self, _objects: &WgpuObjects, accuracy: Accuracy) -> Result<()> {
        if accuracy.triangle == optik_api::TriangleTest::Driver {
            return Err(Error::unsupported(
                "TriangleTest::Driver is the Vulkan driver's own triangle test; the wgpu backend intersects triangles itself: choose TriangleTest::Watertight or TriangleTest::MollerTrumbore",
            ));
        }
        self.lock()?.accuracy = accuracy;
        Ok(())
    }

    fn create_buffer(&self, size: u64) -> Result<BufferObject> {
        BufferObject::create(&self.gpu, size)
    }

    fn write_buffer(&self, buffer: &mut BufferObject, offset: u64, data: &[u8]) -> Result<()> {
        buffer.write(&self.gpu, offset, data)
    }

    fn read_buffer(&self, buffer: &mut BufferObject, offset: u64, out: &mut [u8]) -> Result<()> {
        buffer.read(&self.gpu, offset, out)
    }

    fn buffer_size(&self, buffer: &BufferObject) -> u64 {
        buffer.size
    }

    fn destroy_buffer(&self, buffer: BufferObject) -> Result<()> {
        drop(buffer);
        self.gpu.check()
    }

    fn create_texture(&self, desc: &TextureDesc) -> Result<TextureObject> {
        TextureObject::create(&self.gpu, desc)
    }

    fn write_texture(&self, texture: &mut TextureObject, data: &[u8]) -> Result<()> {
        texture.write(&self.gpu, data)
    }

    fn texture_desc(&self, texture: &TextureObject) -> TextureDesc {
        texture.desc
    }

    fn destroy_texture(&self, texture: TextureObject) -> Result<()> {
        drop(texture);
        self.gpu.check()
    }

    fn accel_memory_usage(
        &self,
        _objects: &mut WgpuObjects,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
        keys: usize,
    ) -> Result<AccelBufferSizes> {
        let _ = options;
        let n: u64 = inputs.iter().map(|i| i.num_primitives() as u64).sum();
        let per_slot = match &inputs[0] {
            BuildInput::Instances(_) => accel::layout::INSTANCE_VEC4S,
            BuildInput::Triangles(_) => {
                accel::layout::slot_vec4s(accel::layout::prim::TRIANGLES, keys as u32)
            }
            BuildInput::CustomPrimitives(_) => {
                accel::layout::slot_vec4s(accel::layout::prim::CUSTOM, keys as u32)
            }
            BuildInput::Spheres(_) => {
                accel::layout::slot_vec4s(accel::layout::prim::SPHERES, keys as u32)
            }
            BuildInput::Curves(_) => {
                accel::layout::slot_vec4s(accel::layout::prim::CURVES, keys as u32)
            }
        };
        // At most one four-wide node per leaf and the inner nodes above them.
        let nodes = n.div_ceil(2).max(1) * accel::bvh4::NODE_VEC4S as u64;
        let output = (accel::layout::HEADER_VEC4S + nodes + n * per_slot) * 16;
        Ok(AccelBufferSizes {
            output_size_in_bytes: output,
            temp_size_in_bytes: 0,
            temp_update_size_in_bytes: 0,
        })
    }

    fn accel_build(
        &self,
        objects: &mut WgpuObjects,
        handle: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
        _keys: usize,
    ) -> Result<AccelObject> {
        let mut s = self.lock()?;
        let (words, object) = encode(objects, &s.scene, &self.gpu, self.id, options, inputs, None)?;
        store(
            &mut s.scene,
            &self.gpu,
            &self.properties,
            handle,
            &words,
            object,
        )
    }

    fn accel_update(
        &self,
        objects: &mut WgpuObjects,
        accel: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<()> {
        let s = self.lock()?;
        let (built_options, refit, region) = {
            let a = objects.accels.get(accel)?;
            (a.options, a.refit.clone(), a.region)
        };
        let build_like = AccelBuildOptions {
            operation: BuildOperation::Build,
            ..*options
        };
        let (words, mut object) = encode(
            objects,
            &s.scene,
            &self.gpu,
            self.id,
            &build_like,
            inputs,
            Some(&refit),
        )?;
        if words.len() as u64 != region.1 {
            return Err(Error::backend(format!(
                "an update changed the structure's size from {} to {} vec4s",
                region.1,
                words.len()
            )));
        }
        s.scene.arena.write(&self.gpu, region.0, &words);
        object.region = region;
        object.options = built_options;
        *objects.accels.get_mut(accel)? = object;
        self.gpu.check()
    }

    fn accel_compact(
        &self,
        objects: &mut WgpuObjects,
        accel: Accel,
        handle: Accel,
    ) -> Result<AccelObject> {
        let mut s = self.lock()?;
        let a = objects.accels.get(accel)?;
        let mut copy = AccelObject {
            region: a.region,
            bounds: a.bounds,
            stack_need: a.stack_need,
            levels: a.levels,
            features: a.features,
            options: a.options,
            inputs: a.inputs.clone(),
            refit: a.refit.clone(),
            kind_word: a.kind_word,
        };
        // References inside a structure are relative to its header: a copy is as good.
        let (from, n) = a.region;
        let to = s.scene.arena.alloc(&self.gpu, n)?;
        s.scene.arena.copy(&self.gpu, from, to, n);
        // Core inserts the copy only on Ok: a failed copy must give its words back and
        // stay out of the scene.
        if let Err(e) = self.gpu.check() {
            s.scene.arena.free(to, n);
            return Err(e);
        }
        copy.region = (to, n);
        s.scene.register(handle, &copy);
        Ok(copy)
    }

    fn accel_build_record(
        &self,
        accel: &AccelObject,
    ) -> Option<(AccelBuildOptions, Vec<BuildInput>)> {
        // Transforms are stored without inputs.
        (!accel.inputs.is_empty()).then(|| (accel.options, accel.inputs.clone()))
    }

    fn accel_size(&self, accel: &AccelObject) -> u64 {
        accel.region.1 * accel::arena::VEC4_BYTES
    }

    fn accel_features(&self, accel: &AccelObject) -> SceneFeatures {
        accel.features
    }

    fn create_transform(
        &self,
        objects: &mut WgpuObjects,
        handle: Accel,
        desc: &TransformDesc,
    ) -> Result<AccelObject> {
        let mut s = self.lock()?;
        let child = child(&objects.accels, &s.scene, self.id, desc.child().0)
            .map_err(|e| e.context("transform child"))?;
        let built = instances::build_transform(desc, child);
        let object = AccelObject {
            region: (0, built.words.len() as u64),
            bounds: built.bounds,
            stack_need: built.stack_need,
            levels: built.levels,
            features: built.features,
            options: AccelBuildOptions::default(),
            inputs: Vec::new(),
            refit: Refit::None,
            kind_word: built.words[0][0],
        };
        store(
            &mut s.scene,
            &self.gpu,
            &self.properties,
            handle,
            &built.words,
            object,
        )
    }

    fn create_opacity_micromap_array(
        &self,
        desc: &OpacityMicromapArrayDesc,
    ) -> Result<Arc<MicromapArrayData>> {
        Ok(Arc::new(MicromapArrayData::new(desc)))
    }

    fn traversable_handle(&self, handle: Accel, _accel: &AccelObject) -> Result<TraversableHandle> {
        Ok(accel::handle_of(self.id, handle))
    }

    fn destroy_accel(
        &self,
        _objects: &mut WgpuObjects,
        handle: Accel,
        accel: AccelObject,
    ) -> Result<()> {
        // Core has taken the object out of its table already: free its words and forget
        // its handle before reporting a lost device, or the scene would name a dead slot.
        let mut s = self.state()?;
        s.scene.arena.free(accel.region.0, accel.region.1);
        s.scene.unregister(handle.raw().slot);
        drop(s);
        self.gpu.check()
    }

    fn destroy_micromap_array(&self, array: Arc<MicromapArrayData>) -> Result<()> {
        drop(array);
        self.gpu.check()
    }

    fn create_module(
        &self,
        module_options: &ModuleCompileOptions,
        pipeline_options: &PipelineCompileOptions,
        source: &ProgramSource,
    ) -> Result<(ModuleObject, String)> {
        let (m, log) = ModuleObject::create(module_options, pipeline_options, source)?;
        self.gpu.check()?;
        Ok((m, log))
    }

    fn module_programs(&self, module: &ModuleObject) -> Vec<String> {
        module
            .source
            .compiled
            .programs
            .iter()
            .map(|p| p.name.clone())
            .collect()
    }

    fn destroy_module(&self, module: ModuleObject) -> Result<()> {
        drop(module);
        self.gpu.check()
    }

    fn create_program_groups(
        &self,
        objects: &WgpuObjects,
        descs: &[ProgramGroupDesc],
    ) -> Result<Vec<GroupObject>> {
        descs
            .iter()
            .enumerate()
            .map(|(i, d)| {
                let module_of = |p: &ProgramRef| -> Result<Arc<ModuleSource>> {
                    Ok(objects.modules.get(p.module)?.source.clone())
                };
                GroupObject::create(d, &module_of).map_err(|e| e.context(format!("descs[{i}]")))
            })
            .collect()
    }

    fn group_region(&self, group: &GroupObject) -> GroupRegion {
        group.desc.region()
    }

    fn destroy_program_group(&self, group: GroupObject) -> Result<()> {
        drop(group);
        self.gpu.check()
    }

    fn create_pipeline(
        &self,
        objects: &WgpuObjects,
        _pipeline_options: &PipelineCompileOptions,
        link_options: &PipelineLinkOptions,
        groups: &[ProgramGroup],
        features: &FeatureSet,
    ) -> Result<PipelineObject> {
        let s = self.lock()?;
        let mut unique: Vec<ProgramGroup> = Vec::new();
        for g in groups {
            objects.groups.get(*g)?;
            if !unique.contains(g) {
                unique.push(*g);
            }
        }
        let pairs: Vec<(ProgramGroup, &GroupObject)> = unique
            .iter()
            .map(|g| Ok((*g, objects.groups.get(*g)?)))
            .collect::<Result<_>>()?;
        let mut p = pipeline::link(
            link_options,
            &pairs,
            *features,
            s.accuracy,
            self.id.0 & 0xFFFF,
        )?;
        // Compile now, so that errors surface at link time.
        let sizes = scene_sizes(&objects.accels, &s.scene);
        p.variant(&self.gpu, sizes, scene_content(&objects.accels), false)?;
        Ok(p)
    }

    fn program_features(
        &self,
        objects: &WgpuObjects,
        groups: &[ProgramGroup],
    ) -> Result<optik_api::ProgramFeatures> {
        Ok(pipeline::program_features(&objects.groups_of(groups)?))
    }

    fn pipeline_features(&self, pipeline: &PipelineObject) -> FeatureSet {
        pipeline.features
    }

    fn pipeline_bindings(&self, pipeline: &PipelineObject) -> Vec<BindingInfo> {
        pipeline
            .bindings
            .iter()
            .flat_map(|(_, b)| b.iter().cloned())
            .collect()
    }

    fn destroy_pipeline(&self, pipeline: PipelineObject) -> Result<()> {
        drop(pipeline);
        self.gpu.check()
    }

    fn launch(
        &self,
        objects: &mut WgpuObjects,
        pipeline: Pipeline,
        params: &[u8],
        resources: &[Resource],
        sbt: &ShaderBindingTable,
        size: LaunchSize,
        options: &optik_api::LaunchOptions,
    ) -> Result<()> {
        let watch = optik_api::LaunchWatch::new(options)?;
        crate::launch::launch(
            self,
            objects,
            pipeline,
            params,
            resources,
            sbt,
            size,
            crate::launch::Observe::default(),
        )?;
        if options.deadline.is_some() || options.cancel.is_some() {
            crate::launch::wait_watched(&self.gpu, &watch)?;
        }
        watch.finish()
    }

    fn synchronize(&self) -> Result<()> {
        self.gpu.wait()
    }
}
