//! Buffers: bounds (`ReadZeroSkipWrite`), `arrayLength`, the params uniform, structs with
//! runtime-sized arrays, and atomics.

use super::*;

const BUFFERS: &str = r#"
struct Params { scale: f32, count: u32, offset: vec2<i32> }
struct Mesh { header: vec4<u32>, normals: array<vec3<f32>> }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> mesh: Mesh;
@group(0) @binding(2) var<storage, read> idx: array<u32>;
@group(0) @binding(3) var<storage, read_write> out: array<u32>;
@group(0) @binding(4) var<storage, read_write> fixed: array<u32, 4>;

fn raygen__buffers() {
    let n = arrayLength(&idx);
    out[0] = arrayLength(&mesh.normals);
    out[1] = bitcast<u32>(params.scale) ^ params.count ^ bitcast<u32>(params.offset.y);
    out[2] = mesh.header.w;
    for (var i = 0u; i < n; i++) {
        let k = idx[i];
        let nrm = mesh.normals[k];
        out[3u + i * 3u] = bitcast<u32>(nrm.x * params.scale);
        out[4u + i * 3u] = bitcast<u32>(nrm.z);
        out[5u + i * 3u] = fixed[k] + mesh.header[k];
        // Writes past the end are dropped.
        out[k + 100000u] = 7u;
        fixed[k] = k;
    }
}
"#;

fn f(x: f32) -> u32 {
    x.to_bits()
}

#[test]
fn out_of_bounds_reads_give_zero_and_writes_are_dropped() {
    let module = jit(BUFFERS);
    // Mesh: header (4 words) then 3 normals of 4 words (vec3 stride 16), and one stray word
    // (not a whole element: arrayLength ignores it).
    let mut mesh = vec![10, 11, 12, 13];
    for v in 0..3 {
        mesh.extend([f(v as f32 + 0.5), f(1.0), f(-(v as f32)), 0]);
    }
    mesh.push(99);
    let idx = vec![0, 2, 3, 1, u32::MAX, 4, 0x8000_0000];
    let n = idx.len();
    let mut buffers = Buffers::new(vec![
        mesh,
        idx.clone(),
        vec![0; 3 + 3 * n],
        vec![50, 51, 52, 53],
    ]);
    buffers.params = vec![f(2.0), 5, 6, 7];
    buffers.run(&module, "raygen__buffers", &mut Mock::default());
    let out = &buffers.words[2];
    assert_eq!(out[0], 3, "arrayLength counts whole elements");
    assert_eq!(out[1], f(2.0) ^ 5 ^ 7);
    assert_eq!(out[2], 13);
    let mut fixed = [50u32, 51, 52, 53];
    for (i, &k) in idx.iter().enumerate() {
        let (nx, nz) = if k < 3 {
            (f((k as f32 + 0.5) * 2.0), f(-(k as f32)))
        } else {
            (0, 0)
        };
        let fx = fixed.get(k as usize).copied().unwrap_or(0);
        let header = [10, 11, 12, 13].get(k as usize).copied().unwrap_or(0);
        assert_eq!(out[3 + 3 * i], nx, "normal x at index {k}");
        assert_eq!(out[4 + 3 * i], nz, "normal z at index {k}");
        assert_eq!(
            out[5 + 3 * i],
            fx + header,
            "fixed array and vector at index {k}"
        );
        if let Some(slot) = fixed.get_mut(k as usize) {
            *slot = k;
        }
    }
    assert_eq!(
        buffers.words[3],
        fixed.to_vec(),
        "in-bounds writes land, others are dropped"
    );
}

#[test]
fn a_buffer_smaller_than_its_type_reads_zero_past_its_end() {
    let module = jit(BUFFERS);
    // `fixed` is declared as 4 words but only 2 are bound; params bound empty.
    let mut buffers = Buffers::new(vec![
        vec![1, 2, 3, 4],
        vec![0, 1, 2, 3],
        vec![0; 15],
        vec![5, 6, 7, 8],
    ]);
    buffers.bound[3] = 8;
    buffers.run(&module, "raygen__buffers", &mut Mock::default());
    let out = &buffers.words[2];
    assert_eq!(out[0], 0, "a mesh of 16 bytes has no normals");
    assert_eq!(out[1], 0, "unbound params read as zero");
    let fixed_reads: Vec<u32> = (0..4).map(|i| out[5 + 3 * i]).collect();
    assert_eq!(
        fixed_reads,
        vec![5 + 1, 6 + 2, 3, 4],
        "words 2 and 3 are past the bound length"
    );
    assert_eq!(
        buffers.words[3],
        vec![0, 1, 7, 8],
        "writes past the bound length are dropped"
    );
}

/// Reads every field of `params` inside a loop (loads the compiler may hoist) and writes
/// them out.
const PARAMS_IN_A_LOOP: &str = r#"
struct Params { a: u32, b: u32, c: u32, d: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32, 8>;

fn raygen__params() {
    for (var i = 0u; i < 2u; i++) {
        out[i * 4u] += params.a;
        out[i * 4u + 1u] += params.b;
        out[i * 4u + 2u] += params.c;
        out[i * 4u + 3u] += params.d;
    }
}
"#;

#[test]
fn params_shorter_than_their_type_read_zero_past_their_end() {
    let module = jit(PARAMS_IN_A_LOOP);
    // Read unchecked at constant offsets (`host::SlotLayout`): a table built for a call
    // pads params shorter than their type with zeros, as bounds checks would have read.
    for bound_words in 0..=4 {
        let mut buffers = Buffers::new(vec![vec![0; 8]]);
        buffers.params = vec![10, 20, 30, 40];
        buffers.params.truncate(bound_words);
        buffers.run(&module, "raygen__params", &mut Mock::default());
        // Through bindings prepared once, as launches call programs.
        buffers.run_repeated(&module, "raygen__params", &mut Mock::default(), 2);
        let seen: Vec<u32> = (0..4)
            .map(|k| {
                if k < bound_words {
                    30 * (k as u32 + 1)
                } else {
                    0
                }
            })
            .collect();
        let expected: Vec<u32> = seen.iter().chain(&seen).copied().collect();
        assert_eq!(
            buffers.words[0], expected,
            "{bound_words} words of params bound"
        );
    }
}

#[test]
fn params_read_at_constant_offsets_are_not_bounds_checked() {
    // The same program with its values in a read-only storage buffer instead: its reads
    // are checked; the params' are not.
    let storage = PARAMS_IN_A_LOOP
        .replace("var<uniform> params", "var<storage, read> params")
        .replace("@binding(0) var<storage", "@binding(2) var<storage");
    let checks = |wgsl: &str| {
        let stats = jit(wgsl).stats();
        // Per compiled function: the program and, on Linux, its launch loop.
        let functions = stats.functions + stats.launch_loops;
        assert_eq!(stats.bounds_checks % functions, 0, "{stats:?}");
        stats.bounds_checks / functions
    };
    // The loop is unrolled: two iterations of four read-modify-writes of `out` (a
    // fixed-size array at constant indices, whose accesses are checked: only the params'
    // length is given) and four reads of the values.
    assert_eq!(checks(&storage), 2 * (4 * 2 + 4));
    assert_eq!(checks(PARAMS_IN_A_LOOP), 2 * (4 * 2));
}

const ATOMICS: &str = r#"
@group(0) @binding(1) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(2) var<storage, read_write> signed: array<atomic<i32>, 2>;
@group(0) @binding(3) var<storage, read_write> out: array<u32>;

fn raygen__atomics() {
    out[0] = atomicAdd(&counters[0], 5u);
    out[1] = atomicSub(&counters[1], 1u);
    out[2] = atomicMax(&counters[2], 7u);
    out[3] = atomicMin(&counters[3], 7u);
    out[4] = atomicAnd(&counters[4], 6u);
    out[5] = atomicOr(&counters[5], 6u);
    out[6] = atomicXor(&counters[6], 6u);
    out[7] = atomicExchange(&counters[7], 42u);
    let r = atomicCompareExchangeWeak(&counters[8], 3u, 30u);
    out[8] = r.old_value + select(0u, 1000u, r.exchanged);
    let s = atomicCompareExchangeWeak(&counters[9], 3u, 30u);
    out[9] = s.old_value + select(0u, 1000u, s.exchanged);
    out[10] = bitcast<u32>(atomicMin(&signed[0], -5));
    out[11] = bitcast<u32>(atomicMax(&signed[1], -5));
    out[12] = atomicLoad(&counters[0]);
    atomicStore(&counters[10], 77u);
    // Out of bounds: nothing happens, the result is 0.
    out[13] = atomicAdd(&counters[1000], 1u) + 1u;
    let t = atomicCompareExchangeWeak(&counters[1000], 0u, 1u);
    out[14] = t.old_value + select(0u, 1000u, t.exchanged);
}
"#;

#[test]
fn atomics_update_buffers_and_return_the_old_value() {
    let module = jit(ATOMICS);
    let counters = vec![10, 10, 5, 5, 3, 3, 3, 1, 3, 4, 0];
    let signed = vec![2u32, 2u32];
    let mut buffers = Buffers::new(vec![counters, signed, vec![0; 15]]);
    buffers.run(&module, "raygen__atomics", &mut Mock::default());
    assert_eq!(buffers.words[0], vec![15, 9, 7, 5, 2, 7, 5, 42, 30, 4, 77]);
    assert_eq!(buffers.words[1], vec![(-5i32) as u32, 2]);
    assert_eq!(
        buffers.words[2],
        vec![10, 10, 5, 5, 3, 3, 3, 1, 1003, 4, 2, 2, 15, 1, 0]
    );
}

#[test]
fn atomics_are_atomic_across_threads() {
    let module = jit(ATOMICS);
    let mut words = vec![0u32; 11];
    let (ptr, len) = (words.as_mut_ptr() as usize, words.len() * 4);
    std::thread::scope(|s| {
        for _ in 0..4 {
            let module = &module;
            s.spawn(move || {
                let mut signed = vec![0u32; 2];
                let mut out = vec![0u32; 15];
                let mut params = vec![0u32; 1];
                let resources = [
                    BoundResource::Buffer(BoundBuffer {
                        ptr: params.as_mut_ptr().cast(),
                        len: 0,
                    }),
                    BoundResource::Buffer(BoundBuffer {
                        ptr: ptr as *mut u8,
                        len,
                    }),
                    BoundResource::Buffer(BoundBuffer {
                        ptr: signed.as_mut_ptr().cast(),
                        len: 8,
                    }),
                    BoundResource::Buffer(BoundBuffer {
                        ptr: out.as_mut_ptr().cast(),
                        len: 60,
                    }),
                ];
                let f = module.program("raygen__atomics").unwrap();
                for _ in 0..1000 {
                    f.call(
                        &Bindings {
                            resources: &resources,
                        },
                        &mut Mock::default(),
                    );
                }
            });
        }
    });
    assert_eq!(words[0], 4 * 1000 * 5, "no lost updates");
}
