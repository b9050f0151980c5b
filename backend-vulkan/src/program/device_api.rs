//! The Vulkan backend's prelude: the device API (DESIGN.md §3) written in WGSL on top of a few
//! intrinsics, plus the stage wrappers.
//!
//! The front end validated the user's module against the API prelude, whose bodies are
//! stand-ins. The backend compiles the same user source followed by this prelude instead: the
//! same aliases, constants and `rt_*` signatures, with bodies that implement the device API.
//! Everything that needs a SPIR-V ray tracing instruction, built-in or storage class is an
//! intrinsic (`_optik_*` in [`super::intrinsic`]) whose stand-in body the post-pass replaces;
//! the rest (invalid-ray policy, flag masking, depth and exception bookkeeping, the tables
//! behind `rt_instance_id` and friends) is plain WGSL, validated by naga.
//!
//! Per launch index, stages share a state word in `_optik_state` (only when the pipeline needs
//! one, [`LoweringConfig::uses_state`]), laid out as `vec4<u32>`:
//! - `x`: the current ray's time (f32 bits);
//! - `y`: bits 0..8 the ray's visibility mask, 8..16 the trace depth, 16..24 the continuation
//!   call depth, 24..32 the direct call depth;
//! - `z`: bits 0..16 the ray's flags as given to `rt_trace`, 16..18 the exception status
//!   (0 none, 1 raised and unhandled, 2 handled: the launch index is ending);
//! - `w`: the exception code.
//!
//! Only one traversal per launch index is in flight at a time (closest-hit and miss programs
//! run after their traversal ends), so `rt_trace` saves the ray fields, sets the new ray's and
//! restores them when the trace returns: intersection programs, which cannot read payloads on
//! Vulkan, read the current ray's time, flags and mask there.
//!
//! Emulation, each compiled in only when the pipeline needs it ([`LoweringConfig`]; its WGSL
//! is in traversal.rs, optik's own stages in internal.rs, inlined direct calls in
//! inline.rs): optik's triangle stage reads the ray's face-culling flags from Vulkan's (both
//! faces as `SkipTrianglesKHR`) or the state word, and with micromaps the 2-state flag from
//! the state; motion interpolates primitives at the ray's time and composes the motion chain
//! of the instance (the transforms below the Vulkan instance, tables.rs), which the
//! object-space device functions apply on top of Vulkan's built-ins; with micromaps, optik's
//! stages decide opacity culling (`_optik_fate`, `optik_api::semantics::opacity`), because a
//! micromap state can change a candidate's opacity after the driver's culling.

use super::config::{HitContext, LoweringConfig, StageRole, stage_code};
use super::intrinsic::Intrinsic;
use super::traversal;
use optik_api::{ExceptionFlags, ProgramKind};
use optik_core::frontend::{OFFSET_RAY_BODY, PRELUDE_CONSTANTS, PRELUDE_EXCEPTION_CODES};

/// Words of shader record data a program can address (`rt_sbt_data_u32` indices are clamped
/// below this); the translated SBT buffer is padded by as many bytes so no read leaves it.
pub const SBT_DATA_WORDS: u32 = 1024;

/// Callable SBT index of the exception program.
pub const CALLABLE_EXCEPTION: u32 = 0;
/// Callable SBT index of the null callable (out-of-range indices land here).
pub const CALLABLE_NULL: u32 = 1;
/// Callable SBT index of the user's callable record 0.
pub const CALLABLE_FIRST_USER: u32 = 2;

/// Marks a geometry-table field that is absent.
pub const NONE: u32 = 0xFFFF_FFFF;

/// The prelude for a pipeline with settings `c`.
pub fn prelude(c: &LoweringConfig) -> String {
    let mut s = String::new();
    s.push_str("\n// ---- optik Vulkan prelude (backend-vulkan/src/program/device_api.rs) ----\n");
    s.push_str("alias RtHandle = vec2<u32>;\n");
    s.push_str(&format!(
        "alias RtPayload = array<u32, {}>;\n",
        c.payload_len.max(1)
    ));
    s.push_str(&format!(
        "alias RtAttributes = array<u32, {}>;\n",
        optik_api::MAX_ATTRIBUTE_VALUES
    ));
    for (name, ty, value) in PRELUDE_CONSTANTS {
        s.push_str(&format!("const {name}: {ty} = {value}u;\n"));
    }
    for (name, value) in PRELUDE_EXCEPTION_CODES {
        s.push_str(&format!("const {name}: i32 = {value}i;\n"));
    }
    for kind in ProgramKind::ALL {
        s.push_str(&format!(
            "const _OPTIK_STAGE_{}: u32 = {}u;\n",
            stage_const(kind),
            stage_code(kind)
        ));
    }
    for ctx in [
        HitContext::Triangles,
        HitContext::Custom,
        HitContext::Sphere,
        HitContext::Curve,
    ] {
        s.push_str(&format!(
            "const _OPTIK_CTX_{}: u32 = {}u;\n",
            format!("{ctx:?}").to_uppercase(),
            ctx.code()
        ));
    }
    s.push_str(RESOURCES);
    for i in Intrinsic::ALL {
        s.push_str(&format!(
            "fn {}{} {}\n",
            i.name(),
            i.signature(),
            i.stand_in_body()
        ));
    }
    s.push_str(optik_api::wgsl::RAY);
    if c.motion_structures {
        s.push_str(optik_api::wgsl::MOTION);
    }
    if c.motion_structures || c.box_guard() {
        let options = optik_api::wgsl::SnippetOptions {
            conservative_boxes: true,
            f64_fallback: false,
        };
        s.push_str(&optik_api::wgsl::specialise(optik_api::wgsl::SLAB, options));
    }
    s.push_str(
        &HELPERS
            .replace(
                "$INLINE_SBT",
                if c.inline_calls {
                    "// A direct callable inlined into an intersection or any-hit stage reads its own\n    // record's data from the callable table.\n    if _optik_inline_depth > 0u {\n        return _optik_callables[_optik_inline_data + min(i, $SBT_DATA_LAST)];\n    }"
                } else {
                    ""
                },
            )
            .replace("$SBT_DATA_LAST", &(SBT_DATA_WORDS - 1).to_string())
            .replace(
                "$BOTH_FACES",
                if c.skip_triangles_flag {
                    "f = (f & ~48u) | 256u;"
                } else {
                    "f = f & ~32u;"
                },
            )
            .replace(
                "$STRIP_OPACITY_CULLING",
                if c.micromaps {
                    "// A micromap state changes a candidate's opacity after the driver would cull it:\n    // optik's stages cull by opacity instead.\n    f = f & ~(64u | 128u);"
                } else {
                    ""
                },
            ),
    );
    s.push_str(&state_functions(c));
    s.push_str(&traversal::motion_functions(c));
    s.push_str(&traversal::opacity_functions(c));
    s.push_str(&device_functions(c));
    s
}

fn stage_const(kind: ProgramKind) -> &'static str {
    match kind {
        ProgramKind::Raygen => "RAYGEN",
        ProgramKind::Intersection => "INTERSECTION",
        ProgramKind::AnyHit => "ANYHIT",
        ProgramKind::ClosestHit => "CLOSESTHIT",
        ProgramKind::Miss => "MISS",
        ProgramKind::Exception => "EXCEPTION",
        ProgramKind::DirectCallable => "DIRECT_CALLABLE",
        ProgramKind::ContinuationCallable => "CONTINUATION_CALLABLE",
    }
}

/// The backend's resources (DESIGN.md §3: groups 1 and up belong to the backends).
const RESOURCES: &str = r#"
struct _OptikLaunch {
    empty_tlas: vec2<u32>,
    miss_count: u32,
    callable_count: u32,
    origin: vec4<u32>,
    size: vec4<u32>,
}
// Per-dispatch constants: the empty acceleration structure (null handles and continuation
// calls trace against it), the user's miss and callable record counts, and where this
// dispatch lies in the user's launch: a launch larger than one vkCmdTraceRaysKHR allows runs
// as several (launch.rs), each seeing its own LaunchIdKHR and LaunchSizeKHR.
@group(1) @binding(0) var<uniform> _optik_launch: _OptikLaunch;
// Per launch index state of the dispatch running (see the module documentation of
// device_api.rs), indexed by the dispatch's own launch id: dispatches reuse it in turn.
@group(1) @binding(1) var<storage, read_write> _optik_state: array<vec4<u32>>;
// Two vec4 per Vulkan instance (its custom index): [OptiX instance id, instance index, first
// record of its geometry acceleration structure, instance flags of the path], [motion chain
// or NONE, 0, 0, 0] (accel/tables.rs).
@group(1) @binding(2) var<storage, read> _optik_instances: array<vec4<u32>>;
// Two vec4 per geometry: [primitive index offset, remap table, primitive data, info (curve
// basis, primitive kind, geometry flags)], [motion keys, micromap block, primitives, 0].
@group(1) @binding(3) var<storage, read> _optik_geometries: array<vec4<u32>>;
@group(1) @binding(4) var<storage, read> _optik_data: array<u32>;
// The launch's callable records for calls inlined into intersection and any-hit stages
// (program/inline.rs): per record [program id, data offset], then the records' data.
@group(1) @binding(5) var<storage, read> _optik_callables: array<u32>;

// Set by the stage wrapper: which program kind the stage runs, and for hit programs the
// primitive their hit group serves. Constant per stage, so drivers fold the branches on them.
var<private> _optik_stage: u32;
var<private> _optik_ctx: u32;
// A direct call inlined into an intersection or any-hit stage (program/inline.rs): its
// nesting (0 outside one), arguments and record data in the callable table.
var<private> _optik_inline_depth: u32;
var<private> _optik_args: RtPayload;
var<private> _optik_inline_data: u32;
"#;

/// Helpers every configuration has.
const HELPERS: &str = r#"
fn _optik_slot() -> u32 {
    let id = _optik_launch_id();
    let n = _optik_launch_size();
    return id.x + n.x * (id.y + n.y * id.z);
}

// Vulkan allows only one of OpaqueKHR, NoOpaqueKHR, CullOpaqueKHR and CullNoOpaqueKHR, and not
// both face-culling flags; optik_api::semantics::opacity defines every combination. Folds the
// flags into one Vulkan allows, with the same outcome: combinations that cull every candidate
// clear the mask instead. Both face-culling flags: for optik's triangle stage, where the
// device has it, SkipTrianglesKHR (no Vulkan triangles exist) carries them to the stage;
// otherwise the stage reads the state and native triangles keep back-face culling only.
fn _optik_vk_ray_flags(flags: u32, mask: ptr<function, u32>) -> u32 {
    var f = flags & 0xFFu;
    let cull_disabled = (f & 64u) != 0u;
    let cull_enforced = (f & 128u) != 0u;
    if (f & 1u) != 0u {
        if cull_disabled {
            *mask = 0u;
        }
        f = f & ~(2u | 64u | 128u);
    } else if (f & 2u) != 0u {
        if cull_enforced {
            *mask = 0u;
        }
        f = f & ~(64u | 128u);
    } else if cull_disabled && cull_enforced {
        *mask = 0u;
        f = f & ~(64u | 128u);
    }
    if (f & 48u) == 48u {
        $BOTH_FACES
    }
    $STRIP_OPACITY_CULLING
    return f;
}

// The instance table record of the hit's Vulkan instance (the first of its two vec4).
fn _optik_instance_record() -> u32 {
    return 2u * _optik_instance_custom_index();
}

// The geometry table record of the hit's geometry (the first of its two vec4).
fn _optik_geometry_slot() -> u32 {
    let inst = _optik_instances[_optik_instance_record()];
    return 2u * (inst.z + _optik_geometry_index());
}

fn _optik_geometry_record() -> vec4<u32> {
    return _optik_geometries[_optik_geometry_slot()];
}

// The kind of the geometry with table record `g0` (tables.rs): 0 triangles, 1 custom
// primitives, 2 spheres, 3 curves. A hit group's built-in intersection stage runs only on
// geometry of its own kind, so a box whose group has no intersection program is never hit,
// as on the CPU backend.
fn _optik_kind(g0: vec4<u32>) -> u32 {
    return (g0.w >> 8u) & 0xFFu;
}

fn _optik_geometry_extra() -> vec4<u32> {
    return _optik_geometries[_optik_geometry_slot() + 1u];
}

fn _optik_data_vec3(i: u32) -> vec3<f32> {
    return bitcast<vec3<f32>>(vec3<u32>(_optik_data[i], _optik_data[i + 1u], _optik_data[i + 2u]));
}

fn _optik_data_vec4(i: u32) -> vec4<f32> {
    return bitcast<vec4<f32>>(vec4<u32>(_optik_data[i], _optik_data[i + 1u], _optik_data[i + 2u], _optik_data[i + 3u]));
}

fn _optik_attribute_f32(i: u32) -> f32 {
    return bitcast<f32>(_optik_attribute_get(i));
}

fn _optik_sbt_word(i: u32) -> u32 {
    $INLINE_SBT
    return _optik_sbt_u32(min(i, $SBT_DATA_LAST));
}
"#;

/// The state bookkeeping: depth, ray fields, exceptions. Bodies shrink to constants when the
/// configuration has no state.
fn state_functions(c: &LoweringConfig) -> String {
    let mut s = String::new();
    let state = c.uses_state();
    // The trace depth of the program running: the ray it serves (0 in raygen).
    if c.track_depth {
        s.push_str(
            "fn _optik_depth() -> u32 {\n    return (_optik_state[_optik_slot()].y >> 8u) & 0xFFu;\n}\n",
        );
    } else {
        s.push_str("fn _optik_depth() -> u32 {\n    return select(1u, 0u, _optik_stage == _OPTIK_STAGE_RAYGEN);\n}\n");
    }
    if state {
        s.push_str(STATE_FUNCTIONS);
    }
    if c.unwinds() {
        s.push_str(&EXCEPTION_FUNCTIONS.replace(
            "$RUN_EXCEPTION_PROGRAM",
            if c.exception_program {
                "var data: RtPayload;\n        _optik_execute_callable(0u, &data);"
            } else {
                "// No exception program: the launch index ends, as with OptiX's default handler."
            },
        ));
    } else {
        s.push_str("fn _optik_unwinding() -> bool {\n    return false;\n}\n");
        // Set when a report ended the ray: the intersection program returns (exceptions.rs).
        s.push_str("var<private> _optik_unwound: bool;\n");
    }
    s
}

const STATE_FUNCTIONS: &str = r#"
fn _optik_state_init() {
    _optik_state[_optik_slot()] = vec4<u32>(0u, 0u, 0u, 0u);
}

// Sets the ray fields for a new trace at `depth`; returns the caller's, for _optik_trace_leave.
fn _optik_trace_enter(depth: u32, time: f32, mask: u32, flags: u32) -> vec3<u32> {
    let s = _optik_slot();
    let old = _optik_state[s];
    _optik_state[s] = vec4<u32>(
        bitcast<u32>(time),
        (old.y & 0xFFFF0000u) | ((depth & 0xFFu) << 8u) | (mask & 0xFFu),
        (old.z & 0xFFFF0000u) | (flags & 0xFFFFu),
        old.w);
    return old.xyz;
}

fn _optik_trace_leave(saved: vec3<u32>) {
    let s = _optik_slot();
    let cur = _optik_state[s];
    _optik_state[s] = vec4<u32>(saved.x, (cur.y & 0xFFFF0000u) | (saved.y & 0xFFFFu), (cur.z & 0xFFFF0000u) | (saved.z & 0xFFFFu), cur.w);
}

// The 8-bit counter at bit `shift` of state.y (continuation and direct call depths).
fn _optik_counter(shift: u32) -> u32 {
    return (_optik_state[_optik_slot()].y >> shift) & 0xFFu;
}

fn _optik_counter_set(shift: u32, value: u32) {
    let s = _optik_slot();
    let cur = _optik_state[s];
    _optik_state[s] = vec4<u32>(cur.x, (cur.y & ~(0xFFu << shift)) | ((value & 0xFFu) << shift), cur.z, cur.w);
}
"#;

const EXCEPTION_FUNCTIONS: &str = r#"
// Raises an exception: the first one of a launch index counts. Programs then unwind (the
// lowering returns from every function after a call that may raise) to their stage wrapper,
// which runs the exception program where Vulkan allows a callable (raygen, closest-hit, miss,
// callables); intersection and any-hit stages end their traversal instead and leave it to the
// stage that traced.
fn _optik_raise(code: i32) {
    _optik_unwound = true;
    let s = _optik_slot();
    let cur = _optik_state[s];
    if (cur.z >> 16u) == 0u {
        _optik_state[s] = vec4<u32>(cur.x, cur.y, (cur.z & 0xFFFFu) | (1u << 16u), bitcast<u32>(code));
    }
}

// Set when this stage raised, or a stage it traced or called did: user functions return.
var<private> _optik_unwound: bool;

// Whether an exception was raised for this launch index: the program must return at once.
fn _optik_unwinding() -> bool {
    return (_optik_state[_optik_slot()].z >> 16u) != 0u;
}

// At the end of a raygen, closest-hit, miss or callable stage: runs the exception program
// for an exception not handled yet. The exception is marked handled first, so the stages the
// exception program runs in (and the null callable standing in for a missing one) do not
// run it again.
fn _optik_exit_stage() {
    let s = _optik_slot();
    let cur = _optik_state[s];
    if (cur.z >> 16u) == 1u {
        _optik_state[s] = vec4<u32>(cur.x, cur.y, (cur.z & 0xFFFFu) | (2u << 16u), cur.w);
        $RUN_EXCEPTION_PROGRAM
    }
}
"#;

/// `_optik_raise(code)` when `flag` is checked, else nothing.
pub(crate) fn raise_if(c: &LoweringConfig, flag: ExceptionFlags, code: &str) -> String {
    if c.exceptions.contains(flag) {
        format!("_optik_raise({code});")
    } else {
        String::new()
    }
}

/// The device functions with their Vulkan bodies, in the API prelude's order and signatures.
fn device_functions(c: &LoweringConfig) -> String {
    use optik_core::frontend::DeviceFunction as F;
    let last_payload = c.payload_len.max(1) - 1;
    let state = c.uses_state();
    let mut s = String::new();
    for f in F::ALL {
        let body: String = match f {
            F::LaunchIndex => "return _optik_launch_id() + _optik_launch.origin.xyz;".into(),
            F::LaunchDimensions => "return _optik_launch.size.xyz;".into(),
            F::Trace => trace_body(c),
            F::GetPayload if c.inline_calls => format!(
                "if _optik_inline_depth > 0u {{\n        return _optik_args[min(i, {last_payload}u)];\n    }}\n    return _optik_payload_get(min(i, {last_payload}u));"
            ),
            F::GetPayload => format!("return _optik_payload_get(min(i, {last_payload}u));"),
            F::SetPayload if c.inline_calls => format!(
                "if _optik_inline_depth > 0u {{\n        _optik_args[min(i, {last_payload}u)] = value;\n        return;\n    }}\n    _optik_payload_set(min(i, {last_payload}u), value);"
            ),
            F::SetPayload => format!("_optik_payload_set(min(i, {last_payload}u), value);"),
            // Triangles have two attributes (the barycentrics); Vulkan leaves the rest of a
            // native triangle's attribute memory undefined, and the CPU backend reads 0.
            F::GetAttribute => "if _optik_ctx == _OPTIK_CTX_TRIANGLES && i >= 2u {\n        return 0u;\n    }\n    return _optik_attribute_get(min(i, 7u));".into(),
            // OptiX keeps 7 bits of a reported hit kind; Vulkan reserves 128..255 too.
            // A report accepted under TERMINATE_ON_FIRST_HIT (Vulkan's bit 4 as optik's) ends
            // the ray: the program unwinds (exceptions.rs), as the CPU backend's does.
            F::ReportIntersection => "let accepted = _optik_report_intersection(t, hit_kind & 0x7Fu, attributes);\n    if accepted && (_optik_ray_flags() & 4u) != 0u {\n        _optik_unwound = true;\n    }\n    return accepted;".into(),
            F::IgnoreIntersection => "_optik_ignore_intersection();".into(),
            F::TerminateRay => "_optik_terminate_ray();".into(),
            F::WorldRayOrigin => "return _optik_world_ray_origin();".into(),
            F::WorldRayDirection => "return _optik_world_ray_direction();".into(),
            F::ObjectRayOrigin => "return _optik_obj_origin();".into(),
            F::ObjectRayDirection => "return _optik_obj_direction();".into(),
            F::RayTmin => "return _optik_ray_tmin();".into(),
            F::RayTmax => "return _optik_ray_tmax();".into(),
            F::RayTime if c.motion => "return bitcast<f32>(_optik_state[_optik_slot()].x);".into(),
            // Without motion, rays carry no time (OptiX returns 0).
            F::RayTime => "return 0.0;".into(),
            F::RayFlags if c.track_ray_flags => "return _optik_state[_optik_slot()].z & 0xFFFFu;".into(),
            F::RayFlags => "return _optik_ray_flags();".into(),
            F::RayMask if c.track_ray_flags => "return _optik_state[_optik_slot()].y & 0xFFu;".into(),
            F::RayMask => "return 0xFFu;".into(),
            F::PrimitiveIndex => PRIMITIVE_INDEX.into(),
            // Each SBT record of a build input is its own Vulkan geometry, numbered as OptiX
            // numbers records, so the geometry index is the SBT GAS index.
            F::SbtGasIndex => "return _optik_geometry_index();".into(),
            F::InstanceId => "return _optik_instances[_optik_instance_record()].x;".into(),
            F::InstanceIndex => "return _optik_instances[_optik_instance_record()].y;".into(),
            F::HitKind => hit_kind_body(c),
            F::IsFrontFaceHit => {
                "let k = rt_hit_kind();\n    if k >= 0x80u {\n        return k == RT_HIT_KIND_TRIANGLE_FRONT_FACE;\n    }\n    return (k & 1u) == 0u;".into()
            }
            F::TriangleBarycentrics => "return vec2<f32>(_optik_attribute_f32(0u), _optik_attribute_f32(1u));".into(),
            F::TriangleVertices if c.triangles.emulated() => EMULATED_TRIANGLE_VERTICES.into(),
            F::TriangleVertices => TRIANGLE_VERTICES.into(),
            F::Sphere => {
                "if _optik_ctx != _OPTIK_CTX_SPHERE {\n        return vec4<f32>();\n    }\n    return vec4<f32>(_optik_attribute_f32(0u), _optik_attribute_f32(1u), _optik_attribute_f32(2u), _optik_attribute_f32(3u));".into()
            }
            F::CurveParameter => {
                "if _optik_ctx != _OPTIK_CTX_CURVE {\n        return 0.0;\n    }\n    return _optik_attribute_f32(0u);".into()
            }
            F::ObjectToWorld => "return _optik_obj_to_world();".into(),
            F::WorldToObject => "return _optik_world_to_obj();".into(),
            F::SbtDataU32 => "return _optik_sbt_word(i);".into(),
            F::SbtDataF32 => "return bitcast<f32>(_optik_sbt_word(i));".into(),
            F::DirectCall => direct_call_body(c),
            F::ContinuationCall => continuation_call_body(c),
            F::ThrowException => raise_if(c, ExceptionFlags::USER, "i32(code & 0x3FFFFFFFu)"),
            F::ExceptionCode if state => "return bitcast<i32>(_optik_state[_optik_slot()].w);".into(),
            F::ExceptionCode => "return 0i;".into(),
            F::RemainingTraceDepth => {
                format!("return {max}u - min(_optik_depth(), {max}u);", max = c.max_trace_depth)
            }
            F::OffsetRay => {
                s.push_str(&format!("fn {}{} {}\n", f.name(), f.signature(), OFFSET_RAY_BODY));
                continue;
            }
        };
        s.push_str(&format!(
            "fn {}{} {{\n    {}\n}}\n",
            f.name(),
            f.signature(),
            body
        ));
    }
    s
}

const PRIMITIVE_INDEX: &str = "let g = _optik_geometry_record();
    var p = _optik_primitive_id();
    if g.y != 0xFFFFFFFFu {
        p = _optik_data[g.y + p];
    }
    return p + g.x;";

/// `rt_hit_kind`: optik's sphere and curve stages report 0 (entering) or 1 (leaving), and its
/// triangle stage bit 0 for the face (0 front) and bit 1 for an opacity its any-hit wrapper
/// applies; programs see the face kinds of built-in primitives (optik_api::wgsl, sphere.wgsl).
fn hit_kind_body(c: &LoweringConfig) -> String {
    let triangles = if c.mixed_triangles {
        // The driver's triangles report Vulkan's face kinds already.
        "\n    if _optik_ctx == _OPTIK_CTX_TRIANGLES && k < 0x80u {\n        return select(RT_HIT_KIND_TRIANGLE_BACK_FACE, RT_HIT_KIND_TRIANGLE_FRONT_FACE, (k & 1u) == 0u);\n    }"
    } else if c.triangles.emulated() {
        "\n    if _optik_ctx == _OPTIK_CTX_TRIANGLES {\n        return select(RT_HIT_KIND_TRIANGLE_BACK_FACE, RT_HIT_KIND_TRIANGLE_FRONT_FACE, (k & 1u) == 0u);\n    }"
    } else {
        ""
    };
    format!(
        "let k = _optik_hit_kind();
    if _optik_ctx >= _OPTIK_CTX_SPHERE {{
        return select(RT_HIT_KIND_TRIANGLE_BACK_FACE, RT_HIT_KIND_TRIANGLE_FRONT_FACE, (k & 1u) == 0u);
    }}{triangles}
    return k;"
    )
}

/// `rt_triangle_vertices` of optik's triangles: the vertices it tested, at the ray's time
/// (always kept, as on the CPU backend).
const EMULATED_TRIANGLE_VERTICES: &str = "if _optik_ctx != _OPTIK_CTX_TRIANGLES {
        return array<vec3<f32>, 3>();
    }
    let t = _optik_triangle(_optik_geometry_record(), _optik_geometry_extra(), _optik_primitive_id());
    return array<vec3<f32>, 3>(t.v0, t.v1, t.v2);";

const TRIANGLE_VERTICES: &str = "if _optik_ctx != _OPTIK_CTX_TRIANGLES {
        return array<vec3<f32>, 3>();
    }
    let g = _optik_geometry_record();
    if g.z == 0xFFFFFFFFu {
        return array<vec3<f32>, 3>();
    }
    let b = g.z + _optik_primitive_id() * 9u;
    return array<vec3<f32>, 3>(_optik_data_vec3(b), _optik_data_vec3(b + 3u), _optik_data_vec3(b + 6u));";

fn trace_body(c: &LoweringConfig) -> String {
    let state = c.uses_state();
    let mut b = String::new();
    b.push_str("if !_optik_ray_is_valid(origin, direction, tmin, tmax) {\n");
    b.push_str(&format!(
        "        {}\n",
        raise_if(c, ExceptionFlags::DEBUG, "RT_EXCEPTION_CODE_INVALID_RAY")
    ));
    b.push_str("        return;\n    }\n");
    b.push_str("    let depth = _optik_depth();\n");
    b.push_str(&format!("    if depth >= {}u {{\n", c.max_trace_depth));
    b.push_str(&format!(
        "        {}\n",
        raise_if(
            c,
            ExceptionFlags::TRACE_DEPTH,
            "RT_EXCEPTION_CODE_TRACE_DEPTH_EXCEEDED"
        )
    ));
    b.push_str("        return;\n    }\n");
    b.push_str("    var miss = miss_index & 0xFFFFu;\n");
    b.push_str("    if miss >= _optik_launch.miss_count {\n");
    if c.exceptions.contains(ExceptionFlags::DEBUG) {
        b.push_str("        _optik_raise(RT_EXCEPTION_CODE_INVALID_MISS_SBT);\n        return;\n");
    } else {
        // The record after the user's is a null miss record: hits still run, misses run nothing.
        b.push_str("        miss = _optik_launch.miss_count;\n");
    }
    b.push_str("    }\n");
    b.push_str("    var accel = handle;\n");
    b.push_str("    if accel.x == 0u && accel.y == 0u {\n        accel = _optik_launch.empty_tlas;\n    }\n");
    b.push_str("    var vk_mask = mask & 0xFFu;\n");
    b.push_str("    let vk_flags = _optik_vk_ray_flags(flags, &vk_mask);\n");
    if state {
        b.push_str("    let saved = _optik_trace_enter(depth + 1u, time, mask, flags);\n");
    }
    b.push_str(
        "    _optik_trace(accel, vk_flags, vk_mask, sbt_offset & 0xFu, sbt_stride & 0xFu, miss, origin, tmin, direction, tmax, payload);\n",
    );
    if state {
        b.push_str("    _optik_trace_leave(saved);");
    }
    if c.unwinds() {
        b.push_str("\n    _optik_unwound = _optik_unwinding();");
    }
    b
}

/// A callable call's body: the index checked against the user's callable records, the call
/// nested inside a depth guard (the 8-bit counter at bit `counter` of the state's `y`, up to
/// `max_depth`) when `guarded`, and the unwinding flag refreshed after it.
fn call_body(c: &LoweringConfig, call: &str, guarded: Option<(u32, u32)>) -> String {
    let mut b = String::new();
    b.push_str("if index >= _optik_launch.callable_count {\n");
    b.push_str(&format!(
        "        {}\n        return;\n    }}\n",
        raise_if(
            c,
            ExceptionFlags::DEBUG,
            "RT_EXCEPTION_CODE_CALLABLE_INVALID_SBT"
        )
    ));
    if let Some((counter, max_depth)) = guarded {
        b.push_str(&format!("    let depth = _optik_counter({counter}u);\n"));
        b.push_str(&format!("    if depth >= {}u {{\n", max_depth.min(255)));
        b.push_str(&format!(
            "        {}\n        return;\n    }}\n",
            raise_if(
                c,
                ExceptionFlags::STACK_OVERFLOW,
                "RT_EXCEPTION_CODE_STACK_OVERFLOW"
            )
        ));
        b.push_str(&format!(
            "    _optik_counter_set({counter}u, depth + 1u);\n"
        ));
    }
    b.push_str(&format!("    {call}"));
    if let Some((counter, _)) = guarded {
        b.push_str(&format!("\n    _optik_counter_set({counter}u, depth);"));
    }
    if c.unwinds() {
        b.push_str("\n    _optik_unwound = _optik_unwinding();");
    }
    b
}

fn direct_call_body(c: &LoweringConfig) -> String {
    let call = format!("_optik_execute_callable(index + {CALLABLE_FIRST_USER}u, args);");
    let inline = if c.inline_calls {
        // Intersection and any-hit stages cannot execute callables: the callables are
        // compiled into them (program/inline.rs).
        "if _optik_stage == _OPTIK_STAGE_INTERSECTION || _optik_stage == _OPTIK_STAGE_ANYHIT {\n        _optik_inline_call_1(index, args);\n        return;\n    }\n    "
    } else {
        ""
    };
    let body = call_body(
        c,
        &call,
        c.guard_direct_calls
            .then_some((24, c.max_direct_callable_depth)),
    );
    format!("{inline}{body}")
}

fn continuation_call_body(c: &LoweringConfig) -> String {
    if !c.continuation_calls {
        return String::new();
    }
    // Vulkan callables cannot trace: continuation callables are miss stages placed after the
    // user's miss records (and the null miss record), reached by a ray that misses the empty
    // acceleration structure.
    let call = "_optik_trace(_optik_launch.empty_tlas, 0u, 0xFFu, 0u, 0u, _optik_launch.miss_count + 1u + index, vec3<f32>(0.0), 0.0, vec3<f32>(0.0, 0.0, 1.0), 0.0, args);";
    call_body(c, call, Some((16, c.max_continuation_callable_depth)))
}

/// The primitive types an intersection stage serves when the pipeline does not intersect
/// them (its wrapper then skips every candidate).
fn skipped_types(role: &StageRole, c: &LoweringConfig) -> Option<&'static str> {
    use optik_api::PrimitiveTypeFlags as T;
    let (types, name) = match role {
        StageRole::Program { .. } => (T::CUSTOM, "custom primitives"),
        StageRole::SphereIntersection => (T::SPHERE, "spheres"),
        StageRole::CurveIntersection(basis) => (
            match basis {
                0 => T::ROUND_LINEAR,
                1 => T::ROUND_QUADRATIC_BSPLINE,
                2 => T::ROUND_CUBIC_BSPLINE,
                _ => T::ROUND_CATMULLROM,
            },
            "curves of this basis",
        ),
        StageRole::TriangleIntersection => (T::TRIANGLE, "triangles"),
        _ => return None,
    };
    (!c.intersects(types)).then_some(name)
}

/// The compute wrapper naga writes for a stage: it sets the stage's constants, runs the
/// program, and does the stage's part of the exception scheme.
pub fn wrapper(entry_fn: &str, role: &StageRole, c: &LoweringConfig) -> String {
    let kind = role.behaves_as();
    let ctx = match role {
        StageRole::Program {
            context: Some(ctx), ..
        } => *ctx,
        StageRole::SphereIntersection => HitContext::Sphere,
        StageRole::CurveIntersection(_) => HitContext::Curve,
        _ => HitContext::Triangles,
    };
    let program = match role {
        StageRole::Program { name, .. } => name.clone(),
        StageRole::SphereIntersection => "_optik_builtin_sphere".into(),
        StageRole::CurveIntersection(_) => "_optik_builtin_curve".into(),
        StageRole::TriangleIntersection => "_optik_builtin_triangle".into(),
        StageRole::PastTableIntersection => "_optik_builtin_past_table".into(),
        StageRole::InvalidHitAnyHit | StageRole::InvalidHitClosestHit => {
            "_optik_invalid_hit_program".into()
        }
        StageRole::NullCallable | StageRole::NullContinuation => "_optik_null_callable".into(),
    };
    let mut b = String::new();
    b.push_str(&format!(
        "\n@compute @workgroup_size(1)\nfn {entry_fn}() {{\n"
    ));
    b.push_str(&format!(
        "    _optik_stage = {}u;\n    _optik_ctx = {}u;\n",
        stage_code(kind),
        ctx.code()
    ));
    let unwinds = c.unwinds();
    match kind {
        ProgramKind::Raygen => {
            if c.uses_state() {
                b.push_str("    _optik_state_init();\n");
            }
            b.push_str(&format!("    {program}();\n"));
        }
        ProgramKind::Exception => b.push_str(&format!("    {program}();\n")),
        ProgramKind::AnyHit => {
            if unwinds {
                b.push_str("    if _optik_unwinding() {\n        _optik_terminate_ray();\n    }\n");
            }
            if c.micromaps && c.triangles.emulated() && ctx == HitContext::Triangles {
                // optik's triangle stage found the candidate opaque (a micromap state) where
                // Vulkan saw it non-opaque: accepted without the any-hit program. (The
                // driver's triangles, where they share the scene, report 0xFE and 0xFF.)
                b.push_str(if c.mixed_triangles {
                    "    if (_optik_hit_kind() & 0x82u) == 2u {\n        return;\n    }\n"
                } else {
                    "    if (_optik_hit_kind() & 2u) != 0u {\n        return;\n    }\n"
                });
            }
            b.push_str(&format!("    {program}();\n"));
            if unwinds {
                b.push_str("    if _optik_unwinding() {\n        _optik_terminate_ray();\n    }\n");
            }
        }
        ProgramKind::Intersection => {
            if unwinds {
                b.push_str("    if _optik_unwinding() {\n        return;\n    }\n");
            }
            let culled_by_opacity = matches!(
                role,
                StageRole::Program { .. }
                    | StageRole::SphereIntersection
                    | StageRole::CurveIntersection(_)
            );
            if c.micromaps && culled_by_opacity {
                // The driver does not cull by opacity in pipelines with micromaps (the
                // triangle stage decides its own candidates' opacity).
                b.push_str("    if _optik_opacity_culled() {\n        return;\n    }\n");
            }
            if let Some(types) = skipped_types(role, c) {
                // Vulkan's skip flags cannot skip AABBs of one kind only.
                let raise = raise_if(
                    c,
                    ExceptionFlags::DEBUG,
                    "RT_EXCEPTION_CODE_UNSUPPORTED_PRIMITIVE_TYPE",
                );
                b.push_str(&format!(
                    "    // The pipeline does not intersect {types}.\n    {raise}\n    return;\n"
                ));
            }
            if (c.motion_structures || c.box_guard()) && matches!(role, StageRole::Program { .. }) {
                b.push_str("    if _optik_vanished() {\n        return;\n    }\n");
            }
            b.push_str(&format!("    {program}();\n"));
        }
        _ => {
            if unwinds {
                b.push_str("    if _optik_unwinding() {\n        return;\n    }\n");
            }
            b.push_str(&format!("    {program}();\n"));
        }
    }
    if unwinds
        && !matches!(
            kind,
            ProgramKind::AnyHit | ProgramKind::Intersection | ProgramKind::Exception
        )
    {
        b.push_str("    _optik_exit_stage();\n");
    }
    b.push_str("}\n");
    b
}
