//! MADE-Net at execution time: each robot runs its DEP on its own macro observation at its
//! macro-action terminations, greedily over its valid goal candidates, carrying the LSTM state
//! from one decision to the next (paper Sec. III.C.3, *Decentralized Execution*).

use crate::obs::{action_mask, Observation};
use crate::{masked_argmax_slice, LstmState, QNet, Tensor, TensorData};
use madenet_agent::{AgentView, Decision, Policy};
use std::sync::Arc;

/// One robot's MADE-Net (or MADE-Net-DT) policy.
pub struct DepPolicy {
    name: String,
    net: Arc<QNet>,
    state: Option<LstmState>,
    device: burn::tensor::Device,
    observation: Observation,
    recurrent: bool,
    spread_margin: Option<f32>,
    /// The Q-values of the last decision (empty: none).
    last: Vec<f32>,
}

impl DepPolicy {
    /// A fresh policy (zero LSTM state) running `net` under registry name `name`.
    pub fn new(name: &str, net: Arc<QNet>) -> Self {
        DepPolicy {
            name: name.to_string(),
            net,
            state: None,
            last: Vec::new(),
            device: crate::cpu(),
            observation: Observation::Paper,
            recurrent: true,
            spread_margin: None,
        }
    }

    /// Whether the LSTM state is carried from decision to decision (the paper's DEP) or every
    /// decision starts from zero state (a model trained on single decisions).
    pub fn with_recurrence(mut self, recurrent: bool) -> Self {
        self.recurrent = recurrent;
        self
    }

    /// Conservative acting: the `spread` rule's candidate unless the DEP values another more by
    /// at least `margin` (`None`: the DEP's greedy choice).
    pub fn with_spread_margin(mut self, margin: Option<f32>) -> Self {
        self.spread_margin = margin;
        self
    }

    /// Reads `observation`'s vector instead of the paper's.
    pub fn with_observation(mut self, observation: Observation) -> Self {
        self.observation = observation;
        self
    }
}

impl Policy for DepPolicy {
    fn name(&self) -> &str {
        &self.name
    }
    fn last_scores(&self) -> Option<&[f32]> {
        (!self.last.is_empty()).then_some(&self.last[..])
    }
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision {
        let (h, w) = (view.belief.height(), view.belief.width());
        let m: Vec<f32> = view.map_image().into_iter().map(f32::from).collect();
        let vec = self.observation.vector(view);
        let mask = action_mask(view);
        let maps = Tensor::<4>::from_data(TensorData::new(m, [1, 4, h, w]), &self.device);
        let obs =
            Tensor::<2>::from_data(TensorData::new(vec.clone(), [1, vec.len()]), &self.device);
        let (q, state) = self.net.act(maps, obs, self.state.take());
        self.state = self.recurrent.then_some(state);
        let q = q
            .into_data()
            .try_into_vec_as::<f32>()
            .expect("Q values readable as f32");
        // The state advances at every decision, as in training; with no valid candidate the
        // mask offers slot 0 alone, which leaves the robot without a goal (it stays).
        if !view.candidates().valid_mask().contains(&true) {
            self.last.clear();
            return Decision::Idle;
        }
        self.last.clone_from(&q);
        let greedy = masked_argmax_slice(&q, &mask).expect("a valid candidate");
        let anchor = self.spread_margin.and_then(|_| spread_choice(view));
        Decision::Candidate(conservative(&q, greedy, self.spread_margin, anchor))
    }
}

/// The candidate the `spread` rule takes, if any.
pub(crate) fn spread_choice(view: &mut AgentView<'_>) -> Option<usize> {
    madenet_agent::Spread
        .scores(view)
        .iter()
        .enumerate()
        .filter_map(|(k, s)| s.map(|s| (k, s)))
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
        .map(|(k, _)| k)
}

/// Conservative acting: `anchor` (the `spread` rule's candidate) unless the network values
/// `greedy` more than it by at least `margin` (`None`: `greedy`).
pub(crate) fn conservative(
    q: &[f32],
    greedy: usize,
    margin: Option<f32>,
    anchor: Option<usize>,
) -> usize {
    match (margin, anchor) {
        (Some(margin), Some(k)) if q[greedy] - q[k] < margin => k,
        _ => greedy,
    }
}
