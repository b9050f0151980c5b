//! ex07 (the course's `example07_firstRealModel`): an OBJ model, one mesh per (shape,
//! material) as the course's tinyobjloader code splits it, each mesh coloured by
//! `random_color(material id)` (the course reads the MTL colour and then overwrites it the
//! same way). The programs are ex05's; the camera frames the model's bounds.
//!
//! The course renders Crytek Sponza, which cannot be shipped here: without `--obj` the step
//! renders a Cornell box generated in code ([`crate::scenes::CORNELL_OBJ`]); with
//! `--obj PATH` any OBJ+MTL (for example `CornellBox-Original.obj` of McGuire's archive).

use crate::common::{
    CameraParams, Image, Options, Result, build_sbt, download_image, random_color, upload,
};
use crate::ex04_first_mesh::Params;
use crate::ex05_sbt_data::{WGSL, pipeline_options};
use crate::meshes::upload_meshes;
use crate::scenes::load_model;
use optik::{
    Device, LaunchSize, ModuleCompileOptions, PipelineLinkOptions, ProgramGroupDesc, ProgramRef,
    ProgramSource, Resource,
};

/// Renders the model with one colour per material.
pub fn run(device: &dyn Device, opts: &Options) -> Result<Image> {
    let model = load_model(opts.model.as_deref())?;
    let device_meshes = upload_meshes(device, &model.meshes)?;

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
    let hit_records = model
        .meshes
        .iter()
        .zip(&device_meshes.offsets)
        .map(|(m, o)| {
            let [r, g, b] = random_color(m.material_id).map(f32::to_bits);
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
    let (from, at, up) = model.framing().camera;
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
