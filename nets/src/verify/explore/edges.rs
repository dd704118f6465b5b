//! The arcs of the reachability graph as the exploration finds them, kept
//! for the loop analysis (strongly connected components) so it need not
//! fire every transition again: for each stored marking of a partition, in
//! store order, its successors in the order they were fired (duplicates
//! kept).
//!
//! They are kept coded: each successor as a varint (7 bits a byte) of the
//! difference between its index and the previous successor's (the first
//! one's: the marking's own index), zigzag-coded, shifted left to make room
//! for the successor's partition. Breadth-first numbering keeps these
//! differences small: the new successors of a marking are stored one after
//! the other. About 1.5 to 2 bytes per arc instead of 4, plus 4 bytes per
//! marking for where its successors start.
//!
//! The successors of the markings of the level being explored are staged
//! as plain ids first: those in another partition are stored by that
//! partition's thread, which answers with their id at the end of the level
//! (until then their slot holds [`PENDING`]). [`Edges::seal`] codes them
//! once the level is complete.

use super::engine::split_id;

/// A slot whose successor id has not arrived yet.
pub const PENDING: u32 = u32::MAX;

/// One partition's arcs.
#[derive(Debug, Clone)]
pub struct Edges {
    /// Low bits of a coded successor naming its partition.
    part_bits: u32,
    /// Successor ids of the markings not coded yet, and how many each has.
    staged: Vec<u32>,
    counts: Vec<u32>,
    /// `starts[i]..starts[i + 1]`: the coded successors of marking `i`.
    starts: Vec<u32>,
    coded: Vec<u8>,
    /// More arcs than 32-bit offsets can hold, or a slot never answered:
    /// nothing is kept.
    overflow: bool,
    /// The partitions whose first marking is a successor here (one bit
    /// each): whether anything leads back to the initial marking.
    leads_to_first: u32,
}

/// Bits needed to name one of `parts` partitions.
pub fn part_bits(parts: usize) -> u32 {
    usize::BITS - parts.max(1).saturating_sub(1).leading_zeros()
}

impl Edges {
    /// Arcs of one of `parts` partitions.
    pub fn new(parts: usize) -> Edges {
        Edges {
            part_bits: part_bits(parts),
            staged: Vec::new(),
            counts: Vec::new(),
            starts: vec![0],
            coded: Vec::new(),
            overflow: false,
            leads_to_first: 0,
        }
    }

    /// Records that the next marking (in store order) has `k` successors,
    /// whose ids follow with [`Edges::push`].
    #[inline]
    pub fn node(&mut self, k: u32) {
        if !self.overflow {
            self.counts.push(k);
        }
    }

    /// Appends a successor id (or [`PENDING`]); returns its slot, for
    /// [`Edges::answer`] until the next [`Edges::seal`].
    #[inline]
    pub fn push(&mut self, id: u32) -> u32 {
        let slot = self.staged.len() as u32;
        if !self.overflow {
            if slot == PENDING {
                self.give_up();
            } else {
                self.staged.push(id);
            }
        }
        slot
    }

    /// Fills a [`PENDING`] slot.
    #[inline]
    pub fn answer(&mut self, slot: u32, id: u32) {
        if let Some(t) = self.staged.get_mut(slot as usize) {
            *t = id;
        }
    }

    /// Codes the staged successors (every slot answered); slots start again
    /// from 0.
    pub fn seal(&mut self) {
        if self.overflow {
            return;
        }
        let mut at = 0usize;
        let first = (self.starts.len() - 1) as u32;
        for (local, &k) in (first..).zip(&self.counts) {
            let Some(ids) = self.staged.get(at..at + k as usize) else {
                self.overflow = true;
                break;
            };
            at += k as usize;
            let mut prev = local;
            for &id in ids {
                if id == PENDING {
                    self.overflow = true;
                    break;
                }
                let (q, l) = split_id(id);
                if l == 0 {
                    self.leads_to_first |= 1 << q;
                }
                let d = i64::from(l) - i64::from(prev);
                prev = l;
                let zigzag = ((d << 1) ^ (d >> 63)) as u64;
                push_varint(&mut self.coded, (zigzag << self.part_bits) | q as u64);
            }
            match u32::try_from(self.coded.len()) {
                Ok(end) if !self.overflow => self.starts.push(end),
                _ => {
                    self.overflow = true;
                    break;
                }
            }
        }
        if self.overflow || at != self.staged.len() {
            self.give_up();
            return;
        }
        self.staged.clear();
        self.counts.clear();
    }

    fn give_up(&mut self) {
        self.overflow = true;
        self.staged = Vec::new();
        self.counts = Vec::new();
        self.starts = Vec::new();
        self.coded = Vec::new();
    }

    /// Whether the successors of all `nodes` markings are coded.
    pub fn complete(&self, nodes: u32) -> bool {
        !self.overflow && self.staged.is_empty() && self.starts.len() == nodes as usize + 1
    }

    /// Whether an arc kept here leads to the first marking of partition `q`.
    pub fn leads_to_first(&self, q: usize) -> bool {
        (self.leads_to_first >> q) & 1 == 1
    }

    /// Gives back the room reserved for more arcs and the staging buffers.
    pub fn shrink(&mut self) {
        self.staged = Vec::new();
        self.counts = Vec::new();
        self.starts.shrink_to_fit();
        self.coded.shrink_to_fit();
    }

    /// The successors of local marking `i`, whose partitions start at
    /// `offsets` in the dense numbering (all partitions one after the other).
    #[inline]
    pub fn targets<'a>(&'a self, i: u32, offsets: &'a [u32]) -> Targets<'a> {
        let (a, b) = (self.starts[i as usize], self.starts[i as usize + 1]);
        Targets {
            coded: &self.coded[a as usize..b as usize],
            prev: i,
            part_bits: self.part_bits,
            offsets,
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        ((self.starts.capacity() + self.staged.capacity() + self.counts.capacity()) * 4
            + self.coded.capacity()) as u64
    }

    /// Arcs coded so far.
    #[cfg(test)]
    pub fn coded_bytes(&self) -> usize {
        self.coded.len()
    }
}

#[inline]
fn push_varint(out: &mut Vec<u8>, mut x: u64) {
    while x >= 0x80 {
        out.push((x as u8) | 0x80);
        x >>= 7;
    }
    out.push(x as u8);
}

/// The successors of one marking as dense node numbers, decoded one by one.
#[derive(Debug, Clone)]
pub struct Targets<'a> {
    coded: &'a [u8],
    /// The local index of the previous successor (first: of the marking).
    prev: u32,
    part_bits: u32,
    offsets: &'a [u32],
}

impl Iterator for Targets<'_> {
    type Item = u32;

    #[inline]
    fn next(&mut self) -> Option<u32> {
        let (&first, mut rest) = self.coded.split_first()?;
        let mut x = u64::from(first & 0x7f);
        if first >= 0x80 {
            let mut shift = 7;
            while let Some((&b, r)) = rest.split_first() {
                rest = r;
                x |= u64::from(b & 0x7f) << shift;
                shift += 7;
                if b < 0x80 {
                    break;
                }
            }
        }
        self.coded = rest;
        let q = (x & ((1 << self.part_bits) - 1)) as usize;
        let zigzag = x >> self.part_bits;
        let d = ((zigzag >> 1) as i64) ^ -((zigzag & 1) as i64);
        let local = (i64::from(self.prev) + d) as u32;
        self.prev = local;
        Some(
            self.offsets
                .get(q)
                .copied()
                .unwrap_or(0)
                .wrapping_add(local),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::super::engine::state_id;
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn nodes_slots_answers_and_seals() {
        let mut e = Edges::new(2);
        e.node(2);
        assert_eq!(e.push(state_id(0, 7)), 0);
        assert_eq!(e.push(PENDING), 1);
        e.node(0);
        assert!(!e.complete(2));
        e.answer(1, state_id(1, 9));
        e.seal();
        assert!(e.complete(2));
        assert!(!e.leads_to_first(0));
        e.node(1);
        assert_eq!(e.push(state_id(0, 0)), 0);
        assert!(!e.complete(3));
        e.seal();
        assert!(e.complete(3));
        assert!(e.leads_to_first(0) && !e.leads_to_first(1));
        // partition 0 holds 20 markings, partition 1 starts at 20
        let offsets = [0, 20, 40];
        assert_eq!(e.targets(0, &offsets).collect::<Vec<_>>(), vec![7, 29]);
        assert_eq!(e.targets(1, &offsets).count(), 0);
        assert_eq!(e.targets(2, &offsets).collect::<Vec<_>>(), vec![0]);
    }

    #[test]
    fn successors_stored_one_after_the_other_take_a_byte_each() {
        // marking i of a level of 1000 has successors 1000 + 3i, +1, +2:
        // the first is 1000 + 2i past its marking (2 or 3 bytes), the
        // others one past the previous (1 byte)
        let mut e = Edges::new(1);
        for i in 0..1000u32 {
            e.node(3);
            for j in 0..3 {
                e.push(state_id(0, 1000 + 3 * i + j));
            }
        }
        e.seal();
        assert!(e.complete(1000));
        let firsts: usize = (0..1000u64)
            .map(|i| if 2 * (1000 + 2 * i) < 1 << 14 { 2 } else { 3 })
            .sum();
        assert_eq!(e.coded_bytes(), firsts + 2 * 1000);
        let offsets = [0, 4000];
        assert_eq!(
            e.targets(999, &offsets).collect::<Vec<_>>(),
            vec![3997, 3998, 3999]
        );
    }

    #[test]
    fn an_unanswered_slot_keeps_nothing() {
        let mut e = Edges::new(2);
        e.node(1);
        e.push(PENDING);
        e.seal();
        assert!(!e.complete(1));
    }

    proptest! {
        /// Any successor lists come back as they went in, on any number
        /// of partitions, level by level.
        #[test]
        fn successors_come_back(
            parts in 1usize..=16,
            lists in prop::collection::vec(
                prop::collection::vec((0usize..16, 0u32..(1 << 28) - 1), 0..12), 1..40),
            level in 1usize..8,
        ) {
            let lists: Vec<Vec<(usize, u32)>> = lists
                .into_iter()
                .map(|l| l.into_iter().map(|(q, i)| (q % parts, i)).collect())
                .collect();
            let mut e = Edges::new(parts);
            for chunk in lists.chunks(level) {
                for l in chunk {
                    e.node(l.len() as u32);
                    for &(q, i) in l {
                        e.push(state_id(q, i));
                    }
                }
                e.seal();
            }
            prop_assert!(e.complete(lists.len() as u32));
            // partitions far apart in the dense numbering
            let offsets: Vec<u32> = (0..=parts as u32).map(|p| p * 7).collect();
            for (i, l) in lists.iter().enumerate() {
                let want: Vec<u32> = l.iter().map(|&(q, x)| offsets[q].wrapping_add(x)).collect();
                prop_assert_eq!(e.targets(i as u32, &offsets).collect::<Vec<_>>(), want);
            }
        }
    }
}
