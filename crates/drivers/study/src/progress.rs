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
    lines_off_terminal(&bar);
    Ok((bar, pool))
}

/// Seconds between two progress lines when stderr is not a terminal.
pub const PROGRESS_LINE_S: u64 = 5;

/// Off a terminal (a log file, a pipe) the bar is not drawn: a line to stderr every
/// [`PROGRESS_LINE_S`] seconds instead — trials done of all, rate, time so far, ETA — until the
/// bar finishes (issue 60: `compare 2>log` was silent for 12 minutes).
fn lines_off_terminal(bar: &indicatif::ProgressBar) {
    use std::io::{IsTerminal, Write};
    if std::io::stderr().is_terminal() {
        return;
    }
    let bar = bar.clone();
    let start = std::time::Instant::now();
    // Hand-written rather than indicatif's hidden bar: it draws nothing off a terminal.
    std::thread::spawn(move || {
        let mut last = std::time::Instant::now();
        while !bar.is_finished() {
            std::thread::sleep(std::time::Duration::from_millis(200));
            if last.elapsed().as_secs() < PROGRESS_LINE_S || bar.is_finished() {
                continue;
            }
            last = std::time::Instant::now();
            let (done, total) = (bar.position(), bar.length().unwrap_or(0));
            let secs = start.elapsed().as_secs_f64();
            let eta = match done {
                0 => "eta unknown".to_string(),
                _ if total > done => {
                    let left = (total - done) as f64 * secs / done as f64;
                    format!("eta {}", hms(left))
                }
                _ => "finishing".to_string(),
            };
            // A full stderr loses the line, never the run.
            let _ = writeln!(
                std::io::stderr(),
                "progress   {done}/{total} trials, {:.2} trials/s, {} so far, {eta}",
                done as f64 / secs.max(1e-9),
                hms(secs)
            );
        }
    });
}

/// Seconds as `1h02m03s`, `2m03s` or `3s`.
fn hms(s: f64) -> String {
    let s = s.round() as u64;
    match (s / 3600, s / 60 % 60, s % 60) {
        (0, 0, sec) => format!("{sec}s"),
        (0, m, sec) => format!("{m}m{sec:02}s"),
        (h, m, sec) => format!("{h}h{m:02}m{sec:02}s"),
    }
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

#[cfg(test)]
mod tests {
    #[test]
    fn durations_read_as_hours_minutes_seconds() {
        assert_eq!(super::hms(3.4), "3s");
        assert_eq!(super::hms(123.0), "2m03s");
        assert_eq!(super::hms(3723.0), "1h02m03s");
    }
}
