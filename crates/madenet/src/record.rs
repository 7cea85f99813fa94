//! `--record PATH` and `--foxglove [ADDR]`: a run of any world as ROS 2 messages
//! ([`madenet_ros2::record`]: its topics, in simulated time) into a bag and/or a live Foxglove
//! view, as a sink of the run loop, with the CLI's error context and the line it prints;
//! `--record-trials` (`compare`, `scale`): chosen trials of a study as bags.

use anyhow::{Context, Result};
use madenet_ros2::bag::Bag;
use madenet_ros2::live::Live;
use madenet_ros2::record::{Recorder, RecorderSink};
use madenet_sim::stepping::{Present, Stepping};
use std::path::Path;

/// The bag and/or live view asked for, started on `sim`'s present (`None` when neither is):
/// the bag's place checked first, so a refused `--foxglove` leaves no bag behind (an
/// unfinished bag removes itself).
pub fn start<S: Present + ?Sized>(
    bag: Option<&Path>,
    live: Option<&str>,
    sim: &S,
) -> Result<Option<RecorderSink>> {
    if bag.is_none() && live.is_none() {
        return Ok(None);
    }
    let bag = bag
        .map(|p| Bag::create(p).context("--record"))
        .transpose()?;
    let live = match live {
        Some(addr) => {
            let live = Live::start(addr).context("--foxglove")?;
            // Printed at once (stderr): a viewer connects while the run goes on.
            eprintln!(
                "foxglove   {} (Foxglove: Open connection → Foxglove WebSocket)",
                live.url()
            );
            Some(live)
        }
        None => None,
    };
    let r = Recorder::to_live(bag, live, sim).context("--record")?;
    Ok(Some(RecorderSink::new(r)))
}

/// Records `trial` to its end into `bag` (the run loop with the recorder as its one sink).
fn record_trial<S: Stepping>(mut trial: S, bag: Bag) -> Result<()> {
    let mut sink = RecorderSink::new(Recorder::to(Some(bag), &trial)?);
    madenet_sim::stepping::run(&mut trial, &mut [&mut sink]).map_err(anyhow::Error::from_boxed)?;
    Ok(())
}

/// Records each of `chosen` (trials of a study, re-run: the same seed gives the same
/// trial) as a bag in `dir`/[`folder_name`](madenet_study::select::folder_name), in
/// parallel on the current pool; a bag already there is kept. Returns how many were
/// written.
pub fn record_trials(
    chosen: &[&madenet_study::runner::Planned],
    registry: &madenet_sim::PolicyRegistry,
    dir: &Path,
) -> Result<usize> {
    use rayon::prelude::*;
    std::fs::create_dir_all(dir).with_context(|| format!("--record-trials: {}", dir.display()))?;
    let written = chosen
        .par_iter()
        .map(|p| -> Result<bool> {
            let at = dir.join(madenet_study::select::folder_name(&p.key));
            if at.join("metadata.yaml").is_file() {
                return Ok(false);
            }
            let failed = |e: madenet_sim::SimError| anyhow::anyhow!("{}: {e}", p.key);
            let bag = Bag::create(&at).context("--record-trials")?;
            match p.continuous_trial(registry) {
                Some(trial) => record_trial(trial.map_err(failed)?, bag),
                None => record_trial(
                    madenet_sim::Trial::with_registry(p.spec.clone(), registry).map_err(failed)?,
                    bag,
                ),
            }
            .context("--record-trials")?;
            Ok(true)
        })
        .collect::<Result<Vec<bool>>>()?;
    Ok(written.into_iter().filter(|&w| w).count())
}

/// After a study, while its folder `out` is still locked: records the trials of `planned`
/// that `--record-trials` conditions `items` choose into `out`/bags ([`record_trials`], on
/// `pool`) and prints where. Bags there are kept, as the study keeps its rows; with `fresh`
/// (the study started afresh) the bags are recorded into a hidden folder that replaces
/// `out`/bags only once all are written, so a failed re-recording leaves the old bags.
pub fn record_study_trials(
    items: &[String],
    planned: &[madenet_study::runner::Planned],
    registry: &madenet_sim::PolicyRegistry,
    out: &std::path::Path,
    fresh: bool,
    pool: &rayon::ThreadPool,
) -> anyhow::Result<()> {
    use anyhow::Context;
    let chosen = chosen_trials(items, planned)?;
    let bags = out.join("bags");
    // An interrupted fresh recording's folders (the caller holds `out`'s lock).
    let (new, old) = (out.join(".madenet-bags-new"), out.join(".madenet-bags-old"));
    let clear = |d: &std::path::Path| -> anyhow::Result<()> {
        if d.exists() {
            std::fs::remove_dir_all(d)
                .with_context(|| format!("--record-trials: {}", d.display()))?;
        }
        Ok(())
    };
    // A swap cut between its two renames: the old bags are whole, put them back first.
    if !bags.exists() && old.is_dir() {
        std::fs::rename(&old, &bags)
            .with_context(|| format!("--record-trials: {}", bags.display()))?;
    }
    clear(&new)?;
    clear(&old)?;
    let n = pool.install(|| record_trials(&chosen, registry, if fresh { &new } else { &bags }))?;
    if fresh {
        let swap = || -> std::io::Result<()> {
            if bags.exists() {
                std::fs::rename(&bags, &old)?;
            }
            std::fs::rename(&new, &bags)
        };
        swap().with_context(|| format!("--record-trials: {}", bags.display()))?;
        clear(&old)?;
    }
    out!(
        "{} trials recorded → {} ({n} written now)",
        chosen.len(),
        bags.display()
    )?;
    Ok(())
}

/// After a study run afresh without `--record-trials`, while its folder `out` is still
/// locked: the bags of the earlier study go with its rows.
pub fn discard_bags(out: &std::path::Path) -> anyhow::Result<()> {
    use anyhow::Context;
    for d in ["bags", ".madenet-bags-new", ".madenet-bags-old"] {
        let d = out.join(d);
        if d.exists() {
            std::fs::remove_dir_all(&d).with_context(|| format!("--fresh: {}", d.display()))?;
        }
    }
    Ok(())
}

/// At most this many trials of a study are recorded (a filter choosing more is refused).
const MAX_RECORDED_TRIALS: usize = 1000;

/// The trials of `planned` that `--record-trials` conditions `items` choose: some, at most
/// [`MAX_RECORDED_TRIALS`], none an oracle's; every refusal names the flag. Checked before a
/// study runs.
pub fn chosen_trials<'a>(
    items: &[String],
    planned: &'a [madenet_study::runner::Planned],
) -> anyhow::Result<Vec<&'a madenet_study::runner::Planned>> {
    let filter = madenet_study::select::TrialFilter::parse(items)
        .map_err(|e| anyhow::anyhow!("--record-trials: {e}"))?;
    let chosen: Vec<_> = planned.iter().filter(|p| filter.matches(&p.key)).collect();
    if chosen.is_empty() {
        anyhow::bail!(
            "--record-trials: chooses none of the study's {} trials (fields: method, map, start, csp, seed, as trials.csv writes them)",
            planned.len()
        );
    }
    if chosen.len() > MAX_RECORDED_TRIALS {
        anyhow::bail!(
            "--record-trials: chooses {} trials, more than the {MAX_RECORDED_TRIALS} bags a study records: narrow it (e.g. seed=1)",
            chosen.len()
        );
    }
    if let Some(p) = chosen.iter().find(|p| p.oracle.is_some()) {
        anyhow::bail!(
            "--record-trials: chooses an oracle's trial ({}), which is not recorded: add a method=… condition",
            p.key
        );
    }
    let mut names = std::collections::HashSet::new();
    if let Some(p) = chosen
        .iter()
        .find(|p| !names.insert(madenet_study::select::folder_name(&p.key)))
    {
        anyhow::bail!(
            "--record-trials: two chosen trials share the folder name {} (starts that differ only in punctuation): narrow it",
            madenet_study::select::folder_name(&p.key)
        );
    }
    Ok(chosen)
}
