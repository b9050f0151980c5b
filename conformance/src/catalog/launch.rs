//! The `launch` group: launch dimensions and indices, and empty launches.

use crate::case::*;
use crate::kit::uint_channel;
use crate::oracle::model::Models;
use crate::scene::Scene;
use optik::{PipelineCompileOptions, PipelineLinkOptions, Setting};

/// Every case of the `launch` group.
pub fn cases() -> Vec<Case> {
    vec![index_dims(), zero_dims()]
}

const LAUNCH_WGSL: &str = r#"// optik conformance: launch indices and dimensions.
struct Params { value: u32, pad0: u32, pad1: u32, pad2: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> rec: array<u32>;

fn raygen__index() {
    let i = rt_launch_index();
    let d = rt_launch_dimensions();
    let id = i.x + d.x * (i.y + d.y * i.z);
    rec[id * 6u + 0u] = i.x + 1u;
    rec[id * 6u + 1u] = i.y + 1u;
    rec[id * 6u + 2u] = i.z + 1u;
    rec[id * 6u + 3u] = d.x;
    rec[id * 6u + 4u] = d.y;
    rec[id * 6u + 5u] = d.z;
}

fn raygen__touch() {
    rec[0] = params.value;
    rec[15] = params.value;
}
"#;

fn launch_models() -> Models {
    let mut m = Models::new();
    m.add("raygen__index", |ctx| {
        let (i, d) = (ctx.launch_index(), ctx.launch_dimensions());
        let id = ctx.linear_index() as usize;
        for (k, v) in [i[0] + 1, i[1] + 1, i[2] + 1, d[0], d[1], d[2]]
            .into_iter()
            .enumerate()
        {
            ctx.write(1, id * 6 + k, v);
        }
        Ok(())
    });
    m.add("raygen__touch", |ctx| {
        let v = ctx.param(0);
        ctx.write(1, 0, v);
        ctx.write(1, 15, v);
        Ok(())
    });
    m
}

fn launch_pipeline(raygen: &str) -> PipelineDesc {
    PipelineDesc {
        wgsl: LAUNCH_WGSL.into(),
        raygen: raygen.into(),
        miss: vec![],
        hit: vec![],
        callables: vec![],
        exception: None,
        compile: PipelineCompileOptions {
            num_payload_values: Setting::Value(1),
            ..Default::default()
        },
        link: PipelineLinkOptions {
            max_trace_depth: 0,
            ..Default::default()
        },
    }
}

fn index_dims() -> Case {
    let sizes: [[u32; 3]; 8] = [
        [1, 1, 1],
        [16, 16, 16],
        [256, 256, 1],
        [16384, 1, 1],
        [1, 16384, 1],
        [1, 1, 16384],
        [317, 331, 1],
        [1, 1331, 11],
    ];
    Case {
        name: "launch.index_dims".into(),
        group: Group::Launch,
        summary: "every launch index of 1×1×1 … 317×331 and 1×1331×11 launches runs once and sees its index and the dimensions (CTS launchidext/launchsizeext)".into(),
        guards: vec![],
        scene: Scene::default(),
        pipeline: launch_pipeline("raygen__index"),
        models: launch_models(),
        sbt: SbtLayout::default(),
        launches: sizes
            .iter()
            .map(|d| Launch {
                dims: *d,
                params: vec![ParamWord::U32(0)],
                buffers: vec![BufferInit { binding: 1, words: vec![0; d.iter().product::<u32>() as usize * 6] }],
            })
            .collect(),
        record: RecordSpec {
            binding: 1,
            layout: RecordLayout::PerIndex { stride: 6 },
            channels: ["ix", "iy", "iz", "dx", "dy", "dz"].iter().enumerate().map(|(k, n)| uint_channel(n, k)).collect(),
            judgement: Judgement::PerRecord,
        },
        rounding: crate::oracle::geometry::Rounding::EXACT,
        backend_specific: vec![],
    }
}

fn zero_dims() -> Case {
    let sentinel = 0xDEAD_BEEFu32;
    Case {
        name: "launch.zero_dims".into(),
        group: Group::Launch,
        summary: "launches with a zero dimension ((0,0,0), (0,1,1), (1,0,1), (1,1,0)) run nothing and leave buffers untouched, without an error (CTS trace_rays_cmds 0_*)".into(),
        guards: vec![],
        scene: Scene::default(),
        pipeline: launch_pipeline("raygen__touch"),
        models: launch_models(),
        sbt: SbtLayout::default(),
        launches: [[0, 0, 0], [0, 1, 1], [1, 0, 1], [1, 1, 0]]
            .iter()
            .map(|d| Launch {
                dims: *d,
                params: vec![ParamWord::U32(7)],
                buffers: vec![BufferInit { binding: 1, words: vec![sentinel; 16] }],
            })
            .collect(),
        record: RecordSpec {
            binding: 1,
            layout: RecordLayout::WholeBuffer { width: 16 },
            channels: vec![uint_channel("word", 0)],
            judgement: Judgement::PerRecord,
        },
        rounding: crate::oracle::geometry::Rounding::EXACT,
        backend_specific: vec![],
    }
}
