//! `madenet batch`: many trials in parallel, one CSV row each — a trial set planned and run by
//! the study runner ([`madenet_study::runner`]), written in its `trials.csv` schema.

use anyhow::{bail, Context, Result};
use clap::Args;
use madenet_study::runner::{self, TrialOutcome};
use madenet_study::StudyConfig;
use std::path::PathBuf;

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
    #[command(flatten)]
    set: crate::scenario_args::TrialSetArgs,
    /// Output CSV (written atomically), in the schema of `madenet compare`'s `trials.csv`.
    #[arg(long, default_value = "batch.csv")]
    out: PathBuf,
}

pub fn run(a: BatchArgs) -> Result<()> {
    if a.model.is_some() && a.policy != "model" {
        bail!(
            "--model is used only with --policy model (got --policy {})",
            a.policy
        );
    }
    let mut inputs = crate::clashes::map_list_inputs("--maps", &a.maps);
    inputs.extend(crate::clashes::given("--config", a.set.config.as_ref()));
    crate::clashes::refuse_clashes(&[("--out", a.out.clone())], &inputs)?;
    let registry = madenet_catalogue::with_model(&Default::default(), a.model.as_deref())?;
    let scenario =
        madenet_world::ScenarioConfig::from_toml_file_or_default(a.set.config.as_deref())?;
    let seeds = (a.set.seeds, a.set.seed_base);
    let mut cfg = StudyConfig::trial_set(&a.maps, &a.starts, &a.csp, seeds, scenario);
    cfg.methods = vec![a.policy.clone()];
    let flag = format!("--policy {}", a.policy);
    let planned = cfg.plan_flags(&registry, a.set.config.as_deref(), &flag)?;
    let started = std::time::Instant::now();
    let outcomes = madenet_study::progress::run_with_bar(&planned, &registry, a.set.threads)?;
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
    for line in madenet_study::means_by_csp(&outcomes, &a.csp) {
        out!("{line}")?;
    }
    Ok(())
}
