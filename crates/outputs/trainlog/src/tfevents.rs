//! TensorBoard event files, written by hand.
//!
//! An event file is a sequence of TFRecord records, each holding one
//! serialized `tensorflow.Event` protocol buffer. Only the handful of fields
//! a scalar curve needs are written, so the encoding is done here in a few
//! lines rather than through a protobuf toolchain (see the crate
//! documentation for the layout).

use std::fs::{File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

/// The `file_version` of the first event of every file: TensorBoard reads
/// files that declare version 2 of the event format.
pub const FILE_VERSION: &str = "brain.Event:2";

/// Writes scalars (loss, reward, ε, …) to a TensorBoard event file.
///
/// The file is `events.out.tfevents.<unix_secs>.madenet` in the directory
/// given to [`create`](Self::create), whose first record declares the file
/// version. Writes are buffered: call [`flush`](Self::flush) to make them
/// visible to a running TensorBoard (dropping the writer flushes too, but
/// ignores errors).
///
/// ```no_run
/// use madenet_trainlog::TfEventWriter;
/// let mut tb = TfEventWriter::create("runs/cep")?;
/// for episode in 0..100_i64 {
///     let reward = -60.0 + episode as f32;
///     tb.add_scalar("train/team_reward", reward, episode, 1.7e9 + episode as f64)?;
/// }
/// tb.flush()?;
/// # Ok::<(), std::io::Error>(())
/// ```
#[derive(Debug)]
pub struct TfEventWriter {
    out: BufWriter<File>,
    path: PathBuf,
    /// Reused encoding buffers.
    event: Vec<u8>,
    scratch: Vec<u8>,
}

impl TfEventWriter {
    /// Creates `dir` if needed and a new event file in it, named
    /// `events.out.tfevents.<unix_secs>.madenet` after the current time
    /// (with `.1`, `.2`, … appended if that name is taken, so two writers
    /// never share a file), and writes the file-version event stamped with
    /// the current wall time.
    ///
    /// A resumed run simply creates another file in the same directory:
    /// TensorBoard reads every event file of a run directory, and the names
    /// sort in creation order.
    ///
    /// # Errors
    ///
    /// Any I/O error creating the directory or the file or writing the
    /// first record.
    pub fn create(dir: impl AsRef<Path>) -> io::Result<Self> {
        let dir = dir.as_ref();
        std::fs::create_dir_all(dir).map_err(|e| {
            io::Error::new(e.kind(), format!("cannot create {}: {e}", dir.display()))
        })?;
        let now = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_err(|e| io::Error::other(format!("system clock before 1970: {e}")))?;
        let base = format!("events.out.tfevents.{}.madenet", now.as_secs());
        let mut n = 0u32;
        let (file, path) = loop {
            let name = if n == 0 {
                base.clone()
            } else {
                format!("{base}.{n}")
            };
            let path = dir.join(name);
            match OpenOptions::new().write(true).create_new(true).open(&path) {
                Ok(f) => break (f, path),
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists && n < 10_000 => n += 1,
                Err(e) => {
                    return Err(io::Error::new(
                        e.kind(),
                        format!("cannot create {}: {e}", path.display()),
                    ))
                }
            }
        };
        let mut w = TfEventWriter {
            out: BufWriter::new(file),
            path,
            event: Vec::with_capacity(128),
            scratch: Vec::with_capacity(64),
        };
        w.event.clear();
        put_double(&mut w.event, 1, now.as_secs_f64());
        put_bytes(&mut w.event, 3, FILE_VERSION.as_bytes());
        w.write_event()?;
        Ok(w)
    }

    /// The event file being written.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Appends one scalar: an event at `wall_time` (seconds since the Unix
    /// epoch, as TensorBoard's relative-time axis expects) and `step`
    /// holding the summary value `tag` = `value`. Tags group by their
    /// prefix before `/` in TensorBoard (`train/loss`, `val/steps`).
    ///
    /// # Errors
    ///
    /// Any I/O error writing to the file (buffered: an error may also only
    /// surface at the next write or [`flush`](Self::flush)).
    pub fn add_scalar(
        &mut self,
        tag: &str,
        value: f32,
        step: i64,
        wall_time: f64,
    ) -> io::Result<()> {
        // Summary.Value { tag = 1, simple_value = 2 }
        self.scratch.clear();
        put_bytes(&mut self.scratch, 1, tag.as_bytes());
        put_key(&mut self.scratch, 2, WIRE_FIXED32);
        self.scratch.extend_from_slice(&value.to_le_bytes());
        // Event { wall_time = 1, step = 2, summary = 5: Summary { value = 1 } }
        self.event.clear();
        put_double(&mut self.event, 1, wall_time);
        put_key(&mut self.event, 2, WIRE_VARINT);
        put_varint(&mut self.event, step as u64); // int64: two's complement
        put_key(&mut self.event, 5, WIRE_LEN);
        let value_len = self.scratch.len() as u64;
        put_varint(&mut self.event, 1 + varint_len(value_len) + value_len);
        put_bytes(&mut self.event, 1, &self.scratch);
        self.write_event()
    }

    /// Flushes buffered records to the file, where TensorBoard sees them.
    ///
    /// # Errors
    ///
    /// Any I/O error writing to the file.
    pub fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }

    /// Frames the encoded event in `self.event` as a TFRecord and writes it.
    fn write_event(&mut self) -> io::Result<()> {
        let len = (self.event.len() as u64).to_le_bytes();
        self.out.write_all(&len)?;
        self.out.write_all(&masked_crc32c(&len).to_le_bytes())?;
        self.out.write_all(&self.event)?;
        self.out
            .write_all(&masked_crc32c(&self.event).to_le_bytes())
    }
}

/// Drops, from every TensorBoard event file in `dir` (`events.out.tfevents.*`), the scalar
/// events that `keep(tag, step)` refuses — what a resumed run does with the events written
/// after its checkpoint, which it is about to write again (TensorBoard would otherwise draw
/// both). Each changed file is rewritten through a temporary file and a rename, so a crash
/// leaves either the old or the new file; a record cut short or corrupt at the end (a writer
/// stopped mid-record) is dropped with everything after it. Events that are not scalars (the
/// file-version record) are kept; a file left with no scalar is removed. A missing `dir` is
/// nothing to do. Returns the number of events dropped.
///
/// # Errors
///
/// Any I/O error reading, writing or renaming, naming the file.
pub fn truncate_events(
    dir: impl AsRef<Path>,
    keep: impl Fn(&str, i64) -> bool,
) -> io::Result<usize> {
    let dir = dir.as_ref();
    let named = |e: io::Error, p: &Path| io::Error::new(e.kind(), format!("{}: {e}", p.display()));
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(0),
        Err(e) => return Err(named(e, dir)),
    };
    let mut dropped = 0;
    let files = event_files(entries);
    for path in files {
        let bytes = std::fs::read(&path).map_err(|e| named(e, &path))?;
        let (mut kept, mut scalars, mut changed) = (Vec::with_capacity(bytes.len()), 0usize, false);
        let mut at = 0;
        while at < bytes.len() {
            let Some((data, next)) = read_record(&bytes, at) else {
                changed = true; // a torn or corrupt tail
                break;
            };
            match scalar_event(data) {
                Some((tag, step, _)) if !keep(tag, step) => {
                    dropped += 1;
                    changed = true;
                }
                other => {
                    scalars += usize::from(other.is_some());
                    kept.extend_from_slice(&bytes[at..next]);
                }
            }
            at = next;
        }
        if scalars == 0 {
            std::fs::remove_file(&path).map_err(|e| named(e, &path))?;
        } else if changed {
            // The temporary file is not named like an event file: a crash mid-rewrite leaves
            // nothing TensorBoard reads.
            madenet_files::write_atomic(&path, &kept).map_err(|e| named(e, &path))?;
        }
    }
    Ok(dropped)
}

/// The event files among `entries`, in name (= creation) order.
fn event_files(entries: std::fs::ReadDir) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| {
            p.is_file()
                && p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.starts_with("events.out.tfevents."))
        })
        .collect();
    files.sort();
    files
}

/// Every scalar of the TensorBoard event files in `dir` as (tag, step, value), file by file in
/// creation order, each in writing order (a torn or corrupt tail ends a file's reading).
///
/// # Errors
///
/// Any I/O error listing `dir` or reading a file, naming it.
pub fn read_scalars(dir: impl AsRef<Path>) -> io::Result<Vec<(String, i64, f32)>> {
    let dir = dir.as_ref();
    let named = |e: io::Error, p: &Path| io::Error::new(e.kind(), format!("{}: {e}", p.display()));
    let mut out = Vec::new();
    for path in event_files(std::fs::read_dir(dir).map_err(|e| named(e, dir))?) {
        let bytes = std::fs::read(&path).map_err(|e| named(e, &path))?;
        let mut at = 0;
        while let Some((data, next)) = read_record(&bytes, at) {
            if let Some((tag, step, value)) = scalar_event(data) {
                out.push((tag.to_string(), step, value));
            }
            at = next;
        }
    }
    Ok(out)
}

/// The data of the TFRecord at `at` and where the next one starts, if the record is whole and
/// both its CRCs match.
fn read_record(file: &[u8], at: usize) -> Option<(&[u8], usize)> {
    let header = file.get(at..at.checked_add(12)?)?;
    let (len_bytes, len_crc) = header.split_at(8);
    if u32::from_le_bytes(len_crc.try_into().ok()?) != masked_crc32c(len_bytes) {
        return None;
    }
    let len = usize::try_from(u64::from_le_bytes(len_bytes.try_into().ok()?)).ok()?;
    let start = at + 12;
    let end = start.checked_add(len)?;
    let data = file.get(start..end)?;
    let crc = file.get(end..end.checked_add(4)?)?;
    (u32::from_le_bytes(crc.try_into().ok()?) == masked_crc32c(data)).then_some((data, end + 4))
}

/// A protobuf varint at `*at` (advancing past it), if well formed.
fn read_varint(b: &[u8], at: &mut usize) -> Option<u64> {
    let mut v = 0u64;
    for shift in (0..70).step_by(7) {
        let byte = *b.get(*at)?;
        *at += 1;
        v |= u64::from(byte & 0x7f) << shift;
        if byte < 0x80 {
            return Some(v);
        }
    }
    None
}

/// One field of a protobuf message: its number, wire type, and payload (`varint` for wire
/// type 0, `bytes` for the others).
struct ProtoField<'a> {
    num: u32,
    wire: u8,
    varint: u64,
    bytes: &'a [u8],
}

impl ProtoField<'_> {
    fn is(&self, num: u32, wire: u8) -> bool {
        self.num == num && self.wire == wire
    }
}

/// The fields of one protobuf message, in order; `None` if malformed.
fn proto_fields(b: &[u8]) -> Option<Vec<ProtoField<'_>>> {
    let mut at = 0;
    let mut out = Vec::new();
    while at < b.len() {
        let key = read_varint(b, &mut at)?;
        let (num, wire) = (u32::try_from(key >> 3).ok()?, (key & 7) as u8);
        let size = match wire {
            WIRE_VARINT => {
                let varint = read_varint(b, &mut at)?;
                out.push(ProtoField {
                    num,
                    wire,
                    varint,
                    bytes: &[],
                });
                continue;
            }
            WIRE_FIXED64 => 8,
            WIRE_LEN => usize::try_from(read_varint(b, &mut at)?).ok()?,
            WIRE_FIXED32 => 4,
            _ => return None,
        };
        let payload = b.get(at..at.checked_add(size)?)?;
        out.push(ProtoField {
            num,
            wire,
            varint: 0,
            bytes: payload,
        });
        at += size;
    }
    Some(out)
}

/// The tag, step and value of a scalar event
/// (`Event { step = 2, summary = 5 { value = 1 { tag = 1, simple_value = 2 } } }`), or `None`
/// for any other record (the file-version event, or bytes that do not decode).
fn scalar_event(event: &[u8]) -> Option<(&str, i64, f32)> {
    let fields = proto_fields(event)?;
    let step = fields
        .iter()
        .find(|f| f.is(2, WIRE_VARINT))
        .map_or(0, |f| f.varint as i64);
    let summary = fields.iter().find(|f| f.is(5, WIRE_LEN))?.bytes;
    let value = proto_fields(summary)?
        .into_iter()
        .find(|f| f.is(1, WIRE_LEN))?
        .bytes;
    let value = proto_fields(value)?;
    let tag = value.iter().find(|f| f.is(1, WIRE_LEN))?.bytes;
    let x = value.iter().find(|f| f.is(2, WIRE_FIXED32))?.bytes;
    Some((
        std::str::from_utf8(tag).ok()?,
        step,
        f32::from_le_bytes(x.try_into().ok()?),
    ))
}

/// The CRC-32C (Castagnoli) of `data`, masked as TFRecord stores it (a CRC
/// of data that itself embeds CRCs is otherwise prone to collisions):
/// rotated right by 15 bits, plus `0xa282ead8`.
#[must_use]
pub fn masked_crc32c(data: &[u8]) -> u32 {
    let crc = crc32c::crc32c(data);
    crc.rotate_right(15).wrapping_add(0xa282_ead8)
}

const WIRE_VARINT: u8 = 0;
const WIRE_FIXED64: u8 = 1;
const WIRE_LEN: u8 = 2;
const WIRE_FIXED32: u8 = 5;

fn put_varint(buf: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        buf.push((v as u8) | 0x80);
        v >>= 7;
    }
    buf.push(v as u8);
}

fn varint_len(v: u64) -> u64 {
    u64::from((64 - v.leading_zeros()).max(1).div_ceil(7))
}

fn put_key(buf: &mut Vec<u8>, field: u32, wire: u8) {
    put_varint(buf, u64::from(field) << 3 | u64::from(wire));
}

fn put_double(buf: &mut Vec<u8>, field: u32, v: f64) {
    put_key(buf, field, WIRE_FIXED64);
    buf.extend_from_slice(&v.to_le_bytes());
}

fn put_bytes(buf: &mut Vec<u8>, field: u32, bytes: &[u8]) {
    put_key(buf, field, WIRE_LEN);
    put_varint(buf, bytes.len() as u64);
    buf.extend_from_slice(bytes);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A protobuf field as read back: number and value.
    #[derive(Debug, Clone, PartialEq)]
    enum Field {
        Varint(u32, u64),
        Fixed64(u32, [u8; 8]),
        Len(u32, Vec<u8>),
        Fixed32(u32, [u8; 4]),
    }

    fn get_varint(b: &[u8], at: &mut usize) -> u64 {
        let mut v = 0u64;
        for shift in (0..70).step_by(7) {
            let byte = b[*at];
            *at += 1;
            v |= u64::from(byte & 0x7f) << shift;
            if byte < 0x80 {
                return v;
            }
        }
        panic!("varint longer than 10 bytes");
    }

    /// Decodes one protobuf message into its fields, in order.
    fn fields(b: &[u8]) -> Vec<Field> {
        let mut at = 0;
        let mut out = Vec::new();
        while at < b.len() {
            let key = get_varint(b, &mut at);
            let (num, wire) = ((key >> 3) as u32, (key & 7) as u8);
            out.push(match wire {
                WIRE_VARINT => Field::Varint(num, get_varint(b, &mut at)),
                WIRE_FIXED64 => {
                    at += 8;
                    Field::Fixed64(num, b[at - 8..at].try_into().unwrap())
                }
                WIRE_LEN => {
                    let n = get_varint(b, &mut at) as usize;
                    at += n;
                    Field::Len(num, b[at - n..at].to_vec())
                }
                WIRE_FIXED32 => {
                    at += 4;
                    Field::Fixed32(num, b[at - 4..at].try_into().unwrap())
                }
                w => panic!("unexpected wire type {w}"),
            });
        }
        assert_eq!(at, b.len(), "message overruns its bytes");
        out
    }

    /// Splits an event file into its records' data, checking the framing
    /// and both CRCs of every record.
    fn records(file: &[u8]) -> Vec<Vec<u8>> {
        let mut at = 0;
        let mut out = Vec::new();
        while at < file.len() {
            assert!(
                file.len() - at >= 16,
                "truncated record header at byte {at}"
            );
            let len_bytes = &file[at..at + 8];
            let len = u64::from_le_bytes(len_bytes.try_into().unwrap()) as usize;
            let len_crc = u32::from_le_bytes(file[at + 8..at + 12].try_into().unwrap());
            assert_eq!(len_crc, masked_crc32c(len_bytes), "length CRC at byte {at}");
            let data = &file[at + 12..at + 12 + len];
            let data_crc =
                u32::from_le_bytes(file[at + 12 + len..at + 16 + len].try_into().unwrap());
            assert_eq!(data_crc, masked_crc32c(data), "data CRC at byte {at}");
            out.push(data.to_vec());
            at += 16 + len;
        }
        out
    }

    /// A decoded scalar event: (wall_time, step, tag, value).
    fn scalar(event: &[u8]) -> (f64, i64, String, f32) {
        let f = fields(event);
        let [Field::Fixed64(1, wall), Field::Varint(2, step), Field::Len(5, summary)] = &f[..]
        else {
            panic!("not a scalar event: {f:?}");
        };
        let s = fields(summary);
        let [Field::Len(1, value)] = &s[..] else {
            panic!("not one summary value: {s:?}");
        };
        let v = fields(value);
        let [Field::Len(1, tag), Field::Fixed32(2, x)] = &v[..] else {
            panic!("not a simple value: {v:?}");
        };
        (
            f64::from_le_bytes(*wall),
            *step as i64,
            String::from_utf8(tag.clone()).unwrap(),
            f32::from_le_bytes(*x),
        )
    }

    /// A scratch folder, removed when dropped (this crate is below the test kit).
    fn temp_dir(name: &str) -> tempfile::TempDir {
        tempfile::Builder::new()
            .prefix(&format!("madenet-trainlog-tf-{name}-"))
            .tempdir()
            .unwrap()
    }

    #[test]
    fn crc32c_matches_the_check_value_and_the_mask_is_tfrecords() {
        // The CRC-32C check value (RFC 3720, B.4; "CRC catalogue").
        assert_eq!(crc32c::crc32c(b"123456789"), 0xE306_9283);
        let crc: u32 = 0xE306_9283;
        #[allow(clippy::manual_rotate)] // the formula as TFRecord's documentation states it
        let masked = ((crc >> 15) | (crc << 17)).wrapping_add(0xa282_ead8);
        assert_eq!(masked_crc32c(b"123456789"), masked);
        // By hand: 0xE3069283 rotated right by 15 is 0x2507C60D; plus 0xA282EAD8.
        assert_eq!(masked, 0xC78A_B0E5);
        assert_eq!(crc32c::crc32c(b""), 0);
    }

    #[test]
    fn varints_encode_as_protobuf_does() {
        let enc = |v: u64| {
            let mut b = Vec::new();
            put_varint(&mut b, v);
            assert_eq!(b.len() as u64, varint_len(v), "length of {v}");
            b
        };
        assert_eq!(enc(0), [0x00]);
        assert_eq!(enc(1), [0x01]);
        assert_eq!(enc(127), [0x7f]);
        assert_eq!(enc(128), [0x80, 0x01]);
        assert_eq!(enc(300), [0xac, 0x02]);
        assert_eq!(enc(u64::MAX).len(), 10);
        // int64 −1 is ten bytes of two's complement.
        assert_eq!(
            enc(-1i64 as u64),
            [0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x01]
        );
    }

    #[test]
    fn a_scalar_event_has_the_hand_encoded_bytes() {
        let tmp = temp_dir("bytes");
        let dir = tmp.path().to_path_buf();
        let mut w = TfEventWriter::create(&dir).unwrap();
        w.add_scalar("a", 1.0, 2, 0.5).unwrap();
        w.flush().unwrap();
        let file = std::fs::read(w.path()).unwrap();
        let recs = records(&file);
        #[rustfmt::skip]
        let want: Vec<u8> = [
            &[0x09][..], &0.5f64.to_le_bytes(), // wall_time = 0.5 (field 1, fixed64)
            &[0x10, 0x02],                      // step = 2 (field 2, varint)
            &[0x2a, 0x0a,                       // summary (field 5, 10 bytes)
              0x0a, 0x08,                       //   value (field 1, 8 bytes)
              0x0a, 0x01, b'a',                 //     tag = "a"
              0x15], &1.0f32.to_le_bytes(),     //     simple_value = 1.0 (field 2, fixed32)
        ]
        .concat();
        assert_eq!(recs[1], want);
        // The whole record: length, its CRC, data, its CRC.
        let mut framed = (want.len() as u64).to_le_bytes().to_vec();
        framed.extend_from_slice(&masked_crc32c(&framed.clone()).to_le_bytes());
        framed.extend_from_slice(&want);
        framed.extend_from_slice(&masked_crc32c(&want).to_le_bytes());
        assert!(file.ends_with(&framed));
    }

    #[test]
    fn written_files_decode_to_the_version_and_the_scalars() {
        let tmp = temp_dir("decode");
        let dir = tmp.path().join("nested");
        let before = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap()
            .as_secs_f64();
        let mut w = TfEventWriter::create(&dir).unwrap();
        let name = w.path().file_name().unwrap().to_str().unwrap().to_string();
        assert!(
            name.starts_with("events.out.tfevents.") && name.ends_with(".madenet"),
            "{name}"
        );
        let secs: u64 = name["events.out.tfevents.".len()..name.len() - ".madenet".len()]
            .parse()
            .unwrap();
        assert!(secs as f64 >= before.floor());

        let long_tag = "validation/".repeat(20); // a length that needs a two-byte varint
        let scalars: Vec<(String, f32, i64, f64)> = vec![
            ("train/team_reward".into(), -57.25, 0, 1_700_000_000.125),
            ("train/steps".into(), 143.0, 1, 1_700_000_001.5),
            ("train/loss".into(), f32::NAN, 300, 1_700_000_002.0),
            (long_tag, f32::MAX, i64::MAX, 1e10),
            ("ünïcode/ε".into(), -0.0, -5, 0.0),
        ];
        for (tag, v, step, t) in &scalars {
            w.add_scalar(tag, *v, *step, *t).unwrap();
        }
        w.flush().unwrap();
        let file = std::fs::read(w.path()).unwrap();
        let recs = records(&file);
        assert_eq!(recs.len(), 1 + scalars.len());

        let first = fields(&recs[0]);
        let [Field::Fixed64(1, wall), Field::Len(3, version)] = &first[..] else {
            panic!("not a file-version event: {first:?}");
        };
        let wall = f64::from_le_bytes(*wall);
        assert!(wall >= before && wall < before + 60.0, "{wall} vs {before}");
        assert_eq!(version, FILE_VERSION.as_bytes());

        for (rec, (tag, v, step, t)) in recs[1..].iter().zip(&scalars) {
            let (t2, step2, tag2, v2) = scalar(rec);
            assert_eq!((t2, step2, &tag2), (*t, *step, tag));
            assert_eq!(v2.to_bits(), v.to_bits(), "{tag}");
        }
    }

    #[test]
    fn a_second_writer_in_the_same_directory_gets_its_own_file() {
        let tmp = temp_dir("resume");
        let dir = tmp.path().to_path_buf();
        let mut a = TfEventWriter::create(&dir).unwrap();
        let mut b = TfEventWriter::create(&dir).unwrap();
        assert_ne!(a.path(), b.path());
        a.add_scalar("x", 1.0, 0, 1.0).unwrap();
        b.add_scalar("x", 2.0, 1, 2.0).unwrap();
        drop(a); // dropping flushes
        b.flush().unwrap();
        let mut names: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        names.sort();
        assert_eq!(names.len(), 2);
        let values: Vec<f32> = names
            .iter()
            .map(|p| scalar(&records(&std::fs::read(p).unwrap())[1]).3)
            .collect();
        assert_eq!(values, [1.0, 2.0], "names sort in creation order");
    }

    #[test]
    fn truncating_keeps_what_the_checkpoint_saw_and_drops_a_torn_tail() {
        let tmp = temp_dir("truncate");
        let dir = tmp.path().to_path_buf();
        // An earlier run: episodes 0..6 and losses 1..=4, then a second file from a resume.
        let mut a = TfEventWriter::create(&dir).unwrap();
        for e in 0..6 {
            a.add_scalar("episode/reward", e as f32, e, 1.0).unwrap();
        }
        for u in 1..=4 {
            a.add_scalar("loss/dep", u as f32 * 0.5, u, 2.0).unwrap();
        }
        a.add_scalar("other/x", 9.0, 99, 3.0).unwrap();
        drop(a);
        // A resumed run's file, whose writer stopped mid-record (a torn tail)…
        let mut b = TfEventWriter::create(&dir).unwrap();
        b.add_scalar("other/y", 10.0, 1, 4.0).unwrap();
        let second = b.path().to_path_buf();
        drop(b);
        let whole = std::fs::read(&second).unwrap();
        let mut torn = whole.clone();
        torn.extend_from_slice(&whole[..10]);
        std::fs::write(&second, &torn).unwrap();
        // …and a file holding only episodes the checkpoint never saw.
        let mut c = TfEventWriter::create(&dir).unwrap();
        c.add_scalar("episode/reward", 11.0, 8, 5.0).unwrap();
        drop(c);

        let keep = |tag: &str, step: i64| match tag.split('/').next() {
            Some("episode") => step < 4,
            Some("loss") => step <= 2,
            _ => true,
        };
        let dropped = truncate_events(&dir, keep).unwrap();
        assert_eq!(
            dropped,
            2 + 2 + 1,
            "episodes 4 and 5, losses 3 and 4, episode 8"
        );
        let mut names: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        names.sort();
        assert_eq!(
            names.len(),
            2,
            "the file left without scalars is gone: {names:?}"
        );
        assert_eq!(names[1], second);
        assert_eq!(
            std::fs::read(&second).unwrap(),
            whole,
            "the torn tail is cut off"
        );
        let recs = records(&std::fs::read(&names[0]).unwrap());
        assert!(
            matches!(
                fields(&recs[0])[..],
                [Field::Fixed64(1, _), Field::Len(3, _)]
            ),
            "the version record stays first"
        );
        let left: Vec<(String, i64)> = recs[1..]
            .iter()
            .map(|r| scalar(r))
            .map(|(_, step, tag, _)| (tag, step))
            .collect();
        let want: Vec<(String, i64)> = (0..4)
            .map(|e| ("episode/reward".to_string(), e))
            .chain((1..=2).map(|u| ("loss/dep".to_string(), u)))
            .chain([("other/x".to_string(), 99)])
            .collect();
        assert_eq!(left, want);
        let read: Vec<(String, i64)> = read_scalars(&dir)
            .unwrap()
            .into_iter()
            .map(|(tag, step, _)| (tag, step))
            .collect();
        assert_eq!(
            read,
            want.iter()
                .cloned()
                .chain([("other/y".to_string(), 1)])
                .collect::<Vec<_>>()
        );
        assert_eq!(read_scalars(&dir).unwrap()[0].2, 0.0);
        // Nothing more to drop: the file is left as it is.
        let before = std::fs::read(&names[0]).unwrap();
        assert_eq!(truncate_events(&dir, keep).unwrap(), 0);
        assert_eq!(std::fs::read(&names[0]).unwrap(), before);
        assert_eq!(truncate_events(dir.join("missing"), keep).unwrap(), 0);
    }

    #[test]
    fn an_unwritable_directory_is_an_error_naming_it() {
        let tmp = temp_dir("blocked");
        let dir = tmp.path().to_path_buf();
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("not-a-dir");
        std::fs::write(&file, b"x").unwrap();
        let err = TfEventWriter::create(&file).unwrap_err().to_string();
        assert!(err.contains(&file.display().to_string()), "{err}");
        let err = TfEventWriter::create(file.join("below"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("not-a-dir"), "{err}");
    }
}
