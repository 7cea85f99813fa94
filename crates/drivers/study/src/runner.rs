//! Running the trials: in parallel, appended as whole lines as they finish, resumable.

use crate::config::{oracle_method, StudyConfig, StudyError, StudyMap};
use madenet_baselines::rollout::{run_oracle_by, OracleKind};
use madenet_metrics::COVERAGE_LEVELS;
use madenet_sim::continuous::{ContinuousSpec, ContinuousTrial};
use madenet_sim::{PolicyRegistry, StartSpec, Trial, TrialSpec};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::io::Write;
use std::path::Path;
use std::sync::Mutex;

/// Identifies a trial: (method, map, start, CSP, seed).
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct TrialKey {
    /// Method: a policy name, or `oracle-<kind>` for an oracle's trials.
    pub method: String,
    /// Map name ([`StudyMap::name`]; `side<S>-map<k>` in the scalability study).
    pub map: String,
    /// Start name: a corner, cells `r,c;r,c;…` or `random` (`<start>:<team>` in the
    /// scalability study).
    pub start: String,
    /// CSP as written in outputs (shortest round-trip decimal).
    pub csp: String,
    /// Seed of the trial's world and policies.
    pub seed: u64,
}

/// One row of `trials.csv`.
#[derive(Clone, Debug, PartialEq)]
pub struct TrialRow {
    /// Which trial.
    pub key: TrialKey,
    /// The team explored every explorable cell before the step cap.
    pub completed: bool,
    /// TNS, total number of steps: timesteps to completion, or the step cap.
    pub tns: usize,
    /// TTD, total travel distance of the team, metres (column `ttd_m`).
    pub ttd: f64,
    /// NOLI, number of local interactions: robot pairs within d_s in line of sight, summed
    /// over timesteps.
    pub noli: usize,
    /// NOLI counted the way the authors' code does, for the calibration.
    pub noli_authors: usize,
    /// OFV, objective function value of Eq. (1): Σ_p p / D(p) over coverage levels p.
    pub ofv: f64,
    /// Final explored fraction of the explorable cells (0–1).
    pub explored: f64,
    /// Timesteps until coverage first reached each level of [`COVERAGE_LEVELS`] (columns
    /// `to_20` … `to_100`); `None` (an empty cell): never reached.
    pub steps_to: Vec<Option<usize>>,
    /// Wall-clock simulation time of the trial (CT), seconds; not deterministic.
    pub trial_s: f64,
    /// Decisions taken by all robots during the trial.
    pub decisions: usize,
    /// Mean wall-clock time of one decision (CT), seconds; not deterministic.
    pub per_decision_s: f64,
    /// What only a continuous-world trial has (its own columns; absent in grid tables).
    pub continuous: Option<ContinuousColumns>,
}

/// The columns of a continuous-world trial ([`madenet_sim::continuous`]), where the timestep
/// of the other columns is the simulated second (TNS: ET rounded up; `to_*`: seconds).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContinuousColumns {
    /// ET: simulated seconds until exploration ended (complete, the team out of frontiers,
    /// or the time cap).
    pub et_s: f64,
    /// Robot–obstacle collisions.
    pub obstacle_collisions: u64,
    /// Robot–robot collisions.
    pub robot_collisions: u64,
    /// Cells a local planner found impassable (free on the coarse map, blocked in truth).
    pub impassable_cells: u64,
    /// Stuck events: a target cell not entered within `planner.stuck_time`.
    pub stuck: u64,
    /// Cells written off: unknown neighbours of a reached goal its robot could not read from
    /// there (they count as explored).
    pub written_off_cells: u64,
    /// Explorable cells counted as explored though no robot's map read them.
    pub unread_cells: u64,
    /// Explorable cells of the trial.
    pub explorable_cells: u64,
}

/// The extra columns of a continuous study's `trials.csv`, after the grid's.
const CONTINUOUS_HEADER: [&str; 8] = [
    "et_s",
    "obstacle_collisions",
    "robot_collisions",
    "impassable_cells",
    "stuck",
    "written_off_cells",
    "unread_cells",
    "explorable_cells",
];

/// One line of `curves.jsonl`: the exploration curve of a trial.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Curve {
    /// Which trial.
    pub key: TrialKey,
    /// Explored fraction after each timestep (index 0: before the first move).
    pub explored: Vec<f64>,
    /// Team distance in metres, aligned with `explored`.
    pub distance: Vec<f64>,
}

/// A finished trial.
#[derive(Clone, Debug, PartialEq)]
pub struct TrialOutcome {
    /// Its row of `trials.csv`.
    pub row: TrialRow,
    /// Its line of `curves.jsonl`.
    pub curve: Curve,
}

const FIXED_HEADER: [&str; 15] = [
    "method",
    "map",
    "start",
    "csp",
    "seed",
    "completed",
    "tns",
    "ttd_m",
    "noli",
    "noli_authors",
    "ofv",
    "explored",
    "trial_s",
    "decisions",
    "per_decision_s",
];

/// The columns of `trials.csv`.
pub fn header() -> Vec<String> {
    let mut h: Vec<String> = FIXED_HEADER.iter().map(|s| s.to_string()).collect();
    h.extend(COVERAGE_LEVELS.iter().map(|n| format!("to_{n}")));
    h
}

/// The columns of a continuous study's `trials.csv`: [`header`], then ET and the collisions.
pub fn continuous_header() -> Vec<String> {
    let mut h = header();
    h.extend(CONTINUOUS_HEADER.iter().map(|s| s.to_string()));
    h
}

impl TrialRow {
    /// The row as a CSV line. Numbers are written in Rust's shortest form that reads back as
    /// the same `f64`, so a resumed study computes its statistics from exactly the values a
    /// fresh one holds.
    fn to_line(&self) -> String {
        let k = &self.key;
        let mut f = vec![
            k.method.clone(),
            k.map.clone(),
            k.start.clone(),
            k.csp.clone(),
            k.seed.to_string(),
            self.completed.to_string(),
            self.tns.to_string(),
            self.ttd.to_string(),
            self.noli.to_string(),
            self.noli_authors.to_string(),
            self.ofv.to_string(),
            self.explored.to_string(),
            self.trial_s.to_string(),
            self.decisions.to_string(),
            self.per_decision_s.to_string(),
        ];
        f.extend(
            self.steps_to
                .iter()
                .map(|s| s.map(|v| v.to_string()).unwrap_or_default()),
        );
        if let Some(c) = &self.continuous {
            f.extend([
                c.et_s.to_string(),
                c.obstacle_collisions.to_string(),
                c.robot_collisions.to_string(),
                c.impassable_cells.to_string(),
                c.stuck.to_string(),
                c.written_off_cells.to_string(),
                c.unread_cells.to_string(),
                c.explorable_cells.to_string(),
            ]);
        }
        let mut w = csv::WriterBuilder::new()
            .has_headers(false)
            .from_writer(Vec::new());
        w.write_record(&f).expect("writing to memory");
        String::from_utf8(w.into_inner().expect("writing to memory")).expect("utf-8")
    }

    fn from_record(r: &csv::StringRecord) -> Option<TrialRow> {
        let grid = FIXED_HEADER.len() + COVERAGE_LEVELS.len();
        if r.len() != grid && r.len() != grid + CONTINUOUS_HEADER.len() {
            return None;
        }
        let g = |i: usize| r.get(i);
        Some(TrialRow {
            key: TrialKey {
                method: g(0)?.to_string(),
                map: g(1)?.to_string(),
                start: g(2)?.to_string(),
                csp: g(3)?.to_string(),
                seed: g(4)?.parse().ok()?,
            },
            completed: g(5)?.parse().ok()?,
            tns: g(6)?.parse().ok()?,
            ttd: g(7)?.parse().ok()?,
            noli: g(8)?.parse().ok()?,
            noli_authors: g(9)?.parse().ok()?,
            ofv: g(10)?.parse().ok()?,
            explored: g(11)?.parse().ok()?,
            trial_s: g(12)?.parse().ok()?,
            decisions: g(13)?.parse().ok()?,
            per_decision_s: g(14)?.parse().ok()?,
            steps_to: (0..COVERAGE_LEVELS.len())
                .map(|k| {
                    let s = g(15 + k)?;
                    if s.is_empty() {
                        Some(None)
                    } else {
                        s.parse().ok().map(Some)
                    }
                })
                .collect::<Option<Vec<_>>>()?,
            continuous: if r.len() == grid {
                None
            } else {
                Some(ContinuousColumns {
                    et_s: g(grid)?.parse().ok()?,
                    obstacle_collisions: g(grid + 1)?.parse().ok()?,
                    robot_collisions: g(grid + 2)?.parse().ok()?,
                    impassable_cells: g(grid + 3)?.parse().ok()?,
                    stuck: g(grid + 4)?.parse().ok()?,
                    written_off_cells: g(grid + 5)?.parse().ok()?,
                    unread_cells: g(grid + 6)?.parse().ok()?,
                    explorable_cells: g(grid + 7)?.parse().ok()?,
                })
            },
        })
    }
}

/// Writes `contents` to `path` ([`madenet_files::write_atomic`]).
pub fn write_atomic(path: &Path, contents: &[u8]) -> Result<(), StudyError> {
    madenet_files::write_atomic(path, contents).map_err(|e| StudyError::File {
        path: path.display().to_string(),
        message: e.to_string(),
    })
}

/// The text up to and including its last newline: a line torn by an interruption is dropped
/// even when what remains of it still parses.
fn whole_lines(text: &str) -> &str {
    text.rfind('\n').map_or("", |i| &text[..=i])
}

/// Trials already recorded in `out` (complete rows with their curves); a torn last line from
/// an interrupted run is dropped.
fn load_done(out: &Path) -> HashMap<TrialKey, TrialOutcome> {
    let mut rows = HashMap::new();
    if let Ok(text) = std::fs::read_to_string(out.join("trials.csv")) {
        let text = whole_lines(&text);
        let mut rdr = csv::ReaderBuilder::new()
            .flexible(true)
            .from_reader(text.as_bytes());
        for rec in rdr.records().flatten() {
            if let Some(row) = TrialRow::from_record(&rec) {
                rows.insert(row.key.clone(), row);
            }
        }
    }
    let mut curves = HashMap::new();
    if let Ok(text) = std::fs::read_to_string(out.join("curves.jsonl")) {
        for line in whole_lines(&text).lines() {
            if let Ok(c) = serde_json::from_str::<Curve>(line) {
                curves.insert(c.key.clone(), c);
            }
        }
    }
    rows.into_iter()
        .filter_map(|(k, row)| {
            curves
                .remove(&k)
                .map(|curve| (k, TrialOutcome { row, curve }))
        })
        .collect()
}

/// A CSP as written in [`TrialKey::csp`] and outputs: Rust's shortest round-trip decimal.
pub fn csp_label(c: f64) -> String {
    format!("{c}")
}

impl std::fmt::Display for TrialKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}, map {}, start {}, CSP {}, seed {}",
            self.method, self.map, self.start, self.csp, self.seed
        )
    }
}

/// A trial the study runs: its key, its spec, and the oracle that makes its decisions (`None`:
/// the spec's policy does).
#[derive(Clone, Debug)]
pub struct Planned {
    /// The trial's identity in the outputs.
    pub key: TrialKey,
    /// What is simulated: map, start cells, scenario (at this trial's CSP), policy, seed.
    pub spec: TrialSpec,
    /// The oracle and its number of futures.
    pub oracle: Option<(OracleKind, usize)>,
    /// How a scoring oracle cuts and values its continuations.
    pub look: madenet_baselines::rollout::Lookahead,
    /// `Some`: the trial runs in the continuous world on this geometry, `spec.map` being its
    /// coarse truth and `spec.starts` the cells whose centres the robots start at.
    pub continuous: Option<PlannedContinuous>,
}

/// The continuous world of a [`Planned`] trial.
#[derive(Clone, Debug)]
pub struct PlannedContinuous {
    /// The true geometry.
    pub scene: std::sync::Arc<madenet_continuous::Scene>,
    /// The world's parameters.
    pub config: madenet_continuous::ContinuousConfig,
}

impl Planned {
    /// The continuous trial this plans, if it is one (a grid trial: `None`).
    pub fn continuous_trial(
        &self,
        registry: &PolicyRegistry,
    ) -> Option<Result<ContinuousTrial, madenet_sim::SimError>> {
        let c = self.continuous.as_ref()?;
        let spec = ContinuousSpec {
            scene: c.scene.clone(),
            starts: self.spec.starts.clone(),
            config: self.spec.config.clone(),
            continuous: c.config,
            policy: self.spec.policy.clone(),
            seed: self.spec.seed,
        };
        Some(ContinuousTrial::new(spec, registry))
    }
}

/// Everything the study runs, in output order: each policy of
/// [`StudyConfig::policies_run`], then each oracle (over `oracle_base`).
pub fn plan(cfg: &StudyConfig, maps: &[StudyMap], starts: &[StartSpec]) -> Vec<Planned> {
    let runs = cfg
        .policies_run()
        .into_iter()
        .map(|m| (m.clone(), m, None))
        .chain(cfg.oracles.iter().map(|&k| {
            (
                oracle_method(k),
                cfg.oracle_base.clone(),
                Some((k, cfg.oracle_futures)),
            )
        }));
    let mut v = Vec::new();
    for (method, policy, oracle) in runs {
        for m in maps {
            for s in starts {
                for &csp in &cfg.csp {
                    for k in 0..cfg.seeds {
                        let seed = cfg.seed_base + k;
                        let key = TrialKey {
                            method: method.clone(),
                            map: m.name.clone(),
                            start: s.name(),
                            csp: csp_label(csp),
                            seed,
                        };
                        let config = madenet_world::ScenarioConfig {
                            comm_success_prob: csp,
                            ..cfg.scenario.clone()
                        };
                        let spec = TrialSpec {
                            map: m.grid.clone(),
                            map_name: m.name.clone(),
                            starts: s.cells(
                                &m.grid,
                                cfg.scenario.num_robots,
                                cfg.scenario.movement,
                            ),
                            config,
                            policy: policy.clone(),
                            seed,
                        };
                        v.push(Planned {
                            key,
                            spec,
                            oracle,
                            look: cfg.oracle_lookahead,
                            continuous: None,
                        });
                    }
                }
            }
        }
    }
    v
}

/// Runs one planned trial (its outcome depends only on what was planned, never on which
/// thread, process or machine runs it).
pub fn run_one(p: &Planned, registry: &PolicyRegistry) -> Result<TrialOutcome, StudyError> {
    let (key, spec) = (&p.key, &p.spec);
    let failed = |e: madenet_sim::SimError| StudyError::Other(format!("{key}: {e}"));
    if let Some(trial) = p.continuous_trial(registry) {
        if p.oracle.is_some() {
            return Err(StudyError::Other(format!(
                "{key}: the oracles run in the grid world only"
            )));
        }
        let r = trial.map_err(failed)?.run();
        let per_decision_s = if r.decisions > 0 {
            r.wall_s / r.decisions as f64
        } else {
            0.0
        };
        let columns = ContinuousColumns {
            et_s: r.exploration_time_s,
            obstacle_collisions: r.obstacle_collisions,
            robot_collisions: r.robot_collisions,
            impassable_cells: r.impassable_cells,
            stuck: r.stuck,
            written_off_cells: r.written_off_cells,
            unread_cells: r.unread_cells,
            explorable_cells: r.explorable_cells,
        };
        let timing = (r.wall_s, r.decisions, per_decision_s);
        return Ok(outcome(key, r.metrics(), timing, Some(columns)));
    }
    let result = match p.oracle {
        None => Trial::with_registry(spec.clone(), registry)
            .map_err(failed)?
            .run(),
        Some((kind, futures)) => {
            run_oracle_by(spec.clone(), registry, kind, futures, p.look).map_err(failed)?
        }
    };
    let t = &result.timing;
    let timing = (t.trial_s, t.decisions, t.per_decision_s);
    Ok(outcome(key, result.metrics, timing, None))
}

/// A trial's row and curve from its metrics, its timing (trial seconds, decisions, seconds per
/// decision) and, for a continuous trial, its own columns.
fn outcome(
    key: &TrialKey,
    m: madenet_metrics::TrialMetrics,
    (trial_s, decisions, per_decision_s): (f64, usize, f64),
    continuous: Option<ContinuousColumns>,
) -> TrialOutcome {
    TrialOutcome {
        row: TrialRow {
            key: key.clone(),
            completed: m.completed,
            tns: m.tns,
            ttd: m.ttd,
            noli: m.noli,
            noli_authors: m.noli_authors,
            ofv: m.ofv,
            explored: m.explored,
            steps_to: m.steps_to,
            trial_s,
            decisions,
            per_decision_s,
            continuous,
        },
        curve: Curve {
            key: key.clone(),
            explored: m.explored_per_step,
            distance: m.distance_per_step,
        },
    }
}

/// Runs every planned trial not yet recorded in `out`, appending each as it finishes, and
/// returns all outcomes in plan order. `progress(done, total)` is called as trials finish.
pub fn run(
    cfg: &StudyConfig,
    registry: &PolicyRegistry,
    maps: &[StudyMap],
    starts: &[StartSpec],
    out: &Path,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<TrialOutcome>, StudyError> {
    run_planned(&plan(cfg, maps, starts), registry, out, progress)
}

/// Checks a planned trial set before anything runs: every key unique, and every trial able to
/// start (e.g. no start cell in an obstacle, enough start cells for the team; checked on the
/// first seed, as the seed changes neither).
pub fn check_planned(planned: &[Planned], registry: &PolicyRegistry) -> Result<(), StudyError> {
    let mut keys = std::collections::HashSet::new();
    if let Some(p) = planned.iter().find(|p| !keys.insert(&p.key)) {
        return Err(StudyError::Other(format!(
            "the trial ({}) is planned twice (each trial of a set needs its own key)",
            p.key
        )));
    }
    let first_seed = planned.iter().map(|p| p.key.seed).min().unwrap_or(0);
    for p in planned {
        if p.key.seed == first_seed {
            let fails = |e: madenet_sim::SimError| {
                StudyError::Other(format!("map {}, start {}: {e}", p.key.map, p.key.start))
            };
            match p.continuous_trial(registry) {
                Some(t) => drop(t.map_err(fails)?),
                None => drop(Trial::with_registry(p.spec.clone(), registry).map_err(fails)?),
            }
        }
    }
    Ok(())
}

/// [`run`] for trials planned by the caller (e.g. the scalability study's grid): runs every
/// one not yet recorded in `out` (keys must be unique: a repeated key is an error), appending
/// each as it finishes, and returns all outcomes in plan order.
pub fn run_planned(
    planned: &[Planned],
    registry: &PolicyRegistry,
    out: &Path,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<TrialOutcome>, StudyError> {
    check_planned(planned, registry)?;
    let mut done = load_done(out);
    done.retain(|k, _| planned.iter().any(|p| &p.key == k));
    // Rewrite the record files with exactly the complete trials, then append.
    let mut kept: Vec<&TrialOutcome> = done.values().collect();
    kept.sort_by(|a, b| a.row.key.cmp(&b.row.key));
    let continuous = planned.iter().any(|p| p.continuous.is_some());
    write_records(out, &kept, continuous)?;
    let open = |name: &str| {
        std::fs::OpenOptions::new()
            .append(true)
            .open(out.join(name))
            .map_err(|e| StudyError::File {
                path: out.join(name).display().to_string(),
                message: e.to_string(),
            })
    };
    let files = Mutex::new((open("trials.csv")?, open("curves.jsonl")?));
    let todo: Vec<&Planned> = planned
        .iter()
        .filter(|p| !done.contains_key(&p.key))
        .collect();
    let total = planned.len();
    let counter = std::sync::atomic::AtomicUsize::new(done.len());
    progress(done.len(), total);
    let fresh = run_all(&todo, registry, &|outcome| {
        {
            let mut f = files.lock().expect("no panics while holding the lock");
            let io = |e: std::io::Error| StudyError::File {
                path: out.display().to_string(),
                message: e.to_string(),
            };
            let mut line = serde_json::to_string(&outcome.curve).expect("curve serializes");
            line.push('\n');
            f.1.write_all(line.as_bytes()).map_err(io)?;
            f.1.flush().map_err(io)?;
            f.0.write_all(outcome.row.to_line().as_bytes())
                .map_err(io)?;
            f.0.flush().map_err(io)?;
        }
        let n = counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        progress(n, total);
        Ok(())
    })?;
    for o in fresh {
        done.insert(o.row.key.clone(), o);
    }
    let all: Vec<TrialOutcome> = planned
        .iter()
        .map(|p| done.remove(&p.key).expect("every planned trial ran"))
        .collect();
    // Final files in plan order: the same bytes whatever the thread count or interruptions
    // (but for the wall-clock columns).
    write_records(out, &all.iter().collect::<Vec<_>>(), continuous)?;
    Ok(all)
}

/// Runs `planned` in parallel on the current rayon pool, whatever records they have, calling
/// `finished` with each outcome as it finishes (from the worker thread that ran it); returns
/// the outcomes in plan order, or the first error in plan order.
pub fn run_all(
    planned: &[&Planned],
    registry: &PolicyRegistry,
    finished: &(dyn Fn(&TrialOutcome) -> Result<(), StudyError> + Sync),
) -> Result<Vec<TrialOutcome>, StudyError> {
    planned
        .par_iter()
        .map(|p| {
            let outcome = run_one(p, registry)?;
            finished(&outcome)?;
            Ok(outcome)
        })
        .collect::<Vec<Result<TrialOutcome, StudyError>>>()
        .into_iter()
        .collect()
}

/// The bytes of `trials.csv` holding `outcomes`' rows in the given order: the one trial-table
/// schema ([`header`]) of the study, the scalability study and `madenet batch`.
pub fn trials_csv(outcomes: &[&TrialOutcome]) -> Vec<u8> {
    let continuous = outcomes.iter().any(|o| o.row.continuous.is_some());
    trials_table(outcomes, continuous)
}

/// [`trials_csv`] with the header of a continuous study's table ([`continuous_header`]) or of
/// a grid study's.
fn trials_table(outcomes: &[&TrialOutcome], continuous: bool) -> Vec<u8> {
    let mut w = csv::WriterBuilder::new().from_writer(Vec::new());
    // A continuous study's table has its own columns after the grid's.
    if continuous {
        w.write_record(continuous_header())
    } else {
        w.write_record(header())
    }
    .expect("writing to memory");
    let mut csv_bytes = w.into_inner().expect("writing to memory");
    for o in outcomes {
        csv_bytes.extend_from_slice(o.row.to_line().as_bytes());
    }
    csv_bytes
}

fn write_records(
    out: &Path,
    outcomes: &[&TrialOutcome],
    continuous: bool,
) -> Result<(), StudyError> {
    let csv_bytes = trials_table(outcomes, continuous);
    let mut curves = Vec::new();
    for o in outcomes {
        curves.extend_from_slice(
            serde_json::to_string(&o.curve)
                .expect("curve serializes")
                .as_bytes(),
        );
        curves.push(b'\n');
    }
    write_atomic(&out.join("curves.jsonl"), &curves)?;
    write_atomic(&out.join("trials.csv"), &csv_bytes)
}
