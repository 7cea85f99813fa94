//! Step 4: the students (the paper's DEP on the grid, or the size- and team-agnostic DEP), their
//! losses on the labels' advantages, the updates, and refitting a stored run's labels.

use super::{config::*, run::*, teacher::*};
use crate::agnostic::{AgnosticInput, AgnosticNet, Batch, CONTEXT_FEATURES};
use crate::error::TrainError;
use crate::harness::{self};
use crate::learner::adam_step;
use crate::model::{Model, ModelInfo};
use crate::obs::unpack_bits;
use crate::{cpu_autodiff, QNet};
use burn::module::Module;
use burn::optim::grad_clipping::GradientClippingConfig;
use burn::optim::{AdamConfig, ModuleOptimizer};
use burn::tensor::{Tensor, TensorData};
use madenet_agent::AgentView;
use madenet_world::rng::stream;
use rand::RngExt;
use std::path::Path;
use std::sync::Arc;

/// The DEP being trained (on the autodiff device).
#[derive(Clone)]
#[allow(clippy::large_enum_variant)] // one per run, never moved in a loop
pub(super) enum Student {
    Grid(QNet),
    Agnostic(AgnosticNet),
}

impl Student {
    pub(super) fn init(
        cfg: &RolloutTrainConfig,
        device: &burn::tensor::Device,
    ) -> Result<Self, TrainError> {
        Ok(match cfg.network {
            Network::Grid => Student::Grid(cfg.net_config().init(device)?),
            Network::Agnostic => {
                Student::Agnostic(cfg.agnostic().init(device).map_err(TrainError::Other)?)
            }
        })
    }

    /// Share of `labelled` decisions (those with targets) at which the greedy student's choice
    /// is among the teacher's best candidates, and the correlation of its scores (less their
    /// mean over the valid candidates) with the labels' advantages, and the same for the
    /// `spread` rule's score (negated: lower is better there; read from the candidate inputs),
    /// and what the teacher's and the student's choices (greedy and with each of `margins`)
    /// gain on the labels over `spread`'s; `None` for the grid network or no decision.
    pub(super) fn imitation<'a>(
        &self,
        labelled: impl Iterator<Item = &'a Labelled>,
        margins: &[f32],
    ) -> LabelFit {
        let Student::Agnostic(net) = self else {
            return LabelFit::default();
        };
        let net = crate::agnostic::AgnosticScorer::new(&net.valid());
        let (mut n, mut agree) = (0usize, 0usize);
        let (mut corr, mut spread_corr) = (Correlation::default(), Correlation::default());
        let acting: Vec<Option<f32>> = std::iter::once(None)
            .chain(margins.iter().map(|&m| Some(m)))
            .collect();
        // Over the decisions where `spread`'s choice is known: their count, Σ of the teacher's
        // gain, Σ of the student's per margin of `acting`.
        let (mut anchored, mut teacher_sum) = (0usize, 0.0);
        let mut student_sums = vec![0.0; acting.len()];
        for l in labelled.filter(|l| l.train_mask.iter().any(|&m| m)) {
            let input = AgnosticInput {
                context: l.vec[..CONTEXT_FEATURES].to_vec(),
                features: l.vec[CONTEXT_FEATURES..].to_vec(),
                crops: l.map.clone(),
                mask: l.train_mask.clone(),
            };
            let q = net.scores(&input);
            let valid = || (0..q.len()).filter(|&k| l.train_mask[k]);
            let mean = valid().map(|k| q[k] as f64).sum::<f64>() / valid().count() as f64;
            for k in valid() {
                corr.add(q[k] as f64 - mean, l.target[k] as f64);
            }
            // `spread`'s score of k / (height + width), from the candidate's inputs.
            let width = (l.vec.len() - CONTEXT_FEATURES) / l.train_mask.len().max(1);
            let spread = |k: usize| {
                -l.vec[CONTEXT_FEATURES + k * width + AgentView::SPREAD_SCORE_FEATURE] as f64
            };
            let spread_mean = valid().map(spread).sum::<f64>() / valid().count() as f64;
            for k in valid() {
                spread_corr.add(spread(k) - spread_mean, l.target[k] as f64);
            }
            let masked = |v: &[f32], k: usize| {
                if l.train_mask[k] {
                    v[k]
                } else {
                    f32::NEG_INFINITY
                }
            };
            // The choice the acting policy makes greedily.
            let Some(pick) = crate::actions::masked_argmax_slice(&q, &l.train_mask) else {
                continue;
            };
            let best = (0..l.train_mask.len())
                .map(|k| masked(&l.target, k))
                .fold(f32::NEG_INFINITY, f32::max);
            n += 1;
            agree += (l.target[pick] == best) as usize;
            if let Some((teacher, students)) = label_gains(l, &q, &acting) {
                anchored += 1;
                teacher_sum += teacher;
                for (sum, gain) in student_sums.iter_mut().zip(students) {
                    *sum += gain;
                }
            }
        }
        let mean = |sum: f64| sum / anchored as f64;
        LabelFit {
            agreement: (n > 0).then(|| agree as f64 / n as f64),
            label_corr: corr.value(),
            spread_label_corr: spread_corr.value(),
            teacher_label_gain: (anchored > 0).then(|| mean(teacher_sum)),
            student_gains: if anchored > 0 {
                acting
                    .into_iter()
                    .zip(student_sums.into_iter().map(mean))
                    .collect()
            } else {
                Vec::new()
            },
        }
    }

    /// The student on the plain CPU device as a model acting with `info`'s margin.
    pub(super) fn model(&self, info: ModelInfo) -> Model {
        match self {
            Student::Grid(net) => {
                Model::with_grid(info, vec![Arc::new(net.valid())]).expect("one DEP")
            }
            Student::Agnostic(net) => Model::with_agnostic(info, net.valid()),
        }
    }

    /// Saves the weights (of the plain copy when `plain`) to `path`.
    pub(super) fn save(&self, path: &Path, plain: bool) -> Result<(), TrainError> {
        let result = match (self, plain) {
            (Student::Grid(n), true) => n.valid().into_record().save(path),
            (Student::Grid(n), false) => n.clone().into_record().save(path),
            (Student::Agnostic(n), true) => n.valid().into_record().save(path),
            (Student::Agnostic(n), false) => n.clone().into_record().save(path),
        };
        result.map_err(|e| TrainError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })
    }

    pub(super) fn load(self, path: &Path) -> Result<Self, TrainError> {
        Ok(match self {
            Student::Grid(n) => Student::Grid(harness::load_weights(n, path)?),
            Student::Agnostic(n) => Student::Agnostic(harness::load_weights(n, path)?),
        })
    }

    /// One Adam step on `windows` (single decisions for the agnostic network).
    fn update(
        self,
        optim: &mut ModuleOptimizer,
        cfg: &RolloutTrainConfig,
        windows: &[&[Labelled]],
    ) -> (Self, f32) {
        match self {
            Student::Grid(net) => {
                let (net, loss) = update(net, optim, cfg, windows);
                (Student::Grid(net), loss)
            }
            Student::Agnostic(net) => {
                let (net, loss) = update_agnostic(net, optim, cfg, windows);
                (Student::Agnostic(net), loss)
            }
        }
    }
}

/// The student's loss on scores `q` against the teacher's advantages `y` (`[rows, slots]`; `m`
/// is 1 on trained slots): [`Loss`].
pub(super) fn student_loss(
    cfg: &RolloutTrainConfig,
    q: Tensor<2>,
    y: Tensor<2>,
    m: Tensor<2>,
) -> Tensor<1> {
    match cfg.loss {
        Loss::Advantage => advantage_loss(q, y, m),
        Loss::Listwise => listwise_loss(q, y, m, cfg.listwise_temperature),
    }
}

/// Σ over rows with a trained slot of −Σ_k softmax(y/τ)_k · log softmax(q/τ)_k over the trained
/// slots, divided by those rows' count (untrained slots pushed to −10⁹ before both softmaxes,
/// after the division by τ).
pub(super) fn listwise_loss(q: Tensor<2>, y: Tensor<2>, m: Tensor<2>, tau: f32) -> Tensor<1> {
    use burn::tensor::activation::{log_softmax, softmax};
    let off = m.clone().neg().add_scalar(1.0).mul_scalar(1e9);
    let p = softmax(y.div_scalar(tau).sub(off.clone()), 1).mul(m.clone());
    let log_q = log_softmax(q.div_scalar(tau).sub(off), 1);
    let rows = m.clone().sum_dim(1).clamp_max(1.0);
    let count = rows.clone().sum().clamp_min(1.0);
    p.mul(log_q)
        .mul(m)
        .sum_dim(1)
        .mul(rows)
        .sum()
        .neg()
        .div(count)
}

/// The masked mean squared error between scores `q` centred over each row's trained slots and
/// the teacher's advantages `y` (`[rows, slots]`; `m` is 1 on trained slots).
pub(super) fn advantage_loss(q: Tensor<2>, y: Tensor<2>, m: Tensor<2>) -> Tensor<1> {
    let g = q.dims()[1];
    let count = m.clone().sum().clamp_min(1.0);
    let n = m.clone().sum_dim(1).clamp_min(1.0);
    let mean = q.clone().mul(m.clone()).sum_dim(1).div(n).repeat_dim(1, g);
    let centred = (q - mean).mul(m.clone());
    (centred - y).powf_scalar(2.0).mul(m).sum().div(count)
}

/// One Adam step on a batch of robot windows: masked MSE between the DEP's centred Q values and
/// the teacher's advantages. Returns the loss.
pub(super) fn update(
    net: QNet,
    optim: &mut ModuleOptimizer,
    cfg: &RolloutTrainConfig,
    windows: &[&[Labelled]],
) -> (QNet, f32) {
    let (h, w) = (cfg.map_height, cfg.map_width);
    let map_len = 4 * h * w;
    let (b, t) = (
        windows.len(),
        windows.iter().map(|s| s.len()).max().unwrap_or(1).max(1),
    );
    let g = cfg.goals();
    let d = windows
        .iter()
        .find_map(|s| s.first())
        .map_or(1, |l| l.vec.len());
    let (mut maps, mut obs) = (vec![0.0f32; b * t * map_len], vec![0.0f32; b * t * d]);
    let (mut target, mut mask) = (vec![0.0f32; b * t * g], vec![0.0f32; b * t * g]);
    for (bi, seq) in windows.iter().enumerate() {
        for (ti, l) in seq.iter().enumerate() {
            let idx = bi * t + ti;
            unpack_bits(&l.map, &mut maps[idx * map_len..(idx + 1) * map_len]);
            obs[idx * d..(idx + 1) * d].copy_from_slice(&l.vec);
            for k in 0..g {
                target[idx * g + k] = l.target[k];
                mask[idx * g + k] = l.train_mask[k] as u8 as f32;
            }
        }
    }
    let device = net.devices()[0].clone();
    let maps = Tensor::<5>::from_data(TensorData::new(maps, [b, t, 4, h, w]), &device);
    let obs = Tensor::<3>::from_data(TensorData::new(obs, [b, t, d]), &device);
    let y = Tensor::<2>::from_data(TensorData::new(target, [b * t, g]), &device);
    let m = Tensor::<2>::from_data(TensorData::new(mask, [b * t, g]), &device);
    let (q, _) = net.forward(maps, obs, None);
    let loss = student_loss(cfg, q.reshape([b * t, g]), y, m);
    adam_step(net, optim, cfg.learning_rate, loss)
}

/// One Adam step of the agnostic DEP on single decisions (the first of each window): the same
/// loss as [`update`], slots padded to the widest decision of the batch.
pub(super) fn update_agnostic(
    net: AgnosticNet,
    optim: &mut ModuleOptimizer,
    cfg: &RolloutTrainConfig,
    windows: &[&[Labelled]],
) -> (AgnosticNet, f32) {
    let inputs: Vec<AgnosticInput> = windows
        .iter()
        .filter_map(|w| w.first())
        .map(|l| AgnosticInput {
            context: l.vec[..CONTEXT_FEATURES].to_vec(),
            features: l.vec[CONTEXT_FEATURES..].to_vec(),
            crops: l.map.clone(),
            mask: l.train_mask.clone(),
        })
        .collect();
    let refs: Vec<&AgnosticInput> = inputs.iter().collect();
    let device = net.devices()[0].clone();
    let batch = Batch::of(&refs, net.crop_side, &device);
    let (b, g) = (refs.len(), batch.slots);
    let mut target = vec![0.0f32; b * g];
    for (i, l) in windows.iter().filter_map(|w| w.first()).enumerate() {
        target[i * g..i * g + l.target.len()].copy_from_slice(&l.target);
    }
    let y = Tensor::<2>::from_data(TensorData::new(target, [b, g]), &device);
    let q = net.forward(
        batch.crops,
        batch.features,
        batch.context,
        batch.mask.clone(),
    );
    let loss = student_loss(cfg, q, y, batch.mask);
    adam_step(net, optim, cfg.learning_rate, loss)
}

/// Adam steps `updates` (their indices name each batch's `sample` stream, so a run resumed at
/// an iteration boundary draws what an uninterrupted one draws) on batches of windows of the
/// robots' decision sequences `data`; the trained student and the sum of the steps' losses, or
/// `None` as soon as `stop` says so.
pub(super) fn fit(
    mut net: Student,
    optim: &mut ModuleOptimizer,
    cfg: &RolloutTrainConfig,
    data: &[Vec<Labelled>],
    updates: std::ops::Range<u64>,
    stop: &dyn Fn() -> bool,
) -> Option<(Student, f64)> {
    let mut loss_sum = 0.0;
    let trace_len = if cfg.recurrent { cfg.trace_len } else { 1 };
    for u in updates {
        if stop() {
            return None;
        }
        let mut rng = stream(cfg.seed, "sample", u);
        let windows: Vec<&[Labelled]> = (0..cfg.batch_size)
            .map(|_| {
                let seq = &data[rng.random_range(0..data.len())];
                let start = if seq.len() > trace_len {
                    rng.random_range(0..=seq.len() - trace_len)
                } else {
                    0
                };
                &seq[start..(start + trace_len).min(seq.len())]
            })
            .collect();
        let (next, loss) = net.update(optim, cfg, &windows);
        net = next;
        loss_sum += loss as f64;
    }
    Some((net, loss_sum))
}

/// What [`fit_checked`] ends with.
pub(super) struct Fitted {
    pub(super) net: Student,
    /// Σ of the losses of the updates made.
    pub(super) loss_sum: f64,
    pub(super) updates: u64,
    /// The kept student's correlation with the held-out labels (`fit_holdout`).
    pub(super) holdout_corr: Option<f64>,
}

/// An iteration's fit: [`fit`] on `train` for `updates_per_iteration` updates numbered from
/// `first`, or with held-out sequences (`fit_holdout`) in rounds of `fit_check_every`, scoring
/// the student against their labels after each round and ending after `fit_patience` rounds
/// without a better score, with the best-scoring student. `None` when `stop` said so.
pub(super) fn fit_checked(
    net: Student,
    optim: &mut ModuleOptimizer,
    cfg: &RolloutTrainConfig,
    (train, held_out): (&[Vec<Labelled>], &[Vec<Labelled>]),
    first: u64,
    stop: &dyn Fn() -> bool,
) -> Option<Fitted> {
    let all = cfg.updates_per_iteration;
    if held_out.is_empty() {
        let (net, loss_sum) = fit(net, optim, cfg, train, first..first + all, stop)?;
        return Some(Fitted {
            net,
            loss_sum,
            updates: all,
            holdout_corr: None,
        });
    }
    let (mut net, mut done, mut loss_sum, mut since_best) = (net, 0, 0.0, 0);
    let mut best: Option<(f64, Student)> = None;
    while done < all && since_best < cfg.fit_patience {
        let to = (done + cfg.fit_check_every).min(all);
        let (next, loss) = fit(net, optim, cfg, train, first + done..first + to, stop)?;
        (net, done, loss_sum) = (next, to, loss_sum + loss);
        let corr = net.imitation(held_out.iter().flatten(), &[]).label_corr;
        match (corr, &best) {
            (Some(c), Some((b, _))) if c <= *b => since_best += 1,
            (Some(c), _) => (best, since_best) = (Some((c, net.clone())), 0),
            (None, _) => since_best += 1,
        }
    }
    let holdout_corr = best.as_ref().map(|b| b.0);
    Some(Fitted {
        net: best.map_or(net, |b| b.1),
        loss_sum,
        updates: done,
        holdout_corr,
    })
}

/// A run's stored labels (`RUN/checkpoint/data.bin`: every robot's labelled decisions in
/// episode order) cut at its iterations' boundaries (`RUN/iterations.csv`'s `decisions`): entry
/// `i` holds the decision sequences iteration `i` collected.
pub fn stored_labels(run_dir: &Path) -> Result<Vec<Vec<Vec<Labelled>>>, TrainError> {
    let data: Vec<Vec<Labelled>> =
        harness::read_postcard(&run_dir.join("checkpoint").join("data.bin"))?;
    let log = run_dir.join("iterations.csv");
    let rows = read_rows(&log)?;
    let mut data = data.into_iter();
    let mut out = Vec::new();
    for row in &rows {
        let (mut seqs, mut n) = (Vec::new(), 0);
        while n < row.decisions {
            let Some(seq) = data.next() else { break };
            n += seq.len();
            seqs.push(seq);
        }
        if n != row.decisions {
            return Err(TrainError::Other(format!(
                "{}: iteration {} logs {} decisions but `checkpoint/data.bin` holds {n} there (a checkpoint and log of different runs?)",
                log.display(),
                row.iteration,
                row.decisions
            )));
        }
        out.push(seqs);
    }
    Ok(out)
}

/// The supervised half of a run alone: a fresh agnostic student of `sizes` (seeded, drawing its
/// batches and stepping as a run with `cfg` does) fitted to `train` for `updates` Adam steps,
/// measured against `test`'s labels after every `every` steps and at the end — does a larger or
/// differently trained student fit labels it never saw better? With `cfg`'s sizes and
/// `updates_per_iteration` as `updates`, `train` = a run's iteration 0 and `test` its iteration
/// 1, the last row is that run's `student_label_corr` of iteration 1 (for a run without
/// `fit_holdout`, whose iteration 0 fitted every label for every update). Rows: (updates so far,
/// mean loss since the last row, the fit).
pub fn refit(
    cfg: &RolloutTrainConfig,
    sizes: &crate::agnostic::AgnosticConfig,
    train: &[Vec<Labelled>],
    test: &[Labelled],
    updates: u64,
    every: u64,
) -> Result<Vec<(u64, f64, LabelFit)>, TrainError> {
    if train.is_empty() {
        return Err(TrainError::Other("refit: no training labels".into()));
    }
    if sizes.crop_radius != cfg.crop_radius {
        return Err(TrainError::Other(format!(
            "refit: field `crop_radius`: the labels' crops are of radius {}, not {}",
            cfg.crop_radius, sizes.crop_radius
        )));
    }
    if cfg.network != Network::Agnostic
        || sizes.wide() != cfg.wide_inputs
        || sizes.territory() != cfg.territory_inputs
        || sizes.plan() != cfg.plan_inputs
    {
        return Err(TrainError::Other(
            "refit: fields `network`/`wide_inputs`/`territory_inputs`/`plan_inputs`: the labels must be an agnostic run's, with the inputs `sizes` expects".into(),
        ));
    }
    let (mut net, mut optim) = fresh_student(cfg, Some(sizes))?;
    let (mut done, mut rows) = (0, Vec::new());
    while done < updates {
        let to = (done + every.max(1)).min(updates);
        let (next, loss) =
            fit(net, &mut optim, cfg, train, done..to, &|| false).expect("never stopped");
        net = next;
        rows.push((
            to,
            loss / (to - done) as f64,
            net.imitation(test.iter(), &cfg.spread_margins),
        ));
        done = to;
    }
    Ok(rows)
}

/// What choosing by the labels, and by the scores `q` acting with each of `acting`'s margins
/// (`None`: greedy), gains at one labelled decision (agnostic inputs) over `spread`'s choice, in
/// label units; `None` when `spread`'s choice is not among the decision's trained candidates.
pub(super) fn label_gains(
    l: &Labelled,
    q: &[f32],
    acting: &[Option<f32>],
) -> Option<(f64, Vec<f64>)> {
    let slots = l.train_mask.len();
    let width = (l.vec.len() - CONTEXT_FEATURES) / slots.max(1);
    let anchor = crate::agnostic::spread_slot(&l.vec[CONTEXT_FEATURES..], width, &l.train_mask)?;
    let valid = || (0..slots).filter(|&k| l.train_mask[k]);
    let best = valid()
        .map(|k| l.target[k])
        .fold(f32::NEG_INFINITY, f32::max);
    let greedy = crate::actions::masked_argmax_slice(q, &l.train_mask)?;
    let over = |k: usize| (l.target[k] - l.target[anchor]) as f64;
    let students = acting
        .iter()
        .map(|&margin| over(crate::policy::conservative(q, greedy, margin, Some(anchor))))
        .collect();
    Some(((best - l.target[anchor]) as f64, students))
}

/// `net` with the weights of `cfg.init_model`, which [`crate::Model::load`] checks (digests, sizes,
/// NaN) and which must be an agnostic model of the run's sizes.
pub(super) fn warm_start(cfg: &RolloutTrainConfig, net: Student) -> Result<Student, TrainError> {
    let dir = Path::new(&cfg.init_model);
    let bad = |why: String| TrainError::Config {
        path: dir.display().to_string(),
        message: format!("field `init_model`: {why}"),
    };
    let model = crate::Model::load(dir).map_err(|e| bad(e.to_string()))?;
    if model.info.agnostic.as_ref() != Some(&cfg.agnostic()) {
        return Err(bad(
            "not an agnostic model of this run's sizes (crop_radius, wide_inputs, territory_inputs, plan_inputs)".into(),
        ));
    }
    let weights = model
        .info
        .deps
        .first()
        .ok_or_else(|| bad("no weight file".into()))?;
    net.load(&dir.join(weights))
}

/// A fresh student on the seeded training device and its Adam optimizer, as every fit starts:
/// of `cfg`'s network, or agnostic of `sizes`.
pub(super) fn fresh_student(
    cfg: &RolloutTrainConfig,
    sizes: Option<&crate::agnostic::AgnosticConfig>,
) -> Result<(Student, ModuleOptimizer), TrainError> {
    let device = cpu_autodiff();
    device.seed(cfg.seed);
    let net = match sizes {
        Some(sizes) => Student::Agnostic(sizes.init(&device).map_err(TrainError::Other)?),
        None => Student::init(cfg, &device)?,
    };
    let optim = AdamConfig::new()
        .with_grad_clipping(Some(GradientClippingConfig::Norm(cfg.grad_clip_norm)))
        .init();
    Ok((net, optim))
}
