//! A module's one closest-hit program compiled into its ray generation programs, after each
//! trace (`InlinedClosestHit`, docs/cpu-backend.md §5): the same results as the runtime
//! calling it, and the record's own program whenever the hit is not the inlined one.

use optik_api::*;
use optik_cpu::{CpuBackend, CpuDevice};

/// Words each trace's payload gives back.
const WORDS: usize = 16;
/// What a module's compile log says when it inlined its closest hit.
const INLINED: &str = "closest-hit program inlined";
/// Launch width: rays 0–3 hit the triangles, 4–5 miss.
const RAYS: usize = 6;

const RAYGEN: &str = r#"
@group(0) @binding(0) var<uniform> handle: vec2<u32>;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn raygen__main() {
    let x = rt_launch_index().x;
    let origin = vec3<f32>(f32(x) * 1.5 + 0.1, 0.3, -1.0);
    var p: RtPayload;
    var q: RtPayload;
    for (var i = 0u; i < 16u; i++) {
        p[i] = 0xAAAAAAAAu;
        q[i] = 0xBBBBBBBBu;
    }
    rt_trace(handle, origin, vec3<f32>(0.0, 0.0, 1.0), 0.0, 1e30, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    // A second trace (another inlined copy), whose closest hit the flag turns off.
    rt_trace(handle, origin, vec3<f32>(0.0, 0.0, 2.0), 0.25, 1e30, 0.0, 0x0Fu,
             RT_RAY_FLAG_DISABLE_CLOSESTHIT, 0u, 1u, 0u, &q);
    for (var i = 0u; i < 16u; i++) {
        out[x * 32u + i] = p[i];
        out[x * 32u + 16u + i] = q[i];
    }
}

fn miss__none() {
}
"#;

/// Reads every value an inlined closest hit may read from the state.
const CLOSEST_HIT: &str = r#"
fn closesthit__all() {
    let b = rt_triangle_barycentrics();
    rt_set_payload(0u, bitcast<u32>(rt_ray_tmax()));
    rt_set_payload(1u, bitcast<u32>(rt_ray_tmin()));
    rt_set_payload(2u, bitcast<u32>(b.x));
    rt_set_payload(3u, bitcast<u32>(b.y));
    rt_set_payload(4u, rt_primitive_index());
    rt_set_payload(5u, rt_sbt_gas_index());
    rt_set_payload(6u, rt_instance_id());
    rt_set_payload(7u, rt_instance_index() + bitcast<u32>(rt_world_to_object()[3].y + rt_object_to_world()[1].y));
    rt_set_payload(8u, rt_hit_kind());
    rt_set_payload(9u, rt_ray_flags());
    rt_set_payload(10u, rt_ray_mask());
    rt_set_payload(11u, bitcast<u32>(rt_world_ray_origin().x));
    rt_set_payload(12u, bitcast<u32>(rt_object_ray_direction().z));
    rt_set_payload(13u, rt_launch_index().x + 100u * rt_launch_dimensions().x);
    rt_set_payload(14u, rt_remaining_trace_depth());
    // The caller's register, read in place.
    rt_set_payload(15u, rt_get_payload(15u) + 1u);
}
"#;

/// Payload registers by computed and by constant index, some past the payload's 16 (reads
/// give 0, writes are dropped): the inlined code addresses the caller's registers itself.
const DYNAMIC: &str = r#"
fn closesthit__dynamic() {
    let k = rt_primitive_index();
    rt_set_payload(k + 2u, rt_get_payload(k) + 5u);
    rt_set_payload(k + 15u, 9u);
    rt_set_payload(k + 4u, rt_get_payload(k + 16u) + 1u);
    rt_set_payload(6u, rt_get_payload(3u * k + 14u));
    rt_set_payload(20u, rt_get_payload(17u) + 7u);
}
"#;

/// A second closest-hit program: with it no program of the module is inlined.
const OTHER: &str = r#"
fn closesthit__other() {
    rt_set_payload(0u, 77u);
}
"#;

/// Two triangles side by side at z = 5.
fn two_triangles(dev: &CpuDevice) -> TraversableHandle {
    crate::jit::triangles(
        dev,
        &[
            [0.0, 0.0, 5.0],
            [0.0, 4.0, 5.0],
            [3.0, 0.0, 5.0],
            [3.0, 0.0, 5.0],
            [3.0, 4.0, 5.0],
            [6.0, 0.0, 5.0],
        ],
    )
}

/// Compiles `source`; returns the module and its log.
fn module(dev: &CpuDevice, source: &str) -> (Module, String) {
    dev.create_module(
        &ModuleCompileOptions::default(),
        &options(),
        &ProgramSource::new("inlined.wgsl", source),
    )
    .unwrap()
}

fn options() -> PipelineCompileOptions {
    PipelineCompileOptions {
        num_payload_values: Setting::Value(WORDS as u32),
        ..Default::default()
    }
}

/// Launches `raygen` with a hit group of `closest_hit`; returns each ray's two payloads.
fn launch(
    dev: &CpuDevice,
    handle: TraversableHandle,
    raygen: ProgramRef,
    closest_hit: ProgramRef,
) -> Vec<u32> {
    let miss = ProgramRef::new(raygen.module, "miss__none");
    let groups = dev
        .create_program_groups(&[
            ProgramGroupDesc::Raygen(raygen),
            ProgramGroupDesc::Miss(Some(miss)),
            ProgramGroupDesc::closest_hit(closest_hit),
        ])
        .unwrap();
    let pipeline = dev
        .create_pipeline(&options(), &PipelineLinkOptions::default(), &groups)
        .unwrap();
    let sbt = crate::jit::sbt_of(dev, &groups);
    let words = RAYS * 2 * WORDS;
    let out = dev.create_buffer(words as u64 * 4).unwrap();
    dev.launch(
        pipeline,
        bytemuck::cast_slice(&handle.to_words()),
        &[Resource::buffer(1, out)],
        &sbt,
        LaunchSize::new(RAYS as u32, 1, 1),
    )
    .unwrap();
    let mut bytes = vec![0u8; words * 4];
    dev.read_buffer(out, 0, &mut bytes).unwrap();
    bytemuck::cast_slice(&bytes).to_vec()
}

/// The payloads of `RAYGEN` with the closest-hit program `closest_hit` (its source, its
/// entry `entry`) compiled into the ray generation program, after checking that they equal
/// those of the same programs where the runtime calls it (a module with `OTHER` too, whose
/// two closest hits keep either from being inlined).
fn inlined_as_called(dev: &CpuDevice, closest_hit: &str, entry: &str) -> Vec<u32> {
    let handle = two_triangles(dev);
    let (inlined, log) = module(dev, &format!("{RAYGEN}{closest_hit}"));
    assert!(
        log.contains(&format!("{INLINED} after the traces of 1 ray generation")),
        "{log}"
    );
    let (called, log) = module(dev, &format!("{RAYGEN}{closest_hit}{OTHER}"));
    assert!(!log.contains(INLINED), "two closest-hit programs: {log}");
    let run = |m: Module| {
        let raygen = ProgramRef::new(m, "raygen__main");
        launch(dev, handle, raygen, ProgramRef::new(m, entry))
    };
    let got = run(inlined);
    assert_eq!(got, run(called));
    got
}

#[test]
fn an_inlined_closest_hit_gives_what_the_called_program_gives() {
    let _launches = crate::shared();
    let dev = CpuBackend::with_threads(2).map(CpuDevice::new).unwrap();
    let got = inlined_as_called(&dev, CLOSEST_HIT, "closesthit__all");
    for (x, ray) in got.chunks(2 * WORDS).enumerate() {
        let (p, q) = ray.split_at(WORDS);
        assert_eq!(
            q, [0xBBBB_BBBB; WORDS],
            "no closest hit on the second trace ({x})"
        );
        if x >= 4 {
            assert_eq!(p, [0xAAAA_AAAA; WORDS], "ray {x} misses");
            continue;
        }
        assert!((f32::from_bits(p[0]) - 6.0).abs() < 1e-5, "t of ray {x}");
        assert_eq!(p[4], (x >= 2) as u32, "primitive of ray {x}");
        assert_eq!(
            (p[8], p[9], p[10]),
            (0xFE, 0, 0xFF),
            "kind, flags, mask of {x}"
        );
        assert_eq!(f32::from_bits(p[7]), 1.0, "transforms of {x}");
        assert_eq!(
            (p[13], p[15]),
            (x as u32 + 600, 0xAAAA_AAAB),
            "index, dimensions, register of {x}"
        );
    }
}

#[test]
fn an_inlined_closest_hit_reads_and_writes_registers_by_computed_index() {
    let _launches = crate::shared();
    let dev = CpuBackend::with_threads(2).map(CpuDevice::new).unwrap();
    let got = inlined_as_called(&dev, DYNAMIC, "closesthit__dynamic");
    const A: u32 = 0xAAAA_AAAA;
    for (x, ray) in got.chunks(2 * WORDS).enumerate() {
        let mut want = [A; WORDS];
        if x < 2 {
            // Primitive 0: registers 2, 15 and 4 (register 16 reads 0), 6 from 14.
            (want[2], want[15], want[4], want[6]) = (A + 5, 9, 1, A);
        } else if x < 4 {
            // Primitive 1: registers 3 and 5; 16 and 17 are past the payload; 6 from 17.
            (want[3], want[5], want[6]) = (A + 5, 1, 0);
        }
        assert_eq!(ray[..WORDS], want, "ray {x}");
    }
}

#[test]
fn a_hit_whose_record_has_another_closest_hit_runs_that_one() {
    let _launches = crate::shared();
    let dev = CpuBackend::with_threads(2).map(CpuDevice::new).unwrap();
    let handle = two_triangles(&dev);
    let (inlined, log) = module(&dev, &format!("{RAYGEN}{CLOSEST_HIT}"));
    assert!(log.contains(INLINED), "{log}");
    let (other, _) = module(&dev, &format!("{RAYGEN}{OTHER}"));
    let got = launch(
        &dev,
        handle,
        ProgramRef::new(inlined, "raygen__main"),
        ProgramRef::new(other, "closesthit__other"),
    );
    for (x, ray) in got.chunks(2 * WORDS).enumerate() {
        let first = if x < 4 { 77 } else { 0xAAAA_AAAA };
        assert_eq!(ray[0], first, "ray {x}");
        assert_eq!(ray[1..WORDS], [0xAAAA_AAAA; WORDS - 1], "ray {x}");
    }
}

#[test]
fn closest_hits_that_ask_the_runtime_are_not_inlined() {
    let dev = CpuBackend::with_threads(1).map(CpuDevice::new).unwrap();
    for (why, program) in [
        (
            "record data",
            "fn closesthit__data() { rt_set_payload(0u, rt_sbt_data_u32(0u)); }",
        ),
        (
            "a private variable",
            "var<private> seen: u32;\nfn closesthit__private() { seen += 1u; rt_set_payload(0u, seen); }",
        ),
        (
            "a private variable of a helper",
            "var<private> seen: u32;\nfn bump() -> u32 { seen += 1u; return seen; }\nfn closesthit__helper() { rt_set_payload(0u, bump()); }",
        ),
        (
            "a trace",
            "fn closesthit__again() { var r: RtPayload; rt_trace(handle, vec3<f32>(0.0), vec3<f32>(0.0, 0.0, 1.0), 0.0, 1.0, 0.0, 0xFFu, 0u, 0u, 1u, 0u, &r); }",
        ),
    ] {
        let (_, log) = module(&dev, &format!("{RAYGEN}{program}"));
        assert!(!log.contains(INLINED), "{why}: {log}");
    }
}
