//! Lowering tests: every stage kind and device function, under the smallest and the largest
//! configurations, gives SPIR-V that `spirv-val` accepts.

use super::*;
use optik_api::{ExceptionFlags, ProgramKind, ProgramSource};

/// Runs a SPIRV-Tools program (`spirv-val`, `spirv-dis`) on `words` written to a temporary
/// file named after `what`; its output.
pub(crate) fn spirv_tool(
    tool: &str,
    args: &[&str],
    words: &[u32],
    what: &str,
) -> std::process::Output {
    // Straight in the temporary folder (the file is removed below; a folder of our own
    // would be left behind).
    let path = std::env::temp_dir().join(format!(
        "optik-spirv-{}-{tool}-{}.spv",
        std::process::id(),
        what.replace(['/', ' ', '.', ':'], "_")
    ));
    std::fs::write(
        &path,
        words
            .iter()
            .flat_map(|w| w.to_le_bytes())
            .collect::<Vec<u8>>(),
    )
    .unwrap();
    let out = std::process::Command::new(tool).args(args).arg(&path).output().unwrap_or_else(|e| {
        panic!("{tool} is needed by the Vulkan backend's tests (Debian: apt install spirv-tools; scripts/setup installs it): {e}")
    });
    let _ = std::fs::remove_file(&path);
    out
}

/// Runs `spirv-val` (Vulkan 1.2 rules) on `words`; panics with its report and the
/// disassembly on failure.
pub(crate) fn spirv_val(words: &[u32], what: &str) {
    let out = spirv_tool("spirv-val", &["--target-env", "vulkan1.2"], words, what);
    if !out.status.success() {
        let dis =
            String::from_utf8_lossy(&spirv_tool("spirv-dis", &[], words, what).stdout).into_owned();
        panic!(
            "spirv-val rejects {what}:\n{}{}\n{dis}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

/// A module with one program of every kind, each calling every device function its kind
/// allows.
pub(crate) const EVERYTHING: &str = r#"
struct Params { handle: vec2<u32>, pad: vec2<u32> }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn helper_trace(p: ptr<function, RtPayload>) -> u32 {
    rt_trace(params.handle, vec3<f32>(0.0), vec3<f32>(0.0, 0.0, 1.0), 0.0, 1e30, 0.5, 0xFFu, 0u, 1u, 2u, 3u, p);
    return (*p)[0];
}

fn raygen__main() {
    let i = rt_launch_index();
    let d = rt_launch_dimensions();
    var p: RtPayload;
    let r = helper_trace(&p);
    rt_direct_call(0u, &p);
    rt_continuation_call(1u, &p);
    if r == 7u {
        rt_throw_exception(5u);
    }
    out[i.x + d.x] = p[0] + rt_sbt_data_u32(0u) + u32(rt_sbt_data_f32(1u)) + rt_remaining_trace_depth();
    let o = rt_offset_ray(vec3<f32>(1.0), vec3<f32>(0.0, 1.0, 0.0));
    out[1] = u32(o.y);
}

fn closesthit__ch() {
    var p: RtPayload;
    let v = rt_triangle_vertices();
    let m = rt_object_to_world() * vec4<f32>(1.0);
    let w = rt_world_to_object() * vec4<f32>(1.0);
    let s = rt_sphere();
    let b = rt_triangle_barycentrics();
    let x = rt_world_ray_origin() + rt_world_ray_direction() + rt_object_ray_origin() + rt_object_ray_direction()
        + v[0] + m + w + s.xyz + vec3<f32>(b, rt_curve_parameter());
    let t = rt_ray_tmin() + rt_ray_tmax() + rt_ray_time() + x.x;
    let k = rt_primitive_index() + rt_sbt_gas_index() + rt_instance_id() + rt_instance_index() + rt_hit_kind()
        + rt_ray_flags() + rt_ray_mask() + rt_get_attribute(2u) + select(0u, 1u, rt_is_front_face_hit());
    rt_set_payload(0u, rt_get_payload(1u) + k + u32(t) + rt_remaining_trace_depth());
    let r = helper_trace(&p);
    rt_direct_call(2u, &p);
    rt_continuation_call(0u, &p);
    rt_set_payload(2u, r + rt_sbt_data_u32(3u));
}

fn anyhit__ah() {
    let k = rt_primitive_index() + rt_hit_kind() + rt_get_attribute(0u) + rt_instance_id() + rt_ray_flags();
    rt_set_payload(0u, k + u32(rt_ray_tmax()) + u32(rt_ray_time()));
    var p: RtPayload;
    if k == 3u {
        rt_ignore_intersection();
    }
    if k == 4u {
        rt_throw_exception(9u);
    }
    if rt_get_payload(1u) == 2u {
        rt_terminate_ray();
    }
}

fn intersection__is() {
    var a: RtAttributes;
    a[0] = rt_primitive_index();
    a[1] = bitcast<u32>(rt_object_ray_origin().x + rt_ray_time());
    a[2] = rt_ray_mask() + rt_ray_flags();
    if rt_report_intersection(rt_ray_tmin() + 1.0, 0x83u, a) {
        a[3] = 1u;
    }
    if rt_instance_index() == 2u {
        rt_throw_exception(1u);
    }
    rt_report_intersection(2.0, rt_sbt_gas_index(), a);
}

fn miss__ms() {
    var p: RtPayload;
    rt_set_payload(0u, rt_get_payload(0u) + rt_ray_mask() + u32(rt_world_ray_direction().x) + u32(rt_ray_tmax()));
    let r = helper_trace(&p);
    rt_direct_call(0u, &p);
    rt_continuation_call(0u, &p);
    rt_set_payload(3u, r);
}

fn exception__ex() {
    out[rt_launch_index().x] = u32(rt_exception_code()) + rt_sbt_data_u32(0u);
}

fn direct_callable__dc() {
    var p: RtPayload;
    rt_direct_call(1u, &p);
    rt_set_payload(0u, rt_get_payload(0u) + 1u + rt_remaining_trace_depth());
    if p[0] == 3u {
        rt_throw_exception(4u);
    }
}

fn continuation_callable__cc() {
    var p: RtPayload;
    let r = helper_trace(&p);
    rt_direct_call(0u, &p);
    rt_continuation_call(1u, &p);
    rt_set_payload(0u, rt_get_payload(0u) + r + rt_remaining_trace_depth());
}
"#;

pub(crate) fn user_roles(src: &str) -> Vec<StageRole> {
    let compiled = optik_core::frontend::compile(&ProgramSource::new("everything.wgsl", src), 4)
        .unwrap_or_else(|e| panic!("{e}"));
    let mut roles = Vec::new();
    for p in &compiled.programs {
        let contexts: Vec<Option<HitContext>> = match p.kind {
            ProgramKind::ClosestHit | ProgramKind::AnyHit => {
                vec![
                    Some(HitContext::Triangles),
                    Some(HitContext::Custom),
                    Some(HitContext::Sphere),
                    Some(HitContext::Curve),
                ]
            }
            _ => vec![None],
        };
        for context in contexts {
            roles.push(StageRole::Program {
                name: p.name.clone(),
                kind: p.kind,
                context,
            });
        }
    }
    roles
}

pub(crate) fn largest_config() -> LoweringConfig {
    LoweringConfig {
        payload_len: 4,
        max_trace_depth: 3,
        max_direct_callable_depth: 3,
        max_continuation_callable_depth: 2,
        exceptions: ExceptionFlags::ALL,
        exception_program: true,
        motion: true,
        track_depth: true,
        track_ray_flags: true,
        guard_direct_calls: true,
        continuation_calls: true,
        inline_calls: true,
        triangles: TriangleMode::Watertight { f64: true },
        mixed_triangles: false,
        skip_triangles_flag: true,
        motion_structures: true,
        micromaps: true,
        micromap_states: true,
        primitive_types: optik_api::PrimitiveTypeFlags::ALL.0,
    }
}

fn lower_and_validate(
    text: ModuleText,
    config: &LoweringConfig,
    roles: &[StageRole],
    what: &str,
) -> Vec<LoweredStage> {
    let stages = lower_stages(text, config, roles, None).unwrap_or_else(|e| panic!("{what}: {e}"));
    for s in &stages {
        spirv_val(&s.spirv, &format!("{what}-{}", s.entry_name));
    }
    stages
}

#[test]
fn every_stage_kind_and_device_function_validates_in_the_largest_configuration() {
    let roles = user_roles(EVERYTHING);
    let stages = lower_and_validate(
        ModuleText::User(EVERYTHING),
        &largest_config(),
        &roles,
        "largest",
    );
    assert_eq!(stages.len(), roles.len());
}

#[test]
fn every_stage_kind_validates_in_the_smallest_configuration() {
    let config = LoweringConfig {
        continuation_calls: true,
        ..LoweringConfig::default()
    };
    let roles = user_roles(EVERYTHING);
    lower_and_validate(ModuleText::User(EVERYTHING), &config, &roles, "smallest");
}

#[test]
fn internal_stages_validate() {
    for basis in 0..4 {
        let roles = [
            StageRole::SphereIntersection,
            StageRole::CurveIntersection(basis),
            StageRole::NullCallable,
            StageRole::NullContinuation,
        ];
        lower_and_validate(
            ModuleText::Internal { curve_basis: basis },
            &largest_config(),
            &roles,
            &format!("internal{basis}"),
        );
        lower_and_validate(
            ModuleText::Internal { curve_basis: basis },
            &LoweringConfig::default(),
            &roles,
            &format!("internal-small{basis}"),
        );
    }
}

#[test]
fn optik_stages_validate_for_every_triangle_mode_and_emulation() {
    use optik_api::PrimitiveTypeFlags as T;
    let roles = [
        StageRole::TriangleIntersection,
        StageRole::PastTableIntersection,
        StageRole::SphereIntersection,
        StageRole::CurveIntersection(2),
        StageRole::NullCallable,
    ];
    for triangles in [
        TriangleMode::Watertight { f64: true },
        TriangleMode::Watertight { f64: false },
        TriangleMode::MollerTrumbore,
    ] {
        for (motion, micromaps) in [(false, false), (true, false), (false, true), (true, true)] {
            let config = LoweringConfig {
                triangles,
                motion,
                motion_structures: motion,
                micromaps,
                micromap_states: micromaps,
                track_ray_flags: true,
                exceptions: ExceptionFlags::DEBUG,
                ..LoweringConfig::default()
            };
            let what = format!("{triangles:?}-motion{motion}-omm{micromaps}");
            lower_and_validate(
                ModuleText::Internal { curve_basis: 2 },
                &config,
                &roles,
                &what,
            );
        }
    }
    // Face-culling flags read from Vulkan's (SkipTrianglesKHR for both faces).
    let config = LoweringConfig {
        triangles: TriangleMode::Watertight { f64: false },
        skip_triangles_flag: true,
        ..LoweringConfig::default()
    };
    lower_and_validate(
        ModuleText::Internal { curve_basis: 0 },
        &config,
        &roles[..1],
        "skip-flag",
    );
    // A pipeline of custom primitives only: optik's stages skip what it does not intersect.
    let config = LoweringConfig {
        triangles: TriangleMode::MollerTrumbore,
        track_ray_flags: true,
        primitive_types: T::CUSTOM.0,
        ..LoweringConfig::default()
    };
    lower_and_validate(
        ModuleText::Internal { curve_basis: 0 },
        &config,
        &roles[..1],
        "skip",
    );
    // Native triangles under debug exceptions: the any-hit and closest-hit of records past the
    // user's.
    let config = LoweringConfig {
        exceptions: ExceptionFlags::DEBUG,
        ..LoweringConfig::default()
    };
    lower_and_validate(
        ModuleText::Internal { curve_basis: 0 },
        &config,
        &[StageRole::InvalidHitAnyHit, StageRole::InvalidHitClosestHit],
        "invalid-hit-native",
    );
}

#[test]
fn user_stages_validate_with_emulated_triangles_motion_and_micromaps() {
    let config = LoweringConfig {
        triangles: TriangleMode::MollerTrumbore,
        micromap_states: false,
        ..largest_config()
    };
    let roles = user_roles(EVERYTHING);
    lower_and_validate(ModuleText::User(EVERYTHING), &config, &roles, "emulated");
}

#[test]
fn direct_callables_inlined_into_intersection_and_any_hit_stages_validate() {
    let src = r#"
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
fn helper(x: u32) -> u32 {
    var a: RtPayload;
    a[0] = x;
    rt_direct_call(1u, &a);
    return a[0];
}
fn direct_callable__leaf() {
    rt_set_payload(0u, rt_get_payload(0u) + rt_sbt_data_u32(0u));
}
fn direct_callable__nested() {
    rt_set_payload(0u, helper(rt_get_payload(0u)) * 2u);
    if rt_get_payload(0u) == 9u {
        rt_throw_exception(3u);
    }
}
fn anyhit__ah() {
    var a: RtPayload;
    rt_direct_call(0u, &a);
    rt_set_payload(0u, a[0]);
}
fn intersection__is() {
    var a: RtPayload;
    a[0] = helper(2u);
    var attributes: RtAttributes;
    rt_report_intersection(1.0, a[0], attributes);
}
fn raygen__rg() { }
"#;
    let compiled =
        optik_core::frontend::compile(&ProgramSource::new("inline.wgsl", src), 4).unwrap();
    let callables = [
        (0, "direct_callable__leaf".to_string()),
        (1, "direct_callable__nested".to_string()),
    ];
    let roles: Vec<StageRole> = ["anyhit__ah", "intersection__is", "direct_callable__nested"]
        .iter()
        .map(|name| {
            let kind = compiled.program(name).unwrap().kind;
            StageRole::Program {
                name: name.to_string(),
                kind,
                context: (kind == ProgramKind::AnyHit).then_some(HitContext::Triangles),
            }
        })
        .collect();
    for config in [
        LoweringConfig {
            payload_len: 4,
            inline_calls: true,
            guard_direct_calls: true,
            ..LoweringConfig::default()
        },
        LoweringConfig {
            payload_len: 4,
            ..largest_config()
        },
    ] {
        let stages = lower_stages(
            ModuleText::User(src),
            &config,
            &roles,
            Some((&compiled, &callables)),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        for s in &stages {
            spirv_val(&s.spirv, &format!("inline-{}", s.entry_name));
        }
        // The nested callable runs at levels 1..=max in any-hit and intersection stages.
        let text = vulkan_source(
            ModuleText::User(src),
            &config,
            &roles,
            Some((&compiled, &callables)),
        );
        assert!(text.contains("direct_callable__nested__optik_inline3()"));
        assert!(text.contains("helper__optik_inline1("));
        assert!(
            !text.contains("direct_callable__leaf__optik_inline"),
            "callables that call none are not copied"
        );
    }
}

/// Every module-scope name the backend adds to a module starts with the internal prefix
/// (`optik_api::wgsl::INTERNAL_PREFIX`, which the front end refuses in user names), except the
/// copies of the user's own functions inlined into intersection and any-hit stages, named
/// `<user name>__optik_inline<level>`.
#[test]
fn every_generated_name_has_the_internal_prefix() {
    let is_copy = |n: &str, user: &str| {
        n.rsplit_once("__optik_inline")
            .is_some_and(|(base, level)| {
                level.chars().all(|c| c.is_ascii_digit()) && user.contains(&format!("fn {base}("))
            })
    };
    let roles = user_roles(EVERYTHING);
    for config in [largest_config(), LoweringConfig::default()] {
        let text = vulkan_source(ModuleText::User(EVERYTHING), &config, &roles, None);
        let bad: Vec<String> = optik_core::frontend::unprefixed_internal_names(&text, EVERYTHING)
            .into_iter()
            .filter(|n| !is_copy(n, EVERYTHING))
            .collect();
        assert!(bad.is_empty(), "user module: {bad:?}");
        let roles = [StageRole::SphereIntersection, StageRole::NullCallable];
        let text = vulkan_source(
            ModuleText::Internal { curve_basis: 2 },
            &config,
            &roles,
            None,
        );
        let bad = optik_core::frontend::unprefixed_internal_names(&text, "");
        assert!(bad.is_empty(), "internal module: {bad:?}");
    }
}
