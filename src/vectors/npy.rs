//! Arrays as NumPy `.npy` files (the `npyz` crate): little-endian, C order, one dtype each.

use std::path::Path;

use npyz::WriterBuilder;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// The element type of an array.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Dtype {
    F64,
    F32,
    U32,
    I32,
}

impl Dtype {
    /// NumPy's descriptor: `<f8`, `<f4`, `<u4`, `<i4`.
    pub fn descr(self) -> &'static str {
        match self {
            Dtype::F64 => "<f8",
            Dtype::F32 => "<f4",
            Dtype::U32 => "<u4",
            Dtype::I32 => "<i4",
        }
    }
}

/// The values of an array, in C order.
#[derive(Clone, Debug, PartialEq)]
pub enum Values {
    F64(Vec<f64>),
    F32(Vec<f32>),
    U32(Vec<u32>),
    I32(Vec<i32>),
}

/// An n-dimensional array.
#[derive(Clone, Debug, PartialEq)]
pub struct Array {
    pub shape: Vec<usize>,
    pub values: Values,
}

impl Array {
    /// An array of `shape` holding `values`; panics (a programming error, not input) when the
    /// count differs from the shape's product.
    pub fn new(shape: &[usize], values: Values) -> Array {
        let a = Array {
            shape: shape.to_vec(),
            values,
        };
        assert_eq!(a.len(), shape.iter().product::<usize>(), "array shape");
        a
    }

    pub fn f64(shape: &[usize], v: Vec<f64>) -> Array {
        Array::new(shape, Values::F64(v))
    }
    pub fn f32(shape: &[usize], v: Vec<f32>) -> Array {
        Array::new(shape, Values::F32(v))
    }
    pub fn u32(shape: &[usize], v: Vec<u32>) -> Array {
        Array::new(shape, Values::U32(v))
    }
    pub fn i32(shape: &[usize], v: Vec<i32>) -> Array {
        Array::new(shape, Values::I32(v))
    }

    pub fn dtype(&self) -> Dtype {
        match self.values {
            Values::F64(_) => Dtype::F64,
            Values::F32(_) => Dtype::F32,
            Values::U32(_) => Dtype::U32,
            Values::I32(_) => Dtype::I32,
        }
    }

    /// The number of values.
    pub fn len(&self) -> usize {
        match &self.values {
            Values::F64(v) => v.len(),
            Values::F32(v) => v.len(),
            Values::U32(v) => v.len(),
            Values::I32(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every value widened to f64.
    pub fn to_f64(&self) -> Vec<f64> {
        match &self.values {
            Values::F64(v) => v.clone(),
            Values::F32(v) => v.iter().map(|&x| x as f64).collect(),
            Values::U32(v) => v.iter().map(|&x| x as f64).collect(),
            Values::I32(v) => v.iter().map(|&x| x as f64).collect(),
        }
    }

    /// Write `path` (`.npy`).
    pub fn save(&self, path: &Path) -> Result<()> {
        let io = |e: std::io::Error| Error::io(path, e);
        let mut bytes = Vec::new();
        let shape: Vec<u64> = self.shape.iter().map(|&n| n as u64).collect();
        fn put<T: npyz::AutoSerialize>(
            bytes: &mut Vec<u8>,
            shape: &[u64],
            v: &[T],
        ) -> std::io::Result<()> {
            let mut w = npyz::WriteOptions::new()
                .default_dtype()
                .shape(shape)
                .writer(bytes)
                .begin_nd()?;
            w.extend(v.iter())?;
            w.finish()
        }
        match &self.values {
            Values::F64(v) => put(&mut bytes, &shape, v),
            Values::F32(v) => put(&mut bytes, &shape, v),
            Values::U32(v) => put(&mut bytes, &shape, v),
            Values::I32(v) => put(&mut bytes, &shape, v),
        }
        .map_err(io)?;
        std::fs::write(path, bytes).map_err(io)
    }

    /// Read `path` (`.npy`, C order, one of the four dtypes); a typed error naming the file for
    /// a missing file, another format, dtype or order.
    pub fn load(path: &Path) -> Result<Array> {
        let bytes = crate::input::read_input(path)?;
        let bad = |why: String| Error::Vectors {
            file: path.display().to_string(),
            reason: why,
        };
        if let Some(shape) = declared_shape(&bytes) {
            // npyz multiplies the shape unchecked (an overflow panics in debug builds and wraps
            // in release): refuse a shape that overflows or that the file cannot hold.
            let elements = shape.iter().try_fold(1u64, |n, &d| n.checked_mul(d));
            if elements.is_none_or(|n| n > bytes.len() as u64) {
                return Err(bad(format!(
                    "the header's shape {shape:?} declares more elements than the file's {} \
                     bytes hold",
                    bytes.len()
                )));
            }
        }
        let npy = npyz::NpyFile::new(&bytes[..])
            .map_err(|e| bad(format!("not a .npy file: {}", one_line(&e.to_string()))))?;
        if npy.order() != npyz::Order::C {
            return Err(bad("Fortran order; save the array in C order".into()));
        }
        let shape: Vec<usize> = npy.shape().iter().map(|&n| n as usize).collect();
        let descr = match npy.dtype() {
            npyz::DType::Plain(t) => t.to_string(),
            other => other.descr(),
        };
        let read = |e: std::io::Error| bad(format!("cannot read the data: {e}"));
        let values = match descr.as_str() {
            "<f8" => Values::F64(npy.into_vec().map_err(read)?),
            "<f4" => Values::F32(npy.into_vec().map_err(read)?),
            "<u4" => Values::U32(npy.into_vec().map_err(read)?),
            "<i4" => Values::I32(npy.into_vec().map_err(read)?),
            other => {
                return Err(bad(format!(
                    "dtype {other}; expected <f8, <f4, <u4 or <i4 (little-endian)"
                )))
            }
        };
        let a = Array { shape, values };
        if a.len() != a.shape.iter().product::<usize>() {
            return Err(bad("the data does not fill the shape".into()));
        }
        Ok(a)
    }
}

/// The `'shape': (d0, d1, …)` of a .npy header as integers, when it reads as such (anything
/// else is left to npyz to refuse). Only the header's first 64 KiB are searched.
fn declared_shape(bytes: &[u8]) -> Option<Vec<u64>> {
    let header = String::from_utf8_lossy(&bytes[..bytes.len().min(1 << 16)]);
    let after = &header[header.find("'shape'")? + "'shape'".len()..];
    let tuple = after
        .trim_start()
        .strip_prefix(':')?
        .trim_start()
        .strip_prefix('(')?;
    let inside = &tuple[..tuple.find(')')?];
    inside
        .split(',')
        .map(str::trim)
        .filter(|d| !d.is_empty())
        .map(|d| d.trim_end_matches('L').parse::<u64>().ok())
        .collect()
}

/// `message` on one line: npyz's header errors quote the header over several lines (a caret
/// under the bad character); its lines are joined by ` | ` with their indentation dropped.
fn one_line(message: &str) -> String {
    message
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && *l != "|")
        .collect::<Vec<_>>()
        .join(" | ")
}
