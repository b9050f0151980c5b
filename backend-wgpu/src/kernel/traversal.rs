//! The traversal loop, written for exactly the features of the pipeline.
//!
//! One walk covers every level of the graph with one stack of `vec2<u32>` entries (a
//! reference and the entry's near distance, to skip entries beyond the closest hit when
//! they are popped). A reference's top two bits say what it is: 0 an inner BVH4 node, 1 a
//! geometry leaf and 2 an instance leaf (count − 1 in bits 27..30, first slot below), 3 a
//! level marker. Entering an instance puts its record on the path (`_optik_path`) and pushes
//! two markers: popping the first builds the instance's level (the ray in its space, through
//! any transform traversables below it, and its structure's bases), popping the second, once
//! the instance is done, builds its parent's level again. Levels are built from the world
//! ray along the path (`_optik_level_at`), never saved. No composed matrices are kept: a hit
//! records its path, from which the device functions rebuild its object space
//! (`_optik_hit_frame`). Children are pushed far to near, so the nearest is visited first.
//!
//! The rules of DESIGN.md §4 are those of `optik_api::semantics`, ported: opacity and
//! culling (`opacity::resolve`, `opacity::triangle_face_culled`), facing (decided in object
//! space, flipped by instances), the SBT index (`sbt_index::hit_record_index`), masks, and
//! the open interval for built-in primitives and closed one for reports (`ray`).

use super::KernelConfig;
use optik_api::{ExceptionFlags, TriangleTest};

pub(super) fn write(c: &KernelConfig<'_>, out: &mut String) {
    if c.counters {
        let mut text = String::new();
        write_plain(c, &mut text);
        out.push_str(&super::counters::instrument(&text));
    } else {
        write_plain(c, out);
    }
}

fn write_plain(c: &KernelConfig<'_>, out: &mut String) {
    level_struct(c, out);
    rules(c, out);
    enter(c, out);
    if c.instancing() {
        out.push_str(
            "fn _optik_rows(at: u32) -> _OptikXform {\n    return _OptikXform(bitcast<vec4<f32>>(_optik_fetch(at)), bitcast<vec4<f32>>(_optik_fetch(at + 1u)), bitcast<vec4<f32>>(_optik_fetch(at + 2u)));\n}\n\n",
        );
    }
    if c.any_graph() {
        transforms(c, out);
    }
    if c.instancing() {
        hit_frame(c, out);
        level_builder(c, out);
    }
    accept(c, out);
    if c.triangles() {
        triangles(c, out);
    }
    if c.custom() && c.intersection() {
        custom(c, out);
        report(c, out);
    }
    if c.spheres() {
        spheres(c, out);
    }
    if c.curves() {
        curves(c, out);
    }
    traverse(c, out);
}

fn level_struct(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(
        "\n// One level of the graph being traversed: the ray in its space and its structure.\nstruct _OptikLevel {\n    origin: vec3<f32>,\n    direction: vec3<f32>,\n    slab: _OptikSlabRay,\n",
    );
    if c.triangles() && c.accuracy.triangle == TriangleTest::Watertight {
        out.push_str("    woop: _OptikWoop,\n");
    }
    out.push_str("    header: u32,\n    node_base: u32,\n    prim_base: u32,\n    kind_word: u32,\n    keys: u32,\n");
    // The motion key and fraction exist only where geometry moves; elsewhere they are the
    // constants 0 (`key`), not fields a saved level carries through memory.
    if keyed(c) {
        out.push_str("    key: u32,\n    frac: f32,\n");
    }
    if c.instancing() {
        // The instances entered are `_optik_path[0..depth]`; a candidate reads their ids
        // and SBT offsets from their records, so the level carries only what its tests read
        // (fewer values live across the walk, docs/wgpu-backend.md §12.4–12.5).
        out.push_str("    inst_flags: u32,\n    flip: bool,\n    depth: u32,\n");
    } else {
        out.push_str(
            "    instance_id: u32,\n    instance_index: u32,\n    sbt_offset: u32,\n    inst_flags: u32,\n    flip: bool,\n",
        );
    }
    out.push_str("}\n");
}

fn rules(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(
        r#"
// Pushing order of four children: keys descending (misses carry +inf and come first).
struct _OptikSorted {
    keys: vec4<f32>,
    refs: vec4<u32>,
}

fn _optik_sort4(k_in: vec4<f32>, r_in: vec4<u32>) -> _OptikSorted {
    var k = k_in;
    var r = r_in;
    if k.y > k.x {
        k = k.yxzw;
        r = r.yxzw;
    }
    if k.w > k.z {
        k = k.xywz;
        r = r.xywz;
    }
    if k.z > k.x {
        k = k.zyxw;
        r = r.zyxw;
    }
    if k.w > k.y {
        k = k.xwzy;
        r = r.xwzy;
    }
    if k.z > k.y {
        k = k.xzyw;
        r = r.xzyw;
    }
    return _OptikSorted(k, r);
}

// A traversable's header from its handle-table slot and generation, or _OPTIK_NONE.
fn _optik_resolve(slot: u32, generation: u32) -> u32 {
    if slot >= arrayLength(&_optik_handles) {
        return _OPTIK_NONE;
    }
    let e = _optik_handles[slot];
    if e.x != (generation | 0x80000000u) {
        return _OPTIK_NONE;
    }
    return e.z;
}

"#,
    );
    out.push_str(&format!(
        r#"// A 64-bit traversable handle (slot + 1, generation, device) to a header, or _OPTIK_NONE.
fn _optik_resolve_handle(h: vec2<u32>) -> u32 {{
    let slot_field = h.x & 0xFFFFFFu;
    if slot_field == 0u || (h.y >> 16u) != {}u {{
        return _OPTIK_NONE;
    }}
    return _optik_resolve(slot_field - 1u, (h.x >> 24u) | ((h.y & 0xFFFFu) << 8u));
}}

"#,
        c.device16
    ));
    if c.triangles() {
        out.push_str(
            r#"// optik_api::semantics::opacity::triangle_face_culled.
fn _optik_face_culled(front: bool, geom: u32, inst: u32, ray: u32) -> bool {
    if (geom & 4u) != 0u || (inst & 1u) != 0u {
        return false;
    }
    return (front && (ray & 32u) != 0u) || (!front && (ray & 16u) != 0u);
}

"#,
        );
    }
    let debug = c.debug();
    out.push_str(
        "// The hit group record of a candidate (optik_api::semantics::sbt_index), or _OPTIK_NONE.\nfn _optik_hit_record(instance_offset: u32, gas_index: u32) -> u32 {\n    let stride = _optik_ray.sbt_stride;\n    let base = instance_offset + _optik_ray.sbt_offset;\n    var index = _OPTIK_NONE;\n    if stride == 0u || gas_index <= (_OPTIK_NONE - base) / stride {\n        index = base + gas_index * stride;\n    }\n    if index >= _optik_launch.sbt1.x {\n",
    );
    if debug {
        out.push_str("        _optik_raise(-7);\n        _optik_done = true;\n");
    }
    out.push_str("        return _OPTIK_NONE;\n    }\n    return _optik_launch.sbt0.z + index * _optik_launch.sbt0.w;\n}\n\n");
    if c.micromaps() {
        out.push_str(
            r#"// The micromap state of a triangle at barycentrics (u, v).
fn _optik_micromap(lv: ptr<function, _OptikLevel>, word: u32, u: f32, v: f32) -> u32 {
    if word <= 4u {
        return word - 1u;
    }
    let h1 = _optik_fetch((*lv).header + 1u);
    let h2 = _optik_fetch((*lv).header + 2u);
    let d = _optik_fetch((*lv).header + h1.w + word - 5u);
    return _optik_micromap_state((*lv).header + h2.x, d.x, d.y, d.z != 0u, u, v);
}

"#,
        );
    }
}

/// `_optik_enter`: points a level at a structure; false when it holds nothing to hit now.
fn enter(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(
        "fn _optik_enter(lv: ptr<function, _OptikLevel>, header: u32) -> bool {\n    let h0 = _optik_fetch(header);\n    (*lv).header = header;\n    (*lv).kind_word = h0.x;\n    (*lv).keys = max(h0.y, 1u);\n    (*lv).node_base = header + h0.z;\n    (*lv).prim_base = header + h0.w;\n",
    );
    if keyed(c) {
        out.push_str("    (*lv).key = 0u;\n    (*lv).frac = 0.0;\n");
    }
    // Primitive types the pipeline was not compiled for are skipped (DEBUG: exception).
    let mut supported = Vec::new();
    for (on, code) in [
        (c.triangles(), 0),
        (c.custom(), 1),
        (c.spheres(), 2),
        (c.curves(), 3),
    ] {
        if on {
            supported.push(format!("prim_type != {code}u"));
        }
    }
    let unsupported = if supported.is_empty() {
        "true".to_string()
    } else {
        supported.join(" && ")
    };
    out.push_str(&format!(
        "    let prim_type = (h0.x >> 4u) & 15u;\n    if (h0.x & 15u) == 1u && {unsupported} {{\n"
    ));
    if c.debug() {
        out.push_str("        _optik_raise(-8);\n        _optik_done = true;\n");
    }
    out.push_str("        return false;\n    }\n");
    if !c.instancing() {
        out.push_str("    if (h0.x & 15u) != 1u {\n        return false;\n    }\n");
    }
    if c.geometry_motion() {
        out.push_str(
            "    if (h0.x & 15u) == 1u && h0.y > 1u {\n        let h1 = _optik_fetch(header + 1u);\n        let k = _optik_motion_key(h0.y, bitcast<f32>(h1.x), bitcast<f32>(h1.y), h1.z, _optik_ray.time);\n        if k.key < 0 {\n            return false;\n        }\n        (*lv).key = u32(k.key);\n        (*lv).frac = k.frac;\n    }\n",
        );
    }
    out.push_str("    (*lv).slab = _optik_slab_ray((*lv).origin, (*lv).direction);\n");
    if c.triangles() && c.accuracy.triangle == TriangleTest::Watertight {
        out.push_str("    (*lv).woop = _optik_woop_ray((*lv).direction);\n");
    }
    out.push_str("    return _optik_fetch(header + 2u).y > 0u;\n}\n\n");
}

/// `_optik_transform_step` (one transform traversable's matrices) and
/// `_optik_through_transforms` (a chain of them applied to a level's ray).
fn transforms(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(
        r#"fn _optik_srt_key(at: u32) -> array<vec4<f32>, 4> {
    return array<vec4<f32>, 4>(bitcast<vec4<f32>>(_optik_fetch(at)), bitcast<vec4<f32>>(_optik_fetch(at + 1u)), bitcast<vec4<f32>>(_optik_fetch(at + 2u)), bitcast<vec4<f32>>(_optik_fetch(at + 3u)));
}

// A transform traversable's matrices at the ray's time and the header of its child
// (_OPTIK_NONE when the child is gone or the object has vanished at this time).
struct _OptikStep {
    w2o: _OptikXform,
    o2w: _OptikXform,
    child: u32,
}

fn _optik_transform_step(header: u32, h0: vec4<u32>) -> _OptikStep {
    let kind = h0.x & 15u;
    let h1 = _optik_fetch(header + 1u);
    let data = header + h1.w;
    var s: _OptikStep;
    s.child = _OPTIK_NONE;
    if kind == 3u {
        s.w2o = _optik_rows(data);
        s.o2w = _optik_rows(data + 3u);
    } else {
"#,
    );
    if c.motion() {
        out.push_str(
            r#"        let k = _optik_motion_key(h0.y, bitcast<f32>(h1.x), bitcast<f32>(h1.y), h1.z, _optik_ray.time);
        if k.key < 0 {
            return s;
        }
        let a = u32(k.key);
        let b = min(a + 1u, h0.y - 1u);
        if kind == 4u {
            s.o2w = _optik_lerp_xform(_optik_rows(data + 3u * a), _optik_rows(data + 3u * b), k.frac);
        } else {
            s.o2w = _optik_srt_lerp(_optik_srt_key(data + 4u * a), _optik_srt_key(data + 4u * b), k.frac);
        }
"#,
        );
    } else {
        // Without motion compiled in, keys 0 are used (FeatureSet::motion).
        out.push_str(
            r#"        if kind == 4u {
            s.o2w = _optik_rows(data);
        } else {
            let k = _optik_srt_key(data);
            s.o2w = _optik_srt_matrix(k[0], k[1], k[2], k[3]);
        }
"#,
        );
    }
    out.push_str(
        r#"        s.w2o = _optik_xform_inverse(s.o2w);
    }
    s.child = _optik_resolve(h0.z, h0.w);
    return s;
}

"#,
    );
    through_transforms("_optik_through_transforms", "_OptikLevel", false, out);
}

/// A function following transform traversables from `first` down to a structure, moving the
/// ray of `*lv` (of type `state`) into each one's space, and with `compose` also composing
/// its `w2o` and `o2w`; it returns the structure's header, or _OPTIK_NONE when a child is
/// gone or the object has vanished. The traversal moves only the ray; the hit's frame
/// (`_optik_hit_frame`) composes the matrices along the same steps, so both see one ray.
fn through_transforms(name: &str, state: &str, compose: bool, out: &mut String) {
    let matrices = if compose {
        "        (*lv).w2o = _optik_xform_mul(s.w2o, (*lv).w2o);\n        (*lv).o2w = _optik_xform_mul((*lv).o2w, s.o2w);\n"
    } else {
        ""
    };
    out.push_str(&format!(
        r#"fn {name}(lv: ptr<function, {state}>, first: u32) -> u32 {{
    var header = first;
    for (var i = 0u; i < 64u; i = i + 1u) {{
        let h0 = _optik_fetch(header);
        if (h0.x & 15u) <= 2u {{
            return header;
        }}
        let s = _optik_transform_step(header, h0);
        if s.child == _OPTIK_NONE {{
            return _OPTIK_NONE;
        }}
{matrices}        (*lv).origin = _optik_xform_point(s.w2o, (*lv).origin);
        (*lv).direction = _optik_canonical_direction(_optik_xform_vector(s.w2o, (*lv).direction));
        header = s.child;
    }}
    return _OPTIK_NONE;
}}

"#
    ));
}

/// `_optik_hit_frame`: the object space of `_optik_hit` (the ray in it and the composed
/// matrices), rebuilt from the hit's path through the graph, as OptiX computes transforms on
/// demand. The traversal keeps no matrices: two composed 3×4 matrices were 24 values in
/// every saved level and 30 with the object ray in every candidate and the closest hit,
/// carried through the whole walk for the few programs that ask (docs/wgpu-backend.md
/// §12.3 has what it changed on the H200). The steps are the traversal's own, in the same
/// order, so the ray is the one it tested.
fn hit_frame(c: &KernelConfig<'_>, out: &mut String) {
    if c.any_graph() {
        through_transforms("_optik_frame_through_transforms", "_OptikFrame", true, out);
    }
    out.push_str(
        r#"fn _optik_hit_frame() -> _OptikFrame {
    var f: _OptikFrame;
    f.origin = _optik_ray.origin;
    f.direction = _optik_ray.direction;
    f.w2o = _optik_xform_identity();
    f.o2w = _optik_xform_identity();
"#,
    );
    if c.any_graph() {
        out.push_str("    _optik_frame_through_transforms(&f, _optik_hit.root);\n");
    }
    out.push_str(
        r#"    for (var i = 0u; i < min(_optik_hit.depth, _OPTIK_LEVELS); i = i + 1u) {
        let rec = _optik_hit.path[i];
        let iw = _optik_rows(rec);
        f.w2o = _optik_xform_mul(iw, f.w2o);
        f.o2w = _optik_xform_mul(f.o2w, _optik_rows(rec + 3u));
        f.origin = _optik_xform_point(iw, f.origin);
        f.direction = _optik_canonical_direction(_optik_xform_vector(iw, f.direction));
"#,
    );
    if c.any_graph() {
        out.push_str(
            "        let link = _optik_fetch(rec + 7u);\n        _optik_frame_through_transforms(&f, _optik_resolve(link.x, link.y));\n",
        );
    }
    out.push_str("    }\n    return f;\n}\n\n");
}

/// The candidate record and the acceptance of built-in primitive hits (any-hit included).
fn accept(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(
        r#"fn _optik_candidate(lv: ptr<function, _OptikLevel>, slot: u32, prim: u32, gas_index: u32, geom: u32) -> _OptikHit {
    var h: _OptikHit;
    h.prim_index = prim;
    h.gas_index = gas_index;
    h.gas = (*lv).header;
    h.slot = slot;
    h.geom_flags = geom;
    h.inst_flags = (*lv).inst_flags;
"#,
    );
    if c.instancing() {
        // The innermost instance's ids (record word 6: id, SBT offset, mask and flags,
        // index) and the sum of the path's SBT offsets (`sbt_index`); all zero at the root.
        out.push_str("    var info = vec4<u32>(0u);\n    var offset = 0u;\n    let depth = min((*lv).depth, _OPTIK_LEVELS);\n    if depth > 0u {\n        info = _optik_fetch(_optik_path[depth - 1u] + 6u);\n        offset = info.y;\n        for (var i = 0u; i + 1u < depth; i = i + 1u) {\n            offset = offset + _optik_fetch(_optik_path[i] + 6u).y;\n        }\n    }\n    h.instance_id = info.x;\n    h.instance_index = info.w;\n    h.record = _optik_hit_record(offset, gas_index);\n    h.root = _optik_root;\n    h.depth = (*lv).depth;\n    h.path = _optik_path;\n");
    } else {
        out.push_str("    h.instance_id = (*lv).instance_id;\n    h.instance_index = (*lv).instance_index;\n    h.record = _optik_hit_record((*lv).sbt_offset, gas_index);\n");
    }
    out.push_str(
        r#"    return h;
}

fn _optik_commit(h: _OptikHit) {
    _optik_best = h;
    _optik_found = true;
    _optik_ray.tmax = h.t;
}

// Accepts a built-in primitive's candidate of fate `fate` (1 opaque, 2 non-opaque).
fn _optik_accept(h: _OptikHit, fate: u32) {
    if _optik_unwind == 3u {
        return;
    }
"#,
    );
    if c.any_hit() {
        out.push_str(
            r#"    if fate == 2u && (_optik_group_flags(h.record) & 2u) != 0u {
        _optik_hit = h;
        _optik_ray.tmax = h.t;
        let reason = _optik_ah(h.record);
        _optik_ray.tmax = _optik_best.t;
        if reason == 3u {
            _optik_done = true;
            return;
        }
        if reason == 1u {
            return;
        }
        _optik_commit(h);
        if reason == 2u {
            _optik_done = true;
        }
    } else {
        _optik_commit(h);
    }
"#,
        );
    } else {
        out.push_str("    _optik_commit(h);\n");
    }
    out.push_str(
        "    if (_optik_ray.flags & 4u) != 0u {\n        _optik_done = true;\n    }\n}\n\n",
    );
}

/// The code reading key `key` of a slot's data, lerped toward the next key under motion.
fn keyed(c: &KernelConfig<'_>) -> bool {
    c.geometry_motion()
}

/// The motion key a leaf reads: the level's, or 0 where no geometry moves.
fn motion_key(c: &KernelConfig<'_>) -> &'static str {
    if keyed(c) { "(*lv).key" } else { "0u" }
}

fn triangles(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(
        &r#"fn _optik_leaf_triangles(lv: ptr<function, _OptikLevel>, first: u32, count: u32) {
    for (var i = 0u; i < count; i = i + 1u) {
        if _optik_done {
            return;
        }
        let slot = first + i;
        let a = (*lv).prim_base + (slot * (*lv).keys + {KEY}) * 3u;
        let q0 = _optik_fetch(a);
        let q1 = _optik_fetch(a + 1u);
        let q2 = _optik_fetch(a + 2u);
        var v0 = bitcast<vec3<f32>>(q0.xyz);
        var v1 = bitcast<vec3<f32>>(q1.xyz);
        var v2 = bitcast<vec3<f32>>(q2.xyz);
"#
        .replace("{KEY}", motion_key(c)),
    );
    if keyed(c) {
        out.push_str(
            r#"        if (*lv).frac > 0.0 {
            v0 = mix(v0, bitcast<vec3<f32>>(_optik_fetch(a + 3u).xyz), (*lv).frac);
            v1 = mix(v1, bitcast<vec3<f32>>(_optik_fetch(a + 4u).xyz), (*lv).frac);
            v2 = mix(v2, bitcast<vec3<f32>>(_optik_fetch(a + 5u).xyz), (*lv).frac);
        }
"#,
        );
    }
    out.push_str(match c.accuracy.triangle {
        // `Driver` is refused by `set_accuracy`; it never reaches a kernel.
        TriangleTest::Watertight | TriangleTest::Driver => "        let t = _optik_tri_watertight((*lv).woop, (*lv).origin, v0, v1, v2, _optik_ray.tmin, _optik_best.t);\n",
        TriangleTest::MollerTrumbore => "        let t = _optik_tri_moller_trumbore((*lv).origin, (*lv).direction, v0, v1, v2, _optik_ray.tmin, _optik_best.t);\n",
    });
    out.push_str(
        r#"        if !t.hit {
            continue;
        }
        let geom = q1.w >> 29u;
        let front = t.front != (*lv).flip;
        if _optik_face_culled(front, geom, (*lv).inst_flags, _optik_ray.flags) {
            continue;
        }
        var omm = _OPTIK_NONE;
"#,
    );
    if c.micromaps() {
        out.push_str(
            "        if q2.w != 0u && ((*lv).inst_flags & 32u) == 0u {\n            omm = _optik_micromap(lv, q2.w, t.u, t.v);\n        }\n",
        );
    }
    out.push_str(
        r#"        let fate = _optik_fate(geom, (*lv).inst_flags, _optik_ray.flags, omm);
        if fate == 0u {
            continue;
        }
        var h = _optik_candidate(lv, slot, q0.w, q1.w & 0x1FFFFFFFu, geom);
        h.t = t.t;
        h.hit_kind = select(0xFFu, 0xFEu, front);
        h.attrs[0] = bitcast<u32>(t.u);
        h.attrs[1] = bitcast<u32>(t.v);
        _optik_accept(h, fate);
    }
}

"#,
    );
}

fn custom(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(
        &r#"fn _optik_leaf_custom(lv: ptr<function, _OptikLevel>, first: u32, count: u32) {
    for (var i = 0u; i < count; i = i + 1u) {
        if _optik_done {
            return;
        }
        let slot = first + i;
        let base = (*lv).prim_base + slot * (1u + 2u * (*lv).keys);
        let info = _optik_fetch(base);
        let a = base + 1u + 2u * {KEY};
        var lo = bitcast<vec3<f32>>(_optik_fetch(a).xyz);
        var hi = bitcast<vec3<f32>>(_optik_fetch(a + 1u).xyz);
"#
        .replace("{KEY}", motion_key(c)),
    );
    if keyed(c) {
        out.push_str(
            r#"        if (*lv).frac > 0.0 {
            lo = mix(lo, bitcast<vec3<f32>>(_optik_fetch(a + 2u).xyz), (*lv).frac);
            hi = mix(hi, bitcast<vec3<f32>>(_optik_fetch(a + 3u).xyz), (*lv).frac);
        }
"#,
        );
    }
    out.push_str(
        r#"        if !_optik_box1((*lv).slab, lo, hi, _optik_ray.tmin, _optik_best.t) {
            continue;
        }
        let geom = info.y >> 29u;
        if _optik_fate(geom, (*lv).inst_flags, _optik_ray.flags, _OPTIK_NONE) == 0u {
            continue;
        }
        let h = _optik_candidate(lv, slot, info.x, info.y & 0x1FFFFFFFu, geom);
        if _optik_unwind == 3u {
            return;
        }
        if (_optik_group_flags(h.record) & 4u) == 0u {
            continue;
        }
        _optik_hit = h;
        _optik_hit.t = _optik_best.t;
        _optik_ray.tmax = _optik_best.t;
        let reason = _optik_is(h.record);
        if reason >= 2u {
            _optik_done = true;
            return;
        }
    }
}

"#,
    );
}

fn report(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(
        r#"// rt_report_intersection: t in the closed interval [tmin, closest so far], then any-hit.
fn _optik_report(t: f32, hit_kind: u32, attributes: array<u32, 8>) -> bool {
    if _optik_done || _optik_unwind != 0u {
        return false;
    }
    if !(t >= _optik_ray.tmin && t <= _optik_best.t) {
        return false;
    }
    let fate = _optik_fate(_optik_hit.geom_flags, _optik_hit.inst_flags, _optik_ray.flags, _OPTIK_NONE);
    if fate == 0u {
        return false;
    }
    var h = _optik_hit;
    h.t = t;
    h.hit_kind = hit_kind & 0x7Fu;
    h.attrs = attributes;
"#,
    );
    if c.any_hit() {
        out.push_str(
            r#"    if fate == 2u && (_optik_group_flags(h.record) & 2u) != 0u {
        let own = _optik_hit;
        _optik_hit = h;
        _optik_ray.tmax = t;
        let reason = _optik_ah(h.record);
        _optik_hit = own;
        _optik_ray.tmax = _optik_best.t;
        if reason == 3u {
            _optik_done = true;
            return false;
        }
        if reason == 1u {
            return false;
        }
        _optik_commit(h);
        if reason == 2u {
            _optik_done = true;
            _optik_unwind = 2u;
            return true;
        }
    } else {
        _optik_commit(h);
    }
"#,
        );
    } else {
        out.push_str("    _optik_commit(h);\n");
    }
    out.push_str(
        "    if (_optik_ray.flags & 4u) != 0u {\n        _optik_done = true;\n        _optik_unwind = 2u;\n    }\n    return true;\n}\n\n",
    );
}

fn spheres(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(
        &r#"fn _optik_leaf_spheres(lv: ptr<function, _OptikLevel>, first: u32, count: u32) {
    for (var i = 0u; i < count; i = i + 1u) {
        if _optik_done {
            return;
        }
        let slot = first + i;
        let base = (*lv).prim_base + slot * (1u + (*lv).keys);
        let info = _optik_fetch(base);
        var s = bitcast<vec4<f32>>(_optik_fetch(base + 1u + {KEY}));
"#
        .replace("{KEY}", motion_key(c)),
    );
    if keyed(c) {
        out.push_str(
            "        if (*lv).frac > 0.0 {\n            s = mix(s, bitcast<vec4<f32>>(_optik_fetch(base + 2u + (*lv).key)), (*lv).frac);\n        }\n",
        );
    }
    out.push_str(
        r#"        // Built-in primitives hit in the open interval (tmin, tmax): the near root entering
        // (front), else the far root leaving (a ray from inside; back).
        let r = _optik_sphere_roots(s.xyz, s.w, (*lv).origin, (*lv).direction);
        let near_ok = r.z != 0.0 && r.x > _optik_ray.tmin && r.x < _optik_best.t;
        let far_ok = r.z != 0.0 && r.y > _optik_ray.tmin && r.y < _optik_best.t;
        if !near_ok && !far_ok {
            continue;
        }
        let geom = info.y >> 29u;
        let fate = _optik_fate(geom, (*lv).inst_flags, _optik_ray.flags, _OPTIK_NONE);
        if fate == 0u {
            continue;
        }
        var h = _optik_candidate(lv, slot, info.x, info.y & 0x1FFFFFFFu, geom);
        h.t = select(r.y, r.x, near_ok);
        h.hit_kind = select(0xFFu, 0xFEu, near_ok);
        _optik_accept(h, fate);
    }
}

"#,
    );
}

fn curves(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(
        &r#"fn _optik_leaf_curves(lv: ptr<function, _OptikLevel>, first: u32, count: u32) {
    let basis = ((*lv).kind_word >> 8u) & 3u;
    for (var i = 0u; i < count; i = i + 1u) {
        if _optik_done {
            return;
        }
        let slot = first + i;
        let base = (*lv).prim_base + slot * (1u + 4u * (*lv).keys);
        let info = _optik_fetch(base);
        let a = base + 1u + 4u * {KEY};
        var p: array<vec4<f32>, 4>;
        for (var j = 0u; j < 4u; j = j + 1u) {
            p[j] = bitcast<vec4<f32>>(_optik_fetch(a + j));
"#
        .replace("{KEY}", motion_key(c)),
    );
    if keyed(c) {
        out.push_str(
            "            if (*lv).frac > 0.0 {\n                p[j] = mix(p[j], bitcast<vec4<f32>>(_optik_fetch(a + 4u + j)), (*lv).frac);\n            }\n",
        );
    }
    out.push_str(
        r#"        }
        let t = _optik_curve_intersect(basis, p[0], p[1], p[2], p[3], (info.z & 1u) != 0u, (info.z & 2u) != 0u, (*lv).origin, (*lv).direction, _optik_ray.tmin, _optik_best.t);
        if t.z == 0.0 || !(t.x > _optik_ray.tmin && t.x < _optik_best.t) {
            continue;
        }
        let geom = info.y >> 29u;
        let fate = _optik_fate(geom, (*lv).inst_flags, _optik_ray.flags, _OPTIK_NONE);
        if fate == 0u {
            continue;
        }
        var h = _optik_candidate(lv, slot, info.x, info.y & 0x1FFFFFFFu, geom);
        h.t = t.x;
        h.hit_kind = 0xFEu;
        h.attrs[0] = bitcast<u32>(t.y);
        _optik_accept(h, fate);
    }
}

"#,
    );
}

fn traverse(c: &KernelConfig<'_>, out: &mut String) {
    let stack = c.sizes.stack.max(1);
    out.push_str(&format!("const _OPTIK_STACK: u32 = {stack}u;\n\n"));
    out.push_str(
        r#"// Pushes a child with the distance where the ray enters it, unless it is _OPTIK_NONE or
// the stack is full.
fn _optik_push(stack: ptr<function, array<vec2<u32>, _OPTIK_STACK>>, sp: ptr<function, u32>, r: u32, key: f32) {
    if r != _OPTIK_NONE && *sp < _OPTIK_STACK {
        (*stack)[*sp] = vec2<u32>(r, bitcast<u32>(key));
        *sp = *sp + 1u;
    }
}

"#,
    );
    out.push_str(
        r#"// Walks the graph under `handle` for _optik_ray; the closest accepted hit ends in _optik_best.
fn _optik_traverse(handle: vec2<u32>) -> bool {
    _optik_found = false;
    _optik_done = false;
    _optik_best.t = _optik_ray.tmax;
    var root = _optik_resolve_handle(handle);
    if root == _OPTIK_NONE {
"#,
    );
    if c.exception(ExceptionFlags::DEBUG) {
        out.push_str(
            "        if (handle.x | handle.y) != 0u {\n            _optik_raise(-5);\n        }\n",
        );
    }
    out.push_str(
        r#"        return false;
    }
    var lv: _OptikLevel;
"#,
    );
    if c.instancing() {
        out.push_str("    _optik_root = root;\n    if !_optik_level_at(&lv, 0u) {\n        return false;\n    }\n");
    } else {
        root_fields(c, "lv", out);
        out.push_str("    if !_optik_enter(&lv, root) {\n        return false;\n    }\n");
    }
    out.push_str(
        r#"    var stack: array<vec2<u32>, _OPTIK_STACK>;
    stack[0] = vec2<u32>(0u, bitcast<u32>(_optik_ray.tmin));
    var sp = 1u;
"#,
    );
    if c.instancing() {
        out.push_str("    var lvl = 0u;\n");
    }
    // "While-while" (Aila and Laine 2009): an inner loop tests nodes until this invocation
    // pops a leaf; the leaf is tested after it. Invocations of a warp that reach a leaf
    // wait for the others at the inner loop's end, so the warp runs node tests together and
    // leaf tests together instead of alternating between the two each step. The entries
    // are popped in the same order as with one loop, so the hits are the same. On the H200
    // it traced 1.01–1.08× the incoherent rays per second alone and 1.2–1.3× with the
    // direct node test (docs/wgpu-backend.md §12.3).
    out.push_str(
        r#"    loop {
        var e = vec2<u32>(0u);
        var tag = 0u;
        var leaf = false;
        loop {
            if sp == 0u || _optik_done {
                break;
            }
            sp = sp - 1u;
            e = stack[sp];
            tag = e.x >> 30u;
"#,
    );
    out.push_str(
        r#"            if bitcast<f32>(e.y) > _optik_best.t {
                continue;
            }
            if tag != 0u {
                leaf = true;
                break;
            }
            var n: _OptikNode4;
            if any(lv.slab.parallel) {
                n = _optik_node4(lv.node_base, e.x & 0x3FFFFFFFu, lv.slab, _optik_ray.tmin, _optik_best.t);
            } else {
                n = _optik_node4_direct(lv.node_base, e.x & 0x3FFFFFFFu, lv.slab, _optik_ray.tmin, _optik_best.t);
            }
            // Inner children by node index; a leaf as count - 1 in bits 27..30 with its tag,
            // primitives (1) or instances (2); children the ray misses _OPTIK_NONE. Whole
            // vectors, no loop over lanes: a vector indexed by a loop counter may be lowered
            // to local memory (the watertight test's dynamic indices cost wgpu a sixth of
            // its incoherent-ray time, docs/wgpu-backend.md §12.2).
            let leaf_tag = vec4<u32>(select(1u, 2u, (lv.kind_word & 15u) == 2u) << 30u);
            let leaves = leaf_tag | ((n.kind - vec4<u32>(2u)) << vec4<u32>(27u)) | n.child;
            let inner = n.kind == vec4<u32>(1u);
            let refs = select(vec4<u32>(_OPTIK_NONE), select(leaves, n.child, inner), n.hit);
            let s = _optik_sort4(select(vec4<f32>(_optik_inf()), n.tnear, n.hit), refs);
            _optik_push(&stack, &sp, s.refs.x, s.keys.x);
            _optik_push(&stack, &sp, s.refs.y, s.keys.y);
            _optik_push(&stack, &sp, s.refs.z, s.keys.z);
            _optik_push(&stack, &sp, s.refs.w, s.keys.w);
        }
        if !leaf {
            break;
        }
        if tag == 1u {
            let first = e.x & 0x7FFFFFFu;
            let count = ((e.x >> 27u) & 7u) + 1u;
            switch (lv.kind_word >> 4u) & 15u {
"#,
    );
    if c.triangles() {
        out.push_str("                case 0u: {\n                    _optik_leaf_triangles(&lv, first, count);\n                }\n");
    }
    if c.custom() && c.intersection() {
        out.push_str("                case 1u: {\n                    _optik_leaf_custom(&lv, first, count);\n                }\n");
    }
    if c.spheres() {
        out.push_str("                case 2u: {\n                    _optik_leaf_spheres(&lv, first, count);\n                }\n");
    }
    if c.curves() {
        out.push_str("                case 3u: {\n                    _optik_leaf_curves(&lv, first, count);\n                }\n");
    }
    out.push_str("                default: {}\n            }\n        }");
    if c.instancing() {
        level_markers(out);
        instance_entry(out);
    }
    out.push_str("\n    }\n    return _optik_found;\n}\n\n");
}

/// A level marker popped from the stack (tag 3): bit 0 clear rebuilds the parent level of
/// the instance just done, set builds the level of the instance last put on the path and
/// pushes its structure's root.
fn level_markers(out: &mut String) {
    out.push_str(" else if tag == 3u {\n            // A marker: bit 0 clear leaves the current level for its parent, set enters the\n            // level of the instance last put on the path.\n            if (e.x & 1u) == 0u {\n                lvl = lvl - 1u;\n            }\n            if _optik_level_at(&lv, lvl) && (e.x & 1u) != 0u {\n                stack[sp] = vec2<u32>(0u, bitcast<u32>(_optik_ray.tmin));\n                sp = sp + 1u;\n            }\n        }");
}

/// Entering an instance popped from the stack (tag 2): the instance goes on the path and two
/// markers on the stack, the one that builds its level (popped next) above the one that
/// builds its parent's again when the instance is done. Markers carry -inf as their
/// distance, so the node loop never skips one, and are handled with the leaves, out of the
/// node loop: with the level built in one place, outside the loop where the node test's
/// registers peak, the instance kernels went from 95–118 registers to 72–80 on the H200
/// and their cost from 1.15–1.36× to 1.00–1.12× (docs/wgpu-backend.md §12.5).
fn instance_entry(out: &mut String) {
    out.push_str(
        r#" else if tag == 2u {
            // An instance leaf: enter its first instance, leaving the rest for later. The
            // instance's level is built when its marker is popped, next.
            let count = ((e.x >> 27u) & 7u) + 1u;
            let slot = e.x & 0x7FFFFFFu;
            if count > 1u && sp < _OPTIK_STACK {
                stack[sp] = vec2<u32>((2u << 30u) | ((count - 2u) << 27u) | (slot + 1u), e.y);
                sp = sp + 1u;
            }
            let rec = lv.prim_base + slot * 8u;
            if ((_optik_fetch(rec + 6u).z & 0xFFu) & _optik_ray.mask) == 0u {
                continue;
            }
            if lvl >= _OPTIK_LEVELS || sp + 2u > _OPTIK_STACK {
                continue;
            }
            _optik_path[lvl] = rec;
            lvl = lvl + 1u;
            stack[sp] = vec2<u32>(3u << 30u, 0xFF800000u);
            stack[sp + 1u] = vec2<u32>((3u << 30u) | 1u, 0xFF800000u);
            sp = sp + 2u;
        }"#,
    );
}

/// The root level's fields that do not come from its structure: the world ray, and no
/// instance entered. `_optik_traverse` starts a flat walk from them; `_optik_level_at`
/// starts every level of an instancing walk from them.
/// `level` is the level as the function writing them names it (`lv` or `(*lv)`).
fn root_fields(c: &KernelConfig<'_>, level: &str, out: &mut String) {
    let mut fields = vec![
        ("origin", "_optik_ray.origin"),
        ("direction", "_optik_ray.direction"),
        ("inst_flags", "0u"),
        ("flip", "false"),
    ];
    if c.instancing() {
        fields.push(("depth", "0u"));
    } else {
        fields.extend([
            ("instance_id", "0u"),
            ("instance_index", "0u"),
            ("sbt_offset", "0u"),
        ]);
    }
    for (field, value) in fields {
        out.push_str(&format!("    {level}.{field} = {value};\n"));
    }
}

/// `_optik_into_instance`: a level's ray, depth and flags moved into an instance (record
/// `rec`, word 6 `info`).
const INTO_INSTANCE: &str = r#"fn _optik_into_instance(lv: ptr<function, _OptikLevel>, rec: u32, info: vec4<u32>) {
    let iw = _optik_rows(rec);
    (*lv).depth = (*lv).depth + 1u;
    (*lv).origin = _optik_xform_point(iw, (*lv).origin);
    (*lv).direction = _optik_canonical_direction(_optik_xform_vector(iw, (*lv).direction));
    // Nested instances: flips compose, culling and micromap switches accumulate, and the
    // innermost instance that sets DISABLE_ANYHIT or ENFORCE_ANYHIT decides.
    let f = info.z >> 8u;
    (*lv).flip = (*lv).flip != ((f & 2u) != 0u);
    var flags = (*lv).inst_flags | (f & 49u);
    if (f & 12u) != 0u {
        flags = (flags & ~12u) | (f & 12u);
    }
    (*lv).inst_flags = flags;
}

"#;

/// `_optik_level_at`: the level at depth `k` of an instancing walk, built from the world ray
/// by the walk's own steps along `_optik_path` (the root's transforms, then each instance and
/// its transforms). Every level is built by this one function, the root's when the walk
/// starts, an instance's when its marker is popped, and its parent's again when the instance
/// is done: the same steps in the same order give the same ray bit for bit, so no level is
/// saved (a saved level lived in local memory and its copy in registers at the instance
/// entry, where the kernel's registers peaked; docs/wgpu-backend.md §12.4–12.5).
fn level_builder(c: &KernelConfig<'_>, out: &mut String) {
    out.push_str(INTO_INSTANCE);
    out.push_str("// Makes `*lv` the level at depth `k` of the current walk from the world ray, by the walk's\n// steps along the path; false when it holds nothing to hit.\nfn _optik_level_at(lv: ptr<function, _OptikLevel>, k: u32) -> bool {\n");
    root_fields(c, "(*lv)", out);
    let follow = |header: &str| {
        if c.any_graph() {
            format!("_optik_through_transforms(lv, {header})")
        } else {
            header.to_string()
        }
    };
    out.push_str(&format!(
        "    var header = {};\n    for (var i = 0u; i < min(k, _OPTIK_LEVELS); i = i + 1u) {{\n        if header == _OPTIK_NONE {{\n            return false;\n        }}\n        let rec = _optik_path[i];\n        let link = _optik_fetch(rec + 7u);\n        _optik_into_instance(lv, rec, _optik_fetch(rec + 6u));\n        header = {};\n    }}\n",
        follow("_optik_root"),
        follow("_optik_resolve(link.x, link.y)")
    ));
    // Single-level instancing: an instance holds geometry only.
    let nested = if c.one_level() {
        " && (k == 0u || ((*lv).kind_word & 15u) != 2u)"
    } else {
        ""
    };
    out.push_str(&format!("    return header != _OPTIK_NONE && _optik_finite3((*lv).origin) && _optik_finite3((*lv).direction) && _optik_enter(lv, header){nested};\n}}\n\n"));
}
