//! The shipped DME-DRL model (`models/dme-drl/`), compiled into the binary so that
//! `madenet run --policy dme-drl` and `madenet compare` work from any directory. How it was
//! trained (config, command, wall time, validation) is in `models/README.md`.

use crate::model::Model;
use madenet_harness::TrainError;
use madenet_sim::PolicyRegistry;

/// The policy name of the shipped model.
pub const NAME: &str = "dme-drl";
const ABOUT: &str = "DME-DRL (shipped model): MADDPG actors choosing a frontier sector, heading to its nearest frontier cell";
const MODEL_TOML: &str = include_str!("../../../../models/dme-drl/model.toml");
const ACTORS: [&[u8]; 3] = [
    include_bytes!("../../../../models/dme-drl/actor0.bpk"),
    include_bytes!("../../../../models/dme-drl/actor1.bpk"),
    include_bytes!("../../../../models/dme-drl/actor2.bpk"),
];

/// Loads the shipped model.
pub fn model() -> Result<Model, TrainError> {
    Model::from_bytes(MODEL_TOML, &ACTORS, "models/dme-drl/model.toml")
}

/// Registers the shipped model as policy `dme-drl`, loaded when a trial first asks for it.
pub fn register(registry: &mut PolicyRegistry) {
    registry.register_lazy(
        NAME,
        ABOUT,
        || model().map_err(|e| e.to_string()),
        |m: &Model, ctx| m.check(ctx.height, ctx.width, ctx.config),
        |m, ctx| m.policy(NAME, ctx.robot),
    );
}
