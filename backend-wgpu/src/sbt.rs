//! The shader binding table, read in OptiX's record layout from the user's buffers and
//! packed for the kernel.
//!
//! Records keep the user's layout and strides; each 32-byte header (packed by
//! `optik_api::SbtHeader`) is replaced by `(pipeline group index, group flags, 0 × 6)`, so
//! the kernel's `switch` selects the program and `rt_sbt_data_*` reads the data after the
//! header at the same offsets the user wrote it. Headers are checked on the host by
//! `optik_core::sbt::resolve_record_header`, the check every backend shares.

use crate::pipeline::PipelineObject;
use optik_api::{Buffer, Error, GroupRegion, Result, SBT_RECORD_HEADER_SIZE, ShaderBindingTable};

/// Bytes of data copied after a raygen or exception record's header: they have no stride,
/// so their data runs to the end of the buffer, capped as a record of the largest stride
/// (`properties().max_sbt_record_stride`, as the CPU backend does).
const SINGLE_RECORD_DATA_BYTES: u64 = (1 << 16) - 32;
/// Marks "no record" (as `_OPTIK_NONE` in the kernel).
pub(crate) const NONE: u32 = u32::MAX;

/// A packed table and where its regions are, in words.
pub(crate) struct PackedSbt {
    pub words: Vec<u32>,
    /// raygen, exception, hit base, hit stride, hit count, miss base, miss stride, miss
    /// count, callables base, stride, count, 0 (the kernel's `sbt0..sbt2`).
    pub regions: [u32; 12],
}

/// Packs `table` for `pipeline`; `bytes` gives a buffer's current contents.
pub(crate) fn pack(
    table: &ShaderBindingTable,
    pipeline: &PipelineObject,
    bytes: &mut dyn FnMut(Buffer) -> Result<Vec<u8>>,
) -> Result<PackedSbt> {
    let mut words = Vec::new();
    let mut cache: Vec<(Buffer, Vec<u8>)> = Vec::new();
    let mut record = |what: String,
                      buffer: Buffer,
                      offset: u64,
                      data_bytes: u64,
                      region: GroupRegion,
                      words: &mut Vec<u32>|
     -> Result<u32> {
        let region_stride = matches!(
            region,
            GroupRegion::Miss | GroupRegion::HitGroup | GroupRegion::Callables
        );
        if !cache.iter().any(|(b, _)| *b == buffer) {
            cache.push((buffer, bytes(buffer)?));
        }
        let data = &cache
            .iter()
            .find(|(b, _)| *b == buffer)
            .map(|(_, d)| d)
            .ok_or_else(|| Error::backend("SBT buffer cache"))?;
        let header_end = offset + SBT_RECORD_HEADER_SIZE as u64;
        let group = optik_core::sbt::resolve_record_header(
            &what,
            data,
            offset,
            region,
            pipeline.device,
            |h| pipeline.group_index.get(&h).copied(),
        )?;
        let at = words.len() as u32;
        words.push(group);
        words.push(pipeline.groups[group as usize].flags);
        words.extend_from_slice(&[0; 6]);
        let end = (header_end + data_bytes).min(data.len() as u64);
        let mut chunk = data[header_end as usize..end as usize].to_vec();
        // Records of a region keep their stride; single records keep what their buffer holds.
        let len = if region_stride {
            data_bytes
        } else {
            end - header_end
        };
        chunk.resize((len as usize).div_ceil(4) * 4, 0);
        words.extend(
            chunk
                .chunks_exact(4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        );
        Ok(at)
    };
    let raygen = record(
        "sbt.raygen".into(),
        table.raygen.buffer,
        table.raygen.offset,
        SINGLE_RECORD_DATA_BYTES,
        GroupRegion::Raygen,
        &mut words,
    )?;
    let exception = match &table.exception {
        Some(e) => record(
            "sbt.exception".into(),
            e.buffer,
            e.offset,
            SINGLE_RECORD_DATA_BYTES,
            GroupRegion::Exception,
            &mut words,
        )?,
        None => NONE,
    };
    let mut region = |name: &str,
                      r: &Option<optik_api::SbtRegion>,
                      kind: GroupRegion,
                      words: &mut Vec<u32>|
     -> Result<[u32; 3]> {
        let Some(r) = r else { return Ok([0, 8, 0]) };
        if r.count == 0 {
            return Ok([0, 8, 0]);
        }
        let base = words.len() as u32;
        let data_bytes = (r.stride - SBT_RECORD_HEADER_SIZE) as u64;
        for i in 0..r.count {
            record(
                format!("{name} record {i}"),
                r.buffer,
                r.offset + i as u64 * r.stride as u64,
                data_bytes,
                kind,
                words,
            )?;
        }
        Ok([base, r.stride / 4, r.count])
    };
    let hit = region(
        "sbt.hitgroup",
        &table.hitgroup,
        GroupRegion::HitGroup,
        &mut words,
    )?;
    let miss = region("sbt.miss", &table.miss, GroupRegion::Miss, &mut words)?;
    let call = region(
        "sbt.callables",
        &table.callables,
        GroupRegion::Callables,
        &mut words,
    )?;
    if words.len() > u32::MAX as usize / 2 {
        return Err(Error::limit("the shader binding table exceeds 8 GiB"));
    }
    Ok(PackedSbt {
        words,
        regions: [
            raygen, exception, hit[0], hit[1], hit[2], miss[0], miss[1], miss[2], call[0], call[1],
            call[2], 0,
        ],
    })
}
