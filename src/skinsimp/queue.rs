//! The priority queue of the greedy collapse ([`super::collapse`]): edges by cost, cheapest
//! first, ties by `(a, b)`, with lazy deletion.
//!
//! An entry carries the versions its endpoints had when its cost was computed; it is *current*
//! while both still have them (a collapse bumps the versions of its two endpoints). Entries are
//! not removed when they go stale, only skipped when popped or dropped in bulk. At most one
//! current entry exists per edge and the keys `(cost, a, b)` of different edges differ, so the
//! order in which current entries come out depends on their keys alone: not on the order of
//! the pushes, nor on when stale entries are dropped.
//!
//! Layout. A collapse re-queues every edge around the merged vertex, and most of those entries
//! are never popped before the target is reached (on the 100k-triangle tube with rest-pose
//! quadrics ≈ 40 pushes per collapse, ≈ 2 pops). So the queue is split at a key `split`: the
//! entries below it in a binary heap (`near`), the others in an unsorted list (`far`, O(1)
//! push). When the heap runs dry, the stale entries of `far` are dropped and its smallest
//! quarter moves into the heap (`select_nth_unstable`, O(n)); the next key becomes the split.
//! `far` is also cleared of stale entries whenever it has doubled since the last time, so it
//! stays O(current edges) however many entries go stale.
//!
//! Each entry can carry a payload (the simplifier keeps the candidate of a costly evaluation),
//! stored in a slot that is freed when the entry is popped or dropped.

use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;

/// A queued edge `(a, b)` with its cost and its endpoints' versions when it was computed.
#[derive(Clone, Copy, Debug)]
pub(super) struct Entry {
    pub cost: f64,
    pub a: u32,
    pub b: u32,
    pub version_a: u32,
    pub version_b: u32,
    /// The payload's slot, [`NO_SLOT`] without one.
    slot: u32,
}

const NO_SLOT: u32 = u32::MAX;

impl Entry {
    pub fn new(cost: f64, (a, b): (u32, u32), (version_a, version_b): (u32, u32)) -> Entry {
        Entry {
            cost,
            a,
            b,
            version_a,
            version_b,
            slot: NO_SLOT,
        }
    }
}

impl PartialEq for Entry {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    /// By cost, then by `(a, b)` (deterministic ties); versions and payload do not count.
    fn cmp(&self, other: &Self) -> Ordering {
        self.cost
            .total_cmp(&other.cost)
            .then(self.a.cmp(&other.a))
            .then(self.b.cmp(&other.b))
    }
}

/// Which entries go to the heap.
#[derive(Clone, Copy, Debug)]
enum Split {
    /// None: everything is in `far` (before the first pop).
    Nothing,
    /// Those below this key.
    Below(Entry),
    /// All (`far` was emptied into the heap).
    Everything,
}

/// Fewest entries moved into the heap at once, and least size of `far` that triggers
/// dropping its stale entries.
const MIN_CHUNK: usize = 1 << 12;

/// The queue of the module docs, with payloads `T`.
pub(super) struct Queue<T> {
    near: BinaryHeap<Reverse<Entry>>,
    far: Vec<Entry>,
    split: Split,
    /// Drop the stale entries of `far` when it grows beyond this.
    far_limit: usize,
    slots: Vec<Option<T>>,
    /// Slots of entries popped or dropped, to reuse.
    free: Vec<u32>,
}

impl<T> Queue<T> {
    /// A queue holding `entries` with their `payloads` (all in `far` until the first pop).
    pub fn new(entries: Vec<Entry>, payloads: Vec<Option<T>>) -> Queue<T> {
        let mut queue = Queue {
            near: BinaryHeap::new(),
            far: Vec::with_capacity(entries.len()),
            split: Split::Nothing,
            far_limit: 0,
            slots: Vec::new(),
            free: Vec::new(),
        };
        for (entry, payload) in entries.into_iter().zip(payloads) {
            queue.push(entry, payload);
        }
        queue.far_limit = (2 * queue.far.len()).max(MIN_CHUNK);
        queue
    }

    /// Queue `entry` with its payload.
    pub fn push(&mut self, mut entry: Entry, payload: Option<T>) {
        if let Some(p) = payload {
            entry.slot = self.store(p);
        }
        let near = match self.split {
            Split::Nothing => false,
            Split::Below(split) => entry < split,
            Split::Everything => true,
        };
        if near {
            self.near.push(Reverse(entry));
        } else {
            self.far.push(entry);
        }
    }

    /// Drop the stale entries of `far` if it has doubled since they were last dropped.
    pub fn tidy(&mut self, is_current: impl Fn(&Entry) -> bool) {
        if self.far.len() > self.far_limit {
            self.drop_stale(&is_current);
        }
    }

    /// The cheapest entry (current or not: the caller checks) and its payload.
    pub fn pop(&mut self, is_current: impl Fn(&Entry) -> bool) -> Option<(Entry, Option<T>)> {
        loop {
            if let Some(Reverse(entry)) = self.near.pop() {
                let payload = self.take(entry.slot);
                return Some((entry, payload));
            }
            if self.far.is_empty() {
                return None;
            }
            self.refill(&is_current);
        }
    }

    /// Move the smallest quarter of the current entries of `far` into the (empty) heap.
    fn refill(&mut self, is_current: &impl Fn(&Entry) -> bool) {
        self.drop_stale(is_current);
        let k = (self.far.len() / 4).max(MIN_CHUNK);
        if k >= self.far.len() {
            self.near = BinaryHeap::from_iter(self.far.drain(..).map(Reverse));
            self.split = Split::Everything;
            return;
        }
        self.far.select_nth_unstable(k);
        self.split = Split::Below(self.far[k]);
        self.near = BinaryHeap::from_iter(self.far.drain(..k).map(Reverse));
    }

    fn drop_stale(&mut self, is_current: &impl Fn(&Entry) -> bool) {
        let (slots, free) = (&mut self.slots, &mut self.free);
        self.far.retain(|e| {
            let keep = is_current(e);
            if !keep && e.slot != NO_SLOT {
                slots[e.slot as usize] = None;
                free.push(e.slot);
            }
            keep
        });
        self.far_limit = (2 * self.far.len()).max(MIN_CHUNK);
    }

    fn store(&mut self, payload: T) -> u32 {
        match self.free.pop() {
            Some(slot) => {
                self.slots[slot as usize] = Some(payload);
                slot
            }
            None => {
                self.slots.push(Some(payload));
                (self.slots.len() - 1) as u32
            }
        }
    }

    fn take(&mut self, slot: u32) -> Option<T> {
        if slot == NO_SLOT {
            return None;
        }
        self.free.push(slot);
        self.slots[slot as usize].take()
    }
}
