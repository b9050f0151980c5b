//! A ray prepared for box and triangle tests in one space (world or an instance's object
//! space).
//!
//! Signed zeros: every test works on the *canonical* direction, `d + 0.0`, which turns
//! `-0.0` into `+0.0`, so a ray with a `-0.0` component gives bit-for-bit the answers of the
//! same ray with `+0.0` (obvhs's traversal does not: docs/numerics.md F0). A zero component gets
//! the reciprocal `+∞` and its near plane is the box's minimum.

use super::simd::F4;

/// The factor the conservative box test applies to a box's exit distance: `1 + 2γ(3)` with
/// `γ(n) = nε / (1 − nε)`, `ε = 2⁻²⁴` (pbrt-v4's `Bounds3::IntersectP`, docs/numerics.md, "Conservative slab test").
/// Each computed slab distance is within a factor `1 ± γ(3)` of the exact one (a
/// subtraction, a reciprocal, a product), so widening the exit by `2γ(3)` keeps every box
/// the exact test hits. `2γ(3)` is a little over 6ε, so this is the next f32 above it,
/// `1 + 8ε`.
pub const SLAB_WIDENING: f32 = 1.0 + 4.0 * f32::EPSILON;

/// A ray with the per-ray constants of the slab test and the watertight triangle test.
#[derive(Clone, Copy, Debug)]
pub struct PreparedRay {
    /// Origin.
    pub origin: [f32; 3],
    /// Canonical direction (no `-0.0`).
    pub dir: [f32; 3],
    /// Reciprocal of the canonical direction (`+∞` for zero components).
    pub inv: [f32; 3],
    /// Factor on a box's exit distance: [`SLAB_WIDENING`] when conservative, else 1.
    pub exit_scale: f32,
    /// Per axis, whether the direction is negative (near plane = box maximum).
    pub negative: [bool; 3],
    /// Watertight test: the axis of largest |direction|, then the other two, ordered so
    /// the shear keeps the triangle's winding.
    pub axes: [usize; 3],
    /// Watertight test: shear constants `(dx/dz, dy/dz, 1/dz)` along `axes`.
    pub shear: [f32; 3],
    /// Whether the direction is nonzero (a zero direction hits no built-in primitive).
    pub moves: bool,
}

impl PreparedRay {
    /// Prepares `origin`, `dir` (finite); `conservative` selects the widened reciprocals.
    #[inline]
    pub fn new(origin: [f32; 3], dir: [f32; 3], conservative: bool) -> PreparedRay {
        let dir = [dir[0] + 0.0, dir[1] + 0.0, dir[2] + 0.0];
        let inv = [1.0 / dir[0], 1.0 / dir[1], 1.0 / dir[2]];
        let abs = [dir[0].abs(), dir[1].abs(), dir[2].abs()];
        let kz = if abs[0] >= abs[1] && abs[0] >= abs[2] {
            0
        } else if abs[1] >= abs[2] {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let dz = dir[kz];
        PreparedRay {
            origin,
            dir,
            inv,
            exit_scale: if conservative { SLAB_WIDENING } else { 1.0 },
            negative: [dir[0] < 0.0, dir[1] < 0.0, dir[2] < 0.0],
            axes: [kx, ky, kz],
            // `1.0 / dz` is `inv[kz]`, bit for bit: one division fewer per ray.
            shear: [dir[kx] / dz, dir[ky] / dz, inv[kz]],
            moves: dz != 0.0,
        }
    }
}

/// A [`PreparedRay`]'s constants in all four lanes, for the 4-wide tests (only what they
/// read, so it stays small to build per ray).
#[derive(Clone, Copy)]
pub struct WideRay {
    /// Origin, per axis.
    pub origin: [F4; 3],
    /// Direction, per axis (Möller–Trumbore's four-wide test reads it).
    pub dir: [F4; 3],
    /// Reciprocal direction, per axis.
    pub inv: [F4; 3],
    /// The exit scale of the box test.
    pub exit_scale: F4,
    /// The watertight test's shear constants.
    pub shear: [F4; 3],
    /// Per axis, whether the direction is negative.
    pub negative: [bool; 3],
    /// The watertight test's axes.
    pub axes: [usize; 3],
}

impl WideRay {
    /// The lanes of `ray`.
    #[inline(always)]
    pub fn new(ray: &PreparedRay) -> WideRay {
        WideRay {
            origin: ray.origin.map(F4::splat),
            dir: ray.dir.map(F4::splat),
            inv: ray.inv.map(F4::splat),
            exit_scale: F4::splat(ray.exit_scale),
            shear: ray.shear.map(F4::splat),
            negative: ray.negative,
            axes: ray.axes,
        }
    }
}
