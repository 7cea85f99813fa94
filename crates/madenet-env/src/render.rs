//! A trial's current state as a [`madenet_render::Frame`]: the picture `madenet run --render`
//! draws and the Python environments' `render()` returns.

use madenet_map::OccGrid;
use madenet_render::{Frame, RobotFrame};
use madenet_sim::Trial;

/// The current state of `trial` as a render frame.
pub fn frame(trial: &Trial) -> Frame {
    let w = trial.world();
    let truth = w.truth().clone();
    let team_map = OccGrid::from_cells(truth.height(), truth.width(), w.team_map().to_vec());
    let robots = trial
        .agents()
        .iter()
        .enumerate()
        .map(|(i, a)| RobotFrame {
            pos: w.positions()[i],
            goal: a.goal(),
            path: a.path().to_vec(),
            candidates: a.candidates().cells.clone(),
            in_view: w.observation(i).seen.iter().map(|&(p, _)| p).collect(),
        })
        .collect();
    Frame {
        step: w.t(),
        truth,
        team_map,
        robots,
        explored: w.explored_fraction(),
        links: w.exchanges().to_vec(),
    }
}
