//! ex05 (the course's `example05_firstSBTData`): data in the shader binding table. The hit
//! group record now holds the mesh's colour and where its vertices and triangles live; the
//! closest-hit program reads them and shades by `0.2 + 0.8·|ray · normal|`.

use crate::common::{CameraParams, Image, Options, Result, build_sbt, download_image, upload};
use crate::ex04_first_mesh::Params;
use crate::meshes::upload_meshes;
use crate::scenes::{TWO_BOXES_CAMERA, TriangleMesh, two_boxes};
use optik::{
    Device, LaunchSize, ModuleCompileOptions, PipelineCompileOptions, PipelineLinkOptions,
    ProgramGroupDesc, ProgramRef, ProgramSource, Resource, Setting, TraversableGraph,
};

/// The programs (ex06 uses them too).
pub const WGSL: &str = include_str!("ex05_sbt_data.wgsl");

/// The pipeline options of ex05 and ex06: three payload registers for the colour.
pub fn pipeline_options() -> PipelineCompileOptions {
    PipelineCompileOptions {
        traversable_graph: Setting::Value(TraversableGraph::SingleGas),
        num_payload_values: Setting::Value(3),
        num_attribute_values: Setting::Value(2),
        uses_motion_blur: Setting::Value(false),
        ..Default::default()
    }
}

/// Renders the two boxes as one green mesh.
pub fn run(device: &dyn Device, opts: &Options) -> Result<Image> {
    let (floor, cube) = two_boxes();
    let mut mesh = TriangleMesh {
        diffuse: [0.2, 0.8, 0.2],
        ..Default::default()
    };
    for part in [&floor, &cube] {
        let first = mesh.positions.len() as u32;
        mesh.positions.extend_from_slice(&part.positions);
        mesh.indices
            .extend(part.indices.iter().map(|t| t.map(|i| i + first)));
    }
    // Positions and triangles go to storage buffers the closest-hit program reads; the same
    // buffers feed the acceleration structure build.
    let meshes = upload_meshes(device, std::slice::from_ref(&mesh))?;

    let options = pipeline_options();
    let (module, _log) = device.create_module(
        &ModuleCompileOptions::default(),
        &options,
        &ProgramSource::new("ex05_sbt_data.wgsl", WGSL),
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
    let pipeline = device.create_pipeline(&options, &link, &groups)?;

    // The hit record's data, in the order of the WGSL's SBT_* constants: colour (3 × f32),
    // first vertex and first triangle (u32).
    let o = meshes.offsets[0];
    let [r, g, b] = mesh.diffuse.map(f32::to_bits);
    let hit_data = vec![r, g, b, o.first_vertex, o.first_triangle];
    let sbt = build_sbt(
        device,
        (groups[0], vec![]),
        vec![(groups[1], vec![])],
        vec![(groups[2], hit_data)],
    )?;

    let (w, h) = (opts.width, opts.height);
    let (from, at, up) = TWO_BOXES_CAMERA;
    let params = Params {
        scene: meshes.handle.to_words(),
        width: w,
        height: h,
        camera: CameraParams::look_at(from, at, up, w, h),
    };
    let image = upload(device, &vec![[0.0f32; 4]; (w * h) as usize])?;
    let [positions, indices, ..] = meshes.resources(2);
    device.launch(
        pipeline,
        bytemuck::bytes_of(&params),
        &[Resource::buffer(1, image), positions, indices],
        &sbt.table,
        LaunchSize::new(w, h, 1),
    )?;
    download_image(device, image, w, h)
}
