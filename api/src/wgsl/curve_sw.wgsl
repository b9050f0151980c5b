// Round curves of the software traversal: a segment in Bézier form (the host converts
// B-spline and Catmull-Rom control points) is split into OPTK_CURVE_PIECES straight pieces,
// each a round cone: two spheres at the piece ends joined by the cone tangent to both.
// Radii follow the same basis as the centres. Only entries from outside count (as OptiX's
// intersectors, rays starting inside a curve do not hit it).
//
// Tolerance: a piece of parameter length h stands in for the curve within h²/8 · max|B''|
// (the chord error of a polyline); with 8 pieces of a cubic that is at most 3/256 of the
// largest second difference of the Bézier control points. Linear curves are exact.

const OPTK_CURVE_PIECES: u32 = 8u;

struct OptkConeHit {
    hit: bool,
    t: f32,
    // Position along the piece, 0 at `pa` and 1 at `pb`.
    s: f32,
}

// Entry into a sphere from outside, in (tmin, tmax); `d` is unit length.
fn optk_sphere_entry(o: vec3<f32>, d: vec3<f32>, centre: vec3<f32>, radius: f32, tmin: f32, tmax: f32) -> f32 {
    let f = o - centre;
    let b = dot(f, d);
    let across = f - b * d;
    let disc = radius * radius - dot(across, across);
    if disc < 0.0 {
        return -1.0;
    }
    let t = -b - sqrt(disc);
    if t > tmin && t < tmax {
        return t;
    }
    return -1.0;
}

// A ray (unit direction `d`) against the round cone from (pa, ra) to (pb, rb). `cap_a` and
// `cap_b` say whether the end spheres count (open curve ends have none).
//
// With axis w, length L and sin θ = (ra − rb) / L, a point at axial position s and distance
// ρ from the axis lies on the tangent cone when ρ·cos θ = ra − s·sin θ; between the two
// tangent circles (s from ra·sin θ to L + rb·sin θ) that is the cone's side. Squaring gives
// a quadratic in t, written with the parts of (o − pa) and d across the axis so that nothing
// cancels when the ray is far along the axis.
fn optk_round_cone(o: vec3<f32>, d: vec3<f32>, pa: vec3<f32>, ra: f32, pb: vec3<f32>, rb: f32, cap_a: bool, cap_b: bool, tmin: f32, tmax: f32) -> OptkConeHit {
    var best = OptkConeHit(false, tmax, 0.0);
    if cap_a {
        let t = optk_sphere_entry(o, d, pa, ra, tmin, best.t);
        if t >= 0.0 {
            best = OptkConeHit(true, t, 0.0);
        }
    }
    if cap_b {
        let t = optk_sphere_entry(o, d, pb, rb, tmin, best.t);
        if t >= 0.0 {
            best = OptkConeHit(true, t, 1.0);
        }
    }
    let axis = pb - pa;
    let len = length(axis);
    if len <= abs(ra - rb) {
        // One end sphere holds the other: the piece is that sphere.
        let big_a = ra >= rb;
        let t = optk_sphere_entry(o, d, select(pb, pa, big_a), max(ra, rb), tmin, best.t);
        if t >= 0.0 {
            best = OptkConeHit(true, t, select(1.0, 0.0, big_a));
        }
        return best;
    }
    let w = axis / len;
    let sin_t = (ra - rb) / len;
    let cos2 = 1.0 - sin_t * sin_t;
    let f = o - pa;
    let s0 = dot(f, w);
    let sd = dot(d, w);
    let fp = f - s0 * w;
    let dp = d - sd * w;
    let k = ra - s0 * sin_t;
    let m = sd * sin_t;
    let qa = cos2 * dot(dp, dp) - m * m;
    let qb = cos2 * dot(fp, dp) + k * m;
    let qc = cos2 * dot(fp, fp) - k * k;
    let disc = qb * qb - qa * qc;
    if disc < 0.0 {
        return best;
    }
    let q = -(qb + select(-1.0, 1.0, qb >= 0.0) * sqrt(disc));
    var roots = vec2<f32>(-1.0, -1.0);
    if qa != 0.0 {
        roots.x = q / qa;
    }
    if q != 0.0 {
        roots.y = qc / q;
    }
    let s_lo = ra * sin_t;
    let s_hi = len + rb * sin_t;
    for (var i = 0u; i < 2u; i = i + 1u) {
        let t = roots[i];
        if !(t > tmin && t < best.t) {
            continue;
        }
        let s = s0 + t * sd;
        if s < s_lo || s > s_hi || ra - s * sin_t < 0.0 {
            continue;
        }
        // Only entries: the outward normal (radial·cos θ + w·sin θ) must face the ray.
        let radial = fp + t * dp;
        let normal = radial * sqrt(cos2) / max(length(radial), OPTK_MIN_NORMAL) + w * sin_t;
        if dot(normal, d) >= 0.0 {
            continue;
        }
        best = OptkConeHit(true, t, clamp(s / len, 0.0, 1.0));
    }
    return best;
}

// A point (xyz) and radius (w) on a Bézier segment of `degree` at parameter u.
fn optk_bezier(p: array<vec4<f32>, 4>, degree: u32, u: f32) -> vec4<f32> {
    let v = 1.0 - u;
    if degree == 1u {
        return v * p[0] + u * p[1];
    }
    if degree == 2u {
        return v * v * p[0] + 2.0 * u * v * p[1] + u * u * p[2];
    }
    return v * v * v * p[0] + 3.0 * u * v * v * p[1] + 3.0 * u * u * v * p[2] + u * u * u * p[3];
}

struct OptkCurveHit {
    hit: bool,
    t: f32,
    // The curve parameter of the hit, in [0, 1] along the segment.
    u: f32,
}

// A ray against one curve segment. `d` need not be unit length: t is returned in its units.
// `cap_start` / `cap_end` give round caps at the segment's own ends.
fn optk_curve(o: vec3<f32>, d: vec3<f32>, p: array<vec4<f32>, 4>, degree: u32, cap_start: bool, cap_end: bool, tmin: f32, tmax: f32) -> OptkCurveHit {
    let len = length(d);
    var result = OptkCurveHit(false, tmax, 0.0);
    if len == 0.0 {
        return result;
    }
    let dn = d / len;
    var pieces = OPTK_CURVE_PIECES;
    if degree == 1u {
        pieces = 1u;
    }
    var tmax_n = tmax * len;
    var a = optk_bezier(p, degree, 0.0);
    for (var i = 0u; i < pieces; i = i + 1u) {
        let b = optk_bezier(p, degree, f32(i + 1u) / f32(pieces));
        let cap_a = i > 0u || cap_start;
        let cap_b = i + 1u < pieces || cap_end;
        let h = optk_round_cone(o, dn, a.xyz, a.w, b.xyz, b.w, cap_a, cap_b, tmin * len, tmax_n);
        if h.hit {
            tmax_n = h.t;
            result = OptkCurveHit(true, h.t / len, (f32(i) + h.s) / f32(pieces));
        }
        a = b;
    }
    return result;
}
