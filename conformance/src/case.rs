//! What a conformance case is: a scene, WGSL programs with a Rust model of each, pipeline
//! options, an SBT layout, launches, what is recorded and with which tolerance.

use crate::compare::IdiffOptions;
use crate::image::ChannelKind;
use crate::oracle::geometry::Rounding;
use crate::oracle::model::Models;
use crate::scene::{NodeId, Scene};
use crate::tolerance::Tolerance;
use optik::{BackendKind, BuiltinIntersector, PipelineCompileOptions, PipelineLinkOptions};

/// The case groups (README.md, "Rules"); `catalog/<group>.rs` holds each group's cases.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Group {
    /// Launch dimensions and indices.
    Launch,
    /// Built-in values per program kind.
    Builtin,
    /// Triangle intersection.
    Tri,
    /// Ray, instance and geometry flags.
    Flags,
    /// Any-hit programs.
    Ah,
    /// Custom primitives and intersection programs.
    Aabb,
    /// Shader binding table indexing.
    Sbt,
    /// Payload registers.
    Payload,
    /// Callables.
    Call,
    /// Recursive tracing.
    Trace,
    /// Instances.
    Inst,
    /// Motion.
    Motion,
    /// Built-in primitives (spheres, curves) and opacity micromaps.
    Prim,
    /// Acceleration structure lifecycle and data access.
    As,
    /// Exceptions and the invalid-ray policy.
    Exc,
    /// End-to-end images.
    Img,
    /// Numerically hard rays.
    Numerics,
}

impl Group {
    /// Every group, in catalog order.
    pub const ALL: [Group; 17] = [
        Group::Launch,
        Group::Builtin,
        Group::Tri,
        Group::Flags,
        Group::Ah,
        Group::Aabb,
        Group::Sbt,
        Group::Payload,
        Group::Call,
        Group::Trace,
        Group::Inst,
        Group::Motion,
        Group::Prim,
        Group::As,
        Group::Exc,
        Group::Img,
        Group::Numerics,
    ];

    /// The name that starts case names (`sbt` in `sbt.hit_index_grid`).
    pub fn name(self) -> &'static str {
        match self {
            Group::Launch => "launch",
            Group::Builtin => "builtin",
            Group::Tri => "tri",
            Group::Flags => "flags",
            Group::Ah => "ah",
            Group::Aabb => "aabb",
            Group::Sbt => "sbt",
            Group::Payload => "payload",
            Group::Call => "call",
            Group::Trace => "trace",
            Group::Inst => "inst",
            Group::Motion => "motion",
            Group::Prim => "prim",
            Group::As => "as",
            Group::Exc => "exc",
            Group::Img => "img",
            Group::Numerics => "numerics",
        }
    }
}

/// The rules of DESIGN.md §4 (and the accuracy promises of §5) a case guards.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Rule {
    /// Ray flag bit values; only 8 mask bits, 4 SBT offset/stride bits, 16 miss-index bits.
    FlagBitsAndWidths,
    /// Precedence of geometry, instance and ray flags.
    FlagPrecedence,
    /// Triangles hit in the open interval (tmin, tmax).
    TriangleOpenInterval,
    /// Custom primitives report any t in [tmin, tmax].
    CustomClosedInterval,
    /// Front face: counter-clockwise from the origin, in object space; hit kinds 0xFE/0xFF.
    FrontFace,
    /// Any-hit runs for every candidate on non-opaque geometry unless disabled.
    AnyHitPerCandidate,
    /// REQUIRE_SINGLE_ANYHIT_CALL: exactly once per primitive.
    SingleAnyHit,
    /// Ignore discards the candidate; terminate accepts it and ends traversal.
    IgnoreTerminate,
    /// Invalid rays: miss without programs; INVALID_RAY with debug exceptions.
    InvalidRayPolicy,
    /// Degenerate and NaN-vertex triangles never hit and do not disturb neighbours.
    DegenerateTriangles,
    /// Matrix motion interpolates keys linearly.
    MatrixMotion,
    /// SRT motion uses nlerp.
    SrtMotion,
    /// Times outside the range clamp unless the vanish flags say otherwise.
    MotionClamp,
    /// Exceptions: depth exceeded, user codes, invalid ray, invalid SBT index.
    Exceptions,
    /// SBT record index = instance offset + ray offset + GAS index × stride; miss index.
    SbtIndex,
    /// §5: watertight triangles (no leaks, no double hits through closed meshes).
    Watertight,
    /// §5: secondary rays from `rt_offset_ray` do not re-hit their surface.
    OffsetRay,
}

impl Rule {
    /// Every rule.
    pub const ALL: [Rule; 17] = [
        Rule::FlagBitsAndWidths,
        Rule::FlagPrecedence,
        Rule::TriangleOpenInterval,
        Rule::CustomClosedInterval,
        Rule::FrontFace,
        Rule::AnyHitPerCandidate,
        Rule::SingleAnyHit,
        Rule::IgnoreTerminate,
        Rule::InvalidRayPolicy,
        Rule::DegenerateTriangles,
        Rule::MatrixMotion,
        Rule::SrtMotion,
        Rule::MotionClamp,
        Rule::Exceptions,
        Rule::SbtIndex,
        Rule::Watertight,
        Rule::OffsetRay,
    ];

    /// The rule in DESIGN.md's words.
    pub fn text(self) -> &'static str {
        match self {
            Rule::FlagBitsAndWidths => {
                "§4 ray flag bits; only 8 mask bits, 4 bits of SBT offset/stride, 16 bits of miss index count"
            }
            Rule::FlagPrecedence => "§4 precedence of geometry, instance and ray flags",
            Rule::TriangleOpenInterval => "§4 triangles hit in the open interval (tmin, tmax)",
            Rule::CustomClosedInterval => "§4 custom primitives report any t in [tmin, tmax]",
            Rule::FrontFace => {
                "§4 front face: counter-clockwise from the ray origin, object space (0xFE / 0xFF)"
            }
            Rule::AnyHitPerCandidate => {
                "§4 any-hit runs for every candidate on non-opaque geometry unless disabled"
            }
            Rule::SingleAnyHit => "§4 REQUIRE_SINGLE_ANYHIT_CALL: exactly once per primitive",
            Rule::IgnoreTerminate => {
                "§4 ignore discards the candidate; terminate accepts it and ends traversal"
            }
            Rule::InvalidRayPolicy => {
                "§4 invalid rays miss without programs; INVALID_RAY with debug exceptions"
            }
            Rule::DegenerateTriangles => {
                "§4 degenerate and NaN-vertex triangles never hit and do not disturb neighbours"
            }
            Rule::MatrixMotion => "§4 matrix motion interpolates keys linearly",
            Rule::SrtMotion => "§4 SRT motion uses normalised linear quaternion blending (nlerp)",
            Rule::MotionClamp => {
                "§4 times outside the motion range clamp unless the vanish flags say otherwise"
            }
            Rule::Exceptions => {
                "§4 exceptions: trace depth, user codes, invalid ray, invalid SBT index"
            }
            Rule::SbtIndex => {
                "§2/§4 SBT record index = instance offset + ray offset + GAS index × stride; miss index"
            }
            Rule::Watertight => {
                "§5 watertight triangles: exactly one hit where a ray crosses a closed mesh"
            }
            Rule::OffsetRay => "§5 rt_offset_ray spawn points do not re-hit their surface",
        }
    }
}

/// A hit group: programs by WGSL function name.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HitGroupDesc {
    /// Closest-hit program.
    pub closest_hit: Option<String>,
    /// Any-hit program.
    pub any_hit: Option<String>,
    /// Intersection program.
    pub intersection: Option<String>,
    /// The built-in intersector when there is no intersection program (`None`: triangles).
    pub builtin: Option<BuiltinIntersector>,
}

/// A callables group.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CallableDesc {
    /// Direct callable.
    pub direct: Option<String>,
    /// Continuation callable.
    pub continuation: Option<String>,
}

/// The programs of a case: one WGSL module and its program groups.
#[derive(Clone, Debug)]
pub struct PipelineDesc {
    /// The WGSL source.
    pub wgsl: String,
    /// The raygen program.
    pub raygen: String,
    /// Miss groups (`None`: a null miss group).
    pub miss: Vec<Option<String>>,
    /// Hit groups.
    pub hit: Vec<HitGroupDesc>,
    /// Callables groups.
    pub callables: Vec<CallableDesc>,
    /// The exception program.
    pub exception: Option<String>,
    /// Pipeline compile options (mostly Auto).
    pub compile: PipelineCompileOptions,
    /// Link options.
    pub link: PipelineLinkOptions,
}

/// One SBT record: which group of its region, and its data words.
#[derive(Clone, Debug, PartialEq)]
pub struct SbtEntry {
    /// Index into the region's groups (`PipelineDesc::miss`, `hit` or `callables`).
    pub group: usize,
    /// User data after the 32-byte header.
    pub data: Vec<u32>,
}

impl SbtEntry {
    /// A record of `group` whose data is `data`.
    pub fn new(group: usize, data: Vec<u32>) -> Self {
        SbtEntry { group, data }
    }
}

/// The shader binding table of a case.
#[derive(Clone, Debug, Default)]
pub struct SbtLayout {
    /// Raygen record data.
    pub raygen_data: Vec<u32>,
    /// Exception record data.
    pub exception_data: Vec<u32>,
    /// Miss records.
    pub miss: Vec<SbtEntry>,
    /// Hit group records.
    pub hit: Vec<SbtEntry>,
    /// Callable records.
    pub callables: Vec<SbtEntry>,
    /// Stride of every region; `None`: the smallest multiple of 16 that holds every record.
    pub stride: Option<u32>,
}

impl SbtLayout {
    /// The stride used: given, or header + the largest data, rounded up to 16 bytes.
    pub fn effective_stride(&self) -> u32 {
        self.stride.unwrap_or_else(|| {
            let most = [&self.miss, &self.hit, &self.callables]
                .iter()
                .flat_map(|r| r.iter().map(|e| e.data.len()))
                .chain([self.raygen_data.len(), self.exception_data.len()])
                .max()
                .unwrap_or(0) as u32;
            (32 + 4 * most).div_ceil(16) * 16
        })
    }
}

/// One word of the launch parameters (`params` at binding 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ParamWord {
    /// A `u32`.
    U32(u32),
    /// An `f32`.
    F32(f32),
    /// The low word of a traversable handle (`None`: the null handle).
    HandleLo(Option<NodeId>),
    /// The high word of a traversable handle.
    HandleHi(Option<NodeId>),
}

impl ParamWord {
    /// The two words of a handle to `node`.
    pub fn handle(node: Option<NodeId>) -> [ParamWord; 2] {
        [ParamWord::HandleLo(node), ParamWord::HandleHi(node)]
    }
}

/// A storage buffer's initial contents.
#[derive(Clone, Debug, PartialEq)]
pub struct BufferInit {
    /// `@group(0) @binding(n)`, n ≥ 1.
    pub binding: u32,
    /// The words.
    pub words: Vec<u32>,
}

/// One launch.
#[derive(Clone, Debug)]
pub struct Launch {
    /// Width, height, depth.
    pub dims: [u32; 3],
    /// Launch parameter words.
    pub params: Vec<ParamWord>,
    /// Storage buffers (inputs and the record buffer).
    pub buffers: Vec<BufferInit>,
}

impl Launch {
    /// Number of launch indices.
    pub fn count(&self) -> usize {
        self.dims.iter().map(|d| *d as usize).product()
    }
}

/// Where records are in the record buffer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RecordLayout {
    /// One record of `stride` words per launch index; the image is width × (height · depth).
    PerIndex {
        /// Words per record.
        stride: usize,
    },
    /// The whole buffer, one word per pixel, `width` pixels per row (for launches that must
    /// leave it untouched).
    WholeBuffer {
        /// Pixels per row.
        width: usize,
    },
}

/// One recorded channel.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelSpec {
    /// Channel name.
    pub name: String,
    /// Word within the record.
    pub word: usize,
    /// UINT or FLOAT.
    pub kind: ChannelKind,
    /// How outputs are compared.
    pub tolerance: Tolerance,
}

/// How a case's outputs are judged.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Judgement {
    /// Every record must match an admissible record within each channel's tolerance.
    PerRecord,
    /// An image: idiff thresholds over all pixels (after picking, per pixel, the admissible
    /// value closest to the output).
    Image(IdiffOptions),
}

/// What a case records.
#[derive(Clone, Debug)]
pub struct RecordSpec {
    /// The record buffer's binding.
    pub binding: u32,
    /// Where records are.
    pub layout: RecordLayout,
    /// The channels.
    pub channels: Vec<ChannelSpec>,
    /// How outputs are judged.
    pub judgement: Judgement,
}

/// A conformance case.
#[derive(Clone)]
pub struct Case {
    /// `group.case`.
    pub name: String,
    /// Its group.
    pub group: Group,
    /// What it checks, in a sentence.
    pub summary: String,
    /// The DESIGN.md rules it guards.
    pub guards: Vec<Rule>,
    /// The scene.
    pub scene: Scene,
    /// The programs.
    pub pipeline: PipelineDesc,
    /// Rust models of the programs, for the oracle.
    pub models: Models,
    /// The shader binding table.
    pub sbt: SbtLayout,
    /// The launches (each gives one record image).
    pub launches: Vec<Launch>,
    /// What is recorded.
    pub record: RecordSpec,
    /// The oracle's ambiguity bands.
    pub rounding: Rounding,
    /// Backends allowed their own reference, with the implementation-defined reason.
    pub backend_specific: Vec<(BackendKind, String)>,
}

impl Case {
    /// The file stem of launch `k`'s reference: `<case>` or `<case>.launch<k>`.
    pub fn launch_stem(&self, k: usize) -> String {
        if self.launches.len() == 1 {
            self.name.clone()
        } else {
            format!("{}.launch{k}", self.name)
        }
    }

    /// Channel names with their tolerance, for listings (`hit:E prim:E t:U16`).
    pub fn tolerance_text(&self) -> String {
        match self.record.judgement {
            Judgement::Image(o) => format!("image ({})", o.describe()),
            Judgement::PerRecord => {
                let mut parts: Vec<String> = Vec::new();
                for c in &self.record.channels {
                    let t = c.tolerance.name();
                    match parts.last_mut() {
                        Some(last) if last.ends_with(&format!(":{t}")) => {
                            let base = last.trim_end_matches(&format!(":{t}")).to_string();
                            *last = format!("{base},{}:{t}", c.name);
                        }
                        _ => parts.push(format!("{}:{t}", c.name)),
                    }
                }
                format!("{}; ambiguous rays: AMB", parts.join(" "))
            }
        }
    }
}
