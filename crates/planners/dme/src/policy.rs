//! DME-DRL at execution time. A decision feeds the robot's own frame history and pose vector
//! to its actor and picks a sector among those with a reachable frontier cell; the robot then
//! heads for that sector's goal (the navigator plans on the robot's own map) until the goal is
//! reached, stops being a frontier cell, becomes unreachable, or the robot is blocked for
//! [`BLOCKED_STEPS`] steps — as the original walks the whole A* path to it. Re-deciding every
//! timestep instead made robots oscillate where a goal crosses a sector boundary (see
//! `models/README.md`). The policy still runs every timestep, to keep the frame history and to
//! check its goal.
//!
//! Greedy (argmax of the actor's logits) for evaluation; in training the action is sampled
//! from the softmax over the valid sectors (the original samples even at evaluation, see the
//! design brief), and each decision is written to the [`DecisionSlots`] for the replay.

use crate::nets::Actor;
use crate::obs::{frame, pose_vector, History};
use crate::sectors::view_sector_goals;
use crate::SECTORS;
use burn::tensor::{Device, Tensor, TensorData};
use madenet_agent::{AgentView, Decision, DecisionMode, Policy};
use madenet_world::rng::Rng;
use rand::RngExt;
use std::sync::{Arc, Mutex, RwLock};

/// An actor shared by the policies that run it; the trainer swaps in new weights.
pub type SharedActor = Arc<RwLock<Actor>>;

/// Timesteps without moving, despite a goal elsewhere, that end a macro action (as the
/// simulator's macro policies).
pub const BLOCKED_STEPS: usize = madenet_agent::BLOCKED_STEPS;

/// One robot's timestep, as the replay stores it.
#[derive(Clone, Debug, PartialEq)]
pub struct StepRecord {
    /// This timestep's frame `[4][H][W]` (0/1).
    pub frame: Vec<u8>,
    /// This timestep's pose vector `[2 · team]` ([`pose_vector`]).
    pub pose: Vec<f32>,
    /// Sectors with a reachable frontier cell.
    pub mask: [bool; SECTORS],
    /// The sector in force (chosen at this or an earlier decision); `None` when the last
    /// decision found every sector masked (the robot stays).
    pub action: Option<u8>,
    /// Whether the robot decided at this timestep.
    pub decided: bool,
}

/// Where the policies of a training episode leave their decisions: one slot per robot,
/// taken by the trainer after each timestep.
pub type DecisionSlots = Arc<Mutex<Vec<Option<StepRecord>>>>;

/// One robot's DME-DRL policy.
pub struct DmePolicy {
    name: String,
    robot: usize,
    actor: SharedActor,
    history: History,
    sample: Option<Rng>,
    recorder: Option<DecisionSlots>,
    device: Device,
    /// The macro action in force: sector and goal.
    action: Option<u8>,
    goal: Option<madenet_map::Pos>,
    last_pos: Option<madenet_map::Pos>,
    still_for: usize,
}

impl DmePolicy {
    /// A greedy policy running `actor` with a `history`-frame input.
    pub fn new(name: &str, robot: usize, actor: SharedActor, history: usize) -> Self {
        DmePolicy {
            name: name.to_string(),
            robot,
            actor,
            history: History::new(history),
            sample: None,
            recorder: None,
            device: Device::flex(),
            action: None,
            goal: None,
            last_pos: None,
            still_for: 0,
        }
    }

    /// Samples actions from the actor's softmax with `rng` instead of taking the argmax.
    pub fn sampling(mut self, rng: Rng) -> Self {
        self.sample = Some(rng);
        self
    }

    /// Writes every decision into `recorder[robot]`.
    pub fn recording(mut self, recorder: DecisionSlots) -> Self {
        self.recorder = Some(recorder);
        self
    }
}

/// The index of the largest of `logits` among valid ones.
pub fn masked_argmax(logits: &[f32], mask: &[bool; SECTORS]) -> Option<usize> {
    (0..SECTORS)
        .filter(|&k| mask[k])
        .fold(None, |best: Option<usize>, k| match best {
            Some(b) if logits[b] >= logits[k] => Some(b),
            _ => Some(k),
        })
}

/// A draw from the softmax of `logits` restricted to the valid ones.
pub fn masked_sample(logits: &[f32], mask: &[bool; SECTORS], rng: &mut Rng) -> Option<usize> {
    let top = (0..SECTORS)
        .filter(|&k| mask[k])
        .map(|k| logits[k])
        .fold(f32::NEG_INFINITY, f32::max);
    if top == f32::NEG_INFINITY {
        return None;
    }
    let w: Vec<f64> = (0..SECTORS)
        .map(|k| {
            if mask[k] {
                f64::from(logits[k] - top).exp()
            } else {
                0.0
            }
        })
        .collect();
    let mut u = rng.random::<f64>() * w.iter().sum::<f64>();
    let mut last = None;
    for (k, &wk) in w.iter().enumerate() {
        if wk > 0.0 {
            last = Some(k);
            if u < wk {
                return Some(k);
            }
            u -= wk;
        }
    }
    last
}

impl Policy for DmePolicy {
    fn name(&self) -> &str {
        &self.name
    }
    fn mode(&self) -> DecisionMode {
        DecisionMode::EveryStep
    }
    fn needs_candidates(&self) -> bool {
        false
    }
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision {
        let f = frame(view);
        self.history.push(f.clone());
        let pose = pose_vector(view);
        let goals = view_sector_goals(view);
        let mask = goals.mask();
        self.still_for = if self.goal.is_some() && self.last_pos == Some(view.pos) {
            self.still_for + 1
        } else {
            0
        };
        self.last_pos = Some(view.pos);
        // The macro action goes on while its goal is an unreached, reachable frontier cell.
        let going_on = self.goal.is_some_and(|g| {
            g != view.pos
                && view.belief.is_frontier(g)
                && view.searched_cost(g).is_some()
                && self.still_for < BLOCKED_STEPS
        });
        if !going_on {
            self.action = if mask.contains(&true) {
                let (h, w) = (view.belief.height(), view.belief.width());
                let maps = self.history.stacked();
                let channels = maps.len() / (h * w);
                let maps = Tensor::<4>::from_data(
                    TensorData::new(maps, [1, channels, h, w]),
                    &self.device,
                );
                let p = Tensor::<2>::from_data(
                    TensorData::new(pose.clone(), [1, pose.len()]),
                    &self.device,
                );
                let logits = self.actor.read().expect("actor lock").forward(maps, p);
                let logits = logits
                    .into_data()
                    .try_into_vec_as::<f32>()
                    .expect("logits readable as f32");
                match self.sample.as_mut() {
                    Some(rng) => masked_sample(&logits, &mask, rng),
                    None => masked_argmax(&logits, &mask),
                }
                .map(|k| k as u8)
            } else {
                None
            };
            self.goal = self.action.and_then(|k| goals.goals[k as usize]);
            self.still_for = 0;
        }
        if let Some(rec) = &self.recorder {
            rec.lock().expect("recorder lock")[self.robot] = Some(StepRecord {
                frame: f,
                pose,
                mask,
                action: self.action,
                decided: !going_on,
            });
        }
        match self.goal {
            Some(goal) => Decision::Goal(goal),
            None => Decision::Idle,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn argmax_and_sampling_respect_the_mask() {
        let logits = [5.0, 1.0, 0.0, 9.0, 0.0, 0.0, 0.0, 2.0];
        let mut mask = [false; SECTORS];
        assert_eq!(masked_argmax(&logits, &mask), None);
        mask[1] = true;
        mask[7] = true;
        assert_eq!(masked_argmax(&logits, &mask), Some(7));
        let mut rng = madenet_world::rng::stream(3, "test", 0);
        let mut counts = [0usize; SECTORS];
        for _ in 0..2000 {
            counts[masked_sample(&logits, &mask, &mut rng).unwrap()] += 1;
        }
        // Only valid sectors, in proportion e^2 : e^1 ≈ 0.73 : 0.27.
        assert_eq!(counts.iter().sum::<usize>(), counts[1] + counts[7]);
        let share = counts[7] as f64 / 2000.0;
        assert!((share - 0.731).abs() < 0.04, "share of sector 7: {share}");
        assert_eq!(masked_sample(&logits, &[false; SECTORS], &mut rng), None);
    }
}
