//! A model folder's `model.toml` (`madenet run --policy model --model DIR`), read with the
//! shipped weights beside it: MADE-Net's grid DEP, the agnostic DEP and DME-DRL's actors. Any
//! text must load or be refused with an error — never a panic, an abort or an allocation past the
//! fuzzer's RSS limit (sizes are checked before a network is built, weights against the sizes).
#![no_main]

use libfuzzer_sys::fuzz_target;

const GRID: &[u8] = include_bytes!("../../models/made-net/dep0.bpk");
const ANY: &[u8] = include_bytes!("../../models/made-net-any/dep0.bpk");
const DME: [&[u8]; 3] = [
    include_bytes!("../../models/dme-drl/actor0.bpk"),
    include_bytes!("../../models/dme-drl/actor1.bpk"),
    include_bytes!("../../models/dme-drl/actor2.bpk"),
];

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let _ = madenet_learn::Model::from_bytes(text, &[GRID], "fuzz/model.toml");
    let _ = madenet_learn::Model::from_bytes(text, &[ANY], "fuzz/model.toml");
    let _ = madenet_dme::model::Model::from_bytes(text, &DME, "fuzz/model.toml");
});
