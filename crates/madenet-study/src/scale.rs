//! The scalability study (`madenet scale`): the grid analogue of the paper's Sec. V.B and
//! Fig. 7 — exploration time against team size on maps of several sizes.
//!
//! Map sides × generated maps per side × starts (bottom-left, top-right, middle) × team sizes ×
//! seeds, for every method, at one CSP. Maps are generated from seeds of their own (never the
//! learners' training or validation streams) with the start areas kept free; robots start at
//! the free cells nearest (by moves) to the start's anchor cell. The step cap grows with the
//! map (`steps_per_cell` × cells), so that small teams on large maps can finish.
//!
//! Outputs (the trials resumable as in `madenet compare`, by the same runner):
//! * `trials.csv`, `curves.jsonl` — one row per trial; map `side<S>-map<k>`, start
//!   `<start>:<team>`;
//! * `cells.csv` — mean TNS, TTD, NOLI and completions per (side, team, method);
//! * `fig7_scalability.{png,svg}` — mean TNS against team size, one panel per map side;
//! * `scale.md` — the tables; per map side and method a Friedman test across team sizes and
//!   Wilcoxon signed-rank tests between consecutive team sizes (paired by map, start and seed),
//!   where exploration time stops falling; the first method against every other: the share of
//!   (side, team) cells where it has lower mean TNS and TTD, and pooled Wilcoxon tests.

use crate::analysis::mean_sd;
use crate::config::{field, StudyError};
use crate::runner::{
    run_planned, write_atomic, Planned, PlannedContinuous, TrialKey, TrialOutcome,
};
use madenet_baselines::BaselineParams;
use madenet_continuous::scene::generate_cluttered;
use madenet_map::generate::{generate_with_movement, starts_near, GeneratorConfig};
use madenet_map::Pos;
use madenet_sim::TrialSpec;
use madenet_stats::{friedman, wilcoxon};
use madenet_world::rng::derive_seed;
use madenet_world::ScenarioConfig;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Where a team starts in the scalability study.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ScaleStart {
    /// Around the bottom-left corner cell.
    BottomLeft,
    /// Around the top-right corner cell.
    TopRight,
    /// Around the centre cell.
    Middle,
}

impl ScaleStart {
    /// Name in outputs.
    pub fn name(self) -> &'static str {
        match self {
            ScaleStart::BottomLeft => "bottom-left",
            ScaleStart::TopRight => "top-right",
            ScaleStart::Middle => "middle",
        }
    }

    /// The anchor cell on a `side` × `side` map.
    pub fn anchor(self, side: usize) -> Pos {
        let s = side as i32;
        match self {
            ScaleStart::BottomLeft => Pos::new(s - 1, 0),
            ScaleStart::TopRight => Pos::new(0, s - 1),
            ScaleStart::Middle => Pos::new(s / 2, s / 2),
        }
    }
}

/// The world the scalability study's trials run in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ScaleWorld {
    /// The grid world: timesteps, TNS in steps.
    #[default]
    Grid,
    /// The continuous world (the paper's own protocol: differential-drive robots, lidar
    /// maps, a local planner): generated cluttered scenes, ET in simulated seconds.
    Continuous,
}

/// The scalability study's design, with its defaults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScaleConfig {
    /// Methods by policy name; the first is the one judged against the others.
    pub methods: Vec<String>,
    /// Map sides (square maps, cells).
    pub sides: Vec<usize>,
    /// Team sizes.
    pub teams: Vec<usize>,
    /// Start areas.
    pub starts: Vec<ScaleStart>,
    /// Generated maps per side.
    pub maps_per_side: usize,
    /// Master seed of the generated maps (`side<S>-map<k>` is drawn from it, side and k).
    pub map_seed: u64,
    /// Lower bound of the generated maps' target obstacle fraction.
    pub density_min: f64,
    /// Upper bound of the generated maps' target obstacle fraction.
    pub density_max: f64,
    /// Seeds per (method, map, start, team): `seed_base`, `seed_base + 1`, …
    pub seeds: u64,
    /// The first seed of each (method, map, start, team).
    pub seed_base: u64,
    /// Communication success probability of every trial (the paper's Fig. 7: 1).
    pub csp: f64,
    /// Step cap per map cell: a trial on a side-S map stops after max(scenario.step_cap,
    /// ⌈steps_per_cell · S²⌉) steps (in the continuous world: simulated seconds, at least
    /// `continuous.time_cap`).
    pub steps_per_cell: f64,
    /// The world the trials run in. `continuous`: each map is a cluttered scene of the
    /// continuous world's generator (bookshelves, bins, cylinders; S × S cells of
    /// `scenario.cell_size` metres, drawn from `map_seed`; `density_min`/`density_max` do not
    /// apply), read as cells by the scenario's discretization rule.
    pub world: ScaleWorld,
    /// The continuous world's parameters (`world = "continuous"` only).
    pub continuous: madenet_continuous::ContinuousConfig,
    /// Everything else about the world (`num_robots` and `comm_success_prob` are set per trial).
    pub scenario: ScenarioConfig,
    /// Parameters of the classical baselines.
    pub baselines: BaselineParams,
}

impl Default for ScaleConfig {
    fn default() -> Self {
        ScaleConfig {
            methods: ["made-net-any", "nf", "ub", "pb", "spread"]
                .map(String::from)
                .to_vec(),
            sides: vec![20, 30, 40, 60],
            teams: vec![2, 3, 4, 5, 6],
            starts: vec![
                ScaleStart::BottomLeft,
                ScaleStart::TopRight,
                ScaleStart::Middle,
            ],
            maps_per_side: 4,
            map_seed: 7001,
            density_min: 0.15,
            density_max: 0.45,
            seeds: 3,
            seed_base: 1,
            csp: 1.0,
            steps_per_cell: 1.0,
            world: ScaleWorld::Grid,
            continuous: madenet_continuous::ContinuousConfig::default(),
            scenario: ScenarioConfig::default(),
            baselines: BaselineParams::default(),
        }
    }
}

impl ScaleConfig {
    /// The continuous world's study as `madenet scale --world continuous` runs it: the paper's
    /// Fig. 7 grid (sides 20, 30, 40, 60 m; teams 2–6; starts BL, TR, M) on one generated
    /// scene per side, 3 seeds, methods made-net-any, nf, ub, spread (PB's cost grows with the
    /// team and its grid results trail UB's).
    pub fn continuous_default() -> Self {
        ScaleConfig {
            world: ScaleWorld::Continuous,
            methods: ["made-net-any", "nf", "ub", "spread"]
                .map(String::from)
                .to_vec(),
            maps_per_side: 1,
            ..ScaleConfig::default()
        }
    }
}

/// One trial's place in the grid, beside its planned run.
#[derive(Clone, Debug)]
pub struct ScalePlanned {
    /// Map side, cells.
    pub side: usize,
    /// Team size, robots.
    pub team: usize,
    /// The trial, as the runner runs it.
    pub planned: Planned,
}

impl ScaleConfig {
    /// Reads a TOML config; errors name the file, field and line.
    pub fn from_toml_file(path: &Path) -> Result<Self, StudyError> {
        crate::config::read_toml(path)
    }

    /// Checks every field; the message names it.
    pub fn validate(&self, registry: &madenet_sim::PolicyRegistry) -> Result<(), StudyError> {
        if self.methods.is_empty() {
            return Err(field("methods", "is empty"));
        }
        let known = registry.names();
        for (i, m) in self.methods.iter().enumerate() {
            if !known.contains(m) {
                return Err(field(
                    "methods",
                    format!("unknown method `{m}`; known: {}", known.join(", ")),
                ));
            }
            if self.methods[..i].contains(m) {
                return Err(field("methods", format!("`{m}` is listed twice")));
            }
        }
        let unique = |v: &[usize]| v.iter().enumerate().all(|(i, x)| !v[..i].contains(x));
        if self.sides.is_empty()
            || !unique(&self.sides)
            || self.sides.iter().any(|&s| !(12..=500).contains(&s))
        {
            return Err(field("sides", "list distinct map sides in 12..=500 cells"));
        }
        if self.teams.is_empty()
            || !unique(&self.teams)
            || self
                .teams
                .iter()
                .any(|&t| !(1..=madenet_world::MAX_ROBOTS).contains(&t))
        {
            return Err(field(
                "teams",
                format!(
                    "list distinct team sizes in 1..={}",
                    madenet_world::MAX_ROBOTS
                ),
            ));
        }
        if self.starts.is_empty()
            || self
                .starts
                .iter()
                .enumerate()
                .any(|(i, s)| self.starts[..i].contains(s))
        {
            return Err(field("starts", "list distinct starts"));
        }
        if !(1..=1000).contains(&self.maps_per_side) {
            return Err(field("maps_per_side", "must be in 1..=1000"));
        }
        if !(0.0..=0.6).contains(&self.density_min)
            || !(self.density_min..=0.6).contains(&self.density_max)
        {
            return Err(field(
                "density_min/density_max",
                "need 0 ≤ density_min ≤ density_max ≤ 0.6",
            ));
        }
        if self.seeds == 0
            || self.seeds > 1000
            || self.seed_base.checked_add(self.seeds - 1).is_none()
        {
            return Err(field(
                "seeds",
                "must be in 1..=1000 (and the last seed, seed_base + seeds − 1, fit a u64)",
            ));
        }
        if !(0.0..=1.0).contains(&self.csp) {
            return Err(field("csp", format!("{} is not a probability", self.csp)));
        }
        if !(self.steps_per_cell > 0.0 && self.steps_per_cell <= 100.0) {
            return Err(field("steps_per_cell", "must be in (0, 100]"));
        }
        let cells: Vec<u64> = self
            .sides
            .iter()
            .flat_map(|&s| std::iter::repeat_n((s * s) as u64, self.maps_per_side))
            .collect();
        madenet_sim::check_trial_set_size(
            (self.methods.len() * self.teams.len()) as u64,
            &cells,
            self.starts.len() as u64,
            1,
            self.seeds,
        )
        .map_err(|e| field("sides/teams/seeds", e))?;
        self.scenario
            .validate()
            .map_err(|e| field("scenario", e.to_string()))?;
        self.baselines
            .validate()
            .map_err(|e| field("baselines", e))?;
        self.continuous
            .validate()
            .map_err(|e| field("continuous", e.to_string()))?;
        Ok(())
    }

    /// The step cap on a side-`side` map (in the continuous world: the time cap, seconds).
    pub fn step_cap(&self, side: usize) -> usize {
        let floor = match self.world {
            ScaleWorld::Grid => self.scenario.step_cap,
            ScaleWorld::Continuous => self.continuous.time_cap.ceil() as usize,
        };
        floor.max((self.steps_per_cell * (side * side) as f64).ceil() as usize)
    }

    /// Every trial, in output order (method, side, map, start, team, seed).
    pub fn plan(&self) -> Result<Vec<ScalePlanned>, StudyError> {
        let movement = self.scenario.movement;
        let mut maps = Vec::new();
        let cell = self.scenario.cell_size;
        for &side in &self.sides {
            for k in 0..self.maps_per_side {
                if self.world == ScaleWorld::Continuous {
                    let seed = derive_seed(self.map_seed, "scale-scene", (side * 1000 + k) as u64);
                    let scene = generate_cluttered(
                        side as f64 * cell,
                        self.continuous.mapping.resolution,
                        seed,
                    );
                    let grid = scene.coarse_truth(cell, &self.scenario.discretize);
                    let planned = PlannedContinuous {
                        scene: Arc::new(scene),
                        config: madenet_continuous::ContinuousConfig {
                            time_cap: self.step_cap(side) as f64,
                            ..self.continuous
                        },
                    };
                    maps.push((side, format!("side{side}-map{k}"), grid, Some(planned)));
                    continue;
                }
                // The start areas (3 × 3 around each anchor) stay free.
                let keep_free: Vec<Pos> = self
                    .starts
                    .iter()
                    .flat_map(|s| {
                        let a = s.anchor(side);
                        (-1..=1).flat_map(move |dr| {
                            (-1..=1).map(move |dc| Pos::new(a.row + dr, a.col + dc))
                        })
                    })
                    .filter(|p| {
                        p.row >= 0
                            && p.col >= 0
                            && (p.row as usize) < side
                            && (p.col as usize) < side
                    })
                    .collect();
                let gen = GeneratorConfig {
                    height: side,
                    width: side,
                    density_min: self.density_min,
                    density_max: self.density_max,
                    keep_free,
                };
                let seed = derive_seed(self.map_seed, "scale-map", (side * 1000 + k) as u64);
                let grid = generate_with_movement(&gen, seed, movement)
                    .map_err(|e| StudyError::Other(format!("map side {side} #{k}: {e}")))?;
                maps.push((side, format!("side{side}-map{k}"), grid, None));
            }
        }
        let mut v = Vec::new();
        for method in &self.methods {
            for (side, name, grid, continuous) in &maps {
                for start in &self.starts {
                    for &team in &self.teams {
                        let cells =
                            starts_near(grid, start.anchor(*side), team, movement).ok_or_else(
                                || {
                                    StudyError::Other(format!(
                                        "map {name}: fewer than {team} free cells connected to the {} start",
                                        start.name()
                                    ))
                                },
                            )?;
                        for s in 0..self.seeds {
                            let seed = self.seed_base + s;
                            let config = ScenarioConfig {
                                num_robots: team,
                                comm_success_prob: self.csp,
                                step_cap: self.step_cap(*side),
                                ..self.scenario.clone()
                            };
                            let key = TrialKey {
                                method: method.clone(),
                                map: name.clone(),
                                start: format!("{}:{team}", start.name()),
                                csp: crate::runner::csp_label(self.csp),
                                seed,
                            };
                            let spec = TrialSpec {
                                map: grid.clone(),
                                map_name: name.clone(),
                                starts: cells.clone(),
                                config,
                                policy: method.clone(),
                                seed,
                            };
                            v.push(ScalePlanned {
                                side: *side,
                                team,
                                planned: Planned {
                                    key,
                                    spec,
                                    oracle: None,
                                    continuous: continuous.clone(),
                                },
                            });
                        }
                    }
                }
            }
        }
        Ok(v)
    }
}

impl ScaleConfig {
    /// The grid twin of a continuous study's plan: the same trials (the scenes read as cells
    /// by the scenario's rule, the same start cells, teams, methods and seeds) in the grid
    /// world, with the grid study's step cap — so each policy's advantage can be compared
    /// between the two worlds trial by trial (same index, same trial).
    pub fn grid_twin(&self, planned: &[ScalePlanned]) -> Vec<ScalePlanned> {
        let grid = ScaleConfig {
            world: ScaleWorld::Grid,
            ..self.clone()
        };
        planned
            .iter()
            .map(|p| {
                let mut t = p.clone();
                t.planned.continuous = None;
                t.planned.spec.config.step_cap = grid.step_cap(p.side);
                t
            })
            .collect()
    }
}

/// One (side, team, method) cell of the grid.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CellRow {
    /// Map side, cells.
    pub side: usize,
    /// Team size, robots.
    pub team: usize,
    /// Method (policy name).
    pub method: String,
    /// Number of trials in the cell.
    pub trials: usize,
    /// How many of them completed before the step cap.
    pub completed: usize,
    /// Mean TNS (total number of steps), timesteps; in the continuous world mean ET,
    /// simulated seconds.
    pub tns: f64,
    /// Mean TTD (total travel distance), metres.
    pub ttd_m: f64,
    /// Mean NOLI (number of local interactions).
    pub noli: f64,
    /// Collisions (robot–obstacle and robot–robot) over the cell's trials; 0 in the grid.
    #[serde(skip)]
    pub collisions: u64,
}

/// A row of a continuous study's `cells.csv`.
#[derive(Serialize)]
struct ContinuousCellRow<'a> {
    side: usize,
    team: usize,
    method: &'a str,
    trials: usize,
    completed: usize,
    et_s: f64,
    ttd_m: f64,
    noli: f64,
    collisions: u64,
}

/// What [`run_scale`] produced.
#[derive(Debug)]
pub struct ScaleResult {
    /// `scale.md`.
    pub report: PathBuf,
    /// The means per (side, team, method), as written to `cells.csv`.
    pub cells: Vec<CellRow>,
    /// Number of trials of the study, recorded earlier or run now.
    pub trials: usize,
}

/// Runs the scalability study into `out` (resuming trials recorded there by the same
/// configuration; `fresh` discards them) and writes its tables, tests and figure.
pub fn run_scale(
    cfg: &ScaleConfig,
    registry: &madenet_sim::PolicyRegistry,
    out: &Path,
    fresh: bool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<ScaleResult, StudyError> {
    cfg.validate(registry)?;
    let planned = cfg.plan()?;
    let io = |e: std::io::Error| StudyError::File {
        path: out.display().to_string(),
        message: e.to_string(),
    };
    std::fs::create_dir_all(out).map_err(io)?;
    let _lock = crate::prepare_out(out, "scale.toml", cfg, "", fresh)?;
    let started = std::time::Instant::now();
    // A continuous study runs its grid twin first (`grid/`; fast), in one progress count.
    let twin = match cfg.world {
        ScaleWorld::Grid => None,
        ScaleWorld::Continuous => {
            let dir = out.join("grid");
            std::fs::create_dir_all(&dir).map_err(io)?;
            // `grid/` stays this run's until the report is written, as `out` does.
            let header = "# The grid twin of ../scale.toml: its trials on each scene's 1 m cells\n# (the paper's discretization) in the grid world, in timesteps, not seconds.\n";
            let lock = crate::prepare_out(&dir, "scale.toml", cfg, header, fresh)?;
            let twin = cfg.grid_twin(&planned);
            let runs: Vec<Planned> = twin.iter().map(|p| p.planned.clone()).collect();
            let n = planned.len();
            let outcomes = run_planned(&runs, registry, &dir, &|d, t| progress(d, t + n))?;
            Some((twin, outcomes, lock))
        }
    };
    let offset = twin.as_ref().map_or(0, |(t, _, _)| t.len());
    let runs: Vec<Planned> = planned.iter().map(|p| p.planned.clone()).collect();
    let outcomes = run_planned(&runs, registry, out, &|d, t| {
        progress(d + offset, t + offset)
    })?;
    let wall = started.elapsed().as_secs_f64();
    let cells = cells(cfg, &planned, &outcomes);
    let mut w = csv::Writer::from_writer(Vec::new());
    for c in &cells {
        match cfg.world {
            ScaleWorld::Grid => w.serialize(c),
            ScaleWorld::Continuous => w.serialize(ContinuousCellRow {
                side: c.side,
                team: c.team,
                method: &c.method,
                trials: c.trials,
                completed: c.completed,
                et_s: c.tns,
                ttd_m: c.ttd_m,
                noli: c.noli,
                collisions: c.collisions,
            }),
        }
        .map_err(|e| StudyError::Other(e.to_string()))?;
    }
    write_atomic(
        &out.join("cells.csv"),
        &w.into_inner()
            .map_err(|e| StudyError::Other(e.to_string()))?,
    )?;
    figure(cfg, &cells, out)?;
    let report = out.join("scale.md");
    let mut text = report_text(cfg, &planned, &outcomes, &cells, wall);
    if let Some((twin_planned, twin_outcomes, _)) = &twin {
        text.push_str(&twin_text(
            cfg,
            (&planned, &outcomes),
            (twin_planned, twin_outcomes),
        ));
    }
    write_atomic(&report, text.as_bytes())?;
    Ok(ScaleResult {
        report,
        cells,
        trials: outcomes.len(),
    })
}

/// Means per (side, team, method), in the config's order.
pub fn cells(
    cfg: &ScaleConfig,
    planned: &[ScalePlanned],
    outcomes: &[TrialOutcome],
) -> Vec<CellRow> {
    let mut rows = Vec::new();
    for &side in &cfg.sides {
        for &team in &cfg.teams {
            for method in &cfg.methods {
                let sel: Vec<&TrialOutcome> = planned
                    .iter()
                    .zip(outcomes)
                    .filter(|(p, _)| {
                        p.side == side && p.team == team && &p.planned.key.method == method
                    })
                    .map(|(_, o)| o)
                    .collect();
                let n = sel.len().max(1) as f64;
                rows.push(CellRow {
                    side,
                    team,
                    method: method.clone(),
                    trials: sel.len(),
                    completed: sel.iter().filter(|o| o.row.completed).count(),
                    tns: sel.iter().map(|o| tns(o)).sum::<f64>() / n,
                    ttd_m: sel.iter().map(|o| o.row.ttd).sum::<f64>() / n,
                    noli: sel.iter().map(|o| o.row.noli as f64).sum::<f64>() / n,
                    collisions: sel
                        .iter()
                        .filter_map(|o| o.row.continuous)
                        .map(|c| c.obstacle_collisions + c.robot_collisions)
                        .sum(),
                });
            }
        }
    }
    rows
}

/// The paired values of `metric` for `method` on side `side` and team `team`, in plan order
/// (so the same (map, start, seed) sits at the same index for every method and team).
fn paired(
    planned: &[ScalePlanned],
    outcomes: &[TrialOutcome],
    method: &str,
    side: Option<usize>,
    team: Option<usize>,
    metric: fn(&TrialOutcome) -> f64,
) -> Vec<f64> {
    planned
        .iter()
        .zip(outcomes)
        .filter(|(p, _)| {
            p.planned.key.method == method
                && side.is_none_or(|s| p.side == s)
                && team.is_none_or(|t| p.team == t)
        })
        .map(|(_, o)| metric(o))
        .collect()
}

/// The study's time metric: TNS in steps, or ET in seconds in the continuous world.
fn tns(o: &TrialOutcome) -> f64 {
    o.row.continuous.map_or(o.row.tns as f64, |c| c.et_s)
}
fn ttd(o: &TrialOutcome) -> f64 {
    o.row.ttd
}

fn p_text(p: f64) -> String {
    if p < 1e-3 {
        format!("{p:.1e}")
    } else {
        format!("{p:.3}")
    }
}

fn report_text(
    cfg: &ScaleConfig,
    planned: &[ScalePlanned],
    outcomes: &[TrialOutcome],
    cells: &[CellRow],
    wall: f64,
) -> String {
    let mut s = String::new();
    let (what, unit, cap, world) = match cfg.world {
        ScaleWorld::Grid => ("TNS", "steps", "step cap", "grid world"),
        ScaleWorld::Continuous => ("ET", "s", "time cap, s", "continuous world"),
    };
    let _ = writeln!(
        s,
        "# Scalability study ({world})\n\n{} trials ({} methods × sides {:?} × {} maps × starts {} × teams {:?} × {} seeds) at CSP {}, {:.1} min of this run's wall time.\nMean {what} ({unit}) / TTD (m) / NOLI, completed trials in brackets when not all; figure `fig7_scalability.png`.\n",
        outcomes.len(),
        cfg.methods.len(),
        cfg.sides,
        cfg.maps_per_side,
        cfg.starts.iter().map(|s| s.name()).collect::<Vec<_>>().join(", "),
        cfg.teams,
        cfg.seeds,
        cfg.csp,
        wall / 60.0
    );
    if cfg.world == ScaleWorld::Continuous {
        let sum = |f: fn(&crate::runner::ContinuousColumns) -> u64| {
            outcomes
                .iter()
                .filter_map(|o| o.row.continuous.as_ref())
                .map(f)
                .sum::<u64>()
        };
        let _ = writeln!(
            s,
            "Over all trials: {} robot–obstacle and {} robot–robot collisions, {} cells found impassable by a local planner, {} cells written off (a robot next to them could not read them; they count as explored), of which {} explorable ({:.1} % of all trials' explorable cells: explored unread), {} stuck events, {} of {} trials incomplete ({} stopped by the time cap, the others when no robot had a reachable frontier left).\n",
            sum(|c| c.obstacle_collisions),
            sum(|c| c.robot_collisions),
            sum(|c| c.impassable_cells),
            sum(|c| c.written_off_cells),
            sum(|c| c.unread_cells),
            100.0 * sum(|c| c.unread_cells) as f64 / sum(|c| c.explorable_cells).max(1) as f64,
            sum(|c| c.stuck),
            outcomes.iter().filter(|o| !o.row.completed).count(),
            outcomes.len(),
            planned
                .iter()
                .zip(outcomes)
                .filter(|(p, o)| !o.row.completed && tns(o) >= cfg.step_cap(p.side) as f64)
                .count()
        );
    }
    for &side in &cfg.sides {
        let _ = writeln!(
            s,
            "## {side} × {side} ({cap} {})\n\n| method | {} |\n|---|{}",
            cfg.step_cap(side),
            cfg.teams
                .iter()
                .map(|t| format!("{t} robots"))
                .collect::<Vec<_>>()
                .join(" | "),
            "---|".repeat(cfg.teams.len())
        );
        for method in &cfg.methods {
            let row: Vec<String> = cfg
                .teams
                .iter()
                .map(|&t| {
                    let c = cells
                        .iter()
                        .find(|c| c.side == side && c.team == t && &c.method == method)
                        .expect("every cell computed");
                    let done = if c.completed < c.trials {
                        format!(" ({}/{})", c.completed, c.trials)
                    } else {
                        String::new()
                    };
                    format!("{:.1} / {:.0} / {:.0}{done}", c.tns, c.ttd_m, c.noli)
                })
                .collect();
            let _ = writeln!(s, "| {method} | {} |", row.join(" | "));
        }
        let _ = writeln!(
            s,
            "\nAcross team sizes ({what}; Friedman over teams, blocks = map × start × seed; Wilcoxon between consecutive sizes):\n"
        );
        for method in &cfg.methods {
            let groups: Vec<Vec<f64>> = cfg
                .teams
                .iter()
                .map(|&t| paired(planned, outcomes, method, Some(side), Some(t), tns))
                .collect();
            let refs: Vec<&[f64]> = groups.iter().map(|g| g.as_slice()).collect();
            let fr = if refs.len() < 3 {
                "Friedman needs 3 or more team sizes".to_string()
            } else {
                friedman(&refs)
                    .map(|f| {
                        format!(
                            "Friedman χ² = {:.1}, p = {}",
                            f.statistic,
                            p_text(f.p_value)
                        )
                    })
                    .unwrap_or_else(|e| format!("Friedman not computed ({e})"))
            };
            let mut steps = Vec::new();
            let mut stops = None;
            for w in 0..cfg.teams.len().saturating_sub(1) {
                let (a, b) = (&groups[w], &groups[w + 1]);
                let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
                let (p, falls) = match wilcoxon(a, b) {
                    Ok(r) => (r.p_value, mean(b) < mean(a) && r.p_value < 0.05),
                    Err(_) => (1.0, false),
                };
                if !falls && stops.is_none() {
                    stops = Some(cfg.teams[w]);
                }
                steps.push(format!(
                    "{}→{}: {:+.1} (p {})",
                    cfg.teams[w],
                    cfg.teams[w + 1],
                    mean(b) - mean(a),
                    p_text(p)
                ));
            }
            let stop_text = match stops {
                Some(t) => format!("stops falling significantly after {t} robots"),
                None => "falls significantly at every step".into(),
            };
            let _ = writeln!(s, "- {method}: {fr}; {}; {stop_text}", steps.join(", "));
        }
        let _ = writeln!(s);
    }
    if cfg.methods.len() > 1 {
        let focus = &cfg.methods[0];
        let _ = writeln!(
            s,
            "## {focus} against the others\n\n| method | cells where {focus} has lower mean {what} | … and lower mean TTD | pooled {what} difference ({unit}) | Wilcoxon p ({what}) | pooled TTD difference (m) | Wilcoxon p (TTD) |\n|---|---|---|---|---|---|---|"
        );
        for other in &cfg.methods[1..] {
            let (mut lower_tns, mut lower_both, mut n) = (0, 0, 0);
            for &side in &cfg.sides {
                for &team in &cfg.teams {
                    let get = |m: &String| {
                        cells
                            .iter()
                            .find(|c| c.side == side && c.team == team && &c.method == m)
                            .expect("every cell computed")
                    };
                    let (a, b) = (get(focus), get(other));
                    n += 1;
                    lower_tns += (a.tns < b.tns) as usize;
                    lower_both += (a.tns < b.tns && a.ttd_m < b.ttd_m) as usize;
                }
            }
            let test = |metric: fn(&TrialOutcome) -> f64| {
                let x = paired(planned, outcomes, focus, None, None, metric);
                let y = paired(planned, outcomes, other, None, None, metric);
                let diff = (x.iter().sum::<f64>() - y.iter().sum::<f64>()) / x.len().max(1) as f64;
                let p = wilcoxon(&x, &y)
                    .map(|r| p_text(r.p_value))
                    .unwrap_or("–".into());
                (diff, p)
            };
            let (dt, pt) = test(tns);
            let (dd, pd) = test(ttd);
            let _ = writeln!(
                s,
                "| {other} | {lower_tns}/{n} | {lower_both}/{n} | {dt:+.2} | {pt} | {dd:+.1} | {pd} |"
            );
        }
    }
    s
}

/// Each method's time relative to the block's mean over methods (block = map × start × team ×
/// seed), averaged: below 1 is faster than the methods' average on the same trials.
fn relative_time(
    cfg: &ScaleConfig,
    planned: &[ScalePlanned],
    outcomes: &[TrialOutcome],
) -> Vec<f64> {
    let by_method: Vec<Vec<f64>> = cfg
        .methods
        .iter()
        .map(|m| paired(planned, outcomes, m, None, None, tns))
        .collect();
    let blocks = by_method.first().map_or(0, Vec::len);
    let block_mean =
        |b: usize| by_method.iter().map(|v| v[b]).sum::<f64>() / by_method.len() as f64;
    by_method
        .iter()
        .map(|v| (0..blocks).map(|b| v[b] / block_mean(b)).sum::<f64>() / blocks.max(1) as f64)
        .collect()
}

/// The continuous study beside its grid twin: the methods' ranking and each gap of the first
/// method to the others in both worlds, per side and pooled, with paired Wilcoxon tests.
fn twin_text(
    cfg: &ScaleConfig,
    continuous: (&[ScalePlanned], &[TrialOutcome]),
    grid: (&[ScalePlanned], &[TrialOutcome]),
) -> String {
    let mut s = String::new();
    let rank = |(p, o): (&[ScalePlanned], &[TrialOutcome])| {
        let rel = relative_time(cfg, p, o);
        let mut order: Vec<usize> = (0..cfg.methods.len()).collect();
        order.sort_by(|&a, &b| rel[a].total_cmp(&rel[b]));
        order
            .iter()
            .map(|&k| format!("{} {:.3}", cfg.methods[k], rel[k]))
            .collect::<Vec<_>>()
            .join(" < ")
    };
    let _ = writeln!(
        s,
        "## Grid and continuous worlds on the same maps

The grid twin (`grid/`) runs every trial of this study in the grid world: the scenes read as cells by the scenario's rule, the same start cells, teams, methods and seeds, TNS in steps. Ranking by mean time relative to the methods' mean on the same trial (below 1: faster):

- grid: {}
- continuous: {}
",
        rank(grid),
        rank(continuous)
    );
    let Some(focus) = cfg.methods.first() else {
        return s;
    };
    let _ = writeln!(
        s,
        "{focus} against each other method: mean time difference in % of the other's mean (negative: {focus} faster), paired Wilcoxon p over the same trials.

| side | method | grid Δ TNS | p | continuous Δ ET | p | same verdict |
|---|---|---|---|---|---|---|"
    );
    let sides: Vec<Option<usize>> = cfg
        .sides
        .iter()
        .map(|&x| Some(x))
        .chain(std::iter::once(None))
        .collect();
    for side in sides {
        for other in &cfg.methods[1..] {
            let gap = |(p, o): (&[ScalePlanned], &[TrialOutcome])| {
                let x = paired(p, o, focus, side, None, tns);
                let y = paired(p, o, other, side, None, tns);
                let (mx, my) = (mean_sd(&x).0, mean_sd(&y).0);
                let pct = 100.0 * (mx - my) / my.max(f64::MIN_POSITIVE);
                let p = wilcoxon(&x, &y).map(|r| r.p_value).ok();
                (pct, p)
            };
            let (gd, gp) = gap(grid);
            let (cd, cp) = gap(continuous);
            // A verdict: faster, slower or no difference at p < 0.05.
            let verdict = |d: f64, p: Option<f64>| match p {
                Some(p) if p < 0.05 => d.signum() as i32,
                _ => 0,
            };
            let same = if verdict(gd, gp) == verdict(cd, cp) {
                "yes"
            } else {
                "no"
            };
            let p_or = |p: Option<f64>| p.map_or("–".to_string(), p_text);
            let side_text = side.map_or("all".to_string(), |x| format!("{x}"));
            let _ = writeln!(
                s,
                "| {side_text} | {other} | {gd:+.1} % | {} | {cd:+.1} % | {} | {same} |",
                p_or(gp),
                p_or(cp)
            );
        }
    }
    s
}

fn figure(cfg: &ScaleConfig, cells: &[CellRow], out: &Path) -> Result<(), StudyError> {
    use madenet_plots::{line_panels, LinePanel, LineSeries};
    let panels: Vec<LinePanel> = cfg
        .sides
        .iter()
        .map(|&side| LinePanel {
            title: match cfg.world {
                ScaleWorld::Grid => format!("{side} × {side} cells"),
                ScaleWorld::Continuous => {
                    format!("{0} × {0} m", side as f64 * cfg.scenario.cell_size)
                }
            },
            x_label: "Robots".into(),
            y_label: match cfg.world {
                ScaleWorld::Grid => "Mean TNS (steps)".into(),
                ScaleWorld::Continuous => "Mean ET (s)".into(),
            },
            series: cfg
                .methods
                .iter()
                .map(|m| LineSeries {
                    name: m.clone(),
                    points: cfg
                        .teams
                        .iter()
                        .filter_map(|&t| {
                            cells
                                .iter()
                                .find(|c| c.side == side && c.team == t && &c.method == m)
                                .map(|c| (t as f64, c.tns))
                        })
                        .collect(),
                })
                .collect(),
        })
        .collect();
    line_panels(&out.join("fig7_scalability"), &panels, panels.len().min(2))
        .map_err(|e| StudyError::Other(e.to_string()))?;
    Ok(())
}
