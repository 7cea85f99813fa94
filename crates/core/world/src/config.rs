//! [`ScenarioConfig`]: every convention of a trial in one documented, serde-able struct.
//!
//! Defaults are the paper's values (Tan et al., RA-L 2023, Sec. IV and V.A). Where the paper is
//! silent, the default follows the authors' evaluation code and the field says so.

use madenet_map::discretize::DiscretizeParams;
use madenet_map::Movement;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// How goal candidates are chosen ([`ScenarioConfig::candidate_rule`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CandidateRule {
    /// The nearest frontier cluster's representative, then farthest-point selection among the
    /// other clusters' representatives (straight-line distance), then among frontier cells.
    #[default]
    Paper,
    /// The representatives of the clusters in order of their nearest cell's path cost, then
    /// farthest-point selection among frontier cells when clusters run out.
    NearestClusters,
}

/// One scenario's parameters. Load from TOML with [`ScenarioConfig::from_toml_file`]; unknown
/// fields are rejected so a typo never silently falls back to a default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScenarioConfig {
    /// Team size |I| (paper: 3, Sec. V.A.2).
    pub num_robots: usize,
    /// Sensing range d_s in cells; the sensor sees the (2·d_s+1)² square around the robot, and
    /// robots communicate within Chebyshev distance d_s with line of sight (paper: 4, Sec. IV).
    pub sensing_range: i32,
    /// Probability that a cell in view is independently not observed in a timestep
    /// (paper: 0.1, Sec. V.A.2).
    pub sensor_miss_prob: f64,
    /// Probability that a move reaches the intended cell; otherwise the robot executes a
    /// uniformly random other legal move, staying included (paper: 0.9, Sec. V.A.2).
    pub motion_success_prob: f64,
    /// Diagonal moves past obstacle corners: `corner-cutting` (default: any free 8-neighbour,
    /// squeezing between diagonal obstacles — the rule of the paper's evaluation code, which
    /// its maps need) or `no-corner-cutting` (both orthogonal cells must be free; sensor rays
    /// are then blocked by such squeezes too, so what is seen can be approached).
    pub movement: Movement,
    /// Whether a robot that intends to stay can also slip (convention: false — a robot that
    /// does not move does not slip).
    pub slip_when_staying: bool,
    /// CSP: probability that an exchange between two robots that can talk succeeds
    /// (paper: 0, 0.5, 0.8, 1.0; default 1.0).
    pub comm_success_prob: f64,
    /// Timesteps a pair cannot exchange after a failed exchange; positions are still observed
    /// (paper: 7, Sec. V.A.3).
    pub dropout_steps: u32,
    /// Maximum number of timesteps of a trial (paper: 300, Sec. V.A.4).
    pub step_cap: usize,
    /// Robot cell size in metres (paper: 1 m cells). Every map is read at it: a map file of
    /// resolution r (any r ≤ `cell_size`: the pixels whose centres fall in a cell) and the
    /// built-in maps (1 m cells; a whole multiple of 1 m) are merged into cells of this size by
    /// the `discretize` rule.
    pub cell_size: f64,
    /// Rule for maps finer than `cell_size` (paper, Sec. V.B.1: a cell is an obstacle when
    /// more than 25 % of its pixels have occupancy probability above 0.65).
    pub discretize: DiscretizeParams,
    /// Number of goal candidates |G|; unset means Eq. (3),
    /// floor(4·log10(√|X| / (2·d_s+1))) + |I|, or |I| on maps too small for it
    /// ([`ScenarioConfig::goal_count_for`]).
    pub goal_count: Option<usize>,
    /// How the goal candidates 𝒢 are chosen among the frontier clusters (Sec. III.C.1):
    /// `paper` (default) — the nearest cluster, then farthest-point selection; or
    /// `nearest-clusters` — the clusters in order of path cost (ours: far, extreme candidates
    /// are rarely worth their trip).
    pub candidate_rule: CandidateRule,
    /// Plan among communicating robots with prioritized space-time A* (paper, Sec. III.C.5).
    pub prioritized_planning: bool,
    /// Space-time A* horizon in timesteps; beyond it reservations are ignored.
    pub plan_horizon: usize,
}

impl Default for ScenarioConfig {
    fn default() -> Self {
        ScenarioConfig {
            num_robots: 3,
            sensing_range: 4,
            sensor_miss_prob: 0.1,
            motion_success_prob: 0.9,
            movement: Movement::default(),
            slip_when_staying: false,
            comm_success_prob: 1.0,
            dropout_steps: 7,
            step_cap: 300,
            cell_size: 1.0,
            discretize: DiscretizeParams::default(),
            goal_count: None,
            candidate_rule: CandidateRule::Paper,
            prioritized_planning: true,
            plan_horizon: 24,
        }
    }
}

/// A bad configuration value or file; the message names the file (if any) and the field.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// A config file (or TOML text) that cannot be read, parsed or validated.
    #[error("{path}: {message}")]
    File {
        /// The file; `<toml>` for text given to [`ScenarioConfig::from_toml_str`].
        path: String,
        /// What is wrong (a bad field's message is prefixed with ``field `name`: ``).
        message: String,
    },
    /// A field whose value is out of its range (from [`ScenarioConfig::validate`]).
    #[error("config field `{field}`: {message}")]
    Field {
        /// The field's name as in TOML, e.g. `sensing_range` or `discretize.occupied_prob`.
        field: &'static str,
        /// What the field must be and what it was, e.g. `must be at least 1`.
        message: String,
    },
}

fn field(field: &'static str, message: impl Into<String>) -> ConfigError {
    ConfigError::Field {
        field,
        message: message.into(),
    }
}

/// Checks `1 <= value <= max`; the message gives the range with `unit` (" cells", or "").
fn check_count<T>(name: &'static str, value: T, max: T, unit: &str) -> Result<(), ConfigError>
where
    T: PartialOrd + From<u8> + std::fmt::Display + Copy,
{
    if (T::from(1)..=max).contains(&value) {
        Ok(())
    } else {
        Err(field(
            name,
            format!("must be in 1..={max}{unit}, got {value}"),
        ))
    }
}

fn check_prob(name: &'static str, p: f64) -> Result<(), ConfigError> {
    if (0.0..=1.0).contains(&p) {
        Ok(())
    } else {
        Err(field(
            name,
            format!("must be a probability in [0, 1], got {p}"),
        ))
    }
}

impl ScenarioConfig {
    /// The file's config if a path is given (`--config`), else the paper's defaults.
    pub fn from_toml_file_or_default(path: Option<&Path>) -> Result<Self, ConfigError> {
        path.map_or_else(|| Ok(Self::default()), Self::from_toml_file)
    }

    /// Reads a TOML file; errors name the file and the offending key.
    pub fn from_toml_file(path: &Path) -> Result<Self, ConfigError> {
        let text = madenet_files::read_text_capped(path, madenet_files::InputKind::Config)
            .map_err(|e| ConfigError::File {
                path: path.display().to_string(),
                message: e.to_string(),
            })?;
        Self::from_toml_str(&text).map_err(|e| match e {
            ConfigError::File { message, .. } => ConfigError::File {
                path: path.display().to_string(),
                message,
            },
            ConfigError::Field { field, message } => ConfigError::File {
                path: path.display().to_string(),
                message: format!("field `{field}`: {message}"),
            },
        })
    }

    /// Parses TOML text and validates it.
    pub fn from_toml_str(text: &str) -> Result<Self, ConfigError> {
        let cfg: ScenarioConfig =
            madenet_files::parse_toml(text).map_err(|message| ConfigError::File {
                path: "<toml>".into(),
                message,
            })?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.num_robots == 0 {
            return Err(field("num_robots", "must be at least 1"));
        }
        if self.num_robots > MAX_ROBOTS {
            return Err(field(
                "num_robots",
                format!("at most {MAX_ROBOTS}, got {}", self.num_robots),
            ));
        }
        check_count(
            "sensing_range",
            self.sensing_range,
            MAX_SENSING_RANGE,
            " cells",
        )?;
        check_prob("sensor_miss_prob", self.sensor_miss_prob)?;
        check_prob("motion_success_prob", self.motion_success_prob)?;
        check_prob("comm_success_prob", self.comm_success_prob)?;
        check_count("step_cap", self.step_cap, MAX_STEP_CAP, "")?;
        if !(self.cell_size > 0.0 && self.cell_size.is_finite()) {
            return Err(field(
                "cell_size",
                format!(
                    "must be a positive number of metres, got {}",
                    self.cell_size
                ),
            ));
        }
        check_prob("discretize.occupied_prob", self.discretize.occupied_prob)?;
        check_prob(
            "discretize.obstacle_fraction",
            self.discretize.obstacle_fraction,
        )?;
        if self.goal_count == Some(0) {
            return Err(field("goal_count", "must be at least 1"));
        }
        if let Some(g) = self.goal_count.filter(|&g| g > MAX_GOALS) {
            return Err(field("goal_count", format!("at most {MAX_GOALS}, got {g}")));
        }
        check_count(
            "plan_horizon",
            self.plan_horizon,
            MAX_PLAN_HORIZON,
            " timesteps",
        )?;
        Ok(())
    }

    /// |G| for a map of `cells` cells: the configured value, or Eq. (3). Eq. (3) is defined
    /// only when the sensor window fits the map (2·d_s+1 ≤ √|X|); on smaller maps |G| is its
    /// minimum, |I| ("to provide each robot with a unique location to explore").
    pub fn goal_count_for(&self, cells: usize) -> usize {
        self.goal_count.unwrap_or_else(|| {
            goal_count_eq3(cells, self.sensing_range, self.num_robots).unwrap_or(self.num_robots)
        })
    }
}

/// Largest team a scenario may have (far beyond the paper's 3; keeps every buffer size sane).
pub const MAX_ROBOTS: usize = 256;
/// Largest configured |G|.
pub const MAX_GOALS: usize = 4096;
/// Largest d_s: the sensor's ray table grows as d_s⁴ (64 cells: ≈ 6 MB; 200: 0.6 GB).
pub const MAX_SENSING_RANGE: i32 = 64;
/// Largest space-time A* horizon: its reservation table holds cells × (horizon + 1) stamps.
pub const MAX_PLAN_HORIZON: usize = 256;
/// Largest step cap: a trial's per-step records grow with its steps.
pub const MAX_STEP_CAP: usize = 100_000;

/// Eq. (3): |G| = floor(4·log10(√|X| / (2·d_s+1))) + |I|, defined when 2·d_s+1 ≤ √|X|.
pub fn goal_count_eq3(cells: usize, sensing_range: i32, robots: usize) -> Option<usize> {
    let side = (cells as f64).sqrt();
    let window = (2 * sensing_range + 1) as f64;
    if window > side + 1e-9 {
        return None;
    }
    let extra = (4.0 * (side / window).log10() + 1e-9).floor().max(0.0) as usize;
    Some(extra + robots)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq3_matches_paper() {
        // 20×20, d_s = 4, 3 robots: floor(4·log10(20/9)) + 3 = 1 + 3 = 4 (paper Sec. IV).
        assert_eq!(goal_count_eq3(400, 4, 3), Some(4));
        // Smallest legal map: √|X| = 2·d_s+1 gives exactly |I|.
        assert_eq!(goal_count_eq3(81, 4, 3), Some(3));
        assert_eq!(goal_count_eq3(64, 4, 3), None);
        // 60×60 with d_s = 4: floor(4·log10(60/9)) = floor(3.296) = 3.
        assert_eq!(goal_count_eq3(3600, 4, 5), Some(8));
    }

    #[test]
    fn toml_round_trip_and_errors() {
        let cfg = ScenarioConfig {
            comm_success_prob: 0.5,
            ..Default::default()
        };
        let text = toml::to_string(&cfg).unwrap();
        assert_eq!(ScenarioConfig::from_toml_str(&text).unwrap(), cfg);
        let e = ScenarioConfig::from_toml_str("comm_success_prob = 1.5")
            .unwrap_err()
            .to_string();
        assert!(e.contains("comm_success_prob"), "{e}");
        let e = ScenarioConfig::from_toml_str("sensing_rnage = 3")
            .unwrap_err()
            .to_string();
        assert!(e.contains("sensing_rnage"), "{e}");
        let e = ScenarioConfig::from_toml_str("step_cap = \"x\"")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 1"), "{e}");
    }
}

#[cfg(test)]
mod shipped_config {
    use super::*;

    /// The documented example config in `configs/scenario.toml` lists exactly the defaults.
    #[test]
    fn shipped_example_equals_defaults() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../configs/scenario.toml");
        let cfg = ScenarioConfig::from_toml_file(&path).expect("shipped config parses");
        assert_eq!(cfg, ScenarioConfig::default());
    }
}
