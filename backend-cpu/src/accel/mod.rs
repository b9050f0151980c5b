//! Acceleration structures: optik-accel builds them (obvhs PLOC, shared with every
//! backend); this module adds the CPU backend's own encoding, the 4-wide BVH with triangle
//! blocks the traversal walks ([`wide::WideBvh`]), and names the shared types with it.

pub mod wide;

pub use optik_accel::Ias;
pub use optik_accel::{
    Aabb, BufferBytes, BuildQuality, Bvh, BvhNode, Curves, CustomPrimitives, GasEncoding, Geometry,
    InstanceRecord, MicromapArrayData, MicromapLookup, MicromapRef, PrimitiveInfo, Spheres,
    Transform, TransformKind, TriangleMicromaps, Triangles, curve_basis, curve_caps, handle,
    micromap,
};

use optik_api::{AccelBufferSizes, BuildInput};

/// A geometry structure with the CPU's wide BVH.
pub type Gas = optik_accel::Gas<wide::WideBvh>;
/// Anything a traversable handle names, with the CPU's wide BVH in geometry.
pub type Traversable = optik_accel::Traversable<wide::WideBvh>;
/// The CPU device's handle table.
pub type SceneTable = optik_accel::SceneTable<wide::WideBvh>;
/// What a handle resolves to in the CPU device's table.
pub type Resolved<'a> = optik_accel::Resolved<'a, wide::WideBvh>;

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
            // A static triangle may fill a block of its own, and have a class of its own.
            BuildInput::Triangles(t) => (
                36,
                if t.opacity_micromap.is_some() { 8 } else { 0 }
                    + if motion_keys == 1 {
                        (std::mem::size_of::<wide::TriangleBlock>()
                            + std::mem::size_of::<wide::PrimitiveClass>())
                            as u64
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
