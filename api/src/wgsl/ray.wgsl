// Ray checks and set-up for software traversal (DESIGN.md §4, §5).
//
// Special values are tested on bits: shader compilers may assume floats are never NaN or
// infinite and fold `x != x` or `x == inf` away.

const _OPTIK_MIN_NORMAL: f32 = 1.17549435e-38;

// +infinity, made at run time (WGSL has no infinite literal).
fn _optik_inf() -> f32 {
    return bitcast<f32>(0x7f800000u);
}

fn _optik_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn _optik_finite3(v: vec3<f32>) -> bool {
    let e = bitcast<vec3<u32>>(v) & vec3<u32>(0x7f800000u);
    return all(e != vec3<u32>(0x7f800000u));
}

fn _optik_nan(x: f32) -> bool {
    let b = bitcast<u32>(x);
    return (b & 0x7f800000u) == 0x7f800000u && (b & 0x007fffffu) != 0u;
}

// The invalid-ray policy of optik_api::semantics::ray::check: finite origin and direction,
// tmin not NaN and not negative (-0.0 is allowed), tmax not NaN, tmin <= tmax. Each check is a
// comparison of bits that returns at once. An earlier form (`_optik_nan(tmin) || (sign bit &&
// not -0.0)`, then `_optik_nan(tmax)`) judged valid rays invalid in lavapipe's Vulkan ray
// tracing stages (backend-vulkan/tests/vulkan/exceptions.rs failed) while it was right in
// compute shaders; this one is right in both, so both GPU backends share it.
fn _optik_ray_is_valid(origin: vec3<f32>, direction: vec3<f32>, tmin: f32, tmax: f32) -> bool {
    if !_optik_finite3(origin) {
        return false;
    }
    if !_optik_finite3(direction) {
        return false;
    }
    let tmin_bits = bitcast<u32>(tmin);
    // +0.0 up to +inf, or -0.0: negatives (sign bit set) and NaNs are above +inf's bits.
    if tmin_bits > 0x7f800000u && tmin_bits != 0x80000000u {
        return false;
    }
    if (bitcast<u32>(tmax) & 0x7fffffffu) > 0x7f800000u {
        return false;
    }
    return !(tmin > tmax);
}

// -0.0 components become +0.0, so that every later sign test treats them as zero
// (docs/numerics.md F0: obvhs's traversal misses everything for -0.0 directions).
fn _optik_canonical_direction(d: vec3<f32>) -> vec3<f32> {
    let b = bitcast<vec3<u32>>(d);
    return bitcast<vec3<f32>>(select(b, vec3<u32>(0u), b == vec3<u32>(0x80000000u)));
}

// A ray prepared for slab tests. Axes whose direction is zero or subnormal are "parallel":
// their slab is all of t when the origin lies between the planes, and empty otherwise, so no
// 0 * inf = NaN ever reaches a comparison.
struct _OptikSlabRay {
    origin: vec3<f32>,
    inv: vec3<f32>,
    parallel: vec3<bool>,
}

fn _optik_slab_ray(origin: vec3<f32>, direction: vec3<f32>) -> _OptikSlabRay {
    let parallel = abs(direction) < vec3<f32>(_OPTIK_MIN_NORMAL);
    let safe = select(direction, vec3<f32>(1.0), parallel);
    return _OptikSlabRay(origin, select(vec3<f32>(1.0) / safe, vec3<f32>(0.0), parallel), parallel);
}
