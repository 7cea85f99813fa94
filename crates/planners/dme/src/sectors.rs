//! The 8 angular sectors of DME-DRL's action space and their goals.
//!
//! Sector `k` holds the directions at angle θ ∈ [45°·k, 45°·(k+1)) measured counter-clockwise
//! from east (column +1), with north = row −1 (maps are drawn with row 0 at the top). The
//! original code assigns cells straight above or below the robot to the opposite side's sector
//! (a `tan = ±inf` quirk, see the design brief); here every direction has exactly one sector.

use madenet_agent::{AgentView, Belief};
use madenet_map::Pos;
use madenet_nav::Dijkstra;

/// Number of sectors (actions).
pub const SECTORS: usize = 8;

/// The sector of the direction from `from` to `to`; `None` for the same cell.
pub fn sector_of(from: Pos, to: Pos) -> Option<usize> {
    let (dx, dy) = ((to.col - from.col) as f64, (from.row - to.row) as f64);
    if dx == 0.0 && dy == 0.0 {
        return None;
    }
    let theta = dy.atan2(dx).to_degrees().rem_euclid(360.0);
    Some(((theta / 45.0) as usize).min(SECTORS - 1))
}

/// Per sector, the goal its action leads to: the reachable frontier cell in it with the
/// cheapest path (ties: lower row-major index), or `None` (the action is masked).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SectorGoals {
    /// `goals[k]`: sector k's goal cell, `None` if it holds no reachable frontier cell.
    pub goals: [Option<Pos>; SECTORS],
}

impl SectorGoals {
    /// Which actions may be chosen.
    pub fn mask(&self) -> [bool; SECTORS] {
        self.goals.map(|g| g.is_some())
    }
}

/// The best frontier cell per sector among the cells a cost-ordered search settles.
struct SectorBest {
    from: Pos,
    own: usize,
    best: [Option<(u32, usize)>; SECTORS],
}

impl SectorBest {
    fn visit(&mut self, belief: &Belief, i: usize, cost: u32) {
        if i != self.own && belief.is_frontier_index(i) {
            if let Some(k) = sector_of(self.from, belief.pos(i)) {
                if self.best[k].is_none_or(|b| (cost, i) < b) {
                    self.best[k] = Some((cost, i));
                }
            }
        }
    }
    fn goals(self, belief: &Belief) -> SectorGoals {
        SectorGoals {
            goals: self.best.map(|b| b.map(|(_, i)| belief.pos(i))),
        }
    }
}

/// The sector goals of a robot at `from` with map `belief`. Paths go through known free cells
/// not in `held` (teammates in view), like every other planner in madenet; the robot's own
/// cell is never a goal.
pub fn sector_goals(
    belief: &Belief,
    from: Pos,
    held: &[Pos],
    dijkstra: &mut Dijkstra,
) -> SectorGoals {
    let map = belief.map();
    let held: Vec<usize> = held
        .iter()
        .filter(|p| belief.in_bounds(**p))
        .map(|&p| belief.index(p))
        .collect();
    let mut best = SectorBest {
        from,
        own: belief.index(from),
        best: [None; SECTORS],
    };
    dijkstra.run_indexed(
        from,
        |i| map[i] == madenet_map::Occupancy::Free && !held.contains(&i),
        belief.movement(),
        |i, cost| {
            best.visit(belief, i, cost);
            false
        },
    );
    best.goals(belief)
}

/// [`sector_goals`] of the robot a policy is deciding for, through its view's search (which
/// treats the teammates it detects now as obstacles, and leaves the search tree for the
/// navigator's path).
pub fn view_sector_goals(view: &mut AgentView<'_>) -> SectorGoals {
    let belief = view.belief;
    let mut best = SectorBest {
        from: view.pos,
        own: belief.index(view.pos),
        best: [None; SECTORS],
    };
    view.search(|i, cost| {
        best.visit(belief, i, cost);
        false
    });
    best.goals(belief)
}

#[cfg(test)]
mod tests {
    use super::*;
    use madenet_map::Movement;

    #[test]
    fn compass_directions_and_boundaries() {
        let o = Pos::new(5, 5);
        let at = |dr: i32, dc: i32| sector_of(o, Pos::new(5 + dr, 5 + dc)).unwrap();
        assert_eq!(at(0, 1), 0); // east, θ = 0°
        assert_eq!(at(-1, 1), 1); // north-east, θ = 45° starts sector 1
        assert_eq!(at(-1, 0), 2); // north, 90°
        assert_eq!(at(-1, -1), 3); // 135°
        assert_eq!(at(0, -1), 4); // west, 180°
        assert_eq!(at(1, -1), 5); // 225°
        assert_eq!(at(1, 0), 6); // south, 270°
        assert_eq!(at(1, 1), 7); // 315°
        assert_eq!(at(-1, 3), 0); // 18°
        assert_eq!(sector_of(o, o), None);
        // Every direction has one sector and the eight are all used around a ring.
        let mut used = [false; SECTORS];
        for dr in -3..=3 {
            for dc in -3..=3 {
                if let Some(k) = sector_of(o, Pos::new(5 + dr, 5 + dc)) {
                    used[k] = true;
                }
            }
        }
        assert_eq!(used, [true; SECTORS]);
    }

    fn belief_from(rows: &[&str]) -> Belief {
        Belief::from_rows(rows, Movement::default())
    }

    #[test]
    fn goals_are_the_nearest_frontier_per_sector_and_empty_sectors_are_masked() {
        // Known free room, unknown beyond its east wall gap and north edge.
        let b = belief_from(&[
            "?????????",
            ".........",
            ".........",
            "......#??",
            ".......??",
            "#########",
        ]);
        let mut d = Dijkstra::new(b.height(), b.width());
        let from = Pos::new(3, 2);
        let g = sector_goals(&b, from, &[], &mut d);
        let mask = g.mask();
        // Frontiers lie north (row 1 touches the unknown row 0) and east (next to the ?? cells);
        // nothing lies south or south-west.
        assert!(mask[1] && mask[2] && mask[0]);
        assert!(!mask[5] && !mask[6]);
        for (k, goal) in g.goals.iter().enumerate() {
            if let Some(p) = goal {
                assert!(b.is_frontier(*p));
                assert_eq!(sector_of(from, *p), Some(k));
            }
        }
        // North: straight up is (1, 2), two moves away — the nearest frontier of sector 2.
        assert_eq!(g.goals[2], Some(Pos::new(1, 2)));
        // A teammate blocking the corridor's only way east hides the east sector's frontier.
        let corridor = belief_from(&["#####", "#...?", "#####"]);
        let mut d = Dijkstra::new(corridor.height(), corridor.width());
        assert_eq!(
            sector_goals(&corridor, Pos::new(1, 1), &[], &mut d).goals[0],
            Some(Pos::new(1, 3))
        );
        assert_eq!(
            sector_goals(&corridor, Pos::new(1, 1), &[Pos::new(1, 2)], &mut d).goals[0],
            None
        );
    }
}
