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
    /// The robot's current and previous goal.
    pub goal: Option<Pos>,
    pub prev_goal: Option<Pos>,
    pub(crate) candidates: &'a GoalCandidates,
    pub(crate) dijkstra: &'a mut Dijkstra,
    pub(crate) dijkstra_fresh: &'a mut bool,
}

impl<'a> AgentView<'a> {
    /// 𝒢_i, the goal candidates (empty if the policy declared it does not need them).
    pub fn candidates(&self) -> &GoalCandidates {
        self.candidates
    }

    /// The frontier cell with the shortest path from the robot through known free cells not
    /// held by a teammate detected now (the robot's own cell excluded; ties to the lower
    /// row-major index).
    pub fn nearest_frontier(&mut self) -> Option<Pos> {
        let (belief, own) = (self.belief, self.belief.index(self.pos));
        self.search(|i, _| i != own && belief.is_frontier_index(i)).map(|i| belief.pos(i))
    }

    /// Dijkstra from the robot through known free cells not held by a teammate detected now,
    /// settling cells (row-major index, cost in units of [`madenet_nav::STRAIGHT`] per cell)
    /// in order of cost until `stop` returns true; see [`Dijkstra::run_indexed`]. The search
    /// tree is kept, so the navigator's path to a settled goal is free.
    pub fn search(&mut self, stop: impl FnMut(usize, u32) -> bool) -> Option<usize> {
        let belief = self.belief;
        let map = belief.map();
        let mut held = self.teammates.iter().filter(|r| r.detected).filter_map(|r| r.seen_pos).map(|p| belief.index(p));
        let (a, b) = (held.next().unwrap_or(usize::MAX), held.next().unwrap_or(usize::MAX));
        *self.dijkstra_fresh = true;
        if held.next().is_none() {
            // Up to two teammates in view (the paper's team of three): two compares per cell.
            self.dijkstra.run_indexed(self.pos, |i| map[i] == Occupancy::Free && i != a && i != b, belief.movement(), stop)
        } else {
            let cells: Vec<usize> = self.teammates.iter().filter(|r| r.detected).filter_map(|r| r.seen_pos).map(|p| belief.index(p)).collect();
            self.dijkstra.run_indexed(self.pos, |i| map[i] == Occupancy::Free && !cells.contains(&i), belief.movement(), stop)
        }
    }

    /// The cost to a cell settled by the last [`AgentView::search`], in cells.
    pub fn searched_cost(&self, p: Pos) -> Option<f64> {
        self.dijkstra.settled_cost(p).map(madenet_nav::cost_to_cells)
    }

    /// Path cost in cells from the robot to every known-free cell, computed once (full
    /// Dijkstra) and reused by the navigator. `None` if unreachable.
    pub fn path_cost(&mut self, to: Pos) -> Option<f64> {
        if !*self.dijkstra_fresh || self.dijkstra.settled_cost(to).is_none() {
            let (belief, from) = (self.belief, self.pos);
            self.dijkstra.run(from, |p| belief.is_free(p), belief.movement(), |_| false);
            *self.dijkstra_fresh = true;
        }
        self.dijkstra.settled_cost(to).map(madenet_nav::cost_to_cells)
    }

    /// The paper's 4-channel binary map image of this robot, channel-major
    /// `[4][height][width]`: explored space, obstacles, observed robot positions (own and
    /// teammates' last known), goal candidates.
    pub fn map_image(&self) -> Vec<u8> {
        let b = self.belief;
        let n = b.width() * b.height();
        let mut img = vec![0u8; 4 * n];
        for (i, &o) in b.map().iter().enumerate() {
            img[i] = (o != Occupancy::Unknown) as u8;
            img[n + i] = (o == Occupancy::Obstacle) as u8;
        }
        img[2 * n + b.index(self.pos)] = 1;
        for rec in self.teammates {
            if let Some(p) = rec.last_pos() {
                img[2 * n + b.index(p)] = 1;
            }
        }
        for &c in &self.candidates.cells {
            img[3 * n + b.index(c)] = 1;
        }
        img
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
            TeammateRecord { seen_pos: Some(Pos::new(2, 3)), seen_at: Some(5), ..Default::default() },
        ];
        let candidates = GoalCandidates { slots: 4, cells: vec![Pos::new(1, 0)] };
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
    }
}
