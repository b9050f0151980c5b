//! Reading build inputs out of buffer bytes, shared by optik-accel's builders (which every
//! backend builds with) and by the Vulkan backend's checks.
//!
//! Every function here assumes `optik_core::validate::build_inputs` passed, and still returns
//! an error (never panics) for data that only the bytes can reveal: indices past the vertex
//! count, SBT offsets past the record count, micromap indices past the array.

// `!(x >= 0.0)` is how this module says "negative or NaN": the NaN case is the point.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use crate::PARALLEL_MIN_LEN;
use optik_api::accel::{
    BufferView, CurveArray, CustomPrimitiveArray, IndexFormat, Instance, InstanceArray,
    SbtIndexOffsets, SphereArray, TriangleArray, VertexFormat,
};
use optik_api::error::{Error, Result};
use optik_api::handle::Buffer;
use optik_api::semantics::affine;
use rayon::prelude::*;

/// Access to buffer bytes for decoding.
pub trait BufferBytes {
    /// The whole contents of `buffer`.
    fn bytes(&self, buffer: Buffer) -> Result<&[u8]>;
}

fn slice<'a>(
    bytes: &'a dyn BufferBytes,
    view: &BufferView,
    at: u64,
    len: usize,
) -> Result<&'a [u8]> {
    let data = bytes.bytes(view.buffer)?;
    let start = view.offset + at;
    let end = start + len as u64;
    data.get(start as usize..end as usize).ok_or_else(|| {
        Error::invalid(format!(
            "reading bytes {start}..{end} of a buffer of {} bytes",
            data.len()
        ))
    })
}

fn f32_at(b: &[u8], i: usize) -> f32 {
    f32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
}
fn u32_at(b: &[u8], i: usize) -> u32 {
    u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
}
fn u16_at(b: &[u8], i: usize) -> u16 {
    u16::from_le_bytes([b[i], b[i + 1]])
}

/// Decodes one vertex of `format` from `b`.
pub fn decode_vertex(format: VertexFormat, b: &[u8]) -> [f32; 3] {
    let half = |i| half::f16::from_bits(u16_at(b, i)).to_f32();
    let snorm = |i| (u16_at(b, i) as i16 as f32 / 32767.0).max(-1.0);
    match format {
        VertexFormat::Float3 => [f32_at(b, 0), f32_at(b, 4), f32_at(b, 8)],
        VertexFormat::Float2 => [f32_at(b, 0), f32_at(b, 4), 0.0],
        VertexFormat::Half3 => [half(0), half(2), half(4)],
        VertexFormat::Half2 => [half(0), half(2), 0.0],
        VertexFormat::Snorm16x3 => [snorm(0), snorm(2), snorm(4)],
        VertexFormat::Snorm16x2 => [snorm(0), snorm(2), 0.0],
    }
}

/// Decoded triangles of one input and one motion key.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DecodedTriangles {
    /// Vertex positions after the pre-transform.
    pub vertices: Vec<[f32; 3]>,
    /// Vertex indices per triangle, each checked against the vertex count.
    pub indices: Vec<[u32; 3]>,
}

/// Reads the vertices of motion key `key` and the indices of a triangle input.
pub fn triangles(
    t: &TriangleArray,
    key: usize,
    bytes: &dyn BufferBytes,
) -> Result<DecodedTriangles> {
    let stride = t.effective_vertex_stride() as usize;
    let size = t.vertex_format.size() as usize;
    let vb = &t.vertex_buffers[key];
    let n = t.num_vertices as usize;
    let raw = if n == 0 {
        &[][..]
    } else {
        slice(bytes, vb, 0, (n - 1) * stride + size)?
    };
    // Vertex by vertex and triangle by triangle on the current rayon pool (each writes only
    // its own entry): otherwise a serial share of every build.
    let mut vertices: Vec<[f32; 3]> = (0..n)
        .into_par_iter()
        .with_min_len(PARALLEL_MIN_LEN)
        .map(|i| decode_vertex(t.vertex_format, &raw[i * stride..]))
        .collect();
    if let Some(pt) = &t.pre_transform {
        let m = slice(bytes, pt, 0, 48)?;
        let m: [f32; 12] = std::array::from_fn(|i| f32_at(m, i * 4));
        vertices
            .par_iter_mut()
            .with_min_len(PARALLEL_MIN_LEN)
            .for_each(|v| *v = affine::transform_point(&m, *v));
    }
    let indices = match &t.indices {
        None => (0..t.num_vertices / 3)
            .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
            .collect(),
        Some(ix) => {
            let isize = ix.format.size() as usize;
            let istride = if ix.stride == 0 {
                isize
            } else {
                ix.stride as usize
            };
            let count = ix.num_triangles as usize;
            let raw = if count == 0 {
                &[][..]
            } else {
                slice(bytes, &ix.buffer, 0, (count - 1) * istride + isize)?
            };
            let out: Vec<[u32; 3]> = (0..count)
                .into_par_iter()
                .with_min_len(PARALLEL_MIN_LEN)
                .map(|tri| {
                    let b = &raw[tri * istride..];
                    match ix.format {
                        IndexFormat::U16x3 => [
                            u16_at(b, 0) as u32,
                            u16_at(b, 2) as u32,
                            u16_at(b, 4) as u32,
                        ],
                        IndexFormat::U32x3 => [u32_at(b, 0), u32_at(b, 4), u32_at(b, 8)],
                    }
                })
                .collect();
            // The first bad triangle (in order, whatever the threads), as a serial check would.
            let bad_index = |idx: &[u32; 3]| idx.iter().copied().find(|&i| i >= t.num_vertices);
            if let Some(tri) = out
                .par_iter()
                .with_min_len(PARALLEL_MIN_LEN)
                .position_first(|idx| bad_index(idx).is_some())
            {
                let bad = bad_index(&out[tri]).unwrap_or_default();
                return Err(Error::invalid(format!(
                    "triangle {tri} has vertex index {bad}, but the input has {} vertices (indices must be below num_vertices)",
                    t.num_vertices
                )));
            }
            out
        }
    };
    Ok(DecodedTriangles { vertices, indices })
}

/// Reads per-primitive SBT offsets; checks each is below the record count.
pub fn sbt_offsets(
    offsets: Option<&SbtIndexOffsets>,
    num_primitives: u32,
    num_records: u32,
    bytes: &dyn BufferBytes,
) -> Result<Vec<u32>> {
    let Some(o) = offsets else {
        return Ok(vec![0; num_primitives as usize]);
    };
    let size = o.size_in_bytes as usize;
    let stride = if o.stride == 0 {
        size
    } else {
        o.stride as usize
    };
    let n = num_primitives as usize;
    let raw = if n == 0 {
        &[][..]
    } else {
        slice(bytes, &o.buffer, 0, (n - 1) * stride + size)?
    };
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let b = &raw[i * stride..];
        let v = match size {
            1 => b[0] as u32,
            2 => u16_at(b, 0) as u32,
            _ => u32_at(b, 0),
        };
        if v >= num_records {
            return Err(Error::invalid(format!(
                "sbt_index_offsets[{i}] is {v}, but the input has {num_records} SBT records (offsets must be below that)"
            )));
        }
        out.push(v);
    }
    Ok(out)
}

/// Reads the AABBs (`min.xyz, max.xyz`) of motion key `key`.
pub fn aabbs(
    c: &CustomPrimitiveArray,
    key: usize,
    bytes: &dyn BufferBytes,
) -> Result<Vec<[f32; 6]>> {
    let stride = c.effective_stride() as usize;
    let n = c.num_primitives as usize;
    let raw = if n == 0 {
        &[][..]
    } else {
        slice(bytes, &c.aabb_buffers[key], 0, (n - 1) * stride + 24)?
    };
    Ok((0..n)
        .map(|i| std::array::from_fn(|k| f32_at(raw, i * stride + k * 4)))
        .collect())
}

/// Reads spheres (`centre.xyz, radius`) of motion key `key`.
pub fn spheres(s: &SphereArray, key: usize, bytes: &dyn BufferBytes) -> Result<Vec<[f32; 4]>> {
    let vs = s.effective_vertex_stride() as usize;
    let rs = s.effective_radius_stride() as usize;
    let n = s.num_vertices as usize;
    if n == 0 {
        return Ok(Vec::new());
    }
    let centres = slice(bytes, &s.vertex_buffers[key], 0, (n - 1) * vs + 12)?;
    let nr = if s.single_radius { 1 } else { n };
    let radii = slice(bytes, &s.radius_buffers[key], 0, (nr - 1) * rs + 4)?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let r = f32_at(radii, if s.single_radius { 0 } else { i * rs });
        if !(r >= 0.0) || !r.is_finite() {
            return Err(Error::invalid(format!(
                "sphere {i} has radius {r}; radii must be finite and not negative"
            )));
        }
        out.push([
            f32_at(centres, i * vs),
            f32_at(centres, i * vs + 4),
            f32_at(centres, i * vs + 8),
            r,
        ]);
    }
    Ok(out)
}

/// Decoded curves of one motion key.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DecodedCurves {
    /// Control points with their radius in `w`.
    pub points: Vec<[f32; 4]>,
    /// Per segment, its first control point; each checked so the segment's points exist.
    pub segments: Vec<u32>,
}

/// Reads the control points and segment indices of a curve input.
pub fn curves(c: &CurveArray, key: usize, bytes: &dyn BufferBytes) -> Result<DecodedCurves> {
    let vs = if c.vertex_stride == 0 {
        12
    } else {
        c.vertex_stride as usize
    };
    let ws = if c.width_stride == 0 {
        4
    } else {
        c.width_stride as usize
    };
    let is = if c.index_stride == 0 {
        4
    } else {
        c.index_stride as usize
    };
    let nv = c.num_vertices as usize;
    let mut points = Vec::with_capacity(nv);
    if nv > 0 {
        let pos = slice(bytes, &c.vertex_buffers[key], 0, (nv - 1) * vs + 12)?;
        let wid = slice(bytes, &c.width_buffers[key], 0, (nv - 1) * ws + 4)?;
        for i in 0..nv {
            let r = f32_at(wid, i * ws);
            if !(r >= 0.0) || !r.is_finite() {
                return Err(Error::invalid(format!(
                    "curve control point {i} has radius {r}; radii must be finite and not negative"
                )));
            }
            points.push([
                f32_at(pos, i * vs),
                f32_at(pos, i * vs + 4),
                f32_at(pos, i * vs + 8),
                r,
            ]);
        }
    }
    let n = c.num_primitives as usize;
    let raw = if n == 0 {
        &[][..]
    } else {
        slice(bytes, &c.index_buffer, 0, (n - 1) * is + 4)?
    };
    let per = c.curve_type.control_points();
    let mut segments = Vec::with_capacity(n);
    for s in 0..n {
        let first = u32_at(raw, s * is);
        if first as u64 + per as u64 > c.num_vertices as u64 {
            return Err(Error::invalid(format!(
                "curve segment {s} starts at control point {first} and needs {per} points, but the input has {} (segment indices must leave room for the segment)",
                c.num_vertices
            )));
        }
        segments.push(first);
    }
    Ok(DecodedCurves { points, segments })
}

/// Reads instances.
pub fn instances(ia: &InstanceArray, bytes: &dyn BufferBytes) -> Result<Vec<Instance>> {
    let n = ia.num_instances as usize;
    let raw = slice(bytes, &ia.instances, 0, n * Instance::SIZE as usize)?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let inst: Instance = bytemuck::pod_read_unaligned(&raw[i * 80..i * 80 + 80]);
        if !affine::is_finite(&inst.transform) {
            return Err(Error::invalid(format!(
                "instance {i} has a transform with NaN or infinite values: {:?}",
                inst.transform
            )));
        }
        if inst.flags & !optik_api::flags::InstanceFlags::ALL.0 != 0 {
            return Err(Error::invalid(format!(
                "instance {i} has unknown flag bits {:#x}",
                inst.flags & !optik_api::flags::InstanceFlags::ALL.0
            )));
        }
        out.push(inst);
    }
    Ok(out)
}

/// Reads micromap indices of a triangle input: per triangle, a micromap index or a special
/// (negative) index. `None` when the input has no micromap.
pub fn micromap_indices(
    t: &TriangleArray,
    num_micromaps: usize,
    bytes: &dyn BufferBytes,
) -> Result<Option<Vec<i32>>> {
    let Some(omm) = &t.opacity_micromap else {
        return Ok(None);
    };
    let n = t.num_primitives() as usize;
    let mut out = Vec::with_capacity(n);
    let raw = match &omm.index_buffer {
        Some(ib) if n > 0 => {
            let size = omm.index_size_in_bytes as usize;
            let stride = if omm.index_stride == 0 {
                size
            } else {
                omm.index_stride as usize
            };
            Some((slice(bytes, ib, 0, (n - 1) * stride + size)?, size, stride))
        }
        _ => None,
    };
    for i in 0..n {
        let v: i32 = match raw {
            Some((b, 2, stride)) => u16_at(b, i * stride) as i16 as i32,
            Some((b, _, stride)) => u32_at(b, i * stride) as i32,
            None => i as i32,
        };
        let v = if v < 0 { v } else { v + omm.base_index as i32 };
        if v < -4 || v >= num_micromaps as i32 {
            return Err(Error::invalid(format!(
                "triangle {i} uses micromap index {v}, but the array holds {num_micromaps} micromaps (special indices are -1..-4)"
            )));
        }
        out.push(v);
    }
    Ok(Some(out))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Bytes, buffer};
    use optik_api::flags::GeometryFlags;

    /// `count` triangles over 3 vertices (buffer 0; indices in buffer 1), with the triangles
    /// of `bad` using vertex 7.
    fn input(count: u32, bad: &[u32]) -> (TriangleArray, Bytes) {
        let vertices: Vec<u8> = (0..9).flat_map(|i| (i as f32).to_le_bytes()).collect();
        let indices: Vec<u8> = (0..count)
            .flat_map(|t| {
                let last = if bad.contains(&t) { 7u32 } else { 2 };
                [0u32, 1, last].into_iter().flat_map(u32::to_le_bytes)
            })
            .collect();
        let t = TriangleArray::new(BufferView::new(buffer(0)), 3, GeometryFlags::DISABLE_ANYHIT)
            .with_indices(BufferView::new(buffer(1)), count);
        (t, Bytes(vec![vertices, indices]))
    }

    #[test]
    fn triangles_decode_in_order_on_any_pool() {
        let (t, bytes) = input(50_000, &[]);
        let d = triangles(&t, 0, &bytes).unwrap();
        assert_eq!(
            d.vertices,
            [[0.0, 1.0, 2.0], [3.0, 4.0, 5.0], [6.0, 7.0, 8.0]]
        );
        assert_eq!(d.indices.len(), 50_000);
        assert!(d.indices.iter().all(|&i| i == [0, 1, 2]));
    }

    #[test]
    fn the_first_triangle_with_an_index_past_the_vertices_is_named() {
        // Decoded by several threads: the error still names the first bad triangle, as a
        // serial check would, not whichever thread found one first.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        for bad in [vec![3], vec![40_000, 7, 45_000], vec![49_999]] {
            let (t, bytes) = input(50_000, &bad);
            let e = pool
                .install(|| triangles(&t, 0, &bytes))
                .unwrap_err()
                .to_string();
            let first = bad.iter().min().unwrap();
            assert!(
                e.contains(&format!("triangle {first} has vertex index 7"))
                    && e.contains("3 vertices"),
                "{e}"
            );
        }
    }
}
