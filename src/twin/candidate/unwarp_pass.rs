//! `unwarp_pass` ([`crate::twin::unwarp_pass`]) over the canonical vectors' inputs
//! (`reference_data/vectors/unwarp/unwarp_pass.*.npy`, written by [`crate::vectors::unwarp`]):
//! the new offset of every active texel, [n, 2] f32, as a conforming GPU under a [`Model`]
//! would return it to `verify`.

use std::path::Path;

use crate::error::{Error, Result};
use crate::twin::unwarp_pass::{
    unwarp_pass, unwarp_pass_invocation, Bindings, TexelResult, UnwarpParams,
};
use crate::twin::{with_model, Model, F, V2};
use crate::vectors::{Array, KernelVectors};

/// The kernel's inputs as its bindings hold them: `params` (θ, R and the border from
/// `params.npy`, W and H from the shape of `z.npy`), z, pin weights and offsets per node
/// (row-major), and the active node indices in dispatch order.
#[derive(Clone, Debug)]
pub struct Inputs {
    pub params: UnwarpParams<F>,
    pub z: Vec<F>,
    pub pins: Vec<F>,
    pub offsets: Vec<V2<F>>,
    pub active: Vec<usize>,
}

/// A [`Error::Vectors`] about `file`.
fn bad(file: &str, reason: String) -> Error {
    Error::Vectors {
        file: file.into(),
        reason,
    }
}

/// Input `name` of kernel `k` (the file `<kernel>.<name>.npy` in `dir`), with its shape
/// checked against `shape`.
fn load(dir: &Path, k: &KernelVectors, name: &str, shape: Option<&[usize]>) -> Result<Array> {
    let suffix = format!(".{name}.npy");
    let info = k
        .inputs
        .iter()
        .find(|i| i.file.ends_with(&suffix))
        .ok_or_else(|| bad(&k.name, format!("no input `{name}` in the manifest")))?;
    let a = Array::load(&dir.join(&info.file))?;
    if let Some(shape) = shape {
        if a.shape != shape {
            return Err(bad(
                &info.file,
                format!("shape {:?}, expected {shape:?}", a.shape),
            ));
        }
    }
    Ok(a)
}

/// f32 values as the twin's scalars (the inputs are f32 arrays: exact).
fn scalars(a: &Array) -> Vec<F> {
    a.to_f64().into_iter().map(|v| F::new(v as f32)).collect()
}

impl Inputs {
    /// The inputs of kernel `k` (`unwarp_pass`) in `dir`. Errors: a missing input, a shape
    /// that disagrees with `z`'s [H, W], an active index outside the grid.
    pub fn load(dir: &Path, k: &KernelVectors) -> Result<Inputs> {
        let z = load(dir, k, "z", None)?;
        let [h, w] = z.shape[..] else {
            return Err(bad(
                &k.name,
                format!("z has shape {:?}, expected [H, W]", z.shape),
            ));
        };
        let pins = load(dir, k, "pins", Some(&[h, w]))?;
        let offsets = load(dir, k, "offsets", Some(&[h, w, 2]))?.to_f64();
        let params = load(dir, k, "params", Some(&[4]))?.to_f64();
        let active: Vec<usize> = load(dir, k, "active", None)?
            .to_f64()
            .into_iter()
            .map(|c| c as usize)
            .collect();
        if let Some(c) = active.iter().find(|&&c| c >= w * h) {
            return Err(bad(
                &k.name,
                format!("active node {c} outside the {w}×{h} grid"),
            ));
        }
        let f = |v: f64| F::new(v as f32);
        Ok(Inputs {
            params: UnwarpParams {
                width: w as u32,
                height: h as u32,
                periodic: params[3] != 0.0,
                theta: f(params[0]),
                pin_resolution: V2::new(f(params[1]), f(params[2])),
            },
            z: scalars(&z),
            pins: scalars(&pins),
            offsets: offsets
                .chunks_exact(2)
                .map(|o| V2::new(f(o[0]), f(o[1])))
                .collect(),
            active,
        })
    }

    /// The dispatch over the active texels under `model` with `body` per invocation: the new
    /// offsets, [n, 2] f32 in the order of `active`.
    pub fn run(&self, model: Model, body: impl Fn(&Bindings<F>, usize) -> TexelResult<F>) -> Array {
        let mut offsets = self.offsets.clone();
        let results = with_model(model, || {
            unwarp_pass(
                self.params,
                &self.z,
                &self.pins,
                &self.active,
                &mut offsets,
                body,
            )
        });
        let values = results
            .iter()
            .flat_map(|r| r.offset.values().map(|v| v as f32))
            .collect();
        Array::f32(&[results.len(), 2], values)
    }
}

/// The twin's candidate for kernel `k` (`unwarp_pass`) of the vectors in `dir` under `model`.
pub fn candidate(dir: &Path, k: &KernelVectors, model: Model) -> Result<Array> {
    candidate_with(dir, k, model, unwarp_pass_invocation)
}

/// [`candidate`] with another per-invocation `body` (a port's, e.g. a mutant's) in place of
/// [`unwarp_pass_invocation`].
pub fn candidate_with(
    dir: &Path,
    k: &KernelVectors,
    model: Model,
    body: impl Fn(&Bindings<F>, usize) -> TexelResult<F>,
) -> Result<Array> {
    Ok(Inputs::load(dir, k)?.run(model, body))
}
