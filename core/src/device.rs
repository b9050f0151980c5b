//! [`Device<B>`]: `optik_api::Device` for every backend, checking each call once and owning
//! the objects.

use crate::{Backend, Objects};
use crate::{features, validate};
use optik_api::{
    Accel, AccelBufferSizes, AccelBuildOptions, Accuracy, BackendKind, Buffer, BuildFlags,
    BuildInput, BuildOperation, DeviceId, DeviceProperties, Error, FeatureSet, GroupRegion,
    LaunchOptions, LaunchSize, MAX_PAYLOAD_VALUES, MicromapArray, Module, ModuleCompileOptions,
    OpacityMicromapArrayDesc, Pipeline, PipelineCompileOptions, PipelineLinkOptions, ProgramGroup,
    ProgramGroupDesc, ProgramKind, ProgramSource, Resource, Result, SbtHeader, ShaderBindingTable,
    Texture, TextureDesc, TransformDesc, TraversableHandle,
};
use std::sync::{Mutex, MutexGuard, RwLockReadGuard};

/// An optik device: the backend `B` behind the checks every backend shares, and the
/// objects it made.
///
/// Every call locks the objects once, checks its arguments against them and calls the
/// backend under the same lock, so what was checked still holds when the backend acts. On a
/// lost device every call fails with the backend's `DeviceLost` error first.
/// Dereferences to `B` for what a backend offers beyond the API (the CPU device's thread
/// count, the wgpu device's memory tracker, the Vulkan device's validation log).
pub struct Device<B: Backend> {
    backend: B,
    objects: Mutex<Objects<B>>,
}

impl<B: Backend> Device<B> {
    /// The device of `backend`.
    pub fn new(backend: B) -> Self {
        let objects = Mutex::new(Objects::new(backend.id()));
        Self { backend, objects }
    }

    /// Held through a call that reaches the backend ([`crate::vulkan_loader`]): `None` for a
    /// backend without the Vulkan loader.
    fn loader(&self) -> LoaderGuard {
        B::USES_VULKAN_LOADER.then(crate::vulkan_loader::using)
    }

    /// The start of every call that reaches the backend: the loader held to its end and the
    /// backend found alive (a lost device fails every call with its `DeviceLost` error
    /// first). The call locks the objects from it ([`Entered::lock`]) for as long as it
    /// needs them, so one that works long without them (compiling a module) or after them
    /// (destroying what it removed) leaves them free meanwhile.
    fn enter(&self) -> Result<Entered<'_, B>> {
        let loader = self.loader();
        self.backend.alive()?;
        Ok(Entered {
            objects: &self.objects,
            _loader: loader,
        })
    }

    /// The backend behind the checks.
    pub fn backend(&self) -> &B {
        &self.backend
    }

    /// The device's objects, locked: for a backend's own extensions (calls beyond the API
    /// that read or add objects, such as the CPU backend's native modules, or that launch
    /// with them). Every other call on the device waits while the guard lives, and the guard
    /// holds the Vulkan loader as the device's own calls do ([`crate::vulkan_loader`]).
    pub fn objects(&self) -> Locked<'_, B> {
        // Loader first, as in every call: the two locks are always taken in one order.
        let loader = self.loader();
        Locked {
            objects: lock_objects(&self.objects),
            _loader: loader,
        }
    }

    /// Checks build inputs against the live buffers; their motion key count.
    fn check_inputs(
        &self,
        objects: &Objects<B>,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<usize> {
        validate::build_inputs(
            options,
            inputs,
            self.backend.properties(),
            &sizes(&self.backend, objects),
        )
    }

    /// The build record of `accel`, refusing transforms in `call`.
    fn built(
        &self,
        objects: &Objects<B>,
        accel: Accel,
        call: &str,
    ) -> Result<(AccelBuildOptions, Vec<BuildInput>)> {
        self.backend
            .accel_build_record(objects.accels.get(accel)?)
            .ok_or_else(|| {
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
    fn check_group(&self, objects: &Objects<B>, i: usize, desc: &ProgramGroupDesc) -> Result<()> {
        for (kind, program) in desc.programs() {
            let context = || {
                format!(
                    "program_groups[{i}] ({} program `{}`)",
                    kind.name(),
                    program.entry
                )
            };
            let names = objects
                .modules
                .get(program.module)
                .map(|m| self.backend.module_programs(m))
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

    /// The union of the features of every live acceleration structure and transform;
    /// `None` when there is none. What `Auto` pipeline options resolve against.
    fn scene_features(&self, objects: &Objects<B>) -> Option<optik_api::SceneFeatures> {
        objects
            .accels
            .iter()
            .map(|(_, a)| self.backend.accel_features(a))
            .reduce(optik_api::SceneFeatures::union)
    }
}

/// The shared hold of the Vulkan loader's lock ([`crate::vulkan_loader`]) by a call on a
/// device whose backend uses the loader.
type LoaderGuard = Option<RwLockReadGuard<'static, ()>>;

/// `objects`, locked.
fn lock_objects<B: Backend>(objects: &Mutex<Objects<B>>) -> MutexGuard<'_, Objects<B>> {
    // A panic inside a call never leaves a table half-updated (objects are inserted and
    // removed whole), so a poisoned lock is safe to keep using.
    objects.lock().unwrap_or_else(|e| e.into_inner())
}

/// A call on a [`Device`] in progress ([`Device::enter`]): the loader held, the backend
/// found alive.
struct Entered<'d, B: Backend> {
    objects: &'d Mutex<Objects<B>>,
    _loader: LoaderGuard,
}

impl<B: Backend> Entered<'_, B> {
    /// The device's objects, locked while the guard lives (within the call).
    fn lock(&self) -> MutexGuard<'_, Objects<B>> {
        lock_objects(self.objects)
    }
}

/// A device's objects, locked, with the Vulkan loader held ([`Device::objects`]);
/// dereferences to them.
pub struct Locked<'d, B: Backend> {
    // Fields drop in order: the objects are unlocked before the loader is let go.
    objects: MutexGuard<'d, Objects<B>>,
    _loader: LoaderGuard,
}

impl<B: Backend> std::ops::Deref for Locked<'_, B> {
    type Target = Objects<B>;

    fn deref(&self) -> &Objects<B> {
        &self.objects
    }
}

impl<B: Backend> std::ops::DerefMut for Locked<'_, B> {
    fn deref_mut(&mut self) -> &mut Objects<B> {
        &mut self.objects
    }
}

/// The size of each buffer, for the checks.
fn sizes<'a, B: Backend>(
    backend: &'a B,
    objects: &'a Objects<B>,
) -> impl Fn(Buffer) -> Result<u64> + 'a {
    |b| objects.buffers.get(b).map(|o| backend.buffer_size(o))
}

impl<B: Backend> Drop for Device<B> {
    fn drop(&mut self) {
        let objects = self.objects.get_mut().unwrap_or_else(|e| e.into_inner());
        let objects = std::mem::replace(objects, Objects::new(self.backend.id()));
        self.backend.release(objects);
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
        let call = self.enter()?;
        self.backend.set_accuracy(&*call.lock(), accuracy)
    }

    fn create_buffer(&self, size: u64) -> Result<Buffer> {
        let call = self.enter()?;
        validate::buffer_create(size, self.backend.properties())?;
        let buffer = self.backend.create_buffer(size)?;
        Ok(call.lock().buffers.insert(buffer))
    }

    fn write_buffer(&self, buffer: Buffer, offset: u64, data: &[u8]) -> Result<()> {
        let call = self.enter()?;
        let mut objects = call.lock();
        validate::buffer_range(
            "write_buffer",
            buffer,
            offset,
            data.len() as u64,
            &sizes(&self.backend, &objects),
        )?;
        let b = objects.buffers.get_mut(buffer)?;
        self.backend.write_buffer(b, offset, data)
    }

    fn read_buffer(&self, buffer: Buffer, offset: u64, out: &mut [u8]) -> Result<()> {
        let call = self.enter()?;
        let mut objects = call.lock();
        validate::buffer_range(
            "read_buffer",
            buffer,
            offset,
            out.len() as u64,
            &sizes(&self.backend, &objects),
        )?;
        let b = objects.buffers.get_mut(buffer)?;
        self.backend.read_buffer(b, offset, out)
    }

    fn buffer_size(&self, buffer: Buffer) -> Result<u64> {
        let call = self.enter()?;
        sizes(&self.backend, &*call.lock())(buffer)
    }

    fn destroy_buffer(&self, buffer: Buffer) -> Result<()> {
        let call = self.enter()?;
        let b = call.lock().buffers.remove(buffer)?;
        self.backend.destroy_buffer(b)
    }

    fn create_texture(&self, desc: &TextureDesc) -> Result<Texture> {
        let call = self.enter()?;
        validate::texture(desc)?;
        let texture = self.backend.create_texture(desc)?;
        Ok(call.lock().textures.insert(texture))
    }

    fn write_texture(&self, texture: Texture, data: &[u8]) -> Result<()> {
        let call = self.enter()?;
        let mut objects = call.lock();
        let t = objects.textures.get_mut(texture)?;
        validate::texture_data(&self.backend.texture_desc(t), data)?;
        self.backend.write_texture(t, data)
    }

    fn destroy_texture(&self, texture: Texture) -> Result<()> {
        let call = self.enter()?;
        let t = call.lock().textures.remove(texture)?;
        self.backend.destroy_texture(t)
    }

    fn accel_memory_usage(
        &self,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<AccelBufferSizes> {
        let call = self.enter()?;
        let mut objects = call.lock();
        let keys = self.check_inputs(&objects, options, inputs)?;
        self.backend
            .accel_memory_usage(&mut objects, options, inputs, keys)
    }

    fn accel_build(&self, options: &AccelBuildOptions, inputs: &[BuildInput]) -> Result<Accel> {
        let call = self.enter()?;
        let mut objects = call.lock();
        let keys = self.check_inputs(&objects, options, inputs)?;
        if options.operation != BuildOperation::Build {
            return Err(Error::invalid(
                "accel_build needs build_options.operation = Build; refit an existing structure with accel_update",
            ));
        }
        let handle = objects.accels.next_handle();
        let accel = self
            .backend
            .accel_build(&mut objects, handle, options, inputs, keys)?;
        Ok(objects.accels.insert(accel))
    }

    fn accel_update(
        &self,
        accel: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<()> {
        let call = self.enter()?;
        let mut objects = call.lock();
        let (built_with, built_inputs) = self.built(&objects, accel, "accel_update")?;
        validate::update(&built_with, &built_inputs, options, inputs)?;
        self.check_inputs(&objects, options, inputs)?;
        self.backend
            .accel_update(&mut objects, accel, options, inputs)
    }

    fn accel_compact(&self, accel: Accel) -> Result<Accel> {
        let call = self.enter()?;
        let mut objects = call.lock();
        let (built_with, _) = self.built(&objects, accel, "accel_compact")?;
        if !built_with.flags.contains(BuildFlags::ALLOW_COMPACTION) {
            return Err(Error::invalid(
                "accel_compact: the acceleration structure was built without BuildFlags::ALLOW_COMPACTION; rebuild it with that flag",
            ));
        }
        let handle = objects.accels.next_handle();
        let compacted = self.backend.accel_compact(&mut objects, accel, handle)?;
        Ok(objects.accels.insert(compacted))
    }

    fn accel_size(&self, accel: Accel) -> Result<u64> {
        let call = self.enter()?;
        Ok(self.backend.accel_size(call.lock().accels.get(accel)?))
    }

    fn create_transform(&self, desc: &TransformDesc) -> Result<Accel> {
        let call = self.enter()?;
        validate::transform(desc)?;
        let mut objects = call.lock();
        let handle = objects.accels.next_handle();
        let transform = self.backend.create_transform(&mut objects, handle, desc)?;
        Ok(objects.accels.insert(transform))
    }

    fn create_opacity_micromap_array(
        &self,
        desc: &OpacityMicromapArrayDesc,
    ) -> Result<MicromapArray> {
        let call = self.enter()?;
        validate::micromap_array(desc)?;
        let array = self.backend.create_opacity_micromap_array(desc)?;
        Ok(call.lock().micromaps.insert(array))
    }

    fn traversable_handle(&self, accel: Accel) -> Result<TraversableHandle> {
        let call = self.enter()?;
        let objects = call.lock();
        self.backend
            .traversable_handle(accel, objects.accels.get(accel)?)
    }

    fn destroy_accel(&self, accel: Accel) -> Result<()> {
        let call = self.enter()?;
        let mut objects = call.lock();
        let object = objects.accels.remove(accel)?;
        self.backend.destroy_accel(&mut objects, accel, object)
    }

    fn destroy_micromap_array(&self, array: MicromapArray) -> Result<()> {
        let call = self.enter()?;
        let array = call.lock().micromaps.remove(array)?;
        self.backend.destroy_micromap_array(array)
    }

    fn create_module(
        &self,
        module_options: &ModuleCompileOptions,
        pipeline_options: &PipelineCompileOptions,
        source: &ProgramSource,
    ) -> Result<(Module, String)> {
        let call = self.enter()?;
        let payload = pipeline_options.num_payload_values.or(MAX_PAYLOAD_VALUES);
        if payload > MAX_PAYLOAD_VALUES {
            return Err(Error::limit(format!(
                "pipeline_options.num_payload_values is {payload}; at most {MAX_PAYLOAD_VALUES} payload registers exist"
            )));
        }
        // Compiling takes long and needs no other object: the lock is taken to insert.
        let (module, log) = self
            .backend
            .create_module(module_options, pipeline_options, source)?;
        Ok((call.lock().modules.insert(module), log))
    }

    fn destroy_module(&self, module: Module) -> Result<()> {
        let call = self.enter()?;
        let module = call.lock().modules.remove(module)?;
        self.backend.destroy_module(module)
    }

    fn create_program_groups(&self, descs: &[ProgramGroupDesc]) -> Result<Vec<ProgramGroup>> {
        let call = self.enter()?;
        let mut objects = call.lock();
        for (i, desc) in descs.iter().enumerate() {
            self.check_group(&objects, i, desc)?;
        }
        let groups = self.backend.create_program_groups(&objects, descs)?;
        Ok(groups
            .into_iter()
            .map(|g| objects.groups.insert(g))
            .collect())
    }

    fn destroy_program_group(&self, group: ProgramGroup) -> Result<()> {
        let call = self.enter()?;
        let group = call.lock().groups.remove(group)?;
        self.backend.destroy_program_group(group)
    }

    fn create_pipeline(
        &self,
        pipeline_options: &PipelineCompileOptions,
        link_options: &PipelineLinkOptions,
        groups: &[ProgramGroup],
    ) -> Result<Pipeline> {
        let call = self.enter()?;
        if groups.is_empty() {
            return Err(Error::invalid(
                "create_pipeline needs at least one program group (a raygen group)",
            ));
        }
        let mut objects = call.lock();
        let live = objects.groups_of(groups)?;
        if !live
            .iter()
            .any(|g| self.backend.group_region(g) == GroupRegion::Raygen)
        {
            return Err(Error::invalid(
                "create_pipeline: none of the groups is a raygen group; launches start in a raygen program",
            ));
        }
        let programs = self.backend.program_features(&objects, groups)?;
        let features = features::resolve(
            pipeline_options,
            link_options,
            self.scene_features(&objects),
            &programs,
            self.backend.properties().max_trace_depth,
        )?;
        let pipeline = self.backend.create_pipeline(
            &objects,
            pipeline_options,
            link_options,
            groups,
            &features,
        )?;
        Ok(objects.pipelines.insert(pipeline))
    }

    fn pipeline_features(&self, pipeline: Pipeline) -> Result<FeatureSet> {
        let call = self.enter()?;
        Ok(self
            .backend
            .pipeline_features(call.lock().pipelines.get(pipeline)?))
    }

    fn destroy_pipeline(&self, pipeline: Pipeline) -> Result<()> {
        let call = self.enter()?;
        let pipeline = call.lock().pipelines.remove(pipeline)?;
        self.backend.destroy_pipeline(pipeline)
    }

    fn sbt_record_pack_header(&self, group: ProgramGroup) -> Result<[u8; 32]> {
        let call = self.enter()?;
        let region = self.backend.group_region(call.lock().groups.get(group)?);
        Ok(SbtHeader::pack(group, region))
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
        let call = self.enter()?;
        let mut objects = call.lock();
        let bindings = self
            .backend
            .pipeline_bindings(objects.pipelines.get(pipeline)?);
        let props = self.backend.properties();
        let sizes = sizes(&self.backend, &objects);
        validate::launch_size(size, props)?;
        validate::sbt(sbt, props, &sizes)?;
        validate::launch_bindings(params, resources, &bindings, &sizes)?;
        for r in resources {
            match r {
                Resource::Buffer {
                    binding,
                    buffer,
                    offset,
                    size,
                } => {
                    let what = format!("resource at binding {binding}");
                    let total = sizes(*buffer).map_err(|e| e.context(&what))?;
                    let len = size.unwrap_or(total.saturating_sub(*offset));
                    validate::buffer_range(&what, *buffer, *offset, len, &sizes)?;
                }
                Resource::Texture { binding, texture } => {
                    objects
                        .textures
                        .get(*texture)
                        .map_err(|e| e.context(format!("resource at binding {binding}")))?;
                }
                Resource::Sampler { .. } => {}
            }
        }
        drop(sizes);
        self.backend.launch(
            &mut objects,
            pipeline,
            params,
            resources,
            sbt,
            size,
            options,
        )
    }

    fn synchronize(&self) -> Result<()> {
        let _call = self.enter()?;
        self.backend.synchronize()
    }

    fn take_diagnostics(&self) -> Vec<String> {
        let _loader = self.loader();
        self.backend.take_diagnostics()
    }
}
