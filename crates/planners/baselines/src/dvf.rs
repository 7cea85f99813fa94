//! PB: the Dec-MDP with distributed value functions (Matignon, Jeanpierre, Mouaddib, AAAI 2012),
//! solved online by value iteration, as the paper adapted it to square grids.

use madenet_agent::{AgentView, Belief, Decision, DecisionMode, Policy};
use madenet_map::{Movement, Occupancy, Pos};
use madenet_world::ScenarioConfig;
use serde::{Deserialize, Serialize};

/// PB's constants. Defaults are the values of the paper's evaluation code (`RobotMDP.py`),
/// which follows Matignon et al.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PbParams {
    /// Planning horizon: only cells within this Chebyshev distance of the robot are states
    /// (default 20).
    pub horizon: usize,
    /// Maximum value-iteration sweeps (default 50, the authors' `max_iterations`).
    pub iterations: usize,
    /// After at least `horizon + 1` sweeps (so values can cross the horizon), sweeping stops
    /// once no value changes by more than this (default 1.0, the authors' `minimum_change`).
    pub tolerance: f32,
    /// Discount γ (default 0.8: the authors' 1 − 80 / horizon²).
    pub discount: f32,
    /// f_ij: weight of a teammate's expected value in the distributed value function
    /// (default 4, the authors' `weighing_factor`).
    pub teammate_weight: f32,
    /// Extra repulsion c · Pr_j(s)² from where a teammate probably is (default 64 = the
    /// authors' `weighing_factor`³).
    pub crowding_weight: f32,
    /// Radius, in steps, of the cells a teammate is assumed able to reach right after contact;
    /// it grows by one step every two timesteps without contact (default 4, the authors'
    /// `exploration_horizon`).
    pub reach_radius: usize,
    /// A best next value within this of the current one means the MDP is stuck on a plateau:
    /// the robot then heads for the nearest frontier (default 1e-3, as the authors).
    pub stuck_threshold: f32,
}

impl Default for PbParams {
    fn default() -> Self {
        PbParams {
            horizon: 20,
            iterations: 50,
            tolerance: 1.0,
            discount: 0.8,
            teammate_weight: 4.0,
            crowding_weight: 64.0,
            reach_radius: 4,
            stuck_threshold: 1e-3,
        }
    }
}

/// The PB policy of one robot.
///
/// Each timestep, on the robot's own map:
///
/// 1. **Rewards.** R(s) = the unknown 8-neighbours of a known free cell s (the authors' cell
///    reward), 0 at the robot's own cell.
/// 2. **Teammates.** For each teammate whose last known position (detection or β) is within
///    the horizon: Pr_j(s), a probability spread over the free cells within
///    `reach_radius` + Δt/2 steps of that position, Δt the timesteps since it was last heard
///    or seen — 1 / (N · max(1, √d)) for a cell at Chebyshev distance d, N the number of such
///    cells (the authors' `compute_probability`); and V_j, its value function, estimated by
///    value iteration on the same rewards (on this map it is independent of j).
/// 3. **Distributed value function.** DVF(s) = Σ_j f · Pr_j(s) · |V_j(s)| + c · Pr_j(s)².
/// 4. **Value iteration** (Jacobi sweeps, deterministic moves to free 8-neighbours under the
///    movement rule): V(s) = R(s) + γ · max_{s'} (V(s') − DVF(s')), at least horizon + 1
///    sweeps, then until no value moves by more than `tolerance`, at most `iterations`.
/// 5. **Action.** The neighbouring free cell not held by a detected teammate with the highest
///    V (ties: the first in clockwise order from north); if its value is within
///    `stuck_threshold` of V(here), the MDP is stuck on a plateau and the robot heads for the
///    nearest frontier instead (as the authors' code).
///
/// Value iteration runs on flat `f32` arrays over a padded grid as vectorized element-wise
/// maxima, which is what makes it fast.
pub struct DistributedValueFunctions {
    p: PbParams,
    movement: Movement,
    /// Padded grid: (h + 2) × (w + 2), row-major.
    pw: usize,
    reward: Vec<f32>,
    value: Vec<f32>,
    next: Vec<f32>,
    dvf: Vec<f32>,
    team_value: Vec<f32>,
    /// 8 × cells: 0 where move d is allowed from a state, −∞ where not.
    penalty: Vec<f32>,
    best: Vec<f32>,
    /// State mask: known free and within the horizon.
    active: Vec<bool>,
    prob: Vec<f32>,
    bfs: Vec<u32>,
    queue: std::collections::VecDeque<usize>,
}

/// [`madenet_map::RING8`] as offsets into padded index arithmetic.
const DIRS: [(isize, isize); 8] = {
    let mut d = [(0isize, 0isize); 8];
    let mut k = 0;
    while k < 8 {
        d[k] = (
            madenet_map::RING8[k].0 as isize,
            madenet_map::RING8[k].1 as isize,
        );
        k += 1;
    }
    d
};

impl DistributedValueFunctions {
    /// The PB policy of a robot on a `height` × `width` map (cells), moving by `cfg`'s
    /// movement rule.
    pub fn new(p: PbParams, cfg: &ScenarioConfig, height: usize, width: usize) -> Self {
        let pw = width + 2;
        let n = (height + 2) * pw;
        DistributedValueFunctions {
            p,
            movement: cfg.movement,
            pw,
            reward: vec![0.0; n],
            value: vec![0.0; n],
            next: vec![0.0; n],
            dvf: vec![0.0; n],
            team_value: vec![0.0; n],
            penalty: Vec::new(),
            best: Vec::new(),
            active: vec![false; n],
            prob: vec![0.0; n],
            bfs: vec![u32::MAX; n],
            queue: std::collections::VecDeque::new(),
        }
    }

    #[inline]
    fn padded(&self, p: Pos) -> usize {
        (p.row as usize + 1) * self.pw + p.col as usize + 1
    }

    #[inline]
    fn offset(&self, k: usize) -> isize {
        DIRS[k].0 * self.pw as isize + DIRS[k].1
    }

    /// Rewards, states within the horizon, and the allowed moves (as penalties) of every state.
    fn prepare(&mut self, belief: &Belief, at: Pos) {
        let (h, w) = (belief.height(), belief.width());
        self.reward.fill(0.0);
        self.active.fill(false);
        let hz = self.p.horizon as i32;
        for r in 0..h {
            for c in 0..w {
                let i = r * w + c;
                if belief.map()[i] != Occupancy::Free {
                    continue;
                }
                let pos = Pos::new(r as i32, c as i32);
                if pos.chebyshev(at) > hz {
                    continue;
                }
                let k = self.padded(pos);
                self.active[k] = true;
                self.reward[k] = belief.unknown_neighbour_count(i) as f32;
            }
        }
        let own = self.padded(at);
        self.reward[own] = 0.0;
        // Per direction d and state k: 0 where the move is allowed, −∞ where not.
        let n = self.reward.len();
        self.penalty.clear();
        self.penalty.resize(8 * n, f32::NEG_INFINITY);
        let strict = self.movement == Movement::NoCornerCutting;
        let pw = self.pw as isize;
        for k in 0..n {
            if !self.active[k] {
                continue;
            }
            for (d, &(dr, dc)) in DIRS.iter().enumerate() {
                let nb = (k as isize + dr * pw + dc) as usize;
                if !self.active[nb] {
                    continue;
                }
                if strict && dr != 0 && dc != 0 {
                    let (a, b) = ((k as isize + dr * pw) as usize, (k as isize + dc) as usize);
                    if !(self.active[a] && self.active[b]) {
                        continue;
                    }
                }
                self.penalty[d * n + k] = 0.0;
            }
        }
    }

    /// Value iteration: V(s) = R(s) + γ · max over allowed moves of (V(s') − DVF(s')) (DVF
    /// only `with_dvf`); a state without moves keeps V = R. Jacobi sweeps written as eight
    /// shifted element-wise maxima over the padded grid, with a 0 / −∞ penalty per state and
    /// direction for disallowed moves, so the compiler vectorizes them.
    fn value_iteration(&mut self, with_dvf: bool) -> Vec<f32> {
        let n = self.reward.len();
        let pw = self.pw;
        let offsets: [isize; 8] = std::array::from_fn(|d| self.offset(d));
        let gamma = self.p.discount;
        let mut v = std::mem::take(&mut self.next);
        v.clone_from(&self.reward);
        let mut w = std::mem::take(&mut self.value);
        w.resize(n, 0.0);
        let mut best = std::mem::take(&mut self.best);
        best.resize(n, 0.0);
        // Interior range: every state and its 8 neighbours lie inside the padded grid.
        let (lo, hi) = (pw + 1, n - pw - 1);
        let len = hi - lo;
        let min_sweeps = (self.p.horizon + 1).min(self.p.iterations);
        for sweep in 0..self.p.iterations {
            if with_dvf {
                for ((wk, vk), dk) in w.iter_mut().zip(&v).zip(&self.dvf) {
                    *wk = vk - dk;
                }
            } else {
                w.copy_from_slice(&v);
            }
            // One fused pass: the 8 shifted neighbour values plus penalties, their maximum,
            // the new value and the largest change (slices of equal length, so the compiler
            // drops bounds checks and vectorizes across states).
            let src: [&[f32]; 8] = std::array::from_fn(|d| {
                let o = (lo as isize + offsets[d]) as usize;
                &w[o..o + len]
            });
            let pen: [&[f32]; 8] = std::array::from_fn(|d| &self.penalty[d * n + lo..d * n + hi]);
            let (reward, out) = (&self.reward[lo..hi], &mut best[lo..hi]);
            let mut change = 0.0f32;
            bellman(&src, &pen, reward, out, gamma);
            for (vk, &nv) in v[lo..hi].iter_mut().zip(out.iter()) {
                let dv = (nv - *vk).abs();
                change = if dv > change { dv } else { change };
                *vk = nv;
            }
            if sweep + 1 >= min_sweeps && change < self.p.tolerance {
                break;
            }
        }
        self.value = w;
        self.best = best;
        v
    }

    /// Pr_j over free cells reachable within `radius` steps of `from` (breadth-first on the
    /// robot's map), 1 / (N · max(1, √d)) with d the Chebyshev distance to `from`.
    fn spread(&mut self, belief: &Belief, from: Pos, radius: usize) {
        self.prob.fill(0.0);
        let (h, w) = (belief.height(), belief.width());
        self.bfs.fill(u32::MAX);
        self.queue.clear();
        let start = from.row as usize * w + from.col as usize;
        self.bfs[start] = 0;
        self.queue.push_back(start);
        let mut cells = Vec::new();
        while let Some(i) = self.queue.pop_front() {
            cells.push(i);
            let d = self.bfs[i];
            if d as usize >= radius {
                continue;
            }
            let (r, c) = ((i / w) as isize, (i % w) as isize);
            for &(dr, dc) in &DIRS {
                let (nr, nc) = (r + dr, c + dc);
                if nr < 0 || nc < 0 || nr >= h as isize || nc >= w as isize {
                    continue;
                }
                let j = nr as usize * w + nc as usize;
                if self.bfs[j] == u32::MAX && belief.map()[j] == Occupancy::Free {
                    self.bfs[j] = d + 1;
                    self.queue.push_back(j);
                }
            }
        }
        let n = cells.len() as f32;
        for i in cells {
            let p = belief.pos(i);
            let d = p.chebyshev(from) as f32;
            let k = self.padded(p);
            self.prob[k] = 1.0 / (n * d.sqrt().max(1.0));
        }
    }
}

impl Policy for DistributedValueFunctions {
    fn name(&self) -> &str {
        "pb"
    }
    fn mode(&self) -> DecisionMode {
        DecisionMode::EveryStep
    }
    fn needs_candidates(&self) -> bool {
        false
    }
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision {
        let belief = view.belief;
        let at = view.pos;
        self.prepare(belief, at);
        // Teammates within the horizon, where they probably are.
        let mates: Vec<(Pos, usize)> = view
            .teammates
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != view.id)
            .filter_map(|(_, r)| {
                let pos = r.last_pos()?;
                let last = r.heard_at.into_iter().chain(r.seen_at).max()?;
                Some((pos, view.t.saturating_sub(last)))
            })
            .filter(|(pos, _)| pos.chebyshev(at) < self.p.horizon as i32)
            .collect();
        self.dvf.fill(0.0);
        if !mates.is_empty() {
            self.team_value = self.value_iteration(false);
            for (pos, dt) in mates {
                if belief.get(pos) != Occupancy::Free {
                    continue;
                }
                self.spread(belief, pos, self.p.reach_radius + dt / 2);
                for k in 0..self.dvf.len() {
                    let pr = self.prob[k];
                    if pr > 0.0 {
                        self.dvf[k] += self.p.teammate_weight * pr * self.team_value[k].abs()
                            + self.p.crowding_weight * pr * pr;
                    }
                }
            }
        }
        let v = self.value_iteration(true);
        // The best move from here, avoiding teammates it can see.
        let here = self.padded(at);
        let held: Vec<usize> = view
            .teammates
            .iter()
            .filter(|r| r.detected)
            .filter_map(|r| r.seen_pos)
            .map(|p| self.padded(p))
            .collect();
        let mut best: Option<(f32, usize)> = None;
        let cells = self.reward.len();
        for d in 0..8 {
            if self.penalty[d * cells + here] != 0.0 {
                continue;
            }
            let n = (here as isize + self.offset(d)) as usize;
            if held.contains(&n) {
                continue;
            }
            if best.is_none_or(|(bv, _)| v[n] > bv) {
                best = Some((v[n], d));
            }
        }
        self.next = v;
        match best {
            Some((bv, d)) if (bv - self.next[here]).abs() >= self.p.stuck_threshold => {
                Decision::Goal(Pos::new(
                    at.row + DIRS[d].0 as i32,
                    at.col + DIRS[d].1 as i32,
                ))
            }
            _ => match view.nearest_frontier() {
                Some(p) => Decision::Goal(p),
                None => Decision::Idle,
            },
        }
    }
}

/// One Bellman backup of every state: out = R + γ · max_d (src_d + pen_d), or R without moves.
/// Element-wise only, so the result is the same whatever the vector width; on x86-64 with
/// AVX2 the same code is compiled a second time for 8 lanes and chosen at run time.
fn bellman(src: &[&[f32]; 8], pen: &[&[f32]; 8], reward: &[f32], out: &mut [f32], gamma: f32) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, checked just above.
        unsafe { bellman_avx2(src, pen, reward, out, gamma) };
        return;
    }
    bellman_body(src, pen, reward, out, gamma);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn bellman_avx2(
    src: &[&[f32]; 8],
    pen: &[&[f32]; 8],
    reward: &[f32],
    out: &mut [f32],
    gamma: f32,
) {
    bellman_body(src, pen, reward, out, gamma);
}

#[inline(always)]
fn bellman_body(src: &[&[f32]; 8], pen: &[&[f32]; 8], reward: &[f32], out: &mut [f32], gamma: f32) {
    let len = out.len();
    let (reward, src, pen) = (
        &reward[..len],
        src.map(|s| &s[..len]),
        pen.map(|p| &p[..len]),
    );
    for i in 0..len {
        let mut b = f32::NEG_INFINITY;
        for d in 0..8 {
            let y = src[d][i] + pen[d][i];
            b = if y > b { y } else { b };
        }
        out[i] = if b == f32::NEG_INFINITY {
            reward[i]
        } else {
            reward[i] + gamma * b
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn padded_layout_round_trips() {
        let pb =
            DistributedValueFunctions::new(PbParams::default(), &ScenarioConfig::default(), 5, 7);
        assert_eq!(pb.padded(Pos::new(0, 0)), 9 + 1);
        assert_eq!(pb.value.len(), 7 * 9);
        assert_eq!(pb.offset(0), -9);
    }

    /// A 1 × 3 corridor of states a – b – c (a padded grid's middle row) with rewards
    /// R = (0, 0, 4), γ = 0.5 and moves only along the corridor.
    fn corridor(iterations: usize, tolerance: f32) -> DistributedValueFunctions {
        let p = PbParams {
            horizon: 0,
            iterations,
            tolerance,
            discount: 0.5,
            ..PbParams::default()
        };
        let mut pb = DistributedValueFunctions::new(p, &ScenarioConfig::default(), 1, 3);
        let n = pb.reward.len();
        let [a, b, c] = [0, 1, 2].map(|col| pb.padded(Pos::new(0, col)));
        pb.reward[c] = 4.0;
        pb.penalty = vec![f32::NEG_INFINITY; 8 * n];
        let (east, west) = (2, 6); // DIRS[2] = (0, 1), DIRS[6] = (0, -1)
        for k in [a, b] {
            pb.penalty[east * n + k] = 0.0;
        }
        for k in [b, c] {
            pb.penalty[west * n + k] = 0.0;
        }
        pb
    }

    fn corridor_values(pb: &DistributedValueFunctions, v: &[f32]) -> [f32; 3] {
        [0, 1, 2].map(|col| v[pb.padded(Pos::new(0, col))])
    }

    /// Jacobi sweeps by hand from V = R = (0, 0, 4): V(s) = R(s) + γ · max over neighbours.
    /// Sweep 1: (0, 0.5·4, 4 + 0.5·0) = (0, 2, 4); sweep 2: (0.5·2, 0.5·4, 4 + 0.5·2) =
    /// (1, 2, 5); the fixed point solves c = 4 + b/2, b = c/2, a = b/2: (4/3, 8/3, 16/3).
    #[test]
    fn value_iteration_matches_hand_computed_sweeps() {
        for (iterations, want) in [(1, [0.0, 2.0, 4.0]), (2, [1.0, 2.0, 5.0])] {
            let mut pb = corridor(iterations, 0.0);
            let v = pb.value_iteration(false);
            assert_eq!(corridor_values(&pb, &v), want, "{iterations} sweeps");
        }
        let mut pb = corridor(200, 1e-6);
        let v = pb.value_iteration(false);
        let got = corridor_values(&pb, &v);
        for (g, w) in got.iter().zip([4.0 / 3.0, 8.0 / 3.0, 16.0 / 3.0]) {
            assert!((g - w).abs() < 1e-4, "{got:?}");
        }
    }

    /// The DVF is subtracted from the successor's value: with DVF(c) = 10, b's best successor
    /// is a (V(a) − 0 > V(c) − 10), so nothing of c's reward flows left of c. The fixed point
    /// is then a = b = 0 and c = 4 + γ · V(b) = 4.
    #[test]
    fn value_iteration_subtracts_the_distributed_value_function() {
        let mut pb = corridor(200, 1e-6);
        let c = pb.padded(Pos::new(0, 2));
        pb.dvf[c] = 10.0;
        let v = pb.value_iteration(true);
        assert_eq!(corridor_values(&pb, &v), [0.0, 0.0, 4.0]);
        // Without the DVF the same corridor carries the reward left.
        let v = pb.value_iteration(false);
        assert!(corridor_values(&pb, &v)[0] > 1.0);
    }

    /// A state without allowed moves keeps V = R, whatever the sweeps.
    #[test]
    fn a_state_without_moves_keeps_its_reward() {
        let mut pb = corridor(5, 0.0);
        let n = pb.reward.len();
        let c = pb.padded(Pos::new(0, 2));
        for d in 0..8 {
            pb.penalty[d * n + c] = f32::NEG_INFINITY;
        }
        let v = pb.value_iteration(false);
        assert_eq!(v[c], 4.0);
        // b still sees c: 0 + 0.5 · 4.
        assert_eq!(v[pb.padded(Pos::new(0, 1))], 2.0);
    }

    /// `prepare` on a 3 × 3 belief, robot at the centre: rewards are the unknown in-bounds
    /// 8-neighbours of known free cells (0 at the robot's own cell), and under the
    /// no-corner-cutting rule a diagonal move needs both side cells free.
    #[test]
    fn prepare_sets_rewards_and_allowed_moves() {
        let mut belief = Belief::new(3, 3, Movement::NoCornerCutting);
        for (r, c) in [(1, 1), (1, 2), (2, 2)] {
            belief.observe(Pos::new(r, c), Occupancy::Free);
        }
        belief.observe(Pos::new(2, 1), Occupancy::Obstacle);
        let cfg = ScenarioConfig {
            movement: Movement::NoCornerCutting,
            ..ScenarioConfig::default()
        };
        let mut pb = DistributedValueFunctions::new(PbParams::default(), &cfg, 3, 3);
        pb.prepare(&belief, Pos::new(1, 1));
        let k = |r, c| pb.padded(Pos::new(r, c));
        // (1, 2): neighbours (0, 1), (0, 2) unknown; (1, 1), (2, 1), (2, 2) known → 2.
        // (2, 2): neighbours (1, 1), (1, 2), (2, 1) all known → 0.
        assert_eq!(pb.reward[k(1, 1)], 0.0);
        assert_eq!(pb.reward[k(1, 2)], 2.0);
        assert_eq!(pb.reward[k(2, 2)], 0.0);
        assert!(pb.active[k(1, 1)] && pb.active[k(2, 2)] && !pb.active[k(2, 1)]);
        let n = pb.reward.len();
        let allowed = |from: usize, d: usize| pb.penalty[d * n + from] == 0.0;
        assert!(allowed(k(1, 1), 2)); // east to (1, 2)
        assert!(!allowed(k(1, 1), 3)); // south-east to (2, 2): (2, 1) is occupied
        assert!(allowed(k(1, 2), 4)); // south to (2, 2)
        assert!(!allowed(k(1, 1), 4)); // south into the obstacle
        assert!(!allowed(k(1, 1), 0)); // north into unknown space
    }
}
