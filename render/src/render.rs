//! The path tracer: scene upload, pipeline from the scene's features, progressive launches,
//! and the frame with per-pixel mean and variance.

use crate::camera::half_fov_tangents;
use crate::error::{Context, RenderError};
use crate::features::RenderFeatures;
use crate::geometry::{Geometry, HitGroupKey, Primitive, RECORD_DATA_WORDS, SPHERE_WORDS, Tables};
use crate::gpu::{Owned, Std140};
use crate::plan::{Effects, PipelinePlan};
use crate::programs;
use crate::scene::{Aov, AovKind, Filter, Integrator, PathSettings, Scene};
use glam::Vec3;
use optik::{
    AccelBuildOptions, Buffer, BufferView, BuildFlags, BuildInput, BuiltinIntersector, Device,
    FeatureSet, GeometryFlags, InstanceArray, LaunchSize, ModuleCompileOptions, Pipeline,
    PipelineLinkOptions, ProgramGroupDesc, ProgramRef, ProgramSource, Resource, SbtRecord,
    SbtRegion, ShaderBindingTable, SphereArray, TraversableHandle, TriangleArray,
};
use std::time::Instant;

/// How to render.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RenderOptions {
    /// Samples per pixel; `None` uses the scene's sampler.
    pub spp: Option<u32>,
    /// Seed of the per-pixel random numbers; `None` uses the scene's sampler.
    pub seed: Option<u32>,
    /// Whether [`Frame::variance`] is filled.
    pub want_variance: bool,
    /// Whether the first hit's albedo and shading normal are kept (the denoiser's guides).
    pub want_aovs: bool,
    /// Most path samples in one launch (`None`: about 256 K); results do not depend on it.
    pub samples_per_launch: Option<u32>,
}

/// Progress reported after every launch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    /// Samples per pixel done.
    pub done: u32,
    /// Samples per pixel in all.
    pub total: u32,
}

/// An extra image layer (an AOV), `channels.len()` floats per pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct AovImage {
    /// The layer name (`albedo`, `normal`).
    pub name: String,
    /// Channel names (`R`, `G`, `B` or `X`, `Y`, `Z`).
    pub channels: Vec<String>,
    /// Row-major values, row 0 at the top.
    pub data: Vec<f32>,
}

/// What a render measured.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Seconds spent in launches (upload and compilation excluded).
    pub render_seconds: f64,
    /// Seconds spent building the scene and compiling the pipeline.
    pub setup_seconds: f64,
    /// Rays traced (radiance and shadow).
    pub rays: f64,
    /// The scene's features.
    pub features: RenderFeatures,
    /// The programs compiled into the pipeline.
    pub programs: Vec<String>,
}

/// A rendered image: the per-pixel mean and, on request, the per-sample variance.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Linear RGB mean per pixel, row 0 at the top.
    pub mean: Vec<[f32; 3]>,
    /// The unbiased sample variance of one sample's radiance per pixel and channel (divide by
    /// `spp` for the variance of the mean); `None` unless asked for or with one sample.
    pub variance: Option<Vec<[f32; 3]>>,
    /// Extra layers (the first hit's albedo and normal when asked for).
    pub aovs: Vec<AovImage>,
    /// Timings and counts.
    pub stats: RenderStats,
}

/// Renders `scene` on `device`.
pub fn render(
    device: &dyn Device,
    scene: &Scene,
    options: &RenderOptions,
) -> Result<Frame, RenderError> {
    render_with_progress(device, scene, options, &mut |_| {})
}

/// Floats per pixel of the accumulation buffer (path.wgsl's ACC_* layout).
const ACCUM_WORDS: u32 = 7;
const ACCUM_WORDS_AOVS: u32 = 13;
const RECORD_STRIDE: u32 = (32 + RECORD_DATA_WORDS as u32 * 4).div_ceil(16) * 16;
/// Renders `scene`, calling `progress` after every launch.
pub fn render_with_progress(
    device: &dyn Device,
    scene: &Scene,
    options: &RenderOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Frame, RenderError> {
    let mut renderer = Renderer::new(device, scene, options, Effects::Scene)?;
    renderer.accumulate(renderer.spp(), progress)?;
    renderer.frame()
}

/// The parameter block of one launch: (first sample index, samples per pixel) to bytes.
type ParamsFn<'a> = Box<dyn Fn(u32, u32) -> Vec<u8> + 'a>;

/// A scene set up on a device (geometry uploaded, pipeline compiled, SBT written), ready to
/// accumulate samples. The benchmark and convergence modes use it to time launches without
/// setup, to read the image at several sample counts of one progressive render, and to
/// restart; [`render`] is `new`, `accumulate` and `frame`.
pub struct Renderer<'a> {
    device: &'a dyn Device,
    /// Holds the device objects until the renderer drops.
    _owned: Owned<'a>,
    pipeline: Pipeline,
    sbt: ShaderBindingTable,
    resources: Vec<Resource>,
    params: ParamsFn<'a>,
    accum: Buffer,
    stride: u32,
    width: u32,
    height: u32,
    spp: u32,
    per_launch: u32,
    want_variance: bool,
    want_aovs: bool,
    /// The aov integrator's outputs (`None`: another integrator).
    aov_outputs: Option<Vec<Aov>>,
    plan: PipelinePlan,
    done: u32,
    render_seconds: f64,
    setup_seconds: f64,
}

impl<'a> Renderer<'a> {
    /// Uploads `scene` to `device` and compiles the pipeline of `effects` for it.
    pub fn new(
        device: &'a dyn Device,
        scene: &'a Scene,
        options: &RenderOptions,
        effects: Effects,
    ) -> Result<Renderer<'a>, RenderError> {
        let setup_start = Instant::now();
        let (width, height) = (scene.film.width, scene.film.height);
        if width == 0 || height == 0 {
            return Err(RenderError::Invalid(format!(
                "film size {width}x{height}: expected at least 1x1"
            )));
        }
        let pixels = width as u64 * height as u64;
        let spp = options.spp.unwrap_or(scene.sampler.sample_count);
        if spp == 0 {
            return Err(RenderError::Invalid(
                "0 samples per pixel: expected at least 1".into(),
            ));
        }
        let seed = options.seed.unwrap_or(scene.sampler.seed);
        // The integrator: its id in Params, settings of the path loop, and the direct
        // integrator's strategy weights (fraction of light samples, of BSDF samples, and the
        // weight of one light sample); the path integrator's are all 1.
        let mut mis = [1.0f32, 1.0, 1.0];
        let mut samples = [1u32, 1];
        let (integrator_id, settings) = match &scene.integrator {
            Integrator::Path(p) => (0u32, *p),
            Integrator::Direct(d) => {
                let (ne, nb) = (d.emitter_samples, d.bsdf_samples);
                if ne == 0 && nb == 0 {
                    return Err(RenderError::Invalid(
                        "the direct integrator with emitter_samples = 0 and bsdf_samples = 0: expected at least one sample of either".into(),
                    ));
                }
                let total = (ne + nb) as f32;
                mis = [
                    ne as f32 / total,
                    nb as f32 / total,
                    if ne > 0 { 1.0 / ne as f32 } else { 0.0 },
                ];
                samples = [ne, nb];
                let s = PathSettings {
                    max_depth: Some(2),
                    rr_depth: u32::MAX,
                    hide_emitters: d.hide_emitters,
                };
                (1, s)
            }
            Integrator::Aov(list) => {
                if list.is_empty() {
                    return Err(RenderError::Invalid(
                        "the aov integrator without outputs: expected aovs such as \"albedo:albedo,nn:sh_normal,dd:depth\"".into(),
                    ));
                }
                let s = PathSettings {
                    max_depth: Some(1),
                    rr_depth: u32::MAX,
                    hide_emitters: false,
                };
                (2, s)
            }
        };
        let aov_outputs = match &scene.integrator {
            Integrator::Aov(list) => Some(list.clone()),
            _ => None,
        };
        let want_aovs = options.want_aovs || aov_outputs.is_some();
        let plan = PipelinePlan::new(scene, want_aovs, effects);
        let features = &plan.features;
        let built = Tables::build(scene)?;
        let mut owned = Owned::new(device);

        // Geometry: one GAS per primitive type and shape group, one build input (and SBT record)
        // per shape; an IAS over them when there are spheres or instances.
        let positions = owned.upload(bytemuck::cast_slice(&built.positions), "vertex positions")?;
        let normals = owned.upload(bytemuck::cast_slice(&built.normals), "vertex normals")?;
        let uvs = owned.upload(bytemuck::cast_slice(&built.uvs), "texture coordinates")?;
        let indices = owned.upload(bytemuck::cast_slice(&built.indices), "triangle indices")?;
        let lights = owned.upload(bytemuck::cast_slice(&built.lights), "the light table")?;
        let spheres = owned.upload(bytemuck::cast_slice(&built.spheres), "the sphere table")?;
        let texels = owned.upload(bytemuck::cast_slice(&built.texels), "the texel table")?;
        let build_options = AccelBuildOptions {
            flags: BuildFlags::PREFER_FAST_TRACE,
            ..Default::default()
        };
        let mut gas_handles = Vec::with_capacity(built.gases.len());
        for gas in &built.gases {
            let records = &built.records[gas.first as usize..(gas.first + gas.count) as usize];
            let inputs: Vec<BuildInput> = records
                .iter()
                .map(|r| {
                    let flags = if r.group.masked {
                        GeometryFlags::NONE
                    } else {
                        GeometryFlags::DISABLE_ANYHIT
                    };
                    match r.geometry {
                        Geometry::Triangles {
                            vertex_base,
                            vertex_count,
                            triangle_base,
                            triangle_count,
                        } => BuildInput::Triangles(
                            TriangleArray::new(
                                BufferView::at(positions, vertex_base as u64 * 12),
                                vertex_count,
                                flags,
                            )
                            .with_indices(
                                BufferView::at(indices, triangle_base as u64 * 12),
                                triangle_count,
                            ),
                        ),
                        Geometry::Sphere(i) => {
                            let at = i as u64 * SPHERE_WORDS as u64 * 4;
                            BuildInput::Spheres(SphereArray {
                                vertex_buffers: vec![BufferView::at(spheres, at)],
                                vertex_stride: 0,
                                num_vertices: 1,
                                radius_buffers: vec![BufferView::at(spheres, at + 12)],
                                radius_stride: 0,
                                single_radius: true,
                                flags: vec![flags],
                                sbt_index_offsets: None,
                                primitive_index_offset: 0,
                            })
                        }
                    }
                })
                .collect();
            let accel = device
                .accel_build(&build_options, &inputs)
                .during("building a GAS")?;
            owned.accel(accel);
            gas_handles.push(
                device
                    .traversable_handle(accel)
                    .during("getting a GAS handle")?,
            );
        }
        let handle = if built.gases.is_empty() {
            TraversableHandle::NULL
        } else if !built.uses_ias() {
            gas_handles[0]
        } else {
            let records: Vec<optik::Instance> = built
                .instances
                .iter()
                .enumerate()
                .map(|(i, (gas, m))| {
                    let mut inst = optik::Instance::new(gas_handles[*gas as usize]);
                    for r in 0..3 {
                        inst.transform[4 * r..4 * r + 4].copy_from_slice(&m.row(r).to_array());
                    }
                    inst.instance_id = i as u32;
                    inst.sbt_offset = built.gases[*gas as usize].first;
                    inst
                })
                .collect();
            let buffer = owned.upload(bytemuck::cast_slice(&records), "the instances")?;
            let accel = device
                .accel_build(
                    &build_options,
                    &[BuildInput::Instances(InstanceArray {
                        instances: BufferView::at(buffer, 0),
                        num_instances: records.len() as u32,
                    })],
                )
                .during("building the scene's IAS")?;
            owned.accel(accel);
            device
                .traversable_handle(accel)
                .during("getting the IAS handle")?
        };

        // Programs: the pieces the features call for.
        let source = programs::path_module(features);
        let pipeline_options = plan.compile_options;
        let (module, _log) = device
            .create_module(
                &ModuleCompileOptions::default(),
                &pipeline_options,
                &ProgramSource::new("optik-render/path.wgsl", source),
            )
            .during("compiling the path tracer's programs")?;
        let module = owned.module(module);
        let hit_groups: Vec<HitGroupKey> = features.hit_groups.iter().copied().collect();
        let miss_count = if features.shadow_rays { 2 } else { 1 };
        let mut descs = vec![ProgramGroupDesc::Raygen(ProgramRef::new(
            module,
            "raygen__path",
        ))];
        descs.push(ProgramGroupDesc::Miss(Some(ProgramRef::new(
            module,
            "miss__radiance",
        ))));
        if features.shadow_rays {
            descs.push(ProgramGroupDesc::Miss(Some(ProgramRef::new(
                module,
                "miss__shadow",
            ))));
        }
        for g in &hit_groups {
            descs.push(ProgramGroupDesc::HitGroup {
                closest_hit: Some(ProgramRef::new(
                    module,
                    programs::closest_hit_name(g.kind, g.back, g.primitive),
                )),
                any_hit: g
                    .masked
                    .then(|| ProgramRef::new(module, programs::any_hit_name(g.primitive))),
                intersection: None,
                builtin: match g.primitive {
                    Primitive::Triangles => BuiltinIntersector::Triangle,
                    Primitive::Spheres => BuiltinIntersector::Sphere,
                },
            });
        }
        let groups = device
            .create_program_groups(&descs)
            .during("creating program groups")?;
        let groups = owned.groups(groups);
        let pipeline = device
            .create_pipeline(&pipeline_options, &PipelineLinkOptions::default(), &groups)
            .during("linking the pipeline")?;
        let pipeline = owned.pipeline(pipeline);

        // SBT: raygen, misses, then one hit record per shape, in GAS order.
        let mut table = Vec::new();
        table.extend_from_slice(
            &device
                .sbt_record_pack_header(groups[0])
                .during("packing the raygen record")?,
        );
        for g in &groups[1..1 + miss_count] {
            table.extend_from_slice(
                &device
                    .sbt_record_pack_header(*g)
                    .during("packing a miss record")?,
            );
        }
        let hit_offset = table.len() as u64;
        for r in &built.records {
            let slot = hit_groups
                .iter()
                .position(|k| *k == r.group)
                .ok_or_else(|| RenderError::Invalid(format!("no hit group for {:?}", r.group)))?;
            let mut rec = device
                .sbt_record_pack_header(groups[1 + miss_count + slot])
                .during("packing a hit record")?
                .to_vec();
            for w in r.data {
                rec.extend_from_slice(&w.to_le_bytes());
            }
            rec.resize(RECORD_STRIDE as usize, 0);
            table.extend_from_slice(&rec);
        }
        let sbt_buffer = owned.upload(&table, "the shader binding table")?;
        let sbt = ShaderBindingTable {
            raygen: SbtRecord {
                buffer: sbt_buffer,
                offset: 0,
            },
            exception: None,
            miss: Some(SbtRegion {
                buffer: sbt_buffer,
                offset: 32,
                stride: 32,
                count: miss_count as u32,
            }),
            hitgroup: (!built.records.is_empty()).then_some(SbtRegion {
                buffer: sbt_buffer,
                offset: hit_offset,
                stride: RECORD_STRIDE,
                count: built.records.len() as u32,
            }),
            callables: None,
        };

        let stride = if aov_outputs.is_some() {
            ACCUM_WORDS_AOVS + 1
        } else if want_aovs {
            ACCUM_WORDS_AOVS
        } else {
            ACCUM_WORDS
        };
        let accum = owned.zeroed(pixels * stride as u64 * 4, "the accumulation buffer")?;
        let resources = [
            Resource::buffer(1, accum),
            Resource::buffer(2, positions),
            Resource::buffer(3, normals),
            Resource::buffer(4, uvs),
            Resource::buffer(5, indices),
            Resource::buffer(6, lights),
            Resource::buffer(7, spheres),
            Resource::buffer(8, texels),
        ];
        let (tan_x, tan_y) = half_fov_tangents(&scene.camera, width, height);
        let (filter_kind, filter_param) = match scene.film.filter {
            Filter::Box => (0, 0.5),
            Filter::Tent { radius } => (1, radius),
            Filter::Gaussian { stddev } => (2, stddev),
        };
        if filter_param.is_nan() || filter_param <= 0.0 {
            return Err(RenderError::Invalid(format!(
                "filter {:?}: expected a positive radius or standard deviation",
                scene.film.filter
            )));
        }
        let m = scene.camera.to_world;
        let flags = u32::from(settings.hide_emitters) | if want_aovs { 2 } else { 0 };
        let params = move |base: u32, count: u32| {
            let mut p = Std140::default();
            let h = handle.to_words();
            p.u(h[0]).u(h[1]).u(width).u(height);
            p.u(base)
                .u(count)
                .u(seed)
                .u(settings.max_depth.unwrap_or(u32::MAX));
            p.u(settings.rr_depth)
                .u(flags)
                .u(filter_kind)
                .u(built.light_count);
            p.f(filter_param)
                .f(scene.camera.near_clip)
                .f(scene.camera.far_clip)
                .f(tan_x);
            for r in 0..3 {
                let row = m.row(r);
                p.f(row.x).f(row.y).f(row.z).f(row.w);
            }
            p.f(tan_y).u(stride).u(0).u(built.env_light);
            p.f(built.env_radiance.x)
                .f(built.env_radiance.y)
                .f(built.env_radiance.z)
                .f(built.env_pdf);
            p.f(mis[0]).f(mis[1]).f(mis[2]).u(integrator_id);
            p.u(samples[0]).u(samples[1]).u(0).u(0);
            p.0
        };
        let setup_seconds = setup_start.elapsed().as_secs_f64();
        let budget = options.samples_per_launch.unwrap_or(1 << 18).max(1) as u64;
        let per_launch = (budget / pixels).clamp(1, spp as u64) as u32;
        Ok(Renderer {
            device,
            _owned: owned,
            pipeline,
            sbt,
            resources: resources.to_vec(),
            params: Box::new(params),
            accum,
            stride,
            width,
            height,
            spp,
            per_launch,
            want_variance: options.want_variance,
            want_aovs,
            aov_outputs,
            plan,
            done: 0,
            render_seconds: 0.0,
            setup_seconds,
        })
    }

    /// The samples per pixel asked for (the options', else the scene's).
    pub fn spp(&self) -> u32 {
        self.spp
    }

    /// Samples per pixel accumulated so far.
    pub fn done(&self) -> u32 {
        self.done
    }

    /// Samples per pixel in one launch (launches are split so that each holds about 256 K
    /// path samples, or `RenderOptions::samples_per_launch`).
    pub fn samples_per_launch(&self) -> u32 {
        self.per_launch
    }

    /// Rays traced so far (radiance and shadow), read back from the device.
    pub fn rays(&self) -> Result<f64, RenderError> {
        Ok(self.frame()?.stats.rays)
    }

    /// The pipeline this renderer built.
    pub fn plan(&self) -> &PipelinePlan {
        &self.plan
    }

    /// The traversal features the device compiled into the pipeline (its `Auto` settings
    /// resolved).
    pub fn compiled_features(&self) -> Result<FeatureSet, RenderError> {
        self.device
            .pipeline_features(self.pipeline)
            .during("reading the pipeline's features")
    }

    /// Seconds spent in launches since the last restart.
    pub fn render_seconds(&self) -> f64 {
        self.render_seconds
    }

    /// Forgets the samples accumulated: the next `accumulate` starts the image afresh (and
    /// with the same random numbers as the first time).
    pub fn restart(&mut self) -> Result<(), RenderError> {
        let bytes = self.width as usize * self.height as usize * self.stride as usize * 4;
        self.device
            .write_buffer(self.accum, 0, &vec![0u8; bytes])
            .during("clearing the accumulation buffer")?;
        self.done = 0;
        self.render_seconds = 0.0;
        Ok(())
    }

    /// Adds `samples` samples per pixel to the image, calling `progress` after every launch.
    /// The image after N samples is the same however they were split between calls.
    pub fn accumulate(
        &mut self,
        samples: u32,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<(), RenderError> {
        let total = self.done.checked_add(samples).ok_or_else(|| {
            RenderError::Invalid(format!(
                "{} + {samples} samples per pixel: expected fewer than 2^32",
                self.done
            ))
        })?;
        let start = Instant::now();
        while self.done < total {
            let count = self.per_launch.min(total - self.done);
            self.device
                .launch(
                    self.pipeline,
                    &(self.params)(self.done, count),
                    &self.resources,
                    &self.sbt,
                    LaunchSize::new(self.width, self.height, 1),
                )
                .during("launching the path tracer")?;
            self.device
                .synchronize()
                .during("waiting for the path tracer")?;
            self.done += count;
            progress(Progress {
                done: self.done,
                total,
            });
        }
        self.render_seconds += start.elapsed().as_secs_f64();
        Ok(())
    }

    /// The image of the samples accumulated so far.
    pub fn frame(&self) -> Result<Frame, RenderError> {
        let (width, height, stride, spp) = (self.width, self.height, self.stride, self.done);
        if spp == 0 {
            return Err(RenderError::Invalid(
                "no samples accumulated yet: expected at least 1 per pixel".into(),
            ));
        }
        let pixels = width as u64 * height as u64;
        let mut raw = vec![0u8; (pixels * stride as u64 * 4) as usize];
        self.device
            .read_buffer(self.accum, 0, &mut raw)
            .during("reading the image")?;
        let acc: &[f32] = bytemuck::cast_slice(&raw);
        let n = spp as f32;
        let mut mean = Vec::with_capacity(pixels as usize);
        let mut variance = Vec::with_capacity(pixels as usize);
        let mut rays = 0.0f64;
        let mut albedo = Vec::new();
        let mut normal = Vec::new();
        let mut normal_mean = Vec::new();
        let mut depth = Vec::new();
        let aov_integrator = self.aov_outputs.is_some();
        for px in acc.chunks_exact(stride as usize) {
            let s = [px[0], px[1], px[2]];
            mean.push(s.map(|v| v / n));
            if spp > 1 {
                let q = [px[3], px[4], px[5]];
                variance.push(std::array::from_fn(|c| {
                    ((q[c] - s[c] * s[c] / n) / (n - 1.0)).max(0.0)
                }));
            }
            rays += px[6] as f64;
            if self.want_aovs {
                albedo.extend(px[7..10].iter().map(|v| v / n));
                let nv = Vec3::new(px[10], px[11], px[12]).normalize_or_zero();
                normal.extend_from_slice(&nv.to_array());
                normal_mean.extend(px[10..13].iter().map(|v| v / n));
            }
            if aov_integrator {
                depth.push(px[13] / n);
            }
        }
        let mut aovs = Vec::new();
        if let Some(list) = &self.aov_outputs {
            // Mitsuba's aov integrator: one layer per entry, pixel means (normals not
            // renormalised), channels named as Mitsuba names them.
            let names = |s: &[&str]| s.iter().map(|c| c.to_string()).collect::<Vec<String>>();
            for a in list {
                let (channels, data) = match a.kind {
                    AovKind::Albedo => (names(&["R", "G", "B"]), albedo.clone()),
                    AovKind::ShadingNormal => (names(&["X", "Y", "Z"]), normal_mean.clone()),
                    AovKind::Depth => (names(&["T"]), depth.clone()),
                };
                aovs.push(AovImage {
                    name: a.name.clone(),
                    channels,
                    data,
                });
            }
            // The main image repeats the first output (a grey one for depth), so that a PNG
            // shows it.
            if let Some(first) = aovs.first() {
                let k = first.channels.len();
                mean = first
                    .data
                    .chunks_exact(k)
                    .map(|c| {
                        if k == 3 {
                            [c[0], c[1], c[2]]
                        } else {
                            [c[0]; 3]
                        }
                    })
                    .collect();
            }
            variance.clear();
        } else if self.want_aovs {
            let rgb = |s: &[&str]| s.iter().map(|c| c.to_string()).collect();
            aovs.push(AovImage {
                name: "albedo".into(),
                channels: rgb(&["R", "G", "B"]),
                data: albedo,
            });
            aovs.push(AovImage {
                name: "normal".into(),
                channels: rgb(&["X", "Y", "Z"]),
                data: normal,
            });
        }
        Ok(Frame {
            width,
            height,
            spp,
            mean,
            variance: (self.want_variance && spp > 1 && !aov_integrator).then_some(variance),
            aovs,
            stats: RenderStats {
                render_seconds: self.render_seconds,
                setup_seconds: self.setup_seconds,
                rays,
                features: self.plan.features.clone(),
                programs: self.plan.programs.clone(),
            },
        })
    }
}
