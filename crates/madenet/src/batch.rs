//! `madenet batch`: many trials in parallel, one CSV row each.

use anyhow::{bail, Context, Result};
use clap::Args;
use madenet_map::paper::{Corner, PAPER_MAP_COUNT};
use madenet_metrics::COVERAGE_LEVELS;
use madenet_sim::{MapSource, StartSpec, Trial, TrialResult, TrialSpec};
use rayon::prelude::*;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct BatchArgs {
    /// Maps (comma-separated): `paper` for all 10 paper maps, `paper:N`, `generate:SEED`, `generate-wide:SEED`, or files.
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
    /// Output CSV (written atomically).
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
    if !registry.names().contains(&a.policy) {
        bail!(
            "unknown policy `{}` (field `--policy`); known policies: {}",
            a.policy,
            registry.names().join(", ")
        );
    }
    let specs = plan(
        &a.maps,
        &a.starts,
        &a.csp,
        a.seeds,
        a.seed_base,
        a.config.as_deref(),
        &a.policy,
    )?;
    let (bar, pool) = crate::trials_bar_and_pool(specs.len() as u64, a.threads)?;
    let started = std::time::Instant::now();
    let results: Vec<Result<(String, TrialResult)>> = pool.install(|| {
        specs
            .into_par_iter()
            .map(|(start, spec)| {
                let label = format!("map {}, start {start}", spec.map_name);
                let r = Trial::with_registry(spec, &registry)
                    .with_context(|| label)?
                    .run();
                bar.inc(1);
                Ok((start, r))
            })
            .collect()
    });
    bar.finish_and_clear();
    let elapsed = started.elapsed();
    let results: Vec<(String, TrialResult)> = results.into_iter().collect::<Result<_>>()?;
    write_csv(&a.out, &results)?;
    out!(
        "{} trials in {:.2} s → {}",
        results.len(),
        elapsed.as_secs_f64(),
        a.out.display()
    )?;
    for &csp in &a.csp {
        let sel: Vec<&TrialResult> = results
            .iter()
            .map(|(_, r)| r)
            .filter(|r| r.comm_success_prob == csp)
            .collect();
        let n = sel.len().max(1) as f64;
        let mean = |f: &dyn Fn(&TrialResult) -> f64| sel.iter().map(|r| f(r)).sum::<f64>() / n;
        out!(
            "csp {csp:.2}: completed {}/{}  TNS {:.1}  TTD {:.1} m  NOLI {:.1}  OFV {:.2}",
            sel.iter().filter(|r| r.metrics.completed).count(),
            sel.len(),
            mean(&|r| r.metrics.tns as f64),
            mean(&|r| r.metrics.ttd),
            mean(&|r| r.metrics.noli as f64),
            mean(&|r| r.metrics.ofv),
        )?;
    }
    Ok(())
}

/// The trials of a trial set: every map × start × CSP × seed, with its start's name.
pub fn plan(
    maps_arg: &[String],
    starts_arg: &[String],
    csps: &[f64],
    seeds: u64,
    seed_base: u64,
    config: Option<&std::path::Path>,
    policy: &str,
) -> Result<Vec<(String, TrialSpec)>> {
    if seeds == 0 {
        bail!("--seeds 0: need at least one seed");
    }
    let base = crate::load_config(config)?;
    let mut maps = Vec::new();
    for m in maps_arg {
        if m == "paper" {
            maps.extend((1..=PAPER_MAP_COUNT).map(MapSource::Paper));
        } else {
            maps.push(
                m.parse::<MapSource>()
                    .map_err(anyhow::Error::msg)
                    .context("--maps")?,
            );
        }
    }
    let mut starts = Vec::new();
    for s in starts_arg {
        if s == "all" {
            starts.extend(Corner::ALL.into_iter().map(StartSpec::Corner));
        } else {
            let start = s
                .parse::<StartSpec>()
                .map_err(anyhow::Error::msg)
                .context("--starts")?;
            start
                .check_team(base.num_robots)
                .map_err(anyhow::Error::msg)
                .context("--starts")?;
            starts.push(start);
        }
    }
    let loaded = maps
        .iter()
        .map(|source| source.load(&base))
        .collect::<Result<Vec<_>, _>>()?;
    madenet_sim::check_trial_set_size(
        1,
        &loaded
            .iter()
            .map(|m| m.cells().len() as u64)
            .collect::<Vec<_>>(),
        starts.len() as u64,
        csps.len() as u64,
        seeds,
    )
    .map_err(anyhow::Error::msg)
    .context("--seeds")?;
    if seed_base.checked_add(seeds.saturating_sub(1)).is_none() {
        bail!(
            "--seed-base {seed_base}: with {seeds} seeds it runs past the largest seed, {}",
            u64::MAX
        );
    }
    let mut specs = Vec::new();
    for (source, map) in maps.iter().zip(&loaded) {
        for start in &starts {
            for &csp in csps {
                let mut cfg = base.clone();
                cfg.comm_success_prob = csp;
                cfg.validate().context("--csp")?;
                let cells = start.cells(map, cfg.num_robots, cfg.movement);
                if cells.is_empty() {
                    bail!("--starts random: map {} has no {} connected free cells around the cell drawn from it", source.name(), cfg.num_robots);
                }
                for k in 0..seeds {
                    specs.push((
                        start.name(),
                        TrialSpec {
                            map: map.clone(),
                            map_name: source.name(),
                            starts: cells.clone(),
                            config: cfg.clone(),
                            policy: policy.to_string(),
                            seed: seed_base + k,
                        },
                    ));
                }
            }
        }
    }
    Ok(specs)
}

pub fn write_csv(path: &std::path::Path, results: &[(String, TrialResult)]) -> Result<()> {
    let file =
        madenet_files::AtomicFile::create(path).with_context(|| format!("{}", path.display()))?;
    let mut w = csv::Writer::from_writer(std::io::BufWriter::new(file));
    let mut header: Vec<String> = [
        "map",
        "start",
        "policy",
        "csp",
        "seed",
        "completed",
        "tns",
        "ttd",
        "noli",
        "ofv",
        "explored",
    ]
    .map(String::from)
    .to_vec();
    header.extend(COVERAGE_LEVELS.iter().map(|n| format!("to_{n}")));
    header.extend(["trial_s", "decisions", "per_decision_s"].map(String::from));
    w.write_record(&header)?;
    for (start, r) in results {
        let m = &r.metrics;
        let mut row = vec![
            r.map.clone(),
            start.clone(),
            r.policy.clone(),
            r.comm_success_prob.to_string(),
            r.seed.to_string(),
            m.completed.to_string(),
            m.tns.to_string(),
            format!("{:.6}", m.ttd),
            m.noli.to_string(),
            format!("{:.6}", m.ofv),
            format!("{:.6}", m.explored),
        ];
        row.extend(
            m.steps_to
                .iter()
                .map(|s| s.map(|v| v.to_string()).unwrap_or_default()),
        );
        row.extend([
            format!("{:.6}", r.timing.trial_s),
            r.timing.decisions.to_string(),
            format!("{:.9}", r.timing.per_decision_s),
        ]);
        w.write_record(&row)?;
    }
    w.into_inner()
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?
        .into_inner()
        .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), e.error()))?
        .commit()
        .with_context(|| format!("{}", path.display()))
}
