//! The scalability study's configuration: its grid of sides, teams, starts and methods, and
//! the checks of every field.

use crate::config::{field, StudyError};
use madenet_baselines::BaselineParams;
use madenet_map::Pos;
use madenet_world::ScenarioConfig;
use serde::{Deserialize, Serialize};
use std::path::Path;

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
    /// Run the known-map reference (`oracle-known-map`, [`madenet_baselines::reference`]) on every
    /// (map, start, team, seed) beside the methods, and report every method's distance to it
    /// and to the trials' lower bound. Grid world only (ignored in the continuous world).
    pub known_map: bool,
    /// Everything else about the world (`num_robots` and `comm_success_prob` are set per trial).
    pub scenario: ScenarioConfig,
    /// Parameters of the classical baselines.
    pub baselines: BaselineParams,
}

impl Default for ScaleConfig {
    fn default() -> Self {
        ScaleConfig {
            methods: ["made-net", "made-net-any", "nf", "ub", "pb", "spread"]
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
            known_map: true,
            scenario: ScenarioConfig::default(),
            baselines: BaselineParams::default(),
        }
    }
}

impl ScaleConfig {
    /// The continuous world's study as `madenet scale --world continuous` runs it: the paper's
    /// Fig. 7 grid (sides 20, 30, 40, 60 m; teams 2–6; starts BL, TR, M) on one generated
    /// scene per side, 3 seeds, methods made-net, made-net-any, nf, ub, spread (PB's cost grows with the
    /// team and its grid results trail UB's).
    pub fn continuous_default() -> Self {
        ScaleConfig {
            world: ScaleWorld::Continuous,
            methods: ["made-net", "made-net-any", "nf", "ub", "spread"]
                .map(String::from)
                .to_vec(),
            maps_per_side: 1,
            ..ScaleConfig::default()
        }
    }
}

impl ScaleConfig {
    /// Reads a TOML config; errors name the file, field and line.
    pub fn from_toml_file(path: &Path) -> Result<Self, StudyError> {
        crate::config::read_toml(path)
    }

    /// Checks every field; the message names it.
    pub fn validate(&self, registry: &madenet_sim::PolicyRegistry) -> Result<(), StudyError> {
        // A [continuous] section in a grid study would be ignored without a word (issue 59).
        if self.world == ScaleWorld::Grid
            && self.continuous != madenet_continuous::ContinuousConfig::default()
        {
            return Err(field(
                "continuous",
                "is set, but world is \"grid\": the section applies to world = \"continuous\" only",
            ));
        }
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
        // The caps the program derives from sides × steps_per_cell must be ones it accepts.
        let max_side = self.sides.iter().copied().max().unwrap_or(0);
        let mut caps = vec![(
            "scenario.step_cap",
            madenet_world::MAX_STEP_CAP as f64,
            ScaleConfig {
                world: ScaleWorld::Grid,
                ..self.clone()
            }
            .step_cap(max_side),
            "steps",
        )];
        if self.world == ScaleWorld::Continuous {
            caps.push((
                "continuous.time_cap",
                madenet_continuous::MAX_TIME_CAP,
                self.step_cap(max_side),
                "s",
            ));
        }
        for (what, limit, cap, unit) in caps {
            if cap as f64 > limit {
                return Err(field(
                    "sides/steps_per_cell",
                    format!(
                        "a side of {max_side} cells gives its trials a cap of {cap} {unit} ({} per cell × {max_side}², or the floor), above the largest {what}, {limit}: use smaller sides or a lower steps_per_cell",
                        self.steps_per_cell
                    ),
                ));
            }
        }
        if self.world == ScaleWorld::Continuous {
            let side_m = max_side as f64 * self.scenario.cell_size;
            let team = self.teams.iter().copied().max().unwrap_or(0);
            madenet_continuous::check_map_memory(&self.continuous, team, side_m, side_m)
                .map_err(|e| field("sides/teams", format!("on the largest side and team: {e}")))?;
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
}
