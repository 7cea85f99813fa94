//! Every parameter of the continuous world in one struct, with its default and where the
//! default comes from. The scenario's own parameters (team size, d_s, CSP, dropout, the
//! discretization rule, |G|) stay in [`madenet_world::ScenarioConfig`], shared with the grid world.

use serde::{Deserialize, Serialize};

/// Why a [`ContinuousConfig`] cannot be used: names the field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("field `{field}` {message}")]
pub struct ConfigError {
    /// Dotted field name, e.g. `robot.max_speed`.
    pub field: String,
    /// What is wrong with it.
    pub message: String,
}

/// The longest trial, simulated seconds (`time_cap`'s upper bound).
pub const MAX_TIME_CAP: f64 = 1.0e7;

/// The robot: a differential-drive base with a round footprint. Defaults mimic a TurtleBot 2
/// (Kobuki base: 354 mm diameter, 0.7 m/s and 180°/s at most by its datasheet), cruising below
/// its limits as navigation stacks configure it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotConfig {
    /// Footprint radius in metres (Kobuki: 0.177).
    pub radius: f64,
    /// Top linear speed in m/s (0.5; Kobuki's hardware limit is 0.7).
    pub max_speed: f64,
    /// Top turn rate in rad/s (1.5; Kobuki's hardware limit is π).
    pub max_turn_rate: f64,
    /// Linear acceleration limit in m/s² (1.0).
    pub max_accel: f64,
    /// Angular acceleration limit in rad/s² (3.0).
    pub max_turn_accel: f64,
}

impl Default for RobotConfig {
    fn default() -> Self {
        RobotConfig {
            radius: 0.177,
            max_speed: 0.5,
            max_turn_rate: 1.5,
            max_accel: 1.0,
            max_turn_accel: 3.0,
        }
    }
}

/// The range sensor: a planar lidar by default (an RPLIDAR A1-like 360° scanner with one beam
/// per degree at 5 Hz, its range cut to d_s), or a camera-like limited field of view.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LidarConfig {
    /// Beams per scan, spread evenly over the field of view (360).
    pub beams: usize,
    /// Field of view in degrees, centred on the heading (360; a stereo camera: about 87).
    pub fov_deg: f64,
    /// Scans per second (5).
    pub rate_hz: f64,
    /// Standard deviation of the range noise in metres (0.01).
    pub range_noise: f64,
    /// Probability that a beam returns nothing (0.01).
    pub miss_prob: f64,
}

impl Default for LidarConfig {
    fn default() -> Self {
        LidarConfig {
            beams: 360,
            fov_deg: 360.0,
            rate_hz: 5.0,
            range_noise: 0.01,
            miss_prob: 0.01,
        }
    }
}

/// Each robot's occupancy-probability grid (log-odds, as gmapping, OctoMap and RTAB-Map keep
/// it) and how the agent's 1 m cells are read from it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MappingConfig {
    /// Pixel size in metres (0.1).
    pub resolution: f64,
    /// Log-odds added where a beam ends on a surface (0.85: OctoMap's hit probability 0.7).
    pub hit_log_odds: f64,
    /// Log-odds added along a beam's free path (−0.4: OctoMap's miss probability 0.4).
    pub miss_log_odds: f64,
    /// Lower clamp of a pixel's log-odds (−2.0: probability 0.12, OctoMap's).
    pub min_log_odds: f64,
    /// Upper clamp (3.5: probability 0.97, OctoMap's).
    pub max_log_odds: f64,
    /// A 1 m cell the robot has not found to be an obstacle becomes known free once this
    /// fraction of its pixels has been observed (0.5; ours: the paper does not say when a cell
    /// of an incrementally built map counts as explored).
    pub known_fraction: f64,
    /// Localization error (ours; the issue asks for it optional, off by default): each scan
    /// is integrated at the robot's true position plus zero-mean Gaussian noise of this
    /// standard deviation in metres per axis (0: the true pose) — a localizer's jitter,
    /// independent per scan, not drift. The robot still drives at its true pose.
    pub localization_noise_m: f64,
    /// The same for the heading, radians (0).
    pub localization_noise_rad: f64,
}

impl Default for MappingConfig {
    fn default() -> Self {
        MappingConfig {
            resolution: 0.1,
            hit_log_odds: 0.85,
            miss_log_odds: -0.4,
            min_log_odds: -2.0,
            max_log_odds: 3.5,
            known_fraction: 0.5,
            localization_noise_m: 0.0,
            localization_noise_rad: 0.0,
        }
    }
}

/// The local planner between the agent's cells (ours; see [`crate::local`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlannerConfig {
    /// Clearance kept beyond the footprint, in metres (0.05).
    pub safety_margin: f64,
    /// Pursuit lookahead along the local path, in metres (0.4).
    pub lookahead: f64,
    /// How far ahead, in seconds, the robot's own motion and its teammates' (at constant
    /// velocity, as TEB predicts them in the paper) are checked for contact (1.5).
    pub prediction_horizon: f64,
    /// Seconds without reaching the next cell, held up by teammates, after which the agent is
    /// asked again as if blocked (3.0).
    pub wait_time: f64,
    /// Seconds a robot whose agent said "stay" waits before asking again (1.0).
    pub stay_period: f64,
    /// The stuck rule: a robot that has not entered its target cell this many seconds after
    /// it was named finds that cell impassable (it becomes an obstacle to it, the agent plans
    /// anew) and the event is counted (30.0).
    pub stuck_time: f64,
}

impl Default for PlannerConfig {
    fn default() -> Self {
        PlannerConfig {
            safety_margin: 0.05,
            lookahead: 0.4,
            prediction_horizon: 1.5,
            wait_time: 3.0,
            stay_period: 1.0,
            stuck_time: 30.0,
        }
    }
}

/// The continuous world's parameters; [`ContinuousConfig::default`] documents each default.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ContinuousConfig {
    /// The robots' base.
    pub robot: RobotConfig,
    /// Their range sensor (its range is d_s: `sensing_range` cells of `cell_size` metres).
    pub lidar: LidarConfig,
    /// Their maps.
    pub mapping: MappingConfig,
    /// Their local planner.
    pub planner: PlannerConfig,
    /// Control and physics period in seconds (0.05: move_base's 20 Hz controller frequency).
    pub control_period: f64,
    /// Radio rounds per second: contacts, CSP draws and β exchanges (1.0; the dropout of
    /// `dropout_steps` counts rounds, so 7 rounds = 7 s as the paper's 7 timesteps).
    pub radio_rate_hz: f64,
    /// Simulated seconds after which a trial ends unfinished (1800).
    pub time_cap: f64,
    /// Seconds no robot's agent may have a reachable frontier before the trial ends
    /// unfinished: the team believes the map explored where the world does not (cells sealed
    /// off behind written-off ones), and stops as a real team would (10; at least
    /// `1 / radio_rate_hz` and `planner.stay_period`, checked: a last exchange may bring news and
    /// a robot told to stay asks again).
    pub no_frontier_time: f64,
}

impl Default for ContinuousConfig {
    fn default() -> Self {
        ContinuousConfig {
            robot: RobotConfig::default(),
            lidar: LidarConfig::default(),
            mapping: MappingConfig::default(),
            planner: PlannerConfig::default(),
            control_period: 0.05,
            radio_rate_hz: 1.0,
            time_cap: 1800.0,
            no_frontier_time: 10.0,
        }
    }
}

impl ContinuousConfig {
    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let positive = |field: &str, v: f64, max: f64| -> Result<(), ConfigError> {
            if v.is_finite() && v > 0.0 && v <= max {
                Ok(())
            } else {
                Err(ConfigError {
                    field: field.into(),
                    message: format!("must be a positive number at most {max}, got {v}"),
                })
            }
        };
        let r = &self.robot;
        positive("robot.radius", r.radius, 5.0)?;
        positive("robot.max_speed", r.max_speed, 20.0)?;
        positive("robot.max_turn_rate", r.max_turn_rate, 20.0)?;
        positive("robot.max_accel", r.max_accel, 100.0)?;
        positive("robot.max_turn_accel", r.max_turn_accel, 100.0)?;
        let l = &self.lidar;
        if !(1..=10_000).contains(&l.beams) {
            return Err(ConfigError {
                field: "lidar.beams".into(),
                message: format!("must lie in 1..=10000, got {}", l.beams),
            });
        }
        positive("lidar.fov_deg", l.fov_deg, 360.0)?;
        positive("lidar.rate_hz", l.rate_hz, 1000.0)?;
        for (field, v) in [
            ("lidar.range_noise", l.range_noise),
            ("lidar.miss_prob", l.miss_prob),
        ] {
            if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                return Err(ConfigError {
                    field: field.into(),
                    message: format!("must lie in [0, 1], got {v}"),
                });
            }
        }
        let m = &self.mapping;
        positive("mapping.resolution", m.resolution, 1.0)?;
        positive("mapping.hit_log_odds", m.hit_log_odds, 100.0)?;
        if !(m.miss_log_odds.is_finite() && m.miss_log_odds < 0.0) {
            return Err(ConfigError {
                field: "mapping.miss_log_odds".into(),
                message: format!("must be a negative number, got {}", m.miss_log_odds),
            });
        }
        if !(m.min_log_odds.is_finite()
            && m.max_log_odds.is_finite()
            && m.min_log_odds < 0.0
            && m.max_log_odds > 0.0)
        {
            return Err(ConfigError {
                field: "mapping.min_log_odds".into(),
                message: format!(
                    "the clamps must satisfy min_log_odds < 0 < max_log_odds, got {} and {}",
                    m.min_log_odds, m.max_log_odds
                ),
            });
        }
        positive("mapping.known_fraction", m.known_fraction, 1.0)?;
        for (field, v, max) in [
            ("mapping.localization_noise_m", m.localization_noise_m, 1.0),
            (
                "mapping.localization_noise_rad",
                m.localization_noise_rad,
                0.5,
            ),
        ] {
            if !(v.is_finite() && (0.0..=max).contains(&v)) {
                return Err(ConfigError {
                    field: field.into(),
                    message: format!("must lie in [0, {max}], got {v}"),
                });
            }
        }
        let p = &self.planner;
        if !(p.safety_margin.is_finite() && (0.0..=1.0).contains(&p.safety_margin)) {
            return Err(ConfigError {
                field: "planner.safety_margin".into(),
                message: format!("must lie in [0, 1] m, got {}", p.safety_margin),
            });
        }
        positive("planner.lookahead", p.lookahead, 10.0)?;
        positive("planner.prediction_horizon", p.prediction_horizon, 30.0)?;
        positive("planner.wait_time", p.wait_time, 3600.0)?;
        positive("planner.stay_period", p.stay_period, 3600.0)?;
        positive("planner.stuck_time", p.stuck_time, 1.0e6)?;
        positive("control_period", self.control_period, 1.0)?;
        positive("radio_rate_hz", self.radio_rate_hz, 1000.0)?;
        positive("time_cap", self.time_cap, MAX_TIME_CAP)?;
        positive("no_frontier_time", self.no_frontier_time, 1.0e7)?;
        // A team ends only after it could have heard each other and tried staying once more.
        let least = (1.0 / self.radio_rate_hz).max(p.stay_period);
        if self.no_frontier_time < least {
            return Err(ConfigError {
                field: "no_frontier_time".into(),
                message: format!(
                    "must be at least one radio round and one stay period ({least} s), got {}",
                    self.no_frontier_time
                ),
            });
        }
        if l.rate_hz * self.control_period > 1.0 + 1e-9 {
            return Err(ConfigError {
                field: "lidar.rate_hz".into(),
                message: format!(
                    "scans at most once per control period ({} Hz), got {} Hz",
                    1.0 / self.control_period,
                    l.rate_hz
                ),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_bad_fields_are_named() {
        assert_eq!(ContinuousConfig::default().validate(), Ok(()));
        let mut c = ContinuousConfig::default();
        c.robot.max_speed = 0.0;
        assert_eq!(c.validate().unwrap_err().field, "robot.max_speed");
        let mut c = ContinuousConfig::default();
        c.lidar.beams = 0;
        assert_eq!(c.validate().unwrap_err().field, "lidar.beams");
        let mut c = ContinuousConfig::default();
        c.mapping.miss_log_odds = f64::NAN;
        assert_eq!(c.validate().unwrap_err().field, "mapping.miss_log_odds");
        let mut c = ContinuousConfig::default();
        c.lidar.rate_hz = 50.0;
        assert_eq!(c.validate().unwrap_err().field, "lidar.rate_hz");
        let mut c = ContinuousConfig::default();
        c.no_frontier_time = 0.5 * c.planner.stay_period;
        assert_eq!(c.validate().unwrap_err().field, "no_frontier_time");
    }

    #[test]
    fn unknown_fields_are_rejected() {
        let err = toml::from_str::<ContinuousConfig>("[robot]\nmax_sped = 1.0\n").unwrap_err();
        assert!(err.to_string().contains("max_sped"), "{err}");
    }
}
