//! Module, pipeline and program group descriptions (OptiX `OptixModuleCompileOptions`,
//! `OptixPipelineCompileOptions`, `OptixPipelineLinkOptions`, `OptixProgramGroupDesc`).

use crate::flags::{ExceptionFlags, PrimitiveTypeFlags};
use crate::handle::Module;

/// A setting that may be left for optik to derive (DESIGN.md §6): `Auto` takes the value from
/// the acceleration structures alive when the pipeline is created and from the programs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Setting<T> {
    /// Derive from the scene and the programs.
    #[default]
    Auto,
    /// Use this value.
    Value(T),
}

impl<T: Copy> Setting<T> {
    /// The value, or `auto` when left to `Auto`.
    pub fn or(self, auto: T) -> T {
        match self {
            Setting::Auto => auto,
            Setting::Value(v) => v,
        }
    }
}

/// The eight program kinds, found by the prefix of a function's name (DESIGN.md §3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ProgramKind {
    /// `raygen__`.
    Raygen,
    /// `intersection__`.
    Intersection,
    /// `anyhit__`.
    AnyHit,
    /// `closesthit__`.
    ClosestHit,
    /// `miss__`.
    Miss,
    /// `exception__`.
    Exception,
    /// `direct_callable__`.
    DirectCallable,
    /// `continuation_callable__`.
    ContinuationCallable,
}

impl ProgramKind {
    /// Every kind, in the order of the table in DESIGN.md §3.
    pub const ALL: [ProgramKind; 8] = [
        ProgramKind::Raygen,
        ProgramKind::Intersection,
        ProgramKind::AnyHit,
        ProgramKind::ClosestHit,
        ProgramKind::Miss,
        ProgramKind::Exception,
        ProgramKind::DirectCallable,
        ProgramKind::ContinuationCallable,
    ];

    /// The function-name prefix, including the double underscore.
    pub fn prefix(self) -> &'static str {
        match self {
            ProgramKind::Raygen => "raygen__",
            ProgramKind::Intersection => "intersection__",
            ProgramKind::AnyHit => "anyhit__",
            ProgramKind::ClosestHit => "closesthit__",
            ProgramKind::Miss => "miss__",
            ProgramKind::Exception => "exception__",
            ProgramKind::DirectCallable => "direct_callable__",
            ProgramKind::ContinuationCallable => "continuation_callable__",
        }
    }

    /// A readable name ("closest-hit").
    pub fn name(self) -> &'static str {
        match self {
            ProgramKind::Raygen => "raygen",
            ProgramKind::Intersection => "intersection",
            ProgramKind::AnyHit => "any-hit",
            ProgramKind::ClosestHit => "closest-hit",
            ProgramKind::Miss => "miss",
            ProgramKind::Exception => "exception",
            ProgramKind::DirectCallable => "direct callable",
            ProgramKind::ContinuationCallable => "continuation callable",
        }
    }

    /// The kind whose prefix starts `function_name`, if any.
    pub fn from_function_name(function_name: &str) -> Option<ProgramKind> {
        ProgramKind::ALL
            .into_iter()
            .find(|k| function_name.starts_with(k.prefix()))
    }

    /// The bit of this kind in a "programs that ran" mask (conformance `programs` channel).
    pub fn bit(self) -> u32 {
        match self {
            ProgramKind::Raygen => 1 << 0,
            ProgramKind::Intersection => 1 << 1,
            ProgramKind::AnyHit => 1 << 2,
            ProgramKind::ClosestHit => 1 << 3,
            ProgramKind::Miss => 1 << 4,
            ProgramKind::Exception => 1 << 5,
            ProgramKind::DirectCallable => 1 << 6,
            ProgramKind::ContinuationCallable => 1 << 7,
        }
    }
}

impl std::fmt::Display for ProgramKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Optimisation level of a module (OptiX `OptixCompileOptimizationLevel`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum OptLevel {
    /// The backend's default (full optimisation).
    #[default]
    Default,
    /// No optimisation, fastest compile.
    None,
    /// Full optimisation.
    Full,
}

/// Debug information level of a module (OptiX `OptixCompileDebugLevel`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum DebugLevel {
    /// None.
    #[default]
    None,
    /// Line information where the backend supports it.
    Minimal,
    /// Everything the backend can keep.
    Full,
}

/// Options for compiling one module (OptiX `OptixModuleCompileOptions`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct ModuleCompileOptions {
    /// Optimisation level.
    pub opt_level: OptLevel,
    /// Debug information.
    pub debug_level: DebugLevel,
}

/// Which traversable graphs a pipeline must handle (OptiX `OptixTraversableGraphFlags`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum TraversableGraph {
    /// Only a single geometry acceleration structure, no instances or transforms.
    SingleGas,
    /// One level of instances over geometry.
    SingleLevelInstancing,
    /// Any graph: nested instances and transforms.
    Any,
}

/// Most payload registers a pipeline may have (OptiX's 32): the largest
/// [`PipelineCompileOptions::num_payload_values`] and the longest `RtPayload`.
pub const MAX_PAYLOAD_VALUES: u32 = 32;

/// Most attribute registers an intersection program may report (OptiX's 8): the largest
/// [`PipelineCompileOptions::num_attribute_values`] and the length of `RtAttributes`.
pub const MAX_ATTRIBUTE_VALUES: u32 = 8;

/// Options shared by every module of a pipeline and the pipeline itself (OptiX
/// `OptixPipelineCompileOptions`). Each may be left to `Auto` (DESIGN.md §6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct PipelineCompileOptions {
    /// Whether rays carry time and motion is interpolated.
    pub uses_motion_blur: Setting<bool>,
    /// Which traversable graphs the pipeline handles.
    pub traversable_graph: Setting<TraversableGraph>,
    /// Which primitive types the pipeline intersects.
    pub primitive_types: Setting<PrimitiveTypeFlags>,
    /// Payload registers (0..=[`MAX_PAYLOAD_VALUES`]): the length of WGSL's `RtPayload`.
    pub num_payload_values: Setting<u32>,
    /// Attribute registers (0..=[`MAX_ATTRIBUTE_VALUES`]) reported by intersection programs.
    pub num_attribute_values: Setting<u32>,
    /// Which exceptions are checked.
    pub exception_flags: Setting<ExceptionFlags>,
    /// Whether triangles may carry opacity micromaps.
    pub allow_opacity_micromaps: Setting<bool>,
}

/// Options for linking a pipeline (OptiX `OptixPipelineLinkOptions`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PipelineLinkOptions {
    /// Deepest recursion of `rt_trace` (0..=31): with 1, raygen may trace but hit and miss
    /// programs may not.
    pub max_trace_depth: u32,
    /// Deepest nesting of direct callables.
    pub max_direct_callable_depth: u32,
    /// Deepest nesting of continuation callables.
    pub max_continuation_callable_depth: u32,
}

impl Default for PipelineLinkOptions {
    fn default() -> Self {
        Self {
            max_trace_depth: 1,
            max_direct_callable_depth: 4,
            max_continuation_callable_depth: 4,
        }
    }
}

/// A program in a module: the module and the function's full name (`closesthit__radiance`).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct ProgramRef {
    /// The module holding the program.
    pub module: Module,
    /// The function name, with its prefix.
    pub entry: String,
}

impl ProgramRef {
    /// `entry` in `module`.
    pub fn new(module: Module, entry: impl Into<String>) -> Self {
        Self {
            module,
            entry: entry.into(),
        }
    }
}

/// Built-in intersectors for hit groups of built-in primitives (OptiX
/// `optixBuiltinISModuleGet`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BuiltinIntersector {
    /// Triangles (always built in; the default of a hit group without an intersection).
    Triangle,
    /// Spheres.
    Sphere,
    /// Curves of one type.
    Curve(crate::accel::CurveType),
}

/// What a program group holds (OptiX `OptixProgramGroupDesc`).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum ProgramGroupDesc {
    /// A ray generation program.
    Raygen(ProgramRef),
    /// A miss program, or none (a null miss group: misses run nothing).
    Miss(Option<ProgramRef>),
    /// An exception program.
    Exception(ProgramRef),
    /// A hit group: each program may be absent. Without an intersection program the group
    /// serves triangles, or the built-in intersector named by `builtin`.
    HitGroup {
        /// Closest-hit program.
        closest_hit: Option<ProgramRef>,
        /// Any-hit program.
        any_hit: Option<ProgramRef>,
        /// Intersection program, for custom primitives.
        intersection: Option<ProgramRef>,
        /// The built-in intersector used when `intersection` is `None`.
        builtin: BuiltinIntersector,
    },
    /// Callables: a direct callable, a continuation callable, or both.
    Callables {
        /// Direct callable.
        direct: Option<ProgramRef>,
        /// Continuation callable.
        continuation: Option<ProgramRef>,
    },
}

impl ProgramGroupDesc {
    /// A hit group with only a closest-hit program, for triangles.
    pub fn closest_hit(program: ProgramRef) -> Self {
        ProgramGroupDesc::HitGroup {
            closest_hit: Some(program),
            any_hit: None,
            intersection: None,
            builtin: BuiltinIntersector::Triangle,
        }
    }

    /// The programs the group names, with the kind each must have.
    pub fn programs(&self) -> Vec<(ProgramKind, &ProgramRef)> {
        let mut v = Vec::new();
        match self {
            ProgramGroupDesc::Raygen(p) => v.push((ProgramKind::Raygen, p)),
            ProgramGroupDesc::Miss(p) => v.extend(p.iter().map(|p| (ProgramKind::Miss, p))),
            ProgramGroupDesc::Exception(p) => v.push((ProgramKind::Exception, p)),
            ProgramGroupDesc::HitGroup {
                closest_hit,
                any_hit,
                intersection,
                ..
            } => {
                v.extend(closest_hit.iter().map(|p| (ProgramKind::ClosestHit, p)));
                v.extend(any_hit.iter().map(|p| (ProgramKind::AnyHit, p)));
                v.extend(intersection.iter().map(|p| (ProgramKind::Intersection, p)));
            }
            ProgramGroupDesc::Callables {
                direct,
                continuation,
            } => {
                v.extend(direct.iter().map(|p| (ProgramKind::DirectCallable, p)));
                v.extend(
                    continuation
                        .iter()
                        .map(|p| (ProgramKind::ContinuationCallable, p)),
                );
            }
        }
        v
    }

    /// The SBT region records of this group belong in.
    pub fn region(&self) -> GroupRegion {
        match self {
            ProgramGroupDesc::Raygen(_) => GroupRegion::Raygen,
            ProgramGroupDesc::Miss(_) => GroupRegion::Miss,
            ProgramGroupDesc::Exception(_) => GroupRegion::Exception,
            ProgramGroupDesc::HitGroup { .. } => GroupRegion::HitGroup,
            ProgramGroupDesc::Callables { .. } => GroupRegion::Callables,
        }
    }
}

/// The SBT region a program group's records belong in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum GroupRegion {
    /// The raygen record.
    Raygen,
    /// The exception record.
    Exception,
    /// Miss records.
    Miss,
    /// Hit group records.
    HitGroup,
    /// Callable records.
    Callables,
}

impl GroupRegion {
    /// A readable name.
    pub fn name(self) -> &'static str {
        match self {
            GroupRegion::Raygen => "raygen",
            GroupRegion::Exception => "exception",
            GroupRegion::Miss => "miss",
            GroupRegion::HitGroup => "hit group",
            GroupRegion::Callables => "callables",
        }
    }
}
