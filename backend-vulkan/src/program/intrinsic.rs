//! The intrinsics of the Vulkan prelude: functions whose WGSL bodies are stand-ins and whose
//! SPIR-V bodies the post-pass writes, each one ray tracing instruction, built-in or storage
//! class access.

use rspirv::spirv::BuiltIn;

/// One intrinsic.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Intrinsic {
    /// `LaunchIdKHR`.
    LaunchId,
    /// `LaunchSizeKHR`.
    LaunchSize,
    /// `WorldRayOriginKHR`.
    WorldRayOrigin,
    /// `WorldRayDirectionKHR`.
    WorldRayDirection,
    /// `ObjectRayOriginKHR`.
    ObjectRayOrigin,
    /// `ObjectRayDirectionKHR`.
    ObjectRayDirection,
    /// `RayTminKHR`.
    RayTmin,
    /// `RayTmaxKHR` (KHR has no HitT: in any-hit and closest-hit it is the hit's t).
    RayTmax,
    /// `IncomingRayFlagsKHR`.
    RayFlags,
    /// `PrimitiveId`.
    PrimitiveId,
    /// `InstanceCustomIndexKHR`.
    InstanceCustomIndex,
    /// `RayGeometryIndexKHR`.
    GeometryIndex,
    /// `HitKindKHR`.
    HitKind,
    /// `ObjectToWorldKHR`.
    ObjectToWorld,
    /// `WorldToObjectKHR`.
    WorldToObject,
    /// `OpTraceRayKHR` with the payload copied in and out.
    Trace,
    /// `OpExecuteCallableKHR` with the callable data copied in and out.
    ExecuteCallable,
    /// Reads a word of the incoming payload (or incoming callable data).
    PayloadGet,
    /// Writes a word of the incoming payload (or incoming callable data).
    PayloadSet,
    /// Reads a word of the hit attributes.
    AttributeGet,
    /// Writes the hit attributes, then `OpReportIntersectionKHR`.
    ReportIntersection,
    /// `OpIgnoreIntersectionKHR`.
    IgnoreIntersection,
    /// `OpTerminateRayKHR`.
    TerminateRay,
    /// Reads a word of the shader record's data.
    SbtU32,
}

impl Intrinsic {
    /// Every intrinsic.
    pub const ALL: [Intrinsic; 24] = [
        Intrinsic::LaunchId,
        Intrinsic::LaunchSize,
        Intrinsic::WorldRayOrigin,
        Intrinsic::WorldRayDirection,
        Intrinsic::ObjectRayOrigin,
        Intrinsic::ObjectRayDirection,
        Intrinsic::RayTmin,
        Intrinsic::RayTmax,
        Intrinsic::RayFlags,
        Intrinsic::PrimitiveId,
        Intrinsic::InstanceCustomIndex,
        Intrinsic::GeometryIndex,
        Intrinsic::HitKind,
        Intrinsic::ObjectToWorld,
        Intrinsic::WorldToObject,
        Intrinsic::Trace,
        Intrinsic::ExecuteCallable,
        Intrinsic::PayloadGet,
        Intrinsic::PayloadSet,
        Intrinsic::AttributeGet,
        Intrinsic::ReportIntersection,
        Intrinsic::IgnoreIntersection,
        Intrinsic::TerminateRay,
        Intrinsic::SbtU32,
    ];

    /// The WGSL function name.
    pub fn name(self) -> &'static str {
        match self {
            Intrinsic::LaunchId => "_optik_launch_id",
            Intrinsic::LaunchSize => "_optik_launch_size",
            Intrinsic::WorldRayOrigin => "_optik_world_ray_origin",
            Intrinsic::WorldRayDirection => "_optik_world_ray_direction",
            Intrinsic::ObjectRayOrigin => "_optik_object_ray_origin",
            Intrinsic::ObjectRayDirection => "_optik_object_ray_direction",
            Intrinsic::RayTmin => "_optik_ray_tmin",
            Intrinsic::RayTmax => "_optik_ray_tmax",
            Intrinsic::RayFlags => "_optik_ray_flags",
            Intrinsic::PrimitiveId => "_optik_primitive_id",
            Intrinsic::InstanceCustomIndex => "_optik_instance_custom_index",
            Intrinsic::GeometryIndex => "_optik_geometry_index",
            Intrinsic::HitKind => "_optik_hit_kind",
            Intrinsic::ObjectToWorld => "_optik_object_to_world",
            Intrinsic::WorldToObject => "_optik_world_to_object",
            Intrinsic::Trace => "_optik_trace",
            Intrinsic::ExecuteCallable => "_optik_execute_callable",
            Intrinsic::PayloadGet => "_optik_payload_get",
            Intrinsic::PayloadSet => "_optik_payload_set",
            Intrinsic::AttributeGet => "_optik_attribute_get",
            Intrinsic::ReportIntersection => "_optik_report_intersection",
            Intrinsic::IgnoreIntersection => "_optik_ignore_intersection",
            Intrinsic::TerminateRay => "_optik_terminate_ray",
            Intrinsic::SbtU32 => "_optik_sbt_u32",
        }
    }

    /// The intrinsic named `name`.
    pub fn from_name(name: &str) -> Option<Intrinsic> {
        Intrinsic::ALL.into_iter().find(|i| i.name() == name)
    }

    /// The WGSL signature after the name.
    pub fn signature(self) -> &'static str {
        match self {
            Intrinsic::LaunchId | Intrinsic::LaunchSize => "() -> vec3<u32>",
            Intrinsic::WorldRayOrigin
            | Intrinsic::WorldRayDirection
            | Intrinsic::ObjectRayOrigin
            | Intrinsic::ObjectRayDirection => "() -> vec3<f32>",
            Intrinsic::RayTmin | Intrinsic::RayTmax => "() -> f32",
            Intrinsic::RayFlags
            | Intrinsic::PrimitiveId
            | Intrinsic::InstanceCustomIndex
            | Intrinsic::GeometryIndex
            | Intrinsic::HitKind => "() -> u32",
            Intrinsic::ObjectToWorld | Intrinsic::WorldToObject => "() -> mat4x3<f32>",
            Intrinsic::Trace => {
                "(handle: vec2<u32>, flags: u32, mask: u32, sbt_offset: u32, sbt_stride: u32, miss_index: u32, origin: vec3<f32>, tmin: f32, direction: vec3<f32>, tmax: f32, payload: ptr<function, RtPayload>)"
            }
            Intrinsic::ExecuteCallable => "(sbt_index: u32, data: ptr<function, RtPayload>)",
            Intrinsic::PayloadGet => "(i: u32) -> u32",
            Intrinsic::PayloadSet => "(i: u32, value: u32)",
            Intrinsic::AttributeGet => "(i: u32) -> u32",
            Intrinsic::ReportIntersection => {
                "(t: f32, hit_kind: u32, attributes: RtAttributes) -> bool"
            }
            Intrinsic::IgnoreIntersection | Intrinsic::TerminateRay => "()",
            Intrinsic::SbtU32 => "(i: u32) -> u32",
        }
    }

    /// A body that makes the stand-in valid WGSL.
    pub fn stand_in_body(self) -> &'static str {
        match self.signature().rsplit_once("->").map(|(_, r)| r.trim()) {
            None => "{ }",
            Some("vec3<u32>") => "{ return vec3<u32>(); }",
            Some("vec3<f32>") => "{ return vec3<f32>(); }",
            Some("f32") => "{ return 0.0; }",
            Some("u32") => "{ return 0u; }",
            Some("bool") => "{ return false; }",
            Some(_) => "{ return mat4x3<f32>(); }",
        }
    }

    /// The built-in variable an intrinsic loads, for the built-in getters.
    pub fn builtin(self) -> Option<BuiltIn> {
        Some(match self {
            Intrinsic::LaunchId => BuiltIn::LaunchIdKHR,
            Intrinsic::LaunchSize => BuiltIn::LaunchSizeKHR,
            Intrinsic::WorldRayOrigin => BuiltIn::WorldRayOriginKHR,
            Intrinsic::WorldRayDirection => BuiltIn::WorldRayDirectionKHR,
            Intrinsic::ObjectRayOrigin => BuiltIn::ObjectRayOriginKHR,
            Intrinsic::ObjectRayDirection => BuiltIn::ObjectRayDirectionKHR,
            Intrinsic::RayTmin => BuiltIn::RayTminKHR,
            Intrinsic::RayTmax => BuiltIn::RayTmaxKHR,
            Intrinsic::RayFlags => BuiltIn::IncomingRayFlagsKHR,
            Intrinsic::PrimitiveId => BuiltIn::PrimitiveId,
            Intrinsic::InstanceCustomIndex => BuiltIn::InstanceCustomIndexKHR,
            Intrinsic::GeometryIndex => BuiltIn::RayGeometryIndexKHR,
            Intrinsic::HitKind => BuiltIn::HitKindKHR,
            Intrinsic::ObjectToWorld => BuiltIn::ObjectToWorldKHR,
            Intrinsic::WorldToObject => BuiltIn::WorldToObjectKHR,
            _ => return None,
        })
    }
}
