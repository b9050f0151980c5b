//! Flag sets with OptiX's bit values.

/// Defines a transparent `u32` flag set with named constants and set operations.
macro_rules! flag_set {
    ($(#[$doc:meta])* $name:ident { $($(#[$cdoc:meta])* $c:ident = $v:expr,)* }) => {
        $(#[$doc])*
        #[derive(Clone, Copy, PartialEq, Eq, Hash, Default, PartialOrd, Ord)]
        pub struct $name(pub u32);

        impl $name {
            /// No flag set.
            pub const NONE: Self = Self(0);
            $($(#[$cdoc])* pub const $c: Self = Self($v);)*
            /// Every named flag.
            pub const ALL: Self = Self(0 $(| $v)*);
            /// Whether every flag of `other` is set.
            pub const fn contains(self, other: Self) -> bool { self.0 & other.0 == other.0 }
            /// Whether any flag of `other` is set.
            pub const fn intersects(self, other: Self) -> bool { self.0 & other.0 != 0 }
            /// Whether no flag is set.
            pub const fn is_empty(self) -> bool { self.0 == 0 }
            /// The bits that name no flag.
            pub const fn unknown_bits(self) -> u32 { self.0 & !Self::ALL.0 }
            /// The named flags that are set.
            pub fn names(self) -> Vec<&'static str> {
                let mut v = Vec::new();
                $(if self.contains(Self::$c) && $v != 0 { v.push(stringify!($c)); })*
                v
            }
        }
        impl std::ops::BitOr for $name { type Output = Self; fn bitor(self, o: Self) -> Self { Self(self.0 | o.0) } }
        impl std::ops::BitOrAssign for $name { fn bitor_assign(&mut self, o: Self) { self.0 |= o.0 } }
        impl std::ops::BitAnd for $name { type Output = Self; fn bitand(self, o: Self) -> Self { Self(self.0 & o.0) } }
        impl std::ops::Not for $name { type Output = Self; fn not(self) -> Self { Self(!self.0) } }
        impl std::fmt::Debug for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                let names = self.names();
                let unknown = self.unknown_bits();
                if names.is_empty() && unknown == 0 { return write!(f, "{}(NONE)", stringify!($name)); }
                write!(f, "{}({}", stringify!($name), names.join(" | "))?;
                if unknown != 0 { write!(f, "{}{:#x}", if names.is_empty() { "" } else { " | " }, unknown)?; }
                write!(f, ")")
            }
        }
    };
}

flag_set!(
    /// Ray flags passed to `rt_trace` (OptiX `OptixRayFlags`; same bits as Vulkan's).
    RayFlags {
        /// Treat every candidate as opaque: no any-hit (Vulkan `OpaqueKHR`).
        DISABLE_ANYHIT = 1 << 0,
        /// Treat every candidate as non-opaque: any-hit runs (Vulkan `NoOpaqueKHR`).
        ENFORCE_ANYHIT = 1 << 1,
        /// Accept the first hit found and end traversal.
        TERMINATE_ON_FIRST_HIT = 1 << 2,
        /// Do not run the closest-hit program.
        DISABLE_CLOSESTHIT = 1 << 3,
        /// Drop back-facing triangles.
        CULL_BACK_FACING_TRIANGLES = 1 << 4,
        /// Drop front-facing triangles.
        CULL_FRONT_FACING_TRIANGLES = 1 << 5,
        /// Drop candidates that are opaque after flag resolution (Vulkan `CullOpaqueKHR`).
        CULL_DISABLED_ANYHIT = 1 << 6,
        /// Drop candidates that are non-opaque after flag resolution (Vulkan `CullNoOpaqueKHR`).
        CULL_ENFORCED_ANYHIT = 1 << 7,
        /// Treat opacity micromap "unknown" states as their known counterparts.
        FORCE_OPACITY_MICROMAP_2_STATE = 1 << 10,
    }
);

flag_set!(
    /// Per-SBT-record geometry flags of a build input (OptiX `OptixGeometryFlags`).
    GeometryFlags {
        /// The geometry is opaque: its any-hit program does not run.
        DISABLE_ANYHIT = 1 << 0,
        /// Any-hit runs exactly once per primitive along a ray (Vulkan `NO_DUPLICATE_ANY_HIT`).
        REQUIRE_SINGLE_ANYHIT_CALL = 1 << 1,
        /// Ray face-culling flags do not apply to these triangles.
        DISABLE_TRIANGLE_FACE_CULLING = 1 << 2,
    }
);

flag_set!(
    /// Instance flags (OptiX `OptixInstanceFlags`).
    InstanceFlags {
        /// Ray face-culling flags do not apply inside this instance.
        DISABLE_TRIANGLE_FACE_CULLING = 1 << 0,
        /// Swap front and back faces of the instance's triangles.
        FLIP_TRIANGLE_FACING = 1 << 1,
        /// Force the instance's geometry opaque.
        DISABLE_ANYHIT = 1 << 2,
        /// Force the instance's geometry non-opaque.
        ENFORCE_ANYHIT = 1 << 3,
        /// Opacity micromap "unknown" states act as their known counterparts.
        FORCE_OPACITY_MICROMAP_2_STATE = 1 << 4,
        /// Ignore opacity micromaps in this instance.
        DISABLE_OPACITY_MICROMAPS = 1 << 5,
    }
);

flag_set!(
    /// Acceleration structure build flags (OptiX `OptixBuildFlags`).
    BuildFlags {
        /// The structure may later be refit with [`crate::BuildOperation::Update`].
        ALLOW_UPDATE = 1 << 0,
        /// The structure may later be compacted.
        ALLOW_COMPACTION = 1 << 1,
        /// Spend more build time for faster traversal.
        PREFER_FAST_TRACE = 1 << 2,
        /// Spend less build time at some cost in traversal.
        PREFER_FAST_BUILD = 1 << 3,
        /// Programs may read triangle vertices (`rt_triangle_vertices`).
        ALLOW_RANDOM_VERTEX_ACCESS = 1 << 4,
        /// Programs may read instances' data at random.
        ALLOW_RANDOM_INSTANCE_ACCESS = 1 << 5,
    }
);

flag_set!(
    /// Motion flags of motion options (OptiX `OptixMotionFlags`).
    MotionFlags {
        /// Before `time_begin` the object vanishes instead of clamping to the first key.
        START_VANISH = 1 << 0,
        /// After `time_end` the object vanishes instead of clamping to the last key.
        END_VANISH = 1 << 1,
    }
);

flag_set!(
    /// Which exceptions a pipeline checks for (OptiX `OptixExceptionFlags`).
    ExceptionFlags {
        /// Stack overflow (continuation-call depth beyond the configured stack).
        STACK_OVERFLOW = 1 << 0,
        /// `rt_trace` beyond the pipeline's `max_trace_depth`.
        TRACE_DEPTH = 1 << 1,
        /// `rt_throw_exception` from programs.
        USER = 1 << 2,
        /// Debug checks: invalid rays, invalid SBT indices, unsupported primitive types.
        DEBUG = 1 << 3,
    }
);

flag_set!(
    /// Primitive types a pipeline supports (OptiX `OptixPrimitiveTypeFlags`).
    PrimitiveTypeFlags {
        /// Custom primitives (AABBs with an intersection program).
        CUSTOM = 1 << 0,
        /// Round quadratic B-spline curves.
        ROUND_QUADRATIC_BSPLINE = 1 << 1,
        /// Round cubic B-spline curves.
        ROUND_CUBIC_BSPLINE = 1 << 2,
        /// Round linear curves.
        ROUND_LINEAR = 1 << 3,
        /// Round Catmull-Rom curves.
        ROUND_CATMULLROM = 1 << 4,
        /// Spheres.
        SPHERE = 1 << 6,
        /// Triangles.
        TRIANGLE = 1 << 31,
    }
);

impl PrimitiveTypeFlags {
    /// Every curve type.
    pub const CURVES: Self = Self(
        Self::ROUND_QUADRATIC_BSPLINE.0
            | Self::ROUND_CUBIC_BSPLINE.0
            | Self::ROUND_LINEAR.0
            | Self::ROUND_CATMULLROM.0,
    );
}

/// Hit kind of a front-facing triangle hit (OptiX `OPTIX_HIT_KIND_TRIANGLE_FRONT_FACE`).
pub const HIT_KIND_TRIANGLE_FRONT_FACE: u32 = 0xFE;
/// Hit kind of a back-facing triangle hit (OptiX `OPTIX_HIT_KIND_TRIANGLE_BACK_FACE`).
pub const HIT_KIND_TRIANGLE_BACK_FACE: u32 = 0xFF;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bit_values_match_optix_and_vulkan() {
        assert_eq!(RayFlags::DISABLE_ANYHIT.0, 1);
        assert_eq!(RayFlags::ENFORCE_ANYHIT.0, 2);
        assert_eq!(RayFlags::TERMINATE_ON_FIRST_HIT.0, 4);
        assert_eq!(RayFlags::DISABLE_CLOSESTHIT.0, 8);
        assert_eq!(RayFlags::CULL_BACK_FACING_TRIANGLES.0, 16);
        assert_eq!(RayFlags::CULL_FRONT_FACING_TRIANGLES.0, 32);
        assert_eq!(RayFlags::CULL_DISABLED_ANYHIT.0, 64);
        assert_eq!(RayFlags::CULL_ENFORCED_ANYHIT.0, 128);
        assert_eq!(RayFlags::FORCE_OPACITY_MICROMAP_2_STATE.0, 1024);
        assert_eq!(PrimitiveTypeFlags::TRIANGLE.0, 1 << 31);
    }

    #[test]
    fn debug_names_flags_and_unknown_bits() {
        let f = RayFlags::DISABLE_ANYHIT | RayFlags(1 << 20);
        assert_eq!(format!("{f:?}"), "RayFlags(DISABLE_ANYHIT | 0x100000)");
        assert_eq!(format!("{:?}", RayFlags::NONE), "RayFlags(NONE)");
    }
}
