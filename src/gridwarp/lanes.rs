//! The lane machinery under both energies ([`super::energy`], [`super::energy_naa`]): samples
//! processed [`LANES`] at a time in fixed-size arrays, per-lane partial sums of a cell's F,
//! Jᵀr and JᵀJ added in lane order, and the split of the cells into parallel tasks. None of it
//! is part of the formula (`super::plain` states the formula without it); it fixes the order
//! of the sums, so that results depend on the sample layout only, never on the number of
//! threads.

use rayon::prelude::*;

use crate::lm::LocalNormalEquations;

/// Samples processed together by the sample loops: 8 f64, one 512-bit register.
pub const LANES: usize = 8;

/// The first LANES entries of `v` from `at`, as a fixed-size array (index checks once).
#[inline(always)]
pub(super) fn lanes<T>(v: &[T], at: usize) -> &[T; LANES] {
    v[at..at + LANES].try_into().expect("LANES entries")
}

/// The upper triangle of an N×N block, row by row: (0,0) (0,1) … (0,N−1) (1,1) … (N−1,N−1);
/// T = N(N+1)/2 entries (checked when evaluated, at compile time).
const fn upper_triangle<const N: usize, const T: usize>() -> [(usize, usize); T] {
    assert!(T == N * (N + 1) / 2, "T must be N(N+1)/2");
    let mut out = [(0, 0); T];
    let (mut p, mut k) = (0, 0);
    while p < N {
        let mut q = p;
        while q < N {
            out[k] = (p, q);
            k += 1;
            q += 1;
        }
        p += 1;
    }
    out
}

/// The (p, q), p ≤ q, of an 8×8 block in the order of [`LaneSums`]'s JᵀJ entries.
pub(super) const UPPER_8: [(usize, usize); 36] = upper_triangle::<8, 36>();

/// Per-lane partial sums of a cell's F, Jᵀr and the T = N(N+1)/2 upper-triangle entries of
/// JᵀJ over N slots: each lane accumulates its own samples (independent additions the
/// compiler runs side by side in one vector register per entry), and the lanes are added in
/// lane order at the end of the cell: the axis-aligned energy's (N = 4: its 15 sums stay in
/// registers while the cell's chunks stream by; [`cell_block_of`] sums the non-axis-aligned
/// energy's 45, entry by entry).
pub(super) struct LaneSums<const N: usize, const T: usize> {
    energy: [f64; LANES],
    jtr: [[f64; LANES]; N],
    jtj: [[f64; LANES]; T],
}

impl<const N: usize, const T: usize> LaneSums<N, T> {
    pub(super) const UPPER: [(usize, usize); T] = upper_triangle::<N, T>();

    pub(super) fn new() -> Self {
        LaneSums {
            energy: [0.0; LANES],
            jtr: [[0.0; LANES]; N],
            jtj: [[0.0; LANES]; T],
        }
    }

    /// F += r², Jᵀr += d r, JᵀJ += d dᵀ (upper triangle), one residual per lane: `r[lane]`
    /// with derivatives `d[p][lane]`, p the slot; each term added by a fused multiply-add.
    #[inline(always)]
    pub(super) fn accumulate(&mut self, r: &[f64; LANES], d: &[[f64; LANES]; N]) {
        for lane in 0..LANES {
            self.energy[lane] = r[lane].mul_add(r[lane], self.energy[lane]);
            for (sum, d_p) in self.jtr.iter_mut().zip(d) {
                sum[lane] = d_p[lane].mul_add(r[lane], sum[lane]);
            }
            for (sum, &(p, q)) in self.jtj.iter_mut().zip(&Self::UPPER) {
                sum[lane] = d[p][lane].mul_add(d[q][lane], sum[lane]);
            }
        }
    }

    /// [`LaneSums::accumulate`] of every chunk's residuals in order, axis s then t.
    #[inline(always)]
    pub(super) fn accumulate_chunks(&mut self, chunks: &[LaneResiduals<N>]) {
        for chunk in chunks {
            for axis in 0..2 {
                self.accumulate(&chunk.r[axis], &chunk.d[axis]);
            }
        }
    }

    /// The cell's block: lanes summed in order ([`lane_total`]), the lower triangle
    /// mirrored from the upper. (Inlined: compiled with the caller's instruction set.)
    #[inline(always)]
    pub(super) fn reduce(&self) -> LocalNormalEquations<N> {
        let mut block = LocalNormalEquations {
            energy: lane_total(&self.energy),
            jtr: self.jtr.each_ref().map(lane_total),
            ..Default::default()
        };
        for (sum, &(p, q)) in self.jtj.iter().zip(&Self::UPPER) {
            block.jtj[p][q] = lane_total(sum);
            block.jtj[q][p] = block.jtj[p][q];
        }
        block
    }
}

/// The sum of per-lane partial sums, in lane order (the end of every cell's accumulation).
#[inline(always)]
pub(super) fn lane_total(lanes: &[f64; LANES]) -> f64 {
    lanes.iter().sum()
}

/// The two residuals (axes s, t) of LANES samples, one sample per lane, and their
/// derivatives in slot order: `r[axis][lane]`, `d[axis][slot][lane]`.
#[derive(Clone, Copy)]
pub(super) struct LaneResiduals<const N: usize> {
    pub r: [[f64; LANES]; 2],
    pub d: [[[f64; LANES]; N]; 2],
}

impl<const N: usize> LaneResiduals<N> {
    pub(super) const ZERO: Self = LaneResiduals {
        r: [[0.0; LANES]; 2],
        d: [[[0.0; LANES]; N]; 2],
    };
}

/// Slots per side of the tiles in which [`cell_block_of`] sums JᵀJ.
const TILE: usize = 4;

/// A cell's F, Jᵀr and JᵀJ (upper triangle, mirrored) from the residuals of its chunks of
/// LANES samples. F and Jᵀr entry by entry ([`cell_gradient_of`]); JᵀJ in tiles of
/// [`TILE`]×[`TILE`] slots ([`tile_sums`]), so that each chunk's derivatives are read once
/// per tile rather than once per entry (N = 8: three tiles instead of 36 entries).
#[inline(always)]
pub(super) fn cell_block_of<const N: usize>(
    chunks: &[LaneResiduals<N>],
) -> LocalNormalEquations<N> {
    assert!(N.is_multiple_of(TILE), "N must be a multiple of TILE");
    let mut block = cell_gradient_of(chunks);
    for p0 in (0..N).step_by(TILE) {
        for q0 in (p0..N).step_by(TILE) {
            let tile = tile_sums(chunks, p0, q0);
            for (a, row) in tile.iter().enumerate() {
                for (b, sums) in row.iter().enumerate() {
                    let (p, q) = (p0 + a, q0 + b);
                    if p <= q {
                        block.jtj[p][q] = lane_total(sums);
                        block.jtj[q][p] = block.jtj[p][q];
                    }
                }
            }
        }
    }
    block
}

/// Σ d_p d_q over a cell's residuals for the slots p = p0 … p0 + TILE − 1, q = q0 … q0 +
/// TILE − 1, per lane: each lane's partial sum runs over the chunks in order, axis s then
/// t within a chunk (the lanes are added by the caller). TILE² partial sums plus 2·TILE
/// derivatives fit in the vector registers.
#[inline(always)]
fn tile_sums<const N: usize>(
    chunks: &[LaneResiduals<N>],
    p0: usize,
    q0: usize,
) -> [[[f64; LANES]; TILE]; TILE] {
    let mut sums = [[[0.0; LANES]; TILE]; TILE];
    for chunk in chunks {
        for d in &chunk.d {
            for (a, row) in sums.iter_mut().enumerate() {
                for (b, sum) in row.iter_mut().enumerate() {
                    for lane in 0..LANES {
                        sum[lane] += d[p0 + a][lane] * d[q0 + b][lane];
                    }
                }
            }
        }
    }
    sums
}

/// A cell's F and Jᵀr alone (JᵀJ left 0) from the residuals of its chunks, as in
/// [`cell_block_of`].
#[inline(always)]
pub(super) fn cell_gradient_of<const N: usize>(
    chunks: &[LaneResiduals<N>],
) -> LocalNormalEquations<N> {
    let mut block = LocalNormalEquations {
        energy: chunk_sum(chunks, |c, axis, lane| c.r[axis][lane] * c.r[axis][lane]),
        ..Default::default()
    };
    for (p, jtr) in block.jtr.iter_mut().enumerate() {
        *jtr = chunk_sum(chunks, |c, axis, lane| c.d[axis][p][lane] * c.r[axis][lane]);
    }
    block
}

/// Σ over the chunks, the axes and the lanes of `term(chunk, axis, lane)`: each lane keeps
/// one partial sum per axis over the chunks in order (two independent chains of additions),
/// then [`axes_total`] adds them. [`super::energy_naa`]'s energy-only evaluation sums r² in
/// the same order, so that both give the same F bit for bit.
#[inline(always)]
pub(super) fn chunk_sum<const N: usize>(
    chunks: &[LaneResiduals<N>],
    term: impl Fn(&LaneResiduals<N>, usize, usize) -> f64,
) -> f64 {
    let mut sums = [[0.0; LANES]; 2];
    for chunk in chunks {
        for (axis, sums) in sums.iter_mut().enumerate() {
            for (lane, sum) in sums.iter_mut().enumerate() {
                *sum += term(chunk, axis, lane);
            }
        }
    }
    axes_total(&sums)
}

/// The total of per-axis, per-lane partial sums: per lane axis s + axis t, then the lanes in
/// lane order.
#[inline(always)]
pub(super) fn axes_total([s, t]: &[[f64; LANES]; 2]) -> f64 {
    lane_total(&std::array::from_fn(|lane| s[lane] + t[lane]))
}
/// Fill `out` (one entry per cell of `samples_per_cell` samples) by `fill(first cell, part)`,
/// in parallel tasks of equal numbers of cells (±1): as many tasks as rayon's pool has
/// threads, or the smallest multiple of that with at most `samples_per_task` samples a task
/// (one task per thread when the cells cost alike: each extra task costs a steal), or on
/// the calling thread if there are fewer than `samples_per_task` samples in all (or one
/// thread). The split depends on the problem size and the thread count, the results on
/// neither (each entry is computed alone, and the caller sums them in cell order).
pub(super) fn for_each_task<T: Send>(
    out: &mut [T],
    samples_per_cell: usize,
    samples_per_task: usize,
    fill: impl Fn(usize, &mut [T]) + Sync,
) {
    let samples = out.len() * samples_per_cell;
    let threads = rayon::current_num_threads();
    if threads <= 1 || samples < samples_per_task.max(1) {
        return fill(0, out);
    }
    let tasks = threads * samples.div_ceil(threads * samples_per_task.max(1));
    let per_task = out.len().div_ceil(tasks);
    out.par_chunks_mut(per_task)
        .enumerate()
        .for_each(|(t, part)| fill(t * per_task, part));
}
