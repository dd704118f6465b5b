//! Long STATUSTEXTs put back together. MAVLink 2 sends a text longer than
//! 50 bytes as chunks of one `id` (non-zero), `chunk_seq` counting from 0;
//! a chunk holding a NUL byte (shorter than 50) is the last, so a text of
//! exactly 50 × n bytes ends with an empty chunk. `id` 0: a text of one
//! piece. PX4 does this ("RTL: start return at 505 m (15 m above
//! destination" then ")"); ArduPilot does too for its longer texts.
//!
//! Per sender, one text at a time (autopilots send a text's chunks back to
//! back): a chunk of another `id`, or out of sequence, drops the text
//! under way (a lost chunk must not glue two texts together); a text that
//! grows past [`MAX_CHUNKS`] chunks is cut there and given as it is.

/// The most chunks one text may have (2,000 bytes; MAVLink sets no limit).
pub const MAX_CHUNKS: u8 = 40;

/// What one STATUSTEXT chunk gives.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Piece {
    /// A text of one piece (`id` 0, or a single last chunk): as received.
    Whole,
    /// The last chunk of a longer text: the text put together.
    Joined(String),
    /// A chunk of a text not finished yet: nothing to say.
    Pending,
}

/// The text under way for one sender.
#[derive(Debug, Default, Clone)]
pub struct Joiner {
    /// (id, next chunk_seq expected, text so far).
    under_way: Option<(u16, u8, String)>,
}

impl Joiner {
    /// One chunk: `text` its bytes up to the first NUL, `last` whether it
    /// held a NUL (fewer than 50 bytes of text).
    pub fn push(&mut self, id: u16, chunk_seq: u8, text: &str, last: bool) -> Piece {
        if id == 0 {
            self.under_way = None;
            return Piece::Whole;
        }
        let mut so_far = match self.under_way.take() {
            Some((held, next, so_far)) if held == id && next == chunk_seq => so_far,
            // The first chunk of a new text (or a text resumed after a
            // lost chunk: its first part is gone, what is left is given).
            _ if chunk_seq == 0 => String::new(),
            _ => {
                // Out of sequence: its beginning was lost. Given alone if
                // it is the end, so that the reason is not lost with it.
                return if last {
                    Piece::Joined(format!("…{text}"))
                } else {
                    Piece::Pending
                };
            }
        };
        so_far.push_str(text);
        if last || chunk_seq + 1 >= MAX_CHUNKS {
            return if chunk_seq == 0 {
                Piece::Whole
            } else {
                Piece::Joined(so_far)
            };
        }
        self.under_way = Some((id, chunk_seq + 1, so_far));
        Piece::Pending
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FIFTY: &str = "RTL: start return at 505 m (15 m above destination";

    #[test]
    fn a_text_of_one_piece_is_given_as_received() {
        let mut j = Joiner::default();
        assert_eq!(j.push(0, 0, "Takeoff detected", true), Piece::Whole);
        // A non-zero id with a single, last chunk is one piece too.
        assert_eq!(j.push(7, 0, "Landing detected", true), Piece::Whole);
    }

    #[test]
    fn chunks_of_one_id_are_joined_on_the_last() {
        assert_eq!(FIFTY.len(), 50);
        let mut j = Joiner::default();
        assert_eq!(j.push(3, 0, FIFTY, false), Piece::Pending);
        assert_eq!(j.push(3, 1, ")", true), Piece::Joined(format!("{FIFTY})")));
        // Exactly 100 bytes: two full chunks and an empty last one.
        assert_eq!(j.push(4, 0, FIFTY, false), Piece::Pending);
        assert_eq!(j.push(4, 1, FIFTY, false), Piece::Pending);
        assert_eq!(
            j.push(4, 2, "", true),
            Piece::Joined(format!("{FIFTY}{FIFTY}"))
        );
    }

    #[test]
    fn a_lost_chunk_never_glues_two_texts_together() {
        let mut j = Joiner::default();
        // Chunk 1 of text 5 lost: its end comes alone, marked as cut.
        assert_eq!(j.push(5, 0, FIFTY, false), Piece::Pending);
        assert_eq!(j.push(5, 2, "end", true), Piece::Joined("…end".into()));
        // Another text's chunk drops the one under way.
        assert_eq!(j.push(6, 0, FIFTY, false), Piece::Pending);
        assert_eq!(j.push(8, 0, "Armed", true), Piece::Whole);
        assert_eq!(j.push(6, 1, "x", true), Piece::Joined("…x".into()));
        // A text of id 0 in the middle drops it too.
        assert_eq!(j.push(9, 0, FIFTY, false), Piece::Pending);
        assert_eq!(j.push(0, 0, "Disarmed", true), Piece::Whole);
        assert_eq!(j.push(9, 1, "y", false), Piece::Pending);
        assert_eq!(j.push(9, 2, "z", true), Piece::Joined("…z".into()));
    }

    #[test]
    fn a_text_that_never_ends_is_cut() {
        let mut j = Joiner::default();
        let mut last = Piece::Pending;
        for seq in 0..=255u8 {
            last = j.push(1, seq, FIFTY, false);
            if last != Piece::Pending {
                assert_eq!(seq, MAX_CHUNKS - 1);
                break;
            }
        }
        assert_eq!(last, Piece::Joined(FIFTY.repeat(usize::from(MAX_CHUNKS))));
    }
}
