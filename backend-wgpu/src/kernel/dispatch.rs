//! Trace and callable functions, the `switch` over program groups at every place that runs
//! programs, and the entry point (exceptions: `exceptions`).
//!
//! A trace at depth d saves the caller's view (ray, hit, registers, record), runs the
//! traversal, then the closest-hit or miss program of depth d + 1, copies the payload
//! back and restores the view. `_optik_trace_{T}_fn` (T = max_trace_depth) only raises
//! TRACE_DEPTH_EXCEEDED: that is where the per-depth copies end.

use super::KernelConfig;
use crate::program::instance::{
    Site, continuation_stub_name, direct_stub_name, trace_stub_name,
    trace_without_closest_hit_stub_name,
};
use optik_api::ExceptionFlags;

pub(super) fn write(c: &KernelConfig<'_>, out: &mut String) {
    if !c.features.exceptions.is_empty() {
        super::exceptions::write(c, out);
    }
    for &d in &c.lowered.traces {
        trace(c, d, true, out);
    }
    for &d in &c.lowered.traces_without_closest_hit {
        trace(c, d, false, out);
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
            verdict(c, out, "_optik_ah", Site::AnyHit);
        }
        if c.custom() && c.intersection() {
            verdict(c, out, "_optik_is", Site::Intersection);
        }
    }
    entry(c, out);
}

/// `switch _optik_group(record) { case g: { program(); } ... }`.
pub(super) fn switch(c: &KernelConfig<'_>, site: Site, indent: &str) -> String {
    let mut s = format!("{indent}switch _optik_group(record) {{\n");
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

/// `_optik_trace_{d}_fn`, or with `closest_hit` false the copy for call sites whose flags
/// always disable closest-hit.
fn trace(c: &KernelConfig<'_>, d: u32, closest_hit: bool, out: &mut String) {
    let n = c.payload_len();
    let name = if closest_hit {
        trace_stub_name(d)
    } else {
        trace_without_closest_hit_stub_name(d)
    };
    out.push_str(&format!(
        "fn {name}(handle: vec2<u32>, origin: vec3<f32>, direction: vec3<f32>, tmin: f32, tmax: f32, time: f32, mask: u32, flags: u32, sbt_offset: u32, sbt_stride: u32, miss_index: u32, payload: ptr<function, array<u32, {n}>>) {{\n"
    ));
    if d >= c.features.max_trace_depth {
        if c.exception(ExceptionFlags::TRACE_DEPTH) {
            out.push_str("    _optik_raise(-2);\n");
        }
        out.push_str("}\n\n");
        return;
    }
    out.push_str("    if !_optik_ray_is_valid(origin, direction, tmin, tmax) {\n");
    if c.debug() {
        out.push_str("        _optik_raise(-9);\n");
    }
    let time = if c.motion() { "time" } else { "0.0" };
    let run_closest_hit = if closest_hit {
        format!(
            "            if (flags & 8u) == 0u {{\n                _optik_closest_hit_{}(_optik_best.record);\n            }}\n",
            d + 1
        )
    } else {
        String::new()
    };
    out.push_str(&format!(
        r#"        return;
    }}
    let saved_ray = _optik_ray;
    let saved_hit = _optik_hit;
    let saved_regs = _optik_regs;
    let saved_record = _optik_record;
    _optik_ray = _OptikRay(origin, tmin, _optik_canonical_direction(direction), tmax, {time}, flags, mask & 0xFFu, sbt_offset & 0xFu, sbt_stride & 0xFu, miss_index & 0xFFFFu);
    _optik_regs = *payload;
    _optik_depth = {next}u;
    let hit = _optik_traverse(handle);
    if _optik_unwind == 0u {{
        if hit {{
            _optik_hit = _optik_best;
            _optik_ray.tmax = _optik_best.t;
{run_closest_hit}        }} else {{
            _optik_miss_{next}(miss_index & 0xFFFFu);
        }}
    }}
    *payload = _optik_regs;
    _optik_ray = saved_ray;
    _optik_hit = saved_hit;
    _optik_regs = saved_regs;
    _optik_record = saved_record;
    _optik_depth = {d}u;
}}

"#,
        next = d + 1
    ));
}

fn closest_hit(c: &KernelConfig<'_>, p: u32, out: &mut String) {
    out.push_str(&format!(
        "fn _optik_closest_hit_{p}(record: u32) {{\n    if record == _OPTIK_NONE {{\n        return;\n    }}\n    _optik_record = record;\n"
    ));
    out.push_str(&switch(c, Site::ClosestHit(p), "    "));
    out.push_str("}\n\n");
}

fn miss(c: &KernelConfig<'_>, p: u32, out: &mut String) {
    out.push_str(&format!(
        "fn _optik_miss_{p}(index: u32) {{\n    if index >= _optik_launch.sbt1.w {{\n"
    ));
    if c.debug() {
        out.push_str("        _optik_raise(-6);\n");
    }
    out.push_str("        return;\n    }\n    let record = _optik_launch.sbt1.y + index * _optik_launch.sbt1.z;\n    _optik_record = record;\n");
    out.push_str(&switch(c, Site::Miss(p), "    "));
    out.push_str("}\n\n");
}

/// Any-hit and intersection dispatch: run the program, then return (and clear) its verdict:
/// 0 accept, 1 ignore, 2 terminate, 3 exception.
fn verdict(c: &KernelConfig<'_>, out: &mut String, name: &str, site: Site) {
    out.push_str(&format!(
        "fn {name}(record: u32) -> u32 {{\n    let saved_record = _optik_record;\n    _optik_record = record;\n"
    ));
    out.push_str(&switch(c, site, "    "));
    out.push_str(
        "    _optik_record = saved_record;\n    let reason = _optik_unwind;\n    if reason == 1u || reason == 2u {\n        _optik_unwind = 0u;\n    }\n    return reason;\n}\n\n",
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
            out.push_str("    _optik_raise(-1);\n");
        }
        out.push_str("}\n\n");
        return;
    }
    let debug_raise = if c.debug() {
        "        _optik_raise(-12);\n"
    } else {
        ""
    };
    out.push_str(&format!(
        "    if index >= _optik_launch.sbt2.z {{\n{debug_raise}        return;\n    }}\n    let record = _optik_launch.sbt2.x + index * _optik_launch.sbt2.y;\n    if (_optik_group_flags(record) & {flag}u) == 0u {{\n{debug_raise}        return;\n    }}\n    let saved_regs = _optik_regs;\n    let saved_record = _optik_record;\n    _optik_regs = *args;\n    _optik_record = record;\n"
    ));
    out.push_str(&switch(c, site, "    "));
    out.push_str("    *args = _optik_regs;\n    _optik_regs = saved_regs;\n    _optik_record = saved_record;\n}\n\n");
}

fn entry(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(&format!(
        r#"@compute @workgroup_size({})
fn _optik_main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {{
    let row = groups.x * {}u;
    if _optik_launch.dims.w == 0u || gid.y > (_optik_launch.dims.w - 1u) / row {{
        return;
    }}
    let linear = gid.x + gid.y * row;
    if linear >= _optik_launch.dims.w {{
        return;
    }}
    let w = _optik_launch.dims.x;
    let h = _optik_launch.dims.y;
    _optik_launch_index = vec3<u32>(linear % w, (linear / w) % h, linear / (w * h));
    _optik_depth = 0u;
    _optik_unwind = 0u;
    _optik_done = false;
    let record = _optik_launch.sbt0.x;
    _optik_record = record;
"#,
        super::WORKGROUP_SIZE,
        super::WORKGROUP_SIZE
    ));
    out.push_str(&switch(c, Site::Raygen, "    "));
    super::counters::flush(c, out);
    out.push_str("}\n");
}
