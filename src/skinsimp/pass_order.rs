//! The order of one pass of [`Schedule::Passes`](super::Schedule::Passes): every edge once,
//! cheapest first, `(cost, a, b)` lexicographically — the same order the greedy queue pops in,
//! so ties never depend on the thread count.
//!
//! The lesson is one sentence: *sort the edges by cost*. The machinery is there because a pass
//! usually stops long before its last edge: only the edges up to the pass's stopping cost are
//! sorted at first, the rest in parts of doubling size if the pass gets to them
//! ([`PassOrder::sort_next_part`]). Each edge is one `u128` key (its cost's
//! [`f64::total_cmp`] rank above its ends, [`edge_key`]), so the sort needs no comparison
//! closure and the pass never looks up an entry at random.

use super::queue::Entry;

/// The order of one pass of [`passes`]: the edges by `(cost, a, b)`, sorted in parts: those
/// up to the pass's stopping cost when the pass starts, then, only if the pass goes on past
/// them, the next smallest keys in parts of growing size ([`PassOrder::sort_next_part`]).
///
/// An edge's key is its cost's [`f64::total_cmp`] rank ([`cost_rank`]) and its ends
/// ([`edge_key`]): the keys order the edges by `(cost, a, b)` in a plain sort of `u128`s, with
/// no comparison closure, and hold all a pass needs of an edge (its cost comes back from its
/// rank, [`rank_cost`]), so that the pass does not look up the entries at random.
#[derive(Default)]
pub(super) struct PassOrder {
    /// `cost rank << 64 | a << 32 | b`, sorted up to `sorted`.
    keys: Vec<u128>,
    /// Keys before this are sorted; the others all come after them.
    sorted: usize,
    /// The position of the next key to hand out.
    at: usize,
}

impl PassOrder {
    /// Start a pass over the queue entries of `parts` (the scored blocks' entries) wanting
    /// `goal` collapses: its stopping cost, `1.5 ×` the cost of the `goal`-th cheapest entry
    /// (the last if fewer; ∞ if none), with the keys up to it sorted.
    pub(super) fn start<'e>(
        &mut self,
        parts: impl Iterator<Item = &'e [Entry]>,
        goal: usize,
    ) -> f64 {
        self.keys.clear();
        for entries in parts {
            self.keys.extend(entries.iter().map(edge_key));
        }
        (self.at, self.sorted) = (0, 0);
        if self.keys.is_empty() {
            return f64::INFINITY;
        }
        let k = goal.min(self.keys.len() - 1);
        self.keys.select_nth_unstable(k);
        let stop = 1.5 * key_edge(self.keys[k]).0;
        let bound = u128::from(cost_rank(stop)) << 64 | u128::from(u64::MAX);
        // Those above the k-th whose cost ranks at most `stop`'s join the first part.
        let mut head = k + 1;
        for i in k + 1..self.keys.len() {
            if self.keys[i] <= bound {
                self.keys.swap(head, i);
                head += 1;
            }
        }
        self.keys[..head].sort_unstable();
        self.sorted = head;
        stop
    }
}

impl PassOrder {
    /// The fewest keys [`PassOrder::sort_next_part`] sorts at once.
    const MIN_PART: usize = 1024;

    /// The edge `(a, b)` `d ≥ 1` places after the last one handed out, if already sorted (only
    /// a hint of what comes: for [`passes`] to prefetch).
    pub(super) fn ahead(&self, d: usize) -> Option<(usize, usize)> {
        let i = self.at + d - 1;
        (i < self.sorted).then(|| {
            let (_, a, b) = key_edge(self.keys[i]);
            (a, b)
        })
    }

    /// Sort the next part of the keys: the smallest `max(MIN_PART, sorted)` of those not
    /// sorted yet (all of them if fewer), picked by a selection, O(n), and sorted alone. A
    /// pass that goes on past its first part usually stops soon after (at the first edge of
    /// infinite cost, or once it has done its least), so sorting every remaining key — many of
    /// them of infinite cost — would be wasted; the parts double, so a pass that does go on
    /// costs about a sort all the same. Keys are distinct (no two edges share `(a, b)`), so
    /// the order is exactly a full sort's.
    fn sort_next_part(&mut self) {
        let rest = &mut self.keys[self.sorted..];
        let part = self.sorted.max(Self::MIN_PART);
        if part < rest.len() {
            rest.select_nth_unstable(part);
            rest[..part].sort_unstable();
            self.sorted += part;
        } else {
            rest.sort_unstable();
            self.sorted = self.keys.len();
        }
    }
}

impl Iterator for PassOrder {
    type Item = (f64, usize, usize);

    /// The next edge `(cost, a, b)` in that order.
    fn next(&mut self) -> Option<(f64, usize, usize)> {
        if self.at == self.keys.len() {
            return None;
        }
        if self.at == self.sorted {
            self.sort_next_part();
        }
        self.at += 1;
        Some(key_edge(self.keys[self.at - 1]))
    }
}

/// The [`PassOrder`] key of `entry`.
fn edge_key(entry: &Entry) -> u128 {
    u128::from(cost_rank(entry.cost)) << 64 | u128::from(entry.a) << 32 | u128::from(entry.b)
}

/// The edge `(cost, a, b)` of a [`PassOrder`] key.
fn key_edge(key: u128) -> (f64, usize, usize) {
    let cost = rank_cost((key >> 64) as u64);
    (cost, (key >> 32) as u32 as usize, key as u32 as usize)
}

/// `x`'s rank in [`f64::total_cmp`]'s order as an unsigned integer: the bits with the sign
/// bit set for positive numbers, all bits flipped for negative ones.
fn cost_rank(x: f64) -> u64 {
    let bits = x.to_bits();
    if bits >> 63 == 1 {
        !bits
    } else {
        bits | 1 << 63
    }
}

/// The number of rank `rank` ([`cost_rank`]'s inverse, bit for bit).
fn rank_cost(rank: u64) -> f64 {
    f64::from_bits(if rank >> 63 == 1 {
        rank & !(1 << 63)
    } else {
        !rank
    })
}
