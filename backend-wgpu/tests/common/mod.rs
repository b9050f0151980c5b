//! Helpers for the end-to-end tests: a device, buffers from values, structures, pipelines
//! and shader binding tables in a few lines.
#![allow(dead_code)]

use optik_api::*;

/// A wgpu device (lavapipe in CI).
pub fn device() -> Box<dyn Device> {
    optik_wgpu::open().expect("a wgpu adapter (lavapipe: mesa-vulkan-drivers) is needed")
}

/// A buffer holding `data`.
pub fn buffer<T: bytemuck::Pod>(dev: &dyn Device, data: &[T]) -> Buffer {
    let bytes: &[u8] = bytemuck::cast_slice(data);
    let b = dev.create_buffer(bytes.len().max(4) as u64).unwrap();
    dev.write_buffer(b, 0, bytes).unwrap();
    b
}

/// Reads a whole buffer as `T`s.
pub fn read<T: bytemuck::Pod>(dev: &dyn Device, b: Buffer) -> Vec<T> {
    let mut out = vec![0u8; dev.buffer_size(b).unwrap() as usize];
    dev.read_buffer(b, 0, &mut out).unwrap();
    bytemuck::pod_collect_to_vec(&out)
}

/// A GAS of unindexed triangles with one SBT record.
pub fn triangles(dev: &dyn Device, vertices: &[[f32; 3]], flags: GeometryFlags) -> Accel {
    let vb = buffer(dev, vertices);
    let input = BuildInput::Triangles(TriangleArray::new(
        BufferView::new(vb),
        vertices.len() as u32,
        flags,
    ));
    dev.accel_build(&AccelBuildOptions::default(), &[input]).unwrap()
}

/// A quad (two triangles) in the plane z = `z` over [x0, x1] × [y0, y1], facing +z.
pub fn quad(x0: f32, x1: f32, y0: f32, y1: f32, z: f32) -> Vec<[f32; 3]> {
    vec![
        [x0, y0, z],
        [x1, y0, z],
        [x1, y1, z],
        [x0, y0, z],
        [x1, y1, z],
        [x0, y1, z],
    ]
}

/// Compiles `src` as module "test.wgsl".
pub fn module(dev: &dyn Device, src: &str) -> Module {
    dev.create_module(
        &ModuleCompileOptions::default(),
        &PipelineCompileOptions::default(),
        &ProgramSource::new("test.wgsl", src),
    )
    .unwrap_or_else(|e| panic!("{e}"))
    .0
}

/// The program groups of a pipeline, by role.
pub struct Groups {
    pub raygen: ProgramGroup,
    pub miss: Vec<ProgramGroup>,
    pub hit: Vec<ProgramGroup>,
    pub callables: Vec<ProgramGroup>,
    pub exception: Option<ProgramGroup>,
}

impl Groups {
    pub fn all(&self) -> Vec<ProgramGroup> {
        let mut v = vec![self.raygen];
        v.extend(&self.miss);
        v.extend(&self.hit);
        v.extend(&self.callables);
        v.extend(self.exception);
        v
    }
}

/// Creates groups from descriptions (raygen first, then the rest by their region).
pub fn groups(dev: &dyn Device, descs: &[ProgramGroupDesc]) -> Groups {
    let handles = dev.create_program_groups(descs).unwrap_or_else(|e| panic!("{e}"));
    let mut g = Groups {
        raygen: handles[0],
        miss: vec![],
        hit: vec![],
        callables: vec![],
        exception: None,
    };
    for (d, h) in descs.iter().zip(&handles).skip(1) {
        match d.region() {
            GroupRegion::Miss => g.miss.push(*h),
            GroupRegion::HitGroup => g.hit.push(*h),
            GroupRegion::Callables => g.callables.push(*h),
            GroupRegion::Exception => g.exception = Some(*h),
            GroupRegion::Raygen => panic!("one raygen group"),
        }
    }
    g
}

/// Builds an SBT: records of `stride` bytes, each header followed by its data words.
pub struct SbtBuilder {
    bytes: Vec<u8>,
}

pub const STRIDE: u32 = 64;

impl SbtBuilder {
    pub fn new() -> Self {
        SbtBuilder { bytes: Vec::new() }
    }

    /// Appends a record; returns its offset.
    pub fn record(&mut self, dev: &dyn Device, group: ProgramGroup, data: &[u32]) -> u64 {
        let at = self.bytes.len() as u64;
        self.bytes.extend_from_slice(&dev.sbt_record_pack_header(group).unwrap());
        let mut d: Vec<u8> = bytemuck::cast_slice(data).to_vec();
        d.resize((STRIDE - 32) as usize, 0);
        self.bytes.extend_from_slice(&d);
        at
    }

    pub fn finish(self, dev: &dyn Device) -> Buffer {
        buffer(dev, &self.bytes)
    }
}

/// A table with one record per group: raygen, misses, hits (with data), callables.
pub fn sbt(dev: &dyn Device, g: &Groups, hit_data: &[Vec<u32>]) -> ShaderBindingTable {
    let mut b = SbtBuilder::new();
    let raygen = b.record(dev, g.raygen, &[]);
    let miss0 = b.bytes.len() as u64;
    for m in &g.miss {
        b.record(dev, *m, &[]);
    }
    let hit0 = b.bytes.len() as u64;
    for (i, h) in g.hit.iter().enumerate() {
        b.record(dev, *h, hit_data.get(i).map(|v| v.as_slice()).unwrap_or(&[]));
    }
    let call0 = b.bytes.len() as u64;
    for c in &g.callables {
        b.record(dev, *c, &[]);
    }
    let exc = g.exception.map(|e| b.record(dev, e, &[]));
    let buf = b.finish(dev);
    let region = |offset, count: usize| {
        (count > 0).then_some(SbtRegion {
            buffer: buf,
            offset,
            stride: STRIDE,
            count: count as u32,
        })
    };
    ShaderBindingTable {
        raygen: SbtRecord {
            buffer: buf,
            offset: raygen,
        },
        exception: exc.map(|offset| SbtRecord { buffer: buf, offset }),
        miss: region(miss0, g.miss.len()),
        hitgroup: region(hit0, g.hit.len()),
        callables: region(call0, g.callables.len()),
    }
}

/// Launch parameters: a handle and up to six more words.
pub fn params(handle: TraversableHandle, extra: &[u32]) -> Vec<u8> {
    let mut words = handle.to_words().to_vec();
    words.extend_from_slice(extra);
    words.resize(8, 0);
    bytemuck::cast_slice(&words).to_vec()
}

/// The parameter struct matching [`params`] (binding 0) and an output buffer (binding 1).
pub const HEADER: &str = r#"
struct Params { handle: vec2<u32>, a: u32, b: u32, c: u32, d: u32, e: u32, f: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
"#;

/// Launches `width × height` with `params` and an output buffer of `words` u32s; returns it.
pub fn run(
    dev: &dyn Device,
    pipeline: Pipeline,
    table: &ShaderBindingTable,
    params: &[u8],
    width: u32,
    height: u32,
    words: usize,
) -> Vec<u32> {
    let out = dev.create_buffer((words * 4) as u64).unwrap();
    dev.launch(
        pipeline,
        params,
        &[Resource::buffer(1, out)],
        table,
        LaunchSize::new(width, height, 1),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    read(dev, out)
}

/// A pipeline with default options over `g`.
pub fn pipeline(dev: &dyn Device, g: &Groups, max_trace_depth: u32) -> Pipeline {
    dev.create_pipeline(
        &PipelineCompileOptions::default(),
        &PipelineLinkOptions {
            max_trace_depth,
            ..Default::default()
        },
        &g.all(),
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

pub fn raygen(m: Module, entry: &str) -> ProgramGroupDesc {
    ProgramGroupDesc::Raygen(ProgramRef::new(m, entry))
}

pub fn miss(m: Module, entry: &str) -> ProgramGroupDesc {
    ProgramGroupDesc::Miss(Some(ProgramRef::new(m, entry)))
}

pub fn closest_hit(m: Module, entry: &str) -> ProgramGroupDesc {
    ProgramGroupDesc::closest_hit(ProgramRef::new(m, entry))
}
