//! Bare PNG images through `madenet_map::io::load_bytes` (the `image` crate's PNG decoder,
//! then conversion to luma + alpha and classification at 1 m/pixel).
#![no_main]

use libfuzzer_sys::fuzz_target;
use madenet_map::io::{load_bytes, LoadOptions};
use madenet_map::MapError;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let no_image = |_: &Path| -> Result<Vec<u8>, MapError> { unreachable!("a PNG names no image") };
    let _ = load_bytes(data, Path::new("fuzz.png"), &LoadOptions::default(), no_image);
});
