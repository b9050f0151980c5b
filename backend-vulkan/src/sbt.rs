//! The user's shader binding table (OptiX layout: 32-byte headers from
//! `sbt_record_pack_header`, 16-byte aligned records) translated into Vulkan's at launch.
//!
//! Each user record becomes a Vulkan record: the shader group handle of the group its header
//! names (the device's `shaderGroupHandleSize` bytes), then the user's data. Strides are the
//! user's data plus the handle, aligned to `shaderGroupHandleAlignment`; regions start on
//! `shaderGroupBaseAlignment`; strides past `maxShaderGroupStride` are an error that says
//! which stride to use. Regions (Vulkan indices):
//! - raygen: the raygen record;
//! - miss: the user's miss records `0..M`, a null record at `M` (misses with an index past the
//!   table run nothing), then the continuation callables of the user's callable records at
//!   `M + 1 + i` (continuation callables run as miss stages) and a null continuation;
//! - hit: the user's hit records, then null records up to the highest index a ray of the
//!   live scene can select (bounded), so an index past the table runs no program (or raises
//!   `INVALID_HIT_SBT` under debug exceptions) instead of reading past the buffer. Where the
//!   device mixes the driver's triangles with optik's, paths over boxes (every kind but the
//!   driver's triangles) select a second half starting at the device's `hit_half`: the same
//!   records with the triangle groups' procedural twins (docs/vulkan-backend.md §2.4), so
//!   each half serves one Vulkan geometry type;
//! - callable: the exception program at 0, the null callable at 1, the direct callables of
//!   the user's callable records from 2.
//!
//! Translations are cached per pipeline and keyed by the table, the buffers' generations and
//! the scene's reach, so a launch loop over an unchanged table reads nothing back.

use crate::buffer::snapshot_view;
use crate::device::Inner;
use crate::memory::{Allocator, GpuBuffer, Location};
use crate::objects::Objects;
use crate::pipeline::{GroupHandles, PipelineObject};
use crate::program::device_api::SBT_DATA_WORDS;
use ash::vk;
use optik_accel::decode::BufferBytes;
use optik_api::*;
use std::sync::Arc;

/// Null hit records added past the user's at most (bounded padding).
const MAX_HIT_PADDING: u64 = 1 << 16;
/// Cached translations per pipeline.
const CACHE_ENTRIES: usize = 4;

/// What decides a translation.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SbtKey {
    table: ShaderBindingTable,
    generations: Vec<(Buffer, u64)>,
    hit_reach: HitReach,
}

/// The hit record indices a ray of the live scene can select.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct HitReach {
    /// The largest index without the second half's offset.
    all: u64,
    /// Where paths over boxes select a second half: its start and the largest index (before
    /// the offset) they select.
    boxes: Option<(u64, u64)>,
}

/// A Vulkan shader binding table.
pub struct TranslatedSbt {
    key: SbtKey,
    buffer: GpuBuffer,
    /// The callable table of calls inlined into intersection and any-hit stages
    /// (program/inline.rs), a storage buffer: per callable record its direct callable's
    /// program id (or NONE) and the offset of its data, then the data words.
    pub callable_table: GpuBuffer,
    /// The raygen region.
    pub raygen: vk::StridedDeviceAddressRegionKHR,
    /// The miss region (misses, then continuation callables).
    pub miss: vk::StridedDeviceAddressRegionKHR,
    /// The hit group region.
    pub hit: vk::StridedDeviceAddressRegionKHR,
    /// The callable region (exception, null, direct callables).
    pub callable: vk::StridedDeviceAddressRegionKHR,
    /// The user's miss records.
    pub miss_count: u32,
    /// The user's callable records.
    pub callable_count: u32,
}

impl TranslatedSbt {
    /// Frees the buffers.
    pub fn destroy(self, ctx: &crate::context::Context, alloc: &mut Allocator) {
        self.buffer.destroy(ctx, alloc);
        self.callable_table.destroy(ctx, alloc);
    }
}

fn align(v: u64, a: u64) -> u64 {
    if a <= 1 { v } else { v.div_ceil(a) * a }
}

/// One record to write: a handle (or zeros) and data.
struct Record {
    handle: Option<Vec<u8>>,
    data: Vec<u8>,
}

/// A region to lay out.
struct Region {
    name: &'static str,
    records: Vec<Record>,
    /// The user's stride when records come from an array (for the error message).
    user_stride: Option<u32>,
}

/// Reads and checks user records.
struct Reader<'a> {
    bytes: &'a dyn BufferBytes,
    pipeline: &'a PipelineObject,
    /// The device whose groups headers must name.
    device: DeviceId,
}

impl Reader<'_> {
    /// The handles of the group a record's header names; checks the group is in the pipeline
    /// and belongs in `region`.
    fn header(
        &self,
        what: &str,
        buffer: Buffer,
        offset: u64,
        region: GroupRegion,
    ) -> Result<&GroupHandles> {
        let bytes = self.bytes.bytes(buffer)?;
        let handles = optik_core::sbt::resolve_record_header(
            what,
            bytes,
            offset,
            region,
            self.device,
            |h| self.pipeline.handles.get(&h).map(|(_, handles)| handles),
        )?;
        Ok(handles)
    }

    fn data(&self, buffer: Buffer, offset: u64, len: u64) -> Result<Vec<u8>> {
        let bytes = self.bytes.bytes(buffer)?;
        let start = (offset + sbt::SBT_RECORD_HEADER_SIZE as u64) as usize;
        let end = (start + len as usize).min(bytes.len());
        Ok(bytes
            .get(start..end)
            .map(|b| b.to_vec())
            .unwrap_or_default())
    }

    fn array(
        &self,
        what: &str,
        r: &SbtRegion,
        region: GroupRegion,
    ) -> Result<Vec<(GroupHandles, Vec<u8>)>> {
        (0..r.count)
            .map(|k| {
                let offset = r.offset + k as u64 * r.stride as u64;
                let handles = self
                    .header(&format!("{what} record {k}"), r.buffer, offset, region)?
                    .clone();
                let data = self.data(
                    r.buffer,
                    offset,
                    (r.stride - sbt::SBT_RECORD_HEADER_SIZE) as u64,
                )?;
                Ok((handles, data))
            })
            .collect()
    }
}

impl Inner {
    /// The Vulkan table for a launch of `pipeline` with `table`: cached, or translated now.
    pub fn translate_sbt(
        &mut self,
        objects: &mut Objects,
        pipeline: Pipeline,
        table: &ShaderBindingTable,
    ) -> Result<Arc<TranslatedSbt>> {
        let mut buffers = vec![table.raygen.buffer];
        buffers.extend(table.exception.iter().map(|r| r.buffer));
        buffers.extend(
            [table.miss, table.hitgroup, table.callables]
                .iter()
                .flatten()
                .map(|r| r.buffer),
        );
        buffers.sort();
        buffers.dedup();
        let mut generations = Vec::with_capacity(buffers.len());
        for b in &buffers {
            generations.push((*b, objects.buffers.get(*b)?.generation));
        }
        let box_offset = self.box_offset() as u64;
        let hit_reach = HitReach {
            all: objects
                .accels
                .iter()
                .map(|(_, a)| a.sbt_reach())
                .max()
                .unwrap_or(0),
            boxes: objects
                .accels
                .iter()
                .filter_map(|(_, a)| a.box_reach())
                .max()
                .filter(|_| box_offset > 0)
                .map(|r| (box_offset, r)),
        };
        let key = SbtKey {
            table: *table,
            generations,
            hit_reach,
        };
        if let Some(t) = objects
            .pipelines
            .get(pipeline)?
            .sbt_cache
            .iter()
            .find(|t| t.key == key)
        {
            return Ok(t.clone());
        }
        // Reading the table waits for launches that may write it.
        let snapshot_buffers = buffers.clone();
        let max_stride = self.ctx.info.max_shader_group_stride as u64;
        let handle_size = self.ctx.info.shader_group_handle_size as u64;
        let regions = {
            let downloaded = self.download_for_snapshot(&objects.buffers, &snapshot_buffers)?;
            let snapshot = snapshot_view(&objects.buffers, downloaded, &snapshot_buffers)?;
            let reader = Reader {
                bytes: &snapshot,
                pipeline: objects.pipelines.get(pipeline)?,
                device: pipeline.raw().device,
            };
            read_regions(
                &reader,
                table,
                hit_reach,
                max_stride.saturating_sub(handle_size),
            )?
        };
        let (regions, callable_words) = regions;
        let translated = self.lay_out(key, regions, callable_words, table)?;
        let p = objects.pipelines.get_mut(pipeline)?;
        let translated = Arc::new(translated);
        p.sbt_cache.insert(0, translated.clone());
        let evicted: Vec<Arc<TranslatedSbt>> = if p.sbt_cache.len() > CACHE_ENTRIES {
            p.sbt_cache.split_off(CACHE_ENTRIES)
        } else {
            Vec::new()
        };
        for t in evicted {
            // In-flight launches hold their table; the last holder frees it (launch.rs).
            if let Ok(t) = Arc::try_unwrap(t) {
                t.destroy(&self.ctx, &mut self.alloc);
            }
        }
        Ok(translated)
    }

    /// Writes the regions into a new buffer in Vulkan's layout.
    fn lay_out(
        &mut self,
        key: SbtKey,
        regions: [Region; 4],
        callable_words: Vec<u32>,
        table: &ShaderBindingTable,
    ) -> Result<TranslatedSbt> {
        let info = &self.ctx.info;
        let (hs, ha, ba, max_stride) = (
            info.shader_group_handle_size as u64,
            info.shader_group_handle_alignment.max(1) as u64,
            info.shader_group_base_alignment.max(1) as u64,
            info.max_shader_group_stride as u64,
        );
        let mut layout = Vec::with_capacity(4);
        let mut size = 0u64;
        for r in &regions {
            let data = r
                .records
                .iter()
                .map(|x| x.data.len() as u64)
                .max()
                .unwrap_or(0);
            let stride = align(hs + data, ha);
            if stride > max_stride {
                let advice = match r.user_stride {
                    Some(s) => format!(
                        " (user stride {s}); keep the stride at most {}",
                        (max_stride - hs + sbt::SBT_RECORD_HEADER_SIZE as u64) / 16 * 16
                    ),
                    None => String::new(),
                };
                return Err(Error::limit(format!(
                    "the {} region's records need {stride} bytes in Vulkan's table (a {hs}-byte handle and {data} bytes of data), more than this device's maxShaderGroupStride of {max_stride}{advice}",
                    r.name
                )));
            }
            let start = align(size, ba);
            size = start + stride * r.records.len() as u64;
            layout.push((start, stride));
        }
        let total = align(size, 16) + SBT_DATA_WORDS as u64 * 4;
        let mut bytes = vec![0u8; total as usize];
        for (r, (start, stride)) in regions.iter().zip(&layout) {
            for (k, rec) in r.records.iter().enumerate() {
                let at = (start + k as u64 * stride) as usize;
                if let Some(h) = &rec.handle {
                    bytes[at..at + h.len()].copy_from_slice(h);
                }
                let d = at + hs as usize;
                bytes[d..d + rec.data.len()].copy_from_slice(&rec.data);
            }
        }
        let buffer = GpuBuffer::new(
            &self.ctx,
            &mut self.alloc,
            total,
            vk::BufferUsageFlags::SHADER_BINDING_TABLE_KHR,
            Location::HostVisible,
            ba,
        )?;
        if let Err(e) = buffer.write(0, &bytes) {
            buffer.destroy(&self.ctx, &mut self.alloc);
            return Err(e);
        }
        let callable_bytes: Vec<u8> = bytemuck::cast_slice(&callable_words).to_vec();
        let callable_table = GpuBuffer::new(
            &self.ctx,
            &mut self.alloc,
            callable_bytes.len().max(16) as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            Location::HostVisible,
            16,
        );
        let callable_table = match callable_table.and_then(|t| match t.write(0, &callable_bytes) {
            Ok(()) => Ok(t),
            Err(e) => {
                t.destroy(&self.ctx, &mut self.alloc);
                Err(e)
            }
        }) {
            Ok(t) => t,
            Err(e) => {
                buffer.destroy(&self.ctx, &mut self.alloc);
                return Err(e);
            }
        };
        let region = |i: usize, n: usize| vk::StridedDeviceAddressRegionKHR {
            device_address: buffer.address + layout[i].0,
            stride: layout[i].1,
            size: layout[i].1 * n as u64,
        };
        let raygen = region(0, 1);
        let miss = region(1, regions[1].records.len());
        let hit = region(2, regions[2].records.len());
        let callable = region(3, regions[3].records.len());
        Ok(TranslatedSbt {
            key,
            raygen,
            miss,
            hit,
            callable,
            miss_count: table.miss.map_or(0, |m| m.count),
            callable_count: table.callables.map_or(0, |c| c.count),
            buffer,
            callable_table,
        })
    }
}

/// Reads the user's records into the four Vulkan regions, and the callable table of calls
/// inlined into intersection and any-hit stages.
fn read_regions(
    reader: &Reader,
    table: &ShaderBindingTable,
    hit_reach: HitReach,
    max_data: u64,
) -> Result<([Region; 4], Vec<u32>)> {
    let single_data = |buffer: Buffer, offset: u64| -> Result<Vec<u8>> {
        // A single record's data runs to the end of its buffer; Vulkan's record holds as much
        // of it as the largest stride allows.
        let len = reader.bytes.bytes(buffer)?.len() as u64;
        let available = len.saturating_sub(offset + sbt::SBT_RECORD_HEADER_SIZE as u64);
        reader.data(buffer, offset, available.min(max_data) / 4 * 4)
    };
    let p = reader.pipeline;
    let rg = reader.header(
        "sbt.raygen",
        table.raygen.buffer,
        table.raygen.offset,
        GroupRegion::Raygen,
    )?;
    let raygen = Region {
        name: "raygen",
        records: vec![Record {
            handle: rg.primary.clone(),
            data: single_data(table.raygen.buffer, table.raygen.offset)?,
        }],
        user_stride: None,
    };

    let mut miss = Region {
        name: "miss",
        records: Vec::new(),
        user_stride: table.miss.map(|m| m.stride),
    };
    if let Some(m) = &table.miss {
        for (handles, data) in reader.array("sbt.miss", m, GroupRegion::Miss)? {
            miss.records.push(Record {
                handle: handles.primary,
                data,
            });
        }
    }
    miss.records.push(Record {
        handle: None,
        data: Vec::new(),
    });
    let callables = match &table.callables {
        Some(c) => reader.array("sbt.callables", c, GroupRegion::Callables)?,
        None => Vec::new(),
    };
    if let Some(null_cc) = &p.null_continuation {
        for (handles, data) in &callables {
            miss.records.push(Record {
                handle: Some(
                    handles
                        .continuation
                        .clone()
                        .unwrap_or_else(|| null_cc.clone()),
                ),
                data: data.clone(),
            });
        }
        miss.records.push(Record {
            handle: Some(null_cc.clone()),
            data: Vec::new(),
        });
    }

    let mut hit = Region {
        name: "hit group",
        records: Vec::new(),
        user_stride: table.hitgroup.map(|h| h.stride),
    };
    let user_hits = match &table.hitgroup {
        Some(h) => reader.array("sbt.hitgroup", h, GroupRegion::HitGroup)?,
        None => Vec::new(),
    };
    for (handles, data) in &user_hits {
        hit.records.push(Record {
            handle: handles.primary.clone(),
            data: data.clone(),
        });
    }
    // Records past the user's: hits without programs, or raising INVALID_HIT_SBT under debug
    // exceptions (pipeline.rs).
    let user_count = user_hits.len() as u64;
    let padded = |reach: u64| (reach + 1).min(user_count + MAX_HIT_PADDING).max(1);
    while (hit.records.len() as u64) < padded(hit_reach.all) {
        hit.records.push(Record {
            handle: p.past_table.clone(),
            data: Vec::new(),
        });
    }
    // The second half, for paths over boxes: every path selects below its start without
    // the offset, so the gap is never selected (and records of the first half past it never
    // were). Pipelines that intersect no triangles have no twins: their groups' own stages
    // skip triangle candidates.
    if let Some((start, reach)) = hit_reach.boxes {
        hit.records.resize_with(start as usize, || Record {
            handle: None,
            data: Vec::new(),
        });
        for (handles, data) in user_hits {
            hit.records.push(Record {
                handle: handles.optik_triangles.or(handles.primary),
                data,
            });
        }
        while ((hit.records.len() as u64) - start) < padded(reach) {
            hit.records.push(Record {
                handle: p.past_table_optik.clone().or_else(|| p.past_table.clone()),
                data: Vec::new(),
            });
        }
    }

    let exception = match &table.exception {
        Some(e) => {
            let handles =
                reader.header("sbt.exception", e.buffer, e.offset, GroupRegion::Exception)?;
            Record {
                handle: handles.primary.clone(),
                data: single_data(e.buffer, e.offset)?,
            }
        }
        None => Record {
            handle: Some(p.null_callable.clone()),
            data: Vec::new(),
        },
    };
    let mut callable = Region {
        name: "callables",
        records: vec![
            exception,
            Record {
                handle: Some(p.null_callable.clone()),
                data: Vec::new(),
            },
        ],
        user_stride: table.callables.map(|c| c.stride),
    };
    let callable_words = callable_table(&callables);
    for (handles, data) in callables {
        callable.records.push(Record {
            handle: Some(handles.primary.unwrap_or_else(|| p.null_callable.clone())),
            data,
        });
    }
    Ok(([raygen, miss, hit, callable], callable_words))
}

/// The callable table (program/inline.rs): per record `[direct callable id or NONE, data
/// offset]`, then each record's data, padded so that clamped reads stay inside.
fn callable_table(callables: &[(GroupHandles, Vec<u8>)]) -> Vec<u32> {
    let mut header = Vec::with_capacity(2 * callables.len());
    let mut data: Vec<u32> = Vec::new();
    let start = 2 * callables.len() as u32;
    for (handles, bytes) in callables {
        header.push(
            handles
                .direct_id
                .unwrap_or(crate::program::device_api::NONE),
        );
        header.push(start + data.len() as u32);
        data.extend(
            bytes.chunks(4).map(|c| {
                u32::from_le_bytes(std::array::from_fn(|k| c.get(k).copied().unwrap_or(0)))
            }),
        );
    }
    header.extend(data);
    header.resize(header.len() + SBT_DATA_WORDS as usize, 0);
    header
}
