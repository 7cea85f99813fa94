//! `madenet compare`: the paper's comparison study in one command.

use anyhow::Result;
use clap::Args;
use madenet_sim::rollout::OracleKind;
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
    /// Discard earlier results in the output folder.
    #[arg(long)]
    fresh: bool,
    /// Methods, overriding the config (comma-separated policy names).
    #[arg(long, value_delimiter = ',')]
    methods: Option<Vec<String>>,
    /// Rollout oracles beside the methods, overriding the config (comma-separated: replay,
    /// averaged, noiseless, placebo, known-map, redrawn, plan-redrawn, plan-own-map,
    /// plan-team-map; `none` for none).
    #[arg(long, value_delimiter = ',', value_parser = parse_oracle)]
    oracles: Option<Vec<Option<OracleKind>>>,
    /// Seeds per trial, overriding the config.
    #[arg(long)]
    seeds: Option<u64>,
    /// Worker threads (default: all cores).
    #[arg(long, value_parser = crate::threads_arg)]
    threads: Option<usize>,
    /// Record the trials these conditions choose as ROS 2 bags in OUT/bags/ (after the
    /// study, re-run with their seeds: the same trials): `field=value` over method, map,
    /// start, csp, seed as trials.csv writes them, all met; `a|b` for either (quoted); e.g.
    /// `--record-trials method=spread seed=1`. A bag already there is kept, as the study
    /// keeps its rows (with --fresh: OUT/bags is made anew, replacing the old once every
    /// chosen trial is recorded).
    #[arg(long, num_args = 1.., value_name = "FIELD=VALUE")]
    record_trials: Option<Vec<String>>,
}

fn parse_oracle(s: &str) -> Result<Option<OracleKind>, String> {
    if s == "none" {
        return Ok(None);
    }
    OracleKind::ALL
        .into_iter()
        .find(|k| k.name() == s)
        .map(Some)
        .ok_or_else(|| {
            let names: Vec<&str> = OracleKind::ALL.iter().map(|k| k.name()).collect();
            format!("unknown oracle `{s}`; known: {}, none", names.join(", "))
        })
}

/// Names where a bad study field came from: the flag that set it, else the config file.
fn name_source(e: StudyError, a: &CompareArgs) -> anyhow::Error {
    name_study_source(
        e,
        a.config.as_deref(),
        &[
            ("methods", "--methods", a.methods.is_some()),
            ("oracles", "--oracles", a.oracles.is_some()),
            ("seeds", "--seeds", a.seeds.is_some()),
        ],
    )
}

/// Names where a bad study field came from: the flag that set it (`(field, flag, given)`), else
/// the config file, else nothing more (a default). Shared by `batch`, `compare` and `scale`.
pub fn name_study_source(
    e: StudyError,
    config: Option<&std::path::Path>,
    flags: &[(&str, &str, bool)],
) -> anyhow::Error {
    let StudyError::Field { field, message } = &e else {
        return e.into();
    };
    let flag = flags
        .iter()
        .find(|(f, _, given)| f == field && *given)
        .map(|(_, flag, _)| *flag);
    match (flag, config) {
        (Some(flag), _) => anyhow::anyhow!("{flag}: {message}"),
        (None, Some(path)) => anyhow::anyhow!("{}: {e}", path.display()),
        (None, None) => e.into(),
    }
}

pub fn run(a: CompareArgs) -> Result<()> {
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
    let recorded = match &a.record_trials {
        Some(items) => {
            let (registry, _, planned) =
                madenet_study::study_plan(&cfg).map_err(|e| name_source(e, &a))?;
            madenet_ros2::study_bags::chosen_trials(items, &planned)?;
            Some((items, registry, planned))
        }
        None => None,
    };
    let (bar, pool) = crate::trials_bar_and_pool(0, a.threads)?;
    // The folder stays this run's until the chosen trials are recorded too.
    let (report, outcomes, _lock) = pool
        .install(|| {
            run_study_held(&cfg, &a.out, a.fresh, &|done, total| {
                bar.set_length(total as u64);
                bar.set_position(done as u64);
            })
        })
        .map_err(|e| name_source(e, &a))?;
    bar.finish_and_clear();
    out!("{} trials → {}", outcomes.len(), report.display())?;
    if let Some((items, registry, planned)) = recorded {
        let chosen = madenet_ros2::study_bags::chosen_trials(items, &planned)?;
        crate::record::record_study_trials(&chosen, &registry, &a.out, a.fresh, &pool)?;
    } else if a.fresh {
        madenet_ros2::study_bags::discard_bags(&a.out)?;
    }
    Ok(())
}
