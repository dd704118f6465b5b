//! The arcs of the reachability graph as the exploration finds them, kept
//! for the loop analysis (strongly connected components) so it need not
//! fire every transition again: for each stored marking of a partition, in
//! store order, the ids of its successors in the order they were fired
//! (duplicates kept). 4 bytes per arc plus 4 per marking.
//!
//! Successors in another partition are stored by that partition's thread,
//! which answers with their id at the end of the level: until then their
//! slot holds [`PENDING`].

/// A slot whose successor id has not arrived yet.
pub const PENDING: u32 = u32::MAX;

/// One partition's arcs, in compressed sparse row form.
#[derive(Debug, Clone)]
pub struct Edges {
    /// `starts[i]..starts[i + 1]`: the slots of marking `i`'s successors.
    starts: Vec<u32>,
    /// Successor ids (partition and index, see `engine::state_id`), later
    /// dense node numbers (see [`Edges::renumber`]).
    targets: Vec<u32>,
    /// More arcs than 32-bit slots can number: nothing is kept.
    overflow: bool,
}

impl Default for Edges {
    fn default() -> Self {
        Edges {
            starts: vec![0],
            targets: Vec::new(),
            overflow: false,
        }
    }
}

impl Edges {
    /// Records that the next marking (in store order) has `k` successors,
    /// whose ids follow with [`Edges::push`].
    #[inline]
    pub fn node(&mut self, k: u32) {
        let last = self.starts.last().copied().unwrap_or(0);
        match last.checked_add(k) {
            Some(end) if end != PENDING && !self.overflow => self.starts.push(end),
            _ => self.give_up(),
        }
    }

    /// Appends a successor id; returns its slot.
    #[inline]
    pub fn push(&mut self, id: u32) -> u32 {
        let slot = self.targets.len() as u32;
        if !self.overflow {
            self.targets.push(id);
        }
        slot
    }

    /// Fills a [`PENDING`] slot.
    #[inline]
    pub fn answer(&mut self, slot: u32, id: u32) {
        if let Some(t) = self.targets.get_mut(slot as usize) {
            *t = id;
        }
    }

    fn give_up(&mut self) {
        self.overflow = true;
        self.starts = Vec::new();
        self.targets = Vec::new();
    }

    /// Whether every successor of `nodes` markings is known.
    pub fn complete(&self, nodes: u32) -> bool {
        !self.overflow
            && self.starts.len() == nodes as usize + 1
            && self.starts.last().copied() == Some(self.targets.len() as u32)
    }

    /// Replaces state ids by dense numbers.
    pub fn renumber(&mut self, dense: impl Fn(u32) -> u32) {
        for t in &mut self.targets {
            *t = dense(*t);
        }
    }

    /// The successors of local marking `i`.
    #[inline]
    pub fn of(&self, i: u32) -> &[u32] {
        let i = i as usize;
        &self.targets[self.starts[i] as usize..self.starts[i + 1] as usize]
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        ((self.starts.capacity() + self.targets.capacity()) * 4) as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_slots_and_answers() {
        let mut e = Edges::default();
        e.node(2);
        assert_eq!(e.push(7), 0);
        assert_eq!(e.push(PENDING), 1);
        e.node(0);
        e.node(1);
        assert_eq!(e.push(3), 2);
        assert!(e.complete(3));
        assert!(!e.complete(2));
        e.answer(1, 9);
        assert_eq!(e.of(0), &[7, 9]);
        assert_eq!(e.of(1), &[] as &[u32]);
        e.renumber(|id| id + 1);
        assert_eq!(e.of(2), &[4]);
    }
}
