//! WGSL written once in the project and shared by the GPU backends (DESIGN.md §3, "Shared
//! WGSL"): the built-in intersectors for spheres and curves. The wgpu megakernel includes these
//! sources; the Vulkan backend compiles them into the intersection stages it uses for sphere
//! and curve build inputs. Each file holds pure functions with names prefixed `optik_`.

/// The sphere intersector: `optik_sphere_roots` (Ray Tracing Gems ch. 7) and the hit kinds
/// built-in primitives report.
pub const SPHERE: &str = include_str!("sphere.wgsl");

/// The round-curve intersector (`optik_curve_intersect`); needs [`SPHERE`] in the same source.
pub const CURVE: &str = include_str!("curve.wgsl");

/// The basis number `optik_curve_intersect` takes for a curve type.
pub fn curve_basis(curve_type: crate::accel::CurveType) -> u32 {
    match curve_type {
        crate::accel::CurveType::RoundLinear => 0,
        crate::accel::CurveType::RoundQuadraticBSpline => 1,
        crate::accel::CurveType::RoundCubicBSpline => 2,
        crate::accel::CurveType::RoundCatmullRom => 3,
    }
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
            "optik_sphere_roots",
            "optik_sphere_normal",
            "optik_curve_intersect",
            "optik_round_cone",
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
}
