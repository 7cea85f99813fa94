//! `madenet batch`: many trials in parallel, one CSV row each — a trial set planned and run by
//! the study runner ([`madenet_study::runner`]), written in its `trials.csv` schema.

use anyhow::{bail, Context, Result};
use clap::Args;
use madenet_map::paper::Corner;
use madenet_sim::PolicyRegistry;
use madenet_study::runner::{self, Planned, TrialOutcome};
use madenet_study::StudyConfig;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct BatchArgs {
    /// Maps (comma-separated): `paper` for all 10 paper maps, `paper:N`, `generate:SEED`, `generate-wide:SEED`, `floorplan:SEED`, or files.
    #[arg(long, value_delimiter = ',', default_value = "paper")]
    maps: Vec<String>,
    /// Starts (comma-separated): `all` for the four corners, corner names, or `random`.
    #[arg(long, value_delimiter = ',', default_value = "all")]
    starts: Vec<String>,
    /// Policy name.
    #[arg(long, default_value = "nf")]
    policy: String,
    /// A trained model directory (`madenet train`'s `best/` or `last/`), usable as `--policy model`.
    #[arg(long, value_name = "DIR")]
    model: Option<std::path::PathBuf>,
    /// Communication success probabilities (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "1.0")]
    csp: Vec<f64>,
    /// Seeds per (map, start, CSP): `seed-base`, `seed-base + 1`, …
    #[arg(long, default_value_t = 1)]
    seeds: u64,
    #[arg(long, default_value_t = 1)]
    seed_base: u64,
    /// Scenario config (TOML).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Output CSV (written atomically), in the schema of `madenet compare`'s `trials.csv`.
    #[arg(long, default_value = "batch.csv")]
    out: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long, value_parser = crate::threads_arg)]
    threads: Option<usize>,
}

pub fn run(a: BatchArgs) -> Result<()> {
    if a.model.is_some() && a.policy != "model" {
        bail!(
            "--model is used only with --policy model (got --policy {})",
            a.policy
        );
    }
    let registry = crate::registry(a.model.as_deref())?;
    let mut cfg = trial_set(
        &a.maps,
        &a.starts,
        &a.csp,
        a.seeds,
        a.seed_base,
        a.config.as_deref(),
    )?;
    cfg.methods = vec![a.policy.clone()];
    let flag = format!("--policy {}", a.policy);
    let planned = plan(&cfg, &registry, a.config.as_deref(), &flag)?;
    let started = std::time::Instant::now();
    let outcomes = run_planned(&planned, &registry, a.threads)?;
    let elapsed = started.elapsed();
    let rows: Vec<&TrialOutcome> = outcomes.iter().collect();
    madenet_files::write_atomic(&a.out, &runner::trials_csv(&rows))
        .with_context(|| format!("--out {}", a.out.display()))?;
    out!(
        "{} trials in {:.2} s → {}",
        outcomes.len(),
        elapsed.as_secs_f64(),
        a.out.display()
    )?;
    for &csp in &a.csp {
        let sel: Vec<&runner::TrialRow> = outcomes
            .iter()
            .map(|o| &o.row)
            .filter(|r| r.key.csp == runner::csp_label(csp))
            .collect();
        let n = sel.len().max(1) as f64;
        let mean = |f: &dyn Fn(&runner::TrialRow) -> f64| sel.iter().map(|r| f(r)).sum::<f64>() / n;
        out!(
            "csp {csp:.2}: completed {}/{}  TNS {:.1}  TTD {:.1} m  NOLI {:.1}  OFV {:.2}",
            sel.iter().filter(|r| r.completed).count(),
            sel.len(),
            mean(&|r| r.tns as f64),
            mean(&|r| r.ttd),
            mean(&|r| r.noli as f64),
            mean(&|r| r.ofv),
        )?;
    }
    Ok(())
}

/// The trial set the flags of `batch` and `oracle` describe, as a study config with no methods
/// and no oracles yet: `--starts all` is the four corners, `--config` the scenario.
pub fn trial_set(
    maps: &[String],
    starts: &[String],
    csp: &[f64],
    seeds: u64,
    seed_base: u64,
    config: Option<&Path>,
) -> Result<StudyConfig> {
    let mut corners = Vec::new();
    for s in starts {
        if s == "all" {
            corners.extend(Corner::ALL.iter().map(|c| c.name().to_string()));
        } else {
            corners.push(s.clone());
        }
    }
    Ok(StudyConfig {
        methods: Vec::new(),
        maps: maps.to_vec(),
        starts: corners,
        csp: csp.to_vec(),
        seeds,
        seed_base,
        scenario: crate::load_config(config)?,
        oracles: Vec::new(),
        ..StudyConfig::default()
    })
}

/// Checks `cfg` (a bad field named by its flag; `policy_flag` for the policy) and plans its
/// trials with the study runner, in its order: methods, then oracles; maps, starts, CSPs, seeds.
pub fn plan(
    cfg: &StudyConfig,
    registry: &PolicyRegistry,
    config: Option<&Path>,
    policy_flag: &str,
) -> Result<Vec<Planned>> {
    let (maps, starts) = cfg.validate(registry).map_err(|e| {
        crate::compare::name_study_source(
            e,
            config,
            &[
                ("methods", policy_flag, true),
                ("oracle_base", policy_flag, true),
                ("oracle_futures", "--futures", true),
                ("oracle_lookahead.horizon", "--horizon", true),
                ("maps", "--maps", true),
                ("starts", "--starts", true),
                ("csp", "--csp", true),
                ("seeds", "--seeds", true),
                ("seed_base", "--seed-base", true),
            ],
        )
    })?;
    let planned = runner::plan(cfg, &maps, &starts);
    runner::check_planned(&planned, registry)?;
    Ok(planned)
}

/// Runs `planned` with a progress bar on `threads` workers; outcomes in plan order.
pub fn run_planned(
    planned: &[Planned],
    registry: &PolicyRegistry,
    threads: Option<usize>,
) -> Result<Vec<TrialOutcome>> {
    let (bar, pool) = crate::trials_bar_and_pool(planned.len() as u64, threads)?;
    let all: Vec<&Planned> = planned.iter().collect();
    let outcomes = pool.install(|| {
        runner::run_all(&all, registry, &|_| {
            bar.inc(1);
            Ok(())
        })
    });
    bar.finish_and_clear();
    Ok(outcomes?)
}
