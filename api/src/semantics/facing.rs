//! Facing and hit kinds (DESIGN.md §4).
//!
//! A triangle is front-facing when its vertices run counter-clockwise seen from the ray
//! origin, decided in object space: with geometric normal `n = (v1 − v0) × (v2 − v0)`, front
//! means `n · d < 0` for the object-space direction `d`. The instance flag
//! `FLIP_TRIANGLE_FACING` swaps the result. Mirroring instance transforms do not change it,
//! because it is decided in object space.

use crate::flags::{HIT_KIND_TRIANGLE_BACK_FACE, HIT_KIND_TRIANGLE_FRONT_FACE, InstanceFlags};

/// Whether a triangle is front-facing, from the sign of `n · d` in object space and the flip
/// flags of the instances on the path (an odd number of flips swaps).
pub fn is_front_face(normal_dot_direction: f64, flipped: bool) -> bool {
    (normal_dot_direction < 0.0) != flipped
}

/// Whether the instance flags flip facing.
pub fn flips(instance: InstanceFlags) -> bool {
    instance.contains(InstanceFlags::FLIP_TRIANGLE_FACING)
}

/// The hit kind of a triangle hit.
pub fn triangle_hit_kind(front: bool) -> u32 {
    if front {
        HIT_KIND_TRIANGLE_FRONT_FACE
    } else {
        HIT_KIND_TRIANGLE_BACK_FACE
    }
}

/// The hit kind a custom primitive reports: only the low 7 bits count (OptiX reserves
/// 128..=255 for built-in primitives).
pub fn custom_hit_kind(reported: u32) -> u32 {
    reported & 0x7F
}

/// Whether a hit kind is a front-face hit: triangle front faces, and custom kinds (which
/// OptiX's `optixIsFrontFaceHit` counts as front when the low bit is 0).
pub fn hit_kind_is_front(hit_kind: u32) -> bool {
    if hit_kind >= 0x80 {
        hit_kind == HIT_KIND_TRIANGLE_FRONT_FACE
    } else {
        hit_kind & 1 == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn normal(v: [[f64; 3]; 3]) -> [f64; 3] {
        let e1 = [v[1][0] - v[0][0], v[1][1] - v[0][1], v[1][2] - v[0][2]];
        let e2 = [v[2][0] - v[0][0], v[2][1] - v[0][1], v[2][2] - v[0][2]];
        [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ]
    }

    #[test]
    fn ccw_seen_from_origin_is_front() {
        // Counter-clockwise in the xy plane, seen from +z looking down -z.
        let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let n = normal(tri);
        let d_down = [0.0, 0.0, -1.0];
        let d_up = [0.0, 0.0, 1.0];
        let dot = |d: [f64; 3]| n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
        assert!(is_front_face(dot(d_down), false));
        assert!(!is_front_face(dot(d_up), false));
        assert!(!is_front_face(dot(d_down), true));
        assert_eq!(triangle_hit_kind(true), 0xFE);
        assert_eq!(triangle_hit_kind(false), 0xFF);
    }

    #[test]
    fn custom_hit_kinds_keep_seven_bits() {
        assert_eq!(custom_hit_kind(0x7F), 0x7F);
        assert_eq!(custom_hit_kind(0xFE), 0x7E);
        assert!(hit_kind_is_front(0xFE));
        assert!(!hit_kind_is_front(0xFF));
        assert!(hit_kind_is_front(4));
        assert!(!hit_kind_is_front(5));
    }
}
