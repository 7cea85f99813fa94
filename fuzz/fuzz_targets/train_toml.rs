//! Training TOML (`madenet train --config`): the `method` key read first to choose the learner,
//! then each learner's `from_toml_file` (parse + validate: `TrainConfig` for MADE-Net and
//! MADE-Net-DT, `RolloutTrainConfig`, `DmeTrainConfig`). The input is written to a temporary
//! file first, since the error messages are built from the file's text. A config that validates
//! must write back to TOML that reads as the same config (a run saves it and `--resume` reads
//! it), and the network sizes training derives from it must be computable.
#![no_main]

use libfuzzer_sys::fuzz_target;
use madenet_dme::train::DmeTrainConfig;
use madenet_learn::dagger::RolloutTrainConfig;
use madenet_learn::TrainConfig;
use std::path::PathBuf;
use std::sync::LazyLock;

static INPUT: LazyLock<PathBuf> =
    LazyLock::new(|| std::env::temp_dir().join(format!("madenet-fuzz-train-{}.toml", std::process::id())));

/// Asserts that `cfg` survives a TOML round trip through `read` (the learner's `from_toml_str`
/// equivalent: parse and validate).
fn round_trips<T: serde::Serialize + PartialEq + std::fmt::Debug>(
    cfg: &T,
    read: impl Fn(&str) -> Result<T, String>,
) {
    let saved = toml::to_string(cfg).expect("a validated config serializes");
    let again = read(&saved).unwrap_or_else(|e| panic!("a saved config reads back: {e}\n{saved}"));
    assert_eq!(&again, cfg, "saved as:\n{saved}");
}

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        // What `madenet train` does first: the `method` key of the file as a table.
        let _ = toml::from_str::<toml::Table>(text).map(|t| t.get("method").and_then(|m| m.as_str()).map(str::to_string));
    }
    std::fs::write(&*INPUT, data).expect("write the fuzz input");

    if let Ok(cfg) = TrainConfig::from_toml_file(&INPUT) {
        round_trips(&cfg, |s| {
            let c: TrainConfig = toml::from_str(s).map_err(|e| e.to_string())?;
            c.validate().map(|()| c)
        });
        let _ = cfg.goals();
        cfg.cep_config().validate().expect("a validated training config has a valid CEP");
        cfg.dep_config().validate().expect("a validated training config has a valid DEP");
    }
    if let Ok(cfg) = RolloutTrainConfig::from_toml_file(&INPUT) {
        round_trips(&cfg, |s| {
            let c: RolloutTrainConfig = toml::from_str(s).map_err(|e| e.to_string())?;
            c.validate().map(|()| c)
        });
    }
    if let Ok(cfg) = DmeTrainConfig::from_toml_file(&INPUT) {
        round_trips(&cfg, |s| {
            let c: DmeTrainConfig = toml::from_str(s).map_err(|e| e.to_string())?;
            c.validate().map(|()| c)
        });
        let _ = cfg.nets();
    }
});
