//! The caches: the same module twice in memory is one compile; the disk cache gives the
//! same code cold, warm, and off.

use super::*;

const PROGRAM: &str = r#"
struct Params { seed: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@group(0) @binding(2) var<storage, read> a: array<u32>;
@group(0) @binding(3) var<storage, read> b: array<u32>;
@group(0) @binding(4) var<storage, read> c: array<u32>;
var<private> count: u32 = 3u;
var<private> other: vec2<f32>;
fn mix_bits(x: u32) -> u32 { count += 1u; return (x * 2654435761u) ^ (x >> 13u) ^ a[x & 3u] ^ b[x & 1u] ^ c[0] ^ params.seed; }
fn raygen__a() {
    for (var i = 0u; i < arrayLength(&out); i++) { out[i] = mix_bits(i + out[i]) + count; }
}
fn miss__b() { out[0] = bitcast<u32>(sin(f32(out[1])) + other.y); }
"#;

fn results(module: &JitModule) -> Vec<Vec<u32>> {
    let start: Vec<u32> = (0..64).map(|i| i * 7).collect();
    ["raygen__a", "miss__b"]
        .iter()
        .map(|p| run(module, p, vec![start.clone()]).remove(0))
        .collect()
}

#[test]
fn the_same_source_compiles_once_in_memory() {
    let a = jit(PROGRAM);
    let b = jit(PROGRAM);
    assert!(JitModule::same_code(&a, &b));
    let other = JitModule::compile(
        &front(PROGRAM),
        &JitOptions {
            opt_level: optik_api::OptLevel::None,
            ..options()
        },
    )
    .unwrap();
    assert!(
        !JitModule::same_code(&a, &other),
        "another optimisation level is another module"
    );
    assert_eq!(results(&a), results(&other));
}

#[test]
fn disk_cache_cold_warm_and_off_give_the_same_results() {
    let dir = std::env::temp_dir().join(format!("optik-jit-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let module = front(PROGRAM);
    let with_dir = JitOptions {
        disk_cache: DiskCache::Directory(dir.clone()),
        ..JitOptions::default()
    };
    let cold = JitModule::compile_uncached(&module, &with_dir).unwrap();
    assert_eq!(
        (cold.stats().functions, cold.stats().disk_cache_hits),
        (2, 0)
    );
    let warm = JitModule::compile_uncached(&module, &with_dir).unwrap();
    assert_eq!(
        (warm.stats().functions, warm.stats().disk_cache_hits),
        (2, 2),
        "both programs come from disk"
    );
    let off = JitModule::compile_uncached(&module, &options()).unwrap();
    assert_eq!(off.stats().disk_cache_hits, 0);
    let want = results(&off);
    assert_eq!(results(&cold), want);
    assert_eq!(results(&warm), want);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn modules_and_programs_are_shareable_between_threads() {
    fn send_sync<T: Send + Sync>() {}
    fn copy<T: Copy>() {}
    send_sync::<JitModule>();
    send_sync::<crate::program::ProgramFn<'static>>();
    send_sync::<crate::program::PreparedBindings<'static>>();
    copy::<crate::program::ProgramFn<'static>>();
}
