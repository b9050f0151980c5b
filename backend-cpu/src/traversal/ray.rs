//! A ray prepared for box and triangle tests in one space (world or an instance's object
//! space).
//!
//! Signed zeros: every test works on the *canonical* direction, `d + 0.0`, which turns
//! `-0.0` into `+0.0`, so a ray with a `-0.0` component gives bit-for-bit the answers of the
//! same ray with `+0.0` (obvhs's traversal does not: docs/numerics.md F0). A zero component gets
//! the reciprocal `+∞` and its near plane is the box's minimum.

use super::simd::F4;
#[cfg(target_arch = "x86_64")]
use super::simd::F8;

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
    /// Reciprocal for a box's far planes (`inv` times `exit_scale`): the exit distances
    /// come out widened without a multiply per box.
    pub inv_far: [f32; 3],
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
        let dir = canonical(dir);
        let inv = reciprocal(dir);
        let (axes, shear) = shear_of(&dir, &inv);
        PreparedRay {
            origin,
            dir,
            inv,
            inv_far: far_reciprocal(inv, conservative),
            negative: negative(dir),
            axes,
            shear,
            moves: moves(dir),
        }
    }
}

/// `d + 0.0` per component: `-0.0` becomes `+0.0`, every other value stays.
#[inline(always)]
fn canonical(dir: [f32; 3]) -> [f32; 3] {
    [dir[0] + 0.0, dir[1] + 0.0, dir[2] + 0.0]
}

#[inline(always)]
fn reciprocal(dir: [f32; 3]) -> [f32; 3] {
    [1.0 / dir[0], 1.0 / dir[1], 1.0 / dir[2]]
}

/// Factor on a box's exit distance: [`SLAB_WIDENING`] for the conservative test, else 1.
#[inline(always)]
pub(super) fn exit_scale(conservative: bool) -> f32 {
    if conservative { SLAB_WIDENING } else { 1.0 }
}

/// The reciprocal the slab tests multiply a far plane's distance by: `inv` times the exit
/// scale, rounded once per ray. The product `(far − o) · inv_far` carries the same rounding
/// errors as widening `(far − o) · inv` by the scale afterwards (one subtraction, the
/// reciprocal, two roundings of products, each within a factor `1 ± ε/2`), so it keeps every
/// box the exact test hits; folded here it takes a multiply off every node test's chain of
/// dependent operations (docs/cpu-backend.md, "The slab test's chain").
#[inline(always)]
pub(super) fn far_reciprocal(inv: [f32; 3], conservative: bool) -> [f32; 3] {
    let scale = exit_scale(conservative);
    inv.map(|x| x * scale)
}

/// Per axis, whether a canonical direction is negative (the near plane is the box maximum).
#[inline(always)]
fn negative(dir: [f32; 3]) -> [bool; 3] {
    [dir[0] < 0.0, dir[1] < 0.0, dir[2] < 0.0]
}

/// Whether a canonical direction is nonzero (a zero direction hits no built-in primitive).
#[inline(always)]
fn moves(dir: [f32; 3]) -> bool {
    dir[0] != 0.0 || dir[1] != 0.0 || dir[2] != 0.0
}

/// The watertight test's axes and shear constants of a canonical direction and its
/// reciprocal: the axis of largest |direction| last, the other two ordered so the shear
/// keeps the triangle's winding, and `(dx/dz, dy/dz, 1/dz)` along them.
#[inline(always)]
fn shear_of(dir: &[f32; 3], inv: &[f32; 3]) -> ([usize; 3], [f32; 3]) {
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
    // `1.0 / dz` is `inv[kz]`, bit for bit: one division fewer per ray.
    ([kx, ky, kz], [dir[kx] / dz, dir[ky] / dz, inv[kz]])
}

/// A ray's constants for the wide node test and the triangle tests' origin lanes (only
/// what they read, so it stays small to build per ray). The node test splats what it needs
/// into its own registers (`slab::NodeTest`); the triangle tests' constants are
/// [`TriangleLanes`], built from this when the ray first reaches a leaf: most rays of a
/// mostly empty view never do, and the shear's divisions were a fifth of their trace.
#[derive(Clone, Copy)]
pub struct WideRay {
    /// Origin.
    pub origin1: [f32; 3],
    /// Reciprocal of the canonical direction (`+∞` for zero components).
    pub inv1: [f32; 3],
    /// Per axis, whether the direction is negative.
    pub negative: [bool; 3],
    /// The canonical direction, for [`TriangleLanes::new`].
    dir: [f32; 3],
}

impl WideRay {
    /// Prepares `origin`, `dir` (finite) for box tests, bit for bit as [`PreparedRay::new`]
    /// does. (The node test takes the exit scale from the pipeline's switch, a constant
    /// there: `slab::NodeTest`.)
    #[inline(always)]
    pub fn new(origin: [f32; 3], dir: [f32; 3]) -> WideRay {
        let dir = canonical(dir);
        let inv = reciprocal(dir);
        WideRay {
            origin1: origin,
            inv1: inv,
            negative: negative(dir),
            dir,
        }
    }

    /// The lanes of `ray`.
    #[inline(always)]
    pub fn of(ray: &PreparedRay) -> WideRay {
        WideRay {
            origin1: ray.origin,
            inv1: ray.inv,
            negative: ray.negative,
            dir: ray.dir,
        }
    }

    /// Whether the direction is nonzero (as [`PreparedRay::moves`]).
    #[inline(always)]
    pub fn moves(&self) -> bool {
        moves(self.dir)
    }

    /// The box test's scalars, `[origin, reciprocal]`, read word by word
    /// (`traversal::words`): they were stored one by one moments before the walk that reads
    /// them, and LLVM would otherwise merge the reads into wider loads that wait for every
    /// store they span.
    #[inline(always)]
    pub fn box_constants(&self) -> [[f32; 3]; 2] {
        [super::words(&self.origin1), super::words(&self.inv1)]
    }
}

/// The constants of the block triangle tests for one ray, in every lane (four lanes for one
/// block; eight, [`TriangleLanes::widen`], for two blocks at once).
#[derive(Clone, Copy)]
pub struct TriangleLanes<L = F4> {
    /// Origin, per axis (both tests read it).
    pub origin: [L; 3],
    /// Canonical direction, per axis (Möller–Trumbore's test reads it).
    pub dir: [L; 3],
    /// The watertight test's shear constants (as [`PreparedRay::shear`]).
    pub shear: [L; 3],
    /// The watertight test's axes (as [`PreparedRay::axes`]).
    pub axes: [usize; 3],
}

impl TriangleLanes {
    /// The same constants in eight lanes, for the tests of two blocks at once.
    ///
    /// # Safety
    /// The CPU has AVX.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub unsafe fn widen(&self) -> TriangleLanes<F8> {
        // SAFETY: AVX by the contract. Written out, not `map`ped: a closure given to `map`
        // is not always inlined into the AVX leaf that calls this.
        let wide =
            |x: [F4; 3]| unsafe { [F8::from_f4(x[0]), F8::from_f4(x[1]), F8::from_f4(x[2])] };
        TriangleLanes {
            origin: wide(self.origin),
            dir: wide(self.dir),
            shear: wide(self.shear),
            axes: self.axes,
        }
    }

    /// The triangle constants of `ray`, bit for bit those [`PreparedRay::new`] computes.
    #[inline(always)]
    pub fn new(ray: &WideRay) -> TriangleLanes {
        // By reference: indexing copies of the arrays made here would read them back
        // across the stores that made them (a store-forwarding stall per ray).
        let (axes, shear) = shear_of(&ray.dir, &ray.inv1);
        TriangleLanes {
            origin: ray.origin1.map(F4::splat),
            dir: ray.dir.map(F4::splat),
            shear: shear.map(F4::splat),
            axes,
        }
    }

    /// The constants Möller–Trumbore's test reads (the direction): the shear and axes,
    /// which only the watertight test reads, are left zero, and their divisions unpaid.
    #[inline(always)]
    pub fn for_moller_trumbore(ray: &WideRay) -> TriangleLanes {
        TriangleLanes {
            origin: ray.origin1.map(F4::splat),
            dir: ray.dir.map(F4::splat),
            shear: [F4::splat(0.0); 3],
            axes: [0, 1, 2],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The split preparation (box lanes first, triangle lanes later) computes what the
    /// scalar preparation does, bit for bit, signed zeros and axis ties included.
    #[test]
    fn lazily_built_lanes_equal_the_prepared_ray() {
        let dirs = [
            [1.0, 2.0, 3.0],
            [-3.0, 2.0, 1.0],
            [0.5, -0.5, 0.25],
            [-0.0, 0.0, -1.0],
            [1.0, 1.0, 1.0],
            [-1.0, -1.0, 0.0],
            [0.0, 0.0, 0.0],
            [1e-30, -2e30, 3.0],
        ];
        for d in dirs {
            for conservative in [false, true] {
                let o = [0.25, -7.0, 1e5];
                let p = PreparedRay::new(o, d, conservative);
                let w = WideRay::new(o, d);
                let l = TriangleLanes::new(&w);
                let bits = |v: [f32; 3]| v.map(f32::to_bits);
                let lane0 = |v: [F4; 3]| v.map(|x| x.to_array()[0].to_bits());
                assert_eq!(lane0(l.origin), bits(p.origin), "{d:?}");
                assert_eq!(bits(w.origin1), bits(p.origin), "{d:?}");
                assert_eq!(bits(w.inv1), bits(p.inv), "{d:?}");
                assert_eq!(w.negative, p.negative);
                assert_eq!(w.moves(), p.moves, "{d:?}");
                assert_eq!(lane0(l.dir), bits(p.dir), "{d:?}");
                if p.moves {
                    assert_eq!(l.axes, p.axes, "{d:?}");
                    assert_eq!(lane0(l.shear), bits(p.shear), "{d:?}");
                }
            }
        }
    }
}
