//! Constructs the JIT cannot lower are compile errors at the user's line, never panics.

use super::*;
use optik_api::ErrorKind;

fn error_of(wgsl: &str) -> optik_api::Error {
    JitModule::compile(&front(wgsl), &options()).expect_err("the JIT must refuse this module")
}

#[test]
fn texture_gather_is_refused_at_its_line() {
    let e = error_of(
        "@group(0) @binding(1) var tex: texture_2d<f32>;
@group(0) @binding(2) var smp: sampler;
@group(0) @binding(3) var<storage, read_write> out: array<vec4<f32>>;
fn raygen__gather() {
    out[0] = textureGather(0, tex, smp, vec2<f32>(0.5));
}
",
    );
    assert_eq!(e.kind(), ErrorKind::Compile);
    let d = &e.diagnostics()[0];
    assert_eq!((d.file.as_str(), d.line), ("test.wgsl", 5), "{e}");
    assert!(
        d.message.contains("textureGather") && d.message.contains("raygen__gather"),
        "{e}"
    );
}

#[test]
fn an_override_without_a_default_is_refused() {
    let e = error_of(
        "@group(0) @binding(1) var<storage, read_write> out: array<f32>;

override gain: f32;
fn raygen__o() {
    out[0] = gain;
}
",
    );
    let d = &e.diagnostics()[0];
    assert_eq!(d.line, 3, "{e}");
    assert!(d.message.contains("override `gain` has no default"), "{e}");
}

#[test]
fn overrides_take_their_defaults() {
    let module = jit(
        "@group(0) @binding(1) var<storage, read_write> out: array<f32>;
override gain: f32 = 2.5;
override twice = gain * 2.0;
fn raygen__o() {
    out[0] = gain;
    out[1] = twice;
}
",
    );
    let out = run(&module, "raygen__o", vec![vec![0; 2]]);
    assert_eq!(out[0], vec![2.5f32.to_bits(), 5.0f32.to_bits()]);
}
