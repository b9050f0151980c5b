//! Measures what docs/cpu-backend.md ("BVH") reports: build presets, BVH2 against CWBVH
//! (both traversed by optik's own robust code), and the price of the accuracy options.
//!
//! `cargo run --release -p optik-cpu --no-default-features --example bvh_layouts [scene.obj]`
//!
//! Scenes: a generated bumpy sphere (always), and the OBJ given on the command line (the
//! project's test scenes, DESIGN.md §9, are kept outside the repository; without the argument
//! only the generated scene runs). Timings are single-threaded; jobs run interleaved, best of 7.

use optik_accel::decode::BufferBytes;
use optik_api::semantics::opacity::CandidateFate;
use optik_api::*;
use optik_cpu::accel::{Gas, MicromapArrayData, MicromapLookup, SceneTable, Traversable};
use optik_cpu::traversal::{
    self, Candidate, CustomPrimitive, Handler, Path, PreparedRay, Spec, Specialised, TraceConfig,
    TraceRay,
};
use std::sync::Arc;
use std::time::Instant;

struct Memory(Vec<Vec<u8>>);

impl BufferBytes for Memory {
    fn bytes(&self, buffer: Buffer) -> Result<&[u8]> {
        Ok(&self.0[buffer.raw().slot as usize])
    }
}

impl MicromapLookup for Memory {
    fn micromap_array(&self, _: MicromapArray) -> Result<Arc<MicromapArrayData>> {
        Err(Error::invalid("none"))
    }
}

fn buffer(slot: u32) -> Buffer {
    Buffer::from_raw(RawHandle {
        device: DeviceId(0),
        slot,
        generation: 0,
    })
}

/// Vertices and triangles.
type Mesh = (Vec<[f32; 3]>, Vec<[u32; 3]>);
/// Origin and direction.
type RaySet = Vec<([f32; 3], [f32; 3])>;

fn load_obj(path: &str) -> Option<Mesh> {
    let text = std::fs::read_to_string(path).ok()?;
    let mut v: Vec<[f32; 3]> = Vec::new();
    let mut f = Vec::new();
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f32> = it.take(3).filter_map(|x| x.parse().ok()).collect();
                if c.len() == 3 {
                    v.push([c[0], c[1], c[2]]);
                }
            }
            Some("f") => {
                let idx: Vec<u32> = it
                    .filter_map(|x| x.split('/').next()?.parse::<i64>().ok())
                    .map(|i| {
                        if i < 0 {
                            (v.len() as i64 + i) as u32
                        } else {
                            (i - 1) as u32
                        }
                    })
                    .collect();
                for k in 1..idx.len().saturating_sub(1) {
                    f.push([idx[0], idx[k], idx[k + 1]]);
                }
            }
            _ => {}
        }
    }
    Some((v, f))
}

/// A sphere with bumps, `n × 2n` quads.
fn bumpy_sphere(n: u32) -> Mesh {
    let mut v = Vec::new();
    for i in 0..=n {
        for j in 0..=2 * n {
            let (th, ph) = (
                std::f32::consts::PI * i as f32 / n as f32,
                std::f32::consts::PI * j as f32 / n as f32,
            );
            let r = 1.0
                + 0.05 * (7.0 * th).sin() * (9.0 * ph).cos()
                + 0.02 * (31.0 * th).cos() * (23.0 * ph).sin();
            v.push([
                r * th.sin() * ph.cos(),
                r * th.cos(),
                r * th.sin() * ph.sin(),
            ]);
        }
    }
    let at = |i: u32, j: u32| i * (2 * n + 1) + j;
    let mut f = Vec::new();
    for i in 0..n {
        for j in 0..2 * n {
            f.push([at(i, j), at(i, j + 1), at(i + 1, j)]);
            f.push([at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)]);
        }
    }
    (v, f)
}

struct Closest {
    tmax: f32,
    hit: u32,
}

impl Handler for Closest {
    fn t_max(&self) -> f32 {
        self.tmax
    }
    fn done(&self) -> bool {
        false
    }
    fn candidate<S: Spec>(&mut self, c: &Candidate<'_>, _: &Path, _: CandidateFate) {
        self.tmax = c.t;
        self.hit = c.info.primitive_index;
    }
    fn custom<S: Spec>(&mut self, _: &CustomPrimitive<'_>, _: &Path, _: CandidateFate) {}
    fn traversal_exception(&mut self, _: i32) {}
}

struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn rays(v: &[[f32; 3]]) -> (RaySet, RaySet) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in v {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let c = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f32, f32::max);
    let eye = [c[0] + 0.3 * size, c[1] + 0.2 * size, c[2] + 1.6 * size];
    let (w, h) = (384u32, 256u32);
    let mut primary = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let target = [
                c[0] + size * (x as f32 / w as f32 - 0.5),
                c[1] + size * (0.5 - y as f32 / h as f32) * 0.67,
                c[2],
            ];
            primary.push((
                eye,
                [target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]],
            ));
        }
    }
    let mut rng = Rng(42);
    let incoherent = (0..w * h)
        .map(|_| {
            let o = [0, 1, 2].map(|k| lo[k] + (hi[k] - lo[k]) * rng.f());
            let d = [rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5];
            (o, d)
        })
        .collect();
    (primary, incoherent)
}

const CONFIG: TraceConfig = TraceConfig {
    primitive_types: PrimitiveTypeFlags::TRIANGLE,
    intersection: false,
    micromaps: false,
    debug_exceptions: false,
    max_graph_depth: 16,
};

fn trace_all<S: Spec>(
    scene: &SceneTable,
    root: TraversableHandle,
    rays: &[([f32; 3], [f32; 3])],
) -> Vec<u32> {
    rays.iter()
        .map(|&(o, d)| {
            let r = TraceRay {
                origin: o,
                direction: d,
                tmin: 0.0,
                tmax: f32::INFINITY,
                time: 0.0,
                mask: 0xFF,
                flags: RayFlags::NONE,
            };
            let mut h = Closest {
                tmax: f32::INFINITY,
                hit: u32::MAX,
            };
            traversal::trace::<S, _>(scene, root, &r, &CONFIG, &mut h);
            h.hit
        })
        .collect()
}

type Robust = Specialised<false, false, false, true, true>;
type Fast = Specialised<false, false, false, false, false>;
type WatertightPlain = Specialised<false, false, false, true, false>;
type MtConservative = Specialised<false, false, false, false, true>;

/// optik's robust traversal of an obvhs CWBVH: children decoded from their quantised planes,
/// widened by a few ulps to stay conservative (docs/numerics.md F8), tested as 8 slabs, nearest
/// first.
fn cwbvh_trace(bvh: &obvhs::cwbvh::CwBvh, tris: &[[[f32; 3]; 3]], o: [f32; 3], d: [f32; 3]) -> u32 {
    let ray = PreparedRay::new(o, d, true);
    let mut tmax = f32::INFINITY;
    let mut hit = u32::MAX;
    let mut stack: Vec<(u32, f32)> = Vec::with_capacity(64);
    if bvh.nodes.is_empty() {
        return hit;
    }
    stack.push((0, 0.0));
    while let Some((i, entry)) = stack.pop() {
        if entry > tmax {
            continue;
        }
        let n = &bvh.nodes[i as usize];
        let scale = n.e.map(|e| f32::from_bits((e as u32) << 23));
        let p: [f32; 3] = n.p.into();
        let mut inner: [(u32, f32); 8] = [(0, 0.0); 8];
        let mut count = 0;
        let mut internal_before = 0u32;
        for slot in 0..8 {
            let meta = n.child_meta[slot];
            let is_internal = (n.imask >> slot) & 1 == 1;
            if meta == 0 && !is_internal {
                continue;
            }
            let q_lo = [
                n.child_min_x[slot],
                n.child_min_y[slot],
                n.child_min_z[slot],
            ];
            let q_hi = [
                n.child_max_x[slot],
                n.child_max_y[slot],
                n.child_max_z[slot],
            ];
            let mut lo = [0.0f32; 3];
            let mut hi = [0.0f32; 3];
            for k in 0..3 {
                let (a, b) = (
                    p[k] + q_lo[k] as f32 * scale[k],
                    p[k] + q_hi[k] as f32 * scale[k],
                );
                let pad = a.abs().max(b.abs()).max(p[k].abs()) * (4.0 * f32::EPSILON);
                lo[k] = a - pad;
                hi[k] = b + pad;
            }
            let e = traversal::slab_entry(&ray, &lo, &hi, 0.0, tmax);
            if is_internal {
                if let Some(e) = e {
                    inner[count] = (n.child_base_idx + internal_before, e);
                    count += 1;
                }
                internal_before += 1;
            } else if e.is_some() {
                let first = n.primitive_base_idx + (meta & 0x1F) as u32;
                let prims = (meta >> 5).count_ones();
                for s in first..first + prims {
                    if let Some(h) = traversal::watertight(&ray, &tris[s as usize], 0.0, tmax) {
                        tmax = h.t;
                        hit = bvh.primitive_indices[s as usize];
                    }
                }
            }
        }
        let inner = &mut inner[..count];
        inner.sort_by(|a, b| b.1.total_cmp(&a.1));
        stack.extend_from_slice(inner);
    }
    hit
}

/// Runs the jobs round-robin `ROUNDS` times and returns each one's best time: other load on
/// the machine hits every job alike.
fn interleaved(jobs: &mut [&mut dyn FnMut()]) -> Vec<f64> {
    const ROUNDS: usize = 7;
    let mut best = vec![f64::INFINITY; jobs.len()];
    for _ in 0..ROUNDS {
        for (j, job) in jobs.iter_mut().enumerate() {
            let t = Instant::now();
            job();
            best[j] = best[j].min(t.elapsed().as_secs_f64());
        }
    }
    best
}

fn run_scene(name: &str, v: &[[f32; 3]], f: &[[u32; 3]]) {
    println!("\n## {name}: {} triangles\n", f.len());
    let memory = Memory(vec![
        bytemuck::cast_slice(v).to_vec(),
        bytemuck::cast_slice(f).to_vec(),
    ]);
    let input = TriangleArray::new(
        BufferView::new(buffer(0)),
        v.len() as u32,
        GeometryFlags::DISABLE_ANYHIT,
    )
    .with_indices(BufferView::new(buffer(1)), f.len() as u32);
    let inputs = [BuildInput::Triangles(input)];
    let (primary, incoherent) = rays(v);
    let mrays = |n: usize, t: f64| n as f64 / t / 1e6;

    // BVH2 presets, and CWBVH from obvhs over the same boxes.
    let presets = [
        (
            "BVH2 very_fast_build (PREFER_FAST_BUILD)",
            BuildFlags::PREFER_FAST_BUILD,
        ),
        ("BVH2 fast_build (default)", BuildFlags::NONE),
        (
            "BVH2 medium_build (PREFER_FAST_TRACE)",
            BuildFlags::PREFER_FAST_TRACE,
        ),
    ];
    let mut scenes = Vec::new();
    let mut build_times = Vec::new();
    for (_, flags) in presets {
        let options = AccelBuildOptions {
            flags,
            ..Default::default()
        };
        let mut gas = None;
        let t = interleaved(&mut [&mut || {
            gas = Some(Gas::build(&options, &inputs, &memory, &memory).expect("build"))
        }])[0];
        let gas = gas.expect("built");
        let nodes = gas.bvh.nodes().len();
        let mut scene = SceneTable::new(DeviceId(1));
        let root = scene.set(0, 0, Arc::new(Traversable::Geometry(gas)));
        scenes.push((scene, root, nodes));
        build_times.push(t);
    }
    let boxes: Vec<obvhs::aabb::Aabb> = f
        .iter()
        .map(|t| {
            let mut b = obvhs::aabb::Aabb::INVALID;
            for &i in t {
                b.extend(v[i as usize].into());
            }
            b
        })
        .collect();
    let mut cws = Vec::new();
    for params in [
        obvhs::BvhBuildParams::fast_build(),
        obvhs::BvhBuildParams::medium_build(),
    ] {
        let mut cw = None;
        let t = interleaved(&mut [&mut || {
            cw = Some(obvhs::cwbvh::builder::build_cwbvh(
                &boxes,
                params,
                &mut Default::default(),
            ))
        }])[0];
        let cw = cw.expect("built");
        let tris: Vec<[[f32; 3]; 3]> = cw
            .primitive_indices
            .iter()
            .map(|&p| f[p as usize].map(|i| v[i as usize]))
            .collect();
        cws.push((cw, tris, t));
    }
    let reference = trace_all::<Robust>(&scenes[1].0, scenes[1].1, &primary);
    for (cw, tris, _) in &cws {
        let hits: Vec<u32> = primary
            .iter()
            .map(|&(o, d)| cwbvh_trace(cw, tris, o, d))
            .collect();
        let same = reference.iter().zip(&hits).filter(|(a, b)| a == b).count();
        assert!(
            same as f64 >= 0.999 * hits.len() as f64,
            "CWBVH and BVH2 disagree on {} rays",
            hits.len() - same
        );
    }
    for rays in [&primary, &incoherent] {
        let kind = if std::ptr::eq(rays, &primary) {
            "primary"
        } else {
            "incoherent"
        };
        let [s0, s1, s2] = [0, 1, 2].map(|i| (&scenes[i].0, scenes[i].1));
        let (c0, c1) = (&cws[0], &cws[1]);
        let times = interleaved(&mut [
            &mut || drop(trace_all::<Robust>(s0.0, s0.1, rays)),
            &mut || drop(trace_all::<Robust>(s1.0, s1.1, rays)),
            &mut || drop(trace_all::<Robust>(s2.0, s2.1, rays)),
            &mut || {
                drop(
                    rays.iter()
                        .map(|&(o, d)| cwbvh_trace(&c0.0, &c0.1, o, d))
                        .collect::<Vec<u32>>(),
                )
            },
            &mut || {
                drop(
                    rays.iter()
                        .map(|&(o, d)| cwbvh_trace(&c1.0, &c1.1, o, d))
                        .collect::<Vec<u32>>(),
                )
            },
        ]);
        println!(
            "{kind} rays, {} of them, watertight + conservative, 1 thread:\n",
            rays.len()
        );
        println!("| structure | build s | nodes | Mrays/s |");
        println!("|---|---|---|---|");
        for (i, (label, _)) in presets.iter().enumerate() {
            println!(
                "| {label} | {:.3} | {} | {:.2} |",
                build_times[i],
                scenes[i].2,
                mrays(rays.len(), times[i])
            );
        }
        for (i, label) in ["CWBVH fast_build", "CWBVH medium_build"]
            .iter()
            .enumerate()
        {
            println!(
                "| {label} | {:.3} | {} | {:.2} |",
                cws[i].2,
                cws[i].0.nodes.len(),
                mrays(rays.len(), times[3 + i])
            );
        }
        println!();
    }
    // The accuracy options on the default build.
    let (scene, root) = (&scenes[1].0, scenes[1].1);
    println!("accuracy options on the default build, 1 thread (Mrays/s primary / incoherent):\n");
    let labels = [
        "watertight + conservative (default)",
        "watertight + plain",
        "Möller–Trumbore + conservative",
        "Möller–Trumbore + plain (FAST)",
    ];
    let mut rates = [[0.0f64; 2]; 4];
    for (k, rays) in [&primary, &incoherent].into_iter().enumerate() {
        let times = interleaved(&mut [
            &mut || drop(trace_all::<Robust>(scene, root, rays)),
            &mut || drop(trace_all::<WatertightPlain>(scene, root, rays)),
            &mut || drop(trace_all::<MtConservative>(scene, root, rays)),
            &mut || drop(trace_all::<Fast>(scene, root, rays)),
        ]);
        for i in 0..4 {
            rates[i][k] = mrays(rays.len(), times[i]);
        }
    }
    for (i, label) in labels.iter().enumerate() {
        println!("- {label}: {:.2} / {:.2}", rates[i][0], rates[i][1]);
    }
}

/// `OPTIK_BENCH_ONLY=<robust|watertight-plain|mt-conservative|fast|none>`: build the default
/// BVH and trace both ray sets once with that option (`none`: build only), for instruction
/// counts under `valgrind --tool=callgrind` (stable on a loaded machine, unlike times).
fn only(option: &str, v: &[[f32; 3]], f: &[[u32; 3]]) {
    let memory = Memory(vec![
        bytemuck::cast_slice(v).to_vec(),
        bytemuck::cast_slice(f).to_vec(),
    ]);
    let input = TriangleArray::new(
        BufferView::new(buffer(0)),
        v.len() as u32,
        GeometryFlags::DISABLE_ANYHIT,
    )
    .with_indices(BufferView::new(buffer(1)), f.len() as u32);
    let gas = Gas::build(
        &AccelBuildOptions::default(),
        &[BuildInput::Triangles(input)],
        &memory,
        &memory,
    )
    .expect("build");
    let mut scene = SceneTable::new(DeviceId(1));
    let root = scene.set(0, 0, Arc::new(Traversable::Geometry(gas)));
    let (primary, incoherent) = rays(v);
    let all: Vec<([f32; 3], [f32; 3])> = primary.into_iter().chain(incoherent).collect();
    let hits = match option {
        "robust" => trace_all::<Robust>(&scene, root, &all),
        "watertight-plain" => trace_all::<WatertightPlain>(&scene, root, &all),
        "mt-conservative" => trace_all::<MtConservative>(&scene, root, &all),
        "fast" => trace_all::<Fast>(&scene, root, &all),
        _ => Vec::new(),
    };
    println!(
        "{option}: {} rays, {} hits",
        all.len(),
        hits.iter().filter(|&&h| h != u32::MAX).count()
    );
}

fn main() {
    if let Ok(option) = std::env::var("OPTIK_BENCH_ONLY") {
        let scene = match std::env::args().nth(1) {
            Some(path) => load_obj(&path),
            None => Some(bumpy_sphere(300)),
        };
        if let Some((v, f)) = scene {
            only(&option, &v, &f);
        }
        return;
    }
    let (v, f) = bumpy_sphere(300);
    run_scene("bumpy sphere", &v, &f);
    if let Some(path) = std::env::args().nth(1) {
        match load_obj(&path) {
            Some((v, f)) => run_scene(&path, &v, &f),
            None => println!("\n{path}: cannot read; skipped"),
        }
    }
}
