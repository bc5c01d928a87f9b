//! Branch coverage of the f32 twins, as data: every decision a kernel takes (a bracket's side,
//! a guard, a fallback, a mirroring, a clamp, a root's form …) is reported by the twin with a
//! static name ([`taken`], [`hit`]), and a run over a kernel's vectors counts, per branch, the
//! invocations that took it ([`count`]; each invocation of a kernel, one GPU thread, is marked
//! by the runner with [`invocation`]). `tests/vectors_coverage.rs` counts them over the
//! canonical vectors and fails when a branch of a kernel's catalogue ([`Branch`], `BRANCHES` in
//! each twin) has no invocation and is not in its list of branches not reached yet (each with
//! its reason), or when a listed branch is reached. The manifests do not carry the counts yet.
//!
//! Off by default: a twin's report is one read of a thread-local flag, so the model checks and
//! the bound derivations (the same twins over [`super::Ball`] and [`super::Lin`]) pay nothing
//! measurable. Counting is per thread, like the arithmetic [`super::Model`].
//!
//! A new kernel plugs in with three lines: its twin calls [`taken`] (or [`hit`]) at each
//! decision, lists the names in a `BRANCHES` catalogue, and its runner
//! ([`super::candidate::runner`]) wraps each invocation in [`invocation`];
//! [`super::candidate::branches`] names the catalogue.

use std::cell::{Cell, RefCell};
use std::collections::{BTreeMap, BTreeSet};

/// One branch of a kernel: its static name (`<kernel or shader>.<decision>.<side>`) and what
/// taking it means, for the manifest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Branch {
    pub name: &'static str,
    pub meaning: &'static str,
}

/// What [`count`] saw: the invocations run and, per branch name, how many of them took it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    pub invocations: usize,
    pub taken: BTreeMap<&'static str, usize>,
}

impl Counts {
    /// The invocations that took branch `name` (0 when none did).
    pub fn of(&self, name: &str) -> usize {
        self.taken.get(name).copied().unwrap_or(0)
    }
}

/// A kernel's branch catalogue, one `"name" => "meaning"` per line:
/// `pub const BRANCHES: &[Branch] = branches![…];`.
macro_rules! branches {
    ($($name:literal => $meaning:literal),* $(,)?) => {
        &[$($crate::twin::coverage::Branch { name: $name, meaning: $meaning }),*]
    };
}
pub(crate) use branches;

#[derive(Default)]
struct State {
    /// Branches taken by the invocation running now.
    current: BTreeSet<&'static str>,
    /// Nesting depth of [`invocation`]: only the outermost one is counted.
    depth: usize,
    counts: Counts,
}

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static STATE: RefCell<State> = RefCell::new(State::default());
}

/// Report that the running twin took branch `name` (nothing unless this thread is counting).
#[inline]
pub fn hit(name: &'static str) {
    if COUNTING.with(Cell::get) {
        STATE.with(|s| {
            s.borrow_mut().current.insert(name);
        });
    }
}

/// `cond`, reporting branch `yes` when it holds and `no` when it does not: the twin's `if`
/// reads `if taken(a > 0, "…hi", "…lo")`.
#[inline]
pub fn taken(cond: bool, yes: &'static str, no: &'static str) -> bool {
    hit(if cond { yes } else { no });
    cond
}

/// Run one invocation of a kernel (`f`): the branches it takes count once each, however often
/// it takes them. Nested calls belong to the outermost invocation.
pub fn invocation<T>(f: impl FnOnce() -> T) -> T {
    if !COUNTING.with(Cell::get) {
        return f();
    }
    STATE.with(|s| s.borrow_mut().depth += 1);
    let out = f();
    STATE.with(|s| {
        let mut s = s.borrow_mut();
        s.depth -= 1;
        if s.depth == 0 {
            let taken = std::mem::take(&mut s.current);
            s.counts.invocations += 1;
            for name in taken {
                *s.counts.taken.entry(name).or_insert(0) += 1;
            }
        }
    });
    out
}

/// Run `f` with this thread counting, and return its result and the counts (counting stops
/// afterwards, also when `f` panics). Branches reported outside any [`invocation`] count as one
/// invocation of their own.
pub fn count<T>(f: impl FnOnce() -> T) -> (T, Counts) {
    struct Stop;
    impl Drop for Stop {
        fn drop(&mut self) {
            COUNTING.with(|c| c.set(false));
        }
    }
    STATE.with(|s| *s.borrow_mut() = State::default());
    COUNTING.with(|c| c.set(true));
    let stop = Stop;
    let out = f();
    drop(stop);
    let mut state = STATE.with(|s| std::mem::take(&mut *s.borrow_mut()));
    if !state.current.is_empty() {
        state.counts.invocations += 1;
        for name in state.current {
            *state.counts.taken.entry(name).or_insert(0) += 1;
        }
    }
    (out, state.counts)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kernel(x: i32) -> i32 {
        if taken(x > 0, "test.positive", "test.not_positive") {
            hit("test.positive_again");
            hit("test.positive_again");
            x
        } else {
            -x
        }
    }

    #[test]
    fn counts_each_invocation_once_per_branch() {
        let (sum, counts) = count(|| {
            [3, -1, 4, 0]
                .into_iter()
                .map(|x| invocation(|| kernel(x)))
                .sum::<i32>()
        });
        assert_eq!(sum, 8);
        assert_eq!(counts.invocations, 4);
        assert_eq!(counts.of("test.positive"), 2);
        assert_eq!(counts.of("test.positive_again"), 2);
        assert_eq!(counts.of("test.not_positive"), 2);
        assert_eq!(counts.of("test.never"), 0);
    }

    #[test]
    fn nothing_is_counted_outside_count() {
        assert_eq!(invocation(|| kernel(1)), 1);
        let (_, counts) = count(|| ());
        assert_eq!(counts, Counts::default());
    }

    #[test]
    fn nested_invocations_belong_to_the_outer_one() {
        let (_, counts) = count(|| {
            invocation(|| {
                invocation(|| kernel(1));
                invocation(|| kernel(-1));
            })
        });
        assert_eq!(counts.invocations, 1);
        assert_eq!(counts.of("test.positive"), 1);
        assert_eq!(counts.of("test.not_positive"), 1);
    }
}
