//! The CPU backend's program JIT against the same programs written in Rust, behind the
//! same call boundary (`fn(&Bindings, &mut dyn DeviceCalls)`, not inlined).
//!
//! - `closest_hit`: a shading program (vertex normals fetched by primitive, barycentric
//!   interpolation, face-forwarding, a hashed albedo, Lambert and Blinn-Phong with `pow`,
//!   `exp` fog, RGBA8 packing, payload writes, a private counter).
//! - `loops`: a local `array<f32, 8>` worked over in nested constant-trip loops and a
//!   `loop` with `continuing` and `break if`.
//!
//! Both results are checked equal, bit for bit, before timing. After criterion's runs a
//! summary prints JIT/Rust ratios measured in this process (best of several batches), with
//! the compiled program called four ways: `call` (bindings laid out per call),
//! `call_prepared` (laid out once), the same with the state offered as memory, and
//! `RepeatedCall::call` with its context built once (how a launch task runs its ray
//! generation program at every launch index where the program has no launch loop, and how
//! close the program's own code is to Rust's: the other three add per-call set-up that a
//! launch does once per task). Ray generation programs also get a fifth column, "launch
//! loop": their launch loop (`RepeatedCall::run_indices`) over rows of launch indices, how
//! a launch runs them on Linux.

use criterion::{Criterion, criterion_group, criterion_main};
use optik_api::ProgramSource;
use optik_cpu::program::abi::{Bindings, BoundBuffer, BoundResource, DeviceCalls, DeviceState};
use optik_cpu::program::{DiskCache, JitModule, JitOptions, PreparedBindings, RepeatedCall};
use std::hint::black_box;
use std::sync::atomic::AtomicU32;
use std::time::Instant;

const SHADER: &str = r#"
struct Params { light: vec3<f32>, fog: f32, shininess: f32, width: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> normals: array<f32>;
@group(0) @binding(2) var<storage, read_write> image: array<u32>;
@group(0) @binding(3) var<storage, read> data: array<f32>;
@group(0) @binding(4) var<storage, read_write> results: array<f32>;

var<private> shaded: u32;

fn vertex_normal(v: u32) -> vec3<f32> {
    return vec3<f32>(normals[v * 3u], normals[v * 3u + 1u], normals[v * 3u + 2u]);
}

fn hash(x: u32) -> u32 {
    var h = x * 747796405u + 2891336453u;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    return (h >> 22u) ^ h;
}

fn albedo(prim: u32) -> vec3<f32> {
    let h = hash(prim);
    return vec3<f32>(f32(h & 255u), f32((h >> 8u) & 255u), f32((h >> 16u) & 255u)) * (1.0 / 255.0);
}

fn pack(c: vec3<f32>) -> u32 {
    let q = vec3<u32>(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0)) * 255.0 + 0.5);
    return q.x | (q.y << 8u) | (q.z << 16u) | (255u << 24u);
}

fn closesthit__shade() {
    let prim = rt_primitive_index();
    let bary = rt_triangle_barycentrics();
    let dir = rt_world_ray_direction();
    let t = rt_ray_tmax();
    let n0 = vertex_normal(prim * 3u);
    let n1 = vertex_normal(prim * 3u + 1u);
    let n2 = vertex_normal(prim * 3u + 2u);
    let w = 1.0 - bary.x - bary.y;
    var n = normalize(n0 * w + n1 * bary.x + n2 * bary.y);
    n = select(n, -n, dot(n, dir) > 0.0);
    let base = albedo(prim);
    let l = normalize(params.light);
    let diffuse = max(dot(n, l), 0.0);
    let h = normalize(l - dir);
    let spec = pow(max(dot(n, h), 0.0), params.shininess);
    let fog = exp(-t * params.fog);
    var color = base * diffuse + vec3<f32>(spec);
    color = mix(vec3<f32>(0.5, 0.6, 0.7), color, fog);
    color = min(color, vec3<f32>(length(color)));
    let li = rt_launch_index();
    let packed = pack(color);
    image[li.y * params.width + li.x] = packed;
    rt_set_payload(0u, packed);
    shaded += 1u;
    rt_set_payload(1u, shaded);
}

fn miss__empty() {}

fn miss__launch_index() {
    let li = rt_launch_index();
    image[li.x & 7u] = li.y;
}

fn raygen__loops() {
    let li = rt_launch_index();
    let n = arrayLength(&data);
    var window: array<f32, 8>;
    for (var i = 0u; i < 8u; i++) {
        window[i] = data[(li.x + i * 7u) % n];
    }
    var acc = 0.0;
    for (var round = 0u; round < 4u; round++) {
        for (var i = 0u; i < 8u; i++) {
            let j = (i + round) & 7u;
            acc += window[i] * window[j];
            window[i] = window[i] * 0.5 + window[j] * 0.25;
        }
    }
    var k = 0u;
    loop {
        acc = acc * 0.9 + f32(k);
        continuing {
            k += 1u;
            break if k >= 6u;
        }
    }
    results[li.x % arrayLength(&results)] = acc;
}
"#;

/// The state a hit program reads, set per call; offered to programs as memory
/// (`DeviceCalls::state`) when `offer` is set.
#[derive(Default)]
struct Hit {
    s: DeviceState,
    payload: [u32; 4],
    offer: bool,
}

#[rustfmt::skip]
impl DeviceCalls for Hit {
    fn launch_index(&self) -> [u32; 3] { self.s.launch_index }
    fn launch_dimensions(&self) -> [u32; 3] { self.s.launch_dimensions }
    fn trace(&mut self, _: [u32; 2], _: [f32; 3], _: [f32; 3], _: f32, _: f32, _: f32, _: u32, _: u32, _: u32, _: u32, _: u32, _: &mut [u32]) {}
    fn get_payload(&self, i: u32) -> u32 { self.payload[i as usize % 4] }
    fn set_payload(&mut self, i: u32, v: u32) { self.payload[i as usize % 4] = v; }
    fn get_attribute(&self, _: u32) -> u32 { 0 }
    fn report_intersection(&mut self, _: f32, _: u32, _: &[u32; 8]) -> bool { false }
    fn ignore_intersection(&mut self) {}
    fn terminate_ray(&mut self) {}
    fn world_ray_origin(&self) -> [f32; 3] { self.s.world_ray_origin }
    fn world_ray_direction(&self) -> [f32; 3] { self.s.world_ray_direction }
    fn object_ray_origin(&self) -> [f32; 3] { self.s.object_ray_origin }
    fn object_ray_direction(&self) -> [f32; 3] { self.s.object_ray_direction }
    fn ray_tmin(&self) -> f32 { self.s.ray_tmin }
    fn ray_tmax(&self) -> f32 { self.s.ray_tmax }
    fn ray_time(&self) -> f32 { self.s.ray_time }
    fn ray_flags(&self) -> u32 { self.s.ray_flags }
    fn ray_mask(&self) -> u32 { self.s.ray_mask }
    fn primitive_index(&self) -> u32 { self.s.primitive_index }
    fn sbt_gas_index(&self) -> u32 { self.s.sbt_gas_index }
    fn instance_id(&self) -> u32 { self.s.instance_id }
    fn instance_index(&self) -> u32 { self.s.instance_index }
    fn hit_kind(&self) -> u32 { self.s.hit_kind }
    fn is_front_face_hit(&self) -> bool { self.s.hit_kind == 0xfe }
    fn triangle_barycentrics(&self) -> [f32; 2] { self.s.triangle_barycentrics }
    fn triangle_vertices(&self) -> [[f32; 3]; 3] { [[0.0; 3]; 3] }
    fn sphere(&self) -> [f32; 4] { [0.0; 4] }
    fn curve_parameter(&self) -> f32 { 0.0 }
    fn object_to_world(&self) -> [f32; 12] { self.s.object_to_world }
    fn world_to_object(&self) -> [f32; 12] { self.s.world_to_object }
    fn sbt_data_u32(&self, _: u32) -> u32 { 0 }
    fn direct_call(&mut self, _: u32, _: &mut [u32]) {}
    fn continuation_call(&mut self, _: u32, _: &mut [u32]) {}
    fn throw_exception(&mut self, _: u32) {}
    fn exception_code(&self) -> i32 { 0 }
    fn remaining_trace_depth(&self) -> u32 { self.s.remaining_trace_depth }
    fn state(&self) -> *const DeviceState {
        if self.offer { &self.s } else { std::ptr::null() }
    }
}

const WIDTH: u32 = 64;
const TRIANGLES: usize = 500;
const BATCH: usize = 1024;

type V3 = [f32; 3];

fn dot(a: V3, b: V3) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn normalize(a: V3) -> V3 {
    let l = dot(a, a).sqrt();
    a.map(|x| x / l)
}
fn fmin(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}
fn fmax(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// A buffer's words, or an empty slice when the binding is not a buffer.
///
/// # Safety
/// The runtime's contract: a bound buffer is valid for its length during the call.
unsafe fn words<'a, T>(bindings: &Bindings<'a>, binding: usize) -> &'a mut [T] {
    match bindings.resources.get(binding) {
        Some(BoundResource::Buffer(b)) => unsafe {
            std::slice::from_raw_parts_mut(b.ptr.cast::<T>(), b.len / size_of::<T>())
        },
        _ => &mut [],
    }
}

/// `closesthit__shade` in Rust, with WGSL's bounds rules (`get` for reads, checked writes).
#[inline(never)]
fn shade_rust(bindings: &Bindings<'_>, calls: &mut dyn DeviceCalls) {
    let params: &[u32] = unsafe { words(bindings, 0) };
    let normals: &[f32] = unsafe { words(bindings, 1) };
    let image: &mut [u32] = unsafe { words(bindings, 2) };
    let p = |i: usize| params.get(i).copied().unwrap_or(0);
    let light = [
        f32::from_bits(p(0)),
        f32::from_bits(p(1)),
        f32::from_bits(p(2)),
    ];
    let (fog_k, shininess, width) = (f32::from_bits(p(3)), f32::from_bits(p(4)), p(5));
    let mut shaded = 0u32;
    let prim = calls.primitive_index();
    let bary = calls.triangle_barycentrics();
    let dir = calls.world_ray_direction();
    let t = calls.ray_tmax();
    let vertex = |v: u32| -> V3 {
        std::array::from_fn(|k| {
            normals
                .get(v.wrapping_mul(3).wrapping_add(k as u32) as usize)
                .copied()
                .unwrap_or(0.0)
        })
    };
    let (n0, n1, n2) = (
        vertex(prim.wrapping_mul(3)),
        vertex(prim.wrapping_mul(3) + 1),
        vertex(prim.wrapping_mul(3) + 2),
    );
    let w = 1.0 - bary[0] - bary[1];
    let mut n = normalize(std::array::from_fn(|k| {
        n0[k] * w + n1[k] * bary[0] + n2[k] * bary[1]
    }));
    if dot(n, dir) > 0.0 {
        n = n.map(|x| -x);
    }
    let mut h = prim.wrapping_mul(747796405).wrapping_add(2891336453);
    h = ((h >> ((h >> 28) + 4)) ^ h).wrapping_mul(277803737);
    let h = (h >> 22) ^ h;
    let inv255 = (1.0f64 / 255.0) as f32;
    let base = [
        (h & 255) as f32 * inv255,
        ((h >> 8) & 255) as f32 * inv255,
        ((h >> 16) & 255) as f32 * inv255,
    ];
    let l = normalize(light);
    let diffuse = fmax(dot(n, l), 0.0);
    let hv = normalize([l[0] - dir[0], l[1] - dir[1], l[2] - dir[2]]);
    let spec = fmax(dot(n, hv), 0.0).powf(shininess);
    let fog = (-t * fog_k).exp();
    let sky = [0.5, 0.6, 0.7];
    let mut color: V3 = std::array::from_fn(|k| base[k] * diffuse + spec);
    color = std::array::from_fn(|k| sky[k] * (1.0 - fog) + color[k] * fog);
    let len = dot(color, color).sqrt();
    color = color.map(|c| fmin(c, len));
    let li = calls.launch_index();
    let q = color.map(|c| (fmin(fmax(c, 0.0), 1.0) * 255.0 + 0.5) as u32);
    let packed = q[0] | (q[1] << 8) | (q[2] << 16) | (255 << 24);
    if let Some(px) = image.get_mut(li[1].wrapping_mul(width).wrapping_add(li[0]) as usize) {
        *px = packed;
    }
    calls.set_payload(0, packed);
    shaded += 1;
    calls.set_payload(1, shaded);
}

/// `raygen__loops` in Rust.
#[inline(never)]
fn loops_rust(bindings: &Bindings<'_>, calls: &mut dyn DeviceCalls) {
    let data: &[f32] = unsafe { words(bindings, 3) };
    let results: &mut [f32] = unsafe { words(bindings, 4) };
    let li = calls.launch_index();
    let n = data.len() as u32;
    let mut window = [0.0f32; 8];
    for (i, slot) in window.iter_mut().enumerate() {
        let at = li[0].wrapping_add(i as u32 * 7).checked_rem(n).unwrap_or(0);
        *slot = data.get(at as usize).copied().unwrap_or(0.0);
    }
    let mut acc = 0.0f32;
    for round in 0..4 {
        for i in 0..8 {
            let j = (i + round) & 7;
            acc += window[i] * window[j];
            window[i] = window[i] * 0.5 + window[j] * 0.25;
        }
    }
    let mut k = 0u32;
    loop {
        acc = acc * 0.9 + k as f32;
        k += 1;
        if k >= 6 {
            break;
        }
    }
    let len = results.len() as u32;
    if let Some(r) = results.get_mut(li[0].checked_rem(len).unwrap_or(0) as usize) {
        *r = acc;
    }
}

struct Scene {
    params: Vec<u32>,
    normals: Vec<f32>,
    image: Vec<u32>,
    data: Vec<f32>,
    results: Vec<f32>,
    hits: Vec<Hit>,
}

impl Scene {
    fn new() -> Scene {
        let mut seed = 0x9e37_79b9u32;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let normals = (0..TRIANGLES * 9).map(|_| rnd() * 2.0 - 1.0).collect();
        let hits = (0..BATCH)
            .map(|i| {
                let (u, v) = (rnd(), rnd());
                Hit {
                    s: DeviceState {
                        // The payload is offered by `offer_state`, pointing at `payload`.
                        present: !DeviceState::PAYLOAD,
                        launch_index: [i as u32 % WIDTH, i as u32 / WIDTH, 0],
                        launch_dimensions: [WIDTH, WIDTH, 1],
                        primitive_index: (rnd() * TRIANGLES as f32) as u32,
                        triangle_barycentrics: [u * 0.5, v * 0.5],
                        world_ray_direction: normalize([rnd() - 0.5, rnd() - 0.5, -1.0]),
                        ray_tmax: rnd() * 20.0,
                        hit_kind: 0xfe,
                        ..DeviceState::default()
                    },
                    payload: [0; 4],
                    offer: false,
                }
            })
            .collect();
        let params = [0.3f32, 0.8, 0.5, 0.05, 32.0]
            .iter()
            .map(|x| x.to_bits())
            .chain([WIDTH, 0, 0])
            .collect();
        Scene {
            params,
            normals,
            image: vec![0; (WIDTH * WIDTH) as usize],
            data: (0..257).map(|_| rnd()).collect(),
            results: vec![0.0; 256],
            hits,
        }
    }

    fn resources(&mut self) -> [BoundResource; 5] {
        let buffer = |ptr: *mut u8, len: usize| BoundResource::Buffer(BoundBuffer { ptr, len });
        [
            buffer(self.params.as_mut_ptr().cast(), self.params.len() * 4),
            buffer(self.normals.as_mut_ptr().cast(), self.normals.len() * 4),
            buffer(self.image.as_mut_ptr().cast(), self.image.len() * 4),
            buffer(self.data.as_mut_ptr().cast(), self.data.len() * 4),
            buffer(self.results.as_mut_ptr().cast(), self.results.len() * 4),
        ]
    }

    /// Runs `f` over the whole batch of hits.
    fn run(&mut self, f: &dyn Fn(&Bindings<'_>, &mut dyn DeviceCalls)) {
        let resources = self.resources();
        let bindings = Bindings {
            resources: &resources,
        };
        for hit in &mut self.hits {
            f(black_box(&bindings), hit);
        }
    }

    /// Whether the hits offer their state (payload registers included) to programs as
    /// memory. The hits stay where they are in their vector from here on.
    fn offer_state(mut self, offer: bool) -> Self {
        for h in &mut self.hits {
            h.offer = offer;
            h.s.payload = h.payload.as_mut_ptr();
            h.s.payload_len = h.payload.len() as u32;
            h.s.present |= DeviceState::PAYLOAD;
        }
        self
    }

    /// Runs a compiled program over the whole batch with bindings prepared once, as the
    /// runtime does per launch.
    fn run_prepared(&mut self, jit: &JitModule, program: &str) {
        let f = jit.program(program).expect("program");
        let resources = self.resources();
        let bindings = Bindings {
            resources: &resources,
        };
        let prepared = jit.prepare(&bindings);
        for hit in &mut self.hits {
            f.call_prepared(black_box(&prepared), hit);
        }
    }

    /// The batch's calls as a launch task makes them: one [`RepeatedCall`] per hit, built
    /// once with that hit's offered state (a task's state pointer and stop flag are the same
    /// for every launch index it runs), then only called.
    fn repeated_calls<'a>(
        &mut self,
        jit: &'a JitModule,
        program: &str,
        prepared: &'a PreparedBindings<'a>,
    ) -> Vec<RepeatedCall<'a>> {
        let f = jit.program(program).expect("program");
        self.hits
            .iter_mut()
            .map(|h| {
                let (state, stop) = (h.state(), h.stop_flag());
                f.repeated(prepared, h, state, stop, None)
                    .expect("bindings prepared by the same module")
            })
            .collect()
    }

    /// Calls `run` with this scene's [`Scene::repeated_calls`] for `program` (bindings
    /// prepared once, as a launch does).
    fn repeated<T>(
        &mut self,
        jit: &JitModule,
        program: &str,
        run: impl FnOnce(&mut Scene, &mut [RepeatedCall<'_>]) -> T,
    ) -> T {
        let resources = self.resources();
        let bindings = Bindings {
            resources: &resources,
        };
        let prepared = jit.prepare(&bindings);
        let mut calls = self.repeated_calls(jit, program, &prepared);
        run(self, &mut calls)
    }

    /// Runs `calls` (from [`Scene::repeated_calls`] on this scene) over the whole batch.
    fn run_repeated(&mut self, calls: &mut [RepeatedCall<'_>]) {
        for (call, hit) in calls.iter_mut().zip(&mut self.hits) {
            call.call(hit);
        }
    }

    /// Calls `run` with a runner of the whole batch as a launch on Linux runs a ray
    /// generation program: one [`RepeatedCall`] on the first hit's offered state, whose
    /// launch loop ([`RepeatedCall::run_indices`]) runs a row of `WIDTH` launch indices a
    /// call, the row's first index written into the state before it as the runtime writes
    /// it. The batch's indices are the hits' own. `None` for a program without a launch loop.
    fn launch_rows<T>(
        &mut self,
        jit: &JitModule,
        program: &str,
        run: impl FnOnce(&mut dyn FnMut()) -> T,
    ) -> Option<T> {
        assert!(
            self.hits[0].offer,
            "the launch loop steps the offered state"
        );
        let resources = self.resources();
        let bindings = Bindings {
            resources: &resources,
        };
        let prepared = jit.prepare(&bindings);
        let f = jit.program(program).expect("program");
        let hit: *mut Hit = &mut self.hits[0];
        let never = AtomicU32::new(0);
        let ended = 0u32;
        // SAFETY: `hit` points into `self.hits`, which outlives the calls below and is
        // reached only through it meanwhile (its state is the one the loop steps).
        let state = unsafe { &raw mut (*hit).s };
        let mut call = f
            .repeated(&prepared, unsafe { &mut *hit }, state, &never, None)
            .expect("bindings prepared by the same module");
        if !call.has_launch_loop() {
            return None;
        }
        let rows = (BATCH as u32).div_ceil(WIDTH);
        let mut batch = || {
            for y in 0..rows {
                // SAFETY: as above; `ended` is only read (no program here throws), and the
                // state is the hit's own, writable.
                unsafe {
                    (*state).launch_index = [0, y, 0];
                    call.run_indices(&mut *hit, WIDTH as usize, &never, &ended);
                }
            }
        };
        Some(run(&mut batch))
    }

    /// Everything a run writes, as bits.
    fn outputs(&self) -> Vec<u32> {
        let payloads = self.hits.iter().flat_map(|h| h.payload);
        self.image
            .iter()
            .copied()
            .chain(self.results.iter().map(|r| r.to_bits()))
            .chain(payloads)
            .collect()
    }
}

fn compile() -> JitModule {
    let module = optik_core::frontend::compile(&ProgramSource::new("bench.wgsl", SHADER), 4)
        .expect("front end");
    let options = JitOptions {
        disk_cache: DiskCache::Disabled,
        ..JitOptions::default()
    };
    JitModule::compile(&module, &options).expect("JIT")
}

/// `miss__empty` in Rust: the cost of the call boundary alone.
#[inline(never)]
fn empty_rust(_: &Bindings<'_>, _: &mut dyn DeviceCalls) {}

/// `miss__launch_index` in Rust: one device call and one buffer store.
#[inline(never)]
fn launch_index_rust(bindings: &Bindings<'_>, calls: &mut dyn DeviceCalls) {
    let image: &mut [u32] = unsafe { words(bindings, 2) };
    let li = calls.launch_index();
    if let Some(px) = image.get_mut((li[0] & 7) as usize) {
        *px = li[1];
    }
}

type Pair = (
    &'static str,
    &'static str,
    fn(&Bindings<'_>, &mut dyn DeviceCalls),
);
const PROGRAMS: [Pair; 4] = [
    ("closest_hit", "closesthit__shade", shade_rust),
    ("loops", "raygen__loops", loops_rust),
    ("empty", "miss__empty", empty_rust),
    ("one_call", "miss__launch_index", launch_index_rust),
];

/// Both versions give the same outputs, bit for bit.
fn check(jit: &JitModule) {
    for (name, program, rust) in PROGRAMS {
        let f = jit.program(program).expect("program");
        let mut a = Scene::new();
        a.run(&|b, c| f.call(b, c));
        let mut r = Scene::new();
        r.run(&|b, c| rust(b, c));
        assert_eq!(a.outputs(), r.outputs(), "{name}: JIT and Rust disagree");
        let mut p = Scene::new();
        p.run_prepared(jit, program);
        assert_eq!(
            p.outputs(),
            r.outputs(),
            "{name}: prepared JIT and Rust disagree"
        );
        let mut s = Scene::new().offer_state(true);
        s.run_prepared(jit, program);
        assert_eq!(
            s.outputs(),
            r.outputs(),
            "{name}: JIT reading the offered state and Rust disagree"
        );
        let mut q = Scene::new().offer_state(true);
        q.repeated(jit, program, |scene, calls| scene.run_repeated(calls));
        assert_eq!(
            q.outputs(),
            r.outputs(),
            "{name}: JIT called as a launch calls it and Rust disagree"
        );
        let mut l = Scene::new().offer_state(true);
        if l.launch_rows(jit, program, |batch| batch()).is_some() {
            assert_eq!(
                l.outputs(),
                r.outputs(),
                "{name}: JIT's launch loop and Rust disagree"
            );
        }
    }
}

fn bench(c: &mut Criterion) {
    let jit = compile();
    check(&jit);
    let mut group = c.benchmark_group("jit");
    for (name, program, rust) in PROGRAMS {
        let f = jit.program(program).expect("program");
        let mut scene = Scene::new();
        group.bench_function(format!("{name}/jit"), |b| {
            b.iter(|| scene.run(&|bd, c| f.call(bd, c)))
        });
        group.bench_function(format!("{name}/jit_prepared"), |b| {
            b.iter(|| scene.run_prepared(&jit, program))
        });
        let mut offered = Scene::new().offer_state(true);
        group.bench_function(format!("{name}/jit_prepared_state"), |b| {
            b.iter(|| offered.run_prepared(&jit, program))
        });
        let mut launched = Scene::new().offer_state(true);
        launched.repeated(&jit, program, |scene, calls| {
            group.bench_function(format!("{name}/jit_repeated"), |b| {
                b.iter(|| scene.run_repeated(calls))
            })
        });
        group.bench_function(format!("{name}/rust"), |b| {
            b.iter(|| scene.run(&|bd, c| rust(bd, c)))
        });
    }
    group.finish();
    summary(&jit);
}

/// Nanoseconds per call, best of `rounds` batches of 20 runs of the scene.
fn per_call(rounds: usize, mut run: impl FnMut()) -> f64 {
    (0..rounds)
        .map(|_| {
            let start = Instant::now();
            for _ in 0..20 {
                run();
            }
            start.elapsed().as_secs_f64() * 1e9 / (20 * BATCH) as f64
        })
        .fold(f64::INFINITY, f64::min)
}

fn summary(jit: &JitModule) {
    println!("\nns per call (best of 30 batches of {BATCH} x 20) and ratio to Rust:");
    println!(
        "  {:12} {:>7}  {:>15}  {:>15}  {:>15}  {:>15}  {:>15}",
        "", "rust", "jit", "jit prepared", "+ state", "as launched", "launch loop"
    );
    for (name, program, rust) in PROGRAMS {
        let f = jit.program(program).expect("program");
        let mut scene = Scene::new();
        let r = per_call(30, || scene.run(&|b, c| rust(b, c)));
        let j = per_call(30, || scene.run(&|b, c| f.call(b, c)));
        let p = per_call(30, || scene.run_prepared(jit, program));
        let mut offered = Scene::new().offer_state(true);
        let st = per_call(30, || offered.run_prepared(jit, program));
        let mut launched = Scene::new().offer_state(true);
        let l = launched.repeated(jit, program, |scene, calls| {
            per_call(30, || scene.run_repeated(calls))
        });
        let mut looped = Scene::new().offer_state(true);
        let rows = match looped.launch_rows(jit, program, |batch| per_call(30, batch)) {
            Some(t) => format!("{t:7.2} ({:.3})", t / r),
            None => "-".into(),
        };
        println!(
            "  {name:12} {r:7.2}  {j:7.2} ({:.3})  {p:7.2} ({:.3})  {st:7.2} ({:.3})  {l:7.2} ({:.3})  {rows:>15}",
            j / r,
            p / r,
            st / r,
            l / r
        );
    }
    println!("  compile: {:?}", jit.stats());
}

criterion_group!(benches, bench);
criterion_main!(benches);
