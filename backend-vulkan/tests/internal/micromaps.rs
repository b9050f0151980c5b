//! Opacity micromaps on optik's triangle stage: the state of the micro-triangle a hit falls
//! in (both formats, the special indices) drops transparent hits, makes opaque ones opaque
//! and leaves unknown ones to any-hit, with FORCE_OPACITY_MICROMAP_2_STATE (ray and
//! instance), DISABLE_OPACITY_MICROMAPS and every other opacity flag as
//! `optik_api::semantics::opacity::resolve` defines them. The micro-triangles come from the
//! shared bird-curve indexing (`optik_accel::micromap`). A rule for every backend that only this
//! test checks at subdivision levels above 0: it is to move to optik-conformance's
//! `tests/rules/prim.rs`, which has level 1's order and pipelines that disallow micromaps.

use crate::common::*;
use optik_accel::micromap::micro_triangle;
use optik_api::semantics::opacity::{CandidateFate, MicromapState, resolve};
use optik_api::*;

const PROGRAMS: &str = r#"
struct Params { handle: vec2<u32>, n: u32, pad: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
// origin xy (z = 5, straight down) and ray flags (bits) per ray
@group(0) @binding(2) var<storage, read> rays: array<f32>;

fn raygen__rg() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    p[0] = 0xFFFFu;
    p[1] = 0u;
    rt_trace(params.handle, vec3<f32>(rays[3u * i], rays[3u * i + 1u], 5.0), vec3<f32>(0.0, 0.0, -1.0),
        0.0, 100.0, 0.0, 0xFFu, bitcast<u32>(rays[3u * i + 2u]), 0u, 1u, 0u, &p);
    out[2u * i] = p[0];
    out[2u * i + 1u] = p[1];
}

fn closesthit__ch() {
    rt_set_payload(0u, rt_primitive_index() * 16u + rt_instance_id());
}

fn anyhit__ah() {
    rt_set_payload(1u, rt_get_payload(1u) + 1u);
}

fn miss__ms() {
}
"#;

/// The states of a level-2 micromap (16 micro-triangles), every state four times.
fn states_level_2() -> Vec<u32> {
    (0..16).map(|i| (i * 7 + 3) % 4).collect()
}

/// Packs states `bits` bits each, the lowest bits first.
fn pack(states: &[u32], bits: u32) -> Vec<u8> {
    let mut out = vec![0u8; (states.len() * bits as usize).div_ceil(8)];
    for (i, s) in states.iter().enumerate() {
        let bit = i * bits as usize;
        out[bit / 8] |= (*s as u8) << (bit % 8);
    }
    out
}

/// The centroid of micro-triangle `index` at `level`, in barycentrics (u, v).
fn centroid(index: u32, level: u32) -> (f32, f32) {
    let c = micro_triangle(index, level);
    (
        ((c[0][0] + c[1][0] + c[2][0]) / 3.0) as f32,
        ((c[0][1] + c[1][1] + c[2][1]) / 3.0) as f32,
    )
}

#[test]
fn micromap_states_decide_opacity_with_every_flag() {
    let dev = device();
    let states = states_level_2();
    // Micromap 0: four-state, micromap 1: two-state (states & 1), both level 2.
    let mut data = pack(&states, 2);
    let two_state_at = data.len() as u32;
    data.extend(pack(&states.iter().map(|s| s & 1).collect::<Vec<_>>(), 1));
    let array = dev
        .create_opacity_micromap_array(&OpacityMicromapArrayDesc {
            micromaps: vec![
                OpacityMicromapDesc {
                    byte_offset: 0,
                    subdivision_level: 2,
                    format: OpacityMicromapFormat::FourState,
                },
                OpacityMicromapDesc {
                    byte_offset: two_state_at,
                    subdivision_level: 2,
                    format: OpacityMicromapFormat::TwoState,
                },
            ],
            data,
        })
        .unwrap();
    // Six unit triangles side by side (x = 2k): micromap 0, micromap 1, then the special
    // indices -1..-4.
    let indices: [i32; 6] = [0, 1, -1, -2, -3, -4];
    let mut vertices = Vec::new();
    for k in 0..indices.len() {
        let x = 2.0 * k as f32;
        vertices.extend_from_slice(&[x, 0.0, 0.0, x + 1.0, 0.0, 0.0, x, 1.0, 0.0]);
    }
    let index_buffer = dev.buffer_with(bytemuck::cast_slice(&indices));
    let gas_of = |flags: GeometryFlags| {
        let mut t = TriangleArray::new(
            BufferView::new(dev.f32_buffer(&vertices)),
            (vertices.len() / 3) as u32,
            flags,
        );
        t.opacity_micromap = Some(TriangleOpacityMicromap {
            array,
            index_buffer: Some(BufferView::new(index_buffer)),
            index_size_in_bytes: 4,
            index_stride: 0,
            base_index: 0,
        });
        dev.accel_build(&AccelBuildOptions::default(), &[BuildInput::Triangles(t)])
            .unwrap()
    };
    let geometries = [GeometryFlags::NONE, GeometryFlags::DISABLE_ANYHIT];
    let instance_flags = [
        InstanceFlags::NONE,
        InstanceFlags::FORCE_OPACITY_MICROMAP_2_STATE,
        InstanceFlags::DISABLE_OPACITY_MICROMAPS,
        InstanceFlags::DISABLE_ANYHIT,
        InstanceFlags::ENFORCE_ANYHIT,
    ];
    // Instance (g, f) at y = 2 (g * 5 + f), id g * 5 + f.
    let mut instances = Vec::new();
    for (g, geometry) in geometries.iter().enumerate() {
        let child = dev.traversable_handle(gas_of(*geometry)).unwrap();
        for (f, flags) in instance_flags.iter().enumerate() {
            let mut inst = Instance::new(child);
            let id = (g * instance_flags.len() + f) as u32;
            inst.transform[7] = 2.0 * id as f32;
            inst.instance_id = id;
            inst.flags = flags.0;
            instances.push(inst);
        }
    }
    let ias = dev.instances(&instances);
    let ray_flags = [
        RayFlags::NONE,
        RayFlags::FORCE_OPACITY_MICROMAP_2_STATE,
        RayFlags::ENFORCE_ANYHIT,
        RayFlags::DISABLE_ANYHIT,
        RayFlags::CULL_DISABLED_ANYHIT,
        RayFlags::CULL_ENFORCED_ANYHIT,
    ];
    let m = dev.module(PROGRAMS);
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let ms = dev.group(ProgramGroupDesc::Miss(Some(prog(m, "miss__ms"))));
    let hg = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: Some(prog(m, "closesthit__ch")),
        any_hit: Some(prog(m, "anyhit__ah")),
        intersection: None,
        builtin: BuiltinIntersector::Triangle,
    });
    let pipeline = dev.pipeline(&[rg, ms, hg], 1);
    assert!(dev.pipeline_features(pipeline).unwrap().opacity_micromaps);
    let mut table = Table::new(rg);
    table.miss.push((ms, &[]));
    table.hit.push((hg, &[]));
    let sbt = table.build(&dev);
    // Every ray flag × instance × triangle × micro-triangle.
    let mut rays: Vec<f32> = Vec::new();
    let mut expected = Vec::new();
    for rf in ray_flags {
        for (g, geometry) in geometries.iter().enumerate() {
            for (f, flags) in instance_flags.iter().enumerate() {
                let id = (g * instance_flags.len() + f) as u32;
                for (k, index) in indices.iter().enumerate() {
                    for micro in 0..16 {
                        let (u, v) = centroid(micro, 2);
                        rays.extend_from_slice(&[
                            2.0 * k as f32 + u,
                            2.0 * id as f32 + v,
                            f32::from_bits(rf.0),
                        ]);
                        let state = match index {
                            0 => states[micro as usize],
                            1 => states[micro as usize] & 1,
                            special => (-special - 1) as u32,
                        };
                        let omm = (!flags.contains(InstanceFlags::DISABLE_OPACITY_MICROMAPS))
                            .then(|| MicromapState::from_code(state));
                        let fate = resolve(*geometry, *flags, rf, omm);
                        expected.push((fate, k as u32 * 16 + id, format!(
                            "ray {rf:?}, geometry {geometry:?}, instance {flags:?}, micromap index {index}, micro-triangle {micro} (state {state})"
                        )));
                    }
                }
            }
        }
    }
    let n = expected.len() as u32;
    let out = run_rays(
        &dev,
        pipeline,
        &sbt,
        dev.traversable_handle(ias).unwrap(),
        n,
        2,
        &[Resource::buffer(2, dev.f32_buffer(&rays))],
    );
    let mut mismatches = Vec::new();
    for (k, (fate, hit, what)) in expected.iter().enumerate() {
        let got = (out[2 * k], out[2 * k + 1]);
        let want = match fate {
            CandidateFate::Culled => (0xFFFF, 0),
            CandidateFate::Opaque => (*hit, 0),
            CandidateFate::NonOpaque => (*hit, 1),
        };
        if got != want {
            mismatches.push(format!("{what}: got {got:?}, want {want:?} ({fate:?})"));
        }
    }
    assert!(
        mismatches.is_empty(),
        "{} of {n} rays differ:\n{}",
        mismatches.len(),
        mismatches[..mismatches.len().min(20)].join("\n")
    );
    dev.assert_no_messages();
}
