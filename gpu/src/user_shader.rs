//! A user's own compute shader, run as reparam runs its kernels: read by naga's front ends
//! (WGSL, GLSL compute, SPIR-V), validated, reflected (what each binding of an entry point holds,
//! word by word), then dispatched on a [`Gpu`] with buffers the caller packed, under a watchdog
//! and with guard regions after every buffer the shader may write.
//!
//! This module knows nothing of manifests or kernels: the caller (`reparam verify --shader`)
//! compares the [`Reflected`] bindings with a kernel's ABI and packs the buffers; here is only
//! the plumbing.
//!
//! - [`UserShader::parse`]: source bytes → a validated naga module, or [`ShaderError::Syntax`]
//!   / [`ShaderError::Invalid`] with naga's message and the line.
//! - [`UserShader::bindings`]: the resource bindings an entry point uses, each flattened into
//!   4-byte [`Word`]s (the layout naga gives the type: struct member offsets, array strides,
//!   the padding of a `vec3`).
//! - [`UserShader::dispatch`]: one dispatch, on a worker thread the caller waits for at most
//!   `timeout` ([`ShaderError::DidNotFinish`] after that: a shader that never ends gives an
//!   error, never a hang of the caller). Every writable binding covers only its data; the
//!   [`GUARD_BYTES`] after it are filled with [`GUARD_WORD`] and checked after the dispatch
//!   ([`ShaderError::GuardOverwritten`]). wgpu's runtime bounds checks are on (the default
//!   `ShaderRuntimeChecks`), so an index past a binding cannot reach another buffer.

use std::borrow::Cow;
use std::sync::mpsc;
use std::time::Duration;

use naga::valid::{Capabilities, GlobalUse, ModuleInfo, ValidationFlags, Validator};
use wgpu::util::DeviceExt;

use crate::compute::{workgroup_grid, WORKGROUP_SIZE};
use crate::{Gpu, GpuError};

/// Bytes after each writable buffer that no binding covers, checked after a dispatch.
pub const GUARD_BYTES: usize = 1024;
/// What the guard region holds (any other word there means a write went past a binding).
pub const GUARD_WORD: u32 = 0xA5A5_5A5A;

/// The source language of a shader, from its file name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShaderLanguage {
    /// `.wgsl`.
    Wgsl,
    /// `.comp`, `.glsl`: a GLSL compute shader (naga's glsl-in, `#version 450`).
    Glsl,
    /// `.spv`: a SPIR-V binary (naga's spv-in).
    SpirV,
}

impl ShaderLanguage {
    /// The language of `file` by its extension (`.wgsl`, `.comp` / `.glsl`, `.spv`).
    pub fn of_file(file: &str) -> Option<ShaderLanguage> {
        let ext = std::path::Path::new(file)
            .extension()?
            .to_string_lossy()
            .to_lowercase();
        match ext.as_str() {
            "wgsl" => Some(ShaderLanguage::Wgsl),
            "comp" | "glsl" => Some(ShaderLanguage::Glsl),
            "spv" => Some(ShaderLanguage::SpirV),
            _ => None,
        }
    }
}

/// Everything that can go wrong with a user's shader, each one line.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ShaderError {
    /// The front end rejected the source: naga's message, at `file:line:column` where known.
    #[error("{0}")]
    Syntax(String),
    /// The module parsed but naga's validator (or wgpu's) rejected it.
    #[error("{0}")]
    Invalid(String),
    /// No compute entry point of that name (or none to choose).
    #[error("{0}")]
    Entry(String),
    /// The dispatch (compilation, run and read-back together) did not finish in time.
    #[error("the shader did not finish within {seconds} s (compilation, dispatch and read-back)")]
    DidNotFinish { seconds: u64 },
    /// A write went past binding `binding`: its guard region changed.
    #[error(
        "the shader wrote past binding {binding}: word {word} of the {GUARD_BYTES}-byte guard \
         region after it is {found:#010x}, not {GUARD_WORD:#010x}"
    )]
    GuardOverwritten {
        binding: u32,
        word: usize,
        found: u32,
    },
    /// The device or wgpu refused something (limits, device lost, a mapping).
    #[error("{0}")]
    Gpu(#[from] GpuError),
}

/// What a 4-byte word of a binding's type is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum WordKind {
    F32,
    U32,
    I32,
    /// Padding the layout inserts (after a `vec3`, between struct members, up to an array's
    /// stride): the shader never sees it.
    Hole,
    /// A type a buffer of 4-byte values cannot hold (f16, f64, bool, …), named.
    Other(String),
}

impl std::fmt::Display for WordKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WordKind::F32 => write!(f, "f32"),
            WordKind::U32 => write!(f, "u32"),
            WordKind::I32 => write!(f, "i32"),
            WordKind::Hole => write!(f, "padding"),
            WordKind::Other(name) => write!(f, "{name}"),
        }
    }
}

/// One word of a binding's type and the path that names it (`TriangleMaps.flags`, `b[1]`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Word {
    pub kind: WordKind,
    pub name: String,
}

/// The address space of a binding.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Space {
    Uniform,
    /// `var<storage, read>` (`writable` false) or `var<storage, read_write>`.
    Storage {
        writable: bool,
    },
    /// Textures, samplers, …: nothing reparam binds.
    Other(String),
}

impl std::fmt::Display for Space {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Space::Uniform => write!(f, "var<uniform>"),
            Space::Storage { writable: false } => write!(f, "var<storage, read>"),
            Space::Storage { writable: true } => write!(f, "var<storage, read_write>"),
            Space::Other(s) => write!(f, "{s}"),
        }
    }
}

/// A resource binding an entry point uses, as naga lays it out.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Reflected {
    pub group: u32,
    pub binding: u32,
    /// The variable's name (GLSL blocks: the instance's or the block's).
    pub name: String,
    pub space: Space,
    /// The type, WGSL-like (`array<TriangleMaps>`, `Params`, `array<f32, 10>`).
    pub type_name: String,
    /// The words before a runtime-sized array (all of them for a fixed-size type).
    pub fixed: Vec<Word>,
    /// One element of the runtime-sized array (its stride's worth of words), if any.
    pub element: Option<Vec<Word>>,
    /// Whether the entry point writes it.
    pub written: bool,
}

/// A parsed and validated shader.
#[derive(Debug)]
pub struct UserShader {
    module: naga::Module,
    info: ModuleInfo,
    layouter: naga::proc::Layouter,
    file: String,
}

impl UserShader {
    /// Parse `source` (the file's bytes) as `language` and validate it. `file` names it in
    /// messages (`file:line:column: message`).
    pub fn parse(
        source: &[u8],
        language: ShaderLanguage,
        file: &str,
    ) -> Result<UserShader, ShaderError> {
        let text = || {
            std::str::from_utf8(source).map_err(|e| {
                ShaderError::Syntax(format!(
                    "{file}: not UTF-8 text (byte {}); a WGSL or GLSL shader is text, a SPIR-V \
                     one is named .spv",
                    e.valid_up_to()
                ))
            })
        };
        let (module, text) = match language {
            ShaderLanguage::Wgsl => {
                let text = text()?;
                let module = naga::front::wgsl::parse_str(text).map_err(|e| {
                    ShaderError::Syntax(located(file, text, e.location(text), e.message()))
                })?;
                (module, Some(text))
            }
            ShaderLanguage::Glsl => {
                let text = text()?;
                let options = naga::front::glsl::Options::from(naga::ShaderStage::Compute);
                let module = naga::front::glsl::Frontend::default()
                    .parse(&options, text)
                    .map_err(|errors| {
                        let first = errors.errors.first();
                        let message =
                            first.map_or("no message".to_string(), |e| e.kind.to_string());
                        let more = match errors.errors.len() {
                            0 | 1 => String::new(),
                            n => format!(" (and {} more)", n - 1),
                        };
                        ShaderError::Syntax(format!(
                            "{}{more}",
                            located(file, text, first.and_then(|e| e.location(text)), &message)
                        ))
                    })?;
                (module, Some(text))
            }
            ShaderLanguage::SpirV => {
                let options = naga::front::spv::Options {
                    adjust_coordinate_space: false,
                    strict_capabilities: true,
                    block_ctx_dump_prefix: None,
                };
                let module = naga::front::spv::parse_u8_slice(source, &options)
                    .map_err(|e| ShaderError::Syntax(format!("{file}: SPIR-V: {e}")))?;
                (module, None)
            }
        };
        let info = Validator::new(ValidationFlags::all(), Capabilities::default())
            .validate(&module)
            .map_err(|e| {
                let location = e
                    .spans()
                    .next()
                    .zip(text)
                    .map(|((span, _), t)| span.location(t));
                let mut message = e.as_inner().to_string();
                let mut source = std::error::Error::source(e.as_inner());
                while let Some(s) = source {
                    message.push_str(&format!(": {s}"));
                    source = s.source();
                }
                ShaderError::Invalid(match (location, text) {
                    (Some(l), Some(t)) => located(file, t, Some(l), &message),
                    _ => format!("{file}: {message}"),
                })
            })?;
        let mut layouter = naga::proc::Layouter::default();
        layouter
            .update(module.to_ctx())
            .map_err(|e| ShaderError::Invalid(format!("{file}: layout: {e}")))?;
        Ok(UserShader {
            module,
            info,
            layouter,
            file: file.to_string(),
        })
    }

    /// The names of the compute entry points, in the module's order.
    pub fn compute_entries(&self) -> Vec<String> {
        self.module
            .entry_points
            .iter()
            .filter(|e| e.stage == naga::ShaderStage::Compute)
            .map(|e| e.name.clone())
            .collect()
    }

    /// The compute entry point `entry`, with its index.
    fn entry(&self, entry: &str) -> Result<(usize, &naga::EntryPoint), ShaderError> {
        self.module
            .entry_points
            .iter()
            .enumerate()
            .find(|(_, e)| e.name == entry && e.stage == naga::ShaderStage::Compute)
            .ok_or_else(|| {
                ShaderError::Entry(format!(
                    "{}: no compute entry point '{entry}'; it has: {}",
                    self.file,
                    list_or_none(&self.compute_entries())
                ))
            })
    }

    /// The workgroup size `entry` declares.
    pub fn workgroup_size(&self, entry: &str) -> Result<[u32; 3], ShaderError> {
        Ok(self.entry(entry)?.1.workgroup_size)
    }

    /// Every resource binding `entry` uses (reads, writes or queries), by (group, binding).
    pub fn bindings(&self, entry: &str) -> Result<Vec<Reflected>, ShaderError> {
        let (index, _) = self.entry(entry)?;
        let uses = self.info.get_entry_point(index);
        let mut out: Vec<Reflected> = self
            .module
            .global_variables
            .iter()
            .filter(|(handle, _)| !uses[*handle].is_empty())
            .filter_map(|(handle, var)| {
                let binding = var.binding.as_ref()?;
                Some(self.reflect(var, binding, uses[handle]))
            })
            .collect();
        out.sort_by_key(|r| (r.group, r.binding));
        Ok(out)
    }

    fn reflect(
        &self,
        var: &naga::GlobalVariable,
        binding: &naga::ResourceBinding,
        used: GlobalUse,
    ) -> Reflected {
        let space = match var.space {
            naga::AddressSpace::Uniform => Space::Uniform,
            naga::AddressSpace::Storage { access } => Space::Storage {
                writable: access.contains(naga::StorageAccess::STORE),
            },
            other => Space::Other(format!("{other:?}")),
        };
        let ty = &self.module.types[var.ty];
        let name = var
            .name
            .clone()
            .or_else(|| ty.name.clone())
            .unwrap_or_else(|| format!("binding{}", binding.binding));
        let mut fixed = Vec::new();
        let mut element = None;
        match &ty.inner {
            naga::TypeInner::Array {
                base,
                size: naga::ArraySize::Dynamic,
                stride,
            } => {
                element = Some(self.element_words(*base, *stride, ""));
            }
            naga::TypeInner::Struct { members, .. }
                if members.last().is_some_and(|m| self.is_runtime_array(m.ty)) =>
            {
                let prefix = ty.name.clone().unwrap_or_default();
                let (last, head) = members.split_last().unwrap_or_else(|| unreachable!());
                for m in head {
                    self.pad_to(&mut fixed, m.offset);
                    self.words(m.ty, &member_path(&prefix, m), &mut fixed);
                }
                self.pad_to(&mut fixed, last.offset);
                if let naga::TypeInner::Array { base, stride, .. } =
                    self.module.types[last.ty].inner
                {
                    element = Some(self.element_words(base, stride, &member_path(&prefix, last)));
                }
            }
            _ => self.words(var.ty, ty.name.as_deref().unwrap_or(""), &mut fixed),
        }
        Reflected {
            group: binding.group,
            binding: binding.binding,
            name,
            space,
            type_name: self.type_name(var.ty),
            fixed,
            element,
            written: used.contains(GlobalUse::WRITE) || used.contains(GlobalUse::ATOMIC),
        }
    }

    fn is_runtime_array(&self, ty: naga::Handle<naga::Type>) -> bool {
        matches!(
            self.module.types[ty].inner,
            naga::TypeInner::Array {
                size: naga::ArraySize::Dynamic,
                ..
            }
        )
    }

    /// One array element's words, padded with holes to `stride`.
    fn element_words(&self, base: naga::Handle<naga::Type>, stride: u32, path: &str) -> Vec<Word> {
        let mut words = Vec::new();
        let name = self.module.types[base]
            .name
            .clone()
            .unwrap_or_else(|| format!("{path}[i]"));
        self.words(base, &name, &mut words);
        pad_words(&mut words, stride);
        words
    }

    /// Holes up to byte `offset`.
    fn pad_to(&self, words: &mut Vec<Word>, offset: u32) {
        pad_words(words, offset);
    }

    /// Append the words of type `ty` (named `path`) to `out`: exactly its layout size / 4.
    fn words(&self, ty: naga::Handle<naga::Type>, path: &str, out: &mut Vec<Word>) {
        let start = out.len();
        let size = self.layouter[ty].size;
        let scalar_word = |s: naga::Scalar| match (s.kind, s.width) {
            (naga::ScalarKind::Float, 4) => WordKind::F32,
            (naga::ScalarKind::Uint, 4) => WordKind::U32,
            (naga::ScalarKind::Sint, 4) => WordKind::I32,
            (kind, width) => WordKind::Other(format!("{kind:?}{}", 8 * width)),
        };
        let push = |out: &mut Vec<Word>, kind: WordKind, name: String| {
            out.push(Word { kind, name });
        };
        match &self.module.types[ty].inner {
            naga::TypeInner::Scalar(s) | naga::TypeInner::Atomic(s) if s.width == 4 => {
                push(out, scalar_word(*s), path.to_string());
            }
            naga::TypeInner::Vector { size: n, scalar } if scalar.width == 4 => {
                for c in 0..*n as usize {
                    push(
                        out,
                        scalar_word(*scalar),
                        format!("{path}.{}", ["x", "y", "z", "w"][c]),
                    );
                }
            }
            naga::TypeInner::Matrix {
                columns,
                rows,
                scalar,
            } if scalar.width == 4 => {
                let column_bytes = if *rows as u32 == 2 { 8 } else { 16 };
                for c in 0..*columns as usize {
                    let column_start = out.len();
                    for r in 0..*rows as usize {
                        push(out, scalar_word(*scalar), format!("{path}[{c}][{r}]"));
                    }
                    let column_end = column_start * 4 + column_bytes;
                    while out.len() * 4 < column_end {
                        push(out, WordKind::Hole, format!("{path}[{c}] padding"));
                    }
                }
            }
            naga::TypeInner::Array {
                base,
                size: naga::ArraySize::Constant(n),
                stride,
            } => {
                for i in 0..n.get() {
                    let element_start = out.len();
                    self.words(*base, &format!("{path}[{i}]"), out);
                    while (out.len() - element_start) * 4 < *stride as usize {
                        push(out, WordKind::Hole, format!("{path}[{i}] padding"));
                    }
                }
            }
            naga::TypeInner::Struct { members, .. } => {
                for m in members {
                    while (out.len() - start) * 4 < m.offset as usize {
                        push(out, WordKind::Hole, format!("{path} padding"));
                    }
                    self.words(m.ty, &member_path(path, m), out);
                }
            }
            _ => {
                let name = self.type_name(ty);
                for _ in 0..size.div_ceil(4) {
                    push(out, WordKind::Other(name.clone()), path.to_string());
                }
            }
        }
        while (out.len() - start) * 4 < size as usize {
            push(out, WordKind::Hole, format!("{path} padding"));
        }
    }

    /// A WGSL-like name of type `ty`.
    fn type_name(&self, ty: naga::Handle<naga::Type>) -> String {
        let t = &self.module.types[ty];
        if let Some(name) = &t.name {
            if matches!(t.inner, naga::TypeInner::Struct { .. }) {
                return name.clone();
            }
        }
        let scalar = |s: &naga::Scalar| match s.kind {
            naga::ScalarKind::Float => format!("f{}", 8 * s.width),
            naga::ScalarKind::Uint => format!("u{}", 8 * s.width),
            naga::ScalarKind::Sint => format!("i{}", 8 * s.width),
            naga::ScalarKind::Bool => "bool".into(),
            other => format!("{other:?}"),
        };
        match &t.inner {
            naga::TypeInner::Scalar(s) => scalar(s),
            naga::TypeInner::Atomic(s) => format!("atomic<{}>", scalar(s)),
            naga::TypeInner::Vector { size, scalar: s } => {
                format!("vec{}<{}>", *size as u32, scalar(s))
            }
            naga::TypeInner::Matrix {
                columns,
                rows,
                scalar: s,
            } => format!("mat{}x{}<{}>", *columns as u32, *rows as u32, scalar(s)),
            naga::TypeInner::Array { base, size, .. } => match size {
                naga::ArraySize::Constant(n) => format!("array<{}, {n}>", self.type_name(*base)),
                _ => format!("array<{}>", self.type_name(*base)),
            },
            naga::TypeInner::Struct { members, .. } => {
                let fields: Vec<String> = members
                    .iter()
                    .map(|m| {
                        format!(
                            "{}: {}",
                            m.name.as_deref().unwrap_or("_"),
                            self.type_name(m.ty)
                        )
                    })
                    .collect();
                format!("struct {{ {} }}", fields.join(", "))
            }
            other => format!("{other:?}"),
        }
    }

    /// Run `entry` once on `gpu` with `buffers` bound at `@group(0) @binding(b)` (only those
    /// the entry point uses are bound), `grid` workgroups, and return the contents of every
    /// buffer with `read_back`, in the order given. Everything (compilation, dispatch, read-back)
    /// runs on a worker thread that is waited for at most `timeout`; past it the worker is left
    /// behind (a device that runs the shader forever cannot be stopped from here) and the
    /// result is [`ShaderError::DidNotFinish`]: the caller should then not use `gpu` again, and
    /// may need to end the process without waiting for the driver's threads.
    pub fn dispatch(
        &self,
        gpu: &Gpu,
        entry: &str,
        buffers: Vec<UserBuffer>,
        grid: [u32; 2],
        timeout: Duration,
    ) -> Result<Vec<Vec<u8>>, ShaderError> {
        self.entry(entry)?;
        let used: Vec<u32> = self
            .bindings(entry)?
            .iter()
            .filter(|r| r.group == 0)
            .map(|r| r.binding)
            .collect();
        let job = Job {
            gpu: gpu.clone(),
            module: self.module.clone(),
            label: format!("{} ({entry})", self.file),
            entry: entry.to_string(),
            buffers,
            used,
            grid,
        };
        let (sender, receiver) = mpsc::channel();
        std::thread::Builder::new()
            .name("reparam user shader".into())
            .spawn(move || {
                // The receiver may have given up (timeout): then nobody wants the result.
                let _ = sender.send(job.run());
            })
            .map_err(|e| GpuError::Input(format!("cannot start the dispatch thread: {e}")))?;
        match receiver.recv_timeout(timeout) {
            Ok(result) => result,
            Err(mpsc::RecvTimeoutError::Timeout) => Err(ShaderError::DidNotFinish {
                seconds: timeout.as_secs_f64().ceil() as u64,
            }),
            Err(mpsc::RecvTimeoutError::Disconnected) => Err(ShaderError::Gpu(GpuError::Map(
                "the dispatch thread ended without a result (the driver panicked)".into(),
            ))),
        }
    }
}

/// A buffer for [`UserShader::dispatch`].
#[derive(Clone, Debug)]
pub struct UserBuffer {
    /// `@binding(b)` in group 0.
    pub binding: u32,
    /// Its contents (a multiple of 4 bytes; a uniform is padded to 16 bytes here).
    pub contents: Vec<u8>,
    pub kind: BufferKind,
}

/// How a [`UserBuffer`] is made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BufferKind {
    Uniform,
    /// A storage buffer the shader only reads.
    Read,
    /// A storage buffer the shader may write, with a guard region after it; `read_back`: its
    /// contents are returned.
    Write {
        read_back: bool,
    },
}

/// The grid [x, y] for `count` invocations of [`WORKGROUP_SIZE`] that `verify --shader` uses:
/// G = ⌈count / 64⌉ workgroups in rows of ⌈√G⌉ ([`workgroup_grid`] with that row width), so
/// that both dimensions are exercised as on a device with a small
/// `max_compute_workgroups_per_dimension` (a shader that ignores `global_invocation_id.y`, or
/// assumes one row, fails on every input of more than one workgroup). The shader rebuilds its
/// index as `gid.x + gid.y · num_workgroups.x · 64` and returns when it is ≥ count.
pub fn exercising_grid(label: &str, count: u32, gpu: &Gpu) -> Result<[u32; 2], GpuError> {
    let groups = count.div_ceil(WORKGROUP_SIZE);
    let row = (f64::from(groups).sqrt().ceil() as u32)
        .clamp(1, gpu.limits().max_compute_workgroups_per_dimension.max(1));
    workgroup_grid(label, count, row)
}

/// Everything the dispatch thread needs (owned: it may outlive the caller's wait).
struct Job {
    gpu: Gpu,
    module: naga::Module,
    label: String,
    entry: String,
    buffers: Vec<UserBuffer>,
    used: Vec<u32>,
    grid: [u32; 2],
}

impl Job {
    fn run(self) -> Result<Vec<Vec<u8>>, ShaderError> {
        let gpu = &self.gpu;
        let label = self.label.as_str();
        let pipeline = gpu
            .checked(|| {
                let module = gpu
                    .device
                    .create_shader_module(wgpu::ShaderModuleDescriptor {
                        label: Some(label),
                        source: wgpu::ShaderSource::Naga(Cow::Owned(self.module.clone())),
                    });
                Ok(gpu
                    .device
                    .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                        label: Some(label),
                        layout: None,
                        module: &module,
                        entry_point: Some(&self.entry),
                        compilation_options: Default::default(),
                        cache: None,
                    }))
            })
            .map_err(|e| match e {
                GpuError::Validation(m) => ShaderError::Invalid(format!("{label}: {m}")),
                other => ShaderError::Gpu(other),
            })?;
        let max = gpu.max_storage_bytes();
        let mut made = Vec::new();
        for b in &self.buffers {
            let size = b.contents.len() as u64;
            if b.kind != BufferKind::Uniform && size > max {
                return Err(GpuError::ExceedsLimit {
                    kernel: format!("{label} binding {}", b.binding),
                    limit: "max_storage_buffer_binding_size",
                    needed: size,
                    allowed: max,
                }
                .into());
            }
            made.push(make_buffer(gpu, label, b)?);
        }
        let outputs = gpu.checked(|| {
            let entries: Vec<wgpu::BindGroupEntry> = self
                .buffers
                .iter()
                .zip(&made)
                .filter(|(b, _)| self.used.contains(&b.binding))
                .map(|(b, buffer)| wgpu::BindGroupEntry {
                    binding: b.binding,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer,
                        offset: 0,
                        size: wgpu::BufferSize::new(data_bytes(b)),
                    }),
                })
                .collect();
            let bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &pipeline.get_bind_group_layout(0),
                entries: &entries,
            });
            let mut encoder = gpu.encoder(label);
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(label),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &bind_group, &[]);
                pass.dispatch_workgroups(self.grid[0], self.grid[1], 1);
            }
            let mut staging = Vec::new();
            for (b, buffer) in self.buffers.iter().zip(&made) {
                if let BufferKind::Write { .. } = b.kind {
                    let s = gpu.staging_buffer(label, buffer.size());
                    encoder.copy_buffer_to_buffer(buffer, 0, &s, 0, buffer.size());
                    staging.push((b, s));
                }
            }
            let submission = gpu.queue.submit([encoder.finish()]);
            Ok((staging, submission))
        });
        let (staging, submission) = outputs.map_err(|e| match e {
            GpuError::Validation(m) => ShaderError::Invalid(format!("{label}: {m}")),
            other => ShaderError::Gpu(other),
        })?;
        let mut read = Vec::new();
        for (b, s) in staging {
            let bytes = gpu.map_staging(&s, submission.clone())?;
            let data = data_bytes(b) as usize;
            check_guard(b.binding, &bytes[data.min(bytes.len())..])?;
            if let BufferKind::Write { read_back: true } = b.kind {
                read.push(bytes[..data.min(bytes.len())].to_vec());
            }
        }
        Ok(read)
    }
}

/// The bytes a binding covers: the contents (at least 4; a uniform rounded up to 16).
fn data_bytes(b: &UserBuffer) -> u64 {
    let len = b.contents.len().max(4) as u64;
    match b.kind {
        BufferKind::Uniform => len.div_ceil(16) * 16,
        _ => len.div_ceil(4) * 4,
    }
}

/// The wgpu buffer of `b`: its contents, zero-padded to [`data_bytes`], then for a writable
/// one the guard region.
fn make_buffer(gpu: &Gpu, label: &str, b: &UserBuffer) -> Result<wgpu::Buffer, GpuError> {
    let mut contents = b.contents.clone();
    contents.resize(data_bytes(b) as usize, 0);
    let usage = match b.kind {
        BufferKind::Uniform => wgpu::BufferUsages::UNIFORM,
        BufferKind::Read => wgpu::BufferUsages::STORAGE,
        BufferKind::Write { .. } => {
            for _ in 0..GUARD_BYTES / 4 {
                contents.extend_from_slice(&GUARD_WORD.to_le_bytes());
            }
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC
        }
    };
    gpu.check_buffer_size(label, contents.len() as u64)?;
    Ok(gpu
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: &contents,
            usage,
        }))
}

/// [`ShaderError::GuardOverwritten`] at the first word of `guard` that is not [`GUARD_WORD`].
fn check_guard(binding: u32, guard: &[u8]) -> Result<(), ShaderError> {
    match guard
        .chunks_exact(4)
        .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
        .enumerate()
        .find(|(_, w)| *w != GUARD_WORD)
    {
        Some((word, found)) => Err(ShaderError::GuardOverwritten {
            binding,
            word,
            found,
        }),
        None if guard.len() < GUARD_BYTES => Err(ShaderError::Gpu(GpuError::Map(format!(
            "binding {binding}: {} of the {GUARD_BYTES} guard bytes read back",
            guard.len()
        )))),
        None => Ok(()),
    }
}

/// Holes until `words` spans `bytes` bytes.
fn pad_words(words: &mut Vec<Word>, bytes: u32) {
    while words.len() * 4 < bytes as usize {
        words.push(Word {
            kind: WordKind::Hole,
            name: "padding".into(),
        });
    }
}

/// `path.member` (or the member's name alone at the top).
fn member_path(path: &str, m: &naga::StructMember) -> String {
    let name = m.name.as_deref().unwrap_or("_");
    if path.is_empty() {
        name.to_string()
    } else {
        format!("{path}.{name}")
    }
}

/// `file:line:column: message`, or `file: message` without a location.
fn located(
    file: &str,
    text: &str,
    location: Option<naga::SourceLocation>,
    message: &str,
) -> String {
    match location {
        Some(l) => {
            let line = text
                .lines()
                .nth(l.line_number.saturating_sub(1) as usize)
                .unwrap_or("")
                .trim();
            format!(
                "{file}:{}:{}: {message} (`{line}`)",
                l.line_number, l.line_position
            )
        }
        None => format!("{file}: {message}"),
    }
}

fn list_or_none(names: &[String]) -> String {
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}
