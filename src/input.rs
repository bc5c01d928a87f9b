//! Reading input files and the files they refer to, within bounds (issues #25 and #35).
//!
//! Three rules, kept in one place so that the next loader gets them for free:
//!
//! - **Counts.** A number read from a file that sizes an allocation (vertex, face and corner
//!   counts, PLY element counts, glTF accessor counts, an image's samples) is checked against
//!   what the file can hold before anything is reserved: [`check_count`].
//! - **Files.** Inputs are read only when they are regular files (not a device, a FIFO, a socket
//!   or a directory) and never beyond a bound: [`read_input`] for the files named on the
//!   command line, [`Reference::read`] for the files a model names. The file is opened without
//!   blocking (a FIFO without a writer would stall `open` forever) and checked on the open
//!   descriptor, so nothing can be swapped in between the check and the read.
//! - **References** inside a model (glTF buffer and image URIs, OBJ `mtllib`, MTL `map_Kd`) are
//!   followed, by default, only inside the model's folder: no absolute path, no `..` above the
//!   folder, no symbolic link out of it ([`ReferencePolicy`]). A viewer opening a user's own
//!   files may widen this ([`with_reference_policy`], `reparam --allow-outside-references`); a
//!   batch tool run on downloaded assets should not.
#![doc = include_str!("input.md")]

use std::cell::Cell;
use std::fs::{File, Metadata};
use std::io::{self, Read};
use std::path::{Component, Path, PathBuf};

use crate::error::{Error, Result};

// ---------------------------------------------------------------------------------------------
// Counts

/// Whether `count` items of at least `each` units fit in `available` units (without overflow):
/// the test of [`check_count`], for a caller that words its own message (an image's samples
/// against what its compressed bytes can hold).
pub fn fits(count: u64, each: u64, available: u64) -> bool {
    count
        .checked_mul(each.max(1))
        .is_some_and(|needed| needed <= available)
}

/// Check a count read from a file before anything is allocated for it: `count` items of at
/// least `each` units (bytes, words) must fit in the `available` units that remain, `unit`
/// saying which and where (`"bytes after the header"`). Returns the count as a `usize` (it fits:
/// it is at most `available`, a length in memory or on disk), or a one-line message for the
/// caller's error (which names the file and the line), e.g. `the corner count
/// 18446744073709551615 needs at least 18446744073709551615 words after it on the line (1
/// each), but there are only 7; the count is wrong or the file is truncated`. `each` is taken
/// as 1 when 0, so that items of no size cannot be "read" 10¹² times from nothing.
pub fn check_count(
    what: &str,
    count: u64,
    each: u64,
    available: u64,
    unit: &str,
) -> std::result::Result<usize, String> {
    let each = each.max(1);
    if fits(count, each, available) {
        return usize::try_from(count)
            .map_err(|_| format!("{what} {count} does not fit in memory"));
    }
    let needed = count
        .checked_mul(each)
        .map_or_else(|| format!("more than {}", u64::MAX), |n| n.to_string());
    Err(format!(
        "{what} {count} needs at least {needed} {unit} ({each} each), but there are only \
         {available}; the count is wrong or the file is truncated"
    ))
}

// ---------------------------------------------------------------------------------------------
// Regular files

/// What `metadata` describes, for messages: "a directory", "a FIFO", "a character device"…
fn file_kind(metadata: &Metadata) -> &'static str {
    let kind = metadata.file_type();
    if kind.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if kind.is_char_device() {
            return "a character device";
        }
        if kind.is_block_device() {
            return "a block device";
        }
        if kind.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

/// Why a file was not opened: it could not be (missing, no permission), or it is not a
/// regular file (the kind it is).
enum OpenError {
    Io(io::Error),
    NotRegular(&'static str),
}

/// Open `path` for reading when it is a regular file, with its size. On Unix the open does
/// not block (`O_NONBLOCK`: opening a FIFO with no writer would wait forever; the flag changes
/// nothing for a regular file) and the kind is read from the open descriptor (`fstat`).
fn open_regular(path: &Path) -> std::result::Result<(File, u64), OpenError> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    #[cfg(not(unix))]
    {
        // No non-blocking open: look before opening.
        let metadata = std::fs::metadata(path).map_err(OpenError::Io)?;
        if !metadata.is_file() {
            return Err(OpenError::NotRegular(file_kind(&metadata)));
        }
    }
    let file = options.open(path).map_err(OpenError::Io)?;
    let metadata = file.metadata().map_err(OpenError::Io)?;
    if !metadata.is_file() {
        return Err(OpenError::NotRegular(file_kind(&metadata)));
    }
    Ok((file, metadata.len()))
}

/// Read at most `limit` bytes of `file`, growing the buffer with the data read (never reserving
/// what a header or a size merely claims).
fn read_at_most(file: File, limit: u64) -> io::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    file.take(limit).read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// Open an input file named on the command line (a mesh, a glTF, an image), when it is a
/// regular file, with its size in bytes. Errors: [`Error::Io`] when it cannot be opened,
/// [`Error::NotAFile`] for a device, a FIFO, a socket or a directory.
pub fn open_input(path: &Path) -> Result<(File, u64)> {
    open_regular(path).map_err(|e| match e {
        OpenError::Io(e) => Error::io(path, e),
        OpenError::NotRegular(kind) => Error::NotAFile {
            path: path.to_path_buf(),
            kind,
        },
    })
}

/// Read a whole input file named on the command line: a regular file ([`open_input`]), read up
/// to the size it had when opened (a file growing meanwhile is not followed).
pub fn read_input(path: &Path) -> Result<Vec<u8>> {
    let (file, size) = open_input(path)?;
    read_at_most(file, size).map_err(|e| Error::io(path, e))
}

/// [`read_input`] as UTF-8 text; invalid UTF-8 is [`Error::Io`] (`InvalidData`), as from
/// `std::fs::read_to_string`.
pub fn read_input_text(path: &Path) -> Result<String> {
    String::from_utf8(read_input(path)?).map_err(|_| {
        let invalid = io::Error::new(
            io::ErrorKind::InvalidData,
            "stream did not contain valid UTF-8",
        );
        Error::io(path, invalid)
    })
}

// ---------------------------------------------------------------------------------------------
// References

/// Where the files a model refers to may lie.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ReferencePolicy {
    /// In the model's folder or below it: relative paths only, no `..` above the folder, no
    /// symbolic link leading out of it. The default.
    #[default]
    ModelFolder,
    /// Anywhere (absolute paths, `..`, links out of the folder), as a viewer of one's own files
    /// would: `reparam --allow-outside-references`.
    Anywhere,
}

thread_local! {
    static POLICY: Cell<ReferencePolicy> = const { Cell::new(ReferencePolicy::ModelFolder) };
}

/// The policy in force for references read on this thread ([`ReferencePolicy::ModelFolder`]
/// unless inside [`with_reference_policy`]).
pub fn reference_policy() -> ReferencePolicy {
    POLICY.with(Cell::get)
}

/// Run `f` with `policy` for the references the loaders follow on this thread, then restore
/// the previous policy (also when `f` panics). The CLI wraps each command in it.
pub fn with_reference_policy<T>(policy: ReferencePolicy, f: impl FnOnce() -> T) -> T {
    struct Restore(ReferencePolicy);
    impl Drop for Restore {
        fn drop(&mut self) {
            POLICY.with(|p| p.set(self.0));
        }
    }
    let _restore = Restore(POLICY.with(|p| p.replace(policy)));
    f()
}

/// How much of a referenced file [`Reference::read`] reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Length {
    /// Exactly this many bytes, which the model declares (a glTF buffer's `byteLength`): a
    /// shorter file is refused, the bytes after them are not read.
    Declared(u64),
    /// The whole file, which must be at most this long (a material library).
    AtMost(u64),
}

/// A file named inside a model: the model, what names it (`mtllib`, `buffer 0 URI`…), and
/// the name as written (after percent-decoding for URIs).
#[derive(Clone, Copy, Debug)]
pub struct Reference<'a> {
    /// The model file that names the reference (an OBJ, a glTF).
    pub model: &'a Path,
    /// What names it, for messages: `mtllib`, `buffer 0 URI`, `image 2 URI`…
    pub kind: &'a str,
    /// The path as the model writes it (percent-decoded for a URI), relative to the model's
    /// folder unless absolute.
    pub written: &'a str,
}

impl Reference<'_> {
    /// The model's folder (`.` for a model named without one).
    fn folder(&self) -> &Path {
        match self.model.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => dir,
            _ => Path::new("."),
        }
    }

    /// The referenced path, joined to the model's folder (as the model's path names it).
    pub fn path(&self) -> PathBuf {
        self.model
            .parent()
            .unwrap_or(Path::new(""))
            .join(self.written)
    }

    /// An [`Error::Reference`] for this reference.
    pub fn error(&self, reason: impl Into<String>) -> Error {
        Error::Reference {
            model: self.model.to_path_buf(),
            kind: self.kind.to_string(),
            reference: self.written.to_string(),
            reason: reason.into(),
        }
    }

    /// Why the reference leaves the model's folder, if it does: an absolute path, a `..` above
    /// the folder, or (when both exist) a symbolic link whose target lies outside it.
    fn outside_reason(&self) -> Option<String> {
        let written = Path::new(self.written);
        let mut depth = 0usize;
        for component in written.components() {
            match component {
                Component::Prefix(_) | Component::RootDir => {
                    return Some("an absolute path".into());
                }
                Component::ParentDir if depth == 0 => {
                    return Some("`..` leads above the model's folder".into());
                }
                Component::ParentDir => depth -= 1,
                Component::Normal(_) => depth += 1,
                Component::CurDir => {}
            }
        }
        let folder = std::fs::canonicalize(self.folder()).ok()?;
        let target = std::fs::canonicalize(self.path()).ok()?;
        (!target.starts_with(&folder)).then(|| format!("a symbolic link to {}", target.display()))
    }

    /// The referenced path, when the policy in force allows it ([`reference_policy`]); else an
    /// [`Error::Reference`] saying why and how to allow it. Whether the file exists is not
    /// checked here.
    pub fn resolve(&self) -> Result<PathBuf> {
        if reference_policy() == ReferencePolicy::ModelFolder {
            if let Some(why) = self.outside_reason() {
                return Err(self.error(format!(
                    "{why}, outside the model's folder: refused (references stay in the \
                     model's folder by default; pass --allow-outside-references to follow it)"
                )));
            }
        }
        Ok(self.path())
    }

    /// [`resolve`](Self::resolve), and, when the file exists, check that it is a regular file
    /// (for a texture read later by its own loader). `Ok(path)` also for a missing file: the
    /// caller reports that in its own terms.
    pub fn resolve_file(&self) -> Result<PathBuf> {
        let path = self.resolve()?;
        if let Ok(metadata) = std::fs::metadata(&path) {
            if !metadata.is_file() {
                return Err(self.error(format!("{}, not a regular file", file_kind(&metadata))));
            }
        }
        Ok(path)
    }

    /// Read the referenced file: [`resolve`](Self::resolve)d, a regular file, and as long as
    /// `length` says ([`Length`]).
    ///
    /// Outer `Err`: the reference is refused ([`Error::Reference`]: outside the folder, not a
    /// regular file, shorter than declared, larger than its limit). Inner `Err`: the file cannot
    /// be opened or read (the caller decides: a missing `mtllib` is no texture, a missing buffer
    /// is an error).
    pub fn read(&self, length: Length) -> Result<io::Result<Vec<u8>>> {
        let path = self.resolve()?;
        let (file, size) = match open_regular(&path) {
            Ok(opened) => opened,
            Err(OpenError::Io(e)) => return Ok(Err(e)),
            Err(OpenError::NotRegular(kind)) => {
                return Err(self.error(format!("{kind}, not a regular file")));
            }
        };
        let short = |size: u64, n: u64| {
            self.error(format!("the file has {size} bytes, the model declares {n}"))
        };
        match length {
            Length::Declared(n) if size < n => Err(short(size, n)),
            Length::Declared(n) => Ok(match read_at_most(file, n) {
                Ok(bytes) if (bytes.len() as u64) < n => return Err(short(bytes.len() as u64, n)),
                other => other,
            }),
            Length::AtMost(max) if size > max => Err(self.error(format!(
                "the file has {size} bytes, more than the limit of {max} for it"
            ))),
            Length::AtMost(max) => Ok(read_at_most(file, max)),
        }
    }
}
