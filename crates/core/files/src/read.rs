//! Reading input files with a size cap: every file madenet reads because a user pointed at it
//! (a config, a map, a model's weights) is read here, so none can make it read without end.
//!
//! * a **regular file** larger than its kind's cap is refused before a byte is read;
//! * anything else — a **FIFO** or a **device** (`/dev/stdin`, `/dev/zero`) — is read as a
//!   stream, up to the same cap, and never waits more than [`STREAM_WAIT`] of silence for more:
//!   a FIFO nobody writes is an error at once instead of a hang (an empty one would silently be
//!   an empty config). A writer must have the FIFO open when it is read.
//!
//! ```
//! use madenet_files::{read_capped, InputKind};
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("cfg.toml");
//! std::fs::write(&path, "seeds = 3\n").unwrap();
//! assert_eq!(read_capped(&path, InputKind::Config).unwrap(), b"seeds = 3\n");
//! let e = madenet_files::read_capped(std::path::Path::new("/dev/zero"), InputKind::Config);
//! assert!(e.unwrap_err().to_string().contains("16 MiB"));
//! ```

use std::io::{self, Read};
use std::path::Path;
use std::time::{Duration, Instant};

/// The longest a stream (FIFO, device) may stay silent before the read gives up.
pub const STREAM_WAIT: Duration = Duration::from_secs(10);

/// What an input file is, which sets how large it may be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputKind {
    /// A TOML, YAML or JSON config or description (`study.toml`, a map's `.yaml`,
    /// `model.toml`): 16 MiB.
    Config,
    /// A map: an image (PGM, PNG) or a text map: 256 MiB (a 16 000 × 16 000 8-bit PGM).
    Map,
    /// A model's weight file: 256 MiB (the shipped ones are under 1 MiB).
    Weights,
}

impl InputKind {
    /// The largest file of this kind that is read, in bytes.
    pub fn cap(self) -> u64 {
        const MIB: u64 = 1 << 20;
        match self {
            InputKind::Config => 16 * MIB,
            InputKind::Map | InputKind::Weights => 256 * MIB,
        }
    }

    fn name(self) -> &'static str {
        match self {
            InputKind::Config => "a config",
            InputKind::Map => "a map",
            InputKind::Weights => "a weight file",
        }
    }

    fn too_large(self, what: String) -> io::Error {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!(
                "{what}, more than the {} MiB read of {}",
                self.cap() >> 20,
                self.name()
            ),
        )
    }
}

/// Reads `path` whole, refusing more than `kind`'s cap (see the module doc). Errors are
/// `io::Error`s without the path; callers name it.
pub fn read_capped(path: &Path, kind: InputKind) -> io::Result<Vec<u8>> {
    let meta = std::fs::metadata(path)?;
    if meta.is_dir() {
        return Err(io::Error::new(
            io::ErrorKind::IsADirectory,
            "is a folder, not a file",
        ));
    }
    if meta.is_file() {
        if meta.len() > kind.cap() {
            return Err(kind.too_large(format!("{} bytes", meta.len())));
        }
        let mut bytes = Vec::with_capacity(meta.len() as usize);
        // The file may grow while it is read: the cap holds all the same.
        std::fs::File::open(path)?
            .take(kind.cap() + 1)
            .read_to_end(&mut bytes)?;
        if bytes.len() as u64 > kind.cap() {
            return Err(kind.too_large("it grew while read".into()));
        }
        return Ok(bytes);
    }
    use std::os::unix::fs::FileTypeExt;
    let bytes = read_stream(path, kind)?;
    if bytes.is_empty() && meta.file_type().is_fifo() {
        // Nobody was writing when it was opened (or the writer sent nothing): an empty config
        // would silently mean every default.
        return Err(io::Error::new(
            io::ErrorKind::UnexpectedEof,
            "a pipe that ended before sending anything (was anything writing to it?)",
        ));
    }
    Ok(bytes)
}

/// [`read_capped`] for text: the bytes must be UTF-8.
pub fn read_text_capped(path: &Path, kind: InputKind) -> io::Result<String> {
    String::from_utf8(read_capped(path, kind)?)
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidData, "is not UTF-8 text"))
}

/// A FIFO or device: opened without blocking (a FIFO with no writer would block `open` itself),
/// read until end of stream, the cap, or [`STREAM_WAIT`] of silence.
fn read_stream(path: &Path, kind: InputKind) -> io::Result<Vec<u8>> {
    use std::os::unix::fs::OpenOptionsExt;
    let mut file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)?;
    let mut bytes = Vec::new();
    let mut buf = [0u8; 64 * 1024];
    let mut last_data = Instant::now();
    loop {
        match file.read(&mut buf) {
            Ok(0) => return Ok(bytes),
            Ok(n) => {
                bytes.extend_from_slice(&buf[..n]);
                if bytes.len() as u64 > kind.cap() {
                    return Err(kind.too_large("a stream that goes on".into()));
                }
                last_data = Instant::now();
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                if last_data.elapsed() > STREAM_WAIT {
                    return Err(io::Error::new(
                        io::ErrorKind::TimedOut,
                        format!("a stream that sent nothing for {} s", STREAM_WAIT.as_secs()),
                    ));
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_large_regular_file_is_refused_before_it_is_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.toml");
        let f = std::fs::File::create(&path).unwrap();
        f.set_len(InputKind::Config.cap() + 1).unwrap(); // sparse: no disk used
        let e = read_capped(&path, InputKind::Config).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidData);
        assert!(e.to_string().contains("16777217 bytes"), "{e}");
        std::fs::File::create(&path)
            .unwrap()
            .set_len(InputKind::Config.cap())
            .unwrap();
        assert_eq!(
            read_capped(&path, InputKind::Config).unwrap().len() as u64,
            InputKind::Config.cap()
        );
    }

    #[test]
    fn endless_devices_stop_at_the_cap() {
        for dev in ["/dev/zero", "/dev/urandom"] {
            let e = read_capped(Path::new(dev), InputKind::Config).unwrap_err();
            assert!(
                e.to_string().contains("a stream that goes on"),
                "{dev}: {e}"
            );
        }
        assert!(read_capped(Path::new("/dev/null"), InputKind::Map)
            .unwrap()
            .is_empty());
    }

    #[test]
    fn a_fifo_without_a_writer_is_an_error_and_a_written_one_reads_whole() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("fifo");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let start = Instant::now();
        let e = read_capped(&fifo, InputKind::Config).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::UnexpectedEof, "{e}");
        assert!(start.elapsed() < Duration::from_secs(5));
        // A writer that holds the FIFO open (read-write: that never blocks on Linux) and
        // writes a little later is waited for.
        let mut w = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&fifo)
            .unwrap();
        let writer = std::thread::spawn(move || {
            use std::io::Write;
            std::thread::sleep(Duration::from_millis(50));
            w.write_all(b"seeds = 3\n").unwrap();
        });
        let got = read_capped(&fifo, InputKind::Config);
        writer.join().unwrap();
        assert_eq!(got.unwrap(), b"seeds = 3\n");
    }

    #[test]
    fn folders_and_missing_files_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let e = read_capped(dir.path(), InputKind::Map).unwrap_err();
        assert!(e.to_string().contains("folder"), "{e}");
        let e = read_capped(&dir.path().join("nope"), InputKind::Map).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::NotFound);
    }
}
