//! ex10 (the course's `example10_softShadows`): an area light. Shadow rays go to random points
//! on a quad light, with the course's LCG seeded per pixel and frame; each launch traces 16
//! jittered camera rays per pixel with one light sample each. The random state travels in the
//! payload with the colour.
//!
//! [`SoftShadows`] sets the step up once so that ex11 (more frames) and ex12 (more outputs)
//! can launch it again.

use crate::common::{
    CameraParams, Image, Options, Result, SbtLayout, build_sbt, download_image, upload,
};
use crate::meshes::{surface_data, texture_resources, upload_meshes};
use crate::scenes::load_model;
use optik::{
    Buffer, Device, LaunchSize, ModuleCompileOptions, Pipeline, PipelineCompileOptions,
    PipelineLinkOptions, ProgramGroupDesc, ProgramRef, ProgramSource, Resource, Setting,
    TraversableGraph,
};

/// The programs: the step's own, then the shared surface code.
pub const WGSL: &str = concat!(
    include_str!("ex10_soft_shadows.wgsl"),
    include_str!("surface.wgsl")
);

/// The course's quad light: a corner, two edges and a power.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct QuadLight {
    origin: [f32; 4],
    du: [f32; 4],
    dv: [f32; 4],
    power: [f32; 4],
}

/// The launch parameters (WGSL `Params`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    scene: [u32; 2],
    width: u32,
    height: u32,
    camera: CameraParams,
    light: QuadLight,
    frame_id: u32,
    pixel_samples: u32,
    light_samples: u32,
    pad: u32,
}

/// The step set up: the scene, pipeline, SBT and output buffers, ready to launch frames.
pub struct SoftShadows {
    pipeline: Pipeline,
    sbt: SbtLayout,
    resources: Vec<Resource>,
    params: Params,
    /// The accumulated colour (`vec4<f32>` per pixel).
    pub image: Buffer,
}

impl SoftShadows {
    /// Loads the model and builds the pipeline of `wgsl` (whose programs are this step's, with
    /// `num_payload_values` registers); `outputs` are more buffers bound from binding 11 up.
    pub fn new(
        device: &dyn Device,
        opts: &Options,
        (file_name, wgsl): (&str, &str),
        num_payload_values: u32,
        outputs: &[Buffer],
    ) -> Result<SoftShadows> {
        let model = load_model(opts.model.as_deref())?;
        let framing = model.framing();
        let device_meshes = upload_meshes(device, &model.meshes)?;
        let textures = texture_resources(device, &model.textures)?;
        let options = PipelineCompileOptions {
            traversable_graph: Setting::Value(TraversableGraph::SingleGas),
            num_payload_values: Setting::Value(num_payload_values),
            num_attribute_values: Setting::Value(2),
            uses_motion_blur: Setting::Value(false),
            ..Default::default()
        };
        let (module, _log) = device.create_module(
            &ModuleCompileOptions::default(),
            &options,
            &ProgramSource::new(file_name, wgsl),
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
        let (corner, du, dv) = framing.quad_light;
        let v4 = |v: [f32; 3]| [v[0], v[1], v[2], 0.0];
        let params = Params {
            scene: device_meshes.handle.to_words(),
            width: w,
            height: h,
            camera: CameraParams::look_at(from, at, up, w, h),
            light: QuadLight {
                origin: v4(corner),
                du: v4(du),
                dv: v4(dv),
                power: v4(framing.light_power),
            },
            frame_id: 0,
            pixel_samples: 1,
            light_samples: 1,
            pad: 0,
        };
        let image = upload(device, &vec![[0.0f32; 4]; (w * h) as usize])?;
        let mut resources = vec![Resource::buffer(1, image)];
        resources.extend(device_meshes.resources(2));
        resources.extend(textures);
        resources.extend(
            outputs
                .iter()
                .enumerate()
                .map(|(i, b)| Resource::buffer(11 + i as u32, *b)),
        );
        Ok(SoftShadows {
            pipeline,
            sbt,
            resources,
            params,
            image,
        })
    }

    /// Launches frame `frame_id` (0 restarts the running mean) with `pixel_samples` camera
    /// rays per pixel and `light_samples` shadow rays per hit.
    pub fn launch(
        &mut self,
        device: &dyn Device,
        frame_id: u32,
        pixel_samples: u32,
        light_samples: u32,
    ) -> Result<()> {
        self.params.frame_id = frame_id;
        self.params.pixel_samples = pixel_samples;
        self.params.light_samples = light_samples;
        device.launch(
            self.pipeline,
            bytemuck::bytes_of(&self.params),
            &self.resources,
            &self.sbt.table,
            LaunchSize::new(self.params.width, self.params.height, 1),
        )?;
        Ok(())
    }
}

/// Renders one frame of 16 samples per pixel, one light sample each (the course's
/// `NUM_PIXEL_SAMPLES` and `NUM_LIGHT_SAMPLES`).
pub fn run(device: &dyn Device, opts: &Options) -> Result<Image> {
    let mut step = SoftShadows::new(device, opts, ("ex10_soft_shadows.wgsl", WGSL), 4, &[])?;
    step.launch(device, 0, 16, 1)?;
    download_image(device, step.image, opts.width, opts.height)
}
