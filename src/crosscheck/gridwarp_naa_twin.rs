//! The f32 twin of `gridwarp_naa_cell` and `gridwarp_naa_residuals`
//! ([`crate::twin::gridwarp_naa`], the WGSL line for line) run over [`F`] on the kernel's own
//! input ([`NaaInput`], the buffers the GPU receives), returning what the GPU returns: one
//! (r^s, r^t) per sample and one [`NaaCellContribution`] per cell. Run under each of the seven
//! arithmetic models ([`crate::twin::with_model`]) and judged by the very rows that judge the
//! GPU ([`super::gridwarp_naa::naa_judged_rows`]), it shows the bound accepts every conforming
//! evaluation, not only lavapipe's; run on a mutated input ([`NaaMutant`]) it shows the bound
//! rejects the porting mistakes a host or a shader makes.

use reparam_gpu::gridwarp::{NaaCellContribution, NaaInput, VectorFieldF32};

use crate::twin::gridwarp_aa::RestSample;
use crate::twin::gridwarp_naa::{
    cell_contribution, sample_residuals, Corners, Fields, RestCell, VectorField,
};
use crate::twin::{Real, F, V2};

/// A field of the input as the twin reads it.
fn field_of(f: &VectorFieldF32) -> (Vec<F>, usize, usize) {
    let values = f.values.iter().map(|&v| F::from(v)).collect();
    (values, f.width as usize, f.height as usize)
}

/// The twin's view of `input`: samples, rest sizes, corners and fields over [`F`].
struct TwinInput {
    samples: Vec<RestSample<F>>,
    per_cell: usize,
    h: Vec<F>,
    k: Vec<F>,
    vertices: Vec<V2<F>>,
    rows: usize,
    d_s: (Vec<F>, usize, usize),
    d_t: (Vec<F>, usize, usize),
}

impl TwinInput {
    fn new(input: &NaaInput) -> TwinInput {
        let f = |v: f32| F::from(v);
        TwinInput {
            samples: input
                .samples
                .iter()
                .map(|p| RestSample {
                    alpha: f(p.alpha),
                    beta: f(p.beta),
                    sigma: f(p.sigma),
                    o_s: f(p.o_s),
                    o_t: f(p.o_t),
                })
                .collect(),
            per_cell: input.per_cell.max(1) as usize,
            h: input.rest_h.iter().map(|&v| f(v)).collect(),
            k: input.rest_k.iter().map(|&v| f(v)).collect(),
            vertices: input
                .vertices
                .iter()
                .map(|p| V2::new(f(p[0]), f(p[1])))
                .collect(),
            rows: input.rest_k.len(),
            d_s: field_of(&input.d_s),
            d_t: field_of(&input.d_t),
        }
    }

    fn fields(&self) -> Fields<'_, F> {
        fn field((values, width, height): &(Vec<F>, usize, usize)) -> VectorField<'_, F> {
            VectorField {
                values,
                width: *width,
                height: *height,
            }
        }
        Fields {
            d_s: field(&self.d_s),
            d_t: field(&self.d_t),
        }
    }

    /// `rest_cell(i, j)` and `corners(i, j)` of the WGSL: vertex (a, b) at a·N + b.
    fn cell(&self, i: usize, j: usize) -> (RestCell<F>, Corners<F>) {
        let n = self.rows + 1;
        let p = |a: usize, b: usize| self.vertices[a * n + b];
        (
            RestCell {
                h: self.h[i],
                k: self.k[j],
            },
            Corners {
                p00: p(i, j),
                p10: p(i + 1, j),
                p01: p(i, j + 1),
                p11: p(i + 1, j + 1),
            },
        )
    }
}

/// The unknowns of cell (i, j)'s 8 slots as the kernel writes them (`vertex_index`).
fn slots(input: &NaaInput, i: usize, j: usize) -> [i32; 8] {
    let n = input.rest_k.len() + 1;
    let v = |a: usize, b: usize| input.vertex_index[a * n + b];
    let [a, b, c, d] = [v(i, j), v(i + 1, j), v(i, j + 1), v(i + 1, j + 1)];
    [a[0], a[1], b[0], b[1], c[0], c[1], d[0], d[1]]
}

/// The twin's outputs on `input` under the current thread's model: per sample (r^s, r^t)
/// ((0, 0) for σ = 0, as `gridwarp_naa_residuals` writes), per cell its contribution (cell
/// c = i·(N − 1) + j, as `gridwarp_naa_cell` writes). `input` must pass [`NaaInput::check`].
pub fn twin_outputs(input: &NaaInput) -> (Vec<[f32; 2]>, Vec<NaaCellContribution>) {
    let t = TwinInput::new(input);
    let fields = t.fields();
    let cells = t.h.len() * t.rows;
    let mut residuals = Vec::with_capacity(t.samples.len());
    let mut out = Vec::with_capacity(cells);
    for c in 0..cells {
        let (i, j) = (c / t.rows, c % t.rows);
        let (cell, quad) = t.cell(i, j);
        let samples = &t.samples[c * t.per_cell..(c + 1) * t.per_cell];
        for p in samples {
            if p.sigma.value() == 0.0 {
                residuals.push([0.0; 2]);
                continue;
            }
            let r = sample_residuals(&cell, &quad, p, &fields);
            residuals.push([r.r_s.get(), r.r_t.get()]);
        }
        let block = cell_contribution(&cell, &quad, samples, &fields);
        out.push(NaaCellContribution {
            jtj: block.jtj.map(F::get),
            jtr: block.jtr.map(F::get),
            unknowns: slots(input, i, j),
            energy: block.energy.get(),
            _pad: [0.0; 3],
        });
    }
    (residuals, out)
}

/// A realistic porting mistake, applied to the kernel's input (what a host that binds or packs
/// the buffers wrongly, or a shader that reads them wrongly, computes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NaaMutant {
    /// D_s and D_t bound to each other's slot.
    FieldsSwapped,
    /// The fields' rows read top-down (t = 0 at the last row: an image's convention).
    RowsFlipped,
    /// The rest widths h and heights k exchanged.
    SizesSwapped,
    /// Each sample's α and β exchanged.
    AlphaBetaSwapped,
    /// σ = √(w R) taken as 1 for every weighted sample (the weight dropped).
    SigmaDropped,
    /// Each vertex's (s, t) read as (t, s).
    VertexAxesSwapped,
    /// The fields read as `array<vec3<f32>>`, whose stride is 16 bytes, where the buffer packs
    /// 12 (the vec3 padding trap the binding layout forbids): texel n read at floats 4n..4n+3.
    /// (Reading x, y, z as y, z, x is not a mistake of this energy: a permutation of the
    /// components is orthogonal and leaves every ‖J_D W‖ unchanged, an equivalent mutant.)
    Vec3Stride,
}

impl NaaMutant {
    /// Every mutant.
    pub const ALL: [NaaMutant; 7] = [
        NaaMutant::FieldsSwapped,
        NaaMutant::RowsFlipped,
        NaaMutant::SizesSwapped,
        NaaMutant::AlphaBetaSwapped,
        NaaMutant::SigmaDropped,
        NaaMutant::VertexAxesSwapped,
        NaaMutant::Vec3Stride,
    ];

    /// What the mistake is, for the mutation table.
    pub fn describe(self) -> &'static str {
        match self {
            NaaMutant::FieldsSwapped => "D_s and D_t bound to each other's slot",
            NaaMutant::RowsFlipped => "field rows read top-down (image convention)",
            NaaMutant::SizesSwapped => "rest widths h and heights k exchanged",
            NaaMutant::AlphaBetaSwapped => "sample α and β exchanged",
            NaaMutant::SigmaDropped => "σ = √(w R) dropped (1 for every sample)",
            NaaMutant::VertexAxesSwapped => "vertex (s, t) read as (t, s)",
            NaaMutant::Vec3Stride => "fields read with vec3's 16-byte stride (12 packed)",
        }
    }

    /// `input` with the mistake made.
    pub fn apply(self, input: &NaaInput) -> NaaInput {
        let mut m = input.clone();
        match self {
            NaaMutant::FieldsSwapped => std::mem::swap(&mut m.d_s, &mut m.d_t),
            NaaMutant::RowsFlipped => {
                for f in [&mut m.d_s, &mut m.d_t] {
                    let row = 3 * f.width as usize;
                    let rows: Vec<Vec<f32>> =
                        f.values.chunks(row).rev().map(<[f32]>::to_vec).collect();
                    f.values = rows.concat();
                }
            }
            NaaMutant::SizesSwapped => {
                // Only a square cell grid can swap its size arrays without reading out of
                // bounds; otherwise the mistake is the sizes read in reverse order.
                if m.rest_h.len() == m.rest_k.len() {
                    std::mem::swap(&mut m.rest_h, &mut m.rest_k);
                } else {
                    m.rest_h.reverse();
                    m.rest_k.reverse();
                }
            }
            NaaMutant::AlphaBetaSwapped => {
                for p in &mut m.samples {
                    std::mem::swap(&mut p.alpha, &mut p.beta);
                }
            }
            NaaMutant::SigmaDropped => {
                for p in &mut m.samples {
                    if p.sigma != 0.0 {
                        p.sigma = 1.0;
                    }
                }
            }
            NaaMutant::VertexAxesSwapped => {
                for p in &mut m.vertices {
                    p.swap(0, 1);
                }
            }
            NaaMutant::Vec3Stride => {
                for f in [&mut m.d_s, &mut m.d_t] {
                    let packed = &f.values;
                    let read = |n: usize| packed.get(n).copied().unwrap_or(0.0);
                    f.values = (0..packed.len())
                        .map(|n| read(4 * (n / 3) + n % 3))
                        .collect();
                }
            }
        }
        m
    }
}
