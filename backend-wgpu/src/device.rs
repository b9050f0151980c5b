//! [`WgpuBackend`]: the wgpu backend's `optik_core::Backend` ([`WgpuDevice`] is the device
//! users hold: optik-core's checks in front of it).
//!
//! All state sits behind one lock; handles and the adapter's own limits are checked before
//! anything is changed, so a failed call leaves the device as it was. Dropping the device
//! drops every wgpu object it owns.

use crate::accel::geometry;
use crate::accel::instances::{self, ChildInfo};
use crate::accel::{self, AccelObject, Refit, Scene};
use crate::buffer::{BufferObject, TextureObject};
use crate::gpu::Gpu;
use crate::kernel::Sizes;
use crate::pipeline::{self, PipelineObject};
use crate::program::{GroupObject, ModuleObject, ModuleSource};
use optik_accel::decode::BufferBytes;
use optik_accel::{MicromapArrayData, MicromapLookup};
use optik_api::{
    Accel, AccelBufferSizes, AccelBuildOptions, Accuracy, BackendKind, Buffer, BufferView,
    BuildInput, BuildOperation, DeviceId, DeviceProperties, Error, FeatureSet, GroupRegion, Handle,
    LaunchSize, MicromapArray, Module, ModuleCompileOptions, OpacityMicromapArrayDesc, Pipeline,
    PipelineCompileOptions, PipelineLinkOptions, ProgramGroup, ProgramGroupDesc, ProgramRef,
    ProgramSource, Resource, Result, SceneFeatures, ShaderBindingTable, Texture, TextureDesc,
    TransformDesc, TraversableHandle,
};
use optik_core::HandleTable;
use optik_core::frontend::BindingInfo;
use std::sync::{Arc, Mutex, MutexGuard};

/// The wgpu device users hold: optik-core's checks in front of [`WgpuBackend`], whose own
/// methods (kernel source, memory tracker, limits) it dereferences to.
pub type WgpuDevice = optik_core::Device<WgpuBackend>;

/// The wgpu backend: optik pipelines run as compute megakernels.
pub struct WgpuBackend {
    id: DeviceId,
    gpu: Arc<Gpu>,
    properties: DeviceProperties,
    state: Mutex<State>,
}

pub(crate) struct State {
    pub accuracy: Accuracy,
    pub buffers: HandleTable<Buffer, BufferObject>,
    pub textures: HandleTable<Texture, TextureObject>,
    pub accels: HandleTable<Accel, AccelObject>,
    pub micromaps: HandleTable<MicromapArray, Arc<MicromapArrayData>>,
    pub modules: HandleTable<Module, ModuleObject>,
    pub groups: HandleTable<ProgramGroup, GroupObject>,
    pub pipelines: HandleTable<Pipeline, PipelineObject>,
    pub scene: Scene,
    pub samplers: Vec<(optik_api::SamplerDesc, wgpu::Sampler)>,
}

/// Options of [`WgpuDevice::with_options`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WgpuOptions {
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
    /// Opens the adapter chosen by [`crate::gpu::ADAPTER_ENV`] or the best one found.
    pub fn new() -> Result<WgpuBackend> {
        WgpuBackend::with_options(WgpuOptions::default())
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
            backend: BackendKind::Wgpu,
            device_name: gpu.info.name.clone(),
        };
        let scene = Scene::new(&gpu)?;
        Ok(WgpuBackend {
            id,
            properties,
            state: Mutex::new(State {
                accuracy: Accuracy::default(),
                buffers: HandleTable::new(id),
                textures: HandleTable::new(id),
                accels: HandleTable::new(id),
                micromaps: HandleTable::new(id),
                modules: HandleTable::new(id),
                groups: HandleTable::new(id),
                pipelines: HandleTable::new(id),
                scene,
                samplers: Vec::new(),
            }),
            gpu,
        })
    }

    pub(crate) fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    pub(crate) fn lock(&self) -> Result<MutexGuard<'_, State>> {
        self.gpu.check()?;
        self.state
            .lock()
            .map_err(|_| Error::backend("the device's state lock was poisoned by a panic"))
    }

    /// The WGSL of the kernel a launch of `pipeline` would run now (for inspection and
    /// tests of specialisation).
    pub fn kernel_source(&self, pipeline: Pipeline) -> Result<String> {
        let mut s = self.lock()?;
        let sizes = s.sizes();
        let p = s.pipelines.get_mut(pipeline)?;
        Ok(p.variant(&self.gpu, sizes, false)?.source.clone())
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

/// Buffer bytes for decoding build inputs (after [`State::refresh`]).
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

impl State {
    fn size_of(&self, b: Buffer) -> Result<u64> {
        Ok(self.buffers.get(b)?.size)
    }

    /// Makes the host copies of `buffers` current.
    fn refresh(&mut self, gpu: &Gpu, buffers: &[Buffer]) -> Result<()> {
        for b in buffers {
            self.buffers.get_mut(*b)?.bytes(gpu)?;
        }
        Ok(())
    }

    /// The scene sizes a kernel must be compiled for now.
    pub fn sizes(&self) -> Sizes {
        let stack = self
            .accels
            .iter()
            .map(|(_, a)| a.stack_need)
            .max()
            .unwrap_or(0)
            .max(1);
        let levels = self
            .accels
            .iter()
            .map(|(_, a)| a.levels)
            .max()
            .unwrap_or(1)
            .max(1);
        Sizes {
            chunks: self.scene.arena.chunks().len() as u32,
            chunk_shift: self.scene.arena.chunk_shift(),
            stack: stack.div_ceil(8) * 8,
            levels,
        }
    }

    /// The union of the features of every live structure (`None` when there is none).
    pub fn scene_features(&self) -> Option<SceneFeatures> {
        self.accels
            .iter()
            .map(|(_, a)| a.features)
            .reduce(|a, b| a.union(b))
    }

    fn child(&self, device: DeviceId, handle: u64) -> Result<Option<ChildInfo>> {
        match self.scene.resolve(device, handle)? {
            None => Ok(None),
            Some(h) => Ok(Some(self.accels.get(h)?.child_info(h))),
        }
    }

    /// Encodes a structure from `inputs` (validated): its words and metadata.
    fn encode(
        &mut self,
        gpu: &Gpu,
        device: DeviceId,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
        previous: Option<&Refit>,
    ) -> Result<(Vec<[u32; 4]>, AccelObject)> {
        self.refresh(gpu, &input_buffers(inputs))?;
        let bytes = HostBytes(&self.buffers);
        if let BuildInput::Instances(ia) = &inputs[0] {
            let topology = match previous {
                Some(Refit::Instances(t)) => Some(t),
                _ => None,
            };
            let built = instances::build_instances(
                options,
                ia,
                &bytes,
                &|h| self.child(device, h),
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
        let micromaps = Micromaps(&self.micromaps);
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

    /// Stores encoded words in the arena and registers the object.
    fn store(
        &mut self,
        gpu: &Gpu,
        props: &DeviceProperties,
        words: &[[u32; 4]],
        mut object: AccelObject,
    ) -> Result<Accel> {
        let depth = object.features.depth + 1;
        if depth > props.max_traversable_graph_depth {
            return Err(Error::limit(format!(
                "this structure would make a traversable graph {depth} levels deep (instances and transforms over geometry); this device allows {}",
                props.max_traversable_graph_depth
            )));
        }
        let n = words.len() as u64;
        let at = self.scene.arena.alloc(gpu, n)?;
        self.scene.arena.write(gpu, at, words);
        if let Err(e) = gpu.check() {
            self.scene.arena.free(at, n);
            return Err(e);
        }
        object.region = (at, n);
        let handle = self.accels.insert(object);
        let object = self.accels.get(handle)?;
        self.scene.register(handle, object);
        Ok(handle)
    }
}

impl optik_core::Backend for WgpuBackend {
    fn id(&self) -> DeviceId {
        self.id
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

    fn set_accuracy(&self, accuracy: Accuracy) -> Result<()> {
        if accuracy.triangle == optik_api::TriangleTest::Driver {
            return Err(Error::unsupported(
                "TriangleTest::Driver is the Vulkan driver's own triangle test; the wgpu backend intersects triangles itself: choose TriangleTest::Watertight or TriangleTest::MollerTrumbore",
            ));
        }
        self.lock()?.accuracy = accuracy;
        Ok(())
    }

    fn create_buffer(&self, size: u64) -> Result<Buffer> {
        let mut s = self.lock()?;
        let b = BufferObject::create(&self.gpu, size)?;
        Ok(s.buffers.insert(b))
    }

    fn write_buffer(&self, buffer: Buffer, offset: u64, data: &[u8]) -> Result<()> {
        let mut s = self.lock()?;
        s.buffers.get_mut(buffer)?.write(&self.gpu, offset, data)
    }

    fn read_buffer(&self, buffer: Buffer, offset: u64, out: &mut [u8]) -> Result<()> {
        let s = self.lock()?;
        s.buffers.get(buffer)?.read(&self.gpu, offset, out)
    }

    fn buffer_size(&self, buffer: Buffer) -> Result<u64> {
        self.lock()?.size_of(buffer)
    }

    fn destroy_buffer(&self, buffer: Buffer) -> Result<()> {
        self.lock()?.buffers.remove(buffer).map(drop)
    }

    fn create_texture(&self, desc: &TextureDesc) -> Result<Texture> {
        let mut s = self.lock()?;
        let t = TextureObject::create(&self.gpu, desc)?;
        Ok(s.textures.insert(t))
    }

    fn write_texture(&self, texture: Texture, data: &[u8]) -> Result<()> {
        let s = self.lock()?;
        let t = s.textures.get(texture)?;
        t.write(&self.gpu, data)
    }

    fn texture_desc(&self, texture: Texture) -> Result<TextureDesc> {
        Ok(self.lock()?.textures.get(texture)?.desc)
    }

    fn destroy_texture(&self, texture: Texture) -> Result<()> {
        self.lock()?.textures.remove(texture).map(drop)
    }

    fn accel_memory_usage(
        &self,
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
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
        _keys: usize,
    ) -> Result<Accel> {
        let mut s = self.lock()?;
        let (words, object) = s.encode(&self.gpu, self.id, options, inputs, None)?;
        s.store(&self.gpu, &self.properties, &words, object)
    }

    fn accel_update(
        &self,
        accel: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<()> {
        let mut s = self.lock()?;
        let (built_options, refit, region) = {
            let a = s.accels.get(accel)?;
            (a.options, a.refit.clone(), a.region)
        };
        let build_like = AccelBuildOptions {
            operation: BuildOperation::Build,
            ..*options
        };
        let (words, mut object) =
            s.encode(&self.gpu, self.id, &build_like, inputs, Some(&refit))?;
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
        *s.accels.get_mut(accel)? = object;
        self.gpu.check()
    }

    fn accel_compact(&self, accel: Accel) -> Result<Accel> {
        let mut s = self.lock()?;
        let a = s.accels.get(accel)?;
        let copy = AccelObject {
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
        let mut copy = copy;
        copy.region = (to, n);
        let st = &mut *s;
        let handle = st.accels.insert(copy);
        let object = st.accels.get(handle)?;
        st.scene.register(handle, object);
        self.gpu.check()?;
        Ok(handle)
    }

    fn accel_build_record(
        &self,
        accel: Accel,
    ) -> Result<Option<(AccelBuildOptions, Vec<BuildInput>)>> {
        let s = self.lock()?;
        let a = s.accels.get(accel)?;
        // Transforms are stored without inputs.
        Ok((!a.inputs.is_empty()).then(|| (a.options, a.inputs.clone())))
    }

    fn accel_size(&self, accel: Accel) -> Result<u64> {
        Ok(self.lock()?.accels.get(accel)?.region.1 * accel::arena::VEC4_BYTES)
    }

    fn create_transform(&self, desc: &TransformDesc) -> Result<Accel> {
        let mut s = self.lock()?;
        let child = s
            .child(self.id, desc.child().0)
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
        s.store(&self.gpu, &self.properties, &built.words, object)
    }

    fn create_opacity_micromap_array(
        &self,
        desc: &OpacityMicromapArrayDesc,
    ) -> Result<MicromapArray> {
        let mut s = self.lock()?;
        Ok(s.micromaps.insert(Arc::new(MicromapArrayData::new(desc))))
    }

    fn traversable_handle(&self, accel: Accel) -> Result<TraversableHandle> {
        self.lock()?.accels.get(accel)?;
        Ok(accel::handle_of(self.id, accel))
    }

    fn destroy_accel(&self, accel: Accel) -> Result<()> {
        let mut s = self.lock()?;
        let a = s.accels.remove(accel)?;
        s.scene.arena.free(a.region.0, a.region.1);
        s.scene.unregister(accel.raw().slot);
        Ok(())
    }

    fn destroy_micromap_array(&self, array: MicromapArray) -> Result<()> {
        self.lock()?.micromaps.remove(array).map(drop)
    }

    fn create_module(
        &self,
        module_options: &ModuleCompileOptions,
        pipeline_options: &PipelineCompileOptions,
        source: &ProgramSource,
    ) -> Result<(Module, String)> {
        let (m, log) = ModuleObject::create(module_options, pipeline_options, source)?;
        Ok((self.lock()?.modules.insert(m), log))
    }

    fn module_programs(&self, module: Module) -> Result<Vec<String>> {
        let s = self.lock()?;
        let m = s.modules.get(module)?;
        Ok(m.source
            .compiled
            .programs
            .iter()
            .map(|p| p.name.clone())
            .collect())
    }

    fn destroy_module(&self, module: Module) -> Result<()> {
        self.lock()?.modules.remove(module).map(drop)
    }

    fn create_program_groups(&self, descs: &[ProgramGroupDesc]) -> Result<Vec<ProgramGroup>> {
        let mut s = self.lock()?;
        let objects: Vec<GroupObject> = descs
            .iter()
            .enumerate()
            .map(|(i, d)| {
                let module_of = |p: &ProgramRef| -> Result<Arc<ModuleSource>> {
                    Ok(s.modules.get(p.module)?.source.clone())
                };
                GroupObject::create(d, &module_of).map_err(|e| e.context(format!("descs[{i}]")))
            })
            .collect::<Result<_>>()?;
        Ok(objects.into_iter().map(|g| s.groups.insert(g)).collect())
    }

    fn group_region(&self, group: ProgramGroup) -> Result<GroupRegion> {
        Ok(self.lock()?.groups.get(group)?.desc.region())
    }

    fn destroy_program_group(&self, group: ProgramGroup) -> Result<()> {
        self.lock()?.groups.remove(group).map(drop)
    }

    fn create_pipeline(
        &self,
        _pipeline_options: &PipelineCompileOptions,
        link_options: &PipelineLinkOptions,
        groups: &[ProgramGroup],
        features: &FeatureSet,
    ) -> Result<Pipeline> {
        let mut s = self.lock()?;
        let mut unique: Vec<ProgramGroup> = Vec::new();
        for g in groups {
            s.groups.get(*g)?;
            if !unique.contains(g) {
                unique.push(*g);
            }
        }
        let pairs: Vec<(ProgramGroup, &GroupObject)> = unique
            .iter()
            .map(|g| Ok((*g, s.groups.get(*g)?)))
            .collect::<Result<_>>()?;
        let mut p = pipeline::link(
            link_options,
            &pairs,
            *features,
            s.accuracy,
            self.id.0 & 0xFFFF,
        )?;
        // Compile now, so that errors surface at link time.
        p.variant(&self.gpu, s.sizes(), false)?;
        Ok(s.pipelines.insert(p))
    }

    fn program_features(&self, groups: &[ProgramGroup]) -> Result<optik_api::ProgramFeatures> {
        let s = self.lock()?;
        let objects = groups
            .iter()
            .enumerate()
            .map(|(i, g)| {
                s.groups
                    .get(*g)
                    .map_err(|e| e.context(format!("groups[{i}]")))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(pipeline::program_features(&objects))
    }

    fn scene_features(&self) -> Result<Option<SceneFeatures>> {
        Ok(self.lock()?.scene_features())
    }

    fn pipeline_features(&self, pipeline: Pipeline) -> Result<FeatureSet> {
        Ok(self.lock()?.pipelines.get(pipeline)?.features)
    }

    fn pipeline_bindings(&self, pipeline: Pipeline) -> Result<Vec<BindingInfo>> {
        let s = self.lock()?;
        let p = s.pipelines.get(pipeline)?;
        Ok(p.bindings
            .iter()
            .flat_map(|(_, b)| b.iter().cloned())
            .collect())
    }

    fn destroy_pipeline(&self, pipeline: Pipeline) -> Result<()> {
        self.lock()?.pipelines.remove(pipeline).map(drop)
    }

    fn launch(
        &self,
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
