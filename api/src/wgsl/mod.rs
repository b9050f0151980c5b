//! WGSL written once in the project and shared by the GPU backends (DESIGN.md §3, "Shared
//! WGSL"). The wgpu megakernel includes all of it; the Vulkan backend compiles the sphere and
//! curve intersectors into its intersection stages, and can use the traversal pieces inside
//! intersection programs for what its driver lacks (motion).
//!
//! Two families of snippets, each plain WGSL of pure functions:
//! - the built-in intersectors [`SPHERE`] and [`CURVE`];
//! - the software traversal pieces: [`RAY`], [`SLAB`], [`TRIANGLE`], [`MOTION`], [`BVH4`],
//!   [`MICROMAP`], [`OPACITY`].
//!
//! Every module-scope name in them, and in the WGSL the backends generate around the user's
//! programs, starts with [`INTERNAL_PREFIX`] (`_optik_name` for functions and variables,
//! `_OPTIK_NAME` for constants, `_OptikName` for types); the front end refuses user names
//! that do (`optik_core::frontend::compile`), so the two never clash.
//!
//! Dependencies: [`CURVE`] needs [`SPHERE`]; [`SLAB`], [`TRIANGLE`] and [`MOTION`] need [`RAY`];
//! [`BVH4`] needs [`RAY`] and [`SLAB`]; [`BVH4`] and [`MICROMAP`] call
//! `fn _optik_fetch(i: u32) -> vec4<u32>`, which the including shader defines over its scene
//! data. Lines tagged `// @conservative`, `// @plain` or `// @f64` are optional: [`specialise`]
//! keeps or drops them (the conservative or the plain slab test; no f64 fallback where the
//! device has no f64).

/// The prefix, compared without regard to ASCII case, of every internal WGSL name: the shared
/// snippets here and what the backends generate. User names may not start with it.
pub const INTERNAL_PREFIX: &str = "_optik";

/// Whether `name` starts with [`INTERNAL_PREFIX`] in any letter case.
pub fn is_internal_name(name: &str) -> bool {
    name.get(..INTERNAL_PREFIX.len())
        .is_some_and(|p| p.eq_ignore_ascii_case(INTERNAL_PREFIX))
}

/// The sphere intersector: `_optik_sphere_roots` (Ray Tracing Gems ch. 7) and the hit kinds
/// built-in primitives report.
pub const SPHERE: &str = include_str!("sphere.wgsl");

/// The round-curve intersector (`_optik_curve_intersect`); needs [`SPHERE`] in the same source.
pub const CURVE: &str = include_str!("curve.wgsl");

/// The basis number `_optik_curve_intersect` takes for a curve type.
pub fn curve_basis(curve_type: crate::accel::CurveType) -> u32 {
    match curve_type {
        crate::accel::CurveType::RoundLinear => 0,
        crate::accel::CurveType::RoundQuadraticBSpline => 1,
        crate::accel::CurveType::RoundCubicBSpline => 2,
        crate::accel::CurveType::RoundCatmullRom => 3,
    }
}

/// Ray validity (the invalid-ray policy), `-0.0` canonicalisation, slab-test set-up.
pub const RAY: &str = include_str!("ray.wgsl");
/// Four-wide and single slab tests, conservative (1 + 2γ(3)) or plain.
pub const SLAB: &str = include_str!("slab.wgsl");
/// Watertight (Woop et al. 2013, f64 fallback) and Möller–Trumbore triangle tests.
pub const TRIANGLE: &str = include_str!("triangle.wgsl");
/// 3×4 transforms, motion key resolution, matrix lerp and SRT nlerp.
pub const MOTION: &str = include_str!("motion.wgsl");
/// The BVH4 node layout of the software traversal and its four-wide node test.
pub const BVH4: &str = include_str!("bvh4.wgsl");
/// Opacity micromap micro-triangle indexing and state lookup.
pub const MICROMAP: &str = include_str!("micromap.wgsl");
/// A candidate's fate from its geometry, instance and ray flags and micromap state
/// (`_optik_fate`, `semantics::opacity::resolve`).
pub const OPACITY: &str = include_str!("opacity.wgsl");

/// Which optional lines of the snippets to keep.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SnippetOptions {
    /// Keep the `@conservative` lines (the slab test widened by 1 + 2γ(3)) rather than the
    /// `@plain` ones.
    pub conservative_boxes: bool,
    /// Keep the `@f64` lines: the exact fallback of the watertight triangle test, which
    /// needs WGSL's `f64` (wgpu's `SHADER_F64`).
    pub f64_fallback: bool,
}

/// `source` with the optional lines `options` leaves out removed and the tags stripped.
pub fn specialise(source: &str, options: SnippetOptions) -> String {
    let mut out = String::with_capacity(source.len());
    for line in source.lines() {
        let (code, keep) = if let Some(code) = line.strip_suffix(" // @conservative") {
            (code, options.conservative_boxes)
        } else if let Some(code) = line.strip_suffix(" // @plain") {
            (code, !options.conservative_boxes)
        } else if let Some(code) = line.strip_suffix(" // @f64") {
            (code, options.f64_fallback)
        } else {
            (line, true)
        };
        if keep {
            out.push_str(code);
            out.push('\n');
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shared_sources_parse_and_validate_together() {
        let src = format!("{SPHERE}\n{CURVE}");
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)));
        for name in [
            "_optik_sphere_roots",
            "_optik_sphere_normal",
            "_optik_curve_intersect",
            "_optik_round_cone",
        ] {
            assert!(
                module
                    .functions
                    .iter()
                    .any(|(_, f)| f.name.as_deref() == Some(name)),
                "{name} missing"
            );
        }
    }

    fn validate(src: &str, f64: bool) {
        let module = naga::front::wgsl::parse_str(src)
            .unwrap_or_else(|e| panic!("{}", e.emit_to_string(src)));
        let mut caps = naga::valid::Capabilities::default();
        caps.set(naga::valid::Capabilities::FLOAT64, f64);
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), caps)
            .validate(&module)
            .unwrap_or_else(|e| panic!("{}", e.emit_to_string(src)));
    }

    #[test]
    fn every_combination_validates() {
        for conservative_boxes in [false, true] {
            for f64_fallback in [false, true] {
                let options = SnippetOptions {
                    conservative_boxes,
                    f64_fallback,
                };
                let mut src = String::from(
                    "@group(0) @binding(0) var<storage, read> data: array<vec4<u32>>;\nfn _optik_fetch(i: u32) -> vec4<u32> { return data[i]; }\n",
                );
                for s in [
                    RAY, SLAB, TRIANGLE, SPHERE, CURVE, MOTION, BVH4, MICROMAP, OPACITY,
                ] {
                    src.push_str(&specialise(s, options));
                }
                validate(&src, f64_fallback);
                assert_eq!(src.contains("_OPTIK_SLAB_WIDEN;"), conservative_boxes);
                assert_eq!(
                    src.contains("* _OPTIK_SLAB_WIDEN, vec4<f32>(tmax)"),
                    conservative_boxes
                );
                assert_eq!(
                    src.contains("min(max(az, bz), vec4<f32>(tmax))"),
                    !conservative_boxes
                );
                assert_eq!(src.contains("f64("), f64_fallback);
                assert!(!src.contains("// @"));
            }
        }
    }
}
