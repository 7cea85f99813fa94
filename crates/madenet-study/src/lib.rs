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
pub mod report;
pub mod runner;
pub mod scale;

pub use config::{StudyConfig, StudyError};
pub use runner::{TrialKey, TrialOutcome};
pub use scale::{run_scale, ScaleConfig, ScaleWorld};

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
    let registry = cfg.registry()?;
    let (maps, starts) = cfg.validate(&registry)?;
    let io = |e: std::io::Error| StudyError::File {
        path: out.display().to_string(),
        message: e.to_string(),
    };
    std::fs::create_dir_all(out).map_err(io)?;
    let cfg_text = toml::to_string(cfg).map_err(|e| StudyError::Other(e.to_string()))?;
    let _lock = prepare_out(out, "study.toml", &cfg_text, fresh)?;
    let started = std::time::Instant::now();
    let outcomes = runner::run(cfg, &registry, &maps, &starts, out, progress)?;
    let wall = started.elapsed().as_secs_f64();
    let paper_maps: Vec<String> = maps
        .iter()
        .filter(|m| m.paper)
        .map(|m| m.name.clone())
        .collect();
    let report = report::write_all(cfg, &outcomes, &paper_maps, out, wall)?;
    Ok((report, outcomes))
}

/// Readies output folder `out` for a study whose config (as text) is saved there as
/// `cfg_name`: with `fresh`, earlier trials are discarded; otherwise trials recorded by another
/// configuration are refused (the folder is not touched) and those of this one kept. The folder
/// is this run's while the returned lock lives (a second run on it is refused), and the temporary
/// files of an interrupted write are removed.
pub(crate) fn prepare_out(
    out: &Path,
    cfg_name: &str,
    cfg_text: &str,
    fresh: bool,
) -> Result<madenet_files::FolderLock, StudyError> {
    let cfg_path = out.join(cfg_name);
    let check = || -> Result<(), StudyError> {
        if !fresh && cfg_path.exists() {
            let old = std::fs::read_to_string(&cfg_path).map_err(|e| StudyError::File {
                path: cfg_path.display().to_string(),
                message: e.to_string(),
            })?;
            // Comment lines do not make another study (an earlier run's grid twin had none).
            let body = |t: &str| -> String {
                t.lines()
                    .filter(|l| !l.starts_with('#'))
                    .collect::<Vec<_>>()
                    .join("\n")
            };
            if body(&old) != body(cfg_text) && (out.join("trials.csv").exists()) {
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
    runner::write_atomic(&cfg_path, cfg_text.as_bytes())?;
    Ok(lock)
}
