//! The megakernel: one WGSL compute shader per pipeline (and per scene size), generated.
//!
//! Its parts, in the order [`generate`] writes them:
//! 1. bindings: launch constants, the packed SBT, the handle table and the scene arena
//!    chunks in `@group(1)` (the user's bindings stay in `@group(0)`), and `_optik_fetch`;
//! 2. the shared WGSL of `optik_api::wgsl`, only the parts the features need;
//! 3. the state of the current program (ray, hit, payload registers, SBT record) as
//!    private globals, which trace and callable calls save and restore around the callee;
//! 4. the device API (`device_api`), the traversal (`traversal`), `_optik_raise`
//!    (`exceptions`), and the trace, callable and program dispatch functions (`dispatch`);
//! 5. the user's modules lowered by `crate::program::instance`;
//! 6. the entry point.
//!
//! Everything a pipeline does not use is left out (DESIGN.md §6): the feature set decides
//! which primitive intersectors, motion, instancing, any-hit, intersection, micromap and
//! exception code is written at all.

pub(crate) mod counters;
mod device_api;
mod dispatch;
mod exceptions;
mod traversal;

use crate::program::instance::Lowered;
use optik_api::wgsl::{self, SnippetOptions};
use optik_api::{Accuracy, BoxTest, FeatureSet, PrimitiveTypeFlags, TriangleTest};

/// Group flag bits stored in each packed SBT record's second word.
pub(crate) mod group_flags {
    /// The group has a closest-hit program.
    pub const CLOSEST_HIT: u32 = 1;
    /// The group has an any-hit program.
    pub const ANY_HIT: u32 = 2;
    /// The group has an intersection program.
    pub const INTERSECTION: u32 = 4;
    /// The group has a direct callable.
    pub const DIRECT: u32 = 8;
    /// The group has a continuation callable.
    pub const CONTINUATION: u32 = 16;
}

/// Sizes that depend on the scene alive at launch, not on the pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct Sizes {
    /// Scene arena chunks (bindings).
    pub chunks: u32,
    /// log2 of the vec4s per chunk.
    pub chunk_shift: u32,
    /// Traversal stack entries.
    pub stack: u32,
    /// BVH levels (instance and geometry structures) on the deepest path.
    pub levels: u32,
}

/// Everything the kernel text depends on.
pub(crate) struct KernelConfig<'a> {
    pub features: &'a FeatureSet,
    pub accuracy: Accuracy,
    /// The device offers WGSL `f64` (the watertight test's exact fallback).
    pub f64: bool,
    /// Low 16 bits of the device id, checked in traversable handles.
    pub device16: u32,
    pub max_direct: u32,
    pub max_continuation: u32,
    pub sizes: Sizes,
    pub lowered: &'a Lowered,
    /// The instrumented benchmark kernel: traffic counters (`counters`), never in a
    /// pipeline's normal kernel.
    pub counters: bool,
}

impl KernelConfig<'_> {
    fn has(&self, t: PrimitiveTypeFlags) -> bool {
        self.features.primitive_types.intersects(t)
    }
    fn triangles(&self) -> bool {
        self.has(PrimitiveTypeFlags::TRIANGLE)
    }
    fn custom(&self) -> bool {
        self.has(PrimitiveTypeFlags::CUSTOM)
    }
    fn spheres(&self) -> bool {
        self.has(PrimitiveTypeFlags::SPHERE)
    }
    fn curves(&self) -> bool {
        self.has(PrimitiveTypeFlags::CURVES)
    }
    fn instancing(&self) -> bool {
        self.features.instancing()
    }
    /// Instances of geometry structures only (single-level instancing): the walk's levels
    /// are the root's and one instance's.
    fn one_level(&self) -> bool {
        self.instancing() && !self.any_graph()
    }
    /// Transform traversables and nested instances (any graph).
    fn any_graph(&self) -> bool {
        self.features.traversable_graph == optik_api::TraversableGraph::Any
    }
    fn motion(&self) -> bool {
        self.features.motion
    }
    fn geometry_motion(&self) -> bool {
        self.features.motion && self.features.motion_kinds.geometry
    }
    fn any_hit(&self) -> bool {
        self.features.any_hit
    }
    fn intersection(&self) -> bool {
        self.features.intersection
    }
    fn micromaps(&self) -> bool {
        self.features.opacity_micromaps && self.triangles()
    }
    fn exception(&self, f: optik_api::ExceptionFlags) -> bool {
        self.features.exceptions.contains(f)
    }
    fn debug(&self) -> bool {
        self.exception(optik_api::ExceptionFlags::DEBUG)
    }
    fn payload_len(&self) -> u32 {
        self.features.num_payload_values.max(1)
    }
    /// Whether any trace exists (so the traversal is needed).
    fn traces(&self) -> bool {
        self.lowered
            .traces
            .iter()
            .any(|&d| d < self.features.max_trace_depth)
    }
}

/// Workgroup size of the entry point.
pub(crate) const WORKGROUP_SIZE: u32 = 64;

/// The whole kernel.
pub(crate) fn generate(c: &KernelConfig<'_>) -> String {
    let mut out = String::with_capacity(64 * 1024);
    out.push_str("// optik wgpu megakernel (generated; see docs/wgpu-backend.md)\n\n");
    bindings(c, &mut out);
    snippets(c, &mut out);
    device_api::write(c, &mut out);
    if c.traces() {
        traversal::write(c, &mut out);
    }
    dispatch::write(c, &mut out);
    for (i, m) in c.lowered.module_wgsl.iter().enumerate() {
        out.push_str(&format!("\n// ---- user module {i} (lowered) ----\n"));
        out.push_str(m);
    }
    out
}

fn bindings(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(
        r#"struct _OptikLaunch {
    // width, height, depth, width·height·depth
    dims: vec4<u32>,
    // raygen record, exception record (0xFFFFFFFF: none), hit base, hit stride (words)
    sbt0: vec4<u32>,
    // hit count, miss base, miss stride, miss count
    sbt1: vec4<u32>,
    // callables base, stride, count, 0
    sbt2: vec4<u32>,
}

@group(1) @binding(0) var<uniform> _optik_launch: _OptikLaunch;
// The shader binding table, records as the user laid them out with each header replaced
// by (pipeline group index, group flags, 0...).
@group(1) @binding(1) var<storage, read> _optik_sbt: array<u32>;
// Per traversable slot: (generation | alive bit, kind word, header index, 0).
@group(1) @binding(2) var<storage, read> _optik_handles: array<vec4<u32>>;
"#,
    );
    for i in 0..c.sizes.chunks {
        out.push_str(&format!(
            "@group(1) @binding({}) var<storage, read> _optik_scene{i}: array<vec4<u32>>;\n",
            3 + i
        ));
    }
    counters::declare(c, out);
    out.push_str("\nfn _optik_fetch(i: u32) -> vec4<u32> {\n");
    let counted = counters::count(c, counters::Counter::ArenaFetches, "1u");
    if !counted.is_empty() {
        out.push_str(&format!("    {counted}\n"));
    }
    if c.sizes.chunks <= 1 {
        out.push_str("    return _optik_scene0[i];\n}\n\n");
    } else {
        out.push_str(&format!(
            "    let j = i & {}u;\n    switch i >> {}u {{\n",
            (1u64 << c.sizes.chunk_shift) - 1,
            c.sizes.chunk_shift
        ));
        for k in 1..c.sizes.chunks {
            out.push_str(&format!(
                "        case {k}u: {{ return _optik_scene{k}[j]; }}\n"
            ));
        }
        out.push_str("        default: { return _optik_scene0[j]; }\n    }\n}\n\n");
    }
}

fn snippets(c: &KernelConfig<'_>, out: &mut String) {
    let options = SnippetOptions {
        conservative_boxes: c.accuracy.box_test == BoxTest::Conservative,
        f64_fallback: c.f64 && c.accuracy.triangle == TriangleTest::Watertight,
    };
    let add = |out: &mut String, s: &str| out.push_str(&wgsl::specialise(s, options));
    add(out, wgsl::RAY);
    // The hit state holds instance transforms whenever instancing is compiled in, even in
    // a kernel that never traces (a raygen-only pipeline made before any structure).
    if c.instancing() || c.motion() {
        add(out, wgsl::MOTION);
    }
    if !c.traces() {
        return;
    }
    add(out, wgsl::SLAB);
    add(out, wgsl::BVH4);
    add(out, wgsl::OPACITY);
    if c.triangles() {
        // Only the chosen triangle test.
        let unused = match c.accuracy.triangle {
            TriangleTest::Watertight | TriangleTest::Driver => "_optik_tri_moller_trumbore",
            TriangleTest::MollerTrumbore => "_optik_tri_watertight",
        };
        let text = wgsl::specialise(wgsl::TRIANGLE, options);
        out.push_str(&crate::program::instance::remove_function(&text, unused).unwrap_or(text));
    }
    // The built-in intersectors shared with the Vulkan backend; curves use the sphere's.
    if c.spheres() || c.curves() {
        add(out, wgsl::SPHERE);
    }
    if c.curves() {
        add(out, wgsl::CURVE);
    }
    if c.micromaps() {
        add(out, wgsl::MICROMAP);
    }
}
