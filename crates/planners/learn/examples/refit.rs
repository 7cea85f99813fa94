//! The supervised half of a rollout-teacher run alone: fits a fresh agnostic student to a run's
//! stored labels of its first iterations and prints, every `EVERY` updates, how it scores the
//! labels of the next iteration (which it never saw) — the `student_label_corr` of
//! `iterations.csv`, as a curve, for other network sizes, updates or losses than the run's.
//!
//! ```text
//! cargo run --release -p madenet-learn --example refit -- RUN_DIR [UPDATES [EVERY [WIDTH [TRAIN_ITERATIONS [LOSS [SHARE]]]]]]
//! ```
//!
//! `UPDATES` defaults to the run's `updates_per_iteration`; `WIDTH` multiplies every width of the network (conv channels, crop feature, embedding,
//! context, hidden; default 1); `TRAIN_ITERATIONS` (default 1) iterations are fitted and the
//! next one is the test, or with 0 the last quarter of iteration 0's robot sequences is the test
//! and the rest the training set (to compare runs that differ only in what their labels store,
//! e.g. `crop_radius`, on the same decisions); `LOSS` is `advantage` or `listwise` (`run`: the run's, the default);
//! `SHARE` in (0, 1] fits only that first share of the training sequences (default 1). The run's
//! `config.toml` gives the seed, batch size, learning rate, `spread_margins` and the rest.
//! Output: CSV on stdout; beside the correlations, `teacher_label_gain` (what the teacher's choice
//! gains on the test labels over `spread`'s, per decision) and `gain_*` (what the student's
//! choice gains, greedy and with each of the run's margins): the policy's side of the fit.

use madenet_learn::dagger::{refit, stored_labels, Loss, RolloutTrainConfig};
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: refit RUN_DIR [UPDATES [EVERY [WIDTH [TRAIN_ITERATIONS [LOSS [SHARE]]]]]]";
    let run = Path::new(args.first().ok_or(usage)?);
    let num = |i: usize, default: u64| -> Result<u64, String> {
        args.get(i).map_or(Ok(default), |a| {
            a.parse()
                .map_err(|_| format!("argument {i} `{a}`: not a whole number ({usage})"))
        })
    };
    let mut cfg = RolloutTrainConfig::from_toml_file(&run.join("config.toml"))?;
    let (updates, every) = (num(1, cfg.updates_per_iteration)?, num(2, 500)?);
    let width: f64 = args.get(3).map_or(Ok(1.0), |a| a.parse())?;
    let train_iterations = num(4, 1)? as usize;
    match args.get(5).map(String::as_str) {
        None | Some("run") => {}
        Some("advantage") => cfg.loss = Loss::Advantage,
        Some("listwise") => cfg.loss = Loss::Listwise,
        Some(other) => return Err(format!("LOSS `{other}`: advantage or listwise").into()),
    }
    let base = cfg.agnostic();
    let w = |x: usize| ((x as f64 * width).round() as usize).max(1);
    let sizes = base
        .clone()
        .with_conv_channels(w(base.conv_channels))
        .with_crop_width(w(base.crop_width))
        .with_embed_width(w(base.embed_width))
        .with_context_width(w(base.context_width))
        .with_hidden_width(w(base.hidden_width));
    sizes.validate()?;
    let mut iterations = stored_labels(run)?;
    if train_iterations == 0 && !iterations.is_empty() {
        let first = &mut iterations[0];
        let held_out = first.split_off(first.len() - first.len() / 4);
        iterations.insert(1, held_out);
    }
    let train_iterations = train_iterations.max(1);
    if iterations.len() <= train_iterations {
        return Err(format!(
            "{}: {} iterations stored; TRAIN_ITERATIONS {train_iterations} leaves none to test on",
            run.display(),
            iterations.len()
        )
        .into());
    }
    let share: f64 = args.get(6).map_or(Ok(1.0), |a| a.parse())?;
    if !(share > 0.0 && share <= 1.0) {
        return Err(format!("SHARE {share}: must be in (0, 1]").into());
    }
    let mut train: Vec<_> = iterations[..train_iterations].concat();
    train.truncate(((train.len() as f64 * share).ceil() as usize).max(1));
    let test: Vec<_> = iterations[train_iterations]
        .iter()
        .flatten()
        .cloned()
        .collect();
    if test.is_empty() {
        return Err(format!("{}: no labels to test on", run.display()).into());
    }
    let header: String = std::iter::once("gain_greedy".to_string())
        .chain(
            cfg.spread_margins
                .iter()
                .map(|m| format!(",gain_margin_{m}")),
        )
        .collect();
    println!(
        "updates,loss,student_label_corr,student_agreement,spread_label_corr,teacher_label_gain,{header}"
    );
    for (u, loss, fit) in refit(&cfg, &sizes, &train, &test, updates, every)? {
        let f = |x: Option<f64>| x.map_or(String::new(), |x| format!("{x:.4}"));
        // One cell per margin column, empty without a decision where `spread`'s choice is known.
        let gains: Vec<String> = (0..=cfg.spread_margins.len())
            .map(|i| f(fit.student_gains.get(i).map(|g| g.1)))
            .collect();
        println!(
            "{u},{loss:.5},{},{},{},{},{}",
            f(fit.label_corr),
            f(fit.agreement),
            f(fit.spread_label_corr),
            f(fit.teacher_label_gain),
            gains.join(",")
        );
    }
    Ok(())
}
