//! What every Vulkan test uses: a device with the Khronos validation layer on, whose messages
//! fail the test (checked after the device is gone, so leaks count too), and small helpers
//! for buffers, programs and shader binding tables.

use optik_api::*;
use optik_vulkan::{VulkanBackend, VulkanDevice, VulkanOptions};
use std::sync::Arc;

/// A validated device; dropping it fails the test on any validation message.
pub struct TestDevice {
    dev: Option<VulkanDevice>,
    log: Arc<optik_vulkan::validation::MessageLog>,
}

impl std::ops::Deref for TestDevice {
    type Target = VulkanDevice;
    fn deref(&self) -> &VulkanDevice {
        self.dev.as_ref().expect("device is open")
    }
}

impl Drop for TestDevice {
    fn drop(&mut self) {
        drop(self.dev.take());
        let messages = self.log.take();
        if !messages.is_empty() && !std::thread::panicking() {
            panic!(
                "the validation layer reported {} message(s):\n{}",
                messages.len(),
                messages.join("\n")
            );
        }
    }
}

/// Opens the test device: validation on, pipeline cache off, staging as asked.
pub fn device_with(force_staging: bool) -> TestDevice {
    let options = VulkanOptions {
        validation: true,
        device: None,
        force_staging,
        pipeline_cache: false,
        cache_dir: None,
        max_dispatch_invocations: None,
        // OPTIK_VULKAN_DRIVER_TRIANGLES=1 runs the suite with the driver's triangles mixed
        // in (docs/vulkan-backend.md §2.4).
        driver_triangles: VulkanOptions::from_env().driver_triangles,
    };
    let dev = VulkanBackend::open(&options)
        .map(VulkanDevice::new)
        .unwrap_or_else(|e| panic!("no Vulkan ray tracing device for the tests: {e}"));
    let log = dev.validation_log();
    TestDevice {
        dev: Some(dev),
        log,
    }
}

/// A validated device with `options` (validation is forced on).
pub fn device_with_options(mut options: VulkanOptions) -> TestDevice {
    options.validation = true;
    let dev = VulkanBackend::open(&options)
        .map(VulkanDevice::new)
        .unwrap_or_else(|e| panic!("no Vulkan ray tracing device for the tests: {e}"));
    let log = dev.validation_log();
    TestDevice {
        dev: Some(dev),
        log,
    }
}

/// The test device with the memory layout the driver suggests.
pub fn device() -> TestDevice {
    device_with(false)
}

impl TestDevice {
    /// Fails the test now if the layer has reported anything.
    pub fn assert_no_messages(&self) {
        let messages = self.log.take();
        assert!(
            messages.is_empty(),
            "validation messages:\n{}",
            messages.join("\n")
        );
    }

    /// A buffer holding `data`.
    pub fn buffer_with(&self, data: &[u8]) -> Buffer {
        let b = self.create_buffer(data.len().max(4) as u64).unwrap();
        self.write_buffer(b, 0, data).unwrap();
        b
    }

    /// A buffer holding `f32`s.
    pub fn f32_buffer(&self, data: &[f32]) -> Buffer {
        self.buffer_with(bytemuck::cast_slice(data))
    }

    /// A buffer holding `u32`s.
    pub fn u32_buffer(&self, data: &[u32]) -> Buffer {
        self.buffer_with(bytemuck::cast_slice(data))
    }

    /// Reads a whole buffer as `u32`s.
    pub fn read_u32(&self, b: Buffer) -> Vec<u32> {
        let mut bytes = vec![0u8; self.buffer_size(b).unwrap() as usize];
        self.read_buffer(b, 0, &mut bytes).unwrap();
        bytemuck::cast_slice(&bytes).to_vec()
    }

    /// A GAS of unindexed `Float3` triangles with one SBT record.
    pub fn triangles(&self, vertices: &[[f32; 3]], flags: GeometryFlags) -> Accel {
        let flat: Vec<f32> = vertices.iter().flatten().copied().collect();
        let vb = self.f32_buffer(&flat);
        let input = BuildInput::Triangles(TriangleArray::new(
            BufferView::new(vb),
            vertices.len() as u32,
            flags,
        ));
        self.accel_build(&AccelBuildOptions::default(), &[input])
            .unwrap()
    }

    /// A GAS of custom primitives with one SBT record.
    pub fn aabbs(&self, boxes: &[[f32; 6]], flags: GeometryFlags) -> Accel {
        let flat: Vec<f32> = boxes.iter().flatten().copied().collect();
        let b = self.f32_buffer(&flat);
        let input = BuildInput::CustomPrimitives(CustomPrimitiveArray::new(
            BufferView::new(b),
            boxes.len() as u32,
            flags,
        ));
        self.accel_build(&AccelBuildOptions::default(), &[input])
            .unwrap()
    }

    /// An IAS over `instances`.
    pub fn instances(&self, instances: &[Instance]) -> Accel {
        let b = self.buffer_with(bytemuck::cast_slice(instances));
        let input = BuildInput::Instances(InstanceArray {
            instances: BufferView::new(b),
            num_instances: instances.len() as u32,
        });
        self.accel_build(&AccelBuildOptions::default(), &[input])
            .unwrap()
    }

    /// Compiles `wgsl` with default options.
    pub fn module(&self, wgsl: &str) -> Module {
        self.create_module(
            &ModuleCompileOptions::default(),
            &PipelineCompileOptions::default(),
            &ProgramSource::new("test.wgsl", wgsl),
        )
        .unwrap_or_else(|e| panic!("{e}"))
        .0
    }

    /// One program group.
    pub fn group(&self, desc: ProgramGroupDesc) -> ProgramGroup {
        self.create_program_groups(&[desc])
            .unwrap_or_else(|e| panic!("{e}"))[0]
    }

    /// A pipeline with default compile options.
    pub fn pipeline(&self, groups: &[ProgramGroup], max_trace_depth: u32) -> Pipeline {
        let link = PipelineLinkOptions {
            max_trace_depth,
            ..Default::default()
        };
        self.create_pipeline(&PipelineCompileOptions::default(), &link, groups)
            .unwrap_or_else(|e| panic!("{e}"))
    }
}

/// A program reference.
pub fn prog(module: Module, name: &str) -> ProgramRef {
    ProgramRef::new(module, name)
}

/// Builds an SBT buffer: records of `stride` bytes, each a header and `u32` data words.
pub struct SbtBuilder {
    bytes: Vec<u8>,
}

impl SbtBuilder {
    pub fn new() -> Self {
        SbtBuilder { bytes: Vec::new() }
    }

    /// Appends records (group, data words) at `stride`; returns the region's offset.
    pub fn records(
        &mut self,
        dev: &TestDevice,
        stride: u32,
        records: &[(ProgramGroup, &[u32])],
    ) -> u64 {
        while !self.bytes.len().is_multiple_of(64) {
            self.bytes.push(0);
        }
        let offset = self.bytes.len() as u64;
        for (g, data) in records {
            let mut rec = dev.sbt_record_pack_header(*g).unwrap().to_vec();
            rec.extend(data.iter().flat_map(|w| w.to_le_bytes()));
            assert!(
                rec.len() <= stride as usize,
                "record longer than its stride"
            );
            rec.resize(stride as usize, 0);
            self.bytes.extend(rec);
        }
        offset
    }

    /// The buffer.
    pub fn build(&self, dev: &TestDevice) -> Buffer {
        dev.buffer_with(&self.bytes)
    }
}

/// A table with a raygen record, misses, hit groups and callables at the given strides.
pub struct Table<'a> {
    pub raygen: (ProgramGroup, &'a [u32]),
    pub miss: Vec<(ProgramGroup, &'a [u32])>,
    pub hit: Vec<(ProgramGroup, &'a [u32])>,
    pub callables: Vec<(ProgramGroup, &'a [u32])>,
    pub exception: Option<(ProgramGroup, &'a [u32])>,
    pub stride: u32,
}

impl<'a> Table<'a> {
    pub fn new(raygen: ProgramGroup) -> Self {
        Table {
            raygen: (raygen, &[]),
            miss: Vec::new(),
            hit: Vec::new(),
            callables: Vec::new(),
            exception: None,
            stride: 64,
        }
    }

    /// Writes the table into a buffer.
    pub fn build(&self, dev: &TestDevice) -> ShaderBindingTable {
        let mut b = SbtBuilder::new();
        let rg = b.records(dev, self.stride, &[self.raygen]);
        let ex = self.exception.map(|e| b.records(dev, self.stride, &[e]));
        let miss = b.records(dev, self.stride, &self.miss);
        let hit = b.records(dev, self.stride, &self.hit);
        let callables = b.records(dev, self.stride, &self.callables);
        let buffer = b.build(dev);
        let region = |offset: u64, n: usize| {
            (n > 0).then_some(SbtRegion {
                buffer,
                offset,
                stride: self.stride,
                count: n as u32,
            })
        };
        ShaderBindingTable {
            raygen: SbtRecord { buffer, offset: rg },
            exception: ex.map(|offset| SbtRecord { buffer, offset }),
            miss: region(miss, self.miss.len()),
            hitgroup: region(hit, self.hit.len()),
            callables: region(callables, self.callables.len()),
        }
    }
}

/// Launch parameters: a traversable handle and a width/height.
pub fn params(handle: TraversableHandle, width: u32, height: u32) -> Vec<u8> {
    let w = handle.to_words();
    bytemuck::cast_slice(&[w[0], w[1], width, height]).to_vec()
}

/// Runs a one-dimensional launch of `n` rays of `pipeline` with `table`, an output buffer of
/// `words_per_ray` `u32`s per ray at binding 1 and `extra` resources; returns the words.
pub fn run_rays(
    dev: &TestDevice,
    pipeline: Pipeline,
    sbt: &ShaderBindingTable,
    handle: TraversableHandle,
    n: u32,
    words_per_ray: u32,
    extra: &[Resource],
) -> Vec<u32> {
    let out = dev
        .create_buffer(n as u64 * words_per_ray as u64 * 4)
        .unwrap();
    let mut resources = vec![Resource::buffer(1, out)];
    resources.extend_from_slice(extra);
    dev.launch(
        pipeline,
        &params(handle, n, 1),
        &resources,
        sbt,
        LaunchSize::new(n, 1, 1),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    dev.read_u32(out)
}

/// WGSL shared by the ray tests: the params struct, the output buffer, and `ray_for(i)`:
/// ray `i` of `n` starts at (x, 0.5, 1) with x spread over [-1, 2], pointing down -z.
pub const RAY_HEADER: &str = r#"
struct Params { handle: vec2<u32>, n: u32, pad: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn ray_x(i: u32) -> f32 {
    return -1.0 + 3.0 * (f32(i) + 0.5) / f32(params.n);
}
"#;

/// A pipeline of `raygen__rg`, `miss__ms` and `closesthit__ch` (a triangle hit group) from
/// [`RAY_HEADER`] + `programs`, with the groups for its tables.
pub struct Basic {
    pub pipeline: Pipeline,
    pub rg: ProgramGroup,
    pub ms: ProgramGroup,
}

/// Compiles and links a [`Basic`] pipeline with `max_trace_depth` 1.
pub fn basic(dev: &TestDevice, programs: &str) -> Basic {
    let m = dev.module(&format!("{RAY_HEADER}{programs}"));
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let ms = dev.group(ProgramGroupDesc::Miss(Some(prog(m, "miss__ms"))));
    let ch = dev.group(ProgramGroupDesc::closest_hit(prog(m, "closesthit__ch")));
    Basic {
        pipeline: dev.pipeline(&[rg, ms, ch], 1),
        rg,
        ms,
    }
}
