//! Where a module's code lives: one reservation per module, so the programs' references to
//! one another (32-bit displacements) always reach, and a module too large for it is an
//! error, not a panic.

use super::super::jit::CODE_ARENA_BYTES;
use super::*;

/// A module of `programs` ray generation programs, each with a loop of its own (so the
/// code spans several pages).
fn many_programs(programs: usize) -> String {
    let mut wgsl =
        String::from("@group(0) @binding(1) var<storage, read_write> out: array<u32>;\n");
    for p in 0..programs {
        wgsl.push_str(&format!(
            "fn raygen__p{p}() {{\n    var x = {p}u;\n    for (var i = 0u; i < arrayLength(&out); i++) {{\n        x = x * 1664525u + 1013904223u + out[i];\n        out[i] = x ^ (x >> {s}u) ^ {p}u;\n    }}\n}}\n",
            s = 1 + p % 30
        ));
    }
    wgsl
}

#[test]
fn a_modules_programs_lie_in_one_reservation_and_run() {
    let module =
        JitModule::compile_in_arena(&front(&many_programs(24)), &options(), CODE_ARENA_BYTES)
            .unwrap_or_else(|e| panic!("JIT failed: {e}"));
    let addresses = module.entry_addresses();
    assert_eq!(addresses.len(), 24);
    let (low, high) = (addresses.iter().min(), addresses.iter().max());
    let span = high.unwrap() - low.unwrap();
    assert!(
        span < CODE_ARENA_BYTES,
        "programs {span} bytes apart, beyond the module's reservation"
    );
    assert!(CODE_ARENA_BYTES < i32::MAX as usize);
    let out = run(&module, "raygen__p3", vec![vec![1, 2, 3]]).remove(0);
    let mut x = 3u32;
    let expected: Vec<u32> = [1u32, 2, 3]
        .iter()
        .map(|&v| {
            x = x
                .wrapping_mul(1664525)
                .wrapping_add(1013904223)
                .wrapping_add(v);
            x ^ (x >> 4) ^ 3
        })
        .collect();
    assert_eq!(out, expected);
}

#[test]
fn a_module_beyond_its_reservation_is_an_error_naming_it() {
    let page = 4096;
    let Err(e) = JitModule::compile_in_arena(&front(&many_programs(24)), &options(), page) else {
        panic!("24 programs fit in one page");
    };
    let message = e.to_string();
    assert!(
        message.contains("could not place the module's code in the 4096 bytes reserved for it"),
        "{message}"
    );
}
