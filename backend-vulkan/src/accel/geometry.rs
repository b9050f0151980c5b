//! Build inputs decoded on the host (with `optik_api::decode`, which checks index and SBT
//! offset ranges) into what the Vulkan builds take: `f32` vertices with `u32` indices, and
//! packed AABBs, one Vulkan geometry per SBT record (DESIGN.md §2: OptiX's per-primitive SBT
//! offsets select among an input's records; Vulkan selects by geometry index, so each record
//! becomes its own geometry, numbered as OptiX numbers records).
//!
//! Decoding on the host also converts every vertex format (Vulkan lacks half3 and snorm3) and
//! applies the pre-transform with the same code the CPU backend uses, so vertex positions are
//! identical across backends. The tables programs read come out of the same pass: primitive
//! index remaps (a record's geometry holds a subset of its input's primitives), vertices for
//! `rt_triangle_vertices`, spheres and curve segments for optik's intersection stages.

use super::tables::NONE;
use optik_api::decode::{self, BufferBytes};
use optik_api::{
    AccelBuildOptions, BuildFlags, BuildInput, CurveEndcaps, CurveType, Error, GeometryFlags,
    Result,
};

/// What kind of primitives a geometry acceleration structure holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GasKind {
    /// Triangles, intersected by the driver.
    Triangles,
    /// Custom primitives (AABBs) with the user's intersection programs.
    Custom,
    /// Spheres, as AABBs with optik's sphere intersection stage.
    Spheres,
    /// Curves of one type, as AABBs with optik's curve intersection stage.
    Curves(CurveType),
}

impl GasKind {
    /// Whether Vulkan sees triangles (else AABBs).
    pub fn is_triangles(self) -> bool {
        self == GasKind::Triangles
    }
}

/// One Vulkan geometry: its data's place in [`DecodedGas::bytes`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DecodedGeometry {
    /// Triangles: byte offset of the input's vertex array; AABB kinds: of the AABBs.
    pub data_offset: u64,
    /// Triangles: vertices in the array.
    pub vertex_count: u32,
    /// Triangles: byte offset of the geometry's index array.
    pub index_offset: u64,
    /// Primitives in the geometry.
    pub count: u32,
    /// The record's geometry flags.
    pub flags: GeometryFlags,
}

/// A geometry acceleration structure's inputs, decoded.
#[derive(Clone, Debug, Default)]
pub struct DecodedGas {
    /// What the Vulkan build reads: vertex, index and AABB arrays, 16-byte aligned.
    pub bytes: Vec<u8>,
    /// One per SBT record, in SBT GAS index order.
    pub geometries: Vec<DecodedGeometry>,
    /// Geometry table records (`[primitive index offset, remap, data, curve basis]`, data
    /// offsets relative to `data`).
    pub records: Vec<[u32; 4]>,
    /// Data table words: remaps, vertices, spheres, curve segments.
    pub data: Vec<u32>,
    /// Per input, each primitive's record: updates must keep it.
    pub partition: Vec<Vec<u32>>,
}

/// The geometry table record of a geometry of boxes.
struct BoxRecord {
    flags: GeometryFlags,
    primitive_index_offset: u32,
    basis: u32,
}

impl DecodedGas {
    /// Adds one geometry of boxes holding the usable ones of primitives `all` (indices in
    /// their input); `item` gives a primitive's box and its data words (sphere centre and
    /// radius, curve segment; none for custom primitives). The geometry's primitives are
    /// remapped to their input indices when it holds a subset (`several_records`, or
    /// unusable boxes left out).
    fn push_boxes(
        &mut self,
        all: &[u32],
        several_records: bool,
        record: BoxRecord,
        item: impl Fn(u32) -> ([f32; 6], Vec<u32>),
    ) {
        let items: Vec<(u32, [f32; 6], Vec<u32>)> = all
            .iter()
            .map(|&p| (p, item(p)))
            .map(|(p, (b, d))| (p, b, d))
            .filter(|(_, b, _)| usable(b))
            .collect();
        let packed: Vec<f32> = items.iter().flat_map(|(_, b, _)| *b).collect();
        let data_offset = push_aligned(&mut self.bytes, &f32_bytes(&packed));
        let base = if items.iter().any(|(_, _, d)| !d.is_empty()) {
            let base = self.data.len() as u32;
            for (_, _, d) in &items {
                self.data.extend_from_slice(d);
            }
            base
        } else {
            NONE
        };
        self.geometries.push(DecodedGeometry {
            data_offset,
            vertex_count: 0,
            index_offset: 0,
            count: items.len() as u32,
            flags: record.flags,
        });
        let prims: Vec<u32> = items.iter().map(|(p, _, _)| *p).collect();
        let remap = remap_table(
            &mut self.data,
            &prims,
            several_records || prims.len() < all.len(),
        );
        self.records
            .push([record.primitive_index_offset, remap, base, record.basis]);
    }
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

/// Decodes validated geometry inputs.
pub fn decode_gas(
    options: &AccelBuildOptions,
    inputs: &[BuildInput],
    bytes: &dyn BufferBytes,
) -> Result<DecodedGas> {
    let mut out = DecodedGas::default();
    let vertex_access = options
        .flags
        .contains(BuildFlags::ALLOW_RANDOM_VERTEX_ACCESS);
    for (i, input) in inputs.iter().enumerate() {
        let at = |e: Error| e.context(format!("build_inputs[{i}]"));
        match input {
            BuildInput::Triangles(t) => {
                let tris = decode::triangles(t, 0, bytes).map_err(at)?;
                let n = tris.indices.len() as u32;
                let records = t.flags.len() as u32;
                let offsets = decode::sbt_offsets(t.sbt_index_offsets.as_ref(), n, records, bytes)
                    .map_err(at)?;
                // A triangle with a NaN or infinite vertex never hits and must not disturb its
                // neighbours: it becomes degenerate (all three indices on one finite vertex),
                // which Vulkan never reports. (Vulkan's own rule, a NaN x making a triangle
                // inactive, is not safe to rely on: lavapipe lets one such triangle hide its
                // neighbours.) Degenerate triangles stay active, so refits keep working.
                let finite = |v: &[f32; 3]| v.iter().all(|c| c.is_finite());
                let mut vertices: Vec<f32> = tris.vertices.iter().flatten().copied().collect();
                let stand_in = match tris.vertices.iter().position(finite) {
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
                        let usable = tri.iter().all(|&v| finite(&tris.vertices[v as usize]));
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
                    });
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
                    out.records
                        .push([t.primitive_index_offset, remap, vertex_data, 0]);
                }
                out.partition.push(offsets);
            }
            BuildInput::CustomPrimitives(c) => {
                let boxes = decode::aabbs(c, 0, bytes).map_err(at)?;
                let records = c.flags.len() as u32;
                let offsets = decode::sbt_offsets(
                    c.sbt_index_offsets.as_ref(),
                    boxes.len() as u32,
                    records,
                    bytes,
                )
                .map_err(at)?;
                for (r, all) in split_by_record(&offsets, records).iter().enumerate() {
                    let record = BoxRecord {
                        flags: c.flags[r],
                        primitive_index_offset: c.primitive_index_offset,
                        basis: 0,
                    };
                    out.push_boxes(all, records > 1, record, |p| {
                        (boxes[p as usize], Vec::new())
                    });
                }
                out.partition.push(offsets);
            }
            BuildInput::Spheres(s) => {
                let spheres = decode::spheres(s, 0, bytes).map_err(at)?;
                let records = s.flags.len() as u32;
                let offsets = decode::sbt_offsets(
                    s.sbt_index_offsets.as_ref(),
                    spheres.len() as u32,
                    records,
                    bytes,
                )
                .map_err(at)?;
                for (r, all) in split_by_record(&offsets, records).iter().enumerate() {
                    let record = BoxRecord {
                        flags: s.flags[r],
                        primitive_index_offset: s.primitive_index_offset,
                        basis: 0,
                    };
                    out.push_boxes(all, records > 1, record, |p| {
                        let [x, y, z, radius] = spheres[p as usize];
                        (
                            [
                                x - radius,
                                y - radius,
                                z - radius,
                                x + radius,
                                y + radius,
                                z + radius,
                            ],
                            [x, y, z, radius].map(f32::to_bits).to_vec(),
                        )
                    });
                }
                out.partition.push(offsets);
            }
            BuildInput::Curves(c) => {
                let curves = decode::curves(c, 0, bytes).map_err(at)?;
                let per = c.curve_type.control_points() as usize;
                let n = curves.segments.len();
                // Linear curves always have round ends; other bases only with end caps on;
                // joints inside a strand are always round.
                let caps_on =
                    c.curve_type == CurveType::RoundLinear || c.endcaps == CurveEndcaps::On;
                let segment = |s: u32| {
                    let s = s as usize;
                    let first = curves.segments[s];
                    let points: Vec<[f32; 4]> = (0..4)
                        .map(|k| curves.points[first as usize + k.min(per - 1)])
                        .collect();
                    let starts_strand = s == 0 || curves.segments[s - 1] + 1 != first;
                    let ends_strand = s + 1 == n || curves.segments[s + 1] != first + 1;
                    let caps = u32::from(!starts_strand || caps_on)
                        | (u32::from(!ends_strand || caps_on) << 1);
                    let mut data: Vec<u32> =
                        points.iter().flat_map(|p| p.map(f32::to_bits)).collect();
                    data.push(caps);
                    (curve_bounds(c.curve_type, &points[..per]), data)
                };
                let all: Vec<u32> = (0..n as u32).collect();
                let record = BoxRecord {
                    flags: c.flag,
                    primitive_index_offset: c.primitive_index_offset,
                    basis: optik_api::wgsl::curve_basis(c.curve_type),
                };
                out.push_boxes(&all, false, record, segment);
                out.partition.push(vec![0; n]);
            }
            BuildInput::Instances(_) => {
                return Err(Error::invalid(
                    "instances cannot be built into a geometry acceleration structure",
                ));
            }
        }
    }
    if out.bytes.is_empty() {
        out.bytes.resize(16, 0);
    }
    Ok(out)
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

/// A box holding a curve segment's swept spheres. Uniform B-splines lie in the convex hull of
/// their control points; Catmull-Rom segments do not, so their Bezier control points (whose
/// hull holds the segment) are bounded instead. Radii interpolate with the same weights.
fn curve_bounds(t: CurveType, points: &[[f32; 4]]) -> [f32; 6] {
    let hull: Vec<[f32; 4]> = if t == CurveType::RoundCatmullRom && points.len() == 4 {
        let (p0, p1, p2, p3) = (points[0], points[1], points[2], points[3]);
        let b1: [f32; 4] = std::array::from_fn(|k| p1[k] + (p2[k] - p0[k]) / 6.0);
        let b2: [f32; 4] = std::array::from_fn(|k| p2[k] - (p3[k] - p1[k]) / 6.0);
        vec![p1, b1, b2, p2]
    } else {
        points.to_vec()
    };
    let r = hull.iter().map(|p| p[3].abs()).fold(0.0f32, f32::max);
    let mut b = [
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
    ];
    for p in &hull {
        for k in 0..3 {
            b[k] = b[k].min(p[k] - r);
            b[k + 3] = b[k + 3].max(p[k] + r);
        }
    }
    b
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
