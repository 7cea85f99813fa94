//! ROS `map_server` YAML files: the input is the YAML, and whatever image it names reads as a
//! fixed valid PGM (one of the paper's maps): decoded by our PGM reader when the name ends in
//! `.pgm`, by the `image` crate's format guess otherwise. The cell size (1 m or 0.2 m, chosen by
//! the input's length) makes both finer and coarser resolutions reachable.
#![no_main]

use libfuzzer_sys::fuzz_target;
use madenet_map::io::{load_bytes, LoadOptions};
use std::path::Path;

const IMAGE: &[u8] = include_bytes!("../../maps/paper/test_1.pgm");

fuzz_target!(|data: &[u8]| {
    let cell_size = if data.len() % 2 == 0 { 1.0 } else { 0.2 };
    let opts = LoadOptions { cell_size, ..LoadOptions::default() };
    let _ = load_bytes(data, Path::new("fuzz/map.yaml"), &opts, |_| Ok(IMAGE.to_vec()));
});
