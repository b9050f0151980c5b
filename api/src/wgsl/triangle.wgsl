// Ray/triangle tests (DESIGN.md §5). Both hit in the open interval (tmin, tmax) and report
// OptiX's barycentrics: the hit point is (1 - u - v)·v0 + u·v1 + v·v2. `front` is true when
// the vertices run counter-clockwise seen from the ray origin (optik_api::semantics::facing).

struct _OptikTriHit {
    hit: bool,
    t: f32,
    u: f32,
    v: f32,
    front: bool,
}

fn _optik_tri_miss() -> _OptikTriHit {
    return _OptikTriHit(false, 0.0, 0.0, 0.0, false);
}

// Per-ray constants of the watertight test (Woop, Benthin, Wald 2013): the axis of largest
// direction component becomes z, x and y are swapped when that component is negative (to
// keep the winding), and the shear maps the ray to the +z axis.
struct _OptikWoop {
    kx: u32,
    ky: u32,
    kz: u32,
    shear: vec3<f32>,
    usable: bool,
}

// Component `k` of `v`, through selects: a vector indexed by a value known only at run time
// may be lowered to local memory, one access per read.
fn _optik_pick(v: vec3<f32>, k: u32) -> f32 {
    return select(select(v.x, v.y, k == 1u), v.z, k == 2u);
}

fn _optik_woop_ray(d: vec3<f32>) -> _OptikWoop {
    let a = abs(d);
    var kz = 0u;
    if a.y > a.x {
        kz = 1u;
    }
    if a.z > max(a.x, a.y) {
        kz = 2u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    let dz = _optik_pick(d, kz);
    if dz < 0.0 {
        let swap = kx;
        kx = ky;
        ky = swap;
    }
    // A zero (or subnormal) direction has no largest axis; it hits no triangle.
    let usable = _optik_pick(a, kz) >= _OPTIK_MIN_NORMAL;
    let dz_safe = select(1.0, dz, usable);
    return _OptikWoop(kx, ky, kz, vec3<f32>(_optik_pick(d, kx) / dz_safe, _optik_pick(d, ky) / dz_safe, 1.0 / dz_safe), usable);
}

// The 2D edge function p.x·q.y − p.y·q.x, always evaluated with its operands in one
// canonical order and negated when swapped. Two triangles sharing an edge then compute
// bit-identical magnitudes with opposite signs even where the shader compiler fuses the
// multiply and subtract into an FMA, which would otherwise break watertightness.
fn _optik_edge(p: vec2<f32>, q: vec2<f32>) -> f32 {
    let swap = p.x > q.x || (p.x == q.x && p.y > q.y);
    let a = select(p, q, swap);
    let b = select(q, p, swap);
    let e = a.x * b.y - a.y * b.x;
    return select(e, -e, swap);
}

// The f64 fallback for edge functions that are exactly zero in f32 (DESIGN.md §5): the
// products of two f32 values are exact in f64, so the sign of their difference is exact.
// A nonzero result too small for f32 keeps its sign as ±the smallest normal.
fn _optik_edge64(p: vec2<f32>, q: vec2<f32>) -> f32 { // @f64
    let e = f64(p.x) * f64(q.y) - f64(p.y) * f64(q.x); // @f64
    let r = f32(e); // @f64
    if r == 0.0 && e != 0.0lf { // @f64
        return select(-_OPTIK_MIN_NORMAL, _OPTIK_MIN_NORMAL, e > 0.0lf); // @f64
    } // @f64
    return r; // @f64
} // @f64

// The sign an edge function takes when the ray's point in the sheared plane is pushed by
// (ε, ε²): its own sign where it is nonzero, else the sign of its x derivative, or of its y
// derivative where that is zero too. A neighbour sharing the edge takes its ends in the
// other order and gets exactly the opposite sign (subtraction is antisymmetric), so a ray
// through a shared edge or vertex of a closed mesh lands in exactly one triangle (the
// rasterisers' top-left rule in symbolic form; the CPU backend's `pushed_sign`).
fn _optik_edge_pushed(e: f32, p: vec2<f32>, q: vec2<f32>) -> f32 {
    if e != 0.0 {
        return e;
    }
    let dx = p.y - q.y;
    return select(q.x - p.x, dx, dx != 0.0);
}

// Woop, Benthin and Wald's watertight test, with exact-zero edge functions tie-broken.
fn _optik_tri_watertight(w: _OptikWoop, o: vec3<f32>, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, tmin: f32, tmax: f32) -> _OptikTriHit {
    if !w.usable {
        return _optik_tri_miss();
    }
    let a = v0 - o;
    let b = v1 - o;
    let c = v2 - o;
    let akz = _optik_pick(a, w.kz);
    let bkz = _optik_pick(b, w.kz);
    let ckz = _optik_pick(c, w.kz);
    let pa = vec2<f32>(_optik_pick(a, w.kx) - w.shear.x * akz, _optik_pick(a, w.ky) - w.shear.y * akz);
    let pb = vec2<f32>(_optik_pick(b, w.kx) - w.shear.x * bkz, _optik_pick(b, w.ky) - w.shear.y * bkz);
    let pc = vec2<f32>(_optik_pick(c, w.kx) - w.shear.x * ckz, _optik_pick(c, w.ky) - w.shear.y * ckz);
    var eu = _optik_edge(pc, pb);
    var ev = _optik_edge(pa, pc);
    var ew = _optik_edge(pb, pa);
    if eu == 0.0 || ev == 0.0 || ew == 0.0 { // @f64
        eu = _optik_edge64(pc, pb); // @f64
        ev = _optik_edge64(pa, pc); // @f64
        ew = _optik_edge64(pb, pa); // @f64
    } // @f64
    let su = _optik_edge_pushed(eu, pc, pb);
    let sv = _optik_edge_pushed(ev, pa, pc);
    let sw = _optik_edge_pushed(ew, pb, pa);
    if (su < 0.0 || sv < 0.0 || sw < 0.0) && (su > 0.0 || sv > 0.0 || sw > 0.0) {
        return _optik_tri_miss();
    }
    let det = eu + ev + ew;
    if det == 0.0 {
        return _optik_tri_miss();
    }
    let az = w.shear.z * akz;
    let bz = w.shear.z * bkz;
    let cz = w.shear.z * ckz;
    let t = (eu * az + ev * bz + ew * cz) / det;
    if !(t > tmin && t < tmax) {
        return _optik_tri_miss();
    }
    return _OptikTriHit(true, t, ev / det, ew / det, det > 0.0);
}

// Möller–Trumbore: faster, not watertight (rays through shared edges may leak).
fn _optik_tri_moller_trumbore(o: vec3<f32>, d: vec3<f32>, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, tmin: f32, tmax: f32) -> _OptikTriHit {
    let e1 = v1 - v0;
    let e2 = v2 - v0;
    let p = cross(d, e2);
    let det = dot(e1, p);
    if det == 0.0 {
        return _optik_tri_miss();
    }
    let inv = 1.0 / det;
    let s = o - v0;
    let u = dot(s, p) * inv;
    if u < 0.0 || u > 1.0 {
        return _optik_tri_miss();
    }
    let q = cross(s, e1);
    let v = dot(d, q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return _optik_tri_miss();
    }
    let t = dot(e2, q) * inv;
    if !(t > tmin && t < tmax) {
        return _optik_tri_miss();
    }
    return _OptikTriHit(true, t, u, v, det > 0.0);
}
