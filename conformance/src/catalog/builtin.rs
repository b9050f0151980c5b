//! The `builtin` group: the built-in values each program kind sees (ray state, ids,
//! transforms).

use super::util::*;
use crate::case::*;
use crate::image::ChannelKind;
use crate::kit::{self, Ray, StdCase, action, ch, hit_group, prog, trace_words, uint_channel};
use crate::oracle::model::Models;
use crate::scene::{Aabbs, Gas, GeomInput, InstanceDesc, Node, Scene, Triangles};
use crate::tolerance::Tolerance;
use optik::GeometryFlags;

/// Every case of the `builtin` group.
pub fn cases() -> Vec<Case> {
    vec![ray_state_per_stage(), ids_per_stage(), transforms()]
}

/// Programs that record the ray state each stage sees: 11 words per stage at `stage · 11`
/// of a 48-word record (intersection 0, any-hit 1, closest-hit 2, miss 3).
const STATE_WGSL: &str = r#"
fn write_state(stage: u32) {
    let b = ray_id() * 48u + stage * 11u;
    let o = rt_world_ray_origin();
    let d = rt_world_ray_direction();
    out[b + 0u] = bitcast<u32>(o.x);
    out[b + 1u] = bitcast<u32>(o.y);
    out[b + 2u] = bitcast<u32>(o.z);
    out[b + 3u] = bitcast<u32>(d.x);
    out[b + 4u] = bitcast<u32>(d.y);
    out[b + 5u] = bitcast<u32>(d.z);
    out[b + 6u] = bitcast<u32>(rt_ray_tmin());
    out[b + 7u] = bitcast<u32>(rt_ray_tmax());
    out[b + 8u] = rt_ray_flags();
    out[b + 9u] = rt_ray_mask();
    out[b + 10u] = bitcast<u32>(rt_ray_time());
}

fn raygen__state() {
    let id = ray_id();
    if id >= params.num_rays {
        return;
    }
    let r = rays[id];
    var p: RtPayload;
    rt_trace(params.handle, r.origin, r.dir, r.tmin, r.tmax, r.time, r.mask, r.flags, r.sbt_offset, r.sbt_stride, r.miss_index, &p);
    out[id * 48u + 44u] = p[0] | 1u;
}

fn intersection__state() {
    write_state(0u);
    var attrs: RtAttributes;
    let accepted = rt_report_intersection(rt_sbt_data_f32(2u), 3u, attrs);
}

fn anyhit__state() {
    write_state(1u);
    rt_set_payload(0u, rt_get_payload(0u) | 4u);
}

fn closesthit__state() {
    write_state(2u);
    rt_set_payload(0u, rt_get_payload(0u) | 8u);
}

fn miss__state() {
    write_state(3u);
    rt_set_payload(0u, rt_get_payload(0u) | 16u);
}
"#;

fn state_models() -> Models {
    fn write_state(ctx: &mut crate::oracle::exec::Ctx<'_, '_>, stage: usize) {
        let b = ctx.linear_index() as usize * 48 + stage * 11;
        let (o, d) = (ctx.world_ray_origin(), ctx.world_ray_direction());
        let words = [
            o[0].to_bits(),
            o[1].to_bits(),
            o[2].to_bits(),
            d[0].to_bits(),
            d[1].to_bits(),
            d[2].to_bits(),
            ctx.ray_tmin().to_bits(),
            ctx.ray_tmax().to_bits(),
            ctx.ray_flags(),
            ctx.ray_mask(),
            ctx.ray_time().to_bits(),
        ];
        for (k, w) in words.into_iter().enumerate() {
            ctx.write(2, b + k, w);
        }
    }
    let mut m = Models::new();
    m.add("raygen__state", |ctx| {
        let id = ctx.linear_index();
        if id >= ctx.param(2) {
            return Ok(());
        }
        let w: Vec<u32> = (0..16).map(|k| ctx.read(1, id as usize * 16 + k)).collect();
        let mut p = [0u32; 8];
        trace_words(ctx, &w, &mut p)?;
        ctx.write(2, id as usize * 48 + 44, p[0] | 1);
        Ok(())
    });
    m.add("intersection__state", |ctx| {
        write_state(ctx, 0);
        let t = ctx.sbt_data_f32(2);
        ctx.report_intersection(t, 3, [0; 8])?;
        Ok(())
    });
    m.add("anyhit__state", |ctx| {
        write_state(ctx, 1);
        let p = ctx.get_payload(0);
        ctx.set_payload(0, p | 4);
        Ok(())
    });
    m.add("closesthit__state", |ctx| {
        write_state(ctx, 2);
        let p = ctx.get_payload(0);
        ctx.set_payload(0, p | 8);
        Ok(())
    });
    m.add("miss__state", |ctx| {
        write_state(ctx, 3);
        let p = ctx.get_payload(0);
        ctx.set_payload(0, p | 16);
        Ok(())
    });
    m
}

fn ray_state_per_stage() -> Case {
    // Quads at z = -c over a 4 × 4 grid (one cell empty for misses), and the same as boxes whose
    // intersection program reports t = c.
    let depth = |i: u32, j: u32| 0.03125 + 0.25 * (i + 4 * j) as f32 / 16.0;
    let mut verts = Vec::new();
    let mut boxes = Vec::new();
    for j in 0..4u32 {
        for i in 0..4u32 {
            if i == 3 && j == 3 {
                continue;
            }
            let c = depth(i, j);
            verts.extend(quad(i as f32, j as f32, i as f32 + 1.0, j as f32 + 1.0, -c));
            boxes.push([
                i as f32,
                j as f32,
                -c - 0.01,
                i as f32 + 1.0,
                j as f32 + 1.0,
                -c + 0.01,
            ]);
        }
    }
    let mut scene = Scene::default();
    let tris = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(verts, GeometryFlags::NONE),
    )])));
    // One box per record so each reports its own t: per-primitive SBT offsets.
    let n = boxes.len() as u32;
    let mut aabbs = Aabbs::new(boxes, GeometryFlags::NONE);
    aabbs.flags = vec![GeometryFlags::NONE; n as usize];
    aabbs.sbt_offsets = Some(crate::scene::SbtOffsets {
        offsets: (0..n).collect(),
        size_in_bytes: 4,
        stride: 0,
    });
    let aabb = scene.add(Node::Gas(Gas::new(vec![GeomInput::Aabbs(aabbs)])));
    let mut rays = Vec::new();
    let flags = [0u32, 4, 16, 4 | 16];
    let masks = [0xFFu32, 0x01, 0x80, 0x3C];
    for j in 0..4u32 {
        for i in 0..4u32 {
            let k = (i + 4 * j) as usize;
            let mut r = Ray::new([i as f32 + 0.375, j as f32 + 0.625, 0.5], [0.0, 0.0, -1.0])
                .interval(0.0078125 * (k % 3) as f32, 9.0 - 0.5 * (k % 4) as f32)
                .at_time(0.25 * (k % 4) as f32);
            r.flags = flags[k % 4];
            r.mask = masks[(k / 4) % 4];
            rays.push(r);
        }
    }
    let groups = vec![
        HitGroupDesc {
            closest_hit: Some("closesthit__state".into()),
            any_hit: Some("anyhit__state".into()),
            ..Default::default()
        },
        HitGroupDesc {
            closest_hit: Some("closesthit__state".into()),
            any_hit: Some("anyhit__state".into()),
            intersection: Some("intersection__state".into()),
            builtin: None,
        },
    ];
    // Record 0: triangles. Records 1..=15: box k reports t = c_k + 0.5 (from the ray origin).
    let mut records = vec![SbtEntry::new(0, vec![0, 0, 0])];
    let mut k = 0u32;
    for j in 0..4u32 {
        for i in 0..4u32 {
            if i == 3 && j == 3 {
                continue;
            }
            records.push(SbtEntry::new(
                1,
                vec![1 + k, 0, (depth(i, j) + 0.5).to_bits()],
            ));
            k += 1;
        }
    }
    let box_rays: Vec<Ray> = rays
        .iter()
        .map(|r| Ray {
            sbt_offset: 1,
            ..*r
        })
        .collect();
    let mut case = StdCase::new(
        Group::Builtin,
        "ray_state_per_stage",
        "world origin, direction, tmin, tmax, flags, mask and time as intersection, any-hit, closest-hit and miss see them; tmax is the closest so far in intersection, the candidate in any-hit, the hit in closest-hit, the traced tmax in miss; time is 0 without motion",
        &[Rule::TriangleOpenInterval, Rule::CustomClosedInterval],
        scene,
        None,
    )
    .hits(groups, records)
    .launch_on(Some(tris), 4, rays)
    .launch_on(Some(aabb), 4, box_rays);
    case.miss_groups = vec![Some("miss__state".into())];
    case.raygen = "raygen__state";
    case.more_wgsl = Some((STATE_WGSL.into(), state_models()));
    let mut case = case.build();
    let fields = [
        "ox", "oy", "oz", "dx", "dy", "dz", "tmin", "tmax", "flags", "mask", "time",
    ];
    let mut channels = Vec::new();
    for (s, stage) in ["is", "ah", "ch", "ms"].iter().enumerate() {
        for (f, field) in fields.iter().enumerate() {
            let word = s * 11 + f;
            channels.push(if *field == "flags" || *field == "mask" {
                uint_channel(&format!("{stage}_{field}"), word)
            } else {
                kit::float_channel(&format!("{stage}_{field}"), word, Tolerance::F6)
            });
        }
    }
    channels.push(uint_channel("programs", 44));
    case.record = RecordSpec {
        binding: 2,
        layout: RecordLayout::PerIndex { stride: 48 },
        channels,
        judgement: Judgement::PerRecord,
    };
    for l in &mut case.launches {
        let n = l.dims[0] as usize * l.dims[1] as usize;
        l.buffers
            .iter_mut()
            .filter(|b| b.binding == 2)
            .for_each(|b| b.words = vec![0; n * 48]);
    }
    case
}

const IDS_WGSL: &str = r#"
fn anyhit__ids() {
    rt_set_payload(0u, rt_get_payload(0u) | 4u);
    rt_set_payload(3u, rt_primitive_index());
    rt_set_payload(4u, rt_instance_id());
    rt_set_payload(5u, rt_instance_index());
    rt_set_payload(6u, rt_sbt_gas_index());
}
"#;

fn ids_models() -> Models {
    let mut m = Models::new();
    m.add("anyhit__ids", |ctx| {
        let p = ctx.get_payload(0);
        ctx.set_payload(0, p | 4);
        let v = [
            ctx.primitive_index(),
            ctx.instance_id(),
            ctx.instance_index(),
            ctx.sbt_gas_index(),
        ];
        for (k, x) in v.into_iter().enumerate() {
            ctx.set_payload(3 + k as u32, x);
        }
        Ok(())
    });
    m
}

fn ids_per_stage() -> Case {
    // One GAS of 8 inputs (2 triangles each, primitive index offset 100·input), 4 instances
    // with ids 2·index and SBT offsets 8·index.
    let mut scene = Scene::default();
    let inputs = (0..8)
        .map(|g| {
            let mut t = Triangles::soup(
                quad(g as f32, 0.0, g as f32 + 1.0, 1.0, -1.0),
                GeometryFlags::NONE,
            );
            t.prim_index_offset = 100 * g;
            GeomInput::Triangles(t)
        })
        .collect();
    let gas = scene.add(Node::Gas(Gas::new(inputs)));
    let instances = (0..4)
        .map(|i| InstanceDesc {
            id: 2 * i,
            sbt_offset: 8 * i,
            ..InstanceDesc::of(gas).at(translate([0.0, 2.0 * i as f32, 0.0]))
        })
        .collect();
    let root = scene.add(Node::Ias(instances));
    let mut rays = Vec::new();
    for i in 0..4 {
        for g in 0..8 {
            for (x, y) in [(0.75f32, 0.25f32), (0.25, 0.75)] {
                rays.push(Ray::new(
                    [g as f32 + x, 2.0 * i as f32 + y, 1.0],
                    [0.0, 0.0, -1.0],
                ));
            }
        }
    }
    let records = (0..32)
        .map(|k| SbtEntry::new(0, vec![k, action::ACCEPT]))
        .collect();
    let mut case = StdCase::new(
        Group::Builtin,
        "ids_per_stage",
        "primitive index (with per-input offsets), instance id, instance index and SBT GAS index as any-hit and closest-hit see them, over 4 instances × 8 inputs",
        &[Rule::SbtIndex],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some(prog::CH), Some("anyhit__ids"), None)], records)
    .launch(16, rays)
    .record(vec![
        ch::prim(),
        ch::inst_id(),
        ch::inst_index(),
        ch::gas_index(),
        ch::sbt_index(),
        ch::payload(3),
        ch::payload(4),
        ch::payload(5),
        ch::payload(6),
    ]);
    case.more_wgsl = Some((IDS_WGSL.into(), ids_models()));
    case.build()
}

/// A closest-hit program recording the transforms and the object-space ray: words 0..11
/// object-to-world, 12..23 world-to-object (3×4 row-major), 24..29 object origin and
/// direction, 30 hit, 31 instance id, 32 SBT record data word 0, 33 instance index, 34 hit
/// kind, 35 t — of a 40-word record.
pub const XFORM_WGSL: &str = r#"
fn closesthit__xform() {
    let b = ray_id() * 40u;
    let m = rt_object_to_world();
    let w = rt_world_to_object();
    for (var r = 0u; r < 3u; r++) {
        for (var c = 0u; c < 4u; c++) {
            out[b + r * 4u + c] = bitcast<u32>(m[c][r]);
            out[b + 12u + r * 4u + c] = bitcast<u32>(w[c][r]);
        }
    }
    let o = rt_object_ray_origin();
    let d = rt_object_ray_direction();
    out[b + 24u] = bitcast<u32>(o.x);
    out[b + 25u] = bitcast<u32>(o.y);
    out[b + 26u] = bitcast<u32>(o.z);
    out[b + 27u] = bitcast<u32>(d.x);
    out[b + 28u] = bitcast<u32>(d.y);
    out[b + 29u] = bitcast<u32>(d.z);
    out[b + 30u] = 1u;
    out[b + 31u] = rt_instance_id();
    out[b + 32u] = rt_sbt_data_u32(0u);
    out[b + 33u] = rt_instance_index();
    out[b + 34u] = rt_hit_kind();
    out[b + 35u] = bitcast<u32>(rt_ray_tmax());
}

fn miss__xform() {
    out[ray_id() * 40u + 30u] = 0u;
}

fn raygen__xform() {
    let id = ray_id();
    if id >= params.num_rays {
        return;
    }
    let r = rays[id];
    var p: RtPayload;
    rt_trace(params.handle, r.origin, r.dir, r.tmin, r.tmax, r.time, r.mask, r.flags, r.sbt_offset, r.sbt_stride, r.miss_index, &p);
}
"#;

/// Models of [`XFORM_WGSL`].
pub fn xform_models() -> Models {
    let mut m = Models::new();
    m.add("closesthit__xform", |ctx| {
        let b = ctx.linear_index() as usize * 40;
        let (m, w) = (ctx.object_to_world(), ctx.world_to_object());
        for k in 0..12 {
            ctx.write(2, b + k, m[k].to_bits());
            ctx.write(2, b + 12 + k, w[k].to_bits());
        }
        let (o, d) = (ctx.object_ray_origin(), ctx.object_ray_direction());
        for k in 0..3 {
            ctx.write(2, b + 24 + k, o[k].to_bits());
            ctx.write(2, b + 27 + k, d[k].to_bits());
        }
        let extra = [
            1,
            ctx.instance_id(),
            ctx.sbt_data_u32(0),
            ctx.instance_index(),
            ctx.hit_kind(),
            ctx.ray_tmax().to_bits(),
        ];
        for (k, v) in extra.into_iter().enumerate() {
            ctx.write(2, b + 30 + k, v);
        }
        Ok(())
    });
    m.add("miss__xform", |ctx| {
        let b = ctx.linear_index() as usize * 40;
        ctx.write(2, b + 30, 0);
        Ok(())
    });
    m.add("raygen__xform", |ctx| {
        let id = ctx.linear_index();
        if id >= ctx.param(2) {
            return Ok(());
        }
        let w: Vec<u32> = (0..16).map(|k| ctx.read(1, id as usize * 16 + k)).collect();
        let mut p = [0u32; 8];
        trace_words(ctx, &w, &mut p)
    });
    m
}

/// The channels of [`XFORM_WGSL`]'s record, floats with `t`.
pub fn xform_channels(t: Tolerance) -> Vec<ChannelSpec> {
    let mut v = Vec::new();
    for k in 0..12 {
        v.push(kit::float_channel(&format!("o2w{k}"), k, t));
        v.push(kit::float_channel(&format!("w2o{k}"), 12 + k, t));
    }
    for (k, n) in ["obj_ox", "obj_oy", "obj_oz", "obj_dx", "obj_dy", "obj_dz"]
        .iter()
        .enumerate()
    {
        v.push(kit::float_channel(n, 24 + k, t));
    }
    for (word, name) in [
        (30, "hit"),
        (31, "inst_id"),
        (32, "sbt_index"),
        (33, "inst_index"),
        (34, "hit_kind"),
    ] {
        v.push(ChannelSpec {
            name: name.into(),
            word,
            kind: ChannelKind::Uint,
            tolerance: Tolerance::Exact,
        });
    }
    v.push(kit::float_channel("t", 35, t));
    v
}

/// A case of [`XFORM_WGSL`] programs over `scene` and `rays`.
#[allow(clippy::too_many_arguments)]
pub fn xform_case(
    group: Group,
    name: &str,
    summary: &str,
    guards: &[Rule],
    scene: Scene,
    root: usize,
    records: Vec<SbtEntry>,
    rays: Vec<Ray>,
    t: Tolerance,
) -> Case {
    let n = rays.len() as u32;
    let mut case = StdCase::new(group, name, summary, guards, scene, Some(root))
        .hits(
            vec![hit_group(Some("closesthit__xform"), None, None)],
            records,
        )
        .launch(n.min(16), rays)
        .record(xform_channels(t));
    case.miss_groups = vec![Some("miss__xform".into())];
    case.raygen = "raygen__xform";
    case.more_wgsl = Some((XFORM_WGSL.into(), xform_models()));
    let mut case = case.build();
    case.record.layout = RecordLayout::PerIndex { stride: 40 };
    for l in &mut case.launches {
        let n = l.dims[0] as usize * l.dims[1] as usize;
        l.buffers
            .iter_mut()
            .filter(|b| b.binding == 2)
            .for_each(|b| b.words = vec![0; n * 40]);
    }
    case
}

fn transforms() -> Case {
    let (w, h) = (16.0f32, 16.0f32);
    let mut scene = Scene::default();
    let gas = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(
            quad(-0.5, -0.5, 0.5, 0.5, 0.0),
            GeometryFlags::DISABLE_ANYHIT,
        ),
    )])));
    let ms = [
        translate([0.125 / w, 0.0625 / h, -1.0]),
        translate([3.0 - 0.125 / w, -0.0625 / h, -1.0]),
        rotate_translate([1.0, 2.0, 3.0], 0.7, [6.0, 0.0, -2.0]),
        {
            let mut m = rotate_translate([0.0, 1.0, 0.0], 0.3, [9.0, 0.0, -2.0]);
            for c in 0..3 {
                m[c] *= 1.5;
                m[4 + c] *= 0.5;
            }
            m
        },
    ];
    let instances = ms
        .iter()
        .enumerate()
        .map(|(i, m)| InstanceDesc {
            id: i as u32,
            ..InstanceDesc::of(gas).at(*m)
        })
        .collect();
    let root = scene.add(Node::Ias(instances));
    let rays: Vec<Ray> = [0.0f32, 3.0, 6.0, 9.0]
        .iter()
        .flat_map(|x| {
            [(0.1f32, 0.2f32), (-0.15, 0.05), (0.05, -0.1), (0.2, -0.2)]
                .map(|(dx, dy)| Ray::new([x + dx, dy, 1.0], [0.01, 0.02, -1.0]))
        })
        .collect();
    xform_case(
        Group::Builtin,
        "transforms",
        "object-to-world, world-to-object and the object-space ray in closest-hit, for translations of ±1/8 and ±1/16 pixel and rotated, scaled instances (CTS objecttoworld/worldtoobject), U16",
        &[],
        scene,
        root,
        vec![SbtEntry::new(0, vec![0])],
        rays,
        Tolerance::U16 { scale: 10.0 },
    )
}
