//! Runs a case on a device through the public API: builds the scene, compiles the module,
//! creates program groups, the pipeline and the SBT, launches, and reads the record buffer
//! back. Every object is destroyed afterwards, so one device serves the whole catalog.

use crate::case::{Case, ParamWord, SbtEntry};
use crate::scene::{Gas, GeomInput, Node, SbtOffsets, TransformKind, encode_vertex};
use optik::{
    AccelBuildOptions, BufferView, BuildFlags, BuildInput, BuildOperation, CurveArray,
    CustomPrimitiveArray, Device, Error, IndexFormat, Instance, InstanceArray, LaunchSize,
    ModuleCompileOptions, OpacityMicromapArrayDesc, OpacityMicromapDesc, ProgramGroupDesc,
    ProgramRef, ProgramSource, Resource, SbtIndexOffsets, SbtRecord, SbtRegion, ShaderBindingTable,
    SphereArray, TransformDesc, TraversableHandle, TriangleArray, TriangleIndices,
    TriangleOpacityMicromap,
};

/// Objects created for one case, destroyed when dropped (errors on destruction are ignored:
/// the device is being cleaned, and a failure there has already been reported elsewhere).
struct Owned<'d> {
    device: &'d dyn Device,
    buffers: Vec<optik::Buffer>,
    accels: Vec<optik::Accel>,
    modules: Vec<optik::Module>,
    groups: Vec<optik::ProgramGroup>,
    pipelines: Vec<optik::Pipeline>,
    micromaps: Vec<optik::MicromapArray>,
}

impl Drop for Owned<'_> {
    fn drop(&mut self) {
        for p in self.pipelines.drain(..) {
            let _ = self.device.destroy_pipeline(p);
        }
        for g in self.groups.drain(..) {
            let _ = self.device.destroy_program_group(g);
        }
        for m in self.modules.drain(..) {
            let _ = self.device.destroy_module(m);
        }
        for a in self.accels.drain(..).rev() {
            let _ = self.device.destroy_accel(a);
        }
        for m in self.micromaps.drain(..) {
            let _ = self.device.destroy_micromap_array(m);
        }
        for b in self.buffers.drain(..) {
            let _ = self.device.destroy_buffer(b);
        }
    }
}

impl<'d> Owned<'d> {
    fn buffer(&mut self, bytes: &[u8]) -> Result<optik::Buffer, Error> {
        // Buffers of zero bytes are allowed by few APIs; a 16-byte minimum is harmless.
        let b = self.device.create_buffer((bytes.len() as u64).max(16))?;
        self.buffers.push(b);
        if !bytes.is_empty() {
            self.device.write_buffer(b, 0, bytes)?;
        }
        Ok(b)
    }

    fn words(&mut self, words: &[u32]) -> Result<optik::Buffer, Error> {
        self.buffer(bytemuck::cast_slice(words))
    }
}

fn f32_bytes(values: impl IntoIterator<Item = f32>) -> Vec<u8> {
    values.into_iter().flat_map(|v| v.to_le_bytes()).collect()
}

fn strided(elements: &[Vec<u8>], stride: u32) -> Vec<u8> {
    let size = elements.first().map_or(0, |e| e.len());
    let stride = if stride == 0 { size } else { stride as usize };
    let mut out = vec![
        0u8;
        if elements.is_empty() {
            0
        } else {
            stride * (elements.len() - 1) + size
        }
    ];
    for (i, e) in elements.iter().enumerate() {
        out[i * stride..i * stride + e.len()].copy_from_slice(e);
    }
    out
}

fn sbt_offsets(
    o: &Option<SbtOffsets>,
    owned: &mut Owned<'_>,
) -> Result<Option<SbtIndexOffsets>, Error> {
    let Some(o) = o else { return Ok(None) };
    let elements: Vec<Vec<u8>> = o
        .offsets
        .iter()
        .map(|v| match o.size_in_bytes {
            1 => vec![*v as u8],
            2 => (*v as u16).to_le_bytes().to_vec(),
            _ => v.to_le_bytes().to_vec(),
        })
        .collect();
    let buffer = owned.buffer(&strided(&elements, o.stride))?;
    Ok(Some(SbtIndexOffsets {
        buffer: BufferView::new(buffer),
        size_in_bytes: o.size_in_bytes,
        stride: o.stride,
    }))
}

fn build_input(input: &GeomInput, owned: &mut Owned<'_>) -> Result<BuildInput, Error> {
    Ok(match input {
        GeomInput::Triangles(t) => {
            let mut vertex_buffers = Vec::new();
            for key in &t.keys {
                let elements: Vec<Vec<u8>> =
                    key.iter().map(|v| encode_vertex(t.format, *v)).collect();
                vertex_buffers.push(BufferView::new(
                    owned.buffer(&strided(&elements, t.vertex_stride))?,
                ));
            }
            let indices = match &t.indices {
                Some((tris, format, stride)) => {
                    let elements: Vec<Vec<u8>> = tris
                        .iter()
                        .map(|tri| match format {
                            IndexFormat::U16x3 => {
                                tri.iter().flat_map(|i| (*i as u16).to_le_bytes()).collect()
                            }
                            IndexFormat::U32x3 => {
                                tri.iter().flat_map(|i| i.to_le_bytes()).collect()
                            }
                        })
                        .collect();
                    let buffer = owned.buffer(&strided(&elements, *stride))?;
                    Some(TriangleIndices {
                        buffer: BufferView::new(buffer),
                        format: *format,
                        stride: *stride,
                        num_triangles: tris.len() as u32,
                    })
                }
                None => None,
            };
            let pre_transform = match &t.pre_transform {
                Some(m) => Some(BufferView::new(
                    owned.buffer(&f32_bytes(m.iter().copied()))?,
                )),
                None => None,
            };
            let opacity_micromap = match &t.omm {
                Some(omm) => {
                    let desc = OpacityMicromapArrayDesc {
                        micromaps: (0..omm.states.len())
                            .map(|k| OpacityMicromapDesc {
                                byte_offset: k as u32,
                                subdivision_level: 0,
                                format: omm.format,
                            })
                            .collect(),
                        data: omm.states.clone(),
                    };
                    let array = owned.device.create_opacity_micromap_array(&desc)?;
                    owned.micromaps.push(array);
                    let indices: Vec<u8> =
                        omm.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
                    let buffer = owned.buffer(&indices)?;
                    Some(TriangleOpacityMicromap {
                        array,
                        index_buffer: Some(BufferView::new(buffer)),
                        index_size_in_bytes: 4,
                        index_stride: 0,
                        base_index: 0,
                    })
                }
                None => None,
            };
            BuildInput::Triangles(TriangleArray {
                vertex_buffers,
                num_vertices: t.keys.first().map_or(0, |k| k.len() as u32),
                vertex_format: t.format,
                vertex_stride: t.vertex_stride,
                indices,
                flags: t.flags.clone(),
                sbt_index_offsets: sbt_offsets(&t.sbt_offsets, owned)?,
                primitive_index_offset: t.prim_index_offset,
                pre_transform,
                opacity_micromap,
            })
        }
        GeomInput::Aabbs(a) => {
            let mut aabb_buffers = Vec::new();
            for key in &a.keys {
                aabb_buffers.push(BufferView::new(
                    owned.buffer(&f32_bytes(key.iter().flatten().copied()))?,
                ));
            }
            BuildInput::CustomPrimitives(CustomPrimitiveArray {
                aabb_buffers,
                num_primitives: a.keys.first().map_or(0, |k| k.len() as u32),
                stride: 0,
                flags: a.flags.clone(),
                sbt_index_offsets: sbt_offsets(&a.sbt_offsets, owned)?,
                primitive_index_offset: a.prim_index_offset,
            })
        }
        GeomInput::Spheres(s) => {
            let mut vertex_buffers = Vec::new();
            for key in &s.centres {
                vertex_buffers.push(BufferView::new(
                    owned.buffer(&f32_bytes(key.iter().flatten().copied()))?,
                ));
            }
            let mut radius_buffers = Vec::new();
            for key in &s.radii {
                radius_buffers.push(BufferView::new(
                    owned.buffer(&f32_bytes(key.iter().copied()))?,
                ));
            }
            BuildInput::Spheres(SphereArray {
                vertex_buffers,
                vertex_stride: 0,
                num_vertices: s.centres.first().map_or(0, |k| k.len() as u32),
                radius_buffers,
                radius_stride: 0,
                single_radius: s.single_radius,
                flags: s.flags.clone(),
                sbt_index_offsets: sbt_offsets(&s.sbt_offsets, owned)?,
                primitive_index_offset: s.prim_index_offset,
            })
        }
        GeomInput::Curves(c) => {
            let mut vertex_buffers = Vec::new();
            for key in &c.points {
                vertex_buffers.push(BufferView::new(
                    owned.buffer(&f32_bytes(key.iter().flatten().copied()))?,
                ));
            }
            let mut width_buffers = Vec::new();
            for key in &c.radii {
                width_buffers.push(BufferView::new(
                    owned.buffer(&f32_bytes(key.iter().copied()))?,
                ));
            }
            let index_buffer = BufferView::new(owned.words(&c.segments)?);
            BuildInput::Curves(CurveArray {
                curve_type: optik::CurveType::RoundLinear,
                num_primitives: c.segments.len() as u32,
                vertex_buffers,
                num_vertices: c.points.first().map_or(0, |k| k.len() as u32),
                vertex_stride: 0,
                width_buffers,
                width_stride: 0,
                index_buffer,
                index_stride: 0,
                flag: c.flag,
                primitive_index_offset: c.prim_index_offset,
                endcaps: c.endcaps,
            })
        }
    })
}

fn build_gas(device: &dyn Device, gas: &Gas, owned: &mut Owned<'_>) -> Result<optik::Accel, Error> {
    let inputs = gas
        .inputs
        .iter()
        .map(|i| build_input(i, owned))
        .collect::<Result<Vec<_>, _>>()?;
    let mut options = AccelBuildOptions {
        flags: gas.build_flags,
        operation: BuildOperation::Build,
        motion: gas.motion,
    };
    let accel = match &gas.update_from {
        Some(first) => {
            let first = first
                .iter()
                .map(|i| build_input(i, owned))
                .collect::<Result<Vec<_>, _>>()?;
            options.flags |= BuildFlags::ALLOW_UPDATE;
            let accel = device.accel_build(&options, &first)?;
            owned.accels.push(accel);
            device.accel_update(
                accel,
                &AccelBuildOptions {
                    operation: BuildOperation::Update,
                    ..options
                },
                &inputs,
            )?;
            accel
        }
        None => {
            let accel = device.accel_build(&options, &inputs)?;
            owned.accels.push(accel);
            accel
        }
    };
    if gas.compact {
        let compacted = device.accel_compact(accel)?;
        owned.accels.push(compacted);
        return Ok(compacted);
    }
    Ok(accel)
}

/// Builds the scene; returns the traversable handle of every node.
fn build_scene(
    device: &dyn Device,
    case: &Case,
    owned: &mut Owned<'_>,
) -> Result<Vec<TraversableHandle>, Error> {
    let mut handles: Vec<TraversableHandle> = Vec::new();
    for node in &case.scene.nodes {
        let accel = match node {
            Node::Gas(g) => build_gas(device, g, owned)?,
            Node::Ias(instances) => {
                let records: Vec<Instance> = instances
                    .iter()
                    .map(|i| Instance {
                        transform: i.transform,
                        instance_id: i.id,
                        sbt_offset: i.sbt_offset,
                        visibility_mask: i.mask,
                        flags: i.flags.0,
                        traversable_handle: i.child.map_or(0, |c| handles[c].0),
                        pad: [0; 2],
                    })
                    .collect();
                let buffer = owned.buffer(bytemuck::cast_slice(&records))?;
                let input = BuildInput::Instances(InstanceArray {
                    instances: BufferView::new(buffer),
                    num_instances: records.len() as u32,
                });
                let accel = device.accel_build(&AccelBuildOptions::default(), &[input])?;
                owned.accels.push(accel);
                accel
            }
            Node::Transform(t) => {
                let child = handles[t.child];
                let desc = match &t.kind {
                    TransformKind::Static(m) => TransformDesc::Static {
                        child,
                        object_to_world: *m,
                        world_to_object: optik::semantics::affine::inverse(m).ok_or_else(|| {
                            Error::invalid(format!(
                                "case {}: a static transform has no inverse",
                                case.name
                            ))
                        })?,
                    },
                    TransformKind::MatrixMotion(motion, keys) => TransformDesc::MatrixMotion {
                        child,
                        motion: *motion,
                        keys: keys.clone(),
                    },
                    TransformKind::SrtMotion(motion, keys) => TransformDesc::SrtMotion {
                        child,
                        motion: *motion,
                        keys: keys.clone(),
                    },
                };
                let accel = device.create_transform(&desc)?;
                owned.accels.push(accel);
                accel
            }
        };
        handles.push(device.traversable_handle(accel)?);
    }
    Ok(handles)
}

/// The record buffer of every launch, as words, after running `case` on `device`.
pub fn run_case(device: &dyn Device, case: &Case) -> Result<Vec<Vec<u32>>, Error> {
    let mut owned = Owned {
        device,
        buffers: vec![],
        accels: vec![],
        modules: vec![],
        groups: vec![],
        pipelines: vec![],
        micromaps: vec![],
    };
    let handles = build_scene(device, case, &mut owned)?;
    let p = &case.pipeline;
    let source = ProgramSource::new(format!("{}.wgsl", case.name), p.wgsl.clone());
    let (module, _log) =
        device.create_module(&ModuleCompileOptions::default(), &p.compile, &source)?;
    owned.modules.push(module);
    let pref = |name: &Option<String>| name.as_ref().map(|n| ProgramRef::new(module, n.clone()));

    // Program groups, in one call: raygen, exception, miss, hit, callables.
    let mut descs = vec![ProgramGroupDesc::Raygen(ProgramRef::new(
        module,
        p.raygen.clone(),
    ))];
    if let Some(ex) = &p.exception {
        descs.push(ProgramGroupDesc::Exception(ProgramRef::new(
            module,
            ex.clone(),
        )));
    }
    let miss_base = descs.len();
    descs.extend(p.miss.iter().map(|m| ProgramGroupDesc::Miss(pref(m))));
    let hit_base = descs.len();
    descs.extend(p.hit.iter().map(|h| ProgramGroupDesc::HitGroup {
        closest_hit: pref(&h.closest_hit),
        any_hit: pref(&h.any_hit),
        intersection: pref(&h.intersection),
        builtin: h.builtin.unwrap_or(optik::BuiltinIntersector::Triangle),
    }));
    let call_base = descs.len();
    descs.extend(p.callables.iter().map(|c| ProgramGroupDesc::Callables {
        direct: pref(&c.direct),
        continuation: pref(&c.continuation),
    }));
    let groups = device.create_program_groups(&descs)?;
    owned.groups.extend(groups.iter().copied());
    let pipeline = device.create_pipeline(&p.compile, &p.link, &groups)?;
    owned.pipelines.push(pipeline);

    // The SBT: one buffer, one stride; raygen, exception, miss, hit, callables in order.
    let sbt = &case.sbt;
    let stride = sbt.effective_stride() as usize;
    let record = |group: optik::ProgramGroup, data: &[u32]| -> Result<Vec<u8>, Error> {
        let mut r = device.sbt_record_pack_header(group)?.to_vec();
        r.extend_from_slice(bytemuck::cast_slice(data));
        r.resize(stride.max(r.len()), 0);
        Ok(r)
    };
    let mut bytes = record(groups[0], &sbt.raygen_data)?;
    let exception_offset = bytes.len();
    if p.exception.is_some() {
        bytes.extend(record(groups[1], &sbt.exception_data)?);
    }
    let region = |entries: &[SbtEntry],
                  base: usize,
                  bytes: &mut Vec<u8>|
     -> Result<Option<(u64, u32)>, Error> {
        if entries.is_empty() {
            return Ok(None);
        }
        let offset = bytes.len() as u64;
        for e in entries {
            let group = groups.get(base + e.group).copied().ok_or_else(|| {
                Error::invalid(format!(
                    "case {}: an SBT record names group {} which does not exist",
                    case.name, e.group
                ))
            })?;
            bytes.extend(record(group, &e.data)?);
        }
        Ok(Some((offset, entries.len() as u32)))
    };
    let miss = region(&sbt.miss, miss_base, &mut bytes)?;
    let hit = region(&sbt.hit, hit_base, &mut bytes)?;
    let callables = region(&sbt.callables, call_base, &mut bytes)?;
    let sbt_buffer = owned.buffer(&bytes)?;
    let as_region = |r: Option<(u64, u32)>| {
        r.map(|(offset, count)| SbtRegion {
            buffer: sbt_buffer,
            offset,
            stride: stride as u32,
            count,
        })
    };
    let table = ShaderBindingTable {
        raygen: SbtRecord {
            buffer: sbt_buffer,
            offset: 0,
        },
        exception: p.exception.as_ref().map(|_| SbtRecord {
            buffer: sbt_buffer,
            offset: exception_offset as u64,
        }),
        miss: as_region(miss),
        hitgroup: as_region(hit),
        callables: as_region(callables),
    };

    let mut results = Vec::new();
    for launch in &case.launches {
        let mut params: Vec<u32> = launch
            .params
            .iter()
            .map(|w| match *w {
                ParamWord::U32(v) => v,
                ParamWord::F32(f) => f.to_bits(),
                ParamWord::HandleLo(n) => n.map_or(0, |n| handles[n].to_words()[0]),
                ParamWord::HandleHi(n) => n.map_or(0, |n| handles[n].to_words()[1]),
            })
            .collect();
        // Uniform blocks are sized in 16-byte units.
        params.resize(params.len().div_ceil(4).max(1) * 4, 0);
        let mut resources = Vec::new();
        let mut record_buffer = None;
        for b in &launch.buffers {
            let buffer = owned.words(&b.words)?;
            resources.push(Resource::buffer(b.binding, buffer));
            if b.binding == case.record.binding {
                record_buffer = Some((buffer, b.words.len()));
            }
        }
        let (buffer, len) = record_buffer.ok_or_else(|| {
            Error::invalid(format!(
                "case {}: no record buffer at binding {}",
                case.name, case.record.binding
            ))
        })?;
        let [w, h, d] = launch.dims;
        device.launch(
            pipeline,
            bytemuck::cast_slice(&params),
            &resources,
            &table,
            LaunchSize::new(w, h, d),
        )?;
        device.synchronize()?;
        let mut out = vec![0u8; len * 4];
        device.read_buffer(buffer, 0, &mut out)?;
        results.push(
            out.chunks_exact(4)
                .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect(),
        );
    }
    Ok(results)
}
