//! Trial sets on a thread pool with a progress bar: what `batch`, `oracle`, `compare` and
//! `scale` show while they run.

use crate::runner::{self, Planned, TrialOutcome};
use crate::StudyError;
use madenet_sim::PolicyRegistry;

/// The progress bar of a trial set (`len` trials, 0 if not known yet) and the thread pool its
/// trials run on (`threads`: `--threads`, all cores when unset or 0).
pub fn trials_bar_and_pool(
    len: u64,
    threads: Option<usize>,
) -> Result<(indicatif::ProgressBar, rayon::ThreadPool), rayon::ThreadPoolBuildError> {
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} trials  {elapsed_precise}  eta {eta}",
        )
        .expect("valid template"),
    );
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()?;
    Ok((bar, pool))
}

/// Runs `planned` with a progress bar on `threads` workers (no records, unlike
/// [`runner::run_planned`]); outcomes in plan order.
pub fn run_with_bar(
    planned: &[Planned],
    registry: &PolicyRegistry,
    threads: Option<usize>,
) -> Result<Vec<TrialOutcome>, StudyError> {
    let (bar, pool) = trials_bar_and_pool(planned.len() as u64, threads)
        .map_err(|e| StudyError::Other(e.to_string()))?;
    let all: Vec<&Planned> = planned.iter().collect();
    let outcomes = pool.install(|| {
        runner::run_all(&all, registry, &|_| {
            bar.inc(1);
            Ok(())
        })
    });
    bar.finish_and_clear();
    outcomes
}
