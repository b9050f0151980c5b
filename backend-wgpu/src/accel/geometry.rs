//! Geometry acceleration structures: build inputs decoded on the host, a BVH built over the
//! primitives' boxes, and everything encoded in the layout of [`super::layout`].
//!
//! Triangles keep full f32 vertices (48 bytes per triangle and key), so the GPU's
//! watertight test sees exactly the vertices the user gave (no f16 edges, research/numerics.md
//! F7). Motion geometry stores every key; boxes are unions over the keys, which bound the
//! linear interpolation between them.

use super::aabb::Aabb;
use super::builder;
use super::bvh4::{Bvh4, NODE_VEC4S};
use super::layout::{self, HEADER_VEC4S, kind, prim};
use optik_api::decode::{self, BufferBytes};
use optik_api::semantics::sbt_index;
use optik_api::{
    AccelBuildOptions, BuildInput, CurveEndcaps, CurveType, Error, MicromapArray,
    OpacityMicromapDesc, OpacityMicromapFormat, Result,
};

/// A built opacity micromap array (immutable once created).
#[derive(Clone, Debug)]
pub(crate) struct MicromapData {
    pub micromaps: Vec<OpacityMicromapDesc>,
    pub data: Vec<u8>,
}

/// What a rebuild-free update needs: the tree and the slot order of the build.
#[derive(Clone, Debug)]
pub(crate) struct RefitState {
    bvh: Bvh4,
    order: Vec<u32>,
}

/// An encoded geometry structure.
pub(crate) struct BuiltGeometry {
    pub words: Vec<[u32; 4]>,
    pub bounds: Aabb,
    pub stack_need: u32,
    pub refit: RefitState,
}

/// Primitives of one structure before ordering: a box and a fixed-size record each.
struct Prims {
    prim_type: u32,
    keys: u32,
    /// Curve basis (0 for other primitives).
    basis: u32,
    boxes: Vec<Aabb>,
    records: Vec<[u32; 4]>,
    micromap_table: Vec<[u32; 4]>,
    micromap_data: Vec<u8>,
}

impl Prims {
    fn stride(&self) -> usize {
        layout::slot_vec4s(self.prim_type, self.keys) as usize
    }
}

fn meta_word(gas_index: u32, flags: u32) -> Result<u32> {
    if gas_index > layout::MAX_GAS_INDEX {
        return Err(Error::limit(format!(
            "SBT GAS index {gas_index} exceeds this backend's limit of {}",
            layout::MAX_GAS_INDEX
        )));
    }
    Ok(gas_index | ((flags & 7) << layout::GAS_INDEX_BITS))
}

fn bits3(v: [f32; 3], w: u32) -> [u32; 4] {
    [v[0].to_bits(), v[1].to_bits(), v[2].to_bits(), w]
}

/// Decodes `inputs` (all of one kind, already validated) into primitive records.
fn collect(
    options: &AccelBuildOptions,
    inputs: &[BuildInput],
    keys: usize,
    bytes: &dyn BufferBytes,
    micromap: &dyn Fn(MicromapArray) -> Result<MicromapData>,
) -> Result<Prims> {
    let _ = options;
    let first_records = sbt_index::input_first_records(
        &inputs
            .iter()
            .map(|i| i.num_sbt_records())
            .collect::<Vec<_>>(),
    );
    let (prim_type, basis) = match &inputs[0] {
        BuildInput::Triangles(_) => (prim::TRIANGLES, 0),
        BuildInput::CustomPrimitives(_) => (prim::CUSTOM, 0),
        BuildInput::Spheres(_) => (prim::SPHERES, 0),
        BuildInput::Curves(c) => (prim::CURVES, optik_api::wgsl::curve_basis(c.curve_type)),
        BuildInput::Instances(_) => {
            return Err(Error::backend("instances reached the geometry builder"));
        }
    };
    let mut p = Prims {
        prim_type,
        keys: keys as u32,
        basis,
        boxes: Vec::new(),
        records: Vec::new(),
        micromap_table: Vec::new(),
        micromap_data: Vec::new(),
    };
    for (input_index, input) in inputs.iter().enumerate() {
        let first_record = first_records[input_index];
        let context = |e: Error| e.context(format!("build_inputs[{input_index}]"));
        match input {
            BuildInput::Triangles(t) => {
                let n = t.num_primitives();
                let key_data: Vec<decode::DecodedTriangles> = (0..keys)
                    .map(|k| decode::triangles(t, k, bytes))
                    .collect::<Result<_>>()
                    .map_err(context)?;
                let offsets = decode::sbt_offsets(
                    t.sbt_index_offsets.as_ref(),
                    n,
                    t.flags.len() as u32,
                    bytes,
                )
                .map_err(context)?;
                let micromap_words = match &t.opacity_micromap {
                    None => None,
                    Some(omm) => {
                        let array = micromap(omm.array).map_err(context)?;
                        let indices = decode::micromap_indices(t, array.micromaps.len(), bytes)
                            .map_err(context)?
                            .unwrap_or_default();
                        let table_base = p.micromap_table.len() as u32;
                        let data_base = p.micromap_data.len() as u32;
                        for m in &array.micromaps {
                            p.micromap_table.push([
                                data_base + m.byte_offset,
                                m.subdivision_level as u32,
                                (m.format == OpacityMicromapFormat::FourState) as u32,
                                0,
                            ]);
                        }
                        p.micromap_data.extend_from_slice(&array.data);
                        Some(
                            indices
                                .iter()
                                .map(|&i| {
                                    if i < 0 {
                                        (-i) as u32
                                    } else {
                                        5 + table_base + i as u32
                                    }
                                })
                                .collect::<Vec<u32>>(),
                        )
                    }
                };
                for i in 0..n as usize {
                    let record = offsets[i];
                    let meta1 = meta_word(first_record + record, t.flags[record as usize].0)?;
                    let prim_index = t.primitive_index_offset.wrapping_add(i as u32);
                    let omm = micromap_words.as_ref().map_or(0, |w| w[i]);
                    let mut bounds = Aabb::EMPTY;
                    let mut usable = true;
                    for kd in &key_data {
                        let idx = kd.indices[i];
                        let v = idx.map(|j| kd.vertices[j as usize]);
                        let b = Aabb::of_points(&v);
                        usable &= b.is_usable();
                        bounds = bounds.union(b);
                        p.records.push(bits3(v[0], prim_index));
                        p.records.push(bits3(v[1], meta1));
                        p.records.push(bits3(v[2], omm));
                    }
                    p.boxes.push(if usable { bounds } else { Aabb::EMPTY });
                }
            }
            BuildInput::CustomPrimitives(c) => {
                let key_data: Vec<Vec<[f32; 6]>> = (0..keys)
                    .map(|k| decode::aabbs(c, k, bytes))
                    .collect::<Result<_>>()
                    .map_err(context)?;
                let offsets = decode::sbt_offsets(
                    c.sbt_index_offsets.as_ref(),
                    c.num_primitives,
                    c.flags.len() as u32,
                    bytes,
                )
                .map_err(context)?;
                for i in 0..c.num_primitives as usize {
                    let record = offsets[i];
                    let meta1 = meta_word(first_record + record, c.flags[record as usize].0)?;
                    p.records
                        .push([c.primitive_index_offset.wrapping_add(i as u32), meta1, 0, 0]);
                    let mut bounds = Aabb::EMPTY;
                    let mut usable = true;
                    for kd in &key_data {
                        let a = kd[i];
                        let b = Aabb {
                            min: [a[0], a[1], a[2]],
                            max: [a[3], a[4], a[5]],
                        };
                        usable &= b.is_usable();
                        bounds = bounds.union(b);
                        p.records.push(bits3(b.min, 0));
                        p.records.push(bits3(b.max, 0));
                    }
                    p.boxes.push(if usable { bounds } else { Aabb::EMPTY });
                }
            }
            BuildInput::Spheres(s) => {
                let key_data: Vec<Vec<[f32; 4]>> = (0..keys)
                    .map(|k| decode::spheres(s, k, bytes))
                    .collect::<Result<_>>()
                    .map_err(context)?;
                let offsets = decode::sbt_offsets(
                    s.sbt_index_offsets.as_ref(),
                    s.num_vertices,
                    s.flags.len() as u32,
                    bytes,
                )
                .map_err(context)?;
                for i in 0..s.num_vertices as usize {
                    let record = offsets[i];
                    let meta1 = meta_word(first_record + record, s.flags[record as usize].0)?;
                    p.records
                        .push([s.primitive_index_offset.wrapping_add(i as u32), meta1, 0, 0]);
                    let mut bounds = Aabb::EMPTY;
                    let mut usable = true;
                    for kd in &key_data {
                        let [x, y, z, r] = kd[i];
                        let b = Aabb {
                            min: [x, y, z],
                            max: [x, y, z],
                        }
                        .padded(r)
                        .widened_relative();
                        usable &= b.is_usable();
                        bounds = bounds.union(b);
                        p.records.push(kd[i].map(f32::to_bits));
                    }
                    p.boxes.push(if usable { bounds } else { Aabb::EMPTY });
                }
            }
            BuildInput::Curves(c) => {
                let key_data: Vec<decode::DecodedCurves> = (0..keys)
                    .map(|k| decode::curves(c, k, bytes))
                    .collect::<Result<_>>()
                    .map_err(context)?;
                let meta1 = meta_word(first_record, c.flag.0)?;
                let segments = &key_data[0].segments;
                let starts: std::collections::HashSet<u32> = segments.iter().copied().collect();
                let linear = c.curve_type == CurveType::RoundLinear;
                let caps_on = c.endcaps == CurveEndcaps::On;
                for (i, &first) in segments.iter().enumerate() {
                    let has_prev = first > 0 && starts.contains(&(first - 1));
                    let has_next = starts.contains(&(first + 1));
                    let cap_start = linear || caps_on || has_prev;
                    let cap_end = linear || caps_on || has_next;
                    p.records.push([
                        c.primitive_index_offset.wrapping_add(i as u32),
                        meta1,
                        cap_start as u32 | ((cap_end as u32) << 1),
                        0,
                    ]);
                    let mut bounds = Aabb::EMPTY;
                    let mut usable = true;
                    for kd in &key_data {
                        let n = c.curve_type.control_points() as usize;
                        let mut control = [[0.0f32; 4]; 4];
                        for (j, cp) in control.iter_mut().enumerate().take(n) {
                            *cp = kd.points[first as usize + j];
                        }
                        // Bounds from the Bézier form: Catmull-Rom segments can leave the
                        // hull of their own control points, never that of their Bézier ones.
                        let bezier = to_bezier(c.curve_type, &control);
                        let mut hull = Aabb::EMPTY;
                        let mut radius = 0.0f32;
                        for b in bezier.iter().take(n) {
                            hull = hull.grow([b[0], b[1], b[2]]);
                            radius = radius.max(b[3]);
                        }
                        let b = hull.padded(radius).widened_relative();
                        usable &= b.is_usable() && radius.is_finite();
                        bounds = bounds.union(b);
                        // The GPU evaluates the input's own basis (optik_curve_intersect).
                        for cp in control {
                            p.records.push(cp.map(f32::to_bits));
                        }
                    }
                    p.boxes.push(if usable { bounds } else { Aabb::EMPTY });
                }
            }
            BuildInput::Instances(_) => {}
        }
    }
    Ok(p)
}

/// A segment's control points (with radii) in Bézier form: the same curve, and by the convex
/// hull property its Bézier points bound it (centre and radius alike).
fn to_bezier(t: CurveType, p: &[[f32; 4]; 4]) -> [[f32; 4]; 4] {
    let weights: [[f32; 4]; 4] = match t {
        CurveType::RoundLinear => [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0; 4],
            [0.0; 4],
        ],
        CurveType::RoundQuadraticBSpline => [
            [0.5, 0.5, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.5, 0.5, 0.0],
            [0.0; 4],
        ],
        CurveType::RoundCubicBSpline => [
            [1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0, 0.0],
            [0.0, 4.0 / 6.0, 2.0 / 6.0, 0.0],
            [0.0, 2.0 / 6.0, 4.0 / 6.0, 0.0],
            [0.0, 1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0],
        ],
        CurveType::RoundCatmullRom => [
            [0.0, 1.0, 0.0, 0.0],
            [-1.0 / 6.0, 1.0, 1.0 / 6.0, 0.0],
            [0.0, 1.0 / 6.0, 1.0, -1.0 / 6.0],
            [0.0, 0.0, 1.0, 0.0],
        ],
    };
    std::array::from_fn(|i| std::array::from_fn(|k| (0..4).map(|j| weights[i][j] * p[j][k]).sum()))
}

/// Builds a geometry structure.
pub(crate) fn build(
    options: &AccelBuildOptions,
    inputs: &[BuildInput],
    keys: usize,
    bytes: &dyn BufferBytes,
    micromap: &dyn Fn(MicromapArray) -> Result<MicromapData>,
) -> Result<BuiltGeometry> {
    let prims = collect(options, inputs, keys, bytes, micromap)?;
    let (bin, order) = builder::build(&prims.boxes, 8, options.flags)?;
    let bvh = Bvh4::from_binary(&bin);
    let refit = RefitState { bvh, order };
    Ok(encode(options, &prims, &refit))
}

/// Re-encodes a structure for moved geometry with the topology of its build.
pub(crate) fn update(
    options: &AccelBuildOptions,
    inputs: &[BuildInput],
    keys: usize,
    bytes: &dyn BufferBytes,
    micromap: &dyn Fn(MicromapArray) -> Result<MicromapData>,
    state: &RefitState,
) -> Result<BuiltGeometry> {
    let prims = collect(options, inputs, keys, bytes, micromap)?;
    let mut refit = state.clone();
    let order = refit.order.clone();
    refit.bvh.refit(|slot| prims.boxes[order[slot] as usize]);
    Ok(encode(options, &prims, &refit))
}

fn encode(options: &AccelBuildOptions, prims: &Prims, refit: &RefitState) -> BuiltGeometry {
    let motion = options.motion.filter(|m| m.num_keys >= 2);
    let stride = prims.stride();
    let table_rel = HEADER_VEC4S as u32;
    let data_rel = table_rel + prims.micromap_table.len() as u32;
    let data_vec4s = prims.micromap_data.len().div_ceil(16) as u32;
    let node_rel = data_rel + data_vec4s;
    let prim_rel = node_rel + (refit.bvh.nodes.len() * NODE_VEC4S) as u32;
    let mut words = Vec::with_capacity(prim_rel as usize + refit.order.len() * stride);
    words.push([
        layout::kind_word(kind::GAS, prims.prim_type, prims.basis),
        prims.keys,
        node_rel,
        prim_rel,
    ]);
    words.push([
        motion.map_or(0.0f32, |m| m.time_begin).to_bits(),
        motion.map_or(0.0f32, |m| m.time_end).to_bits(),
        motion.map_or(0, |m| m.flags.0),
        table_rel,
    ]);
    words.push([data_rel, refit.bvh.nodes.len() as u32, 0, 0]);
    words.extend_from_slice(&prims.micromap_table);
    let mut data = prims.micromap_data.clone();
    data.resize(data_vec4s as usize * 16, 0);
    for chunk in data.chunks_exact(16) {
        words.push(std::array::from_fn(|i| {
            u32::from_le_bytes([
                chunk[i * 4],
                chunk[i * 4 + 1],
                chunk[i * 4 + 2],
                chunk[i * 4 + 3],
            ])
        }));
    }
    refit.bvh.encode(&mut words);
    for &p in &refit.order {
        let at = p as usize * stride;
        words.extend_from_slice(&prims.records[at..at + stride]);
    }
    BuiltGeometry {
        words,
        bounds: refit.bvh.bounds(),
        stack_need: refit.bvh.stack_need(|_, _| 0),
        refit: refit.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bezier_forms_match_their_bases() {
        // A cubic B-spline through collinear, evenly spaced points is the line itself:
        // its Bézier points are the thirds between the two middle points' neighbours.
        let p = [
            [0.0, 0.0, 0.0, 1.0],
            [1.0, 0.0, 0.0, 1.0],
            [2.0, 0.0, 0.0, 1.0],
            [3.0, 0.0, 0.0, 1.0],
        ];
        let b = to_bezier(CurveType::RoundCubicBSpline, &p);
        let xs: Vec<f32> = b.iter().map(|q| q[0]).collect();
        for (x, want) in xs.iter().zip([1.0, 4.0 / 3.0, 5.0 / 3.0, 2.0]) {
            assert!((x - want).abs() < 1e-6, "{xs:?}");
        }
        assert!(b.iter().all(|q| (q[3] - 1.0).abs() < 1e-6));
        // Catmull-Rom interpolates its middle points.
        let c = to_bezier(CurveType::RoundCatmullRom, &p);
        assert_eq!(c[0][0], 1.0);
        assert_eq!(c[3][0], 2.0);
        let q = to_bezier(CurveType::RoundQuadraticBSpline, &p);
        assert_eq!([q[0][0], q[1][0], q[2][0]], [0.5, 1.0, 1.5]);
    }
}
