//! Opacity and culling: how geometry, instance and ray flags combine (OptiX's flag
//! documentation; the Vulkan spec's opacity rules are the same).
//!
//! 1. The geometry record's `DISABLE_ANYHIT` makes a candidate opaque; an opacity micromap
//!    state, where one applies, replaces it (transparent drops the candidate outright).
//! 2. Instance `DISABLE_ANYHIT` forces opaque, instance `ENFORCE_ANYHIT` non-opaque.
//! 3. Ray `DISABLE_ANYHIT` forces opaque, ray `ENFORCE_ANYHIT` non-opaque (rays win).
//! 4. Ray `CULL_DISABLED_ANYHIT` drops opaque candidates, `CULL_ENFORCED_ANYHIT` non-opaque ones.
//!
//! OptiX calls the pairs at each level mutually exclusive. optik defines them anyway, the
//! same on every backend: the `DISABLE` flag of a pair wins, and both cull flags cull
//! everything.

use crate::flags::{GeometryFlags, InstanceFlags, RayFlags};

/// What happens to a candidate after flag resolution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CandidateFate {
    /// Dropped before any program runs.
    Culled,
    /// Accepted without any-hit.
    Opaque,
    /// Non-opaque: the any-hit program (if the hit group has one) decides.
    NonOpaque,
}

/// An opacity micromap state at the hit point (OptiX/Vulkan encoding 0..=3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MicromapState {
    /// Not hit at all.
    Transparent,
    /// Hit, opaque.
    Opaque,
    /// Any-hit decides; treated as transparent in 2-state mode.
    UnknownTransparent,
    /// Any-hit decides; treated as opaque in 2-state mode.
    UnknownOpaque,
}

impl MicromapState {
    /// The state from its 2-bit code.
    pub fn from_code(code: u32) -> MicromapState {
        match code & 3 {
            0 => MicromapState::Transparent,
            1 => MicromapState::Opaque,
            2 => MicromapState::UnknownTransparent,
            _ => MicromapState::UnknownOpaque,
        }
    }
}

/// Resolves a candidate's fate from the flags on its path.
///
/// `micromap` is the opacity micromap state at the hit, when the triangle has one and the
/// instance does not disable micromaps.
// Inlined: backends call it per candidate, from another crate.
#[inline]
pub fn resolve(
    geometry: GeometryFlags,
    instance: InstanceFlags,
    ray: RayFlags,
    micromap: Option<MicromapState>,
) -> CandidateFate {
    let force_2_state = ray.contains(RayFlags::FORCE_OPACITY_MICROMAP_2_STATE)
        || instance.contains(InstanceFlags::FORCE_OPACITY_MICROMAP_2_STATE);
    let mut opaque = geometry.contains(GeometryFlags::DISABLE_ANYHIT);
    if let Some(state) =
        micromap.filter(|_| !instance.contains(InstanceFlags::DISABLE_OPACITY_MICROMAPS))
    {
        opaque = match (state, force_2_state) {
            (MicromapState::Transparent, _) | (MicromapState::UnknownTransparent, true) => {
                return CandidateFate::Culled;
            }
            (MicromapState::Opaque, _) | (MicromapState::UnknownOpaque, true) => true,
            (MicromapState::UnknownTransparent | MicromapState::UnknownOpaque, false) => false,
        };
    }
    if instance.contains(InstanceFlags::DISABLE_ANYHIT) {
        opaque = true;
    } else if instance.contains(InstanceFlags::ENFORCE_ANYHIT) {
        opaque = false;
    }
    if ray.contains(RayFlags::DISABLE_ANYHIT) {
        opaque = true;
    } else if ray.contains(RayFlags::ENFORCE_ANYHIT) {
        opaque = false;
    }
    if (opaque && ray.contains(RayFlags::CULL_DISABLED_ANYHIT))
        || (!opaque && ray.contains(RayFlags::CULL_ENFORCED_ANYHIT))
    {
        return CandidateFate::Culled;
    }
    if opaque {
        CandidateFate::Opaque
    } else {
        CandidateFate::NonOpaque
    }
}

/// Whether a triangle that faces front (`front`, after instance flipping) is dropped by the
/// ray's face-culling flags, given the geometry's and instance's culling overrides.
#[inline]
pub fn triangle_face_culled(
    front: bool,
    geometry: GeometryFlags,
    instance: InstanceFlags,
    ray: RayFlags,
) -> bool {
    // Most rays cull no faces: their flags decide first (one test per candidate).
    if !ray.intersects(RayFlags::CULL_FRONT_FACING_TRIANGLES | RayFlags::CULL_BACK_FACING_TRIANGLES)
    {
        return false;
    }
    if geometry.contains(GeometryFlags::DISABLE_TRIANGLE_FACE_CULLING)
        || instance.contains(InstanceFlags::DISABLE_TRIANGLE_FACE_CULLING)
    {
        return false;
    }
    (front && ray.contains(RayFlags::CULL_FRONT_FACING_TRIANGLES))
        || (!front && ray.contains(RayFlags::CULL_BACK_FACING_TRIANGLES))
}

#[cfg(test)]
mod tests {
    use super::CandidateFate::*;
    use super::*;

    const G_NONE: GeometryFlags = GeometryFlags::NONE;
    const G_DIS: GeometryFlags = GeometryFlags::DISABLE_ANYHIT;
    const I_NONE: InstanceFlags = InstanceFlags::NONE;
    const I_DIS: InstanceFlags = InstanceFlags::DISABLE_ANYHIT;
    const I_ENF: InstanceFlags = InstanceFlags::ENFORCE_ANYHIT;
    const R_NONE: RayFlags = RayFlags::NONE;
    const R_DIS: RayFlags = RayFlags::DISABLE_ANYHIT;
    const R_ENF: RayFlags = RayFlags::ENFORCE_ANYHIT;
    const R_CD: RayFlags = RayFlags::CULL_DISABLED_ANYHIT;
    const R_CE: RayFlags = RayFlags::CULL_ENFORCED_ANYHIT;

    /// The precedence table of OptiX's flag documentation: ray overrides instance overrides
    /// geometry; cull flags act on the result.
    #[test]
    fn optix_precedence_table() {
        let table: &[(GeometryFlags, InstanceFlags, RayFlags, CandidateFate)] = &[
            (G_NONE, I_NONE, R_NONE, NonOpaque),
            (G_DIS, I_NONE, R_NONE, Opaque),
            // "Instance ENFORCE_ANYHIT overrides OPTIX_GEOMETRY_FLAG_DISABLE_ANYHIT".
            (G_DIS, I_ENF, R_NONE, NonOpaque),
            (G_NONE, I_DIS, R_NONE, Opaque),
            // "Ray ENFORCE_ANYHIT overrides geometry DISABLE_ANYHIT and instance DISABLE_ANYHIT".
            (G_DIS, I_NONE, R_ENF, NonOpaque),
            (G_NONE, I_DIS, R_ENF, NonOpaque),
            (G_DIS, I_DIS, R_ENF, NonOpaque),
            // "Ray DISABLE_ANYHIT overrides instance ENFORCE_ANYHIT".
            (G_NONE, I_ENF, R_DIS, Opaque),
            (G_NONE, I_NONE, R_DIS, Opaque),
            // CULL_DISABLED_ANYHIT: "do not intersect geometry which disables anyhit programs
            // (geometry flag or instance flag)".
            (G_DIS, I_NONE, R_CD, Culled),
            (G_NONE, I_DIS, R_CD, Culled),
            (G_NONE, I_NONE, R_CD, NonOpaque),
            (G_DIS, I_ENF, R_CD, NonOpaque),
            // CULL_ENFORCED_ANYHIT: "do not intersect geometry which has an enabled anyhit
            // program (geometry flag not set or instance ENFORCE_ANYHIT)".
            (G_NONE, I_NONE, R_CE, Culled),
            (G_DIS, I_ENF, R_CE, Culled),
            (G_DIS, I_NONE, R_CE, Opaque),
            (G_NONE, I_DIS, R_CE, Opaque),
        ];
        for &(g, i, r, want) in table {
            assert_eq!(
                resolve(g, i, r, None),
                want,
                "geometry {g:?}, instance {i:?}, ray {r:?}"
            );
        }
    }

    #[test]
    fn exclusive_pairs_are_defined() {
        assert_eq!(resolve(G_NONE, I_DIS | I_ENF, R_NONE, None), Opaque);
        assert_eq!(resolve(G_NONE, I_NONE, R_DIS | R_ENF, None), Opaque);
        assert_eq!(resolve(G_NONE, I_NONE, R_CD | R_CE, None), Culled);
        assert_eq!(resolve(G_DIS, I_NONE, R_CD | R_CE, None), Culled);
    }

    #[test]
    fn micromap_states() {
        use MicromapState::{Opaque, Transparent, UnknownOpaque, UnknownTransparent};
        let fate_opaque = CandidateFate::Opaque;
        let f2 = RayFlags::FORCE_OPACITY_MICROMAP_2_STATE;
        assert_eq!(resolve(G_NONE, I_NONE, R_NONE, Some(Transparent)), Culled);
        // Transparent wins even over a ray forcing any-hit.
        assert_eq!(resolve(G_NONE, I_NONE, R_ENF, Some(Transparent)), Culled);
        assert_eq!(resolve(G_NONE, I_NONE, R_NONE, Some(Opaque)), fate_opaque);
        // The micromap state overrides the geometry bit.
        assert_eq!(
            resolve(G_DIS, I_NONE, R_NONE, Some(UnknownOpaque)),
            NonOpaque
        );
        assert_eq!(
            resolve(G_NONE, I_NONE, R_NONE, Some(UnknownTransparent)),
            NonOpaque
        );
        assert_eq!(
            resolve(G_NONE, I_NONE, f2, Some(UnknownTransparent)),
            Culled
        );
        assert_eq!(
            resolve(G_NONE, I_NONE, f2, Some(UnknownOpaque)),
            fate_opaque
        );
        assert_eq!(
            resolve(
                G_NONE,
                InstanceFlags::FORCE_OPACITY_MICROMAP_2_STATE,
                R_NONE,
                Some(UnknownOpaque)
            ),
            fate_opaque
        );
        // Instances may switch micromaps off: the geometry bit applies again.
        assert_eq!(
            resolve(
                G_NONE,
                InstanceFlags::DISABLE_OPACITY_MICROMAPS,
                R_NONE,
                Some(Transparent)
            ),
            NonOpaque
        );
        // Ray flags still override a micromap's opaque state.
        assert_eq!(resolve(G_NONE, I_NONE, R_ENF, Some(Opaque)), NonOpaque);
        assert_eq!(MicromapState::from_code(3), UnknownOpaque);
    }

    #[test]
    fn face_culling_overrides() {
        let back = RayFlags::CULL_BACK_FACING_TRIANGLES;
        let front = RayFlags::CULL_FRONT_FACING_TRIANGLES;
        assert!(triangle_face_culled(false, G_NONE, I_NONE, back));
        assert!(!triangle_face_culled(true, G_NONE, I_NONE, back));
        assert!(triangle_face_culled(true, G_NONE, I_NONE, front));
        assert!(!triangle_face_culled(
            false,
            GeometryFlags::DISABLE_TRIANGLE_FACE_CULLING,
            I_NONE,
            back
        ));
        assert!(!triangle_face_culled(
            true,
            G_NONE,
            InstanceFlags::DISABLE_TRIANGLE_FACE_CULLING,
            front
        ));
        assert!(!triangle_face_culled(true, G_NONE, I_NONE, R_NONE));
    }
}
