//! One error type for the whole library. Every variant names the element (face, vertex, edge)
//! and the file or built-in mesh it came from, so a user can find the culprit.

use std::path::PathBuf;

/// Result alias used throughout `reparam`.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong on user input. Nothing in the library panics on user input.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An input file that is not a regular file (a device, a FIFO, a socket, a directory):
    /// refused before it is read, since reading it might never end ([`crate::input`]).
    #[error("{path}: {kind}, not a regular file; reparam reads its inputs from regular files")]
    NotAFile { path: PathBuf, kind: &'static str },
    /// A file named inside a model (a glTF buffer or image URI, an OBJ `mtllib`, an MTL
    /// `map_Kd`) that is not followed: outside the model's folder, not a regular file, shorter
    /// than the model declares, or larger than its limit ([`crate::input::Reference`]).
    #[error("{model}: {kind} {reference:?}: {reason}")]
    Reference {
        model: PathBuf,
        kind: String,
        reference: String,
        reason: String,
    },
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A mesh file could not be parsed.
    #[error("{path}: cannot parse mesh: {message}")]
    MeshParse { path: PathBuf, message: String },
    /// The mesh has no triangles (or no vertices).
    #[error("{mesh}: the mesh is empty (no triangles)")]
    EmptyMesh { mesh: String },
    /// An algorithm that needs texture coordinates got a mesh without them.
    #[error("{mesh}: the mesh has no texture coordinates (no `vt` lines); this command needs UVs")]
    MissingUvs { mesh: String },
    /// Some faces have UV indices and some do not.
    #[error("{mesh}: face {face} has no texture coordinates while others do")]
    PartialUvs { mesh: String, face: usize },
    /// A vertex position or texture coordinate is NaN or infinite.
    #[error("{mesh}: {what} {index} is not finite ({value})")]
    NonFinite {
        mesh: String,
        what: &'static str,
        index: usize,
        value: String,
    },
    /// A face refers to a vertex that does not exist.
    #[error("{mesh}: face {face} refers to {what} {index}, but there are only {count}")]
    IndexOutOfRange {
        mesh: String,
        face: usize,
        what: &'static str,
        index: usize,
        count: usize,
    },
    /// A face that is not a triangle where triangles are required, or repeats a vertex.
    #[error("{mesh}: face {face} is degenerate: {reason}")]
    DegenerateFace {
        mesh: String,
        face: usize,
        reason: String,
    },
    /// Edges shared by more than two faces where the algorithm needs a 2-manifold.
    #[error("{mesh}: {count} non-manifold edge(s), first: vertices {first:?}")]
    NonManifold {
        mesh: String,
        count: usize,
        first: (u32, u32),
    },
    /// A mesh that is not a consistently oriented 2-manifold: `edges` lists (sorted, at most 16)
    /// the edges with three or more faces or with two faces of opposite orientation, `vertices`
    /// the vertices whose faces form more than one fan (checked once the edges are fine).
    #[error("{mesh}: not a 2-manifold: {edge_count} bad edge(s) {edges:?}, {vertex_count} bad vertex(es) {vertices:?}")]
    NonManifoldMesh {
        mesh: String,
        edge_count: usize,
        vertex_count: usize,
        edges: Vec<(u32, u32)>,
        vertices: Vec<u32>,
    },
    /// The mesh's material names a texture file that does not exist.
    #[error("{mesh}: texture {texture} (from the material file) does not exist; pass --texture to use another image")]
    MissingTexture { mesh: String, texture: PathBuf },
    /// An image could not be decoded or encoded.
    #[error("{path}: image error: {message}")]
    Image { path: PathBuf, message: String },
    /// A command-line or options value is out of its valid range.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// A GPU operation failed (no adapter, device lost, timeout, shader error).
    #[error("GPU: {0}")]
    Gpu(String),
    /// A height map (or pin mask) whose size the unwarp mesh cannot use: empty, too small, or
    /// an odd size with a periodic border that no colouring covers (`map` names the file or
    /// the built-in map).
    #[error("{map}: {width}x{height} texels: {reason}")]
    HeightMapSize {
        map: String,
        width: usize,
        height: usize,
        reason: String,
    },
    /// A height (or pin-mask value) is NaN or infinite at texel (x, y) of `map`.
    #[error("{map}: value at texel ({x}, {y}) is not finite ({value})")]
    NonFiniteHeight {
        map: String,
        x: usize,
        y: usize,
        value: String,
    },
    /// An element of a glTF file cannot be used: `element` names it (node, mesh, primitive,
    /// accessor, vertex, skin, animation channel, or the JSON path of a validation error).
    #[error("{path}: {element}: {message}")]
    Gltf {
        path: PathBuf,
        element: String,
        message: String,
    },
    /// Conformance vectors or a candidate that `reparam verify` cannot use: `file` names the
    /// manifest or array, `reason` what is wrong and what was expected.
    #[error("{file}: {reason}")]
    Vectors { file: String, reason: String },

    /// A user's shader (`verify --shader`) that does not parse or validate: naga's message,
    /// at `file:line:column`.
    #[error("{0}")]
    Shader(String),
    /// A figure in a command's `--json` output is NaN or infinite (serde_json would write it as
    /// `null`): `field` is its path in the output, e.g. `results[0].training.rms_mean`. Raised
    /// instead of printing, so a figure that cannot be computed is never a `null` with exit 0.
    #[error("{field}: the result is not a finite number (NaN or infinity), not written")]
    NonFiniteOutput { field: String },
    /// A vertex coordinate too large for the f32 GPU kernels of `crosscheck`: their products
    /// of coordinate differences (areas, dot products, quadrics) would overflow f32
    /// ([`crate::crosscheck::F32_COORDINATE_MAX`]).
    #[error(
        "{mesh}: vertex {vertex} has a coordinate of {value:e}, beyond ±{limit:e}, the largest \
         the f32 kernels can multiply and sum without overflow; rescale the input (a mesh in a \
         unit box, bone transforms of that size) to cross-check it"
    )]
    OutOfF32Range {
        mesh: String,
        vertex: usize,
        value: f64,
        limit: f64,
    },
    /// A vertex coordinate too large for a remesh's distance figures in f64: area-weighted
    /// distances are cubic in the coordinates and summed over the samples
    /// ([`crate::maps::quality::DISTANCE_COORDINATE_MAX`]).
    #[error(
        "{mesh}: vertex {vertex} has a coordinate of {value:e}, beyond ±{limit:e}, the largest \
         for which a remesh's distance figures (distances × areas, summed) stay finite in f64; \
         rescale the input (e.g. into a unit box) to remesh it, or build the hierarchy alone \
         (no --remesh)"
    )]
    OutOfDistanceRange {
        mesh: String,
        vertex: usize,
        value: f64,
        limit: f64,
    },
    /// `bpm qc --subdiv` would measure more sub-triangles (`faces · 4^subdiv`) than the limit
    /// (`REPARAM_MAX_QC_SUB_TRIANGLES`, default 2²⁵), each kept for the quantiles.
    #[error(
        "{mesh}: --subdiv {subdiv} on {faces} faces measures {needed} sub-triangles, more than \
         the limit of {limit}; lower --subdiv or raise REPARAM_MAX_QC_SUB_TRIANGLES"
    )]
    TooManySubTriangles {
        mesh: String,
        faces: usize,
        subdiv: u32,
        needed: u64,
        limit: u64,
    },
}

impl Error {
    /// The exit status of a command that stops with this error: 2 for input that reparam
    /// refuses (a malformed or hostile file, a count the file cannot hold, a refused reference,
    /// not a regular file, a bad argument: everything naming the user's input), 1 for a failure
    /// of the system or the computation (an I/O error, the GPU, a figure that is not finite).
    /// `crosscheck` and `verify` exit 2 on any error, their 1 meaning a bound exceeded.
    pub fn exit_status(&self) -> u8 {
        match self {
            Error::Io { .. } | Error::Gpu(_) | Error::NonFiniteOutput { .. } => 1,
            _ => 2,
        }
    }

    /// Wrap an `std::io::Error` with the path it concerns.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}
