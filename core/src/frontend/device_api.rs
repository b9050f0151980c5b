//! The device API of DESIGN.md §3: the functions programs call, where each may be called, and
//! the WGSL prelude that declares them.
//!
//! The prelude is appended *after* the user's source, so the user's line numbers are the ones
//! naga reports. Its function bodies are stand-ins that only make the module valid WGSL; each
//! backend replaces them (Cranelift host calls, generated WGSL, SPIR-V ray tracing
//! instructions). `rt_offset_ray` is the exception: its body is the real, shared algorithm.

use ProgramKind::*;
use optik_api::program::ProgramKind;

/// One device function of the prelude.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum DeviceFunction {
    /// `rt_launch_index() -> vec3<u32>`
    LaunchIndex,
    /// `rt_launch_dimensions() -> vec3<u32>`
    LaunchDimensions,
    /// `rt_trace(handle, origin, direction, tmin, tmax, time, mask, flags, sbt_offset,
    /// sbt_stride, miss_index, &payload)`
    Trace,
    /// `rt_get_payload(i) -> u32`
    GetPayload,
    /// `rt_set_payload(i, value)`
    SetPayload,
    /// `rt_get_attribute(i) -> u32`
    GetAttribute,
    /// `rt_report_intersection(t, hit_kind, attributes) -> bool`
    ReportIntersection,
    /// `rt_ignore_intersection()`
    IgnoreIntersection,
    /// `rt_terminate_ray()`
    TerminateRay,
    /// `rt_world_ray_origin() -> vec3<f32>`
    WorldRayOrigin,
    /// `rt_world_ray_direction() -> vec3<f32>`
    WorldRayDirection,
    /// `rt_object_ray_origin() -> vec3<f32>`
    ObjectRayOrigin,
    /// `rt_object_ray_direction() -> vec3<f32>`
    ObjectRayDirection,
    /// `rt_ray_tmin() -> f32`
    RayTmin,
    /// `rt_ray_tmax() -> f32`
    RayTmax,
    /// `rt_ray_time() -> f32`
    RayTime,
    /// `rt_ray_flags() -> u32`
    RayFlags,
    /// `rt_ray_mask() -> u32`
    RayMask,
    /// `rt_primitive_index() -> u32`
    PrimitiveIndex,
    /// `rt_sbt_gas_index() -> u32`
    SbtGasIndex,
    /// `rt_instance_id() -> u32`
    InstanceId,
    /// `rt_instance_index() -> u32`
    InstanceIndex,
    /// `rt_hit_kind() -> u32`
    HitKind,
    /// `rt_is_front_face_hit() -> bool`
    IsFrontFaceHit,
    /// `rt_triangle_barycentrics() -> vec2<f32>`
    TriangleBarycentrics,
    /// `rt_triangle_vertices() -> array<vec3<f32>, 3>`
    TriangleVertices,
    /// `rt_sphere() -> vec4<f32>` (centre, radius)
    Sphere,
    /// `rt_curve_parameter() -> f32`
    CurveParameter,
    /// `rt_object_to_world() -> mat4x3<f32>`
    ObjectToWorld,
    /// `rt_world_to_object() -> mat4x3<f32>`
    WorldToObject,
    /// `rt_sbt_data_u32(i) -> u32`
    SbtDataU32,
    /// `rt_sbt_data_f32(i) -> f32`
    SbtDataF32,
    /// `rt_direct_call(index, &args)`
    DirectCall,
    /// `rt_continuation_call(index, &args)`
    ContinuationCall,
    /// `rt_throw_exception(code)`
    ThrowException,
    /// `rt_exception_code() -> i32`
    ExceptionCode,
    /// `rt_remaining_trace_depth() -> u32`
    RemainingTraceDepth,
    /// `rt_offset_ray(p, n) -> vec3<f32>`: a real function of the prelude.
    OffsetRay,
}

const ALL_KINDS: &[ProgramKind] = &[
    Raygen,
    Intersection,
    AnyHit,
    ClosestHit,
    Miss,
    Exception,
    DirectCallable,
    ContinuationCallable,
];
const HIT_MISS_CALLABLE: &[ProgramKind] = &[
    AnyHit,
    ClosestHit,
    Miss,
    DirectCallable,
    ContinuationCallable,
];
const HIT: &[ProgramKind] = &[AnyHit, ClosestHit];
const TRAVERSAL: &[ProgramKind] = &[Intersection, AnyHit, ClosestHit, Miss];
const PRIMITIVE: &[ProgramKind] = &[Intersection, AnyHit, ClosestHit];

impl DeviceFunction {
    /// Every device function.
    pub const ALL: [DeviceFunction; 38] = [
        DeviceFunction::LaunchIndex,
        DeviceFunction::LaunchDimensions,
        DeviceFunction::Trace,
        DeviceFunction::GetPayload,
        DeviceFunction::SetPayload,
        DeviceFunction::GetAttribute,
        DeviceFunction::ReportIntersection,
        DeviceFunction::IgnoreIntersection,
        DeviceFunction::TerminateRay,
        DeviceFunction::WorldRayOrigin,
        DeviceFunction::WorldRayDirection,
        DeviceFunction::ObjectRayOrigin,
        DeviceFunction::ObjectRayDirection,
        DeviceFunction::RayTmin,
        DeviceFunction::RayTmax,
        DeviceFunction::RayTime,
        DeviceFunction::RayFlags,
        DeviceFunction::RayMask,
        DeviceFunction::PrimitiveIndex,
        DeviceFunction::SbtGasIndex,
        DeviceFunction::InstanceId,
        DeviceFunction::InstanceIndex,
        DeviceFunction::HitKind,
        DeviceFunction::IsFrontFaceHit,
        DeviceFunction::TriangleBarycentrics,
        DeviceFunction::TriangleVertices,
        DeviceFunction::Sphere,
        DeviceFunction::CurveParameter,
        DeviceFunction::ObjectToWorld,
        DeviceFunction::WorldToObject,
        DeviceFunction::SbtDataU32,
        DeviceFunction::SbtDataF32,
        DeviceFunction::DirectCall,
        DeviceFunction::ContinuationCall,
        DeviceFunction::ThrowException,
        DeviceFunction::ExceptionCode,
        DeviceFunction::RemainingTraceDepth,
        DeviceFunction::OffsetRay,
    ];

    /// The WGSL name.
    pub fn name(self) -> &'static str {
        self.entry().0
    }

    /// The WGSL signature after the name, as declared in the prelude.
    pub fn signature(self) -> &'static str {
        self.entry().1
    }

    /// The program kinds that may call this function (OptiX's "available in" notes,
    /// narrowed to what every backend can do: no payload access in intersection programs,
    /// which Vulkan forbids).
    pub fn allowed_in(self) -> &'static [ProgramKind] {
        self.entry().2
    }

    /// Whether a program of `kind` may call this function.
    pub fn is_allowed_in(self, kind: ProgramKind) -> bool {
        self.allowed_in().contains(&kind)
    }

    /// The device function named `name`.
    pub fn from_name(name: &str) -> Option<DeviceFunction> {
        DeviceFunction::ALL.into_iter().find(|f| f.name() == name)
    }

    fn entry(self) -> (&'static str, &'static str, &'static [ProgramKind]) {
        use DeviceFunction as F;
        match self {
            F::LaunchIndex => ("rt_launch_index", "() -> vec3<u32>", ALL_KINDS),
            F::LaunchDimensions => ("rt_launch_dimensions", "() -> vec3<u32>", ALL_KINDS),
            F::Trace => (
                "rt_trace",
                "(handle: RtHandle, origin: vec3<f32>, direction: vec3<f32>, tmin: f32, tmax: f32, time: f32, mask: u32, flags: u32, sbt_offset: u32, sbt_stride: u32, miss_index: u32, payload: ptr<function, RtPayload>)",
                &[Raygen, ClosestHit, Miss, ContinuationCallable],
            ),
            F::GetPayload => ("rt_get_payload", "(i: u32) -> u32", HIT_MISS_CALLABLE),
            F::SetPayload => ("rt_set_payload", "(i: u32, value: u32)", HIT_MISS_CALLABLE),
            F::GetAttribute => ("rt_get_attribute", "(i: u32) -> u32", HIT),
            F::ReportIntersection => (
                "rt_report_intersection",
                "(t: f32, hit_kind: u32, attributes: RtAttributes) -> bool",
                &[Intersection],
            ),
            F::IgnoreIntersection => ("rt_ignore_intersection", "()", &[AnyHit]),
            F::TerminateRay => ("rt_terminate_ray", "()", &[AnyHit]),
            F::WorldRayOrigin => ("rt_world_ray_origin", "() -> vec3<f32>", TRAVERSAL),
            F::WorldRayDirection => ("rt_world_ray_direction", "() -> vec3<f32>", TRAVERSAL),
            F::ObjectRayOrigin => ("rt_object_ray_origin", "() -> vec3<f32>", PRIMITIVE),
            F::ObjectRayDirection => ("rt_object_ray_direction", "() -> vec3<f32>", PRIMITIVE),
            F::RayTmin => ("rt_ray_tmin", "() -> f32", TRAVERSAL),
            F::RayTmax => ("rt_ray_tmax", "() -> f32", TRAVERSAL),
            F::RayTime => ("rt_ray_time", "() -> f32", TRAVERSAL),
            F::RayFlags => ("rt_ray_flags", "() -> u32", TRAVERSAL),
            F::RayMask => ("rt_ray_mask", "() -> u32", TRAVERSAL),
            F::PrimitiveIndex => ("rt_primitive_index", "() -> u32", PRIMITIVE),
            F::SbtGasIndex => ("rt_sbt_gas_index", "() -> u32", PRIMITIVE),
            F::InstanceId => ("rt_instance_id", "() -> u32", PRIMITIVE),
            F::InstanceIndex => ("rt_instance_index", "() -> u32", PRIMITIVE),
            F::HitKind => ("rt_hit_kind", "() -> u32", HIT),
            F::IsFrontFaceHit => ("rt_is_front_face_hit", "() -> bool", HIT),
            F::TriangleBarycentrics => ("rt_triangle_barycentrics", "() -> vec2<f32>", HIT),
            F::TriangleVertices => ("rt_triangle_vertices", "() -> array<vec3<f32>, 3>", HIT),
            F::Sphere => ("rt_sphere", "() -> vec4<f32>", HIT),
            F::CurveParameter => ("rt_curve_parameter", "() -> f32", HIT),
            F::ObjectToWorld => ("rt_object_to_world", "() -> mat4x3<f32>", PRIMITIVE),
            F::WorldToObject => ("rt_world_to_object", "() -> mat4x3<f32>", PRIMITIVE),
            F::SbtDataU32 => ("rt_sbt_data_u32", "(i: u32) -> u32", ALL_KINDS),
            F::SbtDataF32 => ("rt_sbt_data_f32", "(i: u32) -> f32", ALL_KINDS),
            F::DirectCall => (
                "rt_direct_call",
                "(index: u32, args: ptr<function, RtPayload>)",
                &[
                    Raygen,
                    Intersection,
                    AnyHit,
                    ClosestHit,
                    Miss,
                    DirectCallable,
                    ContinuationCallable,
                ],
            ),
            F::ContinuationCall => (
                "rt_continuation_call",
                "(index: u32, args: ptr<function, RtPayload>)",
                &[Raygen, ClosestHit, Miss, ContinuationCallable],
            ),
            F::ThrowException => (
                "rt_throw_exception",
                "(code: u32)",
                &[
                    Raygen,
                    Intersection,
                    AnyHit,
                    ClosestHit,
                    Miss,
                    DirectCallable,
                    ContinuationCallable,
                ],
            ),
            F::ExceptionCode => ("rt_exception_code", "() -> i32", &[Exception]),
            F::RemainingTraceDepth => (
                "rt_remaining_trace_depth",
                "() -> u32",
                &[
                    Raygen,
                    ClosestHit,
                    Miss,
                    DirectCallable,
                    ContinuationCallable,
                ],
            ),
            F::OffsetRay => (
                "rt_offset_ray",
                "(p: vec3<f32>, n: vec3<f32>) -> vec3<f32>",
                ALL_KINDS,
            ),
        }
    }

    /// Where this function may be called, as readable text ("any-hit and closest-hit").
    pub fn allowed_in_text(self) -> String {
        let names: Vec<&str> = self.allowed_in().iter().map(|k| k.name()).collect();
        match names.as_slice() {
            [] => "no program".into(),
            [one] => format!("{one} programs"),
            [init @ .., last] if names.len() == ALL_KINDS.len() => {
                let _ = (init, last);
                "every program".into()
            }
            [init @ .., last] => format!("{} and {last} programs", init.join(", ")),
        }
    }

    /// Whether this function ends the program that calls it (no return): the any-hit
    /// terminators and `rt_throw_exception` (which ends the program even when the pipeline
    /// does not check user exceptions).
    pub fn is_terminator(self) -> bool {
        matches!(
            self,
            DeviceFunction::IgnoreIntersection
                | DeviceFunction::TerminateRay
                | DeviceFunction::ThrowException
        )
    }
}

/// Named constants the prelude defines for users (OptiX's enums under an `RT_` prefix).
pub const PRELUDE_CONSTANTS: &[(&str, &str, u32)] = &[
    ("RT_RAY_FLAG_NONE", "u32", 0),
    ("RT_RAY_FLAG_DISABLE_ANYHIT", "u32", 1),
    ("RT_RAY_FLAG_ENFORCE_ANYHIT", "u32", 2),
    ("RT_RAY_FLAG_TERMINATE_ON_FIRST_HIT", "u32", 4),
    ("RT_RAY_FLAG_DISABLE_CLOSESTHIT", "u32", 8),
    ("RT_RAY_FLAG_CULL_BACK_FACING_TRIANGLES", "u32", 16),
    ("RT_RAY_FLAG_CULL_FRONT_FACING_TRIANGLES", "u32", 32),
    ("RT_RAY_FLAG_CULL_DISABLED_ANYHIT", "u32", 64),
    ("RT_RAY_FLAG_CULL_ENFORCED_ANYHIT", "u32", 128),
    ("RT_RAY_FLAG_FORCE_OPACITY_MICROMAP_2_STATE", "u32", 1024),
    ("RT_HIT_KIND_TRIANGLE_FRONT_FACE", "u32", 0xFE),
    ("RT_HIT_KIND_TRIANGLE_BACK_FACE", "u32", 0xFF),
];

/// Exception codes (OptiX `OptixExceptionCodes`), as `i32` constants in the prelude.
pub const PRELUDE_EXCEPTION_CODES: &[(&str, i32)] = &[
    (
        "RT_EXCEPTION_CODE_STACK_OVERFLOW",
        optik_api::semantics::exception::STACK_OVERFLOW,
    ),
    (
        "RT_EXCEPTION_CODE_TRACE_DEPTH_EXCEEDED",
        optik_api::semantics::exception::TRACE_DEPTH_EXCEEDED,
    ),
    (
        "RT_EXCEPTION_CODE_INVALID_TRAVERSABLE",
        optik_api::semantics::exception::INVALID_TRAVERSABLE,
    ),
    (
        "RT_EXCEPTION_CODE_INVALID_MISS_SBT",
        optik_api::semantics::exception::INVALID_MISS_SBT,
    ),
    (
        "RT_EXCEPTION_CODE_INVALID_HIT_SBT",
        optik_api::semantics::exception::INVALID_HIT_SBT,
    ),
    (
        "RT_EXCEPTION_CODE_UNSUPPORTED_PRIMITIVE_TYPE",
        optik_api::semantics::exception::UNSUPPORTED_PRIMITIVE_TYPE,
    ),
    (
        "RT_EXCEPTION_CODE_INVALID_RAY",
        optik_api::semantics::exception::INVALID_RAY,
    ),
    (
        "RT_EXCEPTION_CODE_CALLABLE_INVALID_SBT",
        optik_api::semantics::exception::CALLABLE_INVALID_SBT,
    ),
];

/// The body of `rt_offset_ray`: Wächter and Binder, "A Fast and Robust Method for Avoiding
/// Self-Intersection" (Ray Tracing Gems ch. 6). Moves `p` 256 ulps along `n` per component,
/// or by a fixed 1/65536 where |p| < 1/32 (the ulp-starved region near zero). `n` must point
/// to the side the new ray leaves from. Public so that backends which write their own prelude
/// (the Vulkan backend) keep this one shared body.
pub const OFFSET_RAY_BODY: &str = r#"{
    let of_i = vec3<i32>(256.0 * n);
    let p_bits = bitcast<vec3<i32>>(p);
    let p_i = bitcast<vec3<f32>>(p_bits + select(of_i, -of_i, p < vec3<f32>(0.0)));
    let near_zero = abs(p) < vec3<f32>(1.0 / 32.0);
    return select(p_i, p + (1.0 / 65536.0) * n, near_zero);
}"#;

/// The stand-in body of a device function: returns a zero of its type.
fn stub_body(f: DeviceFunction) -> &'static str {
    let sig = f.signature();
    match sig.rsplit_once("->").map(|(_, r)| r.trim()) {
        None => "{ }",
        Some("vec3<u32>") => "{ return vec3<u32>(); }",
        Some("u32") => "{ return 0u; }",
        Some("i32") => "{ return 0i; }",
        Some("f32") => "{ return 0.0; }",
        Some("bool") => "{ return false; }",
        Some("vec2<f32>") => "{ return vec2<f32>(); }",
        Some("vec3<f32>") => "{ return vec3<f32>(); }",
        Some("vec4<f32>") => "{ return vec4<f32>(); }",
        Some("mat4x3<f32>") => "{ return mat4x3<f32>(); }",
        Some("array<vec3<f32>, 3>") => "{ return array<vec3<f32>, 3>(); }",
        Some(other) => unreachable!("device function return type {other} has no stub"),
    }
}

/// The line that starts the prelude; backends split the source here.
pub const PRELUDE_MARKER: &str = "// ---- optik prelude: device API (DESIGN.md §3) ----";

/// The WGSL prelude for a pipeline whose payload holds `payload_len` registers (at least 1:
/// WGSL has no zero-length arrays).
pub fn prelude(payload_len: u32) -> String {
    let mut s = String::new();
    s.push('\n');
    s.push_str(PRELUDE_MARKER);
    s.push('\n');
    s.push_str("alias RtHandle = vec2<u32>;\n");
    s.push_str(&format!(
        "alias RtPayload = array<u32, {}>;\n",
        payload_len.max(1)
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
    for f in DeviceFunction::ALL {
        let body = if f == DeviceFunction::OffsetRay {
            OFFSET_RAY_BODY
        } else {
            stub_body(f)
        };
        s.push_str(&format!("fn {}{} {}\n", f.name(), f.signature(), body));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prelude_parses_and_validates_for_every_payload_length() {
        for n in [0, 1, 8, 32] {
            let src = prelude(n);
            let module = naga::front::wgsl::parse_str(&src)
                .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)));
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::default(),
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)));
            assert_eq!(module.functions.len(), DeviceFunction::ALL.len());
        }
    }

    #[test]
    fn names_are_unique_and_round_trip() {
        for f in DeviceFunction::ALL {
            assert_eq!(DeviceFunction::from_name(f.name()), Some(f));
            assert!(f.name().starts_with("rt_"));
        }
    }

    #[test]
    fn terminators_are_the_functions_that_end_their_program() {
        let terminators: Vec<DeviceFunction> = DeviceFunction::ALL
            .into_iter()
            .filter(|f| f.is_terminator())
            .collect();
        assert_eq!(
            terminators,
            [
                DeviceFunction::IgnoreIntersection,
                DeviceFunction::TerminateRay,
                DeviceFunction::ThrowException
            ]
        );
    }

    #[test]
    fn legality_follows_optix() {
        assert!(!DeviceFunction::SetPayload.is_allowed_in(ProgramKind::Raygen));
        assert!(DeviceFunction::Trace.is_allowed_in(ProgramKind::ClosestHit));
        assert!(!DeviceFunction::Trace.is_allowed_in(ProgramKind::AnyHit));
        assert!(DeviceFunction::ReportIntersection.is_allowed_in(ProgramKind::Intersection));
        assert!(!DeviceFunction::ReportIntersection.is_allowed_in(ProgramKind::ClosestHit));
        assert!(!DeviceFunction::ThrowException.is_allowed_in(ProgramKind::Exception));
        assert_eq!(
            DeviceFunction::LaunchIndex.allowed_in_text(),
            "every program"
        );
        assert_eq!(
            DeviceFunction::IgnoreIntersection.allowed_in_text(),
            "any-hit programs"
        );
    }
}
