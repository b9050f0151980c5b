//! Acceleration structures: built with obvhs's PLOC builder, stored in optik's own layout.
//!
//! This module is the CPU backend's and the wgpu backend's source of built structures (the
//! wgpu backend uploads them as they are), so everything here is public and documented:
//!
//! - [`Bvh`] / [`BvhNode`]: a binary BVH, 32-byte nodes, root first, siblings adjacent,
//!   leaves covering ranges of primitive *slots*;
//! - [`wide::WideBvh`]: the same tree collapsed to 4-wide nodes, with triangles packed four
//!   to a block: what the CPU traversal walks (the wgpu backend ignores it);
//! - [`Gas`]: a geometry structure: per-slot [`PrimitiveInfo`] and per-key, per-slot
//!   [`Geometry`] (triangle vertices, AABBs, spheres, curve control points);
//! - [`Ias`]: an instance structure: per-slot [`InstanceRecord`]s naming children by handle;
//! - [`Transform`]: static, matrix-motion and SRT-motion transforms;
//! - [`SceneTable`] and the handle encoding in [`handle`]: what a traversable handle names.
//!
//! Builders read inputs through [`optik_api::decode`] from any [`BufferBytes`] and resolve
//! children through a [`SceneTable`], so they need no CPU device.

mod aabb;
mod bvh;
pub mod curve_basis;
mod gas;
pub mod handle;
mod instances;
pub mod micromap;
pub mod wide;

pub use aabb::Aabb;
pub use bvh::{BuildQuality, Bvh, BvhNode};
pub use gas::{
    Curves, CustomPrimitives, Gas, Geometry, MicromapLookup, MicromapRef, PrimitiveInfo, Spheres,
    TriangleMicromaps, Triangles, curve_caps,
};
pub use handle::{Resolved, SceneTable};
pub use instances::{Ias, InstanceRecord, Transform, TransformKind};
pub use micromap::MicromapArrayData;
pub use optik_api::decode::BufferBytes;

use optik_api::{AccelBufferSizes, BuildInput, SceneFeatures};

/// Anything a traversable handle can name.
#[derive(Clone, Debug, PartialEq)]
pub enum Traversable {
    /// A geometry acceleration structure.
    Geometry(Gas),
    /// An instance acceleration structure.
    Instances(Ias),
    /// A transform.
    Transform(Transform),
}

impl Traversable {
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
    pub fn compacted(&self) -> Traversable {
        // `Clone` of a `Vec` allocates exactly its length.
        self.clone()
    }
}

/// An upper bound of the memory a build of `inputs` needs (validated inputs), the way
/// OptiX's `optixAccelComputeMemoryUsage` reports it: the output size is what a build
/// reports as its size until compacted.
pub fn memory_usage(inputs: &[BuildInput], motion_keys: usize) -> AccelBufferSizes {
    let mut prims = 0u64;
    let mut per_key = 0u64;
    let mut per_prim = 0u64;
    for input in inputs {
        let n = input.num_primitives() as u64;
        prims += n;
        let (geometry, extra) = match input {
            // A static triangle may fill a block of its own.
            BuildInput::Triangles(t) => (
                36,
                if t.opacity_micromap.is_some() { 8 } else { 0 }
                    + if motion_keys == 1 {
                        std::mem::size_of::<wide::TriangleBlock>() as u64
                    } else {
                        0
                    },
            ),
            BuildInput::CustomPrimitives(_) => (24, 0),
            BuildInput::Spheres(_) => (16, 0),
            BuildInput::Curves(_) => (64, 1),
            BuildInput::Instances(_) => (0, std::mem::size_of::<InstanceRecord>() as u64),
        };
        per_key += n * geometry;
        per_prim += n * (extra + 4 + std::mem::size_of::<PrimitiveInfo>() as u64);
    }
    // At most 2n - 1 nodes, plus the padding node after the root; at most one wide node
    // per inner binary node (or one for a leaf root).
    let nodes = 2 * prims * std::mem::size_of::<BvhNode>() as u64
        + prims.max(1) * std::mem::size_of::<wide::WideNode>() as u64;
    let output = nodes + per_prim + per_key * motion_keys as u64;
    AccelBufferSizes {
        output_size_in_bytes: output,
        // The builder's boxes, Morton codes and obvhs's own tree.
        temp_size_in_bytes: prims * (32 + 16 + 48) + per_key * motion_keys as u64,
        temp_update_size_in_bytes: prims * 32 + per_key * motion_keys as u64,
    }
}
