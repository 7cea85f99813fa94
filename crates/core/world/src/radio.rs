//! The paper's communication model as its own component: which pairs of robots in contact
//! exchange β this timestep.
//!
//! Two robots in contact (within d_s and in line of sight, decided by the world's sensing) try to
//! exchange; the attempt succeeds with probability `comm_success_prob` (CSP), and a failure
//! silences that pair for `dropout_steps` timesteps (paper Sec. V.A). [`crate::World`] runs one
//! in process; the decentralized runtime runs one in its radio node, fed the world's contacts,
//! with the same seeded stream (`comm`), so both deliver exactly the same messages.

use crate::rng::{stream, Rng};
use crate::ScenarioConfig;
use rand::RngExt;

/// The communication model of one trial.
#[derive(Clone, Debug)]
pub struct Radio {
    comm_success_prob: f64,
    dropout_steps: u32,
    robots: usize,
    rng: Rng,
    /// Remaining dropout steps per robot pair (i < j), indexed i·n + j.
    dropout: Vec<u32>,
}

impl Radio {
    /// The radio of a trial with `robots` robots, `cfg`'s CSP and dropout, and `seed`'s `comm`
    /// stream.
    pub fn new(cfg: &ScenarioConfig, robots: usize, seed: u64) -> Self {
        Radio {
            comm_success_prob: cfg.comm_success_prob,
            dropout_steps: cfg.dropout_steps,
            robots,
            rng: stream(seed, "comm", 0),
            dropout: vec![0; robots * robots],
        }
    }

    /// One timestep: every dropout counts down, then each pair in `contacts` (i < j, in
    /// lexicographic order, as the world lists them) that is not in a dropout tries to
    /// exchange. Returns the pairs that did, in the same order.
    pub fn exchange(&mut self, contacts: &[(usize, usize)], out: &mut Vec<(usize, usize)>) {
        out.clear();
        let n = self.robots;
        // A pair is silent this timestep when its counter was running at the timestep's start;
        // counting down afterwards changes no draw (a failure sets the counter anew).
        let silent: Vec<bool> = contacts
            .iter()
            .map(|&(i, j)| self.dropout[i * n + j] > 0)
            .collect();
        for d in self.dropout.iter_mut().filter(|d| **d > 0) {
            *d -= 1;
        }
        for (&(i, j), silent) in contacts.iter().zip(silent) {
            debug_assert!(i < j && j < n, "contacts are pairs i < j of this team");
            if silent {
                continue;
            }
            if self.rng.random::<f64>() < self.comm_success_prob {
                out.push((i, j));
            } else {
                self.dropout[i * n + j] = self.dropout_steps;
            }
        }
    }

    /// Remaining dropout steps of pair (i, j).
    pub fn dropout_remaining(&self, i: usize, j: usize) -> u32 {
        let (a, b) = if i < j { (i, j) } else { (j, i) };
        self.dropout[a * self.robots + b]
    }

    /// Replaces the random stream (see [`crate::World::reseed_noise`]).
    pub fn reseed(&mut self, rng: Rng) {
        self.rng = rng;
    }

    /// The radio of `Radio::new` with `seed`, reusing this one's allocation.
    pub fn restart(&mut self, seed: u64) {
        self.rng = stream(seed, "comm", 0);
        self.dropout.fill(0);
    }
}
