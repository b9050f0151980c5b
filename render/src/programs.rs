//! WGSL programs assembled from pieces: only the code a scene's features call for.

use crate::features::RenderFeatures;
use crate::geometry::Primitive;
use crate::material::{BsdfKind, SharedWgsl};
use std::collections::BTreeSet;

const COMMON: &str = include_str!("wgsl/common.wgsl");
const SCENE: &str = include_str!("wgsl/scene.wgsl");
const HIT: &str = include_str!("wgsl/hit.wgsl");
const PATH: &str = include_str!("wgsl/path.wgsl");
const INTEGRATOR_PATH: &str = include_str!("wgsl/integrator_path.wgsl");
const INTEGRATOR_DIRECT: &str = include_str!("wgsl/integrator_direct.wgsl");
const INTEGRATOR_AOV: &str = include_str!("wgsl/integrator_aov.wgsl");
const PROBE: &str = include_str!("wgsl/probe.wgsl");
const TEXTURE: &str = include_str!("wgsl/texture.wgsl");
const MASK: &str = include_str!("wgsl/mask.wgsl");
const ENVMAP: &str = include_str!("wgsl/envmap.wgsl");
/// Stands in for envmap.wgsl where no envmap exists: never called (ENVMAP is false).
const NO_ENVMAP: &str = "fn env_eval(b: u32, d: vec3<f32>) -> vec3<f32> {\n    return vec3<f32>(0.0);\n}\nfn env_pdf(b: u32, d: vec3<f32>) -> f32 {\n    return 0.0;\n}\nfn sample_env(b: u32, x: vec3<f32>, u: vec2<f32>) -> LightSample {\n    return light_none();\n}\n";
/// Stands in for texture.wgsl where no bitmap exists: never called (no texture has kind 2 or 3).
const NO_TEXTURE: &str = "fn tex_bitmap(image: u32, uv: vec2<f32>, bilinear: bool, wrap: u32) -> vec4<f32> {\n    return vec4<f32>(0.0);\n}\n";
const TWOSIDED: &str = include_str!("wgsl/twosided.wgsl");
const TWOSIDED_PAIR: &str = include_str!("wgsl/twosided_pair.wgsl");

/// The name suffix of a primitive type's hit programs.
fn suffix(primitive: Primitive) -> &'static str {
    match primitive {
        Primitive::Triangles => "",
        Primitive::Spheres => "_sphere",
    }
}

/// The name of what shades a hit group: its kind's, or for a twosided material with two
/// different BSDFs `twosided_<front>_<back>` (the pair's functions, twosided_pair.wgsl; `__`
/// is reserved for program prefixes).
pub fn shading_name(kind: BsdfKind, back: Option<BsdfKind>) -> String {
    match back {
        None => kind.name().to_string(),
        Some(back) => format!("twosided_{}_{}", kind.name(), back.name()),
    }
}

/// The closest-hit program's name for `kind` (and the back side's `back`) on `primitive`.
pub fn closest_hit_name(kind: BsdfKind, back: Option<BsdfKind>, primitive: Primitive) -> String {
    format!(
        "closesthit__{}{}",
        shading_name(kind, back),
        suffix(primitive)
    )
}

/// A twosided pair's functions (twosided_pair.wgsl).
fn pair_functions(front: BsdfKind, back: BsdfKind) -> String {
    TWOSIDED_PAIR
        .replace("PAIR", &shading_name(front, Some(back)))
        .replace("FRONT", front.name())
        .replace("BACK", back.name())
}

/// The mask's any-hit program's name on `primitive`.
pub fn any_hit_name(primitive: Primitive) -> String {
    format!("anyhit__mask{}", suffix(primitive))
}

/// The path tracer's module: common code, the scene's buffers, each BSDF kind present with
/// its closest-hit program, and the path integrator's ray generation program.
pub fn path_module(features: &RenderFeatures) -> String {
    let mut s = String::new();
    s += COMMON;
    s += &format!("const NEE: bool = {};\n", features.shadow_rays);
    s += &format!("const INSTANCED: bool = {};\n", features.uses_ias());
    s += &format!("const MASKS: bool = {};\n", features.masks);
    let envmap = features.emitters.contains("envmap");
    s += &format!("const ENVMAP: bool = {envmap};\n");
    s += &material_words();
    s += &light_samplers(features);
    s += if features.bitmap { TEXTURE } else { NO_TEXTURE };
    s += SCENE;
    s += if envmap { ENVMAP } else { NO_ENVMAP };
    s += &shared(features.bsdf_kinds.iter().copied());
    for kind in &features.bsdf_kinds {
        s += kind.wgsl();
        s += &TWOSIDED.replace("KIND", kind.name());
    }
    let mut masked = BTreeSet::new();
    let mut shaded = BTreeSet::new();
    let mut pairs = BTreeSet::new();
    for g in &features.hit_groups {
        if let Some(back) = g.back
            && pairs.insert((g.kind, back))
        {
            s += &pair_functions(g.kind, back);
        }
        // A masked and an opaque material of one kind share the closest-hit program.
        if shaded.insert((g.kind, g.back, g.primitive)) {
            s += &instantiate_hit(g.kind, g.back, g.primitive);
        }
        if g.masked {
            masked.insert(g.primitive);
        }
    }
    for p in masked {
        s += &instantiate_prim(MASK, p);
    }
    s += PATH;
    // Only the scene's integrator: every rt_trace call site costs a traversal in software
    // backends.
    s += match features.integrator {
        "direct" => INTEGRATOR_DIRECT,
        "aov" => INTEGRATOR_AOV,
        _ => INTEGRATOR_PATH,
    };
    s
}

/// `MATERIAL_WORDS`, where a twosided pair's back material follows its front
/// (`material::Encoded::words`, read by scene.wgsl's and probe.wgsl's `back_material`).
fn material_words() -> String {
    format!(
        "const MATERIAL_WORDS: u32 = {}u;\n",
        crate::material::MATERIAL_WORDS
    )
}

/// The light sampler's switches: `sample_light` (scene.wgsl) compiles the sampling code of
/// the light kinds present only. Every closest-hit program that estimates direct light calls
/// it, and drivers inline every call, so an unused sampler costs compile time once per BSDF
/// kind (on lavapipe, minutes for the sphere scenes).
fn light_samplers(features: &RenderFeatures) -> String {
    let has = |name: &str| features.emitters.contains(name);
    [
        ("TRIANGLE", features.area_on.contains(&Primitive::Triangles)),
        ("SPHERE", features.area_on.contains(&Primitive::Spheres)),
        ("POINT", has("point")),
        ("SPOT", has("spot")),
        ("DIRECTIONAL", has("directional")),
        ("CONSTANT", has("constant")),
    ]
    .iter()
    .map(|(kind, on)| format!("const SAMPLE_{kind}: bool = {on};\n"))
    .collect()
}

/// A hit program template for one primitive type.
fn instantiate_prim(template: &str, primitive: Primitive) -> String {
    let prim = match primitive {
        Primitive::Triangles => "mesh",
        Primitive::Spheres => "sphere",
    };
    template
        .replace("SUFFIX", suffix(primitive))
        .replace("PRIM", prim)
}

/// hit.wgsl for one kind (or twosided pair) on one primitive type.
fn instantiate_hit(kind: BsdfKind, back: Option<BsdfKind>, primitive: Primitive) -> String {
    let smooth = kind.smooth() || back.is_some_and(BsdfKind::smooth);
    let smooth = if smooth { "NEE" } else { "false" };
    instantiate_prim(HIT, primitive)
        .replace("KIND", &shading_name(kind, back))
        .replace("SMOOTH", smooth)
}

/// The probe module of one BSDF kind (or, with `back`, of a twosided pair): its functions and
/// the probe's ray generation programs.
pub fn probe_module(kind: BsdfKind, back: Option<BsdfKind>) -> String {
    let kinds: BTreeSet<BsdfKind> = [Some(kind), back].into_iter().flatten().collect();
    let mut s = String::new();
    s += COMMON;
    s += NO_TEXTURE;
    s += &material_words();
    s += &shared(kinds.iter().copied());
    for k in &kinds {
        s += k.wgsl();
        s += &TWOSIDED.replace("KIND", k.name());
    }
    if let Some(back) = back {
        s += &pair_functions(kind, back);
    }
    s += &PROBE.replace("KIND", &shading_name(kind, back));
    s
}

/// The shared pieces (Fresnel, microfacet) the kinds call, each once.
fn shared(kinds: impl Iterator<Item = BsdfKind>) -> String {
    let pieces: BTreeSet<SharedWgsl> = kinds.flat_map(|k| k.needs().iter().copied()).collect();
    pieces.iter().map(|p| p.wgsl()).collect()
}
