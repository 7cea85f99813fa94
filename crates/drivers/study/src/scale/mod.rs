//! The scalability study (`madenet scale`): the grid analogue of the paper's Sec. V.B and
//! Fig. 7 — exploration time against team size on maps of several sizes.
//!
//! Map sides × generated maps per side × starts (bottom-left, top-right, middle) × team sizes ×
//! seeds, for every method, at one CSP. Maps are generated from seeds of their own (never the
//! learners' training or validation streams) with the start areas kept free; robots start at
//! the free cells nearest (by moves) to the start's anchor cell. The step cap grows with the
//! map (`steps_per_cell` × cells), so that small teams on large maps can finish.
//!
//! Outputs (the trials resumable as in `madenet compare`, by the same runner):
//! * `trials.csv`, `curves.jsonl` — one row per trial; map `side<S>-map<k>`, start
//!   `<start>:<team>`;
//! * `cells.csv` — mean TNS, TTD, NOLI and completions per (side, team, method);
//! * `fig7_scalability.{png,svg}` — mean TNS against team size, one panel per map side;
//! * `fig_headroom.{png,svg}` — with the known-map reference (`known_map`, grid only): every
//!   method's mean TNS as % above the reference's, against team size, one panel per side;
//! * `scale.md` — the tables; per map side and method a Friedman test across team sizes and
//!   Wilcoxon signed-rank tests between consecutive team sizes (paired by map, start and seed),
//!   where exploration time stops falling; the first method against every other: the share of
//!   (side, team) cells where it has lower mean TNS and TTD, and pooled Wilcoxon tests.

mod cells;
mod config;
mod plan;
mod report;

pub use cells::{cells, CellRow};
pub use config::{ScaleConfig, ScaleStart, ScaleWorld};
pub use plan::ScalePlanned;

use crate::config::StudyError;
use crate::runner::{run_planned, write_atomic, Planned};
use cells::ContinuousCellRow;
use report::{figure, headroom_figure, headroom_text, report_text, twin_text};
use std::path::{Path, PathBuf};

/// What [`run_scale`] produced.
#[derive(Debug)]
pub struct ScaleResult {
    /// `scale.md`.
    pub report: PathBuf,
    /// The means per (side, team, method), as written to `cells.csv`.
    pub cells: Vec<CellRow>,
    /// Number of trials of the study, recorded earlier or run now.
    pub trials: usize,
}

/// Runs the scalability study into `out` (resuming trials recorded there by the same
/// configuration; `fresh` discards them) and writes its tables, tests and figure.
pub fn run_scale(
    cfg: &ScaleConfig,
    registry: &madenet_sim::PolicyRegistry,
    out: &Path,
    fresh: bool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<ScaleResult, StudyError> {
    run_scale_held(cfg, registry, out, fresh, progress).map(|(result, _)| result)
}

/// [`run_scale`], returning the lock on `out` too: the folder stays this run's for whatever
/// the caller writes there after the study (`madenet scale --record-trials`: its bags).
pub fn run_scale_held(
    cfg: &ScaleConfig,
    registry: &madenet_sim::PolicyRegistry,
    out: &Path,
    fresh: bool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(ScaleResult, madenet_files::FolderLock), StudyError> {
    cfg.validate(registry)?;
    let planned = cfg.plan()?;
    let io = |e: std::io::Error| StudyError::File {
        path: out.display().to_string(),
        message: e.to_string(),
    };
    std::fs::create_dir_all(out).map_err(io)?;
    let lock = crate::prepare_out(out, "scale.toml", cfg, "", fresh)?;
    let started = std::time::Instant::now();
    // A continuous study runs its grid twin first (`grid/`; fast). Progress counts the
    // continuous trials only: twin trials take milliseconds, continuous ones seconds, and one
    // count of both gave an ETA of 3 min, then 21 min, and a bar of 1 800 trials for a study of
    // 900.
    let twin = match cfg.world {
        ScaleWorld::Grid => None,
        ScaleWorld::Continuous => {
            let dir = out.join("grid");
            std::fs::create_dir_all(&dir).map_err(io)?;
            // `grid/` stays this run's until the report is written, as `out` does.
            let header = "# The grid twin of ../scale.toml: its trials on each scene's 1 m cells\n# (the paper's discretization) in the grid world, in timesteps, not seconds.\n";
            let lock = crate::prepare_out(&dir, "scale.toml", cfg, header, fresh)?;
            let twin = cfg.grid_twin(&planned);
            let runs: Vec<Planned> = twin.iter().map(|p| p.planned.clone()).collect();
            let n = planned.len();
            let outcomes = run_planned(&runs, registry, &dir, &|_, _| progress(0, n))?;
            Some((twin, outcomes, lock))
        }
    };
    let runs: Vec<Planned> = planned.iter().map(|p| p.planned.clone()).collect();
    let outcomes = run_planned(&runs, registry, out, progress)?;
    let wall = started.elapsed().as_secs_f64();
    let cells = cells(cfg, &planned, &outcomes);
    let mut w = csv::Writer::from_writer(Vec::new());
    for c in &cells {
        match cfg.world {
            ScaleWorld::Grid => w.serialize(c),
            ScaleWorld::Continuous => w.serialize(ContinuousCellRow {
                side: c.side,
                team: c.team,
                method: &c.method,
                trials: c.trials,
                completed: c.completed,
                et_s: c.tns,
                ttd_m: c.ttd_m,
                noli: c.noli,
                collisions: c.collisions,
            }),
        }
        .map_err(|e| StudyError::Other(e.to_string()))?;
    }
    write_atomic(
        &out.join("cells.csv"),
        &w.into_inner()
            .map_err(|e| StudyError::Other(e.to_string()))?,
    )?;
    figure(cfg, &cells, out)?;
    headroom_figure(cfg, &planned, &outcomes, out)?;
    let report = out.join("scale.md");
    let mut text = report_text(cfg, &planned, &outcomes, &cells, wall);
    let bounds = crate::lower_bounds(planned.iter().map(|p| &p.planned))?;
    text.push_str(&headroom_text(cfg, &planned, &outcomes, &bounds));
    if let Some((twin_planned, twin_outcomes, _)) = &twin {
        text.push_str(&twin_text(
            cfg,
            (&planned, &outcomes),
            (twin_planned, twin_outcomes),
        ));
    }
    write_atomic(&report, text.as_bytes())?;
    Ok((
        ScaleResult {
            report,
            cells,
            trials: outcomes.len(),
        },
        lock,
    ))
}
