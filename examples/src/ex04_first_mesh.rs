//! ex04 (the course's `example04_firstTriangleMesh`): a triangle mesh in a geometry
//! acceleration structure, a pinhole camera, and rays traced against it. Every triangle gets
//! its own colour (`random_color(primitive index)`); the background is white.

use crate::common::{CameraParams, Image, Options, Result, build_sbt, download_image, upload};
use crate::scenes::{TWO_BOXES_CAMERA, TriangleMesh, two_boxes};
use optik::{
    AccelBuildOptions, BufferView, BuildFlags, BuildInput, Device, GeometryFlags, LaunchSize,
    ModuleCompileOptions, PipelineCompileOptions, PipelineLinkOptions, ProgramGroupDesc,
    ProgramRef, ProgramSource, Resource, Setting, TraversableGraph, TriangleArray,
};

/// The programs.
pub const WGSL: &str = include_str!("ex04_first_mesh.wgsl");

/// The launch parameters (WGSL `Params`): the scene's traversable handle, the image size and
/// the camera.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Params {
    /// The traversable handle, low word first (WGSL `vec2<u32>`).
    pub scene: [u32; 2],
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// The camera.
    pub camera: CameraParams,
}

/// Renders the two boxes, merged into one mesh.
pub fn run(device: &dyn Device, opts: &Options) -> Result<Image> {
    // 1. The geometry: the floor and the cube in one mesh, uploaded to device buffers.
    let (floor, cube) = two_boxes();
    let mut mesh = TriangleMesh::default();
    for part in [&floor, &cube] {
        let first = mesh.positions.len() as u32;
        mesh.positions.extend_from_slice(&part.positions);
        mesh.indices
            .extend(part.indices.iter().map(|t| t.map(|i| i + first)));
    }
    let vertices = upload(device, &mesh.positions)?;
    let indices = upload(device, &mesh.indices)?;

    // 2. The geometry acceleration structure (OptiX `optixAccelBuild`): one triangle build
    //    input with one SBT record. Compaction is what the course does after every build.
    let input = BuildInput::Triangles(
        TriangleArray::new(
            BufferView::new(vertices),
            mesh.positions.len() as u32,
            GeometryFlags::NONE,
        )
        .with_indices(BufferView::new(indices), mesh.indices.len() as u32),
    );
    let build = AccelBuildOptions {
        flags: BuildFlags::ALLOW_COMPACTION,
        ..Default::default()
    };
    let gas = device.accel_build(&build, &[input])?;
    let gas = device.accel_compact(gas)?;
    let scene = device.traversable_handle(gas)?;

    // 3. Module, program groups and pipeline, as in ex02; three payload registers carry the
    //    colour.
    let pipeline_options = PipelineCompileOptions {
        traversable_graph: Setting::Value(TraversableGraph::SingleGas),
        num_payload_values: Setting::Value(3),
        num_attribute_values: Setting::Value(2),
        uses_motion_blur: Setting::Value(false),
        ..Default::default()
    };
    let (module, _log) = device.create_module(
        &ModuleCompileOptions::default(),
        &pipeline_options,
        &ProgramSource::new("ex04_first_mesh.wgsl", WGSL),
    )?;
    let groups = device.create_program_groups(&[
        ProgramGroupDesc::Raygen(ProgramRef::new(module, "raygen__render_frame")),
        ProgramGroupDesc::Miss(Some(ProgramRef::new(module, "miss__radiance"))),
        ProgramGroupDesc::closest_hit(ProgramRef::new(module, "closesthit__radiance")),
    ])?;
    let link = PipelineLinkOptions {
        max_trace_depth: 2,
        ..Default::default()
    };
    let pipeline = device.create_pipeline(&pipeline_options, &link, &groups)?;
    let sbt = build_sbt(
        device,
        (groups[0], vec![]),
        vec![(groups[1], vec![])],
        vec![(groups[2], vec![])],
    )?;

    // 4. Launch with the camera and the scene's handle in the parameters.
    let (w, h) = (opts.width, opts.height);
    let (from, at, up) = TWO_BOXES_CAMERA;
    let params = Params {
        scene: scene.to_words(),
        width: w,
        height: h,
        camera: CameraParams::look_at(from, at, up, w, h),
    };
    let image = upload(device, &vec![[0.0f32; 4]; (w * h) as usize])?;
    device.launch(
        pipeline,
        bytemuck::bytes_of(&params),
        &[Resource::buffer(1, image)],
        &sbt.table,
        LaunchSize::new(w, h, 1),
    )?;
    download_image(device, image, w, h)
}
