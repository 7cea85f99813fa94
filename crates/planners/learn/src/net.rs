//! [`QNet`]: the MADE-Net Q-network (MFE → F3 → CONCAT → F4 → LSTM → F5 → F6), shared by the
//! CEP and the DEPs, which differ only in their [`NetConfig`].

use burn::module::Module;
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::nn::{LeakyRelu, LeakyReluConfig, Linear, LinearConfig, Lstm, LstmConfig};
use burn::tensor::{Device, Tensor};

use crate::config::{ConfigError, NetConfig};

/// The LSTM's recurrent state carried between calls: `cell` and `hidden`, each
/// `[batch, lstm_hidden]` (burn's [`burn::nn::LstmState`]).
pub type LstmState = burn::nn::LstmState<2>;

/// One layer's output shape, as recorded by [`QNet::trace`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LayerShape {
    /// The paper's layer name (`"C1"`, …, `"F6"`).
    pub layer: &'static str,
    /// Output dims of that layer for the traced call.
    pub dims: Vec<usize>,
}

/// The MADE-Net Q-network. Fields are named after the paper's layers (Sec. III.C.2, IV).
#[derive(Module, Debug)]
pub struct QNet {
    /// MFE convolution C1 (kernel 4, stride 2, 8 channels).
    pub c1: Conv2d,
    /// MFE convolution C2 (3, 2, 16).
    pub c2: Conv2d,
    /// MFE convolution C3 (2, 2, 16).
    pub c3: Conv2d,
    /// MFE fully connected F1 (32) on the flattened C3 output.
    pub f1: Linear,
    /// MFE fully connected F2 (10): the map feature.
    pub f2: Linear,
    /// F3 (`width`) on the non-map observation vector.
    pub f3: Linear,
    /// CONCAT as a learned layer (`width`), present only with [`NetConfig::concat_fc`].
    pub concat: Option<Linear>,
    /// F4 (`width`).
    pub f4: Linear,
    /// The LSTM (hidden 64) over the macro-step sequence.
    pub lstm: Lstm,
    /// F5 (`width`).
    pub f5: Linear,
    /// F6: the Q values (`outputs`), no activation.
    pub f6: Linear,
    /// The leaky ReLU used after every layer but F6 (and the LSTM, whose output is already
    /// `o ⊙ tanh(c)`).
    pub act: LeakyRelu,
    /// Map channels expected.
    pub map_channels: usize,
    /// Map height expected.
    pub map_height: usize,
    /// Map width expected.
    pub map_width: usize,
    /// Observation vector length expected.
    pub obs_dim: usize,
    /// Number of Q outputs.
    pub outputs: usize,
}

impl NetConfig {
    /// Builds the network on `device` (use [`crate::cpu`] for acting/evaluation and
    /// [`crate::cpu_autodiff`] for training), or says why the sizes don't work.
    pub fn init(&self, device: &Device) -> Result<QNet, ConfigError> {
        let dims = self.validate()?;
        let conv = |cin: usize, spec: crate::ConvSpec| {
            Conv2dConfig::new([cin, spec.channels], [spec.kernel, spec.kernel])
                .with_stride([spec.stride, spec.stride])
                .init(device)
        };
        let linear = |i: usize, o: usize| LinearConfig::new(i, o).init(device);
        Ok(QNet {
            c1: conv(self.map_channels, self.c1),
            c2: conv(self.c1.channels, self.c2),
            c3: conv(self.c2.channels, self.c3),
            f1: linear(dims.flat, self.f1),
            f2: linear(self.f1, self.f2),
            f3: linear(self.obs_dim, self.width),
            concat: self
                .concat_fc
                .then(|| linear(self.width + self.f2, self.width)),
            f4: linear(self.f4_input(), self.width),
            lstm: LstmConfig::new(self.width, self.lstm_hidden, true).init(device),
            f5: linear(self.lstm_hidden, self.width),
            f6: linear(self.width, self.outputs),
            act: LeakyReluConfig::new()
                .with_negative_slope(self.leaky_slope)
                .init(),
            map_channels: self.map_channels,
            map_height: self.map_height,
            map_width: self.map_width,
            obs_dim: self.obs_dim,
            outputs: self.outputs,
        })
    }
}

impl QNet {
    /// Q values over whole sequences (training).
    ///
    /// * `maps`: `[batch, time, channels, H, W]`, `obs`: `[batch, time, obs_dim]`;
    /// * `state`: the LSTM state before the first step (`None` = zeros);
    /// * returns Q `[batch, time, outputs]` and the LSTM state after the last step.
    ///
    /// The convolutions and fully connected layers run on all `batch·time` steps at once; the
    /// LSTM runs over the time axis in one call.
    pub fn forward(
        &self,
        maps: Tensor<5>,
        obs: Tensor<3>,
        state: Option<LstmState>,
    ) -> (Tensor<3>, LstmState) {
        self.forward_traced(maps, obs, state, None)
    }

    /// One step (execution): `maps` `[batch, channels, H, W]`, `obs` `[batch, obs_dim]` and the
    /// carried LSTM state (`None` at the start of an episode); returns Q `[batch, outputs]` and
    /// the state to carry to the next decision.
    pub fn act(
        &self,
        maps: Tensor<4>,
        obs: Tensor<2>,
        state: Option<LstmState>,
    ) -> (Tensor<2>, LstmState) {
        let [b, c, h, w] = maps.dims();
        let [_, d] = obs.dims();
        let (q, state) = self.forward(maps.reshape([b, 1, c, h, w]), obs.reshape([b, 1, d]), state);
        (q.reshape([b, self.outputs]), state)
    }

    /// Runs [`Self::forward`] and records every layer's output shape, in order (C1 … F6;
    /// CONCAT is recorded whether learned or bare).
    pub fn trace(&self, maps: Tensor<5>, obs: Tensor<3>) -> Vec<LayerShape> {
        let mut shapes = Vec::new();
        self.forward_traced(maps, obs, None, Some(&mut shapes));
        shapes
    }

    /// The MFE alone: `[n, channels, H, W]` → `[n, f2]`.
    pub fn mfe(&self, maps: Tensor<4>) -> Tensor<2> {
        self.mfe_traced(maps, &mut None)
    }

    fn mfe_traced(&self, maps: Tensor<4>, trace: &mut Option<&mut Vec<LayerShape>>) -> Tensor<2> {
        let x = record(trace, "C1", self.act.forward(self.c1.forward(maps)));
        let x = record(trace, "C2", self.act.forward(self.c2.forward(x)));
        let x = record(trace, "C3", self.act.forward(self.c3.forward(x)));
        let x: Tensor<2> = x.flatten(1, 3);
        let x = record(trace, "F1", self.act.forward(self.f1.forward(x)));
        record(trace, "F2", self.act.forward(self.f2.forward(x)))
    }

    fn forward_traced(
        &self,
        maps: Tensor<5>,
        obs: Tensor<3>,
        state: Option<LstmState>,
        mut trace: Option<&mut Vec<LayerShape>>,
    ) -> (Tensor<3>, LstmState) {
        let [b, t, c, h, w] = maps.dims();
        let [ob, ot, d] = obs.dims();
        assert_eq!(
            [c, h, w],
            [self.map_channels, self.map_height, self.map_width],
            "maps must be [batch, time, channels, H, W] of this network's config"
        );
        assert_eq!(
            [ob, ot, d],
            [b, t, self.obs_dim],
            "obs must be [batch, time, obs_dim]"
        );
        let n = b * t;
        let map_feat = self.mfe_traced(maps.reshape([n, c, h, w]), &mut trace);
        let obs_feat = record(
            &mut trace,
            "F3",
            self.act.forward(self.f3.forward(obs.reshape([n, d]))),
        );
        let x = Tensor::cat(vec![obs_feat, map_feat], 1);
        let x = match &self.concat {
            Some(concat) => self.act.forward(concat.forward(x)),
            None => x,
        };
        let x = record(&mut trace, "CONCAT", x);
        let x = record(&mut trace, "F4", self.act.forward(self.f4.forward(x)));
        let width = x.dims()[1];
        let (x, state) = self.lstm.forward(x.reshape([b, t, width]), state);
        let x = record(&mut trace, "LSTM", x);
        let x = record(&mut trace, "F5", self.act.forward(self.f5.forward(x)));
        let q = record(&mut trace, "F6", self.f6.forward(x));
        (q, state)
    }
}

fn record<const D: usize>(
    trace: &mut Option<&mut Vec<LayerShape>>,
    layer: &'static str,
    x: Tensor<D>,
) -> Tensor<D> {
    if let Some(t) = trace.as_deref_mut() {
        t.push(LayerShape {
            layer,
            dims: x.dims().to_vec(),
        });
    }
    x
}
