//! DESIGN.md §6: the kernel holds only what the pipeline uses, and reports it.

use crate::common::*;
use optik_api::*;
use optik_wgpu::WgpuDeviceExt;

/// Names that only the code of one feature defines.
const SPHERES: &str = "_optik_sphere_roots(";
const CURVES: &str = "_optik_curve_intersect(";
const MOTION: &str = "_optik_motion_key(";
const INSTANCES: &str = "_OptikXform";
const TRANSFORMS: &str = "_optik_through_transforms(";
const ANY_HIT: &str = "fn _optik_ah(";
const INTERSECTION: &str = "fn _optik_is(";
const EXCEPTIONS: &str = "_optik_raise(";
const MICROMAPS: &str = "_optik_micromap_state(";
/// A saved copy of the walk's levels, and the one function that builds every level of an
/// instancing walk instead (docs/wgpu-backend.md §12.5).
const SAVED_LEVELS: &str = "var levels: array<_OptikLevel";
const LEVEL_BUILDER: &str = "fn _optik_level_at(";

/// Checks that an instancing kernel builds its levels with `_optik_level_at` and saves none,
/// and that the node loop (from its first pop to its end) neither builds a level nor handles
/// a marker: both happen with the leaves, out of the loop where the node test's registers
/// peak.
fn assert_levels_built_outside_the_node_loop(src: &str) {
    assert!(src.contains(LEVEL_BUILDER) && !src.contains(SAVED_LEVELS));
    let walk = &src[src.find("fn _optik_traverse(").expect("the walk")..];
    let start = walk.find("e = stack[sp];").expect("the node loop's pop");
    let end = start
        + walk[start..]
            .find("if !leaf {")
            .expect("the node loop's end");
    let node_loop = &walk[start..end];
    assert!(
        !node_loop.contains("_optik_level_at(") && !node_loop.contains("tag == 3u"),
        "the node loop builds levels: {node_loop}"
    );
    assert!(walk[end..].contains("_optik_level_at(&lv, lvl)"));
}

#[test]
fn a_triangle_only_single_gas_pipeline_has_nothing_else() {
    let dev = optik_wgpu::WgpuBackend::new()
        .map(optik_wgpu::WgpuDevice::new)
        .unwrap();
    let d: &dyn Device = &dev;
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let m = module(d, RAY_LIST);
    let g = ray_list_groups(d, m, 1, &[]);
    let p = pipeline(d, &g, 1);
    let f = d.pipeline_features(p).unwrap();
    assert_eq!(f.primitive_types, PrimitiveTypeFlags::TRIANGLE);
    assert_eq!(f.traversable_graph, TraversableGraph::SingleGas);
    assert!(!f.motion && !f.any_hit && !f.intersection && !f.opacity_micromaps);
    assert!(f.exceptions.is_empty());
    let src = dev.kernel_source(p).unwrap();
    for absent in [
        SPHERES,
        CURVES,
        MOTION,
        INSTANCES,
        TRANSFORMS,
        LEVEL_BUILDER,
        ANY_HIT,
        INTERSECTION,
        EXCEPTIONS,
        MICROMAPS,
    ] {
        assert!(
            !src.contains(absent),
            "`{absent}` in a triangle-only single-GAS kernel"
        );
    }
    assert!(src.contains("_optik_tri_watertight("));
    // And it still traces.
    let table = numbered_sbt(d, &g);
    let h = d.traversable_handle(gas).unwrap();
    assert!(
        trace_rays(
            d,
            p,
            &table,
            h,
            &[Ray::new([0.5, 0.5, 1.0], [0.0, 0.0, -1.0])],
            TraceArgs::default()
        )[0]
        .hit()
    );
}

#[test]
fn forcing_every_feature_compiles_every_part() {
    let dev = optik_wgpu::WgpuBackend::new()
        .map(optik_wgpu::WgpuDevice::new)
        .unwrap();
    let d: &dyn Device = &dev;
    let src = format!(
        "{RAY_LIST}\nfn anyhit__a() {{ }}\nfn intersection__i() {{ var a: RtAttributes; _ = rt_report_intersection(1.0, 0u, a); }}\n"
    );
    let m = module(d, &src);
    let g = ray_list_groups(
        d,
        m,
        1,
        &[ProgramGroupDesc::HitGroup {
            closest_hit: None,
            any_hit: Some(ProgramRef::new(m, "anyhit__a")),
            intersection: Some(ProgramRef::new(m, "intersection__i")),
            builtin: BuiltinIntersector::Triangle,
        }],
    );
    let options = PipelineCompileOptions {
        uses_motion_blur: Setting::Value(true),
        traversable_graph: Setting::Value(TraversableGraph::Any),
        primitive_types: Setting::Value(PrimitiveTypeFlags::ALL),
        exception_flags: Setting::Value(ExceptionFlags::ALL),
        allow_opacity_micromaps: Setting::Value(true),
        ..Default::default()
    };
    let p = d
        .create_pipeline(&options, &PipelineLinkOptions::default(), &g.all())
        .unwrap_or_else(|e| panic!("{e}"));
    let f = d.pipeline_features(p).unwrap();
    assert!(f.motion && f.any_hit && f.intersection && f.opacity_micromaps && f.instancing());
    let kernel = dev.kernel_source(p).unwrap();
    // Every name the kernel adds has the internal prefix the front end refuses in user names;
    // the user's own names come back with their module's prefix `m<i>_` (or `m<i>q<k>_`).
    let module_prefixed = |n: &str| {
        n.strip_prefix('m').is_some_and(|rest| {
            let (head, _) = rest.split_once('_').unwrap_or((rest, ""));
            let mut parts = head.splitn(2, 'q');
            let digits = |p: &str| !p.is_empty() && p.chars().all(|c| c.is_ascii_digit());
            parts.next().is_some_and(digits) && parts.next().is_none_or(digits)
        })
    };
    let unprefixed: Vec<String> = optik_core::frontend::unprefixed_internal_names(&kernel, &src)
        .into_iter()
        .filter(|n| !module_prefixed(n))
        .collect();
    assert_eq!(unprefixed, Vec::<String>::new());
    let src = kernel;
    for present in [
        SPHERES,
        CURVES,
        MOTION,
        INSTANCES,
        TRANSFORMS,
        ANY_HIT,
        INTERSECTION,
        EXCEPTIONS,
        MICROMAPS,
    ] {
        assert!(
            src.contains(present),
            "`{present}` missing from an all-features kernel"
        );
    }
    assert_levels_built_outside_the_node_loop(&src);
}

#[test]
fn accuracy_selects_the_tests_compiled() {
    let dev = optik_wgpu::WgpuBackend::new()
        .map(optik_wgpu::WgpuDevice::new)
        .unwrap();
    let d: &dyn Device = &dev;
    triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    d.set_accuracy(Accuracy::FAST).unwrap();
    let m = module(d, RAY_LIST);
    let g = ray_list_groups(d, m, 1, &[]);
    let p = pipeline(d, &g, 1);
    let src = dev.kernel_source(p).unwrap();
    assert!(src.contains("_optik_tri_moller_trumbore(") && !src.contains("_optik_tri_watertight("));
    assert!(
        !src.contains("_OPTIK_SLAB_WIDEN;"),
        "plain slabs are not widened"
    );
    d.set_accuracy(Accuracy::ROBUST).unwrap();
    let p = pipeline(d, &g, 1);
    let src = dev.kernel_source(p).unwrap();
    assert!(src.contains("_optik_tri_watertight(") && src.contains("far_x * _OPTIK_SLAB_WIDEN"));
    // The driver's triangle test is the Vulkan backend's.
    let driver = Accuracy {
        triangle: TriangleTest::Driver,
        ..Accuracy::ROBUST
    };
    let e = d.set_accuracy(driver).unwrap_err();
    assert_eq!(e.kind(), optik_api::ErrorKind::Unsupported);
    assert!(e.message().contains("TriangleTest::Driver"), "{e}");
    assert_eq!(d.accuracy(), Accuracy::ROBUST);
}

/// A trace whose flags always include DISABLE_CLOSESTHIT (a shadow ray) calls a trace without
/// the closest-hit dispatch, which drivers would otherwise inline once more at that call site;
/// a trace with other flags keeps it, and both behave as the flags say.
#[test]
fn a_shadow_ray_call_site_traces_without_the_closest_hit_dispatch() {
    let dev = optik_wgpu::WgpuBackend::new()
        .map(optik_wgpu::WgpuDevice::new)
        .unwrap();
    let d: &dyn Device = &dev;
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let src = format!(
        "{HEADER}
fn shoot(flags: u32, x: f32) -> u32 {{
    var p: RtPayload;
    rt_trace(params.handle, vec3<f32>(x, 0.5, 1.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.0,
        0xFFu, flags, 0u, 1u, 0u, &p);
    return p[0];
}}
fn raygen__main() {{
    let i = rt_launch_index().x;
    let x = select(0.5, 5.0, i == 1u);
    var p: RtPayload;
    // The shadow ray: the closest-hit bit is set whatever params.a holds.
    rt_trace(params.handle, vec3<f32>(x, 0.5, 1.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.0,
        0xFFu, RT_RAY_FLAG_DISABLE_CLOSESTHIT | RT_RAY_FLAG_TERMINATE_ON_FIRST_HIT | params.a,
        0u, 1u, 0u, &p);
    out[2u * i] = p[0];
    // Flags only known at run time: the full trace.
    out[2u * i + 1u] = shoot(params.b, x);
}}
fn miss__m() {{ rt_set_payload(0u, 1u); }}
fn closesthit__c() {{ rt_set_payload(0u, 2u); }}
"
    );
    let m = module(d, &src);
    let g = groups(
        d,
        &[
            raygen(m, "raygen__main"),
            miss(m, "miss__m"),
            closest_hit(m, "closesthit__c"),
        ],
    );
    let p = pipeline(d, &g, 1);
    let kernel = dev.kernel_source(p).unwrap();
    assert_eq!(
        kernel.matches("_optik_trace_0_nch_fn(").count(),
        2,
        "one definition, one call"
    );
    assert_eq!(
        kernel.matches("_optik_trace_0_fn(").count(),
        2,
        "one definition, one call"
    );
    let nch = &kernel[kernel.find("fn _optik_trace_0_nch_fn(").unwrap()..];
    let nch = &nch[..nch.find("\n}\n").unwrap()];
    assert!(!nch.contains("_optik_closest_hit_"), "{nch}");
    let table = sbt(d, &g, &[]);
    let h = d.traversable_handle(gas).unwrap();
    let out = run(d, p, &table, &params(h, &[0, 0]), 2, 1, 4);
    // Ray 0 hits: the shadow ray runs no closest-hit (payload untouched), the other one does;
    // ray 1 misses both times.
    assert_eq!(out, vec![0, 2, 1, 1]);
}

#[test]
fn kernels_are_written_to_the_kernel_folder() {
    let dir = std::env::temp_dir().join(format!("optik-kernels-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // A device writing its kernels to `folder`, and the ray-list program groups.
    let device_writing_to = |folder: &std::path::Path| {
        let dev = optik_wgpu::WgpuBackend::with_options(optik_wgpu::WgpuOptions {
            kernel_dir: Some(folder.to_path_buf()),
            ..Default::default()
        })
        .map(optik_wgpu::WgpuDevice::new)
        .unwrap();
        let m = module(&dev, RAY_LIST);
        let g = ray_list_groups(&dev, m, 1, &[]);
        (dev, g)
    };
    let (dev, g) = device_writing_to(&dir);
    let d: &dyn Device = &dev;
    let p = pipeline(d, &g, 1);
    let src = dev.kernel_source(p).unwrap();
    let written: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(written.len(), 1, "{written:?}");
    let name = written[0]
        .file_name()
        .unwrap()
        .to_string_lossy()
        .into_owned();
    assert!(
        name.starts_with("kernel-") && name.ends_with(".wgsl"),
        "{name}"
    );
    assert_eq!(std::fs::read_to_string(&written[0]).unwrap(), src);

    // A folder that cannot be written fails the compile (at create_pipeline), naming it.
    let file = dir.join("not-a-folder");
    std::fs::write(&file, b"").unwrap();
    let (dev, g) = device_writing_to(&file);
    let e = dev
        .create_pipeline(
            &PipelineCompileOptions::default(),
            &PipelineLinkOptions {
                max_trace_depth: 1,
                ..Default::default()
            },
            &g.all(),
        )
        .unwrap_err();
    assert!(
        e.message().contains("kernel_dir") && e.message().contains("not-a-folder"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A pipeline forced to any graph, every primitive type and opacity micromaps traces a lone
/// triangle GAS with the kernel an `Auto` pipeline gets (FeatureSet::narrowed_to), and
/// compiles the general kernel once an instance exists, which it then traces.
#[test]
fn features_no_live_structure_has_are_left_out_of_the_launchs_kernel() {
    let dev = optik_wgpu::WgpuBackend::new()
        .map(optik_wgpu::WgpuDevice::new)
        .unwrap();
    let d: &dyn Device = &dev;
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let m = module(d, RAY_LIST);
    let g = ray_list_groups(d, m, 1, &[]);
    let auto = pipeline(d, &g, 1);
    let general = d
        .create_pipeline(
            &PipelineCompileOptions {
                traversable_graph: Setting::Value(TraversableGraph::Any),
                primitive_types: Setting::Value(PrimitiveTypeFlags::ALL),
                allow_opacity_micromaps: Setting::Value(true),
                ..Default::default()
            },
            &PipelineLinkOptions::default(),
            &g.all(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
    // The pipeline keeps what it was asked for; its kernel for this scene does not.
    let f = d.pipeline_features(general).unwrap();
    assert_eq!(f.traversable_graph, TraversableGraph::Any);
    assert_eq!(f.primitive_types, PrimitiveTypeFlags::ALL);
    let narrowed = dev.kernel_source(general).unwrap();
    assert_eq!(narrowed, dev.kernel_source(auto).unwrap());
    for absent in [SPHERES, CURVES, INSTANCES, TRANSFORMS, MICROMAPS] {
        assert!(
            !narrowed.contains(absent),
            "`{absent}` in the narrowed kernel"
        );
    }
    // A translated instance appears: the next kernel has instances (one level, so still no
    // transform chain).
    let top = one_instance(
        d,
        d.traversable_handle(gas).unwrap(),
        [1.0, 0.0, 0.0, 2.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
    );
    let general_kernel = dev.kernel_source(general).unwrap();
    assert!(general_kernel.contains(INSTANCES));
    assert!(!general_kernel.contains(TRANSFORMS) && !general_kernel.contains(SPHERES));
    assert_levels_built_outside_the_node_loop(&general_kernel);
    let table = numbered_sbt(d, &g);
    let recs = trace_rays(
        d,
        general,
        &table,
        top,
        &[
            Ray::new([2.5, 0.5, 1.0], [0.0, 0.0, -1.0]),
            Ray::new([0.5, 0.5, 1.0], [0.0, 0.0, -1.0]),
        ],
        TraceArgs::default(),
    );
    assert!(recs[0].hit() && recs[1].missed());
    // The GAS alone is still traced by the same pipeline, now with the general kernel.
    let recs = trace_rays(
        d,
        general,
        &table,
        d.traversable_handle(gas).unwrap(),
        &[Ray::new([0.5, 0.5, 1.0], [0.0, 0.0, -1.0])],
        TraceArgs::default(),
    );
    assert!(recs[0].hit());
}
