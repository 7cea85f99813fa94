//! PGM images: the decoder for `.pgm` files (binary P5 and ASCII P2, 8-bit) and the P5 writer.
//!
//! Not `image`'s PNM decoder: measured (0.25.10), it decodes 16-bit PGMs and clamps samples > maxval.

use super::raster::Raster;
use super::{check_savable, format_err, pixel_of, write_atomic};
use crate::{MapError, OccGrid};
use std::path::Path;

/// Why a PGM number token could not be read.
enum PgmToken {
    End,
    NotDigit(u8),
    TooLarge,
}

/// Reads one whitespace-separated decimal number of a PGM (skipping `#` comments).
fn pgm_number(bytes: &[u8], pos: &mut usize) -> Result<usize, PgmToken> {
    skip_pgm_space(bytes, pos);
    let start = *pos;
    let mut value: usize = 0;
    while let Some(&b) = bytes.get(*pos).filter(|b| b.is_ascii_digit()) {
        value = value
            .checked_mul(10)
            .and_then(|v| v.checked_add((b - b'0') as usize))
            .ok_or(PgmToken::TooLarge)?;
        *pos += 1;
    }
    if start == *pos {
        return Err(bytes
            .get(*pos)
            .map_or(PgmToken::End, |&b| PgmToken::NotDigit(b)));
    }
    Ok(value)
}

/// Reads a PGM number, describing a failure as an error about `what` in `path`.
fn pgm_field(
    bytes: &[u8],
    pos: &mut usize,
    what: impl Fn() -> String,
    path: &Path,
) -> Result<usize, MapError> {
    pgm_number(bytes, pos).map_err(|e| match e {
        PgmToken::End => format_err(
            path,
            format!("truncated PGM: file ends before the {}", what()),
        ),
        PgmToken::NotDigit(b) => format_err(
            path,
            format!(
                "garbled PGM: expected the {} (a number), found byte 0x{b:02x}",
                what()
            ),
        ),
        PgmToken::TooLarge => format_err(path, format!("garbled PGM: the {} is too large", what())),
    })
}

fn skip_pgm_space(bytes: &[u8], pos: &mut usize) {
    while *pos < bytes.len() {
        if bytes[*pos].is_ascii_whitespace() {
            *pos += 1;
        } else if bytes[*pos] == b'#' {
            while *pos < bytes.len() && bytes[*pos] != b'\n' && bytes[*pos] != b'\r' {
                *pos += 1;
            }
        } else {
            break;
        }
    }
}

/// Decodes an 8-bit PGM: binary P5 or ASCII P2, `maxval` 1–255 (values are rescaled to
/// 0–255 when `maxval < 255`). Every error names `path`.
pub(super) fn decode_pgm(bytes: &[u8], path: &Path) -> Result<Raster, MapError> {
    let binary = match bytes.get(..2) {
        Some(b"P5") => true,
        Some(b"P2") => false,
        _ => {
            return Err(format_err(
                path,
                "not an 8-bit PGM image: the file must start with P5 (binary) or P2 (ASCII)",
            ));
        }
    };
    let mut pos = 2;
    if bytes
        .get(pos)
        .is_some_and(|b| !b.is_ascii_whitespace() && *b != b'#')
    {
        return Err(format_err(
            path,
            "garbled PGM header: expected whitespace after the magic number",
        ));
    }
    let width = pgm_field(bytes, &mut pos, || "header width".into(), path)?;
    let height = pgm_field(bytes, &mut pos, || "header height".into(), path)?;
    let maxval = pgm_field(bytes, &mut pos, || "header maxval".into(), path)?;
    if width == 0 || height == 0 {
        return Err(format_err(
            path,
            format!("PGM image is empty ({width}×{height} pixels)"),
        ));
    }
    if !(1..=255).contains(&maxval) {
        return Err(format_err(
            path,
            format!("PGM maxval {maxval} is not supported (8-bit images only: 1..=255)"),
        ));
    }
    let n = width.checked_mul(height).ok_or_else(|| {
        format_err(
            path,
            format!("garbled PGM header: {width}×{height} pixels is too large"),
        )
    })?;
    let scale = |v: usize| -> Result<u8, MapError> {
        if v > maxval {
            return Err(format_err(
                path,
                format!("PGM pixel value {v} exceeds maxval {maxval}"),
            ));
        }
        // Rescale to 0..=255, rounding to nearest; exact when maxval == 255.
        Ok(((v * 255 + maxval / 2) / maxval) as u8)
    };
    let mut gray = Vec::with_capacity(n.min(bytes.len()));
    if binary {
        // Exactly one whitespace byte separates maxval from the raster.
        match bytes.get(pos) {
            Some(b) if b.is_ascii_whitespace() => pos += 1,
            Some(_) => {
                return Err(format_err(
                    path,
                    "garbled PGM header: expected whitespace after maxval",
                ))
            }
            None => {
                return Err(format_err(
                    path,
                    format!("truncated PGM: no pixel data (expected {n} bytes)"),
                ))
            }
        }
        let data = &bytes[pos..];
        if data.len() < n {
            return Err(format_err(
                path,
                format!(
                    "truncated PGM: expected {n} pixel bytes for {width}×{height}, found {}",
                    data.len()
                ),
            ));
        }
        for &b in &data[..n] {
            gray.push(scale(b as usize)?);
        }
    } else {
        for i in 0..n {
            let v = pgm_field(
                bytes,
                &mut pos,
                || format!("pixel value #{} of {n}", i + 1),
                path,
            )?;
            gray.push(scale(v)?);
        }
    }
    Ok(Raster {
        width,
        height,
        gray,
        alpha: None,
    })
}

/// Encodes a grid as a binary P5 PGM (free 254, obstacle 0, unknown 205).
pub(super) fn encode_pgm(grid: &OccGrid) -> Vec<u8> {
    let mut out = format!(
        "P5\n# madenet occupancy grid: free 254, obstacle 0, unknown 205\n{} {}\n255\n",
        grid.width(),
        grid.height()
    )
    .into_bytes();
    out.extend(grid.cells().iter().map(|&c| pixel_of(c)));
    out
}

/// Writes `grid` as a bare binary P5 PGM (free 254, obstacle 0, unknown 205), atomically.
pub fn save_pgm(grid: &OccGrid, path: &Path) -> Result<(), MapError> {
    check_savable(grid, path)?;
    write_atomic(path, &encode_pgm(grid))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode(bytes: &[u8]) -> Result<Vec<u8>, String> {
        decode_pgm(bytes, Path::new("t.pgm"))
            .map(|r| r.gray)
            .map_err(|e| e.to_string())
    }

    /// The cases where `image`'s PNM decoder (0.25.10) gives another result: it decodes the
    /// first two and clamps the samples of the next two to 255, and its f32 rescaling gives
    /// 127 for sample 7 of maxval 14.
    #[test]
    fn cases_the_image_crate_decodes_differently() {
        for (bytes, error) in [
            (
                &b"P5\n1 1\n65535\n\x00\x00"[..],
                "maxval 65535 is not supported",
            ),
            (b"P2\n1 1\n300\n150\n", "maxval 300 is not supported"),
            (b"P2\n1 1\n1\n3\n", "pixel value 3 exceeds maxval 1"),
            (b"P5\n1 1\n100\n\xc8", "pixel value 200 exceeds maxval 100"),
        ] {
            let e = decode(bytes).unwrap_err();
            assert!(e.contains(error) && e.contains("t.pgm"), "{e}");
        }
        assert_eq!(decode(b"P5\n1 1\n14\n\x07"), Ok(vec![128]));
    }
}
