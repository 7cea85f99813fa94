//! [`AgentView`]: what a policy may look at — one robot's own macro observation z_i.

use crate::belief::Belief;
use crate::goals::GoalCandidates;
use crate::messages::TeammateRecord;
use madenet_map::{Occupancy, Pos};
use madenet_nav::Dijkstra;

/// One robot's macro observation z_i = ⟨x_i, ϱ_i, β_i, m_i, |E_i|, 𝒢_i⟩ (Sec. III.C.1), lent
/// to its policy. It borrows the robot's navigator scratch so that distance queries are
/// cheap and can be reused for the path.
pub struct AgentView<'a> {
    /// Robot index i.
    pub id: usize,
    /// Current timestep.
    pub t: usize,
    /// x_i
    pub pos: Pos,
    /// ϱ_i: a teammate is detected within d_s this timestep.
    pub teammate_detected: bool,
    /// m_i and |E_i| (`belief.known_count()`).
    pub belief: &'a Belief,
    /// β_i: the last information heard from (or seen of) each teammate; own index included
    /// as an empty record.
    pub teammates: &'a [TeammateRecord],
    /// g_i^t: the robot's current goal (None: it has none).
    pub goal: Option<Pos>,
    /// g_i^{t-1}: the goal the robot had before the current one (None: none).
    pub prev_goal: Option<Pos>,
    /// d_s, the sensing range in cells (Sec. V.A.1): one source for every policy.
    pub sensing_range: i32,
    pub(crate) candidates: &'a GoalCandidates,
    pub(crate) dijkstra: &'a mut Dijkstra,
    pub(crate) dijkstra_fresh: &'a mut bool,
}

impl<'a> AgentView<'a> {
    /// Values per candidate in [`AgentView::write_candidate_features`].
    pub const CANDIDATE_FEATURES: usize = 9;
    /// Index of the [`crate::Spread`] score among a candidate's features (lower is better).
    pub const SPREAD_SCORE_FEATURE: usize = 7;
    /// Index of "[`crate::Spread`] would take this candidate" among a candidate's features.
    pub const SPREAD_CHOICE_FEATURE: usize = 8;

    /// 𝒢_i, the goal candidates (empty if the policy declared it does not need them).
    pub fn candidates(&self) -> &GoalCandidates {
        self.candidates
    }

    /// The frontier cell with the shortest path from the robot through known free cells not
    /// held by a teammate detected now (the robot's own cell excluded; ties to the lower
    /// row-major index).
    pub fn nearest_frontier(&mut self) -> Option<Pos> {
        let (belief, own) = (self.belief, self.belief.index(self.pos));
        self.search(|i, _| i != own && belief.is_frontier_index(i))
            .map(|i| belief.pos(i))
    }

    /// Dijkstra from the robot through known free cells not held by a teammate detected now,
    /// settling cells (row-major index, cost in units of [`madenet_nav::STRAIGHT`] per cell)
    /// in order of cost until `stop` returns true; see [`Dijkstra::run_indexed`]. The search
    /// tree is kept, so the navigator's path to a settled goal is free.
    ///
    /// Every search of the view (and the goal extraction) is this one search, stopped at
    /// different cells: the cells a stopped search settles have exactly the costs and parents
    /// of the full search, so whatever a policy queries, the navigator's path to a goal is the
    /// same (it searches on when the goal is not settled).
    pub fn search(&mut self, stop: impl FnMut(usize, u32) -> bool) -> Option<usize> {
        *self.dijkstra_fresh = true;
        search_from(self.dijkstra, self.belief, self.teammates, self.pos, stop)
    }
    /// The cost to a cell settled by the last [`AgentView::search`], in cells.
    pub fn searched_cost(&self, p: Pos) -> Option<f64> {
        self.dijkstra
            .settled_cost(p)
            .map(madenet_nav::cost_to_cells)
    }

    /// Path cost in cells from the robot through known free cells not held by a teammate
    /// detected now (as [`AgentView::search`] and the goal extraction), from the last search if
    /// it settled `to`, else from a full search, reused by the navigator. `None` if unreachable.
    pub fn path_cost(&mut self, to: Pos) -> Option<f64> {
        if !*self.dijkstra_fresh
            || self.dijkstra.source() != Some(self.pos)
            || self.dijkstra.settled_cost(to).is_none()
        {
            self.search(|_, _| false);
        }
        self.dijkstra
            .settled_cost(to)
            .map(madenet_nav::cost_to_cells)
    }

    /// Length of [`AgentView::macro_observation`] for `team` robots and `goals` candidates:
    /// 3 + 8 · (team − 1) + 3 · goals.
    pub fn macro_observation_len(team: usize, goals: usize) -> usize {
        3 + 8 * team.saturating_sub(1) + 3 * goals
    }

    /// The macro observation z_i without the map (the input of the networks' F3), as `f32`s:
    ///
    /// * own position (row, col), each divided by (height − 1, width − 1);
    /// * ϱ_i, the teammate-detected flag (0/1);
    /// * for each teammate in index order (self skipped): previous goal (2), last known
    ///   position (2), current goal (2) — normalised like the own position, −1 when unknown —
    ///   |E_j| over the number of cells, and a flag whether anything was ever heard or seen of
    ///   it;
    /// * the |G| goal candidates (2 each, normalised, −1 for an empty slot), then their
    ///   validity mask (0/1 each).
    pub fn macro_observation(&self) -> Vec<f32> {
        let mut z =
            vec![0.0; Self::macro_observation_len(self.teammates.len(), self.candidates.slots)];
        self.write_macro_observation(&mut z);
        z
    }

    /// A cell as the networks read it: (row, col) divided by the map's last row and column, so
    /// both lie in [0, 1]; `[-1, -1]` for no cell (a position or goal not known).
    pub fn normalized(&self, p: Option<Pos>) -> [f32; 2] {
        let b = self.belief;
        let (sr, sc) = (
            (b.height().max(2) - 1) as f32,
            (b.width().max(2) - 1) as f32,
        );
        match p {
            Some(p) => [p.row as f32 / sr, p.col as f32 / sc],
            None => [-1.0, -1.0],
        }
    }

    /// [`AgentView::macro_observation`] written into `z` (of exactly
    /// [`AgentView::macro_observation_len`] values): batched callers allocate nothing.
    ///
    /// # Panics
    /// If `z` has another length.
    pub fn write_macro_observation(&self, z: &mut [f32]) {
        assert_eq!(
            z.len(),
            Self::macro_observation_len(self.teammates.len(), self.candidates.slots),
            "macro observation length"
        );
        let b = self.belief;
        let coords = |p: Option<Pos>| self.normalized(p);
        let mut k = 0;
        let mut put = |vals: &[f32]| {
            z[k..k + vals.len()].copy_from_slice(vals);
            k += vals.len();
        };
        put(&coords(Some(self.pos)));
        put(&[self.teammate_detected as u8 as f32]);
        let cells = (b.width() * b.height()).max(1) as f32;
        for (j, rec) in self.teammates.iter().enumerate() {
            if j == self.id {
                continue;
            }
            put(&coords(rec.prev_goal));
            put(&coords(rec.last_pos()));
            put(&coords(rec.goal));
            put(&[
                rec.explored as f32 / cells,
                (rec.heard_at.is_some() || rec.seen_at.is_some()) as u8 as f32,
            ]);
        }
        for slot in 0..self.candidates.slots {
            put(&coords(self.candidates.get(slot)));
        }
        for slot in 0..self.candidates.slots {
            put(&[self.candidates.is_valid(slot) as u8 as f32]);
        }
    }

    /// Features per goal candidate: [`AgentView::CANDIDATE_FEATURES`] values for each of the
    /// |G| slots.
    pub fn candidate_features_len(goals: usize) -> usize {
        Self::CANDIDATE_FEATURES * goals
    }

    /// Each teammate's announced goal heard within [`crate::Spread::GOAL_MEMORY`] steps and
    /// last known position from within [`crate::Spread::POSITION_MEMORY`] (what the
    /// candidate features and [`crate::Spread`] weigh), in teammate order.
    pub fn recent_teammates(&self) -> Vec<(Option<Pos>, Option<Pos>)> {
        let recent = |at: Option<usize>, memory: usize| {
            at.is_some_and(|a| self.t.saturating_sub(a) <= memory)
        };
        self.teammates
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != self.id)
            .map(|(_, r)| {
                let goal = r
                    .goal
                    .filter(|_| recent(r.heard_at, crate::Spread::GOAL_MEMORY));
                let at = match (r.seen_at, r.heard_at) {
                    (Some(s), Some(h)) => Some(s.max(h)),
                    (s, h) => s.or(h),
                };
                (
                    goal,
                    r.last_pos()
                        .filter(|_| recent(at, crate::Spread::POSITION_MEMORY)),
                )
            })
            .collect()
    }

    /// Per-candidate inputs of the learned policy beyond the paper's (the `candidate-features`
    /// observation; zeros for an empty slot), with the view's d_s:
    ///
    /// 0. path cost from the robot (cells) / (height + width);
    /// 1. unknown cells within d_s (Chebyshev) of the candidate / (2 d_s + 1)², the information
    ///    to be gained there;
    /// 2. frontier cells within d_s / (2 d_s + 1)²;
    /// 3. distance (Chebyshev) to the nearest teammate goal announced within
    ///    [`crate::Spread::GOAL_MEMORY`] steps, / (4 d_s), capped at 1 (1: none);
    /// 4. the same for teammates' last known positions within [`crate::Spread::POSITION_MEMORY`];
    /// 5. the [`crate::Spread`] crowding count (teammates whose goal or position is within d_s) / 2;
    /// 6. rank of the path cost among the candidates / |G| (0 = nearest);
    /// 7. the [`crate::Spread`] score / (height + width);
    /// 8. 1 for the candidate [`crate::Spread`] would take, else 0.
    ///
    /// Costs are [`AgentView::path_cost`]s (the goal extraction's search when it is at hand).
    pub fn write_candidate_features(&mut self, out: &mut [f32]) {
        let slots = self.candidates.slots;
        assert_eq!(
            out.len(),
            Self::candidate_features_len(slots),
            "candidate features length"
        );
        out.fill(0.0);
        let b = self.belief;
        let ds = self.sensing_range.max(1);
        let window = ((2 * ds + 1) * (2 * ds + 1)) as f32;
        let mates = self.recent_teammates();
        let cells = self.candidates.cells.clone();
        let costs: Vec<f64> = cells
            .iter()
            .map(|&c| self.path_cost(c).unwrap_or(f64::MAX))
            .collect();
        let scale = (b.height() + b.width()) as f64;
        let near_cap = (4 * ds) as f32;
        for (k, &c) in self.candidates.cells.iter().enumerate().take(slots) {
            let f = &mut out[k * Self::CANDIDATE_FEATURES..(k + 1) * Self::CANDIDATE_FEATURES];
            f[0] = if costs[k] == f64::MAX {
                1.0
            } else {
                (costs[k] / scale) as f32
            };
            let (mut unknown, mut frontier) = (0, 0);
            for r in c.row - ds..=c.row + ds {
                for col in c.col - ds..=c.col + ds {
                    let q = Pos::new(r, col);
                    if b.in_bounds(q) {
                        unknown += (b.get(q) == Occupancy::Unknown) as u32;
                        frontier += b.is_frontier(q) as u32;
                    }
                }
            }
            f[1] = unknown as f32 / window;
            f[2] = frontier as f32 / window;
            type Mate = (Option<Pos>, Option<Pos>); // announced goal, last known position
            let nearest = |sel: &dyn Fn(&Mate) -> Option<Pos>| {
                mates
                    .iter()
                    .filter_map(sel)
                    .map(|p| p.chebyshev(c) as f32)
                    .fold(near_cap, f32::min)
                    / near_cap
            };
            f[3] = nearest(&|m| m.0);
            f[4] = nearest(&|m| m.1);
            let crowded = mates
                .iter()
                .filter(|m| {
                    m.0.is_some_and(|g| g.chebyshev(c) <= ds)
                        || m.1.is_some_and(|p| p.chebyshev(c) <= ds)
                })
                .count();
            f[5] = crowded as f32 / 2.0;
            let rank = costs
                .iter()
                .enumerate()
                .filter(|&(j, &x)| x < costs[k] || (x == costs[k] && j < k))
                .count();
            f[6] = rank as f32 / slots.max(1) as f32;
        }
        let scores = crate::Spread.scores(self);
        let best = scores
            .iter()
            .enumerate()
            .filter_map(|(k, s)| s.map(|s| (k, s)))
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        for (k, s) in scores.iter().enumerate().take(slots) {
            let f = &mut out[k * Self::CANDIDATE_FEATURES..(k + 1) * Self::CANDIDATE_FEATURES];
            f[Self::SPREAD_SCORE_FEATURE] = s.map_or(1.0, |s| (s / scale) as f32);
            f[Self::SPREAD_CHOICE_FEATURE] = (best.map(|b| b.0) == Some(k)) as u8 as f32;
        }
    }

    /// The paper's 4-channel binary map image of this robot, channel-major
    /// `[4][height][width]`: explored space, obstacles, observed robot positions (own and
    /// teammates' last known), goal candidates.
    pub fn map_image(&self) -> Vec<u8> {
        let mut img = vec![0u8; 4 * self.belief.width() * self.belief.height()];
        self.write_map_image(&mut img);
        img
    }

    /// [`AgentView::map_image`] written into `img` (4 · H · W values of any numeric type, e.g.
    /// `f32` for a network's or numpy's buffer).
    ///
    /// # Panics
    /// If `img` has another length.
    pub fn write_map_image<T: Copy + From<u8>>(&self, img: &mut [T]) {
        let b = self.belief;
        let n = b.width() * b.height();
        assert_eq!(img.len(), 4 * n, "map image length");
        let (zero, one) = (T::from(0), T::from(1));
        let (known, rest) = img.split_at_mut(n);
        let (obstacles, rest) = rest.split_at_mut(n);
        let (robots, goals) = rest.split_at_mut(n);
        write_known_and_obstacles(b.map(), known, obstacles);
        robots.fill(zero);
        robots[b.index(self.pos)] = one;
        for rec in self.teammates {
            if let Some(p) = rec.last_pos() {
                robots[b.index(p)] = one;
            }
        }
        goals.fill(zero);
        for &c in &self.candidates.cells {
            goals[b.index(c)] = one;
        }
    }
}

/// Channels 0 (explored) and 1 (obstacles) of a map image from `cells`, as numbers: on the
/// `Occupancy` codes 0/1/2 explored is `code != 0` and obstacle `code >> 1`, which compiles to
/// vector instructions. Also compiled for AVX2 and picked at run time where the CPU has it
/// (`multiversion`): widening bytes to floats takes one instruction there instead of four,
/// and this loop is a fifth of a primitive environment step's instructions.
#[multiversion::multiversion(targets("x86_64+avx2"))]
fn write_known_and_obstacles<T: Copy + From<u8>>(
    cells: &[Occupancy],
    known: &mut [T],
    obstacles: &mut [T],
) {
    let n = cells.len();
    for ((k, o), &c) in known[..n].iter_mut().zip(&mut obstacles[..n]).zip(cells) {
        let code = c as u8;
        *k = T::from((code != 0) as u8);
        *o = T::from(code >> 1);
    }
}

/// The one search of a robot: Dijkstra from `pos` through the known free cells of `belief`
/// not held by a teammate detected now (`teammates[j].detected`, at its `seen_pos`), until
/// `stop(cell, cost)` returns true. [`AgentView::search`], the goal extraction and the
/// navigator's path all use it, so a search stopped anywhere is a prefix of the full one.
pub(crate) fn search_from(
    dijkstra: &mut Dijkstra,
    belief: &Belief,
    teammates: &[TeammateRecord],
    pos: Pos,
    stop: impl FnMut(usize, u32) -> bool,
) -> Option<usize> {
    let map = belief.map();
    let mut held = teammates
        .iter()
        .filter(|r| r.detected)
        .filter_map(|r| r.seen_pos)
        .map(|p| belief.index(p));
    let (a, b) = (
        held.next().unwrap_or(usize::MAX),
        held.next().unwrap_or(usize::MAX),
    );
    if held.next().is_none() {
        // Up to two teammates in view (the paper's team of three): two compares per cell.
        dijkstra.run_indexed(
            pos,
            |i| map[i] == Occupancy::Free && i != a && i != b,
            belief.movement(),
            stop,
        )
    } else {
        let cells: Vec<usize> = teammates
            .iter()
            .filter(|r| r.detected)
            .filter_map(|r| r.seen_pos)
            .map(|p| belief.index(p))
            .collect();
        dijkstra.run_indexed(
            pos,
            |i| map[i] == Occupancy::Free && !cells.contains(&i),
            belief.movement(),
            stop,
        )
    }
}

/// The macro actions a robot may choose: its valid goal candidates, or — when it has none
/// (nothing reachable left to explore) — slot 0 alone, which then means "stay" (the agent
/// idles on an empty slot). Every argmax therefore has at least one admissible action.
pub fn action_mask(view: &AgentView<'_>) -> Vec<bool> {
    let mut mask = view.candidates().valid_mask();
    if !mask.iter().any(|&v| v) {
        if let Some(first) = mask.first_mut() {
            *first = true;
        }
    }
    mask
}

/// The merged map image a centralized policy (the CEP, Sec. III.C.2) sees, channel-major
/// `[4][H][W]`: explored space and obstacles of the team's merged map (`team_map`, row-major),
/// every robot's position, every robot's goal candidates.
///
/// # Panics
/// If `img` is not 4 × `team_map.len()` long.
pub fn write_joint_map_image<T: Copy + From<u8>>(
    views: &[AgentView<'_>],
    team_map: &[Occupancy],
    img: &mut [T],
) {
    let n = team_map.len();
    assert_eq!(img.len(), 4 * n, "joint map image length");
    let (zero, one) = (T::from(0), T::from(1));
    let (known, rest) = img.split_at_mut(n);
    let (obstacles, rest) = rest.split_at_mut(n);
    let (robots, goals) = rest.split_at_mut(n);
    write_known_and_obstacles(team_map, known, obstacles);
    robots.fill(zero);
    goals.fill(zero);
    for v in views {
        robots[v.belief.index(v.pos)] = one;
        for &c in &v.candidates().cells {
            goals[v.belief.index(c)] = one;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::messages::TeammateRecord;
    use madenet_map::Movement;

    #[test]
    fn map_image_channels() {
        let mut b = Belief::new(3, 4, Movement::default());
        b.observe(Pos::new(0, 0), Occupancy::Free);
        b.observe(Pos::new(0, 1), Occupancy::Obstacle);
        b.observe(Pos::new(1, 0), Occupancy::Free);
        let teammates = vec![
            TeammateRecord::default(),
            TeammateRecord {
                seen_pos: Some(Pos::new(2, 3)),
                seen_at: Some(5),
                ..Default::default()
            },
        ];
        let candidates = GoalCandidates {
            slots: 4,
            cells: vec![Pos::new(1, 0)],
        };
        let mut d = Dijkstra::new(3, 4);
        let mut fresh = false;
        let view = AgentView {
            id: 0,
            t: 5,
            pos: Pos::new(0, 0),
            teammate_detected: false,
            belief: &b,
            teammates: &teammates,
            goal: None,
            prev_goal: None,
            sensing_range: 4,
            candidates: &candidates,
            dijkstra: &mut d,
            dijkstra_fresh: &mut fresh,
        };
        let img = view.map_image();
        let n = 12;
        let ones = |c: usize| (0..n).filter(|&i| img[c * n + i] == 1).collect::<Vec<_>>();
        assert_eq!(ones(0), vec![0, 1, 4]); // explored: the three known cells
        assert_eq!(ones(1), vec![1]); // obstacles
        assert_eq!(ones(2), vec![0, 11]); // own position and the teammate's last known one
        assert_eq!(ones(3), vec![4]); // goal candidates
        assert!(img.iter().all(|&v| v <= 1));

        // Macro observation: own (0,0) → 0,0; ϱ 0; teammate 1: no goals (−1s), position (2,3)
        // → (1, 1), explored 0, known 1; candidate (1,0) → (0.5, 0), three empty slots, mask.
        let z = view.macro_observation();
        assert_eq!(z.len(), AgentView::macro_observation_len(2, 4));
        assert_eq!(
            z,
            vec![
                0.0, 0.0, 0.0, //
                -1.0, -1.0, 1.0, 1.0, -1.0, -1.0, 0.0, 1.0, //
                0.5, 0.0, -1.0, -1.0, -1.0, -1.0, -1.0, -1.0, //
                1.0, 0.0, 0.0, 0.0
            ]
        );
    }
}
