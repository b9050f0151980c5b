// Affine 3×4 transforms (three row vec4s, row-major as OptiX's) and motion interpolation
// (optik_api::semantics::motion): keys evenly spaced in [time_begin, time_end], clamped
// outside unless the vanish flags say otherwise; matrices lerp element-wise; SRT keys lerp
// all 16 values and then normalise the quaternion (nlerp), as OptiX does.

struct _OptikXform {
    r0: vec4<f32>,
    r1: vec4<f32>,
    r2: vec4<f32>,
}

fn _optik_xform_identity() -> _OptikXform {
    return _OptikXform(vec4<f32>(1.0, 0.0, 0.0, 0.0), vec4<f32>(0.0, 1.0, 0.0, 0.0), vec4<f32>(0.0, 0.0, 1.0, 0.0));
}

fn _optik_xform_point(m: _OptikXform, p: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(m.r0.xyz, p) + m.r0.w, dot(m.r1.xyz, p) + m.r1.w, dot(m.r2.xyz, p) + m.r2.w);
}

fn _optik_xform_vector(m: _OptikXform, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(m.r0.xyz, v), dot(m.r1.xyz, v), dot(m.r2.xyz, v));
}

// a · b (b applied first).
fn _optik_xform_mul(a: _OptikXform, b: _OptikXform) -> _OptikXform {
    let c0 = vec3<f32>(b.r0.x, b.r1.x, b.r2.x);
    let c1 = vec3<f32>(b.r0.y, b.r1.y, b.r2.y);
    let c2 = vec3<f32>(b.r0.z, b.r1.z, b.r2.z);
    let c3 = vec3<f32>(b.r0.w, b.r1.w, b.r2.w);
    return _OptikXform(
        vec4<f32>(dot(a.r0.xyz, c0), dot(a.r0.xyz, c1), dot(a.r0.xyz, c2), dot(a.r0.xyz, c3) + a.r0.w),
        vec4<f32>(dot(a.r1.xyz, c0), dot(a.r1.xyz, c1), dot(a.r1.xyz, c2), dot(a.r1.xyz, c3) + a.r1.w),
        vec4<f32>(dot(a.r2.xyz, c0), dot(a.r2.xyz, c1), dot(a.r2.xyz, c2), dot(a.r2.xyz, c3) + a.r2.w),
    );
}

// The inverse of an affine transform (cofactors); a singular one gives non-finite values,
// which the ray validity checks downstream treat as a miss.
fn _optik_xform_inverse(m: _OptikXform) -> _OptikXform {
    let a = m.r0.xyz;
    let b = m.r1.xyz;
    let c = m.r2.xyz;
    let bc = cross(b, c);
    let ca = cross(c, a);
    let ab = cross(a, b);
    let inv_det = 1.0 / dot(a, bc);
    // Rows of the inverse linear part are the columns of the cofactor matrix.
    let i0 = vec3<f32>(bc.x, ca.x, ab.x) * inv_det;
    let i1 = vec3<f32>(bc.y, ca.y, ab.y) * inv_det;
    let i2 = vec3<f32>(bc.z, ca.z, ab.z) * inv_det;
    let t = vec3<f32>(m.r0.w, m.r1.w, m.r2.w);
    return _OptikXform(vec4<f32>(i0, -dot(i0, t)), vec4<f32>(i1, -dot(i1, t)), vec4<f32>(i2, -dot(i2, t)));
}

// Where a time falls among the keys: `key` < 0 when the object vanishes; otherwise
// interpolate key `key` and `key + 1` by `frac` (frac 0 means key `key` alone).
struct _OptikKey {
    key: i32,
    frac: f32,
}

fn _optik_motion_key(num_keys: u32, time_begin: f32, time_end: f32, flags: u32, time: f32) -> _OptikKey {
    if (flags & 1u) != 0u && time < time_begin {
        return _OptikKey(-1, 0.0);
    }
    if (flags & 2u) != 0u && time > time_end {
        return _OptikKey(-1, 0.0);
    }
    if num_keys < 2u {
        return _OptikKey(0, 0.0);
    }
    let intervals = f32(num_keys - 1u);
    var x = intervals * ((time - time_begin) / (time_end - time_begin));
    if _optik_nan(x) {
        x = 0.0;
    }
    x = clamp(x, 0.0, intervals);
    let k = min(floor(x), intervals - 1.0);
    return _OptikKey(i32(k), x - k);
}

fn _optik_lerp_xform(a: _OptikXform, b: _OptikXform, t: f32) -> _OptikXform {
    return _OptikXform(a.r0 * (1.0 - t) + b.r0 * t, a.r1 * (1.0 - t) + b.r1 * t, a.r2 * (1.0 - t) + b.r2 * t);
}

// An SRT key as OptiX's 16 floats in four vec4s: (sx a b pvx) (sy c pvy sz) (pvz qx qy qz)
// (qw tx ty tz). Returns the object-to-world matrix T · R · S.
fn _optik_srt_matrix(k0: vec4<f32>, k1: vec4<f32>, k2: vec4<f32>, k3: vec4<f32>) -> _OptikXform {
    let s = _OptikXform(vec4<f32>(k0.x, k0.y, k0.z, k0.w), vec4<f32>(0.0, k1.x, k1.y, k1.z), vec4<f32>(0.0, 0.0, k1.w, k2.x));
    let x = k2.y;
    let y = k2.z;
    let z = k2.w;
    let w = k3.x;
    let r = _OptikXform(
        vec4<f32>(1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w), 0.0),
        vec4<f32>(2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w), 0.0),
        vec4<f32>(2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y), 0.0),
    );
    var m = _optik_xform_mul(r, s);
    m.r0.w = m.r0.w + k3.y;
    m.r1.w = m.r1.w + k3.z;
    m.r2.w = m.r2.w + k3.w;
    return m;
}

// Lerps two SRT keys and normalises the quaternion (at frac 0 the key is used as stored).
fn _optik_srt_lerp(a: array<vec4<f32>, 4>, b: array<vec4<f32>, 4>, t: f32) -> _OptikXform {
    if t == 0.0 {
        return _optik_srt_matrix(a[0], a[1], a[2], a[3]);
    }
    let k0 = a[0] * (1.0 - t) + b[0] * t;
    let k1 = a[1] * (1.0 - t) + b[1] * t;
    var k2 = a[2] * (1.0 - t) + b[2] * t;
    var k3 = a[3] * (1.0 - t) + b[3] * t;
    let q = vec4<f32>(k2.y, k2.z, k2.w, k3.x);
    let len = length(q);
    if len > 0.0 {
        let n = q / len;
        k2 = vec4<f32>(k2.x, n.x, n.y, n.z);
        k3 = vec4<f32>(n.w, k3.y, k3.z, k3.w);
    }
    return _optik_srt_matrix(k0, k1, k2, k3);
}
