//! Traversal tests without a device: structures built from in-memory buffers, a closest-hit
//! handler, and the hard cases of docs/numerics.md.

use super::*;
use crate::accel::{Gas, MicromapArrayData, MicromapLookup, SceneTable, Traversable};
use optik_accel::decode::BufferBytes;
use optik_api::{
    AccelBuildOptions, Buffer, BufferView, BuildInput, DeviceId, GeometryFlags, Handle,
    MicromapArray, PrimitiveTypeFlags, RawHandle, RayFlags, Result, TraversableHandle,
    TriangleArray,
};
use std::collections::HashMap;
use std::sync::Arc;

/// Buffers in memory, for builders.
#[derive(Default)]
pub(crate) struct Memory {
    buffers: HashMap<Buffer, Vec<u8>>,
}

impl Memory {
    pub(crate) fn add(&mut self, bytes: &[u8]) -> Buffer {
        let b = Buffer::from_raw(RawHandle {
            device: DeviceId(0),
            slot: self.buffers.len() as u32,
            generation: 0,
        });
        self.buffers.insert(b, bytes.to_vec());
        b
    }
}

impl BufferBytes for Memory {
    fn bytes(&self, buffer: Buffer) -> Result<&[u8]> {
        Ok(&self.buffers[&buffer])
    }
}

impl MicromapLookup for Memory {
    fn micromap_array(&self, _: MicromapArray) -> Result<Arc<MicromapArrayData>> {
        Err(optik_api::Error::invalid("no micromaps in these tests"))
    }
}

pub(crate) fn triangle_gas(vertices: &[[f32; 3]], indices: &[[u32; 3]]) -> Gas {
    let mut m = Memory::default();
    let vb = m.add(bytemuck::cast_slice(vertices));
    let ib = m.add(bytemuck::cast_slice(indices));
    let input = TriangleArray::new(
        BufferView::new(vb),
        vertices.len() as u32,
        GeometryFlags::DISABLE_ANYHIT,
    )
    .with_indices(BufferView::new(ib), indices.len() as u32);
    Gas::build(
        &AccelBuildOptions::default(),
        &[BuildInput::Triangles(input)],
        &m,
        &m,
    )
    .unwrap()
}

/// Keeps the closest candidate, like a pipeline with only closest-hit programs.
struct Closest {
    tmax: f32,
    hit: Option<(f32, u32, u32)>,
    candidates: u32,
    exceptions: Vec<i32>,
    /// Every candidate's `(t, primitive, barycentrics)` (floats as bits), in the order the
    /// walk found them.
    log: Vec<(u32, u32, [u32; 2])>,
}

impl Closest {
    fn new(tmax: f32) -> Closest {
        Closest {
            tmax,
            hit: None,
            candidates: 0,
            exceptions: Vec::new(),
            log: Vec::new(),
        }
    }
}

impl Handler for Closest {
    fn t_max(&self) -> f32 {
        self.tmax
    }
    fn done(&self) -> bool {
        false
    }
    fn candidate<S: Spec>(&mut self, c: &Candidate<'_>, _: &Path, _: CandidateFate) {
        self.candidates += 1;
        let barycentrics = match c.data {
            HitData::Triangle { barycentrics, .. } => barycentrics.map(f32::to_bits),
            _ => [0; 2],
        };
        self.log
            .push((c.t.to_bits(), c.info.primitive_index, barycentrics));
        assert!(c.t < self.tmax, "candidates lie before the committed hit");
        self.tmax = c.t;
        self.hit = Some((c.t, c.info.primitive_index, c.hit_kind));
    }
    fn custom<S: Spec>(&mut self, _: &CustomPrimitive<'_>, _: &Path, _: CandidateFate) {}
    fn traversal_exception(&mut self, code: i32) {
        self.exceptions.push(code);
    }
}

type Robust = Specialised<false, true, false, true, true>;
type Fast = Specialised<false, true, false, false, false>;

const CONFIG: TraceConfig = TraceConfig {
    primitive_types: PrimitiveTypeFlags::ALL,
    intersection: true,
    micromaps: true,
    debug_exceptions: true,
    max_graph_depth: 16,
};

fn scene_of(gas: Gas) -> (SceneTable, TraversableHandle) {
    let mut scene = SceneTable::new(DeviceId(7));
    let h = scene.set(0, 0, Arc::new(Traversable::Geometry(gas)));
    (scene, h)
}

fn ray(origin: [f32; 3], direction: [f32; 3]) -> TraceRay {
    TraceRay {
        origin,
        direction,
        tmin: 0.0,
        tmax: f32::INFINITY,
        time: 0.0,
        mask: 0xFF,
        flags: RayFlags::NONE,
    }
}

fn closest<S: Spec>(scene: &SceneTable, root: TraversableHandle, r: &TraceRay) -> Closest {
    let mut h = Closest::new(r.tmax);
    trace::<S, _>(scene, root, r, &CONFIG, &mut h);
    h
}

/// The traversal tests' xorshift generator (seeded per test, so each test's cases are fixed).
pub(super) struct Rng(pub(super) u64);
impl Rng {
    /// A number in `[0, 1)`.
    pub(super) fn f(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }

    /// A point with coordinates in `[-s/2, s/2)`.
    pub(super) fn v(&mut self, s: f32) -> [f32; 3] {
        [
            (self.f() - 0.5) * s,
            (self.f() - 0.5) * s,
            (self.f() - 0.5) * s,
        ]
    }
}

/// docs/numerics.md, "Leak test": a closed 16×16 UV sphere, interior vertices pushed out
/// radially by up to 50 %, centred at `centre` with radius `scale`.
fn jittered_sphere(centre: [f64; 3], scale: f64, rng: &mut Rng) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let (rings, segs) = (16u32, 16u32);
    let mut v = Vec::new();
    let point = |theta: f64, phi: f64, r: f64| -> [f32; 3] {
        [
            (centre[0] + scale * r * theta.sin() * phi.cos()) as f32,
            (centre[1] + scale * r * theta.cos()) as f32,
            (centre[2] + scale * r * theta.sin() * phi.sin()) as f32,
        ]
    };
    v.push(point(0.0, 0.0, 1.0));
    for i in 1..rings {
        for j in 0..segs {
            let theta = std::f64::consts::PI * i as f64 / rings as f64;
            let phi = 2.0 * std::f64::consts::PI * j as f64 / segs as f64;
            v.push(point(theta, phi, 1.0 + 0.5 * rng.f() as f64));
        }
    }
    v.push(point(std::f64::consts::PI, 0.0, 1.0));
    let south = v.len() as u32 - 1;
    let at = |i: u32, j: u32| 1 + (i - 1) * segs + j % segs;
    let mut idx = Vec::new();
    for j in 0..segs {
        idx.push([0, at(1, j + 1), at(1, j)]);
        idx.push([south, at(rings - 1, j), at(rings - 1, j + 1)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segs {
            idx.push([at(i, j), at(i, j + 1), at(i + 1, j)]);
            idx.push([at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)]);
        }
    }
    (v, idx)
}

/// Rays from inside a closed mesh aimed at shared edges and at vertices: the watertight
/// test with conservative boxes must never miss (docs/numerics.md, "Leak test").
#[test]
fn closed_mesh_never_leaks() {
    let mut rng = Rng(0x5eed);
    let mut fast_misses = 0;
    let configs: &[(f64, f64)] = &[
        (0.0, 1e-4),
        (0.0, 1e-2),
        (0.0, 1.0),
        (0.0, 1e2),
        (0.0, 1e4),
        (1e5, 1.0),
        (1e5, 1e2),
        (1e5, 1e4),
    ];
    for &(offset, scale) in configs {
        let centre = [offset, offset * 0.7, offset * 0.3];
        let (v, idx) = jittered_sphere(centre, scale, &mut rng);
        let (scene, root) = scene_of(triangle_gas(&v, &idx));
        for target_kind in ["edge", "vertex"] {
            let mut misses = 0;
            for _ in 0..4000 {
                // Origin uniformly inside the ball of radius scale / 2 (rejection sampling).
                let o = loop {
                    let p = [
                        rng.f() * 2.0 - 1.0,
                        rng.f() * 2.0 - 1.0,
                        rng.f() * 2.0 - 1.0,
                    ];
                    if p[0] * p[0] + p[1] * p[1] + p[2] * p[2] <= 1.0 {
                        break std::array::from_fn::<f32, 3, _>(|k| {
                            (centre[k] + 0.5 * scale * p[k] as f64) as f32
                        });
                    }
                };
                let tri = idx[(rng.f() * idx.len() as f32) as usize % idx.len()];
                let target = if target_kind == "vertex" {
                    v[tri[(rng.f() * 3.0) as usize % 3] as usize]
                } else {
                    let (a, b) = (v[tri[0] as usize], v[tri[1] as usize]);
                    let f = rng.f();
                    std::array::from_fn(|k| a[k] + (b[k] - a[k]) * f)
                };
                let d = [target[0] - o[0], target[1] - o[1], target[2] - o[2]];
                if d == [0.0; 3] {
                    continue;
                }
                let r = ray(o, d);
                if closest::<Robust>(&scene, root, &r).hit.is_none() {
                    misses += 1;
                }
                if closest::<Fast>(&scene, root, &r).hit.is_none() {
                    fast_misses += 1;
                }
            }
            assert_eq!(
                misses, 0,
                "offset {offset}, scale {scale}, {target_kind}: watertight traversal leaked"
            );
        }
    }
    // The same rays leak through Möller–Trumbore: the test can see a leak.
    assert!(
        fast_misses > 0,
        "Möller–Trumbore with plain boxes did not leak once; the test rays are too easy"
    );
}

#[test]
fn signed_zero_rays_give_identical_answers_through_a_bvh() {
    // docs/numerics.md F0: a quad wall at x = 10 over [0, 1]² and one cell beyond (so rays on the
    // unit square's border cross shared edges, not the wall's own border, where the
    // tie-break may go either way), rays with d = (1, ±0, 0).
    let mut v = Vec::new();
    let mut idx = Vec::new();
    for i in -1..33i32 {
        for j in -1..33i32 {
            let (y, z) = (i as f32 / 32.0, j as f32 / 32.0);
            let base = v.len() as u32;
            v.extend([
                [10.0, y, z],
                [10.0, y + 1.0 / 32.0, z],
                [10.0, y + 1.0 / 32.0, z + 1.0 / 32.0],
                [10.0, y, z + 1.0 / 32.0],
            ]);
            idx.push([base, base + 1, base + 2]);
            idx.push([base, base + 2, base + 3]);
        }
    }
    let (scene, root) = scene_of(triangle_gas(&v, &idx));
    for i in 0..50 {
        for j in 0..50 {
            let o = [0.0, i as f32 / 49.0, j as f32 / 49.0];
            let plus = closest::<Robust>(&scene, root, &ray(o, [1.0, 0.0, 0.0])).hit;
            let minus = closest::<Robust>(&scene, root, &ray(o, [1.0, -0.0, -0.0])).hit;
            assert!(plus.is_some(), "{o:?}");
            assert_eq!(plus, minus, "{o:?}");
        }
    }
}

#[test]
fn degenerate_and_nan_triangles_never_hit_nor_disturb_neighbours() {
    let mut rng = Rng(3);
    let mut v = Vec::new();
    let mut good = Vec::new();
    for i in 0..200u32 {
        let c = [rng.f() * 10.0, rng.f() * 10.0, 5.0 + rng.f()];
        v.extend([
            [c[0], c[1], c[2]],
            [c[0] + 0.5, c[1], c[2]],
            [c[0], c[1] + 0.5, c[2]],
        ]);
        good.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    let mut all = good.clone();
    // Interleave bad triangles sharing the good vertices' neighbourhood.
    for i in 0..200u32 {
        let base = v.len() as u32;
        let c = v[3 * i as usize];
        let bad: [[f32; 3]; 3] = match i % 4 {
            0 => [c, c, c],
            1 => {
                // Exactly collinear: coordinates on a 1/8 grid.
                let g = c.map(|x| (x * 8.0).round() / 8.0);
                [
                    g,
                    [g[0] + 1.0, g[1] + 1.0, g[2]],
                    [g[0] + 2.0, g[1] + 2.0, g[2]],
                ]
            }
            2 => [c, [f32::NAN, c[1], c[2]], [c[0], c[1] + 1.0, c[2]]],
            _ => [
                [c[0], c[1], f32::INFINITY],
                [c[0] + 1.0, c[1], c[2]],
                [c[0], c[1] + 1.0, c[2]],
            ],
        };
        v.extend(bad);
        all.push([base, base + 1, base + 2]);
    }
    let (clean, clean_root) = scene_of(triangle_gas(&v, &good));
    let gas = triangle_gas(&v, &all);
    assert_eq!(gas.num_slots(), 200, "bad triangles get no slot");
    let (dirty, dirty_root) = scene_of(gas);
    for _ in 0..3000 {
        let o = [rng.f() * 10.0, rng.f() * 10.0, 0.0];
        let r = ray(o, [rng.f() * 0.1, rng.f() * 0.1, 1.0]);
        let a = closest::<Robust>(&clean, clean_root, &r).hit;
        let b = closest::<Robust>(&dirty, dirty_root, &r).hit;
        assert_eq!(a, b);
        if let Some(h) = b {
            assert!(h.1 < 200, "a bad triangle was hit");
        }
    }
}

#[test]
fn unsupported_primitive_types_are_skipped_with_a_debug_exception() {
    let (scene, root) = scene_of(triangle_gas(
        &[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]],
        &[[0, 1, 2]],
    ));
    let r = ray([0.2, 0.2, 0.0], [0.0, 0.0, 1.0]);
    let config = TraceConfig {
        primitive_types: PrimitiveTypeFlags::SPHERE,
        ..CONFIG
    };
    let mut h = Closest::new(f32::INFINITY);
    trace::<Robust, _>(&scene, root, &r, &config, &mut h);
    assert!(h.hit.is_none());
    assert_eq!(
        h.exceptions,
        vec![optik_api::semantics::exception::UNSUPPORTED_PRIMITIVE_TYPE]
    );
    // Stale and foreign handles miss with INVALID_TRAVERSABLE.
    let mut h = Closest::new(f32::INFINITY);
    let stale = crate::accel::handle::encode(DeviceId(7), 0, 1);
    trace::<Robust, _>(&scene, stale, &r, &CONFIG, &mut h);
    let foreign = crate::accel::handle::encode(DeviceId(8), 0, 0);
    trace::<Robust, _>(&scene, foreign, &r, &CONFIG, &mut h);
    trace::<Robust, _>(
        &scene,
        TraversableHandle(0xdead_beef_0000_0000),
        &r,
        &CONFIG,
        &mut h,
    );
    trace::<Robust, _>(&scene, TraversableHandle::NULL, &r, &CONFIG, &mut h);
    assert!(h.hit.is_none());
    assert_eq!(
        h.exceptions,
        vec![optik_api::semantics::exception::INVALID_TRAVERSABLE; 3]
    );
}

/// A triangle structure whose wide tree is a chain of `n` nodes: node `i` holds triangle
/// `i` (x in `[i, i + 0.5]`, y in `[0, 1]`, z = 1) as a leaf in lane 0 and the rest of the
/// chain, in the structure's box, in lane 1. A ray along +z under triangle `i` enters both
/// children of node `i` and only the rest of the chain elsewhere.
fn triangle_chain(n: u32) -> Gas {
    use crate::accel::wide::{TriangleBlock, WideBvh, WideNode};
    let mut v = Vec::new();
    let mut idx = Vec::new();
    for i in 0..n {
        let x = i as f32;
        v.extend([[x, 0.0, 1.0], [x + 0.5, 0.0, 1.0], [x, 1.0, 1.0]]);
        idx.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    let mut gas = triangle_gas(&v, &idx);
    let crate::accel::Geometry::Triangles(tris) = &gas.geometry else {
        unreachable!("a triangle structure")
    };
    let slots = tris.keys[0].clone();
    let empty = WideNode::EMPTY;
    let mut chain = WideBvh {
        nodes: vec![empty; n as usize],
        blocks: Vec::new(),
        // No classes: the blocks' records are read from the structure's.
        classes: Vec::new(),
        depth: n,
        root_bounds: None,
    };
    for (i, tri) in slots.iter().enumerate() {
        let mut block = TriangleBlock {
            vertices: [[[0.0; 4]; 3]; 3],
            primitives: [0; 4],
            first_slot: i as u32,
            classes: [0; 4],
            lanes: 1,
        };
        for (vi, vertex) in tri.iter().enumerate() {
            for (a, &c) in vertex.iter().enumerate() {
                block.vertices[vi][a][0] = c;
            }
        }
        block.classes[0] = crate::accel::wide::CLASS_IN_GAS;
        chain.blocks.push(block);
        let node = &mut chain.nodes[i];
        for a in 0..3 {
            node.min[a][0] = tri.iter().map(|p| p[a]).fold(f32::INFINITY, f32::min);
            node.max[a][0] = tri.iter().map(|p| p[a]).fold(f32::NEG_INFINITY, f32::max);
            // The rest of the chain, inside the scene's box.
            node.min[a][1] = gas.bounds.min[a];
            node.max[a][1] = gas.bounds.max[a];
        }
        (node.first[0], node.count[0]) = (i as u32, 1);
        if i + 1 < slots.len() {
            node.first[1] = i as u32 + 1;
        } else {
            for a in 0..3 {
                (node.min[a][1], node.max[a][1]) = (f32::INFINITY, f32::NEG_INFINITY);
            }
        }
    }
    gas.encoding = chain;
    gas
}

/// A tree deeper than the walk's inline stack (a chain of 80 wide nodes, each with one
/// triangle and the rest of the chain) is walked with a heap stack and still gives every
/// triangle.
#[test]
fn trees_deeper_than_the_inline_stack_are_walked() {
    let n = 80u32;
    let (scene, root) = scene_of(triangle_chain(n));
    for i in 0..n {
        let origin = [i as f32 + 0.125, 0.25, 0.0];
        let h = closest::<Robust>(&scene, root, &ray(origin, [0.0, 0.0, 1.0]));
        assert_eq!(h.hit.map(|(_, p, _)| p), Some(i), "triangle {i}");
    }
}

/// The wide walk visits every leaf the ray enters exactly once, also down a chain of nodes
/// that each enter one child (the walk's one-or-two case writes a copy of a lone child
/// above the stack's top, which must not be counted): [`triangle_chain`]'s 20 nodes, and
/// rays that enter one node's leaf (both children there, one child everywhere else) or
/// none. The leaves run no test, so the interval never shrinks and a child counted twice
/// would be walked twice.
#[test]
fn the_wide_walk_visits_each_entered_leaf_once() {
    let n = 20u32;
    let gas = triangle_chain(n);
    // Rays along +z under each leaf, and one between leaves (x = 0.75: no leaf's box).
    for target in (0..n).map(Some).chain([None]) {
        let x = target.map_or(0.75, |i| i as f32 + 0.125);
        let ray = WideRay::new([x, 0.25, 0.0], [0.0, 0.0, 1.0]);
        let test = slab::Halves::new(&ray, 0.0, true);
        let mut visits = vec![0u32; n as usize];
        let mut h = Closest::new(f32::INFINITY);
        engine::walk_wide_on(&gas.encoding, test, &mut h, |_, first, count| {
            assert_eq!(count, 1);
            visits[first as usize] += 1;
        });
        let expected: Vec<u32> = (0..n).map(|i| u32::from(target == Some(i))).collect();
        assert_eq!(visits, expected, "ray under leaf {target:?}");
    }
}

/// The walk visits the same nodes in the same order with either node test (AVX's and the
/// two 4-lane halves), and the leaves compiled for AVX test triangles as the SSE ones do:
/// the same candidates (distances and barycentrics bit for bit), in the same order, on a
/// soup of random and exactly overlapping triangles (equal entry and hit distances).
#[test]
fn node_tests_walk_in_the_same_order() {
    let mut rng = Rng(0xa5a5);
    let mut v = Vec::new();
    let mut idx = Vec::new();
    for i in 0..3000u32 {
        let c = [rng.f() * 10.0, rng.f() * 10.0, rng.f() * 10.0];
        let e = 0.2 + rng.f();
        v.extend([c, [c[0] + e, c[1], c[2]], [c[0], c[1] + e, c[2] + 0.1]]);
        idx.push([3 * i, 3 * i + 1, 3 * i + 2]);
        if i % 4 == 0 {
            // A copy of the same triangle: a tie at every ray through it.
            idx.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
    }
    let (scene, root) = scene_of(triangle_gas(&v, &idx));
    let walk = |halves: bool, r: &TraceRay| {
        engine::HALVES_ONLY.with(|c| c.set(halves));
        let h = closest::<Robust>(&scene, root, r);
        engine::HALVES_ONLY.with(|c| c.set(false));
        h
    };
    let mut candidates = 0;
    for i in 0..3000 {
        let o = [rng.f() * 14.0 - 2.0, rng.f() * 14.0 - 2.0, -1.0 - rng.f()];
        let mut d = [rng.f() - 0.5, rng.f() - 0.5, 0.2 + rng.f()];
        if i % 5 == 0 {
            d = [0.0, -0.0, 1.0];
        }
        let r = ray(o, d);
        let (a, b) = (walk(false, &r), walk(true, &r));
        assert_eq!(a.log, b.log, "ray {i}");
        candidates += a.log.len();
    }
    assert!(
        candidates > 1000,
        "the rays hit the soup ({candidates} candidates)"
    );
}

/// `misses_bounds` on a node's union box never rejects a ray the node test lets into a
/// child: random nodes and rays, with axis-parallel directions (zero, negative zero, tiny)
/// and origins on the planes of a child or of the union (the NaN distances), both exit
/// widenings, and intervals that start or end inside the boxes.
#[test]
fn the_root_check_rejects_only_rays_the_node_test_rejects() {
    use crate::accel::wide::{NODE_WIDTH, WideNode};
    use slab::NodeTest;
    type Plain = Specialised<false, false, false, true, false>;
    type Conservative = Specialised<false, false, false, true, true>;
    let mut rng = Rng(7);
    let mut rnd = || rng.f();
    let specials = [0.0, -0.0, 1e-40, -1e-40];
    let (mut rejected, mut entered) = (0, 0);
    for i in 0..40000 {
        let mut node = WideNode::EMPTY;
        for lane in 0..NODE_WIDTH {
            if (i + lane) % 5 == 0 {
                continue; // an unused child
            }
            for a in 0..3 {
                let lo = (rnd() - 0.5) * 10.0;
                node.min[a][lane] = lo;
                node.max[a][lane] = lo + rnd() * 4.0;
            }
        }
        let bounds = node.union();
        let mut o: [f32; 3] = std::array::from_fn(|_| (rnd() - 0.5) * 40.0);
        // Towards a point among the boxes, so that many rays enter some.
        let mut d: [f32; 3] = std::array::from_fn(|a| (rnd() - 0.5) * 12.0 - o[a]);
        if i % 3 == 0 {
            let a = (i / 3) % 3;
            d[(a + 1) % 3] = specials[i % 4];
            // On a plane of the union (i even) or of a child.
            o[(a + 1) % 3] = if i % 2 == 0 {
                bounds[i % 4 / 2][(a + 1) % 3]
            } else {
                node.max[(a + 1) % 3][i % NODE_WIDTH]
            };
        }
        let (tmin, tmax) = match i % 4 {
            0 => (3.0, 9.0),
            1 => (0.0, 2.0),
            _ => (0.0, f32::INFINITY),
        };
        for conservative in [false, true] {
            let wide = WideRay::new(o, d);
            let (mask, _) = slab::Halves::new(&wide, tmin, conservative).entry(&node, tmax);
            let skipped = if conservative {
                misses_bounds::<Conservative>(&bounds, o, d, tmin, tmax)
            } else {
                misses_bounds::<Plain>(&bounds, o, d, tmin, tmax)
            };
            // Bit for bit the scalar test on the union box (the vectorised form's promise).
            let scalar = slab::entry_wide(&wide, conservative, &bounds[0], &bounds[1], tmin, tmax);
            assert_eq!(
                skipped,
                !wide.moves() || scalar.is_none(),
                "{o:?} {d:?} [{tmin}, {tmax}] conservative {conservative}"
            );
            if wide.moves() {
                assert!(
                    !(skipped && mask != 0),
                    "{o:?} {d:?} [{tmin}, {tmax}] conservative {conservative}: rejected a ray that enters children {mask:#b}"
                );
            }
            rejected += skipped as u32;
            entered += (mask != 0) as u32;
        }
    }
    // Both outcomes are common, so the check is exercised both ways.
    assert!(rejected > 10000 && entered > 10000, "{rejected} {entered}");
}

/// A pipeline without any-hit programs accepts opaque and non-opaque candidates alike, but
/// still drops the ones the ray's cull flags name (its candidates skip the flag resolution
/// only when the ray culls neither kind): the geometry here is opaque (`DISABLE_ANYHIT`).
/// Face culling drops one side and keeps the other.
#[test]
fn cull_flags_drop_candidates_without_any_hit_programs() {
    const { assert!(!<Robust as Spec>::ANY_HIT) };
    let gas = triangle_gas(
        &[[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]],
        &[[0, 1, 2]],
    );
    let (scene, root) = scene_of(gas);
    let hits = |flags: RayFlags, dz: f32| {
        let r = TraceRay {
            flags,
            ..ray([0.0, 0.0, -dz], [0.0, 0.0, dz])
        };
        closest::<Robust>(&scene, root, &r).hit.is_some()
    };
    assert!(hits(RayFlags::NONE, 1.0));
    assert!(!hits(RayFlags::CULL_DISABLED_ANYHIT, 1.0), "opaque culled");
    assert!(hits(RayFlags::CULL_ENFORCED_ANYHIT, 1.0), "opaque kept");
    let enforced = RayFlags::ENFORCE_ANYHIT;
    assert!(
        !hits(enforced | RayFlags::CULL_ENFORCED_ANYHIT, 1.0),
        "non-opaque culled"
    );
    assert!(
        hits(enforced | RayFlags::CULL_DISABLED_ANYHIT, 1.0),
        "non-opaque kept"
    );
    for dz in [1.0, -1.0] {
        let front = hits(RayFlags::CULL_BACK_FACING_TRIANGLES, dz);
        let back = hits(RayFlags::CULL_FRONT_FACING_TRIANGLES, dz);
        assert!(front != back, "one side culled, the other kept ({dz})");
    }
}

/// `blocks_root` names the roots whose traces walk triangle blocks straight away, and
/// `trace_blocks` from one finds what `trace` finds, candidate for candidate; every other
/// root (null, stale, foreign, triangles the pipeline does not trace) is left to `trace`,
/// which reports them.
#[test]
fn blocks_roots_trace_as_trace_does() {
    let mut rng = Rng(11);
    let (v, idx) = jittered_sphere([0.0; 3], 1.0, &mut rng);
    let (scene, root) = scene_of(triangle_gas(&v, &idx));
    let g = blocks_root::<Robust>(&scene, root, &CONFIG).expect("static triangles walk blocks");
    let mut hits = 0;
    for i in 0..2000 {
        let r = TraceRay {
            tmin: if i % 4 == 0 { 0.5 } else { 0.0 },
            ..ray(rng.v(4.0), rng.v(2.0))
        };
        let mut h = Closest::new(r.tmax);
        trace_blocks::<Robust, _>(&scene, g, &r, &CONFIG, &mut h);
        let expected = closest::<Robust>(&scene, root, &r);
        assert_eq!(h.log, expected.log, "ray {i}");
        hits += h.hit.is_some() as u32;
    }
    assert!(hits > 200, "{hits} of the rays hit the sphere");
    let stale = crate::accel::handle::encode(DeviceId(7), 0, 1);
    let foreign = crate::accel::handle::encode(DeviceId(8), 0, 0);
    for other in [TraversableHandle::NULL, stale, foreign] {
        assert!(blocks_root::<Robust>(&scene, other, &CONFIG).is_none());
    }
    let spheres_only = TraceConfig {
        primitive_types: PrimitiveTypeFlags::SPHERE,
        ..CONFIG
    };
    assert!(blocks_root::<Robust>(&scene, root, &spheres_only).is_none());
}

/// `accel::memory_usage` bounds what a build occupies when every triangle has a record class
/// of its own (per-primitive SBT offsets, all different: the most classes a structure can
/// have) and triangles lie far apart.
#[test]
fn memory_usage_bounds_a_build_with_a_class_per_triangle() {
    let n = 64u32;
    let mut m = Memory::default();
    let vertices: Vec<[f32; 3]> = (0..n)
        .flat_map(|i| {
            let x = i as f32 * 100.0;
            [[x, 0.0, 0.0], [x + 1.0, 0.0, 0.0], [x, 1.0, 0.0]]
        })
        .collect();
    let offsets: Vec<u32> = (0..n).collect();
    let vb = m.add(bytemuck::cast_slice(&vertices));
    let ob = m.add(bytemuck::cast_slice(&offsets));
    let mut input = TriangleArray::new(BufferView::new(vb), 3 * n, GeometryFlags::NONE);
    input.flags = vec![GeometryFlags::NONE; n as usize];
    input.sbt_index_offsets = Some(optik_api::SbtIndexOffsets {
        buffer: BufferView::new(ob),
        size_in_bytes: 4,
        stride: 0,
    });
    let inputs = [BuildInput::Triangles(input)];
    let gas = Gas::build(&AccelBuildOptions::default(), &inputs, &m, &m).unwrap();
    assert_eq!(gas.encoding.classes.len(), n as usize);
    let bound = crate::accel::memory_usage(&inputs, 1).output_size_in_bytes;
    assert!(
        gas.size_in_bytes() <= bound,
        "{} bytes built, {bound} bounded",
        gas.size_in_bytes()
    );
}
