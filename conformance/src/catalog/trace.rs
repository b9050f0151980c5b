//! The `trace` group: recursive tracing.

use super::util::*;
use crate::case::*;
use crate::kit::{Ray, hit_group, trace_words, uint_channel};
use crate::oracle::exec::Ctx;
use crate::oracle::model::{Flow, Models};
use optik::{PipelineCompileOptions, PipelineLinkOptions, Setting};

/// Every case of the `trace` group.
pub fn cases() -> Vec<Case> {
    vec![recursion_tree()]
}

const TREE_WGSL: &str = r#"
fn child(hit: bool) -> array<u32, 2> {
    var p: RtPayload;
    let x = select(5.0, 0.25, hit);
    rt_trace(params.handle, vec3<f32>(x, 0.5, 1.0), vec3<f32>(0.0, 0.0, -1.0), 0.0, 10.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    return array<u32, 2>(p[0], p[1]);
}

fn node() {
    let remaining = rt_remaining_trace_depth();
    var ch = 0u;
    var ms = 0u;
    if remaining > 0u {
        let a = child(true);
        let b = child(false);
        ch = a[0] + b[0];
        ms = a[1] + b[1];
    }
    rt_set_payload(0u, rt_get_payload(0u) + ch);
    rt_set_payload(1u, rt_get_payload(1u) + ms);
    rt_set_payload(2u, min(rt_get_payload(2u), remaining));
}

fn closesthit__tree() {
    rt_set_payload(0u, 1u);
    rt_set_payload(1u, 0u);
    rt_set_payload(2u, 0xFFFFu);
    node();
}

fn miss__tree() {
    rt_set_payload(0u, 0u);
    rt_set_payload(1u, 1u);
    rt_set_payload(2u, 0xFFFFu);
    node();
}

fn raygen__tree() {
    let id = ray_id();
    if id >= params.num_rays {
        return;
    }
    let r = rays[id];
    var p: RtPayload;
    rt_trace(params.handle, r.origin, r.dir, r.tmin, r.tmax, r.time, r.mask, r.flags, r.sbt_offset, r.sbt_stride, r.miss_index, &p);
    out[slot(0u)] = p[0];
    out[slot(1u)] = p[1];
    out[slot(2u)] = p[2];
    out[slot(3u)] = rt_remaining_trace_depth();
}
"#;

fn recursion_tree() -> Case {
    let (scene, root) = one_quad();
    let depth = 3u32;
    fn child(ctx: &mut Ctx<'_, '_>, hit: bool) -> Result<[u32; 2], crate::oracle::model::Unwind> {
        let mut p = [0u32; 8];
        let x = if hit { 0.25 } else { 5.0 };
        let handle = [ctx.param(0), ctx.param(1)];
        ctx.trace(
            handle,
            [x, 0.5, 1.0],
            [0.0, 0.0, -1.0],
            0.0,
            10.0,
            0.0,
            0xFF,
            0,
            0,
            1,
            0,
            &mut p,
        )?;
        Ok([p[0], p[1]])
    }
    fn node(ctx: &mut Ctx<'_, '_>) -> Flow {
        let remaining = ctx.remaining_trace_depth();
        let (mut ch, mut ms) = (0, 0);
        if remaining > 0 {
            let a = child(ctx, true)?;
            let b = child(ctx, false)?;
            ch = a[0] + b[0];
            ms = a[1] + b[1];
        }
        let (p0, p1, p2) = (ctx.get_payload(0), ctx.get_payload(1), ctx.get_payload(2));
        ctx.set_payload(0, p0 + ch);
        ctx.set_payload(1, p1 + ms);
        ctx.set_payload(2, p2.min(remaining));
        Ok(())
    }
    let mut m = Models::new();
    m.add("closesthit__tree", |ctx| {
        ctx.set_payload(0, 1);
        ctx.set_payload(1, 0);
        ctx.set_payload(2, 0xFFFF);
        node(ctx)
    });
    m.add("miss__tree", |ctx| {
        ctx.set_payload(0, 0);
        ctx.set_payload(1, 1);
        ctx.set_payload(2, 0xFFFF);
        node(ctx)
    });
    m.add("raygen__tree", |ctx| {
        let id = ctx.linear_index();
        if id >= ctx.param(2) {
            return Ok(());
        }
        let w = ray_words(ctx, id);
        let mut p = [0u32; 8];
        trace_words(ctx, &w, &mut p)?;
        let s = id as usize * 4;
        for (k, v) in p.iter().take(3).enumerate() {
            ctx.write(2, s + k, *v);
        }
        let r = ctx.remaining_trace_depth();
        ctx.write(2, s + 3, r);
        Ok(())
    });
    let pipeline = PipelineDesc {
        wgsl: format!("{}{TREE_WGSL}", header(4)),
        raygen: "raygen__tree".into(),
        miss: vec![Some("miss__tree".into())],
        hit: vec![hit_group(Some("closesthit__tree"), None, None)],
        callables: vec![],
        exception: None,
        compile: PipelineCompileOptions {
            num_payload_values: Setting::Value(3),
            ..Default::default()
        },
        link: PipelineLinkOptions {
            max_trace_depth: depth,
            ..Default::default()
        },
    };
    let sbt = plain_sbt(Vec::new());
    own_case(
        Group::Trace,
        "recursion_tree",
        &format!(
            "closest-hit and miss each trace one hit child and one miss child until rt_remaining_trace_depth is 0 (max_trace_depth {depth}): node counts 2^d − 1 per kind, depth seen at every level (CTS recursiveTraces)"
        ),
        &[],
        scene,
        Some(root),
        pipeline,
        m,
        sbt,
        vec![
            Ray::new([0.25, 0.5, 1.0], [0.0, 0.0, -1.0]),
            Ray::new([5.0, 0.5, 1.0], [0.0, 0.0, -1.0]),
        ],
        4,
        ["ch_nodes", "ms_nodes", "min_remaining", "rg_remaining"]
            .iter()
            .enumerate()
            .map(|(k, n)| uint_channel(n, k))
            .collect(),
    )
}
