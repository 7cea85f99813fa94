//! `madenet compare`: the paper's comparison study in one command.

use anyhow::Result;
use clap::Args;
use madenet_baselines::rollout::OracleKind;
use madenet_study::{run_study_held, StudyConfig, StudyError};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct CompareArgs {
    /// Study config (TOML, see configs/study.toml); defaults: every shipped method, the placebo
    /// and noiseless oracles over spread × the 10 paper maps × 4 corners × CSP {0, 0.5, 0.8, 1}
    /// × 5 seeds.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Output folder (created; an interrupted study there resumes).
    #[arg(long, default_value = "study")]
    out: PathBuf,
    /// Methods, overriding the config (comma-separated policy names).
    #[arg(long, value_delimiter = ',')]
    methods: Option<Vec<String>>,
    /// Rollout oracles beside the methods, overriding the config (comma-separated: replay,
    /// averaged, noiseless, placebo, known-map, redrawn, plan-redrawn, plan-own-map,
    /// plan-team-map; `none` for none).
    #[arg(long, value_delimiter = ',', value_parser = madenet_baselines::rollout::OracleKind::parse_or_none)]
    oracles: Option<Vec<Option<OracleKind>>>,
    /// Seeds per trial, overriding the config.
    #[arg(long)]
    seeds: Option<u64>,
    #[command(flatten)]
    study: crate::scenario_args::StudyRunArgs,
}

/// Names where a bad study field came from: the flag that set it, else the config file.
fn name_source(e: StudyError, a: &CompareArgs) -> StudyError {
    e.named_by(
        a.config.as_deref(),
        &[
            ("methods", "--methods", a.methods.is_some()),
            ("oracles", "--oracles", a.oracles.is_some()),
            ("seeds", "--seeds", a.seeds.is_some()),
        ],
    )
}

pub fn run(a: CompareArgs) -> Result<()> {
    // The study saves its config in --out: never over the user's own file.
    let saved = a.out.join("study.toml");
    let config: Vec<_> = crate::clashes::given("--config", a.config.as_ref());
    crate::clashes::refuse_clashes(&[("--out", saved)], &config)?;
    let mut cfg = match &a.config {
        Some(p) => StudyConfig::from_toml_file(p)?,
        None => StudyConfig::default(),
    };
    if let Some(m) = &a.methods {
        cfg.methods = m.clone();
    }
    if let Some(o) = &a.oracles {
        if o.len() > 1 && o.contains(&None) {
            anyhow::bail!("--oracles: `none` stands alone (got {} names)", o.len());
        }
        cfg.oracles = o.iter().flatten().copied().collect();
    }
    if let Some(s) = a.seeds {
        cfg.seeds = s;
    }
    // The trials to record, checked before the study runs.
    let recorded = match &a.study.record_trials {
        Some(items) => {
            let (registry, _, planned) =
                madenet_study::study_plan(&cfg).map_err(|e| name_source(e, &a))?;
            madenet_ros2::study_bags::chosen_trials(items, &planned)?;
            Some((registry, planned))
        }
        None => None,
    };
    // The folder stays this run's until the chosen trials are recorded too.
    let (held, pool) = a
        .study
        .run(|fresh, progress| run_study_held(&cfg, &a.out, fresh, progress))?;
    let (report, outcomes, _lock) = held.map_err(|e| name_source(e, &a))?;
    out!("{} trials → {}", outcomes.len(), report.display())?;
    let recorded = recorded.as_ref().map(|(r, p)| (p.as_slice(), r));
    a.study.record(recorded, &a.out, &pool)?;
    Ok(())
}
