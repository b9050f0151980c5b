//! The shader binding table (OptiX `OptixShaderBindingTable`) and its record headers.
//!
//! Users fill a buffer with records: a 32-byte header packed by `sbt_record_pack_header`,
//! then their own data. Every backend reads the user's table in this layout (the Vulkan
//! backend translates it into Vulkan's), so the header format is defined here, once.

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

impl ShaderBindingTable {
    /// The smallest table: three header-only records packed in `buffer` from offset 0, the
    /// raygen's, one miss record and one hit record (what a single-mesh ray caster needs).
    pub fn raygen_miss_hit(buffer: Buffer) -> ShaderBindingTable {
        let region = |offset: u64| SbtRegion {
            buffer,
            offset,
            stride: SBT_RECORD_HEADER_SIZE,
            count: 1,
        };
        ShaderBindingTable {
            raygen: SbtRecord { buffer, offset: 0 },
            exception: None,
            miss: Some(region(SBT_RECORD_HEADER_SIZE as u64)),
            hitgroup: Some(region(2 * SBT_RECORD_HEADER_SIZE as u64)),
            callables: None,
        }
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_smallest_table_packs_raygen_miss_and_hit_headers_in_order() {
        let b = Buffer::from_raw(RawHandle {
            device: DeviceId(7),
            slot: 1,
            generation: 2,
        });
        let t = ShaderBindingTable::raygen_miss_hit(b);
        assert_eq!((t.raygen.buffer, t.raygen.offset), (b, 0));
        let miss = t.miss.unwrap();
        let hit = t.hitgroup.unwrap();
        assert_eq!((miss.offset, miss.stride, miss.count), (32, 32, 1));
        assert_eq!((hit.offset, hit.stride, hit.count), (64, 32, 1));
        assert!(t.exception.is_none() && t.callables.is_none());
    }
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
}
