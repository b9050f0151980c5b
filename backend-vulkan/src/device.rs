//! [`VulkanBackend`]: this backend's `optik_core::Backend` ([`VulkanDevice`] is the device
//! users hold: optik-core's checks in front of it), and the state behind its lock.
//!
//! optik-core owns the objects (buffers, textures, acceleration structures, micromap arrays,
//! modules, program groups, pipelines: the trait's associated types, in its
//! `optik_core::Objects`) and lends them to each call, locked. [`Inner`] holds what is no
//! object: the Vulkan context, memory, commands, samplers, the scene tables and the empty
//! top level, launches in flight, the pipeline cache and the accuracy. Its lock is always
//! taken after core's. The trait methods lock it and call the `impl Inner` methods of the
//! modules named as in every backend (`accel`, `pipeline`, `sbt`, `launch`), plus `buffer`
//! and `texture`, passing the tables they read.

use crate::accel::{Proxy, SceneTables, Tlas, TriangleBuild};
use crate::cache::PipelineCache;
use crate::commands::{Commands, Submission};
use crate::context::{Context, VulkanOptions};
use crate::launch::InFlight;
use crate::memory::Allocator;
use crate::objects::{
    AccelObject, Accels, GroupObject, MicromapArrayObject, ModuleObject, Objects, PipelineObject,
    TextureObject, Unfreed, UserBuffer,
};
use crate::probe::VulkanDeviceInfo;
use ash::vk;
use optik_api::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard};

/// What a device holds besides its objects (which optik-core owns), behind its lock.
pub struct Inner {
    /// The instance and device.
    pub ctx: Arc<Context>,
    /// Device memory.
    pub alloc: Allocator,
    /// The command pool.
    pub commands: Commands,
    /// Samplers, one per description.
    pub samplers: HashMap<SamplerDesc, vk::Sampler>,
    /// Traversable handle (a TLAS device address) → the handle of its object in core's
    /// table (instances and transforms name children by traversable handle).
    pub by_handle: HashMap<u64, Accel>,
    /// The instance, geometry and data tables programs read.
    pub tables: SceneTables,
    /// An acceleration structure with no instances: null handles and continuation calls
    /// trace against it.
    pub empty_tlas: Option<Tlas>,
    /// Launches the host has not waited for.
    pub in_flight: Vec<InFlight>,
    /// The pipeline cache.
    pub cache: PipelineCache,
    /// Counter for buffer generations.
    pub next_generation: u64,
    /// The accuracy setting: the triangle test of structures built and pipelines created
    /// from now on (DESIGN.md §5).
    pub accuracy: Accuracy,
    /// The proxy bottom levels of paths through motion transforms, by address (owned by
    /// their transforms, accel/transform.rs).
    pub proxies: HashMap<u64, Proxy>,
    /// Proxies replaced while top levels above them are refreshed, freed afterwards.
    pub retired_proxies: Vec<u64>,
    /// Objects destroyed while they could not be freed, freed with the device.
    pub unfreed: Vec<Unfreed>,
    /// `TriangleTest::Watertight` uses the driver's triangles where they can serve (the
    /// driver passed optik's check; docs/vulkan-backend.md §2.4).
    pub driver_triangles: bool,
    /// Where the device mixes triangle kinds, the first hit record index of the second half,
    /// which paths over boxes select (a power of two above every index a path selects
    /// without it; accel/mod.rs keeps it so).
    pub hit_half: u32,
    /// Box twins of geometry structures built with the driver's triangles, for paths whose
    /// instances disable face culling (accel/mod.rs, §2.4), by structure.
    pub box_twins: HashMap<Accel, crate::accel::vkas::AsBuffer>,
    /// Traversable handles of the live geometry structures whose triangles are the driver's.
    pub driver_triangle_structures: std::collections::HashSet<u64>,
}

/// The Vulkan device users hold: optik-core's checks in front of [`VulkanBackend`], whose own
/// methods (device info, validation log, pipeline cache) it dereferences to.
pub type VulkanDevice = optik_core::Device<VulkanBackend>;

/// The Vulkan backend: ray tracing pipelines through ash.
pub struct VulkanBackend {
    id: DeviceId,
    ctx: Arc<Context>,
    props: DeviceProperties,
    inner: Mutex<Inner>,
    /// The error that lost the device, returned again by every later call.
    lost: Mutex<Option<Error>>,
}

impl VulkanBackend {
    /// Opens the device `options` ask for.
    pub fn open(options: &VulkanOptions) -> Result<VulkanBackend> {
        let ctx = Arc::new(Context::new(options)?);
        let id = DeviceId::next();
        let props = properties(&ctx.info);
        let commands = Commands::new(&ctx)?;
        let cache = PipelineCache::open(&ctx, options.pipeline_cache, options.cache_dir.clone());
        let mut inner = Inner {
            ctx: ctx.clone(),
            alloc: Allocator::default(),
            commands,
            samplers: HashMap::new(),
            by_handle: HashMap::new(),
            tables: SceneTables::default(),
            empty_tlas: None,
            in_flight: Vec::new(),
            cache,
            next_generation: 1,
            accuracy: Accuracy::ROBUST,
            proxies: HashMap::new(),
            retired_proxies: Vec::new(),
            unfreed: Vec::new(),
            driver_triangles: options.driver_triangles.unwrap_or(false),
            hit_half: 0,
            box_twins: HashMap::new(),
            driver_triangle_structures: Default::default(),
        };
        inner.create_empty_tlas()?;
        Ok(VulkanBackend {
            id,
            ctx,
            props,
            inner: Mutex::new(inner),
            lost: Mutex::new(None),
        })
    }

    /// The physical device's properties.
    pub fn info(&self) -> &VulkanDeviceInfo {
        &self.ctx.info
    }

    /// The validation layer's messages since the last call (always empty without
    /// validation). Tests fail on any.
    pub fn take_validation_messages(&self) -> Vec<String> {
        self.ctx.log.take()
    }

    /// The validation layer's message log, which outlives the device: messages the layer
    /// reports while the device is destroyed arrive there too.
    pub fn validation_log(&self) -> Arc<crate::validation::MessageLog> {
        self.ctx.log.clone()
    }

    /// The pipeline cache file, when the cache is kept on disk.
    pub fn pipeline_cache_path(&self) -> Option<std::path::PathBuf> {
        self.lock().cache.path().cloned()
    }

    /// Lets `TriangleTest::Watertight` (the default) use the driver's triangles where they
    /// can serve, for a driver that passed optik's check (`optik::open` decides it so;
    /// docs/vulkan-backend.md §2.4), or keeps optik's triangle stage for every triangle.
    /// Only before any acceleration structure or transform is built; pipelines created
    /// before it are refused at launch.
    pub fn set_driver_triangles(&self, on: bool) -> Result<()> {
        self.with(|i| i.set_driver_triangles(on))
    }

    /// Whether the device was told its driver's triangles may serve the default
    /// (`set_driver_triangles`); they do where it also has `rayTraversalPrimitiveCulling`.
    pub fn driver_triangles(&self) -> bool {
        self.lock().driver_triangles
    }

    /// Whether the live geometry structure with traversable handle `handle` holds the
    /// driver's triangles (under `TriangleTest::Driver`, or where the default mixes them in,
    /// docs/vulkan-backend.md §2.4), rather than boxes for optik's intersection stages.
    pub fn holds_driver_triangles(&self, handle: TraversableHandle) -> bool {
        self.lock().driver_triangle_structures.contains(&handle.0)
    }

    /// Whether buffers live in device-local memory behind staging copies.
    pub fn uses_staging(&self) -> bool {
        self.ctx.staging
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Runs `f` on the state; a lost device stays lost: every call after the one that met
    /// `VK_ERROR_DEVICE_LOST` returns that error again, without touching the device.
    fn with<T>(&self, f: impl FnOnce(&mut Inner) -> Result<T>) -> Result<T> {
        if let Some(e) = self.lost_error() {
            return Err(e);
        }
        let mut inner = self.lock();
        let r = f(&mut inner);
        if let Err(e) = &r
            && e.kind() == ErrorKind::DeviceLost
        {
            let mut lost = self.lost.lock().unwrap_or_else(|p| p.into_inner());
            lost.get_or_insert_with(|| {
                Error::new(
                    ErrorKind::DeviceLost,
                    format!(
                        "this Vulkan device was lost earlier and every object it owned is gone; drop it and open a new device (the first error: {})",
                        e.message()
                    ),
                )
            });
        }
        r
    }

    fn lost_error(&self) -> Option<Error> {
        self.lost.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// Runs `free` on an object core has taken out of its table. Core's handle is gone
    /// either way, so an object the device cannot free now (lost: `free` does not run) is
    /// kept in [`Inner::unfreed`] and freed with the device, as `free` does when its wait
    /// for launches fails.
    fn freeing<T>(
        &self,
        object: T,
        keep: fn(T) -> Unfreed,
        free: impl FnOnce(&mut Inner, T) -> Result<()>,
    ) -> Result<()> {
        let mut object = Some(object);
        let r = self.with(|i| object.take().map_or(Ok(()), |o| free(i, o)));
        if let Some(o) = object {
            self.lock().keep(keep(o));
        }
        r
    }

    /// Makes the device behave as lost (`VK_ERROR_DEVICE_LOST`), as after a driver reset:
    /// every later call fails with `ErrorKind::DeviceLost`. The Vulkan device itself stays
    /// intact, so dropping it frees everything. For testing how applications handle device
    /// loss.
    pub fn lose_device_for_testing(&self) {
        let _ = self.with(|_| -> Result<()> {
            Err(crate::error::vk_error(
                "lose_device_for_testing",
                vk::Result::ERROR_DEVICE_LOST,
            ))
        });
    }
}

/// optik's device properties from the Vulkan device's.
fn properties(info: &VulkanDeviceInfo) -> DeviceProperties {
    let clamp = |v: u64| v.min(u32::MAX as u64) as u32;
    // A user record's data follows the handle in Vulkan's record: the largest user stride is
    // what fits maxShaderGroupStride after swapping the 32-byte header for the handle.
    let max_stride = (info.max_shader_group_stride as u64 + sbt::SBT_RECORD_HEADER_SIZE as u64)
        .saturating_sub(info.shader_group_handle_size as u64)
        / sbt::SBT_RECORD_ALIGNMENT as u64
        * sbt::SBT_RECORD_ALIGNMENT as u64;
    DeviceProperties {
        max_trace_depth: info.max_ray_recursion_depth.min(31),
        // Instance trees are flattened into one Vulkan level, so any depth works; deep trees
        // multiply instances.
        max_traversable_graph_depth: 16,
        max_primitives_per_build_input: clamp(info.max_primitive_count),
        max_instances_per_ias: clamp(info.max_instance_count),
        max_instance_id: semantics::sbt_index::INSTANCE_ID_MASK + 1,
        max_sbt_offset: semantics::sbt_index::INSTANCE_SBT_OFFSET_MASK + 1,
        num_bits_instance_visibility_mask: 8,
        // Each record of a build input is one Vulkan geometry.
        max_sbt_records_per_build_input: clamp(info.max_geometry_count),
        sbt_record_header_size: sbt::SBT_RECORD_HEADER_SIZE,
        sbt_record_alignment: sbt::SBT_RECORD_ALIGNMENT,
        max_sbt_record_stride: clamp(max_stride),
        max_payload_values: 32,
        max_attribute_values: 8,
        // Larger launches than one vkCmdTraceRaysKHR allows run as several (launch.rs); the
        // bound keeps linear launch indices in a u32, as on the wgpu backend.
        max_launch_size: 1 << 31,
        max_buffer_size: info.device_local_heap.max(1 << 30),
        max_binding_size: info.max_storage_buffer_range as u64,
        backend: BackendKind::Vulkan,
        device_name: format!("{} (Vulkan, {})", info.name, info.driver_name),
        driver: format!(
            "{} {} (version {:#x})",
            info.driver_name, info.driver_info, info.driver_version
        ),
    }
}

/// What a launch stopped by its options adds to the error: the GPU goes on, what to do.
pub const STOPPED_ON_GPU: &str = "the Vulkan device goes on running the launch until its programs end (a running shader cannot be stopped): the device stays usable, and later calls on it (reads, writes, launches, synchronize, dropping it) wait for that end. A program that never ends is stopped only by the driver's watchdog, where there is one (not on lavapipe), and that loses the device: later calls then fail with ErrorKind::DeviceLost; open a new device. To stop runaway programs at the deadline, run them on the CPU backend";

impl Inner {
    /// Chooses the triangle test (DESIGN.md §5). Box tests are the driver's, over boxes
    /// padded for it: only `BoxTest::Conservative` describes them. Switching between native
    /// triangles (`TriangleTest::Driver`) and optik's triangle stage changes how structures
    /// are built, so it is refused while triangle structures built the other way are alive.
    pub fn set_accuracy(&mut self, accels: &Accels, accuracy: Accuracy) -> Result<()> {
        if accuracy.box_test != BoxTest::Conservative {
            return Err(Error::unsupported(format!(
                "BoxTest::{:?}: the Vulkan backend's box tests are the driver's, over boxes it pads so that no triangle a ray touches is missed (BoxTest::Conservative); an unpadded box test cannot be chosen",
                accuracy.box_test
            )));
        }
        let build = TriangleBuild::of(accuracy.triangle, self.mixable());
        if build != self.triangle_build() {
            let built_the_other_way = accels.iter().filter(|(_, a)| a.has_triangles()).count();
            if built_the_other_way > 0 {
                return Err(Error::invalid(format!(
                    "set_accuracy({:?}): {built_the_other_way} live acceleration structure(s) hold triangles built for {}; the Vulkan backend builds triangles differently for TriangleTest::Driver (native triangles), the watertight test on a driver that passed optik's check (the driver's triangles where they can serve, docs/vulkan-backend.md §2.4) and the other tests (optik's triangle stage), so destroy them first or set the accuracy before building",
                    accuracy.triangle,
                    match self.triangle_build() {
                        TriangleBuild::Driver => "TriangleTest::Driver",
                        TriangleBuild::Optik => "optik's triangle test",
                        TriangleBuild::Mixed => "the driver's and optik's triangles",
                    }
                )));
            }
        }
        self.accuracy = accuracy;
        Ok(())
    }

    /// Lets `TriangleTest::Watertight` use the driver's triangles where they can serve
    /// (`on`, for a driver that passed optik's check) or not; only before any acceleration
    /// structure or transform is built (structures are built for one or the other).
    pub fn set_driver_triangles(&mut self, on: bool) -> Result<()> {
        if on != self.driver_triangles && !self.by_handle.is_empty() {
            return Err(Error::invalid(format!(
                "set_driver_triangles({on}): {} acceleration structure(s) or transform(s) are alive, built {} the driver's triangles; call it before building any",
                self.by_handle.len(),
                if self.driver_triangles {
                    "with"
                } else {
                    "without"
                }
            )));
        }
        self.driver_triangles = on;
        Ok(())
    }

    /// Keeps an object that cannot be freed now until the device is dropped; a structure's
    /// traversable handle stops naming it at once.
    pub fn keep(&mut self, object: Unfreed) {
        if let Unfreed::Accel(a) = &object {
            self.by_handle.remove(&a.handle());
            self.driver_triangle_structures.remove(&a.handle());
        }
        self.unfreed.push(object);
    }

    /// Frees a buffer, texture or pipeline after the launches that may use it (kept for the
    /// device's drop when the wait fails).
    pub fn free(&mut self, object: Unfreed) -> Result<()> {
        if let Err(e) = self.wait_launches() {
            self.keep(object);
            return Err(e);
        }
        object.destroy(&self.ctx, &mut self.alloc);
        Ok(())
    }

    /// A fresh buffer generation.
    pub fn generation(&mut self) -> u64 {
        self.next_generation += 1;
        self.next_generation
    }

    /// Waits for every launch and frees what they held.
    pub fn wait_launches(&mut self) -> Result<()> {
        let mut first_error = None;
        for f in std::mem::take(&mut self.in_flight) {
            if let Err(e) = self.commands.wait(&self.ctx, &f.submission) {
                first_error.get_or_insert(e);
            }
            self.retire(f);
        }
        first_error.map_or(Ok(()), Err)
    }

    /// Waits for the launches in flight until they finish or `watch` stops the launch,
    /// looking at the stop flag between fence waits of a few milliseconds. A GPU cannot stop
    /// a running shader: a stopped launch returns its error while the device finishes the
    /// work, and later calls wait for it. A driver whose watchdog ends the work reports
    /// `VK_ERROR_DEVICE_LOST`, which becomes `ErrorKind::DeviceLost` for this and every later
    /// call ([`VulkanDevice`] keeps it).
    pub fn wait_watched(&mut self, watch: &optik_api::LaunchWatch) -> Result<()> {
        /// How long one fence wait lasts before the stop flag is looked at again.
        const SLICE: std::time::Duration = std::time::Duration::from_millis(5);
        loop {
            self.reap_launches()?;
            let Some(last) = self.in_flight.last() else {
                return Ok(());
            };
            if watch.stopped() {
                return watch.check().map_err(|e| {
                    Error::new(e.kind(), format!("{}; {STOPPED_ON_GPU}", e.message()))
                });
            }
            // Submissions finish in order: the last one ends the wait.
            self.commands.wait_for(&self.ctx, &last.submission, SLICE)?;
        }
    }

    /// Frees the launches that are done.
    pub fn reap_launches(&mut self) -> Result<()> {
        let mut still = Vec::new();
        for f in std::mem::take(&mut self.in_flight) {
            if self.commands.is_done(&self.ctx, &f.submission)? {
                self.retire(f);
            } else {
                still.push(f);
            }
        }
        self.in_flight = still;
        Ok(())
    }

    /// Runs recorded work and waits (after earlier launches finish).
    pub fn run_commands(
        &mut self,
        record: impl FnOnce(vk::CommandBuffer) -> Result<()>,
    ) -> Result<()> {
        self.wait_launches()?;
        self.commands.run(&self.ctx, record)
    }

    /// Submits recorded work without waiting.
    pub fn submit_commands(
        &mut self,
        record: impl FnOnce(vk::CommandBuffer) -> Result<()>,
    ) -> Result<Submission> {
        self.commands.submit(&self.ctx, record)
    }
}

impl Drop for VulkanBackend {
    /// Frees what is no object; optik-core has handed the objects back first
    /// ([`optik_core::Backend::release`]).
    fn drop(&mut self) {
        let mut inner = self.lock();
        let _ = inner.wait_launches();
        // SAFETY: nothing is pending after the wait (or the device is lost).
        let _ = unsafe { inner.ctx.device.device_wait_idle() };
        inner.cache.save(&inner.ctx);
        inner.destroy_everything();
    }
}

impl Inner {
    /// Frees the objects core hands back when the device is dropped, in the order that
    /// frees users before what they use: pipelines, structures, buffers, textures.
    fn free_objects(&mut self, mut objects: Objects) {
        let ctx = self.ctx.clone();
        for (_, p) in objects.pipelines.drain() {
            p.destroy(&ctx, &mut self.alloc);
        }
        for (_, a) in objects.accels.drain() {
            a.destroy(&ctx, &mut self.alloc);
        }
        for (_, b) in objects.buffers.drain() {
            b.gpu.destroy(&ctx, &mut self.alloc);
        }
        for (_, t) in objects.textures.drain() {
            t.destroy(&ctx, &mut self.alloc);
        }
    }

    /// Frees everything that is no object (device destruction), and the objects that could
    /// not be freed when they were destroyed.
    fn destroy_everything(&mut self) {
        let ctx = self.ctx.clone();
        for o in std::mem::take(&mut self.unfreed) {
            o.destroy(&ctx, &mut self.alloc);
        }
        for (_, p) in std::mem::take(&mut self.proxies) {
            p.structure.destroy(&ctx, &mut self.alloc);
        }
        for (_, t) in std::mem::take(&mut self.box_twins) {
            t.destroy(&ctx, &mut self.alloc);
        }
        if let Some(t) = self.empty_tlas.take() {
            t.destroy(&ctx, &mut self.alloc);
        }
        self.tables.destroy(&ctx, &mut self.alloc);
        for (_, s) in self.samplers.drain() {
            // SAFETY: idle device.
            unsafe { ctx.device.destroy_sampler(s, None) };
        }
        self.cache.destroy(&ctx);
        self.commands.destroy(&ctx);
        self.alloc.destroy(&ctx);
    }
}

impl optik_core::Backend for VulkanBackend {
    type Buffer = UserBuffer;
    type Texture = TextureObject;
    type Accel = AccelObject;
    type MicromapArray = MicromapArrayObject;
    type Module = ModuleObject;
    type ProgramGroup = GroupObject;
    type Pipeline = PipelineObject;

    const USES_VULKAN_LOADER: bool = true;

    fn id(&self) -> DeviceId {
        self.id
    }

    fn alive(&self) -> Result<()> {
        self.lost_error().map_or(Ok(()), Err)
    }

    fn kind(&self) -> BackendKind {
        BackendKind::Vulkan
    }

    fn properties(&self) -> &DeviceProperties {
        &self.props
    }

    fn accuracy(&self) -> Accuracy {
        self.lock().accuracy
    }

    fn set_accuracy(&self, objects: &Objects, accuracy: Accuracy) -> Result<()> {
        self.with(|i| i.set_accuracy(&objects.accels, accuracy))
    }

    fn create_buffer(&self, size: u64) -> Result<UserBuffer> {
        self.with(|i| i.create_buffer(size))
    }

    fn write_buffer(&self, buffer: &mut UserBuffer, offset: u64, data: &[u8]) -> Result<()> {
        self.with(|i| i.write_buffer(buffer, offset, data))
    }

    fn read_buffer(&self, buffer: &mut UserBuffer, offset: u64, out: &mut [u8]) -> Result<()> {
        self.with(|i| i.read_buffer(buffer, offset, out))
    }

    fn buffer_size(&self, buffer: &UserBuffer) -> u64 {
        buffer.gpu.size
    }

    fn destroy_buffer(&self, buffer: UserBuffer) -> Result<()> {
        self.freeing(buffer, Unfreed::Buffer, |i, b| i.free(Unfreed::Buffer(b)))
    }

    fn create_texture(&self, desc: &TextureDesc) -> Result<TextureObject> {
        self.with(|i| i.create_texture(desc))
    }

    fn texture_desc(&self, texture: &TextureObject) -> TextureDesc {
        texture.desc
    }

    fn write_texture(&self, texture: &mut TextureObject, data: &[u8]) -> Result<()> {
        self.with(|i| i.write_texture(texture, data))
    }

    fn destroy_texture(&self, texture: TextureObject) -> Result<()> {
        self.freeing(texture, Unfreed::Texture, |i, t| {
            i.free(Unfreed::Texture(t))
        })
    }

    fn accel_memory_usage(
        &self,
        objects: &mut Objects,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
        _keys: usize,
    ) -> Result<AccelBufferSizes> {
        self.with(|i| i.accel_memory_usage(objects, options, inputs))
    }

    fn accel_build(
        &self,
        objects: &mut Objects,
        handle: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
        _keys: usize,
    ) -> Result<AccelObject> {
        self.with(|i| i.accel_build(objects, handle, options, inputs))
    }

    fn accel_build_record(
        &self,
        accel: &AccelObject,
    ) -> Option<(AccelBuildOptions, Vec<BuildInput>)> {
        accel.build_record()
    }

    fn accel_update(
        &self,
        objects: &mut Objects,
        accel: Accel,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
    ) -> Result<()> {
        self.with(|i| i.accel_update(objects, accel, options, inputs))
    }

    fn accel_compact(
        &self,
        objects: &mut Objects,
        accel: Accel,
        handle: Accel,
    ) -> Result<AccelObject> {
        self.with(|i| i.accel_compact(&objects.accels, accel, handle))
    }

    fn accel_size(&self, accel: &AccelObject) -> u64 {
        accel.size()
    }

    fn accel_features(&self, accel: &AccelObject) -> SceneFeatures {
        accel.features()
    }

    fn create_transform(
        &self,
        objects: &mut Objects,
        handle: Accel,
        desc: &TransformDesc,
    ) -> Result<AccelObject> {
        self.with(|i| i.create_transform(&objects.accels, handle, desc))
    }

    fn create_opacity_micromap_array(
        &self,
        desc: &OpacityMicromapArrayDesc,
    ) -> Result<Arc<OpacityMicromapArrayDesc>> {
        self.with(|_| Ok(Arc::new(desc.clone())))
    }

    fn traversable_handle(&self, _handle: Accel, accel: &AccelObject) -> Result<TraversableHandle> {
        self.with(|_| Ok(TraversableHandle(accel.handle())))
    }

    fn destroy_accel(
        &self,
        objects: &mut Objects,
        handle: Accel,
        accel: AccelObject,
    ) -> Result<()> {
        self.freeing(accel, Unfreed::Accel, |i, a| {
            i.destroy_accel(&mut objects.accels, handle, a)
        })
    }

    fn destroy_micromap_array(&self, array: Arc<OpacityMicromapArrayDesc>) -> Result<()> {
        // Structures built with it keep their own copy of its states.
        self.with(|_| {
            drop(array);
            Ok(())
        })
    }

    fn create_module(
        &self,
        module_options: &ModuleCompileOptions,
        pipeline_options: &PipelineCompileOptions,
        source: &ProgramSource,
    ) -> Result<(ModuleObject, String)> {
        // Compiling needs nothing of the state, so other calls need not wait for it.
        if let Some(e) = self.lost_error() {
            return Err(e);
        }
        crate::pipeline::create_module(module_options, pipeline_options, source)
    }

    fn module_programs(&self, module: &ModuleObject) -> Vec<String> {
        module.programs()
    }

    fn destroy_module(&self, module: ModuleObject) -> Result<()> {
        // Host data only; `with` is there so that a lost device still says so.
        self.with(|_| {
            drop(module);
            Ok(())
        })
    }

    fn create_program_groups(
        &self,
        _objects: &Objects,
        descs: &[ProgramGroupDesc],
    ) -> Result<Vec<GroupObject>> {
        // optik-core has checked that every program exists with the kind its group uses.
        self.with(|_| {
            Ok(descs
                .iter()
                .map(|d| GroupObject { desc: d.clone() })
                .collect())
        })
    }

    fn group_region(&self, group: &GroupObject) -> GroupRegion {
        group.desc.region()
    }

    fn destroy_program_group(&self, group: GroupObject) -> Result<()> {
        // Host data only; `with` is there so that a lost device still says so.
        self.with(|_| {
            drop(group);
            Ok(())
        })
    }

    fn create_pipeline(
        &self,
        objects: &Objects,
        _pipeline_options: &PipelineCompileOptions,
        link_options: &PipelineLinkOptions,
        groups: &[ProgramGroup],
        features: &FeatureSet,
    ) -> Result<PipelineObject> {
        self.with(|i| i.create_pipeline(objects, link_options, groups, features))
    }

    fn program_features(
        &self,
        objects: &Objects,
        groups: &[ProgramGroup],
    ) -> Result<ProgramFeatures> {
        self.with(|_| crate::pipeline::program_features(objects, groups))
    }

    fn pipeline_features(&self, pipeline: &PipelineObject) -> FeatureSet {
        let c = &pipeline.config;
        FeatureSet {
            driver_triangles: c.intersects(PrimitiveTypeFlags::TRIANGLE)
                && (!c.triangles.emulated() || c.mixed_triangles),
            ..pipeline.features
        }
    }

    fn pipeline_bindings(
        &self,
        pipeline: &PipelineObject,
    ) -> Vec<optik_core::frontend::BindingInfo> {
        pipeline.bindings.clone()
    }

    fn destroy_pipeline(&self, pipeline: PipelineObject) -> Result<()> {
        self.freeing(pipeline, Unfreed::Pipeline, |i, p| {
            i.free(Unfreed::Pipeline(p))
        })
    }

    fn launch(
        &self,
        objects: &mut Objects,
        pipeline: Pipeline,
        params: &[u8],
        resources: &[Resource],
        sbt: &ShaderBindingTable,
        size: LaunchSize,
        options: &optik_api::LaunchOptions,
    ) -> Result<()> {
        let watch = optik_api::LaunchWatch::new(options)?;
        self.with(|i| i.launch(objects, pipeline, params, resources, sbt, size))?;
        if options.deadline.is_some() || options.cancel.is_some() {
            self.with(|i| i.wait_watched(&watch))?;
        }
        watch.finish()
    }

    fn synchronize(&self) -> Result<()> {
        self.with(|i| i.wait_launches())
    }

    fn take_diagnostics(&self) -> Vec<String> {
        self.take_validation_messages()
    }

    /// Waits for every launch, then frees the objects; [`VulkanBackend`]'s `Drop` frees
    /// the rest.
    fn release(&self, objects: Objects) {
        let mut inner = self.lock();
        let _ = inner.wait_launches();
        // SAFETY: nothing is pending after the wait (or the device is lost).
        let _ = unsafe { inner.ctx.device.device_wait_idle() };
        inner.free_objects(objects);
    }
}
