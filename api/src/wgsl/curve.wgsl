// optik shared WGSL: the built-in round-curve intersector (DESIGN.md §3 "Shared WGSL", §5).
//
// Written once in the project: the wgpu megakernel includes this file, and the Vulkan backend
// compiles it into the intersection stage it uses for curve build inputs. Pure functions
// only: no bindings and no device-API calls, every name prefixed `_optik`. It uses
// _OPTIK_HIT_KIND_FRONT_FACE from sphere.wgsl; include that file too.
//
// A round curve segment is the surface swept by a sphere whose centre and radius follow the
// segment's basis. The test approximates the segment by `_optik_curve_pieces(basis)` round
// cones (a cone frustum tangent to two end spheres) joined at parameters k / n, and
// intersects those exactly.
//
// Stated tolerance: linear segments are exact (one piece). For the other bases the pieces'
// axes deviate from the curve by at most max|C''| / (8 n^2), where C'' is the second
// derivative of the segment with respect to its parameter u in [0, 1] (for uniform B-splines
// and Catmull-Rom it is bounded by the control polygon's second differences, times 1 for
// quadratic B-splines and 6 for the cubic bases); radii interpolate the same way. With
// n = 8 (quadratic) and n = 16 (cubic, Catmull-Rom) that is 1/512 and 6/2048 of the largest
// second difference of the control points: hit distances and curve parameters agree with
// the true swept surface to about 1e-3 of the segment's size for control polygons that do
// not fold back on themselves.
//
// Culling: as OptiX's curves, only rays entering the tube hit it; a ray starting inside a
// tube does not hit that tube (so secondary rays leaving a curve's surface do not re-hit it).
// Every reported hit is a front-face hit (_OPTIK_HIT_KIND_FRONT_FACE).

// Curve bases, in the order of optik's `CurveType`.
const _OPTIK_CURVE_ROUND_LINEAR: u32 = 0u;
const _OPTIK_CURVE_ROUND_QUADRATIC_BSPLINE: u32 = 1u;
const _OPTIK_CURVE_ROUND_CUBIC_BSPLINE: u32 = 2u;
const _OPTIK_CURVE_ROUND_CATMULLROM: u32 = 3u;

// Round cones per segment.
fn _optik_curve_pieces(basis: u32) -> u32 {
    switch basis {
        case 0u: { return 1u; }
        case 1u: { return 8u; }
        default: { return 16u; }
    }
}

// The centre (xyz) and radius (w) at parameter u in [0, 1] of a segment with control points
// p0..p3 (xyz, radius w; bases with fewer points ignore the last ones).
fn _optik_curve_eval(basis: u32, p0: vec4<f32>, p1: vec4<f32>, p2: vec4<f32>, p3: vec4<f32>, u: f32) -> vec4<f32> {
    let v = 1.0 - u;
    switch basis {
        case 0u: {
            return v * p0 + u * p1;
        }
        case 1u: {
            return (0.5 * v * v) * p0 + (0.5 + u * v) * p1 + (0.5 * u * u) * p2;
        }
        case 2u: {
            let u2 = u * u;
            let u3 = u2 * u;
            return (v * v * v / 6.0) * p0
                + ((3.0 * u3 - 6.0 * u2 + 4.0) / 6.0) * p1
                + ((-3.0 * u3 + 3.0 * u2 + 3.0 * u + 1.0) / 6.0) * p2
                + (u3 / 6.0) * p3;
        }
        default: {
            let u2 = u * u;
            let u3 = u2 * u;
            return (0.5 * (-u3 + 2.0 * u2 - u)) * p0
                + (0.5 * (3.0 * u3 - 5.0 * u2 + 2.0)) * p1
                + (0.5 * (-3.0 * u3 + 4.0 * u2 + u)) * p2
                + (0.5 * (u3 - u2)) * p3;
        }
    }
}

// Where a ray enters a round cone: the union of the spheres centred on a.xyz -> b.xyz whose
// radius goes linearly from a.w to b.w. The end spheres count only where `cap_a` / `cap_b`
// ask for them. Hits must also lie on the positive side of both planes `clip0` and `clip1`
// (dot(xyz, p) + w >= 0; vec4(0, 0, 0, 1) clips nothing): open strand ends cut the whole
// segment flat there. Returns (t, s, 1) for the first entry with t in [tmin, tmax], where s in
// [0, 1] is the parameter of the sphere touching the hit point, or (0, 0, 0).
//
// The cone body: with L^2 = |b - a|^2, rr = a.w - b.w and d2 = L^2 - rr^2 > 0 (neither end
// sphere contains the other), a point x lies on the tangent cone when
//   d2 |x - a|^2 - Y^2 + 2 a.w rr Y - a.w^2 L^2 = 0,   Y = (x - a).(b - a),
// negative inside, and on the part between the tangent circles when Y - a.w rr is in [0, d2];
// then s = (Y - a.w rr) / d2. Substituting x = o + t d gives k2 t^2 + 2 k1 t + k0 = 0; the ray
// enters where the implicit function decreases, the root (-k1 - sqrt(k1^2 - k0 k2)) / k2.
fn _optik_round_cone(origin: vec3<f32>, direction: vec3<f32>, a: vec4<f32>, b: vec4<f32>, cap_a: bool, cap_b: bool, clip0: vec4<f32>, clip1: vec4<f32>, tmin: f32, tmax: f32) -> vec3<f32> {
    var best = vec3<f32>(0.0);
    var best_t = tmax;
    let ba = b.xyz - a.xyz;
    let oa = origin - a.xyz;
    let l2 = dot(ba, ba);
    let rr = a.w - b.w;
    let d2 = l2 - rr * rr;
    if d2 > 0.0 {
        let dd = dot(direction, direction);
        let m1 = dot(ba, oa);
        let m2 = dot(ba, direction);
        let m3 = dot(oa, direction);
        let m5 = dot(oa, oa);
        let k2 = d2 * dd - m2 * m2;
        let k1 = d2 * m3 - m1 * m2 + a.w * rr * m2;
        let k0 = d2 * m5 - m1 * m1 + 2.0 * a.w * rr * m1 - a.w * a.w * l2;
        let h = k1 * k1 - k0 * k2;
        if k2 != 0.0 && h >= 0.0 {
            let t = (-k1 - sqrt(h)) / k2;
            let y = m1 + t * m2 - a.w * rr;
            if y >= 0.0 && y <= d2 && t >= tmin && t <= best_t && _optik_curve_kept(origin + t * direction, clip0, clip1) {
                best_t = t;
                best = vec3<f32>(t, y / d2, 1.0);
            }
        }
    }
    if cap_a {
        let r = _optik_sphere_roots(a.xyz, a.w, origin, direction);
        if r.z != 0.0 && r.x >= tmin && r.x <= best_t && _optik_curve_kept(origin + r.x * direction, clip0, clip1) {
            best_t = r.x;
            best = vec3<f32>(r.x, 0.0, 1.0);
        }
    }
    if cap_b {
        let r = _optik_sphere_roots(b.xyz, b.w, origin, direction);
        if r.z != 0.0 && r.x >= tmin && r.x <= best_t && _optik_curve_kept(origin + r.x * direction, clip0, clip1) {
            best_t = r.x;
            best = vec3<f32>(r.x, 1.0, 1.0);
        }
    }
    return best;
}

// Whether a point lies on the kept side of both clip planes.
fn _optik_curve_kept(p: vec3<f32>, clip0: vec4<f32>, clip1: vec4<f32>) -> bool {
    return dot(clip0.xyz, p) + clip0.w >= 0.0 && dot(clip1.xyz, p) + clip1.w >= 0.0;
}

// The first entry of a ray into a round curve segment in [tmin, tmax], as (t, u, 1) with u the
// curve parameter in [0, 1], or (0, 0, 0). `cap_start` / `cap_end` put round caps on the
// segment's ends (strand ends with end caps, and every end of a linear curve; joints between
// the segments of a strand); joints between the pieces of a segment are always round. An end
// without a cap is open: the tube is cut flat by the plane through the end, perpendicular
// to the end piece's axis (the joint spheres inside the segment do not poke out of it).
fn _optik_curve_intersect(basis: u32, p0: vec4<f32>, p1: vec4<f32>, p2: vec4<f32>, p3: vec4<f32>, cap_start: bool, cap_end: bool, origin: vec3<f32>, direction: vec3<f32>, tmin: f32, tmax: f32) -> vec3<f32> {
    let dd = dot(direction, direction);
    if !(dd > 0.0) {
        return vec3<f32>(0.0);
    }
    // Move the origin along the ray next to the segment before solving: the quadratics then
    // work with small numbers, not with the squared distance to a far camera.
    let mid = _optik_curve_eval(basis, p0, p1, p2, p3, 0.5).xyz;
    let shift = dot(mid - origin, direction) / dd;
    let o = origin + shift * direction;
    let n = _optik_curve_pieces(basis);
    var best = vec3<f32>(0.0);
    var best_t = tmax - shift;
    var clip0 = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    var clip1 = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    let first = _optik_curve_eval(basis, p0, p1, p2, p3, 0.0).xyz;
    let last = _optik_curve_eval(basis, p0, p1, p2, p3, 1.0).xyz;
    if !cap_start {
        let axis = _optik_curve_eval(basis, p0, p1, p2, p3, 1.0 / f32(n)).xyz - first;
        clip0 = vec4<f32>(axis, -dot(axis, first));
    }
    if !cap_end {
        let axis = last - _optik_curve_eval(basis, p0, p1, p2, p3, 1.0 - 1.0 / f32(n)).xyz;
        clip1 = vec4<f32>(-axis, dot(axis, last));
    }
    // The planes in the shifted frame.
    clip0.w += dot(clip0.xyz, shift * direction);
    clip1.w += dot(clip1.xyz, shift * direction);
    var a = _optik_curve_eval(basis, p0, p1, p2, p3, 0.0);
    for (var i = 0u; i < n; i++) {
        let u1 = f32(i + 1u) / f32(n);
        let b = _optik_curve_eval(basis, p0, p1, p2, p3, u1);
        let hit = _optik_round_cone(o, direction, a, b, i > 0u || cap_start, i + 1u < n || cap_end, clip0, clip1, tmin - shift, best_t);
        if hit.z != 0.0 {
            best_t = hit.x;
            best = vec3<f32>(hit.x + shift, (f32(i) + hit.y) / f32(n), 1.0);
        }
        a = b;
    }
    return best;
}
