//! Traversal as optik's stages see it on Vulkan: the prelude's WGSL for what optik emulates
//! there (device_api.rs includes it): where
//! primitives are at the ray's time and the object space of paths through motion transforms
//! (accel/motion.rs), and opacity decided by optik's stages (`optik_api::semantics::opacity`)
//! where micromaps take it from the driver. Each piece is written only when the pipeline's
//! configuration needs it; without motion, primitives read key 0 and object space is
//! Vulkan's.

use super::config::LoweringConfig;

/// Where primitives and instances are at the ray's time: key resolution, primitive data per
/// key (key-major, tables.rs), the motion chain of a path, and the object space they give.
/// Without motion structures everything reads key 0 and the object space is Vulkan's.
pub fn motion_functions(c: &LoweringConfig) -> String {
    let mut s = String::new();
    s.push_str(
        r#"
fn _optik_time() -> f32 {
    $TIME
}
"#
        .replace(
            "$TIME",
            if c.motion {
                "return bitcast<f32>(_optik_state[_optik_slot()].x);"
            } else {
                "return 0.0;"
            },
        )
        .as_str(),
    );
    s.push_str(PRIMITIVE_STRUCTS);
    if !c.motion_structures {
        s.push_str(STATIC_PRIMITIVES);
        if c.box_guard() {
            s.push_str(BOX_MISS);
            s.push_str(STATIC_BOX_GUARD);
        }
        return s;
    }
    s.push_str(BOX_MISS);
    s.push_str(&MOTION_PRIMITIVES.replace(
        "$KEY",
        if c.motion {
            "return _optik_motion_key(num_keys, begin, end, flags, _optik_time());"
        } else {
            // Pipelines compiled without motion use key 0 (as the CPU backend's).
            "return _OptikKey(0, 0.0);"
        },
    ));
    s
}

/// What the primitive readers of both kinds of scene return (`live` false when a primitive
/// vanished at the ray's time).
const PRIMITIVE_STRUCTS: &str = r#"
struct _OptikTriangle {
    v0: vec3<f32>,
    v1: vec3<f32>,
    v2: vec3<f32>,
    live: bool,
}

// A curve segment's control points (xyz, radius) and cap bits; `live` false when it vanished.
struct _OptikSegment {
    p0: vec4<f32>,
    p1: vec4<f32>,
    p2: vec4<f32>,
    p3: vec4<f32>,
    caps: u32,
    live: bool,
}
"#;

/// Primitive data of static scenes: key 0 only, Vulkan's object space.
const STATIC_PRIMITIVES: &str = r#"
fn _optik_triangle(g0: vec4<u32>, g1: vec4<u32>, p: u32) -> _OptikTriangle {
    let a = g0.z + p * 9u;
    return _OptikTriangle(_optik_data_vec3(a), _optik_data_vec3(a + 3u), _optik_data_vec3(a + 6u), true);
}

fn _optik_sphere_at(g0: vec4<u32>, g1: vec4<u32>, p: u32) -> vec4<f32> {
    return _optik_data_vec4(g0.z + p * 4u);
}

fn _optik_segment(g0: vec4<u32>, g1: vec4<u32>, p: u32) -> _OptikSegment {
    let b = g0.z + p * 17u;
    return _OptikSegment(_optik_data_vec4(b), _optik_data_vec4(b + 4u), _optik_data_vec4(b + 8u), _optik_data_vec4(b + 12u), _optik_data[b + 16u], true);
}

fn _optik_obj_origin() -> vec3<f32> {
    return _optik_object_ray_origin();
}

fn _optik_obj_direction() -> vec3<f32> {
    return _optik_object_ray_direction();
}

fn _optik_obj_to_world() -> mat4x3<f32> {
    return _optik_object_to_world();
}

fn _optik_world_to_obj() -> mat4x3<f32> {
    return _optik_world_to_object();
}

"#;

/// Whether the object-space ray misses a box in its current interval, by the shared
/// conservative slab test (the CPU backend's): the box guard of custom primitives.
const BOX_MISS: &str = r#"
fn _optik_misses_box(lo: vec3<f32>, hi: vec3<f32>) -> bool {
    let r = _optik_slab_ray(_optik_obj_origin(), _optik_canonical_direction(_optik_obj_direction()));
    return !_optik_box1(r, lo, hi, _optik_ray_tmin(), _optik_ray_tmax());
}
"#;

/// The box guard of static scenes: whether the ray misses the hit's custom primitive's own
/// box (the geometry's data holds the boxes as given). The driver tests padded boxes, and
/// hardware quantises them, so it runs intersection programs for rays that miss the box;
/// the CPU backend runs them only for rays that meet it.
const STATIC_BOX_GUARD: &str = r#"
fn _optik_vanished() -> bool {
    let g0 = _optik_geometry_record();
    if _optik_kind(g0) != 1u || g0.z == 0xFFFFFFFFu {
        return false;
    }
    let a = g0.z + _optik_primitive_id() * 6u;
    return _optik_misses_box(_optik_data_vec3(a), _optik_data_vec3(a + 3u));
}
"#;

/// Primitive data and object space of scenes with motion.
const MOTION_PRIMITIVES: &str = r#"
fn _optik_key(num_keys: u32, flags: u32, begin: f32, end: f32) -> _OptikKey {
    $KEY
}

// The key position of a geometry's primitives (key 0 when the geometry has no motion keys).
fn _optik_geometry_key(g1: vec4<u32>) -> _OptikKey {
    if g1.x == 0xFFFFFFFFu {
        return _OptikKey(0, 0.0);
    }
    let m = g1.x;
    return _optik_key(_optik_data[m], _optik_data[m + 1u], bitcast<f32>(_optik_data[m + 2u]), bitcast<f32>(_optik_data[m + 3u]));
}

// A motion transform above the primitive that vanished at the ray's time hides it too.
fn _optik_triangle(g0: vec4<u32>, g1: vec4<u32>, p: u32) -> _OptikTriangle {
    let k = _optik_geometry_key(g1);
    if k.key < 0 || !_optik_path().live {
        return _OptikTriangle(vec3<f32>(), vec3<f32>(), vec3<f32>(), false);
    }
    let a = g0.z + (u32(k.key) * g1.z + p) * 9u;
    var t = _OptikTriangle(_optik_data_vec3(a), _optik_data_vec3(a + 3u), _optik_data_vec3(a + 6u), true);
    if k.frac > 0.0 {
        let b = a + g1.z * 9u;
        t.v0 = t.v0 * (1.0 - k.frac) + _optik_data_vec3(b) * k.frac;
        t.v1 = t.v1 * (1.0 - k.frac) + _optik_data_vec3(b + 3u) * k.frac;
        t.v2 = t.v2 * (1.0 - k.frac) + _optik_data_vec3(b + 6u) * k.frac;
    }
    return t;
}

// A sphere (centre, radius) at the ray's time; radius -1 when it vanished.
fn _optik_sphere_at(g0: vec4<u32>, g1: vec4<u32>, p: u32) -> vec4<f32> {
    let k = _optik_geometry_key(g1);
    if k.key < 0 || !_optik_path().live {
        return vec4<f32>(0.0, 0.0, 0.0, -1.0);
    }
    let a = g0.z + (u32(k.key) * g1.z + p) * 4u;
    var s = _optik_data_vec4(a);
    if k.frac > 0.0 {
        s = s * (1.0 - k.frac) + _optik_data_vec4(a + g1.z * 4u) * k.frac;
    }
    return s;
}

fn _optik_segment(g0: vec4<u32>, g1: vec4<u32>, p: u32) -> _OptikSegment {
    let k = _optik_geometry_key(g1);
    if k.key < 0 || !_optik_path().live {
        return _OptikSegment(vec4<f32>(), vec4<f32>(), vec4<f32>(), vec4<f32>(), 0u, false);
    }
    let a = g0.z + (u32(k.key) * g1.z + p) * 17u;
    var c = _OptikSegment(_optik_data_vec4(a), _optik_data_vec4(a + 4u), _optik_data_vec4(a + 8u), _optik_data_vec4(a + 12u), _optik_data[a + 16u], true);
    if k.frac > 0.0 {
        let b = a + g1.z * 17u;
        let f = k.frac;
        c.p0 = c.p0 * (1.0 - f) + _optik_data_vec4(b) * f;
        c.p1 = c.p1 * (1.0 - f) + _optik_data_vec4(b + 4u) * f;
        c.p2 = c.p2 * (1.0 - f) + _optik_data_vec4(b + 8u) * f;
        c.p3 = c.p3 * (1.0 - f) + _optik_data_vec4(b + 12u) * f;
    }
    return c;
}

fn _optik_data_xform(a: u32) -> _OptikXform {
    return _OptikXform(_optik_data_vec4(a), _optik_data_vec4(a + 4u), _optik_data_vec4(a + 8u));
}

fn _optik_data_srt(a: u32) -> array<vec4<f32>, 4> {
    return array<vec4<f32>, 4>(_optik_data_vec4(a), _optik_data_vec4(a + 4u), _optik_data_vec4(a + 8u), _optik_data_vec4(a + 12u));
}

// A path's transform below its Vulkan instance at the ray's time (object to instance space)
// and its inverse; `live` false when a motion transform on it vanished.
struct _OptikPath {
    to_instance: _OptikXform,
    from_instance: _OptikXform,
    moving: bool,
    live: bool,
}

// Composes the motion chain at `at` (accel/motion.rs writes it): a link count, then per link
// [kind (0 static, 1 matrix motion, 2 SRT motion), keys, flags, time begin, time end] and
// its 3x4 matrix (static), its matrix keys or its SRT keys, outermost first.
fn _optik_chain(at: u32) -> _OptikPath {
    var m = _optik_xform_identity();
    let n = _optik_data[at];
    var c = at + 1u;
    for (var i = 0u; i < n; i = i + 1u) {
        let kind = _optik_data[c];
        let keys = _optik_data[c + 1u];
        let flags = _optik_data[c + 2u];
        let begin = bitcast<f32>(_optik_data[c + 3u]);
        let end = bitcast<f32>(_optik_data[c + 4u]);
        c = c + 5u;
        var x = _optik_xform_identity();
        if kind == 0u {
            x = _optik_data_xform(c);
            c = c + 12u;
        } else {
            let k = _optik_key(keys, flags, begin, end);
            if k.key < 0 {
                return _OptikPath(m, m, true, false);
            }
            if kind == 1u {
                let a = c + u32(k.key) * 12u;
                x = _optik_data_xform(a);
                if k.frac > 0.0 {
                    x = _optik_lerp_xform(x, _optik_data_xform(a + 12u), k.frac);
                }
                c = c + keys * 12u;
            } else {
                let a = c + u32(k.key) * 16u;
                x = _optik_srt_lerp(_optik_data_srt(a), _optik_data_srt(a + select(0u, 16u, k.frac > 0.0)), k.frac);
                c = c + keys * 16u;
            }
        }
        m = _optik_xform_mul(m, x);
    }
    return _OptikPath(m, _optik_xform_inverse(m), true, true);
}

var<private> _optik_path_cache: _OptikPath;
var<private> _optik_path_ready: bool;

// The hit's path below its Vulkan instance (identity without a motion chain), composed once
// per stage invocation.
fn _optik_path() -> _OptikPath {
    if !_optik_path_ready {
        let chain = _optik_instances[_optik_instance_record() + 1u].x;
        if chain == 0xFFFFFFFFu {
            _optik_path_cache = _OptikPath(_optik_xform_identity(), _optik_xform_identity(), false, true);
        } else {
            _optik_path_cache = _optik_chain(chain);
        }
        _optik_path_ready = true;
    }
    return _optik_path_cache;
}

fn _optik_obj_origin() -> vec3<f32> {
    let o = _optik_object_ray_origin();
    let path = _optik_path();
    if !path.moving {
        return o;
    }
    return _optik_xform_point(path.from_instance, o);
}

fn _optik_obj_direction() -> vec3<f32> {
    let d = _optik_object_ray_direction();
    let path = _optik_path();
    if !path.moving {
        return d;
    }
    return _optik_xform_vector(path.from_instance, d);
}

fn _optik_xform_of(m: mat4x3<f32>) -> _OptikXform {
    return _OptikXform(vec4<f32>(m[0].x, m[1].x, m[2].x, m[3].x), vec4<f32>(m[0].y, m[1].y, m[2].y, m[3].y), vec4<f32>(m[0].z, m[1].z, m[2].z, m[3].z));
}

fn _optik_mat_of(x: _OptikXform) -> mat4x3<f32> {
    return mat4x3<f32>(vec3<f32>(x.r0.x, x.r1.x, x.r2.x), vec3<f32>(x.r0.y, x.r1.y, x.r2.y), vec3<f32>(x.r0.z, x.r1.z, x.r2.z), vec3<f32>(x.r0.w, x.r1.w, x.r2.w));
}

fn _optik_obj_to_world() -> mat4x3<f32> {
    let path = _optik_path();
    if !path.moving {
        return _optik_object_to_world();
    }
    return _optik_mat_of(_optik_xform_mul(_optik_xform_of(_optik_object_to_world()), path.to_instance));
}

fn _optik_world_to_obj() -> mat4x3<f32> {
    let path = _optik_path();
    if !path.moving {
        return _optik_world_to_object();
    }
    return _optik_mat_of(_optik_xform_mul(path.from_instance, _optik_xform_of(_optik_world_to_object())));
}

// Whether the hit's primitive does not exist at the ray's time (a vanish flag of its motion
// chain or of its geometry's keys), or, for custom primitives, the ray misses the
// primitive's box at that time (the CPU backend runs intersection programs only for rays
// that meet the interpolated box; the driver's test of the padded box lets more through).
fn _optik_vanished() -> bool {
    if !_optik_path().live {
        return true;
    }
    let g0 = _optik_geometry_record();
    let g1 = _optik_geometry_extra();
    let k = _optik_geometry_key(g1);
    if k.key < 0 {
        return true;
    }
    if _optik_kind(g0) != 1u || g0.z == 0xFFFFFFFFu {
        return false;
    }
    let a = g0.z + (u32(k.key) * g1.z + _optik_primitive_id()) * 6u;
    var lo = _optik_data_vec3(a);
    var hi = _optik_data_vec3(a + 3u);
    if k.frac > 0.0 {
        let b = a + g1.z * 6u;
        lo = lo * (1.0 - k.frac) + _optik_data_vec3(b) * k.frac;
        hi = hi * (1.0 - k.frac) + _optik_data_vec3(b + 3u) * k.frac;
    }
    return _optik_misses_box(lo, hi);
}
"#;

/// Opacity and culling decided by optik's stages (`optik_api::semantics::opacity`): the
/// flags of the current ray (from the state word), the candidate's fate.
pub fn opacity_functions(c: &LoweringConfig) -> String {
    let mut s = String::new();
    // Without flags in the state, Vulkan's stand in (SkipTrianglesKHR meaning both faces, as
    // the fold in `_optik_vk_ray_flags` writes it).
    s.push_str(if c.track_ray_flags {
        "\nfn _optik_current_ray_flags() -> u32 {\n    return _optik_state[_optik_slot()].z & 0xFFFFu;\n}\n"
    } else {
        "\nfn _optik_current_ray_flags() -> u32 {\n    let f = _optik_ray_flags();\n    return select(f, f | 48u, (f & 256u) != 0u);\n}\n"
    });
    if c.micromaps {
        s.push_str(optik_api::wgsl::OPACITY);
        s.push_str(OPACITY_CULLED);
    }
    s
}

/// Whether the hit's candidate is culled by opacity (primitives without micromaps), by the
/// shared `_optik_fate`.
const OPACITY_CULLED: &str = r#"
fn _optik_opacity_culled() -> bool {
    let inst = _optik_instances[_optik_instance_record()].w;
    let geometry = (_optik_geometry_record().w >> 16u) & 0xFFu;
    return _optik_fate(geometry, inst, _optik_current_ray_flags(), 4u) == 0u;
}
"#;
