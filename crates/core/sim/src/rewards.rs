//! The trial's reward signal (paper Eq. 7 and 8): what a timestep was worth to each robot and
//! to the team, computed by the trial's last stage as a Gym environment computes its reward.
//! It is part of the simulator, not of a learner: it needs what only the trial sees between
//! the world's move and the robots' next observation (the cells each robot had not explored
//! yet, the contacts), and every consumer reads the same numbers — the Python environments,
//! MADE-Net's learners (Eq. 7 and 8 as written) and DME-DRL's (its own constants through
//! [`RewardConfig`]). No learning algorithm lives here.

use serde::{Deserialize, Serialize};

/// The constants of Eq. (7) and (8), defaults as in the paper.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RewardConfig {
    /// Reward per cell a robot observes that it had not explored (Eq. 7, c ∩ U: +1).
    pub new_cell: f64,
    /// Reward per cell a robot observes that it had already explored (Eq. 7, c ∩ E: −1).
    pub reobserved_cell: f64,
    /// Consecutive local-interaction steps ρ from which the penalty
    /// −(e^ρ / `interaction_scale`)^0.5 applies (Eq. 7: ρ ∈ [2, 7]).
    pub interaction_from: u32,
    /// The divisor of e^ρ in the interaction penalty (Eq. 7: 5).
    pub interaction_scale: f64,
    /// Above this ρ the penalty is `interaction_cap` (Eq. 7: 7).
    pub interaction_until: u32,
    /// The penalty for ρ above `interaction_until` (Eq. 7: −15).
    pub interaction_cap: f64,
    /// Team reward per timestep (Eq. 8: −1).
    pub step: f64,
    /// Team reward when exploration completes (Eq. 8: +100).
    pub completion: f64,
}

impl Default for RewardConfig {
    fn default() -> Self {
        RewardConfig {
            new_cell: 1.0,
            reobserved_cell: -1.0,
            interaction_from: 2,
            interaction_scale: 5.0,
            interaction_until: 7,
            interaction_cap: -15.0,
            step: -1.0,
            completion: 100.0,
        }
    }
}

impl RewardConfig {
    /// The interaction term of Eq. (7) for ρ = `interaction_steps` consecutive steps in local
    /// interaction.
    pub fn interaction_penalty(&self, interaction_steps: u32) -> f64 {
        let rho = interaction_steps; // ρ of Eq. (7)
        if rho < self.interaction_from {
            0.0
        } else if rho <= self.interaction_until {
            -((rho as f64).exp() / self.interaction_scale).sqrt()
        } else {
            self.interaction_cap
        }
    }

    /// Eq. (7) for one robot: `new` cells it observed that it had not explored, `reobserved`
    /// that it had, and ρ = `interaction_steps` consecutive steps in local interaction.
    pub fn robot(&self, new: usize, reobserved: usize, interaction_steps: u32) -> f64 {
        self.new_cell * new as f64
            + self.reobserved_cell * reobserved as f64
            + self.interaction_penalty(interaction_steps)
    }

    /// Eq. (8) for the team: distinct cells observed that the team had not known (`new`) and
    /// had (`reobserved`), the per-step cost, and the completion bonus.
    pub fn team(&self, new: usize, reobserved: usize, completed: bool) -> f64 {
        self.new_cell * new as f64
            + self.reobserved_cell * reobserved as f64
            + self.step
            + if completed { self.completion } else { 0.0 }
    }
}

/// The rewards of one timestep.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StepRewards {
    /// r_i of Eq. (7), per robot.
    pub robots: Vec<f64>,
    /// r of Eq. (8).
    pub team: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq7_by_hand() {
        let r = RewardConfig::default();
        // 12 new cells, 30 seen again, no interaction: 12 − 30.
        assert_eq!(r.robot(12, 30, 0), -18.0);
        assert_eq!(r.robot(12, 30, 1), -18.0);
        // ρ = 2: −(e² / 5)^0.5 = −(7.389056 / 5)^0.5 = −1.215653.
        assert!((r.interaction_penalty(2) + (7.38905609893065f64 / 5.0).sqrt()).abs() < 1e-12);
        assert!((r.interaction_penalty(2) + 1.215_653).abs() < 1e-6);
        // ρ = 7: −(e⁷ / 5)^0.5 = −(1096.633158 / 5)^0.5 = −14.809680.
        assert!((r.interaction_penalty(7) + 14.809_680).abs() < 1e-5);
        assert_eq!(r.interaction_penalty(8), -15.0);
        assert_eq!(r.interaction_penalty(50), -15.0);
        assert!((r.robot(5, 0, 3) - (5.0 - (3f64.exp() / 5.0).sqrt())).abs() < 1e-12);
    }

    #[test]
    fn eq8_by_hand() {
        let r = RewardConfig::default();
        assert_eq!(r.team(40, 10, false), 29.0); // 40 − 10 − 1
        assert_eq!(r.team(3, 77, true), 25.0); // 3 − 77 − 1 + 100
        assert_eq!(r.team(0, 0, false), -1.0);
    }
}
