//! A plain, obviously correct explorer of a P/T net's token game: markings
//! as `Vec<u32>` in a `HashMap`, breadth first. Slow; the tests and the
//! benchmark compare [`super::explore`] with it.

use std::collections::{HashMap, VecDeque};

use super::ptnet::PtNet;

/// What the reference explorer computes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReferenceSummary {
    pub states: u64,
    /// (marking, enabled transition) pairs.
    pub edges: u64,
    pub dead_markings: u64,
    pub max_tokens: u32,
    /// No reachable marking puts more than one token in a place.
    pub safe: bool,
    /// Length of a shortest firing sequence to a dead marking.
    pub deadlock_depth: Option<usize>,
    /// Length of a shortest firing sequence to a marking that is not 1-safe.
    pub unsafe_depth: Option<usize>,
    /// Transitions enabled in no reachable marking.
    pub never_fired: Vec<usize>,
}

/// Explores every reachable marking; `None` when there are more than
/// `max_states` of them or a count overflows u32.
pub fn explore_reference(net: &PtNet, max_states: usize) -> Option<ReferenceSummary> {
    let initial = net.initial_marking();
    let mut depth: HashMap<Vec<u32>, usize> = HashMap::new();
    let mut queue = VecDeque::new();
    depth.insert(initial.clone(), 0);
    queue.push_back(initial);
    let mut s = ReferenceSummary {
        states: 0,
        edges: 0,
        dead_markings: 0,
        max_tokens: 0,
        safe: true,
        deadlock_depth: None,
        unsafe_depth: None,
        never_fired: Vec::new(),
    };
    let mut fired = vec![false; net.transitions.len()];
    while let Some(m) = queue.pop_front() {
        let d = depth[&m];
        s.states += 1;
        let most = m.iter().copied().max().unwrap_or(0);
        s.max_tokens = s.max_tokens.max(most);
        if most > 1 {
            s.safe = false;
            s.unsafe_depth = Some(s.unsafe_depth.map_or(d, |u| u.min(d)));
        }
        let mut enabled = 0;
        for (t, fired) in fired.iter_mut().enumerate() {
            if net.enabled(&m, t) {
                enabled += 1;
                *fired = true;
                let next = net.fire(&m, t)?;
                if !depth.contains_key(&next) {
                    if depth.len() >= max_states {
                        return None;
                    }
                    depth.insert(next.clone(), d + 1);
                    queue.push_back(next);
                }
            }
        }
        s.edges += enabled;
        if enabled == 0 {
            s.dead_markings += 1;
            s.deadlock_depth = Some(s.deadlock_depth.map_or(d, |u| u.min(d)));
        }
    }
    s.never_fired = fired
        .iter()
        .enumerate()
        .filter(|(_, &f)| !f)
        .map(|(t, _)| t)
        .collect();
    Some(s)
}
