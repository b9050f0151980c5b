//! Device functions through a recording `DeviceCalls`: every getter, payload and
//! attribute registers, `rt_trace` and the callables with their payload copies, the
//! terminators ending the program from inside helpers, returns when the runtime unwinds,
//! the `DeviceState` fast paths, and `rt_offset_ray`.

use super::*;

const DEVICE: &str = r#"
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn f(i: u32, x: f32) { out[i] = bitcast<u32>(x); }
fn v3(i: u32, x: vec3<f32>) { f(i, x.x); f(i + 1u, x.y); f(i + 2u, x.z); }

fn closesthit__all() {
    let li = rt_launch_index();
    let ld = rt_launch_dimensions();
    out[0] = li.x + li.y * 10u + li.z * 100u;
    out[1] = ld.x + ld.y + ld.z;
    v3(2u, rt_world_ray_origin());
    v3(5u, rt_world_ray_direction());
    v3(8u, rt_object_ray_origin());
    v3(11u, rt_object_ray_direction());
    f(14u, rt_ray_tmin()); f(15u, rt_ray_tmax()); f(16u, rt_ray_time());
    out[17] = rt_ray_flags(); out[18] = rt_ray_mask();
    out[19] = rt_primitive_index(); out[20] = rt_sbt_gas_index();
    out[21] = rt_instance_id(); out[22] = rt_instance_index(); out[23] = rt_hit_kind();
    out[24] = select(0u, 1u, rt_is_front_face_hit());
    let bary = rt_triangle_barycentrics();
    f(25u, bary.x); f(26u, bary.y);
    let tv = rt_triangle_vertices();
    v3(27u, tv[0]); v3(30u, tv[2]);
    let s = rt_sphere();
    f(33u, s.w);
    let m = rt_object_to_world();
    v3(34u, m[0]); v3(37u, m[3]);
    let w = rt_world_to_object();
    v3(40u, w * vec4<f32>(1.0, 0.0, 0.0, 1.0));
    out[43] = rt_sbt_data_u32(3u);
    f(44u, rt_sbt_data_f32(2u));
    out[45] = rt_get_payload(1u);
    rt_set_payload(2u, 77u);
    out[46] = rt_get_attribute(5u);
    out[47] = rt_remaining_trace_depth();
    var p: RtPayload;
    p[0] = 5u;
    p[1] = 6u;
    rt_trace(vec2<u32>(11u, 22u), vec3<f32>(1.0, 2.0, 3.0), vec3<f32>(0.0, 1.0, 0.0), 0.5, 100.0, 0.25,
        0xffu, 1u, 2u, 3u, 4u, &p);
    out[48] = p[0]; out[49] = p[1]; out[50] = p[3];
    var args: RtPayload;
    args[0] = 7u;
    rt_direct_call(3u, &args);
    out[51] = args[0];
    rt_continuation_call(4u, &args);
    out[52] = args[0];
    f(53u, rt_curve_parameter());
}

fn intersection__tmax() {
    let before = rt_ray_tmax();
    let attrs = RtAttributes(0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u);
    let hit = rt_report_intersection(2.5, 1u, attrs);
    out[0] = bitcast<u32>(before);
    out[1] = bitcast<u32>(rt_ray_tmax());
    out[2] = select(0u, 1u, hit);
}

fn exception__code() {
    out[0] = bitcast<u32>(rt_exception_code());
}

fn intersection__report() {
    let attrs = RtAttributes(1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u);
    let near = rt_report_intersection(2.5, 3u, attrs);
    let far = rt_report_intersection(20.0, 4u, attrs);
    out[0] = select(0u, 1u, near) + select(0u, 2u, far);
}

fn reject(t: f32) {
    if t > 0.5 {
        rt_ignore_intersection();
    }
    out[1] = 1u;
}

fn anyhit__maybe_ignore() {
    out[0] = 1u;
    for (var i = 0; i < 3; i++) {
        reject(rt_ray_time() + f32(i) * 0.2);
        out[2] += 1u;
    }
    out[3] = 1u;
}

fn anyhit__terminate() {
    out[0] = 1u;
    rt_terminate_ray();
    out[1] = 1u;
}

fn fail(code: u32) -> u32 {
    if code > 2u {
        rt_throw_exception(code);
    }
    return code * 10u;
}

fn raygen__throw() {
    for (var i = 0u; i < 10u; i++) {
        out[i] = fail(i);
    }
    out[20] = 1u;
}

fn raygen__offset() {
    let n = arrayLength(&out) / 6u;
    for (var i = 0u; i < n; i++) {
        let p = vec3<f32>(bitcast<f32>(out[i * 6u]), bitcast<f32>(out[i * 6u + 1u]), bitcast<f32>(out[i * 6u + 2u]));
        let nrm = normalize(vec3<f32>(bitcast<f32>(out[i * 6u + 3u]), 1.0, -0.5));
        let q = rt_offset_ray(p, nrm);
        out[i * 6u] = bitcast<u32>(q.x);
        out[i * 6u + 1u] = bitcast<u32>(q.y);
        out[i * 6u + 2u] = bitcast<u32>(q.z);
    }
}
"#;

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn every_getter_reaches_device_calls() {
    let module = jit(DEVICE);
    let mut buffers = Buffers::new(vec![vec![0; 54]]);
    let mut mock = Mock {
        payload: vec![0, 555, 0, 0],
        trace_adds: 10,
        ..Mock::default()
    };
    buffers.run(&module, "closesthit__all", &mut mock);
    let out = &buffers.words[0];
    assert_eq!(out[0], 3 + 40 + 500);
    assert_eq!(out[1], 640 + 480 + 1);
    assert_eq!(
        out[2..14],
        bits(&[1.0, 2.0, 3.0, 0.0, 0.0, -1.0, 4.0, 5.0, 6.0, 0.0, -1.0, 0.0])[..]
    );
    assert_eq!(out[14..17], bits(&[0.001, 1e30, 0.25])[..]);
    assert_eq!(out[17..25], [0x11, 0xfe, 42, 7, 1234, 9, 0xfe, 1]);
    assert_eq!(out[25..27], bits(&[0.25, 0.5])[..]);
    assert_eq!(out[27..33], bits(&[1.0, 2.0, 3.0, 7.0, 8.0, 9.0])[..]);
    assert_eq!(out[33], 0.5f32.to_bits());
    // Column j of object-to-world is (m[j], m[4 + j], m[8 + j]) of the row-major 3x4.
    assert_eq!(out[34..40], bits(&[1.0, 5.0, 9.0, 4.0, 8.0, 12.0])[..]);
    // world-to-object * (1, 0, 0, 1) = column 0 + column 3.
    assert_eq!(
        out[40..43],
        bits(&[-1.0 + -4.0, -5.0 + -8.0, -9.0 + -12.0])[..]
    );
    assert_eq!(out[43], 1003);
    assert_eq!(out[44], f32::from_bits(1002).to_bits());
    assert_eq!(out[45], 555);
    assert_eq!(out[46], 105);
    assert_eq!(out[47], 5);
    assert_eq!(
        out[48..51],
        [15, 16, 10],
        "rt_trace's payload comes back updated"
    );
    assert_eq!(out[51..53], [14, 42], "callables update their arguments");
    assert_eq!(out[53], 0.75f32.to_bits());
    assert_eq!(
        mock.events,
        vec![
            Event::SetPayload(2, 77),
            Event::Trace {
                handle: [11, 22],
                origin: [1.0, 2.0, 3.0],
                direction: [0.0, 1.0, 0.0],
                tmin: 0.5,
                tmax: 100.0,
                time: 0.25,
                words: [0xff, 1, 2, 3, 4],
                payload: vec![5, 6, 0, 0],
            },
            Event::DirectCall(3, vec![7, 0, 0, 0]),
            Event::ContinuationCall(4, vec![14, 0, 0, 0]),
        ]
    );
}

#[test]
fn exception_code_and_report_intersection() {
    let module = jit(DEVICE);
    let mut buffers = Buffers::new(vec![vec![0; 4]]);
    buffers.run(&module, "exception__code", &mut Mock::default());
    assert_eq!(buffers.words[0][0] as i32, -3);
    let mut mock = Mock::default();
    buffers.run(&module, "intersection__report", &mut mock);
    assert_eq!(buffers.words[0][0], 1, "the mock accepts t < 10 only");
    let attrs = [1, 2, 3, 4, 5, 6, 7, 8];
    assert_eq!(
        mock.events,
        vec![Event::Report(2.5, 3, attrs), Event::Report(20.0, 4, attrs)]
    );
}

#[test]
fn terminators_end_the_program_from_inside_helpers() {
    let module = jit(DEVICE);
    // ray time 0.25: iterations 0 (0.25) and 1 (0.45) pass, 2 (0.65) ignores.
    let mut buffers = Buffers::new(vec![vec![0; 4]]);
    let mut mock = Mock::default();
    buffers.run(&module, "anyhit__maybe_ignore", &mut mock);
    assert_eq!(buffers.words[0], vec![1, 1, 2, 0]);
    assert_eq!(mock.events, vec![Event::Ignore]);

    let mut buffers = Buffers::new(vec![vec![0; 2]]);
    let mut mock = Mock::default();
    buffers.run(&module, "anyhit__terminate", &mut mock);
    assert_eq!(buffers.words[0], vec![1, 0]);
    assert_eq!(mock.events, vec![Event::Terminate]);

    let mut buffers = Buffers::new(vec![vec![0; 21]]);
    let mut mock = Mock::default();
    buffers.run(&module, "raygen__throw", &mut mock);
    assert_eq!(buffers.words[0][..4], [0, 10, 20, 0]);
    assert_eq!(buffers.words[0][20], 0, "nothing runs after the throw");
    assert_eq!(mock.events, vec![Event::Throw(3)]);
}

/// Wächter and Binder's offset, as the prelude writes it.
fn offset_ray(p: [f32; 3], n: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|i| {
        let of = (256.0 * n[i]) as i32;
        let moved =
            f32::from_bits(
                (p[i].to_bits() as i32).wrapping_add(if p[i] < 0.0 { -of } else { of }) as u32,
            );
        if p[i].abs() < 1.0 / 32.0 {
            p[i] + (1.0 / 65536.0) * n[i]
        } else {
            moved
        }
    })
}

#[test]
fn offset_ray_runs_the_prelude_body() {
    let module = jit(DEVICE);
    let mut rng = Rng(3);
    let mut words = Vec::new();
    let mut inputs = Vec::new();
    for _ in 0..500 {
        let p = [
            rng.float() * 0.01,
            rng.float(),
            (rng.next_u32() % 100) as f32 * 0.001,
        ];
        let nx = rng.float().clamp(-4.0, 4.0);
        words.extend(bits(&[p[0], p[1], p[2], nx, 0.0, 0.0]));
        inputs.push((p, nx));
    }
    let out = run(&module, "raygen__offset", vec![words]);
    for (i, (p, nx)) in inputs.iter().enumerate() {
        let n = [*nx, 1.0, -0.5];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let n = n.map(|c| c / len);
        let want = offset_ray(*p, n);
        for k in 0..3 {
            assert!(
                super::float::same(out[0][i * 6 + k], want[k].to_bits()),
                "{p:?} {n:?}: {k}"
            );
        }
    }
}

#[test]
fn a_panic_in_device_calls_reaches_the_caller() {
    struct Panicking;
    impl DeviceCalls for Panicking {
        fn launch_index(&self) -> [u32; 3] {
            panic!("launch index exploded")
        }
        fn launch_dimensions(&self) -> [u32; 3] {
            [0; 3]
        }
        fn trace(
            &mut self,
            _: [u32; 2],
            _: [f32; 3],
            _: [f32; 3],
            _: f32,
            _: f32,
            _: f32,
            _: u32,
            _: u32,
            _: u32,
            _: u32,
            _: u32,
            _: &mut [u32],
        ) {
        }
        fn get_payload(&self, _: u32) -> u32 {
            0
        }
        fn set_payload(&mut self, _: u32, _: u32) {}
        fn get_attribute(&self, _: u32) -> u32 {
            0
        }
        fn report_intersection(&mut self, _: f32, _: u32, _: &[u32; 8]) -> bool {
            false
        }
        fn ignore_intersection(&mut self) {}
        fn terminate_ray(&mut self) {}
        fn world_ray_origin(&self) -> [f32; 3] {
            [0.0; 3]
        }
        fn world_ray_direction(&self) -> [f32; 3] {
            [0.0; 3]
        }
        fn object_ray_origin(&self) -> [f32; 3] {
            [0.0; 3]
        }
        fn object_ray_direction(&self) -> [f32; 3] {
            [0.0; 3]
        }
        fn ray_tmin(&self) -> f32 {
            0.0
        }
        fn ray_tmax(&self) -> f32 {
            0.0
        }
        fn ray_time(&self) -> f32 {
            0.0
        }
        fn ray_flags(&self) -> u32 {
            0
        }
        fn ray_mask(&self) -> u32 {
            0
        }
        fn primitive_index(&self) -> u32 {
            0
        }
        fn sbt_gas_index(&self) -> u32 {
            0
        }
        fn instance_id(&self) -> u32 {
            0
        }
        fn instance_index(&self) -> u32 {
            0
        }
        fn hit_kind(&self) -> u32 {
            0
        }
        fn is_front_face_hit(&self) -> bool {
            false
        }
        fn triangle_barycentrics(&self) -> [f32; 2] {
            [0.0; 2]
        }
        fn triangle_vertices(&self) -> [[f32; 3]; 3] {
            [[0.0; 3]; 3]
        }
        fn sphere(&self) -> [f32; 4] {
            [0.0; 4]
        }
        fn curve_parameter(&self) -> f32 {
            0.0
        }
        fn object_to_world(&self) -> [f32; 12] {
            [0.0; 12]
        }
        fn world_to_object(&self) -> [f32; 12] {
            [0.0; 12]
        }
        fn sbt_data_u32(&self, _: u32) -> u32 {
            0
        }
        fn direct_call(&mut self, _: u32, _: &mut [u32]) {}
        fn continuation_call(&mut self, _: u32, _: &mut [u32]) {}
        fn throw_exception(&mut self, _: u32) {}
        fn exception_code(&self) -> i32 {
            0
        }
        fn remaining_trace_depth(&self) -> u32 {
            0
        }
    }
    let module = jit(DEVICE);
    let mut buffers = Buffers::new(vec![vec![0; 54]]);
    let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        buffers.run(&module, "closesthit__all", &mut Panicking);
    }));
    let message = caught
        .expect_err("the panic comes back")
        .downcast::<&str>()
        .map(|s| *s);
    assert_eq!(message.ok(), Some("launch index exploded"));
    // The same through a context built once for repeated calls.
    let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        buffers.run_repeated(&module, "closesthit__all", &mut Panicking, 2);
    }));
    let message = caught
        .expect_err("the panic comes back")
        .downcast::<&str>()
        .map(|s| *s);
    assert_eq!(message.ok(), Some("launch index exploded"));
}

/// A state whose every value differs from what the mock's methods return.
fn offered_state(present: u32) -> DeviceState {
    DeviceState {
        present,
        launch_index: [7, 8, 9],
        launch_dimensions: [10, 20, 30],
        world_ray_origin: [-1.0, -2.0, -3.0],
        world_ray_direction: [0.5, 0.5, 0.0],
        object_ray_origin: [-4.0, -5.0, -6.0],
        object_ray_direction: [0.0, 0.0, 1.0],
        ray_tmin: 0.5,
        ray_tmax: 50.0,
        ray_time: 0.75,
        ray_flags: 0x22,
        ray_mask: 0x0f,
        primitive_index: 4242,
        sbt_gas_index: 77,
        instance_id: 55,
        instance_index: 66,
        hit_kind: 0xff,
        triangle_barycentrics: [0.125, 0.375],
        object_to_world: std::array::from_fn(|i| 100.0 + i as f32),
        world_to_object: std::array::from_fn(|i| 200.0 + i as f32),
        remaining_trace_depth: 3,
        ..DeviceState::EMPTY
    }
}

#[test]
fn getters_read_the_offered_state_where_present() {
    let module = jit(DEVICE);
    let all = DeviceState::LAUNCH_INDEX
        | DeviceState::LAUNCH_DIMENSIONS
        | DeviceState::WORLD_RAY
        | DeviceState::OBJECT_RAY
        | DeviceState::RAY
        | DeviceState::PRIMITIVE
        | DeviceState::HIT
        | DeviceState::TRANSFORMS
        | DeviceState::TRACE_DEPTH;
    let mut buffers = Buffers::new(vec![vec![0; 54]]);
    let mut mock = Mock {
        state: Some(Box::new(offered_state(all))),
        ..Mock::default()
    };
    buffers.run(&module, "closesthit__all", &mut mock);
    let out = buffers.words[0].clone();
    assert_eq!(out[0], 7 + 80 + 900);
    assert_eq!(out[1], 60);
    assert_eq!(
        out[2..14],
        bits(&[
            -1.0, -2.0, -3.0, 0.5, 0.5, 0.0, -4.0, -5.0, -6.0, 0.0, 0.0, 1.0
        ])[..]
    );
    assert_eq!(out[14..17], bits(&[0.5, 50.0, 0.75])[..]);
    assert_eq!(out[17..24], [0x22, 0x0f, 4242, 77, 55, 66, 0xff]);
    assert_eq!(out[25..27], bits(&[0.125, 0.375])[..]);
    // Columns 0 and 3 of the row-major 3x4 [100, 101, ...].
    assert_eq!(
        out[34..40],
        bits(&[100.0, 104.0, 108.0, 103.0, 107.0, 111.0])[..]
    );
    assert_eq!(out[47], 3);
    // Not in the state: still the methods.
    assert_eq!(out[24], 1, "is_front_face_hit");
    assert_eq!(out[27..30], bits(&[1.0, 2.0, 3.0])[..], "triangle vertices");
    assert_eq!(out[43], 1003, "sbt data");

    // Only some groups present: the others come from the methods.
    let mut buffers = Buffers::new(vec![vec![0; 54]]);
    let mut mock = Mock {
        state: Some(Box::new(offered_state(
            DeviceState::PRIMITIVE | DeviceState::RAY,
        ))),
        ..Mock::default()
    };
    buffers.run(&module, "closesthit__all", &mut mock);
    let partial = &buffers.words[0];
    assert_eq!(partial[0], 3 + 40 + 500, "launch index from the method");
    assert_eq!(partial[19], 4242, "primitive index from the state");
    assert_eq!(partial[14..17], bits(&[0.5, 50.0, 0.75])[..]);
    assert_eq!(
        partial[25..27],
        bits(&[0.25, 0.5])[..],
        "barycentrics from the method"
    );
}

#[test]
fn state_updates_made_by_calls_are_seen_afterwards() {
    let module = jit(DEVICE);
    let mut buffers = Buffers::new(vec![vec![0; 3]]);
    let mut mock = Mock {
        state: Some(Box::new(offered_state(DeviceState::RAY))),
        ..Mock::default()
    };
    buffers.run(&module, "intersection__tmax", &mut mock);
    assert_eq!(
        buffers.words[0],
        vec![50.0f32.to_bits(), 2.5f32.to_bits(), 1]
    );
}

const UNWIND: &str = r#"
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn trace_in_helper() {
    var p: RtPayload;
    rt_trace(vec2<u32>(1u, 0u), vec3<f32>(0.0), vec3<f32>(0.0, 0.0, 1.0), 0.0, 1.0, 0.0,
        0xffu, 0u, 0u, 1u, 0u, &p);
    out[1] = 1u;
}

fn raygen__trace() {
    out[0] = 1u;
    trace_in_helper();
    out[2] = 1u;
}

fn closesthit__direct() {
    out[0] = 1u;
    var args: RtPayload;
    rt_direct_call(0u, &args);
    out[1] = 1u;
}

fn closesthit__continuation() {
    out[0] = 1u;
    var args: RtPayload;
    rt_continuation_call(0u, &args);
    out[1] = 1u;
}

fn intersection__twice() {
    let attrs = RtAttributes(0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u);
    out[0] = select(0u, 1u, rt_report_intersection(1.0, 0u, attrs));
    out[1] = select(0u, 1u, rt_report_intersection(0.5, 0u, attrs));
}
"#;

#[test]
fn programs_return_when_the_runtime_unwinds() {
    let module = jit(UNWIND);
    for (program, ran, calls) in [
        ("raygen__trace", vec![1, 0, 0], 1),
        ("closesthit__direct", vec![1, 0, 0], 1),
        ("closesthit__continuation", vec![1, 0, 0], 1),
        ("intersection__twice", vec![0, 0, 0], 1),
    ] {
        let mut buffers = Buffers::new(vec![vec![0; 3]]);
        let mut mock = Mock {
            unwind_after_calls: true,
            ..Mock::default()
        };
        buffers.run(&module, program, &mut mock);
        assert_eq!(
            buffers.words[0], ran,
            "{program}: nothing runs after the call"
        );
        assert_eq!(mock.events.len(), calls, "{program}: {:?}", mock.events);

        // Without unwinding every statement runs.
        let mut buffers = Buffers::new(vec![vec![0; 3]]);
        let mut mock = Mock::default();
        buffers.run(&module, program, &mut mock);
        assert_ne!(buffers.words[0], ran, "{program} runs on");
    }
}

const PAYLOAD_ACCESS: &str = r#"
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn closesthit__payload() {
    let n = arrayLength(&out);
    for (var i = 0u; i < n; i++) {
        out[i] = rt_get_payload(i);
        rt_set_payload(i, 100u + i);
    }
    rt_set_payload(0xffffffffu, 1u);
}
"#;

#[test]
fn payload_registers_read_and_written_in_the_offered_memory() {
    let module = jit(PAYLOAD_ACCESS);
    let mut words = [11u32, 12, 13, 14, 0xaaaa];
    let mut mock = Mock {
        state: Some(Box::new(DeviceState {
            present: DeviceState::PAYLOAD,
            payload_len: 4,
            payload: words.as_mut_ptr(),
            ..DeviceState::EMPTY
        })),
        ..Mock::default()
    };
    let mut buffers = Buffers::new(vec![vec![0; 6]]);
    buffers.run(&module, "closesthit__payload", &mut mock);
    assert_eq!(
        buffers.words[0],
        [11, 12, 13, 14, 0, 0],
        "past the length reads 0"
    );
    assert_eq!(
        words,
        [100, 101, 102, 103, 0xaaaa],
        "past the length drops writes"
    );
    assert!(
        mock.events.is_empty(),
        "no method was called: {:?}",
        mock.events
    );

    // Without the bit, the methods answer.
    let mut mock = Mock {
        payload: vec![1, 2],
        state: Some(Box::new(offered_state(DeviceState::RAY))),
        ..Mock::default()
    };
    let mut buffers = Buffers::new(vec![vec![0; 2]]);
    buffers.run(&module, "closesthit__payload", &mut mock);
    assert_eq!(buffers.words[0], [1, 2]);
    assert_eq!(
        mock.events,
        vec![
            Event::SetPayload(0, 100),
            Event::SetPayload(1, 101),
            Event::SetPayload(u32::MAX, 1)
        ]
    );
}

#[test]
fn state_bits_name_what_programs_read() {
    let module = jit(DEVICE);
    let all = module.program("closesthit__all").expect("compiled");
    for bit in [
        DeviceState::LAUNCH_INDEX,
        DeviceState::RAY,
        DeviceState::TRANSFORMS,
        DeviceState::PAYLOAD,
    ] {
        assert_ne!(all.state_bits() & bit, 0, "bit {bit:#x}");
    }
    let code = module.program("exception__code").expect("compiled");
    assert_eq!(code.state_bits(), 0, "rt_exception_code has no state field");
}

#[test]
fn empty_programs_say_they_do_nothing() {
    let module = jit(r#"
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
fn miss__empty() {}
fn miss__only_values() { let x = 3u * 7u; let y = out[2]; }
fn miss__writes() { out[0] = 1u; }
fn miss__calls() { rt_set_payload(0u, 1u); }
fn helper() { out[1] = 2u; }
fn miss__through_a_helper() { helper(); }
"#);
    let nothing = |name: &str| module.program(name).expect("compiled").does_nothing();
    assert!(nothing("miss__empty"));
    assert!(nothing("miss__only_values"));
    for name in ["miss__writes", "miss__calls", "miss__through_a_helper"] {
        assert!(!nothing(name), "{name}");
    }
}
