//! The image a `map_server` YAML names, with a fixed valid YAML beside it: the input is the
//! image file. Its name has no `.pgm` extension, so the format is guessed from the content
//! (PNG, GIF or PNM through the `image` crate), as for any image a user's YAML names. The YAML
//! (chosen by the input's length, so every input reaches one) covers the three modes, `negate`
//! and a resolution finer than the cell (discretization).
#![no_main]

use libfuzzer_sys::fuzz_target;
use madenet_map::io::{load_bytes, LoadOptions};
use std::path::Path;

const YAMLS: [&str; 3] = [
    "image: fuzz.img\nresolution: 1.0\norigin: [0.0, 0.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n",
    "image: fuzz.img\nmode: scale\nresolution: 0.25\norigin: [1.0, -2.0, 0.5]\nnegate: 1\noccupied_thresh: 0.65\nfree_thresh: 0.196\n",
    "image: fuzz.img\nmode: raw\nresolution: 0.5\norigin: [0.0, 0.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.25\n",
];

fuzz_target!(|data: &[u8]| {
    let yaml = YAMLS[data.len() % YAMLS.len()];
    let image = |p: &Path| {
        assert_eq!(p, Path::new("fuzz/fuzz.img"), "the image is resolved against the YAML's folder");
        Ok(data.to_vec())
    };
    let _ = load_bytes(yaml.as_bytes(), Path::new("fuzz/map.yaml"), &LoadOptions::default(), image);
});
