//! ex08 (the course's `example08_addingTextures`): shading normals, texture coordinates and
//! textures. Each hit record says whether its mesh has normals and texture coordinates and
//! which texture slot holds its `map_Kd`; textures are optik textures sampled bilinearly with
//! wrap-around. As in the course, texels are used as stored (no sRGB decoding).

use crate::common::{CameraParams, Image, Options, Result, build_sbt, download_image, upload};
use crate::ex04_first_mesh::Params;
use crate::meshes::{surface_data, texture_resources, upload_meshes};
use crate::scenes::load_model;
use optik::{
    Device, LaunchSize, ModuleCompileOptions, PipelineCompileOptions, PipelineLinkOptions,
    ProgramGroupDesc, ProgramRef, ProgramSource, Resource, Setting, TraversableGraph,
};

/// The programs: the step's own, then the shared surface code.
pub const WGSL: &str = concat!(
    include_str!("ex08_textures.wgsl"),
    include_str!("surface.wgsl")
);

/// Renders the model with its textures.
pub fn run(device: &dyn Device, opts: &Options) -> Result<Image> {
    let model = load_model(opts.model.as_deref())?;
    let device_meshes = upload_meshes(device, &model.meshes)?;
    let textures = texture_resources(device, &model.textures)?;

    let options = PipelineCompileOptions {
        traversable_graph: Setting::Value(TraversableGraph::SingleGas),
        num_payload_values: Setting::Value(3),
        num_attribute_values: Setting::Value(2),
        uses_motion_blur: Setting::Value(false),
        ..Default::default()
    };
    let (module, _log) = device.create_module(
        &ModuleCompileOptions::default(),
        &options,
        &ProgramSource::new("ex08_textures.wgsl", WGSL),
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
    let hit_records = surface_data(&model.meshes, &device_meshes)
        .into_iter()
        .map(|data| (groups[2], data))
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
    let mut resources = vec![Resource::buffer(1, image)];
    resources.extend(device_meshes.resources(2));
    resources.extend(textures);
    device.launch(
        pipeline,
        bytemuck::bytes_of(&params),
        &resources,
        &sbt.table,
        LaunchSize::new(w, h, 1),
    )?;
    download_image(device, image, w, h)
}
