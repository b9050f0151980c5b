//! Geometry acceleration structures: build inputs decoded into per-primitive arrays in BVH
//! slot order, one array per motion key.

use super::aabb::Aabb;
use super::bvh::{BuildQuality, Bvh};
use super::collapse::LeafCosts;
use super::curve_basis::BezierSegment;
use super::micromap::MicromapArrayData;
use crate::PARALLEL_MIN_LEN;
use crate::decode::{self, BufferBytes};
use optik_api::semantics::{primitive, sbt_index};
use optik_api::{
    AccelBuildOptions, BuildInput, CurveEndcaps, CurveType, Error, GeometryFlags, MicromapArray,
    MotionOptions, PrimitiveTypeFlags, Result, SceneFeatures,
};
use rayon::prelude::*;
use std::sync::Arc;

/// Looks up opacity micromap arrays named by triangle inputs.
pub trait MicromapLookup {
    /// The built array of `array`, or the handle's error.
    fn micromap_array(&self, array: MicromapArray) -> Result<Arc<MicromapArrayData>>;
}

/// A backend's own encoding of a built geometry structure, kept beside it and rebuilt with
/// it (the CPU backend's wide nodes and triangle blocks); `()` for a backend that encodes
/// elsewhere.
pub trait GasEncoding: Clone + std::fmt::Debug + PartialEq + Send + Sync + 'static {
    /// Encodes a structure whose tree, per-slot geometry and records are built.
    fn encode(bvh: &Bvh, geometry: &Geometry, primitives: &[PrimitiveInfo]) -> Self;

    /// How the backend's leaves over `geometry` cost, when it tests them a block of
    /// primitives at a time; `None` (the default) prices leaves per primitive.
    fn leaf_costs(_geometry: &Geometry) -> Option<LeafCosts> {
        None
    }

    /// Bytes the encoding occupies.
    fn size_in_bytes(&self) -> u64;
}

impl GasEncoding for () {
    fn encode(_: &Bvh, _: &Geometry, _: &[PrimitiveInfo]) {}

    fn size_in_bytes(&self) -> u64 {
        0
    }
}

/// What a primitive reports to programs, per slot.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PrimitiveInfo {
    /// `rt_primitive_index`: the index within its build input plus the input's
    /// `primitive_index_offset`.
    pub primitive_index: u32,
    /// `rt_sbt_gas_index`: the input's first record plus the per-primitive offset.
    pub sbt_gas_index: u32,
    /// The [`GeometryFlags`] bits of the primitive's SBT record.
    pub geometry_flags: u32,
    /// The build input the primitive came from.
    pub input: u32,
}

impl PrimitiveInfo {
    /// The geometry flags as a typed set.
    pub fn flags(&self) -> GeometryFlags {
        GeometryFlags(self.geometry_flags)
    }
}

/// Which opacity micromap a triangle uses.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MicromapRef {
    /// Index into [`TriangleMicromaps::arrays`]; `u32::MAX` for a triangle without one.
    pub array: u32,
    /// The micromap index in that array, or a special index (-1..-4).
    pub index: i32,
}

impl MicromapRef {
    /// No micromap.
    pub const NONE: MicromapRef = MicromapRef {
        array: u32::MAX,
        index: 0,
    };
}

/// Opacity micromaps of a triangle structure.
#[derive(Clone, Debug, PartialEq)]
pub struct TriangleMicromaps {
    /// The arrays the inputs name.
    pub arrays: Vec<Arc<MicromapArrayData>>,
    /// Per slot.
    pub refs: Vec<MicromapRef>,
}

/// Triangles: per key, per slot, the three object-space vertices (after the pre-transform).
#[derive(Clone, Debug, PartialEq)]
pub struct Triangles {
    /// `keys[k][slot]`.
    pub keys: Vec<Vec<[[f32; 3]; 3]>>,
    /// Opacity micromaps, when an input has them.
    pub micromaps: Option<TriangleMicromaps>,
}

/// Custom primitives: per key, per slot, the AABB an intersection program is called for.
#[derive(Clone, Debug, PartialEq)]
pub struct CustomPrimitives {
    /// `keys[k][slot]`.
    pub keys: Vec<Vec<Aabb>>,
}

/// Spheres: per key, per slot, `(centre.xyz, radius)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Spheres {
    /// `keys[k][slot]`.
    pub keys: Vec<Vec<[f32; 4]>>,
}

/// Curve segment end treatment, per slot: bit 0 cuts the swept tube at the segment's start
/// (an open strand start), bit 1 at its end.
pub mod curve_caps {
    /// The start is open.
    pub const OPEN_START: u8 = 1;
    /// The end is open.
    pub const OPEN_END: u8 = 2;
}

/// Round curves: per key, per slot, the segment's control points `(x, y, z, radius)` in
/// the input's basis (the first `curve_type.control_points()` count).
#[derive(Clone, Debug, PartialEq)]
pub struct Curves {
    /// The basis.
    pub curve_type: CurveType,
    /// `keys[k][slot]`.
    pub keys: Vec<Vec<[[f32; 4]; 4]>>,
    /// Per slot, [`curve_caps`] bits.
    pub caps: Vec<u8>,
}

/// The primitives of a structure.
#[derive(Clone, Debug, PartialEq)]
pub enum Geometry {
    /// Triangles.
    Triangles(Triangles),
    /// Custom primitives.
    Custom(CustomPrimitives),
    /// Spheres.
    Spheres(Spheres),
    /// Curves.
    Curves(Curves),
}

impl Geometry {
    /// The vertices of triangles without motion, per slot (what triangle blocks are made
    /// of); `None` for other primitives and for moving triangles.
    pub fn static_triangles(&self) -> Option<&[[[f32; 3]; 3]]> {
        match self {
            Geometry::Triangles(t) if t.keys.len() == 1 => Some(&t.keys[0]),
            _ => None,
        }
    }

    /// The pipeline primitive-type flag of this geometry.
    pub fn primitive_type(&self) -> PrimitiveTypeFlags {
        match self {
            Geometry::Triangles(_) => PrimitiveTypeFlags::TRIANGLE,
            Geometry::Custom(_) => PrimitiveTypeFlags::CUSTOM,
            Geometry::Spheres(_) => PrimitiveTypeFlags::SPHERE,
            Geometry::Curves(c) => optik_api::features::curve_flag(c.curve_type),
        }
    }

    fn size_in_bytes(&self) -> u64 {
        fn keys<T>(k: &[Vec<T>]) -> u64 {
            k.iter()
                .map(|v| (v.len() * std::mem::size_of::<T>()) as u64)
                .sum()
        }
        match self {
            Geometry::Triangles(t) => {
                keys(&t.keys)
                    + t.micromaps.as_ref().map_or(0, |m| {
                        (m.refs.len() * std::mem::size_of::<MicromapRef>()) as u64
                    })
            }
            Geometry::Custom(c) => keys(&c.keys),
            Geometry::Spheres(s) => keys(&s.keys),
            Geometry::Curves(c) => keys(&c.keys) + c.caps.len() as u64,
        }
    }

    /// The same geometry with slot `s` taken from position `order[s]` (gathered on the
    /// current rayon pool).
    fn permuted(&self, order: &[u32]) -> Geometry {
        fn keys<T: Copy + Send + Sync>(k: &[Vec<T>], order: &[u32]) -> Vec<Vec<T>> {
            k.iter().map(|v| pick(v, order)).collect()
        }
        match self {
            Geometry::Triangles(t) => Geometry::Triangles(Triangles {
                keys: keys(&t.keys, order),
                micromaps: t.micromaps.as_ref().map(|m| TriangleMicromaps {
                    arrays: m.arrays.clone(),
                    refs: pick(&m.refs, order),
                }),
            }),
            Geometry::Custom(c) => Geometry::Custom(CustomPrimitives {
                keys: keys(&c.keys, order),
            }),
            Geometry::Spheres(s) => Geometry::Spheres(Spheres {
                keys: keys(&s.keys, order),
            }),
            Geometry::Curves(c) => Geometry::Curves(Curves {
                curve_type: c.curve_type,
                keys: keys(&c.keys, order),
                caps: pick(&c.caps, order),
            }),
        }
    }
}

/// `v[order[s]]` for every `s`, gathered on the current rayon pool: the build's
/// permutations read in random order from arrays of up to millions of entries, a serial
/// share that grew with the thread count (docs/cpu-backend.md, "Issue 14: pushed children
/// prefetched, builds on the pool").
fn pick<T: Copy + Send + Sync>(v: &[T], order: &[u32]) -> Vec<T> {
    order
        .par_iter()
        .with_min_len(PARALLEL_MIN_LEN)
        .map(|&i| v[i as usize])
        .collect()
}

/// A built geometry acceleration structure, with a backend's encoding `E`.
#[derive(Clone, Debug, PartialEq)]
pub struct Gas<E: GasEncoding = ()> {
    /// The BVH over slots.
    pub bvh: Bvh,
    /// The backend's encoding of the structure, rebuilt on every build and refit.
    pub encoding: E,
    /// `primitive_order[slot]`: the primitive's index over all inputs, in input order.
    pub primitive_order: Vec<u32>,
    /// Per slot.
    pub primitives: Vec<PrimitiveInfo>,
    /// Per key, per slot.
    pub geometry: Geometry,
    /// Motion keys (`num_keys >= 2`), or `None` for a static structure.
    pub motion: Option<MotionOptions>,
    /// A box holding every primitive at every time.
    pub bounds: Aabb,
    /// What the structure contains, for pipeline feature resolution.
    pub features: SceneFeatures,
    /// The build quality used (kept so a compacted copy reports the same).
    pub quality: BuildQuality,
}

/// Primitives decoded in input order.
struct Decoded {
    infos: Vec<PrimitiveInfo>,
    /// Per primitive, a box over all keys; empty for primitives that can never be hit.
    boxes: Vec<Aabb>,
    geometry: Geometry,
}

fn motion_of(options: &AccelBuildOptions) -> (Option<MotionOptions>, usize) {
    match options.motion {
        Some(m) if m.num_keys >= 2 => (Some(m), m.num_keys as usize),
        _ => (None, 1),
    }
}

/// Per primitive of one input: its record offset (checked) and flags.
fn records(
    offsets: Option<&optik_api::SbtIndexOffsets>,
    flags: &[GeometryFlags],
    n: u32,
    first_record: u32,
    input: u32,
    primitive_index_offset: u32,
    bytes: &dyn BufferBytes,
) -> Result<Vec<PrimitiveInfo>> {
    let offsets = decode::sbt_offsets(offsets, n, flags.len() as u32, bytes)
        .map_err(|e| e.context(format!("build_inputs[{input}].sbt_index_offsets")))?;
    Ok(offsets
        .par_iter()
        .with_min_len(PARALLEL_MIN_LEN)
        .enumerate()
        .map(|(i, &o)| PrimitiveInfo {
            primitive_index: primitive_index_offset.wrapping_add(i as u32),
            sbt_gas_index: sbt_index::sbt_gas_index(first_record, o),
            geometry_flags: flags[o as usize].0,
            input,
        })
        .collect())
}

fn decode_inputs(
    options: &AccelBuildOptions,
    inputs: &[BuildInput],
    bytes: &dyn BufferBytes,
    micromaps: &dyn MicromapLookup,
) -> Result<Decoded> {
    let (_, keys) = motion_of(options);
    let counts: Vec<u32> = inputs.iter().map(|i| i.num_sbt_records()).collect();
    let first_records = sbt_index::input_first_records(&counts);
    let mut infos = Vec::new();
    let mut boxes = Vec::new();
    let ctx = |i: usize| move |e: Error| e.context(format!("build_inputs[{i}]"));
    match &inputs[0] {
        BuildInput::Triangles(_) => {
            let mut tri_keys: Vec<Vec<[[f32; 3]; 3]>> = vec![Vec::new(); keys];
            let mut arrays: Vec<Arc<MicromapArrayData>> = Vec::new();
            let mut refs = Vec::new();
            for (i, input) in inputs.iter().enumerate() {
                let BuildInput::Triangles(t) = input else {
                    unreachable!("validated: one input kind")
                };
                let n = t.num_primitives();
                infos.extend(records(
                    t.sbt_index_offsets.as_ref(),
                    &t.flags,
                    n,
                    first_records[i],
                    i as u32,
                    t.primitive_index_offset,
                    bytes,
                )?);
                let first_prim = boxes.len();
                boxes.par_extend(
                    rayon::iter::repeat_n(Aabb::EMPTY, n as usize).with_min_len(PARALLEL_MIN_LEN),
                );
                let mut usable = vec![true; n as usize];
                let mut some_key_has_area = vec![false; n as usize];
                for (k, key) in tri_keys.iter_mut().enumerate() {
                    let d = decode::triangles(t, k, bytes).map_err(ctx(i))?;
                    // Triangle by triangle on the current rayon pool (each writes only its
                    // own entries): the decoding is a serial share of the build otherwise.
                    let tris: Vec<[[f32; 3]; 3]> = d
                        .indices
                        .par_iter()
                        .with_min_len(PARALLEL_MIN_LEN)
                        .map(|idx| idx.map(|v| d.vertices[v as usize]))
                        .collect();
                    boxes[first_prim..]
                        .par_iter_mut()
                        .zip(usable.par_iter_mut())
                        .zip(some_key_has_area.par_iter_mut())
                        .zip(tris.par_iter())
                        .with_min_len(PARALLEL_MIN_LEN)
                        .for_each(|(((b, usable), has_area), tri)| {
                            if tri.iter().all(primitive::finite_point) {
                                *has_area |= !primitive::zero_area(tri);
                                for &v in tri {
                                    b.grow(v);
                                }
                            } else {
                                *usable = false;
                            }
                        });
                    if key.is_empty() {
                        *key = tris;
                    } else {
                        key.extend_from_slice(&tris);
                    }
                }
                for p in 0..n as usize {
                    if !usable[p] || !some_key_has_area[p] {
                        boxes[first_prim + p] = Aabb::EMPTY;
                    }
                }
                match &t.opacity_micromap {
                    Some(omm) => {
                        let array = micromaps.micromap_array(omm.array).map_err(ctx(i))?;
                        let ids = decode::micromap_indices(t, array.micromaps.len(), bytes)
                            .map_err(ctx(i))?
                            .unwrap_or_default();
                        let a = arrays
                            .iter()
                            .position(|x| Arc::ptr_eq(x, &array))
                            .unwrap_or_else(|| {
                                arrays.push(array);
                                arrays.len() - 1
                            });
                        refs.extend(ids.into_iter().map(|index| MicromapRef {
                            array: a as u32,
                            index,
                        }));
                    }
                    None => refs.extend(std::iter::repeat_n(MicromapRef::NONE, n as usize)),
                }
            }
            let micromaps = (!arrays.is_empty()).then_some(TriangleMicromaps { arrays, refs });
            Ok(Decoded {
                infos,
                boxes,
                geometry: Geometry::Triangles(Triangles {
                    keys: tri_keys,
                    micromaps,
                }),
            })
        }
        BuildInput::CustomPrimitives(_) => {
            let mut aabb_keys: Vec<Vec<Aabb>> = vec![Vec::new(); keys];
            for (i, input) in inputs.iter().enumerate() {
                let BuildInput::CustomPrimitives(c) = input else {
                    unreachable!("validated: one input kind")
                };
                infos.extend(records(
                    c.sbt_index_offsets.as_ref(),
                    &c.flags,
                    c.num_primitives,
                    first_records[i],
                    i as u32,
                    c.primitive_index_offset,
                    bytes,
                )?);
                let first_prim = boxes.len();
                boxes.resize(first_prim + c.num_primitives as usize, Aabb::EMPTY);
                let mut usable = vec![true; c.num_primitives as usize];
                for (k, key) in aabb_keys.iter_mut().enumerate() {
                    for (p, six) in decode::aabbs(c, k, bytes)
                        .map_err(ctx(i))?
                        .into_iter()
                        .enumerate()
                    {
                        let b = Aabb::from_six(six);
                        if b.is_finite() && b.is_valid() {
                            boxes[first_prim + p] = boxes[first_prim + p].union(&b);
                        } else {
                            usable[p] = false;
                        }
                        key.push(b);
                    }
                }
                for (p, ok) in usable.iter().enumerate() {
                    if !ok {
                        boxes[first_prim + p] = Aabb::EMPTY;
                    }
                }
            }
            Ok(Decoded {
                infos,
                boxes,
                geometry: Geometry::Custom(CustomPrimitives { keys: aabb_keys }),
            })
        }
        BuildInput::Spheres(_) => {
            let mut sphere_keys: Vec<Vec<[f32; 4]>> = vec![Vec::new(); keys];
            for (i, input) in inputs.iter().enumerate() {
                let BuildInput::Spheres(s) = input else {
                    unreachable!("validated: one input kind")
                };
                infos.extend(records(
                    s.sbt_index_offsets.as_ref(),
                    &s.flags,
                    s.num_vertices,
                    first_records[i],
                    i as u32,
                    s.primitive_index_offset,
                    bytes,
                )?);
                let first_prim = boxes.len();
                boxes.resize(first_prim + s.num_vertices as usize, Aabb::EMPTY);
                let mut usable = vec![true; s.num_vertices as usize];
                for (k, key) in sphere_keys.iter_mut().enumerate() {
                    for (p, sp) in decode::spheres(s, k, bytes)
                        .map_err(ctx(i))?
                        .into_iter()
                        .enumerate()
                    {
                        if sp.iter().all(|v| v.is_finite()) {
                            let b = Aabb::point([sp[0], sp[1], sp[2]])
                                .padded(sp[3])
                                .rounded_out();
                            boxes[first_prim + p] = boxes[first_prim + p].union(&b);
                        } else {
                            usable[p] = false;
                        }
                        key.push(sp);
                    }
                }
                for (p, ok) in usable.iter().enumerate() {
                    if !ok {
                        boxes[first_prim + p] = Aabb::EMPTY;
                    }
                }
            }
            Ok(Decoded {
                infos,
                boxes,
                geometry: Geometry::Spheres(Spheres { keys: sphere_keys }),
            })
        }
        BuildInput::Curves(c0) => {
            let curve_type = c0.curve_type;
            let per = curve_type.control_points() as usize;
            let mut curve_keys: Vec<Vec<[[f32; 4]; 4]>> = vec![Vec::new(); keys];
            let mut caps = Vec::new();
            for (i, input) in inputs.iter().enumerate() {
                let BuildInput::Curves(c) = input else {
                    unreachable!("validated: one input kind")
                };
                let n = c.num_primitives as usize;
                infos.extend((0..n).map(|p| PrimitiveInfo {
                    primitive_index: c.primitive_index_offset.wrapping_add(p as u32),
                    sbt_gas_index: first_records[i],
                    geometry_flags: c.flag.0,
                    input: i as u32,
                }));
                let first_prim = boxes.len();
                boxes.resize(first_prim + n, Aabb::EMPTY);
                let mut usable = vec![true; n];
                let mut segments = Vec::new();
                for (k, key) in curve_keys.iter_mut().enumerate() {
                    let d = decode::curves(c, k, bytes).map_err(ctx(i))?;
                    for (p, &first) in d.segments.iter().enumerate() {
                        let mut cp = [[0.0f32; 4]; 4];
                        for (j, point) in cp.iter_mut().enumerate().take(per) {
                            *point = d.points[first as usize + j];
                        }
                        if cp.iter().all(|q| q.iter().all(|v| v.is_finite())) {
                            let b = BezierSegment::from_basis(curve_type, &cp).bounds();
                            boxes[first_prim + p] = boxes[first_prim + p].union(&b);
                        } else {
                            usable[p] = false;
                        }
                        key.push(cp);
                    }
                    segments = d.segments;
                }
                for (p, ok) in usable.iter().enumerate() {
                    if !ok {
                        boxes[first_prim + p] = Aabb::EMPTY;
                    }
                }
                // A strand continues where another segment starts one control point later
                // (OptiX's convention); its open ends are cut unless round caps are asked for.
                let starts: std::collections::HashSet<u32> = segments.iter().copied().collect();
                let open_ends =
                    curve_type != CurveType::RoundLinear && c.endcaps == CurveEndcaps::Default;
                caps.extend(segments.iter().map(|&s| {
                    let mut bits = 0;
                    if open_ends && (s == 0 || !starts.contains(&(s - 1))) {
                        bits |= curve_caps::OPEN_START;
                    }
                    if open_ends && !starts.contains(&(s + 1)) {
                        bits |= curve_caps::OPEN_END;
                    }
                    bits
                }));
            }
            Ok(Decoded {
                infos,
                boxes,
                geometry: Geometry::Curves(Curves {
                    curve_type,
                    keys: curve_keys,
                    caps,
                }),
            })
        }
        BuildInput::Instances(_) => Err(Error::invalid(
            "instance inputs build an instance acceleration structure, not a geometry one",
        )),
    }
}

impl<E: GasEncoding> Gas<E> {
    /// Builds a geometry structure from validated inputs (`optik_core::validate::build_inputs`
    /// passed) whose buffers `bytes` reads.
    pub fn build(
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
        bytes: &dyn BufferBytes,
        micromaps: &dyn MicromapLookup,
    ) -> Result<Gas<E>> {
        let decoded = decode_inputs(options, inputs, bytes, micromaps)?;
        let quality = BuildQuality::from_flags(options.flags);
        let leaf_costs = E::leaf_costs(&decoded.geometry);
        let (bvh, order) = Bvh::build_with(&decoded.boxes, quality, leaf_costs)?;
        let (motion, _) = motion_of(options);
        let primitives = pick(&decoded.infos, &order);
        let geometry = decoded.geometry.permuted(&order);
        Ok(Gas {
            bounds: bvh.bounds(),
            encoding: E::encode(&bvh, &geometry, &primitives),
            geometry,
            primitive_order: order,
            primitives,
            bvh,
            motion,
            features: SceneFeatures::of_geometry(options, inputs),
            quality,
        })
    }

    /// Refits to moved primitives (`optik_core::validate::update` passed): same slots, new
    /// positions. Primitives left out at build (never hittable then) stay out. On error the
    /// structure is unchanged.
    pub fn refit(
        &mut self,
        options: &AccelBuildOptions,
        inputs: &[BuildInput],
        bytes: &dyn BufferBytes,
        micromaps: &dyn MicromapLookup,
    ) -> Result<()> {
        let decoded = decode_inputs(options, inputs, bytes, micromaps)?;
        let order = &self.primitive_order;
        let boxes = &decoded.boxes;
        self.geometry = decoded.geometry.permuted(order);
        self.primitives = pick(&decoded.infos, order);
        self.bvh.refit(|slot| boxes[order[slot] as usize]);
        self.encoding = E::encode(&self.bvh, &self.geometry, &self.primitives);
        self.bounds = self.bvh.bounds();
        Ok(())
    }

    /// Number of primitive slots (hittable primitives).
    pub fn num_slots(&self) -> usize {
        self.primitive_order.len()
    }

    /// Bytes the structure occupies.
    pub fn size_in_bytes(&self) -> u64 {
        self.bvh.size_in_bytes()
            + self.encoding.size_in_bytes()
            + (self.primitive_order.len() * 4) as u64
            + (self.primitives.len() * std::mem::size_of::<PrimitiveInfo>()) as u64
            + self.geometry.size_in_bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Bytes, buffer};
    use optik_api::{BufferView, BuildFlags, TriangleArray};

    struct NoMicromaps;

    impl MicromapLookup for NoMicromaps {
        fn micromap_array(&self, _: MicromapArray) -> Result<Arc<MicromapArrayData>> {
            Err(Error::invalid("no micromap arrays here"))
        }
    }

    /// An encoding whose leaves are priced by blocks of four, as the CPU backend's: its
    /// structures are built by the binned SAH (`()`'s by PLOC).
    #[derive(Clone, Debug, PartialEq)]
    struct Blocks;

    impl GasEncoding for Blocks {
        fn encode(_: &Bvh, _: &Geometry, _: &[PrimitiveInfo]) -> Blocks {
            Blocks
        }

        fn leaf_costs(_: &Geometry) -> Option<LeafCosts> {
            Some(LeafCosts {
                block: 4,
                visit: 0.0,
                node: 0.3,
                max_prims: 24,
            })
        }

        fn size_in_bytes(&self) -> u64 {
            0
        }
    }

    /// `n` small triangles scattered over a cube (as vertex bytes), each nudged by `nudge`.
    fn soup(n: u32, nudge: f32) -> Vec<u8> {
        let mut rnd = crate::testing::uniform(0x2545_f491);
        (0..n)
            .flat_map(|_| {
                let at = [rnd() * 100.0, rnd() * 100.0, rnd() * 100.0];
                let tri: [[f32; 3]; 3] = std::array::from_fn(|v| {
                    std::array::from_fn(|k| at[k] + rnd() + nudge * (v + k) as f32)
                });
                tri
            })
            .flat_map(|v| v.map(f32::to_le_bytes))
            .flatten()
            .collect()
    }

    fn built_and_refit<E: GasEncoding>(threads: usize) -> (Gas<E>, Gas<E>) {
        let n = 3 * PARALLEL_MIN_LEN as u32;
        let input = BuildInput::Triangles(TriangleArray::new(
            BufferView::new(buffer(0)),
            3 * n,
            GeometryFlags::DISABLE_ANYHIT,
        ));
        let options = AccelBuildOptions {
            flags: BuildFlags::ALLOW_UPDATE | BuildFlags::PREFER_FAST_TRACE,
            ..Default::default()
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("a thread pool");
        pool.install(|| {
            let before = Bytes(vec![soup(n, 0.0)]);
            let built = Gas::<E>::build(
                &options,
                std::slice::from_ref(&input),
                &before,
                &NoMicromaps,
            )
            .expect("a build");
            let mut refit = built.clone();
            let after = Bytes(vec![soup(n, 0.25)]);
            refit
                .refit(&options, &[input], &after, &NoMicromaps)
                .expect("a refit");
            (built, refit)
        })
    }

    #[test]
    fn builds_and_refits_are_the_same_on_any_number_of_threads() {
        // Both builders (PLOC for `()`, the binned SAH for `Blocks`), with inputs large
        // enough that every parallel loop splits into jobs on four threads.
        let (one, four) = (built_and_refit::<()>(1), built_and_refit::<()>(4));
        assert!(
            one.0 == four.0 && one.1 == four.1,
            "PLOC-built structures differ"
        );
        assert_ne!(one.0.bvh, one.1.bvh, "the refit moved the boxes");
        let (one, four) = (built_and_refit::<Blocks>(1), built_and_refit::<Blocks>(4));
        assert!(
            one.0 == four.0 && one.1 == four.1,
            "SAH-built structures differ"
        );
    }
}
