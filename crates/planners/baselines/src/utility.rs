//! UB: utility-based coordinated exploration (Burgard et al., IEEE T-RO 2005).

use madenet_agent::{AgentView, Decision, DecisionMode, Policy};
use madenet_map::{Occupancy, Pos};
use madenet_world::ScenarioConfig;
use serde::{Deserialize, Serialize};

/// UB's constants.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct UbParams {
    /// β, the weight of path cost against utility, per metre. Unset: one over the map's side
    /// in metres, so a path as long as the map is wide costs as much as the best possible
    /// target is worth (Burgard et al. leave β to the application).
    pub beta: Option<f64>,
    /// Radius, in cells, within which a teammate's announced goal discounts a target:
    /// P(d) = max(0, 1 − d / radius) for a target at Euclidean distance d from that goal
    /// (Burgard et al. Sec. III: the probability that the target is also covered by the
    /// teammate's sensor). Unset: the sensing range d_s.
    pub coordination_radius: Option<f64>,
}

/// The UB policy of one robot.
///
/// Each timestep, over the frontier cells reachable through known free space (cells held by
/// detected teammates avoided, the robot's own cell excluded), with V(t) the path length in
/// metres:
///
/// * information gain I(t): the unknown cells of the robot's map within the sensor window
///   around t, over the window's size, so 0 ≤ I(t) ≤ 1 (the utility Burgard et al. start
///   every target with, weighted by what it would reveal);
/// * coordination: U(t) = I(t) − Σ_j P(‖t − g_j‖) over the teammates' goals g_j from the last
///   β heard from each (robots that cannot talk now use the last goals they heard);
/// * choice: the target maximizing U(t) − β · V(t); ties go to the cheaper, then the lower
///   row-major index.
///
/// No target costing more than (max U − best)/β can win (max U over all frontier cells), and
/// the search stops there.
pub struct UtilityBased {
    beta: f64,
    radius: f64,
    sensing_range: usize,
    cell_size: f64,
    /// Summed-area table of unknown cells, (h+1) × (w+1).
    sat: Vec<u32>,
}

impl UtilityBased {
    /// The UB policy of a robot on a `height` × `width` map (cells), its sensing range d_s
    /// and cell size taken from `cfg`; the unset `params` get their defaults from them.
    pub fn new(params: UbParams, cfg: &ScenarioConfig, height: usize, width: usize) -> Self {
        let side_m = (height.max(width) as f64) * cfg.cell_size;
        UtilityBased {
            beta: params.beta.unwrap_or(1.0 / side_m),
            radius: params
                .coordination_radius
                .unwrap_or(cfg.sensing_range as f64),
            sensing_range: cfg.sensing_range.max(0) as usize,
            cell_size: cfg.cell_size,
            sat: Vec::new(),
        }
    }

    fn build_sat(&mut self, map: &[Occupancy], height: usize, width: usize) {
        let w1 = width + 1;
        self.sat.clear();
        self.sat.resize((height + 1) * w1, 0);
        for r in 0..height {
            let mut row = 0u32;
            for c in 0..width {
                row += (map[r * width + c] == Occupancy::Unknown) as u32;
                self.sat[(r + 1) * w1 + c + 1] = self.sat[r * w1 + c + 1] + row;
            }
        }
    }

    /// Unknown cells in the window of radius d_s around (r, c), clipped to the map.
    fn unknown_around(&self, r: usize, c: usize, height: usize, width: usize) -> u32 {
        let ds = self.sensing_range;
        let (r0, c0) = (r.saturating_sub(ds), c.saturating_sub(ds));
        let (r1, c1) = ((r + ds + 1).min(height), (c + ds + 1).min(width));
        let w1 = width + 1;
        self.sat[r1 * w1 + c1] + self.sat[r0 * w1 + c0]
            - self.sat[r0 * w1 + c1]
            - self.sat[r1 * w1 + c0]
    }
}

impl Policy for UtilityBased {
    fn name(&self) -> &str {
        "ub"
    }
    fn mode(&self) -> DecisionMode {
        DecisionMode::EveryStep
    }
    fn needs_candidates(&self) -> bool {
        false
    }
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision {
        let belief = view.belief;
        let (h, w) = (belief.height(), belief.width());
        self.build_sat(belief.map(), h, w);
        let window = ((2 * self.sensing_range + 1).pow(2) - 1) as f64;
        let goals: Vec<Pos> = view
            .teammates
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != view.id)
            .filter_map(|(_, r)| r.goal)
            .collect();
        let own = belief.index(view.pos);
        let (beta, radius, cell_size) = (self.beta, self.radius, self.cell_size);
        // Utility per frontier cell (reachable or not): the largest bounds what any target
        // can score, so the search can stop once distance alone rules the rest out.
        let this = &*self;
        let utility = |p: Pos| {
            let gain = this.unknown_around(p.row as usize, p.col as usize, h, w) as f64 / window;
            let overlap: f64 = goals
                .iter()
                .map(|g| (1.0 - p.euclid(*g) / radius).max(0.0))
                .sum();
            gain - overlap
        };
        let max_utility = belief
            .frontier_cells()
            .map(utility)
            .fold(f64::NEG_INFINITY, f64::max);
        let mut best: Option<(f64, u32, usize)> = None; // (score, cost, cell)
        view.search(|i, cost| {
            let metres = madenet_nav::cost_to_cells(cost) * cell_size;
            if let Some((score, _, _)) = best {
                if max_utility - beta * metres < score {
                    return true; // nothing this far away can beat the best any more
                }
            }
            if i == own || !belief.is_frontier_index(i) {
                return false;
            }
            let score = utility(belief.pos(i)) - beta * metres;
            let better = match best {
                None => true,
                Some((s, c, j)) => score > s || (score == s && (cost, i) < (c, j)),
            };
            if better {
                best = Some((score, cost, i));
            }
            false
        });
        match best {
            Some((_, _, i)) => Decision::Goal(belief.pos(i)),
            None => Decision::Idle,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The summed-area table counts the unknown cells of the d_s window around a cell,
    /// clipped to the map; hand-counted on a 4 × 5 map with d_s = 1.
    #[test]
    fn unknown_window_counts_by_hand() {
        use Occupancy::{Free as F, Obstacle as O, Unknown as U};
        #[rustfmt::skip]
        let map = [
            U, U, F, F, O,
            U, F, F, U, U,
            F, F, O, U, F,
            O, U, U, U, U,
        ];
        let cfg = ScenarioConfig {
            sensing_range: 1,
            ..ScenarioConfig::default()
        };
        let mut ub = UtilityBased::new(UbParams::default(), &cfg, 4, 5);
        ub.build_sat(&map, 4, 5);
        // (0, 0): window rows 0–1, cols 0–1: U U / U F → 3.
        assert_eq!(ub.unknown_around(0, 0, 4, 5), 3);
        // (1, 2): rows 0–2, cols 1–3: U F F / F F U / F O U → 3.
        assert_eq!(ub.unknown_around(1, 2, 4, 5), 3);
        // (3, 4): rows 2–3, cols 3–4: U F / U U → 3.
        assert_eq!(ub.unknown_around(3, 4, 4, 5), 3);
        // (2, 3): rows 1–3, cols 2–4: F U U / O U F / U U U → 6.
        assert_eq!(ub.unknown_around(2, 3, 4, 5), 6);
    }

    /// Unset β is one over the map's side in metres; unset radius is d_s.
    #[test]
    fn unset_parameters_follow_the_map_and_sensor() {
        let cfg = ScenarioConfig::default();
        let ub = UtilityBased::new(UbParams::default(), &cfg, 20, 30);
        assert_eq!(ub.beta, 1.0 / (30.0 * cfg.cell_size));
        assert_eq!(ub.radius, cfg.sensing_range as f64);
        let ub = UtilityBased::new(
            UbParams {
                beta: Some(0.25),
                coordination_radius: Some(2.5),
            },
            &cfg,
            20,
            30,
        );
        assert_eq!((ub.beta, ub.radius), (0.25, 2.5));
    }
}
