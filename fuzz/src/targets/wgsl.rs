//! The WGSL front end (parse, validate, optik's program checks and reflection), then, for
//! every module it accepts, the CPU backend's Cranelift JIT and the Vulkan backend's SPIR-V
//! lowering of every program (naga's SPIR-V writer and optik's ray tracing post-pass).
//!
//! An error of kind `Backend` from the JIT or the lowering, for a module the front end
//! accepted, is a finding: the front end should have rejected it with a located message.

use crate::{Outcome, Target};
use optik_api::{ErrorKind, ExceptionFlags, OptLevel, ProgramKind, ProgramSource};
use optik_cpu::program::{DiskCache, JitModule, JitOptions};
use optik_vulkan::program::{
    HitContext, LoweringConfig, ModuleText, StageRole, TriangleMode, lower_stages,
};

/// The target.
pub const TARGET: Target = Target {
    name: "wgsl",
    seeds,
    dictionary: DICTIONARY,
    run,
};

const DICTIONARY: &[&[u8]] = &[
    b"fn raygen__a() {", b"fn closesthit__a() {", b"fn anyhit__a() {", b"fn miss__a() {",
    b"fn intersection__a() {", b"fn exception__a() {", b"fn direct_callable__a() {",
    b"loop {", b"for (var i = 0u; i < 4u; i++) {", b"while (true) {", b"break;", b"continue;",
    b"continuing {", b"break if", b"switch", b"return;", b"if", b"else", b"var", b"let",
    b"const", b"array<u32, 4>", b"vec3<f32>", b"vec2<u32>", b"mat4x3<f32>", b"f32", b"u32",
    b"i32", b"bool", b"f16", b"struct S { a: u32, b: vec3<f32> }",
    b"@group(0) @binding(1) var<storage, read_write> out: array<u32>;",
    b"@group(0) @binding(0) var<uniform> params: vec4<u32>;",
    b"var<private> p: u32;", b"var<workgroup> w: u32;", b"rt_launch_index()",
    b"rt_launch_dimensions()", b"rt_set_payload(0u, 1u);", b"rt_get_payload(0u)",
    b"rt_trace(vec2<u32>(0u), vec3<f32>(0.0), vec3<f32>(0.0, 0.0, 1.0), 0.0, 1e30, 0.0, 255u, 0u, 0u, 1u, 0u, &p);",
    b"rt_report_intersection(1.0, 0u, a)", b"rt_ignore_intersection();",
    b"rt_terminate_ray();", b"rt_throw_exception(1u);", b"rt_direct_call(0u, &a);",
    b"rt_sbt_data_u32(0u)", b"1e38", b"-0.0", b"0x7fffffffu", b"4294967295u", b"(", b")",
    b"{", b"}", b"[", b"]", b";", b",", b"&", b"*", b"<<", b">>", b"/", b"%",
];

/// Seeds: the programs in `fuzz/seeds/wgsl/`, embedded so the target needs no files.
fn seeds() -> Vec<Vec<u8>> {
    SEEDS.iter().map(|s| s.as_bytes().to_vec()).collect()
}

const SEEDS: &[&str] = &[
    include_str!("../../seeds/wgsl/raycast.wgsl"),
    include_str!("../../seeds/wgsl/loops.wgsl"),
    include_str!("../../seeds/wgsl/hitgroups.wgsl"),
    include_str!("../../seeds/wgsl/callables.wgsl"),
];

/// Runs one input.
pub fn run(data: &[u8]) -> Outcome {
    let Ok(text) = std::str::from_utf8(data) else {
        return Outcome::Rejected;
    };
    let Ok(module) = optik_core::frontend::compile(&ProgramSource::new("fuzz.wgsl", text), 8)
    else {
        return Outcome::Rejected;
    };
    let jit = JitModule::compile_uncached(
        &module,
        &JitOptions {
            opt_level: OptLevel::Default,
            disk_cache: DiskCache::Disabled,
        },
    );
    if let Err(e) = &jit
        && e.kind() == ErrorKind::Backend
    {
        return Outcome::Finding(format!("CPU JIT: {e}"));
    }
    drop(jit);
    let roles: Vec<StageRole> = module
        .programs
        .iter()
        .map(|p| StageRole::Program {
            name: p.name.clone(),
            kind: p.kind,
            context: matches!(p.kind, ProgramKind::ClosestHit | ProgramKind::AnyHit)
                .then_some(HitContext::Triangles),
        })
        .collect();
    // The smallest configuration or one with every feature, by the input's length.
    let config = if data.len().is_multiple_of(2) {
        LoweringConfig {
            payload_len: 8,
            continuation_calls: true,
            ..LoweringConfig::default()
        }
    } else {
        LoweringConfig {
            payload_len: 8,
            max_trace_depth: 3,
            exceptions: ExceptionFlags::ALL,
            exception_program: true,
            motion: true,
            track_depth: true,
            track_ray_flags: true,
            guard_direct_calls: true,
            continuation_calls: true,
            inline_calls: true,
            triangles: TriangleMode::Watertight { f64: true },
            skip_triangles_flag: true,
            motion_structures: true,
            micromaps: true,
            micromap_states: true,
            ..LoweringConfig::default()
        }
    };
    match lower_stages(ModuleText::User(text), &config, &roles, None) {
        Err(e) if e.kind() == ErrorKind::Backend => {
            Outcome::Finding(format!("SPIR-V lowering: {e}"))
        }
        _ => Outcome::Accepted,
    }
}
