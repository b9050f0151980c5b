//! One misuse, one message: every user misuse of the host API in this catalog gives the same
//! error, kind and message, on every backend (DESIGN.md §1, `optik-core`).
//!
//! Each case runs on a fresh device of each backend, so handles carry the same slots and
//! generations everywhere; device numbers differ between devices and are blanked before the
//! messages are compared. A backend that cannot run here is skipped and named.

use optik::*;

/// WGSL with a raygen, a miss and a closest-hit program; the raygen reads `params` and an
/// output buffer so that launches have bindings to get wrong.
const WGSL: &str = r#"
struct Params { value: u32, pad0: u32, pad1: u32, pad2: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
fn raygen__main() {
    out[rt_launch_index().x] = params.value;
}
fn miss__main() {
    rt_set_payload(0u, 1u);
}
fn closesthit__main() {
    rt_set_payload(0u, 2u);
}
"#;

/// A misuse: sets up what it needs on the device and returns the misused call's result.
type Misuse = fn(&dyn Device, &dyn Device) -> Result<()>;

fn module(d: &dyn Device) -> Result<Module> {
    Ok(d.create_module(
        &ModuleCompileOptions::default(),
        &PipelineCompileOptions::default(),
        &ProgramSource::new("misuse.wgsl", WGSL),
    )?
    .0)
}

/// Raygen, miss and hit groups of [`WGSL`].
fn groups(d: &dyn Device) -> Result<Vec<ProgramGroup>> {
    let m = module(d)?;
    d.create_program_groups(&[
        ProgramGroupDesc::Raygen(ProgramRef::new(m, "raygen__main")),
        ProgramGroupDesc::Miss(Some(ProgramRef::new(m, "miss__main"))),
        ProgramGroupDesc::closest_hit(ProgramRef::new(m, "closesthit__main")),
    ])
}

fn pipeline(d: &dyn Device, groups: &[ProgramGroup]) -> Result<Pipeline> {
    d.create_pipeline(
        &PipelineCompileOptions::default(),
        &PipelineLinkOptions::default(),
        groups,
    )
}

/// A buffer holding `records` records of 32 bytes, each the header of the matching group.
fn records(d: &dyn Device, groups: &[ProgramGroup]) -> Result<Buffer> {
    let b = d.create_buffer(32 * groups.len().max(1) as u64)?;
    for (i, g) in groups.iter().enumerate() {
        let header = d.sbt_record_pack_header(*g)?;
        d.write_buffer(b, 32 * i as u64, &header)?;
    }
    Ok(b)
}

/// A shader binding table over [`groups`]: raygen record 0, miss record 1, hit record 2.
fn sbt(d: &dyn Device, groups: &[ProgramGroup]) -> Result<ShaderBindingTable> {
    let b = records(d, groups)?;
    Ok(ShaderBindingTable {
        raygen: SbtRecord {
            buffer: b,
            offset: 0,
        },
        exception: None,
        miss: Some(SbtRegion {
            buffer: b,
            offset: 32,
            stride: 32,
            count: 1,
        }),
        hitgroup: Some(SbtRegion {
            buffer: b,
            offset: 64,
            stride: 32,
            count: 1,
        }),
        callables: None,
    })
}

/// A pipeline, its SBT and a well-formed launch's params and resources.
struct Launch {
    pipeline: Pipeline,
    sbt: ShaderBindingTable,
    params: [u8; 16],
    out: Buffer,
}

fn launch_setup(d: &dyn Device) -> Result<Launch> {
    let g = groups(d)?;
    Ok(Launch {
        pipeline: pipeline(d, &g)?,
        sbt: sbt(d, &g)?,
        params: [0; 16],
        out: d.create_buffer(64)?,
    })
}

impl Launch {
    fn run(&self, d: &dyn Device, sbt: &ShaderBindingTable) -> Result<()> {
        d.launch(
            self.pipeline,
            &self.params,
            &[Resource::buffer(1, self.out)],
            sbt,
            LaunchSize::new(4, 1, 1),
        )?;
        d.synchronize()
    }
}

/// One triangle's vertices.
fn triangle(d: &dyn Device) -> Result<Buffer> {
    let b = d.create_buffer(36)?;
    let v: [f32; 9] = [0.0, 0.0, 1.0, 1.0, 0.0, 1.0, 0.0, 1.0, 1.0];
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
    d.write_buffer(b, 0, &bytes)?;
    Ok(b)
}

fn triangles(vertices: Buffer, n: u32) -> BuildInput {
    BuildInput::Triangles(TriangleArray::new(
        BufferView::new(vertices),
        n,
        GeometryFlags::NONE,
    ))
}

fn gas(d: &dyn Device, flags: BuildFlags) -> Result<Accel> {
    let v = triangle(d)?;
    d.accel_build(
        &AccelBuildOptions {
            flags,
            ..Default::default()
        },
        &[triangles(v, 3)],
    )
}

fn static_transform(d: &dyn Device) -> Result<Accel> {
    let child = d.traversable_handle(gas(d, BuildFlags::NONE)?)?;
    d.create_transform(&TransformDesc::Static {
        child,
        object_to_world: IDENTITY_3X4,
        world_to_object: IDENTITY_3X4,
    })
}

/// The catalog: each misuse, named.
fn catalog() -> Vec<(&'static str, Misuse)> {
    vec![
        // Handles: destroyed, and of another device.
        ("buffer.destroyed", |d, _| {
            let b = d.create_buffer(16)?;
            d.destroy_buffer(b)?;
            d.write_buffer(b, 0, &[0; 4])
        }),
        ("buffer.foreign", |d, other| {
            let b = other.create_buffer(16)?;
            d.read_buffer(b, 0, &mut [0; 4])
        }),
        ("buffer.destroyed_twice", |d, _| {
            let b = d.create_buffer(16)?;
            d.destroy_buffer(b)?;
            d.destroy_buffer(b)
        }),
        ("texture.destroyed", |d, _| {
            let t = d.create_texture(&TextureDesc {
                width: 2,
                height: 2,
                format: TextureFormat::Rgba8Unorm,
            })?;
            d.destroy_texture(t)?;
            d.write_texture(t, &[0; 16])
        }),
        ("accel.destroyed_handle", |d, _| {
            let a = gas(d, BuildFlags::NONE)?;
            d.destroy_accel(a)?;
            d.traversable_handle(a).map(drop)
        }),
        ("accel.foreign_size", |d, other| {
            let a = gas(other, BuildFlags::NONE)?;
            d.accel_size(a).map(drop)
        }),
        ("module.destroyed", |d, _| {
            let m = module(d)?;
            d.destroy_module(m)?;
            d.create_program_groups(&[ProgramGroupDesc::Raygen(ProgramRef::new(m, "raygen__main"))])
                .map(drop)
        }),
        ("group.destroyed_header", |d, _| {
            let g = groups(d)?;
            d.destroy_program_group(g[0])?;
            d.sbt_record_pack_header(g[0]).map(drop)
        }),
        ("pipeline.destroyed_features", |d, _| {
            let g = groups(d)?;
            let p = pipeline(d, &g)?;
            d.destroy_pipeline(p)?;
            d.pipeline_features(p).map(drop)
        }),
        ("micromap.destroyed", |d, _| {
            let a = d.create_opacity_micromap_array(&OpacityMicromapArrayDesc {
                micromaps: vec![OpacityMicromapDesc {
                    byte_offset: 0,
                    subdivision_level: 0,
                    format: OpacityMicromapFormat::TwoState,
                }],
                data: vec![1],
            })?;
            d.destroy_micromap_array(a)?;
            d.destroy_micromap_array(a)
        }),
        // Buffers and textures.
        ("buffer.write_out_of_range", |d, _| {
            let b = d.create_buffer(16)?;
            d.write_buffer(b, 8, &[0; 16])
        }),
        ("buffer.read_out_of_range", |d, _| {
            let b = d.create_buffer(16)?;
            d.read_buffer(b, 0, &mut [0; 17])
        }),
        ("buffer.offset_overflow", |d, _| {
            let b = d.create_buffer(16)?;
            d.write_buffer(b, u64::MAX, &[0; 2])
        }),
        ("texture.zero_size", |d, _| {
            d.create_texture(&TextureDesc {
                width: 0,
                height: 4,
                format: TextureFormat::R32Float,
            })
            .map(drop)
        }),
        ("texture.data_size", |d, _| {
            let t = d.create_texture(&TextureDesc {
                width: 2,
                height: 2,
                format: TextureFormat::Rgba32Float,
            })?;
            d.write_texture(t, &[0; 16])
        }),
        // Acceleration structures.
        ("accel.no_inputs", |d, _| {
            d.accel_build(&AccelBuildOptions::default(), &[]).map(drop)
        }),
        ("accel.build_with_update_operation", |d, _| {
            let v = triangle(d)?;
            d.accel_build(
                &AccelBuildOptions {
                    operation: BuildOperation::Update,
                    ..Default::default()
                },
                &[triangles(v, 3)],
            )
            .map(drop)
        }),
        ("accel.vertex_buffer_too_small", |d, _| {
            let v = triangle(d)?;
            d.accel_build(&AccelBuildOptions::default(), &[triangles(v, 6)])
                .map(drop)
        }),
        ("accel.foreign_vertex_buffer", |d, other| {
            let v = triangle(other)?;
            d.accel_build(&AccelBuildOptions::default(), &[triangles(v, 3)])
                .map(drop)
        }),
        ("accel.index_out_of_range", |d, _| {
            let v = triangle(d)?;
            let idx = d.create_buffer(12)?;
            d.write_buffer(idx, 0, &[0, 0, 0, 0, 1, 0, 0, 0, 7, 0, 0, 0])?;
            let input = TriangleArray::new(BufferView::new(v), 3, GeometryFlags::NONE)
                .with_indices(BufferView::new(idx), 1);
            d.accel_build(
                &AccelBuildOptions::default(),
                &[BuildInput::Triangles(input)],
            )
            .map(drop)
        }),
        ("accel.memory_usage_mixed_kinds", |d, _| {
            let v = triangle(d)?;
            let aabbs = d.create_buffer(24)?;
            d.accel_memory_usage(
                &AccelBuildOptions::default(),
                &[
                    triangles(v, 3),
                    BuildInput::CustomPrimitives(CustomPrimitiveArray::new(
                        BufferView::new(aabbs),
                        1,
                        GeometryFlags::NONE,
                    )),
                ],
            )
            .map(drop)
        }),
        ("accel.update_without_allow_update", |d, _| {
            let v = triangle(d)?;
            let a = d.accel_build(&AccelBuildOptions::default(), &[triangles(v, 3)])?;
            d.accel_update(
                a,
                &AccelBuildOptions {
                    operation: BuildOperation::Update,
                    ..Default::default()
                },
                &[triangles(v, 3)],
            )
        }),
        ("accel.update_a_transform", |d, _| {
            let t = static_transform(d)?;
            let v = triangle(d)?;
            d.accel_update(
                t,
                &AccelBuildOptions {
                    flags: BuildFlags::ALLOW_UPDATE,
                    operation: BuildOperation::Update,
                    ..Default::default()
                },
                &[triangles(v, 3)],
            )
        }),
        ("accel.compact_without_allow_compaction", |d, _| {
            let a = gas(d, BuildFlags::NONE)?;
            d.accel_compact(a).map(drop)
        }),
        ("accel.compact_a_transform", |d, _| {
            let t = static_transform(d)?;
            d.accel_compact(t).map(drop)
        }),
        ("transform.not_inverse", |d, _| {
            let child = d.traversable_handle(gas(d, BuildFlags::NONE)?)?;
            let mut scaled = IDENTITY_3X4;
            scaled[0] = 2.0;
            d.create_transform(&TransformDesc::Static {
                child,
                object_to_world: scaled,
                world_to_object: IDENTITY_3X4,
            })
            .map(drop)
        }),
        ("micromap.level_too_deep", |d, _| {
            d.create_opacity_micromap_array(&OpacityMicromapArrayDesc {
                micromaps: vec![OpacityMicromapDesc {
                    byte_offset: 0,
                    subdivision_level: MAX_MICROMAP_SUBDIVISION_LEVEL + 1,
                    format: OpacityMicromapFormat::TwoState,
                }],
                data: vec![0; 16],
            })
            .map(drop)
        }),
        // Programs and pipelines.
        ("module.too_many_payload_values", |d, _| {
            d.create_module(
                &ModuleCompileOptions::default(),
                &PipelineCompileOptions {
                    num_payload_values: Setting::Value(33),
                    ..Default::default()
                },
                &ProgramSource::new("misuse.wgsl", WGSL),
            )
            .map(drop)
        }),
        ("module.compile_error", |d, _| {
            d.create_module(
                &ModuleCompileOptions::default(),
                &PipelineCompileOptions::default(),
                &ProgramSource::new("bad.wgsl", "fn raygen__x() {\n    let a: u32 = 1.5;\n}\n"),
            )
            .map(drop)
        }),
        ("group.missing_program", |d, _| {
            let m = module(d)?;
            d.create_program_groups(&[ProgramGroupDesc::closest_hit(ProgramRef::new(
                m,
                "closesthit__nothere",
            ))])
            .map(drop)
        }),
        ("group.wrong_kind", |d, _| {
            let m = module(d)?;
            d.create_program_groups(&[ProgramGroupDesc::closest_hit(ProgramRef::new(
                m,
                "miss__main",
            ))])
            .map(drop)
        }),
        ("pipeline.no_groups", |d, _| pipeline(d, &[]).map(drop)),
        ("pipeline.no_raygen", |d, _| {
            let g = groups(d)?;
            pipeline(d, &g[1..]).map(drop)
        }),
        ("pipeline.destroyed_group", |d, _| {
            let g = groups(d)?;
            d.destroy_program_group(g[1])?;
            pipeline(d, &g).map(drop)
        }),
        ("pipeline.trace_depth_too_deep", |d, _| {
            let g = groups(d)?;
            d.create_pipeline(
                &PipelineCompileOptions::default(),
                &PipelineLinkOptions {
                    max_trace_depth: 40,
                    ..Default::default()
                },
                &g,
            )
            .map(drop)
        }),
        // Launches.
        ("launch.destroyed_pipeline", |d, _| {
            let l = launch_setup(d)?;
            d.destroy_pipeline(l.pipeline)?;
            l.run(d, &l.sbt)
        }),
        ("launch.params_too_short", |d, _| {
            let l = launch_setup(d)?;
            d.launch(
                l.pipeline,
                &[0; 4],
                &[Resource::buffer(1, l.out)],
                &l.sbt,
                LaunchSize::new(4, 1, 1),
            )
        }),
        ("launch.missing_resource", |d, _| {
            let l = launch_setup(d)?;
            d.launch(l.pipeline, &l.params, &[], &l.sbt, LaunchSize::new(4, 1, 1))
        }),
        ("launch.resource_out_of_range", |d, _| {
            let l = launch_setup(d)?;
            d.launch(
                l.pipeline,
                &l.params,
                &[Resource::Buffer {
                    binding: 1,
                    buffer: l.out,
                    offset: 0,
                    size: Some(128),
                }],
                &l.sbt,
                LaunchSize::new(4, 1, 1),
            )
        }),
        ("launch.destroyed_resource", |d, _| {
            let l = launch_setup(d)?;
            d.destroy_buffer(l.out)?;
            l.run(d, &l.sbt)
        }),
        ("launch.sbt_raygen_misaligned", |d, _| {
            let l = launch_setup(d)?;
            let mut sbt = l.sbt;
            sbt.raygen.offset = 8;
            l.run(d, &sbt)
        }),
        ("launch.sbt_raygen_out_of_range", |d, _| {
            let l = launch_setup(d)?;
            let mut sbt = l.sbt;
            sbt.raygen.offset = 96;
            l.run(d, &sbt)
        }),
        ("launch.sbt_stride_misaligned", |d, _| {
            let l = launch_setup(d)?;
            let mut sbt = l.sbt;
            sbt.hitgroup = sbt.hitgroup.map(|r| SbtRegion { stride: 40, ..r });
            l.run(d, &sbt)
        }),
        ("launch.sbt_region_out_of_range", |d, _| {
            let l = launch_setup(d)?;
            let mut sbt = l.sbt;
            sbt.hitgroup = sbt.hitgroup.map(|r| SbtRegion { count: 5, ..r });
            l.run(d, &sbt)
        }),
        ("launch.sbt_garbage_header", |d, _| {
            let l = launch_setup(d)?;
            d.write_buffer(l.sbt.raygen.buffer, 64, &[0xAB; 32])?;
            l.run(d, &l.sbt)
        }),
        ("launch.sbt_header_of_wrong_region", |d, _| {
            let l = launch_setup(d)?;
            // The miss group's header in the hit record.
            let mut header = [0; 32];
            d.read_buffer(l.sbt.raygen.buffer, 32, &mut header)?;
            d.write_buffer(l.sbt.raygen.buffer, 64, &header)?;
            l.run(d, &l.sbt)
        }),
        ("launch.sbt_header_of_foreign_group", |d, other| {
            let l = launch_setup(d)?;
            let foreign = groups(other)?;
            let header = other.sbt_record_pack_header(foreign[0])?;
            d.write_buffer(l.sbt.raygen.buffer, 0, &header)?;
            l.run(d, &l.sbt)
        }),
        ("launch.sbt_group_not_in_pipeline", |d, _| {
            let l = launch_setup(d)?;
            let stray = groups(d)?;
            let header = d.sbt_record_pack_header(stray[1])?;
            d.write_buffer(l.sbt.raygen.buffer, 32, &header)?;
            l.run(d, &l.sbt)
        }),
    ]
}

/// Blanks device numbers (`device #3`, `DeviceId(3)`): each case runs on its own devices.
fn normalise(message: &str) -> String {
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    while !rest.is_empty() {
        let prefix = ["device #", "DeviceId("]
            .into_iter()
            .find(|p| rest.starts_with(p));
        match prefix {
            Some(p) => {
                out.push_str(p);
                out.push('N');
                rest = rest[p.len()..].trim_start_matches(|c: char| c.is_ascii_digit());
            }
            None => {
                let c = rest.chars().next().unwrap_or_default();
                out.push(c);
                rest = &rest[c.len_utf8()..];
            }
        }
    }
    out
}

/// What a misuse gave on one backend: `Err((kind, normalised message))` or `Ok`.
fn outcome(kind: BackendKind, case: Misuse) -> Option<std::result::Result<(), String>> {
    let (Ok(d), Ok(other)) = (open_backend(kind), open_backend(kind)) else {
        return None;
    };
    let r = case(d.as_ref(), other.as_ref());
    // A misuse that reaches the driver is caught too late: the validation layer's messages
    // (OPTIK_VALIDATION=1) count against the case.
    let diagnostics = d.take_diagnostics();
    Some(match r {
        Ok(()) => Ok(()),
        Err(e) if diagnostics.is_empty() => {
            Err(format!("{:?}: {}", e.kind(), normalise(&e.to_string())))
        }
        Err(e) => Err(format!(
            "{:?}: {} (and the driver reported {diagnostics:?})",
            e.kind(),
            normalise(&e.to_string())
        )),
    })
}

#[test]
fn every_misuse_gives_one_error_on_every_backend() {
    let mut failures = Vec::new();
    let mut skipped = Vec::new();
    for (name, case) in catalog() {
        let mut seen: Vec<(BackendKind, std::result::Result<(), String>)> = Vec::new();
        for kind in BackendKind::ALL {
            match outcome(kind, case) {
                Some(r) => seen.push((kind, r)),
                None => skipped.push(kind),
            }
        }
        for (kind, r) in &seen {
            if r.is_ok() {
                failures.push(format!("{name}: {kind} accepted the misuse"));
            }
        }
        if let Some((first_kind, first)) = seen.first()
            && seen.iter().any(|(_, r)| r != first)
        {
            let mut lines = format!("{name}: the backends disagree\n");
            for (kind, r) in &seen {
                lines.push_str(&format!("    {kind}: {r:?}\n"));
            }
            let _ = first_kind;
            failures.push(lines);
        }
    }
    skipped.sort();
    skipped.dedup();
    for kind in &skipped {
        eprintln!("misuse: {kind} skipped (it cannot run here)");
    }
    assert!(
        failures.is_empty(),
        "{} of {} misuses:\n{}",
        failures.len(),
        catalog().len(),
        failures.join("\n")
    );
}

#[test]
fn device_numbers_are_blanked() {
    assert_eq!(
        normalise(
            "buffer handle RawHandle { device: DeviceId(12), slot: 0 } belongs to device #12, not to this device (device #3)"
        ),
        "buffer handle RawHandle { device: DeviceId(N), slot: 0 } belongs to device #N, not to this device (device #N)"
    );
}
