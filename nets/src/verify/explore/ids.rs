//! State ids: a stored marking's partition (its thread) and its index in
//! that partition, packed in 32 bits.

/// Bits of a state id naming its partition (so at most 16 threads).
pub const PART_BITS: u32 = 4;
pub const MAX_THREADS: usize = 1 << PART_BITS;
const LOCAL_BITS: u32 = 32 - PART_BITS;
/// Most markings one partition holds.
pub const MAX_PER_PARTITION: u32 = (1 << LOCAL_BITS) - 1;

/// A state id: partition and index in it.
#[inline]
pub fn state_id(part: usize, local: u32) -> u32 {
    ((part as u32) << LOCAL_BITS) | local
}

#[inline]
pub fn split_id(id: u32) -> (usize, u32) {
    ((id >> LOCAL_BITS) as usize, id & MAX_PER_PARTITION)
}
