//! ex06 (the course's `example06_multipleObjects`): several meshes in one acceleration
//! structure. Each mesh is its own build input with one SBT record, so mesh *i* hits hit group
//! record *i* (`rt_sbt_gas_index()` = *i*), whose data holds that mesh's colour and offsets.
//! The programs are ex05's, unchanged.

use crate::common::{CameraParams, Image, Options, Result, build_sbt, download_image, upload};
use crate::ex04_first_mesh::Params;
use crate::ex05_sbt_data::{WGSL, pipeline_options};
use crate::meshes::upload_meshes;
use crate::scenes::{TWO_BOXES_CAMERA, two_boxes};
use optik::{
    Device, LaunchSize, ModuleCompileOptions, PipelineLinkOptions, ProgramGroupDesc, ProgramRef,
    ProgramSource, Resource,
};

/// Renders the green floor and the cyan cube as two meshes.
pub fn run(device: &dyn Device, opts: &Options) -> Result<Image> {
    let (floor, cube) = two_boxes();
    let meshes = [floor, cube];
    let device_meshes = upload_meshes(device, &meshes)?;

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

    // One hit record per mesh, all with the same program group and each with its own data.
    let hit_records = meshes
        .iter()
        .zip(&device_meshes.offsets)
        .map(|(m, o)| {
            let [r, g, b] = m.diffuse.map(f32::to_bits);
            (groups[2], vec![r, g, b, o.first_vertex, o.first_triangle])
        })
        .collect();
    let sbt = build_sbt(
        device,
        (groups[0], vec![]),
        vec![(groups[1], vec![])],
        hit_records,
    )?;

    let (w, h) = (opts.width, opts.height);
    let (from, at, up) = TWO_BOXES_CAMERA;
    let params = Params {
        scene: device_meshes.handle.to_words(),
        width: w,
        height: h,
        camera: CameraParams::look_at(from, at, up, w, h),
    };
    let image = upload(device, &vec![[0.0f32; 4]; (w * h) as usize])?;
    let [positions, indices, ..] = device_meshes.resources(2);
    device.launch(
        pipeline,
        bytemuck::bytes_of(&params),
        &[Resource::buffer(1, image), positions, indices],
        &sbt.table,
        LaunchSize::new(w, h, 1),
    )?;
    download_image(device, image, w, h)
}
