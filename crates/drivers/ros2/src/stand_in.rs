//! A stand-in robot stack, to try [`crate::RealRobots`] without robots: it holds a true map,
//! publishes `/robot<i>/map` (what its square sensor of radius d_s has seen so far) and
//! `/robot<i>/pose`, and goes to the cell a `/robot<i>/goal_pose` names when that cell is a
//! free neighbour (any controller that reaches the goal cell would do the same).

use crate::msgs::PoseStamped;
use crate::{MapFrame, QosProfile, RobotTopics, Ros2Error, Ros2Options};
use madenet_map::{OccGrid, Occupancy, Pos};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Runs robot `i`'s stand-in stack on `truth` from `start` until `stop` is set; returns the
/// cells it went through.
pub fn run_stand_in(
    opts: &Ros2Options,
    i: usize,
    truth: &OccGrid,
    start: Pos,
    sensing_range: i32,
    stop: &AtomicBool,
) -> Result<Vec<Pos>, Ros2Error> {
    let ctx = opts.context()?;
    let frame = MapFrame::of(truth);
    let mut topics = RobotTopics::new(&ctx, i, frame)?;
    let node = ctx.create_node(&format!("stand_in{i}"))?;
    let topic = crate::topics(i)[2].clone();
    let goals = node.create_sub::<PoseStamped>(&topic, QosProfile::default())?;
    let mut seen = OccGrid::new(truth.height(), truth.width(), Occupancy::Unknown);
    let sense = |at: Pos, seen: &mut OccGrid| {
        let ds = sensing_range;
        for p in
            (-ds..=ds).flat_map(|dr| (-ds..=ds).map(move |dc| Pos::new(at.row + dr, at.col + dc)))
        {
            if truth.in_bounds(p) {
                seen.set(p, truth.get(p));
            }
        }
    };
    let (mut at, mut path) = (start, vec![start]);
    sense(at, &mut seen);
    while !stop.load(Ordering::Relaxed) {
        topics.publish(seen.cells(), at, None)?;
        if let Some(g) = goals.recv_timeout(Duration::from_millis(3))? {
            let to = frame.cell_at(g.pose.position.x, g.pose.position.y);
            if let Some(to) = to.filter(|&to| to.chebyshev(at) == 1 && truth.is_free(to)) {
                at = to;
                path.push(at);
                sense(at, &mut seen);
            }
        }
    }
    Ok(path)
}
