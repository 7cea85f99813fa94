//! One home for writing output files (every crate of madenet that writes one uses it).
//!
//! What a user points an output at is respected:
//!
//! * a **regular file** (or a path that does not exist yet) is replaced atomically: the bytes go
//!   to a temporary file in the same folder, are synced, and the temporary file is renamed over
//!   the target, so an interrupted run leaves either the old file or the new one, never half of
//!   one;
//! * a **symlink** is followed to its final target, which is replaced as above — the link itself
//!   stays a link (`--out latest.csv` pointing into a results folder updates that file);
//! * anything else that exists — a **device or a pipe** such as `/dev/stdout` or a FIFO — is
//!   written to directly (streamed), never replaced by a regular file;
//! * a **folder** is refused with a clear error.
//!
//! ```
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("out.csv");
//! madenet_files::write_atomic(&path, b"a,b\n1,2\n").unwrap();
//! assert_eq!(std::fs::read(&path).unwrap(), b"a,b\n1,2\n");
//! ```
//!
//! Errors are `std::io::Error`s; callers name the path (and the flag or field) in their own error.
//!
//! It is also the one reader of TOML configs ([`read_toml`], [`parse_toml`]): errors name the
//! file, the field and the line.

#![deny(missing_docs)]

mod read;
mod toml_config;
pub use read::{read_capped, read_text_capped, InputKind, STREAM_WAIT};
pub use toml_config::{parse_toml, read_toml, ConfigFileError};

use std::fs::{File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// Symlink hops followed before giving up (Linux's own limit is 40).
const MAX_LINKS: usize = 40;

/// Refuses an output `path` (given as `flag`) whose extension is not `want` (any case): a
/// `.png` asked of a GIF writer says so before anything runs. No extension is accepted.
///
/// ```
/// use std::path::Path;
/// assert!(madenet_files::check_extension(Some(Path::new("a.GIF")), "--render", "gif").is_ok());
/// let e = madenet_files::check_extension(Some(Path::new("a.png")), "--render", "gif");
/// assert_eq!(e.unwrap_err(), "--render: writes a GIF file, but a.png ends in .png: name it *.gif");
/// ```
pub fn check_extension(path: Option<&Path>, flag: &str, want: &str) -> Result<(), String> {
    let Some((path, ext)) = path.and_then(|p| Some((p, p.extension()?))) else {
        return Ok(());
    };
    let ext = ext.to_string_lossy().to_ascii_lowercase();
    if ext != want {
        return Err(format!(
            "{flag}: writes a {} file, but {} ends in .{ext}: name it *.{want}",
            want.to_uppercase(),
            path.display()
        ));
    }
    Ok(())
}

/// `path` with its symbolic links resolved, made absolute: the file itself when it exists,
/// else its folder resolved and its name (a file still to be written); as given when its folder
/// does not exist either.
pub fn resolved(path: &Path) -> PathBuf {
    if let Ok(p) = std::fs::canonicalize(path) {
        return p;
    }
    match (path.file_name(), std::fs::canonicalize(parent_dir(path))) {
        (Some(name), Ok(dir)) => dir.join(name),
        _ => path.to_path_buf(),
    }
}

/// Refuses, before any work, an output that would replace an input or another output: each
/// `(flag, path)` of `outputs` against every input and every other output, symbolic links
/// resolved. The error names both flags and the path.
pub fn check_outputs(outputs: &[(&str, &Path)], inputs: &[(&str, &Path)]) -> Result<(), String> {
    let ins: Vec<(&str, PathBuf)> = inputs.iter().map(|&(f, p)| (f, resolved(p))).collect();
    let outs: Vec<(&str, PathBuf)> = outputs.iter().map(|&(f, p)| (f, resolved(p))).collect();
    for (k, (flag, out)) in outs.iter().enumerate() {
        if let Some((in_flag, _)) = ins.iter().find(|(_, i)| i == out) {
            return Err(format!(
                "{flag} {}: is {in_flag}'s file: an output never replaces an input; choose another path",
                outputs[k].1.display()
            ));
        }
        if let Some((other, _)) = outs[..k].iter().find(|(_, o)| o == out) {
            return Err(format!(
                "{flag} {}: is also {other}'s path: choose another",
                outputs[k].1.display()
            ));
        }
    }
    Ok(())
}

/// Writes `bytes` to `path` as described in the crate doc.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes)?;
    f.commit()
}

/// A file being written: [`Write`] into it, then [`AtomicFile::commit`]. Dropped without a
/// commit, a replacement leaves the target as it was (the temporary file is removed); a
/// stream keeps what was written.
pub struct AtomicFile {
    inner: Inner,
}

enum Inner {
    Replace {
        tmp: tempfile::NamedTempFile,
        target: PathBuf,
    },
    Stream(File),
}

impl AtomicFile {
    /// Starts writing `path` (see the crate doc for what each kind of target gets).
    pub fn create(path: &Path) -> io::Result<AtomicFile> {
        let inner = match Target::resolve(path)? {
            Target::Replace(target) => {
                let tmp = temp_builder("")
                    .tempfile_in(parent_dir(&target))
                    .map_err(without_temp_path)?;
                // Held while it is written, so that [`lock_folder`]'s cleanup of interrupted
                // writes leaves it alone (best effort: not every file system has `flock`).
                let _ = tmp.as_file().try_lock();
                Inner::Replace { tmp, target }
            }
            Target::Stream(device) => Inner::Stream(OpenOptions::new().write(true).open(device)?),
        };
        Ok(AtomicFile { inner })
    }

    /// Syncs what was written so far to disk (a stream: flushes it), so that a [`Self::commit`]
    /// after it only renames: writers of several files sync every one before committing any.
    pub fn sync(&mut self) -> io::Result<()> {
        match &mut self.inner {
            Inner::Replace { tmp, .. } => tmp.as_file().sync_all(),
            Inner::Stream(f) => f.flush(),
        }
    }

    /// Finishes the file: syncs and renames a replacement over its target, flushes a stream.
    pub fn commit(self) -> io::Result<()> {
        match self.inner {
            Inner::Replace { tmp, target } => {
                tmp.as_file().sync_all()?;
                tmp.persist(&target).map_err(|e| e.error)?;
                Ok(())
            }
            Inner::Stream(mut f) => f.flush(),
        }
    }
}

// Through the `File`, not the `NamedTempFile`: its errors would name the temporary path
// (`… at path ".madenet-XXXXXX"`), which the user never chose; callers name the target.
impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match &mut self.inner {
            Inner::Replace { tmp, .. } => tmp.as_file_mut().write(buf),
            Inner::Stream(f) => f.write(buf),
        }
    }
    fn flush(&mut self) -> io::Result<()> {
        match &mut self.inner {
            Inner::Replace { tmp, .. } => tmp.as_file_mut().flush(),
            Inner::Stream(f) => f.flush(),
        }
    }
}

/// `e` without the `… at path ".madenet-XXXXXX"` tempfile appends: callers name the target,
/// the temporary file is none of the user's business.
fn without_temp_path(e: io::Error) -> io::Error {
    let text = e.to_string();
    match text.split_once(" at path ") {
        Some((cause, _)) => io::Error::new(e.kind(), cause.to_string()),
        None => e,
    }
}

/// What writing a path means.
enum Target {
    /// Replace this regular file (or create it).
    Replace(PathBuf),
    /// Write into this existing non-regular file (device, pipe).
    Stream(PathBuf),
}

impl Target {
    fn resolve(path: &Path) -> io::Result<Target> {
        if path.file_name().is_none() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "not a file path (no file name)",
            ));
        }
        // What the kernel finds at the end of every link first: a device or pipe reached
        // through a link the chain below cannot spell out (`/dev/stdout` → `/proc/self/fd/1`
        // → `pipe:[…]`) is streamed through the path as given.
        if let Ok(meta) = std::fs::metadata(path) {
            let kind = meta.file_type();
            if !kind.is_file() && !kind.is_dir() {
                return Ok(Target::Stream(path.to_path_buf()));
            }
        }
        let mut p = path.to_path_buf();
        for _ in 0..MAX_LINKS {
            let meta = match std::fs::symlink_metadata(&p) {
                Ok(m) => m,
                Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Target::Replace(p)),
                Err(e) => return Err(e),
            };
            let kind = meta.file_type();
            if kind.is_symlink() {
                let link = std::fs::read_link(&p)?;
                p = if link.is_absolute() {
                    link
                } else {
                    parent_dir(&p).join(link)
                };
            } else if kind.is_dir() {
                return Err(io::Error::new(
                    io::ErrorKind::IsADirectory,
                    "is a folder, not a file",
                ));
            } else if kind.is_file() {
                return Ok(Target::Replace(p));
            } else {
                return Ok(Target::Stream(p));
            }
        }
        Err(io::Error::other(format!(
            "more than {MAX_LINKS} symbolic links to follow"
        )))
    }
}

/// An output folder held by one run: [`lock_folder`]. The lock is the kernel's (`flock`) on
/// `.madenet.lock` in the folder, so it ends with the process however that ends.
#[derive(Debug)]
pub struct FolderLock {
    _file: File,
}

/// Takes `dir` (which must exist) for this run: fails with [`io::ErrorKind::WouldBlock`] while
/// another run holds it. Holding it, removes the temporary files an interrupted write left
/// there (`.madenet-*` files nobody holds: an [`AtomicFile`] holds its own while it writes).
pub fn lock_folder(dir: &Path) -> io::Result<FolderLock> {
    let file = OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(dir.join(".madenet.lock"))?;
    file.try_lock().map_err(|e| match e {
        std::fs::TryLockError::WouldBlock => io::Error::new(
            io::ErrorKind::WouldBlock,
            "another madenet run is using this folder",
        ),
        std::fs::TryLockError::Error(e) => e,
    })?;
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        let name = entry.file_name();
        if name.to_string_lossy().starts_with(".madenet-") && entry.file_type()?.is_file() {
            // Only an interrupted write's: a writer still at work (outside this lock, say a
            // `run --out` into the same folder) holds its file's lock. Best effort: that writer
            // may also have renamed or removed it already.
            let Ok(f) = File::open(entry.path()) else {
                continue;
            };
            if f.try_lock().is_ok() {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
    Ok(FolderLock { _file: file })
}

fn parent_dir(p: &Path) -> PathBuf {
    match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Temporary files readable like any file the user creates (tempfile's default is 0600; the
/// mode given here is still masked by the umask, as `File::create`'s 0666 is).
fn temp_builder(suffix: &str) -> tempfile::Builder<'_, '_> {
    let mut b = tempfile::Builder::new();
    b.prefix(".madenet-").suffix(suffix);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        b.permissions(std::fs::Permissions::from_mode(0o666));
    }
    b
}
