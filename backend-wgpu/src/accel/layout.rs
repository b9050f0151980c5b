//! The GPU layout of traversables in the scene arena, shared by the encoders here and the
//! kernel generator (which writes the matching WGSL).
//!
//! Every traversable starts with a header of [`HEADER_VEC4S`] vec4s; all references inside
//! it are relative to the header, so a structure can be copied (compaction) as it is.
//!
//! | header vec4 | geometry (GAS) | instances (IAS) | transform |
//! |---|---|---|---|
//! | 0 | kind word, keys, node rel, prim rel | kind word, 1, node rel, instance rel | kind word, keys, child slot, child generation |
//! | 1 | time begin, time end, motion flags, micromap table rel | 0 | time begin, time end, motion flags, data rel |
//! | 2 | micromap data rel, nodes, 0, 0 | 0, nodes, 0, 0 | 0 |
//!
//! The kind word holds the traversable kind in bits 0..4, the primitive type in bits 4..8
//! and the curve basis (`optik_api::wgsl::curve_basis`) in bits 8..10.
//!
//! Per-slot records (slots are in BVH leaf order; `k` runs over motion keys):
//! - triangles, 3 vec4 per key: `(v0, prim index) (v1, sbt-gas-index | flags << 29)
//!   (v2, micromap word)`; keys after the first repeat the meta words;
//! - custom primitives: meta, then per key `(min, 0) (max, 0)`;
//! - spheres: meta, then per key `(centre, radius)`;
//! - curves: meta (with cap bits in z), then per key the segment's four control points in
//!   its own basis `(xyz, radius)` (unused ones zero);
//! - instances, [`INSTANCE_VEC4S`]: world-to-object rows (3), object-to-world rows (3),
//!   `(id, sbt offset, mask | flags << 8, index)`, `(child slot, child generation, 0, 0)`.
//!
//! The meta vec4 of a primitive is `(prim index, sbt-gas-index | flags << 29, extra, 0)`.
//! A micromap word is 0 (none), 1..=4 (special indices −1..−4) or 5 + a micromap's index in
//! the structure's table of `(byte offset, level, 4-state?, 0)` vec4s.

/// Vec4s of every header.
pub(crate) const HEADER_VEC4S: u64 = 3;
/// Vec4s per instance record.
pub(crate) const INSTANCE_VEC4S: u64 = 8;

/// Traversable kinds (kind word bits 0..4).
pub(crate) mod kind {
    /// Geometry acceleration structure.
    pub const GAS: u32 = 1;
    /// Instance acceleration structure.
    pub const IAS: u32 = 2;
    /// Static transform.
    pub const STATIC: u32 = 3;
    /// Matrix motion transform.
    pub const MATRIX_MOTION: u32 = 4;
    /// SRT motion transform.
    pub const SRT_MOTION: u32 = 5;
}

/// Primitive types (kind word bits 4..8).
pub(crate) mod prim {
    /// Triangles.
    pub const TRIANGLES: u32 = 0;
    /// Custom primitives (AABBs).
    pub const CUSTOM: u32 = 1;
    /// Spheres.
    pub const SPHERES: u32 = 2;
    /// Curves.
    pub const CURVES: u32 = 3;
}

/// Bits of the sbt-gas-index word below the geometry flags.
pub(crate) const GAS_INDEX_BITS: u32 = 29;
/// Largest SBT GAS index a primitive can have.
pub(crate) const MAX_GAS_INDEX: u32 = (1 << GAS_INDEX_BITS) - 1;

/// Vec4s per slot of a primitive type with `keys` motion keys.
pub(crate) fn slot_vec4s(prim_type: u32, keys: u32) -> u64 {
    let keys = keys as u64;
    match prim_type {
        prim::TRIANGLES => 3 * keys,
        prim::CUSTOM => 1 + 2 * keys,
        prim::SPHERES => 1 + keys,
        _ => 1 + 4 * keys,
    }
}

/// The kind word.
pub(crate) fn kind_word(kind: u32, prim_type: u32, curve_basis: u32) -> u32 {
    kind | (prim_type << 4) | (curve_basis << 8)
}

/// A 3×4 row-major matrix as three vec4 rows of f32 bits.
pub(crate) fn matrix_rows(m: &optik_api::Matrix3x4) -> [[u32; 4]; 3] {
    std::array::from_fn(|r| std::array::from_fn(|c| m[r * 4 + c].to_bits()))
}
