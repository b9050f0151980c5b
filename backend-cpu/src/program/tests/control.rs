//! Control flow, calls, composite values, local and private variables.

use super::*;

const CONTROL: &str = r#"
@group(0) @binding(1) var<storage, read> input: array<i32>;
@group(0) @binding(2) var<storage, read_write> out: array<i32>;

var<private> calls: i32 = 100;
var<private> hist: array<i32, 4>;

struct Pair { a: i32, b: vec2<i32> }

fn classify(x: i32) -> i32 {
    calls += 1;
    switch x & 7 {
        case 0, 1: { return 10; }
        case 2: { if x > 0 { return 20; } }
        case 3, default: { return 30 + (x & 7); }
    }
    return -2;
}

fn bump(p: ptr<function, Pair>, by: i32) {
    (*p).a += by;
    (*p).b[by & 1] += 1;
}

fn early(x: i32) -> i32 {
    var acc = 0;
    loop {
        if acc > 50 { return acc; }
        acc += x & 15;
        continuing {
            acc += 1;
            break if acc > 40;
        }
    }
    return -acc;
}

fn raygen__control() {
    let n = arrayLength(&input);
    for (var i = 0u; i < n; i++) {
        let x = input[i];
        var sum = 0;
        for (var k = 0; k < 10; k++) {
            if k == 3 { continue; }
            if k * (x & 3) > 12 { break; }
            sum += k;
        }
        var w = 0;
        while w < (x & 31) { w += 3; }
        var local: array<i32, 8>;
        for (var k = 0; k < 8; k++) { local[k] = x * k; }
        var p = Pair(x, vec2<i32>(1, 2));
        bump(&p, x);
        hist[u32(x) & 3u] += 1;
        var m = mat3x3<f32>(1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0);
        let ci = u32(x) % 3u;
        let ri = (u32(x) / 3u) % 3u;
        m[ci][ri] = f32(x);
        var v = vec4<i32>(x, 2, 3, 4);
        v[u32(x) & 7u] = 9;
        let o = i * 12u;
        out[o + 0u] = sum;
        out[o + 1u] = w;
        out[o + 2u] = classify(x);
        out[o + 3u] = local[u32(x) & 15u] + local[3];
        out[o + 4u] = p.a * 3 + p.b.x * 5 + p.b.y * 7;
        out[o + 5u] = early(x);
        out[o + 6u] = i32(m[ci][ri]) + i32(m[ri][ci]) * 3 + i32(m[2].z);
        out[o + 7u] = v.x + v.y * 3 + v.z * 5 + v.w * 7;
        out[o + 8u] = calls;
        out[o + 9u] = hist[0] + hist[1] * 10 + hist[2] * 100 + hist[3] * 1000;
        let arr = array<i32, 3>(x, x + 1, x + 2);
        out[o + 10u] = arr[u32(x) & 3u] + vec3<i32>(7, 8, 9)[u32(x) % 5u];
        out[o + 11u] = select(1, 2, any(vec2<bool>(x > 0, x < -5))) + select(10, 20, all(vec3<bool>(x > 0, true, x != 7)));
    }
}
"#;

fn classify(x: i32, calls: &mut i32) -> i32 {
    *calls += 1;
    match x & 7 {
        0 | 1 => 10,
        2 if x > 0 => 20,
        2 => -2,
        other => 30 + other,
    }
}

fn early(x: i32) -> i32 {
    let mut acc = 0;
    loop {
        if acc > 50 {
            return acc;
        }
        acc += x & 15;
        acc += 1;
        if acc > 40 {
            break;
        }
    }
    -acc
}

/// One invocation of the program over all inputs: private state carries across
/// iterations of the loop (it is one invocation) but not across invocations.
fn reference(input: &[i32]) -> Vec<i32> {
    let mut calls = 100;
    let mut hist = [0i32; 4];
    let mut out = Vec::new();
    for &x in input {
        let mut sum = 0;
        for k in 0..10 {
            if k == 3 {
                continue;
            }
            if k * (x & 3) > 12 {
                break;
            }
            sum += k;
        }
        let mut w = 0;
        while w < (x & 31) {
            w += 3;
        }
        let local: Vec<i32> = (0..8).map(|k| x.wrapping_mul(k)).collect();
        let (mut pa, mut pb) = (x, [1, 2]);
        pa = pa.wrapping_add(x);
        pb[(x & 1) as usize] += 1;
        hist[(x as u32 & 3) as usize] += 1;
        let mut m = [[1.0f32, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]];
        let ci = (x as u32 % 3) as usize;
        let ri = ((x as u32 / 3) % 3) as usize;
        m[ci][ri] = x as f32;
        let mut v = [x, 2, 3, 4];
        v[((x as u32 & 7) as usize).min(3)] = 9;
        let class = classify(x, &mut calls);
        out.push(sum);
        out.push(w);
        out.push(class);
        out.push(local[((x as u32 & 15) as usize).min(7)].wrapping_add(local[3]));
        out.push(
            pa.wrapping_mul(3)
                .wrapping_add(pb[0] * 5)
                .wrapping_add(pb[1] * 7),
        );
        out.push(early(x));
        out.push(
            (m[ci][ri] as i32)
                .wrapping_add((m[ri][ci] as i32).wrapping_mul(3))
                .wrapping_add(m[2][2] as i32),
        );
        out.push(
            v[0].wrapping_add(v[1] * 3)
                .wrapping_add(v[2] * 5)
                .wrapping_add(v[3] * 7),
        );
        out.push(calls);
        out.push(hist[0] + hist[1] * 10 + hist[2] * 100 + hist[3] * 1000);
        let arr = [x, x.wrapping_add(1), x.wrapping_add(2)];
        out.push(
            arr[((x as u32 & 3) as usize).min(2)]
                .wrapping_add([7, 8, 9][((x as u32 % 5) as usize).min(2)]),
        );
        out.push(
            if !(-5..=0).contains(&x) { 2 } else { 1 } + if x > 0 && x != 7 { 20 } else { 10 },
        );
    }
    out
}

#[test]
fn control_flow_and_composites_match_rust() {
    let module = jit(CONTROL);
    let mut rng = Rng(5);
    let input: Vec<i32> = (0..2000).map(|_| rng.int() as i32 % 1000).collect();
    let words: Vec<u32> = input.iter().map(|&x| x as u32).collect();
    let mut buffers = Buffers::new(vec![words, vec![0; input.len() * 12]]);
    buffers.run(&module, "raygen__control", &mut Mock::default());
    let got: Vec<i32> = buffers.words[1].iter().map(|&w| w as i32).collect();
    let want = reference(&input);
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(
            g,
            w,
            "input {} (x = {}), result {}",
            i / 12,
            input[i / 12],
            i % 12
        );
    }
}

#[test]
fn private_globals_start_over_at_every_invocation() {
    let module = jit(CONTROL);
    let input = vec![5u32, 6];
    let mut buffers = Buffers::new(vec![input, vec![0; 24]]);
    buffers.run(&module, "raygen__control", &mut Mock::default());
    let first = buffers.words[1].clone();
    buffers.run(&module, "raygen__control", &mut Mock::default());
    assert_eq!(
        buffers.words[1], first,
        "a second invocation sees fresh privates"
    );
    // Within one invocation the counter counts both calls of `classify`.
    assert_eq!((first[8], first[12 + 8]), (101, 102));
    assert_eq!((first[9], first[12 + 9]), (10, 110));
}

const MEMORY_LOCALS: &str = r#"
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

struct Bag { flags: array<bool, 4>, v: array<vec3<f32>, 3>, m: mat2x2<f32> }

fn total(p: ptr<function, array<u32, 8>>, upto: u32) -> u32 {
    var s = 0u;
    for (var i = 0u; i < upto; i++) { s += (*p)[i]; }
    (*p)[upto] = 1000u;
    return s;
}

fn raygen__locals() {
    let n = arrayLength(&out) / 8u;
    for (var i = 0u; i < n; i++) {
        var big: array<u32, 300>;
        big[i * 37u] = i + 1u;
        var small: array<u32, 8>;
        for (var k = 0u; k < 8u; k++) { small[k] = k * i; }
        var bag: Bag;
        bag.flags[i & 3u] = true;
        bag.v[i % 3u][(i + 1u) % 3u] = f32(i);
        bag.m[i & 1u][(i >> 1u) & 1u] = 2.0;
        let o = i * 8u;
        out[o] = big[i * 37u] + big[299] + big[(i * 37u + 1u) % 300u];
        out[o + 1u] = total(&small, i & 7u);
        out[o + 2u] = small[i & 7u];
        out[o + 3u] = select(0u, 1u, bag.flags[0]) | select(0u, 2u, bag.flags[1]) | select(0u, 4u, bag.flags[2]) | select(0u, 8u, bag.flags[3]);
        out[o + 4u] = u32(bag.v[0].y + bag.v[1].z * 10.0 + bag.v[2].x * 100.0);
        out[o + 5u] = u32(bag.m[0][0] + bag.m[0][1] * 10.0 + bag.m[1][0] * 100.0 + bag.m[1][1] * 1000.0);
        out[o + 6u] = u32(!bag.flags[i & 3u]) + u32(all(vec2<bool>(bag.flags[i & 3u], true)));
    }
}
"#;

#[test]
fn locals_in_memory_arrays_of_bools_and_pointer_arguments() {
    let module = jit(MEMORY_LOCALS);
    let n = 12u32;
    let out = run(&module, "raygen__locals", vec![vec![0; n as usize * 8]]).remove(0);
    for i in 0..n {
        let o = (i * 8) as usize;
        let big_index = (i * 37).min(299);
        let neighbour = if (i * 37 + 1) % 300 == big_index {
            i + 1
        } else {
            0
        };
        let last = if big_index == 299 { i + 1 } else { 0 };
        assert_eq!(out[o], (i + 1) + last + neighbour, "big array at {i}");
        let upto = i & 7;
        assert_eq!(
            out[o + 1],
            (0..upto).map(|k| k * i).sum::<u32>(),
            "total at {i}"
        );
        assert_eq!(out[o + 2], 1000, "written through the pointer");
        assert_eq!(out[o + 3], 1 << (i & 3), "bool array at {i}");
        let mut v = [[0.0f32; 3]; 3];
        v[(i % 3) as usize][((i + 1) % 3) as usize] = i as f32;
        assert_eq!(
            out[o + 4],
            (v[0][1] + v[1][2] * 10.0 + v[2][0] * 100.0) as u32,
            "vec3 array at {i}"
        );
        let mut m = [[0.0f32; 2]; 2];
        m[(i & 1) as usize][((i >> 1) & 1) as usize] = 2.0;
        assert_eq!(
            out[o + 5],
            (m[0][0] + m[0][1] * 10.0 + m[1][0] * 100.0 + m[1][1] * 1000.0) as u32
        );
        assert_eq!(out[o + 6], 1);
    }
}

const UNROLLING: &str = r#"
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn raygen__unroll() {
    // More iterations than are unrolled: the copies hand over to a real loop.
    var long = 0u;
    for (var i = 0u; i < 1000u; i++) { long += i * i; }
    // A counted loop whose exit depends on a buffer value after a few iterations.
    var early = 0u;
    for (var i = 0u; i < 8u; i++) {
        if i == out[0] { break; }
        early += i + 1u;
    }
    // Nested counted loops over a small array, and `break if`.
    var a: array<u32, 6>;
    for (var r = 0u; r < 3u; r++) {
        for (var k = 0u; k < 6u; k++) { a[k] = a[k] * 3u + a[(k + r) % 6u] + k; }
    }
    var n = 0u;
    loop {
        n += 2u;
        continuing { break if n >= 11u; }
    }
    out[1] = long;
    out[2] = early;
    out[3] = a[0] ^ (a[1] << 1u) ^ (a[2] << 2u) ^ (a[3] << 3u) ^ (a[4] << 4u) ^ (a[5] << 5u);
    out[4] = n;
}
"#;

#[test]
fn unrolled_loops_compute_what_loops_do() {
    let module = jit(UNROLLING);
    let long = (0..1000u32).fold(0u32, |acc, i| acc.wrapping_add(i * i));
    let mut a = [0u32; 6];
    for r in 0..3 {
        for k in 0..6 {
            a[k] = a[k]
                .wrapping_mul(3)
                .wrapping_add(a[(k + r) % 6])
                .wrapping_add(k as u32);
        }
    }
    let mixed = a[0] ^ (a[1] << 1) ^ (a[2] << 2) ^ (a[3] << 3) ^ (a[4] << 4) ^ (a[5] << 5);
    for stop in [0u32, 3, 7, 100] {
        let out = run(&module, "raygen__unroll", vec![vec![stop, 0, 0, 0, 0]]).remove(0);
        let early: u32 = (0..8u32.min(stop)).map(|i| i + 1).sum();
        assert_eq!(out[1..], [long, early, mixed, 12], "stop at {stop}");
    }
}

#[test]
fn prepared_bindings_give_the_same_results_and_survive_a_module_mix_up() {
    let module = jit(CONTROL);
    let other = jit(UNROLLING);
    let mut rng = Rng(11);
    let mut input: Vec<u32> = (0..50).map(|_| rng.int() % 1000).collect();
    let mut direct = vec![0u32; 50 * 12];
    let mut prepared_out = vec![0u32; 50 * 12];
    let mut params: Vec<u32> = Vec::new();
    let mut bind = |out: &mut Vec<u32>, input: &mut Vec<u32>| {
        [
            BoundResource::Buffer(BoundBuffer {
                ptr: params.as_mut_ptr().cast(),
                len: 0,
            }),
            BoundResource::Buffer(BoundBuffer {
                ptr: input.as_mut_ptr().cast(),
                len: input.len() * 4,
            }),
            BoundResource::Buffer(BoundBuffer {
                ptr: out.as_mut_ptr().cast(),
                len: out.len() * 4,
            }),
        ]
    };
    let f = module.program("raygen__control").unwrap();
    let resources = bind(&mut direct, &mut input);
    f.call(
        &Bindings {
            resources: &resources,
        },
        &mut Mock::default(),
    );
    let resources = bind(&mut prepared_out, &mut input);
    let bindings = Bindings {
        resources: &resources,
    };
    let prepared = module.prepare(&bindings);
    f.call_prepared(&prepared, &mut Mock::default());
    assert_eq!(prepared_out, direct);
    // Bindings prepared for another module's layout are laid out again, not misread.
    prepared_out.iter_mut().for_each(|w| *w = 0);
    let wrong = other.prepare(&bindings);
    f.call_prepared(&wrong, &mut Mock::default());
    assert_eq!(prepared_out, direct);
    // A context built once serves call after call (a launch task's ray generation runs).
    let mut mock = Mock::default();
    let null = std::ptr::null();
    let mut repeated = f
        .repeated(&prepared, &mut mock, null, std::ptr::null(), None)
        .expect("bindings prepared for the program's own module");
    for _ in 0..3 {
        prepared_out.iter_mut().for_each(|w| *w = 0);
        repeated.call(&mut mock);
        assert_eq!(prepared_out, direct);
    }
    // Bindings of another layout get no repeated context (the caller lays them out per call).
    assert!(
        f.repeated(&wrong, &mut mock, null, std::ptr::null(), None)
            .is_none()
    );
}
