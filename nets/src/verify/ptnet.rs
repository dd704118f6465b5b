//! Place/transition nets: places with initial markings, transitions with
//! weighted input (pre) and output (post) arcs. The model the PNML reader
//! produces and the explorers run.

/// A place of a P/T net.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Place {
    /// The PNML id (unique in the net).
    pub id: String,
    /// The name for people (the id when the file gives none).
    pub name: String,
    /// Tokens in the initial marking.
    pub initial: u32,
}

/// A transition of a P/T net, with its arcs as (place index, weight) pairs
/// sorted by place, one pair per place, weights at least 1.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Transition {
    /// The PNML id (unique in the net).
    pub id: String,
    /// The name for people (the id when the file gives none).
    pub name: String,
    /// Input arcs: tokens consumed from each place.
    pub pre: Vec<(usize, u32)>,
    /// Output arcs: tokens produced into each place.
    pub post: Vec<(usize, u32)>,
}

/// A place/transition net with its initial marking.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct PtNet {
    /// The PNML net id.
    pub id: String,
    /// The name for people (the id when the file gives none).
    pub name: String,
    pub places: Vec<Place>,
    pub transitions: Vec<Transition>,
}

impl PtNet {
    /// An empty net.
    pub fn new(id: impl Into<String>) -> PtNet {
        let id = id.into();
        PtNet {
            name: id.clone(),
            id,
            places: Vec::new(),
            transitions: Vec::new(),
        }
    }

    /// Adds a place and returns its index.
    pub fn add_place(&mut self, id: impl Into<String>, initial: u32) -> usize {
        let id = id.into();
        self.places.push(Place {
            name: id.clone(),
            id,
            initial,
        });
        self.places.len() - 1
    }

    /// Adds a transition with its arcs and returns its index. Arcs to the same
    /// place are merged (weights added); zero weights are dropped.
    pub fn add_transition(
        &mut self,
        id: impl Into<String>,
        pre: &[(usize, u32)],
        post: &[(usize, u32)],
    ) -> usize {
        let id = id.into();
        self.transitions.push(Transition {
            name: id.clone(),
            id,
            pre: normalize_arcs(pre),
            post: normalize_arcs(post),
        });
        self.transitions.len() - 1
    }

    /// The initial marking, one count per place.
    pub fn initial_marking(&self) -> Vec<u32> {
        self.places.iter().map(|p| p.initial).collect()
    }

    /// Whether `t` is enabled in `marking` (one count per place).
    pub fn enabled(&self, marking: &[u32], t: usize) -> bool {
        self.transitions[t]
            .pre
            .iter()
            .all(|&(p, w)| marking[p] >= w)
    }

    /// Fires enabled transition `t` in `marking`; `None` when a count would
    /// overflow u32.
    pub fn fire(&self, marking: &[u32], t: usize) -> Option<Vec<u32>> {
        let mut next = marking.to_vec();
        let tr = &self.transitions[t];
        for &(p, w) in &tr.pre {
            next[p] -= w;
        }
        for &(p, w) in &tr.post {
            next[p] = next[p].checked_add(w)?;
        }
        Some(next)
    }
}

/// Sorts arcs by place, merges duplicates by adding weights, drops zero weights.
pub fn normalize_arcs(arcs: &[(usize, u32)]) -> Vec<(usize, u32)> {
    let mut v = arcs.to_vec();
    v.sort_by_key(|&(p, _)| p);
    let mut out: Vec<(usize, u32)> = Vec::with_capacity(v.len());
    for (p, w) in v {
        match out.last_mut() {
            Some(last) if last.0 == p => last.1 = last.1.saturating_add(w),
            _ => out.push((p, w)),
        }
    }
    out.retain(|&(_, w)| w > 0);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arcs_are_merged_and_sorted() {
        assert_eq!(
            normalize_arcs(&[(3, 1), (1, 2), (3, 2), (2, 0)]),
            vec![(1, 2), (3, 3)]
        );
    }

    #[test]
    fn firing_moves_tokens() {
        let mut net = PtNet::new("n");
        let a = net.add_place("a", 2);
        let b = net.add_place("b", 0);
        let t = net.add_transition("t", &[(a, 2)], &[(b, 1), (a, 1)]);
        let m0 = net.initial_marking();
        assert!(net.enabled(&m0, t));
        let m1 = net.fire(&m0, t).unwrap();
        assert_eq!(m1, vec![1, 1]);
        assert!(!net.enabled(&m1, t));
    }
}
