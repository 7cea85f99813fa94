//! `madenet oracle`: the rollout oracle (and its placebo) beside the base rule on a trial set —
//! the ceiling a candidate rule or a learned policy is judged against
//! ([`madenet_baselines::rollout`]).

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use madenet_baselines::rollout::{Lookahead, OracleKind, Value};
use madenet_study::runner::{self, TrialOutcome};
use madenet_study::StudyConfig;
use std::path::PathBuf;

#[derive(Clone, Copy, Debug, ValueEnum)]
enum ValueArg {
    /// Steps until the map is explored (past --horizon: estimated at the rate so far).
    StepsLeft,
    /// The mean over cells of the steps until each is known, capped at --horizon (every
    /// discovery counts, not only the last).
    MeanDiscovery,
}

#[derive(Args, Debug)]
pub struct OracleArgs {
    /// Maps (comma-separated): `paper`, `paper:N`, `generate:SEED`, `generate-wide:SEED`, `floorplan:SEED`, or files.
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
    /// Which oracle: replay (each candidate scored in the trial's own future), averaged (over
    /// --futures other futures), placebo (the base rule's choice in the best of --futures
    /// futures: luck alone), noiseless (in the noiseless future), known-map (a clairvoyant team
    /// plan over the true map), redrawn (over --futures noiseless futures with the unseen cells
    /// redrawn), plan-redrawn (the known-map plan over redrawn maps: a team-wide teacher),
    /// plan-own-map, plan-team-map (plan-redrawn on the robot's own map, or with the teammates
    /// where it last knew them); see `madenet_baselines::rollout::OracleKind`.
    #[arg(long, default_value = "replay")]
    kind: OracleKind,
    /// Futures per candidate (averaged, redrawn) or to choose from (placebo); 1–64.
    #[arg(long, default_value_t = 4)]
    futures: usize,
    /// Cut the scoring oracles' continuations after this many steps (0: run to the end).
    #[arg(long, default_value_t = 0)]
    horizon: usize,
    /// What a continuation's value measures (scoring oracles).
    #[arg(long, value_enum, default_value = "steps-left")]
    value: ValueArg,
    /// Communication success probabilities (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "1.0,0.0")]
    csp: Vec<f64>,
    #[command(flatten)]
    set: crate::scenario_args::TrialSetArgs,
    /// Also write the base rule's and the oracle's trials as CSV (the schema of `madenet batch`
    /// and the study's `trials.csv`; the oracle's rows are method `oracle-KIND`).
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(a: OracleArgs) -> Result<()> {
    if !(1..=64).contains(&a.futures) {
        bail!("--futures {}: must be in 1..=64", a.futures);
    }
    let scoring = matches!(
        a.kind,
        OracleKind::Replay | OracleKind::Averaged | OracleKind::Noiseless | OracleKind::Redrawn
    );
    if !scoring && (a.horizon > 0 || !matches!(a.value, ValueArg::StepsLeft)) {
        bail!("--horizon/--value: only the scoring oracles (replay, averaged, noiseless, redrawn) value continuations");
    }
    let registry = madenet_catalogue::shipped()?;
    let scenario =
        madenet_world::ScenarioConfig::from_toml_file_or_default(a.set.config.as_deref())?;
    let seeds = (a.set.seeds, a.set.seed_base);
    if let Some(out) = &a.out {
        let mut inputs = crate::clashes::map_list_inputs("--maps", &a.maps);
        inputs.extend(crate::clashes::given("--config", a.set.config.as_ref()));
        crate::clashes::refuse_clashes(&[("--out", out.clone())], &inputs)?;
    }
    let mut cfg = StudyConfig::trial_set(&a.maps, &a.starts, &a.csp, seeds, scenario);
    cfg.methods = vec![a.base.clone()];
    cfg.oracles = vec![a.kind];
    cfg.oracle_base = a.base.clone();
    cfg.oracle_futures = a.futures;
    cfg.oracle_lookahead = Lookahead {
        horizon: (a.horizon > 0).then_some(a.horizon),
        value: match a.value {
            ValueArg::StepsLeft => Value::StepsLeft,
            ValueArg::MeanDiscovery => Value::MeanDiscovery,
        },
    };
    let flag = format!("--base {}", a.base);
    // The base rule's trials, then the oracle's on the same (map, start, CSP, seed), in order.
    let planned = cfg.plan_flags(&registry, a.set.config.as_deref(), &flag)?;
    let started = std::time::Instant::now();
    let outcomes = madenet_study::progress::run_with_bar(&planned, &registry, a.set.threads)?;
    let (base, oracle) = outcomes.split_at(outcomes.len() / 2);
    if let Some(path) = &a.out {
        let rows: Vec<&TrialOutcome> = outcomes.iter().collect();
        madenet_files::write_atomic(path, &runner::trials_csv(&rows))
            .with_context(|| format!("--out {}", path.display()))?;
    }
    let futures = match a.kind {
        OracleKind::Replay | OracleKind::Noiseless | OracleKind::KnownMap => String::new(),
        _ => format!(" ({} futures)", a.futures),
    };
    let look = match (a.horizon, a.value) {
        (0, ValueArg::StepsLeft) => String::new(),
        (h, v) => format!(
            ", valued by {}{}",
            v.to_possible_value()
                .expect("no skipped variants")
                .get_name(),
            match h {
                0 => String::new(),
                h => format!(" over {h} steps"),
            }
        ),
    };
    out!(
        "{} trials in {:.1} s; oracle {:?} over base `{}`{futures}{look}",
        base.len(),
        started.elapsed().as_secs_f64(),
        a.kind,
        a.base
    )?;
    for line in madenet_study::oracle_by_csp(base, oracle, &a.csp) {
        out!("{line}")?;
    }
    Ok(())
}
