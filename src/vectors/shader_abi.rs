//! The binding ABI of `reparam verify --shader`: how a user's compute shader receives a kernel's
//! conformance vectors, derived from the kernel's manifest entry alone, so that every kernel
//! with a manifest (those of later releases too) can judge a shader with no harness written.
//!
//! For a kernel with inputs `in_1 … in_n` (the manifest's `inputs`, in order) and a candidate
//! output of shape (m, …) (the expected array's shape, or the precompute's rows for
//! [`Metric::BpmMapsAtSamples`](super::Metric::BpmMapsAtSamples)):
//!
//! ```text
//! @group(0) @binding(0)      var<uniform> params: Params;          // u32 fields, below
//! @group(0) @binding(i)      var<storage, read> in_i: array<T_i>;  // i = 1 … n, in_i.npy's bytes
//! @group(0) @binding(n + 1)  var<storage, read_write> out: array<f32>;
//! @compute @workgroup_size(64, 1, 1) fn main(…)                   // one invocation per output row
//! ```
//!
//! - `params` holds, as u32: `count` = m (the invocations that do work), then every axis length
//!   of every input in order (`<input>_len0`, `<input>_len1`, …), zero-padded to a multiple of
//!   16 bytes. A shader may declare fewer fields (a prefix) but none of another type.
//! - Input i is the `.npy`'s values in C order, 4 bytes each (f32, u32 or i32): `array<f32>`
//!   indexed `row · k + c`, or an array of a vector or struct whose words are all of the input's
//!   type with no padding (so no `vec3`, whose stride is 16 bytes), whose size tiles the array.
//! - The output is f32, the candidate's shape in C order, at first NaN: an element no
//!   invocation writes is judged non-finite.
//! - Dispatch: G = ⌈m / 64⌉ workgroups on a 2D grid ([`reparam_gpu::user_shader::exercising_grid`]);
//!   an invocation's index is `gid.x + gid.y · num_workgroups.x · 64` and it returns when the
//!   index is ≥ `params.count`.
//!
//! [`ShaderAbi::check`] holds a reflected shader to this before anything runs: a mismatch is one
//! line naming the binding, what the ABI expects (the `.npy` and its dtype) and what the shader
//! declares, and how to fix it. [`ShaderAbi::wgsl`] writes the declarations
//! (`reparam verify DIR --kernel K --print-abi`).

use std::path::Path;

use reparam_gpu::user_shader::{BufferKind, Reflected, Space, UserBuffer, Word, WordKind};

use super::{Array, Dtype, KernelVectors, Values};
use crate::error::{Error, Result};

/// The entry point a shader must have unless `--entry` names another.
pub const DEFAULT_ENTRY: &str = "main";
/// The workgroup size of the ABI (`WORKGROUP_SIZE` of reparam's own kernels).
pub const WORKGROUP: [u32; 3] = [reparam_gpu::compute::WORKGROUP_SIZE, 1, 1];
/// The bit pattern the output starts with (a quiet NaN): unwritten elements fail as non-finite.
pub const UNWRITTEN: u32 = 0x7FC0_0000;

/// One u32 field of `params`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParamField {
    pub name: String,
    pub value: u32,
}

/// One input binding: the `.npy` it holds.
#[derive(Clone, Debug, PartialEq)]
pub struct InputBinding {
    pub binding: u32,
    /// The input's name (`rest` for `skinsimp_lbs.rest.npy`), a WGSL identifier.
    pub name: String,
    /// The `.npy` in the vectors folder.
    pub file: String,
    pub dtype: Dtype,
    pub shape: Vec<usize>,
}

/// The ABI of one kernel (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct ShaderAbi {
    pub kernel: String,
    /// The invocations that do work: the output's first axis.
    pub count: u32,
    /// `params`, padding included.
    pub params: Vec<ParamField>,
    pub inputs: Vec<InputBinding>,
    pub output_binding: u32,
    /// The candidate's shape (what is read back and judged).
    pub output_shape: Vec<usize>,
}

impl ShaderAbi {
    /// The ABI of kernel `k`; [`Error::Vectors`] naming the manifest when the kernel cannot be a
    /// shader's (an f64 input: a whole run's figures, judged on the CPU; a size past u32).
    pub fn of(k: &KernelVectors, manifest: &str) -> Result<ShaderAbi> {
        let bad = |reason: String| Error::Vectors {
            file: manifest.to_string(),
            reason,
        };
        let u32_of = |n: usize, what: &str| {
            u32::try_from(n).map_err(|_| bad(format!("kernel {}: {what} {n} exceeds u32", k.name)))
        };
        let output_shape = k.metric.candidate_shape(&k.expected.shape);
        let count = u32_of(output_shape.first().copied().unwrap_or(1), "output rows")?;
        let mut params = vec![ParamField {
            name: "count".into(),
            value: count,
        }];
        let mut inputs = Vec::new();
        for (i, info) in k.inputs.iter().enumerate() {
            if info.dtype == Dtype::F64 {
                return Err(bad(format!(
                    "kernel {} is not a shader's: its input {} is f64 (a whole run's inputs, \
                     judged with `reparam verify --candidate`); a shader's inputs are 4-byte \
                     f32, u32 or i32",
                    k.name, info.file
                )));
            }
            let name = input_name(&k.name, &info.file, i);
            for (axis, &n) in info.shape.iter().enumerate() {
                params.push(ParamField {
                    name: format!("{name}_len{axis}"),
                    value: u32_of(n, &format!("{} axis {axis}", info.file))?,
                });
            }
            inputs.push(InputBinding {
                binding: u32_of(i + 1, "inputs")?,
                name,
                file: info.file.clone(),
                dtype: info.dtype,
                shape: info.shape.clone(),
            });
        }
        let mut pad = 0;
        while params.len() % 4 != 0 {
            params.push(ParamField {
                name: format!("_pad{pad}"),
                value: 0,
            });
            pad += 1;
        }
        Ok(ShaderAbi {
            kernel: k.name.clone(),
            count,
            params,
            output_binding: u32_of(k.inputs.len() + 1, "inputs")?,
            inputs,
            output_shape,
        })
    }

    /// The declarations a WGSL shader for this kernel starts with.
    pub fn wgsl(&self) -> String {
        let mut s = format!(
            "// reparam verify --shader ABI of kernel {} (one invocation per output row, \
             {} rows)\nstruct Params {{\n",
            self.kernel, self.count
        );
        for p in &self.params {
            s.push_str(&format!("    {}: u32, // {}\n", p.name, p.value));
        }
        s.push_str("}\n\n@group(0) @binding(0) var<uniform> params: Params;\n");
        for i in &self.inputs {
            s.push_str(&format!(
                "@group(0) @binding({}) var<storage, read> {}: array<{}>; // {} {:?}\n",
                i.binding,
                i.name,
                wgsl_scalar(i.dtype),
                i.file,
                i.shape
            ));
        }
        s.push_str(&format!(
            "@group(0) @binding({}) var<storage, read_write> out: array<f32>; // {:?}, C order\n\n\
             @compute @workgroup_size({}, 1, 1)\n\
             fn main(@builtin(global_invocation_id) gid: vec3<u32>, \
             @builtin(num_workgroups) groups: vec3<u32>) {{\n    \
             let index = gid.x + gid.y * groups.x * {}u;\n    \
             if index >= params.count {{\n        return;\n    }}\n    // …\n}}\n",
            self.output_binding, self.output_shape, WORKGROUP[0], WORKGROUP[0]
        ));
        s
    }

    /// Hold the shader `file`'s reflected `bindings` and `workgroup` size to the ABI: the first
    /// mismatch as one line naming the binding, the expected and the found declaration.
    pub fn check(&self, file: &str, bindings: &[Reflected], workgroup: [u32; 3]) -> Result<()> {
        let bad = |reason: String| Error::Vectors {
            file: file.to_string(),
            reason,
        };
        let hint = format!(
            "(`reparam verify DIR --kernel {} --print-abi` prints the declarations)",
            self.kernel
        );
        if workgroup != WORKGROUP {
            return Err(bad(format!(
                "@workgroup_size{workgroup:?}; kernel {}'s ABI dispatches one invocation per \
                 output row in workgroups of @workgroup_size({}, 1, 1) {hint}",
                self.kernel, WORKGROUP[0]
            )));
        }
        for r in bindings {
            let at = format!("@group({}) @binding({}) `{}`", r.group, r.binding, r.name);
            if r.group != 0 {
                return Err(bad(format!(
                    "{at}: reparam binds group 0 only (bindings 0 to {}) {hint}",
                    self.output_binding
                )));
            }
            if r.binding == 0 {
                self.check_params(r, &at, &hint).map_err(bad)?;
            } else if let Some(input) = self.inputs.iter().find(|i| i.binding == r.binding) {
                check_input(input, r, &at, &hint).map_err(bad)?;
            } else if r.binding == self.output_binding {
                self.check_output(r, &at, &hint).map_err(bad)?;
            } else {
                return Err(bad(format!(
                    "{at}: kernel {} has bindings 0 (params) to {} (the output); this one holds \
                     nothing {hint}",
                    self.kernel, self.output_binding
                )));
            }
        }
        match bindings
            .iter()
            .find(|r| r.group == 0 && r.binding == self.output_binding)
        {
            Some(r) if r.written => Ok(()),
            _ => Err(bad(format!(
                "the entry point never writes @binding({}), the output {hint}",
                self.output_binding
            ))),
        }
    }

    fn check_params(&self, r: &Reflected, at: &str, hint: &str) -> std::result::Result<(), String> {
        let expected = format!(
            "var<uniform> of at most {} u32 fields ({})",
            self.params.len(),
            names(&self.params)
        );
        if r.space != Space::Uniform || r.element.is_some() {
            return Err(format!(
                "{at}: expected {expected}, found {} {} {hint}",
                r.space, r.type_name
            ));
        }
        if r.fixed.len() > self.params.len() {
            return Err(format!(
                "{at}: {} is {} bytes; expected {expected}, {} bytes {hint}",
                r.type_name,
                4 * r.fixed.len(),
                4 * self.params.len()
            ));
        }
        for (w, p) in r.fixed.iter().zip(&self.params) {
            if !matches!(w.kind, WordKind::U32 | WordKind::I32 | WordKind::Hole) {
                return Err(format!(
                    "{at}: field `{}` is {}, where params has `{}` (u32); expected {expected} \
                     {hint}",
                    w.name, w.kind, p.name
                ));
            }
        }
        Ok(())
    }

    fn check_output(&self, r: &Reflected, at: &str, hint: &str) -> std::result::Result<(), String> {
        let total: usize = self.output_shape.iter().product();
        let expected = format!(
            "var<storage, read_write> array<f32> (the candidate, f32 {:?} in C order)",
            self.output_shape
        );
        array_of(r, Dtype::F32, total, true)
            .map_err(|why| format!("{at}: expected {expected}, found {why} {hint}"))
    }
}

/// Input `input` against its reflected binding `r`.
fn check_input(
    input: &InputBinding,
    r: &Reflected,
    at: &str,
    hint: &str,
) -> std::result::Result<(), String> {
    let total: usize = input.shape.iter().product();
    array_of(r, input.dtype, total, false).map_err(|why| {
        format!(
            "{at}: expected var<storage, read> array<{}> ({}, {} {:?} in C order), found {why} \
             {hint}",
            wgsl_scalar(input.dtype),
            input.file,
            wgsl_scalar(input.dtype),
            input.shape
        )
    })
}

/// Whether `r` is a runtime-sized storage array (writable as asked) whose element is a whole
/// number of `dtype` words, no padding, tiling `total` values; else what it is instead.
fn array_of(
    r: &Reflected,
    dtype: Dtype,
    total: usize,
    writable: bool,
) -> std::result::Result<(), String> {
    let found = format!("{} {}", r.space, r.type_name);
    if r.space != (Space::Storage { writable }) {
        return Err(found);
    }
    let element = match (&r.element, r.fixed.is_empty()) {
        (Some(e), true) => e,
        _ => return Err(format!("{found} (declare a runtime-sized array<T>)")),
    };
    let want = word_kind(dtype);
    if let Some(w) = element.iter().find(|w| w.kind != want) {
        return Err(format!("{found}, whose element has {}", describe(w)));
    }
    if element.is_empty() || !total.is_multiple_of(element.len()) {
        return Err(format!(
            "{found}, whose element of {} words does not tile the {total} values",
            element.len()
        ));
    }
    Ok(())
}

/// `padding after x` or `f32 at b[1]`: a word for an error message.
fn describe(w: &Word) -> String {
    match w.kind {
        WordKind::Hole => format!(
            "padding ({}: a vec3 or an aligned member; use scalars or vec2/vec4)",
            w.name
        ),
        _ => format!("{} at `{}`", w.kind, w.name),
    }
}

fn names(params: &[ParamField]) -> String {
    params
        .iter()
        .map(|p| p.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

fn word_kind(d: Dtype) -> WordKind {
    match d {
        Dtype::F32 | Dtype::F64 => WordKind::F32,
        Dtype::U32 => WordKind::U32,
        Dtype::I32 => WordKind::I32,
    }
}

fn wgsl_scalar(d: Dtype) -> &'static str {
    match d {
        Dtype::F32 | Dtype::F64 => "f32",
        Dtype::U32 => "u32",
        Dtype::I32 => "i32",
    }
}

/// The input's name: its file less `<kernel>.` and `.npy` (`in<i>` when that is no identifier).
fn input_name(kernel: &str, file: &str, i: usize) -> String {
    let stem = file.strip_suffix(".npy").unwrap_or(file);
    let name = stem
        .strip_prefix(kernel)
        .and_then(|s| s.strip_prefix('.'))
        .unwrap_or(stem);
    let identifier = name.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if identifier {
        name.to_string()
    } else {
        format!("in{}", i + 1)
    }
}

/// The buffers of the ABI for the vectors in `dir`: params, every input's bytes, the output
/// (NaN-filled, read back).
pub fn buffers(abi: &ShaderAbi, dir: &Path) -> Result<Vec<UserBuffer>> {
    let words =
        |w: &mut dyn Iterator<Item = u32>| -> Vec<u8> { w.flat_map(|x| x.to_le_bytes()).collect() };
    let mut out = vec![UserBuffer {
        binding: 0,
        contents: words(&mut abi.params.iter().map(|p| p.value)),
        kind: BufferKind::Uniform,
    }];
    for input in &abi.inputs {
        let path = dir.join(&input.file);
        let a = Array::load(&path)?;
        if a.shape != input.shape || a.dtype() != input.dtype {
            return Err(Error::Vectors {
                file: path.display().to_string(),
                reason: format!(
                    "{:?} {:?}; the manifest says {:?} {:?}",
                    a.dtype(),
                    a.shape,
                    input.dtype,
                    input.shape
                ),
            });
        }
        let contents = match &a.values {
            Values::F32(v) => words(&mut v.iter().map(|x| x.to_bits())),
            Values::U32(v) => words(&mut v.iter().copied()),
            Values::I32(v) => words(&mut v.iter().map(|x| *x as u32)),
            Values::F64(_) => {
                return Err(Error::Vectors {
                    file: path.display().to_string(),
                    reason: "f64; a shader's inputs are 4-byte values".into(),
                })
            }
        };
        out.push(UserBuffer {
            binding: input.binding,
            contents,
            kind: BufferKind::Read,
        });
    }
    let total: usize = abi.output_shape.iter().product();
    out.push(UserBuffer {
        binding: abi.output_binding,
        contents: words(&mut std::iter::repeat_n(UNWRITTEN, total)),
        kind: BufferKind::Write { read_back: true },
    });
    Ok(out)
}

/// The read-back output bytes as the candidate array.
pub fn candidate(abi: &ShaderAbi, bytes: &[u8]) -> Array {
    let values: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|w| f32::from_le_bytes([w[0], w[1], w[2], w[3]]))
        .collect();
    let total: usize = abi.output_shape.iter().product();
    let mut values = values;
    values.resize(total, f32::NAN);
    Array::f32(&abi.output_shape, values)
}
