//! WGSL programs assembled from pieces: only the code a scene's features call for.

use crate::features::RenderFeatures;
use crate::material::{BsdfKind, SharedWgsl};
use std::collections::BTreeSet;

const COMMON: &str = include_str!("wgsl/common.wgsl");
const SCENE: &str = include_str!("wgsl/scene.wgsl");
const HIT: &str = include_str!("wgsl/hit.wgsl");
const PATH: &str = include_str!("wgsl/path.wgsl");
const PROBE: &str = include_str!("wgsl/probe.wgsl");
const TWOSIDED: &str = include_str!("wgsl/twosided.wgsl");

/// The closest-hit program's name for `kind`.
pub fn closest_hit_name(kind: BsdfKind) -> String {
    format!("closesthit__{}", kind.name())
}

/// The path tracer's module: common code, the scene's buffers, each BSDF kind present with
/// its closest-hit program, and the path integrator's ray generation program.
pub fn path_module(features: &RenderFeatures) -> String {
    let mut s = String::new();
    s += COMMON;
    s += &format!("const NEE: bool = {};\n", features.shadow_rays);
    s += SCENE;
    s += &shared(features.bsdf_kinds.iter().copied());
    for kind in &features.bsdf_kinds {
        s += kind.wgsl();
        s += &TWOSIDED.replace("KIND", kind.name());
        s += &instantiate_hit(*kind);
    }
    s += PATH;
    s
}

/// hit.wgsl for one kind.
fn instantiate_hit(kind: BsdfKind) -> String {
    let smooth = if kind.smooth() { "NEE" } else { "false" };
    HIT.replace("KIND", kind.name()).replace("SMOOTH", smooth)
}

/// The probe module of one BSDF kind: its functions and the probe's ray generation programs.
pub fn probe_module(kind: BsdfKind) -> String {
    let mut s = String::new();
    s += COMMON;
    s += &shared([kind].into_iter());
    s += kind.wgsl();
    s += &TWOSIDED.replace("KIND", kind.name());
    s += &PROBE.replace("KIND", kind.name());
    s
}

/// The shared pieces (Fresnel, microfacet) the kinds call, each once.
fn shared(kinds: impl Iterator<Item = BsdfKind>) -> String {
    let pieces: BTreeSet<SharedWgsl> = kinds.flat_map(|k| k.needs().iter().copied()).collect();
    pieces.iter().map(|p| p.wgsl()).collect()
}
