//! The study's cells: means per (side, team, method), and the paired samples its tests take.

use super::{ScaleConfig, ScalePlanned};
use crate::runner::TrialOutcome;
use serde::Serialize;

/// One (side, team, method) cell of the grid.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CellRow {
    /// Map side, cells.
    pub side: usize,
    /// Team size, robots.
    pub team: usize,
    /// Method (policy name).
    pub method: String,
    /// Number of trials in the cell.
    pub trials: usize,
    /// How many of them completed before the step cap.
    pub completed: usize,
    /// Mean TNS (total number of steps), timesteps; in the continuous world mean ET,
    /// simulated seconds.
    pub tns: f64,
    /// Mean TTD (total travel distance), metres.
    pub ttd_m: f64,
    /// Mean NOLI (number of local interactions).
    pub noli: f64,
    /// Collisions (robot–obstacle and robot–robot) over the cell's trials; 0 in the grid.
    #[serde(skip)]
    pub collisions: u64,
}

/// A row of a continuous study's `cells.csv`.
#[derive(Serialize)]
pub(super) struct ContinuousCellRow<'a> {
    pub(super) side: usize,
    pub(super) team: usize,
    pub(super) method: &'a str,
    pub(super) trials: usize,
    pub(super) completed: usize,
    pub(super) et_s: f64,
    pub(super) ttd_m: f64,
    pub(super) noli: f64,
    pub(super) collisions: u64,
}

/// Means per (side, team, method), in the config's order.
pub fn cells(
    cfg: &ScaleConfig,
    planned: &[ScalePlanned],
    outcomes: &[TrialOutcome],
) -> Vec<CellRow> {
    let mut rows = Vec::new();
    for &side in &cfg.sides {
        for &team in &cfg.teams {
            for method in &cfg.methods {
                let sel: Vec<&TrialOutcome> = planned
                    .iter()
                    .zip(outcomes)
                    .filter(|(p, _)| {
                        p.side == side && p.team == team && &p.planned.key.method == method
                    })
                    .map(|(_, o)| o)
                    .collect();
                let n = sel.len().max(1) as f64;
                rows.push(CellRow {
                    side,
                    team,
                    method: method.clone(),
                    trials: sel.len(),
                    completed: sel.iter().filter(|o| o.row.completed).count(),
                    tns: sel.iter().map(|o| tns(o)).sum::<f64>() / n,
                    ttd_m: sel.iter().map(|o| o.row.ttd).sum::<f64>() / n,
                    noli: sel.iter().map(|o| o.row.noli as f64).sum::<f64>() / n,
                    collisions: sel
                        .iter()
                        .filter_map(|o| o.row.continuous)
                        .map(|c| c.obstacle_collisions + c.robot_collisions)
                        .sum(),
                });
            }
        }
    }
    rows
}

/// The paired values of `metric` for `method` on side `side` and team `team`, in plan order
/// (so the same (map, start, seed) sits at the same index for every method and team).
pub(super) fn paired(
    planned: &[ScalePlanned],
    outcomes: &[TrialOutcome],
    method: &str,
    side: Option<usize>,
    team: Option<usize>,
    metric: fn(&TrialOutcome) -> f64,
) -> Vec<f64> {
    planned
        .iter()
        .zip(outcomes)
        .filter(|(p, _)| {
            p.planned.key.method == method
                && side.is_none_or(|s| p.side == s)
                && team.is_none_or(|t| p.team == t)
        })
        .map(|(_, o)| metric(o))
        .collect()
}

/// The study's time metric: TNS in steps, or ET in seconds in the continuous world.
pub(super) fn tns(o: &TrialOutcome) -> f64 {
    o.row.continuous.map_or(o.row.tns as f64, |c| c.et_s)
}
pub(super) fn ttd(o: &TrialOutcome) -> f64 {
    o.row.ttd
}
