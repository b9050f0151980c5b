//! Scene and ray generators shared by the catalog: a seeded random number generator,
//! meshes (quads, fans, cubes, spheres, terrains, knots, the CTS subdivided square) and
//! transforms.

use optik::{GeometryFlags, Matrix3x4};

use crate::case::*;
use crate::kit::Ray;
use crate::oracle::exec::Ctx;
use crate::oracle::model::Models;
use crate::scene::{Gas, GeomInput, Node, Scene, Triangles};

/// A small seeded generator (PCG-XSH-RR 32): cases are the same on every machine.
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        let mut r = Rng(seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407));
        r.next_u32();
        r
    }

    /// The next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.0;
        self.0 = old
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A float in [0, 1).
    pub fn unit(&mut self) -> f64 {
        self.next_u32() as f64 / 4294967296.0
    }

    /// A float in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// A direction uniformly distributed on the unit sphere.
    pub fn direction(&mut self) -> [f64; 3] {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, std::f64::consts::TAU);
        let r = (1.0 - z * z).max(0.0).sqrt();
        [r * phi.cos(), r * phi.sin(), z]
    }
}

/// `f64` triple to `f32`.
pub fn v32(v: [f64; 3]) -> [f32; 3] {
    v.map(|c| c as f32)
}

/// An indexed mesh.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Vertices.
    pub vertices: Vec<[f32; 3]>,
    /// Triangles, counter-clockwise seen from outside (the front).
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// The mesh as a triangle input with one record.
    pub fn input(&self, flags: GeometryFlags) -> GeomInput {
        GeomInput::Triangles(Triangles::mesh(
            self.vertices.clone(),
            self.triangles.clone(),
            flags,
        ))
    }

    /// A GAS of this mesh alone.
    pub fn gas(&self, flags: GeometryFlags) -> Gas {
        Gas::new(vec![self.input(flags)])
    }

    /// The mesh moved and scaled: `v · s + offset`, rounded to `f32`.
    pub fn placed(&self, scale: f64, offset: [f64; 3]) -> Mesh {
        Mesh {
            vertices: self
                .vertices
                .iter()
                .map(|v| std::array::from_fn(|i| (v[i] as f64 * scale + offset[i]) as f32))
                .collect(),
            triangles: self.triangles.clone(),
        }
    }

    /// The midpoint of the edge between two vertices, computed in `f64`.
    pub fn midpoint(&self, a: u32, b: u32) -> [f64; 3] {
        let (a, b) = (self.vertices[a as usize], self.vertices[b as usize]);
        std::array::from_fn(|i| 0.5 * (a[i] as f64 + b[i] as f64))
    }

    /// Every undirected edge, once.
    pub fn edges(&self) -> Vec<(u32, u32)> {
        let mut e: Vec<(u32, u32)> = self
            .triangles
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .map(|(a, b)| (a.min(b), a.max(b)))
            .collect();
        e.sort();
        e.dedup();
        e
    }

    /// The centroid of the vertices.
    pub fn centroid(&self) -> [f64; 3] {
        let n = self.vertices.len().max(1) as f64;
        std::array::from_fn(|i| self.vertices.iter().map(|v| v[i] as f64).sum::<f64>() / n)
    }
}

/// A unit axis-aligned cube `[lo, hi]³`, 12 triangles facing out.
pub fn cube(lo: f32, hi: f32) -> Mesh {
    let v = |x: u32, y: u32, z: u32| {
        [
            if x == 1 { hi } else { lo },
            if y == 1 { hi } else { lo },
            if z == 1 { hi } else { lo },
        ]
    };
    let vertices: Vec<[f32; 3]> = (0..8)
        .map(|i| v(i & 1, (i >> 1) & 1, (i >> 2) & 1))
        .collect();
    // Faces as quads (a, b, c, d) counter-clockwise seen from outside.
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let triangles = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    Mesh {
        vertices,
        triangles,
    }
}

/// An icosphere of radius 1 at the origin, subdivided `levels` times, facing out
/// (`optik::shapes::icosphere`, the mesh the benchmarks and backend tests use too).
pub fn icosphere(levels: u32) -> Mesh {
    let (vertices, triangles) = optik::shapes::icosphere(levels);
    Mesh {
        vertices,
        triangles,
    }
}

/// A latitude-longitude sphere of radius 1 with `lat` × `lon` cells, facing out.
pub fn uv_sphere(lat: u32, lon: u32) -> Mesh {
    let mut vertices = vec![[0.0f32, 0.0, 1.0]];
    for i in 1..lat {
        let th = std::f64::consts::PI * i as f64 / lat as f64;
        for j in 0..lon {
            let ph = std::f64::consts::TAU * j as f64 / lon as f64;
            vertices.push(v32([th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()]));
        }
    }
    vertices.push([0.0, 0.0, -1.0]);
    let south = vertices.len() as u32 - 1;
    let ring = |i: u32, j: u32| 1 + (i - 1) * lon + (j % lon);
    let mut triangles = Vec::new();
    for j in 0..lon {
        triangles.push([0, ring(1, j), ring(1, j + 1)]);
        triangles.push([south, ring(lat - 1, j + 1), ring(lat - 1, j)]);
    }
    for i in 1..lat - 1 {
        for j in 0..lon {
            let (a, b, c, d) = (
                ring(i, j),
                ring(i, j + 1),
                ring(i + 1, j + 1),
                ring(i + 1, j),
            );
            triangles.push([a, d, c]);
            triangles.push([a, c, b]);
        }
    }
    Mesh {
        vertices,
        triangles,
    }
}

/// A fan of `n` triangles around `(0, 0, z)` with rim radius `r`, counter-clockwise seen
/// from +z; vertex 0 is the centre.
pub fn fan(n: u32, r: f64, z: f32) -> Mesh {
    let mut vertices = vec![[0.0, 0.0, z]];
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        vertices.push([(r * a.cos()) as f32, (r * a.sin()) as f32, z]);
    }
    let triangles = (0..n).map(|i| [0, 1 + i, 1 + (i + 1) % n]).collect();
    Mesh {
        vertices,
        triangles,
    }
}

/// A height field over `[0, 1]²` with `n` × `n` cells.
pub fn terrain(n: u32, height: impl Fn(f64, f64) -> f64) -> Mesh {
    let mut vertices = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
            vertices.push(v32([x, y, height(x, y)]));
        }
    }
    let at = |i: u32, j: u32| j * (n + 1) + i;
    let mut triangles = Vec::new();
    for j in 0..n {
        for i in 0..n {
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    Mesh {
        vertices,
        triangles,
    }
}

/// A (p, q) torus knot tube with `segments` × `sides` quads.
pub fn torus_knot(p: f64, q: f64, segments: u32, sides: u32, tube: f64) -> Mesh {
    let curve = |u: f64| {
        let r = 0.5 * (2.0 + (q * u).cos());
        [r * (p * u).cos(), r * (p * u).sin(), 0.5 * -(q * u).sin()]
    };
    let mut vertices = Vec::new();
    for i in 0..segments {
        let u = std::f64::consts::TAU * i as f64 / segments as f64;
        let (c0, c1) = (curve(u), curve(u + 1e-3));
        let t = normalize3([c1[0] - c0[0], c1[1] - c0[1], c1[2] - c0[2]]);
        let n = normalize3(cross3(t, [0.0, 0.0, 1.0]));
        let b = cross3(t, n);
        for j in 0..sides {
            let a = std::f64::consts::TAU * j as f64 / sides as f64;
            let (ca, sa) = (a.cos() * tube, a.sin() * tube);
            vertices.push(v32([
                c0[0] + ca * n[0] + sa * b[0],
                c0[1] + ca * n[1] + sa * b[1],
                c0[2] + ca * n[2] + sa * b[2],
            ]));
        }
    }
    let at = |i: u32, j: u32| (i % segments) * sides + (j % sides);
    let mut triangles = Vec::new();
    for i in 0..segments {
        for j in 0..sides {
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    Mesh {
        vertices,
        triangles,
    }
}

fn cross3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize3(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

/// The CTS watertightness construction: the unit square at z = -1 split by inserting `n - 2`
/// random points strictly inside random triangles, each with a random z in [-0.99, -0.01].
pub fn subdivided_square(n: usize, seed: u64) -> Mesh {
    let mut rng = Rng::new(seed);
    let mut v: Vec<[f64; 3]> = vec![
        [0.0, 0.0, -1.0],
        [1.0, 0.0, -1.0],
        [1.0, 1.0, -1.0],
        [0.0, 1.0, -1.0],
    ];
    let mut tris: Vec<[u32; 3]> = vec![[0, 1, 2], [0, 2, 3]];
    while tris.len() < n {
        let k = (rng.next_u32() as usize) % tris.len();
        let t = tris[k];
        let (a, b) = (rng.unit(), rng.unit());
        let (a, b) = if a + b > 1.0 {
            (1.0 - a, 1.0 - b)
        } else {
            (a, b)
        };
        let c = 1.0 - a - b;
        if a.min(b).min(c) < 0.05 {
            continue;
        }
        let p = [t[0], t[1], t[2]].map(|i| v[i as usize]);
        let q = [
            c * p[0][0] + a * p[1][0] + b * p[2][0],
            c * p[0][1] + a * p[1][1] + b * p[2][1],
            rng.range(-0.99, -0.01),
        ];
        let q = v32(q).map(|x| x as f64);
        v.push(q);
        let i = v.len() as u32 - 1;
        tris[k] = [t[0], t[1], i];
        tris.push([t[1], t[2], i]);
        tris.push([t[2], t[0], i]);
    }
    Mesh {
        vertices: v.into_iter().map(v32).collect(),
        triangles: tris,
    }
}

/// A translation.
pub fn translate(t: [f32; 3]) -> Matrix3x4 {
    [
        1.0, 0.0, 0.0, t[0], 0.0, 1.0, 0.0, t[1], 0.0, 0.0, 1.0, t[2],
    ]
}

/// A scale about the origin followed by a translation.
pub fn scale_translate(s: [f32; 3], t: [f32; 3]) -> Matrix3x4 {
    [
        s[0], 0.0, 0.0, t[0], 0.0, s[1], 0.0, t[1], 0.0, 0.0, s[2], t[2],
    ]
}

/// A rotation by `angle` about `axis` (normalised here), then a translation.
pub fn rotate_translate(axis: [f64; 3], angle: f64, t: [f32; 3]) -> Matrix3x4 {
    let a = normalize3(axis);
    let (s, c) = angle.sin_cos();
    let k = 1.0 - c;
    let r = [
        [
            c + a[0] * a[0] * k,
            a[0] * a[1] * k - a[2] * s,
            a[0] * a[2] * k + a[1] * s,
        ],
        [
            a[1] * a[0] * k + a[2] * s,
            c + a[1] * a[1] * k,
            a[1] * a[2] * k - a[0] * s,
        ],
        [
            a[2] * a[0] * k - a[1] * s,
            a[2] * a[1] * k + a[0] * s,
            c + a[2] * a[2] * k,
        ],
    ];
    [
        r[0][0] as f32,
        r[0][1] as f32,
        r[0][2] as f32,
        t[0],
        r[1][0] as f32,
        r[1][1] as f32,
        r[1][2] as f32,
        t[1],
        r[2][0] as f32,
        r[2][1] as f32,
        r[2][2] as f32,
        t[2],
    ]
}

/// Two triangles covering `[x0, x1] × [y0, y1]` at height `z`, counter-clockwise seen from +z.
pub fn quad(x0: f32, y0: f32, x1: f32, y1: f32, z: f32) -> Vec<[f32; 3]> {
    vec![
        [x0, y0, z],
        [x1, y0, z],
        [x1, y1, z],
        [x0, y0, z],
        [x1, y1, z],
        [x0, y1, z],
    ]
}

/// Rays straight down (−z) from height `z` through the centres of a `w` × `h` grid over
/// `[x0, x1] × [y0, y1]`.
pub fn down_grid(
    w: u32,
    h: u32,
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
    z: f32,
) -> Vec<crate::kit::Ray> {
    let mut v = Vec::new();
    for j in 0..h {
        for i in 0..w {
            let x = x0 + (x1 - x0) * (i as f64 + 0.5) / w as f64;
            let y = y0 + (y1 - y0) * (j as f64 + 0.5) / h as f64;
            v.push(crate::kit::Ray::new(
                [x as f32, y as f32, z],
                [0.0, 0.0, -1.0],
            ));
        }
    }
    v
}

/// A ray from `from` (rounded to `f32`) towards `to`: the direction is `to` minus the
/// rounded origin, in `f64`, then rounded, so the ray passes within direction rounding of
/// `to` (t ≈ 1 there).
pub fn ray_to(from: [f64; 3], to: [f64; 3]) -> crate::kit::Ray {
    let o = v32(from);
    crate::kit::Ray::new(
        o,
        v32([
            to[0] - o[0] as f64,
            to[1] - o[1] as f64,
            to[2] - o[2] as f64,
        ]),
    )
}

/// A scene of one non-opaque quad over [0, 1]² at z = -1 (hit from above at (x, y) ∈ [0, 1]²).
pub fn one_quad() -> (Scene, usize) {
    Scene::single(Gas::new(vec![GeomInput::Triangles(Triangles::soup(
        quad(0.0, 0.0, 1.0, 1.0, -1.0),
        GeometryFlags::NONE,
    ))]))
}

/// The shared header of the cases with their own raygen: parameters and buffers as in the
/// standard kit, a record of `stride` words per ray.
pub fn header(stride: u32) -> String {
    format!(
        r#"struct Params {{ handle: vec2<u32>, num_rays: u32, pad: u32 }}
@group(0) @binding(0) var<uniform> params: Params;
struct Ray {{
    origin: vec3<f32>, tmin: f32, dir: vec3<f32>, tmax: f32,
    time: f32, mask: u32, flags: u32, sbt_offset: u32, sbt_stride: u32, miss_index: u32, aux: u32, pad: u32,
}}
@group(0) @binding(1) var<storage, read> rays: array<Ray>;
@group(0) @binding(2) var<storage, read_write> out: array<u32>;

fn ray_id() -> u32 {{
    let i = rt_launch_index();
    let d = rt_launch_dimensions();
    return i.x + d.x * (i.y + d.y * i.z);
}}

fn slot(k: u32) -> u32 {{
    return ray_id() * {stride}u + k;
}}
"#
    )
}

/// A case with its own module (the header of [`header`] plus `body`), one launch of `rays`
/// against `root`, records of `stride` words.
#[allow(clippy::too_many_arguments)]
pub fn own_case(
    group: Group,
    name: &str,
    summary: &str,
    guards: &[Rule],
    scene: Scene,
    root: Option<usize>,
    pipeline: PipelineDesc,
    models: Models,
    sbt: SbtLayout,
    rays: Vec<Ray>,
    stride: usize,
    channels: Vec<ChannelSpec>,
) -> Case {
    let n = rays.len() as u32;
    let width = n.min(32);
    let height = n.div_ceil(width);
    let mut rays = rays;
    while (rays.len() as u32) < width * height {
        rays.push(Ray::new([3e38; 3], [0.0, 0.0, 1.0]).interval(0.0, 0.0));
    }
    let count = rays.len();
    Case {
        name: format!("{}.{name}", group.name()),
        group,
        summary: summary.into(),
        guards: guards.to_vec(),
        scene,
        pipeline,
        models,
        sbt,
        launches: vec![Launch {
            dims: [width, height, 1],
            params: {
                let mut p = ParamWord::handle(root).to_vec();
                p.push(ParamWord::U32(count as u32));
                p.push(ParamWord::U32(0));
                p
            },
            buffers: vec![
                BufferInit {
                    binding: 1,
                    words: rays.iter().flat_map(|r| r.words()).collect(),
                },
                BufferInit {
                    binding: 2,
                    words: vec![0; count * stride],
                },
            ],
        }],
        record: RecordSpec {
            binding: 2,
            layout: RecordLayout::PerIndex { stride },
            channels,
            judgement: Judgement::PerRecord,
        },
        rounding: crate::oracle::geometry::Rounding::F32,
        backend_specific: vec![],
    }
}

/// Reads ray `id` of the rays buffer as the standard layout's words.
pub fn ray_words(ctx: &mut Ctx<'_, '_>, id: u32) -> Vec<u32> {
    (0..16).map(|k| ctx.read(1, id as usize * 16 + k)).collect()
}

/// One miss and one hit record without data, and `callables`.
pub fn plain_sbt(callables: Vec<SbtEntry>) -> SbtLayout {
    SbtLayout {
        miss: vec![SbtEntry::new(0, vec![])],
        hit: vec![SbtEntry::new(0, vec![])],
        callables,
        ..Default::default()
    }
}

/// Adds a GAS of one opaque quad over [-0.5, 0.5]² at z = 0 to `scene`; returns its node.
pub fn small_quad_gas(scene: &mut Scene) -> usize {
    scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(
            quad(-0.5, -0.5, 0.5, 0.5, 0.0),
            GeometryFlags::DISABLE_ANYHIT,
        ),
    )])))
}
