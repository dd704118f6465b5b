//! Where an exploration keeps its markings: their bytes back to back in
//! fixed-size chunks (no parent links: counterexamples are rebuilt level by
//! level, see `explore::chain_to`), and an open
//! addressing hash table of 8-byte entries (32 bits of hash, index + 1)
//! with full comparison on a hash match. No allocation per state: the first
//! chunk grows by doubling (small nets stay small), later ones are allocated
//! whole.

/// States per chunk of the arena.
const CHUNK_BITS: u32 = 16;
const CHUNK: usize = 1 << CHUNK_BITS;
/// Smallest table (entries).
const MIN_TABLE: usize = 1024;

/// Outcome of [`Store::insert`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Inserted {
    New(u32),
    Old(u32),
    /// The store is at its limit; the marking was not stored.
    Full,
}

/// One partition's markings.
pub struct Store {
    width: usize,
    /// Bytes per stored marking (room for more per state later).
    record: usize,
    chunks: Vec<Vec<u8>>,
    len: u32,
    table: Vec<u64>,
    limit: u32,
}

impl Store {
    /// A store for markings of `width` bytes, holding at most `limit`.
    pub fn new(width: usize, limit: u32) -> Store {
        Store {
            width,
            record: width,
            chunks: Vec::new(),
            len: 0,
            table: vec![0; MIN_TABLE],
            limit,
        }
    }

    pub fn len(&self) -> u32 {
        self.len
    }

    /// Bytes held: arena chunks plus table.
    pub fn bytes(&self) -> u64 {
        (self.chunks.iter().map(Vec::capacity).sum::<usize>() + self.table.len() * 8) as u64
    }

    fn record_at(&self, index: u32) -> &[u8] {
        let i = index as usize;
        let at = (i & (CHUNK - 1)) * self.record;
        &self.chunks[i >> CHUNK_BITS][at..at + self.record]
    }

    /// The marking stored at `index`.
    pub fn get(&self, index: u32) -> &[u8] {
        &self.record_at(index)[..self.width]
    }

    /// Frees the hash table once no marking will be looked up again (the
    /// markings stay: counterexamples are rebuilt from them); later lookups
    /// find nothing.
    pub fn drop_table(&mut self) {
        self.table = Vec::new();
    }

    /// The index of `marking` (with hash `hash`) if stored.
    pub fn lookup(&self, marking: &[u8], hash: u64) -> Option<u32> {
        if self.table.is_empty() {
            return None;
        }
        let h = hash as u32;
        let mut slot = slot_of(h, self.table.len());
        loop {
            let e = self.table[slot];
            if e == 0 {
                return None;
            }
            if (e >> 32) as u32 == h && same(self.get(e as u32 - 1), marking) {
                return Some(e as u32 - 1);
            }
            slot = next_slot(slot, self.table.len());
        }
    }

    /// Asks the processor to fetch the table slot of `hash` (first step of
    /// a batch: the fetches of the whole batch overlap).
    #[inline]
    pub fn prefetch_slot(&self, hash: u64) {
        if self.table.is_empty() {
            return;
        }
        prefetch(&self.table[slot_of(hash as u32, self.table.len())]);
    }

    /// Asks the processor to fetch the first stored record with the same
    /// hash as `hash` (second step of a batch, once the slots are cached).
    #[inline]
    pub fn prefetch_record(&self, hash: u64) {
        if self.table.is_empty() {
            return;
        }
        let h = hash as u32;
        let mut slot = slot_of(h, self.table.len());
        for _ in 0..4 {
            let e = self.table[slot];
            if e == 0 {
                return;
            }
            if (e >> 32) as u32 == h {
                let i = (e as u32 - 1) as usize;
                let at = (i & (CHUNK - 1)) * self.record;
                if let Some(b) = self.chunks[i >> CHUNK_BITS].get(at) {
                    prefetch(b);
                }
                return;
            }
            slot = next_slot(slot, self.table.len());
        }
    }

    /// Stores `marking` (with hash `hash`) unless already there.
    #[inline]
    pub fn insert(&mut self, marking: &[u8], hash: u64) -> Inserted {
        let h = hash as u32;
        let mut slot = slot_of(h, self.table.len());
        loop {
            let e = self.table[slot];
            if e == 0 {
                break;
            }
            if (e >> 32) as u32 == h && same(self.get(e as u32 - 1), marking) {
                return Inserted::Old(e as u32 - 1);
            }
            slot = next_slot(slot, self.table.len());
        }
        if self.len >= self.limit {
            return Inserted::Full;
        }
        let index = self.len;
        let i = index as usize;
        if i >> CHUNK_BITS == self.chunks.len() {
            let whole = CHUNK * self.record;
            let capacity = if i == 0 {
                (64 * self.record).min(whole)
            } else {
                whole
            };
            self.chunks.push(Vec::with_capacity(capacity));
        }
        let chunk = &mut self.chunks[i >> CHUNK_BITS];
        if chunk.len() + self.record > chunk.capacity() {
            // only the first chunk grows: double it, up to a whole chunk
            let more = chunk.capacity().min(CHUNK * self.record - chunk.capacity());
            chunk.reserve_exact(more);
        }
        chunk.extend_from_slice(marking);
        self.table[slot] = (u64::from(h) << 32) | u64::from(index + 1);
        self.len += 1;
        if self.len as usize * 4 >= self.table.len() * 3 {
            self.grow();
        }
        Inserted::New(index)
    }

    /// Makes the table twice as large while small, then half as large again
    /// (less memory left unused), and places every entry again (in order:
    /// slots follow hash order, so the writes are sequential).
    fn grow(&mut self) {
        let len = self.table.len();
        let capacity = if len < 1 << 20 {
            2 * len
        } else {
            len + len / 2
        };
        let mut table = vec![0u64; capacity];
        touch_for_writing(&mut table);
        for &e in &self.table {
            if e != 0 {
                let mut slot = slot_of((e >> 32) as u32, capacity);
                while table[slot] != 0 {
                    slot = next_slot(slot, capacity);
                }
                table[slot] = e;
            }
        }
        self.table = table;
    }
}

/// Writes one word of every page of `table`, a fresh zeroed allocation,
/// before anything reads it. The system maps such memory on first touch: a
/// read first maps the shared zero page, and the first write then replaces
/// it (a second fault per page, and, while other threads of the process run
/// on other cores, a flush of their address translations by an interrupt
/// per page). The placing of entries reads each slot before writing it:
/// untouched, that cost a fifth of a two-thread exploration
/// (docs/benchmarks-history.md, stop 31). Written first, each page faults once.
fn touch_for_writing(table: &mut [u64]) {
    const WORDS_PER_PAGE: usize = 4096 / 8;
    for w in table.iter_mut().step_by(WORDS_PER_PAGE) {
        // an opaque zero: the compiler may not drop a store of the value
        // the allocation already holds
        *w = std::hint::black_box(0);
    }
}

/// The home slot of 32-bit hash `h` in a table of `capacity` entries
/// (multiply-shift: any capacity, order-preserving).
#[inline(always)]
fn slot_of(h: u32, capacity: usize) -> usize {
    ((u64::from(h) * capacity as u64) >> 32) as usize
}

#[inline(always)]
fn next_slot(slot: usize, capacity: usize) -> usize {
    if slot + 1 == capacity {
        0
    } else {
        slot + 1
    }
}

/// A hint to load the cache line holding `r`.
#[inline(always)]
pub(super) fn prefetch<T>(r: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is only a hint: it never faults, writes nothing and
    // the address comes from a live reference.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
            (r as *const T).cast(),
        )
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = r;
}

/// `a == b` for short slices of equal length, 8 bytes at a time, inlined.
#[inline(always)]
fn same(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    let mut ca = a.chunks_exact(8);
    let mut cb = b.chunks_exact(8);
    for (x, y) in (&mut ca).zip(&mut cb) {
        let mut wx = [0u8; 8];
        let mut wy = [0u8; 8];
        wx.copy_from_slice(x);
        wy.copy_from_slice(y);
        if wx != wy {
            return false;
        }
    }
    ca.remainder()
        .iter()
        .zip(cb.remainder())
        .all(|(x, y)| x == y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stores_finds_and_grows() {
        let mut s = Store::new(3, 1_000_000);
        for i in 0u32..100_000 {
            let m = i.to_le_bytes();
            // a poor hash on purpose: pairs of equal hashes
            let h = u64::from(i % 50_000).wrapping_mul(0x9e37_79b9_7f4a_7c15);
            assert_eq!(s.insert(&m[..3], h), Inserted::New(i));
        }
        assert_eq!(s.len(), 100_000);
        for i in (0u32..100_000).step_by(7) {
            let m = i.to_le_bytes();
            let h = u64::from(i % 50_000).wrapping_mul(0x9e37_79b9_7f4a_7c15);
            assert_eq!(s.lookup(&m[..3], h), Some(i));
            assert_eq!(s.insert(&m[..3], h), Inserted::Old(i));
            assert_eq!(s.get(i), &m[..3]);
        }
        assert_eq!(s.lookup(&[1, 2, 200], 77), None);
        s.drop_table();
        assert_eq!(s.lookup(&[0, 0, 0], 0), None);
        assert_eq!(s.get(7), &7u32.to_le_bytes()[..3]);
    }

    #[test]
    fn the_limit_is_kept() {
        let mut s = Store::new(1, 2);
        assert_eq!(s.insert(&[1], 1), Inserted::New(0));
        assert_eq!(s.insert(&[2], 2), Inserted::New(1));
        assert_eq!(s.insert(&[3], 3), Inserted::Full);
        assert_eq!(s.insert(&[2], 2), Inserted::Old(1));
    }
}
