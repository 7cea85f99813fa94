//! A trial's current state as a [`Frame`]: the picture `madenet run --render` draws, the
//! Python environments' `render()` returns and the runtime's world node shows.

use crate::{Frame, RobotFrame};
use madenet_map::{OccGrid, Pos};
use madenet_sim::Trial;
use madenet_world::World;

/// The current state of `trial` as a render frame.
pub fn trial_frame(trial: &Trial) -> Frame {
    let w = trial.world();
    let agents = trial.agents();
    world_frame(
        w,
        |i| {
            let a = &agents[i];
            (a.goal(), a.path().to_vec(), a.candidates().cells.clone())
        },
        w.exchanges(),
    )
}

/// The current state of `w` as a render frame, robot i drawn with what `shown(i)` gives (its
/// goal, planned path and goal candidates) and `links` the pairs exchanging this timestep:
/// [`trial_frame`] for a world whose agents live elsewhere (the runtime's world node).
pub fn world_frame(
    w: &World,
    shown: impl Fn(usize) -> (Option<Pos>, Vec<Pos>, Vec<Pos>),
    links: &[(usize, usize)],
) -> Frame {
    let truth = w.truth().clone();
    let team_map = OccGrid::from_cells(truth.height(), truth.width(), w.team_map().to_vec());
    let robots = (0..w.positions().len())
        .map(|i| {
            let (goal, path, candidates) = shown(i);
            RobotFrame {
                pos: w.positions()[i],
                goal,
                path,
                candidates,
                in_view: w.observation(i).seen.iter().map(|&(p, _)| p).collect(),
            }
        })
        .collect();
    Frame {
        step: w.t(),
        truth,
        team_map,
        robots,
        explored: w.explored_fraction(),
        links: links.to_vec(),
    }
}
