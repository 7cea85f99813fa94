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
    lines_off_terminal(&bar, "trials");
    Ok((bar, pool))
}

/// Seconds between two progress lines when stderr is not a terminal.
pub const PROGRESS_LINE_S: u64 = 5;

/// Off a terminal (a log file, a pipe) the bar is not drawn: a line to stderr every
/// [`PROGRESS_LINE_S`] seconds instead — `unit`s done of all (trials, episodes, iterations),
/// rate, time so far, ETA — until the bar finishes or is abandoned (issue 60: `compare 2>log`
/// was silent for 12 minutes). The one home of progress off a terminal: studies and training.
pub fn lines_off_terminal(bar: &indicatif::ProgressBar, unit: &'static str) {
    use std::io::{IsTerminal, Write};
    if std::io::stderr().is_terminal() {
        return;
    }
    let bar = bar.clone();
    // Hand-written rather than indicatif's hidden bar: it draws nothing off a terminal.
    std::thread::spawn(move || {
        let start = std::time::Instant::now();
        let mut last = start;
        // Trials done when the count was first known, and then: a resumed study's earlier
        // trials are not this run's rate (its ETA once read "5 s" with 780 trials left).
        let mut base: Option<(u64, std::time::Instant)> = None;
        while !bar.is_finished() {
            std::thread::sleep(std::time::Duration::from_millis(200));
            let (done, total) = (bar.position(), bar.length().unwrap_or(0));
            if total > 0 && base.is_none() {
                base = Some((done, std::time::Instant::now()));
            }
            if last.elapsed().as_secs() < PROGRESS_LINE_S || bar.is_finished() {
                continue;
            }
            last = std::time::Instant::now();
            let _ = writeln!(
                std::io::stderr(),
                "{}",
                line(
                    unit,
                    done,
                    total,
                    base.map(|(d, t)| (d, t.elapsed().as_secs_f64())),
                    start.elapsed().as_secs_f64()
                )
            );
        }
    });
}

/// A progress line: `done` of `total` `unit`s, `secs` so far; `base`: trials done when the
/// count became known (earlier runs' trials, on a resume) and seconds since.
fn line(unit: &str, done: u64, total: u64, base: Option<(u64, f64)>, secs: f64) -> String {
    let (before, since) = base.unwrap_or((0, secs));
    let new = done.saturating_sub(before);
    let eta = match new {
        _ if total > 0 && done >= total => "finishing".to_string(),
        0 => "eta unknown".to_string(),
        _ => {
            let left = total.saturating_sub(done) as f64 * since / new as f64;
            format!("eta {}", hms(left))
        }
    };
    let resumed = match before {
        0 => String::new(),
        b => format!(" ({b} from an earlier run)"),
    };
    format!(
        "progress   {done}/{total} {unit}{resumed}, {:.2} {unit}/s, {} so far, {eta}",
        new as f64 / since.max(1e-9),
        hms(secs)
    )
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

    /// A resumed study's earlier trials do not count in this run's rate: 20 of 800 left done
    /// in 10 s is 2 trials/s and 6m20s to go, not "5 s" (issue 60).
    #[test]
    fn a_resumed_study_counts_only_its_own_trials_in_the_rate() {
        let l = super::line("trials", 40, 800, Some((20, 10.0)), 12.0);
        assert!(l.contains("40/800 trials (20 from an earlier run)"), "{l}");
        assert!(
            l.contains("2.00 trials/s") && l.contains("eta 6m20s"),
            "{l}"
        );
        let l = super::line("trials", 20, 800, Some((20, 3.0)), 3.0);
        assert!(l.contains("eta unknown"), "{l}");
        let l = super::line("episodes", 5, 10, None, 10.0);
        assert!(
            l.contains("5/10 episodes, 0.50 episodes/s") && l.contains("eta 10s"),
            "{l}"
        );
    }
}
