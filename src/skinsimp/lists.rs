//! Per-vertex lists of `u32` (the faces and the UV wedges of every vertex, [`super::collapse`])
//! in one flat arena, rather than one heap allocation per vertex.
//!
//! With a `Vec<Vec<u32>>`, reading a vertex's list costs two dependent memory accesses (the
//! `Vec` header, then its heap block, anywhere in memory), and a million small blocks are
//! scattered over the heap. Here every list is a [`Span`] of one shared `Vec<u32>`: the spans
//! are 12 bytes each, and after [`Lists::compact`] the lists of consecutive vertices lie side
//! by side, in vertex order.
//!
//! A list shrinks in place ([`Lists::retain`]). One that grows past its capacity
//! ([`Lists::replace`]) moves to the end of the arena, leaving its old slots unused; when the
//! unused slots outnumber the used ones, the arena is compacted (amortised O(1) per slot
//! written), so the arena stays under about twice the total length of the lists.

/// Where one list lies in the arena: `arena[start..start + len]`, with room for `cap` items.
#[derive(Clone, Copy, Debug, Default)]
struct Span {
    start: u32,
    len: u32,
    cap: u32,
}

impl Span {
    /// The arena range of the list's items.
    fn range(&self) -> std::ops::Range<usize> {
        self.start as usize..(self.start + self.len) as usize
    }
}

/// `n` lists of `u32` in one arena (module docs).
#[derive(Clone, Debug, Default)]
pub(super) struct Lists {
    spans: Vec<Span>,
    arena: Vec<u32>,
    /// Slots of the arena outside every list's capacity (left by moved or cleared lists).
    unused: usize,
}

impl Lists {
    /// `n` empty lists.
    pub(super) fn empty(n: usize) -> Lists {
        Lists {
            spans: vec![Span::default(); n],
            arena: Vec::new(),
            unused: 0,
        }
    }

    /// The lists of `n` vertices holding, in order, the items `(v, x)` of `items` with
    /// `v < n`: list `v` gets the `x`s paired with `v`, in the order they come. `items` is
    /// called twice (once to count, once to fill), and must give the same items both times.
    /// Each list is allocated at its length, in vertex order.
    pub(super) fn from_pairs<I>(n: usize, items: impl Fn() -> I) -> Lists
    where
        I: Iterator<Item = (u32, u32)>,
    {
        let mut spans = vec![Span::default(); n];
        for (v, _) in items() {
            spans[v as usize].len += 1;
        }
        let mut start = 0;
        for span in &mut spans {
            *span = Span {
                start,
                len: 0,
                cap: span.len,
            };
            start += span.cap;
        }
        let mut arena = vec![0; start as usize];
        for (v, x) in items() {
            let span = &mut spans[v as usize];
            arena[(span.start + span.len) as usize] = x;
            span.len += 1;
        }
        Lists {
            spans,
            arena,
            unused: 0,
        }
    }

    /// List `v`.
    pub(super) fn get(&self, v: usize) -> &[u32] {
        &self.arena[self.spans[v].range()]
    }

    /// Make list `v` a copy of `items`: in place if it has the room, else at the end of the
    /// arena (its old slots become unused; the arena is compacted when they are too many).
    pub(super) fn replace(&mut self, v: usize, items: &[u32]) {
        let len = u32::try_from(items.len())
            .expect("a list is shorter than the arena (super::MAX_FACES)");
        let span = self.spans[v];
        if len <= span.cap {
            let start = span.start as usize;
            self.arena[start..start + items.len()].copy_from_slice(items);
            self.spans[v].len = len;
            return;
        }
        self.unused += span.cap as usize;
        let start =
            u32::try_from(self.arena.len()).expect("the arena fits u32 indices (super::MAX_FACES)");
        self.arena.extend_from_slice(items);
        self.spans[v] = Span {
            start,
            len,
            cap: len,
        };
        if self.unused > self.arena.len() / 2 {
            self.compact();
        }
    }

    /// Empty list `v` (its slots become unused).
    pub(super) fn clear(&mut self, v: usize) {
        self.unused += self.spans[v].cap as usize;
        self.spans[v] = Span::default();
    }

    /// Keep the items `x` of list `v` with `keep(x)`, in order, in place.
    pub(super) fn retain(&mut self, v: usize, mut keep: impl FnMut(u32) -> bool) {
        let span = self.spans[v];
        let list = &mut self.arena[span.range()];
        let mut len = 0;
        for i in 0..list.len() {
            if keep(list[i]) {
                list[len] = list[i];
                len += 1;
            }
        }
        self.spans[v].len = len as u32;
    }

    /// Ask the CPU to start loading where list `v` is ([`prefetch`]).
    pub(super) fn prefetch_span(&self, v: usize) {
        prefetch(&self.spans[v]);
    }

    /// Ask the CPU to start loading list `v`'s first and last items ([`prefetch`]); reads
    /// its span, so best after [`Lists::prefetch_span`] had the time to bring it in.
    pub(super) fn prefetch_items(&self, v: usize) {
        let list = self.get(v);
        if let (Some(first), Some(last)) = (list.first(), list.last()) {
            prefetch(first);
            prefetch(last);
        }
    }

    /// Rewrite the arena with every list in vertex order, each at capacity = length: no unused
    /// slots, and neighbouring vertices' lists side by side. The lists do not change.
    pub(super) fn compact(&mut self) {
        let live = self.spans.iter().map(|s| s.len as usize).sum();
        let mut arena = Vec::with_capacity(live);
        for span in &mut self.spans {
            let start = arena.len() as u32;
            arena.extend_from_slice(&self.arena[span.range()]);
            *span = Span {
                start,
                len: span.len,
                cap: span.len,
            };
        }
        self.arena = arena;
        self.unused = 0;
    }
}

/// A hint to the CPU to start loading the cache line of `x` now, so that a later read of it
/// does not wait for memory: the simplifier visits vertices in cost order, all over the mesh,
/// and knows a few edges ahead which ones it will read. It changes no value.
#[inline]
pub(super) fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: a prefetch is a hint; it reads nothing into the program and cannot fault,
        // and `x` is a valid reference anyway. (SSE, which has it, is part of x86_64.)
        unsafe { _mm_prefetch::<_MM_HINT_T0>((x as *const T).cast::<i8>()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_grow_shrink_and_compact_without_changing() {
        let pairs = [(0, 5), (2, 7), (0, 6), (2, 8), (2, 9)];
        let mut lists = Lists::from_pairs(3, || pairs.iter().copied());
        assert_eq!(lists.get(0), &[5, 6]);
        assert!(lists.get(1).is_empty());
        assert_eq!(lists.get(2), &[7, 8, 9]);
        lists.replace(0, &[1, 2, 3, 4]);
        lists.retain(2, |x| x != 8);
        lists.replace(1, &[10]);
        assert_eq!(lists.get(0), &[1, 2, 3, 4]);
        assert_eq!(lists.get(1), &[10]);
        assert_eq!(lists.get(2), &[7, 9]);
        lists.clear(0);
        lists.compact();
        assert!(lists.get(0).is_empty());
        assert_eq!(lists.get(1), &[10]);
        assert_eq!(lists.get(2), &[7, 9]);
        assert_eq!(lists.arena.len(), 3);
    }
}
