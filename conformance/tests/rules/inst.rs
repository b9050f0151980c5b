//! Instance structures after they were built: an instance whose child structure was
//! destroyed is missed while its siblings still hit, and an update with new transforms moves
//! the instances; the parent keeps its handle through both.

use optik::*;
use optik_conformance::kit::rig::*;

/// A pipeline over [`RAY_LIST`] whose closest-hit records the instance id, and its table.
fn instance_pipeline(d: &dyn Device) -> (Pipeline, ShaderBindingTable) {
    let m = module(
        d,
        &format!(
            "{RAY_LIST}\nfn closesthit__id() {{ rt_set_payload(0u, 1u); rt_set_payload(1u, bitcast<u32>(rt_ray_tmax())); rt_set_payload(4u, rt_instance_id()); }}\n"
        ),
    );
    let g = groups(
        d,
        &[
            raygen(m, "raygen__rays"),
            miss(m, "miss__rec"),
            closest_hit(m, "closesthit__id"),
        ],
    );
    (pipeline(d, &g, 1), numbered_sbt(d, &g))
}

/// An instance of `child` moved by `x` along x, with id `id`.
fn placed(d: &dyn Device, child: Accel, x: f32, id: u32) -> Instance {
    Instance {
        transform: [1.0, 0.0, 0.0, x, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        instance_id: id,
        ..Instance::new(d.traversable_handle(child).unwrap())
    }
}

fn instances_input(d: &dyn Device, instances: &[Instance]) -> (Buffer, BuildInput) {
    let ib = buffer(d, instances);
    let input = BuildInput::Instances(InstanceArray {
        instances: BufferView::new(ib),
        num_instances: instances.len() as u32,
    });
    (ib, input)
}

#[test]
fn destroyed_children_are_missed_and_handles_stay() {
    on_every_backend("inst: destroyed children", |_, d| {
        let a = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
        let b = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
        let (_, input) = instances_input(d, &[placed(d, a, 0.0, 1), placed(d, b, 2.0, 2)]);
        let ias = d
            .accel_build(&AccelBuildOptions::default(), &[input])
            .unwrap();
        let h = d.traversable_handle(ias).unwrap();
        let (p, table) = instance_pipeline(d);
        let rays = [
            Ray::new([0.75, 0.25, 1.0], [0.0, 0.0, -1.0]),
            Ray::new([2.75, 0.25, 1.0], [0.0, 0.0, -1.0]),
        ];
        let before = trace_rays(d, p, &table, h, &rays, TraceArgs::default());
        assert!(before[0].hit() && before[1].hit(), "{before:?}");
        assert_eq!((before[0].instance_id(), before[1].instance_id()), (1, 2));
        d.destroy_accel(a).unwrap();
        assert_eq!(
            d.traversable_handle(ias).unwrap(),
            h,
            "the parent keeps its handle"
        );
        let after = trace_rays(d, p, &table, h, &rays, TraceArgs::default());
        assert!(
            after[0].missed(),
            "the destroyed child is missed: {:?}",
            after[0]
        );
        assert!(after[1].hit(), "the other child still hits: {:?}", after[1]);
        assert_eq!(after[1].instance_id(), 2);
        let e = d.traversable_handle(a).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::InvalidHandle);
    });
}

#[test]
fn instance_structures_update_their_transforms() {
    on_every_backend("inst: updated transforms", |_, d| {
        let gas = triangles(d, &quad(0.0, 1.0, 0.0, 1.0, 0.0), GeometryFlags::NONE);
        let mut inst = placed(d, gas, 0.0, 7);
        let (ib, input) = instances_input(d, &[inst]);
        let options = AccelBuildOptions {
            flags: BuildFlags::ALLOW_UPDATE,
            ..Default::default()
        };
        let ias = d
            .accel_build(&options, std::slice::from_ref(&input))
            .unwrap();
        let h = d.traversable_handle(ias).unwrap();
        let (p, table) = instance_pipeline(d);
        let rays = [
            Ray::new([0.75, 0.25, 1.0], [0.0, 0.0, -1.0]),
            Ray::new([20.75, 0.25, 1.0], [0.0, 0.0, -1.0]),
        ];
        let before = trace_rays(d, p, &table, h, &rays, TraceArgs::default());
        assert!(
            before[0].hit() && (before[0].t() - 1.0).abs() < 1e-6,
            "{:?}",
            before[0]
        );
        assert!(before[1].missed(), "{:?}", before[1]);
        inst.transform[3] = 20.0;
        d.write_buffer(ib, 0, bytemuck::bytes_of(&inst)).unwrap();
        d.accel_update(
            ias,
            &AccelBuildOptions {
                operation: BuildOperation::Update,
                ..options
            },
            &[input],
        )
        .unwrap();
        assert_eq!(
            d.traversable_handle(ias).unwrap(),
            h,
            "the update keeps the handle"
        );
        let after = trace_rays(d, p, &table, h, &rays, TraceArgs::default());
        assert!(after[0].missed(), "the instance moved away: {:?}", after[0]);
        assert!(
            after[1].hit() && (after[1].t() - 1.0).abs() < 1e-6,
            "{:?}",
            after[1]
        );
        assert_eq!(after[1].instance_id(), 7);
    });
}
