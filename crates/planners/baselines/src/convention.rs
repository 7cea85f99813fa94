//! **convention**: a decentralized split of the map that robots agree on without negotiating —
//! at every meeting each of them computes the same team plan from the same inputs, and each
//! keeps (softly) to its own part of it until the next meeting.

use madenet_agent::{AgentView, Decision, Policy, Spread};
use madenet_map::Pos;

/// No owner: a cell outside every convention so far.
const NONE: u8 = u8::MAX;

/// `spread` with the teammates' parts of the map made dearer. When the robot decides at a
/// timestep at which it exchanged β with every teammate it detects (a macro action ends when
/// one is newly detected, so both sides of a meeting decide then, their maps merged both
/// ways), the group — itself and those teammates — plans the whole group's routes with the
/// known-map reference's planner ([`crate::reference::belief_team_routes`]) on the
/// merged map, its unknown cells redrawn over `futures` generated maps whose seeds depend only
/// on the trial and the timestep, the members where they stand, in index order: every member
/// computes the same plan without negotiating. Each cell then belongs to the member whose
/// viewpoint (over all futures) is nearest, and until the next meeting a candidate in a
/// teammate's part costs `penalty` cells more in `spread`'s score (d_s in the registry; a hard
/// split and 4 d_s measured worse on the development maps — models/README, stop 54).
///
/// A group is only the same for all its members when each detects all the others (a chain of
/// contacts gives different groups), and a pair's merged maps are only equal when neither
/// merged a third robot's map that timestep; the convention is then a near-agreement. A
/// meeting without an exchange (a dropout) makes no new agreement, and at CSP 0 there is none
/// at all: the robot plays `spread`.
#[derive(Clone, Debug)]
pub struct Convention {
    spread: Spread,
    futures: usize,
    penalty: f64,
    seed: u64,
    /// The map's width in cells (the owners are row-major).
    width: usize,
    /// Per cell, the group member whose part of the last plan it lies in ([`NONE`]: none).
    owner: Vec<u8>,
}

impl Convention {
    /// The policy on a `height` × `width` map, redrawing over `futures` maps (0: unknown cells
    /// free) from the stream `convention/redraw` of the trial's `seed`, a teammate's part
    /// costing `penalty` cells (d_s: the view's).
    pub fn new(futures: usize, penalty: f64, seed: u64, height: usize, width: usize) -> Self {
        Convention {
            spread: Spread,
            futures,
            penalty,
            seed,
            width,
            owner: vec![NONE; height * width],
        }
    }

    /// The group member whose part of the last agreed plan cell `p` lies in (`None`: no
    /// meeting yet, or a cell off the map).
    pub fn part(&self, p: Pos) -> Option<usize> {
        let w = self.width;
        let inside = p.row >= 0 && p.col >= 0 && (p.col as usize) < w;
        let c = inside.then(|| p.row as usize * w + p.col as usize)?;
        self.owner
            .get(c)
            .filter(|&&o| o != NONE)
            .map(|&o| o as usize)
    }

    /// The cells' owners under the plan the detected group agrees on now.
    fn agree(&mut self, view: &AgentView<'_>, group: &[(usize, Pos)]) {
        let (h, w) = (view.belief.height(), view.belief.width());
        let heard_all = group
            .iter()
            .filter(|&&(j, _)| j != view.id)
            .all(|&(j, _)| view.teammates[j].heard_at == Some(view.t));
        if !heard_all {
            return;
        }
        let map = view.belief.grid();
        let movement = view.belief.movement();
        let fills = crate::rollout::generated_maps(
            h,
            w,
            movement,
            self.seed,
            "convention/redraw",
            (0..self.futures as u64).map(|k| ((view.t as u64) << 8) | k),
        )
        .unwrap_or_default();
        let team: Vec<Pos> = group.iter().map(|&(_, p)| p).collect();
        let ds = view.sensing_range;
        let mut viewpoints: Vec<(Pos, u8)> = Vec::new();
        for fill in crate::reference::plan_fills(&fills) {
            let Some(routes) = crate::reference::belief_team_routes(map, fill, &team, ds, movement)
            else {
                continue;
            };
            for (route, &(j, _)) in routes.iter().zip(group) {
                viewpoints.extend(route.iter().map(|&v| (v, j as u8)));
            }
        }
        // Nearest viewpoint by straight-line distance, ties to the first listed: a Voronoi
        // split of the plan's routes (by hand: a few thousand cells × a few hundred points).
        for (c, owner) in self.owner.iter_mut().enumerate() {
            let p = Pos::new((c / w) as i32, (c % w) as i32);
            *owner = viewpoints
                .iter()
                .min_by_key(|(v, _)| {
                    let (dr, dc) = (v.row - p.row, v.col - p.col);
                    dr * dr + dc * dc
                })
                .map_or(NONE, |&(_, j)| j);
        }
    }
}

impl Policy for Convention {
    fn name(&self) -> &str {
        "convention"
    }
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision {
        let spread = self.spread.scores(view);
        let group: Vec<(usize, Pos)> = view
            .teammates
            .iter()
            .enumerate()
            .filter_map(|(j, r)| {
                if j == view.id {
                    Some((j, view.pos))
                } else {
                    r.seen_pos.filter(|_| r.detected).map(|p| (j, p))
                }
            })
            .collect();
        // Owners are stored as u8: teams beyond 255 robots make no agreements.
        if group.len() > 1 && view.teammates.len() <= NONE as usize {
            self.agree(view, &group);
        }
        let cells = &view.candidates().cells;
        let mine = |k: usize| {
            let o = self.owner[view.belief.index(cells[k])];
            o == NONE || o as usize == view.id
        };
        let best = spread
            .iter()
            .enumerate()
            .filter_map(|(k, s)| s.map(|s| (k, if mine(k) { s } else { s + self.penalty })))
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        match best {
            Some((k, _)) => Decision::Candidate(k),
            None => Decision::Idle,
        }
    }
}
