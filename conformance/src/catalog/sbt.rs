//! Group F (`sbt`): hit record index math, the bits that count, miss indices, per-primitive
//! records, record data layout, null programs.

use super::tri::with_offsets;
use super::util::*;
use crate::case::*;
use crate::kit::{Ray, StdCase, action, ch, hit_group, prog};
use crate::oracle::model::Models;
use crate::scene::{Aabbs, Gas, GeomInput, InstanceDesc, Node, Scene, Triangles};
use optik::{GeometryFlags, RayFlags};

/// Every case of the group.
pub fn cases() -> Vec<Case> {
    vec![
        hit_index_grid(),
        high_bits_ignored(),
        miss_index(),
        gas_index_multi_record(),
        record_data_layout(),
        null_programs(),
    ]
}

/// 32 unit quads in a checkerboard of 8 × 8 cells, shuffled into GASes of 3 inputs (one quad
/// each), one instance per GAS with SBT offset = instance index (CTS shader_binding_table).
fn checkerboard(scene: &mut Scene) -> (usize, Vec<[f32; 2]>) {
    let mut cells: Vec<[f32; 2]> = (0..64)
        .filter(|k| (k % 8 + k / 8) % 2 == 0)
        .map(|k| [(k % 8) as f32, (k / 8) as f32])
        .collect();
    let mut rng = Rng::new(1410);
    for i in (1..cells.len()).rev() {
        let j = rng.next_u32() as usize % (i + 1);
        cells.swap(i, j);
    }
    let mut instances = Vec::new();
    for (g, chunk) in cells.chunks(3).enumerate() {
        let inputs = chunk
            .iter()
            .map(|c| {
                GeomInput::Triangles(Triangles::soup(
                    quad(c[0], c[1], c[0] + 1.0, c[1] + 1.0, -1.0),
                    GeometryFlags::DISABLE_ANYHIT,
                ))
            })
            .collect();
        let gas = scene.add(Node::Gas(Gas::new(inputs)));
        instances.push(InstanceDesc {
            id: g as u32,
            sbt_offset: g as u32,
            ..InstanceDesc::of(gas)
        });
    }
    (scene.add(Node::Ias(instances)), cells)
}

fn hit_index_grid() -> Case {
    let mut scene = Scene::default();
    let (root, cells) = checkerboard(&mut scene);
    let mut rays = Vec::new();
    for off in 0..4u32 {
        for stride in 0..6u32 {
            for c in &cells {
                rays.push(Ray {
                    sbt_offset: off,
                    sbt_stride: stride,
                    ..Ray::new([c[0] + 0.75, c[1] + 0.25, 0.0], [0.0, 0.0, -1.0])
                });
            }
        }
    }
    // Largest index: instance 10 + offset 3 + GAS index 2 × stride 5 = 23.
    let records = (0..24).map(|k| SbtEntry::new(0, vec![k])).collect();
    StdCase::new(
        Group::Sbt,
        "hit_index_grid",
        "hit record = instance offset + ray offset + GAS index × ray stride, over 11 instances × 3 inputs × offsets 0..3 × strides 0..5 (CTS shader_binding_table.indexing_hit)",
        &[Rule::SbtIndex],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some(prog::CH), None, None)], records)
    .launch(32, rays)
    .record(vec![ch::hit(), ch::sbt_index(), ch::gas_index(), ch::inst_index()])
    .build()
}

fn high_bits_ignored() -> Case {
    let mut scene = Scene::default();
    let (root, cells) = checkerboard(&mut scene);
    let mut rays = Vec::new();
    let garbage = [
        (0x13u32, 0xF2u32),
        (0xFFFF_FFF0 | 2, 0x1_0001),
        (0x70, 0x30),
        (0x8000_0001, 0xA5A5_A5A3),
    ];
    for (k, c) in cells.iter().enumerate() {
        let (off, stride) = garbage[k % 4];
        let base = Ray::new([c[0] + 0.75, c[1] + 0.25, 0.0], [0.0, 0.0, -1.0]);
        rays.push(Ray {
            sbt_offset: off,
            sbt_stride: stride,
            ..base
        });
        // Masks: bits above 8 do not count (0x100 sees nothing, 0x101 sees mask 0x01).
        rays.push(Ray {
            mask: 0x100 | (k as u32 % 2),
            ..base
        });
        // Miss indices: bits above 16 do not count.
        rays.push(Ray {
            miss_index: 0x1_0001 + 0x10000 * k as u32,
            ..Ray::new([c[0] + 0.5, c[1] + 0.5, 0.0], [0.0, 0.0, 1.0])
        });
    }
    let records = (0..32).map(|k| SbtEntry::new(0, vec![k])).collect();
    let mut case = StdCase::new(
        Group::Sbt,
        "high_bits_ignored",
        "only the low 4 bits of SBT offset and stride, 16 of the miss index and 8 of the visibility mask count (CTS extrabits, cullmask_extrabits)",
        &[Rule::FlagBitsAndWidths, Rule::SbtIndex],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some(prog::CH), None, None)], records)
    .launch(48, rays)
    .record(vec![ch::hit(), ch::sbt_index(), ch::programs()]);
    case.miss_groups = vec![Some(prog::MS.into())];
    case.miss_records = vec![SbtEntry::new(0, vec![100]), SbtEntry::new(0, vec![101])];
    case.build()
}

fn miss_index() -> Case {
    let mut scene = Scene::default();
    let gas = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(
            quad(0.0, 0.0, 1.0, 1.0, -1.0),
            GeometryFlags::DISABLE_ANYHIT,
        ),
    )])));
    let root = scene.add(Node::Ias(vec![InstanceDesc {
        mask: 0x0F,
        ..InstanceDesc::of(gas)
    }]));
    let hit = Ray::new([0.75, 0.25, 0.0], [0.0, 0.0, -1.0]);
    let mut rays = Vec::new();
    for m in 0..4 {
        rays.push(Ray {
            miss_index: m,
            ..Ray::new([5.0, 5.0, 0.0], [0.0, 0.0, -1.0])
        });
    }
    // Misses by cause (CTS non_uniform_args): culling flag, mask, origin, tmin, direction, tmax.
    rays.push(Ray {
        miss_index: 1,
        ..hit.flags(RayFlags::CULL_FRONT_FACING_TRIANGLES.0)
    });
    rays.push(Ray {
        miss_index: 2,
        mask: 0xF0,
        ..hit
    });
    rays.push(Ray {
        miss_index: 3,
        origin: [3.0, 0.25, 0.0],
        ..hit
    });
    rays.push(Ray {
        miss_index: 0,
        ..hit.interval(2.0, 10.0)
    });
    rays.push(Ray {
        miss_index: 1,
        dir: [0.0, 0.0, 1.0],
        ..hit
    });
    rays.push(Ray {
        miss_index: 2,
        ..hit.interval(0.0, 0.5)
    });
    rays.push(Ray {
        miss_index: 3,
        ..hit
    });
    let mut case = StdCase::new(
        Group::Sbt,
        "miss_index",
        "four miss programs selected by the miss index, for plain misses and for misses caused by flags, mask, origin, tmin, direction and tmax (CTS indexing_miss, non_uniform_args)",
        &[Rule::SbtIndex],
        scene,
        Some(root),
    )
    .launch(11, rays)
    .record(vec![ch::hit(), ch::sbt_index(), ch::programs()]);
    case.miss_records = (0..4).map(|k| SbtEntry::new(0, vec![200 + k])).collect();
    case.build()
}

fn gas_index_multi_record() -> Case {
    // Inputs with 1 or 3 records; per-primitive offsets stored in 8, 16 and 32 bits with strides.
    let f = GeometryFlags::DISABLE_ANYHIT;
    let row = |y: f32, n: usize| -> Vec<[f32; 3]> {
        (0..n)
            .flat_map(|i| quad(i as f32, y, i as f32 + 1.0, y + 1.0, -1.0))
            .collect()
    };
    let inputs = vec![
        GeomInput::Triangles(Triangles::soup(row(0.0, 3), f)),
        GeomInput::Triangles(with_offsets(
            Triangles::soup(row(2.0, 3), f),
            vec![0, 0, 2, 2, 1, 1],
            1,
            3,
            vec![f; 3],
        )),
        GeomInput::Triangles(with_offsets(
            Triangles::soup(row(4.0, 3), f),
            vec![1, 2, 0, 1, 2, 0],
            2,
            0,
            vec![f; 3],
        )),
        GeomInput::Triangles(with_offsets(
            Triangles::soup(row(6.0, 3), f),
            vec![2, 1, 2, 0, 0, 1],
            4,
            8,
            vec![f; 3],
        )),
    ];
    let mut aabbs = Aabbs::new(
        (0..3)
            .map(|i| [i as f32, 8.0, -1.5, i as f32 + 1.0, 9.0, -0.5])
            .collect(),
        f,
    );
    aabbs.flags = vec![f; 3];
    aabbs.sbt_offsets = Some(crate::scene::SbtOffsets {
        offsets: vec![2, 0, 1],
        size_in_bytes: 2,
        stride: 4,
    });
    let mut scene = Scene::default();
    let tris = scene.add(Node::Gas(Gas::new(inputs)));
    let boxes = scene.add(Node::Gas(Gas::new(vec![GeomInput::Aabbs(aabbs)])));
    let root = scene.add(Node::Ias(vec![
        InstanceDesc::of(tris),
        InstanceDesc {
            sbt_offset: 10,
            ..InstanceDesc::of(boxes)
        },
    ]));
    let mut rays = Vec::new();
    for y in 0..5 {
        for x in 0..3 {
            for (dx, dy) in [(0.75f32, 0.25f32), (0.25, 0.75)] {
                rays.push(Ray::new(
                    [x as f32 + dx, 2.0 * y as f32 + dy, 0.0],
                    [0.0, 0.0, -1.0],
                ));
            }
        }
    }
    let mut records: Vec<SbtEntry> = (0..10)
        .map(|k| SbtEntry::new(0, vec![k, action::ACCEPT]))
        .collect();
    records.extend((10..13).map(|k| {
        SbtEntry::new(
            1,
            vec![
                k,
                action::ACCEPT,
                0,
                0,
                1,
                (1.0f32 + 0.125 * (k - 10) as f32).to_bits(),
            ],
        )
    }));
    StdCase::new(
        Group::Sbt,
        "gas_index_multi_record",
        "inputs spanning 1 or 3 SBT records with per-primitive offsets in 8/16/32-bit strided buffers: sbt_gas_index = input's first record + the primitive's offset (OptiX; the Vulkan backend flattens)",
        &[Rule::SbtIndex],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some(prog::CH), None, None), hit_group(Some(prog::CH_ATTRS), None, Some(prog::IS_FIXED))], records)
    .launch(6, rays)
    .record(vec![ch::hit(), ch::prim(), ch::gas_index(), ch::sbt_index()])
    .build()
}

const DATA_WGSL: &str = r#"
fn closesthit__data() {
    record_hit();
    let n = rt_sbt_data_u32(2u);
    rt_set_payload(3u, rt_sbt_data_u32(n - 1u));
    rt_set_payload(4u, rt_sbt_data_u32(n / 2u));
    rt_set_payload(5u, bitcast<u32>(rt_sbt_data_f32(3u)));
}

fn miss__data() {
    out[slot(0u)] = 0u;
    let n = rt_sbt_data_u32(2u);
    rt_set_payload(3u, rt_sbt_data_u32(n - 1u));
    rt_set_payload(6u, rt_sbt_data_u32(0u));
}
"#;

fn record_data_layout() -> Case {
    let lens = [3u32, 4, 8, 17, 32, 64];
    let cells: Vec<f32> = (0..lens.len()).map(|i| i as f32 * 2.0).collect();
    let verts: Vec<[f32; 3]> = cells
        .iter()
        .flat_map(|x| quad(*x, 0.0, x + 1.0, 1.0, -1.0))
        .collect();
    let mut t = Triangles::soup(verts, GeometryFlags::DISABLE_ANYHIT);
    t = with_offsets(
        t,
        (0..lens.len() as u32).flat_map(|k| [k, k]).collect(),
        4,
        0,
        vec![GeometryFlags::DISABLE_ANYHIT; lens.len()],
    );
    let (scene, root) = Scene::single(Gas::new(vec![GeomInput::Triangles(t)]));
    let data = |k: u32, len: u32| -> Vec<u32> {
        let mut d = vec![k, action::ACCEPT, len];
        d.extend((3..len).map(|j| {
            if j == 3 {
                1.5f32.to_bits()
            } else {
                (k << 16) | j
            }
        }));
        d
    };
    let records = lens
        .iter()
        .enumerate()
        .map(|(k, l)| SbtEntry::new(0, data(k as u32, *l)))
        .collect();
    let rays: Vec<Ray> = cells
        .iter()
        .map(|x| Ray::new([x + 0.75, 0.25, 0.0], [0.0, 0.0, -1.0]))
        .chain([Ray::new([-5.0, 0.0, 0.0], [0.0, 0.0, -1.0])])
        .collect();
    let mut m = Models::new();
    m.add("closesthit__data", |ctx| {
        let s = ctx.linear_index() as usize * 32;
        let words = [
            (0, 1),
            (1, ctx.ray_tmax().to_bits()),
            (2, ctx.primitive_index()),
            (3, ctx.instance_id()),
            (4, ctx.instance_index()),
            (5, ctx.sbt_gas_index()),
            (6, ctx.hit_kind()),
            (15, ctx.sbt_data_u32(0)),
        ];
        for (k, v) in words {
            ctx.write(2, s + k, v);
        }
        let p = ctx.get_payload(0);
        ctx.set_payload(0, p | 8);
        let n = ctx.sbt_data_u32(2);
        let (a, b, c) = (
            ctx.sbt_data_u32(n - 1),
            ctx.sbt_data_u32(n / 2),
            ctx.sbt_data_f32(3).to_bits(),
        );
        ctx.set_payload(3, a);
        ctx.set_payload(4, b);
        ctx.set_payload(5, c);
        Ok(())
    });
    m.add("miss__data", |ctx| {
        let s = ctx.linear_index() as usize * 32;
        ctx.write(2, s, 0);
        let n = ctx.sbt_data_u32(2);
        let a = ctx.sbt_data_u32(n - 1);
        ctx.set_payload(3, a);
        let b = ctx.sbt_data_u32(0);
        ctx.set_payload(6, b);
        Ok(())
    });
    let mut case = StdCase::new(
        Group::Sbt,
        "record_data_layout",
        "SBT record data of 12 to 256 bytes read back word for word, in a table whose stride (512) is larger than every record (CTS handle_alignment, shaderRecord*; u32/f32 only: the device API reads no other types)",
        &[Rule::SbtIndex],
        scene,
        Some(root),
    )
    .hits(vec![hit_group(Some("closesthit__data"), None, None)], records)
    .launch(7, rays)
    .record(vec![ch::hit(), ch::sbt_index(), ch::payload(3), ch::payload(4), ch::payload(5), ch::payload(6)]);
    case.miss_groups = vec![Some("miss__data".into())];
    case.miss_records = vec![SbtEntry::new(0, data(99, 40))];
    case.more_wgsl = Some((DATA_WGSL.into(), m));
    let mut case = case.build();
    case.sbt.stride = Some(512);
    case
}

fn null_programs() -> Case {
    // Hit groups: 0 null closest-hit, 1 null any-hit on non-opaque geometry, 2 a box group
    // with a null intersection program; the miss group is null.
    let mut scene = Scene::default();
    let tris = scene.add(Node::Gas(Gas::new(vec![GeomInput::Triangles(
        Triangles::soup(quad(0.0, 0.0, 1.0, 1.0, -1.0), GeometryFlags::NONE),
    )])));
    let boxes = scene.add(Node::Gas(Gas::new(vec![GeomInput::Aabbs(Aabbs::new(
        vec![[2.0, 0.0, -1.5, 3.0, 1.0, -0.5]],
        GeometryFlags::NONE,
    ))])));
    let root = scene.add(Node::Ias(vec![
        InstanceDesc::of(tris),
        InstanceDesc {
            sbt_offset: 2,
            ..InstanceDesc::of(boxes)
        },
    ]));
    let groups = vec![
        hit_group(None, Some(prog::AH), None),
        hit_group(Some(prog::CH), None, None),
        hit_group(Some(prog::CH_ATTRS), Some(prog::AH), None),
    ];
    let records = vec![
        SbtEntry::new(0, vec![0, action::ACCEPT]),
        SbtEntry::new(1, vec![1, action::ACCEPT]),
        SbtEntry::new(2, vec![2, action::ACCEPT]),
    ];
    let rays = vec![
        Ray::new([0.75, 0.25, 0.0], [0.0, 0.0, -1.0]),
        Ray {
            sbt_offset: 1,
            ..Ray::new([0.75, 0.25, 0.0], [0.0, 0.0, -1.0])
        },
        Ray::new([2.5, 0.5, 0.0], [0.0, 0.0, -1.0]),
        Ray::new([5.0, 0.5, 0.0], [0.0, 0.0, -1.0]),
    ];
    let mut case = StdCase::new(
        Group::Sbt,
        "null_programs",
        "null programs run nothing: a hit group without closest-hit (any-hit still runs), one without any-hit on non-opaque geometry (accepted), a box group without an intersection program (never hit), a null miss group (CTS null_miss, pipeline_no_null_shaders_flag)",
        &[Rule::SbtIndex, Rule::AnyHitPerCandidate],
        scene,
        Some(root),
    )
    .hits(groups, records)
    .launch(4, rays)
    .record(vec![ch::hit(), ch::programs(), ch::ah_count(), ch::sbt_index()]);
    case.miss_groups = vec![None];
    case.build()
}
