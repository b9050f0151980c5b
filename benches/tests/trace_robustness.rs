//! The guarantees of `optik trace` on every backend that runs here: rays from inside a closed
//! mesh never escape, even aimed exactly at its vertices and shared edges, at the origin, far
//! from it and at tiny scale; and a -0.0 direction component gives the same answer as +0.0.

use optik::raycast::RayCaster;
use optik::{BackendKind, Device};
use optik_benches::mesh::{BenchMesh, Mesh};
use optik_benches::rays;

fn devices() -> Vec<Box<dyn Device>> {
    BackendKind::ALL
        .into_iter()
        .filter_map(|kind| match optik::open_backend(kind) {
            Ok(d) => Some(d),
            Err(e) => {
                eprintln!("skipping the {kind} backend: {}", e.message());
                None
            }
        })
        .collect()
}

#[test]
fn closed_mesh_never_leaks() {
    let sphere = Mesh::icosphere(3);
    // (scale, offset): at the origin, far from it, tiny, and tiny far away (relative to size).
    let placements: [(f64, [f64; 3]); 4] = [
        (1.0, [0.0; 3]),
        (1.0, [1e5, -1e5, 1e5]),
        (1e-4, [0.0; 3]),
        (1e-4, [0.5, 0.25, -0.125]),
    ];
    for device in devices() {
        for (scale, offset) in placements {
            let mesh = sphere.transformed(scale, offset);
            // An interior point near the centre, off every symmetry plane.
            let inside: [f32; 3] =
                std::array::from_fn(|k| (offset[k] + scale * [0.0123, -0.0311, 0.0217][k]) as f32);
            let aimed = rays::aimed_at_vertices_and_edges(&mesh, inside);
            let mut caster =
                RayCaster::new(device.as_ref(), &mesh.positions, &mesh.triangles).expect("build");
            let (hits, _) = caster.cast(&aimed, 1).expect("cast");
            let escaped = hits.prim.iter().filter(|&&p| p == u32::MAX).count();
            assert_eq!(
                escaped,
                0,
                "{}: {escaped} of {} rays escaped the closed mesh at scale {scale}, offset {offset:?}",
                device.backend(),
                hits.prim.len()
            );
        }
    }
}

#[test]
fn signed_zero_directions_agree() {
    let mesh = Mesh::icosphere(2);
    for device in devices() {
        let mut plus = Vec::new();
        // Axis-aligned rays from inside and outside, through vertices of the icosphere.
        for o in [
            [0.0f32, 0.0, 0.0],
            [0.3, -0.2, 0.1],
            [-3.0, 0.0, 0.0],
            [0.0, 0.0, 0.0],
        ] {
            for axis in 0..3 {
                for sign in [1.0f32, -1.0] {
                    let mut d = [0.0f32; 3];
                    d[axis] = sign;
                    plus.extend_from_slice(&[
                        o[0],
                        o[1],
                        o[2],
                        0.0,
                        d[0],
                        d[1],
                        d[2],
                        f32::INFINITY,
                    ]);
                }
            }
        }
        let minus: Vec<f32> = plus
            .chunks_exact(8)
            .flat_map(|r| {
                let mut r = r.to_vec();
                for c in &mut r[4..7] {
                    if *c == 0.0 {
                        *c = -0.0;
                    }
                }
                r
            })
            .collect();
        let mut caster =
            RayCaster::new(device.as_ref(), &mesh.positions, &mesh.triangles).expect("build");
        let (a, _) = caster.cast(&plus, 1).expect("cast +0");
        let (b, _) = caster.cast(&minus, 1).expect("cast -0");
        assert_eq!(
            a.prim,
            b.prim,
            "{}: primitives differ between +0.0 and -0.0 directions",
            device.backend()
        );
        assert_eq!(
            a.t.iter().map(|t| t.to_bits()).collect::<Vec<_>>(),
            b.t.iter().map(|t| t.to_bits()).collect::<Vec<_>>(),
            "{}: t differs between +0.0 and -0.0 directions",
            device.backend()
        );
        // The first two origins are inside the sphere: their 12 rays must hit.
        assert!(
            a.prim[..12].iter().all(|&p| p != u32::MAX),
            "{}: every ray from inside hits",
            device.backend()
        );
        // From (-3, 0, 0) the ray along +x reaches the sphere.
        assert_ne!(
            a.prim[12],
            u32::MAX,
            "{}: the ray along +x from (-3, 0, 0) hits",
            device.backend()
        );
    }
}

/// `optik trace` splits its rays into launches that each bind less than a device's storage
/// binding limit (the GPU backends failed with a binding-range error above 4,194,304 rays on
/// lavapipe's 128 MiB limit). Tested small: a wgpu device capped at 16 KiB per binding
/// traces 4,000 rays in batches of what one binding holds by default, refuses one launch
/// of all of them (128 KB of rays) with an error naming the limit, and gives the same hits
/// in batches of any size; on the CPU device batches give the hits of one launch.
#[test]
fn rays_beyond_a_binding_limit_trace_in_batches() {
    use optik::backends::wgpu::{WgpuBackend, WgpuDevice, WgpuOptions};
    let mesh = Mesh::icosphere(2);
    let aimed = rays::aimed_at_vertices_and_edges(&mesh, [0.0123, -0.0311, 0.0217]);
    let rays: Vec<f32> = aimed.iter().copied().cycle().take(4000 * 8).collect();
    let cpu = optik::open_backend(BackendKind::Cpu).expect("cpu");
    let (expected, _) = RayCaster::new(cpu.as_ref(), &mesh.positions, &mesh.triangles)
        .expect("build")
        .cast(&rays, 1)
        .expect("one launch");
    let mut batched =
        RayCaster::new(cpu.as_ref(), &mesh.positions, &mesh.triangles).expect("build");
    batched.set_batch_rays(300);
    assert_eq!(batched.upload(&rays).expect("upload").batches(), 14);
    assert_eq!(batched.cast(&rays, 1).expect("batches").0, expected);

    let gpu = match WgpuBackend::with_options(WgpuOptions {
        max_storage_binding: Some(16 << 10),
        ..Default::default()
    })
    .map(WgpuDevice::new)
    {
        Ok(d) => d,
        Err(e) => {
            eprintln!("skipping the wgpu part: {}", e.message());
            return;
        }
    };
    let mut caster = RayCaster::new(&gpu, &mesh.positions, &mesh.triangles).expect("build");
    // By default a batch fills one binding: 16 KiB hold 512 rays of 32 bytes.
    assert_eq!(gpu.properties().max_binding_size, 16 << 10);
    assert_eq!(caster.upload(&rays).expect("upload").batches(), 8);
    let (hits, _) = caster.cast(&rays, 1).expect("batches of 16 KB");
    caster.set_batch_rays(4000);
    let e = caster.cast(&rays, 1).expect_err("one launch binds 128 KB");
    assert_eq!(e.kind(), optik::ErrorKind::LimitExceeded, "{e}");
    assert!(e.message().contains("at most 16384 bytes"), "{e}");
    caster.set_batch_rays(500);
    assert_eq!(caster.cast(&rays, 1).expect("batches of 500").0, hits);
    assert_eq!(hits.t.len(), 4000);
    assert!(hits.prim.iter().all(|&p| p != u32::MAX), "a ray escaped");
    // Ties at shared edges may go to either triangle across backends; the batch size
    // changes nothing.
    caster.set_batch_rays(123);
    assert_eq!(caster.cast(&rays, 1).expect("other batches").0, hits);
}
