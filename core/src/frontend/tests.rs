//! Front-end tests: valid modules reflect correctly; each misuse is an error at the user's
//! line and column with a message that says what is wrong.

use super::*;

fn compile_src(src: &str) -> Result<CompiledModule> {
    compile(&ProgramSource::new("user.wgsl", src), 8)
}

/// The single diagnostic of a module that must fail.
fn diag(src: &str) -> Diagnostic {
    let e = compile_src(src).expect_err("module should not compile");
    assert_eq!(e.kind(), optik_api::ErrorKind::Compile);
    assert!(!e.diagnostics().is_empty(), "{e}");
    e.diagnostics()[0].clone()
}

fn assert_diag(src: &str, line: u32, column: u32, needle: &str) {
    let d = diag(src);
    assert_eq!(d.file, "user.wgsl", "{d}");
    assert!(
        d.message.contains(needle),
        "message {:?} lacks {needle:?}",
        d.message
    );
    assert_eq!(
        (d.line, d.column),
        (line, column),
        "wrong position for: {d}"
    );
}

const VALID: &str = r#"struct Params { handle: vec2<u32>, width: u32, pad: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn shade(n: vec3<f32>) -> u32 {
    return u32(n.x * 255.0);
}

fn raygen__main() {
    let idx = rt_launch_index();
    var p: RtPayload;
    p[2] = 7u;
    rt_trace(params.handle, vec3<f32>(0.0), vec3<f32>(0.0, 0.0, 1.0), 0.0, 1e30, 0.0,
             0xFFu, RT_RAY_FLAG_NONE, 0u, 1u, 0u, &p);
    out[idx.x] = p[0];
}

fn closesthit__radiance() {
    rt_set_payload(0u, shade(rt_world_ray_direction()) + rt_primitive_index());
}

fn miss__background() {
    rt_set_payload(1u, 0u);
}

fn anyhit__cutout() {
    if rt_get_attribute(0u) == 0u { rt_ignore_intersection(); }
}
"#;

#[test]
fn valid_module_reflects_programs_and_bindings() {
    let m = compile_src(VALID).unwrap();
    let names: Vec<(&str, ProgramKind)> = m
        .programs
        .iter()
        .map(|p| (p.name.as_str(), p.kind))
        .collect();
    assert_eq!(
        names,
        vec![
            ("raygen__main", ProgramKind::Raygen),
            ("closesthit__radiance", ProgramKind::ClosestHit),
            ("miss__background", ProgramKind::Miss),
            ("anyhit__cutout", ProgramKind::AnyHit),
        ]
    );
    let rg = m.program("raygen__main").unwrap();
    assert!(rg.calls(DeviceFunction::Trace) && rg.calls(DeviceFunction::LaunchIndex));
    assert_eq!(
        rg.bindings_used.iter().copied().collect::<Vec<_>>(),
        vec![0, 1]
    );
    assert_eq!((rg.line, rg.column), (9, 4));
    let ch = m.program("closesthit__radiance").unwrap();
    assert!(ch.helpers.contains("shade"));
    assert!(
        ch.calls(DeviceFunction::WorldRayDirection) && ch.calls(DeviceFunction::PrimitiveIndex)
    );
    assert!(ch.bindings_used.is_empty());
    assert_eq!(m.bindings.len(), 2);
    assert_eq!(m.params().unwrap().kind, BindingKind::Params { size: 16 });
    assert_eq!(
        m.bindings[1].kind,
        BindingKind::StorageBuffer {
            read_only: false,
            min_size: 4
        }
    );
    // p[2] in raygen and rt_set_payload(1u) in miss: registers 0..=2 are used.
    assert_eq!(m.payload_values_used, 3);
    assert_eq!(m.attribute_values_used, 2);
}

#[test]
fn dynamic_payload_index_uses_every_register() {
    let src = "fn closesthit__a() { let i = rt_primitive_index(); rt_set_payload(i, 1u); }\n";
    assert_eq!(compile_src(src).unwrap().payload_values_used, 32);
}

#[test]
fn largest_constant_register_index_counts_as_all_registers() {
    let src = "fn closesthit__a() { rt_set_payload(0xffffffffu, 1u); let a = rt_get_attribute(0xffffffffu); }\n";
    let m = compile_src(src).unwrap();
    assert_eq!((m.payload_values_used, m.attribute_values_used), (32, 8));
}

#[test]
fn error_type_mismatch_points_at_the_expression() {
    // A u32 added to an f32 on line 3.
    let src = "fn raygen__a() {\n    let x: f32 = 1.0;\n    let y = x + 1u;\n}\n";
    let d = diag(src);
    assert_eq!(d.line, 3, "{d}");
    assert!(d.column >= 13 && d.column <= 17, "{d}");
}

#[test]
fn error_set_payload_in_raygen() {
    let src = "fn raygen__a() {\n    rt_set_payload(0u, 1u);\n}\n";
    assert_diag(
        src,
        2,
        5,
        "`rt_set_payload` cannot be used in a raygen program (`raygen__a`)",
    );
}

#[test]
fn error_get_payload_in_raygen_through_helper() {
    let src = "fn helper() -> u32 {\n  return rt_get_payload(0u);\n}\nfn raygen__a() {\n  let v = helper();\n}\n";
    let d = diag(src);
    assert_eq!((d.line, d.column), (2, 10), "{d}");
    assert!(
        d.message.contains("reached through raygen__a -> helper"),
        "{d}"
    );
}

#[test]
fn error_report_intersection_outside_intersection() {
    let src = "fn closesthit__a() {\n  var a: RtAttributes;\n  let ok = rt_report_intersection(1.0, 0u, a);\n}\n";
    assert_diag(
        src,
        3,
        12,
        "`rt_report_intersection` cannot be used in a closest-hit program",
    );
}

#[test]
fn error_ignore_in_closest_hit() {
    let src = "fn closesthit__a() {\n  rt_ignore_intersection();\n}\n";
    assert_diag(src, 2, 3, "available in any-hit programs");
}

#[test]
fn error_trace_in_anyhit() {
    let src = "fn anyhit__a() {\n  var p: RtPayload;\n  rt_trace(vec2<u32>(), vec3<f32>(), vec3<f32>(), 0.0, 1.0, 0.0, 255u, 0u, 0u, 0u, 0u, &p);\n}\n";
    assert_diag(src, 3, 3, "`rt_trace` cannot be used in a any-hit program");
}

#[test]
fn error_throw_in_exception_program() {
    let src = "fn exception__a() {\n  rt_throw_exception(3u);\n}\n";
    assert_diag(
        src,
        2,
        3,
        "`rt_throw_exception` cannot be used in a exception program",
    );
}

#[test]
fn error_unknown_prefix() {
    let src = "fn closest_hit__shade() {\n}\n";
    assert_diag(
        src,
        1,
        4,
        "unknown program prefix `closest_hit__` in `closest_hit__shade` (did you mean `closesthit__`?)",
    );
}

#[test]
fn error_program_with_parameters() {
    let src = "fn miss__a(x: u32) {\n}\n";
    assert_diag(src, 1, 4, "miss program `miss__a` takes parameters");
}

#[test]
fn error_program_with_result() {
    let src = "\nfn raygen__a() -> u32 {\n  return 1u;\n}\n";
    assert_diag(src, 2, 4, "raygen program `raygen__a` returns a value");
}

#[test]
fn error_workgroup_variable() {
    let src = "var<workgroup> shared_data: array<u32, 64>;\nfn raygen__a() {\n  shared_data[0] = 1u;\n}\n";
    assert_diag(src, 1, 1, "workgroup memory is not available");
}

#[test]
fn error_barrier() {
    let src = "fn raygen__a() {\n  storageBarrier();\n}\n";
    assert_diag(src, 2, 3, "barriers are not available");
}

#[test]
fn error_recursion() {
    let src = "fn f(n: u32) -> u32 {\n  return f(n - 1u);\n}\nfn raygen__a() { let x = f(3u); }\n";
    let d = diag(src);
    assert!(
        d.message.contains("recursive") || d.message.contains("cyclic"),
        "{d}"
    );
    assert_eq!(d.line, 1, "{d}");
}

#[test]
fn error_entry_point() {
    let src = "@compute @workgroup_size(1)\nfn main() {\n}\n";
    assert_diag(src, 2, 4, "entry point `main` is not allowed");
}

#[test]
fn error_group_one_binding() {
    let src = "@group(1) @binding(0) var<storage, read> data: array<u32>;\nfn raygen__a() { let x = data[0]; }\n";
    assert_diag(src, 1, 23, "is in @group(1); programs use @group(0) only");
}

#[test]
fn error_binding_zero_not_uniform() {
    let src = "@group(0) @binding(0) var<storage, read> data: array<u32>;\nfn raygen__a() { let x = data[0]; }\n";
    assert_diag(
        src,
        1,
        23,
        "binding 0 is the launch parameters and must be `var<uniform>",
    );
}

#[test]
fn error_uniform_above_zero() {
    let src = "@group(0) @binding(2) var<uniform> extra: vec4<f32>;\nfn raygen__a() { let x = extra.x; }\n";
    assert_diag(
        src,
        1,
        23,
        "only binding 0 (the launch parameters) is a uniform",
    );
}

#[test]
fn error_texture_sample_implicit_lod() {
    let src = "@group(0) @binding(1) var t: texture_2d<f32>;\n@group(0) @binding(2) var s: sampler;\nfn closesthit__a() {\n  let c = textureSample(t, s, vec2<f32>(0.5));\n}\n";
    let d = diag(src);
    assert_eq!(d.line, 4, "{d}");
    assert!(d.message.contains("textureSampleLevel"), "{d}");
}

#[test]
fn error_reserved_rt_name() {
    let src = "fn rt_my_helper() {\n}\nfn raygen__a() { rt_my_helper(); }\n";
    assert_diag(src, 1, 4, "names starting with `rt_` are reserved");
}

#[test]
fn error_redefining_device_function() {
    let src = "fn rt_launch_index() -> vec3<u32> { return vec3<u32>(); }\nfn raygen__a() { }\n";
    let d = diag(src);
    assert!(d.message.contains("rt_launch_index"), "{d}");
}

#[test]
fn error_wrong_argument_type_to_device_function() {
    let src = "fn closesthit__a() {\n  rt_set_payload(0u, 1.5);\n}\n";
    let d = diag(src);
    assert_eq!(d.line, 2, "{d}");
}

#[test]
fn error_syntax() {
    let src = "fn raygen__a() {\n  let x = ;\n}\n";
    assert_diag(src, 2, 11, "expected");
}

#[test]
fn error_unknown_identifier() {
    let src = "fn raygen__a() {\n  let x = rt_not_a_function();\n}\n";
    assert_diag(
        src,
        2,
        11,
        "no definition in scope for identifier: `rt_not_a_function`",
    );
}

#[test]
fn error_discard() {
    let src = "fn closesthit__a() {\n  discard;\n}\n";
    let d = diag(src);
    assert_eq!(d.line, 2, "{d}");
}

#[test]
fn diagnostics_format_as_file_line_column() {
    let src = "fn raygen__a() {\n    rt_set_payload(0u, 1u);\n}\n";
    let e = compile_src(src).unwrap_err();
    let text = e.to_string();
    assert!(
        text.starts_with("user.wgsl:2:5: `rt_set_payload` cannot be used"),
        "{text}"
    );
    assert!(
        text.contains("\n        rt_set_payload(0u, 1u);\n"),
        "{text}"
    );
}

#[test]
fn prelude_does_not_shift_user_lines() {
    // A module without a trailing newline still reports its last line correctly.
    let src = "fn raygen__a() {\n  rt_set_payload(0u, 1u); }";
    let d = diag(src);
    assert_eq!((d.line, d.column), (2, 3), "{d}");
}

#[test]
fn recursion_limit_is_named_at_the_deepest_nesting() {
    let depth = 198;
    let src = format!(
        "fn raygen__a() {{\n    let x = {}1.0{};\n}}\n",
        "(".repeat(depth),
        ")".repeat(depth)
    );
    let d = diag(&src);
    assert_eq!(d.file, "user.wgsl", "{d}");
    assert!(d.message.contains("recursion limit exceeded"), "{d}");
    assert!(!d.message.contains("internal WGSL front end error"), "{d}");
    assert_eq!(d.line, 2, "{d}");
    assert!(d.column > 13, "{d}");
}

#[test]
fn type_too_large_points_at_the_array_and_keeps_naga_notes() {
    let src = "struct Small { a: f32 }\n\
               var<private> big: array<vec4<f32>, 0x10000000>;\n\
               fn raygen__a() { big[0] = vec4<f32>(); }\n";
    let d = diag(src);
    assert!(d.message.contains("type is too large"), "{d}");
    assert!(d.message.contains("note: the maximum size is"), "{d}");
    assert_eq!((d.file.as_str(), d.line), ("user.wgsl", 2), "{d}");
}

#[test]
fn a_missing_closing_brace_is_reported_at_its_opening() {
    let src = "fn raygen__a() {\n    let x = 1.0;\n";
    let e = compile_src(src).expect_err("unclosed");
    assert_eq!(e.diagnostics().len(), 1, "{e}");
    assert_diag(src, 1, 16, "this `{` is never closed");
    assert!(
        diag("/* open\nfn raygen__a() {}\n")
            .message
            .contains("`/*` comment is never closed")
    );
}

#[test]
fn names_the_prelude_relies_on_give_one_clear_error() {
    let src = "fn f32() -> u32 { return 1u; }\nfn raygen__a() { }\n";
    let e = compile_src(src).expect_err("f32 is taken");
    assert_eq!(e.diagnostics().len(), 1, "{e}");
    assert_diag(
        src,
        1,
        4,
        "a function named `f32` would hide WGSL's own `f32`, which optik's device-API prelude uses",
    );
    let src = "fn raygen__a() { }\nfn rt_trace() { }\n";
    let e = compile_src(src).expect_err("rt_trace is taken");
    assert_eq!(e.diagnostics().len(), 1, "{e}");
    assert_diag(src, 2, 4, "`rt_trace` is a name of optik's device API");
    assert_diag(
        "struct RtPayload { a: u32 }\nfn raygen__a() { }\n",
        1,
        8,
        "`RtPayload` is a name of optik's device API",
    );
    // The backends' internal prefix, in any letter case, on any kind of declaration.
    for (src, line, column) in [
        ("fn _optik_state() {}\nfn raygen__a() { }\n", 1, 4),
        ("const _OPTIK_NONE: u32 = 1u;\nfn raygen__a() { }\n", 1, 7),
        ("fn raygen__a() { }\nstruct _OptikHit { t: f32 }\n", 2, 8),
        ("var<private> _Optik_x: u32;\nfn raygen__a() { }\n", 1, 14),
    ] {
        assert_diag(src, line, column, "are reserved for the WGSL optik adds");
    }
    // Local names and names the prelude does not use stay free (the old internal prefixes
    // too).
    let ok = "fn p() -> f32 { return 1.0; }\nfn normalize2() {}\nfn optk_a() {}\nfn optik_b() {}\nfn raygen__a() { let n = p(); let _optik_local = 1u; }\n";
    compile_src(ok).unwrap();
}

#[test]
fn a_spill_into_the_prelude_is_reported_in_the_user_file() {
    let full = format!("fn raygen__a() {{}}\n{}", prelude(8));
    let user_len = "fn raygen__a() {}\n".len();
    let loc = Locator::new("user.wgsl", &full, user_len);
    let at = full.find("fn rt_trace").unwrap() as u32;
    let d = loc.diagnostic(naga::Span::new(at, at + 2), "something");
    assert_eq!((d.file.as_str(), d.line), ("user.wgsl", 1), "{d}");
    assert!(d.message.contains("optik's device-API prelude"), "{d}");
}

#[test]
fn a_byte_order_mark_is_accepted() {
    let m = compile_src("\u{FEFF}fn raygen__a() { }\n").unwrap();
    assert_eq!(m.programs[0].name, "raygen__a");
    assert_eq!((m.programs[0].line, m.programs[0].column), (1, 4));
    let s = source_from_bytes("bom.wgsl", b"\xEF\xBB\xBFfn raygen__a() { }\n").unwrap();
    assert!(s.wgsl.starts_with("fn raygen__a"));
}

#[test]
fn invalid_utf8_names_its_byte_offset() {
    let e = source_from_bytes("latin1.wgsl", b"fn raygen__a() { }\n// caf\xE9\n").unwrap_err();
    let d = &e.diagnostics()[0];
    assert_eq!(
        (d.file.as_str(), d.line, d.column),
        ("latin1.wgsl", 2, 7),
        "{d}"
    );
    assert!(d.message.contains("byte offset 25 holds 0xe9"), "{d}");
}

#[test]
fn every_shared_name_has_the_internal_prefix() {
    let all = {
        use optik_api::wgsl::*;
        [RAY, SLAB, TRIANGLE, SPHERE, CURVE, MOTION, BVH4, MICROMAP].concat()
    };
    assert_eq!(unprefixed_internal_names(&all, ""), Vec::<String>::new());
    // The check sees every kind of declaration, leaves the user's and the device API's
    // names alone, and ignores letter case in the prefix.
    let generated = "fn helper() {}\nconst LIMIT: u32 = 1u;\nstruct Hit { t: f32 }\n\
                         fn _optik_a() {}\nconst _OPTIK_B: u32 = 2u;\nstruct _OptikC { t: f32 }\n\
                         fn raygen__a() {}\nfn rt_trace() {}\nalias RtPayload = u32;";
    assert_eq!(
        unprefixed_internal_names(generated, "fn raygen__a() {}"),
        ["helper", "LIMIT", "Hit"]
    );
    assert!(
        optik_api::wgsl::is_internal_name("_OptikX")
            && optik_api::wgsl::is_internal_name("_optik_x")
    );
    assert!(
        !optik_api::wgsl::is_internal_name("optik_x")
            && !optik_api::wgsl::is_internal_name("_opti")
    );
}
