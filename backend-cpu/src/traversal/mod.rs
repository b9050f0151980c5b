//! optik's own traversal: robust box and primitive tests over the BVHs of `accel`, instance
//! and transform graphs, motion, and the flag semantics of DESIGN.md §4.
//!
//! The traversal knows geometry, flags and instances; what happens to a candidate (any-hit
//! programs, intersection programs, committing a hit) belongs to a [`Handler`]: the launch
//! runtime's invocation, or a plain closest-hit collector in tests and tools. Pipelines pick a
//! [`Spec`], a set of compile-time switches, so a pipeline without motion never interpolates,
//! one without instancing never transforms a ray, and one without any-hit programs never looks
//! for them (DESIGN.md §6).

mod alone;
mod curve;
mod engine;
mod ray;
mod simd;
mod slab;
mod sphere;
mod triangle;

pub use alone::nearest_triangle_hits;
pub use curve::{
    CURVE_TOLERANCE_RADIUS, CURVE_TOLERANCE_SIZE, CurveHit, MAX_DEPTH as CURVE_MAX_DEPTH,
};
pub use engine::{
    Candidate, CustomPrimitive, HitData, Path, TraceConfig, TraceRay, TriangleVertices,
    blocks_root, misses_bounds, trace, trace_blocks,
};
pub use ray::{PreparedRay, SLAB_WIDENING, TriangleLanes, WideRay};
pub use slab::entry as slab_entry;
pub use sphere::SphereHit;
pub use triangle::{
    BlockHits, TriangleHit, moller_trumbore, moller_trumbore4, watertight, watertight4,
};

/// The intersectors of the built-in primitives, for tools and the wgpu backend's tests.
pub mod intersect {
    pub use super::curve::intersect as curve;
    pub use super::sphere::intersect as sphere;
}

use optik_api::semantics::opacity::CandidateFate;

/// `v` read one 4-byte word at a time, so that values just written word by word (the launch
/// index, the traced ray: scalars in registers stored one by one) are read back the way they
/// were written: the CPU forwards a store to a load that lies within it, never a wider load
/// spanning two stores (which waits for both to reach the cache). LLVM merges plain
/// component reads into wider loads, hence the volatile reads.
#[inline(always)]
pub(crate) fn words<T: Copy, const N: usize>(v: &[T; N]) -> [T; N] {
    // SAFETY: each element of a live reference is valid to read.
    std::array::from_fn(|i| unsafe { std::ptr::read_volatile(&v[i]) })
}

/// `x`, used from the register that holds it: an empty instruction LLVM cannot see through
/// takes it in and hands it back. For a float that a caller stored moments ago and whose
/// value LLVM still holds: read with [`words`] it would come back through memory (a float's
/// store-to-load forwarding costs ~9 cycles on AMD Zen 4, where a general register's round
/// trip costs nothing), and read plainly LLVM may copy it with its neighbours as one wider
/// word across their narrower stores, which waits for all of them to reach the cache.
#[inline(always)]
pub(crate) fn in_register(x: f32) -> f32 {
    #[cfg(target_arch = "x86_64")]
    {
        let mut x = x;
        // SAFETY: an empty instruction (an assembler comment) on one vector register: no
        // memory, stack or flags touched.
        unsafe {
            std::arch::asm!(
                "/* {0} */",
                inout(xmm_reg) x,
                options(pure, nomem, nostack, preserves_flags)
            );
        }
        x
    }
    #[cfg(not(target_arch = "x86_64"))]
    x
}

/// Compile-time switches of a traversal (DESIGN.md §6).
pub trait Spec: 'static {
    /// Interpolate motion keys at the ray's time (else key 0, time ignored).
    const MOTION: bool;
    /// Traverse instance structures and transforms (else only a geometry structure).
    const INSTANCING: bool;
    /// Look up and run any-hit programs (else non-opaque candidates are accepted as opaque).
    const ANY_HIT: bool;
    /// The watertight triangle test (else Möller–Trumbore).
    const WATERTIGHT: bool;
    /// The conservative box test (else plain).
    const CONSERVATIVE: bool;
}

/// A [`Spec`] from const parameters: motion, instancing, any-hit, watertight, conservative.
pub struct Specialised<const M: bool, const I: bool, const A: bool, const W: bool, const C: bool>;

impl<const M: bool, const I: bool, const A: bool, const W: bool, const C: bool> Spec
    for Specialised<M, I, A, W, C>
{
    const MOTION: bool = M;
    const INSTANCING: bool = I;
    const ANY_HIT: bool = A;
    const WATERTIGHT: bool = W;
    const CONSERVATIVE: bool = C;
}

/// Decides the fate of candidates the traversal finds.
pub trait Handler {
    /// The end of the ray's interval now: its tmax, or the distance of the committed hit.
    fn t_max(&self) -> f32;
    /// Whether traversal must stop (terminated ray, or an exception ended the invocation).
    fn done(&self) -> bool;
    /// A built-in primitive (triangle, sphere, curve) hit that passed culling; `fate` is
    /// `Opaque` or `NonOpaque` after flag resolution (with `S::ANY_HIT` false, where both
    /// are accepted alike, `Opaque` unless a micromap or the ray's cull flags needed it).
    fn candidate<S: Spec>(&mut self, candidate: &Candidate<'_>, path: &Path, fate: CandidateFate);
    /// A custom primitive whose box the ray meets (and whose flags do not cull it): run its
    /// intersection program, whose reports carry `fate`.
    fn custom<S: Spec>(
        &mut self,
        primitive: &CustomPrimitive<'_>,
        path: &Path,
        fate: CandidateFate,
    );
    /// A condition the traversal reports under debug exceptions (invalid traversable,
    /// unsupported primitive type).
    fn traversal_exception(&mut self, code: i32);
}

#[cfg(test)]
mod tests;
