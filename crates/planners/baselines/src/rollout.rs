//! Rollouts: a trial continued from its present under a base rule ([`Trial::fork`]), to score
//! a robot's goal candidates — the rollout teacher of learning and the rollout oracle, the
//! ceiling every candidate rule and learner is judged against.
//!
//! A candidate's value is the mean number of steps from now until the map is explored when the
//! robot takes it now and everyone follows the base rule afterwards, over a set of [`Future`]s:
//! the trial's own (a replay, which knows the luck to come), other futures of the same present,
//! or the noiseless one.
//!
//! Measured (generated maps 11–15 × 4 corners, base `spread`, CSP 1 / 0): the replay oracle
//! finishes 27 % / 37 % sooner than the base rule, but the placebo — the base rule's own choice
//! in the luckiest of 4 futures — already 21 % / 25 %: most of a replay's gain is luck. Scoring
//! candidates over 4 other futures is *worse* than the base rule (the candidates' differences
//! drown in that luck); the noiseless future scores them without it.

use madenet_agent::Decision;
use madenet_sim::{Future, PolicyRegistry, SimError, Trial, TrialResult, TrialSpec};
use serde::{Deserialize, Serialize};

/// Values of robot `i`'s candidates in `trial` — between [`Trial::begin_step`] and the
/// decisions, robot `i` deciding with its candidates extracted (`agent_mut(i).view(true)`):
/// mean steps left when `i` takes candidate k now (robots with a decision in `fixed` take it,
/// the other deciding robots ask `base`) and everyone follows `base` afterwards, over
/// `futures`. `None` for invalid slots.
pub fn candidate_values(
    trial: &Trial,
    i: usize,
    fixed: &[Option<Decision>],
    base: &str,
    registry: &PolicyRegistry,
    futures: &[Future],
) -> Result<Vec<Option<f64>>, SimError> {
    candidate_values_by(
        trial,
        i,
        fixed,
        base,
        registry,
        futures,
        Lookahead::default(),
    )
}

/// How a continuation values the decision it starts with (lower is better), in steps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Value {
    /// Steps left until the map is explored. Past a horizon they are estimated as the horizon
    /// plus (explorable cells still unknown) / r, with r the rate at which the team came to know
    /// cells in the trial so far (known cells now / timesteps now, at least one per step). r is
    /// the same for every continuation from one present, so candidates are ranked by how much
    /// of the map they leave unknown at the horizon; a rate measured within each continuation
    /// instead explodes when a continuation happens to learn little. On large maps a long
    /// continuation's finishing time hinges on a few far cells and ranks candidates almost by
    /// chance: the noiseless oracle over `spread` valued so is worse than `spread` itself
    /// (docs/research/oracles-and-teachers.md, "On large maps").
    #[default]
    StepsLeft,
    /// The mean over the map's explorable cells of the steps from now until each is known,
    /// each capped at the horizon (the area under the continuation's unknown-cells curve,
    /// divided by the explorable cells): every cell's discovery counts, so candidates are
    /// ranked by how soon they open the map.
    MeanDiscovery,
}

/// How far a continuation runs and how it is valued.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Lookahead {
    /// Steps after which a continuation is cut (`None`: run to the end).
    pub horizon: Option<usize>,
    /// What the continuation's value measures.
    pub value: Value,
}

/// [`candidate_values`] with continuations cut and valued by `look`.
pub fn candidate_values_by(
    trial: &Trial,
    i: usize,
    fixed: &[Option<Decision>],
    base: &str,
    registry: &PolicyRegistry,
    futures: &[Future],
    look: Lookahead,
) -> Result<Vec<Option<f64>>, SimError> {
    let agent = &trial.agents()[i];
    let (slots, valid) = (agent.candidates().slots, agent.candidates().cells.len());
    let mut values = vec![None; slots];
    for (k, value) in values.iter_mut().enumerate().take(valid) {
        let mut with_k = fixed.to_vec();
        with_k.resize(trial.agents().len(), None);
        with_k[i] = Some(Decision::Candidate(k));
        let mut sum = 0.0;
        for future in futures {
            sum += continuation_by(trial, &with_k, base, registry, future.clone(), look)?;
        }
        *value = Some(sum / futures.len() as f64);
    }
    Ok(values)
}

/// Steps left when the deciding robots of `trial` take `fixed` (or ask `base`) now and everyone
/// follows `base` afterwards, living `future`.
pub fn continuation(
    trial: &Trial,
    fixed: &[Option<Decision>],
    base: &str,
    registry: &PolicyRegistry,
    future: Future,
) -> Result<f64, SimError> {
    continuation_by(trial, fixed, base, registry, future, Lookahead::default())
}

/// The value of a continuation in which the deciding robots of `trial` take `fixed` (or ask
/// `base`) now and everyone follows `base` afterwards, living `future`, cut and valued by
/// `look` ([`Value`]).
pub fn continuation_by(
    trial: &Trial,
    fixed: &[Option<Decision>],
    base: &str,
    registry: &PolicyRegistry,
    future: Future,
    look: Lookahead,
) -> Result<f64, SimError> {
    let now = trial.world().t() as f64;
    let rate = (trial.world().known_count() as f64 / now.max(1.0)).max(1.0);
    let unknown = |t: &Trial| {
        let w = t.world();
        w.explorable_count().saturating_sub(w.known_count()) as f64
    };
    // Σ over the continuation's timesteps of the cells still unknown before each: a cell first
    // known after step d counts d, one still unknown at the horizon counts the horizon
    // (counted in the fork's world: a redrawn one has other explorable cells).
    let mut fork = trial.fork(base, registry, future)?;
    let mut area = unknown(&fork);
    fork.decide_with(fixed);
    fork.finish_step();
    let limit = look.horizon.unwrap_or(usize::MAX).max(1);
    let mut steps = 1;
    while steps < limit {
        let before = unknown(&fork);
        if !fork.step() {
            break;
        }
        area += before;
        steps += 1;
    }
    let left = unknown(&fork);
    match look.value {
        Value::MeanDiscovery => {
            // A trial stopped by its step cap keeps its unknown cells unknown to the horizon.
            if look.horizon.is_some() {
                area += left * (limit - steps) as f64;
            }
            let explorable = fork.world().explorable_count().max(1) as f64;
            Ok(area / explorable)
        }
        Value::StepsLeft if fork.is_done() => Ok(fork.finish().metrics.tns as f64 - now),
        Value::StepsLeft => Ok(steps as f64 + left / rate),
    }
}

/// Which oracle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OracleKind {
    /// At each decision with a choice, every candidate is scored in the trial's own future (a
    /// replay: it knows the map and the noise to come) and the best is taken — the issue's
    /// oracle, an upper bound that includes luck.
    Replay,
    /// Every candidate scored over `futures` other futures (it knows the map, not the noise):
    /// one step of policy improvement over the base rule — drowned in luck unless `futures` is
    /// large.
    Averaged,
    /// Every candidate scored in the noiseless future (it knows the map, not the sensing and
    /// motion noise; communication keeps the trial's own draws): the rollout teacher's choice.
    Noiseless,
    /// The placebo: the robot takes the base rule's own choice, and the oracle picks among
    /// `futures` futures of the noise the one that finishes soonest (the trial then lives it).
    /// What it gains over the base rule is luck alone — the part of the replay oracle's gain
    /// no policy can learn.
    Placebo,
    /// The known-map reference ([`crate::reference`]): a clairvoyant team plan over the true
    /// map, executed in the trial's own world. No base rule: the plan makes every move.
    KnownMap,
    /// Every candidate scored over `futures` noiseless futures whose unseen cells are redrawn
    /// by the map generator ([`Future::Redrawn`]; the same draws for every candidate of a
    /// decision): it knows what the team knows and the kind of map, not this map — the
    /// teacher a student that sees only the team's knowledge can learn from.
    Redrawn,
    /// A team-wide, multi-step teacher: over `futures` redrawn maps (as [`OracleKind::Redrawn`])
    /// the known-map reference plans routes for the whole team from where it stands, and the
    /// deciding robot takes the candidate with the fewest moves, summed over the draws, to its
    /// first planned viewpoint (the base rule's choice when no draw gives it one). It knows what
    /// the team knows and where every robot is — what a student could learn to imitate.
    PlanRedrawn,
    /// [`OracleKind::PlanRedrawn`] on the deciding robot's own map m_i instead of the team's
    /// cells (its unknown cells redrawn by the same draws), every robot still at its true cell:
    /// with `plan-redrawn` and the `belief-plan` policy (own map, teammates where it last knew
    /// them) it splits the teacher's gain into what the map and what the positions are worth.
    PlanOwnMap,
    /// [`OracleKind::PlanRedrawn`] on the team's cells, but with the teammates where the deciding
    /// robot last knew them (at the goal each last announced, or else its last known cell) —
    /// the fourth corner of the split, beside `plan-own-map`.
    PlanTeamMap,
}

/// An oracle by its [`OracleKind::name`] (`oracle --kind`, `compare --oracles`).
impl std::str::FromStr for OracleKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        OracleKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = OracleKind::ALL.iter().map(|k| k.name()).collect();
                format!("unknown oracle `{s}`; known: {}", names.join(", "))
            })
    }
}

impl OracleKind {
    /// Every oracle: replay, averaged, noiseless, placebo, known-map, redrawn, plan-redrawn,
    /// plan-own-map, plan-team-map.
    pub const ALL: [OracleKind; 9] = [
        OracleKind::Replay,
        OracleKind::Averaged,
        OracleKind::Noiseless,
        OracleKind::Placebo,
        OracleKind::KnownMap,
        OracleKind::Redrawn,
        OracleKind::PlanRedrawn,
        OracleKind::PlanOwnMap,
        OracleKind::PlanTeamMap,
    ];

    /// An item of a list that may say `none` (no oracle), as `compare --oracles` takes it.
    pub fn parse_or_none(s: &str) -> Result<Option<OracleKind>, String> {
        match s {
            "none" => Ok(None),
            _ => s.parse().map(Some).map_err(|e| format!("{e}, none")),
        }
    }

    /// The name in configs and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            OracleKind::Replay => "replay",
            OracleKind::Averaged => "averaged",
            OracleKind::Noiseless => "noiseless",
            OracleKind::Placebo => "placebo",
            OracleKind::KnownMap => "known-map",
            OracleKind::Redrawn => "redrawn",
            OracleKind::PlanRedrawn => "plan-redrawn",
            OracleKind::PlanOwnMap => "plan-own-map",
            OracleKind::PlanTeamMap => "plan-team-map",
        }
    }

    /// Whether `futures` matters (the placebo, averaged, redrawn and the plan oracles draw that
    /// many futures).
    pub fn uses_futures(self) -> bool {
        matches!(
            self,
            OracleKind::Averaged
                | OracleKind::Placebo
                | OracleKind::Redrawn
                | OracleKind::PlanRedrawn
                | OracleKind::PlanOwnMap
                | OracleKind::PlanTeamMap
        )
    }
}

/// Why `spec`'s policy cannot be an oracle's base rule, if it cannot: the oracle needs a rule
/// that chooses among two or more goal candidates when its robot's goal ends.
pub fn check_base(spec: &TrialSpec, registry: &PolicyRegistry) -> Result<(), String> {
    let probe = Trial::with_registry(spec.clone(), registry).map_err(|e| e.to_string())?;
    let Some(agent) = probe.agents().first() else {
        return Ok(());
    };
    if agent.config().goal_count < 2 {
        return Err("the oracle needs at least 2 goal candidates per decision (goal_count)".into());
    }
    if agent.policy_mode() != madenet_agent::DecisionMode::OnTermination {
        return Err(format!(
            "`{}` re-decides every step; the oracle needs a rule that chooses among goal candidates (e.g. spread, random, made-net)",
            spec.policy
        ));
    }
    Ok(())
}

/// A trial of `spec` (its `policy` is the base rule) in which `kind`'s oracle makes every
/// decision with two or more candidates; robots decide in index order, each seeing the
/// oracle's choices for the robots before it.
pub fn run_oracle(
    spec: TrialSpec,
    registry: &PolicyRegistry,
    kind: OracleKind,
    futures: usize,
) -> Result<TrialResult, SimError> {
    run_oracle_by(spec, registry, kind, futures, Lookahead::default())
}

/// [`run_oracle`] with the scoring oracles' (replay, averaged, noiseless, redrawn) continuations cut
/// and valued by `look`.
pub fn run_oracle_by(
    spec: TrialSpec,
    registry: &PolicyRegistry,
    kind: OracleKind,
    futures: usize,
    look: Lookahead,
) -> Result<TrialResult, SimError> {
    if kind == OracleKind::KnownMap {
        let (mut result, _) = crate::reference::run(&spec)?;
        result.policy = spec.policy;
        return Ok(result);
    }
    let base = spec.policy.clone();
    let seed = spec.seed;
    let mut trial = Trial::with_registry(spec, registry)?.timed(false);
    let n = trial.agents().len();
    let mut decision = 0u64;
    while trial.begin_step() {
        let mut fixed = vec![None; n];
        let mut placebo_done = false;
        for i in 0..n {
            if !trial.deciding()[i] {
                continue;
            }
            trial.agent_mut(i).view(true); // extracts the candidates
            if trial.agents()[i].candidates().cells.len() < 2 {
                continue;
            }
            decision += 1;
            let salts: Vec<Future> = (0..futures.max(1) as u64)
                .map(|s| {
                    Future::Salted(madenet_world::rng::derive_seed(
                        seed,
                        "oracle",
                        decision * 4096 + s,
                    ))
                })
                .collect();
            match kind {
                OracleKind::Replay
                | OracleKind::Averaged
                | OracleKind::Noiseless
                | OracleKind::Redrawn => {
                    let futures = match kind {
                        OracleKind::Replay => vec![Future::Own],
                        OracleKind::Noiseless => vec![Future::Noiseless],
                        OracleKind::Redrawn => redrawn_futures(&trial, seed, decision, futures)?,
                        _ => salts,
                    };
                    let values =
                        candidate_values_by(&trial, i, &fixed, &base, registry, &futures, look)?;
                    let best = values
                        .iter()
                        .enumerate()
                        .filter_map(|(k, v)| v.map(|v| (k, v)))
                        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
                    fixed[i] = best.map(|(k, _)| Decision::Candidate(k));
                }
                OracleKind::Placebo if placebo_done => {}
                OracleKind::Placebo => {
                    // One choice of future per step (the first deciding robot with a choice).
                    placebo_done = true;
                    let mut best: Option<(u64, f64)> = None;
                    for future in salts {
                        let Future::Salted(salt) = future else {
                            continue;
                        };
                        let v = continuation(&trial, &fixed, &base, registry, future.clone())?;
                        if best.is_none_or(|(_, b)| v < b) {
                            best = Some((salt, v));
                        }
                    }
                    if let Some((salt, _)) = best {
                        trial.reseed_noise(salt);
                    }
                }
                OracleKind::PlanRedrawn | OracleKind::PlanOwnMap | OracleKind::PlanTeamMap => {
                    let draws = redrawn_futures(&trial, seed, decision, futures)?;
                    let values = match kind {
                        OracleKind::PlanOwnMap => own_map_plan_values(&trial, i, &draws),
                        OracleKind::PlanTeamMap => team_map_plan_values(&trial, i, &draws),
                        _ => plan_values(&trial, i, &draws),
                    };
                    let best = values
                        .into_iter()
                        .enumerate()
                        .filter_map(|(k, v)| v.map(|v| (k, v)))
                        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
                    fixed[i] = best.map(|(k, _)| Decision::Candidate(k));
                }
                OracleKind::KnownMap => {} // played by `crate::reference` above
            }
        }
        trial.decide_with(&fixed);
        trial.finish_step();
    }
    Ok(trial.finish())
}

/// Robot `i`'s candidates valued by the team plan (the plan-redrawn teacher): over each
/// [`Future::Redrawn`] in `futures` (others are skipped), the known-map reference plans the
/// whole team's routes on the redrawn world from where it stands, and a candidate's value is
/// the mean, over the draws that give robot `i` a viewpoint, of its moves to that robot's first
/// viewpoint (lower is better; an unreachable one counts twice the map's height + width). All
/// `None` when no draw gives the robot a viewpoint; `None` for invalid slots.
pub fn plan_values(trial: &Trial, i: usize, futures: &[Future]) -> Vec<Option<f64>> {
    let fields = futures.iter().filter_map(|future| {
        let Future::Redrawn(map) = future else {
            return None;
        };
        let mut world = trial.world().clone();
        world.set_noiseless();
        world.redraw_unseen(map);
        Some(
            crate::reference::first_viewpoint_moves(&mut world)
                .into_iter()
                .nth(i)
                .flatten(),
        )
    });
    slot_values(trial, i, trial.world().truth(), fields)
}

/// Robot `i`'s candidates valued, in its slots, by their mean moves over `fields`
/// ([`crate::reference::mean_plan_moves`], capped at twice `grid`'s height + width): what every
/// plan oracle decides by.
fn slot_values(
    trial: &Trial,
    i: usize,
    grid: &madenet_map::OccGrid,
    fields: impl IntoIterator<Item = Option<Vec<u32>>>,
) -> Vec<Option<f64>> {
    let candidates = trial.agents()[i].candidates();
    let far = 2 * (grid.height() + grid.width()) as u32;
    let mut values = vec![None; candidates.slots];
    if let Some(mean) = crate::reference::mean_plan_moves(grid, &candidates.cells, far, fields) {
        for (v, m) in values.iter_mut().zip(mean) {
            *v = Some(m);
        }
    }
    values
}

/// [`plan_values`] planned on robot `i`'s own map m_i (its unknown cells from each
/// [`Future::Redrawn`]'s map), with every robot at its true cell, robot `i` first: the
/// `plan-own-map` oracle's values.
pub fn own_map_plan_values(trial: &Trial, i: usize, futures: &[Future]) -> Vec<Option<f64>> {
    let positions = trial.world().positions();
    let team: Vec<madenet_map::Pos> = std::iter::once(positions[i])
        .chain(
            positions
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, &p)| p),
        )
        .collect();
    plan_values_on(trial, i, futures, trial.agents()[i].belief().grid(), &team)
}

/// [`plan_values`] planned on the team's cells with the teammates where robot `i` last knew
/// them ([`crate::reference::known_team`]), robot `i` at its true cell: the `plan-team-map`
/// oracle's values.
pub fn team_map_plan_values(trial: &Trial, i: usize, futures: &[Future]) -> Vec<Option<f64>> {
    let world = trial.world();
    let truth = world.truth();
    let team_map =
        madenet_map::OccGrid::from_cells(truth.height(), truth.width(), world.team_map().to_vec());
    let agent = &trial.agents()[i];
    let team = crate::reference::known_team(i, world.positions()[i], agent.teammates());
    plan_values_on(trial, i, futures, &team_map, &team)
}

/// Robot `i`'s candidates valued by the team plan on `grid` (its unknown cells from each
/// [`Future::Redrawn`]'s map) for `team` (robot `i` first;
/// [`crate::reference::belief_first_viewpoint_moves`]), as [`plan_values`].
fn plan_values_on(
    trial: &Trial,
    i: usize,
    futures: &[Future],
    grid: &madenet_map::OccGrid,
    team: &[madenet_map::Pos],
) -> Vec<Option<f64>> {
    let config = trial.world().config();
    let fields = futures.iter().filter_map(|future| {
        let Future::Redrawn(map) = future else {
            return None;
        };
        Some(crate::reference::belief_first_viewpoint_moves(
            grid,
            Some(map),
            team,
            config.sensing_range,
            config.movement,
        ))
    });
    slot_values(trial, i, grid, fields)
}

/// `count` belief-consistent futures for decision number `decision` of the trial of `seed`
/// ([`Future::Redrawn`]): maps drawn by the default map generator at the trial's size (as
/// `madenet map generate`: [`GeneratorConfig::for_size`](madenet_map::generate::GeneratorConfig::for_size))
/// under its movement rule, seeds from the stream `oracle/redraw`.
pub fn redrawn_futures(
    trial: &Trial,
    seed: u64,
    decision: u64,
    count: usize,
) -> Result<Vec<Future>, SimError> {
    let truth = trial.world().truth();
    let movement = trial.world().config().movement;
    let indices = (0..count.max(1) as u64).map(|k| decision * 4096 + k);
    generated_maps(
        truth.height(),
        truth.width(),
        movement,
        seed,
        "oracle/redraw",
        indices,
    )
    .map(|maps| {
        maps.into_iter()
            .map(|m| Future::Redrawn(std::sync::Arc::new(m)))
            .collect()
    })
    .map_err(SimError::Redraw)
}

/// Maps of `height` × `width` drawn by the generator (its default for that size, the movement
/// rule `movement`), one per index, each from the stream `stream` of `seed` at that index: the
/// belief-consistent futures the plan teachers and planners redraw unseen cells from.
pub fn generated_maps(
    height: usize,
    width: usize,
    movement: madenet_map::Movement,
    seed: u64,
    stream: &str,
    indices: impl IntoIterator<Item = u64>,
) -> Result<Vec<madenet_map::OccGrid>, madenet_map::MapError> {
    let cfg = madenet_map::generate::GeneratorConfig::for_size(height, width);
    indices
        .into_iter()
        .map(|index| {
            let s = madenet_world::rng::derive_seed(seed, stream, index);
            madenet_map::generate::generate_with_movement(&cfg, s, movement)
        })
        .collect()
}
