//! `gridwarp_aa`'s candidates from its twin ([`crate::twin::gridwarp_aa`]): `.residuals`, the
//! residual pair (r^s, r^t) of every rest sample ([samples, 2]), and the host's assembly of the
//! cells' shares (gpu/src/gridwarp/aa.rs: added in cell order, in f64) into `.cell_energy`,
//! `.energy`, `.jtj` and `.jtr`, as a conforming GPU under a [`Model`] computes them.

use std::path::Path;

use super::invalid;
use crate::error::Result;
use crate::twin::gridwarp_aa::{
    cell_contribution, sample_residuals, CellContribution, CellLines, Field, RestSample,
};
use crate::twin::{with_model, Model, F};
use crate::vectors::{Array, KernelVectors};

/// One kernel's inputs as its bindings hold them.
#[derive(Clone, Debug)]
pub struct Inputs {
    /// (α, β, σ, o_s, o_t) per rest sample, cell after cell.
    pub samples: Vec<F>,
    /// Samples per cell.
    pub per_cell: usize,
    /// Rest sizes h_i of the columns and k_j of the rows.
    pub h: Vec<F>,
    pub k: Vec<F>,
    /// The grid lines s_0 … s_M and t_0 … t_N.
    pub s: Vec<F>,
    pub t: Vec<F>,
    /// Each line's unknown (s first, then t), −1 where the line is fixed.
    pub s_index: Vec<i32>,
    pub t_index: Vec<i32>,
    /// The fields D_s, D_t: (values, width, height).
    pub d_s: (Vec<F>, usize, usize),
    pub d_t: (Vec<F>, usize, usize),
}

/// A field (values, width, height) as the kernel reads it.
fn field((values, width, height): &(Vec<F>, usize, usize)) -> Field<'_, F> {
    Field {
        values,
        width: *width,
        height: *height,
    }
}

/// f32 values as the twin's scalars (the inputs are f32 arrays: exact).
fn scalars(a: &Array) -> Vec<F> {
    a.to_f64().into_iter().map(|x| F::new(x as f32)).collect()
}

impl Inputs {
    /// The inputs of kernel `k` in `dir`. Errors: a missing input; sizes that disagree (a field
    /// that is not [H, W], fewer than 2 lines, h, k or the line indices not one per column, row
    /// or line, a sample count that is not cells × per_cell).
    pub fn load(dir: &Path, k: &KernelVectors) -> Result<Inputs> {
        let field = |name: &str| -> Result<(Vec<F>, usize, usize)> {
            let a = k.load_input(dir, name)?;
            match a.shape[..] {
                [h, w] if w > 0 && h > 0 => Ok((scalars(&a), w, h)),
                _ => Err(invalid(
                    k,
                    format!("{name} has shape {:?}, expected [H, W]", a.shape),
                )),
            }
        };
        let indices = |name: &str| -> Result<Vec<i32>> {
            Ok(k.load_input(dir, name)?
                .to_f64()
                .iter()
                .map(|&v| v as i32)
                .collect())
        };
        let x = Inputs {
            samples: scalars(&k.load_input(dir, "samples")?),
            per_cell: k
                .load_input(dir, "per_cell")?
                .to_f64()
                .first()
                .map_or(0, |&v| v as usize),
            h: scalars(&k.load_input(dir, "rest_h")?),
            k: scalars(&k.load_input(dir, "rest_k")?),
            s: scalars(&k.load_input(dir, "s")?),
            t: scalars(&k.load_input(dir, "t")?),
            s_index: indices("s_index")?,
            t_index: indices("t_index")?,
            d_s: field("d_s")?,
            d_t: field("d_t")?,
        };
        let (columns, rows) = (x.s.len().saturating_sub(1), x.t.len().saturating_sub(1));
        let consistent = columns > 0
            && rows > 0
            && x.h.len() == columns
            && x.k.len() == rows
            && x.s_index.len() == x.s.len()
            && x.t_index.len() == x.t.len()
            && x.samples.len() == 5 * columns * rows * x.per_cell;
        if !consistent {
            return Err(invalid(
                k,
                format!(
                    "{} s and {} t lines need one rest size per column and row, one index per \
                     line and 5 × cells × per_cell ({}) sample values; found h {}, k {}, \
                     indices {} and {}, {} sample values",
                    x.s.len(),
                    x.t.len(),
                    x.per_cell,
                    x.h.len(),
                    x.k.len(),
                    x.s_index.len(),
                    x.t_index.len(),
                    x.samples.len()
                ),
            ));
        }
        Ok(x)
    }

    /// The fields D_s, D_t as the kernel reads them.
    pub fn fields(&self) -> (Field<'_, F>, Field<'_, F>) {
        (field(&self.d_s), field(&self.d_t))
    }

    /// (columns, rows) of cells.
    pub fn cells(&self) -> (usize, usize) {
        (self.s.len() - 1, self.t.len() - 1)
    }

    /// Cell (i, j)'s lines and rest size.
    pub fn lines(&self, i: usize, j: usize) -> CellLines<F> {
        CellLines {
            s0: self.s[i],
            s1: self.s[i + 1],
            t0: self.t[j],
            t1: self.t[j + 1],
            h: self.h[i],
            k: self.k[j],
        }
    }

    /// The rest samples.
    pub fn rest_samples(&self) -> Vec<RestSample<F>> {
        self.samples
            .chunks(5)
            .map(|v| RestSample {
                alpha: v[0],
                beta: v[1],
                sigma: v[2],
                o_s: v[3],
                o_t: v[4],
            })
            .collect()
    }
}

/// What a port does with one sample: its cell's lines and rest size, the sample, the fields.
pub type Body = fn(&CellLines<F>, &RestSample<F>, &Field<F>, &Field<F>) -> [F; 2];

/// How a port maps the cell index c to (column i, row j), given (columns, rows).
pub type CellOrder = fn(usize, usize, usize) -> (usize, usize);

/// The kernel's cell order: c = i · rows + j.
pub fn row_inner(c: usize, _: usize, rows: usize) -> (usize, usize) {
    (c / rows, c % rows)
}

/// `.residuals`' candidate of `body` with cell order `order` under `model`: [samples, 2].
pub fn residuals_with(x: &Inputs, body: Body, order: CellOrder, model: Model) -> Array {
    let (d_s, d_t) = x.fields();
    let (columns, rows) = x.cells();
    let mut out = Vec::new();
    for (n, sample) in x.rest_samples().iter().enumerate() {
        let (i, j) = order(n / x.per_cell.max(1), columns, rows);
        let lines = x.lines(i.min(columns - 1), j.min(rows - 1));
        let r = with_model(model, || body(&lines, sample, &d_s, &d_t));
        out.extend([r[0].get(), r[1].get()]);
    }
    Array::f32(&[out.len() / 2, 2], out)
}

/// `.residuals`' candidate (vectors in `dir`) under `model`.
pub fn residuals(dir: &Path, k: &KernelVectors, model: Model) -> Result<Array> {
    Ok(residuals_with(
        &Inputs::load(dir, k)?,
        sample_residuals,
        row_inner,
        model,
    ))
}

/// What a port does with one cell (its lines, samples and the fields).
pub type CellBody =
    fn(&CellLines<F>, &[RestSample<F>], &Field<F>, &Field<F>) -> CellContribution<F>;

/// How a port numbers the unknown of a line: (the manifest's index, the count of s unknowns).
pub type UnknownOrder = fn(i32, usize) -> i32;

/// The unknowns as the manifest numbers them (s first, then t).
pub fn as_numbered(u: i32, _: usize) -> i32 {
    u
}

/// The host's assembly (gpu/src/gridwarp/aa.rs): cells added in cell order, in f64, each
/// slot's row and column dropped where its line is fixed (−1).
#[derive(Clone, Debug, PartialEq)]
pub struct Assembled {
    pub cell_energy: Vec<f64>,
    pub energy: f64,
    pub jtj: Vec<f64>,
    pub jtr: Vec<f64>,
}

impl Assembled {
    /// The output that kernel `name` (`gridwarp_aa.cell_energy`, `.energy`, `.jtj`, `.jtr`)
    /// is judged on.
    pub fn output(&self, name: &str) -> Option<Array> {
        let n = self.jtr.len();
        Some(match name {
            "gridwarp_aa.cell_energy" => {
                Array::f64(&[self.cell_energy.len()], self.cell_energy.clone())
            }
            "gridwarp_aa.energy" => Array::f64(&[1], vec![self.energy]),
            "gridwarp_aa.jtj" => Array::f64(&[n, n], self.jtj.clone()),
            "gridwarp_aa.jtr" => Array::f64(&[n], self.jtr.clone()),
            _ => return None,
        })
    }
}

/// Every cell's share by `body` under `model`, assembled by the host with the unknowns
/// numbered by `unknown_order`.
pub fn assemble(
    x: &Inputs,
    body: CellBody,
    unknown_order: UnknownOrder,
    model: Model,
) -> Assembled {
    let n = x
        .s_index
        .iter()
        .chain(&x.t_index)
        .filter(|&&u| u >= 0)
        .count();
    let ns = x.s_index.iter().filter(|&&u| u >= 0).count();
    let (d_s, d_t) = x.fields();
    let (columns, rows) = x.cells();
    let samples = x.rest_samples();
    let mut out = Assembled {
        cell_energy: vec![0.0; columns * rows],
        energy: 0.0,
        jtj: vec![0.0; n * n],
        jtr: vec![0.0; n],
    };
    let slot = |u: i32| usize::try_from(u).ok().filter(|&u| u < n);
    for c in 0..columns * rows {
        let (i, j) = (c / rows, c % rows);
        let lines = x.lines(i, j);
        let cell_samples = &samples[c * x.per_cell..(c + 1) * x.per_cell];
        let cell = with_model(model, || body(&lines, cell_samples, &d_s, &d_t));
        let unknowns = [
            x.s_index[i],
            x.s_index[i + 1],
            x.t_index[j],
            x.t_index[j + 1],
        ]
        .map(|u| slot(unknown_order(u, ns)));
        out.cell_energy[c] = cell.energy.f64();
        out.energy += cell.energy.f64();
        for a in 0..4 {
            let Some(ua) = unknowns[a] else { continue };
            out.jtr[ua] += cell.jtr[a].f64();
            for (b, ub) in unknowns.iter().enumerate() {
                if let Some(ub) = ub {
                    out.jtj[ua * n + ub] += cell.jtj[4 * a + b].f64();
                }
            }
        }
    }
    out
}

/// The candidate of `.cell_energy`, `.energy`, `.jtj` or `.jtr` (vectors in `dir`) under
/// `model`: the twin's [`cell_contribution`] assembled ([`assemble`]).
pub fn normal_equations(dir: &Path, k: &KernelVectors, model: Model) -> Result<Array> {
    let x = Inputs::load(dir, k)?;
    assemble(&x, cell_contribution, as_numbered, model)
        .output(&k.name)
        .ok_or_else(|| invalid(k, "not a kernel of the gridwarp_aa assembly".into()))
}
