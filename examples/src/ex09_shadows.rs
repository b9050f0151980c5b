//! ex09 (the course's `example09_shadowRays`): hard shadows from a point light, through a
//! second ray type. The hit group records are laid out mesh-major, record = mesh × 2 + ray
//! type, and there are two miss records (radiance, shadow).

use crate::common::{CameraParams, Image, Options, Result, build_sbt, download_image, upload};
use crate::meshes::{surface_data, texture_resources, upload_meshes};
use crate::scenes::load_model;
use optik::{
    Device, LaunchSize, ModuleCompileOptions, PipelineCompileOptions, PipelineLinkOptions,
    ProgramGroupDesc, ProgramRef, ProgramSource, Resource, Setting, TraversableGraph,
};

/// The programs: the step's own, then the shared surface code.
pub const WGSL: &str = concat!(
    include_str!("ex09_shadows.wgsl"),
    include_str!("surface.wgsl")
);

/// The launch parameters (WGSL `Params`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    scene: [u32; 2],
    width: u32,
    height: u32,
    camera: CameraParams,
    light_position: [f32; 4],
}

/// Renders the model lit by a point light, with hard shadows.
pub fn run(device: &dyn Device, opts: &Options) -> Result<Image> {
    let model = load_model(opts.model.as_deref())?;
    let framing = model.framing();
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
        &ProgramSource::new("ex09_shadows.wgsl", WGSL),
    )?;
    let groups = device.create_program_groups(&[
        ProgramGroupDesc::Raygen(ProgramRef::new(module, "raygen__render_frame")),
        ProgramGroupDesc::Miss(Some(ProgramRef::new(module, "miss__radiance"))),
        ProgramGroupDesc::Miss(Some(ProgramRef::new(module, "miss__shadow"))),
        ProgramGroupDesc::closest_hit(ProgramRef::new(module, "closesthit__radiance")),
        ProgramGroupDesc::closest_hit(ProgramRef::new(module, "closesthit__shadow")),
    ])?;
    let [raygen, miss_radiance, miss_shadow, hit_radiance, hit_shadow] = groups[..] else {
        return Err("optik returned the wrong number of program groups".into());
    };
    // Depth 2: raygen traces radiance rays, whose closest-hit traces shadow rays.
    let link = PipelineLinkOptions {
        max_trace_depth: 2,
        ..Default::default()
    };
    let pipeline = device.create_pipeline(&options, &link, &groups)?;
    let hit_records = surface_data(&model.meshes, &device_meshes)
        .into_iter()
        .flat_map(|data| [(hit_radiance, data.clone()), (hit_shadow, data)])
        .collect();
    let sbt = build_sbt(
        device,
        (raygen, vec![]),
        vec![(miss_radiance, vec![]), (miss_shadow, vec![])],
        hit_records,
    )?;

    let (w, h) = (opts.width, opts.height);
    let (from, at, up) = framing.camera;
    let [lx, ly, lz] = framing.point_light;
    let params = Params {
        scene: device_meshes.handle.to_words(),
        width: w,
        height: h,
        camera: CameraParams::look_at(from, at, up, w, h),
        light_position: [lx, ly, lz, 1.0],
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
