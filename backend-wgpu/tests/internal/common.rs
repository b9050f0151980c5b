//! Helpers of the tests in this binary: a device, buffers from values, structures, pipelines
//! and shader binding tables in a few lines.

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
    dev.accel_build(&AccelBuildOptions::default(), &[input])
        .unwrap()
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
    let handles = dev
        .create_program_groups(descs)
        .unwrap_or_else(|e| panic!("{e}"));
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
        self.bytes
            .extend_from_slice(&dev.sbt_record_pack_header(group).unwrap());
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
    sbt_with(dev, g, |region, i| match region {
        GroupRegion::HitGroup => hit_data.get(i).cloned().unwrap_or_default(),
        _ => Vec::new(),
    })
}

/// A table with one record per group, in the order raygen, misses, hits, callables,
/// exception; `data(region, i)` is the data of the region's `i`-th record.
fn sbt_with(
    dev: &dyn Device,
    g: &Groups,
    data: impl Fn(GroupRegion, usize) -> Vec<u32>,
) -> ShaderBindingTable {
    let mut b = SbtBuilder::new();
    let raygen = b.record(dev, g.raygen, &data(GroupRegion::Raygen, 0));
    let mut region_of = |groups: &[ProgramGroup], region: GroupRegion| {
        let offset = b.bytes.len() as u64;
        for (i, h) in groups.iter().enumerate() {
            b.record(dev, *h, &data(region, i));
        }
        (offset, groups.len())
    };
    let miss = region_of(&g.miss, GroupRegion::Miss);
    let hit = region_of(&g.hit, GroupRegion::HitGroup);
    let call = region_of(&g.callables, GroupRegion::Callables);
    let exc = g
        .exception
        .map(|e| b.record(dev, e, &data(GroupRegion::Exception, 0)));
    let buf = b.finish(dev);
    let region = |(offset, count): (u64, usize)| {
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
        exception: exc.map(|offset| SbtRecord {
            buffer: buf,
            offset,
        }),
        miss: region(miss),
        hitgroup: region(hit),
        callables: region(call),
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

/// One test ray: origin, tmin, direction, tmax.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: [f32; 3],
    pub tmin: f32,
    pub direction: [f32; 3],
    pub tmax: f32,
}

impl Ray {
    pub fn new(origin: [f32; 3], direction: [f32; 3]) -> Ray {
        Ray {
            origin,
            tmin: 0.0,
            direction,
            tmax: 1e30,
        }
    }
}

/// Per-trace settings of [`RAY_LIST`] launches.
#[derive(Clone, Copy, Debug)]
pub struct TraceArgs {
    pub flags: u32,
    pub sbt_offset: u32,
    pub sbt_stride: u32,
    pub miss_index: u32,
    pub mask: u32,
    pub time: f32,
}

impl Default for TraceArgs {
    fn default() -> Self {
        TraceArgs {
            flags: 0,
            sbt_offset: 0,
            sbt_stride: 1,
            miss_index: 0,
            mask: 0xFF,
            time: 0.0,
        }
    }
}

/// A raygen tracing one ray per launch index from a ray buffer (binding 2) and writing the
/// 8 payload words to `out` (binding 1). Payload on entry: 0xAAAAAAAA in every word.
/// Closest-hit `closesthit__rec` records: 1, t, primitive, hit kind, instance id, SBT GAS
/// index, the record's first data word, packed barycentrics; `miss__rec`: 2 and its record's
/// first data word.
pub const RAY_LIST: &str = r#"
struct Params { handle: vec2<u32>, flags: u32, sbt_offset: u32, sbt_stride: u32, miss_index: u32, mask: u32, time_bits: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@group(0) @binding(2) var<storage, read> rays: array<vec4<f32>>;

fn raygen__rays() {
    let i = rt_launch_index().x;
    let o = rays[2u * i];
    let d = rays[2u * i + 1u];
    var p: RtPayload;
    for (var k = 0u; k < 8u; k = k + 1u) {
        p[k] = 0xAAAAAAAAu;
    }
    rt_trace(params.handle, o.xyz, d.xyz, o.w, d.w, bitcast<f32>(params.time_bits), params.mask, params.flags, params.sbt_offset, params.sbt_stride, params.miss_index, &p);
    for (var k = 0u; k < 8u; k = k + 1u) {
        out[8u * i + k] = p[k];
    }
}

fn closesthit__rec() {
    rt_set_payload(0u, 1u);
    rt_set_payload(1u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(2u, rt_primitive_index());
    rt_set_payload(3u, rt_hit_kind());
    rt_set_payload(4u, rt_instance_id());
    rt_set_payload(5u, rt_sbt_gas_index());
    rt_set_payload(6u, rt_sbt_data_u32(0u));
    rt_set_payload(7u, pack2x16unorm(rt_triangle_barycentrics()));
}

fn miss__rec() {
    rt_set_payload(0u, 2u);
    rt_set_payload(6u, rt_sbt_data_u32(0u));
}
"#;

/// What [`RAY_LIST`] recorded for one ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rec {
    pub words: [u32; 8],
}

impl Rec {
    pub fn hit(&self) -> bool {
        self.words[0] == 1
    }
    pub fn missed(&self) -> bool {
        self.words[0] == 2
    }
    pub fn t(&self) -> f32 {
        f32::from_bits(self.words[1])
    }
    pub fn prim(&self) -> u32 {
        self.words[2]
    }
}

/// Traces `rays` through a [`RAY_LIST`] pipeline.
pub fn trace_rays(
    dev: &dyn Device,
    pipeline: Pipeline,
    table: &ShaderBindingTable,
    handle: TraversableHandle,
    rays: &[Ray],
    args: TraceArgs,
) -> Vec<Rec> {
    let ray_words: Vec<[f32; 4]> = rays
        .iter()
        .flat_map(|r| {
            [
                [r.origin[0], r.origin[1], r.origin[2], r.tmin],
                [r.direction[0], r.direction[1], r.direction[2], r.tmax],
            ]
        })
        .collect();
    let ray_buffer = buffer(dev, &ray_words);
    let out = dev.create_buffer((rays.len() * 32) as u64).unwrap();
    let mut words = handle.to_words().to_vec();
    words.extend_from_slice(&[
        args.flags,
        args.sbt_offset,
        args.sbt_stride,
        args.miss_index,
        args.mask,
        args.time.to_bits(),
    ]);
    dev.launch(
        pipeline,
        bytemuck::cast_slice(&words),
        &[Resource::buffer(1, out), Resource::buffer(2, ray_buffer)],
        table,
        LaunchSize::new(rays.len() as u32, 1, 1),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    read::<u32>(dev, out)
        .chunks_exact(8)
        .map(|c| Rec {
            words: c.try_into().unwrap(),
        })
        .collect()
}

/// Groups for [`RAY_LIST`] with one miss group and `hits` closest-hit groups, plus `extra`.
pub fn ray_list_groups(
    dev: &dyn Device,
    m: Module,
    hits: usize,
    extra: &[ProgramGroupDesc],
) -> Groups {
    let mut descs = vec![raygen(m, "raygen__rays"), miss(m, "miss__rec")];
    for _ in 0..hits {
        descs.push(closest_hit(m, "closesthit__rec"));
    }
    descs.extend_from_slice(extra);
    groups(dev, &descs)
}

/// An SBT whose records carry their index in the first data word (miss records 100 + i).
pub fn numbered_sbt(dev: &dyn Device, g: &Groups) -> ShaderBindingTable {
    sbt_with(dev, g, |region, i| match region {
        GroupRegion::Raygen => Vec::new(),
        GroupRegion::Miss => vec![100 + i as u32],
        GroupRegion::HitGroup => vec![i as u32],
        GroupRegion::Callables => vec![200 + i as u32],
        GroupRegion::Exception => vec![300],
    })
}

/// An instance structure holding one instance of `child` placed by `transform` (3×4 rows).
pub fn one_instance(
    dev: &dyn Device,
    child: TraversableHandle,
    transform: [f32; 12],
) -> TraversableHandle {
    let inst = Instance {
        transform,
        ..Instance::new(child)
    };
    let ib = buffer(dev, &[inst]);
    let ias = dev
        .accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::Instances(InstanceArray {
                instances: BufferView::new(ib),
                num_instances: 1,
            })],
        )
        .unwrap_or_else(|e| panic!("{e}"));
    dev.traversable_handle(ias)
        .unwrap_or_else(|e| panic!("{e}"))
}
