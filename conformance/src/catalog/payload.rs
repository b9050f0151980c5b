//! The `payload` group: payload registers, copied in and out, of every type.

use super::util::*;
use crate::case::*;
use crate::kit::{Ray, StdCase, ch, hit_group, trace_words, uint_channel};
use crate::oracle::exec::Ctx;
use crate::oracle::model::{Flow, Models};
use optik::{PipelineCompileOptions, PipelineLinkOptions, Setting};

/// Every case of the `payload` group.
pub fn cases() -> Vec<Case> {
    vec![copy_semantics(32), copy_semantics(1), types_semantics()]
}

const PAYLOAD_WGSL: &str = r#"
const INIT: array<u32, 8> = array<u32, 8>(0x7FC00001u, 0x00000001u, 0x80000000u, 0xFFFFFFFFu, 0x3F800000u, 0x007FFFFFu, 0xFF800000u, 0x12345678u);

fn raygen__payload() {
    let id = ray_id();
    if id >= params.num_rays {
        return;
    }
    let r = rays[id];
    var p: RtPayload;
    for (var k = 0u; k < NUM_PAYLOAD; k++) {
        p[k] = INIT[k % 8u] ^ (k * 0x01010101u) ^ r.aux;
    }
    rt_trace(params.handle, r.origin, r.dir, r.tmin, r.tmax, r.time, r.mask, r.flags, r.sbt_offset, r.sbt_stride, r.miss_index, &p);
    for (var k = 0u; k < NUM_PAYLOAD; k++) {
        out[slot(k)] = p[k];
    }
}

fn anyhit__xor() {
    for (var k = 0u; k < NUM_PAYLOAD; k++) {
        if k % 3u == 0u {
            rt_set_payload(k, rt_get_payload(k) ^ 0x0F0F0F0Fu);
        }
    }
}

fn closesthit__xor() {
    for (var k = 0u; k < NUM_PAYLOAD; k++) {
        if k % 3u == 1u {
            rt_set_payload(k, rt_get_payload(k) ^ 0x00FF00FFu);
        }
    }
}

fn miss__xor() {
    for (var k = 0u; k < NUM_PAYLOAD; k++) {
        if k % 3u == 2u {
            rt_set_payload(k, rt_get_payload(k) ^ 0xF000000Fu);
        }
    }
}
"#;

const INIT: [u32; 8] = [
    0x7FC00001, 0x00000001, 0x80000000, 0xFFFFFFFF, 0x3F800000, 0x007FFFFF, 0xFF800000, 0x12345678,
];

fn copy_semantics(n: u32) -> Case {
    let (scene, root) = one_quad();
    let wgsl = format!(
        "{}const NUM_PAYLOAD: u32 = {n}u;\n{PAYLOAD_WGSL}",
        header(32)
    );
    let mut m = Models::new();
    m.add("raygen__payload", move |ctx| {
        let id = ctx.linear_index();
        if id >= ctx.param(2) {
            return Ok(());
        }
        let w = ray_words(ctx, id);
        let mut p = vec![0u32; n as usize];
        for (k, v) in p.iter_mut().enumerate() {
            *v = INIT[k % 8] ^ (k as u32).wrapping_mul(0x01010101) ^ w[14];
        }
        trace_words(ctx, &w, &mut p)?;
        for (k, v) in p.iter().enumerate() {
            ctx.write(2, id as usize * 32 + k, *v);
        }
        Ok(())
    });
    let xor = |rem: u32, mask: u32| {
        move |ctx: &mut Ctx<'_, '_>| -> Flow {
            for k in 0..n {
                if k % 3 == rem {
                    let v = ctx.get_payload(k);
                    ctx.set_payload(k, v ^ mask);
                }
            }
            Ok(())
        }
    };
    m.add("anyhit__xor", xor(0, 0x0F0F_0F0F));
    m.add("closesthit__xor", xor(1, 0x00FF_00FF));
    m.add("miss__xor", xor(2, 0xF000_000F));
    let rays = vec![
        Ray {
            aux: 0,
            ..Ray::new([0.75, 0.25, 0.0], [0.0, 0.0, -1.0])
        },
        Ray {
            aux: 0xDEAD_0000,
            ..Ray::new([0.75, 0.25, 0.0], [0.0, 0.0, -1.0])
        },
        Ray {
            aux: 0,
            ..Ray::new([5.0, 0.25, 0.0], [0.0, 0.0, -1.0])
        },
        Ray {
            aux: 0x0000_BEEF,
            ..Ray::new([5.0, 0.25, 0.0], [0.0, 0.0, -1.0])
        },
    ];
    let pipeline = PipelineDesc {
        wgsl,
        raygen: "raygen__payload".into(),
        miss: vec![Some("miss__xor".into())],
        hit: vec![hit_group(
            Some("closesthit__xor"),
            Some("anyhit__xor"),
            None,
        )],
        callables: vec![],
        exception: None,
        compile: PipelineCompileOptions {
            num_payload_values: Setting::Value(n),
            ..Default::default()
        },
        link: PipelineLinkOptions::default(),
    };
    let sbt = SbtLayout {
        miss: vec![SbtEntry::new(0, vec![0])],
        hit: vec![SbtEntry::new(0, vec![0])],
        ..Default::default()
    };
    let channels = (0..n as usize)
        .map(|k| uint_channel(&format!("payload{k}"), k))
        .collect();
    own_case(
        Group::Payload,
        if n == 1 {
            "copy_semantics_single"
        } else {
            "copy_semantics"
        },
        &format!(
            "{n} payload register(s) copied in and out of a trace, any-hit, closest-hit and miss each XOR their own words, NaN, -0, denormal and all-ones bit patterns survive bit for bit"
        ),
        &[],
        scene,
        Some(root),
        pipeline,
        m,
        sbt,
        rays,
        32,
        channels,
    )
}

const TYPES_WGSL: &str = r#"
fn anyhit__reader() {
    rt_set_payload(7u, rt_get_payload(0u) + 1u);
}

fn closesthit__writer() {
    rt_set_payload(6u, 0xC0FFEEu);
}

fn miss__writer() {
    rt_set_payload(5u, 0xBADu);
}
"#;

fn types_semantics() -> Case {
    let (scene, root) = one_quad();
    let mut m = Models::new();
    m.add("anyhit__reader", |ctx| {
        let v = ctx.get_payload(0);
        ctx.set_payload(7, v.wrapping_add(1));
        Ok(())
    });
    m.add("closesthit__writer", |ctx| {
        ctx.set_payload(6, 0xC0FFEE);
        Ok(())
    });
    m.add("miss__writer", |ctx| {
        ctx.set_payload(5, 0xBAD);
        Ok(())
    });
    let mut case = StdCase::new(
        Group::Payload,
        "types_semantics",
        "payload words with per-stage roles (any-hit reads word 0 and writes 7, closest-hit writes 6, miss writes 5): words a stage does not write come back as the caller set them (the observable part of OptiX payload types; optik has no per-word declarations)",
        &[],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some("closesthit__writer"), Some("anyhit__reader"), None)], vec![SbtEntry::new(0, vec![0])])
    .launch(4, vec![
        Ray { aux: 41, ..Ray::new([0.75, 0.25, 0.0], [0.0, 0.0, -1.0]) },
        Ray { aux: 42, ..Ray::new([5.0, 0.25, 0.0], [0.0, 0.0, -1.0]) },
        Ray { aux: 43, ..Ray::new([0.25, 0.75, 0.0], [0.0, 0.0, -1.0]) },
        Ray { aux: 44, ..Ray::new([0.25, 0.75, 0.0], [0.0, 0.0, 1.0]) },
    ])
    .record((0..8).map(ch::payload).collect());
    case.miss_groups = vec![Some("miss__writer".into())];
    case.more_wgsl = Some((TYPES_WGSL.into(), m));
    case.build()
}
