//! optik-accel: host-side scene building, shared by every backend.
//!
//! Every backend builds the same structures from the same inputs, so the decisions that
//! change what a ray can hit live here once: which primitives can never be hit, the slot
//! order of the obvhs build, the boxes of moving and curved primitives, how a 4-wide node's
//! children are picked, what a traversable handle names. Backends keep only their own
//! encodings of the result (the CPU's wide nodes and triangle blocks, the wgpu arena, the
//! Vulkan acceleration structures), so none depends on another (DESIGN.md §1).
//!
//! - [`Bvh`] / [`BvhNode`]: a binary BVH, 32-byte nodes, root first, siblings adjacent,
//!   leaves covering ranges of primitive *slots*; [`widen::children`] picks the children of
//!   a 4-wide node from it, in the one order every backend uses;
//! - [`Gas`]: a geometry structure: per-slot [`PrimitiveInfo`] and per-key, per-slot
//!   [`Geometry`] (triangle vertices, AABBs, spheres, curve control points), plus a
//!   backend's own [`GasEncoding`];
//! - [`Ias`]: an instance structure: per-slot [`InstanceRecord`]s naming children by handle;
//! - [`Transform`]: static, matrix-motion and SRT-motion transforms, bounded by
//!   [`motion_bounds`];
//! - [`SceneTable`] and the handle encoding in [`handle`]: what a traversable handle names;
//! - [`micromap`]: opacity micromap arrays and the micro-triangle a hit falls in;
//! - [`curve_basis`]: curve segments in Bézier form and their bounds.
//!
//! Builders read inputs through [`decode`] from any [`BufferBytes`] and resolve
//! children through a [`SceneTable`], so they need no device.

mod aabb;
mod bvh;
mod collapse;
pub mod curve_basis;
pub mod decode;
mod gas;
pub mod handle;
mod instances;
pub mod micromap;
mod sah;
pub mod widen;

/// The fewest entries a rayon job of the builders' per-primitive loops takes
/// (`with_min_len`): a structure of a few primitives is then one job on the calling thread,
/// since waking a pool thread costs more than its loop, while a large one still splits into
/// many jobs. (A build of 4 boxes on a 2-thread pool: 2.5 µs with these loops serial, 5.4–7.4
/// µs with every loop split, 3.2–3.4 µs with this floor; 64 boxes 24.3, 27.4 and 24.9 µs.)
pub(crate) const PARALLEL_MIN_LEN: usize = 4096;

/// The nodes of the binary subtree at `root`, each after both its children (its pre-order,
/// reversed): the order of a bottom-up pass over one subtree, walked with an explicit stack
/// (trees can be deep). `first_child(i)` is inner node `i`'s first child (the second is
/// next to it), `None` for a leaf.
pub(crate) fn children_first(
    root: usize,
    first_child: impl Fn(usize) -> Option<usize>,
) -> Vec<usize> {
    let mut order = Vec::new();
    let mut stack = vec![root];
    while let Some(i) = stack.pop() {
        order.push(i);
        if let Some(c) = first_child(i) {
            stack.extend([c, c + 1]);
        }
    }
    order.reverse();
    order
}

/// What the builders' tests share.
#[cfg(test)]
mod testing {
    use crate::decode::BufferBytes;
    use optik_api::Result;
    use optik_api::handle::{Buffer, DeviceId, Handle, RawHandle};

    /// Buffers' bytes by handle slot.
    pub(crate) struct Bytes(pub(crate) Vec<Vec<u8>>);

    impl BufferBytes for Bytes {
        fn bytes(&self, buffer: Buffer) -> Result<&[u8]> {
            Ok(&self.0[buffer.raw().slot as usize])
        }
    }

    /// The handle of [`Bytes`]' buffer `slot`.
    pub(crate) fn buffer(slot: u32) -> Buffer {
        Buffer::from_raw(RawHandle {
            device: DeviceId(0),
            slot,
            generation: 0,
        })
    }

    /// A fixed pseudo-random sequence in `[0, 1)` from `seed` (xorshift64).
    pub(crate) fn uniform(mut seed: u64) -> impl FnMut() -> f32 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        }
    }
}

pub use aabb::Aabb;
pub use bvh::{BuildQuality, Bvh, BvhNode};
pub use collapse::LeafCosts;
pub use decode::BufferBytes;
pub use gas::{
    Curves, CustomPrimitives, Gas, GasEncoding, Geometry, MicromapLookup, MicromapRef,
    PrimitiveInfo, Spheres, TriangleMicromaps, Triangles, curve_caps,
};
pub use handle::{Resolved, SceneTable};
pub use instances::{
    Ias, InstanceRecord, Transform, TransformKind, matrix_motion_bounds, motion_bounds,
    srt_motion_bounds,
};
pub use micromap::MicromapArrayData;

use optik_api::SceneFeatures;

/// Anything a traversable handle can name; `E` is the backend's encoding of geometry.
#[derive(Clone, Debug, PartialEq)]
pub enum Traversable<E: GasEncoding = ()> {
    /// A geometry acceleration structure.
    Geometry(Gas<E>),
    /// An instance acceleration structure.
    Instances(Ias),
    /// A transform.
    Transform(Transform),
}

impl<E: GasEncoding> Traversable<E> {
    /// A box holding everything below, at every time, in the space of whoever references it.
    pub fn bounds(&self) -> Aabb {
        match self {
            Traversable::Geometry(g) => g.bounds,
            Traversable::Instances(i) => i.bounds,
            Traversable::Transform(t) => t.bounds,
        }
    }

    /// What the traversable and everything below it contain.
    pub fn features(&self) -> SceneFeatures {
        match self {
            Traversable::Geometry(g) => g.features,
            Traversable::Instances(i) => i.features,
            Traversable::Transform(t) => t.features,
        }
    }

    /// Levels of instances and transforms above geometry (0 for a geometry structure).
    pub fn depth(&self) -> u32 {
        match self {
            Traversable::Geometry(_) => 0,
            Traversable::Instances(i) => i.depth,
            Traversable::Transform(t) => t.depth,
        }
    }

    /// Bytes the structure occupies.
    pub fn size_in_bytes(&self) -> u64 {
        match self {
            Traversable::Geometry(g) => g.size_in_bytes(),
            Traversable::Instances(i) => i.size_in_bytes(),
            Traversable::Transform(t) => t.size_in_bytes(),
        }
    }

    /// A copy with every array's capacity trimmed to its length (compaction).
    pub fn compacted(&self) -> Traversable<E> {
        // `Clone` of a `Vec` allocates exactly its length.
        self.clone()
    }
}
