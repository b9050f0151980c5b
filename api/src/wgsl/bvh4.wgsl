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

// `_optik_node4` for a ray with no parallel axis (every `r.parallel` false), as nearly every
// ray is: the same values without the selects and inside tests that only parallel axes
// need. The traversal picks one of the two per node with a branch around the whole call.
// Written out whole, as one expression per slab: the same test through a helper taking the
// six box vectors, or with the boxes fetched before a branch inside one function, made the
// H200's kernel 80 and 93–95 registers where this form makes 72, and traced up to a sixth
// fewer incoherent rays (docs/wgpu-backend.md §12.3).
fn _optik_node4_direct(node_base: u32, index: u32, r: _OptikSlabRay, tmin: f32, tmax: f32) -> _OptikNode4 {
    let i = node_base + index * 8u;
    let o = r.origin;
    let ax = (bitcast<vec4<f32>>(_optik_fetch(i)) - vec4<f32>(o.x)) * r.inv.x;
    let bx = (bitcast<vec4<f32>>(_optik_fetch(i + 1u)) - vec4<f32>(o.x)) * r.inv.x;
    let ay = (bitcast<vec4<f32>>(_optik_fetch(i + 2u)) - vec4<f32>(o.y)) * r.inv.y;
    let by = (bitcast<vec4<f32>>(_optik_fetch(i + 3u)) - vec4<f32>(o.y)) * r.inv.y;
    let az = (bitcast<vec4<f32>>(_optik_fetch(i + 4u)) - vec4<f32>(o.z)) * r.inv.z;
    let bz = (bitcast<vec4<f32>>(_optik_fetch(i + 5u)) - vec4<f32>(o.z)) * r.inv.z;
    let tn = max(max(min(ax, bx), min(ay, by)), max(min(az, bz), vec4<f32>(tmin)));
    let tf = min(min(max(ax, bx) * _OPTIK_SLAB_WIDEN, max(ay, by) * _OPTIK_SLAB_WIDEN), min(max(az, bz) * _OPTIK_SLAB_WIDEN, vec4<f32>(tmax))); // @conservative
    let tf = min(min(max(ax, bx), max(ay, by)), min(max(az, bz), vec4<f32>(tmax))); // @plain
    let child = _optik_fetch(i + 6u);
    let kind = _optik_fetch(i + 7u);
    return _OptikNode4((tn <= tf) & (kind != vec4<u32>(0u)), tn, child, kind);
}
