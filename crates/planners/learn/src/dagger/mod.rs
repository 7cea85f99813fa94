//! MADE-Net's DEP trained by DAgger from a centralized teacher (`method = "made-net-rollout"`:
//! the **rollout teacher**, `teacher = "rollout"`, or the **plan teacher**, `teacher = "plan"`,
//! which trains the shipped `made-net`), read top to bottom like a CleanRL script, one file per
//! idea: [`config`] (every knob, validated), [`teacher`] (steps 1–3: scenarios, behaviour,
//! labels), [`collector`] (an iteration's episodes as plain data, collected here or on Ray),
//! [`student`] (step 4: networks, losses, updates) and [`run`] (the loop: collect → fit →
//! validate, logs, checkpoints, best/last). A departure from the paper's CEP/DEP Q-learning
//! (which ships as `made-net-paper`), chosen because that learner ends no better than "always
//! take candidate 0" within an hour.
//!
//! 1. **Scenarios**: generated maps at obstacle fractions across `density_min..density_max`
//!    (15–60 % by default: the paper's training maps are 40–60 %, its evaluation maps 18–36 %),
//!    the team in a shared corner or around a random cell, CSP drawn per episode. With
//!    `network = "agnostic"` a curriculum: square maps whose largest side grows over the
//!    iterations up to `map_side_max`, teams up to `team_max`; with `floorplan_prob`, generated
//!    floor plans (rooms, doors, corridors) among the clutter.
//! 2. **Behaviour** (DAgger): iteration 0 follows the base rule (`spread`), later iterations the
//!    DEP being trained (greedy); both take a random valid candidate with probability
//!    `behaviour_epsilon`.
//! 3. **Teacher** (centralized training: it sees the simulator): at each decision of a robot
//!    with two or more candidates, every candidate k is scored by continuing the trial from this
//!    very state ([`madenet_sim::Trial::fork`]) with the robot taking k and everyone following the base rule
//!    afterwards — by default once, in the noiseless future (no sensor misses, no slips;
//!    communication keeps the trial's own draws), or with `futures = "salted"` over `rollouts`
//!    other futures of the noise ([`madenet_world::World::reseed_noise`]; the same for every k),
//!    or with `futures = "redrawn"` over `rollouts` noiseless futures whose unseen cells are
//!    redrawn from the episode's map distribution (labels the team's knowledge can predict).
//!    The label of k is the mean number of steps left until the map is explored (`value =
//!    "mean-discovery"`: the mean over cells of the steps until each is known, capped at
//!    `horizon`): one step of policy improvement over the base rule. With `expert_iteration`, once a student beats the
//!    base rule on validation the best student so far (with its margin) is the base of the
//!    continuations, so the improvements can compound; each iteration logs the teacher's gain
//!    over its base (per labelled decision) and the student's over the base rule (validation),
//!    and `patience` stops the run when validation stops improving. With `team_rounds`, robots
//!    choosing at the same timestep are valued by coordinate descent over the robots, each
//!    beside the others' current choices. With `horizon`,
//!    continuations stop after that many steps and the rest is estimated; `label_prob` thins
//!    the labelled decisions on large maps.
//! 4. **Student**: the paper's DEP (MFE, F3, LSTM, F6; `observation` may add per-candidate
//!    features), or the size- and team-agnostic DEP ([`crate::agnostic`]), regresses the
//!    labels' *advantages* (label minus its mean over the valid candidates) with Adam, or
//!    (`loss = "listwise"`) matches softmax(scores / τ) to softmax(advantages / τ) — by default
//!    on single decisions from zero LSTM state (`recurrent = false`), else on windows of each
//!    robot's decision sequence.
//! 5. **Validation** after every iteration on generated trials of their own seeds (210 by
//!    default), the DEP acting greedily and with each `spread_margins` margin (the `spread` rule's
//!    candidate unless the DEP values another more by the margin); the best (iteration, margin)
//!    is kept in `best/`, the last iteration in `last/`.
//!
//! Checkpoints are written after every iteration (dataset, net, optimizer, counters, the
//! teacher's base student), so a killed run resumes at its last iteration boundary and ends as
//! an uninterrupted one would.
//!
//! Steps 1–3 of an iteration are one [`CollectRequest`] — plain data: episode indices, the
//! curriculum's side, the behaviour's and the teacher's base students as model files' bytes
//! (the behaviour's written to `RUN/.behaviour/`) — collected here or by a [`Collector`]
//! elsewhere ([`train_with`]; the Python package's `madenet.ray.train` hands batches to Ray
//! tasks that run [`collect_bytes`]), with the same episodes either way.

pub mod collector;
pub mod config;
pub mod run;
pub mod student;
pub mod teacher;
#[cfg(test)]
mod tests;

pub use collector::*;
pub use config::*;
pub use run::*;
pub use student::*;
pub use teacher::*;
