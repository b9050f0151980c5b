//! Backend-independent scene descriptions: what a case builds, once for the oracle and once
//! on every device (`device_run`). Geometry is kept as the `f32` values the device receives,
//! so the oracle sees exactly the numbers the backends see.

use optik::{
    BuildFlags, CurveEndcaps, GeometryFlags, IndexFormat, InstanceFlags, Matrix3x4, MotionOptions,
    SrtData, VertexFormat,
};

/// Index of a node in [`Scene::nodes`].
pub type NodeId = usize;

/// A scene: traversables in build order (children before parents).
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// The nodes; a node may name only earlier nodes as children.
    pub nodes: Vec<Node>,
}

impl Scene {
    /// Appends a node and returns its id.
    pub fn add(&mut self, node: Node) -> NodeId {
        self.nodes.push(node);
        self.nodes.len() - 1
    }

    /// A scene of one geometry acceleration structure; its id is 0.
    pub fn single(gas: Gas) -> (Scene, NodeId) {
        let mut s = Scene::default();
        let id = s.add(Node::Gas(gas));
        (s, id)
    }

    /// Checks that children come before parents; the message names the offending node.
    pub fn check(&self) -> Result<(), String> {
        for (id, node) in self.nodes.iter().enumerate() {
            let children: Vec<NodeId> = match node {
                Node::Gas(_) => vec![],
                Node::Ias(instances) => instances.iter().filter_map(|i| i.child).collect(),
                Node::Transform(t) => vec![t.child],
            };
            if let Some(c) = children.iter().find(|c| **c >= id) {
                return Err(format!(
                    "scene node {id} names node {c} as a child; children must come first"
                ));
            }
        }
        Ok(())
    }
}

/// A traversable.
#[derive(Clone, Debug)]
pub enum Node {
    /// A geometry acceleration structure.
    Gas(Gas),
    /// An instance acceleration structure.
    Ias(Vec<InstanceDesc>),
    /// A static or motion transform over a child.
    Transform(TransformNode),
}

/// A geometry acceleration structure: build inputs of one primitive type.
#[derive(Clone, Debug, Default)]
pub struct Gas {
    /// The build inputs, in order (their SBT records are numbered in this order).
    pub inputs: Vec<GeomInput>,
    /// Motion keys of the build; `None` for static geometry.
    pub motion: Option<MotionOptions>,
    /// Build flags.
    pub build_flags: BuildFlags,
    /// Build first from these inputs with `ALLOW_UPDATE`, then refit to `inputs`
    /// (`as.empty_null_update_compact`).
    pub update_from: Option<Vec<GeomInput>>,
    /// Compact after building and use the compacted copy.
    pub compact: bool,
}

impl Gas {
    /// A static structure of these inputs.
    pub fn new(inputs: Vec<GeomInput>) -> Self {
        Gas {
            inputs,
            ..Default::default()
        }
    }
}

/// One build input.
#[derive(Clone, Debug)]
pub enum GeomInput {
    /// Triangles.
    Triangles(Triangles),
    /// Custom primitives.
    Aabbs(Aabbs),
    /// Built-in spheres.
    Spheres(Spheres),
    /// Built-in round linear curves.
    Curves(Curves),
}

impl GeomInput {
    /// Number of SBT records this input spans.
    pub fn num_records(&self) -> u32 {
        match self {
            GeomInput::Triangles(t) => t.flags.len() as u32,
            GeomInput::Aabbs(a) => a.flags.len() as u32,
            GeomInput::Spheres(s) => s.flags.len() as u32,
            GeomInput::Curves(_) => 1,
        }
    }

    /// Number of primitives.
    pub fn num_primitives(&self) -> usize {
        match self {
            GeomInput::Triangles(t) => t.num_triangles(),
            GeomInput::Aabbs(a) => a.keys.first().map_or(0, |k| k.len()),
            GeomInput::Spheres(s) => s.centres.first().map_or(0, |k| k.len()),
            GeomInput::Curves(c) => c.segments.len(),
        }
    }
}

/// Per-primitive SBT record offsets (OptiX `sbtIndexOffsetBuffer`).
#[derive(Clone, Debug)]
pub struct SbtOffsets {
    /// One offset per primitive.
    pub offsets: Vec<u32>,
    /// Bytes per stored offset: 1, 2 or 4.
    pub size_in_bytes: u32,
    /// Bytes between offsets; 0 means packed.
    pub stride: u32,
}

/// Triangles.
#[derive(Clone, Debug)]
pub struct Triangles {
    /// Vertex positions, one array per motion key (exactly representable in `format`).
    pub keys: Vec<Vec<[f32; 3]>>,
    /// How vertices are stored on the device.
    pub format: VertexFormat,
    /// Bytes between vertices; 0 means packed.
    pub vertex_stride: u32,
    /// Index triples and their storage; `None`: vertices `3i, 3i+1, 3i+2`.
    pub indices: Option<(Vec<[u32; 3]>, IndexFormat, u32)>,
    /// One flag set per SBT record.
    pub flags: Vec<GeometryFlags>,
    /// Which record each triangle uses.
    pub sbt_offsets: Option<SbtOffsets>,
    /// Added to reported primitive indices.
    pub prim_index_offset: u32,
    /// 3×4 transform applied to the vertices at build time.
    pub pre_transform: Option<Matrix3x4>,
    /// Opacity micromaps (subdivision level 0: one state per micromap).
    pub omm: Option<Omm>,
}

/// Opacity micromaps of a triangle input at subdivision level 0.
#[derive(Clone, Debug)]
pub struct Omm {
    /// Two- or four-state micromaps.
    pub format: optik::OpacityMicromapFormat,
    /// The state of each micromap (0 transparent, 1 opaque, 2 unknown-transparent, 3
    /// unknown-opaque).
    pub states: Vec<u8>,
    /// Per triangle: a micromap index, or a special index −1..−4.
    pub indices: Vec<i32>,
}

impl Triangles {
    /// Unindexed `Float3` triangles (three vertices per triangle) with one SBT record.
    pub fn soup(vertices: Vec<[f32; 3]>, flags: GeometryFlags) -> Self {
        Triangles {
            keys: vec![vertices],
            format: VertexFormat::Float3,
            vertex_stride: 0,
            indices: None,
            flags: vec![flags],
            sbt_offsets: None,
            prim_index_offset: 0,
            pre_transform: None,
            omm: None,
        }
    }

    /// An indexed `Float3` mesh with `U32x3` indices and one SBT record.
    pub fn mesh(vertices: Vec<[f32; 3]>, indices: Vec<[u32; 3]>, flags: GeometryFlags) -> Self {
        Triangles {
            indices: Some((indices, IndexFormat::U32x3, 0)),
            ..Triangles::soup(vertices, flags)
        }
    }

    /// Number of triangles.
    pub fn num_triangles(&self) -> usize {
        match &self.indices {
            Some((i, _, _)) => i.len(),
            None => self.keys.first().map_or(0, |k| k.len() / 3),
        }
    }

    /// The vertex indices of triangle `i`.
    pub fn triangle(&self, i: usize) -> [usize; 3] {
        match &self.indices {
            Some((idx, _, _)) => idx[i].map(|v| v as usize),
            None => [3 * i, 3 * i + 1, 3 * i + 2],
        }
    }
}

/// Custom primitives: boxes an intersection program tests.
#[derive(Clone, Debug)]
pub struct Aabbs {
    /// `min.xyz, max.xyz` per primitive, one array per motion key.
    pub keys: Vec<Vec<[f32; 6]>>,
    /// One flag set per SBT record.
    pub flags: Vec<GeometryFlags>,
    /// Which record each primitive uses.
    pub sbt_offsets: Option<SbtOffsets>,
    /// Added to reported primitive indices.
    pub prim_index_offset: u32,
}

impl Aabbs {
    /// Static boxes with one SBT record.
    pub fn new(boxes: Vec<[f32; 6]>, flags: GeometryFlags) -> Self {
        Aabbs {
            keys: vec![boxes],
            flags: vec![flags],
            sbt_offsets: None,
            prim_index_offset: 0,
        }
    }
}

/// Built-in spheres.
#[derive(Clone, Debug)]
pub struct Spheres {
    /// Centres, one array per motion key.
    pub centres: Vec<Vec<[f32; 3]>>,
    /// Radii, one array per motion key (one value when `single_radius`).
    pub radii: Vec<Vec<f32>>,
    /// Every sphere uses the first radius.
    pub single_radius: bool,
    /// One flag set per SBT record.
    pub flags: Vec<GeometryFlags>,
    /// Which record each sphere uses.
    pub sbt_offsets: Option<SbtOffsets>,
    /// Added to reported primitive indices.
    pub prim_index_offset: u32,
}

/// Built-in round linear curves of constant radius per control point.
#[derive(Clone, Debug)]
pub struct Curves {
    /// Control points, one array per motion key.
    pub points: Vec<Vec<[f32; 3]>>,
    /// Radius per control point, one array per motion key.
    pub radii: Vec<Vec<f32>>,
    /// Per segment, the index of its first control point.
    pub segments: Vec<u32>,
    /// The input's geometry flags.
    pub flag: GeometryFlags,
    /// End caps.
    pub endcaps: CurveEndcaps,
    /// Added to reported primitive indices.
    pub prim_index_offset: u32,
}

/// One instance of an instance acceleration structure.
#[derive(Clone, Debug)]
pub struct InstanceDesc {
    /// Object-to-world, 3×4 row-major.
    pub transform: Matrix3x4,
    /// `rt_instance_id`.
    pub id: u32,
    /// Added to hit SBT record indices.
    pub sbt_offset: u32,
    /// Visibility mask.
    pub mask: u32,
    /// Instance flags.
    pub flags: InstanceFlags,
    /// The child; `None` is the null traversable.
    pub child: Option<NodeId>,
}

impl InstanceDesc {
    /// An identity instance of `child` with id 0, offset 0, mask 0xFF and no flags.
    pub fn of(child: NodeId) -> Self {
        InstanceDesc {
            transform: optik::IDENTITY_3X4,
            id: 0,
            sbt_offset: 0,
            mask: 0xFF,
            flags: InstanceFlags::NONE,
            child: Some(child),
        }
    }

    /// The same instance with a transform.
    pub fn at(mut self, transform: Matrix3x4) -> Self {
        self.transform = transform;
        self
    }
}

/// A transform traversable.
#[derive(Clone, Debug)]
pub struct TransformNode {
    /// What kind and its data.
    pub kind: TransformKind,
    /// The transformed child.
    pub child: NodeId,
}

/// The kinds of transform traversables.
#[derive(Clone, Debug)]
pub enum TransformKind {
    /// A fixed object-to-world matrix (its inverse is computed when built).
    Static(Matrix3x4),
    /// Matrix keys, linearly interpolated.
    MatrixMotion(MotionOptions, Vec<Matrix3x4>),
    /// SRT keys, nlerp-interpolated.
    SrtMotion(MotionOptions, Vec<SrtData>),
}

/// Encodes one vertex in a vertex format (little-endian), the inverse of what a device decodes.
pub fn encode_vertex(format: VertexFormat, v: [f32; 3]) -> Vec<u8> {
    use exr::prelude::f16;
    let snorm = |x: f32| ((x.clamp(-1.0, 1.0) * 32767.0).round() as i16).to_le_bytes();
    let half = |x: f32| f16::from_f32(x).to_bits().to_le_bytes();
    match format {
        VertexFormat::Float3 => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
        VertexFormat::Float2 => v[..2].iter().flat_map(|x| x.to_le_bytes()).collect(),
        VertexFormat::Half3 => v.iter().flat_map(|x| half(*x)).collect(),
        VertexFormat::Half2 => v[..2].iter().flat_map(|x| half(*x)).collect(),
        VertexFormat::Snorm16x3 => v.iter().flat_map(|x| snorm(*x)).collect(),
        VertexFormat::Snorm16x2 => v[..2].iter().flat_map(|x| snorm(*x)).collect(),
    }
}

/// Decodes one vertex the way the API documents its formats (the oracle's own decoder:
/// `Float2`/`Half2`/`Snorm16x2` have z = 0, snorm is value / 32767 clamped to −1).
pub fn decode_vertex(format: VertexFormat, b: &[u8]) -> [f32; 3] {
    use exr::prelude::f16;
    let f = |i: usize| f32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]]);
    let h = |i: usize| f16::from_bits(u16::from_le_bytes([b[2 * i], b[2 * i + 1]])).to_f32();
    let s = |i: usize| (i16::from_le_bytes([b[2 * i], b[2 * i + 1]]) as f32 / 32767.0).max(-1.0);
    match format {
        VertexFormat::Float3 => [f(0), f(1), f(2)],
        VertexFormat::Float2 => [f(0), f(1), 0.0],
        VertexFormat::Half3 => [h(0), h(1), h(2)],
        VertexFormat::Half2 => [h(0), h(1), 0.0],
        VertexFormat::Snorm16x3 => [s(0), s(1), s(2)],
        VertexFormat::Snorm16x2 => [s(0), s(1), 0.0],
    }
}

/// The vertices of a triangle input as the device stores them: the given positions
/// round-tripped through the vertex format.
pub fn stored_vertices(t: &Triangles, key: usize) -> Vec<[f32; 3]> {
    t.keys[key]
        .iter()
        .map(|v| decode_vertex(t.format, &encode_vertex(t.format, *v)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_round_trip() {
        for format in [
            VertexFormat::Float3,
            VertexFormat::Half3,
            VertexFormat::Float2,
            VertexFormat::Half2,
        ] {
            let back = decode_vertex(format, &encode_vertex(format, [0.5, -0.25, 0.75]));
            assert_eq!(&back[..2], &[0.5, -0.25], "{format:?}");
            assert_eq!(
                encode_vertex(format, [0.0; 3]).len(),
                format.size() as usize
            );
        }
        for format in [VertexFormat::Snorm16x3, VertexFormat::Snorm16x2] {
            let back = decode_vertex(format, &encode_vertex(format, [0.5, -0.25, 0.75]));
            assert!(
                (back[0] - 0.5).abs() <= 1.0 / 32767.0 && (back[1] + 0.25).abs() <= 1.0 / 32767.0,
                "{back:?}"
            );
            assert_eq!(
                encode_vertex(format, [0.0; 3]).len(),
                format.size() as usize
            );
        }
        let ends = decode_vertex(
            VertexFormat::Snorm16x3,
            &encode_vertex(VertexFormat::Snorm16x3, [-1.0, 1.0, 0.0]),
        );
        assert_eq!(ends, [-1.0, 1.0, 0.0]);
    }

    #[test]
    fn children_come_first() {
        let mut s = Scene::default();
        let g = s.add(Node::Gas(Gas::default()));
        s.add(Node::Ias(vec![InstanceDesc::of(g)]));
        assert!(s.check().is_ok());
        s.add(Node::Ias(vec![InstanceDesc::of(5)]));
        assert!(s.check().unwrap_err().contains("children must come first"));
    }
}
