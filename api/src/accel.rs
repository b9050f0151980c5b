//! Acceleration structure build inputs, options and transforms (OptiX `OptixBuildInput*`,
//! `OptixAccelBuildOptions`, `Optix*Transform`).
//!
//! Geometry data lives in device [`Buffer`]s, as in OptiX. A build input names the buffers and
//! how to read them; `optik_core::validate` checks every size, stride and count against the
//! buffers before a backend reads anything.

use crate::flags::{BuildFlags, GeometryFlags, InstanceFlags, MotionFlags};
use crate::handle::{Buffer, MicromapArray};

/// A 64-bit handle to a traversable (OptiX `OptixTraversableHandle`), written into launch
/// parameters and instances. In WGSL it is a `vec2<u32>` (low word first). Zero is the null
/// handle: tracing against it misses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default, PartialOrd, Ord)]
#[repr(transparent)]
pub struct TraversableHandle(pub u64);

impl TraversableHandle {
    /// The null traversable: every ray against it misses.
    pub const NULL: Self = Self(0);

    /// The two 32-bit words a WGSL `vec2<u32>` holds, low word first.
    pub fn to_words(self) -> [u32; 2] {
        [self.0 as u32, (self.0 >> 32) as u32]
    }

    /// The handle from WGSL's `vec2<u32>` words.
    pub fn from_words(words: [u32; 2]) -> Self {
        Self(words[0] as u64 | ((words[1] as u64) << 32))
    }
}

/// A position in a buffer: where an array starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BufferView {
    /// The buffer.
    pub buffer: Buffer,
    /// Byte offset of the first element.
    pub offset: u64,
}

impl BufferView {
    /// The start of `buffer`.
    pub fn new(buffer: Buffer) -> Self {
        Self { buffer, offset: 0 }
    }

    /// `buffer` from byte `offset`.
    pub fn at(buffer: Buffer, offset: u64) -> Self {
        Self { buffer, offset }
    }
}

/// Vertex formats of triangle inputs (OptiX `OptixVertexFormat`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum VertexFormat {
    /// Three `f32` (x, y, z).
    #[default]
    Float3,
    /// Two `f32` (x, y); z = 0.
    Float2,
    /// Three IEEE half floats.
    Half3,
    /// Two IEEE half floats; z = 0.
    Half2,
    /// Three signed normalised 16-bit integers (value / 32767, clamped to -1).
    Snorm16x3,
    /// Two signed normalised 16-bit integers; z = 0.
    Snorm16x2,
}

impl VertexFormat {
    /// Bytes of one vertex when tightly packed (the stride used when a stride of 0 is given).
    pub fn size(self) -> u32 {
        match self {
            VertexFormat::Float3 => 12,
            VertexFormat::Float2 => 8,
            VertexFormat::Half3 => 6,
            VertexFormat::Half2 => 4,
            VertexFormat::Snorm16x3 => 6,
            VertexFormat::Snorm16x2 => 4,
        }
    }

    /// Alignment in bytes that the vertex stride and offset must have.
    pub fn alignment(self) -> u32 {
        match self {
            VertexFormat::Float3 | VertexFormat::Float2 => 4,
            _ => 2,
        }
    }
}

/// Index formats of triangle inputs (OptiX `OptixIndicesFormat`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum IndexFormat {
    /// Three `u16` per triangle.
    U16x3,
    /// Three `u32` per triangle.
    U32x3,
}

impl IndexFormat {
    /// Bytes of one triangle's indices when tightly packed.
    pub fn size(self) -> u32 {
        match self {
            IndexFormat::U16x3 => 6,
            IndexFormat::U32x3 => 12,
        }
    }

    /// Alignment of the index stride and offset.
    pub fn alignment(self) -> u32 {
        match self {
            IndexFormat::U16x3 => 2,
            IndexFormat::U32x3 => 4,
        }
    }
}

/// Per-primitive SBT record offsets of a build input (OptiX `sbtIndexOffsetBuffer`): primitive
/// `i` uses record `offsets[i]` of the input's `flags.len()` records.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SbtIndexOffsets {
    /// Where the offsets start.
    pub buffer: BufferView,
    /// Bytes per offset: 1, 2 or 4.
    pub size_in_bytes: u32,
    /// Bytes between offsets; 0 means `size_in_bytes`.
    pub stride: u32,
}

/// The index buffer of a triangle input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TriangleIndices {
    /// Where the indices start.
    pub buffer: BufferView,
    /// Index format.
    pub format: IndexFormat,
    /// Bytes between triangles; 0 means packed.
    pub stride: u32,
    /// Number of triangles.
    pub num_triangles: u32,
}

/// Opacity micromap indexing of a triangle input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TriangleOpacityMicromap {
    /// The micromap array built with `create_opacity_micromap_array`.
    pub array: MicromapArray,
    /// Per-triangle micromap indices; `None` uses `base_index + triangle index`.
    pub index_buffer: Option<BufferView>,
    /// Bytes per index: 2 or 4 (signed: negative values are the special indices).
    pub index_size_in_bytes: u32,
    /// Bytes between indices; 0 means `index_size_in_bytes`.
    pub index_stride: u32,
    /// Added to every index read (not to the special indices).
    pub base_index: u32,
}

/// Triangles (OptiX `OptixBuildInputTriangleArray`).
#[derive(Clone, Debug, PartialEq)]
pub struct TriangleArray {
    /// Vertex arrays, one per motion key (one when the build has no motion).
    pub vertex_buffers: Vec<BufferView>,
    /// Vertices per key.
    pub num_vertices: u32,
    /// How vertices are stored.
    pub vertex_format: VertexFormat,
    /// Bytes between vertices; 0 means packed.
    pub vertex_stride: u32,
    /// Index buffer; without one, vertices `3i, 3i+1, 3i+2` make triangle `i`.
    pub indices: Option<TriangleIndices>,
    /// One flag set per SBT record of this input; its length is the input's record count.
    pub flags: Vec<GeometryFlags>,
    /// Which record each primitive uses; required when `flags.len() > 1`.
    pub sbt_index_offsets: Option<SbtIndexOffsets>,
    /// Added to the primitive index reported to programs.
    pub primitive_index_offset: u32,
    /// An optional 3×4 row-major `f32` transform applied to the vertices at build time.
    pub pre_transform: Option<BufferView>,
    /// Opacity micromaps for these triangles.
    pub opacity_micromap: Option<TriangleOpacityMicromap>,
}

impl TriangleArray {
    /// An unindexed `Float3` array of `num_vertices` packed vertices with one SBT record.
    pub fn new(vertices: BufferView, num_vertices: u32, flags: GeometryFlags) -> Self {
        Self {
            vertex_buffers: vec![vertices],
            num_vertices,
            vertex_format: VertexFormat::Float3,
            vertex_stride: 0,
            indices: None,
            flags: vec![flags],
            sbt_index_offsets: None,
            primitive_index_offset: 0,
            pre_transform: None,
            opacity_micromap: None,
        }
    }

    /// The same input with a packed `U32x3` index buffer of `num_triangles` triangles.
    pub fn with_indices(mut self, indices: BufferView, num_triangles: u32) -> Self {
        self.indices = Some(TriangleIndices {
            buffer: indices,
            format: IndexFormat::U32x3,
            stride: 0,
            num_triangles,
        });
        self
    }

    /// Number of triangles.
    pub fn num_primitives(&self) -> u32 {
        match &self.indices {
            Some(i) => i.num_triangles,
            None => self.num_vertices / 3,
        }
    }

    /// Bytes between vertices after resolving a stride of 0.
    pub fn effective_vertex_stride(&self) -> u32 {
        if self.vertex_stride == 0 {
            self.vertex_format.size()
        } else {
            self.vertex_stride
        }
    }
}

/// Custom primitives given by their bounds (OptiX `OptixBuildInputCustomPrimitiveArray`);
/// an intersection program decides hits.
#[derive(Clone, Debug, PartialEq)]
pub struct CustomPrimitiveArray {
    /// AABB arrays (`min.xyz, max.xyz` as six `f32`), one per motion key.
    pub aabb_buffers: Vec<BufferView>,
    /// Number of primitives.
    pub num_primitives: u32,
    /// Bytes between AABBs; 0 means 24.
    pub stride: u32,
    /// One flag set per SBT record.
    pub flags: Vec<GeometryFlags>,
    /// Which record each primitive uses.
    pub sbt_index_offsets: Option<SbtIndexOffsets>,
    /// Added to the primitive index reported to programs.
    pub primitive_index_offset: u32,
}

impl CustomPrimitiveArray {
    /// Packed AABBs with one SBT record.
    pub fn new(aabbs: BufferView, num_primitives: u32, flags: GeometryFlags) -> Self {
        Self {
            aabb_buffers: vec![aabbs],
            num_primitives,
            stride: 0,
            flags: vec![flags],
            sbt_index_offsets: None,
            primitive_index_offset: 0,
        }
    }

    /// Bytes between AABBs after resolving a stride of 0.
    pub fn effective_stride(&self) -> u32 {
        if self.stride == 0 { 24 } else { self.stride }
    }
}

/// Spheres (OptiX `OptixBuildInputSphereArray`), intersected by the built-in sphere test.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereArray {
    /// Centre arrays (three `f32`), one per motion key.
    pub vertex_buffers: Vec<BufferView>,
    /// Bytes between centres; 0 means 12.
    pub vertex_stride: u32,
    /// Number of spheres.
    pub num_vertices: u32,
    /// Radius arrays (`f32`), one per motion key.
    pub radius_buffers: Vec<BufferView>,
    /// Bytes between radii; 0 means 4.
    pub radius_stride: u32,
    /// Every sphere uses the first radius.
    pub single_radius: bool,
    /// One flag set per SBT record.
    pub flags: Vec<GeometryFlags>,
    /// Which record each sphere uses.
    pub sbt_index_offsets: Option<SbtIndexOffsets>,
    /// Added to the primitive index reported to programs.
    pub primitive_index_offset: u32,
}

impl SphereArray {
    /// Bytes between centres after resolving a stride of 0.
    pub fn effective_vertex_stride(&self) -> u32 {
        if self.vertex_stride == 0 {
            12
        } else {
            self.vertex_stride
        }
    }

    /// Bytes between radii after resolving a stride of 0.
    pub fn effective_radius_stride(&self) -> u32 {
        if self.radius_stride == 0 {
            4
        } else {
            self.radius_stride
        }
    }
}

/// Curve bases (OptiX `OptixPrimitiveType` round curves).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CurveType {
    /// Linear segments between consecutive vertices, with round joints.
    RoundLinear,
    /// Uniform quadratic B-spline segments of 3 control points.
    RoundQuadraticBSpline,
    /// Uniform cubic B-spline segments of 4 control points.
    RoundCubicBSpline,
    /// Catmull-Rom segments of 4 control points.
    RoundCatmullRom,
}

impl CurveType {
    /// Control points per segment.
    pub fn control_points(self) -> u32 {
        match self {
            CurveType::RoundLinear => 2,
            CurveType::RoundQuadraticBSpline => 3,
            CurveType::RoundCubicBSpline | CurveType::RoundCatmullRom => 4,
        }
    }
}

/// Curve end caps (OptiX `OptixCurveEndcapFlags`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum CurveEndcaps {
    /// Open ends (OptiX default for non-linear curves).
    #[default]
    Default,
    /// Round caps at the ends of the strand.
    On,
}

/// Curves (OptiX `OptixBuildInputCurveArray`): one SBT record per input.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveArray {
    /// The basis.
    pub curve_type: CurveType,
    /// Number of segments.
    pub num_primitives: u32,
    /// Control point arrays (three `f32`), one per motion key.
    pub vertex_buffers: Vec<BufferView>,
    /// Control points per key.
    pub num_vertices: u32,
    /// Bytes between control points; 0 means 12.
    pub vertex_stride: u32,
    /// Radius arrays (`f32` per control point), one per motion key.
    pub width_buffers: Vec<BufferView>,
    /// Bytes between radii; 0 means 4.
    pub width_stride: u32,
    /// Per segment, the `u32` index of its first control point.
    pub index_buffer: BufferView,
    /// Bytes between segment indices; 0 means 4.
    pub index_stride: u32,
    /// The input's single geometry flag set.
    pub flag: GeometryFlags,
    /// Added to the primitive index reported to programs.
    pub primitive_index_offset: u32,
    /// End caps.
    pub endcaps: CurveEndcaps,
}

/// One instance of an instance acceleration structure, in OptiX's 80-byte layout
/// (`OptixInstance`): write these into a buffer for an [`InstanceArray`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Instance {
    /// Object-to-world transform, 3×4 row-major.
    pub transform: [f32; 12],
    /// User id (`rt_instance_id`); the low 28 bits count.
    pub instance_id: u32,
    /// Added to the SBT record index of hits inside the instance.
    pub sbt_offset: u32,
    /// Visibility mask; the low 8 bits count against the ray's mask.
    pub visibility_mask: u32,
    /// [`InstanceFlags`] bits.
    pub flags: u32,
    /// The child traversable.
    pub traversable_handle: u64,
    /// Padding to 80 bytes.
    pub pad: [u32; 2],
}

impl Instance {
    /// Bytes per instance.
    pub const SIZE: u32 = 80;
    /// Required alignment of instance buffers.
    pub const ALIGNMENT: u32 = 16;

    /// An instance of `child` with the identity transform, mask 0xFF and no flags.
    pub fn new(child: TraversableHandle) -> Self {
        Self {
            transform: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            instance_id: 0,
            sbt_offset: 0,
            visibility_mask: 0xFF,
            flags: 0,
            traversable_handle: child.0,
            pad: [0; 2],
        }
    }

    /// The flags as a typed set.
    pub fn instance_flags(&self) -> InstanceFlags {
        InstanceFlags(self.flags)
    }

    /// The 80 bytes to write into an instance buffer (the host's byte order: little-endian
    /// on every platform optik's backends run on).
    pub fn as_bytes(&self) -> &[u8] {
        bytemuck::bytes_of(self)
    }
}

/// Instances (OptiX `OptixBuildInputInstanceArray`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InstanceArray {
    /// Where the [`Instance`] records start (16-byte aligned).
    pub instances: BufferView,
    /// Number of instances.
    pub num_instances: u32,
}

/// One build input.
#[derive(Clone, Debug, PartialEq)]
pub enum BuildInput {
    /// Triangles.
    Triangles(TriangleArray),
    /// Custom primitives.
    CustomPrimitives(CustomPrimitiveArray),
    /// Spheres.
    Spheres(SphereArray),
    /// Curves.
    Curves(CurveArray),
    /// Instances (builds an instance acceleration structure).
    Instances(InstanceArray),
}

impl BuildInput {
    /// A short name for messages.
    pub fn kind_name(&self) -> &'static str {
        match self {
            BuildInput::Triangles(_) => "triangles",
            BuildInput::CustomPrimitives(_) => "custom primitives",
            BuildInput::Spheres(_) => "spheres",
            BuildInput::Curves(_) => "curves",
            BuildInput::Instances(_) => "instances",
        }
    }

    /// Number of primitives (or instances).
    pub fn num_primitives(&self) -> u32 {
        match self {
            BuildInput::Triangles(t) => t.num_primitives(),
            BuildInput::CustomPrimitives(c) => c.num_primitives,
            BuildInput::Spheres(s) => s.num_vertices,
            BuildInput::Curves(c) => c.num_primitives,
            BuildInput::Instances(i) => i.num_instances,
        }
    }

    /// Number of SBT records the input spans (its `sbt_gas_index` range).
    pub fn num_sbt_records(&self) -> u32 {
        match self {
            BuildInput::Triangles(t) => t.flags.len() as u32,
            BuildInput::CustomPrimitives(c) => c.flags.len() as u32,
            BuildInput::Spheres(s) => s.flags.len() as u32,
            BuildInput::Curves(_) => 1,
            BuildInput::Instances(_) => 0,
        }
    }

    /// Number of motion keys the input provides.
    pub fn num_motion_keys(&self) -> usize {
        match self {
            BuildInput::Triangles(t) => t.vertex_buffers.len(),
            BuildInput::CustomPrimitives(c) => c.aabb_buffers.len(),
            BuildInput::Spheres(s) => s.vertex_buffers.len(),
            BuildInput::Curves(c) => c.vertex_buffers.len(),
            BuildInput::Instances(_) => 1,
        }
    }
}

/// Motion options of a build or a motion transform (OptiX `OptixMotionOptions`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionOptions {
    /// Number of keys, evenly spaced from `time_begin` to `time_end`; at least 2 for motion.
    pub num_keys: u16,
    /// Vanish flags.
    pub flags: MotionFlags,
    /// Time of the first key.
    pub time_begin: f32,
    /// Time of the last key.
    pub time_end: f32,
}

/// Whether a build creates a new structure or refits an existing one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BuildOperation {
    /// Build from scratch.
    #[default]
    Build,
    /// Refit a structure built with [`BuildFlags::ALLOW_UPDATE`] to moved geometry (same
    /// topology, same counts).
    Update,
}

/// Options of an acceleration structure build (OptiX `OptixAccelBuildOptions`).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct AccelBuildOptions {
    /// Build flags.
    pub flags: BuildFlags,
    /// Build or update.
    pub operation: BuildOperation,
    /// Motion keys; `None` or `num_keys < 2` means a static structure.
    pub motion: Option<MotionOptions>,
}

/// Sizes a build needs (OptiX `OptixAccelBufferSizes`), reported by `accel_memory_usage`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct AccelBufferSizes {
    /// Bytes of the built structure.
    pub output_size_in_bytes: u64,
    /// Bytes of temporary memory for a build.
    pub temp_size_in_bytes: u64,
    /// Bytes of temporary memory for an update.
    pub temp_update_size_in_bytes: u64,
}

/// A 3×4 row-major affine matrix, as in OptiX's transforms.
pub type Matrix3x4 = [f32; 12];

/// The identity [`Matrix3x4`].
pub const IDENTITY_3X4: Matrix3x4 = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];

/// One SRT motion key (OptiX `OptixSRTData`), in OptiX's field order. The transform is
/// `T · R · S` where S holds scale, shear and pivot, R is the unit quaternion and T the
/// translation.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SrtData {
    /// Scale x.
    pub sx: f32,
    /// Shear xy.
    pub a: f32,
    /// Shear xz.
    pub b: f32,
    /// Pivot x.
    pub pvx: f32,
    /// Scale y.
    pub sy: f32,
    /// Shear yz.
    pub c: f32,
    /// Pivot y.
    pub pvy: f32,
    /// Scale z.
    pub sz: f32,
    /// Pivot z.
    pub pvz: f32,
    /// Quaternion x.
    pub qx: f32,
    /// Quaternion y.
    pub qy: f32,
    /// Quaternion z.
    pub qz: f32,
    /// Quaternion w.
    pub qw: f32,
    /// Translation x.
    pub tx: f32,
    /// Translation y.
    pub ty: f32,
    /// Translation z.
    pub tz: f32,
}

impl SrtData {
    /// The identity key (unit scale, identity rotation, no translation).
    pub fn identity() -> Self {
        Self {
            sx: 1.0,
            sy: 1.0,
            sz: 1.0,
            qw: 1.0,
            ..Default::default()
        }
    }
}

/// A transform traversable (OptiX static, matrix-motion and SRT-motion transforms), created
/// with `Device::create_transform`.
#[derive(Clone, Debug, PartialEq)]
pub enum TransformDesc {
    /// A fixed transform and its inverse (OptiX `OptixStaticTransform`).
    Static {
        /// The transformed traversable.
        child: TraversableHandle,
        /// Object-to-world.
        object_to_world: Matrix3x4,
        /// World-to-object; must be the inverse of `object_to_world`.
        world_to_object: Matrix3x4,
    },
    /// Keys of 3×4 matrices, interpolated linearly (OptiX `OptixMatrixMotionTransform`).
    MatrixMotion {
        /// The transformed traversable.
        child: TraversableHandle,
        /// Key count, time range and vanish flags.
        motion: MotionOptions,
        /// `motion.num_keys` object-to-world matrices.
        keys: Vec<Matrix3x4>,
    },
    /// Keys of scale/rotation/translation, interpolated with normalised quaternion lerp
    /// (OptiX `OptixSRTMotionTransform`).
    SrtMotion {
        /// The transformed traversable.
        child: TraversableHandle,
        /// Key count, time range and vanish flags.
        motion: MotionOptions,
        /// `motion.num_keys` keys.
        keys: Vec<SrtData>,
    },
}

impl TransformDesc {
    /// The child traversable.
    pub fn child(&self) -> TraversableHandle {
        match self {
            TransformDesc::Static { child, .. }
            | TransformDesc::MatrixMotion { child, .. }
            | TransformDesc::SrtMotion { child, .. } => *child,
        }
    }
}

/// Opacity micromap formats (OptiX `OptixOpacityMicromapFormat`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OpacityMicromapFormat {
    /// One bit per micro-triangle: 0 transparent, 1 opaque.
    TwoState,
    /// Two bits per micro-triangle: 0 transparent, 1 opaque, 2 unknown-transparent,
    /// 3 unknown-opaque.
    FourState,
}

/// One micromap of an array (OptiX `OptixOpacityMicromapDesc`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct OpacityMicromapDesc {
    /// Byte offset of the micromap's states in the array's data.
    pub byte_offset: u32,
    /// Subdivision level, 0..=12: the triangle splits into `4^level` micro-triangles.
    pub subdivision_level: u16,
    /// The format of the states.
    pub format: OpacityMicromapFormat,
}

/// An opacity micromap array to build (OptiX `OptixOpacityMicromapArrayBuildInput`). States
/// are packed in micro-triangle order (OptiX's space-filling order), the lowest bits first.
#[derive(Clone, Debug, PartialEq)]
pub struct OpacityMicromapArrayDesc {
    /// The micromaps.
    pub micromaps: Vec<OpacityMicromapDesc>,
    /// The packed states all micromaps index into.
    pub data: Vec<u8>,
}

/// Opacity micromap special indices (OptiX `OPTIX_OPACITY_MICROMAP_PREDEFINED_INDEX_*`).
pub mod micromap_special_index {
    /// The whole triangle is transparent.
    pub const FULLY_TRANSPARENT: i32 = -1;
    /// The whole triangle is opaque.
    pub const FULLY_OPAQUE: i32 = -2;
    /// The whole triangle is unknown-transparent.
    pub const FULLY_UNKNOWN_TRANSPARENT: i32 = -3;
    /// The whole triangle is unknown-opaque.
    pub const FULLY_UNKNOWN_OPAQUE: i32 = -4;
}

/// Largest opacity micromap subdivision level.
pub const MAX_MICROMAP_SUBDIVISION_LEVEL: u16 = 12;
