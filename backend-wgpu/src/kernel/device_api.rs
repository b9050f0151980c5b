//! The state programs see, and the device API over it.
//!
//! Only one program runs at a time in an invocation, so the state is a set of private
//! globals describing "the current program's view": its ray, its hit (the candidate during
//! intersection and any-hit programs), its payload or callable-argument registers and its
//! SBT record. Trace and callable calls save the caller's view in locals and restore it
//! when the callee returns, which is what makes the view per activation.

use super::KernelConfig;
use crate::program::instance::device_stub_name;
use optik_core::frontend::DeviceFunction;

pub(super) fn write(c: &KernelConfig<'_>, out: &mut String) {
    let n = c.payload_len();
    let t = c.features.max_trace_depth;
    let instancing = c.instancing();
    out.push_str(&format!(
        "\nconst _OPTIK_MAX_TRACE_DEPTH: u32 = {t}u;\nconst _OPTIK_NONE: u32 = 0xFFFFFFFFu;\nalias _OptikRegs = array<u32, {n}>;\n"
    ));
    if instancing {
        // Instances on the deepest path of the structures alive (the levels below the root).
        let levels = c.sizes.levels.saturating_sub(1).max(1);
        out.push_str(&format!("const _OPTIK_LEVELS: u32 = {levels}u;\n"));
    }
    out.push_str(
        r#"
// The ray of the current trace, in world space. `tmax` follows the closest hit so far.
struct _OptikRay {
    origin: vec3<f32>,
    tmin: f32,
    direction: vec3<f32>,
    tmax: f32,
    time: f32,
    flags: u32,
    mask: u32,
    sbt_offset: u32,
    sbt_stride: u32,
    miss_index: u32,
}

// A hit or candidate: what hit-related device functions return.
struct _OptikHit {
    t: f32,
    hit_kind: u32,
    prim_index: u32,
    gas_index: u32,
    instance_id: u32,
    instance_index: u32,
    // The hit group record (word index into _optik_sbt), or _OPTIK_NONE.
    record: u32,
    // The geometry structure's header and the primitive's slot (for vertex data).
    gas: u32,
    slot: u32,
    geom_flags: u32,
    inst_flags: u32,
    attrs: array<u32, 8>,
"#,
    );
    if instancing {
        // The hit's path through the graph: the structure under the trace's handle (before
        // transforms) and the instance records entered, outermost first; its object space
        // is rebuilt from them only when a program asks (`_optik_hit_frame`).
        out.push_str("    root: u32,\n    depth: u32,\n    path: array<u32, _OPTIK_LEVELS>,\n");
    }
    out.push_str(
        r#"}

var<private> _optik_launch_index: vec3<u32>;
// Trace depth of the current program (0 in raygen).
var<private> _optik_depth: u32;
var<private> _optik_ray: _OptikRay;
var<private> _optik_hit: _OptikHit;
// The traversal's closest hit so far, and whether there is one.
var<private> _optik_best: _OptikHit;
var<private> _optik_found: bool;
// The traversal must stop (terminate, exception).
var<private> _optik_done: bool;
var<private> _optik_regs: _OptikRegs;
var<private> _optik_record: u32;
// Why the current program must return at once: 0 no, 1 ignore, 2 terminate, 3 exception.
var<private> _optik_unwind: u32;
var<private> _optik_exception: i32;
"#,
    );
    if instancing {
        out.push_str(
            r#"// The current traversal's root structure and the instance records of its current level's
// path (entries below the level's depth), which candidates copy.
var<private> _optik_root: u32;
var<private> _optik_path: array<u32, _OPTIK_LEVELS>;
"#,
        );
        out.push_str(
            r#"// The object space of a hit: the ray in it and the matrices to and from world space
// (`_optik_hit_frame`, rebuilt from the hit's path by the traversal's code).
struct _OptikFrame {
    origin: vec3<f32>,
    direction: vec3<f32>,
    w2o: _OptikXform,
    o2w: _OptikXform,
}
"#,
        );
        if !c.traces() {
            // No trace, no hit: the device functions that ask still need a frame.
            out.push_str(
                "\nfn _optik_hit_frame() -> _OptikFrame {\n    return _OptikFrame(_optik_ray.origin, _optik_ray.direction, _optik_xform_identity(), _optik_xform_identity());\n}\n",
            );
        }
    }
    out.push_str(
        r#"

fn _optik_unwinding_fn() -> bool {
    return _optik_unwind != 0u;
}

// Group index and flags of a packed SBT record.
fn _optik_group(record: u32) -> u32 {
    return _optik_sbt[record];
}

fn _optik_group_flags(record: u32) -> u32 {
    if record == _OPTIK_NONE {
        return 0u;
    }
    return _optik_sbt[record + 1u];
}

"#,
    );
    for f in c.lowered.device_functions.iter().copied() {
        if let Some(body) = body(c, f) {
            out.push_str(&format!(
                "fn {}{} {{\n{body}}}\n\n",
                device_stub_name(f),
                signature(f, n)
            ));
        }
    }
}

/// The prelude signature with the aliases spelt out (WGSL types are structural).
fn signature(f: DeviceFunction, payload_len: u32) -> String {
    f.signature()
        .replace("RtHandle", "vec2<u32>")
        .replace("RtPayload", &format!("array<u32, {payload_len}>"))
        .replace("RtAttributes", "array<u32, 8>")
}

/// The body of a device function; `None` for those lowered elsewhere (trace, calls).
fn body(c: &KernelConfig<'_>, f: DeviceFunction) -> Option<String> {
    use DeviceFunction as F;
    let n = c.payload_len();
    let s = match f {
        F::LaunchIndex => "    return _optik_launch_index;\n".to_string(),
        F::LaunchDimensions => "    return _optik_launch.dims.xyz;\n".to_string(),
        F::GetPayload => format!("    if i < {n}u {{\n        return _optik_regs[i];\n    }}\n    return 0u;\n"),
        F::SetPayload => format!("    if i < {n}u {{\n        _optik_regs[i] = value;\n    }}\n"),
        F::GetAttribute => "    if i < 8u {\n        return _optik_hit.attrs[i];\n    }\n    return 0u;\n".to_string(),
        F::ReportIntersection => {
            if c.intersection() && c.traces() {
                "    return _optik_report(t, hit_kind, attributes);\n".to_string()
            } else {
                "    return false;\n".to_string()
            }
        }
        F::IgnoreIntersection => "    if _optik_unwind == 0u {\n        _optik_unwind = 1u;\n    }\n".to_string(),
        F::TerminateRay => "    if _optik_unwind == 0u {\n        _optik_unwind = 2u;\n    }\n".to_string(),
        F::WorldRayOrigin => "    return _optik_ray.origin;\n".to_string(),
        F::WorldRayDirection => "    return _optik_ray.direction;\n".to_string(),
        F::ObjectRayOrigin => if c.instancing() {
            "    return _optik_hit_frame().origin;\n"
        } else {
            "    return _optik_ray.origin;\n"
        }
        .to_string(),
        F::ObjectRayDirection => if c.instancing() {
            "    return _optik_hit_frame().direction;\n"
        } else {
            "    return _optik_ray.direction;\n"
        }
        .to_string(),
        F::RayTmin => "    return _optik_ray.tmin;\n".to_string(),
        F::RayTmax => "    return _optik_ray.tmax;\n".to_string(),
        F::RayTime => "    return _optik_ray.time;\n".to_string(),
        F::RayFlags => "    return _optik_ray.flags;\n".to_string(),
        F::RayMask => "    return _optik_ray.mask;\n".to_string(),
        F::PrimitiveIndex => "    return _optik_hit.prim_index;\n".to_string(),
        F::SbtGasIndex => "    return _optik_hit.gas_index;\n".to_string(),
        F::InstanceId => "    return _optik_hit.instance_id;\n".to_string(),
        F::InstanceIndex => "    return _optik_hit.instance_index;\n".to_string(),
        F::HitKind => "    return _optik_hit.hit_kind;\n".to_string(),
        // optik_api::semantics::facing::hit_kind_is_front.
        F::IsFrontFaceHit => "    let k = _optik_hit.hit_kind;\n    if k >= 0x80u {\n        return k == 0xFEu;\n    }\n    return (k & 1u) == 0u;\n".to_string(),
        F::TriangleBarycentrics => "    return vec2<f32>(bitcast<f32>(_optik_hit.attrs[0]), bitcast<f32>(_optik_hit.attrs[1]));\n".to_string(),
        F::CurveParameter => "    return bitcast<f32>(_optik_hit.attrs[0]);\n".to_string(),
        F::TriangleVertices => triangle_vertices(c),
        F::Sphere => sphere_data(c),
        F::ObjectToWorld => matrix(c, "o2w"),
        F::WorldToObject => matrix(c, "w2o"),
        F::SbtDataU32 => "    if _optik_record == _OPTIK_NONE {\n        return 0u;\n    }\n    return _optik_sbt[_optik_record + 8u + i];\n".to_string(),
        F::SbtDataF32 => "    if _optik_record == _OPTIK_NONE {\n        return 0.0;\n    }\n    return bitcast<f32>(_optik_sbt[_optik_record + 8u + i]);\n".to_string(),
        F::ThrowException => {
            if c.exception(optik_api::ExceptionFlags::USER) {
                "    _optik_raise(i32(code & 0x3FFFFFFFu));\n".to_string()
            } else {
                String::new()
            }
        }
        F::ExceptionCode => "    return _optik_exception;\n".to_string(),
        F::RemainingTraceDepth => "    return _OPTIK_MAX_TRACE_DEPTH - min(_optik_depth, _OPTIK_MAX_TRACE_DEPTH);\n".to_string(),
        F::Trace | F::DirectCall | F::ContinuationCall | F::OffsetRay => return None,
    };
    Some(s)
}

fn matrix(c: &KernelConfig<'_>, which: &str) -> String {
    if c.instancing() {
        format!(
            "    let m = _optik_hit_frame().{which};\n    return mat4x3<f32>(vec3<f32>(m.r0.x, m.r1.x, m.r2.x), vec3<f32>(m.r0.y, m.r1.y, m.r2.y), vec3<f32>(m.r0.z, m.r1.z, m.r2.z), vec3<f32>(m.r0.w, m.r1.w, m.r2.w));\n"
        )
    } else {
        "    return mat4x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(0.0));\n".to_string()
    }
}

/// Vertex `i` of the hit triangle in object space, at the ray's time.
fn triangle_vertices(c: &KernelConfig<'_>) -> String {
    if !c.triangles() || !c.traces() {
        return "    return array<vec3<f32>, 3>();\n".to_string();
    }
    let mut s = String::from(
        "    let h = _optik_fetch(_optik_hit.gas);\n    if ((h.x >> 4u) & 15u) != 0u {\n        return array<vec3<f32>, 3>();\n    }\n    let keys = h.y;\n    let base = _optik_hit.gas + h.w + _optik_hit.slot * 3u * keys;\n",
    );
    if c.geometry_motion() {
        s.push_str(
            "    let m = _optik_fetch(_optik_hit.gas + 1u);\n    let k = _optik_motion_key(keys, bitcast<f32>(m.x), bitcast<f32>(m.y), 0u, _optik_ray.time);\n    let a = base + 3u * u32(max(k.key, 0));\n    let b = base + 3u * min(u32(max(k.key, 0)) + 1u, keys - 1u);\n    var v: array<vec3<f32>, 3>;\n    for (var j = 0u; j < 3u; j = j + 1u) {\n        v[j] = mix(bitcast<vec3<f32>>(_optik_fetch(a + j).xyz), bitcast<vec3<f32>>(_optik_fetch(b + j).xyz), k.frac);\n    }\n    return v;\n",
        );
    } else {
        s.push_str(
            "    return array<vec3<f32>, 3>(bitcast<vec3<f32>>(_optik_fetch(base).xyz), bitcast<vec3<f32>>(_optik_fetch(base + 1u).xyz), bitcast<vec3<f32>>(_optik_fetch(base + 2u).xyz));\n",
        );
    }
    s
}

/// Centre and radius of the hit sphere in object space, at the ray's time.
fn sphere_data(c: &KernelConfig<'_>) -> String {
    if !c.spheres() || !c.traces() {
        return "    return vec4<f32>();\n".to_string();
    }
    let mut s = String::from(
        "    let h = _optik_fetch(_optik_hit.gas);\n    if ((h.x >> 4u) & 15u) != 2u {\n        return vec4<f32>();\n    }\n    let keys = h.y;\n    let base = _optik_hit.gas + h.w + _optik_hit.slot * (1u + keys) + 1u;\n",
    );
    if c.geometry_motion() {
        s.push_str(
            "    let m = _optik_fetch(_optik_hit.gas + 1u);\n    let k = _optik_motion_key(keys, bitcast<f32>(m.x), bitcast<f32>(m.y), 0u, _optik_ray.time);\n    let a = u32(max(k.key, 0));\n    return mix(bitcast<vec4<f32>>(_optik_fetch(base + a)), bitcast<vec4<f32>>(_optik_fetch(base + min(a + 1u, keys - 1u))), k.frac);\n",
        );
    } else {
        s.push_str("    return bitcast<vec4<f32>>(_optik_fetch(base));\n");
    }
    s
}
