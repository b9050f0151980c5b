//! Scene and program feature analysis (DESIGN.md §6).
//!
//! A pipeline is compiled for exactly the features its scene and programs use. Scenes
//! report theirs per acceleration structure ([`SceneFeatures`]); program groups report
//! theirs ([`ProgramFeatures`]); `optik_core::features::resolve` combines both with the pipeline options,
//! replacing every `Auto` and checking explicit settings against what the programs need.

use crate::accel::{AccelBuildOptions, BuildInput, CurveType};
use crate::flags::{ExceptionFlags, PrimitiveTypeFlags};
use crate::program::TraversableGraph;

/// Kinds of motion in a scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct MotionKinds {
    /// Geometry with per-key vertices, AABBs, spheres or curves.
    pub geometry: bool,
    /// Matrix motion transforms.
    pub matrix: bool,
    /// SRT motion transforms.
    pub srt: bool,
}

impl MotionKinds {
    /// Whether any motion is present.
    pub fn any(&self) -> bool {
        self.geometry || self.matrix || self.srt
    }

    /// The union.
    pub fn union(self, o: MotionKinds) -> MotionKinds {
        MotionKinds {
            geometry: self.geometry || o.geometry,
            matrix: self.matrix || o.matrix,
            srt: self.srt || o.srt,
        }
    }
}

/// What a traversable (and everything below it) contains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SceneFeatures {
    /// Primitive types present.
    pub primitive_types: PrimitiveTypeFlags,
    /// Motion present.
    pub motion: MotionKinds,
    /// The graph shape.
    pub graph: TraversableGraph,
    /// Levels of instances and transforms above the geometry (0 for a lone GAS).
    pub depth: u32,
    /// Whether triangles carry opacity micromaps.
    pub opacity_micromaps: bool,
    /// Static transforms present.
    pub static_transforms: bool,
}

impl Default for SceneFeatures {
    fn default() -> Self {
        SceneFeatures {
            primitive_types: PrimitiveTypeFlags::NONE,
            motion: MotionKinds::default(),
            graph: TraversableGraph::SingleGas,
            depth: 0,
            opacity_micromaps: false,
            static_transforms: false,
        }
    }
}

impl SceneFeatures {
    /// The features of a geometry acceleration structure built from `inputs`.
    pub fn of_geometry(options: &AccelBuildOptions, inputs: &[BuildInput]) -> SceneFeatures {
        let mut f = SceneFeatures::default();
        for input in inputs {
            f.primitive_types |= match input {
                BuildInput::Triangles(t) => {
                    f.opacity_micromaps |= t.opacity_micromap.is_some();
                    PrimitiveTypeFlags::TRIANGLE
                }
                BuildInput::CustomPrimitives(_) => PrimitiveTypeFlags::CUSTOM,
                BuildInput::Spheres(_) => PrimitiveTypeFlags::SPHERE,
                BuildInput::Curves(c) => curve_flag(c.curve_type),
                BuildInput::Instances(_) => PrimitiveTypeFlags::NONE,
            };
        }
        f.motion.geometry = options.motion.is_some_and(|m| m.num_keys >= 2);
        f
    }

    /// The features of an instance structure or transform over children with `children`
    /// features. `motion` adds the kind of a motion transform.
    pub fn of_parent(
        children: &[SceneFeatures],
        motion: MotionKinds,
        is_static_transform: bool,
    ) -> SceneFeatures {
        let mut f = SceneFeatures {
            depth: 1,
            ..SceneFeatures::default()
        };
        let mut all_gas = true;
        for c in children {
            f.primitive_types |= c.primitive_types;
            f.motion = f.motion.union(c.motion);
            f.opacity_micromaps |= c.opacity_micromaps;
            f.static_transforms |= c.static_transforms;
            f.depth = f.depth.max(c.depth + 1);
            all_gas &= c.depth == 0;
        }
        f.motion = f.motion.union(motion);
        f.static_transforms |= is_static_transform;
        let is_transform = motion.any() || is_static_transform;
        f.graph = if all_gas && !is_transform {
            TraversableGraph::SingleLevelInstancing
        } else {
            TraversableGraph::Any
        };
        f
    }

    /// The union of two scenes (a pipeline serves every structure alive at its creation).
    pub fn union(self, o: SceneFeatures) -> SceneFeatures {
        SceneFeatures {
            primitive_types: self.primitive_types | o.primitive_types,
            motion: self.motion.union(o.motion),
            graph: self.graph.max(o.graph),
            depth: self.depth.max(o.depth),
            opacity_micromaps: self.opacity_micromaps || o.opacity_micromaps,
            static_transforms: self.static_transforms || o.static_transforms,
        }
    }
}

/// The primitive-type flag of a curve type.
pub fn curve_flag(t: CurveType) -> PrimitiveTypeFlags {
    match t {
        CurveType::RoundLinear => PrimitiveTypeFlags::ROUND_LINEAR,
        CurveType::RoundQuadraticBSpline => PrimitiveTypeFlags::ROUND_QUADRATIC_BSPLINE,
        CurveType::RoundCubicBSpline => PrimitiveTypeFlags::ROUND_CUBIC_BSPLINE,
        CurveType::RoundCatmullRom => PrimitiveTypeFlags::ROUND_CATMULLROM,
    }
}

/// What a pipeline's program groups use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct ProgramFeatures {
    /// Some hit group has an any-hit program.
    pub any_hit: bool,
    /// Some hit group has an intersection program.
    pub intersection: bool,
    /// Some hit group has a closest-hit program.
    pub closest_hit: bool,
    /// Some miss group has a program.
    pub miss: bool,
    /// Some group has a direct callable.
    pub direct_callables: bool,
    /// Some group has a continuation callable.
    pub continuation_callables: bool,
    /// Some group is an exception program.
    pub exception_program: bool,
    /// Some program calls `rt_throw_exception`.
    pub throws: bool,
    /// Some program reads `rt_ray_time`.
    pub reads_time: bool,
    /// Some program traces rays (raygen always may).
    pub traces_from_hits: bool,
    /// Built-in intersectors the hit groups name.
    pub builtin_types: PrimitiveTypeFlags,
    /// Payload registers the programs touch.
    pub payload_values_used: u32,
    /// Attribute registers the programs touch.
    pub attribute_values_used: u32,
}

/// The features a pipeline is compiled with: `pipeline.features()` (DESIGN.md §6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FeatureSet {
    /// Primitive types intersected; others are skipped (with an exception under `DEBUG`).
    pub primitive_types: PrimitiveTypeFlags,
    /// Motion interpolation compiled in; without it `rt_ray_time` is 0 and keys 0 are used.
    pub motion: bool,
    /// Which kinds of motion the code handles.
    pub motion_kinds: MotionKinds,
    /// Graph shape handled: without instancing no transform code is compiled.
    pub traversable_graph: TraversableGraph,
    /// Any-hit calls compiled in.
    pub any_hit: bool,
    /// Intersection program calls compiled in.
    pub intersection: bool,
    /// Direct callables compiled in.
    pub direct_callables: bool,
    /// Continuation callables compiled in.
    pub continuation_callables: bool,
    /// Exception checks compiled in.
    pub exceptions: ExceptionFlags,
    /// Opacity micromap lookups compiled in.
    pub opacity_micromaps: bool,
    /// The pipeline's `max_trace_depth`.
    pub max_trace_depth: u32,
    /// Payload registers.
    pub num_payload_values: u32,
    /// Attribute registers.
    pub num_attribute_values: u32,
    /// Some triangles are intersected by the device's own triangle test rather than optik's
    /// (a backend's report, not a request): Vulkan under `TriangleTest::Driver`, or under
    /// the default where the driver passed optik's check of its triangle test
    /// (docs/vulkan-backend.md §2.4). Resolving features leaves it false.
    pub driver_triangles: bool,
}

impl FeatureSet {
    /// Every feature (what an unspecialised pipeline compiles).
    pub fn everything(max_trace_depth: u32) -> FeatureSet {
        FeatureSet {
            primitive_types: PrimitiveTypeFlags::ALL,
            motion: true,
            motion_kinds: MotionKinds {
                geometry: true,
                matrix: true,
                srt: true,
            },
            traversable_graph: TraversableGraph::Any,
            any_hit: true,
            intersection: true,
            direct_callables: true,
            continuation_callables: true,
            exceptions: ExceptionFlags::ALL,
            opacity_micromaps: true,
            max_trace_depth,
            num_payload_values: crate::MAX_PAYLOAD_VALUES,
            num_attribute_values: crate::MAX_ATTRIBUTE_VALUES,
            driver_triangles: false,
        }
    }

    /// These features less what `scene` cannot call for: the graph shape, primitive types,
    /// kinds of motion and opacity micromaps no live structure has. A trace can only reach
    /// live structures (a handle to a destroyed one is refused before its kind is read), so
    /// code for the rest would never run; backends that compile per launch compile only this
    /// (docs/wgpu-backend.md §3, "Kernel variants"). What programs see is unchanged: ray
    /// time, payload, attributes, exceptions and program calls are not narrowed, and a
    /// narrowing that would leave no primitive type keeps the pipeline's.
    pub fn narrowed_to(&self, scene: &SceneFeatures) -> FeatureSet {
        let mut f = *self;
        f.traversable_graph = self.traversable_graph.min(scene.graph);
        let types = PrimitiveTypeFlags(self.primitive_types.0 & scene.primitive_types.0);
        if !types.is_empty() {
            f.primitive_types = types;
        }
        f.motion_kinds = MotionKinds {
            geometry: self.motion_kinds.geometry && scene.motion.geometry,
            matrix: self.motion_kinds.matrix && scene.motion.matrix,
            srt: self.motion_kinds.srt && scene.motion.srt,
        };
        f.opacity_micromaps = self.opacity_micromaps && scene.opacity_micromaps;
        f
    }

    /// Whether instances or transforms are traversed.
    pub fn instancing(&self) -> bool {
        self.traversable_graph != TraversableGraph::SingleGas
    }

    /// The features as short names, for reports (`triangles spheres motion any-hit ...`).
    pub fn names(&self) -> Vec<String> {
        let mut v: Vec<String> = Vec::new();
        for (flag, name) in [
            (PrimitiveTypeFlags::TRIANGLE, "triangles"),
            (PrimitiveTypeFlags::CUSTOM, "custom"),
            (PrimitiveTypeFlags::SPHERE, "spheres"),
            (PrimitiveTypeFlags::ROUND_LINEAR, "linear-curves"),
            (
                PrimitiveTypeFlags::ROUND_QUADRATIC_BSPLINE,
                "quadratic-curves",
            ),
            (PrimitiveTypeFlags::ROUND_CUBIC_BSPLINE, "cubic-curves"),
            (PrimitiveTypeFlags::ROUND_CATMULLROM, "catmull-rom-curves"),
        ] {
            if self.primitive_types.contains(flag) {
                v.push(name.into());
            }
        }
        if self.motion {
            v.push("motion".into());
        }
        v.push(
            match self.traversable_graph {
                TraversableGraph::SingleGas => "single-gas",
                TraversableGraph::SingleLevelInstancing => "single-level-instancing",
                TraversableGraph::Any => "any-graph",
            }
            .into(),
        );
        for (on, name) in [
            (self.any_hit, "any-hit"),
            (self.intersection, "intersection"),
            (self.direct_callables, "direct-callables"),
            (self.continuation_callables, "continuation-callables"),
            (self.opacity_micromaps, "opacity-micromaps"),
            (self.driver_triangles, "driver-triangles"),
        ] {
            if on {
                v.push(name.into());
            }
        }
        if !self.exceptions.is_empty() {
            v.push(format!("exceptions{:?}", self.exceptions).replace("ExceptionFlags", ""));
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn instance_graphs() {
        let gas = SceneFeatures {
            primitive_types: PrimitiveTypeFlags::SPHERE,
            ..Default::default()
        };
        let ias = SceneFeatures::of_parent(&[gas], MotionKinds::default(), false);
        assert_eq!(ias.graph, TraversableGraph::SingleLevelInstancing);
        assert_eq!(ias.depth, 1);
        let srt = SceneFeatures::of_parent(
            &[gas],
            MotionKinds {
                srt: true,
                ..Default::default()
            },
            false,
        );
        assert_eq!(srt.graph, TraversableGraph::Any);
        let top = SceneFeatures::of_parent(&[ias, srt], MotionKinds::default(), false);
        assert_eq!(top.graph, TraversableGraph::Any);
        assert_eq!(top.depth, 2);
        assert!(top.motion.srt);
    }

    #[test]
    fn narrowing_keeps_only_what_the_scene_has_and_what_programs_see() {
        let all = FeatureSet::everything(2);
        let flat = SceneFeatures {
            primitive_types: PrimitiveTypeFlags::TRIANGLE,
            ..Default::default()
        };
        let f = all.narrowed_to(&flat);
        assert_eq!(f.traversable_graph, TraversableGraph::SingleGas);
        assert_eq!(f.primitive_types, PrimitiveTypeFlags::TRIANGLE);
        assert_eq!(f.motion_kinds, MotionKinds::default());
        assert!(!f.opacity_micromaps);
        // What programs see stays: ray time, registers, exceptions, program calls.
        assert!(f.motion && f.any_hit && f.intersection && f.direct_callables);
        assert_eq!(f.exceptions, ExceptionFlags::ALL);
        assert_eq!((f.num_payload_values, f.num_attribute_values), (32, 8));
        // Never wider than the pipeline: a single-GAS triangle pipeline over a scene of
        // instanced spheres keeps its own features (its kernel misses them, as before).
        let single = f;
        let spheres = SceneFeatures::of_parent(
            &[SceneFeatures {
                primitive_types: PrimitiveTypeFlags::SPHERE,
                motion: MotionKinds {
                    geometry: true,
                    ..Default::default()
                },
                ..Default::default()
            }],
            MotionKinds::default(),
            false,
        );
        assert_eq!(single.narrowed_to(&spheres), single);
        let f = all.narrowed_to(&spheres);
        assert_eq!(f.traversable_graph, TraversableGraph::SingleLevelInstancing);
        assert_eq!(f.primitive_types, PrimitiveTypeFlags::SPHERE);
        assert!(f.motion_kinds.geometry && !f.motion_kinds.srt);
    }
}
