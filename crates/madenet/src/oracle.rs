//! `madenet oracle`: the rollout oracle (and its placebo) beside the base rule on a trial set —
//! the ceiling a candidate rule or a learned policy is judged against
//! ([`madenet_sim::rollout`]).

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use madenet_sim::rollout::{Lookahead, OracleKind, Value};
use madenet_study::runner::{self, TrialOutcome};
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
    /// The known-map reference: a clairvoyant team plan over the true map, in the trial's own
    /// world (the base rule only names the pairing).
    KnownMap,
    /// Each candidate scored over --futures noiseless futures whose unseen cells are redrawn by
    /// the map generator (knows what the team knows, not the map).
    Redrawn,
    /// Over --futures redrawn maps, the known-map reference plans the whole team's routes from
    /// where it stands; the robot takes the candidate nearest its first viewpoint (a team-wide,
    /// multi-step teacher).
    PlanRedrawn,
    /// plan-redrawn on the deciding robot's own map instead of the team's cells, every robot
    /// at its true cell (what the positions alone are worth).
    PlanOwnMap,
    /// plan-redrawn on the team's cells with the teammates where the deciding robot last knew
    /// them (what the team's map alone is worth).
    PlanTeamMap,
}

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
    /// Which oracle.
    #[arg(long, value_enum, default_value = "replay")]
    kind: Kind,
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
    /// Seeds per (map, start, CSP).
    #[arg(long, default_value_t = 1)]
    seeds: u64,
    #[arg(long, default_value_t = 1)]
    seed_base: u64,
    /// Scenario config (TOML).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Also write the base rule's and the oracle's trials as CSV (the schema of `madenet batch`
    /// and the study's `trials.csv`; the oracle's rows are method `oracle-KIND`).
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
    let scoring = matches!(
        a.kind,
        Kind::Replay | Kind::Averaged | Kind::Noiseless | Kind::Redrawn
    );
    if !scoring && (a.horizon > 0 || !matches!(a.value, ValueArg::StepsLeft)) {
        bail!("--horizon/--value: only the scoring oracles (replay, averaged, noiseless, redrawn) value continuations");
    }
    let registry = crate::registry(None)?;
    let kind = match a.kind {
        Kind::Replay => OracleKind::Replay,
        Kind::Averaged => OracleKind::Averaged,
        Kind::Placebo => OracleKind::Placebo,
        Kind::Noiseless => OracleKind::Noiseless,
        Kind::KnownMap => OracleKind::KnownMap,
        Kind::Redrawn => OracleKind::Redrawn,
        Kind::PlanRedrawn => OracleKind::PlanRedrawn,
        Kind::PlanOwnMap => OracleKind::PlanOwnMap,
        Kind::PlanTeamMap => OracleKind::PlanTeamMap,
    };
    let mut cfg = crate::batch::trial_set(
        &a.maps,
        &a.starts,
        &a.csp,
        a.seeds,
        a.seed_base,
        a.config.as_deref(),
    )?;
    cfg.methods = vec![a.base.clone()];
    cfg.oracles = vec![kind];
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
    let planned = crate::batch::plan(&cfg, &registry, a.config.as_deref(), &flag)?;
    let started = std::time::Instant::now();
    let outcomes = crate::batch::run_planned(&planned, &registry, a.threads)?;
    let (base, oracle) = outcomes.split_at(outcomes.len() / 2);
    if let Some(path) = &a.out {
        let rows: Vec<&TrialOutcome> = outcomes.iter().collect();
        madenet_files::write_atomic(path, &runner::trials_csv(&rows))
            .with_context(|| format!("--out {}", path.display()))?;
    }
    let futures = match a.kind {
        Kind::Averaged
        | Kind::Placebo
        | Kind::Redrawn
        | Kind::PlanRedrawn
        | Kind::PlanOwnMap
        | Kind::PlanTeamMap => {
            format!(" ({} futures)", a.futures)
        }
        Kind::Replay | Kind::Noiseless | Kind::KnownMap => String::new(),
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
    for &csp in &a.csp {
        let sel: Vec<(&TrialOutcome, &TrialOutcome)> = base
            .iter()
            .zip(oracle)
            .filter(|(b, _)| b.row.key.csp == runner::csp_label(csp))
            .collect();
        let n = sel.len().max(1) as f64;
        let mean = |f: &dyn Fn(&(&TrialOutcome, &TrialOutcome)) -> usize| {
            sel.iter().map(|r| f(r) as f64).sum::<f64>() / n
        };
        let base_tns = mean(&|r| r.0.row.tns);
        let oracle_tns = mean(&|r| r.1.row.tns);
        let wins = sel.iter().filter(|r| r.1.row.tns < r.0.row.tns).count();
        let losses = sel.iter().filter(|r| r.1.row.tns > r.0.row.tns).count();
        out!("csp {csp:.2}: base TNS {base_tns:.1}  oracle TNS {oracle_tns:.1}  ({:+.1} %)  oracle better on {wins}, worse on {losses} of {}", 100.0 * (oracle_tns / base_tns - 1.0), sel.len())?;
    }
    Ok(())
}
