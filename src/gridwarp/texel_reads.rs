//! Reading the four texels around the warped points of [`LANES`] samples at once: the axis-
//! aligned energy's lane loops ([`super::energy`]) interpolate ‖D_s‖ and ‖D_t‖ bilinearly
//! between f₀₀ = f(x, y), f₁₀ = f(x', y), f₀₁ = f(x, y'), f₁₁ = f(x', y') with (x, y) the lower
//! and (x', y') the upper texel of each lane's point ([`super::field::Axis`]).
//!
//! Two ways to read them, giving the same values bit for bit (they read the same texels):
//! - [`Gathers`]: one indexed read per lane and texel. Portable; with AVX-512 each of the four
//!   reads is one gather instruction, about 40 % of the normal-equations pass when measured.
//! - [`Windows`] (AVX-512 only): the lanes of a chunk share their texel columns (one column
//!   sample, or two) and their texel rows lie within a few texels of each other (the L row
//!   samples of one cell). With the field stored column by column ([`ColumnMajor`]), each of
//!   the four texels of all lanes is picked out of 16 consecutive values (two vector loads) by
//!   one permutation (`vpermt2pd`; one load and `vpermpd` when they lie within 8). The row
//!   offsets of a chunk row ([`RowWindow`]) are found once per evaluation, shared by every
//!   cell column. A chunk row whose texel rows span more than the loads cover (a cell taller
//!   than ≈ 15 texels with 8 row samples) falls back to gathers.
//!
//! When ‖D_t‖ has ‖D_s‖'s resolution the lanes' texel positions are the same on both, and
//! [`TexelReads::quads_of_both`] finds the indices (or the window loads' addresses) once.

use super::field::Field;
use super::lanes::LANES;

/// The four texels of every lane, [f₀₀, f₁₀, f₀₁, f₁₁].
pub(super) type Quads = [[f64; LANES]; 4];

/// The texel columns of a chunk's lanes on one field (x and x', as column indices).
#[derive(Clone, Copy)]
pub(super) struct LaneColumns<'c> {
    pub lower: &'c [usize; LANES],
    pub upper: &'c [usize; LANES],
}

/// The texel rows of a chunk's lanes on one field, as offsets y·W into the row-major values.
#[derive(Clone, Copy)]
pub(super) struct LaneRows<'c> {
    pub lower: &'c [usize; LANES],
    pub upper: &'c [usize; LANES],
}

/// A field's values column by column, value of texel (x, y) at x·H + y, followed by 16
/// padding values so that a window's two loads never run past the end.
pub(super) struct ColumnMajor {
    height: usize,
    values: Vec<f64>,
}

impl ColumnMajor {
    /// The transpose of `field`'s row-major values (padding 0), in tiles of 8×8 texels read
    /// as 8 rows and written as 8 columns (contiguous reads and writes, the transpose in
    /// registers; a field whose sides are not multiples of 8 finishes its last rows and
    /// columns one value at a time).
    pub fn of(field: &Field) -> ColumnMajor {
        const T: usize = 8;
        let (w, h) = (field.width, field.height);
        let mut values = vec![0.0; w * h + 2 * LANES];
        let source = &field.values;
        let (full_w, full_h) = (w - w % T, h - h % T);
        for y0 in (0..full_h).step_by(T) {
            for x0 in (0..full_w).step_by(T) {
                let mut tile = [[0.0; T]; T];
                for (dy, row) in tile.iter_mut().enumerate() {
                    row.copy_from_slice(&source[(y0 + dy) * w + x0..][..T]);
                }
                for dx in 0..T {
                    let column = &mut values[(x0 + dx) * h + y0..][..T];
                    for (value, row) in column.iter_mut().zip(&tile) {
                        *value = row[dx];
                    }
                }
            }
        }
        for y in 0..h {
            for x in (0..w).filter(|&x| x >= full_w || y >= full_h) {
                values[x * h + y] = source[y * w + x];
            }
        }
        ColumnMajor { height: h, values }
    }
}

/// Where a chunk row's lanes read inside a window of 16 texels: the window starts at texel row
/// `first` of the lanes' lower column (values 0–7) and continues at `second` (values 8–15):
/// the next 8 rows of the same column when the chunk has one column sample (`second` = 8),
/// the same rows of the second column sample's column (`second` = 0, and lanes 4–7 add 8 to
/// their offsets). `lower[l]`, `upper[l]`: lane l's texel rows y, y' as positions in the window.
/// With one column sample whose rows all lie within the first 8 (`one_load`), the second 8
/// are not needed: one load and a one-register permutation (`vpermpd`) per texel column.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct RowWindow {
    first: usize,
    second: usize,
    one_load: bool,
    lower: [i64; LANES],
    upper: [i64; LANES],
}

impl RowWindow {
    /// The window of a chunk row whose lanes have texel rows `lower`, `upper` (row indices) and
    /// `columns` column samples (1 or 2, the chunk layout); None if they span more texel rows
    /// than one window holds (16 with one column sample, 8 with two).
    pub fn of(lower: &[usize; LANES], upper: &[usize; LANES], columns: usize) -> Option<Self> {
        let first = *lower.iter().min()?;
        let last = *upper.iter().max()?;
        let rows_per_column = 2 * LANES / columns;
        if last - first >= rows_per_column {
            return None;
        }
        // Lane l belongs to the column sample l / (LANES / columns): its values start at 8 times that.
        let offset = |lane: usize, row: usize| {
            let column = lane / (LANES / columns);
            (row - first + column * LANES) as i64
        };
        Some(RowWindow {
            first,
            second: if columns == 1 { LANES } else { 0 },
            one_load: columns == 1 && last - first < LANES,
            lower: std::array::from_fn(|lane| offset(lane, lower[lane])),
            upper: std::array::from_fn(|lane| offset(lane, upper[lane])),
        })
    }

    /// Where the two loads of the window start in a field of height `h` stored column by
    /// column, in the lanes' lower texel columns and in their upper ones: the window's rows
    /// in the columns of lanes 0 and LANES − 1 (the same column with one column sample per
    /// chunk).
    #[inline(always)]
    fn loads(&self, h: usize, x: LaneColumns) -> ((usize, usize), (usize, usize)) {
        let starts = |columns: &[usize; LANES]| {
            let base = columns[0] * h + self.first;
            (base, columns[LANES - 1] * h + self.first + self.second)
        };
        (starts(x.lower), starts(x.upper))
    }
}

/// How the lane loops read the texels of the two deformed fields ‖D_s‖ (field 0) and ‖D_t‖
/// (field 1).
pub(super) trait TexelReads: Copy {
    /// The quads of every lane on field `field`, the lanes at the texel columns `x` and rows
    /// `y`, `window` their chunk row's window on that field (if it has one).
    fn quads(self, field: usize, x: LaneColumns, y: LaneRows, window: Option<&RowWindow>) -> Quads;

    /// The quads of both fields, which have the same width and height (so the same texel
    /// positions): the indices found once.
    fn quads_of_both(self, x: LaneColumns, y: LaneRows, window: Option<&RowWindow>) -> [Quads; 2];
}

/// One indexed read per lane and texel.
#[derive(Clone, Copy, Debug)]
pub(super) struct Gathers<'a> {
    pub fields: [&'a Field; 2],
}

impl Gathers<'_> {
    /// f(row + column) of every lane. (The tables hold only valid indices; clamping them to
    /// the last value anyway, instead of a checked index, leaves the lane loop without a
    /// branch, so that it becomes one gather.)
    #[inline(always)]
    fn read(values: &[f64], rows: &[usize; LANES], columns: &[usize; LANES]) -> [f64; LANES] {
        let mut out = [0.0; LANES];
        let Some(last) = values.len().checked_sub(1) else {
            return out;
        };
        for lane in 0..LANES {
            out[lane] = values[(rows[lane] + columns[lane]).min(last)];
        }
        out
    }
}

impl TexelReads for Gathers<'_> {
    #[inline(always)]
    fn quads(self, field: usize, x: LaneColumns, y: LaneRows, _: Option<&RowWindow>) -> Quads {
        let v = &self.fields[field].values;
        [
            Self::read(v, y.lower, x.lower),
            Self::read(v, y.lower, x.upper),
            Self::read(v, y.upper, x.lower),
            Self::read(v, y.upper, x.upper),
        ]
    }

    #[inline(always)]
    fn quads_of_both(self, x: LaneColumns, y: LaneRows, window: Option<&RowWindow>) -> [Quads; 2] {
        [self.quads(0, x, y, window), self.quads(1, x, y, window)]
    }
}

/// Permutations of two vector loads (AVX-512F) from the fields stored column by column,
/// gathers where a chunk row has no window. Holding one proves the CPU has AVX-512F
/// ([`Windows::new`]).
#[derive(Clone, Copy)]
pub(super) struct Windows<'a> {
    gathers: Gathers<'a>,
    column_major: &'a [ColumnMajor; 2],
}

impl<'a> Windows<'a> {
    /// Whether this CPU can read by windows (has AVX-512F).
    pub fn available() -> bool {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            return true;
        }
        false
    }

    /// Reads of `fields`, stored column by column as `column_major`; None unless this CPU
    /// has AVX-512F.
    pub fn new(fields: [&'a Field; 2], column_major: &'a [ColumnMajor; 2]) -> Option<Self> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            return Some(Windows {
                gathers: Gathers { fields },
                column_major,
            });
        }
        None
    }

    /// The quads of the lanes in the window `w`, whose loads start at `lower` in the lanes'
    /// lower texel columns and at `upper` in their upper ones (first and second 8 values).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn window_quads(
        self,
        values: &[f64],
        lower: (usize, usize),
        upper: (usize, usize),
        w: &RowWindow,
    ) -> Quads {
        if w.one_load {
            return [
                self.select_one(values, lower.0, &w.lower),
                self.select_one(values, upper.0, &w.lower),
                self.select_one(values, lower.0, &w.upper),
                self.select_one(values, upper.0, &w.upper),
            ];
        }
        [
            self.select(values, lower.0, lower.1, &w.lower),
            self.select(values, upper.0, upper.1, &w.lower),
            self.select(values, lower.0, lower.1, &w.upper),
            self.select(values, upper.0, upper.1, &w.upper),
        ]
    }

    /// Lane l gets value `at[l]` (< 8) of the 8 values `values[base..base + 8]`.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn select_one(self, values: &[f64], base: usize, at: &[i64; LANES]) -> [f64; 8] {
        use std::arch::x86_64::{_mm512_loadu_epi64, _mm512_loadu_pd, _mm512_permutexvar_pd};
        // As in `select`: clamped so that the load stays in bounds whatever the tables hold.
        let base = base.min(values.len() - LANES);
        // SAFETY: a `Windows` exists only if the CPU has AVX-512F (`new`); the load reads
        // LANES values from an index ≤ len − LANES; `at` is 8 i64 (the permutation uses their
        // low 3 bits).
        unsafe {
            let selected = _mm512_permutexvar_pd(
                _mm512_loadu_epi64(at.as_ptr()),
                _mm512_loadu_pd(values.as_ptr().add(base)),
            );
            std::mem::transmute::<std::arch::x86_64::__m512d, [f64; LANES]>(selected)
        }
    }

    /// Lane l gets value `at[l]` of the 16 values `values[base..base + 8]`,
    /// `values[second..second + 8]`.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn select(self, values: &[f64], base: usize, second: usize, at: &[i64; LANES]) -> [f64; 8] {
        use std::arch::x86_64::{_mm512_loadu_epi64, _mm512_loadu_pd, _mm512_permutex2var_pd};
        // Texel indices come from `Axis`, within the field: base, second ≤ W·H − 1 and the
        // loads end within the padding. Clamping them to the last LANES values anyway keeps
        // every load in bounds whatever the tables hold (one instruction, where a checked
        // slice costs two compares and branches).
        let last = values.len() - LANES;
        let (base, second) = (base.min(last), second.min(last));
        // SAFETY: a `Windows` exists only if the CPU has AVX-512F (`new`); both loads read
        // LANES values from an index ≤ len − LANES (clamped just above); `at` is 8 i64 (the
        // permutation uses their low 4 bits).
        unsafe {
            let selected = _mm512_permutex2var_pd(
                _mm512_loadu_pd(values.as_ptr().add(base)),
                _mm512_loadu_epi64(at.as_ptr()),
                _mm512_loadu_pd(values.as_ptr().add(second)),
            );
            std::mem::transmute::<std::arch::x86_64::__m512d, [f64; LANES]>(selected)
        }
    }
}

impl TexelReads for Windows<'_> {
    #[inline(always)]
    fn quads(self, field: usize, x: LaneColumns, y: LaneRows, window: Option<&RowWindow>) -> Quads {
        #[cfg(target_arch = "x86_64")]
        if let Some(w) = window {
            let field = &self.column_major[field];
            let (lower, upper) = w.loads(field.height, x);
            return self.window_quads(&field.values, lower, upper, w);
        }
        self.gathers.quads(field, x, y, window)
    }

    #[inline(always)]
    fn quads_of_both(self, x: LaneColumns, y: LaneRows, window: Option<&RowWindow>) -> [Quads; 2] {
        #[cfg(target_arch = "x86_64")]
        if let Some(w) = window {
            let [s, t] = self.column_major;
            let (lower, upper) = w.loads(s.height, x);
            return [
                self.window_quads(&s.values, lower, upper, w),
                self.window_quads(&t.values, lower, upper, w),
            ];
        }
        self.gathers.quads_of_both(x, y, window)
    }
}
