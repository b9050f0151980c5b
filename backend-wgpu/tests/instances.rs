//! Instances at three levels, a static transform, masks, flags and SBT offsets summed
//! along the path; destroyed children are missed.
mod common;
use common::*;
use optik_api::*;

const PROGRAMS: &str = r#"
struct Params { handle: vec2<u32>, mask: u32, pad: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@group(0) @binding(2) var<storage, read> rays: array<vec4<f32>>;

fn raygen__rays() {
    let i = rt_launch_index().x;
    var p: RtPayload;
    p[0] = 2u;
    rt_trace(params.handle, rays[2u * i].xyz, rays[2u * i + 1u].xyz, 0.0, 1e30, 0.0, params.mask, 0u, 0u, 1u, 0u, &p);
    for (var k = 0u; k < 8u; k = k + 1u) {
        out[8u * i + k] = p[k];
    }
}

fn closesthit__inst() {
    rt_set_payload(0u, 1u);
    rt_set_payload(1u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(2u, rt_hit_kind());
    rt_set_payload(3u, rt_instance_id());
    rt_set_payload(4u, rt_instance_index());
    rt_set_payload(5u, rt_sbt_data_u32(0u));
    rt_set_payload(6u, bitcast<u32>(rt_object_ray_origin().z));
    rt_set_payload(7u, bitcast<u32>(rt_object_to_world()[3].y));
}

fn miss__none() {
    rt_set_payload(0u, 2u);
}
"#;

fn instance(
    child: TraversableHandle,
    m: Matrix3x4,
    id: u32,
    sbt_offset: u32,
    mask: u32,
    flags: InstanceFlags,
) -> Instance {
    Instance {
        transform: m,
        instance_id: id,
        sbt_offset,
        visibility_mask: mask,
        flags: flags.0,
        ..Instance::new(child)
    }
}

fn translate(x: f32, y: f32, z: f32) -> Matrix3x4 {
    [1.0, 0.0, 0.0, x, 0.0, 1.0, 0.0, y, 0.0, 0.0, 1.0, z]
}

fn ias(dev: &dyn Device, instances: &[Instance]) -> Accel {
    let b = buffer(dev, instances);
    let input = BuildInput::Instances(InstanceArray {
        instances: BufferView::new(b),
        num_instances: instances.len() as u32,
    });
    dev.accel_build(&AccelBuildOptions::default(), &[input])
        .unwrap()
}

struct Scene {
    dev: Box<dyn Device>,
    gas: Accel,
    top: TraversableHandle,
}

/// GAS: the unit quad at z = 0. IAS1: it at x = 0 (id 1), x = 2 flipped (id 2, SBT +1),
/// x = 4 (id 3, mask 2). IAS2: IAS1 as is (id 4, SBT +2) and scaled by 2 at y = 2 (id 5).
/// A static transform moves IAS2 down by 1; IAS3 holds it (id 6, SBT +1).
fn scene() -> Scene {
    let dev = device();
    let d = dev.as_ref();
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let h = |a| d.traversable_handle(a).unwrap();
    let l1 = ias(
        d,
        &[
            instance(
                h(gas),
                translate(0.0, 0.0, 0.0),
                1,
                0,
                0xFF,
                InstanceFlags::NONE,
            ),
            instance(
                h(gas),
                translate(2.0, 0.0, 0.0),
                2,
                1,
                0xFF,
                InstanceFlags::FLIP_TRIANGLE_FACING,
            ),
            instance(
                h(gas),
                translate(4.0, 0.0, 0.0),
                3,
                0,
                0x02,
                InstanceFlags::NONE,
            ),
        ],
    );
    let scaled = [2.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 2.0, 0.0, 0.0, 2.0, 0.0];
    let l2 = ias(
        d,
        &[
            instance(
                h(l1),
                translate(0.0, 0.0, 0.0),
                4,
                2,
                0xFF,
                InstanceFlags::NONE,
            ),
            instance(h(l1), scaled, 5, 0, 0xFF, InstanceFlags::NONE),
        ],
    );
    let t = d
        .create_transform(&TransformDesc::Static {
            child: h(l2),
            object_to_world: translate(0.0, 0.0, -1.0),
            world_to_object: translate(0.0, 0.0, 1.0),
        })
        .unwrap();
    let l3 = ias(
        d,
        &[instance(
            h(t),
            IDENTITY_3X4,
            6,
            1,
            0xFF,
            InstanceFlags::NONE,
        )],
    );
    let top = h(l3);
    Scene { dev, gas, top }
}

fn trace(s: &Scene, points: &[[f32; 2]], mask: u32) -> Vec<[u32; 8]> {
    let d = s.dev.as_ref();
    let m = module(d, PROGRAMS);
    let descs: Vec<ProgramGroupDesc> = [raygen(m, "raygen__rays"), miss(m, "miss__none")]
        .into_iter()
        .chain((0..6).map(|_| closest_hit(m, "closesthit__inst")))
        .collect();
    let g = groups(d, &descs);
    let p = pipeline(d, &g, 1);
    let table = numbered_sbt(d, &g);
    let words: Vec<[f32; 4]> = points
        .iter()
        .flat_map(|q| [[q[0], q[1], 5.0, 0.0], [0.0, 0.0, -1.0, 0.0]])
        .collect();
    let rb = buffer(d, &words);
    let out = d.create_buffer((points.len() * 32) as u64).unwrap();
    d.launch(
        p,
        &params(s.top, &[mask]),
        &[Resource::buffer(1, out), Resource::buffer(2, rb)],
        &table,
        LaunchSize::new(points.len() as u32, 1, 1),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    read::<u32>(d, out)
        .chunks_exact(8)
        .map(|c| c.try_into().unwrap())
        .collect()
}

#[test]
fn three_levels_with_a_transform() {
    let s = scene();
    let out = trace(
        &s,
        &[
            [0.5, 0.5],
            [2.5, 0.5],
            [4.5, 0.5],
            [1.0, 3.0],
            [5.0, 3.0],
            [0.5, 1.5],
        ],
        0xFF,
    );
    let t = |o: &[u32; 8]| f32::from_bits(o[1]);
    // (0.5, 0.5): IAS3 → transform → IAS2 #0 → IAS1 #0.
    assert_eq!(out[0][0], 1);
    assert!(
        (t(&out[0]) - 6.0).abs() < 1e-5,
        "the quad sits at z = -1: t = 6, got {}",
        t(&out[0])
    );
    assert_eq!(out[0][2], 0xFE);
    assert_eq!(
        (out[0][3], out[0][4]),
        (1, 0),
        "innermost instance id and index"
    );
    assert_eq!(out[0][5], 1 + 2, "SBT offsets add up along the path");
    assert_eq!(
        f32::from_bits(out[0][6]),
        6.0,
        "object-space origin z: 5 + 1"
    );
    assert_eq!(f32::from_bits(out[0][7]), 0.0);
    // (2.5, 0.5): the flipped instance.
    assert_eq!(out[1][2], 0xFF, "FLIP_TRIANGLE_FACING swaps the faces");
    assert_eq!((out[1][3], out[1][4], out[1][5]), (2, 1, 1 + 2 + 1));
    // (4.5, 0.5): mask 2 is visible to mask 0xFF.
    assert_eq!((out[2][3], out[2][5]), (3, 1 + 2));
    // (1, 3): through the scaled instance: object space (0.5, 0.5), origin z (5 + 1) / 2.
    assert_eq!((out[3][0], out[3][3], out[3][5]), (1, 1, 1));
    assert!((t(&out[3]) - 6.0).abs() < 1e-5);
    assert_eq!(f32::from_bits(out[3][6]), 3.0);
    assert_eq!(
        f32::from_bits(out[3][7]),
        2.0,
        "object-to-world translation y"
    );
    assert_eq!((out[4][3], out[4][5], out[4][2]), (2, 2, 0xFF));
    assert_eq!(out[5][0], 2, "between the quads");
}

#[test]
fn masks_hide_instances() {
    let s = scene();
    let out = trace(&s, &[[0.5, 0.5], [4.5, 0.5]], 0x01);
    assert_eq!(out[0][0], 1);
    assert_eq!(out[1][0], 2, "instance mask 2 & ray mask 1 = 0: invisible");
    let out = trace(&s, &[[0.5, 0.5]], 0x100);
    assert_eq!(out[0][0], 2, "only the low 8 bits of the ray mask count");
}

#[test]
fn destroyed_children_are_missed() {
    let s = scene();
    s.dev.destroy_accel(s.gas).unwrap();
    let out = trace(&s, &[[0.5, 0.5], [1.0, 3.0]], 0xFF);
    assert!(
        out.iter().all(|o| o[0] == 2),
        "the geometry is gone: {out:?}"
    );
}

#[test]
fn many_instances_share_leaves() {
    // 12 × 12 instances: the builder puts several instances in one leaf, and entering one
    // must leave the others for later.
    let dev = device();
    let d = dev.as_ref();
    let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
    let h = d.traversable_handle(gas).unwrap();
    let n = 12;
    let instances: Vec<Instance> = (0..n * n)
        .map(|k| {
            let (x, y) = ((k % n) as f32 * 1.5, (k / n) as f32 * 1.5);
            instance(
                h,
                translate(x, y, (k % 5) as f32 * 0.25),
                1000 + k as u32,
                0,
                0xFF,
                InstanceFlags::NONE,
            )
        })
        .collect();
    let top = d.traversable_handle(ias(d, &instances)).unwrap();
    let s = Scene { dev, gas, top };
    let points: Vec<[f32; 2]> = (0..n * n)
        .map(|k| [(k % n) as f32 * 1.5 + 0.5, (k / n) as f32 * 1.5 + 0.5])
        .collect();
    let out = trace(&s, &points, 0xFF);
    for (k, o) in out.iter().enumerate() {
        assert_eq!(o[0], 1, "instance {k} missed");
        assert_eq!(o[3], 1000 + k as u32, "instance {k}");
        assert_eq!(o[4], k as u32, "instance index");
        let t = f32::from_bits(o[1]);
        assert!((t - (5.0 - (k % 5) as f32 * 0.25)).abs() < 1e-5);
    }
}
