//! Goal extraction (paper Sec. III.C.1, *Goal Extraction*): clusters the frontier into at
//! most |G| spatially spread, reachable goal candidates 𝒢_i.

use crate::belief::{Belief, NEIGHBOURS};
use madenet_map::Pos;
use madenet_nav::Dijkstra;
use madenet_world::CandidateRule;
use serde::{Deserialize, Serialize};

/// The goal candidates 𝒢_i of one robot: `cells[k]` is the goal of macro action k;
/// [`GoalCandidates::valid_mask`] is the mask of the paper's network outputs (slots past
/// `cells.len()` are invalid).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GoalCandidates {
    /// |G|: the number of macro actions (Eq. 3).
    pub slots: usize,
    /// The candidates, at most `slots`, in selection order.
    pub cells: Vec<Pos>,
}

impl GoalCandidates {
    /// Validity of each of the `slots` macro actions.
    pub fn valid_mask(&self) -> Vec<bool> {
        (0..self.slots).map(|k| k < self.cells.len()).collect()
    }
    /// Whether macro action k has a candidate (k < `cells.len()`).
    pub fn is_valid(&self, k: usize) -> bool {
        k < self.cells.len()
    }
    /// The goal of macro action k (None: the slot is invalid).
    pub fn get(&self, k: usize) -> Option<Pos> {
        self.cells.get(k).copied()
    }
}

/// Extracts up to `slots` goal candidates for a robot at `from`.
///
/// 1. Frontier cells reachable from `from` through known free cells (the robot's own cell
///    excluded) are found with one Dijkstra run, which is left in `dijkstra` for the
///    navigator to reuse. Cells in `held` — those of teammates detected now — are neither
///    passed through nor offered, as in the nearest-frontier search: a goal on or behind a
///    teammate standing in a corridor would deadlock two robots that cannot talk.
/// 2. They are clustered into 8-connected components; each cluster is represented by its
///    cell nearest to the cluster's centroid (ties: lowest row-major index).
/// 3. Farthest-point selection: the first candidate is the representative of the cluster
///    whose nearest cell is closest to the robot by path (a near option is always offered);
///    each next one is the remaining representative farthest (Euclidean) from those chosen.
///    When clusters run out, the same selection continues over all reachable frontier cells,
///    so a single large frontier still yields several spread goals.
///
/// With [`CandidateRule::NearestClusters`], step 3 takes the cluster representatives in order
/// of their nearest cell's path cost instead (then farthest-point selection over frontier cells
/// when clusters run out).
pub fn extract_goals(
    belief: &Belief,
    from: Pos,
    slots: usize,
    dijkstra: &mut Dijkstra,
    held: &[Pos],
) -> GoalCandidates {
    extract_goals_with(belief, from, slots, dijkstra, held, CandidateRule::Paper)
}

/// [`extract_goals`] under `rule`.
pub fn extract_goals_with(
    belief: &Belief,
    from: Pos,
    slots: usize,
    dijkstra: &mut Dijkstra,
    held: &[Pos],
    rule: CandidateRule,
) -> GoalCandidates {
    let mut reachable: Vec<Pos> = Vec::new();
    dijkstra.run(
        from,
        |p| belief.is_free(p) && !held.contains(&p),
        belief.movement(),
        |p| {
            if p != from && belief.is_frontier(p) {
                reachable.push(p);
            }
            false
        },
    );
    // Nearest first (ties: row-major index), whatever order the search settled them in.
    reachable.sort_by_key(|&p| (dijkstra.settled_cost(p), belief.index(p)));
    let mut out = GoalCandidates {
        slots,
        cells: Vec::with_capacity(slots),
    };
    if reachable.is_empty() || slots == 0 {
        return out;
    }
    // Clusters: flood fill over reachable frontier cells. `reachable` is sorted by path cost
    // (nearest first), so cluster 0 holds the nearest frontier cell.
    let mut label = vec![usize::MAX; belief.width() * belief.height()];
    let mut is_reach = vec![false; label.len()];
    for &p in &reachable {
        is_reach[belief.index(p)] = true;
    }
    let mut reps: Vec<Pos> = Vec::new();
    let mut stack = Vec::new();
    let mut members = Vec::new();
    for &seed in &reachable {
        if label[belief.index(seed)] != usize::MAX {
            continue;
        }
        let id = reps.len();
        members.clear();
        label[belief.index(seed)] = id;
        stack.push(seed);
        while let Some(p) = stack.pop() {
            members.push(p);
            for (dr, dc) in NEIGHBOURS {
                let q = Pos::new(p.row + dr, p.col + dc);
                if belief.in_bounds(q) {
                    let qi = belief.index(q);
                    if is_reach[qi] && label[qi] == usize::MAX {
                        label[qi] = id;
                        stack.push(q);
                    }
                }
            }
        }
        let n = members.len() as f64;
        let (sr, sc) = members
            .iter()
            .fold((0.0, 0.0), |(r, c), p| (r + p.row as f64, c + p.col as f64));
        let (cr, cc) = (sr / n, sc / n);
        let rep = *members
            .iter()
            .min_by(|a, b| {
                let da = (a.row as f64 - cr).powi(2) + (a.col as f64 - cc).powi(2);
                let db = (b.row as f64 - cr).powi(2) + (b.col as f64 - cc).powi(2);
                da.total_cmp(&db)
                    .then(belief.index(**a).cmp(&belief.index(**b)))
            })
            .expect("cluster is not empty");
        reps.push(rep);
    }
    match rule {
        CandidateRule::Paper => {
            out.cells.push(reps[0]);
            farthest_point(&reps, &mut out.cells, slots);
        }
        // Clusters are numbered in order of their nearest cell's path cost (flood fills start
        // from `reachable`, nearest first).
        CandidateRule::NearestClusters => out.cells.extend(reps.iter().take(slots)),
    }
    if out.cells.len() < slots {
        farthest_point(&reachable, &mut out.cells, slots);
    }
    out
}

/// Adds points of `pool` to `chosen` by farthest-point selection until `slots` are chosen or
/// every remaining point coincides with a chosen one. Ties go to the earlier pool entry.
fn farthest_point(pool: &[Pos], chosen: &mut Vec<Pos>, slots: usize) {
    let mut best_d: Vec<i64> = pool
        .iter()
        .map(|p| {
            chosen
                .iter()
                .map(|c| sq_dist(*p, *c))
                .min()
                .unwrap_or(i64::MAX)
        })
        .collect();
    while chosen.len() < slots {
        let mut best = None;
        for (k, &d) in best_d.iter().enumerate() {
            if d > 0 && best.is_none_or(|b: usize| d > best_d[b]) {
                best = Some(k);
            }
        }
        let Some(k) = best else { break };
        let p = pool[k];
        chosen.push(p);
        for (j, q) in pool.iter().enumerate() {
            best_d[j] = best_d[j].min(sq_dist(p, *q));
        }
    }
}

fn sq_dist(a: Pos, b: Pos) -> i64 {
    let dr = (a.row - b.row) as i64;
    let dc = (a.col - b.col) as i64;
    dr * dr + dc * dc
}

#[cfg(test)]
mod tests {
    use super::*;

    fn belief_from(rows: &[&str]) -> Belief {
        Belief::from_rows(rows, madenet_map::Movement::default())
    }

    #[test]
    fn candidates_are_reachable_spread_frontiers() {
        let b = belief_from(&[
            "?????????",
            "?.......?",
            "?.......?",
            "?...#...?",
            "?.......?",
            "?????????",
        ]);
        let mut d = Dijkstra::new(b.height(), b.width());
        let g = extract_goals(&b, Pos::new(3, 3), 4, &mut d, &[]);
        assert_eq!(g.cells.len(), 4);
        for &c in &g.cells {
            assert!(b.is_frontier(c));
            assert!(d.settled_cost(c).is_some());
        }
        // Spread: all pairwise distances at least 3 cells on this 7×4 ring.
        for i in 0..4 {
            for j in i + 1..4 {
                assert!(g.cells[i].euclid(g.cells[j]) >= 3.0, "{:?}", g.cells);
            }
        }
        assert_eq!(g.valid_mask(), vec![true; 4]);
    }

    #[test]
    fn fewer_frontiers_fewer_candidates_and_unreachable_excluded() {
        // A walled-off pocket with a frontier at (1,7) cannot be reached from (1,1).
        let b = belief_from(&["#########", "#..#...?#", "#.?#...##", "#########"]);
        let mut d = Dijkstra::new(b.height(), b.width());
        let g = extract_goals(&b, Pos::new(1, 1), 4, &mut d, &[]);
        assert!(!g.cells.is_empty());
        assert!(g.cells.iter().all(|c| c.col < 3), "{:?}", g.cells);
        assert_eq!(g.valid_mask().iter().filter(|&&v| v).count(), g.cells.len());
        assert!(g.cells.len() < 4);
    }

    #[test]
    fn teammates_in_view_block_goals_on_and_behind_them() {
        // A corridor: the robot at (1,1), a teammate at (1,4), frontiers at both ends.
        let b = belief_from(&["###?#####", "#.......?", "#########"]);
        let mut d = Dijkstra::new(b.height(), b.width());
        let free = extract_goals(&b, Pos::new(1, 1), 4, &mut d, &[]);
        assert!(free.cells.contains(&Pos::new(1, 7)), "{:?}", free.cells);
        let held = extract_goals(&b, Pos::new(1, 1), 4, &mut d, &[Pos::new(1, 4)]);
        assert!(held.cells.iter().all(|c| c.col < 4), "{:?}", held.cells);
        assert!(!held.cells.is_empty());
    }
}
