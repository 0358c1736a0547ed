//! What the neighbour lists of the pairs ([`super::DiskPairs`]) and of the walls
//! ([`super::PersonShapes`]) share: where a list was built, how far the present people have
//! moved since, and when keeping lists pays.
//!
//! A list built at a configuration `anchor` holds every member with `gᵢ(anchor) ≤ reach`. A
//! member's value changes by at most how far its people (and its shape) moved since, since
//! `gᵢ` is a distance minus radii (1-Lipschitz in each centre), so the list holds every member
//! with `gᵢ(q) ≤ c` while `c +` (those displacements) `≤ reach`. Each query checks that afresh
//! from the anchor, whatever happened in between.

use super::Population;

/// The configuration a list was built at, and who was present then: a person absent then is in
/// no member of the list, so the list cannot answer where they are present.
#[derive(Debug, Default)]
pub(super) struct Anchor {
    q: Vec<f64>,
    listed: Vec<bool>,
    /// Presence at the configuration of the last call to [`moved`](Self::moved).
    present: Vec<bool>,
}

/// How far the present people have moved since the anchor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Moved {
    /// The two largest displacements `|qᵢ − anchorᵢ|` of present people, largest first.
    pub largest: [f64; 2],
    /// The largest `|xᵢ| + |yᵢ|` of a present person at the query: the scale of the rounding
    /// of anything computed from their position.
    pub extent: f64,
}

impl Anchor {
    /// Whether a list is built.
    pub fn is_set(&self) -> bool {
        !self.q.is_empty()
    }

    /// Drops the list's anchor: the next query builds anew.
    pub fn forget(&mut self) {
        self.q.clear();
    }

    /// The list is being built at `q` with the people `present`.
    pub fn set(&mut self, pop: &Population, q: &[f64], present: impl IntoIterator<Item = usize>) {
        self.q.clear();
        self.q.extend_from_slice(q);
        self.listed.clear();
        self.listed.resize(pop.len(), false);
        for i in present {
            self.listed[i] = true;
        }
    }

    /// Who is present at `q` (kept for [`present`](Self::present)) and how far they moved since
    /// the anchor; `None` when no anchor is set, `q` has another dimension, someone present now
    /// was absent at the anchor, or a position is not a number.
    pub fn moved(&mut self, pop: &Population, q: &[f64]) -> Option<Moved> {
        let n = pop.len();
        // No anchor (an empty one), or another dimension.
        if self.q.len() != 2 * n || q.len() != 2 * n {
            return None;
        }
        self.present.clear();
        // Squared displacements; the roots of the two largest at the end (monotone and
        // correctly rounded, so the same numbers as the two largest roots).
        let (mut top, mut extent) = ([0.0f64; 2], 0.0f64);
        for i in 0..n {
            let here = pop.is_present(q, i);
            self.present.push(here);
            if !here {
                continue;
            }
            if !self.listed[i] {
                return None;
            }
            let (x, y) = (q[2 * i], q[2 * i + 1]);
            let d = (x - self.q[2 * i]).powi(2) + (y - self.q[2 * i + 1]).powi(2);
            if d.is_nan() {
                return None; // a position that is not a number: nothing can be proven
            }
            keep_two_largest(&mut top, d);
            extent = extent.max(x.abs() + y.abs());
        }
        Some(Moved {
            largest: top.map(f64::sqrt),
            extent,
        })
    }

    /// Presence of each person at the configuration of the last [`moved`](Self::moved).
    pub fn present(&self) -> &[bool] {
        &self.present
    }
}

/// Keeps in `top` the two largest values seen, largest first (`d` is the next one).
pub(super) fn keep_two_largest(top: &mut [f64; 2], d: f64) {
    if d > top[0] {
        top[1] = top[0];
        top[0] = d;
    } else if d > top[1] {
        top[1] = d;
    }
}

/// How far beyond the cutoff `c ≥ 0` a list reaches: as far again as the cutoff (itself twice
/// a step's movement), and at least the largest radius: a crowd walking at its usual pace at
/// `h = 0.01` keeps a list for several steps, and the list holds a few times the members within
/// the cutoff, each tested again at a query for a few nanoseconds.
pub(super) fn skin(pop: &Population, cutoff: f64) -> f64 {
    cutoff.max(pop.max_radius())
}

/// A neighbour list: its policy and its anchor, for [`answer`].
pub(super) trait NeighbourSearch {
    fn policy_and_anchor(&mut self) -> (&mut ListPolicy, &mut Anchor);
}

/// One query to `list`: `true` when `select` answered it from the current list, or from one
/// that `rebuild` built at the query's configuration; `false` (nothing selected) when the
/// plain search should answer instead ([`ListPolicy`]).
pub(super) fn answer<L: NeighbourSearch>(
    list: &mut L,
    mut select: impl FnMut(&mut L) -> bool,
    rebuild: impl FnOnce(&mut L),
) -> bool {
    if list.policy_and_anchor().0.plain_turn() {
        return false;
    }
    if !select(list) {
        let (policy, anchor) = list.policy_and_anchor();
        if !policy.rebuild_now(anchor) {
            return false;
        }
        rebuild(list);
        if !select(list) {
            return false;
        }
    }
    list.policy_and_anchor().0.served();
    true
}

/// A list that answers fewer queries than this before it fails (a crowd moving a large part of
/// the skin each step: the jams at `h = 0.1`) costs more than the plain search, which then
/// answers the next [`PLAIN_SPELL`] queries before a list is tried again.
pub(super) const MIN_SERVED: usize = 3;
/// See [`MIN_SERVED`].
pub(super) const PLAIN_SPELL: usize = 8;

/// When keeping a list pays (see [`MIN_SERVED`]).
#[derive(Debug, Default)]
pub(super) struct ListPolicy {
    /// Queries the current list has answered.
    served: usize,
    /// Queries left to the plain search before a list is tried again.
    plain_left: usize,
    /// Lists built so far.
    builds: usize,
    /// Queries answered by a list so far.
    answered: usize,
}

impl ListPolicy {
    /// Whether the plain search answers this query (a spell after a list that did not pay).
    pub fn plain_turn(&mut self) -> bool {
        if self.plain_left > 0 {
            self.plain_left -= 1;
            true
        } else {
            false
        }
    }

    /// The list answered a query.
    pub fn served(&mut self) {
        self.served += 1;
        self.answered += 1;
    }

    /// The list (if `anchor` is set) could not answer: whether to build one now, or (`false`:
    /// the last list did not pay) to forget it and let the plain search answer for a spell.
    pub fn rebuild_now(&mut self, anchor: &mut Anchor) -> bool {
        if anchor.is_set() && self.served < MIN_SERVED {
            anchor.forget();
            self.plain_left = PLAIN_SPELL;
            return false;
        }
        true
    }

    /// A list was built.
    pub fn built(&mut self) {
        self.served = 0;
        self.builds += 1;
    }

    /// Lists built so far (read by the tests).
    #[cfg_attr(not(test), allow(dead_code))]
    pub fn builds(&self) -> usize {
        self.builds
    }

    /// Queries answered by a list so far (read by the tests).
    #[cfg_attr(not(test), allow(dead_code))]
    pub fn answered(&self) -> usize {
        self.answered
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::crowd::Room;

    /// The two largest displacements of present people (largest first, whoever comes first),
    /// the extent, and who is present; `None` without an anchor, for another dimension, for a
    /// person present now but absent at the anchor, and for a position that is not a number.
    #[test]
    fn moved_reports_the_two_largest_displacements_of_present_people() {
        let room = Room::rectangle(-100.0, -100.0, 100.0, 100.0);
        let pop = Population::new(vec![0.2; 4]).with_room(room);
        let at = [0.0, 0.0, 10.0, 0.0, 20.0, 0.0, 200.0, 0.0];
        let mut anchor = Anchor::default();
        assert_eq!(anchor.moved(&pop, &at), None);
        anchor.set(&pop, &at, [0, 1, 2]);
        // Person 1 moves 3, person 2 moves 4 (after 1), person 0 moves 1; person 3 is outside
        // the room and moves 50 (not counted).
        let q = [1.0, 0.0, 10.0, 3.0, 16.0, 0.0, 250.0, 0.0];
        let moved = anchor.moved(&pop, &q).expect("a proof");
        assert_eq!(moved.largest, [4.0, 3.0]);
        assert_eq!(moved.extent, 16.0);
        assert_eq!(anchor.present(), &[true, true, true, false]);
        // Largest first whatever the order they come in.
        let q = [1.0, 0.0, 10.0, 4.0, 17.0, 0.0, 250.0, 0.0];
        assert_eq!(anchor.moved(&pop, &q).unwrap().largest, [4.0, 3.0]);
        assert_eq!(anchor.moved(&pop, &q[..6]), None);
        // Without a room (where a position that is not a number is not a departure).
        let anywhere = Population::new(vec![0.2; 4]);
        let mut free = Anchor::default();
        free.set(&anywhere, &at, 0..4);
        let mut nan = q;
        nan[2] = f64::NAN;
        assert_eq!(free.moved(&anywhere, &nan), None);
        assert_eq!(free.moved(&anywhere, &q).unwrap().largest, [50.0, 4.0]);
        // Person 3 back inside (a new run), but absent at the anchor.
        pop.reset_departures();
        let mut back = q;
        back[6] = 50.0;
        assert_eq!(anchor.moved(&pop, &back), None);
        anchor.forget();
        assert!(!anchor.is_set());
        assert_eq!(anchor.moved(&pop, &q), None);
    }

    /// A list pays once it has answered `MIN_SERVED` queries: one that fails sooner is
    /// forgotten and the plain search answers the next `PLAIN_SPELL`; then a list is built again.
    #[test]
    fn the_policy_hands_a_spell_to_the_plain_search_after_a_list_that_did_not_pay() {
        let pop = Population::new(vec![0.2]);
        let mut anchor = Anchor::default();
        let mut policy = ListPolicy::default();
        // No list yet: build.
        assert!(!policy.plain_turn());
        assert!(policy.rebuild_now(&mut anchor));
        anchor.set(&pop, &[0.0, 0.0], [0]);
        policy.built();
        policy.served();
        // It fails at its second query: forgotten, and a spell of the plain search.
        assert!(!policy.plain_turn());
        assert!(!policy.rebuild_now(&mut anchor));
        assert!(!anchor.is_set());
        for _ in 0..PLAIN_SPELL {
            assert!(policy.plain_turn());
        }
        assert!(!policy.plain_turn());
        assert!(policy.rebuild_now(&mut anchor));
        anchor.set(&pop, &[0.0, 0.0], [0]);
        policy.built();
        for _ in 0..MIN_SERVED {
            assert!(!policy.plain_turn());
            policy.served();
        }
        // Paid: rebuilt when it fails, without a spell.
        assert!(policy.rebuild_now(&mut anchor));
        assert!(anchor.is_set());
        assert_eq!((policy.builds(), policy.answered()), (2, 1 + MIN_SERVED));
    }
}
