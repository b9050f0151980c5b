//! Direct and continuation callables, recursion, and the remaining trace depth.

use crate::common::*;
use optik_api::*;

#[test]
fn direct_calls_from_any_hit_reach_callables_of_its_module_only() {
    let dev = device();
    let a = dev.module(
        "fn raygen__rg() { }\nfn anyhit__ah() {\n    var a: RtPayload;\n    rt_direct_call(0u, &a);\n}\n",
    );
    let b = dev.module("fn direct_callable__dc() { }\n");
    let rg = dev.group(ProgramGroupDesc::Raygen(prog(a, "raygen__rg")));
    let hg = dev.group(ProgramGroupDesc::HitGroup {
        closest_hit: None,
        any_hit: Some(prog(a, "anyhit__ah")),
        intersection: None,
        builtin: BuiltinIntersector::Triangle,
    });
    let dc = dev.group(ProgramGroupDesc::Callables {
        direct: Some(prog(b, "direct_callable__dc")),
        continuation: None,
    });
    let e = dev
        .create_pipeline(
            &PipelineCompileOptions::default(),
            &PipelineLinkOptions::default(),
            &[rg, hg, dc],
        )
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Unsupported);
    assert!(
        e.message().contains("rt_direct_call") && e.message().contains("same module"),
        "{e}"
    );
}
