//! Ray/triangle tests.
//!
//! Both report `t` in the open interval `(tmin, tmax)`, barycentrics `(u, v)` (the weights
//! of vertices 1 and 2, as `rt_triangle_barycentrics`) and the facing in the triangle's own
//! space: front when `(v1 − v0) × (v2 − v0)` points against the direction (counter-clockwise
//! seen from the origin). Degenerate triangles (zero area), triangles with NaN or infinite
//! vertices and zero directions never hit; NaNs fall through every comparison to a miss.

use super::ray::{PreparedRay, TriangleLanes};
#[cfg(target_arch = "x86_64")]
use super::simd::F8;
use super::simd::{F4, Lanes};
use crate::accel::wide::TriangleBlock;

/// A triangle hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Distance along the (unnormalised) direction.
    pub t: f32,
    /// Weight of vertex 1.
    pub u: f32,
    /// Weight of vertex 2.
    pub v: f32,
    /// Whether the triangle faces the ray (before instance flips).
    pub front: bool,
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The sign an edge function takes when the ray's point in the sheared plane is pushed by
/// (ε, ε²), for an edge function that is exactly zero: the sign of its x derivative, or of
/// its y derivative where that is zero. `p` and `q` are the edge's ends as the edge function
/// `p.x·q.y − p.y·q.x` takes them. A neighbour sharing the edge takes the ends in the other
/// order and gets exactly the opposite sign (f32 subtraction is antisymmetric), so a ray
/// through a shared edge or vertex lands inside exactly one triangle of a closed mesh: the
/// one holding the pushed point (the top-left rule of rasterisers, in symbolic form).
#[inline(always)]
fn pushed_sign(p: (f32, f32), q: (f32, f32)) -> f32 {
    let dx = p.1 - q.1;
    let dy = q.0 - p.0;
    if dx != 0.0 { dx } else { dy }
}

/// Woop, Benthin and Wald's watertight test (JCGT 2013) with the double-precision fallback
/// (an edge function that is exactly zero in f32 is recomputed in f64, whose products of f32
/// values are exact) and a tie-break for edge functions that are exactly zero even then
/// (`pushed_sign`): rays through shared edges and vertices of a closed mesh hit exactly
/// one triangle, never none or two (docs/numerics.md, "Watertight triangles"; DESIGN.md §5).
#[inline(always)]
pub fn watertight(
    ray: &PreparedRay,
    tri: &[[f32; 3]; 3],
    tmin: f32,
    tmax: f32,
) -> Option<TriangleHit> {
    if !ray.moves {
        return None;
    }
    let [kx, ky, kz] = ray.axes;
    let [sx, sy, sz] = ray.shear;
    let a = sub(tri[0], ray.origin);
    let b = sub(tri[1], ray.origin);
    let c = sub(tri[2], ray.origin);
    // Shear and scale so the ray runs along +z through the origin.
    let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
    let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
    let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let f = |p: f32, q: f32, r: f32, s: f32| (p as f64 * q as f64 - r as f64 * s as f64) as f32;
        u = f(cx, by, cy, bx);
        v = f(ax, cy, ay, cx);
        w = f(bx, ay, by, ax);
    }
    // Signs for the inside test; zeros (the ray's point on an edge line) tie-broken.
    let (pa, pb, pc) = ((ax, ay), (bx, by), (cx, cy));
    let su = if u == 0.0 { pushed_sign(pc, pb) } else { u };
    let sv = if v == 0.0 { pushed_sign(pa, pc) } else { v };
    let sw = if w == 0.0 { pushed_sign(pb, pa) } else { w };
    if (su < 0.0 || sv < 0.0 || sw < 0.0) && (su > 0.0 || sv > 0.0 || sw > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let (az, bz, cz) = (sz * a[kz], sz * b[kz], sz * c[kz]);
    let t = (u * az + v * bz + w * cz) / det;
    if !(t > tmin && t < tmax) {
        return None;
    }
    let inv = 1.0 / det;
    Some(TriangleHit {
        t,
        u: v * inv,
        v: w * inv,
        front: det > 0.0,
    })
}

/// Hits of a block triangle test, lane by lane (four lanes: one block; eight: two).
#[derive(Clone, Copy, Debug)]
pub struct BlockHits<L: Lanes = F4> {
    /// Lanes that hit (bit `i` for lane `i`).
    pub mask: u32,
    /// Per lane, as [`TriangleHit`] (meaningful in hit lanes only).
    pub t: L::Array,
    /// Weights of vertex 1.
    pub u: L::Array,
    /// Weights of vertex 2.
    pub v: L::Array,
    /// Lanes whose triangle faces the ray.
    pub front: u32,
}

impl<L: Lanes> BlockHits<L> {
    /// No lane hits.
    #[inline(always)]
    fn none() -> BlockHits<L> {
        BlockHits {
            mask: 0,
            t: L::Array::default(),
            u: L::Array::default(),
            v: L::Array::default(),
            front: 0,
        }
    }

    /// Lane `lane`'s hit.
    #[inline(always)]
    pub fn lane(&self, lane: usize) -> TriangleHit {
        TriangleHit {
            t: self.t.as_ref()[lane],
            u: self.u.as_ref()[lane],
            v: self.v.as_ref()[lane],
            front: self.front >> lane & 1 == 1,
        }
    }
}

/// [`watertight`] for the lanes `lanes` of a triangle block at once, lane by lane the same
/// arithmetic (the f64 fallback included), so each lane's answer is bit for bit the scalar
/// test's. The ray must move (`WideRay::moves`).
#[inline(always)]
pub fn watertight4(
    lanes_of_ray: &TriangleLanes,
    block: &TriangleBlock,
    lanes: u32,
    tmin: f32,
    tmax: f32,
) -> BlockHits {
    let vertex = |v: usize, k: usize| F4::load(&block.vertices[v][k]);
    watertight_lanes(lanes_of_ray, vertex, lanes, tmin, tmax)
}

/// [`watertight4`] for two blocks at once: lanes 0–3 are `blocks[0]`'s, 4–7 `blocks[1]`'s
/// (`lanes` has bit `4 + i` for lane `i` of the second), each bit for bit the scalar test's.
/// An eight-lane test costs about what a four-lane one does, so a leaf of several blocks
/// takes half the tests.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn watertight8(
    lanes_of_ray: &TriangleLanes<F8>,
    blocks: [&TriangleBlock; 2],
    lanes: u32,
    tmin: f32,
    tmax: f32,
) -> BlockHits<F8> {
    // SAFETY: `lanes_of_ray` holds `F8`s, which exist only where the CPU has AVX.
    let vertex = |v: usize, k: usize| unsafe {
        F8::pair(&blocks[0].vertices[v][k], &blocks[1].vertices[v][k])
    };
    watertight_lanes(lanes_of_ray, vertex, lanes, tmin, tmax)
}

/// The watertight block test on lanes of any width; `vertex(v, axis)` loads coordinate
/// `axis` of vertex `v` of every lane's triangle.
#[inline(always)]
fn watertight_lanes<L: Lanes>(
    lanes_of_ray: &TriangleLanes<L>,
    vertex: impl Fn(usize, usize) -> L,
    lanes: u32,
    tmin: f32,
    tmax: f32,
) -> BlockHits<L> {
    let [kx, ky, kz] = lanes_of_ray.axes;
    let [sx, sy, sz] = lanes_of_ray.shear;
    let o = &lanes_of_ray.origin;
    let rel = |v: usize, k: usize| vertex(v, k) - o[k];
    let (a, b, c) = (
        [rel(0, kx), rel(0, ky), rel(0, kz)],
        [rel(1, kx), rel(1, ky), rel(1, kz)],
        [rel(2, kx), rel(2, ky), rel(2, kz)],
    );
    let (ax, ay) = (a[0] - sx * a[2], a[1] - sy * a[2]);
    let (bx, by) = (b[0] - sx * b[2], b[1] - sy * b[2]);
    let (cx, cy) = (c[0] - sx * c[2], c[1] - sy * c[2]);
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    let zero = L::splat(0.0);
    let exact = L::bits(u.eq(zero) | v.eq(zero) | w.eq(zero)) & lanes;
    // The signs the inside test reads: the edge functions, with exact zeros tie-broken.
    let (mut su, mut sv, mut sw) = (u, v, w);
    if exact != 0 {
        // Edge functions exactly zero: recomputed in f64 and tie-broken, as the scalar test
        // does.
        // `map` is fine here, unlike in the hot paths (`moller_trumbore_lanes`): this branch
        // is rare, and written out its arrays cost the common path 18 instructions a
        // Breakfast Room camera ray (the leaf's register allocation).
        let [ax, ay, bx, by, cx, cy] = [ax, ay, bx, by, cx, cy].map(L::to_array);
        let [ax, ay, bx, by, cx, cy] = [&ax, &ay, &bx, &by, &cx, &cy].map(|x| x.as_ref());
        let (mut uu, mut vv, mut ww) = (u.to_array(), v.to_array(), w.to_array());
        let f = |p: f32, q: f32, r: f32, s: f32| (p as f64 * q as f64 - r as f64 * s as f64) as f32;
        let (mut s_u, mut s_v, mut s_w) = (uu, vv, ww);
        for lane in 0..L::N {
            if exact >> lane & 1 == 1 {
                let (u, v, w) = (
                    f(cx[lane], by[lane], cy[lane], bx[lane]),
                    f(ax[lane], cy[lane], ay[lane], cx[lane]),
                    f(bx[lane], ay[lane], by[lane], ax[lane]),
                );
                let (pa, pb, pc) = (
                    (ax[lane], ay[lane]),
                    (bx[lane], by[lane]),
                    (cx[lane], cy[lane]),
                );
                uu.as_mut()[lane] = u;
                vv.as_mut()[lane] = v;
                ww.as_mut()[lane] = w;
                s_u.as_mut()[lane] = if u == 0.0 { pushed_sign(pc, pb) } else { u };
                s_v.as_mut()[lane] = if v == 0.0 { pushed_sign(pa, pc) } else { v };
                s_w.as_mut()[lane] = if w == 0.0 { pushed_sign(pb, pa) } else { w };
            }
        }
        (u, v, w) = (L::from_array(&uu), L::from_array(&vv), L::from_array(&ww));
        (su, sv, sw) = (
            L::from_array(&s_u),
            L::from_array(&s_v),
            L::from_array(&s_w),
        );
    }
    // Signs of both kinds (the point outside an edge): the least below zero and the
    // greatest above it. Exactly the scalar test's "one negative and one positive" where no
    // sign is NaN; a lane with a NaN edge function may come out either way, and its `det`
    // (their sum) and so its `t` are NaN, which the interval test below rejects, as the
    // scalar test does. Four instructions fewer than two chains of three comparisons.
    let mixed = su.min(sv).min(sw).lt(zero) & su.max(sv).max(sw).gt(zero);
    let det = u + v + w;
    let inside = lanes & !L::bits(mixed) & !L::bits(det.eq(zero));
    if inside == 0 {
        return BlockHits::none();
    }
    let (az, bz, cz) = (sz * a[2], sz * b[2], sz * c[2]);
    let t = (u * az + v * bz + w * cz) / det;
    let mask = inside & L::bits(t.gt(L::splat(tmin)) & t.lt(L::splat(tmax)));
    if mask == 0 {
        return BlockHits::none();
    }
    let inv = L::splat(1.0) / det;
    BlockHits {
        mask,
        t: t.to_array(),
        u: (v * inv).to_array(),
        v: (w * inv).to_array(),
        front: L::bits(det.gt(zero)),
    }
}

/// [`moller_trumbore`] on the four lanes of `block` at once (the lanes of `lanes`), bit for
/// bit: the same operations in the same order, without fused multiply-adds, so each lane's
/// hit equals the scalar test's. The scalar test ran one lane after another; this one is
/// what makes `TriangleTest::MollerTrumbore` cheaper than the watertight block test it
/// replaces, as users expect of the option that gives up watertightness.
#[inline(always)]
pub fn moller_trumbore4(
    lanes_of_ray: &TriangleLanes,
    block: &TriangleBlock,
    lanes: u32,
    tmin: f32,
    tmax: f32,
) -> BlockHits {
    let vertex = |v: usize, k: usize| F4::load(&block.vertices[v][k]);
    moller_trumbore_lanes(lanes_of_ray, vertex, lanes, tmin, tmax)
}

/// [`moller_trumbore4`] for two blocks at once, laid out as [`watertight8`]'s.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn moller_trumbore8(
    lanes_of_ray: &TriangleLanes<F8>,
    blocks: [&TriangleBlock; 2],
    lanes: u32,
    tmin: f32,
    tmax: f32,
) -> BlockHits<F8> {
    // SAFETY: `lanes_of_ray` holds `F8`s, which exist only where the CPU has AVX.
    let vertex = |v: usize, k: usize| unsafe {
        F8::pair(&blocks[0].vertices[v][k], &blocks[1].vertices[v][k])
    };
    moller_trumbore_lanes(lanes_of_ray, vertex, lanes, tmin, tmax)
}

/// The Möller–Trumbore block test on lanes of any width (`vertex` as in
/// [`watertight_lanes`]).
#[inline(always)]
fn moller_trumbore_lanes<L: Lanes>(
    lanes_of_ray: &TriangleLanes<L>,
    vertex: impl Fn(usize, usize) -> L,
    lanes: u32,
    tmin: f32,
    tmax: f32,
) -> BlockHits<L> {
    // Vector helpers as `#[inline(always)]` functions, arrays written out, no `map`: a
    // closure is not always inlined into the AVX leaf, and the eight-lane operations it
    // calls are then calls too (closures here made the eight-lane test 1.8× slower).
    let v0 = [vertex(0, 0), vertex(0, 1), vertex(0, 2)];
    let v1 = [vertex(1, 0), vertex(1, 1), vertex(1, 2)];
    let v2 = [vertex(2, 0), vertex(2, 1), vertex(2, 2)];
    let e1 = sub3(v1, v0);
    let e2 = sub3(v2, v0);
    let p = cross3(lanes_of_ray.dir, e2);
    let det = dot3(e1, p);
    let (zero, one) = (L::splat(0.0), L::splat(1.0));
    // Finite and non-zero (NaN fails both comparisons).
    let inf = L::splat(f32::INFINITY);
    let finite = det.lt(inf) & L::splat(f32::NEG_INFINITY).lt(det);
    let usable = !L::bits(det.eq(zero)) & L::bits(finite);
    // Everything at once, tested once: the division's latency overlaps the second cross
    // product and the dot products, and there is one branch per block instead of four
    // (each value is the scalar test's; only the order of evaluation differs).
    let inv = one / det;
    let s = sub3(lanes_of_ray.origin, v0);
    let q = cross3(s, e1);
    let u = dot3(s, p) * inv;
    let v = dot3(lanes_of_ray.dir, q) * inv;
    let t = dot3(e2, q) * inv;
    let inside = zero.le(u) & u.le(one) & zero.le(v) & (u + v).le(one);
    let within = t.gt(L::splat(tmin)) & t.lt(L::splat(tmax));
    let mask = lanes & usable & L::bits(inside & within);
    if mask == 0 {
        return BlockHits::none();
    }
    BlockHits {
        mask,
        t: t.to_array(),
        u: u.to_array(),
        v: v.to_array(),
        front: L::bits(det.gt(zero)),
    }
}

/// `a − b` per axis.
#[inline(always)]
fn sub3<L: Lanes>(a: [L; 3], b: [L; 3]) -> [L; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a × b`, in the scalar test's order of operations.
#[inline(always)]
fn cross3<L: Lanes>(a: [L; 3], b: [L; 3]) -> [L; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `a · b`, in the scalar test's order of operations.
#[inline(always)]
fn dot3<L: Lanes>(a: [L; 3], b: [L; 3]) -> L {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Möller–Trumbore: faster, not watertight (rays through shared edges can slip between
/// neighbours). Only an exactly zero determinant is rejected, so tiny triangles still hit.
#[inline(always)]
pub fn moller_trumbore(
    ray: &PreparedRay,
    tri: &[[f32; 3]; 3],
    tmin: f32,
    tmax: f32,
) -> Option<TriangleHit> {
    let cross = |a: [f32; 3], b: [f32; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let e1 = sub(tri[1], tri[0]);
    let e2 = sub(tri[2], tri[0]);
    let p = cross(ray.dir, e2);
    let det = dot(e1, p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = sub(ray.origin, tri[0]);
    let u = dot(s, p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = cross(s, e1);
    let v = dot(ray.dir, q) * inv;
    if !(v >= 0.0 && u + v <= 1.0) {
        return None;
    }
    let t = dot(e2, q) * inv;
    if !(t > tmin && t < tmax) {
        return None;
    }
    // det = e1 · (d × e2) = −d · ((v1 − v0) × (v2 − v0)): positive when facing the ray.
    Some(TriangleHit {
        t,
        u,
        v,
        front: det > 0.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::traversal::ray::WideRay;

    use crate::traversal::tests::Rng;

    type Test = fn(&PreparedRay, &[[f32; 3]; 3], f32, f32) -> Option<TriangleHit>;
    const TESTS: [(&str, Test); 2] = [
        ("watertight", watertight),
        ("moller-trumbore", moller_trumbore),
    ];

    fn ray(o: [f32; 3], d: [f32; 3]) -> PreparedRay {
        PreparedRay::new(o, d, true)
    }

    #[test]
    fn hit_values_and_facing_match_f64() {
        let mut rng = Rng(99);
        let mut hits = 0;
        for _ in 0..5000 {
            let tri = [rng.v(2.0), rng.v(2.0), rng.v(2.0)];
            let o = rng.v(8.0);
            let aim = rng.v(1.0);
            let d = sub(aim, o);
            let r = ray(o, d);
            // f64 reference: n · d decides facing.
            let e = |i: usize, k: usize| tri[i][k] as f64 - tri[0][k] as f64;
            let n = [
                e(1, 1) * e(2, 2) - e(1, 2) * e(2, 1),
                e(1, 2) * e(2, 0) - e(1, 0) * e(2, 2),
                e(1, 0) * e(2, 1) - e(1, 1) * e(2, 0),
            ];
            let ndotd = n[0] * d[0] as f64 + n[1] * d[1] as f64 + n[2] * d[2] as f64;
            for (name, test) in TESTS {
                if let Some(h) = test(&r, &tri, 0.0, f32::INFINITY) {
                    hits += 1;
                    assert_eq!(h.front, ndotd < 0.0, "{name} facing");
                    let p: [f32; 3] = std::array::from_fn(|k| {
                        tri[0][k] * (1.0 - h.u - h.v) + tri[1][k] * h.u + tri[2][k] * h.v
                    });
                    let q: [f32; 3] = std::array::from_fn(|k| o[k] + h.t * d[k]);
                    for k in 0..3 {
                        assert!((p[k] - q[k]).abs() < 1e-3, "{name}: {p:?} vs {q:?}");
                    }
                }
            }
        }
        assert!(hits > 500, "{hits}");
    }

    #[test]
    fn interval_is_open() {
        let tri = [[-1.0, -1.0, 5.0], [1.0, -1.0, 5.0], [0.0, 1.0, 5.0]];
        let r = ray([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
        for (name, test) in TESTS {
            assert_eq!(test(&r, &tri, 0.0, 10.0).map(|h| h.t), Some(5.0), "{name}");
            assert_eq!(
                test(&r, &tri, 5.0, 10.0),
                None,
                "{name}: t == tmin is outside"
            );
            assert_eq!(
                test(&r, &tri, 0.0, 5.0),
                None,
                "{name}: t == tmax is outside"
            );
            assert!(test(&r, &tri, 4.999999, 5.000001).is_some(), "{name}");
        }
    }

    #[test]
    fn degenerate_nan_and_zero_direction_never_hit() {
        let r = ray([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
        let bad = [
            [[0.0, 0.0, 5.0], [1.0, 1.0, 5.0], [2.0, 2.0, 5.0]],
            [[0.0, 0.0, 5.0], [0.0, 0.0, 5.0], [0.0, 0.0, 5.0]],
            [[-1.0, -1.0, 5.0], [f32::NAN, -1.0, 5.0], [0.0, 1.0, 5.0]],
            [[-1.0, -1.0, f32::NAN], [1.0, -1.0, 5.0], [0.0, 1.0, 5.0]],
            [
                [-1.0, -1.0, 5.0],
                [f32::INFINITY, -1.0, 5.0],
                [0.0, 1.0, 5.0],
            ],
        ];
        for (name, test) in TESTS {
            for tri in &bad {
                assert_eq!(test(&r, tri, 0.0, f32::INFINITY), None, "{name}: {tri:?}");
            }
            let good = [[-1.0, -1.0, 5.0], [1.0, -1.0, 5.0], [0.0, 1.0, 5.0]];
            assert_eq!(
                test(&ray([0.0; 3], [0.0; 3]), &good, 0.0, f32::INFINITY),
                None,
                "{name}"
            );
        }
    }

    #[test]
    fn signed_zero_directions_agree() {
        let mut rng = Rng(7);
        for _ in 0..2000 {
            let tri = [rng.v(2.0), rng.v(2.0), rng.v(2.0)];
            let o = rng.v(4.0);
            let mut d = rng.v(1.0);
            let axis = (rng.f() * 3.0) as usize % 3;
            d[axis] = 0.0;
            let mut dn = d;
            dn[axis] = -0.0;
            for (name, test) in TESTS {
                assert_eq!(
                    test(&ray(o, d), &tri, 0.0, 1e30),
                    test(&ray(o, dn), &tri, 0.0, 1e30),
                    "{name}"
                );
            }
        }
    }

    /// Builds a block from up to four triangles.
    fn block(tris: &[[[f32; 3]; 3]]) -> TriangleBlock {
        let mut b = TriangleBlock {
            vertices: [[[0.0; 4]; 3]; 3],
            primitives: [0; 4],
            first_slot: 0,
            classes: [0; 4],
            lanes: tris.len() as u32,
        };
        for (lane, t) in tris.iter().enumerate() {
            for (v, vertex) in t.iter().enumerate() {
                for (a, &c) in vertex.iter().enumerate() {
                    b.vertices[v][a][lane] = c;
                }
            }
        }
        b
    }

    /// Checks a block test's hits against its scalar form, lane by lane and bit for bit
    /// (masked lanes have none); the number of hits.
    fn assert_lanes_match<L: Lanes>(
        block_index: usize,
        tris: &[[[f32; 3]; 3]],
        lanes: u32,
        got: &BlockHits<L>,
        scalar: impl Fn(&[[f32; 3]; 3]) -> Option<TriangleHit>,
    ) -> u32 {
        let bits = |h: Option<TriangleHit>| {
            h.map(|h| (h.t.to_bits(), h.u.to_bits(), h.v.to_bits(), h.front))
        };
        let mut hits = 0;
        for (lane, tri) in tris.iter().enumerate() {
            let want = (lanes >> lane & 1 == 1).then(|| scalar(tri)).flatten();
            let have = (got.mask >> lane & 1 == 1).then(|| got.lane(lane));
            assert_eq!(bits(want), bits(have), "block {block_index} lane {lane}");
            hits += want.is_some() as u32;
        }
        hits
    }

    /// The block tests on eight triangles: `four` on each block of four, and (where the CPU
    /// has AVX) `eight` on both blocks at once, every lane checked against `scalar`
    /// (`lanes`: bit `i` for triangle `i`). The hits found, and whether `eight` ran.
    fn check_blocks(
        case: usize,
        tris: &[[[f32; 3]; 3]; 8],
        lanes: u32,
        four: impl Fn(&TriangleBlock, u32) -> BlockHits,
        eight: impl Fn([&TriangleBlock; 2], u32) -> Option<EightLanes>,
        scalar: impl Fn(&[[f32; 3]; 3]) -> Option<TriangleHit>,
    ) -> (u32, bool) {
        let (low, high) = (block(&tris[..4]), block(&tris[4..]));
        let mut hits = 0;
        for (k, (b, t)) in [(&low, &tris[..4]), (&high, &tris[4..])]
            .into_iter()
            .enumerate()
        {
            let l = lanes >> (4 * k) & 0xF;
            hits += assert_lanes_match(2 * case + k, t, l, &four(b, l), &scalar);
        }
        if let Some(got) = eight([&low, &high], lanes) {
            assert_eq!(assert_lanes_match(case, tris, lanes, &got, &scalar), hits);
            return (hits, true);
        }
        (hits, false)
    }

    /// What an eight-lane block test gives (no such test off x86-64: never made there).
    #[cfg(target_arch = "x86_64")]
    type EightLanes = BlockHits<F8>;
    #[cfg(not(target_arch = "x86_64"))]
    type EightLanes = BlockHits;

    /// The ray's lanes widened to eight, where the CPU has AVX.
    #[cfg(target_arch = "x86_64")]
    fn widened(l: &TriangleLanes) -> Option<TriangleLanes<F8>> {
        // SAFETY: AVX checked first.
        std::arch::is_x86_feature_detected!("avx").then(|| unsafe { l.widen() })
    }

    #[test]
    fn block_lanes_agree_with_the_scalar_test_bit_for_bit() {
        let mut rng = Rng(5);
        let (mut hits, mut exact, mut eight_lane_cases) = (0, 0, 0);
        for i in 0..20000 {
            // Every fourth case shares edges on an integer grid, where edge functions are
            // exactly zero and the f64 fallback decides. Elsewhere some lanes are degenerate
            // or hold a NaN or an infinite coordinate: their edge functions are NaN or
            // infinite, and the inside test's signs must still agree with the scalar test's.
            let tris: [[[f32; 3]; 3]; 8] = std::array::from_fn(|k| {
                if i % 4 == 0 {
                    let (x, y) = ((k % 2) as f32, (k / 2) as f32);
                    return [[x, y, 3.0], [x + 1.0, y, 3.0], [x + 1.0, y + 1.0, 3.0]];
                }
                let t = [rng.v(2.0), rng.v(2.0), rng.v(2.0)];
                match (i + k) % 19 {
                    0 => [t[0], t[0], t[2]],
                    1 => [t[0], [f32::INFINITY, 0.0, 0.0], t[2]],
                    2 => [t[0], t[1], [f32::NAN, 0.0, 0.0]],
                    3 => [[0.0, f32::NEG_INFINITY, 1.0], t[1], t[2]],
                    _ => t,
                }
            });
            let (o, d) = if i % 4 == 0 {
                let o = [
                    (rng.f() * 4.0).round() * 0.5,
                    (rng.f() * 8.0).round() * 0.5,
                    0.0,
                ];
                (o, [0.0, if i % 8 == 0 { -0.0 } else { 0.0 }, 1.0])
            } else {
                let o = rng.v(8.0);
                (o, sub(rng.v(1.0), o))
            };
            let r = ray(o, d);
            if !r.moves {
                continue;
            }
            // Leaves end inside a block: its last lanes (and a pair's whole second block)
            // are masked.
            let lanes = [0xFF, 0x7F, 0x0F, 0x3F, 0xF7][i % 5];
            // Grid hits lie at exactly t = 3: intervals ending there are open at both ends.
            let (tmin, tmax) = match i % 10 {
                0 | 5 => (1.0, 4.0),
                4 => (3.0, 4.0),
                8 => (1.0, 3.0),
                _ => (0.0, f32::INFINITY),
            };
            // The lanes as the traversal builds them: box lanes first, triangle lanes later.
            let w = WideRay::new(o, d);
            let four_lanes = TriangleLanes::new(&w);
            let (found, eight) = check_blocks(
                i,
                &tris,
                lanes,
                |b, l| watertight4(&four_lanes, b, l, tmin, tmax),
                |_pair, _l| {
                    #[cfg(target_arch = "x86_64")]
                    return widened(&four_lanes).map(|l8| watertight8(&l8, _pair, _l, tmin, tmax));
                    #[cfg(not(target_arch = "x86_64"))]
                    None
                },
                |t| watertight(&r, t, tmin, tmax),
            );
            hits += found;
            exact += if i % 4 == 0 { found } else { 0 };
            eight_lane_cases += eight as u32;
        }
        assert!(hits > 4000 && exact > 1000, "{hits} {exact}");
        println!("eight-lane test checked on {eight_lane_cases} cases");
    }

    #[test]
    fn block_lanes_of_moller_trumbore_agree_with_the_scalar_test_bit_for_bit() {
        let mut rng = Rng(11);
        let (mut hits, mut eight_lane_cases) = (0, 0);
        for i in 0..20000 {
            // Some lanes degenerate (a repeated vertex) or not finite, as the scalar test
            // rejects them.
            // Every fourth case on an integer grid, rays along an axis through its edges and
            // vertices: barycentrics exactly 0 or 1, where the inside test's `<=` decides.
            let grid = i % 4 == 0;
            let tris: [[[f32; 3]; 3]; 8] = std::array::from_fn(|k| {
                let t = [rng.v(2.0), rng.v(2.0), rng.v(2.0)];
                if grid {
                    let (x, y) = ((k % 2) as f32, (k / 2) as f32);
                    return [[x, y, 3.0], [x + 1.0, y, 3.0], [x + 1.0, y + 1.0, 3.0]];
                }
                match (i + k) % 23 {
                    0 => [t[0], t[0], t[2]],
                    1 => [t[0], [f32::INFINITY, 0.0, 0.0], t[2]],
                    2 => [t[0], t[1], [f32::NAN, 0.0, 0.0]],
                    _ => t,
                }
            });
            let (o, d) = if grid {
                let o = [
                    (rng.f() * 4.0).round() * 0.5,
                    (rng.f() * 8.0).round() * 0.5,
                    0.0,
                ];
                (o, [0.0, 0.0, 1.0])
            } else {
                let o = rng.v(8.0);
                (o, sub(rng.v(1.0), o))
            };
            let r = ray(o, d);
            let lanes = [0xFF, 0xBF, 0x0B, 0x3F][i % 4];
            // Grid hits lie at exactly t = 3: intervals ending there are open at both ends.
            let (tmin, tmax) = match i % 10 {
                0 | 5 => (1.0, 4.0),
                4 => (3.0, 4.0),
                8 => (1.0, 3.0),
                _ => (0.0, f32::INFINITY),
            };
            let w = WideRay::new(o, d);
            let four_lanes = TriangleLanes::for_moller_trumbore(&w);
            let (found, eight) = check_blocks(
                i,
                &tris,
                lanes,
                |b, l| moller_trumbore4(&four_lanes, b, l, tmin, tmax),
                |_pair, _l| {
                    #[cfg(target_arch = "x86_64")]
                    return widened(&four_lanes)
                        .map(|l8| moller_trumbore8(&l8, _pair, _l, tmin, tmax));
                    #[cfg(not(target_arch = "x86_64"))]
                    None
                },
                |t| moller_trumbore(&r, t, tmin, tmax),
            );
            hits += found;
            eight_lane_cases += eight as u32;
        }
        assert!(hits > 4000, "{hits}");
        println!("eight-lane test checked on {eight_lane_cases} cases");
    }

    #[test]
    fn watertight_never_leaks_through_an_axis_aligned_grid() {
        // Integer-coordinate quads split in two: rays along the axes through every shared
        // edge and vertex must hit exactly once (edge functions exactly zero even in f64:
        // the tie-break decides). Möller–Trumbore is allowed to fail here.
        let mut tris = Vec::new();
        for i in 0..4 {
            for j in 0..4 {
                let (x, y) = (i as f32, j as f32);
                tris.push([[x, y, 3.0], [x + 1.0, y, 3.0], [x + 1.0, y + 1.0, 3.0]]);
                tris.push([[x, y, 3.0], [x + 1.0, y + 1.0, 3.0], [x, y + 1.0, 3.0]]);
            }
        }
        for i in 1..8 {
            for j in 1..8 {
                let o = [i as f32 * 0.5, j as f32 * 0.5, 0.0];
                for d in [[0.0, 0.0, 1.0], [-0.0, 0.0, 1.0], [0.0, -0.0, 1.0]] {
                    let r = ray(o, d);
                    let n = tris
                        .iter()
                        .filter(|t| watertight(&r, t, 0.0, f32::INFINITY).is_some())
                        .count();
                    assert_eq!(n, 1, "leak or double hit at {o:?} along {d:?}");
                }
            }
        }
    }

    #[test]
    fn watertight_hits_a_closed_fan_exactly_once_at_its_vertex_and_edges() {
        // Fans around a centre in tilted planes, rays from random origins aimed at the centre
        // and at points of the shared edges: edge functions are zero or within rounding of
        // it, and every ray must hit exactly one triangle (no double hits, no leaks).
        let mut rng = Rng(2024);
        for n in [3usize, 4, 7, 16, 64] {
            for _ in 0..20 {
                let centre = rng.v(4.0);
                let (e1, e2) = (rng.v(1.0), rng.v(1.0));
                let rim: Vec<[f32; 3]> = (0..n)
                    .map(|k| {
                        let a = k as f32 / n as f32 * std::f32::consts::TAU;
                        let (c, s) = (a.cos(), a.sin());
                        std::array::from_fn(|i| centre[i] + c * e1[i] + s * e2[i])
                    })
                    .collect();
                let fan: Vec<[[f32; 3]; 3]> =
                    (0..n).map(|k| [centre, rim[k], rim[(k + 1) % n]]).collect();
                let mut aims = vec![centre];
                for r in &rim {
                    for f in [0.25f32, 0.5] {
                        aims.push(std::array::from_fn(|i| centre[i] + f * (r[i] - centre[i])));
                    }
                }
                for aim in aims {
                    let o = rng.v(16.0);
                    let r = ray(o, sub(aim, o));
                    let hits = fan
                        .iter()
                        .filter(|t| watertight(&r, t, 0.0, f32::INFINITY).is_some())
                        .count();
                    assert_eq!(hits, 1, "fan of {n}, ray {o:?} towards {aim:?}");
                }
            }
        }
    }
}
