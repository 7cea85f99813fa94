//! The agnostic DEP at decision time: [`AgnosticNet::forward`]'s arithmetic on plain `f32`
//! weights, each convolution an im2col matrix product (`matrixmultiply`'s `sgemm`, which picks
//! AVX/FMA at run time), and only the valid candidates computed.
//!
//! Why not burn's forward pass: for one decision (4–8 crops of 13 × 13) burn's CPU backend
//! convolves plane by plane and splits the work over threads, which costs more than the work
//! (≈ 150 µs on 20 × 20 against issue 29's 100 µs for a whole decision). Training keeps burn's
//! forward and its gradients; a test holds the two forward passes equal to 1e-4.
//!
//! Same seed ⇒ same run holds on one machine; across machines `sgemm`'s run-time choice of
//! kernel (AVX/FMA or not) may change a score's last bits, and so a choice between two
//! candidates scored equal to within them (burn's backend dispatched the same way).

use super::{AgnosticInput, AgnosticNet, CONTEXT_FEATURES, CROP_CHANNELS};
use crate::Tensor;
use burn::module::Param;
use burn::nn::conv::Conv2d;
use burn::nn::{Linear, PaddingConfig2d};

/// The values of a layer's parameter `p` (`what`: which, in the panic should they not be `f32`).
fn values<const D: usize>(p: &Param<Tensor<D>>, what: &str) -> Vec<f32> {
    p.val().into_data().try_into_vec_as::<f32>().expect(what)
}

/// A layer's bias, or `n` zeros for a layer without one.
fn bias(b: &Option<Param<Tensor<1>>>, n: usize) -> Vec<f32> {
    match b {
        Some(b) => values(b, "f32 bias"),
        None => vec![0.0; n],
    }
}

/// A dense layer's weights: `w` is `[inputs, outputs]` row-major (burn's [`Linear`] layout).
#[derive(Clone, Debug)]
struct Dense {
    w: Vec<f32>,
    b: Vec<f32>,
    inputs: usize,
    outputs: usize,
}

impl Dense {
    fn of(l: &Linear) -> Self {
        let [inputs, outputs] = l.weight.val().dims();
        Dense {
            w: values(&l.weight, "f32 weights"),
            b: bias(&l.bias, outputs),
            inputs,
            outputs,
        }
    }

    /// `out` `[rows, outputs]` = `x` `[rows, inputs]` · w + b, then the leaky ReLU if `slope`.
    fn apply(&self, x: &[f32], rows: usize, out: &mut Vec<f32>, slope: Option<f32>) {
        debug_assert_eq!(x.len(), rows * self.inputs);
        out.clear();
        for _ in 0..rows {
            out.extend_from_slice(&self.b);
        }
        gemm_acc(x, rows, self.inputs, &self.w, self.outputs, out);
        if let Some(s) = slope {
            leaky(out, s);
        }
    }
}

/// A 3 × 3 "valid" convolution's weights as an im2col matrix `[in·3·3, out]`.
#[derive(Clone, Debug)]
struct Conv {
    dense: Dense,
    stride: usize,
    kernel: usize,
    channels_in: usize,
    /// The leaky ReLU's negative slope after it.
    slope: f32,
}

impl Conv {
    fn of(c: &Conv2d, slope: f32) -> Self {
        assert!(
            matches!(c.padding, PaddingConfig2d::Valid) && c.dilation == [1, 1] && c.groups == 1,
            "the agnostic DEP's convolutions are valid, undilated, ungrouped"
        );
        assert_eq!(c.stride[0], c.stride[1], "square strides");
        let [out, cin, kh, kw] = c.weight.val().dims();
        assert_eq!(kh, kw, "square kernels");
        let w = values(&c.weight, "f32 weights");
        // burn's [out, in, kh, kw] → rows (in, kh, kw), columns out.
        let k = cin * kh * kw;
        let mut m = vec![0.0; k * out];
        for o in 0..out {
            for r in 0..k {
                m[r * out + o] = w[o * k + r];
            }
        }
        let b = bias(&c.bias, out);
        Conv {
            dense: Dense {
                w: m,
                b,
                inputs: k,
                outputs: out,
            },
            stride: c.stride[0],
            kernel: kh,
            channels_in: cin,
            slope,
        }
    }

    fn out_side(&self, side: usize) -> usize {
        (side - self.kernel) / self.stride + 1
    }

    /// Convolves `n` images `x` of `side` × `side` pixels (channel-last `[n, y, x, c]`, or
    /// channel-first `[n, c, y, x]` if `channel_first`) into `out`, channel-last; returns the
    /// output side.
    fn apply(
        &self,
        x: &[f32],
        n: usize,
        side: usize,
        channel_first: bool,
        cols: &mut Vec<f32>,
        out: &mut Vec<f32>,
    ) -> usize {
        let (k, c, s) = (self.kernel, self.channels_in, self.stride);
        let o = self.out_side(side);
        let at = |img: usize, y: usize, xx: usize, ch: usize| {
            if channel_first {
                ((img * c + ch) * side + y) * side + xx
            } else {
                ((img * side + y) * side + xx) * c + ch
            }
        };
        cols.clear();
        cols.reserve(n * o * o * c * k * k);
        for img in 0..n {
            for oy in 0..o {
                for ox in 0..o {
                    for ch in 0..c {
                        for i in 0..k {
                            for j in 0..k {
                                cols.push(x[at(img, oy * s + i, ox * s + j, ch)]);
                            }
                        }
                    }
                }
            }
        }
        self.dense.apply(cols, n * o * o, out, Some(self.slope));
        o
    }
}

/// `out` `[m, n]` += `a` `[m, k]` · `b` `[k, n]`, all row-major.
fn gemm_acc(a: &[f32], m: usize, k: usize, b: &[f32], n: usize, out: &mut [f32]) {
    assert!(a.len() >= m * k && b.len() >= k * n && out.len() >= m * n);
    if m == 0 || n == 0 || k == 0 {
        return;
    }
    // SAFETY: the asserts above keep every index sgemm reads or writes inside the slices.
    unsafe {
        matrixmultiply::sgemm(
            m,
            k,
            n,
            1.0,
            a.as_ptr(),
            k as isize,
            1,
            b.as_ptr(),
            n as isize,
            1,
            1.0,
            out.as_mut_ptr(),
            n as isize,
            1,
        );
    }
}

fn leaky(x: &mut [f32], slope: f32) {
    for v in x {
        if *v < 0.0 {
            *v *= slope;
        }
    }
}

/// The agnostic DEP's weights, ready for decisions ([module docs](self)).
#[derive(Clone, Debug)]
pub struct AgnosticScorer {
    k1: Conv,
    k2: Conv,
    k3: Conv,
    /// KF with its rows in the channel-last order of K3's output.
    kf: Dense,
    embed: Dense,
    context: Dense,
    hidden: Dense,
    out: Dense,
    slope: f32,
    crop_side: usize,
}

impl AgnosticScorer {
    /// The weights of `net`, copied (a scorer does not follow later training of `net`).
    pub fn new(net: &AgnosticNet) -> Self {
        let slope = net.act.negative_slope as f32;
        let conv = |c: &Conv2d| Conv::of(c, slope);
        let (k1, k2, k3) = (conv(&net.k1), conv(&net.k2), conv(&net.k3));
        let side = k3.out_side(k2.out_side(k1.out_side(net.crop_side)));
        let ch = k3.dense.outputs;
        // burn flattens K3's output channel-first (c, y, x); this scorer holds it (y, x, c).
        let mut kf = Dense::of(&net.kf);
        let w = kf.w.clone();
        let hw = side * side;
        for c in 0..ch {
            for p in 0..hw {
                let (from, to) = ((c * hw + p) * kf.outputs, (p * ch + c) * kf.outputs);
                kf.w[to..to + kf.outputs].copy_from_slice(&w[from..from + kf.outputs]);
            }
        }
        AgnosticScorer {
            k1,
            k2,
            k3,
            kf,
            embed: Dense::of(&net.embed),
            context: Dense::of(&net.context),
            hidden: Dense::of(&net.hidden),
            out: Dense::of(&net.out),
            slope,
            crop_side: net.crop_side,
        }
    }

    /// The scores of one decision's slots, as [`AgnosticNet::scores`] gives them for the slots
    /// `input.mask` allows (the others: −∞, never chosen).
    pub fn scores(&self, input: &AgnosticInput) -> Vec<f32> {
        let slots = input.mask.len();
        let valid: Vec<usize> = (0..slots).filter(|&k| input.mask[k]).collect();
        let n = valid.len();
        let mut q = vec![f32::NEG_INFINITY; slots];
        if n == 0 {
            return q;
        }
        let side = self.crop_side;
        let crop_len = CROP_CHANNELS * side * side;
        let mut all = vec![0.0f32; slots * crop_len];
        crate::obs::unpack_bits(&input.crops, &mut all);
        let mut crops = Vec::with_capacity(n * crop_len);
        for &k in &valid {
            crops.extend_from_slice(&all[k * crop_len..(k + 1) * crop_len]);
        }
        let (mut cols, mut a, mut b) = (Vec::new(), Vec::new(), Vec::new());
        let s = self.k1.apply(&crops, n, side, true, &mut cols, &mut a);
        let s = self.k2.apply(&a, n, s, false, &mut cols, &mut b);
        self.k3.apply(&b, n, s, false, &mut cols, &mut a);
        self.kf.apply(&a, n, &mut b, Some(self.slope));
        // E on [crop feature ‖ candidate inputs].
        let fw = self.kf.outputs;
        let width = input.features.len() / slots; // CANDIDATE_INPUTS, or more (`wide_inputs`)
        assert_eq!(
            fw + width,
            self.embed.inputs,
            "candidate inputs of another width than the network's (wide_inputs?)"
        );
        let mut x = Vec::with_capacity(n * (fw + width));
        for (row, &k) in valid.iter().enumerate() {
            x.extend_from_slice(&b[row * fw..(row + 1) * fw]);
            x.extend_from_slice(&input.features[k * width..(k + 1) * width]);
        }
        let mut e = Vec::new();
        self.embed.apply(&x, n, &mut e, Some(self.slope));
        // C on [mean embedding over the valid slots ‖ robot context].
        let ew = self.embed.outputs;
        let mut pooled = vec![0.0f32; ew + CONTEXT_FEATURES];
        for row in 0..n {
            for (p, v) in pooled.iter_mut().zip(&e[row * ew..(row + 1) * ew]) {
                *p += v;
            }
        }
        for p in &mut pooled[..ew] {
            *p /= n as f32;
        }
        pooled[ew..].copy_from_slice(&input.context);
        let mut c = Vec::new();
        self.context.apply(&pooled, 1, &mut c, Some(self.slope));
        // H on [e_k ‖ c], then O.
        let mut h_in = Vec::with_capacity(n * (ew + c.len()));
        for row in 0..n {
            h_in.extend_from_slice(&e[row * ew..(row + 1) * ew]);
            h_in.extend_from_slice(&c);
        }
        let mut h = Vec::new();
        self.hidden.apply(&h_in, n, &mut h, Some(self.slope));
        let mut out = Vec::new();
        self.out.apply(&h, n, &mut out, None);
        for (row, &k) in valid.iter().enumerate() {
            q[k] = out[row];
        }
        q
    }
}
