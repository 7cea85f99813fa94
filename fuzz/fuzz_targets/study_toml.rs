//! Study TOML (`madenet compare --config`): `StudyConfig::from_toml_file` (the input is written
//! to a temporary file first: its error messages are part of what is tested), then
//! `StudyConfig::validate` with the registry the study builds, which loads the maps and checks
//! every method on them. Map entries that name files or folders are dropped before validation
//! so the fuzzer never reads the machine's files (map files have their own targets); the
//! embedded `paper` maps and the seeded `generate:` and `floorplan:` maps stay.
#![no_main]

use libfuzzer_sys::fuzz_target;
use madenet_sim::PolicyRegistry;
use madenet_study::StudyConfig;
use std::path::PathBuf;
use std::sync::LazyLock;

/// The study's registry without its baselines (`ub`, `pb`), which each config registers with its
/// own parameters. Loading the shipped models is the costly part, so it is done once.
static REGISTRY: LazyLock<PolicyRegistry> =
    LazyLock::new(|| StudyConfig::default().registry().expect("the shipped models load"));

static INPUT: LazyLock<PathBuf> =
    LazyLock::new(|| std::env::temp_dir().join(format!("madenet-fuzz-study-{}.toml", std::process::id())));

fuzz_target!(|data: &[u8]| {
    std::fs::write(&*INPUT, data).expect("write the fuzz input");
    let Ok(mut cfg) = StudyConfig::from_toml_file(&INPUT) else { return };
    cfg.maps.retain(|m| {
        m == "paper"
            || m.starts_with("paper:")
            || m.starts_with("generate:")
            || m.starts_with("generate-wide:")
            || m.starts_with("floorplan:")
    });
    // `StudyConfig::registry` is the shared part plus the baselines at this config's parameters.
    let mut registry = REGISTRY.clone();
    madenet_baselines::register(&mut registry, &cfg.baselines);
    let _ = cfg.validate(&registry);
});
