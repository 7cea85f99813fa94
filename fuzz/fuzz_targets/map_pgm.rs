//! Bare PGM images (binary P5 and ASCII P2) through `madenet_map::io::load_bytes`, read at
//! 1 m/pixel into 1 m cells (pixel by pixel) and into 2 m cells (discretized 2 × 2 blocks).
#![no_main]

use libfuzzer_sys::fuzz_target;
use madenet_map::io::{load_bytes, LoadOptions};
use madenet_map::MapError;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    for cell_size in [1.0, 2.0] {
        let opts = LoadOptions { cell_size, ..LoadOptions::default() };
        let no_image = |_: &Path| -> Result<Vec<u8>, MapError> { unreachable!("a PGM names no image") };
        let _ = load_bytes(data, Path::new("fuzz.pgm"), &opts, no_image);
    }
});
