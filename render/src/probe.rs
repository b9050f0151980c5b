//! The BSDF probe: the renderer's own WGSL BSDF code run on given directions, for comparison
//! with Mitsuba 3's `eval`, `pdf` and `sample` (VALIDATION's tests).
//!
//! Directions are in Mitsuba's local shading frame: z is the shading normal, `wi` points away
//! from the surface (towards the viewer), `wo` away from it (towards the light).

use crate::error::{Context, RenderError};
use crate::gpu::{Owned, Std140};
use crate::material;
use crate::programs;
use crate::scene::Bsdf;
use optik::{
    Device, LaunchSize, ModuleCompileOptions, PipelineCompileOptions, PipelineLinkOptions,
    ProgramGroupDesc, ProgramRef, ProgramSource, Resource, SbtRecord, ShaderBindingTable,
};

/// One evaluation: incident and outgoing directions (local frame) and texture coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfQuery {
    /// Towards the viewer, local frame.
    pub wi: [f32; 3],
    /// Towards the light, local frame.
    pub wo: [f32; 3],
    /// Texture coordinates.
    pub uv: [f32; 2],
}

/// The BSDF at one query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfValue {
    /// f(wi, wo) · |cos θo| per channel (Mitsuba's `eval`).
    pub value: [f32; 3],
    /// The density of sampling wo given wi (Mitsuba's `pdf`), solid angle.
    pub pdf: f32,
}

/// One BSDF sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSampled {
    /// The sampled direction, local frame (zero when the sample failed).
    pub wo: [f32; 3],
    /// f · |cos θo| / pdf per channel (Mitsuba's sample weight; zero when the sample failed).
    pub weight: [f32; 3],
    /// The sample's density (0 when it failed).
    pub pdf: f32,
    /// Relative index of refraction of the sampled event.
    pub eta: f32,
    /// Whether a Dirac lobe was sampled (a null lobe included, as Mitsuba's `Delta` flag).
    pub delta: bool,
    /// Whether the lobe was a null one (thindielectric's straight transmission).
    pub null: bool,
}

/// Evaluates `bsdf` at each query with the renderer's WGSL code.
pub fn bsdf(
    device: &dyn Device,
    bsdf: &Bsdf,
    queries: &[BsdfQuery],
) -> Result<Vec<BsdfValue>, RenderError> {
    let input: Vec<f32> = queries
        .iter()
        .flat_map(|q| {
            [
                q.wi[0], q.wi[1], q.wi[2], q.wo[0], q.wo[1], q.wo[2], q.uv[0], q.uv[1],
            ]
        })
        .collect();
    let out = run(device, bsdf, "raygen__probe_eval", &input, 4)?;
    Ok(out
        .chunks_exact(4)
        .map(|o| BsdfValue {
            value: [o[0], o[1], o[2]],
            pdf: o[3],
        })
        .collect())
}

/// Samples `bsdf` for incident direction `wi` once per entry of `samples` (`[u1, u2.x, u2.y]`,
/// each in [0, 1)) at texture coordinates `uv`.
pub fn bsdf_sample(
    device: &dyn Device,
    bsdf: &Bsdf,
    wi: [f32; 3],
    uv: [f32; 2],
    samples: &[[f32; 3]],
) -> Result<Vec<BsdfSampled>, RenderError> {
    let items: Vec<([f32; 3], [f32; 3])> = samples.iter().map(|u| (wi, *u)).collect();
    bsdf_sample_each(device, bsdf, uv, &items)
}

/// Samples `bsdf` once per `(wi, [u1, u2.x, u2.y])` item (sample values in [0, 1)) at texture
/// coordinates `uv`, in one launch.
pub fn bsdf_sample_each(
    device: &dyn Device,
    bsdf: &Bsdf,
    uv: [f32; 2],
    items: &[([f32; 3], [f32; 3])],
) -> Result<Vec<BsdfSampled>, RenderError> {
    if let Some(bad) = items
        .iter()
        .flat_map(|(_, u)| u)
        .find(|u| !(0.0..1.0).contains(*u))
    {
        return Err(RenderError::Invalid(format!(
            "sample value {bad}: expected values in [0, 1)"
        )));
    }
    let input: Vec<f32> = items
        .iter()
        .flat_map(|(wi, u)| [wi[0], wi[1], wi[2], u[0], u[1], u[2], uv[0], uv[1]])
        .collect();
    let out = run(device, bsdf, "raygen__probe_sample", &input, 12)?;
    Ok(out
        .chunks_exact(12)
        .map(|o| BsdfSampled {
            wo: [o[0], o[1], o[2]],
            weight: [o[3], o[4], o[5]],
            pdf: o[6],
            eta: o[7],
            delta: o[8] != 0.0,
            null: o[8] == 2.0,
        })
        .collect())
}

/// Runs one probe program over `input` (8 floats per item), returning `out_words` per item.
fn run(
    device: &dyn Device,
    bsdf: &Bsdf,
    entry: &str,
    input: &[f32],
    out_words: usize,
) -> Result<Vec<f32>, RenderError> {
    let count = input.len() / 8;
    if count == 0 {
        return Ok(Vec::new());
    }
    let enc = material::encode(bsdf, &[], "probed BSDF")?;
    let mut owned = Owned::new(device);
    let pipeline_options = PipelineCompileOptions::default();
    let (module, _) = device
        .create_module(
            &ModuleCompileOptions::default(),
            &pipeline_options,
            &ProgramSource::new(
                "optik-render/probe.wgsl",
                programs::probe_module(enc.kind, enc.back.as_ref().map(|b| b.kind)),
            ),
        )
        .during("compiling the BSDF probe")?;
    let module = owned.module(module);
    let groups = device
        .create_program_groups(&[ProgramGroupDesc::Raygen(ProgramRef::new(module, entry))])
        .during("creating the probe's program group")?;
    let groups = owned.groups(groups);
    let pipeline = device
        .create_pipeline(&pipeline_options, &PipelineLinkOptions::default(), &groups)
        .during("linking the probe")?;
    let pipeline = owned.pipeline(pipeline);
    let header = device
        .sbt_record_pack_header(groups[0])
        .during("packing the probe's record")?;
    let sbt_buffer = owned.upload(&header, "the probe's SBT")?;
    let out = owned.zeroed((count * out_words * 4) as u64, "probe results")?;
    let inp = owned.upload(bytemuck::cast_slice(input), "probe queries")?;
    let material = enc.words(0);
    let mat = owned.upload(bytemuck::cast_slice(&material), "probe material")?;
    // The shared Params block, with only probe_count used.
    let mut p = Std140::default();
    for _ in 0..30 {
        p.u(0);
    }
    p.u(count as u32);
    for _ in 0..13 {
        p.u(0);
    }
    let sbt = ShaderBindingTable {
        raygen: SbtRecord {
            buffer: sbt_buffer,
            offset: 0,
        },
        exception: None,
        miss: None,
        hitgroup: None,
        callables: None,
    };
    let resources = [
        Resource::buffer(1, out),
        Resource::buffer(2, inp),
        Resource::buffer(3, mat),
    ];
    device
        .launch(
            pipeline,
            &p.0,
            &resources,
            &sbt,
            LaunchSize::new(count as u32, 1, 1),
        )
        .during("launching the probe")?;
    let mut raw = vec![0u8; count * out_words * 4];
    device
        .read_buffer(out, 0, &mut raw)
        .during("reading probe results")?;
    Ok(bytemuck::cast_slice(&raw).to_vec())
}
