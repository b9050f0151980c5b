//! Trace, callable and exception functions, the `switch` over program groups at every
//! place that runs programs, and the entry point.
//!
//! A trace at depth d saves the caller's view (ray, hit, registers, record), runs the
//! traversal, then the closest-hit or miss program of depth d + 1, copies the payload
//! back and restores the view. `optk_trace_{T}_fn` (T = max_trace_depth) only raises
//! TRACE_DEPTH_EXCEEDED: that is where the per-depth copies end.

use super::KernelConfig;
use crate::program::instance::{Site, continuation_stub_name, direct_stub_name, trace_stub_name};
use optik_api::ExceptionFlags;

pub(super) fn write(c: &KernelConfig<'_>, out: &mut String) {
    if !c.features.exceptions.is_empty() {
        raise(c, out);
    }
    for &d in &c.lowered.traces {
        trace(c, d, out);
    }
    for &k in &c.lowered.directs {
        callable(
            c,
            out,
            &direct_stub_name(k),
            Site::Direct(k),
            k > c.max_direct,
            8,
        );
    }
    for &(d, n) in &c.lowered.continuations {
        callable(
            c,
            out,
            &continuation_stub_name(d, n),
            Site::Continuation(d, n),
            n > c.max_continuation,
            16,
        );
    }
    for p in 1..=c.features.max_trace_depth {
        if c.lowered.dispatch.contains_key(&Site::ClosestHit(p)) {
            closest_hit(c, p, out);
            miss(c, p, out);
        }
    }
    if c.traces() {
        if c.any_hit() {
            verdict(c, out, "optk_ah", Site::AnyHit);
        }
        if c.custom() && c.intersection() {
            verdict(c, out, "optk_is", Site::Intersection);
        }
    }
    entry(c, out);
}

/// `switch optk_group(record) { case g: { program(); } ... }`.
fn switch(c: &KernelConfig<'_>, site: Site, indent: &str) -> String {
    let mut s = format!("{indent}switch optk_group(record) {{\n");
    if let Some(entries) = c.lowered.dispatch.get(&site) {
        for (group, name) in entries {
            s.push_str(&format!(
                "{indent}    case {group}u: {{\n{indent}        {name}();\n{indent}    }}\n"
            ));
        }
    }
    s.push_str(&format!("{indent}    default: {{}}\n{indent}}}\n"));
    s
}

fn raise(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(
        r#"
// Raises an exception: runs the exception program (if the SBT has its record), then makes
// every program on the way back return at once.
fn optk_raise(code: i32) {
    if optk_unwind == 3u {
        return;
    }
    optk_exception = code;
    let record = optk_launch.sbt0.y;
    if record != OPTK_NONE {
        let saved = optk_record;
        optk_record = record;
"#,
    );
    out.push_str(&switch(c, Site::Exception, "        "));
    out.push_str(
        "        optk_record = saved;\n    }\n    optk_unwind = 3u;\n    optk_done = true;\n}\n\n",
    );
}

fn trace(c: &KernelConfig<'_>, d: u32, out: &mut String) {
    let n = c.payload_len();
    out.push_str(&format!(
        "fn {}(handle: vec2<u32>, origin: vec3<f32>, direction: vec3<f32>, tmin: f32, tmax: f32, time: f32, mask: u32, flags: u32, sbt_offset: u32, sbt_stride: u32, miss_index: u32, payload: ptr<function, array<u32, {n}>>) {{\n",
        trace_stub_name(d)
    ));
    if d >= c.features.max_trace_depth {
        if c.exception(ExceptionFlags::TRACE_DEPTH) {
            out.push_str("    optk_raise(-2);\n");
        }
        out.push_str("}\n\n");
        return;
    }
    out.push_str("    if !optk_ray_is_valid(origin, direction, tmin, tmax) {\n");
    if c.debug() {
        out.push_str("        optk_raise(-9);\n");
    }
    let time = if c.motion() { "time" } else { "0.0" };
    out.push_str(&format!(
        r#"        return;
    }}
    let saved_ray = optk_ray;
    let saved_hit = optk_hit;
    let saved_regs = optk_regs;
    let saved_record = optk_record;
    optk_ray = OptkRay(origin, tmin, optk_canonical_direction(direction), tmax, {time}, flags, mask & 0xFFu, sbt_offset & 0xFu, sbt_stride & 0xFu, miss_index & 0xFFFFu);
    optk_regs = *payload;
    optk_depth = {next}u;
    let hit = optk_traverse(handle);
    if optk_unwind == 0u {{
        if hit {{
            optk_hit = optk_best;
            optk_ray.tmax = optk_best.t;
            if (flags & 8u) == 0u {{
                optk_closest_hit_{next}(optk_best.record);
            }}
        }} else {{
            optk_miss_{next}(miss_index & 0xFFFFu);
        }}
    }}
    *payload = optk_regs;
    optk_ray = saved_ray;
    optk_hit = saved_hit;
    optk_regs = saved_regs;
    optk_record = saved_record;
    optk_depth = {d}u;
}}

"#,
        next = d + 1
    ));
}

fn closest_hit(c: &KernelConfig<'_>, p: u32, out: &mut String) {
    out.push_str(&format!(
        "fn optk_closest_hit_{p}(record: u32) {{\n    if record == OPTK_NONE {{\n        return;\n    }}\n    optk_record = record;\n"
    ));
    out.push_str(&switch(c, Site::ClosestHit(p), "    "));
    out.push_str("}\n\n");
}

fn miss(c: &KernelConfig<'_>, p: u32, out: &mut String) {
    out.push_str(&format!(
        "fn optk_miss_{p}(index: u32) {{\n    if index >= optk_launch.sbt1.w {{\n"
    ));
    if c.debug() {
        out.push_str("        optk_raise(-6);\n");
    }
    out.push_str("        return;\n    }\n    let record = optk_launch.sbt1.y + index * optk_launch.sbt1.z;\n    optk_record = record;\n");
    out.push_str(&switch(c, Site::Miss(p), "    "));
    out.push_str("}\n\n");
}

/// Any-hit and intersection dispatch: run the program, then return (and clear) its verdict:
/// 0 accept, 1 ignore, 2 terminate, 3 exception.
fn verdict(c: &KernelConfig<'_>, out: &mut String, name: &str, site: Site) {
    out.push_str(&format!(
        "fn {name}(record: u32) -> u32 {{\n    let saved_record = optk_record;\n    optk_record = record;\n"
    ));
    out.push_str(&switch(c, site, "    "));
    out.push_str(
        "    optk_record = saved_record;\n    let reason = optk_unwind;\n    if reason == 1u || reason == 2u {\n        optk_unwind = 0u;\n    }\n    return reason;\n}\n\n",
    );
}

/// A direct (`flag` 8) or continuation (16) callable call; `overflow` when the nesting is
/// beyond the pipeline's limit.
fn callable(
    c: &KernelConfig<'_>,
    out: &mut String,
    name: &str,
    site: Site,
    overflow: bool,
    flag: u32,
) {
    let n = c.payload_len();
    out.push_str(&format!(
        "fn {name}(index: u32, args: ptr<function, array<u32, {n}>>) {{\n"
    ));
    if overflow {
        if c.exception(ExceptionFlags::STACK_OVERFLOW) {
            out.push_str("    optk_raise(-1);\n");
        }
        out.push_str("}\n\n");
        return;
    }
    let debug_raise = if c.debug() {
        "        optk_raise(-12);\n"
    } else {
        ""
    };
    out.push_str(&format!(
        "    if index >= optk_launch.sbt2.z {{\n{debug_raise}        return;\n    }}\n    let record = optk_launch.sbt2.x + index * optk_launch.sbt2.y;\n    if (optk_group_flags(record) & {flag}u) == 0u {{\n{debug_raise}        return;\n    }}\n    let saved_regs = optk_regs;\n    let saved_record = optk_record;\n    optk_regs = *args;\n    optk_record = record;\n"
    ));
    out.push_str(&switch(c, site, "    "));
    out.push_str("    *args = optk_regs;\n    optk_regs = saved_regs;\n    optk_record = saved_record;\n}\n\n");
}

fn entry(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(&format!(
        r#"@compute @workgroup_size({})
fn optk_main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {{
    let row = groups.x * {}u;
    if optk_launch.dims.w == 0u || gid.y > (optk_launch.dims.w - 1u) / row {{
        return;
    }}
    let linear = gid.x + gid.y * row;
    if linear >= optk_launch.dims.w {{
        return;
    }}
    let w = optk_launch.dims.x;
    let h = optk_launch.dims.y;
    optk_launch_index = vec3<u32>(linear % w, (linear / w) % h, linear / (w * h));
    optk_depth = 0u;
    optk_unwind = 0u;
    optk_done = false;
    let record = optk_launch.sbt0.x;
    optk_record = record;
"#,
        super::WORKGROUP_SIZE,
        super::WORKGROUP_SIZE
    ));
    out.push_str(&switch(c, Site::Raygen, "    "));
    super::counters::flush(c, out);
    out.push_str("}\n");
}
