//! Validation shared by every backend.
//!
//! Each check returns an [`Error`] that names the argument, the value and what was expected.
//! Backends call these before touching any data, so a bad input is reported the same way on
//! every backend and nothing is half-built.

use crate::frontend::{BindingInfo, BindingKind};
use optik_api::accel::{
    AccelBuildOptions, BuildInput, BuildOperation, Instance, MAX_MICROMAP_SUBDIVISION_LEVEL,
    MotionOptions, OpacityMicromapArrayDesc, OpacityMicromapFormat, SbtIndexOffsets, TransformDesc,
};
use optik_api::device::DeviceProperties;
use optik_api::error::{Error, Result};
use optik_api::handle::Buffer;
use optik_api::launch::{LaunchSize, Resource, TextureDesc};
use optik_api::sbt::{SBT_RECORD_ALIGNMENT, SBT_RECORD_HEADER_SIZE, SbtRegion, ShaderBindingTable};
use optik_api::semantics::{affine, motion};

/// Looks up buffer sizes (and checks the handles) for validation.
pub trait BufferSizes {
    /// The size of `buffer`, or the handle's error.
    fn size_of(&self, buffer: Buffer) -> Result<u64>;
}

impl<F: Fn(Buffer) -> Result<u64>> BufferSizes for F {
    fn size_of(&self, buffer: Buffer) -> Result<u64> {
        self(buffer)
    }
}

/// Checks that `len` bytes from `offset` lie inside `buffer`.
pub fn buffer_range(
    what: &str,
    buffer: Buffer,
    offset: u64,
    len: u64,
    sizes: &dyn BufferSizes,
) -> Result<()> {
    let size = sizes.size_of(buffer).map_err(|e| e.context(what))?;
    let end = offset.checked_add(len);
    match end {
        Some(end) if end <= size => Ok(()),
        _ => Err(Error::invalid(format!(
            "{what}: bytes {offset}..{} lie outside the buffer of {size} bytes (need {len} bytes from offset {offset})",
            offset as u128 + len as u128
        ))),
    }
}

fn aligned(what: &str, value: u64, alignment: u64) -> Result<()> {
    if !value.is_multiple_of(alignment) {
        return Err(Error::invalid(format!(
            "{what} is {value}; it must be a multiple of {alignment}"
        )));
    }
    Ok(())
}

/// Bytes an array of `count` elements of `elem` bytes at `stride` spans.
fn array_bytes(count: u32, stride: u32, elem: u32) -> u64 {
    if count == 0 {
        0
    } else {
        (count as u64 - 1) * stride as u64 + elem as u64
    }
}

/// Checks build options and inputs; returns the number of motion keys (1 for static).
pub fn build_inputs(
    options: &AccelBuildOptions,
    inputs: &[BuildInput],
    props: &DeviceProperties,
    sizes: &dyn BufferSizes,
) -> Result<usize> {
    if inputs.is_empty() {
        return Err(Error::invalid(
            "build inputs are empty; give at least one input (an input may hold zero primitives)",
        ));
    }
    let keys = match options.motion {
        Some(m) if m.num_keys >= 2 => {
            motion_options("build_options.motion", &m)?;
            m.num_keys as usize
        }
        Some(m) if m.num_keys == 0 || m.num_keys == 1 => 1,
        _ => 1,
    };
    let first = std::mem::discriminant(&inputs[0]);
    for (i, input) in inputs.iter().enumerate() {
        if std::mem::discriminant(input) != first {
            return Err(Error::invalid(format!(
                "build_inputs[{i}] is {} but build_inputs[0] is {}; one acceleration structure holds one kind of input",
                input.kind_name(),
                inputs[0].kind_name()
            )));
        }
        if let BuildInput::Curves(c) = input
            && let BuildInput::Curves(c0) = &inputs[0]
            && c.curve_type != c0.curve_type
        {
            return Err(Error::invalid(format!(
                "build_inputs[{i}] has curve type {:?} but build_inputs[0] has {:?}; one structure holds one curve type",
                c.curve_type, c0.curve_type
            )));
        }
        let n = input.num_primitives();
        let limit = match input {
            BuildInput::Instances(_) => props.max_instances_per_ias,
            _ => props.max_primitives_per_build_input,
        };
        if n > limit {
            return Err(Error::limit(format!(
                "build_inputs[{i}] has {n} {}; this device allows at most {limit} per input",
                input.kind_name()
            )));
        }
        if !matches!(input, BuildInput::Instances(_)) && input.num_motion_keys() != keys {
            return Err(Error::invalid(format!(
                "build_inputs[{i}] gives {} motion key buffers; the build options ask for {keys} (one per key)",
                input.num_motion_keys()
            )));
        }
        let records = input.num_sbt_records();
        if !matches!(input, BuildInput::Instances(_) | BuildInput::Curves(_)) {
            if records == 0 {
                return Err(Error::invalid(format!(
                    "build_inputs[{i}].flags is empty; give one geometry flag set per SBT record (at least one)"
                )));
            }
            if records > props.max_sbt_records_per_build_input {
                return Err(Error::limit(format!(
                    "build_inputs[{i}].flags has {records} SBT records; this device allows at most {}",
                    props.max_sbt_records_per_build_input
                )));
            }
        }
        let what = |field: &str| format!("build_inputs[{i}].{field}");
        match input {
            BuildInput::Triangles(t) => {
                let stride = t.effective_vertex_stride();
                if stride < t.vertex_format.size() {
                    return Err(Error::invalid(format!(
                        "{} is {stride}; {:?} vertices need at least {} bytes",
                        what("vertex_stride"),
                        t.vertex_format,
                        t.vertex_format.size()
                    )));
                }
                aligned(
                    &what("vertex_stride"),
                    stride as u64,
                    t.vertex_format.alignment() as u64,
                )?;
                for (k, vb) in t.vertex_buffers.iter().enumerate() {
                    aligned(
                        &what(&format!("vertex_buffers[{k}].offset")),
                        vb.offset,
                        t.vertex_format.alignment() as u64,
                    )?;
                    buffer_range(
                        &what(&format!(
                            "vertex_buffers[{k}] ({} vertices)",
                            t.num_vertices
                        )),
                        vb.buffer,
                        vb.offset,
                        array_bytes(t.num_vertices, stride, t.vertex_format.size()),
                        sizes,
                    )?;
                }
                match &t.indices {
                    Some(ix) => {
                        let istride = if ix.stride == 0 {
                            ix.format.size()
                        } else {
                            ix.stride
                        };
                        if istride < ix.format.size() {
                            return Err(Error::invalid(format!(
                                "{} is {istride}; {:?} indices need at least {} bytes per triangle",
                                what("indices.stride"),
                                ix.format,
                                ix.format.size()
                            )));
                        }
                        aligned(
                            &what("indices.stride"),
                            istride as u64,
                            ix.format.alignment() as u64,
                        )?;
                        aligned(
                            &what("indices.buffer.offset"),
                            ix.buffer.offset,
                            ix.format.alignment() as u64,
                        )?;
                        buffer_range(
                            &what(&format!("indices ({} triangles)", ix.num_triangles)),
                            ix.buffer.buffer,
                            ix.buffer.offset,
                            array_bytes(ix.num_triangles, istride, ix.format.size()),
                            sizes,
                        )?;
                    }
                    None => {
                        if t.num_vertices % 3 != 0 {
                            return Err(Error::invalid(format!(
                                "{} is {} without an index buffer; unindexed triangles need a multiple of 3 vertices",
                                what("num_vertices"),
                                t.num_vertices
                            )));
                        }
                    }
                }
                if let Some(pt) = &t.pre_transform {
                    aligned(&what("pre_transform.offset"), pt.offset, 16)?;
                    buffer_range(
                        &what("pre_transform (3x4 f32)"),
                        pt.buffer,
                        pt.offset,
                        48,
                        sizes,
                    )?;
                }
                sbt_offsets(
                    &what("sbt_index_offsets"),
                    t.sbt_index_offsets.as_ref(),
                    n,
                    records,
                    sizes,
                )?;
                if let Some(omm) = &t.opacity_micromap
                    && let Some(ib) = &omm.index_buffer
                {
                    if !matches!(omm.index_size_in_bytes, 2 | 4) {
                        return Err(Error::invalid(format!(
                            "{} is {}; micromap indices are 2 or 4 bytes",
                            what("opacity_micromap.index_size_in_bytes"),
                            omm.index_size_in_bytes
                        )));
                    }
                    let s = if omm.index_stride == 0 {
                        omm.index_size_in_bytes
                    } else {
                        omm.index_stride
                    };
                    if s < omm.index_size_in_bytes {
                        return Err(Error::invalid(format!(
                            "{} is {s}; it must be at least the index size {}",
                            what("opacity_micromap.index_stride"),
                            omm.index_size_in_bytes
                        )));
                    }
                    buffer_range(
                        &what("opacity_micromap.index_buffer"),
                        ib.buffer,
                        ib.offset,
                        array_bytes(n, s, omm.index_size_in_bytes),
                        sizes,
                    )?;
                }
            }
            BuildInput::CustomPrimitives(c) => {
                let stride = c.effective_stride();
                if stride < 24 || stride % 8 != 0 {
                    return Err(Error::invalid(format!(
                        "{} is {stride}; AABB strides are multiples of 8 and at least 24 bytes",
                        what("stride")
                    )));
                }
                for (k, b) in c.aabb_buffers.iter().enumerate() {
                    aligned(&what(&format!("aabb_buffers[{k}].offset")), b.offset, 8)?;
                    buffer_range(
                        &what(&format!("aabb_buffers[{k}] ({} AABBs)", c.num_primitives)),
                        b.buffer,
                        b.offset,
                        array_bytes(c.num_primitives, stride, 24),
                        sizes,
                    )?;
                }
                sbt_offsets(
                    &what("sbt_index_offsets"),
                    c.sbt_index_offsets.as_ref(),
                    n,
                    records,
                    sizes,
                )?;
            }
            BuildInput::Spheres(s) => {
                let vs = s.effective_vertex_stride();
                let rs = s.effective_radius_stride();
                if vs < 12 || vs % 4 != 0 {
                    return Err(Error::invalid(format!(
                        "{} is {vs}; centres need at least 12 bytes, 4-aligned",
                        what("vertex_stride")
                    )));
                }
                if rs < 4 || rs % 4 != 0 {
                    return Err(Error::invalid(format!(
                        "{} is {rs}; radii need at least 4 bytes, 4-aligned",
                        what("radius_stride")
                    )));
                }
                if s.radius_buffers.len() != s.vertex_buffers.len() {
                    return Err(Error::invalid(format!(
                        "{} has {} buffers but vertex_buffers has {}; give one radius buffer per motion key",
                        what("radius_buffers"),
                        s.radius_buffers.len(),
                        s.vertex_buffers.len()
                    )));
                }
                for k in 0..s.vertex_buffers.len() {
                    let vb = &s.vertex_buffers[k];
                    buffer_range(
                        &what(&format!("vertex_buffers[{k}]")),
                        vb.buffer,
                        vb.offset,
                        array_bytes(n, vs, 12),
                        sizes,
                    )?;
                    let rb = &s.radius_buffers[k];
                    let radii = if s.single_radius { n.min(1) } else { n };
                    buffer_range(
                        &what(&format!("radius_buffers[{k}]")),
                        rb.buffer,
                        rb.offset,
                        array_bytes(radii, rs, 4),
                        sizes,
                    )?;
                }
                sbt_offsets(
                    &what("sbt_index_offsets"),
                    s.sbt_index_offsets.as_ref(),
                    n,
                    records,
                    sizes,
                )?;
            }
            BuildInput::Curves(c) => {
                let vs = if c.vertex_stride == 0 {
                    12
                } else {
                    c.vertex_stride
                };
                let ws = if c.width_stride == 0 {
                    4
                } else {
                    c.width_stride
                };
                let is = if c.index_stride == 0 {
                    4
                } else {
                    c.index_stride
                };
                if vs < 12 || ws < 4 || is < 4 || vs % 4 != 0 || ws % 4 != 0 || is % 4 != 0 {
                    return Err(Error::invalid(format!(
                        "{}: strides are vertex {vs}, width {ws}, index {is}; they must be 4-aligned and at least 12, 4 and 4 bytes",
                        what("curves")
                    )));
                }
                if c.width_buffers.len() != c.vertex_buffers.len() {
                    return Err(Error::invalid(format!(
                        "{} has {} buffers but vertex_buffers has {}; give one width buffer per motion key",
                        what("width_buffers"),
                        c.width_buffers.len(),
                        c.vertex_buffers.len()
                    )));
                }
                for k in 0..c.vertex_buffers.len() {
                    let vb = &c.vertex_buffers[k];
                    buffer_range(
                        &what(&format!("vertex_buffers[{k}]")),
                        vb.buffer,
                        vb.offset,
                        array_bytes(c.num_vertices, vs, 12),
                        sizes,
                    )?;
                    let wb = &c.width_buffers[k];
                    buffer_range(
                        &what(&format!("width_buffers[{k}]")),
                        wb.buffer,
                        wb.offset,
                        array_bytes(c.num_vertices, ws, 4),
                        sizes,
                    )?;
                }
                buffer_range(
                    &what("index_buffer"),
                    c.index_buffer.buffer,
                    c.index_buffer.offset,
                    array_bytes(n, is, 4),
                    sizes,
                )?;
            }
            BuildInput::Instances(ia) => {
                if inputs.len() != 1 {
                    return Err(Error::invalid(format!(
                        "an instance acceleration structure takes exactly one instance input; got {}",
                        inputs.len()
                    )));
                }
                aligned(
                    &what("instances.offset"),
                    ia.instances.offset,
                    Instance::ALIGNMENT as u64,
                )?;
                buffer_range(
                    &what(&format!(
                        "instances ({} instances of {} bytes)",
                        ia.num_instances,
                        Instance::SIZE
                    )),
                    ia.instances.buffer,
                    ia.instances.offset,
                    ia.num_instances as u64 * Instance::SIZE as u64,
                    sizes,
                )?;
            }
        }
    }
    Ok(keys)
}

fn sbt_offsets(
    what: &str,
    offsets: Option<&SbtIndexOffsets>,
    n: u32,
    records: u32,
    sizes: &dyn BufferSizes,
) -> Result<()> {
    match offsets {
        None if records > 1 => Err(Error::invalid(format!(
            "{what} is missing; an input with {records} SBT records needs per-primitive offsets to choose among them"
        ))),
        None => Ok(()),
        Some(o) => {
            if !matches!(o.size_in_bytes, 1 | 2 | 4) {
                return Err(Error::invalid(format!(
                    "{what}.size_in_bytes is {}; it must be 1, 2 or 4",
                    o.size_in_bytes
                )));
            }
            let stride = if o.stride == 0 {
                o.size_in_bytes
            } else {
                o.stride
            };
            if stride < o.size_in_bytes {
                return Err(Error::invalid(format!(
                    "{what}.stride is {stride}; it must be at least size_in_bytes ({})",
                    o.size_in_bytes
                )));
            }
            aligned(
                &format!("{what}.stride"),
                stride as u64,
                o.size_in_bytes as u64,
            )?;
            aligned(
                &format!("{what}.buffer.offset"),
                o.buffer.offset,
                o.size_in_bytes as u64,
            )?;
            buffer_range(
                what,
                o.buffer.buffer,
                o.buffer.offset,
                array_bytes(n, stride, o.size_in_bytes),
                sizes,
            )
        }
    }
}

/// Checks motion options.
pub fn motion_options(what: &str, m: &MotionOptions) -> Result<()> {
    if !m.time_begin.is_finite() || !m.time_end.is_finite() {
        return Err(Error::invalid(format!(
            "{what}: time_begin {} and time_end {} must be finite",
            m.time_begin, m.time_end
        )));
    }
    if m.time_begin > m.time_end {
        return Err(Error::invalid(format!(
            "{what}: time_begin {} is after time_end {}",
            m.time_begin, m.time_end
        )));
    }
    if m.flags.unknown_bits() != 0 {
        return Err(Error::invalid(format!(
            "{what}.flags has unknown bits {:#x}",
            m.flags.unknown_bits()
        )));
    }
    Ok(())
}

/// Checks that an update matches the structure's build: same operation flags, kinds and counts.
pub fn update(
    built_with: &AccelBuildOptions,
    built_inputs: &[BuildInput],
    options: &AccelBuildOptions,
    inputs: &[BuildInput],
) -> Result<()> {
    if options.operation != BuildOperation::Update {
        return Err(Error::invalid(
            "accel_update needs build_options.operation = Update",
        ));
    }
    if !built_with
        .flags
        .contains(optik_api::flags::BuildFlags::ALLOW_UPDATE)
    {
        return Err(Error::invalid(
            "the acceleration structure was built without BuildFlags::ALLOW_UPDATE, so it cannot be updated; rebuild it with that flag",
        ));
    }
    if inputs.len() != built_inputs.len() {
        return Err(Error::invalid(format!(
            "update gives {} build inputs; the structure was built from {}",
            inputs.len(),
            built_inputs.len()
        )));
    }
    for (i, (a, b)) in built_inputs.iter().zip(inputs).enumerate() {
        if std::mem::discriminant(a) != std::mem::discriminant(b)
            || a.num_primitives() != b.num_primitives()
            || a.num_sbt_records() != b.num_sbt_records()
            || a.num_motion_keys() != b.num_motion_keys()
        {
            return Err(Error::invalid(format!(
                "update input {i} ({} with {} primitives, {} records) differs from the build's ({} with {}, {}); updates keep kinds and counts",
                b.kind_name(),
                b.num_primitives(),
                b.num_sbt_records(),
                a.kind_name(),
                a.num_primitives(),
                a.num_sbt_records()
            )));
        }
    }
    Ok(())
}

/// Checks a transform description (the child handle is checked by the backend).
pub fn transform(desc: &TransformDesc) -> Result<()> {
    match desc {
        TransformDesc::Static {
            object_to_world,
            world_to_object,
            ..
        } => {
            if !affine::is_finite(object_to_world) || !affine::is_finite(world_to_object) {
                return Err(Error::invalid(
                    "static transform: object_to_world and world_to_object must hold finite values",
                ));
            }
            let product = affine::mul(object_to_world, world_to_object);
            let scale = object_to_world
                .iter()
                .chain(world_to_object.iter())
                .fold(1.0f32, |a, v| a.max(v.abs()));
            let off = product
                .iter()
                .zip(optik_api::accel::IDENTITY_3X4.iter())
                .map(|(a, b)| (a - b).abs())
                .fold(0.0f32, f32::max);
            if off > 1e-3 * scale {
                return Err(Error::invalid(format!(
                    "static transform: world_to_object is not the inverse of object_to_world (their product is off the identity by {off})"
                )));
            }
            Ok(())
        }
        TransformDesc::MatrixMotion { motion, keys, .. } => {
            motion_options("matrix motion transform", motion)?;
            motion_key_count(motion, keys.len())?;
            for (k, m) in keys.iter().enumerate() {
                if !affine::is_finite(m) || affine::inverse(m).is_none() {
                    return Err(Error::invalid(format!(
                        "matrix motion transform key {k} is not finite or not invertible: {m:?}"
                    )));
                }
            }
            Ok(())
        }
        TransformDesc::SrtMotion { motion, keys, .. } => {
            motion_options("SRT motion transform", motion)?;
            motion_key_count(motion, keys.len())?;
            for (k, key) in keys.iter().enumerate() {
                if !motion::srt_key_is_valid(key) {
                    return Err(Error::invalid(format!(
                        "SRT motion transform key {k} must hold finite values and a unit quaternion; got {key:?}"
                    )));
                }
            }
            Ok(())
        }
    }
}

fn motion_key_count(m: &MotionOptions, n: usize) -> Result<()> {
    if m.num_keys < 2 || m.num_keys as usize != n {
        return Err(Error::invalid(format!(
            "motion transform: motion.num_keys is {} and {n} keys are given; give at least 2 keys and num_keys equal to their count",
            m.num_keys
        )));
    }
    Ok(())
}

/// Checks an opacity micromap array description.
pub fn micromap_array(desc: &OpacityMicromapArrayDesc) -> Result<()> {
    for (i, m) in desc.micromaps.iter().enumerate() {
        if m.subdivision_level > MAX_MICROMAP_SUBDIVISION_LEVEL {
            return Err(Error::invalid(format!(
                "micromaps[{i}].subdivision_level is {}; at most {MAX_MICROMAP_SUBDIVISION_LEVEL}",
                m.subdivision_level
            )));
        }
        let bits_per = match m.format {
            OpacityMicromapFormat::TwoState => 1u64,
            OpacityMicromapFormat::FourState => 2,
        };
        let bits = bits_per << (2 * m.subdivision_level as u64);
        let bytes = bits.div_ceil(8);
        if m.byte_offset as u64 + bytes > desc.data.len() as u64 {
            return Err(Error::invalid(format!(
                "micromaps[{i}] needs {bytes} bytes of states from offset {} but data holds {} bytes",
                m.byte_offset,
                desc.data.len()
            )));
        }
    }
    Ok(())
}

/// Checks a launch's dimensions against the device limit. Zero-sized launches are valid
/// no-ops.
pub fn launch_size(size: LaunchSize, props: &DeviceProperties) -> Result<()> {
    if size.count() > props.max_launch_size {
        return Err(Error::limit(format!(
            "launch of {}x{}x{} = {} invocations exceeds this device's limit of {}",
            size.width,
            size.height,
            size.depth,
            size.count(),
            props.max_launch_size
        )));
    }
    Ok(())
}

fn sbt_region(
    what: &str,
    r: &SbtRegion,
    props: &DeviceProperties,
    sizes: &dyn BufferSizes,
) -> Result<()> {
    aligned(
        &format!("{what}.offset"),
        r.offset,
        SBT_RECORD_ALIGNMENT as u64,
    )?;
    if r.count > 0 {
        if r.stride < SBT_RECORD_HEADER_SIZE || !r.stride.is_multiple_of(SBT_RECORD_ALIGNMENT) {
            return Err(Error::invalid(format!(
                "{what}.stride is {}; it must be a multiple of {SBT_RECORD_ALIGNMENT} and at least the {SBT_RECORD_HEADER_SIZE}-byte header",
                r.stride
            )));
        }
        if r.stride > props.max_sbt_record_stride {
            return Err(Error::limit(format!(
                "{what}.stride is {}; this device allows at most {}",
                r.stride, props.max_sbt_record_stride
            )));
        }
    }
    buffer_range(
        &format!("{what} ({} records of stride {})", r.count, r.stride),
        r.buffer,
        r.offset,
        array_bytes(r.count, r.stride, SBT_RECORD_HEADER_SIZE),
        sizes,
    )
}

/// Checks the shape of a shader binding table: alignments, strides, and that every record
/// lies inside its buffer. Record headers are checked when the backend reads them.
pub fn sbt(
    table: &ShaderBindingTable,
    props: &DeviceProperties,
    sizes: &dyn BufferSizes,
) -> Result<()> {
    aligned(
        "sbt.raygen.offset",
        table.raygen.offset,
        SBT_RECORD_ALIGNMENT as u64,
    )?;
    buffer_range(
        "sbt.raygen",
        table.raygen.buffer,
        table.raygen.offset,
        SBT_RECORD_HEADER_SIZE as u64,
        sizes,
    )?;
    if let Some(e) = &table.exception {
        aligned(
            "sbt.exception.offset",
            e.offset,
            SBT_RECORD_ALIGNMENT as u64,
        )?;
        buffer_range(
            "sbt.exception",
            e.buffer,
            e.offset,
            SBT_RECORD_HEADER_SIZE as u64,
            sizes,
        )?;
    }
    for (what, region) in [
        ("sbt.miss", &table.miss),
        ("sbt.hitgroup", &table.hitgroup),
        ("sbt.callables", &table.callables),
    ] {
        if let Some(r) = region {
            sbt_region(what, r, props, sizes)?;
        }
    }
    Ok(())
}

/// Checks launch parameters and resources against a pipeline's bindings.
pub fn launch_bindings(
    params: &[u8],
    resources: &[Resource],
    bindings: &[BindingInfo],
    sizes: &dyn BufferSizes,
) -> Result<()> {
    for b in bindings {
        match b.kind {
            BindingKind::Params { size } => {
                if (params.len() as u64) < size as u64 {
                    return Err(Error::invalid(format!(
                        "params is {} bytes; the programs' `{}` (binding 0) needs {size} bytes",
                        params.len(),
                        b.name
                    )));
                }
            }
            _ => {
                let Some(r) = resources.iter().find(|r| r.binding() == b.binding) else {
                    return Err(Error::invalid(format!(
                        "no resource given for binding {} (`{}`); the programs use it",
                        b.binding, b.name
                    )));
                };
                match (b.kind, r) {
                    (
                        BindingKind::StorageBuffer { min_size, .. },
                        Resource::Buffer {
                            buffer,
                            offset,
                            size,
                            ..
                        },
                    ) => {
                        let total = sizes
                            .size_of(*buffer)
                            .map_err(|e| e.context(format!("binding {}", b.binding)))?;
                        let bound = match size {
                            Some(s) => *s,
                            None => total.saturating_sub(*offset),
                        };
                        buffer_range(
                            &format!("resource at binding {} (`{}`)", b.binding, b.name),
                            *buffer,
                            *offset,
                            bound,
                            sizes,
                        )?;
                        if bound < min_size as u64 {
                            return Err(Error::invalid(format!(
                                "buffer bound at binding {} (`{}`) is {bound} bytes; its type needs at least {min_size}",
                                b.binding, b.name
                            )));
                        }
                        if bound % 4 != 0 || offset % 4 != 0 {
                            return Err(Error::invalid(format!(
                                "buffer bound at binding {}: offset {offset} and size {bound} must be multiples of 4",
                                b.binding
                            )));
                        }
                    }
                    (BindingKind::Texture2d, Resource::Texture { .. })
                    | (BindingKind::Sampler, Resource::Sampler { .. }) => {}
                    (kind, r) => {
                        return Err(Error::invalid(format!(
                            "binding {} (`{}`) is a {} in the programs, but a {} was given",
                            b.binding,
                            b.name,
                            binding_kind_name(kind),
                            resource_name(r)
                        )));
                    }
                }
            }
        }
    }
    let mut seen = std::collections::BTreeSet::new();
    for r in resources {
        if r.binding() == 0 {
            return Err(Error::invalid(
                "resources: binding 0 is the launch parameters; pass them as `params` bytes",
            ));
        }
        if !seen.insert(r.binding()) {
            return Err(Error::invalid(format!(
                "resources: binding {} is given twice",
                r.binding()
            )));
        }
    }
    Ok(())
}

fn binding_kind_name(k: BindingKind) -> &'static str {
    match k {
        BindingKind::Params { .. } => "uniform",
        BindingKind::StorageBuffer { .. } => "storage buffer",
        BindingKind::Texture2d => "texture",
        BindingKind::Sampler => "sampler",
    }
}

fn resource_name(r: &Resource) -> &'static str {
    match r {
        Resource::Buffer { .. } => "buffer",
        Resource::Texture { .. } => "texture",
        Resource::Sampler { .. } => "sampler",
    }
}

/// Checks a texture description.
pub fn texture(desc: &TextureDesc) -> Result<()> {
    if desc.width == 0 || desc.height == 0 || desc.width > 16384 || desc.height > 16384 {
        return Err(Error::invalid(format!(
            "texture is {}x{}; width and height must be 1..=16384",
            desc.width, desc.height
        )));
    }
    Ok(())
}

/// Checks texel data against a texture description.
pub fn texture_data(desc: &TextureDesc, data: &[u8]) -> Result<()> {
    let want = desc.width as u64 * desc.height as u64 * desc.format.texel_size() as u64;
    if data.len() as u64 != want {
        return Err(Error::invalid(format!(
            "texture data is {} bytes; a {}x{} {:?} texture holds {want}",
            data.len(),
            desc.width,
            desc.height,
            desc.format
        )));
    }
    Ok(())
}

/// Checks a buffer size at creation.
pub fn buffer_create(size: u64, props: &DeviceProperties) -> Result<()> {
    if size > props.max_buffer_size {
        return Err(Error::limit(format!(
            "buffer of {size} bytes exceeds this device's largest buffer of {} bytes",
            props.max_buffer_size
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
