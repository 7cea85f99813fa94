//! The comparison study of MADE-Net (paper Sec. V.A), reproducible with one command
//! (`madenet compare`): methods × maps × starts × CSPs × seeds, run in parallel over cores,
//! each finished trial appended as a whole line (so an interrupted study resumes where it
//! stopped), then
//!
//! * `trials.csv` — one row per trial with every metric; `curves.jsonl` — exploration curves;
//! * `summary.md` / `summary.csv` — mean ± sd per method × CSP;
//! * `statistics.md` / `statistics.csv` — Friedman tests across methods and Bonferroni-corrected
//!   pairwise Wilcoxon signed-rank tests per metric per CSP, paired by (map, start, seed);
//! * `fig4_metrics.{png,svg}` and `fig5_exploration.{png,svg}` — the paper's Fig. 4 and 5;
//! * `report.md` — all of it, plus the calibration against the authors' published baseline
//!   results.
//!
//! Methods are policy names: the study has no special case per method.

#![deny(missing_docs)]

pub mod analysis;
pub mod calibration;
pub mod config;
pub mod progress;
pub mod report;
pub mod runner;
pub mod scale;
pub mod select;
mod trial_set;
pub use trial_set::{means_by_csp, oracle_by_csp};

pub use config::{StudyConfig, StudyError};
pub use runner::{TrialKey, TrialOutcome};
pub use scale::{run_scale, run_scale_held, ScaleConfig, ScaleWorld};

use std::path::{Path, PathBuf};

/// Runs the study into `out` (created if needed). With `fresh`, earlier results there are
/// discarded; otherwise trials already recorded for the same configuration are kept and only
/// the rest run. Returns the path of `report.md` and every trial's outcome, in plan order.
pub fn run_study(
    cfg: &StudyConfig,
    out: &Path,
    fresh: bool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(PathBuf, Vec<TrialOutcome>), StudyError> {
    run_study_held(cfg, out, fresh, progress).map(|(report, outcomes, _)| (report, outcomes))
}

/// [`run_study`], returning the lock on `out` too: the folder stays this run's for whatever
/// the caller writes there after the study (`madenet compare --record-trials`: its bags).
pub fn run_study_held(
    cfg: &StudyConfig,
    out: &Path,
    fresh: bool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(PathBuf, Vec<TrialOutcome>, madenet_files::FolderLock), StudyError> {
    let (registry, maps, planned) = study_plan(cfg)?;
    let io = |e: std::io::Error| StudyError::File {
        path: out.display().to_string(),
        message: e.to_string(),
    };
    std::fs::create_dir_all(out).map_err(io)?;
    let lock = prepare_out(out, "study.toml", cfg, "", fresh)?;
    let started = std::time::Instant::now();
    let outcomes = runner::run_planned(&planned, &registry, out, progress)?;
    let wall = started.elapsed().as_secs_f64();
    let paper_maps: Vec<String> = maps
        .iter()
        .filter(|m| m.paper)
        .map(|m| m.name.clone())
        .collect();
    let bounds = lower_bounds(planned.iter())?;
    let report = report::write_all(cfg, &outcomes, &paper_maps, &bounds, out, wall)?;
    Ok((report, outcomes, lock))
}

/// The study's policies, its maps and every trial it runs, in output order
/// ([`runner::plan`]), after checking the config.
pub fn study_plan(cfg: &StudyConfig) -> Result<StudyPlan, StudyError> {
    let registry = cfg.registry()?;
    let (maps, starts) = cfg.validate(&registry)?;
    let planned = runner::plan(cfg, &maps, &starts);
    Ok((registry, maps, planned))
}

/// What [`study_plan`] returns: the policies, the maps, the trials.
pub type StudyPlan = (
    madenet_sim::PolicyRegistry,
    Vec<config::StudyMap>,
    Vec<runner::Planned>,
);

/// The lower bound ([`madenet_baselines::reference::lower_bound`]) of every trial of `planned` the
/// known-map reference runs, by map, start and seed (in parallel; none if it does not run).
pub(crate) fn lower_bounds<'a>(
    planned: impl Iterator<Item = &'a runner::Planned>,
) -> Result<report::Bounds, StudyError> {
    use rayon::prelude::*;
    let kind = madenet_baselines::rollout::OracleKind::KnownMap;
    let mut specs = std::collections::BTreeMap::new();
    for p in planned.filter(|p| p.oracle.is_some_and(|(k, _)| k == kind)) {
        let k = &p.key;
        specs
            .entry((k.map.clone(), k.start.clone(), k.seed))
            .or_insert(&p.spec);
    }
    let specs: Vec<_> = specs.into_iter().collect();
    specs
        .into_par_iter()
        .map(|(key, spec)| {
            madenet_baselines::reference::lower_bound(spec)
                .map(|b| (key, b))
                .map_err(|e| StudyError::Other(format!("{}: {e}", spec.map_name)))
        })
        .collect()
}

/// Readies output folder `out` for a study whose config is saved there as `cfg_name` (its TOML
/// after the comment lines `header`): with `fresh`, earlier trials are discarded; otherwise
/// trials recorded by another configuration are refused (the folder is not touched) and those
/// of this one kept. A saved config is the same when it reads as `cfg` (comments aside, and
/// fields added to the config since it was saved taking their defaults). The folder is this
/// run's while the returned lock lives (a second run on it is refused), and the temporary files
/// of an interrupted write are removed.
pub(crate) fn prepare_out<T: serde::Serialize + serde::de::DeserializeOwned>(
    out: &Path,
    cfg_name: &str,
    cfg: &T,
    header: &str,
    fresh: bool,
) -> Result<madenet_files::FolderLock, StudyError> {
    let cfg_path = out.join(cfg_name);
    let cfg_text = toml::to_string(cfg).map_err(|e| StudyError::Other(e.to_string()))?;
    let same = |old: &str| {
        toml::from_str::<T>(old)
            .ok()
            .and_then(|c| toml::to_string(&c).ok())
            .is_some_and(|t| t == cfg_text)
    };
    let check = || -> Result<(), StudyError> {
        if !fresh && cfg_path.exists() {
            let old = std::fs::read_to_string(&cfg_path).map_err(|e| StudyError::File {
                path: cfg_path.display().to_string(),
                message: e.to_string(),
            })?;
            if !same(&old) && out.join("trials.csv").exists() {
                return Err(StudyError::File {
                    path: out.display().to_string(),
                    message: "holds results of a different study configuration: choose another output folder or start afresh (--fresh)".into(),
                });
            }
        } else if !fresh && out.join("trials.csv").exists() {
            // Another kind of study (or `madenet batch`'s table) in this folder: its rows would
            // be dropped as not planned here.
            return Err(StudyError::File {
                path: out.display().to_string(),
                message: format!("holds a trials.csv without {cfg_name}: results of another study: choose another output folder or start afresh (--fresh)"),
            });
        }
        Ok(())
    };
    // Refusals leave the folder untouched; from the lock on it is this run's.
    check()?;
    let lock = madenet_files::lock_folder(out).map_err(|e| StudyError::File {
        path: out.display().to_string(),
        message: e.to_string(),
    })?;
    // Again under the lock: a run that held the folder may have finished in between.
    check()?;
    if fresh {
        for f in ["trials.csv", "curves.jsonl"] {
            let _ = std::fs::remove_file(out.join(f));
        }
    }
    runner::write_atomic(&cfg_path, format!("{header}{cfg_text}").as_bytes())?;
    Ok(lock)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_saved_before_a_field_was_added_resumes_and_another_study_is_refused() {
        let dir = madenet_testkit::Scratch::new("prepare");
        let cfg = ScaleConfig::continuous_default();
        // As an earlier madenet saved it: without a field added since, and with a comment.
        let text = toml::to_string(&cfg).unwrap();
        let old: String = text
            .lines()
            .filter(|l| !l.starts_with("localization_noise_m"))
            .map(|l| format!("{l}\n"))
            .collect();
        assert_ne!(old, text);
        std::fs::write(dir.join("scale.toml"), format!("# saved earlier\n{old}")).unwrap();
        std::fs::write(dir.join("trials.csv"), "method\n").unwrap();
        let lock = prepare_out(&dir, "scale.toml", &cfg, "", false).expect("the same study");
        drop(lock);
        // Saved now as the whole config.
        assert_eq!(
            std::fs::read_to_string(dir.join("scale.toml")).unwrap(),
            text
        );
        let other = ScaleConfig {
            seeds: cfg.seeds + 1,
            ..cfg.clone()
        };
        let Err(e) = prepare_out(&dir, "scale.toml", &other, "", false) else {
            panic!("another study was taken for this one");
        };
        let e = e.to_string();
        assert!(e.contains("different study configuration"), "{e}");
    }
}
