//! The trained models shipped in the repository (`models/`), compiled into the binary so that
//! `madenet run --policy made-net` and `madenet compare` work from any directory. How each was
//! trained (config, command, wall time, validation) is in `models/README.md`.

use crate::error::TrainError;
use crate::model::Model;
use madenet_sim::PolicyRegistry;

/// (policy name, description, model.toml, DEP weights).
const SHIPPED: [(&str, &str, &str, &[u8]); 4] = [
    (
        "made-net",
        "MADE-Net (shipped model): the size- and team-agnostic DEP trained on 20 x 20 maps with 3 robots from the team-plan teacher (the known-map reference planning on redrawn maps), decentralized execution",
        include_str!("../../../../models/made-net/model.toml"),
        include_bytes!("../../../../models/made-net/dep0.bpk"),
    ),
    (
        "made-net-paper",
        "MADE-Net by the paper's procedure (shipped model): DEP trained with the CEP (Eq. 5/6), decentralized execution",
        include_str!("../../../../models/made-net-paper/model.toml"),
        include_bytes!("../../../../models/made-net-paper/dep0.bpk"),
    ),
    (
        "made-net-dt",
        "MADE-Net-DT (shipped model): DEP trained on decentralized experience alone",
        include_str!("../../../../models/made-net-dt/model.toml"),
        include_bytes!("../../../../models/made-net-dt/dep0.bpk"),
    ),
    (
        "made-net-any",
        "MADE-Net for any map size and team (shipped model): the size- and team-agnostic DEP, rollout teacher on a curriculum of sides 20-60 and teams 2-6",
        include_str!("../../../../models/made-net-any/model.toml"),
        include_bytes!("../../../../models/made-net-any/dep0.bpk"),
    ),
];

/// Names of the shipped models.
pub fn names() -> Vec<&'static str> {
    SHIPPED.iter().map(|s| s.0).collect()
}

/// Loads shipped model `name`.
pub fn model(name: &str) -> Result<Model, TrainError> {
    let (_, _, toml, weights) = SHIPPED.iter().find(|s| s.0 == name).ok_or_else(|| {
        TrainError::Other(format!(
            "no shipped model `{name}`; shipped: {}",
            names().join(", ")
        ))
    })?;
    Model::from_bytes(toml, &[weights], &format!("models/{name}/model.toml"))
}

/// Registers every shipped model under its name; each is loaded when a trial first asks for
/// it (a process that plays none loads none).
pub fn register(registry: &mut PolicyRegistry) {
    for (name, about, _, _) in SHIPPED {
        registry.register_lazy(
            name,
            about,
            move || model(name).map_err(|e| e.to_string()),
            |m: &Model, ctx| m.check(ctx.height, ctx.width, ctx.config),
            move |m, ctx| m.policy(name, ctx.robot),
        );
    }
}
