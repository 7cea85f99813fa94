//! Animated GIFs of rendered frames: [`save_gif`] and the streaming [`GifWriter`], which stores
//! only what changed between frames (its colour table and change scan are hand-written: they
//! run for every pixel of every frame, where general-purpose containers cost more than the
//! encoding).

use crate::{check_frame_size, create, io_err, render, Frame, RenderError, RenderOptions};
use image::RgbaImage;
use madenet_files::AtomicFile;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// Renders `frames` and writes them as an endlessly looping animated GIF to `path`
/// (atomically), `delay_ms` per frame (GIF stores hundredths of a second). All frames must
/// have the same grid size. Uses [`GifWriter`].
pub fn save_gif(
    frames: &[Frame],
    opts: &RenderOptions,
    delay_ms: u32,
    path: &Path,
) -> Result<(), RenderError> {
    if frames.is_empty() {
        return Err(RenderError::NoFrames {
            path: path.to_path_buf(),
        });
    }
    let mut w = GifWriter::new(path, opts, delay_ms)?;
    for f in frames {
        w.push(f)?;
    }
    w.finish().map(drop)
}

/// Counts the bytes written through it: the size of the GIF so far.
struct Counting<W> {
    inner: W,
    bytes: u64,
}

impl<W: Write> Write for Counting<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.bytes += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

type GifOut = Counting<BufWriter<AtomicFile>>;

/// The GIF encoder's speed for pictures of more than 256 colours (NeuQuant quantization);
/// the setting the writer has always used.
const QUANTIZER_SPEED: i32 = 10;

/// Writes an animated GIF one frame at a time, so long episodes need not keep every frame
/// in memory. Frames go to a temporary file next to the target (a device or pipe is written
/// directly); [`GifWriter::finish`] renames it into place. Dropping the writer without finishing removes the temporary file.
/// The animation loops forever.
///
/// Each frame after the first stores only the rectangle around the pixels that changed since
/// the previous frame, with the unchanged pixels inside it transparent (so the previous
/// frame shows through), which keeps files and encoding time small when little moves. The
/// decoded animation is the same as storing every frame in full: pictures of at most 256
/// colours come back pixel for pixel. Pictures of more colours (quantized) or with fully
/// transparent pixels are stored whole, as before. Fully transparent pixels show the frame
/// before (the background in the first frame); the writer used to show the background there.
/// The pictures [`render`] draws are opaque.
pub struct GifWriter {
    /// The file until the first frame sets the picture size (the GIF header needs it).
    out: Option<GifOut>,
    encoder: Option<gif::Encoder<GifOut>>,
    path: PathBuf,
    opts: RenderOptions,
    /// Frame delay in hundredths of a second.
    delay: u16,
    size: Option<(u32, u32)>,
    frames: usize,
    delta: Delta,
}

impl GifWriter {
    /// Starts a GIF at `path` with `delay_ms` per frame.
    pub fn new(path: &Path, opts: &RenderOptions, delay_ms: u32) -> Result<GifWriter, RenderError> {
        let file = create(path)?;
        Ok(GifWriter {
            out: Some(Counting {
                inner: BufWriter::new(file),
                bytes: 0,
            }),
            encoder: None,
            path: path.to_path_buf(),
            opts: *opts,
            delay: u16::try_from(delay_ms / 10).unwrap_or(u16::MAX),
            size: None,
            frames: 0,
            delta: Delta::default(),
        })
    }

    /// Renders `frame` and appends it.
    pub fn push(&mut self, frame: &Frame) -> Result<(), RenderError> {
        check_frame_size(frame, &self.opts, &self.path)?;
        self.push_image(render(frame, &self.opts))
    }

    /// Appends an already rendered picture (e.g. from [`render`], possibly annotated).
    pub fn push_image(&mut self, img: RgbaImage) -> Result<(), RenderError> {
        let got = img.dimensions();
        let (width, height) = *self.size.get_or_insert(got);
        if got != (width, height) {
            return Err(RenderError::FrameSize {
                path: self.path.clone(),
                index: self.frames,
                width,
                height,
                got_width: got.0,
                got_height: got.1,
            });
        }
        let (Ok(w16), Ok(h16)) = (u16::try_from(width), u16::try_from(height)) else {
            return Err(RenderError::Encode {
                path: self.path.clone(),
                source: image::ImageError::Parameter(image::error::ParameterError::from_kind(
                    image::error::ParameterErrorKind::DimensionMismatch,
                )),
            });
        };
        if self.encoder.is_none() {
            let out = self.out.take().expect("file present until the first frame");
            let mut encoder = gif::Encoder::new(out, w16, h16, &[]).map_err(|e| self.gif_err(e))?;
            encoder
                .set_repeat(gif::Repeat::Infinite)
                .map_err(|e| self.gif_err(e))?;
            self.encoder = Some(encoder);
        }
        let mut frame = match self.delta.frame(&img) {
            Some(frame) => frame,
            // More than 256 colours or transparent pixels: the whole picture, as always.
            None => {
                self.delta.canvas = None;
                let mut raw = img.into_raw();
                let mut f = gif::Frame::from_rgba_speed(w16, h16, &mut raw, QUANTIZER_SPEED);
                // Kept like the changed-rectangle frames, so a later picture's transparent
                // pixels always show the frame before it.
                f.dispose = gif::DisposalMethod::Keep;
                f
            }
        };
        frame.delay = self.delay;
        let encoder = self.encoder.as_mut().expect("encoder present until finish");
        let written = encoder.write_frame(&frame);
        drop(frame);
        written.map_err(|e| self.gif_err(e))?;
        self.frames += 1;
        Ok(())
    }

    /// Number of frames written so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Size of the GIF so far in bytes (everything written for the frames pushed so far;
    /// [`GifWriter::finish`] adds the one-byte trailer), e.g. for progress output.
    pub fn bytes_written(&self) -> u64 {
        match (&self.encoder, &self.out) {
            (Some(e), _) => e.get_ref().bytes,
            (None, Some(out)) => out.bytes,
            (None, None) => 0,
        }
    }

    /// Picture size in pixels (width, height), known once the first frame is pushed.
    pub fn dimensions(&self) -> Option<(u32, u32)> {
        self.size
    }

    /// Writes the GIF trailer and moves the file into place; returns the file's size in bytes.
    pub fn finish(mut self) -> Result<u64, RenderError> {
        if self.frames == 0 {
            return Err(RenderError::NoFrames {
                path: self.path.clone(),
            });
        }
        let encoder = self.encoder.take().expect("encoder present after a frame");
        let out = encoder.into_inner().map_err(|e| self.gif_err(e))?;
        let bytes = out.bytes;
        let file = out
            .inner
            .into_inner()
            .map_err(|e| io_err(&self.path, e.into_error()))?;
        file.commit().map_err(|e| io_err(&self.path, e))?;
        Ok(bytes)
    }

    fn gif_err(&self, e: gif::EncodingError) -> RenderError {
        match e {
            gif::EncodingError::Io(source) => RenderError::Io {
                path: self.path.clone(),
                source,
            },
            other => RenderError::Encode {
                path: self.path.clone(),
                source: image::ImageError::Encoding(image::error::EncodingError::new(
                    image::ImageFormat::Gif.into(),
                    other,
                )),
            },
        }
    }
}

/// The colours seen so far (at most 256), each with a fixed palette index.
///
/// Hand-written open addressing keyed by the packed colour: looked up for every pixel, where
/// a general hash map would cost more than the rest of the encoding.
struct Colors {
    /// `[r, g, b]` by palette index.
    palette: Vec<[u8; 3]>,
    /// Packed colour (`r | g << 8 | b << 16`) or [`Colors::EMPTY`], by slot.
    keys: Box<[u32; Colors::SLOTS]>,
    /// Palette index, by slot.
    index: Box<[u8; Colors::SLOTS]>,
}

impl Default for Colors {
    fn default() -> Self {
        Colors {
            palette: Vec::with_capacity(256),
            keys: Box::new([Colors::EMPTY; Colors::SLOTS]),
            index: Box::new([0; Colors::SLOTS]),
        }
    }
}

impl Colors {
    /// Four slots per colour keep probe sequences short.
    const SLOTS: usize = 1024;
    /// No packed colour has bits above the 24th.
    const EMPTY: u32 = u32::MAX;

    fn key(p: &[u8]) -> u32 {
        u32::from(p[0]) | u32::from(p[1]) << 8 | u32::from(p[2]) << 16
    }

    /// Palette index of colour `key`, adding it if new; `None` when the palette is full.
    fn index_of(&mut self, key: u32) -> Option<u8> {
        let mut slot = (key.wrapping_mul(0x9E37_79B1) >> 22) as usize;
        loop {
            match self.keys[slot] {
                k if k == key => return Some(self.index[slot]),
                Colors::EMPTY => break,
                _ => slot = (slot + 1) % Colors::SLOTS,
            }
        }
        let i = u8::try_from(self.palette.len()).ok()?;
        self.keys[slot] = key;
        self.index[slot] = i;
        self.palette
            .push([key as u8, (key >> 8) as u8, (key >> 16) as u8]);
        Some(i)
    }

    fn clear(&mut self) {
        self.palette.clear();
        self.keys.fill(Colors::EMPTY);
    }
}

/// What a GIF decoder shows after the frames written so far, to encode only the changes.
#[derive(Default)]
struct Delta {
    colors: Colors,
    /// Palette index of every pixel shown (row-major); `None` when nothing usable is shown
    /// (before the first frame, after a frame stored whole and disposed to the background).
    canvas: Option<Vec<u8>>,
    /// The frame's indices, reused.
    buf: Vec<u8>,
}

/// What [`Delta::scan`] found.
enum Scan {
    /// A fully transparent pixel.
    Transparent,
    /// A colour that does not fit the palette.
    Full,
    /// The rectangle (x0, y0, x1, y1, inclusive) around the pixels that differ from the
    /// canvas (all of them without a canvas), `None` if none does.
    Changed(Option<(usize, usize, usize, usize)>),
}

impl Delta {
    /// The GIF frame for opaque picture `img` of at most 256 colours, storing the pixels that
    /// changed and updating the canvas; `None` for any other picture (the caller stores it
    /// whole and must then clear the canvas).
    fn frame(&mut self, img: &RgbaImage) -> Option<gif::Frame<'_>> {
        let mut changed = self.scan(img);
        if matches!(changed, Scan::Full) {
            // The palette filled up with colours of earlier frames: start afresh from this one.
            self.colors.clear();
            self.canvas = None;
            changed = self.scan(img);
        }
        let Scan::Changed(rect) = changed else {
            return None;
        };
        let width = img.width() as usize;
        // Nothing changed: a one-pixel frame repeating the top-left pixel keeps the timing.
        let (x0, y0, x1, y1) = rect.unwrap_or((0, 0, 0, 0));
        let (rw, rh) = (x1 - x0 + 1, y1 - y0 + 1);
        // Unchanged pixels become a transparent index past the colours, if there is room.
        let keep = match self.canvas {
            Some(_) => u8::try_from(self.colors.palette.len()).ok(),
            None => None,
        };
        let canvas = self
            .canvas
            .get_or_insert_with(|| vec![0; img.width() as usize * img.height() as usize]);
        let raw = img.as_raw();
        self.buf.clear();
        self.buf.reserve(rw * rh);
        let (mut last_key, mut last) = (Colors::EMPTY, 0u8);
        for y in y0..=y1 {
            let row = &raw[(y * width + x0) * 4..(y * width + x1 + 1) * 4];
            let shown = &mut canvas[y * width + x0..=y * width + x1];
            for (p, shown) in row.chunks_exact(4).zip(shown) {
                let key = Colors::key(p);
                if key != last_key {
                    last = self.colors.index_of(key).expect("scanned colours fit");
                    last_key = key;
                }
                let out = match keep {
                    Some(t) if *shown == last => t,
                    _ => last,
                };
                *shown = last;
                self.buf.push(out);
            }
        }
        let mut palette: Vec<u8> = self.colors.palette.iter().flatten().copied().collect();
        if keep.is_some() {
            palette.extend_from_slice(&[0, 0, 0]);
        }
        Some(gif::Frame {
            left: x0 as u16,
            top: y0 as u16,
            width: rw as u16,
            height: rh as u16,
            buffer: std::borrow::Cow::Borrowed(&self.buf),
            palette: Some(palette),
            transparent: keep,
            dispose: gif::DisposalMethod::Keep,
            ..gif::Frame::default()
        })
    }

    /// Adds the picture's colours to the palette and finds what changed since the canvas.
    fn scan(&mut self, img: &RgbaImage) -> Scan {
        let width = img.width() as usize;
        let canvas = self.canvas.as_deref();
        let mut rect: Option<(usize, usize, usize, usize)> = None;
        let (mut last_key, mut last) = (Colors::EMPTY, 0u8);
        for (y, row) in img.as_raw().chunks_exact(width * 4).enumerate() {
            let shown = canvas.map(|c| &c[y * width..(y + 1) * width]);
            let (mut first, mut end) = (usize::MAX, 0);
            for (x, p) in row.chunks_exact(4).enumerate() {
                if p[3] == 0 {
                    return Scan::Transparent;
                }
                let key = Colors::key(p);
                if key != last_key {
                    match self.colors.index_of(key) {
                        Some(i) => last = i,
                        None => return Scan::Full,
                    }
                    last_key = key;
                }
                if shown.is_none_or(|s| s[x] != last) {
                    first = first.min(x);
                    end = x;
                }
            }
            if first != usize::MAX {
                rect = Some(match rect {
                    None => (first, y, end, y),
                    Some((x0, y0, x1, _)) => (x0.min(first), y0, x1.max(end), y),
                });
            }
        }
        Scan::Changed(rect)
    }
}
