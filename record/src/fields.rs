//! Guards in front of the `mcap` crate's record parser: it reserves memory
//! for what a string's or a map's 4-byte length claims before reading it,
//! so one damaged length in a small file asks for gigabytes (found by
//! fuzzing `mcap_replay_read`: a Metadata record claiming a 4 GiB string).
//! A record is parsed only when every length inside it fits in the record.
//! The field layouts are the MCAP specification's.

use mcap::records::op;

/// Whether every length-prefixed field of a record (opcode, body) fits in
/// its body; records without such fields always do.
pub(super) fn lengths_fit(opcode: u8, data: &[u8]) -> bool {
    let mut f = Fields { data, at: 0 };
    let fits = match opcode {
        op::HEADER => f.string() && f.string(),
        op::SCHEMA => f.skip(2) && f.string() && f.string() && f.bytes32(),
        op::CHANNEL => f.skip(4) && f.string() && f.string() && f.bytes32(),
        op::METADATA => f.string() && f.bytes32(),
        op::ATTACHMENT => f.skip(16) && f.string() && f.string() && f.bytes64() && f.skip(4),
        op::METADATA_INDEX => f.skip(16) && f.string(),
        op::ATTACHMENT_INDEX => f.skip(40) && f.string() && f.string(),
        _ => true,
    };
    fits && f.maps_fit(opcode)
}

struct Fields<'a> {
    data: &'a [u8],
    at: usize,
}

impl Fields<'_> {
    fn skip(&mut self, n: usize) -> bool {
        match self.at.checked_add(n) {
            Some(end) if end <= self.data.len() => {
                self.at = end;
                true
            }
            _ => false,
        }
    }

    fn len(&mut self, width: usize) -> Option<usize> {
        let bytes = self.data.get(self.at..self.at.checked_add(width)?)?;
        self.at += width;
        let mut le = [0u8; 8];
        le[..width].copy_from_slice(bytes);
        usize::try_from(u64::from_le_bytes(le)).ok()
    }

    /// A string or a map: a 4-byte length, then that many bytes.
    fn string(&mut self) -> bool {
        self.len(4).is_some_and(|n| self.skip(n))
    }

    fn bytes32(&mut self) -> bool {
        self.string()
    }

    fn bytes64(&mut self) -> bool {
        self.len(8).is_some_and(|n| self.skip(n))
    }

    /// The strings inside the string maps of Channel and Metadata records
    /// (the map's own length was checked above): each key and value fits
    /// in the map.
    fn maps_fit(&self, opcode: u8) -> bool {
        let map = match opcode {
            op::CHANNEL => {
                let mut f = Fields {
                    data: self.data,
                    at: 0,
                };
                if !(f.skip(4) && f.string() && f.string()) {
                    return false;
                }
                f.at
            }
            op::METADATA => {
                let mut f = Fields {
                    data: self.data,
                    at: 0,
                };
                if !f.string() {
                    return false;
                }
                f.at
            }
            _ => return true,
        };
        let mut f = Fields {
            data: self.data,
            at: map,
        };
        let Some(n) = f.len(4) else { return false };
        let Some(end) = f.at.checked_add(n) else {
            return false;
        };
        let Some(body) = self.data.get(f.at..end) else {
            return false;
        };
        let mut m = Fields { data: body, at: 0 };
        while m.at < body.len() {
            if !(m.string() && m.string()) {
                return false;
            }
        }
        true
    }
}

/// Whether the file ends with a Footer that points at a summary (a clean
/// finish), read from the footer alone.
pub(super) fn has_summary(bytes: &[u8]) -> bool {
    // Footer: opcode, length 20, summary_start (u64) …, then the magic.
    let Some(start) = bytes.len().checked_sub(mcap::MAGIC.len() + 29) else {
        return false;
    };
    let footer = &bytes[start..];
    footer[0] == op::FOOTER
        && footer[1..9] == 20u64.to_le_bytes()
        && footer[9..17] != [0u8; 8]
        && &footer[29..] == mcap::MAGIC
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The record the fuzzer found: Metadata whose name claims 4 GiB.
    #[test]
    fn a_length_past_the_record_is_refused_before_parsing() {
        let mut body = Vec::new();
        body.extend_from_slice(&u32::MAX.to_le_bytes());
        body.extend_from_slice(b"petrel");
        assert!(!lengths_fit(op::METADATA, &body));
        // A map entry claiming more than its map.
        let mut body = Vec::new();
        body.extend_from_slice(&6u32.to_le_bytes());
        body.extend_from_slice(b"petrel");
        body.extend_from_slice(&9u32.to_le_bytes());
        body.extend_from_slice(&0xffff_fff0u32.to_le_bytes());
        body.extend_from_slice(b"layout");
        assert!(!lengths_fit(op::METADATA, &body));
        // A well-formed one.
        let mut body = Vec::new();
        body.extend_from_slice(&6u32.to_le_bytes());
        body.extend_from_slice(b"petrel");
        body.extend_from_slice(&15u32.to_le_bytes());
        body.extend_from_slice(&6u32.to_le_bytes());
        body.extend_from_slice(b"layout");
        body.extend_from_slice(&1u32.to_le_bytes());
        body.extend_from_slice(b"1");
        assert!(lengths_fit(op::METADATA, &body));
        assert!(mcap::parse_record(op::METADATA, &body).is_ok());
    }
}
