//! `madenet scale`: the scalability study (the paper's Sec. V.B, Fig. 7) in one command.

use anyhow::Result;
use clap::Args;
use madenet_study::{run_scale_held, ScaleConfig, ScaleWorld, StudyError};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct ScaleArgs {
    /// Scalability config (TOML, see configs/scale.toml); defaults: made-net, made-net-any, nf, ub, pb,
    /// spread × sides 20, 30, 40, 60 × 4 maps × starts bottom-left, top-right, middle × teams
    /// 2–6 × 3 seeds at CSP 1.
    #[arg(long)]
    config: Option<PathBuf>,
    /// The world the trials run in: `grid`, or `continuous` (the paper's own protocol:
    /// differential-drive robots, lidar maps, a local planner, ET in seconds; without
    /// --config its defaults are `ScaleConfig::continuous_default`: made-net, made-net-any, nf, ub,
    /// spread on one generated cluttered scene per side). Overrides the config's `world`.
    #[arg(long, value_parser = ["grid", "continuous"])]
    world: Option<String>,
    /// Output folder (created; an interrupted study there resumes).
    #[arg(long, default_value = "scale")]
    out: PathBuf,
    /// Methods, overriding the config (comma-separated policy names; the first is judged
    /// against the others). `model` is the model given with --model.
    #[arg(long, value_delimiter = ',')]
    methods: Option<Vec<String>>,
    /// Map sides, overriding the config (comma-separated).
    #[arg(long, value_delimiter = ',')]
    sides: Option<Vec<usize>>,
    /// Team sizes, overriding the config (comma-separated).
    #[arg(long, value_delimiter = ',')]
    teams: Option<Vec<usize>>,
    /// Seeds per trial, overriding the config.
    #[arg(long)]
    seeds: Option<u64>,
    /// Communication success probability of every trial, overriding the config (one value: a
    /// study per CSP, each in its own --out folder).
    #[arg(long)]
    csp: Option<f64>,
    /// A trained model directory, usable as method `model`.
    #[arg(long)]
    model: Option<PathBuf>,
    #[command(flatten)]
    study: crate::scenario_args::StudyRunArgs,
}

/// Names where a bad field came from: the flag that set it, else the config file.
fn name_source(e: StudyError, a: &ScaleArgs) -> StudyError {
    e.named_by(
        a.config.as_deref(),
        &[
            ("methods", "--methods", a.methods.is_some()),
            ("sides", "--sides", a.sides.is_some()),
            ("teams", "--teams", a.teams.is_some()),
            ("seeds", "--seeds", a.seeds.is_some()),
            ("csp", "--csp", a.csp.is_some()),
        ],
    )
}

pub fn run(a: ScaleArgs) -> Result<()> {
    // The study saves its config in --out: never over the user's own file.
    let saved = a.out.join("scale.toml");
    let config: Vec<_> = crate::clashes::given("--config", a.config.as_ref());
    crate::clashes::refuse_clashes(&[("--out", saved)], &config)?;
    let mut cfg = match (&a.config, a.world.as_deref()) {
        (Some(p), _) => ScaleConfig::from_toml_file(p)?,
        (None, Some("continuous")) => ScaleConfig::continuous_default(),
        (None, _) => ScaleConfig::default(),
    };
    match a.world.as_deref() {
        Some("continuous") => cfg.world = ScaleWorld::Continuous,
        Some(_) => cfg.world = ScaleWorld::Grid,
        None => {}
    }
    if let Some(m) = &a.methods {
        cfg.methods = m.clone();
    }
    if let Some(s) = &a.sides {
        cfg.sides = s.clone();
    }
    if let Some(t) = &a.teams {
        cfg.teams = t.clone();
    }
    if let Some(s) = a.seeds {
        cfg.seeds = s;
    }
    if let Some(c) = a.csp {
        cfg.csp = c;
    }
    // The config's own `[baselines]` parameters (ub, pb), as `madenet compare` uses its own.
    let registry = madenet_catalogue::with_model(&cfg.baselines, a.model.as_deref())?;
    // The trials to record, checked before the study runs.
    let planned = match &a.study.record_trials {
        Some(items) => {
            cfg.validate(&registry).map_err(|e| name_source(e, &a))?;
            let planned: Vec<_> = cfg
                .plan()
                .map_err(|e| name_source(e, &a))?
                .into_iter()
                .map(|p| p.planned)
                .collect();
            madenet_ros2::study_bags::chosen_trials(items, &planned)?;
            Some(planned)
        }
        None => None,
    };
    // The folder stays this run's until the chosen trials are recorded too.
    let (held, pool) = a
        .study
        .run(|fresh, progress| run_scale_held(&cfg, &registry, &a.out, fresh, progress))?;
    let (result, _lock) = held.map_err(|e| name_source(e, &a))?;
    out!("{} trials → {}", result.trials, result.report.display())?;
    let planned = planned.as_deref().map(|p| (p, &registry));
    a.study.record(planned, &a.out, &pool)?;
    Ok(())
}
