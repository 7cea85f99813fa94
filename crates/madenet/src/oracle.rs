//! `madenet oracle`: the rollout oracle (and its placebo) beside the base rule on a trial set —
//! the ceiling a candidate rule or a learned policy is judged against
//! ([`madenet_sim::rollout`]).

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use madenet_sim::rollout::{check_base, run_oracle, OracleKind};
use madenet_sim::{Trial, TrialResult};
use rayon::prelude::*;
use std::path::PathBuf;

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Kind {
    /// Each candidate scored in the trial's own future (knows the map and the noise to come).
    Replay,
    /// Each candidate scored over --futures other futures (knows the map, not the noise).
    Averaged,
    /// The base rule's choice, in the best of --futures futures: luck alone.
    Placebo,
    /// Each candidate scored in the noiseless future (knows the map; no luck).
    Noiseless,
}

#[derive(Args, Debug)]
pub struct OracleArgs {
    /// Maps (comma-separated): `paper`, `paper:N`, `generate:SEED`, `generate-wide:SEED`, or files.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "generate:1,generate:2,generate:3,generate:4,generate:5"
    )]
    maps: Vec<String>,
    /// Starts (comma-separated): `all` for the four corners, corner names, or `random`.
    #[arg(long, value_delimiter = ',', default_value = "all")]
    starts: Vec<String>,
    /// The base rule the oracle's continuations follow (and the trial runs by): a macro policy.
    #[arg(long, default_value = "spread")]
    base: String,
    /// Which oracle.
    #[arg(long, value_enum, default_value = "replay")]
    kind: Kind,
    /// Futures per candidate (averaged) or to choose from (placebo); 1–64.
    #[arg(long, default_value_t = 4)]
    futures: usize,
    /// Communication success probabilities (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "1.0,0.0")]
    csp: Vec<f64>,
    /// Seeds per (map, start, CSP).
    #[arg(long, default_value_t = 1)]
    seeds: u64,
    #[arg(long, default_value_t = 1)]
    seed_base: u64,
    /// Scenario config (TOML).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Also write the oracle's trials as CSV (the schema of `madenet batch`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long, value_parser = crate::threads_arg)]
    threads: Option<usize>,
}

pub fn run(a: OracleArgs) -> Result<()> {
    if !(1..=64).contains(&a.futures) {
        bail!("--futures {}: must be in 1..=64", a.futures);
    }
    let registry = crate::registry(None)?;
    if !registry.names().contains(&a.base) {
        bail!(
            "unknown policy `{}` (field `--base`); known policies: {}",
            a.base,
            registry.names().join(", ")
        );
    }
    let specs = crate::batch::plan(
        &a.maps,
        &a.starts,
        &a.csp,
        a.seeds,
        a.seed_base,
        a.config.as_deref(),
        &a.base,
    )?;
    if let Some((_, s)) = specs.first() {
        check_base(s, &registry).map_err(|e| anyhow::anyhow!("--base {}: {e}", a.base))?;
    }
    let kind = match a.kind {
        Kind::Replay => OracleKind::Replay,
        Kind::Averaged => OracleKind::Averaged,
        Kind::Placebo => OracleKind::Placebo,
        Kind::Noiseless => OracleKind::Noiseless,
    };
    let (bar, pool) = crate::trials_bar_and_pool(specs.len() as u64, a.threads)?;
    let started = std::time::Instant::now();
    let results: Vec<Result<(String, TrialResult, TrialResult)>> = pool.install(|| {
        specs
            .into_par_iter()
            .map(|(start, spec)| {
                let label = format!("map {}, start {start}", spec.map_name);
                let base = Trial::with_registry(spec.clone(), &registry)
                    .with_context(|| label.clone())?
                    .timed(false)
                    .run();
                let mut oracle =
                    run_oracle(spec, &registry, kind, a.futures).with_context(|| label)?;
                oracle.policy = format!(
                    "oracle-{}({})",
                    format!("{:?}", a.kind).to_lowercase(),
                    a.base
                );
                bar.inc(1);
                Ok((start, base, oracle))
            })
            .collect()
    });
    bar.finish_and_clear();
    let results: Vec<(String, TrialResult, TrialResult)> =
        results.into_iter().collect::<Result<_>>()?;
    if let Some(path) = &a.out {
        let rows: Vec<(String, TrialResult)> = results
            .iter()
            .map(|(s, _, o)| (s.clone(), o.clone()))
            .collect();
        crate::batch::write_csv(path, &rows)?;
    }
    let futures = match a.kind {
        Kind::Averaged | Kind::Placebo => format!(" ({} futures)", a.futures),
        Kind::Replay | Kind::Noiseless => String::new(),
    };
    out!(
        "{} trials in {:.1} s; oracle {:?} over base `{}`{futures}",
        results.len(),
        started.elapsed().as_secs_f64(),
        a.kind,
        a.base
    )?;
    for &csp in &a.csp {
        let sel: Vec<&(String, TrialResult, TrialResult)> = results
            .iter()
            .filter(|r| r.1.comm_success_prob == csp)
            .collect();
        let n = sel.len().max(1) as f64;
        let base: f64 = sel.iter().map(|r| r.1.metrics.tns as f64).sum::<f64>() / n;
        let oracle: f64 = sel.iter().map(|r| r.2.metrics.tns as f64).sum::<f64>() / n;
        let wins = sel
            .iter()
            .filter(|r| r.2.metrics.tns < r.1.metrics.tns)
            .count();
        let losses = sel
            .iter()
            .filter(|r| r.2.metrics.tns > r.1.metrics.tns)
            .count();
        out!("csp {csp:.2}: base TNS {base:.1}  oracle TNS {oracle:.1}  ({:+.1} %)  oracle better on {wins}, worse on {losses} of {}", 100.0 * (oracle / base - 1.0), sel.len())?;
    }
    Ok(())
}
