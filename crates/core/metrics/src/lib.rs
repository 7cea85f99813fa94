//! Per-trial metrics of the comparison study (paper Sec. V.A).
//!
//! A [`MetricsRecorder`] is fed one sample per timestep (explored fraction, team distance,
//! robot pairs in contact) and produces [`TrialMetrics`]:
//!
//! * **TNS** — timesteps to completion (the step cap if the trial did not complete);
//! * **TTD** — total travel distance, the sum of the robots' path lengths in metres;
//! * **NOLI** — number of local interactions: over timesteps t ≥ 1, the robot pairs within
//!   d_s and in line of sight (unordered pairs);
//! * the **exploration curve** — explored fraction (known cells, obstacles included, over
//!   explorable cells) against team distance, one point per timestep;
//! * **OFV** — the objective of Eq. (1) as the paper evaluates it: Σ over coverage levels
//!   p = 0.1, 0.1001, …, 1.0 of p / D(p), D(p) the team distance at which coverage p was
//!   reached (linear interpolation along the curve), see [`ofv`];
//! * **CT** — wall-clock time of the trial and per decision (kept apart from everything else,
//!   since it is the only non-deterministic number).

#![deny(missing_docs)]

use serde::{Deserialize, Serialize};

/// Coverage levels (percent) reported as "timesteps to N %", like the authors' `to_N`.
pub const COVERAGE_LEVELS: [u32; 9] = [20, 30, 40, 50, 60, 70, 80, 90, 100];

/// Deterministic metrics of one trial.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrialMetrics {
    /// The team explored every explorable cell before the step cap.
    pub completed: bool,
    /// TNS: timesteps to completion, or the step cap.
    pub tns: usize,
    /// TTD: team travel distance, metres.
    pub ttd: f64,
    /// NOLI: robot pairs in contact, summed over timesteps.
    pub noli: usize,
    /// NOLI as the authors' code counts it (`local_int`), for calibration: pairs at Chebyshev
    /// distance < d_s (strictly) with line of sight, over timesteps (their `RobotTeam` lists
    /// ordered pairs and `data_cleaning.create_data_entry` halves the count).
    pub noli_authors: usize,
    /// OFV: Eq. (1) over coverage levels, see [`ofv`].
    pub ofv: f64,
    /// Final explored fraction.
    pub explored: f64,
    /// Timesteps until coverage first reached 20 %, 30 %, …, 100 % (None: never).
    pub steps_to: Vec<Option<usize>>,
    /// Explored fraction after each timestep, index 0 = before the first move.
    pub explored_per_step: Vec<f64>,
    /// Team distance after each timestep, metres, aligned with `explored_per_step`.
    pub distance_per_step: Vec<f64>,
}

/// Wall-clock timings of one trial (not deterministic; reported as CT).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    /// Simulation time of the whole trial (world, agents, policies; no rendering), seconds.
    pub trial_s: f64,
    /// Decisions taken by all robots.
    pub decisions: usize,
    /// Mean wall time of one decision, seconds.
    pub per_decision_s: f64,
}

/// Collects one sample per timestep.
#[derive(Clone, Debug, Default)]
pub struct MetricsRecorder {
    explored: Vec<f64>,
    distance: Vec<f64>,
    noli: usize,
    noli_authors: usize,
}

impl MetricsRecorder {
    /// Starts with the state before the first move (distance 0).
    pub fn new(initial_explored: f64) -> Self {
        MetricsRecorder {
            explored: vec![initial_explored],
            distance: vec![0.0],
            noli: 0,
            noli_authors: 0,
        }
    }

    /// Records the state after a timestep: `pairs_in_contact` within d_s with line of sight,
    /// of which `pairs_closer` strictly closer than d_s.
    pub fn record(
        &mut self,
        explored: f64,
        team_distance: f64,
        pairs_in_contact: usize,
        pairs_closer: usize,
    ) {
        self.explored.push(explored);
        self.distance.push(team_distance);
        self.noli += pairs_in_contact;
        self.noli_authors += pairs_closer;
    }

    /// Ends the trial (`completed`: every explorable cell was explored before the step cap)
    /// and computes its [`TrialMetrics`]: TNS is the number of recorded timesteps.
    pub fn finish(self, completed: bool) -> TrialMetrics {
        let tns = self.explored.len() - 1;
        let steps_to = COVERAGE_LEVELS
            .iter()
            .map(|&n| {
                let p = n as f64 / 100.0;
                self.explored.iter().position(|&e| e >= p - 1e-12)
            })
            .collect();
        TrialMetrics {
            completed,
            tns,
            ttd: *self.distance.last().unwrap_or(&0.0),
            noli: self.noli,
            noli_authors: self.noli_authors,
            ofv: ofv(&self.explored, &self.distance),
            explored: *self.explored.last().unwrap_or(&0.0),
            steps_to,
            explored_per_step: self.explored,
            distance_per_step: self.distance,
        }
    }
}

/// Team distance at which coverage `p` was first reached, linearly interpolated between the
/// two timesteps that bracket it; `None` if never reached. Levels reached during the team's
/// first moving step get that step's distance (no interpolation from zero distance).
pub fn distance_at(p: f64, explored: &[f64], distance: &[f64]) -> Option<f64> {
    let k = explored.iter().position(|&e| e >= p)?;
    distance_at_step(p, k, explored, distance)
}

/// [`distance_at`] given `k`, the first step whose coverage reaches `p`.
fn distance_at_step(p: f64, k: usize, explored: &[f64], distance: &[f64]) -> Option<f64> {
    if k == 0 {
        return Some(distance[0]);
    }
    let (e0, e1) = (explored[k - 1], explored[k]);
    let (d0, d1) = (distance[k - 1], distance[k]);
    if d0 <= 0.0 {
        // The first moving step: interpolating from zero distance would make p / D(p)
        // arbitrarily large for levels just above the initial coverage.
        return Some(d1);
    }
    let f = if e1 > e0 { (p - e0) / (e1 - e0) } else { 1.0 };
    Some(d0 + f * (d1 - d0))
}

/// OFV, Eq. (1) as evaluated in the paper: Σ_{p = 0.1, 0.1001, …, 1.0} p / D(p).
///
/// Levels never reached contribute 0 (an incomplete trial scores lower), and levels reached
/// at zero distance (already covered by the first observation) are skipped, since p / 0 is
/// undefined.
pub fn ofv(explored: &[f64], distance: &[f64]) -> f64 {
    // Levels ascend, so the first step reaching each level only moves forward: one pass
    // over the levels, with D(p) = d0 + (p − e0)·slope inside each step's segment.
    let mut sum = 0.0;
    let mut k = 0;
    let mut level = 0u32;
    while level <= 9000 && k < explored.len() {
        let p = 0.1 + level as f64 * 1e-4;
        if explored[k] < p {
            k += 1;
            continue;
        }
        // Levels up to explored[k] are first reached at step k.
        let (base, slope) = match k {
            0 => (distance[0], 0.0),
            _ if distance[k - 1] <= 0.0 => (distance[k], 0.0),
            _ => {
                let (e0, e1, d0, d1) = (explored[k - 1], explored[k], distance[k - 1], distance[k]);
                if e1 > e0 {
                    let s = (d1 - d0) / (e1 - e0);
                    (d0 - e0 * s, s)
                } else {
                    (d1, 0.0)
                }
            }
        };
        while level <= 9000 {
            let p = 0.1 + level as f64 * 1e-4;
            if p > explored[k] {
                break;
            }
            let d = base + p * slope;
            if d > 0.0 {
                sum += p / d;
            }
            level += 1;
        }
        k += 1;
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_trial() {
        let mut r = MetricsRecorder::new(0.1);
        r.record(0.5, 10.0, 2, 1);
        r.record(1.0, 20.0, 1, 0);
        let m = r.finish(true);
        assert_eq!(m.tns, 2);
        assert_eq!(m.noli, 3);
        assert_eq!(m.noli_authors, 1);
        assert_eq!(m.ttd, 20.0);
        assert_eq!(m.steps_to[0], Some(1)); // 20 % reached at step 1
        assert_eq!(m.steps_to[8], Some(2));
        // D(p): 0.1 -> 0 (skipped); p in (0.1, 0.5]: 10 (first moving step); p in (0.5, 1]:
        // 10 + 10·(p−0.5)/0.5.
        assert_eq!(
            distance_at(0.3, &m.explored_per_step, &m.distance_per_step),
            Some(10.0)
        );
        assert!(
            (distance_at(0.75, &m.explored_per_step, &m.distance_per_step).unwrap() - 15.0).abs()
                < 1e-12
        );
        // OFV by a direct sum with the closed-form D(p).
        let mut want = 0.0;
        for k in 1..=9000 {
            let p = 0.1 + k as f64 * 1e-4;
            let d = if p <= 0.5 {
                10.0
            } else {
                10.0 + 20.0 * (p - 0.5)
            };
            want += p / d;
        }
        assert!((m.ofv - want).abs() < 1e-6 * want, "{} vs {want}", m.ofv);
    }

    #[test]
    fn unreached_levels_contribute_nothing() {
        let full = ofv(&[0.0, 0.5, 1.0], &[0.0, 10.0, 20.0]);
        let half = ofv(&[0.0, 0.5], &[0.0, 10.0]);
        assert!(half < full);
        assert!(half > 0.0);
        assert_eq!(ofv(&[0.05], &[0.0]), 0.0);
    }
}
