//! Build inputs decoded on the host (with `optik_accel::decode`, which checks index and SBT
//! offset ranges) into what the Vulkan builds take: `f32` vertices with `u32` indices for
//! native triangles, and packed AABBs for everything optik intersects itself, one Vulkan
//! geometry per SBT record (DESIGN.md §2: OptiX's per-primitive SBT offsets select among an
//! input's records; Vulkan selects by geometry index, so each record becomes its own geometry,
//! numbered as OptiX numbers records).
//!
//! Decoding on the host also converts every vertex format (Vulkan lacks half3 and snorm3) and
//! applies the pre-transform with the same code the CPU backend uses, so vertex positions are
//! identical across backends. The tables programs read come out of the same pass (tables.rs
//! has the record layout): primitive index remaps (a record's geometry holds a subset of its
//! input's primitives), triangle vertices, spheres and curve segments for optik's intersection
//! stages, per motion key (key-major: key `k` of primitive `p` at `(k · count + p) · stride`,
//! so key 0 reads the same with or without motion), the motion keys' times, and opacity
//! micromaps.
//!
//! Emulated triangles (every triangle test but `TriangleTest::Driver`) are AABBs padded so
//! that the driver's box test cannot miss a ray that touches the triangle ([`pad_triangle_box`]);
//! optik's triangle intersection stage decides the hit. Custom primitives', spheres' and
//! curves' boxes are padded the same way, so a ray grazing a box face still runs the
//! intersection program (conformance `numerics.near_box_faces`).

use super::tables::{self, NONE, Record};
use optik_accel::decode::{self, BufferBytes};
use optik_api::semantics::primitive;
use optik_api::{
    AccelBuildOptions, BuildFlags, BuildInput, CurveEndcaps, CurveType, Error, GeometryFlags,
    MicromapArray, OpacityMicromapArrayDesc, OpacityMicromapFormat, Result,
};
use std::sync::Arc;

/// What kind of primitives a geometry acceleration structure holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GasKind {
    /// Triangles (native Vulkan triangles, or AABBs with optik's triangle stage).
    Triangles,
    /// Custom primitives (AABBs) with the user's intersection programs.
    Custom,
    /// Spheres, as AABBs with optik's sphere intersection stage.
    Spheres,
    /// Curves of one type, as AABBs with optik's curve intersection stage.
    Curves(CurveType),
}

impl GasKind {
    /// The primitive kind of the geometry records' info word.
    pub fn info_kind(self) -> u32 {
        match self {
            GasKind::Triangles => tables::KIND_TRIANGLES,
            GasKind::Custom => tables::KIND_CUSTOM,
            GasKind::Spheres => tables::KIND_SPHERES,
            GasKind::Curves(_) => tables::KIND_CURVES,
        }
    }
}

/// Looks up the opacity micromap arrays triangle inputs name.
pub type MicromapLookup<'a> = dyn Fn(MicromapArray) -> Result<Arc<OpacityMicromapArrayDesc>> + 'a;

/// One Vulkan geometry: its data's place in [`DecodedGas::bytes`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DecodedGeometry {
    /// Native triangles: byte offset of the input's vertex array; AABB kinds: of the AABBs.
    pub data_offset: u64,
    /// Native triangles: vertices in the array.
    pub vertex_count: u32,
    /// Native triangles: byte offset of the geometry's index array.
    pub index_offset: u64,
    /// Primitives in the geometry.
    pub count: u32,
    /// The record's geometry flags.
    pub flags: GeometryFlags,
    /// The record's triangles have an opacity micromap: the intersection stage decides their
    /// opacity, so Vulkan must see them non-opaque.
    pub micromap: bool,
}

impl DecodedGeometry {
    /// Whether Vulkan treats the geometry as opaque.
    pub fn vk_opaque(&self) -> bool {
        self.flags.contains(GeometryFlags::DISABLE_ANYHIT) && !self.micromap
    }
}

/// A geometry acceleration structure's inputs, decoded.
#[derive(Clone, Debug, Default)]
pub struct DecodedGas {
    /// What the Vulkan build reads: vertex, index and AABB arrays, 16-byte aligned.
    pub bytes: Vec<u8>,
    /// One per SBT record, in SBT GAS index order.
    pub geometries: Vec<DecodedGeometry>,
    /// Geometry table records (tables.rs), data offsets relative to `data`.
    pub records: Vec<Record>,
    /// Data table words (a multiple of 4).
    pub data: Vec<u32>,
    /// Per input, each primitive's record: updates must keep it.
    pub partition: Vec<Vec<u32>>,
    /// Per geometry of boxes, its boxes over all motion keys (what Vulkan builds; motion
    /// transforms bound them again).
    pub boxes: Vec<Vec<[f32; 6]>>,
    /// Whether Vulkan sees triangles (else AABBs).
    pub native_triangles: bool,
}

/// The geometry table record of a geometry of boxes.
struct BoxRecord {
    flags: GeometryFlags,
    primitive_index_offset: u32,
    basis: u32,
    kind: GasKind,
}

/// One primitive of a geometry of boxes (its data words go to the builder's scratch).
struct BoxItem {
    /// Its box over all motion keys.
    bbox: [f32; 6],
    /// Its micromap words (tables.rs), when its input has micromaps.
    micromap: Option<[u32; 2]>,
}

/// The micromap of a geometry: the array's states, shared by its primitives.
struct MicromapBlock<'a> {
    states: &'a [u8],
}

/// Boxes of a geometry not yet written (boxes are padded once the whole structure's extent
/// is known).
struct PendingBoxes {
    geometry: usize,
    boxes: Vec<[f32; 6]>,
    pad: bool,
}

/// Collects a structure's geometries.
struct Builder {
    out: DecodedGas,
    pending: Vec<PendingBoxes>,
    /// Data offset of the structure's motion key block, or NONE.
    motion_block: u32,
    /// Motion keys of every input (1 without motion).
    keys: usize,
}

impl Builder {
    /// Adds one geometry of boxes holding the usable ones of primitives `all` (indices in
    /// their input); `item` gives a primitive's box and micromap words and appends its data
    /// words (`keys × stride`, key after key) to the vector it is given. The geometry's
    /// primitives are remapped to their input indices when it holds a subset
    /// (`several_records`, or unusable boxes left out).
    fn push_boxes(
        &mut self,
        all: &[u32],
        several_records: bool,
        record: BoxRecord,
        micromap: Option<MicromapBlock>,
        item: impl Fn(u32, &mut Vec<u32>) -> BoxItem,
    ) {
        // One scratch vector for every item's words (not one allocation per primitive:
        // decoding is most of a structure's build time).
        let mut words: Vec<u32> = Vec::new();
        let mut items: Vec<(u32, BoxItem)> = Vec::with_capacity(all.len());
        for &p in all {
            let start = words.len();
            let it = item(p, &mut words);
            if usable(&it.bbox) {
                items.push((p, it));
            } else {
                words.truncate(start);
            }
        }
        let count = items.len() as u32;
        let data = if words.is_empty() {
            NONE
        } else {
            let base = self.out.data.len() as u32;
            let per_item = words.len() / items.len();
            if self.keys == 1 {
                self.out.data.extend_from_slice(&words);
            } else {
                let stride = per_item / self.keys;
                for k in 0..self.keys {
                    for i in 0..items.len() {
                        let at = i * per_item + k * stride;
                        self.out.data.extend_from_slice(&words[at..at + stride]);
                    }
                }
            }
            base
        };
        let micromap_block = match micromap {
            Some(block) => self.push_micromaps(&items, block),
            None => NONE,
        };
        let geometry = self.out.geometries.len();
        self.out.geometries.push(DecodedGeometry {
            data_offset: 0,
            vertex_count: 0,
            index_offset: 0,
            count,
            flags: record.flags,
            micromap: micromap_block != NONE,
        });
        self.pending.push(PendingBoxes {
            geometry,
            boxes: items.iter().map(|(_, it)| it.bbox).collect(),
            // Every kind is padded: a driver's box test must never miss a box the ray
            // touches (custom primitives, spheres and curves included, see near_box_faces).
            pad: true,
        });
        let prims: Vec<u32> = items.iter().map(|(p, _)| *p).collect();
        let remap = remap_table(
            &mut self.out.data,
            &prims,
            several_records || prims.len() < all.len(),
        );
        self.out.records.push([
            record.primitive_index_offset,
            remap,
            data,
            info_word(record.kind, record.basis, record.flags),
            self.motion_block,
            micromap_block,
            count,
            0,
        ]);
    }

    /// Writes a geometry's micromap block: a header with the offset of the states, two words
    /// per primitive, then the states, 16-byte aligned.
    fn push_micromaps(&mut self, items: &[(u32, BoxItem)], block: MicromapBlock) -> u32 {
        let data = &mut self.out.data;
        data.resize(data.len().next_multiple_of(4), 0);
        let start = data.len();
        let states_at = (4 + 2 * items.len()).next_multiple_of(4);
        data.extend_from_slice(&[states_at as u32, 0, 0, 0]);
        for (_, it) in items {
            data.extend_from_slice(&it.micromap.unwrap_or([0, 0]));
        }
        data.resize(start + states_at, 0);
        for chunk in block.states.chunks(4) {
            let mut w = [0u8; 4];
            w[..chunk.len()].copy_from_slice(chunk);
            data.push(u32::from_le_bytes(w));
        }
        start as u32
    }

    /// Pads every box, writes every box array into `bytes` and pads the data.
    fn finish(mut self) -> DecodedGas {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in self.pending.iter().filter(|p| p.pad) {
            for b in &p.boxes {
                for k in 0..3 {
                    lo[k] = lo[k].min(b[k]);
                    hi[k] = hi[k].max(b[k + 3]);
                }
            }
        }
        let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f32, f32::max);
        self.out.boxes = vec![Vec::new(); self.out.geometries.len()];
        for mut p in std::mem::take(&mut self.pending) {
            if p.pad {
                for b in &mut p.boxes {
                    *b = pad_triangle_box(b, extent);
                }
            }
            let packed: Vec<f32> = p.boxes.iter().flatten().copied().collect();
            self.out.geometries[p.geometry].data_offset =
                push_aligned(&mut self.out.bytes, &f32_bytes(&packed));
            self.out.boxes[p.geometry] = p.boxes;
        }
        if self.out.bytes.is_empty() {
            self.out.bytes.resize(16, 0);
        }
        self.out.data = tables::padded_data(std::mem::take(&mut self.out.data));
        self.out
    }
}

/// The info word of a geometry record (tables.rs).
fn info_word(kind: GasKind, basis: u32, flags: GeometryFlags) -> u32 {
    (basis & 0xFF) | (kind.info_kind() << 8) | ((flags.0 & 0xFF) << 16)
}

/// Padding of emulated triangles' boxes, relative to the structure's extent: the driver's
/// slab test rounds each distance it computes by a few ε relative to the distance from the ray
/// origin, so a ray through a triangle's vertex or edge (which lie on its box) may miss the
/// exact box. Padded by `2^-14 · extent` (plus 4 ulps of the coordinate, so the padding
/// survives rounding far from the origin), a touching ray stays inside the box for ray
/// origins up to `2^-14 / (3ε) ≈ 340` extents away (object space).
pub const TRIANGLE_BOX_PADDING: f32 = 1.0 / 16384.0;

/// A triangle's box padded for the driver's box test (see [`TRIANGLE_BOX_PADDING`]).
pub fn pad_triangle_box(b: &[f32; 6], extent: f32) -> [f32; 6] {
    pad_box(b, extent * TRIANGLE_BOX_PADDING)
}

/// `b` widened by `delta` and then by 4 ulps on every side.
pub fn pad_box(b: &[f32; 6], delta: f32) -> [f32; 6] {
    let down = |x: f32| (x - delta).next_down().next_down().next_down().next_down();
    let up = |x: f32| (x + delta).next_up().next_up().next_up().next_up();
    [
        down(b[0]),
        down(b[1]),
        down(b[2]),
        up(b[3]),
        up(b[4]),
        up(b[5]),
    ]
}

fn push_aligned(bytes: &mut Vec<u8>, data: &[u8]) -> u64 {
    while !bytes.len().is_multiple_of(16) {
        bytes.push(0);
    }
    let at = bytes.len() as u64;
    bytes.extend_from_slice(data);
    at
}

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// Whether a box can hold a primitive: finite and not inverted. Primitives whose boxes
/// cannot are left out of the Vulkan geometry (their primitive indices are remapped around
/// them), so they never hit and no intersection program sees them.
fn usable(b: &[f32; 6]) -> bool {
    b.iter().all(|v| v.is_finite()) && (0..3).all(|k| b[k] <= b[k + 3])
}

/// The union of two boxes (NaN and inverted boxes stay unusable).
fn union(a: &[f32; 6], b: &[f32; 6]) -> [f32; 6] {
    if !usable(a) || !usable(b) {
        return [f32::NAN; 6];
    }
    [
        a[0].min(b[0]),
        a[1].min(b[1]),
        a[2].min(b[2]),
        a[3].max(b[3]),
        a[4].max(b[4]),
        a[5].max(b[5]),
    ]
}

/// The box of points; NaN when one is not finite.
fn box_of(points: &[[f32; 3]]) -> [f32; 6] {
    let mut b = [
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
    ];
    for p in points {
        if !p.iter().all(|c| c.is_finite()) {
            return [f32::NAN; 6];
        }
        for k in 0..3 {
            b[k] = b[k].min(p[k]);
            b[k + 3] = b[k + 3].max(p[k]);
        }
    }
    b
}

/// Which of an input's primitives use each of its records.
fn split_by_record(offsets: &[u32], records: u32) -> Vec<Vec<u32>> {
    let mut by_record = vec![Vec::new(); records as usize];
    for (p, &r) in offsets.iter().enumerate() {
        by_record[r as usize].push(p as u32);
    }
    by_record
}

/// The kind of a (validated) set of inputs.
pub fn gas_kind(inputs: &[BuildInput]) -> Result<GasKind> {
    Ok(match inputs.first() {
        Some(BuildInput::Triangles(_)) => GasKind::Triangles,
        Some(BuildInput::CustomPrimitives(_)) => GasKind::Custom,
        Some(BuildInput::Spheres(_)) => GasKind::Spheres,
        Some(BuildInput::Curves(c)) => GasKind::Curves(c.curve_type),
        _ => {
            return Err(Error::invalid(
                "a geometry acceleration structure needs geometry inputs",
            ));
        }
    })
}

/// The motion keys of a build (1 for a static one).
pub fn motion_keys(options: &AccelBuildOptions) -> usize {
    match options.motion {
        Some(m) if m.num_keys >= 2 => m.num_keys as usize,
        _ => 1,
    }
}

/// Decodes validated geometry inputs. `emulate_triangles` makes triangles AABBs for optik's
/// triangle stage (else they are Vulkan triangles); `micromaps` finds the micromap arrays
/// triangle inputs name.
pub fn decode_gas(
    options: &AccelBuildOptions,
    inputs: &[BuildInput],
    bytes: &dyn BufferBytes,
    emulate_triangles: bool,
    micromaps: &MicromapLookup,
) -> Result<DecodedGas> {
    let keys = motion_keys(options);
    let mut b = Builder {
        out: DecodedGas::default(),
        pending: Vec::new(),
        motion_block: NONE,
        keys,
    };
    if let Some(m) = options.motion.filter(|_| keys > 1) {
        b.motion_block = 0;
        b.out.data.extend_from_slice(&[
            keys as u32,
            m.flags.0,
            m.time_begin.to_bits(),
            m.time_end.to_bits(),
        ]);
    }
    let vertex_access = options
        .flags
        .contains(BuildFlags::ALLOW_RANDOM_VERTEX_ACCESS);
    for (i, input) in inputs.iter().enumerate() {
        let at = |e: Error| e.context(format!("build_inputs[{i}]"));
        match input {
            BuildInput::Triangles(t) if emulate_triangles => {
                let per_key: Vec<decode::DecodedTriangles> = (0..keys)
                    .map(|k| decode::triangles(t, k, bytes))
                    .collect::<Result<_>>()
                    .map_err(at)?;
                let indices = &per_key[0].indices;
                let n = indices.len() as u32;
                let records = t.flags.len() as u32;
                let offsets = decode::sbt_offsets(t.sbt_index_offsets.as_ref(), n, records, bytes)
                    .map_err(at)?;
                let array = match &t.opacity_micromap {
                    Some(omm) => Some(micromaps(omm.array).map_err(at)?),
                    None => None,
                };
                let micromap_ids = match &array {
                    Some(a) => decode::micromap_indices(t, a.micromaps.len(), bytes).map_err(at)?,
                    None => None,
                };
                for (r, all) in split_by_record(&offsets, records).iter().enumerate() {
                    let record = BoxRecord {
                        flags: t.flags[r],
                        primitive_index_offset: t.primitive_index_offset,
                        basis: 0,
                        kind: GasKind::Triangles,
                    };
                    let block = array.as_ref().map(|a| MicromapBlock { states: &a.data });
                    b.push_boxes(all, records > 1, record, block, |p, data| {
                        let tri = indices[p as usize];
                        let mut bbox = [f32::NAN; 6];
                        let mut some_key_has_area = false;
                        for (k, key) in per_key.iter().enumerate() {
                            let v = tri.map(|x| key.vertices[x as usize]);
                            let kb = box_of(&v);
                            bbox = if k == 0 { kb } else { union(&bbox, &kb) };
                            some_key_has_area |= !primitive::zero_area(&v);
                            data.extend(v.iter().flatten().map(|c| c.to_bits()));
                        }
                        // A triangle of zero area in every key is left out like a NaN one
                        // (DESIGN.md §4): the device test alone lets slivers through.
                        if !some_key_has_area {
                            bbox = [f32::NAN; 6];
                        }
                        let micromap = match (&array, &micromap_ids) {
                            (Some(a), Some(ids)) => Some(micromap_words(a, ids[p as usize])),
                            _ => None,
                        };
                        BoxItem { bbox, micromap }
                    });
                }
                b.out.partition.push(offsets);
            }
            BuildInput::Triangles(t) => {
                b.out.native_triangles = true;
                push_native_triangles(&mut b.out, t, vertex_access, bytes).map_err(at)?;
            }
            BuildInput::CustomPrimitives(c) => {
                let per_key: Vec<Vec<[f32; 6]>> = (0..keys)
                    .map(|k| decode::aabbs(c, k, bytes))
                    .collect::<Result<_>>()
                    .map_err(at)?;
                let records = c.flags.len() as u32;
                let offsets = decode::sbt_offsets(
                    c.sbt_index_offsets.as_ref(),
                    per_key[0].len() as u32,
                    records,
                    bytes,
                )
                .map_err(at)?;
                for (r, all) in split_by_record(&offsets, records).iter().enumerate() {
                    let record = BoxRecord {
                        flags: c.flags[r],
                        primitive_index_offset: c.primitive_index_offset,
                        basis: 0,
                        kind: GasKind::Custom,
                    };
                    // The keys' boxes as given: intersection programs run only when the ray
                    // meets the box (at its time), as on the CPU backend; the driver's test
                    // of the padded (and, in hardware, quantised) box lets more rays through
                    // (program/traversal.rs, `_optik_vanished`).
                    b.push_boxes(all, records > 1, record, None, |p, data| {
                        data.extend(per_key.iter().flat_map(|k| k[p as usize].map(f32::to_bits)));
                        BoxItem {
                            bbox: per_key
                                .iter()
                                .map(|k| k[p as usize])
                                .reduce(|a, x| union(&a, &x))
                                .unwrap_or([f32::NAN; 6]),
                            micromap: None,
                        }
                    });
                }
                b.out.partition.push(offsets);
            }
            BuildInput::Spheres(s) => {
                let per_key: Vec<Vec<[f32; 4]>> = (0..keys)
                    .map(|k| decode::spheres(s, k, bytes))
                    .collect::<Result<_>>()
                    .map_err(at)?;
                let records = s.flags.len() as u32;
                let offsets = decode::sbt_offsets(
                    s.sbt_index_offsets.as_ref(),
                    per_key[0].len() as u32,
                    records,
                    bytes,
                )
                .map_err(at)?;
                for (r, all) in split_by_record(&offsets, records).iter().enumerate() {
                    let record = BoxRecord {
                        flags: s.flags[r],
                        primitive_index_offset: s.primitive_index_offset,
                        basis: 0,
                        kind: GasKind::Spheres,
                    };
                    b.push_boxes(all, records > 1, record, None, |p, data| {
                        let mut bbox = [f32::NAN; 6];
                        for (k, key) in per_key.iter().enumerate() {
                            let [x, y, z, radius] = key[p as usize];
                            let kb = [
                                x - radius,
                                y - radius,
                                z - radius,
                                x + radius,
                                y + radius,
                                z + radius,
                            ];
                            bbox = if k == 0 { kb } else { union(&bbox, &kb) };
                            data.extend([x, y, z, radius].map(f32::to_bits));
                        }
                        BoxItem {
                            bbox,
                            micromap: None,
                        }
                    });
                }
                b.out.partition.push(offsets);
            }
            BuildInput::Curves(c) => {
                let per_key: Vec<decode::DecodedCurves> = (0..keys)
                    .map(|k| decode::curves(c, k, bytes))
                    .collect::<Result<_>>()
                    .map_err(at)?;
                let per = c.curve_type.control_points() as usize;
                let segments = &per_key[0].segments;
                let n = segments.len();
                // Linear curves always have round ends; other bases only with end caps on;
                // joints inside a strand are always round.
                let caps_on =
                    c.curve_type == CurveType::RoundLinear || c.endcaps == CurveEndcaps::On;
                let segment = |s: u32, data: &mut Vec<u32>| {
                    let s = s as usize;
                    let first = segments[s];
                    let starts_strand = s == 0 || segments[s - 1] + 1 != first;
                    let ends_strand = s + 1 == n || segments[s + 1] != first + 1;
                    let caps = u32::from(!starts_strand || caps_on)
                        | (u32::from(!ends_strand || caps_on) << 1);
                    let mut bbox = [f32::NAN; 6];
                    for (k, key) in per_key.iter().enumerate() {
                        let points: Vec<[f32; 4]> = (0..4)
                            .map(|j| key.points[first as usize + j.min(per - 1)])
                            .collect();
                        let kb = curve_bounds(c.curve_type, &points[..per]);
                        bbox = if k == 0 { kb } else { union(&bbox, &kb) };
                        data.extend(points.iter().flat_map(|p| p.map(f32::to_bits)));
                        data.push(caps);
                    }
                    BoxItem {
                        bbox,
                        micromap: None,
                    }
                };
                let all: Vec<u32> = (0..n as u32).collect();
                let record = BoxRecord {
                    flags: c.flag,
                    primitive_index_offset: c.primitive_index_offset,
                    basis: optik_api::wgsl::curve_basis(c.curve_type),
                    kind: GasKind::Curves(c.curve_type),
                };
                b.push_boxes(&all, false, record, None, segment);
                b.out.partition.push(vec![0; n]);
            }
            BuildInput::Instances(_) => {
                return Err(Error::invalid(
                    "instances cannot be built into a geometry acceleration structure",
                ));
            }
        }
    }
    Ok(b.finish())
}

/// Whether the driver's triangles can serve a triangle structure decoded for optik's
/// triangle stage, on a device that mixes them (docs/vulkan-backend.md §2.4): without motion
/// keys, micromaps or records that disable face culling (Vulkan culls per instance, and a
/// ray culling both faces skips every driver triangle, §4).
pub fn driver_can_serve(options: &AccelBuildOptions, decoded: &DecodedGas) -> bool {
    motion_keys(options) == 1
        && decoded.geometries.iter().all(|g| {
            !g.micromap
                && !g
                    .flags
                    .contains(GeometryFlags::DISABLE_TRIANGLE_FACE_CULLING)
        })
}

/// Gives a structure decoded for optik's triangle stage native Vulkan triangles over the
/// same primitives, numbered as its boxes were: the tables (records, remaps, vertices) stay
/// those optik's stage reads, so one closest-hit or any-hit stage serves both kinds, and the
/// boxes stay for motion transforms over it, whose proxies are optik's (§2.4). Each
/// geometry's vertices are its primitives' three vertices in the data table, unindexed
/// (indices `0..3n`).
pub fn add_driver_triangles(decoded: &mut DecodedGas) {
    let mut bytes = Vec::new();
    for (g, r) in decoded.geometries.iter_mut().zip(&decoded.records) {
        let words = 9 * g.count as usize;
        let mut vertices: Vec<f32> = match r[2] {
            NONE => Vec::new(),
            at => decoded.data[at as usize..at as usize + words]
                .iter()
                .map(|w| f32::from_bits(*w))
                .collect(),
        };
        if vertices.is_empty() {
            // Vulkan wants a vertex to point at even when a geometry has no triangles.
            vertices.extend([0.0; 3]);
        }
        g.data_offset = push_aligned(&mut bytes, &f32_bytes(&vertices));
        g.vertex_count = (vertices.len() / 3) as u32;
        let indices: Vec<u8> = (0..3 * g.count).flat_map(|i| i.to_le_bytes()).collect();
        g.index_offset = push_aligned(&mut bytes, &indices);
    }
    if bytes.is_empty() {
        bytes.resize(16, 0);
    }
    decoded.bytes = bytes;
    decoded.native_triangles = true;
}

/// A triangle input as Vulkan triangles, one geometry per record.
fn push_native_triangles(
    out: &mut DecodedGas,
    t: &optik_api::TriangleArray,
    vertex_access: bool,
    bytes: &dyn BufferBytes,
) -> Result<()> {
    let tris = decode::triangles(t, 0, bytes)?;
    let n = tris.indices.len() as u32;
    let records = t.flags.len() as u32;
    let offsets = decode::sbt_offsets(t.sbt_index_offsets.as_ref(), n, records, bytes)?;
    // A triangle with a NaN or infinite vertex, or of zero area, never hits and must not
    // disturb its neighbours: it becomes a point (all three indices on one finite vertex), which
    // Vulkan never reports. (Vulkan's own rule, a NaN x making a triangle inactive, is not
    // safe to rely on: lavapipe lets one such triangle hide its neighbours.) Degenerate
    // triangles stay active, so refits keep working.
    let mut vertices: Vec<f32> = tris.vertices.iter().flatten().copied().collect();
    let stand_in = match tris.vertices.iter().position(primitive::finite_point) {
        Some(i) => i as u32,
        None => {
            vertices.extend([0.0, 0.0, 0.0]);
            tris.vertices.len() as u32
        }
    };
    let vertex_count = (vertices.len() / 3) as u32;
    let data_offset = push_aligned(&mut out.bytes, &f32_bytes(&vertices));
    for (r, prims) in split_by_record(&offsets, records).iter().enumerate() {
        let mut idx: Vec<u32> = Vec::with_capacity(prims.len() * 3);
        for &p in prims {
            let tri = tris.indices[p as usize];
            let usable = primitive::triangle_hittable(&tri.map(|v| tris.vertices[v as usize]));
            idx.extend(if usable { tri } else { [stand_in; 3] });
        }
        let idx_bytes: Vec<u8> = idx.iter().flat_map(|v| v.to_le_bytes()).collect();
        let index_offset = push_aligned(&mut out.bytes, &idx_bytes);
        out.geometries.push(DecodedGeometry {
            data_offset,
            vertex_count,
            index_offset,
            count: prims.len() as u32,
            flags: t.flags[r],
            micromap: false,
        });
        out.boxes.push(Vec::new());
        let remap = remap_table(&mut out.data, prims, records > 1);
        let vertex_data = if vertex_access {
            let base = out.data.len() as u32;
            for &p in prims {
                for v in tris.indices[p as usize] {
                    out.data
                        .extend(tris.vertices[v as usize].iter().map(|c| c.to_bits()));
                }
            }
            base
        } else {
            NONE
        };
        out.records.push([
            t.primitive_index_offset,
            remap,
            vertex_data,
            info_word(GasKind::Triangles, 0, t.flags[r]),
            NONE,
            NONE,
            prims.len() as u32,
            0,
        ]);
    }
    out.partition.push(offsets);
    Ok(())
}

/// The micromap words of a triangle (tables.rs): the states' byte offset, and the level,
/// format and special state (`1 + state` for the special indices -1..-4, else 0).
fn micromap_words(array: &OpacityMicromapArrayDesc, index: i32) -> [u32; 2] {
    if index < 0 {
        // -1 transparent (state 0), -2 opaque (1), -3 unknown-transparent (2),
        // -4 unknown-opaque (3).
        let state = (-index - 1) as u32;
        return [0, (state + 1) << 16];
    }
    match array.micromaps.get(index as usize) {
        Some(m) => [
            m.byte_offset,
            m.subdivision_level as u32
                | (u32::from(m.format == OpacityMicromapFormat::FourState) << 8),
        ],
        // Indices were checked against the array by `decode::micromap_indices`.
        None => [0, 2 << 16],
    }
}

/// Writes a geometry's table from its primitives to their indices in the input when it
/// holds a subset of the input (several records, or primitives left out); returns its data
/// offset, or NONE when the geometry holds the input's primitives in order.
fn remap_table(data: &mut Vec<u32>, prims: &[u32], subset: bool) -> u32 {
    if !subset {
        return NONE;
    }
    let base = data.len() as u32;
    data.extend_from_slice(prims);
    base
}

/// A box holding a curve segment's swept spheres: optik-accel's curve bounds (the Bézier
/// form's control points, which hold the segment, grown by the largest radius), from the
/// segment's `t.control_points()` control points.
fn curve_bounds(t: CurveType, points: &[[f32; 4]]) -> [f32; 6] {
    let cp: [[f32; 4]; 4] = std::array::from_fn(|j| points[j.min(points.len() - 1)]);
    optik_accel::curve_basis::BezierSegment::from_basis(t, &cp)
        .bounds()
        .to_six()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_partition_primitives_in_order() {
        assert_eq!(
            split_by_record(&[1, 0, 1, 2, 1], 3),
            vec![vec![1], vec![0, 2, 4], vec![3]]
        );
        let mut data = Vec::new();
        assert_eq!(remap_table(&mut data, &[0, 2, 4], true), 0);
        assert_eq!(remap_table(&mut data, &[0, 1], false), NONE);
        assert_eq!(data, vec![0, 2, 4]);
    }

    #[test]
    fn unusable_boxes_are_recognised() {
        assert!(usable(&[0.0, 0.0, 0.0, 1.0, 1.0, 1.0]));
        assert!(usable(&[1.0, 1.0, 1.0, 1.0, 1.0, 1.0]));
        assert!(!usable(&[2.0, 0.0, 0.0, 1.0, 1.0, 1.0]));
        assert!(!usable(&[0.0, f32::INFINITY, 0.0, 1.0, 1.0, 1.0]));
        assert!(!usable(&[f32::NAN, 0.0, 0.0, 1.0, 1.0, 1.0]));
        assert!(!usable(&union(
            &[0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            &[f32::NAN, 0.0, 0.0, 1.0, 1.0, 1.0]
        )));
    }

    #[test]
    fn padded_triangle_boxes_hold_their_triangle_with_a_margin() {
        // A flat triangle far from the origin: the padding survives rounding there.
        let b = box_of(&[[1e5, 2.0, 0.0], [1e5 + 1.0, 2.0, 0.0], [1e5, 3.0, 0.0]]);
        let p = pad_triangle_box(&b, 1.0);
        for k in 0..3 {
            assert!(
                p[k] < b[k] && p[k + 3] > b[k + 3],
                "axis {k}: {p:?} around {b:?}"
            );
        }
        // Near the origin the relative padding dominates.
        let b = [0.0, 0.0, 0.0, 1.0, 1.0, 0.0];
        let p = pad_triangle_box(&b, 1.0);
        assert!(p[2] <= -TRIANGLE_BOX_PADDING && p[5] >= TRIANGLE_BOX_PADDING);
    }

    #[test]
    fn micromap_words_encode_special_indices_and_formats() {
        let array = OpacityMicromapArrayDesc {
            micromaps: vec![optik_api::OpacityMicromapDesc {
                byte_offset: 8,
                subdivision_level: 3,
                format: OpacityMicromapFormat::FourState,
            }],
            data: vec![0; 40],
        };
        assert_eq!(micromap_words(&array, 0), [8, 3 | 1 << 8]);
        assert_eq!(micromap_words(&array, -1), [0, 1 << 16]);
        assert_eq!(micromap_words(&array, -4), [0, 4 << 16]);
    }

    #[test]
    fn catmull_rom_bounds_hold_the_overshoot() {
        // A Catmull-Rom segment overshoots its middle control points' hull.
        let pts = [
            [0.0, 0.0, 0.0, 0.1],
            [1.0, 0.0, 0.0, 0.1],
            [2.0, 1.0, 0.0, 0.1],
            [3.0, -5.0, 0.0, 0.1],
        ];
        let b = curve_bounds(CurveType::RoundCatmullRom, &pts);
        for i in 0..=100 {
            let u = i as f32 / 100.0;
            let w = [
                0.5 * (-u * u * u + 2.0 * u * u - u),
                0.5 * (3.0 * u * u * u - 5.0 * u * u + 2.0),
                0.5 * (-3.0 * u * u * u + 4.0 * u * u + u),
                0.5 * (u * u * u - u * u),
            ];
            for k in 0..3 {
                let c: f32 = (0..4).map(|j| w[j] * pts[j][k]).sum();
                assert!(
                    c - 0.1 >= b[k] - 1e-5 && c + 0.1 <= b[k + 3] + 1e-5,
                    "u {u} axis {k}: {c} outside {b:?}"
                );
            }
        }
    }
}
