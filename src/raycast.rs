//! A batch ray caster on the public [`Device`] API: rays in, closest hits out.
//!
//! A raygen program reads rays from a buffer and traces them against one triangle mesh; the
//! closest-hit program writes the hit record. This is what `optik trace` runs and what the
//! throughput benchmarks time, with no side path around the API. [`RayCaster::instanced`]
//! traces the mesh placed several times by an instance structure instead (`inst` is then the
//! instance's index), which is how the benchmarks build scenes of many millions of triangles.
//!
//! Rays are [`RAY_FLOATS`] `f32` each: origin x, y, z, tmin, direction x, y, z, tmax. Each ray
//! gives a hit record ([`Hits`]): `t`, the triangle index `prim` (in the order the triangles
//! were given), the instance id `inst` (0: the mesh is the only instance), and the barycentric
//! weights `u` and `v` of the triangle's second and third vertices. A ray that hits nothing
//! gives t = +inf, prim = inst = 0xFFFFFFFF, u = v = 0; so does an invalid ray (DESIGN.md §4:
//! NaN or infinite origin or direction, tmin < 0 or NaN, tmax NaN, tmin > tmax).

use crate::{
    Accel, AccelBuildOptions, Buffer, BufferView, BuildFlags, BuildInput, Device, Error,
    GeometryFlags, Instance, InstanceArray, LaunchSize, ModuleCompileOptions, Pipeline,
    PipelineCompileOptions, PipelineLinkOptions, ProgramGroupDesc, ProgramRef, ProgramSource,
    Resource, Result, ShaderBindingTable, TriangleArray,
};
use std::time::Instant;

/// Floats per ray in the input: origin xyz, tmin, direction xyz, tmax.
pub const RAY_FLOATS: usize = 8;
/// Words per hit in the output: t, prim, inst, u, v.
const HIT_WORDS: usize = 5;
/// Rays per launch by default on `properties`: as many as one binding holds (a ray takes
/// 32 bytes, its hit 20) and one launch allows, so that any number of rays the host holds
/// can be traced (a launch per batch; 2^22 rays on lavapipe's 128 MiB bindings) while a
/// GPU with large bindings gets all its rays in one launch: every launch ends in a tail of
/// few busy threads, which splitting would repeat.
pub fn default_batch_rays(properties: &crate::DeviceProperties) -> usize {
    let by_binding = properties.max_binding_size / (RAY_FLOATS * 4) as u64;
    let rays = by_binding.min(properties.max_launch_size).max(1);
    usize::try_from(rays).unwrap_or(usize::MAX)
}

/// Launch width; the height covers the rest of the rays.
const LAUNCH_WIDTH: u32 = 4096;
/// `prim` and `inst` of a miss.
pub const NO_HIT: u32 = u32::MAX;

/// The programs: the ray layout above in, the hit record out.
pub const PROGRAMS: &str = r#"
struct Params { scene: vec2<u32>, count: u32, width: u32 }
// A ray as two vectors (origin, tmin; direction, tmax) and a hit as one struct: each is read
// or written with one bounds check instead of one per word.
struct Hit { t: u32, prim: u32, inst: u32, u: u32, v: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> rays: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> hits: array<Hit>;

const MISS_T: u32 = 0x7f800000u;      // +inf
const NO_PRIMITIVE: u32 = 0xFFFFFFFFu;

fn raygen__cast() {
    let id = rt_launch_index();
    let i = id.y * params.width + id.x;
    if i >= params.count { return; }
    let start = rays[2u * i];
    let along = rays[2u * i + 1u];
    // Invalid rays run no program (DESIGN.md §4): the payload keeps these miss values.
    var p: RtPayload;
    p[0] = MISS_T;
    p[1] = NO_PRIMITIVE;
    p[2] = NO_PRIMITIVE;
    p[3] = 0u;
    p[4] = 0u;
    rt_trace(params.scene, start.xyz, along.xyz, start.w, along.w, 0.0,
             0xFFu, RT_RAY_FLAG_DISABLE_ANYHIT, 0u, 1u, 0u, &p);
    hits[i] = Hit(p[0], p[1], p[2], p[3], p[4]);
}

fn closesthit__record() {
    let bary = rt_triangle_barycentrics();
    rt_set_payload(0u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(1u, rt_primitive_index());
    rt_set_payload(2u, rt_instance_id());
    rt_set_payload(3u, bitcast<u32>(bary.x));
    rt_set_payload(4u, bitcast<u32>(bary.y));
}

fn miss__none() {
}
"#;

/// Per-ray results, one entry per ray in input order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Hits {
    /// Hit distance along the direction (in units of its length), +inf on a miss.
    pub t: Vec<f32>,
    /// Triangle index in the order given, [`NO_HIT`] on a miss.
    pub prim: Vec<u32>,
    /// Instance id (0 for the single mesh), [`NO_HIT`] on a miss.
    pub inst: Vec<u32>,
    /// Barycentric weight of the triangle's second vertex, 0 on a miss.
    pub u: Vec<f32>,
    /// Barycentric weight of the triangle's third vertex, 0 on a miss.
    pub v: Vec<f32>,
}

impl Hits {
    /// The number of rays that hit a triangle.
    pub fn hit_count(&self) -> usize {
        self.prim.iter().filter(|&&p| p != NO_HIT).count()
    }
}

/// The number of rays in `rays` (`RAY_FLOATS` floats each) that the invalid-ray policy
/// (DESIGN.md §4) makes misses without tracing.
pub fn invalid_ray_count(rays: &[f32]) -> usize {
    rays.chunks_exact(RAY_FLOATS)
        .filter(|r| {
            crate::semantics::ray::check([r[0], r[1], r[2]], [r[4], r[5], r[6]], r[3], r[7])
                .is_err()
        })
        .count()
}

fn le_bytes<T: Copy, const N: usize>(items: &[T], bytes: impl Fn(T) -> [u8; N]) -> Vec<u8> {
    items.iter().flat_map(|&x| bytes(x)).collect()
}

/// A mesh built on a device with the ray-casting pipeline ready to launch.
pub struct RayCaster<'d> {
    device: &'d dyn Device,
    /// The mesh's structure, then the instance structure over it if any (destroyed in
    /// reverse).
    accels: Vec<Accel>,
    handle: [u32; 2],
    pipeline: Pipeline,
    sbt: ShaderBindingTable,
    owned: Vec<Buffer>,
    /// Seconds the acceleration structure build took (including upload of the mesh).
    pub build_seconds: f64,
    batch_rays: usize,
}

impl<'d> RayCaster<'d> {
    /// Uploads and builds the mesh (`triangles` index `positions`), compiles the programs and
    /// fills the SBT.
    pub fn new(
        device: &'d dyn Device,
        positions: &[[f32; 3]],
        triangles: &[[u32; 3]],
    ) -> Result<RayCaster<'d>> {
        Self::with_options(
            device,
            positions,
            triangles,
            &PipelineCompileOptions::default(),
        )
    }

    /// Like [`RayCaster::new`], with explicit pipeline options (the benchmark report forces
    /// features on to measure what specialisation saves).
    pub fn with_options(
        device: &'d dyn Device,
        positions: &[[f32; 3]],
        triangles: &[[u32; 3]],
        pipeline_options: &PipelineCompileOptions,
    ) -> Result<RayCaster<'d>> {
        Self::build(device, positions, triangles, None, pipeline_options)
    }

    /// Like [`RayCaster::new`], with the mesh placed once per `transforms` entry (3×4
    /// row-major object-to-world matrices) by an instance structure over it: hits report
    /// the instance's index as `inst`. `build_seconds` covers both structures.
    pub fn instanced(
        device: &'d dyn Device,
        positions: &[[f32; 3]],
        triangles: &[[u32; 3]],
        transforms: &[[f32; 12]],
    ) -> Result<RayCaster<'d>> {
        Self::build(
            device,
            positions,
            triangles,
            Some(transforms),
            &PipelineCompileOptions::default(),
        )
    }

    fn build(
        device: &'d dyn Device,
        positions: &[[f32; 3]],
        triangles: &[[u32; 3]],
        transforms: Option<&[[f32; 12]]>,
        pipeline_options: &PipelineCompileOptions,
    ) -> Result<RayCaster<'d>> {
        let count = |n: usize, what: &str| {
            u32::try_from(n)
                .map_err(|_| Error::invalid(format!("{n} {what}: at most 2^32 - 1 are supported")))
        };
        let vertex_count = count(positions.len(), "vertices")?;
        let triangle_count = count(triangles.len(), "triangles")?;
        let mut owned = Vec::new();
        let mut upload = |bytes: &[u8]| -> Result<Buffer> {
            let b = device.create_buffer(bytes.len().max(4) as u64)?;
            owned.push(b);
            device.write_buffer(b, 0, bytes)?;
            Ok(b)
        };
        let start = Instant::now();
        let vertices = upload(&le_bytes(positions, |p| {
            let mut b = [0u8; 12];
            for (k, c) in p.iter().enumerate() {
                b[4 * k..4 * k + 4].copy_from_slice(&c.to_le_bytes());
            }
            b
        }))?;
        let indices = upload(&le_bytes(triangles, |t| {
            let mut b = [0u8; 12];
            for (k, i) in t.iter().enumerate() {
                b[4 * k..4 * k + 4].copy_from_slice(&i.to_le_bytes());
            }
            b
        }))?;
        let input = TriangleArray::new(
            BufferView::new(vertices),
            vertex_count,
            GeometryFlags::DISABLE_ANYHIT,
        )
        .with_indices(BufferView::new(indices), triangle_count);
        let options = AccelBuildOptions {
            flags: BuildFlags::PREFER_FAST_TRACE,
            ..Default::default()
        };
        let mut accels = Vec::new();
        // On an error below, the structures built so far are destroyed with the buffers.
        let built = (|| -> Result<crate::TraversableHandle> {
            let mesh = device.accel_build(&options, &[BuildInput::Triangles(input)])?;
            accels.push(mesh);
            let mesh_handle = device.traversable_handle(mesh)?;
            let Some(transforms) = transforms else {
                return Ok(mesh_handle);
            };
            let instance_count = count(transforms.len(), "instances")?;
            let records: Vec<u8> = transforms
                .iter()
                .enumerate()
                .flat_map(|(i, m)| {
                    let instance = Instance {
                        transform: *m,
                        instance_id: i as u32,
                        ..Instance::new(mesh_handle)
                    };
                    instance.as_bytes().to_vec()
                })
                .collect();
            let instances = upload(&records)?;
            let ias = device.accel_build(
                &options,
                &[BuildInput::Instances(InstanceArray {
                    instances: BufferView::new(instances),
                    num_instances: instance_count,
                })],
            )?;
            accels.push(ias);
            device.traversable_handle(ias)
        })();
        let handle = match built.and_then(|h| device.synchronize().map(|()| h)) {
            Ok(h) => h.to_words(),
            Err(e) => {
                for a in accels.into_iter().rev() {
                    let _ = device.destroy_accel(a);
                }
                for b in owned {
                    let _ = device.destroy_buffer(b);
                }
                return Err(e);
            }
        };
        let build_seconds = start.elapsed().as_secs_f64();

        let (module, _log) = device.create_module(
            &ModuleCompileOptions::default(),
            pipeline_options,
            &ProgramSource::new("raycast.wgsl", PROGRAMS),
        )?;
        let groups = device.create_program_groups(&[
            ProgramGroupDesc::Raygen(ProgramRef::new(module, "raygen__cast")),
            ProgramGroupDesc::Miss(Some(ProgramRef::new(module, "miss__none"))),
            ProgramGroupDesc::closest_hit(ProgramRef::new(module, "closesthit__record")),
        ])?;
        let pipeline =
            device.create_pipeline(pipeline_options, &PipelineLinkOptions::default(), &groups)?;
        let mut table = Vec::new();
        for g in &groups {
            table.extend_from_slice(&device.sbt_record_pack_header(*g)?);
        }
        let sbt = ShaderBindingTable::raygen_miss_hit(upload(&table)?);
        let batch_rays = default_batch_rays(device.properties());
        Ok(RayCaster {
            device,
            accels,
            handle,
            pipeline,
            sbt,
            owned,
            build_seconds,
            batch_rays,
        })
    }

    /// Bytes the acceleration structures occupy on the device (`Device::accel_size`, summed).
    pub fn accel_bytes(&self) -> Result<u64> {
        let mut total = 0u64;
        for &a in &self.accels {
            total = total.saturating_add(self.device.accel_size(a)?);
        }
        Ok(total)
    }

    /// The handle of the traversable the rays are cast into (the mesh's structure, or the
    /// instance structure over it).
    pub fn handle(&self) -> crate::TraversableHandle {
        crate::TraversableHandle::from_words(self.handle)
    }

    /// The features the pipeline was compiled with.
    pub fn features(&self) -> Result<crate::FeatureSet> {
        self.device.pipeline_features(self.pipeline)
    }

    /// Rays per launch.
    pub fn batch_rays(&self) -> usize {
        self.batch_rays
    }

    /// Rays per launch from now on (at least 1; the default is [`default_batch_rays`]).
    pub fn set_batch_rays(&mut self, rays: usize) {
        self.batch_rays = rays.max(1);
    }

    /// Uploads `rays` (`RAY_FLOATS` floats each) and hit buffers for them: a launch to run
    /// as often as wanted (its buffers are freed when it drops). Rays go in batches of at
    /// most [`RayCaster::set_batch_rays`], each with its own buffers and launch, so no
    /// binding exceeds a device's storage binding limit however many rays there are.
    pub fn upload(&self, rays: &[f32]) -> Result<Launch<'d>> {
        if !rays.len().is_multiple_of(RAY_FLOATS) {
            return Err(Error::invalid(format!(
                "{} floats do not make whole rays; expected {RAY_FLOATS} per ray",
                rays.len()
            )));
        }
        let n = rays.len() / RAY_FLOATS;
        let d = self.device;
        let mut launch = Launch {
            device: d,
            rays: n,
            batches: Vec::new(),
        };
        for (k, chunk) in rays
            .chunks(self.batch_rays.saturating_mul(RAY_FLOATS))
            .enumerate()
        {
            let m = chunk.len() / RAY_FLOATS;
            let m32 = u32::try_from(m).map_err(|_| {
                Error::invalid(format!("{m} rays: at most 2^32 - 1 rays per launch"))
            })?;
            // Pushed before the writes: on an error the launch drops and frees them.
            let ray_buffer = d.create_buffer((chunk.len() * 4).max(4) as u64)?;
            let hit_buffer = match d.create_buffer((m * HIT_WORDS * 4).max(4) as u64) {
                Ok(b) => b,
                Err(e) => {
                    let _ = d.destroy_buffer(ray_buffer);
                    return Err(e);
                }
            };
            let mut params = Vec::with_capacity(16);
            for w in [self.handle[0], self.handle[1], m32, LAUNCH_WIDTH] {
                params.extend_from_slice(&w.to_le_bytes());
            }
            launch.batches.push(Batch {
                first: k * self.batch_rays,
                rays: m,
                params,
                resources: [
                    Resource::buffer(1, ray_buffer),
                    Resource::buffer(2, hit_buffer),
                ],
                ray_buffer,
                hit_buffer,
                size: LaunchSize::new(LAUNCH_WIDTH.min(m32), m32.div_ceil(LAUNCH_WIDTH), 1),
            });
            d.write_buffer(ray_buffer, 0, &le_bytes(chunk, f32::to_le_bytes))?;
        }
        Ok(launch)
    }

    /// Runs `launch` once (a launch per batch) and waits for it (no launch at all for no
    /// rays).
    pub fn run(&self, launch: &Launch) -> Result<()> {
        if launch.rays == 0 {
            return Ok(());
        }
        let d = self.device;
        for b in &launch.batches {
            d.launch(self.pipeline, &b.params, &b.resources, &self.sbt, b.size)
                .map_err(|e| {
                    e.context(format!("tracing rays {}..{}", b.first, b.first + b.rays))
                })?;
        }
        d.synchronize()
    }

    /// The hits `launch` wrote.
    pub fn hits(&self, launch: &Launch) -> Result<Hits> {
        let mut hits = Hits::default();
        for b in &launch.batches {
            let mut raw = vec![0u8; b.rays * HIT_WORDS * 4];
            self.device.read_buffer(b.hit_buffer, 0, &mut raw)?;
            // Decoded word by word: a byte buffer's alignment is the allocator's choice, so it
            // is never reinterpreted as u32s in place.
            for h in raw.chunks_exact(HIT_WORDS * 4) {
                let word = |k: usize| {
                    u32::from_le_bytes([h[4 * k], h[4 * k + 1], h[4 * k + 2], h[4 * k + 3]])
                };
                hits.t.push(f32::from_bits(word(0)));
                hits.prim.push(word(1));
                hits.inst.push(word(2));
                hits.u.push(f32::from_bits(word(3)));
                hits.v.push(f32::from_bits(word(4)));
            }
        }
        Ok(hits)
    }

    /// Traces `rays` (`RAY_FLOATS` floats each) `repeat` times; returns the hits and the best
    /// launch time in seconds (0 for no rays). With `repeat > 1` (a measurement), untimed
    /// launches come first, for `optik_core::measure::WARM_UP` (GPU clocks).
    pub fn cast(&mut self, rays: &[f32], repeat: usize) -> Result<(Hits, f64)> {
        let launch = self.upload(rays)?;
        if launch.rays == 0 {
            return Ok((Hits::default(), 0.0));
        }
        if repeat > 1 {
            optik_core::measure::warm_up(|| self.run(&launch))?;
        }
        let mut best = f64::INFINITY;
        for _ in 0..repeat.max(1) {
            self.device.synchronize()?;
            let start = Instant::now();
            self.run(&launch)?;
            best = best.min(start.elapsed().as_secs_f64());
        }
        Ok((self.hits(&launch)?, best))
    }
}

/// Rays uploaded for a [`RayCaster`]: what the launches over them need. Its buffers are
/// freed when it drops.
pub struct Launch<'d> {
    device: &'d dyn Device,
    rays: usize,
    batches: Vec<Batch>,
}

/// One launch's share of the rays, with its own buffers.
struct Batch {
    first: usize,
    rays: usize,
    params: Vec<u8>,
    resources: [Resource; 2],
    ray_buffer: Buffer,
    hit_buffer: Buffer,
    size: LaunchSize,
}

impl Launch<'_> {
    /// The number of rays.
    pub fn rays(&self) -> usize {
        self.rays
    }

    /// The number of launches a run makes.
    pub fn batches(&self) -> usize {
        self.batches.len()
    }
}

impl Drop for Launch<'_> {
    fn drop(&mut self) {
        // Destroy errors only mean the device is gone, which frees everything anyway.
        for b in &self.batches {
            let _ = self.device.destroy_buffer(b.ray_buffer);
            let _ = self.device.destroy_buffer(b.hit_buffer);
        }
    }
}

impl Drop for RayCaster<'_> {
    fn drop(&mut self) {
        // Errors here mean the device is already gone, which frees everything anyway.
        let _ = self.device.destroy_pipeline(self.pipeline);
        for a in self.accels.drain(..).rev() {
            let _ = self.device.destroy_accel(a);
        }
        for b in self.owned.drain(..) {
            let _ = self.device.destroy_buffer(b);
        }
    }
}

#[cfg(all(test, feature = "cpu"))]
mod tests {
    use super::*;

    fn triangle() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        (
            vec![[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]],
            vec![[0, 1, 2]],
        )
    }

    #[test]
    fn a_batch_fills_one_binding_within_the_launch_limit() {
        let device = crate::open_backend(crate::BackendKind::Cpu).unwrap();
        let mut props = device.properties().clone();
        // The CPU binds any buffer: the launch limit decides.
        assert_eq!(default_batch_rays(&props) as u64, props.max_launch_size);
        // lavapipe's 128 MiB storage bindings hold 2^22 rays of 32 bytes.
        props.max_binding_size = 128 << 20;
        assert_eq!(default_batch_rays(&props), 1 << 22);
        props.max_binding_size = 16;
        assert_eq!(default_batch_rays(&props), 1, "at least one ray per launch");
        let (p, t) = triangle();
        let caster = RayCaster::new(device.as_ref(), &p, &t).unwrap();
        assert_eq!(
            caster.batch_rays as u64,
            device.properties().max_launch_size
        );
    }

    #[test]
    fn instances_place_the_mesh_and_report_their_index() {
        let device = crate::open_backend(crate::BackendKind::Cpu).unwrap();
        let (p, t) = triangle();
        let moved = |x: f32| [1.0, 0.0, 0.0, x, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let mut caster =
            RayCaster::instanced(device.as_ref(), &p, &t, &[moved(0.0), moved(2.0)]).unwrap();
        let inf = f32::INFINITY;
        let rays = [
            [0.25, 0.25, 0.0, 0.0, 0.0, 0.0, 1.0, inf], // the first copy
            [2.25, 0.5, 0.0, 0.0, 0.0, 0.0, 2.0, inf],  // the second, half as far along d
            [1.5, 0.25, 0.0, 0.0, 0.0, 0.0, 1.0, inf],  // between them
        ];
        let flat: Vec<f32> = rays.iter().flatten().copied().collect();
        let (hits, _) = caster.cast(&flat, 1).unwrap();
        assert_eq!(hits.prim, vec![0, 0, NO_HIT]);
        assert_eq!(hits.inst, vec![0, 1, NO_HIT]);
        assert_eq!(&hits.t[..2], &[1.0, 0.5]);
        assert_eq!((hits.u[1], hits.v[1]), (0.25, 0.5));
        // Both structures and the instance records count.
        let single = RayCaster::new(device.as_ref(), &p, &t).unwrap();
        assert!(caster.accel_bytes().unwrap() > single.accel_bytes().unwrap());
        assert!(
            RayCaster::instanced(device.as_ref(), &p, &t, &[[f32::NAN; 12]])
                .and_then(|mut c| c.cast(&flat, 1))
                .map_or(true, |(h, _)| h.hit_count() == 0),
            "a NaN transform hides its instance (or is refused)"
        );
    }

    #[test]
    fn no_rays_give_no_hits() {
        let device = crate::open_backend(crate::BackendKind::Cpu).unwrap();
        let (p, t) = triangle();
        let mut caster = RayCaster::new(device.as_ref(), &p, &t).unwrap();
        let (hits, seconds) = caster.cast(&[], 1).unwrap();
        assert_eq!((hits, seconds), (Hits::default(), 0.0));
        assert!(caster.cast(&[0.0; 7], 1).is_err());
    }

    #[test]
    fn hits_misses_and_invalid_rays() {
        let device = crate::open_backend(crate::BackendKind::Cpu).unwrap();
        let (p, t) = triangle();
        let mut caster = RayCaster::new(device.as_ref(), &p, &t).unwrap();
        let inf = f32::INFINITY;
        let rays = [
            [0.25, 0.25, 0.0, 0.0, 0.0, 0.0, 1.0, inf],  // hit
            [2.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0, inf],    // miss
            [0.25, 0.25, 0.0, -1.0, 0.0, 0.0, 1.0, inf], // invalid: tmin < 0
        ];
        let flat: Vec<f32> = rays.iter().flatten().copied().collect();
        let (hits, _) = caster.cast(&flat, 1).unwrap();
        assert_eq!(hits.prim, vec![0, NO_HIT, NO_HIT]);
        assert_eq!(hits.inst, vec![0, NO_HIT, NO_HIT]);
        assert_eq!(hits.t[0], 1.0);
        assert_eq!((hits.u[0], hits.v[0]), (0.25, 0.25));
        assert_eq!(&hits.t[1..], &[inf, inf]);
        assert_eq!(
            (&hits.u[1..], &hits.v[1..]),
            (&[0.0, 0.0][..], &[0.0, 0.0][..])
        );
        assert_eq!(hits.hit_count(), 1);
        assert_eq!(invalid_ray_count(&flat), 1);
    }
}
