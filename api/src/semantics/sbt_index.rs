//! SBT record index math (DESIGN.md §2, OptiX's formula) and the bit widths that count.

/// Bits of `rt_trace`'s SBT offset and stride that count.
pub const SBT_OFFSET_STRIDE_MASK: u32 = 0xF;
/// Bits of `rt_trace`'s miss index that count.
pub const MISS_INDEX_MASK: u32 = 0xFFFF;
/// Bits of visibility masks that count.
pub const VISIBILITY_MASK_BITS: u32 = 0xFF;
/// Bits of an instance's SBT offset that count (Vulkan's 24-bit field).
pub const INSTANCE_SBT_OFFSET_MASK: u32 = 0xFF_FFFF;
/// Bits of an instance id that count (Vulkan's 24-bit custom index).
pub const INSTANCE_ID_MASK: u32 = 0xFF_FFFF;

/// The hit group record a candidate selects:
/// `instance.sbt_offset + (ray offset & 0xF) + sbt_gas_index × (ray stride & 0xF)`.
/// `instance_sbt_offset` is the sum over the instances on the path (0 without instances).
pub fn hit_record_index(
    instance_sbt_offset: u32,
    sbt_gas_index: u32,
    ray_offset: u32,
    ray_stride: u32,
) -> u64 {
    instance_sbt_offset as u64
        + (ray_offset & SBT_OFFSET_STRIDE_MASK) as u64
        + sbt_gas_index as u64 * (ray_stride & SBT_OFFSET_STRIDE_MASK) as u64
}

/// The miss record `rt_trace`'s miss index selects.
pub fn miss_record_index(miss_index: u32) -> u32 {
    miss_index & MISS_INDEX_MASK
}

/// Whether an instance is visible to a ray: the low 8 bits of both masks share a bit.
pub fn instance_visible(instance_mask: u32, ray_mask: u32) -> bool {
    instance_mask & ray_mask & VISIBILITY_MASK_BITS != 0
}

/// The SBT GAS index of a primitive: its build input's first record (the sum of the record
/// counts of earlier inputs) plus the primitive's per-primitive offset (0 without offsets).
pub fn sbt_gas_index(input_first_record: u32, primitive_offset: u32) -> u32 {
    input_first_record + primitive_offset
}

/// The first SBT GAS index of each build input, given each input's record count.
pub fn input_first_records(record_counts: &[u32]) -> Vec<u32> {
    let mut first = 0u32;
    record_counts
        .iter()
        .map(|&n| {
            let f = first;
            first = first.saturating_add(n);
            f
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cts_checkerboard_examples() {
        // CTS sbt.hit_index_grid: instance offset = index, offsets 0..3, strides 0..5.
        for inst in 0..4u32 {
            for gas in 0..3u32 {
                for off in 0..4u32 {
                    for stride in 0..6u32 {
                        assert_eq!(
                            hit_record_index(inst, gas, off, stride),
                            (inst + off + gas * stride) as u64
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn high_bits_ignored() {
        assert_eq!(hit_record_index(5, 2, 0x1F3, 0xFFF2), 5 + 3 + 2 * 2);
        assert_eq!(hit_record_index(0, 7, 0x10, 0x10), 0);
        assert_eq!(miss_record_index(0x1_0003), 3);
        assert_eq!(miss_record_index(0xFFFF_FFFF), 0xFFFF);
        assert!(!instance_visible(0x100, 0x1FF));
        assert!(instance_visible(0x101, 0x001));
        assert!(!instance_visible(0xFF, 0xF00));
    }

    #[test]
    fn per_primitive_offsets() {
        // Three inputs with 1, 3 and 2 records.
        let first = input_first_records(&[1, 3, 2]);
        assert_eq!(first, vec![0, 1, 4]);
        assert_eq!(sbt_gas_index(first[1], 2), 3);
        assert_eq!(sbt_gas_index(first[2], 1), 5);
        // A ray with stride 2 and offset 1 through instance offset 10 on GAS index 3.
        assert_eq!(hit_record_index(10, 3, 1, 2), 17);
    }
}
