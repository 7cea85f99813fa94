//! A model folder's weight file (`dep0.bpk`, `actor0.bpk`; the input's first byte picks which
//! model's): any bytes under the shipped
//! `model.toml`s (their digests removed, so that the bytes reach the burnpack reader, the shape
//! check and the NaN/∞ check instead of stopping at the digest) must load or be refused with an
//! error — never a panic or an abort.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::sync::LazyLock;

fn without_digests(toml: &str) -> String {
    toml.lines()
        .filter(|l| !l.starts_with("digests"))
        .map(|l| format!("{l}\n"))
        .collect()
}

static GRID: LazyLock<String> =
    LazyLock::new(|| without_digests(include_str!("../../models/made-net/model.toml")));
static ANY: LazyLock<String> =
    LazyLock::new(|| without_digests(include_str!("../../models/made-net-any/model.toml")));
static DME: LazyLock<String> =
    LazyLock::new(|| without_digests(include_str!("../../models/dme-drl/model.toml")));
const ACTORS: [&[u8]; 2] = [
    include_bytes!("../../models/dme-drl/actor1.bpk"),
    include_bytes!("../../models/dme-drl/actor2.bpk"),
];

fuzz_target!(|data: &[u8]| {
    // The first byte picks the loader (one network per run keeps the rate up), the rest is
    // the weight file.
    let Some((&which, weights)) = data.split_first() else { return };
    match which % 3 {
        0 => drop(madenet_learn::Model::from_bytes(&GRID, &[weights], "fuzz/model.toml")),
        1 => drop(madenet_learn::Model::from_bytes(&ANY, &[weights], "fuzz/model.toml")),
        _ => drop(madenet_dme::model::Model::from_bytes(
            &DME,
            &[weights, ACTORS[0], ACTORS[1]],
            "fuzz/model.toml",
        )),
    }
});
