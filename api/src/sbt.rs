//! The shader binding table (OptiX `OptixShaderBindingTable`) and its record headers.
//!
//! Users fill a buffer with records: a 32-byte header packed by `sbt_record_pack_header`,
//! then their own data. Every backend reads the user's table in this layout (the Vulkan
//! backend translates it into Vulkan's), so the header format is defined here, once.

use crate::error::{Error, Result};
use crate::handle::{Buffer, DeviceId, ProgramGroup, RawHandle};
use crate::program::GroupRegion;

/// Bytes of a record header (OptiX `OPTIX_SBT_RECORD_HEADER_SIZE`).
pub const SBT_RECORD_HEADER_SIZE: u32 = 32;
/// Alignment of records and strides (OptiX `OPTIX_SBT_RECORD_ALIGNMENT`).
pub const SBT_RECORD_ALIGNMENT: u32 = 16;

/// One record: where it starts in a buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SbtRecord {
    /// The buffer holding the record.
    pub buffer: Buffer,
    /// Byte offset of the record's header (16-byte aligned).
    pub offset: u64,
}

/// An array of equally spaced records.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SbtRegion {
    /// The buffer holding the records.
    pub buffer: Buffer,
    /// Byte offset of the first record (16-byte aligned).
    pub offset: u64,
    /// Bytes between records: a multiple of 16, at least the 32-byte header.
    pub stride: u32,
    /// Number of records.
    pub count: u32,
}

/// The shader binding table of a launch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ShaderBindingTable {
    /// The raygen record.
    pub raygen: SbtRecord,
    /// The exception record, if the pipeline has an exception program.
    pub exception: Option<SbtRecord>,
    /// Miss records, selected by `rt_trace`'s miss index.
    pub miss: Option<SbtRegion>,
    /// Hit group records, selected by the SBT index formula (DESIGN.md §2).
    pub hitgroup: Option<SbtRegion>,
    /// Callable records, selected by `rt_direct_call` / `rt_continuation_call`'s index.
    pub callables: Option<SbtRegion>,
}

const HEADER_MAGIC: u32 = u32::from_le_bytes(*b"OPTK");

/// What a record header identifies: a program group of one device.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SbtHeader {
    /// The program group.
    pub group: RawHandle,
    /// The SBT region the group's records belong in.
    pub region: GroupRegion,
}

fn region_code(region: GroupRegion) -> u32 {
    match region {
        GroupRegion::Raygen => 1,
        GroupRegion::Exception => 2,
        GroupRegion::Miss => 3,
        GroupRegion::HitGroup => 4,
        GroupRegion::Callables => 5,
    }
}

fn region_from_code(code: u32) -> Option<GroupRegion> {
    Some(match code {
        1 => GroupRegion::Raygen,
        2 => GroupRegion::Exception,
        3 => GroupRegion::Miss,
        4 => GroupRegion::HitGroup,
        5 => GroupRegion::Callables,
        _ => return None,
    })
}

impl SbtHeader {
    /// The 32 header bytes for `group` (OptiX `optixSbtRecordPackHeader`).
    pub fn pack(group: ProgramGroup, region: GroupRegion) -> [u8; 32] {
        use crate::handle::Handle;
        let raw = group.raw();
        let words = [
            HEADER_MAGIC,
            raw.device.0,
            raw.slot,
            raw.generation,
            region_code(region),
            // A check word, so that random bytes are not taken for a header.
            HEADER_MAGIC ^ raw.device.0 ^ raw.slot.rotate_left(8) ^ raw.generation.rotate_left(16),
            0,
            0,
        ];
        let mut out = [0u8; 32];
        for (i, w) in words.iter().enumerate() {
            out[i * 4..i * 4 + 4].copy_from_slice(&w.to_le_bytes());
        }
        out
    }

    /// Reads a header packed by [`SbtHeader::pack`]; `None` for bytes that are not one.
    pub fn unpack(bytes: &[u8]) -> Option<SbtHeader> {
        if bytes.len() < SBT_RECORD_HEADER_SIZE as usize {
            return None;
        }
        let w = |i: usize| u32::from_le_bytes(bytes[i * 4..i * 4 + 4].try_into().unwrap_or([0; 4]));
        let (magic, device, slot, generation, region, check) = (w(0), w(1), w(2), w(3), w(4), w(5));
        if magic != HEADER_MAGIC
            || check != HEADER_MAGIC ^ device ^ slot.rotate_left(8) ^ generation.rotate_left(16)
        {
            return None;
        }
        Some(SbtHeader {
            group: RawHandle {
                device: DeviceId(device),
                slot,
                generation,
            },
            region: region_from_code(region)?,
        })
    }
}

/// Reads the header of the record at byte `offset` of `bytes` (a buffer's contents) and
/// resolves its group with `lookup` (the pipeline's groups by handle). Every backend checks
/// headers here, so the same misuse gives the same error everywhere: a header outside the
/// buffer, bytes that are no header, a group of another device, a group of another region,
/// a group that is not one of the pipeline's. `what` names the record (`sbt.miss record 2`).
pub fn resolve_record_header<G>(
    what: &str,
    bytes: &[u8],
    offset: u64,
    region: GroupRegion,
    device: DeviceId,
    lookup: impl FnOnce(RawHandle) -> Option<G>,
) -> Result<G> {
    let header = usize::try_from(offset)
        .ok()
        .and_then(|start| bytes.get(start..start.checked_add(SBT_RECORD_HEADER_SIZE as usize)?))
        .ok_or_else(|| {
            Error::invalid(format!(
                "{what} (byte offset {offset}): the record's {SBT_RECORD_HEADER_SIZE}-byte header lies outside its buffer of {} bytes",
                bytes.len()
            ))
        })?;
    let h = SbtHeader::unpack(header).ok_or_else(|| {
        Error::invalid(format!(
            "{what} (byte offset {offset}): the first {SBT_RECORD_HEADER_SIZE} bytes hold no record header; write the bytes of sbt_record_pack_header(group) at the start of every record"
        ))
    })?;
    if h.group.device != device {
        return Err(Error::invalid(format!(
            "{what} (byte offset {offset}): the header names a program group of {}, not of this device ({device})",
            h.group.device
        )));
    }
    if h.region != region {
        return Err(Error::invalid(format!(
            "{what} (byte offset {offset}): the header names a {} group, but the record is in the {} region",
            h.region.name(),
            region.name()
        )));
    }
    lookup(h.group).ok_or_else(|| {
        Error::invalid(format!(
            "{what} (byte offset {offset}): the header names program group {:?}, which is not one of this pipeline's groups (pack headers for the live groups the pipeline was created with)",
            h.group
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::handle::Handle;

    #[test]
    fn header_round_trips_and_rejects_garbage() {
        let raw = RawHandle {
            device: DeviceId(42),
            slot: 3,
            generation: 9,
        };
        let group = ProgramGroup::from_raw(raw);
        let bytes = SbtHeader::pack(group, GroupRegion::HitGroup);
        let h = SbtHeader::unpack(&bytes).unwrap();
        assert_eq!(h.group, raw);
        assert_eq!(h.region, GroupRegion::HitGroup);
        let mut bad = bytes;
        bad[8] ^= 1;
        assert!(SbtHeader::unpack(&bad).is_none());
        assert!(SbtHeader::unpack(&[0u8; 32]).is_none());
        assert!(SbtHeader::unpack(&bytes[..16]).is_none());
    }

    #[test]
    fn record_headers_resolve_or_name_what_is_wrong() {
        let raw = RawHandle {
            device: DeviceId(7),
            slot: 1,
            generation: 0,
        };
        let mut buf = vec![0u8; 8];
        buf.extend(SbtHeader::pack(
            ProgramGroup::from_raw(raw),
            GroupRegion::Miss,
        ));
        let here = DeviceId(7);
        let found = |h: RawHandle| (h == raw).then_some(5u32);
        let ok = resolve_record_header("r", &buf, 8, GroupRegion::Miss, here, found);
        assert_eq!(ok.ok(), Some(5));
        let err = |offset, region, device, lookup: &dyn Fn(RawHandle) -> Option<u32>| {
            resolve_record_header("sbt.miss record 0", &buf, offset, region, device, lookup)
                .err()
                .map(|e| e.message().to_string())
                .unwrap_or_default()
        };
        assert!(
            err(16, GroupRegion::Miss, here, &found)
                .contains("lies outside its buffer of 40 bytes")
        );
        assert!(err(u64::MAX, GroupRegion::Miss, here, &found).contains("lies outside"));
        assert!(err(0, GroupRegion::Miss, here, &found).contains("hold no record header"));
        assert!(err(8, GroupRegion::Miss, DeviceId(8), &found).contains("not of this device"));
        assert!(
            err(8, GroupRegion::HitGroup, here, &found)
                .contains("names a miss group, but the record is in the hit group region")
        );
        let e = err(8, GroupRegion::Miss, here, &|_| None);
        assert!(
            e.starts_with("sbt.miss record 0 (byte offset 8)")
                && e.contains("not one of this pipeline's groups"),
            "{e}"
        );
    }
}
