//! Text grids (`.txt` / `.map`: `#`, `.`, `?` rows) through `madenet_map::io::load_bytes`, the
//! entry point `load` reads every map file through.
#![no_main]

use libfuzzer_sys::fuzz_target;
use madenet_map::io::{load_bytes, parse_text, to_text, LoadOptions};
use madenet_map::MapError;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let no_image = |_: &Path| -> Result<Vec<u8>, MapError> { unreachable!("a text grid names no image") };
    if let Ok(grid) = load_bytes(data, Path::new("fuzz.txt"), &LoadOptions::default(), no_image) {
        // What `save_text` writes for a grid that was read must read back as the same grid.
        let again = parse_text(&to_text(&grid), Path::new("again.txt")).expect("to_text output parses");
        assert_eq!(again, grid);
    }
});
