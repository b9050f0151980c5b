//! The path tracer: scene upload, pipeline from the scene's features, progressive launches,
//! and the frame with per-pixel mean and variance.

use crate::camera::half_fov_tangents;
use crate::error::{Context, RenderError};
use crate::features::RenderFeatures;
use crate::gpu::{Owned, Std140};
use crate::material::{self, BsdfKind, MAT_PARAMS};
use crate::plan::{Effects, PipelinePlan};
use crate::programs;
use crate::scene::{Emitter, Filter, Integrator, Scene, ShapeRef, Texture};
use glam::{Mat3, Vec3};
use optik::{
    AccelBuildOptions, Buffer, BufferView, BuildFlags, BuildInput, Device, FeatureSet,
    GeometryFlags, LaunchSize, ModuleCompileOptions, Pipeline, PipelineLinkOptions,
    ProgramGroupDesc, ProgramRef, ProgramSource, Resource, SbtRecord, SbtRegion,
    ShaderBindingTable, TraversableHandle, TriangleArray,
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
/// Words of SBT record data (scene.wgsl: SBT_MATERIAL + MatParams).
const RECORD_DATA_WORDS: usize = 10 + MAT_PARAMS;
const RECORD_STRIDE: u32 = (32 + RECORD_DATA_WORDS as u32 * 4).div_ceil(16) * 16;
const LIGHT_WORDS: usize = 16;

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
        let settings = match &scene.integrator {
            Integrator::Path(p) => *p,
            Integrator::Direct(_) => {
                return Err(RenderError::Unsupported("the `direct` integrator".into()));
            }
            Integrator::Aov(_) => {
                return Err(RenderError::Unsupported("the `aov` integrator".into()));
            }
        };
        let plan = PipelinePlan::new(scene, options.want_aovs, effects);
        let features = &plan.features;
        let built = GeometryTables::build(scene)?;
        let mut owned = Owned::new(device);

        // Geometry: one GAS, one build input (and SBT record) per mesh.
        let positions = owned.upload(bytemuck::cast_slice(&built.positions), "vertex positions")?;
        let normals = owned.upload(bytemuck::cast_slice(&built.normals), "vertex normals")?;
        let uvs = owned.upload(bytemuck::cast_slice(&built.uvs), "texture coordinates")?;
        let indices = owned.upload(bytemuck::cast_slice(&built.indices), "triangle indices")?;
        let lights = owned.upload(bytemuck::cast_slice(&built.lights), "the light table")?;
        let inputs: Vec<BuildInput> = built
            .meshes
            .iter()
            .map(|m| {
                BuildInput::Triangles(
                    TriangleArray::new(
                        BufferView::at(positions, m.vertex_base as u64 * 12),
                        m.vertex_count,
                        GeometryFlags::DISABLE_ANYHIT,
                    )
                    .with_indices(
                        BufferView::at(indices, m.triangle_base as u64 * 12),
                        m.triangle_count,
                    ),
                )
            })
            .collect();
        let handle = if inputs.is_empty() {
            TraversableHandle::NULL
        } else {
            let options = AccelBuildOptions {
                flags: BuildFlags::PREFER_FAST_TRACE,
                ..Default::default()
            };
            let accel = device
                .accel_build(&options, &inputs)
                .during("building the scene's GAS")?;
            owned.accel(accel);
            device
                .traversable_handle(accel)
                .during("getting the GAS handle")?
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
        let kinds: Vec<BsdfKind> = features.bsdf_kinds.iter().copied().collect();
        let descs: Vec<ProgramGroupDesc> = plan
            .programs
            .iter()
            .map(|n| {
                let r = ProgramRef::new(module, n.as_str());
                match n.split("__").next() {
                    Some("raygen") => ProgramGroupDesc::Raygen(r),
                    Some("miss") => ProgramGroupDesc::Miss(Some(r)),
                    _ => ProgramGroupDesc::closest_hit(r),
                }
            })
            .collect();
        let groups = device
            .create_program_groups(&descs)
            .during("creating program groups")?;
        let groups = owned.groups(groups);
        let pipeline = device
            .create_pipeline(&pipeline_options, &PipelineLinkOptions::default(), &groups)
            .during("linking the pipeline")?;
        let pipeline = owned.pipeline(pipeline);

        // SBT: raygen, misses, then one hit record per mesh.
        let miss_count = if features.shadow_rays { 2 } else { 1 };
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
        for m in &built.meshes {
            let slot = kinds.iter().position(|k| *k == m.kind).unwrap_or(0);
            let mut rec = device
                .sbt_record_pack_header(groups[1 + miss_count + slot])
                .during("packing a hit record")?
                .to_vec();
            for w in m.record {
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
            hitgroup: (!built.meshes.is_empty()).then_some(SbtRegion {
                buffer: sbt_buffer,
                offset: hit_offset,
                stride: RECORD_STRIDE,
                count: built.meshes.len() as u32,
            }),
            callables: None,
        };

        let stride = if options.want_aovs {
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
        let flags = u32::from(settings.hide_emitters) | if options.want_aovs { 2 } else { 0 };
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
            p.f(tan_y).u(stride).u(0).u(0);
            p.f(built.env_radiance.x)
                .f(built.env_radiance.y)
                .f(built.env_radiance.z)
                .f(built.env_pdf);
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
            want_aovs: options.want_aovs,
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
            }
        }
        let mut aovs = Vec::new();
        if self.want_aovs {
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
            variance: (self.want_variance && spp > 1).then_some(variance),
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

/// One mesh as uploaded.
struct MeshEntry {
    kind: BsdfKind,
    vertex_base: u32,
    vertex_count: u32,
    triangle_base: u32,
    triangle_count: u32,
    record: [u32; RECORD_DATA_WORDS],
}

/// The scene flattened into the buffers the programs read.
#[derive(Default)]
struct GeometryTables {
    positions: Vec<f32>,
    normals: Vec<f32>,
    uvs: Vec<f32>,
    indices: Vec<u32>,
    lights: Vec<f32>,
    light_count: u32,
    meshes: Vec<MeshEntry>,
    env_radiance: Vec3,
    env_pdf: f32,
}

impl GeometryTables {
    fn build(scene: &Scene) -> Result<GeometryTables, RenderError> {
        let mut t = GeometryTables::default();
        let mut emissive: Vec<(usize, Vec3)> = Vec::new();
        let mut bounds_min = Vec3::splat(f32::INFINITY);
        let mut bounds_max = Vec3::splat(f32::NEG_INFINITY);
        for (to_world, shape) in scene.placed_shapes() {
            let mesh = match shape {
                ShapeRef::Mesh(m) => m,
                ShapeRef::Sphere(s) => {
                    return Err(RenderError::Unsupported(format!(
                        "sphere `{}`: spheres",
                        s.name
                    )));
                }
            };
            if mesh.indices.is_empty() {
                continue;
            }
            let what = format!("mesh `{}`", mesh.name);
            let nv = mesh.positions.len();
            if let Some(bad) = mesh.indices.iter().flatten().find(|&&i| i as usize >= nv) {
                return Err(RenderError::Invalid(format!(
                    "{what}: vertex index {bad} with {nv} vertices"
                )));
            }
            if !mesh.normals.is_empty() && mesh.normals.len() != nv {
                return Err(RenderError::Invalid(format!(
                    "{what}: {} normals for {nv} vertices (expected one per vertex or none)",
                    mesh.normals.len()
                )));
            }
            if !mesh.uvs.is_empty() && mesh.uvs.len() != nv {
                return Err(RenderError::Invalid(format!(
                    "{what}: {} texture coordinates for {nv} vertices (expected one per vertex or none)",
                    mesh.uvs.len()
                )));
            }
            let bsdf = scene.materials.get(mesh.material as usize).ok_or_else(|| {
                RenderError::Invalid(format!(
                    "{what}: material {} of {}",
                    mesh.material,
                    scene.materials.len()
                ))
            })?;
            let enc = material::encode(bsdf, &what)?;
            let vertex_base = (t.positions.len() / 3) as u32;
            let triangle_base = (t.indices.len() / 3) as u32;
            for p in &mesh.positions {
                let w = to_world.transform_point3(*p);
                bounds_min = bounds_min.min(w);
                bounds_max = bounds_max.max(w);
                t.positions.extend_from_slice(&w.to_array());
            }
            let normal_base = if mesh.normals.is_empty() {
                u32::MAX
            } else {
                let nm = Mat3::from_mat4(to_world).inverse().transpose();
                let base = (t.normals.len() / 3) as u32;
                for n in &mesh.normals {
                    t.normals
                        .extend_from_slice(&(nm * *n).normalize_or_zero().to_array());
                }
                base
            };
            let uv_base = if mesh.uvs.is_empty() {
                u32::MAX
            } else {
                let base = (t.uvs.len() / 2) as u32;
                for uv in &mesh.uvs {
                    t.uvs.extend_from_slice(&uv.to_array());
                }
                base
            };
            t.indices.extend(mesh.indices.iter().flatten());
            let emission = match &mesh.emission {
                None => Vec3::ZERO,
                Some(Texture::Constant(c)) => *c,
                Some(_) => {
                    return Err(RenderError::Unsupported(format!(
                        "{what}: textured emission (supported: constant radiance)"
                    )));
                }
            };
            let mut record = [0u32; RECORD_DATA_WORDS];
            record[0] = vertex_base;
            record[1] = triangle_base;
            record[2] = normal_base;
            record[3] = uv_base;
            // Face normals come from the world-space winding, as Mitsuba computes them.
            record[4] = u32::from(mesh.flip_normals);
            for (i, c) in emission.to_array().iter().enumerate() {
                record[6 + i] = c.to_bits();
            }
            for (i, v) in enc.params.iter().enumerate() {
                record[10 + i] = v.to_bits();
            }
            if emission.max_element() > 0.0 {
                emissive.push((t.meshes.len(), emission));
            }
            t.meshes.push(MeshEntry {
                kind: enc.kind,
                vertex_base,
                vertex_count: nv as u32,
                triangle_base,
                triangle_count: mesh.indices.len() as u32,
                record,
            });
        }
        let radius = if bounds_min.x <= bounds_max.x {
            (bounds_max - bounds_min).length() * 0.5
        } else {
            1.0
        };
        // Beyond the scene from any point inside it (Mitsuba: twice the bounding sphere).
        let far = 2.0 * radius * 1.01 + 1.0;

        let emitter_count = emissive.len() + scene.emitters.len();
        if emitter_count == 0 {
            return Ok(t);
        }
        let select = 1.0 / emitter_count as f32;
        let mut cdf = 0.0f64;
        let mut push = |t: &mut GeometryTables, e: [f32; LIGHT_WORDS], weight: f64| {
            cdf += weight;
            let mut e = e;
            e[1] = cdf as f32;
            t.lights.extend_from_slice(&e);
            t.light_count += 1;
        };
        for (mi, le) in emissive {
            let m = &t.meshes[mi];
            let triangles: Vec<[Vec3; 3]> = (0..m.triangle_count)
                .map(|k| {
                    let ti = ((m.triangle_base + k) * 3) as usize;
                    std::array::from_fn(|c| {
                        let v = (m.vertex_base + t.indices[ti + c]) as usize * 3;
                        Vec3::from_slice(&t.positions[v..v + 3])
                    })
                })
                .collect();
            let areas: Vec<f64> = triangles
                .iter()
                .map(|p| 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length() as f64)
                .collect();
            let total: f64 = areas.iter().sum();
            if total <= 0.0 {
                continue;
            }
            let flip_sign = if m.record[4] != 0 { -1.0 } else { 1.0 };
            // Hits on this mesh weigh emission against next-event estimation with this pdf.
            t.meshes[mi].record[5] = ((select as f64 / total) as f32).to_bits();
            for (p, a) in triangles.iter().zip(&areas) {
                if *a <= 0.0 {
                    continue;
                }
                let mut e = [0.0f32; LIGHT_WORDS];
                e[0] = 0.0;
                e[2..5].copy_from_slice(&le.to_array());
                e[5] = (select as f64 / total) as f32;
                e[6..9].copy_from_slice(&p[0].to_array());
                e[9..12].copy_from_slice(&(p[1] - p[0]).to_array());
                e[12..15].copy_from_slice(&(p[2] - p[0]).to_array());
                e[15] = flip_sign;
                push(&mut t, e, select as f64 * a / total);
            }
        }
        for em in &scene.emitters {
            let mut e = [0.0f32; LIGHT_WORDS];
            e[5] = select;
            match em {
                Emitter::Point {
                    position,
                    intensity,
                } => {
                    e[0] = 1.0;
                    e[2..5].copy_from_slice(&intensity.to_array());
                    e[6..9].copy_from_slice(&position.to_array());
                }
                Emitter::Directional {
                    direction,
                    irradiance,
                } => {
                    e[0] = 2.0;
                    e[2..5].copy_from_slice(&irradiance.to_array());
                    e[6..9].copy_from_slice(&direction.normalize_or_zero().to_array());
                    e[9] = far;
                }
                Emitter::Constant { radiance } => {
                    e[0] = 3.0;
                    e[2..5].copy_from_slice(&radiance.to_array());
                    e[9] = far;
                    t.env_radiance = *radiance;
                    t.env_pdf = select / (4.0 * std::f32::consts::PI);
                }
                Emitter::Spot { .. } => {
                    return Err(RenderError::Unsupported("spot emitters".into()));
                }
                Emitter::EnvMap { .. } => {
                    return Err(RenderError::Unsupported("envmap emitters".into()));
                }
            }
            push(&mut t, e, select as f64);
        }
        Ok(t)
    }
}
