//! Acceleration-structure builds through the public `Device` API (the CPU device) with
//! random buffers, offsets, strides, counts, formats, flags and motion options: every
//! build input kind, then instances over what was built. Memory usage, build, update and
//! compaction must answer with an error or a structure, never a panic, an abort or a hang.

use crate::{Outcome, Target};
use arbitrary::{Result as AResult, Unstructured};
use optik_api::{
    AccelBuildOptions, Buffer, BufferView, BuildFlags, BuildInput, BuildOperation, CurveArray,
    CurveEndcaps, CurveType, CustomPrimitiveArray, Device, ErrorKind, GeometryFlags, IndexFormat,
    Instance, InstanceArray, MotionFlags, MotionOptions, SbtIndexOffsets, SphereArray,
    TriangleArray, TriangleIndices, VertexFormat,
};
use std::sync::OnceLock;

/// The target.
pub const TARGET: Target = Target {
    name: "accel",
    seeds,
    dictionary: &[],
    run,
};

/// Seeds: pseudo-random byte strings (each decodes to some build; mutations then vary
/// it), and one of all ones (every count and offset at its largest).
fn seeds() -> Vec<Vec<u8>> {
    let mut seeds: Vec<Vec<u8>> = (1..=12u64)
        .map(|k| {
            let mut x = k.wrapping_mul(0x9E37_79B9_7F4A_7C15);
            (0..64 * k)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    x as u8
                })
                .collect()
        })
        .collect();
    seeds.push(vec![0xFF; 256]);
    seeds
}

fn device() -> &'static dyn Device {
    static DEVICE: OnceLock<Option<optik_cpu::CpuDevice>> = OnceLock::new();
    match DEVICE.get_or_init(|| {
        optik_cpu::CpuBackend::with_threads(1)
            .map(optik_cpu::CpuDevice::new)
            .ok()
    }) {
        Some(d) => d,
        None => panic!("the CPU device cannot open"),
    }
}

/// Runs one input.
pub fn run(data: &[u8]) -> Outcome {
    let d = device();
    let mut made = Made::default();
    let mut u = Unstructured::new(data);
    let outcome = match builds(d, &mut u, &mut made) {
        Ok(Ok(())) => Outcome::Accepted,
        Err(_) => Outcome::Rejected,
        Ok(Err(e)) if e.kind() == ErrorKind::Backend => {
            Outcome::Finding(format!("an internal error for build inputs: {e}"))
        }
        Ok(Err(e)) => {
            if std::env::var_os("OPTIK_FUZZ_VERBOSE").is_some() {
                eprintln!("accel: rejected: {e}");
            }
            Outcome::Rejected
        }
    };
    for a in made.accels.drain(..).rev() {
        let _ = d.destroy_accel(a);
    }
    for b in made.buffers.drain(..) {
        let _ = d.destroy_buffer(b);
    }
    outcome
}

/// What an input created, freed after it.
#[derive(Default)]
struct Made {
    buffers: Vec<Buffer>,
    accels: Vec<optik_api::Accel>,
}

/// A small number usually, any number sometimes.
fn count(u: &mut Unstructured<'_>) -> AResult<u32> {
    Ok(match u.int_in_range(0..=7u8)? {
        0..=5 => u.int_in_range(0..=48)?,
        6 => u.int_in_range(0..=4096)?,
        _ => u.arbitrary()?,
    })
}

/// An offset or stride: aligned and small usually, anything sometimes.
fn bytes_at(u: &mut Unstructured<'_>) -> AResult<u32> {
    Ok(match u.int_in_range(0..=7u8)? {
        0..=2 => 0,
        3..=5 => 4 * u.int_in_range(0..=32u32)?,
        6 => u.int_in_range(0..=300)?,
        _ => u.arbitrary()?,
    })
}

fn view(u: &mut Unstructured<'_>, bufs: &[Buffer]) -> AResult<BufferView> {
    let buffer = *u.choose(bufs)?;
    let offset = match u.int_in_range(0..=7u8)? {
        0..=4 => 0,
        5 | 6 => u64::from(bytes_at(u)?),
        _ => u.arbitrary()?,
    };
    Ok(BufferView { buffer, offset })
}

/// One buffer per motion key usually (`keys`), another number sometimes.
fn views(u: &mut Unstructured<'_>, bufs: &[Buffer], keys: usize) -> AResult<Vec<BufferView>> {
    let n = match u.int_in_range(0..=15u8)? {
        0 => 0,
        1 => u.int_in_range(1..=4)?,
        _ => keys,
    };
    (0..n).map(|_| view(u, bufs)).collect()
}

fn flags(u: &mut Unstructured<'_>) -> AResult<Vec<GeometryFlags>> {
    let n = if u.ratio(1, 8)? {
        u.int_in_range(0..=3)?
    } else {
        1
    };
    (0..n)
        .map(|_| Ok(GeometryFlags(u.int_in_range(0..=15)?)))
        .collect()
}

fn sbt_offsets(u: &mut Unstructured<'_>, bufs: &[Buffer]) -> AResult<Option<SbtIndexOffsets>> {
    Ok(if u.ratio(1, 4)? {
        Some(SbtIndexOffsets {
            buffer: view(u, bufs)?,
            size_in_bytes: *u.choose(&[0, 1, 2, 4, 3, 8])?,
            stride: bytes_at(u)?,
        })
    } else {
        None
    })
}

fn geometry(
    u: &mut Unstructured<'_>,
    bufs: &[Buffer],
    kind: u8,
    keys: usize,
) -> AResult<BuildInput> {
    Ok(match kind {
        0 => BuildInput::Triangles(TriangleArray {
            vertex_buffers: views(u, bufs, keys)?,
            num_vertices: count(u)?,
            vertex_format: *u.choose(&[
                VertexFormat::Float3,
                VertexFormat::Float2,
                VertexFormat::Half3,
                VertexFormat::Half2,
                VertexFormat::Snorm16x3,
                VertexFormat::Snorm16x2,
            ])?,
            vertex_stride: bytes_at(u)?,
            indices: if u.arbitrary()? {
                Some(TriangleIndices {
                    buffer: view(u, bufs)?,
                    format: *u.choose(&[IndexFormat::U16x3, IndexFormat::U32x3])?,
                    stride: bytes_at(u)?,
                    num_triangles: count(u)?,
                })
            } else {
                None
            },
            flags: flags(u)?,
            sbt_index_offsets: sbt_offsets(u, bufs)?,
            primitive_index_offset: u.arbitrary()?,
            pre_transform: if u.ratio(1, 4)? {
                Some(view(u, bufs)?)
            } else {
                None
            },
            opacity_micromap: None,
        }),
        1 => BuildInput::CustomPrimitives(CustomPrimitiveArray {
            aabb_buffers: views(u, bufs, keys)?,
            num_primitives: count(u)?,
            stride: bytes_at(u)?,
            flags: flags(u)?,
            sbt_index_offsets: sbt_offsets(u, bufs)?,
            primitive_index_offset: u.arbitrary()?,
        }),
        2 => BuildInput::Spheres(SphereArray {
            vertex_buffers: views(u, bufs, keys)?,
            vertex_stride: bytes_at(u)?,
            num_vertices: count(u)?,
            radius_buffers: views(u, bufs, keys)?,
            radius_stride: bytes_at(u)?,
            single_radius: u.arbitrary()?,
            flags: flags(u)?,
            sbt_index_offsets: sbt_offsets(u, bufs)?,
            primitive_index_offset: u.arbitrary()?,
        }),
        _ => BuildInput::Curves(CurveArray {
            curve_type: *u.choose(&[
                CurveType::RoundLinear,
                CurveType::RoundQuadraticBSpline,
                CurveType::RoundCubicBSpline,
                CurveType::RoundCatmullRom,
            ])?,
            num_primitives: count(u)?,
            vertex_buffers: views(u, bufs, keys)?,
            num_vertices: count(u)?,
            vertex_stride: bytes_at(u)?,
            width_buffers: views(u, bufs, keys)?,
            width_stride: bytes_at(u)?,
            index_buffer: view(u, bufs)?,
            index_stride: bytes_at(u)?,
            flag: GeometryFlags(u.int_in_range(0..=15)?),
            primitive_index_offset: u.arbitrary()?,
            endcaps: *u.choose(&[CurveEndcaps::Default, CurveEndcaps::On])?,
        }),
    })
}

fn options(u: &mut Unstructured<'_>) -> AResult<AccelBuildOptions> {
    Ok(AccelBuildOptions {
        flags: BuildFlags(u.int_in_range(0..=63)?),
        operation: BuildOperation::Build,
        motion: if u.ratio(1, 4)? {
            Some(MotionOptions {
                num_keys: *u.choose(&[0, 1, 2, 2, 3, 4, 0xFFFF])?,
                flags: MotionFlags(u.int_in_range(0..=3)?),
                time_begin: if u.ratio(1, 4)? {
                    f32::from_bits(u.arbitrary()?)
                } else {
                    0.0
                },
                time_end: if u.ratio(1, 4)? {
                    f32::from_bits(u.arbitrary()?)
                } else {
                    1.0
                },
            })
        } else {
            None
        },
    })
}

/// `size` bytes for a buffer, from a few input bytes (so the rest of the input still
/// decides the build): small floats (valid geometry), small integers (valid indices), raw
/// bits (NaNs, infinities, denormals, huge values) or a repeated pattern.
fn contents(u: &mut Unstructured<'_>, size: usize) -> AResult<Vec<u8>> {
    let mode = u.int_in_range(0..=3u8)?;
    let mut state: u64 = u.arbitrary::<u64>()? | 1;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let pattern: Vec<u8> = u.bytes(u.len().min(16))?.to_vec();
    let mut out = Vec::with_capacity(size + 4);
    while out.len() < size {
        let word: u32 = match mode {
            0 => ((next() % 2001) as f32 / 250.0 - 4.0).to_bits(),
            1 => (next() % 64) as u32,
            2 => next() as u32,
            _ => {
                let i = out.len() % pattern.len().max(1);
                u32::from_le_bytes(std::array::from_fn(|k| {
                    pattern
                        .get((i + k) % pattern.len().max(1))
                        .copied()
                        .unwrap_or(0)
                }))
            }
        };
        out.extend_from_slice(&word.to_le_bytes());
    }
    out.truncate(size);
    Ok(out)
}

/// Decodes and runs the builds; the outer error is the input running out.
fn builds(
    d: &dyn Device,
    u: &mut Unstructured<'_>,
    made: &mut Made,
) -> AResult<optik_api::Result<()>> {
    // Buffers of random sizes holding the input's bytes (NaNs, huge and denormal floats,
    // out-of-range indices included).
    for _ in 0..u.int_in_range(1..=3)? {
        let size = match u.int_in_range(0..=3u8)? {
            0 => u64::from(u.int_in_range(0..=2048u32)?),
            _ => 4 * u64::from(u.int_in_range(1..=256u32)?),
        };
        let b = match d.create_buffer(size) {
            Ok(b) => b,
            Err(e) => return Ok(Err(e)),
        };
        made.buffers.push(b);
        let fill = contents(u, size as usize)?;
        if let Err(e) = d.write_buffer(b, 0, &fill) {
            return Ok(Err(e));
        }
    }
    let bufs = made.buffers.clone();
    let kind = u.int_in_range(0..=3u8)?;
    let opts = options(u)?;
    let keys = opts
        .motion
        .map_or(1, |m| usize::from(m.num_keys.clamp(1, 4)));
    let mut inputs = Vec::new();
    for _ in 0..u.int_in_range(1..=2)? {
        // Mostly one primitive kind per build; sometimes a mix (an error).
        let k = if u.ratio(1, 8)? {
            u.int_in_range(0..=3u8)?
        } else {
            kind
        };
        inputs.push(geometry(u, &bufs, k, keys)?);
    }
    if let Err(e) = d.accel_memory_usage(&opts, &inputs) {
        return Ok(Err(e));
    }
    if std::env::var_os("OPTIK_FUZZ_VERBOSE").is_some() {
        describe(d, &opts, &inputs, &bufs);
    }
    let gas = match d.accel_build(&opts, &inputs) {
        Ok(a) => a,
        Err(e) => return Ok(Err(e)),
    };
    made.accels.push(gas);
    if opts.flags.contains(BuildFlags::ALLOW_UPDATE) && u.arbitrary()? {
        let update = AccelBuildOptions {
            operation: BuildOperation::Update,
            ..opts
        };
        if let Err(e) = d.accel_update(gas, &update, &inputs) {
            return Ok(Err(e));
        }
    }
    if opts.flags.contains(BuildFlags::ALLOW_COMPACTION) && u.arbitrary()? {
        match d.accel_compact(gas) {
            Ok(c) => made.accels.push(c),
            Err(e) => return Ok(Err(e)),
        }
    }
    // Instances over it, with random transforms, masks, flags and offsets.
    let handle = match d.traversable_handle(gas) {
        Ok(h) => h,
        Err(e) => return Ok(Err(e)),
    };
    let n = u.int_in_range(0..=4u32)?;
    let mut bytes = Vec::new();
    for _ in 0..n {
        let mut inst = Instance::new(handle);
        for v in &mut inst.transform {
            if u.ratio(1, 4)? {
                *v = f32::from_bits(u.arbitrary()?);
            }
        }
        inst.instance_id = u.arbitrary()?;
        inst.sbt_offset = count(u)?;
        inst.visibility_mask = u.arbitrary()?;
        inst.flags = u.int_in_range(0..=31)?;
        if u.ratio(1, 8)? {
            inst.traversable_handle = u.arbitrary()?;
        }
        bytes.extend_from_slice(bytemuck::bytes_of(&inst));
    }
    let ib = match d.create_buffer((bytes.len() as u64).max(16) + u64::from(bytes_at(u)? % 64)) {
        Ok(b) => b,
        Err(e) => return Ok(Err(e)),
    };
    made.buffers.push(ib);
    if let Err(e) = d.write_buffer(ib, 0, &bytes) {
        return Ok(Err(e));
    }
    let instances = BuildInput::Instances(InstanceArray {
        instances: BufferView {
            buffer: ib,
            offset: if u.ratio(1, 4)? {
                u64::from(bytes_at(u)?)
            } else {
                0
            },
        },
        num_instances: if u.ratio(1, 4)? { count(u)? } else { n },
    });
    let ias_opts = options(u)?;
    match d.accel_build(&ias_opts, &[instances]) {
        Ok(a) => made.accels.push(a),
        Err(e) => return Ok(Err(e)),
    }
    Ok(Ok(()))
}

/// Prints the build about to run (`OPTIK_FUZZ_VERBOSE`, for replaying one input): the options, the inputs and
/// every buffer as f32 and u32 words, enough to write the failing case as a unit test.
fn describe(d: &dyn Device, opts: &AccelBuildOptions, inputs: &[BuildInput], bufs: &[Buffer]) {
    eprintln!("accel: options {opts:?}");
    for (i, input) in inputs.iter().enumerate() {
        eprintln!("accel: input {i}: {input:?}");
    }
    for b in bufs {
        let size = d.buffer_size(*b).unwrap_or(0);
        let mut bytes = vec![0u8; size as usize];
        if d.read_buffer(*b, 0, &mut bytes).is_err() {
            continue;
        }
        let words: Vec<String> = bytes
            .chunks_exact(4)
            .map(|w| {
                let w = [w[0], w[1], w[2], w[3]];
                format!("{:e}/{}", f32::from_le_bytes(w), u32::from_le_bytes(w))
            })
            .collect();
        eprintln!("accel: {b:?} ({size} bytes): {}", words.join(" "));
    }
}
