//! How markings are encoded and transitions fired, for the two engines:
//! [`Bits`] (1-safe nets: one bit per place) and [`Counts`] (a count of `W`
//! bytes per place). Both hash a marking as the wrapping sum of a random key
//! per token, so a firing changes the hash by a constant per transition.

use crate::verify::ptnet::PtNet;

/// Why an expansion stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// A firing would put a second token in a place (bit engine).
    Unsafe,
    /// A count would not fit its width (count engine).
    Overflow,
}

/// A marking encoding and its firing rule. Markings are stored as `width()`
/// bytes and worked on as little-endian 64-bit words (the bytes, padded
/// with zeros): see [`load_words`] and [`push_words`].
pub trait Semantics: Sync {
    /// Bytes per stored marking.
    fn width(&self) -> usize;
    /// Words per marking being worked on.
    fn words(&self) -> usize {
        self.width().div_ceil(8)
    }
    /// The hash key of a marking (before mixing).
    fn key(&self, m: &[u64]) -> u64;
    /// Calls `visit(transition, successor, successor key)` for each enabled
    /// transition; returns how many there were. `child` is scratch space.
    fn expand<V: FnMut(u32, &[u64], u64)>(
        &self,
        m: &[u64],
        key: u64,
        child: &mut Vec<u64>,
        visit: V,
    ) -> Result<u32, Stop>;
    /// The most tokens in one place of stored marking `m`.
    fn max_tokens(&self, m: &[u8]) -> u32;
    /// Tokens in each place of stored marking `m`.
    fn counts(&self, m: &[u8]) -> Vec<u32>;
    /// The stored form of a marking given by its counts; `None` when this
    /// engine cannot hold it.
    fn stored(&self, counts: &[u32]) -> Option<Vec<u8>>;
}

/// Reads stored bytes into words (the last one padded with zeros).
#[inline]
pub fn load_words(bytes: &[u8], out: &mut [u64]) {
    let mut chunks = bytes.chunks_exact(8);
    let mut i = 0;
    for c in &mut chunks {
        let mut w = [0u8; 8];
        w.copy_from_slice(c);
        out[i] = u64::from_le_bytes(w);
        i += 1;
    }
    let rest = chunks.remainder();
    if !rest.is_empty() {
        let mut w = [0u8; 8];
        w[..rest.len()].copy_from_slice(rest);
        out[i] = u64::from_le_bytes(w);
    }
}

/// Stored bytes as words.
pub fn to_words(bytes: &[u8]) -> Vec<u64> {
    let mut w = vec![0u64; bytes.len().div_ceil(8)];
    load_words(bytes, &mut w);
    w
}

/// Appends the bytes of `words` (8 each, little-endian) to `out`.
#[inline]
pub fn push_words(out: &mut Vec<u8>, words: &[u64]) {
    for w in words {
        out.extend_from_slice(&w.to_le_bytes());
    }
}

/// The stored form (`width` bytes) of words.
pub fn to_bytes(words: &[u64], width: usize) -> Vec<u8> {
    let mut b = Vec::with_capacity(words.len() * 8);
    push_words(&mut b, words);
    b.truncate(width);
    b
}

/// Mixes a key into a well-spread hash (MurmurHash3's finalizer).
#[inline]
pub fn mix(mut h: u64) -> u64 {
    h ^= h >> 33;
    h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
    h ^= h >> 33;
    h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    h ^ (h >> 33)
}

/// One random key per place (splitmix64, fixed seed: runs are repeatable).
fn place_keys(n: usize) -> Vec<u64> {
    let mut x = 0x5eed_0f9e_7e11_u64;
    (0..n)
        .map(|_| {
            x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = x;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^ (z >> 31)
        })
        .collect()
}

/// Lists of u32 by index, flattened.
#[derive(Debug, Clone, Default)]
struct Lists {
    offsets: Vec<u32>,
    items: Vec<u32>,
}

impl Lists {
    fn from(lists: &[Vec<u32>]) -> Lists {
        let mut l = Lists {
            offsets: vec![0],
            items: Vec::new(),
        };
        for v in lists {
            l.items.extend_from_slice(v);
            l.offsets.push(l.items.len() as u32);
        }
        l
    }
    #[inline]
    fn get(&self, i: usize) -> &[u32] {
        &self.items[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }
}

/// For each transition, the input place that decides when it is looked at:
/// the one marked least often according to `marked_frequency` (one count
/// per place; ties to the first). `None` for transitions without inputs.
fn triggers(
    net: &PtNet,
    marked_frequency: &[u64],
    usable: impl Fn(usize) -> bool,
) -> (Lists, Vec<u32>) {
    let mut by_place: Vec<Vec<u32>> = vec![Vec::new(); net.places.len()];
    let mut always = Vec::new();
    for (t, tr) in net.transitions.iter().enumerate() {
        if !usable(t) {
            continue;
        }
        match tr.pre.iter().min_by_key(|&&(p, _)| marked_frequency[p]) {
            Some(&(p, _)) => by_place[p].push(t as u32),
            None => always.push(t as u32),
        }
    }
    (Lists::from(&by_place), always)
}

// ---------------------------------------------------------------- bits

/// (word, mask) lists by index, flattened.
#[derive(Debug, Clone, Default)]
struct MaskLists {
    offsets: Vec<u32>,
    items: Vec<(u32, u64)>,
}

impl MaskLists {
    /// From lists of places: one (word, mask) pair per word touched.
    fn from(lists: &[Vec<u32>]) -> MaskLists {
        let mut l = MaskLists {
            offsets: vec![0],
            items: Vec::new(),
        };
        for v in lists {
            let mut pairs: Vec<(u32, u64)> = Vec::new();
            for &p in v {
                let (w, bit) = (p >> 6, 1u64 << (p & 63));
                match pairs.iter_mut().find(|e| e.0 == w) {
                    Some(e) => e.1 |= bit,
                    None => pairs.push((w, bit)),
                }
            }
            l.items.extend_from_slice(&pairs);
            l.offsets.push(l.items.len() as u32);
        }
        l
    }
    #[inline]
    fn get(&self, i: usize) -> &[(u32, u64)] {
        &self.items[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }
}

/// 1-safe markings: bit `p % 64` of word `p / 64` is place `p`.
pub struct Bits {
    places: usize,
    width: usize,
    /// Key sums per byte position (of the padded words) and byte value.
    byte_keys: Vec<[u64; 256]>,
    delta: Vec<u64>,
    clear: MaskLists,
    set: MaskLists,
    /// A transition whose firing always puts 2 tokens somewhere.
    overfull: Vec<bool>,
    /// For each place, the transitions it triggers, as (transition, range
    /// in `checks`): the (word, mask) pairs of their other input places.
    trigger_offsets: Vec<u32>,
    triggered: Vec<(u32, u32, u32)>,
    checks: Vec<(u32, u64)>,
    always: Vec<u32>,
}

impl Bits {
    pub fn new(net: &PtNet, marked_frequency: &[u64]) -> Bits {
        let n = net.places.len();
        let width = n.div_ceil(8);
        let keys = place_keys(n);
        let mut byte_keys = vec![[0u64; 256]; width.div_ceil(8) * 8];
        for (i, table) in byte_keys.iter_mut().enumerate() {
            for (b, slot) in table.iter_mut().enumerate() {
                *slot = (0..8)
                    .filter(|bit| b & (1 << bit) != 0 && i * 8 + bit < n)
                    .fold(0u64, |acc, bit| acc.wrapping_add(keys[i * 8 + bit]));
            }
        }
        let mut pre: Vec<Vec<u32>> = Vec::new();
        let mut clear = Vec::new();
        let mut set = Vec::new();
        let mut overfull = Vec::new();
        let mut delta = Vec::new();
        let mut usable = Vec::new();
        for tr in &net.transitions {
            let weight_in = |p: usize| tr.pre.iter().find(|a| a.0 == p).map_or(0, |a| a.1);
            let weight_out = |p: usize| tr.post.iter().find(|a| a.0 == p).map_or(0, |a| a.1);
            usable.push(tr.pre.iter().all(|&(_, w)| w == 1));
            pre.push(tr.pre.iter().map(|&(p, _)| p as u32).collect());
            clear.push(
                tr.pre
                    .iter()
                    .filter(|&&(p, _)| weight_out(p) == 0)
                    .map(|&(p, _)| p as u32)
                    .collect(),
            );
            set.push(
                tr.post
                    .iter()
                    .filter(|&&(p, _)| weight_in(p) == 0)
                    .map(|&(p, _)| p as u32)
                    .collect(),
            );
            overfull.push(tr.post.iter().any(|&(p, w)| w >= 2 && w > weight_in(p)));
            let mut d = 0u64;
            for &(p, w) in &tr.post {
                d = d.wrapping_add(keys[p].wrapping_mul(u64::from(w)));
            }
            for &(p, w) in &tr.pre {
                d = d.wrapping_sub(keys[p].wrapping_mul(u64::from(w)));
            }
            delta.push(d);
        }
        let (trigger, always) = triggers(net, marked_frequency, |t| usable[t]);
        let mut trigger_offsets = vec![0u32];
        let mut triggered = Vec::new();
        let mut checks: Vec<(u32, u64)> = Vec::new();
        for p in 0..n {
            for &t in trigger.get(p) {
                let lo = checks.len() as u32;
                let others: Vec<u32> = pre[t as usize]
                    .iter()
                    .copied()
                    .filter(|&q| q as usize != p)
                    .collect();
                checks.extend_from_slice(&MaskLists::from(&[others]).items);
                triggered.push((t, lo, checks.len() as u32));
            }
            trigger_offsets.push(triggered.len() as u32);
        }
        Bits {
            places: n,
            width,
            byte_keys,
            delta,
            clear: MaskLists::from(&clear),
            set: MaskLists::from(&set),
            overfull,
            trigger_offsets,
            triggered,
            checks,
            always,
        }
    }

    /// Encodes a marking whose counts are all 0 or 1 (stored form).
    pub fn encode(&self, counts: &[u32]) -> Vec<u8> {
        let mut m = vec![0u8; self.width];
        for (p, &c) in counts.iter().enumerate() {
            if c > 0 {
                m[p >> 3] |= 1 << (p & 7);
            }
        }
        m
    }

    #[inline]
    fn fire<V: FnMut(u32, &[u64], u64)>(
        &self,
        t: u32,
        m: &[u64],
        key: u64,
        child: &mut Vec<u64>,
        visit: &mut V,
    ) -> Result<(), Stop> {
        let ti = t as usize;
        if self.overfull[ti] {
            return Err(Stop::Unsafe);
        }
        child.clear();
        child.extend_from_slice(m);
        for &(w, mask) in self.clear.get(ti) {
            if let Some(x) = child.get_mut(w as usize) {
                *x &= !mask;
            }
        }
        for &(w, mask) in self.set.get(ti) {
            if let Some(x) = child.get_mut(w as usize) {
                if *x & mask != 0 {
                    return Err(Stop::Unsafe);
                }
                *x |= mask;
            }
        }
        visit(t, child, key.wrapping_add(self.delta[ti]));
        Ok(())
    }
}

impl Semantics for Bits {
    fn width(&self) -> usize {
        self.width
    }

    #[inline]
    fn key(&self, m: &[u64]) -> u64 {
        let mut k = 0u64;
        for (i, &w) in m.iter().enumerate() {
            let tables = &self.byte_keys[i * 8..i * 8 + 8];
            for (b, t) in tables.iter().enumerate() {
                k = k.wrapping_add(t[((w >> (8 * b)) & 0xff) as usize]);
            }
        }
        k
    }

    #[inline]
    fn expand<V: FnMut(u32, &[u64], u64)>(
        &self,
        m: &[u64],
        key: u64,
        child: &mut Vec<u64>,
        mut visit: V,
    ) -> Result<u32, Stop> {
        let mut enabled = 0u32;
        for &t in &self.always {
            enabled += 1;
            self.fire(t, m, key, child, &mut visit)?;
        }
        for (i, &word) in m.iter().enumerate() {
            let mut w = word;
            while w != 0 {
                let p = i * 64 + w.trailing_zeros() as usize;
                w &= w - 1;
                let (lo, hi) = (
                    self.trigger_offsets[p] as usize,
                    self.trigger_offsets[p + 1] as usize,
                );
                for &(t, a, b) in &self.triggered[lo..hi] {
                    let on = self.checks[a as usize..b as usize]
                        .iter()
                        .all(|&(j, mask)| m.get(j as usize).is_some_and(|&x| x & mask == mask));
                    if on {
                        enabled += 1;
                        self.fire(t, m, key, child, &mut visit)?;
                    }
                }
            }
        }
        Ok(enabled)
    }

    fn max_tokens(&self, m: &[u8]) -> u32 {
        u32::from(m.iter().any(|&b| b != 0))
    }

    fn counts(&self, m: &[u8]) -> Vec<u32> {
        (0..self.places)
            .map(|p| u32::from(m[p >> 3] >> (p & 7) & 1))
            .collect()
    }

    fn stored(&self, counts: &[u32]) -> Option<Vec<u8>> {
        (counts.len() == self.places && counts.iter().all(|&c| c <= 1)).then(|| self.encode(counts))
    }
}

// ---------------------------------------------------------------- counts

/// Markings as a count of `W` bytes (1, 2 or 4, little-endian) per place.
pub struct Counts<const W: usize> {
    places: usize,
    keys: Vec<u64>,
    delta: Vec<u64>,
    /// (place, weight) pairs.
    pre: Vec<Vec<(u32, u32)>>,
    /// (place, change) for every place whose count changes.
    change: Vec<Vec<(u32, i64)>>,
    trigger: Lists,
    always: Vec<u32>,
}

impl<const W: usize> Counts<W> {
    /// The largest count a place can hold.
    pub const MAX: u64 = if W >= 4 {
        u32::MAX as u64
    } else {
        (1u64 << (8 * W)) - 1
    };

    pub fn new(net: &PtNet, marked_frequency: &[u64]) -> Counts<W> {
        let keys = place_keys(net.places.len());
        let mut delta = Vec::new();
        let mut pre = Vec::new();
        let mut change = Vec::new();
        for tr in &net.transitions {
            let mut c: Vec<(u32, i64)> = Vec::new();
            for &(p, w) in &tr.pre {
                c.push((p as u32, -i64::from(w)));
            }
            for &(p, w) in &tr.post {
                match c.iter_mut().find(|e| e.0 == p as u32) {
                    Some(e) => e.1 += i64::from(w),
                    None => c.push((p as u32, i64::from(w))),
                }
            }
            c.retain(|e| e.1 != 0);
            delta.push(c.iter().fold(0u64, |d, &(p, k)| {
                d.wrapping_add(keys[p as usize].wrapping_mul(k as u64))
            }));
            pre.push(tr.pre.iter().map(|&(p, w)| (p as u32, w)).collect());
            change.push(c);
        }
        let (trigger, always) = triggers(net, marked_frequency, |_| true);
        Counts {
            places: net.places.len(),
            keys,
            delta,
            pre,
            change,
            trigger,
            always,
        }
    }

    #[inline]
    fn get(m: &[u8], p: usize) -> u64 {
        let mut v = 0u64;
        for (i, &b) in m[p * W..p * W + W].iter().enumerate() {
            v |= u64::from(b) << (8 * i);
        }
        v
    }

    #[inline]
    fn put(m: &mut [u8], p: usize, v: u64) {
        for (i, b) in m[p * W..p * W + W].iter_mut().enumerate() {
            *b = (v >> (8 * i)) as u8;
        }
    }

    /// Encodes a marking; `None` when a count does not fit.
    pub fn encode(&self, counts: &[u32]) -> Option<Vec<u8>> {
        let mut m = vec![0u8; self.places * W];
        for (p, &c) in counts.iter().enumerate() {
            if u64::from(c) > Self::MAX {
                return None;
            }
            Self::put(&mut m, p, u64::from(c));
        }
        Some(m)
    }

    #[inline]
    fn fire<V: FnMut(u32, &[u64], u64)>(
        &self,
        t: u32,
        m: &[u8],
        key: u64,
        child: &mut Vec<u8>,
        words: &mut Vec<u64>,
        visit: &mut V,
    ) -> Result<(), Stop> {
        child.clear();
        child.extend_from_slice(m);
        for &(p, k) in &self.change[t as usize] {
            let v = Self::get(m, p as usize) as i64 + k;
            if v as u64 > Self::MAX {
                return Err(Stop::Overflow);
            }
            Self::put(child, p as usize, v as u64);
        }
        words.clear();
        words.resize(child.len().div_ceil(8), 0);
        load_words(child, words);
        visit(t, words, key.wrapping_add(self.delta[t as usize]));
        Ok(())
    }
}

impl<const W: usize> Semantics for Counts<W> {
    fn width(&self) -> usize {
        self.places * W
    }

    fn key(&self, m: &[u64]) -> u64 {
        let m = to_bytes(m, self.width());
        (0..self.places).fold(0u64, |k, p| {
            k.wrapping_add(self.keys[p].wrapping_mul(Self::get(&m, p)))
        })
    }

    fn expand<V: FnMut(u32, &[u64], u64)>(
        &self,
        m: &[u64],
        key: u64,
        child: &mut Vec<u64>,
        mut visit: V,
    ) -> Result<u32, Stop> {
        let m = to_bytes(m, self.width());
        let mut scratch = Vec::with_capacity(m.len());
        let mut enabled = 0u32;
        for &t in &self.always {
            enabled += 1;
            self.fire(t, &m, key, &mut scratch, child, &mut visit)?;
        }
        for p in 0..self.places {
            if Self::get(&m, p) == 0 {
                continue;
            }
            for &t in self.trigger.get(p) {
                if self.pre[t as usize]
                    .iter()
                    .all(|&(q, w)| Self::get(&m, q as usize) >= u64::from(w))
                {
                    enabled += 1;
                    self.fire(t, &m, key, &mut scratch, child, &mut visit)?;
                }
            }
        }
        Ok(enabled)
    }

    fn max_tokens(&self, m: &[u8]) -> u32 {
        (0..self.places)
            .map(|p| Self::get(m, p) as u32)
            .max()
            .unwrap_or(0)
    }

    fn counts(&self, m: &[u8]) -> Vec<u32> {
        (0..self.places).map(|p| Self::get(m, p) as u32).collect()
    }

    fn stored(&self, counts: &[u32]) -> Option<Vec<u8>> {
        if counts.len() != self.places {
            return None;
        }
        self.encode(counts)
    }
}
