//! Launches larger than one `vkCmdTraceRaysKHR` allows run as several dispatches: every
//! launch index runs once and sees the user's index and dimensions, and per-index state
//! (exceptions here) works in every dispatch.

use crate::common::*;
use optik_api::*;
use optik_vulkan::VulkanOptions;

/// Each launch index writes a word mixing its linear index and the launch dimensions; every
/// 1009th throws, and the exception program writes its code instead (per-index state).
const PROGRAMS: &str = r#"
struct Params { a: u32, b: u32, c: u32, d: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn slot() -> u32 {
    let i = rt_launch_index();
    let d = rt_launch_dimensions();
    return i.x + d.x * (i.y + d.y * i.z);
}

fn raygen__rg() {
    let s = slot();
    if s % 1009u == 5u {
        rt_throw_exception(s % 4096u);
    }
    let d = rt_launch_dimensions();
    out[s] = s ^ (d.x * 7u + d.y * 131u + d.z * 1031u);
}

fn exception__ex() {
    out[slot()] = 0x80000000u | bitcast<u32>(rt_exception_code());
}
"#;

/// What launch index `s` of a `size` launch writes.
fn expected(s: u32, size: LaunchSize) -> u32 {
    if s % 1009 == 5 {
        0x8000_0000 | (s % 4096)
    } else {
        s ^ (size.width * 7 + size.height * 131 + size.depth * 1031)
    }
}

/// Runs [`PROGRAMS`] over `size` (exceptions on, so the pipeline keeps per-index state);
/// returns the output words.
fn run(dev: &TestDevice, size: LaunchSize) -> Vec<u32> {
    let m = dev
        .create_module(
            &ModuleCompileOptions::default(),
            &PipelineCompileOptions::default(),
            &ProgramSource::new("launches.wgsl", PROGRAMS),
        )
        .unwrap_or_else(|e| panic!("{e}"))
        .0;
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(m, "raygen__rg")));
    let ex = dev.group(ProgramGroupDesc::Exception(prog(m, "exception__ex")));
    let options = PipelineCompileOptions {
        exception_flags: Setting::Value(ExceptionFlags::USER),
        ..Default::default()
    };
    let pipeline = dev
        .create_pipeline(&options, &PipelineLinkOptions::default(), &[rg, ex])
        .unwrap_or_else(|e| panic!("{e}"));
    let mut table = Table::new(rg);
    table.exception = Some((ex, &[]));
    let sbt = table.build(dev);
    let out = dev.create_buffer(size.count() * 4).unwrap();
    dev.launch(
        pipeline,
        &[0u8; 16],
        &[Resource::buffer(1, out)],
        &sbt,
        size,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    dev.read_u32(out)
}

fn check(out: &[u32], size: LaunchSize) {
    assert_eq!(out.len() as u64, size.count());
    let wrong: Vec<(usize, u32)> = out
        .iter()
        .enumerate()
        .filter(|&(s, &w)| w != expected(s as u32, size))
        .map(|(s, &w)| (s, w))
        .take(5)
        .collect();
    assert!(
        wrong.is_empty(),
        "{size:?}: launch indices with the wrong word (index, word): {wrong:?}"
    );
}

#[test]
fn a_launch_over_the_dispatch_limit_runs_as_several_dispatches() {
    // 7 invocations per dispatch: a 3D launch becomes tiles along every dimension.
    let dev = device_with_options(VulkanOptions {
        validation: true,
        device: None,
        force_staging: false,
        pipeline_cache: false,
        cache_dir: None,
        max_dispatch_invocations: Some(7),
        driver_triangles: None,
    });
    for size in [
        LaunchSize::new(5, 4, 3),
        LaunchSize::new(2020, 1, 1),
        LaunchSize::new(1, 3, 1011),
    ] {
        check(&run(&dev, size), size);
    }
}

#[test]
fn a_launch_whose_state_passes_one_storage_binding_is_split() {
    // 16 bytes of state per launch index: one binding holds range / 16 indices.
    let dev = device();
    let per_binding = dev.info().max_storage_buffer_range as u64 / 16;
    let width = 4096u32;
    let height = (per_binding / width as u64 + 2) as u32;
    let size = LaunchSize::new(width, height, 1);
    assert!(size.count() > per_binding);
    check(&run(&dev, size), size);
}
