//! Ctrl-C (SIGINT) or SIGTERM during a run that records, streams or is paced: the run stops
//! after the timestep it is in and finishes what it writes — the bag then holds the run up to
//! there, a valid bag, instead of a hidden partial folder — and `madenet` exits with 130
//! (128 + SIGINT; 143 for SIGTERM; [`Interrupted`]). A second signal ends the process at once,
//! with the same codes. A world node does the same ([`crate::serve`]); a launcher catches both
//! ([`Stop::catch`]) and hands them on (the first to the world node, a second stops every
//! node).

use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Whether the user asked the run to stop ([module docs](self)): one flag per signal watched.
pub struct Stop(Vec<(i32, Arc<AtomicBool>)>);

impl Stop {
    /// Watches SIGINT and SIGTERM when `wanted`; otherwise they end the process as usual.
    pub fn watch(wanted: bool) -> std::io::Result<Self> {
        if !wanted {
            return Ok(Stop(Vec::new()));
        }
        let flags = [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM]
            .map(|s| (s, Arc::new(AtomicBool::new(false))));
        for (signal, _) in &flags {
            for (_, flag) in &flags {
                // A second signal (either flag already set) exits at once, with 128 + signal.
                signal_hook::flag::register_conditional_shutdown(
                    *signal,
                    128 + *signal,
                    Arc::clone(flag),
                )?;
            }
        }
        for (signal, flag) in &flags {
            signal_hook::flag::register(*signal, Arc::clone(flag))?;
        }
        Ok(Stop(flags.into()))
    }

    /// Catches SIGINT and SIGTERM without ever ending the process: each signal is taken once
    /// by [`Self::take`] (a supervisor that must stop its children first).
    pub fn catch() -> std::io::Result<Self> {
        let flags = [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM]
            .map(|s| (s, Arc::new(AtomicBool::new(false))));
        for (signal, flag) in &flags {
            signal_hook::flag::register(*signal, Arc::clone(flag))?;
        }
        Ok(Stop(flags.into()))
    }

    /// A signal that came since the last call, if one did (taken: the next call reports only a
    /// later one).
    pub fn take(&self) -> Option<i32> {
        self.0
            .iter()
            .find(|(_, f)| f.swap(false, Ordering::Relaxed))
            .map(|(s, _)| *s)
    }

    /// The signal that came, if one did.
    pub fn requested(&self) -> Option<i32> {
        self.0
            .iter()
            .find(|(_, f)| f.load(Ordering::Relaxed))
            .map(|(s, _)| *s)
    }
}

/// The interrupt as a sink of the run loop: a signal [`Stop`] watches ends the run after the
/// step it is in; `signal` says which came.
pub struct OnSignal<'a> {
    stop: &'a Stop,
    /// The signal that ended the run, if one did.
    pub signal: Option<i32>,
}

impl<'a> OnSignal<'a> {
    /// Watches `stop`.
    pub fn new(stop: &'a Stop) -> Self {
        OnSignal { stop, signal: None }
    }
}

impl<S: ?Sized> madenet_sim::stepping::Sink<S> for OnSignal<'_> {
    fn step(&mut self, _: &S) -> Result<ControlFlow<String>, madenet_sim::stepping::SinkError> {
        Ok(match self.stop.requested() {
            Some(signal) => {
                self.signal = Some(signal);
                ControlFlow::Break(format!("signal {signal}"))
            }
            None => ControlFlow::Continue(()),
        })
    }
}

/// A run ended by a signal; `madenet` exits with 128 + the signal (130 for Ctrl-C, 143 for
/// SIGTERM).
#[derive(Debug)]
pub struct Interrupted {
    /// Where the run stopped: `timestep 37`, `12.4 s`.
    pub at: String,
    /// The signal.
    pub signal: i32,
    /// Whether what the run writes (bag, pictures) was finished; not after `launch`'s second
    /// signal, which stops the nodes at once, nor when its world node failed or was killed.
    pub finished: bool,
}

impl Interrupted {
    /// A run that a signal ended after it finished what it writes: `Err` of that, or `Ok` when
    /// no signal came (`stopped`: where it stopped and the signal).
    pub fn result(stopped: Option<(String, i32)>) -> Result<(), Interrupted> {
        match stopped {
            Some((at, signal)) => Err(Interrupted {
                at,
                signal,
                finished: true,
            }),
            None => Ok(()),
        }
    }

    /// The process exit code: 128 + the signal.
    pub fn exit_code(&self) -> u8 {
        128 + self.signal.clamp(0, 127) as u8
    }
}

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.finished {
            write!(
                f,
                "interrupted at {}; everything asked for (bag, pictures) is finished and ends there",
                self.at
            )
        } else {
            write!(
                f,
                "interrupted at {}; the run was stopped before it finished what it writes (a \
                 second signal, or an error: a bag being written stays unfinished in its hidden \
                 folder beside --record's path)",
                self.at
            )
        }
    }
}

impl std::error::Error for Interrupted {}
