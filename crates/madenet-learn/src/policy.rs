//! MADE-Net at execution time: each robot runs its DEP on its own macro observation at its
//! macro-action terminations, greedily over its valid goal candidates, carrying the LSTM state
//! from one decision to the next (paper Sec. III.C.3, *Decentralized Execution*).

use crate::obs::action_mask;
use crate::{masked_argmax_slice, LstmState, QNet, Tensor, TensorData};
use madenet_agent::{AgentView, Decision, DecisionMode, Policy};
use std::sync::Arc;

/// One robot's MADE-Net (or MADE-Net-DT) policy.
pub struct DepPolicy {
    name: String,
    net: Arc<QNet>,
    state: Option<LstmState>,
    device: burn::tensor::Device,
}

impl DepPolicy {
    /// A fresh policy (zero LSTM state) running `net` under registry name `name`.
    pub fn new(name: &str, net: Arc<QNet>) -> Self {
        DepPolicy { name: name.to_string(), net, state: None, device: crate::cpu() }
    }
}

impl Policy for DepPolicy {
    fn name(&self) -> &str {
        &self.name
    }
    fn mode(&self) -> DecisionMode {
        DecisionMode::OnTermination
    }
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision {
        let (h, w) = (view.belief.height(), view.belief.width());
        let m: Vec<f32> = view.map_image().into_iter().map(f32::from).collect();
        let vec = view.macro_observation();
        let mask = action_mask(view);
        let maps = Tensor::<4>::from_data(TensorData::new(m, [1, 4, h, w]), &self.device);
        let obs = Tensor::<2>::from_data(TensorData::new(vec.clone(), [1, vec.len()]), &self.device);
        let (q, state) = self.net.act(maps, obs, self.state.take());
        self.state = Some(state);
        let q = q.into_data().try_into_vec_as::<f32>().expect("Q values readable as f32");
        // The state advances at every decision, as in training; with no valid candidate the
        // mask offers slot 0 alone, which leaves the robot without a goal (it stays).
        if !view.candidates().valid_mask().contains(&true) {
            return Decision::Idle;
        }
        Decision::Candidate(masked_argmax_slice(&q, &mask).expect("a valid candidate"))
    }
}
