//! What the workspace's integration tests share (a dev-dependency only, never part of a
//! binary): running the command line with a time limit ([`run`]), scratch folders removed
//! after the test ([`Scratch`]), and the contract every bad input is held to
//! ([`assert_clean_error`]: exit code 2, one `error:` line naming what is wrong, no panic).
//!
//! ```
//! use madenet_testkit::Scratch;
//!
//! let dir = Scratch::new("doc");
//! let file = dir.write("a.toml", "seeds = 1\n");
//! assert_eq!(madenet_testkit::read(&file), "seeds = 1\n");
//! let path = dir.to_path_buf();
//! drop(dir);
//! assert!(!path.exists()); // gone with the scratch folder
//! ```

use std::ffi::OsStr;
use std::fmt::Debug;
use std::ops::Deref;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// How long [`run`] lets a command run before the test fails.
pub const RUN_LIMIT: Duration = Duration::from_secs(600);

/// Runs `bin` (in a test: `env!("CARGO_BIN_EXE_madenet")`) with `args` and collects its output;
/// kills it and fails the test after `limit` (a hang or a runaway allocation).
pub fn run_limited<S: AsRef<OsStr> + Debug>(bin: &str, args: &[S], limit: Duration) -> Output {
    use std::io::Read;
    let mut child = Command::new(bin)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("run {bin}: {e}"));
    // The pipes are drained while the command runs, so a chatty one cannot block on a full pipe.
    let drain = |mut pipe: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut buf = Vec::new();
            let _ = pipe.read_to_end(&mut buf);
            buf
        })
    };
    let stdout = drain(Box::new(child.stdout.take().expect("piped")));
    let stderr = drain(Box::new(child.stderr.take().expect("piped")));
    let t0 = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait") {
            break status;
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{bin} {args:?} ran for over {} s", limit.as_secs());
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    Output {
        status,
        stdout: stdout.join().expect("stdout reader"),
        stderr: stderr.join().expect("stderr reader"),
    }
}

/// [`run_limited`] with [`RUN_LIMIT`].
pub fn run<S: AsRef<OsStr> + Debug>(bin: &str, args: &[S]) -> Output {
    run_limited(bin, args, RUN_LIMIT)
}

/// A scratch folder, removed when dropped (kept, to look at, when `MADENET_KEEP_TEST_DIRS` is
/// set). Dereferences to its path.
pub struct Scratch {
    dir: Option<tempfile::TempDir>,
    path: PathBuf,
}

impl Scratch {
    /// A new empty folder under the system's temp folder, its name starting `madenet-<tag>-`.
    pub fn new(tag: &str) -> Self {
        let dir = tempfile::Builder::new()
            .prefix(&format!("madenet-{tag}-"))
            .tempdir()
            .expect("scratch folder");
        let path = dir.path().to_path_buf();
        Scratch {
            dir: Some(dir),
            path,
        }
    }

    /// The folder.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes `text` to `name` in the folder and returns its path.
    pub fn write(&self, name: &str, text: &str) -> PathBuf {
        let p = self.path.join(name);
        std::fs::write(&p, text).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        p
    }
}

impl Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.path
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.path
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if std::env::var_os("MADENET_KEEP_TEST_DIRS").is_some() {
            if let Some(d) = self.dir.take() {
                let _ = d.keep();
            }
        }
    }
}

/// A training run's TensorBoard scalars in `dir` as (tag, step, value bits), sorted: what two
/// runs (an uninterrupted one and a resumed one) are compared by.
pub fn tb_scalars(dir: impl AsRef<Path>) -> Vec<(String, i64, u32)> {
    let dir = dir.as_ref();
    let mut s: Vec<(String, i64, u32)> = madenet_trainlog::read_scalars(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .into_iter()
        .map(|(tag, step, v)| (tag, step, v.to_bits()))
        .collect();
    s.sort();
    s
}

/// The names of the entries of `dir`, sorted.
pub fn entries(dir: impl AsRef<Path>) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir.as_ref())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// `path` as a fresh, empty folder (whatever was there before is removed); returns it.
pub fn fresh_dir(path: impl Into<PathBuf>) -> PathBuf {
    let d = path.into();
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Asserts that the command of `out` succeeded; its stderr is the failure's message.
#[track_caller]
pub fn assert_ok(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Two `curves.jsonl` texts hold the same trials in the same order with the same curves, up to
/// the last bit of a float (madenet-study's `resumed_curves_are_byte_identical`, a known bug).
pub fn assert_curves_close(got: &str, want: &str) {
    let (g, w): (Vec<&str>, Vec<&str>) = (got.lines().collect(), want.lines().collect());
    assert_eq!(g.len(), w.len(), "curves.jsonl line count");
    for (a, b) in g.iter().zip(&w) {
        let a: serde_json::Value = serde_json::from_str(a).unwrap();
        let b: serde_json::Value = serde_json::from_str(b).unwrap();
        assert_eq!(a["key"], b["key"]);
        for f in ["explored", "distance"] {
            let (x, y) = (a[f].as_array().unwrap(), b[f].as_array().unwrap());
            assert_eq!(x.len(), y.len(), "{f} of {}", a["key"]);
            for (p, q) in x.iter().zip(y) {
                let (p, q) = (p.as_f64().unwrap(), q.as_f64().unwrap());
                assert!(
                    (p - q).abs() <= 1e-12 * q.abs().max(1.0),
                    "{f} of {}: {p} vs {q}",
                    a["key"]
                );
            }
        }
    }
}

/// The text of `path` (the test fails naming the file if it cannot be read).
pub fn read(path: impl AsRef<Path>) -> String {
    let p = path.as_ref();
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The error contract: exit code 2, no panic, and one non-empty stderr line starting `error: `
/// that contains every `needle`. Returns the line.
pub fn assert_clean_error(out: &Output, needles: &[&str]) -> String {
    assert_clean_error_in("", out, needles)
}

/// The one error line of `out`, checked as [`assert_clean_error`] checks it.
pub fn error_line(out: &Output) -> String {
    assert_clean_error(out, &[])
}

/// [`assert_clean_error`], naming `case` in its failures.
pub fn assert_clean_error_in(case: &str, out: &Output, needles: &[&str]) -> String {
    let err = String::from_utf8_lossy(&out.stderr);
    let out_text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{case}: stdout {out_text} stderr {err}"
    );
    assert!(!err.contains("panicked"), "{case}: {err}");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{case}: one line expected: {err:?}");
    assert!(lines[0].starts_with("error: "), "{case}: {err}");
    for n in needles {
        assert!(lines[0].contains(n), "{case}: `{n}` missing from: {err}");
    }
    lines[0].to_string()
}
