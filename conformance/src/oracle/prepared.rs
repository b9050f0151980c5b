//! The case's scene in the oracle's form: `f64` geometry decoded from the bytes the device
//! receives (vertex formats round-tripped, pre-transforms applied), instances with their
//! inverses, and the oracle's own traversable handles.

use super::math::*;
use crate::scene::{GeomInput, Node, NodeId, Scene, TransformKind, stored_vertices};
use optik::semantics::opacity::MicromapState;
use optik::{GeometryFlags, InstanceFlags, MotionOptions};

/// The high word of every oracle handle (the low word is node id + 1); 0:0 is null.
pub const HANDLE_TAG: u32 = 0x0C7A_0000;

/// The oracle's handle words for a node (or the null handle).
pub fn handle_words(node: Option<NodeId>) -> [u32; 2] {
    match node {
        Some(n) => [n as u32 + 1, HANDLE_TAG],
        None => [0, 0],
    }
}

/// The node an oracle handle names; `None` for the null handle or foreign values.
pub fn node_of(words: [u32; 2], node_count: usize) -> Option<NodeId> {
    (words[1] == HANDLE_TAG && words[0] >= 1 && (words[0] as usize) <= node_count)
        .then(|| words[0] as usize - 1)
}

/// Geometry of one build input.
#[derive(Clone, Debug)]
pub enum Prims {
    /// Vertex keys and index triples.
    Triangles {
        /// Vertices per motion key.
        keys: Vec<Vec<V3>>,
        /// Vertex indices per triangle (`None` when an index is out of range).
        tris: Vec<Option<[usize; 3]>>,
        /// Opacity micromap state per triangle, when the input has micromaps.
        omm: Option<Vec<MicromapState>>,
    },
    /// Boxes per motion key.
    Aabbs(Vec<Vec<[f64; 6]>>),
    /// Centres and radii per key.
    Spheres {
        /// Centres per key.
        centres: Vec<Vec<V3>>,
        /// Radii per key.
        radii: Vec<Vec<f64>>,
        /// One radius for all.
        single: bool,
    },
    /// Capsules: control points and radii per key, segment starts.
    Curves {
        /// Points per key.
        points: Vec<Vec<V3>>,
        /// Radii per key.
        radii: Vec<Vec<f64>>,
        /// First control point of each segment.
        segments: Vec<u32>,
    },
}

/// One build input.
#[derive(Clone, Debug)]
pub struct Input {
    /// Its primitives.
    pub prims: Prims,
    /// Its first SBT GAS index.
    pub first_record: u32,
    /// Flags per record.
    pub flags: Vec<GeometryFlags>,
    /// Record offset per primitive.
    pub offsets: Vec<u32>,
    /// Added to reported primitive indices.
    pub prim_index_offset: u32,
    /// Number of primitives.
    pub count: usize,
}

/// A geometry acceleration structure.
#[derive(Clone, Debug)]
pub struct GasData {
    /// Its inputs.
    pub inputs: Vec<Input>,
    /// Motion options when it has two or more keys.
    pub motion: Option<MotionOptions>,
    /// Largest coordinate magnitude (for motion rounding bands).
    pub magnitude: f64,
}

/// An instance.
#[derive(Clone, Debug)]
pub struct InstanceData {
    /// Object-to-world.
    pub o2w: M34,
    /// World-to-object (`None`: singular transform, never traversed).
    pub w2o: Option<M34>,
    /// User id.
    pub id: u32,
    /// SBT offset.
    pub sbt_offset: u32,
    /// Visibility mask.
    pub mask: u32,
    /// Flags.
    pub flags: InstanceFlags,
    /// The child.
    pub child: Option<NodeId>,
}

/// A prepared node.
#[derive(Clone, Debug)]
pub enum PNode {
    /// Geometry.
    Gas(GasData),
    /// Instances.
    Ias(Vec<InstanceData>),
    /// A transform (kept in the case's `f32` form: interpolation is the spec's, in `f32`).
    Transform(TransformKind, NodeId),
}

fn to_v3(v: [f32; 3]) -> V3 {
    from_f32(v)
}

fn offsets(o: &Option<crate::scene::SbtOffsets>, count: usize) -> Vec<u32> {
    match o {
        Some(o) => o.offsets.clone(),
        None => vec![0; count],
    }
}

/// Prepares the scene for the oracle.
pub fn prepare(scene: &Scene) -> Vec<PNode> {
    scene
        .nodes
        .iter()
        .map(|node| match node {
            Node::Gas(g) => {
                let mut first = 0u32;
                let mut magnitude: f64 = 0.0;
                let inputs = g
                    .inputs
                    .iter()
                    .map(|input| {
                        let count = input.num_primitives();
                        let prims = match input {
                            GeomInput::Triangles(t) => {
                                let keys: Vec<Vec<V3>> = (0..t.keys.len())
                                    .map(|k| {
                                        stored_vertices(t, k)
                                            .into_iter()
                                            .map(|v| match &t.pre_transform {
                                                // Applied at build time in f32 by the device;
                                                // here exactly, then rounded to f32.
                                                Some(m) => {
                                                    let p = m_point(&m_from_f32(m), to_v3(v));
                                                    p.map(|c| c as f32 as f64)
                                                }
                                                None => to_v3(v),
                                            })
                                            .collect()
                                    })
                                    .collect();
                                let n = keys.first().map_or(0, |k| k.len());
                                let tris = (0..t.num_triangles())
                                    .map(|i| {
                                        let tri = t.triangle(i);
                                        tri.iter().all(|v| *v < n).then_some(tri)
                                    })
                                    .collect();
                                for k in &keys {
                                    for v in k {
                                        if v.iter().all(|c| c.is_finite()) {
                                            magnitude = magnitude.max(max_abs(*v));
                                        }
                                    }
                                }
                                let omm = t.omm.as_ref().map(|o| {
                                    o.indices
                                        .iter()
                                        .map(|i| match *i {
                                            -1 => MicromapState::Transparent,
                                            -2 => MicromapState::Opaque,
                                            -3 => MicromapState::UnknownTransparent,
                                            -4 => MicromapState::UnknownOpaque,
                                            i => MicromapState::from_code(
                                                o.states.get(i as usize).copied().unwrap_or(0)
                                                    as u32,
                                            ),
                                        })
                                        .collect()
                                });
                                Prims::Triangles { keys, tris, omm }
                            }
                            GeomInput::Aabbs(a) => Prims::Aabbs(
                                a.keys
                                    .iter()
                                    .map(|k| k.iter().map(|b| b.map(|c| c as f64)).collect())
                                    .collect(),
                            ),
                            GeomInput::Spheres(s) => Prims::Spheres {
                                centres: s
                                    .centres
                                    .iter()
                                    .map(|k| k.iter().map(|c| to_v3(*c)).collect())
                                    .collect(),
                                radii: s
                                    .radii
                                    .iter()
                                    .map(|k| k.iter().map(|r| *r as f64).collect())
                                    .collect(),
                                single: s.single_radius,
                            },
                            GeomInput::Curves(c) => Prims::Curves {
                                points: c
                                    .points
                                    .iter()
                                    .map(|k| k.iter().map(|p| to_v3(*p)).collect())
                                    .collect(),
                                radii: c
                                    .radii
                                    .iter()
                                    .map(|k| k.iter().map(|r| *r as f64).collect())
                                    .collect(),
                                segments: c.segments.clone(),
                            },
                        };
                        let (flags, offs, pio) = match input {
                            GeomInput::Triangles(t) => (
                                t.flags.clone(),
                                offsets(&t.sbt_offsets, count),
                                t.prim_index_offset,
                            ),
                            GeomInput::Aabbs(a) => (
                                a.flags.clone(),
                                offsets(&a.sbt_offsets, count),
                                a.prim_index_offset,
                            ),
                            GeomInput::Spheres(s) => (
                                s.flags.clone(),
                                offsets(&s.sbt_offsets, count),
                                s.prim_index_offset,
                            ),
                            GeomInput::Curves(c) => {
                                (vec![c.flag], vec![0; count], c.prim_index_offset)
                            }
                        };
                        let data = Input {
                            prims,
                            first_record: first,
                            flags,
                            offsets: offs,
                            prim_index_offset: pio,
                            count,
                        };
                        first += input.num_records();
                        data
                    })
                    .collect();
                PNode::Gas(GasData {
                    inputs,
                    motion: g.motion.filter(|m| m.num_keys >= 2),
                    magnitude,
                })
            }
            Node::Ias(instances) => PNode::Ias(
                instances
                    .iter()
                    .map(|i| {
                        let o2w = m_from_f32(&i.transform);
                        InstanceData {
                            o2w,
                            w2o: m_inverse(&o2w),
                            id: i.id,
                            sbt_offset: i.sbt_offset,
                            mask: i.mask,
                            flags: i.flags,
                            child: i.child,
                        }
                    })
                    .collect(),
            ),
            Node::Transform(t) => PNode::Transform(t.kind.clone(), t.child),
        })
        .collect()
}

/// Whether the scene has motion anywhere (for `uses_motion_blur: Auto`).
pub fn has_motion(scene: &Scene) -> bool {
    scene.nodes.iter().any(|n| match n {
        Node::Gas(g) => g.motion.is_some_and(|m| m.num_keys >= 2),
        Node::Transform(t) => !matches!(t.kind, TransformKind::Static(_)),
        Node::Ias(_) => false,
    })
}
