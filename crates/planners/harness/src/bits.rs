//! Map images at one bit per cell: replays keep them packed, 32× smaller than `f32`.
//!
//! ```
//! use madenet_harness::bits::{pack_bits, unpack_bits};
//!
//! let words = pack_bits(&[1, 0, 1]);
//! let mut image = [9.0; 3];
//! unpack_bits(&words, &mut image);
//! assert_eq!(image, [1.0, 0.0, 1.0]);
//! ```

/// Packs 0/1 bytes into bits (64 per word, LSB first): the replay keeps map images at one bit
/// per cell, 32× smaller than `f32`.
pub fn pack_bits(bytes: &[u8]) -> Vec<u64> {
    let mut words = vec![0u64; bytes.len().div_ceil(64)];
    for (i, &b) in bytes.iter().enumerate() {
        if b != 0 {
            words[i / 64] |= 1 << (i % 64);
        }
    }
    words
}

/// Writes the first `out.len()` bits of `words` into `out` as 0.0/1.0.
pub fn unpack_bits(words: &[u64], out: &mut [f32]) {
    for (i, o) in out.iter_mut().enumerate() {
        *o = ((words[i / 64] >> (i % 64)) & 1) as f32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bits_round_trip() {
        let bytes: Vec<u8> = (0..131).map(|i| ((i * 7 + i / 5) % 3 == 0) as u8).collect();
        let words = pack_bits(&bytes);
        assert_eq!(words.len(), 3);
        let mut out = vec![9.0; 131];
        unpack_bits(&words, &mut out);
        assert_eq!(out, bytes.iter().map(|&b| b as f32).collect::<Vec<_>>());
    }
}
