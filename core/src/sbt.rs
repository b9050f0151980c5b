//! The SBT record reader: every backend reads the user's record headers through
//! [`resolve_record_header`], so a wrong header gives the same error everywhere.

use optik_api::sbt::{SBT_RECORD_HEADER_SIZE, SbtHeader};
use optik_api::{DeviceId, Error, GroupRegion, RawHandle, Result};

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
    use optik_api::sbt::SbtHeader;
    use optik_api::{Handle, ProgramGroup};

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
