//! The WGSL of optik's own stages, compiled with the prelude like a user module: the built-in
//! sphere and curve intersection stages, the triangle stage of emulated triangles (the shared
//! watertight or Möller–Trumbore test of `optik_api::wgsl`), the stages of hit records past
//! the user's (hits without programs, or `INVALID_HIT_SBT` under debug exceptions), and the
//! null callable.
//!
//! Each stage reads its primitive from the data table (tables.rs) at the ray's time, in the
//! object space of its geometry (device_api.rs: `_optik_obj_origin`, which follows motion
//! chains). Only what the pipeline's configuration needs is written.

use super::config::{LoweringConfig, TriangleMode};
use super::device_api::raise_if;
use optik_api::ExceptionFlags;
use optik_api::wgsl::{self, SnippetOptions};

/// The WGSL of optik's programs for a pipeline with settings `c`; the curve stage
/// intersects curves of basis `curve_basis` (`optik_api::wgsl::curve_basis`).
pub fn internal_programs(c: &LoweringConfig, curve_basis: u32) -> String {
    let mut s = String::new();
    s.push_str(wgsl::SPHERE);
    s.push_str(wgsl::CURVE);
    s.push_str(SPHERE_AND_CURVE);
    s.push_str(&format!(
        "\nfn _optik_builtin_curve() {{\n    if _optik_kind(_optik_geometry_record()) != 3u {{\n        return;\n    }}\n    let c = _optik_curve_candidate({curve_basis}u);\n    if c.hit {{\n        _optik_report_intersection(c.t, 0u, c.attributes);\n    }}\n}}\n"
    ));
    if c.triangles.emulated() {
        s.push_str(&triangle_stage(c));
    }
    s.push_str(&past_table_stages(c));
    s.push_str(&format!(
        r#"
// Stands in for callable records without the kind of callable called, and for indices past
// the table.
fn _optik_null_callable() {{
    {}
}}
"#,
        raise_if(
            c,
            ExceptionFlags::DEBUG,
            "RT_EXCEPTION_CODE_CALLABLE_INVALID_SBT"
        )
    ));
    s
}

/// The sphere stage and the curve candidate.
const SPHERE_AND_CURVE: &str = r#"
// A candidate of optik's stages: its t, the hit kind to report and the attributes.
struct _OptikCandidate {
    hit: bool,
    t: f32,
    kind: u32,
    attributes: RtAttributes,
}

// A sphere of a sphere build input: its centre and radius are in the data table (object
// space). Reports the entry hit (kind 0) and, when that is out of range or ignored, the exit
// (kind 1), in the open interval (tmin, tmax) as triangles and the other backends' spheres;
// the object-space sphere goes into attributes 0..3 for rt_sphere.
fn _optik_builtin_sphere() {
    if _optik_kind(_optik_geometry_record()) != 2u {
        return;
    }
    let s = _optik_sphere_at(_optik_geometry_record(), _optik_geometry_extra(), _optik_primitive_id());
    let roots = _optik_sphere_roots_of(s);
    if roots.z == 0.0 {
        return;
    }
    var attributes: RtAttributes;
    attributes[0] = bitcast<u32>(s.x);
    attributes[1] = bitcast<u32>(s.y);
    attributes[2] = bitcast<u32>(s.z);
    attributes[3] = bitcast<u32>(s.w);
    let tmin = _optik_ray_tmin();
    if roots.x > tmin && roots.x < _optik_ray_tmax() {
        if _optik_report_intersection(roots.x, 0u, attributes) {
            return;
        }
    }
    if roots.y > tmin && roots.y < _optik_ray_tmax() {
        _optik_report_intersection(roots.y, 1u, attributes);
    }
}

// The roots of the ray with sphere `s` (radius < 0: it vanished) as _optik_sphere_roots gives
// them.
fn _optik_sphere_roots_of(s: vec4<f32>) -> vec3<f32> {
    if s.w < 0.0 {
        return vec3<f32>(0.0);
    }
    return _optik_sphere_roots(s.xyz, s.w, _optik_obj_origin(), _optik_obj_direction());
}

// The first root of the hit's sphere in the ray's interval, as a candidate (kind 0 entering,
// 1 leaving; the sphere in attributes 0..3).
fn _optik_sphere_candidate() -> _OptikCandidate {
    var c: _OptikCandidate;
    let s = _optik_sphere_at(_optik_geometry_record(), _optik_geometry_extra(), _optik_primitive_id());
    let roots = _optik_sphere_roots_of(s);
    let tmin = _optik_ray_tmin();
    let tmax = _optik_ray_tmax();
    if roots.z == 0.0 {
        return c;
    }
    c.attributes[0] = bitcast<u32>(s.x);
    c.attributes[1] = bitcast<u32>(s.y);
    c.attributes[2] = bitcast<u32>(s.z);
    c.attributes[3] = bitcast<u32>(s.w);
    if roots.x > tmin && roots.x < tmax {
        c.hit = true;
        c.t = roots.x;
    } else if roots.y > tmin && roots.y < tmax {
        c.hit = true;
        c.t = roots.y;
        c.kind = 1u;
    }
    return c;
}

// A curve segment of a curve build input of basis `basis`: 4 control points (xyz, radius)
// and the cap flags (bit 0 start, bit 1 end) in the data table. The curve parameter goes
// into attribute 0.
fn _optik_curve_candidate(basis: u32) -> _OptikCandidate {
    var c: _OptikCandidate;
    let seg = _optik_segment(_optik_geometry_record(), _optik_geometry_extra(), _optik_primitive_id());
    if !seg.live {
        return c;
    }
    let hit = _optik_curve_intersect(basis, seg.p0, seg.p1, seg.p2, seg.p3,
        (seg.caps & 1u) != 0u, (seg.caps & 2u) != 0u, _optik_obj_origin(), _optik_obj_direction(), _optik_ray_tmin(), _optik_ray_tmax());
    if hit.z != 0.0 {
        c.hit = true;
        c.t = hit.x;
        c.attributes[0] = bitcast<u32>(hit.y);
    }
    return c;
}
"#;

/// The triangle stage: the shared test chosen by the pipeline, face culling with the
/// geometry and instance overrides and FLIP_TRIANGLE_FACING (decided in object space), and
/// with micromaps their state and the candidate's whole fate.
fn triangle_stage(c: &LoweringConfig) -> String {
    let f64_fallback = matches!(c.triangles, TriangleMode::Watertight { f64: true });
    let options = SnippetOptions {
        conservative_boxes: true,
        f64_fallback,
    };
    let mut s = wgsl::specialise(wgsl::TRIANGLE, options);
    let test = match c.triangles {
        TriangleMode::MollerTrumbore => {
            "_optik_tri_moller_trumbore(o, d, tri.v0, tri.v1, tri.v2, _optik_ray_tmin(), _optik_ray_tmax())"
        }
        _ => {
            "_optik_tri_watertight(_optik_woop_ray(d), o, tri.v0, tri.v1, tri.v2, _optik_ray_tmin(), _optik_ray_tmax())"
        }
    };
    let lookup = if c.micromap_states {
        s.push_str(&wgsl::specialise(wgsl::MICROMAP, options));
        s.push_str(MICROMAP_LOOKUP);
        r#"
    if g1.y != 0xFFFFFFFFu && (iflags & 32u) == 0u {
        state = _optik_micromap(g1.y, p, h.u, h.v);
    }"#
    } else {
        ""
    };
    let opacity = if c.micromaps {
        format!(
            r#"
    var state = 4u;{lookup}
    let fate = _optik_fate(gflags, iflags, rflags, state);
    if fate == 0u {{
        return c;
    }}
    if fate == 1u {{
        kind = kind | 2u;
    }}"#
        )
    } else {
        String::new()
    };
    s.push_str(&format!(
        r#"
// The candidate of the hit's triangle: the shared test in the open interval (tmin, tmax) on
// the object-space ray (-0.0 directions canonicalised, so they answer as +0.0), the facing of
// the test (counter-clockwise seen from the origin) flipped by the instances, face culling
// unless the geometry or an instance disables it. The hit kind is 0 (front) or 1 (back), plus
// 2 when the candidate is opaque by its micromap; attributes 0 and 1 are the barycentrics.
fn _optik_triangle_candidate() -> _OptikCandidate {{
    var c: _OptikCandidate;
    let e0 = _optik_instances[_optik_instance_record()];
    let slot = 2u * (e0.z + _optik_geometry_index());
    let g0 = _optik_geometries[slot];
    let g1 = _optik_geometries[slot + 1u];
    let p = _optik_primitive_id();
    let tri = _optik_triangle(g0, g1, p);
    if !tri.live {{
        return c;
    }}
    let o = _optik_obj_origin();
    let d = _optik_canonical_direction(_optik_obj_direction());
    let h = {test};
    if !h.hit {{
        return c;
    }}
    let gflags = (g0.w >> 16u) & 0xFFu;
    let iflags = e0.w;
    let rflags = _optik_current_ray_flags();
    let front = h.front != ((iflags & 2u) != 0u);
    let cull_disabled = (gflags & 4u) != 0u || (iflags & 1u) != 0u;
    if !cull_disabled && ((front && (rflags & 32u) != 0u) || (!front && (rflags & 16u) != 0u)) {{
        return c;
    }}
    var kind = select(1u, 0u, front);{opacity}
    c.hit = true;
    c.t = h.t;
    c.kind = kind;
    c.attributes[0] = bitcast<u32>(h.u);
    c.attributes[1] = bitcast<u32>(h.v);
    return c;
}}

fn _optik_builtin_triangle() {{
    if _optik_kind(_optik_geometry_record()) != 0u {{
        return;
    }}
    let c = _optik_triangle_candidate();
    if c.hit {{
        _optik_report_intersection(c.t, c.kind, c.attributes);
    }}
}}
"#
    ));
    s
}

/// The micromap block of a geometry (tables.rs, accel/geometry.rs) read with the shared
/// lookup: `_optik_fetch` reads the data table as `vec4<u32>` (blocks are 16-byte aligned).
const MICROMAP_LOOKUP: &str = r#"
fn _optik_fetch(i: u32) -> vec4<u32> {
    let a = 4u * i;
    return vec4<u32>(_optik_data[a], _optik_data[a + 1u], _optik_data[a + 2u], _optik_data[a + 3u]);
}

// The micromap state (0..3) at barycentrics (u, v) of primitive `p` of the geometry whose
// micromap block starts at `block`.
fn _optik_micromap(block: u32, p: u32, u: f32, v: f32) -> u32 {
    let w1 = _optik_data[block + 4u + 2u * p + 1u];
    let special = w1 >> 16u;
    if special != 0u {
        return special - 1u;
    }
    let byte_offset = _optik_data[block + 4u + 2u * p];
    let states = (block + _optik_data[block]) / 4u;
    return _optik_micromap_state(states, byte_offset, w1 & 0xFFu, ((w1 >> 8u) & 1u) != 0u, u, v);
}
"#;

/// The stages of hit records past the user's. Without debug exceptions a candidate is a hit
/// without programs, as on the CPU backend (custom primitives, which need an intersection
/// program, are never hit); under debug exceptions it raises `INVALID_HIT_SBT`, as the CPU
/// backend does when it looks the candidate's record up.
fn past_table_stages(c: &LoweringConfig) -> String {
    use optik_api::PrimitiveTypeFlags as T;
    // Only the kinds the pipeline intersects.
    let triangles = if c.triangles.emulated() && c.intersects(T::TRIANGLE) {
        "\n    if kind == 0u {\n        h = _optik_triangle_candidate();\n    }"
    } else {
        ""
    };
    let spheres = if c.intersects(T::SPHERE) {
        "\n    if kind == 2u {\n        h = _optik_sphere_candidate();\n    }"
    } else {
        ""
    };
    let curves = if c.intersects(T::CURVES) {
        "\n    if kind == 3u {\n        h = _optik_curve_candidate(g0.w & 0xFFu);\n    }"
    } else {
        ""
    };
    let debug = c.exceptions.contains(ExceptionFlags::DEBUG);
    let custom = if debug && c.intersects(T::CUSTOM) {
        "\n    if kind == 1u {\n        h.hit = true;\n    }"
    } else {
        ""
    };
    let found = if debug {
        "_optik_raise(RT_EXCEPTION_CODE_INVALID_HIT_SBT);"
    } else {
        "_optik_report_intersection(h.t, h.kind, h.attributes);"
    };
    let mut s = format!(
        r#"
// The intersection stage of records past the user's, for every primitive kind.
fn _optik_builtin_past_table() {{
    let g0 = _optik_geometry_record();
    let kind = _optik_kind(g0);
    var h: _OptikCandidate;{triangles}{spheres}{curves}{custom}
    if h.hit {{
        {found}
    }}
}}
"#
    );
    if debug {
        s.push_str(
            r#"
// Native triangles: the any-hit and closest-hit stages of those records.
fn _optik_invalid_hit_program() {
    _optik_raise(RT_EXCEPTION_CODE_INVALID_HIT_SBT);
}
"#,
        );
    }
    s
}
