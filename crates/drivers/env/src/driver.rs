//! What both environments share: a trial of any world driven through the stepping contract
//! ([`madenet_sim::Stepping`]) with its decisions from the caller — the candidates a robot was
//! shown handed to it, the decisions applied, the trial advanced to the next decision point,
//! and the episode's end reported once.

use crate::EnvError;
use madenet_agent::{AgentView, Decision, ViewScratch};
use madenet_sim::Stepping;

/// A trial driven step by step from outside ([module docs](self)).
pub(crate) struct Driver<S> {
    /// The episode's trial (taking its decisions from outside).
    pub(crate) trial: Option<S>,
    /// One scratch per robot (a joint observation holds every robot's view at once).
    pub(crate) scratch: Vec<ViewScratch>,
    /// `scratch[i]` holds robot i's goal candidates (and their search) for the current state:
    /// a step hands them to the robot instead of extracting them again.
    pub(crate) scratch_current: Vec<bool>,
    /// A step has reported the end of the current episode.
    pub(crate) end_reported: bool,
}

/// How [`Driver::step`] went.
pub(crate) enum Stepped {
    /// The episode was already over (at its start, say): this step reports its end, nothing
    /// advanced. `terminated`: explored.
    Ended { terminated: bool },
    /// The trial advanced to the next decision point or its end.
    Advanced { terminated: bool, truncated: bool },
}

impl<S: Stepping> Driver<S> {
    /// No episode yet, for `n` robots on `height × width` cells.
    pub(crate) fn new(n: usize, height: usize, width: usize) -> Self {
        Driver {
            trial: None,
            scratch: (0..n).map(|_| ViewScratch::new(height, width)).collect(),
            scratch_current: vec![false; n],
            end_reported: false,
        }
    }

    /// Starts an episode with `trial` and runs it to its first decision point.
    pub(crate) fn start(&mut self, trial: S) {
        self.trial = Some(trial);
        self.scratch_current.fill(false);
        self.end_reported = false;
        let trial = self.trial.as_mut().expect("just set");
        advance(trial, &mut |_| {});
    }

    /// The trial, or the error of a call before `reset`.
    pub(crate) fn trial(&self, call: &str) -> Result<&S, EnvError> {
        self.trial
            .as_ref()
            .ok_or_else(|| EnvError::Usage(format!("call reset() before {call}")))
    }

    /// Whether the episode is over (or none was started).
    pub(crate) fn is_done(&self) -> bool {
        self.trial.as_ref().is_none_or(|t| t.is_done())
    }

    /// Which robots' decisions the next step uses, into `out`.
    pub(crate) fn needs_action_into(&self, out: &mut [bool]) {
        match &self.trial {
            Some(t) if !t.is_done() => out.copy_from_slice(t.deciding()),
            _ => out.fill(false),
        }
    }

    /// Which robots' decisions the next step uses (one per robot).
    pub(crate) fn needs_action(&self) -> Vec<bool> {
        let mut out = vec![false; self.scratch.len()];
        self.needs_action_into(&mut out);
        out
    }

    /// Robot `robot`'s view of the current state (as [`Driver::view`]) with its map image
    /// written into `map` and its observation vector into `vector`, once `robot` and the
    /// buffers' lengths (map, vector, mask) are checked against `lengths`; the caller writes
    /// the mask.
    pub(crate) fn observe_into(
        &mut self,
        robot: usize,
        candidates: bool,
        lengths: (usize, usize, usize),
        (map, vector, mask): (&mut [f32], &mut [f32], &[u8]),
    ) -> Result<AgentView<'_>, EnvError> {
        let n = self.scratch.len();
        if robot >= n {
            return Err(EnvError::Usage(format!("robot {robot}: the team has {n}")));
        }
        if (map.len(), vector.len(), mask.len()) != lengths {
            return Err(EnvError::Usage(
                "observation buffers of the wrong length".into(),
            ));
        }
        let view = self.view(robot, candidates)?;
        view.write_map_image(map);
        view.write_macro_observation(vector);
        Ok(view)
    }

    /// Robot `robot`'s view of the current state (its goal candidates with `candidates`),
    /// kept for the next step; reading it never changes the trajectory.
    pub(crate) fn view(
        &mut self,
        robot: usize,
        candidates: bool,
    ) -> Result<AgentView<'_>, EnvError> {
        let trial = self
            .trial
            .as_ref()
            .ok_or_else(|| EnvError::Usage("call reset() before observing".into()))?;
        self.scratch_current[robot] = candidates;
        Ok(trial.agents()[robot].peek_view(candidates, &mut self.scratch[robot]))
    }

    /// Applies `decisions` (one per robot, checked by the caller; `None`: the robot's own
    /// policy) to the robots that decide now and advances to the next decision point or the
    /// episode's end, calling `on_step` after every completed step. An episode already over
    /// reports its end once, then refuses.
    pub(crate) fn step(
        &mut self,
        decisions: &[Option<Decision>],
        on_step: &mut dyn FnMut(&S),
    ) -> Result<Stepped, EnvError> {
        let trial = self
            .trial
            .as_mut()
            .ok_or_else(|| EnvError::Usage("call reset() before step()".into()))?;
        if trial.is_done() {
            if self.end_reported {
                return Err(EnvError::Usage(
                    "the episode has ended; call reset()".into(),
                ));
            }
            self.end_reported = true;
            return Ok(Stepped::Ended {
                terminated: trial.is_complete(),
            });
        }
        for (i, d) in decisions.iter().enumerate() {
            if trial.deciding()[i] && matches!(d, Some(Decision::Candidate(_))) {
                // The robot's own candidates, as its own policy would see them: those of its
                // last observation if it is of this state, else extracted now.
                if self.scratch_current[i] {
                    trial.agent_mut(i).adopt_candidates(&mut self.scratch[i]);
                } else {
                    let _ = trial.agent_mut(i).view(true);
                }
            }
        }
        self.scratch_current.fill(false);
        trial.apply_decisions(decisions);
        advance(trial, on_step);
        let terminated = trial.is_done() && trial.is_complete();
        let truncated = trial.is_done() && !terminated;
        self.end_reported = terminated || truncated;
        Ok(Stepped::Advanced {
            terminated,
            truncated,
        })
    }
}

/// Steps `trial` until a robot waits for a decision or the trial is over, calling `on_step`
/// after every completed step (a step that stops at a decision point is not yet complete). A
/// step whose first half ended the trial is finished with the robots' own decisions.
fn advance<S: Stepping>(trial: &mut S, on_step: &mut dyn FnMut(&S)) {
    loop {
        if trial.deciding().contains(&true) {
            if !trial.is_done() {
                break;
            }
            trial.apply_decisions(&[]);
        }
        if !trial.step() {
            break;
        }
        if !trial.deciding().contains(&true) {
            on_step(trial);
        }
    }
}
