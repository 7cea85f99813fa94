//! A study's chosen trials as bags (`madenet compare|scale … --record-trials FIELD=VALUE…`):
//! the trials whose `trials.csv` fields meet every condition, re-run with their seeds (so each
//! is the trial of its row) through the run loop with the [`Recorder`] as its one sink, into
//! `OUT/bags/<method>_<map>_<start>_csp<C>_seed<S>/`. Messages name the flag.

use crate::bag::Bag;
use crate::record::{Recorder, RecorderSink};
use madenet_sim::stepping::{run, Stepping};
use madenet_sim::PolicyRegistry;
use madenet_study::runner::Planned;
use madenet_study::select::{folder_name, TrialFilter};
use rayon::prelude::*;
use std::path::Path;

/// Why a study's bags could not be chosen or written (the message names the flag).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct StudyBagsError(pub String);

type Result<T> = std::result::Result<T, StudyBagsError>;

fn err(flag: &str, what: impl std::fmt::Display) -> StudyBagsError {
    StudyBagsError(format!("{flag}: {what}"))
}

/// At most this many trials of a study are recorded (a filter choosing more is refused).
pub const MAX_RECORDED_TRIALS: usize = 1000;

/// The trials of `planned` that `--record-trials` conditions `items` choose: some, at most
/// [`MAX_RECORDED_TRIALS`], none an oracle's. Checked before a study runs.
pub fn chosen_trials<'a>(items: &[String], planned: &'a [Planned]) -> Result<Vec<&'a Planned>> {
    let flag = "--record-trials";
    let filter = TrialFilter::parse(items).map_err(|e| err(flag, e))?;
    let chosen: Vec<_> = planned.iter().filter(|p| filter.matches(&p.key)).collect();
    if chosen.is_empty() {
        return Err(err(flag, format!(
            "chooses none of the study's {} trials (fields: method, map, start, csp, seed, as trials.csv writes them)",
            planned.len()
        )));
    }
    if chosen.len() > MAX_RECORDED_TRIALS {
        return Err(err(flag, format!(
            "chooses {} trials, more than the {MAX_RECORDED_TRIALS} bags a study records: narrow it (e.g. seed=1)",
            chosen.len()
        )));
    }
    if let Some(p) = chosen.iter().find(|p| p.oracle.is_some()) {
        return Err(err(
            flag,
            format!(
                "chooses an oracle's trial ({}), which is not recorded: add a method=… condition",
                p.key
            ),
        ));
    }
    let mut names = std::collections::HashSet::new();
    if let Some(p) = chosen.iter().find(|p| !names.insert(folder_name(&p.key))) {
        return Err(err(flag, format!(
            "two chosen trials share the folder name {} (starts that differ only in punctuation): narrow it",
            folder_name(&p.key)
        )));
    }
    Ok(chosen)
}

/// Records `trial` to its end into `bag`.
fn record_trial<S: Stepping>(mut trial: S, bag: Bag) -> std::result::Result<(), String> {
    let recorder = Recorder::to(Some(bag), &trial).map_err(|e| e.to_string())?;
    let mut sink = RecorderSink::new(recorder);
    run(&mut trial, &mut [&mut sink]).map_err(|e| e.to_string())?;
    Ok(())
}

/// Records each of `chosen` (trials of a study, re-run: the same seed gives the same trial)
/// as a bag in `dir`/[`folder_name`], in parallel on the current pool; a bag already there is
/// kept. Returns how many were written.
pub fn record_trials(chosen: &[&Planned], registry: &PolicyRegistry, dir: &Path) -> Result<usize> {
    let flag = "--record-trials";
    std::fs::create_dir_all(dir).map_err(|e| err(flag, format!("{}: {e}", dir.display())))?;
    let written = chosen
        .par_iter()
        .map(|p| -> Result<bool> {
            let at = dir.join(folder_name(&p.key));
            if at.join("metadata.yaml").is_file() {
                return Ok(false);
            }
            let failed = |e: madenet_sim::SimError| err(flag, format!("{}: {e}", p.key));
            let bag = Bag::create(&at).map_err(|e| err(flag, e))?;
            match p.continuous_trial(registry) {
                Some(trial) => record_trial(trial.map_err(failed)?, bag),
                None => record_trial(
                    madenet_sim::Trial::with_registry(p.spec.clone(), registry).map_err(failed)?,
                    bag,
                ),
            }
            .map_err(|e| err(flag, e))?;
            Ok(true)
        })
        .collect::<Result<Vec<bool>>>()?;
    Ok(written.into_iter().filter(|&w| w).count())
}

/// After a study, while its folder `out` is still locked: records `chosen` into `out`/bags
/// ([`record_trials`], on `pool`); returns the bags' folder and how many were written now.
/// Bags there are kept, as the study keeps its rows; with `fresh` (the study started afresh)
/// the bags are recorded into a hidden folder that replaces `out`/bags only once all are
/// written, so a failed re-recording leaves the old bags.
pub fn record_study_trials(
    chosen: &[&Planned],
    registry: &PolicyRegistry,
    out: &Path,
    fresh: bool,
    pool: &rayon::ThreadPool,
) -> Result<(std::path::PathBuf, usize)> {
    let flag = "--record-trials";
    let bags = out.join("bags");
    // An interrupted fresh recording's folders (the caller holds `out`'s lock).
    let (new, old) = (out.join(".madenet-bags-new"), out.join(".madenet-bags-old"));
    let clear = |d: &Path| -> Result<()> {
        if d.exists() {
            std::fs::remove_dir_all(d).map_err(|e| err(flag, format!("{}: {e}", d.display())))?;
        }
        Ok(())
    };
    // A swap cut between its two renames: the old bags are whole, put them back first.
    if !bags.exists() && old.is_dir() {
        std::fs::rename(&old, &bags).map_err(|e| err(flag, format!("{}: {e}", bags.display())))?;
    }
    clear(&new)?;
    clear(&old)?;
    // A killed study's bags half written (a resume would keep them for ever).
    Bag::remove_leftovers(&bags).map_err(|e| err(flag, format!("{}: {e}", bags.display())))?;
    let n = pool.install(|| record_trials(chosen, registry, if fresh { &new } else { &bags }))?;
    if fresh {
        let swap = || -> std::io::Result<()> {
            if bags.exists() {
                std::fs::rename(&bags, &old)?;
            }
            std::fs::rename(&new, &bags)
        };
        swap().map_err(|e| err(flag, format!("{}: {e}", bags.display())))?;
        clear(&old)?;
    }
    Ok((bags, n))
}

/// After a study run afresh without `--record-trials`, while its folder `out` is still
/// locked: the bags of the earlier study go with its rows.
pub fn discard_bags(out: &Path) -> Result<()> {
    for d in ["bags", ".madenet-bags-new", ".madenet-bags-old"] {
        let d = out.join(d);
        if d.exists() {
            std::fs::remove_dir_all(&d)
                .map_err(|e| err("--fresh", format!("{}: {e}", d.display())))?;
        }
    }
    Ok(())
}
