//! The arcs of the reachability graph as the exploration finds them, kept
//! for the loop analysis (strongly connected components) so it need not
//! fire every transition again: for each stored marking of a partition, in
//! store order, its successors in the order they were fired (duplicates
//! kept).
//!
//! They are kept plain, 4 bytes per arc and 4 per marking for where its
//! successors start: the loop analysis reads every arc several times, and
//! a slice of numbers is read faster than any coding is decoded (a varint
//! coding of the differences took about 2 bytes per arc, but its coding and
//! decoding cost more time than the loop analysis has: BENCHMARKS.md).
//!
//! During the exploration a successor is its state id (partition and
//! index); those in another partition are stored by that partition's
//! thread, which answers with their ids at the end of the level, in the
//! order they were sent: the sender keeps their slots (until answered a
//! slot holds [`PENDING`]), and the mail carries the same records as an
//! exploration that keeps no arcs. Once every partition's size is known,
//! [`Edges::number`] turns the ids into dense node numbers (all partitions
//! one after the other).

use super::ids::split_id;
use super::store::prefetch;

/// A slot whose successor id has not arrived yet.
pub const PENDING: u32 = u32::MAX;

/// One partition's arcs.
#[derive(Debug, Clone)]
pub struct Edges {
    /// Successors, marking after marking: state ids, then dense numbers
    /// after [`Edges::number`].
    targets: Vec<u32>,
    /// `starts[i]..starts[i + 1]`: the successors of marking `i`.
    starts: Vec<u32>,
    /// Slots still [`PENDING`].
    unanswered: u64,
    /// More arcs than 32-bit offsets can hold: nothing is kept.
    overflow: bool,
    /// The partitions whose first marking is a successor here (one bit
    /// each): whether anything leads back to the initial marking.
    leads_to_first: u32,
}

impl Default for Edges {
    fn default() -> Self {
        Edges::new()
    }
}

impl Edges {
    pub fn new() -> Edges {
        Edges {
            targets: Vec::new(),
            starts: vec![0],
            unanswered: 0,
            overflow: false,
            leads_to_first: 0,
        }
    }

    /// Records that the next marking (in store order) has `k` successors,
    /// whose ids follow with [`Edges::push`].
    #[inline]
    pub fn node(&mut self, k: u32) {
        let end = self.starts.last().copied().unwrap_or(0);
        match end.checked_add(k) {
            Some(end) if end != PENDING => self.starts.push(end),
            _ => self.give_up(),
        }
    }

    /// Appends a successor id (or [`PENDING`]); returns its slot, for
    /// [`Edges::answer`].
    #[inline]
    pub fn push(&mut self, id: u32) -> u32 {
        let slot = self.targets.len() as u32;
        if id == PENDING {
            self.unanswered += 1;
        } else {
            self.note(id);
        }
        self.targets.push(id);
        slot
    }

    #[inline]
    fn note(&mut self, id: u32) {
        let (q, l) = split_id(id);
        if l == 0 {
            self.leads_to_first |= 1 << q;
        }
    }

    /// Fills a [`PENDING`] slot.
    #[inline]
    pub fn answer(&mut self, slot: u32, id: u32) {
        if let Some(t) = self.targets.get_mut(slot as usize) {
            if *t == PENDING && id != PENDING {
                *t = id;
                self.unanswered -= 1;
                self.note(id);
            }
        }
    }

    fn give_up(&mut self) {
        self.overflow = true;
        self.targets = Vec::new();
        self.starts = Vec::new();
    }

    /// Whether the successors of all `nodes` markings are kept, every slot
    /// answered.
    pub fn complete(&self, nodes: u32) -> bool {
        !self.overflow
            && self.unanswered == 0
            && self.starts.len() == nodes as usize + 1
            && self.starts.last().copied() == Some(self.targets.len() as u32)
    }

    /// Whether an arc kept here leads to the first marking of partition `q`.
    pub fn leads_to_first(&self, q: usize) -> bool {
        (self.leads_to_first >> q) & 1 == 1
    }

    /// Gives back the room reserved for more arcs.
    pub fn shrink(&mut self) {
        self.starts.shrink_to_fit();
        self.targets.shrink_to_fit();
    }

    /// Turns the state ids into dense node numbers, the partitions starting
    /// at `offsets` (all one after the other). False (and nothing kept)
    /// when an id names no partition.
    pub fn number(&mut self, offsets: &[u32]) -> bool {
        if offsets.len() <= 2 {
            // one partition: ids are indices in it
            return true;
        }
        for t in &mut self.targets {
            let (q, l) = split_id(*t);
            match offsets.get(q) {
                Some(&o) => *t = o.wrapping_add(l),
                None => {
                    self.give_up();
                    return false;
                }
            }
        }
        true
    }

    /// The successors of local marking `i` (dense numbers after
    /// [`Edges::number`]).
    #[inline]
    pub fn targets(&self, i: u32) -> &[u32] {
        let (a, b) = (self.starts[i as usize], self.starts[i as usize + 1]);
        &self.targets[a as usize..b as usize]
    }

    /// Where the successors of local markings `nodes` start, then where
    /// the last one's end (one more than `nodes`), and every successor
    /// kept: `None` for markings not kept.
    pub fn stretch(&self, nodes: std::ops::Range<u32>) -> Option<(&[u32], &[u32])> {
        let starts = self
            .starts
            .get(nodes.start as usize..nodes.end as usize + 1)?;
        Some((starts, &self.targets))
    }

    /// Every successor kept, marking after marking.
    pub fn all_targets(&self) -> &[u32] {
        &self.targets
    }

    /// The successors of local markings `nodes` (consecutive), all
    /// together; empty for markings not kept.
    pub fn span(&self, nodes: std::ops::Range<u32>) -> &[u32] {
        let at = |i: u32| self.starts.get(i as usize).map(|&s| s as usize);
        match (at(nodes.start), at(nodes.end)) {
            (Some(a), Some(b)) if a <= b => self.targets.get(a..b).unwrap_or_default(),
            _ => &[],
        }
    }

    /// A hint to load where the successors of local marking `i` start.
    #[inline]
    pub fn prefetch_start(&self, i: u32) {
        if let Some(s) = self.starts.get(i as usize) {
            prefetch(s);
        }
    }

    /// A hint to load the successors of local marking `i` (best once its
    /// start is loaded, see [`Edges::prefetch_start`]).
    #[inline]
    pub fn prefetch_targets(&self, i: u32) {
        if let Some(t) = self
            .starts
            .get(i as usize)
            .and_then(|&a| self.targets.get(a as usize))
        {
            prefetch(t);
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        ((self.starts.capacity() + self.targets.capacity()) * 4) as u64
    }
}

#[cfg(test)]
mod tests {
    use super::super::ids::state_id;
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn nodes_slots_answers_and_numbers() {
        let mut e = Edges::new();
        e.node(2);
        assert_eq!(e.push(state_id(0, 7)), 0);
        assert_eq!(e.push(PENDING), 1);
        e.node(0);
        assert!(!e.complete(2));
        e.answer(1, state_id(1, 9));
        assert!(e.complete(2));
        assert!(!e.leads_to_first(0));
        e.node(1);
        assert_eq!(e.push(state_id(0, 0)), 2);
        assert!(!e.complete(2));
        assert!(e.complete(3));
        assert!(e.leads_to_first(0) && !e.leads_to_first(1));
        // partition 0 holds 20 markings, partition 1 starts at 20
        assert!(e.number(&[0, 20, 40]));
        assert_eq!(e.targets(0), &[7, 29]);
        assert!(e.targets(1).is_empty());
        assert_eq!(e.targets(2), &[0]);
    }

    #[test]
    fn an_unanswered_slot_or_a_stray_id_keeps_nothing() {
        let mut e = Edges::new();
        e.node(1);
        e.push(PENDING);
        assert!(!e.complete(1));
        // an answer of PENDING answers nothing
        e.answer(0, PENDING);
        assert!(!e.complete(1));
        let mut e = Edges::new();
        e.node(1);
        e.push(state_id(5, 1));
        assert!(e.complete(1));
        assert!(!e.number(&[0, 3, 6]));
        assert!(!e.complete(1));
    }

    proptest! {
        /// Any successor lists come back as they went in, on any number
        /// of partitions, the other partitions' ids answered late.
        #[test]
        fn successors_come_back(
            parts in 1usize..=16,
            lists in prop::collection::vec(
                prop::collection::vec((0usize..16, 0u32..(1 << 28) - 1), 0..12), 1..40),
        ) {
            let lists: Vec<Vec<(usize, u32)>> = lists
                .into_iter()
                .map(|l| l.into_iter().map(|(q, i)| (q % parts, i)).collect())
                .collect();
            let mut e = Edges::new();
            let mut late = Vec::new();
            for l in &lists {
                e.node(l.len() as u32);
                for &(q, i) in l {
                    if q == 0 {
                        e.push(state_id(q, i));
                    } else {
                        late.push((e.push(PENDING), state_id(q, i)));
                    }
                }
            }
            for (slot, id) in late {
                e.answer(slot, id);
            }
            prop_assert!(e.complete(lists.len() as u32));
            // partitions far apart in the dense numbering
            let offsets: Vec<u32> = (0..=parts as u32).map(|p| p * 7).collect();
            prop_assert!(e.number(&offsets));
            for (i, l) in lists.iter().enumerate() {
                let want: Vec<u32> = l.iter().map(|&(q, x)| offsets[q].wrapping_add(x)).collect();
                prop_assert_eq!(e.targets(i as u32), want.as_slice());
            }
        }
    }
}
