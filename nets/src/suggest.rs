//! "Did you mean …?": the known name nearest a misspelt one, by edit
//! distance, offered only when it is close.

/// The Levenshtein distance between `a` and `b`, in characters (one
/// insertion, deletion or substitution each).
pub fn distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    // One row of the table: the distance of a's prefix to each of b's.
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let substitute = diagonal + usize::from(ca != cb);
            diagonal = row[j + 1];
            row[j + 1] = substitute.min(row[j] + 1).min(diagonal + 1);
        }
    }
    row[b.len()]
}

/// The candidate nearest `word`, if it is close enough to be the name
/// meant: at most one edit in four characters of `word` (at least one),
/// and never `word` itself. Ties go to the first candidate.
pub fn nearest<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let most = (word.chars().count() / 4).max(1);
    let mut best: Option<(usize, &str)> = None;
    for c in candidates {
        let d = distance(word, c);
        if d == 0 || d > most || best.is_some_and(|(b, _)| b <= d) {
            continue;
        }
        best = Some((d, c));
    }
    best.map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances() {
        assert_eq!(distance("engine_failur", "engine_failure"), 1);
        assert_eq!(distance("kitten", "sitting"), 3);
        assert_eq!(distance("", "abc"), 3);
        assert_eq!(distance("abc", ""), 3);
        assert_eq!(distance("same", "same"), 0);
        assert_eq!(distance("été", "ete"), 2);
    }

    #[test]
    fn only_a_close_name_is_suggested() {
        let known = ["engine_failure", "engine_restart", "takeoff", "go"];
        assert_eq!(nearest("engine_failur", known), Some("engine_failure"));
        assert_eq!(nearest("takeof", known), Some("takeoff"));
        // Far from everything, or the name itself: nothing.
        assert_eq!(nearest("battery_low", known), None);
        assert_eq!(nearest("takeoff", known), None);
        // Short names: one edit at most.
        assert_eq!(nearest("do", known), Some("go"));
        assert_eq!(nearest("xy", known), None);
    }
}
