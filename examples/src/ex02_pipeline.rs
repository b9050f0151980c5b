//! ex02 (the course's `example02_pipelineAndRayGen`): a module, program groups, a pipeline, a
//! shader binding table and a launch. Nothing is traced yet: the raygen program writes a test
//! pattern. This is "the biggest step" of the course; every later step only adds to it.

use crate::common::{Image, Options, Result, build_sbt, download_image, upload};
use optik::{
    Device, LaunchSize, ModuleCompileOptions, PipelineCompileOptions, PipelineLinkOptions,
    ProgramGroupDesc, ProgramRef, ProgramSource, Resource, Setting, TraversableGraph,
};

/// The programs: raygen, and the empty closest-hit, any-hit and miss programs.
pub const WGSL: &str = include_str!("ex02_pipeline.wgsl");

/// The launch parameters, laid out as WGSL's `Params` uniform.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    frame_id: u32,
    width: u32,
    height: u32,
    pad: u32,
}

/// Renders the test pattern.
pub fn run(device: &dyn Device, opts: &Options) -> Result<Image> {
    // 1. The module: one WGSL source holding every program (OptiX `optixModuleCreate`). The
    //    pipeline options are shared by every module of a pipeline: nothing is traced here, so
    //    the settings the course gives are enough (a single GAS, two payload registers).
    let pipeline_options = PipelineCompileOptions {
        traversable_graph: Setting::Value(TraversableGraph::SingleGas),
        num_payload_values: Setting::Value(2),
        num_attribute_values: Setting::Value(2),
        uses_motion_blur: Setting::Value(false),
        ..Default::default()
    };
    let (module, _log) = device.create_module(
        &ModuleCompileOptions::default(),
        &pipeline_options,
        &ProgramSource::new("ex02_pipeline.wgsl", WGSL),
    )?;
    // The log says what was compiled (and whether from optik's disk cache).

    // 2. Program groups: one per SBT record kind. The hit group pairs closest-hit and any-hit.
    let groups = device.create_program_groups(&[
        ProgramGroupDesc::Raygen(ProgramRef::new(module, "raygen__render_frame")),
        ProgramGroupDesc::Miss(Some(ProgramRef::new(module, "miss__radiance"))),
        ProgramGroupDesc::HitGroup {
            closest_hit: Some(ProgramRef::new(module, "closesthit__radiance")),
            any_hit: Some(ProgramRef::new(module, "anyhit__radiance")),
            intersection: None,
            builtin: optik::BuiltinIntersector::Triangle,
        },
    ])?;
    let (raygen, miss, hitgroup) = (groups[0], groups[1], groups[2]);

    // 3. The pipeline links the groups; the course's max trace depth is 2.
    let link = PipelineLinkOptions {
        max_trace_depth: 2,
        ..Default::default()
    };
    let pipeline = device.create_pipeline(&pipeline_options, &link, &groups)?;

    // 4. The shader binding table: each record is the 32-byte header optik packs for its
    //    group, followed by the program's data (none yet).
    let sbt = build_sbt(
        device,
        (raygen, vec![]),
        vec![(miss, vec![])],
        vec![(hitgroup, vec![])],
    )?;

    // 5. Launch: the parameters are the bytes of the `params` uniform; the output buffer is
    //    binding 1. One invocation per pixel.
    let (w, h) = (opts.width, opts.height);
    let image = upload(device, &vec![[0.0f32; 4]; (w * h) as usize])?;
    let params = Params {
        frame_id: 0,
        width: w,
        height: h,
        pad: 0,
    };
    device.launch(
        pipeline,
        bytemuck::bytes_of(&params),
        &[Resource::buffer(1, image)],
        &sbt.table,
        LaunchSize::new(w, h, 1),
    )?;
    // Reading waits for the launch (launches are asynchronous, as in OptiX).
    download_image(device, image, w, h)
}
