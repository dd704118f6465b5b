//! A compact binary encoding of the shared vocabulary — unsigned and signed
//! varints, strings, [`Value`]s, [`Params`] and [`Event`]s — for player
//! snapshots ([`crate::player::snapshot`]) and the ground mirror's downlink
//! records (the gateway). Documented in `docs/mirror.md`, "The encoding".
//!
//! Every value has exactly one encoding: varints are minimal, parameter
//! keys strictly increasing, booleans 0 or 1. A [`Reader`] refuses anything
//! else, so that decoding then encoding gives back the same bytes, and it
//! never panics, never allocates more than its input could hold and never
//! recurses deeper than [`MAX_DEPTH`].
//!
//! ```text
//! uvarint  LEB128, at most 10 bytes, no redundant trailing 0x00 group
//! ivarint  zigzag then uvarint
//! str      uvarint byte length, UTF-8
//! value    u8:0 u8 bool | u8:1 ivarint | u8:2 u64 LE float bits | u8:3 str
//!          | u8:4 uvarint n, value × n | u8:5 params
//! params   uvarint n, { str key, value } × n       keys strictly increasing
//! event    str name, u8 category (0 catastrophic … 4 nominal), params
//! ```

use crate::event::{Category, Event};
use crate::value::{Params, Value};

/// How deeply lists and maps may nest in a decoded value.
pub const MAX_DEPTH: usize = 16;

/// Why bytes do not decode.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    #[error("cut short at byte {0}")]
    Truncated(usize),
    #[error("{what} at byte {at}")]
    Invalid { what: &'static str, at: usize },
}

/// Appends encoded values to a byte vector.
#[derive(Debug, Default, Clone)]
pub struct Writer {
    pub bytes: Vec<u8>,
}

impl Writer {
    pub fn new() -> Writer {
        Writer::default()
    }

    pub fn u8(&mut self, v: u8) {
        self.bytes.push(v);
    }

    pub fn bool(&mut self, v: bool) {
        self.bytes.push(v.into());
    }

    /// Fixed eight bytes, little-endian.
    pub fn u64_le(&mut self, v: u64) {
        self.bytes.extend_from_slice(&v.to_le_bytes());
    }

    pub fn raw(&mut self, bytes: &[u8]) {
        self.bytes.extend_from_slice(bytes);
    }

    pub fn uvarint(&mut self, mut v: u64) {
        while v >= 0x80 {
            self.bytes.push((v as u8 & 0x7f) | 0x80);
            v >>= 7;
        }
        self.bytes.push(v as u8);
    }

    pub fn ivarint(&mut self, v: i64) {
        self.uvarint(((v << 1) ^ (v >> 63)) as u64);
    }

    /// A length or index.
    pub fn len(&mut self, n: usize) {
        self.uvarint(n as u64);
    }

    pub fn str(&mut self, s: &str) {
        self.len(s.len());
        self.bytes.extend_from_slice(s.as_bytes());
    }

    pub fn value(&mut self, v: &Value) {
        match v {
            Value::Bool(b) => {
                self.u8(0);
                self.bool(*b);
            }
            Value::Int(i) => {
                self.u8(1);
                self.ivarint(*i);
            }
            Value::Float(f) => {
                self.u8(2);
                self.u64_le(f.to_bits());
            }
            Value::Str(s) => {
                self.u8(3);
                self.str(s);
            }
            Value::List(l) => {
                self.u8(4);
                self.len(l.len());
                for v in l {
                    self.value(v);
                }
            }
            Value::Map(m) => {
                self.u8(5);
                self.params(m);
            }
        }
    }

    pub fn params(&mut self, params: &Params) {
        self.len(params.len());
        for (k, v) in params {
            self.str(k);
            self.value(v);
        }
    }

    pub fn event(&mut self, e: &Event) {
        self.str(&e.name);
        self.u8(e.category.priority() as u8);
        self.params(&e.params);
    }
}

/// Reads encoded values from a byte slice.
#[derive(Debug, Clone)]
pub struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    pub fn new(bytes: &'a [u8]) -> Reader<'a> {
        Reader { bytes, at: 0 }
    }

    /// The offset of the next byte.
    pub fn position(&self) -> usize {
        self.at
    }

    /// Bytes left.
    pub fn remaining(&self) -> usize {
        self.bytes.len() - self.at
    }

    pub fn is_empty(&self) -> bool {
        self.remaining() == 0
    }

    /// An error about what was read just before.
    pub fn invalid(&self, what: &'static str) -> DecodeError {
        DecodeError::Invalid { what, at: self.at }
    }

    /// Fails unless every byte was read.
    pub fn finish(&self) -> Result<(), DecodeError> {
        if self.is_empty() {
            Ok(())
        } else {
            Err(self.invalid("trailing bytes"))
        }
    }

    pub fn u8(&mut self) -> Result<u8, DecodeError> {
        let b = *self
            .bytes
            .get(self.at)
            .ok_or(DecodeError::Truncated(self.at))?;
        self.at += 1;
        Ok(b)
    }

    pub fn bool(&mut self) -> Result<bool, DecodeError> {
        match self.u8()? {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err(self.invalid("a boolean that is neither 0 nor 1")),
        }
    }

    pub fn raw(&mut self, n: usize) -> Result<&'a [u8], DecodeError> {
        if self.remaining() < n {
            return Err(DecodeError::Truncated(self.bytes.len()));
        }
        let s = &self.bytes[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }

    pub fn u64_le(&mut self) -> Result<u64, DecodeError> {
        let mut b = [0u8; 8];
        b.copy_from_slice(self.raw(8)?);
        Ok(u64::from_le_bytes(b))
    }

    pub fn uvarint(&mut self) -> Result<u64, DecodeError> {
        let mut v: u64 = 0;
        for i in 0..10 {
            let b = self.u8()?;
            let bits = u64::from(b & 0x7f);
            if i == 9 && b > 1 {
                return Err(self.invalid("a varint over 64 bits"));
            }
            v |= bits << (7 * i);
            if b & 0x80 == 0 {
                if b == 0 && i > 0 {
                    return Err(self.invalid("a varint not in its shortest form"));
                }
                return Ok(v);
            }
        }
        Err(self.invalid("a varint over 64 bits"))
    }

    pub fn ivarint(&mut self) -> Result<i64, DecodeError> {
        let u = self.uvarint()?;
        Ok(((u >> 1) as i64) ^ -((u & 1) as i64))
    }

    /// A count of items, each at least `min_item` bytes: never more than
    /// the bytes left could hold.
    pub fn count(&mut self, min_item: usize) -> Result<usize, DecodeError> {
        let n = self.uvarint()?;
        if n > (self.remaining() / min_item.max(1)) as u64 {
            return Err(self.invalid("a count larger than the bytes left"));
        }
        Ok(n as usize)
    }

    /// An index below `bound`.
    pub fn index(&mut self, bound: usize) -> Result<usize, DecodeError> {
        let v = self.uvarint()?;
        if v >= bound as u64 {
            return Err(self.invalid("an index out of range"));
        }
        Ok(v as usize)
    }

    pub fn str(&mut self) -> Result<String, DecodeError> {
        let n = self.count(1)?;
        let at = self.at;
        let s = std::str::from_utf8(self.raw(n)?)
            .map_err(|_| DecodeError::Invalid {
                what: "text that is not UTF-8",
                at,
            })?
            .to_owned();
        Ok(s)
    }

    pub fn value(&mut self) -> Result<Value, DecodeError> {
        self.value_at(0)
    }

    fn value_at(&mut self, depth: usize) -> Result<Value, DecodeError> {
        if depth > MAX_DEPTH {
            return Err(self.invalid("values nested too deeply"));
        }
        Ok(match self.u8()? {
            0 => Value::Bool(self.bool()?),
            1 => Value::Int(self.ivarint()?),
            2 => Value::Float(f64::from_bits(self.u64_le()?)),
            3 => Value::Str(self.str()?),
            4 => {
                let n = self.count(2)?;
                let mut l = Vec::with_capacity(n);
                for _ in 0..n {
                    l.push(self.value_at(depth + 1)?);
                }
                Value::List(l)
            }
            5 => Value::Map(self.params_at(depth + 1)?),
            _ => return Err(self.invalid("an unknown value tag")),
        })
    }

    pub fn params(&mut self) -> Result<Params, DecodeError> {
        self.params_at(0)
    }

    fn params_at(&mut self, depth: usize) -> Result<Params, DecodeError> {
        let n = self.count(3)?;
        let mut params = Params::new();
        let mut last: Option<String> = None;
        for _ in 0..n {
            let key = self.str()?;
            if last.as_ref().is_some_and(|l| *l >= key) {
                return Err(self.invalid("parameter keys out of order"));
            }
            let value = self.value_at(depth)?;
            last = Some(key.clone());
            params.insert(key, value);
        }
        Ok(params)
    }

    pub fn category(&mut self) -> Result<Category, DecodeError> {
        let c = self.u8()? as usize;
        Category::ALL
            .get(c)
            .copied()
            .ok_or_else(|| self.invalid("an unknown category"))
    }

    pub fn event(&mut self) -> Result<Event, DecodeError> {
        let name = self.str()?;
        let category = self.category()?;
        let params = self.params()?;
        Ok(Event {
            name,
            category,
            params,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn varints_round_trip_and_refuse_long_forms() {
        for v in [0u64, 1, 127, 128, 300, u32::MAX as u64, u64::MAX] {
            let mut w = Writer::new();
            w.uvarint(v);
            let mut r = Reader::new(&w.bytes);
            assert_eq!(r.uvarint(), Ok(v));
            assert!(r.is_empty());
        }
        for v in [0i64, -1, 1, i64::MIN, i64::MAX] {
            let mut w = Writer::new();
            w.ivarint(v);
            assert_eq!(Reader::new(&w.bytes).ivarint(), Ok(v));
        }
        // 0 written in two bytes, and an eleven-byte varint.
        assert!(Reader::new(&[0x80, 0x00]).uvarint().is_err());
        assert!(Reader::new(&[0xff; 11]).uvarint().is_err());
        assert!(
            Reader::new(&[0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x02])
                .uvarint()
                .is_err()
        );
        assert_eq!(
            Reader::new(&[0x80]).uvarint(),
            Err(DecodeError::Truncated(1))
        );
    }

    #[test]
    fn nesting_and_counts_are_bounded() {
        // A list of a list of … deeper than MAX_DEPTH.
        let mut bytes = Vec::new();
        for _ in 0..=MAX_DEPTH + 1 {
            bytes.extend_from_slice(&[4, 1]);
        }
        bytes.extend_from_slice(&[0, 1]);
        assert!(Reader::new(&bytes).value().is_err());
        // A list claiming a billion items in four bytes.
        assert!(Reader::new(&[4, 0x80, 0x94, 0xeb, 0xdc, 0x03])
            .value()
            .is_err());
        // Keys out of order.
        let mut w = Writer::new();
        w.len(2);
        w.str("b");
        w.value(&Value::Int(1));
        w.str("a");
        w.value(&Value::Int(2));
        assert!(Reader::new(&w.bytes).params().is_err());
    }
}
