//! Conformance vectors: every kernel's inputs exactly as the kernel receives them and the f64
//! expected outputs, as NumPy `.npy` arrays with a `manifest.json` that says what each array
//! means, how a candidate's output is measured, and the bound each element is held to — the
//! same metric and bound functions as the cross-check ([`crate::crosscheck`]). `reparam
//! vectors` writes them, `reparam verify` judges another implementation's outputs against them.
//!
//! Layout of a vectors folder:
//!
//! ```text
//! manifest.json                    reparam version, the command, every kernel (below)
//! <kernel>.<input>.npy             the kernel's inputs
//! <kernel>.expected.npy            the f64 reference's output
//! <kernel>.bound.npy               the bound of each element (see `metric`)
//! ```
#![doc = include_str!("README.md")]

pub mod bpm;
pub mod gridwarp;
pub mod gridwarp_lookup;
pub mod maps;
pub mod npy;
pub mod shader_abi;
pub mod skinsimp;
pub mod unwarp;
pub mod verify;

use std::path::Path;

use serde::{Deserialize, Serialize};

pub use npy::{Array, Dtype, Values};

use crate::error::{Error, Result};

/// How a candidate's output is compared with the expected one, element by element.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Metric {
    /// An element is a vector along the last axis: error = scale · ‖candidate − expected‖₂
    /// (e.g. a UV in texels of a 4096² texture: scale 4096).
    NormOfLastAxis { scale: f64, unit: String },
    /// An element is one value: error = |candidate − expected|.
    Absolute { unit: String },
    /// An element is one figure of a whole run (an energy, a distance): error =
    /// |candidate − expected| / |expected| (|candidate| where expected is 0).
    Relative { unit: String },
    /// The candidate is a precompute's output, one row per face: the 44 values of the
    /// `bpm_eval` kernel's `maps` input, then its flags as a number (shape (faces, 45)). Each
    /// element is a sample (the kernel's `face` and `bary` inputs): error = scale · |f(z) −
    /// expected| with f evaluated in f64 from the candidate's row by the reference's
    /// evaluation ([`crate::bpm::eval::eval_bpm`], seed 004 steps 6–9), so that only the
    /// precompute is judged, whatever scale or sign its Möbius matrices carry.
    BpmMapsAtSamples {
        scale: f64,
        unit: String,
        faces: usize,
    },
}

impl Metric {
    /// The unit the errors and bounds are in.
    pub fn unit(&self) -> &str {
        match self {
            Metric::NormOfLastAxis { unit, .. }
            | Metric::Absolute { unit }
            | Metric::Relative { unit }
            | Metric::BpmMapsAtSamples { unit, .. } => unit,
        }
    }

    /// The shape a candidate must have, given the expected one.
    pub fn candidate_shape(&self, expected: &[usize]) -> Vec<usize> {
        match self {
            Metric::BpmMapsAtSamples { faces, .. } => vec![*faces, bpm::MAPS_ROW],
            _ => expected.to_vec(),
        }
    }

    /// The shape of the elements (one error and one bound each), given the expected shape.
    pub fn element_shape(&self, expected: &[usize]) -> Vec<usize> {
        match self {
            Metric::NormOfLastAxis { .. } | Metric::BpmMapsAtSamples { .. } => {
                expected[..expected.len().saturating_sub(1)].to_vec()
            }
            Metric::Absolute { .. } | Metric::Relative { .. } => expected.to_vec(),
        }
    }

    /// The magnitude of each expected element in the errors' unit, for the summary's relative
    /// error: scale · ‖expected‖₂ per vector, |expected| per value; 1 for [`Metric::Relative`],
    /// whose errors are already relative (so `max_rel` is the largest of them).
    pub fn magnitudes(&self, expected: &[f64], last: usize) -> Vec<f64> {
        match self {
            Metric::NormOfLastAxis { scale, .. } | Metric::BpmMapsAtSamples { scale, .. } => {
                expected
                    .chunks(last.max(1))
                    .map(|e| scale * e.iter().map(|x| x * x).sum::<f64>().sqrt())
                    .collect()
            }
            Metric::Absolute { .. } => expected.iter().map(|e| e.abs()).collect(),
            Metric::Relative { .. } => vec![1.0; expected.len()],
        }
    }

    /// The element errors of `candidate` against `expected` (same length; flat C order with
    /// `last` values along the last axis); `None` for [`Metric::BpmMapsAtSamples`], whose errors
    /// need the samples ([`bpm::errors_at_samples`]). NaN or ∞ where a value is; an error of
    /// finite values too large for f64 (a candidate's 1e308) is `f64::MAX`, not ∞.
    pub fn errors(&self, expected: &[f64], candidate: &[f64], last: usize) -> Option<Vec<f64>> {
        Some(match self {
            Metric::NormOfLastAxis { scale, .. } => expected
                .chunks(last.max(1))
                .zip(candidate.chunks(last.max(1)))
                .map(|(e, c)| {
                    let error = scale
                        * e.iter()
                            .zip(c)
                            .map(|(a, b)| (a - b) * (a - b))
                            .sum::<f64>()
                            .sqrt();
                    saturate(error, e, c)
                })
                .collect(),
            Metric::Absolute { .. } => expected
                .iter()
                .zip(candidate)
                .map(|(a, b)| saturate((a - b).abs(), &[*a], &[*b]))
                .collect(),
            Metric::Relative { .. } => expected
                .iter()
                .zip(candidate)
                .map(|(a, b)| saturate(relative_difference(*b, *a), &[*a], &[*b]))
                .collect(),
            Metric::BpmMapsAtSamples { .. } => return None,
        })
    }
}

/// An element's `error` from the expected values `e` and the candidate's `c`: itself, unless
/// it overflowed from finite values (a candidate's 1e308), then `f64::MAX`, so that only a
/// NaN or ∞ of the candidate counts as non-finite.
pub fn saturate(error: f64, e: &[f64], c: &[f64]) -> f64 {
    if error.is_finite() || e.iter().chain(c).any(|x| !x.is_finite()) {
        error
    } else {
        f64::MAX
    }
}

/// |candidate − expected| / |expected|, or |candidate| where expected is 0.
pub fn relative_difference(candidate: f64, expected: f64) -> f64 {
    let d = (candidate - expected).abs();
    if expected == 0.0 {
        d
    } else {
        d / expected.abs()
    }
}

/// One array in the manifest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ArrayInfo {
    /// File name in the vectors folder.
    pub file: String,
    pub shape: Vec<usize>,
    pub dtype: Dtype,
    /// What the array holds: row order, units, index base, which barycentric goes with which
    /// corner.
    pub meaning: String,
    /// Row r of this input belongs to the element(s) whose first index is r (what `verify`
    /// prints beside a worst element).
    #[serde(default)]
    pub indexed_by_element: bool,
}

/// One kernel's vectors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KernelVectors {
    /// e.g. `bpm_eval`, `gridwarp_aa.jtj`.
    pub name: String,
    /// What the kernel computes (formula, paper section).
    pub description: String,
    pub inputs: Vec<ArrayInfo>,
    /// The f64 expected output; a candidate must have this shape (f32 or f64).
    pub expected: ArrayInfo,
    /// The bound of each element, in the metric's unit (shape: the expected shape, less the
    /// last axis for [`Metric::NormOfLastAxis`]).
    pub bound: ArrayInfo,
    pub metric: Metric,
    /// The bound's formula, and why it holds.
    pub bound_formula: String,
    pub derivation: String,
    /// The branches and terms of the kernel these vectors exercise (empty in manifests written
    /// before reparam listed them).
    #[serde(default)]
    pub covers: Vec<String>,
}

impl KernelVectors {
    /// The input array called `name` (`<kernel>.<name>.npy` in the vectors folder `dir`);
    /// [`Error::Vectors`] naming the manifest when the kernel has no such input.
    pub fn load_input(&self, dir: &Path, name: &str) -> Result<Array> {
        let info = self
            .inputs
            .iter()
            .find(|i| i.file.ends_with(&format!(".{name}.npy")))
            .ok_or_else(|| Error::Vectors {
                file: dir.join("manifest.json").display().to_string(),
                reason: format!("kernel {} has no input '{name}'", self.name),
            })?;
        Array::load(&dir.join(&info.file))
    }
}

/// `manifest.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub reparam_version: String,
    /// The command that made the vectors.
    pub command: String,
    /// The input they were made from.
    pub input: String,
    pub kernels: Vec<KernelVectors>,
}

/// Kernels' vectors and reparam's own GPU outputs for them (`(kernel name, array)`; empty
/// without a GPU).
pub type VectorsAndCandidates = (Vec<KernelData>, Vec<(String, Array)>);

/// A kernel's vectors in memory, before they are written.
pub struct KernelData {
    pub name: String,
    pub description: String,
    /// (input name, meaning, array).
    pub inputs: Vec<(String, String, Array)>,
    pub expected: (String, Array),
    pub bound: (String, Array),
    pub metric: Metric,
    pub bound_formula: String,
    pub derivation: String,
    /// The inputs indexed like the elements (see [`ArrayInfo::indexed_by_element`]).
    pub per_element: Vec<String>,
    /// The branches and terms of the kernel its vectors exercise, each with the elements that
    /// show it (e.g. "mirrored layout (flags bit 1): faces 8–13").
    pub covers: Vec<String>,
}

impl KernelData {
    /// Write the arrays into `dir` and return the kernel's manifest entry.
    pub fn write(&self, dir: &Path) -> Result<KernelVectors> {
        let info = |file: String, meaning: &str, a: &Array, indexed: bool| -> Result<ArrayInfo> {
            a.save(&dir.join(&file))?;
            Ok(ArrayInfo {
                file,
                shape: a.shape.clone(),
                dtype: a.dtype(),
                meaning: meaning.into(),
                indexed_by_element: indexed,
            })
        };
        let inputs = self
            .inputs
            .iter()
            .map(|(n, m, a)| {
                let indexed = self.per_element.contains(n);
                info(format!("{}.{n}.npy", self.name), m, a, indexed)
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(KernelVectors {
            name: self.name.clone(),
            description: self.description.clone(),
            inputs,
            expected: info(
                format!("{}.expected.npy", self.name),
                &self.expected.0,
                &self.expected.1,
                false,
            )?,
            bound: info(
                format!("{}.bound.npy", self.name),
                &self.bound.0,
                &self.bound.1,
                false,
            )?,
            metric: self.metric.clone(),
            bound_formula: self.bound_formula.clone(),
            derivation: self.derivation.clone(),
            covers: self.covers.clone(),
        })
    }
}

/// Write `kernels` and `manifest.json` into `dir` (created).
pub fn write_vectors(
    dir: &Path,
    command: &str,
    input: &str,
    kernels: &[KernelData],
) -> Result<Manifest> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let manifest = Manifest {
        reparam_version: env!("CARGO_PKG_VERSION").into(),
        command: command.into(),
        input: input.into(),
        kernels: kernels
            .iter()
            .map(|k| k.write(dir))
            .collect::<Result<_>>()?,
    };
    let path = dir.join("manifest.json");
    let text = serde_json::to_string_pretty(&manifest).map_err(|e| Error::Vectors {
        file: path.display().to_string(),
        reason: format!("cannot serialise the manifest: {e}"),
    })?;
    std::fs::write(&path, text).map_err(|e| Error::io(&path, e))?;
    Ok(manifest)
}

/// Read `dir/manifest.json`.
pub fn read_manifest(dir: &Path) -> Result<Manifest> {
    let path = dir.join("manifest.json");
    let text = crate::input::read_input_text(&path)?;
    serde_json::from_str(&text).map_err(|e| Error::Vectors {
        file: path.display().to_string(),
        reason: format!("not a reparam manifest: {e}"),
    })
}

/// The algorithms with vectors, in `reference_data/vectors/<name>/`.
pub const ALGORITHMS: [&str; 5] = ["bpm", "gridwarp", "unwarp", "maps", "skinsimp"];

/// The canonical small vectors of `algorithm` (what `reference_data/vectors/<algorithm>` holds):
/// its input's name and the kernels, computed on the CPU alone.
///
/// - bpm: the conformance mesh (`procedural:bpm_conformance`: a curved cone fan, a mirrored
///   one, a non-conformal grid with a zero-area UV island), 32 faces, 352 samples;
/// - gridwarp: [`canonical_gridwarp_scene`] on 32² fields, lines s = (0, 0.2, 0.45, 0.7, 1),
///   t = (0, 0.3, 0.55, 0.85, 1), 4 × 4 samples per cell;
/// - unwarp: the cones height map at 16², s = 0.05, periodic;
/// - maps: the 12 × 6 torus (144 triangles) to its coarsest base, Π⁻¹ at the uniform:2 points
///   (base vertices, points on the base edges and points inside the base faces); the ring
///   kernels on [`canonical_rings`];
/// - skinsimp: the skinned tube of 6 segments and 6 rings, 2 uniform poses per clip.
pub fn canonical(algorithm: &str) -> Result<(String, Vec<KernelData>)> {
    match algorithm {
        "bpm" => {
            let mesh = crate::mesh::procedural::bpm_conformance();
            Ok(("procedural:bpm_conformance".into(), bpm::vectors(&mesh)?))
        }
        "gridwarp" => {
            let scene = canonical_gridwarp_scene().fields(32);
            // Lines not uniform, so that no cell has h_i = k_j.
            let grid = crate::gridwarp::Grid::new(
                vec![0.0, 0.2, 0.45, 0.7, 1.0],
                vec![0.0, 0.3, 0.55, 0.85, 1.0],
            )?;
            let options = crate::gridwarp::SolveOptions {
                samples: (4, 4),
                ..Default::default()
            };
            let (k, _) = gridwarp::all_vectors(None, &scene.rest, &grid, &scene.frames, &options)?;
            Ok((
                "off-centre bump 32², 5 × 5 non-uniform lines, 4 × 4 samples".into(),
                k,
            ))
        }
        "unwarp" => {
            let heights = crate::unwarp::procedural("cones", 16)?;
            let (k, _) = unwarp::vectors(None, &heights, &Default::default())?;
            Ok(("cones 16², s = 0.05".into(), k))
        }
        "maps" => {
            let (built, remesh) = canonical_maps()?;
            let rings = canonical_rings(&built)?;
            let (k, _) = maps::all_vectors(None, &built, &remesh, &rings)?;
            Ok((
                "torus 12 × 6, uniform:2 points; rings of the torus, a creased grid and six \
                 made-up rings"
                    .into(),
                k,
            ))
        }
        "skinsimp" => {
            let (model, sets) = canonical_skinned()?;
            let (k, _) = skinsimp::all_vectors(&model, &sets, None)?;
            Ok(("skinned tube 6 × 6, 2 poses per clip".into(), k))
        }
        other => Err(Error::InvalidArgument(format!(
            "no vectors for '{other}'; known: {}",
            ALGORITHMS.join(", ")
        ))),
    }
}

/// The canonical gridwarp scene: a plane whose bump, centred off both axes of symmetry at
/// (0.6, 0.35), rises to 0.3 (X = (s, t, 0.3 exp(−|(s, t) − c|²/0.05))), and a rigid disc on
/// its flank. The stretch fields differ from their mirror images in s and in t, so that a
/// port that flips the fields' rows or swaps the axes fails (tests/twin_gridwarp.rs).
pub fn canonical_gridwarp_scene() -> crate::gridwarp::scene::AnalyticScene {
    use crate::gridwarp::scene::{disc_rigidity, AnalyticScene};
    use nalgebra::Point3;
    AnalyticScene {
        name: "off-centre bump",
        rest: Box::new(|s, t| Point3::new(s, t, 0.0)),
        frames: vec![Box::new(|s, t| {
            let r2 = (s - 0.6).powi(2) + (t - 0.35).powi(2);
            Point3::new(s, t, 0.3 * (-r2 / 0.05).exp())
        })],
        rigidity: disc_rigidity(32, &[(0.45, 0.5, 0.15)], 0.1),
    }
}

/// The hierarchy and the uniform:2 remesh of the canonical maps vectors: its points include
/// face interiors, not only base vertices and edge midpoints (issue #33).
pub fn canonical_maps() -> Result<(crate::maps::Maps, crate::maps::remesh::Remesh)> {
    let mut torus = crate::mesh::procedural::torus(12, 6, 1.0, 0.35);
    torus.uvs.clear();
    torus.uv_faces.clear();
    let built = crate::maps::build(&torus, &Default::default(), &Default::default())?;
    let remesh = crate::maps::remesh::uniform(&built, 2)?;
    Ok((built, remesh))
}

/// The rings of the canonical `maps_priority` and `maps_flatten` vectors, chosen so that every
/// branch of the two kernels is taken: the rings `crosscheck maps` compares on the canonical
/// torus `maps` (closed disks of levels 0 and the middle one, normals along every axis), those
/// of an 8 × 8 height field z = 0.8|x − ½| + 0.1 sin πy with its crease x = ½ tagged (boundary
/// half disks, feature lines), and made-up rings: four feature lines whose upper side is a
/// single sector and one whose lower side is (flipped fans, which the single-sector rule
/// rejects whichever way f32 rounds a·φ = π), and a disk with a ring vertex on its centre
/// (degenerate).
pub fn canonical_rings(maps: &crate::maps::Maps) -> Result<maps::RingSet> {
    use crate::maps::flatten::RingShape;
    use crate::maps::gpu::{level_rings, LevelRings};
    use nalgebra::Point3;
    let options = crate::maps::MapsOptions::default();
    let mut set = maps::RingSet::of(maps, &options);
    // The creased height field.
    let n = 8;
    let mut grid = crate::mesh::procedural::wavy_grid(n);
    for p in &mut grid.positions {
        p.z = 0.8 * (p.x - 0.5).abs() + 0.1 * (std::f64::consts::PI * p.y).sin();
    }
    let mut features = crate::maps::Features::default();
    let column = |j: usize| (j * (n + 1) + n / 2) as u32;
    for j in 0..n {
        features.edges.insert((column(j), column(j + 1)));
    }
    let rings = level_rings(&grid.positions, &grid.faces, &features, options.corner_turn);
    set.append(&grid.positions, &rings);
    // The made-up rings: centre 0, six ring vertices 1 … 6 on a wavy circle of radius ≈ 0.2·w
    // (w varies the rounding from ring to ring); the last ring's vertex 3 is a copy of its
    // centre.
    let ring_of = |centre: Point3<f64>, w: f64, on_centre: Option<usize>| -> Vec<Point3<f64>> {
        let mut p = vec![centre];
        for k in 0..6 {
            let angle = std::f64::consts::TAU * (k as f64 + 0.1 * w * (k % 2) as f64) / 6.0;
            let r = w * (0.2 + 0.03 * k as f64);
            p.push(if on_centre == Some(k) {
                centre
            } else {
                centre
                    + nalgebra::Vector3::new(
                        r * angle.cos(),
                        r * angle.sin(),
                        0.05 * (k % 3) as f64,
                    )
            });
        }
        p
    };
    let star = |ring: &[u32]| -> Vec<[u32; 3]> {
        (0..ring.len())
            .map(|m| [0, ring[m], ring[(m + 1) % ring.len()]])
            .collect()
    };
    let ring: Vec<u32> = (1..=6).collect();
    let flipped = |s: usize| RingShape::FeatureLine { s, t: s + 1 };
    for (centre, w, on_centre, shape) in [
        (Point3::new(0.3, -0.4, 0.2), 1.0, None, flipped(1)),
        (Point3::new(0.1, -0.3, 0.1), 0.7, None, flipped(0)),
        (Point3::new(-0.1, -0.2, 0.0), 1.3, None, flipped(2)),
        (Point3::new(0.2, 0.3, -0.2), 0.9, None, flipped(3)),
        (
            Point3::new(-0.2, 0.1, 0.3),
            1.1,
            None,
            RingShape::FeatureLine { s: 0, t: 5 },
        ),
        (Point3::new(-0.3, 0.4, -0.1), 1.0, Some(2), RingShape::Disk),
    ] {
        set.append(
            &ring_of(centre, w, on_centre),
            &LevelRings {
                vertices: vec![0],
                rings: vec![ring.clone()],
                stars: vec![star(&ring)],
                shapes: vec![shape],
            },
        );
    }
    Ok(set)
}

/// The skinned model of the canonical skinsimp vectors and its poses.
pub fn canonical_skinned() -> Result<(crate::mesh::SkinnedMesh, crate::skinsimp::poses::PoseSets)> {
    use crate::skinsimp::poses::{select_poses, PoseSelection};
    let model = crate::skinsimp::tube::skinned_tube(6, 6);
    let sets = select_poses(&model, &PoseSelection::Uniform(2))?;
    Ok((model, sets))
}

/// Write the canonical vectors of every algorithm under `dir/<algorithm>/`.
pub fn write_canonical(dir: &Path) -> Result<Vec<std::path::PathBuf>> {
    let mut written = Vec::new();
    for algorithm in ALGORITHMS {
        let (input, kernels) = canonical(algorithm)?;
        let out = dir.join(algorithm);
        let manifest = write_vectors(
            &out,
            &format!("reparam reference-data (canonical {algorithm} vectors)"),
            &input,
            &kernels,
        )?;
        written.push(out.join("manifest.json"));
        for k in manifest.kernels {
            written.extend(
                k.inputs
                    .iter()
                    .chain([&k.expected, &k.bound])
                    .map(|a| out.join(&a.file)),
            );
        }
    }
    Ok(written)
}
