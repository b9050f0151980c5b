// BVH4 nodes of the software traversal. A node is 128 bytes: eight vec4<u32> from
// `node_base + 8·index`, read through `_optik_fetch(i: u32) -> vec4<u32>`, which the including
// shader defines (a storage buffer, or several when data is split across bindings).
//
//   vec4 0..5  min x, max x, min y, max y, min z, max z of the four children (f32 bits)
//   vec4 6     child references
//   vec4 7     child kinds: 0 empty; 1 inner node (reference = node index);
//              n ≥ 2 a leaf of n − 1 items starting at slot `reference`
//
// Boxes are exact f32 unions of what they hold; the slab test decides how conservative the
// traversal is.

struct _OptikNode4 {
    hit: vec4<bool>,
    tnear: vec4<f32>,
    child: vec4<u32>,
    kind: vec4<u32>,
}

fn _optik_node4(node_base: u32, index: u32, r: _OptikSlabRay, tmin: f32, tmax: f32) -> _OptikNode4 {
    let i = node_base + index * 8u;
    let b = _optik_box4(
        r,
        bitcast<vec4<f32>>(_optik_fetch(i)),
        bitcast<vec4<f32>>(_optik_fetch(i + 1u)),
        bitcast<vec4<f32>>(_optik_fetch(i + 2u)),
        bitcast<vec4<f32>>(_optik_fetch(i + 3u)),
        bitcast<vec4<f32>>(_optik_fetch(i + 4u)),
        bitcast<vec4<f32>>(_optik_fetch(i + 5u)),
        tmin,
        tmax,
    );
    let child = _optik_fetch(i + 6u);
    let kind = _optik_fetch(i + 7u);
    return _OptikNode4(b.hit & (kind != vec4<u32>(0u)), b.tnear, child, kind);
}
