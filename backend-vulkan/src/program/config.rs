//! What a pipeline asks of the lowering: the settings every stage of one pipeline shares, and
//! the stages it needs.

use optik_api::{ExceptionFlags, ProgramKind};

/// How a pipeline intersects triangles (DESIGN.md §5, the device's `Accuracy`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TriangleMode {
    /// Vulkan triangles: the driver's test (`TriangleTest::Driver`).
    Native,
    /// AABBs with optik's stage running the shared watertight test; `f64` keeps its exact
    /// fallback for edge functions that are zero (the device has `shaderFloat64`).
    Watertight {
        /// The f64 fallback is compiled in.
        f64: bool,
    },
    /// AABBs with optik's stage running Möller–Trumbore.
    MollerTrumbore,
}

impl TriangleMode {
    /// Whether triangles are AABBs intersected by optik's triangle stage.
    pub fn emulated(self) -> bool {
        self != TriangleMode::Native
    }
}

/// Settings shared by every stage of a pipeline. Derived from the pipeline's resolved
/// [`optik_api::FeatureSet`] and its programs; each emulation below is compiled in only when
/// the pipeline needs it (DESIGN.md §6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LoweringConfig {
    /// Registers in `RtPayload` (at least 1).
    pub payload_len: u32,
    /// The pipeline's `max_trace_depth`.
    pub max_trace_depth: u32,
    /// The pipeline's `max_direct_callable_depth`.
    pub max_direct_callable_depth: u32,
    /// The pipeline's `max_continuation_callable_depth`.
    pub max_continuation_callable_depth: u32,
    /// Exceptions checked.
    pub exceptions: ExceptionFlags,
    /// Whether the pipeline has an exception program (run as callable 0).
    pub exception_program: bool,
    /// Rays carry their time (`uses_motion_blur`); otherwise `rt_ray_time` is 0.
    pub motion: bool,
    /// The trace depth is tracked per launch index (hit, miss and callable programs trace or
    /// read `rt_remaining_trace_depth`); otherwise it is known statically (0 in raygen, 1
    /// elsewhere).
    pub track_depth: bool,
    /// A program reads `rt_ray_flags` or `rt_ray_mask`, so rays carry them.
    pub track_ray_flags: bool,
    /// A direct callable calls direct callables, so their depth is guarded.
    pub guard_direct_calls: bool,
    /// Some program calls continuation callables, whose depth is guarded.
    pub continuation_calls: bool,
    /// Some intersection or any-hit program calls direct callables: they are compiled into
    /// those stages (program/inline.rs).
    pub inline_calls: bool,
    /// How triangles are intersected (optik's triangles, where the pipeline mixes kinds).
    pub triangles: TriangleMode,
    /// The driver's triangles and optik's share the scene (docs/vulkan-backend.md §2.4):
    /// triangle hit groups are two Vulkan groups, and hit stages tell the kinds apart by
    /// their hit kinds (the driver's are 0xFE and 0xFF, optik's stage reports bits 0 and 1).
    pub mixed_triangles: bool,
    /// The device has `rayTraversalPrimitiveCulling`: with optik's triangle stage, a ray
    /// asking to cull both faces carries Vulkan's `SkipTrianglesKHR` instead, which the stage
    /// reads back, so rays need not carry their flags in the state. It skips the driver's
    /// triangles too where they share the scene, as their culling asks (paths that disable
    /// culling over them go through box twins, docs/vulkan-backend.md §2.4).
    pub skip_triangles_flag: bool,
    /// The scene has motion (keys, motion transforms): stages interpolate primitives and
    /// follow motion chains, at the ray's time when `motion` is on and at key 0 otherwise
    /// (as the CPU backend does for pipelines compiled without motion).
    pub motion_structures: bool,
    /// The scene has opacity micromaps: opacity culling is decided by optik's stages rather
    /// than the driver (Vulkan sees micromap triangles non-opaque).
    pub micromaps: bool,
    /// optik's triangle stage looks micromap states up (the pipeline allows micromaps;
    /// otherwise they are ignored, as on the other backends).
    pub micromap_states: bool,
    /// The primitive types the pipeline intersects (`PrimitiveTypeFlags` bits): optik's
    /// stages and the wrappers of intersection programs skip the others, which Vulkan's skip
    /// flags cannot do once triangles are AABBs too.
    pub primitive_types: u32,
}

impl LoweringConfig {
    /// Whether stages keep per-launch-index state (the `_optik_state` buffer).
    pub fn uses_state(&self) -> bool {
        self.motion
            || self.track_depth
            || self.track_ray_flags
            || self.guard_direct_calls
            || self.continuation_calls
            || !self.exceptions.is_empty()
    }

    /// Whether the pipeline intersects primitives of `types` (any of them).
    pub fn intersects(&self, types: optik_api::PrimitiveTypeFlags) -> bool {
        optik_api::PrimitiveTypeFlags(self.primitive_types).intersects(types)
    }

    /// Whether user intersection programs run behind optik's own test of the primitive's box
    /// (traversal.rs): whenever the pipeline intersects custom primitives.
    pub fn box_guard(&self) -> bool {
        self.intersects(optik_api::PrimitiveTypeFlags::CUSTOM)
    }

    /// Whether stages check for and unwind exceptions.
    pub fn unwinds(&self) -> bool {
        !self.exceptions.is_empty()
    }
}

impl Default for LoweringConfig {
    fn default() -> Self {
        LoweringConfig {
            payload_len: 1,
            max_trace_depth: 1,
            max_direct_callable_depth: 4,
            max_continuation_callable_depth: 4,
            exceptions: ExceptionFlags::NONE,
            exception_program: false,
            motion: false,
            track_depth: false,
            track_ray_flags: false,
            guard_direct_calls: false,
            continuation_calls: false,
            inline_calls: false,
            triangles: TriangleMode::Native,
            mixed_triangles: false,
            skip_triangles_flag: false,
            motion_structures: false,
            micromaps: false,
            micromap_states: false,
            primitive_types: optik_api::PrimitiveTypeFlags::ALL.0,
        }
    }
}

/// The primitive a hit group's closest-hit and any-hit programs serve: it decides what
/// `rt_hit_kind`, `rt_triangle_vertices`, `rt_sphere` and `rt_curve_parameter` read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum HitContext {
    /// Triangles (the driver's, or optik's triangle stage).
    Triangles,
    /// Custom primitives with the user's intersection program.
    Custom,
    /// Spheres, with optik's sphere intersection stage.
    Sphere,
    /// Curves, with optik's curve intersection stage.
    Curve,
}

impl HitContext {
    /// The value of the prelude's `_optik_ctx`.
    pub fn code(self) -> u32 {
        match self {
            HitContext::Triangles => 0,
            HitContext::Custom => 1,
            HitContext::Sphere => 2,
            HitContext::Curve => 3,
        }
    }
}

/// The Vulkan shader stage a stage is compiled to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VkStage {
    /// `RayGenerationKHR`.
    Raygen,
    /// `MissKHR`.
    Miss,
    /// `ClosestHitKHR`.
    ClosestHit,
    /// `AnyHitKHR`.
    AnyHit,
    /// `IntersectionKHR`.
    Intersection,
    /// `CallableKHR`.
    Callable,
}

/// What one stage runs, and as which Vulkan stage.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum StageRole {
    /// A user program, run as the stage its kind maps to; hit programs carry the primitive
    /// they serve.
    Program {
        /// The program's function name (`closesthit__radiance`).
        name: String,
        /// Its kind.
        kind: ProgramKind,
        /// The hit group's primitive, for closest-hit and any-hit programs.
        context: Option<HitContext>,
    },
    /// optik's sphere intersection stage (built-in sphere hit groups).
    SphereIntersection,
    /// optik's curve intersection stage for one basis (`optik_api::wgsl::curve_basis`).
    CurveIntersection(u32),
    /// optik's triangle intersection stage (emulated triangles), with the pipeline's test.
    TriangleIntersection,
    /// The intersection stage of the hit records past the user's: a candidate of any
    /// primitive kind is a hit without programs, or raises `INVALID_HIT_SBT` under debug
    /// exceptions.
    PastTableIntersection,
    /// The any-hit stage of those records for native triangles under debug exceptions.
    InvalidHitAnyHit,
    /// The closest-hit stage of those records for native triangles under debug exceptions.
    InvalidHitClosestHit,
    /// The callable that stands in for callable records without a direct callable, and for
    /// indices past the table.
    NullCallable,
    /// The miss stage that stands in for callable records without a continuation callable.
    NullContinuation,
}

impl StageRole {
    /// The Vulkan stage.
    pub fn vk_stage(&self) -> VkStage {
        match self {
            StageRole::Program { kind, .. } => match kind {
                ProgramKind::Raygen => VkStage::Raygen,
                ProgramKind::Miss => VkStage::Miss,
                ProgramKind::ClosestHit => VkStage::ClosestHit,
                ProgramKind::AnyHit => VkStage::AnyHit,
                ProgramKind::Intersection => VkStage::Intersection,
                ProgramKind::DirectCallable | ProgramKind::Exception => VkStage::Callable,
                // Vulkan callables cannot trace; continuation callables run as miss stages
                // reached by a trace against the empty acceleration structure.
                ProgramKind::ContinuationCallable => VkStage::Miss,
            },
            StageRole::SphereIntersection
            | StageRole::CurveIntersection(_)
            | StageRole::TriangleIntersection
            | StageRole::PastTableIntersection => VkStage::Intersection,
            StageRole::InvalidHitAnyHit => VkStage::AnyHit,
            StageRole::InvalidHitClosestHit => VkStage::ClosestHit,
            StageRole::NullCallable => VkStage::Callable,
            StageRole::NullContinuation => VkStage::Miss,
        }
    }

    /// The program kind the stage behaves as (the prelude's `_optik_stage`).
    pub fn behaves_as(&self) -> ProgramKind {
        match self {
            StageRole::Program { kind, .. } => *kind,
            StageRole::SphereIntersection
            | StageRole::CurveIntersection(_)
            | StageRole::TriangleIntersection
            | StageRole::PastTableIntersection => ProgramKind::Intersection,
            StageRole::InvalidHitAnyHit => ProgramKind::AnyHit,
            StageRole::InvalidHitClosestHit => ProgramKind::ClosestHit,
            StageRole::NullCallable => ProgramKind::DirectCallable,
            StageRole::NullContinuation => ProgramKind::ContinuationCallable,
        }
    }

    /// The entry point name the stage gets in its SPIR-V module.
    pub fn entry_name(&self) -> String {
        match self {
            StageRole::Program {
                name,
                context: Some(ctx),
                ..
            } => format!("{name}.{}", ctx.code()),
            StageRole::Program { name, .. } => name.clone(),
            StageRole::SphereIntersection => "optik_sphere_intersection".into(),
            StageRole::CurveIntersection(b) => format!("optik_curve_intersection_{b}"),
            StageRole::TriangleIntersection => "optik_triangle_intersection".into(),
            StageRole::PastTableIntersection => "optik_past_table_intersection".into(),
            StageRole::InvalidHitAnyHit => "optik_invalid_hit_anyhit".into(),
            StageRole::InvalidHitClosestHit => "optik_invalid_hit_closesthit".into(),
            StageRole::NullCallable => "optik_null_callable".into(),
            StageRole::NullContinuation => "optik_null_continuation".into(),
        }
    }
}

/// The prelude's `_optik_stage` value of a program kind: its index in [`ProgramKind::ALL`].
pub fn stage_code(kind: ProgramKind) -> u32 {
    ProgramKind::ALL
        .iter()
        .position(|k| *k == kind)
        .unwrap_or(0) as u32
}
