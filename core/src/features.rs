//! Feature resolution (DESIGN.md §6): what a pipeline's programs use, and the
//! [`FeatureSet`] a pipeline is compiled with, from its options, its scene and its programs.
//! The feature types live in `optik_api::features`; every backend resolves through here.

use crate::frontend::{CompiledModule, DeviceFunction};
use optik_api::features::{FeatureSet, MotionKinds, ProgramFeatures, SceneFeatures, curve_flag};
use optik_api::{
    BuiltinIntersector, Error, ExceptionFlags, MAX_ATTRIBUTE_VALUES, MAX_PAYLOAD_VALUES,
    PipelineCompileOptions, PipelineLinkOptions, PrimitiveTypeFlags, ProgramGroupDesc, ProgramKind,
    ProgramRef, Result, Setting, TraversableGraph,
};

/// Collects the features of program `groups`; `module_of` finds the compiled module of a program.
pub fn program_features<'a>(
    groups: &[&ProgramGroupDesc],
    module_of: impl Fn(&ProgramRef) -> Option<&'a CompiledModule>,
) -> ProgramFeatures {
    let mut f = ProgramFeatures::default();
    for g in groups {
        if let ProgramGroupDesc::HitGroup {
            builtin,
            intersection: None,
            ..
        } = g
        {
            f.builtin_types |= match builtin {
                BuiltinIntersector::Triangle => PrimitiveTypeFlags::TRIANGLE,
                BuiltinIntersector::Sphere => PrimitiveTypeFlags::SPHERE,
                BuiltinIntersector::Curve(t) => curve_flag(*t),
            };
        }
        for (kind, program) in g.programs() {
            match kind {
                ProgramKind::AnyHit => f.any_hit = true,
                ProgramKind::Intersection => f.intersection = true,
                ProgramKind::ClosestHit => f.closest_hit = true,
                ProgramKind::Miss => f.miss = true,
                ProgramKind::DirectCallable => f.direct_callables = true,
                ProgramKind::ContinuationCallable => f.continuation_callables = true,
                ProgramKind::Exception => f.exception_program = true,
                ProgramKind::Raygen => {}
            }
            let Some(module) = module_of(program) else {
                continue;
            };
            f.payload_values_used = f.payload_values_used.max(module.payload_values_used);
            f.attribute_values_used = f.attribute_values_used.max(module.attribute_values_used);
            if let Some(p) = module.program(&program.entry) {
                f.throws |= p.calls(DeviceFunction::ThrowException);
                f.reads_time |= p.calls(DeviceFunction::RayTime);
                f.traces_from_hits |= kind != ProgramKind::Raygen
                    && (p.calls(DeviceFunction::Trace)
                        || p.calls(DeviceFunction::ContinuationCall));
            }
        }
    }
    f
}

/// Resolves a pipeline's features from its options, the scene alive at its creation
/// (`None` when no acceleration structure exists) and its programs.
pub fn resolve(
    options: &PipelineCompileOptions,
    link: &PipelineLinkOptions,
    scene: Option<SceneFeatures>,
    programs: &ProgramFeatures,
    max_trace_depth_limit: u32,
) -> Result<FeatureSet> {
    if link.max_trace_depth > max_trace_depth_limit {
        return Err(Error::limit(format!(
            "link_options.max_trace_depth is {}; this device allows at most {max_trace_depth_limit}",
            link.max_trace_depth
        )));
    }
    let scene_types = scene
        .map(|s| s.primitive_types)
        .unwrap_or(PrimitiveTypeFlags::NONE);
    let mut auto_types = scene_types | programs.builtin_types;
    if programs.intersection {
        auto_types |= PrimitiveTypeFlags::CUSTOM;
    }
    if auto_types.is_empty() {
        // OptiX's default (0): triangles and custom primitives.
        auto_types = PrimitiveTypeFlags::TRIANGLE | PrimitiveTypeFlags::CUSTOM;
    }
    let primitive_types = options.primitive_types.or(auto_types);
    let missing = PrimitiveTypeFlags(
        programs.builtin_types.0 & !primitive_types.0 & !PrimitiveTypeFlags::TRIANGLE.0,
    );
    if !missing.is_empty() {
        return Err(Error::invalid(format!(
            "pipeline_options.primitive_types is {primitive_types:?}, but a hit group uses the built-in intersector of {missing:?}; add it to primitive_types or leave it Auto"
        )));
    }
    let scene_motion = scene.map(|s| s.motion).unwrap_or_default();
    let motion = options.uses_motion_blur.or(scene_motion.any());
    let graph = options
        .traversable_graph
        .or(scene.map(|s| s.graph).unwrap_or(TraversableGraph::Any));
    let max_payload = MAX_PAYLOAD_VALUES;
    let num_payload_values = options.num_payload_values.or(programs.payload_values_used);
    if num_payload_values > max_payload {
        return Err(Error::limit(format!(
            "pipeline_options.num_payload_values is {num_payload_values}; at most {max_payload} payload registers exist"
        )));
    }
    if num_payload_values < programs.payload_values_used
        && programs.payload_values_used < max_payload
    {
        return Err(Error::invalid(format!(
            "pipeline_options.num_payload_values is {num_payload_values}, but the programs use payload register {}; raise it to at least {} or leave it Auto",
            programs.payload_values_used - 1,
            programs.payload_values_used
        )));
    }
    let num_attribute_values = options
        .num_attribute_values
        .or(programs.attribute_values_used)
        .max(2);
    if num_attribute_values > MAX_ATTRIBUTE_VALUES {
        return Err(Error::limit(format!(
            "pipeline_options.num_attribute_values is {num_attribute_values}; at most {MAX_ATTRIBUTE_VALUES} attribute registers exist"
        )));
    }
    let auto_exceptions = if programs.exception_program {
        ExceptionFlags::STACK_OVERFLOW | ExceptionFlags::TRACE_DEPTH | ExceptionFlags::USER
    } else if programs.throws {
        ExceptionFlags::USER
    } else {
        ExceptionFlags::NONE
    };
    let exceptions = options.exception_flags.or(auto_exceptions);
    if exceptions.unknown_bits() != 0 {
        return Err(Error::invalid(format!(
            "pipeline_options.exception_flags has unknown bits {:#x}",
            exceptions.unknown_bits()
        )));
    }
    let opacity_micromaps = options
        .allow_opacity_micromaps
        .or(scene.is_some_and(|s| s.opacity_micromaps));
    let motion_kinds = if motion {
        match options.uses_motion_blur {
            Setting::Value(true) if !scene_motion.any() => MotionKinds {
                geometry: true,
                matrix: true,
                srt: true,
            },
            _ => scene_motion,
        }
    } else {
        MotionKinds::default()
    };
    Ok(FeatureSet {
        primitive_types,
        motion,
        motion_kinds,
        traversable_graph: graph,
        any_hit: programs.any_hit,
        intersection: programs.intersection && primitive_types.contains(PrimitiveTypeFlags::CUSTOM),
        direct_callables: programs.direct_callables,
        continuation_callables: programs.continuation_callables,
        exceptions,
        opacity_micromaps,
        max_trace_depth: link.max_trace_depth,
        num_payload_values,
        num_attribute_values,
        driver_triangles: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_follows_scene_and_programs() {
        let scene = SceneFeatures {
            primitive_types: PrimitiveTypeFlags::TRIANGLE,
            ..Default::default()
        };
        let programs = ProgramFeatures {
            closest_hit: true,
            payload_values_used: 3,
            ..Default::default()
        };
        let f = resolve(
            &PipelineCompileOptions::default(),
            &PipelineLinkOptions::default(),
            Some(scene),
            &programs,
            31,
        )
        .unwrap();
        assert_eq!(f.primitive_types, PrimitiveTypeFlags::TRIANGLE);
        assert!(!f.motion && !f.any_hit && !f.intersection && !f.instancing());
        assert_eq!(f.num_payload_values, 3);
        assert_eq!(f.num_attribute_values, 2);
        assert_eq!(f.exceptions, ExceptionFlags::NONE);
        assert_eq!(f.names(), vec!["triangles", "single-gas"]);
    }

    #[test]
    fn explicit_settings_are_checked() {
        let programs = ProgramFeatures {
            builtin_types: PrimitiveTypeFlags::SPHERE,
            payload_values_used: 5,
            ..Default::default()
        };
        let opts = PipelineCompileOptions {
            primitive_types: Setting::Value(PrimitiveTypeFlags::TRIANGLE),
            ..Default::default()
        };
        let e = resolve(&opts, &PipelineLinkOptions::default(), None, &programs, 31).unwrap_err();
        assert!(e.message().contains("built-in intersector"), "{e}");
        let opts = PipelineCompileOptions {
            num_payload_values: Setting::Value(2),
            ..Default::default()
        };
        let e = resolve(&opts, &PipelineLinkOptions::default(), None, &programs, 31).unwrap_err();
        assert!(e.message().contains("payload register 4"), "{e}");
        let link = PipelineLinkOptions {
            max_trace_depth: 40,
            ..Default::default()
        };
        let e = resolve(
            &PipelineCompileOptions::default(),
            &link,
            None,
            &programs,
            31,
        )
        .unwrap_err();
        assert!(e.message().contains("max_trace_depth is 40"), "{e}");
    }
}
